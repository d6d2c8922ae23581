//! `firecast sim spread-rate|run|behavior|verify`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context as _;
use clap::{Args, Subcommand};
use firecast_episodes::{AgentKind, EpisodesSummary, LandscapeSpec, Outputs, Scenario};

use crate::output;
use crate::settings::Settings;

#[derive(Debug, Subcommand)]
pub enum SimCommand {
    /// Rothermel/Albini surface spread (as behave computes it) for every row of a CSV.
    ///
    /// Input columns, by header name (the inputs of behave's random oracle): `fm` or `code`
    /// or `fuel_model` (number or code, e.g. 102 or GR2); `m1_pct`, `m10_pct`, `m100_pct`,
    /// `mherb_pct`, `mwoody_pct` (percent); `midflame_mph`; `slope_pct`;
    /// `wind_dir_rel_upslope_deg` (where the wind blows toward, clockwise from upslope).
    /// Output adds R0_ftmin, ros_ftmin, ros_chph, dir_max_spread_rel_upslope_deg,
    /// IR_btuft2min, flame_ft, fli_btufts, hpua_btuft2, lw_ratio, back_ftmin, flank_ftmin.
    SpreadRate {
        /// Cases to evaluate.
        #[arg(long, value_name = "CSV")]
        input: PathBuf,
        /// Where to write the results (written atomically).
        #[arg(long, value_name = "CSV")]
        output: PathBuf,
    },
    /// Simulate fires with a helitack agent; print the paper's Table IV columns.
    Run(Box<RunArgs>),
    /// Surface fire behaviour grids over a LANDFIRE landscape, as FlamMap's basic fire
    /// behaviour computes them: head rate of spread (ch/h), flame length (ft), fireline
    /// intensity (Btu/ft/s), direction of maximum spread (degrees from north) and fire type
    /// (0 none, 1 surface, 2 passive crown, 3 active crown), as float32 GeoTIFFs with the
    /// landscape's georeference, plus summary.json.
    Behavior(BehaviorArgs),
    /// Spread verified against Rothermel's ellipse (docs/results/spread-verification.md): point
    /// fires in uniform fuel under constant wind or slope, read after 1, 2 and 4 h; head, flank
    /// and back rates, L/B and area as ratios to the kernel's ellipse, for the FireCastRL
    /// automaton and the minimum-travel-time engine. Exits 1 if a resolved MTT row fails.
    Verify(VerifyArgs),
}

#[derive(Debug, Args)]
pub struct VerifyArgs {
    /// Run the test suite's small subset instead of every case.
    #[arg(long)]
    pub quick: bool,
    /// Engines to run.
    #[arg(long, value_enum, default_value_t = VerifyEngines::Both)]
    pub engine: VerifyEngines,
    /// MTT stencil radius in cells (1-8).
    #[arg(long, default_value_t = firecast_spread::mtt::DEFAULT_STENCIL_RADIUS,
          value_parser = clap::value_parser!(u32).range(1..=8))]
    pub stencil_radius: u32,
    /// Also draw GR2 at 15 and 4 mi/h (22.5°, 60 m cells) as a PNG map here: the exact
    /// ellipses, the MTT fronts and the automaton's burnt cells after 1, 2 and 4 h.
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum VerifyEngines {
    Both,
    Mtt,
    Automaton,
}

