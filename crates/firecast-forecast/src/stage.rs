//! `forecast.experiment`: an experiment as a pipeline stage. Its params are the experiment
//! spec (without `dataset`, which is the stage's input), so a pipeline can build a dataset
//! and evaluate on it, with the usual caching: changing a model's params or the dataset
//! re-runs the experiment; nothing else does.
//!
//! `forecast.predict`: one place and day scored by every training seed of one model of such
//! an experiment; the seeds' mean, their range and the mean threshold.

use std::collections::BTreeMap;
use std::path::PathBuf;

use firecast_pipeline::stage::MetricsAndPlots;
use firecast_pipeline::{ParamsError, Port, Ports, StageContext, StageError, StageKind, typed_params};

use crate::experiment::Sink;
use crate::spec::ExperimentSpec;

/// Registers this crate's stage kinds: `forecast.experiment`, `forecast.evaluate`,
/// `forecast.predict`.
pub fn register(kinds: &mut firecast_pipeline::StageKinds) {
    kinds
        .register(ExperimentStage)
        .register(EvaluateStage)
        .register(PredictStage)
        .register(CellDaysStage);
}

/// `forecast.cell_days`: an experiment's saved models over all cell-days of a period.
#[derive(Debug, Default)]
pub struct CellDaysStage;

impl StageKind for CellDaysStage {
    fn name(&self) -> &'static str {
        "forecast.cell_days"
    }
    fn version(&self) -> u32 {
        // 2: AUPRC intervals over cells and the recommended forecaster's paired comparison.
        // 3: the comparison is against the best model that is not one of FireCast's own.
        3
    }
    fn summary(&self) -> &'static str {
        "saved models -> every GRIDMET cell-day of a period at the true prevalence: AUPRC, Brier and reliability after the prior correction, beside the oracle"
    }
    fn ports(&self) -> Ports {
        const IN: &[Port] = &[
            port(
                "experiment",
                true,
                "a forecast.experiment report folder (results.json and models/)",
            ),
            port(
                "dataset",
                true,
                "the dataset the experiment was trained on (its prevalence is the sampling prior)",
            ),
            port(
                "gridmet",
                true,
                "GRIDMET folder covering the period and the models' input days",
            ),
            port(
                "ignitions",
                true,
                "data.ignitions' positives (Parquet): the cell-days with an ignition",
            ),
            port(
                "truth",
                false,
                "the synthetic generator's truth folder: the oracle beside the models",
            ),
        ];
        const OUT: &[Port] = &[port(
            "report",
            true,
            "folder: cell_days.json, cell_days.md (the table), reliability.png",
        )];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (p, v) = typed_params::<crate::cell_days::CellDayParams>(raw)?;
        for (key, value) in [("from", &p.from), ("to", &p.to)] {
            if firecast_dataset::time::parse_date(value).is_none() {
                return Err(ParamsError {
                    path: key.into(),
                    message: format!("`{value}` is not a YYYY-MM-DD date"),
                });
            }
        }
        for (key, ok) in [
            ("every_days", p.every_days >= 1),
            ("reliability_bins", p.reliability_bins >= 2),
        ] {
            if !ok {
                return Err(ParamsError {
                    path: key.into(),
                    message: "is too small (every_days ≥ 1, reliability_bins ≥ 2)".into(),
                });
            }
        }
        Ok(v)
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        firecast_learn::exclusive(|| {
            let params: crate::cell_days::CellDayParams = ctx.params()?;
            let (experiment, dataset, gridmet, ignitions) = (
                ctx.input("experiment")?.to_path_buf(),
                ctx.input("dataset")?.to_path_buf(),
                ctx.input("gridmet")?.to_path_buf(),
                ctx.input("ignitions")?.to_path_buf(),
            );
            let truth = ctx.input("truth").ok().map(std::path::Path::to_path_buf);
            let out = ctx.output("report")?.to_path_buf();
            std::fs::create_dir_all(&out)?;
            let inputs = crate::cell_days::CellDayInputs {
                experiment: &experiment,
                dataset: &dataset,
                gridmet: &gridmet,
                truth: truth.as_deref(),
                ignitions: &ignitions,
            };
            let mut lines = Vec::new();
            // A bar over the models (reading the windows comes first, at 0).
            let bar = ctx.progress_bar(1, "models scored over all cell-days");
            let result = crate::cell_days::score(
                &inputs,
                &params,
                Some(&out.join("reliability.png")),
                &|line, done, total| {
                    bar.set_length(total as u64);
                    bar.set_position(done as u64);
                    ctx.log(line);
                },
            )?;
            bar.finish_and_clear();
            crate::cell_days::write(&out, &result)?;
            for row in result.oracle.iter().chain(&result.rows) {
                ctx.metric(&format!("cell_days/{}/auprc", row.model), 0, row.auprc);
                ctx.metric(&format!("cell_days/{}/brier", row.model), 0, row.brier);
                lines.push(format!(
                    "{}: AUPRC {:.4}, Brier {:.3e}, ECE {:.2e}",
                    row.model, row.auprc, row.brier, row.ece
                ));
            }
            ctx.log(format!(
                "{} cell-days, {} ignitions (prevalence {:.2e}), prior {:.2e}; {}",
                result.cell_days,
                result.ignitions,
                result.prevalence,
                result.prior,
                lines.join("; ")
            ));
            Ok(())
        })
    }
}

#[derive(Debug, Default)]
pub struct ExperimentStage;

const fn port(name: &'static str, required: bool, description: &'static str) -> Port {
    Port {
        name,
        required,
        many: false,
        description,
    }
}

/// Where an experiment stage reports: the stage's log, progress bar and metrics (finite
/// values only).
pub(crate) struct StageSink<'a, 'b> {
    ctx: &'a StageContext<'b>,
    pub(crate) bar: indicatif::ProgressBar,
}

impl<'a, 'b> StageSink<'a, 'b> {
    pub(crate) fn new(ctx: &'a StageContext<'b>, what: &str) -> Self {
        Self {
            bar: ctx.progress_bar(1, what),
            ctx,
        }
    }
}

impl Sink for StageSink<'_, '_> {
    fn progress(&self, what: &str, done: u64, total: u64) {
        if what == "experiment" {
            self.bar.set_length(total);
            self.bar.set_position(done);
        } else {
            self.bar
                .set_message(format!("{}: {what} {done}/{total}", self.ctx.stage()));
        }
    }
    fn message(&self, line: &str) {
        self.ctx.log(line);
    }
    fn metric(&self, key: &str, step: i64, value: f64) {
        if value.is_finite() {
            self.ctx.metric(key, step, value);
        }
    }
}

