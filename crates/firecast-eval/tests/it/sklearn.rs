//! firecast-eval against scikit-learn 1.9.1, SciPy and NumPy on the cases of `cases.rs`:
//! agreement within 1e-12 (1e-9 for log loss, whose `log` may differ by an ulp from
//! NumPy's), and a tally of how many values are bit-identical.

use firecast_eval::bootstrap::{iqm, quantile};
use firecast_eval::metrics::{
    BinStrategy, Confusion, average_precision, brier, calibration_curve, ece, evaluate, log_loss,
    precision_recall_curve, roc_auc, roc_curve,
};
use firecast_eval::special::{binomial_two_sided_half, chi2_sf_1df, erfc};
use firecast_eval::tests::{delong, mcnemar};
use serde_json::Value;

use crate::reference::{Mismatches, close, close_rel, get, num, nums, raised};

const TOL: f64 = 1e-12;
const LOG_LOSS_TOL: f64 = 1e-9;

/// Each case with sklearn's answers for it.
fn cases() -> impl Iterator<Item = (&'static crate::cases::Case, &'static Value)> {
    let r = get();
    let outs = r.out["cases"].as_array().unwrap();
    assert_eq!(outs.len(), r.cases.len());
    r.cases.iter().zip(outs)
}

fn vec_close(m: &mut Mismatches, name: &str, what: &str, ours: &[f64], theirs: &[f64], tol: f64) {
    m.check(ours.len() == theirs.len(), || {
        format!(
            "{name}: {what} has {} values, sklearn {}",
            ours.len(),
            theirs.len()
        )
    });
    for (i, (&a, &b)) in ours.iter().zip(theirs).enumerate() {
        m.check(close(a, b, tol), || {
            format!("{name}: {what}[{i}] = {a:e}, sklearn {b:e}")
        });
    }
}

#[test]
fn reference_is_scikit_learn_1_9_1() {
    let v = &get().out["versions"];
    assert_eq!(
        v["sklearn"], "1.9.1",
        "firecast-eval matches scikit-learn 1.9.1; the venv has {v}"
    );
}

#[test]
fn roc_auc_matches_roc_auc_score() {
    let mut m = Mismatches::default();
    let (mut identical, mut total) = (0, 0);
    for (c, out) in cases() {
        let theirs = num(&out["roc_auc"]);
        let ours = roc_auc(&c.y, &c.p);
        match ours {
            None => m.check(theirs.is_nan(), || format!("{}: None, sklearn {theirs}", c.name)),
            Some(a) => {
                total += 1;
                identical += usize::from(a == theirs);
                m.check(close(a, theirs, TOL), || {
                    format!("{}: {a:e}, sklearn {theirs:e}", c.name)
                });
            }
        }
    }
    eprintln!("roc_auc: {identical} of {total} bit-identical");
    m.assert_none("roc_auc");
}

#[test]
fn average_precision_matches_average_precision_score() {
    let mut m = Mismatches::default();
    let (mut identical, mut total) = (0, 0);
    for (c, out) in cases() {
        let theirs = num(&out["average_precision"]);
        match average_precision(&c.y, &c.p) {
            // Documented difference: sklearn returns 0.0 (with a warning) without positives.
            None => m.check(!c.y.contains(&true) && theirs == 0.0, || {
                format!("{}: None, sklearn {theirs}", c.name)
            }),
            Some(a) => {
                total += 1;
                identical += usize::from(a == theirs);
                m.check(close(a, theirs, TOL), || {
                    format!("{}: {a:e}, sklearn {theirs:e}", c.name)
                });
            }
        }
    }
    eprintln!("average_precision: {identical} of {total} bit-identical");
    m.assert_none("average_precision");
}

