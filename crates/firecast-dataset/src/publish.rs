//! Publishing a dataset: one typed [`Publication`], derived from the dataset's manifest
//! (name, version, framing, splits), its card statistics (`stats.json`: samples, positives
//! and dates per split and tier) and the schema of the Parquet files actually written, is
//! rendered three ways into the published folder:
//!
//! - `croissant.json`: Croissant 1.1 JSON-LD (files with SHA-256, record sets with one field
//!   per column, the splits as a `cr:Split` record set, the responsible-AI fields);
//! - `README.md`: a Hugging Face dataset card (YAML front matter: licence, tags, one config
//!   per table with a data file per split, the features; then the card);
//! - `dataset-metadata.json`: Kaggle's metadata, checked against the kaggle client's rules.
//!
//! The tables are published one file per table and split (`samples-train.parquet`,
//! `days-test.parquet`, …, flat, since `kaggle datasets create` skips folders), beside the
//! FireCastRL CSV for a `paper`-framed dataset, the card, the map and the normalisation.
//! The folder is assembled under a temporary name, read back and compared with the dataset
//! before it is renamed into place; [`verify`] checks a published folder later.

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use crate::DatasetError;
use crate::card::{FeatureStats, TierCount};
use crate::dataset::{DatasetManifest, FramingKind};
use crate::kaggle::{KaggleLicense, KaggleMetadata, KaggleResource, KaggleSchema};
use crate::table::StoredTable;
use crate::windows::{PAPER_FEATURES, WindowTable};

pub const CROISSANT_FILE: &str = "croissant.json";
pub const HF_CARD_FILE: &str = "README.md";
pub const KAGGLE_FILE: &str = "dataset-metadata.json";
pub const CSV_FILE: &str = "Wildfire_Dataset.csv";
/// `conformsTo` of the Croissant file.
pub const CROISSANT_1_1: &str = "http://mlcommons.org/croissant/1.1";
/// The published tables, in order.
pub const TABLES: [&str; 2] = ["samples", "days"];

/// File of `table` for `split`.
pub fn table_file(table: &str, split: &str) -> String {
    format!("{table}-{split}.parquet")
}

/// Publishing settings (a `--config` YAML file or flags).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PublishConfig {
    /// `<owner>/<dataset-slug>` (Kaggle's id; also the Hugging Face repo name).
    pub id: String,
    pub title: String,
    #[serde(default)]
    pub subtitle: Option<String>,
    /// A Kaggle licence name ([`crate::kaggle::LICENSES`]).
    #[serde(default = "default_license")]
    pub license: String,
    #[serde(default)]
    pub keywords: Vec<String>,
    /// Who made the dataset (Croissant `creator`, the citation's author).
    #[serde(default = "default_creator")]
    pub creator: String,
    /// Landing page. Default: the Kaggle page of `id`.
    #[serde(default)]
    pub url: Option<String>,
    /// Release number, `MAJOR.MINOR.PATCH`; Croissant's `version` is this plus the dataset's
    /// content version as build metadata (`1.0.0+v…`).
    #[serde(default = "default_release")]
    pub release: String,
    /// How to cite the dataset (BibTeX). Default: one built from title, creator, id and version.
    #[serde(default)]
    pub citation: Option<String>,
    /// Publication date (`YYYY-MM-DD`, Croissant's `datePublished`). Default: today (UTC).
    #[serde(default)]
    pub date_published: Option<String>,
    /// Whether the data are synthetic. Default: from the dataset (a dataset built from
    /// synthetic sources carries the generator's truth).
    #[serde(default)]
    pub synthetic: Option<bool>,
}

fn default_license() -> String {
    "CC-BY-4.0".into()
}
fn default_creator() -> String {
    "FireCast".into()
}
fn default_release() -> String {
    "1.0.0".into()
}

/// One licence in the three vocabularies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct License {
    pub kaggle: &'static str,
    /// SPDX id, where the licence has one.
    pub spdx: Option<&'static str>,
    /// Hugging Face's licence id.
    pub hf: &'static str,
}

const LICENSE_TABLE: [License; 14] = [
    lic("CC0-1.0", Some("CC0-1.0"), "cc0-1.0"),
    lic("CC-BY-4.0", Some("CC-BY-4.0"), "cc-by-4.0"),
    lic("CC-BY-SA-4.0", Some("CC-BY-SA-4.0"), "cc-by-sa-4.0"),
    lic("CC-BY-NC-SA-4.0", Some("CC-BY-NC-SA-4.0"), "cc-by-nc-sa-4.0"),
    lic("ODbL-1.0", Some("ODbL-1.0"), "odbl"),
    lic("PDDL", Some("PDDL-1.0"), "pddl"),
    lic("ODC-BY-1.0", Some("ODC-By-1.0"), "odc-by"),
    lic("US-Government-Works", None, "other"),
    lic(
        "CDLA-Permissive-1.0",
        Some("CDLA-Permissive-1.0"),
        "cdla-permissive-1.0",
    ),
    lic("apache-2.0", Some("Apache-2.0"), "apache-2.0"),
    lic("GPL-2.0", Some("GPL-2.0-only"), "gpl-2.0"),
    lic("GPL-3.0", Some("GPL-3.0-only"), "gpl-3.0"),
    lic("other", None, "other"),
    lic("unknown", None, "unknown"),
];

const fn lic(kaggle: &'static str, spdx: Option<&'static str>, hf: &'static str) -> License {
    License { kaggle, spdx, hf }
}

impl License {
    pub fn from_kaggle(name: &str) -> Option<License> {
        LICENSE_TABLE.iter().copied().find(|l| l.kaggle == name)
    }

    /// Croissant's `license`: the SPDX page, or the name where there is none.
    pub fn croissant(self) -> String {
        match self.spdx {
            Some(id) => format!("https://spdx.org/licenses/{id}.html"),
            None => self.kaggle.to_string(),
        }
    }
}

/// A column type, with its spelling in each of the three files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ColumnType {
    Bool,
    Int32,
    UInt32,
    UInt64,
    Float32,
    Float64,
    Date,
    Timestamp,
    Text,
}

impl ColumnType {
    pub fn from_arrow(dt: &arrow::datatypes::DataType) -> Option<ColumnType> {
        use arrow::datatypes::DataType as D;
        Some(match dt {
            D::Boolean => ColumnType::Bool,
            D::Int32 => ColumnType::Int32,
            D::UInt32 => ColumnType::UInt32,
            D::UInt64 => ColumnType::UInt64,
            D::Float32 => ColumnType::Float32,
            D::Float64 => ColumnType::Float64,
            D::Date32 => ColumnType::Date,
            D::Timestamp(_, _) => ColumnType::Timestamp,
            D::Utf8 | D::LargeUtf8 | D::Utf8View => ColumnType::Text,
            _ => return None,
        })
    }

