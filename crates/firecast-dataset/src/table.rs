//! The on-disk form of a window table: two Parquet files.
//!
//! - `samples.parquet`: one row per sample (place, instant, date, tier, label, GRIDMET cell,
//!   in a finished dataset its split, and for synthetic sources built with their truth the
//!   generator's `true_ignition_probability`, which is not a feature);
//! - `days.parquet`: one row per (sample, day) — the long table, with the row's `wildfire`
//!   label in the published CSV's sense and one column per weather variable.
//!
//! Two tables rather than one because the per-sample attributes would otherwise repeat on
//! every day row (75× for the paper framing); the long table stays the exact shape of the
//! Kaggle CSV, and a join on `sample_id` rebuilds it (`firecast query` does so in SQL).
//! Missing weather is a Parquet null, never a sentinel.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::Path;
use std::sync::Arc;

use arrow::array::{
    Array, ArrayRef, BooleanArray, Date32Array, Float32Array, Float64Array, Int32Array, StringArray,
    TimestampMillisecondArray, UInt32Array, UInt64Array,
};
use arrow::datatypes::{DataType, Field, Schema, TimeUnit};
use arrow::record_batch::RecordBatch;
use parquet::arrow::ArrowWriter;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;

use crate::time;
use crate::truth::TRUE_PROBABILITY_COLUMN;
use crate::windows::{WindowSample, WindowTable};
use crate::{DatasetError, Tier};

/// Version of the two-table layout; bump on any column change that a reader of the previous
/// version would misread. The optional trailing `true_ignition_probability` column of
/// `samples.parquet` did not bump it: it is written only when some sample has a value (so
/// every other file is byte-identical to before), columns are read by name (so a reader that
/// predates it skips it), and a file without it reads back as `None`.
pub const SCHEMA_VERSION: &str = "1";
pub const SAMPLES_FILE: &str = "samples.parquet";
pub const DAYS_FILE: &str = "days.parquet";

/// Metadata key of the layout version.
pub const META_SCHEMA_VERSION: &str = "firecast.schema_version";

fn pq_err(path: &Path) -> impl Fn(String) -> DatasetError + '_ {
    move |message| DatasetError::Parquet {
        path: path.to_path_buf(),
        message,
    }
}

fn samples_schema(with_split: bool, with_truth: bool) -> Schema {
    let mut fields = vec![
        Field::new("sample_id", DataType::UInt32, false),
        Field::new("latitude", DataType::Float64, false),
        Field::new("longitude", DataType::Float64, false),
        Field::new(
            "event_time",
            DataType::Timestamp(TimeUnit::Millisecond, Some("UTC".into())),
            false,
        ),
        Field::new("event_date", DataType::Date32, false),
        Field::new("tier", DataType::Utf8, false),
        Field::new("label", DataType::Boolean, false),
        Field::new("source_row", DataType::UInt64, true),
        Field::new("cell_row", DataType::UInt32, false),
        Field::new("cell_col", DataType::UInt32, false),
        Field::new("cell_latitude", DataType::Float64, false),
        Field::new("cell_longitude", DataType::Float64, false),
    ];
    if with_split {
        fields.push(Field::new("split", DataType::Utf8, false));
    }
    if with_truth {
        fields.push(Field::new(TRUE_PROBABILITY_COLUMN, DataType::Float32, true));
    }
    Schema::new(fields)
}

fn days_schema(features: &[String]) -> Schema {
    let mut fields = vec![
        Field::new("sample_id", DataType::UInt32, false),
        Field::new("day_index", DataType::Int32, false),
        Field::new("day_offset", DataType::Int32, false),
        Field::new("date", DataType::Date32, false),
        Field::new("wildfire", DataType::Boolean, false),
    ];
    for f in features {
        fields.push(Field::new(f, DataType::Float32, true));
    }
    Schema::new(fields)
}

