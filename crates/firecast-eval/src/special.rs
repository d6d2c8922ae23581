//! Special functions for the tests' p-values, written out so the crate needs no
//! numerical library: W. J. Cody's rational Chebyshev approximations of `erfc`
//! (Math. Comp. 23, 1969; the coefficients of Netlib SPECFUN `CALERF`), relative error
//! near 1e-16 over the whole range, and the normal and χ²(1) tails built on it.

// Cody's coefficients are kept with the digits he published.
#![allow(clippy::excessive_precision, clippy::unreadable_literal)]

/// erf on [0, 0.46875]: numerator.
const A: [f64; 5] = [
    3.16112374387056560e00,
    1.13864154151050156e02,
    3.77485237685302021e02,
    3.20937758913846947e03,
    1.85777706184603153e-1,
];
/// erf on [0, 0.46875]: denominator.
const B: [f64; 4] = [
    2.36012909523441209e01,
    2.44024637934444173e02,
    1.28261652607737228e03,
    2.84423683343917062e03,
];
/// erfc on (0.46875, 4]: numerator.
const C: [f64; 9] = [
    5.64188496988670089e-1,
    8.88314979438837594e00,
    6.61191906371416295e01,
    2.98635138197400131e02,
    8.81952221241769090e02,
    1.71204761263407058e03,
    2.05107837782607147e03,
    1.23033935479799725e03,
    2.15311535474403846e-8,
];
/// erfc on (0.46875, 4]: denominator.
const D: [f64; 8] = [
    1.57449261107098347e01,
    1.17693950891312499e02,
    5.37181101862009858e02,
    1.62138957456669019e03,
    3.29079923573345963e03,
    4.36261909014324716e03,
    3.43936767414372164e03,
    1.23033935480374942e03,
];
/// erfc on (4, ∞): numerator of the asymptotic correction.
const P: [f64; 6] = [
    3.05326634961232344e-1,
    3.60344899949804439e-1,
    1.25781726111229246e-1,
    1.60837851487422766e-2,
    6.58749161529837803e-4,
    1.63153871373020978e-2,
];
/// erfc on (4, ∞): denominator of the asymptotic correction.
const Q: [f64; 5] = [
    2.56852019228982242e00,
    1.87295284992346047e00,
    5.27905102951428412e-1,
    6.05183413124413191e-2,
    2.33520497626869185e-3,
];
/// 1/√π.
const SQRPI: f64 = 5.6418958354775628695e-1;
/// Below this, x² is negligible next to 1.
const XSMALL: f64 = 1.11e-16;
/// Above this, erfc(x) underflows to 0.
const XBIG: f64 = 26.543;

/// exp(−y²) without losing the bits that y² loses: split y = ysq + (y − ysq) with ysq a
/// multiple of 1/16, as Cody does.
fn exp_neg_square(y: f64) -> f64 {
    let ysq = (y * 16.0).trunc() / 16.0;
    let del = (y - ysq) * (y + ysq);
    (-ysq * ysq).exp() * (-del).exp()
}

/// Complementary error function erfc(x) = 1 − erf(x).
pub fn erfc(x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    let y = x.abs();
    if y <= 0.46875 {
        let ysq = if y > XSMALL { y * y } else { 0.0 };
        let mut xnum = A[4] * ysq;
        let mut xden = ysq;
        for i in 0..3 {
            xnum = (xnum + A[i]) * ysq;
            xden = (xden + B[i]) * ysq;
        }
        return 1.0 - x * (xnum + A[3]) / (xden + B[3]);
    }
    let tail = if y <= 4.0 {
        let mut xnum = C[8] * y;
        let mut xden = y;
        for i in 0..7 {
            xnum = (xnum + C[i]) * y;
            xden = (xden + D[i]) * y;
        }
        exp_neg_square(y) * ((xnum + C[7]) / (xden + D[7]))
    } else if y < XBIG {
        let ysq = 1.0 / (y * y);
        let mut xnum = P[5] * ysq;
        let mut xden = ysq;
        for i in 0..4 {
            xnum = (xnum + P[i]) * ysq;
            xden = (xden + Q[i]) * ysq;
        }
        let r = ysq * (xnum + P[4]) / (xden + Q[4]);
        exp_neg_square(y) * ((SQRPI - r) / y)
    } else {
        0.0
    };
    if x < 0.0 { 2.0 - tail } else { tail }
}

