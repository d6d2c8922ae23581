//! Percentile bootstrap intervals, deterministic given a seed.
//!
//! Resample `r` draws from its own ChaCha8 stream (`ChaCha8Rng::seed_from_u64(seed)`
//! with `set_stream(r)`), so the first 1000 resamples are the same whether 1000 or
//! 10 000 are asked for. Samples can be grouped into clusters (windows of the same
//! GRIDMET cell are correlated): a clustered resample draws whole clusters with
//! replacement, so its size varies. Intervals are NumPy's linear percentiles of the
//! valid draws at (1 − level)/2 and (1 + level)/2.

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{EvalError, same_len};
use crate::metrics::evaluate;
use crate::numeric::{pairwise_sum, quantile_sorted};

/// A point estimate with its percentile bootstrap interval (NaN ↔ JSON `null`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    /// The statistic on the original samples (NaN when undefined there).
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub estimate: f64,
    /// Lower end (NaN when no resample was valid).
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub low: f64,
    /// Upper end (NaN when no resample was valid).
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub high: f64,
    /// Coverage asked for, e.g. 0.95.
    pub level: f64,
    /// Resamples on which the statistic was defined (`Some`, not NaN).
    pub n_valid: usize,
    /// Resamples drawn; `n_resamples − n_valid` were skipped.
    pub n_resamples: usize,
}

/// The interval of a difference A − B on shared resamples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairedInterval {
    /// statistic(A) − statistic(B) on the original samples.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub estimate: f64,
    /// Lower end of the difference.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub low: f64,
    /// Upper end of the difference.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub high: f64,
    /// Coverage asked for.
    pub level: f64,
    /// Resamples on which both statistics were defined.
    pub n_valid: usize,
    /// Resamples drawn.
    pub n_resamples: usize,
    /// Fraction of the valid resamples where A's statistic exceeds B's (NaN when none).
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub prob_a_better: f64,
}

/// Draws bootstrap resamples of `n` samples, optionally by cluster.
#[derive(Debug, Clone)]
pub struct Resampler {
    n: usize,
    /// Member indices of each cluster, clusters by increasing id; `None` = each sample alone.
    clusters: Option<Vec<Vec<usize>>>,
    seed: u64,
}

impl Resampler {
    /// A resampler of `n` samples; `clusters[i]` is sample i's cluster id. An error
    /// naming `clusters` when it does not have `n` entries.
    pub fn new(n: usize, clusters: Option<&[u64]>, seed: u64) -> Result<Self, EvalError> {
        let clusters = match clusters {
            None => None,
            Some(ids) => {
                same_len("clusters", ids.len(), "y", n)?;
                let mut members: BTreeMap<u64, Vec<usize>> = BTreeMap::new();
                for (i, &id) in ids.iter().enumerate() {
                    members.entry(id).or_default().push(i);
                }
                Some(members.into_values().collect())
            }
        };
        Ok(Self { n, clusters, seed })
    }

    /// Indices of resample `r` (with repetitions), written into `out`.
    pub fn resample_into(&self, r: u64, out: &mut Vec<usize>) {
        out.clear();
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        rng.set_stream(r);
        match &self.clusters {
            None => {
                if self.n > 0 {
                    out.extend((0..self.n).map(|_| rng.random_range(0..self.n)));
                }
            }
            Some(clusters) => {
                for _ in 0..clusters.len() {
                    out.extend_from_slice(&clusters[rng.random_range(0..clusters.len())]);
                }
            }
        }
    }

    /// Indices of resample `r`.
    pub fn resample(&self, r: u64) -> Vec<usize> {
        let mut out = Vec::new();
        self.resample_into(r, &mut out);
        out
    }
}

