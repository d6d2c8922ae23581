//! Fires for the page: the environment of a place and day (the threat pipeline's landscape,
//! wind and moisture, so the live fire is the fire the report simulates), and live runs of
//! it under an agent, stepped on their own thread and streamed frame by frame.
//!
//! A frame is binary, little-endian (see `docs/web-app.md` in the repository):
//! `u32 step, f32 hours, u32 burning, u32 burnt, i16 heli_x, i16 heli_y, u8 flags
//! (1: dropped this step, 2: last frame), 3 × u8 padding, u32 n, n × u32 change` where a
//! change is `cell << 8 | state` (state 0 unburnt, 1 burning, 2 burnt, 3 wetted by a drop)
//! and cells count from the south-west corner, row by row (row 0 south).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use firecast_episodes::WeatherSpec;
use firecast_episodes::ensemble::Setup;
use firecast_episodes::{AgentKind, LandscapeSpec, Scenario};
use firecast_landscape::Landscape;
use firecast_sim::{EnvConfig, EpisodeContext, Policy, WildfireEnv};
use serde::Serialize;

use crate::error::{ApiError, Code};

/// Cells of the fire's landscape (the threat pipeline's 240 × 160 grid of 500 ft cells).
pub const WIDTH: usize = 240;
pub const HEIGHT: usize = 160;
const SQ_FT_PER_ACRE: f64 = 43_560.0;

/// What the threat pipeline's `vars` say about its fires (read from `pipelines/threat.yaml`).
#[derive(Debug, Clone)]
pub struct FireSettings {
    pub landscape_seed: u64,
    pub env: EnvConfig,
    /// Where these came from, for the page.
    pub source: String,
}

impl FireSettings {
    /// `vars.landscape_seed` and `vars.env` of the threat pipeline; defaults when the file is
    /// absent. A file that exists but does not parse is an error naming it.
    pub fn from_threat_pipeline(path: &Path) -> Result<Self, String> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Ok(Self {
                    landscape_seed: 1,
                    env: EnvConfig::default(),
                    source: "defaults (no threat pipeline)".into(),
                });
            }
            Err(e) => return Err(format!("{}: {e}", path.display())),
        };
        let doc: serde_yaml_ng::Value =
            serde_yaml_ng::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        let vars = doc.get("vars");
        let landscape_seed = vars
            .and_then(|v| v.get("landscape_seed"))
            .and_then(serde_yaml_ng::Value::as_u64)
            .unwrap_or(1);
        let env_value = vars
            .and_then(|v| v.get("env"))
            .cloned()
            .unwrap_or(serde_yaml_ng::Value::Null);
        let env: EnvConfig = if env_value.is_null() {
            EnvConfig::default()
        } else {
            let json =
                serde_json::to_value(&env_value).map_err(|e| format!("{}: vars.env: {e}", path.display()))?;
            serde_json::from_value(json).map_err(|e| format!("{}: vars.env: {e}", path.display()))?
        };
        Ok(Self {
            landscape_seed,
            env,
            source: path.display().to_string(),
        })
    }
}

/// One place and day, ready to burn.
pub struct Environment {
    pub id: String,
    pub lat: f64,
    pub lon: f64,
    pub date: String,
    pub setup: Setup,
    /// Land cover over hillshade, one pixel per cell, north up.
    pub landscape_png: Vec<u8>,
}

/// The environment as the page sees it.
#[derive(Debug, Clone, Serialize)]
pub struct EnvironmentInfo {
    pub id: String,
    pub lat: f64,
    pub lon: f64,
    pub date: String,
    pub width: usize,
    pub height: usize,
    pub cell_size_ft: f64,
    pub cell_acres: f64,
    pub step_minutes: f64,
    pub max_steps: u32,
    pub max_hours: f64,
    /// Ignition cell [x, y] (row 0 south).
    pub ignition: [usize; 2],
    pub wind_speed_mph: f64,
    pub wind_from_deg: f64,
    pub weather: Option<String>,
    pub landscape: String,
    pub landscape_png: String,
}

