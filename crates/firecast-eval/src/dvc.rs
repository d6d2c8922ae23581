//! Plot data in the shape DVCLive's `log_sklearn_plot` writes, for `dvc plots`.
//!
//! JSON has no infinity or NaN; Python's `json.dump` writes the non-standard tokens
//! `Infinity` and `NaN`. Here such a value becomes the *string* `"Infinity"`,
//! `"-Infinity"` or `"NaN"` (see [`json_number`]), which keeps the file valid JSON and
//! still reads as the same token — the ROC curve's first threshold is `"Infinity"`.

use serde_json::{Value, json};

use crate::error::{EvalError, all_finite, same_len};
use crate::metrics::{BinStrategy, CalibrationCurve, PrPoint, RocPoint};

/// A JSON number, or for a non-finite value the string `"Infinity"`, `"-Infinity"` or
/// `"NaN"`.
pub fn json_number(x: f64) -> Value {
    match serde_json::Number::from_f64(x) {
        Some(n) => Value::Number(n),
        None if x.is_nan() => Value::String("NaN".into()),
        None if x > 0.0 => Value::String("Infinity".into()),
        None => Value::String("-Infinity".into()),
    }
}

/// Serde adapter for an `f64` field that may be infinite: written as [`json_number`]
/// writes it, read back from a number or one of the three strings.
pub mod serde_non_finite {
    use serde::{Deserialize, Deserializer, Serializer};

    /// Finite values as numbers, others as `"Infinity"`, `"-Infinity"`, `"NaN"`.
    pub fn serialize<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
        if x.is_finite() {
            s.serialize_f64(*x)
        } else if x.is_nan() {
            s.serialize_str("NaN")
        } else if *x > 0.0 {
            s.serialize_str("Infinity")
        } else {
            s.serialize_str("-Infinity")
        }
    }

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Repr {
        Number(f64),
        Text(String),
    }

    /// Accepts a number or `"Infinity"`, `"-Infinity"`, `"NaN"` (also `"inf"`, `"-inf"`, `"nan"`).
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        match Repr::deserialize(d)? {
            Repr::Number(x) => Ok(x),
            Repr::Text(t) => match t.as_str() {
                "Infinity" | "inf" => Ok(f64::INFINITY),
                "-Infinity" | "-inf" => Ok(f64::NEG_INFINITY),
                "NaN" | "nan" => Ok(f64::NAN),
                other => Err(serde::de::Error::custom(format!("not a number: {other:?}"))),
            },
        }
    }
}

/// `{"roc": [{"fpr", "tpr", "threshold"}, …]}`, one entry per point of
/// [`crate::metrics::roc_curve`].
pub fn roc_plot(points: &[RocPoint]) -> Value {
    let rows: Vec<Value> = points
        .iter()
        .map(|pt| json!({"fpr": json_number(pt.fpr), "tpr": json_number(pt.tpr), "threshold": json_number(pt.threshold)}))
        .collect();
    json!({ "roc": rows })
}

/// `{"precision_recall": [{"precision", "recall", "threshold"}, …]}`. Like DVCLive, which
/// zips sklearn's n + 1 precisions with its n thresholds, the final threshold-less point
/// (precision 1, recall 0) is left out.
pub fn precision_recall_plot(points: &[PrPoint]) -> Value {
    let rows: Vec<Value> = points
        .iter()
        .filter_map(|pt| {
            pt.threshold.map(|t| {
                json!({"precision": json_number(pt.precision), "recall": json_number(pt.recall), "threshold": json_number(t)})
            })
        })
        .collect();
    json!({ "precision_recall": rows })
}

/// `{"calibration": [{"prob_true", "prob_pred"}, …]}`, one entry per non-empty bin.
pub fn calibration_plot(curve: &CalibrationCurve) -> Value {
    let rows: Vec<Value> = curve
        .prob_true
        .iter()
        .zip(&curve.prob_pred)
        .map(|(&t, &p)| json!({"prob_true": json_number(t), "prob_pred": json_number(p)}))
        .collect();
    json!({ "calibration": rows })
}

