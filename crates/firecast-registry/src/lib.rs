//! The run registry: one embedded DuckDB file (default `.firecast/registry.duckdb`)
//! holding runs, metrics, datasets, artifacts and lineage. It is rsync-able and needs no
//! server or account. Params are written once per run: nothing in this crate updates
//! them; a re-run is a new run whose `parent_run_id` names the earlier one.
//!
//! Also here: the `sql` stage kind (DuckDB over the stage's inputs) and
//! `query`, which exposes registered Parquet datasets as views.

mod sql_stage;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use duckdb::arrow::array::RecordBatch;
use duckdb::{Connection, params};
use firecast_pipeline::observer::{
    DatasetRecord, LineageRecord, ObserverError, PipelineRunInfo, RunObserver, RunStatus, StageRunInfo,
};
use serde::Serialize;

pub use sql_stage::SqlStage;

/// Bumped when the tables change; stored in `registry_meta`.
pub const SCHEMA_VERSION: i32 = 1;

const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS registry_meta (key VARCHAR PRIMARY KEY, value VARCHAR);
CREATE TABLE IF NOT EXISTS runs (
    run_id VARCHAR PRIMARY KEY,
    pipeline_run_id VARCHAR,
    parent_run_id VARCHAR,
    pipeline VARCHAR NOT NULL,
    stage VARCHAR,
    kind VARCHAR NOT NULL,
    kind_version INTEGER,
    params VARCHAR NOT NULL,
    status VARCHAR NOT NULL,
    started_at TIMESTAMP NOT NULL,
    ended_at TIMESTAMP,
    git_commit VARCHAR,
    cache_key VARCHAR,
    error VARCHAR
);
CREATE TABLE IF NOT EXISTS metrics (
    run_id VARCHAR NOT NULL,
    key VARCHAR NOT NULL,
    step BIGINT NOT NULL,
    value DOUBLE NOT NULL,
    time TIMESTAMP NOT NULL
);
CREATE TABLE IF NOT EXISTS datasets (
    name VARCHAR NOT NULL,
    version VARCHAR NOT NULL,
    schema_json VARCHAR NOT NULL,
    rows BIGINT NOT NULL,
    location VARCHAR NOT NULL,
    metadata VARCHAR NOT NULL,
    run_id VARCHAR,
    created_at TIMESTAMP NOT NULL,
    PRIMARY KEY (name, version)
);
CREATE TABLE IF NOT EXISTS artifacts (
    run_id VARCHAR NOT NULL,
    name VARCHAR NOT NULL,
    uri VARCHAR NOT NULL,
    hash VARCHAR NOT NULL,
    size BIGINT NOT NULL,
    created_at TIMESTAMP NOT NULL
);
CREATE TABLE IF NOT EXISTS lineage (
    run_id VARCHAR NOT NULL,
    direction VARCHAR NOT NULL,
    name VARCHAR NOT NULL,
    uri VARCHAR NOT NULL,
    hash VARCHAR NOT NULL,
    size BIGINT NOT NULL
);
";

