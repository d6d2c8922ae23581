//! The helitack's teachers for imitation before PPO (`firecast_ppo::imitation`: behaviour
//! cloning on the teacher's own flights, then DAgger rounds in which the policy flies and the
//! teacher labels what it sees): the fire chaser, reading the helitack observation.

use firecast_ppo::env::{ObsBatch, ObsSpace};
use firecast_ppo::imitation::Teacher;
use firecast_sim::agents::{FireChaser, Policy as _};
use firecast_sim::env::{FRAME_STACK, Observation};
use serde::{Deserialize, Serialize};

use crate::RlError;

/// Which teacher.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TeacherKind {
    /// The fire chaser: fly to the nearest flames, drop when they are within 4 cells.
    Chaser,
}

/// `imitation:` in a training spec, naming one of this crate's teachers.
pub type ImitationConfig = firecast_ppo::imitation::ImitationConfig<TeacherKind>;

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

/// The teacher a spec names, for an environment with observations `space`.
pub fn teacher(kind: TeacherKind, space: ObsSpace) -> Result<Box<dyn Teacher>, RlError> {
    match kind {
        TeacherKind::Chaser => Ok(Box::new(ChaserTeacher::new(space)?)),
    }
}
