//! Integration tests that drive the real `firecast` binary, one test binary for the
//! whole CLI (link time matters with this dependency stack).
#![allow(clippy::unwrap_used)]

mod dataset;
mod dvc;
mod forecast;
mod landscape;
mod pipeline;
mod ray;
mod recordings;
mod registry;
mod report;
mod rl;
mod serve;
mod sim;
mod store;

use std::collections::BTreeMap;
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

/// The run id of a pipeline report's first stage.
pub fn first_stage_run_id(report: &serde_json::Value) -> &str {
    report["stages"][0]["run_id"].as_str().unwrap()
}

/// The entry of stage `name` in a `pipeline run --json` report.
pub fn stage_report<'a>(report: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    report["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["stage"] == name)
        .unwrap_or_else(|| panic!("no stage `{name}` in {report}"))
}

/// A stage run's log (`.firecast/logs/<run>.log`).
pub fn stage_log(p: &Project, run_id: &str) -> String {
    p.read(&format!(".firecast/logs/{run_id}.log"))
}

/// The lockfile without run ids (they differ between any two runs).
pub fn lock_without_run_ids(p: &Project, file: &str) -> String {
    p.read(file)
        .lines()
        .filter(|l| !l.trim_start().starts_with("run_id:"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// What a stage run recorded, from `runs show`: metric key → (count, last, min, max), and
/// artifact name → hash (the `metrics` recording aside: it differs between any two runs).
/// Keys ending in `_seconds` (wall-clock times) keep only their count.
pub fn recorded(p: &Project, run_id: &str) -> (BTreeMap<String, [f64; 4]>, BTreeMap<String, String>) {
    let shown = p.json(&["runs", "show", run_id]);
    let metrics = shown["metrics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            let key = m["key"].as_str().unwrap().to_string();
            let count = m["count"].as_f64().unwrap();
            let values = if key.ends_with("_seconds") {
                [count, 0.0, 0.0, 0.0]
            } else {
                [
                    count,
                    m["last"].as_f64().unwrap(),
                    m["min"].as_f64().unwrap(),
                    m["max"].as_f64().unwrap(),
                ]
            };
            (key, values)
        })
        .collect();
    let artifacts = shown["artifacts"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["name"] != "metrics")
        .map(|a| {
            (
                a["name"].as_str().unwrap().to_string(),
                a["hash"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    (metrics, artifacts)
}

/// Every file under `dir` (relative path → bytes).
pub fn files_under(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut found = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path.strip_prefix(dir).unwrap().to_string_lossy().to_string();
                found.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    found
}
