//! A trained PPO policy as a [`firecast_sim::Policy`] for one environment: observations
//! encoded as the batched evaluation encodes them ([`helitack::encode`], then the frozen
//! observation normaliser), actions from the same log-probabilities. With the same
//! environment, episode seed and action seed it replays an evaluated episode, so anything
//! that takes a `firecast_sim::Policy` (Rerun recordings, frames, GIFs) can draw it.

use firecast_ppo::env::ObsBatch;
use firecast_ppo::normalize::VecNormalize;
use firecast_ppo::policy::Hidden;
use firecast_ppo::train::policy_actions;
use firecast_sim::{Action, Decision, Observation};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;

use crate::RlError;
use crate::helitack;
use crate::policy::Policy;

/// Where an agent's trained policy and frozen observation normaliser live: borrowed from a
/// loaded run, or owned (a live fire on its own thread).
pub trait PolicySource {
    fn policy(&self) -> &Policy;
    fn normalize(&self) -> Option<&VecNormalize>;
}

/// A policy and normaliser borrowed from elsewhere.
pub struct Borrowed<'a>(pub &'a Policy, pub Option<&'a VecNormalize>);

impl PolicySource for Borrowed<'_> {
    fn policy(&self) -> &Policy {
        self.0
    }
    fn normalize(&self) -> Option<&VecNormalize> {
        self.1
    }
}

impl PolicySource for crate::ensemble::EnsemblePolicy {
    fn policy(&self) -> &Policy {
        &self.policy
    }
    fn normalize(&self) -> Option<&VecNormalize> {
        self.normalize.as_ref()
    }
}

/// A trained policy playing one helitack environment.
pub struct PpoAgent<S> {
    source: S,
    deterministic: bool,
    /// Draws of sampled actions (one per step); untouched when greedy.
    rng: ChaCha8Rng,
    obs: ObsBatch,
    /// A recurrent policy's state (one agent plays one episode, from zero).
    hidden: Option<Hidden>,
    width: usize,
    height: usize,
}

impl<'a> PpoAgent<Borrowed<'a>> {
    /// An agent for a `width × height` grid; greedy when `deterministic`, otherwise
    /// sampling with a stream seeded by `action_seed`. `normalize` is the run's frozen
    /// observation normaliser, if it has one.
    pub fn new(
        policy: &'a Policy,
        normalize: Option<&'a VecNormalize>,
        width: usize,
        height: usize,
        deterministic: bool,
        action_seed: u64,
    ) -> Result<Self, RlError> {
        Self::with_source(
            Borrowed(policy, normalize),
            width,
            height,
            deterministic,
            action_seed,
        )
    }
}

impl<S: PolicySource> PpoAgent<S> {
    /// As [`PpoAgent::new`], with the policy held by `source` (e.g. owned).
    pub fn with_source(
        source: S,
        width: usize,
        height: usize,
        deterministic: bool,
        action_seed: u64,
    ) -> Result<Self, RlError> {
        let policy = source.policy();
        let space = helitack::space(width, height);
        if !policy.accepts(space) {
            return Err(RlError::config(
                "policy",
                format!(
                    "the policy was trained on observations {:?}, a {width}×{height} grid gives {space:?}",
                    policy.space
                ),
            ));
        }
        let hidden = policy.initial_hidden(1);
        Ok(Self {
            source,
            deterministic,
            rng: ChaCha8Rng::seed_from_u64(action_seed),
            obs: ObsBatch::new(space, 1),
            hidden,
            width,
            height,
        })
    }
}

impl<S: PolicySource> firecast_sim::Policy for PpoAgent<S> {
    fn act(&mut self, obs: &Observation<'_>) -> Decision {
        if (obs.width, obs.height) != (self.width, self.height) {
            // `new` checked the grid; an environment of another size has no valid
            // observation for this policy, so the helicopter only moves.
            return Action::North.into();
        }
        helitack::encode(
            obs.frames,
            obs.agent,
            obs.on_fire,
            self.width,
            self.height,
            &mut self.obs.image,
            &mut self.obs.vector,
        );
        if let Some(n) = self.source.normalize() {
            n.normalize_obs(&mut self.obs.vector);
        }
        let action = policy_actions(
            self.source.policy(),
            &self.obs,
            self.hidden.as_mut(),
            self.deterministic,
            &mut self.rng,
        )
        .first()
        .copied()
        .unwrap_or(0);
        Action::try_from(action).unwrap_or(Action::North).into()
    }
}
