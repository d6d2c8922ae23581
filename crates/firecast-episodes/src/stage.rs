//! Two stage kinds:
//! - `sim.episodes`: run an agent for N episodes on a landscape; write the Table IV summary
//!   (JSON) and, optionally, a replayable trace of the first episode (its scenario, seed and
//!   every decision).
//! - `sim.render`: replay a trace and draw it: an animated GIF, PNG frames, a Rerun recording.
//!   Changing how a fire is drawn then never re-runs the episodes, and a replay that does not
//!   reproduce the recorded numbers is an error.
//!
//! Landscape and weather files (FireCastRL PNGs, GeoTIFFs, GRIDMET) are declared as the stages'
//! inputs `land_cover`, `elevation` and `gridmet`, so they are part of the cache key.

use firecast_pipeline::stage::SHARD_OUTPUT;
use firecast_pipeline::{
    ParamsError, Port, Ports, Shard, ShardedKind, StageContext, StageError, StageKind, typed_params,
};
use firecast_sim::EnvConfig;
use serde::{Deserialize, Serialize};

use crate::{AgentKind, EpisodeTrace, LandscapeSpec, Outputs, Scenario};

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
        /// [lat, lon] of the grid's centre.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        center: Option<[f64; 2]>,
    },
    /// The synthetic world's terrain and cover around `center` ([lat, lon]); the world's seed
    /// is the `firecast_seed` of the `gridmet` input's files (the world that wrote the weather).
    Synthetic {
        center: [f64; 2],
        #[serde(default = "super::default_width")]
        width: usize,
        #[serde(default = "super::default_height")]
        height: usize,
        #[serde(default = "super::default_cell_ft")]
        cell_size_ft: f64,
    },
    Firecastrl,
    /// A LANDFIRE landscape: the folder of LANDFIRE GeoTIFF layers or the `.lcp` given as the
    /// input `land_cover`, cut to `width` × `height` cells around `center` ([lat, lon]) or
    /// whole without a center (`crate::landfire`).
    Landfire {
        #[serde(default, skip_serializing_if = "crate::landfire::is_fbfm40")]
        fuel: crate::landfire::FuelLayerName,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        center: Option<[f64; 2]>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        width: Option<usize>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        height: Option<usize>,
    },
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
        name: "trace",
        required: false,
        many: false,
        description: "the first episode, replayable by sim.render (JSON)",
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
        let (scenario, land) = prepare_episodes(ctx, &params)?;
        let outputs = Outputs::default();
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
        episode_metrics(ctx, 0, &summary.report.episodes);
        let json = serde_json::to_vec_pretty(&summary)?;
        std::fs::write(ctx.output("summary")?, json)?;
        if let Ok(path) = ctx.output("trace") {
            let episode = summary
                .first_episode
                .clone()
                .ok_or_else(|| StageError::msg("no episode was run"))?;
            std::fs::write(path, trace_bytes(&params, episode)?)?;
        }
        ctx.log(summary_line(&summary.report, params.episodes));
        Ok(())
    }

    fn sharded(&self) -> Option<&dyn ShardedKind> {
        Some(self)
    }
}

