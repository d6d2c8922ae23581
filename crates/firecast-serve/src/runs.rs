//! The runs browser's data: the registry read with short read-only opens (the CLI may be
//! writing it), the runs table kept in memory until the file changes, filtered, sorted and
//! paged here; run details, metric series, logs, artifacts and comparisons.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::SystemTime;

use firecast_registry::{Registry, RunFilter, RunRow};
use serde::{Deserialize, Serialize};

use crate::error::{ApiError, Code};

/// The registry file and an in-memory copy of its runs table.
pub struct Runs {
    path: PathBuf,
    cache: Mutex<Option<Cached>>,
    /// Pages as sent, by query, for the registry state they were made from: the runs table
    /// polled by many pages costs one lookup while nothing is written.
    pages: Mutex<HashMap<String, (Stamp, axum::body::Bytes)>>,
}

/// The registry file's modification time and size (with its WAL's).
type Stamp = (SystemTime, u64);

/// Pages kept at most (then the cache starts over).
const PAGES_KEPT: usize = 256;

struct Cached {
    stamp: (SystemTime, u64),
    rows: Arc<Vec<RunRow>>,
}

/// `GET /api/runs` parameters.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunsQuery {
    pub q: Option<String>,
    pub status: Option<String>,
    pub pipeline: Option<String>,
    pub kind: Option<String>,
    pub sort: Option<String>,
    pub order: Option<String>,
    pub limit: Option<usize>,
    pub offset: Option<usize>,
}

/// A page of runs.
#[derive(Debug, Serialize)]
pub struct RunsPage {
    pub total: usize,
    pub offset: usize,
    pub runs: Vec<RunRow>,
}

fn registry_error(e: firecast_registry::RegistryError) -> ApiError {
    match e {
        firecast_registry::RegistryError::NoSuchRun(id) => {
            ApiError::not_found(format!("no run `{id}` in the registry"))
        }
        firecast_registry::RegistryError::AmbiguousRun { prefix, matches } => {
            ApiError::bad(format!("run id `{prefix}` is ambiguous: {matches}"))
        }
        other => ApiError::internal(other.to_string()),
    }
}

/// A run id as typed: letters, digits, `-`, `_`, `.`, at most 128 characters.
pub fn check_run_id(id: &str) -> Result<(), ApiError> {
    if id.is_empty()
        || id.len() > 128
        || !id
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"-_.".contains(&b))
    {
        return Err(ApiError::bad(format!(
            "`{}` is not a run id",
            id.chars().take(64).collect::<String>()
        )));
    }
    Ok(())
}

impl Runs {
    pub fn new(path: PathBuf) -> Self {
        Self {
            path,
            cache: Mutex::new(None),
            pages: Mutex::new(HashMap::new()),
        }
    }

    fn stamp(&self) -> Option<(SystemTime, u64)> {
        // DuckDB writes the WAL beside the file; either changing means new rows.
        let meta = std::fs::metadata(&self.path).ok()?;
        let wal = std::fs::metadata(format!("{}.wal", self.path.display())).ok();
        let modified = meta.modified().ok()?;
        let wal_modified = wal
            .as_ref()
            .and_then(|w| w.modified().ok())
            .unwrap_or(SystemTime::UNIX_EPOCH);
        Some((
            modified.max(wal_modified),
            meta.len() + wal.map_or(0, |w| w.len()),
        ))
    }

    fn open(&self) -> Result<Registry, ApiError> {
        Registry::open_read_only(&self.path).map_err(registry_error)
    }

    /// Every run, newest first, from memory when the file has not changed.
    pub fn all(&self) -> Result<Arc<Vec<RunRow>>, ApiError> {
        let Some(stamp) = self.stamp() else {
            return Ok(Arc::new(Vec::new()));
        };
        let mut cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(c) = cache.as_ref()
            && c.stamp == stamp
        {
            return Ok(c.rows.clone());
        }
        let rows = Arc::new(
            self.open()?
                .list_runs(&RunFilter::default())
                .map_err(registry_error)?,
        );
        *cache = Some(Cached {
            stamp,
            rows: rows.clone(),
        });
        Ok(rows)
    }

