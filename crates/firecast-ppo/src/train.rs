//! The PPO training loop (SB3's `learn` / `collect_rollouts` / `train`), checkpoints and
//! exact resumption.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use serde::{Deserialize, Serialize};
use tch::{Device, Kind, Tensor};

use crate::PpoError;
use crate::buffer::{Minibatch, RolloutBuffer};
use crate::env::{ObsBatch, ObsSpace, VecEnvironment};
use crate::imitation::{ImitationConfig, Teacher};
use crate::normalize::VecNormalize;
use crate::policy::{ActorCritic, PolicySpec};
use crate::policy::{Hidden, ObsTensors, SEQUENCE};
use crate::ppo::{Adam, LossSettings, PpoConfig, PpoMinibatch, Sequences, log_prob_entropy, ppo_losses};
use crate::rng::RngState;

/// Finished episodes remembered for `rollout/ep_*_mean` (SB3's `stats_window_size`).
const STATS_WINDOW: usize = 100;

/// A finished training episode (raw rewards, before normalisation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRecord {
    pub reward: f64,
    pub length: u64,
    #[serde(default)]
    pub extras: Vec<(String, f64)>,
}

/// Receives per-update metrics (SB3's logger keys) and progress.
pub trait TrainSink {
    fn update(&self, _timesteps: u64, _metrics: &[(String, f64)]) {}
    fn progress(&self, _timesteps: u64, _total: u64, _fps: f64, _ep_rew_mean: f64) {}
    /// A checkpoint was written.
    fn checkpoint(&self, _dir: &Path, _timesteps: u64) {}
    /// Metrics of one imitation round, after `imitation_timesteps` steps of it.
    fn imitation(&self, _imitation_timesteps: u64, _metrics: &[(String, f64)]) {}
    /// Asked after every imitation round and every update: `true` ends training there (a
    /// benchmark's wall-clock budget). [`Trainer::learn_until`] then returns short of its
    /// budget, without a last checkpoint, and [`Trainer::imitate`] skips its remaining rounds.
    fn should_stop(&self) -> bool {
        false
    }
}

/// A sink that ignores everything.
pub struct NoSink;
impl TrainSink for NoSink {}

/// What a checkpoint stores besides tensors.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct TrainerState<C> {
    format: u32,
    policy: C,
    space: ObsSpace,
    num_actions: usize,
    ppo: PpoConfig,
    seed: u64,
    num_timesteps: u64,
    n_updates: u64,
    iterations: u64,
    adam_step: u64,
    rng: RngState,
    normalize: VecNormalize,
    last_episode_starts: Vec<bool>,
    running: Vec<(f64, u64)>,
    episodes: VecDeque<EpisodeRecord>,
    env: serde_json::Value,
    /// A recurrent policy's state for the next step (`Hidden::to_host`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    hidden: Option<Vec<f32>>,
    /// Environment steps spent imitating a teacher before PPO (not in `num_timesteps`).
    #[serde(default, skip_serializing_if = "is_zero")]
    imitation_timesteps: u64,
}

/// For `skip_serializing_if`: a count that is zero is left out, so keys and files written
/// before the field existed stay the same.
pub fn is_zero<T: Default + PartialEq>(v: &T) -> bool {
    *v == T::default()
}

const CHECKPOINT_FORMAT: u32 = 1;
pub const POLICY_FILE: &str = "policy.safetensors";
const OPTIMIZER_FILE: &str = "optimizer.safetensors";
const STATE_FILE: &str = "trainer.json";

/// A PPO learner bound to its environments.
pub struct Trainer<C: PolicySpec> {
    pub ppo: PpoConfig,
    pub policy: C::Policy,
    adam: Adam,
    /// Names of `adam.params`, sorted (checkpoint keys).
    param_names: Vec<String>,
    env: Box<dyn VecEnvironment>,
    pub normalize: VecNormalize,
    buffer: RolloutBuffer,
    rng: ChaCha8Rng,
    seed: u64,
    pub num_timesteps: u64,
    /// SB3's `_n_updates`: epochs run.
    pub n_updates: u64,
    pub iterations: u64,
    last_obs: ObsBatch,
    last_episode_starts: Vec<bool>,
    running: Vec<(f64, u64)>,
    pub episodes: VecDeque<EpisodeRecord>,
    /// Every finished episode of this process (not only the window).
    pub all_episodes: Vec<EpisodeRecord>,
    last_checkpoint: Option<PathBuf>,
    /// A recurrent policy's state for the next step of each environment (before the reset
    /// of those whose episode starts there).
    hidden: Option<Hidden>,
    /// Environment steps spent imitating a teacher before PPO (not in `num_timesteps`).
    pub imitation_timesteps: u64,
    /// A teacher labelling PPO's rollouts and the initial weight of the cross-entropy to its
    /// labels ([`Trainer::kickstart`]).
    kickstart: Option<(Box<dyn Teacher>, f64)>,
}

