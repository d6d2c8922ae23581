//! The exported `dvc.yaml` in a real git + DVC project: `dvc repro` runs a small forecasting
//! pipeline through `firecast`, then `dvc metrics show` finds the experiment's metrics and
//! `dvc plots show` renders its ROC, precision-recall, calibration and confusion plots.

use std::path::Path;
use std::process::{Command, Output};

use crate::{Project, describe, venv_bin};

const PIPELINE: &str = r#"
description: A small ignition dataset and a two-model Table III, for DVC.
vars:
  region: {lat_min: 38.5, lat_max: 40.0, lon_min: -108.5, lon_max: -106.5}
stages:
  sources:
    uses: data.synthesize
    params: {seed: 3, region: "${region}", years: [2018, 2019], ignition_rate_scale: 1.0}
    outputs:
      gridmet: build/sources/gridmet
      incidents: build/sources/wfigs_incidents.csv
      model: build/sources/MODEL.md
      truth: build/sources/truth
  ignitions:
    uses: data.ignitions
    inputs: {incidents: {from: sources.incidents}, gridmet: {from: sources.gridmet}}
    outputs: {ignitions: build/ignitions.parquet, report: build/ignitions.json, rejects: build/rejects.csv}
  samples:
    uses: data.negatives
    params:
      variant: paper
      period_start: "2018-03-02"
      period_end: "2019-12-17"
      region: "${region}"
      far_min_km: 4
      near_max_km: 30
    inputs: {ignitions: {from: ignitions.ignitions}, gridmet: {from: sources.gridmet}}
    outputs: {samples: build/samples.parquet, report: build/samples.json}
  windows:
    uses: data.windows
    inputs: {samples: {from: samples.samples}, gridmet: {from: sources.gridmet}}
    outputs: {windows: build/windows}
  dataset:
    uses: data.dataset
    params: {name: dvc-ignitions, framing: {kind: paper}, split: {method: temporal, test_months: 4}}
    inputs: {windows: {from: windows.windows}, source_model: {from: sources.model}}
    outputs: {dataset: datasets/ignitions}
  table3:
    uses: forecast.experiment
    params:
      name: dvc-table3
      protocols:
        paper:
          days: [-60, 14]
          split: {method: stratified_random, test: 0.3, val: 0.25, seed: 42}
        leak_free:
          days: [-30, -1]
          split: {method: stratified_random, test: 0.3, val: 0.25, seed: 42, grouped: true}
      seeds: [0]
      evaluation: {bootstrap: 20}
      device: cpu
      models: [{kind: majority}, {name: logreg, kind: logistic_regression}]
    inputs: {dataset: {from: dataset.dataset}}
    outputs: {report: build/table3}
"#;

/// The venv's `dvc` (or `git`) in the project, with `firecast` on the PATH for `dvc repro`.
fn tool(p: &Project, program: &Path, args: &[&str]) -> Output {
    let bin_dir = Path::new(env!("CARGO_BIN_EXE_firecast")).parent().unwrap();
    let path = std::env::var_os("PATH").unwrap_or_default();
    let mut dirs = vec![bin_dir.to_path_buf()];
    dirs.extend(std::env::split_paths(&path));
    let out = Command::new(program)
        .args(args)
        .current_dir(p.root())
        .env("PATH", std::env::join_paths(dirs).unwrap())
        .env("DVC_NO_ANALYTICS", "1")
        .env_remove("FIRECAST_REGISTRY")
        .env_remove("FIRECAST_STORE")
        .env_remove("FIRECAST_RERUN_CONNECT")
        .output()
        .unwrap_or_else(|e| panic!("{}: {e}", program.display()));
    assert!(
        out.status.success(),
        "{} {args:?} failed:\n{}",
        program.display(),
        describe(&out)
    );
    out
}

fn dvc(p: &Project, args: &[&str]) -> Output {
    let dvc = venv_bin("dvc");
    tool(p, &dvc, args)
}

fn json(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("not JSON ({e}):\n{}", describe(out)))
}

#[test]
fn dvc_finds_the_experiment_metrics_and_plots() {
    let p = Project::new();
    p.write("pipelines/small.yaml", PIPELINE);
    tool(&p, Path::new("git"), &["init", "-q"]);
    dvc(&p, &["init", "-q"]);
    p.ok(&["pipeline", "export-dvc"]);
    let exported = p.read("dvc.yaml");
    assert!(
        exported.contains("\nmetrics:\n- build/table3/metrics.json\n"),
        "{exported}"
    );
    // A project with a commit, as DVC users have (`dvc metrics show` names the workspace).
    tool(&p, Path::new("git"), &["add", "-A"]);
    tool(
        &p,
        Path::new("git"),
        &[
            "-c",
            "user.name=t",
            "-c",
            "user.email=t@localhost",
            "commit",
            "-qm",
            "pipeline",
        ],
    );

    dvc(&p, &["repro", "-q"]);
    assert!(p.path("build/table3/plots/roc_paper_logreg.json").is_file());

    // Metrics: DVC reads the nested {protocol: {model: {metric}}} file.
    let shown = json(&dvc(&p, &["metrics", "show", "--json"]));
    // One revision, the workspace (DVC 3.67 keys it "" when it is the only one shown).
    let revisions = shown.as_object().unwrap_or_else(|| panic!("{shown}"));
    assert_eq!(revisions.len(), 1, "{shown}");
    let workspace = revisions.values().next().unwrap();
    let metrics = &workspace["data"]["build/table3/metrics.json"]["data"];
    for protocol in ["paper", "leak_free"] {
        for model in ["majority", "logreg"] {
            let auroc = metrics[protocol][model]["auroc"].as_f64();
            assert!(auroc.is_some_and(|a| (0.0..=1.0).contains(&a)), "{shown}");
        }
    }
    let table = String::from_utf8_lossy(&dvc(&p, &["metrics", "show"]).stdout).to_string();
    assert!(table.contains("paper.logreg.auroc"), "{table}");

    // Plots: one overlaid curve per model, one confusion matrix per model, no errors.
    let shown = json(&dvc(&p, &["plots", "show", "--json"]));
    assert!(
        shown
            .get("errors")
            .is_none_or(|e| e.as_array().is_some_and(Vec::is_empty)),
        "{shown}"
    );
    let data = shown["data"].as_object().unwrap_or_else(|| panic!("{shown}"));
    for protocol in ["paper", "leak_free"] {
        for (plot, x, y) in [
            ("roc", "fpr", "tpr"),
            ("precision_recall", "recall", "precision"),
            ("calibration", "prob_pred", "prob_true"),
            ("confusion", "actual", "predicted"),
        ] {
            let id = format!("small-table3-{plot}-{protocol}");
            let renderers = data
                .get(&id)
                .and_then(|r| r.as_array())
                .unwrap_or_else(|| panic!("no plot {id} in {:?}", data.keys().collect::<Vec<_>>()));
            let vega = renderers
                .iter()
                .find(|r| r["type"] == "vega")
                .unwrap_or_else(|| panic!("{id}: {renderers:?}"));
            let spec = vega["content"].to_string();
            assert!(spec.contains(x) && spec.contains(y), "{id}: {spec}");
            for model in ["majority", "logreg"] {
                // DVC names each series by the shortest distinct end of its path.
                let file = format!("{plot}_{protocol}_{model}.json");
                assert!(spec.contains(&file), "{id} lacks {file}: {spec}");
            }
        }
    }

    // The HTML page renders too.
    dvc(&p, &["plots", "show", "-o", "dvc_plots"]);
    let html = p.read("dvc_plots/index.html");
    assert!(html.contains("small-table3-roc-paper"), "{html}");
}
