//! IRWIN / WFIGS incident readers (docs/spec/data.md §1).
//!
//! [`read_incidents`] reads one incident file into an [`IncidentTable`]: the incidents that pass
//! (discovery time as epoch milliseconds UTC, a WGS84 point, an id and the incident type) and,
//! for every other data row, a [`Reject`] saying which row, why, and with what value. Nothing is
//! dropped silently: `rows_read == incidents.len() + rejects.len()`.
//!
//! Three formats are read, detected from the content (a file whose first non-blank character is
//! `{` is JSON, anything else is CSV):
//!
//! - **CSV** as exported by ArcGIS Hub (docs/spec/data.md §1.2). Columns are found by header
//!   *name*, never by position, so every year's field set works as long as the few needed columns
//!   exist. The authors' display-name layout (`Fire Discovery Date Time`, `x`, `y`;
//!   docs/spec/data.md §1.5) and the perimeter layer's `attr_*` names are accepted as aliases (see
//!   [`FIELD_NAMES`]).
//! - **GeoJSON** (`f=geojson`): a `FeatureCollection`; attributes in `properties`, the point in
//!   `geometry.coordinates = [lon, lat]`.
//! - **Esri JSON** (`f=json`): attributes in `attributes`, the point in `geometry {x, y}`; the
//!   top-level `spatialReference` must be geographic (EPSG 4326 or 4269; query with
//!   `outSR=4326`).
//!
//! CSV records are read into one reused buffer. JSON features are evaluated one at a time as
//! the parser reaches them, never collected; the text is parsed from memory up to 512 MiB and
//! streamed from the file above that. Row numbers count data rows from 1; CSV rows also carry
//! the physical line on which the record starts (correct for CRLF files, blank lines and quoted
//! line breaks).
//!
//! Per row, the checks run in this order and the first failure is the row's [`RejectReason`]:
//! incident type (only when the file has an `IncidentTypeCategory` column or attribute), then
//! the discovery time, then the location.
//!
//! - **Discovery time**: see [`parse_discovery_time`] for the accepted encodings; JSON numbers
//!   are epoch milliseconds. Everything is UTC.
//! - **Location**: `InitialLatitude`/`InitialLongitude` when both are present and valid,
//!   otherwise the point geometry (CSV `X`/`Y`). Empty values and the text `NaN` count as
//!   missing. A point is valid when both coordinates are finite, |lat| ≤ 90, |lon| ≤ 180 and it
//!   is not exactly (0, 0), a common placeholder for "unknown". [`Incident::location`] records
//!   which of the two was used.
//! - **Incident type**: with [`IncidentFilter::categories`] non-empty, a row whose category is
//!   another one is [`RejectReason::CategoryFiltered`], and a row with an empty category is
//!   [`RejectReason::MissingCategory`] (its type is unknown, so it cannot be shown to match).
//!   Files without the column (the authors' layout) keep every row.

use std::collections::{BTreeMap, VecDeque};
use std::fmt;
use std::fs::File;
use std::io::{self, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use serde::de::{self, DeserializeSeed, IgnoredAny, MapAccess, SeqAccess, Visitor};

/// Accepted names of each field, in priority order. A header or attribute matches a name
/// exactly, or else (at lower priority) ignoring ASCII case and surrounding white space.
///
/// The canonical WFIGS name comes first, then the ArcGIS display name (the authors' file uses
/// `Fire Discovery Date Time`, `x`, `y`), then the perimeter layer's `attr_` copy.
pub const FIELD_NAMES: &[(&str, &[&str])] = &[
    (
        "FireDiscoveryDateTime",
        &[
            "FireDiscoveryDateTime",
            "Fire Discovery Date Time",
            "attr_FireDiscoveryDateTime",
        ],
    ),
    (
        "InitialLatitude",
        &["InitialLatitude", "Initial Latitude", "attr_InitialLatitude"],
    ),
    (
        "InitialLongitude",
        &["InitialLongitude", "Initial Longitude", "attr_InitialLongitude"],
    ),
    (
        "IncidentTypeCategory",
        &[
            "IncidentTypeCategory",
            "Incident Type Category",
            "attr_IncidentTypeCategory",
        ],
    ),
    (
        "UniqueFireIdentifier",
        &[
            "UniqueFireIdentifier",
            "Unique Fire Identifier",
            "attr_UniqueFireIdentifier",
        ],
    ),
    ("IrwinID", &["IrwinID", "IRWIN ID", "attr_IrwinID"]),
    ("X", &["X", "x"]),
    ("Y", &["Y", "y"]),
];

/// Index into [`FIELD_NAMES`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Slot {
    Date = 0,
    InitLat = 1,
    InitLon = 2,
    Category = 3,
    Uid = 4,
    Irwin = 5,
    X = 6,
    Y = 7,
}

const SLOTS: [Slot; 8] = [
    Slot::Date,
    Slot::InitLat,
    Slot::InitLon,
    Slot::Category,
    Slot::Uid,
    Slot::Irwin,
    Slot::X,
    Slot::Y,
];

/// Priority offset of a case-insensitive match (exact matches rank `0..names.len()`).
const LOOSE: u16 = 100;

/// Which field a header/attribute name is, and how good the match is (lower is better).
fn classify(name: &str) -> Option<(Slot, u16)> {
    let name = name.trim_start_matches('\u{feff}');
    for slot in SLOTS {
        for (rank, cand) in (0u16..).zip(FIELD_NAMES[slot as usize].1.iter()) {
            if name == *cand {
                return Some((slot, rank));
            }
        }
    }
    let name = name.trim();
    for slot in SLOTS {
        for (rank, cand) in (0u16..).zip(FIELD_NAMES[slot as usize].1.iter()) {
            if name.eq_ignore_ascii_case(cand) {
                return Some((slot, LOOSE + rank));
            }
        }
    }
    None
}

/// Accepted names of `slot`, for error messages.
fn accepted(slots: &[Slot]) -> Vec<String> {
    slots
        .iter()
        .flat_map(|s| FIELD_NAMES[*s as usize].1.iter().map(|n| (*n).to_owned()))
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Public types
// ---------------------------------------------------------------------------------------------

/// File format of an incident file, detected from its content.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum IncidentFormat {
    /// ArcGIS Hub CSV export.
    Csv,
    /// GeoJSON `FeatureCollection` (ArcGIS REST `f=geojson`).
    GeoJson,
    /// Esri JSON feature set (ArcGIS REST `f=json`).
    EsriJson,
}

impl IncidentFormat {
    /// Short lower-case name: `csv`, `geojson` or `esri-json`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Csv => "csv",
            Self::GeoJson => "geojson",
            Self::EsriJson => "esri-json",
        }
    }
}

impl fmt::Display for IncidentFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Which rows to keep.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IncidentFilter {
    /// `IncidentTypeCategory` values to keep (compared ignoring ASCII case). Empty keeps every
    /// row, whatever its category. The default is `["WF"]` (wildfires; docs/spec/data.md §1.3).
    pub categories: Vec<String>,
}

impl Default for IncidentFilter {
    fn default() -> Self {
        Self::wildfires()
    }
}

impl IncidentFilter {
    /// Wildfires only (`IncidentTypeCategory = WF`), the default.
    pub fn wildfires() -> Self {
        Self {
            categories: vec!["WF".to_owned()],
        }
    }

    /// Every row regardless of its category.
    pub fn all() -> Self {
        Self {
            categories: Vec::new(),
        }
    }

    fn keeps(&self, category: &str) -> bool {
        self.categories
            .iter()
            .any(|c| c.trim().eq_ignore_ascii_case(category))
    }
}

