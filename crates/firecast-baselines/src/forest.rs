//! Random forest and single decision tree classifiers, seeded as scikit-learn seeds them.
//!
//! - `DecisionTreeClassifier(random_state=seed)`: the splitter's state is the first
//!   `RandomState(seed).randint(0, 2³¹ − 1)`.
//! - `RandomForestClassifier(random_state=seed)`: tree `i`'s `random_state` is the `i`-th
//!   `RandomState(seed).randint(2³¹ − 1)`; with `bootstrap` its rows are
//!   `RandomState(tree_seed).randint(0, n, n)`, passed as counts (sample weights); the
//!   tree's splitter then starts from `RandomState(tree_seed)` like a lone tree.

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::BaselineError;
use crate::matrix::Matrix;
use crate::nprandom::RandomState;
use crate::spec::{DecisionTreeParams, RandomForestParams};
use crate::tree::{Criterion, Targets, Tree, TreeConfig, grow, rand_r_seed};

/// scikit-learn's `MAX_INT` (`np.iinfo(np.int32).max`), the bound of per-tree seeds.
const MAX_INT: u64 = 0x7FFF_FFFF;

/// A `random_state` as NumPy accepts it: an integer in [0, 2³²).
pub(crate) fn random_state(seed: u64) -> Result<u32, BaselineError> {
    u32::try_from(seed).map_err(|_| {
        BaselineError::param(
            "seed",
            "in [0, 2^32 - 1] (scikit-learn's random_state, as NumPy's RandomState takes it)",
            seed,
        )
    })
}

fn config(
    max_depth: Option<usize>,
    min_samples_split: usize,
    min_samples_leaf: usize,
    max_features: usize,
) -> TreeConfig {
    TreeConfig {
        criterion: Criterion::Gini,
        max_depth: max_depth.unwrap_or(usize::MAX),
        min_samples_split,
        min_samples_leaf,
        max_features,
    }
}

fn labels(y: &[bool]) -> Vec<f64> {
    y.iter().map(|&v| f64::from(u8::from(v))).collect()
}

/// `DecisionTreeClassifier`: one tree on all rows.
pub(crate) fn fit_tree(
    p: &DecisionTreeParams,
    x: &Matrix,
    y: &[bool],
    seed: u64,
) -> Result<Tree, BaselineError> {
    let cfg = config(
        p.max_depth,
        p.min_samples_split,
        p.min_samples_leaf,
        p.max_features.resolve(x.cols)?,
    );
    let target = labels(y);
    let targets = Targets {
        weight: None,
        target: &target,
    };
    let state = rand_r_seed(&mut RandomState::new(random_state(seed)?));
    Ok(grow(&x.columns(), x.rows, x.cols, &targets, &cfg, state))
}

/// A fitted random forest: P(class 1) is the mean of the trees' leaf fractions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Forest {
    pub trees: Vec<Tree>,
}

/// `RandomForestClassifier`: scikit-learn's per-tree seeds and bootstrap draws; trees are
/// grown in parallel, each from its own seed, so the forest does not depend on threads.
pub(crate) fn fit_forest(
    p: &RandomForestParams,
    x: &Matrix,
    y: &[bool],
    seed: u64,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Forest, BaselineError> {
    let n = x.rows;
    let cfg = config(
        p.max_depth,
        p.min_samples_split,
        p.min_samples_leaf,
        p.max_features.resolve(x.cols)?,
    );
    let mut forest_rng = RandomState::new(random_state(seed)?);
    let tree_seeds: Vec<u32> = (0..p.n_estimators)
        .map(|_| forest_rng.randint(0, MAX_INT) as u32)
        .collect();
    let target = labels(y);
    let cols = x.columns();
    let done = AtomicUsize::new(0);
    let trees = tree_seeds
        .into_par_iter()
        .map(|tree_seed| {
            let weight = p.bootstrap.then(|| {
                let mut draws = RandomState::new(tree_seed);
                let mut w = vec![0.0; n];
                for _ in 0..n {
                    w[draws.randint(0, n as u64) as usize] += 1.0;
                }
                w
            });
            let targets = Targets {
                weight: weight.as_deref(),
                target: &target,
            };
            let state = rand_r_seed(&mut RandomState::new(tree_seed));
            let tree = grow(&cols, n, x.cols, &targets, &cfg, state);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, p.n_estimators);
            tree
        })
        .collect();
    Ok(Forest { trees })
}

impl Forest {
    /// Mean over trees (summed in tree order) of the class-1 fraction.
    pub fn predict_proba(&self, x: &Matrix) -> Vec<f64> {
        let k = self.trees.len() as f64;
        x.data
            .par_chunks(x.cols.max(1))
            .map(|row| {
                let mut sum = 0.0;
                for t in &self.trees {
                    sum += t.predict(row);
                }
                sum / k
            })
            .collect()
    }
}
