//! The rollout buffer and GAE(λ) exactly as SB3's `RolloutBuffer` computes them (float32,
//! same operation order), and minibatches over SB3's env-major flattening.

use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use crate::env::{ObsBatch, ObsSpace};

/// `n_steps × n_envs` transitions, stored step-major.
#[derive(Debug, Clone)]
pub struct RolloutBuffer {
    pub n_steps: usize,
    pub n_envs: usize,
    pub space: ObsSpace,
    pub images: Vec<u8>,
    pub vectors: Vec<f32>,
    pub actions: Vec<u8>,
    pub rewards: Vec<f32>,
    pub episode_starts: Vec<f32>,
    pub values: Vec<f32>,
    pub log_probs: Vec<f32>,
    pub advantages: Vec<f32>,
    pub returns: Vec<f32>,
    /// A recurrent policy's state at each step, before that step's episode resets
    /// (`Hidden::to_host` rows, step-major); empty without memory.
    pub hidden: Vec<f32>,
    /// A teacher's action at each step (imitation, [`add_labels`](Self::add_labels));
    /// empty otherwise.
    pub labels: Vec<u8>,
    pos: usize,
}

/// One minibatch, gathered.
#[derive(Debug, Clone)]
pub struct Minibatch {
    pub obs: ObsBatch,
    pub actions: Vec<u8>,
    pub values: Vec<f32>,
    pub log_probs: Vec<f32>,
    pub advantages: Vec<f32>,
    pub returns: Vec<f32>,
    /// A teacher's actions (empty when the buffer has none).
    pub labels: Vec<u8>,
    /// Set by [`RolloutBuffer::gather_sequences`].
    pub sequences: Option<SequenceBatch>,
}

/// The recurrent part of a minibatch of `count` sequences of `steps` steps (rows of the
/// minibatch are time-major: row `k·count + j` is step `k` of sequence `j`).
#[derive(Debug, Clone)]
pub struct SequenceBatch {
    pub count: usize,
    pub steps: usize,
    /// The state at each sequence's first step (`count` rows).
    pub hidden: Vec<f32>,
    /// Episode starts, time-major, 0/1.
    pub starts: Vec<f32>,
}

impl RolloutBuffer {
    pub fn new(n_steps: usize, n_envs: usize, space: ObsSpace) -> Self {
        let n = n_steps * n_envs;
        Self {
            n_steps,
            n_envs,
            space,
            images: vec![0; n * space.image_len()],
            vectors: vec![0.0; n * space.vector],
            actions: vec![0; n],
            rewards: vec![0.0; n],
            episode_starts: vec![0.0; n],
            values: vec![0.0; n],
            log_probs: vec![0.0; n],
            advantages: vec![0.0; n],
            returns: vec![0.0; n],
            hidden: Vec::new(),
            labels: Vec::new(),
            pos: 0,
        }
    }

