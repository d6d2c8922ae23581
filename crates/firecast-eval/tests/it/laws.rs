//! Laws the metrics obey whatever the data (proptest).

use firecast_eval::bootstrap::{Resampler, ci};
use firecast_eval::metrics::{Confusion, average_precision, brier, ece, log_loss, roc_auc};
use firecast_eval::tests::{delong, holm};
use proptest::prelude::*;

/// Labels with scores on a 1/64 grid, so ties are common.
fn labelled(max: usize) -> impl Strategy<Value = (Vec<bool>, Vec<f64>)> {
    prop::collection::vec((any::<bool>(), 0u8..=64), 1..max)
        .prop_map(|v| v.into_iter().map(|(l, k)| (l, f64::from(k) / 64.0)).unzip())
}

fn both_classes(y: &[bool]) -> bool {
    y.contains(&true) && y.contains(&false)
}

/// P(s⁺ > s⁻) + ½ P(s⁺ = s⁻) over all pairs: the Mann–Whitney reading of AUROC.
fn mann_whitney(y: &[bool], p: &[f64]) -> f64 {
    let pos: Vec<f64> = p.iter().zip(y).filter(|(_, l)| **l).map(|(&v, _)| v).collect();
    let neg: Vec<f64> = p.iter().zip(y).filter(|(_, l)| !**l).map(|(&v, _)| v).collect();
    let mut sum = 0.0;
    for &a in &pos {
        for &b in &neg {
            sum += if a > b {
                1.0
            } else if a == b {
                0.5
            } else {
                0.0
            };
        }
    }
    sum / (pos.len() * neg.len()) as f64
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn auroc_of_negated_scores_is_the_complement((y, p) in labelled(120)) {
        prop_assume!(both_classes(&y));
        let neg: Vec<f64> = p.iter().map(|v| -v).collect();
        let sum = roc_auc(&y, &p).unwrap() + roc_auc(&y, &neg).unwrap();
        prop_assert!((sum - 1.0).abs() < 1e-12, "sum {sum}");
    }

    #[test]
    fn auroc_is_the_mann_whitney_probability((y, p) in labelled(120)) {
        prop_assume!(both_classes(&y));
        let a = roc_auc(&y, &p).unwrap();
        let b = mann_whitney(&y, &p);
        prop_assert!((a - b).abs() < 1e-12, "{a} vs {b}");
    }

    #[test]
    fn ranking_metrics_ignore_strictly_increasing_transforms((y, p) in labelled(120)) {
        let f: Vec<f64> = p.iter().map(|&v| (3.0 * v).exp() + 2.0 * v - 7.0).collect();
        prop_assert_eq!(roc_auc(&y, &p), roc_auc(&y, &f));
        prop_assert_eq!(average_precision(&y, &p), average_precision(&y, &f));
    }

    #[test]
    fn average_precision_is_mean_precision_at_each_positive_without_ties(
        y in prop::collection::vec(any::<bool>(), 1..120),
        seed in any::<u64>(),
    ) {
        prop_assume!(y.contains(&true));
        // Distinct scores: a seeded permutation of 0..n.
        let n = y.len();
        let mut p: Vec<f64> = (0..n).map(|i| ((i as u64).wrapping_mul(seed | 1) % 1_000_003) as f64).collect();
        p.iter_mut().enumerate().for_each(|(i, v)| *v += i as f64 / n as f64);
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| p[b].total_cmp(&p[a]));
        let (mut tp, mut total) = (0.0, 0.0);
        for (k, &i) in order.iter().enumerate() {
            if y[i] {
                tp += 1.0;
                total += tp / (k + 1) as f64;
            }
        }
        let want = total / tp;
        let ap = average_precision(&y, &p).unwrap();
        prop_assert!((ap - want).abs() < 1e-12, "{ap} vs {want}");
        prop_assert!((0.0..=1.0).contains(&ap));
    }

    #[test]
    fn perfect_separation_scores_one((y, _) in labelled(80)) {
        prop_assume!(both_classes(&y));
        let p: Vec<f64> = y.iter().map(|&l| if l { 0.9 } else { 0.1 }).collect();
        prop_assert_eq!(roc_auc(&y, &p), Some(1.0));
        prop_assert_eq!(average_precision(&y, &p), Some(1.0));
    }

    #[test]
    fn confusion_identities((y, p) in labelled(150), t in 0u8..=64) {
        let t = f64::from(t) / 64.0;
        let c = Confusion::at(&y, &p, t);
        let n = y.len() as u64;
        prop_assert_eq!(c.n(), n);
        prop_assert_eq!(c.tp + c.fp, p.iter().filter(|&&v| v > t).count() as u64);
        prop_assert_eq!(c.accuracy(), (c.tp + c.tn) as f64 / n as f64);
        let (pr, re) = (c.precision(), c.recall());
        if pr > 0.0 && re > 0.0 {
            prop_assert!((c.f1() - 2.0 * pr * re / (pr + re)).abs() < 1e-12);
        }
        prop_assert!((-1.0..=1.0).contains(&c.mcc()));
        if both_classes(&y) {
            prop_assert!((c.balanced_accuracy() - (re + c.specificity()) / 2.0).abs() < 1e-15);
        }
    }

    #[test]
    fn probability_metrics_are_bounded((y, p) in labelled(150), bins in 1usize..20) {
        let b = brier(&y, &p);
        prop_assert!((0.0..=1.0).contains(&b));
        let e = ece(&y, &p, bins);
        prop_assert!((0.0..=1.0).contains(&e));
        prop_assert!(log_loss(&y, &p) >= 0.0);
        // ECE is at most the mean absolute error sample by sample.
        let mae = y.iter().zip(&p).map(|(&l, &q)| (f64::from(u8::from(l)) - q).abs()).sum::<f64>() / y.len() as f64;
        prop_assert!(e <= mae + 1e-12);
    }

    #[test]
    fn delong_auc_is_roc_auc_and_a_model_ties_itself((y, p) in labelled(120), (_, q) in labelled(120)) {
        let n = y.len().min(q.len());
        let (y, p, q) = (&y[..n], &p[..n], &q[..n]);
        let (pos, neg) = (y.iter().filter(|&&l| l).count(), y.iter().filter(|&&l| !l).count());
        prop_assume!(pos >= 2 && neg >= 2);
        let t = delong(y, p, q).unwrap();
        prop_assert!((t.auc_a - roc_auc(y, p).unwrap()).abs() < 1e-12);
        prop_assert!((t.auc_b - roc_auc(y, q).unwrap()).abs() < 1e-12);
        prop_assert!((0.0..=1.0).contains(&t.p_value));
        let same = delong(y, p, p).unwrap();
        prop_assert_eq!((same.diff, same.p_value), (0.0, 1.0));
    }

    #[test]
    fn holm_adjusts_upwards_monotonically(p in prop::collection::vec(0.0f64..=1.0, 0..30)) {
        let adj = holm(&p);
        prop_assert_eq!(adj.len(), p.len());
        for i in 0..p.len() {
            prop_assert!(adj[i] >= p[i] && adj[i] <= 1.0);
            for j in 0..p.len() {
                if p[i] < p[j] {
                    prop_assert!(adj[i] <= adj[j]);
                }
            }
        }
    }

    #[test]
    fn clustered_resamples_draw_whole_clusters(
        ids in prop::collection::vec(0u64..12, 1..80),
        seed in any::<u64>(),
    ) {
        let r = Resampler::new(ids.len(), Some(&ids), seed).unwrap();
        let distinct: std::collections::BTreeSet<u64> = ids.iter().copied().collect();
        for k in 0..5 {
            let idx = r.resample(k);
            prop_assert_eq!(&idx, &r.resample(k));
            let mut count = vec![0usize; ids.len()];
            idx.iter().for_each(|&i| count[i] += 1);
            let mut drawn = 0;
            for &c in &distinct {
                let members: Vec<usize> = (0..ids.len()).filter(|&i| ids[i] == c).collect();
                prop_assert!(members.iter().all(|&i| count[i] == count[members[0]]));
                drawn += count[members[0]];
            }
            prop_assert_eq!(drawn, distinct.len());
        }
    }

    #[test]
    fn intervals_are_reproducible_and_ordered((y, p) in labelled(60), seed in any::<u64>()) {
        let a = ci(&y, &p, None, 50, seed, 0.9, roc_auc).unwrap();
        let b = ci(&y, &p, None, 50, seed, 0.9, roc_auc).unwrap();
        // Debug text, so NaN (undefined everywhere) compares equal to itself.
        prop_assert_eq!(format!("{a:?}"), format!("{b:?}"));
        if a.n_valid > 0 {
            prop_assert!(a.low <= a.high);
        }
    }
}
