//! The run registry: one embedded DuckDB file (default `.firecast/registry.duckdb`)
//! holding runs, metrics, datasets, artifacts and lineage. It is rsync-able and needs no
//! server or account. Params are written once per run: nothing in this crate updates
//! them; a re-run is a new run whose `parent_run_id` names the earlier one.
//!
//! Also here: the `sql` stage kind (DuckDB over the stage's inputs) and
//! `query`, which exposes registered Parquet datasets as views.

pub mod saved_models;
mod sql_stage;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use duckdb::arrow::array::RecordBatch;
use duckdb::types::Value;
use duckdb::{Connection, params};
use firecast_pipeline::observer::{
    DatasetRecord, LineageRecord, ObserverError, PipelineRunInfo, RunObserver, RunStatus, StageRunInfo,
};
use serde::Serialize;

pub use sql_stage::SqlStage;

/// Registers this crate's stage kind: `sql`.
pub fn register(kinds: &mut firecast_pipeline::StageKinds) {
    kinds.register(SqlStage);
}

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
CREATE TABLE IF NOT EXISTS run_owners (run_id VARCHAR PRIMARY KEY, owner VARCHAR NOT NULL);
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
    #[error("cannot open the run registry (is another firecast using it?){}: {path}: {source}", waited_note(.waited))]
    Open {
        path: PathBuf,
        /// How long the open waited for another process's lock before giving up; `None` when
        /// it failed for another reason (those are not retried).
        waited: Option<Duration>,
        #[source]
        source: duckdb::Error,
    },
    #[error("the run registry is open read-only, so it cannot {what}: {path}")]
    ReadOnly { what: &'static str, path: PathBuf },
    #[error("the run registry's path is not UTF-8 text: {}", .0.display())]
    NotUtf8(PathBuf),
    #[error("{WAIT_ENV} must be a whole number of milliseconds, not `{0}`")]
    BadWait(String),
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

fn waited_note(waited: &Option<Duration>) -> String {
    waited.map_or_else(String::new, |w| {
        format!(
            ", waited {:.1} s for its lock ({WAIT_ENV} sets how long)",
            w.as_secs_f64()
        )
    })
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

/// A registered dataset version.
#[derive(Debug, Clone, Serialize)]
pub struct DatasetRow {
    pub name: String,
    pub version: String,
    pub rows: i64,
    pub location: String,
    /// The schema as the writer recorded it (JSON text).
    pub schema_json: String,
    pub metadata: serde_json::Value,
    pub run_id: Option<String>,
    pub created_at: String,
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

/// How a registry opens its file for each operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// Reads and writes; creates the file (and its tables) on `Registry::open`.
    ReadWrite,
    /// Reads only (`firecast serve`): writes are refused, and several read-only processes can
    /// read at once. A missing file reads as an empty registry until a writer creates it.
    ReadOnly,
}

/// The environment variable that sets how long an open waits for another process's lock.
pub const WAIT_ENV: &str = "FIRECAST_REGISTRY_WAIT_MS";
/// How long an open waits for another process's lock unless `FIRECAST_REGISTRY_WAIT_MS` says.
pub const DEFAULT_LOCK_WAIT: Duration = Duration::from_secs(30);
/// Pauses between tries: short at first (operations hold the file for milliseconds), doubling
/// up to a cap so a long holder is not polled hard.
const FIRST_PAUSE: Duration = Duration::from_millis(5);
const MAX_PAUSE: Duration = Duration::from_millis(100);

/// The lock wait from `FIRECAST_REGISTRY_WAIT_MS` (milliseconds), or `DEFAULT_LOCK_WAIT`.
pub fn lock_wait_from_env() -> Result<Duration, RegistryError> {
    match std::env::var(WAIT_ENV) {
        Ok(text) => text
            .trim()
            .parse::<u64>()
            .map(Duration::from_millis)
            .map_err(|_| RegistryError::BadWait(text)),
        Err(std::env::VarError::NotPresent) => Ok(DEFAULT_LOCK_WAIT),
        Err(std::env::VarError::NotUnicode(text)) => {
            Err(RegistryError::BadWait(text.to_string_lossy().into_owned()))
        }
    }
}

/// Whether an open failed only because another process holds the file's lock (worth
/// retrying), as DuckDB words it: `Could not set lock on file "…": Conflicting lock is held
/// in … (PID n)`.
pub fn is_lock_conflict(message: &str) -> bool {
    message.contains("Conflicting lock") || message.contains("Could not set lock on file")
}

/// The process's one DuckDB instance, in memory, into which each operation attaches the
/// registry file (as `registry`) and from which it detaches it after. Creating an instance
/// registers DuckDB's whole catalog of functions (about 17 ms on a 2-core machine, against
/// 1 to 2 ms for an ATTACH and DETACH), and one instance used one operation at a time also
/// keeps two opens of a file in this process apart: DuckDB's file lock is a POSIX record
/// lock, which does not exclude the same process and which the first close releases for
/// both. `None` before the first operation, or after one whose detach failed (dropping the
/// instance is what closes the file then).
static INSTANCE: Mutex<Option<Connection>> = Mutex::new(None);

/// The name the registry file is attached under (and made the default catalog).
const ALIAS: &str = "registry";

/// The registry. It holds the DuckDB file only while one of its methods runs: DuckDB lets
/// one process at a time open a file read-write (or several read-only), so a process that
/// kept it open would shut out every other `firecast` (and `firecast serve`) on the project.
/// Each method opens (attaches) the file, runs its statements and closes (detaches) it; an
/// open that meets another process's lock is retried until the lock wait runs out.
pub struct Registry {
    file: RegistryFile,
    pending: Mutex<Pending>,
}

/// Where and how each operation opens the file.
struct RegistryFile {
    path: PathBuf,
    access: Access,
    lock_wait: Duration,
}

/// The rows not yet written: metric values, and the lineage, artifact and dataset records
/// a stage reports around its end. Each open that writes costs milliseconds (DuckDB commits,
/// and checkpoints the file when it is closed), and metrics come in bursts of thousands, so
/// these rows are written in batches, one open per batch: with the next run start or end
/// (or any other operation, reads included), every `BATCH` rows or `FLUSH_AFTER`, and when
/// the registry is dropped. Another process reading meanwhile (`firecast serve`) sees a
/// running stage's curves up to that much behind; runs' starts and ends are written at once.
struct Pending {
    metrics: Vec<MetricRow>,
    records: Vec<Record>,
    last_flush: Instant,
}

struct MetricRow {
    run_id: String,
    key: String,
    step: i64,
    value: f64,
    time: String,
}

/// One queued INSERT and its values.
struct Record {
    sql: &'static str,
    values: Vec<Value>,
}

const BATCH: usize = 4096;
const FLUSH_AFTER: Duration = Duration::from_secs(2);

impl Pending {
    fn len(&self) -> usize {
        self.metrics.len() + self.records.len()
    }

    fn due(&self) -> bool {
        self.len() >= BATCH || self.last_flush.elapsed() >= FLUSH_AFTER
    }

    /// Write the pending rows through `conn` (the operation's own open). Rows that fail to
    /// write are dropped with the error, as a lone INSERT's would be.
    fn write(&mut self, conn: &Connection) -> Result<(), RegistryError> {
        self.last_flush = Instant::now();
        if !self.records.is_empty() {
            let records = std::mem::take(&mut self.records);
            // One transaction: one commit for the lot.
            conn.execute_batch("BEGIN TRANSACTION")?;
            let inserted = records.iter().try_for_each(|r| {
                conn.prepare_cached(r.sql)?
                    .execute(duckdb::params_from_iter(r.values.iter()))
                    .map(drop)
            });
            match inserted {
                Ok(()) => conn.execute_batch("COMMIT")?,
                Err(e) => {
                    conn.execute_batch("ROLLBACK")?;
                    return Err(e.into());
                }
            }
        }
        if !self.metrics.is_empty() {
            let rows = std::mem::take(&mut self.metrics);
            let mut appender = conn.appender_to_catalog_and_db("metrics", ALIAS, "main")?;
            for r in &rows {
                // The appender casts the text to the column's TIMESTAMP as `?::TIMESTAMP` did.
                appender.append_row(params![r.run_id, r.key, r.step, r.value, r.time])?;
            }
            appender.flush()?;
        }
        Ok(())
    }
}

impl RegistryFile {
    /// Attach the file to `conn` as the default catalog, retrying while another process
    /// holds its lock.
    fn attach(&self, conn: &Connection) -> Result<(), RegistryError> {
        if self.access == Access::ReadOnly && !self.path.exists() {
            // No registry yet: reads see its tables, empty.
            conn.execute_batch(&format!("ATTACH ':memory:' AS {ALIAS}; USE {ALIAS}; {SCHEMA}"))?;
            return Ok(());
        }
        let path = self
            .path
            .to_str()
            .ok_or_else(|| RegistryError::NotUtf8(self.path.clone()))?;
        let options = match self.access {
            Access::ReadWrite => "",
            Access::ReadOnly => " (READ_ONLY)",
        };
        let attach = format!("ATTACH '{}' AS {ALIAS}{options}", path.replace('\'', "''"));
        let started = Instant::now();
        let mut pause = FIRST_PAUSE;
        loop {
            let source = match conn.execute_batch(&attach) {
                Ok(()) => break,
                Err(e) => e,
            };
            if !is_lock_conflict(&source.to_string()) {
                return Err(self.open_error(None, source));
            }
            let waited = started.elapsed();
            if waited >= self.lock_wait {
                return Err(self.open_error(Some(waited), source));
            }
            std::thread::sleep(pause.min(self.lock_wait - waited));
            pause = (pause * 2).min(MAX_PAUSE);
        }
        conn.execute_batch(&format!("USE {ALIAS}"))?;
        Ok(())
    }

    fn open_error(&self, waited: Option<Duration>, source: duckdb::Error) -> RegistryError {
        RegistryError::Open {
            path: self.path.clone(),
            waited,
            source,
        }
    }

    /// One operation: open, write the pending metrics, run `f`, close (which lets other
    /// processes in).
    fn with_conn<T>(
        &self,
        pending: &mut Pending,
        f: impl FnOnce(&Connection) -> Result<T, RegistryError>,
    ) -> Result<T, RegistryError> {
        let mut instance = INSTANCE.lock().unwrap_or_else(|e| e.into_inner());
        let base = match instance.take() {
            Some(base) => base,
            None => new_instance().map_err(|source| self.open_error(None, source))?,
        };
        // A fresh connection per operation, so temporary views (`query`) end with it.
        let conn = base.try_clone()?;
        let out = self.attach(&conn).and_then(|()| {
            pending.write(&conn)?;
            f(&conn)
        });
        let detached = detach_all(&conn);
        drop(conn);
        if let Err(e) = detached {
            // Dropping the instance closes whatever it still has open; the next operation
            // starts a new one.
            drop(base);
            return out.and(Err(e.into()));
        }
        *instance = Some(base);
        out
    }
}

/// The in-memory instance the registry files are attached to.
fn new_instance() -> duckdb::Result<Connection> {
    // Parquet blocks read by `query` would otherwise stay cached for the process's life.
    let config = duckdb::Config::default().with("enable_external_file_cache", "false")?;
    Connection::open_in_memory_with_flags(config)
}

/// Detach every database the operation attached (a `query` may ATTACH too), so that no file
/// stays held once it ends.
fn detach_all(conn: &Connection) -> duckdb::Result<()> {
    conn.execute_batch("USE memory")?;
    let mut stmt = conn.prepare(
        "SELECT database_name FROM duckdb_databases() WHERE NOT internal AND database_name <> 'memory'",
    )?;
    let names: Vec<String> = stmt.query_map([], |r| r.get(0))?.collect::<Result<_, _>>()?;
    for name in names {
        conn.execute_batch(&format!("DETACH \"{}\"", name.replace('"', "\"\"")))?;
    }
    Ok(())
}

impl Drop for Registry {
    fn drop(&mut self) {
        let pending = self.pending.get_mut().unwrap_or_else(|e| e.into_inner());
        let rows = pending.len();
        if rows == 0 {
            return;
        }
        if let Err(e) = self.file.with_conn(pending, |_| Ok(())) {
            eprintln!(
                "warning: {}: {rows} metric, lineage, artifact or dataset rows could not be written: {e}",
                self.file.path.display()
            );
        }
    }
}

impl std::fmt::Debug for Registry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Registry")
            .field("path", &self.file.path)
            .field("access", &self.file.access)
            .finish()
    }
}

