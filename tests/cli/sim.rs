//! The simulator through the CLI: spread rates, episodes, the sim.episodes stage.

use crate::{Project, describe, venv_bin};

#[test]
fn sim_run_compares_agents_and_writes_outputs() {
    let p = Project::new();
    let out = p.json(&[
        "sim",
        "run",
        "--landscape",
        "procedural:2",
        "--agent",
        "rule",
        "--agent",
        "none",
        "--episodes",
        "2",
        "--seed",
        "4",
        "--wind-mph",
        "8",
        "--wind-from-deg",
        "270",
        "--gif",
        "out/fire.gif",
    ]);
    let runs = out.as_array().unwrap();
    assert_eq!(runs.len(), 2);
    assert_eq!(runs[0]["agent"], "rule");
    assert_eq!(runs[1]["agent"], "none");
    assert_eq!(runs[0]["wind_speed_mph"], 8.0);
    assert_eq!(runs[1]["report"]["helitacks"]["mean"], 0.0);
    assert!(p.path("out/fire-rule.gif").exists() && p.path("out/fire-none.gif").exists());

    let bad = p
        .firecast()
        .args(["sim", "run", "--agent", "robot", "--episodes", "1"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2), "{}", describe(&bad));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("unknown agent `robot`"));
}

#[test]
fn sim_episodes_stage_in_a_pipeline() {
    let p = Project::new();
    p.write(
        "pipelines/fire.yaml",
        r#"
stages:
  helitack:
    uses: sim.episodes
    foreach: [rule, none]
    params:
      landscape: {procedural: {seed: 5, width: 100, height: 80}}
      agent: ${item}
      episodes: 2
      env: {max_steps: 300, sim: {wind: {speed_mph: 6, from_direction_deg: 200}}}
    outputs:
      summary: "build/${item}.json"
      trace: "build/${item}.trace.json"
  film:
    uses: sim.render
    foreach: [rule, none]
    params: {frame_every: 10}
    inputs:
      trace: {from: "helitack@${item}.trace"}
    outputs:
      animation: "build/${item}.gif"
      frames: "build/${item}-frames"
      recording: "build/${item}.rrd"
"#,
    );
    let outcomes = p.run_pipeline("pipelines/fire.yaml", &[]);
    assert_eq!(outcomes["helitack@rule"], "ran");
    assert_eq!(outcomes["film@rule"], "ran");
    for agent in ["rule", "none"] {
        let gif = std::fs::read(p.path(&format!("build/{agent}.gif"))).unwrap();
        assert_eq!(&gif[..6], b"GIF89a");
        let frames = std::fs::read_dir(p.path(&format!("build/{agent}-frames")))
            .unwrap()
            .count();
        assert!(frames > 3, "{agent}: {frames} frames");
        assert!(
            std::fs::metadata(p.path(&format!("build/{agent}.rrd")))
                .unwrap()
                .len()
                > 1000
        );
    }
    let recording = std::fs::read(p.path("build/rule.rrd")).unwrap();
    // Drawing differently re-runs only the drawing.
    p.write(
        "pipelines/fire.yaml",
        &p.read("pipelines/fire.yaml")
            .replace("frame_every: 10", "frame_every: 20"),
    );
    let outcomes = p.run_pipeline("pipelines/fire.yaml", &[]);
    assert_eq!(
        (outcomes["helitack@rule"].as_str(), outcomes["film@rule"].as_str()),
        ("up_to_date", "ran")
    );
    // The recording does not depend on the frames: the re-run wrote the same bytes.
    assert!(
        std::fs::read(p.path("build/rule.rrd")).unwrap() == recording,
        "the re-run's recording differs"
    );
    // A trace that the simulator does not reproduce is refused.
    let trace = p.read("build/rule.trace.json");
    let tampered = trace.replacen("\"cells_burned\":", "\"cells_burned\":1", 1);
    assert_ne!(trace, tampered);
    p.write("traces/tampered.json", &tampered);
    p.write(
        "pipelines/replay.yaml",
        "stages:\n  film:\n    uses: sim.render\n    inputs: {trace: traces/tampered.json}\n    outputs: {animation: build/t.gif}\n",
    );
    let out = p
        .firecast()
        .args(["pipeline", "run", "pipelines/replay.yaml"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("replaying the trace diverged"),
        "{}",
        describe(&out)
    );
    let summary: serde_json::Value = serde_json::from_str(&p.read("build/rule.json")).unwrap();
    assert_eq!(summary["report"]["episodes"].as_array().unwrap().len(), 2);
    let runs = p.json(&["runs", "list", "--stage", "helitack"]);
    let run_id = runs[0]["run_id"].as_str().unwrap().to_string();
    let show = p.json(&["runs", "show", &run_id]);
    let keys: Vec<&str> = show["metrics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["key"].as_str().unwrap())
        .collect();
    assert_eq!(keys, ["cells_burned", "helitacks", "timesteps", "water_used_gal"]);

    p.write(
        "pipelines/bad.yaml",
        &p.read("pipelines/fire.yaml").replace("max_steps", "max_stesp"),
    );
    let out = p
        .firecast()
        .args(["pipeline", "run", "pipelines/bad.yaml"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("stages.helitack.params.env.max_stesp: unknown field `max_stesp`"),
        "{stderr}"
    );
}

/// A stand-in for the FireCastRL package: same import path and step contract, but its "fire"
/// ends after one step with nothing burnt. FireCast's real fire on the same (uniform grass)
/// map lasts longer, so the comparison must report no identical fire — proof that the bench
/// compares what the reference returns rather than trusting it.
const FAKE_ENV: &str = r#"
import numpy as np

class _State:
    def __init__(self):
        self.fire_state = np.zeros((160, 240), dtype=np.int8)

class WildfireEnv:
    def __init__(self, render_mode=None):
        self.cell_state = _State()
    def reset(self, seed=None):
        return {}, {}
    def step(self, action):
        return {}, 0.0, True, False, {"cells_burning": 0, "cells_burnt": 0}
"#;

/// Writes the training-map PNGs (uniform grassland, flat) with a minimal PNG encoder.
const WRITE_MAPS: &str = r#"
import os, struct, sys, zlib
def png(path, w, h, channels, pixel):
    raw = b"".join(b"\x00" + bytes(pixel) * w for _ in range(h))
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))
    color = {3: 2, 4: 6}[channels]
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, color, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
d = sys.argv[1]
png(os.path.join(d, "landcover_1.png"), 240, 160, 3, (144, 238, 144))
png(os.path.join(d, "heightmap_1.png"), 240, 160, 4, (0, 0, 0, 255))
"#;

#[test]
fn bench_sim_reference_compares_what_the_reference_returns() {
    let p = Project::new();
    p.write("wildfire-env/firecastrl_env/__init__.py", "");
    p.write("wildfire-env/firecastrl_env/envs/__init__.py", "");
    p.write("wildfire-env/firecastrl_env/envs/wildfire_env.py", FAKE_ENV);
    p.write("write_maps.py", WRITE_MAPS);
    let maps = p.path("wildfire-env/firecastrl_env/envs/training_environments");
    std::fs::create_dir_all(&maps).unwrap();
    let python = venv_bin("python");
    let status = std::process::Command::new(&python)
        .arg(p.path("write_maps.py"))
        .arg(&maps)
        .status()
        .unwrap();
    assert!(status.success());
    let v = p.json(&[
        "bench",
        "sim",
        "--reference-env",
        "wildfire-env",
        "--python",
        python.to_str().unwrap(),
        "--reference-seeds",
        "2",
    ]);
    let comparisons = v["comparisons"].as_array().unwrap();
    assert_eq!(comparisons.len(), 2, "{v}");
    for c in comparisons {
        let reference = c["reference"].as_array().unwrap();
        let firecast = c["firecast"].as_array().unwrap();
        assert_eq!((reference.len(), firecast.len()), (2, 2));
        assert_eq!(reference[0]["steps"], 1, "the stand-in ends after one step");
        assert!(
            firecast[0]["steps"].as_u64().unwrap() > 1,
            "a grass fire outlives one step"
        );
        assert_eq!(c["identical_fires"], 0);
        assert!(c["ratio"].as_f64().unwrap() > 0.0);
    }

    // A folder without the package is refused with a clear message.
    let out = p
        .firecast()
        .args(["bench", "sim", "--reference-env", "nowhere", "--python"])
        .arg(&python)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("training map") || err.contains("firecastrl_env"),
        "{err}"
    );
}

