//! PPO with Stable-Baselines3's semantics in `tch`, apart from any application:
//!
//! - [`ppo`]: hyper-parameters and presets (`sb3`, `paper`, `websocket`, `cartpole_zoo`),
//!   the minibatch loss, PyTorch's Adam and gradient-norm clipping;
//! - [`buffer`]: the rollout buffer and GAE(λ) as SB3 computes them;
//! - [`normalize`]: `VecNormalize` (observation and return statistics);
//! - [`policy`]: what the loss asks of a policy ([`policy::ActorCritic`]), observations as
//!   tensors, a recurrent state, SB3's MLP blocks;
//! - [`train`]: the learning loop (SB3's `learn`), imitation of a teacher before it
//!   ([`imitation`]), checkpoints and exact resumption;
//! - [`env`]: the batched-environment interface, with [`cartpole`] (the correctness gate);
//! - [`rng`]: a random stream whose position a checkpoint saves.

pub mod buffer;
pub mod cartpole;
pub mod env;
mod error;
pub mod imitation;
pub mod normalize;
pub mod policy;
pub mod ppo;
pub mod rng;
pub mod train;

pub use error::PpoError;