/// Errors of the registry. The file path comes last.
#[derive(Debug, thiserror::Error)]
pub enum RegistryError {
    #[error("cannot open the run registry (is another firecast using it?): {path}: {source}")]
    Open {
        path: PathBuf,
        #[source]
        source: duckdb::Error,
    },
    #[error("registry schema version {found} is newer than this firecast ({SCHEMA_VERSION}): {path}")]
    SchemaTooNew { found: i32, path: PathBuf },
    #[error("registry query failed: {0}")]
    Query(#[from] duckdb::Error),
    #[error("no run `{0}` in the registry")]
    NoSuchRun(String),
    #[error("run id `{prefix}` is ambiguous: {matches}")]
    AmbiguousRun { prefix: String, matches: String },
    #[error("cannot create folder for the registry: {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// A run as listed.
#[derive(Debug, Clone, Serialize)]
pub struct RunRow {
    pub run_id: String,
    pub pipeline_run_id: Option<String>,
    pub parent_run_id: Option<String>,
    pub pipeline: String,
    pub stage: Option<String>,
    pub kind: String,
    pub kind_version: Option<i32>,
    pub params: serde_json::Value,
    pub status: String,
    pub started_at: String,
    pub ended_at: Option<String>,
    pub duration_secs: Option<f64>,
    pub git_commit: Option<String>,
    pub cache_key: Option<String>,
    pub error: Option<String>,
}

/// Summary of one metric key of a run: last, min, max and where.
#[derive(Debug, Clone, Serialize)]
pub struct MetricSummary {
    pub key: String,
    pub count: i64,
    pub last_step: i64,
    pub last: f64,
    pub min: f64,
    pub min_step: i64,
    pub max: f64,
    pub max_step: i64,
    /// Mean over steps: over seeds for an experiment's test metrics (logged at step = seed).
    pub mean: f64,
}

/// An artifact row.
#[derive(Debug, Clone, Serialize)]
pub struct ArtifactRow {
    pub run_id: String,
    pub name: String,
    pub uri: String,
    pub hash: String,
    pub size: i64,
}

/// A lineage row.
#[derive(Debug, Clone, Serialize)]
pub struct LineageRow {
    pub direction: String,
    pub name: String,
    pub uri: String,
    pub hash: String,
    pub size: i64,
}

/// A run with everything recorded about it.
#[derive(Debug, Clone, Serialize)]
pub struct RunDetails {
    pub run: RunRow,
    pub metrics: Vec<MetricSummary>,
    pub artifacts: Vec<ArtifactRow>,
    pub lineage: Vec<LineageRow>,
    /// Stage runs of a pipeline run.
    pub children: Vec<RunRow>,
}

/// Filters for `runs list`.
#[derive(Debug, Clone, Default)]
pub struct RunFilter {
    pub pipeline: Option<String>,
    pub stage: Option<String>,
    pub status: Option<String>,
    pub limit: Option<usize>,
}

/// A query result: column names and rows of JSON values.
#[derive(Debug, Clone, Serialize)]
pub struct QueryResult {
    pub columns: Vec<String>,
    pub rows: Vec<Vec<serde_json::Value>>,
}

/// The registry, one connection per process (DuckDB allows one writing process per file).
pub struct Registry {
    path: PathBuf,
    conn: Mutex<Held>,
}

/// The connection and the metric rows not yet written. Metrics come in bursts (thousands
/// per evaluation) and DuckDB commits each lone INSERT on its own (about 1 ms), so they are
/// appended in batches: before any other statement, every `METRIC_BATCH` rows or
/// `METRIC_FLUSH_AFTER`, and when the registry is dropped. No other process can read the
/// file meanwhile (DuckDB locks it), so nobody sees the delay.
struct Held {
    conn: Connection,
    pending: Vec<MetricRow>,
    last_flush: std::time::Instant,
}

struct MetricRow {
    run_id: String,
    key: String,
    step: i64,
    value: f64,
    time: String,
}

const METRIC_BATCH: usize = 4096;
const METRIC_FLUSH_AFTER: std::time::Duration = std::time::Duration::from_secs(2);

impl Held {
    fn flush(&mut self) -> Result<(), RegistryError> {
        self.last_flush = std::time::Instant::now();
        if self.pending.is_empty() {
            return Ok(());
        }
        let rows = std::mem::take(&mut self.pending);
        let mut appender = self.conn.appender("metrics")?;
        for r in &rows {
            // The appender casts the text to the column's TIMESTAMP as `?::TIMESTAMP` did.
            appender.append_row(params![r.run_id, r.key, r.step, r.value, r.time])?;
        }
        appender.flush()?;
        Ok(())
    }
}

impl Drop for Registry {
    fn drop(&mut self) {
        let held = self.conn.get_mut().unwrap_or_else(|e| e.into_inner());
        let rows = held.pending.len();
        if let Err(e) = held.flush() {
            eprintln!(
                "warning: {}: {rows} metric rows could not be written: {e}",
                self.path.display()
            );
        }
    }
}

impl std::fmt::Debug for Registry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Registry").field("path", &self.path).finish()
    }
}

/// The connection inside a held lock.
struct ConnGuard<'a>(std::sync::MutexGuard<'a, Held>);

impl std::ops::Deref for ConnGuard<'_> {
    type Target = Connection;
    fn deref(&self) -> &Connection {
        &self.0.conn
    }
}

