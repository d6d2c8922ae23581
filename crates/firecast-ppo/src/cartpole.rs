//! CartPole-v1 with Gymnasium 1.x semantics (physics, thresholds, +1 per step including the
//! terminating one, truncation at 500 steps), the trainer's correctness gate.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::PpoError;
use crate::env::{ObsBatch, ObsSpace, VecEnvironment};

const GRAVITY: f64 = 9.8;
const MASS_CART: f64 = 1.0;
const MASS_POLE: f64 = 0.1;
const TOTAL_MASS: f64 = MASS_CART + MASS_POLE;
const HALF_LENGTH: f64 = 0.5;
const POLE_MASS_LENGTH: f64 = MASS_POLE * HALF_LENGTH;
const FORCE_MAG: f64 = 10.0;
const TAU: f64 = 0.02;
const THETA_LIMIT: f64 = 12.0 * 2.0 * std::f64::consts::PI / 360.0;
const X_LIMIT: f64 = 2.4;
/// `max_episode_steps` of CartPole-v1.
pub const MAX_STEPS: u32 = 500;

/// One CartPole.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct CartPoleState {
    state: [f64; 4],
    steps: u32,
    rng: crate::rng::RngState,
}

#[derive(Debug, Clone)]
pub struct CartPole {
    state: [f64; 4],
    steps: u32,
    rng: ChaCha8Rng,
}

impl CartPole {
    pub fn new(seed: u64) -> Self {
        let mut c = Self {
            state: [0.0; 4],
            steps: 0,
            rng: ChaCha8Rng::seed_from_u64(seed),
        };
        c.reset();
        c
    }

    /// Starts an episode: each state variable uniform in [−0.05, 0.05).
    pub fn reset(&mut self) -> [f32; 4] {
        for s in &mut self.state {
            *s = self.rng.random_range(-0.05..0.05);
        }
        self.steps = 0;
        self.obs()
    }

    pub fn obs(&self) -> [f32; 4] {
        self.state.map(|v| v as f32)
    }

    /// Euler step (Gymnasium's default integrator): (obs, reward, terminated, truncated).
    pub fn step(&mut self, push_right: bool) -> ([f32; 4], f64, bool, bool) {
        let [x, x_dot, theta, theta_dot] = self.state;
        let force = if push_right { FORCE_MAG } else { -FORCE_MAG };
        let (sin, cos) = theta.sin_cos();
        let temp = (force + POLE_MASS_LENGTH * theta_dot * theta_dot * sin) / TOTAL_MASS;
        let theta_acc =
            (GRAVITY * sin - cos * temp) / (HALF_LENGTH * (4.0 / 3.0 - MASS_POLE * cos * cos / TOTAL_MASS));
        let x_acc = temp - POLE_MASS_LENGTH * theta_acc * cos / TOTAL_MASS;
        self.state = [
            x + TAU * x_dot,
            x_dot + TAU * x_acc,
            theta + TAU * theta_dot,
            theta_dot + TAU * theta_acc,
        ];
        self.steps += 1;
        let [x, _, theta, _] = self.state;
        let terminated = !(-X_LIMIT..=X_LIMIT).contains(&x) || !(-THETA_LIMIT..=THETA_LIMIT).contains(&theta);
        let truncated = !terminated && self.steps >= MAX_STEPS;
        (self.obs(), 1.0, terminated, truncated)
    }
}

/// N CartPoles with same-step autoreset. Env i is seeded `seed + i` (as SB3's `make_vec_env`).
#[derive(Debug, Clone)]
pub struct CartPoleVec {
    envs: Vec<CartPole>,
    obs: Vec<[f32; 4]>,
    terminal: Vec<[f32; 4]>,
    rewards: Vec<f64>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
}

impl CartPoleVec {
    pub fn new(n: usize, seed: u64) -> Self {
        let mut v = Self {
            envs: Vec::new(),
            obs: vec![[0.0; 4]; n],
            terminal: vec![[0.0; 4]; n],
            rewards: vec![0.0; n],
            terminated: vec![false; n],
            truncated: vec![false; n],
        };
        v.reset(seed);
        v
    }
}

impl VecEnvironment for CartPoleVec {
    fn num_envs(&self) -> usize {
        self.obs.len()
    }
    fn space(&self) -> ObsSpace {
        ObsSpace {
            image: None,
            vector: 4,
        }
    }
    fn num_actions(&self) -> usize {
        2
    }
    fn reset(&mut self, seed: u64) {
        let n = self.obs.len();
        self.envs = (0..n as u64)
            .map(|i| CartPole::new(seed.wrapping_add(i)))
            .collect();
        for (o, e) in self.obs.iter_mut().zip(&self.envs) {
            *o = e.obs();
        }
        self.terminated.fill(false);
        self.truncated.fill(false);
        self.rewards.fill(0.0);
    }
    fn step(&mut self, actions: &[u8]) -> Result<(), PpoError> {
        if actions.len() != self.envs.len() {
            return Err(PpoError::config(
                "actions",
                format!("{} actions for {} environments", actions.len(), self.envs.len()),
            ));
        }
        for (i, env) in self.envs.iter_mut().enumerate() {
            if actions[i] > 1 {
                return Err(PpoError::config(
                    "actions",
                    format!("CartPole action {} is not 0 or 1", actions[i]),
                ));
            }
            let (o, r, te, tr) = env.step(actions[i] == 1);
            self.rewards[i] = r;
            self.terminated[i] = te;
            self.truncated[i] = tr;
            if te || tr {
                self.terminal[i] = o;
                self.obs[i] = env.reset();
            } else {
                self.obs[i] = o;
            }
        }
        Ok(())
    }
    fn observe(&self, out: &mut ObsBatch) {
        for (i, o) in self.obs.iter().enumerate() {
            out.vector_row_mut(i).copy_from_slice(o);
        }
    }
    fn terminal_observation(&self, i: usize, out: &mut ObsBatch, row: usize) {
        out.vector_row_mut(row).copy_from_slice(&self.terminal[i]);
    }
    fn rewards(&self) -> &[f64] {
        &self.rewards
    }
    fn terminated(&self) -> &[bool] {
        &self.terminated
    }
    fn truncated(&self) -> &[bool] {
        &self.truncated
    }
    fn snapshot(&self) -> serde_json::Value {
        let states: Vec<CartPoleState> = self
            .envs
            .iter()
            .map(|e| CartPoleState {
                state: e.state,
                steps: e.steps,
                rng: crate::rng::RngState::of(&e.rng),
            })
            .collect();
        serde_json::json!({ "envs": states })
    }
    fn restore(&mut self, snapshot: &serde_json::Value) -> Result<(), PpoError> {
        let states: Vec<CartPoleState> = snapshot
            .get("envs")
            .cloned()
            .map(serde_json::from_value)
            .transpose()
            .map_err(|e| PpoError::config("env", format!("bad CartPole snapshot: {e}")))?
            .unwrap_or_default();
        if states.len() != self.envs.len() {
            return Err(PpoError::config(
                "env.n_envs",
                format!(
                    "the snapshot has {} environments, this run {}",
                    states.len(),
                    self.envs.len()
                ),
            ));
        }
        for ((env, s), o) in self.envs.iter_mut().zip(states).zip(&mut self.obs) {
            env.state = s.state;
            env.steps = s.steps;
            env.rng = s.rng.restore();
            *o = env.obs();
        }
        Ok(())
    }
}
