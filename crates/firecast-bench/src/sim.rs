//! `firecast bench sim`: the simulator's speed (environment steps per second, one env on one
//! thread and vectorised on all cores, with an active fire; Rothermel point evaluations per
//! second), or with `--reference-env` FireCast beside the FireCastRL Python environment on its
//! training map: the same episodes in both, the fires compared and the times divided.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use firecast_episodes::LandscapeSpec;

use crate::Context;
use crate::python::{Venv, find_python};

/// `firecast bench sim`'s flags.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Environment steps to time on one thread.
    #[arg(long, default_value_t = 50_000)]
    pub steps: u64,
    /// Environments in the vectorised run [default: 4 per core].
    #[arg(long)]
    pub envs: Option<usize>,
    /// Landscape seed (procedural 240 x 160).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Also run the FireCastRL Python environment beside FireCast: DIR is a checkout of
    /// aisystems-lab/wildfire-env (the folder holding `firecastrl_env`). Both engines play the
    /// same episodes on its training map; the fires are compared and the times divided.
    #[arg(long, value_name = "DIR")]
    pub reference_env: Option<PathBuf>,
    /// Python for the reference (with gymnasium, numpy, pillow, websockets, requests)
    /// [default: $FIRECAST_VENV, ./.venv].
    #[arg(long, value_name = "PYTHON", requires = "reference_env")]
    pub python: Option<PathBuf>,
    /// Seeds (1..=N) per action script in the reference comparison.
    #[arg(long, default_value_t = 5, value_name = "N", requires = "reference_env")]
    pub reference_seeds: u64,
}

/// One benchmark scenario's results.
#[derive(Debug, serde::Serialize)]
pub struct EnvBench {
    scenario: &'static str,
    single_env_steps_per_sec: f64,
    mean_cells_burning: f64,
    vec_envs: usize,
    vec_threads: usize,
    vec_env_steps_per_sec: f64,
}

/// `firecast bench sim`: environment steps per second and Rothermel evaluations per second;
/// with `--reference-env`, FireCast beside the FireCastRL Python environment.
pub fn run(ctx: &Context, args: &Args) -> anyhow::Result<SimReport> {
    if let Some(env_dir) = &args.reference_env {
        return Ok(SimReport::Reference(bench_reference(
            ctx,
            args,
            &ctx.root.join(env_dir),
        )?));
    }
    let landscape = LandscapeSpec::Procedural {
        seed: args.seed,
        width: 240,
        height: 160,
        center: None,
    }
    .load(&ctx.root)?;
    let firecastrl = firecast_sim::bench::firecastrl_config();
    let wind_driven = firecast_sim::bench::large_fire_config();
    let results = [
        bench_env(
            &landscape,
            &firecastrl,
            "FireCastRL defaults (Concord kernel), wind 10 mi/h",
            args,
        )?,
        bench_env(
            &landscape,
            &wind_driven,
            "Rothermel kernel, dry fuels, wind 10 mi/h (large fire)",
            args,
        )?,
    ];
    let (prepared, full) = bench_rothermel(200_000)?;
    Ok(SimReport::Speed(SpeedReport {
        seed: args.seed,
        results,
        prepared,
        full,
    }))
}

/// `firecast bench sim`'s report: the speeds, or the comparison with the FireCastRL
/// environment (`--reference-env`).
#[derive(Debug)]
pub enum SimReport {
    Speed(SpeedReport),
    Reference(ReferenceReport),
}

/// The simulator's speeds on a procedural landscape.
#[derive(Debug)]
pub struct SpeedReport {
    pub seed: u64,
    pub results: [EnvBench; 2],
    /// Rothermel evaluations a second with a prepared fuel bed.
    pub prepared: f64,
    /// Rothermel evaluations a second building the bed each time.
    pub full: f64,
}

/// FireCast beside the FireCastRL Python environment on its training map.
#[derive(Debug)]
pub struct ReferenceReport {
    pub maps: PathBuf,
    pub reference_seeds: u64,
    pub comparisons: Vec<ScriptComparison>,
}

impl serde::Serialize for SimReport {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Speed(r) => serde_json::json!({
                "landscape": format!("procedural 240 x 160 x 500 ft, seed {}", r.seed),
                "env": r.results,
                "rothermel_spread_per_sec_prepared_bed": r.prepared,
                "rothermel_bed_and_spread_per_sec": r.full,
            })
            .serialize(s),
            Self::Reference(r) => serde_json::json!({
                "map": r.maps,
                "comparisons": r.comparisons,
            })
            .serialize(s),
        }
    }
}

impl crate::Report for SimReport {
    fn render(&self) -> String {
        let mut out = String::new();
        let _ = match self {
            Self::Speed(r) => r.write(&mut out),
            Self::Reference(r) => r.write(&mut out),
        };
        out
    }
}

