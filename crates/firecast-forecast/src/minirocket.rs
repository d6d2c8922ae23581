//! MiniRocket (Dempster, Schmidt & Webb, KDD 2021), multivariate: 84 fixed length-9 kernels
//! with weights −1 and 2, exponentially spaced dilations, a random subset of variables per
//! kernel, biases drawn from quantiles of a training window's convolution, and the
//! proportion of positive values (PPV) as each feature. A linear head on top.
//!
//! One change from the reference: each variable is standardised with training statistics
//! before the variables of a kernel are summed, because GRIDMET variables differ in scale by
//! three orders of magnitude (radiation in W/m², precipitation in mm).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::ForecastError;
use crate::data::Block;
use firecast_baselines::Matrix;

const KERNEL_LEN: usize = 9;

/// The 84 choices of three positions (out of 9) that carry weight 2.
fn kernel_positions() -> Vec<[usize; 3]> {
    let mut out = Vec::with_capacity(84);
    for a in 0..KERNEL_LEN {
        for b in a + 1..KERNEL_LEN {
            for c in b + 1..KERNEL_LEN {
                out.push([a, b, c]);
            }
        }
    }
    out
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Combination {
    kernel: usize,
    dilation: usize,
    padding: bool,
    channels: Vec<usize>,
    biases: Vec<f32>,
}

/// A fitted MiniRocket transform.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MiniRocket {
    pub features: Vec<String>,
    pub days: usize,
    mean: Vec<f32>,
    std: Vec<f32>,
    combinations: Vec<Combination>,
}

impl MiniRocket {
    pub fn output_len(&self) -> usize {
        self.combinations.iter().map(|c| c.biases.len()).sum()
    }

