//! `firecast bench behavior`: fire behaviour of every cell of a LANDFIRE landscape beside
//! pyretechnics ([`crate::pyretechnics`]), one thread each, same landscape and inputs:
//! agreement on rate of spread first (exit status 1 if it fails), then grid cells per second
//! and the ratio.

use std::fmt::Write as _;
use std::path::PathBuf;

use firecast_spread::landfire::Window;

use crate::Context;
use crate::pyretechnics::{
    self, BehaviorBench, FireBenchArgs, GOAL, QUICK_BEHAVIOR, goal_line, inputs_line, options, shown,
    timing_row,
};

/// `firecast bench behavior`'s flags.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub common: FireBenchArgs,
    /// 20-ft wind speed, mi/h [default: 0, FlamMap's run on the Worcester clip].
    #[arg(long, default_value_t = 0.0, value_name = "MPH")]
    pub wind_mph: f64,
    /// Crown fire method: finney (FlamMap's default), scott-reinhardt, or none.
    #[arg(long, default_value = "finney", value_name = "finney|scott-reinhardt|none")]
    pub crown: String,
}

/// `firecast bench behavior`.
pub fn run(ctx: &Context, args: &Args) -> anyhow::Result<BehaviorReport> {
    let (opts, work) = options(ctx, &args.common, args.wind_mph, &args.crown)?;
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
    let result = pyretechnics::bench_behavior(&opts, window);
    let _ = std::fs::remove_dir_all(&work);
    let r = result?;
    Ok(BehaviorReport {
        bench: r,
        root: ctx.root.clone(),
    })
}

/// `firecast bench behavior`'s report.
#[derive(Debug)]
pub struct BehaviorReport {
    pub bench: BehaviorBench,
    /// The project root, to show the landscape's path as the user would type it.
    pub root: PathBuf,
}

impl serde::Serialize for BehaviorReport {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut v = serde_json::to_value(&self.bench).map_err(serde::ser::Error::custom)?;
        v["agreement_holds"] = self.bench.agreement.holds().into();
        v["goal"] = GOAL.into();
        v.serialize(s)
    }
}

impl crate::Report for BehaviorReport {
    fn render(&self) -> String {
        let mut out = String::new();
        let _ = self.write(&mut out);
        out
    }

    /// 1 when the two engines disagree on the rate of spread.
    fn exit_code(&self) -> u8 {
        u8::from(!self.bench.agreement.holds())
    }
}

impl BehaviorReport {
    fn write(&self, out: &mut String) -> std::fmt::Result {
        let (r, agrees) = (&self.bench, self.bench.agreement.holds());
        let a = &r.agreement;
        writeln!(
            out,
            "fire behaviour of every cell: {} ({} x {} cells from col {}, row {}; {} burning), {}; crown {:?}",
            shown(&self.root, &r.landscape).display(),
            r.window.cols,
            r.window.rows,
            r.window.col0,
            r.window.row0,
            r.burning_cells,
            inputs_line(&r.params),
            r.params.crown
        )?;
        writeln!(
            out,
            "machine: {}; one thread each; pyretechnics {} (Python {}, numpy {})",
            r.machine, r.peer.pyretechnics, r.peer.python, r.peer.numpy
        )?;
        writeln!(
            out,
            "agreement: {} of {} cells within {:.1} % on rate of spread (max {:.3} %){}; compared: {}",
            a.within_tolerance,
            a.compared_cells,
            a.tolerance * 100.0,
            a.max_relative_difference * 100.0,
            if agrees { "" } else { " DISAGREE" },
            a.rule
        )?;
        writeln!(
            out,
            "  all cells both call surface fire: {} of {} within {:.1} % (max {:.3} %)",
            a.surface_within_tolerance,
            a.surface_cells,
            a.tolerance * 100.0,
            a.surface_max_relative_difference * 100.0
        )?;
        writeln!(
            out,
            "  fire type equal on {} of {} cells; none/surface/passive/active: FireCast {:?}, pyretechnics {:?}",
            a.fire_type_equal_cells, r.cells, a.firecast_fire_types, a.pyretechnics_fire_types
        )?;
        let mut table = crate::table(&["engine (1 thread)", "repeats", "best s", "grid cells/s", "ratio"]);
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
        writeln!(out, "{table}")?;
        writeln!(out, "ratio: FireCast {:.1}x pyretechnics", r.ratio)?;
        writeln!(out, "{}", goal_line(r.ratio))?;
        Ok(())
    }
}
