//! Determinism, persistence, errors and progress through the public API.

use std::sync::Mutex;

use firecast_baselines::{
    BaselineError, BaselineSpec, Fitted, KnnParams, Matrix, RandomForestParams, Standardizer, fit,
    fit_with_progress,
};
use proptest::prelude::*;
use serde_json::json;

use crate::data::{split, weather_windows};

fn spec(kind: &str, params: serde_json::Value) -> BaselineSpec {
    BaselineSpec::from_kind(kind, &params).unwrap()
}

/// Small versions of every model (a few trees keep the tests fast).
fn all_specs() -> Vec<BaselineSpec> {
    vec![
        spec("logistic_regression", json!({})),
        spec("gaussian_nb", json!({})),
        spec("decision_tree", json!({})),
        spec("decision_tree", json!({"max_features": "sqrt", "max_depth": 6})),
        spec("random_forest", json!({"n_estimators": 12})),
        spec(
            "random_forest",
            json!({"n_estimators": 4, "max_features": null, "bootstrap": false}),
        ),
        spec("gradient_boosting", json!({"n_estimators": 15})),
        spec(
            "gradient_boosting",
            json!({"n_estimators": 8, "subsample": 0.7, "max_features": 0.3}),
        ),
        spec("knn", json!({"n_neighbors": 7, "weights": "distance"})),
    ]
}

