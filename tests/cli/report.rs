//! The threat-report flow through the real binary on a small fire: synthetic GRIDMET files,
//! a PPO agent trained for a few steps, ensembles without suppression, under the rule-based
//! plan and under the agent, then the `report` stage — and bad input that must not leave a
//! report behind. (The forecast comes from a file in the `forecast.predict` format: training
//! a forecaster needs a whole dataset, which the demo and `pipelines/threat.yaml` build.)

use crate::{Project, describe};

const LAT: f64 = 39.3;
const LON: f64 = -107.4;

pub(crate) fn pipeline(lat: f64, lon: f64) -> String {
    format!(
        r#"
vars:
  lat: {lat}
  lon: {lon}
  date: "2019-08-01"
stages:
  sources:
    uses: data.synthesize
    params:
      seed: 5
      region: {{lat_min: 39.1, lat_max: 39.5, lon_min: -107.6, lon_max: -107.2}}
      years: [2019, 2019]
      variables: [vs, th, tmmx, tmmn, rmin, rmax, pr, erc, fm100]
    outputs:
      gridmet: build/sources/gridmet
      incidents: build/sources/incidents.csv
      model: build/sources/MODEL.md
  agent:
    uses: rl.train
    params:
      name: tiny-agent
      env: {{kind: helitack}}
      policy: {{kind: compact}}
      ppo: {{preset: paper, n_envs: 2, n_steps: 16, batch_size: 16, n_epochs: 1, total_timesteps: 32}}
      seeds: [0]
      device: cpu
    inputs:
      fires: fires.yaml
    outputs:
      run: build/agent
  unsuppressed:
    uses: sim.ensemble
    params:
      landscape: {{procedural: {{seed: 2, width: 48, height: 32, center: [{LAT}, {LON}]}}}}
      agent: none
      runs: 4
      weather_date: ${{date}}
      ignition: ["${{lat}}", "${{lon}}"]
      env: &env
        max_steps: 60
        sim: {{kernel: {{rothermel: {{moisture: {{dead_1h_frac: 0.06, dead_10h_frac: 0.07, dead_100h_frac: 0.08, live_herb_frac: 0.6, live_woody_frac: 0.9}}}}}}}}
    inputs:
      gridmet: {{from: sources.gridmet}}
    outputs:
      ensemble: build/none.json
  rule_plan:
    uses: sim.ensemble
    params:
      landscape: {{procedural: {{seed: 2, width: 48, height: 32, center: [{LAT}, {LON}]}}}}
      agent: rule
      runs: 4
      weather_date: ${{date}}
      ignition: ["${{lat}}", "${{lon}}"]
      env: *env
    inputs:
      gridmet: {{from: sources.gridmet}}
    outputs:
      ensemble: build/rule.json
  agent_plan:
    uses: rl.ensemble
    params:
      landscape: {{procedural: {{seed: 2, width: 48, height: 32, center: [{LAT}, {LON}]}}}}
      runs: 4
      weather_date: ${{date}}
      ignition: ["${{lat}}", "${{lon}}"]
      env: *env
      device: cpu
    inputs:
      run: {{from: agent.run}}
      gridmet: {{from: sources.gridmet}}
    outputs:
      ensemble: build/ppo.json
  report:
    uses: report
    params:
      lat: ${{lat}}
      lon: ${{lon}}
      date: ${{date}}
      bootstrap_resamples: 200
    inputs:
      ensembles: [{{from: unsuppressed.ensemble}}, {{from: rule_plan.ensemble}}, {{from: agent_plan.ensemble}}]
      forecast: forecast.json
      gridmet: {{from: sources.gridmet}}
    outputs:
      html: {{path: build/report.html, artifact: true}}
      json: {{path: build/report.json, artifact: true}}
      geojson: {{path: build/report.geojson, artifact: true}}
      pdf: {{path: build/report.pdf, artifact: true}}
"#
    )
}

pub(crate) const FIRES: &str = r#"
profile: p2
train:
  landscape_seeds: [1]
  width: 48
  height: 32
  fires: 2
  seed: 1
  wind_speed_mph: [3, 6]
  dead_1h_frac: [0.06, 0.1]
  ignition_margin_cells: 8
  env: {max_steps: 30}
evaluate:
  landscape_seeds: [11]
  width: 48
  height: 32
  fires: 2
  seed: 2
  wind_speed_mph: [3, 6]
  dead_1h_frac: [0.06, 0.1]
  ignition_margin_cells: 8
  env: {max_steps: 30}
