//! PPO with Stable-Baselines3's semantics (rl-anchors.md §1): hyper-parameters and presets,
//! the per-minibatch loss, PyTorch's Adam and `clip_grad_norm_`.

use serde::{Deserialize, Serialize};
use tch::{Kind, Tensor};

use crate::RlError;
use crate::normalize::NormalizeConfig;
use crate::policy::{ObsTensors, Policy};

/// A constant or linearly decaying value of the remaining progress p (1 → 0):
/// `end + (start − end)·p` (RL-Zoo's `lin_<v>` is `{linear: v}`, ending at 0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Schedule {
    Constant(f64),
    Linear {
        linear: f64,
        #[serde(default)]
        end: f64,
    },
}

impl Schedule {
    pub fn at(&self, progress_remaining: f64) -> f64 {
        match *self {
            Self::Constant(v) => v,
            Self::Linear { linear, end } => end + (linear - end) * progress_remaining,
        }
    }
    fn initial(&self) -> f64 {
        self.at(1.0)
    }
}

/// PPO hyper-parameters (SB3's names and defaults).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PpoConfig {
    pub n_envs: usize,
    /// Steps per environment per rollout.
    pub n_steps: usize,
    pub batch_size: usize,
    pub n_epochs: usize,
    pub learning_rate: Schedule,
    pub clip_range: Schedule,
    /// Value clipping around the old values (off in SB3 by default).
    pub clip_range_vf: Option<f64>,
    pub gamma: f64,
    pub gae_lambda: f64,
    pub ent_coef: f64,
    pub vf_coef: f64,
    pub max_grad_norm: f64,
    /// Stop the update when approx_kl > 1.5 × this (SB3).
    pub target_kl: Option<f64>,
    pub normalize_advantage: bool,
    /// Adam's ε (SB3 sets 1e-5; PyTorch's and tch's default is 1e-8).
    pub adam_eps: f64,
    pub normalize: NormalizeConfig,
    pub total_timesteps: u64,
}

/// The preset names.
pub const PRESETS: &[&str] = &["sb3", "paper", "websocket", "cartpole_zoo"];

impl PpoConfig {
    /// SB3's `PPO` defaults.
    pub fn sb3() -> Self {
        Self {
            n_envs: 1,
            n_steps: 2048,
            batch_size: 64,
            n_epochs: 10,
            learning_rate: Schedule::Constant(3e-4),
            clip_range: Schedule::Constant(0.2),
            clip_range_vf: None,
            gamma: 0.99,
            gae_lambda: 0.95,
            ent_coef: 0.0,
            vf_coef: 0.5,
            max_grad_norm: 0.5,
            target_kl: None,
            normalize_advantage: true,
            adam_eps: 1e-5,
            normalize: NormalizeConfig::default(),
            total_timesteps: 1_000_000,
        }
    }

    /// The values the paper states (= `training_improved.py`): 8 envs, n_steps 128, batch 64,
    /// 3 epochs, lr 3e-4, clip 0.1, γ 0.95, λ 0.9, entropy 0.2, value 0.4, grad norm 1.0,
    /// target KL 0.03, reward normalisation only; 3×10⁵ steps.
    pub fn paper() -> Self {
        Self {
            n_envs: 8,
            n_steps: 128,
            batch_size: 64,
            n_epochs: 3,
            learning_rate: Schedule::Constant(3e-4),
            clip_range: Schedule::Constant(0.1),
            gamma: 0.95,
            gae_lambda: 0.9,
            ent_coef: 0.2,
            vf_coef: 0.4,
            max_grad_norm: 1.0,
            target_kl: Some(0.03),
            normalize: NormalizeConfig {
                obs: false,
                reward: true,
                ..NormalizeConfig::default()
            },
            total_timesteps: 300_000,
            ..Self::sb3()
        }
    }

