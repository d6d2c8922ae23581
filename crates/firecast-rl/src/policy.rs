//! Actor-critic policies with SB3's `ActorCriticPolicy` layout: a shared features extractor,
//! separate policy and value MLPs (`pi`, `vf`, Tanh by default), `action_net` and `value_net`;
//! orthogonal initialisation with SB3's gains (extractor and MLPs √2, `action_net` 0.01,
//! `value_net` 1, biases 0). Parameter names follow SB3's `state_dict`, so SB3 weights load
//! directly (golden tests).
//!
//! - `mlp`: flattened vector observations (CartPole).
//! - `compact` (helitack default): the authors' three convolution branches and spatial
//!   attention on a 2×-pooled input, then a 1×1 reduction and average pooling to 2,400
//!   features, fused with the helicopter vector; a frame stack instead of the LSTM.
//! - `paper`: the authors' `FireEnvLSTMCNN` as specified (docs/spec/learning.md §3.1), with the
//!   275,515,392-parameter LSTM input projection.

use firecast_learn::layers::{Cell, Recurrent};
use firecast_ppo::PpoError;
use firecast_ppo::env::ObsSpace;
use firecast_ppo::policy::{Activation, ActorCritic, Heads, Hidden, ObsTensors, PolicySpec, linear};
use serde::{Deserialize, Serialize};
use tch::nn::{self, Module, ModuleT};
use tch::{Device, Kind, Tensor};

use crate::RlError;

/// Which policy network.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PolicyKind {
    Mlp,
    Compact,
    Paper,
}

/// Policy settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PolicyConfig {
    pub kind: PolicyKind,
    /// Hidden sizes of the policy MLP after the extractor.
    pub pi: Vec<i64>,
    /// Hidden sizes of the value MLP.
    pub vf: Vec<i64>,
    pub activation: Activation,
    pub ortho_init: bool,
    /// Batch normalisation in the convolution branches (the authors' extractor has it; off
    /// in `compact` because rollouts run it in eval mode and updates in train mode, so the
    /// PPO ratio starts away from 1).
    pub batch_norm: bool,
    /// What the `compact` extractor looks at: the whole map as observed (`map`) or the map
    /// re-centred on the helicopter (`helicopter`), so "flames to the left" reads the same
    /// wherever the helicopter is.
    #[serde(skip_serializing_if = "View::is_map")]
    pub view: View,
    /// Radius in cells of a full-resolution window around the helicopter (`view:
    /// helicopter` only; 0 = none): the newest frame's fire states there (unburnt, burning,
    /// burnt, one-hot) feed the fusion layer directly, because the pooled branches blur
    /// where the nearest flames are to a few cells' precision, which is what a drop needs.
    #[serde(skip_serializing_if = "firecast_ppo::train::is_zero")]
    pub focus: u32,
    /// `[rows, columns]` of the helicopter view (`view: helicopter` only; none = the map's
    /// size): the extractor sees this many cells around the helicopter whatever the map, and
    /// not the helicopter's map coordinates, so a policy trained on one map size plays any
    /// other at the same scale, and its network costs the same on a 240 × 160 map as on a
    /// 96 × 64 one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub window: Option<[u32; 2]>,
    /// With a `window`: k > 0 adds a coarse view of k × k times the window's area around the
    /// helicopter, the newest frame's burning and burnt cells as fractions of each k × k block,
    /// on the window's grid, so flames beyond the window still show where they are.
    #[serde(skip_serializing_if = "firecast_ppo::train::is_zero")]
    pub context: u32,
    /// How the `compact` policy remembers: the environment's frame stack (`frames`), or an
    /// LSTM over the newest frame (`lstm`: recurrent PPO, trained on sequences of
    /// [`SEQUENCE`](firecast_ppo::policy::SEQUENCE) steps from the states the rollout stored).
    #[serde(skip_serializing_if = "Memory::is_frames")]
    pub memory: Memory,
    /// `compact` only: the offset and distance from the helicopter to the nearest burning
    /// cell of the whole map (the newest frame; nearest by squared distance, then lowest
    /// cell index), what the chaser steers by, so a student can copy its teacher exactly
    /// and learn only where to differ. A pooled image places flames to a few cells at best.
    #[serde(skip_serializing_if = "is_false")]
    pub nearest_flames: bool,
}

fn is_false(b: &bool) -> bool {
    !*b
}

/// What the compact policy remembers the fire's past with.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Memory {
    /// All frames of the observation's stack.
    #[default]
    Frames,
    /// The newest frame and an LSTM (hidden size 256) after the extractor.
    Lstm,
}

impl Memory {
    fn is_frames(&self) -> bool {
        *self == Memory::Frames
    }
}

/// The frame of reference of the image the extractor sees.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum View {
    /// The observation as the environment gives it.
    #[default]
    Map,
    /// Shifted so the helicopter sits at the centre (row H/2, column W/2); cells beyond the
    /// map read 0, the code of non-burnable cells.
    Helicopter,
}

impl View {
    fn is_map(&self) -> bool {
        *self == View::Map
    }
}

impl Default for PolicyConfig {
    fn default() -> Self {
        Self {
            kind: PolicyKind::Mlp,
            pi: vec![64, 64],
            vf: vec![64, 64],
            activation: Activation::Tanh,
            ortho_init: true,
            batch_norm: false,
            view: View::Map,
            focus: 0,
            window: None,
            context: 0,
            memory: Memory::Frames,
            nearest_flames: false,
        }
    }
}

fn conv(p: nn::Path<'_>, i: i64, o: i64, k: i64, stride: i64, padding: i64, gain: Option<f64>) -> nn::Conv2D {
    let mut cfg = nn::ConvConfig {
        stride,
        padding,
        ..Default::default()
    };
    if gain.is_some() {
        cfg.bs_init = nn::Init::Const(0.0);
    }
    let mut c = nn::conv2d(p, i, o, k, cfg);
    // tch's Orthogonal creates a 2-D tensor: build the 4-D weight, then fill it in place
    // (torch's orthogonal_ on the weight flattened to [out, in·k·k], as SB3 does).
    if let Some(gain) = gain {
        nn::Init::Orthogonal { gain }.set(&mut c.ws);
    }
    c
}

/// A conv branch step: Conv → (BN) → ReLU.
#[derive(Debug)]
struct ConvBlock {
    conv: nn::Conv2D,
    bn: Option<nn::BatchNorm>,
}

