//! Every baseline against scikit-learn 1.9.1 on the same seeded data
//! (`tests/tools/sklearn_baselines.py` run with the project's venv), and the tree models
//! node by node against scikit-learn's own trees (`tests/tools/sklearn_trees.py`).

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use firecast_baselines::{BaselineSpec, Matrix, Standardizer, fit};
use serde_json::{Value, json};

use crate::data::{accuracy, auroc, read_npy_f32, split, write_npy_f32, write_npy_labels};

/// The venv's Python with scikit-learn; a missing venv fails the test (never skips it).
fn python() -> PathBuf {
    firecast_testkit::python_with(&["sklearn"])
}

/// (name, spec JSON, whether it sees standardised features, max |Δproba| or None).
/// Names ending in `_f64` make scikit-learn fit float64 copies of the same values.
fn cases() -> Vec<(&'static str, Value, bool, Option<f64>)> {
    // Tight tol and a high max_iter so both optimisers reach the optimum: scikit-learn gets
    // there only in float64 (in float32 it stalls ~1e-3 away), hence the two references.
    let lr = json!({"model": "logistic_regression", "c": 1.0, "max_iter": 10000, "tol": 1e-8, "fit_intercept": true});
    vec![
        ("logistic_regression", lr.clone(), true, Some(1e-3)),
        ("logistic_regression_f64", lr, true, Some(1e-5)),
        ("gaussian_nb", json!({"model": "gaussian_nb"}), false, Some(1e-4)),
        // The trees are scikit-learn's (same random_state): equal to rounding.
        (
            "decision_tree",
            json!({"model": "decision_tree"}),
            false,
            Some(1e-12),
        ),
        (
            "random_forest",
            json!({"model": "random_forest"}),
            false,
            Some(1e-12),
        ),
        (
            "gradient_boosting",
            json!({"model": "gradient_boosting"}),
            false,
            Some(1e-12),
        ),
        ("knn", json!({"model": "knn"}), true, Some(1e-4)),
    ]
}