    /// The React/websocket `train.py`: 1 env, n_steps 128, batch 32, 4 epochs, lr 3e-4
    /// decayed linearly over 2×10⁵ steps, clip 0.2, γ 0.99, λ 0.95, entropy 0.05, value 0.5,
    /// grad norm 0.5, target KL 0.01, observation (coordinates) and reward normalisation.
    pub fn websocket() -> Self {
        Self {
            n_envs: 1,
            n_steps: 128,
            batch_size: 32,
            n_epochs: 4,
            // 3e-4·(1 − t/200k) over a 1e6-step run reaches 0 at 200k; as a schedule over
            // the run it is the linear decay of the run's budget.
            learning_rate: Schedule::Linear {
                linear: 3e-4,
                end: 0.0,
            },
            clip_range: Schedule::Constant(0.2),
            gamma: 0.99,
            gae_lambda: 0.95,
            ent_coef: 0.05,
            vf_coef: 0.5,
            max_grad_norm: 0.5,
            target_kl: Some(0.01),
            normalize: NormalizeConfig {
                obs: true,
                reward: true,
                clip_reward: 10.0,
                gamma: Some(0.99),
                ..NormalizeConfig::default()
            },
            total_timesteps: 200_000,
            ..Self::sb3()
        }
    }

    /// RL-Zoo's tuned CartPole-v1 PPO: 8 envs × 32 steps, batch 256, 20 epochs, γ 0.98,
    /// λ 0.8, lr lin_1e-3, clip lin_0.2, no entropy bonus; 10⁵ steps.
    pub fn cartpole_zoo() -> Self {
        Self {
            n_envs: 8,
            n_steps: 32,
            batch_size: 256,
            n_epochs: 20,
            learning_rate: Schedule::Linear {
                linear: 1e-3,
                end: 0.0,
            },
            clip_range: Schedule::Linear {
                linear: 0.2,
                end: 0.0,
            },
            gamma: 0.98,
            gae_lambda: 0.8,
            ent_coef: 0.0,
            total_timesteps: 100_000,
            ..Self::sb3()
        }
    }

    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "sb3" => Some(Self::sb3()),
            "paper" => Some(Self::paper()),
            "websocket" => Some(Self::websocket()),
            "cartpole_zoo" => Some(Self::cartpole_zoo()),
            _ => None,
        }
    }

    /// A preset with `overrides` (a mapping of PpoConfig keys) applied; unknown keys are
    /// errors naming `ppo.<key>`.
    pub fn resolve(
        preset: &str,
        overrides: &serde_json::Map<String, serde_json::Value>,
    ) -> Result<Self, RlError> {
        let base = Self::preset(preset).ok_or_else(|| {
            RlError::config(
                "ppo.preset",
                format!("unknown preset `{preset}` (use one of {})", PRESETS.join(", ")),
            )
        })?;
        let mut v = serde_json::to_value(&base).map_err(|e| RlError::config("ppo", e.to_string()))?;
        if let serde_json::Value::Object(map) = &mut v {
            for (k, val) in overrides {
                if !map.contains_key(k) {
                    return Err(RlError::config(
                        format!("ppo.{k}"),
                        "unknown hyper-parameter (see `PpoConfig` in firecast-rl)",
                    ));
                }
                if k == "normalize" {
                    // Merge key by key so `normalize: {reward: true}` keeps the rest.
                    if let (Some(serde_json::Value::Object(dst)), serde_json::Value::Object(src)) =
                        (map.get_mut(k), val)
                    {
                        for (nk, nv) in src {
                            dst.insert(nk.clone(), nv.clone());
                        }
                        continue;
                    }
                }
                map.insert(k.clone(), val.clone());
            }
        }
        let cfg: Self = serde_path_to_error::deserialize(v)
            .map_err(|e| RlError::config(format!("ppo.{}", e.path()), e.inner().to_string()))?;
        cfg.validate()?;
        Ok(cfg)
    }

    pub fn buffer_size(&self) -> usize {
        self.n_envs * self.n_steps
    }

    pub fn validate(&self) -> Result<(), RlError> {
        let bad = |k: &str, m: String| Err(RlError::config(format!("ppo.{k}"), m));
        if self.n_envs == 0 {
            return bad("n_envs", "must be at least 1".into());
        }
        if self.n_steps == 0 {
            return bad("n_steps", "must be at least 1".into());
        }
        if self.buffer_size() < 2 {
            return bad("n_steps", "n_steps × n_envs must be > 1 (SB3)".into());
        }
        if self.batch_size < 2 && self.normalize_advantage {
            return bad("batch_size", "must be > 1 with normalize_advantage (SB3)".into());
        }
        if !self.buffer_size().is_multiple_of(self.batch_size) {
            return bad(
                "batch_size",
                format!(
                    "{} does not divide the rollout of n_steps × n_envs = {} × {} = {}",
                    self.batch_size,
                    self.n_steps,
                    self.n_envs,
                    self.buffer_size()
                ),
            );
        }
        if self.n_epochs == 0 {
            return bad("n_epochs", "must be at least 1".into());
        }
        for (k, v) in [("gamma", self.gamma), ("gae_lambda", self.gae_lambda)] {
            if !(0.0..=1.0).contains(&v) {
                return bad(k, format!("{v} is not in [0, 1]"));
            }
        }
        if self.learning_rate.initial().is_nan() || self.learning_rate.initial() <= 0.0 {
            return bad("learning_rate", "must be positive".into());
        }
        if self.clip_range.initial().is_nan() || self.clip_range.initial() <= 0.0 {
            return bad("clip_range", "must be positive".into());
        }
        if self.max_grad_norm.is_nan() || self.max_grad_norm <= 0.0 {
            return bad("max_grad_norm", "must be positive".into());
        }
        if self.adam_eps.is_nan() || self.adam_eps <= 0.0 {
            return bad("adam_eps", "must be positive".into());
        }
        if self.total_timesteps == 0 {
            return bad("total_timesteps", "must be at least 1".into());
        }
        Ok(())
    }
}

