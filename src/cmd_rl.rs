//! `firecast rl train|evaluate`: PPO training runs and Table IV, each run as a one-stage
//! pipeline (`rl.train`, `rl.evaluate`) so they are cached, registered and uploaded like
//! every other stage.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args, Subcommand};
use firecast_rl::spec::{EnvSpec, TrainSpec};

use crate::output;
use crate::settings::Settings;

#[derive(Debug, Subcommand)]
pub enum RlCommand {
    /// Train PPO agents (one per seed) from a training spec (experiments/rl/*.yaml).
    ///
    /// Checkpoints are kept in .firecast/rl/<name>-<key>/: a run that was stopped resumes
    /// from its last checkpoint and ends exactly where an uninterrupted run would.
    Train(TrainArgs),
    /// Table IV: the trained agents, both rule-based agents and no suppression on the same
    /// held-out fires, with intervals.
    ///
    /// Also replays the best, median and worst PPO episodes into Rerun recordings
    /// (<out>/recordings/ppo-{best,median,worst}.rrd; open with `rerun FILE`).
    Evaluate(EvaluateArgs),
}

#[derive(Debug, Args)]
pub struct TrainArgs {
    /// The training spec (a YAML file, as `experiment run FILE` takes its spec).
    #[arg(value_name = "FILE", required_unless_present = "config")]
    pub file: Option<PathBuf>,
    /// The training spec, the older way to name it (same as FILE).
    #[arg(long = "config", value_name = "FILE", conflicts_with = "file")]
    pub config: Option<PathBuf>,
    /// Override a key: `-S ppo.total_timesteps=20000`, `-S seeds=[0,1,2]` (value read as YAML).
    #[arg(short = 'S', long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Torch device: auto, cpu, cuda, cuda:N (overrides the spec's `device`).
    #[arg(long)]
    pub device: Option<String>,
    /// libtorch threads (overrides the spec's `threads`; part of the result and its cache key).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Run folder [default: experiments/runs/<name>].
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Continue from the last checkpoint (an error if there is none).
    #[arg(long, conflicts_with = "fresh")]
    pub resume: bool,
    /// Discard the checkpoints of this spec and start over (runs even when nothing changed).
    #[arg(long)]
    pub fresh: bool,
    /// Stop every seed after this many steps, keeping checkpoints (resume later).
    #[arg(long, value_name = "STEPS")]
    pub stop_after: Option<u64>,
    /// Run even when nothing changed.
    #[arg(short, long)]
    pub force: bool,
}

#[derive(Debug, Args)]
pub struct EvaluateArgs {
    /// A training run folder (written by `rl train`).
    #[arg(long, value_name = "DIR")]
    pub run: PathBuf,
    /// Fire file whose `evaluate` fires are used [default: the run's].
    #[arg(long, value_name = "FILE")]
    pub fires: Option<PathBuf>,
    /// Report folder [default: <run>/evaluation].
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Bootstrap resamples.
    #[arg(long, default_value_t = 10_000)]
    pub resamples: usize,
    /// Sample PPO actions instead of taking the greedy one.
    #[arg(long)]
    pub stochastic: bool,
    /// Another training run to evaluate beside this one on the same fires, compared pair by
    /// pair (its agent is `ppo:<its name>`).
    #[arg(long, value_name = "DIR")]
    pub against: Option<PathBuf>,
    /// Do not record the best, median and worst PPO episodes.
    #[arg(long)]
    pub no_recordings: bool,
    #[arg(long, default_value = "auto")]
    pub device: String,
    /// libtorch threads (part of the result and its cache key).
    #[arg(long, default_value_t = firecast_learn::DEFAULT_THREADS)]
    pub threads: usize,
    /// Run even when nothing changed.
    #[arg(short, long)]
    pub force: bool,
}

pub fn run(settings: &Settings, command: RlCommand) -> anyhow::Result<ExitCode> {
    match command {
        RlCommand::Train(args) => train(settings, &args),
        RlCommand::Evaluate(args) => evaluate(settings, &args),
    }
}

