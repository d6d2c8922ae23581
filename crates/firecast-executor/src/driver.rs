//! The driver side of the task contract, shared by every remote executor: upload a
//! job's inputs by content, write its task, and turn a worker's result back into the
//! job's temporary outputs.

use firecast_pipeline::StageJob;
use firecast_pipeline::executor::JobOutcome;
use firecast_store::ArtifactStore;

use crate::ExecutorError;
use crate::cas;
use crate::task::{FIRECAST_VERSION, TASK_SCHEMA, TaskInput, TaskResult, TaskSpec, put_json, task_key};

/// Upload the job's inputs (objects already in the store are not sent again) and write
/// `remote/<run>/task.json`. Returns the task's key.
pub fn prepare(store: &ArtifactStore, job: &StageJob<'_>) -> Result<String, ExecutorError> {
    let mut inputs = std::collections::BTreeMap::new();
    for (name, list) in &job.inputs {
        let mut out = Vec::new();
        for input in list {
            let stored = cas::put_path(store, &input.local, job.hashes)?;
            if stored.content != input.content {
                return Err(ExecutorError::Integrity(format!(
                    "input `{name}` changed since it was hashed: {}",
                    input.local.display()
                )));
            }
            out.push(TaskInput {
                rel: input.rel.to_string_lossy().to_string(),
                stored,
            });
        }
        inputs.insert(name.clone(), out);
    }
    let task = TaskSpec {
        schema: TASK_SCHEMA.into(),
        firecast_version: FIRECAST_VERSION.into(),
        pipeline: job.pipeline.to_string(),
        stage: job.stage.name.clone(),
        kind: job.stage.kind.clone(),
        kind_version: job.stage.kind_version,
        params: job.stage.params.clone(),
        run_id: job.run_id.to_string(),
        cache_key: job.cache_key.to_string(),
        inputs,
        outputs: job
            .final_outputs
            .iter()
            .map(|(k, v)| (k.clone(), v.to_string_lossy().to_string()))
            .collect(),
        jobs: job.jobs,
    };
    let key = task_key(job.run_id);
    put_json(store, &key, &task)?;
    Ok(key)
}

/// Download a successful result's outputs to the job's temporary paths (checked against
/// their hashes) and return what the stage reported.
pub fn collect(
    store: &ArtifactStore,
    job: &StageJob<'_>,
    result: TaskResult,
    worker: String,
) -> Result<JobOutcome, ExecutorError> {
    for (name, tmp) in job.tmp_outputs {
        let stored = result
            .outputs
            .get(name)
            .ok_or_else(|| ExecutorError::Integrity(format!("the worker's result lacks output `{name}`")))?;
        firecast_fs::remove_path(tmp);
        if let Some(parent) = tmp.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|e| ExecutorError::io("cannot create folder", parent, e))?;
        }
        if let Err(e) = cas::get_path(store, stored, tmp) {
            firecast_fs::remove_path(tmp);
            return Err(e);
        }
    }
    Ok(JobOutcome {
        log: result.log,
        warnings: result.warnings,
        events: result.events,
        pending_artifacts: result.pending_artifacts,
        worker: Some(worker),
    })
}
