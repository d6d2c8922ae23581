//! Every headline metric of a binary classifier at once.

use serde::{Deserialize, Serialize};

use super::{Confusion, average_precision, brier, brier_skill, ece, log_loss, roc_auc};
use crate::error::{EvalError, all_finite, same_len};

/// The metrics of one model on one set of samples at one threshold. An undefined (NaN)
/// metric is written to JSON as `null` and read back as NaN.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BinaryReport {
    /// Samples.
    pub n: u64,
    /// Actual positives (fires).
    pub positives: u64,
    /// positives / n.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub prevalence: f64,
    /// Decision threshold: predicted fire ⇔ `p > threshold`.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub threshold: f64,
    /// See [`Confusion::accuracy`].
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub accuracy: f64,
    /// See [`Confusion::precision`].
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub precision: f64,
    /// See [`Confusion::recall`].
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub recall: f64,
    /// See [`Confusion::specificity`].
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub specificity: f64,
    /// See [`Confusion::f1`].
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub f1: f64,
    /// See [`Confusion::balanced_accuracy`].
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub balanced_accuracy: f64,
    /// See [`Confusion::mcc`].
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub mcc: f64,
    /// [`roc_auc`]; `None` when a class is absent.
    pub auroc: Option<f64>,
    /// [`average_precision`]; `None` without positives.
    pub auprc: Option<f64>,
    /// [`brier`]; NaN (JSON `null`) when `p` is not a probability.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub brier: f64,
    /// [`brier_skill`] against predicting this set's prevalence.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub brier_skill: f64,
    /// [`log_loss`].
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub log_loss: f64,
    /// [`ece`] with `ece_bins` equal-width bins.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub ece: f64,
    /// Bins used for `ece`.
    pub ece_bins: usize,
    /// Counts at `threshold`.
    pub confusion: Confusion,
}

/// Every metric of `p` against `y` at `threshold`, ECE over `n_bins` bins. Lengths must
/// match and scores be finite: otherwise the report is empty (`n` = 0, metrics NaN or
/// `None`); [`try_evaluate`] reports the error instead.
pub fn evaluate(y: &[bool], p: &[f64], threshold: f64, n_bins: usize) -> BinaryReport {
    try_evaluate(y, p, threshold, n_bins).unwrap_or_else(|_| BinaryReport::undefined(threshold, n_bins))
}

/// [`evaluate`], with an error when `p`'s length differs from `y`'s or a score is not
/// finite. Empty input gives an empty report, not an error.
pub fn try_evaluate(y: &[bool], p: &[f64], threshold: f64, n_bins: usize) -> Result<BinaryReport, EvalError> {
    same_len("p", p.len(), "y", y.len())?;
    all_finite("p", p)?;
    let confusion = Confusion::try_at(y, p, threshold)?;
    let n = confusion.n();
    let positives = confusion.positives();
    Ok(BinaryReport {
        n,
        positives,
        prevalence: if n == 0 {
            f64::NAN
        } else {
            positives as f64 / n as f64
        },
        threshold,
        accuracy: confusion.accuracy(),
        precision: confusion.precision(),
        recall: confusion.recall(),
        specificity: confusion.specificity(),
        f1: confusion.f1(),
        balanced_accuracy: confusion.balanced_accuracy(),
        mcc: confusion.mcc(),
        auroc: roc_auc(y, p),
        auprc: average_precision(y, p),
        brier: brier(y, p),
        brier_skill: brier_skill(y, p),
        log_loss: log_loss(y, p),
        ece: ece(y, p, n_bins),
        ece_bins: n_bins,
        confusion,
    })
}

impl BinaryReport {
    /// A report of nothing: `n` = 0, every metric NaN or `None`.
    fn undefined(threshold: f64, n_bins: usize) -> Self {
        Self {
            n: 0,
            positives: 0,
            prevalence: f64::NAN,
            threshold,
            accuracy: f64::NAN,
            precision: f64::NAN,
            recall: f64::NAN,
            specificity: f64::NAN,
            f1: f64::NAN,
            balanced_accuracy: f64::NAN,
            mcc: f64::NAN,
            auroc: None,
            auprc: None,
            brier: f64::NAN,
            brier_skill: f64::NAN,
            log_loss: f64::NAN,
            ece: f64::NAN,
            ece_bins: n_bins,
            confusion: Confusion::default(),
        }
    }

    /// The scalar metrics by name (`auroc` and `auprc` only when defined, NaN values
    /// left out), the names [`crate::bootstrap::report_intervals`] uses.
    pub fn metrics(&self) -> Vec<(&'static str, f64)> {
        let all = [
            ("prevalence", self.prevalence),
            ("accuracy", self.accuracy),
            ("precision", self.precision),
            ("recall", self.recall),
            ("specificity", self.specificity),
            ("f1", self.f1),
            ("balanced_accuracy", self.balanced_accuracy),
            ("mcc", self.mcc),
            ("auroc", self.auroc.unwrap_or(f64::NAN)),
            ("auprc", self.auprc.unwrap_or(f64::NAN)),
            ("brier", self.brier),
            ("brier_skill", self.brier_skill),
            ("log_loss", self.log_loss),
            ("ece", self.ece),
        ];
        all.into_iter().filter(|(_, v)| !v.is_nan()).collect()
    }
}
