//! Running an experiment: every protocol × model × seed (a training [`Unit`]) is fitted on
//! its training side, thresholded on its validation side, and scored once on its test side.
//! Intervals come from a cluster bootstrap over the test set; the best model is tested
//! against the best baseline on the same test samples.
//!
//! [`prepare`] splits the dataset, [`fit_units`] fits units and keeps their scores,
//! [`assemble`] computes everything else from the scores alone, so the units can be fitted
//! in one process ([`run`]) or in shards ([`crate::shard`]) with the same report.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use firecast_eval::metrics::{BinaryReport, ThresholdRule as EvalRule};
use serde::{Deserialize, Serialize};

use crate::ForecastError;
use crate::data::{Block, Windows};
use crate::inputs::{FitContext, Inputs};
use crate::models::{ModelConfig, ThresholdRule, Trained};
use crate::spec::{ClusterBy, Evaluation, ExperimentSpec};

/// The reported numbers of one model under one protocol, pooled over its seeds.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ModelResult {
    pub protocol: String,
    pub model: String,
    pub kind: String,
    /// Which family the row belongs to: `reference` (no-skill and cheap references),
    /// `paper_baseline` (Table III's flattened models), `sequence` (LSTM, LightTS), `authors`
    /// (variants R and D), `firecast`.
    pub family: String,
    pub seeds: Vec<u64>,
    /// Test metrics averaged over seeds.
    pub test: BTreeMap<String, f64>,
    /// Bootstrap intervals of the seed-averaged metrics: metric → (low, high).
    pub intervals: BTreeMap<String, (f64, f64)>,
    /// Standard deviation over seeds (0 for deterministic models).
    pub seed_std: BTreeMap<String, f64>,
    /// Per-seed test reports.
    pub runs: Vec<SeedRun>,
    /// Test metrics by year of the predicted date.
    pub by_year: BTreeMap<String, BTreeMap<String, f64>>,
    /// By negative tier: positives against that tier's negatives.
    pub by_tier: BTreeMap<String, BTreeMap<String, f64>>,
    pub parameters: Option<i64>,
    /// Skill above no skill as a share of the oracle's, (m − m₀)/(oracle − m₀), for AUROC
    /// (m₀ = 0.5) and AUPRC (m₀ = prevalence), on synthetic data with known probabilities.
    pub skill_vs_oracle: Option<BTreeMap<String, f64>>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SeedRun {
    pub seed: u64,
    pub threshold: f64,
    pub threshold_rule: String,
    pub report: BinaryReport,
    /// Validation scores at the chosen threshold (none when saved models are re-scored).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation: Option<BinaryReport>,
    pub epochs: Option<usize>,
    pub best_epoch: Option<usize>,
    /// Where the fitted model was written, relative to the report folder.
    pub model_dir: String,
    /// Per-epoch curves of networks: key → (epoch, value).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub curves: BTreeMap<String, Vec<(i64, f64)>>,
}

/// The test-side scores of one protocol, kept for curves and plots.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ProtocolPredictions {
    pub protocol: String,
    pub sample_ids: Vec<u32>,
    pub labels: Vec<bool>,
    /// Model → per-seed test scores and thresholds.
    pub models: Vec<(String, Vec<Vec<f64>>, Vec<f64>)>,
}

/// One protocol's facts.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ProtocolInfo {
    pub name: String,
    pub days: (i32, i32),
    pub split: String,
    pub train: usize,
    pub val: usize,
    pub test: usize,
    pub dropped: usize,
    pub test_positives: usize,
    pub prevalence: f64,
    /// Always predicting "no fire".
    pub majority_accuracy: f64,
    pub leaks_future: bool,
    /// AUROC and AUPRC of the generator's true probabilities on the test side (synthetic data).
    pub oracle: Option<BTreeMap<String, f64>>,
}

/// A paired comparison on the same test samples.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PairedTest {
    pub protocol: String,
    pub model: String,
    pub baseline: String,
    pub mcnemar_b: u64,
    pub mcnemar_c: u64,
    pub mcnemar_p: f64,
    pub mcnemar_exact: bool,
    pub delong_auroc_diff: f64,
    pub delong_p: f64,
    #[serde(deserialize_with = "firecast_eval::serde_nan::nan_if_null")]
    pub auprc_diff: f64,
    pub auprc_diff_interval: (f64, f64),
    pub prob_model_better_auprc: f64,
}

/// Everything an experiment produced.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ExperimentResult {
    pub name: String,
    pub dataset: String,
    pub dataset_version: String,
    pub framing: String,
    pub headline: String,
    pub device: String,
    pub bootstrap: usize,
    pub level: f64,
    pub cluster: String,
    pub protocols: Vec<ProtocolInfo>,
    pub results: Vec<ModelResult>,
    pub paired: Vec<PairedTest>,
    /// FireCast's forecaster against every other model, and the best model against the best
    /// baseline, over all seeds (empty in results written before 2026-11-28).
    #[serde(default)]
    pub comparisons: Vec<Comparison>,
}