/// All `n_resamples` resamples of `n` samples, materialised (n_resamples × ~n indices;
/// use [`Resampler`] to draw them one at a time). `clusters`, when given, must have `n`
/// entries; otherwise no resample is returned (an empty `Vec`) — [`Resampler::new`]
/// reports that error.
pub fn resample_indices(
    n: usize,
    clusters: Option<&[u64]>,
    n_resamples: usize,
    seed: u64,
) -> Vec<Vec<usize>> {
    match Resampler::new(n, clusters, seed) {
        Ok(resampler) => (0..n_resamples as u64).map(|r| resampler.resample(r)).collect(),
        Err(_) => Vec::new(),
    }
}

/// `np.quantile(values, q)` (linear method); sorts `values`. NaN when empty.
pub fn quantile(values: &mut [f64], q: f64) -> f64 {
    values.sort_by(f64::total_cmp);
    quantile_sorted(values, q)
}

fn check_level(level: f64) -> Result<(), EvalError> {
    if level > 0.0 && level < 1.0 {
        Ok(())
    } else {
        Err(EvalError::InvalidArgument {
            argument: "level",
            reason: format!("{level} is not in (0, 1)"),
        })
    }
}

/// Percentile interval of the draws (sorted in place).
fn percentile_interval(draws: &mut [f64], level: f64) -> (f64, f64) {
    draws.sort_by(f64::total_cmp);
    (
        quantile_sorted(draws, (1.0 - level) / 2.0),
        quantile_sorted(draws, (1.0 + level) / 2.0),
    )
}

/// Fills `ys`/`ps` with the resampled pairs.
fn gather<T: Copy>(idx: &[usize], src: &[T], out: &mut Vec<T>) {
    out.clear();
    out.extend(idx.iter().map(|&i| src[i]));
}

fn valid(v: Option<f64>) -> Option<f64> {
    v.filter(|x| !x.is_nan())
}

/// Percentile bootstrap interval of `statistic(y, p)`. Resamples where the statistic is
/// `None` or NaN (say, a class absent) are skipped and counted in `n_resamples −
/// n_valid`. Errors name `p` or `clusters` when their length differs from `y`'s, or
/// `level` outside (0, 1).
pub fn ci(
    y: &[bool],
    p: &[f64],
    clusters: Option<&[u64]>,
    n_resamples: usize,
    seed: u64,
    level: f64,
    statistic: impl Fn(&[bool], &[f64]) -> Option<f64>,
) -> Result<Interval, EvalError> {
    same_len("p", p.len(), "y", y.len())?;
    check_level(level)?;
    let resampler = Resampler::new(y.len(), clusters, seed)?;
    let (mut idx, mut ys, mut ps) = (Vec::new(), Vec::new(), Vec::new());
    let mut draws = Vec::with_capacity(n_resamples);
    for r in 0..n_resamples as u64 {
        resampler.resample_into(r, &mut idx);
        gather(&idx, y, &mut ys);
        gather(&idx, p, &mut ps);
        if let Some(v) = valid(statistic(&ys, &ps)) {
            draws.push(v);
        }
    }
    let (low, high) = percentile_interval(&mut draws, level);
    Ok(Interval {
        estimate: statistic(y, p).unwrap_or(f64::NAN),
        low,
        high,
        level,
        n_valid: draws.len(),
        n_resamples,
    })
}

/// Names of the metrics [`report_intervals`] returns, as in [`crate::metrics::BinaryReport::metrics`].
pub const REPORT_METRICS: [&str; 14] = [
    "prevalence",
    "accuracy",
    "precision",
    "recall",
    "specificity",
    "f1",
    "balanced_accuracy",
    "mcc",
    "auroc",
    "auprc",
    "brier",
    "brier_skill",
    "log_loss",
    "ece",
];

