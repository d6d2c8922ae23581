//! Ensembles: one suppression strategy against one fire, replayed over many seeds, with what a
//! threat report needs from each run — when every cell caught fire (arrival time), the burnt
//! area after every step, and where and when each drop fell — and what the runs say together:
//! how often each cell burned (burn probability) and the earliest and median arrival times.
//!
//! The simulator is deterministic apart from cosmetic draws, so replaying the same fire with
//! other seeds would give the same fire: each run instead perturbs the day's weather and fuel
//! moisture ([`Perturbation`], seeded by the run's seed), as FSPro varies weather, and every
//! strategy sees the same perturbed runs (the comparison is paired).
//!
//! The recorder ([`Tracker`]) only looks at the environment after each step, so any policy
//! can be tracked: the rule-based agents here ([`run_agent`]), the trained PPO policy in
//! `firecast-rl`. Times are simulated hours (a step is `dt_min` minutes), never steps.

use firecast_landscape::{LandCoverScheme, Landscape};
use firecast_sim::env::EnvCore;
use firecast_sim::{
    EnvConfig, FuelModel, FuelMoisture, KernelConfig, StepInfo, WildfireEnv, Wind, run_episode,
};
use serde::{Deserialize, Serialize};

use crate::{AgentKind, EpisodeError, ResolvedWeather, Scenario};

/// Bumped when the file layout changes; readers refuse other versions.
pub const ENSEMBLE_VERSION: u32 = 1;

/// How each run departs from the day's weather and the scenario's fuel moisture. Every draw is
/// uniform and seeded by the run's seed, so strategies with the same seeds meet the same runs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Perturbation {
    /// Wind speed scaled by a factor in [1 − s, 1 + s].
    pub wind_speed_frac: f64,
    /// Wind direction turned by up to ± this many degrees.
    pub wind_direction_deg: f64,
    /// Dead 1/10/100-h moistures (Rothermel kernel) shifted together by up to ± this much
    /// (fraction of dry weight, 0.01 = one moisture point), never below 0.02.
    pub dead_moisture_frac: f64,
}

impl Default for Perturbation {
    fn default() -> Self {
        Self {
            wind_speed_frac: 0.25,
            wind_direction_deg: 20.0,
            dead_moisture_frac: 0.01,
        }
    }
}

impl Perturbation {
    /// No perturbation: every run is the day as given.
    pub const NONE: Self = Self {
        wind_speed_frac: 0.0,
        wind_direction_deg: 0.0,
        dead_moisture_frac: 0.0,
    };

    /// Checks the spreads, naming the key.
    pub fn validate(&self) -> Result<(), String> {
        let checks = [
            ("wind_speed_frac", self.wind_speed_frac, 1.0),
            ("wind_direction_deg", self.wind_direction_deg, 180.0),
            ("dead_moisture_frac", self.dead_moisture_frac, 0.2),
        ];
        for (key, v, max) in checks {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return Err(format!("perturb.{key}: {v} is not in [0, {max}]"));
            }
        }
        Ok(())
    }
}

/// The weather and moisture one run met.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConditions {
    pub wind_speed_mph: f64,
    pub wind_from_deg: f64,
    /// Dead 1-h moisture (fraction), when the kernel is Rothermel.
    pub dead_1h_frac: Option<f64>,
}

/// Where the grid lies and what its cells are (enough to rebuild the landscape).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridInfo {
    pub width: usize,
    pub height: usize,
    pub cell_size_ft: f64,
    pub crs: String,
    pub origin_x: f64,
    pub origin_y: f64,
    pub cell_size_x: f64,
    pub cell_size_y: f64,
    /// `modis`, `fbfm13` or `fbfm40`.
    pub scheme: String,
}

/// One drop of one run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DropRecord {
    /// Simulated hours since ignition at which the drop fell.
    pub hour: f64,
    pub x: i32,
    pub y: i32,
    /// Burning cells it put out.
    pub quenched: u32,
}