fn sim_verify(settings: &Settings, args: &VerifyArgs) -> anyhow::Result<ExitCode> {
    use firecast_spread::verify::{self, Engine, VerifyOptions};
    let cases = if args.quick {
        verify::quick_cases()
    } else {
        verify::all_cases()
    };
    let engines: &[Engine] = match args.engine {
        VerifyEngines::Both => &[Engine::Automaton, Engine::Mtt],
        VerifyEngines::Mtt => &[Engine::Mtt],
        VerifyEngines::Automaton => &[Engine::Automaton],
    };
    let opts = VerifyOptions {
        stencil_radius: args.stencil_radius,
    };
    let rows = verify::run(&cases, engines, &opts);
    if let Some(png) = &args.png {
        firecast_spread::picture::write_picture(png, &opts)
            .with_context(|| format!("cannot draw the verification picture: {}", png.display()))?;
    }
    let mtt_fail = rows
        .iter()
        .filter(|r| r.engine == Engine::Mtt && r.resolved && !r.pass)
        .count();
    if settings.json {
        output::print_json(&serde_json::json!({ "rows": rows, "mtt_failures": mtt_fail }))?;
    } else {
        println!("{}", verify::exact_table(&cases));
        println!("{}", verify::markdown_table(&rows));
        for &e in engines {
            let of = |f: &dyn Fn(&verify::Row) -> bool| rows.iter().filter(|r| r.engine == e && f(r)).count();
            println!(
                "{}: {} pass, {} fail, {} not resolved (the fire's shortest radius under {} cells)",
                e.name(),
                of(&|r| r.pass),
                of(&|r| r.resolved && !r.pass),
                of(&|r| !r.resolved),
                verify::RESOLVED_CELLS
            );
        }
    }
    Ok(if mtt_fail == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

#[derive(Debug, Args)]
pub struct BehaviorArgs {
    /// The landscape: a LANDFIRE folder (one GeoTIFF per layer, found by LANDFIRE's file names
    /// F40/FBFM40, F13/FBFM13, SlpP or SlpD, Asp, Elev, CC, CH, CBH, CBD, up to two levels
    /// deep), a FARSITE/FlamMap .lcp file (units as its header says; CRS from the .prj beside
    /// it), or a folder holding one .lcp.
    #[arg(long, value_name = "DIR|FILE.lcp")]
    pub landscape: PathBuf,
    /// Fuel layer: fbfm40 or fbfm13.
    #[arg(long, default_value = "fbfm40", value_name = "LAYER")]
    pub fuel: String,
    /// Fuel moisture, percent: D1,D10,D100,HERB,WOODY (e.g. 6,8,10,75,60).
    #[arg(long, value_name = "D1,D10,D100,HERB,WOODY")]
    pub moisture: String,
    /// 20-ft wind speed, mi/h (reduced to midflame per cell as FlamMap does).
    #[arg(long, default_value_t = 0.0, value_name = "MPH")]
    pub wind_mph: f64,
    /// Direction the wind comes from, degrees clockwise from north.
    #[arg(long, default_value_t = 0.0, value_name = "DEG")]
    pub wind_from_deg: f64,
    /// Slope as given (LANDFIRE percent) or `lcp`: rounded to whole degrees as a FlamMap .lcp
    /// keeps it (what FlamMap's own outputs reflect).
    #[arg(long, default_value = "as-given", value_name = "as-given|lcp")]
    pub slope: String,
    /// Apply Rothermel's effective wind limit (off in behave and here by default).
    #[arg(long)]
    pub wind_limit: bool,
    /// Crown fire method: finney (FlamMap's default), scott-reinhardt, or none.
    #[arg(long, default_value = "finney", value_name = "finney|scott-reinhardt|none")]
    pub crown: String,
    /// Foliar moisture content, percent (30-300; FlamMap's default 100).
    #[arg(long, default_value_t = 100.0, value_name = "PCT")]
    pub foliar_moisture: f64,
    /// Output folder (replaced atomically).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// Resolve `sim behavior`'s flags into the typed params the stage kind takes.
fn behavior_params(args: &BehaviorArgs) -> anyhow::Result<firecast_sim::behavior::BehaviorParams> {
    use firecast_sim::behavior::{BehaviorParams, FuelChoice, MoisturePercent, SlopeMode};
    let fuel = match args.fuel.to_ascii_lowercase().as_str() {
        "fbfm40" => FuelChoice::Fbfm40,
        "fbfm13" => FuelChoice::Fbfm13,
        other => anyhow::bail!("--fuel {other}: expected fbfm40 or fbfm13"),
    };
    let slope = match args.slope.as_str() {
        "as-given" => SlopeMode::AsGiven,
        "lcp" => SlopeMode::LcpWholeDegrees,
        other => anyhow::bail!("--slope {other}: expected as-given or lcp"),
    };
    let crown = firecast_sim::crown::CrownMethod::parse(&args.crown)
        .ok_or_else(|| anyhow::anyhow!("--crown {}: expected finney, scott-reinhardt or none", args.crown))?;
    let moisture = MoisturePercent::parse(&args.moisture).map_err(|e| anyhow::anyhow!("--moisture: {e}"))?;
    let params = BehaviorParams {
        fuel,
        moisture,
        wind_20ft_mph: args.wind_mph,
        wind_from_deg: args.wind_from_deg,
        slope,
        wind_limit: args.wind_limit,
        crown,
        foliar_moisture_pct: args.foliar_moisture,
    };
    params.validate().map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(params)
}

fn sim_behavior(settings: &Settings, args: &BehaviorArgs) -> anyhow::Result<ExitCode> {
    let params = behavior_params(args)?;
    let landscape = settings.root.join(&args.landscape);
    let out = settings.root.join(&args.out);
    let started = Instant::now();
    let summary = firecast_sim::behavior::run_behavior(&landscape, &params, &out)?;
    let seconds = started.elapsed().as_secs_f64();
    if settings.json {
        output::print_json(&serde_json::json!({ "summary": summary, "out": args.out, "seconds": seconds }))?;
        return Ok(ExitCode::SUCCESS);
    }
    let cells = |k: &str| summary.fire_type_cells.get(k).copied().unwrap_or(0);
    println!(
        "{} x {} cells ({}): {} surface fire, {} passive crown, {} active crown, {} no fire ({} non-burnable, \
         {} past extinction), {} nodata",
        summary.width,
        summary.height,
        summary.crs,
        cells("surface"),
        cells("passive_crown"),
        cells("active_crown"),
        cells("none"),
        summary.nonburnable_cells,
        summary.extinct_cells,
        summary.nodata_cells
    );
    for (name, range) in [
        ("rate of spread, ch/h", summary.ros_chph),
        ("flame length, ft", summary.flame_length_ft),
        (
            "fireline intensity, Btu/ft/s",
            summary.fireline_intensity_btu_ft_s,
        ),
    ] {
        if let Some(r) = range {
            println!(
                "  {name:<30} min {:>10.4}  mean {:>10.4}  max {:>10.4}",
                r.min, r.mean, r.max
            );
        }
    }
    println!(
        "landscape: {} ({})",
        summary.landscape_format,
        summary
            .layer_units
            .iter()
            .map(|(layer, unit)| format!("{layer}: {unit}"))
            .collect::<Vec<_>>()
            .join("; ")
    );
    println!(
        "crown fire: {} (foliar moisture {} %)",
        summary.params.crown.name(),
        summary.params.foliar_moisture_pct
    );
    if !summary.crown_fire_missing_layers.is_empty() {
        println!(
            "  no crown fire anywhere: the landscape has no {} layer",
            summary.crown_fire_missing_layers.join(", no ")
        );
    }
    println!("wrote {} in {seconds:.2} s", args.out.display());
    Ok(ExitCode::SUCCESS)
}

#[derive(Debug, Args)]
pub struct RunArgs {
    /// Terrain: `procedural:SEED` or `firecastrl:LAND_COVER.png,HEIGHTMAP.png`
    /// [default: procedural:1].
    #[arg(long, value_name = "SPEC", conflicts_with = "scenario")]
    pub landscape: Option<String>,
    /// A scenario YAML (`landscape:` and `env:`), for GeoTIFF terrain and full env settings.
    #[arg(long, value_name = "FILE")]
    pub scenario: Option<PathBuf>,
    /// Agent(s): none, rule (circle of radius 30), rule-concentric (45/40/35), chaser (flies
    /// to the nearest flames). Repeat to compare.
    #[arg(long, default_value = "rule", value_name = "AGENT")]
    pub agent: Vec<String>,
    /// Episodes per agent (seeds SEED, SEED+1, …).
    #[arg(long, default_value_t = 10)]
    pub episodes: usize,
    /// Seed of the first episode (every random draw is seeded: same seed, same fire).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Midflame wind speed, mi/h (overrides the scenario).
    #[arg(long, value_name = "MPH")]
    pub wind_mph: Option<f64>,
    /// Direction the wind comes from, degrees clockwise from north (as GRIDMET `th`).
    #[arg(long, value_name = "DEG")]
    pub wind_from_deg: Option<f64>,
    /// Take the wind from GRIDMET on this day (YYYY-MM-DD): 10-m `vs` and `th` at the
    /// landscape's centre, brought to midflame per fuel. Needs --gridmet.
    #[arg(long, value_name = "DATE", requires = "gridmet")]
    pub weather_date: Option<String>,
    /// Folder of GRIDMET files (vs_YYYY.nc, th_YYYY.nc) for --weather-date.
    #[arg(long, value_name = "DIR")]
    pub gridmet: Option<PathBuf>,
    /// Write PNG frames of the first episode into DIR (one subfolder per agent).
    #[arg(long, value_name = "DIR")]
    pub frames: Option<PathBuf>,
    /// Write an animated GIF of the first episode (`-AGENT` is added when comparing agents).
    #[arg(long, value_name = "FILE")]
    pub gif: Option<PathBuf>,
    /// Write a Rerun recording (.rrd) of the first episode (open with rerun-sdk 0.36.3).
    #[arg(long, value_name = "FILE")]
    pub rerun: Option<PathBuf>,
    /// Keep every k-th step in PNG frames and the GIF (drops are always kept).
    #[arg(long, default_value_t = 4, value_name = "K")]
    pub frame_every: usize,
    /// Also print every episode.
    #[arg(long)]
    pub per_episode: bool,
}

pub fn run(settings: &Settings, command: SimCommand) -> anyhow::Result<ExitCode> {
    match command {
        SimCommand::SpreadRate { input, output } => {
            let rows =
                firecast_sim::spread_rate_csv(&settings.root.join(&input), &settings.root.join(&output))?;
            if settings.json {
                output::print_json(&serde_json::json!({ "rows": rows, "output": output }))?;
            } else {
                println!("{rows} cases written to {}", output.display());
            }
            Ok(ExitCode::SUCCESS)
        }
        SimCommand::Run(args) => sim_run(settings, &args),
        SimCommand::Behavior(args) => sim_behavior(settings, &args),
        SimCommand::Verify(args) => sim_verify(settings, &args),
    }
}

fn with_agent_suffix(path: &Path, agent: &str, many: bool) -> PathBuf {
    if !many {
        return path.to_path_buf();
    }
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_default();
    let name = match path.extension() {
        Some(ext) => format!("{stem}-{agent}.{}", ext.to_string_lossy()),
        None => format!("{stem}-{agent}"),
    };
    path.with_file_name(name)
}

fn sim_run(settings: &Settings, args: &RunArgs) -> anyhow::Result<ExitCode> {
    let mut scenario = match (&args.scenario, &args.landscape) {
        (Some(file), _) => Scenario::from_file(&settings.root.join(file))?,
        (None, Some(spec)) => {
            Scenario::new(spec.parse::<LandscapeSpec>()?, firecast_sim::EnvConfig::default())
        }
        (None, None) => Scenario::new(
            LandscapeSpec::Procedural {
                seed: 1,
                width: 240,
                height: 160,
                center: None,
            },
            firecast_sim::EnvConfig::default(),
        ),
    };
    if let Some(date) = &args.weather_date {
        let dir = args
            .gridmet
            .clone()
            .context("--weather-date needs --gridmet DIR (the folder of vs_YYYY.nc and th_YYYY.nc)")?;
        scenario.weather = Some(firecast_episodes::WeatherSpec::gridmet_wind(dir, date));
    }
    if args.wind_mph.is_some() || args.wind_from_deg.is_some() {
        // Flags win over the scenario, weather included.
        scenario.weather = None;
    }
    if let Some(speed) = args.wind_mph {
        scenario.env.sim.wind.speed_mph = speed;
        scenario.env.sim.wind.measured_at = firecast_sim::WindHeight::Midflame;
    }
    if let Some(from) = args.wind_from_deg {
        scenario.env.sim.wind.from_direction_deg = from;
    }
    let agents = args
        .agent
        .iter()
        .map(|a| a.parse::<AgentKind>())
        .collect::<Result<Vec<_>, _>>()?;
    let (landscape, weather) = scenario
        .prepare(&settings.root)
        .context("cannot prepare the scenario")?;
    let many = agents.len() > 1;
    let mut summaries: Vec<EpisodesSummary> = Vec::new();
    for agent in agents {
        let outputs = Outputs {
            frames_dir: args
                .frames
                .as_ref()
                .map(|d| settings.root.join(d).join(agent.name())),
            gif: args
                .gif
                .as_ref()
                .map(|p| settings.root.join(with_agent_suffix(p, agent.name(), many))),
            recording: args
                .rerun
                .as_ref()
                .map(|p| settings.root.join(with_agent_suffix(p, agent.name(), many))),
            frame_every: args.frame_every,
        };
        let bar = progress_bar(settings, args.episodes as u64, agent.name());
        let summary = firecast_episodes::run(
            &scenario,
            &landscape,
            agent,
            args.episodes,
            args.seed,
            &outputs,
            |_| {
                bar.inc(1);
            },
        )?;
        bar.finish_and_clear();
        summaries.push(summary);
    }
    if settings.json {
        output::print_json(&summaries)?;
        return Ok(ExitCode::SUCCESS);
    }
    let ms =
        |m: &firecast_sim::MeanStd, digits: usize| format!("{:.*} ± {:.*}", digits, m.mean, digits, m.std);
    let mut table = output::table(&[
        "agent",
        "episodes",
        "cells burned",
        "timesteps",
        "helitacks",
        "water used (gal)",
    ]);
    for s in &summaries {
        let r = &s.report;
        table.add_row(vec![
            s.agent.to_string(),
            r.episodes.len().to_string(),
            ms(&r.cells_burned, 1),
            ms(&r.timesteps, 1),
            ms(&r.helitacks, 1),
            ms(&r.water_used_gal, 0),
        ]);
    }
    let wind = &scenario.env.sim.wind;
    let height = match wind.measured_at {
        firecast_sim::WindHeight::Midflame => "midflame",
        firecast_sim::WindHeight::TwentyFoot => "20-ft",
        firecast_sim::WindHeight::TenMetre => "10-m",
    };
    let source = match &weather {
        Some(w) => format!(" (GRIDMET vs/th on {} at {:.4}, {:.4})", w.date, w.lat, w.lon),
        None => String::new(),
    };
    println!(
        "{} x {} cells of {} ft, {height} wind {:.1} mi/h from {:.0}°{source}, seeds {}..{}",
        landscape.width,
        landscape.height,
        landscape.cell_size_ft,
        wind.speed_mph,
        wind.from_direction_deg,
        args.seed,
        args.seed + args.episodes as u64 - 1
    );
    output::print_table(&table)?;
    if args.per_episode {
        let mut table = output::table(&[
            "agent",
            "seed",
            "cells burned",
            "timesteps",
            "helitacks",
            "water (gal)",
            "fire out",
        ]);
        for s in &summaries {
            for e in &s.report.episodes {
                table.add_row(vec![
                    s.agent.to_string(),
                    e.seed.to_string(),
                    e.cells_burned.to_string(),
                    e.timesteps.to_string(),
                    e.helitacks.to_string(),
                    format!("{:.0}", e.water_used_gal),
                    e.terminated.to_string(),
                ]);
            }
        }
        output::print_table(&table)?;
    }
    Ok(ExitCode::SUCCESS)
}

fn progress_bar(settings: &Settings, len: u64, label: &str) -> indicatif::ProgressBar {
    if !settings.progress {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg:>16} [{bar:30}] {pos}/{len} episodes ({eta})")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(label.to_string());
    bar
}
