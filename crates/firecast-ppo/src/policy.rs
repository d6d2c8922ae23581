//! The parts of an actor-critic network that PPO itself handles, whatever the network:
//! observations as tensors, a recurrent policy's state, SB3's MLP building blocks, and
//! [`ActorCritic`], what the loss and the trainer ask of a policy.

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use tch::nn::{self, Module};
use tch::{Device, Tensor};

use crate::PpoError;
use crate::env::{ObsBatch, ObsSpace};

/// What PPO's loss and trainer ask of a policy network: its outputs on a batch, with or
/// without memory, and its parameters (the optimiser's and checkpoints').
pub trait ActorCritic {
    /// The settings that built it ([`PolicySpec`]), as checkpoints store them.
    type Spec: PolicySpec<Policy = Self>;
    fn spec(&self) -> &Self::Spec;
    /// The observations it reads.
    fn space(&self) -> ObsSpace;
    fn num_actions(&self) -> usize;
    fn var_store(&self) -> &nn::VarStore;
    fn var_store_mut(&mut self) -> &mut nn::VarStore;
    fn device(&self) -> Device;
    /// Action logits `[n, actions]` and values `[n]` of a policy without memory (a recurrent
    /// one would run from a zero state: use [`sequence`](Self::sequence)).
    fn forward(&self, obs: &ObsTensors, train: bool) -> (Tensor, Tensor);
    /// Values `[n]` alone.
    fn values(&self, obs: &ObsTensors) -> Tensor;
    /// `t` steps of `n` environments, time-major (row `k·n + i` is step `k` of environment
    /// `i`), from `hidden`, resetting the state of every environment whose `starts[k·n + i]`
    /// is 1 before step `k`: the logits `[t·n, actions]`, the values `[t·n]` and the state
    /// after the last step. Without memory it is [`forward`](Self::forward) and `hidden`
    /// comes back unchanged.
    fn sequence(
        &self,
        obs: &ObsTensors,
        hidden: &Hidden,
        starts: &[f32],
        t: usize,
        train: bool,
    ) -> (Tensor, Tensor, Hidden);
    /// Whether it carries a state from step to step (trained on sequences of [`SEQUENCE`]).
    fn is_recurrent(&self) -> bool;
    /// Length of one environment's row of [`Hidden::to_host`]; 0 without memory.
    fn hidden_len(&self) -> usize;
    /// The zero state of `n` environments, if it is recurrent.
    fn initial_hidden(&self, n: usize) -> Option<Hidden>;
}

/// A policy's settings: what a checkpoint stores of it and what builds it again.
pub trait PolicySpec: Clone + Serialize + DeserializeOwned {
    type Policy: ActorCritic<Spec = Self>;
    /// A network for observations `space` and `num_actions` actions, its weights drawn from
    /// torch's generator (the trainer seeds it first).
    fn build(&self, space: ObsSpace, num_actions: usize, device: Device) -> Result<Self::Policy, PpoError>;
}

/// Steps per training sequence of a recurrent policy: minibatches are `batch_size / SEQUENCE`
/// sequences, each replayed from the LSTM state stored at its first step.
pub const SEQUENCE: usize = 16;

/// LSTM state `(h, c)` of `n` environments, each `[n, hidden]` on the policy's device.
#[derive(Debug)]
pub struct Hidden {
    pub h: Tensor,
    pub c: Tensor,
}

impl Hidden {
    /// Rows `rows` (a sub-batch).
    pub fn select(&self, rows: &[usize]) -> Self {
        let idx = index_tensor(rows, self.h.device());
        Self {
            h: self.h.index_select(0, &idx),
            c: self.c.index_select(0, &idx),
        }
    }

    /// Writes `other`'s rows into rows `rows`.
    pub fn scatter(&mut self, rows: &[usize], other: &Hidden) {
        let idx = index_tensor(rows, self.h.device());
        let _ = self.h.index_copy_(0, &idx, &other.h);
        let _ = self.c.index_copy_(0, &idx, &other.c);
    }

    /// `[n, 2·hidden]` on the host (h then c per row), for the rollout buffer and checkpoints.
    pub fn to_host(&self) -> Vec<f32> {
        let both = Tensor::cat(&[&self.h, &self.c], 1).to_device(Device::Cpu);
        Vec::<f32>::try_from(both.flatten(0, -1)).unwrap_or_default()
    }