impl<C: PolicySpec> Trainer<C> {
    /// A fresh learner: torch is seeded with `seed` before the weights are drawn, the
    /// environments are reset with `seed`, and minibatches and actions come from a ChaCha8
    /// stream seeded with `seed`.
    pub fn new(
        ppo: PpoConfig,
        policy: &C,
        mut env: Box<dyn VecEnvironment>,
        seed: u64,
        device: Device,
    ) -> Result<Self, PpoError> {
        ppo.validate()?;
        if env.num_envs() != ppo.n_envs {
            return Err(PpoError::config(
                "ppo.n_envs",
                format!("{} but the environment has {}", ppo.n_envs, env.num_envs()),
            ));
        }
        let space = env.space();
        let num_actions = env.num_actions();
        let policy = firecast_learn::with_seed(seed, || policy.build(space, num_actions, device))?;
        check_sequences(&policy, &ppo)?;
        let hidden = policy.initial_hidden(ppo.n_envs);
        let (param_names, params) = trainable(&policy);
        let adam = Adam::new(params, ppo.adam_eps);
        let normalize = VecNormalize::new(ppo.normalize.clone(), ppo.gamma, space.vector, ppo.n_envs);
        env.reset(seed);
        let mut t = Self {
            buffer: RolloutBuffer::new(ppo.n_steps, ppo.n_envs, space),
            last_obs: ObsBatch::new(space, ppo.n_envs),
            last_episode_starts: vec![true; ppo.n_envs],
            running: vec![(0.0, 0); ppo.n_envs],
            rng: ChaCha8Rng::seed_from_u64(seed),
            ppo,
            policy,
            adam,
            param_names,
            env,
            normalize,
            seed,
            num_timesteps: 0,
            n_updates: 0,
            iterations: 0,
            episodes: VecDeque::new(),
            all_episodes: Vec::new(),
            last_checkpoint: None,
            hidden,
            imitation_timesteps: 0,
            kickstart: None,
        };
        t.env.observe(&mut t.last_obs);
        t.normalize.observe(&mut t.last_obs.vector);
        Ok(t)
    }

    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Trains until `ppo.total_timesteps` (SB3 `learn`: whole rollouts, so it may overshoot
    /// by less than one rollout). With `checkpoint_every` (iterations) and a folder, a
    /// checkpoint `step-<timesteps>` is written there every so often and at the end.
    pub fn learn(&mut self, sink: &dyn TrainSink, checkpoints: Option<(&Path, u64)>) -> Result<(), PpoError> {
        self.learn_until(sink, checkpoints, None)
    }

    /// As [`learn`](Self::learn), stopping (with a checkpoint) once `stop_after` steps are
    /// done: the run is interrupted, not shortened — schedules still run over
    /// `total_timesteps`, so a resume continues exactly where a straight run would be.
    pub fn learn_until(
        &mut self,
        sink: &dyn TrainSink,
        checkpoints: Option<(&Path, u64)>,
        stop_after: Option<u64>,
    ) -> Result<(), PpoError> {
        let total = self.ppo.total_timesteps;
        let stop = stop_after.unwrap_or(total).min(total);
        let started = Instant::now();
        let start_steps = self.num_timesteps;
        while self.num_timesteps < stop {
            let mut kickstart = self.kickstart.take();
            let teacher: Option<(&mut dyn Teacher, bool)> = match &mut kickstart {
                Some((t, _)) => Some((t.as_mut(), false)),
                None => None,
            };
            let collected = self.collect_rollouts(teacher);
            self.kickstart = kickstart;
            collected?;
            self.iterations += 1;
            // SB3's `1 − steps / total`, stopped at the budget's end: a last rollout that
            // overshoots the budget would make it negative, and a linear schedule (RL-Zoo's
            // `lin_`) then a negative learning rate and clip range (gradient ascent). The
            // update runs at the schedules' end values instead (docs/guides/rl.md).
            let progress_remaining = (1.0 - self.num_timesteps as f64 / total as f64).max(0.0);
            let mut metrics = self.train(progress_remaining)?;
            let elapsed = started.elapsed().as_secs_f64().max(1e-9);
            let fps = (self.num_timesteps - start_steps) as f64 / elapsed;
            let ep_rew = self.ep_mean(|e| e.reward);
            metrics.push(("rollout/ep_rew_mean".into(), ep_rew));
            metrics.push(("rollout/ep_len_mean".into(), self.ep_mean(|e| e.length as f64)));
            let mut extra_names: Vec<String> = Vec::new();
            for e in &self.episodes {
                for (k, _) in &e.extras {
                    if !extra_names.contains(k) {
                        extra_names.push(k.clone());
                    }
                }
            }
            for k in extra_names {
                let v = self.ep_mean(|e| {
                    e.extras
                        .iter()
                        .find(|(n, _)| *n == k)
                        .map_or(f64::NAN, |(_, v)| *v)
                });
                metrics.push((format!("rollout/{k}"), v));
            }
            metrics.push(("time/fps".into(), fps));
            metrics.push(("time/iterations".into(), self.iterations as f64));
            metrics.push(("time/total_timesteps".into(), self.num_timesteps as f64));
            sink.update(self.num_timesteps, &metrics);
            sink.progress(self.num_timesteps, total, fps, ep_rew);
            if let Some((dir, every)) = checkpoints {
                let last = self.num_timesteps >= stop;
                if last || (every > 0 && self.iterations.is_multiple_of(every)) {
                    let path = dir.join(format!("step-{:09}", self.num_timesteps));
                    self.save(&path)?;
                    sink.checkpoint(&path, self.num_timesteps);
                }
            }
            if sink.should_stop() {
                break;
            }
        }
        Ok(())
    }

    fn ep_mean(&self, f: impl Fn(&EpisodeRecord) -> f64) -> f64 {
        let vals: Vec<f64> = self.episodes.iter().map(f).filter(|v| v.is_finite()).collect();
        mean_or_nan(&vals)
    }

    /// Actions for a batch of (already normalised) observations: sampled from the policy
    /// with this trainer's stream, or greedy.
    fn act(&mut self, obs: &ObsBatch, deterministic: bool) -> (Vec<u8>, Vec<f32>, Vec<f32>) {
        let device = self.policy.device();
        let (logits, values) = match &self.hidden {
            None => tch::no_grad(|| self.policy.forward(&ObsTensors::from_batch(obs, device), false)),
            Some(hidden) => {
                let starts = as_f32(&self.last_episode_starts);
                let (logits, values, next) = tch::no_grad(|| {
                    self.policy
                        .sequence(&ObsTensors::from_batch(obs, device), hidden, &starts, 1, false)
                });
                self.hidden = Some(next);
                (logits, values)
            }
        };
        let to_cpu = |t: Tensor| {
            if device == Device::Cpu {
                t
            } else {
                t.to_device(Device::Cpu)
            }
        };
        let logp_all = to_cpu(logits.log_softmax(-1, Kind::Float));
        let a = self.policy.num_actions();
        let logp: Vec<f32> = Vec::<f32>::try_from(logp_all.flatten(0, -1)).unwrap_or_default();
        let values: Vec<f32> = Vec::<f32>::try_from(to_cpu(values)).unwrap_or_default();
        let mut actions = Vec::with_capacity(obs.n);
        let mut chosen = Vec::with_capacity(obs.n);
        for row in logp.chunks(a) {
            let k = if deterministic {
                argmax(row)
            } else {
                sample(row, self.rng.random::<f64>())
            };
            actions.push(k as u8);
            chosen.push(row[k]);
        }
        (actions, values, chosen)
    }

    /// Runs one rollout (SB3's `collect_rollouts`: actions, time-limit bootstrap, GAE) and
    /// returns the filled buffer, without training on it. For golden tests against SB3's
    /// rollout buffer; [`learn`](Self::learn) does this and then updates the policy.
    pub fn collect_rollout(&mut self) -> Result<&RolloutBuffer, PpoError> {
        self.collect_rollouts(None)?;
        Ok(&self.buffer)
    }

    /// With a teacher, its actions label every step (and replace the policy's when `flies`).
    fn collect_rollouts(&mut self, mut teacher: Option<(&mut dyn Teacher, bool)>) -> Result<(), PpoError> {
        self.buffer.reset();
        let n = self.ppo.n_envs;
        let mut new_obs = ObsBatch::new(self.env.space(), n);
        let mut dones = vec![false; n];
        let mut labels = vec![0u8; n];
        while !self.buffer.is_full() {
            // Moved out (not cloned) while `act` borrows the trainer; the buffers rotate.
            let obs = std::mem::replace(&mut self.last_obs, ObsBatch::new(self.env.space(), 0));
            // The state this step starts from (before the resets of new episodes).
            if let Some(h) = &self.hidden {
                self.buffer.add_hidden(&h.to_host());
            }
            let (mut actions, values, log_probs) = self.act(&obs, false);
            if let Some((teacher, flies)) = teacher.as_mut() {
                teacher.act_in(self.env.as_ref(), &obs, &mut labels);
                self.buffer.add_labels(&labels);
                if *flies {
                    actions.copy_from_slice(&labels);
                }
            }
            if let Err(e) = self.env.step(&actions) {
                self.last_obs = obs;
                return Err(e);
            }
            self.num_timesteps += n as u64;
            let raw = self.env.rewards().to_vec();
            for (i, d) in dones.iter_mut().enumerate() {
                *d = self.env.terminated()[i] || self.env.truncated()[i];
            }
            self.env.observe(&mut new_obs);
            self.normalize.observe(&mut new_obs.vector);
            let mut rewards = self.normalize.rewards(&raw, &dones);
            // Episode bookkeeping on raw rewards (Monitor).
            for i in 0..n {
                self.running[i].0 += raw[i];
                self.running[i].1 += 1;
                if dones[i] {
                    let (reward, length) = self.running[i];
                    let extras = self
                        .env
                        .episode_extras(i)
                        .into_iter()
                        .map(|(k, v)| (k.to_string(), v))
                        .collect();
                    let rec = EpisodeRecord {
                        reward,
                        length,
                        extras,
                    };
                    self.all_episodes.push(rec.clone());
                    self.episodes.push_back(rec);
                    if self.episodes.len() > STATS_WINDOW {
                        self.episodes.pop_front();
                    }
                    self.running[i] = (0.0, 0);
                }
            }
            // Time-limit bootstrap: r += γ·V(terminal observation) where truncated.
            let truncated: Vec<usize> = (0..n)
                .filter(|&i| self.env.truncated()[i] && !self.env.terminated()[i])
                .collect();
            if !truncated.is_empty() {
                let mut term = ObsBatch::new(self.env.space(), truncated.len());
                for (row, &i) in truncated.iter().enumerate() {
                    self.env.terminal_observation(i, &mut term, row);
                }
                self.normalize.normalize_obs(&mut term.vector);
                let device = self.policy.device();
                let term = ObsTensors::from_batch(&term, device);
                let v = tch::no_grad(|| match &self.hidden {
                    None => self.policy.values(&term),
                    // One more step from the state after the episode's last.
                    Some(h) => {
                        let starts = vec![0.0; truncated.len()];
                        self.policy
                            .sequence(&term, &h.select(&truncated), &starts, 1, false)
                            .1
                    }
                });
                let v: Vec<f32> = Vec::<f32>::try_from(v.to_device(Device::Cpu)).unwrap_or_default();
                for (row, &i) in truncated.iter().enumerate() {
                    rewards[i] += self.ppo.gamma as f32 * v[row];
                }
            }
            self.buffer.add(
                &obs,
                &actions,
                &rewards,
                &self.last_episode_starts,
                &values,
                &log_probs,
            );
            self.last_obs = std::mem::replace(&mut new_obs, obs);
            self.last_episode_starts.copy_from_slice(&dones);
        }
        let device = self.policy.device();
        let last = ObsTensors::from_batch(&self.last_obs, device);
        let last_values = tch::no_grad(|| match &self.hidden {
            None => self.policy.values(&last),
            Some(h) => {
                let starts = as_f32(&self.last_episode_starts);
                self.policy.sequence(&last, h, &starts, 1, false).1
            }
        });
        let last_values: Vec<f32> =
            Vec::<f32>::try_from(last_values.to_device(Device::Cpu)).unwrap_or_default();
        self.buffer
            .compute_returns_and_advantage(&last_values, &dones, self.ppo.gamma, self.ppo.gae_lambda);
        Ok(())
    }

    fn minibatch(&self, mb: Minibatch) -> PpoMinibatch {
        let device = self.policy.device();
        PpoMinibatch {
            sequences: mb.sequences.map(|s| Sequences {
                hidden: Hidden::from_host(&s.hidden, s.count, device),
                starts: s.starts,
                steps: s.steps,
            }),
            obs: ObsTensors::from_batch(&mb.obs, device),
            actions: mb.actions,
            old_values: mb.values,
            old_log_probs: mb.log_probs,
            advantages: mb.advantages,
            returns: mb.returns,
        }
    }

    /// Kickstarting: from now on `teacher` labels every rollout and each PPO minibatch's loss
    /// gains `weight` × (1 − progress) × the cross-entropy to the labels (not part of the
    /// checkpoint: set it again after a resume, as an application's run does from its spec).
    pub fn kickstart(&mut self, teacher: Box<dyn Teacher>, weight: f64) -> Result<(), PpoError> {
        crate::imitation::single_steps(self.policy.is_recurrent())?;
        self.kickstart = (weight > 0.0).then_some((teacher, weight));
        Ok(())
    }

    /// Learns a teacher's actions before PPO ([`crate::imitation`]): `rounds` rollouts, the
    /// first `teacher_rounds` flown by the teacher, the rest by the policy (sampling) with the
    /// teacher's labels. Every labelled step joins one dataset (DAgger's aggregation); after
    /// each round, `updates` Adam steps on minibatches drawn from all of it minimise the
    /// cross-entropy on the labels plus `vf_coef` × the squared error to each step's GAE
    /// return. The steps count in `imitation_timesteps`, not in PPO's budget; the
    /// normalisers keep what they saw; the optimiser's moments and the training-episode
    /// window are cleared for PPO. Metrics (`imitation/*`) go to [`TrainSink::imitation`].
    pub fn imitate<K>(
        &mut self,
        cfg: &ImitationConfig<K>,
        teacher: &mut dyn Teacher,
        sink: &dyn TrainSink,
    ) -> Result<(), PpoError> {
        crate::imitation::single_steps(self.policy.is_recurrent())?;
        cfg.validate(self.buffer.len())?;
        let ppo_timesteps = self.num_timesteps;
        let device = self.policy.device();
        let space = self.env.space();
        let mut data = Demonstrations::new(space);
        let mut order: Vec<usize> = Vec::new();
        for round in 0..cfg.rounds {
            let flies = round < cfg.teacher_rounds;
            let finished = self.all_episodes.len();
            self.collect_rollouts(Some((&mut *teacher, flies)))?;
            self.imitation_timesteps += self.num_timesteps - ppo_timesteps;
            self.num_timesteps = ppo_timesteps;
            // How often the flying policy already did what the teacher would have.
            let agreement = if flies {
                f64::NAN
            } else {
                let same = (self.buffer.actions.iter())
                    .zip(&self.buffer.labels)
                    .filter(|(a, l)| a == l)
                    .count();
                same as f64 / self.buffer.len() as f64
            };
            data.extend(&self.buffer);
            let (mut ce, mut vl, mut hits, mut seen) = (0.0, 0.0, 0usize, 0usize);
            for _ in 0..cfg.updates {
                let mut rows = Vec::with_capacity(cfg.batch_size);
                while rows.len() < cfg.batch_size {
                    if order.is_empty() {
                        order = (0..data.len()).collect();
                        rand::seq::SliceRandom::shuffle(order.as_mut_slice(), &mut self.rng);
                    }
                    rows.extend(order.pop());
                }
                let (obs, labels, returns) = data.gather(&rows);
                let returns = Tensor::from_slice(&returns).to_device(device);
                let (logits, values) = self.policy.forward(&ObsTensors::from_batch(&obs, device), true);
                let (cross_entropy, agree) = crate::imitation::cross_entropy(&logits, &labels);
                let value_loss = (&returns - &values).square().mean(Kind::Float);
                let loss = &cross_entropy + &value_loss * self.ppo.vf_coef;
                if !f64::try_from(&loss).is_ok_and(f64::is_finite) {
                    return Err(PpoError::NonFinite {
                        update: u64::from(round),
                        what: "the imitation loss".into(),
                        checkpoint: self.last_checkpoint.clone(),
                    });
                }
                let n = rows.len();
                ce += f64::try_from(&cross_entropy).unwrap_or(f64::NAN) * n as f64;
                vl += f64::try_from(&value_loss).unwrap_or(f64::NAN) * n as f64;
                hits += agree;
                seen += n;
                self.adam.gradients(&loss)?;
                self.adam.clip_grad_norm(self.ppo.max_grad_norm);
                self.adam.step(cfg.learning_rate);
            }
            let returns: Vec<f64> = self.all_episodes[finished..].iter().map(|e| e.reward).collect();
            let ep_rew = mean_or_nan(&returns);
            let seen = seen.max(1) as f64;
            sink.imitation(
                self.imitation_timesteps,
                &[
                    ("imitation/round".into(), f64::from(round + 1)),
                    ("imitation/teacher_flies".into(), if flies { 1.0 } else { 0.0 }),
                    ("imitation/agreement".into(), agreement),
                    ("imitation/cross_entropy".into(), ce / seen),
                    ("imitation/accuracy".into(), hits as f64 / seen),
                    ("imitation/value_loss".into(), vl / seen),
                    ("imitation/ep_rew_mean".into(), ep_rew),
                    ("imitation/episodes".into(), returns.len() as f64),
                    ("imitation/dataset".into(), data.len() as f64),
                ],
            );
            if sink.should_stop() {
                break;
            }
        }
        self.adam.reset_moments();
        self.episodes.clear();
        self.all_episodes.clear();
        self.buffer.labels.clear();
        Ok(())
    }

    /// One update over the buffer (SB3 `train`); returns the `train/*` metrics. Public so a
    /// benchmark can time the updates alone over a collected rollout.
    pub fn train(&mut self, progress_remaining: f64) -> Result<Vec<(String, f64)>, PpoError> {
        let lr = self.ppo.learning_rate.at(progress_remaining);
        let clip = self.ppo.clip_range.at(progress_remaining);
        let settings = LossSettings {
            clip_range: clip,
            clip_range_vf: self.ppo.clip_range_vf,
            ent_coef: self.ppo.ent_coef,
            vf_coef: self.ppo.vf_coef,
            normalize_advantage: self.ppo.normalize_advantage,
        };
        let (mut pg, mut vl, mut ent, mut cf) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut approx_kls = Vec::new();
        // Kickstarting's weight now (0 without a teacher) and its cross-entropies.
        let kick = (self.kickstart.as_ref()).map_or(0.0, |(_, w)| w * progress_remaining.max(0.0));
        let mut kick_ce = Vec::new();
        let mut last_loss = f64::NAN;
        let mut continue_training = true;
        for _epoch in 0..self.ppo.n_epochs {
            approx_kls.clear();
            // Without memory: SB3's shuffled transitions. With an LSTM: shuffled sequences of
            // SEQUENCE steps, `batch_size / SEQUENCE` to a minibatch, time-major.
            let batches: Vec<Vec<usize>> = if self.hidden.is_some() {
                let seqs = self.buffer.sequence_permutation(SEQUENCE, &mut self.rng);
                seqs.chunks(self.ppo.batch_size / SEQUENCE)
                    .map(<[usize]>::to_vec)
                    .collect()
            } else {
                let perm = self.buffer.permutation(&mut self.rng);
                perm.chunks(self.ppo.batch_size).map(<[usize]>::to_vec).collect()
            };
            for chunk in &batches {
                let mb = if self.hidden.is_some() {
                    self.buffer.gather_sequences(chunk, SEQUENCE)
                } else {
                    self.buffer.gather(chunk)
                };
                let labels = (kick > 0.0).then(|| mb.labels.clone());
                let losses = ppo_losses(&self.policy, &self.minibatch(mb), &settings);
                let loss_value = losses.loss_value;
                if !loss_value.is_finite() {
                    return Err(PpoError::NonFinite {
                        update: self.iterations,
                        what: "the PPO loss".into(),
                        checkpoint: self.last_checkpoint.clone(),
                    });
                }
                pg.push(losses.policy_loss);
                vl.push(losses.value_loss);
                ent.push(losses.entropy_loss);
                cf.push(losses.clip_fraction);
                approx_kls.push(losses.approx_kl);
                last_loss = loss_value;
                if let Some(target) = self.ppo.target_kl
                    && losses.approx_kl > 1.5 * target
                {
                    continue_training = false;
                    break;
                }
                match &labels {
                    Some(labels) => {
                        let (ce, _) = crate::imitation::cross_entropy(&losses.logits, labels);
                        kick_ce.push(f64::try_from(&ce).unwrap_or(f64::NAN));
                        self.adam.gradients(&(&losses.surrogate + ce * kick))?;
                    }
                    None => self.adam.gradients(&losses.surrogate)?,
                }
                let norm = self.adam.clip_grad_norm(self.ppo.max_grad_norm);
                if !norm.is_finite() {
                    return Err(PpoError::NonFinite {
                        update: self.iterations,
                        what: "the gradient norm".into(),
                        checkpoint: self.last_checkpoint.clone(),
                    });
                }
                self.adam.step(lr);
            }
            self.n_updates += 1;
            if !continue_training {
                break;
            }
        }
        let mean = mean_or_nan;
        let mut kickstart = Vec::new();
        if self.kickstart.is_some() {
            kickstart.push(("train/kickstart_weight".to_string(), kick));
            kickstart.push(("train/kickstart_cross_entropy".to_string(), mean(&kick_ce)));
        }
        Ok(kickstart
            .into_iter()
            .chain([
                ("train/entropy_loss".into(), mean(&ent)),
                ("train/policy_gradient_loss".into(), mean(&pg)),
                ("train/value_loss".into(), mean(&vl)),
                ("train/approx_kl".into(), mean(&approx_kls)),
                ("train/clip_fraction".into(), mean(&cf)),
                ("train/loss".into(), last_loss),
                (
                    "train/explained_variance".into(),
                    explained_variance(&self.buffer.values, &self.buffer.returns),
                ),
                ("train/n_updates".into(), self.n_updates as f64),
                ("train/clip_range".into(), clip),
                ("train/learning_rate".into(), lr),
            ])
            .collect())
    }

    /// Writes a checkpoint folder atomically (a temporary sibling renamed into place).
    pub fn save(&mut self, dir: &Path) -> Result<(), PpoError> {
        // The staging folder is removed when dropped unpublished (any error below).
        let staged = firecast_fs::TempPath::dir(dir)
            .map_err(|e| PpoError::io("creating the checkpoint folder", &e.path, e.source))?;
        let tmp = staged.path();
        self.policy.var_store().save(tmp.join(POLICY_FILE))?;
        let mut named = Vec::new();
        for ((n, m), v) in self
            .param_names
            .iter()
            .zip(&self.adam.exp_avg)
            .zip(&self.adam.exp_avg_sq)
        {
            named.push((format!("exp_avg.{n}"), m.shallow_clone()));
            named.push((format!("exp_avg_sq.{n}"), v.shallow_clone()));
        }
        Tensor::write_safetensors(&named, tmp.join(OPTIMIZER_FILE))?;
        let state = TrainerState {
            format: CHECKPOINT_FORMAT,
            policy: self.policy.spec().clone(),
            space: self.policy.space(),
            num_actions: self.policy.num_actions(),
            ppo: self.ppo.clone(),
            seed: self.seed,
            num_timesteps: self.num_timesteps,
            n_updates: self.n_updates,
            iterations: self.iterations,
            adam_step: self.adam.step,
            rng: RngState::of(&self.rng),
            normalize: self.normalize.clone(),
            last_episode_starts: self.last_episode_starts.clone(),
            running: self.running.clone(),
            episodes: self.episodes.clone(),
            env: self.env.snapshot(),
            hidden: self.hidden.as_ref().map(Hidden::to_host),
            imitation_timesteps: self.imitation_timesteps,
        };
        let json = serde_json::to_vec_pretty(&state).map_err(|e| PpoError::Checkpoint {
            path: dir.to_path_buf(),
            message: e.to_string(),
        })?;
        let state_path = tmp.join(STATE_FILE);
        std::fs::write(&state_path, json)
            .map_err(|e| PpoError::io("writing the checkpoint", &state_path, e))?;
        staged
            .publish()
            .map_err(|e| PpoError::io("finishing the checkpoint", dir, e.source))?;
        self.last_checkpoint = Some(dir.to_path_buf());
        Ok(())
    }

    /// Continues from a checkpoint with environments built the same way (`env`); `ppo` may
    /// raise `total_timesteps` (or change nothing else: other changes are errors, as they
    /// would silently make a different run).
    pub fn resume(
        dir: &Path,
        ppo: PpoConfig,
        mut env: Box<dyn VecEnvironment>,
        device: Device,
    ) -> Result<Self, PpoError> {
        let bad = |message: String| PpoError::Checkpoint {
            path: dir.to_path_buf(),
            message,
        };
        let state_path = dir.join(STATE_FILE);
        let text = std::fs::read(&state_path).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => bad(format!("no {STATE_FILE}: not a FireCast PPO checkpoint")),
            _ => PpoError::io("reading the checkpoint", &state_path, e),
        })?;
        let state: TrainerState<C> =
            serde_json::from_slice(&text).map_err(|e| bad(format!("{STATE_FILE} is corrupt: {e}")))?;
        if state.format != CHECKPOINT_FORMAT {
            return Err(bad(format!(
                "format {} (this build reads {CHECKPOINT_FORMAT})",
                state.format
            )));
        }
        if state.space != env.space() || state.num_actions != env.num_actions() {
            return Err(bad(format!(
                "it was trained on observations {:?} with {} actions; this environment has {:?} and {}",
                state.space,
                state.num_actions,
                env.space(),
                env.num_actions()
            )));
        }
        let mut expected = state.ppo.clone();
        expected.total_timesteps = ppo.total_timesteps;
        if expected != ppo {
            return Err(bad(
                "the PPO settings differ from the checkpoint's (only total_timesteps may change on resume)"
                    .into(),
            ));
        }
        let policy = state.policy.build(state.space, state.num_actions, device)?;
        let mut policy = policy;
        policy
            .var_store_mut()
            .load(dir.join(POLICY_FILE))
            .map_err(|e| bad(format!("{POLICY_FILE}: {e}")))?;
        let (param_names, params) = trainable(&policy);
        let mut adam = Adam::new(params, ppo.adam_eps);
        let moments = Tensor::read_safetensors(dir.join(OPTIMIZER_FILE))
            .map_err(|e| bad(format!("{OPTIMIZER_FILE}: {e}")))?;
        let find = |key: String| {
            moments
                .iter()
                .find(|(n, _)| *n == key)
                .map(|(_, t)| t.shallow_clone())
                .ok_or_else(|| bad(format!("{OPTIMIZER_FILE} lacks {key}")))
        };
        for (k, n) in param_names.iter().enumerate() {
            let m = find(format!("exp_avg.{n}"))?;
            let v = find(format!("exp_avg_sq.{n}"))?;
            if m.size() != adam.exp_avg[k].size() || v.size() != adam.exp_avg_sq[k].size() {
                return Err(bad(format!(
                    "{OPTIMIZER_FILE}: moments of {n} have the wrong shape"
                )));
            }
            tch::no_grad(|| {
                adam.exp_avg[k].copy_(&m);
                adam.exp_avg_sq[k].copy_(&v);
            });
        }
        adam.step = state.adam_step;
        env.restore(&state.env)?;
        let hidden = match (policy.is_recurrent(), &state.hidden) {
            (false, _) => None,
            (true, Some(h)) if h.len() == ppo.n_envs * policy.hidden_len() => {
                Some(Hidden::from_host(h, ppo.n_envs, device))
            }
            (true, _) => return Err(bad(format!("{STATE_FILE} lacks the recurrent policy's state"))),
        };
        let space = state.space;
        let mut t = Self {
            buffer: RolloutBuffer::new(ppo.n_steps, ppo.n_envs, space),
            last_obs: ObsBatch::new(space, ppo.n_envs),
            last_episode_starts: state.last_episode_starts,
            running: state.running,
            rng: state.rng.restore(),
            ppo,
            policy,
            adam,
            param_names,
            env,
            normalize: state.normalize,
            seed: state.seed,
            num_timesteps: state.num_timesteps,
            n_updates: state.n_updates,
            iterations: state.iterations,
            episodes: state.episodes,
            all_episodes: Vec::new(),
            last_checkpoint: Some(dir.to_path_buf()),
            hidden,
            imitation_timesteps: state.imitation_timesteps,
            kickstart: None,
        };
        t.env.observe(&mut t.last_obs);
        // The statistics already include these observations: normalise without updating.
        t.normalize.normalize_obs(&mut t.last_obs.vector);
        Ok(t)
    }
}