/// Where an incident's coordinates came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LocationSource {
    /// `InitialLatitude` / `InitialLongitude`: the point of origin as first reported.
    InitialLatLon,
    /// The point geometry (CSV `X`/`Y`, GeoJSON `coordinates`, Esri `x`/`y`).
    Geometry,
}

/// One accepted incident.
#[derive(Debug, Clone, PartialEq)]
pub struct Incident {
    /// 1-based data-row number: the CSV record number after the header, or the JSON feature
    /// index + 1.
    pub row: u64,
    /// CSV: the physical line on which the record starts (the header is line 1; a record with
    /// quoted line breaks spans several lines). JSON: 0.
    pub line: u64,
    /// `UniqueFireIdentifier`, else `IrwinID`, else `None`.
    pub id: Option<String>,
    /// `FireDiscoveryDateTime` in milliseconds since 1970-01-01T00:00:00Z.
    pub discovered_ms: i64,
    /// Latitude, decimal degrees WGS84.
    pub lat: f64,
    /// Longitude, decimal degrees WGS84.
    pub lon: f64,
    /// Which coordinates were used.
    pub location: LocationSource,
    /// `IncidentTypeCategory` (`WF`, `RX`, `CX`), `None` when the file has no such column.
    pub category: Option<String>,
}

/// Why a data row was not turned into an [`Incident`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RejectReason {
    /// `IncidentTypeCategory` is not one the filter keeps (e.g. `RX`, `CX`); detail: the value.
    CategoryFiltered,
    /// The file has an `IncidentTypeCategory` column, the filter is not empty, and this row's
    /// value is empty.
    MissingCategory,
    /// The discovery time is empty or null.
    MissingDiscoveryDate,
    /// The discovery time is not in an accepted encoding or not a valid date; detail: the text.
    BadDiscoveryDate,
    /// Neither `InitialLatitude`/`InitialLongitude` nor the point geometry has any value.
    MissingLocation,
    /// Coordinates are present but none usable: unparseable, non-finite, latitude outside ±90,
    /// longitude outside ±180, only one of the pair, exactly (0, 0), or a non-point geometry;
    /// detail: what was wrong with each source.
    BadLocation,
}

impl RejectReason {
    /// Every reason, in report order.
    pub const ALL: [RejectReason; 6] = [
        Self::CategoryFiltered,
        Self::MissingCategory,
        Self::MissingDiscoveryDate,
        Self::BadDiscoveryDate,
        Self::MissingLocation,
        Self::BadLocation,
    ];

    /// Stable kebab-case name, used in reports and [`IncidentTable::reject_counts`].
    pub fn slug(self) -> &'static str {
        match self {
            Self::CategoryFiltered => "category-filtered",
            Self::MissingCategory => "missing-category",
            Self::MissingDiscoveryDate => "missing-discovery-date",
            Self::BadDiscoveryDate => "bad-discovery-date",
            Self::MissingLocation => "missing-location",
            Self::BadLocation => "bad-location",
        }
    }
}

impl fmt::Display for RejectReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.slug())
    }
}

/// A data row that was not kept.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Reject {
    /// As [`Incident::row`].
    pub row: u64,
    /// As [`Incident::line`].
    pub line: u64,
    /// Why.
    pub reason: RejectReason,
    /// The offending value or a short explanation (empty for the `missing-*` reasons).
    pub detail: String,
}

/// Everything read from one incident file.
#[derive(Debug, Clone)]
pub struct IncidentTable {
    /// The file.
    pub path: PathBuf,
    /// Its detected format.
    pub format: IncidentFormat,
    /// Data rows (CSV records after the header, or JSON features) read;
    /// always `incidents.len() + rejects.len()`.
    pub rows_read: u64,
    /// Kept incidents, in file order.
    pub incidents: Vec<Incident>,
    /// Rejected rows, in file order.
    pub rejects: Vec<Reject>,
}

impl IncidentTable {
    /// Number of rejects per [`RejectReason::slug`]; reasons that did not occur are absent.
    pub fn reject_counts(&self) -> BTreeMap<&'static str, u64> {
        let mut counts = BTreeMap::new();
        for r in &self.rejects {
            *counts.entry(r.reason.slug()).or_insert(0) += 1;
        }
        counts
    }

    /// Writes the rejects as CSV with the header `row,line,reason,detail` (RFC 4180 quoting).
    pub fn write_reject_report(&self, path: impl AsRef<Path>) -> io::Result<()> {
        std::fs::write(path, self.reject_report_csv(&[])?)
    }

    /// The reject report as CSV bytes (`row,line,reason,detail`, in row order): the reader's
    /// rejects plus `later`, rows a later stage dropped, given as `(row, reason)` (their line
    /// comes from the kept incidents; 0 if the row is not one of them).
    pub fn reject_report_csv(&self, later: &[(u64, &str)]) -> io::Result<Vec<u8>> {
        let line_of: BTreeMap<u64, u64> = self.incidents.iter().map(|i| (i.row, i.line)).collect();
        let mut rows: Vec<(u64, u64, &str, &str)> = self
            .rejects
            .iter()
            .map(|r| (r.row, r.line, r.reason.slug(), r.detail.as_str()))
            .collect();
        rows.extend(
            later
                .iter()
                .map(|&(row, why)| (row, line_of.get(&row).copied().unwrap_or(0), why, "")),
        );
        rows.sort();
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(["row", "line", "reason", "detail"])?;
        for (row, line, reason, detail) in rows {
            w.write_record([
                row.to_string().as_str(),
                line.to_string().as_str(),
                reason,
                detail,
            ])?;
        }
        w.into_inner().map_err(|e| e.into_error())
    }
}

/// Errors from reading incident files. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum IncidentError {
    /// The file does not exist.
    #[error("incident file {} does not exist", path.display())]
    MissingFile {
        /// The file.
        path: PathBuf,
    },
    /// Reading the file failed.
    #[error("incident file {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
    /// The file is not well-formed CSV/JSON or lacks the expected structure (a CSV record with
    /// the wrong number of fields, invalid JSON, no `features` array, an ArcGIS error response).
    #[error("incident file {}, line {line}: {message}", path.display())]
    Malformed {
        /// The file.
        path: PathBuf,
        /// 1-based line of the problem (0 when it is not tied to a line).
        line: u64,
        /// What is wrong (JSON messages also give the column).
        message: String,
    },
    /// A required column (or, in JSON, attribute) does not exist under any accepted name.
    #[error(
        "incident file {}: no `{column}` column (accepted names {accepted:?}); the file has {found:?}",
        path.display()
    )]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The missing field, e.g. `FireDiscoveryDateTime`.
        column: String,
        /// Names that would have been accepted.
        accepted: Vec<String>,
        /// The CSV header, or the attribute names of the first JSON feature.
        found: Vec<String>,
    },
    /// The JSON's spatial reference is not geographic WGS84/NAD83.
    #[error(
        "incident file {}: spatial reference {found} is not EPSG:4326/4269 longitude/latitude \
         (query with outSR=4326)",
        path.display()
    )]
    SpatialReference {
        /// The file.
        path: PathBuf,
        /// The spatial reference found (wkid or CRS name).
        found: String,
    },
}

// ---------------------------------------------------------------------------------------------
// Entry point
// ---------------------------------------------------------------------------------------------

/// Reads an incident file (CSV, GeoJSON or Esri JSON; detected from the content) and applies
/// `filter`. Structural problems are errors; a row that cannot be used is a [`Reject`].
pub fn read_incidents(
    path: impl AsRef<Path>,
    filter: &IncidentFilter,
) -> Result<IncidentTable, IncidentError> {
    read_with_limit(path.as_ref(), filter, JSON_IN_MEMORY_LIMIT)
}