fn ts(t: chrono::DateTime<chrono::Utc>) -> String {
    t.format("%Y-%m-%d %H:%M:%S%.6f").to_string()
}

impl Registry {
    /// Open (creating if needed) the registry file.
    pub fn open(path: &Path) -> Result<Self, RegistryError> {
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent).map_err(|source| RegistryError::Io {
                path: parent.to_path_buf(),
                source,
            })?;
        }
        let conn = Connection::open(path).map_err(|source| RegistryError::Open {
            path: path.to_path_buf(),
            source,
        })?;
        conn.execute_batch(SCHEMA)?;
        let found: Option<String> = conn
            .query_row(
                "SELECT value FROM registry_meta WHERE key = 'schema_version'",
                [],
                |r| r.get(0),
            )
            .ok();
        match found.and_then(|v| v.parse::<i32>().ok()) {
            Some(v) if v > SCHEMA_VERSION => {
                return Err(RegistryError::SchemaTooNew {
                    found: v,
                    path: path.to_path_buf(),
                });
            }
            Some(_) => {}
            None => {
                conn.execute(
                    "INSERT INTO registry_meta VALUES ('schema_version', ?)",
                    params![SCHEMA_VERSION.to_string()],
                )?;
            }
        }
        Ok(Self {
            path: path.to_path_buf(),
            conn: Mutex::new(Held {
                conn,
                pending: Vec::new(),
                last_flush: std::time::Instant::now(),
            }),
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The connection, with every pending metric written first (so reads see them).
    fn conn(&self) -> Result<ConnGuard<'_>, RegistryError> {
        let mut held = self.conn.lock().unwrap_or_else(|e| e.into_inner());
        held.flush()?;
        Ok(ConnGuard(held))
    }

    /// Write the pending metric rows now.
    pub fn flush(&self) -> Result<(), RegistryError> {
        self.conn().map(drop)
    }

    /// Insert a run. Params are stored here once and never updated.
    #[allow(clippy::too_many_arguments)]
    pub fn insert_run(
        &self,
        run_id: &str,
        pipeline_run_id: Option<&str>,
        parent_run_id: Option<&str>,
        pipeline: &str,
        stage: Option<&str>,
        kind: &str,
        kind_version: Option<u32>,
        params: &serde_json::Value,
        git_commit: Option<&str>,
        cache_key: Option<&str>,
        started_at: chrono::DateTime<chrono::Utc>,
    ) -> Result<(), RegistryError> {
        self.conn()?.execute(
            "INSERT INTO runs (run_id, pipeline_run_id, parent_run_id, pipeline, stage, kind, kind_version,
                               params, status, started_at, git_commit, cache_key)
             VALUES (?, ?, ?, ?, ?, ?, ?, ?, 'running', ?::TIMESTAMP, ?, ?)",
            params![
                run_id,
                pipeline_run_id,
                parent_run_id,
                pipeline,
                stage,
                kind,
                kind_version,
                params.to_string(),
                ts(started_at),
                git_commit,
                cache_key
            ],
        )?;
        Ok(())
    }

    /// Record how a run ended (status, end time, error). Params are left untouched.
    pub fn finish_run(
        &self,
        run_id: &str,
        status: RunStatus,
        ended_at: chrono::DateTime<chrono::Utc>,
        error: Option<&str>,
    ) -> Result<(), RegistryError> {
        self.conn()?.execute(
            "UPDATE runs SET status = ?, ended_at = ?::TIMESTAMP, error = ? WHERE run_id = ?",
            params![status.as_str(), ts(ended_at), error, run_id],
        )?;
        Ok(())
    }

    pub fn log_metric(&self, run_id: &str, key: &str, step: i64, value: f64) -> Result<(), RegistryError> {
        let mut held = self.conn.lock().unwrap_or_else(|e| e.into_inner());
        held.pending.push(MetricRow {
            run_id: run_id.to_string(),
            key: key.to_string(),
            step,
            value,
            time: ts(chrono::Utc::now()),
        });
        if held.pending.len() >= METRIC_BATCH || held.last_flush.elapsed() >= METRIC_FLUSH_AFTER {
            held.flush()?;
        }
        Ok(())
    }

    pub fn log_artifact(
        &self,
        run_id: &str,
        name: &str,
        uri: &str,
        hash: &str,
        size: u64,
    ) -> Result<(), RegistryError> {
        self.conn()?.execute(
            "INSERT INTO artifacts VALUES (?, ?, ?, ?, ?, ?::TIMESTAMP)",
            params![run_id, name, uri, hash, size as i64, ts(chrono::Utc::now())],
        )?;
        Ok(())
    }

    /// Register a dataset version; registering the same (name, version) again is a no-op.
    pub fn register_dataset(&self, run_id: Option<&str>, d: &DatasetRecord) -> Result<(), RegistryError> {
        let metadata = serde_json::to_string(&d.metadata).unwrap_or_default();
        self.conn()?.execute(
            "INSERT INTO datasets VALUES (?, ?, ?, ?, ?, ?, ?, ?::TIMESTAMP) ON CONFLICT DO NOTHING",
            params![
                d.name,
                d.version,
                d.schema_json,
                d.rows as i64,
                d.location,
                metadata,
                run_id,
                ts(chrono::Utc::now())
            ],
        )?;
        Ok(())
    }

    pub fn log_lineage(&self, run_id: &str, r: &LineageRecord) -> Result<(), RegistryError> {
        self.conn()?.execute(
            "INSERT INTO lineage VALUES (?, ?, ?, ?, ?, ?)",
            params![run_id, r.direction, r.name, r.uri, r.hash, r.size as i64],
        )?;
        Ok(())
    }

    /// Runs, newest first.
    pub fn list_runs(&self, filter: &RunFilter) -> Result<Vec<RunRow>, RegistryError> {
        let mut sql = String::from(RUN_SELECT);
        let mut clauses = Vec::new();
        let mut args: Vec<String> = Vec::new();
        if let Some(p) = &filter.pipeline {
            clauses.push("pipeline = ?");
            args.push(p.clone());
        }
        if let Some(s) = &filter.stage {
            clauses.push("(stage = ? OR split_part(stage, '@', 1) = ?)");
            args.push(s.clone());
            args.push(s.clone());
        }
        if let Some(s) = &filter.status {
            clauses.push("status = ?");
            args.push(s.clone());
        }
        if !clauses.is_empty() {
            sql.push_str(" WHERE ");
            sql.push_str(&clauses.join(" AND "));
        }
        sql.push_str(" ORDER BY started_at DESC, run_id DESC");
        if let Some(limit) = filter.limit {
            sql.push_str(&format!(" LIMIT {limit}"));
        }
        let conn = self.conn()?;
        let mut stmt = conn.prepare(&sql)?;
        let rows = stmt.query_map(duckdb::params_from_iter(args.iter()), run_row)?;
        Ok(rows.collect::<Result<_, _>>()?)
    }

    /// Resolve a run id or a unique prefix of one.
    pub fn resolve_run_id(&self, prefix: &str) -> Result<String, RegistryError> {
        let conn = self.conn()?;
        let mut stmt =
            conn.prepare("SELECT run_id FROM runs WHERE starts_with(run_id, ?) ORDER BY run_id LIMIT 6")?;
        let ids: Vec<String> = stmt
            .query_map(params![prefix], |r| r.get(0))?
            .collect::<Result<_, _>>()?;
        match ids.as_slice() {
            [] => Err(RegistryError::NoSuchRun(prefix.to_string())),
            [one] => Ok(one.clone()),
            many => {
                if let Some(exact) = many.iter().find(|id| id.as_str() == prefix) {
                    return Ok(exact.clone());
                }
                Err(RegistryError::AmbiguousRun {
                    prefix: prefix.to_string(),
                    matches: many.join(", "),
                })
            }
        }
    }

    /// Everything about one run.
    pub fn run_details(&self, id_or_prefix: &str) -> Result<RunDetails, RegistryError> {
        let run_id = self.resolve_run_id(id_or_prefix)?;
        let conn = self.conn()?;
        let run = conn.query_row(
            &format!("{RUN_SELECT} WHERE run_id = ?"),
            params![run_id],
            run_row,
        )?;
        let mut stmt = conn.prepare(
            "SELECT key, count(*), arg_max(step, step), arg_max(value, step), min(value), arg_min(step, value),
                    max(value), arg_max(step, value), avg(value)
             FROM metrics WHERE run_id = ? GROUP BY key ORDER BY key",
        )?;
        let metrics = stmt
            .query_map(params![run_id], |r| {
                Ok(MetricSummary {
                    key: r.get(0)?,
                    count: r.get(1)?,
                    last_step: r.get(2)?,
                    last: r.get(3)?,
                    min: r.get(4)?,
                    min_step: r.get(5)?,
                    max: r.get(6)?,
                    max_step: r.get(7)?,
                    mean: r.get(8)?,
                })
            })?
            .collect::<Result<_, _>>()?;
        let mut stmt = conn.prepare(
            "SELECT run_id, name, uri, hash, size FROM artifacts WHERE run_id = ? ORDER BY name, uri",
        )?;
        let artifacts = stmt
            .query_map(params![run_id], artifact_row)?
            .collect::<Result<_, _>>()?;
        let mut stmt = conn.prepare(
            "SELECT direction, name, uri, hash, size FROM lineage WHERE run_id = ? ORDER BY direction, name, uri",
        )?;
        let lineage = stmt
            .query_map(params![run_id], |r| {
                Ok(LineageRow {
                    direction: r.get(0)?,
                    name: r.get(1)?,
                    uri: r.get(2)?,
                    hash: r.get(3)?,
                    size: r.get(4)?,
                })
            })?
            .collect::<Result<_, _>>()?;
        let mut stmt = conn.prepare(&format!(
            "{RUN_SELECT} WHERE pipeline_run_id = ? ORDER BY started_at, run_id"
        ))?;
        let children = stmt
            .query_map(params![run_id], run_row)?
            .collect::<Result<_, _>>()?;
        Ok(RunDetails {
            run,
            metrics,
            artifacts,
            lineage,
            children,
        })
    }

    /// Artifacts, newest first, optionally of one run.
    pub fn list_artifacts(&self, run: Option<&str>) -> Result<Vec<ArtifactRow>, RegistryError> {
        let conn = self.conn()?;
        let (sql, args): (&str, Vec<String>) = match run {
            Some(r) => (
                "SELECT run_id, name, uri, hash, size FROM artifacts WHERE run_id = ? ORDER BY created_at DESC, uri",
                vec![r.to_string()],
            ),
            None => (
                "SELECT run_id, name, uri, hash, size FROM artifacts ORDER BY created_at DESC, uri",
                Vec::new(),
            ),
        };
        let mut stmt = conn.prepare(sql)?;
        let rows = stmt.query_map(duckdb::params_from_iter(args.iter()), artifact_row)?;
        Ok(rows.collect::<Result<_, _>>()?)
    }

    /// Run SQL over the registry tables, with each registered dataset (latest version)
    /// available as a view named after it.
    pub fn query(&self, sql: &str) -> Result<QueryResult, RegistryError> {
        let conn = self.conn()?;
        let mut stmt = conn.prepare(
            "SELECT name, location FROM datasets QUALIFY row_number() OVER (PARTITION BY name ORDER BY created_at DESC) = 1",
        )?;
        let datasets: Vec<(String, String)> = stmt
            .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))?
            .collect::<Result<_, _>>()?;
        for (name, location) in datasets {
            let source = if Path::new(&location).is_dir() {
                format!("{}/**/*.parquet", location.trim_end_matches('/'))
            } else {
                location
            };
            if !Path::new(&source).exists() && !source.contains('*') {
                continue;
            }
            let view = name.replace('"', "\"\"");
            conn.execute_batch(&format!(
                "CREATE OR REPLACE TEMP VIEW \"{view}\" AS SELECT * FROM read_parquet('{}')",
                source.replace('\'', "''")
            ))?;
        }
        let mut stmt = conn.prepare(sql)?;
        let batches: Vec<RecordBatch> = stmt.query_arrow([])?.collect();
        let columns = stmt.column_names();
        let mut rows = Vec::new();
        for batch in &batches {
            for row in 0..batch.num_rows() {
                rows.push(
                    batch
                        .columns()
                        .iter()
                        .map(|col| cell_to_json(col.as_ref(), row))
                        .collect(),
                );
            }
        }
        Ok(QueryResult { columns, rows })
    }
}

