//! The researcher's result pages: Table III (a `forecast.experiment` run's `results.json`),
//! Table IV (an `rl.evaluate` run's `evaluation.json`), their plots, the files a run wrote
//! (its lineage outputs, read only inside the project), the datasets of the registry, and
//! runs grouped by a parameter with a mean and interval over the group.

use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};

use firecast_registry::{DatasetRow, RunDetails};

use crate::error::{ApiError, Code};
use crate::runs::{Runs, check_run_id};

/// A file of a run's lineage output `name` (a folder or file the stage wrote), `rest` inside
/// it. Both must resolve inside the project root: a registry row never names a path to read
/// outside it, nor does a request.
pub fn output_path(root: &Path, details: &RunDetails, name: &str, rest: &str) -> Result<PathBuf, ApiError> {
    let row = details
        .lineage
        .iter()
        .find(|l| l.direction == "output" && l.name == name)
        .ok_or_else(|| {
            ApiError::not_found(format!(
                "run {} wrote no output `{}`",
                details.run.run_id,
                name.chars().take(64).collect::<String>()
            ))
        })?;
    let base = inside(root, &root.join(row.uri.trim_start_matches("file://")))?;
    let rest = rest.trim_matches('/');
    if rest.is_empty() {
        return Ok(base);
    }
    let rel = Path::new(rest);
    if rest.len() > 1024
        || rest.contains(['\\', '\0'])
        || !rel.components().all(|c| matches!(c, Component::Normal(_)))
    {
        return Err(ApiError::bad(format!(
            "`{}` is not a path inside the output",
            rest.chars().take(64).collect::<String>()
        )));
    }
    let file = inside(&base, &base.join(rel))?;
    Ok(file)
}

/// `path` resolved (links followed) if it stays under `base`; else `not_found`.
fn inside(base: &Path, path: &Path) -> Result<PathBuf, ApiError> {
    let gone = || ApiError::not_found(format!("{} is not on disk", path.display()));
    let base = base.canonicalize().map_err(|_| gone())?;
    let real = path.canonicalize().map_err(|_| gone())?;
    if !real.starts_with(&base) {
        return Err(ApiError::new(
            Code::BadRequest,
            format!("{} is outside the project", path.display()),
        ));
    }
    Ok(real)
}

/// The run of `kind` asked for, or the newest succeeded one.
fn pick_run(
    runs: &Runs,
    kind: &str,
    id: Option<&str>,
) -> Result<(RunDetails, Vec<serde_json::Value>), ApiError> {
    let all = runs.all()?;
    let succeeded: Vec<&firecast_registry::RunRow> = all
        .iter()
        .filter(|r| r.kind == kind && r.status == "succeeded")
        .collect();
    let candidates: Vec<serde_json::Value> = succeeded
        .iter()
        .map(|r| {
            serde_json::json!({"run_id": r.run_id, "pipeline": r.pipeline, "stage": r.stage, "started_at": r.started_at})
        })
        .collect();
    // Unasked, the fullest table: the run comparing the most models (newest among equals).
    let models = |r: &firecast_registry::RunRow| r.params["models"].as_array().map_or(0, Vec::len);
    let id = match id.filter(|s| !s.is_empty()) {
        Some(id) => id.to_string(),
        None => succeeded
            .iter()
            .rev()
            .max_by_key(|r| models(r))
            .map(|r| r.run_id.clone())
            .ok_or_else(|| {
                ApiError::not_found(format!(
                    "no succeeded `{kind}` run in the registry: run `cargo xtask demo` or a pipeline with such a stage"
                ))
            })?,
    };
    let details = runs.details(&id)?;
    if details.run.kind != kind {
        return Err(ApiError::bad(format!(
            "run {} is a `{}` run, not `{kind}`",
            details.run.run_id, details.run.kind
        )));
    }
    Ok((details, candidates))
}