/// `sim.episodes` shards by episode range: shard `i/N` runs episodes
/// `[E·i/N, E·(i+1)/N)` (episode `k` is seeded `seed + k` whatever the split) and writes a
/// part with its episodes; the merge concatenates them in order and computes the same
/// summary and trace bytes as the unsharded run.
impl ShardedKind for EpisodesStage {
    fn unit_name(&self) -> &'static str {
        "episodes"
    }

    fn units(&self, params: &serde_json::Value) -> Result<usize, ParamsError> {
        let params: EpisodesParams = firecast_pipeline::stage::deserialize_params(params)?;
        Ok(params.episodes)
    }

    fn run_shard(&self, ctx: &mut StageContext<'_>, shard: Shard) -> Result<(), StageError> {
        let params: EpisodesParams = ctx.params()?;
        let (scenario, land) = prepare_episodes(ctx, &params)?;
        let range = shard.range(params.episodes);
        let (stats, first) = crate::run_range(
            &scenario,
            &land,
            params.agent,
            range.clone(),
            params.seed,
            &Outputs::default(),
            |_| {},
        )?;
        episode_metrics(ctx, range.start, &stats);
        let trace = match first {
            Some(episode) => Some(String::from_utf8(trace_bytes(&params, episode)?)?),
            None => None,
        };
        let part = ShardPart {
            shard,
            start: range.start,
            end: range.end,
            landscape: scenario.landscape.clone(),
            wind_speed_mph_bits: scenario.env.sim.wind.speed_mph.to_bits(),
            wind_from_deg_bits: scenario.env.sim.wind.from_direction_deg.to_bits(),
            wind_measured_at: scenario.env.sim.wind.measured_at,
            episodes: stats.iter().map(PartEpisode::from).collect(),
            trace,
        };
        ctx.log(format!("shard {shard}: episodes {}..{}", range.start, range.end));
        std::fs::write(ctx.output(SHARD_OUTPUT)?, serde_json::to_vec(&part)?)?;
        Ok(())
    }

    /// The shards recorded the per-episode metrics (the unsharded run's only ones); the merge
    /// writes the outputs and the summary line.
    fn merge(&self, ctx: &mut StageContext<'_>, parts: &[std::path::PathBuf]) -> Result<(), StageError> {
        let params: EpisodesParams = ctx.params()?;
        let mut stats = Vec::with_capacity(params.episodes);
        let mut first: Option<ShardPart> = None;
        for (i, path) in parts.iter().enumerate() {
            let part: ShardPart = serde_json::from_slice(&std::fs::read(path)?)
                .map_err(|e| StageError::msg(format!("shard part {}: {e}", path.display())))?;
            if part.shard.index as usize != i
                || part.shard.count as usize != parts.len()
                || part.start != stats.len()
            {
                return Err(StageError::msg(format!(
                    "shard part {} is shard {} covering episodes {}..{}, expected shard {i}/{} starting at episode {}",
                    path.display(),
                    part.shard,
                    part.start,
                    part.end,
                    parts.len(),
                    stats.len()
                )));
            }
            stats.extend(part.episodes.iter().map(PartEpisode::stats));
            if i == 0 {
                first = Some(part);
            }
        }
        let head = first.ok_or_else(|| StageError::msg("no shard parts to merge"))?;
        if stats.len() != params.episodes {
            return Err(StageError::msg(format!(
                "the shards cover {} episodes, the stage has {}",
                stats.len(),
                params.episodes
            )));
        }
        let summary = crate::EpisodesSummary {
            agent: params.agent.name(),
            landscape: head.landscape,
            seed: params.seed,
            wind_speed_mph: f64::from_bits(head.wind_speed_mph_bits),
            wind_from_deg: f64::from_bits(head.wind_from_deg_bits),
            wind_measured_at: head.wind_measured_at,
            report: crate::eval_report(stats),
            first_episode: None,
        };
        std::fs::write(ctx.output("summary")?, serde_json::to_vec_pretty(&summary)?)?;
        if let Ok(path) = ctx.output("trace") {
            let trace = head
                .trace
                .ok_or_else(|| StageError::msg("shard 0 carries no trace of episode 0"))?;
            std::fs::write(path, trace)?;
        }
        ctx.log(summary_line(&summary.report, params.episodes));
        Ok(())
    }
}

/// What one shard of `sim.episodes` hands to the merge. Floats travel as their bits so
/// the merged summary is byte-identical to the unsharded one.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ShardPart {
    shard: Shard,
    start: usize,
    end: usize,
    landscape: LandscapeSpec,
    wind_speed_mph_bits: u64,
    wind_from_deg_bits: u64,
    wind_measured_at: firecast_sim::WindHeight,
    episodes: Vec<PartEpisode>,
    /// The trace output's exact bytes, from the shard that ran episode 0.
    trace: Option<String>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PartEpisode {
    seed: u64,
    cells_burned: u32,
    timesteps: u32,
    helitacks: u32,
    water_used_gal_bits: u64,
    terminated: bool,
}

impl From<&firecast_sim::EpisodeStats> for PartEpisode {
    fn from(s: &firecast_sim::EpisodeStats) -> Self {
        Self {
            seed: s.seed,
            cells_burned: s.cells_burned,
            timesteps: s.timesteps,
            helitacks: s.helitacks,
            water_used_gal_bits: s.water_used_gal.to_bits(),
            terminated: s.terminated,
        }
    }
}

