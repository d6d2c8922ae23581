//! `uses: sim.episodes`: run an agent for N episodes on a landscape; write the Table IV
//! summary (JSON), and optionally an animated GIF and a Rerun recording of the first
//! episode. Landscape files (FireCastRL PNGs, GeoTIFFs) are declared as the stage's inputs
//! `land_cover` and `elevation`, so they are part of the cache key.

use firecast_pipeline::{ParamsError, Port, Ports, StageContext, StageError, StageKind, typed_params};
use firecast_sim::EnvConfig;
use serde::{Deserialize, Serialize};

use crate::{AgentKind, LandscapeSpec, Outputs, Scenario};

/// Params of a `sim.episodes` stage.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EpisodesParams {
    /// `procedural`, `firecastrl` or `geotiff` (the last two read the stage's inputs).
    pub landscape: LandscapeParams,
    pub agent: AgentKind,
    #[serde(default = "default_episodes")]
    pub episodes: usize,
    #[serde(default)]
    pub seed: u64,
    /// Keep every k-th step in the GIF.
    #[serde(default = "default_frame_every")]
    pub frame_every: usize,
    /// Environment and simulator settings (wind, kernel, rewards, max steps, …).
    #[serde(default)]
    pub env: serde_json::Value,
    /// Take the wind of this day (YYYY-MM-DD) from the GRIDMET files of the `gridmet` input
    /// (`vs`, `th` at the landscape's centre), instead of `env.sim.wind`.
    #[serde(default)]
    pub weather_date: Option<String>,
}

fn default_episodes() -> usize {
    10
}
fn default_frame_every() -> usize {
    4
}

/// The landscape, with file paths coming from the stage's inputs.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum LandscapeParams {
    Procedural {
        seed: u64,
        #[serde(default = "super::default_width")]
        width: usize,
        #[serde(default = "super::default_height")]
        height: usize,
    },
    Firecastrl,
    Geotiff {
        scheme: super::SchemeName,
        center_lat: f64,
        center_lon: f64,
        #[serde(default = "super::default_width")]
        width: usize,
        #[serde(default = "super::default_height")]
        height: usize,
        #[serde(default = "super::default_cell_ft")]
        cell_size_ft: f64,
    },
}

#[derive(Debug, Default)]
pub struct EpisodesStage;

const INPUTS: &[Port] = &[
    Port {
        name: "land_cover",
        required: false,
        many: false,
        description: "land-cover raster (FireCastRL palette PNG or GeoTIFF)",
    },
    Port {
        name: "elevation",
        required: false,
        many: false,
        description: "elevation raster (FireCastRL 16-bit height PNG or GeoTIFF)",
    },
    Port {
        name: "gridmet",
        required: false,
        many: false,
        description: "folder of GRIDMET files vs_YYYY.nc and th_YYYY.nc (with `weather_date`)",
    },
];
const OUTPUTS: &[Port] = &[
    Port {
        name: "summary",
        required: true,
        many: false,
        description: "Table IV numbers per episode and mean ± std (JSON)",
    },
    Port {
        name: "animation",
        required: false,
        many: false,
        description: "animated GIF of the first episode",
    },
    Port {
        name: "recording",
        required: false,
        many: false,
        description: "Rerun recording (.rrd) of the first episode",
    },
];

