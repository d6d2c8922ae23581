//! Neural forecasters in `tch`: the authors' CNN-BiLSTM (variant R, their training script)
//! and deployed attention model (variant D), a two-layer LSTM, a LightTS-style sampler
//! network, scikit-learn's MLPClassifier, and FireCast's own forecaster.
//!
//! Two `tch` traps are avoided on purpose: `nn::lstm` initialises biases to zero and fixes
//! inter-layer dropout when it is built (so it stays on at evaluation). `Recurrent` (firecast-learn) holds
//! PyTorch-named weights with PyTorch's U(±1/√h) initialisation and passes `train` to
//! libtorch's fused LSTM/GRU on every call.

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use tch::nn::{self, Module, ModuleT, OptimizerConfig};
use tch::{Device, Kind, Tensor};

use firecast_learn::layers::{Cell, Recurrent};

use crate::ForecastError;
use crate::data::Block;
use crate::features::{FeatureSet, FeatureSetName};
use crate::inputs::{FitContext, Inputs};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NeuralKind {
    /// scikit-learn's MLPClassifier (100 ReLU units, Adam, L2 1e-4) on flattened windows.
    Mlp,
    /// Two stacked LSTM layers (64 units), last hidden state → logit.
    Lstm2,
    /// LightTS-style: continuous and interval sampling of the window, each mixed by small
    /// MLPs, concatenated → logit.
    Lightts,
    /// Variant R: the authors' training script.
    CnnBilstm,
    /// Variant D: the deployed `CNN_BiLSTMAttn`.
    CnnBilstmAttn,
    /// FireCast's forecaster: dilated convolutions, a BiGRU, attention pooling; focal loss,
    /// class-balanced batches, early stopping on validation AUPRC.
    Firecast,
}

