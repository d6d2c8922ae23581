//! The helitack suppression environment (docs/spec/learning.md §2) with Gymnasium semantics, and a
//! vectorised version stepping N environments in parallel.
//!
//! - Actions (Discrete(5), FireCastRL's numbering): 0 north (y + speed), 1 south (y − speed),
//!   2 west (x − speed), 3 east (x + speed), 4 helitack drop. Grid y points north and x east,
//!   and every render is drawn north up, so 0 moves the helicopter *up* on screen (FireCastRL
//!   called it "Down": its screen's y grows downwards).
//! - Observation: the last [`FRAME_STACK`] frames (oldest first, newest last) of H×W cell codes,
//!   the helicopter cell and whether it is over a *Burning* cell. Cell code (P1 intent,
//!   docs/spec/learning.md §2.3): 0 for non-burnable cells, else fireState·3 + BI + 1 (1..=9);
//!   divide by [`CODE_MAX`] for the normalised [0, 1] value. Frames are `u8` and updated
//!   incrementally from the cells that changed in the last four steps, so a step costs O(changes).
//! - One step: teleport (rule-based agent only), apply the action, then exactly one
//!   `update_fire(t + dt)`; reward and observation describe the state after the update.

use firecast_landscape::Landscape;
use rayon::prelude::*;

use crate::automaton::{Automaton, FireState, SimConfig, SimError};

/// Frames in the observation stack.
pub const FRAME_STACK: usize = 4;
/// Largest cell code (Burnt, High BI); codes / 9 lie in [0, 1].
pub const CODE_MAX: u8 = 9;

/// The five discrete actions (FireCastRL numbering). Grid y points north, so on the north-up
/// renders (firecast-render, the Python package's `render()`) `North` moves the helicopter up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Action {
    /// y + speed: north, up on the render (FireCastRL's "Down").
    North = 0,
    /// y − speed: south, down on the render (FireCastRL's "Up").
    South = 1,
    /// x − speed: west, left on the render.
    West = 2,
    /// x + speed: east, right on the render.
    East = 3,
    /// Helitack drop on the helicopter cell.
    Drop = 4,
}

impl Action {
    pub const ALL: [Action; 5] = [Self::North, Self::South, Self::West, Self::East, Self::Drop];
    /// Lower-case names by action number, as the Python package's `ACTIONS` lists them.
    pub const NAMES: [&'static str; 5] = ["north", "south", "west", "east", "drop"];

    /// The lower-case name (`north`, `south`, `west`, `east`, `drop`).
    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }
}

impl TryFrom<u8> for Action {
    type Error = SimError;
    fn try_from(v: u8) -> Result<Self, SimError> {
        Self::ALL
            .get(usize::from(v))
            .copied()
            .ok_or_else(|| SimError::Config(format!("action {v} is not in 0..=4")))
    }
}

/// When an episode terminates.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Termination {
    /// Nothing burns and no ignition is scheduled before the truncation time (the fire is
    /// out for the rest of the episode).
    #[default]
    FireOut,
    /// No cell is Burning (the originals' test; a fully quenched front ends the episode even
    /// if ignitions are still scheduled).
    NoBurningCells,
}

/// Reward weights. Defaults are the P2 set; [`websocket_t`](Self::websocket_t) and
/// [`p1_improved`](Self::p1_improved) are the original sets.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RewardWeights {
    /// Per quenched (Burning → Unburnt) cell.
    pub quenched: f64,
    /// Per newly burnt cell.
    pub new_burnt: f64,
    /// Per burning cell after the step.
    pub burning: f64,
    /// Per unit of reduction in burning cells (previous − current).
    pub burning_reduction: f64,
    /// Every step (time/idleness cost).
    pub step: f64,
    /// Proximity bonus amplitude A in A·exp(−d/scale), d the distance (cells) from the
    /// helicopter to the nearest burning cell; 0 when nothing burns.
    pub proximity: f64,
    pub proximity_scale_cells: f64,
    /// Per cell the helicopter got closer to the nearest burning cell during the step
    /// (negative when it moved away): shaping with the potential −d, so it rewards flying to
    /// the fire without changing which policies are best (Ng et al., 1999, with γ = 1).
    /// 0 when nothing burns before or after the step.
    pub approach: f64,
    /// Drop on a Burning cell: this × (BI + 1).
    pub drop_burning_per_bi: f64,
    /// Drop on a Burnt cell.
    pub drop_burnt: f64,
    /// Drop on a non-burnable cell; `None` classifies it by its fire state instead.
    pub drop_non_burnable: Option<f64>,
    /// Drop on an Unburnt cell with n > 0 burning cells in the window: this × min(n, cap).
    pub drop_unburnt_per_nearby: f64,
    pub drop_unburnt_nearby_cap: u32,
    /// Half-width of that window (5 → 11×11).
    pub drop_unburnt_window: u32,
    /// Drop on an Unburnt cell with no burning cell in the window.
    pub drop_unburnt_isolated: f64,
    /// The sum is multiplied by this, then clipped.
    pub scale: f64,
    pub clip: Option<[f64; 2]>,
}

