//! Threshold selection: the chosen threshold is optimal among all thresholds for the
//! strict rule `p > t`, ties go to the smallest, and the degenerate cases fall back.

use firecast_eval::EvalError;
use firecast_eval::metrics::{
    Confusion, FALLBACK_THRESHOLD, ThresholdRule, choose_threshold, evaluate, try_evaluate,
};
use proptest::prelude::*;

/// Every threshold that changes the predictions: each distinct score and one below all.
fn all_thresholds(p: &[f64]) -> Vec<f64> {
    let mut t: Vec<f64> = p.to_vec();
    t.push(p.iter().copied().fold(f64::INFINITY, f64::min) - 1.0);
    t
}

fn youden(c: &Confusion) -> f64 {
    c.recall() + c.specificity() - 1.0
}

#[test]
fn max_f1_on_a_small_example() {
    let y = [true, true, false, true, false, false];
    let p = [0.9, 0.8, 0.7, 0.6, 0.3, 0.1];
    // p > 0.7 → F1 0.8; p > 0.3 → tp 3, fp 1 → F1 6/7; p > 0.1 → tp 3, fp 2 → 0.75.
    assert_eq!(choose_threshold(&y, &p, ThresholdRule::MaxF1), 0.3);
    // Youden: p > 0.3 gives TPR 1, FPR 1/3 → J = 2/3, the best.
    assert_eq!(choose_threshold(&y, &p, ThresholdRule::Youden), 0.3);
    // Recall ≥ 0.6 is first reached (from the top) by predicting the two highest.
    assert_eq!(choose_threshold(&y, &p, ThresholdRule::TargetRecall(0.6)), 0.7);
    assert_eq!(choose_threshold(&y, &p, ThresholdRule::TargetRecall(1.0)), 0.3);
    assert_eq!(choose_threshold(&y, &p, ThresholdRule::Fixed(0.42)), 0.42);
}

#[test]
fn exact_half_is_negative_and_threshold_rules_respect_it() {
    // Scores exactly at the threshold are predicted negative (PyTorch `> 0.5`).
    let c = Confusion::at(&[true, false], &[0.5, 0.5], 0.5);
    assert_eq!((c.tp, c.fp, c.tn, c.fn_), (0, 0, 1, 1));
    // All scores tied: predicting everything positive needs a threshold below the tie.
    let y = [true, true, false];
    let t = choose_threshold(&y, &[0.5, 0.5, 0.5], ThresholdRule::MaxF1);
    assert!(t < 0.5);
    assert_eq!(Confusion::at(&y, &[0.5, 0.5, 0.5], t).tp, 2);
}

#[test]
fn ties_in_f1_go_to_the_smallest_threshold() {
    // p > 0.8 → tp 1, fp 0, F1 = 2/3; p > 0.2 → tp 2, fp 2: F1 = 4/6 = 2/3 as well.
    let y = [true, false, false, true, false];
    let p = [0.9, 0.8, 0.7, 0.6, 0.2];
    let t = choose_threshold(&y, &p, ThresholdRule::MaxF1);
    let f1 = |t: f64| Confusion::at(&y, &p, t).f1();
    assert_eq!(f1(0.8), f1(0.2));
    assert_eq!(t, 0.2);
}

#[test]
fn degenerate_inputs_fall_back() {
    let rules = [
        ThresholdRule::MaxF1,
        ThresholdRule::Youden,
        ThresholdRule::TargetRecall(0.9),
    ];
    for rule in rules {
        assert_eq!(choose_threshold(&[], &[], rule), FALLBACK_THRESHOLD);
        assert_eq!(
            choose_threshold(&[false, false], &[0.1, 0.2], rule),
            FALLBACK_THRESHOLD
        );
        assert_eq!(choose_threshold(&[true], &[0.1, 0.2], rule), FALLBACK_THRESHOLD);
        assert_eq!(
            choose_threshold(&[true, false], &[f64::NAN, 0.2], rule),
            FALLBACK_THRESHOLD
        );
    }
    assert_eq!(
        choose_threshold(&[true, true], &[0.1, 0.2], ThresholdRule::Youden),
        FALLBACK_THRESHOLD
    );
}

