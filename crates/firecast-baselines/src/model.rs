//! `fit`, and the fitted model that predicts and saves itself.

use serde::{Deserialize, Serialize};

use crate::boosting::{self, Boosted};
use crate::error::BaselineError;
use crate::forest::{self, Forest};
use crate::knn::Knn;
use crate::linear::{self, Logistic};
use crate::matrix::Matrix;
use crate::nb::{self, GaussianNb};
use crate::spec::BaselineSpec;
use crate::tree::Tree;

/// Fits `spec` on the rows of `x` with labels `y` (true = class 1). `seed` is
/// scikit-learn's `random_state` and drives every random choice (tree feature order,
/// bootstrap, subsampling) through the same NumPy streams, so the tree models equal
/// scikit-learn's fitted with `random_state=seed`; they refuse a seed ≥ 2³² as NumPy does.
/// The result does not depend on the number of rayon threads.
pub fn fit(spec: &BaselineSpec, x: &Matrix, y: &[bool], seed: u64) -> Result<Fitted, BaselineError> {
    fit_with_progress(spec, x, y, seed, &|_, _| {})
}

/// [`fit`] reporting `progress(done, total)`: per L-BFGS iteration (total = `max_iter`,
/// with a final `(max_iter, max_iter)` when it converges early), per tree (forests,
/// boosting; forests call it from rayon worker threads, hence `Sync`, and `done` counts
/// finished trees), or once (`1, 1`) for the one-shot models.
pub fn fit_with_progress(
    spec: &BaselineSpec,
    x: &Matrix,
    y: &[bool],
    seed: u64,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Fitted, BaselineError> {
    spec.validate()?;
    x.check_shape()?;
    if x.rows == 0 {
        return Err(BaselineError::EmptyTrainingSet);
    }
    if x.cols == 0 {
        return Err(BaselineError::NoFeatures);
    }
    if y.len() != x.rows {
        return Err(BaselineError::LabelCount {
            expected: x.rows,
            got: y.len(),
        });
    }
    if let Some(&first) = y.first()
        && y.iter().all(|&v| v == first)
    {
        return Err(BaselineError::SingleClass { class: first });
    }
    x.check_finite("x")?;
    let model = match spec {
        BaselineSpec::LogisticRegression(p) => Model::LogisticRegression(linear::fit(p, x, y, progress)),
        BaselineSpec::GaussianNb(p) => {
            let m = nb::fit(p.var_smoothing, x, y)?;
            progress(1, 1);
            Model::GaussianNb(m)
        }
        BaselineSpec::DecisionTree(p) => {
            let t = forest::fit_tree(p, x, y, seed)?;
            progress(1, 1);
            Model::DecisionTree(t)
        }
        BaselineSpec::RandomForest(p) => Model::RandomForest(forest::fit_forest(p, x, y, seed, progress)?),
        BaselineSpec::GradientBoosting(p) => Model::GradientBoosting(boosting::fit(p, x, y, seed, progress)?),
        BaselineSpec::Knn(p) => {
            if p.n_neighbors > x.rows {
                return Err(BaselineError::param(
                    "n_neighbors",
                    format!("≤ the number of training rows ({})", x.rows),
                    p.n_neighbors,
                ));
            }
            progress(1, 1);
            Model::Knn(Knn {
                k: p.n_neighbors,
                weights: p.weights,
                train: x.clone(),
                labels: y.to_vec(),
            })
        }
    };
    Ok(Fitted {
        spec: spec.clone(),
        n_features: x.cols,
        model,
    })
}

/// One node of a fitted tree, as scikit-learn's `tree_` arrays describe it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeNode {
    /// The split feature; `None` for a leaf (scikit-learn writes −2).
    pub feature: Option<usize>,
    /// Rows with `x[feature] ≤ threshold` go left; 0 for a leaf (scikit-learn writes −2).
    pub threshold: f64,
    /// Class-1 fraction of the node's (weighted) training rows for classifiers; for
    /// boosting the leaf's Newton step and, at inner nodes, the mean negative gradient.
    pub value: f64,
}

