//! Running statistics and SB3's `VecNormalize` semantics: the vector part of observations
//! standardised by running mean/variance (clipped at ±10), rewards divided by the running
//! standard deviation of the discounted return (not centred, clipped at ±10, the return
//! reset at episode ends). Statistics are float64 and merged per step-batch (Chan et al.).

use serde::{Deserialize, Serialize};

/// Running mean and (population) variance, as SB3's `RunningMeanStd(epsilon=1e-4)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunningMeanStd {
    pub mean: Vec<f64>,
    pub var: Vec<f64>,
    pub count: f64,
}

impl RunningMeanStd {
    pub fn new(dim: usize) -> Self {
        Self {
            mean: vec![0.0; dim],
            var: vec![1.0; dim],
            count: 1e-4,
        }
    }

    /// Merges a batch of `rows` observations laid out row-major (`rows × dim`).
    pub fn update(&mut self, batch: &[f64]) {
        let dim = self.mean.len();
        if dim == 0 || batch.is_empty() {
            return;
        }
        let rows = batch.len() / dim;
        let n = rows as f64;
        for d in 0..dim {
            let mean = batch.iter().skip(d).step_by(dim).sum::<f64>() / n;
            let var = batch
                .iter()
                .skip(d)
                .step_by(dim)
                .map(|v| (v - mean) * (v - mean))
                .sum::<f64>()
                / n;
            let delta = mean - self.mean[d];
            let tot = self.count + n;
            let m2 = self.var[d] * self.count + var * n + delta * delta * self.count * n / tot;
            self.mean[d] += delta * n / tot;
            self.var[d] = m2 / tot;
        }
        self.count += n;
    }
}

/// Settings of [`VecNormalize`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NormalizeConfig {
    /// Standardise the vector part of observations (images are never normalised).
    pub obs: bool,
    /// Divide rewards by the running std of the discounted return.
    pub reward: bool,
    pub clip_obs: f64,
    pub clip_reward: f64,
    /// Discount of the running return; `None` = the algorithm's γ (as RL-Zoo sets it).
    pub gamma: Option<f64>,
    pub epsilon: f64,
}

impl Default for NormalizeConfig {
    fn default() -> Self {
        Self {
            obs: false,
            reward: false,
            clip_obs: 10.0,
            clip_reward: 10.0,
            gamma: None,
            epsilon: 1e-8,
        }
    }
}

/// The normaliser state (saved in checkpoints, frozen at evaluation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VecNormalize {
    pub config: NormalizeConfig,
    pub gamma: f64,
    pub obs_rms: RunningMeanStd,
    pub ret_rms: RunningMeanStd,
    /// Per-environment discounted return.
    pub returns: Vec<f64>,
    pub training: bool,
}

impl VecNormalize {
    pub fn new(config: NormalizeConfig, algo_gamma: f64, vector_dim: usize, n_envs: usize) -> Self {
        let gamma = config.gamma.unwrap_or(algo_gamma);
        Self {
            config,
            gamma,
            obs_rms: RunningMeanStd::new(vector_dim),
            ret_rms: RunningMeanStd::new(1),
            returns: vec![0.0; n_envs],
            training: true,
        }
    }

    /// Updates the observation statistics with a batch (when training) and normalises it in
    /// place; call with the raw observations right after a step or a reset.
    pub fn observe(&mut self, vector: &mut [f32]) {
        if !self.config.obs {
            return;
        }
        if self.training {
            let batch: Vec<f64> = vector.iter().map(|&v| f64::from(v)).collect();
            self.obs_rms.update(&batch);
        }
        self.normalize_obs(vector);
    }

    /// Normalises without updating (terminal observations, evaluation).
    pub fn normalize_obs(&self, vector: &mut [f32]) {
        if !self.config.obs {
            return;
        }
        let dim = self.obs_rms.mean.len();
        let c = self.config.clip_obs;
        for (k, v) in vector.iter_mut().enumerate() {
            let d = k % dim;
            let z =
                (f64::from(*v) - self.obs_rms.mean[d]) / (self.obs_rms.var[d] + self.config.epsilon).sqrt();
            *v = z.clamp(-c, c) as f32;
        }
    }

    /// Normalised rewards of one step; updates the return statistics when training and
    /// resets the returns of environments whose episode ended.
    pub fn rewards(&mut self, raw: &[f64], dones: &[bool]) -> Vec<f32> {
        if !self.config.reward {
            return raw.iter().map(|&r| r as f32).collect();
        }
        if self.training {
            for (ret, r) in self.returns.iter_mut().zip(raw) {
                *ret = *ret * self.gamma + r;
            }
            self.ret_rms.update(&self.returns);
        }
        let scale = (self.ret_rms.var[0] + self.config.epsilon).sqrt();
        let c = self.config.clip_reward;
        let out = raw.iter().map(|&r| (r / scale).clamp(-c, c) as f32).collect();
        for (ret, &d) in self.returns.iter_mut().zip(dones) {
            if d {
                *ret = 0.0;
            }
        }
        out
    }

    pub fn reset_returns(&mut self) {
        self.returns.fill(0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merged_statistics_equal_the_pooled_ones() {
        let data: Vec<f64> = (0..60).map(|i| ((i * 37) % 11) as f64 - 3.0).collect();
        let mut rms = RunningMeanStd::new(3);
        for chunk in data.chunks(9 * 3) {
            rms.update(chunk);
        }
        for d in 0..3 {
            let col: Vec<f64> = data.iter().skip(d).step_by(3).copied().collect();
            let n = col.len() as f64;
            let mean = col.iter().sum::<f64>() / n;
            let var = col.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
            // The 1e-4 prior count shifts the moments by O(1e-5).
            assert!((rms.mean[d] - mean).abs() < 1e-4, "{} vs {mean}", rms.mean[d]);
            assert!((rms.var[d] - var).abs() < 1e-3, "{} vs {var}", rms.var[d]);
        }
        assert!((rms.count - 20.0 - 1e-4).abs() < 1e-12);
    }
}
