//! A trained binary classifier: fit, predict probabilities, save and load as JSON.

use crate::XgbError;
use crate::ffi::{self, DMatrix, RawBooster};
use crate::params::XgbParams;

/// `XGBoosterPredictFromDMatrix` config for plain (transformed) predictions over all trees.
const PREDICT_CONFIG: &std::ffi::CStr = c"{\"type\": 0, \"training\": false, \"iteration_begin\": 0, \"iteration_end\": 0, \"strict_shape\": false}";
/// `XGBoosterSaveModelToBuffer` config.
const SAVE_JSON_CONFIG: &std::ffi::CStr = c"{\"format\": \"json\"}";

/// A trained XGBoost `binary:logistic` booster (a handle to the C++ learner, freed on drop).
///
/// `Booster` is `Send` and `Sync`: XGBoost's learner has no thread affinity, and XGBoost
/// documents prediction on tree boosters as thread safe since 1.4; the crate serialises
/// everything else ([`Booster::save_json`], [`Booster::config_json`]) against predictions
/// with an internal read-write lock, and training happens inside [`Booster::fit`] before
/// the value is shared.
pub struct Booster {
    raw: RawBooster,
    n_features: usize,
}

impl std::fmt::Debug for Booster {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Booster")
            .field("n_features", &self.n_features)
            .finish_non_exhaustive()
    }
}

/// Checks `x` (`rows x cols`, row-major, NaN = missing): length, `cols >= 1`, no infinities.
fn check_matrix(x: &[f32], rows: usize, cols: usize) -> Result<(), XgbError> {
    if cols == 0 {
        return Err(XgbError::Input("cols must be >= 1".to_owned()));
    }
    let expected = rows
        .checked_mul(cols)
        .ok_or_else(|| XgbError::Input(format!("rows * cols overflows: {rows} * {cols}")))?;
    if x.len() != expected {
        return Err(XgbError::Input(format!(
            "x has {} values but rows * cols = {rows} * {cols} = {expected}",
            x.len()
        )));
    }
    if let Some(i) = x.iter().position(|v| v.is_infinite()) {
        return Err(XgbError::Input(format!(
            "x[row {}, col {}] is {} (use NaN for missing values; infinities are not allowed)",
            i / cols,
            i % cols,
            x[i]
        )));
    }
    Ok(())
}

/// A margin needs one finite log-odds per row.
fn check_margin(margin: &[f32], rows: usize) -> Result<(), XgbError> {
    if margin.len() != rows {
        return Err(XgbError::Input(format!(
            "margin has {} values but there are {rows} rows",
            margin.len()
        )));
    }
    if let Some(i) = margin.iter().position(|v| !v.is_finite()) {
        return Err(XgbError::Input(format!(
            "margin[{i}] is {} (log-odds must be finite)",
            margin[i]
        )));
    }
    Ok(())
}

impl Booster {
    /// Trains a booster on `x` (`rows x cols` row-major f32, NaN = missing) and labels `y`.
    /// `seed` is XGBoost's `seed` (row/column subsampling); it must fit in an `i64`.
    pub fn fit(
        x: &[f32],
        rows: usize,
        cols: usize,
        y: &[bool],
        params: &XgbParams,
        seed: u64,
    ) -> Result<Booster, XgbError> {
        Booster::fit_with_progress(x, rows, cols, y, params, seed, |_, _| {})
    }

    /// [`Booster::fit`], calling `on_round(done, total)` after every boosting round.
    pub fn fit_with_progress(
        x: &[f32],
        rows: usize,
        cols: usize,
        y: &[bool],
        params: &XgbParams,
        seed: u64,
        on_round: impl FnMut(u32, u32),
    ) -> Result<Booster, XgbError> {
        Booster::fit_inner(x, rows, cols, y, None, params, seed, on_round)
    }

    /// [`Booster::fit_with_progress`] starting every row from its own log-odds `margin`
    /// (XGBoost's `base_margin`) instead of `base_score`: the trees learn a correction to
    /// an offset model. Predict with [`Booster::predict_proba_with_margin`] and the new rows'
    /// margins.
    #[allow(clippy::too_many_arguments)] // the data, its offset, the parameters, the seed, progress
    pub fn fit_with_margin(
        x: &[f32],
        rows: usize,
        cols: usize,
        y: &[bool],
        margin: &[f32],
        params: &XgbParams,
        seed: u64,
        on_round: impl FnMut(u32, u32),
    ) -> Result<Booster, XgbError> {
        Booster::fit_inner(x, rows, cols, y, Some(margin), params, seed, on_round)
    }