    /// Croissant `dataType`.
    pub fn croissant(self) -> &'static str {
        match self {
            ColumnType::Bool => "sc:Boolean",
            ColumnType::Int32 => "cr:Int32",
            ColumnType::UInt32 => "cr:UInt32",
            ColumnType::UInt64 => "cr:UInt64",
            ColumnType::Float32 => "cr:Float32",
            ColumnType::Float64 => "cr:Float64",
            ColumnType::Date => "sc:Date",
            ColumnType::Timestamp => "sc:DateTime",
            ColumnType::Text => "sc:Text",
        }
    }

    /// Hugging Face `dtype` (the Arrow type `datasets` reads).
    pub fn hf(self) -> &'static str {
        match self {
            ColumnType::Bool => "bool",
            ColumnType::Int32 => "int32",
            ColumnType::UInt32 => "uint32",
            ColumnType::UInt64 => "uint64",
            ColumnType::Float32 => "float32",
            ColumnType::Float64 => "float64",
            ColumnType::Date => "date32",
            ColumnType::Timestamp => "timestamp[ms, tz=UTC]",
            ColumnType::Text => "string",
        }
    }

    /// Kaggle field `type` of a column named `name`.
    pub fn kaggle(self, name: &str) -> &'static str {
        match (name, self) {
            ("latitude" | "cell_latitude", _) => "latitude",
            ("longitude" | "cell_longitude", _) => "longitude",
            (_, ColumnType::Bool) => "boolean",
            (_, ColumnType::Int32 | ColumnType::UInt32 | ColumnType::UInt64) => "integer",
            (_, ColumnType::Float32 | ColumnType::Float64) => "numeric",
            (_, ColumnType::Date | ColumnType::Timestamp) => "datetime",
            (_, ColumnType::Text) => "string",
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Column {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: ColumnType,
    pub nullable: bool,
    pub description: String,
}

/// A published table: its columns as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableSchema {
    pub name: String,
    pub description: String,
    pub columns: Vec<Column>,
}

/// A split as the card counts it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SplitSummary {
    pub name: String,
    pub samples: u64,
    pub positives: u64,
    pub day_rows: u64,
    pub first_date: String,
    pub last_date: String,
    /// Samples per tier.
    pub tiers: BTreeMap<String, u64>,
}

impl SplitSummary {
    /// Croissant's well-known split, where there is one.
    fn croissant_url(&self) -> Option<&'static str> {
        match self.name.as_str() {
            crate::dataset::TRAIN => Some("cr:TrainingSplit"),
            crate::dataset::VAL => Some("cr:ValidationSplit"),
            crate::dataset::TEST => Some("cr:TestSplit"),
            _ => None,
        }
    }

    fn description(&self) -> String {
        let tiers: Vec<String> = self.tiers.iter().map(|(t, n)| format!("{t} {n}")).collect();
        format!(
            "{} samples ({} positive, prevalence {:.3}; tiers: {}), {} day rows, {} to {}",
            self.samples,
            self.positives,
            self.positives as f64 / self.samples.max(1) as f64,
            tiers.join(", "),
            self.day_rows,
            self.first_date,
            self.last_date
        )
    }
}

/// A file of the published folder.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PublishedFile {
    pub path: String,
    pub encoding_format: String,
    pub sha256: String,
    pub bytes: u64,
    pub description: String,
    /// The table and split it holds, for the tables.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub table: Option<(String, String)>,
}

/// The responsible-AI text of the Croissant file (and the card's sections of the same name).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Rai {
    pub data_collection: String,
    pub data_collection_type: String,
    /// First and last date of the samples.
    pub data_collection_timeframe: (String, String),
    pub data_collection_missing_data: String,
    pub data_collection_raw_data: String,
    pub preprocessing: String,
    pub data_limitations: String,
    pub data_biases: String,
    pub personal_sensitive_information: String,
    pub data_use_cases: String,
    pub data_social_impact: String,
}

/// Everything the three metadata files say, in one place.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Publication {
    /// Registry name of the dataset.
    pub name: String,
    pub id: String,
    pub title: String,
    pub subtitle: Option<String>,
    /// The dataset's content version (`v` + 16 hex digits).
    pub content_version: String,
    /// Croissant's semantic version: release + content version.
    pub version: String,
    pub date_published: String,
    pub license: String,
    pub keywords: Vec<String>,
    pub creator: String,
    pub url: String,
    pub citation: String,
    pub synthetic: bool,
    /// One paragraph: what the dataset is (and, when synthetic, that it is).
    pub summary: String,
    /// The dataset card (Markdown).
    pub card: String,
    pub framing: FramingKind,
    pub day_offsets: (i32, i32),
    pub features: Vec<String>,
    pub splits: Vec<SplitSummary>,
    pub tables: Vec<TableSchema>,
    pub files: Vec<PublishedFile>,
    /// The FireCastRL CSV (paper framing), with its rows.
    pub csv: Option<(PublishedFile, u64)>,
    pub rai: Rai,
}

/// The synthetic-data notice, word for word in all three files.
pub const SYNTHETIC_NOTICE: &str = "SYNTHETIC DATA: every ignition, place and weather value in this \
     dataset was made by FireCast's seeded generator (a WFIGS-style incident file and GRIDMET-style \
     NetCDF weather); no record describes a real fire. It is a test bed for methods, not a record of \
     wildfires.";

/// What each published column holds.
fn column_description(table: &str, name: &str) -> String {
    match (table, name) {
        ("samples", "sample_id") => "Sample id (unique; `days.sample_id` refers to it)".into(),
        ("samples", "latitude") => "Sample latitude (WGS84 degrees)".into(),
        ("samples", "longitude") => "Sample longitude (WGS84 degrees)".into(),
        ("samples", "event_time") => {
            "The sample's instant (UTC): the ignition's report time for a positive".into()
        }
        ("samples", "event_date") => "GRIDMET day of the sample: the date a model predicts".into(),
        ("samples", "tier") => "How the sample was drawn: positive, far, near or yearly negative \
                                (imported_positive, imported_negative for the Kaggle CSV)"
            .into(),
        ("samples", "label") => "True when an ignition was recorded at this place on this date".into(),
        ("samples", "source_row") => {
            "Row of the incident file the ignition came from; empty for negatives".into()
        }
        ("samples", "cell_row") => "GRIDMET grid row of the sample".into(),
        ("samples", "cell_col") => "GRIDMET grid column of the sample".into(),
        ("samples", "cell_latitude") => "Latitude of the GRIDMET cell's centre".into(),
        ("samples", "cell_longitude") => "Longitude of the GRIDMET cell's centre".into(),
        ("samples", "split") => {
            "train, val or test (leak-free: a group of overlapping windows never straddles two)".into()
        }
        ("samples", crate::truth::TRUE_PROBABILITY_COLUMN) => {
            "The synthetic generator's true probability of an ignition at the sample's cell on its \
             date (the oracle): NOT a feature, never a model input"
                .into()
        }
        ("days", "sample_id") => "The sample (`samples.sample_id`)".into(),
        ("days", "day_index") => "Row of the window, 0 first".into(),
        ("days", "day_offset") => "Days from the sample's date".into(),
        ("days", "date") => "Calendar day of this row".into(),
        ("days", "wildfire") => "The row label of the published CSV: true on and after the ignition day \
                                 of a positive window"
            .into(),
        (_, other) => match firecast_data::gridmet::GridmetVariable::from_short_name(other) {
            Some(v) => format!(
                "GRIDMET `{other}` ({}); empty when GRIDMET has no value",
                v.units()
            ),
            None => format!("`{other}`"),
        },
    }
}

fn table_description(table: &str, n_days: usize) -> String {
    match table {
        "samples" => "One row per sample: place, date, tier, label, GRIDMET cell and split".into(),
        _ => format!(
            "One row per sample and day ({n_days} days a sample, in sample order): the row label \
             and one column per GRIDMET variable, empty where GRIDMET has no value"
        ),
    }
}

/// Hugging Face's size category of `n` rows.
fn size_category(n: u64) -> &'static str {
    match n {
        0..1_000 => "n<1K",
        1_000..10_000 => "1K<n<10K",
        10_000..100_000 => "10K<n<100K",
        100_000..1_000_000 => "100K<n<1M",
        1_000_000..10_000_000 => "1M<n<10M",
        10_000_000..100_000_000 => "10M<n<100M",
        _ => "100M<n<1B",
    }
}

