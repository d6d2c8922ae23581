//! Ranking metrics and curves: `roc_auc`, `average_precision`, `roc_curve`,
//! `precision_recall_curve`, built like scikit-learn's `confusion_matrix_at_thresholds`.

use std::cmp::Ordering;

use serde::{Deserialize, Serialize};

use crate::error::{EvalError, all_finite, same_len};
use crate::numeric::pairwise_sum;

/// Cumulative false and true positives at each distinct score, scores descending, as
/// scikit-learn's `confusion_matrix_at_thresholds` returns them (`fps`, `tps`,
/// `thresholds`). Counts are integers held as f64, exactly as NumPy holds them.
struct ClfCurve {
    fps: Vec<f64>,
    tps: Vec<f64>,
    thresholds: Vec<f64>,
}

/// The curve for finite `p` of `y`'s length (the callers check both).
fn clf_curve(y: &[bool], p: &[f64]) -> ClfCurve {
    let n = y.len();
    let mut order: Vec<usize> = (0..n).collect();
    // Stable and descending, like sklearn's `argsort(stable=True, descending=True)`.
    order.sort_by(|&a, &b| p[b].partial_cmp(&p[a]).unwrap_or(Ordering::Equal));
    let mut curve = ClfCurve {
        fps: Vec::new(),
        tps: Vec::new(),
        thresholds: Vec::new(),
    };
    let mut tp: u64 = 0;
    for (k, &i) in order.iter().enumerate() {
        tp += u64::from(y[i]);
        // A threshold closes where the next score differs (`np.diff(y_score) != 0`).
        let closes = order.get(k + 1).is_none_or(|&next| p[next] != p[i]);
        if closes {
            curve.tps.push(tp as f64);
            curve.fps.push(1.0 + k as f64 - tp as f64);
            curve.thresholds.push(p[i]);
        }
    }
    curve
}

/// `Some(())` when `y` and `p` can be ranked: same length, non-empty, finite scores.
fn rankable(y: &[bool], p: &[f64]) -> Option<()> {
    (y.len() == p.len() && !y.is_empty() && p.iter().all(|v| v.is_finite())).then_some(())
}

fn check_rankable(y: &[bool], p: &[f64]) -> Result<(), EvalError> {
    same_len("p", p.len(), "y", y.len())?;
    if y.is_empty() {
        return Err(EvalError::Empty);
    }
    all_finite("p", p)
}

/// One point of a ROC curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RocPoint {
    /// False-positive rate at this threshold (NaN when `y` has no negatives, as in sklearn).
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub fpr: f64,
    /// True-positive rate at this threshold (NaN when `y` has no positives, as in sklearn).
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub tpr: f64,
    /// Samples with `p >= threshold` are predicted positive. The first point's threshold is
    /// `+inf` (sklearn ≥ 1.3); it serialises as the string `"Infinity"` (see
    /// [`crate::dvc::json_number`]) because JSON has no infinity.
    #[serde(with = "crate::dvc::serde_non_finite")]
    pub threshold: f64,
}

/// One point of a precision–recall curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PrPoint {
    /// Precision of predicting `p >= threshold` positive.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub precision: f64,
    /// Recall of predicting `p >= threshold` positive.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub recall: f64,
    /// The threshold; `None` for the final (precision 1, recall 0) point, which sklearn
    /// appends without a threshold.
    pub threshold: Option<f64>,
}

/// `roc_curve` for checked input.
fn roc_points(y: &[bool], p: &[f64], drop_intermediate: bool) -> Vec<RocPoint> {
    let ClfCurve {
        mut fps,
        mut tps,
        mut thresholds,
    } = clf_curve(y, p);
    if drop_intermediate && fps.len() > 2 {
        // Keep the ends and every corner (a non-zero second difference of fps or tps).
        let last = fps.len() - 1;
        let keep: Vec<usize> = (0..=last)
            .filter(|&i| {
                i == 0
                    || i == last
                    || (fps[i + 1] - fps[i]) - (fps[i] - fps[i - 1]) != 0.0
                    || (tps[i + 1] - tps[i]) - (tps[i] - tps[i - 1]) != 0.0
            })
            .collect();
        fps = keep.iter().map(|&i| fps[i]).collect();
        tps = keep.iter().map(|&i| tps[i]).collect();
        thresholds = keep.iter().map(|&i| thresholds[i]).collect();
    }
    let negatives = fps.last().copied().unwrap_or(0.0);
    let positives = tps.last().copied().unwrap_or(0.0);
    let rate = |count: f64, total: f64| if total <= 0.0 { f64::NAN } else { count / total };
    std::iter::once(RocPoint {
        fpr: rate(0.0, negatives),
        tpr: rate(0.0, positives),
        threshold: f64::INFINITY,
    })
    .chain((0..fps.len()).map(|i| RocPoint {
        fpr: rate(fps[i], negatives),
        tpr: rate(tps[i], positives),
        threshold: thresholds[i],
    }))
    .collect()
}