/// One run of the ensemble.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EpisodeRecord {
    pub seed: u64,
    /// Which policy played it when the strategy has several (a PPO training seed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub policy: Option<String>,
    /// Cells that burned (burnt or still burning at the end).
    pub cells_burned: u32,
    /// Simulated hours the run lasted.
    pub hours: f64,
    /// Whether the fire went out before the time limit.
    pub contained: bool,
    pub helitacks: u32,
    pub water_used_gal: f64,
    /// The perturbed weather and moisture of this run.
    pub conditions: RunConditions,
    /// Most cells burning at once, and when (the authors' "containment time" is this hour).
    pub peak_burning_cells: u32,
    pub peak_burning_hour: f64,
    /// Cells burned (burnt + burning) after each step; entry 0 is the ignition.
    pub burned_per_step: Vec<u32>,
    pub drops: Vec<DropRecord>,
    /// Cells on the grid's border (outer ring) that burned: the fire left the domain there.
    #[serde(default)]
    pub edge_cells_burned: u32,
    /// Simulated hours at which the fire first reached the border (None: it never did).
    #[serde(default)]
    pub edge_first_hour: Option<f64>,
}

/// The ensemble file written by `sim.ensemble` and `rl.ensemble`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ensemble {
    pub version: u32,
    /// `none`, `rule`, `rule-concentric` or `ppo`.
    pub strategy: String,
    /// One line on what played (the agent, a policy's run and checkpoint).
    pub description: String,
    /// What the landscape is (synthetic or read from data), in words a report can print.
    #[serde(default)]
    pub landscape: Option<crate::LandscapeLabel>,
    pub grid: GridInfo,
    /// Cells on the grid's border, `2·(width + height) − 4` (what `edge_cells_burned` counts).
    #[serde(default)]
    pub border_cells: u32,
    /// Land-cover (or fuel-model) code per cell, row-major, row 0 south.
    pub land_cover: Vec<u16>,
    pub elevation_ft: Vec<f32>,
    pub ignition: [usize; 2],
    /// Centre of the ignition cell.
    pub ignition_lat_lon: [f64; 2],
    pub step_minutes: f64,
    pub max_steps: u32,
    /// The day's wind (before each run's perturbation).
    pub wind: Wind,
    pub perturbation: Perturbation,
    /// The GRIDMET day the wind came from, when it did.
    pub weather: Option<ResolvedWeather>,
    /// Dead and live fuel moistures of the Rothermel kernel (None: the Concord kernel).
    pub moisture: Option<FuelMoisture>,
    pub episodes: Vec<EpisodeRecord>,
    /// Per cell: in how many runs it burned.
    pub burn_count: Vec<u32>,
    /// Per cell: the earliest fire arrival over the runs, hours (None: never burned).
    pub arrival_first_h: Vec<Option<f32>>,
    /// Per cell: the time by which at least half of the runs had burned it, hours (None: it
    /// burned in fewer than half).
    pub arrival_median_h: Vec<Option<f32>>,
    /// How the map grew until the runs stayed inside it (`grow` on an MTT ensemble), or the
    /// size another ensemble's growth chose (`domain` input). None: the map as given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub domain: Option<DomainGrowth>,
}

/// The map's growth: the size asked for, the size the runs burned on, and whether that size
/// held every run (no burnt cell on the border).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DomainGrowth {
    /// [width, height] in cells as the landscape was given.
    pub base: [usize; 2],
    /// [width, height] in cells the runs burned on.
    pub size: [usize; 2],
    /// Largest growth allowed, per side (the map's width and height at most this many times
    /// the base).
    pub max_factor: u32,
    /// Sizes tried, the last included (1: the base size held every run).
    pub rounds: u32,
    /// Every run stayed off the border at `size` (false: the largest size was reached and some
    /// runs still burned border cells; the burnt area is then a lower bound).
    pub contained: bool,
}

