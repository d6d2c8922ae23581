//! The one error type of the crate.

use thiserror::Error;

/// Why an evaluation could not be computed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EvalError {
    /// A slice that must pair up with `y` (or with another slice) has a different length.
    #[error("`{argument}` has {found} entries but `{reference}` has {expected}")]
    LengthMismatch {
        /// The argument whose length is wrong, as the function names it.
        argument: &'static str,
        /// The argument it is compared with (usually `y`).
        reference: &'static str,
        /// Length of `reference`.
        expected: usize,
        /// Length of `argument`.
        found: usize,
    },
    /// The function needs at least one sample.
    #[error("no samples to evaluate")]
    Empty,
    /// Scores must be finite (scikit-learn rejects NaN and ±inf too).
    #[error("`{argument}` holds a non-finite value at index {index}")]
    NonFinite {
        /// The argument holding the value.
        argument: &'static str,
        /// Index of the first offending entry.
        index: usize,
    },
    /// A probability outside [0, 1] where only probabilities make sense.
    #[error("`{argument}` holds {value} at index {index}, outside [0, 1]")]
    NotAProbability {
        /// The argument holding the value.
        argument: &'static str,
        /// Index of the first offending entry.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// Too few samples of a class for the statistic (for example DeLong's covariance
    /// needs two of each).
    #[error("needs at least {needed} positives and {needed} negatives, got {positives} and {negatives}")]
    TooFewPerClass {
        /// Minimum per class.
        needed: usize,
        /// Positives found.
        positives: usize,
        /// Negatives found.
        negatives: usize,
    },
    /// A parameter outside its domain.
    #[error("invalid `{argument}`: {reason}")]
    InvalidArgument {
        /// The parameter's name.
        argument: &'static str,
        /// What is wrong with it.
        reason: String,
    },
}

/// `Ok` when `found` has as many entries as `y`.
pub(crate) fn same_len(
    argument: &'static str,
    found: usize,
    reference: &'static str,
    expected: usize,
) -> Result<(), EvalError> {
    if found == expected {
        Ok(())
    } else {
        Err(EvalError::LengthMismatch {
            argument,
            reference,
            expected,
            found,
        })
    }
}

/// `Ok` when every entry of `values` is finite.
pub(crate) fn all_finite(argument: &'static str, values: &[f64]) -> Result<(), EvalError> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(index) => Err(EvalError::NonFinite { argument, index }),
    }
}

/// `Ok` when every entry of `values` lies in [0, 1] (NaN fails).
pub(crate) fn all_probabilities(argument: &'static str, values: &[f64]) -> Result<(), EvalError> {
    match values.iter().position(|v| !(0.0..=1.0).contains(v)) {
        None => Ok(()),
        Some(index) => Err(EvalError::NotAProbability {
            argument,
            index,
            value: values[index],
        }),
    }
}
