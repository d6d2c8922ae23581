//! Ignition forecasting for FireCast: the experiments behind Table III, done so a reviewer
//! would accept them.
//!
//! - [`spec`]: experiment files (`experiments/*.yaml`), strict;
//! - [`data`], [`split`], [`features`]: a dataset folder → protocols (the paper's random
//!   split with days −60..+14, and the leak-free temporal split with inputs before the date)
//!   → model inputs;
//! - [`models`]: every model behind one interface ([`inputs`]) — no-skill and cheap references
//!   (majority, climatology, the fire-danger index, MiniRocket, boosted window statistics),
//!   the paper's flattened baselines (pure Rust in `firecast-baselines`, the real XGBoost in
//!   `firecast-xgboost`), and the networks of [`neural`] in `tch`;
//! - [`experiment`]: fit, threshold on validation, score the test side once, bootstrap
//!   intervals over GRIDMET cells, paired tests;
//! - [`table`], [`plots`]: Table III (Markdown, CSV, JSON), DVC metrics and plot files, PNG
//!   plots; [`bundle`]: fitted models on disk; [`predict`]: a model asked about a place
//!   and a date; [`evaluate`]: saved models scored on another dataset; [`stage`]: the
//!   `forecast.experiment`, `forecast.evaluate` and `forecast.predict` pipeline stage kinds;
//!   [`shard`]: `forecast.experiment` sharded by training unit (protocol × model × seed).

use std::path::{Path, PathBuf};

pub mod bundle;
pub mod cell_days;
pub mod daily;
pub mod data;
pub mod evaluate;
pub mod experiment;
pub mod features;
pub mod inputs;
pub mod minirocket;
pub mod models;
pub mod neural;
pub mod plots;
pub mod predict;
pub mod shard;
pub mod spec;
pub mod split;
pub mod stage;
pub mod table;

/// Errors of forecasting. Each names the file, key or model at fault.
#[derive(Debug, thiserror::Error)]
pub enum ForecastError {
    #[error("{context} {}: {source}", path.display())]
    Io {
        context: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: {message}", path.display())]
    Data { path: PathBuf, message: String },
    #[error("dataset {}: {source}", path.display())]
    Dataset {
        path: PathBuf,
        #[source]
        source: Box<firecast_dataset::DatasetError>,
    },
    #[error(transparent)]
    Spec(Box<firecast_pipeline::SpecError>),
    #[error("`{key}`: {message}")]
    Config { key: String, message: String },
    /// A [`ForecastError::Config`] of an experiment file, with the line its key is on.
    #[error("{}:{line}:{column}: `{key}`: {message}", path.display())]
    ConfigAt {
        path: PathBuf,
        line: usize,
        column: usize,
        key: String,
        message: String,
    },
    #[error("unknown model kind `{kind}`")]
    UnknownModel { kind: String },
    #[error("{0}")]
    Model(String),
    #[error("model `{model}`: {source}")]
    InModel {
        model: String,
        #[source]
        source: Box<ForecastError>,
    },
}

impl ForecastError {
    /// An I/O error on `path` while `context`, for `map_err`; public for the benchmark harness.
    pub fn io<'a>(
        context: &'static str,
        path: &'a Path,
    ) -> impl FnOnce(std::io::Error) -> ForecastError + 'a {
        move |source| ForecastError::Io {
            context,
            path: path.to_path_buf(),
            source,
        }
    }

    pub(crate) fn dataset(path: &Path, source: firecast_dataset::DatasetError) -> Self {
        ForecastError::Dataset {
            path: path.to_path_buf(),
            source: Box::new(source),
        }
    }

    /// Names the model a failure belongs to.
    pub fn in_model(self, model: &str) -> Self {
        ForecastError::InModel {
            model: model.into(),
            source: Box::new(self),
        }
    }
}

impl From<firecast_pipeline::SpecError> for ForecastError {
    fn from(e: firecast_pipeline::SpecError) -> Self {
        ForecastError::Spec(Box::new(e))
    }
}

/// Parses `auto`, `cpu`, `cuda` or `cuda:N` (see [`firecast_learn::parse_device`]).
pub fn parse_device(s: &str) -> Result<tch::Device, ForecastError> {
    firecast_learn::parse_device(s).map_err(|message| ForecastError::Config {
        key: "device".into(),
        message,
    })
}