impl Ensemble {
    /// Reads an ensemble file, checking its version and sizes.
    pub fn read(path: &std::path::Path) -> Result<Self, EpisodeError> {
        let bad = |message: String| EpisodeError::Ensemble {
            path: path.to_path_buf(),
            message,
        };
        let bytes = std::fs::read(path).map_err(|source| EpisodeError::Io {
            context: "cannot read the ensemble",
            path: path.to_path_buf(),
            source,
        })?;
        let value: serde_json::Value =
            serde_json::from_slice(&bytes).map_err(|e| bad(format!("line {}: {e}", e.line())))?;
        let version = value.get("version").and_then(serde_json::Value::as_u64);
        if version != Some(u64::from(ENSEMBLE_VERSION)) {
            return Err(bad(format!(
                "ensemble version {version:?}, this FireCast reads {ENSEMBLE_VERSION}"
            )));
        }
        let e: Self = serde_json::from_value(value).map_err(|e| bad(e.to_string()))?;
        let n = e.grid.width * e.grid.height;
        for (name, len) in [
            ("land_cover", e.land_cover.len()),
            ("elevation_ft", e.elevation_ft.len()),
            ("burn_count", e.burn_count.len()),
            ("arrival_first_h", e.arrival_first_h.len()),
            ("arrival_median_h", e.arrival_median_h.len()),
        ] {
            if len != n {
                return Err(bad(format!("`{name}` has {len} cells, the grid {n}")));
            }
        }
        if e.episodes.is_empty() {
            return Err(bad("no runs".into()));
        }
        Ok(e)
    }

    /// The landscape the runs burned on.
    pub fn landscape(&self) -> Result<Landscape, EpisodeError> {
        let g = &self.grid;
        let scheme = scheme_of(&g.scheme).ok_or_else(|| EpisodeError::LandscapeSpec {
            spec: g.scheme.clone(),
            reason: "unknown land-cover scheme".into(),
        })?;
        Ok(Landscape::new(
            g.width,
            g.height,
            g.cell_size_ft,
            scheme,
            self.land_cover.clone(),
            self.elevation_ft.clone(),
            firecast_landscape::GeoReference {
                crs: g.crs.clone(),
                origin_x: g.origin_x,
                origin_y: g.origin_y,
                cell_size_x: g.cell_size_x,
                cell_size_y: g.cell_size_y,
            },
        )?)
    }

    /// Number of runs.
    pub fn runs(&self) -> usize {
        self.episodes.len()
    }

    /// One line on the runs that reached the grid's edge (None when none did).
    pub fn edge_summary(&self) -> Option<String> {
        let reached: Vec<&EpisodeRecord> = self.episodes.iter().filter(|e| e.edge_cells_burned > 0).collect();
        let most = reached.iter().map(|e| e.edge_cells_burned).max()?;
        let first = reached
            .iter()
            .filter_map(|e| e.edge_first_hour)
            .min_by(f64::total_cmp)
            .unwrap_or(f64::NAN);
        Some(format!(
            "the fire reached the grid's edge in {} of {} runs (up to {most} of {} border cells burnt, \
             first after {first:.1} h): it left the simulated domain",
            reached.len(),
            self.runs(),
            self.border_cells
        ))
    }
}

/// Indices of the cells on a `width × height` grid's border.
fn border(width: usize, height: usize) -> impl Iterator<Item = usize> {
    (0..width * height).filter(move |&i| {
        let (x, y) = (i % width, i / width);
        x == 0 || y == 0 || x + 1 == width || y + 1 == height
    })
}

/// A run's edge from its arrival times (hours, +∞ where unburnt): border cells burnt and the
/// first hour the fire reached the border.
pub(crate) fn edge_of(arrival: &[f32], width: usize, height: usize) -> (u32, Option<f64>) {
    let edge: Vec<f32> = border(width, height)
        .map(|i| arrival[i])
        .filter(|t| t.is_finite())
        .collect();
    (
        edge.len() as u32,
        edge.iter().copied().min_by(f32::total_cmp).map(f64::from),
    )
}

fn scheme_name(s: LandCoverScheme) -> &'static str {
    match s {
        LandCoverScheme::ModisIgbp => "modis",
        LandCoverScheme::Fbfm13 => "fbfm13",
        LandCoverScheme::Fbfm40 => "fbfm40",
    }
}

fn scheme_of(s: &str) -> Option<LandCoverScheme> {
    match s {
        "modis" => Some(LandCoverScheme::ModisIgbp),
        "fbfm13" => Some(LandCoverScheme::Fbfm13),
        "fbfm40" => Some(LandCoverScheme::Fbfm40),
        _ => None,
    }
}

