//! `firecast runs list|show|compare` and `firecast query`.

use std::process::ExitCode;

use clap::Subcommand;
use firecast_registry::{Registry, RunFilter};

use crate::output;
use crate::settings::Settings;

#[derive(Debug, Subcommand)]
pub enum RunsCommand {
    /// Runs, newest first.
    List {
        /// Only runs of this pipeline.
        #[arg(long)]
        pipeline: Option<String>,
        /// Only runs of this stage (or foreach base).
        #[arg(long)]
        stage: Option<String>,
        /// Only runs with this status (running, succeeded, failed, restored, or crashed: left running by a process that is gone).
        #[arg(long)]
        status: Option<String>,
        /// At most this many runs.
        #[arg(long, default_value_t = 50)]
        limit: usize,
    },
    /// One run: params, metrics (last/min/max), artifacts, lineage, and its stage runs.
    Show {
        /// Run id or a unique prefix of one.
        run: String,
    },
    /// Several runs side by side: params that differ, and metrics (last, min, max).
    Compare {
        /// Run ids (or unique prefixes), two or more.
        #[arg(required = true, num_args = 2..)]
        runs: Vec<String>,
        /// Show every param, not only those that differ.
        #[arg(long)]
        all: bool,
        /// Only metrics whose key contains this text (repeatable: any of them).
        #[arg(long)]
        metric: Vec<String>,
    },
}

pub fn run(settings: &Settings, command: RunsCommand) -> anyhow::Result<ExitCode> {
    let registry = Registry::open(&settings.registry)?;
    match command {
        RunsCommand::List {
            pipeline,
            stage,
            status,
            limit,
        } => {
            let runs = registry.list_runs(&RunFilter {
                pipeline,
                stage,
                status,
                limit: Some(limit),
            })?;
            if settings.json {
                output::print_json(&runs)?;
            } else {
                let mut table = output::table(&[
                    "run", "pipeline", "stage", "kind", "status", "started", "time", "parent",
                ]);
                for r in &runs {
                    table.add_row(vec![
                        r.run_id.clone(),
                        r.pipeline.clone(),
                        r.stage.clone().unwrap_or_else(|| "(pipeline)".into()),
                        r.kind.clone(),
                        r.status.clone(),
                        r.started_at.clone(),
                        output::seconds(r.duration_secs),
                        r.parent_run_id.clone().unwrap_or_default(),
                    ]);
                }
                output::print_table(&table)?;
                println!("{} runs (registry {})", runs.len(), settings.registry.display());
            }
        }
        RunsCommand::Show { run } => {
            let details = registry.run_details(&run)?;
            if settings.json {
                output::print_json(&details)?;
            } else {
                let r = &details.run;
                println!("run        {}", r.run_id);
                println!("pipeline   {}", r.pipeline);
                if let Some(stage) = &r.stage {
                    println!(
                        "stage      {stage} ({} v{})",
                        r.kind,
                        r.kind_version.unwrap_or_default()
                    );
                }
                println!("status     {}", r.status);
                println!(
                    "started    {}  ({})",
                    r.started_at,
                    output::seconds(r.duration_secs)
                );
                if let Some(p) = &r.parent_run_id {
                    println!("parent     {p}");
                }
                if let Some(c) = &r.git_commit {
                    println!("commit     {c}");
                }
                if let Some(k) = &r.cache_key {
                    println!("cache key  {k}");
                }
                if let Some(e) = &r.error {
                    println!("error      {e}");
                }
                println!("params     {}", serde_json::to_string_pretty(&r.params)?);
                if !details.metrics.is_empty() {
                    let mut table = output::table(&["metric", "n", "last", "min (step)", "max (step)"]);
                    for m in &details.metrics {
                        table.add_row(vec![
                            m.key.clone(),
                            m.count.to_string(),
                            format!("{} @{}", m.last, m.last_step),
                            format!("{} @{}", m.min, m.min_step),
                            format!("{} @{}", m.max, m.max_step),
                        ]);
                    }
                    output::print_table(&table)?;
                }
                if !details.lineage.is_empty() {
                    let mut table = output::table(&["direction", "name", "path", "hash", "bytes"]);
                    for l in &details.lineage {
                        table.add_row(vec![
                            l.direction.clone(),
                            l.name.clone(),
                            l.uri.clone(),
                            l.hash.chars().take(12).collect(),
                            l.size.to_string(),
                        ]);
                    }
                    output::print_table(&table)?;
                }
                if !details.artifacts.is_empty() {
                    let mut table = output::table(&["artifact", "uri", "bytes"]);
                    for a in &details.artifacts {
                        table.add_row(vec![a.name.clone(), a.uri.clone(), a.size.to_string()]);
                    }
                    output::print_table(&table)?;
                }
                if !details.children.is_empty() {
                    let mut table = output::table(&["stage run", "stage", "status", "time"]);
                    for c in &details.children {
                        table.add_row(vec![
                            c.run_id.clone(),
                            c.stage.clone().unwrap_or_default(),
                            c.status.clone(),
                            output::seconds(c.duration_secs),
                        ]);
                    }
                    output::print_table(&table)?;
                }
            }
        }
        RunsCommand::Compare { runs, all, metric } => {
            let details = runs
                .iter()
                .map(|r| registry.stage_run_details(r))
                .collect::<Result<Vec<_>, _>>()?;
            compare(settings, &details, all, &metric)?;
        }
    }
    Ok(ExitCode::SUCCESS)
}