#[test]
fn agrees_with_scikit_learn() {
    let py = python();
    let script = PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("tests/tools/sklearn_baselines.py");
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("baselines-fidelity");
    std::fs::create_dir_all(&dir).unwrap();

    let seed = 20240611;
    let data = split(1500, 600, 10, seed);
    write_npy_f32(&dir.join("x_train.npy"), &data.x_train).unwrap();
    write_npy_f32(&dir.join("x_test.npy"), &data.x_test).unwrap();
    write_npy_labels(&dir.join("y_train.npy"), &data.y_train).unwrap();
    write_npy_labels(&dir.join("y_test.npy"), &data.y_test).unwrap();

    let specs: Vec<(&str, BaselineSpec, bool, Option<f64>)> = cases()
        .into_iter()
        .map(|(name, v, std, tol)| (name, serde_json::from_value(v).unwrap(), std, tol))
        .collect();
    // The specs with every default filled in, so both sides get identical values.
    let models: serde_json::Map<String, Value> = specs
        .iter()
        .map(|(n, s, _, _)| (n.to_string(), serde_json::to_value(s).unwrap()))
        .collect();
    let spread: Vec<u64> = match std::env::var("FIRECAST_SKLEARN_SPREAD") {
        Ok(v) => (1..=v.parse().unwrap_or(3)).collect(),
        Err(_) => Vec::new(),
    };
    let config = json!({
        "seed": seed,
        "standardize": specs.iter().filter(|s| s.2).map(|s| s.0).collect::<Vec<_>>(),
        "float64": specs.iter().filter(|s| s.0.ends_with("_f64")).map(|s| s.0).collect::<Vec<_>>(),
        "spread_seeds": spread,
        "models": models,
    });
    std::fs::write(dir.join("config.json"), config.to_string()).unwrap();

    let t0 = Instant::now();
    let out = Command::new(&py)
        .arg(&script)
        .arg(&dir)
        .output()
        .unwrap_or_else(|e| panic!("could not run {}: {e}; run `cargo xtask setup`", py.display()));
    assert!(
        out.status.success(),
        "{} failed ({}): {}\nrun `cargo xtask setup` if scikit-learn is missing",
        script.display(),
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let reference: Value = serde_json::from_slice(&out.stdout).unwrap();
    eprintln!(
        "scikit-learn {} reference in {:.1} s",
        reference["sklearn_version"],
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(reference["sklearn_version"], "1.9.1");

    // StandardScaler, bit for bit.
    let (scaler, xs_train) = Standardizer::fit_transform(&data.x_train).unwrap();
    let xs_test = scaler.transform(&data.x_test).unwrap();
    let exact = |v: &Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|s| s.as_str().unwrap().parse::<f64>().unwrap())
            .collect()
    };
    assert_eq!(
        scaler.mean,
        exact(&reference["scaler"]["mean"]),
        "StandardScaler.mean_"
    );
    assert_eq!(
        scaler.scale,
        exact(&reference["scaler"]["scale"]),
        "StandardScaler.scale_"
    );
    let bits = |m: &Matrix| m.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&xs_train), bits(&read_npy_f32(&dir.join("x_train_std.npy"))));
    assert_eq!(bits(&xs_test), bits(&read_npy_f32(&dir.join("x_test_std.npy"))));

    let mut failures = Vec::new();
    eprintln!(
        "{:<24} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>10} {:>10} {:>8} {:>8}",
        "model",
        "acc_rs",
        "acc_sk",
        "Δacc",
        "auc_rs",
        "auc_sk",
        "Δauc",
        "max|Δp|",
        "med|Δp|",
        "fit_rs",
        "fit_sk"
    );
    for (name, spec, standardized, tol) in &specs {
        let (xtr, xte) = if *standardized {
            (&xs_train, &xs_test)
        } else {
            (&data.x_train, &data.x_test)
        };
        let t = Instant::now();
        let model = fit(spec, xtr, &data.y_train, seed).unwrap();
        let fit_rs = t.elapsed().as_secs_f64();
        let p = model.predict_proba(xte).unwrap();
        let r = &reference["models"][*name];
        let p_sk: Vec<f64> = r["proba"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let (acc_rs, auc_rs) = (accuracy(&data.y_test, &p), auroc(&data.y_test, &p));
        let (acc_sk, auc_sk) = (r["accuracy"].as_f64().unwrap(), r["roc_auc"].as_f64().unwrap());
        // The local metrics agree with scikit-learn's on its own probabilities.
        assert!(
            (auroc(&data.y_test, &p_sk) - auc_sk).abs() < 1e-12,
            "{name}: local AUROC"
        );
        let mut dp: Vec<f64> = p.iter().zip(&p_sk).map(|(a, b)| (a - b).abs()).collect();
        dp.sort_by(f64::total_cmp);
        let (max_dp, median_dp) = (dp[dp.len() - 1], dp[dp.len() / 2]);
        eprintln!(
            "{:<24} {:>8.4} {:>8.4} {:>+8.4} {:>8.4} {:>8.4} {:>+8.4} {:>10.2e} {:>10.2e} {:>7.2}s {:>7.2}s",
            name,
            acc_rs,
            acc_sk,
            acc_rs - acc_sk,
            auc_rs,
            auc_sk,
            auc_rs - auc_sk,
            max_dp,
            median_dp,
            fit_rs,
            r["fit_seconds"].as_f64().unwrap()
        );
        if let Some(iters) = model.lbfgs_iterations() {
            eprintln!(
                "    L-BFGS: ours {iters:?}, scikit-learn n_iter_ = {}",
                r["n_iter"]
            );
        }
        for s in r["spread"].as_array().unwrap() {
            eprintln!(
                "    scikit-learn random_state={}: acc {:.4} auc {:.4}",
                s["seed"], s["accuracy"], s["roc_auc"]
            );
        }
        if (acc_rs - acc_sk).abs() > 0.015 {
            failures.push(format!(
                "{name}: accuracy {acc_rs:.4} vs scikit-learn {acc_sk:.4}"
            ));
        }
        if (auc_rs - auc_sk).abs() > 0.015 {
            failures.push(format!("{name}: AUROC {auc_rs:.4} vs scikit-learn {auc_sk:.4}"));
        }
        if let Some(tol) = tol
            && max_dp > *tol
        {
            failures.push(format!("{name}: max |p − p_sklearn| = {max_dp:.2e} > {tol:.0e}"));
        }
    }
    assert!(
        failures.is_empty(),
        "disagreements with scikit-learn:\n{}",
        failures.join("\n")
    );
}

