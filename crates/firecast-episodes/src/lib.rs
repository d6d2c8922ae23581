//! Suppression episodes: a helitack agent against a simulated fire on a landscape.
//!
//! One [`Scenario`] (landscape + environment config, strict YAML) and an [`AgentKind`] give
//! the paper's Table IV numbers per episode and as mean ± std ([`run`]); optionally the
//! first episode is drawn as PNG frames / an animated GIF (fire over hill-shaded terrain,
//! drop footprints) and logged to a Rerun recording (terrain, fire state per step,
//! helicopter, drops, burning/burnt counts). [`EpisodesStage`] runs the same as the
//! `sim.episodes` pipeline stage. [`record_episode`] draws one episode of any policy (a
//! trained PPO agent, say) the same way, with the helicopter's path.

mod behavior_stage;
pub mod ensemble;
pub mod free_spread;
pub mod landfire;
mod stage;
mod weather;

use std::path::{Path, PathBuf};
use std::str::FromStr;

use firecast_landscape::{LandCoverScheme, Landscape, procedural};
use firecast_sim::{
    Action, Decision, EnvConfig, EpisodeStats, EvalReport, FireChaser, MeanStd, NoSuppression, Observation,
    Policy, RuleBasedAgent, StepInfo, WildfireEnv, run_episode,
};
use serde::{Deserialize, Serialize};

pub use behavior_stage::BehaviorStage;
pub use stage::{
    EnsembleParams, EnsembleStage, EpisodesStage, FuelMoistureSource, RenderStage, SpreadEngine,
    prepare_ensemble, write_ensemble,
};
pub use weather::{DayFuelMoisture, ResolvedWeather, WeatherSpec};

/// Registers this crate's stage kinds: `sim.episodes`, `sim.render`, `sim.ensemble`,
/// `sim.behavior`.
pub fn register(kinds: &mut firecast_pipeline::StageKinds) {
    kinds
        .register(EpisodesStage)
        .register(RenderStage)
        .register(EnsembleStage)
        .register(BehaviorStage);
}

