//! `firecast bench quality`: how long a researcher waits for a good helitack agent. Each side
//! trains from nothing and stamps a checkpoint of its policy every `--every` seconds of
//! training wall-clock (saving and evaluation are not on the clock); afterwards every stamp
//! is judged on the fire file's held-out fires beside the rule circle (paired by fire, the
//! 95 % bootstrap interval of Table IV) in FireCast's engine. Per seed: the first stamp whose
//! interval of policy − circle lies below zero ("beats the circle") and the first whose
//! reduction reaches `--target` (the paper's claimed 69 %).
//!
//! Sides: FireCast's recipe (`--config`, its own trainer and environment, `--budget` seconds a
//! seed); with `--control`, SB3 with the paper's settings (`--paper-config`) on
//! `firecast.HelitackVecEnv` over the same training fires; with `--reference-env`, the paper's
//! setup: SB3 with those settings on the FireCastRL Python environment, capped at the spec's
//! steps (300,000) and `--reference-budget` seconds. SB3's stamps are its policy's weights
//! (`crates/firecast-rl/reference/quality_sb3.py`, FireCast's compact network as
//! `firecast.CompactExtractor`), loaded into FireCast's policy and checked on a probe
//! observation before they are judged.

use std::cell::{Cell, RefCell};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use firecast_ppo::policy::ObsTensors;
use firecast_ppo::train::{TrainSink, Trainer};
use firecast_rl::ensemble::EnsemblePolicy;
use firecast_rl::evaluate::{EvalConfig, HeldOut, Judgement};
use firecast_rl::policy::{Policy, PolicyConfig};
use firecast_rl::run::TrainingFires;
use firecast_rl::spec::{EnvSpec, TrainSpec};
use serde::Serialize;
use tch::{Device, Kind, Tensor};

use crate::python::{Venv, find_python};
use crate::{Context, table};

/// SB3's side: trains and stamps checkpoints.
const QUALITY_SCRIPT: &str = include_str!("../../firecast-rl/reference/quality_sb3.py");
/// What it imports: the FireCastRL environment seen through FireCast's observation.
const HELITACK_SCRIPT: &str = include_str!("../../firecast-rl/reference/bench_sb3_helitack.py");

/// The goals of issue 31 item 1.
const GOAL_SECONDS: f64 = 300.0;
const GOAL_RATIO: f64 = 20.0;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// FireCast's recipe: a training spec (its fire file holds the held-out fires).
    #[arg(
        long,
        value_name = "FILE",
        default_value = "experiments/rl/best-agent-paper-map.yaml"
    )]
    pub config: PathBuf,
    /// Override a key of the recipe (`-S imitation.rounds=8`), as `rl train -S` does.
    #[arg(short = 'S', long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Training seeds of FireCast's recipe.
    #[arg(long, value_delimiter = ',', default_value = "0,1,2,3,4")]
    pub seeds: Vec<u64>,
    /// Seconds of training between stamps.
    #[arg(long, default_value_t = 30.0)]
    pub every: f64,
    /// Seconds of training a seed of FireCast's recipe (and of the control row) gets.
    #[arg(long, default_value_t = 300.0)]
    pub budget: f64,
    /// The reduction against the circle the second clock waits for (the paper's 69 %).
    #[arg(long, default_value_t = 0.69)]
    pub target: f64,
    /// The paper's setup for the SB3 rows: hyper-parameters, network, steps and reward.
    #[arg(
        long,
        value_name = "FILE",
        default_value = "experiments/rl/paper-settings.yaml"
    )]
    pub paper_config: PathBuf,
    /// Add the control row: SB3 with the paper's settings on `firecast.HelitackVecEnv` over
    /// the recipe's training fires (FireCast's environment, SB3's trainer).
    #[arg(long)]
    pub control: bool,
    /// Add the reference row: a checkout of aisystems-lab/wildfire-env (the folder holding
    /// `firecastrl_env`); SB3 with the paper's settings on that environment.
    #[arg(long, value_name = "DIR")]
    pub reference_env: Option<PathBuf>,
    /// Python with stable-baselines3 and the FireCastRL environment's dependencies
    /// [default: --python].
    #[arg(long, value_name = "PATH", requires = "reference_env")]
    pub reference_python: Option<PathBuf>,
    /// Seconds of training a seed of an SB3 row gets (it also stops at the paper's steps).
    #[arg(long, default_value_t = 1800.0)]
    pub reference_budget: f64,
    /// Seconds of training between an SB3 row's stamps [default: --every]. Each of its stamps
    /// costs a full evaluation (the compact network on the whole map is the slow part).
    #[arg(long)]
    pub reference_every: Option<f64>,
    /// Seeds of the SB3 rows [default: the first of --seeds].
    #[arg(long, value_delimiter = ',')]
    pub reference_seeds: Option<Vec<u64>>,
    /// Torch threads (and worker processes of the FireCastRL environment) of every side.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Bootstrap resamples of each stamp's paired interval.
    #[arg(long, default_value_t = 10_000)]
    pub resamples: usize,
    /// Python with stable-baselines3 and the firecast package [default: $FIRECAST_VENV, ./.venv].
    #[arg(long, value_name = "PATH")]
    pub python: Option<PathBuf>,
}

