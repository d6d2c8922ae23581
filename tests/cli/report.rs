//! The threat-report flow through the real binary on a small fire: synthetic GRIDMET files,
//! a PPO agent trained for a few steps, ensembles without suppression, under the rule-based
//! plan and under the agent, then the `report` stage — and bad input that must not leave a
//! report behind, nor touch the report of another place or day. (The forecast comes from a
//! file in the `forecast.predict` format: training a forecaster needs a whole dataset, which
//! the demo and `pipelines/threat.yaml` build.)
//!
//! As in `pipelines/threat.yaml`, each place and day has its own folders: the report in
//! `build/<lat>_<lon>/<date>/`, the ensembles it is made from in `build/work/<lat>_<lon>/<date>/`.

use std::collections::BTreeMap;
use std::path::Path;

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
  report_dir: build/${{lat}}_${{lon}}/${{date}}
  work_dir: build/work/${{lat}}_${{lon}}/${{date}}
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
      ensemble: ${{work_dir}}/none.json
  free_spread:
    uses: sim.ensemble
    params:
      landscape: {{procedural: {{seed: 2, width: 48, height: 32, center: [{LAT}, {LON}]}}}}
      engine: mtt
      agent: none
      runs: 4
      weather_date: ${{date}}
      ignition: ["${{lat}}", "${{lon}}"]
      env: *env
    inputs:
      gridmet: {{from: sources.gridmet}}
    outputs:
      ensemble: ${{work_dir}}/mtt.json
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
      ensemble: ${{work_dir}}/rule.json
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
      ensemble: ${{work_dir}}/ppo.json
  report:
    uses: report
    params:
      lat: ${{lat}}
      lon: ${{lon}}
      date: ${{date}}
      bootstrap_resamples: 200
    inputs:
      ensembles: [{{from: unsuppressed.ensemble}}, {{from: rule_plan.ensemble}}, {{from: agent_plan.ensemble}}]
      spread: {{from: free_spread.ensemble}}
      forecast: forecast.json
      gridmet: {{from: sources.gridmet}}
    outputs:
      html: {{path: "${{report_dir}}/report.html", artifact: true}}
      json: {{path: "${{report_dir}}/report.json", artifact: true}}
      geojson: {{path: "${{report_dir}}/report.geojson", artifact: true}}
      pdf: {{path: "${{report_dir}}/report.pdf", artifact: true}}
      arrival_tif: {{path: "${{report_dir}}/arrival_h.tif", artifact: true}}
      burn_probability_tif: {{path: "${{report_dir}}/burn_probability_pct.tif", artifact: true}}
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

/// The report folder of a place and day, as the fixture pipeline (and `pipelines/threat.yaml`)
/// names it.
pub(crate) fn report_dir(lat: f64, lon: f64, date: &str) -> String {
    format!("build/{lat}_{lon}/{date}")
}

/// The folder of the ensembles a place and day's report is made from.
fn work_dir(lat: f64, lon: f64, date: &str) -> String {
    format!("build/work/{lat}_{lon}/{date}")
}

const DATE: &str = "2019-08-01";