impl Default for RewardWeights {
    fn default() -> Self {
        Self::p2()
    }
}

impl RewardWeights {
    fn zero() -> Self {
        Self {
            quenched: 0.0,
            new_burnt: 0.0,
            burning: 0.0,
            burning_reduction: 0.0,
            step: 0.0,
            proximity: 0.0,
            proximity_scale_cells: 20.0,
            approach: 0.0,
            drop_burning_per_bi: 0.0,
            drop_burnt: 0.0,
            drop_non_burnable: None,
            drop_unburnt_per_nearby: 0.0,
            drop_unburnt_nearby_cap: 5,
            drop_unburnt_window: 5,
            drop_unburnt_isolated: 0.0,
            scale: 1.0,
            clip: None,
        }
    }

    /// P2 (`firecastrl/Wildfire-env0`, docs/spec/learning.md §2.4): +5 quenched, −0.05 burning,
    /// −0.01 step, −1 drop on non-burnable or burnt, clipped to [−10, 10].
    pub fn p2() -> Self {
        Self {
            quenched: 5.0,
            burning: -0.05,
            step: -0.01,
            drop_burnt: -1.0,
            drop_non_burnable: Some(-1.0),
            clip: Some([-10.0, 10.0]),
            ..Self::zero()
        }
    }

    /// Variant T (websocket, docs/spec/learning.md §2.2): +10 quenched, −5 new burnt, −0.1 burning,
    /// −0.1 step, 2·exp(−d/20) proximity, drops +40·(BI+1) / −5 burnt / +5·min(n,5) or −10.
    pub fn websocket_t() -> Self {
        Self {
            quenched: 10.0,
            new_burnt: -5.0,
            burning: -0.1,
            step: -0.1,
            proximity: 2.0,
            proximity_scale_cells: 20.0,
            drop_burning_per_bi: 40.0,
            drop_burnt: -5.0,
            drop_non_burnable: None,
            drop_unburnt_per_nearby: 5.0,
            drop_unburnt_nearby_cap: 5,
            drop_unburnt_window: 5,
            drop_unburnt_isolated: -10.0,
            ..Self::zero()
        }
    }

    /// Variant P1 `calculate_reward_improved_scaled` (docs/spec/learning.md §2.3), penalty check on
    /// cell state: −1 new burnt, +2 quenched, +1 per burning reduction, −0.05 burning, −0.01 step,
    /// −0.2 drop on river/burnt, clipped to [−10, 10].
    pub fn p1_improved() -> Self {
        Self {
            quenched: 2.0,
            new_burnt: -1.0,
            burning: -0.05,
            burning_reduction: 1.0,
            step: -0.01,
            drop_burnt: -0.2,
            drop_non_burnable: Some(-0.2),
            clip: Some([-10.0, 10.0]),
            ..Self::zero()
        }
    }

    /// FireCast's own: +1 per quenched cell and +1 per cell flown towards the nearest flames
    /// (potential shaping), unclipped, nothing else. Only what the helicopter does is paid:
    /// the originals charge every burning or newly burnt cell, which mostly measures how big
    /// a fire the weather made (the bulk of the return's variance, which no action changes),
    /// and clip each step at ±10, which a few hundred burning cells reach whatever a drop
    /// saved. Measured: with −1 per newly burnt cell added, 41k steps showed no trend.
    pub fn suppression() -> Self {
        Self {
            quenched: 1.0,
            approach: 1.0,
            ..Self::zero()
        }
    }

    /// A named preset: `p2`, `websocket_t`, `p1_improved` or `suppression`.
    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "p2" => Some(Self::p2()),
            "websocket_t" => Some(Self::websocket_t()),
            "p1_improved" => Some(Self::p1_improved()),
            "suppression" => Some(Self::suppression()),
            _ => None,
        }
    }
}