/// Standard normal survival function P(Z > z) = erfc(z/√2)/2.
pub fn normal_sf(z: f64) -> f64 {
    0.5 * erfc(z / std::f64::consts::SQRT_2)
}

/// Standard normal distribution function P(Z ≤ z) = erfc(−z/√2)/2.
pub fn normal_cdf(z: f64) -> f64 {
    0.5 * erfc(-z / std::f64::consts::SQRT_2)
}

/// Survival function of χ² with one degree of freedom: P(X > x) = erfc(√(x/2)).
/// 1 for x ≤ 0.
pub fn chi2_sf_1df(x: f64) -> f64 {
    if x <= 0.0 { 1.0 } else { erfc((x / 2.0).sqrt()) }
}

/// Two-sided exact binomial test of k successes in n trials against p = 1/2, as
/// `scipy.stats.binomtest(k, n, 0.5).pvalue`: min(1, 2·P(X ≤ min(k, n−k))). By exact
/// integer summation, so `n` is limited to 62 (None above, or when k > n).
pub fn binomial_two_sided_half(k: u64, n: u64) -> Option<f64> {
    if k > n || n > 62 {
        return None;
    }
    if n == 0 {
        return Some(1.0);
    }
    let tail_k = k.min(n - k);
    // C(n, i) for i ≤ tail_k ≤ 31 fits easily; the sum stays below 2^62.
    let mut coef: u64 = 1;
    let mut sum: u64 = 1;
    for i in 1..=tail_k {
        coef = coef * (n - i + 1) / i;
        sum += coef;
    }
    // sum / 2^n, doubled: both powers of two, so exact up to the final rounding.
    let p = sum as f64 * 2.0 / 2f64.powi(n as i32);
    Some(p.min(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erfc_known_values() {
        // Values from mpmath at 30 digits.
        let cases = [
            (0.0, 1.0),
            (0.5, 0.479_500_122_186_953_462_317_253_346_108),
            (1.0, 0.157_299_207_050_285_130_658_779_364_917),
            (2.0, 0.004_677_734_981_047_265_837_930_743_632_747),
            (-1.0, 1.842_700_792_949_714_869_341_220_635_08),
            (5.0, 1.537_459_794_428_034_850_188_343_485_383e-12),
        ];
        for (x, want) in cases {
            let got = erfc(x);
            assert!(
                ((got - want) / want).abs() < 1e-14,
                "erfc({x}) = {got}, want {want}"
            );
        }
        assert_eq!(erfc(30.0), 0.0);
        assert_eq!(erfc(-30.0), 2.0);
    }

    #[test]
    fn chi2_and_normal_tails() {
        // P(χ²₁ > 3.841458820694124) = 0.05.
        assert!((chi2_sf_1df(3.841_458_820_694_124) - 0.05).abs() < 1e-15);
        assert!((normal_sf(1.959_963_984_540_054) - 0.025).abs() < 1e-15);
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-16);
        assert_eq!(chi2_sf_1df(0.0), 1.0);
    }

    #[test]
    fn exact_binomial() {
        // scipy.stats.binomtest(3, 10).pvalue = 0.34375; (5, 10) = 1.
        assert_eq!(binomial_two_sided_half(3, 10), Some(0.34375));
        assert_eq!(binomial_two_sided_half(7, 10), Some(0.34375));
        assert_eq!(binomial_two_sided_half(5, 10), Some(1.0));
        assert_eq!(binomial_two_sided_half(0, 1), Some(1.0));
        assert_eq!(binomial_two_sided_half(0, 5), Some(0.0625));
        assert_eq!(binomial_two_sided_half(0, 0), Some(1.0));
        assert_eq!(binomial_two_sided_half(3, 2), None);
    }
}