/// One paired comparison of two models on the same test samples over all training seeds:
/// the difference of their AUROC and AUPRC (mean over seed pairs) with percentile intervals
/// from a bootstrap that resamples the samples by GRIDMET cell and the seed pairs, a
/// two-sided bootstrap p-value of the AUROC difference, Holm-adjusted over the protocol's
/// comparisons, and DeLong's test on each seed.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Comparison {
    pub protocol: String,
    /// Why the pair is compared: `firecast_vs_model` (FireCast's forecaster against every other
    /// model), `best_vs_best_baseline`, or both.
    pub questions: Vec<String>,
    pub model: String,
    pub other: String,
    /// Seed pairs: seed i of one model with seed i of the other, or a deterministic model's one
    /// run with each seed of the other.
    pub seeds: usize,
    #[serde(deserialize_with = "firecast_eval::serde_nan::nan_if_null")]
    pub auroc_diff: f64,
    pub auroc_diff_interval: (f64, f64),
    #[serde(deserialize_with = "firecast_eval::serde_nan::nan_if_null")]
    pub auprc_diff: f64,
    pub auprc_diff_interval: (f64, f64),
    /// Two-sided bootstrap p-value of "same AUROC".
    #[serde(deserialize_with = "firecast_eval::serde_nan::nan_if_null")]
    pub p_value: f64,
    /// `p_value` Holm-adjusted over the protocol's comparisons.
    #[serde(deserialize_with = "firecast_eval::serde_nan::nan_if_null")]
    pub p_holm: f64,
    /// DeLong's p-value of the AUROC difference on each seed pair (None where undefined).
    pub delong_p: Vec<Option<f64>>,
}

/// The comparison family's significance level.
pub const COMPARISON_ALPHA: f64 = 0.05;

impl Comparison {
    /// `better`, `worse` or `no difference`: the AUROC difference's interval on one side of 0
    /// and the Holm-adjusted p below [`COMPARISON_ALPHA`].
    pub fn verdict(&self) -> &'static str {
        if self.p_holm < COMPARISON_ALPHA && self.auroc_diff_interval.0 > 0.0 {
            "better"
        } else if self.p_holm < COMPARISON_ALPHA && self.auroc_diff_interval.1 < 0.0 {
            "worse"
        } else {
            "no difference"
        }
    }
}

/// A model's test scores: (label, kind, scores per seed, threshold per seed).
pub(crate) type ModelScores = (String, String, Vec<Vec<f64>>, Vec<f64>);

/// Where the run reports: progress lines and metrics (the registry, Rerun).
pub trait Sink: Sync {
    fn progress(&self, _what: &str, _done: u64, _total: u64) {}
    fn message(&self, _line: &str) {}
    fn metric(&self, _key: &str, _step: i64, _value: f64) {}
}

/// A sink that drops everything.
pub struct Quiet;
impl Sink for Quiet {}

pub(crate) fn family(kind: &str) -> &'static str {
    match kind {
        "majority" | "climatology" | "fire_danger_index" | "minirocket" | "window_stats_xgboost" => {
            "reference"
        }
        "logistic_regression"
        | "gaussian_nb"
        | "decision_tree"
        | "random_forest"
        | "gradient_boosting"
        | "knn"
        | "xgboost"
        | "mlp" => "paper_baseline",
        "lstm2" | "lightts" => "sequence",
        "cnn_bilstm" | "cnn_bilstm_attn" => "authors",
        _ => "firecast",
    }
}

fn eval_rule(rule: ThresholdRule) -> EvalRule {
    match rule {
        ThresholdRule::Fixed(t) => EvalRule::Fixed(t),
        ThresholdRule::MaxF1 => EvalRule::MaxF1,
        ThresholdRule::Youden => EvalRule::Youden,
    }
}

fn rule_label(rule: ThresholdRule) -> String {
    match rule {
        ThresholdRule::Fixed(t) => format!("fixed {t}"),
        ThresholdRule::MaxF1 => "max F1 on validation".into(),
        ThresholdRule::Youden => "Youden J on validation".into(),
    }
}

/// The headline metrics of a report, by name.
pub fn report_metrics(r: &BinaryReport) -> BTreeMap<String, f64> {
    let mut m = BTreeMap::new();
    m.insert("accuracy".into(), r.accuracy);
    m.insert("precision".into(), r.precision);
    m.insert("recall".into(), r.recall);
    m.insert("f1".into(), r.f1);
    m.insert("auroc".into(), r.auroc.unwrap_or(f64::NAN));
    m.insert("auprc".into(), r.auprc.unwrap_or(f64::NAN));
    m.insert("brier".into(), r.brier);
    m.insert("ece".into(), r.ece);
    m.insert("mcc".into(), r.mcc);
    m.insert("balanced_accuracy".into(), r.balanced_accuracy);
    m
}

/// Metrics that get intervals, in table order.
pub const TABLE_METRICS: [&str; 8] = [
    "accuracy",
    "precision",
    "recall",
    "f1",
    "auroc",
    "auprc",
    "brier",
    "ece",
];

fn metric_of(name: &str, y: &[bool], p: &[f64], threshold: f64, bins: usize) -> Option<f64> {
    use firecast_eval::metrics as m;
    let c = m::Confusion::at(y, p, threshold);
    Some(match name {
        "accuracy" => c.accuracy(),
        "precision" => c.precision(),
        "recall" => c.recall(),
        "f1" => c.f1(),
        "auroc" => m::roc_auc(y, p)?,
        "auprc" => m::average_precision(y, p)?,
        "brier" => m::brier(y, p),
        "ece" => m::ece(y, p, bins),
        _ => return None,
    })
}

/// The ceiling on synthetic data: AUROC and AUPRC of scoring each sample of `rows` by the
/// generator's true probability; `None` when a sample has none (real data).
pub(crate) fn oracle(windows: &Windows, rows: &[usize], labels: &[bool]) -> Option<BTreeMap<String, f64>> {
    let truth: Vec<f64> = rows
        .iter()
        .map(|&s| windows.meta[s].true_probability.map(f64::from))
        .collect::<Option<_>>()?;
    Some(BTreeMap::from([
        (
            "auroc".to_string(),
            firecast_eval::metrics::roc_auc(labels, &truth).unwrap_or(f64::NAN),
        ),
        (
            "auprc".to_string(),
            firecast_eval::metrics::average_precision(labels, &truth).unwrap_or(f64::NAN),
        ),
    ]))
}

