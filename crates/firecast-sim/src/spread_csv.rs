//! CSV front end of `firecast sim spread-rate --input CASES.csv --output OUT.csv`.
//!
//! **Input**: a header row, then one case per row. Columns are found by header name (order
//! free, extra columns ignored):
//!
//! | column | meaning |
//! |---|---|
//! | `fm` (or, if absent, `code`, then `fuel_model`) | fuel model, number (`4`, `124`) or code (`FM4`, `GS4`) |
//! | `m1_pct`, `m10_pct`, `m100_pct`, `mherb_pct`, `mwoody_pct` | moistures, % of oven-dry weight, ≥ 0 |
//! | `midflame_mph` | midflame wind, mi/h, ≥ 0 |
//! | `slope_pct` | slope, percent, ≥ 0 |
//! | `wind_dir_rel_upslope_deg` | direction the wind blows toward, degrees clockwise from upslope |
//!
//! An optional `case` column is echoed.
//!
//! **Output**: one row per case. First the echoed inputs, `case` (only if the input has it),
//! `fm` and `code` (the resolved standard model), then the eight input columns above exactly
//! as written in the input; then the results `R0_ftmin, ros_ftmin, ros_chph,
//! dir_max_spread_rel_upslope_deg, IR_btuft2min, flame_ft, fli_btufts, hpua_btuft2, lw_ratio,
//! back_ftmin, flank_ftmin` (behave's defaults: wind limit off), printed with the shortest
//! representation that parses back to the same f64. Where the fire cannot spread, rates and
//! energies are 0, `lw_ratio` is 1 and the direction 0.
//!
//! The output is written to a temporary file next to `output` and renamed over it only once
//! every row succeeded, so a failed run never leaves a partial file.
//!
//! The parser is a small RFC 4180 reader (quoted fields, doubled quotes, CRLF, UTF-8 BOM,
//! blank lines skipped), kept in-crate to avoid a dependency for a few dozen lines.

use std::fs::File;
use std::io::{self, BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::fuel::FuelModel;
use crate::rothermel::{FuelMoisture, SpreadInputs, SurfaceFuelBed};

/// The result columns, in output order.
pub const OUTPUT_COLUMNS: [&str; 11] = [
    "R0_ftmin",
    "ros_ftmin",
    "ros_chph",
    "dir_max_spread_rel_upslope_deg",
    "IR_btuft2min",
    "flame_ft",
    "fli_btufts",
    "hpua_btuft2",
    "lw_ratio",
    "back_ftmin",
    "flank_ftmin",
];

/// Accepted names of the fuel-model column, in order of preference.
const FUEL_MODEL_COLUMNS: [&str; 3] = ["fm", "code", "fuel_model"];

/// The numeric input columns, in output order.
const NUMERIC_COLUMNS: [&str; 8] = [
    "m1_pct",
    "m10_pct",
    "m100_pct",
    "mherb_pct",
    "mwoody_pct",
    "midflame_mph",
    "slope_pct",
    "wind_dir_rel_upslope_deg",
];

/// Columns whose value must not be negative (all but the wind direction).
const NON_NEGATIVE_COLUMNS: usize = 7;

/// Why a spread-rate CSV run failed. Row-level errors name the file, the 1-based line
/// (the header is line 1) and the column.
#[derive(Debug, thiserror::Error)]
pub enum SpreadCsvError {
    /// The input could not be opened or read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// Input file.
        path: PathBuf,
        /// Underlying error.
        source: io::Error,
    },
    /// The output could not be written or moved into place.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// Output (or its temporary) file.
        path: PathBuf,
        /// Underlying error.
        source: io::Error,
    },
    /// The input has no header row.
    #[error("{}: empty file, expected a header row", path.display())]
    Empty {
        /// Input file.
        path: PathBuf,
    },
    /// A required column is missing from the header.
    #[error("{}:1: missing column `{column}`", path.display())]
    MissingColumn {
        /// Input file.
        path: PathBuf,
        /// The column (alternatives separated by `|`).
        column: String,
    },
    /// The CSV structure is broken (unterminated quote, wrong number of fields…).
    #[error("{}:{line}: malformed CSV: {message}", path.display())]
    Malformed {
        /// Input file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The fuel model is neither a standard number nor a standard code.
    #[error("{}:{line}: column `{column}`: unknown fuel model {value:?}", path.display())]
    UnknownFuelModel {
        /// Input file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// Column name.
        column: String,
        /// The offending text.
        value: String,
    },
    /// A field is not a finite number.
    #[error("{}:{line}: column `{column}`: {value:?} is not a finite number", path.display())]
    InvalidNumber {
        /// Input file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// Column name.
        column: String,
        /// The offending text.
        value: String,
    },
    /// A moisture, wind speed or slope is negative.
    #[error("{}:{line}: column `{column}`: {value} must not be negative", path.display())]
    NegativeValue {
        /// Input file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// Column name.
        column: String,
        /// The offending value.
        value: f64,
    },
    /// The kernel rejected the case (should not happen once the fields are validated).
    #[error("{}:{line}: {source}", path.display())]
    Kernel {
        /// Input file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// Underlying error.
        source: crate::rothermel::RothermelError,
    },
}