#[test]
fn sim_run_takes_its_wind_from_gridmet() {
    let p = Project::new();
    let gridmet = crate::repo_root().join("crates/firecast-episodes/tests/fixtures/gridmet");
    let v = p.json(&[
        "sim",
        "run",
        "--landscape",
        "procedural:2",
        "--agent",
        "none",
        "--episodes",
        "1",
        "--weather-date",
        "2020-07-04",
        "--gridmet",
        gridmet.to_str().unwrap(),
    ]);
    let s = &v[0];
    // The netCDF4-written fixture's th on day 186 at the cell nearest the centre.
    assert_eq!(s["wind_from_deg"], 232.0, "{v}");
    assert_eq!(s["wind_measured_at"], "ten_metre");
    assert!((s["wind_speed_mph"].as_f64().unwrap() - 5.6 * 2.236_936).abs() < 1e-3);

    // A day outside the files names the file it looked for.
    let out = p
        .firecast()
        .args(["sim", "run", "--landscape", "procedural:2", "--episodes", "1"])
        .args(["--weather-date", "2019-07-04", "--gridmet"])
        .arg(&gridmet)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("vs_2019.nc"),
        "{}",
        describe(&out)
    );
}

/// Copy the Worcester LANDFIRE clip (EPL-2.0 fixture) into a project folder.
fn copy_worcester(p: &Project, rel: &str) -> std::path::PathBuf {
    let src = crate::repo_root().join("crates/firecast-landscape/tests/fixtures/landfire-worcester/landfire");
    let dest = p.path(rel);
    for layer in std::fs::read_dir(&src).unwrap() {
        let layer = layer.unwrap().path();
        let into = dest.join(layer.file_name().unwrap());
        std::fs::create_dir_all(&into).unwrap();
        for file in std::fs::read_dir(&layer).unwrap() {
            let file = file.unwrap().path();
            std::fs::copy(&file, into.join(file.file_name().unwrap())).unwrap();
        }
    }
    dest
}