/// Cluster ids of the test samples (GRIDMET cells, or each sample alone).
pub(crate) fn clusters(w: &Windows, idx: &[usize], by: ClusterBy) -> Vec<u64> {
    idx.iter()
        .map(|&s| match by {
            ClusterBy::Cell => (u64::from(w.meta[s].cell.0) << 32) | u64::from(w.meta[s].cell.1),
            ClusterBy::Sample => s as u64,
        })
        .collect()
}

/// One training unit: a model fitted under a protocol with a seed. An experiment's units are
/// numbered protocol by protocol (in name order), model by model (in the spec's order), seed
/// by seed (a deterministic model has one unit, with the first seed). Given the dataset, the
/// spec and the thread count, a unit's fit depends on its protocol, model and seed only,
/// never on the units fitted before it in the process (networks seed libtorch's generator
/// when they start; the other models draw from their own seeded generators), so units can be
/// fitted in any order and in any process: `forecast.experiment` shards by unit.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Unit {
    pub protocol: String,
    pub model: String,
    pub seed: u64,
}

impl std::fmt::Display for Unit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}/seed {}", self.protocol, self.model, self.seed)
    }
}

/// The experiment's units in order.
pub fn units(spec: &ExperimentSpec) -> Result<Vec<Unit>, ForecastError> {
    let mut units = Vec::new();
    for protocol in spec.protocols.keys() {
        for entry in &spec.models {
            let config = ModelConfig::parse(&entry.kind, &entry.params)?;
            let seeds = if config.is_stochastic() {
                &spec.seeds[..]
            } else {
                &spec.seeds[..spec.seeds.len().min(1)]
            };
            units.extend(seeds.iter().map(|&seed| Unit {
                protocol: protocol.clone(),
                model: entry.label(),
                seed,
            }));
        }
    }
    Ok(units)
}

/// What a unit's fit leaves for scoring: its validation and test scores (in the protocol's
/// sample order) and facts about the fit. Thresholds, reports, intervals, paired tests and
/// the table are all computed from these by [`assemble`].
#[derive(Debug, Clone, PartialEq)]
pub struct UnitScores {
    pub unit: Unit,
    pub val: Vec<f64>,
    pub test: Vec<f64>,
    pub epochs: Option<usize>,
    pub best_epoch: Option<usize>,
    pub parameters: Option<i64>,
    /// Per-epoch curves of networks: key → (epoch, value).
    pub curves: BTreeMap<String, Vec<(i64, f64)>>,
}

/// One protocol's split and labels, shared by the fits and the scoring of its units.
pub struct ProtocolSide {
    pub name: String,
    days: std::ops::Range<usize>,
    split: crate::split::SplitIndices,
    ytr: Vec<bool>,
    yva: Vec<bool>,
    yte: Vec<bool>,
    test_clusters: Vec<u64>,
    info: ProtocolInfo,
}

/// Splits `windows` under every protocol of `spec` (cheap: no windows are copied).
pub fn prepare(
    spec: &ExperimentSpec,
    windows: &Windows,
    sink: &dyn Sink,
) -> Result<Vec<ProtocolSide>, ForecastError> {
    let mut sides = Vec::new();
    for (pname, protocol) in &spec.protocols {
        let key = format!("protocols.{pname}");
        let days = windows.day_range(protocol.days.0, protocol.days.1, &format!("{key}.days"))?;
        let split = crate::split::apply(windows, &protocol.split, protocol.days, &key)?;
        let labels = |rows: &[usize]| rows.iter().map(|&s| windows.labels[s]).collect::<Vec<_>>();
        let (ytr, yva, yte) = (labels(&split.train), labels(&split.val), labels(&split.test));
        let test_clusters = clusters(windows, &split.test, spec.evaluation.cluster);
        let positives = yte.iter().filter(|&&l| l).count();
        let prevalence = positives as f64 / yte.len() as f64;
        let info = ProtocolInfo {
            name: pname.clone(),
            days: protocol.days,
            split: split.description.clone(),
            train: split.train.len(),
            val: split.val.len(),
            test: split.test.len(),
            dropped: split.dropped.len(),
            test_positives: positives,
            prevalence,
            majority_accuracy: prevalence.max(1.0 - prevalence),
            leaks_future: protocol.days.1 >= 0,
            oracle: oracle(windows, &split.test, &yte),
        };
        sink.message(&format!(
            "protocol {pname}: days {}..{}, {} (train {}, val {}, test {} with {} positive, dropped {})",
            protocol.days.0,
            protocol.days.1,
            split.description,
            split.train.len(),
            split.val.len(),
            split.test.len(),
            positives,
            split.dropped.len()
        ));
        sides.push(ProtocolSide {
            name: pname.clone(),
            days,
            split,
            ytr,
            yva,
            yte,
            test_clusters,
            info,
        });
    }
    Ok(sides)
}

/// The model entry of `spec` named `label`, its config and its threshold rule.
fn model_of<'s>(
    spec: &'s ExperimentSpec,
    label: &str,
) -> Result<(&'s crate::spec::ModelEntry, ModelConfig, ThresholdRule), ForecastError> {
    let entry = spec
        .models
        .iter()
        .find(|m| m.label() == label)
        .ok_or_else(|| ForecastError::Model(format!("the experiment has no model `{label}`")))?;
    let config = ModelConfig::parse(&entry.kind, &entry.params)?.with_threads(spec.threads, &entry.params);
    let rule = entry.threshold.unwrap_or_else(|| config.default_threshold());
    Ok((entry, config, rule))
}

