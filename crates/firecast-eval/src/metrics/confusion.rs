//! The confusion matrix at a threshold and the metrics read from it.

use serde::{Deserialize, Serialize};

use crate::error::{EvalError, same_len};

/// Binary confusion matrix. A sample is predicted positive when `p > threshold`, strictly:
/// PyTorch's `sigmoid(x) > 0.5` and sklearn's `predict` on `predict_proba` both give
/// class 0 at exactly 0.5. A NaN score is predicted negative.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Confusion {
    /// Fires predicted as fires.
    pub tp: u64,
    /// Non-fires predicted as fires.
    pub fp: u64,
    /// Non-fires predicted as non-fires.
    pub tn: u64,
    /// Fires predicted as non-fires (`fn` is a keyword; serialised as `"fn"`).
    #[serde(rename = "fn")]
    pub fn_: u64,
}

/// `num / den`, or 0 when `den` is 0 (sklearn's `zero_division=0`).
fn ratio(num: f64, den: f64) -> f64 {
    if den == 0.0 { 0.0 } else { num / den }
}

impl Confusion {
    /// Counts at `threshold` (positive ⇔ `p > threshold`). Lengths must match: with
    /// mismatched slices the result is all zeros; [`Confusion::try_at`] reports the error.
    pub fn at(y: &[bool], p: &[f64], threshold: f64) -> Self {
        Self::try_at(y, p, threshold).unwrap_or_default()
    }

    /// [`Confusion::at`], with an error naming `p` when its length differs from `y`'s.
    pub fn try_at(y: &[bool], p: &[f64], threshold: f64) -> Result<Self, EvalError> {
        same_len("p", p.len(), "y", y.len())?;
        Ok(Self::tally(
            y.iter().copied().zip(p.iter().map(|&q| q > threshold)),
        ))
    }

    /// Counts from hard predictions; an error naming `predicted` when lengths differ.
    pub fn from_predictions(y: &[bool], predicted: &[bool]) -> Result<Self, EvalError> {
        same_len("predicted", predicted.len(), "y", y.len())?;
        Ok(Self::tally(y.iter().copied().zip(predicted.iter().copied())))
    }

    fn tally(pairs: impl Iterator<Item = (bool, bool)>) -> Self {
        let mut c = Self::default();
        for (actual, predicted) in pairs {
            match (actual, predicted) {
                (true, true) => c.tp += 1,
                (false, true) => c.fp += 1,
                (false, false) => c.tn += 1,
                (true, false) => c.fn_ += 1,
            }
        }
        c
    }

    /// Number of samples.
    pub fn n(&self) -> u64 {
        self.tp + self.fp + self.tn + self.fn_
    }

    /// Actual positives (tp + fn).
    pub fn positives(&self) -> u64 {
        self.tp + self.fn_
    }

    /// Actual negatives (tn + fp).
    pub fn negatives(&self) -> u64 {
        self.tn + self.fp
    }

    /// (tp + tn) / n; NaN when there are no samples (sklearn raises).
    pub fn accuracy(&self) -> f64 {
        if self.n() == 0 {
            f64::NAN
        } else {
            (self.tp + self.tn) as f64 / self.n() as f64
        }
    }

    /// tp / (tp + fp), 0 when nothing is predicted positive.
    pub fn precision(&self) -> f64 {
        ratio(self.tp as f64, (self.tp + self.fp) as f64)
    }

    /// tp / (tp + fn) (sensitivity, true-positive rate), 0 without positives.
    pub fn recall(&self) -> f64 {
        ratio(self.tp as f64, self.positives() as f64)
    }

    /// tn / (tn + fp) (true-negative rate), 0 without negatives.
    pub fn specificity(&self) -> f64 {
        ratio(self.tn as f64, self.negatives() as f64)
    }

    /// F1 as sklearn computes it: 2·tp / (2·tp + fp + fn), 0 when that denominator is 0.
    pub fn f1(&self) -> f64 {
        let true_sum = self.positives() as f64;
        let pred_sum = (self.tp + self.fp) as f64;
        ratio(2.0 * self.tp as f64, 1.0 * true_sum + pred_sum)
    }

    /// Balanced accuracy as sklearn's `balanced_accuracy_score`: mean recall over the
    /// classes present in `y` (a class absent from `y` is left out, as sklearn does after
    /// its warning); NaN when there are no samples.
    pub fn balanced_accuracy(&self) -> f64 {
        let mut per_class = Vec::with_capacity(2);
        if self.negatives() > 0 {
            per_class.push(self.tn as f64 / self.negatives() as f64);
        }
        if self.positives() > 0 {
            per_class.push(self.tp as f64 / self.positives() as f64);
        }
        crate::numeric::mean(&per_class)
    }

    /// Matthews correlation coefficient as sklearn's `matthews_corrcoef`, with its
    /// arithmetic (covariances from the class sums); 0 when either covariance is 0.
    pub fn mcc(&self) -> f64 {
        let (tp, fp, tn, fn_) = (self.tp as f64, self.fp as f64, self.tn as f64, self.fn_ as f64);
        let t_sum = [tn + fp, fn_ + tp];
        let p_sum = [tn + fn_, fp + tp];
        let n_correct = tn + tp;
        let n = p_sum[0] + p_sum[1];
        let cov_ytyp = n_correct * n - (t_sum[0] * p_sum[0] + t_sum[1] * p_sum[1]);
        let cov_ypyp = n * n - (p_sum[0] * p_sum[0] + p_sum[1] * p_sum[1]);
        let cov_ytyt = n * n - (t_sum[0] * t_sum[0] + t_sum[1] * t_sum[1]);
        let product = cov_ypyp * cov_ytyt;
        if product == 0.0 {
            0.0
        } else {
            cov_ytyp / product.sqrt()
        }
    }
}
