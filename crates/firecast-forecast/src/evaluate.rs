//! Saved models scored on another dataset (`forecast.evaluate`): do the models of one
//! experiment hold on a later year, another region, or the published CSV? Every saved seed
//! of every model is asked about the chosen samples with the threshold it was saved with;
//! the table, intervals, paired test and plots are the experiment's own.
//!
//! A model is never scored on the dataset version it was trained on: the experiment already
//! reports its held-out side, and any other side would mix in training samples.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::ForecastError;
use crate::bundle::{Bundle, MODEL_FILE};
use crate::data::{Block, Windows};
use crate::experiment::{
    ExperimentResult, ModelScores, ProtocolInfo, ProtocolPredictions, SeedRun, Sink, TestSide,
};
use crate::inputs::Inputs;
use crate::spec::Evaluation;

/// Which samples of the dataset are scored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// Every sample.
    #[default]
    All,
    /// The dataset's own `train` / `val` / `test` split column.
    Train,
    Val,
    Test,
}

impl Side {
    fn name(self) -> &'static str {
        match self {
            Side::All => "all",
            Side::Train => "train",
            Side::Val => "val",
            Side::Test => "test",
        }
    }
}

/// Params of `forecast.evaluate` (and `firecast forecast evaluate`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvaluateParams {
    /// Names the report.
    #[serde(default = "default_name")]
    pub name: String,
    #[serde(default)]
    pub side: Side,
    /// Only these models (by name); all when empty.
    #[serde(default)]
    pub models: Vec<String>,
    #[serde(default)]
    pub evaluation: Evaluation,
    /// `auto`, `cpu`, `cuda`, `cuda:N`.
    #[serde(default = "default_device")]
    pub device: String,
    /// libtorch threads: part of the result, so part of the cache key; a fixed default, not
    /// the machine's core count.
    #[serde(default = "firecast_learn::default_threads")]
    pub threads: usize,
}

fn default_name() -> String {
    "evaluate".into()
}
fn default_device() -> String {
    "auto".into()
}

impl Default for EvaluateParams {
    fn default() -> Self {
        Self {
            name: default_name(),
            side: Side::All,
            models: Vec::new(),
            evaluation: Evaluation::default(),
            device: default_device(),
            threads: firecast_learn::DEFAULT_THREADS,
        }
    }
}

/// Every `model.json` folder under `root` (or `root` itself), in path order.
pub fn find_bundles(root: &Path) -> Result<Vec<PathBuf>, ForecastError> {
    if root.join(MODEL_FILE).is_file() {
        return Ok(vec![root.to_path_buf()]);
    }
    let mut found = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let entries = std::fs::read_dir(&dir).map_err(ForecastError::io("reading", &dir))?;
        for entry in entries {
            let path = entry.map_err(ForecastError::io("reading", &dir))?.path();
            if path.is_dir() {
                if path.join(MODEL_FILE).is_file() {
                    found.push(path);
                } else {
                    stack.push(path);
                }
            }
        }
    }
    found.sort();
    if found.is_empty() {
        return Err(ForecastError::Data {
            path: root.to_path_buf(),
            message: format!("no saved model ({MODEL_FILE}) in this folder or below it"),
        });
    }
    Ok(found)
}