/// Environment configuration (defaults: P2 with the choices).
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct EnvConfig {
    pub sim: SimConfig,
    /// Truncation after this many steps.
    pub max_steps: u32,
    /// Spark cell; `None` = (w/2 − 1, h/2 − 1), i.e. (119, 79) on 240×160.
    pub ignition: Option<[usize; 2]>,
    /// Helicopter start; `None` = (70·w/240, 30·h/160), i.e. (70, 30) on 240×160.
    pub helicopter_start: Option<[usize; 2]>,
    /// Cells per move action.
    pub helicopter_speed_cells: u32,
    /// Minimum simulated minutes between drops (0 = none, as in the RL variants; Concord 240).
    /// A drop during the cooldown does nothing.
    pub drop_cooldown_min: f64,
    pub water_per_drop_gal: f64,
    pub termination: Termination,
    pub reward: RewardWeights,
}

impl Default for EnvConfig {
    fn default() -> Self {
        Self {
            sim: SimConfig::default(),
            max_steps: 2000,
            ignition: None,
            helicopter_start: None,
            helicopter_speed_cells: 3,
            drop_cooldown_min: 0.0,
            water_per_drop_gal: 800.0,
            termination: Termination::FireOut,
            reward: RewardWeights::p2(),
        }
    }
}

/// Per-step information (counters are episode totals unless said otherwise).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepInfo {
    /// Steps taken in this episode.
    pub step: u32,
    pub sim_time_min: f64,
    pub cells_burning: u32,
    pub cells_burnt: u32,
    /// Cells that became Burnt during this step.
    pub new_burnt: u32,
    /// Cells quenched by this step's drop.
    pub quenched_step: u32,
    /// Cells quenched in the episode.
    pub cells_quenched: u32,
    /// Drops applied in the episode.
    pub drops: u32,
    pub water_used_gal: f64,
}

/// What an agent sees.
#[derive(Debug, Clone, Copy)]
pub struct Observation<'a> {
    /// `FRAME_STACK × height × width` cell codes, oldest frame first.
    pub frames: &'a [u8],
    pub width: usize,
    pub height: usize,
    /// Helicopter cell [x, y].
    pub agent: [i32; 2],
    /// Whether the helicopter cell is Burning.
    pub on_fire: bool,
}

impl Observation<'_> {
    /// The newest frame.
    pub fn current_frame(&self) -> &[u8] {
        let n = self.width * self.height;
        &self.frames[(FRAME_STACK - 1) * n..]
    }
}

/// The environment without its frame buffer (the caller owns the frames; see [`VecEnv`]).
/// Clones share the automaton's spread-rate cache.
#[derive(Clone)]
pub struct EnvCore {
    sim: Automaton,
    cfg: EnvConfig,
    ignition: (usize, usize),
    heli: (i32, i32),
    steps: u32,
    drops: u32,
    quenched_total: u32,
    water: f64,
    last_drop_min: f64,
    /// Distance (cells) from the helicopter to the nearest burning cell after the last step.
    fire_distance: Option<f64>,
    cur_code: Vec<u8>,
    diffs: [Vec<(u32, u8)>; FRAME_STACK],
    head: usize,
    dirty: Vec<u32>,
}

impl EnvCore {
    pub fn new(landscape: &Landscape, cfg: &EnvConfig) -> Result<Self, SimError> {
        let sim = Automaton::new(landscape, &cfg.sim)?;
        let (w, h) = (landscape.width, landscape.height);
        let ignition = match cfg.ignition {
            Some([x, y]) => (x, y),
            None => ((w / 2).saturating_sub(1), (h / 2).saturating_sub(1)),
        };
        let start = match cfg.helicopter_start {
            Some([x, y]) => (x, y),
            None => (70 * w / 240, 30 * h / 160),
        };
        for (x, y) in [ignition, start] {
            if x >= w || y >= h {
                return Err(SimError::OutOfBounds {
                    x: x as i64,
                    y: y as i64,
                    width: w,
                    height: h,
                });
            }
        }
        Ok(Self {
            sim,
            cfg: cfg.clone(),
            ignition,
            heli: (start.0 as i32, start.1 as i32),
            steps: 0,
            drops: 0,
            quenched_total: 0,
            fire_distance: None,
            water: 0.0,
            last_drop_min: f64::NEG_INFINITY,
            cur_code: vec![0; w * h],
            diffs: Default::default(),
            head: 0,
            dirty: Vec::new(),
        })
    }

    /// Length of one observation's frame stack.
    pub fn frames_len(&self) -> usize {
        FRAME_STACK * self.sim.width() * self.sim.height()
    }