/// Errors of scenario loading and episode runs. Paths come last.
#[derive(Debug, thiserror::Error)]
pub enum EpisodeError {
    #[error("invalid landscape `{spec}`: {reason}")]
    LandscapeSpec { spec: String, reason: String },
    #[error("unknown agent `{0}` (use none, rule, rule-concentric or chaser)")]
    Agent(String),
    #[error(transparent)]
    Landscape(#[from] firecast_landscape::LandscapeError),
    #[error(transparent)]
    Gridmet(#[from] firecast_data::gridmet::GridmetError),
    #[error("weather from {path}: {message}")]
    Weather { path: PathBuf, message: String },
    #[error("ignition: {message}")]
    Ignition { message: String },
    #[error("ensemble {path}: {message}")]
    Ensemble { path: PathBuf, message: String },
    #[error(
        "replaying the trace diverged: it recorded {recorded}, the replay gave {replayed} (the trace \
         was made with other code, settings or inputs)"
    )]
    ReplayDiverged { recorded: String, replayed: String },
    #[error(transparent)]
    Sim(#[from] firecast_sim::SimError),
    #[error(transparent)]
    Render(#[from] firecast_render::RenderError),
    #[error(transparent)]
    Recorder(#[from] firecast_recorder::RecorderError),
    #[error("cannot read scenario: {path}: {source}")]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}")]
    Scenario(#[from] firecast_pipeline::SpecError),
    /// A spread engine refused the scenario.
    #[error("spread engine: {0}")]
    Engine(String),
    #[error("{context}: {path}: {source}")]
    Io {
        context: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Where the terrain comes from.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum LandscapeSpec {
    /// A seeded procedural landscape (fractal relief, land cover following elevation).
    Procedural {
        seed: u64,
        #[serde(default = "default_width")]
        width: usize,
        #[serde(default = "default_height")]
        height: usize,
        /// Where on Earth the grid lies, [lat, lon] (default 37.5, −119.5): it places the
        /// GRIDMET cell a scenario's weather is read from.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        center: Option<[f64; 2]>,
    },
    /// The synthetic world's own terrain and land cover at a place (MODIS IGBP classes): the
    /// world `seed` of the generator that wrote the synthetic GRIDMET weather, sampled on a
    /// grid around `center` ([lat, lon]); docs/spec/data.md §7.5.
    Synthetic {
        seed: u64,
        center: [f64; 2],
        #[serde(default = "default_width")]
        width: usize,
        #[serde(default = "default_height")]
        height: usize,
        #[serde(default = "default_cell_ft")]
        cell_size_ft: f64,
    },
    /// FireCastRL's map format: land-cover palette PNG and 16-bit height-map PNG.
    Firecastrl { land_cover: PathBuf, heightmap: PathBuf },
    /// GeoTIFF land cover (MODIS IGBP, or LANDFIRE FBFM13/FBFM40) and elevation (metres),
    /// resampled onto a grid centred at (`center_lat`, `center_lon`).
    Geotiff {
        land_cover: PathBuf,
        elevation: PathBuf,
        scheme: SchemeName,
        center_lat: f64,
        center_lon: f64,
        #[serde(default = "default_width")]
        width: usize,
        #[serde(default = "default_height")]
        height: usize,
        #[serde(default = "default_cell_ft")]
        cell_size_ft: f64,
    },
    /// A LANDFIRE landscape at its own resolution: a folder of LANDFIRE GeoTIFF layers or a
    /// FARSITE/FlamMap `.lcp` (`path`), cut to `width` × `height` cells (default 240 × 160)
    /// around `center` ([lat, lon]), or the whole grid without a center ([`landfire`]).
    Landfire {
        path: PathBuf,
        /// `fbfm40` (the default) or `fbfm13`.
        #[serde(default, skip_serializing_if = "landfire::is_fbfm40")]
        fuel: landfire::FuelLayerName,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        center: Option<[f64; 2]>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        width: Option<usize>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        height: Option<usize>,
        /// What reading it found, once [`Scenario::prepare`] has read it (for the label and
        /// the ignition's checks).
        #[serde(skip)]
        site: Option<std::sync::Arc<landfire::LandfireSite>>,
    },
}

pub(crate) fn default_width() -> usize {
    240
}
pub(crate) fn default_height() -> usize {
    160
}
fn default_cell_ft() -> f64 {
    500.0
}

/// Land-cover scheme names as written in YAML.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SchemeName {
    Modis,
    Fbfm13,
    Fbfm40,
}

impl FromStr for LandscapeSpec {
    type Err = EpisodeError;

    /// `procedural:SEED` or `firecastrl:LAND_COVER.png,HEIGHTMAP.png` (GeoTIFF needs a
    /// scenario file for its grid).
    fn from_str(spec: &str) -> Result<Self, Self::Err> {
        let bad = |reason: &str| EpisodeError::LandscapeSpec {
            spec: spec.to_string(),
            reason: reason.to_string(),
        };
        match spec.split_once(':') {
            Some(("procedural", seed)) => Ok(Self::Procedural {
                seed: seed.parse().map_err(|_| bad("the seed must be a whole number"))?,
                width: default_width(),
                height: default_height(),
                center: None,
            }),
            Some(("firecastrl", files)) => {
                let (land_cover, heightmap) = files
                    .split_once(',')
                    .ok_or_else(|| bad("expected firecastrl:LAND_COVER.png,HEIGHTMAP.png"))?;
                Ok(Self::Firecastrl {
                    land_cover: land_cover.into(),
                    heightmap: heightmap.into(),
                })
            }
            Some(("geotiff", _)) => Err(bad(
                "GeoTIFF landscapes need a grid: use a scenario file (--scenario)",
            )),
            _ => Err(bad(
                "expected procedural:SEED or firecastrl:LAND_COVER.png,HEIGHTMAP.png",
            )),
        }
    }
}

impl LandscapeSpec {
    /// Build the landscape; relative paths resolve against `root`.
    pub fn load(&self, root: &Path) -> Result<Landscape, EpisodeError> {
        Ok(match self {
            Self::Procedural {
                seed,
                width,
                height,
                center,
            } => {
                let base = procedural::ProceduralOptions::with_seed(*seed);
                let [center_lat, center_lon] = center.unwrap_or([base.center_lat, base.center_lon]);
                let opts = procedural::ProceduralOptions {
                    width: *width,
                    height: *height,
                    center_lat,
                    center_lon,
                    ..base
                };
                procedural::generate(&opts)?
            }
            Self::Synthetic {
                seed,
                center: [lat, lon],
                width,
                height,
                cell_size_ft,
            } => {
                let grid = firecast_synth::PlaceGrid::around(*lat, *lon, *width, *height, *cell_size_ft)
                    .map_err(|e| EpisodeError::LandscapeSpec {
                        spec: "synthetic".into(),
                        reason: e.to_string(),
                    })?;
                let place = firecast_synth::place_landscape(*seed, grid);
                Landscape::new(
                    grid.width,
                    grid.height,
                    grid.cell_size_ft,
                    LandCoverScheme::ModisIgbp,
                    place.land_cover,
                    place.elevation_ft,
                    firecast_landscape::GeoReference {
                        crs: firecast_landscape::Crs::Wgs84Geographic.code(),
                        origin_x: grid.west_lon,
                        origin_y: grid.south_lat,
                        cell_size_x: grid.cell_lon_deg,
                        cell_size_y: grid.cell_lat_deg,
                    },
                )?
            }
            Self::Firecastrl {
                land_cover,
                heightmap,
            } => firecast_landscape::firecastrl::load(
                root.join(land_cover),
                root.join(heightmap),
                &firecast_landscape::firecastrl::FireCastRlOptions::default(),
            )?,
            Self::Geotiff {
                land_cover,
                elevation,
                scheme,
                center_lat,
                center_lon,
                width,
                height,
                cell_size_ft,
            } => {
                let scheme = match scheme {
                    SchemeName::Modis => LandCoverScheme::ModisIgbp,
                    SchemeName::Fbfm13 => LandCoverScheme::Fbfm13,
                    SchemeName::Fbfm40 => LandCoverScheme::Fbfm40,
                };
                let grid = firecast_landscape::GridSpec::utm_centered(
                    *width,
                    *height,
                    *cell_size_ft,
                    *center_lat,
                    *center_lon,
                )?;
                firecast_landscape::geotiff::load_landscape(
                    root.join(land_cover),
                    root.join(elevation),
                    &grid,
                    &firecast_landscape::geotiff::LandCoverOptions::new(scheme),
                    &firecast_landscape::geotiff::ElevationOptions::default(),
                )?
            }
            Self::Landfire { site: Some(site), .. } => site.landscape.clone(),
            Self::Landfire { .. } => self.read_landfire(root)?.landscape,
        })
    }

    /// Builds the landscape and, for a LANDFIRE one, keeps what reading it found (its label
    /// then counts the cells and names the files).
    pub fn load_keeping(&mut self, root: &Path) -> Result<Landscape, EpisodeError> {
        if let Self::Landfire { site: None, .. } = self {
            let read = std::sync::Arc::new(self.read_landfire(root)?);
            let land = read.landscape.clone();
            if let Self::Landfire { site, .. } = self {
                *site = Some(read);
            }
            return Ok(land);
        }
        self.load(root)
    }

    fn read_landfire(&self, root: &Path) -> Result<landfire::LandfireSite, EpisodeError> {
        let Self::Landfire {
            path,
            fuel,
            center,
            width,
            height,
            ..
        } = self
        else {
            return Err(EpisodeError::LandscapeSpec {
                spec: "landfire".into(),
                reason: "not a LANDFIRE landscape".into(),
            });
        };
        let size = match (width, height) {
            (None, None) => None,
            (w, h) => Some([w.unwrap_or_else(default_width), h.unwrap_or_else(default_height)]),
        };
        landfire::load(&root.join(path), *fuel, *center, size)
    }

    /// What reading a LANDFIRE landscape found (None for other kinds, or before it was read).
    pub fn landfire_site(&self) -> Option<&landfire::LandfireSite> {
        match self {
            Self::Landfire { site, .. } => site.as_deref(),
            _ => None,
        }
    }
}

/// What a landscape is, in words every output carries (`landscape` in an ensemble file).
#[derive(Debug, Clone, PartialEq, Eq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LandscapeLabel {
    /// `synthetic`, `procedural`, `geotiff`, `firecastrl` or `landfire`.
    pub kind: String,
    /// Whether the map is made up (synthetic or procedural) rather than read from data.
    pub synthetic: bool,
    /// The world (synthetic) or map (procedural) seed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// One line a report can print.
    pub note: String,
    /// The files the landscape was read from (LANDFIRE: one per layer, or the `.lcp` and its
    /// `.prj`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sources: Vec<String>,
    /// LANDFIRE: the cells by what the fuel layer held (burnable, non-burnable by code,
    /// nodata), and the cells without elevation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fuel_cells: Option<landfire::FuelCellCounts>,
}

impl LandscapeSpec {
    /// The label outputs carry.
    pub fn label(&self) -> LandscapeLabel {
        let (kind, synthetic, seed, note) = match self {
            Self::Synthetic {
                seed,
                center: [lat, lon],
                ..
            } => (
                "synthetic",
                true,
                Some(*seed),
                format!(
                    "synthetic landscape: the terrain and land cover of FireCast's synthetic world (seed {seed}) \
                     around ({lat}, {lon}), from the generator that wrote the synthetic GRIDMET weather; \
                     not LANDFIRE or MODIS data"
                ),
            ),
            Self::Procedural { seed, .. } => (
                "procedural",
                true,
                Some(*seed),
                format!(
                    "synthetic landscape: a procedural map (seed {seed}) that depends on the seed only, \
                     the same at every place; not the place's terrain"
                ),
            ),
            Self::Geotiff {
                land_cover,
                elevation,
                ..
            } => (
                "geotiff",
                false,
                None,
                format!(
                    "land cover from {} and elevation from {}",
                    land_cover.display(),
                    elevation.display()
                ),
            ),
            Self::Firecastrl { land_cover, .. } => (
                "firecastrl",
                false,
                None,
                format!("FireCastRL map {}", land_cover.display()),
            ),
            Self::Landfire { path, site, .. } => {
                let Some(site) = site else {
                    return LandscapeLabel {
                        kind: "landfire".into(),
                        synthetic: false,
                        seed: None,
                        note: format!("LANDFIRE landscape from {} (not read yet)", path.display()),
                        sources: vec![path.display().to_string()],
                        fuel_cells: None,
                    };
                };
                return LandscapeLabel {
                    kind: "landfire".into(),
                    synthetic: false,
                    seed: None,
                    note: site.note(),
                    sources: site.sources.iter().map(|p| p.display().to_string()).collect(),
                    fuel_cells: Some(site.cells.clone()),
                };
            }
        };
        LandscapeLabel {
            kind: kind.into(),
            synthetic,
            seed,
            note,
            sources: Vec::new(),
            fuel_cells: None,
        }
    }
}

/// A scenario file: where the fire burns and how the environment behaves.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub landscape: LandscapeSpec,
    /// Where the wind comes from; when set it replaces `env.sim.wind`.
    #[serde(default)]
    pub weather: Option<WeatherSpec>,
    #[serde(default)]
    pub env: EnvConfig,
}

impl Scenario {
    /// A scenario on `landscape` with default settings.
    pub fn new(landscape: LandscapeSpec, env: EnvConfig) -> Self {
        Self {
            landscape,
            weather: None,
            env,
        }
    }

    /// Builds the landscape and, when the scenario has `weather`, reads it and sets the wind.
    /// Relative paths resolve against `root`.
    pub fn prepare(&mut self, root: &Path) -> Result<(Landscape, Option<ResolvedWeather>), EpisodeError> {
        let landscape = self.landscape.load_keeping(root)?;
        let weather = match &self.weather {
            Some(spec) => {
                let w = spec.resolve(&landscape, root)?;
                self.env.sim.wind = w.wind;
                if let Some(day) = &w.fuel_moisture {
                    match &mut self.env.sim.kernel {
                        firecast_sim::KernelConfig::Rothermel { moisture, .. } => {
                            *moisture = day.fuel_moisture()
                        }
                        firecast_sim::KernelConfig::Concord { .. } => {
                            return Err(EpisodeError::Weather {
                                path: root.join(match spec {
                                    WeatherSpec::Gridmet { dir, .. } => dir,
                                }),
                                message: "the day's fuel moisture needs the Rothermel kernel (env.sim.kernel.rothermel); \
                                          the Concord kernel takes moisture from drought zones"
                                    .into(),
                            });
                        }
                    }
                }
                Some(w)
            }
            None => None,
        };
        Ok((landscape, weather))
    }

    /// Read a scenario YAML file strictly (unknown keys are errors with file:line and key path).
    pub fn from_file(path: &Path) -> Result<Self, EpisodeError> {
        let text = std::fs::read_to_string(path).map_err(|source| EpisodeError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Ok(firecast_pipeline::spec::deserialize_mapping_enums(path, &text)?)
    }
}

/// The suppression agents.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum AgentKind {
    /// No suppression: the fire burns freely.
    None,
    /// The paper's rule-based agent: a circle of radius 30 cells around the ignition, a drop
    /// every 10°.
    Rule,
    /// Concentric circles of radius 45, 40 and 35 cells.
    RuleConcentric,
    /// A helicopter that flies (3 cells a move) to the nearest flames and drops on them.
    Chaser,
}

impl FromStr for AgentKind {
    type Err = EpisodeError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "none" => Ok(Self::None),
            "rule" => Ok(Self::Rule),
            "rule-concentric" => Ok(Self::RuleConcentric),
            "chaser" => Ok(Self::Chaser),
            other => Err(EpisodeError::Agent(other.to_string())),
        }
    }
}

impl AgentKind {
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Rule => "rule",
            Self::RuleConcentric => "rule-concentric",
            Self::Chaser => "chaser",
        }
    }

    pub fn policy(self) -> Box<dyn Policy + Send> {
        match self {
            Self::None => Box::new(NoSuppression),
            Self::Rule => Box::new(RuleBasedAgent::single_circle()),
            Self::RuleConcentric => Box::new(RuleBasedAgent::concentric_circles()),
            Self::Chaser => Box::new(FireChaser::default()),
        }
    }
}