fn read_with_limit(
    path: &Path,
    filter: &IncidentFilter,
    json_in_memory_limit: u64,
) -> Result<IncidentTable, IncidentError> {
    let io_err = |source: io::Error| IncidentError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = match File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return Err(IncidentError::MissingFile {
                path: path.to_path_buf(),
            });
        }
        Err(e) => return Err(io_err(e)),
    };
    let is_json = {
        let mut head = [0u8; 512];
        let n = read_up_to(&mut file, &mut head).map_err(io_err)?;
        let head = head[..n].strip_prefix(BOM).unwrap_or(&head[..n]);
        head.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{')
    };
    file.seek(SeekFrom::Start(0)).map_err(io_err)?;
    let mut table = IncidentTable {
        path: path.to_path_buf(),
        format: IncidentFormat::Csv,
        rows_read: 0,
        incidents: Vec::new(),
        rejects: Vec::new(),
    };
    if is_json {
        read_json(file, filter, &mut table, json_in_memory_limit)?;
    } else {
        read_csv(file, filter, &mut table)?;
    }
    table.rows_read = (table.incidents.len() + table.rejects.len()) as u64;
    Ok(table)
}

fn read_up_to(file: &mut File, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match file.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

// ---------------------------------------------------------------------------------------------
// Row evaluation, shared by CSV and JSON
// ---------------------------------------------------------------------------------------------

/// One field's value, borrowed from the CSV record or the parsed JSON attribute.
#[derive(Debug, Clone, Copy)]
enum Val<'a> {
    /// Absent, empty/blank, or null.
    Missing,
    /// Trimmed, non-empty text.
    Text(&'a str),
    /// A JSON integer.
    Int(i64),
    /// A JSON non-integer number.
    Num(f64),
    /// A value of the wrong kind, described (`not UTF-8`, `boolean`, `array`, `object`).
    Invalid(&'static str),
}

impl<'a> Val<'a> {
    fn text(s: &'a str) -> Self {
        let s = s.trim();
        if s.is_empty() { Val::Missing } else { Val::Text(s) }
    }

    fn bytes(b: &'a [u8]) -> Self {
        match std::str::from_utf8(b) {
            Ok(s) => Val::text(s),
            Err(_) => Val::Invalid("not UTF-8"),
        }
    }

    /// As a string for ids and categories.
    fn to_owned_text(self) -> Option<String> {
        match self {
            Val::Text(s) => Some(s.to_owned()),
            Val::Int(i) => Some(i.to_string()),
            Val::Num(f) => Some(f.to_string()),
            Val::Missing | Val::Invalid(_) => None,
        }
    }

    fn describe(self) -> String {
        match self {
            Val::Missing => String::new(),
            Val::Text(s) => s.to_owned(),
            Val::Int(i) => i.to_string(),
            Val::Num(f) => f.to_string(),
            Val::Invalid(k) => k.to_owned(),
        }
    }
}

/// The point geometry of a row.
#[derive(Debug, Clone, Copy)]
enum GeomVal<'a> {
    /// `(x = lon, y = lat)`.
    Point(Val<'a>, Val<'a>),
    /// A non-point geometry, described.
    NotPoint(&'a str),
}

/// The fields of one row that the reader needs.
struct RawRow<'a> {
    date: Val<'a>,
    init_lat: Val<'a>,
    init_lon: Val<'a>,
    geometry: GeomVal<'a>,
    /// `None` when the file has no category column.
    category: Option<Val<'a>>,
    uid: Val<'a>,
    irwin: Val<'a>,
}

/// Why a coordinate pair is unusable.
enum PairProblem {
    Missing,
    Bad(String),
}

fn coordinate(v: Val<'_>, what: &str) -> Result<Option<f64>, String> {
    match v {
        Val::Missing => Ok(None),
        Val::Text(s) if s.eq_ignore_ascii_case("nan") => Ok(None),
        Val::Text(s) => s
            .parse::<f64>()
            .map(Some)
            .map_err(|_| format!("unparseable {what} {s:?}")),
        Val::Int(i) => Ok(Some(i as f64)),
        Val::Num(f) if f.is_nan() => Ok(None),
        Val::Num(f) => Ok(Some(f)),
        Val::Invalid(k) => Err(format!("{what} is {k}")),
    }
}

fn check_pair(lat: Val<'_>, lon: Val<'_>) -> Result<(f64, f64), PairProblem> {
    let lat = coordinate(lat, "latitude").map_err(PairProblem::Bad)?;
    let lon = coordinate(lon, "longitude").map_err(PairProblem::Bad)?;
    let (lat, lon) = match (lat, lon) {
        (None, None) => return Err(PairProblem::Missing),
        (Some(_), None) => return Err(PairProblem::Bad("longitude missing".to_owned())),
        (None, Some(_)) => return Err(PairProblem::Bad("latitude missing".to_owned())),
        (Some(lat), Some(lon)) => (lat, lon),
    };
    if !lat.is_finite() || !lon.is_finite() {
        return Err(PairProblem::Bad(format!("non-finite ({lat}, {lon})")));
    }
    if lat.abs() > 90.0 {
        return Err(PairProblem::Bad(format!("latitude {lat} outside ±90")));
    }
    if lon.abs() > 180.0 {
        return Err(PairProblem::Bad(format!("longitude {lon} outside ±180")));
    }
    if lat == 0.0 && lon == 0.0 {
        return Err(PairProblem::Bad("(0, 0) placeholder".to_owned()));
    }
    Ok((lat, lon))
}

fn describe_problem(p: &PairProblem) -> &str {
    match p {
        PairProblem::Missing => "missing",
        PairProblem::Bad(s) => s,
    }
}

/// Epoch milliseconds must have at least this magnitude: smaller integers are within 116 days
/// of 1970-01-01 and are far more likely epoch *seconds* or a compact `YYYYMMDD` date.
const MIN_EPOCH_MS: i64 = 10_000_000_000;
/// Epoch milliseconds must be below this (year 2286); larger integers are microseconds.
const MAX_EPOCH_MS: i64 = 10_000_000_000_000;

fn epoch_ms_in_range(ms: i64) -> Option<i64> {
    (MIN_EPOCH_MS.unsigned_abs()..MAX_EPOCH_MS.unsigned_abs())
        .contains(&ms.unsigned_abs())
        .then_some(ms)
}

/// The evaluated fields of a kept row.
struct Kept {
    discovered_ms: i64,
    lat: f64,
    lon: f64,
    location: LocationSource,
    category: Option<String>,
}

/// Applies the filter and the field rules to one row.
fn evaluate(raw: &RawRow<'_>, filter: &IncidentFilter) -> Result<Kept, (RejectReason, String)> {
    let category = match raw.category {
        None => None,
        Some(v) => {
            let c = v.to_owned_text();
            if !filter.categories.is_empty() {
                match &c {
                    None => return Err((RejectReason::MissingCategory, String::new())),
                    Some(c) if !filter.keeps(c) => {
                        return Err((RejectReason::CategoryFiltered, c.clone()));
                    }
                    Some(_) => {}
                }
            }
            c
        }
    };
    let bad_date = |v: Val<'_>| (RejectReason::BadDiscoveryDate, v.describe());
    let discovered_ms = match raw.date {
        Val::Missing => return Err((RejectReason::MissingDiscoveryDate, String::new())),
        Val::Text(s) => parse_discovery_time(s).ok_or_else(|| bad_date(raw.date))?,
        Val::Int(i) => epoch_ms_in_range(i).ok_or_else(|| bad_date(raw.date))?,
        Val::Num(f) => {
            let ms = (f.is_finite() && f.fract() == 0.0 && f.abs() < 1e15).then_some(f as i64);
            ms.and_then(epoch_ms_in_range).ok_or_else(|| bad_date(raw.date))?
        }
        Val::Invalid(_) => return Err(bad_date(raw.date)),
    };
    let initial = match check_pair(raw.init_lat, raw.init_lon) {
        Ok((lat, lon)) => {
            return Ok(Kept {
                discovered_ms,
                lat,
                lon,
                location: LocationSource::InitialLatLon,
                category,
            });
        }
        Err(problem) => problem,
    };
    let geometry = match raw.geometry {
        GeomVal::Point(x, y) => check_pair(y, x),
        GeomVal::NotPoint(kind) => Err(PairProblem::Bad(format!("{kind} is not a point"))),
    };
    match geometry {
        Ok((lat, lon)) => Ok(Kept {
            discovered_ms,
            lat,
            lon,
            location: LocationSource::Geometry,
            category,
        }),
        Err(PairProblem::Missing) if matches!(initial, PairProblem::Missing) => {
            Err((RejectReason::MissingLocation, String::new()))
        }
        Err(g) => Err((
            RejectReason::BadLocation,
            format!(
                "initial: {}; geometry: {}",
                describe_problem(&initial),
                describe_problem(&g)
            ),
        )),
    }
}

fn push_row(table: &mut IncidentTable, row: u64, line: u64, raw: &RawRow<'_>, filter: &IncidentFilter) {
    match evaluate(raw, filter) {
        Ok(kept) => table.incidents.push(Incident {
            row,
            line,
            id: raw.uid.to_owned_text().or_else(|| raw.irwin.to_owned_text()),
            discovered_ms: kept.discovered_ms,
            lat: kept.lat,
            lon: kept.lon,
            location: kept.location,
            category: kept.category,
        }),
        Err((reason, detail)) => table.rejects.push(Reject {
            row,
            line,
            reason,
            detail,
        }),
    }
}

// ---------------------------------------------------------------------------------------------
// CSV
// ---------------------------------------------------------------------------------------------

/// Wraps the CSV input and maps the csv crate's record byte offsets to physical line numbers.
///
/// The csv crate's own `Position::line` is one or more too small for a record that follows a
/// CRLF terminator or a skipped blank line: the position is taken before the reader steps over
/// the previous record's `\n` and over empty lines. A record therefore starts at the end of the
/// run of `\r`/`\n` bytes containing its reported offset (or at the offset itself), and its line
/// is 1 + the number of `\n` bytes before that.
struct LineTracker<R> {
    inner: R,
    /// Bytes read so far.
    offset: u64,
    /// `\n` bytes read so far.
    newlines: u64,
    /// Start offset of the `\r`/`\n` run in progress at the end of the bytes read.
    open_run: Option<u64>,
    /// Completed runs not yet passed by a query, in file order.
    runs: VecDeque<NewlineRun>,
    /// Line of the first byte after the last run dropped from `runs`.
    base_line: u64,
}

/// A maximal run of `\r`/`\n` bytes, `start..end`; `line_at_end` is the line of byte `end`.
struct NewlineRun {
    start: u64,
    end: u64,
    line_at_end: u64,
}

impl<R> LineTracker<R> {
    fn new(inner: R) -> Self {
        Self {
            inner,
            offset: 0,
            newlines: 0,
            open_run: None,
            runs: VecDeque::new(),
            base_line: 1,
        }
    }

    /// Line on which the record the csv crate reports at byte offset `byte` starts. Queries
    /// must not decrease.
    fn line_at(&mut self, byte: u64) -> u64 {
        while let Some(run) = self.runs.front()
            && run.end <= byte
        {
            self.base_line = run.line_at_end;
            self.runs.pop_front();
        }
        match self.runs.front() {
            Some(run) if run.start <= byte => run.line_at_end,
            _ => self.base_line,
        }
    }
}

impl<R: Read> Read for LineTracker<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        for (at, &b) in (self.offset..).zip(&buf[..n]) {
            if b == b'\n' || b == b'\r' {
                self.open_run.get_or_insert(at);
                self.newlines += u64::from(b == b'\n');
            } else if let Some(start) = self.open_run.take() {
                self.runs.push_back(NewlineRun {
                    start,
                    end: at,
                    line_at_end: 1 + self.newlines,
                });
            }
        }
        self.offset += n as u64;
        Ok(n)
    }
}