/// Convert one Arrow cell to JSON, keeping numbers numeric.
fn cell_to_json(array: &dyn duckdb::arrow::array::Array, row: usize) -> serde_json::Value {
    use duckdb::arrow::array::{
        BooleanArray, Float32Array, Float64Array, Int8Array, Int16Array, Int32Array, Int64Array, UInt8Array,
        UInt16Array, UInt32Array, UInt64Array,
    };
    use duckdb::arrow::datatypes::DataType;
    if array.is_null(row) {
        return serde_json::Value::Null;
    }
    macro_rules! num {
        ($t:ty) => {
            array
                .as_any()
                .downcast_ref::<$t>()
                .map(|a| serde_json::json!(a.value(row)))
        };
    }
    let value = match array.data_type() {
        DataType::Boolean => array
            .as_any()
            .downcast_ref::<BooleanArray>()
            .map(|a| serde_json::Value::Bool(a.value(row))),
        DataType::Int8 => num!(Int8Array),
        DataType::Int16 => num!(Int16Array),
        DataType::Int32 => num!(Int32Array),
        DataType::Int64 => num!(Int64Array),
        DataType::UInt8 => num!(UInt8Array),
        DataType::UInt16 => num!(UInt16Array),
        DataType::UInt32 => num!(UInt32Array),
        DataType::UInt64 => num!(UInt64Array),
        DataType::Float32 => num!(Float32Array),
        DataType::Float64 => num!(Float64Array),
        _ => None,
    };
    value.unwrap_or_else(|| {
        let options = duckdb::arrow::util::display::FormatOptions::default();
        duckdb::arrow::util::display::ArrayFormatter::try_new(array, &options)
            .map(|f| serde_json::Value::String(f.value(row).to_string()))
            .unwrap_or(serde_json::Value::Null)
    })
}