/// What to produce besides the numbers (all for the first episode).
#[derive(Debug, Clone, Default)]
pub struct Outputs {
    /// Write `frame_00000.png`, … into this folder.
    pub frames_dir: Option<PathBuf>,
    /// Write an animated GIF.
    pub gif: Option<PathBuf>,
    /// Write a Rerun recording (`.rrd`).
    pub recording: Option<PathBuf>,
    /// Keep every k-th step in PNG/GIF output (the recording keeps every step).
    pub frame_every: usize,
}

/// One episode as a replayable record: the seed and every decision, with the numbers it
/// produced. The simulator is deterministic, so replaying the decisions on the same scenario
/// gives the same fire, bit for bit ([`replay`] checks the numbers).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpisodeTrace {
    pub agent: AgentKind,
    pub seed: u64,
    pub stats: EpisodeStats,
    /// Per step: FireCastRL action number and, for the rule-based agent, the teleport target.
    pub decisions: Vec<(u8, Option<[i32; 2]>)>,
}

/// Wraps a policy and keeps its decisions.
struct Recorder<'a> {
    inner: &'a mut dyn Policy,
    decisions: Vec<(u8, Option<[i32; 2]>)>,
}

impl Policy for Recorder<'_> {
    fn reset(&mut self, ctx: &firecast_sim::EpisodeContext) {
        self.decisions.clear();
        self.inner.reset(ctx);
    }
    fn act(&mut self, obs: &Observation<'_>) -> Decision {
        let d = self.inner.act(obs);
        self.decisions.push((d.action as u8, d.teleport));
        d
    }
}