fn properties(kv: &BTreeMap<String, String>) -> WriterProperties {
    let mut meta = vec![KeyValue::new(
        META_SCHEMA_VERSION.to_string(),
        SCHEMA_VERSION.to_string(),
    )];
    meta.extend(kv.iter().map(|(k, v)| KeyValue::new(k.clone(), v.clone())));
    WriterProperties::builder()
        .set_compression(Compression::ZSTD(ZstdLevel::try_new(3).unwrap_or_default()))
        .set_key_value_metadata(Some(meta))
        .set_created_by(format!("firecast {}", env!("CARGO_PKG_VERSION")))
        .build()
}

/// The `wildfire` label of day slot `d` of sample `s`: from the source when it has row
/// labels, else the published layout (positive windows are `Yes` from the event day on).
pub fn row_label(table: &WindowTable, s: usize, d: usize) -> bool {
    match &table.row_labels {
        Some(labels) => labels[s * table.n_days + d],
        None => table.layout_label(s, d),
    }
}

/// Writes `samples.parquet` and `days.parquet` into `dir` (each through a temporary name).
/// Returns the number of day rows.
pub fn write_window_table(
    dir: &Path,
    table: &WindowTable,
    splits: Option<&[&str]>,
    kv: &BTreeMap<String, String>,
) -> Result<u64, DatasetError> {
    std::fs::create_dir_all(dir).map_err(DatasetError::io("creating", dir))?;
    let props = properties(kv);

    let path = dir.join(SAMPLES_FILE);
    let s = &table.samples;
    let with_truth = has_true_probability(table);
    let schema = Arc::new(samples_schema(splits.is_some(), with_truth));
    let mut columns: Vec<ArrayRef> = vec![
        Arc::new(UInt32Array::from_iter_values(s.iter().map(|x| x.sample_id))),
        Arc::new(Float64Array::from_iter_values(s.iter().map(|x| x.lat))),
        Arc::new(Float64Array::from_iter_values(s.iter().map(|x| x.lon))),
        Arc::new(
            TimestampMillisecondArray::from_iter_values(s.iter().map(|x| x.time_ms)).with_timezone("UTC"),
        ),
        Arc::new(Date32Array::from_iter_values(
            s.iter().map(|x| time::date32(x.event_day)),
        )),
        Arc::new(StringArray::from_iter_values(s.iter().map(|x| x.tier.as_str()))),
        Arc::new(BooleanArray::from(
            s.iter().map(|x| x.label()).collect::<Vec<_>>(),
        )),
        Arc::new(UInt64Array::from(
            s.iter().map(|x| x.source_row).collect::<Vec<_>>(),
        )),
        Arc::new(UInt32Array::from_iter_values(s.iter().map(|x| x.cell.0))),
        Arc::new(UInt32Array::from_iter_values(s.iter().map(|x| x.cell.1))),
        Arc::new(Float64Array::from_iter_values(s.iter().map(|x| x.cell_lat))),
        Arc::new(Float64Array::from_iter_values(s.iter().map(|x| x.cell_lon))),
    ];
    if let Some(splits) = splits {
        columns.push(Arc::new(StringArray::from_iter_values(splits.iter().copied())));
    }
    if with_truth {
        columns.push(Arc::new(Float32Array::from(
            s.iter().map(|x| x.true_probability).collect::<Vec<_>>(),
        )));
    }
    let batch = RecordBatch::try_new(schema.clone(), columns).map_err(|e| pq_err(&path)(e.to_string()))?;
    write_batches(&path, schema, &props, std::iter::once(Ok(batch)))?;

    let path = dir.join(DAYS_FILE);
    let schema = Arc::new(days_schema(&table.features));
    let nf = table.n_features();
    let per_batch = (65_536 / table.n_days.max(1)).max(1);
    let n = table.samples.len();
    let schema_b = schema.clone();
    let batches = (0..n.div_ceil(per_batch)).map(move |b| {
        let range = b * per_batch..((b + 1) * per_batch).min(n);
        let rows = range.len() * table.n_days;
        let mut sid = Vec::with_capacity(rows);
        let mut day_index = Vec::with_capacity(rows);
        let mut day_offset = Vec::with_capacity(rows);
        let mut date = Vec::with_capacity(rows);
        let mut wildfire = Vec::with_capacity(rows);
        let mut feats: Vec<Vec<Option<f32>>> = vec![Vec::with_capacity(rows); nf];
        for si in range {
            let sample = &table.samples[si];
            for d in 0..table.n_days {
                sid.push(sample.sample_id);
                day_index.push(d as i32);
                let off = table.offset(d);
                day_offset.push(off);
                date.push(time::date32(sample.event_day + off));
                wildfire.push(row_label(table, si, d));
                for (f, v) in table.row(si, d).iter().enumerate() {
                    feats[f].push((!v.is_nan()).then_some(*v));
                }
            }
        }
        let mut columns: Vec<ArrayRef> = vec![
            Arc::new(UInt32Array::from(sid)),
            Arc::new(Int32Array::from(day_index)),
            Arc::new(Int32Array::from(day_offset)),
            Arc::new(Date32Array::from(date)),
            Arc::new(BooleanArray::from(wildfire)),
        ];
        columns.extend(
            feats
                .into_iter()
                .map(|f| Arc::new(Float32Array::from(f)) as ArrayRef),
        );
        RecordBatch::try_new(schema_b.clone(), columns).map_err(|e| e.to_string())
    });
    write_batches(&path, schema, &props, batches)?;
    Ok((n * table.n_days) as u64)
}