fn side_of<'a>(sides: &'a [ProtocolSide], name: &str) -> Result<&'a ProtocolSide, ForecastError> {
    sides
        .iter()
        .find(|s| s.name == name)
        .ok_or_else(|| ForecastError::Model(format!("the experiment has no protocol `{name}`")))
}

/// A unit's threshold (chosen on its validation scores) and its test and validation reports.
fn score(
    side: &ProtocolSide,
    val: &[f64],
    test: &[f64],
    rule: ThresholdRule,
    evaluation: &Evaluation,
) -> (f64, BinaryReport, BinaryReport) {
    let bins = evaluation.calibration_bins;
    let threshold = firecast_eval::metrics::choose_threshold(&side.yva, val, eval_rule(rule));
    let report = firecast_eval::metrics::evaluate(&side.yte, test, threshold, bins);
    let validation = firecast_eval::metrics::evaluate(&side.yva, val, threshold, bins);
    (threshold, report, validation)
}

/// Where a unit's fitted model is saved, relative to the report folder.
fn model_dir(unit: &Unit) -> String {
    format!("models/{}/{}/seed-{}", unit.protocol, unit.model, unit.seed)
}

/// Fits `units` in order, saving each fitted model under `out/models/…`, and returns their
/// scores. Reports per-unit metrics (test metrics at step = seed, fit seconds, curves).
pub fn fit_units(
    spec: &ExperimentSpec,
    windows: &Windows,
    sides: &[ProtocolSide],
    units: &[Unit],
    device: tch::Device,
    out: &Path,
    sink: &dyn Sink,
) -> Result<Vec<UnitScores>, ForecastError> {
    let all_features: Vec<usize> = (0..windows.n_features()).collect();
    let meta = |rows: &[usize]| rows.iter().map(|&s| &windows.meta[s]).collect::<Vec<_>>();
    // Units come protocol by protocol: one protocol's blocks at a time, each cut once.
    let mut blocks: Option<(&str, [Block; 3])> = None;
    let mut scores = Vec::with_capacity(units.len());
    for (done, unit) in units.iter().enumerate() {
        let side = side_of(sides, &unit.protocol)?;
        let (entry, config, rule) = model_of(spec, &unit.model)?;
        if blocks.as_ref().is_some_and(|(p, _)| *p != side.name) {
            blocks = None;
        }
        let (_, [btr, bva, bte]) = blocks.get_or_insert_with(|| {
            let cut = |rows: &[usize]| Block::cut(windows, side.days.clone(), &all_features, rows);
            (
                &side.name,
                [
                    cut(&side.split.train),
                    cut(&side.split.val),
                    cut(&side.split.test),
                ],
            )
        });
        let (btr, bva, bte) = (&*btr, &*bva, &*bte);
        let (pname, label, seed) = (&unit.protocol, &unit.model, unit.seed);
        let what = format!("{pname}/{label}/seed {seed}");
        let progress =
            |done: u64, total: u64, step: &str| sink.progress(&format!("{what} {step}"), done, total);
        let curve_prefix = format!("{pname}/{label}/seed{seed}");
        let recorded: std::sync::Mutex<BTreeMap<String, Vec<(i64, f64)>>> = Default::default();
        let curve = |epoch: i64, k: &str, v: f64| {
            sink.metric(&format!("{curve_prefix}/{k}"), epoch, v);
            recorded
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .entry(k.to_string())
                .or_default()
                .push((epoch, v));
        };
        let ctx = FitContext {
            train: Inputs {
                block: btr,
                meta: meta(&side.split.train),
            },
            train_labels: &side.ytr,
            val: Inputs {
                block: bva,
                meta: meta(&side.split.val),
            },
            val_labels: &side.yva,
            seed,
            device,
            progress: &progress,
            curve: &curve,
        };
        let t0 = Instant::now();
        let trained = crate::models::fit(&config, &ctx).map_err(|e| e.in_model(label))?;
        let fit_seconds = t0.elapsed().as_secs_f64();
        let val_inputs = Inputs {
            block: bva,
            meta: meta(&side.split.val),
        };
        let test_inputs = Inputs {
            block: bte,
            meta: meta(&side.split.test),
        };
        let pv = trained
            .predict(&val_inputs, device)
            .map_err(|e| e.in_model(label))?;
        let pt = trained
            .predict(&test_inputs, device)
            .map_err(|e| e.in_model(label))?;
        let (threshold, report, validation) = score(side, &pv, &pt, rule, &spec.evaluation);
        crate::bundle::save(
            &out.join(model_dir(unit)),
            &crate::bundle::BundleInfo {
                model: label.clone(),
                kind: entry.kind.clone(),
                protocol: pname.clone(),
                days: side.info.days,
                seed,
                threshold,
                threshold_rule: rule_label(rule),
                dataset: windows.manifest.name.clone(),
                dataset_version: windows.manifest.version.clone(),
                validation_auprc: validation.auprc,
                validation_auroc: validation.auroc,
                test_auroc: report.auroc,
                features: btr.features.clone(),
                training_extent: crate::bundle::TrainingExtent::of(
                    side.split.train.iter().map(|&s| &windows.meta[s]),
                )
                .map(|e| {
                    e.with_area_fires(
                        side.split
                            .train
                            .iter()
                            .chain(&side.split.val)
                            .map(|&s| &windows.meta[s]),
                    )
                }),
            },
            &trained,
        )?;
        let (epochs, best_epoch) = match &trained {
            Trained::Neural(n) => (Some(n.epochs_run), Some(n.best_epoch)),
            _ => (None, None),
        };
        for (k, v) in report_metrics(&report) {
            sink.metric(&format!("{pname}/{label}/test/{k}"), seed as i64, v);
        }
        // Times go to the registry and the log only: the stage's files stay the same bytes
        // for the same config and seeds.
        sink.metric(&format!("{pname}/{label}/fit_seconds"), seed as i64, fit_seconds);
        sink.progress("experiment", done as u64 + 1, units.len() as u64);
        sink.message(&format!(
            "{what}: test AUROC {:.3} AUPRC {:.3} acc {:.3} (threshold {threshold:.3}, {fit_seconds:.1} s)",
            report.auroc.unwrap_or(f64::NAN),
            report.auprc.unwrap_or(f64::NAN),
            report.accuracy
        ));
        scores.push(UnitScores {
            unit: unit.clone(),
            val: pv,
            test: pt,
            epochs,
            best_epoch,
            parameters: trained.parameter_count(),
            curves: recorded.into_inner().unwrap_or_else(|e| e.into_inner()),
        });
    }
    Ok(scores)
}

