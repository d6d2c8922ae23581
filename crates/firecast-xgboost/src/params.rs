//! Booster parameters: XGBoost's own names and XGBoost 3.x defaults.

use serde::{Deserialize, Serialize};

use crate::XgbError;

/// Training parameters, named as in XGBoost (scikit-learn spellings, with XGBoost's native
/// spellings accepted as aliases: `eta`, `lambda`, `alpha`, `min_split_loss`) and defaulting
/// to XGBoost 3.x's defaults. The seed is not a parameter: it comes from the `fit` call.
///
/// Unknown keys are rejected (`deny_unknown_fields`); [`XgbParams::from_json`] and
/// [`XgbParams::validate`] name the offending key.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct XgbParams {
    /// Boosting rounds (`num_boost_round`). Default 100.
    pub n_estimators: u32,
    /// Maximum tree depth, >= 1. Default 6.
    pub max_depth: u32,
    /// Shrinkage `eta`, > 0. Default 0.3.
    #[serde(alias = "eta")]
    pub learning_rate: f64,
    /// Row subsampling ratio per tree, in (0, 1]. Default 1.0.
    pub subsample: f64,
    /// Column subsampling ratio per tree, in (0, 1]. Default 1.0.
    pub colsample_bytree: f64,
    /// Minimum hessian sum in a child, >= 0. Default 1.0.
    pub min_child_weight: f64,
    /// L2 regularisation (`lambda`), >= 0. Default 1.0.
    #[serde(alias = "lambda")]
    pub reg_lambda: f64,
    /// L1 regularisation (`alpha`), >= 0. Default 0.0.
    #[serde(alias = "alpha")]
    pub reg_alpha: f64,
    /// Minimum loss reduction to split (`min_split_loss`), >= 0. Default 0.0.
    #[serde(alias = "min_split_loss")]
    pub gamma: f64,
    /// `hist` (default), `approx` or `exact`.
    pub tree_method: String,
    /// Histogram bins per feature for `hist`/`approx`, >= 2. Default 256.
    pub max_bin: u32,
    /// Only `binary:logistic` (the default): `predict_proba` returns P(y = 1).
    pub objective: String,
    /// OpenMP threads for training and prediction, >= 1. Default: the number of cores
    /// available to this process. Fix it when results must be reproducible bit for bit
    /// across machines (histogram sums are reduced per thread).
    pub nthread: u32,
}

/// The number of cores available to this process (at least 1).
pub fn available_threads() -> u32 {
    std::thread::available_parallelism()
        .map(|n| u32::try_from(n.get()).unwrap_or(u32::MAX))
        .unwrap_or(1)
}

impl Default for XgbParams {
    fn default() -> Self {
        XgbParams {
            n_estimators: 100,
            max_depth: 6,
            learning_rate: 0.3,
            subsample: 1.0,
            colsample_bytree: 1.0,
            min_child_weight: 1.0,
            reg_lambda: 1.0,
            reg_alpha: 0.0,
            gamma: 0.0,
            tree_method: "hist".to_owned(),
            max_bin: 256,
            objective: "binary:logistic".to_owned(),
            nthread: available_threads(),
        }
    }
}

/// Every accepted key, aliases included.
pub const KEYS: &[&str] = &[
    "n_estimators",
    "max_depth",
    "learning_rate",
    "eta",
    "subsample",
    "colsample_bytree",
    "min_child_weight",
    "reg_lambda",
    "lambda",
    "reg_alpha",
    "alpha",
    "gamma",
    "min_split_loss",
    "tree_method",
    "max_bin",
    "objective",
    "nthread",
];

const TREE_METHODS: &[&str] = &["hist", "approx", "exact"];
const OBJECTIVES: &[&str] = &["binary:logistic"];

fn param_error(key: &str, message: impl Into<String>) -> XgbError {
    XgbError::Param {
        key: key.to_owned(),
        message: message.into(),
    }
}

impl XgbParams {
    /// Parses a JSON object (missing keys take their defaults) and validates it. Errors name
    /// the key: unknown keys, wrong types and out-of-range values alike.
    pub fn from_json(value: &serde_json::Value) -> Result<XgbParams, XgbError> {
        let object = value.as_object().ok_or_else(|| {
            param_error(
                "(params)",
                format!("expected a JSON object of parameters, got {value}"),
            )
        })?;
        if let Some(key) = object.keys().find(|k| !KEYS.contains(&k.as_str())) {
            return Err(param_error(
                key,
                format!("unknown parameter; known: {}", KEYS.join(", ")),
            ));
        }
        let params = match serde_json::from_value::<XgbParams>(value.clone()) {
            Ok(params) => params,
            Err(err) => {
                // Attribute the failure to a key by parsing each one on its own.
                for (key, v) in object {
                    let single = serde_json::Value::Object([(key.clone(), v.clone())].into_iter().collect());
                    if let Err(e) = serde_json::from_value::<XgbParams>(single) {
                        return Err(param_error(key, e.to_string()));
                    }
                }
                return Err(param_error("(params)", err.to_string()));
            }
        };
        params.validate()?;
        Ok(params)
    }