impl StageKind for EpisodesStage {
    fn name(&self) -> &'static str {
        "sim.episodes"
    }

    fn version(&self) -> u32 {
        // 2: wind heights and GRIDMET weather; fire-survivor draws change ChaCha streams.
        2
    }

    fn summary(&self) -> &'static str {
        "run a helitack agent for N episodes on a landscape (Table IV numbers, GIF, Rerun)"
    }

    fn ports(&self) -> Ports {
        Ports {
            inputs: INPUTS,
            outputs: OUTPUTS,
            open: false,
        }
    }

    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (params, mut resolved): (EpisodesParams, serde_json::Value) = typed_params(raw)?;
        // Validate the env block against the simulator's strict config, with its key path.
        serde_path_to_error_env(&params.env)?;
        if params.episodes == 0 {
            return Err(ParamsError {
                path: "episodes".into(),
                message: "must be at least 1".into(),
            });
        }
        if let Some(obj) = resolved.as_object_mut()
            && params.env.is_null()
        {
            obj.insert("env".into(), serde_json::json!({}));
        }
        Ok(resolved)
    }

    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let params: EpisodesParams = ctx.params()?;
        let env = serde_path_to_error_env(&params.env).map_err(|e| StageError::msg(e.message))?;
        let input = |name: &str| -> Result<std::path::PathBuf, StageError> {
            ctx.input(name)
                .map(std::path::Path::to_path_buf)
                .map_err(|_| StageError::msg(format!("this landscape needs the input `{name}`")))
        };
        let landscape = match &params.landscape {
            LandscapeParams::Procedural { seed, width, height } => LandscapeSpec::Procedural {
                seed: *seed,
                width: *width,
                height: *height,
            },
            LandscapeParams::Firecastrl => LandscapeSpec::Firecastrl {
                land_cover: input("land_cover")?,
                heightmap: input("elevation")?,
            },
            LandscapeParams::Geotiff {
                scheme,
                center_lat,
                center_lon,
                width,
                height,
                cell_size_ft,
            } => LandscapeSpec::Geotiff {
                land_cover: input("land_cover")?,
                elevation: input("elevation")?,
                scheme: *scheme,
                center_lat: *center_lat,
                center_lon: *center_lon,
                width: *width,
                height: *height,
                cell_size_ft: *cell_size_ft,
            },
        };
        let weather = match &params.weather_date {
            Some(date) => Some(crate::WeatherSpec::Gridmet {
                dir: input("gridmet")?,
                date: date.clone(),
            }),
            None => None,
        };
        let mut scenario = Scenario {
            landscape,
            weather,
            env,
        };
        let (land, weather) = scenario.prepare(ctx.root())?;
        if let Some(w) = &weather {
            ctx.log(format!(
                "wind from GRIDMET on {}: vs {:.2} m/s from {:.0}° at ({:.4}, {:.4})",
                w.date, w.vs_m_s, w.th_deg, w.lat, w.lon
            ));
        }
        let outputs = Outputs {
            frames_dir: None,
            gif: ctx.output("animation").ok().map(std::path::Path::to_path_buf),
            recording: ctx.output("recording").ok().map(std::path::Path::to_path_buf),
            frame_every: params.frame_every,
        };
        let bar = ctx.progress_bar(params.episodes as u64, &format!("{} agent", params.agent.name()));
        let summary = crate::run(
            &scenario,
            &land,
            params.agent,
            params.episodes,
            params.seed,
            &outputs,
            |_| {
                bar.inc(1);
            },
        )?;
        bar.finish_and_clear();
        for (k, episode) in summary.report.episodes.iter().enumerate() {
            ctx.metric("cells_burned", k as i64, f64::from(episode.cells_burned));
            ctx.metric("timesteps", k as i64, f64::from(episode.timesteps));
            ctx.metric("helitacks", k as i64, f64::from(episode.helitacks));
            ctx.metric("water_used_gal", k as i64, episode.water_used_gal);
        }
        let json = serde_json::to_vec_pretty(&summary)?;
        std::fs::write(ctx.output("summary")?, json)?;
        ctx.log(format!(
            "cells burned {:.1} ± {:.1} over {} episodes",
            summary.report.cells_burned.mean, summary.report.cells_burned.std, params.episodes
        ));
        Ok(())
    }
}

/// Deserialize the `env` block strictly, reporting the key path under `env.`.
fn serde_path_to_error_env(value: &serde_json::Value) -> Result<EnvConfig, ParamsError> {
    if value.is_null() {
        return Ok(EnvConfig::default());
    }
    firecast_pipeline::stage::deserialize_params(value).map_err(|e: ParamsError| ParamsError {
        path: if e.path.is_empty() {
            "env".into()
        } else {
            format!("env.{}", e.path)
        },
        message: e.message,
    })
}
