//! Counter-based random numbers and smooth random fields.
//!
//! Every random number of the generator is a pure function of `(seed, stream, coordinates)`:
//! a SplitMix64-style hash, never a sequential generator shared between threads. That is what
//! makes the output independent of rayon's scheduling, and makes a sub-box of CONUS see the
//! same weather as the same cells of a full CONUS run.

use std::f64::consts::TAU;

/// Independent random streams (the second hash key).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u64)]
pub(crate) enum Stream {
    Elevation = 1,
    Human = 2,
    PrecipShift = 3,
    Towns = 4,
    TempSyn = 10,
    TempReg = 11,
    PrecSyn = 12,
    PrecReg = 13,
    Convective = 14,
    WindU = 15,
    WindV = 16,
    WindSpeed = 17,
    Drought = 18,
    CellNoiseA = 30,
    CellNoiseB = 31,
    Ignition = 40,
    IgnitionDetail = 41,
    /// The landscape of a place (`place.rs`): relief finer than the GRIDMET grid, cover
    /// patchiness, settlement patches.
    TerrainDetail = 50,
    CoverPatch = 51,
    Settlement = 52,
}

const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;

/// The SplitMix64 finaliser (Stafford variant 13): a bijective 64-bit mixer.
#[inline]
pub(crate) fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A key for `(seed, stream, a)`; combine further coordinates with [`hash_with`].
#[inline]
pub(crate) fn key(seed: u64, stream: Stream, a: i64) -> u64 {
    mix64(mix64(seed ^ (stream as u64).wrapping_mul(GOLDEN)) ^ (a as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93))
}

/// Hash of a key and one more coordinate.
#[inline]
pub(crate) fn hash_with(key: u64, b: u64) -> u64 {
    mix64(key.wrapping_add(b.wrapping_mul(GOLDEN)))
}

