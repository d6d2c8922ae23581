//! `firecast pipeline run|status|dag|export-dvc|kinds`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context as _;
use clap::{Args, Subcommand};
use firecast_pipeline::{
    Engine, NoObserver, Outcome, Override, Plan, RunObserver, RunOptions, RunReport, StageKinds,
};

use crate::output;
use crate::settings::{ExecutorKind, Settings};

#[derive(Debug, Subcommand)]
pub enum PipelineCommand {
    /// Run a pipeline: stages whose inputs, params and outputs are unchanged are skipped.
    Run(RunArgs),
    /// Which stages are stale and why (runs nothing).
    Status(PlanArgs),
    /// Print the stage graph (text, or Graphviz with --dot).
    Dag {
        #[command(flatten)]
        plan: PlanArgs,
        /// Graphviz DOT output.
        #[arg(long)]
        dot: bool,
    },
    /// Write dvc.yaml from the pipelines so DVC users can `dvc repro` them.
    ExportDvc {
        /// Pipeline files [default: every pipelines/*.yaml].
        files: Vec<PathBuf>,
        /// Where to write.
        #[arg(long, default_value = "dvc.yaml")]
        output: PathBuf,
        /// Do not write: fail if the file is not what export would write.
        #[arg(long)]
        check: bool,
    },
    /// List the stage kinds `uses:` can name.
    Kinds,
    /// Worker entry point of remote executors: run one stage task from the artifact store
    /// and write its result there (`--executor ray` submits this as the Ray job).
    #[command(hide = true)]
    StageExec(StageExecArgs),
}

#[derive(Debug, Args)]
pub struct StageExecArgs {
    /// The task's key in the artifact store (`remote/<run>/task.json`).
    #[arg(long)]
    pub task: String,
    /// Where to write the result (`remote/<run>/attempt-<n>/result.json`).
    #[arg(long)]
    pub result: String,
    /// Where to unpack inputs and write outputs [default: the temporary folder].
    #[arg(long)]
    pub scratch: Option<PathBuf>,
    /// Run only shard INDEX/COUNT of a sharded stage (a Slurm array task passes
    /// `$SLURM_ARRAY_TASK_ID/N`, a Kubernetes indexed job `$JOB_COMPLETION_INDEX/N`).
    #[arg(long, value_name = "INDEX/COUNT", value_parser = firecast_pipeline::Shard::parse)]
    pub shard: Option<firecast_pipeline::Shard>,
}

