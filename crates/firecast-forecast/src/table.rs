//! Table III and its companions: Markdown, CSV and JSON, DVC's `metrics.json`, and the plot
//! data DVCLive writes, so `dvc metrics show` and `dvc plots show` work on FireCast runs.

use std::fmt::Write as _;
use std::path::Path;

use crate::ForecastError;
use crate::experiment::{ExperimentResult, ModelResult, ProtocolInfo};

/// A threshold for display: the "everything is a fire" threshold sits one ulp below the
/// lowest score (e.g. −5e-324), which would print as −0.000.
pub fn shown_threshold(t: f64) -> f64 {
    if t.abs() < 5e-4 { 0.0 } else { t }
}

fn fmt_ci(v: f64, ci: Option<&(f64, f64)>, pct: bool) -> String {
    let s = if pct { 100.0 } else { 1.0 };
    let digits = if pct { 1 } else { 3 };
    match ci {
        Some((lo, hi)) if v.is_finite() => format!(
            "{:.*} [{:.*}, {:.*}]",
            digits,
            v * s,
            digits,
            lo * s,
            digits,
            hi * s
        ),
        _ if v.is_finite() => format!("{:.*}", digits, v * s),
        _ => "—".into(),
    }
}

/// Rows of one protocol, best AUROC first (as the paper sorts by accuracy, we sort by the
/// threshold-free metric).
pub fn rows<'a>(result: &'a ExperimentResult, protocol: &str) -> Vec<&'a ModelResult> {
    let mut rows: Vec<&ModelResult> = result.results.iter().filter(|r| r.protocol == protocol).collect();
    let key = |r: &ModelResult| {
        r.test
            .get("auroc")
            .copied()
            .filter(|v| v.is_finite())
            .unwrap_or(f64::NEG_INFINITY)
    };
    rows.sort_by(|a, b| key(b).total_cmp(&key(a)).then_with(|| a.model.cmp(&b.model)));
    rows
}

fn protocol_header(p: &ProtocolInfo, result: &ExperimentResult) -> String {
    format!(
        "Protocol `{}`{}: inputs days {}..{} relative to the predicted date{}; split: {}; train {} / val {} / test {} \
         ({} positive, prevalence {:.3}){}. No-skill: majority-class accuracy {:.1} %, AUPRC {:.3} (the prevalence), AUROC 0.5. \
         Intervals: {:.0} % percentile bootstrap, {} resamples of test {}s; neural and random models averaged over seeds. \
         Threshold chosen on validation only (per row: see `threshold`). Dataset `{}` {}.",
        p.name,
        if p.name == result.headline {
            " (headline)"
        } else {
            ""
        },
        p.days.0,
        p.days.1,
        if p.leaks_future {
            " — the inputs include days after the predicted date, as in the paper"
        } else {
            " — inputs end before the predicted date"
        },
        p.split,
        p.train,
        p.val,
        p.test,
        p.test_positives,
        p.prevalence,
        if p.dropped > 0 {
            format!(
                "; {} samples dropped to keep test windows out of training",
                p.dropped
            )
        } else {
            String::new()
        },
        p.majority_accuracy * 100.0,
        p.prevalence,
        result.level * 100.0,
        result.bootstrap,
        result.cluster,
        result.dataset,
        result.dataset_version,
    )
}

