//! Feature views of a window block: variable selection, flattening (the paper's 1125-dim
//! vectors), window statistics, scaling fitted on training rows only.

use serde::{Deserialize, Serialize};

use crate::ForecastError;
use crate::data::Block;
use firecast_baselines::Matrix;

/// Which variables a model reads.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum FeatureSet {
    /// `all` (the paper's flattened baselines: 15 × 75 = 1125), or `no_etr` (the authors'
    /// CNN-BiLSTM drops `etr`).
    Named(FeatureSetName),
    /// An explicit list of variable names.
    List(Vec<String>),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FeatureSetName {
    All,
    NoEtr,
}

impl Default for FeatureSet {
    fn default() -> Self {
        FeatureSet::Named(FeatureSetName::All)
    }
}

impl FeatureSet {
    /// The variable names to read, checked against what the dataset has.
    pub fn resolve(&self, have: &[String]) -> Result<Vec<String>, ForecastError> {
        match self {
            FeatureSet::Named(FeatureSetName::All) => Ok(have.to_vec()),
            FeatureSet::Named(FeatureSetName::NoEtr) => {
                Ok(have.iter().filter(|f| *f != "etr").cloned().collect())
            }
            FeatureSet::List(list) => {
                if list.is_empty() {
                    return Err(ForecastError::Config {
                        key: "params.features".into(),
                        message: "an empty variable list".into(),
                    });
                }
                for f in list {
                    if !have.contains(f) {
                        return Err(ForecastError::Config {
                            key: "params.features".into(),
                            message: format!(
                                "the dataset has no variable `{f}` (it has {})",
                                have.join(", ")
                            ),
                        });
                    }
                }
                Ok(list.clone())
            }
        }
    }
}

fn indices(block: &Block, features: &[String]) -> Result<Vec<usize>, ForecastError> {
    features
        .iter()
        .map(|f| {
            block
                .features
                .iter()
                .position(|n| n == f)
                .ok_or_else(|| ForecastError::Config {
                    key: "features".into(),
                    message: format!(
                        "the model was trained on `{f}`, which these inputs lack (they have {})",
                        block.features.join(", ")
                    ),
                })
        })
        .collect()
}

/// `[sample, day × feature]` rows with the chosen variables, day-major like the authors'
/// flattening of `(75, 15)` windows.
pub fn flatten(block: &Block, features: &[String]) -> Result<Matrix, ForecastError> {
    let idx = indices(block, features)?;
    let nf = block.n_features();
    let cols = block.n_days * idx.len();
    let mut data = Vec::with_capacity(block.rows() * cols);
    for s in 0..block.rows() {
        let x = block.sample(s);
        for d in 0..block.n_days {
            data.extend(idx.iter().map(|&f| x[d * nf + f]));
        }
    }
    Matrix::new(block.rows(), cols, data).map_err(|e| ForecastError::Model(e.to_string()))
}

/// `[sample, day, feature]` values of the chosen variables (sequence models).
pub fn sequences(block: &Block, features: &[String]) -> Result<Vec<f32>, ForecastError> {
    Ok(flatten(block, features)?.data)
}

/// Names of [`window_statistics`] columns.
pub const STATISTICS: [&str; 7] = ["mean", "std", "min", "max", "last", "last7_mean", "slope"];

