//! `sim.behavior`: fire behaviour grids over a LANDFIRE landscape folder or a FARSITE/FlamMap
//! `.lcp` (a file, or a folder holding one with its `.prj`) ([`firecast_sim::behavior`]): rate of spread, flame length, fireline intensity, direction of
//! maximum spread and fire type (surface, passive or active crown fire; params `crown:
//! finney | scott-reinhardt | none`, `foliar_moisture_pct`) as float32 GeoTIFFs, plus
//! `summary.json`.

use firecast_pipeline::{ParamsError, Port, Ports, StageContext, StageError, StageKind, typed_params};
use firecast_sim::behavior::{BehaviorParams, run_behavior};

/// The `sim.behavior` stage kind.
#[derive(Debug, Default)]
pub struct BehaviorStage;

const BEHAVIOR_INPUTS: &[Port] = &[Port {
    name: "landscape",
    required: true,
    many: false,
    description: "a LANDFIRE landscape folder (FBFM40 or FBFM13, slope, aspect; canopy layers optional), a \
                  FARSITE/FlamMap .lcp file, or a folder holding one .lcp and its .prj",
}];
const BEHAVIOR_OUTPUTS: &[Port] = &[Port {
    name: "grids",
    required: true,
    many: false,
    description: "folder of float32 GeoTIFFs (ros_chph, flame_length_ft, fireline_intensity_btu_ft_s, \
                  max_spread_direction_deg, fire_type) and summary.json",
}];

impl StageKind for BehaviorStage {
    fn name(&self) -> &'static str {
        "sim.behavior"
    }

    fn version(&self) -> u32 {
        // 3: .lcp landscapes; summary.json names the landscape's format and stored units;
        // nodata at a burnable cell is an error.
        3
    }

    fn summary(&self) -> &'static str {
        "surface and crown fire behaviour grids over a LANDFIRE landscape or a FARSITE .lcp (GeoTIFFs and a summary)"
    }

    fn ports(&self) -> Ports {
        Ports {
            inputs: BEHAVIOR_INPUTS,
            outputs: BEHAVIOR_OUTPUTS,
            open: false,
        }
    }

    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (params, resolved): (BehaviorParams, serde_json::Value) = typed_params(raw)?;
        params.validate().map_err(|e| ParamsError {
            path: e.field.into(),
            message: format!("{} (got {})", e.message, e.value),
        })?;
        Ok(resolved)
    }

    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let params: BehaviorParams = ctx.params()?;
        let landscape = ctx.input("landscape")?.to_path_buf();
        let out = ctx.output("grids")?.to_path_buf();
        let summary = run_behavior(&landscape, &params, &out).map_err(|e| StageError::msg(e.to_string()))?;
        let surface = summary.fire_type_cells.get("surface").copied().unwrap_or(0);
        ctx.log(format!(
            "{} x {} cells: {surface} surface fire, {} no fire, {} nodata",
            summary.width,
            summary.height,
            summary.fire_type_cells.get("none").copied().unwrap_or(0),
            summary.nodata_cells
        ));
        ctx.metric("surface_cells", 0, surface as f64);
        ctx.metric("nodata_cells", 0, summary.nodata_cells as f64);
        if let Some(r) = summary.ros_chph {
            ctx.metric("ros_chph_max", 0, r.max);
            ctx.metric("ros_chph_mean", 0, r.mean);
        }
        Ok(())
    }
}
