//! Which baseline to fit, with scikit-learn's hyper-parameter names and defaults.

use std::fmt;

use serde::de::{self, Deserializer, Visitor};
use serde::{Deserialize, Serialize, Serializer};

use crate::error::BaselineError;

/// A baseline and its hyper-parameters, as in the pipeline spec:
/// `{model: random_forest, n_estimators: 300}`. Every params struct rejects unknown keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum BaselineSpec {
    /// `sklearn.linear_model.LogisticRegression` (lbfgs, L2).
    LogisticRegression(LogisticRegressionParams),
    /// `sklearn.naive_bayes.GaussianNB`.
    GaussianNb(GaussianNbParams),
    /// `sklearn.tree.DecisionTreeClassifier` (splitter best).
    DecisionTree(DecisionTreeParams),
    /// `sklearn.ensemble.RandomForestClassifier`.
    RandomForest(RandomForestParams),
    /// `sklearn.ensemble.GradientBoostingClassifier` (log-loss).
    GradientBoosting(GradientBoostingParams),
    /// `sklearn.neighbors.KNeighborsClassifier` (Euclidean, brute force).
    Knn(KnnParams),
}

/// The model names [`BaselineSpec::from_kind`] accepts.
pub const KINDS: [&str; 6] = [
    "logistic_regression",
    "gaussian_nb",
    "decision_tree",
    "random_forest",
    "gradient_boosting",
    "knn",
];

/// `LogisticRegression(C, max_iter, tol, fit_intercept)` with the lbfgs solver and an L2
/// penalty. The objective is scikit-learn's: `C · Σ log-loss + ½‖w‖²` (intercept not
/// penalised), minimised on the features as given (standardise them first).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LogisticRegressionParams {
    /// Inverse regularisation strength `C` (> 0). Default 1.0.
    #[serde(alias = "C")]
    pub c: f64,
    /// Maximum L-BFGS iterations (≥ 0). Default 100.
    pub max_iter: usize,
    /// Stop when the largest gradient component of the mean-loss objective is ≤ `tol`
    /// (scipy's `gtol`, as scikit-learn passes it). Default 1e-4.
    pub tol: f64,
    /// Fit an unpenalised intercept. Default true.
    pub fit_intercept: bool,
}

impl Default for LogisticRegressionParams {
    fn default() -> Self {
        LogisticRegressionParams {
            c: 1.0,
            max_iter: 100,
            tol: 1e-4,
            fit_intercept: true,
        }
    }
}

/// `GaussianNB(var_smoothing)`; class priors from the class frequencies.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GaussianNbParams {
    /// Added to every variance, as a fraction of the largest feature variance. Default 1e-9.
    pub var_smoothing: f64,
}

impl Default for GaussianNbParams {
    fn default() -> Self {
        GaussianNbParams { var_smoothing: 1e-9 }
    }
}

/// Split quality for classification trees. Only scikit-learn's default, Gini, exists here.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SplitCriterion {
    /// Gini impurity `1 − Σ p_k²`.
    #[default]
    Gini,
}

/// How many features a tree examines per split, as scikit-learn's `max_features`.
///
/// Serialised as scikit-learn writes it: `null` (all), `"sqrt"`, `"log2"`, an integer
/// count, or a float fraction in (0, 1] (so `1` means one feature and `1.0` all of them).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MaxFeatures {
    /// Every feature (`None`).
    All,
    /// `max(1, ⌊√n_features⌋)`.
    Sqrt,
    /// `max(1, ⌊log₂ n_features⌋)`.
    Log2,
    /// Exactly this many (1 ≤ count ≤ n_features).
    Count(usize),
    /// `max(1, ⌊fraction · n_features⌋)`, fraction in (0, 1].
    Fraction(f64),
}

impl MaxFeatures {
    /// The number of features per split for `n_features` columns (scikit-learn's rule).
    pub fn resolve(self, n_features: usize) -> Result<usize, BaselineError> {
        let n = n_features as f64;
        let k = match self {
            MaxFeatures::All => n_features,
            MaxFeatures::Sqrt => (n.sqrt() as usize).max(1),
            MaxFeatures::Log2 => (n.log2() as usize).max(1),
            MaxFeatures::Count(c) => {
                if c == 0 || c > n_features {
                    return Err(BaselineError::param(
                        "max_features",
                        format!("in [1, n_features = {n_features}]"),
                        c,
                    ));
                }
                c
            }
            MaxFeatures::Fraction(f) => ((f * n) as usize).max(1),
        };
        Ok(k.min(n_features).max(1))
    }

