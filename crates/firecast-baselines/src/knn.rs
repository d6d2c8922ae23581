//! k-nearest neighbours, as scikit-learn's brute-force `KNeighborsClassifier`.
//!
//! Distances are exact Euclidean distances in `f64`. To stay fast without a BLAS, each
//! query first gets `f32` estimates `‖q‖² + ‖t‖² − 2 q·t` for all training rows (blocked
//! 2×2 dot-product kernel), each with a rigorous rounding-error bound; only rows whose
//! lower bound does not exceed the k-th smallest upper bound can be neighbours, and just
//! those are recomputed exactly. Among exactly equal distances the lower training index
//! comes first, as in scikit-learn's brute-force search (its heap keeps the earlier row
//! on ties).

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::matrix::Matrix;
use crate::spec::KnnWeights;

/// A fitted KNN model: the training rows themselves.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Knn {
    pub k: usize,
    pub weights: KnnWeights,
    pub train: Matrix,
    /// Training labels as a string of `0`/`1`.
    #[serde(with = "bits")]
    pub labels: Vec<bool>,
}

mod bits {
    use serde::de::Error as _;
    use serde::{Deserialize, Deserializer, Serializer};

    pub(crate) fn serialize<S: Serializer>(v: &[bool], s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&v.iter().map(|&b| if b { '1' } else { '0' }).collect::<String>())
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<bool>, D::Error> {
        String::deserialize(d)?
            .chars()
            .map(|c| match c {
                '0' => Ok(false),
                '1' => Ok(true),
                other => Err(D::Error::custom(format!("label {other:?} is not 0 or 1"))),
            })
            .collect()
    }
}

/// Queries per parallel block and training rows per cache tile.
const QUERY_BLOCK: usize = 64;
const TRAIN_TILE: usize = 64;
/// Accumulator lanes of the `f32` dot products (the error bound depends on it).
const LANES: usize = 8;

/// Dot products of two query rows with two training rows, in `f32` with 8 lanes. The
/// rows are zero-padded to a multiple of 8 so the loop has no tail: any dynamically
/// indexed tail makes the compiler keep the accumulators in memory. Out of line, since
/// inlined into the block loop it vectorises worse.
#[inline(never)]
fn dot2x2(q: [&[f32]; 2], t: [&[f32]; 2]) -> [[f32; 2]; 2] {
    let mut acc = [[[0.0f32; LANES]; 2]; 2];
    let lane = |v: &[f32], c: usize| -> [f32; LANES] {
        let mut a = [0.0f32; LANES];
        a.copy_from_slice(&v[c * LANES..(c + 1) * LANES]);
        a
    };
    for c in 0..q[0].len() / LANES {
        let xs = [lane(q[0], c), lane(q[1], c)];
        let ys = [lane(t[0], c), lane(t[1], c)];
        for a in 0..2 {
            for b in 0..2 {
                for l in 0..LANES {
                    acc[a][b][l] += xs[a][l] * ys[b][l];
                }
            }
        }
    }
    acc.map(|r| r.map(|v| ((v[0] + v[4]) + (v[2] + v[6])) + ((v[1] + v[5]) + (v[3] + v[7]))))
}

/// `rows` rows of `m` (by index) copied and zero-padded to `width` columns.
fn padded(m: &Matrix, rows: impl Iterator<Item = usize>, width: usize) -> Vec<f32> {
    let mut out = Vec::new();
    for r in rows {
        out.extend_from_slice(m.row(r));
        out.resize(out.len() + width - m.cols, 0.0);
    }
    out
}

/// Exact squared distance in `f64`.
#[inline]
fn exact_sq(a: &[f32], b: &[f32]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| {
            let t = f64::from(x) - f64::from(y);
            t * t
        })
        .sum()
}

fn sq_norm(a: &[f32]) -> f64 {
    a.iter().map(|&v| f64::from(v) * f64::from(v)).sum()
}

