//! The landscape of the place through the real binary: `sim.ensemble` stages with the
//! synthetic landscape at two places 87 miles apart, on synthetic GRIDMET that the same world
//! wrote, get two different maps, both labelled synthetic; real GRIDMET (no `firecast_seed`)
//! is refused with a pointer to real landscapes; a LANDFIRE landscape (GeoTIFF layers or
//! `.lcp`) runs both engines on the place's own fuels.

use crate::{Project, describe};

/// Two places 87 miles apart (1.26° of latitude) on one meridian.
const NORTH: [f64; 2] = [39.3, -107.4];
const SOUTH: [f64; 2] = [38.04, -107.4];

fn ensemble_stage(name: &str, [lat, lon]: [f64; 2]) -> String {
    format!(
        r#"
  {name}:
    uses: sim.ensemble
    params:
      landscape: {{synthetic: {{center: [{lat}, {lon}], width: 48, height: 32}}}}
      agent: none
      runs: 2
      weather_date: "2019-08-01"
      ignition: [{lat}, {lon}]
      env: {{max_steps: 40}}
    inputs:
      gridmet: {{from: sources.gridmet}}
    outputs:
      ensemble: build/{name}.json
"#
    )
}

fn pipeline() -> String {
    format!(
        r#"
stages:
  sources:
    uses: data.synthesize
    params:
      seed: 7
      region: {{lat_min: 37.95, lat_max: 39.4, lon_min: -107.5, lon_max: -107.3}}
      years: [2019, 2019]
      variables: [vs, th]
    outputs:
      gridmet: build/sources/gridmet
      incidents: build/sources/incidents.csv
      model: build/sources/MODEL.md
{}{}"#,
        ensemble_stage("north", NORTH),
        ensemble_stage("south", SOUTH)
    )
}

#[test]
fn the_synthetic_landscape_is_the_places_own_and_says_it_is_synthetic() {
    let p = Project::new();
    p.write("pipelines/places.yaml", &pipeline());
    let outcomes = p.run_pipeline("pipelines/places.yaml", &[]);
    assert!(outcomes.values().all(|o| o == "ran"), "{outcomes:?}");
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_str(&p.read(&format!("build/{name}.json"))).unwrap()
    };
    let (north, south) = (read("north"), read("south"));
    for e in [&north, &south] {
        let label = &e["landscape"];
        assert_eq!(label["kind"], "synthetic", "{label}");
        assert_eq!(label["synthetic"], true);
        // The world that wrote the weather.
        assert_eq!(label["seed"], 7);
        let note = label["note"].as_str().unwrap();
        assert!(
            note.contains("synthetic") && !note.contains('\n') && !note.contains("  "),
            "{label}"
        );
        assert_eq!(e["border_cells"], 2 * (48 + 32) - 4);
        for run in e["episodes"].as_array().unwrap() {
            assert!(run["edge_cells_burned"].as_u64().is_some(), "{run}");
            assert!(run.get("edge_first_hour").is_some(), "{run}");
        }
    }
    // The stage's log says so too.
    let logs: String = std::fs::read_dir(p.path(".firecast/logs"))
        .unwrap()
        .map(|f| std::fs::read_to_string(f.unwrap().path()).unwrap())
        .collect();
    assert!(
        logs.contains(
            "synthetic landscape: the terrain and land cover of FireCast's synthetic world (seed 7)"
        ),
        "{logs}"
    );
    let cells = |e: &serde_json::Value, key: &str| -> Vec<f64> {
        e[key]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    let (a, b) = (cells(&north, "land_cover"), cells(&south, "land_cover"));
    assert_eq!(a.len(), 48 * 32);
    let differ = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    assert!(
        differ * 2 > a.len(),
        "only {differ} of {} cells differ in land cover",
        a.len()
    );
    let (za, zb) = (cells(&north, "elevation_ft"), cells(&south, "elevation_ft"));
    let differ = za
        .iter()
        .zip(&zb)
        .filter(|(x, y)| (**x - **y).abs() > 50.0)
        .count();
    assert!(
        differ * 10 > za.len() * 9,
        "only {differ} cells differ by 50 ft in elevation"
    );
}

#[test]
fn real_gridmet_has_no_synthetic_world() {
    let p = Project::new();
    let gridmet = crate::repo_root().join("crates/firecast-episodes/tests/fixtures/gridmet");
    p.write(
        "pipelines/real.yaml",
        &format!(
            r#"
stages:
  fire:
    uses: sim.ensemble
    params:
      landscape: {{synthetic: {{center: [39.3, -107.4], width: 16, height: 16}}}}
      agent: none
      runs: 1
      weather_date: "2020-07-04"
      env: {{max_steps: 5}}
    inputs:
      gridmet: {}
    outputs:
      ensemble: build/fire.json
"#,
            gridmet.display()
        ),
    );
    let out = p
        .firecast()
        .args(["pipeline", "run", "pipelines/real.yaml"])
        .output()
        .unwrap();
    assert!(!out.status.success(), "{}", describe(&out));
    let text = describe(&out);
    assert!(
        text.contains("firecast_seed") && text.contains("LANDFIRE"),
        "{text}"
    );
    assert!(
        text.contains("vs_2020.nc") || text.contains("_2020.nc"),
        "names no file: {text}"
    );
    assert!(!p.path("build/fire.json").exists());
}

