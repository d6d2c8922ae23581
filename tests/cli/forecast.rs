//! `firecast experiment run|compare` and `firecast forecast predict` on a small synthetic
//! dataset built through the CLI: tiny budgets, real behaviour.

use std::collections::BTreeMap;

use crate::{
    Project, describe, files_under, first_stage_run_id, lock_without_run_ids, outcomes, recorded, stage_log,
};

const EXPERIMENT: &str = r#"
name: cli-exp
dataset: data/a
protocols:
  paper:
    days: [-60, 14]
    split: {method: stratified_random, test: 0.3, val: 0.25, seed: 42}
  leak_free:
    days: [-30, -1]
    split: {method: stratified_random, test: 0.3, val: 0.25, seed: 42, grouped: true}
headline: leak_free
seeds: [0, 1]
evaluation: {bootstrap: 60}
device: cpu
models:
  - {kind: majority}
  - {kind: climatology}
  - {kind: logistic_regression}
  - {kind: xgboost, params: {n_estimators: 20, nthread: 1}}
  - {kind: minirocket, params: {num_features: 168}}
  - {name: cnn_bilstm_R, kind: cnn_bilstm, params: {max_epochs: 1, hidden: 16, layers: 1}}
  - {kind: firecast, params: {max_epochs: 2}}
"#;

pub(crate) fn project_with_dataset() -> Project {
    let p = Project::new();
    // Denser ignitions than the dataset tests use, so both sides of every split hold both classes.
    p.write("synth.yaml", "ignition_rate_scale: 1.0\n");
    let built = build_dataset(&p, "3", "2018", "2019", "a", "cli-fc", true);
    let (n, pos) = (
        built["samples"].as_u64().unwrap(),
        built["positives"].as_u64().unwrap(),
    );
    assert!(n - pos >= 40 && pos >= 40, "{built}");
    p.write("experiments/cli.yaml", EXPERIMENT);
    p
}

/// Synthetic sources (generator seed, first..last year, the test box) → ignitions →
/// negatives over those years → windows (with the generator's truth if asked) → a
/// paper-framed dataset `data/<tag>` named `name`; returns `dataset build`'s report.
fn build_dataset(
    p: &Project,
    seed: &str,
    first: &str,
    last: &str,
    tag: &str,
    name: &str,
    truth: bool,
) -> serde_json::Value {
    let (src, work) = (format!("src-{tag}"), format!("w-{tag}"));
    let years = format!("{first}-{last}");
    p.ok(&[
        "dataset",
        "synthesize",
        "--out",
        &src,
        "--seed",
        seed,
        "--years",
        &years,
        "--region",
        "38.5,40.0,-108.5,-106.5",
        "--config",
        "synth.yaml",
    ]);
    let g = p.path(&format!("{src}/gridmet"));
    let g = g.to_str().unwrap();
    let inc = p.path(&format!("{src}/incidents/wfigs_incidents.csv"));
    let ign = format!("{work}/ign.parquet");
    p.ok(&[
        "dataset",
        "ignitions",
        "--incidents",
        inc.to_str().unwrap(),
        "--gridmet",
        g,
        "--out",
        &ign,
    ]);
    let neg = format!("neg-{tag}.yaml");
    p.write(
        &neg,
        &format!(
            "variant: paper\nperiod_start: \"{first}-03-02\"\nperiod_end: \"{last}-12-17\"\nfar_min_km: 4\nnear_max_km: 30\n"
        ),
    );
    let samples = format!("{work}/s.parquet");
    p.ok(&[
        "dataset",
        "negatives",
        "--ignitions",
        &ign,
        "--gridmet",
        g,
        "--out",
        &samples,
        "--config",
        &neg,
    ]);
    let windows = format!("{work}/windows");
    let truth_dir = p.path(&format!("{src}/truth"));
    let mut args = vec![
        "dataset",
        "windows",
        "--samples",
        &samples,
        "--gridmet",
        g,
        "--out",
        &windows,
    ];
    if truth {
        args.extend(["--truth", truth_dir.to_str().unwrap()]);
    }
    p.ok(&args);
    let out = format!("data/{tag}");
    p.json(&[
        "dataset",
        "build",
        "--windows",
        &windows,
        "--out",
        &out,
        "--name",
        name,
        "--framing",
        "paper",
    ])
}

/// A `forecast.experiment` stage on `data/a` with `shards` (none: unsharded): 16 training
/// units (2 protocols x (majority, logistic regression, 2 seeds of MiniRocket, of the R
/// network and of the MLP)), the networks drawing from libtorch's generator.
pub(crate) fn experiment_stage(shards: Option<u32>) -> String {
    let shards = shards.map(|n| format!("    shards: {n}\n")).unwrap_or_default();
    format!(
        r#"
stages:
  table3:
    uses: forecast.experiment
{shards}    params:
      name: shard-exp
      protocols:
        paper:
          days: [-60, 14]
          split: {{method: stratified_random, test: 0.3, val: 0.25, seed: 42}}
        leak_free:
          days: [-30, -1]
          split: {{method: stratified_random, test: 0.3, val: 0.25, seed: 42, grouped: true}}
      headline: leak_free
      seeds: [0, 1]
      evaluation: {{bootstrap: 60}}
      device: cpu
      models:
        - {{kind: majority}}
        - {{kind: logistic_regression}}
        - {{kind: minirocket, params: {{num_features: 168}}}}
        - {{name: cnn_bilstm_R, kind: cnn_bilstm, params: {{max_epochs: 1, hidden: 16, layers: 1}}}}
        - {{kind: mlp, params: {{max_epochs: 3}}}}
    inputs:
      dataset: data/a
    outputs:
      report: build/table3
"#
    )
}

