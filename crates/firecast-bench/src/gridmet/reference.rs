//! The reference side of `firecast bench gridmet`: the extraction written in Python with
//! xarray + netCDF4 the way the authors did it (one nearest-cell selection per sample and
//! variable), run on the same files and samples as FireCast's, and the comparison of the two.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use firecast_dataset::land::LandMask;
use firecast_dataset::windows::{SampleIn, WindowTable};
use firecast_dataset::{DatasetError, Tier, time};

/// The reference script (kept beside the extraction it re-states), shipped inside the binary so
/// the benchmark needs no checkout.
pub const REFERENCE_SCRIPT: &str = include_str!("../../../firecast-dataset/reference/gridmet_xarray.py");

/// The paper's scale: windows, variables and years of CONUS files (docs/spec/data.md §3.3, §4.7).
pub const PAPER_WINDOWS: f64 = 126_800.0;
pub const PAPER_VARIABLES: f64 = 15.0;
pub const PAPER_YEARS: f64 = 12.0;

/// `n` samples on cells with data, on days whose windows lie inside `years`.
pub fn random_samples(
    mask: &LandMask,
    years: (i32, i32),
    offsets: (i32, i32),
    n: usize,
    seed: u64,
) -> Result<Vec<SampleIn>, DatasetError> {
    let first = time::parse_date(&format!("{}-01-01", years.0)).unwrap_or(0) - offsets.0;
    let last = time::parse_date(&format!("{}-12-31", years.1)).unwrap_or(0) - offsets.1;
    if last < first {
        return Err(DatasetError::Config {
            key: "years".into(),
            message: "too short for the window".into(),
        });
    }
    let land: Vec<(usize, usize)> = (0..mask.lats().len())
        .flat_map(|j| (0..mask.lons().len()).map(move |i| (j, i)))
        .filter(|&(j, i)| mask.is_valid(j, i))
        .collect();
    if land.is_empty() {
        return Err(DatasetError::Input {
            path: mask.source().to_path_buf(),
            message: "no cell has data".into(),
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    Ok((0..n)
        .map(|k| {
            let (j, i) = land[rng.random_range(0..land.len())];
            let day = rng.random_range(first..=last);
            SampleIn {
                sample_id: k as u32,
                lat: mask.lats()[j],
                lon: mask.lons()[i],
                // Noon MST, so both day conventions agree.
                time_ms: time::day_start_ms(day) + 19 * 3_600_000,
                tier: Tier::Positive,
                source_row: None,
            }
        })
        .collect())
}

/// One run of the reference script.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ReferenceRun {
    /// Extraction time measured inside Python (interpreter start and imports excluded).
    pub seconds: f64,
    /// Wall time of the whole process.
    pub wall_seconds: f64,
    pub files_opened: u64,
    pub xarray: String,
    #[serde(skip)]
    pub values: Vec<f32>,
}

/// Runs the reference on the samples of `table` (same cells, same days).
pub fn run_reference(
    python: &Path,
    gridmet: &Path,
    table: &WindowTable,
    workdir: &Path,
) -> Result<ReferenceRun, DatasetError> {
    let script = workdir.join("gridmet_xarray.py");
    std::fs::write(&script, REFERENCE_SCRIPT).map_err(DatasetError::io("writing", &script))?;
    let samples_csv = workdir.join("samples.csv");
    let mut text = String::from("sample_id,lat,lon,date\n");
    for s in &table.samples {
        text.push_str(&format!(
            "{},{},{},{}\n",
            s.sample_id,
            s.lat,
            s.lon,
            time::format_date(s.event_day)
        ));
    }
    std::fs::write(&samples_csv, text).map_err(DatasetError::io("writing", &samples_csv))?;
    let out = workdir.join("reference.f32");
    let last = table.first_offset + table.n_days as i32 - 1;
    let start = Instant::now();
    let output = Command::new(python)
        .arg(&script)
        .arg(gridmet)
        .arg(&samples_csv)
        .arg(&out)
        .arg(table.features.join(","))
        .arg(table.first_offset.to_string())
        .arg(last.to_string())
        .output()
        .map_err(DatasetError::io("running the reference with", python))?;
    let wall_seconds = start.elapsed().as_secs_f64();
    if !output.status.success() {
        return Err(DatasetError::Input {
            path: script,
            message: format!("reference failed: {}", String::from_utf8_lossy(&output.stderr)),
        });
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    let line = stdout.lines().last().unwrap_or("");
    #[derive(Deserialize)]
    struct Line {
        seconds: f64,
        files_opened: u64,
        xarray: String,
    }
    let parsed: Line = serde_json::from_str(line).map_err(|e| DatasetError::Input {
        path: script.clone(),
        message: format!("unexpected reference output `{line}`: {e}"),
    })?;
    let bytes = std::fs::read(&out).map_err(DatasetError::io("reading", &out))?;
    let values = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    Ok(ReferenceRun {
        seconds: parsed.seconds,
        wall_seconds,
        files_opened: parsed.files_opened,
        xarray: parsed.xarray,
        values,
    })
}

/// How far two extractions differ.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Agreement {
    pub values: u64,
    pub max_abs_diff: f64,
    /// Positions where exactly one side is missing.
    pub missing_mismatches: u64,
}

pub fn compare(ours: &[f32], reference: &[f32]) -> Agreement {
    let mut a = Agreement {
        values: ours.len().min(reference.len()) as u64,
        ..Default::default()
    };
    if ours.len() != reference.len() {
        a.missing_mismatches = ours.len().abs_diff(reference.len()) as u64;
    }
    for (x, y) in ours.iter().zip(reference) {
        match (x.is_nan(), y.is_nan()) {
            (true, true) => {}
            (false, false) => a.max_abs_diff = a.max_abs_diff.max(f64::from((x - y).abs())),
            _ => a.missing_mismatches += 1,
        }
    }
    a
}
