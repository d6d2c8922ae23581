//! Error paths: parameters, inputs, C API errors, a missing library.

use std::process::Command;

use firecast_xgboost::{Booster, XgbError, XgbParams};
use serde_json::json;

use crate::common::synthetic;

#[test]
fn unknown_param_key_is_named() {
    let err = XgbParams::from_json(&json!({"max_depth": 3, "max_dept": 4})).expect_err("unknown");
    match &err {
        XgbError::Param { key, .. } => assert_eq!(key, "max_dept"),
        other => panic!("expected Param, got {other:?}"),
    }
    assert!(err.to_string().contains("`max_dept`"), "{err}");
    // Plain serde (e.g. a pipeline's YAML) rejects it too.
    let err = serde_json::from_value::<XgbParams>(json!({"colsample_bylevel": 0.5}))
        .expect_err("deny_unknown_fields");
    assert!(err.to_string().contains("colsample_bylevel"), "{err}");
    // A bad value is attributed to its key.
    let err = XgbParams::from_json(&json!({"subsample": 1.5})).expect_err("range");
    assert!(err.to_string().contains("`subsample`"), "{err}");
}

#[test]
fn inputs_are_checked_before_calling_xgboost() {
    let d = synthetic(50, 6, 4);
    let p = XgbParams {
        n_estimators: 2,
        nthread: 1,
        ..XgbParams::default()
    };
    let input = |r: Result<Booster, XgbError>| match r {
        Err(XgbError::Input(msg)) => msg,
        other => panic!("expected Input error, got {other:?}"),
    };
    input(Booster::fit(&d.x, d.rows, d.cols + 1, &d.y, &p, 0));
    input(Booster::fit(&d.x, d.rows, d.cols, &d.y[1..], &p, 0));
    input(Booster::fit(&[], 0, d.cols, &[], &p, 0));
    let msg = input(Booster::fit(&d.x, d.rows, d.cols, &vec![true; d.rows], &p, 0));
    assert!(msg.contains("both classes"), "{msg}");
    let mut x = d.x.clone();
    x[7] = f32::NEG_INFINITY;
    let msg = input(Booster::fit(&x, d.rows, d.cols, &d.y, &p, 0));
    assert!(msg.contains("row 1, col 1"), "{msg}");
    let bad_seed = Booster::fit(&d.x, d.rows, d.cols, &d.y, &p, u64::MAX).expect_err("seed");
    assert!(matches!(bad_seed, XgbError::Param { ref key, .. } if key == "seed"));

    let model = Booster::fit(&d.x, d.rows, d.cols, &d.y, &p, 0).expect("fit");
    let err = model
        .predict_proba(&d.x[..d.rows * 5], d.rows, 5)
        .expect_err("cols");
    assert!(err.to_string().contains("trained on 6 features"), "{err}");
}

#[test]
fn c_api_errors_carry_xgboost_message() {
    match Booster::load_json(b"{\"not\": \"a model\"}") {
        Err(XgbError::Api { call, message }) => {
            assert_eq!(call, "XGBoosterLoadModelFromBuffer");
            assert!(!message.is_empty());
        }
        other => panic!("expected an Api error, got {other:?}"),
    }
}

#[test]
fn version_is_xgboost_3() {
    let (major, minor, patch) = firecast_xgboost::xgboost_version().expect("library");
    eprintln!(
        "libxgboost {major}.{minor}.{patch} from {:?}",
        firecast_xgboost::library_path()
    );
    assert!(major >= 3);
}

#[test]
fn probing_a_missing_library_fails_clearly() {
    let dir = tempfile::tempdir().expect("tempdir");
    let missing = dir.path().join("libxgboost.so");
    let err = firecast_xgboost::probe_library(&missing).expect_err("missing");
    assert!(matches!(err, XgbError::Library(_)));
    assert!(err.to_string().contains(&missing.display().to_string()), "{err}");
}

const CHILD_ENV: &str = "FIRECAST_XGB_TEST_CHILD";

/// Run by `missing_library_is_a_clear_error` in a child process with
/// `FIRECAST_XGBOOST_LIB` pointing at a missing file; a no-op otherwise.
#[test]
fn child_loads_library_from_env() {
    if std::env::var_os(CHILD_ENV).is_none() {
        return;
    }
    match firecast_xgboost::xgboost_version() {
        Ok(v) => println!("CHILD-OK {v:?}"),
        Err(e) => println!("CHILD-ERR<<{e}>>"),
    }
    // The fit path reports the same error.
    let d = synthetic(20, 6, 1);
    let err = Booster::fit(&d.x, d.rows, d.cols, &d.y, &XgbParams::default(), 0).expect_err("fit");
    println!("CHILD-FIT-ERR<<{err}>>");
}

#[test]
fn missing_library_is_a_clear_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let missing = dir.path().join("nowhere/libxgboost.so");
    let exe = std::env::current_exe().expect("test binary");
    let out = Command::new(exe)
        .args(["--exact", "errors::child_loads_library_from_env", "--nocapture"])
        .env(CHILD_ENV, "1")
        .env(firecast_xgboost::LIB_ENV, &missing)
        .output()
        .expect("run child");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "child failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = stdout
        .split("CHILD-ERR<<")
        .nth(1)
        .and_then(|s| s.split(">>").next())
        .unwrap_or_else(|| panic!("child did not report an error:\n{stdout}"));
    eprintln!("missing-library error: {err}");
    assert!(err.contains(&missing.display().to_string()), "{err}");
    assert!(err.contains("FIRECAST_XGBOOST_LIB"), "{err}");
    assert!(err.contains("cargo xtask setup"), "{err}");
    assert!(stdout.contains(&format!("CHILD-FIT-ERR<<{err}>>")), "{stdout}");
}
