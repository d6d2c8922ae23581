//! Settings resolved once: command-line flags over environment variables over the
//! project file `firecast.yaml` over defaults.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use serde::Deserialize;

/// `firecast.yaml` at the project root (optional). Unknown keys are errors.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProjectFile {
    /// Registry file, relative to the root.
    pub registry: Option<PathBuf>,
    /// Artifact store: a folder or a URL (`s3://…`, `gs://…`, `az://…`).
    pub store: Option<String>,
    /// Stages running at once.
    pub jobs: Option<usize>,
    /// Where `pipeline run` runs stages: `local` (default) or `ray`.
    pub executor: Option<ExecutorKind>,
    /// The Ray executor's settings.
    pub ray: Option<RaySettings>,
    /// A running Rerun viewer that stage metrics also stream to
    /// (`rerun+http://127.0.0.1:9876/proxy`).
    pub rerun_connect: Option<String>,
}

/// Where pipeline stages run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum ExecutorKind {
    /// In this process (threads).
    #[default]
    Local,
    /// One Ray job per stage run, through the cluster's Jobs REST API.
    Ray,
}

/// `ray:` in `firecast.yaml`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RaySettings {
    /// The dashboard address (`http://head:8265`).
    pub address: Option<String>,
    /// Seconds a stage's job may stay PENDING before it is stopped and reported.
    pub pending_timeout_s: Option<f64>,
    /// Submissions per stage run when workers die.
    pub attempts: Option<u32>,
    /// The `firecast` binary's path on the workers [default: this binary's path].
    pub firecast_bin: Option<PathBuf>,
    /// Where workers unpack tasks [default: their temporary folder].
    pub scratch: Option<PathBuf>,
    /// Extra environment variables for the workers (no secrets: they show in Ray's dashboard).
    #[serde(default)]
    pub env: std::collections::BTreeMap<String, String>,
}

/// The resolved settings every command uses.
#[derive(Debug, Clone)]
pub struct Settings {
    pub root: PathBuf,
    pub registry: PathBuf,
    pub store: String,
    pub jobs: usize,
    pub json: bool,
    pub progress: bool,
    /// From `firecast.yaml` (flags and environment variables of `pipeline run` override it).
    pub executor: ExecutorKind,
    pub ray: RaySettings,
    /// A Rerun viewer that stage runs' metrics stream to as well as to their `metrics.rrd`.
    pub rerun_connect: Option<String>,
    /// Where each setting came from, for `firecast settings`.
    pub origins: Origins,
}

/// Where a setting's value came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Origin {
    /// A command-line flag.
    Flag,
    /// An environment variable.
    Env,
    /// `firecast.yaml`.
    File,
    #[default]
    Default,
}

/// The origin of each setting that has more than one source.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Origins {
    pub root: Origin,
    pub registry: Origin,
    pub store: Origin,
    pub jobs: Origin,
    pub executor: Origin,
    pub rerun_connect: Origin,
}

/// A flag's value came from its environment variable when the variable holds that value
/// (clap fills the flag from it when the flag is absent; a flag given wins either way).
fn flag_or_env<T: PartialEq + std::str::FromStr>(flag: Option<&T>, env: &str, in_file: bool) -> Origin {
    match flag {
        Some(value) => match std::env::var(env).ok().and_then(|v| v.parse::<T>().ok()) {
            Some(from_env) if &from_env == value => Origin::Env,
            _ => Origin::Flag,
        },
        None if in_file => Origin::File,
        None => Origin::Default,
    }
}

/// Raw global flags (clap fills these; env vars are applied by clap's `env`).
#[derive(Debug, Clone, clap::Args)]
pub struct GlobalArgs {
    /// Project root: pipelines, outputs and `.firecast/` state resolve against it.
    #[arg(short = 'C', long, global = true, value_name = "DIR")]
    pub root: Option<PathBuf>,
    /// Run registry (DuckDB file) [default: .firecast/registry.duckdb].
    #[arg(long, global = true, env = "FIRECAST_REGISTRY", value_name = "FILE")]
    pub registry: Option<PathBuf>,
    /// Artifact store: a folder, or s3://, gs://, az://, memory:// URL [default: artifacts].
    #[arg(long, global = true, env = "FIRECAST_STORE", value_name = "URL")]
    pub store: Option<String>,
    /// Print machine-readable JSON instead of tables.
    #[arg(long, global = true)]
    pub json: bool,
    /// Do not draw progress bars.
    #[arg(long, global = true)]
    pub no_progress: bool,
    /// Also stream every stage run's metrics live to this Rerun viewer, e.g.
    /// rerun+http://127.0.0.1:9876/proxy (where `rerun` listens). Each run's metrics.rrd is
    /// written either way; an unreachable viewer is a warning [default: `rerun_connect` in
    /// firecast.yaml].
    #[arg(long, global = true, env = "FIRECAST_RERUN_CONNECT", value_name = "URL")]
    pub rerun_connect: Option<String>,
}