fn csv_error<R>(path: &Path, e: csv::Error, lines: &mut LineTracker<R>) -> IncidentError {
    let line = e.position().map_or(0, |p| lines.line_at(p.byte()));
    let message = e.to_string();
    match e.into_kind() {
        csv::ErrorKind::Io(source) => IncidentError::Io {
            path: path.to_path_buf(),
            source,
        },
        csv::ErrorKind::UnequalLengths {
            pos,
            expected_len,
            len,
        } => IncidentError::Malformed {
            path: path.to_path_buf(),
            line: pos.map_or(line, |p| lines.line_at(p.byte())),
            message: format!("record has {len} fields but the header has {expected_len}"),
        },
        _ => IncidentError::Malformed {
            path: path.to_path_buf(),
            line,
            message,
        },
    }
}

fn read_csv(file: File, filter: &IncidentFilter, table: &mut IncidentTable) -> Result<(), IncidentError> {
    let path = table.path.clone();
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(false)
        .buffer_capacity(1 << 20)
        .from_reader(LineTracker::new(file));
    let found: Vec<String> = match rdr.byte_headers() {
        Ok(headers) => headers
            .iter()
            .map(|h| {
                String::from_utf8_lossy(h)
                    .trim_start_matches('\u{feff}')
                    .to_owned()
            })
            .collect(),
        Err(e) => return Err(csv_error(&path, e, rdr.get_mut())),
    };
    // Best-ranked column per slot; ties keep the first column.
    let mut best: [Option<(u16, usize)>; SLOTS.len()] = [None; SLOTS.len()];
    for (col, name) in found.iter().enumerate() {
        if let Some((slot, rank)) = classify(name)
            && best[slot as usize].is_none_or(|(r, _)| rank < r)
        {
            best[slot as usize] = Some((rank, col));
        }
    }
    let col = |slot: Slot| best[slot as usize].map(|(_, c)| c);
    let missing = |column: &str, slots: &[Slot]| IncidentError::MissingColumn {
        path: path.clone(),
        column: column.to_owned(),
        accepted: accepted(slots),
        found: found.clone(),
    };
    let date_col = col(Slot::Date).ok_or_else(|| missing("FireDiscoveryDateTime", &[Slot::Date]))?;
    let initial = col(Slot::InitLat).zip(col(Slot::InitLon));
    let xy = col(Slot::X).zip(col(Slot::Y));
    if initial.is_none() && xy.is_none() {
        return Err(missing(
            "InitialLatitude/InitialLongitude or X/Y",
            &[Slot::InitLat, Slot::InitLon, Slot::X, Slot::Y],
        ));
    }
    let category_col = col(Slot::Category);
    let uid_col = col(Slot::Uid);
    let irwin_col = col(Slot::Irwin);

    let mut record = csv::ByteRecord::new();
    let mut row = 0u64;
    loop {
        match rdr.read_byte_record(&mut record) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => return Err(csv_error(&path, e, rdr.get_mut())),
        }
        row += 1;
        let line = record.position().map_or(0, |p| rdr.get_mut().line_at(p.byte()));
        let get = |c: Option<usize>| c.and_then(|c| record.get(c)).map_or(Val::Missing, Val::bytes);
        let raw = RawRow {
            date: get(Some(date_col)),
            init_lat: get(initial.map(|(lat, _)| lat)),
            init_lon: get(initial.map(|(_, lon)| lon)),
            geometry: GeomVal::Point(get(xy.map(|(x, _)| x)), get(xy.map(|(_, y)| y))),
            category: category_col.map(|c| get(Some(c))),
            uid: get(uid_col),
            irwin: get(irwin_col),
        };
        push_row(table, row, line, &raw, filter);
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// JSON (GeoJSON and Esri JSON), streamed
// ---------------------------------------------------------------------------------------------

/// A JSON attribute value.
#[derive(Debug, Clone)]
enum Scalar {
    Null,
    Bool,
    Int(i64),
    Num(f64),
    Str(String),
    Array,
    Object,
}

impl Scalar {
    fn val(&self) -> Val<'_> {
        match self {
            Scalar::Null => Val::Missing,
            Scalar::Bool => Val::Invalid("boolean"),
            Scalar::Int(i) => Val::Int(*i),
            Scalar::Num(f) => Val::Num(*f),
            Scalar::Str(s) => Val::text(s),
            Scalar::Array => Val::Invalid("array"),
            Scalar::Object => Val::Invalid("object"),
        }
    }
}