impl Knn {
    /// P(class 1) per row: the (weighted) fraction of positive neighbours.
    pub fn predict_proba(&self, x: &Matrix) -> Vec<f64> {
        let (nt, d) = (self.train.rows, self.train.cols);
        let tn: Vec<f64> = (0..nt).map(|i| sq_norm(self.train.row(i))).collect();
        let tnorm: Vec<f64> = tn.iter().map(|v| v.sqrt()).collect();
        // |fl(q·t) − q·t| ≤ (terms per lane + 3 tree levels + 1 product) · u · Σ|qᵢtᵢ|,
        // doubled for second-order terms; Σ|qᵢtᵢ| ≤ ‖q‖‖t‖.
        let width = d.div_ceil(LANES) * LANES;
        // Padding zeros add exact zeros, so the bound counts padded terms per lane.
        let gamma = 2.0 * (width / LANES + 4) as f64 * f64::from(f32::EPSILON) / 2.0;
        let train = padded(&self.train, 0..nt, width);
        let trow = |i: usize| &train[i * width..(i + 1) * width];
        // Products below f32's normal range lose up to one subnormal ulp each.
        let underflow = 2.0 * d as f64 * 1.5e-45;
        let rows: Vec<usize> = (0..x.rows).collect();
        rows.par_chunks(QUERY_BLOCK)
            .flat_map_iter(|block| {
                let qb = block.len();
                let queries = padded(x, block.iter().copied(), width);
                let qrow = |i: usize| &queries[i * width..(i + 1) * width];
                let mut dots = vec![0.0f32; qb * nt];
                for t0 in (0..nt).step_by(TRAIN_TILE) {
                    let t1 = (t0 + TRAIN_TILE).min(nt);
                    for qi in (0..qb).step_by(2) {
                        let qj = (qi + 1).min(qb - 1);
                        let q = [qrow(qi), qrow(qj)];
                        for ti in (t0..t1).step_by(2) {
                            let tj = (ti + 1).min(t1 - 1);
                            let [[r00, r01], [r10, r11]] = dot2x2(q, [trow(ti), trow(tj)]);
                            dots[qi * nt + ti] = r00;
                            dots[qi * nt + tj] = r01;
                            dots[qj * nt + ti] = r10;
                            dots[qj * nt + tj] = r11;
                        }
                    }
                }
                let mut upper = Vec::with_capacity(nt);
                let mut cand: Vec<(f64, usize)> = Vec::new();
                let out: Vec<f64> = (0..qb)
                    .map(|qi| {
                        let q = x.row(block[qi]);
                        let qn = sq_norm(q);
                        let qnorm = qn.sqrt();
                        let row = &dots[qi * nt..(qi + 1) * nt];
                        // An overflowed estimate (|x| ≳ 1e19) bounds nothing: always a candidate.
                        let bound = |i: usize| {
                            if row[i].is_finite() {
                                2.0 * gamma * qnorm * tnorm[i] + 1e-12 * (qn + tn[i]) + underflow
                            } else {
                                f64::INFINITY
                            }
                        };
                        let approx = |i: usize| qn + tn[i] - 2.0 * f64::from(row[i]);
                        upper.clear();
                        upper.extend((0..nt).map(|i| {
                            let b = bound(i);
                            if b.is_finite() {
                                approx(i) + b
                            } else {
                                f64::INFINITY
                            }
                        }));
                        let k = self.k.min(nt);
                        let (_, kth, _) = upper.select_nth_unstable_by(k - 1, |a, b| a.total_cmp(b));
                        let cut = *kth;
                        cand.clear();
                        cand.extend(
                            (0..nt)
                                .filter(|&i| {
                                    let b = bound(i);
                                    !b.is_finite() || approx(i) - b <= cut
                                })
                                .map(|i| (exact_sq(q, self.train.row(i)), i)),
                        );
                        cand.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                        self.vote(&cand[..k])
                    })
                    .collect();
                out.into_iter()
            })
            .collect()
    }

