//! Scored as forecasts are used: every saved model of an experiment over *all* cell-days of a
//! period — every GRIDMET cell with data, every day (or every n-th) — at the true prevalence,
//! not over the case-control samples of Table III.
//!
//! A model trained on a dataset whose prevalence is π_s (0.4 by the paper's design) says 0.4
//! where a fire is as likely as not among its samples; over all cell-days ignitions are rare
//! (π ≈ 10⁻³). Probabilities are corrected for that sampling prior before they are scored
//! (King & Zeng 2001: the odds scaled by π(1 − π_s) / (π_s(1 − π))), with π_s the dataset's
//! prevalence and π the ignition rate of the cell-days *before* the scored period (never the
//! scored labels). Ranking (AUROC) is unchanged by the correction; AUPRC, Brier, log loss and
//! calibration are what a forecaster is used for at this prevalence. Where the synthetic
//! generator's true probability exists, the oracle is scored beside the models and each
//! model's AUPRC is given as a share of the oracle's skill above the prevalence.

use std::collections::HashSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::ForecastError;
use crate::data::{Block, SampleMeta};
use crate::experiment::ExperimentResult;
use crate::inputs::Inputs;

/// How the cell-days are chosen and scored.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CellDayParams {
    /// The protocol whose saved models are scored (default: the experiment's headline).
    #[serde(default)]
    pub protocol: Option<String>,
    /// First and last day scored (`YYYY-MM-DD`, inclusive).
    pub from: String,
    pub to: String,
    /// Score every n-th day of the period (1: every day).
    #[serde(default = "one")]
    pub every_days: u32,
    /// Bins of the reliability curves (equal counts of cell-days).
    #[serde(default = "ten")]
    pub reliability_bins: usize,
    #[serde(default = "default_device")]
    pub device: String,
    /// Resamples of GRIDMET cells for the AUPRC intervals and the paired comparison (a few
    /// dozen ignitions make AUPRC noisy).
    #[serde(default = "default_bootstrap")]
    pub bootstrap: usize,
}

fn default_bootstrap() -> usize {
    200
}

fn one() -> u32 {
    1
}
fn ten() -> usize {
    10
}
fn default_device() -> String {
    "cpu".into()
}

/// One model's scores over the cell-days (means over its seeds).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CellDayRow {
    pub model: String,
    pub kind: String,
    pub family: String,
    pub seeds: usize,
    pub auroc: f64,
    pub auprc: f64,
    /// Brier score and log loss of the prior-corrected probabilities.
    pub brier: f64,
    pub log_loss: f64,
    /// Expected calibration error over `reliability_bins` equal-count bins.
    pub ece: f64,
    /// 1 − Brier / Brier of always forecasting the prior π.
    pub brier_skill_vs_prior: f64,
    /// (AUPRC − prevalence) / (oracle's AUPRC − prevalence); None without the truth.
    pub auprc_share_of_oracle: Option<f64>,
    /// Mean corrected probability (compare with the prevalence).
    pub mean_probability: f64,
    /// 95 % percentile interval of the AUPRC of the seeds' mean forecast, resampling cells.
    #[serde(default)]
    pub auprc_interval: Option<(f64, f64)>,
}

/// FireCast's recommended forecaster against the best other model by AUPRC that is not one of
/// FireCast's own candidates (its other sizes and variants answer a different question),
/// paired over cells and seeds.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CellDayComparison {
    pub model: String,
    pub other: String,
    pub auprc_diff: f64,
    pub auprc_diff_interval: (f64, f64),
    pub p_value: f64,
}

/// Everything the scoring measured.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CellDayResult {
    pub experiment: String,
    pub dataset: String,
    pub dataset_version: String,
    pub protocol: String,
    pub from: String,
    pub to: String,
    pub every_days: u32,
    pub cells: usize,
    pub days: usize,
    /// Cell-days scored (cells × days with a complete input window).
    pub cell_days: usize,
    pub ignitions: usize,
    pub prevalence: f64,
    /// The dataset's share of positives, which the models learnt as their base rate.
    pub sampling_prevalence: f64,
    /// The ignition rate of the cell-days before `from`, which the probabilities are corrected to.
    pub prior: f64,
    pub prior_from: String,
    pub reliability_bins: usize,
    /// The generator's true probability, scored as a forecast (synthetic data only).
    pub oracle: Option<CellDayRow>,
    /// By AUPRC, best first.
    pub rows: Vec<CellDayRow>,
    pub bootstrap: usize,
    #[serde(default)]
    pub comparison: Option<CellDayComparison>,
}