impl StageKind for ExperimentStage {
    fn name(&self) -> &'static str {
        "forecast.experiment"
    }
    fn version(&self) -> u32 {
        // 2: DVCLive plot files per model and protocol.
        // 3: bundles record their training fires and ignition cell-days (daily probabilities).
        3
    }
    fn summary(&self) -> &'static str {
        "ignition dataset -> Table III: every model x protocol x seed, intervals, paired tests, plots, saved models"
    }
    fn ports(&self) -> Ports {
        const IN: &[Port] = &[port("dataset", true, "ignition dataset (directory)")];
        const OUT: &[Port] = &[port(
            "report",
            true,
            "Table III, results.json, metrics, plots, models (directory)",
        )];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (spec, v) = typed_params::<ExperimentSpec>(raw)?;
        if spec.dataset.is_some() {
            return Err(ParamsError {
                path: "dataset".into(),
                message: "a stage takes its dataset from its `dataset` input".into(),
            });
        }
        spec.validate().map_err(|e| match e {
            crate::ForecastError::Config { key, message } => ParamsError { path: key, message },
            other => ParamsError {
                path: String::new(),
                message: other.to_string(),
            },
        })?;
        Ok(v)
    }
    /// `metrics.json` (`{protocol: {model: {metric: value}}}`) and, per protocol, the ROC,
    /// precision-recall and calibration curves of every model overlaid, and their confusion
    /// matrices side by side.
    fn metrics_and_plots(
        &self,
        params: &serde_json::Value,
        outputs: &BTreeMap<String, PathBuf>,
    ) -> MetricsAndPlots {
        let (Ok(spec), Some(out)) = (
            firecast_pipeline::stage::deserialize_params::<ExperimentSpec>(params),
            outputs.get("report"),
        ) else {
            return MetricsAndPlots::default();
        };
        let models: Vec<String> = spec.models.iter().map(crate::spec::ModelEntry::label).collect();
        let mut found = MetricsAndPlots {
            metrics: vec![out.join("metrics.json")],
            plots: Vec::new(),
        };
        for protocol in spec.protocols.keys() {
            for (stem, plot) in crate::plots::DVC_PLOTS {
                let files = models
                    .iter()
                    .map(|m| out.join(crate::plots::dvc_plot_file(stem, protocol, m)));
                found.plots.push(plot.plot(
                    format!("{stem}-{protocol}"),
                    &format!("{}, protocol {protocol}", spec.name),
                    files,
                ));
            }
        }
        found
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        // libtorch's one generator: stages using it run one at a time (reproducible).
        firecast_learn::exclusive(|| {
            let spec: ExperimentSpec = ctx.params()?;
            let dataset = ctx.input("dataset")?.to_path_buf();
            let out = ctx.output("report")?.to_path_buf();
            let device = crate::parse_device(&spec.device)?;
            firecast_learn::set_threads(spec.threads);
            let windows = crate::data::Windows::load(&dataset)?;
            let sink = StageSink::new(ctx, "models");
            let (result, predictions) = crate::experiment::run(&spec, &windows, device, &out, &sink)?;
            sink.bar.finish_and_clear();
            finish_experiment(ctx, &out, &result, &predictions)
        })
    }

    fn sharded(&self) -> Option<&dyn firecast_pipeline::ShardedKind> {
        Some(self)
    }
}

/// What an experiment writes and reports once every unit is scored, sharded or not: the
/// table, the plots, each row's seed-averaged test metrics, and the saved models as
/// artifacts (the run links dataset → models → metrics).
pub(crate) fn finish_experiment(
    ctx: &StageContext<'_>,
    out: &std::path::Path,
    result: &crate::experiment::ExperimentResult,
    predictions: &[crate::experiment::ProtocolPredictions],
) -> Result<(), StageError> {
    crate::table::write_all(out, result)?;
    crate::plots::write_all(out, result, predictions)?;
    for p in &result.protocols {
        for r in result.results.iter().filter(|r| r.protocol == p.name) {
            for (k, v) in &r.test {
                if v.is_finite() {
                    ctx.metric(&format!("{}/{}/{k}", p.name, r.model), 0, *v);
                }
            }
        }
    }
    if ctx.output_final_path("report").is_some() {
        for r in &result.results {
            for s in &r.runs {
                let dir = out.join(&s.model_dir);
                for file in [crate::bundle::MODEL_FILE, crate::bundle::WEIGHTS_FILE] {
                    let path = dir.join(file);
                    if path.exists() {
                        let name = format!("model/{}/{}/seed-{}", r.protocol, r.model, s.seed);
                        let _ = ctx.artifact(&name, &path)?;
                    }
                }
            }
        }
    }
    Ok(())
}

/// `forecast.evaluate`: the saved models of an experiment (its report folder, or any folder
/// of model bundles) scored on another dataset, reported like an experiment.
#[derive(Debug, Default)]
pub struct EvaluateStage;

impl StageKind for EvaluateStage {
    fn name(&self) -> &'static str {
        "forecast.evaluate"
    }
    fn version(&self) -> u32 {
        1
    }
    fn summary(&self) -> &'static str {
        "saved models + another ignition dataset -> the experiment's table, intervals, paired test and plots"
    }
    fn ports(&self) -> Ports {
        const IN: &[Port] = &[
            port(
                "models",
                true,
                "saved models: an experiment's report folder or model folders (directory)",
            ),
            port("dataset", true, "ignition dataset to score them on (directory)"),
        ];
        const OUT: &[Port] = &[port(
            "report",
            true,
            "table, results.json, metrics, plots (directory)",
        )];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (params, v) = typed_params::<crate::evaluate::EvaluateParams>(raw)?;
        crate::parse_device(&params.device).map_err(|e| ParamsError {
            path: "device".into(),
            message: e.to_string(),
        })?;
        firecast_learn::check_threads(params.threads).map_err(|message| ParamsError {
            path: "threads".into(),
            message,
        })?;
        Ok(v)
    }
    /// `metrics.json` only: which models and protocols get plot files is known once the
    /// saved models are read.
    fn metrics_and_plots(
        &self,
        _params: &serde_json::Value,
        outputs: &BTreeMap<String, PathBuf>,
    ) -> MetricsAndPlots {
        MetricsAndPlots {
            metrics: outputs
                .get("report")
                .map(|o| o.join("metrics.json"))
                .into_iter()
                .collect(),
            plots: Vec::new(),
        }
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        firecast_learn::exclusive(|| {
            let params: crate::evaluate::EvaluateParams = ctx.params()?;
            let models = ctx.input("models")?.to_path_buf();
            let dataset = ctx.input("dataset")?.to_path_buf();
            let out = ctx.output("report")?.to_path_buf();
            let device = crate::parse_device(&params.device)?;
            firecast_learn::set_threads(params.threads);
            let windows = crate::data::Windows::load(&dataset)?;
            let sink = StageSink::new(ctx, "models");
            let (result, predictions) = crate::evaluate::evaluate(&models, &windows, &params, device, &sink)?;
            sink.bar.finish_and_clear();
            crate::table::write_all(&out, &result)?;
            crate::plots::write_all(&out, &result, &predictions)?;
            Ok(())
        })
    }
}

