//! Weather windows: for every sample, the nearest GRIDMET cell and a run of days around its
//! date, for each variable.
//!
//! Extraction is organised by *file*, not by sample: every `(variable, year)` file is opened
//! once and all the samples that need it are gathered in one pass (one hyperslab read per
//! block of days, see `GridmetFile::gather`). Files are processed in parallel, a bounded
//! batch at a time, so memory stays at the output plus one block per thread.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use firecast_data::gridmet::{GridmetFile, GridmetVariable};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::time::{self, DayBoundary};
use crate::{DatasetError, Tier};

/// The paper's 15 features, in the column order of the published CSV (docs/spec/data.md §3.1).
pub const PAPER_FEATURES: [GridmetVariable; 15] = [
    GridmetVariable::Pr,
    GridmetVariable::Rmax,
    GridmetVariable::Rmin,
    GridmetVariable::Sph,
    GridmetVariable::Srad,
    GridmetVariable::Tmmn,
    GridmetVariable::Tmmx,
    GridmetVariable::Vs,
    GridmetVariable::Bi,
    GridmetVariable::Fm100,
    GridmetVariable::Fm1000,
    GridmetVariable::Erc,
    GridmetVariable::Etr,
    GridmetVariable::Pet,
    GridmetVariable::Vpd,
];

/// One GRIDMET file found on disk.
#[derive(Debug, Clone)]
pub struct GridmetSource {
    pub variable: GridmetVariable,
    pub year: i32,
    pub path: PathBuf,
}

/// The `<short>_<YYYY>.nc` files in `dir`, sorted by file name.
pub fn list_gridmet_files(dir: &Path) -> Result<Vec<GridmetSource>, DatasetError> {
    let entries = std::fs::read_dir(dir).map_err(|e| DatasetError::Io {
        context: "listing GRIDMET files",
        path: dir.to_path_buf(),
        source: e,
    })?;
    let mut out = Vec::new();
    for entry in entries.flatten() {
        let path = entry.path();
        if let Some((variable, year)) = GridmetVariable::from_file_name(&path) {
            out.push(GridmetSource { variable, year, path });
        }
    }
    out.sort_by(|a, b| a.path.cmp(&b.path));
    Ok(out)
}

/// Extraction settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ExtractConfig {
    /// First day of every window relative to the sample's date (the paper: −60).
    #[serde(default = "default_first_offset")]
    pub first_offset: i32,
    /// Last day (the paper: +14).
    #[serde(default = "default_last_offset")]
    pub last_offset: i32,
    /// Which calendar day a discovery instant belongs to.
    #[serde(default)]
    pub day_boundary: DayBoundary,
    /// GRIDMET short names, in column order. Default: the paper's 15.
    #[serde(default = "default_variables")]
    pub variables: Vec<String>,
}

fn default_first_offset() -> i32 {
    -60
}
fn default_last_offset() -> i32 {
    14
}
fn default_variables() -> Vec<String> {
    PAPER_FEATURES
        .iter()
        .map(|v| v.short_name().to_string())
        .collect()
}

impl Default for ExtractConfig {
    fn default() -> Self {
        Self {
            first_offset: default_first_offset(),
            last_offset: default_last_offset(),
            day_boundary: DayBoundary::default(),
            variables: default_variables(),
        }
    }
}

impl ExtractConfig {
    /// The variables, checked.
    pub fn resolve_variables(&self) -> Result<Vec<GridmetVariable>, DatasetError> {
        if self.variables.is_empty() {
            return Err(DatasetError::Config {
                key: "variables".into(),
                message: "at least one variable is needed".into(),
            });
        }
        self.variables
            .iter()
            .enumerate()
            .map(|(k, s)| {
                GridmetVariable::from_short_name(s).ok_or_else(|| DatasetError::Config {
                    key: format!("variables[{k}]"),
                    message: format!(
                        "unknown GRIDMET variable `{s}` (known: {})",
                        GridmetVariable::ALL.map(|v| v.short_name()).join(", ")
                    ),
                })
            })
            .collect()
    }

