//! Training specs (`experiments/rl/*.yaml`, strict) and fire files (`experiments/rl/*fires*.yaml`).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::RlError;
use crate::helitack::FireSet;
use crate::imitation::ImitationConfig;
use crate::policy::{PolicyConfig, PolicyKind};
use firecast_ppo::ppo::PpoConfig;
use firecast_sim::RewardWeights;

/// Which environment to train on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "snake_case")]
pub enum EnvSpec {
    /// CartPole-v1 (the trainer's correctness gate).
    Cartpole,
    /// The helitack environment on the `train` fires of a fire file.
    Helitack {
        /// The fire file, relative to the repository root (a stage takes it from its `fires`
        /// input instead).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        fires: Option<PathBuf>,
        /// The reward to train on, replacing the fire file's `profile` and `reward`: the
        /// fires say where and how fires burn, the recipe says what the agent is paid for.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        reward: Option<RewardSpec>,
    },
}

/// `reward:` — a profile (`p2`, `websocket_t`, `p1_improved` or `suppression`) and weights
/// that replace the profile's (`RewardWeights`' names), e.g. `{profile: suppression,
/// quenched: 0, new_burnt: -1}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RewardSpec {
    #[serde(default = "default_profile")]
    pub profile: String,
    #[serde(flatten)]
    pub weights: serde_json::Map<String, serde_json::Value>,
}

impl RewardSpec {
    /// The profile's weights with this spec's replacements; `key` prefixes error paths.
    pub fn weights(&self, key: &str) -> Result<RewardWeights, RlError> {
        let mut reward = crate::helitack::reward_profile(&self.profile).map_err(|e| match e {
            RlError::Config { message, .. } => RlError::config(format!("{key}.profile"), message),
            other => other,
        })?;
        if !self.weights.is_empty() {
            let mut weights =
                serde_json::to_value(&reward).map_err(|e| RlError::config(key, e.to_string()))?;
            if let Some(w) = weights.as_object_mut() {
                w.extend(self.weights.clone());
            }
            reward = firecast_pipeline::stage::deserialize_params(&weights).map_err(|e| {
                RlError::config(
                    format!("{key}.{}", e.path).trim_end_matches('.').to_string(),
                    e.message,
                )
            })?;
        }
        Ok(reward)
    }
}

/// `ppo:` — a preset and overrides of any [`PpoConfig`] field.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PpoSpec {
    #[serde(default = "default_preset")]
    pub preset: String,
    #[serde(flatten)]
    pub overrides: serde_json::Map<String, serde_json::Value>,
}

fn default_preset() -> String {
    "paper".into()
}

impl Default for PpoSpec {
    fn default() -> Self {
        Self {
            preset: default_preset(),
            overrides: serde_json::Map::new(),
        }
    }
}

/// A training run: environment, policy, PPO settings and the training seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainSpec {
    pub name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    pub env: EnvSpec,
    /// Default: `mlp` for CartPole, `compact` for the helitack environment.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub policy: Option<PolicyConfig>,
    #[serde(default)]
    pub ppo: PpoSpec,
    /// Learn a teacher's actions before PPO (helitack only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub imitation: Option<ImitationConfig>,
    /// One run per seed (torch weights, environments, minibatches and actions).
    #[serde(default = "default_seeds")]
    pub seeds: Vec<u64>,
    /// Checkpoint every this many iterations (rollout + update); the last is always kept.
    #[serde(default = "default_checkpoint_every")]
    pub checkpoint_every: u64,
    /// `auto` (CUDA when present), `cpu`, `cuda` or `cuda:N`.
    #[serde(default = "default_device")]
    pub device: String,
    /// libtorch threads: part of the result, so part of the cache key; a fixed default, not
    /// the machine's core count.
    #[serde(default = "firecast_learn::default_threads")]
    pub threads: usize,
}

fn default_seeds() -> Vec<u64> {
    vec![0]
}
fn default_checkpoint_every() -> u64 {
    20
}
fn default_device() -> String {
    "auto".into()
}

impl TrainSpec {
    /// Reads a spec strictly, through its `extends` chain (a recipe may start from another
    /// and change only what differs); `overrides` are `key.path=value` (value as YAML).
    /// A setting refused after parsing names the file and line that wrote it.
    pub fn load(root: &Path, file: &Path, overrides: &[String]) -> Result<Self, RlError> {
        let mut layered = firecast_pipeline::extends::load(root, file)?;
        for o in overrides {
            firecast_pipeline::spec::apply_override(&mut layered.value, o)
                .map_err(|e| RlError::config(e.path, e.message))?;
        }
        let spec: Self = layered.deserialize()?;
        spec.validate().map_err(|e| e.placed(&layered))?;
        Ok(spec)
    }

    pub fn policy(&self) -> PolicyConfig {
        self.policy.clone().unwrap_or_else(|| PolicyConfig {
            kind: match self.env {
                EnvSpec::Cartpole => PolicyKind::Mlp,
                EnvSpec::Helitack { .. } => PolicyKind::Compact,
            },
            ..PolicyConfig::default()
        })
    }

    pub fn ppo(&self) -> Result<PpoConfig, RlError> {
        Ok(PpoConfig::resolve(&self.ppo.preset, &self.ppo.overrides)?)
    }