/// One stamped checkpoint and, once judged, how it did.
#[derive(Debug, Clone, Serialize)]
pub struct Stamp {
    /// Seconds of training when it was stamped.
    pub seconds: f64,
    /// PPO steps (imitation's steps apart).
    pub timesteps: u64,
    pub imitation_timesteps: u64,
    /// `None`: not judged (both clocks had already stopped at earlier stamps).
    pub judgement: Option<Judgement>,
}

/// One training seed of a side.
#[derive(Debug, Clone, Serialize)]
pub struct SeedRun {
    pub seed: u64,
    /// Seconds of training in all (the clock at the last stamp).
    pub trained_seconds: f64,
    pub stamps: Vec<Stamp>,
    /// Seconds of training at the first stamp that beats the circle.
    pub beats_circle_at: Option<f64>,
    /// Seconds of training at the first stamp reaching the target reduction.
    pub target_at: Option<f64>,
    /// The largest reduction against the circle any judged stamp reached.
    pub best_fewer: f64,
}

/// One row of the comparison.
#[derive(Debug, Clone, Serialize)]
pub struct Side {
    /// `firecast`, `control` or `reference`.
    pub name: String,
    pub label: String,
    pub detail: String,
    /// Seconds of training a seed was given.
    pub budget: f64,
    pub seeds: Vec<SeedRun>,
}

/// A time over seeds: the median, and whether it is only a lower bound (seeds that never
/// got there count as the time they trained, and the median is one of them).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct SeedTime {
    pub median: f64,
    pub lower_bound: bool,
    pub min: f64,
    pub max: f64,
    /// Seeds that got there.
    pub reached: usize,
}

/// `firecast bench quality`'s report.
#[derive(Debug, Serialize)]
pub struct QualityReport {
    pub fire_file: PathBuf,
    pub fires: usize,
    pub grid: [usize; 2],
    pub rule_cells_burned: f64,
    pub target: f64,
    pub every: f64,
    pub threads: usize,
    pub sides: Vec<Side>,
    pub skipped: Vec<String>,
}