/// The published splits, train/val/test first, from the card's per-tier counts.
fn split_summaries(manifest: &DatasetManifest, tiers: &[TierCount]) -> Vec<SplitSummary> {
    let n_days = (manifest.day_offsets.1 - manifest.day_offsets.0 + 1).max(0) as u64;
    let mut by: BTreeMap<String, SplitSummary> = BTreeMap::new();
    for t in tiers {
        let s = by.entry(t.split.clone()).or_insert_with(|| SplitSummary {
            name: t.split.clone(),
            samples: 0,
            positives: 0,
            day_rows: 0,
            first_date: t.first_date.clone(),
            last_date: t.last_date.clone(),
            tiers: BTreeMap::new(),
        });
        s.samples += t.samples;
        s.positives += t.positives;
        s.day_rows += t.samples * n_days;
        if t.first_date < s.first_date {
            s.first_date = t.first_date.clone();
        }
        if t.last_date > s.last_date {
            s.last_date = t.last_date.clone();
        }
        *s.tiers.entry(t.tier.clone()).or_default() += t.samples;
    }
    let rank = |n: &str| {
        [crate::dataset::TRAIN, crate::dataset::VAL, crate::dataset::TEST]
            .iter()
            .position(|x| *x == n)
            .unwrap_or(3)
    };
    let mut out: Vec<SplitSummary> = by.into_values().collect();
    out.sort_by(|a, b| (rank(&a.name), &a.name).cmp(&(rank(&b.name), &b.name)));
    out
}

/// Inputs of [`Publication::new`] that were measured on the staged folder.
pub struct Staged {
    pub tables: Vec<TableSchema>,
    pub files: Vec<PublishedFile>,
    pub csv: Option<(PublishedFile, u64)>,
}