    fn validate(self) -> Result<(), BaselineError> {
        match self {
            MaxFeatures::Count(0) => Err(BaselineError::param("max_features", "≥ 1", 0)),
            MaxFeatures::Fraction(f) if !(f > 0.0 && f <= 1.0) => {
                Err(BaselineError::param("max_features", "a fraction in (0, 1]", f))
            }
            _ => Ok(()),
        }
    }
}

impl Serialize for MaxFeatures {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match *self {
            MaxFeatures::All => s.serialize_none(),
            MaxFeatures::Sqrt => s.serialize_str("sqrt"),
            MaxFeatures::Log2 => s.serialize_str("log2"),
            MaxFeatures::Count(c) => s.serialize_u64(c as u64),
            MaxFeatures::Fraction(f) => s.serialize_f64(f),
        }
    }
}

impl<'de> Deserialize<'de> for MaxFeatures {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = MaxFeatures;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("null, \"sqrt\", \"log2\", a positive integer or a fraction in (0, 1]")
            }
            fn visit_unit<E: de::Error>(self) -> Result<MaxFeatures, E> {
                Ok(MaxFeatures::All)
            }
            fn visit_none<E: de::Error>(self) -> Result<MaxFeatures, E> {
                Ok(MaxFeatures::All)
            }
            fn visit_some<D2: Deserializer<'de>>(self, d: D2) -> Result<MaxFeatures, D2::Error> {
                d.deserialize_any(V)
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<MaxFeatures, E> {
                match v {
                    "sqrt" => Ok(MaxFeatures::Sqrt),
                    "log2" => Ok(MaxFeatures::Log2),
                    _ => Err(E::invalid_value(de::Unexpected::Str(v), &self)),
                }
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<MaxFeatures, E> {
                Ok(MaxFeatures::Count(v as usize))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<MaxFeatures, E> {
                usize::try_from(v)
                    .map(MaxFeatures::Count)
                    .map_err(|_| E::invalid_value(de::Unexpected::Signed(v), &self))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<MaxFeatures, E> {
                Ok(MaxFeatures::Fraction(v))
            }
        }
        d.deserialize_any(V)
    }
}

/// `DecisionTreeClassifier(criterion="gini", splitter="best", ...)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DecisionTreeParams {
    /// Split quality. Default gini.
    pub criterion: SplitCriterion,
    /// Maximum depth (`null`: grow until pure or too small). Default null.
    pub max_depth: Option<usize>,
    /// A node with fewer samples is a leaf (≥ 2). Default 2.
    pub min_samples_split: usize,
    /// Every leaf keeps at least this many samples (≥ 1). Default 1.
    pub min_samples_leaf: usize,
    /// Features examined per split. Default null (all).
    pub max_features: MaxFeatures,
}

impl Default for DecisionTreeParams {
    fn default() -> Self {
        DecisionTreeParams {
            criterion: SplitCriterion::Gini,
            max_depth: None,
            min_samples_split: 2,
            min_samples_leaf: 1,
            max_features: MaxFeatures::All,
        }
    }
}

/// `RandomForestClassifier(n_estimators, max_features="sqrt", bootstrap, ...)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RandomForestParams {
    /// Number of trees (≥ 1). Default 100.
    pub n_estimators: usize,
    /// Split quality. Default gini.
    pub criterion: SplitCriterion,
    /// Maximum depth (`null`: unlimited). Default null.
    pub max_depth: Option<usize>,
    /// A node with fewer (distinct in-bag) samples is a leaf (≥ 2). Default 2.
    pub min_samples_split: usize,
    /// Every leaf keeps at least this many distinct in-bag samples (≥ 1). Default 1.
    pub min_samples_leaf: usize,
    /// Features examined per split. Default "sqrt".
    pub max_features: MaxFeatures,
    /// Each tree sees a bootstrap sample of n rows drawn with replacement. Default true.
    pub bootstrap: bool,
}

impl Default for RandomForestParams {
    fn default() -> Self {
        RandomForestParams {
            n_estimators: 100,
            criterion: SplitCriterion::Gini,
            max_depth: None,
            min_samples_split: 2,
            min_samples_leaf: 1,
            max_features: MaxFeatures::Sqrt,
            bootstrap: true,
        }
    }
}

