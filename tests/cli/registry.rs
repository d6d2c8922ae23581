//! The DuckDB run registry through the CLI: runs, parents, lineage, metrics, datasets, SQL.

use crate::{Project, describe, outcomes};

const TRAIN: &str = r#"
vars:
  lr: 0.1
stages:
  data:
    uses: cmd
    params: {command: "printf 'station,temp_k\nA,290.5\nB,301.25\nC,288\n' > ${outputs.csv}"}
    outputs: {csv: data/stations.csv}
  hot:
    uses: sql
    params:
      query: SELECT station, temp_k - 273.15 AS temp_c FROM stations WHERE temp_k > 289 ORDER BY station
      dataset: hot_stations
    inputs: {stations: {from: data.csv}}
    outputs: {table: datasets/hot.parquet}
  train:
    uses: cmd
    params:
      command: |
        for s in 1 2 3; do
          awk -v lr=${lr} -v s=$s 'BEGIN { printf "loss %d %.17g\n", s, lr / s }' >> "$FIRECAST_METRICS"
        done
        echo done > ${outputs.model}
    inputs: {rows: {from: hot.table}}
    outputs: {model: {path: models/model.txt, artifact: true}}
"#;

#[test]
fn runs_lineage_metrics_datasets_round_trip() {
    let p = Project::new();
    p.write("pipelines/train.yaml", TRAIN);
    p.run_pipeline("pipelines/train.yaml", &[]);

    let runs = p.json(&["runs", "list"]);
    let runs = runs.as_array().unwrap();
    assert_eq!(runs.len(), 4, "3 stage runs + 1 pipeline run: {runs:#?}");
    assert!(runs.iter().all(|r| r["status"] == "succeeded"), "{runs:#?}");
    let pipeline_run = runs.iter().find(|r| r["kind"] == "pipeline").unwrap();
    let train = runs.iter().find(|r| r["stage"] == "train").unwrap();
    assert_eq!(train["pipeline_run_id"], pipeline_run["run_id"]);
    assert!(train["params"]["command"].as_str().unwrap().contains("lr=0.1 "));
    assert_eq!(train["cache_key"].as_str().unwrap().len(), 64);

    // Show: metrics summarised, lineage with hashes, artifact uploaded.
    let train_id = train["run_id"].as_str().unwrap();
    let show = p.json(&["runs", "show", train_id]);
    let loss = &show["metrics"][0];
    assert_eq!(loss["key"], "loss");
    assert_eq!(loss["count"], 3);
    assert_eq!(loss["min_step"], 3);
    assert!((loss["last"].as_f64().unwrap() - 0.1 / 3.0).abs() < 1e-9);
    let lineage = show["lineage"].as_array().unwrap();
    assert!(
        lineage
            .iter()
            .any(|l| l["direction"] == "input" && l["uri"] == "datasets/hot.parquet")
    );
    assert!(
        lineage
            .iter()
            .any(|l| l["direction"] == "output" && l["uri"] == "models/model.txt")
    );
    let artifact_uri = |name: &str| {
        show["artifacts"]
            .as_array()
            .unwrap()
            .iter()
            .find(|a| a["name"] == name)
            .and_then(|a| a["uri"].as_str())
            .unwrap_or_else(|| panic!("no artifact {name}: {show}"))
            .to_string()
    };
    let model = artifact_uri("model");
    assert!(
        model.ends_with(&format!("runs/{train_id}/model/model.txt")),
        "{model}"
    );
    // The stage reported metrics, so its curves are a Rerun recording too.
    let recording = artifact_uri("metrics");
    assert!(
        recording.ends_with(&format!("runs/{train_id}/metrics/metrics.rrd")),
        "{recording}"
    );

    // The sql stage registered a dataset; query reaches it as a view.
    let rows = p.json(&[
        "query",
        "SELECT station, round(temp_c, 2) AS c FROM hot_stations ORDER BY station",
    ]);
    assert_eq!(
        rows,
        serde_json::json!([{"station": "A", "c": 17.35}, {"station": "B", "c": 28.1}])
    );
    let datasets = p.json(&["query", "SELECT name, rows, length(version) AS v FROM datasets"]);
    assert_eq!(
        datasets,
        serde_json::json!([{"name": "hot_stations", "rows": 2, "v": 16}])
    );

    // A changed param is a new run whose parent is the earlier run; params never change.
    p.run_pipeline("pipelines/train.yaml", &["-S", "lr=0.5"]);
    let trains = p.json(&["runs", "list", "--stage", "train"]);
    let trains = trains.as_array().unwrap();
    assert_eq!(trains.len(), 2);
    assert_eq!(trains[0]["parent_run_id"], trains[1]["run_id"]);
    assert!(
        trains[1]["params"]["command"]
            .as_str()
            .unwrap()
            .contains("lr=0.1 "),
        "old params changed"
    );

    let compare = p.json(&[
        "runs",
        "compare",
        trains[1]["run_id"].as_str().unwrap(),
        trains[0]["run_id"].as_str().unwrap(),
    ]);
    let command = compare["params"]["command"].as_array().unwrap();
    assert_ne!(command[0], command[1]);
    let last_losses: Vec<f64> = compare["metrics"]["loss"]["runs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["last"].as_f64().unwrap())
        .collect();
    assert!(
        (last_losses[1] / last_losses[0] - 5.0).abs() < 1e-9,
        "{last_losses:?}"
    );
    // Means over the three steps (lr · 11/18) and their difference, second minus first.
    let loss = &compare["metrics"]["loss"];
    assert!((loss["runs"][0]["mean"].as_f64().unwrap() - 0.1 * 11.0 / 18.0).abs() < 1e-12);
    assert!((loss["delta_mean"].as_f64().unwrap() - 0.4 * 11.0 / 18.0).abs() < 1e-12);

    // Tables for people.
    let text = p.ok(&[
        "runs",
        "compare",
        trains[1]["run_id"].as_str().unwrap(),
        trains[0]["run_id"].as_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(text.contains("≠ param command"), "{text}");
    assert!(text.contains("loss (mean [min, max] n)"), "{text}");
    assert!(text.contains("+0.2444"), "{text}");
    assert!(text.contains("params are equal in every run"), "{text}");
}

#[test]
fn registry_path_is_configurable_and_query_errors_are_clear() {
    let p = Project::new();
    p.write("pipelines/one.yaml", "stages:\n  a:\n    uses: cmd\n    params: {command: \"echo 1 > ${outputs.o}\"}\n    outputs: {o: o.txt}\n");
    p.write("firecast.yaml", "registry: tracking/runs.duckdb\n");
    p.run_pipeline("pipelines/one.yaml", &[]);
    assert!(p.path("tracking/runs.duckdb").exists());
    assert!(!p.path(".firecast/registry.duckdb").exists());
    let n = p.json(&["query", "SELECT count(*) AS n FROM runs"]);
    assert_eq!(n, serde_json::json!([{"n": 2}]));

    let out = p
        .firecast()
        .args(["query", "SELECT nope FROM runs"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.starts_with("error: registry query failed:"), "{stderr}");

    p.write("firecast.yaml", "registyr: x\n");
    let out = p.firecast().args(["runs", "list"]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.starts_with("error: firecast.yaml:1:1: registyr: unknown field `registyr`, expected one of `registry`, `store`, `jobs`"),
        "{stderr}"
    );
}

/// A slow two-stage pipeline: each stage logs metrics and sleeps, so two of them started
/// together interleave their registry writes for a few seconds.
fn slow_pipeline(name: &str) -> String {
    format!(
        r#"
stages:
  first:
    uses: cmd
    params:
      command: |
        for i in 1 2 3 4 5 6; do echo "tick $i $i" >> "$FIRECAST_METRICS"; sleep 0.2; done
        echo {name} > ${{outputs.o}}
    outputs: {{o: out/{name}-first.txt}}
  second:
    uses: cmd
    params:
      command: |
        sleep 1
        cat ${{inputs.i}} ${{inputs.i}} > ${{outputs.o}}
    inputs: {{i: {{from: first.o}}}}
    outputs: {{o: out/{name}-second.txt}}
"#
    )
}

#[test]
fn two_pipeline_runs_and_a_reader_share_one_registry_at_once() {
    let p = Project::new();
    p.write("pipelines/left.yaml", &slow_pipeline("left"));
    p.write("pipelines/right.yaml", &slow_pipeline("right"));
    // Each process holds the registry only per operation; neither is shut out while the
    // other runs, and a third reads meanwhile.
    let spawn = |file: &str| {
        p.firecast()
            .args(["--json", "pipeline", "run", file])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let left = spawn("pipelines/left.yaml");
    let right = spawn("pipelines/right.yaml");
    std::thread::sleep(std::time::Duration::from_millis(700));
    let during = p.json(&["runs", "list"]);
    assert!(during.as_array().is_some(), "{during}");

    for (name, child) in [("left", left), ("right", right)] {
        let out = child.wait_with_output().unwrap();
        assert!(out.status.success(), "{name}:\n{}", describe(&out));
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let stages = outcomes(&report);
        assert!(stages.values().all(|o| o == "ran"), "{name}: {stages:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        // A registry write that gave up would be a warning, not a failure.
        assert!(
            !stderr.contains("registry") && !stderr.contains("not registered"),
            "{name}: {stderr}"
        );
        assert_eq!(
            p.read(&format!("out/{name}-second.txt")),
            format!("{name}\n{name}\n")
        );
    }

    let runs = p.json(&["runs", "list"]);
    let runs = runs.as_array().unwrap();
    assert_eq!(runs.len(), 6, "2 pipeline runs + 4 stage runs: {runs:#?}");
    assert!(runs.iter().all(|r| r["status"] == "succeeded"), "{runs:#?}");
    for name in ["left", "right"] {
        let pipeline = runs
            .iter()
            .find(|r| r["kind"] == "pipeline" && r["pipeline"] == name)
            .unwrap_or_else(|| panic!("no pipeline run of {name}: {runs:#?}"));
        let first = runs
            .iter()
            .find(|r| r["pipeline"] == name && r["stage"] == "first")
            .unwrap();
        assert_eq!(first["pipeline_run_id"], pipeline["run_id"]);
        let shown = p.json(&["runs", "show", first["run_id"].as_str().unwrap()]);
        assert_eq!(shown["metrics"][0]["key"], "tick");
        assert_eq!(shown["metrics"][0]["count"], 6);
    }
}

#[test]
fn runs_of_a_killed_process_read_as_crashed() {
    let p = Project::new();
    p.write(
        "pipelines/long.yaml",
        r#"
stages:
  wait:
    uses: cmd
    params:
      command: sleep 20 && echo done > ${outputs.o}
    outputs: {o: out/long.txt}
"#,
    );
    let mut child = p
        .firecast()
        .args(["--json", "pipeline", "run", "pipelines/long.yaml"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Wait until the stage run is recorded as running, then kill the process under it.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(30);
    loop {
        let running = p.json(&["runs", "list", "--status", "running"]);
        if running.as_array().is_some_and(|r| r.len() == 2) {
            break;
        }
        assert!(std::time::Instant::now() < deadline, "never running: {running}");
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let runs = p.json(&["runs", "list"]);
    let statuses: Vec<&str> = runs
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["status"].as_str().unwrap())
        .collect();
    assert_eq!(statuses, ["crashed", "crashed"], "{runs:#}");
    assert_eq!(
        p.json(&["runs", "list", "--status", "crashed"])
            .as_array()
            .unwrap()
            .len(),
        2
    );
    assert!(
        p.json(&["runs", "list", "--status", "running"])
            .as_array()
            .unwrap()
            .is_empty()
    );
}
