//! `firecast bench behavior` and `firecast bench spread`: FireCast beside pyretechnics
//! (`firecast_spread::bench`), one thread each, on the same LANDFIRE landscape and inputs.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use firecast_spread::bench::{self, BenchOptions, Timing, Window};

use crate::output;
use crate::settings::Settings;

/// The speed goal: FireCast at least this many times pyretechnics on one core.
const GOAL: f64 = 20.0;

/// What both benches take.
#[derive(Debug, Args)]
pub struct FireBenchArgs {
    /// LANDFIRE landscape folder (GeoTIFF layers, slope in percent) [default: the Worcester
    /// clip of the FlamMap parity test]
    #[arg(long, value_name = "DIR")]
    pub landscape: Option<PathBuf>,
    /// Fuel layer: fbfm40 or fbfm13.
    #[arg(long, default_value = "fbfm40", value_name = "LAYER")]
    pub fuel: String,
    /// Fuel moisture, percent: D1,D10,D100,HERB,WOODY [default: FlamMap's run on the
    /// Worcester clip].
    #[arg(long, default_value = "6,8,10,75,60", value_name = "D1,D10,D100,HERB,WOODY")]
    pub moisture: String,
    /// Foliar moisture content, percent.
    #[arg(long, default_value_t = 120.0, value_name = "PCT")]
    pub foliar_moisture: f64,
    /// Direction the wind comes from, degrees clockwise from north.
    #[arg(long, default_value_t = 225.0, value_name = "DEG")]
    pub wind_from_deg: f64,
    /// Timed repeats of each engine (the best counts).
    #[arg(long, default_value_t = 5, value_name = "N")]
    pub repeats: usize,
    /// A small window of cells and one repeat (for tests).
    #[arg(long)]
    pub quick: bool,
    /// pyretechnics' Python [default: .venv-peers/pyretechnics/bin/python, from `cargo xtask
    /// setup`].
    #[arg(long, value_name = "PYTHON")]
    pub python: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct BenchBehaviorArgs {
    #[command(flatten)]
    pub common: FireBenchArgs,
    /// 20-ft wind speed, mi/h [default: 0, FlamMap's run on the Worcester clip].
    #[arg(long, default_value_t = 0.0, value_name = "MPH")]
    pub wind_mph: f64,
    /// Crown fire method: finney (FlamMap's default), scott-reinhardt, or none.
    #[arg(long, default_value = "finney", value_name = "finney|scott-reinhardt|none")]
    pub crown: String,
}

#[derive(Debug, Args)]
pub struct BenchSpreadArgs {
    #[command(flatten)]
    pub common: FireBenchArgs,
    /// 20-ft wind speed, mi/h.
    #[arg(long, default_value_t = 15.0, value_name = "MPH")]
    pub wind_mph: f64,
    /// Ignition cell, column and row from the landscape's north-west corner [default: the
    /// grass cell col 362, row 457 of the Worcester clip].
    #[arg(long, value_name = "COL,ROW")]
    pub ignition: Option<String>,
    /// Hours to spread.
    #[arg(long, default_value_t = 8.0, value_name = "H")]
    pub hours: f64,
    /// FireCast's MTT stencil radius (1-8).
    #[arg(long, default_value_t = firecast_spread::mtt::DEFAULT_STENCIL_RADIUS,
          value_parser = clap::value_parser!(u32).range(1..=8), value_name = "R")]
    pub stencil_radius: u32,
}

/// The Worcester clip's grass cell (GR2) the spread bench ignites by default.
const DEFAULT_IGNITION: (usize, usize) = (362, 457);
/// `--quick` windows: the behaviour grid's centre, and around the ignition.
const QUICK_BEHAVIOR: usize = 128;
const QUICK_SPREAD: usize = 160;

fn options(
    settings: &Settings,
    a: &FireBenchArgs,
    wind_mph: f64,
    crown: &str,
) -> anyhow::Result<(BenchOptions, PathBuf)> {
    use firecast_sim::behavior::{BehaviorParams, FuelChoice, MoisturePercent, SlopeMode};
    let python = bench::peer_python(a.python.as_deref(), &settings.root)?;
    let fuel = match a.fuel.to_ascii_lowercase().as_str() {
        "fbfm40" => FuelChoice::Fbfm40,
        "fbfm13" => FuelChoice::Fbfm13,
        other => anyhow::bail!("--fuel {other}: expected fbfm40 or fbfm13"),
    };
    let crown = firecast_sim::crown::CrownMethod::parse(crown)
        .ok_or_else(|| anyhow::anyhow!("--crown {crown}: expected finney, scott-reinhardt or none"))?;
    let params = BehaviorParams {
        fuel,
        moisture: MoisturePercent::parse(&a.moisture).map_err(|e| anyhow::anyhow!("--moisture: {e}"))?,
        wind_20ft_mph: wind_mph,
        wind_from_deg: a.wind_from_deg,
        slope: SlopeMode::AsGiven,
        wind_limit: false,
        crown,
        foliar_moisture_pct: a.foliar_moisture,
    };
    params.validate().map_err(|e| anyhow::anyhow!("{e}"))?;
    let landscape = settings
        .root
        .join(a.landscape.clone().unwrap_or_else(|| bench::WORCESTER.into()));
    let work = std::env::temp_dir().join(format!("firecast-bench-pyretechnics-{}", std::process::id()));
    let opts = BenchOptions {
        landscape,
        params,
        repeats: if a.quick { 1 } else { a.repeats.max(1) },
        python,
        work: work.clone(),
    };
    Ok((opts, work))
}