/// The latest `step-*` checkpoint in `dir`.
pub fn latest_checkpoint(dir: &Path) -> Option<PathBuf> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("step-"))
                && p.join(STATE_FILE).exists()
        })
        .collect();
    found.sort();
    found.pop()
}

/// The mean, NaN for no values.
fn mean_or_nan(v: &[f64]) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// Every labelled step of an imitation run. The images are kept plane by plane (a frame of the
/// stack or another channel, `h × w` codes), each stored once: a frame stack shifts by
/// one frame a step, so a step's first three frames are the previous step's last three, and
/// only the newest frame is new. Planes are stored canonically (a few nonzero cells as a
/// list, codes below 16 two to a byte, else as they are), and a plane is reused only where its
/// stored bytes are equal, so [`gather`](Self::gather) gives back exactly the images the
/// rollouts held. On 240 × 160 images of four frames and a one-cell channel that is about
/// 19 KB a step instead of 192 KB.
struct Demonstrations {
    space: ObsSpace,
    /// Channels of an image (0 without images).
    channels: usize,
    /// Cells of a plane (`h × w`).
    plane_len: usize,
    /// Encoded planes back to back; `planes[k]` is the byte range of plane `k`.
    data: Vec<u8>,
    planes: Vec<std::ops::Range<usize>>,
    /// Plane ids of each row's channels (`channels` a row).
    rows: Vec<u32>,
    /// The last row of each environment (its previous step), across rollouts.
    last: Vec<Option<usize>>,
    vectors: Vec<f32>,
    labels: Vec<u8>,
    returns: Vec<f32>,
    /// Encoding scratch.
    scratch: Vec<u8>,
}

