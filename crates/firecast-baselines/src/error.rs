//! The one error type of this crate.

/// Why a fit, a prediction or a spec was refused.
#[derive(Debug, thiserror::Error)]
pub enum BaselineError {
    /// `data.len()` does not equal `rows × cols`.
    #[error("matrix data holds {got} values but rows × cols = {rows} × {cols} = {expected}")]
    Shape {
        /// Declared rows.
        rows: usize,
        /// Declared columns.
        cols: usize,
        /// `rows × cols`.
        expected: usize,
        /// Actual `data.len()`.
        got: usize,
    },
    /// The training matrix has no rows.
    #[error("empty training set: x has no rows")]
    EmptyTrainingSet,
    /// The training matrix has no columns.
    #[error("x has no feature columns")]
    NoFeatures,
    /// `y` and `x` disagree on the number of samples.
    #[error("y holds {got} labels but x has {expected} rows")]
    LabelCount {
        /// Rows of x.
        expected: usize,
        /// Length of y.
        got: usize,
    },
    /// Every label is the same class, so there is nothing to discriminate.
    #[error("y holds a single class (every label is {class}); a classifier needs both classes")]
    SingleClass {
        /// The only class present.
        class: bool,
    },
    /// Prediction input (or a transform input) with a different width than the fit.
    #[error("wrong number of features: the model was fitted on {expected} columns, got {got}")]
    FeatureCount {
        /// Columns seen at fit time.
        expected: usize,
        /// Columns of the offending matrix.
        got: usize,
    },
    /// NaN or ±inf in an input matrix.
    #[error("non-finite value {value} in {what} at row {row}, column {col}")]
    NonFinite {
        /// Which input: `x`, `x (predict)`, ...
        what: &'static str,
        /// Row index (0-based).
        row: usize,
        /// Column index (0-based).
        col: usize,
        /// The value itself (NaN, inf or -inf).
        value: f32,
    },
    /// A hyper-parameter outside its valid range.
    #[error("invalid hyper-parameter: {key} must be {requirement}, got {got}")]
    InvalidParam {
        /// The hyper-parameter's key, as spelled in the spec (e.g. `n_estimators`).
        key: &'static str,
        /// What it must be (e.g. `≥ 1`).
        requirement: String,
        /// The offending value.
        got: String,
    },
    /// A spec that names an unknown model, an unknown key or a wrongly typed value.
    #[error("invalid baseline spec: {0}")]
    Spec(String),
    /// A model that fails its own consistency checks after loading.
    #[error("corrupt fitted model: {0}")]
    Corrupt(String),
    /// Fitting hit a numerical dead end (e.g. a zero variance with `var_smoothing = 0`).
    #[error("{0}")]
    Numerical(String),
    /// JSON (de)serialisation of a fitted model failed.
    #[error("fitted-model JSON: {0}")]
    Json(#[from] serde_json::Error),
}

impl BaselineError {
    /// Shorthand for [`BaselineError::InvalidParam`].
    pub(crate) fn param(key: &'static str, requirement: impl Into<String>, got: impl ToString) -> Self {
        BaselineError::InvalidParam {
            key,
            requirement: requirement.into(),
            got: got.to_string(),
        }
    }
}
