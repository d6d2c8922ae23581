//! The random streams scikit-learn's trees draw from, reproduced bit for bit:
//!
//! - [`RandomState`]: NumPy's legacy `numpy.random.RandomState(seed)` — MT19937 seeded
//!   with Knuth's `init_genrand`, bounded integers by masked rejection on 32-bit draws
//!   (`randint(low, high)` with `high − low ≤ 2³²`), doubles from two 32-bit draws
//!   (`(a >> 5) · 2²⁶ + (b >> 6)) / 2⁵³`, as `uniform()`);
//! - [`rand_r`]: scikit-learn's own 32-bit xorshift (`our_rand_r`, `RAND_R_MAX = 2³¹ − 1`)
//!   that a tree's splitter seeds with `RandomState(random_state).randint(0, RAND_R_MAX)`;
//! - [`pairwise_sum`]: NumPy's pairwise summation of a contiguous `float64` array, which
//!   `np.average` (gradient boosting's leaf values) goes through.

/// scikit-learn's `RAND_R_MAX`.
pub(crate) const RAND_R_MAX: u32 = 0x7FFF_FFFF;

const N: usize = 624;
const M: usize = 397;

/// NumPy's legacy `RandomState` (MT19937).
pub(crate) struct RandomState {
    mt: [u32; N],
    pos: usize,
}

impl RandomState {
    /// `RandomState(seed)` for an integer seed (NumPy accepts 0 ≤ seed < 2³²).
    pub fn new(seed: u32) -> Self {
        let mut mt = [0u32; N];
        mt[0] = seed;
        for i in 1..N {
            mt[i] = 1_812_433_253u32
                .wrapping_mul(mt[i - 1] ^ (mt[i - 1] >> 30))
                .wrapping_add(i as u32);
        }
        RandomState { mt, pos: N }
    }

    fn reload(&mut self) {
        const UPPER: u32 = 0x8000_0000;
        const LOWER: u32 = 0x7FFF_FFFF;
        const MATRIX_A: u32 = 0x9908_B0DF;
        for i in 0..N {
            let y = (self.mt[i] & UPPER) | (self.mt[(i + 1) % N] & LOWER);
            let mag = if y & 1 == 1 { MATRIX_A } else { 0 };
            self.mt[i] = self.mt[(i + M) % N] ^ (y >> 1) ^ mag;
        }
        self.pos = 0;
    }

    /// One tempered 32-bit output (`genrand_int32`).
    pub fn next_u32(&mut self) -> u32 {
        if self.pos == N {
            self.reload();
        }
        let mut y = self.mt[self.pos];
        self.pos += 1;
        y ^= y >> 11;
        y ^= (y << 7) & 0x9D2C_5680;
        y ^= (y << 15) & 0xEFC6_0000;
        y ^ (y >> 18)
    }

    /// `randint(low, high)` (high exclusive), for `0 < high − low ≤ 2³²`: masked rejection
    /// on 32-bit draws, as NumPy's legacy generator does for every integer dtype.
    pub fn randint(&mut self, low: u64, high: u64) -> u64 {
        debug_assert!(high > low && high - low <= 1 << 32);
        let rng = high - 1 - low;
        if rng == 0 {
            return low;
        }
        if rng == u64::from(u32::MAX) {
            return low + u64::from(self.next_u32());
        }
        let rng = rng as u32;
        let mask = u32::MAX >> rng.leading_zeros();
        loop {
            let v = self.next_u32() & mask;
            if v <= rng {
                return low + u64::from(v);
            }
        }
    }

    /// `random_sample()` / `uniform(0, 1)`: a double in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        let a = self.next_u32() >> 5;
        let b = self.next_u32() >> 6;
        (f64::from(a) * 67_108_864.0 + f64::from(b)) / 9_007_199_254_740_992.0
    }
}

/// scikit-learn's `our_rand_r`: xorshift32 (a zero state restarts at 1), reduced to
/// `[0, RAND_R_MAX]`.
#[inline]
pub(crate) fn rand_r(state: &mut u32) -> u32 {
    if *state == 0 {
        *state = 1;
    }
    *state ^= *state << 13;
    *state ^= *state >> 17;
    *state ^= *state << 5;
    *state % (RAND_R_MAX + 1)
}

/// scikit-learn's `rand_int(low, high)`: `low + our_rand_r() % (high − low)`.
#[inline]
pub(crate) fn rand_int(low: usize, high: usize, state: &mut u32) -> usize {
    low + rand_r(state) as usize % (high - low)
}

/// NumPy's pairwise sum of a contiguous `float64` array (`np.add.reduce`): blocks of at
/// most 128 values summed with eight interleaved accumulators, halves (rounded down to a
/// multiple of 8) added recursively; the reduction starts from 0.
pub(crate) fn pairwise_sum(a: &[f64]) -> f64 {
    0.0 + pairwise(a)
}

fn pairwise(a: &[f64]) -> f64 {
    let n = a.len();
    if n < 8 {
        let mut res = 0.0;
        for &v in a {
            res += v;
        }
        res
    } else if n <= 128 {
        let mut r = [0.0f64; 8];
        r.copy_from_slice(&a[..8]);
        let mut i = 8;
        while i < n - n % 8 {
            for j in 0..8 {
                r[j] += a[i + j];
            }
            i += 8;
        }
        let mut res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        while i < n {
            res += a[i];
            i += 1;
        }
        res
    } else {
        let mut n2 = n / 2;
        n2 -= n2 % 8;
        pairwise(&a[..n2]) + pairwise(&a[n2..])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Expected values printed by NumPy 2.4.6.
    #[test]
    fn randint_matches_numpy() {
        let first = |s| RandomState::new(s).randint(0, u64::from(RAND_R_MAX));
        assert_eq!(
            [first(0), first(1), first(42), first(u32::MAX)],
            [209652396, 1791095845, 1608637542, 419326371]
        );
        let mut r = RandomState::new(7);
        let v: Vec<u64> = (0..4).map(|_| r.randint(0, 2147483647)).collect();
        assert_eq!(v, [327741615, 976413892, 1202242073, 1369975286]);
        let mut r = RandomState::new(3);
        let v: Vec<u64> = (0..12).map(|_| r.randint(0, 10)).collect();
        assert_eq!(v, [8, 9, 3, 8, 8, 0, 5, 3, 9, 9, 5, 7]);
        let mut r = RandomState::new(3);
        let v: Vec<u64> = (0..5).map(|_| r.randint(0, 1000003)).collect();
        assert_eq!(v, [71530, 722584, 601337, 452227, 572344]);
    }

    #[test]
    fn uniform_matches_numpy() {
        let mut r = RandomState::new(5);
        let v: Vec<f64> = (0..3).map(|_| r.uniform()).collect();
        assert_eq!(v, [0.22199317108973948, 0.8707323061773764, 0.20671915533942642]);
    }

    #[test]
    fn pairwise_sum_blocks() {
        let a: Vec<f64> = (0..300).map(|i| 0.1 * f64::from(i) + 1e-3).collect();
        let s = pairwise_sum(&a);
        let exact: f64 = (0..300).map(|i| 0.1 * f64::from(i) + 1e-3).sum();
        assert!((s - exact).abs() < 1e-9);
        assert_eq!(pairwise_sum(&[]), 0.0);
        assert_eq!(pairwise_sum(&[-0.0]), 0.0);
    }
}
