//! The synthetic generator's true ignition probability (the "oracle"), looked up for each
//! sample at its GRIDMET cell and event day.
//!
//! `firecast_synth` writes `truth/ignition_probability_<YYYY>.nc` on the GRIDMET grid:
//! `1 − exp(−λ)` of the Poisson rate it drew the ignitions from. A forecasting experiment
//! scores each sample by it to get the best skill any model can reach on those data. It is
//! stored per sample ([`WindowSample::true_probability`], the nullable column
//! [`TRUE_PROBABILITY_COLUMN`] of `samples.parquet`) and is never one of the features.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use firecast_data::gridmet::GridmetFile;
use firecast_synth::{TRUTH_VARIABLE, truth_file_name, truth_file_year};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::DatasetError;
use crate::windows::WindowSample;

/// Column of `samples.parquet` holding [`WindowSample::true_probability`] (Float32, nullable;
/// present only when some sample has a value).
pub const TRUE_PROBABILITY_COLUMN: &str = "true_ignition_probability";

/// Largest number of cells read in one hyperslab (bounds memory for dense sample sets).
const CELLS_PER_READ: usize = 4096;

/// What the truth lookup did.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TruthReport {
    /// The folder's name (not its absolute path, so reports built elsewhere are identical).
    pub source: String,
    pub files_read: u64,
    /// Samples that got a probability.
    pub samples_with_value: u64,
    /// Samples on a cell the truth masks (no land): `None`.
    pub samples_masked: u64,
    /// BLAKE3 of every truth file read, by file name.
    pub source_hashes: BTreeMap<String, String>,
}

/// The `ignition_probability_<YYYY>.nc` files in `dir`, by year.
pub fn list_truth_files(dir: &Path) -> Result<BTreeMap<i32, PathBuf>, DatasetError> {
    let entries = std::fs::read_dir(dir).map_err(DatasetError::io("listing truth files in", dir))?;
    let mut out = BTreeMap::new();
    for entry in entries.flatten() {
        let path = entry.path();
        if let Some(year) = truth_file_year(&path) {
            out.insert(year, path);
        }
    }
    Ok(out)
}

/// Sets [`WindowSample::true_probability`] of every sample from the truth files in `dir`:
/// the value at the sample's GRIDMET cell (`cell_lat`, `cell_lon`) on its `event_day`, `None`
/// where the truth is masked. A year without a file, a cell off the truth grid or a day
/// missing from its file is an error naming the file: the truth must cover what the GRIDMET
/// files covered.
pub fn attach_truth(
    samples: &mut [WindowSample],
    dir: &Path,
    hash_sources: bool,
) -> Result<TruthReport, DatasetError> {
    let lookup = lookup_truth(samples, dir, hash_sources)?;
    let slots: Vec<usize> = (0..samples.len()).collect();
    lookup.apply(samples, &slots)
}

/// A truth file read for a lookup.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TruthFile {
    pub name: String,
    /// BLAKE3, when the lookup hashed its sources.
    pub hash: Option<String>,
}

/// The truth of every sample with what went wrong kept per year and per sample, not raised:
/// the windows look the truth up before they know which samples lose their window to a
/// file's missing days, and only the samples that keep one may fail it
/// ([`TruthLookup::apply`]).
#[derive(Debug)]
pub struct TruthLookup {
    /// The folder's name.
    pub source: String,
    /// Per year with samples: its file, or why it could not be read.
    pub years: BTreeMap<i32, Result<TruthFile, DatasetError>>,
    /// Per sample: its probability (`None`: masked), or why its file has none for it.
    pub values: Vec<Result<Option<f32>, DatasetError>>,
}

/// Looks up the truth of every sample (see [`attach_truth`]), keeping errors per year and
/// per sample.
pub fn lookup_truth(
    samples: &[WindowSample],
    dir: &Path,
    hash_sources: bool,
) -> Result<TruthLookup, DatasetError> {
    let files = list_truth_files(dir)?;
    let mut by_year: BTreeMap<i32, Vec<usize>> = BTreeMap::new();
    for (k, s) in samples.iter().enumerate() {
        by_year
            .entry(crate::time::year_of(s.event_day))
            .or_default()
            .push(k);
    }
    let jobs: Vec<(i32, Option<&PathBuf>, Vec<usize>)> = by_year
        .into_iter()
        .map(|(year, members)| (year, files.get(&year), members))
        .collect();
    let results: Vec<Result<_, DatasetError>> = jobs
        .par_iter()
        .map(|(_, path, members)| {
            let Some(path) = path else {
                return Ok(None);
            };
            let values = read_year(path, samples, members)?;
            let hash = if hash_sources {
                Some(crate::hash_file(path)?)
            } else {
                None
            };
            Ok(Some((values, hash)))
        })
        .collect();
    let mut lookup = TruthLookup {
        source: dir
            .file_name()
            .map_or_else(|| dir.display().to_string(), |n| n.to_string_lossy().into_owned()),
        years: BTreeMap::new(),
        values: samples.iter().map(|_| Ok(None)).collect(),
    };
    for ((year, path, members), result) in jobs.into_iter().zip(results) {
        let file = match (path, result) {
            (None, _) => Err(DatasetError::MissingSource {
                path: dir.join(truth_file_name(year)),
                what: format!("true ignition probability (`{TRUTH_VARIABLE}`) for {year}"),
            }),
            (Some(_), Err(e)) => Err(e),
            (Some(path), Ok(found)) => {
                let (values, hash) = found.unwrap_or_default();
                for (k, v) in members.into_iter().zip(values) {
                    lookup.values[k] = v;
                }
                Ok(TruthFile {
                    name: path
                        .file_name()
                        .map(|n| n.to_string_lossy().into_owned())
                        .unwrap_or_default(),
                    hash,
                })
            }
        };
        lookup.years.insert(year, file);
    }
    Ok(lookup)
}