/// Table III from every unit's scores (`scores[k]` is unit `k` of [`units`]): thresholds and
/// reports per seed, seed means with cluster-bootstrap intervals, breakdowns, skill against
/// the oracle, and per protocol the paired test of the best model against the best baseline.
pub fn assemble(
    spec: &ExperimentSpec,
    windows: &Windows,
    sides: &[ProtocolSide],
    scores: Vec<UnitScores>,
    device: &str,
    sink: &dyn Sink,
) -> Result<(ExperimentResult, Vec<ProtocolPredictions>), ForecastError> {
    let expected = units(spec)?;
    if scores.len() != expected.len() || scores.iter().zip(&expected).any(|(s, u)| s.unit != *u) {
        return Err(ForecastError::Model(format!(
            "the scores cover {} units, not the experiment's {} in order",
            scores.len(),
            expected.len()
        )));
    }
    let mut scores = scores.into_iter().peekable();
    let mut results = Vec::new();
    let mut paired = Vec::new();
    let mut all_comparisons = Vec::new();
    let mut predictions = Vec::new();
    for side in sides {
        let pname = &side.name;
        let mut test_scores: Vec<ModelScores> = Vec::new();
        for entry in &spec.models {
            let label = entry.label();
            let (_, _, rule) = model_of(spec, &label)?;
            let mut runs = Vec::new();
            let mut per_seed_scores = Vec::new();
            let mut seeds = Vec::new();
            let mut parameters = None;
            while let Some(unit) = scores.next_if(|s| s.unit.protocol == *pname && s.unit.model == label) {
                if unit.val.len() != side.yva.len() || unit.test.len() != side.yte.len() {
                    return Err(ForecastError::Model(format!(
                        "{}: {} validation and {} test scores for {} and {} samples",
                        unit.unit,
                        unit.val.len(),
                        unit.test.len(),
                        side.yva.len(),
                        side.yte.len()
                    )));
                }
                let (threshold, report, validation) =
                    score(side, &unit.val, &unit.test, rule, &spec.evaluation);
                seeds.push(unit.unit.seed);
                parameters = unit.parameters;
                runs.push(SeedRun {
                    seed: unit.unit.seed,
                    threshold,
                    threshold_rule: rule_label(rule),
                    report,
                    validation: Some(validation),
                    epochs: unit.epochs,
                    best_epoch: unit.best_epoch,
                    model_dir: model_dir(&unit.unit),
                    curves: unit.curves,
                });
                per_seed_scores.push(unit.test);
            }
            let thresholds: Vec<f64> = runs.iter().map(|r| r.threshold).collect();
            results.push(summarise(
                TestSide {
                    protocol: pname,
                    windows,
                    rows: &side.split.test,
                    labels: &side.yte,
                    clusters: &side.test_clusters,
                    oracle: side.info.oracle.as_ref(),
                },
                &label,
                &entry.kind,
                seeds,
                runs,
                &per_seed_scores,
                parameters,
                &spec.evaluation,
            ));
            test_scores.push((label, entry.kind.clone(), per_seed_scores, thresholds));
        }
        let paired_result = paired_test(
            pname,
            &results,
            &test_scores,
            &side.yte,
            &side.test_clusters,
            &spec.evaluation,
        );
        all_comparisons.extend(comparisons(
            pname,
            &results,
            &test_scores,
            &side.yte,
            &side.test_clusters,
            &spec.evaluation,
        ));
        predictions.push(ProtocolPredictions {
            protocol: pname.clone(),
            sample_ids: side
                .split
                .test
                .iter()
                .map(|&s| windows.meta[s].sample_id)
                .collect(),
            labels: side.yte.clone(),
            models: test_scores.into_iter().map(|(m, _, s, t)| (m, s, t)).collect(),
        });
        if let Some(test) = paired_result {
            sink.message(&format!(
                "{pname}: {} vs {}: McNemar p = {:.2e}, DeLong p = {:.2e}, ΔAUPRC = {:+.3} [{:+.3}, {:+.3}]",
                test.model,
                test.baseline,
                test.mcnemar_p,
                test.delong_p,
                test.auprc_diff,
                test.auprc_diff_interval.0,
                test.auprc_diff_interval.1
            ));
            paired.push(test);
        }
    }
    let result = ExperimentResult {
        name: spec.name.clone(),
        dataset: windows.manifest.name.clone(),
        dataset_version: windows.manifest.version.clone(),
        framing: format!("{:?}", windows.manifest.framing.kind).to_lowercase(),
        headline: spec.headline_protocol().to_string(),
        device: device.to_string(),
        bootstrap: spec.evaluation.bootstrap,
        level: spec.evaluation.level,
        cluster: format!("{:?}", spec.evaluation.cluster).to_lowercase(),
        protocols: sides.iter().map(|s| s.info.clone()).collect(),
        results,
        paired,
        comparisons: all_comparisons,
    };
    Ok((result, predictions))
}