/// Params of a `forecast.predict` stage: one place and day, one model of an experiment.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PredictParams {
    pub lat: f64,
    pub lon: f64,
    /// `YYYY-MM-DD`: the day whose ignition is predicted.
    pub date: String,
    /// The model's name in the experiment (its `name`, else its `kind`).
    pub model: String,
    /// Default: the experiment's headline protocol, else its only protocol.
    #[serde(default)]
    pub protocol: Option<String>,
    #[serde(default = "default_predict_device")]
    pub device: String,
    /// libtorch threads: part of the result, so part of the cache key; a fixed default, not
    /// the machine's core count.
    #[serde(default = "firecast_learn::default_threads")]
    pub threads: usize,
    /// With the output `map`: also the day's probability at every GRIDMET cell within this
    /// many degrees of the place (latitude and longitude), the ignition pattern around it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map_radius_deg: Option<f64>,
}

fn default_predict_device() -> String {
    "cpu".into()
}

/// Bumped when the `forecast` file layout changes.
pub const FORECAST_VERSION: u32 = 1;

/// One training seed's answer.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SeedForecast {
    pub seed: u64,
    pub probability: f64,
    pub threshold: f64,
    pub validation_auroc: Option<f64>,
    pub validation_auprc: Option<f64>,
    pub test_auroc: Option<f64>,
    /// The bundle folder, relative to the experiment folder.
    pub bundle: String,
}

/// What `forecast.predict` writes: the seeds' answers and their mean and range.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PointForecast {
    pub version: u32,
    pub lat: f64,
    pub lon: f64,
    pub date: String,
    /// The GRIDMET cell whose weather was read.
    pub cell_lat: f64,
    pub cell_lon: f64,
    pub model: String,
    pub kind: String,
    pub protocol: String,
    pub dataset: String,
    pub dataset_version: String,
    pub input_days: (i32, i32),
    /// Mean of the seeds' thresholds.
    pub threshold: f64,
    pub thresholds: Vec<f64>,
    /// Mean over seeds.
    pub probability: f64,
    /// [min, max] over seeds.
    pub interval: [f64; 2],
    pub interval_method: String,
    pub per_seed: Vec<SeedForecast>,
    /// Means over the seeds that have one (None: no seed has).
    pub validation_auroc: Option<f64>,
    pub test_auroc: Option<f64>,
    /// `probability > threshold` (both means).
    pub ignition_expected: bool,
    /// Where and when the first seed's model was trained (None for bundles that do not say).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub training_extent: Option<crate::bundle::TrainingExtent>,
    /// Whether the place lies within the training windows' box widened by one GRIDMET cell
    /// (None when the bundle does not say): outside it the forecast is an extrapolation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inside_training_extent: Option<bool>,
    /// The day's probability of an ignition in the cell: the seeds' scores corrected from the
    /// training samples' fire share to the training area's usual daily rate (None for bundles
    /// that do not record their training fires).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub daily: Option<crate::daily::DailyForecast>,
    /// Why `daily` is absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub daily_unavailable: Option<String>,
}

/// How far outside its training windows' box a place may lie and still count as inside: one
/// GRIDMET cell (1/24°).
pub const EXTENT_MARGIN_DEG: f64 = 1.0 / 24.0;

/// One seed's prediction, its bundle's facts and the bundle's path relative to the experiment.
pub type SeedAnswer = (crate::predict::Prediction, crate::bundle::BundleInfo, String);

/// Puts the seeds' answers together (in the order given).
pub fn assemble_forecast(answers: &[SeedAnswer]) -> Result<PointForecast, crate::ForecastError> {
    let Some((first, info0, _)) = answers.first() else {
        return Err(crate::ForecastError::Model(
            "no seed bundles to predict with".into(),
        ));
    };
    // Seeds of one model and protocol share inputs and data; anything else is a mixed folder.
    for (p, info, rel) in answers {
        if p.input_days != first.input_days
            || p.kind != first.kind
            || p.protocol != first.protocol
            || p.dataset != first.dataset
            || p.dataset_version != first.dataset_version
            || info.model != info0.model
        {
            return Err(crate::ForecastError::Model(format!(
                "bundle {rel} was trained differently from the other seeds' (model {} {}, protocol {}, days {:?}, dataset {} {}; \
                 expected {} {}, {}, {:?}, {} {})",
                info.model,
                p.kind,
                p.protocol,
                p.input_days,
                p.dataset,
                p.dataset_version,
                info0.model,
                first.kind,
                first.protocol,
                first.input_days,
                first.dataset,
                first.dataset_version
            )));
        }
    }
    let n = answers.len() as f64;
    let mean_of = |v: Vec<f64>| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    let probabilities: Vec<f64> = answers.iter().map(|(p, _, _)| p.probability).collect();
    let thresholds: Vec<f64> = answers.iter().map(|(p, _, _)| p.threshold).collect();
    let probability = probabilities.iter().sum::<f64>() / n;
    let threshold = thresholds.iter().sum::<f64>() / n;
    let interval = [
        probabilities.iter().copied().fold(f64::INFINITY, f64::min),
        probabilities.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    ];
    let per_seed: Vec<SeedForecast> = answers
        .iter()
        .map(|(p, info, rel)| SeedForecast {
            seed: info.seed,
            probability: p.probability,
            threshold: p.threshold,
            validation_auroc: info.validation_auroc,
            validation_auprc: info.validation_auprc,
            test_auroc: info.test_auroc,
            bundle: rel.clone(),
        })
        .collect();
    Ok(PointForecast {
        version: FORECAST_VERSION,
        lat: first.lat,
        lon: first.lon,
        date: first.date.clone(),
        cell_lat: first.cell_lat,
        cell_lon: first.cell_lon,
        model: info0.model.clone(),
        kind: first.kind.clone(),
        protocol: first.protocol.clone(),
        dataset: first.dataset.clone(),
        dataset_version: first.dataset_version.clone(),
        input_days: first.input_days,
        threshold,
        thresholds,
        probability,
        interval,
        interval_method: format!(
            "range over {} training seed{}",
            answers.len(),
            if answers.len() == 1 { "" } else { "s" }
        ),
        validation_auroc: mean_of(per_seed.iter().filter_map(|s| s.validation_auroc).collect()),
        test_auroc: mean_of(per_seed.iter().filter_map(|s| s.test_auroc).collect()),
        per_seed,
        ignition_expected: probability > threshold,
        training_extent: info0.training_extent.clone(),
        inside_training_extent: info0
            .training_extent
            .as_ref()
            .map(|e| e.contains(first.lat, first.lon, EXTENT_MARGIN_DEG)),
        daily: None,
        daily_unavailable: None,
    })
}

