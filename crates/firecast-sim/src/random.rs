//! The automaton's random source.
//!
//! FireCast's own runs draw from ChaCha8. For parity runs against the FireCastRL Python
//! engine, [`PythonRandom`] reproduces CPython's `random` module (MT19937 seeded the way
//! `random.seed(n)` seeds it, `random.random()` built from two 32-bit draws), so a seed
//! given to both engines yields the same latch days and the same fire.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Which generator the automaton draws from.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RandomSource {
    /// ChaCha8 seeded from the episode seed.
    #[default]
    Chacha8,
    /// CPython's Mersenne Twister: seed `s` draws what `random.seed(s)` then `random.random()`
    /// draws in FireCastRL's engine.
    PythonMt,
}

/// A seeded uniform [0, 1) generator of either kind.
#[derive(Debug, Clone)]
pub enum Uniform {
    Chacha8(Box<ChaCha8Rng>),
    PythonMt(Box<PythonRandom>),
}

impl Uniform {
    pub fn new(source: RandomSource, seed: u64) -> Self {
        match source {
            RandomSource::Chacha8 => Self::Chacha8(Box::new(ChaCha8Rng::seed_from_u64(seed))),
            RandomSource::PythonMt => Self::PythonMt(Box::new(PythonRandom::seed(seed))),
        }
    }

    /// One draw in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        match self {
            Self::Chacha8(r) => r.random(),
            Self::PythonMt(r) => r.random(),
        }
    }
}

const N: usize = 624;
const M: usize = 397;

/// MT19937 as CPython's `_randommodule.c` uses it.
#[derive(Debug, Clone)]
pub struct PythonRandom {
    mt: [u32; N],
    index: usize,
}

impl PythonRandom {
    /// `random.seed(seed)` for a non-negative integer: the key is the seed's 32-bit words,
    /// least significant first, without leading zero words (at least one word).
    pub fn seed(seed: u64) -> Self {
        let low = seed as u32;
        let high = (seed >> 32) as u32;
        let key: &[u32] = if high == 0 { &[low] } else { &[low, high] };
        let mut r = Self::init_genrand(19_650_218);
        let (mut i, mut j) = (1usize, 0usize);
        for _ in 0..N.max(key.len()) {
            let prev = r.mt[i - 1] ^ (r.mt[i - 1] >> 30);
            r.mt[i] = (r.mt[i] ^ prev.wrapping_mul(1_664_525))
                .wrapping_add(key[j])
                .wrapping_add(j as u32);
            i += 1;
            j += 1;
            if i >= N {
                r.mt[0] = r.mt[N - 1];
                i = 1;
            }
            if j >= key.len() {
                j = 0;
            }
        }
        for _ in 0..N - 1 {
            let prev = r.mt[i - 1] ^ (r.mt[i - 1] >> 30);
            r.mt[i] = (r.mt[i] ^ prev.wrapping_mul(1_566_083_941)).wrapping_sub(i as u32);
            i += 1;
            if i >= N {
                r.mt[0] = r.mt[N - 1];
                i = 1;
            }
        }
        r.mt[0] = 0x8000_0000;
        r
    }

    fn init_genrand(s: u32) -> Self {
        let mut mt = [0u32; N];
        mt[0] = s;
        for i in 1..N {
            mt[i] = 1_812_433_253u32
                .wrapping_mul(mt[i - 1] ^ (mt[i - 1] >> 30))
                .wrapping_add(i as u32);
        }
        Self { mt, index: N }
    }

    fn twist(&mut self) {
        const UPPER: u32 = 0x8000_0000;
        const LOWER: u32 = 0x7fff_ffff;
        const MATRIX_A: u32 = 0x9908_b0df;
        for k in 0..N {
            let y = (self.mt[k] & UPPER) | (self.mt[(k + 1) % N] & LOWER);
            let mag = if y & 1 == 1 { MATRIX_A } else { 0 };
            self.mt[k] = self.mt[(k + M) % N] ^ (y >> 1) ^ mag;
        }
        self.index = 0;
    }

    /// One tempered 32-bit output (`genrand_uint32`).
    pub fn next_u32(&mut self) -> u32 {
        if self.index >= N {
            self.twist();
        }
        let mut y = self.mt[self.index];
        self.index += 1;
        y ^= y >> 11;
        y ^= (y << 7) & 0x9d2c_5680;
        y ^= (y << 15) & 0xefc6_0000;
        y ^ (y >> 18)
    }

    /// `random.random()`: 53 random bits from two draws.
    pub fn random(&mut self) -> f64 {
        let a = self.next_u32() >> 5;
        let b = self.next_u32() >> 6;
        (f64::from(a) * 67_108_864.0 + f64::from(b)) * (1.0 / 9_007_199_254_740_992.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_cpython_for_seed_42() {
        // python3 -c "import random; random.seed(42); print([random.random() for _ in range(3)])"
        let mut r = PythonRandom::seed(42);
        let got: Vec<f64> = (0..3).map(|_| r.random()).collect();
        assert_eq!(
            got,
            [0.6394267984578837, 0.025010755222666936, 0.27502931836911926]
        );
    }

    #[test]
    fn matches_cpython_for_zero_and_two_word_seeds() {
        // random.seed(0); random.random()  and  random.seed(2**40 + 5); random.random()
        assert_eq!(PythonRandom::seed(0).random(), 0.8444218515250481);
        assert_eq!(PythonRandom::seed((1 << 40) + 5).random(), 0.5043802970418443);
    }
}