    /// One page of the runs table as JSON, from the page cache when the registry has not
    /// changed since it was made (`key`: the request's query string).
    pub fn page_json(&self, q: &RunsQuery, key: &str) -> Result<axum::body::Bytes, ApiError> {
        let stamp = self.stamp().unwrap_or((SystemTime::UNIX_EPOCH, 0));
        if let Some((s, bytes)) = self.pages.lock().unwrap_or_else(|e| e.into_inner()).get(key)
            && *s == stamp
        {
            return Ok(bytes.clone());
        }
        let page = self.page(q)?;
        let bytes = axum::body::Bytes::from(
            serde_json::to_vec(&page).map_err(|e| ApiError::internal(e.to_string()))?,
        );
        let mut pages = self.pages.lock().unwrap_or_else(|e| e.into_inner());
        if pages.len() >= PAGES_KEPT {
            pages.clear();
        }
        pages.insert(key.to_string(), (stamp, bytes.clone()));
        Ok(bytes)
    }

    /// One page of the runs table.
    pub fn page(&self, q: &RunsQuery) -> Result<RunsPage, ApiError> {
        let all = self.all()?;
        let needle = q.q.as_deref().map(str::to_lowercase).filter(|s| !s.is_empty());
        let eq =
            |want: &Option<String>, have: &str| want.as_deref().is_none_or(|w| w.is_empty() || w == have);
        let mut rows: Vec<&RunRow> = all
            .iter()
            .filter(|r| eq(&q.status, &r.status) && eq(&q.pipeline, &r.pipeline) && eq(&q.kind, &r.kind))
            .filter(|r| {
                needle.as_deref().is_none_or(|n| {
                    r.run_id.to_lowercase().contains(n)
                        || r.pipeline.to_lowercase().contains(n)
                        || r.kind.to_lowercase().contains(n)
                        || r.stage.as_deref().is_some_and(|s| s.to_lowercase().contains(n))
                        || r.params.to_string().to_lowercase().contains(n)
                })
            })
            .collect();
        let key = q.sort.as_deref().unwrap_or("started_at");
        // Borrowed keys: a page of 10,000 runs is sorted per request without allocating.
        match key {
            "duration_secs" => rows.sort_by(|a, b| {
                a.duration_secs
                    .unwrap_or(-1.0)
                    .total_cmp(&b.duration_secs.unwrap_or(-1.0))
                    .then_with(|| a.run_id.cmp(&b.run_id))
            }),
            "run_id" | "pipeline" | "stage" | "kind" | "status" | "ended_at" | "started_at" => {
                rows.sort_by(|a, b| {
                    sort_text(a, key)
                        .cmp(sort_text(b, key))
                        .then_with(|| a.run_id.cmp(&b.run_id))
                })
            }
            other => {
                return Err(ApiError::bad(format!(
                    "cannot sort by `{other}`: run_id, pipeline, stage, kind, status, started_at, ended_at or duration_secs"
                )));
            }
        }
        match q.order.as_deref() {
            None | Some("desc") => rows.reverse(),
            Some("asc") => {}
            Some(other) => return Err(ApiError::bad(format!("order `{other}`: asc or desc"))),
        }
        let total = rows.len();
        let offset = q.offset.unwrap_or(0).min(total);
        let limit = q.limit.unwrap_or(100).min(10_000);
        Ok(RunsPage {
            total,
            offset,
            runs: rows.into_iter().skip(offset).take(limit).cloned().collect(),
        })
    }

    /// Every registered dataset version.
    pub fn datasets(&self) -> Result<Vec<firecast_registry::DatasetRow>, ApiError> {
        if self.stamp().is_none() {
            return Ok(Vec::new());
        }
        self.open()?.list_datasets().map_err(registry_error)
    }

    pub fn details(&self, id: &str) -> Result<firecast_registry::RunDetails, ApiError> {
        check_run_id(id)?;
        self.open()?.run_details(id).map_err(registry_error)
    }

    pub fn series(&self, id: &str, key: &str) -> Result<Vec<(i64, f64)>, ApiError> {
        check_run_id(id)?;
        let reg = self.open()?;
        let full = reg.resolve_run_id(id).map_err(registry_error)?;
        reg.metric_series(&full, key).map_err(registry_error)
    }