fn write_batches(
    path: &Path,
    schema: Arc<Schema>,
    props: &WriterProperties,
    batches: impl Iterator<Item = Result<RecordBatch, String>>,
) -> Result<(), DatasetError> {
    let staged = firecast_fs::TempPath::new(path)?;
    let tmp = staged.path();
    let err = pq_err(path);
    let file = File::create(tmp).map_err(DatasetError::io("creating", tmp))?;
    let mut writer =
        ArrowWriter::try_new(file, schema, Some(props.clone())).map_err(|e| err(e.to_string()))?;
    for batch in batches {
        writer
            .write(&batch.map_err(&err)?)
            .map_err(|e| err(e.to_string()))?;
    }
    writer.close().map_err(|e| err(e.to_string()))?;
    staged
        .publish()
        .map_err(|e| DatasetError::io("renaming into place", path)(e.source))
}

/// A table read back, with its split column and key-value metadata.
pub struct StoredTable {
    pub table: WindowTable,
    pub splits: Option<Vec<String>>,
    pub metadata: BTreeMap<String, String>,
}

fn column<'a, T: 'static>(batch: &'a RecordBatch, name: &str, path: &Path) -> Result<&'a T, DatasetError> {
    batch
        .column_by_name(name)
        .and_then(|c| c.as_any().downcast_ref::<T>())
        .ok_or_else(|| DatasetError::Parquet {
            path: path.to_path_buf(),
            message: format!("column `{name}` is missing or has the wrong type"),
        })
}

/// A Parquet file read whole: its batches, key-value metadata and column names.
type ParquetContents = (Vec<RecordBatch>, BTreeMap<String, String>, Vec<String>);

fn read_batches(path: &Path) -> Result<ParquetContents, DatasetError> {
    let err = pq_err(path);
    let file = File::open(path).map_err(DatasetError::io("opening", path))?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| err(e.to_string()))?;
    let metadata: BTreeMap<String, String> = builder
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .map(|kv| {
            kv.iter()
                .filter_map(|k| k.value.as_ref().map(|v| (k.key.clone(), v.clone())))
                .collect()
        })
        .unwrap_or_default();
    let names = builder
        .schema()
        .fields()
        .iter()
        .map(|f| f.name().clone())
        .collect();
    let reader = builder.build().map_err(|e| err(e.to_string()))?;
    let batches = reader
        .map(|b| b.map_err(|e| err(e.to_string())).and_then(|b| normalise(b, path)))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((batches, metadata, names))
}

