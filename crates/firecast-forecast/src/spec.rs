//! Experiment specs (`experiments/*.yaml`): strict, like pipelines. An unknown key is an error
//! naming the file, line and key path.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::ForecastError;
// Defined beside the models' default rule (`ModelConfig::default_threshold`); experiment
// files name it here.
use crate::models::ThresholdRule;

/// A whole experiment: one dataset, one or more protocols, models, seeds, evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentSpec {
    /// Experiment name (registry key, output folder name).
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// Dataset folder (relative to the project root). A pipeline stage takes it from its
    /// `dataset` input instead.
    #[serde(default)]
    pub dataset: Option<PathBuf>,
    /// Protocols by name; every model is evaluated under each.
    #[serde(default = "default_protocols")]
    pub protocols: BTreeMap<String, Protocol>,
    /// The protocol whose table is printed first and whose best model is tested against
    /// the best baseline. Default: `leak_free` when present.
    #[serde(default)]
    pub headline: Option<String>,
    pub models: Vec<ModelEntry>,
    /// Seeds for models with random training (≥ 3 for neural models is the honest minimum).
    #[serde(default = "default_seeds")]
    pub seeds: Vec<u64>,
    #[serde(default)]
    pub evaluation: Evaluation,
    /// Torch device: `auto` (CUDA when present), `cpu`, `cuda`, `cuda:N`.
    #[serde(default = "default_device")]
    pub device: String,
    /// libtorch threads (and XGBoost's `nthread` where a model names none). Part of the
    /// result, so part of the cache key; fixed default, not the machine's core count.
    #[serde(default = "firecast_learn::default_threads")]
    pub threads: usize,
}

fn default_seeds() -> Vec<u64> {
    vec![0, 1, 2]
}
fn default_device() -> String {
    "auto".into()
}

/// The paper's protocol and the leak-free one.
pub fn default_protocols() -> BTreeMap<String, Protocol> {
    BTreeMap::from([
        (
            "paper".to_string(),
            Protocol {
                days: (-60, 14),
                split: Split::StratifiedRandom {
                    test: 0.30,
                    val: 0.20,
                    seed: 42,
                    grouped: false,
                },
            },
        ),
        (
            "leak_free".to_string(),
            Protocol {
                days: (-60, -1),
                split: Split::Temporal {
                    test_from: None,
                    test_months: 4,
                    val: 0.15,
                    seed: 42,
                },
            },
        ),
    ])
}

/// Which days are inputs and how samples are split.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Protocol {
    /// Inclusive day offsets relative to the predicted date: `[-60, 14]` is the paper's
    /// window (it sees the 15 days after the ignition), `[-60, -1]` a real forecast.
    pub days: (i32, i32),
    pub split: Split,
}

/// How samples are divided into train, validation and test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "method", deny_unknown_fields)]
pub enum Split {
    /// The split stored in the dataset.
    Dataset,
    /// The authors' `train_test_split`: test share stratified by label, then validation as
    /// a share of the rest. `grouped: false` splits windows (as the authors did, so windows
    /// of the same place and season land on both sides); `true` keeps overlapping windows
    /// of one cell together.
    StratifiedRandom {
        #[serde(default = "default_test_share")]
        test: f64,
        #[serde(default = "default_val_share")]
        val: f64,
        #[serde(default = "default_split_seed")]
        seed: u64,
        #[serde(default)]
        grouped: bool,
    },
    /// Test = samples on or after `test_from` (default: the last `test_months` months with
    /// samples, like the paper's January–April 2025 test); validation = a stratified share of
    /// the earlier cell groups. Windows of a cell that overlap the cutoff are dropped from
    /// training rather than leaked.
    Temporal {
        #[serde(default)]
        test_from: Option<String>,
        #[serde(default = "default_test_months")]
        test_months: u32,
        #[serde(default = "default_temporal_val")]
        val: f64,
        #[serde(default = "default_split_seed")]
        seed: u64,
    },
    /// Spatial blocks of `block_degrees`; a seeded share of blocks is test, another share
    /// validation. No cell is on two sides.
    SpatialBlocks {
        #[serde(default = "default_block")]
        block_degrees: f64,
        #[serde(default = "default_block_test")]
        test: f64,
        #[serde(default = "default_temporal_val")]
        val: f64,
        #[serde(default = "default_split_seed")]
        seed: u64,
    },
}