impl ConvBlock {
    #[allow(clippy::too_many_arguments)]
    fn new(
        p: &nn::Path<'_>,
        name: usize,
        i: i64,
        o: i64,
        k: i64,
        s: i64,
        pad: i64,
        bn: bool,
        gain: Option<f64>,
    ) -> Self {
        // Named as SB3 would see an nn.Sequential: conv at `name`, BN at `name + 1`.
        let conv = conv(p / name.to_string(), i, o, k, s, pad, gain);
        let bn = bn.then(|| nn::batch_norm2d(p / (name + 1).to_string(), o, Default::default()));
        Self { conv, bn }
    }
    fn forward(&self, x: &Tensor, train: bool) -> Tensor {
        let h = self.conv.forward(x);
        let h = match &self.bn {
            Some(bn) => bn.forward_t(&h, train),
            None => h,
        };
        h.relu()
    }
}

/// The authors' three-branch trunk with spatial attention (docs/spec/learning.md §3.1).
#[derive(Debug)]
struct Trunk {
    a: [ConvBlock; 2],
    b: [ConvBlock; 2],
    c: [ConvBlock; 2],
    att1: nn::Conv2D,
    att_bn: Option<nn::BatchNorm>,
    att2: nn::Conv2D,
    /// Output size of branches a and b (branch c is upsampled to it).
    size: [i64; 2],
    pool_input: bool,
}

impl Trunk {
    /// `widths` = channels of (a1, a2, b1, b2, c1, c2); the attention's middle width is 32.
    fn new(
        p: nn::Path<'_>,
        c_in: i64,
        hw: [i64; 2],
        widths: [i64; 6],
        bn: bool,
        pool_input: bool,
        gain: Option<f64>,
    ) -> (Self, i64) {
        let [a1, a2, b1, b2, c1, c2] = widths;
        let pa = &p / "branch_a";
        let pb = &p / "branch_b";
        let pc = &p / "branch_c";
        let step = if bn { 3 } else { 2 };
        let a = [
            ConvBlock::new(&pa, 0, c_in, a1, 3, 1, 1, bn, gain),
            ConvBlock::new(&pa, step + 1, a1, a2, 3, 1, 1, bn, gain),
        ];
        let b = [
            ConvBlock::new(&pb, 0, c_in, b1, 5, 2, 2, bn, gain),
            ConvBlock::new(&pb, step, b1, b2, 5, 2, 2, bn, gain),
        ];
        let c = [
            ConvBlock::new(&pc, 0, c_in, c1, 11, 4, 5, bn, gain),
            ConvBlock::new(&pc, step, c1, c2, 7, 2, 3, bn, gain),
        ];
        let total = a2 + b2 + c2;
        let pt = &p / "attention";
        let att1 = conv(&pt / "0", total, 32, 1, 1, 0, gain);
        let att_bn = bn.then(|| nn::batch_norm2d(&pt / "1", 32, Default::default()));
        let att2 = conv(&pt / if bn { "3" } else { "2" }, 32, 1, 1, 1, 0, gain);
        let (h, w) = if pool_input {
            (hw[0] / 2, hw[1] / 2)
        } else {
            (hw[0], hw[1])
        };
        // Branch a: two 2× max pools; branch b: two stride-2 convs.
        let size = [h / 4, w / 4];
        (
            Self {
                a,
                b,
                c,
                att1,
                att_bn,
                att2,
                size,
                pool_input,
            },
            total,
        )
    }

    fn forward(&self, x: &Tensor, train: bool) -> Tensor {
        let x = if self.pool_input {
            x.avg_pool2d([2, 2], [2, 2], [0, 0], false, true, None::<i64>)
        } else {
            x.shallow_clone()
        };
        let a = self.a[0]
            .forward(&x, train)
            .max_pool2d([2, 2], [2, 2], [0, 0], [1, 1], false);
        let a = self.a[1]
            .forward(&a, train)
            .max_pool2d([2, 2], [2, 2], [0, 0], [1, 1], false);
        // Branch a's size is `self.size` on the training grid and follows the input on any
        // other (the compact policy pools to a fixed grid, so it plays larger maps).
        let (ah, aw) = (a.size()[2], a.size()[3]);
        let b = self.b[1].forward(&self.b[0].forward(&x, train), train);
        // Where a side is not a multiple of 4, the strided convolutions round up and the max
        // pools down: b keeps a's cells.
        let b = if b.size()[2..] == [ah, aw] {
            b
        } else {
            b.narrow(2, 0, ah).narrow(3, 0, aw)
        };
        let c = self.c[1].forward(&self.c[0].forward(&x, train), train);
        let c = c.upsample_bilinear2d([ah, aw], false, None::<f64>, None::<f64>);
        let f = Tensor::cat(&[a, b, c], 1);
        let h = self.att1.forward(&f);
        let h = match &self.att_bn {
            Some(bn) => bn.forward_t(&h, train),
            None => h,
        };
        let att = self.att2.forward(&h.relu()).sigmoid();
        &f * &att + &f
    }
}

#[derive(Debug)]
enum Extractor {
    /// Flattened vector observation.
    Flatten,
    Compact {
        trunk: Trunk,
        reduce: nn::Conv2D,
        pooled: [i64; 2],
        vector_net: nn::Linear,
        /// `focus > 0`: the window's one-hot fire states → [`FOCUS_FEATURES`].
        focus_net: Option<nn::Linear>,
        /// `nearest_flames`: [`nearest_flames`]'s four numbers → [`POINTER_FEATURES`].
        pointer_net: Option<nn::Linear>,
        fuse: nn::Linear,
        /// `memory: lstm`: the LSTM after `fuse` (the image is then the newest frame and the
        /// helicopter channel).
        lstm: Option<Recurrent>,
    },
    Paper {
        trunk: Trunk,
        lstm: Recurrent,
        coord_net: [nn::Linear; 2],
        fire_net: nn::Linear,
        fc: [nn::Linear; 2],
    },
}

/// Image codes are 0..=9 (`firecast_sim::env::CODE_MAX`); the helicopter channel is 9 too.
const IMAGE_SCALE: f64 = 9.0;

/// Features of the compact extractor.
const COMPACT_FEATURES: i64 = 256;

/// Features of the compact extractor's focus window.
const FOCUS_FEATURES: i64 = 64;

/// Features of the compact extractor's pointer to the nearest flames.
const POINTER_FEATURES: i64 = 64;