impl Environment {
    /// Builds the landscape around the point with the day's GRIDMET wind and puts the spark
    /// on the point; refuses a point without fuel.
    pub fn create(
        root: &Path,
        gridmet: &Path,
        settings: &FireSettings,
        lat: f64,
        lon: f64,
        date: &str,
    ) -> Result<Self, ApiError> {
        let mut scenario = Scenario::new(
            LandscapeSpec::Procedural {
                seed: settings.landscape_seed,
                width: WIDTH,
                height: HEIGHT,
                center: Some([lat, lon]),
            },
            settings.env.clone(),
        );
        scenario.weather = Some(WeatherSpec::gridmet_wind(gridmet.to_path_buf(), date));
        let setup = Setup::new(scenario, root, Some([lat, lon])).map_err(|e| {
            let text = e.to_string();
            if text.contains("nothing there can burn") {
                ApiError::new(Code::NoFuel, text)
            } else if text.contains("GRIDMET") || text.contains("weather") || text.contains(".nc") {
                ApiError::new(Code::NoWeather, text)
            } else {
                ApiError::internal(text)
            }
        })?;
        let landscape_png = landscape_png(&setup.landscape)?;
        Ok(Self {
            id: environment_id(lat, lon, date, settings.landscape_seed),
            lat,
            lon,
            date: date.to_string(),
            setup,
            landscape_png,
        })
    }

    pub fn info(&self) -> EnvironmentInfo {
        let env = self.setup.env();
        let l = &self.setup.landscape;
        let step_minutes = env.sim.dt_min;
        EnvironmentInfo {
            id: self.id.clone(),
            lat: self.lat,
            lon: self.lon,
            date: self.date.clone(),
            width: l.width,
            height: l.height,
            cell_size_ft: l.cell_size_ft,
            cell_acres: l.cell_size_ft * l.cell_size_ft / SQ_FT_PER_ACRE,
            step_minutes,
            max_steps: env.max_steps,
            max_hours: f64::from(env.max_steps) * step_minutes / 60.0,
            ignition: self.setup.ignition,
            wind_speed_mph: env.sim.wind.speed_mph,
            wind_from_deg: env.sim.wind.from_direction_deg,
            weather: self.setup.weather.as_ref().map(|w| {
                format!(
                    "GRIDMET {}: wind {:.1} m/s from {:.0}° at ({:.4}, {:.4})",
                    w.date, w.vs_m_s, w.th_deg, w.lat, w.lon
                )
            }),
            landscape: format!(
                "procedural landscape (seed {}) centred on the point, {}×{} cells of {:.0} ft",
                match &self.setup.scenario.landscape {
                    LandscapeSpec::Procedural { seed, .. } => *seed,
                    _ => 0,
                },
                l.width,
                l.height,
                l.cell_size_ft
            ),
            landscape_png: format!("/api/environments/{}/landscape.png", self.id),
        }
    }
}

/// Stable for a place, day and landscape seed: a shared URL finds the same fire.
pub fn environment_id(lat: f64, lon: f64, date: &str, seed: u64) -> String {
    let key = format!("{lat:.6},{lon:.6},{date},{seed}");
    blake3::hash(key.as_bytes()).to_hex()[..16].to_string()
}

fn landscape_png(l: &Landscape) -> Result<Vec<u8>, ApiError> {
    let options = firecast_render::RenderOptions {
        scale: 1,
        legend: false,
        ..firecast_render::RenderOptions::default()
    };
    let basemap = firecast_render::basemap::Basemap::new(l, &options);
    firecast_render::output::encode_png(&basemap.image).map_err(|e| ApiError::internal(e.to_string()))
}

/// The agents a live fire can be played by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LiveAgent {
    /// The trained PPO agent (the server's `--agent-run`).
    Ppo,
    Rule(AgentKind),
}

impl LiveAgent {
    pub fn parse(s: &str) -> Result<Self, ApiError> {
        match s {
            "ppo" => Ok(Self::Ppo),
            other => other.parse::<AgentKind>().map(Self::Rule).map_err(|_| {
                ApiError::bad(format!(
                    "unknown agent `{other}`: ppo, rule, rule-concentric, chaser or none"
                ))
            }),
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Self::Ppo => "ppo",
            Self::Rule(k) => k.name(),
        }
    }
}