/// Intervals for every scalar metric of [`crate::metrics::BinaryReport`] at a fixed `threshold` (ECE over
/// `n_bins` bins), all from the same resamples. Every name of [`REPORT_METRICS`] is
/// present; a metric undefined on a resample is skipped there (its own `n_valid`).
#[allow(clippy::too_many_arguments)] // mirrors `ci` plus the report's two settings
pub fn report_intervals(
    y: &[bool],
    p: &[f64],
    threshold: f64,
    n_bins: usize,
    clusters: Option<&[u64]>,
    n_resamples: usize,
    seed: u64,
    level: f64,
) -> Result<BTreeMap<String, Interval>, EvalError> {
    same_len("p", p.len(), "y", y.len())?;
    check_level(level)?;
    let resampler = Resampler::new(y.len(), clusters, seed)?;
    let full: BTreeMap<&str, f64> = evaluate(y, p, threshold, n_bins).metrics().into_iter().collect();
    let mut draws: BTreeMap<&str, Vec<f64>> = REPORT_METRICS.iter().map(|&k| (k, Vec::new())).collect();
    let (mut idx, mut ys, mut ps) = (Vec::new(), Vec::new(), Vec::new());
    for r in 0..n_resamples as u64 {
        resampler.resample_into(r, &mut idx);
        gather(&idx, y, &mut ys);
        gather(&idx, p, &mut ps);
        for (name, v) in evaluate(&ys, &ps, threshold, n_bins).metrics() {
            if let Some(d) = draws.get_mut(name) {
                d.push(v);
            }
        }
    }
    Ok(draws
        .into_iter()
        .map(|(name, mut d)| {
            let (low, high) = percentile_interval(&mut d, level);
            let interval = Interval {
                estimate: full.get(name).copied().unwrap_or(f64::NAN),
                low,
                high,
                level,
                n_valid: d.len(),
                n_resamples,
            };
            (name.to_string(), interval)
        })
        .collect())
}

/// Interval of statistic(y, p_a) − statistic(y, p_b) over shared resamples, and the
/// fraction of valid resamples where A's statistic is the larger. A resample counts when
/// both statistics are defined. Errors name `p_a`, `p_b` or `clusters` on a length
/// mismatch, or `level` outside (0, 1).
#[allow(clippy::too_many_arguments)] // `ci` with a second score vector
pub fn paired_diff_ci(
    y: &[bool],
    p_a: &[f64],
    p_b: &[f64],
    clusters: Option<&[u64]>,
    n_resamples: usize,
    seed: u64,
    level: f64,
    statistic: impl Fn(&[bool], &[f64]) -> Option<f64>,
) -> Result<PairedInterval, EvalError> {
    same_len("p_a", p_a.len(), "y", y.len())?;
    same_len("p_b", p_b.len(), "y", y.len())?;
    check_level(level)?;
    let resampler = Resampler::new(y.len(), clusters, seed)?;
    let (mut idx, mut ys, mut pa, mut pb) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut diffs = Vec::with_capacity(n_resamples);
    let mut a_better = 0usize;
    for r in 0..n_resamples as u64 {
        resampler.resample_into(r, &mut idx);
        gather(&idx, y, &mut ys);
        gather(&idx, p_a, &mut pa);
        gather(&idx, p_b, &mut pb);
        if let (Some(a), Some(b)) = (valid(statistic(&ys, &pa)), valid(statistic(&ys, &pb))) {
            diffs.push(a - b);
            a_better += usize::from(a > b);
        }
    }
    let n_valid = diffs.len();
    let (low, high) = percentile_interval(&mut diffs, level);
    let estimate = match (statistic(y, p_a), statistic(y, p_b)) {
        (Some(a), Some(b)) => a - b,
        _ => f64::NAN,
    };
    Ok(PairedInterval {
        estimate,
        low,
        high,
        level,
        n_valid,
        n_resamples,
        prob_a_better: if n_valid == 0 {
            f64::NAN
        } else {
            a_better as f64 / n_valid as f64
        },
    })
}

/// A paired difference over samples and training seeds, with its two-sided bootstrap p-value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeedPairedInterval {
    /// The interval of mean over seeds of statistic(A_s) − statistic(B_s).
    #[serde(flatten)]
    pub interval: PairedInterval,
    /// Two-sided percentile-bootstrap p-value of "no difference": twice the smaller share of
    /// valid resamples on either side of 0 (ties count on both), capped at 1; NaN when none.
    #[serde(deserialize_with = "crate::serde_nan::nan_if_null")]
    pub p_value: f64,
    /// Seed pairs compared.
    pub seeds: usize,
}