impl SpeedReport {
    fn write(&self, out: &mut String) -> std::fmt::Result {
        let (results, prepared, full) = (&self.results, self.prepared, self.full);
        writeln!(
            out,
            "procedural 240 x 160 landscape (seed {}); observation included in every step",
            self.seed
        )?;
        let mut table = crate::table(&["scenario", "cells burning (mean)", "1 env, 1 thread", "VecEnv"]);
        for r in results {
            table.add_row(vec![
                r.scenario.to_string(),
                format!("{:.0}", r.mean_cells_burning),
                format!("{:.0} steps/s", r.single_env_steps_per_sec),
                format!(
                    "{:.0} steps/s ({} envs, {} threads)",
                    r.vec_env_steps_per_sec, r.vec_envs, r.vec_threads
                ),
            ]);
        }
        writeln!(out, "{table}")?;
        let mut table = crate::table(&["Rothermel/Albini point evaluation", "per second"]);
        table.add_row(vec![
            "spread, prepared fuel bed".to_string(),
            format!("{prepared:.0}"),
        ]);
        table.add_row(vec!["fuel bed + spread".to_string(), format!("{full:.0}")]);
        writeln!(out, "{table}")
    }
}

fn bench_env(
    landscape: &firecast_landscape::Landscape,
    cfg: &firecast_sim::EnvConfig,
    scenario: &'static str,
    args: &Args,
) -> anyhow::Result<EnvBench> {
    use firecast_sim::bench::ACTIONS;
    use firecast_sim::{Action, VecEnv, WildfireEnv};
    let mut env = WildfireEnv::new(landscape, cfg)?;
    env.reset(0);
    let mut burning_sum = 0u64;
    let mut resets = 0u64;
    let started = Instant::now();
    for i in 0..args.steps {
        let (obs, _, terminated, truncated, info) = env.step(ACTIONS[(i % 8) as usize]);
        std::hint::black_box(obs.current_frame());
        burning_sum += u64::from(info.cells_burning);
        if terminated || truncated {
            resets += 1;
            env.reset(resets);
        }
    }
    let single = args.steps as f64 / started.elapsed().as_secs_f64();

    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    let n = args.envs.unwrap_or(threads * 4).max(1);
    let mut vec_env = VecEnv::new(landscape, cfg, n, 0)?;
    let rounds = (args.steps / n as u64).max(1);
    let mut actions = vec![Action::South; n];
    let started = Instant::now();
    for r in 0..rounds {
        for (k, a) in actions.iter_mut().enumerate() {
            *a = ACTIONS[(r as usize + k) % 8];
        }
        vec_env.step(&actions)?;
        std::hint::black_box(vec_env.frames());
    }
    let vectorised = (rounds * n as u64) as f64 / started.elapsed().as_secs_f64();
    Ok(EnvBench {
        scenario,
        single_env_steps_per_sec: single,
        mean_cells_burning: burning_sum as f64 / args.steps as f64,
        vec_envs: n,
        vec_threads: threads,
        vec_env_steps_per_sec: vectorised,
    })
}

/// Rothermel point evaluations per second over the 53 standard fuel models with varied
/// inputs: with a prepared fuel bed (the automaton's case) and building the bed each time.
fn bench_rothermel(n: usize) -> anyhow::Result<(f64, f64)> {
    use firecast_sim::{FuelModel, FuelMoisture, SpreadInputs, SurfaceFuelBed};
    let models: Vec<_> = FuelModel::standard().iter().filter(|m| m.burnable).collect();
    let moisture = FuelMoisture::from_percent(6.0, 7.0, 8.0, 60.0, 90.0);
    let beds = models
        .iter()
        .map(|m| SurfaceFuelBed::new(m, &moisture))
        .collect::<Result<Vec<_>, _>>()?;
    let inputs: Vec<SpreadInputs> = (0..1024)
        .map(|i| {
            SpreadInputs::new(
                f64::from(i % 20),
                f64::from((i * 7) % 80),
                f64::from((i * 37) % 360),
            )
        })
        .collect::<Result<_, _>>()?;
    let started = Instant::now();
    let mut sink = 0.0;
    for i in 0..n {
        sink += beds[i % beds.len()]
            .spread(&inputs[i % inputs.len()])
            .head_ros_ftmin;
    }
    let prepared = n as f64 / started.elapsed().as_secs_f64();
    let started = Instant::now();
    let m = n / 4;
    for i in 0..m {
        let bed = SurfaceFuelBed::new(models[i % models.len()], &moisture)?;
        sink += bed.spread(&inputs[i % inputs.len()]).head_ros_ftmin;
    }
    let full = m as f64 / started.elapsed().as_secs_f64();
    std::hint::black_box(sink);
    Ok((prepared, full))
}

/// One action script's comparison.
#[derive(Debug, serde::Serialize)]
pub struct ScriptComparison {
    script: &'static str,
    firecast: Vec<firecast_sim::reference::EpisodeOutcome>,
    reference: Vec<firecast_sim::reference::EpisodeOutcome>,
    identical_fires: usize,
    firecast_steps_per_sec: f64,
    reference_steps_per_sec: f64,
    ratio: f64,
}