/// Plays recorded decisions back.
struct Replay<'a> {
    decisions: &'a [(u8, Option<[i32; 2]>)],
    next: usize,
}

impl Policy for Replay<'_> {
    fn act(&mut self, _obs: &Observation<'_>) -> Decision {
        // Past the end (only if the replay outlives the recording, which `replay` reports as a
        // divergence) the helicopter just moves.
        let (a, teleport) = self.decisions.get(self.next).copied().unwrap_or((0, None));
        self.next += 1;
        Decision {
            action: Action::try_from(a).unwrap_or(Action::North),
            teleport,
        }
    }
}

/// Replays a trace on its scenario and draws it (GIF, PNG frames, Rerun recording); fails if
/// the replay's numbers differ from the recorded ones.
pub fn replay(
    scenario: &Scenario,
    landscape: &Landscape,
    trace: &EpisodeTrace,
    outputs: &Outputs,
) -> Result<EpisodeStats, EpisodeError> {
    let mut env = WildfireEnv::new(landscape, &scenario.env)?;
    let mut policy = Replay {
        decisions: &trace.decisions,
        next: 0,
    };
    let label = format!("{} agent", trace.agent.name());
    let stats = draw_episode(
        &mut env,
        &mut policy,
        landscape,
        &label,
        trace.seed,
        outputs,
        false,
    )?;
    if stats != trace.stats {
        return Err(EpisodeError::ReplayDiverged {
            recorded: format!("{:?}", trace.stats),
            replayed: format!("{stats:?}"),
        });
    }
    Ok(stats)
}