fn bits(p: &[f64]) -> Vec<u64> {
    p.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn same_seed_same_model_and_json_round_trip_is_bit_identical() {
    let d = split(300, 100, 4, 5);
    let (scaler, xs) = Standardizer::fit_transform(&d.x_train).unwrap();
    let xt = scaler.transform(&d.x_test).unwrap();
    for s in all_specs() {
        let (train, test) = if s.wants_standardized() {
            (&xs, &xt)
        } else {
            (&d.x_train, &d.x_test)
        };
        let a = fit(&s, train, &d.y_train, 17).unwrap();
        let b = fit(&s, train, &d.y_train, 17).unwrap();
        let json = a.to_json().unwrap();
        assert_eq!(json, b.to_json().unwrap(), "{}: same seed, same JSON", s.kind());
        let back = Fitted::from_json(&json).unwrap();
        assert_eq!(back, a);
        assert_eq!(back.feature_count(), 60);
        let p = a.predict_proba(test).unwrap();
        assert_eq!(
            bits(&back.predict_proba(test).unwrap()),
            bits(&p),
            "{}: reloaded predictions",
            s.kind()
        );
        assert!(p.iter().all(|v| (0.0..=1.0).contains(v)), "{}", s.kind());
        assert_eq!(back.to_json().unwrap(), json);
        // The JSON also travels inside other documents (serde, not only to_json).
        let wrapped = serde_json::to_value(json!({ "model": a })).unwrap();
        let again: Fitted = serde_json::from_value(wrapped["model"].clone()).unwrap();
        assert_eq!(again, a);
    }
    let rf = spec("random_forest", json!({"n_estimators": 5}));
    let a = fit(&rf, &d.x_train, &d.y_train, 1).unwrap();
    let b = fit(&rf, &d.x_train, &d.y_train, 2).unwrap();
    assert_ne!(
        a.to_json().unwrap(),
        b.to_json().unwrap(),
        "another seed, another forest"
    );
}

#[test]
fn thread_count_does_not_change_any_model() {
    let d = split(400, 50, 5, 9);
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    for s in all_specs() {
        let one = pool(1).install(|| fit(&s, &d.x_train, &d.y_train, 3).unwrap());
        let two = pool(2).install(|| fit(&s, &d.x_train, &d.y_train, 3).unwrap());
        assert_eq!(one.to_json().unwrap(), two.to_json().unwrap(), "{}", s.kind());
        let p1 = pool(1).install(|| one.predict_proba(&d.x_test).unwrap());
        let p2 = pool(2).install(|| two.predict_proba(&d.x_test).unwrap());
        assert_eq!(bits(&p1), bits(&p2), "{}", s.kind());
    }
}

#[test]
fn tiny_tree_by_hand() {
    // Feature 0 separates the classes between 2 and 4 (threshold 3); feature 1 is noise.
    let x = Matrix::from_rows(&[[1.0f32, 5.0], [2.0, 1.0], [4.0, 4.0], [5.0, 2.0], [6.0, 3.0]]).unwrap();
    let y = [false, false, true, true, true];
    let m = fit(&spec("decision_tree", json!({})), &x, &y, 0).unwrap();
    assert_eq!(m.tree_size(), (1, 3));
    let q = Matrix::from_rows(&[[3.0f32, 0.0], [3.0001, 0.0]]).unwrap();
    assert_eq!(m.predict_proba(&q).unwrap(), vec![0.0, 1.0]);
    // A depth-1 tree on impure data: leaf = class fraction.
    let y = [false, true, true, false, true];
    let m = fit(&spec("decision_tree", json!({"max_depth": 1})), &x, &y, 0).unwrap();
    let p = m.predict_proba(&x).unwrap();
    assert!(
        p.iter()
            .all(|v| [0.0, 0.5, 2.0 / 3.0, 1.0, 0.75, 0.25, 1.0 / 3.0].contains(v)),
        "{p:?}"
    );
}

#[test]
fn knn_ties_go_to_the_lower_training_index() {
    let x = Matrix::from_rows(&[[0.0f32, 1.0], [1.0, 0.0], [0.0, -1.0], [-1.0, 0.0], [5.0, 5.0]]).unwrap();
    let y = [true, false, false, true, true];
    let q = Matrix::from_rows(&[[0.0f32, 0.0]]).unwrap();
    let p = |k| {
        fit(&spec("knn", json!({"n_neighbors": k})), &x, &y, 0)
            .unwrap()
            .predict_proba(&q)
            .unwrap()[0]
    };
    assert_eq!(p(1), 1.0); // row 0
    assert_eq!(p(2), 0.5); // rows 0, 1
    assert_eq!(p(3), 1.0 / 3.0); // rows 0, 1, 2
    assert_eq!(p(4), 0.5);
}

#[test]
fn errors_name_what_is_wrong() {
    let (x, y) = weather_windows(40, 2, 3);
    let lr = spec("logistic_regression", json!({}));
    let e = fit(&lr, &Matrix::empty(30), &[], 0).unwrap_err();
    assert!(matches!(e, BaselineError::EmptyTrainingSet), "{e}");
    let e = fit(&lr, &x, &[true; 40], 0).unwrap_err();
    assert!(e.to_string().contains("single class"), "{e}");
    let e = fit(&lr, &x, &y[..39], 0).unwrap_err();
    assert!(
        e.to_string().contains("39 labels") && e.to_string().contains("40 rows"),
        "{e}"
    );

    let mut bad = x.clone();
    bad.data[3 * 30 + 7] = f32::NAN;
    let e = fit(&lr, &bad, &y, 0).unwrap_err();
    assert!(e.to_string().contains("row 3, column 7"), "{e}");

    // A seed is scikit-learn's random_state: NumPy refuses one of 2^32 or more.
    let e = fit(
        &spec("random_forest", json!({"n_estimators": 2})),
        &x,
        &y,
        1 << 32,
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("seed") && e.to_string().contains("4294967296"),
        "{e}"
    );
    assert!(fit(&spec("decision_tree", json!({})), &x, &y, u64::from(u32::MAX)).is_ok());

    let m = fit(&spec("gaussian_nb", json!({})), &x, &y, 0).unwrap();
    let narrow = Matrix::new(2, 29, vec![0.0; 58]).unwrap();
    let e = m.predict_proba(&narrow).unwrap_err();
    assert!(
        e.to_string().contains("30") && e.to_string().contains("29"),
        "{e}"
    );
    let mut inf = Matrix::new(2, 30, vec![0.0; 60]).unwrap();
    inf.data[30 + 2] = f32::INFINITY;
    let e = m.predict_proba(&inf).unwrap_err();
    assert!(e.to_string().contains("row 1, column 2"), "{e}");
    let broken = Matrix {
        rows: 3,
        cols: 30,
        data: vec![0.0; 60],
    };
    assert!(matches!(
        m.predict_proba(&broken),
        Err(BaselineError::Shape { .. })
    ));

    let rf = BaselineSpec::RandomForest(RandomForestParams {
        n_estimators: 0,
        ..Default::default()
    });
    let e = fit(&rf, &x, &y, 0).unwrap_err();
    assert_eq!(
        e.to_string(),
        "invalid hyper-parameter: n_estimators must be ≥ 1, got 0"
    );
    let knn = BaselineSpec::Knn(KnnParams {
        n_neighbors: 41,
        ..Default::default()
    });
    let e = fit(&knn, &x, &y, 0).unwrap_err();
    assert!(e.to_string().contains("n_neighbors"), "{e}");
    let e = fit(&spec("decision_tree", json!({"max_features": 31})), &x, &y, 0).unwrap_err();
    assert!(e.to_string().contains("max_features"), "{e}");

    // A tampered artifact is refused on load, not at prediction time.
    let tree = fit(&spec("decision_tree", json!({})), &x, &y, 0).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&tree.to_json().unwrap()).unwrap();
    v["n_features"] = json!(3);
    assert!(Fitted::from_json(&v.to_string()).is_err());
    let mut v: serde_json::Value = serde_json::from_str(&m.to_json().unwrap()).unwrap();
    v["spec"] = json!({"model": "knn"});
    assert!(Fitted::from_json(&v.to_string()).is_err());
}