#[test]
fn evaluate_reports_length_mismatch_by_name() {
    let err = try_evaluate(&[true, false], &[0.1], 0.5, 10).unwrap_err();
    assert!(matches!(
        err,
        EvalError::LengthMismatch {
            argument: "p",
            expected: 2,
            found: 1,
            ..
        }
    ));
    assert!(err.to_string().contains("`p` has 1 entries but `y` has 2"));
    let r = evaluate(&[true, false], &[0.1], 0.5, 10);
    assert_eq!(r.n, 0);
    assert!(r.auroc.is_none() && r.accuracy.is_nan());
}

#[test]
fn report_fields_and_json() {
    let y = [true, false, true, false, false];
    let p = [0.8, 0.3, 0.6, 0.55, 0.1];
    let r = evaluate(&y, &p, 0.5, 10);
    assert_eq!((r.n, r.positives), (5, 2));
    assert_eq!(r.prevalence, 0.4);
    assert_eq!(
        r.confusion,
        Confusion {
            tp: 2,
            fp: 1,
            tn: 2,
            fn_: 0
        }
    );
    assert_eq!(r.auroc, Some(1.0));
    // Brier skill against always predicting 0.4: 1 − Brier / 0.24.
    assert!((r.brier_skill - (1.0 - r.brier / 0.24)).abs() < 1e-15);
    let json = serde_json::to_value(&r).unwrap();
    assert_eq!(json["confusion"]["fn"], 0);
    assert_eq!(json["auroc"], 1.0);
    let back: firecast_eval::metrics::BinaryReport = serde_json::from_value(json).unwrap();
    assert_eq!(back, r);
    // Logits: the probability metrics are NaN, written as null and read back as NaN.
    let logits = evaluate(&y, &[2.0, -1.0, 0.5, 0.1, -3.0], 0.0, 10);
    assert!(logits.brier.is_nan() && logits.ece.is_nan() && logits.log_loss.is_nan());
    assert_eq!(logits.auroc, Some(1.0));
    let text = serde_json::to_string(&logits).unwrap();
    assert!(text.contains("\"brier\":null"));
    let back: firecast_eval::metrics::BinaryReport = serde_json::from_str(&text).unwrap();
    assert!(back.brier.is_nan() && back.auroc == Some(1.0) && back.confusion == logits.confusion);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn chosen_thresholds_are_optimal(v in prop::collection::vec((any::<bool>(), 0u8..=20), 1..60)) {
        let (y, p): (Vec<bool>, Vec<f64>) = v.into_iter().map(|(l, k)| (l, f64::from(k) / 20.0)).unzip();
        let pos = y.iter().filter(|&&l| l).count();
        let candidates = all_thresholds(&p);
        if pos > 0 {
            let t = choose_threshold(&y, &p, ThresholdRule::MaxF1);
            let best = Confusion::at(&y, &p, t).f1();
            for &c in &candidates {
                let f = Confusion::at(&y, &p, c).f1();
                prop_assert!(f <= best + 1e-15, "F1 {f} at {c} beats {best} at {t}");
                // Ties go to the smallest threshold.
                if (f - best).abs() < 1e-15 && Confusion::at(&y, &p, c) != Confusion::at(&y, &p, t) {
                    prop_assert!(c > t, "tie at {c} below chosen {t}");
                }
            }
            let r = 0.7;
            let t = choose_threshold(&y, &p, ThresholdRule::TargetRecall(r));
            prop_assert!(Confusion::at(&y, &p, t).recall() >= r);
            for &c in candidates.iter().filter(|&&c| c > t) {
                prop_assert!(Confusion::at(&y, &p, c).recall() < r);
            }
        }
        if pos > 0 && pos < y.len() {
            let t = choose_threshold(&y, &p, ThresholdRule::Youden);
            let best = youden(&Confusion::at(&y, &p, t));
            for &c in &candidates {
                prop_assert!(youden(&Confusion::at(&y, &p, c)) <= best + 1e-12);
            }
        }
    }
}