/// Times every FireCast seed's recipe, then the SB3 rows asked for, and judges every stamp.
pub fn run(ctx: &Context, args: &Args) -> anyhow::Result<QualityReport> {
    if !(args.every > 0.0
        && args.budget > 0.0
        && args.reference_budget > 0.0
        && args.reference_every.is_none_or(|e| e > 0.0))
    {
        anyhow::bail!("--every, --budget, --reference-every and --reference-budget must be positive seconds");
    }
    if let Some(dir) = &args.reference_env
        && !ctx
            .root
            .join(dir)
            .join("firecastrl_env/envs/wildfire_env.py")
            .is_file()
    {
        anyhow::bail!(
            "--reference-env {}: no firecastrl_env/envs/wildfire_env.py there (a checkout of aisystems-lab/wildfire-env)",
            dir.display()
        );
    }
    let threads = args.threads.max(1);
    firecast_learn::set_threads(threads);
    let recipe_file = ctx.root.join(&args.config);
    let recipe = TrainSpec::load(&ctx.root, &recipe_file, &args.set)?;
    let fires_file = fire_file(&recipe, &recipe_file)?;
    let fires = firecast_rl::run::training_fires(&recipe, Some(&ctx.root.join(&fires_file)))?
        .context("the recipe trains no helitack agent")?;
    let eval = EvalConfig {
        resamples: args.resamples,
        recordings: false,
        ..EvalConfig::default()
    };
    eprintln!(
        "held-out fires of {}: the rule circle on each ...",
        fires_file.display()
    );
    let held_out = HeldOut::new(&fires.0, eval)?;
    let grid = [fires.0.evaluate.width, fires.0.evaluate.height];
    let mut report = QualityReport {
        fire_file: fires_file.clone(),
        fires: held_out.fires(),
        grid,
        rule_cells_burned: held_out.rule_cells_burned(),
        target: args.target,
        every: args.every,
        threads,
        sides: Vec::new(),
        skipped: Vec::new(),
    };
    let mut seeds = Vec::new();
    for &seed in &args.seeds {
        eprintln!(
            "FireCast's recipe {}, seed {seed}: {} s of training, a stamp every {} s ...",
            recipe.name, args.budget, args.every
        );
        let stamped = train_stamped(&recipe, &fires, seed, args)?;
        seeds.push(judge_stamps(
            seed,
            stamped
                .iter()
                .map(|s| (s.stamp.clone(), Source::Weights(&s.weights))),
            &recipe.policy(),
            &held_out,
            args.target,
        )?);
    }
    report.sides.push(Side {
        name: "firecast".into(),
        label: format!("FireCast {}", recipe.name),
        detail: recipe_detail(&recipe)?,
        budget: args.budget,
        seeds,
    });
    let wants_sb3 = args.control || args.reference_env.is_some();
    if !args.control {
        report
            .skipped
            .push("control row (SB3 on firecast.HelitackVecEnv): pass --control".into());
    }
    if args.reference_env.is_none() {
        report.skipped.push(
            "reference row (SB3 on the FireCastRL environment): pass --reference-env DIR (a checkout of aisystems-lab/wildfire-env)"
                .into(),
        );
    }
    if wants_sb3 {
        let python = find_python(args.python.as_deref(), &ctx.root, Venv::Project)?;
        let paper_file = ctx.root.join(&args.paper_config);
        let paper = TrainSpec::load(&ctx.root, &paper_file, &[])?;
        let scripts = tempfile_dir(&ctx.root)?;
        std::fs::write(scripts.path().join("quality_sb3.py"), QUALITY_SCRIPT)?;
        std::fs::write(scripts.path().join("bench_sb3_helitack.py"), HELITACK_SCRIPT)?;
        if args.control {
            // The paper's setup on FireCast's environment: the paper spec's fire file and
            // reward (P2), not the recipe's.
            let paper_fires = firecast_rl::run::training_fires(
                &paper,
                Some(&ctx.root.join(fire_file(&paper, &paper_file)?)),
            )?
            .context("the paper's setup trains no helitack agent")?;
            // The reward does not change what burns.
            let unrewarded = |f: &TrainingFires| {
                let mut set = f.0.evaluate.clone();
                set.env.reward = firecast_sim::RewardWeights::default();
                set
            };
            anyhow::ensure!(
                unrewarded(&paper_fires) == unrewarded(&fires),
                "{}: its fire file's held-out fires differ from the recipe's: the rows would not be judged alike",
                paper_file.display()
            );
            let env =
                serde_json::json!({"kind": "firecast", "kwargs": {"fires": python_fires(&paper_fires)?}});
            report.sides.push(sb3_side(
                "control",
                "SB3 on firecast.HelitackVecEnv",
                &paper,
                env,
                &python,
                scripts.path(),
                &held_out,
                grid,
                args,
            )?);
        }
        if let Some(dir) = &args.reference_env {
            let dir = ctx.root.join(dir);
            let dir = std::fs::canonicalize(&dir).with_context(|| dir.display().to_string())?;
            let python = args.reference_python.clone().unwrap_or_else(|| python.clone());
            let env = serde_json::json!({"kind": "firecastrl", "dir": dir});
            report.sides.push(sb3_side(
                "reference",
                "SB3 + FireCastRL (the paper's setup)",
                &paper,
                env,
                &python,
                scripts.path(),
                &held_out,
                grid,
                args,
            )?);
        }
    }
    Ok(report)
}

/// The fire file a helitack recipe trains on, root-relative as the spec names it.
fn fire_file(spec: &TrainSpec, file: &Path) -> anyhow::Result<PathBuf> {
    match &spec.env {
        EnvSpec::Helitack { fires: Some(f), .. } => Ok(f.clone()),
        _ => anyhow::bail!(
            "{}: `env.fires`: bench quality times helitack recipes, which name a fire file",
            file.display()
        ),
    }
}

fn recipe_detail(spec: &TrainSpec) -> anyhow::Result<String> {
    let ppo = spec.ppo()?;
    let imitation = spec.imitation.as_ref().map_or_else(String::new, |i| {
        format!("{} rounds imitating the {:?} teacher, then ", i.rounds, i.teacher).to_lowercase()
    });
    Ok(format!(
        "{imitation}{} PPO steps ({} envs x {} steps, batch {}, {} epochs), {} policy",
        ppo.total_timesteps,
        ppo.n_envs,
        ppo.n_steps,
        ppo.batch_size,
        ppo.n_epochs,
        format!("{:?}", spec.policy().kind).to_lowercase()
    ))
}