/// Table III in the paper's layout (accuracy in %, precision, recall, F1), extended with
/// the threshold-free and probability metrics, for every protocol, headline first.
pub fn markdown(result: &ExperimentResult) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "# Table III — {}\n", result.name);
    let mut protocols: Vec<&ProtocolInfo> = result.protocols.iter().collect();
    protocols.sort_by_key(|p| (p.name != result.headline, p.name.clone()));
    for p in protocols {
        let _ = writeln!(out, "## {}\n\n{}\n", p.name, protocol_header(p, result));
        if let Some(o) = &p.oracle {
            let _ = writeln!(
                out,
                "Oracle (the synthetic generator's true ignition probabilities, never a model input): AUROC {:.3}, AUPRC {:.3}. \
                 Each model's skill above no skill as a share of the oracle's is in results.json (`skill_vs_oracle`).\n",
                o.get("auroc").copied().unwrap_or(f64::NAN),
                o.get("auprc").copied().unwrap_or(f64::NAN)
            );
        }
        let _ = writeln!(
            out,
            "| Model | Family | Accuracy [%] | Precision | Recall | F1 | AUROC | AUPRC | Brier | ECE | Threshold | Seeds |"
        );
        let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|---|---|");
        for r in rows(result, &p.name) {
            let m = |k: &str| r.test.get(k).copied().unwrap_or(f64::NAN);
            let ci = |k: &str| r.intervals.get(k);
            let thr = r.runs.first().map_or(String::new(), |s| {
                if r.runs.len() > 1 {
                    format!("{:.3}… ({})", shown_threshold(s.threshold), s.threshold_rule)
                } else {
                    format!("{:.3} ({})", shown_threshold(s.threshold), s.threshold_rule)
                }
            });
            let _ = writeln!(
                out,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                r.model,
                r.family,
                fmt_ci(m("accuracy"), ci("accuracy"), true),
                fmt_ci(m("precision"), ci("precision"), false),
                fmt_ci(m("recall"), ci("recall"), false),
                fmt_ci(m("f1"), ci("f1"), false),
                fmt_ci(m("auroc"), ci("auroc"), false),
                fmt_ci(m("auprc"), ci("auprc"), false),
                fmt_ci(m("brier"), ci("brier"), false),
                fmt_ci(m("ece"), ci("ece"), false),
                thr,
                r.seeds.len()
            );
        }
        let _ = writeln!(out);
        // Confusion matrices of the first seed, orientation spelled out.
        let _ = writeln!(
            out,
            "Confusion matrices (first seed, test): rows = actual, columns = predicted; `TN FP / FN TP`.\n"
        );
        for r in rows(result, &p.name) {
            if let Some(s) = r.runs.first() {
                let c = &s.report.confusion;
                let _ = writeln!(
                    out,
                    "- {}: actual no-fire → predicted no-fire {} / fire {}; actual fire → predicted no-fire {} / fire {}",
                    r.model, c.tn, c.fp, c.fn_, c.tp
                );
            }
        }
        let _ = writeln!(out);
        for t in result.paired.iter().filter(|t| t.protocol == p.name) {
            let _ = writeln!(
                out,
                "Paired test on the same test samples, best model `{}` vs best baseline `{}`: McNemar b = {}, c = {}, p = {:.2e} ({}); \
                 DeLong ΔAUROC = {:+.3}, p = {:.2e}; ΔAUPRC = {:+.3} [{:+.3}, {:+.3}], P(model better) = {:.2}.\n",
                t.model,
                t.baseline,
                t.mcnemar_b,
                t.mcnemar_c,
                t.mcnemar_p,
                if t.mcnemar_exact {
                    "exact binomial"
                } else {
                    "χ² with continuity correction"
                },
                t.delong_auroc_diff,
                t.delong_p,
                t.auprc_diff,
                t.auprc_diff_interval.0,
                t.auprc_diff_interval.1,
                t.prob_model_better_auprc
            );
        }
        comparisons_table(&mut out, result, &p.name);
        // Breakdowns.
        let _ = writeln!(out, "By year (first seed; AUROC, n):\n");
        for r in rows(result, &p.name) {
            let parts: Vec<String> = r
                .by_year
                .iter()
                .map(|(y, m)| {
                    format!(
                        "{y}: {} (n {})",
                        m.get("auroc").map_or("—".into(), |v| format!("{v:.3}")),
                        m.get("n").copied().unwrap_or(0.0)
                    )
                })
                .collect();
            let _ = writeln!(out, "- {}: {}", r.model, parts.join("; "));
        }
        let _ = writeln!(
            out,
            "\nBy negative tier (first seed; accuracy on the tier, AUROC of all positives against it):\n"
        );
        for r in rows(result, &p.name) {
            let parts: Vec<String> = r
                .by_tier
                .iter()
                .map(|(t, m)| {
                    format!(
                        "{t}: acc {:.3}{}",
                        m.get("accuracy").copied().unwrap_or(f64::NAN),
                        m.get("auroc_vs_positives")
                            .map_or(String::new(), |a| format!(", AUROC {a:.3}"))
                    )
                })
                .collect();
            let _ = writeln!(out, "- {}: {}", r.model, parts.join("; "));
        }
        let _ = writeln!(out);
    }
    out
}