/// Runs the Rothermel–Albini kernel (behave defaults) on every case of `input` and writes the
/// results to `output` atomically. Returns the number of cases written. See the module docs
/// for the column contract.
pub fn spread_rate_csv(input: &Path, output: &Path) -> Result<usize, SpreadCsvError> {
    let read_err = |source| SpreadCsvError::Read {
        path: input.to_path_buf(),
        source,
    };
    let reader = BufReader::new(File::open(input).map_err(read_err)?);

    let write_err = |path: &Path| {
        let path = path.to_path_buf();
        move |source| SpreadCsvError::Write { path, source }
    };
    // A temporary name unique per process and call (removed on drop unless published), so
    // concurrent runs never share a temporary file.
    let temp = firecast_fs::TempPath::new(output).map_err(|e| write_err(&e.path)(e.source))?;
    let file = File::create(temp.path()).map_err(write_err(temp.path()))?;
    let mut writer = BufWriter::new(file);

    let count = process(reader, input, &mut writer, temp.path())?;

    writer
        .into_inner()
        .map_err(|e| e.into_error())
        .and_then(|f| f.sync_all())
        .map_err(write_err(temp.path()))?;
    temp.publish().map_err(|e| write_err(output)(e.source))?;
    Ok(count)
}

/// Column positions resolved from the header.
struct Layout {
    width: usize,
    case: Option<usize>,
    fuel_model: (usize, &'static str),
    numeric: [usize; NUMERIC_COLUMNS.len()],
}

impl Layout {
    fn from_header(header: &[String], path: &Path) -> Result<Self, SpreadCsvError> {
        let find = |name: &str| header.iter().position(|h| h.trim() == name);
        let missing = |column: String| SpreadCsvError::MissingColumn {
            path: path.to_path_buf(),
            column,
        };
        let fuel_model = FUEL_MODEL_COLUMNS
            .iter()
            .find_map(|&name| find(name).map(|i| (i, name)))
            .ok_or_else(|| missing(FUEL_MODEL_COLUMNS.join("|")))?;
        let mut numeric = [0; NUMERIC_COLUMNS.len()];
        for (slot, name) in numeric.iter_mut().zip(NUMERIC_COLUMNS) {
            *slot = find(name).ok_or_else(|| missing(name.to_owned()))?;
        }
        Ok(Self {
            width: header.len(),
            case: find("case"),
            fuel_model,
            numeric,
        })
    }

    fn output_header(&self) -> Vec<&'static str> {
        let mut header = Vec::with_capacity(3 + NUMERIC_COLUMNS.len() + OUTPUT_COLUMNS.len());
        if self.case.is_some() {
            header.push("case");
        }
        header.extend(["fm", "code"]);
        header.extend(NUMERIC_COLUMNS);
        header.extend(OUTPUT_COLUMNS);
        header
    }
}