    /// The inverse of [`to_host`](Self::to_host).
    pub fn from_host(data: &[f32], n: usize, device: Device) -> Self {
        let both = Tensor::from_slice(data).view([n as i64, -1]).to_device(device);
        let hidden = both.size()[1] / 2;
        Self {
            h: both.narrow(1, 0, hidden),
            c: both.narrow(1, hidden, hidden),
        }
    }
}

fn index_tensor(rows: &[usize], device: Device) -> Tensor {
    let rows: Vec<i64> = rows.iter().map(|&r| r as i64).collect();
    Tensor::from_slice(&rows).to_device(device)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Activation {
    Tanh,
    Relu,
}

impl Activation {
    pub fn apply(self, x: &Tensor) -> Tensor {
        match self {
            Self::Tanh => x.tanh(),
            Self::Relu => x.relu(),
        }
    }
}

/// Observations as tensors: the image part as u8 (converted inside the extractor).
#[derive(Debug)]
pub struct ObsTensors {
    pub image: Option<Tensor>,
    pub vector: Tensor,
}

impl ObsTensors {
    pub fn from_batch(b: &ObsBatch, device: Device) -> Self {
        let n = b.n as i64;
        // Per step and minibatch: no `to_device` call at all on the CPU.
        let on = |t: Tensor| {
            if device == Device::Cpu {
                t
            } else {
                t.to_device(device)
            }
        };
        let image = b
            .space
            .image
            .map(|[c, h, w]| on(Tensor::from_slice(&b.image).view([n, c as i64, h as i64, w as i64])));
        let vector = on(Tensor::from_slice(&b.vector).view([n, b.space.vector as i64]));
        Self { image, vector }
    }
}

/// A linear layer; with `gain`, SB3's orthogonal initialisation (biases 0).
pub fn linear(p: nn::Path<'_>, i: i64, o: i64, gain: Option<f64>) -> nn::Linear {
    let cfg = match gain {
        Some(gain) => nn::LinearConfig {
            ws_init: nn::Init::Orthogonal { gain },
            bs_init: Some(nn::Init::Const(0.0)),
            bias: true,
        },
        None => nn::LinearConfig::default(),
    };
    nn::linear(p, i, o, cfg)
}

/// An MLP of `sizes` with `activation` after every layer (SB3's `mlp_extractor` nets).
#[derive(Debug)]
pub struct Mlp {
    layers: Vec<nn::Linear>,
    activation: Activation,
}

impl Mlp {
    /// Layers are named 0, 2, 4, … as in SB3's `nn.Sequential` (activations take odd slots).
    pub fn new(
        p: nn::Path<'_>,
        input: i64,
        sizes: &[i64],
        activation: Activation,
        gain: Option<f64>,
    ) -> (Self, i64) {
        let mut layers = Vec::new();
        let mut last = input;
        for (k, &s) in sizes.iter().enumerate() {
            layers.push(linear(&p / (2 * k).to_string(), last, s, gain));
            last = s;
        }
        (Self { layers, activation }, last)
    }
    pub fn forward(&self, x: &Tensor) -> Tensor {
        let mut h = x.shallow_clone();
        for l in &self.layers {
            h = self.activation.apply(&l.forward(&h));
        }
        h
    }
}

/// SB3's heads after a features extractor: the policy and value MLPs (`mlp_extractor`'s
/// `policy_net` and `value_net`), then `action_net` and `value_net`; with `ortho`, SB3's gains
/// (MLPs √2, `action_net` 0.01, `value_net` 1, biases 0).
#[derive(Debug)]
pub struct Heads {
    pi: Mlp,
    vf: Mlp,
    action_net: nn::Linear,
    value_net: nn::Linear,
}

impl Heads {
    /// The heads under `root`, on `features` inputs, drawn in SB3's order (after the
    /// extractor's weights).
    pub fn new(
        root: &nn::Path<'_>,
        features: i64,
        pi: &[i64],
        vf: &[i64],
        activation: Activation,
        ortho: bool,
        num_actions: usize,
    ) -> Self {
        let g = |gain: f64| ortho.then_some(gain);
        let sqrt2 = std::f64::consts::SQRT_2;
        let me = root / "mlp_extractor";
        let (pi, pi_out) = Mlp::new(&me / "policy_net", features, pi, activation, g(sqrt2));
        let (vf, vf_out) = Mlp::new(&me / "value_net", features, vf, activation, g(sqrt2));
        let action_net = linear(root / "action_net", pi_out, num_actions as i64, g(0.01));
        let value_net = linear(root / "value_net", vf_out, 1, g(1.0));
        Self {
            pi,
            vf,
            action_net,
            value_net,
        }
    }

    /// Action logits `[n, actions]` and values `[n]` of features `[n, features]`.
    pub fn forward(&self, f: &Tensor) -> (Tensor, Tensor) {
        let logits = self.action_net.forward(&self.pi.forward(f));
        let values = self.value_net.forward(&self.vf.forward(f)).squeeze_dim(-1);
        (logits, values)
    }

    /// Values `[n]` alone.
    pub fn values(&self, f: &Tensor) -> Tensor {
        self.value_net.forward(&self.vf.forward(f)).squeeze_dim(-1)
    }
}

/// Settings of [`MlpPolicy`] (SB3's `MlpPolicy`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MlpConfig {
    /// Hidden sizes of the policy MLP.
    pub pi: Vec<i64>,
    /// Hidden sizes of the value MLP.
    pub vf: Vec<i64>,
    pub activation: Activation,
    pub ortho_init: bool,
}

