//! From extracted windows to a finished dataset: a framing, leak-free splits, normalisation
//! statistics on the training split, and a version id; its manifest (`dataset.json`) and
//! the folder read back against it. [`crate::folder`] writes the folder.

use std::collections::BTreeMap;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::table::{DAYS_FILE, SAMPLES_FILE, StoredTable, read_window_files, row_label};
use crate::time;
use crate::windows::WindowTable;
use crate::{DatasetError, Tier};

/// How windows become model inputs and labels.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FramingKind {
    /// The published CSV: days −60…+14, rows `No`×60 then `Yes`×15 for positives. The
    /// inputs include the 15 days after the ignition.
    Paper,
    /// A real forecast: `window_days` days ending `lead_days` before the predicted date,
    /// one label per sample.
    #[default]
    Forecast,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Framing {
    #[serde(default)]
    pub kind: FramingKind,
    /// Forecast: days between the last input day and the predicted date (≥ 1).
    #[serde(default = "default_lead")]
    pub lead_days: u32,
    /// Forecast: input days.
    #[serde(default = "default_window")]
    pub window_days: u32,
}

fn default_lead() -> u32 {
    1
}
fn default_window() -> u32 {
    60
}

impl Default for Framing {
    fn default() -> Self {
        Self {
            kind: FramingKind::Forecast,
            lead_days: default_lead(),
            window_days: default_window(),
        }
    }
}