impl PartEpisode {
    fn stats(&self) -> firecast_sim::EpisodeStats {
        firecast_sim::EpisodeStats {
            seed: self.seed,
            cells_burned: self.cells_burned,
            timesteps: self.timesteps,
            helitacks: self.helitacks,
            water_used_gal: f64::from_bits(self.water_used_gal_bits),
            terminated: self.terminated,
        }
    }
}

/// The scenario (with the day's GRIDMET wind when asked) and its landscape.
fn prepare_episodes(
    ctx: &StageContext<'_>,
    params: &EpisodesParams,
) -> Result<(Scenario, firecast_landscape::Landscape), StageError> {
    let env = serde_path_to_error_env(&params.env).map_err(|e| StageError::msg(e.message))?;
    let mut scenario = scenario_of(
        ctx,
        &params.landscape,
        env,
        params.weather_date.as_deref(),
        FuelMoistureSource::Scenario,
    )?;
    let (land, weather) = scenario.prepare(ctx.root())?;
    if let Some(w) = &weather {
        ctx.log(format!(
            "wind from GRIDMET on {}: vs {:.2} m/s from {:.0}° at ({:.4}, {:.4})",
            w.date, w.vs_m_s, w.th_deg, w.lat, w.lon
        ));
    }
    Ok((scenario, land))
}

/// Per-episode metrics, step = the episode's index in the whole stage.
fn episode_metrics(ctx: &StageContext<'_>, first: usize, episodes: &[firecast_sim::EpisodeStats]) {
    for (i, episode) in episodes.iter().enumerate() {
        let k = (first + i) as i64;
        ctx.metric("cells_burned", k, f64::from(episode.cells_burned));
        ctx.metric("timesteps", k, f64::from(episode.timesteps));
        ctx.metric("helitacks", k, f64::from(episode.helitacks));
        ctx.metric("water_used_gal", k, episode.water_used_gal);
    }
}

fn trace_bytes(params: &EpisodesParams, episode: EpisodeTrace) -> Result<Vec<u8>, StageError> {
    let trace = TraceFile {
        landscape: params.landscape.clone(),
        env: params.env.clone(),
        weather_date: params.weather_date.clone(),
        episode,
    };
    Ok(serde_json::to_vec(&trace)?)
}

fn summary_line(report: &firecast_sim::EvalReport, episodes: usize) -> String {
    format!(
        "cells burned {:.1} ± {:.1} over {episodes} episodes",
        report.cells_burned.mean, report.cells_burned.std
    )
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

/// Builds the scenario of a stage from its params and inputs.
fn scenario_of(
    ctx: &StageContext<'_>,
    landscape: &LandscapeParams,
    env: EnvConfig,
    weather_date: Option<&str>,
    fuel_moisture: FuelMoistureSource,
) -> Result<Scenario, StageError> {
    let input = |name: &str| -> Result<std::path::PathBuf, StageError> {
        ctx.input(name)
            .map(std::path::Path::to_path_buf)
            .map_err(|_| StageError::msg(format!("this scenario needs the input `{name}`")))
    };
    let landscape = match landscape {
        LandscapeParams::Procedural {
            seed,
            width,
            height,
            center,
        } => LandscapeSpec::Procedural {
            seed: *seed,
            width: *width,
            height: *height,
            center: *center,
        },
        LandscapeParams::Synthetic {
            center,
            width,
            height,
            cell_size_ft,
        } => {
            let dir = ctx.input("gridmet").map_err(|_| {
                StageError::msg(
                    "landscape.synthetic takes the synthetic world's seed from the GRIDMET files that \
                     wrote the weather: give the input `gridmet`",
                )
            })?;
            // The weather day's files when there is one, else every file of the folder.
            let year = weather_date.and_then(|d| d.get(..4)).and_then(|y| y.parse().ok());
            let seed = firecast_synth::world_seed(dir, year)
                .map_err(|e| StageError::msg(format!("landscape.synthetic: {e}")))?;
            LandscapeSpec::Synthetic {
                seed,
                center: *center,
                width: *width,
                height: *height,
                cell_size_ft: *cell_size_ft,
            }
        }
        LandscapeParams::Firecastrl => LandscapeSpec::Firecastrl {
            land_cover: input("land_cover")?,
            heightmap: input("elevation")?,
        },
        LandscapeParams::Landfire {
            fuel,
            center,
            width,
            height,
        } => {
            if ctx.input("elevation").is_ok() {
                return Err(StageError::msg(
                    "landscape.landfire takes the elevation from the LANDFIRE layers: remove the input `elevation`",
                ));
            }
            let path = ctx.input("land_cover").map_err(|_| {
                StageError::msg(
                    "landscape.landfire reads the LANDFIRE folder (GeoTIFF layers) or the .lcp given as the \
                     input `land_cover`",
                )
            })?;
            LandscapeSpec::Landfire {
                path: path.to_path_buf(),
                fuel: *fuel,
                center: *center,
                width: *width,
                height: *height,
                site: None,
            }
        }
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
    let weather = match weather_date {
        Some(date) => Some(crate::WeatherSpec::Gridmet {
            dir: input("gridmet")?,
            date: date.to_string(),
            fuel_moisture: fuel_moisture == FuelMoistureSource::Day,
            sky: Default::default(),
        }),
        None if fuel_moisture == FuelMoistureSource::Day => {
            return Err(StageError::msg(
                "fuel_moisture: day takes the day's moisture from GRIDMET; set `weather_date` too",
            ));
        }
        None => None,
    };
    Ok(Scenario {
        landscape,
        weather,
        env,
    })
}

/// What `sim.episodes` writes to `trace` and `sim.render` reads: the scenario as the stage's
/// params gave it (files come from the render stage's own inputs) and the episode.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TraceFile {
    landscape: LandscapeParams,
    #[serde(default)]
    env: serde_json::Value,
    #[serde(default)]
    weather_date: Option<String>,
    episode: EpisodeTrace,
}

/// Params of a `sim.render` stage.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderParams {
    /// Keep every k-th step in the GIF and the PNG frames (drops and the last step are always
    /// kept; the Rerun recording keeps every step).
    #[serde(default = "default_frame_every")]
    pub frame_every: usize,
}