fn text(s: &str) -> Value {
    Value::Text(s.to_string())
}

fn ts(t: chrono::DateTime<chrono::Utc>) -> String {
    t.format("%Y-%m-%d %H:%M:%S%.6f").to_string()
}

/// The schema version a registry file records, if any.
fn stored_schema_version(conn: &Connection) -> Option<i32> {
    conn.query_row(
        "SELECT value FROM registry_meta WHERE key = 'schema_version'",
        [],
        |r| r.get::<_, String>(0),
    )
    .ok()
    .and_then(|v| v.parse::<i32>().ok())
}

impl Registry {
    /// Open (creating if needed) the registry file for reading and writing; how long each
    /// operation waits for another process's lock comes from `FIRECAST_REGISTRY_WAIT_MS`.
    pub fn open(path: &Path) -> Result<Self, RegistryError> {
        Self::open_with(path, Access::ReadWrite, lock_wait_from_env()?)
    }

    /// Open the registry file for reading only (see `Access::ReadOnly`).
    pub fn open_read_only(path: &Path) -> Result<Self, RegistryError> {
        Self::open_with(path, Access::ReadOnly, lock_wait_from_env()?)
    }

    /// Open with an explicit access and lock wait. A read-write open creates the tables; both
    /// check that the file's schema is not newer than this firecast.
    pub fn open_with(path: &Path, access: Access, lock_wait: Duration) -> Result<Self, RegistryError> {
        if access == Access::ReadWrite
            && let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty())
        {
            std::fs::create_dir_all(parent).map_err(|source| RegistryError::Io {
                path: parent.to_path_buf(),
                source,
            })?;
        }
        let registry = Self {
            file: RegistryFile {
                path: path.to_path_buf(),
                access,
                lock_wait,
            },
            pending: Mutex::new(Pending {
                metrics: Vec::new(),
                records: Vec::new(),
                last_flush: Instant::now(),
            }),
        };
        registry.with_conn(|conn| {
            if access == Access::ReadWrite {
                conn.execute_batch(SCHEMA)?;
            }
            match stored_schema_version(conn) {
                Some(found) if found > SCHEMA_VERSION => Err(RegistryError::SchemaTooNew {
                    found,
                    path: path.to_path_buf(),
                }),
                Some(_) => Ok(()),
                None if access == Access::ReadWrite => {
                    conn.execute(
                        "INSERT INTO registry_meta VALUES ('schema_version', ?)",
                        params![SCHEMA_VERSION.to_string()],
                    )?;
                    Ok(())
                }
                None => Ok(()),
            }
        })?;
        Ok(registry)
    }

    pub fn path(&self) -> &Path {
        &self.file.path
    }

    pub fn access(&self) -> Access {
        self.file.access
    }

    /// One operation on the file, with every pending metric written first (so reads see them).
    fn with_conn<T>(
        &self,
        f: impl FnOnce(&Connection) -> Result<T, RegistryError>,
    ) -> Result<T, RegistryError> {
        let mut pending = self.pending.lock().unwrap_or_else(|e| e.into_inner());
        self.file.with_conn(&mut pending, f)
    }

    /// A write: refused on a read-only registry.
    fn write<T>(
        &self,
        what: &'static str,
        f: impl FnOnce(&Connection) -> Result<T, RegistryError>,
    ) -> Result<T, RegistryError> {
        self.writable(what)?;
        self.with_conn(f)
    }

    fn writable(&self, what: &'static str) -> Result<(), RegistryError> {
        match self.file.access {
            Access::ReadWrite => Ok(()),
            Access::ReadOnly => Err(RegistryError::ReadOnly {
                what,
                path: self.file.path.clone(),
            }),
        }
    }

    /// Write the pending rows now (nothing to do on a read-only registry).
    pub fn flush(&self) -> Result<(), RegistryError> {
        let mut pending = self.pending.lock().unwrap_or_else(|e| e.into_inner());
        if pending.len() == 0 {
            return Ok(());
        }
        self.file.with_conn(&mut pending, |_| Ok(()))
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
        self.write("record a run", |conn| {
            conn.execute(
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
            // Who runs it: a reader can then tell a run whose process is gone (`crashed`)
            // from one still going.
            conn.execute(
                "INSERT INTO run_owners VALUES (?, ?) ON CONFLICT DO UPDATE SET owner = excluded.owner",
                params![run_id, owner::this_process()],
            )?;
            Ok(())
        })
    }

    /// Inserts finished runs as listed (`runs list --json` rows) in one operation and one
    /// transaction: a registry filled from another one, or with many runs for a benchmark,
    /// without one open per run. Times are `YYYY-MM-DD HH:MM:SS[.ffffff]` (UTC).
    pub fn import_runs(&self, runs: &[RunRow]) -> Result<(), RegistryError> {
        self.write("import runs", |conn| {
            conn.execute_batch("BEGIN TRANSACTION")?;
            let inserted = (|| -> Result<(), RegistryError> {
                let mut stmt = conn.prepare(
                    "INSERT INTO runs (run_id, pipeline_run_id, parent_run_id, pipeline, stage, kind, kind_version,
                                       params, status, started_at, ended_at, git_commit, cache_key, error)
                     VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?::TIMESTAMP, ?::TIMESTAMP, ?, ?, ?)",
                )?;
                for r in runs {
                    stmt.execute(params![
                        r.run_id,
                        r.pipeline_run_id,
                        r.parent_run_id,
                        r.pipeline,
                        r.stage,
                        r.kind,
                        r.kind_version,
                        r.params.to_string(),
                        r.status,
                        r.started_at,
                        r.ended_at,
                        r.git_commit,
                        r.cache_key,
                        r.error
                    ])?;
                }
                Ok(())
            })();
            match inserted {
                Ok(()) => conn.execute_batch("COMMIT").map_err(RegistryError::from),
                Err(e) => {
                    let _ = conn.execute_batch("ROLLBACK");
                    Err(e)
                }
            }
        })
    }

    /// Record how a run ended (status, end time, error). Params are left untouched.
    pub fn finish_run(
        &self,
        run_id: &str,
        status: RunStatus,
        ended_at: chrono::DateTime<chrono::Utc>,
        error: Option<&str>,
    ) -> Result<(), RegistryError> {
        self.write("record a run's end", |conn| {
            conn.execute(
                "UPDATE runs SET status = ?, ended_at = ?::TIMESTAMP, error = ? WHERE run_id = ?",
                params![status.as_str(), ts(ended_at), error, run_id],
            )?;
            Ok(())
        })
    }

    /// Queue one metric row; it is written with the next batch (see `Pending`).
    pub fn log_metric(&self, run_id: &str, key: &str, step: i64, value: f64) -> Result<(), RegistryError> {
        self.writable("log metrics")?;
        let mut pending = self.pending.lock().unwrap_or_else(|e| e.into_inner());
        pending.metrics.push(MetricRow {
            run_id: run_id.to_string(),
            key: key.to_string(),
            step,
            value,
            time: ts(chrono::Utc::now()),
        });
        self.flush_if_due(&mut pending)
    }

    /// Queue one INSERT; it is written with the next batch (see `Pending`).
    fn queue(&self, what: &'static str, sql: &'static str, values: Vec<Value>) -> Result<(), RegistryError> {
        self.writable(what)?;
        let mut pending = self.pending.lock().unwrap_or_else(|e| e.into_inner());
        pending.records.push(Record { sql, values });
        self.flush_if_due(&mut pending)
    }

    fn flush_if_due(&self, pending: &mut Pending) -> Result<(), RegistryError> {
        if pending.due() {
            // Counted from this try, so a failed open (rows kept) is not retried per row.
            pending.last_flush = Instant::now();
            self.file.with_conn(pending, |_| Ok(()))?;
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
        self.queue(
            "record an artifact",
            "INSERT INTO artifacts VALUES (?, ?, ?, ?, ?, ?::TIMESTAMP)",
            vec![
                text(run_id),
                text(name),
                text(uri),
                text(hash),
                Value::BigInt(size as i64),
                Value::Text(ts(chrono::Utc::now())),
            ],
        )
    }

    /// Register a dataset version; registering the same (name, version) again is a no-op.
    pub fn register_dataset(&self, run_id: Option<&str>, d: &DatasetRecord) -> Result<(), RegistryError> {
        let metadata = serde_json::to_string(&d.metadata).unwrap_or_default();
        self.queue(
            "register a dataset",
            "INSERT INTO datasets VALUES (?, ?, ?, ?, ?, ?, ?, ?::TIMESTAMP) ON CONFLICT DO NOTHING",
            vec![
                text(&d.name),
                text(&d.version),
                text(&d.schema_json),
                Value::BigInt(d.rows as i64),
                text(&d.location),
                Value::Text(metadata),
                run_id.map_or(Value::Null, text),
                Value::Text(ts(chrono::Utc::now())),
            ],
        )
    }

    pub fn log_lineage(&self, run_id: &str, r: &LineageRecord) -> Result<(), RegistryError> {
        self.queue(
            "record lineage",
            "INSERT INTO lineage VALUES (?, ?, ?, ?, ?, ?)",
            vec![
                text(run_id),
                text(r.direction),
                text(&r.name),
                text(&r.uri),
                text(&r.hash),
                Value::BigInt(r.size as i64),
            ],
        )
    }

    /// Runs, newest first. A `running` run whose process is gone from this machine reads as
    /// `crashed` (and filters as such).
    pub fn list_runs(&self, filter: &RunFilter) -> Result<Vec<RunRow>, RegistryError> {
        let wanted = filter.status.clone();
        let liveness = matches!(wanted.as_deref(), Some("running" | "crashed"));
        let mut sql_filter = filter.clone();
        if liveness {
            sql_filter.status = Some("running".into());
        }
        let (clause, args) = filter_clause(&sql_filter);
        self.with_conn(|conn| {
            let mut sql = format!(
                "{}{clause} ORDER BY started_at DESC, run_id DESC",
                run_select(conn)?
            );
            if let (Some(limit), false) = (filter.limit, liveness) {
                sql.push_str(&format!(" LIMIT {limit}"));
            }
            let mut stmt = conn.prepare(&sql)?;
            let rows = stmt.query_map(duckdb::params_from_iter(args.iter()), run_row)?;
            let mut rows: Vec<RunRow> = rows.collect::<Result<_, _>>()?;
            if liveness {
                rows.retain(|r| Some(r.status.as_str()) == wanted.as_deref());
                if let Some(limit) = filter.limit {
                    rows.truncate(limit);
                }
            }
            Ok(rows)
        })
    }

    /// How many runs match (the filter's limit aside).
    pub fn count_runs(&self, filter: &RunFilter) -> Result<u64, RegistryError> {
        if matches!(filter.status.as_deref(), Some("running" | "crashed")) {
            let all = RunFilter {
                limit: None,
                ..filter.clone()
            };
            return Ok(self.list_runs(&all)?.len() as u64);
        }
        let (clause, args) = filter_clause(filter);
        self.with_conn(|conn| {
            let n: i64 = conn.query_row(
                &format!("SELECT count(*) FROM runs{clause}"),
                duckdb::params_from_iter(args.iter()),
                |r| r.get(0),
            )?;
            Ok(u64::try_from(n).unwrap_or(0))
        })
    }

    /// Resolve a run id or a unique prefix of one.
    pub fn resolve_run_id(&self, prefix: &str) -> Result<String, RegistryError> {
        self.with_conn(|conn| resolve_run_id(conn, prefix))
    }

    /// Everything about one run.
    pub fn run_details(&self, id_or_prefix: &str) -> Result<RunDetails, RegistryError> {
        self.with_conn(|conn| {
            let run_id = resolve_run_id(conn, id_or_prefix)?;
            let select = run_select(conn)?;
            let run = conn.query_row(
                &format!("{select} WHERE run_id = ?"),
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
                "{select} WHERE pipeline_run_id = ? ORDER BY started_at, run_id"
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
        })
    }

    /// The metric keys a run logged, sorted (empty for an unknown run id; ids are exact).
    pub fn metric_keys(&self, run_id: &str) -> Result<Vec<String>, RegistryError> {
        self.with_conn(|conn| {
            let mut stmt = conn.prepare("SELECT DISTINCT key FROM metrics WHERE run_id = ? ORDER BY key")?;
            let keys = stmt
                .query_map(params![run_id], |r| r.get(0))?
                .collect::<Result<_, _>>()?;
            Ok(keys)
        })
    }

    /// One metric's curve: (step, value) by step, rows logged at the same step in the order
    /// they were logged (empty for an unknown run or key; ids are exact).
    pub fn metric_series(&self, run_id: &str, key: &str) -> Result<Vec<(i64, f64)>, RegistryError> {
        self.with_conn(|conn| {
            let mut stmt = conn.prepare(
                "SELECT step, value FROM metrics WHERE run_id = ? AND key = ? ORDER BY step, time, rowid",
            )?;
            let points = stmt
                .query_map(params![run_id, key], |r| Ok((r.get(0)?, r.get(1)?)))?
                .collect::<Result<_, _>>()?;
            Ok(points)
        })
    }

    /// Every registered dataset version, by name, newest first within a name.
    pub fn list_datasets(&self) -> Result<Vec<DatasetRow>, RegistryError> {
        self.with_conn(|conn| {
            let mut stmt = conn.prepare(
                "SELECT name, version, rows, location, schema_json, metadata, run_id, created_at::VARCHAR
                 FROM datasets ORDER BY name, created_at DESC, version",
            )?;
            let rows = stmt.query_map([], |r| {
                let metadata: String = r.get(5)?;
                Ok(DatasetRow {
                    name: r.get(0)?,
                    version: r.get(1)?,
                    rows: r.get(2)?,
                    location: r.get(3)?,
                    schema_json: r.get(4)?,
                    metadata: serde_json::from_str(&metadata).unwrap_or(serde_json::Value::String(metadata)),
                    run_id: r.get(6)?,
                    created_at: r.get(7)?,
                })
            })?;
            Ok(rows.collect::<Result<_, _>>()?)
        })
    }

    /// Artifacts, newest first, optionally of one run.
    pub fn list_artifacts(&self, run: Option<&str>) -> Result<Vec<ArtifactRow>, RegistryError> {
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
        self.with_conn(|conn| {
            let mut stmt = conn.prepare(sql)?;
            let rows = stmt.query_map(duckdb::params_from_iter(args.iter()), artifact_row)?;
            Ok(rows.collect::<Result<_, _>>()?)
        })
    }

    /// Run SQL over the registry tables, with each registered dataset (latest version)
    /// available as a view named after it. On a read-only registry, SQL that writes fails.
    pub fn query(&self, sql: &str) -> Result<QueryResult, RegistryError> {
        self.with_conn(|conn| {
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
        })
    }
}

/// ` WHERE …` (or nothing) and its arguments for a run filter (its limit aside).
fn filter_clause(filter: &RunFilter) -> (String, Vec<String>) {
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
    if clauses.is_empty() {
        (String::new(), args)
    } else {
        (format!(" WHERE {}", clauses.join(" AND ")), args)
    }
}

fn resolve_run_id(conn: &Connection, prefix: &str) -> Result<String, RegistryError> {
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

const RUN_COLUMNS: &str =
    "SELECT run_id, pipeline_run_id, parent_run_id, pipeline, stage, kind, kind_version, params,
    status, strftime(started_at, '%Y-%m-%d %H:%M:%S'), strftime(ended_at, '%Y-%m-%d %H:%M:%S'),
    epoch(ended_at) - epoch(started_at), git_commit, cache_key, error";

/// The runs query, with each run's owner where the file records owners (registries written
/// before `run_owners` existed, opened read-only, have none).
fn run_select(conn: &Connection) -> Result<String, RegistryError> {
    let owners: i64 = conn.query_row(
        "SELECT count(*) FROM duckdb_tables() WHERE table_name = 'run_owners' AND database_name = current_database()",
        [],
        |r| r.get(0),
    )?;
    Ok(if owners > 0 {
        format!("{RUN_COLUMNS}, (SELECT o.owner FROM run_owners o WHERE o.run_id = runs.run_id) FROM runs")
    } else {
        format!("{RUN_COLUMNS}, NULL FROM runs")
    })
}

/// Which process runs a run: `host|boot id|pid|process start`, and whether it is gone.
mod owner {
    /// This process, as the registry records it.
    pub fn this_process() -> String {
        let pid = std::process::id();
        format!(
            "{}|{}|{pid}|{}",
            host(),
            boot_id(),
            start_ticks(pid).unwrap_or_default()
        )
    }

    fn read(path: &str) -> String {
        std::fs::read_to_string(path)
            .map(|s| s.trim().to_string())
            .unwrap_or_default()
    }

    fn host() -> String {
        read("/proc/sys/kernel/hostname")
    }

    fn boot_id() -> String {
        read("/proc/sys/kernel/random/boot_id")
    }

    /// The process's start time in clock ticks after boot (`/proc/<pid>/stat` field 22): a
    /// reused pid has another.
    fn start_ticks(pid: u32) -> Option<String> {
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
        // The command name (field 2) may hold spaces; fields after its `)` are plain.
        let rest = stat.get(stat.rfind(')')? + 1..)?;
        rest.split_whitespace().nth(19).map(str::to_string)
    }

    /// Whether the owner is known to be gone: recorded on this machine (same host name), and
    /// either this machine has rebooted since or no process with that pid and start time
    /// exists. Owners on other machines, or not recorded, are never called gone.
    pub fn is_gone(owner: &str) -> bool {
        let parts: Vec<&str> = owner.split('|').collect();
        let [h, boot, pid, start] = parts[..] else {
            return false;
        };
        let (here, this_boot) = (host(), boot_id());
        if h.is_empty() || h != here || this_boot.is_empty() {
            return false;
        }
        if boot != this_boot {
            return true;
        }
        match pid.parse::<u32>() {
            Ok(pid) => start_ticks(pid).is_none_or(|now| !start.is_empty() && now != start),
            Err(_) => false,
        }
    }
}

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
        status: {
            let status: String = r.get(8)?;
            let owner: Option<String> = r.get(15)?;
            if status == "running" && owner.as_deref().is_some_and(owner::is_gone) {
                "crashed".to_string()
            } else {
                status
            }
        },
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
    fn a_run_whose_process_is_gone_reads_as_crashed() {
        let dir = tempfile::tempdir().unwrap();
        let registry = Registry::open(&dir.path().join("r.duckdb")).unwrap();
        for id in ["alive", "dead", "elsewhere", "unrecorded"] {
            run(&registry, id);
        }
        // A process that has ended: its pid with the start time it had is gone.
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead_pid = child.id();
        child.wait().unwrap();
        let mine = owner::this_process();
        let parts: Vec<&str> = mine.split('|').collect();
        let dead = format!("{}|{}|{dead_pid}|1", parts[0], parts[1]);
        let elsewhere = format!("another-host|{}|{dead_pid}|1", parts[1]);
        registry
            .with_conn(|conn| {
                conn.execute(
                    "UPDATE run_owners SET owner = ? WHERE run_id = 'dead'",
                    params![dead],
                )?;
                conn.execute(
                    "UPDATE run_owners SET owner = ? WHERE run_id = 'elsewhere'",
                    params![elsewhere],
                )?;
                conn.execute("DELETE FROM run_owners WHERE run_id = 'unrecorded'", [])?;
                Ok(())
            })
            .unwrap();
        let status = |id: &str| registry.run_details(id).unwrap().run.status;
        assert_eq!(status("alive"), "running");
        assert_eq!(status("dead"), "crashed");
        assert_eq!(
            status("elsewhere"),
            "running",
            "another machine's process is not ours to judge"
        );
        assert_eq!(status("unrecorded"), "running");
        let by = |s: &str| RunFilter {
            status: Some(s.into()),
            ..RunFilter::default()
        };
        let ids = |f: &RunFilter| {
            registry
                .list_runs(f)
                .unwrap()
                .into_iter()
                .map(|r| r.run_id)
                .collect::<Vec<_>>()
        };
        assert_eq!(ids(&by("crashed")), ["dead"]);
        assert_eq!(ids(&by("running")).len(), 3);
        assert_eq!(registry.count_runs(&by("crashed")).unwrap(), 1);
        // A finished run is what it finished as, whoever ran it.
        registry
            .finish_run("dead", RunStatus::Succeeded, chrono::Utc::now(), None)
            .unwrap();
        assert_eq!(status("dead"), "succeeded");
    }

    #[test]
    fn batched_metrics_are_all_written_and_seen_by_reads() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("registry.duckdb");
        let n = BATCH * 2 + 17;
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

    #[test]
    fn read_only_registry_reads_what_was_written_and_refuses_writes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("registry.duckdb");
        let wait = Duration::from_secs(10);

        // Before any writer: empty reads, and no file is created.
        let reader = Registry::open_with(&path, Access::ReadOnly, wait).unwrap();
        assert!(reader.list_runs(&RunFilter::default()).unwrap().is_empty());
        assert_eq!(reader.count_runs(&RunFilter::default()).unwrap(), 0);
        assert!(matches!(
            reader.resolve_run_id("r"),
            Err(RegistryError::NoSuchRun(_))
        ));
        assert!(reader.metric_series("r1", "loss").unwrap().is_empty());
        assert_eq!(
            reader.query("SELECT count(*) AS n FROM runs").unwrap().rows[0][0],
            serde_json::json!(0)
        );
        assert!(!path.exists());

        {
            let writer = Registry::open_with(&path, Access::ReadWrite, wait).unwrap();
            run(&writer, "r1");
            run(&writer, "r2");
            for (step, value) in [(2, 0.5), (0, 2.0), (1, 1.0), (1, 0.9)] {
                writer.log_metric("r1", "loss", step, value).unwrap();
            }
            writer.log_metric("r1", "acc", 0, 0.25).unwrap();
            writer
                .log_artifact("r1", "model", "artifacts/m.bin", "abc", 3)
                .unwrap();
            // Still pending: the reader does not see them until the writer writes the batch.
            assert!(reader.metric_keys("r1").unwrap().is_empty());
            assert!(reader.list_artifacts(None).unwrap().is_empty());
            // The writer's own reads write the batch first.
            assert_eq!(
                writer.list_artifacts(Some("r1")).unwrap()[0].uri,
                "artifacts/m.bin"
            );
            writer
                .log_lineage(
                    "r2",
                    &LineageRecord {
                        direction: "input",
                        name: "data".into(),
                        uri: "data.csv".into(),
                        hash: "h".into(),
                        size: 9,
                    },
                )
                .unwrap();
            // Dropped with the lineage row pending: written on drop.
        }

        // The same reader now sees the file a writer created.
        assert_eq!(reader.count_runs(&RunFilter::default()).unwrap(), 2);
        let filter = RunFilter {
            status: Some("running".into()),
            limit: Some(1),
            ..RunFilter::default()
        };
        assert_eq!(reader.count_runs(&filter).unwrap(), 2, "the limit does not count");
        assert_eq!(reader.list_runs(&filter).unwrap().len(), 1);
        assert_eq!(reader.metric_keys("r1").unwrap(), vec!["acc", "loss"]);
        assert_eq!(
            reader.metric_series("r1", "loss").unwrap(),
            vec![(0, 2.0), (1, 1.0), (1, 0.9), (2, 0.5)]
        );
        assert!(reader.metric_series("r2", "loss").unwrap().is_empty());
        assert_eq!(reader.run_details("r1").unwrap().metrics.len(), 2);
        assert_eq!(reader.list_artifacts(None).unwrap().len(), 1);
        assert_eq!(reader.run_details("r2").unwrap().lineage[0].uri, "data.csv");

        // Writes are refused, by method or by SQL.
        let refused = reader.log_metric("r1", "loss", 3, 0.1).unwrap_err();
        assert!(matches!(refused, RegistryError::ReadOnly { .. }), "{refused}");
        assert!(refused.to_string().contains("read-only"), "{refused}");
        assert!(matches!(
            reader.finish_run("r1", RunStatus::Succeeded, chrono::Utc::now(), None),
            Err(RegistryError::ReadOnly { .. })
        ));
        assert!(matches!(
            reader.query("DELETE FROM runs"),
            Err(RegistryError::Query(_))
        ));
        assert_eq!(reader.count_runs(&RunFilter::default()).unwrap(), 2);
    }

    #[test]
    fn lock_conflicts_are_told_apart_from_other_open_errors() {
        let real = r#"IO Error: Could not set lock on file "/p/.firecast/registry.duckdb": Conflicting lock is held in /usr/bin/firecast (PID 4242). See also https://duckdb.org/docs/stable/connect/concurrency"#;
        assert!(is_lock_conflict(real));
        assert!(!is_lock_conflict(
            r#"IO Error: Cannot open file "/p/registry.duckdb": Permission denied"#
        ));
        assert!(!is_lock_conflict(
            "IO Error: The file \"/p/registry.duckdb\" exists, but it is not a valid DuckDB database file!"
        ));

        // Other open errors fail at once, however long the wait.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("not-a-registry.duckdb");
        std::fs::write(&path, b"this is not a DuckDB file, not even close to one").unwrap();
        let started = Instant::now();
        let err = Registry::open_with(&path, Access::ReadWrite, Duration::from_secs(30)).unwrap_err();
        assert!(matches!(err, RegistryError::Open { waited: None, .. }), "{err}");
        assert!(
            started.elapsed() < Duration::from_secs(5),
            "{:?}",
            started.elapsed()
        );
    }

    /// What `hold_the_lock_in_a_child` holds, and for how many milliseconds.
    const HOLD_ENV: &str = "FIRECAST_REGISTRY_TEST_HOLD";
    const HOLD_MS_ENV: &str = "FIRECAST_REGISTRY_TEST_HOLD_MS";

    /// The child of `another_process_lock_is_waited_for`: opens the registry file read-write
    /// (failing if another process holds it), says so by creating `<file>.held`, and keeps it
    /// open for a while. Does nothing when run on its own.
    #[test]
    #[ignore = "run by another_process_lock_is_waited_for in a child process"]
    fn hold_the_lock_in_a_child() {
        let Some(path) = std::env::var_os(HOLD_ENV).map(PathBuf::from) else {
            return;
        };
        let ms: u64 = std::env::var(HOLD_MS_ENV).unwrap().parse().unwrap();
        let conn = Connection::open(&path).unwrap();
        std::fs::write(path.with_extension("held"), b"").unwrap();
        std::thread::sleep(Duration::from_millis(ms));
        drop(conn);
    }

    fn hold_in_a_child(path: &Path, ms: u64) -> std::process::Child {
        std::process::Command::new(std::env::current_exe().unwrap())
            .args([
                "tests::hold_the_lock_in_a_child",
                "--exact",
                "--ignored",
                "--quiet",
            ])
            .env(HOLD_ENV, path)
            .env(HOLD_MS_ENV, ms.to_string())
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap()
    }

    #[test]
    fn another_process_lock_is_waited_for() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("registry.duckdb");
        run(&Registry::open(&path).unwrap(), "r1");

        let mut child = hold_in_a_child(&path, 1500);
        let held = path.with_extension("held");
        let started = Instant::now();
        while !held.exists() {
            assert!(
                started.elapsed() < Duration::from_secs(60),
                "the child never took the lock"
            );
            std::thread::sleep(Duration::from_millis(10));
        }

        // No wait: DuckDB's real message, classified as a conflict, and the wait is named.
        for access in [Access::ReadWrite, Access::ReadOnly] {
            let err = Registry::open_with(&path, access, Duration::ZERO).unwrap_err();
            let RegistryError::Open {
                waited: Some(_),
                source,
                ..
            } = &err
            else {
                panic!("{access:?}: not a lock conflict: {err}");
            };
            assert!(is_lock_conflict(&source.to_string()), "{source}");
            assert!(err.to_string().contains(WAIT_ENV), "{err}");
        }

        // With a wait, the open goes through once the child lets go.
        let waiting = Instant::now();
        let registry = Registry::open_with(&path, Access::ReadWrite, Duration::from_secs(60)).unwrap();
        assert!(
            waiting.elapsed() >= Duration::from_millis(200),
            "{:?}",
            waiting.elapsed()
        );
        run(&registry, "r2");
        assert_eq!(registry.count_runs(&RunFilter::default()).unwrap(), 2);
        assert!(child.wait().unwrap().success());

        // Between operations this process holds nothing, though its registry is alive: a
        // child that does not wait gets the file.
        std::fs::remove_file(&held).unwrap();
        assert!(hold_in_a_child(&path, 0).wait().unwrap().success());
        assert_eq!(registry.list_runs(&RunFilter::default()).unwrap().len(), 2);
    }

    /// The cost of an operation's open and close, on a registry of 5,000 runs and 250,000
    /// metric rows: `cargo test --release -p firecast-registry -- --ignored open_cost --nocapture`.
    #[test]
    #[ignore = "a measurement; prints timings"]
    fn open_cost() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("registry.duckdb");
        drop(Registry::open(&path).unwrap());
        {
            let conn = Connection::open(&path).unwrap();
            conn.execute_batch(
                "INSERT INTO runs (run_id, pipeline, stage, kind, params, status, started_at)
                   SELECT 'seed-' || i, 'p', 's' || (i % 7), 'cmd', '{\"lr\": 0.1}', 'succeeded',
                          TIMESTAMP '2026-01-01' + INTERVAL (i) SECOND FROM range(5000) t(i);
                 INSERT INTO metrics SELECT 'seed-' || (i // 50), 'loss', i % 50, 1.0 / (i + 1),
                          TIMESTAMP '2026-01-01' FROM range(250000) t(i);",
            )
            .unwrap();
        }
        let n = 1000;
        let time = |label: &str, f: &dyn Fn(usize)| {
            let started = Instant::now();
            for i in 0..n {
                f(i);
            }
            let total = started.elapsed();
            println!(
                "{label:<46} {n} in {:>7.3} s = {:>6.3} ms each",
                total.as_secs_f64(),
                total.as_secs_f64() * 1e3 / n as f64
            );
        };
        // The old way, for comparison: one connection kept open.
        {
            let conn = Connection::open(&path).unwrap();
            time("insert_run, one connection held (before)", &|i| {
                conn.execute(
                    "INSERT INTO runs (run_id, pipeline, kind, params, status, started_at)
                     VALUES (?, 'p', 'cmd', '{}', 'running', now())",
                    params![format!("held-{i}")],
                )
                .unwrap();
            });
        }
        let registry = Registry::open(&path).unwrap();
        time("insert_run, open+insert+close", &|i| {
            run(&registry, &format!("op-{i}"));
        });
        time("finish_run, open+update+close", &|i| {
            registry
                .finish_run(&format!("op-{i}"), RunStatus::Succeeded, chrono::Utc::now(), None)
                .unwrap();
        });
        let reader = Registry::open_read_only(&path).unwrap();
        time("list_runs (50), read-only open+select+close", &|_| {
            assert_eq!(
                reader
                    .list_runs(&RunFilter {
                        limit: Some(50),
                        ..RunFilter::default()
                    })
                    .unwrap()
                    .len(),
                50
            );
        });
        time("metric_series (50 points), read-only", &|i| {
            assert_eq!(
                reader
                    .metric_series(&format!("seed-{}", i % 5000), "loss")
                    .unwrap()
                    .len(),
                50
            );
        });
        let metrics = Instant::now();
        for i in 0..(BATCH * 25) as i64 {
            registry.log_metric("op-0", "loss", i, 0.5).unwrap();
        }
        registry.flush().unwrap();
        println!(
            "log_metric x {} (25 batches)                {:>7.3} s",
            BATCH * 25,
            metrics.elapsed().as_secs_f64()
        );
        println!(
            "file: {} bytes, {} runs",
            std::fs::metadata(&path).unwrap().len(),
            registry.count_runs(&RunFilter::default()).unwrap()
        );
    }
}
