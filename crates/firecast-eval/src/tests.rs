//! Paired statistical tests: McNemar on hard predictions, DeLong on AUROCs, and Holm's
//! step-down adjustment for several comparisons.

use std::cmp::Ordering;

use serde::{Deserialize, Serialize};

use crate::error::{EvalError, all_finite, same_len};
use crate::special::{binomial_two_sided_half, chi2_sf_1df, erfc};

/// Below this many discordant pairs McNemar's test is exact (binomial).
pub const MCNEMAR_EXACT_BELOW: u64 = 25;

/// McNemar's test of two classifiers on the same samples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct McNemar {
    /// Samples A classifies correctly and B does not.
    pub b: u64,
    /// Samples B classifies correctly and A does not.
    pub c: u64,
    /// Exact test: min(b, c), the binomial count; χ² test: (|b − c| − 1)² / (b + c).
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub statistic: f64,
    /// Two-sided p-value.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub p_value: f64,
    /// Whether the exact binomial test was used (b + c < 25).
    pub exact: bool,
}

/// McNemar's test of hard predictions `pred_a`, `pred_b` against `y`. With b + c < 25
/// discordant pairs: exact two-sided binomial test, p = min(1, 2·P(X ≤ min(b, c))) with
/// X ~ Bin(b + c, ½) (`scipy.stats.binomtest`; p = 1 when b + c = 0). Otherwise χ² with
/// continuity correction, (|b − c| − 1)² / (b + c), p from the χ²(1) survival function.
/// Errors name `pred_a` or `pred_b` when their length differs from `y`'s.
pub fn mcnemar(y: &[bool], pred_a: &[bool], pred_b: &[bool]) -> Result<McNemar, EvalError> {
    same_len("pred_a", pred_a.len(), "y", y.len())?;
    same_len("pred_b", pred_b.len(), "y", y.len())?;
    let (mut b, mut c) = (0u64, 0u64);
    for ((&actual, &a), &bb) in y.iter().zip(pred_a).zip(pred_b) {
        match (a == actual, bb == actual) {
            (true, false) => b += 1,
            (false, true) => c += 1,
            _ => {}
        }
    }
    let n = b + c;
    if n < MCNEMAR_EXACT_BELOW {
        let k = b.min(c);
        // n < 25 is within the exact summation's range.
        let p_value = binomial_two_sided_half(k, n).unwrap_or(f64::NAN);
        Ok(McNemar {
            b,
            c,
            statistic: k as f64,
            p_value,
            exact: true,
        })
    } else {
        let d = b.abs_diff(c) as f64 - 1.0;
        let statistic = d * d / n as f64;
        Ok(McNemar {
            b,
            c,
            statistic,
            p_value: chi2_sf_1df(statistic),
            exact: false,
        })
    }
}

/// DeLong's test for two correlated AUROCs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeLong {
    /// AUROC of A.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub auc_a: f64,
    /// AUROC of B.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub auc_b: f64,
    /// auc_a − auc_b.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub diff: f64,
    /// Standard error of the difference.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub se: f64,
    /// diff / se.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub z: f64,
    /// Two-sided p-value, erfc(|z|/√2).
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub p_value: f64,
}

/// Midranks (1-based, ties get the mean of their ranks).
fn midranks(x: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.sort_by(|&a, &b| x[a].partial_cmp(&x[b]).unwrap_or(Ordering::Equal));
    let mut ranks = vec![0.0; x.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        while j < order.len() && x[order[j]] == x[order[i]] {
            j += 1;
        }
        let rank = 0.5 * (i + j - 1) as f64 + 1.0;
        for &k in &order[i..j] {
            ranks[k] = rank;
        }
        i = j;
    }
    ranks
}

/// AUROC and DeLong's structural components of one score vector, by midranks
/// (Sun & Xu 2014): `v10[i]` for each positive, `v01[j]` for each negative.
fn components(pos: &[f64], neg: &[f64]) -> (f64, Vec<f64>, Vec<f64>) {
    let (m, n) = (pos.len() as f64, neg.len() as f64);
    let tx = midranks(pos);
    let ty = midranks(neg);
    let all: Vec<f64> = pos.iter().chain(neg).copied().collect();
    let tz = midranks(&all);
    let (tz_pos, tz_neg) = tz.split_at(pos.len());
    let auc = tz_pos.iter().sum::<f64>() / m / n - (m + 1.0) / 2.0 / n;
    let v10 = tz_pos.iter().zip(&tx).map(|(z, x)| (z - x) / n).collect();
    let v01 = tz_neg.iter().zip(&ty).map(|(z, y)| 1.0 - (z - y) / m).collect();
    (auc, v10, v01)
}