/// How an experiment names its device in `results.json`.
pub fn device_label(device: tch::Device) -> String {
    format!("{device:?}")
}

/// Runs the whole experiment on `windows` in this process; fitted models go under
/// `out/models/`.
pub fn run(
    spec: &ExperimentSpec,
    windows: &Windows,
    device: tch::Device,
    out: &Path,
    sink: &dyn Sink,
) -> Result<(ExperimentResult, Vec<ProtocolPredictions>), ForecastError> {
    let started = Instant::now();
    let sides = prepare(spec, windows, sink)?;
    let scores = fit_units(spec, windows, &sides, &units(spec)?, device, out, sink)?;
    let done = assemble(spec, windows, &sides, scores, &device_label(device), sink)?;
    sink.metric("experiment_seconds", 0, started.elapsed().as_secs_f64());
    Ok(done)
}

/// The scored side of one protocol: which samples, their labels and bootstrap clusters.
pub(crate) struct TestSide<'a> {
    pub protocol: &'a str,
    pub windows: &'a Windows,
    /// Sample indices into `windows`.
    pub rows: &'a [usize],
    pub labels: &'a [bool],
    pub clusters: &'a [u64],
    pub oracle: Option<&'a BTreeMap<String, f64>>,
}

/// One model's row: seed-averaged metrics with intervals, spread over seeds, breakdowns by
/// year and tier (first seed), and skill as a share of the oracle's.
#[allow(clippy::too_many_arguments)]
pub(crate) fn summarise(
    side: TestSide<'_>,
    label: &str,
    kind: &str,
    seeds: Vec<u64>,
    runs: Vec<SeedRun>,
    per_seed_scores: &[Vec<f64>],
    parameters: Option<i64>,
    evaluation: &Evaluation,
) -> ModelResult {
    let yte = side.labels;
    let thresholds: Vec<f64> = runs.iter().map(|r| r.threshold).collect();
    let (test, intervals) =
        seed_mean_with_intervals(yte, per_seed_scores, &thresholds, side.clusters, evaluation);
    let mut seed_std = BTreeMap::new();
    for k in TABLE_METRICS {
        let vals: Vec<f64> = runs.iter().map(|r| report_metrics(&r.report)[k]).collect();
        let mean = vals.iter().sum::<f64>() / vals.len() as f64;
        let var = vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (vals.len().max(2) - 1) as f64;
        seed_std.insert(k.to_string(), if vals.len() > 1 { var.sqrt() } else { 0.0 });
    }
    let by_year = breakdown_by_year(side.windows, side.rows, yte, &per_seed_scores[0], thresholds[0]);
    let by_tier = breakdown_by_tier(side.windows, side.rows, yte, &per_seed_scores[0], thresholds[0]);
    let prevalence = yte.iter().filter(|&&l| l).count() as f64 / yte.len().max(1) as f64;
    // Skill above no skill as a share of the oracle's: (m − m₀) / (oracle − m₀).
    let skill_vs_oracle = side.oracle.map(|o| {
        [("auroc", 0.5), ("auprc", prevalence)]
            .into_iter()
            .map(|(k, none)| {
                let m = test.get(k).copied().unwrap_or(f64::NAN);
                (k.to_string(), (m - none) / (o[k] - none))
            })
            .collect::<BTreeMap<_, _>>()
    });
    ModelResult {
        protocol: side.protocol.to_string(),
        model: label.to_string(),
        kind: kind.to_string(),
        family: family(kind).into(),
        seeds,
        test,
        intervals,
        seed_std,
        runs,
        by_year,
        by_tier,
        parameters,
        skill_vs_oracle,
    }
}

/// Seed-averaged metrics and their bootstrap intervals: on each resample of the test
/// clusters, every seed's metric is computed on the same samples and averaged.
fn seed_mean_with_intervals(
    y: &[bool],
    scores: &[Vec<f64>],
    thresholds: &[f64],
    clusters: &[u64],
    evaluation: &Evaluation,
) -> (BTreeMap<String, f64>, BTreeMap<String, (f64, f64)>) {
    let bins = evaluation.calibration_bins;
    let mean_metric = |name: &str, idx: Option<&[usize]>| -> Option<f64> {
        let mut sum = 0.0;
        for (p, &t) in scores.iter().zip(thresholds) {
            let v = match idx {
                Some(idx) => {
                    let yy: Vec<bool> = idx.iter().map(|&i| y[i]).collect();
                    let pp: Vec<f64> = idx.iter().map(|&i| p[i]).collect();
                    metric_of(name, &yy, &pp, t, bins)?
                }
                None => metric_of(name, y, p, t, bins)?,
            };
            sum += v;
        }
        Some(sum / scores.len() as f64)
    };
    let mut point = BTreeMap::new();
    for k in TABLE_METRICS {
        point.insert(k.to_string(), mean_metric(k, None).unwrap_or(f64::NAN));
    }
    let resamples = firecast_eval::bootstrap::resample_indices(
        y.len(),
        Some(clusters),
        evaluation.bootstrap,
        evaluation.seed,
    );
    let mut draws: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for idx in &resamples {
        for k in TABLE_METRICS {
            if let Some(v) = mean_metric(k, Some(idx)) {
                draws.entry(k).or_default().push(v);
            }
        }
    }
    let alpha = (1.0 - evaluation.level) / 2.0;
    let intervals = draws
        .into_iter()
        .map(|(k, mut v)| {
            v.sort_by(f64::total_cmp);
            (
                k.to_string(),
                (percentile(&v, alpha), percentile(&v, 1.0 - alpha)),
            )
        })
        .collect();
    (point, intervals)
}