/// Cells per unit of the pointer's offsets and distance.
const POINTER_SCALE: f32 = 16.0;

/// An actor-critic network.
#[derive(Debug)]
pub struct Policy {
    pub config: PolicyConfig,
    pub space: ObsSpace,
    pub num_actions: usize,
    pub vs: nn::VarStore,
    extractor: Extractor,
    heads: Heads,
}

impl Policy {
    pub fn new(
        config: &PolicyConfig,
        space: ObsSpace,
        num_actions: usize,
        device: Device,
    ) -> Result<Self, RlError> {
        if config.view == View::Helicopter && config.kind != PolicyKind::Compact {
            return Err(RlError::config(
                "policy.view",
                "`helicopter` is a view of the `compact` extractor",
            ));
        }
        if config.focus > 0 && config.view != View::Helicopter {
            return Err(RlError::config(
                "policy.focus",
                "the focus window is centred on the helicopter: it needs `view: helicopter`",
            ));
        }
        if config.window.is_some() && config.view != View::Helicopter {
            return Err(RlError::config(
                "policy.window",
                "the window is centred on the helicopter: it needs `view: helicopter`",
            ));
        }
        if config
            .window
            .is_some_and(|[r, c]| r < 8 || c < 8 || r % 2 == 1 || c % 2 == 1)
        {
            return Err(RlError::config(
                "policy.window",
                "rows and columns must be even and at least 8",
            ));
        }
        if config.context > 0 && config.window.is_none() {
            return Err(RlError::config(
                "policy.context",
                "the coarse view is drawn on the window's grid: it needs `window`",
            ));
        }
        if config.nearest_flames && config.kind != PolicyKind::Compact {
            return Err(RlError::config(
                "policy.nearest_flames",
                "the pointer to the nearest flames is an input of the `compact` extractor",
            ));
        }
        if config.memory == Memory::Lstm && config.kind != PolicyKind::Compact {
            return Err(RlError::config(
                "policy.memory",
                "`lstm` is a memory of the `compact` extractor",
            ));
        }
        let vs = nn::VarStore::new(device);
        let root = vs.root();
        let ortho = config.ortho_init;
        let g = |gain: f64| ortho.then_some(gain);
        let sqrt2 = std::f64::consts::SQRT_2;
        let fx = &root / "features_extractor";
        let (extractor, features) = match config.kind {
            PolicyKind::Mlp => {
                if space.image.is_some() {
                    return Err(RlError::config(
                        "policy.kind",
                        "`mlp` takes vector observations; use `compact` or `paper` for images",
                    ));
                }
                (Extractor::Flatten, space.vector as i64)
            }
            PolicyKind::Compact | PolicyKind::Paper => {
                let Some([c, h, w]) = space.image else {
                    return Err(RlError::config(
                        "policy.kind",
                        "`compact` and `paper` need image observations (the helitack environment)",
                    ));
                };
                let (c, hw) = (c as i64, [h as i64, w as i64]);
                if config.kind == PolicyKind::Compact {
                    let lstm = config.memory == Memory::Lstm;
                    let hw = config.window.map_or(hw, |[r, c]| [i64::from(r), i64::from(c)]);
                    // With an LSTM the image is the newest frame and the helicopter channel;
                    // the coarse view adds its burning and burnt channels.
                    let image_channels = if lstm { c.min(2) } else { c };
                    let context_channels = if config.context > 0 { 2 } else { 0 };
                    let (trunk, ch) = Trunk::new(
                        &fx / "cnn",
                        image_channels + context_channels,
                        hw,
                        [16, 32, 8, 16, 8, 16],
                        config.batch_norm,
                        true,
                        g(sqrt2),
                    );
                    let reduce = conv(&fx / "reduce", ch, 16, 1, 1, 0, g(sqrt2));
                    let pooled = [trunk.size[0].min(10), trunk.size[1].min(15)];
                    // With a window the helicopter's map coordinates are left out.
                    if config.window.is_some() && space.vector < 3 {
                        return Err(RlError::config(
                            "policy.window",
                            "a window needs the helicopter cell and the on-fire flag in the vector observation",
                        ));
                    }
                    let vector = space.vector as i64 - if config.window.is_some() { 2 } else { 0 };
                    let vector_net = linear(&fx / "vector_net", vector, 64, g(sqrt2));
                    let side = 2 * i64::from(config.focus) + 1;
                    if config.focus > 0 && side > hw[0].min(hw[1]) {
                        return Err(RlError::config(
                            "policy.focus",
                            format!(
                                "a window of radius {} ({side} cells a side) does not fit the {} × {} map",
                                config.focus, hw[1], hw[0]
                            ),
                        ));
                    }
                    let focus_net = (config.focus > 0)
                        .then(|| linear(&fx / "focus_net", 3 * side * side, FOCUS_FEATURES, g(sqrt2)));
                    let focused = if focus_net.is_some() { FOCUS_FEATURES } else { 0 };
                    let pointer_net = config
                        .nearest_flames
                        .then(|| linear(&fx / "pointer_net", 4, POINTER_FEATURES, g(sqrt2)));
                    let pointed = if pointer_net.is_some() {
                        POINTER_FEATURES
                    } else {
                        0
                    };
                    let fuse = linear(
                        &fx / "fuse",
                        16 * pooled[0] * pooled[1] + 64 + focused + pointed,
                        COMPACT_FEATURES,
                        g(sqrt2),
                    );
                    // PyTorch's default LSTM init (U(±1/√h)), as sb3-contrib's RecurrentPPO keeps.
                    let lstm = lstm.then(|| {
                        Recurrent::new(
                            &fx / "lstm",
                            Cell::Lstm,
                            COMPACT_FEATURES,
                            COMPACT_FEATURES,
                            1,
                            false,
                            0.0,
                        )
                    });
                    (
                        Extractor::Compact {
                            trunk,
                            reduce,
                            pooled,
                            vector_net,
                            focus_net,
                            pointer_net,
                            fuse,
                            lstm,
                        },
                        COMPACT_FEATURES,
                    )
                } else {
                    if space.vector < 3 {
                        return Err(RlError::config(
                            "policy.kind",
                            "`paper` needs the helicopter cell and the on-fire flag in the vector observation",
                        ));
                    }
                    let (trunk, ch) =
                        Trunk::new(&fx / "cnn", c, hw, [32, 64, 16, 32, 8, 16], true, false, g(sqrt2));
                    let flat = ch * trunk.size[0] * trunk.size[1];
                    // SB3's init_weights touches Linear and Conv2d only: the LSTM keeps
                    // PyTorch's default U(±1/√h).
                    let lstm = Recurrent::new(&fx / "lstm", Cell::Lstm, flat, 256, 2, false, 0.2);
                    let coord_net = [
                        linear(&fx / "coord_net" / "0", 4, 32, g(sqrt2)),
                        linear(&fx / "coord_net" / "2", 32, 64, g(sqrt2)),
                    ];
                    let fire_net = linear(&fx / "fire_net" / "0", 2, 16, g(sqrt2));
                    let fc = [
                        linear(&fx / "fc" / "0", 256 + 64 + 16, 512, g(sqrt2)),
                        linear(&fx / "fc" / "2", 512, 512, g(sqrt2)),
                    ];
                    (
                        Extractor::Paper {
                            trunk,
                            lstm,
                            coord_net,
                            fire_net,
                            fc,
                        },
                        512,
                    )
                }
            }
        };
        let heads = Heads::new(
            &root,
            features,
            &config.pi,
            &config.vf,
            config.activation,
            ortho,
            num_actions,
        );
        Ok(Self {
            config: config.clone(),
            space,
            num_actions,
            vs,
            extractor,
            heads,
        })
    }