/// Other writers' spellings of our column types, made ours: pandas 3 and pyarrow write
/// strings as `large_string` (or string views) and may keep timestamps in ns or us.
fn normalise(batch: RecordBatch, path: &Path) -> Result<RecordBatch, DatasetError> {
    let wanted = |dt: &DataType| match dt {
        DataType::LargeUtf8 | DataType::Utf8View => Some(DataType::Utf8),
        DataType::Timestamp(unit, tz) if *unit != TimeUnit::Millisecond => {
            Some(DataType::Timestamp(TimeUnit::Millisecond, tz.clone()))
        }
        _ => None,
    };
    if !batch
        .schema()
        .fields()
        .iter()
        .any(|f| wanted(f.data_type()).is_some())
    {
        return Ok(batch);
    }
    let schema = batch.schema();
    let mut fields = Vec::with_capacity(schema.fields().len());
    let mut columns = Vec::with_capacity(schema.fields().len());
    for (field, column) in schema.fields().iter().zip(batch.columns()) {
        match wanted(field.data_type()) {
            Some(to) => {
                let cast = arrow::compute::cast(column, &to).map_err(|e| DatasetError::Parquet {
                    path: path.to_path_buf(),
                    message: format!(
                        "column `{}`: cannot read {} as {to}: {e}",
                        field.name(),
                        field.data_type()
                    ),
                })?;
                fields.push(Field::new(field.name(), to, field.is_nullable()));
                columns.push(cast);
            }
            None => {
                fields.push(field.as_ref().clone());
                columns.push(column.clone());
            }
        }
    }
    RecordBatch::try_new(Arc::new(Schema::new(fields)), columns).map_err(|e| pq_err(path)(e.to_string()))
}

/// `source_row` as written by us (nullable u64), or by pandas, which stores a nullable
/// integer column as float64 with NaN for the missing rows.
fn source_rows(batch: &RecordBatch, path: &Path) -> Result<Vec<Option<u64>>, DatasetError> {
    let bad = |message: String| DatasetError::Parquet {
        path: path.to_path_buf(),
        message: format!("column `source_row`: {message}"),
    };
    let column = batch
        .column_by_name("source_row")
        .ok_or_else(|| bad("missing".into()))?;
    if let Some(a) = column.as_any().downcast_ref::<UInt64Array>() {
        return Ok((0..a.len())
            .map(|k| (!a.is_null(k)).then(|| a.value(k)))
            .collect());
    }
    if let Some(a) = column.as_any().downcast_ref::<Float64Array>() {
        return (0..a.len())
            .map(|k| {
                let v = a.value(k);
                if a.is_null(k) || v.is_nan() {
                    Ok(None)
                } else if v >= 0.0 && v.fract() == 0.0 && v < 2f64.powi(53) {
                    Ok(Some(v as u64))
                } else {
                    Err(bad(format!("row {k}: {v} is not a row number")))
                }
            })
            .collect();
    }
    if let Some(a) = column.as_any().downcast_ref::<arrow::array::Int64Array>() {
        return (0..a.len())
            .map(|k| {
                if a.is_null(k) {
                    return Ok(None);
                }
                u64::try_from(a.value(k))
                    .map(Some)
                    .map_err(|_| bad(format!("row {k}: {} is not a row number", a.value(k))))
            })
            .collect();
    }
    Err(bad(format!("type {} (expected uint64)", column.data_type())))
}

/// The columns of a Parquet file as Arrow sees them (names, types, nullability), from its
/// footer only.
pub fn parquet_schema(path: &Path) -> Result<arrow::datatypes::SchemaRef, DatasetError> {
    let file = File::open(path).map_err(DatasetError::io("opening", path))?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| pq_err(path)(e.to_string()))?;
    Ok(builder.schema().clone())
}