#[test]
fn roc_curve_matches_roc_curve() {
    let mut m = Mismatches::default();
    for (c, out) in cases() {
        let r = &out["roc_curve"];
        assert!(!raised(r), "{}: sklearn raised {r}", c.name);
        let pts = roc_curve(&c.y, &c.p).unwrap();
        vec_close(
            &mut m,
            &c.name,
            "fpr",
            &pts.iter().map(|p| p.fpr).collect::<Vec<_>>(),
            &nums(&r["fpr"]),
            TOL,
        );
        vec_close(
            &mut m,
            &c.name,
            "tpr",
            &pts.iter().map(|p| p.tpr).collect::<Vec<_>>(),
            &nums(&r["tpr"]),
            TOL,
        );
        vec_close(
            &mut m,
            &c.name,
            "threshold",
            &pts.iter().map(|p| p.threshold).collect::<Vec<_>>(),
            &nums(&r["thresholds"]),
            0.0,
        );
    }
    m.assert_none("roc_curve");
}

#[test]
fn precision_recall_curve_matches_precision_recall_curve() {
    let mut m = Mismatches::default();
    for (c, out) in cases() {
        let r = &out["pr_curve"];
        assert!(!raised(r), "{}: sklearn raised {r}", c.name);
        let pts = precision_recall_curve(&c.y, &c.p).unwrap();
        vec_close(
            &mut m,
            &c.name,
            "precision",
            &pts.iter().map(|p| p.precision).collect::<Vec<_>>(),
            &nums(&r["precision"]),
            TOL,
        );
        vec_close(
            &mut m,
            &c.name,
            "recall",
            &pts.iter().map(|p| p.recall).collect::<Vec<_>>(),
            &nums(&r["recall"]),
            TOL,
        );
        let (last, rest) = pts.split_last().unwrap();
        m.check(
            last.threshold.is_none() && rest.iter().all(|p| p.threshold.is_some()),
            || format!("{}: only the last point may lack a threshold", c.name),
        );
        let thr: Vec<f64> = rest.iter().filter_map(|p| p.threshold).collect();
        vec_close(&mut m, &c.name, "threshold", &thr, &nums(&r["thresholds"]), 0.0);
    }
    m.assert_none("precision_recall_curve");
}

#[test]
fn threshold_metrics_match_sklearn_with_strict_threshold() {
    let mut m = Mismatches::default();
    for (c, out) in cases() {
        let r = &out["at_threshold"];
        assert!(!raised(r), "{}: sklearn raised {r}", c.name);
        let k = Confusion::at(&c.y, &c.p, c.threshold);
        let counts = (k.tn, k.fp, k.fn_, k.tp);
        let theirs = (
            r["tn"].as_u64().unwrap(),
            r["fp"].as_u64().unwrap(),
            r["fn"].as_u64().unwrap(),
            r["tp"].as_u64().unwrap(),
        );
        m.check(counts == theirs, || {
            format!("{}: (tn, fp, fn, tp) {counts:?}, sklearn {theirs:?}", c.name)
        });
        let report = evaluate(&c.y, &c.p, c.threshold, 10);
        for (name, ours, from_report) in [
            ("accuracy", k.accuracy(), report.accuracy),
            ("precision", k.precision(), report.precision),
            ("recall", k.recall(), report.recall),
            ("f1", k.f1(), report.f1),
            (
                "balanced_accuracy",
                k.balanced_accuracy(),
                report.balanced_accuracy,
            ),
            ("mcc", k.mcc(), report.mcc),
        ] {
            let theirs = num(&r[name]);
            m.check(ours == theirs || close(ours, theirs, TOL), || {
                format!("{}: {name} {ours:e}, sklearn {theirs:e}", c.name)
            });
            m.check(ours.to_bits() == from_report.to_bits(), || {
                format!("{}: report.{name} differs", c.name)
            });
        }
        m.check(report.auroc == roc_auc(&c.y, &c.p), || {
            format!("{}: report.auroc", c.name)
        });
        m.check(report.auprc == average_precision(&c.y, &c.p), || {
            format!("{}: report.auprc", c.name)
        });
    }
    m.assert_none("threshold metric");
}

