//! Where a stage's work runs. The runner keeps scheduling, cache keys, the lockfile and
//! the registry; an executor only turns one resolved stage (its inputs as local files
//! with content hashes, its temporary output paths) into filled output paths.
//!
//! - [`invoke`] runs a kind in this process (the local executor, and a remote worker);
//! - a [`StageExecutor`] runs it elsewhere (`firecast-executor` ships it to Ray) and
//!   brings the outputs back to the temporary paths. What the stage reported to the
//!   registry on the worker comes back as [`ObservedEvent`]s the runner replays.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use crate::error::StageError;
use crate::hash::{ContentHash, HashCache};
use crate::observer::{DatasetRecord, ObserverError, RunObserver};
use crate::plan::PlannedStage;
use crate::stage::{PendingArtifact, SHARD_OUTPUT, Shard, StageContext, StageKind};

/// What a stage reported to the registry while it ran somewhere else.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum ObservedEvent {
    Metric {
        key: String,
        step: i64,
        value: f64,
    },
    Artifact {
        name: String,
        uri: String,
        hash: String,
        size: u64,
    },
    Dataset {
        record: DatasetRecord,
    },
}

impl ObservedEvent {
    /// Hand the event to the driver's observer under `run_id`.
    pub fn replay(&self, observer: &dyn RunObserver, run_id: &str) -> Result<(), ObserverError> {
        match self {
            Self::Metric { key, step, value } => observer.metric(run_id, key, *step, *value),
            Self::Artifact {
                name,
                uri,
                hash,
                size,
            } => observer.artifact(run_id, name, uri, hash, *size),
            Self::Dataset { record } => observer.dataset(run_id, record),
        }
    }
}

/// An observer that keeps the metrics, artifacts and datasets a stage reports (on a
/// worker, where the registry is not).
#[derive(Debug, Default)]
pub struct RecordingObserver {
    events: Mutex<Vec<ObservedEvent>>,
}

impl RecordingObserver {
    pub fn into_events(self) -> Vec<ObservedEvent> {
        self.events.into_inner().unwrap_or_else(|e| e.into_inner())
    }

    fn push(&self, event: ObservedEvent) {
        self.events.lock().unwrap_or_else(|e| e.into_inner()).push(event);
    }
}

impl RunObserver for RecordingObserver {
    fn metric(&self, _run_id: &str, key: &str, step: i64, value: f64) -> Result<(), ObserverError> {
        self.push(ObservedEvent::Metric {
            key: key.to_string(),
            step,
            value,
        });
        Ok(())
    }
    fn artifact(
        &self,
        _run_id: &str,
        name: &str,
        uri: &str,
        hash: &str,
        size: u64,
    ) -> Result<(), ObserverError> {
        self.push(ObservedEvent::Artifact {
            name: name.to_string(),
            uri: uri.to_string(),
            hash: hash.to_string(),
            size,
        });
        Ok(())
    }
    fn dataset(&self, _run_id: &str, dataset: &DatasetRecord) -> Result<(), ObserverError> {
        self.push(ObservedEvent::Dataset {
            record: dataset.clone(),
        });
        Ok(())
    }
}

/// Everything needed to run a kind once in this process.
pub struct Invocation<'a> {
    pub stage: &'a str,
    pub run_id: &'a str,
    /// Relative paths (inputs, outputs) resolve against it.
    pub root: &'a Path,
    pub params: &'a serde_json::Value,
    pub inputs: &'a BTreeMap<String, Vec<PathBuf>>,
    /// Where the kind writes each output (temporary names).
    pub outputs: &'a BTreeMap<String, PathBuf>,
    /// Where each output will be once published, relative to the root.
    pub final_outputs: &'a BTreeMap<String, PathBuf>,
    pub progress: &'a indicatif::MultiProgress,
    pub observer: &'a dyn RunObserver,
    pub store: Option<&'a firecast_store::ArtifactStore>,
    pub jobs: usize,
    /// Run this shard of a sharded kind (its one output is `SHARD_OUTPUT`).
    pub shard: Option<Shard>,
}