/// A scratch folder for the SB3 scripts and stamps, removed when dropped.
fn tempfile_dir(root: &Path) -> anyhow::Result<firecast_fs::TempPath> {
    let dest = root.join(".firecast/bench-quality");
    std::fs::create_dir_all(root.join(".firecast"))?;
    // What an interrupted run left (its process is gone).
    firecast_fs::remove_stale(&root.join(".firecast"));
    firecast_fs::TempPath::dir(&dest).map_err(|e| anyhow::anyhow!("{}: {}", e.path.display(), e.source))
}

/// A stamp of FireCast's own trainer and the weights it copied then.
struct Stamped {
    stamp: Stamp,
    weights: Vec<Tensor>,
}

/// Where a stamp's weights are.
enum Source<'a> {
    /// Copies of the trainer's variables, in name order.
    Weights(&'a [Tensor]),
    /// An SB3 checkpoint (safetensors with the policy's names).
    File(PathBuf),
}

/// The training clock: a [`TrainSink`] that copies the policy's weights whenever `every`
/// seconds of training have passed since the last copy and asks training to stop at the
/// budget. Copying is taken off the clock.
struct Clock<'a> {
    started: Instant,
    off_clock: Cell<f64>,
    every: f64,
    budget: f64,
    vars: &'a [Tensor],
    imitation_timesteps: Cell<u64>,
    stamps: RefCell<Vec<Stamped>>,
    stop: Cell<bool>,
}

impl Clock<'_> {
    fn seconds(&self) -> f64 {
        self.started.elapsed().as_secs_f64() - self.off_clock.get()
    }

    fn stamp(&self, timesteps: u64) {
        let t0 = Instant::now();
        let seconds = self.seconds();
        let weights = tch::no_grad(|| self.vars.iter().map(Tensor::copy).collect());
        self.stamps.borrow_mut().push(Stamped {
            stamp: Stamp {
                seconds,
                timesteps,
                imitation_timesteps: self.imitation_timesteps.get(),
                judgement: None,
            },
            weights,
        });
        self.off_clock
            .set(self.off_clock.get() + t0.elapsed().as_secs_f64());
        eprintln!(
            "    stamp {} at {seconds:.1} s ({} imitation + {timesteps} PPO steps)",
            self.stamps.borrow().len(),
            self.imitation_timesteps.get()
        );
    }

    /// After an imitation round or a PPO update.
    fn tick(&self, timesteps: u64) {
        let seconds = self.seconds();
        let due = self.every * (self.stamps.borrow().len() + 1) as f64;
        if seconds >= due || seconds >= self.budget {
            self.stamp(timesteps);
        }
        if seconds >= self.budget {
            self.stop.set(true);
        }
    }
}

impl TrainSink for Clock<'_> {
    fn update(&self, timesteps: u64, _metrics: &[(String, f64)]) {
        self.tick(timesteps);
    }
    fn imitation(&self, imitation_timesteps: u64, _metrics: &[(String, f64)]) {
        self.imitation_timesteps.set(imitation_timesteps);
        self.tick(0);
    }
    fn should_stop(&self) -> bool {
        self.stop.get()
    }
}

/// Trains one seed of the recipe from nothing for the budget, stamping as it goes; the
/// clock starts before the environments are built.
fn train_stamped(
    spec: &TrainSpec,
    fires: &TrainingFires,
    seed: u64,
    args: &Args,
) -> anyhow::Result<Vec<Stamped>> {
    let started = Instant::now();
    let ppo = spec.ppo()?;
    if ppo.normalize.obs {
        anyhow::bail!(
            "{}: observation normalisation is on; bench quality judges a stamp's weights alone",
            spec.name
        );
    }
    let env = firecast_rl::run::train_env(spec, Some(fires), ppo.n_envs, seed)?;
    let mut trainer = Trainer::<PolicyConfig>::new(ppo, &spec.policy(), env, seed, Device::Cpu)?;
    let vars = sorted_variables(&trainer.policy);
    let clock = Clock {
        started,
        off_clock: Cell::new(0.0),
        every: args.every,
        budget: args.budget,
        vars: &vars,
        imitation_timesteps: Cell::new(0),
        stamps: RefCell::new(Vec::new()),
        stop: Cell::new(false),
    };
    if let Some(cfg) = &spec.imitation {
        let mut teacher = firecast_rl::imitation::teacher(cfg.teacher, trainer.policy.space)?;
        trainer.imitate(cfg, teacher.as_mut(), &clock)?;
        trainer.kickstart(teacher, cfg.kickstart)?;
    }
    if !clock.stop.get() {
        trainer.learn_until(&clock, None, None)?;
    }
    // The recipe's end before the budget's: its final policy is a stamp too.
    let last = clock.stamps.borrow().last().map(|s| s.stamp.timesteps);
    if last != Some(trainer.num_timesteps) || clock.stamps.borrow().is_empty() {
        clock.stamp(trainer.num_timesteps);
    }
    Ok(clock.stamps.into_inner())
}

