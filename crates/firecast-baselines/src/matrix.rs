//! Dense row-major feature matrices and scikit-learn's `StandardScaler`.

use serde::{Deserialize, Serialize};

use crate::codec;
use crate::error::BaselineError;

/// A dense row-major `rows × cols` matrix of `f32` features (one sample per row).
///
/// The fields are public for cheap construction and destructuring; every function of
/// this crate re-checks `data.len() == rows × cols` and returns
/// [`BaselineError::Shape`] otherwise. Serialised as `{rows, cols, data}` with `data` the
/// base64 of the little-endian `f32`s (exact and compact).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawMatrix", into = "RawMatrix")]
pub struct Matrix {
    /// Number of samples.
    pub rows: usize,
    /// Number of features.
    pub cols: usize,
    /// `rows × cols` values, row after row.
    pub data: Vec<f32>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMatrix {
    rows: usize,
    cols: usize,
    #[serde(with = "codec::b64")]
    data: Vec<f32>,
}

impl TryFrom<RawMatrix> for Matrix {
    type Error = BaselineError;
    fn try_from(m: RawMatrix) -> Result<Self, Self::Error> {
        Matrix::new(m.rows, m.cols, m.data)
    }
}

impl From<Matrix> for RawMatrix {
    fn from(m: Matrix) -> Self {
        RawMatrix {
            rows: m.rows,
            cols: m.cols,
            data: m.data,
        }
    }
}

impl Matrix {
    /// A matrix from row-major data; an error unless `data.len() == rows × cols`.
    pub fn new(rows: usize, cols: usize, data: Vec<f32>) -> Result<Self, BaselineError> {
        let m = Matrix { rows, cols, data };
        m.check_shape()?;
        Ok(m)
    }

    /// A matrix with no rows and `cols` columns.
    pub fn empty(cols: usize) -> Self {
        Matrix {
            rows: 0,
            cols,
            data: Vec::new(),
        }
    }

    /// A matrix from equally long rows; an error naming the first row of another length.
    pub fn from_rows<R: AsRef<[f32]>>(rows: &[R]) -> Result<Self, BaselineError> {
        let cols = rows.first().map_or(0, |r| r.as_ref().len());
        let mut data = Vec::with_capacity(rows.len() * cols);
        for (i, r) in rows.iter().enumerate() {
            let r = r.as_ref();
            if r.len() != cols {
                return Err(BaselineError::Shape {
                    rows: i + 1,
                    cols,
                    expected: (i + 1) * cols,
                    got: data.len() + r.len(),
                });
            }
            data.extend_from_slice(r);
        }
        Matrix::new(rows.len(), cols, data)
    }

    /// Row `i` as a slice of `cols` values. Panics when `i >= rows`, like slice indexing.
    pub fn row(&self, i: usize) -> &[f32] {
        &self.data[i * self.cols..(i + 1) * self.cols]
    }

    /// `Err(Shape)` unless `data.len() == rows × cols`.
    pub fn check_shape(&self) -> Result<(), BaselineError> {
        let expected = self.rows.checked_mul(self.cols);
        if expected != Some(self.data.len()) {
            return Err(BaselineError::Shape {
                rows: self.rows,
                cols: self.cols,
                expected: expected.unwrap_or(usize::MAX),
                got: self.data.len(),
            });
        }
        Ok(())
    }

    /// `Err(NonFinite)` naming the first NaN or ±inf (row-major order).
    pub fn check_finite(&self, what: &'static str) -> Result<(), BaselineError> {
        if let Some(pos) = self.data.iter().position(|v| !v.is_finite()) {
            let cols = self.cols.max(1);
            return Err(BaselineError::NonFinite {
                what,
                row: pos / cols,
                col: pos % cols,
                value: self.data[pos],
            });
        }
        Ok(())
    }

    /// Shape, then finiteness.
    pub(crate) fn check(&self, what: &'static str) -> Result<(), BaselineError> {
        self.check_shape()?;
        self.check_finite(what)
    }

    /// Column-major copy (`cols` contiguous columns of `rows` values): tree builders read
    /// one feature of many samples at a time, which is cache-friendly only in this layout.
    pub(crate) fn columns(&self) -> Vec<f32> {
        let (n, d) = (self.rows, self.cols);
        let mut out = vec![0.0f32; n * d];
        // Blocked transpose: 64 rows at a time keeps both sides in cache.
        for r0 in (0..n).step_by(64) {
            let r1 = (r0 + 64).min(n);
            for c in 0..d {
                for (r, v) in out[c * n + r0..c * n + r1].iter_mut().enumerate() {
                    *v = self.data[(r0 + r) * d + c];
                }
            }
        }
        out
    }
}

/// scikit-learn's `StandardScaler` (with_mean, with_std): per-column mean and population
/// standard deviation fitted on the training rows.
///
/// The statistics are computed the way scikit-learn 1.9 computes them for `float32`
/// input: float64 column sums in row order, the corrected two-pass variance
/// `(Σ(x−m)² − (Σ(x−m))²/n) / n`, and a scale of 1 for columns its
/// `_is_constant_feature` test flags (variance within rounding of zero). `transform`
/// then works in `f32` exactly like `X -= mean_.astype(f32); X /= scale_.astype(f32)`,
/// so the output is bit-identical to scikit-learn's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Standardizer {
    /// Column means (`mean_`).
    #[serde(with = "codec::exact_vec")]
    pub mean: Vec<f64>,
    /// Column scales (`scale_`): the standard deviation, or 1 for constant columns.
    #[serde(with = "codec::exact_vec")]
    pub scale: Vec<f64>,
}