    fn code(&self, i: usize) -> u8 {
        if self.sim.is_non_burnable(i) {
            0
        } else {
            self.sim.fire_states()[i] * 3 + self.sim.burn_indices()[i] + 1
        }
    }

    /// Starts an episode: spark at the ignition cell at time 0, helicopter at its start.
    pub fn reset_into(&mut self, seed: u64, frames: &mut [u8]) -> StepInfo {
        self.sim.reset(seed);
        let (ix, iy) = self.ignition;
        // In bounds by construction.
        let _ = self.sim.ignite(ix, iy, 0.0);
        let start = match self.cfg.helicopter_start {
            Some([x, y]) => (x, y),
            None => (70 * self.sim.width() / 240, 30 * self.sim.height() / 160),
        };
        self.heli = (start.0 as i32, start.1 as i32);
        self.steps = 0;
        self.drops = 0;
        self.quenched_total = 0;
        self.water = 0.0;
        self.last_drop_min = f64::NEG_INFINITY;
        self.fire_distance = self.nearest_fire_distance();
        for i in 0..self.cur_code.len() {
            self.cur_code[i] = self.code(i);
        }
        let n = self.cur_code.len();
        for k in 0..FRAME_STACK {
            frames[k * n..(k + 1) * n].copy_from_slice(&self.cur_code);
        }
        for d in &mut self.diffs {
            d.clear();
        }
        self.head = 0;
        let mut scratch = std::mem::take(&mut self.dirty);
        self.sim.take_dirty(&mut scratch);
        self.dirty = scratch;
        self.info(0, 0)
    }

    fn info(&self, new_burnt: u32, quenched_step: u32) -> StepInfo {
        StepInfo {
            step: self.steps,
            sim_time_min: self.sim.time_min(),
            cells_burning: self.sim.cells_burning(),
            cells_burnt: self.sim.cells_burnt(),
            new_burnt,
            quenched_step,
            cells_quenched: self.quenched_total,
            drops: self.drops,
            water_used_gal: self.water,
        }
    }

    fn clamp_heli(&mut self, x: i64, y: i64) {
        let (w, h) = (self.sim.width() as i64, self.sim.height() as i64);
        self.heli = (x.clamp(0, w - 1) as i32, y.clamp(0, h - 1) as i32);
    }

    /// Moves the helicopter directly (clipped to the grid): the rule-based agent's teleport.
    pub fn teleport(&mut self, x: i32, y: i32) {
        self.clamp_heli(i64::from(x), i64::from(y));
    }

    /// Euclidean distance (cells) from the helicopter to the nearest burning cell; `None`
    /// when nothing burns.
    fn nearest_fire_distance(&self) -> Option<f64> {
        let rw = &self.cfg.reward;
        if rw.proximity == 0.0 && rw.approach == 0.0 {
            return None;
        }
        let w = self.sim.width() as i64;
        let (hx, hy) = (i64::from(self.heli.0), i64::from(self.heli.1));
        self.sim
            .burning_cells()
            .iter()
            .map(|&c| {
                let (x, y) = (i64::from(c) % w, i64::from(c) / w);
                (x - hx) * (x - hx) + (y - hy) * (y - hy)
            })
            .min()
            .map(|d2| (d2 as f64).sqrt())
    }

    fn drop_reward(&self, i: usize) -> f64 {
        let rw = &self.cfg.reward;
        if self.sim.is_non_burnable(i)
            && let Some(v) = rw.drop_non_burnable
        {
            return v;
        }
        match self.sim.fire_state(i) {
            FireState::Burning => rw.drop_burning_per_bi * (f64::from(self.sim.burn_indices()[i]) + 1.0),
            FireState::Burnt => rw.drop_burnt,
            FireState::Unburnt => {
                if rw.drop_unburnt_per_nearby == 0.0 && rw.drop_unburnt_isolated == 0.0 {
                    return 0.0;
                }
                let (w, h) = (self.sim.width() as i64, self.sim.height() as i64);
                let r = i64::from(rw.drop_unburnt_window);
                let (cx, cy) = (i64::from(self.heli.0), i64::from(self.heli.1));
                let states = self.sim.fire_states();
                let mut n = 0u32;
                for y in (cy - r).max(0)..=(cy + r).min(h - 1) {
                    for x in (cx - r).max(0)..=(cx + r).min(w - 1) {
                        n += u32::from(states[(y * w + x) as usize] == FireState::Burning as u8);
                    }
                }
                if n > 0 {
                    rw.drop_unburnt_per_nearby * f64::from(n.min(rw.drop_unburnt_nearby_cap))
                } else {
                    rw.drop_unburnt_isolated
                }
            }
        }
    }