/// Loads the PPO agent of a training-run folder (its first training seed) for a landscape.
pub fn ppo_policy(
    run: Option<&PathBuf>,
    width: usize,
    height: usize,
) -> Result<Box<dyn Policy + Send>, ApiError> {
    let Some(run) = run else {
        return Err(ApiError::new(
            Code::NoModel,
            "no trained PPO agent: run `cargo xtask demo` or `firecast pipeline run pipelines/threat.yaml`, or start the server with --agent-run DIR",
        ));
    };
    let (_, policies) = firecast_rl::ensemble::load_policies(run, firecast_rl::Device::Cpu)
        .map_err(|e| ApiError::new(Code::NoModel, format!("{}: {e}", run.display())))?;
    let first = policies
        .into_iter()
        .next()
        .ok_or_else(|| ApiError::new(Code::NoModel, format!("{}: no policies", run.display())))?;
    // Greedy, as `rl.ensemble` plays it (the action seed draws nothing).
    let live = firecast_rl::agent::PpoAgent::with_source(first, width, height, true, 0)
        .map_err(|e| ApiError::new(Code::NoModel, format!("{}: {e}", run.display())))?;
    Ok(Box::new(live))
}

/// What a live run says when it starts.
#[derive(Debug, Clone, Serialize)]
pub struct StartMessage {
    #[serde(rename = "type")]
    pub kind: &'static str,
    pub agent: String,
    pub seed: u64,
    pub width: usize,
    pub height: usize,
    pub cell_acres: f64,
    pub step_minutes: f64,
    pub max_steps: u32,
    pub wind_speed_mph: f64,
    pub wind_from_deg: f64,
    pub dead_1h_frac: Option<f64>,
}

/// What a live run says when it ends.
#[derive(Debug, Clone, Serialize)]
pub struct EndMessage {
    #[serde(rename = "type")]
    pub kind: &'static str,
    pub steps: u32,
    pub hours: f64,
    pub burnt_cells: u32,
    pub burnt_acres: f64,
    pub drops: u32,
    /// The fire went out (else the run reached its last step still burning).
    pub fire_out: bool,
}

/// One run of an environment under one policy, stepped by the caller.
pub struct LiveRun {
    env: WildfireEnv,
    policy: Box<dyn Policy + Send>,
    /// The automaton's states and drop counts as of the last frame (u8::MAX before it).
    seen_states: Vec<u8>,
    seen_drops: Vec<u8>,
    cell_acres: f64,
    pub start: StartMessage,
    done: bool,
    last_drops: u32,
    steps: u32,
}

impl LiveRun {
    /// Run `seed` of the environment: the weather and moisture `sim.ensemble`'s run `seed`
    /// meets, so the page's fire is one of the report's.
    pub fn new(
        environment: &Arc<Environment>,
        agent: LiveAgent,
        mut policy: Box<dyn Policy + Send>,
        seed: u64,
    ) -> Result<(Self, Vec<u8>), ApiError> {
        let (cfg, conditions) = environment.setup.run_env(seed);
        let l = &environment.setup.landscape;
        let mut env = WildfireEnv::new(l, &cfg).map_err(|e| ApiError::internal(e.to_string()))?;
        env.reset(seed);
        policy.reset(&EpisodeContext {
            width: l.width,
            height: l.height,
            ignition: (environment.setup.ignition[0], environment.setup.ignition[1]),
        });
        let info = environment.info();
        let start = StartMessage {
            kind: "start",
            agent: agent.name().to_string(),
            seed,
            width: l.width,
            height: l.height,
            cell_acres: info.cell_acres,
            step_minutes: cfg.sim.dt_min,
            max_steps: cfg.max_steps,
            wind_speed_mph: conditions.wind_speed_mph,
            wind_from_deg: conditions.wind_from_deg,
            dead_1h_frac: conditions.dead_1h_frac,
        };
        let mut run = Self {
            env,
            policy,
            seen_states: vec![u8::MAX; l.width * l.height],
            seen_drops: vec![u8::MAX; l.width * l.height],
            cell_acres: info.cell_acres,
            start,
            done: false,
            last_drops: 0,
            steps: 0,
        };
        let first = run.frame(0, false, false);
        Ok((run, first))
    }

    pub fn is_done(&self) -> bool {
        self.done
    }

    /// One step; returns its frame (the last one has flag 2).
    pub fn step(&mut self) -> Vec<u8> {
        if self.done {
            return Vec::new();
        }
        let decision = self.policy.act(&self.env.observation());
        let (_, _, terminated, truncated, info) =
            self.env.step_with_teleport(decision.action, decision.teleport);
        let dropped = info.drops > self.last_drops;
        self.last_drops = info.drops;
        self.steps = info.step;
        self.done = terminated || truncated;
        self.frame(info.step, dropped, self.done)
    }