#[test]
fn sim_behavior_writes_georeferenced_grids_and_a_summary() {
    let p = Project::new();
    copy_worcester(&p, "landfire");
    let out = p.json(&[
        "sim",
        "behavior",
        "--landscape",
        "landfire",
        "--moisture",
        "6,8,10,75,60",
        "--slope",
        "lcp",
        "--foliar-moisture",
        "120",
        "--out",
        "out/behavior",
    ]);
    let summary = &out["summary"];
    // FlamMap: 220,846 surface, 1,518 passive and 7 active crown cells; 108,586 nodata.
    assert_eq!(summary["fire_type_cells"]["surface"], 220_846);
    assert_eq!(summary["fire_type_cells"]["passive_crown"], 1_518);
    assert_eq!(summary["fire_type_cells"]["active_crown"], 7);
    assert_eq!(summary["nodata_cells"], 108_586);
    assert_eq!(summary["width"], 549);
    assert_eq!(summary["crs"], "EPSG:5070");
    assert_eq!(summary["params"]["crown"], "finney");
    assert_eq!(summary["params"]["foliar_moisture_pct"], 120.0);
    assert!(summary["crown_fire"].as_str().unwrap().starts_with("Finney"));
    let ros_max = summary["ros_chph"]["max"].as_f64().unwrap();
    // FlamMap's fastest cell, 48.2 ch/h, is a crown fire cell.
    assert!((47.0..49.5).contains(&ros_max), "{ros_max}");
    for name in [
        "ros_chph.tif",
        "flame_length_ft.tif",
        "fireline_intensity_btu_ft_s.tif",
        "max_spread_direction_deg.tif",
        "fire_type.tif",
        "summary.json",
    ] {
        assert!(p.path("out/behavior").join(name).is_file(), "{name}");
    }
    // No staging folder is left beside the output.
    let left: Vec<_> = std::fs::read_dir(p.path("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left, ["behavior"]);

    // An independent reader: Pillow from the project's venv (rasterio and GDAL are not
    // installed there) reads the float32 band and the GeoTIFF tags.
    let python = firecast_testkit::python_with(&["PIL", "numpy"]);
    {
        let flammap =
            crate::repo_root().join("crates/firecast-landscape/tests/fixtures/landfire-worcester/flammap");
        let script = r#"
import sys, numpy as np
from PIL import Image
out, flammap = sys.argv[1], sys.argv[2]
im = Image.open(out + "/ros_chph.tif")
assert im.mode == "F" and im.size == (549, 613), (im.mode, im.size)
t = im.tag_v2
assert tuple(t[33550]) == (30.0, 30.0, 0.0), t[33550]
assert tuple(t[33922]) == (0.0, 0.0, 0.0, 1833825.0, 2617605.0, 0.0), t[33922]
keys = list(t[34735])
assert 5070 in keys[keys.index(3072):keys.index(3072) + 4], keys
assert t[42113].strip("\x00") == "32767", t[42113]
ours = np.array(im, dtype=np.float64)
ref = np.array(Image.open(flammap + "/ROS_ch_hr.tif"), dtype=np.float64)
ft = np.array(Image.open(flammap + "/fire_type.tif"))
surface = ft == 1
rel = np.abs(ours[surface] / ref[surface] - 1)
assert rel.max() < 0.005, rel.max()
ours_type = np.array(Image.open(out + "/fire_type.tif"))
assert (ours_type[ft >= 1] == ft[ft >= 1]).all()
crown = ft >= 2
assert np.abs(ours[crown] / ref[crown] - 1).max() < 0.005
assert (ours[ft == 0] != 0).sum() == 108586
print("ok", surface.sum(), rel.max())
"#;
        let check = std::process::Command::new(&python)
            .args(["-c", script])
            .arg(p.path("out/behavior"))
            .arg(&flammap)
            .output()
            .unwrap();
        assert!(check.status.success(), "{}", describe(&check));
        assert!(
            String::from_utf8_lossy(&check.stdout).starts_with("ok 220846"),
            "{}",
            describe(&check)
        );
    }

    // Bad input: nothing is written, and the message names the problem.
    for (args, expect) in [
        (vec!["--moisture", "6,8,10"], "five"),
        (
            vec!["--moisture", "6,8,10,75,60", "--wind-mph=-3"],
            "wind_20ft_mph",
        ),
        (
            vec!["--moisture", "6,8,10,75,60", "--fuel", "fbfm99"],
            "fbfm40 or fbfm13",
        ),
        (
            vec!["--moisture", "6,8,10,75,60", "--crown", "rothermel"],
            "finney, scott-reinhardt or none",
        ),
        (
            vec!["--moisture", "6,8,10,75,60", "--foliar-moisture", "400"],
            "foliar_moisture_pct",
        ),
    ] {
        let mut full = vec!["sim", "behavior", "--landscape", "landfire", "--out", "out/bad"];
        full.extend(args);
        let bad = p.firecast().args(&full).output().unwrap();
        assert!(!bad.status.success(), "{}", describe(&bad));
        assert!(
            String::from_utf8_lossy(&bad.stderr).contains(expect),
            "{}",
            describe(&bad)
        );
        assert!(!p.path("out/bad").exists());
    }
    // Without a canopy bulk density layer no cell crowns, and the summary says why.
    std::fs::remove_file(p.path("landfire/LF2022_CBD_230_CONUS/LC22_CBD_230.tif")).unwrap();
    let no_cbd = p.json(&[
        "sim",
        "behavior",
        "--landscape",
        "landfire",
        "--moisture",
        "6,8,10,75,60",
        "--out",
        "out/no-cbd",
    ]);
    let summary = &no_cbd["summary"];
    assert_eq!(
        summary["crown_fire_missing_layers"],
        serde_json::json!(["canopy bulk density"])
    );
    assert_eq!(summary["fire_type_cells"]["passive_crown"], 0);
    assert_eq!(summary["fire_type_cells"]["surface"], 222_371);
    std::fs::remove_file(p.path("landfire/LF2020_Asp_220_CONUS/LC20_Asp_220.tif")).unwrap();
    let bad = p
        .firecast()
        .args([
            "sim",
            "behavior",
            "--landscape",
            "landfire",
            "--moisture",
            "6,8,10,75,60",
            "--out",
            "out/bad",
        ])
        .output()
        .unwrap();
    assert!(
        String::from_utf8_lossy(&bad.stderr).contains("no aspect layer"),
        "{}",
        describe(&bad)
    );
    assert!(!p.path("out/bad").exists());
}

#[test]
fn sim_behavior_stage_in_a_pipeline() {
    let p = Project::new();
    copy_worcester(&p, "data/landfire");
    p.write(
        "pipelines/behavior.yaml",
        r#"
stages:
  behavior:
    uses: sim.behavior
    params:
      moisture: {dead_1h: 6, dead_10h: 8, dead_100h: 10, live_herbaceous: 75, live_woody: 60}
      slope: lcp_whole_degrees
      crown: finney
      foliar_moisture_pct: 120
    inputs:
      landscape: data/landfire
    outputs:
      grids: build/behavior
"#,
    );
    let outcomes = p.run_pipeline("pipelines/behavior.yaml", &[]);
    assert_eq!(outcomes["behavior"], "ran");
    let summary: serde_json::Value = serde_json::from_str(&p.read("build/behavior/summary.json")).unwrap();
    assert_eq!(summary["fire_type_cells"]["surface"], 220_846);
    assert_eq!(summary["fire_type_cells"]["active_crown"], 7);
    assert_eq!(summary["params"]["wind_20ft_mph"], 0.0);
    assert_eq!(
        p.run_pipeline("pipelines/behavior.yaml", &[])["behavior"],
        "up_to_date"
    );

    // Strict params: an unknown key and an out-of-range moisture are refused before running.
    for (from, to, expect) in [
        (
            "slope: lcp_whole_degrees",
            "slope: lcp_whole_degrees\n      gusts: 3",
            "gusts",
        ),
        ("live_woody: 60", "live_woody: 5", "live_woody"),
        ("crown: finney", "crown: van-wagner", "van-wagner"),
        (
            "foliar_moisture_pct: 120",
            "foliar_moisture_pct: 10",
            "foliar_moisture_pct",
        ),
    ] {
        p.write(
            "pipelines/bad.yaml",
            &p.read("pipelines/behavior.yaml").replace(from, to),
        );
        let bad = p
            .firecast()
            .args(["pipeline", "run", "pipelines/bad.yaml"])
            .output()
            .unwrap();
        assert!(!bad.status.success(), "{}", describe(&bad));
        assert!(
            String::from_utf8_lossy(&bad.stderr).contains(expect),
            "{}",
            describe(&bad)
        );
    }
}

#[test]
fn sim_verify_quick_passes_for_mtt_and_rejects_a_bad_radius() {
    let p = Project::new();
    let out = p.json(&["sim", "verify", "--quick", "--engine", "mtt"]);
    assert_eq!(out["mtt_failures"], 0);
    let rows = out["rows"].as_array().unwrap();
    assert!(rows.iter().all(|r| r["engine"] == "mtt"));
    assert!(rows.iter().any(|r| r["resolved"] == true && r["pass"] == true));

    // The picture: a PNG, written where asked.
    let png = p.path("pictures/verify.png");
    std::fs::create_dir_all(png.parent().unwrap()).unwrap();
    p.json(&[
        "sim",
        "verify",
        "--quick",
        "--engine",
        "mtt",
        "--png",
        png.to_str().unwrap(),
    ]);
    let bytes = std::fs::read(&png).unwrap();
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    assert!(bytes.len() > 50_000, "{} bytes", bytes.len());

    let bad = p
        .firecast()
        .args(["sim", "verify", "--stencil-radius", "9"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2), "{}", describe(&bad));
}

/// The Worcester fixtures (EPL-2.0): LANDFIRE layers, FlamMap 6's grids, the LCP writer.
fn worcester_fixtures() -> std::path::PathBuf {
    crate::repo_root().join("crates/firecast-landscape/tests/fixtures/landfire-worcester")
}

/// The venv's Python with rasterio (GDAL), from `cargo xtask setup`.
fn gdal_python() -> std::path::PathBuf {
    firecast_testkit::python_with(&["rasterio", "numpy"])
}

/// Write an `.lcp` of the whole Worcester clip with GDAL's LCP driver (make_lcp.py; whole
/// degrees of slope, as FlamMap's own .lcp kept them) and its `.prj`.
fn gdal_worcester_lcp(p: &Project, rel: &str, extra: &[&str]) -> std::path::PathBuf {
    let out = p.path(rel);
    let run = std::process::Command::new(gdal_python())
        .arg(crate::repo_root().join("crates/firecast-landscape/tests/fixtures/make_lcp.py"))
        .arg(worcester_fixtures().join("landfire"))
        .arg(&out)
        .args(extra)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", describe(&run));
    out
}

/// Run a Python check with rasterio, return its stdout's last line parsed as JSON.
fn rasterio_check(script: &str, args: &[&std::path::Path]) -> serde_json::Value {
    let out = std::process::Command::new(gdal_python())
        .args(["-c", script])
        .args(args)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", describe(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(stdout.lines().last().unwrap_or_default())
        .unwrap_or_else(|e| panic!("not JSON ({e}): {}", describe(&out)))
}

/// FlamMap 6 parity of one output folder, measured with rasterio (numpy): relative errors on
/// FlamMap's surface and crown cells, fire type agreement, direction of maximum spread.
const FLAMMAP_PARITY_PY: &str = r#"
import sys, json, numpy as np, rasterio
out, flammap = sys.argv[1], sys.argv[2]
def band(path):
    with rasterio.open(path) as d:
        return d.read(1).astype(np.float64)
ft_ref = band(flammap + "/fire_type.tif")
ft = band(out + "/fire_type.tif")
burnable = ft_ref >= 1
surface, crown = ft_ref == 1, ft_ref >= 2
res = {"surface": int(surface.sum()), "crown": int(crown.sum()),
       "fire_type_equal": int((ft[burnable] == ft_ref[burnable]).sum()), "burnable": int(burnable.sum())}
for ours, ref in [("ros_chph", "ROS_ch_hr"), ("flame_length_ft", "FL_ft"), ("fireline_intensity_btu_ft_s", "FLI_BTU_ft-s")]:
    a, b = band(out + "/" + ours + ".tif"), band(flammap + "/" + ref + ".tif")
    res[ours + "_surface_max_rel"] = float(np.max(np.abs(a[surface] / b[surface] - 1)))
    res[ours + "_crown_max_rel"] = float(np.max(np.abs(a[crown] / b[crown] - 1)))
d_ref = band(flammap + "/max_spread_direction_radians.tif")
d = band(out + "/max_spread_direction_deg.tif")
has = burnable & (d_ref != -9999)
diff = np.abs(np.degrees(d_ref[has]) % 360 - d[has]) % 360
res["direction_max_deg"] = float(np.max(np.minimum(diff, 360 - diff)))
print(json.dumps(res))
"#;

#[test]
fn sim_behavior_on_a_gdal_written_lcp_matches_flammap() {
    let p = Project::new();
    // FlamMap 6 read its landscape from an .lcp with slope in whole degrees; GDAL writes one
    // from the same LANDFIRE layers.
    let lcp = gdal_worcester_lcp(&p, "lcp/worcester.lcp", &[]);
    assert!(p.path("lcp/worcester.prj").is_file());
    let out = p.json(&[
        "sim",
        "behavior",
        "--landscape",
        lcp.to_str().unwrap(),
        "--moisture",
        "6,8,10,75,60",
        "--foliar-moisture",
        "120",
        "--out",
        "out/lcp",
    ]);
    let summary = &out["summary"];
    assert_eq!(summary["landscape_format"], "FARSITE .lcp");
    assert_eq!(
        summary["layer_units"]["slope (degrees)"],
        "degrees (converted to percent)"
    );
    assert_eq!(summary["crs"], "EPSG:5070", "from the .prj GDAL wrote");
    assert_eq!(
        summary["params"]["slope"], "as_given",
        "the .lcp's slope is already whole degrees"
    );
    assert_eq!(summary["fire_type_cells"]["surface"], 220_846);
    assert_eq!(summary["fire_type_cells"]["passive_crown"], 1_518);
    assert_eq!(summary["fire_type_cells"]["active_crown"], 7);
    assert_eq!(summary["nodata_cells"], 108_586);

    // The GeoTIFF layers with the slope rounded as an .lcp keeps it: the same grids.
    copy_worcester(&p, "landfire");
    p.json(&[
        "sim",
        "behavior",
        "--landscape",
        "landfire",
        "--moisture",
        "6,8,10,75,60",
        "--slope",
        "lcp",
        "--foliar-moisture",
        "120",
        "--out",
        "out/tif",
    ]);

    let flammap = worcester_fixtures().join("flammap");
    for run in ["out/lcp", "out/tif"] {
        let r = rasterio_check(FLAMMAP_PARITY_PY, &[&p.path(run), &flammap]);
        assert_eq!(r["surface"], 220_846, "{run}: {r}");
        assert_eq!(r["fire_type_equal"], r["burnable"], "{run}: {r}");
        for grid in ["ros_chph", "flame_length_ft", "fireline_intensity_btu_ft_s"] {
            let surface = r[format!("{grid}_surface_max_rel")].as_f64().unwrap();
            let crown = r[format!("{grid}_crown_max_rel")].as_f64().unwrap();
            assert!(surface < 0.005, "{run} {grid}: {surface}");
            assert!(crown < 0.05, "{run} {grid} on crown cells: {crown}");
        }
        assert!(r["direction_max_deg"].as_f64().unwrap() < 1.0, "{run}: {r}");
    }
    // And the two runs agree with each other cell by cell (the .lcp's slope goes through f32
    // once more: 1e-6 at most).
    let same = rasterio_check(
        r#"
import sys, json, numpy as np, rasterio
a, b = sys.argv[1], sys.argv[2]
res = {}
for g in ["ros_chph", "flame_length_ft", "fireline_intensity_btu_ft_s", "max_spread_direction_deg", "fire_type"]:
    x = rasterio.open(a + "/" + g + ".tif").read(1).astype(np.float64)
    y = rasterio.open(b + "/" + g + ".tif").read(1).astype(np.float64)
    res[g] = float(np.max(np.abs(x - y) / np.maximum(np.abs(y), 1e-9)))
print(json.dumps(res))
"#,
        &[&p.path("out/lcp"), &p.path("out/tif")],
    );
    for (grid, rel) in same.as_object().unwrap() {
        assert!(rel.as_f64().unwrap() < 1e-5, "{grid}: {rel}");
    }
    assert_eq!(same["fire_type"], 0.0);
}

#[test]
fn sim_behavior_grids_read_back_by_gdal() {
    let p = Project::new();
    copy_worcester(&p, "landfire");
    let out = p.json(&[
        "sim",
        "behavior",
        "--landscape",
        "landfire",
        "--moisture",
        "6,8,10,75,60",
        "--slope",
        "lcp",
        "--foliar-moisture",
        "120",
        "--out",
        "out/grids",
    ]);
    let summary = &out["summary"];
    // FireCast's own reading of a few cells of every grid, to compare with GDAL's.
    let cells = [(0usize, 0usize), (274, 306), (300, 420), (548, 612), (100, 450)];
    let script = r#"
import sys, json, numpy as np, rasterio
out = sys.argv[1]
res = {}
for name in ["ros_chph", "flame_length_ft", "fireline_intensity_btu_ft_s", "max_spread_direction_deg", "fire_type"]:
    with rasterio.open(out + "/" + name + ".tif") as d:
        a = d.read(1)
        t = d.transform
        ft = rasterio.open(out + "/fire_type.tif").read(1)
        burning = (ft != 0) & (ft != 32767)
        v = a[burning].astype(np.float64)
        res[name] = {
            "driver": d.driver, "count": d.count, "dtype": d.dtypes[0],
            "width": d.width, "height": d.height, "epsg": d.crs.to_epsg() if d.crs else None,
            "transform": [t.a, t.b, t.c, t.d, t.e, t.f], "nodata": d.nodata,
            "nodata_cells": int((a == d.nodata).sum()),
            "min": float(v.min()), "max": float(v.max()), "mean": float(v.mean()),
            "cells": [float(a[r, c]) for c, r in json.loads(sys.argv[2])],
            "counts": {str(int(k)): int(n) for k, n in zip(*np.unique(a, return_counts=True))} if name == "fire_type" else None,
        }
print(json.dumps(res))
"#;
    let cells_json = serde_json::to_string(&cells).unwrap();
    let r = rasterio_check(script, &[&p.path("out/grids"), std::path::Path::new(&cells_json)]);
    for name in [
        "ros_chph",
        "flame_length_ft",
        "fireline_intensity_btu_ft_s",
        "max_spread_direction_deg",
        "fire_type",
    ] {
        let g = &r[name];
        assert_eq!(g["driver"], "GTiff", "{name}");
        assert_eq!(g["count"], 1, "{name}");
        assert_eq!(g["dtype"], "float32", "{name}");
        assert_eq!(
            (g["width"].as_u64(), g["height"].as_u64()),
            (Some(549), Some(613)),
            "{name}"
        );
        assert_eq!(g["epsg"], 5070, "{name}");
        assert_eq!(
            g["transform"],
            serde_json::json!([30.0, 0.0, 1_833_825.0, 0.0, -30.0, 2_617_605.0]),
            "{name}"
        );
        assert_eq!(g["nodata"], 32767.0, "{name}");
        // FireCast's reading of the same cells.
        let (w, h, ours) =
            firecast_landscape::gridio::read_band_f32(&p.path("out/grids").join(format!("{name}.tif")))
                .unwrap();
        assert_eq!((w, h), (549, 613));
        for (k, (c, row)) in cells.iter().enumerate() {
            assert_eq!(
                g["cells"][k].as_f64().unwrap(),
                f64::from(ours[row * 549 + c]),
                "{name} ({c}, {row})"
            );
        }
    }
    // What GDAL reads is what the summary reports.
    let nodata = summary["nodata_cells"].as_u64().unwrap();
    assert_eq!(r["fire_type"]["nodata_cells"].as_u64(), Some(nodata));
    assert_eq!(r["ros_chph"]["nodata_cells"].as_u64(), Some(nodata));
    // Direction is nodata also where nothing spreads (non-burnable cells).
    assert_eq!(
        r["max_spread_direction_deg"]["nodata_cells"].as_u64(),
        Some(nodata + summary["fire_type_cells"]["none"].as_u64().unwrap())
    );
    let counts = &r["fire_type"]["counts"];
    assert_eq!(counts["0"], summary["fire_type_cells"]["none"]);
    assert_eq!(counts["1"], summary["fire_type_cells"]["surface"]);
    assert_eq!(counts["2"], summary["fire_type_cells"]["passive_crown"]);
    assert_eq!(counts["3"], summary["fire_type_cells"]["active_crown"]);
    for name in ["ros_chph", "flame_length_ft", "fireline_intensity_btu_ft_s"] {
        for stat in ["min", "max", "mean"] {
            let gdal = r[name][stat].as_f64().unwrap();
            let ours = summary[name][stat].as_f64().unwrap();
            assert!(
                (gdal - ours).abs() <= 1e-9 * ours.abs().max(1.0),
                "{name} {stat}: GDAL {gdal}, FireCast {ours}"
            );
        }
    }
    assert!(r["max_spread_direction_deg"]["min"].as_f64().unwrap() >= 0.0);
    assert!(r["max_spread_direction_deg"]["max"].as_f64().unwrap() < 360.0);
}

/// `sim behavior --landscape DIR` that must fail: the message holds every `expect`, and no
/// output folder appears.
fn refused(p: &Project, landscape: &str, expect: &[&str]) {
    let out = p
        .firecast()
        .args([
            "sim",
            "behavior",
            "--landscape",
            landscape,
            "--moisture",
            "6,8,10,75,60",
            "--out",
            "out/refused",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success(), "{}", describe(&out));
    let stderr = String::from_utf8_lossy(&out.stderr);
    for e in expect {
        assert!(stderr.contains(e), "missing {e:?}: {}", describe(&out));
    }
    assert!(!p.path("out/refused").exists(), "{landscape}: output written");
    assert!(
        !p.path("out").exists() || std::fs::read_dir(p.path("out")).unwrap().next().is_none(),
        "{landscape}: something was left in out/"
    );
}

/// Rewrite one LANDFIRE layer of a copied clip (as float32, nodata 32767) with FireCast's
/// GeoTIFF writer: `edit` changes values, `keys`/`origin_x` the georeference.
fn rewrite_layer(
    path: &std::path::Path,
    edit: impl FnOnce(&mut Vec<f32>),
    keys: Option<Vec<u16>>,
    origin_x: f64,
) {
    use firecast_landscape::gridio::{GeoKeyTags, GridPlacement, encode_geotiff_f32};
    let raster = firecast_landscape::geotiff::read_geotiff(path).unwrap();
    let mut values = raster.data.clone();
    edit(&mut values);
    let mut geokeys = GeoKeyTags::read(path).unwrap();
    if let Some(k) = keys {
        geokeys = GeoKeyTags {
            directory: k,
            doubles: Vec::new(),
            ascii: String::new(),
        };
    }
    let placement = GridPlacement {
        width: raster.width,
        height: raster.height,
        origin_x,
        origin_y: raster.origin_y,
        pixel_dx: raster.pixel_dx,
        pixel_dy: raster.pixel_dy,
        geokeys,
    };
    std::fs::write(
        path,
        encode_geotiff_f32(&placement, &values, Some(32767.0)).unwrap(),
    )
    .unwrap();
}

#[test]
fn sim_behavior_refuses_bad_landscapes_naming_file_layer_and_cell() {
    let p = Project::new();
    let fuel = "LF2022_FBFM40_230_CONUS/LC22_F40_230.tif";
    let slope = "LF2020_SlpP_220_CONUS/LC20_SlpP_220.tif";
    let aspect = "LF2020_Asp_220_CONUS/LC20_Asp_220.tif";
    const X0: f64 = 1_833_825.0;

    // A geographic CRS (degrees): refused, naming the layer and its file.
    copy_worcester(&p, "crs");
    rewrite_layer(
        &p.path("crs").join(fuel),
        |_| {},
        Some(vec![1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, 4326]),
        X0,
    );
    refused(
        &p,
        "crs",
        &["fbfm40", "EPSG:4326 is geographic", "LC22_F40_230.tif"],
    );

    // Grids that disagree: both files named, and how.
    copy_worcester(&p, "shifted");
    rewrite_layer(&p.path("shifted").join(slope), |_| {}, None, X0 + 30.0);
    refused(
        &p,
        "shifted",
        &[
            "slope (percent) grid",
            "LC20_SlpP_220.tif",
            "LC22_F40_230.tif",
            "transform",
        ],
    );

    // An unknown fuel code: counted, the first cell named.
    copy_worcester(&p, "unknown");
    rewrite_layer(
        &p.path("unknown").join(fuel),
        |v| {
            v[549 * 300 + 200] = 150.0;
            v[549 * 301 + 10] = 150.0;
        },
        None,
        X0,
    );
    refused(
        &p,
        "unknown",
        &[
            "fbfm40",
            "150: 2 cells",
            "column 200, row 300",
            "LC22_F40_230.tif",
        ],
    );

    // Nodata where a burnable fuel needs a slope.
    let land = firecast_landscape::landfire::LandfireLandscape::read_dir(
        &worcester_fixtures().join("landfire"),
        firecast_landscape::landfire::FuelLayer::Fbfm40,
    )
    .unwrap();
    let cell = (0..land.len())
        .find(|&i| land.fuel[i].is_some_and(|c| c > 100) && i % 549 > 100)
        .unwrap();
    copy_worcester(&p, "hole");
    rewrite_layer(&p.path("hole").join(slope), |v| v[cell] = 32767.0, None, X0);
    refused(
        &p,
        "hole",
        &[
            "slope (percent)",
            "1 cells with a burnable fuel model have no data",
            &format!("column {}, row {}", cell % 549, cell / 549),
            "LC20_SlpP_220.tif",
        ],
    );

    // A truncated GeoTIFF: the layer, the file, and the first rows it cannot decode.
    copy_worcester(&p, "truncated");
    let path = p.path("truncated").join(aspect);
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    refused(
        &p,
        "truncated",
        &[
            "aspect layer",
            "does not decode: cells from column 0, row",
            "LC20_Asp_220.tif",
        ],
    );

    // A truncated .lcp: the cells that are missing.
    let crop = worcester_fixtures().join("lcp/worcester_crop.lcp");
    std::fs::create_dir_all(p.path("lcp")).unwrap();
    let bytes = std::fs::read(&crop).unwrap();
    std::fs::write(p.path("lcp/crop.lcp"), &bytes[..7316 + 1000]).unwrap();
    refused(
        &p,
        "lcp/crop.lcp",
        &["LCP is truncated", "column 14, row 1", "crop.lcp"],
    );
    // An .lcp whose header is not one.
    let mut broken = bytes.clone();
    broken[4164..4168].copy_from_slice(&(-3i32).to_le_bytes());
    std::fs::write(p.path("lcp/crop.lcp"), &broken).unwrap();
    refused(
        &p,
        "lcp/crop.lcp",
        &[
            "LCP header numeast (columns) (byte 4164): -3 is not a positive number",
            "crop.lcp",
        ],
    );
    // An unknown fuel code in an .lcp (band 4 of 8 at column 5, row 3).
    let mut bad_fuel = bytes.clone();
    let at = 7316 + ((3 * 48 + 5) * 8 + 3) * 2;
    bad_fuel[at..at + 2].copy_from_slice(&150i16.to_le_bytes());
    std::fs::write(p.path("lcp/crop.lcp"), &bad_fuel).unwrap();
    refused(
        &p,
        "lcp/crop.lcp",
        &["150: 1 cells", "column 5, row 3", "crop.lcp"],
    );
    // A geographic .prj beside it.
    std::fs::write(p.path("lcp/crop.lcp"), &bytes).unwrap();
    std::fs::write(
        p.path("lcp/crop.prj"),
        r#"GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#,
    )
    .unwrap();
    refused(&p, "lcp/crop.lcp", &["EPSG:4326 is geographic", "crop.prj"]);
    // A single GeoTIFF is not a landscape.
    refused(
        &p,
        &format!("crs/{fuel}"),
        &["a single file, not an .lcp", "LC22_F40_230.tif"],
    );
}

#[test]
fn sim_behavior_stage_reads_an_lcp_folder() {
    let p = Project::new();
    gdal_worcester_lcp(&p, "data/lcp/worcester.lcp", &[]);
    p.write(
        "pipelines/lcp.yaml",
        r#"
stages:
  behavior:
    uses: sim.behavior
    params:
      moisture: {dead_1h: 6, dead_10h: 8, dead_100h: 10, live_herbaceous: 75, live_woody: 60}
      foliar_moisture_pct: 120
    inputs:
      landscape: data/lcp
    outputs:
      grids: build/behavior
"#,
    );
    assert_eq!(p.run_pipeline("pipelines/lcp.yaml", &[])["behavior"], "ran");
    let summary: serde_json::Value = serde_json::from_str(&p.read("build/behavior/summary.json")).unwrap();
    assert_eq!(summary["landscape_format"], "FARSITE .lcp");
    assert_eq!(summary["crs"], "EPSG:5070");
    assert_eq!(summary["fire_type_cells"]["surface"], 220_846);
    assert_eq!(summary["fire_type_cells"]["passive_crown"], 1_518);
    assert_eq!(summary["fire_type_cells"]["active_crown"], 7);

    // A truncated .lcp fails the stage with the file named; the earlier grids stay as they were.
    let lcp = p.path("data/lcp/worcester.lcp");
    let bytes = std::fs::read(&lcp).unwrap();
    std::fs::write(&lcp, &bytes[..bytes.len() - 100]).unwrap();
    let bad = p
        .firecast()
        .args(["pipeline", "run", "pipelines/lcp.yaml"])
        .output()
        .unwrap();
    assert!(!bad.status.success(), "{}", describe(&bad));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&bad.stdout),
        String::from_utf8_lossy(&bad.stderr)
    );
    assert!(
        text.contains("LCP is truncated") && text.contains("worcester.lcp"),
        "{}",
        describe(&bad)
    );
    let kept: serde_json::Value = serde_json::from_str(&p.read("build/behavior/summary.json")).unwrap();
    assert_eq!(kept, summary);
}

#[test]
fn sim_behavior_on_the_committed_lcp_crop_matches_flammap() {
    // The committed crop (GDAL-written, 48 x 40 cells at column 70, row 400 of the clip): no
    // Python needed. Its cells are FlamMap's cells of that window.
    let p = Project::new();
    let crop = worcester_fixtures().join("lcp/worcester_crop.lcp");
    let out = p.json(&[
        "sim",
        "behavior",
        "--landscape",
        crop.to_str().unwrap(),
        "--moisture",
        "6,8,10,75,60",
        "--foliar-moisture",
        "120",
        "--out",
        "out/crop",
    ]);
    let summary = &out["summary"];
    assert_eq!(
        (summary["width"].as_u64(), summary["height"].as_u64()),
        (Some(48), Some(40))
    );
    assert_eq!(summary["crs"], "EPSG:5070");
    let grid = |dir: &std::path::Path, name: &str| {
        firecast_landscape::gridio::read_band_f32(&dir.join(name)).unwrap()
    };
    let flammap = worcester_fixtures().join("flammap");
    let ours = p.path("out/crop");
    let (_, _, ft_ref) = grid(&flammap, "fire_type.tif");
    let (_, _, ros_ref) = grid(&flammap, "ROS_ch_hr.tif");
    let (_, _, fl_ref) = grid(&flammap, "FL_ft.tif");
    let (_, _, ft) = grid(&ours, "fire_type.tif");
    let (_, _, ros) = grid(&ours, "ros_chph.tif");
    let (_, _, fl) = grid(&ours, "flame_length_ft.tif");
    let (mut burning, mut crown) = (0, 0);
    for r in 0..40 {
        for c in 0..48 {
            let (i, j) = (r * 48 + c, (400 + r) * 549 + 70 + c);
            if ft_ref[j] >= 1.0 {
                burning += 1;
                crown += usize::from(ft_ref[j] >= 2.0);
                assert_eq!(ft[i], ft_ref[j], "fire type at ({c}, {r})");
                for (what, a, b) in [("ROS", ros[i], ros_ref[j]), ("flame length", fl[i], fl_ref[j])] {
                    assert!(
                        (a / b - 1.0).abs() < 0.005,
                        "{what} at ({c}, {r}): {a} against FlamMap's {b}"
                    );
                }
            } else {
                assert!(ft[i] == 0.0 || ft[i] == 32767.0, "({c}, {r}): {}", ft[i]);
            }
        }
    }
    assert_eq!(
        burning,
        summary["fire_type_cells"]["surface"].as_u64().unwrap() as usize + crown
    );
    assert!(crown > 100, "the crop holds FlamMap's crown cells ({crown})");
}

/// pyretechnics' own venv (`.venv-peers/pyretechnics`, from `cargo xtask setup`), if installed.
fn pyretechnics_python() -> Option<std::path::PathBuf> {
    firecast_testkit::peer_python(
        "pyretechnics",
        &["pyretechnics.burn_cells", "pyretechnics.eulerian_level_set"],
    )
}

#[test]
fn bench_behavior_and_spread_say_to_run_setup_without_pyretechnics() {
    let p = Project::new();
    for bench in ["behavior", "spread"] {
        let out = p
            .firecast()
            .args(["bench", bench, "--quick", "--python", "no-such-venv/bin/python"])
            .output()
            .unwrap();
        assert!(!out.status.success(), "{}", describe(&out));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("cargo xtask setup"), "{err}");
    }
}