    /// One step; the frame stack in `frames` (as left by the previous call) is updated.
    pub fn step_into(
        &mut self,
        action: Action,
        teleport: Option<[i32; 2]>,
        frames: &mut [u8],
    ) -> (f64, bool, bool, StepInfo) {
        if let Some([x, y]) = teleport {
            self.teleport(x, y);
        }
        let speed = i64::from(self.cfg.helicopter_speed_cells);
        let (hx, hy) = (i64::from(self.heli.0), i64::from(self.heli.1));
        let mut drop_reward = 0.0;
        let mut quenched = 0;
        match action {
            Action::North => self.clamp_heli(hx, hy + speed),
            Action::South => self.clamp_heli(hx, hy - speed),
            Action::West => self.clamp_heli(hx - speed, hy),
            Action::East => self.clamp_heli(hx + speed, hy),
            Action::Drop => {
                let now = self.sim.time_min();
                if self.cfg.drop_cooldown_min <= 0.0 || now - self.last_drop_min >= self.cfg.drop_cooldown_min
                {
                    let i = hy as usize * self.sim.width() + hx as usize;
                    drop_reward = self.drop_reward(i);
                    quenched = self.sim.helitack(hx as usize, hy as usize).quenched;
                    self.drops += 1;
                    self.quenched_total += quenched;
                    self.water += self.cfg.water_per_drop_gal;
                    self.last_drop_min = now;
                }
            }
        }
        let prev_burning = self.sim.cells_burning() + quenched;
        let burnt_before = self.sim.cells_burnt();
        self.sim.step();
        self.steps += 1;
        let burning = self.sim.cells_burning();
        let new_burnt = self.sim.cells_burnt() - burnt_before;

        let rw = &self.cfg.reward;
        let mut reward = drop_reward
            + rw.quenched * f64::from(quenched)
            + rw.new_burnt * f64::from(new_burnt)
            + rw.burning * f64::from(burning)
            + rw.burning_reduction * (f64::from(prev_burning) - f64::from(burning))
            + rw.step;
        if rw.proximity != 0.0 || rw.approach != 0.0 {
            let before = self.fire_distance;
            self.fire_distance = self.nearest_fire_distance();
            if let Some(d) = self.fire_distance {
                reward += rw.proximity * (-d / rw.proximity_scale_cells).exp();
                if let Some(b) = before {
                    reward += rw.approach * (b - d);
                }
            }
        }
        reward *= rw.scale;
        if let Some([lo, hi]) = rw.clip {
            reward = reward.clamp(lo, hi);
        }

        self.update_frames(frames);
        let terminated = match self.cfg.termination {
            Termination::FireOut => self
                .sim
                .fire_out_before(f64::from(self.cfg.max_steps) * self.sim.config().dt_min),
            Termination::NoBurningCells => burning == 0,
        };
        let truncated = !terminated && self.steps >= self.cfg.max_steps;
        (reward, terminated, truncated, self.info(new_burnt, quenched))
    }

    fn update_frames(&mut self, frames: &mut [u8]) {
        self.head = (self.head + 1) % FRAME_STACK;
        let mut dirty = std::mem::take(&mut self.dirty);
        self.sim.take_dirty(&mut dirty);
        let mut diff = std::mem::take(&mut self.diffs[self.head]);
        diff.clear();
        for &c in &dirty {
            let code = self.code(c as usize);
            if code != self.cur_code[c as usize] {
                self.cur_code[c as usize] = code;
                diff.push((c, code));
            }
        }
        self.diffs[self.head] = diff;
        self.dirty = dirty;
        // Slot k holds the state k − 3 steps ago: apply the diff of that step.
        let n = self.cur_code.len();
        for k in 0..FRAME_STACK {
            let d = &self.diffs[(self.head + 1 + k) % FRAME_STACK];
            let slot = &mut frames[k * n..(k + 1) * n];
            for &(c, code) in d {
                slot[c as usize] = code;
            }
        }
    }

