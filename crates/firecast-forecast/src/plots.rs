//! Pictures of an experiment: ROC and precision–recall curves overlaid per protocol,
//! reliability diagrams, confusion matrices, an AUROC forest plot with intervals, training
//! curves; plus the same data as DVCLive's plot files, one per model and protocol (what
//! `dvc plots` reads: [`dvc_plot_file`]), all models of a protocol in one file for scripts
//! (`roc_<protocol>.json`, …), and a long predictions CSV.

use std::fmt::Write as _;
use std::path::Path;

use firecast_render::chart::{BarChart, Chart, Heatmap, LegendPosition, Marker, Series};

use crate::ForecastError;
use crate::experiment::{ExperimentResult, ProtocolPredictions};

fn render_err(path: &Path) -> impl FnOnce(firecast_render::RenderError) -> ForecastError + '_ {
    move |e| ForecastError::Data {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

fn write_json(path: &Path, value: &serde_json::Value) -> Result<(), ForecastError> {
    let bytes = serde_json::to_vec_pretty(value).map_err(|e| ForecastError::Model(e.to_string()))?;
    firecast_fs::write_atomically(path, &bytes).map_err(|e| ForecastError::Data {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// Models drawn on overlaid curves: the best few by AUROC, plus the authors' and FireCast's
/// networks, so a chart stays readable.
fn featured<'a>(result: &'a ExperimentResult, protocol: &str) -> Vec<&'a str> {
    let rows = crate::table::rows(result, protocol);
    let mut out: Vec<&str> = Vec::new();
    for r in &rows {
        if out.len() < 5 || matches!(r.family.as_str(), "authors" | "firecast") {
            out.push(&r.model);
        }
    }
    out.truncate(8);
    out
}

/// Seed-mean scores of a model (the curve of the averaged predictor).
fn mean_scores(scores: &[Vec<f64>]) -> Vec<f64> {
    let n = scores.first().map_or(0, Vec::len);
    (0..n)
        .map(|i| scores.iter().map(|s| s[i]).sum::<f64>() / scores.len() as f64)
        .collect()
}

/// The DVCLive plots written per model and protocol: (file stem, its plot).
pub const DVC_PLOTS: [(&str, firecast_pipeline::stage::SklearnPlot); 4] = [
    ("roc", firecast_pipeline::stage::SklearnPlot::Roc),
    (
        "precision_recall",
        firecast_pipeline::stage::SklearnPlot::PrecisionRecall,
    ),
    ("calibration", firecast_pipeline::stage::SklearnPlot::Calibration),
    (
        "confusion",
        firecast_pipeline::stage::SklearnPlot::ConfusionMatrix,
    ),
];

/// A model's DVCLive plot file under one protocol, relative to the experiment folder:
/// `plots/<plot>_<protocol>_<model>.json` with `plot` a stem of [`DVC_PLOTS`].
pub fn dvc_plot_file(plot: &str, protocol: &str, model: &str) -> String {
    format!("plots/{plot}_{protocol}_{}.json", sanitize(model))
}

/// Writes every plot and plot file of `result` into `out/plots`, and `predictions.csv`.
pub fn write_all(
    out: &Path,
    result: &ExperimentResult,
    predictions: &[ProtocolPredictions],
) -> Result<(), ForecastError> {
    let dir = out.join("plots");
    std::fs::create_dir_all(&dir).map_err(ForecastError::io("creating", &dir))?;
    let palette = firecast_render::chart::OKABE_ITO;
    let mut csv = String::from("protocol,model,seed,sample_id,label,score\n");
    for pred in predictions {
        let p = &pred.protocol;
        let show = featured(result, p);
        let prevalence = pred.labels.iter().filter(|&&l| l).count() as f64 / pred.labels.len().max(1) as f64;
        let mut roc = Chart::new(720, 560)
            .title(format!("ROC, test side, protocol {p}"))
            .x_label("false positive rate")
            .y_label("true positive rate")
            .x_range(0.0, 1.0)
            .y_range(0.0, 1.0)
            .grid(true)
            .legend(Some(LegendPosition::BottomRight))
            .series(
                Series::segment((0.0, 0.0), (1.0, 1.0))
                    .color([150, 150, 150])
                    .dashed(true)
                    .label("no skill"),
            );
        let mut pr = Chart::new(720, 560)
            .title(format!("Precision-recall, test side, protocol {p}"))
            .x_label("recall")
            .y_label("precision")
            .x_range(0.0, 1.0)
            .y_range(0.0, 1.0)
            .grid(true)
            .legend(Some(LegendPosition::TopRight))
            .series(
                Series::hline(prevalence)
                    .color([150, 150, 150])
                    .dashed(true)
                    .label(format!("prevalence {prevalence:.2}")),
            );
        let mut rel = Chart::new(720, 560)
            .title(format!("Reliability, test side, protocol {p}"))
            .x_label("mean predicted probability")
            .y_label("observed fire frequency")
            .x_range(0.0, 1.0)
            .y_range(0.0, 1.0)
            .grid(true)
            .legend(Some(LegendPosition::TopLeft))
            .series(
                Series::segment((0.0, 0.0), (1.0, 1.0))
                    .color([150, 150, 150])
                    .dashed(true)
                    .label("calibrated"),
            );
        let mut k = 0usize;
        let mut dvc_roc = serde_json::Map::new();
        let mut dvc_pr = serde_json::Map::new();
        let mut dvc_cal = serde_json::Map::new();
        for (model, scores, thresholds) in &pred.models {
            for (s, seed_scores) in scores.iter().enumerate() {
                for (i, score) in seed_scores.iter().enumerate() {
                    let _ = writeln!(
                        csv,
                        "{p},{model},{s},{},{},{score}",
                        pred.sample_ids[i],
                        u8::from(pred.labels[i])
                    );
                }
            }
            let mean = mean_scores(scores);
            let y = &pred.labels;
            let roc_pts = firecast_eval::metrics::roc_curve(y, &mean).unwrap_or_default();
            let pr_pts = firecast_eval::metrics::precision_recall_curve(y, &mean).unwrap_or_default();
            let cal = firecast_eval::metrics::calibration_curve(
                y,
                &mean,
                result_bins(result),
                firecast_eval::metrics::BinStrategy::Uniform,
            )
            .map_err(|e| ForecastError::Model(e.to_string()))?;
            let (prob_true, prob_pred) = (cal.prob_true.clone(), cal.prob_pred.clone());
            let (roc_file, pr_file, cal_file) = (
                firecast_eval::dvc::roc_plot(&roc_pts),
                firecast_eval::dvc::precision_recall_plot(&pr_pts),
                firecast_eval::dvc::calibration_plot(&cal),
            );
            // One curve per file, exactly DVCLive's shape: DVC merges the lists of a file
            // row by row, so several models in one file would not plot.
            for (stem, value) in [
                ("roc", &roc_file),
                ("precision_recall", &pr_file),
                ("calibration", &cal_file),
            ] {
                write_json(&out.join(dvc_plot_file(stem, p, model)), value)?;
            }
            dvc_roc.insert(model.clone(), roc_file);
            dvc_pr.insert(model.clone(), pr_file);
            dvc_cal.insert(model.clone(), cal_file);
            // Confusion matrix of the first seed at its threshold.
            if let (Some(first), Some(&t)) = (scores.first(), thresholds.first()) {
                let c = firecast_eval::metrics::Confusion::at(y, first, t);
                let name = format!("confusion_{p}_{}.png", sanitize(model));
                let path = dir.join(&name);
                Heatmap::confusion(c.tn, c.fp, c.fn_, c.tp)
                    .title(format!("{model}, {p}, threshold {t:.3}"))
                    .save_png(&path)
                    .map_err(render_err(&path))?;
                write_json(
                    &out.join(dvc_plot_file("confusion", p, model)),
                    &firecast_eval::dvc::confusion(y, first, t)
                        .map_err(|e| ForecastError::Model(e.to_string()))?,
                )?;
            }
            if show.contains(&model.as_str()) {
                let color = palette[k % palette.len()];
                k += 1;
                roc = roc.series(
                    Series::line(roc_pts.iter().map(|r| (r.fpr, r.tpr)))
                        .color(color)
                        .label(model.clone()),
                );
                // Average precision's step: precision P_n holds on (R_{n-1}, R_n].
                let mut asc: Vec<(f64, f64)> = pr_pts.iter().map(|r| (r.recall, r.precision)).collect();
                asc.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.total_cmp(&a.1)));
                let mut steps = Vec::with_capacity(asc.len() * 2);
                for w in asc.windows(2) {
                    steps.push((w[0].0, w[1].1));
                    steps.push((w[1].0, w[1].1));
                }
                pr = pr.series(Series::line(steps).color(color).label(model.clone()));
                rel = rel.series(
                    Series::line(prob_pred.iter().copied().zip(prob_true.iter().copied()))
                        .marker(Marker::Circle, 4.0)
                        .color(color)
                        .label(model.clone()),
                );
            }
        }
        for (chart, name) in [(roc, "roc"), (pr, "precision_recall"), (rel, "calibration")] {
            let path = dir.join(format!("{name}_{p}.png"));
            chart.save_png(&path).map_err(render_err(&path))?;
        }
        write_json(
            &dir.join(format!("roc_{p}.json")),
            &serde_json::Value::Object(dvc_roc),
        )?;
        write_json(
            &dir.join(format!("precision_recall_{p}.json")),
            &serde_json::Value::Object(dvc_pr),
        )?;
        write_json(
            &dir.join(format!("calibration_{p}.json")),
            &serde_json::Value::Object(dvc_cal),
        )?;
    }
    let path = out.join("predictions.csv");
    firecast_fs::write_atomically(&path, csv.as_bytes()).map_err(|e| ForecastError::Data {
        path: path.clone(),
        message: e.to_string(),
    })?;
    write_tables_only(out, result)?;
    training_curves(&dir, result)
}

