//! `firecast pipeline export-dvc`: a `dvc.yaml` whose stages call `firecast`, so DVC
//! users can `dvc repro` the same pipelines, with DVC 3's top-level `metrics:` and `plots:`
//! naming the metrics and plot files stage kinds write ([`crate::StageKind::metrics_and_plots`]),
//! so `dvc metrics show` and `dvc plots show` find them.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Serialize;

use crate::plan::{Plan, Source};
use crate::stage::StageKinds;

/// The metrics and plot files a stage writes inside its outputs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MetricsAndPlots {
    /// JSON or YAML files of numbers (`dvc metrics`), relative to the project root.
    pub metrics: Vec<PathBuf>,
    pub plots: Vec<Plot>,
}

/// A `dvc plots` definition: one series per data file, as DVC 3's top-level `plots:` takes
/// it (`y: {file: field}`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plot {
    /// Unique within the stage; the export prefixes the DVC stage name.
    #[serde(skip)]
    pub id: String,
    /// A DVC template: `simple`, `linear`, `confusion`, …
    pub template: String,
    pub x: String,
    /// Data file (relative to the project root) → the field plotted on y.
    pub y: BTreeMap<String, String>,
    pub title: String,
    pub x_label: String,
    pub y_label: String,
}

/// The plots DVCLive writes for a binary classifier (`dvclive.plots.sklearn`), with the
/// template, axes, title and labels DVCLive gives them; the data files are DVCLive's too
/// (`firecast_eval::dvc` writes them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SklearnPlot {
    /// `{"roc": [{"fpr", "tpr", "threshold"}, …]}`.
    Roc,
    /// `{"precision_recall": [{"precision", "recall", "threshold"}, …]}`.
    PrecisionRecall,
    /// `{"calibration": [{"prob_true", "prob_pred"}, …]}`.
    Calibration,
    /// `[{"actual", "predicted"}, …]`, one row per sample.
    ConfusionMatrix,
}

impl SklearnPlot {
    /// (template, x, y, title, x label, y label) as DVCLive sets them.
    fn properties(self) -> [&'static str; 6] {
        match self {
            Self::Roc => [
                "simple",
                "fpr",
                "tpr",
                "Receiver operating characteristic (ROC)",
                "False Positive Rate",
                "True Positive Rate",
            ],
            Self::PrecisionRecall => [
                "simple",
                "recall",
                "precision",
                "Precision-Recall Curve",
                "Recall",
                "Precision",
            ],
            Self::Calibration => [
                "simple",
                "prob_pred",
                "prob_true",
                "Calibration Curve",
                "Mean Predicted Probability",
                "Fraction of Positives",
            ],
            Self::ConfusionMatrix => [
                "confusion",
                "actual",
                "predicted",
                "Confusion Matrix",
                "True Label",
                "Predicted Label",
            ],
        }
    }

    /// A plot of these files (one series, or one confusion matrix, per file), titled
    /// `<DVCLive's title>, <what>`.
    pub fn plot(self, id: impl Into<String>, what: &str, files: impl IntoIterator<Item = PathBuf>) -> Plot {
        let [template, x, y, title, x_label, y_label] = self.properties();
        Plot {
            id: id.into(),
            template: template.into(),
            x: x.into(),
            y: files
                .into_iter()
                .map(|f| (f.display().to_string(), y.to_string()))
                .collect(),
            title: if what.is_empty() {
                title.into()
            } else {
                format!("{title}, {what}")
            },
            x_label: x_label.into(),
            y_label: y_label.into(),
        }
    }
}

#[derive(Debug, Serialize)]
struct DvcFile {
    stages: BTreeMap<String, DvcStage>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    metrics: Vec<String>,
    /// `[{id: definition}]`, in stage order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    plots: Vec<BTreeMap<String, Plot>>,
}

#[derive(Debug, Serialize)]
struct DvcStage {
    #[serde(skip_serializing_if = "Option::is_none")]
    desc: Option<String>,
    cmd: String,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    deps: Vec<String>,
    /// `{file: [keys]}`: the pipeline's `vars` and this stage's definition.
    params: Vec<BTreeMap<String, Vec<String>>>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    outs: Vec<String>,
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    always_changed: bool,
}

