//! Agreement with Python xgboost on the same data, parameters, seed and thread count.

use std::process::Command;

use firecast_xgboost::{Booster, XgbParams};
use serde_json::{Value, json};

use crate::common::{max_abs_diff, reference_script, synthetic, venv_python, write_npy_f32};

struct Config {
    name: &'static str,
    params: XgbParams,
    seed: u64,
    /// Train and predict from a per-row log-odds offset, using this many trees.
    offset: Option<u32>,
}

/// A per-row log-odds offset that carries part of the signal (as a climatology would).
fn offset_of(x: &[f32], cols: usize) -> Vec<f32> {
    // Missing values (NaN) count as 0.
    let value = |v: f32| if v.is_nan() { 0.0 } else { v };
    x.chunks(cols)
        .map(|row| 0.8 * value(row[0]) - 0.3 + 0.1 * value(row[1]).sin())
        .collect()
}

fn configs() -> Vec<Config> {
    vec![
        Config {
            name: "tuned",
            params: XgbParams {
                n_estimators: 60,
                max_depth: 5,
                learning_rate: 0.1,
                subsample: 0.8,
                colsample_bytree: 0.7,
                min_child_weight: 2.0,
                reg_lambda: 1.5,
                reg_alpha: 0.1,
                gamma: 0.05,
                max_bin: 128,
                nthread: 2,
                ..XgbParams::default()
            },
            seed: 7,
            offset: None,
        },
        Config {
            // XGBoost defaults, single-threaded (the "tuned" run covers nthread = 2).
            name: "defaults",
            params: XgbParams {
                nthread: 1,
                ..XgbParams::default()
            },
            seed: 0,
            offset: None,
        },
        Config {
            // An offset model (base_margin), predicted with its first 23 of 40 trees.
            name: "offset",
            params: XgbParams {
                n_estimators: 40,
                max_depth: 3,
                learning_rate: 0.05,
                subsample: 0.8,
                nthread: 2,
                ..XgbParams::default()
            },
            seed: 3,
            offset: Some(23),
        },
    ]
}

fn sklearn_kwargs(p: &XgbParams, seed: u64) -> Value {
    json!({
        "n_estimators": p.n_estimators,
        "max_depth": p.max_depth,
        "learning_rate": p.learning_rate,
        "subsample": p.subsample,
        "colsample_bytree": p.colsample_bytree,
        "min_child_weight": p.min_child_weight,
        "reg_lambda": p.reg_lambda,
        "reg_alpha": p.reg_alpha,
        "gamma": p.gamma,
        "tree_method": p.tree_method,
        "max_bin": p.max_bin,
        "objective": p.objective,
        "n_jobs": p.nthread,
        "random_state": seed,
    })
}

/// Decodes the script's float32 bit patterns.
fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| {
            let bits = u32::try_from(x.as_u64().expect("uint32 bits")).expect("u32");
            f64::from(f32::from_bits(bits))
        })
        .collect()
}

/// How many entries are bit-for-bit equal.
fn identical(a: &[f64], b: &[f64]) -> usize {
    a.iter()
        .zip(b)
        .filter(|(x, y)| x.to_bits() == y.to_bits())
        .count()
}

