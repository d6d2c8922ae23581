//! Weather windows: for every sample, the nearest GRIDMET cell and a run of days around its
//! date, for each variable.
//!
//! Extraction is organised by *file*, not by sample: every `(variable, year)` file is opened
//! once and all the samples that need it are gathered in one pass (one hyperslab read per
//! block of days, see `GridmetFile::gather`). Files are processed in parallel, a bounded
//! batch at a time, so memory stays at the output plus one block per thread.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use firecast_data::gridmet::{GridmetFile, GridmetVariable};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::time::{self, DayBoundary};
use crate::{DatasetError, Tier};

/// The paper's 15 features, in the column order of the published CSV (data spec §3.1).
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
    /// Fire on the sample's date.
    pub fn label(&self) -> bool {
        self.tier == Tier::Positive
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
    feature: usize,
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
    cfg.check()?;
    let variables = cfg.resolve_variables()?;
    let files = list_gridmet_files(dir)?;
    let mut by_key: BTreeMap<(&'static str, i32), PathBuf> = BTreeMap::new();
    for f in &files {
        by_key.insert((f.variable.short_name(), f.year), f.path.clone());
    }
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
    // Cell indices in the files' own axes, for reading.
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

    // One task per (variable, year) file that some window touches.
    let mut tasks: BTreeMap<(usize, i32), Task> = BTreeMap::new();
    for (slot, s) in kept.iter().enumerate() {
        let first = s.event_day + cfg.first_offset;
        let mut day = first;
        while day <= s.event_day + cfg.last_offset {
            let year = time::year_of(day);
            let year_end = time::parse_date(&format!("{year}-12-31")).unwrap_or(day);
            let last = year_end.min(s.event_day + cfg.last_offset);
            for (f, v) in variables.iter().enumerate() {
                let task = match tasks.entry((f, year)) {
                    std::collections::btree_map::Entry::Occupied(o) => o.into_mut(),
                    std::collections::btree_map::Entry::Vacant(e) => {
                        let path = by_key.get(&(v.short_name(), year)).cloned().ok_or_else(|| {
                            DatasetError::MissingSource {
                                path: dir.join(v.file_name(year)),
                                what: format!("GRIDMET `{}` for {year}", v.short_name()),
                            }
                        })?;
                        e.insert(Task {
                            variable: *v,
                            feature: f,
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
    let mut values = vec![f32::NAN; kept.len() * n_days * nf];
    let mut invalid = vec![false; kept.len()];
    let tasks: Vec<Task> = tasks.into_values().collect();
    let total = tasks.len() as u64;
    let batch = rayon::current_num_threads().max(1);
    let done = std::sync::atomic::AtomicU64::new(0);
    for chunk in tasks.chunks(batch) {
        let results: Vec<Result<TaskResult, DatasetError>> = chunk
            .par_iter()
            .map(|task| {
                let r = run_task(task, &local, grid.lats(), grid.lons(), hash_sources);
                let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                progress(d, total);
                r
            })
            .collect();
        for (task, result) in chunk.iter().zip(results) {
            let result = result?;
            report.files_read += 1;
            if let Some(h) = result.hash {
                let name = task
                    .path
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default();
                report.source_hashes.insert(name, h);
            }
            for (need, series) in task.needs.iter().zip(&result.series) {
                let (slot, day_slot, _, len) = *need;
                match series {
                    Some(series) => {
                        for (k, v) in series.iter().enumerate().take(len) {
                            values[(slot * n_days + day_slot + k) * nf + task.feature] = *v;
                        }
                    }
                    None => invalid[slot] = true,
                }
            }
        }
    }

    // Drop samples whose days were not in a file (a partial year at the end of the record).
    let mut samples_out = Vec::with_capacity(kept.len());
    let mut values_out = Vec::with_capacity(values.len());
    for (slot, s) in kept.into_iter().enumerate() {
        if invalid[slot] {
            *report
                .dropped
                .entry("days_missing_in_gridmet_file".into())
                .or_default() += 1;
            continue;
        }
        values_out.extend_from_slice(&values[slot * n_days * nf..(slot + 1) * n_days * nf]);
        samples_out.push(s);
    }
    for (f, v) in variables.iter().enumerate() {
        let missing = values_out.chunks(nf).filter(|row| row[f].is_nan()).count() as u64;
        report.missing_values.insert(v.short_name().to_string(), missing);
    }
    report.samples_out = samples_out.len() as u64;
    Ok((
        WindowTable {
            features: variables.iter().map(|v| v.short_name().to_string()).collect(),
            first_offset: cfg.first_offset,
            n_days,
            samples: samples_out,
            values: values_out,
            row_labels: None,
        },
        report,
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