/// The protocol to use: the one asked for, else the headline, else the only one.
pub fn choose_protocol(
    available: &[String],
    headline: Option<&str>,
    asked: Option<&str>,
) -> Result<String, crate::ForecastError> {
    let listed = || {
        if available.is_empty() {
            "none".to_string()
        } else {
            available.join(", ")
        }
    };
    let chosen = match (asked, headline) {
        (Some(p), _) => p,
        (None, Some(h)) if available.iter().any(|a| a == h) => h,
        (None, _) => match available {
            [only] => only.as_str(),
            _ => {
                return Err(crate::ForecastError::Config {
                    key: "protocol".into(),
                    message: format!(
                        "the experiment has no headline protocol among its models; choose one of: {}",
                        listed()
                    ),
                });
            }
        },
    };
    if !available.iter().any(|a| a == chosen) {
        return Err(crate::ForecastError::Config {
            key: "protocol".into(),
            message: format!(
                "the experiment has no models under protocol `{chosen}`; it has: {}",
                listed()
            ),
        });
    }
    Ok(chosen.to_string())
}

/// Predicts `params`' place and day with every seed of its model in `experiment` (a
/// report folder of `forecast.experiment` / `experiment run`), weather from `gridmet`.
pub fn forecast_point(
    experiment: &std::path::Path,
    gridmet: &std::path::Path,
    params: &PredictParams,
    device: tch::Device,
) -> Result<PointForecast, crate::ForecastError> {
    let (results, protocol) = experiment_protocol(experiment, params)?;
    let query = crate::predict::Query {
        lat: params.lat,
        lon: params.lon,
        date: params.date.clone(),
    };
    let mut answers = Vec::new();
    for (_, rel) in crate::bundle::seed_bundles(experiment, results.as_ref(), &protocol, &params.model)? {
        let bundle = crate::bundle::load(&experiment.join(&rel), device)?;
        let prediction = crate::predict::predict(&bundle, gridmet, std::slice::from_ref(&query), device)?
            .pop()
            .ok_or_else(|| crate::ForecastError::Model(format!("{rel}: the model gave no prediction")))?;
        answers.push((prediction, bundle.info, rel));
    }
    let mut forecast = assemble_forecast(&answers)?;
    match crate::daily::base_of(forecast.training_extent.as_ref(), gridmet)? {
        Ok(base) => {
            let scores: Vec<f64> = forecast.per_seed.iter().map(|s| s.probability).collect();
            forecast.daily = Some(crate::daily::daily_forecast(&scores, &base));
        }
        Err(why) => forecast.daily_unavailable = Some(why),
    }
    Ok(forecast)
}

/// An experiment's `results.json` (None when it has none) and the protocol a prediction
/// uses: the one asked for, else the headline, else the only one saved.
fn experiment_protocol(
    experiment: &std::path::Path,
    params: &PredictParams,
) -> Result<(Option<serde_json::Value>, String), crate::ForecastError> {
    let results_path = experiment.join("results.json");
    let results: Option<serde_json::Value> = match std::fs::read(&results_path) {
        Ok(bytes) => Some(
            serde_json::from_slice(&bytes).map_err(|e| crate::ForecastError::Data {
                path: results_path.clone(),
                message: format!("line {}: {e}", e.line()),
            })?,
        ),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(crate::ForecastError::io("reading", &results_path)(e)),
    };
    let available = crate::bundle::sub_folders(&experiment.join("models"))?;
    let headline = results.as_ref().and_then(|r| r.get("headline")?.as_str());
    let protocol = choose_protocol(&available, headline, params.protocol.as_deref())?;
    Ok((results, protocol))
}

/// The day's ignition probability over a grid of GRIDMET cells, row 0 south: the mean over
/// the model's training seeds (what `forecast.predict`'s `map` output and the web app's map
/// hold).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ProbabilityMap {
    pub date: String,
    pub model: String,
    pub protocol: String,
    /// Mean of the seeds' decision thresholds (0–1).
    pub threshold: f64,
    pub seeds: usize,
    pub lats: Vec<f64>,
    pub lons: Vec<f64>,
    /// `lats.len()` rows of `lons.len()` values (0–1, mean over seeds); `null` where a cell
    /// has no complete weather window (masked or outside the files). The models' score, on the
    /// training samples' scale (about 40 % fires), not a daily chance.
    pub probability: Vec<Vec<Option<f64>>>,
    /// The day's probability of an ignition per cell (mean over seeds of each seed's corrected
    /// score, [`crate::daily`]); absent for bundles that do not record their training fires.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub daily_probability: Option<Vec<Vec<Option<f64>>>>,
    /// The training area's usual daily probability the cells are corrected to.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub usual_daily: Option<f64>,
}

/// The probability at every (lat, lon) of `lats` × `lons` on `params.date`, by every saved
/// seed of `params.model`.
pub fn forecast_map(
    experiment: &std::path::Path,
    gridmet: &std::path::Path,
    params: &PredictParams,
    lats: &[f64],
    lons: &[f64],
    device: tch::Device,
) -> Result<ProbabilityMap, crate::ForecastError> {
    let (results, protocol) = experiment_protocol(experiment, params)?;
    let bundles = crate::bundle::seed_bundles(experiment, results.as_ref(), &protocol, &params.model)?;
    let queries: Vec<crate::predict::Query> = lats
        .iter()
        .flat_map(|&lat| {
            lons.iter().map(move |&lon| crate::predict::Query {
                lat,
                lon,
                date: params.date.clone(),
            })
        })
        .collect();
    let mut sum = vec![0.0; queries.len()];
    let mut daily_sum = vec![0.0; queries.len()];
    let mut count = vec![0usize; queries.len()];
    let mut threshold = 0.0;
    // The usual daily rate, from the first seed's training extent (the seeds share the split).
    let mut base = None;
    for (k, (_, rel)) in bundles.iter().enumerate() {
        let bundle = crate::bundle::load(&experiment.join(rel), device)?;
        if k == 0 {
            base = crate::daily::base_of(bundle.info.training_extent.as_ref(), gridmet)?.ok();
        }
        threshold += bundle.info.threshold;
        let (answers, _) = crate::predict::predict_available(&bundle, gridmet, &queries, device)?;
        for (i, a) in answers.iter().enumerate() {
            if let Some(p) = a {
                sum[i] += p.probability;
                if let Some(b) = &base {
                    daily_sum[i] +=
                        crate::cell_days::prior_corrected(p.probability, b.sampled_prevalence, b.usual);
                }
                count[i] += 1;
            }
        }
    }
    let n_lon = lons.len();
    let grid = |values: &[f64]| -> Vec<Vec<Option<f64>>> {
        (0..lats.len())
            .map(|r| {
                (0..n_lon)
                    .map(|c| {
                        let i = r * n_lon + c;
                        (count[i] == bundles.len() && count[i] > 0).then(|| values[i] / count[i] as f64)
                    })
                    .collect()
            })
            .collect()
    };
    let probability = grid(&sum);
    Ok(ProbabilityMap {
        date: params.date.clone(),
        model: params.model.clone(),
        protocol,
        threshold: threshold / bundles.len().max(1) as f64,
        seeds: bundles.len(),
        lats: lats.to_vec(),
        lons: lons.to_vec(),
        probability,
        daily_probability: base.as_ref().map(|_| grid(&daily_sum)),
        usual_daily: base.map(|b| b.usual),
    })
}

