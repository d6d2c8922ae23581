//! What the runner tells the outside world: the run registry implements this trait
//! (in `firecast-registry`), so this crate does not depend on DuckDB.

use std::collections::BTreeMap;

use serde::Serialize;

/// Boxed error of an observer; the runner reports it and carries on.
pub type ObserverError = Box<dyn std::error::Error + Send + Sync>;

/// One invocation of `firecast pipeline run`.
#[derive(Debug, Clone, Serialize)]
pub struct PipelineRunInfo {
    pub run_id: String,
    pub pipeline: String,
    pub file: String,
    /// Resolved vars and the `-S` overrides given.
    pub params: serde_json::Value,
    pub git_commit: Option<String>,
    pub started_at: chrono::DateTime<chrono::Utc>,
}

/// A stage about to execute.
#[derive(Debug, Clone, Serialize)]
pub struct StageRunInfo {
    pub run_id: String,
    pub pipeline_run_id: String,
    /// The previous run of the same stage, when this one re-runs it.
    pub parent_run_id: Option<String>,
    pub pipeline: String,
    pub stage: String,
    pub kind: String,
    pub kind_version: u32,
    pub params: serde_json::Value,
    pub cache_key: String,
    pub git_commit: Option<String>,
    pub started_at: chrono::DateTime<chrono::Utc>,
}

/// How a stage run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RunStatus {
    Running,
    Succeeded,
    Failed,
    /// Outputs restored from the run-cache instead of executing.
    Restored,
}

impl RunStatus {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Running => "running",
            Self::Succeeded => "succeeded",
            Self::Failed => "failed",
            Self::Restored => "restored",
        }
    }
}

/// A file read or written by a run (lineage).
#[derive(Debug, Clone, Serialize)]
pub struct LineageRecord {
    /// `input` or `output`.
    pub direction: &'static str,
    pub name: String,
    pub uri: String,
    pub hash: String,
    pub size: u64,
}

/// A versioned dataset a stage produced.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct DatasetRecord {
    pub name: String,
    /// Content hash of data and config.
    pub version: String,
    pub schema_json: String,
    pub rows: u64,
    pub location: String,
    pub metadata: BTreeMap<String, String>,
}

/// Receives the life of a pipeline run. Every method may fail; the runner reports
/// such failures in its summary and does not stop the pipeline for them.
pub trait RunObserver: Send + Sync {
    fn pipeline_started(&self, _run: &PipelineRunInfo) -> Result<(), ObserverError> {
        Ok(())
    }
    fn pipeline_finished(
        &self,
        _run_id: &str,
        _status: RunStatus,
        _ended_at: chrono::DateTime<chrono::Utc>,
    ) -> Result<(), ObserverError> {
        Ok(())
    }
    fn stage_started(&self, _run: &StageRunInfo) -> Result<(), ObserverError> {
        Ok(())
    }
    fn stage_finished(
        &self,
        _run_id: &str,
        _status: RunStatus,
        _ended_at: chrono::DateTime<chrono::Utc>,
        _error: Option<&str>,
    ) -> Result<(), ObserverError> {
        Ok(())
    }
    fn metric(&self, _run_id: &str, _key: &str, _step: i64, _value: f64) -> Result<(), ObserverError> {
        Ok(())
    }
    fn artifact(
        &self,
        _run_id: &str,
        _name: &str,
        _uri: &str,
        _hash: &str,
        _size: u64,
    ) -> Result<(), ObserverError> {
        Ok(())
    }
    fn dataset(&self, _run_id: &str, _dataset: &DatasetRecord) -> Result<(), ObserverError> {
        Ok(())
    }
    fn lineage(&self, _run_id: &str, _record: &LineageRecord) -> Result<(), ObserverError> {
        Ok(())
    }
}

/// An observer that records nothing (tests, `--no-registry`).
#[derive(Debug, Default)]
pub struct NoObserver;

impl RunObserver for NoObserver {}