impl Publication {
    /// The one description of a publication.
    pub fn new(
        manifest: &DatasetManifest,
        cfg: &PublishConfig,
        card: String,
        stats: &[FeatureStats],
        tiers: &[TierCount],
        staged: Staged,
    ) -> Result<Publication, DatasetError> {
        let license = License::from_kaggle(&cfg.license).ok_or_else(|| DatasetError::Config {
            key: "license".into(),
            message: format!(
                "unknown licence `{}` (known: {})",
                cfg.license,
                crate::kaggle::LICENSES.join(", ")
            ),
        })?;
        let release_ok = {
            let parts: Vec<&str> = cfg.release.split('.').collect();
            parts.len() == 3
                && parts.iter().all(|p| {
                    !p.is_empty()
                        && p.bytes().all(|b| b.is_ascii_digit())
                        && (p.len() == 1 || !p.starts_with('0'))
                })
        };
        if !release_ok {
            return Err(DatasetError::Config {
                key: "release".into(),
                message: format!("`{}` is not MAJOR.MINOR.PATCH", cfg.release),
            });
        }
        let date_published = match &cfg.date_published {
            Some(d) => match crate::time::parse_date(d) {
                Some(day) if crate::time::format_date(day) == d.trim() => d.trim().to_string(),
                _ => {
                    return Err(DatasetError::Config {
                        key: "date_published".into(),
                        message: format!("`{d}` is not a YYYY-MM-DD date"),
                    });
                }
            },
            None => {
                let secs = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_secs());
                crate::time::format_instant(secs as i64 * 1000)
                    .chars()
                    .take(10)
                    .collect()
            }
        };
        let synthetic = cfg.synthetic.unwrap_or(
            manifest.true_probability.is_some()
                || manifest.provenance.keys().any(|k| k.starts_with("truth ")),
        );
        let splits = split_summaries(manifest, tiers);
        let samples: u64 = splits.iter().map(|s| s.samples).sum();
        let positives: u64 = splits.iter().map(|s| s.positives).sum();
        let first = splits
            .iter()
            .map(|s| s.first_date.clone())
            .min()
            .unwrap_or_default();
        let last = splits
            .iter()
            .map(|s| s.last_date.clone())
            .max()
            .unwrap_or_default();
        let n_days = (manifest.day_offsets.1 - manifest.day_offsets.0 + 1) as u64;
        let framing = match manifest.framing.kind {
            FramingKind::Paper => {
                "the `paper` framing of the published FireCastRL CSV (days −60…+14 around each \
                                   sample's date; the inputs include the 15 days after an ignition)"
                    .to_string()
            }
            FramingKind::Forecast => format!(
                "the `forecast` framing ({} days of weather ending {} day(s) before the predicted date)",
                manifest.framing.window_days, manifest.framing.lead_days
            ),
        };
        let mut summary = format!(
            "{}: {samples} wildfire-ignition samples ({positives} positive) with {n_days} days of GRIDMET \
             weather each ({} variables), {first} to {last}, in {framing}; splits {}. Dataset version {}.",
            cfg.title,
            manifest.features.len(),
            splits
                .iter()
                .map(|s| format!("{} ({})", s.name, s.samples))
                .collect::<Vec<_>>()
                .join(", "),
            manifest.version
        );
        if synthetic {
            summary = format!("{SYNTHETIC_NOTICE} {summary}");
        }
        let url = cfg
            .url
            .clone()
            .unwrap_or_else(|| format!("https://www.kaggle.com/datasets/{}", cfg.id));
        let version = format!("{}+{}", cfg.release, manifest.version);
        let citation = cfg.citation.clone().unwrap_or_else(|| {
            let key: String = cfg
                .id
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                .collect();
            format!(
                "@misc{{{key},\n  title = {{{}}},\n  author = {{{}}},\n  note = {{Dataset version {version}{}}},\n  \
                 howpublished = {{\\url{{{url}}}}}\n}}",
                cfg.title,
                cfg.creator,
                if synthetic { "; synthetic data" } else { "" }
            )
        });
        let mut keywords = cfg.keywords.clone();
        for k in ["wildfire", "ignition", "gridmet", "tabular"] {
            if !keywords.iter().any(|x| x.eq_ignore_ascii_case(k)) {
                keywords.push(k.into());
            }
        }
        if synthetic && !keywords.iter().any(|x| x.eq_ignore_ascii_case("synthetic")) {
            keywords.push("synthetic".into());
        }
        let missing: u64 = stats.iter().map(|s| s.missing).sum();
        let values: u64 = stats.iter().map(|s| s.rows).sum();
        let prevalence: Vec<String> = splits
            .iter()
            .map(|s| format!("{} {:.3}", s.name, s.positives as f64 / s.samples.max(1) as f64))
            .collect();
        let rai = Rai {
            data_collection: if synthetic {
                "Synthetic sources: FireCast's seeded generator (`firecast dataset synthesize`) wrote a \
                 WFIGS-style incident CSV and GRIDMET-style NetCDF files over a region and years; ignitions \
                 are drawn from a known daily probability that depends on the weather and land. FireCast \
                 then de-duplicated the reported ignitions, drew negatives in tiers and read each sample's \
                 GRIDMET window."
                    .into()
            } else {
                "Secondary data: ignition reports (IRWIN/WFIGS incidents, or the published FireCastRL \
                 CSV) matched to GRIDMET daily gridded weather (University of Idaho, 1/24° grid over the \
                 contiguous US); FireCast de-duplicated the ignitions, drew negatives in tiers and read \
                 each sample's GRIDMET window."
                    .into()
            },
            data_collection_type: if synthetic {
                "Synthetic data generation".into()
            } else {
                "Secondary data analysis".into()
            },
            data_collection_timeframe: (first.clone(), last.clone()),
            data_collection_missing_data: format!(
                "{missing} of {values} feature values of the model-input rows are missing (GRIDMET has no \
                 value there); they are Parquet nulls and empty CSV cells, never a sentinel and never imputed \
                 in these files. Windows dropped at extraction are counted in the card's provenance."
            ),
            data_collection_raw_data: if synthetic {
                "The generator's incident CSV, NetCDF weather and true ignition probability, reproducible \
                 from its seed; their BLAKE3 hashes are in the card's provenance."
                    .into()
            } else {
                "The incident reports and GRIDMET files named, with their BLAKE3 hashes, in the card's \
                 provenance."
                    .into()
            },
            preprocessing: format!(
                "Reports of one fire de-duplicated into one ignition; negatives drawn in tiers (far: \
                 ≥ 100 km from every ignition; near: within 100 km, shifted by months; yearly: an ignition's \
                 place whole years earlier); windows read from GRIDMET on the sample's cell, missing values \
                 kept as nulls; framing: {framing}; splits leak-free by groups of overlapping windows (no \
                 place and date in two splits). Values are not normalised: `normalization.json` holds the \
                 mean and standard deviation of each feature over the training rows only."
            ),
            data_limitations: format!(
                "A case-control sample, not every place and day: the positives' share per split ({}) is far \
                 above the true daily rate of ignitions, so probabilities learnt here need a prior correction. \
                 {}Covers {first} to {last} and the region of its sources only.{}",
                prevalence.join(", "),
                if manifest.framing.kind == FramingKind::Paper {
                    "The paper framing's inputs include the 15 days after an ignition, so a classifier trained \
                     on them is not a forecast. "
                } else {
                    ""
                },
                if synthetic {
                    " Synthetic: results on it say how a method behaves on a known generator, not how it \
                     performs on real fires."
                } else {
                    ""
                }
            ),
            data_biases: if synthetic {
                "Negatives are drawn by rules (tiers), not at random over all places and days, and the \
                 generator's ignition model decides which weather leads to fire: a model can learn the \
                 sampling design and the generator's form rather than fire behaviour."
                    .into()
            } else {
                "Reported ignitions under-represent remote and small fires and over-represent places near \
                 people and roads; negatives are drawn by rules (tiers), not at random, so a model can learn \
                 the sampling design."
                    .into()
            },
            personal_sensitive_information: if synthetic {
                "None: no person, name, address or identifier; places are synthetic ignition points and \
                 GRIDMET cell centres."
                    .into()
            } else {
                "No personal data: ignition points and dates from public incident records (no names or \
                 addresses) and GRIDMET cell centres."
                    .into()
            },
            data_use_cases: "Benchmarking ignition classifiers and forecasters with leak-free splits \
                             (FireCast's Table III), teaching, and testing data pipelines. Not validated for \
                             operational fire-danger decisions."
                .into(),
            data_social_impact: "Fire-risk models trained on data like this may inform where crews and \
                                 warnings go; a model that looks skilful on a case-control sample can \
                                 mislead at the true prevalence, so report calibrated skill."
                .into(),
        };
        Ok(Publication {
            name: manifest.name.clone(),
            id: cfg.id.clone(),
            title: cfg.title.clone(),
            subtitle: cfg.subtitle.clone(),
            content_version: manifest.version.clone(),
            version,
            date_published,
            license: license.kaggle.into(),
            keywords,
            creator: cfg.creator.clone(),
            url,
            citation,
            synthetic,
            summary,
            card,
            framing: manifest.framing.kind,
            day_offsets: manifest.day_offsets,
            features: manifest.features.clone(),
            splits,
            tables: staged.tables,
            files: staged.files,
            csv: staged.csv,
            rai,
        })
    }

    fn license(&self) -> License {
        License::from_kaggle(&self.license).unwrap_or(LICENSE_TABLE[13])
    }

    fn table(&self, name: &str) -> Option<&TableSchema> {
        self.tables.iter().find(|t| t.name == name)
    }

    /// Croissant 1.1 JSON-LD.
    pub fn croissant(&self) -> Value {
        let context = json!({
            "@language": "en",
            "@vocab": "https://schema.org/",
            "arrayShape": "cr:arrayShape",
            "citeAs": "cr:citeAs",
            "column": "cr:column",
            "conformsTo": "dct:conformsTo",
            "containedIn": "cr:containedIn",
            "cr": "http://mlcommons.org/croissant/",
            "rai": "http://mlcommons.org/croissant/RAI/",
            "data": {"@id": "cr:data", "@type": "@json"},
            "dataType": {"@id": "cr:dataType", "@type": "@vocab"},
            "dct": "http://purl.org/dc/terms/",
            "description": {"@container": "@language"},
            "equivalentProperty": "cr:equivalentProperty",
            "examples": {"@id": "cr:examples", "@type": "@json"},
            "extract": "cr:extract",
            "field": "cr:field",
            "fileProperty": "cr:fileProperty",
            "fileObject": "cr:fileObject",
            "fileSet": "cr:fileSet",
            "format": "cr:format",
            "includes": "cr:includes",
            "isArray": "cr:isArray",
            "isLiveDataset": "cr:isLiveDataset",
            "jsonPath": "cr:jsonPath",
            "key": "cr:key",
            "md5": "cr:md5",
            "name": {"@container": "@language"},
            "parentField": "cr:parentField",
            "path": "cr:path",
            "recordSet": "cr:recordSet",
            "references": "cr:references",
            "regex": "cr:regex",
            "repeated": "cr:repeated",
            "replace": "cr:replace",
            "samplingRate": "cr:samplingRate",
            "sc": "https://schema.org/",
            "separator": "cr:separator",
            "source": "cr:source",
            "subField": "cr:subField",
            "transform": "cr:transform"
        });
        let mut distribution: Vec<Value> = Vec::new();
        let file_object = |f: &PublishedFile| {
            json!({
                "@type": "cr:FileObject",
                "@id": f.path,
                "name": f.path,
                "description": f.description,
                "contentUrl": f.path,
                "encodingFormat": f.encoding_format,
                "contentSize": format!("{} B", f.bytes),
                "sha256": f.sha256,
            })
        };
        for f in &self.files {
            distribution.push(file_object(f));
        }
        if let Some((f, _)) = &self.csv {
            distribution.push(file_object(f));
        }
        for t in TABLES {
            distribution.push(json!({
                "@type": "cr:FileSet",
                "@id": format!("{t}-files"),
                "name": format!("{t}-files"),
                "description": format!(
                    "The `{t}` table, one Parquet file per split (each listed above with its SHA-256)"
                ),
                "encodingFormat": "application/x-parquet",
                "includes": format!("{t}-*.parquet"),
            }));
        }
        let split_names: Vec<&str> = self.splits.iter().map(|s| s.name.as_str()).collect();
        let mut record_sets = vec![json!({
            "@type": "cr:RecordSet",
            "@id": "splits",
            "name": "splits",
            "description": "The dataset's splits (leak-free: no place and date in two of them)",
            "dataType": "cr:Split",
            "key": {"@id": "splits/name"},
            "field": [
                {"@type": "cr:Field", "@id": "splits/name", "name": "name", "dataType": "sc:Text",
                 "description": "Split name, as in the `split` column and the file names"},
                {"@type": "cr:Field", "@id": "splits/url", "name": "url", "dataType": "sc:URL",
                 "description": "Croissant's well-known split"},
                {"@type": "cr:Field", "@id": "splits/description", "name": "description",
                 "dataType": "sc:Text", "description": "Counts from the dataset card"}
            ],
            "data": self.splits.iter().map(|s| {
                let mut row = json!({
                    "splits/name": s.name,
                    "splits/description": s.description(),
                });
                if let Some(u) = s.croissant_url() {
                    row["splits/url"] = json!(u);
                }
                row
            }).collect::<Vec<_>>(),
        })];
        // The split from a file's path (`…/days-val.parquet` → `val`). It also matches the bare
        // split name it yields: mlcroissant 1.1.1 applies a field's transform again after the
        // join a `references` makes, and would warn on every row otherwise.
        let split_regex = |t: &str| format!("^(?:.*/)?(?:{t}-)?({})(?:\\.parquet)?$", split_names.join("|"));
        for t in &self.tables {
            let set = format!("{}-files", t.name);
            let mut fields: Vec<Value> = t
                .columns
                .iter()
                .map(|c| {
                    let mut f = json!({
                        "@type": "cr:Field",
                        "@id": format!("{}/{}", t.name, c.name),
                        "name": c.name,
                        "description": c.description,
                        "dataType": c.kind.croissant(),
                        "source": {"fileSet": {"@id": set}, "extract": {"column": c.name}},
                    });
                    if c.name == "split" {
                        f["references"] = json!({"field": {"@id": "splits/name"}});
                    }
                    f
                })
                .collect();
            if !t.columns.iter().any(|c| c.name == "split") {
                fields.push(json!({
                    "@type": "cr:Field",
                    "@id": format!("{}/split", t.name),
                    "name": "split",
                    "description": "The split, from the file's name",
                    "dataType": "sc:Text",
                    "source": {
                        "fileSet": {"@id": set},
                        "extract": {"fileProperty": "fullpath"},
                        "transform": {"regex": split_regex(&t.name)},
                    },
                    "references": {"field": {"@id": "splits/name"}},
                }));
            }
            let key = match t.name.as_str() {
                "samples" => json!({"@id": "samples/sample_id"}),
                _ => {
                    json!([{"@id": format!("{}/sample_id", t.name)}, {"@id": format!("{}/day_index", t.name)}])
                }
            };
            record_sets.push(json!({
                "@type": "cr:RecordSet",
                "@id": t.name,
                "name": t.name,
                "description": t.description,
                "key": key,
                "field": fields,
            }));
        }
        if let Some((f, _)) = &self.csv {
            let fields: Vec<Value> = crate::kaggle::CSV_COLUMNS
                .iter()
                .map(|c| {
                    let (kind, description) = crate::kaggle::describe(c);
                    let data_type = match kind {
                        "datetime" => "sc:Date",
                        "string" => "sc:Text",
                        _ if *c == "latitude" || *c == "longitude" => "cr:Float64",
                        _ => "cr:Float32",
                    };
                    json!({
                        "@type": "cr:Field",
                        "@id": format!("wildfire_csv/{c}"),
                        "name": c,
                        "description": description,
                        "dataType": data_type,
                        "source": {"fileObject": {"@id": f.path}, "extract": {"column": c}},
                    })
                })
                .collect();
            record_sets.push(json!({
                "@type": "cr:RecordSet",
                "@id": "wildfire_csv",
                "name": "wildfire_csv",
                "description": "The FireCastRL CSV layout: the days table joined with its samples, 75 rows a \
                                window, all splits together",
                "field": fields,
            }));
        }
        let license = self.license();
        json!({
            "@context": context,
            "@type": "sc:Dataset",
            "conformsTo": CROISSANT_1_1,
            "name": self.name,
            "alternateName": [self.title, self.id],
            "description": self.summary,
            "license": license.croissant(),
            "url": self.url,
            "version": self.version,
            "datePublished": self.date_published,
            "creator": {"@type": "sc:Organization", "name": self.creator},
            "keywords": self.keywords,
            "citeAs": self.citation,
            "isAccessibleForFree": true,
            "temporalCoverage": format!("{}/{}", self.rai.data_collection_timeframe.0, self.rai.data_collection_timeframe.1),
            "rai:dataCollection": self.rai.data_collection,
            "rai:dataCollectionType": self.rai.data_collection_type,
            "rai:dataCollectionTimeframe": [self.rai.data_collection_timeframe.0, self.rai.data_collection_timeframe.1],
            "rai:dataCollectionMissingData": self.rai.data_collection_missing_data,
            "rai:dataCollectionRawData": self.rai.data_collection_raw_data,
            "rai:dataPreprocessingProtocol": [self.rai.preprocessing],
            "rai:dataLimitations": self.rai.data_limitations,
            "rai:dataBiases": self.rai.data_biases,
            "rai:personalSensitiveInformation": self.rai.personal_sensitive_information,
            "rai:dataUseCases": self.rai.data_use_cases,
            "rai:dataSocialImpact": self.rai.data_social_impact,
            "distribution": distribution,
            "recordSet": record_sets,
        })
    }

    /// The Hugging Face dataset card: YAML front matter, then the card.
    pub fn hf_card(&self) -> String {
        let q = |s: &str| serde_json::to_string(s).unwrap_or_default();
        let mut y = String::new();
        let _ = writeln!(y, "---");
        let license = self.license();
        let _ = writeln!(y, "license: {}", license.hf);
        if license.hf == "other" && license.kaggle != "other" {
            // Hugging Face asks a licence it does not list to be named.
            let _ = writeln!(y, "license_name: {}", license.kaggle.to_ascii_lowercase());
        }
        let _ = writeln!(y, "pretty_name: {}", q(&self.title));
        let _ = writeln!(y, "tags:");
        for k in &self.keywords {
            let _ = writeln!(y, "- {}", q(k));
        }
        let _ = writeln!(y, "- croissant");
        let _ = writeln!(y, "task_categories:\n- tabular-classification");
        let samples: u64 = self.splits.iter().map(|s| s.samples).sum();
        let _ = writeln!(y, "size_categories:\n- {}", size_category(samples));
        let _ = writeln!(y, "source_datasets:\n- original");
        let _ = writeln!(y, "configs:");
        for (k, t) in self.tables.iter().enumerate() {
            let _ = writeln!(y, "- config_name: {}", t.name);
            if k == 0 {
                let _ = writeln!(y, "  default: true");
            }
            let _ = writeln!(y, "  data_files:");
            for s in &self.splits {
                let _ = writeln!(y, "  - split: {}", s.name);
                let _ = writeln!(y, "    path: {}", table_file(&t.name, &s.name));
            }
        }
        let _ = writeln!(y, "dataset_info:");
        for t in &self.tables {
            let _ = writeln!(y, "- config_name: {}", t.name);
            let _ = writeln!(y, "  features:");
            for c in &t.columns {
                let _ = writeln!(y, "  - name: {}", c.name);
                let _ = writeln!(y, "    dtype: {}", q(c.kind.hf()));
            }
            let _ = writeln!(y, "  splits:");
            for s in &self.splits {
                let rows = if t.name == "samples" {
                    s.samples
                } else {
                    s.day_rows
                };
                let bytes = self
                    .files
                    .iter()
                    .find(|f| f.path == table_file(&t.name, &s.name))
                    .map_or(0, |f| f.bytes);
                let _ = writeln!(y, "  - name: {}", s.name);
                let _ = writeln!(y, "    num_bytes: {bytes}");
                let _ = writeln!(y, "    num_examples: {rows}");
            }
        }
        let _ = writeln!(y, "---\n");
        let _ = writeln!(y, "# {}\n", self.title);
        if self.synthetic {
            let _ = writeln!(y, "> **{SYNTHETIC_NOTICE}**\n");
        }
        if let Some(s) = &self.subtitle {
            let _ = writeln!(y, "{s}\n");
        }
        let _ = writeln!(y, "{}\n", self.summary);
        let _ = writeln!(y, "## Files\n");
        let _ = writeln!(y, "| file | what | SHA-256 |\n|---|---|---|");
        let csv = self.csv.as_ref().map(|(f, _)| f);
        for f in self.files.iter().chain(csv) {
            let _ = writeln!(y, "| `{}` | {} | `{}…` |", f.path, f.description, &f.sha256[..16]);
        }
        let _ = writeln!(
            y,
            "\n`{CROISSANT_FILE}` describes the same files in Croissant 1.1 (checksums, one field per \
             column, the splits, the responsible-AI fields); `{KAGGLE_FILE}` is Kaggle's metadata.\n"
        );
        let _ = writeln!(y, "## Responsible use\n");
        for (what, text) in [
            ("Collection", &self.rai.data_collection),
            ("Preprocessing", &self.rai.preprocessing),
            ("Missing data", &self.rai.data_collection_missing_data),
            ("Limitations", &self.rai.data_limitations),
            ("Biases", &self.rai.data_biases),
            (
                "Personal and sensitive information",
                &self.rai.personal_sensitive_information,
            ),
            ("Intended uses", &self.rai.data_use_cases),
            ("Social impact", &self.rai.data_social_impact),
        ] {
            let _ = writeln!(y, "- **{what}.** {text}");
        }
        let _ = writeln!(y, "\n## Citation\n\n```bibtex\n{}\n```\n", self.citation);
        let _ = writeln!(y, "## Dataset card\n");
        // The card's own title becomes a section of this one.
        for line in self.card.lines() {
            if let Some(rest) = line.strip_prefix("# ") {
                let _ = writeln!(y, "### {rest}");
            } else if line.starts_with("## ") {
                let _ = writeln!(y, "#{line}");
            } else {
                let _ = writeln!(y, "{line}");
            }
        }
        y
    }

    /// Kaggle's `dataset-metadata.json`.
    pub fn kaggle(&self) -> KaggleMetadata {
        let mut resources = Vec::new();
        if let Some((f, rows)) = &self.csv {
            resources.push(KaggleResource {
                path: f.path.clone(),
                description: format!(
                    "{} windows of 75 days x 15 GRIDMET variables in the FireCastRL column order ({rows} rows, \
                     dataset {})",
                    rows / 75,
                    self.content_version
                ),
                schema: Some(KaggleSchema {
                    fields: crate::kaggle::csv_fields(),
                }),
            });
        }
        for f in &self.files {
            let schema = f
                .table
                .as_ref()
                .and_then(|(t, _)| self.table(t))
                .map(|t| KaggleSchema {
                    fields: t
                        .columns
                        .iter()
                        .map(|c| crate::kaggle::KaggleField {
                            name: c.name.clone(),
                            description: c.description.clone(),
                            kind: c.kind.kaggle(&c.name).into(),
                        })
                        .collect(),
                });
            resources.push(KaggleResource {
                path: f.path.clone(),
                description: f.description.clone(),
                schema,
            });
        }
        let notice = if self.synthetic {
            format!("> **{SYNTHETIC_NOTICE}**\n\n")
        } else {
            String::new()
        };
        KaggleMetadata {
            title: self.title.clone(),
            subtitle: self.subtitle.clone(),
            description: format!("{notice}{}\n\n{}", self.summary, self.card),
            id: self.id.clone(),
            licenses: vec![KaggleLicense {
                name: self.license.clone(),
            }],
            keywords: self.keywords.clone(),
            resources,
        }
    }
}

