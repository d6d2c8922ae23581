//! NumPy's floating-point recipes, reproduced operation for operation so that sums,
//! means, bin edges and percentiles round exactly as scikit-learn's do.

/// NumPy's block size for pairwise summation (`PW_BLOCKSIZE`).
const PW_BLOCKSIZE: usize = 128;

/// `np.sum` of a contiguous float64 array: NumPy's pairwise summation (eight running
/// sums inside blocks of at most 128, blocks halved recursively). Bit-identical to NumPy.
pub(crate) fn pairwise_sum(a: &[f64]) -> f64 {
    let n = a.len();
    if n < 8 {
        let mut res = 0.0;
        for &x in a {
            res += x;
        }
        res
    } else if n <= PW_BLOCKSIZE {
        let mut r = [0.0f64; 8];
        r.copy_from_slice(&a[..8]);
        let mut i = 8;
        while i < n - (n % 8) {
            for (j, acc) in r.iter_mut().enumerate() {
                *acc += a[i + j];
            }
            i += 8;
        }
        let mut res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for &x in &a[i..] {
            res += x;
        }
        res
    } else {
        let mut n2 = n / 2;
        n2 -= n2 % 8;
        pairwise_sum(&a[..n2]) + pairwise_sum(&a[n2..])
    }
}

/// `np.mean` of a float64 array (NaN when empty).
pub(crate) fn mean(a: &[f64]) -> f64 {
    if a.is_empty() {
        return f64::NAN;
    }
    pairwise_sum(a) / a.len() as f64
}

/// `np.linspace(0, 1, n_bins + 1)`: `i * (1 / n_bins)`, the last edge set to exactly 1.
pub(crate) fn unit_edges(n_bins: usize) -> Vec<f64> {
    let step = 1.0 / n_bins as f64;
    let mut edges: Vec<f64> = (0..=n_bins).map(|i| i as f64 * step + 0.0).collect();
    if let Some(last) = edges.last_mut() {
        *last = 1.0;
    }
    edges
}

/// NumPy's `_lerp`: interpolates from the nearer end so the result stays within [a, b].
fn lerp(a: f64, b: f64, t: f64) -> f64 {
    let diff = b - a;
    if t >= 0.5 {
        b - diff * (1.0 - t)
    } else {
        a + diff * t
    }
}

/// `np.quantile(values, q)` with the default `linear` method, for `sorted` in ascending
/// order and `q` in [0, 1]. NaN when `sorted` is empty.
pub(crate) fn quantile_sorted(sorted: &[f64], q: f64) -> f64 {
    let n = sorted.len();
    if n == 0 {
        return f64::NAN;
    }
    let virtual_index = (n - 1) as f64 * q;
    if virtual_index >= (n - 1) as f64 {
        return sorted[n - 1];
    }
    if virtual_index < 0.0 {
        return sorted[0];
    }
    let previous = virtual_index.floor();
    let lo = previous as usize;
    lerp(sorted[lo], sorted[lo + 1], virtual_index - previous)
}

/// `np.searchsorted(edges, x, side="left")`: how many edges lie strictly below `x`.
pub(crate) fn searchsorted_left(edges: &[f64], x: f64) -> usize {
    edges.partition_point(|&e| e < x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairwise_sum_small_and_blocked() {
        assert_eq!(pairwise_sum(&[]), 0.0);
        assert_eq!(pairwise_sum(&[1.0, 2.0, 3.0]), 6.0);
        let v: Vec<f64> = (1..=1000).map(f64::from).collect();
        assert_eq!(pairwise_sum(&v), 500_500.0);
    }

    #[test]
    fn edges_end_exactly_at_one() {
        let e = unit_edges(10);
        assert_eq!(e.len(), 11);
        assert_eq!(e[0], 0.0);
        assert_eq!(e[10], 1.0);
        // 3 * 0.1 rounds to 0.30000000000000004, as in NumPy.
        assert_eq!(e[3], 3.0 * 0.1);
    }

    #[test]
    fn quantile_matches_numpy_linear() {
        let s = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(quantile_sorted(&s, 0.0), 1.0);
        assert_eq!(quantile_sorted(&s, 1.0), 4.0);
        assert_eq!(quantile_sorted(&s, 0.5), 2.5);
        assert!((quantile_sorted(&s, 0.25) - 1.75).abs() < 1e-15);
        assert_eq!(quantile_sorted(&[7.0], 0.3), 7.0);
        assert!(quantile_sorted(&[], 0.3).is_nan());
    }

    #[test]
    fn searchsorted_is_left_sided() {
        let e = [0.25, 0.5, 0.5, 0.75];
        assert_eq!(searchsorted_left(&e, 0.5), 1);
        assert_eq!(searchsorted_left(&e, 0.0), 0);
        assert_eq!(searchsorted_left(&e, 0.6), 3);
        assert_eq!(searchsorted_left(&e, 1.0), 4);
    }
}