impl Default for MlpConfig {
    fn default() -> Self {
        Self {
            pi: vec![64, 64],
            vf: vec![64, 64],
            activation: Activation::Tanh,
            ortho_init: true,
        }
    }
}

/// SB3's `MlpPolicy`: the flattened vector observation straight into [`Heads`]. Parameter
/// names follow SB3's `state_dict`, so SB3 weights load directly.
#[derive(Debug)]
pub struct MlpPolicy {
    pub config: MlpConfig,
    pub space: ObsSpace,
    pub num_actions: usize,
    pub vs: nn::VarStore,
    heads: Heads,
}

impl MlpPolicy {
    pub fn new(
        config: &MlpConfig,
        space: ObsSpace,
        num_actions: usize,
        device: Device,
    ) -> Result<Self, PpoError> {
        if space.image.is_some() {
            return Err(PpoError::config(
                "policy",
                "the MLP policy takes vector observations, not images",
            ));
        }
        let vs = nn::VarStore::new(device);
        let heads = Heads::new(
            &vs.root(),
            space.vector as i64,
            &config.pi,
            &config.vf,
            config.activation,
            config.ortho_init,
            num_actions,
        );
        Ok(Self {
            config: config.clone(),
            space,
            num_actions,
            vs,
            heads,
        })
    }
}

impl PolicySpec for MlpConfig {
    type Policy = MlpPolicy;
    fn build(&self, space: ObsSpace, num_actions: usize, device: Device) -> Result<MlpPolicy, PpoError> {
        MlpPolicy::new(self, space, num_actions, device)
    }
}

impl ActorCritic for MlpPolicy {
    type Spec = MlpConfig;
    fn spec(&self) -> &MlpConfig {
        &self.config
    }
    fn space(&self) -> ObsSpace {
        self.space
    }
    fn num_actions(&self) -> usize {
        self.num_actions
    }
    fn var_store(&self) -> &nn::VarStore {
        &self.vs
    }
    fn var_store_mut(&mut self) -> &mut nn::VarStore {
        &mut self.vs
    }
    fn device(&self) -> Device {
        self.vs.device()
    }
    fn forward(&self, obs: &ObsTensors, _train: bool) -> (Tensor, Tensor) {
        self.heads.forward(&obs.vector)
    }
    fn values(&self, obs: &ObsTensors) -> Tensor {
        self.heads.values(&obs.vector)
    }
    fn sequence(
        &self,
        obs: &ObsTensors,
        hidden: &Hidden,
        _starts: &[f32],
        _t: usize,
        _train: bool,
    ) -> (Tensor, Tensor, Hidden) {
        let (logits, values) = self.heads.forward(&obs.vector);
        let same = Hidden {
            h: hidden.h.shallow_clone(),
            c: hidden.c.shallow_clone(),
        };
        (logits, values, same)
    }
    fn is_recurrent(&self) -> bool {
        false
    }
    fn hidden_len(&self) -> usize {
        0
    }
    fn initial_hidden(&self, _n: usize) -> Option<Hidden> {
        None
    }
}
