//! A recording written by the recorder is readable by the Rerun of the same version
//! (PyPI rerun-sdk 0.36.3, installed by `cargo xtask setup`).
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;
use std::process::Command;

use firecast_recorder::{RERUN_VERSION, Recording, rerun};

fn rerun_cli() -> PathBuf {
    std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("../../.venv/bin/rerun")
}

#[test]
fn recording_in_the_store_is_readable_by_the_matching_viewer() {
    let dir = tempfile::tempdir().unwrap();
    let store = firecast_store::ArtifactStore::open("artifacts", dir.path()).unwrap();
    let recording = Recording::create("firecast_test", "run 42", &dir.path().join("staging")).unwrap();
    for step in 0..20 {
        recording
            .scalar("train/loss", "step", step, 1.0 / (1.0 + step as f64))
            .unwrap();
    }
    let fire = rerun::Image::from_l8(vec![0u8, 128, 255, 64], [2, 2]);
    recording.stream().log("env/fire", &fire).unwrap();
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
