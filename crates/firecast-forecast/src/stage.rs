//! `forecast.experiment`: an experiment as a pipeline stage. Its params are the experiment
//! spec (without `dataset`, which is the stage's input), so a pipeline can build a dataset
//! and evaluate on it, with the usual caching: changing a model's params or the dataset
//! re-runs the experiment; nothing else does.

use std::sync::Mutex;

use firecast_pipeline::{ParamsError, Port, Ports, StageContext, StageError, StageKind, typed_params};

use crate::experiment::Sink;
use crate::spec::ExperimentSpec;

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

struct StageSink<'a, 'b> {
    ctx: &'a StageContext<'b>,
    bar: indicatif::ProgressBar,
    log: Mutex<Vec<String>>,
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
        self.log
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(line.to_string());
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
        1
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
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let spec: ExperimentSpec = ctx.params()?;
        let dataset = ctx.input("dataset")?.to_path_buf();
        let out = ctx.output("report")?.to_path_buf();
        let device = crate::parse_device(&spec.device)?;
        firecast_learn::set_threads(ctx.jobs());
        let windows = crate::data::Windows::load(&dataset)?;
        let bar = ctx.progress_bar(1, "models");
        let sink = StageSink {
            ctx,
            bar,
            log: Mutex::new(Vec::new()),
        };
        let (result, predictions) = crate::experiment::run(&spec, &windows, device, &out, &sink)?;
        sink.bar.finish_and_clear();
        crate::table::write_all(&out, &result)?;
        crate::plots::write_all(&out, &result, &predictions, &windows)?;
        for p in &result.protocols {
            for r in result.results.iter().filter(|r| r.protocol == p.name) {
                for (k, v) in &r.test {
                    if v.is_finite() {
                        ctx.metric(&format!("{}/{}/{k}", p.name, r.model), 0, *v);
                    }
                }
            }
        }
        // Saved models go to the artifact store (the run links dataset → models → metrics).
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
}
