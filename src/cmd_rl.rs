//! `firecast rl train|evaluate`: PPO training runs and Table IV, each run as a one-stage
//! pipeline (`rl.train`, `rl.evaluate`) so they are cached, registered and uploaded like
//! every other stage.

use std::path::PathBuf;
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
    /// The training spec.
    #[arg(long = "config", value_name = "FILE")]
    pub config: PathBuf,
    /// Override a key: `-S ppo.total_timesteps=20000`, `-S seeds=[0,1,2]` (value read as YAML).
    #[arg(short = 'S', long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Torch device: auto, cpu, cuda, cuda:N (overrides the spec's `device`).
    #[arg(long)]
    pub device: Option<String>,
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
    /// Do not record the best, median and worst PPO episodes.
    #[arg(long)]
    pub no_recordings: bool,
    #[arg(long, default_value = "auto")]
    pub device: String,
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
    let file = crate::cmd_pipeline::relative_to_root(settings, &args.config);
    let mut spec = TrainSpec::load(&settings.root, &file, &args.set)?;
    if let Some(device) = &args.device {
        spec.device = device.clone();
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
    if let Some(n) = args.stop_after {
        // SAFETY of set_var: single-threaded at this point (before the runner starts).
        #[allow(unsafe_code)]
        unsafe {
            std::env::set_var(firecast_rl::stage::STOP_AFTER_ENV, n.to_string());
        }
    }
    // A resumed or interrupted run must run, whatever the cache says.
    let (outcome, secs, run_id) = crate::cmd_pipeline::run_one_stage(
        settings,
        &file,
        "rl train",
        &spec.name,
        stage,
        None,
        args.force || args.fresh || has_checkpoint,
    )?;
    let summary: firecast_rl::run::TrainSummary = serde_json::from_slice(&std::fs::read(
        settings.root.join(&out).join(firecast_rl::run::SUMMARY_FILE),
    )?)?;
    if settings.json {
        output::print_json(&summary)?;
        return Ok(ExitCode::SUCCESS);
    }
    let mut table = output::table(&[
        "seed",
        "steps",
        "resumed from",
        "ep_rew_mean (last 100)",
        "ep_len_mean",
        "parameters",
    ]);
    for s in &summary.seeds {
        table.add_row(vec![
            s.seed.to_string(),
            s.timesteps.to_string(),
            s.resumed_from.map_or("-".into(), |r| r.to_string()),
            s.ep_rew_mean.map_or("-".into(), |v| format!("{v:.2}")),
            s.ep_len_mean.map_or("-".into(), |v| format!("{v:.1}")),
            s.parameters.to_string(),
        ]);
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
    };
    let stage = serde_json::json!({
        "uses": "rl.evaluate",
        "description": format!("Table IV for {}", run.display()),
        "params": serde_json::to_value(&params)?,
        "inputs": {"run": run.display().to_string(), "fires": fires.display().to_string()},
        "outputs": {"report": out.display().to_string()},
    });
    let (outcome, secs, run_id) =
        crate::cmd_pipeline::run_one_stage(settings, &fires, "rl evaluate", &name, stage, None, args.force)?;
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

#[derive(Debug, Args)]
pub struct BenchPpoArgs {
    /// Environment steps per phase.
    #[arg(long, default_value_t = 50_000)]
    pub steps: u64,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Python with stable-baselines3 [default: $FIRECAST_VENV, ./.venv, python3].
    #[arg(long, value_name = "PATH")]
    pub python: Option<PathBuf>,
}

#[derive(Debug, serde::Serialize)]
struct BenchPpoReport {
    task: &'static str,
    steps: u64,
    threads: usize,
    firecast: firecast_rl::bench::PhaseSpeeds,
    sb3: serde_json::Value,
    ratios: serde_json::Value,
}

/// `firecast bench ppo`: (a) CartPole-v1 with the MLP policy and RL-Zoo's settings,
/// FireCast beside SB3 in the same command, one torch thread each.
pub fn bench_ppo(settings: &Settings, args: &BenchPpoArgs) -> anyhow::Result<ExitCode> {
    let ppo = firecast_rl::ppo::PpoConfig::cartpole_zoo();
    firecast_learn::set_threads(1);
    eprintln!(
        "FireCast PPO on CartPole-v1 ({} steps per phase, 1 thread) ...",
        args.steps
    );
    let firecast = firecast_rl::bench::cartpole(&ppo, args.steps, args.seed)?;
    let python = firecast_dataset::bench::find_python(args.python.as_deref(), &settings.root);
    eprintln!(
        "SB3 PPO on CartPole-v1 with the same settings ({}) ...",
        python.display()
    );
    let lr = ppo.learning_rate.at(1.0);
    let clip = ppo.clip_range.at(1.0);
    let cfg = serde_json::json!({
        "n_envs": ppo.n_envs, "steps": args.steps, "seed": args.seed, "n_steps": ppo.n_steps,
        "batch_size": ppo.batch_size, "n_epochs": ppo.n_epochs, "gamma": ppo.gamma,
        "gae_lambda": ppo.gae_lambda, "ent_coef": ppo.ent_coef, "learning_rate": lr, "clip_range": clip,
    });
    let out = std::process::Command::new(&python)
        .arg("-c")
        .arg(firecast_rl::bench::SB3_SCRIPT)
        .arg(cfg.to_string())
        .env("OMP_NUM_THREADS", "1")
        .env("MKL_NUM_THREADS", "1")
        .output()
        .with_context(|| format!("running {}", python.display()))?;
    if !out.status.success() {
        anyhow::bail!(
            "the SB3 reference failed ({}): {}",
            python.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let sb3: serde_json::Value = serde_json::from_slice(
        out.stdout
            .split(|&b| b == b'\n')
            .rfind(|l| !l.is_empty())
            .unwrap_or_default(),
    )
    .context("the SB3 reference printed no JSON")?;
    let get = |k: &str| sb3.get(k).and_then(serde_json::Value::as_f64).unwrap_or(f64::NAN);
    let ratios = serde_json::json!({
        "env": firecast.env_sps / get("env_sps"),
        "rollout": firecast.rollout_sps / get("rollout_sps"),
        "train": firecast.train_sps / get("train_sps"),
    });
    let report = BenchPpoReport {
        task: "CartPole-v1, MLP policy, RL-Zoo settings (8 envs x 32 steps, batch 256, 20 epochs)",
        steps: args.steps,
        threads: 1,
        firecast,
        sb3: sb3.clone(),
        ratios: ratios.clone(),
    };
    if settings.json {
        output::print_json(&report)?;
        return Ok(ExitCode::SUCCESS);
    }
    let mut table = output::table(&["phase (steps/s)", "FireCast", "SB3", "FireCast / SB3"]);
    for (name, f, k) in [
        ("environment only", firecast.env_sps, "env"),
        ("rollout (env + inference)", firecast.rollout_sps, "rollout"),
        ("training (rollouts + updates)", firecast.train_sps, "train"),
    ] {
        table.add_row(vec![
            name.to_string(),
            format!("{f:.0}"),
            format!("{:.0}", get(&format!("{k}_sps"))),
            format!("{:.1}x", ratios[k].as_f64().unwrap_or(f64::NAN)),
        ]);
    }
    println!("{}\n{table}", report.task);
    println!(
        "SB3 {} / torch {} / gymnasium {}, one torch thread each; {} steps per phase",
        sb3["sb3"], sb3["torch"], sb3["gymnasium"], args.steps
    );
    Ok(ExitCode::SUCCESS)
}