/// A policy's variables in name order.
fn sorted_variables(policy: &Policy) -> Vec<Tensor> {
    let mut vars: Vec<(String, Tensor)> = policy.vs.variables().into_iter().collect();
    vars.sort_by(|a, b| a.0.cmp(&b.0));
    vars.into_iter().map(|(_, t)| t).collect()
}

/// Judges stamps in order until both clocks have stopped (later stamps stay unjudged).
fn judge_stamps<'a>(
    seed: u64,
    stamps: impl Iterator<Item = (Stamp, Source<'a>)>,
    policy_cfg: &PolicyConfig,
    held_out: &HeldOut,
    target: f64,
) -> anyhow::Result<SeedRun> {
    let mut run = SeedRun {
        seed,
        trained_seconds: 0.0,
        stamps: Vec::new(),
        beats_circle_at: None,
        target_at: None,
        best_fewer: f64::NAN,
    };
    let mut judged_policy: Option<EnsemblePolicy> = None;
    for (mut stamp, source) in stamps {
        run.trained_seconds = stamp.seconds;
        if run.beats_circle_at.is_some() && run.target_at.is_some() {
            run.stamps.push(stamp);
            continue;
        }
        let p = match &mut judged_policy {
            Some(p) => p,
            None => judged_policy.insert(EnsemblePolicy {
                seed,
                policy: held_out_policy(policy_cfg, held_out)?,
                normalize: None,
            }),
        };
        load_weights(&mut p.policy, &source)?;
        let j = held_out.judge(p)?;
        eprintln!(
            "    seed {seed}, stamp at {:.1} s: {:.0} cells, circle − policy {:+.0} [{:+.0}, {:+.0}], {:.1} % fewer",
            stamp.seconds,
            j.cells_burned,
            -j.comparison.cells_burned_diff.estimate,
            -j.comparison.cells_burned_diff.high,
            -j.comparison.cells_burned_diff.low,
            100.0 * j.fewer()
        );
        if run.beats_circle_at.is_none() && j.beats_rule() {
            run.beats_circle_at = Some(stamp.seconds);
        }
        if run.target_at.is_none() && j.fewer() >= target {
            run.target_at = Some(stamp.seconds);
        }
        // NaN until the first judged stamp.
        run.best_fewer = run.best_fewer.max(j.fewer());
        stamp.judgement = Some(j);
        run.stamps.push(stamp);
    }
    Ok(run)
}

/// A fresh policy of `cfg` for the held-out fires' grid.
fn held_out_policy(cfg: &PolicyConfig, held_out: &HeldOut) -> anyhow::Result<Policy> {
    let [w, h] = held_out.grid();
    Ok(Policy::new(
        cfg,
        firecast_rl::helitack::space(w, h),
        5,
        Device::Cpu,
    )?)
}

fn load_weights(policy: &mut Policy, source: &Source<'_>) -> anyhow::Result<()> {
    match source {
        Source::Weights(weights) => {
            let vars = sorted_variables(policy);
            anyhow::ensure!(vars.len() == weights.len(), "a stamp of another network");
            tch::no_grad(|| {
                for (mut v, w) in vars.into_iter().zip(weights.iter()) {
                    v.copy_(w);
                }
            });
        }
        Source::File(path) => policy
            .vs
            .load(path)
            .with_context(|| format!("loading the SB3 stamp {}", path.display()))?,
    }
    Ok(())
}

/// The recipe's training fires as `firecast.HelitackVecEnv(fires=...)` takes them.
fn python_fires(fires: &TrainingFires) -> anyhow::Result<serde_json::Value> {
    let (spec, draws, _) = fires;
    let set = &spec.train;
    let mut out = Vec::with_capacity(draws.len());
    for d in draws {
        let (_, cfg) = set.fire(d)?;
        out.push(serde_json::json!({
            "landscape": {"procedural": {"seed": d.landscape_seed, "width": set.width, "height": set.height}},
            "config": serde_json::to_value(&cfg)?,
        }));
    }
    Ok(serde_json::Value::Array(out))
}

