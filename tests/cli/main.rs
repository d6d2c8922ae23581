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
use std::path::Path;

pub use firecast_testkit::{Project, describe, outcomes, venv_bin};

/// The repository root (for the committed pipelines and dvc.yaml).
pub fn repo_root() -> std::path::PathBuf {
    firecast_testkit::workspace_root()
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