/// Plane encodings (the first byte).
const PLANE_SPARSE: u8 = 0;
const PLANE_NIBBLES: u8 = 1;
const PLANE_RAW: u8 = 2;
/// At most this many nonzero cells make a plane sparse (a channel marking one cell has one).
const SPARSE_CELLS: usize = 16;

/// The canonical encoding of one plane into `out`.
fn encode_plane(plane: &[u8], out: &mut Vec<u8>) {
    out.clear();
    let nonzero = plane.iter().filter(|&&v| v != 0).count();
    if nonzero <= SPARSE_CELLS {
        out.push(PLANE_SPARSE);
        for (i, &v) in plane.iter().enumerate().filter(|(_, v)| **v != 0) {
            out.extend_from_slice(&(i as u32).to_le_bytes());
            out.push(v);
        }
    } else if plane.iter().all(|&v| v < 16) {
        out.push(PLANE_NIBBLES);
        for pair in plane.chunks(2) {
            out.push(pair[0] | pair.get(1).map_or(0, |&hi| hi << 4));
        }
    } else {
        out.push(PLANE_RAW);
        out.extend_from_slice(plane);
    }
}

/// Writes the plane `encoded` describes into `out` (`plane_len` cells).
fn decode_plane(encoded: &[u8], out: &mut [u8]) {
    let (tag, body) = encoded.split_first().unwrap_or((&PLANE_SPARSE, &[]));
    match *tag {
        PLANE_NIBBLES => {
            for (pair, &b) in out.chunks_mut(2).zip(body) {
                pair[0] = b & 0x0f;
                if let Some(hi) = pair.get_mut(1) {
                    *hi = b >> 4;
                }
            }
        }
        PLANE_RAW => out.copy_from_slice(body),
        _ => {
            out.fill(0);
            for cell in body.chunks_exact(5) {
                let i = u32::from_le_bytes([cell[0], cell[1], cell[2], cell[3]]) as usize;
                out[i] = cell[4];
            }
        }
    }
}