/// Uniform in `[0, 1)` from the top 53 bits.
#[inline]
pub(crate) fn unit(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Uniform in `(0, 1)` (never 0).
#[inline]
pub(crate) fn unit_open(h: u64) -> f64 {
    ((h >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64)
}

/// A standard normal deviate (Box–Muller on two halves of the hash chain).
#[inline]
pub(crate) fn normal(h: u64) -> f64 {
    let u1 = unit_open(h);
    let u2 = unit(mix64(h ^ GOLDEN));
    (-2.0 * u1.ln()).sqrt() * (TAU * u2).cos()
}

/// Two cheap zero-mean, unit-variance triangular deviates from one hash (fine-scale noise).
#[inline]
pub(crate) fn triangular_pair(h: u64) -> (f32, f32) {
    const S: f32 = 1.0 / 65536.0;
    let a = (h & 0xFFFF) as f32 * S;
    let b = ((h >> 16) & 0xFFFF) as f32 * S;
    let c = ((h >> 32) & 0xFFFF) as f32 * S;
    let d = (h >> 48) as f32 * S;
    // The sum of two U(0,1) has variance 1/6.
    let k = 6f32.sqrt();
    ((a + b - 1.0) * k, (c + d - 1.0) * k)
}

/// Smoothstep interpolation weight.
#[inline]
fn fade(t: f64) -> f64 {
    t * t * (3.0 - 2.0 * t)
}

/// Interpolation coordinates of one grid index on a lattice of spacing `step` cells:
/// `(node offset from the first node kept, weight of the next node, variance normaliser)`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Axis {
    pub node: u32,
    pub w: f32,
    pub norm: f32,
}

impl Axis {
    /// Axis coordinates for global index `g`, relative to lattice node `first`.
    pub fn new(g: usize, step: usize, first: usize) -> Self {
        let a = g / step;
        let t = fade((g % step) as f64 / step as f64);
        // Two independent unit-variance nodes mixed with weights (1-t, t) have variance
        // (1-t)^2 + t^2; dividing by its root keeps the field's variance at 1 everywhere.
        let norm = 1.0 / ((1.0 - t).powi(2) + t * t).sqrt();
        Self {
            node: (a - first) as u32,
            w: t as f32,
            norm: norm as f32,
        }
    }
}

/// Range of lattice nodes (global indices) needed for grid indices `g0..g0+n`.
pub(crate) fn node_range(g0: usize, n: usize, step: usize) -> (usize, usize) {
    let first = g0 / step;
    let last = (g0 + n - 1) / step + 1;
    (first, last - first + 1)
}

/// A lattice of independent AR(1) processes (one per node), bilinearly (smoothstep)
/// upsampled to the grid: a smooth Gaussian anomaly field with unit variance, correlation
/// length ≈ `step` cells and lag-1 autocorrelation `phi` at each node.
#[derive(Debug, Clone)]
pub(crate) struct ArLattice {
    stream: Stream,
    pub step: usize,
    phi: f64,
    a0: usize,
    b0: usize,
    pub nb: usize,
    values: Vec<f32>,
}

impl ArLattice {
    /// Lattice covering global rows `j0..j0+n_lat` and columns `i0..i0+n_lon`, initialised from
    /// its stationary distribution with the innovations of day `day0`.
    pub fn new(
        seed: u64,
        stream: Stream,
        step: usize,
        phi: f64,
        window: (usize, usize, usize, usize),
        day0: i32,
    ) -> Self {
        let (j0, n_lat, i0, n_lon) = window;
        let (a0, na) = node_range(j0, n_lat, step);
        let (b0, nb) = node_range(i0, n_lon, step);
        let mut l = Self {
            stream,
            step,
            phi,
            a0,
            b0,
            nb,
            values: vec![0.0; na * nb],
        };
        let k = key(seed, stream, i64::from(day0));
        for a in 0..na {
            for b in 0..nb {
                l.values[a * nb + b] = normal(hash_with(k, l.node_id(a, b))) as f32;
            }
        }
        l
    }

    fn node_id(&self, a: usize, b: usize) -> u64 {
        ((self.a0 + a) as u64) << 32 | (self.b0 + b) as u64
    }

    /// Advances every node one day with the innovations of `day`.
    pub fn step_day(&mut self, seed: u64, day: i32) {
        use rayon::prelude::*;
        let k = key(seed, self.stream, i64::from(day));
        let s = (1.0 - self.phi * self.phi).sqrt();
        let (a0, b0, phi, nb) = (self.a0, self.b0, self.phi, self.nb);
        // Every node's innovation is a hash of its own id: rows of nodes can go in parallel.
        self.values.par_chunks_mut(nb).enumerate().for_each(|(a, row)| {
            for (b, v) in row.iter_mut().enumerate() {
                let id = ((a0 + a) as u64) << 32 | (b0 + b) as u64;
                let e = normal(hash_with(k, id));
                *v = (phi * f64::from(*v) + s * e) as f32;
            }
        });
    }

    /// Axis coordinates of a global row.
    pub fn row_axis(&self, j: usize) -> Axis {
        Axis::new(j, self.step, self.a0)
    }

    /// Axis coordinates of a global column.
    pub fn col_axis(&self, i: usize) -> Axis {
        Axis::new(i, self.step, self.b0)
    }

    /// The lattice interpolated along rows for one grid row: `out[b]` for every node column.
    pub fn interp_row(&self, ax: Axis, out: &mut Vec<f32>) {
        out.clear();
        let r0 = &self.values[ax.node as usize * self.nb..][..self.nb];
        let r1 = &self.values[(ax.node as usize + 1) * self.nb..][..self.nb];
        let (w0, w1) = ((1.0 - ax.w) * ax.norm, ax.w * ax.norm);
        out.extend(r0.iter().zip(r1).map(|(a, b)| a * w0 + b * w1));
    }
}

/// Final interpolation along a row prepared by [`ArLattice::interp_row`].
#[inline]
pub(crate) fn interp_col(row: &[f32], ax: Axis) -> f32 {
    let b = ax.node as usize;
    (row[b] * (1.0 - ax.w) + row[b + 1] * ax.w) * ax.norm
}

/// Static value noise on global grid indices: one octave with node spacing `step` cells,
/// values uniform-normal from the hash, smoothstep interpolation, unit variance.
pub(crate) fn value_noise(seed: u64, stream: Stream, octave: i64, step: usize, j: usize, i: usize) -> f64 {
    let k = key(seed, stream, octave);
    let (a, b) = (j / step, i / step);
    let tj = fade((j % step) as f64 / step as f64);
    let ti = fade((i % step) as f64 / step as f64);
    let n = |a: usize, b: usize| normal(hash_with(k, (a as u64) << 32 | b as u64));
    let v0 = n(a, b) * (1.0 - ti) + n(a, b + 1) * ti;
    let v1 = n(a + 1, b) * (1.0 - ti) + n(a + 1, b + 1) * ti;
    let norm = 1.0 / (((1.0 - tj).powi(2) + tj * tj) * ((1.0 - ti).powi(2) + ti * ti)).sqrt();
    (v0 * (1.0 - tj) + v1 * tj) * norm
}

/// [`value_noise`] at a fractional grid position `(y, x)` (global row and column, in cells) with
/// a node spacing `step` that may be a fraction of a cell: continuous everywhere, and equal to
/// [`value_noise`] (to rounding) at whole positions with the same integer `step`, so a
/// landscape finer than the GRIDMET grid samples the very field the grid's cells saw.
pub(crate) fn value_noise_at(seed: u64, stream: Stream, octave: i64, step: f64, y: f64, x: f64) -> f64 {
    let k = key(seed, stream, octave);
    let (fy, fx) = (y / step, x / step);
    let (a, b) = (fy.floor(), fx.floor());
    let (tj, ti) = (fade(fy - a), fade(fx - b));
    let (a, b) = (a as i64, b as i64);
    // Nodes at non-negative positions hash exactly as `value_noise`'s `(a << 32) | b`.
    let n = |a: i64, b: i64| normal(hash_with(k, (a as u64) << 32 | (b as u64 & 0xFFFF_FFFF)));
    let v0 = n(a, b) * (1.0 - ti) + n(a, b + 1) * ti;
    let v1 = n(a + 1, b) * (1.0 - ti) + n(a + 1, b + 1) * ti;
    let norm = 1.0 / (((1.0 - tj).powi(2) + tj * tj) * ((1.0 - ti).powi(2) + ti * ti)).sqrt();
    (v0 * (1.0 - tj) + v1 * tj) * norm
}

/// [`fractal`] at a fractional grid position (see [`value_noise_at`]).
pub(crate) fn fractal_at(seed: u64, stream: Stream, steps: &[usize], hurst: f64, y: f64, x: f64) -> f64 {
    let mut sum = 0.0;
    let mut w2 = 0.0;
    for (o, &s) in steps.iter().enumerate() {
        let w = (s as f64).powf(hurst);
        sum += w * value_noise_at(seed, stream, o as i64, s as f64, y, x);
        w2 += w * w;
    }
    sum / w2.sqrt()
}

/// Fractal (multi-octave) value noise, unit variance: octaves with spacings `steps` (cells)
/// and weights proportional to `step^hurst`.
pub(crate) fn fractal(seed: u64, stream: Stream, steps: &[usize], hurst: f64, j: usize, i: usize) -> f64 {
    let mut sum = 0.0;
    let mut w2 = 0.0;
    for (o, &s) in steps.iter().enumerate() {
        let w = (s as f64).powf(hurst);
        sum += w * value_noise(seed, stream, o as i64, s, j, i);
        w2 += w * w;
    }
    sum / w2.sqrt()
}

/// Standard normal upper tail `Q(x) = 1 − Φ(x)` (Numerical Recipes `erfcc`, |rel. error| <
/// 1.2e-7).
pub(crate) fn normal_q(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * z);
    let erfc = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 { 0.5 * erfc } else { 1.0 - 0.5 * erfc }
}

