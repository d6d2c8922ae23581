//! Binary-classification metrics, computed as scikit-learn 1.9.1 computes them.
//!
//! Inputs are `y: &[bool]` (true = fire) and `p: &[f64]` (scores or probabilities) of
//! equal length. Scalar metrics return `Option<f64>` (undefined → `None`) or `f64`
//! (undefined → NaN) so they can run inside bootstrap loops; they never panic. Functions
//! returning `Result` report a length mismatch as [`crate::EvalError::LengthMismatch`]
//! naming the argument.

mod confusion;
mod curves;
mod probability;
mod report;
mod threshold;

pub use confusion::Confusion;
pub use curves::{
    PrPoint, RocPoint, average_precision, precision_recall_curve, roc_auc, roc_curve, roc_curve_with,
};
pub use probability::{BinStrategy, CalibrationCurve, brier, brier_skill, calibration_curve, ece, log_loss};
pub use report::{BinaryReport, evaluate, try_evaluate};
pub use threshold::{FALLBACK_THRESHOLD, ThresholdRule, choose_threshold};