impl TruthLookup {
    /// Sets the truth of `samples`, where `samples[k]` is sample `slots[k]` of the lookup, and
    /// reports what [`attach_truth`] on exactly these samples reports, errors included.
    pub fn apply(
        mut self,
        samples: &mut [WindowSample],
        slots: &[usize],
    ) -> Result<TruthReport, DatasetError> {
        if samples.len() != slots.len() || slots.iter().any(|&s| s >= self.values.len()) {
            return Err(DatasetError::Shard(format!(
                "{} samples at {} slots of a truth lookup of {} samples",
                samples.len(),
                slots.len(),
                self.values.len()
            )));
        }
        let mut by_year: BTreeMap<i32, Vec<usize>> = BTreeMap::new();
        for (k, s) in samples.iter().enumerate() {
            by_year
                .entry(crate::time::year_of(s.event_day))
                .or_default()
                .push(k);
        }
        let mut report = TruthReport {
            source: self.source.clone(),
            ..Default::default()
        };
        // A year without a file is reported before any read error, as the lookup of these
        // samples alone would.
        let missing = by_year
            .keys()
            .copied()
            .find(|y| matches!(self.years.get(y), Some(Err(DatasetError::MissingSource { .. }))));
        for year in missing.into_iter().chain(by_year.keys().copied()) {
            let file = self
                .years
                .remove(&year)
                .ok_or_else(|| DatasetError::Shard(format!("the truth lookup has no entry for {year}")))??;
            report.files_read += 1;
            if let Some(h) = file.hash {
                report.source_hashes.insert(file.name, h);
            }
            for &k in &by_year[&year] {
                let v = std::mem::replace(&mut self.values[slots[k]], Ok(None))?;
                samples[k].true_probability = v;
                if v.is_some() {
                    report.samples_with_value += 1;
                } else {
                    report.samples_masked += 1;
                }
            }
        }
        Ok(report)
    }
}

/// The truth of `samples[members]` from one yearly file, in `members` order; a member off
/// the file's grid or days gets its error, the others their values.
fn read_year(
    path: &Path,
    samples: &[WindowSample],
    members: &[usize],
) -> Result<Vec<Result<Option<f32>, DatasetError>>, DatasetError> {
    let file = GridmetFile::open_named(path, TRUTH_VARIABLE)?;
    let bad = |message: String| DatasetError::Input {
        path: path.to_path_buf(),
        message,
    };
    let days = file.days();
    // Per unique cell: the (member slot, day index) pairs it must supply.
    let mut by_cell: BTreeMap<(usize, usize), Vec<(usize, usize)>> = BTreeMap::new();
    let mut out: Vec<Result<Option<f32>, DatasetError>> = members.iter().map(|_| Ok(None)).collect();
    for (slot, &k) in members.iter().enumerate() {
        let s = &samples[k];
        let cell = file
            .nearest_cell(s.cell_lat, s.cell_lon)
            .filter(|&(j, i)| {
                (file.lats()[j] - s.cell_lat).abs() < 1e-6 && (file.lons()[i] - s.cell_lon).abs() < 1e-6
            })
            .ok_or_else(|| {
                bad(format!(
                    "`{TRUTH_VARIABLE}`: sample {} is at GRIDMET cell ({}, {}), which is not on this \
                     file's grid; the truth must come from the generator run that wrote the GRIDMET files",
                    s.sample_id, s.cell_lat, s.cell_lon
                ))
            });
        let t = days.binary_search(&s.event_day).map_err(|_| {
            bad(format!(
                "`{TRUTH_VARIABLE}`: sample {} is on {}, a day this file does not have",
                s.sample_id,
                crate::time::format_date(s.event_day)
            ))
        });
        match (cell, t) {
            (Ok(cell), Ok(t)) => by_cell.entry(cell).or_default().push((slot, t)),
            (Err(e), _) | (_, Err(e)) => out[slot] = Err(e),
        }
    }
    let cells: Vec<_> = by_cell.into_iter().collect();
    for chunk in cells.chunks(CELLS_PER_READ) {
        let span = |needs: &[(usize, usize)]| {
            let lo = needs.iter().map(|n| n.1).min().unwrap_or(0);
            let hi = needs.iter().map(|n| n.1).max().unwrap_or(0);
            (lo, hi + 1)
        };
        // One time series per cell (sparse samples) or one bounding hyperslab (dense), by the
        // values each would read; a per-cell read costs about as much as a few hundred values.
        let per_cell: usize = chunk
            .iter()
            .map(|(_, n)| {
                let (a, b) = span(n);
                b - a + 400
            })
            .sum();
        let (d0, d1) = chunk.iter().fold((usize::MAX, 0), |acc, (_, n)| {
            let (a, b) = span(n);
            (acc.0.min(a), acc.1.max(b))
        });
        let (j0, j1, i0, i1) = chunk
            .iter()
            .fold((usize::MAX, 0, usize::MAX, 0), |acc, ((j, i), _)| {
                (acc.0.min(*j), acc.1.max(j + 1), acc.2.min(*i), acc.3.max(i + 1))
            });
        let bounding = (j1 - j0) * (i1 - i0) * (d1 - d0);
        if per_cell < bounding {
            for (cell, needs) in chunk {
                let (a, b) = span(needs);
                let series = file.gather(&[*cell], a..b)?;
                for &(slot, t) in needs {
                    out[slot] = Ok(value(series.first().and_then(|s| s.get(t - a))));
                }
            }
        } else {
            let keys: Vec<(usize, usize)> = chunk.iter().map(|(c, _)| *c).collect();
            let series = file.gather(&keys, d0..d1)?;
            for ((_, needs), s) in chunk.iter().zip(&series) {
                for &(slot, t) in needs {
                    out[slot] = Ok(value(s.get(t - d0)));
                }
            }
        }
    }
    Ok(out)
}