/// `[{"actual": "1", "predicted": "0"}, …]`, one row per sample, labels as the strings
/// `"0"`/`"1"` (DVCLive writes `str(label)` of integer labels). Predicted 1 ⇔
/// `p > threshold`. An error names `p` when its length differs from `y`'s.
pub fn confusion_plot(y: &[bool], p: &[f64], threshold: f64) -> Result<Value, EvalError> {
    same_len("p", p.len(), "y", y.len())?;
    let label = |b: bool| if b { "1" } else { "0" };
    Ok(Value::Array(
        y.iter()
            .zip(p)
            .map(|(&actual, &q)| json!({"actual": label(actual), "predicted": label(q > threshold)}))
            .collect(),
    ))
}

/// ROC plot data straight from labels and scores (DVCLive `log_sklearn_plot("roc", …)`).
pub fn roc(y: &[bool], p: &[f64]) -> Result<Value, EvalError> {
    Ok(roc_plot(&crate::metrics::roc_curve(y, p)?))
}

/// Precision–recall plot data from labels and scores
/// (DVCLive `log_sklearn_plot("precision_recall", …)`).
pub fn precision_recall(y: &[bool], p: &[f64]) -> Result<Value, EvalError> {
    Ok(precision_recall_plot(&crate::metrics::precision_recall_curve(
        y, p,
    )?))
}

/// Calibration plot data from labels and probabilities
/// (DVCLive `log_sklearn_plot("calibration", …, n_bins=…, strategy=…)`).
pub fn calibration(y: &[bool], p: &[f64], n_bins: usize, strategy: BinStrategy) -> Result<Value, EvalError> {
    Ok(calibration_plot(&crate::metrics::calibration_curve(
        y, p, n_bins, strategy,
    )?))
}

/// Confusion plot data from labels and scores; also checks the scores are finite.
pub fn confusion(y: &[bool], p: &[f64], threshold: f64) -> Result<Value, EvalError> {
    all_finite("p", p)?;
    confusion_plot(y, p, threshold)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn roc_threshold_infinity_is_a_string_and_round_trips() {
        let v = roc(&[false, true, true], &[0.1, 0.8, 0.4]).unwrap();
        let rows = v["roc"].as_array().unwrap();
        assert_eq!(rows[0]["threshold"], "Infinity");
        assert_eq!(rows[0]["fpr"], 0.0);
        assert_eq!(rows.last().unwrap()["tpr"], 1.0);
        let pts = crate::metrics::roc_curve(&[false, true], &[0.1, 0.8]).unwrap();
        let text = serde_json::to_string(&pts).unwrap();
        assert!(text.contains("\"Infinity\""));
        let back: Vec<RocPoint> = serde_json::from_str(&text).unwrap();
        assert_eq!(back, pts);
    }

    #[test]
    fn pr_plot_drops_the_threshold_less_point() {
        let y = [false, true, true, false];
        let p = [0.1, 0.8, 0.4, 0.35];
        let pts = crate::metrics::precision_recall_curve(&y, &p).unwrap();
        let v = precision_recall(&y, &p).unwrap();
        assert_eq!(v["precision_recall"].as_array().unwrap().len(), pts.len() - 1);
    }

    #[test]
    fn confusion_rows_are_strings_with_strict_threshold() {
        let v = confusion(&[true, false, true], &[0.5, 0.7, 0.9], 0.5).unwrap();
        assert_eq!(
            v,
            json!([
                {"actual": "1", "predicted": "0"},
                {"actual": "0", "predicted": "1"},
                {"actual": "1", "predicted": "1"}
            ])
        );
        assert!(matches!(
            confusion(&[true], &[0.1, 0.2], 0.5),
            Err(EvalError::LengthMismatch { .. })
        ));
    }

    #[test]
    fn calibration_rows() {
        let v = calibration(
            &[false, true, true, false],
            &[0.0, 0.5, 1.0, 0.2],
            2,
            BinStrategy::Uniform,
        )
        .unwrap();
        let rows = v["calibration"].as_array().unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1]["prob_true"], 1.0);
    }
}
