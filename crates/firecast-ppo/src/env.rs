//! The batched-environment interface the trainer drives: same-step autoreset with an
//! explicit terminal observation (SB3's `VecEnv` semantics), observations split into an
//! optional u8 image part (cell codes, channel-first) and an f32 vector part.

use crate::PpoError;

/// Shapes of one observation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ObsSpace {
    /// (channels, height, width) of the u8 image part, if any.
    pub image: Option<[usize; 3]>,
    /// Length of the f32 vector part.
    pub vector: usize,
}

impl ObsSpace {
    pub fn image_len(&self) -> usize {
        self.image.map_or(0, |[c, h, w]| c * h * w)
    }
}

/// Observations of `n` environments, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct ObsBatch {
    pub space: ObsSpace,
    pub n: usize,
    pub image: Vec<u8>,
    pub vector: Vec<f32>,
}

impl ObsBatch {
    pub fn new(space: ObsSpace, n: usize) -> Self {
        Self {
            space,
            n,
            image: vec![0; n * space.image_len()],
            vector: vec![0.0; n * space.vector],
        }
    }
    pub fn image_row(&self, i: usize) -> &[u8] {
        let l = self.space.image_len();
        &self.image[i * l..(i + 1) * l]
    }
    pub fn vector_row(&self, i: usize) -> &[f32] {
        let l = self.space.vector;
        &self.vector[i * l..(i + 1) * l]
    }
    pub fn image_row_mut(&mut self, i: usize) -> &mut [u8] {
        let l = self.space.image_len();
        &mut self.image[i * l..(i + 1) * l]
    }
    pub fn vector_row_mut(&mut self, i: usize) -> &mut [f32] {
        let l = self.space.vector;
        &mut self.vector[i * l..(i + 1) * l]
    }
    /// Copies row `from` of `src` into row `to` of `self`.
    pub fn copy_row(&mut self, to: usize, src: &ObsBatch, from: usize) {
        self.image_row_mut(to).copy_from_slice(src.image_row(from));
        self.vector_row_mut(to).copy_from_slice(src.vector_row(from));
    }
}

/// N environments stepped together. After `step`, environments whose episode ended have
/// already been reset: `observe` gives the new episode's first observation and
/// `terminal_observation` the finished episode's last.
pub trait VecEnvironment: Send {
    fn num_envs(&self) -> usize;
    fn space(&self) -> ObsSpace;
    fn num_actions(&self) -> usize;
    /// Resets every environment; the stream of episodes is a function of `seed`.
    fn reset(&mut self, seed: u64);
    fn step(&mut self, actions: &[u8]) -> Result<(), PpoError>;
    /// Current observations into `out` (n = num_envs).
    fn observe(&self, out: &mut ObsBatch);
    /// Final observation of env `i`'s episode that ended in the last step, into row `row`.
    fn terminal_observation(&self, i: usize, out: &mut ObsBatch, row: usize);
    fn rewards(&self) -> &[f64];
    fn terminated(&self) -> &[bool];
    fn truncated(&self) -> &[bool];
    /// Extra per-episode numbers for env `i` when its episode ended in the last step
    /// (an application's own measures of an episode); logged as `rollout/<name>`.
    fn episode_extras(&self, _i: usize) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
    /// The environment as itself, for a teacher that plans with the application's
    /// simulator ([`Teacher::act_in`](crate::imitation::Teacher::act_in)).
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        None
    }
    /// Everything needed to continue the exact same stream later (checkpoints).
    fn snapshot(&self) -> serde_json::Value;
    /// Restores a [`snapshot`](Self::snapshot) taken from an environment built the same way.
    fn restore(&mut self, snapshot: &serde_json::Value) -> Result<(), PpoError>;
}
