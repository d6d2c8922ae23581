//! A recording written by the recorder is readable by the Rerun of the same version
//! (PyPI rerun-sdk 0.36.3, installed by `cargo xtask setup`).
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;
use std::process::Command;

use firecast_recorder::{RERUN_VERSION, Recording, rerun};

fn rerun_cli() -> PathBuf {
    firecast_testkit::rerun_cli()
}

#[test]
fn recording_in_the_store_is_readable_by_the_matching_viewer() {
    let dir = tempfile::tempdir().unwrap();
    let store = firecast_store::ArtifactStore::open("artifacts", dir.path()).unwrap();
    let mut recording = Recording::create("firecast_test", "run 42", &dir.path().join("staging")).unwrap();
    for step in 0..20 {
        recording
            .scalar("train/loss", "step", step, 1.0 / (1.0 + step as f64))
            .unwrap();
    }
    let fire = rerun::Image::from_l8(vec![0u8, 128, 255, 64], [2, 2]);
    recording.log("env/fire", &fire).unwrap();
    let stored = recording.finish_to_store(&store, "runs/42/rollout.rrd").unwrap();
    assert!(stored.size > 0);

    let local = dir.path().join("copy.rrd");
    store.get_to_file(&stored.uri, &local).unwrap();
    let cli = rerun_cli();
    let version = Command::new(&cli).arg("--version").output().unwrap();
    let version = String::from_utf8_lossy(&version.stdout).to_string();
    assert!(version.contains(RERUN_VERSION), "viewer version: {version}");
    let verify = Command::new(&cli)
        .args(["rrd", "verify"])
        .arg(&local)
        .output()
        .unwrap();
    assert!(
        verify.status.success(),
        "rerun rrd verify failed:\n{}\n{}",
        String::from_utf8_lossy(&verify.stdout),
        String::from_utf8_lossy(&verify.stderr)
    );
    let printed = Command::new(&cli)
        .args(["rrd", "print"])
        .arg(&local)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&printed.stdout);
    assert!(text.contains("train/loss") && text.contains("env/fire"), "{text}");
}

#[test]
fn application_ids_follow_rerun_rules() {
    let dir = tempfile::tempdir().unwrap();
    let err = Recording::create("firecast/ppo", "x", dir.path()).unwrap_err();
    assert!(
        err.to_string()
            .contains("invalid Rerun application id `firecast/ppo`"),
        "{err}"
    );
}

/// Scalar rows per entity of an `.rrd`, read with the venv's Rerun SDK.
fn scalar_rows(path: &std::path::Path) -> firecast_testkit::Series {
    firecast_testkit::read_scalars(path)
}

#[test]
fn metrics_mirror_records_every_run_from_many_threads() {
    use std::sync::Arc;

    use firecast_pipeline::executor::{ObservedEvent, RecordingObserver};
    use firecast_pipeline::observer::StageRunInfo;
    use firecast_pipeline::{RunObserver, RunStatus};

    let dir = tempfile::tempdir().unwrap();
    let store = Arc::new(firecast_store::ArtifactStore::open("artifacts", dir.path()).unwrap());
    let registry = Arc::new(RecordingObserver::default());
    let staging = dir.path().join("staging");
    let mirror = firecast_recorder::MetricsMirror::new(
        registry.clone(),
        store.clone(),
        staging.clone(),
        None,
        |warning| panic!("unexpected warning: {warning}"),
    );
    let info = |run: &str| StageRunInfo {
        run_id: run.into(),
        pipeline_run_id: "p".into(),
        parent_run_id: None,
        pipeline: "demo".into(),
        stage: format!("stage-{run}"),
        kind: "cmd".into(),
        kind_version: 1,
        params: serde_json::json!({}),
        cache_key: "k".into(),
        git_commit: None,
        started_at: chrono::Utc::now(),
    };
    // Three runs at once, each fed by two threads (as parallel stages and their workers do);
    // run `c` fails halfway and keeps its curves; run `quiet` reports no metric.
    let runs = ["a", "b", "c"];
    for run in runs.iter().chain(&["quiet"]) {
        mirror.stage_started(&info(run)).unwrap();
    }
    std::thread::scope(|scope| {
        for run in runs {
            for thread in 0..2_i64 {
                let mirror = &mirror;
                scope.spawn(move || {
                    for step in 0..50 {
                        let key = format!("seed-{thread}/train/loss");
                        mirror
                            .metric(run, &key, step, (step * 10 + thread) as f64)
                            .unwrap();
                    }
                });
            }
        }
    });
    let now = chrono::Utc::now();
    mirror
        .stage_finished("a", RunStatus::Succeeded, now, None)
        .unwrap();
    mirror
        .stage_finished("b", RunStatus::Succeeded, now, None)
        .unwrap();
    mirror
        .stage_finished("c", RunStatus::Failed, now, Some("stopped"))
        .unwrap();
    mirror
        .stage_finished("quiet", RunStatus::Succeeded, now, None)
        .unwrap();
    drop(mirror);

    let events = Arc::try_unwrap(registry).unwrap().into_events();
    let metrics = events
        .iter()
        .filter(|e| matches!(e, ObservedEvent::Metric { .. }))
        .count();
    assert_eq!(metrics, 3 * 2 * 50, "every metric reaches the registry too");
    let artifacts: Vec<(&str, u64)> = events
        .iter()
        .filter_map(|e| match e {
            ObservedEvent::Artifact { name, uri, size, .. } => {
                assert_eq!(name, firecast_recorder::METRICS_ARTIFACT);
                Some((uri.as_str(), *size))
            }
            _ => None,
        })
        .collect();
    assert_eq!(artifacts.len(), 3, "{artifacts:?}");
    for (run, (uri, size)) in runs.iter().zip(&artifacts) {
        assert!(uri.ends_with(&format!("runs/{run}/metrics/metrics.rrd")), "{uri}");
        let local = dir.path().join(format!("{run}.rrd"));
        assert_eq!(store.get_to_file(uri, &local).unwrap(), *size);
        let rows = scalar_rows(&local);
        for thread in 0..2_i64 {
            let expected: Vec<(i64, f64)> = (0..50).map(|s| (s, (s * 10 + thread) as f64)).collect();
            assert_eq!(rows[&format!("seed-{thread}/train/loss")], expected, "run {run}");
        }
    }
    assert_eq!(
        std::fs::read_dir(&staging).unwrap().count(),
        0,
        "no staging file is left"
    );
}