#[derive(Debug, Default)]
pub struct RenderStage;

const RENDER_INPUTS: &[Port] = &[
    Port {
        name: "trace",
        required: true,
        many: false,
        description: "an episode trace written by sim.episodes",
    },
    INPUTS[0],
    INPUTS[1],
    INPUTS[2],
];
const RENDER_OUTPUTS: &[Port] = &[
    Port {
        name: "animation",
        required: false,
        many: false,
        description: "animated GIF: fire over hill-shaded terrain, drops, the helicopter",
    },
    Port {
        name: "frames",
        required: false,
        many: false,
        description: "folder of PNG frames (frame_NNNNN.png)",
    },
    Port {
        name: "recording",
        required: false,
        many: false,
        description: "Rerun recording (.rrd): terrain, fire state per step, helicopter, drops, counts",
    },
];

impl StageKind for RenderStage {
    fn name(&self) -> &'static str {
        "sim.render"
    }

    fn version(&self) -> u32 {
        1
    }

    fn summary(&self) -> &'static str {
        "replay an episode trace and draw it (GIF, PNG frames, Rerun recording)"
    }

    fn ports(&self) -> Ports {
        Ports {
            inputs: RENDER_INPUTS,
            outputs: RENDER_OUTPUTS,
            open: false,
        }
    }

    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (params, resolved): (RenderParams, serde_json::Value) = typed_params(raw)?;
        if params.frame_every == 0 {
            return Err(ParamsError {
                path: "frame_every".into(),
                message: "must be at least 1".into(),
            });
        }
        Ok(resolved)
    }

    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let params: RenderParams = ctx.params()?;
        let trace_path = ctx.input("trace")?.to_path_buf();
        let text = std::fs::read_to_string(&trace_path)?;
        let trace: TraceFile = serde_json::from_str(&text)
            .map_err(|e| StageError::msg(format!("{}: not an episode trace: {e}", trace_path.display())))?;
        let env = serde_path_to_error_env(&trace.env).map_err(|e| StageError::msg(e.message))?;
        let mut scenario = scenario_of(
            ctx,
            &trace.landscape,
            env,
            trace.weather_date.as_deref(),
            FuelMoistureSource::Scenario,
        )?;
        let (land, _) = scenario.prepare(ctx.root())?;
        let outputs = Outputs {
            frames_dir: ctx.output("frames").ok().map(std::path::Path::to_path_buf),
            gif: ctx.output("animation").ok().map(std::path::Path::to_path_buf),
            recording: ctx.output("recording").ok().map(std::path::Path::to_path_buf),
            frame_every: params.frame_every,
        };
        if outputs.frames_dir.is_none() && outputs.gif.is_none() && outputs.recording.is_none() {
            return Err(StageError::msg(
                "sim.render needs at least one of the outputs animation, frames, recording",
            ));
        }
        let stats = crate::replay(&scenario, &land, &trace.episode, &outputs)?;
        ctx.log(format!(
            "replayed {} agent, seed {}: {} steps, {} cells burned, {} drops",
            trace.episode.agent.name(),
            stats.seed,
            stats.timesteps,
            stats.cells_burned,
            stats.helitacks
        ));
        Ok(())
    }
}