    pub fn device(&self) -> Device {
        self.vs.device()
    }

    fn features(&self, obs: &ObsTensors, train: bool) -> Tensor {
        match &self.extractor {
            Extractor::Flatten => obs.vector.shallow_clone(),
            Extractor::Compact {
                trunk,
                reduce,
                pooled,
                vector_net,
                focus_net,
                pointer_net,
                fuse,
                lstm,
            } => {
                let Some(raw) = &obs.image else {
                    unreachable!("the compact extractor is built for image observations")
                };
                let raw = match lstm {
                    // The newest frame and the helicopter channel.
                    Some(_) => {
                        let c = raw.size()[1];
                        raw.narrow(1, c - 2, 2)
                    }
                    None => raw.shallow_clone(),
                };
                let size = raw.size();
                let window = self
                    .config
                    .window
                    .map_or([size[2], size[3]], |[r, c]| [i64::from(r), i64::from(c)]);
                // Cut before converting: a 64 × 96 window of a 240 × 160 map is a sixth of it.
                let (img, input) = match self.config.view {
                    View::Map => {
                        let img = raw.to_kind(Kind::Float) / IMAGE_SCALE;
                        (img.shallow_clone(), img)
                    }
                    View::Helicopter => {
                        let cells = helicopter_cells(&raw);
                        let img = centred(&raw, &cells, window).to_kind(Kind::Float) / IMAGE_SCALE;
                        let input = match self.config.context {
                            0 => img.shallow_clone(),
                            k => Tensor::cat(&[&img, &coarse_view(&raw, &cells, window, i64::from(k))], 1),
                        };
                        (img, input)
                    }
                };
                let f = trunk.forward(&input, train);
                let f = reduce
                    .forward(&f)
                    .relu()
                    .adaptive_avg_pool2d([pooled[0], pooled[1]]);
                let f = f.flatten(1, -1);
                let vector = match self.config.window {
                    // [x, y, on_fire, …]: the coordinates are the first two.
                    Some(_) => obs.vector.narrow(1, 2, obs.vector.size()[1] - 2),
                    None => obs.vector.shallow_clone(),
                };
                let v = vector_net.forward(&vector).relu();
                let mut parts = vec![f, v];
                if let Some(net) = focus_net {
                    let window = focus_window(&img, i64::from(self.config.focus));
                    parts.push(net.forward(&window.flatten(1, -1)).relu());
                }
                if let Some(net) = pointer_net {
                    parts.push(net.forward(&nearest_flames(&raw)).relu());
                }
                fuse.forward(&Tensor::cat(&parts, 1)).relu()
            }
            Extractor::Paper {
                trunk,
                lstm,
                coord_net,
                fire_net,
                fc,
            } => {
                let img = image_float(obs);
                let f = trunk.forward(&img, train).flatten(1, -1).unsqueeze(1);
                // Sequence length 1 from a zero state: what the authors' updates see (their
                // extractor resets its state whenever the batch size changes).
                let (out, _) = lstm.forward(&f, train);
                let out = out.squeeze_dim(1);
                // Vector part: [x, y, on_fire]; coord_net takes [x, y, x − cx, y − cy].
                let xy = obs.vector.narrow(1, 0, 2);
                let size = self
                    .space
                    .image
                    .map_or([0.0, 0.0], |[_, h, w]| [w as f64 / 2.0, h as f64 / 2.0]);
                let centre = Tensor::from_slice(&[size[0] as f32, size[1] as f32]).to_device(xy.device());
                let coords = Tensor::cat(&[xy.shallow_clone(), &xy - centre], 1);
                let c = coord_net[1].forward(&coord_net[0].forward(&coords).relu()).relu();
                let on_fire = obs.vector.narrow(1, 2, 1);
                let onehot = Tensor::cat(&[1.0 - &on_fire, on_fire], 1);
                let fire = fire_net.forward(&onehot).relu();
                let h = Tensor::cat(&[out, c, fire], 1);
                fc[1].forward(&fc[0].forward(&h).relu())
            }
        }
    }

    /// Action logits `[n, actions]` and values `[n]` of a policy without memory (a recurrent
    /// one would run from a zero state: use [`sequence`](Self::sequence)).
    pub fn forward(&self, obs: &ObsTensors, train: bool) -> (Tensor, Tensor) {
        self.heads(&self.features(obs, train))
    }

    /// Logits and values of features (the extractor's, or the LSTM's output).
    fn heads(&self, f: &Tensor) -> (Tensor, Tensor) {
        self.heads.forward(f)
    }

    pub fn values(&self, obs: &ObsTensors) -> Tensor {
        self.heads.values(&self.features(obs, false))
    }

    fn lstm(&self) -> Option<&Recurrent> {
        match &self.extractor {
            Extractor::Compact { lstm, .. } => lstm.as_ref(),
            _ => None,
        }
    }

    /// Whether the policy carries a state from step to step ([`Memory::Lstm`]).
    pub fn is_recurrent(&self) -> bool {
        self.lstm().is_some()
    }