    /// Chooses dilations, variable subsets and biases from the training windows.
    pub fn fit(
        block: &Block,
        features: &[String],
        num_features: usize,
        seed: u64,
    ) -> Result<Self, ForecastError> {
        let days = block.n_days;
        if days < KERNEL_LEN {
            return Err(ForecastError::Config {
                key: "params".into(),
                message: format!("MiniRocket needs windows of at least {KERNEL_LEN} days, these have {days}"),
            });
        }
        let idx = crate::features::flatten(block, features)?;
        let c = features.len();
        let n = block.rows();
        let (mean, std) = crate::features::channel_moments(&idx.data, c);
        let kernels = kernel_positions();
        let per_kernel = (num_features / kernels.len()).max(1);
        let max_exponent = (((days - 1) as f64) / (KERNEL_LEN - 1) as f64).log2().max(0.0);
        let num_dilations = per_kernel.min(32);
        let mut dilations: Vec<(usize, usize)> = Vec::new();
        for i in 0..num_dilations {
            let e = if num_dilations > 1 {
                max_exponent * i as f64 / (num_dilations - 1) as f64
            } else {
                0.0
            };
            let d = 2f64.powf(e).floor() as usize;
            match dilations.last_mut() {
                Some((last, count)) if *last == d => *count += 1,
                _ => dilations.push((d, 1)),
            }
        }
        // Spread `per_kernel` features over the unique dilations like the reference does.
        let total: usize = dilations.iter().map(|(_, k)| k).sum();
        let mut counts: Vec<usize> = dilations.iter().map(|(_, k)| per_kernel * k / total).collect();
        let mut left = per_kernel - counts.iter().sum::<usize>();
        for cnt in counts.iter_mut() {
            if left == 0 {
                break;
            }
            *cnt += 1;
            left -= 1;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let max_channels = c.min(KERNEL_LEN);
        let phi = (5f64.sqrt() + 1.0) / 2.0;
        let mut combinations = Vec::new();
        let mut feature_index = 0usize;
        for (di, &(dilation, _)) in dilations.iter().enumerate() {
            if counts[di] == 0 {
                continue;
            }
            for (k, positions) in kernels.iter().enumerate() {
                let exponent = rng.random_range(0.0..((max_channels + 1) as f64).log2());
                let take = (2f64.powf(exponent).floor() as usize).clamp(1, max_channels);
                let mut all: Vec<usize> = (0..c).collect();
                for i in 0..take {
                    let j = rng.random_range(i..c);
                    all.swap(i, j);
                }
                let mut channels = all[..take].to_vec();
                channels.sort_unstable();
                let mut combo = Combination {
                    kernel: k,
                    dilation,
                    padding: (k + di) % 2 == 0,
                    channels,
                    biases: Vec::new(),
                };
                // Biases: quantiles of one random training window's convolution.
                let example = rng.random_range(0..n);
                let series = mixed_series(
                    &idx.data[example * days * c..(example + 1) * days * c],
                    c,
                    &combo.channels,
                    &mean,
                    &std,
                );
                let mut conv = convolve(&series, positions, dilation, true);
                conv.sort_by(f32::total_cmp);
                for _ in 0..counts[di] {
                    feature_index += 1;
                    let q = (feature_index as f64 * phi) % 1.0;
                    combo.biases.push(quantile(&conv, q));
                }
                combinations.push(combo);
            }
        }
        Ok(Self {
            features: features.to_vec(),
            days,
            mean,
            std,
            combinations,
        })
    }

    /// PPV features of every window of `block`.
    pub fn transform(
        &self,
        block: &Block,
        progress: crate::inputs::Progress<'_>,
    ) -> Result<Matrix, ForecastError> {
        if block.n_days != self.days {
            return Err(ForecastError::Config {
                key: "days".into(),
                message: format!(
                    "MiniRocket was fitted on {}-day windows, these have {}",
                    self.days, block.n_days
                ),
            });
        }
        let x = crate::features::flatten(block, &self.features)?;
        let c = self.features.len();
        let kernels = kernel_positions();
        let width = self.output_len();
        let n = block.rows();
        let done = std::sync::atomic::AtomicU64::new(0);
        let rows: Vec<Vec<f32>> = (0..n)
            .into_par_iter()
            .map(|s| {
                let window = &x.data[s * self.days * c..(s + 1) * self.days * c];
                let mut out = Vec::with_capacity(width);
                for combo in &self.combinations {
                    let series = mixed_series(window, c, &combo.channels, &self.mean, &self.std);
                    let conv = convolve(&series, &kernels[combo.kernel], combo.dilation, combo.padding);
                    let len = conv.len().max(1) as f32;
                    for b in &combo.biases {
                        out.push(conv.iter().filter(|v| *v > b).count() as f32 / len);
                    }
                }
                let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                if k.is_multiple_of(256) || k as usize == n {
                    progress(k, n as u64, "minirocket");
                }
                out
            })
            .collect();
        Matrix::new(n, width, rows.concat()).map_err(|e| ForecastError::Model(e.to_string()))
    }
}

/// The standardised sum of the chosen variables of one `[day, variable]` window.
fn mixed_series(window: &[f32], c: usize, channels: &[usize], mean: &[f32], std: &[f32]) -> Vec<f32> {
    let days = window.len() / c;
    (0..days)
        .map(|d| {
            channels
                .iter()
                .map(|&ch| (window[d * c + ch] - mean[ch]) / std[ch])
                .sum()
        })
        .collect()
}

/// Convolution with weights −1 everywhere and 2 at `positions`, centred, dilated. With
/// padding the output has the input's length (zeros outside); without, only the positions
/// where the kernel fits.
fn convolve(x: &[f32], positions: &[usize; 3], dilation: usize, padding: bool) -> Vec<f32> {
    let n = x.len() as isize;
    let half = (KERNEL_LEN / 2 * dilation) as isize;
    let (start, end) = if padding { (0, n) } else { (half, n - half) };
    let mut out = Vec::with_capacity((end - start).max(0) as usize);
    for t in start..end {
        let mut s = 0.0f32;
        for k in 0..KERNEL_LEN {
            let at = t + (k as isize - (KERNEL_LEN / 2) as isize) * dilation as isize;
            if (0..n).contains(&at) {
                let w = if positions.contains(&k) { 2.0 } else { -1.0 };
                s += w * x[at as usize];
            }
        }
        out.push(s);
    }
    if out.is_empty() {
        // Dilations too wide for an unpadded output: fall back to the padded one.
        return convolve(x, positions, dilation, true);
    }
    out
}

/// NumPy's default (linear) quantile of sorted values.
fn quantile(sorted: &[f32], q: f64) -> f32 {
    if sorted.is_empty() {
        return 0.0;
    }
    let pos = q * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    let frac = (pos - lo as f64) as f32;
    sorted[lo] + (sorted[hi] - sorted[lo]) * frac
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn there_are_84_kernels_with_three_twos() {
        let k = kernel_positions();
        assert_eq!(k.len(), 84);
        // Weights sum to zero: 3 × 2 − 6 × 1.
        assert!(k.iter().all(|p| 3 * 2 - 6 == 0 && p[0] < p[1] && p[1] < p[2]));
    }

    #[test]
    fn convolution_of_a_constant_is_zero_inside() {
        let x = vec![1.0f32; 30];
        let c = convolve(&x, &[0, 4, 8], 2, false);
        assert_eq!(c.len(), 30 - 16);
        assert!(c.iter().all(|v| v.abs() < 1e-6));
    }

    #[test]
    fn quantile_matches_numpy_linear() {
        let s = [1.0f32, 2.0, 3.0, 4.0];
        assert!((quantile(&s, 0.5) - 2.5).abs() < 1e-6);
        assert!((quantile(&s, 0.0) - 1.0).abs() < 1e-6);
        assert!((quantile(&s, 1.0) - 4.0).abs() < 1e-6);
    }
}