fn read_json(path: &Path) -> Result<serde_json::Value, ApiError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| ApiError::not_found(format!("cannot read {}: {e}", path.display())))?;
    serde_json::from_str(&text).map_err(|e| ApiError::internal(format!("{}: {e}", path.display())))
}

/// Files under `dir` with one of `exts`, as paths relative to `base`, sorted.
fn files_with(base: &Path, dir: &Path, exts: &[&str]) -> Vec<String> {
    let mut out: Vec<String> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| exts.contains(&e))
        })
        .filter_map(|p| {
            p.strip_prefix(base)
                .ok()
                .map(|r| r.to_string_lossy().replace('\\', "/"))
        })
        .collect();
    out.sort();
    out
}

/// Table III of a `forecast.experiment` run: its `results.json`, the plots beside it, the
/// other such runs to choose from.
pub fn forecast_table(runs: &Runs, root: &Path, id: Option<&str>) -> Result<serde_json::Value, ApiError> {
    let (details, candidates) = pick_run(runs, "forecast.experiment", id)?;
    let dir = output_path(root, &details, "report", "")?;
    let results = read_json(&dir.join("results.json"))?;
    let plots = files_with(&dir, &dir.join("plots"), &["png"]);
    Ok(serde_json::json!({
        "run": details.run,
        "output": {"name": "report", "path": rel_to(root, &dir)},
        "results": results,
        "plots": plots,
        "runs": candidates,
    }))
}

/// Table IV of an `rl.evaluate` run: its `evaluation.json`, plots, and the recordings
/// (artifacts of the run, opened in Rerun's viewer).
pub fn rl_table(runs: &Runs, root: &Path, id: Option<&str>) -> Result<serde_json::Value, ApiError> {
    let (details, candidates) = pick_run(runs, "rl.evaluate", id)?;
    let dir = output_path(root, &details, "report", "")?;
    let evaluation = read_json(&dir.join("evaluation.json"))?;
    let plots = files_with(&dir, &dir, &["png"]);
    let recordings: Vec<serde_json::Value> = details
        .artifacts
        .iter()
        .filter(|a| a.uri.ends_with(".rrd"))
        .map(|a| {
            let file = a.uri.rsplit('/').next().unwrap_or_default();
            serde_json::json!({"artifact": a.name, "file": file, "size": a.size})
        })
        .collect();
    Ok(serde_json::json!({
        "run": details.run,
        "output": {"name": "report", "path": rel_to(root, &dir)},
        "evaluation": evaluation,
        "plots": plots,
        "recordings": recordings,
        "runs": candidates,
    }))
}

fn rel_to(root: &Path, path: &Path) -> String {
    let root = root.canonicalize().unwrap_or_else(|_| root.to_path_buf());
    path.strip_prefix(&root)
        .unwrap_or(path)
        .to_string_lossy()
        .into_owned()
}

/// The folder a dataset version's files live in, when it is inside the project: the
/// location itself if a folder, else the folder of its Parquet file.
fn dataset_dir(root: &Path, row: &DatasetRow) -> Option<PathBuf> {
    let loc = root.join(row.location.trim_start_matches("file://"));
    let dir = if loc.is_dir() {
        loc
    } else {
        loc.parent()?.to_path_buf()
    };
    inside(root, &dir).ok()
}

/// The files that are the dataset: its folder's when it has a manifest (`dataset.json`),
/// else only the registered file (a lone Parquet file shares its folder with others).
fn dataset_files(root: &Path, row: &DatasetRow, dir: &Path) -> Vec<String> {
    if dir.join("dataset.json").is_file() {
        return files_with(dir, dir, &["png", "md", "json", "parquet", "csv"]);
    }
    let loc = root.join(row.location.trim_start_matches("file://"));
    match (inside(dir, &loc), loc.file_name()) {
        (Ok(real), Some(name)) if real.is_file() => vec![name.to_string_lossy().into_owned()],
        _ => Vec::new(),
    }
}

/// Whether the files on disk are this version: a dataset folder's `dataset.json` names its
/// version; a lone Parquet file is taken as the newest registered version.
fn on_disk_version(dir: &Path) -> Option<String> {
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("dataset.json")).ok()?).ok()?;
    meta["version"].as_str().map(str::to_string)
}

