//! Every model of the comparison behind one interface: parse strict params, fit on the
//! training side (the validation side may stop training), score any samples.

use serde::{Deserialize, Serialize};

use crate::ForecastError;
use crate::data::{Block, SampleMeta};
use crate::features::{FeatureSet, window_statistics};
use crate::neural::{NeuralConfig, NeuralKind, NeuralModel};
// The interface lives below the models that implement it (neural, minirocket); callers
// reach it here, beside the dispatcher.
use crate::inputs::{FitContext, Inputs};
use firecast_baselines::Standardizer as Scaler;

/// Model kinds, in the order tables list them when an experiment does not say otherwise.
pub const KINDS: &[&str] = &[
    "majority",
    "climatology",
    "fire_danger_index",
    "logistic_regression",
    "gaussian_nb",
    "decision_tree",
    "random_forest",
    "gradient_boosting",
    "knn",
    "xgboost",
    "mlp",
    "window_stats_xgboost",
    "minirocket",
    "lstm2",
    "lightts",
    "cnn_bilstm",
    "cnn_bilstm_attn",
    "firecast",
    "climate_boost",
    "climate_offset",
];

/// Inputs shared by the flattened baselines: which variables, scaled or not.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlatInputs {
    /// Variables (default: all of the dataset's, as the paper's 1125-dim vectors).
    #[serde(default)]
    pub features: FeatureSet,
    /// Standardise with training-split statistics (sklearn's StandardScaler in a pipeline).
    #[serde(default)]
    pub standardize: Option<bool>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClimatologyParams {
    /// Gaussian kernel width over the day of the year.
    #[serde(default = "default_bandwidth")]
    pub bandwidth_days: f64,
    /// Places are pooled in square blocks of this size.
    #[serde(default = "default_block")]
    pub block_degrees: f64,
    /// Pseudo-samples pulling a block's rate toward the region-wide seasonal rate.
    #[serde(default = "default_prior")]
    pub prior_strength: f64,
    /// Pool places with a Gaussian kernel of this width (degrees of latitude; longitude
    /// scaled by the cosine of the latitude) instead of square blocks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kernel_degrees: Option<f64>,
}

/// A candidate fire history of `climate_offset`: its climatology, the training samples'
/// left-out log-odds, their recalibration, the validation offsets and their log loss.
struct FireHistory {
    val_loss: f64,
    params: ClimatologyParams,
    left_out: Vec<f32>,
    /// The validation samples' offsets (the fitted climatology's, recalibrated).
    val_margin: Vec<f32>,
    calibration: (f64, f64),
    samples: Vec<Place>,
}

/// One sample as the climatology sees it.
#[derive(Debug, Clone, Copy)]
struct Place {
    doy: u32,
    block: (i64, i64),
    lat: f64,
    lon: f64,
    label: bool,
}

fn default_bandwidth() -> f64 {
    15.0
}
fn default_block() -> f64 {
    0.25
}
fn default_prior() -> f64 {
    10.0
}