/// What [`publish`] wrote.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PublishReport {
    pub folder: PathBuf,
    pub files: Vec<String>,
    /// Rows of the FireCastRL CSV (paper framing only).
    pub csv_rows: Option<u64>,
    pub version: String,
    pub splits: Vec<SplitSummary>,
    pub metadata: KaggleMetadata,
}

fn published_file(
    dir: &Path,
    name: &str,
    format: &str,
    description: String,
) -> Result<PublishedFile, DatasetError> {
    let path = dir.join(name);
    let bytes = std::fs::metadata(&path)
        .map_err(DatasetError::io("reading", &path))?
        .len();
    Ok(PublishedFile {
        path: name.to_string(),
        encoding_format: format.to_string(),
        sha256: crate::sha256::file_hex(&path)?,
        bytes,
        description,
        table: None,
    })
}

/// The rows of `table` in `split`, in the dataset's order, with explicit row labels.
fn split_table(t: &WindowTable, splits: &[String], split: &str) -> WindowTable {
    let nf = t.n_features();
    let mut out = WindowTable {
        features: t.features.clone(),
        first_offset: t.first_offset,
        n_days: t.n_days,
        samples: Vec::new(),
        values: Vec::new(),
        row_labels: Some(Vec::new()),
    };
    for (s, sample) in t.samples.iter().enumerate() {
        if splits[s] != split {
            continue;
        }
        out.samples.push(sample.clone());
        out.values
            .extend_from_slice(&t.values[s * t.n_days * nf..(s + 1) * t.n_days * nf]);
        if let Some(labels) = out.row_labels.as_mut() {
            labels.extend((0..t.n_days).map(|d| crate::table::row_label(t, s, d)));
        }
    }
    out.drop_derived_row_labels();
    out
}