pub fn query(settings: &Settings, sql: &str) -> anyhow::Result<ExitCode> {
    let registry = Registry::open(&settings.registry)?;
    let result = registry.query(sql)?;
    if settings.json {
        let rows: Vec<serde_json::Map<String, serde_json::Value>> = result
            .rows
            .iter()
            .map(|row| result.columns.iter().cloned().zip(row.iter().cloned()).collect())
            .collect();
        output::print_json(&rows)?;
    } else {
        let header: Vec<&str> = result.columns.iter().map(String::as_str).collect();
        let mut table = output::table(&header);
        for row in &result.rows {
            table.add_row(
                row.iter()
                    .map(|v| match v {
                        serde_json::Value::String(s) => s.clone(),
                        serde_json::Value::Null => "NULL".into(),
                        other => other.to_string(),
                    })
                    .collect::<Vec<_>>(),
            );
        }
        output::print_table(&table)?;
        println!("{} rows", result.rows.len());
    }
    Ok(ExitCode::SUCCESS)
}

/// `runs compare`: params that differ; each metric's mean over its steps (over seeds for an
/// experiment's test metrics, which are logged at step = seed) with its range and count, and
/// for two runs the difference of the means.
fn compare(
    settings: &Settings,
    details: &[firecast_registry::RunDetails],
    all: bool,
    filters: &[String],
) -> anyhow::Result<()> {
    let rows: Vec<_> = details.iter().map(|d| d.run.clone()).collect();
    let params = firecast_registry::params_side_by_side(&rows);
    let mut metric_keys: Vec<String> = details
        .iter()
        .flat_map(|d| d.metrics.iter().map(|m| m.key.clone()))
        .filter(|k| filters.is_empty() || filters.iter().any(|f| k.contains(f.as_str())))
        .collect();
    metric_keys.sort();
    metric_keys.dedup();
    let find =
        |d: &firecast_registry::RunDetails, key: &str| d.metrics.iter().find(|m| m.key == key).cloned();
    // Difference of the means, second run minus first; only for a pair.
    let delta = |key: &str| -> Option<f64> {
        match details {
            [a, b] => Some(find(b, key)?.mean - find(a, key)?.mean),
            _ => None,
        }
    };
    if settings.json {
        let differing: serde_json::Map<String, serde_json::Value> = params
            .iter()
            .filter(|(_, v)| all || v.iter().any(|x| x != &v[0]))
            .map(|(k, v)| (k.clone(), serde_json::json!(v)))
            .collect();
        let metrics: serde_json::Map<String, serde_json::Value> = metric_keys
            .iter()
            .map(|k| {
                let per_run: Vec<_> = details.iter().map(|d| find(d, k)).collect();
                (
                    k.clone(),
                    serde_json::json!({"runs": per_run, "delta_mean": delta(k)}),
                )
            })
            .collect();
        output::print_json(&serde_json::json!({
            "runs": rows,
            "params": differing,
            "metrics": metrics,
        }))?;
        return Ok(());
    }
    let pair = details.len() == 2;
    let mut header = vec!["".to_string()];
    header.extend(rows.iter().map(|r| r.run_id.clone()));
    if pair {
        header.push("Δ mean (2nd − 1st)".into());
    }
    let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut table = output::table(&header_refs);
    let mut add = |label: String, mut cells: Vec<String>, extra: Option<String>| {
        let mut row = vec![label];
        row.append(&mut cells);
        if pair {
            row.push(extra.unwrap_or_default());
        }
        table.add_row(row);
    };
    add(
        "pipeline".into(),
        rows.iter().map(|r| r.pipeline.clone()).collect(),
        None,
    );
    add(
        "stage".into(),
        rows.iter().map(|r| r.stage.clone().unwrap_or_default()).collect(),
        None,
    );
    add(
        "status".into(),
        rows.iter().map(|r| r.status.clone()).collect(),
        None,
    );
    add(
        "time".into(),
        rows.iter().map(|r| output::seconds(r.duration_secs)).collect(),
        None,
    );
    let mut same = 0;
    for (key, values) in &params {
        let differs = values.iter().any(|v| v != &values[0]);
        if !differs {
            same += 1;
        }
        if all || differs {
            let marker = if differs { "≠ " } else { "" };
            add(
                format!("{marker}param {key}"),
                values
                    .iter()
                    .map(|v| output::ellipsize(v.as_deref().unwrap_or("—"), 40))
                    .collect(),
                None,
            );
        }
    }
    for key in &metric_keys {
        add(
            format!("{key} (mean [min, max] n)"),
            details
                .iter()
                .map(|d| {
                    find(d, key).map_or_else(
                        || "—".to_string(),
                        |m| format!("{:.4} [{:.4}, {:.4}] {}", m.mean, m.min, m.max, m.count),
                    )
                })
                .collect(),
            delta(key).map(|d| format!("{d:+.4}")),
        );
    }
    output::print_table(&table)?;
    if !all && same > 0 {
        println!("{same} params are equal in every run (--all shows them)");
    }
    Ok(())
}
