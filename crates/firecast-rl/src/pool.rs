//! A pool of helitack training fires described the way `firecast.HelitackVecEnv` (the Python
//! package) takes them — procedural landscape seeds × ignition cells under one environment
//! configuration — so a Rust run and a Python run play the same fires (`firecast bench ppo`
//! (b), the tiny runs of the tests, the device example).

use firecast_landscape::{Landscape, procedural};
use firecast_sim::EnvConfig;
use firecast_sim::env::EnvCore;
use serde::Serialize;

use crate::RlError;
use crate::helitack::reward_profile;

/// (b)'s fire pool, built the way `firecast.HelitackVecEnv` builds its pool (every landscape
/// × every ignition cell, one environment configuration), so both sides play the same fires.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HelitackPool {
    /// Seeds of procedural landscapes.
    pub landscape_seeds: Vec<u64>,
    pub width: usize,
    pub height: usize,
    /// Ignition cells [x, y], burnable on every landscape.
    pub ignitions: Vec<[usize; 2]>,
    /// `EnvConfig` keys, as the Python package takes them (`config=`).
    pub config: serde_json::Value,
    /// Reward profile.
    pub profile: String,
}

impl HelitackPool {
    /// The demo's scale (experiments/rl/demo-fires.yaml): 96 × 64 procedural landscapes 1–4,
    /// 400-step episodes, a light west wind and 11 % 1-h moisture (the middle of the demo's
    /// ranges), two ignition cells burnable on all four.
    pub fn demo_scale() -> Result<Self, RlError> {
        Self::sized(96, 64)
    }

    /// The demo's fires on `width` × `height` landscapes (240 × 160 is FireCastRL's map), the
    /// ignition candidates scaled from the 96 × 64 ones.
    pub fn sized(width: usize, height: usize) -> Result<Self, RlError> {
        let mut pool = Self {
            landscape_seeds: vec![1, 2, 3, 4],
            width,
            height,
            ignitions: Vec::new(),
            config: serde_json::json!({
                "max_steps": 400,
                "sim": {
                    "wind": {"speed_mph": 2.0, "from_direction_deg": 270.0},
                    "kernel": {"rothermel": {"moisture": {
                        "dead_1h_frac": 0.11, "dead_10h_frac": 0.12, "dead_100h_frac": 0.13,
                        "live_herb_frac": 0.6, "live_woody_frac": 0.9,
                    }}},
                },
            }),
            profile: "p2".into(),
        };
        let cfg = pool.env_config()?;
        let cores: Vec<EnvCore> = pool
            .landscapes()?
            .iter()
            .map(|l| EnvCore::new(l, &cfg))
            .collect::<Result<_, _>>()?;
        let candidates = [
            [48, 32],
            [40, 28],
            [56, 36],
            [36, 40],
            [60, 24],
            [30, 30],
            [66, 34],
            [44, 20],
            [52, 44],
            [34, 26],
            [62, 42],
            [28, 36],
            [70, 28],
        ];
        pool.ignitions = candidates
            .into_iter()
            .map(|[x, y]| [x * width / 96, y * height / 64])
            .filter(|&[x, y]| {
                cores
                    .iter()
                    .all(|c| !c.automaton().is_non_burnable(y * pool.width + x))
            })
            .take(2)
            .collect();
        if pool.ignitions.is_empty() {
            return Err(RlError::config(
                "bench.ignitions",
                "no candidate ignition cell is burnable on every bench landscape",
            ));
        }
        Ok(pool)
    }

    fn landscapes(&self) -> Result<Vec<Landscape>, RlError> {
        self.landscape_seeds
            .iter()
            .map(|&seed| {
                Ok(procedural::generate(&procedural::ProceduralOptions {
                    width: self.width,
                    height: self.height,
                    ..procedural::ProceduralOptions::with_seed(seed)
                })?)
            })
            .collect()
    }

    /// The environment configuration both sides use.
    pub fn env_config(&self) -> Result<EnvConfig, RlError> {
        let mut cfg: EnvConfig = serde_json::from_value(self.config.clone())
            .map_err(|e| RlError::config("bench.config", e.to_string()))?;
        cfg.reward = reward_profile(&self.profile)?;
        Ok(cfg)
    }

    /// The pool in `HelitackVecEnv`'s order: landscape-major, then ignition.
    pub fn fires(&self) -> Result<Vec<EnvCore>, RlError> {
        let cfg = self.env_config()?;
        let mut fires = Vec::new();
        for land in self.landscapes()? {
            let core = EnvCore::new(&land, &cfg)?;
            for &[x, y] in &self.ignitions {
                let mut c = core.clone();
                c.set_ignition(x, y)?;
                fires.push(c);
            }
        }
        Ok(fires)
    }

    /// `HelitackVecEnv`'s keyword arguments for this pool.
    pub fn python_kwargs(&self) -> serde_json::Value {
        serde_json::json!({
            "landscapes": self
                .landscape_seeds
                .iter()
                .map(|s| serde_json::json!({"procedural": {"seed": s, "width": self.width, "height": self.height}}))
                .collect::<Vec<_>>(),
            "ignitions": self.ignitions,
            "config": self.config,
            "profile": self.profile,
        })
    }
}