/// The same rows into a new recording: a static image, 300 steps on two timelines of an
/// image (2.8 MiB in all, so cut into chunks by size), a scalar and, now and then, points.
fn write_sample(dir: &std::path::Path, staging: &str) -> Vec<u8> {
    let mut rec = Recording::create("firecast_test", "same twice", &dir.join(staging)).unwrap();
    rec.log_static(
        "env/terrain",
        &rerun::Image::from_l8(vec![7u8; 64 * 64], [64, 64]),
    )
    .unwrap();
    for step in 0..300_i64 {
        rec.set_time_sequence("step", step).unwrap();
        rec.set_duration_secs("sim_time", step as f64 * 30.0).unwrap();
        let pixels = vec![(step % 251) as u8; 96 * 96];
        rec.log("env/fire", &rerun::Image::from_l8(pixels, [96, 96]))
            .unwrap();
        rec.log("stats/burning", &rerun::Scalars::single(step as f64 / 2.0))
            .unwrap();
        if step % 7 == 0 {
            rec.log("env/drops", &rerun::Points2D::new([(step as f32, 1.5)]))
                .unwrap();
        }
    }
    let path = dir.join(format!("{staging}.rrd"));
    rec.finish_to_file(&path).unwrap();
    std::fs::read(&path).unwrap()
}

#[test]
fn the_same_rows_give_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let first = write_sample(dir.path(), "a");
    std::thread::sleep(std::time::Duration::from_millis(20));
    let second = write_sample(dir.path(), "b");
    assert!(first == second, "two recordings of the same rows differ");

    // Still a whole recording: every entity, the two timelines and no clock-based ones,
    // every value, the name, several chunks of the image.
    const READ: &str = r#"
import json, sys
from rerun.experimental import RrdReader
out = {"timelines": set(), "chunks": {}, "rows": {}, "name": None, "recordings": []}
reader = RrdReader(sys.argv[1])
out["recordings"] = [r.recording_id for r in reader.recordings()]
for chunk in reader.stream():
    path = chunk.entity_path.lstrip("/")
    batch = chunk.to_record_batch()
    out["timelines"].update(chunk.timeline_names)
    out["chunks"][path] = out["chunks"].get(path, 0) + 1
    out["rows"][path] = out["rows"].get(path, 0) + chunk.num_rows
    if path == "__properties":
        out["name"] = batch.column("RecordingInfo:name").to_pylist()[0][0]
    if path == "stats/burning":
        out.setdefault("burning", []).extend(
            [s, v[0]] for s, v in zip(batch.column("step").to_pylist(), batch.column("Scalars:scalars").to_pylist()))
out["timelines"] = sorted(out["timelines"])
json.dump(out, sys.stdout)
"#;
    let path = dir.path().join("a.rrd");
    let python = rerun_cli().with_file_name("python");
    let out = Command::new(&python)
        .arg("-c")
        .arg(READ)
        .arg(&path)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let seen: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        seen["timelines"],
        serde_json::json!(["sim_time", "step"]),
        "{seen}"
    );
    assert_eq!(seen["name"], "same twice");
    assert_eq!(seen["recordings"].as_array().unwrap().len(), 1, "{seen}");
    for (entity, rows) in [
        ("env/terrain", 1),
        ("env/fire", 300),
        ("stats/burning", 300),
        ("env/drops", 43),
    ] {
        assert_eq!(seen["rows"][entity], rows, "{entity}: {seen}");
    }
    assert!(seen["chunks"]["env/fire"].as_u64().unwrap() > 1, "{seen}");
    let burning: Vec<(i64, f64)> = serde_json::from_value(seen["burning"].clone()).unwrap();
    assert_eq!(burning, (0..300).map(|s| (s, s as f64 / 2.0)).collect::<Vec<_>>());
    let verify = Command::new(rerun_cli())
        .args(["rrd", "verify"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(
        verify.status.success(),
        "{}",
        String::from_utf8_lossy(&verify.stderr)
    );
}
