//! PPO with Stable-Baselines3's semantics (docs/spec/rl-anchors.md §1): hyper-parameters and presets,
//! the per-minibatch loss, PyTorch's Adam and `clip_grad_norm_`.

use serde::{Deserialize, Serialize};
use tch::{Kind, Tensor};

use crate::PpoError;
use crate::normalize::NormalizeConfig;
use crate::policy::{ActorCritic, Hidden, ObsTensors};

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
    ) -> Result<Self, PpoError> {
        let base = Self::preset(preset).ok_or_else(|| {
            PpoError::config(
                "ppo.preset",
                format!("unknown preset `{preset}` (use one of {})", PRESETS.join(", ")),
            )
        })?;
        let mut v = serde_json::to_value(&base).map_err(|e| PpoError::config("ppo", e.to_string()))?;
        if let serde_json::Value::Object(map) = &mut v {
            for (k, val) in overrides {
                if !map.contains_key(k) {
                    return Err(PpoError::config(
                        format!("ppo.{k}"),
                        "unknown hyper-parameter (see `PpoConfig` in firecast-ppo)",
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
            .map_err(|e| PpoError::config(format!("ppo.{}", e.path()), e.inner().to_string()))?;
        cfg.validate()?;
        Ok(cfg)
    }

    pub fn buffer_size(&self) -> usize {
        self.n_envs * self.n_steps
    }

    pub fn validate(&self) -> Result<(), PpoError> {
        let bad = |k: &str, m: String| Err(PpoError::config(format!("ppo.{k}"), m));
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
        Ok(())
    }
}

/// A minibatch: observations as tensors (they go through the network), the per-sample
/// numbers on the host (see [`loss_gradients`]).
#[derive(Debug)]
pub struct PpoMinibatch {
    /// Rows are time-major sequences replayed through a recurrent policy (`None`: single
    /// transitions).
    pub sequences: Option<Sequences>,
    pub obs: ObsTensors,
    pub actions: Vec<u8>,
    pub old_values: Vec<f32>,
    pub old_log_probs: Vec<f32>,
    pub advantages: Vec<f32>,
    pub returns: Vec<f32>,
}

/// Sequences of a recurrent minibatch: `steps` steps of `hidden.h.size()[0]` sequences, the
/// state stored at each sequence's first step, and the episode-start mask (time-major).
#[derive(Debug)]
pub struct Sequences {
    pub hidden: Hidden,
    pub starts: Vec<f32>,
    pub steps: usize,
}

/// The loss settings of one update (SB3's names).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LossSettings {
    pub clip_range: f64,
    pub clip_range_vf: Option<f64>,
    pub ent_coef: f64,
    pub vf_coef: f64,
    pub normalize_advantage: bool,
}

/// The losses of one minibatch.
#[derive(Debug)]
pub struct Losses {
    /// A scalar whose gradient with respect to the parameters is the PPO loss's gradient:
    /// Σ logits·∂L/∂logits + Σ values·∂L/∂values (its value is not the loss: see
    /// `loss_value`).
    pub surrogate: Tensor,
    pub policy_loss: f64,
    pub value_loss: f64,
    pub entropy_loss: f64,
    pub approx_kl: f64,
    pub clip_fraction: f64,
    pub loss_value: f64,
    /// The policy's logits on the minibatch (part of the graph).
    pub logits: Tensor,
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
///
/// The loss's gradient with respect to the network's outputs is computed without autograd
/// ([`loss_gradients`]) and the parameters' gradient is that of [`Losses::surrogate`]: the
/// same numbers, to the bit, as autograd through SB3's expression, without the ~130 small
/// tensor operations of that graph.
pub fn ppo_losses(policy: &impl ActorCritic, mb: &PpoMinibatch, settings: &LossSettings) -> Losses {
    let (logits, values) = match &mb.sequences {
        None => policy.forward(&mb.obs, true),
        Some(seq) => {
            let (logits, values, _) = policy.sequence(&mb.obs, &seq.hidden, &seq.starts, seq.steps, true);
            (logits, values)
        }
    };
    let (out, g_logits, g_values) = loss_gradients(&logits, &values, mb, settings);
    let surrogate = (&logits * g_logits).sum(Kind::Float) + (&values * g_values).sum(Kind::Float);
    Losses {
        surrogate,
        policy_loss: out.policy_loss,
        value_loss: out.value_loss,
        entropy_loss: out.entropy_loss,
        approx_kl: out.approx_kl,
        clip_fraction: out.clip_fraction,
        loss_value: out.loss,
        logits,
    }
}

/// The PPO loss of network outputs and its gradient with respect to the log-probabilities
/// and the values.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputGradients {
    pub policy_loss: f64,
    pub value_loss: f64,
    pub entropy_loss: f64,
    pub approx_kl: f64,
    pub clip_fraction: f64,
    pub loss: f64,
    /// ∂loss/∂log-softmax(logits), n × actions row-major.
    pub grad_log_probs: Vec<f32>,
    /// ∂loss/∂values.
    pub grad_values: Vec<f32>,
}

/// The loss of `logits` (n × actions) and `values` (n) and its gradients with respect to
/// them (as tensors on their device), autograd's numbers without autograd. What autograd's
/// graph computes with transcendental functions or reductions (log-softmax, exp, the
/// advantages' mean and std, log-softmax's backward) is computed by the same torch kernels,
/// without a graph; the rest is IEEE elementwise arithmetic, on the host, in autograd's
/// order ([`output_gradients`]). The logged numbers (losses, KL, clip fraction) are means
/// accumulated in f64, so they may differ from torch's float32 means in the last bits (the
/// approx KL also decides SB3's early stop: only a KL within ~1e-7 of 1.5 × target_kl could
/// be decided the other way).
pub fn loss_gradients(
    logits: &Tensor,
    values: &Tensor,
    mb: &PpoMinibatch,
    s: &LossSettings,
) -> (OutputGradients, Tensor, Tensor) {
    let n = mb.actions.len();
    let a = logits.size().last().map_or(0, |&a| a as usize);
    let device = logits.device();
    let norm_adv = s.normalize_advantage && n > 1;
    let (lp, host) = tch::no_grad(|| {
        // No graph is recorded here, so nothing needs detaching.
        let lp = logits.log_softmax(-1, Kind::Float);
        let actions: Vec<i64> = mb.actions.iter().map(|&a| i64::from(a)).collect();
        let actions = on(Tensor::from_slice(&actions), device);
        let chosen = lp.gather(1, &actions.unsqueeze(1), false).squeeze_dim(1);
        let inputs = on(
            Tensor::from_slice(&[&mb.old_log_probs[..], &mb.advantages[..]].concat()),
            device,
        );
        let log_ratio = chosen - inputs.narrow(0, 0, n as i64);
        let ratio = log_ratio.exp();
        let adv = inputs.narrow(0, n as i64, n as i64);
        let mut parts = vec![lp.reshape([-1]), log_ratio, ratio, values.shallow_clone()];
        if norm_adv {
            parts.push(Tensor::stack(&[adv.mean(Kind::Float), adv.std(true)], 0));
        }
        if s.ent_coef != 0.0 {
            parts.push(lp.exp().reshape([-1]));
        }
        let host = Vec::<f32>::try_from(on(Tensor::cat(&parts, 0), tch::Device::Cpu)).unwrap_or_default();
        (lp, host)
    });
    let expected = n * a + 3 * n + if norm_adv { 2 } else { 0 } + if s.ent_coef != 0.0 { n * a } else { 0 };
    let out = if host.len() == expected {
        let (lp_h, rest) = host.split_at(n * a);
        let (lr, rest) = rest.split_at(n);
        let (ratio, rest) = rest.split_at(n);
        let (vals, rest) = rest.split_at(n);
        let (stats, probs) = rest.split_at(if norm_adv { 2 } else { 0 });
        let outputs = TorchOutputs {
            log_probs: lp_h,
            log_ratio: lr,
            ratio,
            values: vals,
            adv_mean_std: norm_adv.then(|| (stats[0], stats[1])),
            probs: (s.ent_coef != 0.0).then_some(probs),
        };
        output_gradients(&outputs, a, mb, s)
    } else {
        // Not reachable with a working libtorch; a NaN loss stops training with an error.
        OutputGradients {
            policy_loss: f64::NAN,
            value_loss: f64::NAN,
            entropy_loss: f64::NAN,
            approx_kl: f64::NAN,
            clip_fraction: f64::NAN,
            loss: f64::NAN,
            grad_log_probs: vec![0.0; n * a],
            grad_values: vec![0.0; n],
        }
    };
    let (g_logits, g_values) = tch::no_grad(|| {
        let g_lp = on(Tensor::from_slice(&out.grad_log_probs), device).view([n as i64, a as i64]);
        (
            Tensor::internal_log_softmax_backward_data(&g_lp, &lp, -1, Kind::Float),
            on(Tensor::from_slice(&out.grad_values), device),
        )
    });
    (out, g_logits, g_values)
}

/// `t` on `device` (no call at all when it is already there: these are per-minibatch).
fn on(t: Tensor, device: tch::Device) -> Tensor {
    if t.device() == device {
        t
    } else {
        t.to_device(device)
    }
}

/// Torch's numbers for one minibatch (see [`loss_gradients`]).
#[derive(Debug, Clone, Copy)]
pub struct TorchOutputs<'a> {
    /// log-softmax(logits), n × actions.
    pub log_probs: &'a [f32],
    /// log π(a|s) − old log π.
    pub log_ratio: &'a [f32],
    /// exp(log_ratio).
    pub ratio: &'a [f32],
    pub values: &'a [f32],
    /// The advantages' mean and unbiased std, when they are normalised.
    pub adv_mean_std: Option<(f32, f32)>,
    /// exp(log_probs), when the entropy bonus needs it.
    pub probs: Option<&'a [f32]>,
}

/// SB3's minibatch loss and autograd's gradient with respect to the log-probabilities and
/// values, in float32 and autograd's order: mean's backward −1/n, `minimum` splitting ties
/// in half, `clamp` passing the gradient inside its bounds (inclusive), exp's backward
/// grad·result, the entropy term's three contributions, MSE's (2/n)·(v − R)·grad.
pub fn output_gradients(
    t: &TorchOutputs<'_>,
    a: usize,
    mb: &PpoMinibatch,
    s: &LossSettings,
) -> OutputGradients {
    let n = mb.actions.len();
    let nf = n as f64;
    let adv: Vec<f32> = match t.adv_mean_std {
        Some((m, sd)) => mb.advantages.iter().map(|&x| (x - m) / (sd + 1e-8)).collect(),
        None => mb.advantages.clone(),
    };
    // torch's clamp is max(lo) then min(hi), so lo > hi (a schedule past its end) gives hi.
    let (lo, hi) = ((1.0 - s.clip_range) as f32, (1.0 + s.clip_range) as f32);
    let g_m = -1.0f32 / n as f32;
    // Entropy term: ent_coef·(−mean H), H = −Σ p·log p.
    let g_s = -((-(s.ent_coef as f32)) / n as f32);
    let mse = (2.0 / nf) as f32;
    let vf = s.vf_coef as f32;
    let mut grad_log_probs = vec![0f32; n * a];
    let mut grad_values = vec![0f32; n];
    let (mut pl, mut kl, mut clipped, mut vl, mut ent) = (0f64, 0f64, 0usize, 0f64, 0f64);
    for i in 0..n {
        let act = usize::from(mb.actions[i]);
        let lp = &t.log_probs[i * a..(i + 1) * a];
        let (lr, r) = (t.log_ratio[i], t.ratio[i]);
        let (pl1, pl2) = (adv[i] * r, adv[i] * r.max(lo).min(hi));
        pl += f64::from(pl1.min(pl2));
        kl += f64::from((r - 1.0) - lr);
        if (r - 1.0).abs() > s.clip_range as f32 {
            clipped += 1;
        }
        ent -= lp.iter().map(|&l| f64::from(l.exp() * l)).sum::<f64>();
        let (g1, g2) = if pl1 < pl2 {
            (g_m, 0.0)
        } else if pl1 == pl2 {
            (g_m / 2.0, g_m / 2.0)
        } else {
            (0.0, g_m)
        };
        let g_r1 = g1 * adv[i];
        let g_r2 = if (lo..=hi).contains(&r) { g2 * adv[i] } else { 0.0 };
        let g_lp = (g_r1 + g_r2) * r;
        let row = &mut grad_log_probs[i * a..(i + 1) * a];
        row[act] = g_lp;
        if let Some(p) = t.probs {
            let p = &p[i * a..(i + 1) * a];
            for k in 0..a {
                // Autograd sums the product's two terms first, then the chosen action's.
                row[k] += g_s * p[k] + (g_s * lp[k]) * p[k];
            }
        }
        let (vp, pass) = match s.clip_range_vf {
            None => (t.values[i], true),
            Some(c) => {
                let c = c as f32;
                let d = t.values[i] - mb.old_values[i];
                (mb.old_values[i] + d.max(-c).min(c), (-c..=c).contains(&d))
            }
        };
        let diff = vp - mb.returns[i];
        vl += f64::from(diff * diff);
        grad_values[i] = if pass { mse * diff * vf } else { 0.0 };
    }
    let policy_loss = -pl / nf;
    let value_loss = vl / nf;
    let entropy_loss = -ent / nf;
    OutputGradients {
        policy_loss,
        value_loss,
        entropy_loss,
        approx_kl: kl / nf,
        clip_fraction: clipped as f64 / nf,
        loss: policy_loss + s.ent_coef * entropy_loss + s.vf_coef * value_loss,
        grad_log_probs,
        grad_values,
    }
}

/// PyTorch's Adam (single-tensor implementation, no weight decay, no AMSGrad) and
/// `clip_grad_norm_`, with the moments in the open so checkpoints hold them.
///
/// The parameters are moved into one flat buffer (each variable becomes a view of it) and the
/// moments and the gradient are flat too, so a step is ten elementwise operations over the
/// buffer instead of ten per parameter tensor: elementwise, so every parameter gets exactly
/// the arithmetic it got one tensor at a time.
#[derive(Debug)]
pub struct Adam {
    /// The trainable variables (views of the flat buffer).
    pub params: Vec<Tensor>,
    /// Per-parameter views of the moments (checkpoints).
    pub exp_avg: Vec<Tensor>,
    pub exp_avg_sq: Vec<Tensor>,
    flat: Tensor,
    m: Tensor,
    v: Tensor,
    /// The last gradient ([`Adam::gradients`]) and its per-parameter views.
    grad: Tensor,
    grad_views: Vec<Tensor>,
    pub step: u64,
    pub beta1: f64,
    pub beta2: f64,
    pub eps: f64,
}

/// Views of `flat` shaped as `params`, in order.
fn views_like(flat: &Tensor, params: &[Tensor]) -> Vec<Tensor> {
    let mut off = 0;
    params
        .iter()
        .map(|p| {
            let n = p.numel() as i64;
            let v = flat.narrow(0, off, n).view(p.size().as_slice());
            off += n;
            v
        })
        .collect()
}

impl Adam {
    /// Takes the parameters over: their values are copied into one buffer and each variable
    /// is rebound to its slice (it stays the same variable for autograd and the VarStore).
    pub fn new(mut params: Vec<Tensor>, eps: f64) -> Self {
        let total: i64 = params.iter().map(|p| p.numel() as i64).sum();
        let opts = params
            .first()
            .map_or((Kind::Float, tch::Device::Cpu), |p| (p.kind(), p.device()));
        let flat = Tensor::zeros([total], opts);
        let views = views_like(&flat, &params);
        tch::no_grad(|| {
            for (p, v) in params.iter_mut().zip(&views) {
                let mut v = v.shallow_clone();
                v.copy_(p);
                // One at a time, so at most one parameter is held twice.
                p.set_data(&v);
            }
        });
        let m = Tensor::zeros([total], opts);
        let v = Tensor::zeros([total], opts);
        let grad = Tensor::zeros([total], opts);
        Self {
            exp_avg: views_like(&m, &params),
            exp_avg_sq: views_like(&v, &params),
            grad_views: views_like(&grad, &params),
            params,
            flat,
            m,
            v,
            grad,
            step: 0,
            beta1: 0.9,
            beta2: 0.999,
            eps,
        }
    }

    /// d loss / d params into the flat gradient buffer ([`Adam::gradient`]), without
    /// touching the parameters' `.grad`, so there is nothing to zero between steps. A
    /// parameter the loss does not use gets 0.
    pub fn gradients(&mut self, loss: &Tensor) -> Result<(), PpoError> {
        let grads = Tensor::f_run_backward(&[loss], &self.params, false, false)?;
        let parts: Vec<Tensor> = grads
            .iter()
            .zip(&self.params)
            .map(|(g, p)| {
                if g.defined() {
                    g.reshape([-1])
                } else {
                    p.zeros_like().reshape([-1])
                }
            })
            .collect();
        let _ = tch::no_grad(|| Tensor::f_cat_out(&self.grad, &parts, 0))?;
        Ok(())
    }

    /// The flat gradient buffer (clipped in place by [`Adam::clip_grad_norm`]).
    pub fn gradient(&self) -> &Tensor {
        &self.grad
    }

    /// Per-parameter views of a flat tensor (tests, diagnostics).
    pub fn unflatten(&self, flat: &Tensor) -> Vec<Tensor> {
        views_like(flat, &self.params)
    }

    /// PyTorch's `clip_grad_norm_` (L2, global) on the gradient buffer: total =
    /// ‖(‖g₁‖, …, ‖gₙ‖)‖ over the parameters, every gradient multiplied by
    /// min(1, max/(total + 1e-6)). Returns the total norm before clipping. The per-parameter
    /// norms are kept (not one norm of the flat buffer) so the coefficient is torch's to the bit.
    pub fn clip_grad_norm(&mut self, max_norm: f64) -> f64 {
        tch::no_grad(|| {
            if self.grad_views.is_empty() {
                return 0.0;
            }
            let norms: Vec<Tensor> = self.grad_views.iter().map(Tensor::norm).collect();
            let total = f32::try_from(Tensor::stack(&norms, 0).norm()).unwrap_or(f32::NAN);
            // In float32 as tch's `max_norm / (total + 1e-6)` computes it:
            // ((total + 1e-6) / max_norm)^−1, then clamped at 1.
            let coef = (1.0 / ((total + 1e-6) / max_norm as f32)).min(1.0);
            let _ = self.grad.g_mul_scalar_(f64::from(coef));
            f64::from(total)
        })
    }

    /// Forgets the moments and the step count (a fresh optimiser on the same parameters).
    pub fn reset_moments(&mut self) {
        tch::no_grad(|| {
            let _ = self.m.zero_();
            let _ = self.v.zero_();
        });
        self.step = 0;
    }

    /// One step with the gradient buffer.
    pub fn step(&mut self, lr: f64) {
        self.step += 1;
        let t = self.step as i32;
        let bc1 = 1.0 - self.beta1.powi(t);
        let bc2_sqrt = (1.0 - self.beta2.powi(t)).sqrt();
        let step_size = lr / bc1;
        tch::no_grad(|| {
            let g = &self.grad;
            let _ = self.m.lerp_(g, 1.0 - self.beta1);
            let _ = self.v.g_mul_scalar_(self.beta2);
            let _ = self.v.addcmul_(&(g * (1.0 - self.beta2)), g);
            let mut denom = self.v.sqrt();
            let _ = denom.g_div_scalar_(bc2_sqrt).g_add_scalar_(self.eps);
            // torch: param.addcdiv_(exp_avg, denom, value=−step_size).
            let mut update = &self.m * -step_size;
            let _ = update.g_div_(&denom);
            let _ = self.flat.g_add_(&update);
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn batch(n: usize) -> PpoMinibatch {
        let f = |k: usize, s: f32| {
            (0..n)
                .map(|i| ((i * k) % 7) as f32 * s - 0.3)
                .collect::<Vec<f32>>()
        };
        PpoMinibatch {
            sequences: None,
            obs: ObsTensors {
                image: None,
                vector: Tensor::zeros([n as i64, 1], (Kind::Float, tch::Device::Cpu)),
            },
            actions: (0..n).map(|i| (i % 3) as u8).collect(),
            old_values: f(3, 0.2),
            old_log_probs: (0..n).map(|i| -1.0 - 0.05 * i as f32).collect(),
            advantages: f(5, 0.4),
            returns: f(2, 0.3),
        }
    }

    fn loss_of(
        logits: &[f32],
        a: usize,
        values: &[f32],
        mb: &PpoMinibatch,
        s: &LossSettings,
    ) -> (OutputGradients, Vec<f32>, Vec<f32>) {
        let n = values.len() as i64;
        let l = Tensor::from_slice(logits).view([n, a as i64]);
        let v = Tensor::from_slice(values);
        let (out, gl, gv) = loss_gradients(&l, &v, mb, s);
        let gl = Vec::<f32>::try_from(gl.reshape([-1])).expect("logit gradients");
        let gv = Vec::<f32>::try_from(gv).expect("value gradients");
        (out, gl, gv)
    }

    /// SB3's loss expression in torch, differentiated by autograd (what this crate did before
    /// `loss_gradients`): the gradients with respect to the logits and values.
    fn autograd(
        logits: &Tensor,
        values: &Tensor,
        mb: &PpoMinibatch,
        s: &LossSettings,
    ) -> (Vec<f32>, Vec<f32>) {
        let (logits, values) = (
            logits.detach().set_requires_grad(true),
            values.detach().set_requires_grad(true),
        );
        let t = |v: &[f32]| Tensor::from_slice(v);
        let actions = Tensor::from_slice(&mb.actions).to_kind(Kind::Int64);
        let (logp, entropy) = log_prob_entropy(&logits, &actions);
        let adv = t(&mb.advantages);
        let adv = (&adv - adv.mean(Kind::Float)) / (adv.std(true) + 1e-8);
        let ratio = (&logp - t(&mb.old_log_probs)).exp();
        let pl1 = &adv * &ratio;
        let pl2 = &adv * ratio.clamp(1.0 - s.clip_range, 1.0 + s.clip_range);
        let policy_loss = -pl1.minimum(&pl2).mean(Kind::Float);
        let old = t(&mb.old_values);
        let vp = match s.clip_range_vf {
            None => values.shallow_clone(),
            Some(c) => &old + (&values - &old).clamp(-c, c),
        };
        let value_loss = vp.mse_loss(&t(&mb.returns), tch::Reduction::Mean);
        let entropy_loss = -entropy.mean(Kind::Float);
        let loss = &policy_loss + s.ent_coef * &entropy_loss + s.vf_coef * &value_loss;
        let g = Tensor::run_backward(&[&loss], &[&logits, &values], false, false);
        (
            Vec::<f32>::try_from(g[0].reshape([-1])).expect("autograd logits"),
            Vec::<f32>::try_from(&g[1]).expect("autograd values"),
        )
    }

    /// `loss_gradients` gives autograd's numbers, bit for bit, with and without the entropy
    /// bonus and value clipping (so training is unchanged by not building the graph).
    #[test]
    fn output_gradients_equal_autograd_bit_for_bit() {
        tch::set_num_threads(1);
        for (n, a, ent_coef, clip_range_vf) in [
            (256, 2, 0.0, None),
            (16, 5, 0.2, None),
            (64, 5, 0.2, Some(0.1)),
            (100, 3, 0.05, None),
        ] {
            tch::manual_seed(n);
            let opts = (Kind::Float, tch::Device::Cpu);
            let logits = Tensor::randn([n, a], opts) * 0.5;
            let values = Tensor::randn([n], opts);
            let v = |t: Tensor| Vec::<f32>::try_from(t).expect("tensor");
            let mb = PpoMinibatch {
                sequences: None,
                obs: ObsTensors {
                    image: None,
                    vector: Tensor::zeros([n, 1], opts),
                },
                actions: (0..n).map(|i| (i * 7 % a) as u8).collect(),
                old_values: v(Tensor::randn([n], opts)),
                old_log_probs: v(Tensor::randn([n], opts) * 0.05 - 0.7),
                advantages: v(Tensor::randn([n], opts)),
                returns: v(Tensor::randn([n], opts)),
            };
            let s = LossSettings {
                clip_range: 0.2,
                clip_range_vf,
                ent_coef,
                vf_coef: 0.5,
                normalize_advantage: true,
            };
            let (gl, gv) = autograd(&logits, &values, &mb, &s);
            let (_, hl, hv) = loss_gradients(&logits, &values, &mb, &s);
            let bits = |x: &[f32], y: &[f32]| {
                x.iter()
                    .zip(y)
                    .filter(|(a, b)| a.to_bits() != b.to_bits())
                    .count()
            };
            assert_eq!(
                bits(&gl, &v(hl.reshape([-1]))),
                0,
                "logits, case n={n} a={a} ent={ent_coef}"
            );
            assert_eq!(bits(&gv, &v(hv)), 0, "values, case n={n} a={a} ent={ent_coef}");
        }
    }

    /// The gradient is the loss's derivative: central differences agree.
    #[test]
    fn output_gradients_match_finite_differences() {
        let (n, a) = (6, 3);
        let mb = batch(n);
        let s = LossSettings {
            clip_range: 0.2,
            clip_range_vf: Some(0.15),
            ent_coef: 0.1,
            vf_coef: 0.5,
            normalize_advantage: true,
        };
        let logits: Vec<f32> = (0..n * a).map(|k| ((k * 5) % 11) as f32 * 0.07 - 0.35).collect();
        let values: Vec<f32> = (0..n).map(|i| 0.1 * i as f32 - 0.2).collect();
        let (_, gl, gv) = loss_of(&logits, a, &values, &mb, &s);
        let h = 1e-3f32;
        let fd = |l: &[f32], v: &[f32], l2: &[f32], v2: &[f32]| {
            (loss_of(l, a, v, &mb, &s).0.loss - loss_of(l2, a, v2, &mb, &s).0.loss) / (2.0 * f64::from(h))
        };
        for k in 0..n * a {
            let (mut up, mut down) = (logits.clone(), logits.clone());
            up[k] += h;
            down[k] -= h;
            let d = fd(&up, &values, &down, &values);
            assert!((d - f64::from(gl[k])).abs() < 2e-3, "logit {k}: {d} vs {}", gl[k]);
        }
        for i in 0..n {
            let (mut up, mut down) = (values.clone(), values.clone());
            up[i] += h;
            down[i] -= h;
            let d = fd(&logits, &up, &logits, &down);
            assert!((d - f64::from(gv[i])).abs() < 2e-3, "value {i}: {d} vs {}", gv[i]);
        }
    }

    /// A linear clip schedule run past its end has clip < 0: torch's clamp then gives the
    /// upper bound everywhere and passes no gradient (no panic, as f32::clamp would).
    #[test]
    fn a_negative_clip_range_clamps_like_torch() {
        let (n, a) = (4, 3);
        let mut mb = batch(n);
        mb.advantages = vec![1.0, 2.0, 3.0, 4.0];
        mb.old_log_probs = vec![(1.0f32 / 3.0).ln(); n];
        let s = LossSettings {
            clip_range: -0.01,
            clip_range_vf: None,
            ent_coef: 0.0,
            vf_coef: 0.5,
            normalize_advantage: false,
        };
        let (g, gl, _) = loss_of(&vec![0.0; n * a], a, &vec![0.0; n], &mb, &s);
        // ratio 1 > hi = 0.99: every minimum is the clamped term, whose gradient is masked.
        assert!(gl.iter().all(|&x| x == 0.0), "{gl:?}");
        assert!((g.policy_loss + 0.99 * 2.5).abs() < 1e-6, "{}", g.policy_loss);
        assert_eq!(
            g.clip_fraction, 1.0,
            "|r − 1| > a negative clip everywhere, as in torch"
        );
    }
}