#[test]
fn predictions_match_python_xgboost() {
    let train = synthetic(2000, 50, 20240601);
    let test = synthetic(500, 50, 777);
    let dir = tempfile::tempdir().expect("tempdir");
    let root = dir.path();
    write_npy_f32(&root.join("x_train.npy"), &train.x, &[train.rows, train.cols]);
    let labels: Vec<f32> = train.y.iter().map(|&b| f32::from(u8::from(b))).collect();
    write_npy_f32(&root.join("y_train.npy"), &labels, &[train.rows]);
    write_npy_f32(&root.join("x_test.npy"), &test.x, &[test.rows, test.cols]);

    let mut rust = Vec::new();
    let mut json_configs = Vec::new();
    let (m_train, m_test) = (offset_of(&train.x, train.cols), offset_of(&test.x, test.cols));
    write_npy_f32(&root.join("m_train.npy"), &m_train, &[train.rows]);
    write_npy_f32(&root.join("m_test.npy"), &m_test, &[test.rows]);
    for c in configs() {
        let (model, p) = match c.offset {
            None => {
                let model =
                    Booster::fit(&train.x, train.rows, train.cols, &train.y, &c.params, c.seed).expect("fit");
                let p = model
                    .predict_proba(&test.x, test.rows, test.cols)
                    .expect("predict");
                (model, p)
            }
            Some(rounds) => {
                let model = Booster::fit_with_margin(
                    &train.x,
                    train.rows,
                    train.cols,
                    &train.y,
                    &m_train,
                    &c.params,
                    c.seed,
                    |_, _| {},
                )
                .expect("fit");
                let p = model
                    .predict_proba_with_margin(&test.x, test.rows, test.cols, &m_test, Some(rounds))
                    .expect("predict");
                // The offset is used: without it (all trees, base_score) predictions differ.
                let plain = model
                    .predict_proba(&test.x, test.rows, test.cols)
                    .expect("predict");
                assert!(max_abs_diff(&p, &plain) > 0.05, "the margin changed nothing");
                (model, p)
            }
        };
        let model_file = format!("{}.json", c.name);
        std::fs::write(root.join(&model_file), model.save_json().expect("save")).expect("write");
        let pairs: serde_json::Map<String, Value> = c
            .params
            .booster_params(c.seed)
            .expect("params")
            .into_iter()
            .map(|(k, v)| (k, Value::String(v)))
            .collect();
        let mut config = json!({
            "name": c.name,
            "params": pairs,
            "num_boost_round": c.params.n_estimators,
            "sklearn": sklearn_kwargs(&c.params, c.seed),
            "model": model_file,
        });
        if let Some(rounds) = c.offset {
            config["margin"] = json!({"train": "m_train.npy", "test": "m_test.npy"});
            config["iteration_end"] = json!(rounds);
        }
        json_configs.push(config);
        rust.push((c.name, p));
    }
    std::fs::write(
        root.join("configs.json"),
        serde_json::to_vec_pretty(&json_configs).expect("json"),
    )
    .expect("write configs");

    let python = venv_python();
    let output = Command::new(&python)
        .arg(reference_script())
        .arg(root)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}; run `cargo xtask setup`", python.display()));
    assert!(
        output.status.success(),
        "xgb_reference.py failed ({}); run `cargo xtask setup`:\n{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    let stdout = String::from_utf8_lossy(&output.stdout);
    let line = stdout.lines().last().expect("reference output");
    let reference: Value = serde_json::from_str(line).expect("reference JSON");

    let (major, minor, patch) = firecast_xgboost::xgboost_version().expect("version");
    assert_eq!(
        reference["xgboost_version"].as_str(),
        Some(format!("{major}.{minor}.{patch}").as_str()),
        "Rust and Python must load the same XGBoost"
    );

    for (name, p) in &rust {
        let r = &reference["results"][name];
        let train_api = floats(&r["train"]);
        let classifier = floats(&r["classifier"]);
        let rust_model = floats(&r["rust_model"]);
        let d_train = max_abs_diff(p, &train_api);
        let d_clf = max_abs_diff(p, &classifier);
        let d_model = max_abs_diff(p, &rust_model);
        let mean_p = p.iter().sum::<f64>() / p.len() as f64;
        let n = p.len();
        eprintln!(
            "[{name}] n={n} mean p={mean_p:.4}\n  \
             rust vs xgboost.train:            max |dp| = {d_train:e}, bit-identical {}/{n}\n  \
             rust vs XGBClassifier:            max |dp| = {d_clf:e}, bit-identical {}/{n}\n  \
             rust model loaded by Python:      max |dp| = {d_model:e}, bit-identical {}/{n}",
            identical(p, &train_api),
            identical(p, &classifier),
            identical(p, &rust_model),
        );
        assert!(d_train <= 1e-6, "[{name}] xgboost.train differs by {d_train}");
        assert!(d_clf <= 1e-6, "[{name}] XGBClassifier differs by {d_clf}");
        assert!(
            d_model <= 1e-6,
            "[{name}] Rust model loaded in Python differs by {d_model}"
        );
        // Same library, same data, same parameters and thread count: the same model.
        assert_eq!(
            identical(p, &train_api),
            n,
            "[{name}] not bit-identical to xgboost.train"
        );
        assert_eq!(
            identical(p, &rust_model),
            n,
            "[{name}] Rust model not bit-identical in Python"
        );
        // The predictions carry signal (not a constant model).
        let spread = p.iter().cloned().fold(f64::MIN, f64::max) - p.iter().cloned().fold(f64::MAX, f64::min);
        assert!(spread > 0.5, "[{name}] predictions barely vary: {spread}");
    }
}