fn default_test_share() -> f64 {
    0.30
}
fn default_val_share() -> f64 {
    0.20
}
fn default_split_seed() -> u64 {
    42
}
fn default_test_months() -> u32 {
    4
}
fn default_temporal_val() -> f64 {
    0.15
}
fn default_block() -> f64 {
    0.5
}
fn default_block_test() -> f64 {
    0.25
}

/// One model of the comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelEntry {
    /// Row label in the table; default: the kind.
    #[serde(default)]
    pub name: Option<String>,
    /// One of [`crate::models::KINDS`].
    pub kind: String,
    /// The kind's hyper-parameters (strict: an unknown key is an error).
    #[serde(default)]
    pub params: serde_json::Value,
    /// How the decision threshold is chosen, on validation scores only.
    #[serde(default)]
    pub threshold: Option<ThresholdRule>,
}

impl ModelEntry {
    pub fn label(&self) -> String {
        self.name.clone().unwrap_or_else(|| self.kind.clone())
    }
}

/// Metrics and intervals.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Evaluation {
    /// Bootstrap resamples for the 95 % intervals (≥ 1000 for a report).
    #[serde(default = "default_resamples")]
    pub bootstrap: usize,
    /// Interval level.
    #[serde(default = "default_level")]
    pub level: f64,
    /// Resample GRIDMET cells (correlated windows move together) or single samples.
    #[serde(default = "default_cluster")]
    pub cluster: ClusterBy,
    /// Reliability-diagram and ECE bins.
    #[serde(default = "default_bins")]
    pub calibration_bins: usize,
    #[serde(default = "default_eval_seed")]
    pub seed: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ClusterBy {
    Cell,
    Sample,
}

fn default_resamples() -> usize {
    1000
}
fn default_level() -> f64 {
    0.95
}
fn default_cluster() -> ClusterBy {
    ClusterBy::Cell
}
fn default_bins() -> usize {
    10
}
fn default_eval_seed() -> u64 {
    2025
}

impl Default for Evaluation {
    fn default() -> Self {
        Self {
            bootstrap: default_resamples(),
            level: default_level(),
            cluster: default_cluster(),
            calibration_bins: default_bins(),
            seed: default_eval_seed(),
        }
    }
}

impl ExperimentSpec {
    /// Reads and checks an experiment file; `overrides` are `key.path=value` (value as YAML).
    /// A file may start from another with `extends: FILE` (relative to its folder) and change
    /// only what differs (mappings merge; see [`firecast_pipeline::extends`]).
    pub fn load(root: &Path, file: &Path, overrides: &[String]) -> Result<Self, ForecastError> {
        let path = root.join(file);
        let text = std::fs::read_to_string(&path).map_err(|e| ForecastError::Io {
            context: "reading the experiment",
            path: path.clone(),
            source: e,
        })?;
        let extends = serde_yaml_ng::from_str::<serde_yaml_ng::Value>(&text)
            .ok()
            .is_some_and(|v| v.get("extends").is_some());
        if extends {
            let mut layered = firecast_pipeline::extends::load(root, file)?;
            for o in overrides {
                apply_override(&mut layered.value, o)?;
            }
            let spec: ExperimentSpec = layered.deserialize()?;
            spec.validate().map_err(|e| match e {
                ForecastError::Config { key, message } => ForecastError::from(layered.error(key, message)),
                other => other,
            })?;
            return Ok(spec);
        }
        let spec: ExperimentSpec = if overrides.is_empty() {
            firecast_pipeline::spec::deserialize_mapping_enums(file, &text)?
        } else {
            let mut value: serde_yaml_ng::Value = firecast_pipeline::spec::deserialize_located(file, &text)?;
            for o in overrides {
                apply_override(&mut value, o)?;
            }
            let merged = serde_yaml_ng::to_string(&value).map_err(|e| ForecastError::Config {
                key: String::new(),
                message: e.to_string(),
            })?;
            firecast_pipeline::spec::deserialize_mapping_enums(file, &merged)?
        };
        // Checks beyond the types name the file and the line of the key they refuse.
        spec.validate().map_err(|e| match e {
            ForecastError::Config { key, message } => match firecast_pipeline::locate_path(&text, &key) {
                Some((line, column)) => ForecastError::ConfigAt {
                    path: file.to_path_buf(),
                    line,
                    column,
                    key,
                    message,
                },
                None => ForecastError::Config { key, message },
            },
            other => other,
        })?;
        Ok(spec)
    }

