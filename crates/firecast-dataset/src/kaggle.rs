//! The published FireCastRL CSV (Kaggle `firecastrl/us-wildfire-dataset`,
//! `Wildfire_Dataset.csv`, docs/spec/data.md §3): import into the dataset format, and publish a
//! dataset as a folder ready for `kaggle datasets create -p` / `version -p`.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::time;
use crate::windows::{PAPER_FEATURES, WindowSample, WindowTable};
use crate::{DatasetError, Tier};

/// Columns of the published CSV, in order.
pub const CSV_COLUMNS: [&str; 19] = [
    "latitude",
    "longitude",
    "datetime",
    "Wildfire",
    "pr",
    "rmax",
    "rmin",
    "sph",
    "srad",
    "tmmn",
    "tmmx",
    "vs",
    "bi",
    "fm100",
    "fm1000",
    "erc",
    "etr",
    "pet",
    "vpd",
];

/// Rows per window in the published layout.
pub const WINDOW_ROWS: usize = 75;

/// What to do with a kind of flawed window.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Policy {
    #[default]
    Drop,
    Keep,
}

/// Import settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImportConfig {
    /// Values at or above this are the 32767 fill sentinel and become missing.
    #[serde(default = "default_fill")]
    pub fill_threshold: f64,
    /// Windows with any fill value: drop, or keep with those values missing.
    #[serde(default)]
    pub fill_windows: Policy,
    /// Windows sharing a (place, date) with another window.
    #[serde(default)]
    pub overlapping_windows: Policy,
    /// Windows whose labels are neither `No`×75 nor `No`×60 + `Yes`×15.
    #[serde(default)]
    pub contradictory_windows: Policy,
}

fn default_fill() -> f64 {
    30_000.0
}

impl Default for ImportConfig {
    fn default() -> Self {
        Self {
            fill_threshold: default_fill(),
            fill_windows: Policy::Drop,
            overlapping_windows: Policy::Drop,
            contradictory_windows: Policy::Drop,
        }
    }
}

/// Everything the import detected.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ImportReport {
    pub rows: u64,
    /// Runs of rows at one place on consecutive dates, cut at 75.
    pub windows: u64,
    pub complete_windows: u64,
    /// Windows with fewer than 75 rows (always dropped) and their rows.
    pub cut_short_windows: u64,
    pub cut_short_rows: u64,
    /// Rows with a fill value in any column, and the windows holding them.
    pub fill_rows: u64,
    pub fill_windows: u64,
    /// (place, date) pairs found in more than one window, and the windows involved.
    pub duplicate_place_dates: u64,
    pub overlapping_windows: u64,
    pub contradictory_windows: u64,
    pub kept_windows: u64,
    pub kept_positive: u64,
    pub kept_negative: u64,
}

struct RawWindow {
    lat: f64,
    lon: f64,
    first_day: i32,
    labels: Vec<bool>,
    values: Vec<f32>,
    fill_rows: u64,
}

fn parse_day(s: &str) -> Option<i32> {
    // A date, or a date-time whose time part is ignored (docs/spec/data.md §3.1: both occur).
    let date = s.trim().split([' ', 'T']).next()?;
    time::parse_date(date)
}

