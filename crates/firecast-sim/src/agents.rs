//! Baseline agents behind a small [`Policy`] trait, the episode runner (paper Table IV
//! columns as mean ± std over seeds) and frame recording for the CLI.

use firecast_landscape::Landscape;

use crate::automaton::{FireState, SimError};
use crate::env::{Action, EnvConfig, EnvCore, Observation, StepInfo, WildfireEnv};

/// What a policy returns: an action, optionally after teleporting the helicopter (only the
/// paper's rule-based agent does that, docs/spec/learning.md §4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Decision {
    pub action: Action,
    pub teleport: Option<[i32; 2]>,
}

impl From<Action> for Decision {
    fn from(action: Action) -> Self {
        Self {
            action,
            teleport: None,
        }
    }
}

/// Episode facts a policy may use when an episode starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EpisodeContext {
    pub width: usize,
    pub height: usize,
    /// Spark cell (x, y).
    pub ignition: (usize, usize),
}

/// Observation → action.
pub trait Policy {
    /// Called at the start of each episode.
    fn reset(&mut self, _ctx: &EpisodeContext) {}
    fn act(&mut self, obs: &Observation<'_>) -> Decision;
    /// Acts with the simulator at hand, for agents that plan with it ([`crate::search`]);
    /// every other agent acts on the observation alone.
    fn decide(&mut self, _env: &EnvCore, obs: &Observation<'_>) -> Decision {
        self.act(obs)
    }
}

/// No suppression: never drops (moves north, action 0, which only moves the helicopter).
#[derive(Debug, Clone, Copy, Default)]
pub struct NoSuppression;

impl Policy for NoSuppression {
    fn act(&mut self, _obs: &Observation<'_>) -> Decision {
        Action::North.into()
    }
}

/// How the rule-based agent reaches its waypoints.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum RuleNavigation {
    /// As `rulebased_simulation.py`: teleport to each waypoint and drop, then two idle steps
    /// (action 0); when the path is exhausted, action 0 at (0, 0) for ever.
    #[default]
    Teleport,
    /// Fly with the move actions (3 cells each) to each waypoint, then drop.
    Fly,
}

/// The paper's rule-based agent (docs/spec/learning.md §4): waypoints every 10° on circles around the
/// fire origin, (int(cx + r·cos a), int(cy + r·sin a)), outermost circle first.
#[derive(Debug, Clone)]
pub struct RuleBasedAgent {
    radii: Vec<f64>,
    navigation: RuleNavigation,
    waypoints: Vec<[i32; 2]>,
    next: usize,
    idle_left: u32,
}

impl RuleBasedAgent {
    /// Variant (a): one circle of radius 30 cells (36 drops).
    pub fn single_circle() -> Self {
        Self::with_radii(vec![30.0])
    }
    /// Variant (b): circles of radius 45, 40, 35 (108 drops).
    pub fn concentric_circles() -> Self {
        Self::with_radii(vec![45.0, 40.0, 35.0])
    }
    pub fn with_radii(radii: Vec<f64>) -> Self {
        Self {
            radii,
            navigation: RuleNavigation::default(),
            waypoints: Vec::new(),
            next: 0,
            idle_left: 0,
        }
    }
    pub fn navigation(mut self, navigation: RuleNavigation) -> Self {
        self.navigation = navigation;
        self
    }
    /// The current waypoint list.
    pub fn waypoints(&self) -> &[[i32; 2]] {
        &self.waypoints
    }
}

impl Policy for RuleBasedAgent {
    fn reset(&mut self, ctx: &EpisodeContext) {
        let (cx, cy) = (ctx.ignition.0 as f64, ctx.ignition.1 as f64);
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        self.waypoints.clear();
        for &r in &self.radii {
            for k in 0..36 {
                let a = f64::from(k * 10).to_radians();
                // Python int() truncates toward zero; then clipped to the grid like the env.
                let x = ((cx + r * a.cos()).trunc() as i32).clamp(0, w - 1);
                let y = ((cy + r * a.sin()).trunc() as i32).clamp(0, h - 1);
                self.waypoints.push([x, y]);
            }
        }
        self.next = 0;
        self.idle_left = 0;
    }