fn steps_per_sec(outcomes: &[firecast_sim::reference::EpisodeOutcome]) -> f64 {
    let steps: u64 = outcomes.iter().map(|o| u64::from(o.steps)).sum();
    let seconds: f64 = outcomes.iter().map(|o| o.seconds).sum();
    steps as f64 / seconds.max(1e-12)
}

fn bench_reference(ctx: &Context, args: &Args, env_dir: &Path) -> anyhow::Result<ReferenceReport> {
    use firecast_sim::reference::{self, ParityEpisode};
    let maps = env_dir.join("firecastrl_env/envs/training_environments");
    let landscape = LandscapeSpec::Firecastrl {
        land_cover: maps.join("landcover_1.png"),
        heightmap: maps.join("heightmap_1.png"),
    }
    .load(&ctx.root)
    .with_context(|| format!("loading the FireCastRL training map from {}", maps.display()))?;
    let cfg = reference::p2_parity_config();
    let python = find_python(args.python.as_deref(), &ctx.root, Venv::Project)?;
    let work = std::env::temp_dir().join(format!("firecast-reference-{}", std::process::id()));
    std::fs::create_dir_all(&work).with_context(|| format!("cannot create {}", work.display()))?;
    let mut comparisons = Vec::new();
    for (script, actions) in reference::parity_scripts() {
        let episodes: Vec<ParityEpisode> = (1..=args.reference_seeds)
            .map(|seed| ParityEpisode {
                seed,
                actions: actions.clone(),
                max_steps: cfg.max_steps,
            })
            .collect();
        eprintln!(
            "{script}: {} episodes in the FireCastRL environment ({}) ...",
            episodes.len(),
            python.display()
        );
        let reference_run = reference::run_reference(&python, env_dir, &episodes, &work);
        let reference_run = match reference_run {
            Ok(r) => r,
            Err(e) => {
                let _ = std::fs::remove_dir_all(&work);
                return Err(e.into());
            }
        };
        eprintln!("{script}: the same episodes in FireCast ...");
        let firecast = reference::run_firecast(&landscape, &cfg, &episodes)?;
        let identical_fires = firecast
            .iter()
            .zip(&reference_run.episodes)
            .filter(|(a, b)| a.same_fire(b))
            .count();
        let (ours, theirs) = (steps_per_sec(&firecast), steps_per_sec(&reference_run.episodes));
        comparisons.push(ScriptComparison {
            script,
            firecast,
            reference: reference_run.episodes,
            identical_fires,
            firecast_steps_per_sec: ours,
            reference_steps_per_sec: theirs,
            ratio: ours / theirs,
        });
    }
    let _ = std::fs::remove_dir_all(&work);
    Ok(ReferenceReport {
        maps,
        reference_seeds: args.reference_seeds,
        comparisons,
    })
}

impl ReferenceReport {
    fn write(&self, out: &mut String) -> std::fmt::Result {
        let (maps, comparisons) = (&self.maps, &self.comparisons);
        writeln!(
            out,
            "FireCastRL training map ({}), P2 settings, seeds 1..={}; one thread each, observation included",
            maps.display(),
            self.reference_seeds
        )?;
        let mut table = crate::table(&[
            "actions",
            "episodes",
            "identical fires",
            "burnt (FireCast / ref)",
            "steps (FireCast / ref)",
            "FireCastRL env",
            "FireCast",
            "ratio",
        ]);
        for c in comparisons {
            let mean = |v: &[firecast_sim::reference::EpisodeOutcome],
                        f: fn(&firecast_sim::reference::EpisodeOutcome) -> u32| {
                v.iter().map(|o| f64::from(f(o))).sum::<f64>() / v.len().max(1) as f64
            };
            table.add_row(vec![
                c.script.to_string(),
                c.firecast.len().to_string(),
                format!("{}/{}", c.identical_fires, c.firecast.len()),
                format!(
                    "{:.1} / {:.1}",
                    mean(&c.firecast, |o| o.burnt),
                    mean(&c.reference, |o| o.burnt)
                ),
                format!(
                    "{:.1} / {:.1}",
                    mean(&c.firecast, |o| o.steps),
                    mean(&c.reference, |o| o.steps)
                ),
                format!("{:.1} steps/s", c.reference_steps_per_sec),
                format!("{:.0} steps/s", c.firecast_steps_per_sec),
                format!("{:.0}x", c.ratio),
            ]);
        }
        writeln!(out, "{table}")?;
        let mut table = crate::table(&[
            "actions",
            "seed",
            "engine",
            "steps",
            "burnt",
            "burning",
            "peak burning",
            "checksum",
        ]);
        for c in comparisons {
            for (a, b) in c.firecast.iter().zip(&c.reference) {
                for (engine, o) in [("FireCast", a), ("FireCastRL", b)] {
                    table.add_row(vec![
                        c.script.to_string(),
                        o.seed.to_string(),
                        engine.to_string(),
                        o.steps.to_string(),
                        o.burnt.to_string(),
                        o.burning.to_string(),
                        o.peak_burning.to_string(),
                        o.checksum.to_string(),
                    ]);
                }
            }
        }
        writeln!(out, "{table}")
    }
}