/// `GradientBoostingClassifier(loss="log_loss", ...)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GradientBoostingParams {
    /// Boosting stages (≥ 1). Default 100.
    pub n_estimators: usize,
    /// Shrinkage of every tree (≥ 0). Default 0.1.
    pub learning_rate: f64,
    /// Depth of the regression trees (`null`: unlimited). Default 3.
    pub max_depth: Option<usize>,
    /// A node with fewer samples is a leaf (≥ 2). Default 2.
    pub min_samples_split: usize,
    /// Every leaf keeps at least this many samples (≥ 1). Default 1.
    pub min_samples_leaf: usize,
    /// Fraction of rows drawn without replacement for each stage, in (0, 1]. Default 1.0.
    pub subsample: f64,
    /// Features examined per split. Default null (all).
    pub max_features: MaxFeatures,
}

impl Default for GradientBoostingParams {
    fn default() -> Self {
        GradientBoostingParams {
            n_estimators: 100,
            learning_rate: 0.1,
            max_depth: Some(3),
            min_samples_split: 2,
            min_samples_leaf: 1,
            subsample: 1.0,
            max_features: MaxFeatures::All,
        }
    }
}

/// How neighbours vote.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KnnWeights {
    /// Every neighbour counts once.
    #[default]
    Uniform,
    /// Neighbours count `1 / distance`; exact matches (distance 0) take the whole vote.
    Distance,
}

/// `KNeighborsClassifier(n_neighbors, weights, algorithm="brute", metric="euclidean")`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KnnParams {
    /// Neighbours per query (≥ 1, ≤ training rows). Default 5.
    pub n_neighbors: usize,
    /// Vote weights. Default uniform.
    pub weights: KnnWeights,
}

impl Default for KnnParams {
    fn default() -> Self {
        KnnParams {
            n_neighbors: 5,
            weights: KnnWeights::Uniform,
        }
    }
}

fn check_tree(
    max_depth: Option<usize>,
    min_samples_split: usize,
    min_samples_leaf: usize,
    max_features: MaxFeatures,
) -> Result<(), BaselineError> {
    if max_depth == Some(0) {
        return Err(BaselineError::param("max_depth", "≥ 1 or null", 0));
    }
    if min_samples_split < 2 {
        return Err(BaselineError::param(
            "min_samples_split",
            "≥ 2",
            min_samples_split,
        ));
    }
    if min_samples_leaf < 1 {
        return Err(BaselineError::param("min_samples_leaf", "≥ 1", min_samples_leaf));
    }
    max_features.validate()
}

impl BaselineSpec {
    /// The spec for model `kind` (one of [`KINDS`]) from its params object (`null` or
    /// `{}`: all defaults). An unknown kind, an unknown key or an invalid value is an
    /// error naming it.
    pub fn from_kind(kind: &str, params: &serde_json::Value) -> Result<Self, BaselineError> {
        fn parse<T: serde::de::DeserializeOwned>(
            kind: &str,
            v: &serde_json::Value,
        ) -> Result<T, BaselineError> {
            let v = if v.is_null() {
                serde_json::Value::Object(Default::default())
            } else {
                v.clone()
            };
            serde_json::from_value(v.clone()).map_err(|e| {
                // Every field has a default, so the key whose value alone fails is the culprit.
                let culprit = v.as_object().and_then(|m| {
                    m.iter().find_map(|(k, val)| {
                        let one = serde_json::Value::Object([(k.clone(), val.clone())].into_iter().collect());
                        serde_json::from_value::<T>(one).is_err().then(|| k.clone())
                    })
                });
                match culprit {
                    Some(key) => BaselineError::Spec(format!("{kind}.{key}: {e}")),
                    None => BaselineError::Spec(format!("{kind}: {e}")),
                }
            })
        }
        let spec = match kind {
            "logistic_regression" => BaselineSpec::LogisticRegression(parse(kind, params)?),
            "gaussian_nb" => BaselineSpec::GaussianNb(parse(kind, params)?),
            "decision_tree" => BaselineSpec::DecisionTree(parse(kind, params)?),
            "random_forest" => BaselineSpec::RandomForest(parse(kind, params)?),
            "gradient_boosting" => BaselineSpec::GradientBoosting(parse(kind, params)?),
            "knn" => BaselineSpec::Knn(parse(kind, params)?),
            other => {
                return Err(BaselineError::Spec(format!(
                    "unknown model `{other}`, expected one of {}",
                    KINDS.join(", ")
                )));
            }
        };
        spec.validate()?;
        Ok(spec)
    }

