//! `firecast bench ppo`, FireCast's side: PPO timed in four phases — environment only
//! (step + observation), rollout (environment + inference + buffer), updates only (PPO's
//! epochs over a collected rollout) and training (rollouts and updates, as SB3's `fps`) — on (a) CartPole-v1 with the MLP policy, (b) a small
//! helitack fire pool with the compact policy, and (c) the FireCastRL training map with the
//! compact policy. SB3's sides are `crates/firecast-rl/reference/bench_sb3.py` (a) and
//! `crates/firecast-rl/reference/bench_sb3_helitack.py` (b, c) — kept beside the policies they
//! re-state — run by [`super`] in the same command with the same settings and torch threads.

use std::time::Instant;

use firecast_landscape::Landscape;
use firecast_ppo::cartpole::CartPoleVec;
use firecast_ppo::env::{ObsBatch, VecEnvironment};
use firecast_ppo::ppo::PpoConfig;
use firecast_ppo::train::{NoSink, Trainer};
use firecast_rl::RlError;
use firecast_rl::helitack::HelitackVec;
use firecast_rl::policy::{PolicyConfig, PolicyKind};
use firecast_sim::EnvConfig;
use firecast_sim::env::EnvCore;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use tch::Device;

/// SB3's side of (a).
pub const SB3_SCRIPT: &str = include_str!("../../../firecast-rl/reference/bench_sb3.py");
/// SB3's side of (b) and (c): the compact extractor re-stated as an SB3 features extractor.
pub const SB3_HELITACK_SCRIPT: &str = include_str!("../../../firecast-rl/reference/bench_sb3_helitack.py");
/// Run ahead of either SB3 script: FLOPs per environment step of the network (torch's
/// counter) and the machine's float32 sgemm rate, the yardstick for the goals.
pub const NETWORK_WORK: &str = include_str!("../../../firecast-rl/reference/network_work.py");

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