/// A path inside the project as the user would type it.
fn shown<'a>(settings: &Settings, path: &'a std::path::Path) -> &'a std::path::Path {
    path.strip_prefix(&settings.root).unwrap_or(path)
}

fn inputs_line(p: &firecast_sim::behavior::BehaviorParams) -> String {
    let m = &p.moisture;
    format!(
        "moisture {}/{}/{}/{}/{} %, foliar {} %, 20-ft wind {} mi/h from {}°",
        m.dead_1h,
        m.dead_10h,
        m.dead_100h,
        m.live_herbaceous,
        m.live_woody,
        p.foliar_moisture_pct,
        p.wind_20ft_mph,
        p.wind_from_deg
    )
}

fn timing_row(name: String, t: &Timing, unit: &str, ratio: f64) -> Vec<String> {
    vec![
        name,
        format!("{:.4}", t.best_seconds),
        format!("{:.0} {unit}", t.cells_per_second),
        format!("{ratio:.1}x"),
    ]
}

fn goal_line(ratio: f64) -> String {
    format!(
        "goal >= {GOAL:.0}x pyretechnics on one core: {} ({ratio:.1}x)",
        if ratio >= GOAL { "met" } else { "NOT met" }
    )
}

/// `firecast bench behavior`.
pub fn bench_behavior(settings: &Settings, args: &BenchBehaviorArgs) -> anyhow::Result<ExitCode> {
    let (opts, work) = options(settings, &args.common, args.wind_mph, &args.crown)?;
    let window = if args.common.quick {
        let land = firecast_landscape::landfire::LandfireLandscape::read_dir(
            &opts.landscape,
            opts.params.fuel.layer(),
        )?;
        let (w, h) = (land.grid.width, land.grid.height);
        Some(Window::around(
            &land,
            w / 2,
            h / 2,
            QUICK_BEHAVIOR,
            QUICK_BEHAVIOR,
        ))
    } else {
        None
    };
    let result = bench::bench_behavior(&opts, window);
    let _ = std::fs::remove_dir_all(&work);
    let r = result?;
    let agrees = r.agreement.holds();
    if settings.json {
        let mut v = serde_json::to_value(&r)?;
        v["agreement_holds"] = agrees.into();
        v["goal"] = GOAL.into();
        output::print_json(&v)?;
    } else {
        let a = &r.agreement;
        println!(
            "fire behaviour of every cell: {} ({} x {} cells from col {}, row {}; {} burning), {}; crown {:?}",
            shown(settings, &r.landscape).display(),
            r.window.cols,
            r.window.rows,
            r.window.col0,
            r.window.row0,
            r.burning_cells,
            inputs_line(&r.params),
            r.params.crown
        );
        println!(
            "machine: {}; one thread each; pyretechnics {} (Python {}, numpy {})",
            r.machine, r.peer.pyretechnics, r.peer.python, r.peer.numpy
        );
        println!(
            "agreement: {} of {} cells within {:.1} % on rate of spread (max {:.3} %){}; compared: {}",
            a.within_tolerance,
            a.compared_cells,
            a.tolerance * 100.0,
            a.max_relative_difference * 100.0,
            if agrees { "" } else { " DISAGREE" },
            a.rule
        );
        println!(
            "  all cells both call surface fire: {} of {} within {:.1} % (max {:.3} %)",
            a.surface_within_tolerance,
            a.surface_cells,
            a.tolerance * 100.0,
            a.surface_max_relative_difference * 100.0
        );
        println!(
            "  fire type equal on {} of {} cells; none/surface/passive/active: FireCast {:?}, pyretechnics {:?}",
            a.fire_type_equal_cells, r.cells, a.firecast_fire_types, a.pyretechnics_fire_types
        );
        let mut table = output::table(&["engine (1 thread)", "best s", "grid cells/s", "ratio"]);
        table.add_row(timing_row(
            format!(
                "pyretechnics {}: burn_all_cells_as_head_fire",
                r.peer.pyretechnics
            ),
            &r.pyretechnics,
            "cells/s",
            1.0,
        ));
        table.add_row(timing_row(
            "FireCast: surface_behavior_grids".into(),
            &r.firecast,
            "cells/s",
            r.ratio,
        ));
        output::print_table(&table)?;
        println!("ratio: FireCast {:.1}x pyretechnics", r.ratio);
        println!("{}", goal_line(r.ratio));
    }
    Ok(if agrees {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

fn parse_cell(text: &str) -> anyhow::Result<(usize, usize)> {
    let (c, r) = text
        .split_once(',')
        .ok_or_else(|| anyhow::anyhow!("--ignition {text}: expected COL,ROW"))?;
    Ok((
        c.trim()
            .parse()
            .map_err(|_| anyhow::anyhow!("--ignition {text}: COL is not a cell index"))?,
        r.trim()
            .parse()
            .map_err(|_| anyhow::anyhow!("--ignition {text}: ROW is not a cell index"))?,
    ))
}

/// `firecast bench spread`.
pub fn bench_spread(settings: &Settings, args: &BenchSpreadArgs) -> anyhow::Result<ExitCode> {
    let (opts, work) = options(settings, &args.common, args.wind_mph, "finney")?;
    let ignition = args
        .ignition
        .as_deref()
        .map(parse_cell)
        .transpose()?
        .unwrap_or(DEFAULT_IGNITION);
    let window = if args.common.quick {
        let land = firecast_landscape::landfire::LandfireLandscape::read_dir(
            &opts.landscape,
            opts.params.fuel.layer(),
        )?;
        Some(Window::around(
            &land,
            ignition.0,
            ignition.1,
            QUICK_SPREAD,
            QUICK_SPREAD,
        ))
    } else {
        None
    };
    let result = bench::bench_spread(&opts, ignition, args.hours, args.stencil_radius, window);
    let _ = std::fs::remove_dir_all(&work);
    let r = result?;
    if settings.json {
        let mut v = serde_json::to_value(&r)?;
        v["goal"] = GOAL.into();
        output::print_json(&v)?;
        return Ok(ExitCode::SUCCESS);
    }
    let a = &r.areas;
    println!(
        "point fire for {} h from col {}, row {}: {} ({} x {} cells from col {}, row {}), {}",
        r.hours,
        r.ignition.0,
        r.ignition.1,
        shown(settings, &r.landscape).display(),
        r.window.cols,
        r.window.rows,
        r.window.col0,
        r.window.row0,
        inputs_line(&r.params)
    );
    println!(
        "machine: {}; one thread each; pyretechnics {} (Python {}, numpy {})",
        r.machine, r.peer.pyretechnics, r.peer.python, r.peer.numpy
    );
    println!(
        "different algorithms: FireCast minimum travel time (Dijkstra, radius-{} stencil, surface fire), \
         pyretechnics Eulerian level set (surface and crown fire; stopped: {})",
        r.stencil_radius,
        r.peer.stop_condition.as_deref().unwrap_or("?")
    );
    println!(
        "burnt area: FireCast {} cells ({:.1} ha), pyretechnics {} cells ({:.1} ha, {} as crown fire); \
         ratio {:.3}; both {}, FireCast only {}, pyretechnics only {} (Jaccard {:.3}); \
         mean |arrival difference| {:.2} h",
        a.firecast_cells,
        a.firecast_cells as f64 * a.cell_area_ha,
        a.pyretechnics_cells,
        a.pyretechnics_cells as f64 * a.cell_area_ha,
        a.pyretechnics_crown_cells,
        a.area_ratio,
        a.both_cells,
        a.firecast_only_cells,
        a.pyretechnics_only_cells,
        a.jaccard,
        a.mean_abs_arrival_difference_h
    );
    let mut table = output::table(&["engine (1 thread)", "best wall s", "burnt cells/s", "ratio"]);
    table.add_row(timing_row(
        format!("pyretechnics {}: spread_fire_with_phi_field", r.peer.pyretechnics),
        &r.pyretechnics,
        "cells/s",
        1.0,
    ));
    table.add_row(timing_row(
        format!(
            "FireCast: minimum travel time ({} cells' ellipses evaluated)",
            r.firecast_ellipses_evaluated
        ),
        &r.firecast,
        "cells/s",
        r.cells_per_second_ratio,
    ));
    output::print_table(&table)?;
    println!(
        "ratio: FireCast {:.1}x pyretechnics in burnt cells per second, {:.1}x in wall time",
        r.cells_per_second_ratio, r.wall_ratio
    );
    println!("{}", goal_line(r.cells_per_second_ratio.min(r.wall_ratio)));
    Ok(ExitCode::SUCCESS)
}