    /// The spec from JSON with a `model` tag, e.g. `{"model": "knn", "n_neighbors": 7}`;
    /// validated like [`BaselineSpec::from_kind`].
    pub fn from_json(text: &str) -> Result<Self, BaselineError> {
        let spec: BaselineSpec =
            serde_json::from_str(text).map_err(|e| BaselineError::Spec(e.to_string()))?;
        spec.validate()?;
        Ok(spec)
    }

    /// The model's name in specs (`random_forest`, ...).
    pub fn kind(&self) -> &'static str {
        match self {
            BaselineSpec::LogisticRegression(_) => KINDS[0],
            BaselineSpec::GaussianNb(_) => KINDS[1],
            BaselineSpec::DecisionTree(_) => KINDS[2],
            BaselineSpec::RandomForest(_) => KINDS[3],
            BaselineSpec::GradientBoosting(_) => KINDS[4],
            BaselineSpec::Knn(_) => KINDS[5],
        }
    }

    /// The scikit-learn class this baseline reproduces.
    pub fn sklearn_class(&self) -> &'static str {
        match self {
            BaselineSpec::LogisticRegression(_) => "sklearn.linear_model.LogisticRegression",
            BaselineSpec::GaussianNb(_) => "sklearn.naive_bayes.GaussianNB",
            BaselineSpec::DecisionTree(_) => "sklearn.tree.DecisionTreeClassifier",
            BaselineSpec::RandomForest(_) => "sklearn.ensemble.RandomForestClassifier",
            BaselineSpec::GradientBoosting(_) => "sklearn.ensemble.GradientBoostingClassifier",
            BaselineSpec::Knn(_) => "sklearn.neighbors.KNeighborsClassifier",
        }
    }

    /// Whether the paper's protocol standardises the features first (the scale-sensitive
    /// models: logistic regression and KNN).
    pub fn wants_standardized(&self) -> bool {
        matches!(self, BaselineSpec::LogisticRegression(_) | BaselineSpec::Knn(_))
    }

    /// Whether [`crate::fit`] reports progress more than once (per iteration or tree).
    pub fn is_iterative(&self) -> bool {
        matches!(
            self,
            BaselineSpec::LogisticRegression(_)
                | BaselineSpec::RandomForest(_)
                | BaselineSpec::GradientBoosting(_)
        )
    }

    /// Range checks of every hyper-parameter; the error names the key.
    pub fn validate(&self) -> Result<(), BaselineError> {
        match self {
            BaselineSpec::LogisticRegression(p) => {
                if !(p.c > 0.0 && p.c.is_finite()) {
                    return Err(BaselineError::param("c", "> 0 and finite", p.c));
                }
                if !(p.tol >= 0.0 && p.tol.is_finite()) {
                    return Err(BaselineError::param("tol", "≥ 0 and finite", p.tol));
                }
            }
            BaselineSpec::GaussianNb(p) => {
                if !(p.var_smoothing >= 0.0 && p.var_smoothing.is_finite()) {
                    return Err(BaselineError::param(
                        "var_smoothing",
                        "≥ 0 and finite",
                        p.var_smoothing,
                    ));
                }
            }
            BaselineSpec::DecisionTree(p) => {
                check_tree(
                    p.max_depth,
                    p.min_samples_split,
                    p.min_samples_leaf,
                    p.max_features,
                )?;
            }
            BaselineSpec::RandomForest(p) => {
                if p.n_estimators < 1 {
                    return Err(BaselineError::param("n_estimators", "≥ 1", p.n_estimators));
                }
                check_tree(
                    p.max_depth,
                    p.min_samples_split,
                    p.min_samples_leaf,
                    p.max_features,
                )?;
            }
            BaselineSpec::GradientBoosting(p) => {
                if p.n_estimators < 1 {
                    return Err(BaselineError::param("n_estimators", "≥ 1", p.n_estimators));
                }
                if !(p.learning_rate >= 0.0 && p.learning_rate.is_finite()) {
                    return Err(BaselineError::param(
                        "learning_rate",
                        "≥ 0 and finite",
                        p.learning_rate,
                    ));
                }
                if !(p.subsample > 0.0 && p.subsample <= 1.0) {
                    return Err(BaselineError::param("subsample", "in (0, 1]", p.subsample));
                }
                check_tree(
                    p.max_depth,
                    p.min_samples_split,
                    p.min_samples_leaf,
                    p.max_features,
                )?;
            }
            BaselineSpec::Knn(p) => {
                if p.n_neighbors < 1 {
                    return Err(BaselineError::param("n_neighbors", "≥ 1", p.n_neighbors));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use serde_json::json;

    #[test]
    fn defaults_are_sklearns() {
        let rf = BaselineSpec::from_kind("random_forest", &json!({})).unwrap();
        let BaselineSpec::RandomForest(p) = rf else {
            panic!()
        };
        assert_eq!(p.n_estimators, 100);
        assert_eq!(p.max_features, MaxFeatures::Sqrt);
        assert!(p.bootstrap);
        let gb = BaselineSpec::from_kind("gradient_boosting", &serde_json::Value::Null).unwrap();
        assert_eq!(
            gb,
            BaselineSpec::GradientBoosting(GradientBoostingParams::default())
        );
        let lr = BaselineSpec::from_json(r#"{"model": "logistic_regression", "C": 0.5}"#).unwrap();
        let BaselineSpec::LogisticRegression(p) = lr else {
            panic!()
        };
        assert_eq!((p.c, p.max_iter, p.tol, p.fit_intercept), (0.5, 100, 1e-4, true));
    }

    #[test]
    fn unknown_key_and_model_are_named() {
        let e = BaselineSpec::from_kind("knn", &json!({"n_neighbours": 3})).unwrap_err();
        assert!(e.to_string().contains("n_neighbours"), "{e}");
        let e = BaselineSpec::from_json(r#"{"model": "random_forest", "n_trees": 3}"#).unwrap_err();
        assert!(e.to_string().contains("n_trees"), "{e}");
        let e = BaselineSpec::from_kind("svm", &json!({})).unwrap_err();
        assert!(e.to_string().contains("svm"), "{e}");
        let e = BaselineSpec::from_kind("decision_tree", &json!({"max_depth": 3, "min_samples_leaf": 0.5}))
            .unwrap_err();
        assert!(e.to_string().contains("decision_tree.min_samples_leaf"), "{e}");
        let e = BaselineSpec::from_json(r#"{"n_neighbors": 3}"#).unwrap_err();
        assert!(e.to_string().contains("`model`"), "{e}");
    }

    #[test]
    fn invalid_values_name_the_key() {
        let e = BaselineSpec::from_kind("random_forest", &json!({"n_estimators": 0})).unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid hyper-parameter: n_estimators must be ≥ 1, got 0"
        );
        for (kind, params, key) in [
            ("logistic_regression", json!({"c": 0.0}), "c must"),
            (
                "gaussian_nb",
                json!({"var_smoothing": -1.0}),
                "var_smoothing must",
            ),
            (
                "decision_tree",
                json!({"min_samples_split": 1}),
                "min_samples_split must",
            ),
            ("decision_tree", json!({"max_depth": 0}), "max_depth must"),
            ("random_forest", json!({"max_features": 1.5}), "max_features must"),
            ("gradient_boosting", json!({"subsample": 0.0}), "subsample must"),
            ("knn", json!({"n_neighbors": 0}), "n_neighbors must"),
        ] {
            let e = BaselineSpec::from_kind(kind, &params).unwrap_err();
            assert!(e.to_string().contains(key), "{kind}: {e}");
        }
    }

    #[test]
    fn max_features_forms() {
        let p: DecisionTreeParams = serde_json::from_value(json!({"max_features": "log2"})).unwrap();
        assert_eq!(p.max_features, MaxFeatures::Log2);
        let p: DecisionTreeParams = serde_json::from_value(json!({"max_features": 3})).unwrap();
        assert_eq!(p.max_features, MaxFeatures::Count(3));
        let p: DecisionTreeParams = serde_json::from_value(json!({"max_features": 0.5})).unwrap();
        assert_eq!(p.max_features, MaxFeatures::Fraction(0.5));
        let p: RandomForestParams = serde_json::from_value(json!({"max_features": null})).unwrap();
        assert_eq!(p.max_features, MaxFeatures::All);
        assert!(serde_json::from_value::<DecisionTreeParams>(json!({"max_features": "cube"})).is_err());
        assert_eq!(MaxFeatures::Sqrt.resolve(1125).unwrap(), 33);
        assert_eq!(MaxFeatures::Log2.resolve(1125).unwrap(), 10);
        assert_eq!(MaxFeatures::Fraction(0.1).resolve(15).unwrap(), 1);
        assert!(MaxFeatures::Count(16).resolve(15).is_err());
        let spec = BaselineSpec::RandomForest(RandomForestParams::default());
        let text = serde_json::to_string(&spec).unwrap();
        assert_eq!(BaselineSpec::from_json(&text).unwrap(), spec);
    }
}