/// One CSV row per protocol × model with every metric and interval.
pub fn csv(result: &ExperimentResult) -> String {
    let metrics = crate::experiment::TABLE_METRICS;
    let mut out = String::from("protocol,model,kind,family,seeds,threshold,threshold_rule");
    for m in metrics {
        let _ = write!(out, ",{m},{m}_low,{m}_high,{m}_seed_std");
    }
    out.push_str(",parameters\n");
    for p in &result.protocols {
        for r in rows(result, &p.name) {
            let first = r.runs.first();
            let _ = write!(
                out,
                "{},{},{},{},{},{},\"{}\"",
                r.protocol,
                r.model,
                r.kind,
                r.family,
                r.seeds.len(),
                first.map_or(f64::NAN, |s| s.threshold),
                first.map_or(String::new(), |s| s.threshold_rule.clone())
            );
            for m in metrics {
                let v = r.test.get(m).copied().unwrap_or(f64::NAN);
                let (lo, hi) = r.intervals.get(m).copied().unwrap_or((f64::NAN, f64::NAN));
                let sd = r.seed_std.get(m).copied().unwrap_or(f64::NAN);
                let _ = write!(out, ",{v},{lo},{hi},{sd}");
            }
            let _ = writeln!(out, ",{}", r.parameters.map_or(String::new(), |p| p.to_string()));
        }
    }
    out
}

/// DVC `metrics.json`: `{protocol: {model: {metric: value}}}`.
pub fn dvc_metrics(result: &ExperimentResult) -> serde_json::Value {
    let mut root = serde_json::Map::new();
    for p in &result.protocols {
        let mut models = serde_json::Map::new();
        for r in rows(result, &p.name) {
            let mut m = serde_json::Map::new();
            for (k, v) in &r.test {
                if v.is_finite() {
                    m.insert(k.clone(), serde_json::json!(v));
                }
            }
            models.insert(r.model.clone(), serde_json::Value::Object(m));
        }
        root.insert(p.name.clone(), serde_json::Value::Object(models));
    }
    serde_json::Value::Object(root)
}

/// Writes results.json, table3.md, table3.csv and metrics.json into `out`.
pub fn write_all(out: &Path, result: &ExperimentResult) -> Result<(), ForecastError> {
    std::fs::create_dir_all(out).map_err(ForecastError::io("creating", out))?;
    let write = |name: &str, bytes: &[u8]| -> Result<(), ForecastError> {
        let path = out.join(name);
        firecast_fs::write_atomically(&path, bytes).map_err(|e| ForecastError::Data {
            path: path.clone(),
            message: e.to_string(),
        })
    };
    let json = serde_json::to_vec_pretty(result).map_err(|e| ForecastError::Model(e.to_string()))?;
    write("results.json", &json)?;
    write("table3.md", markdown(result).as_bytes())?;
    write("table3.csv", csv(result).as_bytes())?;
    let metrics =
        serde_json::to_vec_pretty(&dvc_metrics(result)).map_err(|e| ForecastError::Model(e.to_string()))?;
    write("metrics.json", &metrics)?;
    Ok(())
}