    /// The class-1 share of the neighbours' votes.
    fn vote(&self, neighbours: &[(f64, usize)]) -> f64 {
        match self.weights {
            KnnWeights::Uniform => {
                let pos = neighbours.iter().filter(|&&(_, i)| self.labels[i]).count();
                pos as f64 / neighbours.len() as f64
            }
            KnnWeights::Distance => {
                // Exact matches take the whole vote, as scikit-learn's inf handling does.
                let exact = neighbours.iter().any(|&(d, _)| d == 0.0);
                let (mut pos, mut all) = (0.0, 0.0);
                for &(d, i) in neighbours {
                    let w = if exact {
                        f64::from(u8::from(d == 0.0))
                    } else {
                        1.0 / d.sqrt()
                    };
                    all += w;
                    if self.labels[i] {
                        pos += w;
                    }
                }
                pos / all
            }
        }
    }

    pub fn validate(&self) -> Result<(), String> {
        self.train.check_shape().map_err(|e| e.to_string())?;
        if self.labels.len() != self.train.rows || self.k == 0 || self.k > self.train.rows {
            return Err(format!(
                "knn with {} labels, {} rows and k = {}",
                self.labels.len(),
                self.train.rows,
                self.k
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use rand::{Rng, SeedableRng};

    fn knn(train: Matrix, labels: Vec<bool>, k: usize) -> Knn {
        Knn {
            k,
            weights: KnnWeights::Uniform,
            train,
            labels,
        }
    }

    #[test]
    fn equal_distances_prefer_the_lower_training_index() {
        // Query 0 is at distance 1 from rows 0..4; with k = 2 rows 0 and 1 vote.
        let train = Matrix::from_rows(&[[1.0f32, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]).unwrap();
        let q = Matrix::from_rows(&[[0.0f32, 0.0]]).unwrap();
        let m = knn(train.clone(), vec![true, false, true, true], 2);
        assert_eq!(m.predict_proba(&q), vec![0.5]);
        let m = knn(train, vec![false, false, true, true], 3);
        assert_eq!(m.predict_proba(&q), vec![1.0 / 3.0]);
    }

    #[test]
    fn matches_brute_force_on_random_data() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let (nt, nq, d) = (157, 67, 37);
        let train = Matrix::new(
            nt,
            d,
            (0..nt * d).map(|_| rng.random::<f32>() * 4.0 - 2.0).collect(),
        )
        .unwrap();
        let q = Matrix::new(
            nq,
            d,
            (0..nq * d).map(|_| rng.random::<f32>() * 4.0 - 2.0).collect(),
        )
        .unwrap();
        let labels: Vec<bool> = (0..nt).map(|_| rng.random()).collect();
        for weights in [KnnWeights::Uniform, KnnWeights::Distance] {
            let m = Knn {
                k: 7,
                weights,
                train: train.clone(),
                labels: labels.clone(),
            };
            let fast = m.predict_proba(&q);
            for (r, p) in fast.iter().enumerate() {
                let mut all: Vec<(f64, usize)> =
                    (0..nt).map(|i| (exact_sq(q.row(r), train.row(i)), i)).collect();
                all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                assert_eq!(*p, m.vote(&all[..7]));
            }
        }
    }

    #[test]
    fn huge_values_still_find_the_true_neighbours() {
        // q·t overflows f32 for every row; the exact pass must still rank them.
        let train = Matrix::from_rows(&[[3e19f32, 3e19], [1e20, 1e20], [3.1e19, 3e19]]).unwrap();
        let m = knn(train, vec![false, true, false], 2);
        let q = Matrix::from_rows(&[[1e20f32, 0.99e20]]).unwrap();
        assert_eq!(m.predict_proba(&q), vec![0.5]);
    }

    #[test]
    fn distance_weights_give_exact_matches_the_vote() {
        let train = Matrix::from_rows(&[[0.0f32], [1.0], [3.0]]).unwrap();
        let mut m = knn(train, vec![true, false, false], 3);
        m.weights = KnnWeights::Distance;
        assert_eq!(
            m.predict_proba(&Matrix::from_rows(&[[0.0f32]]).unwrap()),
            vec![1.0]
        );
        let p = m.predict_proba(&Matrix::from_rows(&[[2.0f32]]).unwrap())[0];
        let expect = 0.5 / (0.5 + 1.0 + 1.0);
        assert!((p - expect).abs() < 1e-15);
    }
}
