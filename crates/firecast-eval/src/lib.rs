//! Evaluation of binary classifiers (fire / no fire) in pure Rust, without libtorch.
//!
//! - [`metrics`]: AUROC, average precision, ROC and precision–recall curves, Brier score,
//!   log loss, calibration curve and ECE, the confusion matrix at a threshold and its
//!   metrics, threshold selection, and [`metrics::BinaryReport`] with all of them.
//!   Values match scikit-learn 1.9.1 (`roc_auc_score`, `average_precision_score`,
//!   `roc_curve`, `precision_recall_curve`, `brier_score_loss`, `log_loss`,
//!   `calibration_curve`, `accuracy_score`, `precision_score`, `recall_score`,
//!   `f1_score`, `balanced_accuracy_score`, `matthews_corrcoef`) to 1e-12 — mostly to
//!   the last bit, since NumPy's pairwise summation and percentile interpolation are
//!   reproduced — which `tests/it` checks against the real library.
//! - [`bootstrap`]: seeded percentile intervals, resampling samples or whole clusters,
//!   paired differences, the interquartile mean and rliable's stratified bootstrap.
//! - [`tests`]: McNemar (exact or χ²), DeLong's AUROC test, Holm's adjustment.
//! - [`special`]: erfc (W. J. Cody's approximations) and the tails the tests need.
//! - [`dvc`]: plot data shaped as DVCLive's `log_sklearn_plot` writes it.
//!
//! Predicted positive always means `p > threshold`, strictly. Everything random is
//! driven by `ChaCha8Rng` from a `u64` seed, so results are reproducible.

pub mod bootstrap;
pub mod dvc;
mod error;
pub mod metrics;
mod numeric;
pub mod serde_nan;
pub mod special;
pub mod tests;

pub use error::EvalError;
