//! What the Python constructors take, parsed strictly: landscape specs, the environment
//! configuration (JSON into [`EnvConfig`], unknown keys rejected with their key path) and the
//! reward profile.

use std::path::PathBuf;

use firecast_landscape::{Landscape, LandscapeError, firecastrl, procedural};
use firecast_sim::{EnvConfig, RewardWeights, SimError};
use serde::Deserialize;

/// The smallest landscape side the environments take, in cells. The compact feature extractor
/// (firecast-rl's `compact` policy and `firecast.CompactExtractor`) pools by 8 (a 2× average
/// pool, then two 2× max pools) before its first feature cell, and on a smaller grid the
/// default helicopter start and spark cells fall on or next to each other (a 2 × 2 map puts
/// both on cell (0, 0)) while one 3-cell move crosses half the map.
pub const MIN_GRID_SIDE: usize = 8;

/// Refuses a landscape too small for the helicopter and the fire ([`MIN_GRID_SIDE`]), and an
/// ignition or helicopter start off the map, naming the key (`landscape_key` for the grid,
/// `config.ignition` / `config.helicopter_start` for the cells).
pub fn check_grid(land: &Landscape, cfg: &EnvConfig, landscape_key: &str) -> Result<(), BindError> {
    let (w, h) = (land.width, land.height);
    if w < MIN_GRID_SIDE || h < MIN_GRID_SIDE {
        return Err(BindError::invalid(
            landscape_key,
            format!(
                "the {w} × {h} grid is too small: the helitack environment needs at least \
                 {MIN_GRID_SIDE} × {MIN_GRID_SIDE} cells (the compact CNN pools by 8, and the \
                 helicopter moves 3 cells a step)"
            ),
        ));
    }
    for (key, cell) in [
        ("config.ignition", cfg.ignition),
        ("config.helicopter_start", cfg.helicopter_start),
    ] {
        if let Some([x, y]) = cell
            && (x >= w || y >= h)
        {
            return Err(BindError::invalid(
                key,
                format!("cell ({x}, {y}) is outside the {w} × {h} landscape (x in 0..{w}, y in 0..{h})"),
            ));
        }
    }
    Ok(())
}

/// One `VecEnv` steps one grid size: the first landscape's size is kept in `first` (named
/// `first_key`), every later one (named `key`) must match it.
pub fn check_same_grid(
    land: &Landscape,
    first: &mut Option<(usize, usize)>,
    key: &str,
    first_key: &str,
) -> Result<(), BindError> {
    let grid = (land.width, land.height);
    match *first {
        Some(f) if f != grid => Err(BindError::invalid(
            key,
            format!(
                "is {} × {}, {first_key} is {} × {}: one VecEnv needs one grid size",
                grid.0, grid.1, f.0, f.1
            ),
        )),
        _ => {
            *first = Some(grid);
            Ok(())
        }
    }
}

/// The reward profiles (`RewardWeights::preset`).
pub const PROFILES: &[&str] = &["p2", "websocket_t", "p1_improved", "suppression"];