/// Per variable: mean, standard deviation, min, max, last day, mean of the last 7 days and
/// the least-squares slope over the window: a 75 × 15 window becomes 105 numbers.
pub fn window_statistics(block: &Block, features: &[String]) -> Result<Matrix, ForecastError> {
    let idx = indices(block, features)?;
    let nf = block.n_features();
    let n = block.n_days;
    let cols = idx.len() * STATISTICS.len();
    let mut data = Vec::with_capacity(block.rows() * cols);
    let t_mean = (n as f64 - 1.0) / 2.0;
    let t_var: f64 = (0..n).map(|t| (t as f64 - t_mean).powi(2)).sum();
    for s in 0..block.rows() {
        let x = block.sample(s);
        for &f in &idx {
            let series = (0..n).map(|d| f64::from(x[d * nf + f]));
            let (mut sum, mut sq, mut lo, mut hi, mut cov) =
                (0.0, 0.0, f64::INFINITY, f64::NEG_INFINITY, 0.0);
            for (t, v) in series.enumerate() {
                sum += v;
                sq += v * v;
                lo = lo.min(v);
                hi = hi.max(v);
                cov += (t as f64 - t_mean) * v;
            }
            let mean = sum / n as f64;
            let std = (sq / n as f64 - mean * mean).max(0.0).sqrt();
            let last = f64::from(x[(n - 1) * nf + f]);
            let k = n.min(7);
            let last7 = (n - k..n).map(|d| f64::from(x[d * nf + f])).sum::<f64>() / k as f64;
            let slope = if t_var > 0.0 { cov / t_var } else { 0.0 };
            data.extend([mean, std, lo, hi, last, last7, slope].map(|v| v as f32));
        }
    }
    Matrix::new(block.rows(), cols, data).map_err(|e| ForecastError::Model(e.to_string()))
}

/// Per-variable mean and population standard deviation over every day of `[.., variable]`
/// values with `nf` variables (a constant variable gets scale 1): the sequence models and
/// MiniRocket scale each variable, not each (day, variable) column.
pub fn channel_moments(data: &[f32], nf: usize) -> (Vec<f32>, Vec<f32>) {
    let mut mean = vec![0.0f64; nf];
    let mut sq = vec![0.0f64; nf];
    let n = (data.len() / nf.max(1)).max(1) as f64;
    for (i, v) in data.iter().enumerate() {
        mean[i % nf] += f64::from(*v);
    }
    for m in &mut mean {
        *m /= n;
    }
    for (i, v) in data.iter().enumerate() {
        sq[i % nf] += (f64::from(*v) - mean[i % nf]).powi(2);
    }
    let std = sq
        .iter()
        .map(|s| {
            let sd = (s / n).sqrt();
            if sd > 0.0 { sd as f32 } else { 1.0 }
        })
        .collect();
    (mean.iter().map(|m| *m as f32).collect(), std)
}

/// Logistic regression on one variable (Newton's method on standardised x), so a raw
/// index becomes a probability; the ranking, and so AUROC and AUPRC, are the index's own.
pub fn fit_logistic_1d(x: &[f32], y: &[bool]) -> (f64, f64) {
    let n = x.len().max(1) as f64;
    let mean = x.iter().map(|v| f64::from(*v)).sum::<f64>() / n;
    let sd = (x.iter().map(|v| (f64::from(*v) - mean).powi(2)).sum::<f64>() / n)
        .sqrt()
        .max(1e-12);
    let (mut a, mut b) = (0.0f64, 0.0f64);
    for _ in 0..50 {
        let (mut ga, mut gb, mut haa, mut hab, mut hbb) = (0.0, 0.0, 1e-9, 0.0, 1e-9);
        for (v, &l) in x.iter().zip(y) {
            let z = (f64::from(*v) - mean) / sd;
            let p = 1.0 / (1.0 + (-(a * z + b)).exp());
            let r = p - f64::from(u8::from(l));
            let w = p * (1.0 - p);
            ga += r * z;
            gb += r;
            haa += w * z * z;
            hab += w * z;
            hbb += w;
        }
        let det = haa * hbb - hab * hab;
        if det.abs() < 1e-18 {
            break;
        }
        let da = (hbb * ga - hab * gb) / det;
        let db = (haa * gb - hab * ga) / det;
        a -= da;
        b -= db;
        if da.abs() + db.abs() < 1e-10 {
            break;
        }
    }
    // Back to the raw scale: a·(x − mean)/sd + b.
    (a / sd, b - a * mean / sd)
}
