//! The worker side: `firecast pipeline stage-exec --task KEY --result KEY` reads a task
//! from the store, checks it can run it (same firecast version, same kind version),
//! fetches the inputs into a private folder laid out like the project, runs the kind,
//! uploads the outputs by content and writes the result last.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use firecast_pipeline::executor::{Invocation, RecordingObserver, invoke};
use firecast_pipeline::hash::HashCache;
use firecast_pipeline::stage::SHARD_OUTPUT;
use firecast_pipeline::{Shard, StageKinds};
use firecast_store::ArtifactStore;

use crate::ExecutorError;
use crate::cas;
use crate::task::{
    FIRECAST_VERSION, RESULT_SCHEMA, TASK_SCHEMA, TaskResult, TaskSpec, WorkerInfo, get_json, put_json,
};

/// How a task ended (the result is in the store either way).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WorkerExit {
    Succeeded,
    /// The stage (or the checks before it) failed; the result says why.
    StageFailed,
}

/// A folder removed when dropped.
struct WorkDir(PathBuf);

impl Drop for WorkDir {
    fn drop(&mut self) {
        firecast_fs::remove_path(&self.0);
    }
}

/// Run the task at `task_key` and write its result at `result_key`. An `Err` means no
/// result could be written (the store is unreachable or refused the write).
pub fn exec(
    kinds: &StageKinds,
    store: &ArtifactStore,
    task_key: &str,
    result_key: &str,
    scratch: &Path,
    shard: Option<Shard>,
) -> Result<WorkerExit, ExecutorError> {
    let started = Instant::now();
    let task: TaskSpec =
        get_json(store, task_key)?.ok_or_else(|| ExecutorError::Missing(store.uri_of(task_key)))?;
    let worker = WorkerInfo::here();
    let mut result = TaskResult {
        schema: RESULT_SCHEMA.into(),
        stage: task.stage.clone(),
        run_id: task.run_id.clone(),
        worker: worker.clone(),
        error: None,
        seconds: 0.0,
        log: Vec::new(),
        warnings: Vec::new(),
        events: Vec::new(),
        pending_artifacts: Vec::new(),
        outputs: BTreeMap::new(),
    };
    let outcome = run(kinds, store, &task, scratch, shard, &mut result);
    result.seconds = started.elapsed().as_secs_f64();
    let exit = match outcome {
        Ok(()) => WorkerExit::Succeeded,
        Err(message) => {
            result.error = Some(message);
            result.outputs.clear();
            WorkerExit::StageFailed
        }
    };
    put_json(store, result_key, &result)?;
    Ok(exit)
}