/// Streams cases from `reader` (named `path` in errors) to `out` (named `out_path`).
fn process<R: BufRead, W: Write>(
    reader: R,
    path: &Path,
    out: &mut W,
    out_path: &Path,
) -> Result<usize, SpreadCsvError> {
    let mut records = RecordReader::new(reader, path);
    let (_, header) = records.next_record()?.ok_or_else(|| SpreadCsvError::Empty {
        path: path.to_path_buf(),
    })?;
    let layout = Layout::from_header(&header, path)?;
    let write_err = |source| SpreadCsvError::Write {
        path: out_path.to_path_buf(),
        source,
    };
    write_record(out, layout.output_header()).map_err(write_err)?;

    let mut count = 0;
    let mut row: Vec<String> = Vec::new();
    while let Some((line, fields)) = records.next_record()? {
        if fields.len() != layout.width {
            return Err(SpreadCsvError::Malformed {
                path: path.to_path_buf(),
                line,
                message: format!(
                    "expected {} fields as in the header, found {}",
                    layout.width,
                    fields.len()
                ),
            });
        }
        let field = |i: usize| fields[i].trim();

        let (fm_idx, fm_col) = layout.fuel_model;
        let model = FuelModel::lookup(field(fm_idx)).map_err(|_| SpreadCsvError::UnknownFuelModel {
            path: path.to_path_buf(),
            line,
            column: fm_col.to_owned(),
            value: field(fm_idx).to_owned(),
        })?;

        let mut values = [0.0; NUMERIC_COLUMNS.len()];
        for (k, (&idx, name)) in layout.numeric.iter().zip(NUMERIC_COLUMNS).enumerate() {
            let text = field(idx);
            let value = text
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| SpreadCsvError::InvalidNumber {
                    path: path.to_path_buf(),
                    line,
                    column: name.to_owned(),
                    value: text.to_owned(),
                })?;
            if k < NON_NEGATIVE_COLUMNS && value < 0.0 {
                return Err(SpreadCsvError::NegativeValue {
                    path: path.to_path_buf(),
                    line,
                    column: name.to_owned(),
                    value,
                });
            }
            values[k] = value;
        }
        let [m1, m10, m100, mherb, mwoody, wind_mph, slope_pct, wind_dir] = values;
        let moisture = FuelMoisture::from_percent(m1, m10, m100, mherb, mwoody);
        let bed = SurfaceFuelBed::new(model, &moisture).map_err(|source| SpreadCsvError::Kernel {
            path: path.to_path_buf(),
            line,
            source,
        })?;
        let fire = bed.spread(&SpreadInputs {
            midflame_wind_mph: wind_mph,
            slope_percent: slope_pct,
            wind_dir_from_upslope_deg: wind_dir,
        });

        row.clear();
        if let Some(i) = layout.case {
            row.push(field(i).to_owned());
        }
        row.push(model.number.to_string());
        row.push(model.code.to_owned());
        row.extend(layout.numeric.iter().map(|&i| field(i).to_owned()));
        row.extend(
            [
                fire.no_wind_no_slope_ros_ftmin,
                fire.head_ros_ftmin,
                fire.head_ros_chph(),
                fire.dir_max_spread_from_upslope_deg,
                fire.reaction_intensity_btu_ft2_min,
                fire.flame_length_ft,
                fire.fireline_intensity_btu_ft_s,
                fire.heat_per_unit_area_btu_ft2,
                fire.length_to_width_ratio,
                fire.backing_ros_ftmin,
                fire.flanking_ros_ftmin,
            ]
            .iter()
            .map(f64::to_string),
        );
        write_record(out, row.iter().map(String::as_str)).map_err(write_err)?;
        count += 1;
    }
    Ok(count)
}

/// Writes one CSV record, quoting fields that need it.
fn write_record<'a, W: Write>(out: &mut W, fields: impl IntoIterator<Item = &'a str>) -> io::Result<()> {
    for (i, field) in fields.into_iter().enumerate() {
        if i > 0 {
            out.write_all(b",")?;
        }
        if field.contains([',', '"', '\n', '\r']) {
            write!(out, "\"{}\"", field.replace('"', "\"\""))?;
        } else {
            out.write_all(field.as_bytes())?;
        }
    }
    out.write_all(b"\n")
}

/// Minimal RFC 4180 record reader that tracks the 1-based line each record starts on.
struct RecordReader<'p, R> {
    reader: R,
    path: &'p Path,
    /// Lines consumed so far.
    line: usize,
    buf: String,
}