/// Every file under `dir` (relative path → bytes).
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            let path = entry.path();
            if path.is_dir() {
                walk(root, &path, out);
            } else {
                let rel = path.strip_prefix(root).unwrap().display().to_string();
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
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
    let (dir, work) = (report_dir(LAT, LON, DATE), work_dir(LAT, LON, DATE));
    // The report's folder holds the report and nothing else.
    let written: Vec<String> = files(&p.path(&dir)).into_keys().collect();
    assert_eq!(
        written,
        [
            "arrival_h.tif",
            "burn_probability_pct.tif",
            "report.geojson",
            "report.html",
            "report.json",
            "report.pdf"
        ]
    );
    let report: serde_json::Value = serde_json::from_str(&p.read(&format!("{dir}/report.json"))).unwrap();
    let strategies: Vec<&str> = report["strategies"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["strategy"].as_str().unwrap())
        .collect();
    assert_eq!(strategies, ["none", "rule", "ppo"]);
    // The agent's drops, or the rule plan's when the agent's representative run (median
    // burnt area) made none — as a 32-step agent may.
    let ppo: serde_json::Value = serde_json::from_str(&p.read(&format!("{work}/ppo.json"))).unwrap();
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
    let none: serde_json::Value = serde_json::from_str(&p.read(&format!("{work}/none.json"))).unwrap();
    let runs = none["episodes"].as_array().unwrap();
    let cells: f64 = runs
        .iter()
        .map(|r| r["cells_burned"].as_f64().unwrap())
        .sum::<f64>()
        / runs.len() as f64;
    let acres = report["strategies"][0]["burned_acres"]["value"].as_f64().unwrap();
    assert!((acres - cells * 500.0 * 500.0 / 43_560.0).abs() < 1e-6);
    // The free fire from the verified engine's ensemble, beside the automaton's.
    let mtt: serde_json::Value = serde_json::from_str(&p.read(&format!("{work}/mtt.json"))).unwrap();
    let runs = mtt["episodes"].as_array().unwrap();
    let cells: f64 = runs
        .iter()
        .map(|r| r["cells_burned"].as_f64().unwrap())
        .sum::<f64>()
        / runs.len() as f64;
    let free = report["free_spread"]["fire"]["burned_acres"]["value"]
        .as_f64()
        .unwrap();
    assert!((free - cells * 500.0 * 500.0 / 43_560.0).abs() < 1e-6);
    assert!(
        std::fs::read(p.path(&format!("{dir}/report.pdf")))
            .unwrap()
            .starts_with(b"%PDF-")
    );
    // The GIS files as GIS users open them: GeoJSON geometries valid by shapely, the
    // GeoTIFFs read by rasterio and equal to the report's numbers.
    let check = crate::repo_root().join("crates/firecast-report/tests/gis_check.py");
    for args in [
        vec![format!("{dir}/report.geojson")],
        vec![
            format!("{dir}/report.json"),
            format!("{work}/mtt.json"),
            format!("{dir}/arrival_h.tif"),
            format!("{dir}/burn_probability_pct.tif"),
        ],
    ] {
        let what = if args.len() == 1 { "geojson" } else { "rasters" };
        let out = std::process::Command::new(crate::venv_bin("python"))
            .arg(&check)
            .arg(what)
            .args(args.iter().map(|a| p.path(a)))
            .output()
            .expect("the project's Python (cargo xtask setup)");
        assert!(out.status.success(), "{what}: {}", describe(&out));
    }
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
    for name in written {
        assert!(text.contains(&name), "{name} not registered: {text}");
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
    assert!(!p.path(&report_dir(39.6, -107.4, DATE)).exists());
}

/// One report per place and day: after a good run at one place, runs that fail — at a water
/// cell elsewhere, on a day the weather files do not hold, and in the report stage itself
/// (its forecast is for another day) after the fires of that day were simulated — leave the
/// good report byte for byte as it was, write no file of a failed report anywhere, and leave
/// no temporary file behind.
#[test]
fn a_failed_run_leaves_the_last_good_report_of_each_place_and_day_untouched() {
    let p = project(LAT, LON);
    let first = p.run_pipeline("pipelines/threat.yaml", &[]);
    assert!(first.values().all(|o| o == "ran"), "{first:?}");
    let good_dir = report_dir(LAT, LON, DATE);
    let good = files(&p.path(&good_dir));
    assert!(
        good.contains_key("report.json") && good.contains_key("arrival_h.tif"),
        "{:?}",
        good.keys()
    );

    // A water cell of the landscape the fires burnt.
    let none: serde_json::Value =
        serde_json::from_str(&p.read(&format!("{}/none.json", work_dir(LAT, LON, DATE)))).unwrap();
    let g = &none["grid"];
    assert_eq!(g["crs"], "EPSG:4326");
    let w = g["width"].as_u64().unwrap() as usize;
    let water = none["land_cover"]
        .as_array()
        .unwrap()
        .iter()
        .position(|c| c == 17)
        .expect("the procedural landscape has water");
    let f = |k: &str| g[k].as_f64().unwrap();
    let round = |v: f64| (v * 1e6).round() / 1e6;
    let water_lon = round(f("origin_x") + ((water % w) as f64 + 0.5) * f("cell_size_x"));
    let water_lat = round(f("origin_y") + ((water / w) as f64 + 0.5) * f("cell_size_y"));

    let failing: [(f64, f64, &str, &[&str]); 3] = [
        (
            water_lat,
            water_lon,
            DATE,
            &["ignition", "nothing there can burn"],
        ),
        (LAT, LON, "2021-08-01", &["2021"]),
        (LAT, LON, "2019-08-02", &["forecast", "2019-08-01"]),
    ];
    for (lat, lon, date, says) in failing {
        let before_work = files(&p.path("build/work"));
        let out = p
            .firecast()
            .args(["pipeline", "run", "pipelines/threat.yaml"])
            .args(["-S", &format!("lat={lat}"), "-S", &format!("lon={lon}")])
            .args(["-S", &format!("date={date}")])
            .output()
            .unwrap();
        assert!(!out.status.success(), "{}", describe(&out));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            says.iter().all(|s| err.contains(s)),
            "({lat}, {lon}) on {date}: {err}"
        );
        // The good report is untouched.
        assert_eq!(
            files(&p.path(&good_dir)),
            good,
            "({lat}, {lon}) on {date} changed {good_dir}"
        );
        // No file of the failed report (the runner may have made its empty folder).
        let failed = files(&p.path(&report_dir(lat, lon, date)));
        assert!(
            failed.is_empty(),
            "({lat}, {lon}) on {date} left {:?}",
            failed.keys()
        );
        // Outside the work folders, nothing but the good report and the shared sources and
        // agent; in them, only whole outputs of the stages that succeeded, each in the
        // folder of its own place and day.
        let all = files(&p.path("build"));
        for path in all.keys() {
            assert!(!path.contains("firecast-tmp"), "temporary file left: {path}");
            let place = path.starts_with(&format!("{LAT}_{LON}/{DATE}/"))
                || path.starts_with("sources/")
                || path.starts_with("agent/")
                || path.starts_with("work/");
            assert!(place, "({lat}, {lon}) on {date} left build/{path}");
        }
        for (path, bytes) in files(&p.path("build/work")) {
            if before_work.get(&path) != Some(&bytes) {
                assert!(
                    path.starts_with(&format!("{lat}_{lon}/{date}/")),
                    "({lat}, {lon}) on {date} wrote work/{path}"
                );
            }
        }
    }
    // Back at the good place and day nothing runs: the report is up to date, and the stages
    // whose last run was elsewhere come back from the run cache, byte for byte.
    let again = p.run_pipeline("pipelines/threat.yaml", &[]);
    assert_eq!(again["report"], "up_to_date", "{again:?}");
    assert!(
        again.values().all(|o| o == "up_to_date" || o == "restored"),
        "{again:?}"
    );
    assert_eq!(files(&p.path(&good_dir)), good);
}