/// Sample covariance (n − 1 denominator).
fn covariance(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum::<f64>() / (n - 1.0)
}

/// DeLong et al. (1988) test of AUROC(A) = AUROC(B) on the same samples, with the
/// midrank algorithm of Sun & Xu (2014): Var = S₁₀/m + S₀₁/n over the structural
/// components, z = (auc_a − auc_b)/se, p = erfc(|z|/√2). When se = 0 (identical
/// rankings, or both perfect), z = 0 and p = 1 if the AUROCs are equal, else z = ±∞ and
/// p = 0. Needs at least two positives and two negatives (the covariances use n − 1).
/// Errors name `p_a` or `p_b` on a length mismatch or a non-finite score.
pub fn delong(y: &[bool], p_a: &[f64], p_b: &[f64]) -> Result<DeLong, EvalError> {
    same_len("p_a", p_a.len(), "y", y.len())?;
    same_len("p_b", p_b.len(), "y", y.len())?;
    all_finite("p_a", p_a)?;
    all_finite("p_b", p_b)?;
    let positives = y.iter().filter(|&&l| l).count();
    let negatives = y.len() - positives;
    if positives < 2 || negatives < 2 {
        return Err(EvalError::TooFewPerClass {
            needed: 2,
            positives,
            negatives,
        });
    }
    let split = |p: &[f64]| -> (Vec<f64>, Vec<f64>) {
        let pos = y.iter().zip(p).filter(|(l, _)| **l).map(|(_, &v)| v).collect();
        let neg = y.iter().zip(p).filter(|(l, _)| !**l).map(|(_, &v)| v).collect();
        (pos, neg)
    };
    let (pos_a, neg_a) = split(p_a);
    let (pos_b, neg_b) = split(p_b);
    let (auc_a, v10_a, v01_a) = components(&pos_a, &neg_a);
    let (auc_b, v10_b, v01_b) = components(&pos_b, &neg_b);
    let (m, n) = (positives as f64, negatives as f64);
    let s = |a10: &[f64], b10: &[f64], a01: &[f64], b01: &[f64]| {
        covariance(a10, b10) / m + covariance(a01, b01) / n
    };
    let var_a = s(&v10_a, &v10_a, &v01_a, &v01_a);
    let var_b = s(&v10_b, &v10_b, &v01_b, &v01_b);
    let cov_ab = s(&v10_a, &v10_b, &v01_a, &v01_b);
    let se = (var_a + var_b - 2.0 * cov_ab).max(0.0).sqrt();
    let diff = auc_a - auc_b;
    let (z, p_value) = if se > 0.0 {
        let z = diff / se;
        (z, erfc(z.abs() / std::f64::consts::SQRT_2))
    } else if diff == 0.0 {
        (0.0, 1.0)
    } else {
        (diff.signum() * f64::INFINITY, 0.0)
    };
    Ok(DeLong {
        auc_a,
        auc_b,
        diff,
        se,
        z,
        p_value,
    })
}

/// Holm–Bonferroni adjusted p-values, in the input order (as statsmodels'
/// `multipletests(method="holm")`): sorted ascending, p₍ᵢ₎ · (m − i) for i from 0,
/// made non-decreasing by a running maximum, capped at 1. A NaN input gives a NaN
/// output and still counts in m.
pub fn holm(p_values: &[f64]) -> Vec<f64> {
    let m = p_values.len();
    let mut order: Vec<usize> = (0..m).filter(|&i| !p_values[i].is_nan()).collect();
    order.sort_by(|&a, &b| p_values[a].total_cmp(&p_values[b]));
    let mut adjusted = vec![f64::NAN; m];
    let mut running = 0.0f64;
    for (rank, &i) in order.iter().enumerate() {
        running = running.max((m - rank) as f64 * p_values[i]);
        adjusted[i] = running.min(1.0);
    }
    adjusted
}