    pub fn automaton(&self) -> &Automaton {
        &self.sim
    }
    /// Mutable access (fire lines, extra sparks) between steps.
    pub fn automaton_mut(&mut self) -> &mut Automaton {
        &mut self.sim
    }
    pub fn config(&self) -> &EnvConfig {
        &self.cfg
    }
    pub fn helicopter(&self) -> [i32; 2] {
        [self.heli.0, self.heli.1]
    }
    /// Moves the spark cell for the next reset (a fire pool varies ignitions this way while
    /// its entries share one spread-rate cache).
    pub fn set_ignition(&mut self, x: usize, y: usize) -> Result<(), SimError> {
        let (w, h) = (self.sim.width(), self.sim.height());
        if x >= w || y >= h {
            return Err(SimError::OutOfBounds {
                x: x as i64,
                y: y as i64,
                width: w,
                height: h,
            });
        }
        self.ignition = (x, y);
        Ok(())
    }
    /// Grid (width, height).
    pub fn grid_size(&self) -> (usize, usize) {
        (self.sim.width(), self.sim.height())
    }
    pub fn ignition_cell(&self) -> (usize, usize) {
        self.ignition
    }
    /// Whether the helicopter cell is Burning.
    pub fn on_fire(&self) -> bool {
        let i = self.heli.1 as usize * self.sim.width() + self.heli.0 as usize;
        self.sim.fire_state(i) == FireState::Burning
    }
}

/// A single environment with Gymnasium semantics.
pub struct WildfireEnv {
    core: EnvCore,
    frames: Vec<u8>,
}

impl WildfireEnv {
    pub fn new(landscape: &Landscape, cfg: &EnvConfig) -> Result<Self, SimError> {
        let core = EnvCore::new(landscape, cfg)?;
        let frames = vec![0; core.frames_len()];
        let mut env = Self { core, frames };
        env.core.reset_into(0, &mut env.frames);
        Ok(env)
    }

    /// `reset(seed) -> (obs, info)`.
    pub fn reset(&mut self, seed: u64) -> (Observation<'_>, StepInfo) {
        let info = self.core.reset_into(seed, &mut self.frames);
        (self.observation(), info)
    }

    /// `step(action) -> (obs, reward, terminated, truncated, info)`.
    pub fn step(&mut self, action: Action) -> (Observation<'_>, f64, bool, bool, StepInfo) {
        self.step_with_teleport(action, None)
    }

    /// A step that first moves the helicopter to `teleport` (rule-based agent, docs/spec/learning.md §4).
    pub fn step_with_teleport(
        &mut self,
        action: Action,
        teleport: Option<[i32; 2]>,
    ) -> (Observation<'_>, f64, bool, bool, StepInfo) {
        let (r, term, trunc, info) = self.core.step_into(action, teleport, &mut self.frames);
        (self.observation(), r, term, trunc, info)
    }

    pub fn observation(&self) -> Observation<'_> {
        Observation {
            frames: &self.frames,
            width: self.core.sim.width(),
            height: self.core.sim.height(),
            agent: self.core.helicopter(),
            on_fire: self.core.on_fire(),
        }
    }

    pub fn core(&self) -> &EnvCore {
        &self.core
    }
    pub fn core_mut(&mut self) -> &mut EnvCore {
        &mut self.core
    }
    pub fn automaton(&self) -> &Automaton {
        self.core.automaton()
    }
}

/// SplitMix64-style mixing for per-environment episode seeds.
fn mix_seed(base: u64, env: u64, episode: u64) -> u64 {
    let mut z = base ^ env.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ episode.wrapping_mul(0xD1B5_4A32_D192_ED03);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// N environments stepped in parallel (rayon) with automatic reset, drawing each episode's
/// fire from a pool. Observations live in one contiguous buffer `N × FRAME_STACK × H × W` (u8
/// codes), plus `N × 2` positions and `N` on-fire flags. On termination or truncation the
/// environment is reset in the same call (SB3 style): `infos()` holds the finished episode's
/// final info, `terminal_*()` its final observation, and the observation is the new
/// episode's first. Episode k of env i uses seed `mix(seed, i, k)` and fire
/// `mix(seed, i, k) mod pool size`, so the stream is fixed by the seed alone and does not
/// depend on thread scheduling.
pub struct VecEnv {
    /// Fire pool: each entry fixes landscape, weather and ignition cell. All entries share
    /// one grid size.
    fires: Vec<EnvCore>,
    envs: Vec<EnvCore>,
    /// Pool index each environment is playing.
    current: Vec<usize>,
    frames: Vec<u8>,
    agent: Vec<i32>,
    on_fire: Vec<u8>,
    rewards: Vec<f64>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
    infos: Vec<StepInfo>,
    episodes: Vec<u64>,
    terminal_frames: Vec<u8>,
    terminal_agent: Vec<i32>,
    terminal_on_fire: Vec<u8>,
    seed: u64,
    obs_len: usize,
}

/// One environment's mutable slots for a step, grouped so rayon can hand them out per env.
struct Slot<'a> {
    env: &'a mut EnvCore,
    current: &'a mut usize,
    frames: &'a mut [u8],
    terminal_frames: &'a mut [u8],
    terminal_agent: &'a mut [i32],
    terminal_on_fire: &'a mut u8,
    reward: &'a mut f64,
    terminated: &'a mut bool,
    truncated: &'a mut bool,
    info: &'a mut StepInfo,
    episode: &'a mut u64,
}