impl NeuralKind {
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "mlp" => Self::Mlp,
            "lstm2" => Self::Lstm2,
            "lightts" => Self::Lightts,
            "cnn_bilstm" => Self::CnnBilstm,
            "cnn_bilstm_attn" => Self::CnnBilstmAttn,
            "firecast" => Self::Firecast,
            _ => return None,
        })
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Self::Mlp => "mlp",
            Self::Lstm2 => "lstm2",
            Self::Lightts => "lightts",
            Self::CnnBilstm => "cnn_bilstm",
            Self::CnnBilstmAttn => "cnn_bilstm_attn",
            Self::Firecast => "firecast",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Loss {
    /// Binary cross-entropy on the logit (BCEWithLogitsLoss).
    Bce,
    /// Focal loss (Lin et al. 2017): −α_t (1 − p_t)^γ log p_t; α = null weighs both classes 1.
    Focal { gamma: f64, alpha: Option<f64> },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Optimizer {
    /// PyTorch AdamW (decoupled weight decay).
    Adamw,
    /// Adam with L2 added to the loss as scikit-learn's MLP does (alpha/2 · ‖W‖² / batch).
    AdamL2,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopOn {
    /// Early stopping and the plateau schedule watch the validation loss.
    ValLoss,
    /// They watch validation AUPRC (higher is better).
    ValAuprc,
    /// scikit-learn's MLP rule: training loss fails to improve by `tol` for `patience` epochs.
    TrainLoss,
}

/// Every setting of a neural model, resolved (defaults per kind filled in).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NeuralConfig {
    #[serde(skip_deserializing, default = "default_kind")]
    pub kind: NeuralKind,
    pub features: FeatureSet,
    /// Standardise each variable with training-split statistics.
    pub standardize: bool,
    /// Add the month's sine and cosine to every day (variant D).
    pub month_features: bool,
    pub max_epochs: usize,
    pub batch_size: usize,
    pub lr: f64,
    pub weight_decay: f64,
    pub optimizer: Optimizer,
    pub loss: Loss,
    /// Draw each epoch's batches with equal class weight (with replacement).
    pub balanced_sampling: bool,
    pub stop_on: StopOn,
    /// Epochs without improvement before stopping.
    pub patience: usize,
    /// Halve the learning rate after this many epochs without improvement (0 = never).
    pub plateau_patience: usize,
    pub plateau_factor: f64,
    /// Minimum improvement counted (scikit-learn's `tol` for the MLP).
    pub tol: f64,
    /// Width of the recurrent or hidden layers.
    pub hidden: i64,
    pub layers: i64,
    pub dropout: f64,
}

fn default_kind() -> NeuralKind {
    NeuralKind::Mlp
}

impl NeuralConfig {
    /// The kind's defaults (the authors' values where they are known).
    pub fn defaults(kind: NeuralKind) -> Self {
        let base = NeuralConfig {
            kind,
            features: FeatureSet::default(),
            standardize: true,
            month_features: false,
            max_epochs: 50,
            batch_size: 64,
            lr: 1e-3,
            weight_decay: 0.01,
            optimizer: Optimizer::Adamw,
            loss: Loss::Bce,
            balanced_sampling: false,
            stop_on: StopOn::ValLoss,
            patience: 10,
            plateau_patience: 0,
            plateau_factor: 0.5,
            tol: 0.0,
            hidden: 64,
            layers: 2,
            dropout: 0.2,
        };
        match kind {
            NeuralKind::Mlp => NeuralConfig {
                max_epochs: 200,
                batch_size: 200,
                lr: 1e-3,
                weight_decay: 1e-4,
                optimizer: Optimizer::AdamL2,
                stop_on: StopOn::TrainLoss,
                tol: 1e-4,
                hidden: 100,
                layers: 1,
                dropout: 0.0,
                ..base
            },
            NeuralKind::Lstm2 => base,
            NeuralKind::Lightts => NeuralConfig {
                hidden: 32,
                layers: 1,
                dropout: 0.1,
                ..base
            },
            // train.py: 14 variables (no etr), no normalisation, BCE, AdamW 1e-4,
            // ReduceLROnPlateau(0.5, 5), ≤ 100 epochs, batch 64, early stop 15 on val loss.
            NeuralKind::CnnBilstm => NeuralConfig {
                features: FeatureSet::Named(FeatureSetName::NoEtr),
                standardize: false,
                max_epochs: 100,
                batch_size: 64,
                lr: 1e-4,
                patience: 15,
                plateau_patience: 5,
                hidden: 128,
                layers: 3,
                dropout: 0.25,
                ..base
            },
            // The deployed model: 14 variables + month sin/cos, standard-scaled, dropout
            // 0.1, hidden 150 × 3. Its training recipe is unknown; the R recipe is used.
            NeuralKind::CnnBilstmAttn => NeuralConfig {
                features: FeatureSet::Named(FeatureSetName::NoEtr),
                standardize: true,
                month_features: true,
                max_epochs: 100,
                lr: 1e-4,
                patience: 15,
                plateau_patience: 5,
                hidden: 150,
                layers: 3,
                dropout: 0.1,
                ..base
            },
            NeuralKind::Firecast => NeuralConfig {
                month_features: true,
                max_epochs: 40,
                batch_size: 128,
                lr: 1e-3,
                weight_decay: 1e-4,
                loss: Loss::Focal {
                    gamma: 2.0,
                    alpha: None,
                },
                balanced_sampling: true,
                stop_on: StopOn::ValAuprc,
                patience: 8,
                plateau_patience: 4,
                hidden: 32,
                layers: 1,
                dropout: 0.2,
                ..base
            },
        }
    }

    /// Defaults of `kind` overlaid with `params` (strict: unknown keys are errors).
    pub fn parse(kind: NeuralKind, params: &serde_json::Value) -> Result<Self, ForecastError> {
        let mut merged =
            serde_json::to_value(Self::defaults(kind)).map_err(|e| ForecastError::Model(e.to_string()))?;
        // `kind` is serialised but not read back: drop it even when `params` is absent
        // (`{kind: mlp}`), or the strict read below calls it an unknown field.
        if let Some(m) = merged.as_object_mut() {
            m.remove("kind");
        }
        if let (Some(m), Some(p)) = (merged.as_object_mut(), params.as_object()) {
            for (k, v) in p {
                if k == "kind" {
                    return Err(ForecastError::Config {
                        key: "kind".into(),
                        message: "unknown field `kind`".into(),
                    });
                }
                m.insert(k.clone(), v.clone());
            }
        } else if !params.is_null() {
            return Err(ForecastError::Config {
                key: String::new(),
                message: "params must be a mapping".into(),
            });
        }
        let mut cfg: NeuralConfig =
            firecast_pipeline::stage::deserialize_params(&merged).map_err(|e| ForecastError::Config {
                key: e.path,
                message: e.message,
            })?;
        cfg.kind = kind;
        let bad = |key: &str, message: &str| {
            Err(ForecastError::Config {
                key: key.into(),
                message: message.into(),
            })
        };
        if cfg.max_epochs == 0 {
            return bad("max_epochs", "must be at least 1");
        }
        if cfg.batch_size == 0 {
            return bad("batch_size", "must be at least 1");
        }
        if !(cfg.lr > 0.0 && cfg.lr.is_finite()) {
            return bad("lr", "must be a positive number");
        }
        if !(0.0..1.0).contains(&cfg.dropout) {
            return bad("dropout", "must be in [0, 1)");
        }
        if cfg.hidden < 1 || cfg.layers < 1 {
            return bad("hidden", "hidden and layers must be at least 1");
        }
        Ok(cfg)
    }
}

// ---------------------------------------------------------------------------------------
// Layers with PyTorch's defaults.

/// nn.Linear as PyTorch initialises it: U(±1/√fan_in) for weights and bias.
fn torch_linear(p: nn::Path<'_>, i: i64, o: i64) -> nn::Linear {
    let b = 1.0 / (i as f64).sqrt();
    nn::linear(
        p,
        i,
        o,
        nn::LinearConfig {
            ws_init: nn::Init::Uniform { lo: -b, up: b },
            bs_init: Some(nn::Init::Uniform { lo: -b, up: b }),
            bias: true,
        },
    )
}

/// nn.Conv1d as PyTorch initialises it.
fn torch_conv1d(p: nn::Path<'_>, i: i64, o: i64, k: i64, padding: i64, dilation: i64) -> nn::Conv1D {
    let b = 1.0 / ((i * k) as f64).sqrt();
    nn::conv1d(
        p,
        i,
        o,
        k,
        nn::ConvConfig {
            padding,
            dilation,
            ws_init: nn::Init::Uniform { lo: -b, up: b },
            bs_init: nn::Init::Uniform { lo: -b, up: b },
            ..Default::default()
        },
    )
}

/// Kaiming-uniform weights, zero biases (what variant D's `_init_weights` does).
fn kaiming_linear(p: nn::Path<'_>, i: i64, o: i64) -> nn::Linear {
    nn::linear(
        p,
        i,
        o,
        nn::LinearConfig {
            ws_init: nn::init::DEFAULT_KAIMING_UNIFORM,
            bs_init: Some(nn::Init::Const(0.0)),
            bias: true,
        },
    )
}

fn kaiming_conv1d(p: nn::Path<'_>, i: i64, o: i64, k: i64, padding: i64) -> nn::Conv1D {
    nn::conv1d(
        p,
        i,
        o,
        k,
        nn::ConvConfig {
            padding,
            ws_init: nn::init::DEFAULT_KAIMING_UNIFORM,
            bs_init: nn::Init::Const(0.0),
            ..Default::default()
        },
    )
}

/// The networks. Input `[batch, time, features]`, output logits `[batch]`.
#[derive(Debug)]
enum Net {
    Mlp {
        hidden: nn::Linear,
        out: nn::Linear,
    },
    Lstm2 {
        rnn: Recurrent,
        fc: nn::Linear,
    },
    LightTs {
        chunk: i64,
        chunks: i64,
        cont_in: nn::Linear,
        cont_out: nn::Linear,
        int_in: nn::Linear,
        int_out: nn::Linear,
        head: nn::Linear,
        out: nn::Linear,
        dropout: f64,
    },
    CnnBiLstm {
        conv1: nn::Conv1D,
        bn1: nn::BatchNorm,
        conv2: nn::Conv1D,
        bn2: nn::BatchNorm,
        rnn: Recurrent,
        fc: nn::Linear,
    },
    CnnBiLstmAttn {
        conv1: nn::Conv1D,
        bn1: nn::BatchNorm,
        conv2: nn::Conv1D,
        bn2: nn::BatchNorm,
        rnn: Recurrent,
        attn: nn::Linear,
        fc1: nn::Linear,
        fc2: nn::Linear,
        dropout: f64,
    },
    Firecast {
        conv1: nn::Conv1D,
        bn1: nn::BatchNorm,
        conv2: nn::Conv1D,
        bn2: nn::BatchNorm,
        rnn: Recurrent,
        attn: nn::Linear,
        fc1: nn::Linear,
        fc2: nn::Linear,
        dropout: f64,
    },
}

fn net(cfg: &NeuralConfig, root: &nn::Path<'_>, features: i64, days: i64) -> Net {
    let h = cfg.hidden;
    match cfg.kind {
        NeuralKind::Mlp => {
            // scikit-learn's Glorot-uniform initialisation, biases included (factor 6 for ReLU).
            let glorot = |i: i64, o: i64| {
                let b = (6.0 / (i + o) as f64).sqrt();
                nn::LinearConfig {
                    ws_init: nn::Init::Uniform { lo: -b, up: b },
                    bs_init: Some(nn::Init::Uniform { lo: -b, up: b }),
                    bias: true,
                }
            };
            let inputs = features * days;
            Net::Mlp {
                hidden: nn::linear(root / "hidden", inputs, h, glorot(inputs, h)),
                out: nn::linear(root / "out", h, 1, glorot(h, 1)),
            }
        }
        NeuralKind::Lstm2 => Net::Lstm2 {
            rnn: Recurrent::new(
                root / "lstm",
                Cell::Lstm,
                features,
                h,
                cfg.layers,
                false,
                cfg.dropout,
            ),
            fc: torch_linear(root / "fc", h, 1),
        },
        NeuralKind::Lightts => {
            let chunk = lightts_chunk(days);
            let chunks = (days + chunk - 1) / chunk;
            Net::LightTs {
                chunk,
                chunks,
                cont_in: torch_linear(root / "cont_in", chunk, h),
                cont_out: torch_linear(root / "cont_out", chunks, 1),
                int_in: torch_linear(root / "int_in", chunks, h),
                int_out: torch_linear(root / "int_out", chunk, 1),
                head: torch_linear(root / "head", features * 2 * h, 2 * h),
                out: torch_linear(root / "out", 2 * h, 1),
                dropout: cfg.dropout,
            }
        }
        NeuralKind::CnnBilstm => Net::CnnBiLstm {
            conv1: torch_conv1d(root / "conv1", features, 64, 3, 1, 1),
            bn1: nn::batch_norm1d(root / "bn1", 64, Default::default()),
            conv2: torch_conv1d(root / "conv2", 64, 128, 3, 1, 1),
            bn2: nn::batch_norm1d(root / "bn2", 128, Default::default()),
            rnn: Recurrent::new(root / "lstm", Cell::Lstm, 128, h, cfg.layers, true, cfg.dropout),
            fc: torch_linear(root / "fc", 2 * h, 1),
        },
        NeuralKind::CnnBilstmAttn => Net::CnnBiLstmAttn {
            conv1: kaiming_conv1d(root / "conv1", features, 64, 3, 1),
            bn1: nn::batch_norm1d(root / "bn1", 64, Default::default()),
            conv2: kaiming_conv1d(root / "conv2", 64, 64, 3, 1),
            bn2: nn::batch_norm1d(root / "bn2", 64, Default::default()),
            rnn: Recurrent::new(root / "lstm", Cell::Lstm, 64, h, cfg.layers, true, cfg.dropout),
            attn: kaiming_linear(root / "attn", 2 * h, 1),
            fc1: kaiming_linear(root / "fc1", 2 * h, h),
            fc2: kaiming_linear(root / "fc2", h, 1),
            dropout: cfg.dropout,
        },
        NeuralKind::Firecast => Net::Firecast {
            conv1: torch_conv1d(root / "conv1", features, 32, 5, 2, 1),
            bn1: nn::batch_norm1d(root / "bn1", 32, Default::default()),
            conv2: torch_conv1d(root / "conv2", 32, 32, 5, 4, 2),
            bn2: nn::batch_norm1d(root / "bn2", 32, Default::default()),
            rnn: Recurrent::new(root / "gru", Cell::Gru, 32, h, cfg.layers, true, cfg.dropout),
            attn: torch_linear(root / "attn", 2 * h, 1),
            fc1: torch_linear(root / "fc1", 2 * h, h),
            fc2: torch_linear(root / "fc2", h, 1),
            dropout: cfg.dropout,
        },
    }
}

/// Chunk length of the LightTS sampler: about √days, so both views are short.
fn lightts_chunk(days: i64) -> i64 {
    ((days as f64).sqrt().round() as i64).max(1)
}

/// Additive attention pooling over time: softmax(Linear(h_t)) weights the outputs.
fn attention_pool(out: &Tensor, attn: &nn::Linear) -> Tensor {
    let scores = out.apply(attn).softmax(1, Kind::Float); // [B, T, 1]
    (out * scores).sum_dim_intlist(1, false, Kind::Float)
}

impl Net {
    fn forward_t(&self, x: &Tensor, train: bool) -> Tensor {
        match self {
            Net::Mlp { hidden, out } => x.flatten(1, 2).apply(hidden).relu().apply(out).squeeze_dim(1),
            Net::Lstm2 { rnn, fc } => {
                let (_, h) = rnn.forward(x, train);
                h.get(rnn.layers() - 1).apply(fc).squeeze_dim(1)
            }
            Net::LightTs {
                chunk,
                chunks,
                cont_in,
                cont_out,
                int_in,
                int_out,
                head,
                out,
                dropout,
            } => {
                let size = x.size();
                let (b, t, f) = (size[0], size[1], size[2]);
                let pad = chunk * chunks - t;
                // Zero days before the window so it splits into whole chunks.
                let x = if pad > 0 {
                    Tensor::cat(
                        &[
                            Tensor::zeros([b, pad, f], (x.kind(), x.device())),
                            x.shallow_clone(),
                        ],
                        1,
                    )
                } else {
                    x.shallow_clone()
                };
                let xf = x.permute([0, 2, 1]); // [B, F, T']
                // Continuous sampling: consecutive days inside a chunk.
                let cont = xf.reshape([b, f, *chunks, *chunk]).apply(cont_in).relu(); // [B,F,n,h]
                let cont = cont.transpose(2, 3).apply(cont_out).squeeze_dim(3); // [B,F,h]
                // Interval sampling: every chunk-th day.
                let int = xf
                    .reshape([b, f, *chunks, *chunk])
                    .transpose(2, 3)
                    .apply(int_in)
                    .relu(); // [B,F,c,h]
                let int = int.transpose(2, 3).apply(int_out).squeeze_dim(3); // [B,F,h]
                let z = Tensor::cat(&[cont, int], 2).flatten(1, 2);
                z.apply(head)
                    .relu()
                    .dropout(*dropout, train)
                    .apply(out)
                    .squeeze_dim(1)
            }
            Net::CnnBiLstm {
                conv1,
                bn1,
                conv2,
                bn2,
                rnn,
                fc,
            } => {
                let z = x.permute([0, 2, 1]);
                let z = z
                    .apply(conv1)
                    .relu()
                    .apply_t(bn1, train)
                    .max_pool1d(2, 2, 0, 1, false);
                let z = z
                    .apply(conv2)
                    .relu()
                    .apply_t(bn2, train)
                    .max_pool1d(2, 2, 0, 1, false);
                let (_, h) = rnn.forward(&z.permute([0, 2, 1]), train);
                let n = h.size()[0];
                Tensor::cat(&[h.get(n - 2), h.get(n - 1)], 1)
                    .apply(fc)
                    .squeeze_dim(1)
            }
            Net::CnnBiLstmAttn {
                conv1,
                bn1,
                conv2,
                bn2,
                rnn,
                attn,
                fc1,
                fc2,
                dropout,
            }
            | Net::Firecast {
                conv1,
                bn1,
                conv2,
                bn2,
                rnn,
                attn,
                fc1,
                fc2,
                dropout,
            } => {
                let z = x.permute([0, 2, 1]);
                let z = z.apply(conv1).apply_t(bn1, train).relu().dropout(*dropout, train);
                let z = z.apply(conv2).apply_t(bn2, train).relu().dropout(*dropout, train);
                let (out, _) = rnn.forward(&z.permute([0, 2, 1]), train);
                let pooled = attention_pool(&out, attn);
                pooled
                    .apply(fc1)
                    .relu()
                    .dropout(*dropout, train)
                    .apply(fc2)
                    .squeeze_dim(1)
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Inputs.

/// Per-variable mean and standard deviation over every training day.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeqScaler {
    pub mean: Vec<f32>,
    pub std: Vec<f32>,
}

/// `[N, T, F(+2)]` inputs of a model: chosen variables, month sin/cos when asked, scaled.
fn input_tensor(
    cfg: &NeuralConfig,
    features: &[String],
    inputs: &Inputs<'_>,
    scaler: Option<&SeqScaler>,
) -> Result<(Vec<f32>, i64, i64), ForecastError> {
    let block: &Block = inputs.block;
    let mut data = crate::features::sequences(block, features)?;
    let nf = features.len();
    let days = block.n_days;
    if let Some(s) = scaler {
        for (i, v) in data.iter_mut().enumerate() {
            let f = i % nf;
            *v = (*v - s.mean[f]) / s.std[f];
        }
    }
    if !cfg.month_features {
        return Ok((data, days as i64, nf as i64));
    }
    let width = nf + 2;
    let mut out = Vec::with_capacity(block.rows() * days * width);
    for (s, m) in inputs.meta.iter().enumerate() {
        for d in 0..days {
            out.extend_from_slice(&data[(s * days + d) * nf..(s * days + d + 1) * nf]);
            let day = m.event_day + block.first_offset + d as i32;
            let (_, month, _) = firecast_data::gridmet::day_to_ymd(day);
            let angle = 2.0 * std::f64::consts::PI * f64::from(month) / 12.0;
            out.push(angle.sin() as f32);
            out.push(angle.cos() as f32);
        }
    }
    Ok((out, days as i64, width as i64))
}

fn fit_scaler(data: &[f32], nf: usize) -> SeqScaler {
    let (mean, std) = crate::features::channel_moments(data, nf);
    SeqScaler { mean, std }
}

// ---------------------------------------------------------------------------------------
// Training.

/// A trained network with everything needed to score new windows.
pub struct NeuralModel {
    pub config: NeuralConfig,
    pub features: Vec<String>,
    pub scaler: Option<SeqScaler>,
    pub days: i64,
    pub width: i64,
    pub epochs_run: usize,
    pub best_epoch: usize,
    vs: nn::VarStore,
    net: Net,
}

impl std::fmt::Debug for NeuralModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NeuralModel")
            .field("kind", &self.config.kind)
            .field("features", &self.features)
            .finish_non_exhaustive()
    }
}

/// What is saved next to the weights.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct NeuralHeader {
    #[serde(deserialize_with = "config_with_kind")]
    pub config: NeuralConfig,
    pub features: Vec<String>,
    pub scaler: Option<SeqScaler>,
    pub days: i64,
    pub width: i64,
    pub epochs_run: usize,
    pub best_epoch: usize,
}

/// A saved config read back with its `kind` (the experiment file's params may not name
/// it, so [`NeuralConfig`] skips it when deserialising; the header must not).
fn config_with_kind<'de, D: serde::Deserializer<'de>>(d: D) -> Result<NeuralConfig, D::Error> {
    use serde::de::Error as _;
    let mut v = serde_json::Value::deserialize(d)?;
    let kind = v
        .as_object_mut()
        .and_then(|m| m.remove("kind"))
        .ok_or_else(|| D::Error::custom("the network's config has no `kind`"))?;
    let kind = kind
        .as_str()
        .and_then(NeuralKind::parse)
        .ok_or_else(|| D::Error::custom(format!("unknown network kind {kind}")))?;
    NeuralConfig::parse(kind, &v).map_err(D::Error::custom)
}

fn loss_of(cfg: &NeuralConfig, logits: &Tensor, y: &Tensor) -> Tensor {
    match cfg.loss {
        Loss::Bce => logits.binary_cross_entropy_with_logits::<Tensor>(y, None, None, tch::Reduction::Mean),
        Loss::Focal { gamma, alpha } => {
            let bce = logits.binary_cross_entropy_with_logits::<Tensor>(y, None, None, tch::Reduction::None);
            let p = logits.sigmoid();
            let p_t: Tensor = &p * y + (1.0 - &p) * (1.0 - y);
            let one_minus: Tensor = p_t.neg() + 1.0;
            let mut loss: Tensor = one_minus.pow_tensor_scalar(gamma) * bce;
            if let Some(a) = alpha {
                loss *= y * a + (1.0 - y) * (1.0 - a);
            }
            loss.mean(Kind::Float)
        }
    }
}

fn scores(net: &Net, x: &Tensor, batch: i64) -> Vec<f64> {
    let n = x.size()[0];
    let mut out = Vec::with_capacity(n as usize);
    tch::no_grad(|| {
        let mut start = 0;
        while start < n {
            let len = batch.min(n - start);
            let p = net
                .forward_t(&x.narrow(0, start, len), false)
                .sigmoid()
                .to_device(Device::Cpu);
            let v: Vec<f32> = Vec::try_from(&p).unwrap_or_default();
            out.extend(v.into_iter().map(f64::from));
            start += len;
        }
    });
    out
}

fn snapshot(vs: &nn::VarStore) -> BTreeMap<String, Tensor> {
    tch::no_grad(|| {
        vs.variables()
            .into_iter()
            .map(|(k, v)| (k, v.to_device(Device::Cpu).copy()))
            .collect()
    })
}

fn restore(vs: &nn::VarStore, best: &BTreeMap<String, Tensor>) {
    tch::no_grad(|| {
        for (k, mut v) in vs.variables() {
            if let Some(b) = best.get(&k) {
                v.copy_(b);
            }
        }
    });
}

/// Trains `cfg` on the training side; the validation side drives early stopping and the
/// plateau schedule (never the test side).
pub fn train(cfg: &NeuralConfig, ctx: &FitContext<'_>) -> Result<NeuralModel, ForecastError> {
    let device = ctx.device;
    let features = cfg.features.resolve(&ctx.train.block.features)?;
    let (raw, _, _) = input_tensor(
        &NeuralConfig {
            month_features: false,
            ..cfg.clone()
        },
        &features,
        &ctx.train,
        None,
    )?;
    let scaler = cfg.standardize.then(|| fit_scaler(&raw, features.len()));
    let (xtr, days, width) = input_tensor(cfg, &features, &ctx.train, scaler.as_ref())?;
    let (xva, _, _) = input_tensor(cfg, &features, &ctx.val, scaler.as_ref())?;
    let n_train = ctx.train_labels.len() as i64;
    let n_val = ctx.val_labels.len() as i64;
    let to_y = |labels: &[bool]| {
        Tensor::from_slice(&labels.iter().map(|&l| f32::from(u8::from(l))).collect::<Vec<_>>())
    };
    let xtr = Tensor::from_slice(&xtr)
        .reshape([n_train, days, width])
        .to_device(device);
    let ytr = to_y(ctx.train_labels).to_device(device);
    let xva = Tensor::from_slice(&xva)
        .reshape([n_val, days, width])
        .to_device(device);
    let yva = to_y(ctx.val_labels).to_device(device);

    // Every fit starts libtorch's one generator from its own seed: weights and dropout masks
    // do not depend on what was fitted before in the process (sharded experiments rely on it).
    tch::manual_seed(ctx.seed as i64);
    let vs = nn::VarStore::new(device);
    let net = net(cfg, &vs.root(), width, days);
    let mut opt = match cfg.optimizer {
        Optimizer::Adamw => nn::AdamW {
            wd: cfg.weight_decay,
            ..Default::default()
        }
        .build(&vs, cfg.lr),
        Optimizer::AdamL2 => nn::Adam::default().build(&vs, cfg.lr),
    }
    .map_err(|e| ForecastError::Model(e.to_string()))?;
    let weights: Vec<Tensor> = vs
        .variables()
        .into_iter()
        .filter(|(k, _)| k.ends_with("weight"))
        .map(|(_, v)| v)
        .collect();

    let mut rng = ChaCha8Rng::seed_from_u64(ctx.seed ^ 0x5eed_f1e5);
    let positives: Vec<i64> = (0..n_train).filter(|&i| ctx.train_labels[i as usize]).collect();
    let negatives: Vec<i64> = (0..n_train).filter(|&i| !ctx.train_labels[i as usize]).collect();
    let mut lr = cfg.lr;
    let higher_better = cfg.stop_on == StopOn::ValAuprc;
    let mut best_score = f64::NEG_INFINITY;
    let mut best_weights = snapshot(&vs);
    let mut best_epoch = 0;
    let mut since_best = 0usize;
    let mut since_plateau_best = 0usize;
    let mut plateau_best = f64::NEG_INFINITY;
    let mut epochs_run = 0;
    let val_labels = ctx.val_labels;
    for epoch in 0..cfg.max_epochs {
        epochs_run = epoch + 1;
        let order: Vec<i64> = if cfg.balanced_sampling {
            (0..n_train)
                .map(|_| {
                    let pool = if rng.random_bool(0.5) {
                        &positives
                    } else {
                        &negatives
                    };
                    pool[rng.random_range(0..pool.len())]
                })
                .collect()
        } else {
            let mut o: Vec<i64> = (0..n_train).collect();
            for i in (1..o.len()).rev() {
                let j = rng.random_range(0..=i);
                o.swap(i, j);
            }
            o
        };
        let mut total = 0.0;
        let mut seen = 0i64;
        for batch in order.chunks(cfg.batch_size) {
            let idx = Tensor::from_slice(batch).to_device(device);
            let xb = xtr.index_select(0, &idx);
            let yb = ytr.index_select(0, &idx);
            let logits = net.forward_t(&xb, true);
            let mut loss = loss_of(cfg, &logits, &yb);
            if cfg.optimizer == Optimizer::AdamL2 {
                let l2: Tensor = weights
                    .iter()
                    .map(|w| w.pow_tensor_scalar(2).sum(Kind::Float))
                    .sum();
                loss += l2 * (0.5 * cfg.weight_decay / batch.len() as f64);
            }
            opt.zero_grad();
            loss.backward();
            opt.step();
            let value = loss.double_value(&[]);
            if !value.is_finite() {
                return Err(ForecastError::Model(format!(
                    "{}: the training loss became {value} in epoch {}; lower `lr`",
                    cfg.kind.as_str(),
                    epoch + 1
                )));
            }
            total += value * batch.len() as f64;
            seen += batch.len() as i64;
        }
        let train_loss = total / seen.max(1) as f64;
        let val_scores = scores(&net, &xva, 1024);
        let val_loss = tch::no_grad(|| {
            let logits = Tensor::from_slice(
                &val_scores
                    .iter()
                    .map(|p| (p.clamp(1e-7, 1.0 - 1e-7) / (1.0 - p.clamp(1e-7, 1.0 - 1e-7))).ln() as f32)
                    .collect::<Vec<_>>(),
            );
            logits
                .binary_cross_entropy_with_logits::<Tensor>(
                    &yva.to_device(Device::Cpu),
                    None,
                    None,
                    tch::Reduction::Mean,
                )
                .double_value(&[])
        });
        let val_auprc =
            firecast_eval::metrics::average_precision(val_labels, &val_scores).unwrap_or(f64::NAN);
        (ctx.curve)(epoch as i64 + 1, "train_loss", train_loss);
        (ctx.curve)(epoch as i64 + 1, "val_loss", val_loss);
        (ctx.curve)(epoch as i64 + 1, "val_auprc", val_auprc);
        (ctx.curve)(epoch as i64 + 1, "lr", lr);
        (ctx.progress)(epoch as u64 + 1, cfg.max_epochs as u64, "epoch");
        let score = match cfg.stop_on {
            StopOn::ValLoss => -val_loss,
            StopOn::ValAuprc => val_auprc,
            StopOn::TrainLoss => -train_loss,
        };
        let _ = higher_better;
        if score > best_score + cfg.tol {
            best_score = score;
            best_epoch = epoch + 1;
            since_best = 0;
            if cfg.stop_on != StopOn::TrainLoss {
                best_weights = snapshot(&vs);
            }
        } else {
            since_best += 1;
        }
        // ReduceLROnPlateau(mode, factor, patience) with PyTorch's default threshold 1e-4 (rel).
        if cfg.plateau_patience > 0 {
            let improved = score > plateau_best + 1e-4 * plateau_best.abs();
            if improved {
                plateau_best = score;
                since_plateau_best = 0;
            } else {
                since_plateau_best += 1;
                if since_plateau_best > cfg.plateau_patience {
                    lr *= cfg.plateau_factor;
                    opt.set_lr(lr);
                    since_plateau_best = 0;
                }
            }
        }
        if since_best >= cfg.patience {
            break;
        }
    }
    // scikit-learn's MLP keeps its last weights; the others go back to their best epoch.
    if cfg.stop_on != StopOn::TrainLoss {
        restore(&vs, &best_weights);
    }
    Ok(NeuralModel {
        config: cfg.clone(),
        features,
        scaler,
        days,
        width,
        epochs_run,
        best_epoch,
        vs,
        net,
    })
}

impl NeuralModel {
    pub fn predict(&self, inputs: &Inputs<'_>, device: Device) -> Result<Vec<f64>, ForecastError> {
        if inputs.block.n_days as i64 != self.days {
            return Err(ForecastError::Config {
                key: "days".into(),
                message: format!(
                    "the model reads {}-day windows but the inputs have {} days",
                    self.days, inputs.block.n_days
                ),
            });
        }
        let (x, days, width) = input_tensor(&self.config, &self.features, inputs, self.scaler.as_ref())?;
        let n = inputs.block.rows() as i64;
        let x = Tensor::from_slice(&x)
            .reshape([n, days, width])
            .to_device(self.vs.device());
        let _ = device;
        Ok(scores(&self.net, &x, 1024))
    }

    /// The network's inputs for `inputs`, exactly as training and [`Self::predict`] build
    /// them (chosen variables, training-split scaling, month sin/cos): `[N, days, width]`
    /// row-major. The bench hands these to scikit-learn's MLP so both fit the same numbers.
    pub fn prepared_inputs(&self, inputs: &Inputs<'_>) -> Result<Vec<f32>, ForecastError> {
        Ok(input_tensor(&self.config, &self.features, inputs, self.scaler.as_ref())?.0)
    }

    pub fn parameter_count(&self) -> i64 {
        self.vs
            .trainable_variables()
            .iter()
            .map(|t| t.numel() as i64)
            .sum()
    }

    pub fn header(&self) -> NeuralHeader {
        NeuralHeader {
            config: self.config.clone(),
            features: self.features.clone(),
            scaler: self.scaler.clone(),
            days: self.days,
            width: self.width,
            epochs_run: self.epochs_run,
            best_epoch: self.best_epoch,
        }
    }

    /// Weights as safetensors (PyTorch state-dict names).
    pub fn save_weights(&self, path: &std::path::Path) -> Result<(), ForecastError> {
        self.vs
            .save(path)
            .map_err(|e| ForecastError::Model(format!("saving {}: {e}", path.display())))
    }

    /// Rebuilds the network of `header` and loads its weights.
    pub fn load(
        header: NeuralHeader,
        weights: &std::path::Path,
        device: Device,
    ) -> Result<Self, ForecastError> {
        let mut vs = nn::VarStore::new(device);
        let net = net(&header.config, &vs.root(), header.width, header.days);
        vs.load(weights).map_err(|e| ForecastError::Data {
            path: weights.to_path_buf(),
            message: format!(
                "cannot load the weights of a `{}` model: {e}",
                header.config.kind.as_str()
            ),
        })?;
        Ok(Self {
            config: header.config,
            features: header.features,
            scaler: header.scaler,
            days: header.days,
            width: header.width,
            epochs_run: header.epochs_run,
            best_epoch: header.best_epoch,
            vs,
            net,
        })
    }

    /// Named parameter shapes (for the PyTorch parity check).
    pub fn parameter_shapes(&self) -> BTreeMap<String, Vec<i64>> {
        self.vs
            .variables()
            .into_iter()
            .map(|(k, v)| (k, v.size()))
            .collect()
    }
}

/// Builds an untrained network of `cfg` for `features` × `days` inputs and counts its
/// trainable parameters (the PyTorch reference builds the same net and counts its own).
pub fn count_parameters(cfg: &NeuralConfig, width: i64, days: i64) -> i64 {
    let vs = nn::VarStore::new(Device::Cpu);
    let _net = net(cfg, &vs.root(), width, days);
    vs.trainable_variables().iter().map(|t| t.numel() as i64).sum()
}

/// Training speed of one network, measured as the PyTorch reference measures it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TrainingThroughput {
    pub kind: String,
    pub batch: usize,
    pub warmup_steps: usize,
    pub steps: usize,
    pub threads: usize,
    pub seconds: f64,
    pub samples_per_s: f64,
}

