//! Executes a plan: independent stages in parallel (bounded by `--jobs`), each stage
//! skipped when its cache key matches the lockfile and its outputs are intact,
//! restored from the run-cache when an earlier run with the same key exists, and
//! otherwise run with outputs written to temporary names and moved into place only
//! on success.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

use serde::Serialize;

use crate::error::{PipelineError, StageError};
use crate::executor::{Invocation, JobInput, StageExecutor, StageJob};
use crate::hash::{ContentHash, HashCache, hash_json};
use crate::lock::{CachedOutput, LockEntry, LockFile, LockedFile, RunCache};
use crate::observer::{LineageRecord, PipelineRunInfo, RunObserver, RunStatus, StageRunInfo};
use crate::plan::{Plan, PlannedStage, Source};
use crate::stage::{PendingArtifact, StageKinds};

/// Everything a run needs besides the plan.
pub struct Engine {
    pub root: PathBuf,
    pub kinds: StageKinds,
    pub observer: Arc<dyn RunObserver>,
    pub store: Option<Arc<firecast_store::ArtifactStore>>,
    pub git_commit: Option<String>,
    /// Where stages run: `None` runs them in this process; a remote executor ships each
    /// stage that must run (up-to-date and restorable stages never leave the driver).
    pub executor: Option<Arc<dyn StageExecutor>>,
}

/// Flags of `firecast pipeline run`.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Run every selected stage even when up to date.
    pub force: bool,
    /// Decide and report, execute nothing.
    pub dry_run: bool,
    /// Stages running at once.
    pub jobs: usize,
    /// Run only these stages (names or foreach bases); their inputs must exist.
    pub only: Vec<String>,
    /// Draw progress bars (on a terminal).
    pub progress: bool,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self {
            force: false,
            dry_run: false,
            jobs: std::thread::available_parallelism().map_or(1, usize::from),
            only: Vec::new(),
            progress: true,
        }
    }
}

/// What happened to a stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// Executed successfully.
    Ran,
    /// Outputs restored from the run-cache.
    Restored,
    /// Cache key and outputs matched the lockfile.
    UpToDate,
    Failed,
    /// Not run because a stage it reads from failed.
    Skipped,
    /// Not selected by `--only`.
    NotSelected,
    /// Dry run / status: would execute.
    WouldRun,
    /// Dry run / status: would restore from the run-cache.
    WouldRestore,
}

impl Outcome {
    pub fn label(self) -> &'static str {
        match self {
            Self::Ran => "ran",
            Self::Restored => "restored",
            Self::UpToDate => "up to date",
            Self::Failed => "FAILED",
            Self::Skipped => "skipped",
            Self::NotSelected => "not selected",
            Self::WouldRun => "stale",
            Self::WouldRestore => "restorable",
        }
    }

    fn succeeded(self) -> bool {
        matches!(
            self,
            Self::Ran | Self::Restored | Self::UpToDate | Self::NotSelected
        )
    }
}

/// One line of the run report.
#[derive(Debug, Clone, Serialize)]
pub struct StageReport {
    pub stage: String,
    pub kind: String,
    pub outcome: Outcome,
    /// Why the stage ran (or would run), or why it was skipped.
    pub reasons: Vec<String>,
    pub duration_secs: f64,
    pub run_id: Option<String>,
    pub error: Option<String>,
}

/// The result of `run` or `status`.
#[derive(Debug, Clone, Serialize)]
pub struct RunReport {
    pub pipeline: String,
    pub pipeline_run_id: Option<String>,
    pub dry_run: bool,
    pub stages: Vec<StageReport>,
    /// Problems that did not stop the run (e.g. the registry refused a metric).
    pub warnings: Vec<String>,
}

impl RunReport {
    pub fn succeeded(&self) -> bool {
        self.stages
            .iter()
            .all(|s| !matches!(s.outcome, Outcome::Failed | Outcome::Skipped))
    }

    pub fn count(&self, outcome: Outcome) -> usize {
        self.stages.iter().filter(|s| s.outcome == outcome).count()
    }
}

/// Result of processing one stage in a worker.
struct Processed {
    report: StageReport,
    lock_entry: Option<LockEntry>,
    /// Output hashes now known (for downstream decisions in dry runs).
    outputs: BTreeMap<String, ContentHash>,
}

/// What `finish` needs to know about a run that succeeded.
struct FinishedRun {
    run_id: String,
    cache_key: String,
    inputs: BTreeMap<String, Vec<LockedFile>>,
    reasons: Vec<String>,
    started: Instant,
}

/// Shared, read-only state for workers.
struct RunShared<'a> {
    engine: &'a Engine,
    plan: &'a Plan,
    opts: &'a RunOptions,
    hashes: HashCache,
    run_cache: RunCache,
    pipeline_run_id: String,
    progress: indicatif::MultiProgress,
    warnings: Mutex<Vec<String>>,
    state_dir: PathBuf,
}

impl Engine {
    pub fn state_dir(&self) -> PathBuf {
        self.root.join(".firecast")
    }