/// Reads the published CSV, streaming, into a window table (days −60…+14, row labels kept).
pub fn import(
    path: &Path,
    cfg: &ImportConfig,
    progress: &mut dyn FnMut(u64),
) -> Result<(WindowTable, ImportReport), DatasetError> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_path(path)
        .map_err(|e| DatasetError::Input {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    let headers = reader
        .headers()
        .map_err(|e| DatasetError::InputLine {
            path: path.to_path_buf(),
            line: 1,
            message: e.to_string(),
        })?
        .clone();
    let names: Vec<String> = headers
        .iter()
        .map(|h| h.trim_start_matches('\u{feff}').trim().to_string())
        .collect();
    let mut idx = [0usize; 19];
    for (k, want) in CSV_COLUMNS.iter().enumerate() {
        idx[k] = names
            .iter()
            .position(|n| n == want)
            .ok_or_else(|| DatasetError::InputLine {
                path: path.to_path_buf(),
                line: 1,
                message: format!("no column `{want}` in the header (found: {})", names.join(", ")),
            })?;
    }

    let mut report = ImportReport::default();
    let mut windows: Vec<RawWindow> = Vec::new();
    let mut current: Option<RawWindow> = None;
    let mut prev_day = 0;
    let mut record = csv::StringRecord::new();
    let finish = |w: RawWindow, windows: &mut Vec<RawWindow>, report: &mut ImportReport| {
        report.windows += 1;
        if w.labels.len() == WINDOW_ROWS {
            report.complete_windows += 1;
            windows.push(w);
        } else {
            report.cut_short_windows += 1;
            report.cut_short_rows += w.labels.len() as u64;
        }
    };
    loop {
        let more = reader
            .read_record(&mut record)
            .map_err(|e| DatasetError::InputLine {
                path: path.to_path_buf(),
                line: e.position().map_or(0, |p| p.line()),
                message: e.to_string(),
            })?;
        if !more {
            break;
        }
        report.rows += 1;
        if report.rows % 100_000 == 0 {
            progress(report.rows);
        }
        let line = record.position().map_or(0, |p| p.line());
        let bad = |what: &str, value: &str| DatasetError::InputLine {
            path: path.to_path_buf(),
            line,
            message: format!("column `{what}`: cannot read `{value}`"),
        };
        let field = |k: usize| record.get(idx[k]).unwrap_or("");
        let lat: f64 = field(0).trim().parse().map_err(|_| bad("latitude", field(0)))?;
        let lon: f64 = field(1).trim().parse().map_err(|_| bad("longitude", field(1)))?;
        let day = parse_day(field(2)).ok_or_else(|| bad("datetime", field(2)))?;
        let label = match field(3).trim() {
            "Yes" => true,
            "No" => false,
            other => return Err(bad("Wildfire", other)),
        };
        let mut row = [f32::NAN; 15];
        let mut has_fill = false;
        for (f, v) in row.iter_mut().enumerate() {
            let text = field(4 + f).trim();
            if text.is_empty() {
                continue;
            }
            let x: f64 = text.parse().map_err(|_| bad(CSV_COLUMNS[4 + f], text))?;
            if x >= cfg.fill_threshold {
                has_fill = true;
            } else {
                *v = x as f32;
            }
        }
        let continues = current.as_ref().is_some_and(|w| {
            w.lat.to_bits() == lat.to_bits()
                && w.lon.to_bits() == lon.to_bits()
                && day == prev_day + 1
                && w.labels.len() < WINDOW_ROWS
        });
        if !continues && let Some(w) = current.take() {
            finish(w, &mut windows, &mut report);
        }
        let w = current.get_or_insert_with(|| RawWindow {
            lat,
            lon,
            first_day: day,
            labels: Vec::with_capacity(WINDOW_ROWS),
            values: Vec::with_capacity(WINDOW_ROWS * 15),
            fill_rows: 0,
        });
        w.labels.push(label);
        w.values.extend_from_slice(&row);
        if has_fill {
            w.fill_rows += 1;
            report.fill_rows += 1;
        }
        prev_day = day;
    }
    if let Some(w) = current.take() {
        finish(w, &mut windows, &mut report);
    }
    progress(report.rows);

    // (place, date) pairs in more than one complete window.
    let mut seen: HashMap<(u64, u64, i32), u32> = HashMap::new();
    for w in &windows {
        for d in 0..WINDOW_ROWS as i32 {
            *seen
                .entry((w.lat.to_bits(), w.lon.to_bits(), w.first_day + d))
                .or_default() += 1;
        }
    }
    report.duplicate_place_dates = seen.values().filter(|c| **c > 1).count() as u64;

    let mut kept = Vec::new();
    for w in windows {
        let overlaps = (0..WINDOW_ROWS as i32).any(|d| {
            seen.get(&(w.lat.to_bits(), w.lon.to_bits(), w.first_day + d))
                .is_some_and(|c| *c > 1)
        });
        let positive_layout = w.labels[..60].iter().all(|l| !l) && w.labels[60..].iter().all(|l| *l);
        let negative_layout = w.labels.iter().all(|l| !l);
        let contradictory = !positive_layout && !negative_layout;
        report.overlapping_windows += u64::from(overlaps);
        report.contradictory_windows += u64::from(contradictory);
        report.fill_windows += u64::from(w.fill_rows > 0);
        let drop = (overlaps && cfg.overlapping_windows == Policy::Drop)
            || (contradictory && cfg.contradictory_windows == Policy::Drop)
            || (w.fill_rows > 0 && cfg.fill_windows == Policy::Drop);
        if !drop {
            kept.push(w);
        }
    }

    let mut samples = Vec::with_capacity(kept.len());
    let mut values = Vec::with_capacity(kept.len() * WINDOW_ROWS * 15);
    let mut labels = Vec::with_capacity(kept.len() * WINDOW_ROWS);
    for (k, w) in kept.into_iter().enumerate() {
        let positive = w.labels.iter().any(|l| *l);
        if positive {
            report.kept_positive += 1;
        } else {
            report.kept_negative += 1;
        }
        // Row 61 is the event day (the ignition day of a positive window).
        let event_day = w.first_day + 60;
        // The GRIDMET cell by the grid's formula (docs/spec/data.md §2.3).
        let (j, i) = crate::geo::gridmet_cell_index(w.lat, w.lon);
        samples.push(WindowSample {
            sample_id: k as u32,
            lat: w.lat,
            lon: w.lon,
            time_ms: time::day_start_ms(event_day),
            event_day,
            tier: if positive {
                Tier::ImportedPositive
            } else {
                Tier::ImportedNegative
            },
            source_row: None,
            cell: (j, i),
            cell_lat: 49.4 - f64::from(j) / 24.0,
            cell_lon: -124.766_666_633_3 + f64::from(i) / 24.0,
            // The published CSV is real data: there is no generator truth.
            true_probability: None,
        });
        values.extend_from_slice(&w.values);
        labels.extend_from_slice(&w.labels);
    }
    report.kept_windows = samples.len() as u64;
    Ok((
        WindowTable {
            features: PAPER_FEATURES
                .iter()
                .map(|v| v.short_name().to_string())
                .collect(),
            first_offset: -60,
            n_days: WINDOW_ROWS,
            samples,
            values,
            row_labels: Some(labels),
        },
        report,
    ))
}

pub use crate::publish::PublishConfig;

/// Licence names the Kaggle client accepts (docs/spec/peers.md §3.3).
pub const LICENSES: &[&str] = &[
    "CC0-1.0",
    "CC-BY-4.0",
    "CC-BY-SA-4.0",
    "CC-BY-NC-SA-4.0",
    "ODbL-1.0",
    "PDDL",
    "ODC-BY-1.0",
    "US-Government-Works",
    "CDLA-Permissive-1.0",
    "apache-2.0",
    "GPL-2.0",
    "GPL-3.0",
    "other",
    "unknown",
];

/// Field types of the Kaggle metadata schema.
pub const FIELD_TYPES: &[&str] = &[
    "string",
    "boolean",
    "numeric",
    "datetime",
    "id",
    "uuid",
    "latitude",
    "longitude",
    "coordinates",
    "country",
    "province",
    "postalcode",
    "address",
    "email",
    "url",
    "integer",
    "decimal",
    "city",
];

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KaggleField {
    pub name: String,
    pub description: String,
    #[serde(rename = "type")]
    pub kind: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KaggleSchema {
    pub fields: Vec<KaggleField>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KaggleResource {
    pub path: String,
    pub description: String,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub schema: Option<KaggleSchema>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KaggleLicense {
    pub name: String,
}

/// `dataset-metadata.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KaggleMetadata {
    pub title: String,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub subtitle: Option<String>,
    pub description: String,
    pub id: String,
    pub licenses: Vec<KaggleLicense>,
    pub keywords: Vec<String>,
    pub resources: Vec<KaggleResource>,
}

/// The rules the kaggle client enforces before uploading (`dataset_create_new`), plus the
/// folder checks it does: each broken rule is one message naming the field.
pub fn validate_metadata(meta: &KaggleMetadata, folder: &Path) -> Vec<String> {
    let mut problems = Vec::new();
    let (owner, slug) = meta.id.split_once('/').unwrap_or(("", ""));
    if owner.is_empty() || slug.is_empty() || slug.contains('/') {
        problems.push(format!("id: `{}` is not <owner>/<dataset-slug>", meta.id));
    }
    if meta.id.contains("INSERT_SLUG_HERE") || meta.title.contains("INSERT_TITLE_HERE") {
        problems.push("id/title: the template defaults are rejected".into());
    }
    if !(6..=50).contains(&slug.len()) {
        problems.push(format!(
            "id: slug `{slug}` must be 6 to 50 characters (it is {})",
            slug.len()
        ));
    }
    if !slug
        .chars()
        .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')
    {
        problems.push(format!(
            "id: slug `{slug}` may only hold lowercase letters, digits and dashes"
        ));
    }
    let title_len = meta.title.chars().count();
    if !(6..=50).contains(&title_len) {
        problems.push(format!("title: must be 6 to 50 characters (it is {title_len})"));
    }
    if let Some(sub) = &meta.subtitle {
        let n = sub.chars().count();
        if !(20..=80).contains(&n) {
            problems.push(format!("subtitle: must be 20 to 80 characters (it is {n})"));
        }
    }
    if meta.licenses.len() != 1 {
        problems.push(format!(
            "licenses: exactly one licence is required ({} given)",
            meta.licenses.len()
        ));
    }
    for l in &meta.licenses {
        if !LICENSES.contains(&l.name.as_str()) {
            problems.push(format!(
                "licenses: unknown licence `{}` (known: {})",
                l.name,
                LICENSES.join(", ")
            ));
        }
    }
    for (k, r) in meta.resources.iter().enumerate() {
        if !folder.join(&r.path).is_file() {
            problems.push(format!(
                "resources[{k}].path: `{}` is not a file in the folder",
                r.path
            ));
        }
        if let Some(schema) = &r.schema {
            for (j, f) in schema.fields.iter().enumerate() {
                if !FIELD_TYPES.contains(&f.kind.as_str()) {
                    problems.push(format!(
                        "resources[{k}].schema.fields[{j}].type: unknown type `{}`",
                        f.kind
                    ));
                }
            }
        }
    }
    problems
}

/// Kaggle type and description of a column of the published CSV.
pub(crate) fn describe(name: &str) -> (&'static str, String) {
    match name {
        "latitude" => ("latitude", "Sample latitude (WGS84 degrees)".into()),
        "longitude" => ("longitude", "Sample longitude (WGS84 degrees)".into()),
        "datetime" => ("datetime", "Calendar day of this row (YYYY-MM-DD)".into()),
        "Wildfire" => (
            "string",
            "Yes on the ignition day and the 14 days after it in a positive window, else No".into(),
        ),
        other => {
            let unit =
                firecast_data::gridmet::GridmetVariable::from_short_name(other).map_or("", |v| v.units());
            (
                "numeric",
                format!("GRIDMET `{other}` ({unit}); empty when GRIDMET has no data"),
            )
        }
    }
}

/// Writes the published CSV (the 19 columns of [`CSV_COLUMNS`], 75 rows per window) of a
/// `paper`-framed table; returns its rows. The caller writes it inside a staging folder.
pub(crate) fn write_csv(t: &WindowTable, csv_path: &Path) -> Result<u64, DatasetError> {
    let mut w = csv::Writer::from_path(csv_path).map_err(|e| DatasetError::Input {
        path: csv_path.to_path_buf(),
        message: e.to_string(),
    })?;
    let werr = |e: csv::Error| DatasetError::Input {
        path: csv_path.to_path_buf(),
        message: e.to_string(),
    };
    w.write_record(CSV_COLUMNS).map_err(werr)?;
    let mut rows = 0u64;
    let mut fields: Vec<String> = Vec::with_capacity(19);
    for (s, sample) in t.samples.iter().enumerate() {
        for d in 0..t.n_days {
            fields.clear();
            fields.push(format!("{}", sample.lat));
            fields.push(format!("{}", sample.lon));
            fields.push(time::format_date(sample.event_day + t.offset(d)));
            fields.push(
                if crate::table::row_label(t, s, d) {
                    "Yes"
                } else {
                    "No"
                }
                .into(),
            );
            for v in t.row(s, d) {
                fields.push(if v.is_nan() { String::new() } else { format!("{v}") });
            }
            w.write_record(&fields).map_err(werr)?;
            rows += 1;
        }
    }
    w.flush().map_err(DatasetError::io("writing", csv_path))?;
    Ok(rows)
}

/// The CSV's columns as `dataset-metadata.json` describes them.
pub(crate) fn csv_fields() -> Vec<KaggleField> {
    CSV_COLUMNS
        .iter()
        .map(|n| {
            let (kind, description) = describe(n);
            KaggleField {
                name: n.to_string(),
                description,
                kind: kind.into(),
            }
        })
        .collect()
}

/// Summary counts of an import, for reports.
pub fn report_lines(r: &ImportReport) -> BTreeMap<&'static str, u64> {
    BTreeMap::from([
        ("rows", r.rows),
        ("windows", r.windows),
        ("complete_windows", r.complete_windows),
        ("cut_short_windows", r.cut_short_windows),
        ("fill_windows", r.fill_windows),
        ("overlapping_windows", r.overlapping_windows),
        ("contradictory_windows", r.contradictory_windows),
        ("kept_windows", r.kept_windows),
    ])
}