/// Percentile with linear interpolation (NumPy's default).
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let pos = q * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
}

fn breakdown_by_year(
    w: &Windows,
    idx: &[usize],
    y: &[bool],
    p: &[f64],
    threshold: f64,
) -> BTreeMap<String, BTreeMap<String, f64>> {
    let mut groups: BTreeMap<i32, Vec<usize>> = BTreeMap::new();
    for (i, &s) in idx.iter().enumerate() {
        groups.entry(w.meta[s].year).or_default().push(i);
    }
    groups
        .into_iter()
        .map(|(year, members)| {
            let yy: Vec<bool> = members.iter().map(|&i| y[i]).collect();
            let pp: Vec<f64> = members.iter().map(|&i| p[i]).collect();
            let mut m = BTreeMap::new();
            m.insert("n".into(), yy.len() as f64);
            m.insert("positives".into(), yy.iter().filter(|&&l| l).count() as f64);
            for k in ["accuracy", "auroc", "auprc"] {
                if let Some(v) = metric_of(k, &yy, &pp, threshold, 10) {
                    m.insert(k.into(), v);
                }
            }
            (year.to_string(), m)
        })
        .collect()
}

/// Per negative tier: accuracy on that tier's negatives (specificity) and the AUROC of
/// all positives against them, which shows whether a model only separates easy negatives.
fn breakdown_by_tier(
    w: &Windows,
    idx: &[usize],
    y: &[bool],
    p: &[f64],
    threshold: f64,
) -> BTreeMap<String, BTreeMap<String, f64>> {
    let mut tiers: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
    for (i, &s) in idx.iter().enumerate() {
        tiers.entry(w.meta[s].tier.as_str()).or_default().push(i);
    }
    let pos: Vec<usize> = (0..y.len()).filter(|&i| y[i]).collect();
    tiers
        .into_iter()
        .map(|(tier, members)| {
            let mut m = BTreeMap::new();
            m.insert("n".into(), members.len() as f64);
            let correct = members.iter().filter(|&&i| (p[i] > threshold) == y[i]).count();
            m.insert("accuracy".into(), correct as f64 / members.len().max(1) as f64);
            if !members.iter().all(|&i| y[i]) {
                let set: Vec<usize> = pos.iter().chain(members.iter()).copied().collect();
                let yy: Vec<bool> = set.iter().map(|&i| y[i]).collect();
                let pp: Vec<f64> = set.iter().map(|&i| p[i]).collect();
                if let Some(a) = firecast_eval::metrics::roc_auc(&yy, &pp) {
                    m.insert("auroc_vs_positives".into(), a);
                }
            }
            (tier.to_string(), m)
        })
        .collect()
}

/// The protocol's best model by mean test AUROC and the best other model of the paper's
/// baselines and references (the majority rule left out).
fn best_and_baseline<'a>(
    protocol: &str,
    results: &'a [ModelResult],
) -> Option<(&'a ModelResult, &'a ModelResult)> {
    let auroc = |r: &ModelResult| r.test.get("auroc").copied().unwrap_or(f64::NAN);
    let here = || {
        results
            .iter()
            .filter(move |r| r.protocol == protocol && auroc(r).is_finite())
    };
    let best = here().max_by(|a, b| auroc(a).total_cmp(&auroc(b)))?;
    let baseline = here()
        .filter(|r| {
            r.model != best.model
                && matches!(r.family.as_str(), "paper_baseline" | "reference")
                && r.kind != "majority"
        })
        .max_by(|a, b| auroc(a).total_cmp(&auroc(b)))?;
    Some((best, baseline))
}

/// The best model (by mean test AUROC) against the best other model of the paper's
/// baselines and references, on the first seed's scores.
pub(crate) fn paired_test(
    protocol: &str,
    results: &[ModelResult],
    scores: &[ModelScores],
    y: &[bool],
    clusters: &[u64],
    evaluation: &Evaluation,
) -> Option<PairedTest> {
    let (best, baseline) = best_and_baseline(protocol, results)?;
    let find = |name: &str| scores.iter().find(|s| s.0 == name);
    let (_, _, sa, ta) = find(&best.model)?;
    let (_, _, sb, tb) = find(&baseline.model)?;
    let (pa, pb) = (&sa[0], &sb[0]);
    let pred_a: Vec<bool> = pa.iter().map(|p| *p > ta[0]).collect();
    let pred_b: Vec<bool> = pb.iter().map(|p| *p > tb[0]).collect();
    let mc = firecast_eval::tests::mcnemar(y, &pred_a, &pred_b).ok()?;
    let dl = firecast_eval::tests::delong(y, pa, pb).ok()?;
    let diff = firecast_eval::bootstrap::paired_diff_ci(
        y,
        pa,
        pb,
        Some(clusters),
        evaluation.bootstrap,
        evaluation.seed,
        evaluation.level,
        firecast_eval::metrics::average_precision,
    )
    .ok()?;
    Some(PairedTest {
        protocol: protocol.into(),
        model: best.model.clone(),
        baseline: baseline.model.clone(),
        mcnemar_b: mc.b,
        mcnemar_c: mc.c,
        mcnemar_p: mc.p_value,
        mcnemar_exact: mc.exact,
        delong_auroc_diff: dl.diff,
        delong_p: dl.p_value,
        auprc_diff: diff.estimate,
        auprc_diff_interval: (diff.low, diff.high),
        prob_model_better_auprc: diff.prob_a_better,
    })
}