/// What one invocation produced besides its outputs.
#[derive(Debug, Default)]
pub struct InvocationReport {
    pub log: Vec<String>,
    pub warnings: Vec<String>,
    pub pending_artifacts: Vec<PendingArtifact>,
}

/// Run `kind` (the shard `inv.shard` of it, when set) and check it wrote every declared
/// output. The report is returned also when the stage failed (its log explains why).
pub fn invoke(kind: &dyn StageKind, inv: &Invocation<'_>) -> (Result<(), StageError>, InvocationReport) {
    let work = match inv.shard {
        None => Work::Stage,
        Some(shard) => Work::Shard(shard),
    };
    invoke_work(kind, inv, work)
}

/// Merge the parts of a sharded stage (shard 0 first) into `inv.outputs`, with the stage's
/// context: what the merge logs, the metrics and artifacts it reports come back in the
/// report and the observer, as from [`invoke`].
pub fn invoke_merge(
    kind: &dyn StageKind,
    inv: &Invocation<'_>,
    parts: &[PathBuf],
) -> (Result<(), StageError>, InvocationReport) {
    invoke_work(kind, inv, Work::Merge(parts))
}

/// What one invocation does.
enum Work<'p> {
    Stage,
    Shard(Shard),
    Merge(&'p [PathBuf]),
}

fn invoke_work(
    kind: &dyn StageKind,
    inv: &Invocation<'_>,
    work: Work<'_>,
) -> (Result<(), StageError>, InvocationReport) {
    let log = Mutex::new(Vec::new());
    let warnings = Mutex::new(Vec::new());
    let pending = Mutex::new(Vec::new());
    let result = {
        let mut ctx = StageContext {
            stage: inv.stage,
            run_id: inv.run_id,
            root: inv.root,
            params: inv.params,
            inputs: inv.inputs,
            outputs: inv.outputs,
            final_outputs: inv.final_outputs,
            progress: inv.progress,
            observer: inv.observer,
            store: inv.store,
            log: &log,
            warnings: &warnings,
            pending_artifacts: &pending,
            jobs: inv.jobs,
            shard: match work {
                Work::Shard(shard) => Some(shard),
                Work::Stage | Work::Merge(_) => None,
            },
        };
        let cannot = || StageError::msg(format!("stage kind `{}` cannot be sharded", kind.name()));
        // A panicking stage is a failed stage, not a runner waiting for ever on its result.
        let ran = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match work {
            Work::Stage => kind.run(&mut ctx),
            Work::Shard(shard) => match kind.sharded() {
                Some(sharded) => sharded.run_shard(&mut ctx, shard),
                None => Err(cannot()),
            },
            Work::Merge(parts) => match kind.sharded() {
                Some(sharded) => sharded.merge(&mut ctx, parts),
                None => Err(cannot()),
            },
        }))
        .unwrap_or_else(|payload| {
            let what = payload
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| payload.downcast_ref::<&str>().copied())
                .unwrap_or("unknown panic");
            Err(StageError::msg(format!("the stage panicked: {what}")))
        });
        ran.and_then(|()| {
            for (name, tmp) in inv.outputs {
                if !tmp.exists() {
                    let shown = inv
                        .final_outputs
                        .get(name)
                        .map_or_else(|| tmp.display().to_string(), |p| p.display().to_string());
                    return Err(StageError::msg(format!(
                        "stage finished but did not write output `{name}` ({shown})"
                    )));
                }
            }
            Ok(())
        })
    };
    (
        result,
        InvocationReport {
            log: into_inner(log),
            warnings: into_inner(warnings),
            pending_artifacts: into_inner(pending),
        },
    )
}