/// Times `steps` training steps of `cfg`'s network on `[rows, days, width]` standard-normal
/// inputs with 40 % positive labels: a random batch of `cfg.batch_size` rows, forward in
/// training mode, BCE on the logits, backward, an AdamW step (`cfg.lr`, `cfg.weight_decay`).
/// `warmup` steps run first and are not timed (allocator and kernel warm-up). This is what
/// `forecast_torch.py bench` does in PyTorch eager, so the two rates compare the same work.
pub fn training_throughput(
    cfg: &NeuralConfig,
    width: i64,
    days: i64,
    rows: i64,
    warmup: usize,
    steps: usize,
    seed: u64,
) -> Result<TrainingThroughput, ForecastError> {
    if rows < 1 || steps == 0 {
        return Err(ForecastError::Config {
            key: "steps".into(),
            message: "the throughput bench needs at least one row and one timed step".into(),
        });
    }
    let device = Device::Cpu;
    tch::manual_seed(seed as i64);
    let vs = nn::VarStore::new(device);
    let net = net(cfg, &vs.root(), width, days);
    let x = Tensor::randn([rows, days, width], (Kind::Float, device));
    let y = Tensor::rand([rows], (Kind::Float, device))
        .lt(0.4)
        .to_kind(Kind::Float);
    let mut opt = nn::AdamW {
        wd: cfg.weight_decay,
        ..Default::default()
    }
    .build(&vs, cfg.lr)
    .map_err(|e| ForecastError::Model(e.to_string()))?;
    let batch = cfg.batch_size as i64;
    let mut step = || -> Result<(), ForecastError> {
        let idx = Tensor::randint(rows, [batch], (Kind::Int64, device));
        let logits = net.forward_t(&x.index_select(0, &idx), true);
        let loss = logits.binary_cross_entropy_with_logits::<Tensor>(
            &y.index_select(0, &idx),
            None,
            None,
            tch::Reduction::Mean,
        );
        opt.zero_grad();
        loss.backward();
        opt.step();
        if loss.double_value(&[]).is_finite() {
            Ok(())
        } else {
            Err(ForecastError::Model(format!(
                "{}: the bench loss is not finite",
                cfg.kind.as_str()
            )))
        }
    };
    for _ in 0..warmup {
        step()?;
    }
    let t0 = std::time::Instant::now();
    for _ in 0..steps {
        step()?;
    }
    let seconds = t0.elapsed().as_secs_f64();
    Ok(TrainingThroughput {
        kind: cfg.kind.as_str().into(),
        batch: cfg.batch_size,
        warmup_steps: warmup,
        steps,
        threads: tch::get_num_threads().max(1) as usize,
        seconds,
        samples_per_s: (steps * cfg.batch_size) as f64 / seconds.max(1e-12),
    })
}

