//! L2-penalised logistic regression fitted with L-BFGS, as scikit-learn's lbfgs solver.
//!
//! The objective is scikit-learn's, scaled as its `LinearModelLoss` scales it:
//! `f(w, b) = (1/n) Σ log-loss(yᵢ, xᵢ·w + b) + ‖w‖² / (2·C·n)`, whose minimiser is that
//! of `C · Σ log-loss + ½‖w‖²`; `tol` bounds the largest gradient component of this `f`
//! (scipy's `gtol`), and the relative-decrease stop uses scipy's `ftol = 64·ε`. The
//! log-loss and its gradient use scikit-learn's numerically stable branches. The path
//! (line search, first step) is our own, so only a converged fit is the same model.
//! Fitting is in `f64`; probabilities are `expit` of the score in `f32`, as scikit-learn
//! returns them for `float32` input (its fit in `float32` stalls ~1e-3 short of the
//! optimum with a tight `tol`; ours reaches it).

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::codec;
use crate::matrix::Matrix;
use crate::spec::LogisticRegressionParams;

/// A fitted logistic regression.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Logistic {
    #[serde(with = "codec::exact_vec")]
    pub coef: Vec<f64>,
    #[serde(with = "codec::exact")]
    pub intercept: f64,
    /// L-BFGS iterations run.
    pub n_iter: usize,
    /// Whether a stopping test (`tol` or `ftol`) was met before `max_iter`.
    pub converged: bool,
}

/// Rows per parallel chunk: fixed, so sums do not depend on the thread count.
const CHUNK: usize = 512;
/// L-BFGS memory (scipy's default `maxcor`).
const MEMORY: usize = 10;
/// Function evaluations per line search (scikit-learn passes `maxls = 50`).
const MAX_LS: usize = 50;

/// Half binomial loss and its gradient in the raw score, scikit-learn's branches.
#[inline]
fn loss_grad(y: f64, raw: f64) -> (f64, f64) {
    if raw <= -37.0 {
        let e = raw.exp();
        (e - y * raw, e - y)
    } else if raw <= -2.0 {
        let e = raw.exp();
        (e.ln_1p() - y * raw, ((1.0 - y) * e - y) / (1.0 + e))
    } else if raw <= 18.0 {
        let e = (-raw).exp();
        (e.ln_1p() + (1.0 - y) * raw, ((1.0 - y) - y * e) / (1.0 + e))
    } else {
        let e = (-raw).exp();
        (e + (1.0 - y) * raw, ((1.0 - y) - y * e) / (1.0 + e))
    }
}

/// `1 / (1 + e^{−z})`, scipy's `expit`.
#[inline]
pub(crate) fn expit(z: f64) -> f64 {
    1.0 / (1.0 + (-z).exp())
}

#[inline]
fn dot_row(row: &[f32], w: &[f64]) -> f64 {
    row.iter().zip(w).map(|(&x, &w)| f64::from(x) * w).sum()
}

struct Problem<'a> {
    x: &'a Matrix,
    y: Vec<f64>,
    fit_intercept: bool,
    /// `1 / (C n)`.
    l2: f64,
}