const RUN_SELECT: &str =
    "SELECT run_id, pipeline_run_id, parent_run_id, pipeline, stage, kind, kind_version, params,
    status, strftime(started_at, '%Y-%m-%d %H:%M:%S'), strftime(ended_at, '%Y-%m-%d %H:%M:%S'),
    epoch(ended_at) - epoch(started_at), git_commit, cache_key, error FROM runs";

fn artifact_row(r: &duckdb::Row<'_>) -> duckdb::Result<ArtifactRow> {
    Ok(ArtifactRow {
        run_id: r.get(0)?,
        name: r.get(1)?,
        uri: r.get(2)?,
        hash: r.get(3)?,
        size: r.get(4)?,
    })
}

fn run_row(r: &duckdb::Row<'_>) -> duckdb::Result<RunRow> {
    let params: String = r.get(7)?;
    Ok(RunRow {
        run_id: r.get(0)?,
        pipeline_run_id: r.get(1)?,
        parent_run_id: r.get(2)?,
        pipeline: r.get(3)?,
        stage: r.get(4)?,
        kind: r.get(5)?,
        kind_version: r.get(6)?,
        params: serde_json::from_str(&params).unwrap_or(serde_json::Value::String(params)),
        status: r.get(8)?,
        started_at: r.get(9)?,
        ended_at: r.get(10)?,
        duration_secs: r.get(11)?,
        git_commit: r.get(12)?,
        cache_key: r.get(13)?,
        error: r.get(14)?,
    })
}