/// King & Zeng's prior correction of a probability learnt at prevalence `sampled` to a
/// population whose prevalence is `prior`.
pub fn prior_corrected(p: f64, sampled: f64, prior: f64) -> f64 {
    let p = p.clamp(0.0, 1.0);
    let a = p * prior / sampled;
    let b = (1.0 - p) * (1.0 - prior) / (1.0 - sampled);
    if a + b == 0.0 { 0.0 } else { a / (a + b) }
}

/// The rows of one model's or the oracle's probabilities.
fn score_row(
    (model, kind, family): (&str, &str, &str),
    y: &[bool],
    per_seed: &[Vec<f64>],
    bins: usize,
    prior: f64,
) -> CellDayRow {
    let mean = |f: &dyn Fn(&[f64]) -> f64| {
        let v: Vec<f64> = per_seed.iter().map(|p| f(p)).filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            f64::NAN
        } else {
            v.iter().sum::<f64>() / v.len() as f64
        }
    };
    let reference = firecast_eval::metrics::brier(y, &vec![prior; y.len()]);
    CellDayRow {
        model: model.to_string(),
        kind: kind.to_string(),
        family: family.to_string(),
        seeds: per_seed.len(),
        auroc: mean(&|p| firecast_eval::metrics::roc_auc(y, p).unwrap_or(f64::NAN)),
        auprc: mean(&|p| firecast_eval::metrics::average_precision(y, p).unwrap_or(f64::NAN)),
        brier: mean(&|p| firecast_eval::metrics::brier(y, p)),
        log_loss: mean(&|p| firecast_eval::metrics::log_loss(y, p)),
        ece: mean(&|p| equal_count_ece(y, p, bins)),
        brier_skill_vs_prior: mean(&|p| 1.0 - firecast_eval::metrics::brier(y, p) / reference),
        auprc_share_of_oracle: None,
        mean_probability: mean(&|p| p.iter().sum::<f64>() / p.len().max(1) as f64),
        auprc_interval: None,
    }
}

/// ECE over equal-count bins (equal-width bins of [0, 1] put every rare-event forecast in the
/// first bin).
fn equal_count_ece(y: &[bool], p: &[f64], bins: usize) -> f64 {
    match firecast_eval::metrics::calibration_curve(y, p, bins, firecast_eval::metrics::BinStrategy::Quantile)
    {
        Ok(c) => {
            let n = y.len() as f64;
            (0..c.counts.len())
                .map(|b| c.counts[b] as f64 / n * (c.prob_true[b] - c.prob_pred[b]).abs())
                .sum()
        }
        Err(_) => f64::NAN,
    }
}

/// Inputs of [`score`].
pub struct CellDayInputs<'a> {
    pub experiment: &'a Path,
    pub dataset: &'a Path,
    pub gridmet: &'a Path,
    /// The synthetic generator's truth folder (`ignition_probability_<YYYY>.nc`), if any.
    pub truth: Option<&'a Path>,
    /// The positives (`data.ignitions`' Parquet): which cell-days had an ignition.
    pub ignitions: &'a Path,
}

