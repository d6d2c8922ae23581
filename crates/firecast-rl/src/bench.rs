//! `firecast bench ppo`, FireCast's side: CartPole-v1 PPO timed in three phases —
//! environment only, rollout (environment + inference + buffer) and training (rollouts and
//! updates, as SB3's `fps`). SB3's side is `reference/bench_sb3.py`, run by the CLI in the
//! same command with the same settings and one torch thread.

use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use tch::Device;

use crate::RlError;
use crate::cartpole::CartPoleVec;
use crate::env::VecEnvironment;
use crate::policy::{PolicyConfig, PolicyKind};
use crate::ppo::PpoConfig;
use crate::train::{NoSink, Trainer};

/// SB3's side of the benchmark.
pub const SB3_SCRIPT: &str = include_str!("../reference/bench_sb3.py");

/// Steps per second of each phase.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PhaseSpeeds {
    pub env_sps: f64,
    pub rollout_sps: f64,
    pub train_sps: f64,
}

/// FireCast on CartPole with `ppo`'s settings for about `steps` environment steps per phase.
pub fn cartpole(ppo: &PpoConfig, steps: u64, seed: u64) -> Result<PhaseSpeeds, RlError> {
    let n = ppo.n_envs;
    let mut env = CartPoleVec::new(n, seed);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let rounds = (steps / n as u64).max(1);
    let actions: Vec<Vec<u8>> = (0..rounds)
        .map(|_| (0..n).map(|_| rng.random_range(0..2u8)).collect())
        .collect();
    let t = Instant::now();
    for a in &actions {
        env.step(a)?;
    }
    let env_sps = (rounds * n as u64) as f64 / t.elapsed().as_secs_f64();

    let policy = PolicyConfig {
        kind: PolicyKind::Mlp,
        ..PolicyConfig::default()
    };
    let mut cfg = ppo.clone();
    cfg.total_timesteps = steps;
    let mut trainer = Trainer::new(
        cfg.clone(),
        &policy,
        Box::new(CartPoleVec::new(n, seed)),
        seed,
        Device::Cpu,
    )?;
    let rollouts = (steps / ppo.buffer_size() as u64).max(1);
    let t = Instant::now();
    for _ in 0..rollouts {
        trainer.collect_rollout()?;
    }
    let rollout_sps = (rollouts * ppo.buffer_size() as u64) as f64 / t.elapsed().as_secs_f64();

    let mut trainer = Trainer::new(
        cfg,
        &policy,
        Box::new(CartPoleVec::new(n, seed)),
        seed,
        Device::Cpu,
    )?;
    let t = Instant::now();
    trainer.learn(&NoSink, None)?;
    let train_sps = trainer.num_timesteps as f64 / t.elapsed().as_secs_f64();
    Ok(PhaseSpeeds {
        env_sps,
        rollout_sps,
        train_sps,
    })
}