impl Default for ClimatologyParams {
    /// The climatology's defaults: 15-day season kernel, 0.25° blocks, prior strength 10.
    fn default() -> Self {
        Self {
            bandwidth_days: default_bandwidth(),
            block_degrees: default_block(),
            prior_strength: default_prior(),
            kernel_degrees: None,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DangerIndexParams {
    /// The index variable; its value on the last input day is the score.
    #[serde(default = "default_index")]
    pub feature: String,
}

fn default_index() -> String {
    "erc".into()
}

/// XGBoost's own parameters (strict, XGBoost's names) plus the variables to read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct XgbEntry {
    pub features: FeatureSet,
    pub params: firecast_xgboost::XgbParams,
}

impl XgbEntry {
    fn parse(params: &serde_json::Value) -> Result<Self, ForecastError> {
        let mut rest = match params {
            serde_json::Value::Null => serde_json::Map::new(),
            serde_json::Value::Object(m) => m.clone(),
            _ => {
                return Err(ForecastError::Config {
                    key: String::new(),
                    message: "params must be a mapping".into(),
                });
            }
        };
        let features = match rest.remove("features") {
            Some(v) => strict(&v).map_err(|e| match e {
                ForecastError::Config { message, .. } => ForecastError::Config {
                    key: "features".into(),
                    message,
                },
                other => other,
            })?,
            None => FeatureSet::default(),
        };
        let params = firecast_xgboost::XgbParams::from_json(&serde_json::Value::Object(rest)).map_err(
            |e| match e {
                firecast_xgboost::XgbError::Param { key, message } => ForecastError::Config { key, message },
                other => ForecastError::Model(other.to_string()),
            },
        )?;
        Ok(Self { features, params })
    }
}

/// `climate_offset`: the booster's parameters and the fire history's kernel widths to choose
/// from on validation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClimateOffsetParams {
    pub boost: XgbEntry,
    /// Candidate widths (degrees) of the climatology's place kernel; the one with the lowest
    /// validation log loss is used. Empty: the climatology's 0.25° blocks.
    pub kernel_degrees: Vec<f64>,
}

impl ClimateOffsetParams {
    fn parse(params: &serde_json::Value) -> Result<Self, ForecastError> {
        // `kernel_degrees` is ours; the rest are the booster's (a non-mapping is XgbEntry's error).
        let mut rest = params.as_object().cloned();
        let kernel_degrees = match rest.as_mut().and_then(|r| r.remove("kernel_degrees")) {
            None => vec![0.05, 0.1, 0.2, 0.3, 0.5],
            Some(v) => {
                let widths: Vec<f64> = serde_json::from_value(v).map_err(|e| ForecastError::Config {
                    key: "kernel_degrees".into(),
                    message: format!("a list of widths in degrees: {e}"),
                })?;
                if let Some(w) = widths.iter().find(|w| !(w.is_finite() && **w > 0.0)) {
                    return Err(ForecastError::Config {
                        key: "kernel_degrees".into(),
                        message: format!("widths must be positive degrees, got {w}"),
                    });
                }
                widths
            }
        };
        let boost = match rest {
            Some(rest) => XgbEntry::parse(&serde_json::Value::Object(rest))?,
            None => XgbEntry::parse(params)?,
        };
        Ok(Self {
            boost,
            kernel_degrees,
        })
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MiniRocketParams {
    #[serde(default)]
    pub features: FeatureSet,
    /// Number of random-convolution features (rounded down to a multiple of 84).
    #[serde(default = "default_rocket_features")]
    pub num_features: usize,
    /// Inverse L2 strength of the logistic head (on standardised features).
    #[serde(default = "default_rocket_c")]
    pub c: f64,
    #[serde(default = "default_rocket_iter")]
    pub max_iter: usize,
}

fn default_rocket_features() -> usize {
    2016
}
fn default_rocket_c() -> f64 {
    0.1
}
fn default_rocket_iter() -> usize {
    300
}

/// A model's parsed configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind", content = "params")]
pub enum ModelConfig {
    Majority,
    Climatology(ClimatologyParams),
    FireDangerIndex(DangerIndexParams),
    Baseline {
        inputs: FlatInputs,
        spec: firecast_baselines::BaselineSpec,
    },
    Xgboost(XgbEntry),
    WindowStatsXgboost(XgbEntry),
    /// FireCast's blend of where and when: the window statistics and the climatology's rate
    /// (left out for each training sample's own label) in one boosted model.
    ClimateBoost(XgbEntry),
    /// FireCast's weather-on-climatology forecaster: boosted window statistics that correct
    /// the climatology's log-odds (XGBoost's `base_margin`), so the place's fire history
    /// sets the starting point and the weather moves it; the number of trees is chosen on
    /// validation log loss (zero trees leaves the climatology).
    ClimateOffset(ClimateOffsetParams),
    MiniRocket(MiniRocketParams),
    Neural(NeuralConfig),
}

fn strict<T: serde::de::DeserializeOwned>(params: &serde_json::Value) -> Result<T, ForecastError> {
    let value = if params.is_null() {
        serde_json::json!({})
    } else {
        params.clone()
    };
    serde_path_to_error_like(value)
}

/// serde's error with the key path that failed (params are small JSON objects).
fn serde_path_to_error_like<T: serde::de::DeserializeOwned>(
    value: serde_json::Value,
) -> Result<T, ForecastError> {
    match firecast_pipeline::stage::deserialize_params::<T>(&value) {
        Ok(v) => Ok(v),
        Err(e) => Err(ForecastError::Config {
            key: e.path.replace(".?", ""),
            message: e.message,
        }),
    }
}

impl ModelConfig {
    /// `kind` + its params; an unknown kind or key is an error naming it.
    pub fn parse(kind: &str, params: &serde_json::Value) -> Result<Self, ForecastError> {
        let split_inputs =
            |params: &serde_json::Value| -> Result<(FlatInputs, serde_json::Value), ForecastError> {
                let mut rest = if params.is_null() {
                    serde_json::Map::new()
                } else {
                    params.as_object().cloned().ok_or_else(|| ForecastError::Config {
                        key: String::new(),
                        message: "params must be a mapping".into(),
                    })?
                };
                let mut inputs = serde_json::Map::new();
                for k in ["features", "standardize"] {
                    if let Some(v) = rest.remove(k) {
                        inputs.insert(k.into(), v);
                    }
                }
                Ok((
                    strict(&serde_json::Value::Object(inputs))?,
                    serde_json::Value::Object(rest),
                ))
            };
        let baseline = |model: &str, params: &serde_json::Value| -> Result<ModelConfig, ForecastError> {
            let (inputs, rest) = split_inputs(params)?;
            let spec = firecast_baselines::BaselineSpec::from_kind(model, &rest).map_err(|e| {
                ForecastError::Config {
                    key: String::new(),
                    message: e.to_string(),
                }
            })?;
            Ok(ModelConfig::Baseline { inputs, spec })
        };
        Ok(match kind {
            "majority" => {
                let _: EmptyParams = strict(params)?;
                ModelConfig::Majority
            }
            "climatology" => ModelConfig::Climatology(strict(params)?),
            "fire_danger_index" => ModelConfig::FireDangerIndex(strict(params)?),
            "logistic_regression"
            | "gaussian_nb"
            | "decision_tree"
            | "random_forest"
            | "gradient_boosting"
            | "knn" => baseline(kind, params)?,
            "xgboost" => ModelConfig::Xgboost(XgbEntry::parse(params)?),
            "window_stats_xgboost" => ModelConfig::WindowStatsXgboost(XgbEntry::parse(params)?),
            "climate_boost" => ModelConfig::ClimateBoost(XgbEntry::parse(params)?),
            "climate_offset" => ModelConfig::ClimateOffset(ClimateOffsetParams::parse(params)?),
            "minirocket" => ModelConfig::MiniRocket(strict(params)?),
            "mlp" | "lstm2" | "lightts" | "cnn_bilstm" | "cnn_bilstm_attn" | "firecast" => {
                let kind = NeuralKind::parse(kind)
                    .ok_or_else(|| ForecastError::UnknownModel { kind: kind.into() })?;
                ModelConfig::Neural(NeuralConfig::parse(kind, params)?)
            }
            other => return Err(ForecastError::UnknownModel { kind: other.into() }),
        })
    }

    /// XGBoost's `nthread` from the experiment's `threads` when the model's `params` name
    /// none (the count can change the trees, so it must not be the machine's core count).
    pub fn with_threads(mut self, threads: usize, params: &serde_json::Value) -> Self {
        if let ModelConfig::Xgboost(x)
        | ModelConfig::WindowStatsXgboost(x)
        | ModelConfig::ClimateBoost(x)
        | ModelConfig::ClimateOffset(ClimateOffsetParams { boost: x, .. }) = &mut self
            && params.get("nthread").is_none()
        {
            x.params.nthread = u32::try_from(threads).unwrap_or(u32::MAX);
        }
        self
    }

    /// Whether training draws random numbers (then every seed is a separate run).
    pub fn is_stochastic(&self) -> bool {
        match self {
            ModelConfig::Majority | ModelConfig::Climatology(_) | ModelConfig::FireDangerIndex(_) => false,
            ModelConfig::Baseline { spec, .. } => {
                matches!(spec, firecast_baselines::BaselineSpec::RandomForest(_))
            }
            ModelConfig::Xgboost(e)
            | ModelConfig::WindowStatsXgboost(e)
            | ModelConfig::ClimateBoost(e)
            | ModelConfig::ClimateOffset(ClimateOffsetParams { boost: e, .. }) => {
                e.params.subsample < 1.0 || e.params.colsample_bytree < 1.0
            }
            ModelConfig::MiniRocket(_) | ModelConfig::Neural(_) => true,
        }
    }

    /// The default threshold rule: the authors' fixed 0.5 for their own model, else chosen
    /// on validation by F1.
    pub fn default_threshold(&self) -> ThresholdRule {
        match self {
            ModelConfig::Neural(n)
                if n.kind == NeuralKind::CnnBilstm || n.kind == NeuralKind::CnnBilstmAttn =>
            {
                ThresholdRule::Fixed(0.5)
            }
            _ => ThresholdRule::MaxF1,
        }
    }
}

/// Threshold rules; all are decided before the test set is looked at.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ThresholdRule {
    /// A fixed threshold (the authors' 0.5).
    Fixed(f64),
    /// The threshold that maximises F1 on validation.
    MaxF1,
    /// Youden's J on validation.
    Youden,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct EmptyParams {}

/// A fitted model.
#[derive(Serialize, Deserialize)]
#[allow(clippy::large_enum_variant)] // one value per fitted model; boxing buys nothing
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Trained {
    Majority {
        prevalence: f64,
    },
    Climatology {
        params: ClimatologyParams,
        /// Per training sample: (day of year, block row, block col, label).
        samples: Vec<(u32, i64, i64, bool)>,
        /// Per training sample: (latitude, longitude), for the kernel (absent in models saved
        /// before it existed, which pool by blocks).
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        coords: Vec<(f64, f64)>,
        prevalence: f64,
    },
    FireDangerIndex {
        feature: String,
        /// Logistic calibration of the raw index on training data: p = σ(a·x + b).
        a: f64,
        b: f64,
    },
    Baseline {
        features: Vec<String>,
        scaler: Option<Scaler>,
        model: firecast_baselines::Fitted,
    },
    Xgboost {
        features: Vec<String>,
        stats: bool,
        /// The booster as XGBoost's own JSON model.
        model_json: String,
    },
    ClimateBoost {
        /// The climatology ([`Trained::Climatology`]) whose rate is the booster's last input.
        climatology: Box<Trained>,
        features: Vec<String>,
        model_json: String,
    },
    ClimateOffset {
        /// The climatology ([`Trained::Climatology`]) whose log-odds the trees correct.
        climatology: Box<Trained>,
        /// The offset: a·logit(climatology) + b, fitted on the training labels.
        calibration: (f64, f64),
        features: Vec<String>,
        model_json: String,
        /// Trees used (chosen on validation log loss); 0 is the climatology alone.
        rounds: u32,
    },
    MiniRocket {
        features: Vec<String>,
        rocket: crate::minirocket::MiniRocket,
        scaler: Scaler,
        head: firecast_baselines::Fitted,
    },
    /// Saved as a header and safetensors weights by [`crate::bundle`].
    #[serde(skip)]
    Neural(NeuralModel),
}

pub fn fit(config: &ModelConfig, ctx: &FitContext<'_>) -> Result<Trained, ForecastError> {
    let y = ctx.train_labels;
    let prevalence = y.iter().filter(|&&l| l).count() as f64 / y.len().max(1) as f64;
    Ok(match config {
        ModelConfig::Majority => Trained::Majority { prevalence },
        ModelConfig::Climatology(p) => {
            climatology_model(p.clone(), &places(&ctx.train.meta, y, p), prevalence)
        }
        ModelConfig::FireDangerIndex(p) => {
            let x = last_day_values(ctx.train.block, &p.feature)?;
            let (a, b) = crate::features::fit_logistic_1d(&x, y);
            Trained::FireDangerIndex {
                feature: p.feature.clone(),
                a,
                b,
            }
        }
        ModelConfig::Baseline { inputs, spec } => {
            let features = inputs.features.resolve(&ctx.train.block.features)?;
            let x = crate::features::flatten(ctx.train.block, &features)?;
            let standardize = inputs.standardize.unwrap_or_else(|| spec.wants_standardized());
            let scaler = standardize
                .then(|| Scaler::fit(&x))
                .transpose()
                .map_err(model_err)?;
            let x = match &scaler {
                Some(s) => s.transform(&x).map_err(model_err)?,
                None => x,
            };
            let report = |done: usize, total: usize| (ctx.progress)(done as u64, total as u64, "fit");
            let model = firecast_baselines::fit_with_progress(spec, &x, y, ctx.seed, &report)
                .map_err(|e| ForecastError::Model(e.to_string()))?;
            Trained::Baseline {
                features,
                scaler,
                model,
            }
        }
        ModelConfig::Xgboost(e) | ModelConfig::WindowStatsXgboost(e) => {
            let stats = matches!(config, ModelConfig::WindowStatsXgboost(_));
            let features = e.features.resolve(&ctx.train.block.features)?;
            let x = if stats {
                window_statistics(ctx.train.block, &features)?
            } else {
                crate::features::flatten(ctx.train.block, &features)?
            };
            let model_json = fit_booster(&x, y, e, ctx)?;
            Trained::Xgboost {
                features,
                stats,
                model_json,
            }
        }
        ModelConfig::ClimateBoost(e) => {
            let params = ClimatologyParams::default();
            let samples = places(&ctx.train.meta, y, &params);
            // Each training sample's climatology without its own label (else the booster
            // learns to read the answer from the rate).
            let rates = climatology_rates(&params, &samples, prevalence, &samples, true);
            let features = e.features.resolve(&ctx.train.block.features)?;
            let x = with_rate(window_statistics(ctx.train.block, &features)?, &rates);
            let model_json = fit_booster(&x, y, e, ctx)?;
            Trained::ClimateBoost {
                climatology: Box::new(climatology_model(params, &samples, prevalence)),
                features,
                model_json,
            }
        }
        ModelConfig::ClimateOffset(o) => {
            let e = &o.boost;
            // The fire history: the climatology whose kernel width gives the lowest
            // validation log loss. Each training sample's rate leaves out its own label (else
            // the offset already holds the answer and the trees learn nothing about weather);
            // left-out rates are shrunk a little more than the fitted climatology's, so the
            // offset is the log-odds recalibrated on training labels: a·logit(rate) + b.
            let mut candidates: Vec<Option<f64>> = o.kernel_degrees.iter().copied().map(Some).collect();
            if candidates.is_empty() {
                candidates.push(None);
            }
            let mut best: Option<FireHistory> = None;
            for kernel in candidates {
                let params = ClimatologyParams {
                    kernel_degrees: kernel,
                    ..ClimatologyParams::default()
                };
                let samples = places(&ctx.train.meta, y, &params);
                let left_out = log_odds(&climatology_rates(&params, &samples, prevalence, &samples, true));
                let (a, b) = crate::features::fit_logistic_1d(&left_out, y);
                let queries = places(&ctx.val.meta, ctx.val_labels, &params);
                let val_margin = recalibrate(
                    &log_odds(&climatology_rates(&params, &samples, prevalence, &queries, false)),
                    a,
                    b,
                );
                let score = if ctx.val_labels.is_empty() {
                    0.0
                } else {
                    let p: Vec<f64> = val_margin
                        .iter()
                        .map(|&z| 1.0 / (1.0 + (-f64::from(z)).exp()))
                        .collect();
                    log_loss(&p, ctx.val_labels)
                };
                if best.as_ref().is_none_or(|b| score < b.val_loss) {
                    best = Some(FireHistory {
                        val_loss: score,
                        params,
                        left_out,
                        val_margin,
                        calibration: (a, b),
                        samples,
                    });
                }
            }
            let Some(FireHistory {
                params,
                left_out,
                val_margin,
                calibration: (a, b),
                samples,
                ..
            }) = best
            else {
                unreachable!("at least one candidate")
            };
            let margin = recalibrate(&left_out, a, b);
            let features = e.features.resolve(&ctx.train.block.features)?;
            let x = window_statistics(ctx.train.block, &features)?;
            let report = |done: u32, total: u32| (ctx.progress)(u64::from(done), u64::from(total), "boost");
            let booster = firecast_xgboost::Booster::fit_with_margin(
                &x.data, x.rows, x.cols, y, &margin, &e.params, ctx.seed, report,
            )
            .map_err(|e| ForecastError::Model(e.to_string()))?;
            let climatology = climatology_model(params, &samples, prevalence);
            // Early stopping on validation: the tree count with the lowest log loss.
            let rounds = if ctx.val_labels.is_empty() {
                e.params.n_estimators
            } else {
                let xv = window_statistics(ctx.val.block, &features)?;
                let mut best = (f64::INFINITY, 0u32);
                for k in 0..=e.params.n_estimators {
                    let p = booster
                        .predict_proba_with_margin(&xv.data, xv.rows, xv.cols, &val_margin, Some(k))
                        .map_err(|e| ForecastError::Model(e.to_string()))?;
                    let loss = log_loss(&p, ctx.val_labels);
                    if loss < best.0 {
                        best = (loss, k);
                    }
                }
                best.1
            };
            let json = booster
                .save_json()
                .map_err(|e| ForecastError::Model(e.to_string()))?;
            Trained::ClimateOffset {
                climatology: Box::new(climatology),
                calibration: (a, b),
                features,
                model_json: String::from_utf8_lossy(&json).into_owned(),
                rounds,
            }
        }
        ModelConfig::MiniRocket(p) => {
            let features = p.features.resolve(&ctx.train.block.features)?;
            let rocket =
                crate::minirocket::MiniRocket::fit(ctx.train.block, &features, p.num_features, ctx.seed)?;
            let x = rocket.transform(ctx.train.block, ctx.progress)?;
            let scaler = Scaler::fit(&x).map_err(model_err)?;
            let x = scaler.transform(&x).map_err(model_err)?;
            let spec = firecast_baselines::BaselineSpec::from_kind(
                "logistic_regression",
                &serde_json::json!({"c": p.c, "max_iter": p.max_iter}),
            )
            .map_err(|e| ForecastError::Model(e.to_string()))?;
            let head = firecast_baselines::fit(&spec, &x, y, ctx.seed)
                .map_err(|e| ForecastError::Model(e.to_string()))?;
            Trained::MiniRocket {
                features,
                rocket,
                scaler,
                head,
            }
        }
        ModelConfig::Neural(n) => Trained::Neural(crate::neural::train(n, ctx)?),
    })
}

fn model_err(e: firecast_baselines::BaselineError) -> ForecastError {
    ForecastError::Model(e.to_string())
}

fn block_of(m: &SampleMeta, deg: f64) -> (i64, i64) {
    ((m.lat / deg).floor() as i64, (m.lon / deg).floor() as i64)
}

fn last_day_values(block: &Block, feature: &str) -> Result<Vec<f32>, ForecastError> {
    let f = block
        .features
        .iter()
        .position(|n| n == feature)
        .ok_or_else(|| ForecastError::Config {
            key: "params.feature".into(),
            message: format!(
                "the dataset has no variable `{feature}` (it has {})",
                block.features.join(", ")
            ),
        })?;
    let nf = block.n_features();
    let d = block.n_days - 1;
    Ok((0..block.rows()).map(|s| block.sample(s)[d * nf + f]).collect())
}

/// The climatology's rate at each query: the region's seasonal rate (a Gaussian kernel over
/// the day of the year), and the place's rate (its block's, or a Gaussian kernel over
/// distance) shrunk toward it. With `leave_out`, `queries` are the training `samples`
/// themselves and each one's own label and weight are left out of its rate.
fn climatology_rates(
    params: &ClimatologyParams,
    samples: &[Place],
    prevalence: f64,
    queries: &[Place],
    leave_out: bool,
) -> Vec<f64> {
    let kernel = |a: u32, b: u32| {
        let d = doy_distance(a, b) / params.bandwidth_days;
        (-0.5 * d * d).exp()
    };
    let n = samples.len() as f64;
    queries
        .iter()
        .map(|q| {
            let cos_lat = q.lat.to_radians().cos();
            let nearby = |s: &Place| -> f64 {
                match params.kernel_degrees {
                    None => f64::from(u8::from(s.block == q.block)),
                    Some(width) => {
                        let dx = (s.lon - q.lon) * cos_lat / width;
                        let dy = (s.lat - q.lat) / width;
                        (-0.5 * (dx * dx + dy * dy)).exp()
                    }
                }
            };
            let (mut gw, mut gp, mut bw, mut bp) = (0.0, 0.0, 0.0, 0.0);
            for s in samples {
                let k = kernel(q.doy, s.doy);
                let l = f64::from(u8::from(s.label));
                gw += k;
                gp += k * l;
                let w = k * nearby(s);
                bw += w;
                bp += w * l;
            }
            let mut prevalence = prevalence;
            if leave_out {
                // The query's own sample: weight 1 in the region and at its place.
                let l = f64::from(u8::from(q.label));
                (gw, gp, bw, bp) = (gw - 1.0, gp - l, bw - 1.0, bp - l);
                prevalence = if n > 1.0 {
                    (prevalence * n - l) / (n - 1.0)
                } else {
                    prevalence
                };
            }
            // Seasonal rate of the whole region, then the place's rate shrunk toward it.
            let season = (gp + prevalence) / (gw + 1.0);
            (bp.max(0.0) + params.prior_strength * season) / (bw.max(0.0) + params.prior_strength)
        })
        .collect()
}

/// Samples as the climatology sees them (labels `y`; queries may pass any).
fn places(meta: &[&SampleMeta], y: &[bool], params: &ClimatologyParams) -> Vec<Place> {
    meta.iter()
        .zip(y.iter().chain(std::iter::repeat(&false)))
        .map(|(m, &label)| Place {
            doy: m.day_of_year,
            block: block_of(m, params.block_degrees),
            lat: m.lat,
            lon: m.lon,
            label,
        })
        .collect()
}

/// A fitted climatology from its training places.
fn climatology_model(params: ClimatologyParams, samples: &[Place], prevalence: f64) -> Trained {
    Trained::Climatology {
        params,
        samples: samples
            .iter()
            .map(|p| (p.doy, p.block.0, p.block.1, p.label))
            .collect(),
        coords: samples.iter().map(|p| (p.lat, p.lon)).collect(),
        prevalence,
    }
}

/// Fits an XGBoost booster on `x` and returns its JSON model.
fn fit_booster(
    x: &firecast_baselines::Matrix,
    y: &[bool],
    e: &XgbEntry,
    ctx: &FitContext<'_>,
) -> Result<String, ForecastError> {
    let report = |done: u32, total: u32| (ctx.progress)(u64::from(done), u64::from(total), "boost");
    let booster =
        firecast_xgboost::Booster::fit_with_progress(&x.data, x.rows, x.cols, y, &e.params, ctx.seed, report)
            .map_err(|e| ForecastError::Model(e.to_string()))?;
    let json = booster
        .save_json()
        .map_err(|e| ForecastError::Model(e.to_string()))?;
    Ok(String::from_utf8_lossy(&json).into_owned())
}

/// A saved booster's probabilities for `x`.
fn booster_proba(model_json: &str, x: &firecast_baselines::Matrix) -> Result<Vec<f64>, ForecastError> {
    let booster = firecast_xgboost::Booster::load_json(model_json.as_bytes())
        .map_err(|e| ForecastError::Model(e.to_string()))?;
    booster
        .predict_proba(&x.data, x.rows, x.cols)
        .map_err(|e| ForecastError::Model(e.to_string()))
}

/// Probabilities as log-odds, kept off ±∞ (a block with no fire at all has rate 0 only
/// without the prior; the clamp is a guard).
fn log_odds(p: &[f64]) -> Vec<f32> {
    p.iter()
        .map(|&p| {
            let p = p.clamp(1e-6, 1.0 - 1e-6);
            (p / (1.0 - p)).ln() as f32
        })
        .collect()
}

fn recalibrate(logits: &[f32], a: f64, b: f64) -> Vec<f32> {
    logits.iter().map(|&z| (a * f64::from(z) + b) as f32).collect()
}

/// Mean binary cross-entropy.
fn log_loss(p: &[f64], y: &[bool]) -> f64 {
    let total: f64 = p
        .iter()
        .zip(y)
        .map(|(&p, &l)| {
            let p = p.clamp(1e-12, 1.0 - 1e-12);
            if l { -p.ln() } else { -(1.0 - p).ln() }
        })
        .sum();
    total / y.len().max(1) as f64
}

/// `x` with one more column: the climatology's rate.
fn with_rate(x: firecast_baselines::Matrix, rates: &[f64]) -> firecast_baselines::Matrix {
    let cols = x.cols + 1;
    let mut data = Vec::with_capacity(x.rows * cols);
    for (row, &rate) in x.data.chunks(x.cols.max(1)).zip(rates) {
        data.extend_from_slice(row);
        data.push(rate as f32);
    }
    firecast_baselines::Matrix {
        rows: x.rows,
        cols,
        data,
    }
}

fn doy_distance(a: u32, b: u32) -> f64 {
    let d = (a as f64 - b as f64).abs();
    d.min(365.25 - d)
}

impl Trained {
    /// Probability of an ignition for each sample of `inputs`.
    pub fn predict(&self, inputs: &Inputs<'_>, device: tch::Device) -> Result<Vec<f64>, ForecastError> {
        let n = inputs.block.rows();
        Ok(match self {
            Trained::Majority { prevalence } => vec![*prevalence; n],
            Trained::Climatology {
                params,
                samples,
                coords,
                prevalence,
            } => {
                if params.kernel_degrees.is_some() && coords.len() != samples.len() {
                    return Err(ForecastError::Model(
                        "the climatology pools by kernel but the saved model has no sample coordinates"
                            .into(),
                    ));
                }
                let train: Vec<Place> = samples
                    .iter()
                    .enumerate()
                    .map(|(i, &(doy, r, c, label))| {
                        let (lat, lon) = coords.get(i).copied().unwrap_or((f64::NAN, f64::NAN));
                        Place {
                            doy,
                            block: (r, c),
                            lat,
                            lon,
                            label,
                        }
                    })
                    .collect();
                climatology_rates(
                    params,
                    &train,
                    *prevalence,
                    &places(&inputs.meta, &[], params),
                    false,
                )
            }
            Trained::ClimateBoost {
                climatology,
                features,
                model_json,
            } => {
                let rates = climatology.predict(inputs, device)?;
                let x = with_rate(window_statistics(inputs.block, features)?, &rates);
                booster_proba(model_json, &x)?
            }
            Trained::ClimateOffset {
                climatology,
                calibration: (a, b),
                features,
                model_json,
                rounds,
            } => {
                let margin = recalibrate(&log_odds(&climatology.predict(inputs, device)?), *a, *b);
                let x = window_statistics(inputs.block, features)?;
                let booster = firecast_xgboost::Booster::load_json(model_json.as_bytes())
                    .map_err(|e| ForecastError::Model(e.to_string()))?;
                booster
                    .predict_proba_with_margin(&x.data, x.rows, x.cols, &margin, Some(*rounds))
                    .map_err(|e| ForecastError::Model(e.to_string()))?
            }
            Trained::FireDangerIndex { feature, a, b } => last_day_values(inputs.block, feature)?
                .into_iter()
                .map(|x| 1.0 / (1.0 + (-(a * f64::from(x) + b)).exp()))
                .collect(),
            Trained::Baseline {
                features,
                scaler,
                model,
            } => {
                let x = crate::features::flatten(inputs.block, features)?;
                let x = match scaler {
                    Some(s) => s.transform(&x).map_err(model_err)?,
                    None => x,
                };
                model
                    .predict_proba(&x)
                    .map_err(|e| ForecastError::Model(e.to_string()))?
            }
            Trained::Xgboost {
                features,
                stats,
                model_json,
            } => {
                let x = if *stats {
                    window_statistics(inputs.block, features)?
                } else {
                    crate::features::flatten(inputs.block, features)?
                };
                booster_proba(model_json, &x)?
            }
            Trained::MiniRocket {
                rocket, scaler, head, ..
            } => {
                let x = rocket.transform(inputs.block, &|_, _, _| {})?;
                head.predict_proba(&scaler.transform(&x).map_err(model_err)?)
                    .map_err(model_err)?
            }
            Trained::Neural(m) => m.predict(inputs, device)?,
        })
    }

    /// Trainable parameters (neural models) — compared with PyTorch's count of the same net.
    pub fn parameter_count(&self) -> Option<i64> {
        match self {
            Trained::Neural(m) => Some(m.parameter_count()),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples() -> Vec<Place> {
        (0..40u32)
            .map(|k| Place {
                doy: 1 + (k * 37) % 365,
                block: (i64::from(k % 3), i64::from(k % 2)),
                lat: 38.5 + 0.1 * f64::from(k % 7),
                lon: -108.0 + 0.13 * f64::from(k % 5),
                label: k % 5 < 2,
            })
            .collect()
    }

    /// climate_boost's and climate_offset's training input: each sample's climatology with its
    /// own label left out equals the climatology fitted without that sample, for blocks and
    /// for the place kernel.
    #[test]
    fn a_left_out_rate_is_the_rate_without_the_sample() {
        for kernel_degrees in [None, Some(0.2)] {
            let params = ClimatologyParams {
                kernel_degrees,
                ..ClimatologyParams::default()
            };
            let samples = samples();
            let prevalence = |s: &[Place]| s.iter().filter(|x| x.label).count() as f64 / s.len() as f64;
            let left_out = climatology_rates(&params, &samples, prevalence(&samples), &samples, true);
            for (i, &q) in samples.iter().enumerate() {
                let mut rest = samples.clone();
                rest.remove(i);
                let without = climatology_rates(&params, &rest, prevalence(&rest), &[q], false)[0];
                assert!(
                    (left_out[i] - without).abs() < 1e-12,
                    "{kernel_degrees:?} sample {i}: {} vs {without}",
                    left_out[i]
                );
            }
            // Without leaving out, a positive sample's own label raises its rate.
            let kept = climatology_rates(&params, &samples, prevalence(&samples), &samples, false);
            assert!(
                samples
                    .iter()
                    .zip(kept.iter().zip(&left_out))
                    .any(|(s, (k, l))| s.label && k > l)
            );
        }
    }

    /// A very wide kernel is the region's seasonal rate; a very narrow one is a place's own.
    #[test]
    fn the_place_kernel_spans_region_to_place() {
        let samples = samples();
        let prevalence = samples.iter().filter(|x| x.label).count() as f64 / samples.len() as f64;
        let rate = |width: f64, q: Place| {
            let params = ClimatologyParams {
                bandwidth_days: 1e6,
                block_degrees: default_block(),
                prior_strength: 1e-9,
                kernel_degrees: Some(width),
            };
            climatology_rates(&params, &samples, prevalence, &[q], false)[0]
        };
        let wide = rate(1e4, samples[3]);
        assert!((wide - prevalence).abs() < 1e-6, "{wide} vs {prevalence}");
        // Sample 0 is a positive; the samples at its place (k ≡ 0 mod 35) share its label.
        let own = rate(1e-4, samples[0]);
        assert!(own > 0.99, "{own}");
    }

    #[test]
    fn climate_offset_params_are_checked() {
        let ok = ModelConfig::parse(
            "climate_offset",
            &serde_json::json!({"kernel_degrees": [0.1, 0.3], "max_depth": 2}),
        )
        .expect("parses");
        let ModelConfig::ClimateOffset(p) = ok else {
            panic!("kind")
        };
        assert_eq!(p.kernel_degrees, vec![0.1, 0.3]);
        assert_eq!(p.boost.params.max_depth, 2);
        for (bad, key) in [
            (serde_json::json!({"kernel_degrees": [0.0]}), "kernel_degrees"),
            (serde_json::json!({"kernel_degrees": "wide"}), "kernel_degrees"),
            (serde_json::json!({"max_dept": 2}), "max_dept"),
            (serde_json::json!("wide"), ""),
        ] {
            match ModelConfig::parse("climate_offset", &bad) {
                Err(ForecastError::Config { key: k, .. }) => assert_eq!(k, key, "{bad}"),
                other => panic!("{bad}: {other:?}"),
            }
        }
    }
}