/// Reads a window table from its two files, wherever they are and whatever their names
/// (a published folder holds one pair per split). No manifest check: the caller checks the
/// files against the hashes it holds.
pub fn read_window_files(samples_path: &Path, days_path: &Path) -> Result<StoredTable, DatasetError> {
    let path = samples_path.to_path_buf();
    let (batches, metadata, names) = read_batches(&path)?;
    match metadata.get(META_SCHEMA_VERSION) {
        Some(v) if v == SCHEMA_VERSION => {}
        other => {
            return Err(DatasetError::Parquet {
                path,
                message: format!("schema version {other:?}, this FireCast reads {SCHEMA_VERSION}"),
            });
        }
    }
    let has_split = names.iter().any(|n| n == "split");
    let has_truth = names.iter().any(|n| n == TRUE_PROBABILITY_COLUMN);
    let mut samples = Vec::new();
    let mut splits = has_split.then(Vec::new);
    for b in &batches {
        let id = column::<UInt32Array>(b, "sample_id", &path)?;
        let lat = column::<Float64Array>(b, "latitude", &path)?;
        let lon = column::<Float64Array>(b, "longitude", &path)?;
        let t = column::<TimestampMillisecondArray>(b, "event_time", &path)?;
        let date = column::<Date32Array>(b, "event_date", &path)?;
        let tier = column::<StringArray>(b, "tier", &path)?;
        let src = column::<UInt64Array>(b, "source_row", &path)?;
        let cr = column::<UInt32Array>(b, "cell_row", &path)?;
        let cc = column::<UInt32Array>(b, "cell_col", &path)?;
        let clat = column::<Float64Array>(b, "cell_latitude", &path)?;
        let clon = column::<Float64Array>(b, "cell_longitude", &path)?;
        let truth = if has_truth {
            Some(column::<Float32Array>(b, TRUE_PROBABILITY_COLUMN, &path)?)
        } else {
            None
        };
        for k in 0..b.num_rows() {
            let tier = Tier::parse(tier.value(k)).ok_or_else(|| DatasetError::Parquet {
                path: path.clone(),
                message: format!("unknown tier `{}` in row {k}", tier.value(k)),
            })?;
            samples.push(WindowSample {
                sample_id: id.value(k),
                lat: lat.value(k),
                lon: lon.value(k),
                time_ms: t.value(k),
                event_day: time::from_date32(date.value(k)),
                tier,
                source_row: (!src.is_null(k)).then(|| src.value(k)),
                cell: (cr.value(k), cc.value(k)),
                cell_lat: clat.value(k),
                cell_lon: clon.value(k),
                true_probability: truth.and_then(|c| (!c.is_null(k)).then(|| c.value(k))),
            });
        }
        if let Some(splits) = splits.as_mut() {
            let sp = column::<StringArray>(b, "split", &path)?;
            splits.extend((0..b.num_rows()).map(|k| sp.value(k).to_string()));
        }
    }

    let path = days_path.to_path_buf();
    let (batches, _, names) = read_batches(&path)?;
    let features: Vec<String> = names.into_iter().skip(5).collect();
    let mut values = Vec::new();
    let mut labels = Vec::new();
    let mut ids = Vec::new();
    let mut day_index = Vec::new();
    let mut first_offset = 0;
    for b in &batches {
        let sid = column::<UInt32Array>(b, "sample_id", &path)?;
        let di = column::<Int32Array>(b, "day_index", &path)?;
        let off = column::<Int32Array>(b, "day_offset", &path)?;
        let wf = column::<BooleanArray>(b, "wildfire", &path)?;
        let cols = features
            .iter()
            .map(|f| column::<Float32Array>(b, f, &path))
            .collect::<Result<Vec<_>, _>>()?;
        for k in 0..b.num_rows() {
            if ids.is_empty() {
                first_offset = off.value(k);
            }
            ids.push(sid.value(k));
            day_index.push(di.value(k));
            labels.push(wf.value(k));
            for c in &cols {
                values.push(if c.is_null(k) { f32::NAN } else { c.value(k) });
            }
        }
    }
    let rows = ids.len();
    let n_days = day_index.iter().max().map_or(0, |m| *m as usize + 1);
    let consistent = rows == samples.len() * n_days
        && ids
            .iter()
            .zip(&day_index)
            .enumerate()
            .all(|(r, (id, d))| *d as usize == r % n_days && samples[r / n_days].sample_id == *id);
    if !consistent {
        return Err(DatasetError::Parquet {
            path,
            message: format!(
                "{rows} day rows do not line up with the {} samples of {} \
                 (expected {n_days} rows per sample, in sample order)",
                samples.len(),
                samples_path.file_name().unwrap_or_default().to_string_lossy()
            ),
        });
    }
    let mut table = WindowTable {
        features,
        first_offset,
        n_days,
        samples,
        values,
        row_labels: Some(labels),
    };
    table.drop_derived_row_labels();
    Ok(StoredTable {
        table,
        splits,
        metadata,
    })
}