/// Interval of the mean over seeds of statistic(y, a[s]) − statistic(y, b[s]), where `a[s]`
/// and `b[s]` are two models' scores of training seed `s` on the same samples. Each resample
/// draws the samples (by cluster when given, as [`paired_diff_ci`]) and, independently, the
/// seed pairs with replacement, so the interval carries both the test set's and the training
/// seeds' variation. With one seed it is [`paired_diff_ci`]'s interval. Errors name `a`, `b`
/// or `clusters` on a length mismatch, or `level` outside (0, 1).
#[allow(clippy::too_many_arguments)] // `paired_diff_ci` with seeds
pub fn paired_diff_ci_seeds(
    y: &[bool],
    a: &[Vec<f64>],
    b: &[Vec<f64>],
    clusters: Option<&[u64]>,
    n_resamples: usize,
    seed: u64,
    level: f64,
    statistic: impl Fn(&[bool], &[f64]) -> Option<f64>,
) -> Result<SeedPairedInterval, EvalError> {
    same_len("b (seeds)", b.len(), "a (seeds)", a.len())?;
    for (pa, pb) in a.iter().zip(b) {
        same_len("a", pa.len(), "y", y.len())?;
        same_len("b", pb.len(), "y", y.len())?;
    }
    check_level(level)?;
    let k = a.len();
    let resampler = Resampler::new(y.len(), clusters, seed)?;
    let (mut idx, mut ys, mut pa, mut pb) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut diffs = Vec::with_capacity(n_resamples);
    let (mut above, mut below) = (0usize, 0usize);
    let mut a_better = 0usize;
    // One difference per seed pair and resample, computed only for the pairs drawn.
    let mut per_seed: Vec<Option<Option<f64>>> = vec![None; k];
    for r in 0..n_resamples as u64 {
        if k == 0 {
            break;
        }
        resampler.resample_into(r, &mut idx);
        gather(&idx, y, &mut ys);
        let mut seed_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5EED_5EED_5EED_5EED);
        seed_rng.set_stream(r);
        let drawn: Vec<usize> = if k == 1 {
            vec![0]
        } else {
            (0..k).map(|_| seed_rng.random_range(0..k)).collect()
        };
        per_seed.iter_mut().for_each(|d| *d = None);
        let mut sum = 0.0;
        let mut ok = true;
        for &s in &drawn {
            let d = *per_seed[s].get_or_insert_with(|| {
                gather(&idx, &a[s], &mut pa);
                gather(&idx, &b[s], &mut pb);
                match (valid(statistic(&ys, &pa)), valid(statistic(&ys, &pb))) {
                    (Some(x), Some(z)) => Some(x - z),
                    _ => None,
                }
            });
            match d {
                Some(d) => sum += d,
                None => ok = false,
            }
        }
        if ok {
            let d = sum / drawn.len() as f64;
            diffs.push(d);
            a_better += usize::from(d > 0.0);
            above += usize::from(d >= 0.0);
            below += usize::from(d <= 0.0);
        }
    }
    let n_valid = diffs.len();
    let (low, high) = percentile_interval(&mut diffs, level);
    let estimates: Vec<Option<f64>> = a
        .iter()
        .zip(b)
        .map(
            |(pa, pb)| match (valid(statistic(y, pa)), valid(statistic(y, pb))) {
                (Some(x), Some(z)) => Some(x - z),
                _ => None,
            },
        )
        .collect();
    let estimate = if k > 0 && estimates.iter().all(Option::is_some) {
        estimates.iter().flatten().sum::<f64>() / k as f64
    } else {
        f64::NAN
    };
    let share = |c: usize| c as f64 / n_valid as f64;
    Ok(SeedPairedInterval {
        interval: PairedInterval {
            estimate,
            low,
            high,
            level,
            n_valid,
            n_resamples,
            prob_a_better: if n_valid == 0 { f64::NAN } else { share(a_better) },
        },
        p_value: if n_valid == 0 {
            f64::NAN
        } else {
            (2.0 * share(above).min(share(below))).min(1.0)
        },
        seeds: k,
    })
}