    #[allow(clippy::too_many_arguments)]
    fn fit_inner(
        x: &[f32],
        rows: usize,
        cols: usize,
        y: &[bool],
        margin: Option<&[f32]>,
        params: &XgbParams,
        seed: u64,
        mut on_round: impl FnMut(u32, u32),
    ) -> Result<Booster, XgbError> {
        let pairs = params.booster_params(seed)?;
        if rows == 0 {
            return Err(XgbError::Input("rows must be >= 1".to_owned()));
        }
        check_matrix(x, rows, cols)?;
        if y.len() != rows {
            return Err(XgbError::Input(format!(
                "y has {} labels but there are {rows} rows",
                y.len()
            )));
        }
        let positives = y.iter().filter(|&&b| b).count();
        if positives == 0 || positives == rows {
            return Err(XgbError::Input(format!(
                "both classes must be present in y ({positives} positive of {rows})"
            )));
        }
        let api = ffi::api()?;
        let mut train = DMatrix::from_dense(api, x, rows, cols)?;
        let labels: Vec<f32> = y.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
        train.set_labels(&labels)?;
        if let Some(margin) = margin {
            check_margin(margin, rows)?;
            train.set_base_margin(margin)?;
        }
        let mut raw = RawBooster::create(api, &[&train])?;
        for (name, value) in &pairs {
            raw.set_param(name, value)?;
        }
        let total = params.n_estimators;
        for round in 0..total {
            let iter = i32::try_from(round).map_err(|_| XgbError::Param {
                key: "n_estimators".to_owned(),
                message: "too large".to_owned(),
            })?;
            raw.update_one_iter(iter, &train)?;
            on_round(round + 1, total);
        }
        // The booster keeps its own reference to the training matrix (as a cache entry);
        // dropping ours here is fine.
        drop(train);
        Ok(Booster {
            raw,
            n_features: cols,
        })
    }

    /// P(y = 1) for every row of `x` (`rows x cols` row-major, NaN = missing). `cols` must
    /// equal the number of features the booster was trained on. Zero rows give an empty
    /// vector.
    pub fn predict_proba(&self, x: &[f32], rows: usize, cols: usize) -> Result<Vec<f64>, XgbError> {
        self.predict_inner(x, rows, cols, None, None)
    }

    /// P(y = 1) of a booster trained by [`Booster::fit_with_margin`]: each row starts from
    /// its `margin` (log-odds). With `rounds`, only the first `rounds` trees are used (the
    /// count early stopping chose); `None` uses them all.
    pub fn predict_proba_with_margin(
        &self,
        x: &[f32],
        rows: usize,
        cols: usize,
        margin: &[f32],
        rounds: Option<u32>,
    ) -> Result<Vec<f64>, XgbError> {
        self.predict_inner(x, rows, cols, Some(margin), rounds)
    }

    fn predict_inner(
        &self,
        x: &[f32],
        rows: usize,
        cols: usize,
        margin: Option<&[f32]>,
        rounds: Option<u32>,
    ) -> Result<Vec<f64>, XgbError> {
        if cols != self.n_features {
            return Err(XgbError::Input(format!(
                "x has {cols} columns but the model was trained on {} features",
                self.n_features
            )));
        }
        check_matrix(x, rows, cols)?;
        if rows == 0 {
            return Ok(Vec::new());
        }
        let api = ffi::api()?;
        if rounds == Some(0) {
            // No trees: the offset alone (XGBoost's iteration_end 0 would mean all of them).
            return match margin {
                Some(margin) => {
                    check_margin(margin, rows)?;
                    Ok(margin
                        .iter()
                        .map(|&m| 1.0 / (1.0 + (-f64::from(m)).exp()))
                        .collect())
                }
                None => Err(XgbError::Input("rounds must be >= 1 without a margin".to_owned())),
            };
        }
        let mut data = DMatrix::from_dense(api, x, rows, cols)?;
        if let Some(margin) = margin {
            check_margin(margin, rows)?;
            data.set_base_margin(margin)?;
        }
        let out = match rounds {
            None => self.raw.predict(&data, PREDICT_CONFIG)?,
            Some(end) => {
                let config = format!(
                    "{{\"type\": 0, \"training\": false, \"iteration_begin\": 0, \"iteration_end\": {end}, \"strict_shape\": false}}"
                );
                let config =
                    std::ffi::CString::new(config).map_err(|_| XgbError::Input("config".to_owned()))?;
                self.raw.predict(&data, &config)?
            }
        };
        if out.len() != rows {
            return Err(XgbError::Api {
                call: "XGBoosterPredictFromDMatrix",
                message: format!("returned {} values for {rows} rows", out.len()),
            });
        }
        Ok(out.into_iter().map(f64::from).collect())
    }