#[allow(dead_code)]
fn _assert_module_traits(l: &nn::Linear) -> Tensor {
    l.forward(&Tensor::zeros([1, 1], (Kind::Float, Device::Cpu)))
}

#[allow(dead_code)]
fn _assert_module_t(b: &nn::BatchNorm, x: &Tensor) -> Tensor {
    b.forward_t(x, false)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn absent_params_mean_the_kinds_defaults() {
        // `{kind: mlp}` in an experiment file has no params at all.
        for kind in [NeuralKind::Mlp, NeuralKind::CnnBilstm, NeuralKind::Firecast] {
            let cfg = NeuralConfig::parse(kind, &serde_json::Value::Null).unwrap();
            assert_eq!(cfg, NeuralConfig::defaults(kind));
        }
        let e = NeuralConfig::parse(NeuralKind::Mlp, &serde_json::json!({"kind": "lstm2"})).unwrap_err();
        assert!(e.to_string().contains("kind"), "{e}");
    }

    #[test]
    fn a_saved_header_reads_back_with_its_kind() {
        for kind in [
            NeuralKind::CnnBilstm,
            NeuralKind::CnnBilstmAttn,
            NeuralKind::Lstm2,
        ] {
            let mut config = NeuralConfig::defaults(kind);
            config.hidden = 7;
            let header = NeuralHeader {
                config: config.clone(),
                features: vec!["erc".into()],
                scaler: None,
                days: 75,
                width: 1,
                epochs_run: 3,
                best_epoch: 2,
            };
            let text = serde_json::to_string(&header).unwrap();
            let back: NeuralHeader = serde_json::from_str(&text).unwrap();
            assert_eq!(back.config, config, "{text}");
        }
        let e = serde_json::from_str::<NeuralHeader>(
            r#"{"config": {"kind": "svm"}, "features": [], "scaler": null, "days": 1, "width": 1, "epochs_run": 1, "best_epoch": 1}"#,
        )
        .unwrap_err();
        assert!(e.to_string().contains("unknown network kind"), "{e}");
    }
}