impl Settings {
    pub fn resolve(args: &GlobalArgs, jobs_flag: Option<usize>) -> anyhow::Result<Self> {
        let root = match &args.root {
            Some(r) => std::path::absolute(r).with_context(|| format!("bad --root {}", r.display()))?,
            None => std::env::current_dir().context("cannot read the current directory")?,
        };
        let project = load_project_file(&root)?;
        let origins = Origins {
            root: if args.root.is_some() {
                Origin::Flag
            } else {
                Origin::Default
            },
            registry: flag_or_env(
                args.registry.as_ref(),
                "FIRECAST_REGISTRY",
                project.registry.is_some(),
            ),
            store: flag_or_env(args.store.as_ref(), "FIRECAST_STORE", project.store.is_some()),
            jobs: match (jobs_flag, project.jobs) {
                (Some(_), _) => Origin::Flag,
                (None, Some(_)) => Origin::File,
                (None, None) => Origin::Default,
            },
            executor: if project.executor.is_some() {
                Origin::File
            } else {
                Origin::Default
            },
            rerun_connect: flag_or_env(
                args.rerun_connect.as_ref(),
                "FIRECAST_RERUN_CONNECT",
                project.rerun_connect.is_some(),
            ),
        };
        let registry = args
            .registry
            .clone()
            .or(project.registry)
            .unwrap_or_else(|| PathBuf::from(".firecast/registry.duckdb"));
        let store = args
            .store
            .clone()
            .or(project.store)
            .unwrap_or_else(|| "artifacts".to_string());
        let jobs = jobs_flag
            .or(project.jobs)
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from))
            .max(1);
        Ok(Self {
            origins,
            registry: root.join(registry),
            root,
            store,
            jobs,
            json: args.json,
            progress: !args.no_progress && !args.json,
            executor: project.executor.unwrap_or_default(),
            ray: project.ray.unwrap_or_default(),
            rerun_connect: args
                .rerun_connect
                .clone()
                .or(project.rerun_connect)
                .filter(|url| !url.trim().is_empty()),
        })
    }
}

impl Settings {
    /// What the benches take from the settings.
    pub fn bench(&self) -> firecast_bench::Context {
        firecast_bench::Context {
            root: self.root.clone(),
            json: self.json,
            progress: self.progress,
        }
    }
}

fn load_project_file(root: &Path) -> anyhow::Result<ProjectFile> {
    let path = root.join("firecast.yaml");
    match std::fs::read_to_string(&path) {
        Ok(text) => Ok(firecast_pipeline::spec::deserialize_located(
            Path::new("firecast.yaml"),
            &text,
        )?),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(ProjectFile::default()),
        Err(e) => Err(e).with_context(|| format!("cannot read {}", path.display())),
    }
}

/// The arguments every command that runs a spec file takes (`experiment run FILE`, `rl train
/// FILE`), declared once.
#[derive(Debug, Clone, clap::Args)]
pub struct SpecArgs {
    /// Override a key of the spec: `-S seeds=[0,1,2]`, `-S ppo.total_timesteps=20000`,
    /// `-S models.3.params.max_epochs=5` (value read as YAML).
    #[arg(short = 'S', long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Torch device: auto, cpu, cuda, cuda:N (overrides the spec's `device`).
    #[arg(long)]
    pub device: Option<String>,
    /// libtorch threads (XGBoost's too in experiments; overrides the spec's `threads`; part
    /// of the result and its cache key).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Output folder [default: experiments/runs/<name>].
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Run even when nothing changed.
    #[arg(short, long)]
    pub force: bool,
    /// Print the stage this would run — the spec resolved through `extends`, `-S` and the
    /// flags, its inputs and outputs — and run nothing.
    #[arg(short = 'n', long)]
    pub dry_run: bool,
}

impl SpecArgs {
    /// Prints a one-stage pipeline (`uses`, `params`, `inputs`, `outputs`) as YAML.
    pub fn print_stage(stage: &serde_json::Value) -> anyhow::Result<()> {
        print!("{}", serde_yaml_ng::to_string(stage)?);
        Ok(())
    }
}