/// FireCast's recommended forecaster in a protocol: of the `firecast` family, the one with
/// the highest mean validation AUROC (chosen on validation data only; the first listed when
/// none has a validation score).
pub fn recommended_forecaster<'a>(protocol: &str, results: &'a [ModelResult]) -> Option<&'a ModelResult> {
    let validation = |r: &ModelResult| {
        let v: Vec<f64> = r
            .runs
            .iter()
            .filter_map(|s| s.validation.as_ref().and_then(|v| v.auroc))
            .collect();
        if v.is_empty() {
            f64::NEG_INFINITY
        } else {
            v.iter().sum::<f64>() / v.len() as f64
        }
    };
    let mut best: Option<&ModelResult> = None;
    for r in results
        .iter()
        .filter(|r| r.protocol == protocol && r.family == "firecast")
    {
        if best.is_none_or(|b| validation(r) > validation(b)) {
            best = Some(r);
        }
    }
    best
}

/// Two models' per-seed scores as seed pairs: seed i with seed i, or a deterministic model's
/// one run with each seed of the other.
pub(crate) fn seed_pairs(a: &[Vec<f64>], b: &[Vec<f64>]) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let k = if a.len() == 1 || b.len() == 1 {
        a.len().max(b.len())
    } else {
        a.len().min(b.len())
    };
    let pick = |v: &[Vec<f64>]| -> Vec<Vec<f64>> { (0..k).map(|i| v[i.min(v.len() - 1)].clone()).collect() };
    (pick(a), pick(b))
}

/// The protocol's paired comparisons over all seeds: FireCast's recommended forecaster
/// against every other model (the majority rule included: its AUROC is 0.5), and the best
/// model by test AUROC against the best of the paper's baselines and references; Holm's
/// correction over all of them.
pub(crate) fn comparisons(
    protocol: &str,
    results: &[ModelResult],
    scores: &[ModelScores],
    y: &[bool],
    clusters: &[u64],
    evaluation: &Evaluation,
) -> Vec<Comparison> {
    let here: Vec<&ModelResult> = results.iter().filter(|r| r.protocol == protocol).collect();
    let mut pairs: Vec<(String, String, Vec<String>)> = Vec::new();
    let mut ask = |model: &str, other: &str, question: &str| {
        if let Some(p) = pairs.iter_mut().find(|p| p.0 == model && p.1 == other) {
            p.2.push(question.to_string());
        } else {
            pairs.push((model.to_string(), other.to_string(), vec![question.to_string()]));
        }
    };
    if let Some(focus) = recommended_forecaster(protocol, results) {
        for r in here.iter().filter(|r| r.model != focus.model) {
            ask(&focus.model, &r.model, "firecast_vs_model");
        }
    }
    if let Some((best, baseline)) = best_and_baseline(protocol, results) {
        ask(&best.model, &baseline.model, "best_vs_best_baseline");
    }
    let find = |name: &str| scores.iter().find(|s| s.0 == name).map(|s| &s.2);
    let mut out: Vec<Comparison> = Vec::new();
    for (model, other, questions) in pairs {
        let (Some(a), Some(b)) = (find(&model), find(&other)) else {
            continue;
        };
        let (a, b) = seed_pairs(a, b);
        let (a, b) = (a.as_slice(), b.as_slice());
        let ci = |statistic: fn(&[bool], &[f64]) -> Option<f64>| {
            firecast_eval::bootstrap::paired_diff_ci_seeds(
                y,
                a,
                b,
                Some(clusters),
                evaluation.bootstrap,
                evaluation.seed,
                evaluation.level,
                statistic,
            )
            .ok()
        };
        let (Some(roc), Some(pr)) = (
            ci(firecast_eval::metrics::roc_auc),
            ci(firecast_eval::metrics::average_precision),
        ) else {
            continue;
        };
        let delong_p = a
            .iter()
            .zip(b)
            .map(|(pa, pb)| {
                firecast_eval::tests::delong(y, pa, pb)
                    .ok()
                    .map(|d| d.p_value)
                    .filter(|p| p.is_finite())
            })
            .collect();
        out.push(Comparison {
            protocol: protocol.to_string(),
            questions,
            model,
            other,
            seeds: a.len(),
            auroc_diff: roc.interval.estimate,
            auroc_diff_interval: (roc.interval.low, roc.interval.high),
            auprc_diff: pr.interval.estimate,
            auprc_diff_interval: (pr.interval.low, pr.interval.high),
            p_value: roc.p_value,
            p_holm: f64::NAN,
            delong_p,
        });
    }
    let adjusted = firecast_eval::tests::holm(&out.iter().map(|c| c.p_value).collect::<Vec<_>>());
    for (c, p) in out.iter_mut().zip(adjusted) {
        c.p_holm = p;
    }
    out
}

/// Where a run's outputs go.
pub fn output_paths(out: &Path) -> BTreeMap<&'static str, PathBuf> {
    BTreeMap::from([
        ("results", out.join("results.json")),
        ("table_md", out.join("table3.md")),
        ("table_csv", out.join("table3.csv")),
        ("metrics", out.join("metrics.json")),
        ("plots", out.join("plots")),
        ("models", out.join("models")),
    ])
}
