//! The crate's one error type.

/// Everything that can go wrong between Rust and `libxgboost.so`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum XgbError {
    /// `libxgboost.so` could not be found, opened, or lacks a symbol this crate needs.
    /// The message says what was searched and how to fix it.
    #[error("{0}")]
    Library(String),
    /// A C API call returned non-zero; `message` is `XGBGetLastError()` right after it.
    #[error("XGBoost {call} failed: {message}")]
    Api {
        /// The C function that failed, e.g. `XGBoosterUpdateOneIter`.
        call: &'static str,
        /// XGBoost's own error text.
        message: String,
    },
    /// A parameter is unknown, has the wrong type, or is out of range.
    #[error("invalid XGBoost parameter `{key}`: {message}")]
    Param {
        /// The parameter's key as written in the configuration.
        key: String,
        /// What is wrong with it.
        message: String,
    },
    /// The data handed to `fit`/`predict_proba` is malformed (checked in Rust before any C call).
    #[error("invalid input: {0}")]
    Input(String),
    /// A model artifact could not be used (e.g. not a `binary:logistic` model).
    #[error("invalid XGBoost model: {0}")]
    Model(String),
}