#[test]
fn progress_reaches_the_total() {
    let d = split(200, 10, 3, 2);
    for (s, total) in [
        (spec("random_forest", json!({"n_estimators": 9})), 9),
        (spec("gradient_boosting", json!({"n_estimators": 6})), 6),
        (spec("gaussian_nb", json!({})), 1),
        (spec("knn", json!({})), 1),
    ] {
        let seen = Mutex::new(Vec::new());
        fit_with_progress(&s, &d.x_train, &d.y_train, 0, &|done, all| {
            seen.lock().unwrap().push((done, all))
        })
        .unwrap();
        let mut seen = seen.into_inner().unwrap();
        seen.sort_unstable();
        assert_eq!(seen.len(), total, "{}", s.kind());
        assert_eq!(seen.last(), Some(&(total, total)), "{}", s.kind());
    }
    let seen = Mutex::new(Vec::new());
    let lr = spec("logistic_regression", json!({"max_iter": 5}));
    let m = fit_with_progress(&lr, &d.x_train, &d.y_train, 0, &|a, b| {
        seen.lock().unwrap().push((a, b))
    })
    .unwrap();
    let seen = seen.into_inner().unwrap();
    assert!(
        !seen.is_empty() && seen.iter().all(|&(a, b)| a <= b && b == 5),
        "{seen:?}"
    );
    assert!(m.lbfgs_iterations().unwrap().0 <= 5);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Any small finite dataset: probabilities in [0, 1], reload is bit-identical.
    #[test]
    fn any_small_dataset(
        rows in 4usize..30,
        cols in 1usize..5,
        seed in 0u64..1000,
        values in proptest::collection::vec(-1e3f32..1e3, 150),
        kind in 0usize..6,
    ) {
        let data: Vec<f32> = (0..rows * cols).map(|i| values[i % values.len()] * (1.0 + (i / values.len()) as f32)).collect();
        let x = Matrix::new(rows, cols, data).unwrap();
        let y: Vec<bool> = (0..rows).map(|i| i % 3 == 0).collect();
        let s = [
            spec("logistic_regression", json!({})),
            spec("gaussian_nb", json!({})),
            spec("decision_tree", json!({})),
            spec("random_forest", json!({"n_estimators": 3})),
            spec("gradient_boosting", json!({"n_estimators": 3})),
            spec("knn", json!({"n_neighbors": 3})),
        ][kind].clone();
        let m = match fit(&s, &x, &y, seed) {
            Ok(m) => m,
            // Only GaussianNB may refuse (all columns constant).
            Err(e) => { prop_assert!(matches!(e, BaselineError::Numerical(_)), "{e}"); return Ok(()); }
        };
        let p = m.predict_proba(&x).unwrap();
        prop_assert!(p.iter().all(|v| (0.0..=1.0).contains(v)), "{p:?}");
        let back = Fitted::from_json(&m.to_json().unwrap()).unwrap();
        prop_assert_eq!(bits(&back.predict_proba(&x).unwrap()), bits(&p));
    }
}