    /// Checks every value's range; the error names the key.
    pub fn validate(&self) -> Result<(), XgbError> {
        if self.n_estimators == 0 || self.n_estimators > i32::MAX as u32 {
            return Err(param_error("n_estimators", "must be in 1..=2147483647"));
        }
        if self.max_depth == 0 {
            return Err(param_error("max_depth", "must be >= 1"));
        }
        finite_at_least("learning_rate", self.learning_rate, 0.0, false)?;
        ratio("subsample", self.subsample)?;
        ratio("colsample_bytree", self.colsample_bytree)?;
        finite_at_least("min_child_weight", self.min_child_weight, 0.0, true)?;
        finite_at_least("reg_lambda", self.reg_lambda, 0.0, true)?;
        finite_at_least("reg_alpha", self.reg_alpha, 0.0, true)?;
        finite_at_least("gamma", self.gamma, 0.0, true)?;
        if !TREE_METHODS.contains(&self.tree_method.as_str()) {
            return Err(param_error(
                "tree_method",
                format!("`{}` is not one of {}", self.tree_method, TREE_METHODS.join(", ")),
            ));
        }
        if self.max_bin < 2 || self.max_bin > i32::MAX as u32 {
            return Err(param_error("max_bin", "must be in 2..=2147483647"));
        }
        if !OBJECTIVES.contains(&self.objective.as_str()) {
            return Err(param_error(
                "objective",
                format!(
                    "`{}` is not supported (only {})",
                    self.objective,
                    OBJECTIVES.join(", ")
                ),
            ));
        }
        if self.nthread == 0 || self.nthread > i32::MAX as u32 {
            return Err(param_error("nthread", "must be in 1..=2147483647"));
        }
        Ok(())
    }

    /// The `(name, value)` strings handed to `XGBoosterSetParam`, in XGBoost's native
    /// names, including `seed`, `nthread` and `validate_parameters`. `n_estimators` is not
    /// among them: it is the number of `XGBoosterUpdateOneIter` rounds. Passing the same
    /// pairs to Python's `xgboost.train(dict(pairs), dtrain, n_estimators)` trains the same
    /// model.
    pub fn booster_params(&self, seed: u64) -> Result<Vec<(String, String)>, XgbError> {
        self.validate()?;
        if seed > i64::MAX as u64 {
            return Err(param_error("seed", "must be <= 9223372036854775807 (int64)"));
        }
        let pairs: [(&str, String); 15] = [
            ("objective", self.objective.clone()),
            ("booster", "gbtree".to_owned()),
            ("tree_method", self.tree_method.clone()),
            ("max_depth", self.max_depth.to_string()),
            ("eta", self.learning_rate.to_string()),
            ("subsample", self.subsample.to_string()),
            ("colsample_bytree", self.colsample_bytree.to_string()),
            ("min_child_weight", self.min_child_weight.to_string()),
            ("lambda", self.reg_lambda.to_string()),
            ("alpha", self.reg_alpha.to_string()),
            ("gamma", self.gamma.to_string()),
            ("max_bin", self.max_bin.to_string()),
            ("nthread", self.nthread.to_string()),
            ("seed", seed.to_string()),
            ("validate_parameters", "1".to_owned()),
        ];
        Ok(pairs.into_iter().map(|(k, v)| (k.to_owned(), v)).collect())
    }
}

fn finite_at_least(key: &str, value: f64, min: f64, inclusive: bool) -> Result<(), XgbError> {
    let ok = value.is_finite() && if inclusive { value >= min } else { value > min };
    if ok {
        Ok(())
    } else {
        let op = if inclusive { ">=" } else { ">" };
        Err(param_error(key, format!("{value} must be finite and {op} {min}")))
    }
}

fn ratio(key: &str, value: f64) -> Result<(), XgbError> {
    if value.is_finite() && value > 0.0 && value <= 1.0 {
        Ok(())
    } else {
        Err(param_error(key, format!("{value} must be in (0, 1]")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn defaults_are_xgboost_3_defaults() {
        let p = XgbParams::from_json(&json!({})).expect("defaults");
        assert_eq!(p.n_estimators, 100);
        assert_eq!(p.max_depth, 6);
        assert_eq!(p.learning_rate, 0.3);
        assert_eq!(p.tree_method, "hist");
        assert_eq!(p.max_bin, 256);
        assert_eq!(p.objective, "binary:logistic");
        assert!(p.nthread >= 1);
    }

    #[test]
    fn aliases_are_accepted() {
        let p = XgbParams::from_json(&json!({"eta": 0.1, "lambda": 2.0, "alpha": 0.5})).expect("aliases");
        assert_eq!((p.learning_rate, p.reg_lambda, p.reg_alpha), (0.1, 2.0, 0.5));
    }

    #[test]
    fn errors_name_the_key() {
        let cases = [
            (json!({"max_dept": 3}), "max_dept"),
            (json!({"max_depth": "six"}), "max_depth"),
            (json!({"subsample": 0.0}), "subsample"),
            (json!({"learning_rate": -1.0}), "learning_rate"),
            (json!({"tree_method": "gpu_hist"}), "tree_method"),
            (json!({"objective": "reg:squarederror"}), "objective"),
            (json!({"nthread": 0}), "nthread"),
            (json!({"max_bin": 1}), "max_bin"),
        ];
        for (value, key) in cases {
            match XgbParams::from_json(&value) {
                Err(XgbError::Param { key: k, .. }) => assert_eq!(k, key, "{value}"),
                other => panic!("{value}: expected a Param error, got {other:?}"),
            }
        }
    }

    #[test]
    fn serde_rejects_unknown_fields_directly() {
        let err = serde_json::from_value::<XgbParams>(json!({"nope": 1})).expect_err("unknown");
        assert!(err.to_string().contains("nope"), "{err}");
    }
}