impl RunObserver for Registry {
    fn pipeline_started(&self, run: &PipelineRunInfo) -> Result<(), ObserverError> {
        self.insert_run(
            &run.run_id,
            None,
            None,
            &run.pipeline,
            None,
            "pipeline",
            None,
            &run.params,
            run.git_commit.as_deref(),
            None,
            run.started_at,
        )?;
        Ok(())
    }

    fn pipeline_finished(
        &self,
        run_id: &str,
        status: RunStatus,
        ended_at: chrono::DateTime<chrono::Utc>,
    ) -> Result<(), ObserverError> {
        self.finish_run(run_id, status, ended_at, None)?;
        Ok(())
    }

    fn stage_started(&self, run: &StageRunInfo) -> Result<(), ObserverError> {
        self.insert_run(
            &run.run_id,
            Some(&run.pipeline_run_id),
            run.parent_run_id.as_deref(),
            &run.pipeline,
            Some(&run.stage),
            &run.kind,
            Some(run.kind_version),
            &run.params,
            run.git_commit.as_deref(),
            Some(&run.cache_key),
            run.started_at,
        )?;
        Ok(())
    }

    fn stage_finished(
        &self,
        run_id: &str,
        status: RunStatus,
        ended_at: chrono::DateTime<chrono::Utc>,
        error: Option<&str>,
    ) -> Result<(), ObserverError> {
        self.finish_run(run_id, status, ended_at, error)?;
        Ok(())
    }

