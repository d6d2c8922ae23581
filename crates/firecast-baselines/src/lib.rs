//! The classical baselines of FireCastRL's Table III in pure Rust, behaving like
//! scikit-learn 1.9.1 with the same hyper-parameters.
//!
//! ```
//! use firecast_baselines::{BaselineSpec, Matrix, fit};
//! let x = Matrix::from_rows(&[[0.0f32, 1.0], [1.0, 0.0], [2.0, 1.0], [3.0, 0.0]])?;
//! let y = [false, false, true, true];
//! let spec = BaselineSpec::from_kind("decision_tree", &serde_json::json!({}))?;
//! let model = fit(&spec, &x, &y, 42)?;
//! assert_eq!(model.predict_proba(&x)?, vec![0.0, 0.0, 1.0, 1.0]);
//! # Ok::<(), firecast_baselines::BaselineError>(())
//! ```
//!
//! What matches scikit-learn, and how (the fidelity test, `tests/it/fidelity.rs`, fits
//! scikit-learn through `tests/tools/sklearn_baselines.py` on the same data):
//!
//! - **Inputs** are `f32` rows ([`Matrix`]), as scikit-learn's trees convert them;
//!   [`Standardizer`] reproduces `StandardScaler` bit for bit on `float32` data.
//! - **`logistic_regression`**: scikit-learn's objective exactly (`C·Σ log-loss + ½‖w‖²`,
//!   intercept unpenalised, its stable log-loss branches), minimised in `f64` by L-BFGS
//!   (memory 10, strong-Wolfe line search, ≤ 50 evaluations) with its stopping rules
//!   (`max|∇| ≤ tol` on the mean-loss scale, relative decrease ≤ 64ε, `max_iter`). The
//!   optimiser path is ours, so the two agree as far as both converge; scikit-learn on
//!   `float32` data stalls ~1e-3 (in probability) short of the optimum we reach.
//! - **`gaussian_nb`**: same estimator (`epsilon = var_smoothing · max variance`, priors
//!   from frequencies), statistics in `f64`.
//! - LR and NB return probabilities with scikit-learn's `float32` final arithmetic
//!   (it keeps `float32` input in `float32`): its saturation at exactly 0 and 1 creates
//!   ties that move AUROC by more than 0.01 on wide data, so the ties are kept.
//! - **`decision_tree`**, **`random_forest`**, **`gradient_boosting`**: scikit-learn's
//!   trees themselves. For the same `random_state` (the `seed` of [`fit`]) and
//!   hyper-parameters every tree has the same split features, thresholds and node values
//!   (the tests compare `tree_` arrays node by node) and the probabilities are equal: its
//!   NumPy streams (`RandomState` per-tree seeds, bootstrap draws, boosting's subsample
//!   mask), its splitter (xorshift feature draws over a persistent feature array,
//!   constant-feature tracking, introsort of the node's samples and in-place partition, so
//!   ties and float sums come out in its order), Gini / squared-error criteria with its
//!   update and improvement rules, the depth-first builder, boosting's prior log-odds init
//!   (scipy's `logit`) and Newton leaf values with NumPy's pairwise sums. Forest trees grow
//!   in parallel; each tree, like scikit-learn's, is sequential.
//! - **`knn`**: brute-force Euclidean neighbours. `f32` dot-product estimates with
//!   rigorous error bounds select the candidates, whose distances are then computed
//!   exactly in `f64`; equal distances resolve to the lower training index.
//!
//! Fits are parallel (rayon) where it pays and deterministic for a given seed, whatever
//! the thread count. A [`Fitted`] model serialises to JSON with floats stored
//! losslessly (decimal strings or base64), so a reloaded model predicts bit-identically.

mod boosting;
mod codec;
mod error;
mod forest;
mod knn;
mod linear;
mod matrix;
mod model;
mod nb;
mod nprandom;
mod spec;
mod tree;

pub use error::BaselineError;
pub use matrix::{Matrix, Standardizer};
pub use model::{Fitted, TreeNode, fit, fit_with_progress};
pub use spec::{
    BaselineSpec, DecisionTreeParams, GaussianNbParams, GradientBoostingParams, KINDS, KnnParams, KnnWeights,
    LogisticRegressionParams, MaxFeatures, RandomForestParams, SplitCriterion,
};