    /// Length of one environment's row of [`Hidden::to_host`] (h and c); 0 without memory.
    pub fn hidden_len(&self) -> usize {
        if self.is_recurrent() {
            2 * COMPACT_FEATURES as usize
        } else {
            0
        }
    }

    /// The zero state of `n` environments, if the policy is recurrent.
    pub fn initial_hidden(&self, n: usize) -> Option<Hidden> {
        self.lstm().map(|_| {
            let z = Tensor::zeros([n as i64, COMPACT_FEATURES], (Kind::Float, self.device()));
            Hidden {
                h: z.shallow_clone(),
                c: z.zeros_like(),
            }
        })
    }

    /// `t` steps of `n` environments, time-major (row `k·n + i` is step `k` of environment
    /// `i`), from `hidden`: before step `k`, the state of every environment whose
    /// `starts[k·n + i]` is 1 is reset to zero (a new episode), as the rollout did. Returns the
    /// logits `[t·n, actions]`, the values `[t·n]` and the state after the last step. Without
    /// memory it is [`forward`](Self::forward) and `hidden` comes back unchanged.
    pub fn sequence(
        &self,
        obs: &ObsTensors,
        hidden: &Hidden,
        starts: &[f32],
        t: usize,
        train: bool,
    ) -> (Tensor, Tensor, Hidden) {
        let f = self.features(obs, train);
        let Some(lstm) = self.lstm() else {
            let (logits, values) = self.heads(&f);
            let same = Hidden {
                h: hidden.h.shallow_clone(),
                c: hidden.c.shallow_clone(),
            };
            return (logits, values, same);
        };
        let n = hidden.h.size()[0];
        let x = f.view([t as i64, n, -1]);
        let keep = Tensor::from_slice(starts)
            .to_device(f.device())
            .neg()
            .g_add_scalar(1.0)
            .view([t as i64, n, 1]);
        let (mut h, mut c) = (hidden.h.shallow_clone(), hidden.c.shallow_clone());
        let mut outs = Vec::with_capacity(t);
        for k in 0..t as i64 {
            let m = keep.get(k);
            let (h2, c2) = lstm.step(&x.get(k), &(&h * &m), &(&c * &m));
            outs.push(h2.shallow_clone());
            (h, c) = (h2, c2);
        }
        let (logits, values) = self.heads(&Tensor::cat(&outs, 0));
        (logits, values, Hidden { h, c })
    }

    /// Whether this policy can read observations of `space`: the space it was trained on,
    /// or — for the compact policy, whose features are pooled to a fixed grid — the same
    /// channels and numbers on a grid at least as large in both directions (any grid with a
    /// `window`, which is cut from the map whatever its size).
    pub fn accepts(&self, space: ObsSpace) -> bool {
        if space == self.space {
            return true;
        }
        match (self.config.kind, self.space.image, space.image) {
            (PolicyKind::Compact, Some([c, h, w]), Some([c2, h2, w2])) => {
                let fits = self.config.window.is_some() || (h2 >= h && w2 >= w);
                c == c2 && fits && space.vector == self.space.vector
            }
            _ => false,
        }
    }

    pub fn parameter_count(&self) -> i64 {
        self.vs
            .trainable_variables()
            .iter()
            .map(Tensor::numel)
            .sum::<usize>() as i64
    }
}

impl PolicySpec for PolicyConfig {
    type Policy = Policy;
    fn build(&self, space: ObsSpace, num_actions: usize, device: Device) -> Result<Policy, PpoError> {
        Ok(Policy::new(self, space, num_actions, device)?)
    }
}

impl ActorCritic for Policy {
    type Spec = PolicyConfig;
    fn spec(&self) -> &PolicyConfig {
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
        Policy::device(self)
    }
    fn forward(&self, obs: &ObsTensors, train: bool) -> (Tensor, Tensor) {
        Policy::forward(self, obs, train)
    }
    fn values(&self, obs: &ObsTensors) -> Tensor {
        Policy::values(self, obs)
    }
    fn sequence(
        &self,
        obs: &ObsTensors,
        hidden: &Hidden,
        starts: &[f32],
        t: usize,
        train: bool,
    ) -> (Tensor, Tensor, Hidden) {
        Policy::sequence(self, obs, hidden, starts, t, train)
    }
    fn is_recurrent(&self) -> bool {
        Policy::is_recurrent(self)
    }
    fn hidden_len(&self) -> usize {
        Policy::hidden_len(self)
    }
    fn initial_hidden(&self, n: usize) -> Option<Hidden> {
        Policy::initial_hidden(self, n)
    }
}

/// Flat cell index of each image's helicopter (the maximum of the last channel, its own).
fn helicopter_cells(img: &Tensor) -> Vec<i64> {
    let c = img.size()[1];
    Vec::<i64>::try_from(img.select(1, c - 1).flatten(1, -1).argmax(1, false))
        .expect("argmax of a CPU or CUDA tensor")
}

/// `[rows, cols]` of each image `[N, C, H, W]` with map cell `cells[i]` at (rows/2, cols/2);
/// outside the map is 0. Only the part inside the map is copied.
fn centred(img: &Tensor, cells: &[i64], [rows, cols]: [i64; 2]) -> Tensor {
    let size = img.size();
    let (n, c, h, w) = (size[0], size[1], size[2], size[3]);
    let out = Tensor::zeros([n, c, rows, cols], (img.kind(), img.device()));
    for (i, &cell) in cells.iter().enumerate().take(n as usize) {
        // Output row r shows map row hy − rows/2 + r; the same for columns.
        let (top, left) = (cell / w - rows / 2, cell % w - cols / 2);
        let (r0, r1) = (top.max(0), (top + rows).min(h));
        let (c0, c1) = (left.max(0), (left + cols).min(w));
        if r1 <= r0 || c1 <= c0 {
            continue;
        }
        let src = img.get(i as i64).narrow(1, r0, r1 - r0).narrow(2, c0, c1 - c0);
        out.get(i as i64)
            .narrow(1, r0 - top, r1 - r0)
            .narrow(2, c0 - left, c1 - c0)
            .copy_(&src);
    }
    out
}

