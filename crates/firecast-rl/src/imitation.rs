//! The helitack's teachers for imitation before PPO (`firecast_ppo::imitation`: behaviour
//! cloning on the teacher's own flights, then DAgger rounds in which the policy flies and the
//! teacher labels what it sees): the fire chaser, reading the helitack observation, and the
//! rollout search over it, which plans with the training fires themselves.

use firecast_ppo::env::{ObsBatch, ObsSpace, VecEnvironment};
use firecast_ppo::imitation::Teacher;
use firecast_sim::agents::{FireChaser, Policy as _};
use firecast_sim::env::{FRAME_STACK, Observation};
use firecast_sim::{RolloutSearch, SearchConfig};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::RlError;
use crate::helitack::HelitackVec;

/// Which teacher.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TeacherKind {
    /// The fire chaser: fly to the nearest flames, drop when they are within 4 cells.
    Chaser,
    /// The rollout search over the chaser (`teacher: {search: {horizon: 40}}`): before each
    /// label it plays every action on a copy of the training fire and the chaser after it.
    Search(SearchConfig),
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

/// The rollout search labelling each environment of a [`HelitackVec`] from its own fire
/// (one search per environment, in parallel). It needs the fires, not only what they look
/// like: the spec admits teachers only with `env.kind: helitack`, whose trainer labels
/// through [`Teacher::act_in`] on a [`HelitackVec`]; anything else is a programming error
/// and panics rather than labelling silently with another teacher.
pub struct SearchTeacher {
    cfg: SearchConfig,
    searches: Vec<RolloutSearch>,
}

impl SearchTeacher {
    pub fn new(space: ObsSpace, cfg: SearchConfig) -> Result<Self, RlError> {
        // The same observation check as the chaser's.
        ChaserTeacher::new(space)?;
        Ok(Self {
            cfg,
            searches: Vec::new(),
        })
    }
}

const SEARCH_NEEDS_FIRES: &str =
    "the search teacher plans on the fires themselves: label through `act_in` on a `HelitackVec`";

impl Teacher for SearchTeacher {
    fn act(&mut self, _obs: &ObsBatch, _actions: &mut [u8]) {
        panic!("{SEARCH_NEEDS_FIRES}");
    }

    fn act_in(&mut self, env: &dyn VecEnvironment, obs: &ObsBatch, actions: &mut [u8]) {
        let Some(vec) = env.as_any().and_then(|a| a.downcast_ref::<HelitackVec>()) else {
            panic!("{SEARCH_NEEDS_FIRES}");
        };
        let inner = vec.inner();
        let n = inner.num_envs().min(obs.n);
        while self.searches.len() < n {
            let k = self.searches.len() as u64;
            self.searches.push(RolloutSearch::over_chaser(self.cfg.stream(k)));
        }
        let (l, frames, envs) = (inner.obs_len(), inner.frames(), inner.envs());
        self.searches[..n]
            .par_iter_mut()
            .zip(actions[..n].par_iter_mut())
            .enumerate()
            .for_each(|(i, (search, a))| {
                let core = &envs[i];
                let (width, height) = core.grid_size();
                let view = Observation {
                    frames: &frames[i * l..(i + 1) * l],
                    width,
                    height,
                    agent: core.helicopter(),
                    on_fire: core.on_fire(),
                };
                *a = search.decide(core, &view).action as u8;
            });
    }
}

/// The teacher a spec names, for an environment with observations `space`.
pub fn teacher(kind: TeacherKind, space: ObsSpace) -> Result<Box<dyn Teacher>, RlError> {
    match kind {
        TeacherKind::Chaser => Ok(Box::new(ChaserTeacher::new(space)?)),
        TeacherKind::Search(cfg) => Ok(Box::new(SearchTeacher::new(space, cfg)?)),
    }
}