fn train(settings: &Settings, args: &TrainArgs) -> anyhow::Result<ExitCode> {
    let spec_file = args
        .file
        .as_ref()
        .or(args.config.as_ref())
        .ok_or_else(|| anyhow::anyhow!("name the training spec: `firecast rl train FILE`"))?;
    let file = crate::cmd_pipeline::relative_to_root(settings, spec_file);
    let mut spec = TrainSpec::load(&settings.root, &file, &args.set)?;
    if let Some(device) = &args.device {
        spec.device = device.clone();
    }
    if let Some(threads) = args.threads {
        spec.threads = threads;
    }
    let fires = firecast_rl::spec::fires_path(&spec).cloned();
    if let EnvSpec::Helitack { fires: f } = &mut spec.env {
        if f.is_none() {
            anyhow::bail!(
                "{}: `env.fires`: the helitack environment needs a fire file",
                file.display()
            );
        }
        *f = None;
    }
    let work = firecast_rl::run::work_dir(
        &settings.root,
        &spec,
        fires.as_ref().map(|f| settings.root.join(f)).as_deref(),
    )?;
    if args.fresh && work.exists() {
        std::fs::remove_dir_all(&work).with_context(|| format!("removing {}", work.display()))?;
    }
    // Checkpoints short of the budget: an interrupted run, which must run whatever the cache
    // says. A finished run's last checkpoint is not one (re-invoking it is `up to date`).
    let total = spec.ppo()?.total_timesteps;
    let has_checkpoint = spec.seeds.iter().any(|s| {
        firecast_rl::train::Trainer::latest_checkpoint(&work.join(format!("seed-{s}"))).is_some_and(|dir| {
            dir.file_name()
                .and_then(|n| n.to_str())
                .and_then(|n| n.strip_prefix("step-"))
                .and_then(|n| n.parse::<u64>().ok())
                .is_none_or(|step| step < total)
        })
    });
    if args.resume && !has_checkpoint {
        anyhow::bail!(
            "nothing to resume: no checkpoint of this spec in {} (a changed spec or fire file is a new run)",
            work.display()
        );
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("experiments/runs").join(&spec.name));
    let mut stage = serde_json::json!({
        "uses": "rl.train",
        "description": spec.description.clone().unwrap_or_else(|| format!("PPO {} ({})", spec.name, file.display())),
        "params": serde_json::to_value(&spec)?,
        "outputs": {"run": out.display().to_string()},
    });
    if let Some(f) = &fires {
        stage["inputs"] = serde_json::json!({"fires": f.display().to_string()});
    }
    // An interruption asked for travels in the stage kind itself, typed.
    let mut kinds = crate::cmd_pipeline::stage_kinds();
    kinds.register(firecast_rl::stage::TrainStage {
        stop_after: args.stop_after,
    });
    // A resumed or interrupted run must run, whatever the cache says.
    let (outcome, secs, run_id) = crate::cmd_pipeline::run_one_stage(
        settings,
        &file,
        "rl train",
        &spec.name,
        stage,
        crate::cmd_pipeline::OneStage {
            description: None,
            force: args.force || args.fresh || has_checkpoint,
            kinds: Some(kinds),
        },
    )?;
    let summary: firecast_rl::run::TrainSummary = serde_json::from_slice(&std::fs::read(
        settings.root.join(&out).join(firecast_rl::run::SUMMARY_FILE),
    )?)?;
    if settings.json {
        output::print_json(&summary)?;
        return Ok(ExitCode::SUCCESS);
    }
    // Steps spent imitating a teacher before PPO, in their own column when there were any.
    let imitated = summary.seeds.iter().any(|s| s.imitation_timesteps > 0);
    let mut header = vec!["seed"];
    if imitated {
        header.push("imitation steps");
    }
    header.extend([
        "steps",
        "resumed from",
        "ep_rew_mean (last 100)",
        "ep_len_mean",
        "parameters",
    ]);
    let mut table = output::table(&header);
    for s in &summary.seeds {
        let mut row = vec![s.seed.to_string()];
        if imitated {
            row.push(s.imitation_timesteps.to_string());
        }
        row.extend([
            s.timesteps.to_string(),
            s.resumed_from.map_or("-".into(), |r| r.to_string()),
            s.ep_rew_mean.map_or("-".into(), |v| format!("{v:.2}")),
            s.ep_len_mean.map_or("-".into(), |v| format!("{v:.1}")),
            s.parameters.to_string(),
        ]);
        table.add_row(row);
    }
    println!("{table}");
    println!(
        "\nrl train {}: {outcome} ({secs:.1}s), run folder {} (run {run_id}); curves in {}",
        spec.name,
        out.display(),
        out.join("training.png").display()
    );
    Ok(ExitCode::SUCCESS)
}