fn metrics(p: &Project) -> serde_json::Value {
    serde_json::from_str(&p.read("experiments/runs/cli-exp/metrics.json")).unwrap()
}

#[test]
fn experiment_runs_every_model_under_both_protocols_and_answers_predictions() {
    let p = project_with_dataset();
    let out = p.ok(&["experiment", "run", "experiments/cli.yaml"]);
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(stdout.contains("Table III"), "{stdout}");
    assert!(stdout.contains("protocol `leak_free` (headline)"), "{stdout}");
    assert!(stdout.contains("oracle"), "{stdout}");

    let results: serde_json::Value =
        serde_json::from_str(&p.read("experiments/runs/cli-exp/results.json")).unwrap();
    let rows = results["results"].as_array().unwrap();
    assert_eq!(rows.len(), 2 * 7, "every model under every protocol");
    for r in rows {
        let auroc = r["test"]["auroc"].as_f64().unwrap();
        let (lo, hi) = (
            r["intervals"]["auroc"][0].as_f64().unwrap(),
            r["intervals"]["auroc"][1].as_f64().unwrap(),
        );
        assert!(lo <= hi && (0.0..=1.0).contains(&auroc), "{r}");
        // Random models run once per seed, deterministic ones once.
        let seeds = r["runs"].as_array().unwrap().len();
        match r["kind"].as_str().unwrap() {
            "majority" | "climatology" | "logistic_regression" | "xgboost" => assert_eq!(seeds, 1, "{r}"),
            _ => assert_eq!(seeds, 2, "{r}"),
        }
        if r["kind"] == "majority" {
            assert_eq!(auroc, 0.5);
        }
    }
    for protocol in results["protocols"].as_array().unwrap() {
        assert!(protocol["oracle"]["auroc"].as_f64().unwrap() > 0.5, "{protocol}");
    }
    // The R network's parameter count is reported; the paper protocol leaks, the other not.
    assert!(
        results["protocols"]
            .as_array()
            .unwrap()
            .iter()
            .any(|p| p["leaks_future"] == true)
    );
    for f in [
        "table3.md",
        "table3.csv",
        "metrics.json",
        "predictions.csv",
        "plots/roc_paper.png",
        "plots/precision_recall_leak_free.png",
        "plots/calibration_paper.png",
        "plots/auroc_forest_leak_free.png",
        "plots/roc_paper.json",
        "plots/training_paper_firecast.png",
        "models/paper/cnn_bilstm_R/seed-0/weights.safetensors",
        "models/paper/logistic_regression/seed-0/model.json",
    ] {
        assert!(
            p.path("experiments/runs/cli-exp").join(f).is_file(),
            "{f} missing"
        );
    }
    let md = p.read("experiments/runs/cli-exp/table3.md");
    assert!(md.contains("rows = actual, columns = predicted"), "{md}");
    // FireCast's forecaster against every other model over all seeds, Holm-corrected, and the
    // best model against the best baseline; the table says what FireCast's forecaster beat.
    let comparisons = results["comparisons"].as_array().unwrap();
    for protocol in ["paper", "leak_free"] {
        let here: Vec<&serde_json::Value> =
            comparisons.iter().filter(|c| c["protocol"] == protocol).collect();
        let against: Vec<&str> = here
            .iter()
            .filter(|c| c["questions"].to_string().contains("firecast_vs_model"))
            .map(|c| {
                assert_eq!(c["model"], "firecast", "{c}");
                c["other"].as_str().unwrap()
            })
            .collect();
        assert_eq!(against.len(), 6, "{protocol}: {against:?}");
        assert!(
            here.iter()
                .any(|c| c["questions"].to_string().contains("best_vs_best_baseline"))
        );
        for c in &here {
            let (p, holm) = (c["p_value"].as_f64().unwrap(), c["p_holm"].as_f64().unwrap());
            assert!((0.0..=1.0).contains(&p) && holm >= p - 1e-12, "{c}");
            let (lo, hi) = (
                c["auroc_diff_interval"][0].as_f64().unwrap(),
                c["auroc_diff_interval"][1].as_f64().unwrap(),
            );
            assert!(lo <= hi, "{c}");
            // Two seeds of the network meet the deterministic models' one run twice.
            assert_eq!(c["seeds"], 2, "{c}");
            assert_eq!(c["delong_p"].as_array().unwrap().len(), 2, "{c}");
        }
    }
    assert!(md.contains("Paired comparisons over all 2 seeds"), "{md}");
    assert!(md.contains("FireCast's forecaster `firecast`"), "{md}");

    // Every cell-day of a summer, scored at the true prevalence beside the generator's truth.
    let cells = |protocol: &str| {
        format!(
            r#"
stages:
  cells:
    uses: forecast.cell_days
    params: {{protocol: {protocol}, from: "2019-06-01", to: "2019-09-30", every_days: 5}}
    inputs:
      experiment: experiments/runs/cli-exp
      dataset: data/a
      gridmet: src-a/gridmet
      ignitions: w-a/ign.parquet
      truth: src-a/truth
    outputs:
      report: build/cells-{protocol}
"#
        )
    };
    p.write("pipelines/cells.yaml", &cells("leak_free"));
    let ran = p.run_pipeline("pipelines/cells.yaml", &[]);
    assert_eq!(ran["cells"], "ran", "{ran:?}");
    let r: serde_json::Value = serde_json::from_str(&p.read("build/cells-leak_free/cell_days.json")).unwrap();
    let (prevalence, prior) = (r["prevalence"].as_f64().unwrap(), r["prior"].as_f64().unwrap());
    assert!(r["cell_days"].as_u64().unwrap() > 20_000, "{r}");
    assert!(r["ignitions"].as_u64().unwrap() > 0, "{r}");
    assert!(prevalence < 0.01 && prior > 0.0 && prior < 0.01, "{r}");
    assert!(r["sampling_prevalence"].as_f64().unwrap() > 0.2, "{r}");
    let oracle = &r["oracle"];
    assert!(oracle["auprc"].as_f64().unwrap() > prevalence, "{oracle}");
    let rows = r["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 7, "every model of the protocol");
    for row in rows {
        assert!(row["auprc_share_of_oracle"].is_number(), "{row}");
        let (lo, hi) = (
            row["auprc_interval"][0].as_f64().unwrap(),
            row["auprc_interval"][1].as_f64().unwrap(),
        );
        assert!(lo.is_finite() && lo <= hi, "{row}");
        // Corrected to the prior, the forecasts are small on average (0.2 or more before).
        let (brier, mean) = (
            row["brier"].as_f64().unwrap(),
            row["mean_probability"].as_f64().unwrap(),
        );
        assert!(
            brier.is_finite() && brier < 0.5 && mean < 0.1,
            "prior-corrected: {row}"
        );
        if row["kind"] == "majority" {
            // The base rate it learnt, corrected, is the prior.
            assert_eq!(row["auroc"], 0.5);
            let mean = row["mean_probability"].as_f64().unwrap();
            assert!((mean / prior - 1.0).abs() < 0.3, "{mean} vs prior {prior}");
        }
    }
    let table = p.read("build/cells-leak_free/cell_days.md");
    assert!(
        table.contains("| oracle |") && table.contains("prior-corrected")
            || table.contains("prior correction"),
        "{table}"
    );
    assert!(p.path("build/cells-leak_free/reliability.png").is_file());
    // FireCast's recommended forecaster (here its network, the only one) against the best other.
    assert_eq!(r["comparison"]["model"], "firecast", "{}", r["comparison"]);
    assert!(
        table.contains("FireCast's recommended forecaster `firecast` against"),
        "{table}"
    );
    // The day's map over a region: every GRIDMET cell in the box, a PNG and its numbers.
    p.ok(&[
        "forecast",
        "map",
        "--experiment",
        "experiments/runs/cli-exp",
        "--model",
        "logistic_regression",
        "--gridmet",
        "src-a/gridmet",
        "--date",
        "2019-08-01",
        "--region",
        "39.0,39.5,-108.0,-107.5",
        "--out",
        "build/map",
    ]);
    let map: serde_json::Value = serde_json::from_str(&p.read("build/map/map.json")).unwrap();
    let (lats, lons) = (map["lats"].as_array().unwrap(), map["lons"].as_array().unwrap());
    assert!(
        (11..=13).contains(&lats.len()) && (11..=13).contains(&lons.len()),
        "{} x {}",
        lats.len(),
        lons.len()
    );
    assert!(lats.iter().all(|v| (39.0..=39.5).contains(&v.as_f64().unwrap())));
    for row in map["probability"].as_array().unwrap() {
        for v in row.as_array().unwrap() {
            assert!((0.0..=1.0).contains(&v.as_f64().unwrap()), "{v}");
        }
    }
    assert!(p.path("build/map/map.png").is_file());
    let out = p
        .firecast()
        .args([
            "forecast",
            "map",
            "--experiment",
            "experiments/runs/cli-exp",
            "--model",
            "logistic_regression",
        ])
        .args([
            "--gridmet",
            "src-a/gridmet",
            "--date",
            "2019-08-01",
            "--region",
            "39,38",
            "--out",
            "build/bad",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", describe(&out));
    assert!(describe(&out).contains("--region `39,38`"), "{}", describe(&out));
    assert!(!p.path("build/bad").exists());

    // A protocol the experiment does not have is named.
    p.write("pipelines/cells.yaml", &cells("nope"));
    let out = p
        .firecast()
        .args(["pipeline", "run", "pipelines/cells.yaml"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        describe(&out).contains("`nope` is not one of the experiment's protocols"),
        "{}",
        describe(&out)
    );

    // Unchanged experiment and dataset: nothing re-runs. Forced: the same numbers (CPU, seeds).
    let again = p.ok(&["experiment", "run", "experiments/cli.yaml"]);
    assert!(
        String::from_utf8_lossy(&again.stdout).contains("up to date"),
        "{}",
        describe(&again)
    );
    let first = metrics(&p);
    p.ok(&["experiment", "run", "experiments/cli.yaml", "--force"]);
    assert_eq!(
        first,
        metrics(&p),
        "same config and seeds must give the same metrics"
    );

    // The saved model, asked about the test samples' places and dates through GRIDMET, gives
    // back the scores the experiment recorded for them.
    let scores: BTreeMap<u32, f64> = p
        .read("experiments/runs/cli-exp/predictions.csv")
        .lines()
        .skip(1)
        .filter(|l| l.starts_with("paper,logistic_regression,0,"))
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[3].parse().unwrap(), f[5].parse().unwrap())
        })
        .collect();
    assert!(!scores.is_empty());
    let ids: Vec<String> = scores.keys().take(5).map(u32::to_string).collect();
    let rows = p.json(&[
        "query",
        &format!(
            "select sample_id, latitude, longitude, strftime(event_date, '%Y-%m-%d') as d \
             from read_parquet('data/a/samples.parquet') where sample_id in ({}) order by sample_id",
            ids.join(",")
        ),
    ]);
    let mut csv = String::from("lat,lon,date\n");
    let mut picked = Vec::new();
    for r in rows.as_array().unwrap() {
        csv.push_str(&format!(
            "{},{},{}\n",
            r["latitude"],
            r["longitude"],
            r["d"].as_str().unwrap()
        ));
        picked.push(r["sample_id"].as_u64().unwrap() as u32);
    }
    p.write("points.csv", &csv);
    let want = |model: &str| -> Vec<f64> {
        let recorded: BTreeMap<u32, f64> = p
            .read("experiments/runs/cli-exp/predictions.csv")
            .lines()
            .filter(|l| l.starts_with(&format!("paper,{model},0,")))
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                (f[3].parse().unwrap(), f[5].parse().unwrap())
            })
            .collect();
        picked.iter().map(|id| recorded[id]).collect()
    };
    // A model folder, and a network fetched from the artifact store by the run that saved it.
    let stage_run = p.json(&["runs", "list", "--stage", "cli-exp"])[0]["run_id"]
        .as_str()
        .unwrap()
        .to_string();
    for (model, name) in [
        (
            "experiments/runs/cli-exp/models/paper/logistic_regression/seed-0".to_string(),
            "logistic_regression",
        ),
        (format!("{stage_run}:paper/cnn_bilstm_R"), "cnn_bilstm_R"),
    ] {
        let answers = p.json(&[
            "forecast",
            "predict",
            "--model",
            &model,
            "--gridmet",
            "src-a/gridmet",
            "--points",
            "points.csv",
            "--device",
            "cpu",
        ]);
        let got: Vec<f64> = answers
            .as_array()
            .unwrap()
            .iter()
            .map(|a| a["probability"].as_f64().unwrap())
            .collect();
        let want = want(name);
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() < 1e-6, "{name}: predict {g} vs experiment {w}");
        }
        assert_eq!(answers[0]["model"], name);
        assert_eq!(answers[0]["input_days"], serde_json::json!([-60, 14]));
        // The day's chance beside the score: far below it (the samples are ~40 % fires, the
        // area's cell-days a fraction of a percent), in the same order, and at the score of the
        // training share exactly the usual day.
        let usual = answers[0]["usual_daily"].as_f64().expect("usual_daily");
        assert!(usual > 0.0 && usual < 0.05, "{usual}");
        let daily: Vec<f64> = answers
            .as_array()
            .unwrap()
            .iter()
            .map(|a| a["daily_probability"].as_f64().expect("daily_probability"))
            .collect();
        for (d, g) in daily.iter().zip(&got) {
            assert!(*d < *g && *d > 0.0, "{name}: daily {d} vs score {g}");
        }
        for i in 0..got.len() {
            for j in 0..got.len() {
                if got[i] < got[j] {
                    assert!(daily[i] < daily[j], "{name}: the correction keeps the order");
                }
            }
        }
    }
    let map: serde_json::Value = serde_json::from_str(&p.read("build/map/map.json")).unwrap();
    let usual = map["usual_daily"].as_f64().expect("the map's usual_daily");
    let daily = map["daily_probability"]
        .as_array()
        .expect("the map's daily_probability");
    assert_eq!(daily.len(), map["lats"].as_array().unwrap().len());
    for (row, scores) in daily.iter().zip(map["probability"].as_array().unwrap()) {
        for (d, s) in row.as_array().unwrap().iter().zip(scores.as_array().unwrap()) {
            let (d, s) = (d.as_f64().unwrap(), s.as_f64().unwrap());
            assert!(d < s && d > 0.0 && usual > 0.0, "{d} vs {s}");
        }
    }
    let out = p
        .firecast()
        .args([
            "forecast",
            "predict",
            "--model",
            &format!("{stage_run}:paper/svm"),
            "--gridmet",
            "src-a/gridmet",
        ])
        .args(["--lat", "39", "--lon", "-107", "--date", "2019-07-01"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("saved no model `paper/svm`; it saved: ")
            && stderr.contains("paper/cnn_bilstm_R/seed-0"),
        "{}",
        describe(&out)
    );

    // The two runs (first, forced) side by side: same params, same seed-averaged metrics.
    let runs = p.json(&["runs", "list", "--stage", "cli-exp"]);
    let compare = p.json(&[
        "runs",
        "compare",
        runs[1]["run_id"].as_str().unwrap(),
        runs[0]["run_id"].as_str().unwrap(),
        "--metric",
        "leak_free/cnn_bilstm_R/test/auroc",
    ]);
    assert_eq!(compare["params"], serde_json::json!({}), "{compare}");
    let auroc = &compare["metrics"]["leak_free/cnn_bilstm_R/test/auroc"];
    assert_eq!(auroc["runs"][0]["count"], 2, "one value per seed: {auroc}");
    assert_eq!(auroc["delta_mean"], 0.0, "{auroc}");

    // The saved models scored on two other years (forecast.evaluate), and refused on their own data.
    build_dataset(&p, "4", "2020", "2020", "b", "cli-fc-2020", false);
    p.write(
        "pipelines/later.yaml",
        "stages:\n  later:\n    uses: forecast.evaluate\n    params: {models: [logistic_regression, cnn_bilstm_R], evaluation: {bootstrap: 50}, device: cpu}\n    inputs: {models: experiments/runs/cli-exp, dataset: data/b}\n    outputs: {report: reports/later}\n",
    );
    p.run_pipeline("pipelines/later.yaml", &[]);
    let later: serde_json::Value = serde_json::from_str(&p.read("reports/later/results.json")).unwrap();
    let rows = later["results"].as_array().unwrap();
    assert_eq!(rows.len(), 4, "2 protocols x 2 models: {later}");
    for r in rows {
        assert!(r["test"]["auroc"].as_f64().unwrap().is_finite(), "{r}");
    }
    let cnn = rows.iter().find(|r| r["model"] == "cnn_bilstm_R").unwrap();
    assert_eq!(cnn["seeds"], serde_json::json!([0, 1]));
    assert!(
        p.read("reports/later/table3.md")
            .contains("saved models (trained on cli-fc")
    );
    p.write(
        "pipelines/same.yaml",
        "stages:\n  same:\n    uses: forecast.evaluate\n    params: {device: cpu}\n    inputs: {models: experiments/runs/cli-exp, dataset: data/a}\n    outputs: {report: reports/same}\n",
    );
    let out = p
        .firecast()
        .args(["pipeline", "run", "pipelines/same.yaml"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("evaluate on another dataset"),
        "{}",
        describe(&out)
    );
    assert!(
        !p.path("reports/same").exists(),
        "a failed evaluation publishes nothing"
    );

    // compare reads reports back and writes the combined table.
    p.ok(&[
        "experiment",
        "compare",
        "experiments/runs/cli-exp",
        "--out",
        "cmp",
    ]);
    assert!(p.path("cmp/table3.csv").is_file());
}

#[test]
fn bad_experiments_name_the_file_line_and_key() {
    let p = Project::new();
    let err = |text: &str| {
        p.write("experiments/bad.yaml", text);
        let out = p
            .firecast()
            .args(["experiment", "run", "experiments/bad.yaml"])
            .output()
            .unwrap();
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let base = "name: x\ndataset: data/a\nmodels:\n  - {kind: majority}\n";
    let e = err(&format!("{base}colour: red\n"));
    assert!(e.contains("experiments/bad.yaml") && e.contains("colour"), "{e}");
    let e = err("name: x\ndataset: data/a\nmodels:\n  - {kind: majority}\n  - {kind: svm}\n");
    assert!(
        e.contains("experiments/bad.yaml:5:3:")
            && e.contains("models[1].kind")
            && e.contains("unknown model `svm`"),
        "{e}"
    );
    let e = err("name: x\ndataset: data/a\nmodels:\n  - {kind: random_forest, params: {n_trees: 3}}\n");
    assert!(
        e.contains("experiments/bad.yaml:4:3:") && e.contains("models[0].params") && e.contains("n_trees"),
        "{e}"
    );
    let e = err("name: x\ndataset: data/a\nmodels:\n  - {kind: firecast, params: {max_epochs: 0}}\n");
    assert!(e.contains("max_epochs"), "{e}");
    let e = err(base);
    assert!(e.contains("data/a") && e.contains("dataset.json"), "{e}");
}

const BENCH_EXPERIMENT: &str = r#"
name: cli-bench
dataset: data/a
protocols:
  paper:
    days: [-60, 14]
    split: {method: stratified_random, test: 0.3, val: 0.25, seed: 42}
seeds: [0, 1]
device: cpu
models:
  - {kind: majority}
  - {kind: logistic_regression}
  - {kind: gaussian_nb}
  - {kind: decision_tree, params: {max_depth: 4}}
  - {kind: random_forest, params: {n_estimators: 10}}
  - {kind: gradient_boosting, params: {n_estimators: 10}}
  - {kind: knn}
  - {kind: xgboost, params: {n_estimators: 10}}
  - {kind: mlp, params: {max_epochs: 10, hidden: 16}}
  - {name: cnn_bilstm_R, kind: cnn_bilstm, params: {max_epochs: 2, hidden: 16, layers: 1}}
  - {kind: firecast, params: {max_epochs: 2}}
"#;

#[test]
fn bench_forecast_compares_every_baseline_and_network_with_its_python_reference() {
    let p = project_with_dataset();
    p.write("experiments/bench.yaml", BENCH_EXPERIMENT);
    // Never skipped: without the venv's scikit-learn, xgboost and torch the command fails.
    let out = p
        .firecast()
        .args([
            "--json",
            "bench",
            "forecast",
            "--experiment",
            "experiments/bench.yaml",
            "--threads",
            "1",
            "--steps",
            "3",
            "--warmup",
            "1",
            "--rounds",
            "2",
            "--projection-steps",
            "1",
            "--project-to",
            "5000",
        ])
        .output()
        .unwrap();
    let code = out.status.code();
    assert!(
        code == Some(0) || code == Some(1),
        "bench forecast failed:\n{}",
        describe(&out)
    );
    let r: serde_json::Value =
        serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("not JSON ({e}):\n{}", describe(&out)));
    assert_eq!(r["protocol"], "paper");
    assert_eq!(r["threads"], 1);
    let (train, test) = (r["train"].as_u64().unwrap(), r["test"].as_u64().unwrap());
    assert!(train > 0 && test > 0, "{r}");
    assert_eq!(r["flat_inputs"], 15 * 75);
    for k in ["sklearn", "xgboost", "torch"] {
        assert!(
            r["versions"][k].as_str().is_some_and(|v| !v.is_empty()),
            "{k}: {r}"
        );
    }

    // Every flattened baseline, both sides' numbers, the bounds applied as documented.
    let baselines = r["baselines"].as_array().unwrap();
    let kinds: Vec<&str> = baselines.iter().map(|b| b["kind"].as_str().unwrap()).collect();
    assert_eq!(
        kinds,
        [
            "logistic_regression",
            "gaussian_nb",
            "decision_tree",
            "random_forest",
            "gradient_boosting",
            "knn",
            "xgboost",
            "mlp"
        ]
    );
    for b in baselines {
        assert_eq!(b["from_experiment"], true, "{b}");
        for k in [
            "firecast_accuracy",
            "reference_accuracy",
            "firecast_accuracy_at_threshold",
            "reference_accuracy_at_threshold",
            "firecast_auroc",
            "reference_auroc",
        ] {
            let v = b[k].as_f64().unwrap_or_else(|| panic!("{k}: {b}"));
            assert!((0.0..=1.0).contains(&v), "{k}: {b}");
        }
        for k in ["firecast_fit_seconds", "reference_fit_seconds", "speed_ratio"] {
            assert!(b[k].as_f64().unwrap() > 0.0, "{k}: {b}");
        }
        // Baselines default to Table III's max-F1 threshold on validation.
        assert_eq!(b["threshold_rule"], "max F1 on validation", "{b}");
        let within = b["accuracy_delta_points"].as_f64().unwrap().abs() <= 1.5
            && b["threshold_accuracy_delta_points"].as_f64().unwrap().abs() <= 1.5
            && b["auroc_delta"].as_f64().unwrap().abs() <= 0.015;
        assert_eq!(b["within_bounds"].as_bool().unwrap(), within, "{b}");
    }
    // Hyper-parameters reach the reference resolved: the experiment's value and the defaults.
    assert_eq!(baselines[3]["params"]["n_estimators"], 10);
    assert_eq!(baselines[3]["params"]["max_features"], "sqrt");
    assert_eq!(baselines[6]["params"]["max_depth"], 6);
    // Deterministic estimators on the same arrays agree to rounding.
    for b in baselines
        .iter()
        .filter(|b| ["gaussian_nb", "knn", "xgboost"].contains(&b["kind"].as_str().unwrap()))
    {
        assert!(b["max_abs_proba_diff"].as_f64().unwrap() < 1e-3, "{b}");
        assert_eq!(b["within_bounds"], true, "{b}");
    }
    // The trees are scikit-learn's (same random_state): same scores, same thresholds.
    for b in baselines.iter().filter(|b| {
        ["decision_tree", "random_forest", "gradient_boosting"].contains(&b["kind"].as_str().unwrap())
    }) {
        assert!(b["max_abs_proba_diff"].as_f64().unwrap() < 1e-12, "{b}");
        assert_eq!(b["firecast_threshold"], b["reference_threshold"], "{b}");
        assert_eq!(b["accuracy_delta_points"], 0.0, "{b}");
        assert_eq!(b["threshold_accuracy_delta_points"], 0.0, "{b}");
    }
    // FireCast's MLP and scikit-learn's have the same size.
    let mlp = &baselines[7];
    assert_eq!(mlp["kind"], "mlp");
    assert_eq!(mlp["firecast_parameters"], mlp["reference_parameters"], "{mlp}");
    assert_eq!(mlp["firecast_parameters"], 1125 * 16 + 16 + 16 + 1);
    let all = baselines.iter().all(|b| b["within_bounds"] == true);
    assert_eq!(r["all_within_bounds"].as_bool().unwrap(), all);

    // Every network: tch and PyTorch eager count the same parameters.
    let counts = r["parameters"].as_array().unwrap();
    let mut nets: Vec<&str> = counts.iter().map(|c| c["kind"].as_str().unwrap()).collect();
    nets.sort_unstable();
    assert_eq!(
        nets,
        [
            "cnn_bilstm",
            "cnn_bilstm_attn",
            "firecast",
            "lightts",
            "lstm2",
            "mlp"
        ]
    );
    for c in counts {
        assert!(c["tch"].as_i64().unwrap() > 0, "{c}");
        assert_eq!(c["tch"], c["pytorch"], "{c}");
    }
    assert_eq!(r["all_parameters_equal"], true);
    // The experiment's small R network is the one counted and timed.
    let r_net = counts.iter().find(|c| c["model"] == "cnn_bilstm_R").unwrap();
    assert_eq!(
        (r_net["hidden"].as_i64(), r_net["width"].as_i64()),
        (Some(16), Some(14))
    );

    // Throughput of the R network on both engines, same threads.
    let t = &r["throughput"];
    assert_eq!(t["model"], "cnn_bilstm_R");
    assert_eq!((t["threads"].as_u64(), t["steps"].as_u64()), (Some(1), Some(3)));
    for k in ["tch_samples_per_s", "pytorch_samples_per_s", "ratio"] {
        let v = t[k].as_f64().unwrap();
        assert!(v.is_finite() && v > 0.0, "{k}: {t}");
    }
    // Alternating rounds; the best of each side is the one compared.
    assert_eq!(t["rounds"], 2);
    for (side, best) in [
        ("tch_rounds_samples_per_s", "tch_samples_per_s"),
        ("pytorch_rounds_samples_per_s", "pytorch_samples_per_s"),
    ] {
        let rounds: Vec<f64> = t[side]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(rounds.len(), 2, "{t}");
        assert_eq!(
            rounds.iter().copied().fold(0.0, f64::max),
            t[best].as_f64().unwrap()
        );
    }

    // The projection covers every model of the experiment, with its method.
    let proj = &r["projection"];
    assert_eq!(proj["windows"], 5000);
    let share = proj["train_share"].as_f64().unwrap();
    assert_eq!(
        proj["train_rows"].as_u64().unwrap(),
        (5000.0 * share).round() as u64
    );
    let models = proj["models"].as_array().unwrap();
    assert_eq!(models.len(), 11);
    for m in models {
        let s = m["projected_seconds"].as_f64().unwrap();
        assert!(s.is_finite() && s > 0.0, "{m}");
        match m["kind"].as_str().unwrap() {
            "mlp" | "cnn_bilstm" | "firecast" => {
                assert_eq!(m["method"], "per epoch", "{m}");
                assert_eq!(m["runs"], 2, "{m}");
            }
            kind => {
                assert_eq!(m["method"], "power law", "{m}");
                assert_eq!(m["measured"].as_array().unwrap().len(), 3, "{m}");
                let b = m["exponent_used"].as_f64().unwrap();
                assert!((1.0..=3.0).contains(&b), "{m}");
                let runs = if kind == "random_forest" { 2 } else { 1 };
                assert_eq!(m["runs"], runs, "{m}");
            }
        }
    }
    assert!(proj["total_seconds"].as_f64().unwrap() > 0.0);
    assert!(proj["method"].as_str().unwrap().contains("ln t = a + b ln n"));

    // The exit status says whether everything was within bounds.
    assert_eq!(code == Some(0), all, "{}", describe(&out));

    // Tables for people name both sides and the verdict.
    let out = p
        .firecast()
        .args([
            "bench",
            "forecast",
            "--experiment",
            "experiments/bench.yaml",
            "--threads",
            "1",
            "--steps",
            "2",
            "--warmup",
            "0",
            "--rounds",
            "1",
            "--projection-steps",
            "1",
            "--project-to",
            "5000",
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    for want in [
        "sklearn.ensemble.RandomForestClassifier",
        "xgboost.XGBClassifier",
        "sklearn.neural_network.MLPClassifier",
        "tch / PyTorch =",
        "Full-size projection",
        "projected total",
    ] {
        assert!(text.contains(want), "{want}:\n{}", describe(&out));
    }
    assert_eq!(
        out.status.code() == Some(0),
        !text.contains("OUT OF BOUNDS"),
        "{text}"
    );
}

#[test]
fn sharded_experiment_equals_unsharded_locally() {
    let p = project_with_dataset();
    p.write("pipelines/exp.yaml", &experiment_stage(None));
    let report = p.json(&["pipeline", "run", "pipelines/exp.yaml"]);
    assert_eq!(outcomes(&report)["table3"], "ran", "{report}");
    let whole = files_under(&p.path("build/table3"));
    let whole_lock = lock_without_run_ids(&p, "pipelines/exp.lock");
    let (whole_metrics, whole_artifacts) = recorded(&p, first_stage_run_id(&report));
    // Per unit (test metrics per seed, curves, fit times), per row, the experiment's time.
    for key in [
        "paper/cnn_bilstm_R/test/auroc",
        "paper/mlp/seed1/val_auprc",
        "leak_free/minirocket/fit_seconds",
        "leak_free/mlp/auroc",
        "experiment_seconds",
    ] {
        assert!(whole_metrics.contains_key(key), "{key}: {whole_metrics:?}");
    }
    assert_eq!(
        whole_metrics["paper/cnn_bilstm_R/test/auroc"][0], 2.0,
        "one value per seed"
    );
    assert!(
        whole_artifacts.contains_key("model/paper/mlp/seed-1"),
        "{whole_artifacts:?}"
    );

    // `--jobs` only schedules stages: the networks' thread count is the stage's `threads`
    // param (default 1), so another `--jobs` is the same cache key and the same bytes.
    let report = p.json(&["pipeline", "run", "pipelines/exp.yaml", "-j", "1"]);
    assert_eq!(outcomes(&report)["table3"], "up_to_date", "{report}");
    p.json(&["pipeline", "run", "pipelines/exp.yaml", "-j", "1", "--force"]);
    assert!(
        files_under(&p.path("build/table3")) == whole,
        "-j 1 wrote other files than the default --jobs"
    );

    for n in [2, 3] {
        p.write("pipelines/exp.yaml", &experiment_stage(Some(n)));
        let report = p.json(&["pipeline", "run", "pipelines/exp.yaml", "--force"]);
        assert_eq!(outcomes(&report)["table3"], "ran", "{report}");
        let sharded = files_under(&p.path("build/table3"));
        assert_eq!(
            sharded.keys().collect::<Vec<_>>(),
            whole.keys().collect::<Vec<_>>(),
            "{n} shards"
        );
        for (file, bytes) in &whole {
            assert!(
                sharded[file] == *bytes,
                "{file} differs between the unsharded run and {n} shards"
            );
        }
        assert_eq!(lock_without_run_ids(&p, "pipelines/exp.lock"), whole_lock);
        // The same metrics (times aside) and model artifacts as the unsharded run.
        let (metrics, artifacts) = recorded(&p, first_stage_run_id(&report));
        assert_eq!(metrics, whole_metrics, "{n} shards");
        assert_eq!(artifacts, whole_artifacts, "{n} shards");
        let log = stage_log(&p, first_stage_run_id(&report));
        assert!(
            log.contains(&format!("shard {}/{n}: ", n - 1))
                && log.contains(&format!("# merged {n} shards"))
                && log.contains(&format!("merged {n} shards: 16 training units")),
            "{log}"
        );
    }
    assert!(
        std::fs::read_dir(p.path(".firecast/shards")).map_or(0, Iterator::count) == 0,
        "no parts are left behind"
    );

    // The thread count can change the numbers, so it is part of the cache key.
    p.write(
        "pipelines/exp.yaml",
        &experiment_stage(None).replace("      device: cpu\n", "      device: cpu\n      threads: 2\n"),
    );
    let report = p.json(&["pipeline", "run", "pipelines/exp.yaml"]);
    assert_eq!(outcomes(&report)["table3"], "ran", "{report}");
    assert!(
        p.read("pipelines/exp.lock").contains("threads: 2"),
        "{}",
        p.read("pipelines/exp.lock")
    );

    p.write("pipelines/exp.yaml", &experiment_stage(Some(17)));
    let out = p
        .firecast()
        .args(["pipeline", "status", "pipelines/exp.yaml"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("pipelines/exp.yaml:5:")
            && stderr.contains(
                "stages.table3.shards: 17 shards for 16 training units: use between 1 and 16 \
                 (one training unit per shard at least)"
            ),
        "{}",
        describe(&out)
    );
}

/// FireCast's `climate_offset`: the fire history's kernel width and the tree count are chosen
/// on validation and saved with the model; an experiment file may extend another and change
/// only what differs, and a mistake in it names that file and line.
#[test]
fn climate_offset_chooses_on_validation_and_experiments_extend_one_another() {
    let p = project_with_dataset();
    p.write(
        "experiments/base.yaml",
        r#"
name: base
dataset: data/a
protocols:
  leak_free:
    days: [-30, -1]
    split: {method: stratified_random, test: 0.3, val: 0.25, seed: 42, grouped: true}
seeds: [0]
evaluation: {bootstrap: 50}
device: cpu
models:
  - {kind: climatology}
  - {kind: climate_offset, params: {n_estimators: 30, max_depth: 2, subsample: 0.8, kernel_degrees: [0.2, 0.5], nthread: 1}}
"#,
    );
    p.write(
        "experiments/more/child.yaml",
        "extends: ../base.yaml\nname: child\nseeds: [0, 1]\nevaluation: {bootstrap: 40}\n",
    );
    let out = p.ok(&["experiment", "run", "experiments/more/child.yaml"]);
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(stdout.contains("climate_offset"), "{stdout}");
    let results: serde_json::Value =
        serde_json::from_str(&p.read("experiments/runs/child/results.json")).unwrap();
    assert_eq!(results["bootstrap"], 40, "the child's evaluation");
    let offset = results["results"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["kind"] == "climate_offset")
        .expect("climate_offset row");
    assert_eq!(offset["family"], "firecast");
    assert_eq!(
        offset["runs"].as_array().unwrap().len(),
        2,
        "the child's seeds: {offset}"
    );
    for seed in 0..2 {
        let model: serde_json::Value = serde_json::from_str(&p.read(&format!(
            "experiments/runs/child/models/leak_free/climate_offset/seed-{seed}/model.json"
        )))
        .unwrap();
        let model = &model["model"];
        let width = model["climatology"]["params"]["kernel_degrees"].as_f64().unwrap();
        assert!(width == 0.2 || width == 0.5, "{width}");
        assert!(model["rounds"].as_u64().unwrap() <= 30, "{}", model["rounds"]);
        let (a, _) = (
            model["calibration"][0].as_f64().unwrap(),
            model["calibration"][1].as_f64().unwrap(),
        );
        assert!(a > 0.0, "the fire history raises the odds: {a}");
    }

    // A typo in the extending file is placed there; a missing base where `extends` names it.
    let refused = |child: &str| {
        p.write("experiments/more/child.yaml", child);
        let out = p
            .firecast()
            .args(["experiment", "run", "experiments/more/child.yaml"])
            .output()
            .unwrap();
        assert!(!out.status.success(), "{child}");
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let e = refused("extends: ../base.yaml\nname: child\nseedz: [0, 1]\n");
    assert!(
        e.contains("experiments/more/child.yaml:3") && e.contains("seedz"),
        "{e}"
    );
    let e = refused("extends: ../nowhere.yaml\nname: child\n");
    assert!(
        e.contains("experiments/more/child.yaml:1") && e.contains("nowhere.yaml"),
        "{e}"
    );
}