impl Framing {
    /// Inclusive day offsets of the model inputs.
    pub fn offsets(&self) -> Result<(i32, i32), DatasetError> {
        match self.kind {
            FramingKind::Paper => Ok((-60, 14)),
            FramingKind::Forecast => {
                if self.lead_days < 1 {
                    return Err(DatasetError::Config {
                        key: "framing.lead_days".into(),
                        message: "must be at least 1: a forecast cannot see the day it predicts".into(),
                    });
                }
                if self.window_days < 1 {
                    return Err(DatasetError::Config {
                        key: "framing.window_days".into(),
                        message: "must be at least 1".into(),
                    });
                }
                let last = -(self.lead_days as i32);
                Ok((last - self.window_days as i32 + 1, last))
            }
        }
    }
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SplitMethod {
    /// Test = the last months of the data (the paper's January–April 2025 test period).
    #[default]
    Temporal,
    /// The authors' stratified random split, by groups.
    StratifiedRandom,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplitConfig {
    #[serde(default)]
    pub method: SplitMethod,
    /// Temporal: first test day (`YYYY-MM-DD`). Default: the start of the last `test_months`
    /// calendar months that have samples.
    pub test_from: Option<String>,
    #[serde(default = "default_test_months")]
    pub test_months: u32,
    /// Stratified random: share of groups in test.
    #[serde(default = "default_test_fraction")]
    pub test_fraction: f64,
    /// Share of the remaining groups held out for validation (both methods).
    #[serde(default = "default_val_fraction")]
    pub val_fraction: f64,
    #[serde(default = "default_split_seed")]
    pub seed: u64,
}

fn default_test_months() -> u32 {
    4
}
fn default_test_fraction() -> f64 {
    0.2
}
fn default_val_fraction() -> f64 {
    0.1
}
fn default_split_seed() -> u64 {
    42
}

impl Default for SplitConfig {
    fn default() -> Self {
        Self {
            method: SplitMethod::default(),
            test_from: None,
            test_months: default_test_months(),
            test_fraction: default_test_fraction(),
            val_fraction: default_val_fraction(),
            seed: default_split_seed(),
        }
    }
}

/// A dataset's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetConfig {
    /// Dataset name (registry key), e.g. `firecast-demo-forecast`.
    pub name: String,
    #[serde(default)]
    pub framing: Framing,
    #[serde(default)]
    pub split: SplitConfig,
    /// Free text for the card.
    #[serde(default)]
    pub description: String,
}

/// Per-feature mean and standard deviation over the training rows.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Normalization {
    pub split: String,
    pub rows: u64,
    pub features: BTreeMap<String, FeatureMoments>,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct FeatureMoments {
    pub mean: f64,
    pub std: f64,
}

/// A finished dataset in memory.
#[derive(Debug, Clone)]
pub struct BuiltDataset {
    pub table: WindowTable,
    pub splits: Vec<&'static str>,
    pub label_offsets: (i32, i32),
    pub test_from: Option<i32>,
    pub groups: usize,
    /// `v` + 16 hex digits of the content hash of config and data.
    pub version: String,
}

pub const TRAIN: &str = "train";
pub const VAL: &str = "val";
pub const TEST: &str = "test";

/// Applies the framing to `input` and assigns splits.
pub fn build(input: &WindowTable, cfg: &DatasetConfig) -> Result<BuiltDataset, DatasetError> {
    if cfg.name.trim().is_empty() {
        return Err(DatasetError::Config {
            key: "name".into(),
            message: "a dataset needs a name".into(),
        });
    }
    let (lo, hi) = cfg.framing.offsets()?;
    let have = (input.first_offset, input.first_offset + input.n_days as i32 - 1);
    if lo < have.0 || hi > have.1 {
        return Err(DatasetError::Config {
            key: "framing".into(),
            message: format!(
                "needs day offsets {lo}…{hi} but the windows were extracted for {}…{}; \
                 widen first_offset/last_offset of the extraction",
                have.0, have.1
            ),
        });
    }
    let n_days = (hi - lo + 1) as usize;
    let skip = (lo - input.first_offset) as usize;
    let nf = input.n_features();
    let mut values = Vec::with_capacity(input.samples.len() * n_days * nf);
    let mut row_labels = Vec::with_capacity(input.samples.len() * n_days);
    let mut samples = Vec::with_capacity(input.samples.len());
    for (s, sample) in input.samples.iter().enumerate() {
        // The sample label: a fire on the sample's date. For imported rows, "any Yes" in
        // the source window, which is how the authors labelled windows.
        let label = match &input.row_labels {
            Some(labels) => labels[s * input.n_days..(s + 1) * input.n_days]
                .iter()
                .any(|l| *l),
            None => sample.label(),
        };
        let mut sample = sample.clone();
        if input.row_labels.is_some() {
            sample.tier = if label {
                Tier::ImportedPositive
            } else {
                Tier::ImportedNegative
            };
        }
        for d in skip..skip + n_days {
            values.extend_from_slice(input.row(s, d));
            row_labels.push(row_label(input, s, d));
        }
        samples.push(sample);
    }
    let mut table = WindowTable {
        features: input.features.clone(),
        first_offset: lo,
        n_days,
        samples,
        values,
        row_labels: Some(row_labels),
    };
    table.drop_derived_row_labels();

    let (splits, test_from, groups) = assign_splits(&table, &cfg.split)?;
    let version = version_id(&table, &splits, cfg)?;
    Ok(BuiltDataset {
        table,
        splits,
        label_offsets: (lo, hi),
        test_from,
        groups,
        version,
    })
}

/// Groups of samples that share a GRIDMET cell and have overlapping day ranges (window and
/// event day). A group never straddles two splits, so no (place, date) is in two splits.
pub fn overlap_groups(table: &WindowTable) -> Vec<usize> {
    let lo = table.first_offset.min(0);
    let hi = (table.first_offset + table.n_days as i32 - 1).max(0);
    let span = hi - lo;
    let mut order: Vec<usize> = (0..table.samples.len()).collect();
    order.sort_by_key(|&s| {
        let x = &table.samples[s];
        (x.cell, x.event_day, x.sample_id)
    });
    let mut group = vec![0usize; table.samples.len()];
    let mut next = 0;
    let mut prev: Option<usize> = None;
    for &s in &order {
        let x = &table.samples[s];
        let joins = prev.is_some_and(|p| {
            let y = &table.samples[p];
            y.cell == x.cell && x.event_day - y.event_day <= span
        });
        if !joins {
            next += 1;
        }
        group[s] = next - 1;
        prev = Some(s);
    }
    group
}

fn assign_splits(
    table: &WindowTable,
    cfg: &SplitConfig,
) -> Result<(Vec<&'static str>, Option<i32>, usize), DatasetError> {
    for (key, v) in [
        ("split.test_fraction", cfg.test_fraction),
        ("split.val_fraction", cfg.val_fraction),
    ] {
        if !(0.0..1.0).contains(&v) {
            return Err(DatasetError::Config {
                key: key.into(),
                message: format!("{v} is not in [0, 1)"),
            });
        }
    }
    let group = overlap_groups(table);
    let n_groups = group.iter().max().map_or(0, |m| m + 1);
    let mut group_pos = vec![false; n_groups];
    let mut group_last = vec![i32::MIN; n_groups];
    for (s, g) in group.iter().enumerate() {
        group_pos[*g] |= table.samples[s].label();
        group_last[*g] = group_last[*g].max(table.samples[s].event_day);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let mut of_group: Vec<&'static str> = vec![TRAIN; n_groups];
    let mut test_from = None;
    match cfg.method {
        SplitMethod::Temporal => {
            let cutoff = match &cfg.test_from {
                Some(s) => time::parse_date(s).ok_or_else(|| DatasetError::Config {
                    key: "split.test_from".into(),
                    message: format!("`{s}` is not a YYYY-MM-DD date"),
                })?,
                None => {
                    let last = table.samples.iter().map(|s| s.event_day).max().unwrap_or(0);
                    let (y, m, _) = firecast_data::gridmet::day_to_ymd(last);
                    let months_back = cfg.test_months.max(1) as i32 - 1;
                    let idx = y * 12 + m as i32 - 1 - months_back;
                    firecast_data::gridmet::ymd_to_day(idx.div_euclid(12), idx.rem_euclid(12) as u32 + 1, 1)
                        .unwrap_or(last)
                }
            };
            test_from = Some(cutoff);
            for g in 0..n_groups {
                if group_last[g] >= cutoff {
                    of_group[g] = TEST;
                }
            }
        }
        SplitMethod::StratifiedRandom => {
            for stratum in [true, false] {
                let mut members: Vec<usize> = (0..n_groups).filter(|g| group_pos[*g] == stratum).collect();
                crate::shuffle(&mut members, &mut rng);
                let n_test = (members.len() as f64 * cfg.test_fraction).round() as usize;
                for g in &members[..n_test] {
                    of_group[*g] = TEST;
                }
            }
        }
    }
    // Validation: a stratified random share of the non-test groups.
    for stratum in [true, false] {
        let mut members: Vec<usize> = (0..n_groups)
            .filter(|g| group_pos[*g] == stratum && of_group[*g] == TRAIN)
            .collect();
        crate::shuffle(&mut members, &mut rng);
        let n_val = (members.len() as f64 * cfg.val_fraction).round() as usize;
        for g in &members[..n_val] {
            of_group[*g] = VAL;
        }
    }
    Ok((group.iter().map(|g| of_group[*g]).collect(), test_from, n_groups))
}

/// `v` + 16 hex digits of BLAKE3 over the config and every value of the dataset.
fn version_id(table: &WindowTable, splits: &[&str], cfg: &DatasetConfig) -> Result<String, DatasetError> {
    let mut h = blake3::Hasher::new();
    let config = serde_json::to_vec(cfg).map_err(|e| DatasetError::Config {
        key: String::new(),
        message: e.to_string(),
    })?;
    h.update(b"firecast-dataset\0");
    h.update(crate::table::SCHEMA_VERSION.as_bytes());
    h.update(&config);
    for f in &table.features {
        h.update(f.as_bytes());
        h.update(b"\0");
    }
    h.update(&table.first_offset.to_le_bytes());
    h.update(&(table.n_days as u64).to_le_bytes());
    for (s, split) in table.samples.iter().zip(splits) {
        h.update(&s.sample_id.to_le_bytes());
        h.update(&s.lat.to_le_bytes());
        h.update(&s.lon.to_le_bytes());
        h.update(&s.time_ms.to_le_bytes());
        h.update(&s.event_day.to_le_bytes());
        h.update(s.tier.as_str().as_bytes());
        h.update(&s.cell.0.to_le_bytes());
        h.update(&s.cell.1.to_le_bytes());
        h.update(split.as_bytes());
        // Hashed only when present, so datasets without truth keep their versions.
        if let Some(p) = s.true_probability {
            h.update(b"\x01true_probability");
            h.update(&p.to_bits().to_le_bytes());
        }
        h.update(b"\0");
    }
    for v in &table.values {
        h.update(&v.to_bits().to_le_bytes());
    }
    if let Some(labels) = &table.row_labels {
        h.update(&labels.iter().map(|l| u8::from(*l)).collect::<Vec<_>>());
    }
    Ok(format!("v{}", &h.finalize().to_hex()[..16]))
}

/// What [`crate::folder::write`] produced; also the content of `dataset.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DatasetManifest {
    pub name: String,
    pub version: String,
    pub schema_version: String,
    pub framing: Framing,
    /// Inclusive day offsets of the rows of `days.parquet`.
    pub day_offsets: (i32, i32),
    pub features: Vec<String>,
    pub samples: u64,
    pub positives: u64,
    pub day_rows: u64,
    /// Samples per split.
    pub splits: BTreeMap<String, u64>,
    pub test_from: Option<String>,
    pub groups: usize,
    pub config: DatasetConfig,
    pub provenance: BTreeMap<String, String>,
    /// BLAKE3 of each file of the dataset.
    pub files: BTreeMap<String, String>,
    /// The generator's true ignition probability column of `samples.parquet` (synthetic
    /// sources built with their truth only; never a feature).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub true_probability: Option<crate::truth::TruthSummary>,
}

pub const MANIFEST_FILE: &str = "dataset.json";
pub const CARD_FILE: &str = "card.md";
pub const MAP_FILE: &str = "map.png";
pub const NORMALIZATION_FILE: &str = "normalization.json";
pub const STATS_FILE: &str = "stats.json";

/// Checks every file `dataset.json` lists against its BLAKE3 hash (the files are hashed
/// in parallel, each once): a file that is missing, or whose bytes changed since the
/// dataset was written, is refused with its own path named — not whichever file a reader
/// would have tripped over later.
pub fn verify_files(dir: &std::path::Path, manifest: &DatasetManifest) -> Result<(), DatasetError> {
    use rayon::prelude::*;
    manifest
        .files
        .par_iter()
        .map(|(name, expected)| {
            let path = dir.join(name);
            if !path.is_file() {
                return Err(DatasetError::Damaged {
                    path,
                    message: format!("{MANIFEST_FILE} lists it but it is missing; rebuild the dataset"),
                });
            }
            let found = crate::hash_file(&path)?;
            if found != *expected {
                let short = |h: &str| h.chars().take(16).collect::<String>();
                return Err(DatasetError::Damaged {
                    path,
                    message: format!(
                        "its contents do not match {MANIFEST_FILE} (BLAKE3 {}…, expected {}…): the file \
                         was damaged or changed after the dataset was written; rebuild the dataset or \
                         restore the file",
                        short(&found),
                        short(expected)
                    ),
                });
            }
            Ok(())
        })
        .collect::<Vec<_>>()
        .into_iter()
        .collect()
}

/// Reads `dataset.json` of a dataset directory.
pub fn read_manifest(dir: &std::path::Path) -> Result<DatasetManifest, DatasetError> {
    let path = dir.join(MANIFEST_FILE);
    let text = std::fs::read_to_string(&path).map_err(DatasetError::io("reading", &path))?;
    serde_json::from_str(&text).map_err(|e| DatasetError::InputLine {
        path,
        line: e.line() as u64,
        message: e.to_string(),
    })
}

/// Reads a window table written by [`crate::table::write_window_table`]. In a dataset
/// directory (one with `dataset.json`) every file is first checked against the manifest's
/// hashes ([`verify_files`]), so a damaged file is named before it is parsed.
pub fn read_window_table(dir: &std::path::Path) -> Result<StoredTable, DatasetError> {
    if dir.join(MANIFEST_FILE).is_file() {
        let manifest = read_manifest(dir)?;
        verify_files(dir, &manifest)?;
    }
    read_window_files(&dir.join(SAMPLES_FILE), &dir.join(DAYS_FILE))
}