/// Scores the saved models under `models` on `windows`.
pub fn evaluate(
    models: &Path,
    windows: &Windows,
    params: &EvaluateParams,
    device: tch::Device,
    sink: &dyn Sink,
) -> Result<(ExperimentResult, Vec<ProtocolPredictions>), ForecastError> {
    let rows: Vec<usize> = (0..windows.len())
        .filter(|&s| match params.side {
            Side::All => true,
            side => windows.meta[s].dataset_split.as_deref() == Some(side.name()),
        })
        .collect();
    let labels: Vec<bool> = rows.iter().map(|&s| windows.labels[s]).collect();
    let positives = labels.iter().filter(|&&l| l).count();
    if positives == 0 || positives == labels.len() {
        return Err(ForecastError::Config {
            key: "side".into(),
            message: format!(
                "the `{}` side of dataset {} holds {} samples, {positives} of them positive: \
                 scoring needs both classes",
                params.side.name(),
                windows.manifest.name,
                labels.len()
            ),
        });
    }
    // (protocol, model) → its seeds' bundles, in path order.
    let mut groups: BTreeMap<(String, String), Vec<Bundle>> = BTreeMap::new();
    for dir in find_bundles(models)? {
        let bundle = crate::bundle::load(&dir, device)?;
        if !params.models.is_empty() && !params.models.contains(&bundle.info.model) {
            continue;
        }
        if bundle.info.dataset_version == windows.manifest.version {
            return Err(ForecastError::Data {
                path: dir,
                message: format!(
                    "this model was trained on dataset {} {}, the one to score it on: its \
                     experiment already reports the held-out side; evaluate on another dataset",
                    bundle.info.dataset, bundle.info.dataset_version
                ),
            });
        }
        groups
            .entry((bundle.info.protocol.clone(), bundle.info.model.clone()))
            .or_default()
            .push(bundle);
    }
    for wanted in &params.models {
        if !groups.keys().any(|(_, m)| m == wanted) {
            return Err(ForecastError::Config {
                key: "models".into(),
                message: format!("no saved model named `{wanted}` under {}", models.display()),
            });
        }
    }
    let clusters = crate::experiment::clusters(windows, &rows, params.evaluation.cluster);
    let prevalence = positives as f64 / labels.len() as f64;
    let oracle = crate::experiment::oracle(windows, &rows, &labels);
    let meta: Vec<_> = rows.iter().map(|&s| &windows.meta[s]).collect();

    let mut protocols: Vec<ProtocolInfo> = Vec::new();
    let mut results = Vec::new();
    let mut scores_by_protocol: BTreeMap<String, Vec<ModelScores>> = BTreeMap::new();
    let total: usize = groups.values().map(Vec::len).sum();
    let mut done = 0usize;
    for ((protocol, model), bundles) in &groups {
        let days = bundles[0].info.days;
        let trained_on = format!("{} {}", bundles[0].info.dataset, bundles[0].info.dataset_version);
        if !protocols.iter().any(|p| &p.name == protocol) {
            protocols.push(ProtocolInfo {
                name: protocol.clone(),
                days,
                split: format!(
                    "saved models (trained on {trained_on}) scored on the {} side of {} {}",
                    params.side.name(),
                    windows.manifest.name,
                    windows.manifest.version
                ),
                train: 0,
                val: 0,
                test: rows.len(),
                dropped: 0,
                test_positives: positives,
                prevalence,
                majority_accuracy: prevalence.max(1.0 - prevalence),
                leaks_future: days.1 >= 0,
                oracle: oracle.clone(),
            });
        }
        let mut runs = Vec::new();
        let mut per_seed = Vec::new();
        let mut parameters = None;
        for bundle in bundles {
            let info = &bundle.info;
            let what = format!("{}", bundle.dir.display());
            if info.days != days {
                return Err(ForecastError::Data {
                    path: bundle.dir.join(MODEL_FILE),
                    message: format!(
                        "input days {:?} differ from the other seeds' {days:?} of {protocol}/{model}",
                        info.days
                    ),
                });
            }
            let slots = windows.day_range(info.days.0, info.days.1, &format!("{what}: days"))?;
            let features = info
                .features
                .iter()
                .map(|f| {
                    windows.feature_index(f).ok_or_else(|| ForecastError::Data {
                        path: bundle.dir.join(MODEL_FILE),
                        message: format!(
                            "the model reads `{f}`, which dataset {} lacks (it has {})",
                            windows.manifest.name,
                            windows.features.join(", ")
                        ),
                    })
                })
                .collect::<Result<Vec<_>, _>>()?;
            let block = Block::cut(windows, slots, &features, &rows);
            let p = bundle
                .model
                .predict(
                    &Inputs {
                        block: &block,
                        meta: meta.clone(),
                    },
                    device,
                )
                .map_err(|e| e.in_model(model))?;
            let report = firecast_eval::metrics::evaluate(
                &labels,
                &p,
                info.threshold,
                params.evaluation.calibration_bins,
            );
            for (k, v) in crate::experiment::report_metrics(&report) {
                sink.metric(&format!("{protocol}/{model}/test/{k}"), info.seed as i64, v);
            }
            done += 1;
            sink.progress("evaluate", done as u64, total as u64);
            sink.message(&format!(
                "{protocol}/{model}/seed {}: AUROC {:.3} AUPRC {:.3} acc {:.3} (saved threshold {:.3})",
                info.seed,
                report.auroc.unwrap_or(f64::NAN),
                report.auprc.unwrap_or(f64::NAN),
                report.accuracy,
                info.threshold
            ));
            parameters = bundle.model.parameter_count();
            runs.push(SeedRun {
                seed: info.seed,
                threshold: info.threshold,
                threshold_rule: format!("saved with the model ({})", info.threshold_rule),
                report,
                validation: None,
                epochs: None,
                best_epoch: None,
                model_dir: bundle.dir.display().to_string(),
                curves: BTreeMap::new(),
            });
            per_seed.push(p);
        }
        let thresholds: Vec<f64> = runs.iter().map(|r| r.threshold).collect();
        let seeds = runs.iter().map(|r| r.seed).collect();
        let kind = bundles[0].info.kind.clone();
        results.push(crate::experiment::summarise(
            TestSide {
                protocol,
                windows,
                rows: &rows,
                labels: &labels,
                clusters: &clusters,
                oracle: oracle.as_ref(),
            },
            model,
            &kind,
            seeds,
            runs,
            &per_seed,
            parameters,
            &params.evaluation,
        ));
        scores_by_protocol.entry(protocol.clone()).or_default().push((
            model.clone(),
            kind,
            per_seed,
            thresholds,
        ));
    }
    let mut paired = Vec::new();
    let mut comparisons = Vec::new();
    let mut predictions = Vec::new();
    for p in &protocols {
        let scores = scores_by_protocol.remove(&p.name).unwrap_or_default();
        if let Some(t) =
            crate::experiment::paired_test(&p.name, &results, &scores, &labels, &clusters, &params.evaluation)
        {
            paired.push(t);
        }
        comparisons.extend(crate::experiment::comparisons(
            &p.name,
            &results,
            &scores,
            &labels,
            &clusters,
            &params.evaluation,
        ));
        predictions.push(ProtocolPredictions {
            protocol: p.name.clone(),
            sample_ids: rows.iter().map(|&s| windows.meta[s].sample_id).collect(),
            labels: labels.clone(),
            models: scores.into_iter().map(|(m, _, s, t)| (m, s, t)).collect(),
        });
    }
    let headline = protocols
        .iter()
        .find(|p| p.name == "leak_free")
        .or(protocols.first())
        .map(|p| p.name.clone())
        .unwrap_or_default();
    Ok((
        ExperimentResult {
            name: params.name.clone(),
            dataset: windows.manifest.name.clone(),
            dataset_version: windows.manifest.version.clone(),
            framing: format!("{:?}", windows.manifest.framing.kind).to_lowercase(),
            headline,
            device: format!("{device:?}"),
            bootstrap: params.evaluation.bootstrap,
            level: params.evaluation.level,
            cluster: format!("{:?}", params.evaluation.cluster).to_lowercase(),
            protocols,
            results,
            paired,
            comparisons,
        },
        predictions,
    ))
}
