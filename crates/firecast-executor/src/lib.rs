//! Remote stage execution for FireCast pipelines.
//!
//! The runner (`firecast-pipeline`) keeps the scheduler, cache keys, the lockfile and the
//! registry on the driver and hands each stage that must run to a
//! [`firecast_pipeline::StageExecutor`]. This crate provides:
//!
//! - [`cas`]: inputs and outputs travel through the artifact store (`s3://…`, or a folder
//!   every node sees), content-addressed, verified on arrival, written atomically;
//! - [`task`]: the task/result contract (JSON in the store), independent of any cluster;
//! - [`worker`]: the worker side (`firecast pipeline stage-exec`);
//! - [`driver`]: the driver side of that contract (upload inputs, write the task, bring
//!   back outputs);
//! - [`ray`]: the Ray executor, a client of Ray's Jobs REST API: one Ray job per stage
//!   run with the stage's `resources:`, bounded retries when a worker dies, a
//!   client-side pending timeout, errors that name the stage, the worker and the log.

pub mod cas;
pub mod driver;
pub mod ray;
pub mod task;
pub mod worker;

use std::path::{Path, PathBuf};

pub use ray::{RayExecutor, RayOptions};

/// Errors of remote execution. Locations (URLs, paths) come last.
#[derive(Debug, thiserror::Error)]
pub enum ExecutorError {
    #[error(transparent)]
    Store(#[from] firecast_store::StoreError),
    #[error(transparent)]
    Pipeline(#[from] firecast_pipeline::PipelineError),
    #[error("{context}: {path}: {source}")]
    Io {
        context: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("not valid JSON: {what}: {source}")]
    Json {
        what: String,
        #[source]
        source: serde_json::Error,
    },
    #[error("integrity check failed: {0}")]
    Integrity(String),
    #[error("not found in the artifact store: {0}")]
    Missing(String),
    #[error("Ray: {0}")]
    Ray(String),
    #[error("{0}")]
    Config(String),
}

impl ExecutorError {
    pub(crate) fn io(context: &'static str, path: &Path, source: std::io::Error) -> Self {
        Self::Io {
            context,
            path: path.to_path_buf(),
            source,
        }
    }
}