impl<'de> de::Deserialize<'de> for Scalar {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Scalar;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a JSON value")
            }
            fn visit_unit<E>(self) -> Result<Scalar, E> {
                Ok(Scalar::Null)
            }
            fn visit_none<E>(self) -> Result<Scalar, E> {
                Ok(Scalar::Null)
            }
            fn visit_bool<E>(self, _: bool) -> Result<Scalar, E> {
                Ok(Scalar::Bool)
            }
            fn visit_i64<E>(self, v: i64) -> Result<Scalar, E> {
                Ok(Scalar::Int(v))
            }
            fn visit_u64<E>(self, v: u64) -> Result<Scalar, E> {
                Ok(i64::try_from(v).map_or(Scalar::Num(v as f64), Scalar::Int))
            }
            fn visit_f64<E>(self, v: f64) -> Result<Scalar, E> {
                Ok(Scalar::Num(v))
            }
            fn visit_str<E>(self, v: &str) -> Result<Scalar, E> {
                Ok(Scalar::Str(v.to_owned()))
            }
            fn visit_string<E>(self, v: String) -> Result<Scalar, E> {
                Ok(Scalar::Str(v))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Scalar, A::Error> {
                while seq.next_element::<IgnoredAny>()?.is_some() {}
                Ok(Scalar::Array)
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Scalar, A::Error> {
                while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
                Ok(Scalar::Object)
            }
        }
        d.deserialize_any(V)
    }
}

/// An attribute key: which field it is, and its name when asked to keep it.
struct Key {
    slot: Option<(Slot, u16)>,
    name: Option<String>,
}

struct KeySeed {
    keep_name: bool,
}

impl<'de> DeserializeSeed<'de> for KeySeed {
    type Value = Key;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Key, D::Error> {
        d.deserialize_str(self)
    }
}

impl Visitor<'_> for KeySeed {
    type Value = Key;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("an attribute name")
    }
    fn visit_str<E>(self, v: &str) -> Result<Key, E> {
        Ok(Key {
            slot: classify(v),
            name: self.keep_name.then(|| v.to_owned()),
        })
    }
}

/// The attributes of one feature that the reader needs, each with its match rank.
#[derive(Default)]
struct Attrs {
    fields: [Option<(u16, Scalar)>; SLOTS.len()],
    names: Vec<String>,
}

impl Attrs {
    fn get(&self, slot: Slot) -> Option<&Scalar> {
        self.fields[slot as usize].as_ref().map(|(_, v)| v)
    }
    fn val(&self, slot: Slot) -> Val<'_> {
        self.get(slot).map_or(Val::Missing, Scalar::val)
    }
}

struct AttrsSeed {
    keep_names: bool,
}

impl<'de> DeserializeSeed<'de> for AttrsSeed {
    type Value = Option<Attrs>;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_option(self)
    }
}

impl<'de> Visitor<'de> for AttrsSeed {
    type Value = Option<Attrs>;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("an attributes/properties object or null")
    }
    fn visit_none<E>(self) -> Result<Self::Value, E> {
        Ok(None)
    }
    fn visit_unit<E>(self) -> Result<Self::Value, E> {
        Ok(None)
    }
    fn visit_some<D: de::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_map(self)
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let mut attrs = Attrs::default();
        while let Some(key) = map.next_key_seed(KeySeed {
            keep_name: self.keep_names,
        })? {
            if let Some(name) = key.name {
                attrs.names.push(name);
            }
            match key.slot {
                Some((slot, rank))
                    if attrs.fields[slot as usize]
                        .as_ref()
                        .is_none_or(|(r, _)| rank < *r) =>
                {
                    let v: Scalar = map.next_value()?;
                    attrs.fields[slot as usize] = Some((rank, v));
                }
                _ => {
                    map.next_value::<IgnoredAny>()?;
                }
            }
        }
        Ok(Some(attrs))
    }
}

/// A feature's geometry, reduced to what the reader needs.
#[derive(Default)]
struct Geometry {
    /// GeoJSON `type`.
    kind: Option<String>,
    /// GeoJSON `coordinates` of a point: the first two numbers, if it is a flat array.
    coords: Option<Coords>,
    /// Esri `x`, `y` (key present → `Some`).
    x: Option<Scalar>,
    y: Option<Scalar>,
    /// Esri multi-part member seen (`rings`, `paths`, `points`).
    esri_parts: Option<&'static str>,
}

struct Coords {
    values: Vec<Scalar>,
    nested: bool,
}

impl<'de> de::Deserialize<'de> for Coords {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Coords;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a coordinates array")
            }
            fn visit_unit<E>(self) -> Result<Coords, E> {
                Ok(Coords {
                    values: Vec::new(),
                    nested: false,
                })
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Coords, A::Error> {
                let mut c = Coords {
                    values: Vec::new(),
                    nested: false,
                };
                while let Some(v) = seq.next_element::<Scalar>()? {
                    match v {
                        Scalar::Array => c.nested = true,
                        v if c.values.len() < 2 => c.values.push(v),
                        _ => {}
                    }
                }
                Ok(c)
            }
        }
        d.deserialize_any(V)
    }
}

impl<'de> de::Deserialize<'de> for Geometry {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Geometry;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a geometry object or null")
            }
            fn visit_unit<E>(self) -> Result<Geometry, E> {
                Ok(Geometry::default())
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Geometry, A::Error> {
                let mut g = Geometry::default();
                while let Some(key) = map.next_key::<String>()? {
                    match key.as_str() {
                        "type" => g.kind = map.next_value::<Option<String>>()?,
                        "coordinates" => g.coords = Some(map.next_value()?),
                        "x" => g.x = Some(map.next_value()?),
                        "y" => g.y = Some(map.next_value()?),
                        "rings" | "paths" | "points" => {
                            map.next_value::<IgnoredAny>()?;
                            g.esri_parts = Some(match key.as_str() {
                                "rings" => "polygon geometry",
                                "paths" => "polyline geometry",
                                _ => "multipoint geometry",
                            });
                        }
                        _ => {
                            map.next_value::<IgnoredAny>()?;
                        }
                    }
                }
                Ok(g)
            }
        }
        d.deserialize_any(V)
    }
}

fn opt_val(s: &Option<Scalar>) -> Val<'_> {
    s.as_ref().map_or(Val::Missing, Scalar::val)
}

impl Geometry {
    fn is_empty(&self) -> bool {
        self.kind.is_none() && self.coords.is_none() && self.x.is_none() && self.y.is_none()
    }