/// Plays one episode of any `policy` on `env` (reset with `seed`, so the same policy and
/// seed replay an episode played elsewhere) into `outputs`: PNG frames, an animated GIF, a
/// Rerun recording named `"{label}, seed {seed}"`. The recording also draws the
/// helicopter's path so far at every step. `landscape` must be the one `env` was built on.
pub fn record_episode(
    env: &mut WildfireEnv,
    policy: &mut dyn Policy,
    landscape: &Landscape,
    label: &str,
    seed: u64,
    outputs: &Outputs,
) -> Result<EpisodeStats, EpisodeError> {
    draw_episode(env, policy, landscape, label, seed, outputs, true)
}

/// Runs one episode into the requested outputs.
fn draw_episode(
    env: &mut WildfireEnv,
    policy: &mut dyn Policy,
    landscape: &Landscape,
    label: &str,
    seed: u64,
    outputs: &Outputs,
    path: bool,
) -> Result<EpisodeStats, EpisodeError> {
    let mut sink = FrameSink::new(landscape, label, seed, outputs, path)?;
    let mut failure = None;
    let stat = run_episode(env, policy, seed, |e, info| {
        if failure.is_none()
            && let Err(err) = sink.push(e, info)
        {
            failure = Some(err);
        }
    });
    if let Some(err) = failure {
        return Err(err);
    }
    sink.finish()?;
    Ok(stat)
}