impl VecEnv {
    pub fn new(landscape: &Landscape, cfg: &EnvConfig, n: usize, seed: u64) -> Result<Self, SimError> {
        Self::with_fires(vec![EnvCore::new(landscape, cfg)?], n, seed)
    }

    /// N environments drawing their episodes from `fires` (see the type's documentation).
    pub fn with_fires(fires: Vec<EnvCore>, n: usize, seed: u64) -> Result<Self, SimError> {
        if n == 0 {
            return Err(SimError::Config("VecEnv needs at least one environment".into()));
        }
        let Some(first) = fires.first() else {
            return Err(SimError::Config("VecEnv needs at least one fire".into()));
        };
        let obs_len = first.frames_len();
        if let Some(f) = fires.iter().find(|f| f.frames_len() != obs_len) {
            return Err(SimError::Config(format!(
                "fires of one VecEnv must share a grid size: {}×{} and {}×{}",
                first.sim.width(),
                first.sim.height(),
                f.sim.width(),
                f.sim.height()
            )));
        }
        let envs = vec![first.clone(); n];
        let mut v = Self {
            fires,
            envs,
            current: vec![0; n],
            frames: vec![0; n * obs_len],
            agent: vec![0; 2 * n],
            on_fire: vec![0; n],
            rewards: vec![0.0; n],
            terminated: vec![false; n],
            truncated: vec![false; n],
            infos: vec![StepInfo::default(); n],
            episodes: vec![0; n],
            terminal_frames: vec![0; n * obs_len],
            terminal_agent: vec![0; 2 * n],
            terminal_on_fire: vec![0; n],
            seed,
            obs_len,
        };
        v.reset(seed);
        Ok(v)
    }