fn value(v: Option<&f32>) -> Option<f32> {
    v.copied().filter(|x| x.is_finite())
}

/// The truth column of a finished dataset, for its manifest and card.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthSummary {
    /// [`TRUE_PROBABILITY_COLUMN`].
    pub column: String,
    pub samples_with_value: u64,
    /// Mean true probability over the positive samples that have one.
    pub mean_positive: Option<f64>,
    /// Mean true probability over the negative samples that have one.
    pub mean_negative: Option<f64>,
}

/// The summary of `table`'s truth, `None` when no sample has one.
pub fn summarize(table: &crate::windows::WindowTable) -> Option<TruthSummary> {
    let mean = |positive: bool| {
        let v: Vec<f64> = table
            .samples
            .iter()
            .filter(|s| s.label() == positive)
            .filter_map(|s| s.true_probability.map(f64::from))
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let n = table
        .samples
        .iter()
        .filter(|s| s.true_probability.is_some())
        .count() as u64;
    (n > 0).then(|| TruthSummary {
        column: TRUE_PROBABILITY_COLUMN.to_string(),
        samples_with_value: n,
        mean_positive: mean(true),
        mean_negative: mean(false),
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn sample(k: u32, year: i32) -> WindowSample {
        WindowSample {
            sample_id: k,
            lat: 40.0,
            lon: -105.0,
            time_ms: 0,
            event_day: crate::time::parse_date(&format!("{year}-06-01")).unwrap(),
            tier: crate::Tier::Positive,
            source_row: None,
            cell: (k, k),
            cell_lat: 40.0,
            cell_lon: -105.0,
            true_probability: None,
        }
    }

    /// Slots 0–2 in 2019 (slot 1 off the file's grid), slot 3 in 2020 (no file).
    fn lookup() -> TruthLookup {
        TruthLookup {
            source: "truth".into(),
            years: BTreeMap::from([
                (
                    2019,
                    Ok(TruthFile {
                        name: truth_file_name(2019),
                        hash: Some("h".into()),
                    }),
                ),
                (
                    2020,
                    Err(DatasetError::MissingSource {
                        path: PathBuf::from(truth_file_name(2020)),
                        what: "truth for 2020".into(),
                    }),
                ),
            ]),
            values: vec![
                Ok(Some(0.5)),
                Err(DatasetError::Input {
                    path: PathBuf::from(truth_file_name(2019)),
                    message: "not on this file's grid".into(),
                }),
                Ok(None),
                Ok(Some(0.25)),
            ],
        }
    }

    #[test]
    fn only_the_samples_that_keep_their_windows_may_fail_the_truth() {
        let mut kept = vec![sample(0, 2019), sample(2, 2019)];
        let report = lookup().apply(&mut kept, &[0, 2]).unwrap();
        assert_eq!(kept[0].true_probability, Some(0.5));
        assert_eq!(kept[1].true_probability, None);
        assert_eq!(
            (
                report.files_read,
                report.samples_with_value,
                report.samples_masked
            ),
            (1, 1, 1)
        );
        assert_eq!(report.source_hashes.len(), 1);

        let mut off_grid = vec![sample(0, 2019), sample(1, 2019)];
        let e = lookup().apply(&mut off_grid, &[0, 1]).unwrap_err();
        assert!(e.to_string().contains("not on this file's grid"), "{e}");

        // The missing year is reported first, whatever else fails.
        let mut all = vec![sample(1, 2019), sample(3, 2020)];
        let e = lookup().apply(&mut all, &[1, 3]).unwrap_err();
        assert!(matches!(e, DatasetError::MissingSource { .. }), "{e}");
    }
}