    /// The model in XGBoost's JSON format (`XGBoosterSaveModelToBuffer`, `{"format":
    /// "json"}`): trees, base score, objective and feature count; readable by Python's
    /// `xgboost.Booster(model_file=bytearray(...))`. Training-only parameters such as
    /// `nthread` are not part of the model.
    pub fn save_json(&self) -> Result<Vec<u8>, XgbError> {
        self.raw.save_model(SAVE_JSON_CONFIG)
    }

    /// Loads a model written by [`Booster::save_json`] (or by Python's
    /// `Booster.save_model("m.json")`); predictions are identical to the saved booster's.
    /// The model must be a `binary:logistic` model.
    pub fn load_json(json: &[u8]) -> Result<Booster, XgbError> {
        if json.is_empty() {
            return Err(XgbError::Model("empty model buffer".to_owned()));
        }
        let api = ffi::api()?;
        let mut raw = RawBooster::create(api, &[])?;
        raw.load_model(json)?;
        let booster = Booster { n_features: 0, raw };
        let objective = booster.objective()?;
        if objective != "binary:logistic" {
            return Err(XgbError::Model(format!(
                "objective is `{objective}`, expected `binary:logistic`"
            )));
        }
        let n_features = usize::try_from(booster.raw.num_features()?)
            .map_err(|_| XgbError::Model("feature count overflows usize".to_owned()))?;
        if n_features == 0 {
            return Err(XgbError::Model("the model has no features".to_owned()));
        }
        Ok(Booster {
            n_features,
            ..booster
        })
    }

    /// XGBoost's full internal configuration (`XGBoosterSaveJsonConfig`), e.g. to check
    /// which parameters and `base_score` the learner used.
    pub fn config_json(&self) -> Result<String, XgbError> {
        self.raw.save_config()
    }

    /// The number of features the model expects.
    pub fn num_features(&self) -> usize {
        self.n_features
    }

    /// The number of boosting rounds in the model.
    pub fn num_rounds(&self) -> Result<u32, XgbError> {
        let rounds = self.raw.boosted_rounds()?;
        u32::try_from(rounds).map_err(|_| XgbError::Model(format!("{rounds} boosted rounds")))
    }

    /// The objective recorded in the learner's configuration.
    fn objective(&self) -> Result<String, XgbError> {
        let config = self.config_json()?;
        let value: serde_json::Value = serde_json::from_str(&config)
            .map_err(|e| XgbError::Model(format!("unreadable learner config: {e}")))?;
        value
            .pointer("/learner/objective/name")
            .and_then(serde_json::Value::as_str)
            .map(str::to_owned)
            .ok_or_else(|| XgbError::Model("learner config has no objective name".to_owned()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matrix_checks() {
        assert!(check_matrix(&[1.0; 6], 2, 3).is_ok());
        assert!(check_matrix(&[f32::NAN; 6], 2, 3).is_ok());
        assert!(matches!(check_matrix(&[1.0; 5], 2, 3), Err(XgbError::Input(_))));
        assert!(matches!(check_matrix(&[], 0, 0), Err(XgbError::Input(_))));
        let err = check_matrix(&[1.0, 2.0, f32::INFINITY, 4.0], 2, 2).expect_err("inf");
        assert!(err.to_string().contains("row 1, col 0"), "{err}");
    }

    #[test]
    fn booster_is_send_and_sync() {
        fn assert_send_sync<T: Send + Sync>() {}
        assert_send_sync::<Booster>();
    }
}
