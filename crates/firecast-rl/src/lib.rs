//! Reinforcement learning for FireCast: PPO with Stable-Baselines3's semantics in `tch`.
//!
//! - [`ppo`]: hyper-parameters and presets (`sb3`, `paper`, `websocket`, `cartpole_zoo`),
//!   the minibatch loss, PyTorch's Adam and gradient-norm clipping;
//! - [`buffer`]: the rollout buffer and GAE(λ) as SB3 computes them;
//! - [`normalize`]: `VecNormalize` (observation and return statistics);
//! - [`policy`]: actor-critic networks (`mlp`, `compact`, `paper`);
//! - [`train`]: the learning loop, checkpoints and exact resumption;
//! - [`env`]: the batched-environment interface, with [`cartpole`] (the correctness gate);
//! - [`imitation`]: learning a rule-based teacher's actions before PPO (BC, then DAgger);
//! - [`pool`]: a pool of helitack fires as the Python package's `HelitackVecEnv` takes them;
//! - [`agent`]: a trained policy as a simulator `Policy` (one environment: replays, recordings).

pub mod agent;
pub mod buffer;
pub mod cartpole;
pub mod ensemble;
pub mod env;
mod error;
pub mod evaluate;
pub mod helitack;
pub mod imitation;
pub mod normalize;
pub mod policy;
pub mod pool;
pub mod ppo;
pub mod rng;
pub mod run;
pub mod spec;
pub mod stage;
pub mod train;

pub use error::RlError;
/// The torch device type, for callers that do not link `tch` themselves.
pub use tch::Device;

/// Parses `auto`, `cpu`, `cuda` or `cuda:N` (see [`firecast_learn::parse_device`]).
pub fn parse_device(s: &str) -> Result<tch::Device, RlError> {
    firecast_learn::parse_device(s).map_err(|m| RlError::config("device", m))
}