    fn act(&mut self, obs: &Observation<'_>) -> Decision {
        match self.navigation {
            RuleNavigation::Teleport => {
                if self.idle_left > 0 {
                    self.idle_left -= 1;
                    return Action::North.into();
                }
                match self.waypoints.get(self.next) {
                    Some(&wp) => {
                        self.next += 1;
                        self.idle_left = 2;
                        Decision {
                            action: Action::Drop,
                            teleport: Some(wp),
                        }
                    }
                    None => Decision {
                        action: Action::North,
                        teleport: Some([0, 0]),
                    },
                }
            }
            RuleNavigation::Fly => {
                let Some(&[tx, ty]) = self.waypoints.get(self.next) else {
                    return Action::North.into();
                };
                let [x, y] = obs.agent;
                let (dx, dy) = (tx - x, ty - y);
                // Within half a move of the waypoint: drop there.
                if dx.abs() <= 1 && dy.abs() <= 1 {
                    self.next += 1;
                    return Action::Drop.into();
                }
                move_towards(dx, dy).into()
            }
        }
    }
}

/// A helicopter that must fly (3 cells per move, no teleport, like the PPO agent): it heads
/// for the nearest burning cell and drops when a burning cell lies within `reach` cells. The
/// flying counterpart of the rule-based agent, so Table IV can tell what flying costs from
/// what learning costs.
#[derive(Debug, Clone, Copy)]
pub struct FireChaser {
    reach: i32,
}

impl Default for FireChaser {
    /// Reach 4: inside the 5-cell drop footprint (docs/spec/fire-model.md §A8), so a drop always
    /// hits the cell it aims at.
    fn default() -> Self {
        Self { reach: 4 }
    }
}

impl FireChaser {
    pub fn with_reach(reach: u32) -> Self {
        Self {
            reach: i32::try_from(reach).unwrap_or(i32::MAX),
        }
    }
}

/// Cell codes of Burning cells in an observation frame (`state · 3 + BI + 1`, BI 0–2; see
/// `EnvCore::code`).
const BURNING_CODES: std::ops::RangeInclusive<u8> =
    (FireState::Burning as u8 * 3 + 1)..=(FireState::Burning as u8 * 3 + 3);

impl Policy for FireChaser {
    fn act(&mut self, obs: &Observation<'_>) -> Decision {
        let frame = obs.current_frame();
        let [hx, hy] = obs.agent;
        // Nearest burning cell (squared distance, then lowest index).
        let mut best: Option<(i64, i32, i32)> = None;
        for (i, &code) in frame.iter().enumerate() {
            if !BURNING_CODES.contains(&code) {
                continue;
            }
            let (x, y) = ((i % obs.width) as i32, (i / obs.width) as i32);
            let d2 = i64::from(x - hx).pow(2) + i64::from(y - hy).pow(2);
            if best.is_none_or(|(b, ..)| d2 < b) {
                best = Some((d2, x, y));
            }
        }
        let Some((d2, tx, ty)) = best else {
            return Action::North.into();
        };
        if d2 <= i64::from(self.reach).pow(2) {
            return Action::Drop.into();
        }
        move_towards(tx - hx, ty - hy).into()
    }
}

/// The move that closes the larger of the two offsets to a target cell (x first on a tie).
fn move_towards(dx: i32, dy: i32) -> Action {
    if dx.abs() >= dy.abs() {
        if dx > 0 { Action::East } else { Action::West }
    } else if dy > 0 {
        Action::North
    } else {
        Action::South
    }
}

/// One episode's Table IV numbers.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EpisodeStats {
    pub seed: u64,
    /// Cells that burned (Burnt + still Burning at the end).
    pub cells_burned: u32,
    pub timesteps: u32,
    pub helitacks: u32,
    pub water_used_gal: f64,
    /// Whether the fire went out (false: truncated).
    pub terminated: bool,
}

/// Mean and sample standard deviation.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct MeanStd {
    pub mean: f64,
    pub std: f64,
}