/// The result of a run: the Table IV columns per episode and as mean ± std.
#[derive(Debug, Clone, Serialize)]
pub struct EpisodesSummary {
    pub agent: &'static str,
    pub landscape: LandscapeSpec,
    pub seed: u64,
    pub wind_speed_mph: f64,
    pub wind_from_deg: f64,
    pub wind_measured_at: firecast_sim::WindHeight,
    pub report: EvalReport,
    /// The first episode, replayable.
    #[serde(skip)]
    pub first_episode: Option<EpisodeTrace>,
}

/// Run `episodes` episodes (seeds `seed`, `seed + 1`, …) and produce the requested outputs
/// for the first one. `on_episode` is called after each episode (progress bars).
pub fn run(
    scenario: &Scenario,
    landscape: &Landscape,
    agent: AgentKind,
    episodes: usize,
    seed: u64,
    outputs: &Outputs,
    on_episode: impl FnMut(usize),
) -> Result<EpisodesSummary, EpisodeError> {
    let (stats, first_episode) =
        run_range(scenario, landscape, agent, 0..episodes, seed, outputs, on_episode)?;
    Ok(summarize(scenario, agent, seed, stats, first_episode))
}

/// Run episodes `range` (episode `k` uses seed `seed + k`; each starts from a reset env and
/// policy, so any split of `0..n` gives the same episodes). The first episode (`k == 0`)
/// is traced when it is in the range.
pub fn run_range(
    scenario: &Scenario,
    landscape: &Landscape,
    agent: AgentKind,
    range: std::ops::Range<usize>,
    seed: u64,
    outputs: &Outputs,
    mut on_episode: impl FnMut(usize),
) -> Result<(Vec<EpisodeStats>, Option<EpisodeTrace>), EpisodeError> {
    let mut env = WildfireEnv::new(landscape, &scenario.env)?;
    let mut policy = agent.policy();
    let mut stats = Vec::with_capacity(range.len());
    let mut first_episode = None;
    for k in range {
        let episode_seed = seed.wrapping_add(k as u64);
        let stat = if k == 0 {
            let mut recorder = Recorder {
                inner: policy.as_mut(),
                decisions: Vec::new(),
            };
            let stat = if outputs.frames_dir.is_some() || outputs.gif.is_some() || outputs.recording.is_some()
            {
                let label = format!("{} agent", agent.name());
                draw_episode(
                    &mut env,
                    &mut recorder,
                    landscape,
                    &label,
                    episode_seed,
                    outputs,
                    false,
                )?
            } else {
                run_episode(&mut env, &mut recorder, episode_seed, |_, _| {})
            };
            first_episode = Some(EpisodeTrace {
                agent,
                seed: episode_seed,
                stats: stat,
                decisions: recorder.decisions,
            });
            stat
        } else {
            run_episode(&mut env, policy.as_mut(), episode_seed, |_, _| {})
        };
        stats.push(stat);
        on_episode(k);
    }
    Ok((stats, first_episode))
}

/// The summary of episodes `0..stats.len()` (Table IV columns as mean ± std, in episode
/// order).
pub fn summarize(
    scenario: &Scenario,
    agent: AgentKind,
    seed: u64,
    stats: Vec<EpisodeStats>,
    first_episode: Option<EpisodeTrace>,
) -> EpisodesSummary {
    let report = eval_report(stats);
    EpisodesSummary {
        agent: agent.name(),
        landscape: scenario.landscape.clone(),
        seed,
        wind_speed_mph: scenario.env.sim.wind.speed_mph,
        wind_from_deg: scenario.env.sim.wind.from_direction_deg,
        wind_measured_at: scenario.env.sim.wind.measured_at,
        report,
        first_episode,
    }
}