    pub fn validate(&self) -> Result<(), RlError> {
        if self.name.is_empty()
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
        {
            return Err(RlError::config(
                "name",
                format!("`{}`: use letters, digits, -, _ or .", self.name),
            ));
        }
        firecast_learn::check_threads(self.threads).map_err(|m| RlError::config("threads", m))?;
        if self.seeds.is_empty() {
            return Err(RlError::config("seeds", "needs at least one seed"));
        }
        let mut s = self.seeds.clone();
        s.sort_unstable();
        s.dedup();
        if s.len() != self.seeds.len() {
            return Err(RlError::config("seeds", "seeds repeat"));
        }
        let ppo = self.ppo()?;
        if ppo.total_timesteps == 0 && self.imitation.is_none() {
            return Err(RlError::config(
                "ppo.total_timesteps",
                "0 trains nothing (0 is for a policy that only imitates: add `imitation:`)",
            ));
        }
        crate::parse_device(&self.device)?;
        if let EnvSpec::Helitack {
            reward: Some(reward), ..
        } = &self.env
        {
            reward.weights("env.reward")?;
        }
        let p = self.policy();
        if let Some(imitation) = &self.imitation {
            if self.env == EnvSpec::Cartpole {
                return Err(RlError::config(
                    "imitation.teacher",
                    "the teachers fly helicopters: imitation needs the helitack environment",
                ));
            }
            firecast_ppo::imitation::single_steps(p.memory == crate::policy::Memory::Lstm)?;
            imitation.validate(ppo.buffer_size())?;
        }
        match (&self.env, p.kind) {
            (EnvSpec::Cartpole, PolicyKind::Mlp)
            | (EnvSpec::Helitack { .. }, PolicyKind::Compact | PolicyKind::Paper) => {}
            (EnvSpec::Cartpole, k) => {
                return Err(RlError::config(
                    "policy.kind",
                    format!("{k:?} needs images; CartPole takes `mlp`"),
                ));
            }
            (EnvSpec::Helitack { .. }, _) => {
                return Err(RlError::config(
                    "policy.kind",
                    "the helitack environment takes `compact` or `paper`",
                ));
            }
        }
        Ok(())
    }
}

/// A fire file: the reward profile and the training and evaluation fire sets.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FiresSpec {
    /// Reward profile: `p2`, `websocket_t`, `p1_improved` or `suppression`.
    #[serde(default = "default_profile")]
    pub profile: String,
    /// Weights that replace the profile's (`RewardWeights`' names), e.g. `{new_burnt: 0}`.
    #[serde(default)]
    pub reward: serde_json::Map<String, serde_json::Value>,
    pub train: FireSet,
    pub evaluate: FireSet,
}

fn default_profile() -> String {
    "p2".into()
}

impl FiresSpec {
    /// Reads a fire file strictly; a setting refused after parsing names the file, the line
    /// and the column of its key (`fires.yaml:14:7: train.env.ignition: …`).
    /// Reads a fire file strictly; a setting refused after parsing names the file, the line
    /// and the column of its key (`fires.yaml:14:7: train.env.ignition: …`). Fire files do
    /// not `extends` one another: a stage's cache key hashes the fire file it is given.
    pub fn load(path: &Path) -> Result<Self, RlError> {
        let text =
            std::fs::read_to_string(path).map_err(|e| RlError::io("reading the fire file", path, e))?;
        let spec: Self = firecast_pipeline::spec::deserialize_mapping_enums(path, &text)?;
        spec.checked().map_err(|e| e.located(path, &text))
    }

    /// The fires with the reward of a training spec instead of the file's own, when the
    /// spec names one (`env.reward`).
    pub fn with_reward(mut self, reward: Option<&RewardSpec>) -> Result<Self, RlError> {
        if let Some(reward) = reward {
            let weights = reward.weights("env.reward")?;
            self.profile = reward.profile.clone();
            self.reward = reward.weights.clone();
            self.train.env.reward = weights.clone();
            self.evaluate.env.reward = weights;
        }
        Ok(self)
    }

    /// The profile's reward applied and every check of [`load`](Self::load) passed.
    fn checked(mut self) -> Result<Self, RlError> {
        let spec = &mut self;
        let reward = crate::helitack::reward_profile(&spec.profile)?;
        let reward = if spec.reward.is_empty() {
            reward
        } else {
            RewardSpec {
                profile: spec.profile.clone(),
                weights: spec.reward.clone(),
            }
            .weights("reward")?
        };
        for (key, set) in [("train", &spec.train), ("evaluate", &spec.evaluate)] {
            if set.env.reward != RewardWeights::default() {
                return Err(RlError::config(
                    format!("{key}.env.reward"),
                    "the reward comes from `profile` (p2, websocket_t, p1_improved or suppression) \
                     and the top-level `reward` (weights that replace the profile's)",
                ));
            }
        }
        spec.train.env.reward = reward.clone();
        spec.evaluate.env.reward = reward;
        spec.train.validate("train")?;
        spec.evaluate.validate("evaluate")?;
        if spec.train.width != spec.evaluate.width || spec.train.height != spec.evaluate.height {
            return Err(RlError::config(
                "evaluate.width",
                "training and evaluation grids must have the same size",
            ));
        }
        let shared: Vec<u64> = spec
            .evaluate
            .landscape_seeds
            .iter()
            .copied()
            .filter(|s| spec.train.landscape_seeds.contains(s))
            .collect();
        if !shared.is_empty() {
            return Err(RlError::config(
                "evaluate.landscape_seeds",
                format!("{shared:?} are also training landscapes: evaluation fires must be held out"),
            ));
        }
        Ok(self)
    }
}

/// Where a spec's fire file is.
pub fn fires_path(spec: &TrainSpec) -> Option<&PathBuf> {
    match &spec.env {
        EnvSpec::Helitack { fires, .. } => fires.as_ref(),
        EnvSpec::Cartpole => None,
    }
}