/// Errors building an environment from Python arguments.
#[derive(Debug, thiserror::Error)]
pub enum BindError {
    /// A bad argument or key; `key` is its path, e.g. `config.reward.quenched`.
    #[error("{key}: {message}")]
    Invalid { key: String, message: String },
    #[error("landscape: {0}")]
    Landscape(#[from] LandscapeError),
    #[error(transparent)]
    Sim(#[from] SimError),
}

impl BindError {
    pub fn invalid(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Invalid {
            key: key.into(),
            message: message.into(),
        }
    }
}

/// Where the terrain comes from (the CLI's `--landscape` forms, minus GeoTIFF).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum LandscapeSpec {
    /// A seeded procedural landscape (`firecast_landscape::procedural`).
    Procedural {
        seed: u64,
        #[serde(default = "default_width")]
        width: usize,
        #[serde(default = "default_height")]
        height: usize,
        /// [lat, lon] of the grid centre (default 37.5, −119.5).
        #[serde(default)]
        center: Option<[f64; 2]>,
    },
    /// FireCastRL's maps: land-cover palette PNG and 16-bit height-map PNG (240 × 160).
    Firecastrl { land_cover: PathBuf, heightmap: PathBuf },
}

fn default_width() -> usize {
    240
}
fn default_height() -> usize {
    160
}

impl LandscapeSpec {
    /// `procedural:SEED`, `firecastrl:LAND_COVER.png,HEIGHTMAP.png`, or a JSON object
    /// (`{"procedural": {"seed": 0, "width": 48, "height": 32}}`).
    pub fn parse(text: &str) -> Result<Self, BindError> {
        let bad = |message: &str| BindError::invalid("landscape", format!("{message} (got {text:?})"));
        let trimmed = text.trim();
        if trimmed.starts_with('{') {
            let value: serde_json::Value = serde_json::from_str(trimmed)
                .map_err(|e| BindError::invalid("landscape", format!("not valid JSON: {e}")))?;
            return from_value("landscape", value);
        }
        match trimmed.split_once(':') {
            Some(("procedural", seed)) => Ok(Self::Procedural {
                seed: seed
                    .trim()
                    .parse()
                    .map_err(|_| bad("the procedural seed must be a whole number >= 0"))?,
                width: default_width(),
                height: default_height(),
                center: None,
            }),
            Some(("firecastrl", files)) => {
                let (land_cover, heightmap) = files
                    .split_once(',')
                    .ok_or_else(|| bad("expected firecastrl:LAND_COVER.png,HEIGHTMAP.png"))?;
                Ok(Self::Firecastrl {
                    land_cover: land_cover.trim().into(),
                    heightmap: heightmap.trim().into(),
                })
            }
            _ => Err(bad(
                "expected procedural:SEED, firecastrl:LAND_COVER.png,HEIGHTMAP.png or a mapping \
                 {\"procedural\": {...}} / {\"firecastrl\": {...}}",
            )),
        }
    }

    /// Builds the landscape (relative paths resolve against the working directory).
    pub fn load(&self) -> Result<Landscape, BindError> {
        Ok(match self {
            Self::Procedural {
                seed,
                width,
                height,
                center,
            } => {
                let base = procedural::ProceduralOptions::with_seed(*seed);
                let [center_lat, center_lon] = center.unwrap_or([base.center_lat, base.center_lon]);
                procedural::generate(&procedural::ProceduralOptions {
                    width: *width,
                    height: *height,
                    center_lat,
                    center_lon,
                    ..base
                })?
            }
            Self::Firecastrl {
                land_cover,
                heightmap,
            } => firecastrl::load(land_cover, heightmap, &firecastrl::FireCastRlOptions::default())?,
        })
    }
}

/// Deserialises `value` strictly, naming the key path of the first problem under `root`.
fn from_value<T: for<'de> Deserialize<'de>>(root: &str, value: serde_json::Value) -> Result<T, BindError> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let key = if path == "." || path.is_empty() {
            root.to_string()
        } else {
            format!("{root}.{path}")
        };
        BindError::invalid(key, e.into_inner().to_string())
    })
}

/// The environment configuration: `config_json` (a JSON object of [`EnvConfig`] keys, all
/// optional) with the reward of `profile`. A profile and an explicit `reward` exclude each
/// other; with neither the reward is P2's.
pub fn env_config(config_json: Option<&str>, profile: Option<&str>) -> Result<EnvConfig, BindError> {
    let value = match config_json {
        None => serde_json::Value::Object(serde_json::Map::new()),
        Some(text) => serde_json::from_str(text)
            .map_err(|e| BindError::invalid("config", format!("not valid JSON: {e}")))?,
    };
    let Some(map) = value.as_object() else {
        return Err(BindError::invalid(
            "config",
            format!("expected a mapping of EnvConfig keys, got {value}"),
        ));
    };
    let explicit_reward = map.contains_key("reward");
    let mut cfg: EnvConfig = from_value("config", value)?;
    if let Some(name) = profile {
        if explicit_reward {
            return Err(BindError::invalid(
                "profile",
                format!(
                    "`{name}` and config.reward both set the reward: give one (config.reward starts \
                     from p2's weights)"
                ),
            ));
        }
        cfg.reward = RewardWeights::preset(name).ok_or_else(|| {
            BindError::invalid(
                "profile",
                format!("unknown profile `{name}` (use one of {})", PROFILES.join(", ")),
            )
        })?;
    }
    if cfg.max_steps == 0 {
        return Err(BindError::invalid("config.max_steps", "must be at least 1"));
    }
    Ok(cfg)
}