/// Where an ensemble's fuel moisture comes from.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FuelMoistureSource {
    /// The Rothermel kernel's `moisture` in `env` (or the Concord kernel's drought table).
    #[default]
    Scenario,
    /// The day's: dead 1-h and 10-h from its temperature and humidity, 100-h and 1000-h from
    /// GRIDMET, live from the growing season index.
    Day,
}

/// Which engine spreads an ensemble's fires.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpreadEngine {
    #[default]
    Automaton,
    Mtt,
}

impl SpreadEngine {
    fn is_automaton(&self) -> bool {
        *self == Self::Automaton
    }
}

/// Params of a `sim.ensemble` stage (and, with a policy instead of an agent, `rl.ensemble`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnsembleParams {
    pub landscape: LandscapeParams,
    /// `none`, `rule` or `rule-concentric` (`rl.ensemble` plays its policy instead).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub agent: Option<AgentKind>,
    /// Runs (seeds `seed`, `seed + 1`, …).
    #[serde(default = "default_runs")]
    pub runs: usize,
    #[serde(default)]
    pub seed: u64,
    #[serde(default)]
    pub env: serde_json::Value,
    /// Take the wind of this day from the `gridmet` input.
    #[serde(default)]
    pub weather_date: Option<String>,
    /// [lat, lon] of the ignition (default: the environment's ignition cell).
    #[serde(default)]
    pub ignition: Option<[f64; 2]>,
    /// `scenario` (the moistures `env` gives, the default) or `day` (the day's, derived from
    /// GRIDMET on `weather_date`; docs/spec/fire-model.md §B12).
    #[serde(default)]
    pub fuel_moisture: FuelMoistureSource,
    /// `automaton` (the default: FireCastRL's automaton, which every agent plays) or `mtt` (the
    /// minimum-travel-time engine verified against Rothermel's ellipse; `sim.ensemble` with
    /// `agent: none` only).
    #[serde(default, skip_serializing_if = "SpreadEngine::is_automaton")]
    pub engine: SpreadEngine,
    /// `engine: mtt` only: grow the map (around its centre, doubling width and height) until
    /// no run burns a border cell, at most `max_factor` times the given size per side.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grow: Option<GrowParams>,
    /// How each run departs from the day's wind and fuel moisture.
    #[serde(default)]
    pub perturb: crate::ensemble::Perturbation,
    /// `rl.ensemble` only: `auto`, `cpu` or `cuda[:N]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device: Option<String>,
    /// `rl.ensemble` only: libtorch threads (part of the result; default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub threads: Option<usize>,
}

fn default_runs() -> usize {
    20
}

/// How far an MTT ensemble's map may grow.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GrowParams {
    /// Width and height at most this many times the landscape's (1, 2, 4, 8 or 16).
    #[serde(default = "default_max_factor")]
    pub max_factor: u32,
}

fn default_max_factor() -> u32 {
    4
}