    pub fn len(&self) -> usize {
        self.n_steps * self.n_envs
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    pub fn is_full(&self) -> bool {
        self.pos == self.n_steps
    }
    pub fn reset(&mut self) {
        self.pos = 0;
    }

    /// Adds one step of all environments (`obs` are the observations the actions were
    /// chosen on; `episode_starts` whether each was an episode's first).
    pub fn add(
        &mut self,
        obs: &ObsBatch,
        actions: &[u8],
        rewards: &[f32],
        episode_starts: &[bool],
        values: &[f32],
        log_probs: &[f32],
    ) {
        let (t, n) = (self.pos, self.n_envs);
        let il = self.space.image_len();
        let vl = self.space.vector;
        self.images[t * n * il..(t + 1) * n * il].copy_from_slice(&obs.image);
        self.vectors[t * n * vl..(t + 1) * n * vl].copy_from_slice(&obs.vector);
        let row = t * n..(t + 1) * n;
        self.actions[row.clone()].copy_from_slice(actions);
        self.rewards[row.clone()].copy_from_slice(rewards);
        for (d, &s) in self.episode_starts[row.clone()].iter_mut().zip(episode_starts) {
            *d = if s { 1.0 } else { 0.0 };
        }
        self.values[row.clone()].copy_from_slice(values);
        self.log_probs[row].copy_from_slice(log_probs);
        self.pos += 1;
    }

    /// GAE(λ) and returns (SB3's `compute_returns_and_advantage`): `last_values` = V of the
    /// observations after the last step, `dones` = whether each env's last step ended its
    /// episode. Float32, in SB3's operation order.
    pub fn compute_returns_and_advantage(
        &mut self,
        last_values: &[f32],
        dones: &[bool],
        gamma: f64,
        lambda: f64,
    ) {
        let n = self.n_envs;
        let g = gamma as f32;
        let gl = (gamma * lambda) as f32;
        let mut last_gae = vec![0.0f32; n];
        for t in (0..self.n_steps).rev() {
            for e in 0..n {
                let (next_non_terminal, next_value) = if t == self.n_steps - 1 {
                    (1.0 - if dones[e] { 1.0 } else { 0.0 }, last_values[e])
                } else {
                    (
                        1.0 - self.episode_starts[(t + 1) * n + e],
                        self.values[(t + 1) * n + e],
                    )
                };
                let i = t * n + e;
                let delta = self.rewards[i] + g * next_value * next_non_terminal - self.values[i];
                last_gae[e] = delta + gl * next_non_terminal * last_gae[e];
                self.advantages[i] = last_gae[e];
            }
        }
        for i in 0..self.len() {
            self.returns[i] = self.advantages[i] + self.values[i];
        }
    }

    /// Stores the recurrent state of the step about to be added (all environments' rows of
    /// `Hidden::to_host`); call before [`add`](Self::add).
    pub fn add_hidden(&mut self, rows: &[f32]) {
        let len = rows.len();
        if self.hidden.len() != self.n_steps * len {
            self.hidden = vec![0.0; self.n_steps * len];
        }
        self.hidden[self.pos * len..(self.pos + 1) * len].copy_from_slice(rows);
    }

    /// Stores a teacher's actions for the step about to be added (all environments); call
    /// before [`add`](Self::add).
    pub fn add_labels(&mut self, actions: &[u8]) {
        let n = self.n_envs;
        if self.labels.len() != self.len() {
            self.labels = vec![0; self.len()];
        }
        self.labels[self.pos * n..(self.pos + 1) * n].copy_from_slice(actions);
    }

    /// A shuffled list of the sequences of `len` steps (each env's rollout cut at multiples
    /// of `len`), as flat env-major indices of their first steps.
    pub fn sequence_permutation(&self, len: usize, rng: &mut ChaCha8Rng) -> Vec<usize> {
        let mut firsts: Vec<usize> = (0..self.n_envs)
            .flat_map(|e| (0..self.n_steps / len.max(1)).map(move |k| e * self.n_steps + k * len))
            .collect();
        firsts.shuffle(rng);
        firsts
    }

    /// Gathers sequences of `len` steps starting at the flat env-major indices `firsts`,
    /// time-major, with the state stored at each first step and the episode-start mask.
    pub fn gather_sequences(&self, firsts: &[usize], len: usize) -> Minibatch {
        let idx: Vec<usize> = (0..len)
            .flat_map(|k| firsts.iter().map(move |&f| f + k))
            .collect();
        let mut mb = self.gather(&idx);
        let row = self.hidden.len() / self.len().max(1);
        let mut hidden = Vec::with_capacity(firsts.len() * row);
        for &f in firsts {
            let (env, step) = (f / self.n_steps, f % self.n_steps);
            let i = step * self.n_envs + env;
            hidden.extend_from_slice(&self.hidden[i * row..(i + 1) * row]);
        }
        let starts = idx
            .iter()
            .map(|&k| self.episode_starts[(k % self.n_steps) * self.n_envs + k / self.n_steps])
            .collect();
        mb.sequences = Some(SequenceBatch {
            count: firsts.len(),
            steps: len,
            hidden,
            starts,
        });
        mb
    }

    /// A new permutation of SB3's flat env-major indices (k = env · n_steps + step).
    pub fn permutation(&self, rng: &mut ChaCha8Rng) -> Vec<usize> {
        let mut idx: Vec<usize> = (0..self.len()).collect();
        idx.shuffle(rng);
        idx
    }

    /// Gathers the transitions of flat env-major indices `idx`.
    pub fn gather(&self, idx: &[usize]) -> Minibatch {
        let mut obs = ObsBatch::new(self.space, idx.len());
        let il = self.space.image_len();
        let vl = self.space.vector;
        let mut mb = Minibatch {
            obs: ObsBatch::new(self.space, 0),
            actions: Vec::with_capacity(idx.len()),
            values: Vec::with_capacity(idx.len()),
            log_probs: Vec::with_capacity(idx.len()),
            advantages: Vec::with_capacity(idx.len()),
            returns: Vec::with_capacity(idx.len()),
            labels: Vec::new(),
            sequences: None,
        };
        for (r, &k) in idx.iter().enumerate() {
            let (env, step) = (k / self.n_steps, k % self.n_steps);
            let i = step * self.n_envs + env;
            obs.image[r * il..(r + 1) * il].copy_from_slice(&self.images[i * il..(i + 1) * il]);
            obs.vector[r * vl..(r + 1) * vl].copy_from_slice(&self.vectors[i * vl..(i + 1) * vl]);
            mb.actions.push(self.actions[i]);
            mb.values.push(self.values[i]);
            mb.log_probs.push(self.log_probs[i]);
            mb.advantages.push(self.advantages[i]);
            mb.returns.push(self.returns[i]);
            if !self.labels.is_empty() {
                mb.labels.push(self.labels[i]);
            }
        }
        mb.obs = obs;
        mb
    }
}