impl Demonstrations {
    fn new(space: ObsSpace) -> Self {
        let (channels, plane_len) = space.image.map_or((0, 0), |[c, h, w]| (c, h * w));
        Self {
            space,
            channels,
            plane_len,
            data: Vec::new(),
            planes: Vec::new(),
            rows: Vec::new(),
            last: Vec::new(),
            vectors: Vec::new(),
            labels: Vec::new(),
            returns: Vec::new(),
            scratch: Vec::new(),
        }
    }
    fn len(&self) -> usize {
        self.labels.len()
    }

    /// The id of a stored plane whose bytes equal `scratch`, among `candidates`.
    fn find(&self, candidates: &[Option<u32>]) -> Option<u32> {
        candidates
            .iter()
            .flatten()
            .copied()
            .find(|&id| self.data[self.planes[id as usize].clone()] == self.scratch[..])
    }

    fn extend(&mut self, buffer: &RolloutBuffer) {
        let (c, n_envs) = (self.channels, buffer.n_envs);
        self.last.resize(n_envs, None);
        let il = self.space.image_len();
        for row in 0..buffer.len() {
            let env = row % n_envs;
            let image = &buffer.images[row * il..(row + 1) * il];
            let first = self.rows.len();
            for k in 0..c {
                encode_plane(
                    &image[k * self.plane_len..(k + 1) * self.plane_len],
                    &mut self.scratch,
                );
                let prev = |j: usize| self.last[env].filter(|_| j < c).map(|r| self.rows[r * c + j]);
                // The frame that moved up a slot since the previous step, the same slot
                // unchanged, or this step's previous slot (a new episode repeats its frame).
                let this = k.checked_sub(1).map(|j| self.rows[first + j]);
                let id = match self.find(&[prev(k + 1), prev(k), this]) {
                    Some(id) => id,
                    None => {
                        let start = self.data.len();
                        self.data.extend_from_slice(&self.scratch);
                        self.planes.push(start..self.data.len());
                        (self.planes.len() - 1) as u32
                    }
                };
                self.rows.push(id);
            }
            // This row (None without images, where nothing reads it).
            self.last[env] = first.checked_div(c);
        }
        self.vectors.extend_from_slice(&buffer.vectors);
        self.labels.extend_from_slice(&buffer.labels);
        self.returns.extend_from_slice(&buffer.returns);
    }