/// Publishes `dataset_dir` as `folder` (which must not exist): the tables per split, the CSV
/// (paper framing), card, map, normalisation, and the three metadata files from one
/// [`Publication`]. A dataset whose files do not match its manifest is refused naming the
/// damaged file; the staged folder is read back and must equal the dataset.
pub fn publish(
    dataset_dir: &Path,
    folder: &Path,
    cfg: &PublishConfig,
) -> Result<PublishReport, DatasetError> {
    let manifest: DatasetManifest = crate::dataset::read_manifest(dataset_dir)?;
    if folder.exists() {
        return Err(DatasetError::Input {
            path: folder.to_path_buf(),
            message: "already exists; choose a new folder (nothing was changed)".into(),
        });
    }
    // Checks every file against dataset.json first, so a damaged file is named.
    let stored = crate::dataset::read_window_table(dataset_dir)?;
    let Some(splits) = stored.splits.clone() else {
        return Err(DatasetError::Input {
            path: dataset_dir.join(crate::table::SAMPLES_FILE),
            message: "has no `split` column: only a finished dataset (`firecast dataset build`) is published"
                .into(),
        });
    };
    let t = &stored.table;
    let stats_path = dataset_dir.join(crate::dataset::STATS_FILE);
    #[derive(Deserialize)]
    struct StatsDoc {
        features: Vec<FeatureStats>,
        tiers: Vec<TierCount>,
    }
    let stats_text =
        std::fs::read_to_string(&stats_path).map_err(DatasetError::io("reading", &stats_path))?;
    let stats: StatsDoc = serde_json::from_str(&stats_text).map_err(|e| DatasetError::InputLine {
        path: stats_path.clone(),
        line: e.line() as u64,
        message: e.to_string(),
    })?;
    let card_path = dataset_dir.join(crate::dataset::CARD_FILE);
    let card = std::fs::read_to_string(&card_path).map_err(DatasetError::io("reading", &card_path))?;

    let staged = firecast_fs::TempPath::dir(folder)?;
    let tmp = staged.path().to_path_buf();

    let paper: Vec<&str> = PAPER_FEATURES.iter().map(|v| v.short_name()).collect();
    let csv = if manifest.framing.kind == FramingKind::Paper && manifest.features == paper {
        let rows = crate::kaggle::write_csv(t, &tmp.join(CSV_FILE))?;
        Some((
            published_file(
                &tmp,
                CSV_FILE,
                "text/csv",
                format!(
                    "The FireCastRL CSV layout: {} windows of 75 days, 19 columns",
                    t.samples.len()
                ),
            )?,
            rows,
        ))
    } else {
        None
    };

    let summaries = split_summaries(&manifest, &stats.tiers);
    let mut files = Vec::new();
    let mut tables: Vec<TableSchema> = Vec::new();
    for s in &summaries {
        let part = split_table(t, &splits, &s.name);
        let part_splits: Vec<&str> = vec![s.name.as_str(); part.samples.len()];
        let sub = tmp.join(format!(".split-{}", s.name));
        let kv = BTreeMap::from([
            ("firecast.dataset.name".to_string(), manifest.name.clone()),
            ("firecast.dataset.version".to_string(), manifest.version.clone()),
            ("firecast.dataset.split".to_string(), s.name.clone()),
        ]);
        crate::table::write_window_table(&sub, &part, Some(part_splits.as_slice()), &kv)?;
        for (table, from) in [
            ("samples", crate::table::SAMPLES_FILE),
            ("days", crate::table::DAYS_FILE),
        ] {
            let name = table_file(table, &s.name);
            firecast_fs::publish(&sub.join(from), &tmp.join(&name))?;
            if !tables.iter().any(|x| x.name == table) {
                let schema = crate::table::parquet_schema(&tmp.join(&name))?;
                let columns = schema
                    .fields()
                    .iter()
                    .map(|f| {
                        let kind =
                            ColumnType::from_arrow(f.data_type()).ok_or_else(|| DatasetError::Parquet {
                                path: tmp.join(&name),
                                message: format!(
                                    "column `{}`: no published type for {}",
                                    f.name(),
                                    f.data_type()
                                ),
                            })?;
                        Ok(Column {
                            name: f.name().clone(),
                            kind,
                            nullable: f.is_nullable(),
                            description: column_description(table, f.name()),
                        })
                    })
                    .collect::<Result<Vec<_>, DatasetError>>()?;
                tables.push(TableSchema {
                    name: table.into(),
                    description: table_description(table, t.n_days),
                    columns,
                });
            }
            let rows = if table == "samples" { s.samples } else { s.day_rows };
            let mut f = published_file(
                &tmp,
                &name,
                "application/x-parquet",
                format!("`{table}` table, {} split: {rows} rows", s.name),
            )?;
            f.table = Some((table.into(), s.name.clone()));
            files.push(f);
        }
        std::fs::remove_dir(&sub).map_err(DatasetError::io("removing", &sub))?;
    }
    for (name, format, description) in [
        (crate::dataset::CARD_FILE, "text/markdown", "The dataset card"),
        (crate::dataset::MAP_FILE, "image/png", "Where the samples are"),
        (
            crate::dataset::NORMALIZATION_FILE,
            "application/json",
            "Mean and standard deviation per feature over the training rows",
        ),
    ] {
        std::fs::copy(dataset_dir.join(name), tmp.join(name))
            .map_err(DatasetError::io("copying", &dataset_dir.join(name)))?;
        files.push(published_file(&tmp, name, format, description.into())?);
    }

    let publication = Publication::new(
        &manifest,
        cfg,
        card,
        &stats.features,
        &stats.tiers,
        Staged { tables, files, csv },
    )?;
    let meta = publication.kaggle();
    let problems = crate::kaggle::validate_metadata(&meta, &tmp);
    if !problems.is_empty() {
        return Err(DatasetError::Config {
            key: "kaggle".into(),
            message: format!(
                "dataset-metadata.json would be rejected:\n  {}",
                problems.join("\n  ")
            ),
        });
    }
    let pretty = |v: &dyn ErasedJson| v.pretty();
    firecast_fs::write_atomically(&tmp.join(KAGGLE_FILE), pretty(&meta).as_bytes())?;
    firecast_fs::write_atomically(
        &tmp.join(CROISSANT_FILE),
        pretty(&publication.croissant()).as_bytes(),
    )?;
    firecast_fs::write_atomically(&tmp.join(HF_CARD_FILE), publication.hf_card().as_bytes())?;

    // What a reader of the folder gets must be the dataset.
    let back = read_published(&tmp)?;
    compare(&stored, &back).map_err(|message| DatasetError::Input {
        path: folder.to_path_buf(),
        message: format!("the staged folder does not read back as the dataset: {message}"),
    })?;

    let mut names: Vec<String> = publication.files.iter().map(|f| f.path.clone()).collect();
    if let Some((f, _)) = &publication.csv {
        names.insert(0, f.path.clone());
    }
    names.extend([CROISSANT_FILE, HF_CARD_FILE, KAGGLE_FILE].map(String::from));
    staged
        .publish()
        .map_err(|e| DatasetError::io("renaming into place", folder)(e.source))?;
    Ok(PublishReport {
        folder: folder.to_path_buf(),
        files: names,
        csv_rows: publication.csv.as_ref().map(|(_, rows)| *rows),
        version: publication.version.clone(),
        splits: publication.splits.clone(),
        metadata: meta,
    })
}