/// Schema of a sample list (ignitions, or ignitions plus negatives): no weather yet.
fn sample_list_schema() -> Schema {
    Schema::new(vec![
        Field::new("sample_id", DataType::UInt32, false),
        Field::new("latitude", DataType::Float64, false),
        Field::new("longitude", DataType::Float64, false),
        Field::new(
            "event_time",
            DataType::Timestamp(TimeUnit::Millisecond, Some("UTC".into())),
            false,
        ),
        Field::new("tier", DataType::Utf8, false),
        Field::new("source_row", DataType::UInt64, true),
    ])
}

/// Writes a sample list as one Parquet file (through a temporary name); sample ids are the
/// row numbers.
pub fn write_sample_list(
    path: &Path,
    samples: &[crate::sampling::Sample],
    kv: &BTreeMap<String, String>,
) -> Result<(), DatasetError> {
    let schema = Arc::new(sample_list_schema());
    let columns: Vec<ArrayRef> = vec![
        Arc::new(UInt32Array::from_iter_values(0..samples.len() as u32)),
        Arc::new(Float64Array::from_iter_values(samples.iter().map(|x| x.lat))),
        Arc::new(Float64Array::from_iter_values(samples.iter().map(|x| x.lon))),
        Arc::new(
            TimestampMillisecondArray::from_iter_values(samples.iter().map(|x| x.time_ms))
                .with_timezone("UTC"),
        ),
        Arc::new(StringArray::from_iter_values(
            samples.iter().map(|x| x.tier.as_str()),
        )),
        Arc::new(UInt64Array::from(
            samples.iter().map(|x| x.source_row).collect::<Vec<_>>(),
        )),
    ];
    let batch = RecordBatch::try_new(schema.clone(), columns).map_err(|e| pq_err(path)(e.to_string()))?;
    write_batches(path, schema, &properties(kv), std::iter::once(Ok(batch)))
}

/// Reads a sample list written by [`write_sample_list`].
pub fn read_sample_list(path: &Path) -> Result<Vec<crate::windows::SampleIn>, DatasetError> {
    let (batches, _, _) = read_batches(path)?;
    let mut out = Vec::new();
    for b in &batches {
        let id = column::<UInt32Array>(b, "sample_id", path)?;
        let lat = column::<Float64Array>(b, "latitude", path)?;
        let lon = column::<Float64Array>(b, "longitude", path)?;
        let t = column::<TimestampMillisecondArray>(b, "event_time", path)?;
        let tier = column::<StringArray>(b, "tier", path)?;
        let src = source_rows(b, path)?;
        for (k, source_row) in src.into_iter().enumerate() {
            out.push(crate::windows::SampleIn {
                sample_id: id.value(k),
                lat: lat.value(k),
                lon: lon.value(k),
                time_ms: t.value(k),
                tier: Tier::parse(tier.value(k)).ok_or_else(|| DatasetError::Parquet {
                    path: path.to_path_buf(),
                    message: format!("row {k}: unknown tier `{}`", tier.value(k)),
                })?,
                source_row,
            });
        }
    }
    Ok(out)
}

/// Whether `samples.parquet` of `table` gets the [`TRUE_PROBABILITY_COLUMN`] (some sample
/// has a value).
pub fn has_true_probability(table: &WindowTable) -> bool {
    table.samples.iter().any(|s| s.true_probability.is_some())
}

/// Column names of `samples.parquet` in a finished dataset without truth.
pub fn sample_columns() -> Vec<String> {
    sample_columns_with(false)
}

/// Column names of `samples.parquet` in a finished dataset, with or without the
/// [`TRUE_PROBABILITY_COLUMN`].
pub fn sample_columns_with(truth: bool) -> Vec<String> {
    samples_schema(true, truth)
        .fields()
        .iter()
        .map(|f| f.name().clone())
        .collect()
}