/// The protocol's paired comparisons over all seeds (FireCast's forecaster against every
/// model, the best model against the best baseline), with a sentence that answers the question.
fn comparisons_table(out: &mut String, result: &ExperimentResult, protocol: &str) {
    let here: Vec<&crate::experiment::Comparison> = result
        .comparisons
        .iter()
        .filter(|c| c.protocol == protocol)
        .collect();
    let Some(first) = here.first() else {
        return;
    };
    let _ = writeln!(
        out,
        "Paired comparisons over all {} seeds (test samples resampled by GRIDMET cell and seed pairs with \
         replacement, {} resamples; two-sided bootstrap p of the AUROC difference, Holm-adjusted over the {} \
         comparisons of this protocol; DeLong's p on each seed; a verdict needs the interval on one side of 0 and \
         Holm p < {}):\n",
        first.seeds,
        result.bootstrap,
        here.len(),
        crate::experiment::COMPARISON_ALPHA
    );
    let _ = writeln!(
        out,
        "| model | against | ΔAUROC | {:.0} % interval | ΔAUPRC | {:.0} % interval | p | p (Holm) | DeLong p per seed | verdict |",
        result.level * 100.0,
        result.level * 100.0
    );
    let _ = writeln!(out, "|---|---|---:|---|---:|---|---:|---:|---|---|");
    // A bootstrap p of 0 means no resample crossed 0: below one in the resamples drawn.
    let floor = 1.0 / result.bootstrap.max(1) as f64;
    let p_text = |p: f64, floor: f64| {
        if !p.is_finite() {
            "—".to_string()
        } else if p == 0.0 {
            format!("< {floor:.1e}")
        } else {
            format!("{p:.2e}")
        }
    };
    for c in &here {
        let best = if c.questions.iter().any(|q| q == "best_vs_best_baseline") {
            " (best vs best baseline)"
        } else {
            ""
        };
        let _ = writeln!(
            out,
            "| {}{best} | {} | {:+.3} | [{:+.3}, {:+.3}] | {:+.3} | [{:+.3}, {:+.3}] | {} | {} | {} | {} |",
            c.model,
            c.other,
            c.auroc_diff,
            c.auroc_diff_interval.0,
            c.auroc_diff_interval.1,
            c.auprc_diff,
            c.auprc_diff_interval.0,
            c.auprc_diff_interval.1,
            p_text(c.p_value, floor),
            // Holm multiplies by at most the number of comparisons.
            p_text(c.p_holm, (floor * here.len() as f64).min(1.0)),
            c.delong_p
                .iter()
                .map(|p| p.map_or_else(|| "—".to_string(), |p| format!("{p:.2e}")))
                .collect::<Vec<_>>()
                .join(", "),
            c.verdict()
        );
    }
    let focus: Vec<&&crate::experiment::Comparison> = here
        .iter()
        .filter(|c| c.questions.iter().any(|q| q == "firecast_vs_model"))
        .collect();
    if let Some(f) = focus.first() {
        let named = |verdict: &str| -> Vec<String> {
            focus
                .iter()
                .filter(|c| c.verdict() == verdict)
                .map(|c| format!("`{}`", c.other))
                .collect()
        };
        let (better, worse, same) = (named("better"), named("worse"), named("no difference"));
        let list = |v: &[String]| {
            if v.is_empty() {
                "none".to_string()
            } else {
                v.join(", ")
            }
        };
        let _ = writeln!(
            out,
            "\nFireCast's forecaster `{}` (chosen on validation AUROC among FireCast's models) beats {} of {} models \
             ({}), loses to {} ({}) and cannot be told apart from {} ({}).\n",
            f.model,
            better.len(),
            focus.len(),
            list(&better),
            worse.len(),
            list(&worse),
            same.len(),
            list(&same)
        );
    } else {
        let _ = writeln!(out);
    }
}