/// The Scott & Burgan / Anderson fuel model of a land-cover code (MODIS classes through the
/// simulator's crosswalk).
pub fn fuel_model_of(scheme: LandCoverScheme, code: u16) -> Option<&'static FuelModel> {
    let number = match scheme {
        LandCoverScheme::ModisIgbp => firecast_sim::automaton::modis_to_fuel_model(code),
        LandCoverScheme::Fbfm13 | LandCoverScheme::Fbfm40 => code,
    };
    FuelModel::by_number(number)
}

/// Whether a land-cover code carries fuel.
pub fn is_burnable(scheme: LandCoverScheme, code: u16) -> bool {
    fuel_model_of(scheme, code).is_some_and(|m| m.total_load_lb_ft2() > 0.0)
}

/// Whether a land-cover code is developed land (MODIS 13 urban and built-up; NB1 91).
pub fn is_developed(scheme: LandCoverScheme, code: u16) -> bool {
    match scheme {
        LandCoverScheme::ModisIgbp => code == 13,
        LandCoverScheme::Fbfm13 | LandCoverScheme::Fbfm40 => code == 91,
    }
}

/// A scenario ready for an ensemble: the landscape, the environment with its ignition cell,
/// and the weather it was given.
pub struct Setup {
    pub scenario: Scenario,
    pub landscape: Landscape,
    pub weather: Option<ResolvedWeather>,
    pub ignition: [usize; 2],
    pub perturbation: Perturbation,
    /// The growth that chose this map's size, when one did (recorded in the ensemble).
    pub domain: Option<DomainGrowth>,
}

impl Setup {
    /// Builds the landscape and weather; puts the ignition on the cell holding
    /// `ignition_lat_lon` (default: the environment's ignition cell) and refuses one outside
    /// the grid or without fuel (water, rock, developed land).
    pub fn new(
        mut scenario: Scenario,
        root: &std::path::Path,
        ignition_lat_lon: Option<[f64; 2]>,
    ) -> Result<Self, EpisodeError> {
        let (landscape, weather) = scenario.prepare(root)?;
        let (w, h) = (landscape.width, landscape.height);
        let ignition = match ignition_lat_lon {
            Some([lat, lon]) => {
                let (x, y) = landscape
                    .lat_lon_to_cell(lat, lon)
                    .ok_or_else(|| EpisodeError::Ignition {
                        message: format!(
                            "({lat}, {lon}) is outside the landscape (or its CRS `{}` cannot be converted)",
                            landscape.georef.crs
                        ),
                    })?;
                [x, y]
            }
            None => scenario
                .env
                .ignition
                .unwrap_or([(w / 2).saturating_sub(1), (h / 2).saturating_sub(1)]),
        };
        if ignition[0] >= w || ignition[1] >= h {
            return Err(EpisodeError::Ignition {
                message: format!("ignition cell {ignition:?} is outside the {w}×{h} grid"),
            });
        }
        let code = landscape.land_cover[landscape.index(ignition[0], ignition[1])];
        if !is_burnable(landscape.scheme, code) {
            let what = fuel_model_of(landscape.scheme, code).map_or("no fuel", |m| m.name);
            let cell = scenario
                .landscape
                .landfire_site()
                .and_then(|site| site.unburnable_cell(ignition[0], ignition[1]))
                .map_or_else(String::new, |why| format!(": {why}"));
            return Err(EpisodeError::Ignition {
                message: format!(
                    "the ignition point (cell {ignition:?}) is on land cover {code} ({what}): nothing there can burn{cell}"
                ),
            });
        }
        scenario.env.ignition = Some(ignition);
        Ok(Self {
            scenario,
            landscape,
            weather,
            ignition,
            perturbation: Perturbation::default(),
            domain: None,
        })
    }

    /// The same setup with another perturbation.
    pub fn with_perturbation(mut self, perturbation: Perturbation) -> Self {
        self.perturbation = perturbation;
        self
    }

    /// The day's environment (unperturbed).
    pub fn env(&self) -> &EnvConfig {
        &self.scenario.env
    }

