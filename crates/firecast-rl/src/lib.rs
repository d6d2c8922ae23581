//! Reinforcement learning for FireCast's helitack task, on the PPO engine of `firecast_ppo`:
//!
//! - [`policy`]: actor-critic networks (`mlp`, `compact`, `paper`), the engine's policies;
//! - [`helitack`]: the helitack fires as a batched environment;
//! - [`imitation`]: learning a rule-based teacher's actions before PPO (BC, then DAgger);
//! - [`pool`]: a pool of helitack fires as the Python package's `HelitackVecEnv` takes them;
//! - [`agent`]: a trained policy as a simulator `Policy` (one environment: replays, recordings);
//! - [`run`]: a training run's folders, summary and policies; [`evaluate`] and [`ensemble`]
//!   play them; [`spec`] and [`stage`]: the training spec and the stage kinds.

pub mod agent;
pub mod ensemble;
mod error;
pub mod evaluate;
pub mod helitack;
pub mod imitation;
pub mod policy;
pub mod pool;
pub mod run;
pub mod spec;
pub mod stage;

pub use error::RlError;
/// The torch device type, for callers that do not link `tch` themselves.
pub use tch::Device;

/// Parses `auto`, `cpu`, `cuda` or `cuda:N` (see [`firecast_learn::parse_device`]).
pub fn parse_device(s: &str) -> Result<tch::Device, RlError> {
    firecast_learn::parse_device(s).map_err(|m| RlError::config("device", m))
}
