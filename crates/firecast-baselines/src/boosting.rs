//! Gradient boosting with the log-loss, exactly as scikit-learn's
//! `GradientBoostingClassifier`.
//!
//! `raw₀ = logit(prior)` (the prior clipped to [ε, 1−ε], scipy's `logit`). One
//! `RandomState(random_state)` drives every stage: with `subsample < 1` a stage first draws
//! `n` uniforms and keeps row `i` in bag when `u_i·(n − i) < n_inbag − kept so far`
//! (`n_inbag = max(1, ⌊subsample·n⌋)`, out-of-bag rows get weight 0), then its tree's
//! splitter draws its state from the same generator. Each stage fits a squared-error
//! regression tree ([`crate::tree`], bit for bit scikit-learn's) to the negative gradient
//! `−∂loss/∂raw` (scikit-learn's stable branches), replaces every leaf value by one Newton
//! step `mean(y − p) / mean(p(1 − p))` over the leaf's in-bag rows in row order, with
//! NumPy's pairwise sums (`np.average`), 0 when the denominator is below 1e-150, and adds
//! `learning_rate × leaf` to the raw score of every row.

use serde::{Deserialize, Serialize};

use crate::codec;
use crate::error::BaselineError;
use crate::forest::random_state;
use crate::linear::expit;
use crate::matrix::Matrix;
use crate::nprandom::{RandomState, pairwise_sum};
use crate::spec::GradientBoostingParams;
use crate::tree::{Criterion, LEAF, Targets, Tree, TreeConfig, grow, rand_r_seed};

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
    let mut rng = RandomState::new(random_state(seed)?);
    let yv: Vec<f64> = y.iter().map(|&v| f64::from(u8::from(v))).collect();
    let prior = (yv.iter().sum::<f64>() / n as f64).clamp(f64::EPSILON, 1.0 - f64::EPSILON);
    let init = logit(prior);
    let mut raw = vec![init; n];
    let cols = x.columns();
    let do_oob = p.subsample < 1.0;
    let n_inbag = ((p.subsample * n as f64) as usize).max(1);
    let mut weight = vec![1.0; n];
    let mut in_bag = vec![true; n];
    let mut grad = vec![0.0; n];
    let mut leaf = vec![0usize; n];
    let mut trees = Vec::with_capacity(p.n_estimators);
    for stage in 0..p.n_estimators {
        if do_oob {
            let mut bagged = 0usize;
            for i in 0..n {
                let u = rng.uniform();
                in_bag[i] = u * ((n - i) as f64) < ((n_inbag - bagged) as f64);
                bagged += usize::from(in_bag[i]);
                weight[i] = f64::from(u8::from(in_bag[i]));
            }
        }
        for i in 0..n {
            grad[i] = neg_gradient(yv[i], raw[i]);
        }
        let targets = Targets {
            weight: Some(&weight),
            target: &grad,
        };
        let state = rand_r_seed(&mut rng);
        let mut tree = grow(&cols, n, x.cols, &targets, &cfg, state);
        // Newton step per leaf over its in-bag rows, in row order (np.average).
        let mut rows: Vec<Vec<usize>> = vec![Vec::new(); tree.len()];
        for i in 0..n {
            leaf[i] = tree.apply(x.row(i));
            if in_bag[i] {
                rows[leaf[i]].push(i);
            }
        }
        let (mut num, mut den) = (Vec::new(), Vec::new());
        for (l, members) in rows.iter().enumerate() {
            if tree.feature[l] != LEAF || members.is_empty() {
                continue;
            }
            num.clear();
            den.clear();
            for &i in members {
                num.push(grad[i]);
                let prob = yv[i] - grad[i];
                den.push(prob * (1.0 - prob));
            }
            let count = members.len() as f64;
            let (nm, dm) = (pairwise_sum(&num) / count, pairwise_sum(&den) / count);
            tree.value[l] = if dm.abs() < 1e-150 { 0.0 } else { nm / dm };
        }
        for i in 0..n {
            raw[i] += p.learning_rate * tree.value[leaf[i]];
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