    /// Parameters by dotted name, differing ones, and metric summaries side by side.
    pub fn compare(&self, ids: &[String], group: Option<&str>) -> Result<serde_json::Value, ApiError> {
        if ids.len() < 2 || ids.len() > 20 {
            return Err(ApiError::bad("compare 2 to 20 runs: ?ids=a,b"));
        }
        let reg = self.open()?;
        let mut details = Vec::new();
        for id in ids {
            check_run_id(id)?;
            details.push(reg.run_details(id).map_err(registry_error)?);
        }
        let flat: Vec<BTreeMap<String, serde_json::Value>> = details
            .iter()
            .map(|d| {
                let mut out = BTreeMap::new();
                flatten("", &d.run.params, &mut out);
                out
            })
            .collect();
        let names: std::collections::BTreeSet<&String> = flat.iter().flat_map(|f| f.keys()).collect();
        let mut params = serde_json::Map::new();
        let mut differing = Vec::new();
        for name in names {
            let values: Vec<Option<&serde_json::Value>> = flat.iter().map(|f| f.get(name)).collect();
            if values.windows(2).any(|w| w[0] != w[1]) {
                differing.push(name.clone());
            }
            params.insert(name.clone(), serde_json::json!(values));
        }
        let keys: std::collections::BTreeSet<&String> = details
            .iter()
            .flat_map(|d| d.metrics.iter().map(|m| &m.key))
            .collect();
        let mut metrics = serde_json::Map::new();
        for key in keys {
            let per_run: Vec<Option<&firecast_registry::MetricSummary>> = details
                .iter()
                .map(|d| d.metrics.iter().find(|m| &m.key == key))
                .collect();
            metrics.insert(key.clone(), serde_json::json!(per_run));
        }
        let grouped = group
            .filter(|g| !g.is_empty())
            .map(|g| crate::results::group(&details, g));
        Ok(serde_json::json!({
            "runs": details.iter().map(|d| &d.run).collect::<Vec<_>>(),
            "params": params,
            "differing": differing,
            "metrics": metrics,
            "grouped": grouped,
        }))
    }
}

/// The text a sort key compares (borrowed: no allocation per comparison).
fn sort_text<'a>(r: &'a RunRow, key: &str) -> &'a str {
    match key {
        "run_id" => &r.run_id,
        "pipeline" => &r.pipeline,
        "stage" => r.stage.as_deref().unwrap_or_default(),
        "kind" => &r.kind,
        "status" => &r.status,
        "ended_at" => r.ended_at.as_deref().unwrap_or_default(),
        _ => &r.started_at,
    }
}

/// Nested parameters as dotted names (`ppo.gamma`, `models[1].kind`): compared by name, never
/// by position in a list of runs.
pub(crate) fn flatten(prefix: &str, v: &serde_json::Value, out: &mut BTreeMap<String, serde_json::Value>) {
    match v {
        serde_json::Value::Object(map) if !map.is_empty() => {
            for (k, x) in map {
                let name = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&name, x, out);
            }
        }
        serde_json::Value::Array(items) if !items.is_empty() && items.iter().any(|i| i.is_object()) => {
            // Elements by their own name where they have one (`models[xgboost].kind`), so two
            // runs listing models in another order compare model by model.
            let labels = element_labels(items);
            for (label, x) in labels.iter().zip(items) {
                flatten(&format!("{prefix}[{label}]"), x, out);
            }
        }
        other => {
            out.insert(prefix.to_string(), other.clone());
        }
    }
}

/// Labels of a list's elements: their `name`, else their `kind`, when every element has one
/// and no two share it; else their positions.
fn element_labels(items: &[serde_json::Value]) -> Vec<String> {
    for key in ["name", "kind"] {
        let labels: Vec<String> = items
            .iter()
            .filter_map(|i| i.get(key).and_then(|v| v.as_str()).map(str::to_string))
            .collect();
        let unique: std::collections::BTreeSet<&String> = labels.iter().collect();
        if labels.len() == items.len() && unique.len() == labels.len() {
            return labels;
        }
    }
    (0..items.len()).map(|i| i.to_string()).collect()
}

/// The rows as CSV (RFC 4180 quoting).
pub fn to_csv(rows: &[RunRow]) -> String {
    fn field(s: &str) -> String {
        if s.contains([',', '"', '\n', '\r']) {
            format!("\"{}\"", s.replace('"', "\"\""))
        } else {
            s.to_string()
        }
    }
    let mut out = String::from(
        "run_id,pipeline_run_id,parent_run_id,pipeline,stage,kind,status,started_at,ended_at,duration_secs,error,params\n",
    );
    for r in rows {
        let cols = [
            r.run_id.clone(),
            r.pipeline_run_id.clone().unwrap_or_default(),
            r.parent_run_id.clone().unwrap_or_default(),
            r.pipeline.clone(),
            r.stage.clone().unwrap_or_default(),
            r.kind.clone(),
            r.status.clone(),
            r.started_at.clone(),
            r.ended_at.clone().unwrap_or_default(),
            r.duration_secs.map(|d| format!("{d:.3}")).unwrap_or_default(),
            r.error.clone().unwrap_or_default(),
            r.params.to_string(),
        ];
        out.push_str(&cols.iter().map(|c| field(c)).collect::<Vec<_>>().join(","));
        out.push('\n');
    }
    out
}