    fn check(&self) -> Result<(), DatasetError> {
        if self.last_offset < self.first_offset {
            return Err(DatasetError::Config {
                key: "last_offset".into(),
                message: format!(
                    "{} is before first_offset {}",
                    self.last_offset, self.first_offset
                ),
            });
        }
        Ok(())
    }
}

/// A sample with its place in the dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct WindowSample {
    pub sample_id: u32,
    pub lat: f64,
    pub lon: f64,
    pub time_ms: i64,
    /// The sample's GRIDMET day (after the day-boundary rule).
    pub event_day: i32,
    pub tier: Tier,
    pub source_row: Option<u64>,
    /// GRIDMET cell (row from the north, column from the west, on the full CONUS grid) and
    /// its centre.
    pub cell: (u32, u32),
    pub cell_lat: f64,
    pub cell_lon: f64,
    /// The synthetic generator's true probability of at least one ignition at `cell` on
    /// `event_day` (`1 − exp(−λ)`, see [`crate::truth`]): the oracle's score. `None` for real
    /// data, Kaggle imports, and windows extracted without truth. Never a feature.
    pub true_probability: Option<f32>,
}

impl WindowSample {
    /// Fire on the sample's date (an imported positive window's event day is its ignition
    /// day, so it counts too).
    pub fn label(&self) -> bool {
        self.tier.is_positive()
    }
}

/// Samples and their weather: `values[(s * n_days + d) * n_features + f]`, NaN = missing.
#[derive(Debug, Clone)]
pub struct WindowTable {
    pub features: Vec<String>,
    pub first_offset: i32,
    pub n_days: usize,
    pub samples: Vec<WindowSample>,
    pub values: Vec<f32>,
    /// Per-row `Wildfire` labels when they come from a source (the Kaggle CSV); otherwise
    /// they follow from the sample label and the day offset.
    pub row_labels: Option<Vec<bool>>,
}

impl WindowTable {
    pub fn n_features(&self) -> usize {
        self.features.len()
    }

    /// Values of sample `s` on day slot `d`.
    pub fn row(&self, s: usize, d: usize) -> &[f32] {
        let nf = self.features.len();
        let at = (s * self.n_days + d) * nf;
        &self.values[at..at + nf]
    }

    /// Day offset of day slot `d`.
    pub fn offset(&self, d: usize) -> i32 {
        self.first_offset + d as i32
    }

    /// The published layout's row label: a positive sample's rows are `Yes` from its event
    /// day on.
    pub fn layout_label(&self, s: usize, d: usize) -> bool {
        self.samples[s].label() && self.offset(d) >= 0
    }

    /// Drops explicit row labels when they all follow [`Self::layout_label`], so only
    /// imported tables that differ from the layout carry them.
    pub fn drop_derived_row_labels(&mut self) {
        let n_days = self.n_days;
        let derived = self.row_labels.as_ref().is_some_and(|labels| {
            (0..self.samples.len())
                .all(|s| (0..n_days).all(|d| labels[s * n_days + d] == self.layout_label(s, d)))
        });
        if derived {
            self.row_labels = None;
        }
    }
}

/// What extraction did.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ExtractReport {
    pub samples_in: u64,
    pub samples_out: u64,
    /// Samples left out, by reason.
    pub dropped: BTreeMap<String, u64>,
    pub files_read: u64,
    /// Missing (masked) values per feature in the kept windows.
    pub missing_values: BTreeMap<String, u64>,
    /// The GRIDMET years found on disk.
    pub years: (i32, i32),
    /// BLAKE3 of every source file read, by file name.
    pub source_hashes: BTreeMap<String, String>,
}

/// An input sample for extraction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleIn {
    pub sample_id: u32,
    pub lat: f64,
    pub lon: f64,
    pub time_ms: i64,
    pub tier: Tier,
    pub source_row: Option<u64>,
}