/// Table IV columns as mean ± std over `stats`, in the given order.
pub fn eval_report(stats: Vec<EpisodeStats>) -> EvalReport {
    EvalReport {
        cells_burned: MeanStd::of(stats.iter().map(|s| f64::from(s.cells_burned))),
        timesteps: MeanStd::of(stats.iter().map(|s| f64::from(s.timesteps))),
        helitacks: MeanStd::of(stats.iter().map(|s| f64::from(s.helitacks))),
        water_used_gal: MeanStd::of(stats.iter().map(|s| s.water_used_gal)),
        episodes: stats,
    }
}

/// A position in image coordinates.
type Point = (f32, f32);

/// Collects one episode into PNG frames, a GIF and a Rerun recording.
struct FrameSink<'a> {
    outputs: &'a Outputs,
    /// The helicopter's cells and the drops so far, when the recording draws its path.
    path: Option<(Vec<Point>, Vec<Point>)>,
    basemap: firecast_render::Basemap,
    options: firecast_render::RenderOptions,
    gif: Option<firecast_render::GifWriter>,
    recording: Option<firecast_recorder::Recording>,
    step: usize,
    last_drops: u32,
    width: usize,
    height: usize,
}

impl<'a> FrameSink<'a> {
    fn new(
        landscape: &Landscape,
        label: &str,
        seed: u64,
        outputs: &'a Outputs,
        path: bool,
    ) -> Result<Self, EpisodeError> {
        let options = firecast_render::RenderOptions::default();
        let basemap = firecast_render::Basemap::new(landscape, &options);
        let parents = [outputs.gif.as_deref(), outputs.recording.as_deref()]
            .into_iter()
            .flatten()
            .filter_map(Path::parent);
        for dir in outputs.frames_dir.as_deref().into_iter().chain(parents) {
            std::fs::create_dir_all(dir).map_err(|source| EpisodeError::Io {
                context: "cannot create output folder",
                path: dir.to_path_buf(),
                source,
            })?;
        }
        let gif = match &outputs.gif {
            Some(path) => Some(firecast_render::GifWriter::create(
                path,
                basemap.width_px(),
                basemap.height_px(),
                8,
            )?),
            None => None,
        };
        let recording = match &outputs.recording {
            Some(path) => {
                let staging = path.parent().unwrap_or(Path::new(".")).to_path_buf();
                let mut rec = firecast_recorder::Recording::create(
                    "firecast_helitack",
                    &format!("{label}, seed {seed}"),
                    &staging,
                )?;
                log_terrain(&mut rec, landscape)?;
                Some(rec)
            }
            None => None,
        };
        Ok(Self {
            outputs,
            path: path.then(Default::default),
            basemap,
            options,
            gif,
            recording,
            step: 0,
            last_drops: 0,
            width: landscape.width,
            height: landscape.height,
        })
    }

    fn push(&mut self, env: &WildfireEnv, info: &StepInfo) -> Result<(), EpisodeError> {
        let helicopter = env.core().helicopter();
        let dropped = info.drops > self.last_drops;
        self.last_drops = info.drops;
        let drops: Vec<[i32; 2]> = if dropped { vec![helicopter] } else { Vec::new() };
        let fire_state = env.automaton().fire_states();
        let every = self.outputs.frame_every.max(1);
        let is_last = env.automaton().cells_burning() == 0;
        if self.step.is_multiple_of(every) || dropped || is_last {
            let frame = firecast_render::FireFrame::new(fire_state, helicopter).with_drops(&drops);
            let image = firecast_render::render_frame(&self.basemap, &frame, &self.options);
            if let Some(dir) = &self.outputs.frames_dir {
                firecast_render::write_png(&image, dir.join(format!("frame_{:05}.png", self.step)))?;
            }
            if let Some(gif) = &mut self.gif {
                gif.add_frame(&image)?;
            }
        }
        if let Some(rec) = &mut self.recording {
            log_step(
                rec,
                self.step,
                info,
                fire_state,
                self.width,
                self.height,
                helicopter,
                dropped,
            )?;
            if let Some((path, drops)) = &mut self.path {
                let here = cell_centre(helicopter, self.height);
                path.push(here);
                if dropped {
                    drops.push(here);
                }
                log_path(rec, path, dropped.then_some(drops.as_slice()))?;
            }
        }
        self.step += 1;
        Ok(())
    }

    fn finish(self) -> Result<(), EpisodeError> {
        if let Some(gif) = self.gif {
            gif.finish()?;
        }
        if let (Some(rec), Some(path)) = (self.recording, &self.outputs.recording) {
            rec.finish_to_file(path)?;
        }
        Ok(())
    }
}