    /// Which stages are stale and why, executing nothing.
    pub fn status(&self, plan: &Plan) -> Result<RunReport, PipelineError> {
        let opts = RunOptions {
            dry_run: true,
            progress: false,
            jobs: 1,
            ..RunOptions::default()
        };
        self.run(plan, &opts)
    }

    /// Run (or, with `dry_run`, evaluate) the plan.
    pub fn run(&self, plan: &Plan, opts: &RunOptions) -> Result<RunReport, PipelineError> {
        let lock_path = self.root.join(LockFile::path_for(&plan.file));
        let mut lock = LockFile::load(&lock_path, &plan.name)?;
        let state_dir = self.state_dir();
        let selected = select(plan, &opts.only)?;

        let progress = indicatif::MultiProgress::new();
        if !opts.progress || opts.dry_run {
            progress.set_draw_target(indicatif::ProgressDrawTarget::hidden());
        }
        let shared = RunShared {
            engine: self,
            plan,
            opts,
            hashes: HashCache::load(&state_dir.join("state").join("hashes.json")),
            run_cache: RunCache::new(&state_dir),
            pipeline_run_id: new_run_id(),
            progress,
            warnings: Mutex::new(Vec::new()),
            state_dir: state_dir.clone(),
        };
        if !opts.dry_run {
            let info = PipelineRunInfo {
                run_id: shared.pipeline_run_id.clone(),
                pipeline: plan.name.clone(),
                file: plan.file.display().to_string(),
                params: serde_json::json!({ "vars": plan.vars, "overrides": plan.overrides }),
                git_commit: self.git_commit.clone(),
                started_at: chrono::Utc::now(),
            };
            shared.note(
                self.observer.pipeline_started(&info),
                "pipeline run not registered",
            );
        }

        let n = plan.stages.len();
        let overall = shared.progress.add(indicatif::ProgressBar::new(n as u64));
        overall.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} {prefix} [{bar:25}] {pos}/{len} stages  {wide_msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        overall.set_prefix(plan.name.clone());
        overall.enable_steady_tick(Duration::from_millis(120));

        let mut reports: Vec<Option<StageReport>> = vec![None; n];
        let mut known_outputs: Vec<Option<BTreeMap<String, ContentHash>>> = vec![None; n];
        let mut started = vec![false; n];
        let mut running: BTreeSet<usize> = BTreeSet::new();
        let jobs = opts.jobs.max(1);

        std::thread::scope(|scope| -> Result<(), PipelineError> {
            let (tx, rx) = mpsc::channel::<(usize, Result<Processed, PipelineError>)>();
            loop {
                // Start every stage whose upstream is settled, up to `jobs` at once.
                for i in 0..n {
                    if started[i] || running.len() >= jobs {
                        continue;
                    }
                    let stage = &plan.stages[i];
                    if stage.upstream.iter().any(|&u| reports[u].is_none()) {
                        continue;
                    }
                    started[i] = true;
                    if let Some(&bad) = stage.upstream.iter().find(|&&u| {
                        reports[u]
                            .as_ref()
                            .is_some_and(|r| !r.outcome.succeeded() && !is_dry(r.outcome))
                    }) {
                        reports[i] = Some(skipped_report(
                            stage,
                            Outcome::Skipped,
                            format!("upstream stage `{}` did not succeed", plan.stages[bad].name),
                        ));
                        overall.inc(1);
                        continue;
                    }
                    if !selected.contains(&i) {
                        reports[i] = Some(skipped_report(
                            stage,
                            Outcome::NotSelected,
                            "not selected by --only".into(),
                        ));
                        overall.inc(1);
                        continue;
                    }
                    // Upstream that will (re)run in a dry run: this stage's inputs are unknown.
                    let pending: Vec<&str> = stage
                        .upstream
                        .iter()
                        .filter(|&&u| {
                            reports[u]
                                .as_ref()
                                .is_some_and(|r| r.outcome == Outcome::WouldRun)
                        })
                        .map(|&u| plan.stages[u].name.as_str())
                        .collect();
                    if !pending.is_empty() {
                        let mut report = skipped_report(stage, Outcome::WouldRun, String::new());
                        report.reasons = pending
                            .iter()
                            .map(|p| format!("upstream `{p}` will run"))
                            .collect();
                        reports[i] = Some(report);
                        overall.inc(1);
                        continue;
                    }
                    let upstream_outputs: BTreeMap<usize, BTreeMap<String, ContentHash>> = stage
                        .upstream
                        .iter()
                        .filter_map(|&u| known_outputs[u].clone().map(|o| (u, o)))
                        .collect();
                    let previous = lock.stages.get(&stage.name).cloned();
                    let tx = tx.clone();
                    let shared = &shared;
                    running.insert(i);
                    overall.set_message(running_message(plan, &running));
                    scope.spawn(move || {
                        let result = shared.process(i, previous.as_ref(), &upstream_outputs);
                        let _ignored = tx.send((i, result));
                    });
                }
                if running.is_empty() {
                    break;
                }
                let Ok((i, result)) = rx.recv() else { break };
                running.remove(&i);
                overall.inc(1);
                overall.set_message(running_message(plan, &running));
                let processed = match result {
                    Ok(p) => p,
                    Err(e) => Processed {
                        report: StageReport {
                            stage: plan.stages[i].name.clone(),
                            kind: plan.stages[i].kind.clone(),
                            outcome: Outcome::Failed,
                            reasons: Vec::new(),
                            duration_secs: 0.0,
                            run_id: None,
                            error: Some(e.to_string()),
                        },
                        lock_entry: None,
                        outputs: BTreeMap::new(),
                    },
                };
                if processed.report.outcome == Outcome::Failed {
                    overall.println(format!(
                        "stage `{}` failed: {}",
                        processed.report.stage,
                        processed.report.error.as_deref().unwrap_or("")
                    ));
                }
                if let Some(entry) = processed.lock_entry {
                    lock.stages.insert(plan.stages[i].name.clone(), entry);
                    // Saved after every stage: an interrupted run keeps what finished.
                    lock.save(&lock_path)?;
                }
                known_outputs[i] = Some(processed.outputs);
                reports[i] = Some(processed.report);
            }
            Ok(())
        })?;
        overall.finish_and_clear();

        if !opts.dry_run {
            // Forget lock entries of stages that no longer exist in the pipeline.
            let names: BTreeSet<&str> = plan.stages.iter().map(|s| s.name.as_str()).collect();
            let before = lock.stages.len();
            lock.stages.retain(|k, _| names.contains(k.as_str()));
            if lock.stages.len() != before {
                lock.save(&lock_path)?;
            }
            shared.hashes.save()?;
        }
        let stages: Vec<StageReport> = reports.into_iter().flatten().collect();
        let report = RunReport {
            pipeline: plan.name.clone(),
            pipeline_run_id: (!opts.dry_run).then(|| shared.pipeline_run_id.clone()),
            dry_run: opts.dry_run,
            stages,
            warnings: Vec::new(),
        };
        if !opts.dry_run {
            let status = if report.succeeded() {
                RunStatus::Succeeded
            } else {
                RunStatus::Failed
            };
            shared.note(
                self.observer
                    .pipeline_finished(&shared.pipeline_run_id, status, chrono::Utc::now()),
                "pipeline run end not registered",
            );
        }
        let warnings = shared.warnings.into_inner().unwrap_or_else(|e| e.into_inner());
        Ok(RunReport { warnings, ..report })
    }
}