    fn slots(&mut self) -> Vec<Slot<'_>> {
        let obs_len = self.obs_len;
        let mut out = Vec::with_capacity(self.envs.len());
        let iter = self
            .envs
            .iter_mut()
            .zip(self.current.iter_mut())
            .zip(self.frames.chunks_mut(obs_len))
            .zip(self.terminal_frames.chunks_mut(obs_len))
            .zip(self.terminal_agent.chunks_mut(2))
            .zip(self.terminal_on_fire.iter_mut())
            .zip(self.rewards.iter_mut())
            .zip(self.terminated.iter_mut())
            .zip(self.truncated.iter_mut())
            .zip(self.infos.iter_mut())
            .zip(self.episodes.iter_mut());
        for (
            (((((((((env, current), frames), tf), ta), to), reward), terminated), truncated), info),
            episode,
        ) in iter
        {
            out.push(Slot {
                env,
                current,
                frames,
                terminal_frames: tf,
                terminal_agent: ta,
                terminal_on_fire: to,
                reward,
                terminated,
                truncated,
                info,
                episode,
            });
        }
        out
    }

    /// Starts episode `slot.episode` of environment `i` on its fire from the pool.
    fn start_episode(fires: &[EnvCore], seed: u64, i: usize, slot: &mut Slot<'_>) -> StepInfo {
        let episode_seed = mix_seed(seed, i as u64, *slot.episode);
        let fire = (episode_seed % fires.len() as u64) as usize;
        if fire != *slot.current {
            slot.env.clone_from(&fires[fire]);
            *slot.current = fire;
        }
        slot.env.reset_into(episode_seed, slot.frames)
    }

    /// Resets every environment.
    pub fn reset(&mut self, seed: u64) {
        self.seed = seed;
        self.episodes.fill(0);
        let fires = std::mem::take(&mut self.fires);
        self.slots()
            .into_par_iter()
            .enumerate()
            .for_each(|(i, mut slot)| {
                *slot.info = Self::start_episode(&fires, seed, i, &mut slot);
                *slot.terminated = false;
                *slot.truncated = false;
                *slot.reward = 0.0;
            });
        self.fires = fires;
        self.gather();
    }

    fn gather(&mut self) {
        for (i, env) in self.envs.iter().enumerate() {
            let [x, y] = env.helicopter();
            self.agent[2 * i] = x;
            self.agent[2 * i + 1] = y;
            self.on_fire[i] = u8::from(env.on_fire());
        }
    }

    /// Steps every environment with its action.
    pub fn step(&mut self, actions: &[Action]) -> Result<(), SimError> {
        if actions.len() != self.envs.len() {
            return Err(SimError::Config(format!(
                "{} actions for {} environments",
                actions.len(),
                self.envs.len()
            )));
        }
        let seed = self.seed;
        let fires = std::mem::take(&mut self.fires);
        // One task per environment with work stealing: fires differ in size by orders of
        // magnitude, so fixed chunks per thread leave one thread idle behind the big fire.
        self.slots()
            .into_par_iter()
            .with_max_len(1)
            .enumerate()
            .for_each(|(i, mut slot)| {
                let (r, te, tr, inf) = slot.env.step_into(actions[i], None, slot.frames);
                *slot.reward = r;
                *slot.terminated = te;
                *slot.truncated = tr;
                *slot.info = inf;
                if te || tr {
                    slot.terminal_frames.copy_from_slice(slot.frames);
                    let [x, y] = slot.env.helicopter();
                    slot.terminal_agent.copy_from_slice(&[x, y]);
                    *slot.terminal_on_fire = u8::from(slot.env.on_fire());
                    *slot.episode += 1;
                    Self::start_episode(&fires, seed, i, &mut slot);
                }
            });
        self.fires = fires;
        self.gather();
        Ok(())
    }

    /// The final observation of environment `i`'s episode that ended in the last step
    /// (frames, helicopter cell, on-fire flag); meaningful only where `terminated()` or
    /// `truncated()` is set.
    pub fn terminal_observation(&self, i: usize) -> (&[u8], [i32; 2], bool) {
        let n = self.obs_len;
        (
            &self.terminal_frames[i * n..(i + 1) * n],
            [self.terminal_agent[2 * i], self.terminal_agent[2 * i + 1]],
            self.terminal_on_fire[i] != 0,
        )
    }

    /// Episodes environment `i` has finished since the last reset (its current episode's
    /// index).
    pub fn episode_index(&self, i: usize) -> u64 {
        self.episodes[i]
    }

    /// Puts environment `i` into episode `episode` after `actions` (a checkpoint's state:
    /// the episode is replayed, which is exact because it is a function of its seed and
    /// actions). The actions must not end the episode.
    pub fn restore_env(&mut self, i: usize, episode: u64, actions: &[Action]) -> Result<(), SimError> {
        if i >= self.envs.len() {
            return Err(SimError::Config(format!(
                "no environment {i} in a VecEnv of {}",
                self.envs.len()
            )));
        }
        let fires = std::mem::take(&mut self.fires);
        let seed = self.seed;
        let result = {
            let mut slots = self.slots();
            let slot = &mut slots[i];
            *slot.episode = episode;
            *slot.info = Self::start_episode(&fires, seed, i, slot);
            let mut out = Ok(());
            for (k, &a) in actions.iter().enumerate() {
                let (r, te, tr, inf) = slot.env.step_into(a, None, slot.frames);
                *slot.reward = r;
                *slot.info = inf;
                if te || tr {
                    out = Err(SimError::Config(format!(
                        "replaying environment {i}: the episode ended at action {k} of {}",
                        actions.len()
                    )));
                    break;
                }
            }
            *slot.terminated = false;
            *slot.truncated = false;
            out
        };
        self.fires = fires;
        self.gather();
        result
    }

    /// Pool index of the fire environment `i` is playing.
    pub fn fire_index(&self, i: usize) -> usize {
        self.current[i]
    }

    pub fn num_fires(&self) -> usize {
        self.fires.len()
    }

    pub fn num_envs(&self) -> usize {
        self.envs.len()
    }
    /// Frame-stack length per environment (`FRAME_STACK × H × W`).
    pub fn obs_len(&self) -> usize {
        self.obs_len
    }
    /// All observations, `N × FRAME_STACK × H × W`.
    pub fn frames(&self) -> &[u8] {
        &self.frames
    }
    /// Helicopter cells, `N × [x, y]`.
    pub fn agent_positions(&self) -> &[i32] {
        &self.agent
    }
    pub fn on_fire(&self) -> &[u8] {
        &self.on_fire
    }
    pub fn rewards(&self) -> &[f64] {
        &self.rewards
    }
    pub fn terminated(&self) -> &[bool] {
        &self.terminated
    }
    pub fn truncated(&self) -> &[bool] {
        &self.truncated
    }
    pub fn infos(&self) -> &[StepInfo] {
        &self.infos
    }
    pub fn envs(&self) -> &[EnvCore] {
        &self.envs
    }
}