    /// Checks that go beyond the types: names, seeds, shares, and every model's params.
    pub fn validate(&self) -> Result<(), ForecastError> {
        let bad = |key: &str, message: String| ForecastError::Config {
            key: key.into(),
            message,
        };
        if self.name.trim().is_empty() || self.name.contains('/') {
            return Err(bad("name", "must be a non-empty name without `/`".into()));
        }
        firecast_learn::check_threads(self.threads).map_err(|m| bad("threads", m))?;
        if self.models.is_empty() {
            return Err(bad("models", "the experiment names no model".into()));
        }
        if self.protocols.is_empty() {
            return Err(bad("protocols", "the experiment names no protocol".into()));
        }
        if let Some(h) = &self.headline
            && !self.protocols.contains_key(h)
        {
            return Err(bad("headline", format!("`{h}` is not one of the protocols")));
        }
        if self.seeds.is_empty() {
            return Err(bad("seeds", "give at least one seed".into()));
        }
        if self.evaluation.bootstrap == 0 {
            return Err(bad("evaluation.bootstrap", "must be at least 1".into()));
        }
        if !(0.5..1.0).contains(&self.evaluation.level) {
            return Err(bad(
                "evaluation.level",
                format!("{} is not in [0.5, 1)", self.evaluation.level),
            ));
        }
        for (name, p) in &self.protocols {
            let check = |key: &str, v: f64| {
                if (0.0..1.0).contains(&v) && v > 0.0 {
                    Ok(())
                } else {
                    Err(bad(
                        &format!("protocols.{name}.split.{key}"),
                        format!("{v} is not in (0, 1)"),
                    ))
                }
            };
            match &p.split {
                Split::Dataset => {}
                Split::StratifiedRandom { test, val, .. } => {
                    check("test", *test)?;
                    check("val", *val)?;
                }
                Split::Temporal { val, .. } => check("val", *val)?,
                Split::SpatialBlocks {
                    test,
                    val,
                    block_degrees,
                    ..
                } => {
                    check("test", *test)?;
                    check("val", *val)?;
                    if *block_degrees <= 0.0 {
                        return Err(bad(
                            &format!("protocols.{name}.split.block_degrees"),
                            "must be positive".into(),
                        ));
                    }
                }
            }
        }
        let mut labels = std::collections::BTreeSet::new();
        for (i, m) in self.models.iter().enumerate() {
            let key = format!("models[{i}]");
            crate::models::ModelConfig::parse(&m.kind, &m.params).map_err(|e| match e {
                ForecastError::Config { key: k, message } => ForecastError::Config {
                    key: if k.is_empty() {
                        format!("{key}.params")
                    } else {
                        format!("{key}.params.{k}")
                    },
                    message,
                },
                ForecastError::UnknownModel { kind } => ForecastError::Config {
                    key: format!("{key}.kind"),
                    message: format!(
                        "unknown model `{kind}`; known: {}",
                        crate::models::KINDS.join(", ")
                    ),
                },
                other => other,
            })?;
            if !labels.insert(m.label()) {
                return Err(bad(
                    &format!("{key}.name"),
                    format!("`{}` appears twice", m.label()),
                ));
            }
            if let Some(ThresholdRule::Fixed(t)) = m.threshold
                && !(0.0..=1.0).contains(&t)
            {
                return Err(bad(
                    &format!("{key}.threshold.fixed"),
                    format!("{t} is not in [0, 1]"),
                ));
            }
        }
        Ok(())
    }

    /// The headline protocol: the named one, else `leak_free`, else the first.
    pub fn headline_protocol(&self) -> &str {
        if let Some(h) = &self.headline {
            return h;
        }
        if self.protocols.contains_key("leak_free") {
            return "leak_free";
        }
        self.protocols.keys().next().map_or("", String::as_str)
    }
}

/// `a.b.c=value` (see [`firecast_pipeline::spec::apply_override`]).
pub fn apply_override(root: &mut serde_yaml_ng::Value, text: &str) -> Result<(), ForecastError> {
    firecast_pipeline::spec::apply_override(root, text).map_err(|e| ForecastError::Config {
        key: e.path,
        message: e.message,
    })
}