/// The threat report on a real place's fuels: a window of the Worcester, Vermont LANDFIRE clip
/// around the point, the day's GRIDMET weather there (synthetic files over Vermont), fuel
/// moisture from that day, physical drops, the verified engine's map allowed to grow — and a
/// forecaster trained in Colorado, which the report must call an extrapolation.
#[test]
fn a_threat_report_on_landfire_fuels_names_its_landscape_and_the_forecasts_reach() {
    let p = Project::new();
    let fuels =
        crate::repo_root().join("crates/firecast-landscape/tests/fixtures/landfire-worcester/landfire");
    let (lat, lon) = (44.3937, -72.6496);
    p.write(
        "pipelines/threat.yaml",
        &format!(
            r#"
vars:
  lat: {lat}
  lon: {lon}
  date: "2019-08-01"
  landscape: {{landfire: {{center: ["${{lat}}", "${{lon}}"], width: 120, height: 80}}}}
  env:
    max_steps: 60
    sim: {{helitack_footprint: coverage, helitack_volume_gal: 800, kernel: {{rothermel: {{}}}}}}
stages:
  sources:
    uses: data.synthesize
    params:
      seed: 7
      region: {{lat_min: 44.2, lat_max: 44.6, lon_min: -72.9, lon_max: -72.4}}
      years: [2019, 2019]
    outputs:
      gridmet: build/sources/gridmet
      incidents: build/sources/incidents.csv
      model: build/sources/MODEL.md
  free_spread:
    uses: sim.ensemble
    params:
      landscape: ${{landscape}}
      engine: mtt
      grow: {{max_factor: 2}}
      agent: none
      runs: 3
      weather_date: ${{date}}
      fuel_moisture: day
      ignition: ["${{lat}}", "${{lon}}"]
      env: ${{env}}
    inputs:
      gridmet: {{from: sources.gridmet}}
      land_cover: {fuels}
    outputs:
      ensemble: build/work/mtt.json
  unsuppressed:
    uses: sim.ensemble
    params:
      landscape: ${{landscape}}
      agent: none
      runs: 3
      weather_date: ${{date}}
      fuel_moisture: day
      ignition: ["${{lat}}", "${{lon}}"]
      env: ${{env}}
    inputs:
      gridmet: {{from: sources.gridmet}}
      land_cover: {fuels}
      domain: {{from: free_spread.ensemble}}
    outputs:
      ensemble: build/work/none.json
  rule_plan:
    uses: sim.ensemble
    params:
      landscape: ${{landscape}}
      agent: rule
      runs: 3
      weather_date: ${{date}}
      fuel_moisture: day
      ignition: ["${{lat}}", "${{lon}}"]
      env: ${{env}}
    inputs:
      gridmet: {{from: sources.gridmet}}
      land_cover: {fuels}
      domain: {{from: free_spread.ensemble}}
    outputs:
      ensemble: build/work/rule.json
  report:
    uses: report
    params:
      lat: ${{lat}}
      lon: ${{lon}}
      date: ${{date}}
      bootstrap_resamples: 100
      isochrones_h: [3, 6, 12]
    inputs:
      ensembles: [{{from: unsuppressed.ensemble}}, {{from: rule_plan.ensemble}}]
      spread: {{from: free_spread.ensemble}}
      forecast: forecast.json
      gridmet: {{from: sources.gridmet}}
    outputs:
      html: build/report/report.html
      json: build/report/report.json
      arrival_tif: build/report/arrival_h.tif
"#,
            fuels = fuels.display()
        ),
    );
    // A forecaster trained on Colorado's windows, asked about Vermont.
    let mut forecast: serde_json::Value = serde_json::from_str(&forecast(lat, lon)).unwrap();
    forecast["training_extent"] = serde_json::json!({
        "lat_min": 39.1, "lat_max": 39.5, "lon_min": -107.6, "lon_max": -107.2,
        "first_date": "2016-03-01", "last_date": "2019-04-30", "samples": 1799
    });
    forecast["inside_training_extent"] = false.into();
    p.write("forecast.json", &forecast.to_string());

    let outcomes = p.run_pipeline("pipelines/threat.yaml", &[]);
    assert!(outcomes.values().all(|o| o == "ran"), "{outcomes:?}");

    let report: serde_json::Value = serde_json::from_str(&p.read("build/report/report.json")).unwrap();
    // The header and the assumptions say what the map is: LANDFIRE's files, its 30 m cells and
    // the cells without fuel data — not a MODIS crosswalk.
    assert_eq!(report["header"]["crs"], "EPSG:5070");
    let landscape = report["header"]["landscape"].as_str().unwrap();
    assert!(landscape.contains("cells of 98 ft (30 m;"), "{landscape}");
    let assumptions = report["assumptions"].to_string();
    assert!(
        assumptions.contains("LANDFIRE GeoTIFF layers") && assumptions.contains("LC22_F40_230.tif"),
        "{assumptions}"
    );
    assert!(assumptions.contains("without fuel data"), "{assumptions}");
    assert!(!assumptions.contains("MODIS crosswalk"), "{assumptions}");
    // The day's fuel moisture: dead 100-h is GRIDMET's fm100 at the point that day.
    let fb = &report["fire_behaviour"];
    let fm100 = report["weather"]["fm100_pct"].as_f64().unwrap();
    assert!(
        (fb["dead_100h_pct"].as_f64().unwrap() - fm100).abs() < 1e-6,
        "{fb}"
    );
    // The forecast's reach: the model never saw this place.
    let area = &report["forecast"]["training_area"];
    assert_eq!(area["place_inside"], false, "{area}");
    assert_eq!(area["last_date"], "2019-04-30");

    let html = p.read("build/report/report.html");
    assert!(html.contains("landscape: LANDFIRE fuels and terrain, 30 m cells"));
    assert!(
        html.contains("Outside the model&#39;s experience")
            || html.contains("Outside the model's experience")
    );
    // The clip's nodata border lies in this window: the legend says those cells have no fuel
    // data rather than calling them bare ground.
    assert!(
        html.contains("or no fuel data ("),
        "legend does not name the nodata cells"
    );
    assert!(!html.contains("98.4251"), "unformatted cell size");

    // The arrival GeoTIFF is georeferenced in LANDFIRE's Albers (GeoKey ProjectedCSType 3072 = 5070).
    let tif = std::fs::read(p.path("build/report/arrival_h.tif")).unwrap();
    let key: Vec<u8> = [3072u16, 0, 1, 5070]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    assert!(
        tif.windows(key.len()).any(|w| w == key.as_slice()),
        "no EPSG:5070 GeoKey"
    );
}