/// Interquartile mean (Agarwal et al. 2021, rliable): the mean of the values left after
/// trimming ⌊0.25·n⌋ from each end of the sorted values — `scipy.stats.trim_mean(values,
/// 0.25)`. NaN when empty.
pub fn iqm(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let cut = (0.25 * sorted.len() as f64) as usize;
    let kept = &sorted[cut..sorted.len() - cut];
    if kept.is_empty() {
        f64::NAN
    } else {
        pairwise_sum(kept) / kept.len() as f64
    }
}

/// Stratified bootstrap (rliable's `StratifiedBootstrap`): each resample redraws, with
/// replacement, the same number of values within every group (a task's runs), and
/// `statistic` sees the resampled groups in order. Resample r uses stream r of
/// `ChaCha8Rng::seed_from_u64(seed)`. Undefined draws (`None`, NaN) are skipped.
pub fn stratified_bootstrap(
    groups: &[Vec<f64>],
    n_resamples: usize,
    seed: u64,
    level: f64,
    statistic: impl Fn(&[Vec<f64>]) -> Option<f64>,
) -> Result<Interval, EvalError> {
    check_level(level)?;
    let mut resampled: Vec<Vec<f64>> = groups.iter().map(|g| Vec::with_capacity(g.len())).collect();
    let mut draws = Vec::with_capacity(n_resamples);
    for r in 0..n_resamples as u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(r);
        for (group, out) in groups.iter().zip(resampled.iter_mut()) {
            out.clear();
            if !group.is_empty() {
                out.extend((0..group.len()).map(|_| group[rng.random_range(0..group.len())]));
            }
        }
        if let Some(v) = valid(statistic(&resampled)) {
            draws.push(v);
        }
    }
    let (low, high) = percentile_interval(&mut draws, level);
    Ok(Interval {
        estimate: statistic(groups).unwrap_or(f64::NAN),
        low,
        high,
        level,
        n_valid: draws.len(),
        n_resamples,
    })
}