/// Grid rows run south to north; images run top to bottom.
fn flip_rows(cells: &[u8], width: usize, height: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(cells.len());
    for y in (0..height).rev() {
        out.extend_from_slice(&cells[y * width..(y + 1) * width]);
    }
    out
}

fn log_terrain(rec: &mut firecast_recorder::Recording, landscape: &Landscape) -> Result<(), EpisodeError> {
    use firecast_recorder::rerun;
    // One pixel per cell, no legend: image coordinates are cell coordinates.
    let options = firecast_render::RenderOptions {
        scale: 1,
        legend: false,
        ..firecast_render::RenderOptions::default()
    };
    let terrain = firecast_render::Basemap::new(landscape, &options).image;
    rec.log_static(
        "env/terrain",
        &rerun::Image::from_rgb24(
            terrain.data.clone(),
            [terrain.width as u32, terrain.height as u32],
        ),
    )?;
    let context = rerun::AnnotationContext::new([
        (0u16, "unburnt", rerun::Rgba32::from_unmultiplied_rgba(0, 0, 0, 0)),
        (
            1u16,
            "burning",
            rerun::Rgba32::from_unmultiplied_rgba(255, 80, 0, 230),
        ),
        (
            2u16,
            "burnt",
            rerun::Rgba32::from_unmultiplied_rgba(40, 30, 30, 200),
        ),
    ]);
    rec.log_static("env/fire", &context)?;
    rec.log_static(
        "stats/cells_burning",
        &rerun::SeriesLines::new()
            .with_names(["cells burning"])
            .with_colors([[255, 80, 0]]),
    )?;
    rec.log_static(
        "stats/cells_burnt",
        &rerun::SeriesLines::new()
            .with_names(["cells burnt"])
            .with_colors([[60, 60, 60]]),
    )?;
    Ok(())
}

/// A cell's centre in image coordinates: x right, y down from the north edge.
fn cell_centre(cell: [i32; 2], height: usize) -> Point {
    (cell[0] as f32 + 0.5, (height as f32 - 1.0 - cell[1] as f32) + 0.5)
}

/// The helicopter's path up to this step and, on a drop, every drop so far (logged whole,
/// so scrubbing the timeline shows what was flown and dropped until then; `env/drops` only
/// holds the latest drop).
fn log_path(
    rec: &mut firecast_recorder::Recording,
    path: &[Point],
    drops: Option<&[Point]>,
) -> Result<(), EpisodeError> {
    use firecast_recorder::rerun;
    rec.log(
        "env/path",
        &rerun::LineStrips2D::new([path.to_vec()])
            .with_radii([0.3])
            .with_colors([[255, 255, 255, 160]]),
    )?;
    if let Some(drops) = drops {
        rec.log(
            "env/drops_so_far",
            &rerun::Points2D::new(drops.iter().copied())
                .with_radii([5.28])
                .with_colors([[40, 120, 255, 90]]),
        )?;
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn log_step(
    rec: &mut firecast_recorder::Recording,
    step: usize,
    info: &StepInfo,
    fire_state: &[u8],
    width: usize,
    height: usize,
    helicopter: [i32; 2],
    dropped: bool,
) -> Result<(), EpisodeError> {
    use firecast_recorder::rerun;
    rec.set_time_sequence("step", step as i64)?;
    rec.set_duration_secs("sim_time", info.sim_time_min * 60.0)?;
    let tensor = rerun::datatypes::TensorData::new(
        vec![height as u64, width as u64],
        rerun::datatypes::TensorBuffer::U8(flip_rows(fire_state, width, height).into()),
    );
    let image = rerun::SegmentationImage::try_from(tensor)
        .map_err(|e| firecast_recorder::RecorderError::Log(e.to_string()))?;
    rec.log("env/fire", &image)?;
    let position = cell_centre(helicopter, height);
    rec.log(
        "env/helicopter",
        &rerun::Points2D::new([position])
            .with_radii([1.5])
            .with_colors([[255, 255, 255]]),
    )?;
    if dropped {
        rec.log(
            "env/drops",
            &rerun::Points2D::new([position])
                .with_radii([5.28])
                .with_colors([[40, 120, 255]]),
        )?;
    }
    rec.log(
        "stats/cells_burning",
        &rerun::Scalars::single(f64::from(info.cells_burning)),
    )?;
    rec.log(
        "stats/cells_burnt",
        &rerun::Scalars::single(f64::from(info.cells_burnt)),
    )?;
    Ok(())
}