fn run(
    kinds: &StageKinds,
    store: &ArtifactStore,
    task: &TaskSpec,
    scratch: &Path,
    shard: Option<Shard>,
    result: &mut TaskResult,
) -> Result<(), String> {
    if task.schema != TASK_SCHEMA {
        return Err(format!(
            "task schema `{}` is not `{TASK_SCHEMA}` (driver and worker run different firecast builds)",
            task.schema
        ));
    }
    if task.firecast_version != FIRECAST_VERSION {
        return Err(format!(
            "this worker runs firecast {FIRECAST_VERSION}, the driver firecast {}: install the driver's build on every node",
            task.firecast_version
        ));
    }
    let kind = kinds
        .get(&task.kind)
        .ok_or_else(|| format!("this worker's firecast has no stage kind `{}`", task.kind))?;
    if kind.version() != task.kind_version {
        return Err(format!(
            "stage kind `{}` is version {} on this worker but {} on the driver: install the driver's build on every node",
            task.kind,
            kind.version(),
            task.kind_version
        ));
    }

    if let Some(shard) = shard {
        let sharded = kind.sharded().ok_or_else(|| {
            format!(
                "stage kind `{}` cannot be sharded (asked for shard {shard})",
                task.kind
            )
        })?;
        let units = sharded.units(&task.params).map_err(|e| e.message)?;
        if shard.count as usize > units {
            return Err(format!(
                "shard {shard}: {} shards for {units} {}",
                shard.count,
                sharded.unit_name()
            ));
        }
    }

    // Earlier attempts of this run killed on this node left their folders behind.
    // (Shards of one run may run side by side on a node: each has its own prefix.)
    let prefix = match shard {
        Some(s) => format!("firecast-task-{}-s{}-", task.run_id, s.index),
        None => format!("firecast-task-{}-", task.run_id),
    };
    if let Ok(entries) = std::fs::read_dir(scratch) {
        for entry in entries.flatten() {
            if entry.file_name().to_string_lossy().starts_with(&prefix) {
                firecast_fs::remove_path(&entry.path());
            }
        }
    }
    let work = WorkDir(scratch.join(format!("{prefix}{}", std::process::id())));
    std::fs::create_dir_all(&work.0).map_err(|e| format!("cannot create {}: {e}", work.0.display()))?;
    let root = work.0.as_path();

    // A shard fetches only the files of a folder input its kind says it reads.
    let sharded = shard.and_then(|s| kind.sharded().map(|k| (s, k)));
    let mut fetch_log = Vec::new();
    let mut inputs: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for (name, list) in &task.inputs {
        let mut paths = Vec::new();
        for input in list {
            let dest = root.join(&input.rel);
            if !dest.exists() {
                if let Some(parent) = dest.parent() {
                    std::fs::create_dir_all(parent)
                        .map_err(|e| format!("cannot create {}: {e}", parent.display()))?;
                }
                let cannot = |e: ExecutorError| format!("cannot fetch input `{name}` ({}): {e}", input.rel);
                let keep = match (sharded, &input.stored.manifest) {
                    (Some((s, k)), Some(files)) => {
                        let names: Vec<&str> = files.iter().map(|f| f.path.as_str()).collect();
                        k.shard_reads(&task.params, s, name, &names).map(|keep| (s, keep))
                    }
                    _ => None,
                };
                match keep {
                    Some((s, keep)) => {
                        let fetched =
                            cas::get_folder_files(store, &input.stored, &dest, &keep).map_err(cannot)?;
                        let files = input.stored.manifest.as_deref().unwrap_or_default();
                        let mb = |only_fetched: bool| {
                            files
                                .iter()
                                .zip(&keep)
                                .filter(|&(_, &k)| k || !only_fetched)
                                .map(|(f, _)| f.size)
                                .sum::<u64>() as f64
                                / 1e6
                        };
                        fetch_log.push(format!(
                            "shard {s}: fetched {fetched} of {} files of input `{name}` ({}, {:.1} of {:.1} MB), \
                             the rest left empty",
                            keep.len(),
                            input.rel,
                            mb(true),
                            mb(false)
                        ));
                    }
                    None => cas::get_path(store, &input.stored, &dest).map_err(cannot)?,
                }
            }
            paths.push(dest);
        }
        inputs.insert(name.clone(), paths);
    }
    let mut tmp_outputs = BTreeMap::new();
    let mut final_outputs = BTreeMap::new();
    let shard_outputs =
        shard.map(|s| BTreeMap::from([(SHARD_OUTPUT.to_string(), format!("shard-{}.part", s.index))]));
    for (name, rel) in shard_outputs.as_ref().unwrap_or(&task.outputs) {
        let dest = root.join(rel);
        if let Some(parent) = dest.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|e| format!("cannot create {}: {e}", parent.display()))?;
        }
        tmp_outputs.insert(name.clone(), firecast_fs::temp_path(&dest));
        final_outputs.insert(name.clone(), PathBuf::from(rel));
    }

    let observer = RecordingObserver::default();
    let progress = indicatif::MultiProgress::with_draw_target(indicatif::ProgressDrawTarget::hidden());
    let (outcome, report) = invoke(
        kind.as_ref(),
        &Invocation {
            stage: &task.stage,
            run_id: &task.run_id,
            root,
            params: &task.params,
            inputs: &inputs,
            outputs: &tmp_outputs,
            final_outputs: &final_outputs,
            progress: &progress,
            observer: &observer,
            store: Some(store),
            jobs: task.jobs.max(1),
            shard,
        },
    );
    result.log = fetch_log.into_iter().chain(report.log).collect();
    result.warnings = report.warnings;
    result.pending_artifacts = report.pending_artifacts;
    result.events = observer.into_events();
    outcome.map_err(|e| e.to_string())?;

    let hashes = HashCache::default();
    for (name, tmp) in &tmp_outputs {
        let stored =
            cas::put_path(store, tmp, &hashes).map_err(|e| format!("cannot upload output `{name}`: {e}"))?;
        result.outputs.insert(name.clone(), stored);
    }
    Ok(())
}
