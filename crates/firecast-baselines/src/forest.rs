//! Random forest and single decision tree classifiers.

use std::sync::atomic::{AtomicUsize, Ordering};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::BaselineError;
use crate::matrix::Matrix;
use crate::spec::{DecisionTreeParams, RandomForestParams};
use crate::tree::{Criterion, Presorted, Targets, Tree, TreeConfig, grow_presorted, grow_sorting};

/// SplitMix64 of `seed` and a stream number: independent per-tree seeds, so a tree's
/// randomness depends on its index only, never on which thread builds it.
pub(crate) fn derive_seed(seed: u64, stream: u64) -> u64 {
    let mut z = seed ^ stream.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Data every tree of a fit shares: the column-major copy (few features per split) or
/// the presorted columns (all features per split).
pub(crate) enum Shared {
    Columns(Vec<f32>),
    Presorted(Presorted),
}

impl Shared {
    pub fn new(x: &Matrix, cfg: &TreeConfig) -> Self {
        if cfg.max_features < x.cols {
            Shared::Columns(x.columns())
        } else {
            Shared::Presorted(Presorted::new(x))
        }
    }

    /// One tree; `rng` draws the feature order.
    pub fn grow(
        &self,
        x: &Matrix,
        targets: &Targets<'_>,
        cfg: &TreeConfig,
        rng: &mut ChaCha8Rng,
    ) -> (Tree, Vec<u32>) {
        match self {
            Shared::Columns(cols) => grow_sorting(cols, x.rows, x.cols, targets, cfg, rng),
            Shared::Presorted(pre) => grow_presorted(x, pre, targets, cfg, rng.random()),
        }
    }
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
    let weight = vec![1.0; x.rows];
    let target = labels(y);
    let targets = Targets {
        weight: &weight,
        target: &target,
    };
    let shared = Shared::new(x, &cfg);
    let mut rng = ChaCha8Rng::seed_from_u64(derive_seed(seed, 0));
    Ok(shared.grow(x, &targets, &cfg, &mut rng).0)
}

/// A fitted random forest: P(class 1) is the mean of the trees' leaf fractions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Forest {
    pub trees: Vec<Tree>,
}

/// `RandomForestClassifier`: trees in parallel, tree `i` seeded by `derive_seed(seed, i)`
/// (bootstrap draws, then feature draws), so the forest does not depend on the threads.
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
    let target = labels(y);
    let shared = Shared::new(x, &cfg);
    let done = AtomicUsize::new(0);
    let trees = (0..p.n_estimators)
        .into_par_iter()
        .map(|i| {
            let mut rng = ChaCha8Rng::seed_from_u64(derive_seed(seed, i as u64));
            let weight = if p.bootstrap {
                // scikit-learn's bootstrap: n draws with replacement, counts as weights.
                let mut w = vec![0.0; n];
                for _ in 0..n {
                    w[rng.random_range(0..n)] += 1.0;
                }
                w
            } else {
                vec![1.0; n]
            };
            let targets = Targets {
                weight: &weight,
                target: &target,
            };
            let tree = shared.grow(x, &targets, &cfg, &mut rng).0;
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
            .map(|row| self.trees.iter().map(|t| t.predict(row)).sum::<f64>() / k)
            .collect()
    }
}