/// DVC stage names allow letters, digits, `_` and `-`.
pub fn dvc_stage_name(pipeline: &str, stage: &str) -> String {
    let raw = format!("{pipeline}-{stage}");
    raw.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Render `dvc.yaml` for the given plans (sorted by stage name, so output is stable); the
/// kinds name their stages' metrics and plot files.
pub fn export(plans: &[Plan], kinds: &StageKinds, firecast_bin: &str) -> String {
    let mut stages = BTreeMap::new();
    let mut reports = BTreeMap::new();
    for plan in plans {
        let file = plan.file.display().to_string();
        for stage in &plan.stages {
            let mut deps = Vec::new();
            for input in stage.inputs.values() {
                for source in &input.sources {
                    deps.push(match source {
                        Source::File { path } => path.display().to_string(),
                        Source::Url { url } => url.clone(),
                        Source::Output {
                            stage: upstream,
                            output,
                        } => plan
                            .index_of(upstream)
                            .map(|j| plan.stages[j].outputs[output].path.display().to_string())
                            .unwrap_or_default(),
                    });
                }
            }
            deps.sort();
            deps.dedup();
            let mut params_keys = vec![format!("stages.{}", stage.base)];
            if plan.vars.as_object().is_some_and(|v| !v.is_empty()) {
                params_keys.insert(0, "vars".to_string());
            }
            let outs: Vec<String> = stage
                .outputs
                .values()
                .map(|o| o.path.display().to_string())
                .collect();
            let quoted_stage = if stage.name.contains('@') || stage.name.contains('.') {
                format!("'{}'", stage.name)
            } else {
                stage.name.clone()
            };
            let dvc_name = dvc_stage_name(&plan.name, &stage.name);
            if let Some(kind) = kinds.get(&stage.kind) {
                let outputs = stage
                    .outputs
                    .iter()
                    .map(|(name, o)| (name.clone(), o.path.clone()))
                    .collect();
                let found = kind.metrics_and_plots(&stage.params, &outputs);
                if found != MetricsAndPlots::default() {
                    reports.insert(dvc_name.clone(), found);
                }
            }
            stages.insert(
                dvc_name,
                DvcStage {
                    desc: stage.description.clone(),
                    cmd: format!("{firecast_bin} pipeline run {file} --only {quoted_stage} --no-progress"),
                    deps,
                    params: vec![BTreeMap::from([(file.clone(), params_keys)])],
                    outs,
                    always_changed: stage.always_run,
                },
            );
        }
    }
    let header = "# Generated by `firecast pipeline export-dvc` from pipelines/*.yaml. Do not edit:\n\
                  # edit the pipelines and re-run the export (a test fails when this file is stale).\n";
    let mut metrics = Vec::new();
    let mut plots = Vec::new();
    // In DVC stage-name order, like the stages.
    for (dvc_name, found) in reports {
        metrics.extend(found.metrics.iter().map(|m| m.display().to_string()));
        for plot in found.plots {
            plots.push(BTreeMap::from([(format!("{dvc_name}-{}", plot.id), plot)]));
        }
    }
    let body = serde_yaml_ng::to_string(&DvcFile {
        stages,
        metrics,
        plots,
    })
    .unwrap_or_default();
    format!("{header}{body}")
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use std::collections::BTreeMap;
    use std::path::{Path, PathBuf};

    use super::{MetricsAndPlots, SklearnPlot};
    use crate::stage::{ParamsError, Port, Ports, StageContext, StageKind, StageKinds};

    /// Writes `score.json` and a ROC file per model named in its params.
    struct Scored;

    impl StageKind for Scored {
        fn name(&self) -> &'static str {
            "test.scored"
        }
        fn version(&self) -> u32 {
            1
        }
        fn summary(&self) -> &'static str {
            "test"
        }
        fn ports(&self) -> Ports {
            const OUT: &[Port] = &[Port {
                name: "report",
                required: true,
                many: false,
                description: "folder",
            }];
            Ports {
                inputs: &[],
                outputs: OUT,
                open: false,
            }
        }
        fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
            Ok(raw.clone())
        }
        fn run(&self, _ctx: &mut StageContext<'_>) -> Result<(), crate::StageError> {
            Ok(())
        }
        fn metrics_and_plots(
            &self,
            params: &serde_json::Value,
            outputs: &BTreeMap<String, PathBuf>,
        ) -> MetricsAndPlots {
            let out = &outputs["report"];
            let models = params["models"].as_array().unwrap();
            MetricsAndPlots {
                metrics: vec![out.join("score.json")],
                plots: vec![
                    SklearnPlot::Roc.plot(
                        "roc",
                        "test side",
                        models
                            .iter()
                            .map(|m| out.join(format!("roc_{}.json", m.as_str().unwrap()))),
                    ),
                ],
            }
        }
    }

    #[test]
    fn kinds_declare_metrics_and_plots_at_the_top_level() {
        let mut kinds = StageKinds::new();
        kinds.register(crate::cmd::CmdStage);
        kinds.register(Scored);
        let text = "stages:\n  eval:\n    uses: test.scored\n    params: {models: [a, b]}\n    outputs: {report: build/eval}\n  other:\n    uses: cmd\n    params: {command: 'true'}\n    outputs: {out: build/x}\n";
        let expanded = crate::spec::parse(Path::new("."), Path::new("pipelines/p.yaml"), text, &[]).unwrap();
        let plan = crate::plan::plan(&expanded, &kinds).unwrap();
        let yaml: serde_json::Value =
            serde_yaml_ng::from_str(&super::export(&[plan], &kinds, "firecast")).unwrap();
        assert_eq!(yaml["metrics"], serde_json::json!(["build/eval/score.json"]));
        assert_eq!(
            yaml["plots"],
            serde_json::json!([{"p-eval-roc": {
                "template": "simple",
                "x": "fpr",
                "y": {"build/eval/roc_a.json": "tpr", "build/eval/roc_b.json": "tpr"},
                "title": "Receiver operating characteristic (ROC), test side",
                "x_label": "False Positive Rate",
                "y_label": "True Positive Rate",
            }}])
        );
    }
}