fn result_bins(_result: &ExperimentResult) -> usize {
    10
}

fn sanitize(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The plots that need only the results (no per-sample scores): an AUROC and an AUPRC
/// forest plot with intervals per protocol.
pub fn write_tables_only(out: &Path, result: &ExperimentResult) -> Result<(), ForecastError> {
    let dir = out.join("plots");
    std::fs::create_dir_all(&dir).map_err(ForecastError::io("creating", &dir))?;
    for p in &result.protocols {
        for (metric, reference) in [("auroc", 0.5), ("auprc", p.prevalence)] {
            let rows = crate::table::rows(result, &p.name);
            let mut chart = BarChart::new(760, 120 + 28 * rows.len())
                .title(format!(
                    "Test {} with 95% interval, protocol {}",
                    metric.to_uppercase(),
                    p.name
                ))
                .x_label(metric.to_uppercase())
                .x_range(0.0, 1.0)
                .reference(reference)
                .show_values(true)
                .decimals(3);
            for r in rows {
                let v = r.test.get(metric).copied().unwrap_or(f64::NAN);
                if v.is_finite() {
                    chart = chart.bar(r.model.clone(), v, r.intervals.get(metric).copied());
                }
            }
            let path = dir.join(format!("{metric}_forest_{}.png", p.name));
            chart.save_png(&path).map_err(render_err(&path))?;
        }
    }
    Ok(())
}

/// Training and validation loss, and validation AUPRC, per epoch for every network (first seed).
fn training_curves(dir: &Path, result: &ExperimentResult) -> Result<(), ForecastError> {
    let palette = firecast_render::chart::OKABE_ITO;
    for r in &result.results {
        let Some(run) = r.runs.first() else { continue };
        if run.curves.is_empty() {
            continue;
        }
        let mut loss = Chart::new(720, 480)
            .title(format!("{} ({}), seed {}", r.model, r.protocol, run.seed))
            .x_label("epoch")
            .y_label("loss / AUPRC")
            .grid(true)
            .legend(Some(LegendPosition::TopRight));
        for (i, key) in ["train_loss", "val_loss", "val_auprc"].iter().enumerate() {
            if let Some(points) = run.curves.get(*key) {
                loss = loss.series(
                    Series::line(points.iter().map(|(e, v)| (*e as f64, *v)))
                        .color(palette[i])
                        .label(*key),
                );
            }
        }
        if let Some(best) = run.best_epoch {
            loss = loss.series(
                Series::vline(best as f64)
                    .color([120, 120, 120])
                    .dashed(true)
                    .label("kept epoch"),
            );
        }
        let path = dir.join(format!("training_{}_{}.png", r.protocol, sanitize(&r.model)));
        loss.save_png(&path).map_err(render_err(&path))?;
    }
    Ok(())
}