/// A fitted baseline: its spec, its input width and the model. Serialises to JSON
/// (see [`Fitted::to_json`]); loading checks the model's consistency, and a loaded model
/// predicts bit-identically to the one saved.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "FittedRepr", into = "FittedRepr")]
pub struct Fitted {
    spec: BaselineSpec,
    n_features: usize,
    model: Model,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
enum Model {
    LogisticRegression(Logistic),
    GaussianNb(GaussianNb),
    DecisionTree(Tree),
    RandomForest(Forest),
    GradientBoosting(Boosted),
    Knn(Knn),
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FittedRepr {
    spec: BaselineSpec,
    n_features: usize,
    model: Model,
}

impl From<Fitted> for FittedRepr {
    fn from(f: Fitted) -> Self {
        FittedRepr {
            spec: f.spec,
            n_features: f.n_features,
            model: f.model,
        }
    }
}

impl TryFrom<FittedRepr> for Fitted {
    type Error = BaselineError;
    fn try_from(r: FittedRepr) -> Result<Self, BaselineError> {
        let d = r.n_features;
        let corrupt = BaselineError::Corrupt;
        let same_kind = matches!(
            (&r.spec, &r.model),
            (BaselineSpec::LogisticRegression(_), Model::LogisticRegression(_))
                | (BaselineSpec::GaussianNb(_), Model::GaussianNb(_))
                | (BaselineSpec::DecisionTree(_), Model::DecisionTree(_))
                | (BaselineSpec::RandomForest(_), Model::RandomForest(_))
                | (BaselineSpec::GradientBoosting(_), Model::GradientBoosting(_))
                | (BaselineSpec::Knn(_), Model::Knn(_))
        );
        if !same_kind {
            return Err(corrupt(format!(
                "spec `{}` holds another kind of model",
                r.spec.kind()
            )));
        }
        match &r.model {
            Model::LogisticRegression(m) if m.coef.len() != d => {
                return Err(corrupt(format!("{} coefficients for {d} features", m.coef.len())));
            }
            Model::GaussianNb(m) => m.validate(d).map_err(corrupt)?,
            Model::DecisionTree(t) => t.validate(d).map_err(corrupt)?,
            Model::RandomForest(f) => {
                if f.trees.is_empty() {
                    return Err(corrupt("a forest without trees".into()));
                }
                for t in &f.trees {
                    t.validate(d).map_err(corrupt)?;
                }
            }
            Model::GradientBoosting(b) => {
                for t in &b.trees {
                    t.validate(d).map_err(corrupt)?;
                }
            }
            Model::Knn(k) => {
                k.validate().map_err(corrupt)?;
                if k.train.cols != d {
                    return Err(corrupt(format!(
                        "{} training columns for {d} features",
                        k.train.cols
                    )));
                }
            }
            Model::LogisticRegression(_) => {}
        }
        Ok(Fitted {
            spec: r.spec,
            n_features: d,
            model: r.model,
        })
    }
}

impl Fitted {
    /// The spec it was fitted with.
    pub fn spec(&self) -> &BaselineSpec {
        &self.spec
    }

    /// Number of feature columns `predict_proba` expects.
    pub fn feature_count(&self) -> usize {
        self.n_features
    }

    /// P(class 1) for every row of `x`; a wrong width or a NaN/inf is an error.
    pub fn predict_proba(&self, x: &Matrix) -> Result<Vec<f64>, BaselineError> {
        x.check_shape()?;
        if x.cols != self.n_features {
            return Err(BaselineError::FeatureCount {
                expected: self.n_features,
                got: x.cols,
            });
        }
        x.check_finite("x")?;
        if x.rows == 0 {
            return Ok(Vec::new());
        }
        Ok(match &self.model {
            Model::LogisticRegression(m) => m.predict_proba(x),
            Model::GaussianNb(m) => m.predict_proba(x),
            Model::DecisionTree(t) => {
                use rayon::prelude::*;
                x.data.par_chunks(x.cols).map(|row| t.predict(row)).collect()
            }
            Model::RandomForest(f) => f.predict_proba(x),
            Model::GradientBoosting(b) => b.predict_proba(x),
            Model::Knn(k) => k.predict_proba(x),
        })
    }

    /// Class labels as scikit-learn's `predict` gives them: class 1 when its probability
    /// is strictly above ½ (an exact ½ goes to class 0, its `argmax` tie rule).
    pub fn predict(&self, x: &Matrix) -> Result<Vec<bool>, BaselineError> {
        Ok(self.predict_proba(x)?.into_iter().map(|p| p > 0.5).collect())
    }

    /// L-BFGS iterations run and whether it converged (logistic regression only).
    pub fn lbfgs_iterations(&self) -> Option<(usize, bool)> {
        match &self.model {
            Model::LogisticRegression(m) => Some((m.n_iter, m.converged)),
            _ => None,
        }
    }

    /// Number of trees (1 for a decision tree, 0 for non-tree models) and their total
    /// node count.
    pub fn tree_size(&self) -> (usize, usize) {
        let trees: &[Tree] = match &self.model {
            Model::DecisionTree(t) => std::slice::from_ref(t),
            Model::RandomForest(f) => &f.trees,
            Model::GradientBoosting(b) => &b.trees,
            _ => &[],
        };
        (trees.len(), trees.iter().map(Tree::len).sum())
    }

    /// Every tree's nodes in scikit-learn's numbering (depth first, left child first, as
    /// `tree_.feature`, `tree_.threshold` and `tree_.value` list them): one tree for a
    /// decision tree, one per estimator for forests and boosting, none otherwise.
    pub fn tree_nodes(&self) -> Vec<Vec<TreeNode>> {
        let trees: &[Tree] = match &self.model {
            Model::DecisionTree(t) => std::slice::from_ref(t),
            Model::RandomForest(f) => &f.trees,
            Model::GradientBoosting(b) => &b.trees,
            _ => &[],
        };
        trees
            .iter()
            .map(|t| {
                t.preorder()
                    .into_iter()
                    .map(|i| {
                        let leaf = t.feature[i] == crate::tree::LEAF;
                        TreeNode {
                            feature: (!leaf).then_some(t.feature[i] as usize),
                            threshold: t.threshold[i],
                            value: t.value[i],
                        }
                    })
                    .collect()
            })
            .collect()
    }

    /// The model as JSON (floats stored losslessly).
    pub fn to_json(&self) -> Result<String, BaselineError> {
        Ok(serde_json::to_string(self)?)
    }

    /// A model saved by [`Fitted::to_json`], checked for consistency.
    pub fn from_json(text: &str) -> Result<Self, BaselineError> {
        Ok(serde_json::from_str(text)?)
    }
}
