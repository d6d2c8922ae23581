//! The task a driver hands a worker and the result the worker hands back, both JSON in
//! the artifact store:
//!
//! - `remote/<run>/task.json`: the resolved stage (kind, version, params), its inputs as
//!   content in `cas/`, where its outputs go (relative paths), the driver's version;
//! - `remote/<run>/attempt-<n>/result.json`: written last by the worker, so a worker
//!   killed at any point leaves no result and nothing that looks finished.
//!
//! Neither names Ray: a Slurm array task or a Kubernetes indexed job can run
//! `firecast pipeline stage-exec --task … --result …` the same way.

use std::collections::BTreeMap;

use firecast_pipeline::executor::ObservedEvent;
use firecast_pipeline::stage::PendingArtifact;
use firecast_store::ArtifactStore;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::ExecutorError;
use crate::cas::StoredContent;

pub const TASK_SCHEMA: &str = "firecast-task/1";
pub const RESULT_SCHEMA: &str = "firecast-task-result/1";

/// The version every worker must run (the workspace version of this build).
pub const FIRECAST_VERSION: &str = env!("CARGO_PKG_VERSION");

/// One input file or folder: where it goes under the worker's root, and its content.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskInput {
    pub rel: String,
    pub stored: StoredContent,
}

/// A stage run, resolved on the driver.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskSpec {
    pub schema: String,
    pub firecast_version: String,
    pub pipeline: String,
    pub stage: String,
    pub kind: String,
    pub kind_version: u32,
    pub params: serde_json::Value,
    pub run_id: String,
    pub cache_key: String,
    pub inputs: BTreeMap<String, Vec<TaskInput>>,
    /// Output name -> final path relative to the root.
    pub outputs: BTreeMap<String, String>,
    /// Threads the stage may use.
    pub jobs: usize,
}

/// Where and as what a task ran.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct WorkerInfo {
    pub host: String,
    pub pid: u32,
    pub firecast_version: String,
}

impl WorkerInfo {
    pub fn here() -> Self {
        Self {
            host: hostname(),
            pid: std::process::id(),
            firecast_version: FIRECAST_VERSION.to_string(),
        }
    }
}

impl std::fmt::Display for WorkerInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} pid {}", self.host, self.pid)
    }
}

/// What a worker reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskResult {
    pub schema: String,
    pub stage: String,
    pub run_id: String,
    pub worker: WorkerInfo,
    /// `None` when the stage succeeded.
    pub error: Option<String>,
    pub seconds: f64,
    pub log: Vec<String>,
    pub warnings: Vec<String>,
    pub events: Vec<ObservedEvent>,
    pub pending_artifacts: Vec<PendingArtifact>,
    /// Output name -> its content in `cas/` (empty when the stage failed).
    pub outputs: BTreeMap<String, StoredContent>,
}

pub fn task_key(run_id: &str) -> String {
    format!("remote/{run_id}/task.json")
}

pub fn result_key(run_id: &str, attempt: u32) -> String {
    format!("remote/{run_id}/attempt-{attempt}/result.json")
}

/// Write a JSON document once.
pub fn put_json<T: Serialize>(store: &ArtifactStore, key: &str, value: &T) -> Result<(), ExecutorError> {
    let bytes = serde_json::to_vec_pretty(value).map_err(|e| ExecutorError::Json {
        what: key.to_string(),
        source: e,
    })?;
    store.put_bytes(key, bytes)?;
    Ok(())
}

/// Read a JSON document; `Ok(None)` when it does not exist.
pub fn get_json<T: DeserializeOwned>(store: &ArtifactStore, key: &str) -> Result<Option<T>, ExecutorError> {
    match store.get_bytes(key) {
        Ok(bytes) => serde_json::from_slice(&bytes)
            .map(Some)
            .map_err(|e| ExecutorError::Json {
                what: store.uri_of(key),
                source: e,
            }),
        Err(firecast_store::StoreError::NotFound(_)) => Ok(None),
        Err(e) => Err(e.into()),
    }
}

fn hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "unknown-host".into())
}