/// The coarse view of images of cell codes `[N, C, H, W]` (the newest frame is channel
/// C − 2): its burning (codes 4–6) and burnt (7–9) cells in the `[k·rows, k·cols]` cells
/// around the helicopter (at (k·rows/2, k·cols/2), as in [`centred`]), as fractions of each
/// k × k block: `[N, 2, rows, cols]`. Counted on the host over the map's cells only: the same
/// in tensor operations is dominated by the padding (measured: 20 % of an imitation round in
/// average pooling alone on 240 × 160).
fn coarse_view(codes: &Tensor, cells: &[i64], [rows, cols]: [i64; 2], k: i64) -> Tensor {
    let size = codes.size();
    let (n, c, h, w) = (size[0], size[1], size[2], size[3]);
    let newest = codes.select(1, c - 2).to_device(Device::Cpu).contiguous();
    let frames = Vec::<u8>::try_from(newest.flatten(0, -1)).expect("cell codes are u8");
    let (plane, block) = ((rows * cols) as usize, (h * w) as usize);
    let mut counts = vec![0u16; n as usize * 2 * plane];
    for (i, &cell) in cells.iter().enumerate().take(n as usize) {
        let (top, left) = (cell / w - k * rows / 2, cell % w - k * cols / 2);
        let frame = &frames[i * block..(i + 1) * block];
        let out = &mut counts[i * 2 * plane..(i + 1) * 2 * plane];
        for y in top.max(0)..(top + k * rows).min(h) {
            let row = ((y - top) / k * cols) as usize;
            for x in left.max(0)..(left + k * cols).min(w) {
                let slot = row + ((x - left) / k) as usize;
                match frame[(y * w + x) as usize] {
                    4..=6 => out[slot] += 1,
                    7.. => out[plane + slot] += 1,
                    _ => {}
                }
            }
        }
    }
    let scale = 1.0 / (k * k) as f32;
    let fractions: Vec<f32> = counts.iter().map(|&m| f32::from(m) * scale).collect();
    Tensor::from_slice(&fractions)
        .view([n, 2, rows, cols])
        .to_device(codes.device())
}

/// For each image of cell codes `[N, C, H, W]` (newest frame channel C − 2, helicopter
/// channel C − 1), the nearest burning cell (codes 4–6) to the helicopter as the chaser picks
/// it (`firecast_sim::FireChaser`: least squared distance, then lowest cell index):
/// `[dx, dy, distance] / POINTER_SCALE` and 1, or four zeros when nothing burns: `[N, 4]`.
/// Counted on the host, as [`coarse_view`].
fn nearest_flames(codes: &Tensor) -> Tensor {
    let size = codes.size();
    let (n, c, h, w) = (size[0], size[1], size[2], size[3]);
    let cells = helicopter_cells(codes);
    let newest = codes.select(1, c - 2).to_device(Device::Cpu).contiguous();
    let frames = Vec::<u8>::try_from(newest.flatten(0, -1)).expect("cell codes are u8");
    let block = (h * w) as usize;
    let mut out = vec![0f32; n as usize * 4];
    for (i, &cell) in cells.iter().enumerate().take(n as usize) {
        let (hx, hy) = (cell % w, cell / w);
        let mut best: Option<(i64, i64, i64)> = None;
        for (j, &code) in frames[i * block..(i + 1) * block].iter().enumerate() {
            if !(4..=6).contains(&code) {
                continue;
            }
            let (dx, dy) = (j as i64 % w - hx, j as i64 / w - hy);
            let d2 = dx * dx + dy * dy;
            if best.is_none_or(|(b, ..)| d2 < b) {
                best = Some((d2, dx, dy));
            }
        }
        if let Some((d2, dx, dy)) = best {
            out[i * 4..(i + 1) * 4].copy_from_slice(&[
                dx as f32 / POINTER_SCALE,
                dy as f32 / POINTER_SCALE,
                (d2 as f32).sqrt() / POINTER_SCALE,
                1.0,
            ]);
        }
    }
    Tensor::from_slice(&out).view([n, 4]).to_device(codes.device())
}

/// The `(2r + 1)²` cells around the centre of helicopter-centred images `[N, C, H, W]` (codes
/// / 9; the newest frame is channel C − 2), as one-hot fire states `[N, 3, 2r + 1, 2r + 1]`:
/// unburnt (codes 1–3), burning (4–6), burnt (7–9); non-burnable cells (0) are all zero.
fn focus_window(img: &Tensor, r: i64) -> Tensor {
    let size = img.size();
    let (c, h, w) = (size[1], size[2], size[3]);
    let codes = (img
        .select(1, c - 2)
        .narrow(1, h / 2 - r, 2 * r + 1)
        .narrow(2, w / 2 - r, 2 * r + 1)
        * IMAGE_SCALE)
        .round();
    let states: Vec<Tensor> = (0..3)
        .map(|s| {
            let low = 3.0 * f64::from(s) + 0.5;
            codes
                .ge(low)
                .logical_and(&codes.le(low + 3.0))
                .to_kind(Kind::Float)
        })
        .collect();
    Tensor::stack(&states, 1)
}