fn is_dry(outcome: Outcome) -> bool {
    matches!(outcome, Outcome::WouldRun | Outcome::WouldRestore)
}

fn running_message(plan: &Plan, running: &BTreeSet<usize>) -> String {
    let names: Vec<&str> = running.iter().map(|&i| plan.stages[i].name.as_str()).collect();
    if names.is_empty() {
        String::new()
    } else {
        format!("running: {}", names.join(", "))
    }
}

fn skipped_report(stage: &PlannedStage, outcome: Outcome, reason: String) -> StageReport {
    StageReport {
        stage: stage.name.clone(),
        kind: stage.kind.clone(),
        outcome,
        reasons: if reason.is_empty() {
            Vec::new()
        } else {
            vec![reason]
        },
        duration_secs: 0.0,
        run_id: None,
        error: None,
    }
}

/// Indices selected by `--only` (all when empty).
fn select(plan: &Plan, only: &[String]) -> Result<BTreeSet<usize>, PipelineError> {
    if only.is_empty() {
        return Ok((0..plan.stages.len()).collect());
    }
    let mut out = BTreeSet::new();
    for name in only {
        let matches: Vec<usize> = plan
            .stages
            .iter()
            .enumerate()
            .filter(|(_, s)| s.name == *name || s.base == *name)
            .map(|(i, _)| i)
            .collect();
        if matches.is_empty() {
            let known: Vec<&str> = plan.stages.iter().map(|s| s.name.as_str()).collect();
            return Err(PipelineError::Stage {
                stage: name.clone(),
                message: format!(
                    "no such stage in `{}` (stages: {})",
                    plan.file.display(),
                    known.join(", ")
                ),
            });
        }
        out.extend(matches);
    }
    Ok(out)
}

/// A new run id: UTC time to the millisecond plus randomness from the clock and pid,
/// so ids sort by start time.
pub fn new_run_id() -> String {
    let now = chrono::Utc::now();
    let nanos = now.timestamp_nanos_opt().unwrap_or_default();
    let counter = RUN_COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let entropy = blake3::hash(format!("{nanos}:{}:{counter}", std::process::id()).as_bytes());
    format!("{}-{}", now.format("%Y%m%dT%H%M%S%3f"), &entropy.to_hex()[..6])
}

static RUN_COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

