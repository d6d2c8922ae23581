//! `firecast bench spread`: a point fire spread for 8 hours beside pyretechnics' level set
//! ([`crate::pyretechnics`]), one thread each, same landscape and inputs: FireCast's
//! minimum-travel-time engine, wall seconds, burnt cells per second, the ratios and both burnt
//! areas.

use std::fmt::Write as _;
use std::path::PathBuf;

use firecast_spread::landfire::Window;

use crate::Context;
use crate::pyretechnics::{
    self, DEFAULT_IGNITION, FireBenchArgs, GOAL, QUICK_SPREAD, SpreadBench, goal_line, inputs_line, options,
    shown, timing_row,
};

/// `firecast bench spread`'s flags.
#[derive(Debug, clap::Args)]
pub struct Args {
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
pub fn run(ctx: &Context, args: &Args) -> anyhow::Result<SpreadReport> {
    let (opts, work) = options(ctx, &args.common, args.wind_mph, "finney")?;
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
    let result = pyretechnics::bench_spread(&opts, ignition, args.hours, args.stencil_radius, window);
    let _ = std::fs::remove_dir_all(&work);
    let r = result?;
    Ok(SpreadReport {
        bench: r,
        root: ctx.root.clone(),
    })
}

/// `firecast bench spread`'s report.
#[derive(Debug)]
pub struct SpreadReport {
    pub bench: SpreadBench,
    /// The project root, to show the landscape's path as the user would type it.
    pub root: PathBuf,
}

impl serde::Serialize for SpreadReport {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut v = serde_json::to_value(&self.bench).map_err(serde::ser::Error::custom)?;
        v["goal"] = GOAL.into();
        v.serialize(s)
    }
}

impl crate::Report for SpreadReport {
    fn render(&self) -> String {
        let mut out = String::new();
        let _ = self.write(&mut out);
        out
    }
}

impl SpreadReport {
    fn write(&self, out: &mut String) -> std::fmt::Result {
        let r = &self.bench;
        let a = &r.areas;
        writeln!(
            out,
            "point fire for {} h from col {}, row {}: {} ({} x {} cells from col {}, row {}), {}",
            r.hours,
            r.ignition.0,
            r.ignition.1,
            shown(&self.root, &r.landscape).display(),
            r.window.cols,
            r.window.rows,
            r.window.col0,
            r.window.row0,
            inputs_line(&r.params)
        )?;
        writeln!(
            out,
            "machine: {}; one thread each; pyretechnics {} (Python {}, numpy {})",
            r.machine, r.peer.pyretechnics, r.peer.python, r.peer.numpy
        )?;
        writeln!(
            out,
            "different algorithms: FireCast minimum travel time (Dijkstra, radius-{} stencil, surface fire), \
             pyretechnics Eulerian level set (surface and crown fire; stopped: {})",
            r.stencil_radius,
            r.peer.stop_condition.as_deref().unwrap_or("?")
        )?;
        writeln!(
            out,
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
        )?;
        let mut table = crate::table(&[
            "engine (1 thread)",
            "repeats",
            "best wall s",
            "burnt cells/s",
            "ratio",
        ]);
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
        writeln!(out, "{table}")?;
        writeln!(
            out,
            "ratio: FireCast {:.1}x pyretechnics in burnt cells per second, {:.1}x in wall time",
            r.cells_per_second_ratio, r.wall_ratio
        )?;
        writeln!(out, "{}", goal_line(r.cells_per_second_ratio.min(r.wall_ratio)))?;
        Ok(())
    }
}