impl<'p, R: BufRead> RecordReader<'p, R> {
    fn new(reader: R, path: &'p Path) -> Self {
        Self {
            reader,
            path,
            line: 0,
            buf: String::new(),
        }
    }

    /// Reads one physical line into `buf` (appending); false at end of input.
    fn read_line(&mut self) -> Result<bool, SpreadCsvError> {
        let n = self
            .reader
            .read_line(&mut self.buf)
            .map_err(|source| SpreadCsvError::Read {
                path: self.path.to_path_buf(),
                source,
            })?;
        if n > 0 {
            self.line += 1;
        }
        Ok(n > 0)
    }

    /// The next non-blank record with its starting line, or `None` at end of input.
    fn next_record(&mut self) -> Result<Option<(usize, Vec<String>)>, SpreadCsvError> {
        loop {
            self.buf.clear();
            if !self.read_line()? {
                return Ok(None);
            }
            let start_line = self.line;
            if start_line == 1 && self.buf.starts_with('\u{feff}') {
                self.buf.drain(..'\u{feff}'.len_utf8());
            }
            // A quoted field may span lines: keep reading while quotes are unbalanced.
            while self.buf.matches('"').count() % 2 == 1 {
                if !self.read_line()? {
                    return Err(SpreadCsvError::Malformed {
                        path: self.path.to_path_buf(),
                        line: start_line,
                        message: "unterminated quoted field".into(),
                    });
                }
            }
            let record = self.buf.trim_end_matches(['\n', '\r']);
            if record.trim().is_empty() {
                continue;
            }
            let fields = split_record(record).map_err(|message| SpreadCsvError::Malformed {
                path: self.path.to_path_buf(),
                line: start_line,
                message,
            })?;
            return Ok(Some((start_line, fields)));
        }
    }
}

/// Splits one (complete, possibly multi-line) record into fields.
fn split_record(record: &str) -> Result<Vec<String>, String> {
    let mut fields = Vec::new();
    let mut field = String::new();
    let mut chars = record.chars().peekable();
    let mut quoted = false;
    // True right after a closing quote: only a separator may follow.
    let mut closed = false;
    while let Some(c) = chars.next() {
        if quoted {
            if c == '"' {
                if chars.peek() == Some(&'"') {
                    field.push('"');
                    chars.next();
                } else {
                    quoted = false;
                    closed = true;
                }
            } else {
                field.push(c);
            }
        } else if c == ',' {
            fields.push(std::mem::take(&mut field));
            closed = false;
        } else if closed {
            return Err(format!("unexpected {c:?} after a closing quote"));
        } else if c == '"' && field.trim().is_empty() {
            field.clear();
            quoted = true;
        } else if c == '"' {
            return Err("quote inside an unquoted field".into());
        } else {
            field.push(c);
        }
    }
    fields.push(field);
    Ok(fields)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_handles_quotes() {
        assert_eq!(
            split_record(r#"a,"b,c","d""e",,"f""#).expect("valid"),
            vec!["a", "b,c", "d\"e", "", "f"]
        );
        assert!(split_record(r#"a"b"#).is_err());
        assert!(split_record(r#""a"b"#).is_err());
    }

    #[test]
    fn reader_tracks_lines_across_blank_and_multiline_records() {
        let text = "h1,h2\r\n\r\n1,\"x\ny\"\n2,z\n";
        let path = Path::new("mem.csv");
        let mut r = RecordReader::new(text.as_bytes(), path);
        assert_eq!(r.next_record().expect("ok").map(|(l, _)| l), Some(1));
        let (line, fields) = r.next_record().expect("ok").expect("record");
        assert_eq!((line, fields), (3, vec!["1".to_owned(), "x\ny".to_owned()]));
        assert_eq!(r.next_record().expect("ok").map(|(l, _)| l), Some(5));
        assert!(r.next_record().expect("ok").is_none());
    }

    #[test]
    fn write_quotes_when_needed() {
        let mut out = Vec::new();
        write_record(&mut out, ["a", "b,c", "d\"e"]).expect("write");
        assert_eq!(String::from_utf8(out).expect("utf8"), "a,\"b,c\",\"d\"\"e\"\n");
    }
}