/// A minibatch as tensors.
#[derive(Debug)]
pub struct MinibatchTensors {
    pub obs: ObsTensors,
    /// i64 action indices `[n]`.
    pub actions: Tensor,
    pub old_values: Tensor,
    pub old_log_probs: Tensor,
    pub advantages: Tensor,
    pub returns: Tensor,
}

/// The losses of one minibatch (the `loss` tensor carries the graph).
#[derive(Debug)]
pub struct Losses {
    pub loss: Tensor,
    pub policy_loss: f64,
    pub value_loss: f64,
    pub entropy_loss: f64,
    pub approx_kl: f64,
    pub clip_fraction: f64,
}

/// Log-probabilities of `actions` and the entropies of the categorical distributions.
pub fn log_prob_entropy(logits: &Tensor, actions: &Tensor) -> (Tensor, Tensor) {
    let logp_all = logits.log_softmax(-1, Kind::Float);
    let logp = logp_all.gather(1, &actions.unsqueeze(1), false).squeeze_dim(1);
    let entropy = -(logp_all.exp() * &logp_all).sum_dim_intlist(-1, false, Kind::Float);
    (logp, entropy)
}

/// SB3's PPO loss on one minibatch (`train()`, per minibatch): advantage normalisation with
/// the unbiased std + 1e-8, clipped surrogate, optional value clipping, MSE value loss
/// without ½, entropy loss −mean(H), approx KL (k3).
pub fn ppo_losses(
    policy: &Policy,
    mb: &MinibatchTensors,
    clip_range: f64,
    clip_range_vf: Option<f64>,
    ent_coef: f64,
    vf_coef: f64,
    normalize_advantage: bool,
) -> Losses {
    let (logits, values) = policy.forward(&mb.obs, true);
    let (log_prob, entropy) = log_prob_entropy(&logits, &mb.actions);
    let mut adv = mb.advantages.shallow_clone();
    if normalize_advantage && adv.size()[0] > 1 {
        adv = (&adv - adv.mean(Kind::Float)) / (adv.std(true) + 1e-8);
    }
    let log_ratio = &log_prob - &mb.old_log_probs;
    let ratio = log_ratio.exp();
    let pl1 = &adv * &ratio;
    let pl2 = &adv * ratio.clamp(1.0 - clip_range, 1.0 + clip_range);
    let policy_loss = -pl1.minimum(&pl2).mean(Kind::Float);
    let clip_fraction = f64::try_from(
        (&ratio - 1.0)
            .abs()
            .gt(clip_range)
            .to_kind(Kind::Float)
            .mean(Kind::Float),
    )
    .unwrap_or(f64::NAN);
    let values_pred = match clip_range_vf {
        None => values,
        Some(c) => &mb.old_values + (&values - &mb.old_values).clamp(-c, c),
    };
    let value_loss = values_pred.mse_loss(&mb.returns, tch::Reduction::Mean);
    let entropy_loss = -entropy.mean(Kind::Float);
    let loss = &policy_loss + ent_coef * &entropy_loss + vf_coef * &value_loss;
    let approx_kl = tch::no_grad(|| {
        let lr = log_ratio.detach();
        f64::try_from(((lr.exp() - 1.0) - &lr).mean(Kind::Float)).unwrap_or(f64::NAN)
    });
    let scalar = |t: &Tensor| f64::try_from(t.detach()).unwrap_or(f64::NAN);
    Losses {
        policy_loss: scalar(&policy_loss),
        value_loss: scalar(&value_loss),
        entropy_loss: scalar(&entropy_loss),
        approx_kl,
        clip_fraction,
        loss,
    }
}