fn evaluate(settings: &Settings, args: &EvaluateArgs) -> anyhow::Result<ExitCode> {
    let run = crate::cmd_pipeline::relative_to_root(settings, &args.run);
    let summary_path = settings.root.join(&run).join(firecast_rl::run::SUMMARY_FILE);
    let summary: firecast_rl::run::TrainSummary = serde_json::from_slice(
        &std::fs::read(&summary_path)
            .with_context(|| format!("{} is not a training run folder", run.display()))?,
    )
    .with_context(|| format!("reading {}", summary_path.display()))?;
    let fires = match &args.fires {
        Some(f) => crate::cmd_pipeline::relative_to_root(settings, f),
        None => summary.fires_file.clone().with_context(|| {
            format!(
                "the run {} does not say which fire file it used: pass --fires",
                run.display()
            )
        })?,
    };
    let out = args.out.clone().unwrap_or_else(|| run.join("evaluation"));
    let name = format!("{}-evaluate", summary.name);
    let params = firecast_rl::stage::EvaluateParams {
        eval: firecast_rl::evaluate::EvalConfig {
            deterministic: !args.stochastic,
            resamples: args.resamples,
            recordings: !args.no_recordings,
            ..Default::default()
        },
        device: args.device.clone(),
        threads: args.threads,
    };
    let mut inputs =
        serde_json::json!({"run": run.display().to_string(), "fires": fires.display().to_string()});
    if let Some(other) = &args.against {
        let other = crate::cmd_pipeline::relative_to_root(settings, other);
        if !settings
            .root
            .join(&other)
            .join(firecast_rl::run::SUMMARY_FILE)
            .is_file()
        {
            anyhow::bail!(
                "--against {}: not a training run folder (no {})",
                other.display(),
                firecast_rl::run::SUMMARY_FILE
            );
        }
        inputs["against"] = other.display().to_string().into();
    }
    let stage = serde_json::json!({
        "uses": "rl.evaluate",
        "description": format!("Table IV for {}", run.display()),
        "params": serde_json::to_value(&params)?,
        "inputs": inputs,
        "outputs": {"report": out.display().to_string()},
    });
    let (outcome, secs, run_id) = crate::cmd_pipeline::run_one_stage(
        settings,
        &fires,
        "rl evaluate",
        &name,
        stage,
        crate::cmd_pipeline::OneStage {
            force: args.force,
            ..Default::default()
        },
    )?;
    let report: firecast_rl::evaluate::EvalReport =
        serde_json::from_slice(&std::fs::read(settings.root.join(&out).join("evaluation.json"))?)?;
    if settings.json {
        output::print_json(&report)?;
        return Ok(ExitCode::SUCCESS);
    }
    println!("{}", firecast_rl::evaluate::markdown(&report));
    println!(
        "rl evaluate: {outcome} ({secs:.1}s), report in {} (run {run_id}); plots table4.png, ppo_vs_rule.png",
        out.display()
    );
    if !report.recordings.is_empty() {
        println!(
            "Rerun recordings of PPO episodes (open with `rerun FILE`, rerun-sdk {}):",
            firecast_recorder::RERUN_VERSION
        );
        for r in &report.recordings {
            println!(
                "  {:6} {} (training seed {}, fire {}, {} cells burned)",
                r.role,
                out.join(&r.path).display(),
                r.train_seed,
                r.fire,
                r.cells_burned
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// A part of `bench ppo`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BenchPart {
    /// CartPole-v1, MLP policy, RL-Zoo's settings, one torch thread each.
    A,
    /// The helitack environment with the compact policy; SB3 drives it through the Python
    /// package (`firecast.HelitackVecEnv`).
    B,
    /// SB3 on the FireCastRL Python environment (needs --reference-env) against FireCast on
    /// the same map, compact policy.
    C,
}

impl BenchPart {
    /// The goal on training steps per second, FireCast / SB3 (issue 11).
    fn goal(self) -> f64 {
        match self {
            Self::A => 5.0,
            Self::B => 3.0,
            Self::C => 50.0,
        }
    }
}

#[derive(Debug, Args)]
pub struct BenchPpoArgs {
    /// Parts to run (comma-separated): a (CartPole), b (helitack through the Python package),
    /// c (SB3 on the FireCastRL environment; skipped without --reference-env).
    #[arg(long, value_delimiter = ',', default_value = "a,b,c")]
    pub parts: Vec<BenchPart>,
    /// Environment steps per phase in (a).
    #[arg(long, default_value_t = 50_000)]
    pub steps: u64,
    /// Environment steps per phase in (b).
    #[arg(long, default_value_t = 4096)]
    pub helitack_steps: u64,
    /// Environment steps per phase in (c) (the FireCastRL environment steps about 60 times a
    /// second per core).
    #[arg(long, default_value_t = 1024)]
    pub reference_steps: u64,
    /// Torch threads of each side in (b) and (c) [default: every core]. (a) uses one.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Override a PPO setting of (b) and (c) (the `paper` preset): `-S n_steps=16` (value read
    /// as YAML; `ppo.` prefix optional).
    #[arg(short = 'S', long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Times each side runs, FireCast and SB3 alternating so that a slow spell of the machine
    /// falls on both; the tables show each phase's median.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    pub repeats: u32,
    /// Python with stable-baselines3 (and, for (b), the firecast package)
    /// [default: $FIRECAST_VENV, ./.venv, python3].
    #[arg(long, value_name = "PATH")]
    pub python: Option<PathBuf>,
    /// (c): a checkout of aisystems-lab/wildfire-env (the folder holding `firecastrl_env`), as
    /// for `firecast bench sim --reference-env`.
    #[arg(long, value_name = "DIR")]
    pub reference_env: Option<PathBuf>,
    /// (c): Python with stable-baselines3 and the FireCastRL environment's dependencies
    /// (gymnasium, numpy, pillow, websockets, requests) [default: --python].
    #[arg(long, value_name = "PATH", requires = "reference_env")]
    pub reference_python: Option<PathBuf>,
}

/// One part's result: both sides, the ratios and the goal on training.
#[derive(Debug, serde::Serialize)]
struct BenchPartReport {
    part: BenchPart,
    task: String,
    steps: u64,
    threads: usize,
    /// Each phase's median over the repeats.
    firecast: firecast_rl::bench::BenchRun,
    /// SB3's report with each phase's median over the repeats.
    sb3: serde_json::Value,
    ratios: serde_json::Value,
    /// Training FireCast / SB3 of each repeat (FireCast's i-th run against SB3's i-th).
    train_ratios: Vec<f64>,
    /// Goal on training steps per second, FireCast / SB3.
    goal: f64,
    arithmetic: Arithmetic,
}

/// The network's arithmetic against the machine's: what the goal asks of the CPU.
#[derive(Debug, serde::Serialize)]
struct Arithmetic {
    /// Convolution and matrix-product FLOPs per environment step of training (one forward
    /// pass in the rollout, n_epochs forward + backward passes in the updates), torch's count.
    flops_per_step: f64,
    /// GFLOP/s those steps amount to at each side's training speed.
    firecast_gflops: f64,
    sb3_gflops: f64,
    /// GFLOP/s FireCast's training would need to meet the goal.
    goal_gflops: f64,
    /// This machine's float32 matrix-product rate at the part's torch threads.
    sgemm_gflops: f64,
}

impl BenchPartReport {
    /// The report of `part` from both sides' medians and each repeat's training ratio; the
    /// ratios, the goal and the arithmetic follow from them.
    fn new(
        part: BenchPart,
        task: String,
        steps: u64,
        threads: usize,
        (firecast, sb3, train_ratios): (firecast_rl::bench::BenchRun, serde_json::Value, Vec<f64>),
    ) -> Self {
        Self {
            part,
            task,
            steps,
            threads,
            ratios: ratios(&firecast.speeds, &sb3),
            arithmetic: Arithmetic::new(&firecast.speeds, &sb3, part.goal()),
            goal: part.goal(),
            train_ratios,
            firecast,
            sb3,
        }
    }
}

impl Arithmetic {
    fn new(firecast: &firecast_rl::bench::PhaseSpeeds, sb3: &serde_json::Value, goal: f64) -> Self {
        let flops = sb3_number(sb3, "flops_per_step");
        let sb3_train = sb3_number(sb3, "train_sps");
        Self {
            flops_per_step: flops,
            firecast_gflops: firecast.train_sps * flops / 1e9,
            sb3_gflops: sb3_train * flops / 1e9,
            goal_gflops: goal * sb3_train * flops / 1e9,
            sgemm_gflops: sb3_number(sb3, "sgemm_gflops"),
        }
    }
}

#[derive(Debug, serde::Serialize)]
struct BenchPpoReport {
    parts: Vec<BenchPartReport>,
    skipped: Vec<String>,
}

/// Runs an SB3 reference script with `cfg` and returns the JSON object it prints last.
fn run_sb3(
    python: &Path,
    script: &str,
    cfg: &serde_json::Value,
    threads: usize,
) -> anyhow::Result<serde_json::Value> {
    let out = std::process::Command::new(python)
        .arg("-c")
        .arg(format!("{}\n{script}", firecast_rl::bench::NETWORK_WORK))
        .arg(cfg.to_string())
        .env("OMP_NUM_THREADS", threads.to_string())
        .env("MKL_NUM_THREADS", threads.to_string())
        .output()
        .with_context(|| format!("running {}", python.display()))?;
    if !out.status.success() {
        anyhow::bail!(
            "the SB3 reference failed ({}): {}",
            python.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    serde_json::from_slice(
        out.stdout
            .split(|&b| b == b'\n')
            .rfind(|l| !l.is_empty())
            .unwrap_or_default(),
    )
    .with_context(|| {
        format!(
            "the SB3 reference printed no JSON: {}",
            String::from_utf8_lossy(&out.stderr)
        )
    })
}

fn progress_line(run: &firecast_rl::bench::BenchRun) {
    let s = &run.speeds;
    eprintln!(
        "    FireCast: environment {:.0}, rollout {:.0}, updates {:.0}, training {:.0} steps/s ({} parameters)",
        s.env_sps, s.rollout_sps, s.update_sps, s.train_sps, run.parameters
    );
}

/// A number of the SB3 report (`env_sps`, …); NaN where it is missing.
fn sb3_number(report: &serde_json::Value, key: &str) -> f64 {
    report
        .get(key)
        .and_then(serde_json::Value::as_f64)
        .unwrap_or(f64::NAN)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Runs FireCast's side and SB3's side `repeats` times, alternating, so that a slow spell of
/// the shared machine lands on both; returns each side's per-phase medians and the training
/// ratio of each repeat.
fn interleaved(
    repeats: u32,
    mut firecast: impl FnMut() -> anyhow::Result<firecast_rl::bench::BenchRun>,
    mut sb3: impl FnMut() -> anyhow::Result<serde_json::Value>,
) -> anyhow::Result<(firecast_rl::bench::BenchRun, serde_json::Value, Vec<f64>)> {
    let (mut ours, mut theirs) = (Vec::new(), Vec::new());
    let repeats = repeats.max(1);
    for r in 1..=repeats {
        if repeats > 1 {
            eprintln!("    repeat {r}/{repeats}");
        }
        let run = firecast()?;
        progress_line(&run);
        ours.push(run);
        theirs.push(sb3()?);
    }
    let train_ratios = ours
        .iter()
        .zip(&theirs)
        .map(|(o, t)| o.speeds.train_sps / sb3_number(t, "train_sps"))
        .collect();
    let mut run = ours[0];
    run.speeds = firecast_rl::bench::PhaseSpeeds {
        env_sps: median(ours.iter().map(|o| o.speeds.env_sps).collect()),
        rollout_sps: median(ours.iter().map(|o| o.speeds.rollout_sps).collect()),
        update_sps: median(ours.iter().map(|o| o.speeds.update_sps).collect()),
        train_sps: median(ours.iter().map(|o| o.speeds.train_sps).collect()),
    };
    let mut sb3 = theirs[0].clone();
    for k in [
        "env_sps",
        "rollout_sps",
        "update_sps",
        "train_sps",
        "sgemm_gflops",
    ] {
        sb3[k] = serde_json::json!(median(theirs.iter().map(|t| sb3_number(t, k)).collect()));
    }
    Ok((run, sb3, train_ratios))
}

fn ratios(firecast: &firecast_rl::bench::PhaseSpeeds, sb3: &serde_json::Value) -> serde_json::Value {
    let get = |k: &str| sb3_number(sb3, k);
    serde_json::json!({
        "env": firecast.env_sps / get("env_sps"),
        "rollout": firecast.rollout_sps / get("rollout_sps"),
        "update": firecast.update_sps / get("update_sps"),
        // FireCast's training if its rollouts cost nothing: its updates alone bound the ratio.
        "train_ceiling": firecast.update_sps / get("train_sps"),
        "train": firecast.train_sps / get("train_sps"),
    })
}

/// The `paper` preset with `-S` overrides.
fn bench_ppo_config(set: &[String]) -> anyhow::Result<firecast_rl::ppo::PpoConfig> {
    let mut overrides = serde_json::Map::new();
    for kv in set {
        let (k, v) = kv
            .split_once('=')
            .with_context(|| format!("-S {kv}: expected KEY=VALUE"))?;
        let value: serde_json::Value =
            serde_yaml_ng::from_str(v).with_context(|| format!("-S {kv}: the value is not YAML"))?;
        overrides.insert(k.trim().trim_start_matches("ppo.").to_string(), value);
    }
    Ok(firecast_rl::ppo::PpoConfig::resolve("paper", &overrides)?)
}

/// The SB3 side's settings for (b) and (c): every PPO value, the policy, the environment.
fn helitack_sb3_config(
    ppo: &firecast_rl::ppo::PpoConfig,
    policy: &firecast_rl::policy::PolicyConfig,
    env: serde_json::Value,
    steps: u64,
    seed: u64,
    threads: usize,
) -> anyhow::Result<serde_json::Value> {
    Ok(serde_json::json!({
        "ppo": serde_json::to_value(ppo)?,
        "policy": serde_json::to_value(policy)?,
        "env": env,
        "steps": steps,
        "seed": seed,
        "threads": threads,
    }))
}

/// FireCast's compact parameter count must equal SB3's, or the comparison is void.
fn check_parameters(part: &str, firecast: i64, sb3: &serde_json::Value) -> anyhow::Result<()> {
    let theirs = sb3["parameters"].as_i64().unwrap_or(-1);
    if theirs != firecast {
        anyhow::bail!(
            "{part}: the SB3 policy has {theirs} parameters, FireCast's {firecast}: the networks \
             differ (the SB3 scripts in crates/firecast-rl/reference/ re-state policy.rs)"
        );
    }
    Ok(())
}

/// `firecast bench ppo`: FireCast's PPO beside SB3's in the same command, same network,
/// hyper-parameters and torch threads, in three phases: (a) CartPole with the MLP policy,
/// (b) the helitack environment with the compact policy (SB3 through the Python package),
/// (c) SB3 on the FireCastRL Python environment (with --reference-env).
pub fn bench_ppo(settings: &Settings, args: &BenchPpoArgs) -> anyhow::Result<ExitCode> {
    let python = firecast_dataset::bench::find_python(args.python.as_deref(), &settings.root);
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, std::num::NonZero::get))
        .max(1);
    let mut report = BenchPpoReport {
        parts: Vec::new(),
        skipped: Vec::new(),
    };
    if args.parts.contains(&BenchPart::A) {
        report.parts.push(bench_cartpole(args, &python)?);
    }
    let wants_b = args.parts.contains(&BenchPart::B);
    let wants_c = args.parts.contains(&BenchPart::C);
    if wants_b || wants_c {
        let ppo = bench_ppo_config(&args.set)?;
        let policy = firecast_rl::policy::PolicyConfig {
            kind: firecast_rl::policy::PolicyKind::Compact,
            ..Default::default()
        };
        firecast_learn::set_threads(threads);
        if wants_b {
            report
                .parts
                .push(bench_helitack(args, &python, &ppo, &policy, threads)?);
        }
        if wants_c {
            match &args.reference_env {
                Some(dir) => report.parts.push(bench_firecastrl(
                    settings, args, dir, &python, &ppo, &policy, threads,
                )?),
                None => report.skipped.push(
                    "(c) skipped: pass --reference-env DIR (a checkout of aisystems-lab/wildfire-env)".into(),
                ),
            }
        }
    }
    if settings.json {
        output::print_json(&report)?;
        return Ok(ExitCode::SUCCESS);
    }
    for (k, p) in report.parts.iter().enumerate() {
        if k > 0 {
            println!();
        }
        print_part(p);
    }
    for s in &report.skipped {
        println!("\n{s}");
    }
    Ok(ExitCode::SUCCESS)
}

fn print_part(p: &BenchPartReport) {
    let sb3_name = if p.part == BenchPart::C {
        "SB3 + FireCastRL"
    } else {
        "SB3"
    };
    let get = |k: &str| sb3_number(&p.sb3, k);
    let mut table = output::table(&[
        "phase (steps/s)",
        "FireCast",
        sb3_name,
        &format!("FireCast / {sb3_name}"),
    ]);
    let f = &p.firecast.speeds;
    for (name, ours, k) in [
        ("environment only", f.env_sps, "env"),
        ("rollout (env + inference)", f.rollout_sps, "rollout"),
        ("updates only (network)", f.update_sps, "update"),
        ("training (rollouts + updates)", f.train_sps, "train"),
    ] {
        let theirs = get(&format!("{k}_sps"));
        table.add_row(vec![
            name.to_string(),
            format!("{ours:.0}"),
            if theirs < 100.0 {
                format!("{theirs:.1}")
            } else {
                format!("{theirs:.0}")
            },
            format!("{:.1}x", p.ratios[k].as_f64().unwrap_or(f64::NAN)),
        ]);
    }
    println!("{}\n{table}", p.task);
    let train = p.ratios["train"].as_f64().unwrap_or(f64::NAN);
    let plain = |v: &serde_json::Value| v.as_str().map_or_else(|| v.to_string(), str::to_string);
    println!(
        "SB3 {} / torch {} / gymnasium {}; {} torch thread{} each; {} steps per phase; parameters: FireCast {}, SB3 {}",
        plain(&p.sb3["sb3"]),
        plain(&p.sb3["torch"]),
        plain(&p.sb3["gymnasium"]),
        p.threads,
        if p.threads == 1 { "" } else { "s" },
        p.steps,
        p.firecast.parameters,
        plain(&p.sb3["parameters"]),
    );
    let each: Vec<String> = p.train_ratios.iter().map(|r| format!("{r:.1}x")).collect();
    println!(
        "medians of {} alternating runs a side; training FireCast / {sb3_name} in each: {}",
        p.train_ratios.len(),
        each.join(", ")
    );
    println!(
        "ceiling: FireCast's updates alone run at {:.1}x {sb3_name}'s whole training, so no faster rollout takes training past that",
        p.ratios["train_ceiling"].as_f64().unwrap_or(f64::NAN)
    );
    println!(
        "goal: training >= {}x {sb3_name}: {} ({train:.1}x)",
        p.goal,
        if train >= p.goal { "met" } else { "not met" }
    );
    let w = &p.arithmetic;
    println!(
        "arithmetic: {:.2} MFLOP of convolutions and matrix products per training step (torch's count); \
         training runs at {:.1} GFLOP/s in FireCast, {:.1} in {sb3_name}; the goal needs {:.1} GFLOP/s, \
         {:.0} % of this machine's float32 matrix product ({:.0} GFLOP/s on {} thread{})",
        w.flops_per_step / 1e6,
        w.firecast_gflops,
        w.sb3_gflops,
        w.goal_gflops,
        100.0 * w.goal_gflops / w.sgemm_gflops,
        w.sgemm_gflops,
        p.threads,
        if p.threads == 1 { "" } else { "s" },
    );
}

fn bench_cartpole(args: &BenchPpoArgs, python: &Path) -> anyhow::Result<BenchPartReport> {
    let ppo = firecast_rl::ppo::PpoConfig::cartpole_zoo();
    firecast_learn::set_threads(1);
    eprintln!(
        "(a) FireCast PPO on CartPole-v1 ({} steps per phase, 1 thread) ...",
        args.steps
    );
    eprintln!(
        "(a) SB3 PPO on CartPole-v1 with the same settings ({}), alternating ...",
        python.display()
    );
    let cfg = serde_json::json!({
        "n_envs": ppo.n_envs, "steps": args.steps, "seed": args.seed, "n_steps": ppo.n_steps,
        "batch_size": ppo.batch_size, "n_epochs": ppo.n_epochs, "gamma": ppo.gamma,
        "gae_lambda": ppo.gae_lambda, "ent_coef": ppo.ent_coef,
        "learning_rate": ppo.learning_rate.at(1.0), "clip_range": ppo.clip_range.at(1.0),
    });
    let (firecast, sb3, train_ratios) = interleaved(
        args.repeats,
        || Ok(firecast_rl::bench::cartpole(&ppo, args.steps, args.seed)?),
        || run_sb3(python, firecast_rl::bench::SB3_SCRIPT, &cfg, 1),
    )?;
    check_parameters("(a)", firecast.parameters, &sb3)?;
    Ok(BenchPartReport::new(
        BenchPart::A,
        "(a) CartPole-v1, MLP policy, RL-Zoo settings (8 envs x 32 steps, batch 256, 20 epochs)".into(),
        args.steps,
        1,
        (firecast, sb3, train_ratios),
    ))
}

fn bench_helitack(
    args: &BenchPpoArgs,
    python: &Path,
    ppo: &firecast_rl::ppo::PpoConfig,
    policy: &firecast_rl::policy::PolicyConfig,
    threads: usize,
) -> anyhow::Result<BenchPartReport> {
    let pool = firecast_rl::bench::HelitackPool::demo_scale()?;
    let fires = pool.fires()?;
    eprintln!(
        "(b) FireCast PPO on the helitack environment ({} x {}, {} fires, compact policy, {} steps per phase, {threads} threads) ...",
        pool.width,
        pool.height,
        fires.len(),
        args.helitack_steps
    );
    eprintln!(
        "(b) SB3 PPO on firecast.HelitackVecEnv with the same network and settings ({}), alternating ...",
        python.display()
    );
    let env = serde_json::json!({"kind": "firecast", "kwargs": pool.python_kwargs()});
    let sides = helitack_sides(
        "(b)",
        &fires,
        HelitackSettings {
            ppo,
            policy,
            steps: args.helitack_steps,
            seed: args.seed,
            repeats: args.repeats,
            threads,
        },
        env,
        python,
    )?;
    Ok(BenchPartReport::new(
        BenchPart::B,
        format!(
            "(b) helitack, compact policy, {} x {} procedural landscapes {:?} x ignitions {:?}, paper preset ({} envs x {} steps, batch {}, {} epochs); SB3 through firecast.HelitackVecEnv",
            pool.width,
            pool.height,
            pool.landscape_seeds,
            pool.ignitions,
            ppo.n_envs,
            ppo.n_steps,
            ppo.batch_size,
            ppo.n_epochs
        ),
        args.helitack_steps,
        threads,
        sides,
    ))
}

/// What both sides of (b) and (c) share.
struct HelitackSettings<'a> {
    ppo: &'a firecast_rl::ppo::PpoConfig,
    policy: &'a firecast_rl::policy::PolicyConfig,
    steps: u64,
    seed: u64,
    repeats: u32,
    threads: usize,
}

/// (b) and (c): FireCast's PPO on `fires` and SB3's on `env` (the reference script's
/// environment), alternating; the networks must have the same parameter count.
fn helitack_sides(
    part: &str,
    fires: &[firecast_sim::env::EnvCore],
    s: HelitackSettings<'_>,
    env: serde_json::Value,
    python: &Path,
) -> anyhow::Result<(firecast_rl::bench::BenchRun, serde_json::Value, Vec<f64>)> {
    let cfg = helitack_sb3_config(s.ppo, s.policy, env, s.steps, s.seed, s.threads)?;
    let (firecast, sb3, train_ratios) = interleaved(
        s.repeats,
        || {
            Ok(firecast_rl::bench::helitack(
                fires,
                s.ppo,
                s.policy,
                s.steps,
                s.seed,
                firecast_rl::Device::Cpu,
            )?)
        },
        || run_sb3(python, firecast_rl::bench::SB3_HELITACK_SCRIPT, &cfg, s.threads),
    )?;
    check_parameters(part, firecast.parameters, &sb3)?;
    Ok((firecast, sb3, train_ratios))
}

fn bench_firecastrl(
    settings: &Settings,
    args: &BenchPpoArgs,
    env_dir: &Path,
    python: &Path,
    ppo: &firecast_rl::ppo::PpoConfig,
    policy: &firecast_rl::policy::PolicyConfig,
    threads: usize,
) -> anyhow::Result<BenchPartReport> {
    let maps = env_dir.join("firecastrl_env/envs/training_environments");
    let landscape = firecast_episodes::LandscapeSpec::Firecastrl {
        land_cover: maps.join("landcover_1.png"),
        heightmap: maps.join("heightmap_1.png"),
    }
    .load(&settings.root)
    .with_context(|| format!("loading the FireCastRL training map from {}", maps.display()))?;
    // The P2 engine's settings, under which `bench sim` finds FireCast's fires identical to
    // the FireCastRL environment's.
    let cfg = firecast_sim::reference::p2_parity_config();
    let fires = firecast_rl::bench::firecastrl_map(&landscape, &cfg)?;
    eprintln!(
        "(c) FireCast PPO on the FireCastRL training map ({} x {}, compact policy, {} steps per phase, {threads} threads) ...",
        landscape.width, landscape.height, args.reference_steps
    );
    let python = args.reference_python.as_deref().unwrap_or(python);
    eprintln!(
        "(c) SB3 PPO on the FireCastRL environment ({}) with the same network and settings ({}), alternating ...",
        env_dir.display(),
        python.display()
    );
    let dir = std::fs::canonicalize(env_dir).with_context(|| format!("{}", env_dir.display()))?;
    let env = serde_json::json!({"kind": "firecastrl", "dir": dir});
    let sides = helitack_sides(
        "(c)",
        &fires,
        HelitackSettings {
            ppo,
            policy,
            steps: args.reference_steps,
            seed: args.seed,
            repeats: args.repeats,
            threads,
        },
        env,
        python,
    )?;
    let vec_env = sides.1["vec_env"].as_str().unwrap_or("?").to_string();
    Ok(BenchPartReport::new(
        BenchPart::C,
        format!(
            "(c) FireCastRL training map ({} x {}), P2 engine, compact policy, paper preset ({} envs x {} steps, batch {}, {} epochs); SB3 on the FireCastRL Python environment ({}), FireCast on its own engine",
            landscape.width, landscape.height, ppo.n_envs, ppo.n_steps, ppo.batch_size, ppo.n_epochs, vec_env,
        ),
        args.reference_steps,
        threads,
        sides,
    ))
}