    /// The environment of the run seeded `seed`, and what it drew.
    pub fn run_env(&self, seed: u64) -> (EnvConfig, RunConditions) {
        use rand::{Rng, SeedableRng};
        let p = &self.perturbation;
        // A stream of its own, so the simulator's draws from the same seed stay independent.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x7E57_F1BE_u64.rotate_left(32));
        let mut u = |spread: f64| {
            if spread > 0.0 {
                rng.random_range(-spread..=spread)
            } else {
                0.0
            }
        };
        let mut env = self.scenario.env.clone();
        let wind = &mut env.sim.wind;
        wind.speed_mph = (wind.speed_mph * (1.0 + u(p.wind_speed_frac))).max(0.0);
        wind.from_direction_deg = (wind.from_direction_deg + u(p.wind_direction_deg)).rem_euclid(360.0);
        let shift = u(p.dead_moisture_frac);
        let dead_1h = match &mut env.sim.kernel {
            KernelConfig::Rothermel { moisture, .. } => {
                for m in [
                    &mut moisture.dead_1h_frac,
                    &mut moisture.dead_10h_frac,
                    &mut moisture.dead_100h_frac,
                ] {
                    *m = (*m + shift).max(0.02);
                }
                Some(moisture.dead_1h_frac)
            }
            KernelConfig::Concord { .. } => None,
        };
        let conditions = RunConditions {
            wind_speed_mph: env.sim.wind.speed_mph,
            wind_from_deg: env.sim.wind.from_direction_deg,
            dead_1h_frac: dead_1h,
        };
        (env, conditions)
    }
}

/// Records one run from the environment after each step.
pub struct Tracker {
    step_minutes: f64,
    peak: (u32, f64),
    burned: Vec<u32>,
    drops: Vec<DropRecord>,
    last_drops: u32,
}

impl Tracker {
    /// Starts a run; `info` is what the reset returned.
    pub fn new(core: &EnvCore, info: &StepInfo) -> Self {
        Self {
            step_minutes: core.automaton().config().dt_min,
            peak: (info.cells_burning, info.sim_time_min / 60.0),
            burned: vec![info.cells_burnt + info.cells_burning],
            drops: Vec::new(),
            last_drops: info.drops,
        }
    }

    /// After every step.
    pub fn observe(&mut self, core: &EnvCore, info: &StepInfo) {
        self.burned.push(info.cells_burnt + info.cells_burning);
        if info.cells_burning > self.peak.0 {
            self.peak = (info.cells_burning, info.sim_time_min / 60.0);
        }
        if info.drops > self.last_drops {
            // A drop does not move the helicopter and falls before the step's spread.
            let [x, y] = core.helicopter();
            self.drops.push(DropRecord {
                hour: (info.sim_time_min - self.step_minutes) / 60.0,
                x,
                y,
                quenched: info.quenched_step,
            });
            self.last_drops = info.drops;
        }
    }

    /// Ends the run (`info` from its last step): the record and the arrival time of every
    /// cell in hours (+∞ where it did not burn).
    #[allow(clippy::too_many_arguments)] // one run's identity: seed, policy and conditions
    pub fn finish(
        self,
        core: &EnvCore,
        info: &StepInfo,
        terminated: bool,
        seed: u64,
        policy: Option<String>,
        conditions: RunConditions,
    ) -> (EpisodeRecord, Vec<f32>) {
        let sim = core.automaton();
        let arrival: Vec<f32> = sim
            .fire_states()
            .iter()
            .zip(sim.ignition_times())
            .map(|(&s, &t)| if s != 0 { (t / 60.0) as f32 } else { f32::INFINITY })
            .collect();
        let (edge_cells_burned, edge_first_hour) = edge_of(&arrival, sim.width(), sim.height());
        (
            EpisodeRecord {
                seed,
                policy,
                cells_burned: info.cells_burnt + info.cells_burning,
                hours: info.sim_time_min / 60.0,
                contained: terminated,
                helitacks: info.drops,
                water_used_gal: info.water_used_gal,
                conditions,
                peak_burning_cells: self.peak.0,
                peak_burning_hour: self.peak.1,
                burned_per_step: self.burned,
                drops: self.drops,
                edge_cells_burned,
                edge_first_hour,
            },
            arrival,
        )
    }
}

