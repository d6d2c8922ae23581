//! Imitation before PPO: the policy learns a rule-based teacher's actions (behaviour
//! cloning on the teacher's own flights, then DAgger rounds in which the policy flies and the
//! teacher labels what it sees, every round's steps kept; Ross et al., 2011), and its value
//! head learns the returns of whoever flew. PPO then starts from that policy instead of from
//! random weights. The dataset is held in memory: one rollout of observations per round.

use firecast_sim::agents::{FireChaser, Policy as _};
use firecast_sim::env::{FRAME_STACK, Observation};
use serde::{Deserialize, Serialize};

use crate::RlError;
use crate::env::{ObsBatch, ObsSpace};

/// A rule that labels observations with actions.
pub trait Teacher: Send {
    /// Actions for every row of `obs` (image part as the environment gives it; the vector
    /// part may be normalised).
    fn act(&mut self, obs: &ObsBatch, actions: &mut [u8]);
}

/// Which teacher.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TeacherKind {
    /// The fire chaser: fly to the nearest flames, drop when they are within 4 cells.
    Chaser,
}

/// `imitation:` in a training spec.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImitationConfig {
    pub teacher: TeacherKind,
    /// Rounds of one rollout each (`n_steps × n_envs` steps, counted apart from PPO's
    /// `total_timesteps`).
    #[serde(default = "default_rounds")]
    pub rounds: u32,
    /// The first this many rounds are flown by the teacher (behaviour cloning); in the rest
    /// the policy flies, sampling its actions, and the teacher only labels (DAgger).
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

impl ImitationConfig {
    /// Checks the settings (`rollout`: steps per round).
    pub fn validate(&self, rollout: usize) -> Result<(), RlError> {
        let bad = |k: &str, m: String| Err(RlError::config(format!("imitation.{k}"), m));
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

/// The fire chaser reading the helitack observation: the newest frame and the helicopter
/// channel (value > 0 on its cell) of the image part.
pub struct ChaserTeacher {
    chaser: FireChaser,
    width: usize,
    height: usize,
}

impl ChaserTeacher {
    /// For the helitack observation space (image `[FRAME_STACK + 1, h, w]`).
    pub fn new(space: ObsSpace) -> Result<Self, RlError> {
        match space.image {
            Some([c, h, w]) if c == FRAME_STACK + 1 => Ok(Self {
                chaser: FireChaser::default(),
                width: w,
                height: h,
            }),
            _ => Err(RlError::config(
                "imitation.teacher",
                format!("the chaser reads helitack observations, not {space:?}"),
            )),
        }
    }
}

impl Teacher for ChaserTeacher {
    fn act(&mut self, obs: &ObsBatch, actions: &mut [u8]) {
        let n = self.width * self.height;
        for (i, a) in actions.iter_mut().enumerate().take(obs.n) {
            let image = obs.image_row(i);
            let heli = &image[FRAME_STACK * n..];
            let cell = heli.iter().position(|&v| v > 0).unwrap_or(0);
            let view = Observation {
                frames: &image[..FRAME_STACK * n],
                width: self.width,
                height: self.height,
                agent: [(cell % self.width) as i32, (cell / self.width) as i32],
                // The chaser does not read it.
                on_fire: false,
            };
            *a = self.chaser.act(&view).action as u8;
        }
    }
}

/// Imitation and kickstarting train on single steps: a recurrent policy is refused.
pub fn single_steps(recurrent: bool) -> Result<(), RlError> {
    if recurrent {
        return Err(RlError::config(
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

/// The teacher a spec names, for an environment with observations `space`.
pub fn teacher(kind: TeacherKind, space: ObsSpace) -> Result<Box<dyn Teacher>, RlError> {
    match kind {
        TeacherKind::Chaser => Ok(Box::new(ChaserTeacher::new(space)?)),
    }
}