/// One SB3 row: each seed trained by quality_sb3.py, its stamps judged here.
#[allow(clippy::too_many_arguments)]
fn sb3_side(
    name: &str,
    label: &str,
    paper: &TrainSpec,
    env: serde_json::Value,
    python: &Path,
    scripts: &Path,
    held_out: &HeldOut,
    grid: [usize; 2],
    args: &Args,
) -> anyhow::Result<Side> {
    let ppo = paper.ppo()?;
    let policy = paper.policy();
    let steps = ppo.total_timesteps;
    let mut seeds = Vec::new();
    let seed_list = args
        .reference_seeds
        .clone()
        .unwrap_or_else(|| args.seeds.iter().take(1).copied().collect());
    let mut versions = String::new();
    for seed in seed_list {
        let out = scripts.join(format!("{name}-seed-{seed}"));
        let cfg = serde_json::json!({
            "ppo": serde_json::to_value(&ppo)?,
            "policy": serde_json::to_value(&policy)?,
            "env": env,
            "steps": steps,
            "seconds": args.reference_budget,
            "every": args.reference_every.unwrap_or(args.every),
            "seed": seed,
            "threads": args.threads.max(1),
            "out": out,
            "width": grid[0],
            "height": grid[1],
        });
        eprintln!(
            "{label}, seed {seed}: up to {steps} steps or {} s of training, a stamp every {} s ({}) ...",
            args.reference_budget,
            args.reference_every.unwrap_or(args.every),
            python.display()
        );
        let result = run_script(python, scripts, &cfg, args.threads.max(1))?;
        versions = result["versions"].as_str().unwrap_or("").to_string();
        let mut policy_probe = held_out_policy(&policy, held_out)?;
        let ours = policy_probe.parameter_count();
        let theirs = result["parameters"].as_i64().unwrap_or(-1);
        anyhow::ensure!(
            theirs == ours,
            "{label}: SB3's policy has {theirs} parameters, FireCast's {ours}: the networks differ"
        );
        let stamps: Vec<(Stamp, PathBuf)> = result["checkpoints"]
            .as_array()
            .context("quality_sb3.py printed no checkpoints")?
            .iter()
            .map(|c| {
                Ok((
                    Stamp {
                        seconds: c["seconds"].as_f64().context("seconds")?,
                        timesteps: c["timesteps"].as_u64().context("timesteps")?,
                        imitation_timesteps: 0,
                        judgement: None,
                    },
                    out.join(c["file"].as_str().context("file")?),
                ))
            })
            .collect::<anyhow::Result<_>>()?;
        // The last stamp acts in FireCast's engine as it acted in SB3.
        let last = &stamps.last().context("quality_sb3.py stamped nothing")?.1;
        load_weights(&mut policy_probe, &Source::File(last.clone()))?;
        check_probe(&policy_probe, &result["probe"], grid, label)?;
        seeds.push(judge_stamps(
            seed,
            stamps.into_iter().map(|(s, p)| (s, Source::File(p))),
            &policy,
            held_out,
            args.target,
        )?);
    }
    Ok(Side {
        name: name.into(),
        label: label.into(),
        detail: format!(
            "paper preset ({} envs x {} steps, batch {}, {} epochs), {} policy, at most {steps} steps; {versions}",
            ppo.n_envs,
            ppo.n_steps,
            ppo.batch_size,
            ppo.n_epochs,
            format!("{:?}", policy.kind).to_lowercase()
        ),
        budget: args.reference_budget,
        seeds,
    })
}

/// Runs quality_sb3.py (stderr passed through: its progress) and returns its last JSON line.
fn run_script(
    python: &Path,
    scripts: &Path,
    cfg: &serde_json::Value,
    threads: usize,
) -> anyhow::Result<serde_json::Value> {
    let path = match std::env::var_os("PYTHONPATH") {
        Some(p) if !p.is_empty() => {
            let mut v = std::ffi::OsString::from(scripts);
            v.push(":");
            v.push(p);
            v
        }
        _ => scripts.as_os_str().to_owned(),
    };
    let out = std::process::Command::new(python)
        .arg(scripts.join("quality_sb3.py"))
        .arg(cfg.to_string())
        .env("PYTHONPATH", path)
        .env("OMP_NUM_THREADS", threads.to_string())
        .env("MKL_NUM_THREADS", threads.to_string())
        .stderr(std::process::Stdio::inherit())
        .output()
        .with_context(|| format!("running {}", python.display()))?;
    if !out.status.success() {
        anyhow::bail!(
            "the SB3 side failed ({}, {}); its error is printed above",
            python.display(),
            out.status
        );
    }
    let line = out
        .stdout
        .split(|&b| b == b'\n')
        .rfind(|l| !l.is_empty())
        .unwrap_or_default();
    serde_json::from_slice(line).context("quality_sb3.py printed no JSON line")
}