    fn metric(&self, run_id: &str, key: &str, step: i64, value: f64) -> Result<(), ObserverError> {
        self.log_metric(run_id, key, step, value)?;
        Ok(())
    }

    fn artifact(
        &self,
        run_id: &str,
        name: &str,
        uri: &str,
        hash: &str,
        size: u64,
    ) -> Result<(), ObserverError> {
        self.log_artifact(run_id, name, uri, hash, size)?;
        Ok(())
    }

    fn dataset(&self, run_id: &str, dataset: &DatasetRecord) -> Result<(), ObserverError> {
        self.register_dataset(Some(run_id), dataset)?;
        Ok(())
    }

    fn lineage(&self, run_id: &str, record: &LineageRecord) -> Result<(), ObserverError> {
        self.log_lineage(run_id, record)?;
        Ok(())
    }
}

/// Params of several runs side by side: the union of keys, flattened to dotted paths.
pub fn params_side_by_side(runs: &[RunRow]) -> BTreeMap<String, Vec<Option<String>>> {
    let flat: Vec<BTreeMap<String, String>> = runs
        .iter()
        .map(|r| {
            firecast_pipeline::plan::flatten_params(&r.params)
                .into_iter()
                .map(|(k, v)| match v {
                    serde_json::Value::String(s) => (k, s),
                    other => (k, other.to_string()),
                })
                .collect()
        })
        .collect();
    let mut table: BTreeMap<String, Vec<Option<String>>> = BTreeMap::new();
    for (i, f) in flat.iter().enumerate() {
        for (k, v) in f {
            table.entry(k.clone()).or_insert_with(|| vec![None; runs.len()])[i] = Some(v.clone());
        }
    }
    table
}

/// The version of the linked DuckDB library.
pub fn duckdb_version() -> Result<String, RegistryError> {
    let conn = Connection::open_in_memory()?;
    Ok(conn.query_row("SELECT version()", [], |r| r.get(0))?)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn run(registry: &Registry, id: &str) {
        registry
            .insert_run(
                id,
                None,
                None,
                "p",
                Some("s"),
                "cmd",
                Some(1),
                &serde_json::json!({}),
                None,
                None,
                chrono::Utc::now(),
            )
            .unwrap();
    }

    #[test]
    fn batched_metrics_are_all_written_and_seen_by_reads() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("registry.duckdb");
        let n = METRIC_BATCH * 2 + 17;
        {
            let registry = Registry::open(&path).unwrap();
            run(&registry, "r1");
            for step in 0..n as i64 {
                registry
                    .log_metric("r1", "loss", step, step as f64 * 0.5)
                    .unwrap();
            }
            // A read sees every row, including those not yet appended.
            let details = registry.run_details("r1").unwrap();
            let loss = details.metrics.iter().find(|m| m.key == "loss").unwrap();
            assert_eq!(loss.count as usize, n);
            registry.log_metric("r1", "last", 0, 1.0).unwrap();
            // Dropped with one pending row: written on drop.
        }
        let registry = Registry::open(&path).unwrap();
        let q = registry
            .query("SELECT count(*), sum(value), min(step), max(step), count(DISTINCT typeof(time)) FROM metrics")
            .unwrap();
        assert_eq!(
            q.rows[0],
            vec![
                serde_json::json!(n as i64 + 1),
                serde_json::json!((0..n).map(|s| s as f64 * 0.5).sum::<f64>() + 1.0),
                serde_json::json!(0),
                serde_json::json!(n as i64 - 1),
                serde_json::json!(1),
            ]
        );
    }
}
