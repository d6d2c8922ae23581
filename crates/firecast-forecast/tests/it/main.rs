//! The tch networks against PyTorch eager re-statements of the same architectures, and the
//! experiment spec's strictness.
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;
use std::process::Command;

use firecast_forecast::neural::{NeuralConfig, NeuralKind, count_parameters};

fn python() -> PathBuf {
    firecast_testkit::python_with(&["torch"])
}

fn reference() -> PathBuf {
    PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()))
        .join("reference/forecast_torch.py")
}

#[test]
fn parameter_counts_equal_pytorch_for_every_network() {
    for (width, days) in [(15i64, 75i64), (16, 60), (14, 75)] {
        let out = Command::new(python())
            .arg(reference())
            .args(["count", &width.to_string(), &days.to_string()])
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let counts: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        for kind in [
            NeuralKind::CnnBilstm,
            NeuralKind::CnnBilstmAttn,
            NeuralKind::Firecast,
            NeuralKind::Lstm2,
            NeuralKind::Lightts,
            NeuralKind::Mlp,
        ] {
            let ours = count_parameters(&NeuralConfig::defaults(kind), width, days);
            let theirs = counts[kind.as_str()].as_i64().unwrap();
            assert_eq!(ours, theirs, "{} at width {width}, {days} days", kind.as_str());
        }
    }
}

#[test]
fn the_authors_r_network_has_the_size_the_spec_implies() {
    // Conv 14→64→128, BiLSTM 128×3 (hidden 128), Linear 256→1 on 14 variables × 75 days.
    let n = count_parameters(&NeuralConfig::defaults(NeuralKind::CnnBilstm), 14, 75);
    let conv = (14 * 64 * 3 + 64) + 2 * 64 + (64 * 128 * 3 + 128) + 2 * 128;
    let lstm = 2 * (4 * 128 * (128 + 128) + 8 * 128) + 2 * 2 * (4 * 128 * (256 + 128) + 8 * 128);
    assert_eq!(n, conv + lstm + 257);
}

#[test]
fn neural_params_are_strict_and_checked() {
    let bad = NeuralConfig::parse(NeuralKind::Firecast, &serde_json::json!({"epochs": 3})).unwrap_err();
    assert!(bad.to_string().contains("epochs"), "{bad}");
    let bad = NeuralConfig::parse(NeuralKind::Firecast, &serde_json::json!({"dropout": 1.5})).unwrap_err();
    assert!(bad.to_string().contains("dropout"), "{bad}");
    let ok = NeuralConfig::parse(NeuralKind::CnnBilstm, &serde_json::json!({"max_epochs": 3})).unwrap();
    assert_eq!(ok.max_epochs, 3);
    assert_eq!(ok.lr, 1e-4, "variant R keeps the authors' AdamW 1e-4");
    assert!(!ok.standardize, "variant R does not normalise, as train.py");
}