impl EnsembleParams {
    /// Checks what both ensemble kinds check; `agent_required` for `sim.ensemble`.
    pub fn validate(&self, agent_required: bool) -> Result<(), ParamsError> {
        serde_path_to_error_env(&self.env)?;
        self.perturb.validate().map_err(|message| ParamsError {
            path: "perturb".into(),
            message,
        })?;
        if self.runs == 0 {
            return Err(ParamsError {
                path: "runs".into(),
                message: "must be at least 1".into(),
            });
        }
        if self.engine == SpreadEngine::Mtt && (!agent_required || self.agent != Some(AgentKind::None)) {
            return Err(ParamsError {
                path: "engine".into(),
                message:
                    "the mtt engine spreads the fire freely (no helicopter): use it with sim.ensemble and \
                          agent: none"
                        .into(),
            });
        }
        if let Some(g) = self.grow {
            if self.engine != SpreadEngine::Mtt {
                return Err(ParamsError {
                    path: "grow".into(),
                    message:
                        "only the mtt engine grows its map (engine: mtt); the automaton's ensembles take \
                              the grown size from the input `domain`"
                            .into(),
                });
            }
            if !matches!(g.max_factor, 1 | 2 | 4 | 8 | 16) {
                return Err(ParamsError {
                    path: "grow.max_factor".into(),
                    message: format!(
                        "{} is not one of 1, 2, 4, 8, 16 (the map doubles each time)",
                        g.max_factor
                    ),
                });
            }
            if !matches!(
                self.landscape,
                LandscapeParams::Synthetic { .. }
                    | LandscapeParams::Geotiff { .. }
                    | LandscapeParams::Landfire { center: Some(_), .. }
            ) {
                return Err(ParamsError {
                    path: "grow".into(),
                    message: "only a landscape anchored to the world (synthetic, geotiff, landfire with a center) can \
                              grow around its centre"
                        .into(),
                });
            }
        }
        match (agent_required, self.agent) {
            (true, None) => Err(ParamsError {
                path: "agent".into(),
                message: "missing: none, rule, rule-concentric or chaser".into(),
            }),
            (false, Some(_)) => Err(ParamsError {
                path: "agent".into(),
                message: "rl.ensemble plays the policy of its `run` input; remove `agent`".into(),
            }),
            _ => Ok(()),
        }
    }
}

/// The scenario of an ensemble stage, with its ignition placed and checked.
/// With the input `domain` (an ensemble file), the landscape takes that ensemble's size: the
/// automaton's strategies then burn on the map the verified engine's free fire grew to.
pub fn prepare_ensemble(
    ctx: &StageContext<'_>,
    params: &EnsembleParams,
) -> Result<crate::ensemble::Setup, StageError> {
    let size = match ctx.input("domain") {
        Ok(path) => {
            let domain = crate::ensemble::Ensemble::read(path)?;
            Some((domain.grid.width, domain.grid.height, domain.domain))
        }
        Err(_) => None,
    };
    let mut setup = prepare_ensemble_sized(ctx, params, size.map(|(w, h, _)| (w, h)))?;
    if let Some((_, _, growth)) = size {
        setup.domain = growth;
    }
    Ok(setup)
}

/// The setup at a given size (None: the landscape's own).
fn prepare_ensemble_sized(
    ctx: &StageContext<'_>,
    params: &EnsembleParams,
    size: Option<(usize, usize)>,
) -> Result<crate::ensemble::Setup, StageError> {
    let env = serde_path_to_error_env(&params.env).map_err(|e| StageError::msg(e.message))?;
    let mut scenario = scenario_of(
        ctx,
        &params.landscape,
        env,
        params.weather_date.as_deref(),
        params.fuel_moisture,
    )?;
    if let Some((w, h)) = size {
        scenario.landscape = crate::free_spread::resized(&scenario.landscape, w, h).ok_or_else(|| {
            StageError::msg(
                "input `domain`: this landscape cannot be built at another size (only synthetic and geotiff \
                 landscapes can)",
            )
        })?;
    }
    let setup =
        crate::ensemble::Setup::new(scenario, ctx.root(), params.ignition)?.with_perturbation(params.perturb);
    if let Some(w) = &setup.weather {
        ctx.log(format!(
            "wind from GRIDMET on {}: vs {:.2} m/s from {:.0}° at ({:.4}, {:.4})",
            w.date, w.vs_m_s, w.th_deg, w.lat, w.lon
        ));
    }
    Ok(setup)
}

/// Ports shared by `sim.ensemble` and `rl.ensemble` (which adds `policy`).
pub const ENSEMBLE_INPUTS: &[Port] = &[
    INPUTS[0],
    INPUTS[1],
    INPUTS[2],
    Port {
        name: "domain",
        required: false,
        many: false,
        description: "an ensemble whose map size to burn on (the size an MTT ensemble's `grow` chose)",
    },
];
pub const ENSEMBLE_OUTPUTS: &[Port] = &[Port {
    name: "ensemble",
    required: true,
    many: false,
    description: "every run's burnt area, drops and arrival times, and burn probability (JSON)",
}];