#[test]
fn brier_and_log_loss_match_sklearn() {
    let mut m = Mismatches::default();
    let (mut identical, mut total) = (0, 0);
    for (c, out) in cases().filter(|(c, _)| c.probabilities) {
        let b = num(&out["brier"]);
        let ours = brier(&c.y, &c.p);
        total += 1;
        identical += usize::from(ours == b);
        m.check(close(ours, b, TOL), || {
            format!("{}: brier {ours:e}, sklearn {b:e}", c.name)
        });
        let l = num(&out["log_loss"]);
        let ours = log_loss(&c.y, &c.p);
        m.check(close(ours, l, LOG_LOSS_TOL), || {
            format!("{}: log_loss {ours:e}, sklearn {l:e}", c.name)
        });
        let report = evaluate(&c.y, &c.p, c.threshold, 10);
        m.check(report.brier.to_bits() == brier(&c.y, &c.p).to_bits(), || {
            format!("{}: report.brier", c.name)
        });
        m.check(
            report.log_loss.to_bits() == log_loss(&c.y, &c.p).to_bits(),
            || format!("{}: report.log_loss", c.name),
        );
    }
    eprintln!("brier: {identical} of {total} bit-identical");
    m.assert_none("brier/log_loss");
}

#[test]
fn calibration_curve_and_ece_match_sklearn() {
    let mut m = Mismatches::default();
    let mut checked = 0;
    for (c, out) in cases().filter(|(c, _)| c.probabilities) {
        for r in out["calibration"].as_array().unwrap() {
            assert!(!raised(r), "{}: sklearn raised {r}", c.name);
            let n_bins = r["n_bins"].as_u64().unwrap() as usize;
            let strategy = match r["strategy"].as_str().unwrap() {
                "uniform" => BinStrategy::Uniform,
                _ => BinStrategy::Quantile,
            };
            let what = format!("{} ({n_bins} bins, {strategy:?})", c.name);
            let curve = calibration_curve(&c.y, &c.p, n_bins, strategy).unwrap();
            vec_close(
                &mut m,
                &what,
                "prob_true",
                &curve.prob_true,
                &nums(&r["prob_true"]),
                TOL,
            );
            vec_close(
                &mut m,
                &what,
                "prob_pred",
                &curve.prob_pred,
                &nums(&r["prob_pred"]),
                TOL,
            );
            let counts: Vec<u64> = r["counts"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_u64().unwrap())
                .collect();
            m.check(curve.counts == counts, || {
                format!("{what}: counts {:?}, sklearn {counts:?}", curve.counts)
            });
            if strategy == BinStrategy::Uniform {
                let theirs = num(&r["ece"]);
                let ours = ece(&c.y, &c.p, n_bins);
                m.check(close(ours, theirs, TOL), || {
                    format!("{what}: ece {ours:e}, reference {theirs:e}")
                });
            }
            checked += 1;
        }
    }
    assert!(checked > 100);
    m.assert_none("calibration");
}

#[test]
fn mcnemar_matches_scipy() {
    let mut m = Mismatches::default();
    let mut regimes = (0, 0);
    for (c, out) in cases() {
        let r = &out["mcnemar"];
        let pred_a: Vec<bool> = c.p.iter().map(|&v| v > c.threshold).collect();
        let pred_b: Vec<bool> = c.p_b.iter().map(|&v| v > c.threshold_b).collect();
        let t = mcnemar(&c.y, &pred_a, &pred_b).unwrap();
        let want = (
            r["b"].as_u64().unwrap(),
            r["c"].as_u64().unwrap(),
            r["exact"].as_bool().unwrap(),
        );
        m.check((t.b, t.c, t.exact) == want, || {
            format!(
                "{}: (b, c, exact) {:?}, scipy {want:?}",
                c.name,
                (t.b, t.c, t.exact)
            )
        });
        let (s, p) = (num(&r["statistic"]), num(&r["p_value"]));
        m.check(close_rel(t.statistic, s, TOL), || {
            format!("{}: statistic {:e}, reference {s:e}", c.name, t.statistic)
        });
        m.check(close_rel(t.p_value, p, TOL), || {
            format!("{}: p {:e}, scipy {p:e}", c.name, t.p_value)
        });
        if t.exact {
            regimes.0 += 1
        } else {
            regimes.1 += 1
        }
        if c.name.starts_with("mcnemar-") {
            let exact = c.name == "mcnemar-24";
            m.check(
                t.exact == exact && t.b + t.c == if exact { 24 } else { 25 },
                || format!("{}: {t:?}", c.name),
            );
        }
    }
    assert!(
        regimes.0 > 10 && regimes.1 > 10,
        "both regimes exercised: {regimes:?}"
    );
    m.assert_none("mcnemar");
}

