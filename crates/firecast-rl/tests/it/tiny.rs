//! The tiny trained run the ensemble and recording tests start from: seeds 0 and 1 of the
//! compact policy for 32 steps each (2 environments × 16 steps), with an observation
//! normaliser, so loading applies the frozen statistics.

use std::path::{Path, PathBuf};

use firecast_rl::helitack::HelitackVec;
use firecast_rl::policy::PolicyConfig;
use firecast_rl::pool::HelitackPool;
use firecast_rl::run::RunSink;
use firecast_rl::spec::{EnvSpec, PpoSpec, TrainSpec};
use tch::Device;

pub(crate) struct Quiet;
impl RunSink for Quiet {}

/// Helitack environments on small (32 × 24) demo fires, episodes cut at `max_steps`.
pub(crate) fn small_env(n: usize, seed: u64, max_steps: u32) -> HelitackVec {
    let mut pool = HelitackPool::sized(32, 24).expect("pool");
    pool.config["max_steps"] = serde_json::json!(max_steps);
    HelitackVec::new(pool.fires().expect("fires"), n, seed).expect("env")
}

/// Writes `fires` (a fire file) into `dir`, trains the tiny run on it; returns the run
/// folder and the fire file.
pub(crate) fn tiny_run(dir: &Path, fires: &str) -> (PathBuf, PathBuf) {
    tiny_run_with(dir, fires, None)
}

/// [`tiny_run`] with another policy (`None`: the default compact one).
pub(crate) fn tiny_run_with(dir: &Path, fires: &str, policy: Option<PolicyConfig>) -> (PathBuf, PathBuf) {
    let fire_file = dir.join("fires.yaml");
    std::fs::write(&fire_file, fires).expect("writing the fire file");
    let overrides = serde_json::json!({
        "n_envs": 2, "n_steps": 16, "batch_size": 16, "n_epochs": 1, "total_timesteps": 32,
        "normalize": {"obs": true, "reward": true}
    });
    let spec = TrainSpec {
        name: "tiny".into(),
        description: None,
        env: EnvSpec::Helitack {
            fires: None,
            reward: None,
        },
        policy,
        ppo: PpoSpec {
            preset: "paper".into(),
            overrides: overrides.as_object().cloned().unwrap_or_default(),
        },
        imitation: None,
        seeds: vec![0, 1],
        checkpoint_every: 1,
        device: "cpu".into(),
        threads: 1,
    };
    let out = dir.join("run");
    firecast_rl::run::train(
        &spec,
        Some(&fire_file),
        &dir.join("work"),
        &out,
        Device::Cpu,
        &Quiet,
        None,
    )
    .expect("training the tiny run");
    (out, fire_file)
}