impl Problem<'_> {
    fn dim(&self) -> usize {
        self.x.cols + usize::from(self.fit_intercept)
    }

    /// Objective and gradient at `theta = [w, b]`.
    fn eval(&self, theta: &[f64]) -> (f64, Vec<f64>) {
        let d = self.x.cols;
        let w = &theta[..d];
        let b = if self.fit_intercept { theta[d] } else { 0.0 };
        let n = self.x.rows;
        let partials: Vec<(f64, Vec<f64>)> = (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut loss = 0.0;
                let mut g = vec![0.0; d + 1];
                for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                    let row = self.x.row(i);
                    let (l, gp) = loss_grad(self.y[i], dot_row(row, w) + b);
                    loss += l;
                    for (gj, &xj) in g.iter_mut().zip(row) {
                        *gj += gp * f64::from(xj);
                    }
                    g[d] += gp;
                }
                (loss, g)
            })
            .collect();
        let mut loss = 0.0;
        let mut g = vec![0.0; d + 1];
        for (l, pg) in &partials {
            loss += l;
            for (a, b) in g.iter_mut().zip(pg) {
                *a += b;
            }
        }
        let nf = n as f64;
        let norm2: f64 = w.iter().map(|v| v * v).sum();
        let f = loss / nf + 0.5 * self.l2 * norm2;
        for j in 0..d {
            g[j] = g[j] / nf + self.l2 * w[j];
        }
        if self.fit_intercept {
            g[d] /= nf;
        } else {
            g.truncate(d);
        }
        (f, g)
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn max_abs(g: &[f64]) -> f64 {
    g.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// A trial point of the line search.
struct Trial {
    alpha: f64,
    f: f64,
    g: Vec<f64>,
    /// Directional derivative `g · d`.
    dg: f64,
}

/// Strong-Wolfe line search (Nocedal & Wright, algorithms 3.5 and 3.6, cubic
/// interpolation) along `dir` from `x`. `None` when no acceptable decrease was found.
fn line_search(p: &Problem<'_>, x: &[f64], dir: &[f64], f0: f64, dg0: f64, alpha0: f64) -> Option<Trial> {
    const C1: f64 = 1e-4;
    const C2: f64 = 0.9;
    let mut evals = 0usize;
    let at = |alpha: f64, evals: &mut usize| -> Trial {
        *evals += 1;
        let xt: Vec<f64> = x.iter().zip(dir).map(|(a, b)| a + alpha * b).collect();
        let (f, g) = p.eval(&xt);
        let dg = dot(&g, dir);
        Trial { alpha, f, g, dg }
    };
    let armijo = |t: &Trial| t.f <= f0 + C1 * t.alpha * dg0;
    let curvature = |t: &Trial| t.dg.abs() <= -C2 * dg0;

    let mut prev = Trial {
        alpha: 0.0,
        f: f0,
        g: Vec::new(),
        dg: dg0,
    };
    let mut alpha = alpha0;
    let (mut lo, mut hi) = loop {
        let cur = at(alpha, &mut evals);
        if !cur.f.is_finite() {
            // Overshot into overflow: shrink.
            if evals >= MAX_LS {
                return None;
            }
            alpha = 0.5 * (prev.alpha + alpha);
            continue;
        }
        if !armijo(&cur) || (evals > 1 && cur.f >= prev.f) {
            break (prev, cur);
        }
        if curvature(&cur) {
            return Some(cur);
        }
        if cur.dg >= 0.0 {
            break (cur, prev);
        }
        if evals >= MAX_LS {
            return Some(cur);
        }
        alpha = cur.alpha * 2.0;
        prev = cur;
    };
    // Zoom: `lo` satisfies Armijo with the lowest f so far; the minimiser lies between.
    loop {
        if evals >= MAX_LS || (hi.alpha - lo.alpha).abs() <= 1e-16 * lo.alpha.abs().max(1e-300) {
            return (lo.alpha > 0.0).then_some(lo);
        }
        let (a, b) = (lo.alpha, hi.alpha);
        let width = (b - a).abs();
        let d1 = lo.dg + hi.dg - 3.0 * (lo.f - hi.f) / (a - b);
        let disc = d1 * d1 - lo.dg * hi.dg;
        let mut alpha = if disc >= 0.0 {
            let d2 = (b - a).signum() * disc.sqrt();
            b - (b - a) * (hi.dg + d2 - d1) / (hi.dg - lo.dg + 2.0 * d2)
        } else {
            f64::NAN
        };
        let (min, max) = (a.min(b), a.max(b));
        if !alpha.is_finite() || alpha < min + 0.1 * width || alpha > max - 0.1 * width {
            alpha = 0.5 * (a + b);
        }
        let cur = at(alpha, &mut evals);
        if !cur.f.is_finite() || !armijo(&cur) || cur.f >= lo.f {
            hi = cur;
        } else {
            if curvature(&cur) {
                return Some(cur);
            }
            if cur.dg * (hi.alpha - lo.alpha) >= 0.0 {
                hi = lo;
            }
            lo = cur;
        }
    }
}

/// Fits the model; `progress(iteration, max_iter)` after every L-BFGS iteration.
pub(crate) fn fit(
    params: &LogisticRegressionParams,
    x: &Matrix,
    y: &[bool],
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Logistic {
    let n = x.rows;
    let problem = Problem {
        x,
        y: y.iter().map(|&v| f64::from(u8::from(v))).collect(),
        fit_intercept: params.fit_intercept,
        l2: 1.0 / (params.c * n as f64),
    };
    let dim = problem.dim();
    let mut theta = vec![0.0; dim];
    let (mut f, mut g) = problem.eval(&theta);
    let mut hist: Vec<(Vec<f64>, Vec<f64>, f64)> = Vec::new(); // (s, y, 1 / s·y)
    let mut n_iter = 0;
    let mut converged = max_abs(&g) <= params.tol;
    while !converged && n_iter < params.max_iter {
        // Two-loop recursion for d = −H·g.
        let mut q = g.clone();
        let mut alphas = Vec::with_capacity(hist.len());
        for (s, yv, rho) in hist.iter().rev() {
            let a = rho * dot(s, &q);
            for (qi, yi) in q.iter_mut().zip(yv) {
                *qi -= a * yi;
            }
            alphas.push(a);
        }
        if let Some((s, yv, _)) = hist.last() {
            let gamma = dot(s, yv) / dot(yv, yv);
            for qi in q.iter_mut() {
                *qi *= gamma;
            }
        }
        for ((s, yv, rho), a) in hist.iter().zip(alphas.iter().rev()) {
            let b = rho * dot(yv, &q);
            for (qi, si) in q.iter_mut().zip(s) {
                *qi += (a - b) * si;
            }
        }
        let mut dir: Vec<f64> = q.iter().map(|v| -v).collect();
        let mut dg = dot(&g, &dir);
        if dg >= 0.0 || !dg.is_finite() {
            hist.clear();
            dir = g.iter().map(|v| -v).collect();
            dg = dot(&g, &dir);
        }
        // First step of a fresh memory: length 1 / ‖d‖, as L-BFGS-B starts.
        let alpha0 = if hist.is_empty() {
            1.0 / dot(&dir, &dir).sqrt()
        } else {
            1.0
        };
        let trial = match line_search(&problem, &theta, &dir, f, dg, alpha0) {
            Some(t) => t,
            None if !hist.is_empty() => {
                hist.clear();
                continue;
            }
            None => break,
        };
        n_iter += 1;
        let s: Vec<f64> = dir.iter().map(|v| trial.alpha * v).collect();
        let yv: Vec<f64> = trial.g.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy = dot(&s, &yv);
        if sy > f64::EPSILON * dot(&yv, &yv) {
            if hist.len() == MEMORY {
                hist.remove(0);
            }
            hist.push((s.clone(), yv, 1.0 / sy));
        }
        for (t, si) in theta.iter_mut().zip(&s) {
            *t += si;
        }
        let f_old = f;
        f = trial.f;
        g = trial.g;
        progress(n_iter, params.max_iter);
        if max_abs(&g) <= params.tol || (f_old - f) / f_old.abs().max(f.abs()).max(1.0) <= 64.0 * f64::EPSILON
        {
            converged = true;
        }
    }
    if converged && n_iter < params.max_iter {
        progress(params.max_iter, params.max_iter); // converged early: finish the bar
    }
    let d = x.cols;
    Logistic {
        coef: theta[..d].to_vec(),
        intercept: if params.fit_intercept { theta[d] } else { 0.0 },
        n_iter,
        converged,
    }
}

impl Logistic {
    /// P(class 1) per row.
    pub fn predict_proba(&self, x: &Matrix) -> Vec<f64> {
        let d = x.cols;
        x.data
            .par_chunks(d.max(1))
            .map(|row| {
                // scikit-learn fits float32 input in float32 and returns expit of a float32
                // score: same rounding and saturation (p = 1 beyond z ≈ 16.6).
                let z = (dot_row(row, &self.coef) + self.intercept) as f32;
                f64::from(1.0 / (1.0 + (-z).exp()))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn loss_branches_are_continuous() {
        for &raw in &[-37.0f64, -2.0, 18.0] {
            for y in [0.0, 1.0] {
                let (l1, g1) = loss_grad(y, raw);
                let (l2, g2) = loss_grad(y, raw + 1e-9);
                assert!((l1 - l2).abs() < 1e-8 && (g1 - g2).abs() < 1e-8, "{raw} {y}");
            }
        }
        let (l, g) = loss_grad(1.0, 0.0);
        assert!((l - 2f64.ln()).abs() < 1e-15 && (g + 0.5).abs() < 1e-15);
    }

    #[test]
    fn one_feature_optimum_has_zero_gradient() {
        let x = Matrix::from_rows(&[[-2.0f32], [-1.0], [0.5], [1.0], [2.0], [-0.5]]).unwrap();
        let y = [false, false, true, true, true, true];
        let params = LogisticRegressionParams {
            tol: 1e-12,
            max_iter: 1000,
            ..Default::default()
        };
        let m = fit(&params, &x, &y, &|_, _| {});
        assert!(m.converged);
        let p = Problem {
            x: &x,
            y: y.iter().map(|&v| f64::from(u8::from(v))).collect(),
            fit_intercept: true,
            l2: 1.0 / 6.0,
        };
        let (_, g) = p.eval(&[m.coef[0], m.intercept]);
        assert!(max_abs(&g) < 1e-10, "{g:?}");
        assert!(m.coef[0] > 0.0);
    }
}