/// One `sim.ensemble` stage on the Worcester LANDFIRE clip.
fn landfire_stage(name: &str, landscape: &str, source: &str, engine: &str) -> String {
    let fixtures = crate::repo_root().join("crates/firecast-landscape/tests/fixtures/landfire-worcester");
    format!(
        r#"
  {name}:
    uses: sim.ensemble
    params:
      landscape: {landscape}
      agent: none
      engine: {engine}
      runs: 2
      env:
        max_steps: 30
        sim:
          kernel: {{rothermel: {{}}}}
          wind: {{speed_mph: 15, from_direction_deg: 250, measured_at: twenty_foot}}
    inputs:
      land_cover: {}
    outputs:
      ensemble: build/{name}.json
"#,
        fixtures.join(source).display()
    )
}

/// The ensemble stage on a LANDFIRE landscape: a window of the GeoTIFF layers around a place
/// and the `.lcp` of the same cells burn the same fires (automaton and MTT) on burnable fuel
/// only, labelled as LANDFIRE data with its files; a place off the grid names the key.
#[test]
fn landfire_landscapes_run_ensembles_on_the_places_fuels() {
    let p = Project::new();
    // The centre of the clip's cell (94, 420): the middle of the 48 x 40 cells the .lcp holds.
    let window = "{landfire: {center: [44.393706933151634, -72.64962229925173], width: 48, height: 40}}";
    let pipeline = format!(
        "stages:{}{}{}{}",
        landfire_stage("tif", window, "landfire", "automaton"),
        landfire_stage("lcp", "{landfire: {}}", "lcp/worcester_crop.lcp", "automaton"),
        landfire_stage("tif_mtt", window, "landfire", "mtt"),
        landfire_stage("lcp_mtt", "{landfire: {}}", "lcp", "mtt"),
    );
    p.write("pipelines/landfire.yaml", &pipeline);
    let outcomes = p.run_pipeline("pipelines/landfire.yaml", &[]);
    assert!(outcomes.values().all(|o| o == "ran"), "{outcomes:?}");
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_str(&p.read(&format!("build/{name}.json"))).unwrap()
    };
    for (a, b) in [("tif", "lcp"), ("tif_mtt", "lcp_mtt")] {
        let mtt = a.ends_with("_mtt");
        let (a, b) = (read(a), read(b));
        // The MTT engine spreads over the window's own slope layer, which the .lcp stores in
        // whole degrees (the GeoTIFF in percent): arrival times differ by that rounding, the
        // cells burnt do not.
        let exact: &[&str] = if mtt {
            &["grid", "land_cover", "elevation_ft", "ignition", "burn_count"]
        } else {
            &[
                "grid",
                "land_cover",
                "elevation_ft",
                "ignition",
                "episodes",
                "burn_count",
                "arrival_first_h",
            ]
        };
        for key in exact {
            assert_eq!(a[key], b[key], "{key}");
        }
        if mtt {
            let arrival = |v: &serde_json::Value| -> Vec<Option<f64>> {
                v["arrival_first_h"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(serde_json::Value::as_f64)
                    .collect()
            };
            for (x, y) in arrival(&a).into_iter().zip(arrival(&b)) {
                match (x, y) {
                    (Some(x), Some(y)) => {
                        assert!((x - y).abs() <= 0.05 * x.max(y) + 1e-6, "arrival {x} h vs {y} h")
                    }
                    (x, y) => assert_eq!(x, y),
                }
            }
        }
        let burnt = a["burn_count"]
            .as_array()
            .unwrap()
            .iter()
            .zip(a["land_cover"].as_array().unwrap())
            .filter(|(n, _)| n.as_u64().unwrap() > 0)
            .map(|(_, code)| code.as_u64().unwrap())
            .collect::<Vec<_>>();
        assert!(burnt.len() > 5, "{} cells burnt", burnt.len());
        assert!(burnt.iter().all(|&c| c > 100), "burnt fuel codes {burnt:?}");
        for (e, format, file) in [
            (&a, "LANDFIRE GeoTIFF layers", "LC22_F40_230.tif"),
            (&b, "FARSITE .lcp", "worcester_crop.lcp"),
        ] {
            let label = &e["landscape"];
            assert_eq!(label["kind"], "landfire", "{label}");
            assert_eq!(label["synthetic"], false);
            let note = label["note"].as_str().unwrap();
            assert!(note.contains(format) && note.contains(file), "{note}");
            assert!(!note.contains('\n') && !note.contains("  "), "{note}");
            let sources = label["sources"].as_array().unwrap();
            assert!(
                sources.iter().any(|s| s.as_str().unwrap().ends_with(file)),
                "{label}"
            );
            assert!(
                label["fuel_cells"]["fuel_nodata"].as_u64().unwrap() > 300,
                "{label}"
            );
        }
        assert_eq!(a["landscape"]["fuel_cells"], b["landscape"]["fuel_cells"]);
        assert_eq!(a["grid"]["crs"], "EPSG:5070");
    }

    // A place off the grid names the key; nothing is written.
    let off = "{landfire: {center: [40.0, -100.0], width: 48, height: 40}}";
    p.write(
        "pipelines/off.yaml",
        &format!("stages:{}", landfire_stage("off", off, "landfire", "automaton")),
    );
    let out = p
        .firecast()
        .args(["pipeline", "run", "pipelines/off.yaml"])
        .output()
        .unwrap();
    assert!(!out.status.success(), "{}", describe(&out));
    let text = describe(&out);
    assert!(
        text.contains("center (40, -100) is outside the LANDFIRE grid"),
        "{text}"
    );
    assert!(!p.path("build/off.json").exists());
}
