//! `firecast bench ppo`, FireCast's side: PPO timed in four phases — environment only
//! (step + observation), rollout (environment + inference + buffer), updates only (PPO's
//! epochs over a collected rollout) and training (rollouts and updates, as SB3's `fps`) — on (a) CartPole-v1 with the MLP policy, (b) a small
//! helitack fire pool with the compact policy, and (c) the FireCastRL training map with the
//! compact policy. SB3's sides are `reference/bench_sb3.py` (a) and
//! `reference/bench_sb3_helitack.py` (b, c), run by the CLI in the same command with the same
//! settings and torch threads.

use std::time::Instant;

use firecast_landscape::{Landscape, procedural};
use firecast_sim::EnvConfig;
use firecast_sim::env::EnvCore;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use tch::Device;

use crate::RlError;
use crate::cartpole::CartPoleVec;
use crate::env::{ObsBatch, VecEnvironment};
use crate::helitack::{HelitackVec, reward_profile};
use crate::policy::{PolicyConfig, PolicyKind};
use crate::ppo::PpoConfig;
use crate::train::{NoSink, Trainer};

/// SB3's side of (a).
pub const SB3_SCRIPT: &str = include_str!("../reference/bench_sb3.py");
/// SB3's side of (b) and (c): the compact extractor re-stated as an SB3 features extractor.
pub const SB3_HELITACK_SCRIPT: &str = include_str!("../reference/bench_sb3_helitack.py");
/// Run ahead of either SB3 script: FLOPs per environment step of the network (torch's
/// counter) and the machine's float32 sgemm rate, the yardstick for the goals.
pub const NETWORK_WORK: &str = include_str!("../reference/network_work.py");

/// Steps per second of each phase.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PhaseSpeeds {
    pub env_sps: f64,
    pub rollout_sps: f64,
    /// PPO's epochs over a collected rollout alone (no early stop): the network's forward,
    /// backward and Adam steps, with no environment in the loop.
    pub update_sps: f64,
    pub train_sps: f64,
}

/// One side's result: its speeds and the policy's trainable parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BenchRun {
    #[serde(flatten)]
    pub speeds: PhaseSpeeds,
    pub parameters: i64,
}

/// The three phases on environments made by `make_env`, each for about `steps` steps, with
/// the policy on `device`.
pub fn phases(
    make_env: &dyn Fn() -> Result<Box<dyn VecEnvironment>, RlError>,
    ppo: &PpoConfig,
    policy: &PolicyConfig,
    steps: u64,
    seed: u64,
    device: Device,
) -> Result<BenchRun, RlError> {
    let n = ppo.n_envs;
    let mut env = make_env()?;
    env.reset(seed);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let rounds = (steps / n as u64).max(1);
    let num_actions = env.num_actions() as u8;
    let actions: Vec<Vec<u8>> = (0..rounds)
        .map(|_| (0..n).map(|_| rng.random_range(0..num_actions)).collect())
        .collect();
    let mut obs = ObsBatch::new(env.space(), n);
    let t = Instant::now();
    for a in &actions {
        env.step(a)?;
        // SB3's VecEnv hands back observations every step: count them here too.
        env.observe(&mut obs);
    }
    let env_sps = (rounds * n as u64) as f64 / t.elapsed().as_secs_f64();
    drop(env);

    let mut cfg = ppo.clone();
    cfg.total_timesteps = steps;
    let mut trainer = Trainer::new(cfg.clone(), policy, make_env()?, seed, device)?;
    let parameters = trainer.policy.parameter_count();
    let rollouts = (steps / ppo.buffer_size() as u64).max(1);
    let t = Instant::now();
    for _ in 0..rollouts {
        trainer.collect_rollout()?;
    }
    let rollout_sps = (rollouts * ppo.buffer_size() as u64) as f64 / t.elapsed().as_secs_f64();
    // Updates only, over the last rollout, as many as training runs; the approx-KL early stop
    // is off so both sides do every epoch.
    trainer.ppo.target_kl = None;
    let t = Instant::now();
    for _ in 0..rollouts {
        trainer.train(1.0)?;
    }
    let update_sps = (rollouts * ppo.buffer_size() as u64) as f64 / t.elapsed().as_secs_f64();
    drop(trainer);

    let mut trainer = Trainer::new(cfg, policy, make_env()?, seed, device)?;
    let t = Instant::now();
    trainer.learn(&NoSink, None)?;
    let train_sps = trainer.num_timesteps as f64 / t.elapsed().as_secs_f64();
    Ok(BenchRun {
        speeds: PhaseSpeeds {
            env_sps,
            rollout_sps,
            update_sps,
            train_sps,
        },
        parameters,
    })
}

/// (a) CartPole with the MLP policy and `ppo`'s settings.
pub fn cartpole(ppo: &PpoConfig, steps: u64, seed: u64) -> Result<BenchRun, RlError> {
    let policy = PolicyConfig {
        kind: PolicyKind::Mlp,
        ..PolicyConfig::default()
    };
    let n = ppo.n_envs;
    let make =
        move || -> Result<Box<dyn VecEnvironment>, RlError> { Ok(Box::new(CartPoleVec::new(n, seed))) };
    phases(&make, ppo, &policy, steps, seed, Device::Cpu)
}