    fn gather(&self, rows: &[usize]) -> (ObsBatch, Vec<u8>, Vec<f32>) {
        let mut obs = ObsBatch::new(self.space, rows.len());
        let (c, p, vl) = (self.channels, self.plane_len, self.space.vector);
        for (r, &k) in rows.iter().enumerate() {
            let image = obs.image_row_mut(r);
            for j in 0..c {
                let id = self.rows[k * c + j] as usize;
                decode_plane(
                    &self.data[self.planes[id].clone()],
                    &mut image[j * p..(j + 1) * p],
                );
            }
            obs.vector_row_mut(r)
                .copy_from_slice(&self.vectors[k * vl..(k + 1) * vl]);
        }
        let labels = rows.iter().map(|&k| self.labels[k]).collect();
        let returns = rows.iter().map(|&k| self.returns[k]).collect();
        (obs, labels, returns)
    }
}

/// 0/1 as f32 (episode starts as the recurrent policy's reset mask).
fn as_f32(flags: &[bool]) -> Vec<f32> {
    flags.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect()
}

/// A recurrent policy trains on whole sequences: the rollout and the minibatch must hold a
/// whole number of them.
fn check_sequences(policy: &impl ActorCritic, ppo: &PpoConfig) -> Result<(), PpoError> {
    if !policy.is_recurrent() {
        return Ok(());
    }
    for (key, v) in [("ppo.n_steps", ppo.n_steps), ("ppo.batch_size", ppo.batch_size)] {
        if !v.is_multiple_of(SEQUENCE) {
            return Err(PpoError::config(
                key,
                format!("{v} is not a multiple of {SEQUENCE}, the sequence length of `memory: lstm`"),
            ));
        }
    }
    Ok(())
}