/// The probe observation of quality_sb3.py: codes (7x + 3y + frame) mod 10, the helicopter
/// at (w/3, h/2), on fire.
fn check_probe(
    policy: &Policy,
    probe: &serde_json::Value,
    [w, h]: [usize; 2],
    label: &str,
) -> anyhow::Result<()> {
    let space = firecast_rl::helitack::space(w, h);
    let mut frames = vec![0u8; 4 * w * h];
    for f in 0..4 {
        for y in 0..h {
            for x in 0..w {
                frames[(f * h + y) * w + x] = ((7 * x + 3 * y + f) % 10) as u8;
            }
        }
    }
    let mut obs = firecast_ppo::env::ObsBatch::new(space, 1);
    let agent = [(w / 3) as i32, (h / 2) as i32];
    firecast_rl::helitack::encode(&frames, agent, true, w, h, &mut obs.image, &mut obs.vector);
    let (logits, value) = tch::no_grad(|| policy.forward(&ObsTensors::from_batch(&obs, Device::Cpu), false));
    let ours: Vec<f64> = Vec::<f32>::try_from(logits.log_softmax(-1, Kind::Float).flatten(0, -1))?
        .into_iter()
        .map(f64::from)
        .collect();
    let value = f64::try_from(value.flatten(0, -1).get(0))?;
    let theirs: Vec<f64> = probe["log_probs"]
        .as_array()
        .context("the probe's log-probabilities")?
        .iter()
        .filter_map(serde_json::Value::as_f64)
        .collect();
    let their_value = probe["value"].as_f64().context("the probe's value")?;
    let worst = ours
        .iter()
        .zip(&theirs)
        .map(|(a, b)| (a - b).abs())
        .fold((value - their_value).abs(), f64::max);
    anyhow::ensure!(
        ours.len() == theirs.len() && worst <= 1e-4,
        "{label}: the SB3 stamp loaded into FireCast's policy gives the probe {ours:?} (value {value}), SB3 gave {theirs:?} (value {their_value}): the networks do not compute the same thing"
    );
    Ok(())
}

impl SeedTime {
    /// Over seeds: the time each got there, or (a lower bound) the time it trained.
    fn of(seeds: &[SeedRun], at: impl Fn(&SeedRun) -> Option<f64>) -> Option<Self> {
        let mut v: Vec<(f64, bool)> = seeds
            .iter()
            .map(|s| at(s).map_or((s.trained_seconds, true), |t| (t, false)))
            .collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        // The upper median: with seeds censored, the lower one could hide a censored value.
        let (median, lower_bound) = v[v.len() / 2];
        Some(Self {
            median,
            lower_bound,
            min: v[0].0,
            max: v[v.len() - 1].0,
            reached: v.iter().filter(|x| !x.1).count(),
        })
    }

    fn show(self, n: usize) -> String {
        let bound = if self.lower_bound { "> " } else { "" };
        format!(
            "{bound}{:.0} s [{:.0}, {:.0}] ({}/{n} seeds)",
            self.median, self.min, self.max, self.reached
        )
    }
}

impl Side {
    fn beats(&self) -> Option<SeedTime> {
        SeedTime::of(&self.seeds, |s| s.beats_circle_at)
    }
    fn target(&self) -> Option<SeedTime> {
        SeedTime::of(&self.seeds, |s| s.target_at)
    }
}

/// How much longer `slow` waits than `fast`: the ratio, and whether it is only a lower bound;
/// `None` when FireCast's own time is only a bound.
fn ratio(fast: Option<SeedTime>, slow: Option<SeedTime>) -> Option<(f64, bool)> {
    let (f, s) = (fast?, slow?);
    (!f.lower_bound && f.median > 0.0).then(|| (s.median / f.median, s.lower_bound))
}

impl crate::Report for QualityReport {
    fn render(&self) -> String {
        let mut out = String::new();
        let _ = self.write(&mut out);
        out
    }
}