/// Fit and predict times at the paper's scale (ignored by default; run with
/// `cargo test --release -p firecast-baselines --test it -- --ignored --nocapture`).
/// `FIRECAST_SCALE_ROWS` (default 70000, 80 % train), `FIRECAST_SCALE_DAYS` (75),
/// `FIRECAST_SCALE_MODELS` (comma-separated names, default all) and
/// `FIRECAST_SCALE_TREES` (override `n_estimators`).
#[test]
#[ignore = "minutes of CPU: a benchmark, not a check"]
fn full_scale_timing() {
    let rows: usize = std::env::var("FIRECAST_SCALE_ROWS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(70_000);
    let days: usize = std::env::var("FIRECAST_SCALE_DAYS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(75);
    let only = std::env::var("FIRECAST_SCALE_MODELS").unwrap_or_default();
    let train = rows * 4 / 5;
    let t = Instant::now();
    let data = split(train, rows - train, days, 7);
    eprintln!(
        "{} train / {} test × {} features generated in {:.1} s ({} threads)",
        train,
        rows - train,
        data.x_train.cols,
        t.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    let (scaler, xs_train) = Standardizer::fit_transform(&data.x_train).unwrap();
    let xs_test = scaler.transform(&data.x_test).unwrap();
    for (name, v, standardized, _) in cases() {
        if name.ends_with("_f64") || (!only.is_empty() && !only.split(',').any(|m| m == name)) {
            continue;
        }
        let mut v = if name == "logistic_regression" {
            json!({"model": "logistic_regression"})
        } else {
            v
        };
        if let (Ok(trees), true) = (
            std::env::var("FIRECAST_SCALE_TREES"),
            name.ends_with("ing") || name.ends_with("forest"),
        ) {
            v["n_estimators"] = json!(trees.parse::<usize>().unwrap());
        }
        let spec: BaselineSpec = serde_json::from_value(v).unwrap();
        let (xtr, xte) = if standardized {
            (&xs_train, &xs_test)
        } else {
            (&data.x_train, &data.x_test)
        };
        let t = Instant::now();
        let model = fit(&spec, xtr, &data.y_train, 1).unwrap();
        let fit_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let p = model.predict_proba(xte).unwrap();
        let predict_s = t.elapsed().as_secs_f64();
        eprintln!(
            "{name:<20} fit {fit_s:>7.1} s  predict {predict_s:>7.1} s  acc {:.4}  auc {:.4}  trees/nodes {:?}",
            accuracy(&data.y_test, &p),
            auroc(&data.y_test, &p),
            model.tree_size()
        );
    }
}

/// The tree models with the hyper-parameters the exact-tree test fits on both sides.
fn tree_cases() -> Vec<(&'static str, Value)> {
    vec![
        ("decision_tree", json!({"model": "decision_tree"})),
        (
            "decision_tree_sqrt",
            json!({"model": "decision_tree", "max_depth": 6, "min_samples_leaf": 3, "max_features": "sqrt"}),
        ),
        (
            "random_forest",
            json!({"model": "random_forest", "n_estimators": 20}),
        ),
        (
            "random_forest_no_bootstrap",
            json!({"model": "random_forest", "n_estimators": 5, "bootstrap": false, "max_features": 0.5, "min_samples_split": 4}),
        ),
        (
            "gradient_boosting",
            json!({"model": "gradient_boosting", "n_estimators": 40}),
        ),
        (
            "gradient_boosting_subsample",
            json!({"model": "gradient_boosting", "n_estimators": 25, "subsample": 0.7, "max_features": "sqrt", "max_depth": 4}),
        ),
    ]
}

/// The decision tree, random forest and gradient boosting equal scikit-learn's, tree by
/// tree and node by node, for two random_states on two datasets with tied values (the
/// weather windows' rounded humidity, whole-degree wind direction and zero-inflated rain;
/// a five-level grid with duplicated and constant columns).
#[test]
fn trees_equal_scikit_learns() {
    let py = python();
    let script = PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("tests/tools/sklearn_trees.py");
    let random_states = [0u64, 12345];
    let datasets = [
        ("weather", split(900, 300, 8, 7)),
        ("coarse", crate::data::coarse(700, 300, 12, 5, 11)),
    ];
    let cases: Vec<(&str, BaselineSpec)> = tree_cases()
        .into_iter()
        .map(|(n, v)| (n, serde_json::from_value(v).unwrap()))
        .collect();
    let models: serde_json::Map<String, Value> = cases
        .iter()
        .map(|(n, s)| (n.to_string(), serde_json::to_value(s).unwrap()))
        .collect();
    let exact = |v: &Value| -> f64 { v.as_str().unwrap().parse::<f64>().unwrap() };
    let mut failures = Vec::new();
    eprintln!(
        "{:<8} {:<28} {:>6} {:>6} {:>7} {:>10} {:>10} {:>9}",
        "data", "model", "state", "trees", "nodes", "max|Δp|", "max|Δv|", "differ"
    );
    for (data_name, data) in &datasets {
        let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("baselines-trees-{data_name}"));
        std::fs::create_dir_all(&dir).unwrap();
        write_npy_f32(&dir.join("x_train.npy"), &data.x_train).unwrap();
        write_npy_f32(&dir.join("x_test.npy"), &data.x_test).unwrap();
        write_npy_labels(&dir.join("y_train.npy"), &data.y_train).unwrap();
        let config = json!({"random_states": random_states, "models": models});
        std::fs::write(dir.join("config.json"), config.to_string()).unwrap();
        let out = Command::new(&py)
            .arg(&script)
            .arg(&dir)
            .output()
            .unwrap_or_else(|e| panic!("could not run {}: {e}; run `cargo xtask setup`", py.display()));
        assert!(
            out.status.success(),
            "{} failed ({}): {}",
            script.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        let reference: Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(reference["sklearn_version"], "1.9.1");
        for (name, spec) in &cases {
            for &state in &random_states {
                let r = &reference["fits"][format!("{name}/{state}")];
                let model = fit(spec, &data.x_train, &data.y_train, state).unwrap();
                let p = model.predict_proba(&data.x_test).unwrap();
                let max_dp = p
                    .iter()
                    .zip(r["proba"].as_array().unwrap())
                    .map(|(a, b)| (a - exact(b)).abs())
                    .fold(0.0f64, f64::max);
                let ours = model.tree_nodes();
                let theirs = r["trees"].as_array().unwrap();
                let mut differ = 0usize;
                let mut max_dv = 0.0f64;
                let mut first_diff = None;
                if ours.len() != theirs.len() {
                    failures.push(format!(
                        "{data_name} {name} random_state={state}: {} trees, scikit-learn {}",
                        ours.len(),
                        theirs.len()
                    ));
                }
                for (k, (t, s)) in ours.iter().zip(theirs).enumerate() {
                    let feature = s["feature"].as_array().unwrap();
                    let threshold = s["threshold"].as_array().unwrap();
                    let value = s["value"].as_array().unwrap();
                    let mut same = t.len() == feature.len();
                    for (i, node) in t.iter().enumerate().take(feature.len()) {
                        let f = feature[i].as_i64().unwrap();
                        let split_same = match node.feature {
                            Some(ff) => ff as i64 == f && node.threshold == exact(&threshold[i]),
                            None => f == -2,
                        };
                        let dv = (node.value - exact(&value[i])).abs();
                        max_dv = max_dv.max(dv);
                        if !split_same || dv > 1e-12 {
                            same = false;
                        }
                    }
                    if !same {
                        differ += 1;
                        first_diff.get_or_insert(k);
                    }
                }
                let nodes: usize = ours.iter().map(Vec::len).sum();
                eprintln!(
                    "{data_name:<8} {name:<28} {state:>6} {:>6} {nodes:>7} {max_dp:>10.2e} {max_dv:>10.2e} {differ:>9}",
                    ours.len()
                );
                if differ > 0 {
                    failures.push(format!(
                        "{data_name} {name} random_state={state}: {differ} of {} trees differ from scikit-learn's (first: tree {})",
                        ours.len(),
                        first_diff.unwrap_or(0)
                    ));
                }
                if max_dp > 1e-12 {
                    failures.push(format!(
                        "{data_name} {name} random_state={state}: max |p − p_sklearn| = {max_dp:.2e} > 1e-12"
                    ));
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "trees that are not scikit-learn's:\n{}",
        failures.join("\n")
    );
}