#[test]
fn bench_behavior_and_spread_beside_pyretechnics() {
    let Some(python) = pyretechnics_python() else {
        eprintln!(
            "skipped: pyretechnics is not installed in .venv-peers/pyretechnics (`cargo xtask setup` installs it)"
        );
        return;
    };
    let p = Project::new();
    let landscape = worcester_fixtures().join("landfire");
    let common = |bench: &str| -> Vec<String> {
        [
            "bench",
            bench,
            "--quick",
            "--landscape",
            landscape.to_str().unwrap(),
            "--python",
            python.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec()
    };

    // Behaviour, FlamMap's inputs (no wind): every cell both call surface fire agrees.
    let out = p.ok(&common("behavior").iter().map(String::as_str).collect::<Vec<_>>());
    let text = String::from_utf8_lossy(&out.stdout);
    let agreement = text
        .lines()
        .find(|l| l.starts_with("agreement: "))
        .unwrap_or_else(|| panic!("no agreement line:\n{text}"));
    assert!(!agreement.contains("DISAGREE"), "{agreement}");
    let counts: Vec<u64> = agreement
        .trim_start_matches("agreement: ")
        .split(" cells")
        .next()
        .unwrap()
        .split(" of ")
        .map(|n| n.parse().unwrap())
        .collect();
    assert!(counts[0] == counts[1] && counts[0] > 1000, "{agreement}");
    for line in [
        "ratio: FireCast ",
        "grid cells/s",
        "machine: ",
        "goal >= 20x pyretechnics on one core: ",
    ] {
        assert!(text.contains(line), "no `{line}` in:\n{text}");
    }

    // With wind, as JSON: the comparable (flat) cells still agree; rates are printed.
    let mut args = common("behavior");
    args.extend(["--wind-mph", "15"].map(String::from));
    let v = p.json(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(v["agreement_holds"], true, "{v}");
    assert!(v["agreement"]["compared_cells"].as_u64().unwrap() > 0, "{v}");
    assert!(v["firecast"]["cells_per_second"].as_f64().unwrap() > 0.0);
    assert!(v["pyretechnics"]["cells_per_second"].as_f64().unwrap() > 0.0);
    assert!(v["ratio"].as_f64().unwrap() > 0.0);
    assert_eq!(
        (v["window"]["rows"].as_u64(), v["window"]["cols"].as_u64()),
        (Some(128), Some(128))
    );

    // Spread: both engines burn the point fire; areas, rates and ratios printed.
    let out = p.ok(&common("spread").iter().map(String::as_str).collect::<Vec<_>>());
    let text = String::from_utf8_lossy(&out.stdout);
    for line in [
        "burnt area: FireCast ",
        "different algorithms: ",
        "burnt cells/s",
        "ratio: FireCast ",
        "goal >= 20x",
    ] {
        assert!(text.contains(line), "no `{line}` in:\n{text}");
    }
    let v = p.json(&common("spread").iter().map(String::as_str).collect::<Vec<_>>());
    let areas = &v["areas"];
    let (ours, theirs) = (
        areas["firecast_cells"].as_u64().unwrap(),
        areas["pyretechnics_cells"].as_u64().unwrap(),
    );
    assert!(ours > 20 && theirs > 20, "{areas}");
    // Different algorithms, same fire: the burnt areas overlap for the most part.
    assert!(areas["jaccard"].as_f64().unwrap() > 0.6, "{areas}");
    assert!(v["cells_per_second_ratio"].as_f64().unwrap() > 0.0);
    assert_eq!(v["hours"], 8.0);
}
