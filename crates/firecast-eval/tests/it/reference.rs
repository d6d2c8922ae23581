//! Runs `tests/tools/sklearn_reference.py` once per test process with the project's
//! Python (`$FIRECAST_VENV/bin/python`) and hands out its answers.

use std::path::PathBuf;
use std::process::Command;
use std::sync::OnceLock;

use serde_json::{Value, json};

use crate::cases::{self, Case};

/// What was sent and what came back.
pub struct Reference {
    pub cases: Vec<Case>,
    pub erfc_points: Vec<f64>,
    pub chi2_points: Vec<f64>,
    pub binomtest: Vec<(u64, u64)>,
    pub trim_mean: Vec<Vec<f64>>,
    pub quantile: Vec<(Vec<f64>, Vec<f64>)>,
    pub out: Value,
}

fn python() -> PathBuf {
    firecast_testkit::python_with(&["sklearn"])
}

fn run() -> Reference {
    let cases = cases::all();
    let erfc_points = cases::erfc_points();
    let chi2_points: Vec<f64> = [
        0.0,
        1e-8,
        0.5,
        1.0,
        3.841_458_820_694_124,
        4.0,
        10.0,
        25.0,
        60.0,
        150.0,
        700.0,
    ]
    .to_vec();
    let binomtest: Vec<(u64, u64)> = (1..=30u64).flat_map(|n| (0..=n).map(move |k| (k, n))).collect();
    let trim_mean: Vec<Vec<f64>> = (1..=13)
        .map(|n| {
            (0..n)
                .map(|i| f64::from((i * 37) % 11) + 0.25 * f64::from(i))
                .collect()
        })
        .collect();
    let quantile: Vec<(Vec<f64>, Vec<f64>)> = vec![
        (
            vec![3.0, 1.0, 2.0, 10.0, 4.0],
            vec![0.025, 0.05, 0.5, 0.95, 0.975],
        ),
        (
            (0..1000).map(|i| f64::from((i * 7919) % 1000) / 997.0).collect(),
            vec![0.025, 0.975, 0.1, 0.9],
        ),
        (vec![0.5], vec![0.0, 0.025, 1.0]),
    ];
    let spec = json!({
        "cases": cases.iter().map(Case::to_json).collect::<Vec<_>>(),
        "erfc": erfc_points,
        "chi2_1df": chi2_points,
        "binomtest": binomtest.iter().map(|&(k, n)| json!([k, n])).collect::<Vec<_>>(),
        "trim_mean": trim_mean,
        "quantile": quantile.iter().map(|(v, q)| json!({"values": v, "q": q})).collect::<Vec<_>>(),
    });
    let input = std::env::temp_dir().join(format!("firecast-eval-reference-{}.json", std::process::id()));
    std::fs::write(&input, serde_json::to_vec(&spec).unwrap()).unwrap();
    let script = format!(
        "{}/tests/tools/sklearn_reference.py",
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into())
    );
    let output = Command::new(python()).arg(script).arg(&input).output().unwrap();
    let _ = std::fs::remove_file(&input);
    assert!(
        output.status.success(),
        "sklearn_reference.py failed ({}); if scikit-learn is missing run `cargo xtask setup`:\n{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    let out: Value = serde_json::from_slice(&output.stdout).unwrap();
    Reference {
        cases,
        erfc_points,
        chi2_points,
        binomtest,
        trim_mean,
        quantile,
        out,
    }
}

/// The reference, computed on first use.
pub fn get() -> &'static Reference {
    static REFERENCE: OnceLock<Reference> = OnceLock::new();
    REFERENCE.get_or_init(run)
}

/// A float from the script's JSON, which carries IEEE-754 bit patterns (serde_json's
/// default decimal parser is not always correctly rounded; bits are exact).
pub fn num(v: &Value) -> f64 {
    f64::from_bits(v.as_u64().unwrap_or_else(|| panic!("not a float's bits: {v}")))
}

/// A list of floats from the script's JSON.
pub fn nums(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("not a list: {v}"))
        .iter()
        .map(num)
        .collect()
}

/// Whether the script reported that sklearn raised.
pub fn raised(v: &Value) -> bool {
    v.get("error").is_some()
}

/// Equal within `tol` (absolute), NaN matching NaN and infinities matching exactly.
pub fn close(a: f64, b: f64, tol: f64) -> bool {
    (a.is_nan() && b.is_nan()) || a == b || (a - b).abs() <= tol
}

/// Equal within `tol` relative to |b| (absolute below 1).
pub fn close_rel(a: f64, b: f64, tol: f64) -> bool {
    (a.is_nan() && b.is_nan()) || a == b || (a - b).abs() <= tol * b.abs().max(1e-300)
}

/// Collects mismatches so one failing test lists all of them.
#[derive(Default)]
pub struct Mismatches(Vec<String>);

impl Mismatches {
    pub fn check(&mut self, ok: bool, what: impl FnOnce() -> String) {
        if !ok {
            self.0.push(what());
        }
    }

    pub fn assert_none(self, what: &str) {
        assert!(
            self.0.is_empty(),
            "{} {what} mismatch(es):\n{}",
            self.0.len(),
            self.0.join("\n")
        );
    }
}