/// Every dataset of the registry: name, versions newest first.
pub fn datasets(runs: &Runs, root: &Path) -> Result<serde_json::Value, ApiError> {
    let rows = runs.datasets()?;
    let mut by_name: BTreeMap<&str, Vec<&DatasetRow>> = BTreeMap::new();
    for r in &rows {
        by_name.entry(&r.name).or_default().push(r);
    }
    let list: Vec<serde_json::Value> = by_name
        .into_iter()
        .map(|(name, versions)| {
            let latest = versions[0];
            let dir = dataset_dir(root, latest);
            let card = dir.as_ref().is_some_and(|d| d.join("card.md").is_file());
            serde_json::json!({
                "name": name,
                "latest": latest.version,
                "rows": latest.rows,
                "location": latest.location,
                "created_at": latest.created_at,
                "versions": versions.len(),
                "card": card,
            })
        })
        .collect();
    Ok(serde_json::json!({"datasets": list}))
}

/// One dataset: its versions (with the run that made each), the card, statistics and
/// manifest of the version on disk, and the files that can be shown.
pub fn dataset(runs: &Runs, root: &Path, name: &str) -> Result<serde_json::Value, ApiError> {
    check_name(name)?;
    let rows = runs.datasets()?;
    let versions: Vec<&DatasetRow> = rows.iter().filter(|r| r.name == name).collect();
    let Some(latest) = versions.first() else {
        return Err(ApiError::not_found(format!(
            "no dataset `{name}` in the registry"
        )));
    };
    let dir = dataset_dir(root, latest);
    let disk = dir.as_deref().and_then(on_disk_version);
    let files = dir
        .as_ref()
        .map(|d| dataset_files(root, latest, d))
        .unwrap_or_default();
    let read = |f: &str| {
        dir.as_ref()
            .filter(|_| files.iter().any(|x| x == f))
            .and_then(|d| std::fs::read_to_string(d.join(f)).ok())
    };
    let json = |f: &str| read(f).and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok());
    let schema: serde_json::Value = serde_json::from_str(&latest.schema_json)
        .unwrap_or(serde_json::Value::String(latest.schema_json.clone()));
    Ok(serde_json::json!({
        "name": name,
        "location": latest.location,
        "folder": dir.as_ref().map(|d| rel_to(root, d)),
        "on_disk": disk.clone().unwrap_or_else(|| latest.version.clone()),
        "schema": schema,
        "versions": versions.iter().map(|v| serde_json::json!({
            "version": v.version,
            "rows": v.rows,
            "run_id": v.run_id,
            "created_at": v.created_at,
            "metadata": v.metadata,
            "on_disk": disk.as_deref().map_or(v.version == latest.version, |d| d == v.version),
        })).collect::<Vec<_>>(),
        "card": read("card.md"),
        "manifest": json("dataset.json"),
        "stats": json("stats.json"),
        "map_legend": files.iter().any(|f| f == "map.png").then(|| {
            firecast_dataset::card::MAP_LEGEND
                .iter()
                .map(|(label, [r, g, b])| {
                    serde_json::json!({"label": label, "color": format!("#{r:02x}{g:02x}{b:02x}")})
                })
                .collect::<Vec<_>>()
        }),
        "files": files,
    }))
}

/// A file of a dataset's folder (its card, map, statistics): only files the listing shows.
pub fn dataset_file(runs: &Runs, root: &Path, name: &str, file: &str) -> Result<PathBuf, ApiError> {
    check_name(name)?;
    let rows = runs.datasets()?;
    let latest = rows
        .iter()
        .find(|r| r.name == name)
        .ok_or_else(|| ApiError::not_found(format!("no dataset `{name}` in the registry")))?;
    let dir = dataset_dir(root, latest)
        .ok_or_else(|| ApiError::not_found(format!("dataset `{name}` has no folder in the project")))?;
    let listed = dataset_files(root, latest, &dir);
    if !listed.iter().any(|f| f == file) {
        return Err(ApiError::not_found(format!(
            "dataset `{name}` has no file `{}`",
            file.chars().take(64).collect::<String>()
        )));
    }
    inside(&dir, &dir.join(file))
}