/// Trainable variables sorted by name.
fn trainable(policy: &impl ActorCritic) -> (Vec<String>, Vec<Tensor>) {
    let mut vars: Vec<(String, Tensor)> = policy
        .var_store()
        .variables()
        .into_iter()
        .filter(|(_, t)| t.requires_grad())
        .collect();
    vars.sort_by_cached_key(|(name, _)| flat_order(name));
    vars.into_iter().unzip()
}

/// Where a parameter goes in Adam's flat buffer: recurrent layers first, each packed as
/// cuDNN packs them (every layer's and direction's `weight_ih`, `weight_hh`, then the biases
/// in the same order), so on CUDA they stay the one chunk cuDNN takes as it is (see
/// `firecast_learn::layers::Recurrent`); everything else after them, by name.
fn flat_order(name: &str) -> (u8, String, u8, u32, u8, u8) {
    let (prefix, leaf) = name.rsplit_once('.').unwrap_or(("", name));
    let (leaf, reverse) = match leaf.strip_suffix("_reverse") {
        Some(l) => (l, 1),
        None => (leaf, 0),
    };
    let recurrent = [
        ("weight_ih", 0, 0),
        ("weight_hh", 0, 1),
        ("bias_ih", 1, 0),
        ("bias_hh", 1, 1),
    ]
    .iter()
    .find_map(|&(kind, bias, hh)| {
        let layer = leaf.strip_prefix(kind)?.strip_prefix("_l")?.parse::<u32>().ok()?;
        Some((bias, layer, hh))
    });
    match recurrent {
        Some((bias, layer, hh)) => (0, prefix.to_string(), bias, layer, reverse, hh),
        None => (1, name.to_string(), 0, 0, 0, 0),
    }
}

/// 1 − Var(y − ŷ)/Var(y) (population variances); NaN when Var(y) = 0 (SB3).
pub fn explained_variance(pred: &[f32], y: &[f32]) -> f64 {
    let n = y.len() as f64;
    if y.is_empty() {
        return f64::NAN;
    }
    let var = |v: &mut dyn Iterator<Item = f64>| {
        let xs: Vec<f64> = v.collect();
        let m = xs.iter().sum::<f64>() / n;
        xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n
    };
    let vy = var(&mut y.iter().map(|&v| f64::from(v)));
    if vy == 0.0 {
        return f64::NAN;
    }
    let vd = var(&mut y.iter().zip(pred).map(|(&a, &b)| f64::from(a) - f64::from(b)));
    1.0 - vd / vy
}

fn argmax(row: &[f32]) -> usize {
    let mut best = 0;
    for (k, &v) in row.iter().enumerate() {
        if v > row[best] {
            best = k;
        }
    }
    best
}

/// Inverse-CDF draw from log-probabilities.
fn sample(logp: &[f32], u: f64) -> usize {
    let mut acc = 0.0;
    for (k, &lp) in logp.iter().enumerate() {
        acc += f64::from(lp).exp();
        if u < acc {
            return k;
        }
    }
    logp.len() - 1
}

/// Greedy or sampled actions from a trained policy (evaluation), without a trainer; rows
/// draw from `rng` in order when sampling.
pub fn policy_actions(
    policy: &impl ActorCritic,
    obs: &ObsBatch,
    hidden: Option<&mut Hidden>,
    deterministic: bool,
    rng: &mut ChaCha8Rng,
) -> Vec<u8> {
    policy_log_probs(policy, obs, hidden)
        .chunks(policy.num_actions())
        .map(|row| pick_action(row, deterministic, rng))
        .collect()
}

/// [`policy_log_probs`] of a sub-batch: `obs` holds the observations of environments `rows`
/// (in order) and `hidden`, when the policy is recurrent, every environment's state; only
/// those rows step.
pub fn policy_log_probs_of(
    policy: &impl ActorCritic,
    obs: &ObsBatch,
    hidden: Option<&mut Hidden>,
    rows: &[usize],
) -> Vec<f32> {
    match hidden {
        Some(all) => {
            let mut sub = all.select(rows);
            let logp = policy_log_probs(policy, obs, Some(&mut sub));
            all.scatter(rows, &sub);
            logp
        }
        None => policy_log_probs(policy, obs, None),
    }
}

