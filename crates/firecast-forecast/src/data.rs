//! From a dataset folder to model inputs: the windows as a dense `[sample, day, feature]`
//! block, labels and the per-sample facts the protocols and breakdowns need.

use std::path::Path;

use firecast_dataset::Tier;
use firecast_dataset::dataset::{DatasetManifest, read_manifest, read_window_table};

use crate::ForecastError;

/// What the protocols, breakdowns and baselines know about a sample besides its weather.
/// None of it is a model input except where a model says so (climatology uses place and
/// day of year).
#[derive(Debug, Clone, PartialEq)]
pub struct SampleMeta {
    pub sample_id: u32,
    /// The predicted date: days since 1900-01-01 (GRIDMET's day numbering).
    pub event_day: i32,
    pub year: i32,
    pub month: u32,
    /// Day of the year, 1-based.
    pub day_of_year: u32,
    pub lat: f64,
    pub lon: f64,
    /// GRIDMET cell (row, column): windows of one cell are correlated, so intervals resample
    /// cells rather than rows.
    pub cell: (u32, u32),
    pub tier: Tier,
    /// The split the dataset itself assigned (`train`, `val`, `test`).
    pub dataset_split: Option<String>,
    /// The synthetic generator's true probability of an ignition (never a model input).
    pub true_probability: Option<f32>,
}

impl SampleMeta {
    /// The facts of a dataset sample (`split`: the dataset's own, when it has one).
    pub fn of(s: &firecast_dataset::windows::WindowSample, split: Option<String>) -> Self {
        let (year, month, _) = firecast_data::gridmet::day_to_ymd(s.event_day);
        let jan1 = firecast_data::gridmet::ymd_to_day(year, 1, 1).unwrap_or(s.event_day);
        SampleMeta {
            sample_id: s.sample_id,
            event_day: s.event_day,
            year,
            month,
            day_of_year: (s.event_day - jan1 + 1) as u32,
            lat: s.lat,
            lon: s.lon,
            cell: s.cell,
            tier: s.tier,
            dataset_split: split,
            true_probability: s.true_probability,
        }
    }
}

/// A dataset in memory.
#[derive(Debug, Clone)]
pub struct Windows {
    pub manifest: DatasetManifest,
    pub features: Vec<String>,
    /// Day offset of day slot 0 (relative to the predicted date).
    pub first_offset: i32,
    pub n_days: usize,
    /// `values[(s * n_days + d) * n_features + f]`.
    pub values: Vec<f32>,
    pub labels: Vec<bool>,
    pub meta: Vec<SampleMeta>,
}

impl Windows {
    pub fn len(&self) -> usize {
        self.labels.len()
    }

    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }

    pub fn n_features(&self) -> usize {
        self.features.len()
    }

    pub fn last_offset(&self) -> i32 {
        self.first_offset + self.n_days as i32 - 1
    }

    pub fn feature_index(&self, name: &str) -> Option<usize> {
        self.features.iter().position(|f| f == name)
    }

    /// Reads `dir` (a dataset written by `firecast dataset build` or the `data.dataset`
    /// stage). Fill values (NaN) are refused with the sample and feature named: the models
    /// need complete windows, and silently imputing would hide a broken extraction.
    pub fn load(dir: &Path) -> Result<Self, ForecastError> {
        let manifest = read_manifest(dir).map_err(|e| ForecastError::dataset(dir, e))?;
        let stored = read_window_table(dir).map_err(|e| ForecastError::dataset(dir, e))?;
        let table = stored.table;
        let nf = table.n_features();
        if table.samples.is_empty() {
            return Err(ForecastError::Data {
                path: dir.to_path_buf(),
                message: "the dataset has no samples".into(),
            });
        }
        if let Some(at) = table.values.iter().position(|v| !v.is_finite()) {
            let s = at / (table.n_days * nf);
            let d = (at / nf) % table.n_days;
            return Err(ForecastError::Data {
                path: dir.join(firecast_dataset::table::DAYS_FILE),
                message: format!(
                    "sample {} (id {}) has a missing value in `{}` on day {:+}: fill values must be \
                     dropped or repaired before training",
                    s,
                    table.samples[s].sample_id,
                    table.features[at % nf],
                    table.first_offset + d as i32
                ),
            });
        }
        let mut meta = Vec::with_capacity(table.samples.len());
        let mut labels = Vec::with_capacity(table.samples.len());
        for (i, s) in table.samples.iter().enumerate() {
            labels.push(s.tier.is_positive());
            meta.push(SampleMeta::of(s, stored.splits.as_ref().map(|v| v[i].clone())));
        }
        Ok(Self {
            manifest,
            features: table.features,
            first_offset: table.first_offset,
            n_days: table.n_days,
            values: table.values,
            labels,
            meta,
        })
    }

    /// The day slots covering offsets `lo..=hi`, or an error naming what the dataset has.
    pub fn day_range(&self, lo: i32, hi: i32, key: &str) -> Result<std::ops::Range<usize>, ForecastError> {
        if lo > hi || lo < self.first_offset || hi > self.last_offset() {
            return Err(ForecastError::Config {
                key: key.into(),
                message: format!(
                    "days {lo}..{hi} are not inside the dataset's days {}..{} (framing `{:?}`); \
                     a leak-free protocol needs inputs before day 0, the paper protocol needs \
                     a paper-framed dataset (days -60..14)",
                    self.first_offset,
                    self.last_offset(),
                    self.manifest.framing.kind
                ),
            });
        }
        let a = (lo - self.first_offset) as usize;
        let b = (hi - self.first_offset) as usize + 1;
        Ok(a..b)
    }
}

/// The model inputs of one protocol: the chosen days and features of the chosen samples,
/// laid out `[sample, day, feature]`.
#[derive(Debug, Clone)]
pub struct Block {
    pub features: Vec<String>,
    pub first_offset: i32,
    pub n_days: usize,
    pub values: Vec<f32>,
}

impl Block {
    pub fn n_features(&self) -> usize {
        self.features.len()
    }

    pub fn rows(&self) -> usize {
        self.values.len() / (self.n_days * self.n_features()).max(1)
    }

    pub fn sample(&self, s: usize) -> &[f32] {
        let w = self.n_days * self.n_features();
        &self.values[s * w..(s + 1) * w]
    }

    /// Cuts `windows` down to `days`, `features` and the samples `rows`.
    pub fn cut(windows: &Windows, days: std::ops::Range<usize>, features: &[usize], rows: &[usize]) -> Block {
        let nf = windows.n_features();
        let mut values = Vec::with_capacity(rows.len() * days.len() * features.len());
        for &s in rows {
            for d in days.clone() {
                let at = (s * windows.n_days + d) * nf;
                let row = &windows.values[at..at + nf];
                values.extend(features.iter().map(|&f| row[f]));
            }
        }
        Block {
            features: features.iter().map(|&f| windows.features[f].clone()).collect(),
            first_offset: windows.first_offset + days.start as i32,
            n_days: days.len(),
            values,
        }
    }

    /// Rows of the flattened `[day × feature]` vectors, in sample order.
    pub fn flat(&self) -> firecast_baselines::Matrix {
        let cols = self.n_days * self.n_features();
        firecast_baselines::Matrix::new(self.rows(), cols, self.values.clone())
            .unwrap_or_else(|_| firecast_baselines::Matrix::empty(cols))
    }
}