    fn val(&self) -> GeomVal<'_> {
        if self.x.is_some() || self.y.is_some() {
            return GeomVal::Point(opt_val(&self.x), opt_val(&self.y));
        }
        if let Some(parts) = self.esri_parts {
            return GeomVal::NotPoint(parts);
        }
        match (&self.kind, &self.coords) {
            (Some(kind), _) if kind != "Point" => GeomVal::NotPoint(kind),
            (_, Some(c)) if c.nested => GeomVal::NotPoint("nested coordinates"),
            (_, Some(c)) => {
                let v = |i: usize| c.values.get(i).map_or(Val::Missing, Scalar::val);
                GeomVal::Point(v(0), v(1))
            }
            (_, None) => GeomVal::Point(Val::Missing, Val::Missing),
        }
    }
}

/// One feature: attributes (`attributes` or `properties`) and geometry.
struct Feature {
    attrs: Option<Attrs>,
    /// `Some(true)` for `properties` (GeoJSON), `Some(false)` for `attributes` (Esri).
    geojson: Option<bool>,
    geometry: Option<Geometry>,
}

struct FeatureSeed {
    keep_names: bool,
}

impl<'de> DeserializeSeed<'de> for FeatureSeed {
    type Value = Feature;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Feature, D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> Visitor<'de> for FeatureSeed {
    type Value = Feature;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a feature object")
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Feature, A::Error> {
        let mut feature = Feature {
            attrs: None,
            geojson: None,
            geometry: None,
        };
        while let Some(key) = map.next_key::<String>()? {
            match key.as_str() {
                "attributes" | "properties" if feature.attrs.is_none() => {
                    feature.attrs = map.next_value_seed(AttrsSeed {
                        keep_names: self.keep_names,
                    })?;
                    feature.geojson = Some(key == "properties");
                }
                "geometry" => feature.geometry = Some(map.next_value()?),
                _ => {
                    map.next_value::<IgnoredAny>()?;
                }
            }
        }
        Ok(feature)
    }
}

/// Accumulates rows while the features array is being streamed.
struct JsonCtx<'a> {
    filter: &'a IncidentFilter,
    table: &'a mut IncidentTable,
    rows: u64,
    saw_properties: bool,
    saw_attributes: bool,
    saw_date: bool,
    saw_initial: bool,
    saw_geometry: bool,
    /// Attribute names of the first feature that has attributes.
    first_names: Option<Vec<String>>,
}

impl JsonCtx<'_> {
    fn process(&mut self, feature: Feature) {
        self.rows += 1;
        let attrs = feature.attrs.unwrap_or_default();
        match feature.geojson {
            Some(true) => self.saw_properties = true,
            Some(false) => self.saw_attributes = true,
            None => {}
        }
        if self.first_names.is_none() && feature.geojson.is_some() {
            self.first_names = Some(attrs.names.clone());
        }
        self.saw_date |= attrs.get(Slot::Date).is_some();
        self.saw_initial |= attrs.get(Slot::InitLat).is_some() && attrs.get(Slot::InitLon).is_some();
        let geometry = feature.geometry.unwrap_or_default();
        self.saw_geometry |= !geometry.is_empty() || geometry.esri_parts.is_some();
        let raw = RawRow {
            date: attrs.val(Slot::Date),
            init_lat: attrs.val(Slot::InitLat),
            init_lon: attrs.val(Slot::InitLon),
            geometry: geometry.val(),
            category: attrs.get(Slot::Category).map(Scalar::val),
            uid: attrs.val(Slot::Uid),
            irwin: attrs.val(Slot::Irwin),
        };
        push_row(self.table, self.rows, 0, &raw, self.filter);
    }
}

struct FeaturesSeed<'c, 'a> {
    ctx: &'c mut JsonCtx<'a>,
}

impl<'de> DeserializeSeed<'de> for FeaturesSeed<'_, '_> {
    type Value = ();
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for FeaturesSeed<'_, '_> {
    type Value = ();
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a `features` array")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        loop {
            let seed = FeatureSeed {
                keep_names: self.ctx.first_names.is_none(),
            };
            match seq.next_element_seed(seed)? {
                Some(feature) => self.ctx.process(feature),
                None => return Ok(()),
            }
        }
    }
}

/// Top-level members other than `features`.
#[derive(Default)]
struct TopInfo {
    kind: Option<String>,
    has_features: bool,
    esri_markers: bool,
    /// `spatialReference` `latestWkid`/`wkid`, whichever are present, and the member as text.
    wkids: Vec<i64>,
    spatial_reference: String,
    crs_name: Option<String>,
    error: Option<String>,
}

struct TopSeed<'c, 'a> {
    ctx: &'c mut JsonCtx<'a>,
}

impl<'de> DeserializeSeed<'de> for TopSeed<'_, '_> {
    type Value = TopInfo;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<TopInfo, D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> Visitor<'de> for TopSeed<'_, '_> {
    type Value = TopInfo;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a GeoJSON FeatureCollection or an Esri JSON feature set")
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<TopInfo, A::Error> {
        let mut info = TopInfo::default();
        while let Some(key) = map.next_key::<String>()? {
            match key.as_str() {
                "features" => {
                    if info.has_features {
                        return Err(de::Error::duplicate_field("features"));
                    }
                    map.next_value_seed(FeaturesSeed { ctx: &mut *self.ctx })?;
                    info.has_features = true;
                }
                "type" => info.kind = map.next_value::<Option<String>>()?,
                "spatialReference" => {
                    info.esri_markers = true;
                    let v: serde_json::Value = map.next_value()?;
                    info.spatial_reference = v.to_string();
                    for k in ["latestWkid", "wkid"] {
                        if let Some(w) = v.get(k).and_then(serde_json::Value::as_i64) {
                            info.wkids.push(w);
                        }
                    }
                }
                "crs" => {
                    let v: serde_json::Value = map.next_value()?;
                    info.crs_name = v
                        .pointer("/properties/name")
                        .and_then(serde_json::Value::as_str)
                        .map(str::to_owned);
                }
                "error" => {
                    let v: serde_json::Value = map.next_value()?;
                    info.error = Some(v.to_string());
                }
                "geometryType" | "fields" | "objectIdFieldName" | "globalIdFieldName" => {
                    info.esri_markers = true;
                    map.next_value::<IgnoredAny>()?;
                }
                _ => {
                    map.next_value::<IgnoredAny>()?;
                }
            }
        }
        Ok(info)
    }
}

/// `true` when a CRS name (GeoJSON `crs.properties.name`) is geographic WGS84/NAD83.
fn crs_name_ok(name: &str) -> bool {
    let last = name.rsplit(':').next().unwrap_or(name).trim();
    ["4326", "4269", "CRS84", "CRS83"]
        .iter()
        .any(|ok| last.eq_ignore_ascii_case(ok))
}

/// JSON files up to this size are read into memory and parsed from the slice (about twice as
/// fast as from a reader); larger ones are streamed.
const JSON_IN_MEMORY_LIMIT: u64 = 512 << 20;

/// UTF-8 byte-order mark, which serde_json does not accept.
const BOM: &[u8] = b"\xef\xbb\xbf";

fn parse_json<'de, R: serde_json::de::Read<'de>>(
    mut de: serde_json::Deserializer<R>,
    ctx: &mut JsonCtx<'_>,
) -> Result<TopInfo, serde_json::Error> {
    let info = TopSeed { ctx }.deserialize(&mut de)?;
    de.end()?;
    Ok(info)
}

