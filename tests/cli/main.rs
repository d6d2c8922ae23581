//! Integration tests that drive the real `firecast` binary, one test binary for the
//! whole CLI (link time matters with this dependency stack).
#![allow(clippy::unwrap_used)]

mod dataset;
mod dvc;
mod forecast;
mod pipeline;
mod ray;
mod recordings;
mod registry;
mod report;
mod rl;
mod sim;
mod store;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh project folder with a `pipelines/` subfolder.
pub struct Project {
    pub dir: tempfile::TempDir,
}

impl Default for Project {
    fn default() -> Self {
        Self::new()
    }
}

impl Project {
    pub fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("pipelines")).unwrap();
        Self { dir }
    }

    pub fn root(&self) -> &Path {
        self.dir.path()
    }

    pub fn path(&self, rel: &str) -> PathBuf {
        self.root().join(rel)
    }

    pub fn write(&self, rel: &str, text: &str) {
        let path = self.path(rel);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }

    pub fn read(&self, rel: &str) -> String {
        std::fs::read_to_string(self.path(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
    }

    /// `firecast` in this project, without progress bars or inherited settings.
    pub fn firecast(&self) -> Command {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_firecast"));
        cmd.current_dir(self.root())
            .env_remove("FIRECAST_REGISTRY")
            .env_remove("FIRECAST_STORE")
            .env_remove("FIRECAST_RERUN_CONNECT")
            .arg("--no-progress");
        cmd
    }

    /// Run and return output, asserting the exit status.
    pub fn ok(&self, args: &[&str]) -> Output {
        let out = self.firecast().args(args).output().unwrap();
        assert!(
            out.status.success(),
            "firecast {args:?} failed:\n{}",
            describe(&out)
        );
        out
    }

    pub fn json(&self, args: &[&str]) -> serde_json::Value {
        let mut full = vec!["--json"];
        full.extend_from_slice(args);
        let out = self.ok(&full);
        serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("not JSON ({e}):\n{}", describe(&out)))
    }

    /// `pipeline run --json`, returning stage name -> outcome.
    pub fn run_pipeline(&self, file: &str, extra: &[&str]) -> std::collections::BTreeMap<String, String> {
        let mut args = vec!["pipeline", "run", file];
        args.extend_from_slice(extra);
        outcomes(&self.json(&args))
    }
}

pub fn outcomes(report: &serde_json::Value) -> std::collections::BTreeMap<String, String> {
    report["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                s["stage"].as_str().unwrap().to_string(),
                s["outcome"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

pub fn describe(out: &Output) -> String {
    format!(
        "status: {}\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// The repository root (for the committed pipelines and dvc.yaml).
pub fn repo_root() -> PathBuf {
    // `cargo test` sets it at run time; the compiled-in value may name another clone that
    // shared the target directory.
    std::env::var_os("CARGO_MANIFEST_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")))
}

/// The project's Python (from `cargo xtask setup`).
pub fn venv_bin(name: &str) -> PathBuf {
    repo_root().join(".venv/bin").join(name)
}