fn check_name(name: &str) -> Result<(), ApiError> {
    if name.is_empty()
        || name.len() > 200
        || !name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"-_.".contains(&b))
    {
        return Err(ApiError::bad(format!(
            "`{}` is not a dataset name",
            name.chars().take(64).collect::<String>()
        )));
    }
    Ok(())
}

/// Two-sided 95 % Student t quantiles for 1–30 degrees of freedom (then the normal 1.96).
const T95: [f64; 30] = [
    12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131,
    2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042,
];

/// Mean and 95 % t interval of `xs` (no interval for one value).
pub fn mean_interval(xs: &[f64]) -> (f64, Option<(f64, f64)>) {
    let n = xs.len();
    let mean = xs.iter().sum::<f64>() / n.max(1) as f64;
    if n < 2 {
        return (mean, None);
    }
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let t = T95.get(n - 2).copied().unwrap_or(1.96);
    let half = t * (var / n as f64).sqrt();
    (mean, Some((mean - half, mean + half)))
}

/// Runs grouped by the value of one parameter (by dotted name): per group and metric, the
/// mean of the runs' last values and its 95 % interval over the group (seeds, mostly).
pub fn group(details: &[RunDetails], param: &str) -> serde_json::Value {
    let mut groups: BTreeMap<String, Vec<&RunDetails>> = BTreeMap::new();
    for d in details {
        let mut flat = BTreeMap::new();
        crate::runs::flatten("", &d.run.params, &mut flat);
        let value = match flat.get(param) {
            None => "(not set)".to_string(),
            Some(serde_json::Value::String(text)) => text.clone(),
            Some(other) => other.to_string(),
        };
        groups.entry(value).or_default().push(d);
    }
    let out: Vec<serde_json::Value> = groups
        .into_iter()
        .map(|(value, members)| {
            let mut metrics: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
            for d in &members {
                for m in &d.metrics {
                    metrics.entry(&m.key).or_default().push(m.last);
                }
            }
            let metrics: serde_json::Map<String, serde_json::Value> = metrics
                .into_iter()
                .map(|(k, xs)| {
                    let (mean, ci) = mean_interval(&xs);
                    (
                        k.to_string(),
                        serde_json::json!({"n": xs.len(), "mean": mean, "low": ci.map(|c| c.0), "high": ci.map(|c| c.1)}),
                    )
                })
                .collect();
            serde_json::json!({
                "value": value,
                "runs": members.iter().map(|d| &d.run.run_id).collect::<Vec<_>>(),
                "metrics": metrics,
            })
        })
        .collect();
    serde_json::json!({"param": param, "groups": out})
}

/// A run id from a query, checked.
pub fn run_param(id: Option<&str>) -> Result<Option<&str>, ApiError> {
    match id.filter(|s| !s.is_empty()) {
        Some(id) => check_run_id(id).map(|()| Some(id)),
        None => Ok(None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intervals_follow_student() {
        let (m, ci) = mean_interval(&[1.0, 2.0, 3.0]);
        assert!((m - 2.0).abs() < 1e-12);
        let (lo, hi) = ci.expect("three values have an interval");
        // s = 1, n = 3: half width 4.303 / sqrt(3).
        assert!((hi - 2.0 - 4.303 / 3f64.sqrt()).abs() < 1e-9, "{lo} {hi}");
        assert_eq!(mean_interval(&[5.0]).1, None);
    }

    #[test]
    fn dataset_names_are_checked() {
        assert!(check_name("demo-ignitions-paper").is_ok());
        for bad in ["", "../x", "a/b", "a b"] {
            assert!(check_name(bad).is_err(), "{bad}");
        }
    }
}