fn read_json(
    mut file: File,
    filter: &IncidentFilter,
    table: &mut IncidentTable,
    in_memory_limit: u64,
) -> Result<(), IncidentError> {
    let path = table.path.clone();
    let io_error = |source: io::Error| IncidentError::Io {
        path: path.clone(),
        source,
    };
    let json_error = |e: serde_json::Error| {
        if e.is_io() {
            IncidentError::Io {
                path: path.clone(),
                source: e.into(),
            }
        } else {
            IncidentError::Malformed {
                path: path.clone(),
                line: e.line() as u64,
                message: e.to_string(),
            }
        }
    };
    let mut ctx = JsonCtx {
        filter,
        table,
        rows: 0,
        saw_properties: false,
        saw_attributes: false,
        saw_date: false,
        saw_initial: false,
        saw_geometry: false,
        first_names: None,
    };
    let len = file.metadata().map_err(io_error)?.len();
    let info = if len <= in_memory_limit {
        let mut buf = Vec::with_capacity(usize::try_from(len).unwrap_or(0));
        file.read_to_end(&mut buf).map_err(io_error)?;
        let json = buf.strip_prefix(BOM).unwrap_or(&buf);
        parse_json(serde_json::Deserializer::from_slice(json), &mut ctx)
    } else {
        let mut reader = BufReader::with_capacity(1 << 20, file);
        if io::BufRead::fill_buf(&mut reader)
            .map_err(io_error)?
            .starts_with(BOM)
        {
            io::BufRead::consume(&mut reader, BOM.len());
        }
        parse_json(serde_json::Deserializer::from_reader(reader), &mut ctx)
    }
    .map_err(json_error)?;

    let malformed = |message: String| IncidentError::Malformed {
        path: path.clone(),
        line: 0,
        message,
    };
    if let Some(error) = info.error {
        return Err(malformed(format!(
            "ArcGIS error response instead of features: {error}"
        )));
    }
    if !info.has_features {
        return Err(malformed("no `features` array".to_owned()));
    }
    if let Some(kind) = &info.kind
        && kind != "FeatureCollection"
    {
        return Err(malformed(format!(
            "GeoJSON type {kind:?}, expected \"FeatureCollection\""
        )));
    }
    if !info.wkids.is_empty() && !info.wkids.iter().any(|w| matches!(w, 4326 | 4269)) {
        return Err(IncidentError::SpatialReference {
            path,
            found: info.spatial_reference,
        });
    }
    if let Some(name) = &info.crs_name
        && !crs_name_ok(name)
    {
        return Err(IncidentError::SpatialReference {
            path,
            found: name.clone(),
        });
    }
    ctx.table.format = if info.kind.is_some() {
        IncidentFormat::GeoJson
    } else if info.esri_markers || ctx.saw_attributes {
        IncidentFormat::EsriJson
    } else if ctx.saw_properties
        || path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("geojson"))
    {
        IncidentFormat::GeoJson
    } else {
        IncidentFormat::EsriJson
    };
    if ctx.rows > 0 {
        let found = ctx.first_names.take().unwrap_or_default();
        if !ctx.saw_date {
            return Err(IncidentError::MissingColumn {
                path,
                column: "FireDiscoveryDateTime".to_owned(),
                accepted: accepted(&[Slot::Date]),
                found,
            });
        }
        if !ctx.saw_initial && !ctx.saw_geometry {
            return Err(IncidentError::MissingColumn {
                path,
                column: "InitialLatitude/InitialLongitude or geometry".to_owned(),
                accepted: accepted(&[Slot::InitLat, Slot::InitLon]),
                found,
            });
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Dates
// ---------------------------------------------------------------------------------------------

/// Parses a discovery date-time into milliseconds since 1970-01-01T00:00:00Z.
///
/// Accepted (surrounding white space ignored; every value without an explicit offset is UTC,
/// docs/spec/data.md §1.4):
///
/// - epoch milliseconds: an optionally negative integer of 11 to 13 digits, optionally with a
///   `.0…` suffix as pandas writes integral floats (`1596740280000`, `1596740280000.0`). Shorter
///   integers (epoch seconds, compact `YYYYMMDD` dates) are refused rather than misread as a
///   date in early 1970;
/// - year first, `-` or `/` between the date parts: `YYYY-MM-DD`, `YYYY/MM/DD`, optionally
///   followed by `T` or spaces and `HH:MM[:SS[.fff…]]`, optionally followed by a zone `Z`,
///   `UTC`, `GMT`, `±HH`, `±HHMM` or `±HH:MM` (e.g. `2023/07/04 21:15:00+00`,
///   `2020-08-06T18:58:00.000Z`, `2020-08-06 18:58:00`, `2020-08-06`);
/// - US style `M/D/YYYY`, optionally followed by `h:mm[:ss[.fff…]]` and `AM`/`PM`
///   (12-hour clock, `12 AM` = 00) or no marker (24-hour clock), and an optional zone as above.
///
/// Fractional seconds are truncated to milliseconds. Months, days (leap years included), hours,
/// minutes and seconds are range-checked; `None` for anything else.
pub fn parse_discovery_time(s: &str) -> Option<i64> {
    let s = s.trim();
    let b = s.as_bytes();
    let digits = b.strip_prefix(b"-").unwrap_or(b);
    if digits.first().is_some_and(u8::is_ascii_digit)
        && digits.iter().all(|c| c.is_ascii_digit() || *c == b'.')
    {
        return parse_epoch_ms_text(s);
    }
    let mut c = Cursor { b, pos: 0 };
    if b.len() > 4 && b[..4].iter().all(u8::is_ascii_digit) && matches!(b[4], b'-' | b'/') {
        parse_year_first(&mut c)
    } else {
        parse_us(&mut c)
    }
}

fn parse_epoch_ms_text(s: &str) -> Option<i64> {
    let (int, frac) = s.split_once('.').unwrap_or((s, ""));
    if !frac.bytes().all(|c| c == b'0') {
        return None;
    }
    let n_digits = int.trim_start_matches('-').len();
    if !(11..=13).contains(&n_digits) {
        return None;
    }
    int.parse::<i64>().ok().and_then(epoch_ms_in_range)
}

struct Cursor<'a> {
    b: &'a [u8],
    pos: usize,
}

impl Cursor<'_> {
    fn peek(&self) -> Option<u8> {
        self.b.get(self.pos).copied()
    }
    fn at_end(&self) -> bool {
        self.pos >= self.b.len()
    }
    fn eat(&mut self, c: u8) -> bool {
        if self.peek() == Some(c) {
            self.pos += 1;
            true
        } else {
            false
        }
    }
    fn eat_ci(&mut self, word: &str) -> bool {
        let end = self.pos + word.len();
        if self
            .b
            .get(self.pos..end)
            .is_some_and(|w| w.eq_ignore_ascii_case(word.as_bytes()))
        {
            self.pos = end;
            true
        } else {
            false
        }
    }
    fn skip_spaces(&mut self) -> bool {
        let start = self.pos;
        while self.peek() == Some(b' ') {
            self.pos += 1;
        }
        self.pos > start
    }
    /// Reads `min..=max` ASCII digits as a number.
    fn number(&mut self, min: usize, max: usize) -> Option<u32> {
        let start = self.pos;
        let mut v = 0u32;
        while self.pos - start < max
            && let Some(d) = self.peek().filter(u8::is_ascii_digit)
        {
            v = v * 10 + u32::from(d - b'0');
            self.pos += 1;
        }
        (self.pos - start >= min).then_some(v)
    }
}

/// Time of day: hour (as written), minute, second, millisecond.
struct Tod {
    h: u32,
    m: u32,
    s: u32,
    ms: u32,
}

