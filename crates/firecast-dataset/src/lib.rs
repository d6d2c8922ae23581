//! FireCast ignition datasets (stage A of FireCastRL, done properly):
//!
//! 1. [`sampling::dedup_ignitions`]: IRWIN/WFIGS reports → de-duplicated ignitions;
//! 2. [`sampling::sample_negatives`]: three negative tiers (far, near, yearly), paper or
//!    code variant, seeded;
//! 3. [`windows::extract`]: GRIDMET weather windows, one pass per file;
//! 4. [`dataset::build`]: a framing (`paper` or `forecast`), leak-free splits, normalisation
//!    statistics from the training split, a version id, a dataset card and a map;
//! 5. [`kaggle`]: the published FireCastRL CSV in and out; [`publish`]: a published folder
//!    (tables per split, Croissant 1.1, a Hugging Face card and Kaggle's metadata, all from
//!    one [`publish::Publication`]) and its check;
//! 6. [`truth`]: for synthetic sources, the generator's true ignition probability per
//!    sample (the oracle of a forecasting experiment; never a feature).
//!
//! Tables are Parquet (arrow-rs); the card's statistics are computed with polars.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

pub mod card;
pub mod dataset;
pub mod folder;
pub mod geo;
pub mod kaggle;
pub mod land;
pub mod publish;
pub mod sampling;
pub mod sha256;
pub mod stage;
pub mod table;
pub mod time;
pub mod truth;
pub mod windows;
mod windows_shard;

/// What kind of sample a row is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Tier {
    /// A de-duplicated ignition.
    Positive,
    /// ≥ 100 km from every ignition, any time in the period.
    Far,
    /// Within 100 km of an ignition, shifted by months.
    Near,
    /// The place of an ignition, whole years earlier.
    Yearly,
    /// Imported without tier information (the Kaggle CSV): positive windows.
    ImportedPositive,
    /// Imported negative windows.
    ImportedNegative,
}

impl Tier {
    pub const ALL: [Tier; 6] = [
        Tier::Positive,
        Tier::Far,
        Tier::Near,
        Tier::Yearly,
        Tier::ImportedPositive,
        Tier::ImportedNegative,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            Tier::Positive => "positive",
            Tier::Far => "far",
            Tier::Near => "near",
            Tier::Yearly => "yearly",
            Tier::ImportedPositive => "imported_positive",
            Tier::ImportedNegative => "imported_negative",
        }
    }

    pub fn parse(s: &str) -> Option<Tier> {
        Tier::ALL.into_iter().find(|t| t.as_str() == s)
    }

    /// Whether a fire was recorded at the sample's place and date.
    pub fn is_positive(self) -> bool {
        matches!(self, Tier::Positive | Tier::ImportedPositive)
    }
}

/// Errors of dataset building. Every variant names the file, key or variable at fault.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    #[error("{context} {}: {source}", path.display())]
    Io {
        context: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Gridmet(#[from] firecast_data::gridmet::GridmetError),
    #[error(transparent)]
    Store(#[from] firecast_store::StoreError),
    #[error(transparent)]
    Incidents(#[from] firecast_data::incidents::IncidentError),
    #[error("{}: {message}", path.display())]
    Input { path: PathBuf, message: String },
    #[error("{}:{line}: {message}", path.display())]
    InputLine {
        path: PathBuf,
        line: u64,
        message: String,
    },
    #[error("missing {what}: {} does not exist", path.display())]
    MissingSource { path: PathBuf, what: String },
    #[error("`{key}`: {message}")]
    Config { key: String, message: String },
    #[error("Parquet {}: {message}", path.display())]
    Parquet { path: PathBuf, message: String },
    /// A file of a dataset whose contents no longer match the hash its manifest holds.
    #[error("damaged dataset file {}: {message}", path.display())]
    Damaged { path: PathBuf, message: String },
    #[error("polars: {0}")]
    Polars(String),
    /// Shards of a sharded stage that do not fit together, or an error a shard carried over.
    #[error("{0}")]
    Shard(String),
}

impl DatasetError {
    /// An I/O error on `path` while `context` (`"reading"`, …), for `map_err`; public for the
    /// benchmark harness's reference runs.
    pub fn io<'a>(context: &'static str, path: &'a Path) -> impl FnOnce(std::io::Error) -> DatasetError + 'a {
        move |source| DatasetError::Io {
            context,
            path: path.to_path_buf(),
            source,
        }
    }
}

impl From<firecast_fs::FsError> for DatasetError {
    fn from(e: firecast_fs::FsError) -> Self {
        Self::Io {
            context: e.op,
            path: e.path,
            source: e.source,
        }
    }
}

/// BLAKE3 of a file, hex.
pub fn hash_file(path: &Path) -> Result<String, DatasetError> {
    let mut hasher = blake3::Hasher::new();
    let mut file = std::fs::File::open(path).map_err(DatasetError::io("hashing", path))?;
    std::io::copy(&mut file, &mut hasher).map_err(DatasetError::io("hashing", path))?;
    Ok(hasher.finalize().to_hex().to_string())
}

/// Fisher–Yates with our own draws, so an order never depends on a library's algorithm.
pub(crate) fn shuffle<T>(items: &mut [T], rng: &mut rand_chacha::ChaCha8Rng) {
    use rand::Rng;
    for i in (1..items.len()).rev() {
        let j = rng.random_range(0..=i);
        items.swap(i, j);
    }
}