#[derive(Debug, Args)]
pub struct PlanArgs {
    /// The pipeline file, e.g. pipelines/demo.yaml.
    pub file: PathBuf,
    /// Override a var or a stage param: `-S seed=3`, `-S extract.lead_days=2` (value read as YAML).
    #[arg(short = 'S', long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

#[derive(Debug, Args)]
pub struct RunArgs {
    #[command(flatten)]
    pub plan: PlanArgs,
    /// Run stages even when they are up to date.
    #[arg(short, long)]
    pub force: bool,
    /// Print what would run and why; run nothing.
    #[arg(short = 'n', long)]
    pub dry_run: bool,
    /// Stages running at once [default: number of CPUs, or `jobs` in firecast.yaml].
    #[arg(short, long, value_name = "N")]
    pub jobs: Option<usize>,
    /// Run only this stage (or all expansions of a foreach stage); repeatable. Its inputs
    /// must already exist.
    #[arg(long, value_name = "STAGE")]
    pub only: Vec<String>,
    /// Where stages run: in this process, or one Ray job per stage on a Ray cluster
    /// [default: `executor` in firecast.yaml, else local].
    #[arg(long, value_enum, env = "FIRECAST_EXECUTOR")]
    pub executor: Option<ExecutorKind>,
    /// The Ray dashboard address, e.g. http://127.0.0.1:8265 [default: `ray.address` in
    /// firecast.yaml].
    #[arg(long, env = "FIRECAST_RAY_ADDRESS", value_name = "URL")]
    pub ray_address: Option<String>,
    /// Seconds a stage's Ray job may stay PENDING before it is stopped and reported
    /// [default: `ray.pending_timeout_s`, else 120].
    #[arg(long, value_name = "SECS")]
    pub ray_pending_timeout: Option<f64>,
    /// Submissions per stage run when its worker dies [default: `ray.attempts`, else 3].
    #[arg(long, value_name = "N")]
    pub ray_attempts: Option<u32>,
}

/// Every stage kind this binary knows.
pub fn stage_kinds() -> StageKinds {
    let mut kinds = firecast_pipeline::builtin_kinds();
    // Each crate registers its own kinds.
    firecast_registry::register(&mut kinds);
    firecast_episodes::register(&mut kinds);
    firecast_report::register(&mut kinds);
    firecast_dataset::stage::register(&mut kinds);
    firecast_forecast::stage::register(&mut kinds);
    firecast_rl::stage::register(&mut kinds);
    kinds
}

fn load(settings: &Settings, args: &PlanArgs) -> anyhow::Result<Plan> {
    let overrides = args
        .set
        .iter()
        .map(|s| Override::parse(s).map_err(anyhow::Error::msg))
        .collect::<anyhow::Result<Vec<_>>>()?;
    Ok(firecast_pipeline::load_plan(
        &settings.root,
        &args.file,
        &overrides,
        &stage_kinds(),
    )?)
}

pub(crate) fn engine(settings: &Settings, observer: Arc<dyn RunObserver>) -> anyhow::Result<Engine> {
    let store = firecast_store::ArtifactStore::open(&settings.store, &settings.root)?;
    Ok(Engine {
        root: settings.root.clone(),
        kinds: stage_kinds(),
        observer,
        store: Some(Arc::new(store)),
        git_commit: git_commit(&settings.root),
        executor: None,
    })
}

/// An engine that records runs: the registry, with every stage run's metrics mirrored into
/// a `metrics.rrd` artifact (and to a live Rerun viewer with `--rerun-connect`).
pub(crate) fn tracked_engine(settings: &Settings) -> anyhow::Result<Engine> {
    let registry: Arc<dyn RunObserver> = Arc::new(firecast_registry::Registry::open(&settings.registry)?);
    let mut engine = engine(settings, registry.clone())?;
    let store = engine
        .store
        .clone()
        .ok_or_else(|| anyhow::anyhow!("no artifact store is configured"))?;
    let viewer = settings
        .rerun_connect
        .as_deref()
        .map(firecast_recorder::Viewer::parse)
        .transpose()?;
    engine.observer = Arc::new(firecast_recorder::MetricsMirror::new(
        registry,
        store,
        engine.state_dir().join("state").join("recordings"),
        viewer,
        |message| eprintln!("warning: {message}"),
    ));
    Ok(engine)
}

pub fn run(settings: &Settings, command: PipelineCommand) -> anyhow::Result<ExitCode> {
    match command {
        PipelineCommand::Run(args) => {
            let plan = load(settings, &args.plan)?;
            let mut engine = if args.dry_run {
                engine(settings, Arc::new(NoObserver))?
            } else {
                tracked_engine(settings)?
            };
            if !args.dry_run {
                engine.executor = executor(settings, &args, engine.store.clone())?;
            }
            let opts = RunOptions {
                force: args.force,
                dry_run: args.dry_run,
                jobs: settings.jobs,
                only: args.only,
                progress: settings.progress,
            };
            let started = std::time::Instant::now();
            let report = engine.run(&plan, &opts)?;
            print_report(settings, &report, started.elapsed().as_secs_f64())?;
            Ok(if report.succeeded() {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            })
        }
        PipelineCommand::Status(args) => {
            let plan = load(settings, &args)?;
            let engine = engine(settings, Arc::new(NoObserver))?;
            let report = engine.status(&plan)?;
            print_report(settings, &report, 0.0)?;
            Ok(ExitCode::SUCCESS)
        }
        PipelineCommand::Dag { plan, dot } => {
            let plan = load(settings, &plan)?;
            if settings.json {
                output::print_json(&plan)?;
            } else if dot {
                print!("{}", dag_dot(&plan));
            } else {
                print!("{}", dag_text(&plan));
            }
            Ok(ExitCode::SUCCESS)
        }
        PipelineCommand::ExportDvc { files, output, check } => export_dvc(settings, files, &output, check),
        PipelineCommand::StageExec(args) => stage_exec(settings, &args),
        PipelineCommand::Kinds => {
            let kinds = stage_kinds();
            if settings.json {
                let list: Vec<_> = kinds
                    .iter()
                    .map(|k| serde_json::json!({"name": k.name(), "version": k.version(), "summary": k.summary()}))
                    .collect();
                output::print_json(&list)?;
            } else {
                let mut table = output::table(&["kind", "version", "inputs", "outputs", "summary"]);
                for kind in kinds.iter() {
                    let ports = kind.ports();
                    let names = |ports: &[firecast_pipeline::Port]| -> String {
                        if ports.is_empty() {
                            "any".into()
                        } else {
                            ports.iter().map(|p| p.name).collect::<Vec<_>>().join(", ")
                        }
                    };
                    table.add_row(vec![
                        kind.name().to_string(),
                        kind.version().to_string(),
                        names(ports.inputs),
                        names(ports.outputs),
                        kind.summary().to_string(),
                    ]);
                }
                output::print_table(&table)?;
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// The executor `pipeline run` uses: flag > environment > firecast.yaml > local.
fn executor(
    settings: &Settings,
    args: &RunArgs,
    store: Option<Arc<firecast_store::ArtifactStore>>,
) -> anyhow::Result<Option<Arc<dyn firecast_pipeline::StageExecutor>>> {
    match args.executor.unwrap_or(settings.executor) {
        ExecutorKind::Local => Ok(None),
        ExecutorKind::Ray => {
            let ray = &settings.ray;
            let address = args.ray_address.clone().or_else(|| ray.address.clone()).ok_or_else(|| {
                anyhow::anyhow!(
                    "--executor ray needs the cluster's dashboard address: --ray-address http://HEAD:8265, FIRECAST_RAY_ADDRESS, or `ray: {{address: …}}` in firecast.yaml"
                )
            })?;
            let firecast_bin = match &ray.firecast_bin {
                Some(bin) => bin.clone(),
                None => std::env::current_exe().context("cannot find this firecast binary's path")?,
            };
            let mut opts = firecast_executor::RayOptions::new(&address, firecast_bin);
            if let Some(secs) = args.ray_pending_timeout.or(ray.pending_timeout_s) {
                anyhow::ensure!(
                    secs.is_finite() && secs > 0.0,
                    "the Ray pending timeout must be a number of seconds above 0, got {secs}"
                );
                opts.pending_timeout = std::time::Duration::from_secs_f64(secs);
            }
            if let Some(attempts) = args.ray_attempts.or(ray.attempts) {
                opts.max_attempts = attempts;
            }
            opts.scratch = ray.scratch.clone();
            // Where the store is and how to speak to it, not who may: credentials stay in the
            // workers' own environment (runtime_env shows in Ray's dashboard).
            for var in [
                "AWS_ENDPOINT_URL",
                "AWS_ALLOW_HTTP",
                "AWS_REGION",
                "AWS_DEFAULT_REGION",
            ] {
                if let Ok(value) = std::env::var(var) {
                    opts.env.insert(var.to_string(), value);
                }
            }
            // A job runs libtorch with its stage's `threads` on however many CPUs Ray gave
            // it, so jobs share cores; OpenMP's spinning
            // waiters then starve each other (two libtorch jobs on a two-core loopback cluster
            // ran 19x slower than alone). Passive waiting, unless `ray: {env: …}` says otherwise.
            opts.env
                .insert("OMP_WAIT_POLICY".to_string(), "PASSIVE".to_string());
            opts.env.extend(ray.env.clone());
            let store = store.ok_or_else(|| anyhow::anyhow!("--executor ray needs an artifact store"))?;
            let executor = firecast_executor::RayExecutor::connect(opts, store)?;
            Ok(Some(Arc::new(executor)))
        }
    }
}

/// `pipeline stage-exec`: the worker side of a remote executor.
fn stage_exec(settings: &Settings, args: &StageExecArgs) -> anyhow::Result<ExitCode> {
    let store = firecast_store::ArtifactStore::open(&settings.store, &settings.root)?;
    let scratch = args.scratch.clone().unwrap_or_else(std::env::temp_dir);
    let exit = firecast_executor::worker::exec(
        &stage_kinds(),
        &store,
        &args.task,
        &args.result,
        &scratch,
        args.shard,
    )
    .with_context(|| format!("task {} in {}", args.task, store.url()))?;
    Ok(match exit {
        firecast_executor::worker::WorkerExit::Succeeded => ExitCode::SUCCESS,
        firecast_executor::worker::WorkerExit::StageFailed => {
            eprintln!(
                "error: stage task {} failed; see {}",
                args.task,
                store.uri_of(&args.result)
            );
            ExitCode::FAILURE
        }
    })
}

fn print_report(settings: &Settings, report: &RunReport, elapsed_secs: f64) -> anyhow::Result<()> {
    for warning in &report.warnings {
        eprintln!("warning: {warning}");
    }
    if settings.json {
        return output::print_json(report);
    }
    let mut table = output::table(&["stage", "kind", "status", "time", "why"]);
    for stage in &report.stages {
        let mut why = stage.reasons.join("; ");
        if let Some(error) = &stage.error {
            why = if why.is_empty() {
                error.clone()
            } else {
                format!("{why}; {error}")
            };
        }
        table.add_row(vec![
            stage.stage.clone(),
            stage.kind.clone(),
            stage.outcome.label().to_string(),
            if matches!(stage.outcome, Outcome::Ran | Outcome::Restored | Outcome::Failed) {
                format!("{:.2}s", stage.duration_secs)
            } else {
                String::new()
            },
            output::ellipsize(&why, 110),
        ]);
    }
    output::print_table(&table)?;
    if report.dry_run {
        println!(
            "{}: {} stale, {} restorable from cache, {} up to date",
            report.pipeline,
            report.count(Outcome::WouldRun),
            report.count(Outcome::WouldRestore),
            report.count(Outcome::UpToDate)
        );
    } else {
        println!(
            "{}: {} ran, {} restored, {} up to date, {} failed, {} skipped in {elapsed_secs:.2}s (run {})",
            report.pipeline,
            report.count(Outcome::Ran),
            report.count(Outcome::Restored),
            report.count(Outcome::UpToDate),
            report.count(Outcome::Failed),
            report.count(Outcome::Skipped),
            report.pipeline_run_id.as_deref().unwrap_or("-"),
        );
        for stage in report.stages.iter().filter(|s| s.outcome == Outcome::Failed) {
            eprintln!(
                "error: stage `{}` failed: {}",
                stage.stage,
                stage.error.as_deref().unwrap_or("unknown error")
            );
        }
    }
    Ok(())
}

fn dag_text(plan: &Plan) -> String {
    let mut out = String::new();
    for stage in &plan.stages {
        out.push_str(&format!("{} ({})\n", stage.name, stage.kind));
        for &u in &stage.upstream {
            out.push_str(&format!("  <- {}\n", plan.stages[u].name));
        }
    }
    out
}

fn dag_dot(plan: &Plan) -> String {
    let mut out = format!("digraph \"{}\" {{\n  rankdir=LR;\n", plan.name);
    for stage in &plan.stages {
        out.push_str(&format!(
            "  \"{}\" [label=\"{}\\n({})\"];\n",
            stage.name, stage.name, stage.kind
        ));
    }
    for stage in &plan.stages {
        for &u in &stage.upstream {
            out.push_str(&format!("  \"{}\" -> \"{}\";\n", plan.stages[u].name, stage.name));
        }
    }
    out.push_str("}\n");
    out
}

/// Every pipeline file in `pipelines/` (params files `*.params.yaml` excluded), sorted.
fn pipeline_files(root: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let dir = root.join("pipelines");
    let mut files = Vec::new();
    for entry in std::fs::read_dir(&dir).with_context(|| format!("cannot list {}", dir.display()))? {
        let name = entry?.file_name().to_string_lossy().to_string();
        if name.ends_with(".yaml") && !name.ends_with(".params.yaml") {
            files.push(PathBuf::from("pipelines").join(name));
        }
    }
    files.sort();
    Ok(files)
}

fn export_dvc(
    settings: &Settings,
    files: Vec<PathBuf>,
    output: &Path,
    check: bool,
) -> anyhow::Result<ExitCode> {
    let files = if files.is_empty() {
        pipeline_files(&settings.root)?
    } else {
        files
    };
    let kinds = stage_kinds();
    let plans = files
        .iter()
        .map(|f| firecast_pipeline::load_plan(&settings.root, f, &[], &kinds))
        .collect::<Result<Vec<_>, _>>()?;
    let text = firecast_pipeline::dvc::export(&plans, &kinds, "firecast");
    let path = settings.root.join(output);
    if check {
        let current = std::fs::read_to_string(&path).unwrap_or_default();
        if current == text {
            println!("{} is up to date", output.display());
            return Ok(ExitCode::SUCCESS);
        }
        eprintln!(
            "error: {} is out of date with pipelines/; run `firecast pipeline export-dvc`",
            output.display()
        );
        return Ok(ExitCode::FAILURE);
    }
    firecast_fs::write_atomically(&path, text.as_bytes())?;
    let stages: usize = plans.iter().map(|p| p.stages.len()).sum();
    println!(
        "wrote {} ({stages} stages from {} pipelines)",
        output.display(),
        plans.len()
    );
    Ok(ExitCode::SUCCESS)
}

/// `git rev-parse HEAD` (+ `-dirty` when the tree has changes), if this is a git checkout.
fn git_commit(root: &Path) -> Option<String> {
    let head = std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .current_dir(root)
        .output()
        .ok()
        .filter(|o| o.status.success())?;
    let mut commit = String::from_utf8_lossy(&head.stdout).trim().to_string();
    let dirty = std::process::Command::new("git")
        .args(["status", "--porcelain", "--untracked-files=no"])
        .current_dir(root)
        .output()
        .ok()
        .is_some_and(|o| !o.stdout.is_empty());
    if dirty {
        commit.push_str("-dirty");
    }
    Some(commit)
}

/// `path` relative to the project root when it lies inside it (as pipelines name files).
pub(crate) fn relative_to_root(settings: &Settings, path: &Path) -> PathBuf {
    let abs = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()
            .map(|d| d.join(path))
            .unwrap_or_else(|_| path.to_path_buf())
    };
    abs.strip_prefix(&settings.root)
        .map(Path::to_path_buf)
        .unwrap_or(abs)
}

/// How [`run_one_stage`] runs its stage.
#[derive(Default)]
pub(crate) struct OneStage {
    /// The one-stage pipeline's description.
    pub description: Option<String>,
    /// Run even when up to date.
    pub force: bool,
    /// Stage kinds to run it with (default: [`stage_kinds`]), e.g. one configured by flags.
    pub kinds: Option<StageKinds>,
}

/// Runs one stage as a one-stage pipeline (cached, registered, uploaded like any other) and
/// returns (outcome label, seconds, pipeline run id). `what` names it in the failure message.
pub(crate) fn run_one_stage(
    settings: &Settings,
    file: &Path,
    what: &str,
    name: &str,
    stage: serde_json::Value,
    how: OneStage,
) -> anyhow::Result<(String, f64, String)> {
    let OneStage {
        description,
        force,
        kinds,
    } = how;
    let mut pipeline = serde_json::json!({ "stages": { name: stage } });
    if let Some(d) = description {
        pipeline["description"] = serde_json::Value::String(d);
    }
    let text = serde_json::to_string(&pipeline)?;
    let expanded = firecast_pipeline::spec::parse(&settings.root, file, &text, &[])?;
    let kinds = kinds.unwrap_or_else(stage_kinds);
    let plan = firecast_pipeline::plan::plan(&expanded, &kinds)?;
    let mut engine = tracked_engine(settings)?;
    engine.kinds = kinds;
    let opts = firecast_pipeline::RunOptions {
        force,
        dry_run: false,
        jobs: 1,
        only: Vec::new(),
        progress: settings.progress,
    };
    let report = engine.run(&plan, &opts)?;
    for warning in &report.warnings {
        eprintln!("warning: {warning}");
    }
    if let Some(failed) = report.stages.iter().find(|s| s.error.is_some()) {
        anyhow::bail!(
            "{what} `{name}` failed: {}",
            failed.error.as_deref().unwrap_or("unknown error")
        );
    }
    let s = report.stages.first();
    Ok((
        s.map_or("?".into(), |s| s.outcome.label().to_string()),
        s.map_or(0.0, |s| s.duration_secs),
        report.pipeline_run_id.unwrap_or_else(|| "-".into()),
    ))
}