/// Writes an ensemble stage's output, with per-run metrics and a log line naming `who` played
/// (shared by `sim.ensemble` and `rl.ensemble`).
pub fn write_ensemble(
    ctx: &StageContext<'_>,
    ensemble: &crate::ensemble::Ensemble,
    who: &str,
) -> Result<(), StageError> {
    for (k, e) in ensemble.episodes.iter().enumerate() {
        ctx.metric("cells_burned", k as i64, f64::from(e.cells_burned));
        ctx.metric("helitacks", k as i64, f64::from(e.helitacks));
    }
    std::fs::write(ctx.output("ensemble")?, serde_json::to_vec(ensemble)?)?;
    let mean = ensemble
        .episodes
        .iter()
        .map(|e| f64::from(e.cells_burned))
        .sum::<f64>()
        / ensemble.runs() as f64;
    ctx.log(format!(
        "{who}: {} runs, {mean:.0} cells burned on average",
        ensemble.runs()
    ));
    if let Some(label) = &ensemble.landscape {
        ctx.log(label.note.clone());
    }
    if let Some(edge) = ensemble.edge_summary() {
        ctx.log(format!("{who}: {edge}"));
    }
    Ok(())
}

/// `sim.ensemble`: a rule-based agent (or none) against one fire over many seeds.
#[derive(Debug, Default)]
pub struct EnsembleStage;

impl StageKind for EnsembleStage {
    fn name(&self) -> &'static str {
        "sim.ensemble"
    }

    fn version(&self) -> u32 {
        // 2: the landscape's label and each run's edge cells in the file.
        2
    }

    fn summary(&self) -> &'static str {
        "one fire over many seeds under a rule-based agent: arrival times, burn probability, drops"
    }

    fn ports(&self) -> Ports {
        Ports {
            inputs: ENSEMBLE_INPUTS,
            outputs: ENSEMBLE_OUTPUTS,
            open: false,
        }
    }

    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (params, mut resolved): (EnsembleParams, serde_json::Value) = typed_params(raw)?;
        params.validate(true)?;
        if let Some(obj) = resolved.as_object_mut()
            && params.env.is_null()
        {
            obj.insert("env".into(), serde_json::json!({}));
        }
        Ok(resolved)
    }

    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let params: EnsembleParams = ctx.params()?;
        let agent = params.agent.unwrap_or(AgentKind::None);
        let setup = prepare_ensemble(ctx, &params)?;
        let bar = ctx.progress_bar(params.runs as u64, &format!("{} agent", agent.name()));
        let ensemble = match params.engine {
            SpreadEngine::Automaton => {
                crate::ensemble::run_agent(&setup, agent, params.runs, params.seed, |_| bar.inc(1))?
            }
            SpreadEngine::Mtt => match params.grow {
                None => crate::free_spread::run_mtt(&setup, params.runs, params.seed, |_| bar.inc(1))?,
                Some(g) => {
                    let base = [setup.landscape.width, setup.landscape.height];
                    let mut first = Some(setup);
                    let ensemble = crate::free_spread::run_mtt_growing(
                        |w, h| {
                            bar.set_position(0);
                            match first.take() {
                                Some(s) if [s.landscape.width, s.landscape.height] == [w, h] => Ok(s),
                                _ => {
                                    ctx.log(format!(
                                        "a run reached the map's edge: growing the map to {w} × {h} cells"
                                    ));
                                    prepare_ensemble_sized(ctx, &params, Some((w, h))).map_err(|e| {
                                        crate::EpisodeError::Engine(format!("growing the map: {e}"))
                                    })
                                }
                            }
                        },
                        base,
                        g.max_factor,
                        params.runs,
                        params.seed,
                        |_| bar.inc(1),
                    )?;
                    if let Some(d) = ensemble.domain.filter(|d| !d.contained) {
                        ctx.log(format!(
                            "the map reached its largest size ({} × {} cells) and runs still burned its border",
                            d.size[0], d.size[1]
                        ));
                    }
                    ensemble
                }
            },
        };
        bar.finish_and_clear();
        write_ensemble(ctx, &ensemble, agent.name())
    }
}