impl RunShared<'_> {
    fn note(&self, result: Result<(), crate::observer::ObserverError>, what: &str) {
        if let Err(e) = result {
            self.warnings
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push(format!("{what}: {e}"));
        }
    }

    /// Decide and (unless dry) execute one stage.
    fn process(
        &self,
        index: usize,
        previous: Option<&LockEntry>,
        upstream_outputs: &BTreeMap<usize, BTreeMap<String, ContentHash>>,
    ) -> Result<Processed, PipelineError> {
        let started = Instant::now();
        let stage = &self.plan.stages[index];
        let root = &self.engine.root;

        // Resolve every input to a local path and a content hash.
        let mut input_paths: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
        let mut input_locks: BTreeMap<String, Vec<LockedFile>> = BTreeMap::new();
        for (name, input) in &stage.inputs {
            let mut paths = Vec::new();
            let mut locks = Vec::new();
            for source in &input.sources {
                let (display, local, known) = match source {
                    Source::File { path } => (path.display().to_string(), root.join(path), None),
                    Source::Output {
                        stage: upstream,
                        output,
                    } => {
                        let j = self.plan.index_of(upstream).unwrap_or(index);
                        let path = &self.plan.stages[j].outputs[output].path;
                        // Upstream already settled this run: reuse its hash (in a dry run the
                        // file may not be restored yet).
                        let known = upstream_outputs.get(&j).and_then(|o| o.get(output)).cloned();
                        (path.display().to_string(), root.join(path), known)
                    }
                    Source::Url { url } => (url.clone(), self.fetch_url(url)?, None),
                };
                if let (Some(content), true) = (&known, self.opts.dry_run) {
                    paths.push(local);
                    locks.push(LockedFile {
                        path: display,
                        content: content.clone(),
                    });
                    continue;
                }
                if !local.exists() {
                    return Err(PipelineError::Stage {
                        stage: stage.name.clone(),
                        message: format!("input `{name}` not found: {display}"),
                    });
                }
                let content = self.hashes.hash_path(&local)?;
                paths.push(local);
                locks.push(LockedFile {
                    path: display,
                    content,
                });
            }
            input_paths.insert(name.clone(), paths);
            input_locks.insert(name.clone(), locks);
        }

        let cache_key = cache_key(stage, &input_locks);
        let mut reasons = stale_reasons(stage, previous, &cache_key, &input_locks);
        let outputs_intact = self.outputs_intact(stage, previous, &mut reasons)?;
        let up_to_date = reasons.is_empty() && outputs_intact && !stage.always_run && !self.opts.force;
        if stage.always_run {
            reasons.push("always_run is set".into());
        }
        if self.opts.force {
            reasons.push("--force".into());
        }

        let report =
            |outcome, reasons: Vec<String>, run_id: Option<String>, error: Option<String>| StageReport {
                stage: stage.name.clone(),
                kind: stage.kind.clone(),
                outcome,
                reasons,
                duration_secs: started.elapsed().as_secs_f64(),
                run_id,
                error,
            };

        if up_to_date {
            let outputs = previous
                .map(|p| {
                    p.outputs
                        .iter()
                        .map(|(k, v)| (k.clone(), v.content.clone()))
                        .collect()
                })
                .unwrap_or_default();
            return Ok(Processed {
                report: report(
                    Outcome::UpToDate,
                    Vec::new(),
                    previous.map(|p| p.run_id.clone()),
                    None,
                ),
                lock_entry: None,
                outputs,
            });
        }

        let cached = if self.opts.force || stage.always_run {
            None
        } else {
            self.run_cache.lookup(&cache_key)
        };
        if let Some(cached) = cached {
            if self.opts.dry_run {
                reasons.push("same inputs and params seen before: restorable from the run-cache".into());
                return Ok(Processed {
                    report: report(Outcome::WouldRestore, reasons, None, None),
                    lock_entry: None,
                    outputs: cached
                        .iter()
                        .map(|(k, v)| (k.clone(), v.content.clone()))
                        .collect(),
                });
            }
            return self.restore(stage, previous, cache_key, input_locks, cached, reasons, started);
        }
        if self.opts.dry_run {
            return Ok(Processed {
                report: report(Outcome::WouldRun, reasons, None, None),
                lock_entry: None,
                outputs: BTreeMap::new(),
            });
        }
        self.execute(
            stage,
            previous,
            cache_key,
            input_paths,
            input_locks,
            reasons,
            started,
        )
    }

    /// Do the recorded outputs still exist with their hashes? Adds reasons if not.
    fn outputs_intact(
        &self,
        stage: &PlannedStage,
        previous: Option<&LockEntry>,
        reasons: &mut Vec<String>,
    ) -> Result<bool, PipelineError> {
        let Some(previous) = previous else {
            return Ok(false);
        };
        let mut intact = true;
        for (name, output) in &stage.outputs {
            let local = self.engine.root.join(&output.path);
            if !local.exists() {
                reasons.push(format!("output `{name}` is missing: {}", output.path.display()));
                intact = false;
                continue;
            }
            match previous.outputs.get(name) {
                Some(recorded) if self.hashes.hash_path(&local)? == recorded.content => {}
                _ => {
                    reasons.push(format!("output `{name}` was modified: {}", output.path.display()));
                    intact = false;
                }
            }
        }
        Ok(intact)
    }

    fn fetch_url(&self, url: &str) -> Result<PathBuf, PipelineError> {
        let (base, key) = split_store_url(url);
        let store = firecast_store::ArtifactStore::open(&base, &self.engine.root)?;
        let name = key.rsplit('/').next().unwrap_or("input").to_string();
        let dest = self
            .state_dir
            .join("inputs")
            .join(&blake3::hash(url.as_bytes()).to_hex()[..16])
            .join(name);
        store.get_to_file(&key, &dest)?;
        Ok(dest)
    }

    #[allow(clippy::too_many_arguments)]
    fn restore(
        &self,
        stage: &PlannedStage,
        previous: Option<&LockEntry>,
        cache_key: String,
        input_locks: BTreeMap<String, Vec<LockedFile>>,
        cached: BTreeMap<String, CachedOutput>,
        mut reasons: Vec<String>,
        started: Instant,
    ) -> Result<Processed, PipelineError> {
        let run_id = new_run_id();
        let info = self.stage_info(stage, previous, &run_id, &cache_key);
        self.note(self.engine.observer.stage_started(&info), "run not registered");
        for (name, output) in &stage.outputs {
            let Some(entry) = cached.get(name) else {
                return Err(PipelineError::Stage {
                    stage: stage.name.clone(),
                    message: format!("run-cache entry lacks output `{name}`"),
                });
            };
            self.run_cache
                .restore(entry, &self.engine.root.join(&output.path))?;
        }
        reasons.push("restored from the run-cache".into());
        let run = FinishedRun {
            run_id,
            cache_key,
            inputs: input_locks,
            reasons,
            started,
        };
        Ok(self.finish(stage, Outcome::Restored, run, &cached))
    }

    /// The common end of a stage that ran or was restored: record lineage and the run's
    /// end, and return its report and lockfile entry.
    fn finish(
        &self,
        stage: &PlannedStage,
        outcome: Outcome,
        run: FinishedRun,
        cached: &BTreeMap<String, CachedOutput>,
    ) -> Processed {
        let mut output_locks = BTreeMap::new();
        let mut outputs = BTreeMap::new();
        for (name, entry) in cached {
            outputs.insert(name.clone(), entry.content.clone());
            output_locks.insert(
                name.clone(),
                LockedFile {
                    path: entry.path.clone(),
                    content: entry.content.clone(),
                },
            );
        }
        self.record_lineage(&run.run_id, &run.inputs, &output_locks);
        let status = if outcome == Outcome::Restored {
            RunStatus::Restored
        } else {
            RunStatus::Succeeded
        };
        self.note(
            self.engine
                .observer
                .stage_finished(&run.run_id, status, chrono::Utc::now(), None),
            "run end not registered",
        );
        Processed {
            report: StageReport {
                stage: stage.name.clone(),
                kind: stage.kind.clone(),
                outcome,
                reasons: run.reasons,
                duration_secs: run.started.elapsed().as_secs_f64(),
                run_id: Some(run.run_id.clone()),
                error: None,
            },
            lock_entry: Some(LockEntry {
                kind: stage.kind.clone(),
                kind_version: stage.kind_version,
                cache_key: run.cache_key,
                run_id: run.run_id,
                params: stage.params.clone(),
                inputs: run.inputs,
                outputs: output_locks,
            }),
            outputs,
        }
    }

    fn stage_info(
        &self,
        stage: &PlannedStage,
        previous: Option<&LockEntry>,
        run_id: &str,
        key: &str,
    ) -> StageRunInfo {
        StageRunInfo {
            run_id: run_id.to_string(),
            pipeline_run_id: self.pipeline_run_id.clone(),
            parent_run_id: previous.map(|p| p.run_id.clone()),
            pipeline: self.plan.name.clone(),
            stage: stage.name.clone(),
            kind: stage.kind.clone(),
            kind_version: stage.kind_version,
            params: stage.params.clone(),
            cache_key: key.to_string(),
            git_commit: self.engine.git_commit.clone(),
            started_at: chrono::Utc::now(),
        }
    }

    fn record_lineage(
        &self,
        run_id: &str,
        inputs: &BTreeMap<String, Vec<LockedFile>>,
        outputs: &BTreeMap<String, LockedFile>,
    ) {
        let mut records = Vec::new();
        for (name, files) in inputs {
            for f in files {
                records.push(LineageRecord {
                    direction: "input",
                    name: name.clone(),
                    uri: f.path.clone(),
                    hash: f.content.hash.clone(),
                    size: f.content.size,
                });
            }
        }
        for (name, f) in outputs {
            records.push(LineageRecord {
                direction: "output",
                name: name.clone(),
                uri: f.path.clone(),
                hash: f.content.hash.clone(),
                size: f.content.size,
            });
        }
        for record in &records {
            self.note(
                self.engine.observer.lineage(run_id, record),
                "lineage not registered",
            );
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn execute(
        &self,
        stage: &PlannedStage,
        previous: Option<&LockEntry>,
        cache_key: String,
        input_paths: BTreeMap<String, Vec<PathBuf>>,
        input_locks: BTreeMap<String, Vec<LockedFile>>,
        reasons: Vec<String>,
        started: Instant,
    ) -> Result<Processed, PipelineError> {
        let root = &self.engine.root;
        let kind = self
            .engine
            .kinds
            .get(&stage.kind)
            .ok_or_else(|| PipelineError::Stage {
                stage: stage.name.clone(),
                message: format!("unknown stage kind `{}`", stage.kind),
            })?;
        let run_id = new_run_id();
        // Temporary output names next to the final ones: the final rename is atomic.
        let mut tmp_outputs = BTreeMap::new();
        for (name, output) in &stage.outputs {
            let dest = root.join(&output.path);
            if let Some(parent) = dest.parent() {
                // Leftovers of runs whose process is gone.
                firecast_fs::remove_stale(parent);
                std::fs::create_dir_all(parent)
                    .map_err(|e| PipelineError::io("cannot create folder", parent, e))?;
            }
            tmp_outputs.insert(name.clone(), firecast_fs::temp_path(&dest));
        }

        let info = self.stage_info(stage, previous, &run_id, &cache_key);
        self.note(self.engine.observer.stage_started(&info), "run not registered");

        let final_outputs: BTreeMap<String, PathBuf> = stage
            .outputs
            .iter()
            .map(|(k, v)| (k.clone(), v.path.clone()))
            .collect();
        let spinner = self.progress.add(indicatif::ProgressBar::new_spinner());
        spinner.set_message(format!("{} ({})", stage.name, stage.kind));
        spinner.enable_steady_tick(Duration::from_millis(120));
        let (result, log, pending) = match &self.engine.executor {
            None => {
                let inv = Invocation {
                    stage: &stage.name,
                    run_id: &run_id,
                    root,
                    params: &stage.params,
                    inputs: &input_paths,
                    outputs: &tmp_outputs,
                    final_outputs: &final_outputs,
                    progress: &self.progress,
                    observer: self.engine.observer.as_ref(),
                    store: self.engine.store.as_deref(),
                    jobs: self.opts.jobs,
                    shard: None,
                };
                let (result, report) = match stage.shards {
                    Some(count) => crate::executor::invoke_sharded(
                        kind.as_ref(),
                        &inv,
                        count,
                        &self.state_dir.join("shards").join(&run_id),
                    ),
                    None => crate::executor::invoke(kind.as_ref(), &inv),
                };
                self.warnings
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .extend(report.warnings);
                (result, report.log, report.pending_artifacts)
            }
            Some(executor) => {
                let mut inputs: BTreeMap<String, Vec<JobInput>> = BTreeMap::new();
                for (name, paths) in &input_paths {
                    let locks = input_locks.get(name).map_or(&[][..], Vec::as_slice);
                    let list = paths
                        .iter()
                        .zip(locks)
                        .map(|(local, lock)| JobInput {
                            local: local.clone(),
                            rel: job_relative_path(root, local, &lock.content.hash),
                            content: lock.content.clone(),
                        })
                        .collect();
                    inputs.insert(name.clone(), list);
                }
                let job = StageJob {
                    pipeline: &self.plan.name,
                    stage,
                    kind: kind.as_ref(),
                    run_id: &run_id,
                    cache_key: &cache_key,
                    root,
                    inputs,
                    tmp_outputs: &tmp_outputs,
                    final_outputs: &final_outputs,
                    hashes: &self.hashes,
                    jobs: self.opts.jobs,
                };
                match executor.run(&job) {
                    Ok(outcome) => {
                        for event in &outcome.events {
                            self.note(
                                event.replay(self.engine.observer.as_ref(), &run_id),
                                "remote stage event not registered",
                            );
                        }
                        let mut log = outcome.log;
                        if let Some(worker) = &outcome.worker {
                            log.insert(0, format!("# ran on {worker}"));
                        }
                        self.warnings
                            .lock()
                            .unwrap_or_else(|e| e.into_inner())
                            .extend(outcome.warnings);
                        let missing = tmp_outputs.iter().find(|(_, tmp)| !tmp.exists());
                        let result = match missing {
                            Some((name, _)) => Err(StageError::msg(format!(
                                "{} reported success but output `{name}` did not come back",
                                executor.describe()
                            ))),
                            None => Ok(()),
                        };
                        (result, log, outcome.pending_artifacts)
                    }
                    Err(failure) => (Err(StageError::msg(failure.message)), failure.log, Vec::new()),
                }
            }
        };
        spinner.finish_and_clear();
        self.write_log(&run_id, &stage.name, &Mutex::new(log));

        if let Err(error) = result {
            for tmp in tmp_outputs.values() {
                firecast_fs::remove_path(tmp);
            }
            let message = error.to_string();
            self.note(
                self.engine.observer.stage_finished(
                    &run_id,
                    RunStatus::Failed,
                    chrono::Utc::now(),
                    Some(&message),
                ),
                "run end not registered",
            );
            return Ok(Processed {
                report: StageReport {
                    stage: stage.name.clone(),
                    kind: stage.kind.clone(),
                    outcome: Outcome::Failed,
                    reasons,
                    duration_secs: started.elapsed().as_secs_f64(),
                    run_id: Some(run_id),
                    error: Some(message),
                },
                lock_entry: None,
                outputs: BTreeMap::new(),
            });
        }

        // Publish: move every output into place, then hash and cache the final files.
        let mut finals = BTreeMap::new();
        for (name, tmp) in &tmp_outputs {
            let output = &stage.outputs[name];
            let dest = root.join(&output.path);
            firecast_fs::publish(tmp, &dest)?;
            finals.insert(name.clone(), (dest, output.path.display().to_string()));
        }
        let cached = self.run_cache.save(&cache_key, &finals, &self.hashes)?;
        for (name, output) in &stage.outputs {
            if output.artifact {
                self.publish_artifact(&run_id, name, &root.join(&output.path));
            }
        }
        self.publish_pending(stage, &run_id, &pending);
        let run = FinishedRun {
            run_id,
            cache_key,
            inputs: input_locks,
            reasons,
            started,
        };
        Ok(self.finish(stage, Outcome::Ran, run, &cached))
    }

    fn publish_artifact(&self, run_id: &str, name: &str, path: &Path) {
        let Some(store) = self.engine.store.as_deref() else {
            self.note(
                Err("no artifact store is configured".into()),
                &format!("artifact `{name}`"),
            );
            return;
        };
        let mut files = Vec::new();
        if path.is_dir() {
            match self.hashes.manifest(path) {
                Ok(m) => files.extend(
                    m.into_iter()
                        .map(|e| (path.join(&e.path), format!("{name}/{}", e.path))),
                ),
                Err(e) => self.note(Err(e.to_string().into()), &format!("artifact `{name}`")),
            }
        } else {
            let file_name = path
                .file_name()
                .map_or_else(|| name.to_string(), |n| n.to_string_lossy().to_string());
            files.push((path.to_path_buf(), format!("{name}/{file_name}")));
        }
        for (file, rel) in files {
            let key = format!("runs/{run_id}/{rel}");
            match store.put_file(&key, &file) {
                Ok(stored) => self.note(
                    self.engine
                        .observer
                        .artifact(run_id, name, &stored.uri, &stored.hash, stored.size),
                    "artifact not registered",
                ),
                Err(e) => self.note(Err(e.into()), &format!("artifact `{name}` not uploaded")),
            }
        }
    }

    /// Artifacts a stage asked for from inside its outputs, now that they are published.
    fn publish_pending(&self, stage: &PlannedStage, run_id: &str, pending: &[PendingArtifact]) {
        if pending.is_empty() {
            return;
        }
        let Some(store) = self.engine.store.as_deref() else {
            self.note(Err("no artifact store is configured".into()), "artifacts");
            return;
        };
        for artifact in pending {
            let Some(output) = stage.outputs.get(&artifact.output) else {
                continue;
            };
            let rel = artifact
                .rel
                .as_ref()
                .map_or_else(|| output.path.clone(), |r| output.path.join(r));
            let key = crate::stage::artifact_key(run_id, &artifact.name, &rel);
            match store.put_file(&key, &self.engine.root.join(&rel)) {
                Ok(stored) => self.note(
                    self.engine.observer.artifact(
                        run_id,
                        &artifact.name,
                        &stored.uri,
                        &stored.hash,
                        stored.size,
                    ),
                    "artifact not registered",
                ),
                Err(e) => self.note(
                    Err(e.into()),
                    &format!("artifact `{}` not uploaded", artifact.name),
                ),
            }
        }
    }

    fn write_log(&self, run_id: &str, stage: &str, log: &Mutex<Vec<String>>) {
        let lines = log.lock().unwrap_or_else(|e| e.into_inner());
        if lines.is_empty() {
            return;
        }
        let path = self.state_dir.join("logs").join(format!("{run_id}.log"));
        let mut text = format!("# stage {stage}, run {run_id}\n");
        for line in lines.iter() {
            text.push_str(line);
            text.push('\n');
        }
        if let Err(e) = firecast_fs::write_atomically(&path, text.as_bytes()) {
            self.note(Err(e.to_string().into()), "stage log not written");
        }
    }
}

/// Where a job input goes under the worker's root: its path relative to the project root,
/// or for a file outside it (an absolute path) `external/<hash>/<name>`.
fn job_relative_path(root: &Path, local: &Path, hash: &str) -> PathBuf {
    match local.strip_prefix(root) {
        Ok(rel) if !rel.as_os_str().is_empty() => rel.to_path_buf(),
        _ => {
            let name = local
                .file_name()
                .map_or_else(|| "input".to_string(), |n| n.to_string_lossy().to_string());
            PathBuf::from("external")
                .join(&hash[..hash.len().min(16)])
                .join(name)
        }
    }
}

/// Split `s3://bucket/a/b.csv` into the store root `s3://bucket` and key `a/b.csv`.
fn split_store_url(url: &str) -> (String, String) {
    let (scheme, rest) = url.split_once("://").unwrap_or(("file", url));
    if scheme == "file" {
        let path = Path::new(rest);
        let parent = path.parent().map(|p| p.display().to_string()).unwrap_or_default();
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        return (format!("file://{parent}"), name);
    }
    match rest.split_once('/') {
        Some((bucket, key)) => (format!("{scheme}://{bucket}"), key.to_string()),
        None => (format!("{scheme}://{rest}"), String::new()),
    }
}

/// The cache key: kind and version, resolved params, input content hashes, output paths.
pub fn cache_key(stage: &PlannedStage, inputs: &BTreeMap<String, Vec<LockedFile>>) -> String {
    let inputs: BTreeMap<&String, Vec<&str>> = inputs
        .iter()
        .map(|(k, v)| (k, v.iter().map(|f| f.content.hash.as_str()).collect()))
        .collect();
    let outputs: BTreeMap<&String, String> = stage
        .outputs
        .iter()
        .map(|(k, v)| (k, v.path.display().to_string()))
        .collect();
    hash_json(&serde_json::json!({
        "kind": stage.kind,
        "kind_version": stage.kind_version,
        "params": stage.params,
        "inputs": inputs,
        "outputs": outputs,
    }))
}

/// Human reasons a stage differs from its lockfile entry (empty when the key matches).
fn stale_reasons(
    stage: &PlannedStage,
    previous: Option<&LockEntry>,
    key: &str,
    inputs: &BTreeMap<String, Vec<LockedFile>>,
) -> Vec<String> {
    let Some(previous) = previous else {
        return vec!["never run".into()];
    };
    if previous.cache_key == key {
        return Vec::new();
    }
    let mut reasons = Vec::new();
    if previous.kind != stage.kind || previous.kind_version != stage.kind_version {
        reasons.push(format!(
            "stage kind changed: {} v{} -> {} v{}",
            previous.kind, previous.kind_version, stage.kind, stage.kind_version
        ));
    }
    let text = |m: BTreeMap<String, serde_json::Value>| -> BTreeMap<String, String> {
        m.into_iter().map(|(k, v)| (k, v.to_string())).collect()
    };
    let old = text(crate::plan::flatten_params(&previous.params));
    let new = text(crate::plan::flatten_params(&stage.params));
    let keys: BTreeSet<&String> = old.keys().chain(new.keys()).collect();
    for k in keys {
        match (old.get(k), new.get(k)) {
            (Some(a), Some(b)) if a != b => {
                reasons.push(format!("param `{k}` changed: {}", describe_change(a, b)))
            }
            (None, Some(b)) => reasons.push(format!("param `{k}` added: {b}")),
            (Some(a), None) => reasons.push(format!("param `{k}` removed (was {a})")),
            _ => {}
        }
    }
    let names: BTreeSet<&String> = previous.inputs.keys().chain(inputs.keys()).collect();
    for name in names {
        match (previous.inputs.get(name), inputs.get(name)) {
            (Some(a), Some(b)) if a != b => reasons.push(format!("input `{name}` changed")),
            (None, Some(_)) => reasons.push(format!("input `{name}` added")),
            (Some(_), None) => reasons.push(format!("input `{name}` removed")),
            _ => {}
        }
    }
    let old_outputs: BTreeMap<&String, &str> = previous
        .outputs
        .iter()
        .map(|(k, v)| (k, v.path.as_str()))
        .collect();
    let new_outputs: BTreeMap<&String, String> = stage
        .outputs
        .iter()
        .map(|(k, v)| (k, v.path.display().to_string()))
        .collect();
    if old_outputs.len() != new_outputs.len()
        || old_outputs
            .iter()
            .any(|(k, v)| new_outputs.get(k).map(String::as_str) != Some(*v))
    {
        reasons.push("declared outputs changed".into());
    }
    if reasons.is_empty() {
        reasons.push("cache key changed".into());
    }
    reasons
}

/// `old -> new`, or for long values only the part that differs, with a little context.
fn describe_change(old: &str, new: &str) -> String {
    const CONTEXT: usize = 12;
    if old.chars().count() <= 48 && new.chars().count() <= 48 {
        return format!("{old} -> {new}");
    }
    let a: Vec<char> = old.chars().collect();
    let b: Vec<char> = new.chars().collect();
    let prefix = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let suffix = a[prefix..]
        .iter()
        .rev()
        .zip(b[prefix..].iter().rev())
        .take_while(|(x, y)| x == y)
        .count();
    let start = prefix.saturating_sub(CONTEXT);
    let excerpt = |v: &[char]| {
        let end = (v.len() - suffix + CONTEXT).min(v.len());
        let body: String = v[start..end].iter().collect();
        format!(
            "{}{body}{}",
            if start > 0 { "…" } else { "" },
            if end < v.len() { "…" } else { "" }
        )
    };
    format!("{} -> {}", excerpt(&a), excerpt(&b))
}

#[cfg(test)]
mod tests {
    use super::{describe_change, split_store_url};

    #[test]
    fn long_changes_show_only_the_difference() {
        assert_eq!(describe_change("3", "5"), "3 -> 5");
        let old = "echo a,b,c,d,e,f,g,h,i,j,k,l,m,n,o,p,q,r,s,t,u,v,w,x,y,z,20,0 > out.csv";
        let new = "echo a,b,c,d,e,f,g,h,i,j,k,l,m,n,o,p,q,r,s,t,u,v,w,x,y,z,40,0 > out.csv";
        assert_eq!(
            describe_change(old, new),
            "…u,v,w,x,y,z,20,0 > out.cs… -> …u,v,w,x,y,z,40,0 > out.cs…"
        );
    }

    #[test]
    fn store_urls_split_into_root_and_key() {
        assert_eq!(
            split_store_url("s3://bucket/a/b.csv"),
            ("s3://bucket".to_string(), "a/b.csv".to_string())
        );
        assert_eq!(
            split_store_url("file:///tmp/x/y.nc"),
            ("file:///tmp/x".to_string(), "y.nc".to_string())
        );
    }
}