/// Puts the runs together.
pub fn assemble(
    setup: &Setup,
    strategy: &str,
    description: String,
    runs: Vec<(EpisodeRecord, Vec<f32>)>,
) -> Result<Ensemble, EpisodeError> {
    let land = &setup.landscape;
    let n = land.len();
    let r = runs.len();
    let mut burn_count = vec![0u32; n];
    let mut first = vec![f32::INFINITY; n];
    let mut median = vec![None; n];
    let mut column = Vec::with_capacity(r);
    // The k-th smallest arrival (k = ⌈r/2⌉) is the time by which half the runs burned it.
    let k = r.div_ceil(2).saturating_sub(1);
    for i in 0..n {
        column.clear();
        column.extend(runs.iter().map(|(_, a)| a[i]));
        burn_count[i] = column.iter().filter(|t| t.is_finite()).count() as u32;
        column.sort_by(f32::total_cmp);
        first[i] = column.first().copied().unwrap_or(f32::INFINITY);
        median[i] = column.get(k).copied().filter(|t| t.is_finite());
    }
    let (ilat, ilon) = land.try_cell_to_lat_lon(setup.ignition[0], setup.ignition[1])?;
    let moisture = match &setup.scenario.env.sim.kernel {
        KernelConfig::Rothermel { moisture, .. } => Some(*moisture),
        KernelConfig::Concord { .. } => None,
    };
    Ok(Ensemble {
        version: ENSEMBLE_VERSION,
        strategy: strategy.to_string(),
        description,
        landscape: Some(setup.scenario.landscape.label()),
        border_cells: border(land.width, land.height).count() as u32,
        grid: GridInfo {
            width: land.width,
            height: land.height,
            cell_size_ft: land.cell_size_ft,
            crs: land.georef.crs.clone(),
            origin_x: land.georef.origin_x,
            origin_y: land.georef.origin_y,
            cell_size_x: land.georef.cell_size_x,
            cell_size_y: land.georef.cell_size_y,
            scheme: scheme_name(land.scheme).to_string(),
        },
        land_cover: land.land_cover.clone(),
        elevation_ft: land.elevation_ft.clone(),
        ignition: setup.ignition,
        ignition_lat_lon: [ilat, ilon],
        step_minutes: setup.scenario.env.sim.dt_min,
        max_steps: setup.scenario.env.max_steps,
        wind: setup.scenario.env.sim.wind,
        perturbation: setup.perturbation,
        weather: setup.weather.clone(),
        moisture,
        episodes: runs.iter().map(|(e, _)| e.clone()).collect(),
        burn_count,
        arrival_first_h: first.into_iter().map(|t| t.is_finite().then_some(t)).collect(),
        arrival_median_h: median,
        domain: setup.domain,
    })
}

