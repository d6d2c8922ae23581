//! Decision-time search: a helicopter that plans with the simulator (Bertsekas's rollout
//! algorithm). Before every move it plays each of the five actions on a copy of the fire,
//! follows a base policy (the chaser by default) for the rest of a short horizon, and takes
//! the action whose copy ends with the fewest cells burnt and burning. One step of policy
//! improvement over the base policy: where no action does better, it does what the base
//! policy does.
//!
//! The copies do not see the fire's own random draws: each decision re-seeds them from the
//! search's seed and the step, the same seed for all five actions (common random numbers,
//! so the actions are compared on the same future).

use crate::agents::{Decision, EpisodeContext, FireChaser, Policy};
use crate::env::{Action, EnvCore, Observation};

/// Settings of a [`RolloutSearch`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SearchConfig {
    /// Steps each copy plays: the action, then the base policy.
    pub horizon: u32,
    /// A burning cell at the horizon counts this many burnt cells (it has yet to spread).
    pub burning_weight: f64,
    /// Another action replaces the base policy's only when its copy scores better by more
    /// than this (cells): near-ties keep the base action, which makes the search's choices
    /// easier for a student to learn from what it sees.
    pub min_gain: f64,
    /// Seeds the copies' random draws.
    pub seed: u64,
}

impl Default for SearchConfig {
    fn default() -> Self {
        Self {
            horizon: 40,
            burning_weight: 2.0,
            min_gain: 5.0,
            seed: 0,
        }
    }
}

impl SearchConfig {
    /// The settings of the `k`-th of several searches run side by side: its own seed.
    pub fn stream(self, k: u64) -> Self {
        Self {
            seed: self.seed ^ k.wrapping_add(1).wrapping_mul(0xD6E8_FEB8_6659_FD93),
            ..self
        }
    }
}

/// The rollout planner over a base policy `B`.
#[derive(Debug, Clone)]
pub struct RolloutSearch<B = FireChaser> {
    base: B,
    cfg: SearchConfig,
    decisions: u64,
    /// Frames of the copy being played (reused between rollouts).
    scratch: Vec<u8>,
}

impl RolloutSearch<FireChaser> {
    /// Search over the chaser.
    pub fn over_chaser(cfg: SearchConfig) -> Self {
        Self::new(FireChaser::default(), cfg)
    }
}

impl<B: Policy + Clone> RolloutSearch<B> {
    pub fn new(base: B, cfg: SearchConfig) -> Self {
        Self {
            base,
            cfg,
            decisions: 0,
            scratch: Vec::new(),
        }
    }

    /// The score of `first` played now and the base policy after it: cells burnt plus
    /// weighted cells burning when the horizon (or the episode) ends. Lower is better.
    fn rollout(&mut self, env: &EnvCore, frames: &[u8], first: Action, seed: u64) -> f64 {
        let mut copy = env.clone();
        copy.automaton_mut().reseed(seed);
        self.scratch.clear();
        self.scratch.extend_from_slice(frames);
        let mut base = self.base.clone();
        let (w, h) = copy.grid_size();
        let mut action = first;
        for _ in 0..self.cfg.horizon.max(1) {
            let (_, terminated, truncated, _) = copy.step_into(action, None, &mut self.scratch);
            if terminated || truncated {
                break;
            }
            let obs = Observation {
                frames: &self.scratch,
                width: w,
                height: h,
                agent: copy.helicopter(),
                on_fire: copy.on_fire(),
            };
            action = base.act(&obs).action;
        }
        let sim = copy.automaton();
        f64::from(sim.cells_burnt()) + self.cfg.burning_weight * f64::from(sim.cells_burning())
    }
}

impl<B: Policy + Clone> Policy for RolloutSearch<B> {
    fn reset(&mut self, ctx: &EpisodeContext) {
        self.base.reset(ctx);
        self.decisions = 0;
    }

    /// Without the simulator there is nothing to search: the base policy's action.
    fn act(&mut self, obs: &Observation<'_>) -> Decision {
        self.base.act(obs)
    }

    fn decide(&mut self, env: &EnvCore, obs: &Observation<'_>) -> Decision {
        let proposal = self.base.act(obs).action;
        let seed = self.cfg.seed ^ self.decisions.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        self.decisions += 1;
        let kept = self.rollout(env, obs.frames, proposal, seed);
        let mut best = (kept, proposal);
        for a in Action::ALL {
            if a == proposal {
                continue;
            }
            let score = self.rollout(env, obs.frames, a, seed);
            // Strictly better only: ties keep the base policy's action.
            if score < best.0 {
                best = (score, a);
            }
        }
        if kept - best.0 > self.cfg.min_gain {
            best.1.into()
        } else {
            proposal.into()
        }
    }
}