impl MeanStd {
    pub fn of(values: impl IntoIterator<Item = f64>) -> Self {
        let v: Vec<f64> = values.into_iter().collect();
        if v.is_empty() {
            return Self::default();
        }
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let var = if v.len() > 1 {
            v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0)
        } else {
            0.0
        };
        Self {
            mean,
            std: var.sqrt(),
        }
    }
}

/// Per-episode numbers plus mean ± std of each Table IV column.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EvalReport {
    pub episodes: Vec<EpisodeStats>,
    pub cells_burned: MeanStd,
    pub timesteps: MeanStd,
    pub helitacks: MeanStd,
    pub water_used_gal: MeanStd,
}

fn context(env: &WildfireEnv) -> EpisodeContext {
    let a = env.automaton();
    EpisodeContext {
        width: a.width(),
        height: a.height(),
        ignition: env.core().ignition_cell(),
    }
}

/// Runs one episode; `on_step` sees the env and its info after reset and after every step.
pub fn run_episode(
    env: &mut WildfireEnv,
    policy: &mut dyn Policy,
    seed: u64,
    mut on_step: impl FnMut(&WildfireEnv, &StepInfo),
) -> EpisodeStats {
    let (_, info) = env.reset(seed);
    policy.reset(&context(env));
    on_step(env, &info);
    loop {
        let decision = policy.decide(env.core(), &env.observation());
        let (_, _, terminated, truncated, info) = env.step_with_teleport(decision.action, decision.teleport);
        on_step(env, &info);
        if terminated || truncated {
            return EpisodeStats {
                seed,
                cells_burned: info.cells_burnt + info.cells_burning,
                timesteps: info.step,
                helitacks: info.drops,
                water_used_gal: info.water_used_gal,
                terminated,
            };
        }
    }
}

/// Runs `episodes` episodes with seeds `seed, seed + 1, …`.
pub fn run_episodes(
    landscape: &Landscape,
    cfg: &EnvConfig,
    policy: &mut dyn Policy,
    episodes: usize,
    seed: u64,
) -> Result<EvalReport, SimError> {
    let mut env = WildfireEnv::new(landscape, cfg)?;
    let stats: Vec<EpisodeStats> = (0..episodes as u64)
        .map(|k| run_episode(&mut env, policy, seed.wrapping_add(k), |_, _| {}))
        .collect();
    Ok(EvalReport {
        cells_burned: MeanStd::of(stats.iter().map(|s| f64::from(s.cells_burned))),
        timesteps: MeanStd::of(stats.iter().map(|s| f64::from(s.timesteps))),
        helitacks: MeanStd::of(stats.iter().map(|s| f64::from(s.helitacks))),
        water_used_gal: MeanStd::of(stats.iter().map(|s| s.water_used_gal)),
        episodes: stats,
    })
}

/// Per-step fire-state grids of one episode, for rendering (PNG/GIF) by the CLI.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeFrames {
    pub width: usize,
    pub height: usize,
    /// One grid per step, the initial state first: 0 unburnt, 1 burning, 2 burnt, row-major
    /// with row 0 south (flip vertically to draw).
    pub fire_states: Vec<Vec<u8>>,
    /// Helicopter cell at each frame.
    pub helicopter: Vec<[i32; 2]>,
    pub stats: EpisodeStats,
}

/// Records the fire-state grid at every step of one episode.
pub fn record_frames(
    landscape: &Landscape,
    cfg: &EnvConfig,
    policy: &mut dyn Policy,
    seed: u64,
) -> Result<EpisodeFrames, SimError> {
    let mut env = WildfireEnv::new(landscape, cfg)?;
    let mut fire_states = Vec::new();
    let mut helicopter = Vec::new();
    let stats = run_episode(&mut env, policy, seed, |e, _| {
        fire_states.push(e.automaton().fire_states().to_vec());
        helicopter.push(e.core().helicopter());
    });
    Ok(EpisodeFrames {
        width: landscape.width,
        height: landscape.height,
        fire_states,
        helicopter,
        stats,
    })
}
