//! Gaussian naive Bayes, as scikit-learn's `GaussianNB`.
//!
//! Per class: feature means and population variances, plus `epsilon = var_smoothing ×
//! max_j Var(x_j)` (variance over all rows); priors are the class frequencies. The
//! posterior is `exp(jll₁ − logsumexp(jll₀, jll₁))` with
//! `jll_c = ln prior_c − ½ Σ ln(2π σ²_cj) − ½ Σ (x_j − μ_cj)² / σ²_cj`.
//! Means, variances and the joint log-likelihoods are computed in `f64` (scikit-learn
//! keeps `float32` input in `float32`, a ~1e-6 difference); the final normalisation
//! follows scikit-learn's `float32` arithmetic, see [`normalize_f32`].

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::codec;
use crate::error::BaselineError;
use crate::matrix::Matrix;

/// A fitted Gaussian naive Bayes model (class 0 then class 1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct GaussianNb {
    #[serde(with = "codec::exact_vec")]
    pub prior: Vec<f64>,
    #[serde(with = "codec::exact_vec")]
    pub theta0: Vec<f64>,
    #[serde(with = "codec::exact_vec")]
    pub theta1: Vec<f64>,
    /// Smoothed variances.
    #[serde(with = "codec::exact_vec")]
    pub var0: Vec<f64>,
    #[serde(with = "codec::exact_vec")]
    pub var1: Vec<f64>,
    #[serde(with = "codec::exact")]
    pub epsilon: f64,
}

/// Two-pass mean and population variance of the columns of the rows `take` selects.
fn moments(x: &Matrix, take: impl Fn(usize) -> bool) -> (Vec<f64>, Vec<f64>) {
    let d = x.cols;
    let mut n = 0usize;
    let mut sum = vec![0.0f64; d];
    for i in 0..x.rows {
        if take(i) {
            n += 1;
            for (s, &v) in sum.iter_mut().zip(x.row(i)) {
                *s += f64::from(v);
            }
        }
    }
    let nf = n as f64;
    let mean: Vec<f64> = sum.iter().map(|s| s / nf).collect();
    let mut sq = vec![0.0f64; d];
    for i in 0..x.rows {
        if take(i) {
            for ((s, &v), m) in sq.iter_mut().zip(x.row(i)).zip(&mean) {
                let t = f64::from(v) - m;
                *s += t * t;
            }
        }
    }
    (mean, sq.iter().map(|s| s / nf).collect())
}

pub(crate) fn fit(var_smoothing: f64, x: &Matrix, y: &[bool]) -> Result<GaussianNb, BaselineError> {
    let (_, var_all) = moments(x, |_| true);
    let epsilon = var_smoothing * var_all.iter().fold(0.0f64, |m, &v| m.max(v));
    let (theta0, mut var0) = moments(x, |i| !y[i]);
    let (theta1, mut var1) = moments(x, |i| y[i]);
    for (c, var) in [&mut var0, &mut var1].into_iter().enumerate() {
        for (j, v) in var.iter_mut().enumerate() {
            *v += epsilon;
            if *v <= 0.0 || v.is_nan() {
                return Err(BaselineError::Numerical(format!(
                    "gaussian_nb: feature {j} has zero variance in class {c} and var_smoothing adds \
                     nothing (every feature is constant); raise var_smoothing"
                )));
            }
        }
    }
    let n1 = y.iter().filter(|&&v| v).count() as f64;
    let n = y.len() as f64;
    Ok(GaussianNb {
        prior: vec![(n - n1) / n, n1 / n],
        theta0,
        theta1,
        var0,
        var1,
        epsilon,
    })
}