/// Run every shard of a sharded stage here, one after the other, and merge the parts
/// into `inv.outputs`. Parts live in `parts_dir` (removed afterwards).
pub fn invoke_sharded(
    kind: &dyn StageKind,
    inv: &Invocation<'_>,
    count: u32,
    parts_dir: &Path,
) -> (Result<(), StageError>, InvocationReport) {
    let mut total = InvocationReport::default();
    let result = (|| {
        if kind.sharded().is_none() {
            return Err(StageError::msg(format!(
                "stage kind `{}` cannot be sharded",
                kind.name()
            )));
        }
        firecast_fs::remove_path(parts_dir);
        std::fs::create_dir_all(parts_dir)?;
        let mut parts = Vec::new();
        for index in 0..count {
            let shard = Shard { index, count };
            let part = parts_dir.join(format!("{index}.part"));
            let outputs = BTreeMap::from([(SHARD_OUTPUT.to_string(), part.clone())]);
            let finals = BTreeMap::from([(
                SHARD_OUTPUT.to_string(),
                PathBuf::from(format!("shard-{index}.part")),
            )]);
            let (result, report) = invoke(
                kind,
                &Invocation {
                    outputs: &outputs,
                    final_outputs: &finals,
                    shard: Some(shard),
                    ..*inv
                },
            );
            total.log.push(format!("# shard {shard}"));
            total.absorb(report);
            result.map_err(|e| StageError::msg(format!("shard {shard}: {e}")))?;
            parts.push(part);
        }
        let (result, report) = invoke_merge(kind, &Invocation { shard: None, ..*inv }, &parts);
        total.log.push(format!("# merged {count} shards"));
        total.absorb(report);
        result
    })();
    firecast_fs::remove_path(parts_dir);
    (result, total)
}

impl InvocationReport {
    /// Append another invocation's log, warnings and artifacts (a shard's, the merge's).
    pub fn absorb(&mut self, other: InvocationReport) {
        self.log.extend(other.log);
        self.warnings.extend(other.warnings);
        self.pending_artifacts.extend(other.pending_artifacts);
    }
}

fn into_inner<T>(m: Mutex<Vec<T>>) -> Vec<T> {
    m.into_inner().unwrap_or_else(|e| e.into_inner())
}

/// One input file or folder of a job.
#[derive(Debug, Clone)]
pub struct JobInput {
    /// Where it is on the driver.
    pub local: PathBuf,
    /// Where to place it relative to the worker's root (the same relative path as on the
    /// driver, so what a stage derives from paths stays the same).
    pub rel: PathBuf,
    pub content: ContentHash,
}

/// One stage run handed to an executor.
pub struct StageJob<'a> {
    pub pipeline: &'a str,
    pub stage: &'a PlannedStage,
    /// The stage's kind on the driver (sharded stages merge here).
    pub kind: &'a dyn StageKind,
    pub run_id: &'a str,
    pub cache_key: &'a str,
    pub root: &'a Path,
    pub inputs: BTreeMap<String, Vec<JobInput>>,
    /// Temporary paths (on the driver) the executor must fill, one per output.
    pub tmp_outputs: &'a BTreeMap<String, PathBuf>,
    /// Final output paths relative to the root.
    pub final_outputs: &'a BTreeMap<String, PathBuf>,
    pub hashes: &'a HashCache,
    pub jobs: usize,
}

/// What came back from a job that succeeded (its outputs are at the temporary paths).
#[derive(Debug, Default)]
pub struct JobOutcome {
    pub log: Vec<String>,
    pub warnings: Vec<String>,
    pub events: Vec<ObservedEvent>,
    pub pending_artifacts: Vec<PendingArtifact>,
    /// Where it ran, e.g. `ray job firecast-…, node 10.0.0.3, pid 4242`.
    pub worker: Option<String>,
}

/// A job that did not succeed: a message naming the cause (and the worker when known)
/// and the stage's log as far as it got.
#[derive(Debug)]
pub struct JobFailure {
    pub message: String,
    pub log: Vec<String>,
}

/// Runs stages somewhere other than this process.
pub trait StageExecutor: Send + Sync {
    /// For reports, e.g. `ray at http://127.0.0.1:8265`.
    fn describe(&self) -> String;
    /// Run one stage; on success every `job.tmp_outputs` path exists and is complete.
    fn run(&self, job: &StageJob<'_>) -> Result<JobOutcome, JobFailure>;
}