fn image_float(obs: &ObsTensors) -> Tensor {
    match &obs.image {
        Some(img) => img.to_kind(Kind::Float) / IMAGE_SCALE,
        None => Tensor::zeros([0], (Kind::Float, obs.vector.device())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pointer points where the chaser flies: on random frames, the chaser's decision
    /// read off the four numbers (drop within reach 4, else close the larger offset, x on a
    /// tie; north when nothing burns) is the chaser's own.
    #[test]
    fn nearest_flames_points_where_the_chaser_flies() {
        use firecast_sim::env::{FRAME_STACK, Observation};
        use firecast_sim::{Action, FireChaser, Policy as _};
        use rand::{Rng, SeedableRng};
        let (h, w) = (23_usize, 31_usize);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut drops = 0;
        for case in 0..300 {
            let burning = [0.0, 0.002, 0.01, 0.05][case % 4];
            let frames: Vec<u8> = (0..FRAME_STACK * h * w)
                .map(|_| {
                    if rng.random_bool(burning) {
                        rng.random_range(4..=6)
                    } else {
                        [0, 1, 2, 3, 7, 8, 9][rng.random_range(0..7)]
                    }
                })
                .collect();
            let agent = [rng.random_range(0..w as i32), rng.random_range(0..h as i32)];
            let seen = Observation {
                frames: &frames,
                width: w,
                height: h,
                agent,
                on_fire: false,
            };
            let chaser = FireChaser::default().act(&seen).action;
            let mut image = vec![0u8; (FRAME_STACK + 1) * h * w];
            image[..FRAME_STACK * h * w].copy_from_slice(&frames);
            image[FRAME_STACK * h * w + agent[1] as usize * w + agent[0] as usize] = 9;
            let codes = Tensor::from_slice(&image).view([1, (FRAME_STACK + 1) as i64, h as i64, w as i64]);
            let p = Vec::<f32>::try_from(nearest_flames(&codes).flatten(0, -1)).expect("f32");
            let (dx, dy) = ((p[0] * POINTER_SCALE).round(), (p[1] * POINTER_SCALE).round());
            let read = if p[3] == 0.0 {
                Action::North
            } else if dx * dx + dy * dy <= 16.0 {
                drops += 1;
                Action::Drop
            } else if dx.abs() >= dy.abs() {
                if dx > 0.0 { Action::East } else { Action::West }
            } else if dy > 0.0 {
                Action::North
            } else {
                Action::South
            };
            assert_eq!(read, chaser, "case {case}: pointer {p:?}");
            assert!((p[2] * p[2] - (p[0] * p[0] + p[1] * p[1])).abs() < 1e-4);
        }
        assert!(drops > 5, "only {drops} drops among 300 cases");
    }

    /// The focus window is the centre's (2r + 1)² cells of the newest frame, each cell's
    /// fire state one-hot; older frames and non-burnable cells do not show.
    #[test]
    fn focus_window_is_the_newest_frames_fire_states_around_the_centre() {
        let (h, w, r) = (7_i64, 9_i64, 2_i64);
        let code_at = |y: i64, x: i64| ((y * w + x) % 10) as f64;
        let newest = Tensor::from_slice(
            &(0..h * w)
                .map(|i| code_at(i / w, i % w) as f32)
                .collect::<Vec<_>>(),
        )
        .view([1, 1, h, w]);
        let older = Tensor::full([1, 1, h, w], 5.0, (Kind::Float, Device::Cpu));
        let heli = Tensor::zeros([1, 1, h, w], (Kind::Float, Device::Cpu));
        let img = Tensor::cat(&[older, newest, heli], 1) / IMAGE_SCALE;
        let out = focus_window(&img, r);
        assert_eq!(out.size(), [1, 3, 2 * r + 1, 2 * r + 1]);
        for y in 0..2 * r + 1 {
            for x in 0..2 * r + 1 {
                let code = code_at(y + h / 2 - r, x + w / 2 - r);
                for state in 0..3 {
                    let hot = code >= 1.0 && ((code - 1.0) / 3.0).floor() == state as f64;
                    assert_eq!(
                        out.double_value(&[0, state, y, x]),
                        if hot { 1.0 } else { 0.0 },
                        "cell ({x}, {y}) code {code} state {state}"
                    );
                }
            }
        }
    }

    /// A window needs the helicopter view and must fit the map.
    #[test]
    fn focus_settings_are_checked() {
        let space = ObsSpace {
            image: Some([5, 16, 24]),
            vector: 3,
        };
        let compact = PolicyConfig {
            kind: PolicyKind::Compact,
            focus: 4,
            ..PolicyConfig::default()
        };
        let err = Policy::new(&compact, space, 5, Device::Cpu).expect_err("refused");
        assert!(err.to_string().contains("policy.focus"), "{err}");
        let too_big = PolicyConfig {
            view: View::Helicopter,
            focus: 8,
            ..compact.clone()
        };
        let err = Policy::new(&too_big, space, 5, Device::Cpu).expect_err("refused");
        assert!(
            err.to_string().contains("policy.focus") && err.to_string().contains("17 cells"),
            "{err}"
        );
        let fits = PolicyConfig { focus: 7, ..too_big };
        let policy = Policy::new(&fits, space, 5, Device::Cpu).expect("fits");
        let obs = ObsTensors {
            image: Some(Tensor::zeros([2, 5, 16, 24], (Kind::Uint8, Device::Cpu))),
            vector: Tensor::zeros([2, 3], (Kind::Float, Device::Cpu)),
        };
        let (logits, values) = policy.forward(&obs, false);
        assert_eq!((logits.size(), values.size()), (vec![2, 5], vec![2]));
    }

    /// The helitack observation space of an h × w map: 4 frames and the helicopter channel,
    /// [x, y, on_fire].
    fn space(h: usize, w: usize) -> ObsSpace {
        ObsSpace {
            image: Some([5, h, w]),
            vector: 3,
        }
    }

    /// The compact policy pools its features to a fixed grid, so it plays any map at least as
    /// large as its training map (the threat report's landscape with a 96 × 64 agent); smaller
    /// maps, other channels and the paper policy (whose LSTM input is the map's size) are refused.
    #[test]
    fn the_compact_policy_plays_larger_maps() {
        let compact = PolicyConfig {
            kind: PolicyKind::Compact,
            view: View::Helicopter,
            focus: 8,
            ..PolicyConfig::default()
        };
        let policy = Policy::new(&compact, space(64, 96), 5, Device::Cpu).expect("policy");
        assert!(policy.accepts(space(64, 96)) && policy.accepts(space(160, 240)));
        assert!(!policy.accepts(space(32, 48)) && !policy.accepts(space(160, 48)));
        assert!(!policy.accepts(ObsSpace {
            image: Some([4, 160, 240]),
            vector: 3
        }));
        let obs = |h: i64, w: i64| ObsTensors {
            image: Some(Tensor::ones([2, 5, h, w], (Kind::Uint8, Device::Cpu))),
            vector: Tensor::zeros([2, 3], (Kind::Float, Device::Cpu)),
        };
        for (h, w) in [(64, 96), (160, 240), (71, 113)] {
            let (logits, values) = policy.forward(&obs(h, w), false);
            assert_eq!((logits.size(), values.size()), (vec![2, 5], vec![2]), "{h}×{w}");
        }
        let paper = PolicyConfig {
            kind: PolicyKind::Paper,
            ..PolicyConfig::default()
        };
        let policy = Policy::new(&paper, space(16, 24), 5, Device::Cpu).expect("policy");
        assert!(policy.accepts(space(16, 24)) && !policy.accepts(space(32, 48)));
    }

    /// With a window the compact policy plays any map size with the same channels, and reads
    /// neither the helicopter's map coordinates nor anything beyond its views.
    #[test]
    fn a_windowed_policy_plays_any_map_and_ignores_coordinates() {
        let windowed = PolicyConfig {
            kind: PolicyKind::Compact,
            view: View::Helicopter,
            focus: 4,
            window: Some([16, 24]),
            context: 3,
            ..PolicyConfig::default()
        };
        let policy = Policy::new(&windowed, space(32, 48), 5, Device::Cpu).expect("policy");
        assert!(policy.accepts(space(8, 12)) && policy.accepts(space(160, 240)));
        assert!(!policy.accepts(ObsSpace {
            image: Some([4, 160, 240]),
            vector: 3
        }));
        // A fire 30 cells east of the helicopter: beyond the 24-column window, inside the
        // 72-column coarse view; another 60 cells west, beyond both.
        let obs = |h: i64, w: i64, x: f32, far: bool| {
            let img = Tensor::ones([1, 5, h, w], (Kind::Uint8, Device::Cpu));
            let (hy, hx) = (h / 2, w / 2);
            let _ = img.get(0).get(4).get(hy).get(hx).fill_(9);
            let _ = img.get(0).get(3).get(hy).get(hx + 30).fill_(5);
            if far {
                let _ = img.get(0).get(3).get(hy).get(hx - 60).fill_(5);
            }
            ObsTensors {
                image: Some(img),
                vector: Tensor::from_slice(&[x, 7.0, 0.0]).view([1, 3]),
            }
        };
        let (near, _) = policy.forward(&obs(64, 160, 0.0, false), false);
        for (h, w, x, far) in [
            (64, 160, 50.0, false),
            (64, 160, 0.0, true),
            (128, 200, 3.0, false),
        ] {
            let (logits, _) = policy.forward(&obs(h, w, x, far), false);
            assert!(
                logits.allclose(&near, 1e-6, 1e-6, false),
                "{h}×{w}, x {x}, far {far}"
            );
        }
        // …while the fire the coarse view shows does count.
        let unseen = obs(64, 160, 0.0, false);
        if let Some(img) = &unseen.image {
            let _ = img.get(0).get(3).fill_(1);
        }
        let (without, _) = policy.forward(&unseen, false);
        assert!(!without.equal(&near), "the coarse view's fire changes nothing");
        let no_context = PolicyConfig {
            context: 0,
            ..windowed.clone()
        };
        let err = Policy::new(
            &PolicyConfig {
                view: View::Map,
                focus: 0,
                ..no_context.clone()
            },
            space(32, 48),
            5,
            Device::Cpu,
        )
        .expect_err("refused");
        assert!(err.to_string().contains("policy.window"), "{err}");
        let odd = PolicyConfig {
            window: Some([15, 24]),
            ..no_context.clone()
        };
        let err = Policy::new(&odd, space(32, 48), 5, Device::Cpu).expect_err("refused");
        assert!(err.to_string().contains("policy.window"), "{err}");
        let context_only = PolicyConfig {
            window: None,
            ..windowed
        };
        let err = Policy::new(&context_only, space(32, 48), 5, Device::Cpu).expect_err("refused");
        assert!(err.to_string().contains("policy.context"), "{err}");
    }

    /// The coarse view puts a burning cell in the block of its offset from the helicopter and a
    /// burnt one in the second channel, as fractions of k × k blocks; beyond it nothing shows.
    #[test]
    fn the_coarse_view_shows_flames_beyond_the_window() {
        let (h, w, k) = (40_i64, 60_i64, 3_i64);
        let frame = Tensor::ones([1, 1, h, w], (Kind::Uint8, Device::Cpu));
        let heli = Tensor::zeros([1, 1, h, w], (Kind::Uint8, Device::Cpu));
        let (hx, hy) = (10_i64, 20_i64);
        let _ = heli.get(0).get(0).get(hy).get(hx).fill_(9);
        let _ = frame.get(0).get(0).get(hy).get(hx + 15).fill_(5); // burning, 15 east
        let _ = frame.get(0).get(0).get(hy - 7).get(hx).fill_(8); // burnt, 7 north
        let _ = frame.get(0).get(0).get(hy).get(hx + 40).fill_(5); // beyond the view
        let img = Tensor::cat(&[frame, heli], 1);
        let view = coarse_view(&img, &helicopter_cells(&img), [8, 12], k);
        assert_eq!(view.size(), [1, 2, 8, 12]);
        // The view spans 24 × 36 cells with the helicopter at (12, 18): 15 east is column 33
        // (block 11) of row 12 (block 4); 7 north is row 5 (block 1) of column 18 (block 6).
        let total = view.sum(Kind::Double).double_value(&[]);
        assert!((total - 2.0 / 9.0).abs() < 1e-6, "{total}");
        assert!((view.double_value(&[0, 0, 4, 11]) - 1.0 / 9.0).abs() < 1e-6);
        assert!((view.double_value(&[0, 1, 1, 6]) - 1.0 / 9.0).abs() < 1e-6);
    }

    /// The helicopter lands on (H/2, W/2), its neighbours keep their offsets, and cells
    /// beyond the map read 0.
    #[test]
    fn helicopter_view_centres_the_helicopter() {
        let (h, w) = (4_i64, 6_i64);
        for (hx, hy) in [(1_i64, 3_i64), (5, 0), (3, 2)] {
            let map = Tensor::arange(h * w, (Kind::Float, Device::Cpu)).view([1, 1, h, w]) + 1.0;
            let heli = Tensor::zeros([1, 1, h, w], (Kind::Float, Device::Cpu));
            let _ = heli.get(0).get(0).get(hy).get(hx).fill_(1.0);
            let img = Tensor::cat(&[map, heli], 1);
            // The map's own size, a larger window and a smaller one.
            for [rows, cols] in [[h, w], [10, 8], [2, 4]] {
                let out = centred(&img, &helicopter_cells(&img), [rows, cols]);
                assert_eq!(out.size(), [1, 2, rows, cols]);
                for y in 0..rows {
                    for x in 0..cols {
                        let (mx, my) = (x + hx - cols / 2, y + hy - rows / 2);
                        let want = if (0..w).contains(&mx) && (0..h).contains(&my) {
                            (my * w + mx + 1) as f64
                        } else {
                            0.0
                        };
                        assert_eq!(
                            out.double_value(&[0, 0, y, x]),
                            want,
                            "({x}, {y}) from ({hx}, {hy}) in {rows} × {cols}"
                        );
                    }
                }
                assert_eq!(out.double_value(&[0, 1, rows / 2, cols / 2]), 1.0);
            }
        }
    }
}