/// Stratified-bootstrap interval of the IQM of all values pooled, groups = strata (the
/// usual rliable aggregate over runs × tasks).
pub fn iqm_interval(
    groups: &[Vec<f64>],
    n_resamples: usize,
    seed: u64,
    level: f64,
) -> Result<Interval, EvalError> {
    stratified_bootstrap(groups, n_resamples, seed, level, |g| {
        let pooled: Vec<f64> = g.iter().flatten().copied().collect();
        Some(iqm(&pooled))
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::metrics::roc_auc;

    fn data(n: usize) -> (Vec<bool>, Vec<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let y: Vec<bool> = (0..n).map(|_| rng.random::<f64>() < 0.3).collect();
        let p = y
            .iter()
            .map(|&l| (rng.random::<f64>() + if l { 0.4 } else { 0.0 }).min(1.0))
            .collect();
        (y, p)
    }

    #[test]
    fn seed_paired_intervals_carry_seeds_and_samples() {
        let (y, p) = data(300);
        let clusters: Vec<u64> = (0..300u64).map(|i| i / 3).collect();
        // One seed: the same resamples and interval as paired_diff_ci.
        let noisy: Vec<f64> = p
            .iter()
            .enumerate()
            .map(|(i, v)| v * (1.0 + 0.3 * ((i * 7 % 11) as f64 / 11.0)))
            .collect();
        let one = paired_diff_ci_seeds(
            &y,
            std::slice::from_ref(&p),
            std::slice::from_ref(&noisy),
            Some(&clusters),
            300,
            5,
            0.95,
            roc_auc,
        )
        .unwrap();
        let plain = paired_diff_ci(&y, &p, &noisy, Some(&clusters), 300, 5, 0.95, roc_auc).unwrap();
        assert_eq!(one.interval, plain);
        assert_eq!(one.seeds, 1);
        // A model the same as its rival on every seed: no difference, p = 1.
        let same = paired_diff_ci_seeds(
            &y,
            &[p.clone(), noisy.clone()],
            &[p.clone(), noisy.clone()],
            None,
            200,
            5,
            0.95,
            roc_auc,
        )
        .unwrap();
        assert_eq!(same.interval.estimate, 0.0);
        assert_eq!((same.interval.low, same.interval.high), (0.0, 0.0));
        assert_eq!(same.p_value, 1.0);
        // Better on every seed by a wide margin: the interval excludes 0 and p is tiny.
        let perfect: Vec<f64> = y.iter().map(|&l| if l { 0.9 } else { 0.1 }).collect();
        let better = paired_diff_ci_seeds(
            &y,
            &[perfect.clone(), perfect],
            &[p.clone(), noisy],
            Some(&clusters),
            200,
            5,
            0.95,
            roc_auc,
        )
        .unwrap();
        assert!(better.interval.low > 0.0, "{better:?}");
        assert!(better.p_value < 0.01, "{better:?}");
        assert_eq!(better.seeds, 2);
        // Mismatched seed counts name the argument.
        let err =
            paired_diff_ci_seeds(&y, std::slice::from_ref(&p), &[], None, 10, 5, 0.95, roc_auc).unwrap_err();
        assert!(err.to_string().contains("b (seeds)"), "{err}");
    }

    #[test]
    fn same_seed_same_interval_other_seed_other_interval() {
        let (y, p) = data(300);
        let a = ci(&y, &p, None, 200, 11, 0.95, roc_auc).unwrap();
        let b = ci(&y, &p, None, 200, 11, 0.95, roc_auc).unwrap();
        let c = ci(&y, &p, None, 200, 12, 0.95, roc_auc).unwrap();
        assert_eq!(a, b);
        assert_ne!(a.low, c.low);
        assert!(a.low < a.estimate && a.estimate < a.high);
        assert_eq!(a.n_valid, 200);
    }

    #[test]
    fn resample_r_does_not_depend_on_how_many_are_drawn() {
        let few = resample_indices(50, None, 3, 5);
        let many = resample_indices(50, None, 30, 5);
        assert_eq!(few[..], many[..3]);
    }

    #[test]
    fn clusters_move_together() {
        // 40 clusters of uneven size, ids scattered and interleaved in sample order.
        let ids: Vec<u64> = (0..200u64).map(|i| (i * 7919) % 40 * 1000 + 3).collect();
        let resampler = Resampler::new(ids.len(), Some(&ids), 99).unwrap();
        for r in 0..50 {
            let idx = resampler.resample(r);
            let mut count = vec![0usize; ids.len()];
            for &i in &idx {
                count[i] += 1;
            }
            // Every member of a cluster is drawn as often as the cluster.
            for i in 0..ids.len() {
                for j in 0..ids.len() {
                    if ids[i] == ids[j] {
                        assert_eq!(count[i], count[j], "resample {r}: {i} and {j} split");
                    }
                }
            }
            let drawn_clusters: usize = (0..ids.len())
                .filter(|&i| ids.iter().position(|&c| c == ids[i]) == Some(i))
                .map(|i| count[i])
                .sum();
            assert_eq!(drawn_clusters, 40);
        }
    }

    #[test]
    fn cluster_length_mismatch_is_an_error_naming_clusters() {
        let err = Resampler::new(3, Some(&[1, 2]), 0).unwrap_err();
        assert!(matches!(
            err,
            EvalError::LengthMismatch {
                argument: "clusters",
                ..
            }
        ));
        assert!(resample_indices(3, Some(&[1, 2]), 10, 0).is_empty());
        let (y, p) = data(10);
        assert!(matches!(
            ci(&y, &p[..9], None, 10, 0, 0.9, roc_auc),
            Err(EvalError::LengthMismatch { argument: "p", .. })
        ));
        assert!(matches!(
            ci(&y, &p, None, 10, 0, 1.0, roc_auc),
            Err(EvalError::InvalidArgument { .. })
        ));
    }

    #[test]
    fn undefined_resamples_are_skipped_and_counted() {
        // One positive among 20: many resamples miss it.
        let y: Vec<bool> = (0..20).map(|i| i == 0).collect();
        let p: Vec<f64> = (0..20).map(|i| f64::from(i) / 20.0).collect();
        let iv = ci(&y, &p, None, 500, 3, 0.95, roc_auc).unwrap();
        assert!(iv.n_valid < 500 && iv.n_valid > 0);
        assert_eq!(iv.n_resamples, 500);
    }

    #[test]
    fn report_intervals_share_resamples_with_ci() {
        let (y, p) = data(200);
        let clusters: Vec<u64> = (0..200).map(|i| i / 4).collect();
        let all = report_intervals(&y, &p, 0.5, 10, Some(&clusters), 100, 4, 0.9).unwrap();
        assert_eq!(all.len(), REPORT_METRICS.len());
        let auc = ci(&y, &p, Some(&clusters), 100, 4, 0.9, roc_auc).unwrap();
        assert_eq!(all["auroc"], auc);
        let acc = ci(&y, &p, Some(&clusters), 100, 4, 0.9, |y, p| {
            Some(crate::metrics::Confusion::at(y, p, 0.5).accuracy())
        })
        .unwrap();
        assert_eq!(all["accuracy"], acc);
    }

    #[test]
    fn paired_difference_of_a_model_with_itself_is_zero() {
        let (y, p) = data(150);
        let d = paired_diff_ci(&y, &p, &p, None, 100, 1, 0.95, roc_auc).unwrap();
        assert_eq!((d.estimate, d.low, d.high, d.prob_a_better), (0.0, 0.0, 0.0, 0.0));
        let worse: Vec<f64> = p.iter().map(|v| v * 0.5 + 0.25).rev().collect();
        let d = paired_diff_ci(&y, &p, &worse, None, 100, 1, 0.95, roc_auc).unwrap();
        assert!(d.low > 0.0 && d.prob_a_better == 1.0);
    }

    #[test]
    fn iqm_known_values() {
        let v: Vec<f64> = (1..=8).map(f64::from).collect();
        assert_eq!(iqm(&v), 4.5); // keeps 3, 4, 5, 6
        let v: Vec<f64> = (1..=10).rev().map(f64::from).collect();
        assert_eq!(iqm(&v), 5.5); // ⌊2.5⌋ = 2 cut each side: keeps 3..=8
        assert_eq!(iqm(&[1.0, 100.0, 2.0]), 103.0 / 3.0); // ⌊0.75⌋ = 0: plain mean
        assert_eq!(iqm(&[0.0, 0.0, 0.0, 100.0]), 0.0);
        assert!(iqm(&[]).is_nan());
    }

    #[test]
    fn stratified_bootstrap_keeps_group_sizes_and_is_deterministic() {
        let groups = vec![vec![1.0, 2.0, 3.0], vec![10.0, 20.0], vec![5.0; 4]];
        let sizes = |g: &[Vec<f64>]| {
            assert_eq!(g.iter().map(Vec::len).collect::<Vec<_>>(), [3, 2, 4]);
            assert!(g[0].iter().all(|v| *v <= 3.0) && g[1].iter().all(|v| *v >= 10.0));
            Some(g.iter().flatten().sum::<f64>())
        };
        let a = stratified_bootstrap(&groups, 200, 8, 0.95, sizes).unwrap();
        let b = stratified_bootstrap(&groups, 200, 8, 0.95, sizes).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.estimate, 56.0);
        let i = iqm_interval(&groups, 200, 8, 0.95).unwrap();
        assert!(i.low <= i.estimate && i.estimate <= i.high);
    }
}