/// The stage log of a run (`.firecast/logs/<run>.log`), if any.
pub fn log_path(root: &Path, run_id: &str) -> Result<PathBuf, ApiError> {
    check_run_id(run_id)?;
    Ok(root.join(".firecast/logs").join(format!("{run_id}.log")))
}

/// The store key of a file of an artifact: the artifact's own key, or a file under it.
/// Refuses anything that could leave it (`..`, absolute parts, backslashes).
pub fn artifact_key(artifact_key: &str, rest: &str) -> Result<String, ApiError> {
    let rest = rest.trim_matches('/');
    if rest.is_empty() {
        return Ok(artifact_key.to_string());
    }
    if rest.len() > 1024
        || rest.contains('\\')
        || rest.contains('\0')
        || rest.split('/').any(|p| p.is_empty() || p == "." || p == "..")
    {
        return Err(ApiError::new(
            Code::BadRequest,
            format!("`{rest}` is not a path inside the artifact"),
        ));
    }
    Ok(format!("{}/{rest}", artifact_key.trim_end_matches('/')))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn artifact_paths_stay_inside() {
        assert_eq!(
            artifact_key("runs/a/report", "").ok().as_deref(),
            Some("runs/a/report")
        );
        assert_eq!(
            artifact_key("runs/a/report", "x/y.png").ok().as_deref(),
            Some("runs/a/report/x/y.png")
        );
        for bad in ["../b", "x/../../y", "x//y", "./x", "a\\b"] {
            assert!(artifact_key("runs/a/report", bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn run_ids_are_checked() {
        assert!(check_run_id("20261124T011253344-3c17c7").is_ok());
        assert!(check_run_id("../etc").is_err());
        assert!(check_run_id("").is_err());
    }

    #[test]
    fn params_flatten_by_name() {
        let mut out = BTreeMap::new();
        flatten(
            "",
            &serde_json::json!({"ppo": {"gamma": 0.99}, "models": [{"kind": "x"}], "seeds": [0, 1]}),
            &mut out,
        );
        assert_eq!(out.get("ppo.gamma"), Some(&serde_json::json!(0.99)));
        assert_eq!(out.get("models[x].kind"), Some(&serde_json::json!("x")));
        // By name, never by position: the same models listed in another order match.
        let mut a = BTreeMap::new();
        let mut b = BTreeMap::new();
        flatten(
            "",
            &serde_json::json!({"models": [{"kind": "lr"}, {"kind": "xgb", "depth": 3}]}),
            &mut a,
        );
        flatten(
            "",
            &serde_json::json!({"models": [{"kind": "xgb", "depth": 3}, {"kind": "lr"}]}),
            &mut b,
        );
        assert_eq!(a, b);
        assert_eq!(a.get("models[xgb].depth"), Some(&serde_json::json!(3)));
        // Without names, positions.
        let mut c = BTreeMap::new();
        flatten("", &serde_json::json!({"m": [{"a": 1}, {"a": 2}]}), &mut c);
        assert_eq!(c.get("m[1].a"), Some(&serde_json::json!(2)));
        assert_eq!(out.get("seeds"), Some(&serde_json::json!([0, 1])));
    }

    #[test]
    fn csv_quotes_what_needs_it() {
        let row = RunRow {
            run_id: "r1".into(),
            pipeline_run_id: None,
            parent_run_id: None,
            pipeline: "p".into(),
            stage: Some("s".into()),
            kind: "cmd".into(),
            params: serde_json::json!({"a": "x,y"}),
            status: "succeeded".into(),
            started_at: "2026-01-01 00:00:00".into(),
            ended_at: None,
            duration_secs: Some(1.5),
            git_commit: None,
            cache_key: None,
            error: Some("said \"no\"".into()),
            kind_version: None,
        };
        let csv = to_csv(&[row]);
        assert!(csv.contains("\"said \"\"no\"\"\""), "{csv}");
        assert!(csv.contains("\"{\"\"a\"\":\"\"x,y\"\"}\""), "{csv}");
    }
}
