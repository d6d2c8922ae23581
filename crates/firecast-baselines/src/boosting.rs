//! Gradient boosting with the log-loss, as scikit-learn's `GradientBoostingClassifier`.
//!
//! `raw₀ = logit(prior)` (the prior clipped to [ε, 1−ε]); each stage fits a squared-error
//! regression tree to the negative gradient `y − expit(raw)` (scikit-learn 1.9 maps the
//! `friedman_mse` criterion to `squared_error`; the two pick the same splits), replaces
//! every leaf value by one Newton step `mean(y − p) / mean(p(1 − p))` over the leaf's
//! in-bag rows (0 when the denominator is below 1e-150), and adds `learning_rate × leaf`
//! to the raw score of every row. With `subsample < 1` each stage draws
//! `max(1, ⌊subsample·n⌋)` rows without replacement. The features are sorted once and
//! the order reused by every tree.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::codec;
use crate::error::BaselineError;
use crate::forest::{Shared, derive_seed};
use crate::linear::expit;
use crate::matrix::Matrix;
use crate::spec::GradientBoostingParams;
use crate::tree::{Criterion, Targets, Tree, TreeConfig};

/// A fitted boosted ensemble.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Boosted {
    /// Initial raw score (log-odds of the training prior).
    #[serde(with = "codec::exact")]
    pub init: f64,
    #[serde(with = "codec::exact")]
    pub learning_rate: f64,
    /// Leaf values are the Newton steps, before shrinkage.
    pub trees: Vec<Tree>,
}

/// Negative gradient of the half binomial loss, scikit-learn's stable branches.
#[inline]
fn neg_gradient(y: f64, raw: f64) -> f64 {
    if raw > -37.0 {
        let e = (-raw).exp();
        -(((1.0 - y) - y * e) / (1.0 + e))
    } else {
        -(raw.exp() - y)
    }
}

/// scipy's `logit`: `ln(p / (1 − p))`, but `ln1p(s) − ln1p(−s)` with `s = 2p − 1` near ½.
fn logit(p: f64) -> f64 {
    if !(0.3..=0.65).contains(&p) {
        (p / (1.0 - p)).ln()
    } else {
        let s = 2.0 * (p - 0.5);
        s.ln_1p() - (-s).ln_1p()
    }
}

pub(crate) fn fit(
    p: &GradientBoostingParams,
    x: &Matrix,
    y: &[bool],
    seed: u64,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Boosted, BaselineError> {
    let n = x.rows;
    let cfg = TreeConfig {
        criterion: Criterion::Mse,
        max_depth: p.max_depth.unwrap_or(usize::MAX),
        min_samples_split: p.min_samples_split,
        min_samples_leaf: p.min_samples_leaf,
        max_features: p.max_features.resolve(x.cols)?,
    };
    let yv: Vec<f64> = y.iter().map(|&v| f64::from(u8::from(v))).collect();
    let prior = (yv.iter().sum::<f64>() / n as f64).clamp(f64::EPSILON, 1.0 - f64::EPSILON);
    let init = logit(prior);
    let mut raw = vec![init; n];
    let shared = Shared::new(x, &cfg);
    let n_inbag = ((p.subsample * n as f64) as usize).max(1);
    let mut rng = ChaCha8Rng::seed_from_u64(derive_seed(seed, 0));
    let mut index: Vec<usize> = (0..n).collect();
    let mut weight = vec![1.0; n];
    let mut grad = vec![0.0; n];
    let mut trees = Vec::with_capacity(p.n_estimators);
    for stage in 0..p.n_estimators {
        for i in 0..n {
            grad[i] = neg_gradient(yv[i], raw[i]);
        }
        if n_inbag < n {
            // Partial Fisher-Yates: the first n_inbag of a random permutation are in bag.
            for i in 0..n_inbag {
                let j = rng.random_range(i..n);
                index.swap(i, j);
            }
            weight.fill(0.0);
            for &i in &index[..n_inbag] {
                weight[i] = 1.0;
            }
        }
        let targets = Targets {
            weight: &weight,
            target: &grad,
        };
        let mut tree_rng = ChaCha8Rng::seed_from_u64(rng.random());
        let (mut tree, leaf_of) = shared.grow(x, &targets, &cfg, &mut tree_rng);
        // Newton step per leaf over its in-bag rows.
        let mut num = vec![0.0f64; tree.len()];
        let mut den = vec![0.0f64; tree.len()];
        let mut count = vec![0usize; tree.len()];
        for i in 0..n {
            let leaf = leaf_of[i];
            if leaf == u32::MAX {
                continue;
            }
            let l = leaf as usize;
            let prob = yv[i] - grad[i];
            num[l] += grad[i];
            den[l] += prob * (1.0 - prob);
            count[l] += 1;
        }
        for l in 0..tree.len() {
            if count[l] > 0 && tree.feature[l] == crate::tree::LEAF {
                let c = count[l] as f64;
                let (nm, dm) = (num[l] / c, den[l] / c);
                tree.value[l] = if dm.abs() < 1e-150 { 0.0 } else { nm / dm };
            }
        }
        for i in 0..n {
            let leaf = match leaf_of[i] {
                u32::MAX => tree.apply(x.row(i)),
                l => l as usize,
            };
            raw[i] += p.learning_rate * tree.value[leaf];
        }
        trees.push(tree);
        progress(stage + 1, p.n_estimators);
    }
    Ok(Boosted {
        init,
        learning_rate: p.learning_rate,
        trees,
    })
}

impl Boosted {
    /// `expit(raw₀ + Σ learning_rate · leaf)`, trees added in order.
    pub fn predict_proba(&self, x: &Matrix) -> Vec<f64> {
        use rayon::prelude::*;
        x.data
            .par_chunks(x.cols.max(1))
            .map(|row| {
                let mut raw = self.init;
                for t in &self.trees {
                    raw += self.learning_rate * t.predict(row);
                }
                expit(raw)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn one_stage_is_a_newton_step_on_a_stump() {
        // y = [0, 0, 1, 1, 1]: prior 0.6, p = 0.6 everywhere; the stump splits at 1.5.
        let x = Matrix::from_rows(&[[0.0f32], [1.0], [2.0], [3.0], [4.0]]).unwrap();
        let y = [false, false, true, true, true];
        let params = GradientBoostingParams {
            n_estimators: 1,
            max_depth: Some(1),
            ..Default::default()
        };
        let m = fit(&params, &x, &y, 0, &|_, _| {}).unwrap();
        assert!((m.init - (0.6f64 / 0.4).ln()).abs() < 1e-15);
        let t = &m.trees[0];
        assert_eq!(t.threshold[0], 1.5);
        // Left: mean(0 − 0.6) / 0.24 = −2.5; right: mean(1 − 0.6) / 0.24 = 5/3.
        assert!((t.value[1] + 2.5).abs() < 1e-12, "{}", t.value[1]);
        assert!((t.value[2] - 0.4 / 0.24).abs() < 1e-12, "{}", t.value[2]);
        let p = m.predict_proba(&Matrix::from_rows(&[[0.0f32]]).unwrap());
        assert!((p[0] - expit(m.init - 0.25)).abs() < 1e-15);
    }
}