/// The GRIDMET cells (sorted latitudes and longitudes) within `radius_deg` of a place, read
/// from a GRIDMET file of the date's year.
fn cells_around(
    gridmet: &std::path::Path,
    date: &str,
    lat: f64,
    lon: f64,
    radius_deg: f64,
) -> Result<(Vec<f64>, Vec<f64>), crate::ForecastError> {
    use firecast_data::gridmet::{GridmetFile, GridmetVariable};
    let year: i32 = date.get(..4).and_then(|y| y.parse().ok()).unwrap_or(0);
    // Any variable's file of the year: they share one grid.
    let (variable, path) = GridmetVariable::ALL
        .iter()
        .map(|&v| (v, gridmet.join(v.file_name(year))))
        .find(|(_, p)| p.is_file())
        .ok_or_else(|| crate::ForecastError::Data {
            path: gridmet.to_path_buf(),
            message: format!("no GRIDMET file of {year} to read the grid from"),
        })?;
    let file = GridmetFile::open(&path, variable).map_err(|e| crate::ForecastError::Data {
        path: path.clone(),
        message: e.to_string(),
    })?;
    let pick = |v: &[f64], centre: f64| {
        let mut out: Vec<f64> = v
            .iter()
            .copied()
            .filter(|x| (x - centre).abs() <= radius_deg + 1e-9)
            .collect();
        out.sort_by(f64::total_cmp);
        out
    };
    Ok((pick(file.lats(), lat), pick(file.lons(), lon)))
}

/// The day's probability at every GRIDMET cell of the files' grid, or of those inside
/// `region` (`[lat_min, lat_max, lon_min, lon_max]`), by every saved seed of `params.model`
/// (`params.lat`/`lon` are not used). Cells without a complete weather window are `null`.
pub fn region_map(
    experiment: &std::path::Path,
    gridmet: &std::path::Path,
    params: &PredictParams,
    region: Option<[f64; 4]>,
    device: tch::Device,
) -> Result<ProbabilityMap, crate::ForecastError> {
    let [lat_min, lat_max, lon_min, lon_max] = region.unwrap_or([-90.0, 90.0, -180.0, 180.0]);
    if lat_min > lat_max || lon_min > lon_max {
        return Err(crate::ForecastError::Config {
            key: "region".into(),
            message: format!("[{lat_min}, {lat_max}] x [{lon_min}, {lon_max}] is empty"),
        });
    }
    let (mid_lat, mid_lon) = ((lat_min + lat_max) / 2.0, (lon_min + lon_max) / 2.0);
    let half = ((lat_max - lat_min) / 2.0).max((lon_max - lon_min) / 2.0);
    let (lats, lons) = cells_around(gridmet, &params.date, mid_lat, mid_lon, half)?;
    let lats: Vec<f64> = lats
        .into_iter()
        .filter(|v| (lat_min..=lat_max).contains(v))
        .collect();
    let lons: Vec<f64> = lons
        .into_iter()
        .filter(|v| (lon_min..=lon_max).contains(v))
        .collect();
    if lats.is_empty() || lons.is_empty() {
        return Err(crate::ForecastError::Data {
            path: gridmet.to_path_buf(),
            message: format!("no GRIDMET cell in [{lat_min}, {lat_max}] x [{lon_min}, {lon_max}]"),
        });
    }
    forecast_map(experiment, gridmet, params, &lats, &lons, device)
}

