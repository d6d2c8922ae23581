//! `firecast bench ppo`: FireCast's PPO beside Stable-Baselines3's in the same command, same
//! network, hyper-parameters and torch threads: (a) CartPole with the MLP policy, (b) the
//! helitack environment with the compact policy (SB3 through the Python package), (c) SB3 on
//! the FireCastRL Python environment (with --reference-env). FireCast's timed phases are in
//! [`phases`].

pub mod phases;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context as _;

use crate::Context;
use crate::python::{Venv, find_python};

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

#[derive(Debug, clap::Args)]
pub struct Args {
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
    /// [default: $FIRECAST_VENV, ./.venv].
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
pub struct BenchPartReport {
    part: BenchPart,
    task: String,
    steps: u64,
    threads: usize,
    /// Each phase's median over the repeats.
    firecast: phases::BenchRun,
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
pub struct Arithmetic {
    /// Convolution, matrix-product and recurrent FLOPs per environment step of training (one
    /// forward pass in the rollout, n_epochs forward + backward passes in the updates): torch's
    /// count, plus the recurrent layers its counter does not see, counted from their shapes.
    flops_per_step: f64,
    /// The recurrent layers' part of it.
    recurrent_flops_per_step: f64,
    /// GFLOP/s those steps amount to at each side's training speed.
    firecast_gflops: f64,
    sb3_gflops: f64,
    /// GFLOP/s FireCast's training would need to meet the goal.
    goal_gflops: f64,
    /// This machine's float32 matrix-product rate at the part's torch threads.
    sgemm_gflops: f64,
    /// Its bfloat16 matrix-product rate (NaN where the reference did not measure it).
    bf16_gflops: f64,
    /// The faster of the two: the yardstick.
    peak_gflops: f64,
    /// Which kernel that is: "float32" or "bfloat16".
    peak_kernel: &'static str,
}

impl BenchPartReport {
    /// The report of `part` from both sides' medians and each repeat's training ratio; the
    /// ratios, the goal and the arithmetic follow from them.
    fn new(
        part: BenchPart,
        task: String,
        steps: u64,
        threads: usize,
        (firecast, sb3, train_ratios): (phases::BenchRun, serde_json::Value, Vec<f64>),
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
    fn new(firecast: &phases::PhaseSpeeds, sb3: &serde_json::Value, goal: f64) -> Self {
        let flops = sb3_number(sb3, "flops_per_step");
        let sb3_train = sb3_number(sb3, "train_sps");
        let (sgemm, bf16) = (sb3_number(sb3, "sgemm_gflops"), sb3_number(sb3, "bf16_gflops"));
        Self {
            flops_per_step: flops,
            firecast_gflops: firecast.train_sps * flops / 1e9,
            sb3_gflops: sb3_train * flops / 1e9,
            goal_gflops: goal * sb3_train * flops / 1e9,
            sgemm_gflops: sgemm,
            bf16_gflops: bf16,
            peak_gflops: if bf16 > sgemm { bf16 } else { sgemm },
            peak_kernel: if bf16 > sgemm { "bfloat16" } else { "float32" },
            recurrent_flops_per_step: sb3_number(sb3, "recurrent_flops_per_step"),
        }
    }
}

/// `firecast bench ppo`'s report: every part run and the parts skipped.
#[derive(Debug, serde::Serialize)]
pub struct BenchPpoReport {
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
        .arg(format!("{}\n{script}", phases::NETWORK_WORK))
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

fn progress_line(run: &phases::BenchRun) {
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
    mut firecast: impl FnMut() -> anyhow::Result<phases::BenchRun>,
    mut sb3: impl FnMut() -> anyhow::Result<serde_json::Value>,
) -> anyhow::Result<(phases::BenchRun, serde_json::Value, Vec<f64>)> {
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
    run.speeds = phases::PhaseSpeeds {
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
        "bf16_gflops",
    ] {
        sb3[k] = serde_json::json!(median(theirs.iter().map(|t| sb3_number(t, k)).collect()));
    }
    Ok((run, sb3, train_ratios))
}

fn ratios(firecast: &phases::PhaseSpeeds, sb3: &serde_json::Value) -> serde_json::Value {
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
fn bench_ppo_config(set: &[String]) -> anyhow::Result<firecast_ppo::ppo::PpoConfig> {
    let mut overrides = serde_json::Map::new();
    for kv in set {
        let (k, v) = kv
            .split_once('=')
            .with_context(|| format!("-S {kv}: expected KEY=VALUE"))?;
        let value: serde_json::Value =
            serde_yaml_ng::from_str(v).with_context(|| format!("-S {kv}: the value is not YAML"))?;
        overrides.insert(k.trim().trim_start_matches("ppo.").to_string(), value);
    }
    Ok(firecast_ppo::ppo::PpoConfig::resolve("paper", &overrides)?)
}

/// The SB3 side's settings for (b) and (c): every PPO value, the policy, the environment.
fn helitack_sb3_config(
    ppo: &firecast_ppo::ppo::PpoConfig,
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
pub fn run(ctx: &Context, args: &Args) -> anyhow::Result<BenchPpoReport> {
    let python = find_python(args.python.as_deref(), &ctx.root, Venv::Project)?;
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
                Some(dir) => report
                    .parts
                    .push(bench_firecastrl(ctx, args, dir, &python, &ppo, &policy, threads)?),
                None => report.skipped.push(
                    "(c) skipped: pass --reference-env DIR (a checkout of aisystems-lab/wildfire-env)".into(),
                ),
            }
        }
    }
    Ok(report)
}

impl crate::Report for BenchPpoReport {
    fn render(&self) -> String {
        let mut out = String::new();
        let _ = self.write(&mut out);
        out
    }
}

impl BenchPpoReport {
    fn write(&self, out: &mut String) -> std::fmt::Result {
        for (k, p) in self.parts.iter().enumerate() {
            if k > 0 {
                writeln!(out)?;
            }
            print_part(out, p)?;
        }
        for s in &self.skipped {
            writeln!(out, "\n{s}")?;
        }
        Ok(())
    }
}

fn print_part(out: &mut String, p: &BenchPartReport) -> std::fmt::Result {
    let sb3_name = if p.part == BenchPart::C {
        "SB3 + FireCastRL"
    } else {
        "SB3"
    };
    let get = |k: &str| sb3_number(&p.sb3, k);
    let mut table = crate::table(&[
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
    writeln!(out, "{}\n{table}", p.task)?;
    let train = p.ratios["train"].as_f64().unwrap_or(f64::NAN);
    let plain = |v: &serde_json::Value| v.as_str().map_or_else(|| v.to_string(), str::to_string);
    writeln!(
        out,
        "SB3 {} / torch {} / gymnasium {}; {} torch thread{} each; {} steps per phase; parameters: FireCast {}, SB3 {}",
        plain(&p.sb3["sb3"]),
        plain(&p.sb3["torch"]),
        plain(&p.sb3["gymnasium"]),
        p.threads,
        if p.threads == 1 { "" } else { "s" },
        p.steps,
        p.firecast.parameters,
        plain(&p.sb3["parameters"]),
    )?;
    let each: Vec<String> = p.train_ratios.iter().map(|r| format!("{r:.1}x")).collect();
    writeln!(
        out,
        "medians of {} alternating runs a side; training FireCast / {sb3_name} in each: {}",
        p.train_ratios.len(),
        each.join(", ")
    )?;
    writeln!(
        out,
        "ceiling: FireCast's updates alone run at {:.1}x {sb3_name}'s whole training, so no faster rollout takes training past that",
        p.ratios["train_ceiling"].as_f64().unwrap_or(f64::NAN)
    )?;
    writeln!(
        out,
        "goal: training >= {}x {sb3_name}: {} ({train:.1}x)",
        p.goal,
        if train >= p.goal { "met" } else { "not met" }
    )?;
    let w = &p.arithmetic;
    writeln!(
        out,
        "arithmetic: {:.2} MFLOP of convolutions and matrix products per training step (torch's count, \
         with {:.2} MFLOP of recurrent layers counted from their shapes); training runs at {:.1} GFLOP/s in \
         FireCast, {:.1} in {sb3_name}; the goal needs {:.1} GFLOP/s, {:.0} % of this machine's fastest \
         matrix product ({} {:.0} GFLOP/s on {} thread{}; float32 {:.0}, bfloat16 {:.0})",
        w.flops_per_step / 1e6,
        w.recurrent_flops_per_step / 1e6,
        w.firecast_gflops,
        w.sb3_gflops,
        w.goal_gflops,
        100.0 * w.goal_gflops / w.peak_gflops,
        w.peak_kernel,
        w.peak_gflops,
        p.threads,
        if p.threads == 1 { "" } else { "s" },
        w.sgemm_gflops,
        w.bf16_gflops,
    )?;
    Ok(())
}

fn bench_cartpole(args: &Args, python: &Path) -> anyhow::Result<BenchPartReport> {
    let ppo = firecast_ppo::ppo::PpoConfig::cartpole_zoo();
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
        || Ok(phases::cartpole(&ppo, args.steps, args.seed)?),
        || run_sb3(python, phases::SB3_SCRIPT, &cfg, 1),
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
    args: &Args,
    python: &Path,
    ppo: &firecast_ppo::ppo::PpoConfig,
    policy: &firecast_rl::policy::PolicyConfig,
    threads: usize,
) -> anyhow::Result<BenchPartReport> {
    let pool = firecast_rl::pool::HelitackPool::demo_scale()?;
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
    ppo: &'a firecast_ppo::ppo::PpoConfig,
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
) -> anyhow::Result<(phases::BenchRun, serde_json::Value, Vec<f64>)> {
    let cfg = helitack_sb3_config(s.ppo, s.policy, env, s.steps, s.seed, s.threads)?;
    let (firecast, sb3, train_ratios) = interleaved(
        s.repeats,
        || {
            Ok(phases::helitack(
                fires,
                s.ppo,
                s.policy,
                s.steps,
                s.seed,
                firecast_rl::Device::Cpu,
            )?)
        },
        || run_sb3(python, phases::SB3_HELITACK_SCRIPT, &cfg, s.threads),
    )?;
    check_parameters(part, firecast.parameters, &sb3)?;
    Ok((firecast, sb3, train_ratios))
}

fn bench_firecastrl(
    ctx: &Context,
    args: &Args,
    env_dir: &Path,
    python: &Path,
    ppo: &firecast_ppo::ppo::PpoConfig,
    policy: &firecast_rl::policy::PolicyConfig,
    threads: usize,
) -> anyhow::Result<BenchPartReport> {
    let maps = env_dir.join("firecastrl_env/envs/training_environments");
    let landscape = firecast_episodes::LandscapeSpec::Firecastrl {
        land_cover: maps.join("landcover_1.png"),
        heightmap: maps.join("heightmap_1.png"),
    }
    .load(&ctx.root)
    .with_context(|| format!("loading the FireCastRL training map from {}", maps.display()))?;
    // The P2 engine's settings, under which `bench sim` finds FireCast's fires identical to
    // the FireCastRL environment's.
    let cfg = firecast_sim::reference::p2_parity_config();
    let fires = phases::firecastrl_map(&landscape, &cfg)?;
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