#[cfg(test)]
mod unit {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn mcnemar_switches_from_exact_to_chi2_at_25() {
        // b + c = 24: exact.
        let y = vec![true; 24];
        let a: Vec<bool> = (0..24).map(|i| i < 17).collect();
        let b: Vec<bool> = (0..24).map(|i| i >= 17).collect();
        let t = mcnemar(&y, &a, &b).unwrap();
        assert_eq!((t.b, t.c, t.exact), (17, 7, true));
        assert_eq!(t.statistic, 7.0);
        // scipy.stats.binomtest(7, 24).pvalue
        assert!(
            (t.p_value - 0.063_914_656_639_099_12).abs() < 1e-15,
            "{}",
            t.p_value
        );
        // b + c = 25: χ² with continuity correction.
        let y = vec![true; 25];
        let a: Vec<bool> = (0..25).map(|i| i < 18).collect();
        let b: Vec<bool> = (0..25).map(|i| i >= 18).collect();
        let t = mcnemar(&y, &a, &b).unwrap();
        assert_eq!((t.b, t.c, t.exact), (18, 7, false));
        assert_eq!(t.statistic, 100.0 / 25.0);
        // scipy.stats.chi2.sf(4, 1)
        assert!(
            (t.p_value - 0.045_500_263_896_358_41).abs() < 1e-15,
            "{}",
            t.p_value
        );
    }

    #[test]
    fn mcnemar_without_discordant_pairs() {
        let y = [true, false];
        let t = mcnemar(&y, &[true, true], &[true, true]).unwrap();
        assert_eq!((t.b, t.c, t.p_value, t.exact), (0, 0, 1.0, true));
        assert!(matches!(
            mcnemar(&y, &[true], &[true, true]),
            Err(EvalError::LengthMismatch {
                argument: "pred_a",
                ..
            })
        ));
    }

    #[test]
    fn delong_hand_computed() {
        // A: positives {0.9, 0.4}, negatives {0.5, 0.1}: V10 = [1, ½], V01 = [½, 1], AUC ¾.
        // B separates perfectly: AUC 1, components constant.
        // Var = var(V10_A)/2 + var(V01_A)/2 = 0.125/2 + 0.125/2 = 0.125.
        let y = [true, true, false, false];
        let t = delong(&y, &[0.9, 0.4, 0.5, 0.1], &[0.8, 0.7, 0.3, 0.6]).unwrap();
        assert_eq!((t.auc_a, t.auc_b, t.diff), (0.75, 1.0, -0.25));
        assert!((t.se - 0.125f64.sqrt()).abs() < 1e-15);
        assert!((t.z + std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-15);
        // erfc(1/2)
        assert!((t.p_value - 0.479_500_122_186_953_5).abs() < 1e-15);
    }

    #[test]
    fn delong_with_ties_and_identical_models() {
        // Ties across classes count one half: positives {1, 1}, negatives {1, 0}: AUC ¾.
        let y = [true, true, false, false];
        let p = [1.0, 1.0, 1.0, 0.0];
        let t = delong(&y, &p, &p).unwrap();
        assert_eq!(
            (t.auc_a, t.diff, t.se, t.z, t.p_value),
            (0.75, 0.0, 0.0, 0.0, 1.0)
        );
        assert!(matches!(
            delong(&[true, false, false], &[0.1, 0.2, 0.3], &[0.1, 0.2, 0.3]),
            Err(EvalError::TooFewPerClass {
                positives: 1,
                negatives: 2,
                ..
            })
        ));
    }

    #[test]
    fn holm_known_vector() {
        // Sorted 0.005, 0.01, 0.03, 0.04 → ×4, ×3, ×2, ×1 = 0.02, 0.03, 0.06, 0.04 → max-run 0.06.
        let adj = holm(&[0.01, 0.04, 0.03, 0.005]);
        let want = [0.03, 0.06, 0.06, 0.02];
        for (a, w) in adj.iter().zip(want) {
            assert!((a - w).abs() < 1e-15, "{adj:?}");
        }
        assert_eq!(holm(&[0.5, 0.9]), vec![1.0, 1.0]);
        assert!(holm(&[]).is_empty());
        let with_nan = holm(&[0.01, f64::NAN]);
        assert!((with_nan[0] - 0.02).abs() < 1e-15 && with_nan[1].is_nan());
    }
}