impl QualityReport {
    fn side(&self, name: &str) -> Option<&Side> {
        self.sides.iter().find(|s| s.name == name)
    }

    fn write(&self, out: &mut String) -> std::fmt::Result {
        writeln!(
            out,
            "Time to quality on the {} held-out {} x {} fires of {} (rule circle: {:.0} cells burned); a stamp every {} s of training, {} torch threads",
            self.fires,
            self.grid[0],
            self.grid[1],
            self.fire_file.display(),
            self.rule_cells_burned,
            self.every,
            self.threads
        )?;
        let mut t = table(&[
            "side",
            "seed",
            "trained (s)",
            "beats the circle at (s)",
            &format!("{:.0} % fewer at (s)", 100.0 * self.target),
            "best: % fewer than the circle",
            "last stamp: cells, % fewer [95 %]",
        ]);
        for side in &self.sides {
            for s in &side.seeds {
                let last = s.stamps.iter().rev().find_map(|x| x.judgement.as_ref());
                let when = |t: Option<f64>| {
                    t.map_or_else(
                        || format!("not by {:.0}", s.trained_seconds),
                        |t| format!("{t:.0}"),
                    )
                };
                t.add_row(vec![
                    side.label.clone(),
                    s.seed.to_string(),
                    format!("{:.0}", s.trained_seconds),
                    when(s.beats_circle_at),
                    when(s.target_at),
                    format!("{:.1}", 100.0 * s.best_fewer),
                    last.map_or("-".into(), |j| {
                        let r = &j.comparison.relative_reduction;
                        format!(
                            "{:.0}, {:.1} [{:.1}, {:.1}]",
                            j.cells_burned,
                            100.0 * r.estimate,
                            100.0 * r.low,
                            100.0 * r.high
                        )
                    }),
                ]);
            }
        }
        writeln!(out, "{t}")?;
        for side in &self.sides {
            let n = side.seeds.len();
            writeln!(
                out,
                "{}: {}; median over seeds: beats the circle {}, {:.0} % fewer {}",
                side.label,
                side.detail,
                side.beats().map_or("-".into(), |x| x.show(n)),
                100.0 * self.target,
                side.target().map_or("-".into(), |x| x.show(n)),
            )?;
        }
        for s in &self.skipped {
            writeln!(out, "{s}")?;
        }
        let firecast = self.side("firecast");
        let ours = firecast.and_then(Side::beats);
        for (name, what) in [
            ("reference", "SB3 + FireCastRL"),
            ("control", "SB3 on FireCast's environment"),
        ] {
            if let Some(side) = self.side(name) {
                let line = match ratio(ours, side.beats()) {
                    Some((r, true)) => {
                        format!("at least {r:.1}x (it never beat the circle in the time it had)")
                    }
                    Some((r, false)) => format!("{r:.1}x"),
                    None => "not defined (FireCast's median is only a bound)".into(),
                };
                writeln!(out, "time to beat the circle, {what} / FireCast: {line}")?;
            }
        }
        let seconds_goal = firecast.is_some_and(|s| {
            !s.seeds.is_empty()
                && s.seeds
                    .iter()
                    .all(|x| x.beats_circle_at.is_some_and(|t| t <= GOAL_SECONDS))
        });
        writeln!(
            out,
            "goal: beat the circle in <= {GOAL_SECONDS:.0} s a seed: {}",
            if seconds_goal { "met" } else { "not met" }
        )?;
        let ratio_goal = match ratio(ours, self.side("reference").and_then(Side::beats)) {
            Some((r, _)) if r >= GOAL_RATIO => "met".to_string(),
            Some((r, true)) => {
                format!("not shown (at least {r:.1}x: give the reference a longer --reference-budget)")
            }
            Some((r, false)) => format!("not met ({r:.1}x)"),
            None if self.side("reference").is_none() => "not measured (pass --reference-env)".into(),
            None => "not measured (FireCast's median is only a bound)".into(),
        };
        writeln!(
            out,
            "goal: >= {GOAL_RATIO:.0}x less wall-clock than SB3 + FireCastRL: {ratio_goal}"
        )?;
        let best = firecast.map_or(f64::NAN, |s| {
            s.seeds.iter().map(|x| x.best_fewer).fold(f64::NAN, f64::max)
        });
        writeln!(
            out,
            "goal: reach {:.0} % fewer cells than the circle at all: {} (best stamp {:.1} %)",
            100.0 * self.target,
            if best >= self.target { "met" } else { "not met" },
            100.0 * best
        )
    }
}
