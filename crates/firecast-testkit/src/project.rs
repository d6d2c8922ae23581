//! A scratch project folder and the real `firecast` binary run in it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh project folder with a `pipelines/` subfolder, removed when dropped.
pub struct Project {
    pub dir: tempfile::TempDir,
}

impl Default for Project {
    fn default() -> Self {
        Self::new()
    }
}

/// The `firecast` binary cargo built beside the running test (`target/<profile>/firecast`;
/// tests run from `target/<profile>/deps/`), as assert_cmd finds a crate's binaries.
pub fn firecast_bin() -> PathBuf {
    let exe = std::env::current_exe().expect("the test's own path");
    let profile = exe
        .parent()
        .and_then(Path::parent)
        .expect("a test binary under target/<profile>/deps");
    let bin = profile.join(format!("firecast{}", std::env::consts::EXE_SUFFIX));
    assert!(
        bin.is_file(),
        "{} is missing: the `firecast` binary is built for the root package's integration tests",
        bin.display()
    );
    bin
}

impl Project {
    pub fn new() -> Self {
        let dir = tempfile::tempdir().expect("a temporary folder");
        std::fs::create_dir_all(dir.path().join("pipelines")).expect("pipelines/");
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
        std::fs::create_dir_all(path.parent().expect("a parent folder")).expect("a folder");
        std::fs::write(&path, text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }

    pub fn read(&self, rel: &str) -> String {
        std::fs::read_to_string(self.path(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
    }

    /// `firecast` in this project, without progress bars or inherited settings.
    pub fn firecast(&self) -> Command {
        let mut cmd = Command::new(firecast_bin());
        cmd.current_dir(self.root())
            .env_remove("FIRECAST_REGISTRY")
            .env_remove("FIRECAST_STORE")
            .env_remove("FIRECAST_RERUN_CONNECT")
            .arg("--no-progress");
        cmd
    }

    /// Runs `firecast ARGS` and returns its output, failing the test if it failed.
    pub fn ok(&self, args: &[&str]) -> Output {
        let out = self.firecast().args(args).output().expect("running firecast");
        assert!(
            out.status.success(),
            "firecast {args:?} failed:\n{}",
            describe(&out)
        );
        out
    }

    /// Runs `firecast --json ARGS` and parses what it printed.
    pub fn json(&self, args: &[&str]) -> serde_json::Value {
        let mut full = vec!["--json"];
        full.extend_from_slice(args);
        let out = self.ok(&full);
        serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("not JSON ({e}):\n{}", describe(&out)))
    }

    /// `pipeline run --json`, returning stage name → outcome.
    pub fn run_pipeline(&self, file: &str, extra: &[&str]) -> std::collections::BTreeMap<String, String> {
        let mut args = vec!["pipeline", "run", file];
        args.extend_from_slice(extra);
        outcomes(&self.json(&args))
    }
}

/// Stage name → outcome of a `pipeline run --json` report.
pub fn outcomes(report: &serde_json::Value) -> std::collections::BTreeMap<String, String> {
    report["stages"]
        .as_array()
        .expect("a pipeline report lists its stages")
        .iter()
        .map(|s| {
            (
                s["stage"].as_str().expect("a stage name").to_string(),
                s["outcome"].as_str().expect("an outcome").to_string(),
            )
        })
        .collect()
}

/// A process's status, stdout and stderr, for failure messages.
pub fn describe(out: &Output) -> String {
    format!(
        "status: {}\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}