"#;

pub(crate) fn forecast(lat: f64, lon: f64) -> String {
    serde_json::json!({
        "version": 1, "lat": lat, "lon": lon, "date": "2019-08-01", "cell_lat": lat, "cell_lon": lon,
        "model": "xgboost", "kind": "xgboost", "protocol": "leak_free", "dataset": "fixture",
        "dataset_version": "fixture", "input_days": [-60, -1], "threshold": 0.5, "probability": 0.3,
        "interval": [0.2, 0.4], "interval_method": "range over 2 training seeds",
        "per_seed": [{"seed": 0, "probability": 0.2}, {"seed": 1, "probability": 0.4}],
        "validation_auroc": 0.7, "test_auroc": null, "ignition_expected": false
    })
    .to_string()
}

fn project(lat: f64, lon: f64) -> Project {
    let p = Project::new();
    p.write("pipelines/threat.yaml", &pipeline(lat, lon));
    p.write("fires.yaml", FIRES);
    p.write("forecast.json", &forecast(lat, lon));
    p
}

#[test]
fn threat_report_end_to_end_is_cached_and_registered() {
    let p = project(LAT, LON);
    let first = p.run_pipeline("pipelines/threat.yaml", &[]);
    assert!(first.values().all(|o| o == "ran"), "{first:?}");
    let report: serde_json::Value = serde_json::from_str(&p.read("build/report.json")).unwrap();
    let strategies: Vec<&str> = report["strategies"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["strategy"].as_str().unwrap())
        .collect();
    assert_eq!(strategies, ["none", "rule", "ppo"]);
    // The agent's drops, or the rule plan's when the agent's representative run (median
    // burnt area) made none — as a 32-step agent may.
    let ppo: serde_json::Value = serde_json::from_str(&p.read("build/ppo.json")).unwrap();
    let mut order: Vec<(u64, u64, usize)> = ppo["episodes"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .map(|(i, r)| {
            (
                r["cells_burned"].as_u64().unwrap(),
                r["seed"].as_u64().unwrap(),
                i,
            )
        })
        .collect();
    order.sort_unstable();
    let median = order[(order.len() - 1) / 2].2;
    let agent_dropped = !ppo["episodes"][median]["drops"].as_array().unwrap().is_empty();
    assert_eq!(
        report["drops"]["strategy"],
        if agent_dropped { "ppo" } else { "rule" }
    );
    assert_eq!(report["forecast"]["probability"], 0.3);
    // The numbers come from the ensemble files the stages wrote.
    let none: serde_json::Value = serde_json::from_str(&p.read("build/none.json")).unwrap();
    let runs = none["episodes"].as_array().unwrap();
    let cells: f64 = runs
        .iter()
        .map(|r| r["cells_burned"].as_f64().unwrap())
        .sum::<f64>()
        / runs.len() as f64;
    let acres = report["strategies"][0]["burned_acres"]["value"].as_f64().unwrap();
    assert!((acres - cells * 500.0 * 500.0 / 43_560.0).abs() < 1e-6);
    assert!(
        std::fs::read(p.path("build/report.pdf"))
            .unwrap()
            .starts_with(b"%PDF-")
    );
    // Registered artifacts under their final names.
    let runs = p.json(&["runs", "list"]);
    let id = runs
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["stage"] == "report")
        .map(|r| r["run_id"].as_str().unwrap().to_string())
        .expect("a report run");
    let shown = p.json(&["runs", "show", &id]);
    let text = shown.to_string();
    for name in ["report.html", "report.pdf", "report.json", "report.geojson"] {
        assert!(text.contains(name), "{name} not registered: {text}");
    }
    assert!(!text.contains("firecast-tmp"), "temporary names leaked: {text}");
    // A second run is up to date throughout.
    let again = p.run_pipeline("pipelines/threat.yaml", &[]);
    assert!(again.values().all(|o| o == "up_to_date"), "{again:?}");
}

#[test]
fn a_point_without_fuel_or_outside_the_landscape_leaves_no_report() {
    // Far outside the 48 × 32 landscape around (39.3, −107.4).
    let p = project(39.6, -107.4);
    let out = p
        .firecast()
        .args(["pipeline", "run", "pipelines/threat.yaml"])
        .output()
        .unwrap();
    assert!(!out.status.success(), "{}", describe(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("ignition") && err.contains("outside the landscape"),
        "{err}"
    );
    assert!(!p.path("build/report.html").exists() && !p.path("build/report.json").exists());
}