/// (b)'s fire pool, built the way `firecast.HelitackVecEnv` builds its pool (every landscape
/// × every ignition cell, one environment configuration), so both sides play the same fires.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HelitackPool {
    /// Seeds of procedural landscapes.
    pub landscape_seeds: Vec<u64>,
    pub width: usize,
    pub height: usize,
    /// Ignition cells [x, y], burnable on every landscape.
    pub ignitions: Vec<[usize; 2]>,
    /// `EnvConfig` keys, as the Python package takes them (`config=`).
    pub config: serde_json::Value,
    /// Reward profile.
    pub profile: String,
}

impl HelitackPool {
    /// The demo's scale (experiments/rl/demo-fires.yaml): 96 × 64 procedural landscapes 1–4,
    /// 400-step episodes, a light west wind and 11 % 1-h moisture (the middle of the demo's
    /// ranges), two ignition cells burnable on all four.
    pub fn demo_scale() -> Result<Self, RlError> {
        Self::sized(96, 64)
    }

    /// The demo's fires on `width` × `height` landscapes (240 × 160 is FireCastRL's map), the
    /// ignition candidates scaled from the 96 × 64 ones.
    pub fn sized(width: usize, height: usize) -> Result<Self, RlError> {
        let mut pool = Self {
            landscape_seeds: vec![1, 2, 3, 4],
            width,
            height,
            ignitions: Vec::new(),
            config: serde_json::json!({
                "max_steps": 400,
                "sim": {
                    "wind": {"speed_mph": 2.0, "from_direction_deg": 270.0},
                    "kernel": {"rothermel": {"moisture": {
                        "dead_1h_frac": 0.11, "dead_10h_frac": 0.12, "dead_100h_frac": 0.13,
                        "live_herb_frac": 0.6, "live_woody_frac": 0.9,
                    }}},
                },
            }),
            profile: "p2".into(),
        };
        let cfg = pool.env_config()?;
        let cores: Vec<EnvCore> = pool
            .landscapes()?
            .iter()
            .map(|l| EnvCore::new(l, &cfg))
            .collect::<Result<_, _>>()?;
        let candidates = [
            [48, 32],
            [40, 28],
            [56, 36],
            [36, 40],
            [60, 24],
            [30, 30],
            [66, 34],
            [44, 20],
            [52, 44],
            [34, 26],
            [62, 42],
            [28, 36],
            [70, 28],
        ];
        pool.ignitions = candidates
            .into_iter()
            .map(|[x, y]| [x * width / 96, y * height / 64])
            .filter(|&[x, y]| {
                cores
                    .iter()
                    .all(|c| !c.automaton().is_non_burnable(y * pool.width + x))
            })
            .take(2)
            .collect();
        if pool.ignitions.is_empty() {
            return Err(RlError::config(
                "bench.ignitions",
                "no candidate ignition cell is burnable on every bench landscape",
            ));
        }
        Ok(pool)
    }

    fn landscapes(&self) -> Result<Vec<Landscape>, RlError> {
        self.landscape_seeds
            .iter()
            .map(|&seed| {
                Ok(procedural::generate(&procedural::ProceduralOptions {
                    width: self.width,
                    height: self.height,
                    ..procedural::ProceduralOptions::with_seed(seed)
                })?)
            })
            .collect()
    }

    /// The environment configuration both sides use.
    pub fn env_config(&self) -> Result<EnvConfig, RlError> {
        let mut cfg: EnvConfig = serde_json::from_value(self.config.clone())
            .map_err(|e| RlError::config("bench.config", e.to_string()))?;
        cfg.reward = reward_profile(&self.profile)?;
        Ok(cfg)
    }

    /// The pool in `HelitackVecEnv`'s order: landscape-major, then ignition.
    pub fn fires(&self) -> Result<Vec<EnvCore>, RlError> {
        let cfg = self.env_config()?;
        let mut fires = Vec::new();
        for land in self.landscapes()? {
            let core = EnvCore::new(&land, &cfg)?;
            for &[x, y] in &self.ignitions {
                let mut c = core.clone();
                c.set_ignition(x, y)?;
                fires.push(c);
            }
        }
        Ok(fires)
    }

    /// `HelitackVecEnv`'s keyword arguments for this pool.
    pub fn python_kwargs(&self) -> serde_json::Value {
        serde_json::json!({
            "landscapes": self
                .landscape_seeds
                .iter()
                .map(|s| serde_json::json!({"procedural": {"seed": s, "width": self.width, "height": self.height}}))
                .collect::<Vec<_>>(),
            "ignitions": self.ignitions,
            "config": self.config,
            "profile": self.profile,
        })
    }
}

/// (b) and (c): the helitack environment over `fires` with `policy` (the compact one) on
/// `device`.
pub fn helitack(
    fires: &[EnvCore],
    ppo: &PpoConfig,
    policy: &PolicyConfig,
    steps: u64,
    seed: u64,
    device: Device,
) -> Result<BenchRun, RlError> {
    let n = ppo.n_envs;
    let make = move || -> Result<Box<dyn VecEnvironment>, RlError> {
        Ok(Box::new(HelitackVec::new(fires.to_vec(), n, seed)?))
    };
    phases(&make, ppo, policy, steps, seed, device)
}

/// (c)'s FireCast side: the FireCastRL training map with `cfg` (the P2 parity settings).
pub fn firecastrl_map(landscape: &Landscape, cfg: &EnvConfig) -> Result<Vec<EnvCore>, RlError> {
    Ok(vec![EnvCore::new(landscape, cfg)?])
}