/// `exp(jll₁ − logsumexp(jll))` in `f32`, step by step as scikit-learn's `_logsumexp`
/// and `predict_proba` run on `float32` input: `out = log1p(Σ exp(others − max) / m) +
/// ln m + max` (`m` = number of maxima). Its `f32` saturation (p = 1 once the log-odds
/// pass ≈ 16.6, p = 0 below ≈ −104) makes many exact ties on wide data, and those ties
/// move AUROC by more than 0.01, so the same arithmetic is kept here.
fn normalize_f32(j0: f32, j1: f32) -> f64 {
    let max = j0.max(j1);
    if !max.is_finite() {
        return f64::NAN; // the caller falls back to f64
    }
    let out = if j0 == j1 {
        0.0f32.ln_1p() + 2.0f32.ln() + max
    } else {
        (j0.min(j1) - max).exp().ln_1p() + 0.0 + max
    };
    f64::from((j1 - out).exp())
}

impl GaussianNb {
    /// P(class 1) per row.
    pub fn predict_proba(&self, x: &Matrix) -> Vec<f64> {
        let half_log_det = |var: &[f64]| -> f64 {
            -0.5 * var
                .iter()
                .map(|v| (2.0 * std::f64::consts::PI * v).ln())
                .sum::<f64>()
        };
        let c0 = self.prior[0].ln() + half_log_det(&self.var0);
        let c1 = self.prior[1].ln() + half_log_det(&self.var1);
        let quad = |row: &[f32], theta: &[f64], var: &[f64]| -> f64 {
            row.iter()
                .zip(theta)
                .zip(var)
                .map(|((&v, m), s)| {
                    let t = f64::from(v) - m;
                    t * t / s
                })
                .sum::<f64>()
        };
        x.data
            .par_chunks(x.cols.max(1))
            .map(|row| {
                let j0 = c0 - 0.5 * quad(row, &self.theta0, &self.var0);
                let j1 = c1 - 0.5 * quad(row, &self.theta1, &self.var1);
                let p = normalize_f32(j0 as f32, j1 as f32);
                if p.is_nan() {
                    // Log-likelihoods beyond the f32 range (far outliers): f64 instead.
                    let m = j0.max(j1);
                    (j1 - (((j0 - m).exp() + (j1 - m).exp()).ln() + m)).exp()
                } else {
                    p
                }
            })
            .collect()
    }

    pub fn validate(&self, d: usize) -> Result<(), String> {
        let ok = self.prior.len() == 2
            && [&self.theta0, &self.theta1, &self.var0, &self.var1]
                .iter()
                .all(|v| v.len() == d);
        if ok {
            Ok(())
        } else {
            Err("gaussian_nb arrays do not match the feature count".into())
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn two_point_toy_by_hand() {
        // Class 0 at 0 and 2 (μ 1, σ² 1), class 1 at 4 and 6 (μ 5, σ² 1); max Var = 5.
        let x = Matrix::from_rows(&[[0.0f32], [2.0], [4.0], [6.0]]).unwrap();
        let y = [false, false, true, true];
        let m = fit(1e-9, &x, &y).unwrap();
        assert_eq!(m.epsilon, 5e-9);
        assert_eq!((m.theta0[0], m.theta1[0]), (1.0, 5.0));
        assert_eq!(m.var0[0], 1.0 + 5e-9);
        // At x = 3 both classes are equally likely; at x = 4 the odds are e^{(9−1)/2σ²}.
        let p = m.predict_proba(&Matrix::from_rows(&[[3.0f32], [4.0], [30.0]]).unwrap());
        assert_eq!(p[0], 0.5);
        let odds = (4.0f64 / (1.0 + 5e-9)).exp();
        assert!((p[1] - odds / (1.0 + odds)).abs() < 1e-6);
        // Log-odds 52: exactly 1 in f32, as scikit-learn gives it.
        assert_eq!(p[2], 1.0);
    }

    #[test]
    fn all_constant_features_without_smoothing_is_an_error() {
        let x = Matrix::from_rows(&[[1.0f32], [1.0]]).unwrap();
        assert!(fit(0.0, &x, &[false, true]).is_err());
        assert!(fit(1e-9, &x, &[false, true]).is_err());
    }
}