trait ErasedJson {
    fn pretty(&self) -> String;
}
impl<T: Serialize> ErasedJson for T {
    fn pretty(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}

/// What a published folder's `croissant.json` says about its files and splits.
struct CroissantIndex {
    /// Every `cr:FileObject`: its path in the folder and its SHA-256.
    files: Vec<(String, String)>,
    /// The names in the `splits` record set.
    splits: Vec<String>,
}

fn croissant_index(folder: &Path) -> Result<CroissantIndex, DatasetError> {
    let path = folder.join(CROISSANT_FILE);
    let text = std::fs::read_to_string(&path).map_err(DatasetError::io("reading", &path))?;
    let doc: Value = serde_json::from_str(&text).map_err(|e| DatasetError::InputLine {
        path: path.clone(),
        line: e.line() as u64,
        message: e.to_string(),
    })?;
    let bad = |key: &str, message: String| DatasetError::Input {
        path: path.clone(),
        message: format!("`{key}`: {message}"),
    };
    let mut files = Vec::new();
    for (k, d) in doc["distribution"].as_array().into_iter().flatten().enumerate() {
        if d["@type"] != "cr:FileObject" {
            continue;
        }
        let url = d["contentUrl"]
            .as_str()
            .ok_or_else(|| bad(&format!("distribution[{k}].contentUrl"), "missing".into()))?;
        let sha = d["sha256"]
            .as_str()
            .ok_or_else(|| bad(&format!("distribution[{k}].sha256"), "missing".into()))?;
        if url.contains("..") || url.starts_with('/') {
            return Err(bad(
                &format!("distribution[{k}].contentUrl"),
                format!("`{url}` is not a file of the folder"),
            ));
        }
        files.push((url.to_string(), sha.to_string()));
    }
    let splits = doc["recordSet"]
        .as_array()
        .into_iter()
        .flatten()
        .find(|r| r["@id"] == "splits")
        .and_then(|r| r["data"].as_array())
        .ok_or_else(|| bad("recordSet[splits].data", "missing".into()))?
        .iter()
        .filter_map(|row| row["splits/name"].as_str().map(String::from))
        .collect();
    Ok(CroissantIndex { files, splits })
}

/// Checks every file `croissant.json` lists against its SHA-256: a missing or changed file
/// is refused with its own path named.
pub fn verify_files(folder: &Path) -> Result<usize, DatasetError> {
    use rayon::prelude::*;
    let files = croissant_index(folder)?.files;
    files
        .par_iter()
        .map(|(name, expected)| {
            let path = folder.join(name);
            if !path.is_file() {
                return Err(DatasetError::Damaged {
                    path,
                    message: format!("{CROISSANT_FILE} lists it but it is missing"),
                });
            }
            let found = crate::sha256::file_hex(&path)?;
            if found != *expected {
                return Err(DatasetError::Damaged {
                    path,
                    message: format!(
                        "its contents do not match {CROISSANT_FILE} (SHA-256 {}…, expected {}…): the file was \
                         damaged or changed after publishing; publish the dataset again",
                        &found[..16],
                        expected.chars().take(16).collect::<String>()
                    ),
                });
            }
            Ok(())
        })
        .collect::<Vec<_>>()
        .into_iter()
        .collect::<Result<Vec<()>, _>>()
        .map(|v| v.len())
}

/// Reads a published folder's tables back into one table (splits in `croissant.json`'s order),
/// after checking every file's SHA-256.
pub fn read_published(folder: &Path) -> Result<StoredTable, DatasetError> {
    verify_files(folder)?;
    let split_names = croissant_index(folder)?.splits;
    let mut all: Option<StoredTable> = None;
    for s in &split_names {
        let part = crate::table::read_window_files(
            &folder.join(table_file("samples", s)),
            &folder.join(table_file("days", s)),
        )?;
        let part_splits = part.splits.clone().unwrap_or_default();
        let mut table = part.table;
        if table.row_labels.is_none() {
            let n = table.samples.len() * table.n_days;
            table.row_labels = Some(
                (0..n)
                    .map(|r| table.layout_label(r / table.n_days, r % table.n_days))
                    .collect(),
            );
        }
        match all.as_mut() {
            None => {
                all = Some(StoredTable {
                    table,
                    splits: Some(part_splits),
                    metadata: part.metadata,
                })
            }
            Some(acc) => {
                let t = &mut acc.table;
                if t.features != table.features
                    || t.n_days != table.n_days
                    || t.first_offset != table.first_offset
                {
                    return Err(DatasetError::Input {
                        path: folder.join(table_file("days", s)),
                        message: "its columns or days differ from the other splits' files".into(),
                    });
                }
                t.samples.extend(table.samples);
                t.values.extend(table.values);
                if let (Some(a), Some(b)) = (t.row_labels.as_mut(), table.row_labels) {
                    a.extend(b);
                }
                if let Some(sp) = acc.splits.as_mut() {
                    sp.extend(part_splits);
                }
            }
        }
    }
    let mut out = all.ok_or_else(|| DatasetError::Input {
        path: folder.join(CROISSANT_FILE),
        message: "lists no splits".into(),
    })?;
    out.table.drop_derived_row_labels();
    Ok(out)
}

/// Whether `published` holds exactly the samples, splits, values and labels of `dataset`
/// (in any order of samples); the first difference otherwise.
pub fn compare(dataset: &StoredTable, published: &StoredTable) -> Result<(), String> {
    let (a, b) = (&dataset.table, &published.table);
    if a.features != b.features {
        return Err(format!("features {:?} vs {:?}", a.features, b.features));
    }
    if (a.first_offset, a.n_days) != (b.first_offset, b.n_days) {
        return Err(format!(
            "days {}+{} vs {}+{}",
            a.first_offset, a.n_days, b.first_offset, b.n_days
        ));
    }
    if a.samples.len() != b.samples.len() {
        return Err(format!("{} samples vs {}", a.samples.len(), b.samples.len()));
    }
    let index: HashMap<u32, usize> = b
        .samples
        .iter()
        .enumerate()
        .map(|(k, s)| (s.sample_id, k))
        .collect();
    let nf = a.n_features();
    let row = a.n_days * nf;
    let no_splits = Vec::new();
    let (sa, sb) = (
        dataset.splits.as_ref().unwrap_or(&no_splits),
        published.splits.as_ref().unwrap_or(&no_splits),
    );
    for (i, s) in a.samples.iter().enumerate() {
        let Some(&j) = index.get(&s.sample_id) else {
            return Err(format!("sample {} is missing", s.sample_id));
        };
        if *s != b.samples[j] {
            return Err(format!("sample {}: {:?} vs {:?}", s.sample_id, s, b.samples[j]));
        }
        if sa.get(i) != sb.get(j) {
            return Err(format!(
                "sample {}: split {:?} vs {:?}",
                s.sample_id,
                sa.get(i),
                sb.get(j)
            ));
        }
        let (va, vb) = (
            &a.values[i * row..(i + 1) * row],
            &b.values[j * row..(j + 1) * row],
        );
        if let Some(k) = (0..row).find(|k| va[*k].to_bits() != vb[*k].to_bits()) {
            return Err(format!(
                "sample {} day {} `{}`: {} vs {}",
                s.sample_id,
                k / nf,
                a.features[k % nf],
                va[k],
                vb[k]
            ));
        }
        for d in 0..a.n_days {
            if crate::table::row_label(a, i, d) != crate::table::row_label(b, j, d) {
                return Err(format!("sample {} day {d}: row label differs", s.sample_id));
            }
        }
    }
    Ok(())
}

/// What [`verify`] found.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct VerifyReport {
    pub folder: PathBuf,
    pub files_checked: usize,
    pub samples: usize,
    pub splits: BTreeMap<String, u64>,
    /// The dataset compared with, when one was given.
    pub dataset: Option<PathBuf>,
}