/// Runs a rule-based (or no-suppression) agent for `runs` seeds (`seed`, `seed + 1`, …).
pub fn run_agent(
    setup: &Setup,
    agent: AgentKind,
    runs: usize,
    seed: u64,
    mut on_run: impl FnMut(usize),
) -> Result<Ensemble, EpisodeError> {
    let mut policy = agent.policy();
    let mut out = Vec::with_capacity(runs);
    for k in 0..runs {
        let s = seed.wrapping_add(k as u64);
        let (cfg, conditions) = setup.run_env(s);
        let mut env = WildfireEnv::new(&setup.landscape, &cfg)?;
        let mut tracker: Option<Tracker> = None;
        let mut last = StepInfo::default();
        let stats = run_episode(&mut env, policy.as_mut(), s, |e, info| {
            match tracker.as_mut() {
                None => tracker = Some(Tracker::new(e.core(), info)),
                Some(t) => t.observe(e.core(), info),
            }
            last = *info;
        });
        let tracker = tracker.ok_or_else(|| EpisodeError::Ignition {
            message: "the run produced no steps".into(),
        })?;
        out.push(tracker.finish(env.core(), &last, stats.terminated, s, None, conditions));
        on_run(k);
    }
    let description = match agent {
        AgentKind::None => "no suppression: the fire burns freely".to_string(),
        AgentKind::Rule => {
            "rule-based helitack plan (FireCastRL's baseline): drops on a 30-cell circle around the ignition"
                .to_string()
        }
        AgentKind::RuleConcentric => {
            "rule-based helitack plan: drops on concentric circles of 45, 40 and 35 cells".to_string()
        }
        AgentKind::Chaser => {
            "helicopter flying to the nearest flames (3 cells a move) and dropping on them".to_string()
        }
    };
    assemble(setup, agent.name(), description, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::LandscapeSpec;

    fn scenario(seed: u64) -> Scenario {
        Scenario::new(
            LandscapeSpec::Procedural {
                seed,
                width: 96,
                height: 64,
                center: Some([39.3, -107.4]),
            },
            EnvConfig {
                max_steps: 20,
                ..EnvConfig::default()
            },
        )
    }

    #[test]
    fn an_ignition_on_water_or_off_the_landscape_is_refused() {
        let root = std::path::Path::new(".");
        let land = scenario(1).landscape.load(root).expect("landscape");
        let water = (1..20)
            .map(|s| (s, scenario(s).landscape.load(root).expect("landscape")))
            .find_map(|(s, l)| {
                let i = l.land_cover.iter().position(|&c| c == 17)?;
                Some((s, l.cell_to_lat_lon(i % l.width, i / l.width)))
            })
            .expect("a landscape with water");
        let Err(e) = Setup::new(scenario(water.0), root, Some([water.1.0, water.1.1])) else {
            panic!("water accepted");
        };
        assert!(e.to_string().contains("nothing there can burn"), "{e}");
        let (lat, lon) = land.cell_to_lat_lon(0, 0);
        let Err(e) = Setup::new(scenario(1), root, Some([lat - 1.0, lon])) else {
            panic!("a point off the landscape accepted");
        };
        assert!(e.to_string().contains("outside the landscape"), "{e}");
    }

    #[test]
    fn runs_that_reach_the_edge_say_so() {
        let mut small = scenario(1);
        small.landscape = LandscapeSpec::Synthetic {
            seed: 5,
            center: [39.3, -107.4],
            width: 16,
            height: 12,
            cell_size_ft: 500.0,
        };
        small.env.max_steps = 400;
        let setup = Setup::new(small, std::path::Path::new("."), None).expect("setup");
        let ensemble = run_agent(&setup, AgentKind::None, 3, 0, |_| {}).expect("runs");
        assert_eq!(ensemble.border_cells, 2 * (16 + 12) - 4);
        let (w, h) = (16, 12);
        let burnt_border = (0..w * h)
            .filter(|&i| {
                (i % w == 0 || i / w == 0 || i % w == w - 1 || i / w == h - 1) && ensemble.burn_count[i] > 0
            })
            .count() as u32;
        let most = ensemble
            .episodes
            .iter()
            .map(|e| e.edge_cells_burned)
            .max()
            .unwrap_or(0);
        assert!(most > 0, "a free fire on a 16 × 12 grid never reached its edge");
        assert!(most <= burnt_border && burnt_border <= ensemble.border_cells);
        for e in &ensemble.episodes {
            assert_eq!(e.edge_first_hour.is_some(), e.edge_cells_burned > 0);
            assert!(e.edge_first_hour.is_none_or(|t| t >= 0.0 && t <= e.hours));
        }
        let line = ensemble.edge_summary().expect("an edge line");
        assert!(line.contains("of 52 border cells"), "{line}");
        let label = ensemble.landscape.expect("a label");
        assert!(
            label.synthetic && label.kind == "synthetic" && label.seed == Some(5),
            "{label:?}"
        );
    }

    #[test]
    fn runs_are_perturbed_by_their_seed_alone() {
        let setup = Setup::new(scenario(1), std::path::Path::new("."), None)
            .expect("setup")
            .with_perturbation(Perturbation::default());
        let (a, ca) = setup.run_env(7);
        let (b, cb) = setup.run_env(7);
        assert_eq!(ca, cb);
        assert_eq!(a.sim.wind, b.sim.wind);
        let (_, other) = setup.run_env(8);
        assert_ne!(ca, other);
        let base = setup.env().sim.wind;
        for s in 0..50 {
            let (_, c) = setup.run_env(s);
            assert!(c.wind_speed_mph <= base.speed_mph * 1.25 + 1e-9);
            assert!(c.wind_speed_mph >= base.speed_mph * 0.75 - 1e-9);
        }
        let calm = Setup::new(scenario(1), std::path::Path::new("."), None)
            .expect("setup")
            .with_perturbation(Perturbation::NONE);
        assert_eq!(calm.run_env(3).0.sim.wind, calm.env().sim.wind);
    }
}
