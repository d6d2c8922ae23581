//! Imitation before PPO: the policy learns a rule-based teacher's actions (behaviour
//! cloning on the teacher's own episodes, then DAgger rounds in which the policy acts and the
//! teacher labels what it sees, every round's steps kept; Ross et al., 2011), and its value
//! head learns the returns of whoever acted ([`Trainer::imitate`](crate::train::Trainer::imitate));
//! kickstarting keeps the teacher's labels in PPO's loss. The teachers are the application's.

use serde::{Deserialize, Serialize};

use crate::PpoError;
use crate::env::{ObsBatch, VecEnvironment};

/// A rule that labels observations with actions.
pub trait Teacher: Send {
    /// Actions for every row of `obs` (image part as the environment gives it; the vector
    /// part may be normalised).
    fn act(&mut self, obs: &ObsBatch, actions: &mut [u8]);
    /// Actions with the environments that gave `obs` at hand, for a teacher that plans with
    /// them (it downcasts [`VecEnvironment::as_any`]); the others read `obs` alone.
    fn act_in(&mut self, _env: &dyn VecEnvironment, obs: &ObsBatch, actions: &mut [u8]) {
        self.act(obs, actions);
    }
}

/// `imitation:` in a training spec.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImitationConfig<K> {
    /// Which teacher (the application names its own).
    pub teacher: K,
    /// Rounds of one rollout each (`n_steps × n_envs` steps, counted apart from PPO's
    /// `total_timesteps`).
    #[serde(default = "default_rounds")]
    pub rounds: u32,
    /// The first this many rounds are played by the teacher (behaviour cloning); in the rest
    /// the policy plays, sampling its actions, and the teacher only labels (DAgger).
    #[serde(default = "default_teacher_rounds")]
    pub teacher_rounds: u32,
    /// Adam steps after each round, on minibatches drawn from every round so far.
    #[serde(default = "default_updates")]
    pub updates: u32,
    #[serde(default = "default_batch_size")]
    pub batch_size: usize,
    #[serde(default = "default_learning_rate")]
    pub learning_rate: f64,
    /// Kickstarting (Schmitt et al., 2018): during PPO the teacher keeps labelling the
    /// policy's own rollouts and each minibatch's loss gains this × (1 − progress) × the
    /// cross-entropy to its labels, so PPO starts next to the teacher and is free of it at
    /// the end. 0: plain PPO after the imitation rounds.
    #[serde(default)]
    pub kickstart: f64,
}

fn default_rounds() -> u32 {
    8
}
fn default_teacher_rounds() -> u32 {
    1
}
fn default_updates() -> u32 {
    100
}
fn default_batch_size() -> usize {
    64
}
fn default_learning_rate() -> f64 {
    3e-4
}

impl<K> ImitationConfig<K> {
    /// Checks the settings (`rollout`: steps per round).
    pub fn validate(&self, rollout: usize) -> Result<(), PpoError> {
        let bad = |k: &str, m: String| Err(PpoError::config(format!("imitation.{k}"), m));
        if self.rounds == 0 {
            return bad("rounds", "must be at least 1".into());
        }
        if self.teacher_rounds > self.rounds {
            return bad(
                "teacher_rounds",
                format!("{} is more than the {} rounds", self.teacher_rounds, self.rounds),
            );
        }
        if self.updates == 0 {
            return bad("updates", "must be at least 1".into());
        }
        if self.batch_size == 0 || self.batch_size > rollout {
            return bad(
                "batch_size",
                format!(
                    "{} is not in 1..={rollout} (the steps of one round)",
                    self.batch_size
                ),
            );
        }
        if !(self.learning_rate.is_finite() && self.learning_rate > 0.0) {
            return bad(
                "learning_rate",
                format!("{} is not a positive number", self.learning_rate),
            );
        }
        if !(self.kickstart.is_finite() && self.kickstart >= 0.0) {
            return bad(
                "kickstart",
                format!("{} is not a non-negative number", self.kickstart),
            );
        }
        Ok(())
    }
}

/// Imitation and kickstarting train on single steps: a recurrent policy is refused.
pub fn single_steps(recurrent: bool) -> Result<(), PpoError> {
    if recurrent {
        return Err(PpoError::config(
            "imitation",
            "imitation trains on single steps: use `memory: frames`",
        ));
    }
    Ok(())
}

/// The mean cross-entropy of `logits` (n × actions) to a teacher's actions, and the rows
/// whose most likely action is the teacher's.
pub fn cross_entropy(logits: &tch::Tensor, labels: &[u8]) -> (tch::Tensor, usize) {
    use tch::Kind;
    let labels = tch::Tensor::from_slice(labels)
        .to_kind(Kind::Int64)
        .to_device(logits.device());
    let ce = -logits
        .log_softmax(-1, Kind::Float)
        .gather(1, &labels.unsqueeze(1), false)
        .mean(Kind::Float);
    let hits = tch::no_grad(|| logits.argmax(-1, false).eq_tensor(&labels).sum(Kind::Int64));
    (ce, i64::try_from(hits).unwrap_or(0) as usize)
}