/// Inverse standard normal CDF (Acklam's rational approximation, |rel. error| < 1.2e-9).
pub(crate) fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    let p = p.clamp(1e-12, 1.0 - 1e-12);
    let plow = 0.024_25;
    if p < plow {
        let q = (-2.0 * p.ln()).sqrt();
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    } else if p <= 1.0 - plow {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    } else {
        let q = (-2.0 * (1.0 - p).ln()).sqrt();
        -(((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantile_inverts_tail() {
        for p in [0.001, 0.02, 0.1, 0.3, 0.5, 0.8, 0.97, 0.999] {
            let x = normal_quantile(p);
            assert!((1.0 - normal_q(x) - p).abs() < 1e-6, "p={p}");
        }
    }

    #[test]
    fn normals_have_unit_variance() {
        let k = key(7, Stream::TempSyn, 3);
        let n = 20_000;
        let (mut s, mut s2) = (0.0, 0.0);
        let (mut t, mut t2) = (0.0, 0.0);
        for c in 0..n {
            let x = normal(hash_with(k, c));
            s += x;
            s2 += x * x;
            let (a, _) = triangular_pair(hash_with(k, c + n));
            t += f64::from(a);
            t2 += f64::from(a * a);
        }
        let n = n as f64;
        assert!((s / n).abs() < 0.03 && (s2 / n - 1.0).abs() < 0.05);
        assert!((t / n).abs() < 0.03 && (t2 / n - 1.0).abs() < 0.05);
    }

    #[test]
    fn lattice_is_smooth_and_unit_variance() {
        let mut l = ArLattice::new(1, Stream::TempSyn, 12, 0.8, (0, 120, 0, 240), 100);
        l.step_day(1, 101);
        let mut row = Vec::new();
        let (mut s2, mut n, mut jump) = (0.0, 0.0, 0.0f32);
        for j in 0..120 {
            l.interp_row(l.row_axis(j), &mut row);
            let mut prev: Option<f32> = None;
            for i in 0..240 {
                let v = interp_col(&row, l.col_axis(i));
                s2 += f64::from(v * v);
                n += 1.0;
                if let Some(p) = prev {
                    jump = jump.max((v - p).abs());
                }
                prev = Some(v);
            }
        }
        assert!((s2 / n - 1.0).abs() < 0.35, "variance {}", s2 / n);
        assert!(jump < 1.0, "neighbouring cells jump by {jump}");
    }
}