    /// The end summary (valid once done).
    pub fn end(&self) -> EndMessage {
        let a = self.env.automaton();
        let burnt = a.cells_burnt() + a.cells_burning();
        EndMessage {
            kind: "end",
            steps: self.steps,
            hours: a.time_min() / 60.0,
            burnt_cells: burnt,
            burnt_acres: f64::from(burnt) * self.cell_acres,
            drops: self.last_drops,
            fire_out: a.cells_burning() == 0,
        }
    }

    fn frame(&mut self, step: u32, dropped: bool, last: bool) -> Vec<u8> {
        let a = self.env.automaton();
        let mut changes: Vec<u32> = Vec::new();
        // Eight cells at a time against the last frame's raw states and drops: most of a
        // 240 × 160 map is unchanged from one step to the next, and 200 live fires scan it 30
        // times a second each.
        let (states, drops) = (a.fire_states(), a.helitack_drop_counts());
        let Self {
            seen_states,
            seen_drops,
            ..
        } = self;
        for (chunk, ((st, dr), (ps, pd))) in states
            .chunks(8)
            .zip(drops.chunks(8))
            .zip(seen_states.chunks_mut(8).zip(seen_drops.chunks_mut(8)))
            .enumerate()
        {
            if word(st) == word(ps) && word(dr) == word(pd) {
                continue;
            }
            for j in 0..st.len() {
                let state = page_state(st[j], dr[j]);
                // What the page shows now: the last frame's cell (none before the first
                // frame: the page starts from "all unburnt", so only what differs is sent).
                let shown = if ps[j] == u8::MAX {
                    0
                } else {
                    page_state(ps[j], pd[j])
                };
                if state != shown {
                    changes.push((((chunk * 8 + j) as u32) << 8) | u32::from(state));
                }
            }
            ps.copy_from_slice(st);
            pd.copy_from_slice(dr);
        }
        let heli = self.env.core().helicopter();
        let mut out = Vec::with_capacity(28 + 4 * changes.len());
        out.extend_from_slice(&step.to_le_bytes());
        out.extend_from_slice(&((a.time_min() / 60.0) as f32).to_le_bytes());
        out.extend_from_slice(&a.cells_burning().to_le_bytes());
        out.extend_from_slice(&a.cells_burnt().to_le_bytes());
        out.extend_from_slice(&(heli[0].clamp(-1, i32::from(i16::MAX)) as i16).to_le_bytes());
        out.extend_from_slice(&(heli[1].clamp(-1, i32::from(i16::MAX)) as i16).to_le_bytes());
        out.push(u8::from(dropped) | (u8::from(last) << 1));
        out.extend_from_slice(&[0, 0, 0]);
        out.extend_from_slice(&(changes.len() as u32).to_le_bytes());
        for c in changes {
            out.extend_from_slice(&c.to_le_bytes());
        }
        out
    }
}

/// A cell as the page draws it: 0 unburnt, 1 burning, 2 burnt, 3 wetted by a drop.
#[inline(always)]
fn page_state(state: u8, drops: u8) -> u8 {
    if state == 0 && drops > 0 { 3 } else { state.min(2) }
}

/// Up to eight bytes as one word (a whole chunk compiles to one load).
#[inline(always)]
fn word(bytes: &[u8]) -> u64 {
    let mut w = [0u8; 8];
    w[..bytes.len()].copy_from_slice(bytes);
    u64::from_ne_bytes(w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_stable_and_distinct() {
        assert_eq!(
            environment_id(39.3, -107.4, "2019-08-01", 1),
            environment_id(39.3, -107.4, "2019-08-01", 1)
        );
        assert_ne!(
            environment_id(39.3, -107.4, "2019-08-01", 1),
            environment_id(39.3, -107.4, "2019-08-02", 1)
        );
    }

    #[test]
    fn agents_parse_or_name_the_choices() {
        assert_eq!(
            LiveAgent::parse("ppo").unwrap_or(LiveAgent::Rule(AgentKind::None)),
            LiveAgent::Ppo
        );
        assert_eq!(
            LiveAgent::parse("chaser").map(LiveAgent::name).ok(),
            Some("chaser")
        );
        let err = LiveAgent::parse("bulldozer")
            .err()
            .map(|e| e.message)
            .unwrap_or_default();
        assert!(err.contains("ppo, rule"), "{err}");
    }
}