/// PyTorch's `clip_grad_norm_` (L2, global): total = ‖(‖g₁‖, …, ‖gₙ‖)‖, every gradient
/// multiplied by min(1, max/(total + 1e-6)). Returns the total norm before clipping.
pub fn clip_grad_norm(params: &[Tensor], max_norm: f64) -> f64 {
    tch::no_grad(|| {
        let norms: Vec<Tensor> = params
            .iter()
            .filter_map(|p| {
                let g = p.grad();
                g.defined().then(|| g.norm())
            })
            .collect();
        if norms.is_empty() {
            return 0.0;
        }
        let total = Tensor::stack(&norms, 0).norm();
        let coef = (max_norm / (&total + 1e-6)).clamp_max(1.0);
        for p in params {
            let mut g = p.grad();
            if g.defined() {
                let _ = g.g_mul_(&coef);
            }
        }
        f64::try_from(total).unwrap_or(f64::NAN)
    })
}

/// PyTorch's Adam (single-tensor implementation, no weight decay, no AMSGrad), with its
/// moments in the open so checkpoints hold them.
#[derive(Debug)]
pub struct Adam {
    pub params: Vec<Tensor>,
    pub exp_avg: Vec<Tensor>,
    pub exp_avg_sq: Vec<Tensor>,
    pub step: u64,
    pub beta1: f64,
    pub beta2: f64,
    pub eps: f64,
}

impl Adam {
    pub fn new(params: Vec<Tensor>, eps: f64) -> Self {
        let exp_avg = params.iter().map(Tensor::zeros_like).collect();
        let exp_avg_sq = params.iter().map(Tensor::zeros_like).collect();
        Self {
            params,
            exp_avg,
            exp_avg_sq,
            step: 0,
            beta1: 0.9,
            beta2: 0.999,
            eps,
        }
    }

    pub fn zero_grad(&mut self) {
        for p in &mut self.params {
            let mut g = p.grad();
            if g.defined() {
                let _ = g.detach_();
                let _ = g.zero_();
            }
        }
    }

    pub fn step(&mut self, lr: f64) {
        self.step += 1;
        let t = self.step as i32;
        let bc1 = 1.0 - self.beta1.powi(t);
        let bc2_sqrt = (1.0 - self.beta2.powi(t)).sqrt();
        let step_size = lr / bc1;
        tch::no_grad(|| {
            for ((p, m), v) in self
                .params
                .iter_mut()
                .zip(&mut self.exp_avg)
                .zip(&mut self.exp_avg_sq)
            {
                let g = p.grad();
                if !g.defined() {
                    continue;
                }
                let _ = m.lerp_(&g, 1.0 - self.beta1);
                let _ = v.g_mul_scalar_(self.beta2);
                let _ = v.addcmul_(&(&g * (1.0 - self.beta2)), &g);
                let denom = v.sqrt() / bc2_sqrt + self.eps;
                // torch: param + (value·exp_avg)/denom with value = −step_size.
                let _ = p.g_add_(&((&*m * -step_size) / denom));
            }
        });
    }
}