struct Task {
    variable: GridmetVariable,
    /// Column within the gathered features.
    column: usize,
    path: PathBuf,
    /// `(sample slot, first window day slot, first day index in the file, number of days)`
    needs: Vec<(usize, usize, i32, usize)>,
}

/// Gathers the windows of `samples` from the GRIDMET files in `dir`.
///
/// `progress(done, total)` is called after each file.
pub fn extract(
    samples: &[SampleIn],
    dir: &Path,
    cfg: &ExtractConfig,
    hash_sources: bool,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<(WindowTable, ExtractReport), DatasetError> {
    let plan = ExtractPlan::new(samples, dir, cfg)?;
    let gathered = plan.gather(0..plan.n_features(), hash_sources, progress)?;
    let (table, report, _) = assemble(plan.into_head(), vec![gathered])?;
    Ok((table, report))
}

/// What the samples, the settings and the files on disk decide before any value is read.
/// A sharded extraction computes it in every shard alike; shard 0 hands it to the merge.
#[derive(Debug, Clone, PartialEq)]
pub struct ExtractHead {
    pub features: Vec<String>,
    pub first_offset: i32,
    pub n_days: usize,
    /// The samples with a window, in input order, before those with days missing in a file
    /// are dropped (their index here is their *slot*).
    pub kept: Vec<WindowSample>,
    /// `samples_in`, `years` and the samples dropped so far.
    pub report: ExtractReport,
}

/// An extraction split in two: which samples have windows (from the samples, the file names
/// and the first file's grid), then the values of any range of the variables
/// ([`ExtractPlan::gather`]), so the variables can be read in separate shards, each file by
/// exactly one of them, and put together by [`assemble`].
pub struct ExtractPlan {
    dir: PathBuf,
    variables: Vec<GridmetVariable>,
    by_key: BTreeMap<(&'static str, i32), PathBuf>,
    lats: Vec<f64>,
    lons: Vec<f64>,
    last_offset: i32,
    /// Cell indices of each slot in the files' own axes, for reading.
    local: Vec<(usize, usize)>,
    head: ExtractHead,
}

impl ExtractPlan {
    pub fn new(samples: &[SampleIn], dir: &Path, cfg: &ExtractConfig) -> Result<Self, DatasetError> {
        cfg.check()?;
        let variables = cfg.resolve_variables()?;
        let files = list_gridmet_files(dir)?;
        let mut by_key: BTreeMap<(&'static str, i32), PathBuf> = BTreeMap::new();
        for f in &files {
            by_key.insert((f.variable.short_name(), f.year), f.path.clone());
        }
        // The years and the grid come from every variable, whichever ones a shard reads.
        let years: Vec<i32> = files
            .iter()
            .filter(|f| variables.contains(&f.variable))
            .map(|f| f.year)
            .collect();
        let (Some(&y0), Some(&y1)) = (years.iter().min(), years.iter().max()) else {
            return Err(DatasetError::Input {
                path: dir.to_path_buf(),
                message: format!(
                    "no GRIDMET files for {} (expected names like {})",
                    cfg.variables.join(", "),
                    variables[0].file_name(2020)
                ),
            });
        };
        // The grid comes from the first file; every other file must have the same axes.
        let first_path = by_key
            .iter()
            .find(|((s, _), _)| *s == variables[0].short_name())
            .map(|(_, p)| p.clone())
            .unwrap_or_else(|| files[0].path.clone());
        let first_var = GridmetVariable::from_file_name(&first_path).map_or(variables[0], |v| v.0);
        let grid = GridmetFile::open(&first_path, first_var)?;

        let mut report = ExtractReport {
            samples_in: samples.len() as u64,
            years: (y0, y1),
            ..Default::default()
        };
        let n_days = (cfg.last_offset - cfg.first_offset + 1) as usize;
        let mut kept: Vec<WindowSample> = Vec::with_capacity(samples.len());
        let mut local: Vec<(usize, usize)> = Vec::with_capacity(samples.len());
        for s in samples {
            let event_day = time::gridmet_day(s.time_ms, cfg.day_boundary);
            let (first, last) = (event_day + cfg.first_offset, event_day + cfg.last_offset);
            if time::year_of(first) < y0 || time::year_of(last) > y1 {
                *report
                    .dropped
                    .entry("window_outside_gridmet_years".into())
                    .or_default() += 1;
                continue;
            }
            let Some((j, i)) = grid.nearest_cell(s.lat, s.lon) else {
                *report.dropped.entry("outside_gridmet_grid".into()).or_default() += 1;
                continue;
            };
            local.push((j, i));
            kept.push(WindowSample {
                sample_id: s.sample_id,
                lat: s.lat,
                lon: s.lon,
                time_ms: s.time_ms,
                event_day,
                tier: s.tier,
                source_row: s.source_row,
                cell: crate::geo::gridmet_cell_index(grid.lats()[j], grid.lons()[i]),
                cell_lat: grid.lats()[j],
                cell_lon: grid.lons()[i],
                true_probability: None,
            });
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            by_key,
            lats: grid.lats().to_vec(),
            lons: grid.lons().to_vec(),
            last_offset: cfg.last_offset,
            local,
            head: ExtractHead {
                features: variables.iter().map(|v| v.short_name().to_string()).collect(),
                first_offset: cfg.first_offset,
                n_days,
                kept,
                report,
            },
            variables,
        })
    }

    pub fn n_features(&self) -> usize {
        self.variables.len()
    }

    pub fn head(&self) -> &ExtractHead {
        &self.head
    }

    pub fn into_head(self) -> ExtractHead {
        self.head
    }

    /// Reads the variables `features` (indices into the configured variables) for every kept
    /// sample: one task per `(variable, year)` file some window touches, files in parallel.
    pub fn gather(
        &self,
        features: Range<usize>,
        hash_sources: bool,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<Gathered, DatasetError> {
        let variables = self.variables.get(features.clone()).ok_or_else(|| {
            DatasetError::Shard(format!(
                "features {}..{} of {} variables",
                features.start,
                features.end,
                self.variables.len()
            ))
        })?;
        let head = &self.head;
        let (first_offset, n_days) = (head.first_offset, head.n_days);
        let mut tasks: BTreeMap<(usize, i32), Task> = BTreeMap::new();
        for (slot, s) in head.kept.iter().enumerate() {
            let first = s.event_day + first_offset;
            let mut day = first;
            while day <= s.event_day + self.last_offset {
                let year = time::year_of(day);
                let year_end = time::parse_date(&format!("{year}-12-31")).unwrap_or(day);
                let last = year_end.min(s.event_day + self.last_offset);
                for (column, v) in variables.iter().enumerate() {
                    let task = match tasks.entry((column, year)) {
                        std::collections::btree_map::Entry::Occupied(o) => o.into_mut(),
                        std::collections::btree_map::Entry::Vacant(e) => {
                            let path =
                                self.by_key.get(&(v.short_name(), year)).cloned().ok_or_else(|| {
                                    DatasetError::MissingSource {
                                        path: self.dir.join(v.file_name(year)),
                                        what: format!("GRIDMET `{}` for {year}", v.short_name()),
                                    }
                                })?;
                            e.insert(Task {
                                variable: *v,
                                column,
                                path,
                                needs: Vec::new(),
                            })
                        }
                    };
                    task.needs
                        .push((slot, (day - first) as usize, day, (last - day + 1) as usize));
                }
                day = last + 1;
            }
        }

        let nf = variables.len();
        let mut out = Gathered {
            features,
            values: vec![f32::NAN; head.kept.len() * n_days * nf],
            invalid: vec![false; head.kept.len()],
            files_read: 0,
            source_hashes: BTreeMap::new(),
        };
        let tasks: Vec<Task> = tasks.into_values().collect();
        let total = tasks.len() as u64;
        let batch = rayon::current_num_threads().max(1);
        let done = std::sync::atomic::AtomicU64::new(0);
        for chunk in tasks.chunks(batch) {
            let results: Vec<Result<TaskResult, DatasetError>> = chunk
                .par_iter()
                .map(|task| {
                    let r = run_task(task, &self.local, &self.lats, &self.lons, hash_sources);
                    let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                    progress(d, total);
                    r
                })
                .collect();
            for (task, result) in chunk.iter().zip(results) {
                let result = result?;
                out.files_read += 1;
                if let Some(h) = result.hash {
                    let name = task
                        .path
                        .file_name()
                        .map(|n| n.to_string_lossy().into_owned())
                        .unwrap_or_default();
                    out.source_hashes.insert(name, h);
                }
                for (need, series) in task.needs.iter().zip(&result.series) {
                    let (slot, day_slot, _, len) = *need;
                    match series {
                        Some(series) => {
                            for (k, v) in series.iter().enumerate().take(len) {
                                out.values[(slot * n_days + day_slot + k) * nf + task.column] = *v;
                            }
                        }
                        None => out.invalid[slot] = true,
                    }
                }
            }
        }
        Ok(out)
    }
}

/// The values of a contiguous range of the variables for every kept sample (slot), before
/// samples with days missing in a file are dropped.
#[derive(Debug, Clone, PartialEq)]
pub struct Gathered {
    /// Indices into the configured variables.
    pub features: Range<usize>,
    /// `values[(slot * n_days + d) * features.len() + k]`, NaN = missing.
    pub values: Vec<f32>,
    /// Slots with a day missing in one of these variables' files.
    pub invalid: Vec<bool>,
    pub files_read: u64,
    /// BLAKE3 of every file read, by file name.
    pub source_hashes: BTreeMap<String, String>,
}

/// Puts the gathered variables (every one exactly once, in order) together: drops the samples
/// with days missing in any file and counts the missing values, as an unsharded extraction
/// does. Also returns each output sample's slot in `head.kept`.
pub fn assemble(
    head: ExtractHead,
    parts: Vec<Gathered>,
) -> Result<(WindowTable, ExtractReport, Vec<usize>), DatasetError> {
    let nf = head.features.len();
    let (n, n_days) = (head.kept.len(), head.n_days);
    let mut next = 0;
    for p in &parts {
        let width = p.features.end.saturating_sub(p.features.start);
        if p.features.start != next
            || p.features.end > nf
            || width == 0
            || p.values.len() != n * n_days * width
            || p.invalid.len() != n
        {
            return Err(DatasetError::Shard(format!(
                "gathered variables {}..{} ({} values, {} slots) do not continue variables 0..{next} \
                 of {nf} for {n} samples x {n_days} days",
                p.features.start,
                p.features.end,
                p.values.len(),
                p.invalid.len()
            )));
        }
        next = p.features.end;
    }
    if next != nf {
        return Err(DatasetError::Shard(format!(
            "the gathered variables cover {next} of {nf}"
        )));
    }
    let mut report = head.report;
    let invalid: Vec<bool> = (0..n).map(|slot| parts.iter().any(|p| p.invalid[slot])).collect();
    for p in &parts {
        report.files_read += p.files_read;
        report
            .source_hashes
            .extend(p.source_hashes.iter().map(|(k, v)| (k.clone(), v.clone())));
    }

    // Drop samples whose days were not in a file (a partial year at the end of the record).
    let mut samples_out = Vec::with_capacity(n);
    let mut slots = Vec::with_capacity(n);
    let mut values_out = Vec::with_capacity(n * n_days * nf);
    for (slot, s) in head.kept.into_iter().enumerate() {
        if invalid[slot] {
            *report
                .dropped
                .entry("days_missing_in_gridmet_file".into())
                .or_default() += 1;
            continue;
        }
        if let [one] = parts.as_slice() {
            values_out.extend_from_slice(&one.values[slot * n_days * nf..(slot + 1) * n_days * nf]);
        } else {
            for d in 0..n_days {
                for p in &parts {
                    let w = p.features.len();
                    let at = (slot * n_days + d) * w;
                    values_out.extend_from_slice(&p.values[at..at + w]);
                }
            }
        }
        samples_out.push(s);
        slots.push(slot);
    }
    for (f, name) in head.features.iter().enumerate() {
        let missing = values_out.chunks(nf).filter(|row| row[f].is_nan()).count() as u64;
        report.missing_values.insert(name.clone(), missing);
    }
    report.samples_out = samples_out.len() as u64;
    Ok((
        WindowTable {
            features: head.features,
            first_offset: head.first_offset,
            n_days,
            samples: samples_out,
            values: values_out,
            row_labels: None,
        },
        report,
        slots,
    ))
}

struct TaskResult {
    /// Per need: the values, or `None` when a day is not in the file.
    series: Vec<Option<Vec<f32>>>,
    hash: Option<String>,
}

fn run_task(
    task: &Task,
    local: &[(usize, usize)],
    lats: &[f64],
    lons: &[f64],
    hash_sources: bool,
) -> Result<TaskResult, DatasetError> {
    let file = GridmetFile::open(&task.path, task.variable)?;
    if file.lats() != lats || file.lons() != lons {
        return Err(DatasetError::Input {
            path: task.path.clone(),
            message: "its lat/lon grid differs from the other GRIDMET files".into(),
        });
    }
    let days = file.days();
    let Some(&day0) = days.first() else {
        return Ok(TaskResult {
            series: vec![None; task.needs.len()],
            hash: None,
        });
    };
    let contiguous = days
        .last()
        .is_some_and(|&l| (l - day0) as usize + 1 == days.len());
    let index_of = |day: i32| -> Option<usize> {
        if contiguous {
            let k = day - day0;
            (k >= 0 && (k as usize) < days.len()).then_some(k as usize)
        } else {
            days.binary_search(&day).ok()
        }
    };
    // Where each need starts in the file, and the day range each unique cell must supply.
    let located: Vec<Option<usize>> = task
        .needs
        .iter()
        .map(|n| match (index_of(n.2), index_of(n.2 + n.3 as i32 - 1)) {
            (Some(a), Some(b)) if b - a + 1 == n.3 => Some(a),
            _ => None,
        })
        .collect();
    let mut ranges: BTreeMap<(usize, usize), (usize, usize)> = BTreeMap::new();
    for (n, at) in task.needs.iter().zip(&located) {
        if let Some(a) = at {
            let r = ranges.entry(local[n.0]).or_insert((*a, a + n.3));
            r.0 = r.0.min(*a);
            r.1 = r.1.max(a + n.3);
        }
    }
    if ranges.is_empty() {
        return Ok(TaskResult {
            series: vec![None; task.needs.len()],
            hash: None,
        });
    }
    // Two ways to read: one time series per cell (what sparse samples need: a few hundred
    // values each), or the bounding hyperslab in blocks of days (dense samples). Choose by the
    // values each would read.
    let needed: usize = ranges.values().map(|(a, b)| b - a).sum();
    let (j0, j1) = ranges
        .keys()
        .fold((usize::MAX, 0), |acc, c| (acc.0.min(c.0), acc.1.max(c.0 + 1)));
    let (i0, i1) = ranges
        .keys()
        .fold((usize::MAX, 0), |acc, c| (acc.0.min(c.1), acc.1.max(c.1 + 1)));
    let (d0, d1) = ranges
        .values()
        .fold((usize::MAX, 0), |acc, r| (acc.0.min(r.0), acc.1.max(r.1)));
    let bounding = (j1 - j0) * (i1 - i0) * (d1 - d0);
    // A per-cell read costs about as much as a few hundred values of a block read.
    let per_cell_cost = needed + 400 * ranges.len();
    let mut by_cell: BTreeMap<(usize, usize), (usize, Vec<f32>)> = BTreeMap::new();
    if per_cell_cost < bounding {
        for (cell, (a, b)) in &ranges {
            let mut series = file.gather(&[*cell], *a..*b)?;
            by_cell.insert(*cell, (*a, series.pop().unwrap_or_default()));
        }
    } else {
        let cells: Vec<(usize, usize)> = ranges.keys().copied().collect();
        let gathered = file.gather(&cells, d0..d1)?;
        for (cell, series) in cells.into_iter().zip(gathered) {
            by_cell.insert(cell, (d0, series));
        }
    }
    let series = task
        .needs
        .iter()
        .zip(located)
        .map(|(n, at)| {
            let at = at?;
            let (start, values) = by_cell.get(&local[n.0])?;
            values.get(at - start..at - start + n.3).map(<[f32]>::to_vec)
        })
        .collect();
    let hash = if hash_sources {
        Some(crate::hash_file(&task.path)?)
    } else {
        None
    };
    Ok(TaskResult { series, hash })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn head(n: usize) -> ExtractHead {
        ExtractHead {
            features: vec!["a".into(), "b".into(), "c".into()],
            first_offset: -1,
            n_days: 2,
            kept: (0..n as u32)
                .map(|k| WindowSample {
                    sample_id: k,
                    lat: 40.0,
                    lon: -105.0,
                    time_ms: 0,
                    event_day: 40_000,
                    tier: Tier::Positive,
                    source_row: None,
                    cell: (k, k),
                    cell_lat: 40.0,
                    cell_lon: -105.0,
                    true_probability: None,
                })
                .collect(),
            report: ExtractReport::default(),
        }
    }

    /// Value of slot `s`, day `d`, feature `f`; feature 2 of slot 2 is missing.
    fn value(s: usize, d: usize, f: usize) -> f32 {
        if (s, f) == (2, 2) {
            f32::NAN
        } else {
            (s * 100 + d * 10 + f) as f32
        }
    }

    fn part(features: Range<usize>, invalid: Vec<bool>, hash: &str) -> Gathered {
        let mut values = Vec::new();
        for s in 0..invalid.len() {
            for d in 0..2 {
                values.extend(features.clone().map(|f| value(s, d, f)));
            }
        }
        Gathered {
            features,
            values,
            invalid,
            files_read: 1,
            source_hashes: BTreeMap::from([(hash.to_string(), "h".to_string())]),
        }
    }

    #[test]
    fn a_sample_missing_days_in_one_range_is_dropped_from_every_variable() {
        let whole = part(0..3, vec![false, true, false, false], "all");
        let (t, r, slots) = assemble(head(4), vec![whole]).unwrap();
        let split = vec![
            part(0..1, vec![false, true, false, false], "a"),
            part(1..3, vec![false, false, false, false], "bc"),
        ];
        let (ts, rs, slots_s) = assemble(head(4), split).unwrap();
        assert_eq!(slots, vec![0, 2, 3]);
        assert_eq!(slots_s, slots);
        assert_eq!(ts.samples, t.samples);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&ts.values), bits(&t.values));
        // Output row 1 is slot 2, whose third variable is missing.
        assert_eq!(t.row(1, 1)[..2], [value(2, 1, 0), value(2, 1, 1)]);
        assert!(t.row(1, 1)[2].is_nan());
        assert_eq!(r.dropped.get("days_missing_in_gridmet_file"), Some(&1));
        assert_eq!(r.missing_values.get("c"), Some(&2));
        assert_eq!(r.samples_out, 3);
        // Everything but the files and their hashes is the same.
        assert_eq!(rs.files_read, 2);
        assert_eq!(rs.source_hashes.len(), 2);
        assert_eq!(
            ExtractReport {
                files_read: 0,
                source_hashes: BTreeMap::new(),
                ..rs
            },
            ExtractReport {
                files_read: 0,
                source_hashes: BTreeMap::new(),
                ..r
            }
        );
    }
}