/// Scores every saved model of the protocol over the period's cell-days, and writes the
/// reliability curves of the best five and the oracle to `plot` (PNG) when given.
pub fn score(
    inputs: &CellDayInputs<'_>,
    params: &CellDayParams,
    plot: Option<&Path>,
    progress: &dyn Fn(&str, usize, usize),
) -> Result<CellDayResult, ForecastError> {
    let device = crate::parse_device(&params.device)?;
    let results_path = inputs.experiment.join("results.json");
    let text = std::fs::read(&results_path).map_err(ForecastError::io("reading", &results_path))?;
    let result: ExperimentResult = serde_json::from_slice(&text).map_err(|e| ForecastError::Data {
        path: results_path.clone(),
        message: format!("not an experiment's results: {e}"),
    })?;
    let protocol = params.protocol.clone().unwrap_or_else(|| result.headline.clone());
    let info = result
        .protocols
        .iter()
        .find(|p| p.name == protocol)
        .ok_or_else(|| ForecastError::Config {
            key: "protocol".into(),
            message: format!(
                "`{protocol}` is not one of the experiment's protocols ({})",
                result
                    .protocols
                    .iter()
                    .map(|p| p.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        })?;
    let manifest = firecast_dataset::dataset::read_manifest(inputs.dataset)
        .map_err(|e| ForecastError::dataset(inputs.dataset, e))?;
    if manifest.name != result.dataset || manifest.version != result.dataset_version {
        return Err(ForecastError::Data {
            path: inputs.dataset.to_path_buf(),
            message: format!(
                "is {} {}, but the experiment {} was trained on {} {}",
                manifest.name,
                manifest.version,
                inputs.experiment.display(),
                result.dataset,
                result.dataset_version
            ),
        });
    }
    let sampled = manifest.positives as f64 / manifest.samples.max(1) as f64;
    let day = |key: &str, s: &str| {
        firecast_dataset::time::parse_date(s).ok_or_else(|| ForecastError::Config {
            key: key.into(),
            message: format!("`{s}` is not a YYYY-MM-DD date"),
        })
    };
    let (first, last) = (day("from", &params.from)?, day("to", &params.to)?);
    if last < first {
        return Err(ForecastError::Config {
            key: "to".into(),
            message: format!("{} is before `from` ({})", params.to, params.from),
        });
    }
    if params.every_days == 0 || params.reliability_bins == 0 {
        return Err(ForecastError::Config {
            key: if params.every_days == 0 {
                "every_days"
            } else {
                "reliability_bins"
            }
            .into(),
            message: "must be at least 1".into(),
        });
    }
    let mask = firecast_dataset::land::LandMask::from_gridmet_dir(inputs.gridmet)
        .map_err(|e| ForecastError::dataset(inputs.gridmet, e))?;
    let (lats, lons) = (mask.lats().to_vec(), mask.lons().to_vec());
    let cells: Vec<(usize, usize)> = (0..lats.len())
        .flat_map(|j| (0..lons.len()).map(move |i| (j, i)))
        .filter(|&(j, i)| mask.is_valid(j, i))
        .collect();
    let days: Vec<i32> = (first..=last).step_by(params.every_days as usize).collect();

    // Which cell-days had an ignition, and the rate before the period (the prior).
    let nearest = |axis: &[f64], v: f64| {
        axis.iter()
            .enumerate()
            .min_by(|a, b| (a.1 - v).abs().total_cmp(&(b.1 - v).abs()))
            .map(|(k, _)| k)
    };
    let positives = firecast_dataset::table::read_sample_list(inputs.ignitions)
        .map_err(|e| ForecastError::dataset(inputs.ignitions, e))?;
    let valid: HashSet<(usize, usize)> = cells.iter().copied().collect();
    let mut fired: HashSet<(usize, usize, i32)> = HashSet::new();
    let mut before = 0usize;
    let mut earliest = i32::MAX;
    for p in positives.iter().filter(|p| p.tier.is_positive()) {
        let (Some(j), Some(i)) = (nearest(&lats, p.lat), nearest(&lons, p.lon)) else {
            continue;
        };
        if !valid.contains(&(j, i)) {
            continue;
        }
        let d = firecast_dataset::time::gridmet_day(p.time_ms, firecast_dataset::time::DayBoundary::Mst);
        earliest = earliest.min(d);
        if d < first && fired.insert((j, i, d)) {
            before += 1;
        } else {
            fired.insert((j, i, d));
        }
    }
    if earliest >= first {
        return Err(ForecastError::Data {
            path: inputs.ignitions.to_path_buf(),
            message: format!(
                "no ignition before {}: the prior (the ignition rate of the cell-days before the period) cannot be measured",
                params.from
            ),
        });
    }
    let prior = before as f64 / (cells.len() * (first - earliest) as usize).max(1) as f64;

    // One window per cell-day, read once for every model.
    let queries: Vec<(usize, usize, i32)> = days
        .iter()
        .flat_map(|&d| cells.iter().map(move |&(j, i)| (j, i, d)))
        .collect();
    progress(
        &format!(
            "{} cells x {} days = {} cell-days, protocol {protocol} (days {} to {})",
            cells.len(),
            days.len(),
            queries.len(),
            info.days.0,
            info.days.1
        ),
        0,
        1,
    );
    let samples: Vec<firecast_dataset::windows::SampleIn> = queries
        .iter()
        .enumerate()
        .map(|(k, &(j, i, d))| firecast_dataset::windows::SampleIn {
            sample_id: k as u32,
            lat: lats[j],
            lon: lons[i],
            // Noon MST: the GRIDMET day `d`.
            time_ms: firecast_dataset::time::day_start_ms(d) + 19 * 3_600_000,
            tier: firecast_dataset::Tier::Far,
            source_row: None,
        })
        .collect();
    let models: Vec<&crate::experiment::ModelResult> =
        result.results.iter().filter(|r| r.protocol == protocol).collect();
    let features = {
        let first_model = models.first().ok_or_else(|| ForecastError::Data {
            path: results_path.clone(),
            message: format!("no model under protocol `{protocol}`"),
        })?;
        let bundles = crate::bundle::seed_bundles(inputs.experiment, None, &protocol, &first_model.model)?;
        let (_, rel) = bundles.first().ok_or_else(|| ForecastError::Data {
            path: inputs.experiment.join("models").join(&protocol),
            message: format!("no saved model of `{}`", first_model.model),
        })?;
        crate::bundle::load(&inputs.experiment.join(rel), device)?
            .info
            .features
    };
    let cfg = firecast_dataset::windows::ExtractConfig {
        first_offset: info.days.0,
        last_offset: info.days.1,
        variables: features,
        ..Default::default()
    };
    let (mut table, _) =
        firecast_dataset::windows::extract(&samples, inputs.gridmet, &cfg, false, &|_, _| {})
            .map_err(|e| ForecastError::dataset(inputs.gridmet, e))?;
    // Cell-days with a missing value anywhere in the window are left out (masked cells' edges).
    let per_sample = table.n_days * table.n_features();
    let complete: Vec<usize> = (0..table.samples.len())
        .filter(|&s| {
            table.values[s * per_sample..(s + 1) * per_sample]
                .iter()
                .all(|v| v.is_finite())
        })
        .collect();
    if complete.is_empty() {
        return Err(ForecastError::Data {
            path: inputs.gridmet.to_path_buf(),
            message: format!(
                "no complete input window for any cell-day from {} to {}",
                params.from, params.to
            ),
        });
    }
    if let Some(truth) = inputs.truth {
        firecast_dataset::truth::attach_truth(&mut table.samples, truth, false)
            .map_err(|e| ForecastError::dataset(truth, e))?;
    }
    let mut values = Vec::with_capacity(complete.len() * per_sample);
    for &s in &complete {
        values.extend_from_slice(&table.values[s * per_sample..(s + 1) * per_sample]);
    }
    let block = Block {
        features: table.features.clone(),
        first_offset: table.first_offset,
        n_days: table.n_days,
        values,
    };
    let meta: Vec<SampleMeta> = complete
        .iter()
        .map(|&s| SampleMeta::of(&table.samples[s], None))
        .collect();
    let y: Vec<bool> = complete
        .iter()
        .map(|&s| fired.contains(&queries[table.samples[s].sample_id as usize]))
        .collect();
    let ignitions = y.iter().filter(|&&l| l).count();
    if ignitions == 0 {
        return Err(ForecastError::Data {
            path: inputs.ignitions.to_path_buf(),
            message: format!(
                "no ignition on the {} cell-days scored from {} to {}",
                y.len(),
                params.from,
                params.to
            ),
        });
    }
    let prevalence = ignitions as f64 / y.len() as f64;
    // Cell-days of one cell move together in the resamples.
    let clusters: Vec<u64> = complete
        .iter()
        .map(|&s| {
            let (j, i, _) = queries[table.samples[s].sample_id as usize];
            (j * lons.len() + i) as u64
        })
        .collect();
    let interval = |p: &[f64]| {
        firecast_eval::bootstrap::ci(
            &y,
            p,
            Some(&clusters),
            params.bootstrap,
            0,
            0.95,
            firecast_eval::metrics::average_precision,
        )
        .ok()
        .map(|i| (i.low, i.high))
    };

    let oracle = if inputs.truth.is_some() {
        let truth: Option<Vec<f64>> = complete
            .iter()
            .map(|&s| table.samples[s].true_probability.map(f64::from))
            .collect();
        truth.map(|t| {
            let mut row = score_row(
                ("oracle", "truth", "oracle"),
                &y,
                std::slice::from_ref(&t),
                params.reliability_bins,
                prior,
            );
            row.auprc_interval = interval(&t);
            row
        })
    } else {
        None
    };

    let mut rows = Vec::new();
    let mut curves: Vec<(String, Vec<f64>)> = Vec::new();
    let mut scores: Vec<(String, Vec<Vec<f64>>)> = Vec::new();
    for (k, m) in models.iter().enumerate() {
        progress(
            &format!("scoring {} ({} seeds)", m.model, m.runs.len()),
            k,
            models.len(),
        );
        let mut per_seed = Vec::new();
        for (_, rel) in crate::bundle::seed_bundles(inputs.experiment, None, &protocol, &m.model)? {
            let bundle = crate::bundle::load(&inputs.experiment.join(&rel), device)?;
            let scores = bundle
                .model
                .predict(
                    &Inputs {
                        block: &block,
                        meta: meta.iter().collect(),
                    },
                    device,
                )
                .map_err(|e| e.in_model(&m.model))?;
            per_seed.push(
                scores
                    .into_iter()
                    .map(|p| prior_corrected(p, sampled, prior))
                    .collect::<Vec<_>>(),
            );
        }
        let mut row = score_row(
            (&m.model, &m.kind, &m.family),
            &y,
            &per_seed,
            params.reliability_bins,
            prior,
        );
        if let Some(o) = &oracle {
            row.auprc_share_of_oracle = Some((row.auprc - prevalence) / (o.auprc - prevalence));
        }
        let mean = mean_over_seeds(&per_seed);
        row.auprc_interval = interval(&mean);
        curves.push((m.model.clone(), mean));
        scores.push((m.model.clone(), per_seed));
        rows.push(row);
    }
    progress("scored every model", models.len(), models.len());
    rows.sort_by(|a, b| b.auprc.total_cmp(&a.auprc).then(a.model.cmp(&b.model)));
    // FireCast's recommended forecaster (by validation, as Table III chooses it) against the
    // best model here that is not FireCast's own (else the best other of its own).
    let comparison =
        crate::experiment::recommended_forecaster(&protocol, &result.results).and_then(|focus| {
            let other = rows
                .iter()
                .find(|r| r.model != focus.model && r.family != focus.family)
                .or_else(|| rows.iter().find(|r| r.model != focus.model))?;
            let find = |name: &str| scores.iter().find(|s| s.0 == name).map(|s| &s.1);
            let (a, b) = (find(&focus.model)?, find(&other.model)?);
            let (a, b) = crate::experiment::seed_pairs(a, b);
            let d = firecast_eval::bootstrap::paired_diff_ci_seeds(
                &y,
                &a,
                &b,
                Some(&clusters),
                params.bootstrap,
                0,
                0.95,
                firecast_eval::metrics::average_precision,
            )
            .ok()?;
            Some(CellDayComparison {
                model: focus.model.clone(),
                other: other.model.clone(),
                auprc_diff: d.interval.estimate,
                auprc_diff_interval: (d.interval.low, d.interval.high),
                p_value: d.p_value,
            })
        });
    if let Some(path) = plot {
        let mut shown: Vec<(String, Vec<f64>)> = rows
            .iter()
            .take(5)
            .filter_map(|r| curves.iter().find(|c| c.0 == r.model).cloned())
            .collect();
        if oracle.is_some() {
            shown.push((
                "oracle".into(),
                complete
                    .iter()
                    .map(|&s| table.samples[s].true_probability.map_or(f64::NAN, f64::from))
                    .collect(),
            ));
        }
        reliability_plot(path, &y, &shown, params.reliability_bins, &protocol)?;
    }
    Ok(CellDayResult {
        experiment: result.name.clone(),
        dataset: result.dataset.clone(),
        dataset_version: result.dataset_version.clone(),
        protocol,
        from: params.from.clone(),
        to: params.to.clone(),
        every_days: params.every_days,
        cells: cells.len(),
        days: days.len(),
        cell_days: y.len(),
        ignitions,
        prevalence,
        sampling_prevalence: sampled,
        prior,
        prior_from: firecast_dataset::time::format_date(earliest),
        reliability_bins: params.reliability_bins,
        oracle,
        rows,
        bootstrap: params.bootstrap,
        comparison,
    })
}

fn mean_over_seeds(per_seed: &[Vec<f64>]) -> Vec<f64> {
    let n = per_seed.first().map_or(0, Vec::len);
    (0..n)
        .map(|i| per_seed.iter().map(|p| p[i]).sum::<f64>() / per_seed.len() as f64)
        .collect()
}

/// Reliability on log axes (rare events): observed ignition frequency against the mean
/// forecast in equal-count bins; bins with no ignition cannot be drawn on a log axis and are
/// left out.
fn reliability_plot(
    path: &Path,
    y: &[bool],
    curves: &[(String, Vec<f64>)],
    bins: usize,
    protocol: &str,
) -> Result<(), ForecastError> {
    use firecast_render::chart::{Chart, LegendPosition, Marker, Series};
    let palette: [[u8; 3]; 6] = [
        [31, 119, 180],
        [255, 127, 14],
        [44, 160, 44],
        [214, 39, 40],
        [148, 103, 189],
        [60, 60, 60],
    ];
    let mut points: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for (name, p) in curves {
        let Ok(c) = firecast_eval::metrics::calibration_curve(
            y,
            p,
            bins,
            firecast_eval::metrics::BinStrategy::Quantile,
        ) else {
            continue;
        };
        let pts: Vec<(f64, f64)> = c
            .prob_pred
            .iter()
            .zip(&c.prob_true)
            .filter(|(x, o)| **x > 0.0 && **o > 0.0)
            .map(|(x, o)| (x.log10(), o.log10()))
            .collect();
        points.push((name.clone(), pts));
    }
    let all: Vec<f64> = points
        .iter()
        .flat_map(|(_, v)| v.iter().flat_map(|&(x, o)| [x, o]))
        .collect();
    let lo = all
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .min(-3.0)
        .floor();
    let hi = all
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max)
        .max(-1.0)
        .ceil()
        .min(0.0);
    let mut chart = Chart::new(760, 580)
        .title(format!(
            "Reliability over all cell-days, protocol {protocol} (prior-corrected)"
        ))
        .x_label("log10 mean forecast probability")
        .y_label("log10 observed ignition frequency")
        .x_range(lo, hi)
        .y_range(lo, hi)
        .grid(true)
        .legend(Some(LegendPosition::TopLeft))
        .series(
            Series::segment((lo, lo), (hi, hi))
                .color([150, 150, 150])
                .dashed(true)
                .label("calibrated"),
        );
    for (k, (name, pts)) in points.into_iter().enumerate() {
        chart = chart.series(
            Series::line(pts)
                .marker(Marker::Circle, 4.0)
                .color(palette[k % palette.len()])
                .label(name),
        );
    }
    chart.save_png(path).map_err(|e| ForecastError::Data {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// The headline table in Markdown.
pub fn markdown(r: &CellDayResult) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Forecasts over all cell-days: {} (protocol `{}`)\n",
        r.experiment, r.protocol
    );
    let _ = writeln!(
        md,
        "{} GRIDMET cells × {} days ({} to {}, every {} day{}) = {} cell-days with a complete input window, \
         {} with an ignition: prevalence {:.2e}. The models learnt from `{}` ({}) at prevalence {:.3}; their \
         probabilities are corrected to the prior {:.2e}, the ignition rate of the cell-days from {} to the day \
         before {} (King & Zeng's prior correction; AUROC is unchanged by it). Means over each model's seeds; \
         ECE over {} equal-count bins.\n",
        r.cells,
        r.days,
        r.from,
        r.to,
        r.every_days,
        if r.every_days == 1 { "" } else { "s" },
        r.cell_days,
        r.ignitions,
        r.prevalence,
        r.dataset,
        r.dataset_version,
        r.sampling_prevalence,
        r.prior,
        r.prior_from,
        r.from,
        r.reliability_bins
    );
    let _ = writeln!(
        md,
        "| model | family | AUPRC [95 % interval over cells] | share of the oracle's AUPRC skill | AUROC | Brier | Brier skill vs the prior | log loss | ECE | mean forecast |"
    );
    let _ = writeln!(md, "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    let fmt = |v: f64, d: usize| {
        if v.is_finite() {
            format!("{v:.d$}")
        } else {
            "—".into()
        }
    };
    let sci = |v: f64| {
        if v.is_finite() {
            format!("{v:.2e}")
        } else {
            "—".into()
        }
    };
    let line = |md: &mut String, r: &CellDayRow| {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.model,
            r.family,
            match r.auprc_interval {
                Some((lo, hi)) => format!("{} [{}, {}]", fmt(r.auprc, 4), fmt(lo, 4), fmt(hi, 4)),
                None => fmt(r.auprc, 4),
            },
            r.auprc_share_of_oracle
                .map_or("—".into(), |s| format!("{:.0} %", s * 100.0)),
            fmt(r.auroc, 3),
            sci(r.brier),
            fmt(r.brier_skill_vs_prior, 4),
            fmt(r.log_loss, 4),
            sci(r.ece),
            sci(r.mean_probability)
        );
    };
    if let Some(o) = &r.oracle {
        line(&mut md, o);
    }
    for row in &r.rows {
        line(&mut md, row);
    }
    let _ = writeln!(
        md,
        "\nThe no-skill AUPRC is the prevalence ({:.2e}); intervals from {} resamples of the GRIDMET cells. \
         `reliability.png` draws the best five and the oracle.",
        r.prevalence, r.bootstrap
    );
    if let Some(c) = &r.comparison {
        let _ = writeln!(
            md,
            "\nFireCast's recommended forecaster `{}` against `{}` (paired over cells and seeds): ΔAUPRC {:+.4} \
             [{:+.4}, {:+.4}], bootstrap p {:.2}: {}.",
            c.model,
            c.other,
            c.auprc_diff,
            c.auprc_diff_interval.0,
            c.auprc_diff_interval.1,
            c.p_value,
            if c.auprc_diff_interval.0 > 0.0 {
                "better"
            } else if c.auprc_diff_interval.1 < 0.0 {
                "worse"
            } else {
                "not told apart"
            }
        );
    }
    md
}

/// Writes `cell_days.json`, `cell_days.md` and `reliability.png` into `out` (a folder published
/// whole by the caller).
pub fn write(out: &Path, r: &CellDayResult) -> Result<Vec<PathBuf>, ForecastError> {
    let json = out.join("cell_days.json");
    let text = serde_json::to_vec_pretty(r).map_err(|e| ForecastError::Model(e.to_string()))?;
    std::fs::write(&json, text).map_err(ForecastError::io("writing", &json))?;
    let md = out.join("cell_days.md");
    std::fs::write(&md, markdown(r)).map_err(ForecastError::io("writing", &md))?;
    Ok(vec![json, md])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_prior_correction_moves_the_base_rate_and_keeps_the_order() {
        // A model that learnt at 40 % and says 40 % says "base rate": the prior.
        assert!((prior_corrected(0.4, 0.4, 0.001) - 0.001).abs() < 1e-12);
        // Same prevalence: no change.
        assert!((prior_corrected(0.7, 0.3, 0.3) - 0.7).abs() < 1e-12);
        // The odds scale by π(1 − π_s) / (π_s(1 − π)); order is kept.
        let (a, b) = (prior_corrected(0.2, 0.4, 0.01), prior_corrected(0.8, 0.4, 0.01));
        assert!(a < b && b < 0.8);
        let odds = |p: f64| p / (1.0 - p);
        assert!((odds(b) / odds(0.8) - (0.01 * 0.6) / (0.4 * 0.99)).abs() < 1e-12);
        assert_eq!(prior_corrected(0.0, 0.4, 0.01), 0.0);
        assert_eq!(prior_corrected(1.0, 0.4, 0.01), 1.0);
    }
}