fn parse_tod(c: &mut Cursor<'_>) -> Option<Tod> {
    let h = c.number(1, 2)?;
    if !c.eat(b':') {
        return None;
    }
    let m = c.number(2, 2)?;
    let mut s = 0;
    let mut ms = 0;
    if c.eat(b':') {
        s = c.number(2, 2)?;
        if c.eat(b'.') || c.eat(b',') {
            let start = c.pos;
            c.number(1, 9)?;
            // First three fractional digits, right-padded: ".5" → 500, ".123456" → 123.
            ms = c.b[start..c.pos]
                .iter()
                .chain(std::iter::repeat(&b'0'))
                .take(3)
                .fold(0, |acc, d| acc * 10 + u32::from(d - b'0'));
        }
    }
    Some(Tod { h, m, s, ms })
}

/// Optional zone designator at the end of the text, as minutes east of UTC; `None` when the
/// text does not end with a valid zone (or nothing).
fn parse_zone_to_end(c: &mut Cursor<'_>) -> Option<i64> {
    c.skip_spaces();
    let offset = if c.at_end() || c.eat_ci("Z") || c.eat_ci("UTC") || c.eat_ci("GMT") {
        0
    } else if let Some(sign) = c.peek().filter(|s| matches!(s, b'+' | b'-')) {
        c.pos += 1;
        let h = c.number(2, 2)?;
        let colon = c.eat(b':');
        let m = if colon || !c.at_end() { c.number(2, 2)? } else { 0 };
        if h > 23 || m > 59 {
            return None;
        }
        let minutes = i64::from(h * 60 + m);
        if sign == b'-' { -minutes } else { minutes }
    } else {
        return None;
    };
    c.skip_spaces();
    c.at_end().then_some(offset)
}

fn parse_year_first(c: &mut Cursor<'_>) -> Option<i64> {
    let year = c.number(4, 4)?;
    let sep = c.peek()?;
    c.pos += 1;
    let month = c.number(1, 2)?;
    if !c.eat(sep) {
        return None;
    }
    let day = c.number(1, 2)?;
    if c.at_end() {
        return to_epoch_ms(
            year,
            month,
            day,
            &Tod {
                h: 0,
                m: 0,
                s: 0,
                ms: 0,
            },
            0,
        );
    }
    if !(c.eat(b'T') || c.eat(b't') || c.skip_spaces()) {
        return None;
    }
    let tod = parse_tod(c)?;
    let offset = parse_zone_to_end(c)?;
    to_epoch_ms(year, month, day, &tod, offset)
}

fn parse_us(c: &mut Cursor<'_>) -> Option<i64> {
    let month = c.number(1, 2)?;
    if !c.eat(b'/') {
        return None;
    }
    let day = c.number(1, 2)?;
    if !c.eat(b'/') {
        return None;
    }
    let year = c.number(4, 4)?;
    if c.at_end() {
        return to_epoch_ms(
            year,
            month,
            day,
            &Tod {
                h: 0,
                m: 0,
                s: 0,
                ms: 0,
            },
            0,
        );
    }
    if !c.skip_spaces() {
        return None;
    }
    let mut tod = parse_tod(c)?;
    c.skip_spaces();
    let pm = if c.eat_ci("AM") {
        Some(false)
    } else if c.eat_ci("PM") {
        Some(true)
    } else {
        None
    };
    if let Some(pm) = pm {
        if !(1..=12).contains(&tod.h) {
            return None;
        }
        tod.h = tod.h % 12 + if pm { 12 } else { 0 };
    }
    let offset = parse_zone_to_end(c)?;
    to_epoch_ms(year, month, day, &tod, offset)
}

fn to_epoch_ms(year: u32, month: u32, day: u32, t: &Tod, offset_min: i64) -> Option<i64> {
    if !(1..=12).contains(&month)
        || day == 0
        || day > crate::gridmet::days_in_month(year as i32, month)
        || t.h > 23
        || t.m > 59
        || t.s > 59
    {
        return None;
    }
    let days = crate::gridmet::days_from_civil(i64::from(year), month, day);
    let secs = days * 86_400 + i64::from(t.h * 3600 + t.m * 60 + t.s) - offset_min * 60;
    Some(secs * 1000 + i64::from(t.ms))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classify_prefers_exact_names() {
        assert_eq!(classify("X"), Some((Slot::X, 0)));
        assert_eq!(classify("x"), Some((Slot::X, 1)));
        assert_eq!(classify("\u{feff}FireDiscoveryDateTime"), Some((Slot::Date, 0)));
        assert_eq!(classify(" firediscoverydatetime "), Some((Slot::Date, LOOSE)));
        assert_eq!(classify("IncidentName"), None);
    }

    /// Hands out one byte per `read`, so every run of line breaks spans reads.
    struct OneByte<'a>(&'a [u8]);

    impl Read for OneByte<'_> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            match (self.0.split_first(), buf.first_mut()) {
                (Some((b, rest)), Some(slot)) => {
                    *slot = *b;
                    self.0 = rest;
                    Ok(1)
                }
                _ => Ok(0),
            }
        }
    }

    #[test]
    fn record_lines_with_crlf_blank_lines_and_quoted_breaks() {
        let data = b"h1,h2\r\na,b\r\n\r\n\nc,\"d\r\ne\"\r\nf,g\n\n\"\nh\",i\r\nj,k";
        // a,b: line 2; c: line 5 (after two blank lines); f: 7; "\nh": 9; j: 11.
        for capacity in [8, 64, 1 << 16] {
            let mut rdr = csv::ReaderBuilder::new()
                .buffer_capacity(capacity)
                .from_reader(LineTracker::new(OneByte(data)));
            let mut rec = csv::ByteRecord::new();
            let mut lines = Vec::new();
            while rdr.read_byte_record(&mut rec).expect("valid csv") {
                let byte = rec.position().expect("position").byte();
                lines.push(rdr.get_mut().line_at(byte));
            }
            assert_eq!(lines, [2, 5, 7, 9, 11], "capacity {capacity}");
        }
    }

    #[test]
    fn json_streamed_and_in_memory_agree() {
        let dir = std::path::PathBuf::from(
            std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
        )
        .join("tests/fixtures/incidents");
        for name in ["wfigs.geojson", "wfigs_esri.json", "invalid.geojson"] {
            let path = dir.join(name);
            let filter = IncidentFilter::default();
            let slurped = read_with_limit(&path, &filter, u64::MAX);
            let streamed = read_with_limit(&path, &filter, 0);
            match (slurped, streamed) {
                (Ok(a), Ok(b)) => {
                    assert_eq!(a.format, b.format, "{name}");
                    assert_eq!(a.incidents, b.incidents, "{name}");
                    assert_eq!(a.rejects, b.rejects, "{name}");
                }
                (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "{name}"),
                (a, b) => panic!("{name}: {a:?} vs {b:?}"),
            }
        }
    }

    #[test]
    fn epoch_ms_magnitude() {
        assert_eq!(parse_discovery_time("1596740280000"), Some(1_596_740_280_000));
        assert_eq!(parse_discovery_time("1596740280"), None);
        assert_eq!(parse_discovery_time("20200806"), None);
        assert_eq!(parse_discovery_time("-31536000000"), Some(-31_536_000_000));
    }

    #[test]
    fn zone_offsets_are_applied() {
        let utc = parse_discovery_time("2020-08-06T18:58:00Z");
        assert_eq!(parse_discovery_time("2020-08-06T20:58:00+02:00"), utc);
        assert_eq!(parse_discovery_time("2020-08-06T11:58:00-0700"), utc);
        assert_eq!(parse_discovery_time("2020/08/06 18:58:00+00"), utc);
        assert_eq!(parse_discovery_time("2020/08/06 18:58:00+24"), None);
    }
}