/// Draws a probability map as a PNG, north up. With the day's probabilities, each cell is
/// coloured by its chance relative to the training area's usual day (below ½, ½–1, 1–2, 2–4,
/// 4 times or more); otherwise by its model score (five equal classes up to the map's
/// maximum). The cells whose score is at or above the alert threshold are dotted when they are
/// fewer than half.
pub fn map_png(map: &ProbabilityMap, path: &std::path::Path) -> Result<(), crate::ForecastError> {
    use firecast_render::chart::{Chart, LegendPosition, Series};
    let step = |v: &[f64]| {
        v.windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(f64::INFINITY, f64::min)
            .min(1.0)
    };
    let size = step(&map.lats).min(step(&map.lons));
    let size = if size.is_finite() { size } else { 1.0 / 24.0 };
    let max = map
        .probability
        .iter()
        .flatten()
        .flatten()
        .copied()
        .fold(0.0f64, f64::max)
        .max(map.threshold)
        .max(1e-9);
    // The day's chance relative to the usual day where it is known, else five equal classes
    // of the score up to the map's maximum.
    let relative = map.daily_probability.as_ref().zip(map.usual_daily);
    let (edges, labels): (Vec<f64>, Vec<String>) = match relative {
        Some(_) => (
            vec![0.0, 0.5, 1.0, 2.0, 4.0, f64::INFINITY],
            [
                "below ½ the usual day",
                "½–1 x usual",
                "1–2 x usual",
                "2–4 x usual",
                "4 x usual or more",
            ]
            .map(String::from)
            .to_vec(),
        ),
        None => {
            let edges: Vec<f64> = (0..=5).map(|k| max * f64::from(k) / 5.0).collect();
            let labels = (0..5)
                .map(|k| format!("score {:.2}–{:.2}", edges[k], edges[k + 1]))
                .collect();
            (edges, labels)
        }
    };
    let colors: [[u8; 3]; 5] = [
        [255, 247, 188],
        [254, 217, 118],
        [254, 153, 41],
        [217, 95, 14],
        [153, 52, 4],
    ];
    let pad = size;
    // Room on the right for the legend, off the cells.
    let (x0, x1) = (
        map.lons.first().copied().unwrap_or(0.0) - pad,
        map.lons.last().copied().unwrap_or(0.0) + pad,
    );
    let x1 = x1 + 0.45 * (x1 - x0);
    let (y0, y1) = (
        map.lats.first().copied().unwrap_or(0.0) - pad,
        map.lats.last().copied().unwrap_or(0.0) + pad,
    );
    let seeds = format!("{} seed{}", map.seeds, if map.seeds == 1 { "" } else { "s" });
    let title = match relative {
        Some((_, usual)) => format!(
            "Chance of an ignition on {} vs the usual day ({:.3} %/cell): {} ({}, {seeds})",
            map.date,
            usual * 100.0,
            map.model,
            map.protocol
        ),
        // The score is on the training samples' scale, not a daily chance.
        None => format!(
            "Model score on {}: {} ({}, {seeds}), threshold {:.2}",
            map.date, map.model, map.protocol, map.threshold
        ),
    };
    let mut chart = Chart::new(820, 660)
        .title(title)
        .x_label("longitude, degrees east")
        .y_label("latitude, degrees north")
        .x_range(x0, x1)
        .y_range(y0, y1)
        .legend(Some(LegendPosition::TopRight));
    let mut missing = Vec::new();
    let mut classes: Vec<Vec<(f64, f64)>> = vec![Vec::new(); 5];
    let mut above = Vec::new();
    for (r, &lat) in map.lats.iter().enumerate() {
        for (c, &lon) in map.lons.iter().enumerate() {
            match map
                .probability
                .get(r)
                .and_then(|row| row.get(c))
                .copied()
                .flatten()
            {
                Some(p) => {
                    let value = match relative {
                        Some((daily, usual)) => daily
                            .get(r)
                            .and_then(|row| row.get(c))
                            .copied()
                            .flatten()
                            .map_or(0.0, |d| d / usual),
                        None => p,
                    };
                    let k = edges[1..].iter().position(|&e| value < e).unwrap_or(4);
                    classes[k].push((lon, lat));
                    if p >= map.threshold {
                        above.push((lon, lat));
                    }
                }
                None => missing.push((lon, lat)),
            }
        }
    }
    for (k, cells) in classes.into_iter().enumerate() {
        chart = chart.series(
            Series::cells(cells, size)
                .color(colors[k])
                .alpha(1.0)
                .label(labels[k].clone()),
        );
    }
    if !missing.is_empty() {
        chart = chart.series(
            Series::cells(missing, size)
                .color([200, 200, 200])
                .alpha(1.0)
                .label("no data"),
        );
    }
    // Dots mark the cells at or above the threshold when they are the minority worth seeing.
    if above.len() * 2 < map.lats.len() * map.lons.len() {
        chart = chart.series(
            Series::scatter(above)
                .color([90, 0, 0])
                .marker(firecast_render::chart::Marker::Circle, 2.5)
                .label(format!(
                    "score at or above the alert threshold {:.2}",
                    map.threshold
                )),
        );
    }
    chart.save_png(path).map_err(|e| crate::ForecastError::Data {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// A name that must stay one folder inside the experiment.
fn check_folder_name(key: &str, name: &str) -> Result<(), ParamsError> {
    if name.is_empty() || name == "." || name == ".." || name.contains(['/', '\\']) {
        return Err(ParamsError {
            path: key.into(),
            message: format!("`{name}` is not a {key} name"),
        });
    }
    Ok(())
}

/// `forecast.predict`: one place and day, scored by every seed of one model of an experiment.
#[derive(Debug, Default)]
pub struct PredictStage;

impl StageKind for PredictStage {
    fn name(&self) -> &'static str {
        "forecast.predict"
    }
    fn version(&self) -> u32 {
        // 2: the day's probability beside the model's score (`daily`, `daily_probability`).
        2
    }
    fn summary(&self) -> &'static str {
        "ignition probability of a place and day from an experiment's model: mean and range over its seeds"
    }
    fn ports(&self) -> Ports {
        const IN: &[Port] = &[
            port(
                "experiment",
                true,
                "a forecast.experiment report folder (its models/<protocol>/<model>/seed-<n>)",
            ),
            port(
                "gridmet",
                true,
                "GRIDMET folder with <var>_<year>.nc files covering the input window",
            ),
        ];
        const OUT: &[Port] = &[
            port(
                "forecast",
                true,
                "probability per seed, mean, range, threshold (JSON)",
            ),
            port(
                "map",
                false,
                "with `map_radius_deg`: the day's probability at every GRIDMET cell around the place (JSON)",
            ),
        ];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (p, v) = typed_params::<PredictParams>(raw)?;
        if firecast_dataset::time::parse_date(&p.date).is_none() {
            return Err(ParamsError {
                path: "date".into(),
                message: format!("`{}` is not a YYYY-MM-DD date", p.date),
            });
        }
        for (key, value, limit) in [("lat", p.lat, 90.0), ("lon", p.lon, 180.0)] {
            if !(-limit..=limit).contains(&value) {
                return Err(ParamsError {
                    path: key.into(),
                    message: format!("{value} is outside ±{limit}"),
                });
            }
        }
        check_folder_name("model", &p.model)?;
        firecast_learn::check_threads(p.threads).map_err(|message| ParamsError {
            path: "threads".into(),
            message,
        })?;
        if let Some(protocol) = &p.protocol {
            check_folder_name("protocol", protocol)?;
        }
        if let Some(r) = p.map_radius_deg
            && !(r > 0.0 && r <= 5.0)
        {
            return Err(ParamsError {
                path: "map_radius_deg".into(),
                message: format!("{r} is not in (0, 5] degrees"),
            });
        }
        crate::parse_device(&p.device).map_err(|e| match e {
            crate::ForecastError::Config { key, message } => ParamsError { path: key, message },
            other => ParamsError {
                path: "device".into(),
                message: other.to_string(),
            },
        })?;
        Ok(v)
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        // libtorch's one generator: stages using it run one at a time (reproducible).
        firecast_learn::exclusive(|| {
            let params: PredictParams = ctx.params()?;
            let experiment = ctx.input("experiment")?.to_path_buf();
            let gridmet = ctx.input("gridmet")?.to_path_buf();
            let device = crate::parse_device(&params.device)?;
            firecast_learn::set_threads(params.threads);
            let f = forecast_point(&experiment, &gridmet, &params, device)?;
            std::fs::write(ctx.output("forecast")?, serde_json::to_vec_pretty(&f)?)?;
            if let (Some(radius), Ok(out)) = (params.map_radius_deg, ctx.output("map")) {
                let (lats, lons) = cells_around(&gridmet, &params.date, params.lat, params.lon, radius)?;
                let map = forecast_map(&experiment, &gridmet, &params, &lats, &lons, device)?;
                std::fs::write(out, serde_json::to_vec(&map)?)?;
                ctx.log(format!(
                    "ignition pattern: {} × {} GRIDMET cells within {radius}° of the place",
                    lats.len(),
                    lons.len()
                ));
            }
            ctx.metric("probability", 0, f.probability);
            if let Some(d) = &f.daily {
                ctx.metric("daily_probability", 0, d.probability);
                ctx.log(format!(
                    "the day's chance of an ignition in the cell: {:.3} % ({:.1}x the usual {:.3} %); {}",
                    d.probability * 100.0,
                    d.relative_to_usual,
                    d.usual * 100.0,
                    d.method
                ));
            }
            ctx.log(format!(
            "{} ({}, protocol {}): score at ({}, {}) on {} = {:.3} [{:.3}, {:.3}] over {} seeds (training samples' scale), threshold {:.3}: {}",
            f.model,
            f.kind,
            f.protocol,
            f.lat,
            f.lon,
            f.date,
            f.probability,
            f.interval[0],
            f.interval[1],
            f.per_seed.len(),
            f.threshold,
            if f.ignition_expected {
                "ignition expected"
            } else {
                "no ignition expected"
            }
        ));
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use crate::bundle::BundleInfo;
    use crate::models::Trained;
    use crate::predict::Prediction;

    fn info(seed: u64, threshold: f64, val: Option<f64>, test: Option<f64>) -> BundleInfo {
        BundleInfo {
            model: "fdi".into(),
            kind: "fire_danger_index".into(),
            protocol: "leak_free".into(),
            days: (-3, -1),
            seed,
            threshold,
            threshold_rule: "max F1 on validation".into(),
            dataset: "fixture".into(),
            dataset_version: "v1".into(),
            validation_auroc: val,
            validation_auprc: val.map(|v| v / 2.0),
            test_auroc: test,
            features: vec!["tmmx".into()],
            training_extent: Some(crate::bundle::TrainingExtent {
                lat_min: 39.0,
                lat_max: 40.0,
                lon_min: -108.0,
                lon_max: -107.0,
                first_date: "2016-03-01".into(),
                last_date: "2019-04-30".into(),
                samples: 10,
                positives: Some(4),
                ignition_cell_days: Some(4),
            }),
        }
    }

    fn answer(seed: u64, probability: f64, threshold: f64, val: Option<f64>) -> SeedAnswer {
        let i = info(seed, threshold, val, None);
        let p = Prediction {
            lat: 40.0,
            lon: -105.0,
            date: "2018-06-15".into(),
            probability,
            daily_probability: None,
            usual_daily: None,
            daily_unavailable: None,
            threshold,
            ignition_expected: probability > threshold,
            cell_lat: 40.025,
            cell_lon: -105.016,
            model: i.model.clone(),
            kind: i.kind.clone(),
            protocol: i.protocol.clone(),
            dataset: i.dataset.clone(),
            dataset_version: i.dataset_version.clone(),
            input_days: i.days,
        };
        (p, i, format!("models/leak_free/fdi/seed-{seed}"))
    }

    #[test]
    fn the_forecast_is_the_mean_and_range_over_seeds() {
        let f = assemble_forecast(&[
            answer(0, 0.2, 0.3, Some(0.7)),
            answer(1, 0.5, 0.5, None),
            answer(2, 0.35, 0.4, Some(0.8)),
        ])
        .unwrap();
        assert!((f.probability - 0.35).abs() < 1e-12);
        assert_eq!(f.interval, [0.2, 0.5]);
        assert!((f.threshold - 0.4).abs() < 1e-12);
        assert_eq!(f.thresholds, vec![0.3, 0.5, 0.4]);
        assert!(!f.ignition_expected, "0.35 is not above 0.4");
        assert_eq!(f.interval_method, "range over 3 training seeds");
        // The mean over the seeds that report one.
        assert!((f.validation_auroc.unwrap() - 0.75).abs() < 1e-12);
        assert_eq!(f.test_auroc, None);
        assert_eq!(
            f.per_seed.iter().map(|s| s.seed).collect::<Vec<_>>(),
            vec![0, 1, 2]
        );
        assert_eq!(f.per_seed[1].bundle, "models/leak_free/fdi/seed-1");
        let json = serde_json::to_value(&f).unwrap();
        assert_eq!(json["version"], 1);
        assert_eq!(json["input_days"], serde_json::json!([-3, -1]));
        assert!(json["test_auroc"].is_null());
        assert!(json["per_seed"][1]["validation_auroc"].is_null());

        let one = assemble_forecast(&[answer(4, 0.6, 0.5, None)]).unwrap();
        assert_eq!(one.interval, [0.6, 0.6]);
        assert!(one.ignition_expected);
        assert_eq!(one.interval_method, "range over 1 training seed");
        // The place (40 N, 105 W) lies 2° east of the training windows' box: an extrapolation.
        assert_eq!(one.inside_training_extent, Some(false));
        assert_eq!(one.training_extent.as_ref().unwrap().last_date, "2019-04-30");
        let mut inside = answer(4, 0.6, 0.5, None);
        inside.0.lon = -107.02;
        inside.0.lat = 40.03;
        let f = assemble_forecast(&[inside]).unwrap();
        assert_eq!(
            f.inside_training_extent,
            Some(true),
            "within one GRIDMET cell of the box"
        );
        let mut unknown = answer(4, 0.6, 0.5, None);
        unknown.1.training_extent = None;
        let f = assemble_forecast(&[unknown]).unwrap();
        assert_eq!(f.inside_training_extent, None);
        assert!(
            serde_json::to_value(&f)
                .unwrap()
                .get("inside_training_extent")
                .is_none()
        );

        assert!(assemble_forecast(&[]).is_err());
        let mut other = answer(1, 0.5, 0.5, None);
        other.0.input_days = (-60, 14);
        let err = assemble_forecast(&[answer(0, 0.2, 0.3, None), other]).unwrap_err();
        assert!(err.to_string().contains("seed-1"), "{err}");
    }

    #[test]
    fn the_protocol_is_the_one_asked_else_the_headline_else_the_only_one() {
        let two = vec!["leak_free".to_string(), "paper".to_string()];
        assert_eq!(
            choose_protocol(&two, Some("leak_free"), Some("paper")).unwrap(),
            "paper"
        );
        assert_eq!(
            choose_protocol(&two, Some("leak_free"), None).unwrap(),
            "leak_free"
        );
        let err = choose_protocol(&two, None, None).unwrap_err().to_string();
        assert!(err.contains("leak_free, paper"), "{err}");
        // A headline without saved models does not count.
        let err = choose_protocol(&two, Some("other"), None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("leak_free, paper"), "{err}");
        let err = choose_protocol(&two, None, Some("nope")).unwrap_err().to_string();
        assert!(
            err.contains("`nope`") && err.contains("leak_free, paper"),
            "{err}"
        );
        let one = vec!["paper".to_string()];
        assert_eq!(choose_protocol(&one, None, None).unwrap(), "paper");
        assert_eq!(choose_protocol(&one, Some("leak_free"), None).unwrap(), "paper");
        assert!(choose_protocol(&[], None, None).is_err());
    }

    #[test]
    fn params_are_strict_and_checked() {
        let kind = PredictStage;
        let ok = serde_json::json!({"lat": 40.0, "lon": -105.0, "date": "2018-06-15", "model": "xgboost"});
        let resolved = kind.resolve_params(&ok).unwrap();
        assert_eq!(resolved["device"], "cpu");
        for (bad, key) in [
            (
                serde_json::json!({"lat": 40.0, "lon": -105.0, "date": "2018-13-15", "model": "x"}),
                "date",
            ),
            (
                serde_json::json!({"lat": 91.0, "lon": -105.0, "date": "2018-06-15", "model": "x"}),
                "lat",
            ),
            (
                serde_json::json!({"lat": 40.0, "lon": -105.0, "date": "2018-06-15", "model": "../x"}),
                "model",
            ),
            (
                serde_json::json!({"lat": 40.0, "lon": -105.0, "date": "2018-06-15", "model": "x", "seed": 1}),
                "seed",
            ),
        ] {
            let err = kind.resolve_params(&bad).unwrap_err();
            assert!(
                err.path.contains(key) || err.message.contains(key),
                "{key}: {} {}",
                err.path,
                err.message
            );
        }
    }

    /// The GRIDMET fixture of firecast-dataset: tmmx = 300 + day of year + j/10 + i/100 on
    /// cells j = 224.., i = 474.. (2018 and 2019).
    fn fixture_gridmet() -> std::path::PathBuf {
        std::path::PathBuf::from(
            std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
        )
        .join("../firecast-dataset/tests/fixtures/gridmet")
    }

    #[test]
    fn every_seed_bundle_of_the_model_is_asked() {
        let tmp = tempfile::tempdir().unwrap();
        let exp = tmp.path();
        // Seed 0: σ(0.01·tmmx − 4) on the last input day; seed 1: 0.75 whatever the weather.
        for (seed, a, b, threshold) in [(0u64, 0.01, -4.0, 0.6), (1, 0.0, 3f64.ln(), 0.7)] {
            crate::bundle::save(
                &exp.join(format!("models/leak_free/fdi/seed-{seed}")),
                &info(seed, threshold, Some(0.6 + seed as f64 / 10.0), Some(0.5)),
                &Trained::FireDangerIndex {
                    feature: "tmmx".into(),
                    a,
                    b,
                },
            )
            .unwrap();
        }
        // A second protocol, so the choice needs the headline.
        crate::bundle::save(
            &exp.join("models/paper/fdi/seed-0"),
            &info(0, 0.5, None, None),
            &Trained::Majority { prevalence: 0.1 },
        )
        .unwrap();
        std::fs::write(exp.join("results.json"), r#"{"headline": "leak_free"}"#).unwrap();
        let (j, i) = (1usize, 2usize);
        let params = PredictParams {
            lat: 49.4 - (224 + j) as f64 / 24.0 + 0.01,
            lon: -124.766_666_633_3 + (474 + i) as f64 / 24.0 - 0.01,
            date: "2018-06-15".into(),
            model: "fdi".into(),
            protocol: None,
            device: "cpu".into(),
            threads: 1,
            map_radius_deg: None,
        };
        let f = forecast_point(exp, &fixture_gridmet(), &params, tch::Device::Cpu).unwrap();
        // The fixture's GRIDMET cells lie outside the models' training area: the score, and why
        // there is no daily probability.
        assert!(f.daily.is_none());
        assert!(
            f.daily_unavailable
                .as_deref()
                .is_some_and(|w| w.contains("no cell with data in the model's training area")),
            "{:?}",
            f.daily_unavailable
        );
        assert_eq!(f.protocol, "leak_free");
        assert_eq!(f.per_seed.len(), 2);
        // 2018-06-14 (day −1) is day of year 165.
        let x = 300.0 + 165.0 + j as f64 / 10.0 + i as f64 / 100.0;
        let p0 = 1.0 / (1.0 + (-(0.01 * x - 4.0)).exp());
        assert!((f.per_seed[0].probability - p0).abs() < 1e-5, "{f:?}");
        assert!((f.per_seed[1].probability - 0.75).abs() < 1e-9);
        assert!((f.probability - (p0 + 0.75) / 2.0).abs() < 1e-5);
        assert_eq!(f.interval, [f.per_seed[0].probability, f.per_seed[1].probability]);
        assert!((f.threshold - 0.65).abs() < 1e-12);
        assert_eq!(f.ignition_expected, f.probability > 0.65);
        assert!((f.validation_auroc.unwrap() - 0.65).abs() < 1e-12);
        // The map over the GRIDMET cells around the place holds the same mean at the place's
        // cell, and the same threshold.
        let (lats, lons) =
            cells_around(&fixture_gridmet(), &params.date, params.lat, params.lon, 0.05).unwrap();
        assert!(!lats.is_empty() && !lons.is_empty(), "{lats:?} {lons:?}");
        let map = forecast_map(exp, &fixture_gridmet(), &params, &lats, &lons, tch::Device::Cpu).unwrap();
        assert_eq!((map.seeds, map.protocol.as_str()), (2, "leak_free"));
        assert!((map.threshold - f.threshold).abs() < 1e-12);
        let nearest = |v: &[f64], x: f64| {
            (0..v.len())
                .min_by(|&a, &b| (v[a] - x).abs().total_cmp(&(v[b] - x).abs()))
                .unwrap()
        };
        let (r, c) = (nearest(&lats, params.lat), nearest(&lons, params.lon));
        let at = map.probability[r][c].expect("a probability at the place");
        assert!((at - f.probability).abs() < 1e-9, "{at} vs {}", f.probability);
        assert_eq!(f.test_auroc, Some(0.5));
        assert_eq!(f.per_seed[0].bundle, "models/leak_free/fdi/seed-0");

        // The other protocol when asked; an unknown model names what there is.
        let paper = PredictParams {
            protocol: Some("paper".into()),
            ..params.clone()
        };
        let f = forecast_point(exp, &fixture_gridmet(), &paper, tch::Device::Cpu).unwrap();
        assert_eq!((f.per_seed.len(), f.probability), (1, 0.1));
        let missing = PredictParams {
            model: "xgboost".into(),
            ..params.clone()
        };
        let err = forecast_point(exp, &fixture_gridmet(), &missing, tch::Device::Cpu)
            .unwrap_err()
            .to_string();
        assert!(err.contains("`xgboost`") && err.contains("fdi"), "{err}");

        // Outside the files' years or grid: the prediction's error.
        for (lat, lon, date) in [
            (params.lat, params.lon, "2021-06-15"),
            (45.0, -100.0, "2018-06-15"),
        ] {
            let q = PredictParams {
                lat,
                lon,
                date: date.into(),
                ..params.clone()
            };
            let err = forecast_point(exp, &fixture_gridmet(), &q, tch::Device::Cpu)
                .unwrap_err()
                .to_string();
            assert!(err.contains("no complete") && err.contains(date), "{err}");
        }
    }
}
