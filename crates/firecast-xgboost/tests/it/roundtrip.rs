//! Model artifacts, determinism, progress and concurrent prediction.

use firecast_xgboost::{Booster, XgbParams};

use crate::common::{max_abs_diff, synthetic};

fn params(nthread: u32) -> XgbParams {
    XgbParams {
        n_estimators: 30,
        max_depth: 4,
        learning_rate: 0.2,
        subsample: 0.9,
        colsample_bytree: 0.8,
        nthread,
        ..XgbParams::default()
    }
}

#[test]
fn save_load_round_trip_gives_identical_predictions() {
    let train = synthetic(1000, 20, 1);
    let test = synthetic(300, 20, 2);
    let model = Booster::fit(&train.x, train.rows, train.cols, &train.y, &params(2), 11).expect("fit");
    let before = model
        .predict_proba(&test.x, test.rows, test.cols)
        .expect("predict");
    let json = model.save_json().expect("save");
    assert!(json.starts_with(b"{"), "JSON model");
    let loaded = Booster::load_json(&json).expect("load");
    assert_eq!(loaded.num_features(), 20);
    assert_eq!(loaded.num_rounds().expect("rounds"), 30);
    assert_eq!(model.num_rounds().expect("rounds"), 30);
    let after = loaded
        .predict_proba(&test.x, test.rows, test.cols)
        .expect("predict");
    assert_eq!(before, after, "bit-identical after the round trip");
    // Saving the loaded model again gives the same bytes.
    assert_eq!(loaded.save_json().expect("save again"), json);
    // Zero rows predict to nothing.
    assert!(loaded.predict_proba(&[], 0, 20).expect("empty").is_empty());
}

#[test]
fn training_is_deterministic_and_reports_progress() {
    let train = synthetic(800, 12, 3);
    let mut rounds = Vec::new();
    let a = Booster::fit_with_progress(
        &train.x,
        train.rows,
        train.cols,
        &train.y,
        &params(2),
        5,
        |done, total| rounds.push((done, total)),
    )
    .expect("fit");
    assert_eq!(rounds.len(), 30);
    assert_eq!(rounds.first(), Some(&(1, 30)));
    assert_eq!(rounds.last(), Some(&(30, 30)));
    let b = Booster::fit(&train.x, train.rows, train.cols, &train.y, &params(2), 5).expect("fit");
    assert_eq!(
        a.save_json().expect("a"),
        b.save_json().expect("b"),
        "same seed, same model"
    );
    let c = Booster::fit(&train.x, train.rows, train.cols, &train.y, &params(2), 6).expect("fit");
    assert_ne!(
        a.save_json().expect("a"),
        c.save_json().expect("c"),
        "seed is used"
    );

    // Thread count: measured, reported (the hist reduction order may depend on it).
    let one = Booster::fit(&train.x, train.rows, train.cols, &train.y, &params(1), 5).expect("fit");
    let pa = a.predict_proba(&train.x, train.rows, train.cols).expect("p");
    let p1 = one.predict_proba(&train.x, train.rows, train.cols).expect("p");
    eprintln!("nthread 1 vs 2: max |dp| = {:e}", max_abs_diff(&pa, &p1));
}

#[test]
fn concurrent_predictions_agree_with_sequential_ones() {
    let train = synthetic(1000, 16, 8);
    let test = synthetic(400, 16, 9);
    let model = Booster::fit(&train.x, train.rows, train.cols, &train.y, &params(2), 1).expect("fit");
    let expected = model
        .predict_proba(&test.x, test.rows, test.cols)
        .expect("predict");
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..4)
            .map(|_| {
                s.spawn(|| {
                    (0..5)
                        .map(|_| model.predict_proba(&test.x, test.rows, test.cols))
                        .collect::<Result<Vec<_>, _>>()
                })
            })
            .collect();
        let json = model.save_json().expect("save while predicting");
        assert!(!json.is_empty());
        for h in handles {
            for p in h.join().expect("thread").expect("predict") {
                assert_eq!(p, expected);
            }
        }
    });
    // A booster can move to another thread and be dropped there.
    let moved = std::thread::spawn(move || model.num_features())
        .join()
        .expect("thread");
    assert_eq!(moved, 16);
}

/// An offset model: zero trees is the offset itself, the first k trees move away from it
/// step by step, and margins of the wrong length or not finite are refused.
#[test]
fn margins_start_every_row_from_its_offset() {
    let train = synthetic(600, 8, 5);
    let margin: Vec<f32> = (0..train.rows).map(|i| ((i % 7) as f32 - 3.0) * 0.5).collect();
    let model = Booster::fit_with_margin(
        &train.x,
        train.rows,
        train.cols,
        &train.y,
        &margin,
        &params(1),
        3,
        |_, _| {},
    )
    .expect("fit");
    let at = |k: Option<u32>| {
        model
            .predict_proba_with_margin(&train.x, train.rows, train.cols, &margin, k)
            .expect("predict")
    };
    let offset: Vec<f64> = margin
        .iter()
        .map(|&m| 1.0 / (1.0 + (-f64::from(m)).exp()))
        .collect();
    assert_eq!(at(Some(0)), offset, "no trees: the offset alone");
    let (one, all) = (at(Some(1)), at(None));
    assert!(max_abs_diff(&one, &offset) > 0.0 && max_abs_diff(&one, &offset) < max_abs_diff(&all, &offset));
    assert_eq!(at(Some(30)), all, "all 30 trees");
    // The saved model keeps the trees; the margin comes with the rows, as in XGBoost.
    let loaded = Booster::load_json(&model.save_json().expect("save")).expect("load");
    assert_eq!(
        loaded
            .predict_proba_with_margin(&train.x, train.rows, train.cols, &margin, Some(12))
            .expect("predict"),
        at(Some(12))
    );
    let short = model.predict_proba_with_margin(&train.x, train.rows, train.cols, &margin[1..], None);
    assert!(format!("{:?}", short.expect_err("short margin")).contains("margin has 599 values"));
    let mut bad = margin.clone();
    bad[4] = f32::INFINITY;
    let err = Booster::fit_with_margin(
        &train.x,
        train.rows,
        train.cols,
        &train.y,
        &bad,
        &params(1),
        3,
        |_, _| {},
    );
    assert!(format!("{:?}", err.expect_err("infinite margin")).contains("margin[4]"));
}