impl Standardizer {
    /// Fits the means and scales on `x` (no rows, NaN or inf: an error).
    pub fn fit(x: &Matrix) -> Result<Self, BaselineError> {
        x.check("x")?;
        if x.rows == 0 {
            return Err(BaselineError::EmptyTrainingSet);
        }
        let (n, d) = (x.rows, x.cols);
        let nf = n as f64;
        let mut sum = vec![0.0f64; d];
        for r in 0..n {
            for (s, &v) in sum.iter_mut().zip(x.row(r)) {
                *s += f64::from(v);
            }
        }
        let mean: Vec<f64> = sum.iter().map(|s| s / nf).collect();
        let mut correction = vec![0.0f64; d];
        let mut sq = vec![0.0f64; d];
        for r in 0..n {
            for (j, &v) in x.row(r).iter().enumerate() {
                let t = f64::from(v) - mean[j];
                correction[j] += t;
                sq[j] += t * t;
            }
        }
        let eps = f64::EPSILON;
        let scale = (0..d)
            .map(|j| {
                let var = (sq[j] - correction[j] * correction[j] / nf) / nf;
                let bound = nf * eps * var + (nf * mean[j] * eps).powi(2);
                if var <= bound { 1.0 } else { var.sqrt() }
            })
            .collect();
        Ok(Standardizer { mean, scale })
    }

    /// Number of columns this scaler was fitted on.
    pub fn feature_count(&self) -> usize {
        self.mean.len()
    }

    /// `(x − mean) / scale`, column by column, in `f32` as scikit-learn does.
    pub fn transform(&self, x: &Matrix) -> Result<Matrix, BaselineError> {
        x.check("x")?;
        if x.cols != self.mean.len() || self.scale.len() != self.mean.len() {
            return Err(BaselineError::FeatureCount {
                expected: self.mean.len(),
                got: x.cols,
            });
        }
        let mean: Vec<f32> = self.mean.iter().map(|&m| m as f32).collect();
        let scale: Vec<f32> = self.scale.iter().map(|&s| s as f32).collect();
        let mut data = x.data.clone();
        for row in data.chunks_exact_mut(x.cols.max(1)) {
            for ((v, m), s) in row.iter_mut().zip(&mean).zip(&scale) {
                *v = (*v - m) / s;
            }
        }
        Matrix::new(x.rows, x.cols, data)
    }

    /// `fit` then `transform` on the same rows.
    pub fn fit_transform(x: &Matrix) -> Result<(Self, Matrix), BaselineError> {
        let s = Standardizer::fit(x)?;
        let t = s.transform(x)?;
        Ok((s, t))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn new_checks_length_and_row_slices() {
        assert!(matches!(
            Matrix::new(2, 3, vec![0.0; 5]),
            Err(BaselineError::Shape {
                expected: 6,
                got: 5,
                ..
            })
        ));
        let m = Matrix::new(2, 3, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        assert_eq!(m.row(1), &[4.0, 5.0, 6.0]);
        assert_eq!(m.columns(), vec![1.0, 4.0, 2.0, 5.0, 3.0, 6.0]);
        assert!(Matrix::from_rows(&[vec![1.0f32, 2.0], vec![3.0]]).is_err());
    }

    #[test]
    fn non_finite_names_row_and_column() {
        let m = Matrix::new(2, 3, vec![1.0, 2.0, 3.0, 4.0, f32::NAN, 6.0]).unwrap();
        let e = m.check_finite("x").unwrap_err();
        assert!(
            matches!(e, BaselineError::NonFinite { row: 1, col: 1, .. }),
            "{e}"
        );
        assert!(e.to_string().contains("row 1, column 1"), "{e}");
    }

    #[test]
    fn standardizer_matches_population_std_and_constant_columns() {
        let m = Matrix::from_rows(&[[1.0f32, 5.0], [3.0, 5.0]]).unwrap();
        let (s, t) = Standardizer::fit_transform(&m).unwrap();
        assert_eq!(s.mean, vec![2.0, 5.0]);
        assert_eq!(s.scale, vec![1.0, 1.0]);
        assert_eq!(t.data, vec![-1.0, 0.0, 1.0, 0.0]);
        let wide = Matrix::new(1, 3, vec![0.0; 3]).unwrap();
        assert!(matches!(
            s.transform(&wide),
            Err(BaselineError::FeatureCount { expected: 2, got: 3 })
        ));
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(serde_json::from_str::<Standardizer>(&json).unwrap(), s);
    }

    #[test]
    fn matrix_serde_round_trips_and_validates() {
        let m = Matrix::new(2, 2, vec![0.1, -3.5e-8, f32::MAX, 7.0]).unwrap();
        let json = serde_json::to_string(&m).unwrap();
        assert_eq!(serde_json::from_str::<Matrix>(&json).unwrap(), m);
        let bad = json.replace("\"rows\":2", "\"rows\":3");
        assert!(serde_json::from_str::<Matrix>(&bad).is_err());
    }
}