#[test]
fn delong_matches_quadratic_structural_components() {
    let mut m = Mismatches::default();
    let mut checked = 0;
    for (c, out) in cases() {
        let Some(r) = out.get("delong") else { continue };
        let t = delong(&c.y, &c.p, &c.p_b).unwrap();
        m.check(close(t.auc_a, num(&r["auc_a"]), TOL), || {
            format!("{}: auc_a {} vs {}", c.name, t.auc_a, r["auc_a"])
        });
        m.check(close(t.auc_b, num(&r["auc_b"]), TOL), || {
            format!("{}: auc_b {} vs {}", c.name, t.auc_b, r["auc_b"])
        });
        let sk = num(&out["roc_auc"]);
        m.check(close(t.auc_a, sk, TOL), || {
            format!("{}: DeLong AUC {} vs roc_auc_score {sk}", c.name, t.auc_a)
        });
        let se = num(&r["se"]);
        m.check(close_rel(t.se, se, 1e-9) || (se < 1e-15 && t.se < 1e-15), || {
            format!("{}: se {:e} vs {se:e}", c.name, t.se)
        });
        if let Some(z) = r.get("z") {
            let (z, p) = (num(z), num(&r["p_value"]));
            m.check(close_rel(t.z, z, 1e-9), || {
                format!("{}: z {:e} vs {z:e}", c.name, t.z)
            });
            m.check(close(t.p_value, p, TOL) || close_rel(t.p_value, p, 1e-9), || {
                format!("{}: p {:e} vs {p:e}", c.name, t.p_value)
            });
        }
        checked += 1;
    }
    assert!(checked > 40, "{checked} DeLong cases");
    m.assert_none("delong");
}

#[test]
fn erfc_and_tails_match_scipy() {
    let r = get();
    let mut m = Mismatches::default();
    let mut worst: f64 = 0.0;
    for (&x, theirs) in r.erfc_points.iter().zip(nums(&r.out["erfc"])) {
        let ours = erfc(x);
        worst = worst.max(((ours - theirs) / theirs).abs());
        m.check(close_rel(ours, theirs, TOL), || {
            format!("erfc({x}) = {ours:e}, scipy {theirs:e}")
        });
    }
    eprintln!("erfc: worst relative difference from scipy {worst:e}");
    for (&x, theirs) in r.chi2_points.iter().zip(nums(&r.out["chi2_1df"])) {
        let ours = chi2_sf_1df(x);
        m.check(close_rel(ours, theirs, TOL), || {
            format!("chi2.sf({x}, 1) = {ours:e}, scipy {theirs:e}")
        });
    }
    for (&(k, n), theirs) in r.binomtest.iter().zip(nums(&r.out["binomtest"])) {
        let ours = binomial_two_sided_half(k, n).unwrap();
        m.check(close_rel(ours, theirs, TOL), || {
            format!("binomtest({k}, {n}) = {ours:e}, scipy {theirs:e}")
        });
    }
    m.assert_none("special function");
}

#[test]
fn iqm_and_quantile_match_scipy_and_numpy() {
    let r = get();
    let mut m = Mismatches::default();
    for (v, theirs) in r.trim_mean.iter().zip(nums(&r.out["trim_mean"])) {
        let ours = iqm(v);
        m.check(close(ours, theirs, TOL), || {
            format!("iqm({v:?}) = {ours}, trim_mean {theirs}")
        });
    }
    for ((values, qs), theirs) in r.quantile.iter().zip(r.out["quantile"].as_array().unwrap()) {
        for (&q, t) in qs.iter().zip(nums(theirs)) {
            let ours = quantile(&mut values.clone(), q);
            m.check(ours == t, || format!("quantile(q = {q}) = {ours:e}, numpy {t:e}"));
        }
    }
    m.assert_none("iqm/quantile");
}
