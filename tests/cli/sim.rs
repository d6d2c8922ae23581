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
    let python = venv_bin("python");
    let has_pil = python.exists()
        && std::process::Command::new(&python)
            .args(["-c", "import PIL, numpy"])
            .status()
            .is_ok_and(|s| s.success());
    if has_pil {
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
