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
    /// The training spec (a YAML file, as `experiment run FILE` takes its spec).
    #[arg(value_name = "FILE", required_unless_present = "config")]
    pub file: Option<PathBuf>,
    /// The training spec, the older way to name it (same as FILE).
    #[arg(long = "config", value_name = "FILE", conflicts_with = "file", hide = true)]
    pub config: Option<PathBuf>,
    #[command(flatten)]
    pub spec: crate::settings::SpecArgs,
    /// Continue from the last checkpoint (an error if there is none).
    #[arg(long, conflicts_with = "fresh")]
    pub resume: bool,
    /// Discard the checkpoints of this spec and start over (runs even when nothing changed).
    #[arg(long)]
    pub fresh: bool,
    /// Stop every seed after this many steps, keeping checkpoints (resume later).
    #[arg(long, value_name = "STEPS")]
    pub stop_after: Option<u64>,
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
    /// Also fly the rollout search (agent `search`): before every move it plays each of the
    /// five actions on a copy of the fire, then the chaser for the rest of STEPS steps, and
    /// takes the action whose copy burns least.
    #[arg(long, value_name = "STEPS", num_args = 0..=1, default_missing_value = "40")]
    pub search: Option<u32>,
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
    let mut spec = TrainSpec::load(&settings.root, &file, &args.spec.set)?;
    if let Some(device) = &args.spec.device {
        spec.device = device.clone();
    }
    if let Some(threads) = args.spec.threads {
        spec.threads = threads;
    }
    let fires = firecast_rl::spec::fires_path(&spec).cloned();
    if let EnvSpec::Helitack { fires: f, .. } = &mut spec.env {
        if f.is_none() {
            anyhow::bail!(
                "{}: `env.fires`: the helitack environment needs a fire file",
                file.display()
            );
        }
        *f = None;
    }
    let out = args
        .spec
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
    if args.spec.dry_run {
        crate::settings::SpecArgs::print_stage(&stage)?;
        return Ok(ExitCode::SUCCESS);
    }
    let work = firecast_rl::run::work_dir(
        &settings.root,
        &spec,
        fires.as_ref().map(|f| settings.root.join(f)).as_deref(),
    )?;
    if args.fresh && work.exists() {
        std::fs::remove_dir_all(&work).with_context(|| format!("removing {}", work.display()))?;
    }
    let has_checkpoint = firecast_rl::run::has_unfinished_checkpoint(&work, &spec)?;
    if args.resume && !has_checkpoint {
        anyhow::bail!(
            "nothing to resume: no checkpoint of this spec in {} (a changed spec or fire file is a new run)",
            work.display()
        );
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
            force: args.spec.force || args.fresh || has_checkpoint,
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
            search: args.search.map(|horizon| firecast_sim::SearchConfig {
                horizon,
                ..Default::default()
            }),
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
