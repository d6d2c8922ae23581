//! Metrics of the probabilities themselves: Brier score, log loss, expected calibration
//! error and the calibration (reliability) curve.

use serde::{Deserialize, Serialize};

use crate::error::{EvalError, all_probabilities, same_len};
use crate::numeric::{mean, pairwise_sum, quantile_sorted, searchsorted_left, unit_edges};

/// `true` when `p` pairs with `y`, is non-empty and holds only probabilities.
fn probabilities(y: &[bool], p: &[f64]) -> bool {
    y.len() == p.len() && !y.is_empty() && p.iter().all(|v| (0.0..=1.0).contains(v))
}

/// Brier score as sklearn's `brier_score_loss(y, p)`: mean of (y − p)², computed as sklearn
/// does for a binary target (half the two-column squared error). NaN when lengths
/// differ, when empty, or when a value of `p` lies outside [0, 1] (sklearn raises).
pub fn brier(y: &[bool], p: &[f64]) -> f64 {
    if !probabilities(y, p) {
        return f64::NAN;
    }
    let rows: Vec<f64> = y
        .iter()
        .zip(p)
        .map(|(&l, &q)| {
            let l1 = f64::from(u8::from(l));
            let a = (1.0 - l1) - (1.0 - q);
            let b = l1 - q;
            (0.0 + a * a) + b * b
        })
        .collect();
    mean(&rows) * 0.5
}

/// Brier skill score against always predicting the prevalence π of this `y`:
/// 1 − Brier / (π(1 − π)). NaN when a class is absent or [`brier`] is NaN.
pub fn brier_skill(y: &[bool], p: &[f64]) -> f64 {
    if y.is_empty() {
        return f64::NAN;
    }
    let prevalence = y.iter().filter(|&&l| l).count() as f64 / y.len() as f64;
    let reference = prevalence * (1.0 - prevalence);
    if reference == 0.0 {
        f64::NAN
    } else {
        1.0 - brier(y, p) / reference
    }
}

/// Log loss as sklearn's `log_loss(y, p, labels=[0, 1])`: probabilities clipped to
/// [ε, 1 − ε] with ε = `f64::EPSILON` (both columns clipped, as sklearn does), natural
/// log, mean over samples. NaN when lengths differ, when empty, or when a value of `p`
/// lies outside [0, 1] (sklearn raises).
pub fn log_loss(y: &[bool], p: &[f64]) -> f64 {
    if !probabilities(y, p) {
        return f64::NAN;
    }
    let eps = f64::EPSILON;
    let clip = |v: f64| v.max(eps).min(1.0 - eps);
    let losses: Vec<f64> = y
        .iter()
        .zip(p)
        .map(|(&l, &q)| if l { -clip(q).ln() } else { -clip(1.0 - q).ln() })
        .collect();
    mean(&losses)
}

/// How [`calibration_curve`] places its bin edges.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BinStrategy {
    /// Equal-width bins over [0, 1] (sklearn `strategy="uniform"`).
    Uniform,
    /// Edges at the quantiles of `p` (sklearn `strategy="quantile"`, NumPy's linear
    /// percentile).
    Quantile,
}

/// A reliability diagram: one entry per non-empty bin, bins in increasing order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationCurve {
    /// Fraction of positives in the bin (sklearn's `prob_true`).
    pub prob_true: Vec<f64>,
    /// Mean predicted probability in the bin (sklearn's `prob_pred`).
    pub prob_pred: Vec<f64>,
    /// Samples in the bin.
    pub counts: Vec<u64>,
}

/// Per-bin sums as `np.bincount`: count, Σy, Σp, accumulated in sample order.
struct Bins {
    total: Vec<u64>,
    true_sum: Vec<f64>,
    prob_sum: Vec<f64>,
}

/// Bin index of every sample by `np.searchsorted(inner_edges, p, side="left")`.
fn bin(y: &[bool], p: &[f64], inner_edges: &[f64], n_bins: usize) -> Bins {
    let mut bins = Bins {
        total: vec![0; n_bins],
        true_sum: vec![0.0; n_bins],
        prob_sum: vec![0.0; n_bins],
    };
    for (&l, &q) in y.iter().zip(p) {
        let b = searchsorted_left(inner_edges, q);
        bins.total[b] += 1;
        bins.true_sum[b] += f64::from(u8::from(l));
        bins.prob_sum[b] += q;
    }
    bins
}

/// Inner bin edges (`bins[1:-1]` in sklearn).
fn inner_edges(p: &[f64], n_bins: usize, strategy: BinStrategy) -> Vec<f64> {
    let unit = unit_edges(n_bins);
    let inner = &unit[1..n_bins];
    match strategy {
        BinStrategy::Uniform => inner.to_vec(),
        BinStrategy::Quantile => {
            let mut sorted = p.to_vec();
            sorted.sort_by(f64::total_cmp);
            // sklearn passes `quantiles * 100` to np.percentile, which divides by 100 again.
            inner
                .iter()
                .map(|&q| quantile_sorted(&sorted, (q * 100.0) / 100.0))
                .collect()
        }
    }
}

/// Calibration curve as sklearn's `calibration_curve(y, p, n_bins, strategy)`; empty bins
/// are dropped. A sample exactly on an inner edge falls in the lower bin (bin b holds
/// edge_b < p ≤ edge_{b+1}; the first bin also holds its lower edge).
pub fn calibration_curve(
    y: &[bool],
    p: &[f64],
    n_bins: usize,
    strategy: BinStrategy,
) -> Result<CalibrationCurve, EvalError> {
    same_len("p", p.len(), "y", y.len())?;
    if y.is_empty() {
        return Err(EvalError::Empty);
    }
    if n_bins == 0 {
        return Err(EvalError::InvalidArgument {
            argument: "n_bins",
            reason: "must be at least 1".into(),
        });
    }
    all_probabilities("p", p)?;
    let bins = bin(y, p, &inner_edges(p, n_bins, strategy), n_bins);
    let mut curve = CalibrationCurve {
        prob_true: Vec::new(),
        prob_pred: Vec::new(),
        counts: Vec::new(),
    };
    for b in (0..n_bins).filter(|&b| bins.total[b] != 0) {
        let total = bins.total[b] as f64;
        curve.prob_true.push(bins.true_sum[b] / total);
        curve.prob_pred.push(bins.prob_sum[b] / total);
        curve.counts.push(bins.total[b]);
    }
    Ok(curve)
}

/// Expected calibration error (Guo et al. 2017): Σ_B |B|/n · |mean(y ∈ B) − mean(p ∈ B)|
/// over `n_bins` equal-width bins of [0, 1], binned exactly as
/// [`calibration_curve`] with [`BinStrategy::Uniform`] (a value on an inner edge belongs
/// to the lower bin; 0 to the first bin). NaN when lengths differ, when empty, when
/// `n_bins` is 0 or when a value of `p` lies outside [0, 1].
pub fn ece(y: &[bool], p: &[f64], n_bins: usize) -> f64 {
    match calibration_curve(y, p, n_bins, BinStrategy::Uniform) {
        Ok(curve) => {
            let n = y.len() as f64;
            let terms: Vec<f64> = (0..curve.counts.len())
                .map(|b| curve.counts[b] as f64 / n * (curve.prob_true[b] - curve.prob_pred[b]).abs())
                .collect();
            pairwise_sum(&terms)
        }
        Err(_) => f64::NAN,
    }
}