/// Action log-probabilities of a batch, `n × num_actions` row-major. A recurrent policy
/// steps from `hidden` (one row per observation; a new episode's row is zero) and leaves the
/// next state there; without `hidden` it starts from zero.
pub fn policy_log_probs(policy: &impl ActorCritic, obs: &ObsBatch, hidden: Option<&mut Hidden>) -> Vec<f32> {
    let device = policy.device();
    let obs_t = ObsTensors::from_batch(obs, device);
    let starts = vec![0.0; obs.n];
    let logits = tch::no_grad(|| match (hidden, policy.initial_hidden(obs.n)) {
        (_, None) => policy.forward(&obs_t, false).0,
        (Some(h), Some(_)) => {
            let (logits, _, next) = policy.sequence(&obs_t, h, &starts, 1, false);
            *h = next;
            logits
        }
        (None, Some(zero)) => policy.sequence(&obs_t, &zero, &starts, 1, false).0,
    });
    Vec::<f32>::try_from(
        logits
            .log_softmax(-1, Kind::Float)
            .to_device(Device::Cpu)
            .flatten(0, -1),
    )
    .unwrap_or_default()
}

/// One row's action: the greedy one, or one drawn from `rng` (one `f64` per call).
pub fn pick_action(logp: &[f32], deterministic: bool, rng: &mut ChaCha8Rng) -> u8 {
    if deterministic {
        argmax(logp) as u8
    } else {
        sample(logp, rng.random::<f64>()) as u8
    }
}

/// Log-probabilities and entropies under the policy (tests, diagnostics).
pub fn evaluate_actions(
    policy: &impl ActorCritic,
    obs: &ObsBatch,
    actions: &[u8],
) -> (Tensor, Tensor, Tensor) {
    let device = policy.device();
    let (logits, values) = policy.forward(&ObsTensors::from_batch(obs, device), true);
    let a = Tensor::from_slice(actions).to_kind(Kind::Int64).to_device(device);
    let (lp, h) = log_prob_entropy(&logits, &a);
    (values, lp, h)
}

#[cfg(test)]
mod tests {
    use super::{Demonstrations, flat_order};
    use crate::buffer::RolloutBuffer;
    use crate::env::ObsSpace;

    /// Imitation keeps each plane of its images once and gives back exactly the images the
    /// rollouts held: frame stacks that shift a frame a step, an episode's first step (four
    /// equal frames), a helicopter channel with one cell, a plane with codes of 16 and more,
    /// and rollouts that continue each environment's episode.
    #[test]
    fn demonstrations_store_planes_once_and_give_back_the_same_images() {
        let (h, w, envs, steps) = (6, 10, 2, 5);
        let n = h * w;
        let space = ObsSpace {
            image: Some([5, h, w]),
            vector: 3,
        };
        // Frame t of env e: a burning front that grows with t; frame 9 has a code of 200.
        let frame = |e: usize, t: usize| -> Vec<u8> {
            (0..n)
                .map(|i| match (t, i) {
                    (9, 0) => 200,
                    _ if i % w < t + e => 5,
                    _ => (i % 3) as u8 + 1,
                })
                .collect()
        };
        let mut original = Vec::new();
        let mut data = Demonstrations::new(space);
        for rollout in 0..2 {
            let mut buffer = RolloutBuffer::new(steps, envs, space);
            buffer.labels = vec![0; steps * envs];
            for t in 0..steps {
                for e in 0..envs {
                    let step = rollout * steps + t;
                    // Env 1 starts a new episode at step 3: four copies of its first frame.
                    let start = if e == 1 && step >= 3 { 3 } else { 0 };
                    let row = t * envs + e;
                    let image = &mut buffer.images[row * 5 * n..(row + 1) * 5 * n];
                    for k in 0..4 {
                        let ft = (step + k).saturating_sub(3).max(start);
                        image[k * n..(k + 1) * n].copy_from_slice(&frame(e, ft));
                    }
                    image[4 * n + (step * 7 + e) % n] = 9;
                    buffer.vectors[row * 3..(row + 1) * 3].copy_from_slice(&[step as f32, e as f32, 1.0]);
                    buffer.labels[row] = (step % 5) as u8;
                    buffer.returns[row] = step as f32 * 0.5;
                }
            }
            original.push(buffer.clone());
            data.extend(&buffer);
        }
        assert_eq!(data.len(), 2 * steps * envs);
        let rows: Vec<usize> = (0..data.len()).rev().collect();
        let (obs, labels, returns) = data.gather(&rows);
        for (r, &k) in rows.iter().enumerate() {
            let buffer = &original[k / (steps * envs)];
            let row = k % (steps * envs);
            assert_eq!(
                obs.image_row(r),
                &buffer.images[row * 5 * n..(row + 1) * 5 * n],
                "row {k}"
            );
            assert_eq!(obs.vector_row(r), &buffer.vectors[row * 3..(row + 1) * 3]);
            assert_eq!(labels[r], buffer.labels[row]);
            assert_eq!(returns[r], buffer.returns[row]);
        }
        // Each step adds about one new frame (and a helicopter cell), not four.
        let stored = data.data.len();
        let raw = 2 * steps * envs * 5 * n;
        assert!(stored * 5 < raw, "{stored} bytes stored for {raw}");
    }

    #[test]
    fn recurrent_weights_lead_adams_buffer_in_cudnn_order() {
        let mut names = vec![
            "pi_features_extractor.fusion.weight",
            "features_extractor.lstm.bias_hh_l1",
            "features_extractor.lstm.weight_ih_l1",
            "features_extractor.lstm.bias_ih_l0",
            "features_extractor.lstm.weight_hh_l0",
            "action_net.bias",
            "features_extractor.lstm.weight_ih_l0",
            "features_extractor.lstm.bias_hh_l0",
            "features_extractor.lstm.weight_hh_l1",
            "features_extractor.lstm.bias_ih_l1",
        ];
        names.sort_by_cached_key(|n| flat_order(n));
        assert_eq!(
            names,
            [
                "features_extractor.lstm.weight_ih_l0",
                "features_extractor.lstm.weight_hh_l0",
                "features_extractor.lstm.weight_ih_l1",
                "features_extractor.lstm.weight_hh_l1",
                "features_extractor.lstm.bias_ih_l0",
                "features_extractor.lstm.bias_hh_l0",
                "features_extractor.lstm.bias_ih_l1",
                "features_extractor.lstm.bias_hh_l1",
                "action_net.bias",
                "pi_features_extractor.fusion.weight",
            ]
        );
    }
}