/// Checks a published folder: every file against `croissant.json`'s SHA-256, the tables
/// readable, and (given `dataset_dir`) equal to that dataset.
pub fn verify(folder: &Path, dataset_dir: Option<&Path>) -> Result<VerifyReport, DatasetError> {
    let files_checked = verify_files(folder)?;
    let back = read_published(folder)?;
    if let Some(dir) = dataset_dir {
        let stored = crate::dataset::read_window_table(dir)?;
        compare(&stored, &back).map_err(|message| DatasetError::Input {
            path: folder.to_path_buf(),
            message: format!("does not equal the dataset {}: {message}", dir.display()),
        })?;
    }
    let mut splits = BTreeMap::new();
    for s in back.splits.iter().flatten() {
        *splits.entry(s.clone()).or_default() += 1;
    }
    Ok(VerifyReport {
        folder: folder.to_path_buf(),
        files_checked,
        samples: back.table.samples.len(),
        splits,
        dataset: dataset_dir.map(Path::to_path_buf),
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn every_kaggle_licence_has_its_three_spellings() {
        for name in crate::kaggle::LICENSES {
            let l = License::from_kaggle(name).unwrap_or_else(|| panic!("{name}"));
            assert_eq!(l.kaggle, *name);
        }
        assert_eq!(LICENSE_TABLE.len(), crate::kaggle::LICENSES.len());
        assert_eq!(
            License::from_kaggle("CC-BY-4.0").unwrap().croissant(),
            "https://spdx.org/licenses/CC-BY-4.0.html"
        );
    }

    #[test]
    fn size_categories_follow_hugging_face() {
        assert_eq!(size_category(999), "n<1K");
        assert_eq!(size_category(1_000), "1K<n<10K");
        assert_eq!(size_category(66_568), "10K<n<100K");
    }
}