/// ROC curve as sklearn's `roc_curve(y, p)` (default `drop_intermediate=True`): one point
/// per kept distinct score, descending, after a first point (0, 0) at threshold `+inf`.
/// With one class absent the undefined rate is NaN, as in sklearn.
pub fn roc_curve(y: &[bool], p: &[f64]) -> Result<Vec<RocPoint>, EvalError> {
    roc_curve_with(y, p, true)
}

/// [`roc_curve`] with sklearn's `drop_intermediate` choice.
pub fn roc_curve_with(y: &[bool], p: &[f64], drop_intermediate: bool) -> Result<Vec<RocPoint>, EvalError> {
    check_rankable(y, p)?;
    Ok(roc_points(y, p, drop_intermediate))
}

/// Area under the ROC curve as sklearn's `roc_auc_score`: trapezoids over the ROC curve
/// with thresholds at the distinct scores, so tied scores count one half. `None` when a
/// class is absent (sklearn returns NaN), when lengths differ, when empty, or when a
/// score is not finite (sklearn raises).
pub fn roc_auc(y: &[bool], p: &[f64]) -> Option<f64> {
    rankable(y, p)?;
    let positives = y.iter().filter(|&&l| l).count();
    if positives == 0 || positives == y.len() {
        return None;
    }
    let pts = roc_points(y, p, true);
    // numpy.trapezoid: d * (y[1:] + y[:-1]) / 2.0, summed pairwise.
    let terms: Vec<f64> = pts
        .windows(2)
        .map(|w| (w[1].fpr - w[0].fpr) * (w[1].tpr + w[0].tpr) / 2.0)
        .collect();
    Some(pairwise_sum(&terms))
}

/// `precision_recall_curve` for checked input.
fn pr_points(y: &[bool], p: &[f64]) -> Vec<PrPoint> {
    let ClfCurve { fps, tps, thresholds } = clf_curve(y, p);
    let positives = tps.last().copied().unwrap_or(0.0);
    let mut pts: Vec<PrPoint> = (0..tps.len())
        .rev()
        .map(|i| {
            let predicted = tps[i] + fps[i];
            PrPoint {
                precision: if predicted != 0.0 { tps[i] / predicted } else { 0.0 },
                // sklearn sets recall to 1 everywhere when y has no positives.
                recall: if positives == 0.0 { 1.0 } else { tps[i] / positives },
                threshold: Some(thresholds[i]),
            }
        })
        .collect();
    pts.push(PrPoint {
        precision: 1.0,
        recall: 0.0,
        threshold: None,
    });
    pts
}

/// Precision–recall curve as sklearn's `precision_recall_curve(y, p)`: sklearn returns
/// n + 1 precisions and recalls and n thresholds (increasing); here the same n + 1 points
/// in the same order, each with its threshold, the last — precision 1, recall 0 — with
/// `threshold: None`.
pub fn precision_recall_curve(y: &[bool], p: &[f64]) -> Result<Vec<PrPoint>, EvalError> {
    check_rankable(y, p)?;
    Ok(pr_points(y, p))
}

/// Average precision as sklearn's `average_precision_score`: Σₙ (Rₙ − Rₙ₋₁) Pₙ over the
/// precision–recall curve with one threshold per distinct score (ties enter together,
/// no interpolation). `None` when `y` has no positive (sklearn returns 0.0 with a
/// warning; AP is undefined there), when lengths differ, when empty, or when a score is
/// not finite.
pub fn average_precision(y: &[bool], p: &[f64]) -> Option<f64> {
    rankable(y, p)?;
    if !y.iter().any(|&l| l) {
        return None;
    }
    let pts = pr_points(y, p);
    let terms: Vec<f64> = pts
        .windows(2)
        .map(|w| (w[1].recall - w[0].recall) * w[0].precision)
        .collect();
    let ap = -pairwise_sum(&terms);
    // Python's max(0.0, x): rounding can give -0.0.
    Some(if ap > 0.0 { ap } else { 0.0 })
}
