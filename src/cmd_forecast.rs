//! `firecast experiment run|compare` and `firecast forecast predict`.
//!
//! `experiment run` reads an experiment file strictly and runs it as a one-stage pipeline
//! (`forecast.experiment`), so it gets the runner's caching, lockfile, registry run and
//! artifact uploads for free.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args, Subcommand};
use firecast_forecast::experiment::ExperimentResult;
use firecast_forecast::spec::ExperimentSpec;
use firecast_forecast::table::shown_threshold;

use crate::output;
use crate::settings::Settings;

#[derive(Debug, Subcommand)]
pub enum ExperimentCommand {
    /// Run an experiment file (experiments/*.yaml): every model under every protocol,
    /// Table III with intervals, plots, saved models, metrics in the registry.
    Run(RunArgs),
    /// Print and write Table III of one or more finished experiment reports.
    Compare(CompareArgs),
}

#[derive(Debug, Args)]
pub struct RunArgs {
    /// The experiment file.
    pub file: PathBuf,
    #[command(flatten)]
    pub spec: crate::settings::SpecArgs,
}

#[derive(Debug, Args)]
pub struct CompareArgs {
    /// Report folders written by `experiment run` (each holds results.json).
    #[arg(required = true)]
    pub reports: Vec<PathBuf>,
    /// Also write the combined table (Markdown, CSV, JSON) and plots here.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

#[derive(Debug, Subcommand)]
pub enum ForecastCommand {
    /// The day's chance of an ignition at a place and date from a trained model (the paper's
    /// predictWildfire), or at every row of a CSV of points: the model's score and that score
    /// corrected to the training area's usual daily rate, with its multiple of the usual day.
    Predict(PredictArgs),
    /// The day's chance of an ignition at every GRIDMET cell of a region, by every saved seed
    /// of one model of an experiment: a map (PNG, in multiples of the usual day) and its
    /// numbers (JSON: scores and daily chances).
    Map(MapArgs),
}

#[derive(Debug, Args)]
pub struct MapArgs {
    /// An experiment's report folder (results.json and models/).
    #[arg(long, value_name = "DIR")]
    pub experiment: PathBuf,
    /// The model's name in the experiment (its `name`, else its `kind`).
    #[arg(long)]
    pub model: String,
    /// The protocol [default: the experiment's headline].
    #[arg(long)]
    pub protocol: Option<String>,
    /// GRIDMET folder with `<var>_<year>.nc` files covering the input window.
    #[arg(long, value_name = "DIR")]
    pub gridmet: PathBuf,
    /// The day to forecast, YYYY-MM-DD.
    #[arg(long)]
    pub date: String,
    /// `LAT_MIN,LAT_MAX,LON_MIN,LON_MAX` [default: every cell of the files].
    #[arg(long, allow_hyphen_values = true, value_name = "BOX")]
    pub region: Option<String>,
    /// Folder for `map.png` and `map.json`.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    #[arg(long, default_value = "cpu")]
    pub device: String,
    /// libtorch threads.
    #[arg(long, default_value_t = firecast_learn::DEFAULT_THREADS)]
    pub threads: usize,
}

#[derive(Debug, Args)]
pub struct PredictArgs {
    /// A model folder written by an experiment (…/models/<protocol>/<model>/seed-<n>), or
    /// `RUN:<protocol>/<model>[/seed-<n>]`: a model an experiment run (id or unique prefix,
    /// as `runs list` shows) saved to the artifact store, fetched from there.
    #[arg(long, value_name = "DIR|RUN:PROTOCOL/MODEL[/seed-N]")]
    pub model: String,
    /// GRIDMET folder with `<var>_<year>.nc` files covering the input window.
    #[arg(long, value_name = "DIR")]
    pub gridmet: PathBuf,
    /// Latitude of the place, decimal degrees north (WGS84); the GRIDMET cell nearest it is
    /// read. With --lon and --date; or give --points instead.
    #[arg(long, allow_hyphen_values = true)]
    pub lat: Option<f64>,
    /// Longitude of the place, decimal degrees east (west is negative, e.g. -107.4).
    #[arg(long, allow_hyphen_values = true)]
    pub lon: Option<f64>,
    /// The day to forecast, YYYY-MM-DD.
    #[arg(long)]
    pub date: Option<String>,
    /// A CSV with columns lat, lon, date (one query per row) instead of --lat/--lon/--date.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["lat", "lon", "date"])]
    pub points: Option<PathBuf>,
    #[arg(long, default_value = "auto")]
    pub device: String,
    /// libtorch threads.
    #[arg(long, default_value_t = firecast_learn::DEFAULT_THREADS)]
    pub threads: usize,
}

pub fn run_experiment_command(settings: &Settings, command: ExperimentCommand) -> anyhow::Result<ExitCode> {
    match command {
        ExperimentCommand::Run(args) => run(settings, &args),
        ExperimentCommand::Compare(args) => compare(settings, &args),
    }
}

fn run(settings: &Settings, args: &RunArgs) -> anyhow::Result<ExitCode> {
    let file = crate::cmd_pipeline::relative_to_root(settings, &args.file);
    let mut spec = ExperimentSpec::load(&settings.root, &file, &args.spec.set)?;
    if let Some(device) = &args.spec.device {
        spec.device = device.clone();
    }
    if let Some(threads) = args.spec.threads {
        spec.threads = threads;
    }
    let dataset = spec.dataset.take().with_context(|| {
        format!(
            "{}: `dataset`: the experiment names no dataset folder",
            file.display()
        )
    })?;
    if !settings.root.join(&dataset).join("dataset.json").exists() {
        anyhow::bail!(
            "{}: `dataset`: {} is not a dataset folder (no dataset.json); build one with `firecast dataset build` \
             or `cargo xtask demo`",
            file.display(),
            dataset.display()
        );
    }
    let out = args
        .spec
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("experiments/runs").join(&spec.name));
    // A one-stage pipeline: the runner caches, publishes atomically and records the run.
    let stage = serde_json::json!({
        "uses": "forecast.experiment",
        "description": spec.description.clone(),
        "params": serde_json::to_value(&spec)?,
        "inputs": {"dataset": dataset.display().to_string()},
        "outputs": {"report": out.display().to_string()},
    });
    if args.spec.dry_run {
        crate::settings::SpecArgs::print_stage(&stage)?;
        return Ok(ExitCode::SUCCESS);
    }
    let (outcome, secs, run_id) = crate::cmd_pipeline::run_one_stage(
        settings,
        &file,
        "experiment",
        &spec.name,
        stage,
        crate::cmd_pipeline::OneStage {
            description: Some(format!("experiment {} ({})", spec.name, file.display())),
            force: args.spec.force,
            kinds: None,
        },
    )?;
    let result = read_result(&settings.root.join(&out))?;
    if settings.json {
        output::print_json(&result)?;
    } else {
        print_tables(&result)?;
        println!(
            "\nexperiment {}: {} ({:.1}s), report in {} (run {})",
            spec.name,
            outcome,
            secs,
            out.display(),
            run_id
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn read_result(dir: &Path) -> anyhow::Result<ExperimentResult> {
    let path = dir.join("results.json");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {} (not an experiment report?)", path.display()))?;
    serde_json::from_str(&text)
        .with_context(|| format!("{}: not a FireCast experiment result", path.display()))
}

fn cell(r: &firecast_forecast::experiment::ModelResult, k: &str, pct: bool) -> String {
    let v = r.test.get(k).copied().unwrap_or(f64::NAN);
    if !v.is_finite() {
        return "—".into();
    }
    let (s, d) = if pct { (100.0, 1) } else { (1.0, 3) };
    match r.intervals.get(k) {
        Some((lo, hi)) => format!("{:.*} [{:.*}, {:.*}]", d, v * s, d, lo * s, d, hi * s),
        None => format!("{:.*}", d, v * s),
    }
}

/// Table III per protocol, headline first, with the protocol facts and no-skill values.
fn print_tables(result: &ExperimentResult) -> anyhow::Result<()> {
    let mut protocols: Vec<_> = result.protocols.iter().collect();
    protocols.sort_by_key(|p| (p.name != result.headline, p.name.clone()));
    for p in protocols {
        println!(
            "\nTable III — {} — protocol `{}`{}: days {}..{} ({}), {}",
            result.name,
            p.name,
            if p.name == result.headline {
                " (headline)"
            } else {
                ""
            },
            p.days.0,
            p.days.1,
            if p.leaks_future {
                "inputs include days after the predicted date, as in the paper"
            } else {
                "inputs end before the predicted date"
            },
            p.split
        );
        println!(
            "test {} samples, {} positive (prevalence {:.3}); no skill: majority accuracy {:.1} %, AUPRC {:.3}; \
             {:.0} % intervals from {} cluster-bootstrap resamples ({}s); thresholds chosen on validation",
            p.test,
            p.test_positives,
            p.prevalence,
            p.majority_accuracy * 100.0,
            p.prevalence,
            result.level * 100.0,
            result.bootstrap,
            result.cluster
        );
        if let Some(o) = &p.oracle {
            println!(
                "oracle (the synthetic generator's true probabilities): AUROC {:.3}, AUPRC {:.3}; \
                 `of oracle` = (AUROC - 0.5) / (oracle AUROC - 0.5)",
                o.get("auroc").copied().unwrap_or(f64::NAN),
                o.get("auprc").copied().unwrap_or(f64::NAN)
            );
        }
        let mut table = output::table(&[
            "model",
            "family",
            "accuracy %",
            "precision",
            "recall",
            "F1",
            "AUROC",
            "AUPRC",
            "Brier",
            "threshold",
            "seeds",
            "of oracle",
        ]);
        for r in firecast_forecast::table::rows(result, &p.name) {
            table.add_row(vec![
                r.model.clone(),
                r.family.clone(),
                cell(r, "accuracy", true),
                cell(r, "precision", false),
                cell(r, "recall", false),
                cell(r, "f1", false),
                cell(r, "auroc", false),
                cell(r, "auprc", false),
                cell(r, "brier", false),
                r.runs
                    .first()
                    .map_or(String::new(), |s| format!("{:.3}", shown_threshold(s.threshold))),
                r.seeds.len().to_string(),
                r.skill_vs_oracle
                    .as_ref()
                    .and_then(|m| m.get("auroc"))
                    .map_or("—".into(), |v| format!("{:.0} %", v * 100.0)),
            ]);
        }
        output::print_table(&table)?;
        for t in result.paired.iter().filter(|t| t.protocol == p.name) {
            println!(
                "paired: {} vs {} — McNemar p = {:.2e}, DeLong p = {:.2e} (ΔAUROC {:+.3}), ΔAUPRC {:+.3} [{:+.3}, {:+.3}]",
                t.model,
                t.baseline,
                t.mcnemar_p,
                t.delong_p,
                t.delong_auroc_diff,
                t.auprc_diff,
                t.auprc_diff_interval.0,
                t.auprc_diff_interval.1
            );
        }
    }
    Ok(())
}

fn compare(settings: &Settings, args: &CompareArgs) -> anyhow::Result<ExitCode> {
    let mut merged: Option<ExperimentResult> = None;
    for dir in &args.reports {
        let mut r = read_result(&settings.root.join(dir))?;
        if args.reports.len() > 1 {
            for m in &mut r.results {
                m.model = format!("{}:{}", r.name, m.model);
            }
            for p in &mut r.paired {
                p.model = format!("{}:{}", r.name, p.model);
                p.baseline = format!("{}:{}", r.name, p.baseline);
            }
        }
        merged = Some(match merged {
            None => r,
            Some(mut acc) => {
                for p in r.protocols {
                    if !acc.protocols.iter().any(|q| q.name == p.name) {
                        acc.protocols.push(p);
                    }
                }
                acc.results.extend(r.results);
                acc.paired.extend(r.paired);
                acc.name = format!("{} + {}", acc.name, r.name);
                acc
            }
        });
    }
    let result = merged.context("no report given")?;
    if let Some(out) = &args.out {
        let out = settings.root.join(out);
        firecast_forecast::table::write_all(&out, &result)?;
        firecast_forecast::plots::write_tables_only(&out, &result)?;
    }
    if settings.json {
        output::print_json(&result)?;
    } else {
        print_tables(&result)?;
    }
    Ok(ExitCode::SUCCESS)
}

pub fn run_forecast_command(settings: &Settings, command: ForecastCommand) -> anyhow::Result<ExitCode> {
    match command {
        ForecastCommand::Predict(args) => predict(settings, &args),
        ForecastCommand::Map(args) => map(settings, &args),
    }
}

fn map(settings: &Settings, args: &MapArgs) -> anyhow::Result<ExitCode> {
    let region = match &args.region {
        None => None,
        Some(text) => {
            let v: Vec<f64> = text
                .split(',')
                .map(|x| x.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .ok()
                .filter(|v: &Vec<f64>| v.len() == 4)
                .with_context(|| format!("--region `{text}`: expected LAT_MIN,LAT_MAX,LON_MIN,LON_MAX"))?;
            Some([v[0], v[1], v[2], v[3]])
        }
    };
    let device = firecast_forecast::parse_device(&args.device)?;
    firecast_learn::set_threads(args.threads);
    let params = firecast_forecast::stage::PredictParams {
        lat: 0.0,
        lon: 0.0,
        date: args.date.clone(),
        model: args.model.clone(),
        protocol: args.protocol.clone(),
        device: args.device.clone(),
        threads: args.threads,
        map_radius_deg: None,
    };
    let experiment = settings.root.join(&args.experiment);
    let gridmet = settings.root.join(&args.gridmet);
    let map = firecast_forecast::stage::region_map(&experiment, &gridmet, &params, region, device)?;
    let out = settings.root.join(&args.out);
    let staged = firecast_fs::TempPath::dir(&out)?;
    firecast_fs::write_atomically(&staged.path().join("map.json"), &serde_json::to_vec(&map)?)?;
    firecast_forecast::stage::map_png(&map, &staged.path().join("map.png"))?;
    staged.publish()?;
    let values: Vec<f64> = map.probability.iter().flatten().flatten().copied().collect();
    let daily: Vec<f64> = map
        .daily_probability
        .iter()
        .flatten()
        .flatten()
        .flatten()
        .copied()
        .collect();
    let above = values.iter().filter(|&&p| p >= map.threshold).count();
    if settings.json {
        output::print_json(&serde_json::json!({
            "out": out, "cells": values.len(), "above_threshold": above, "threshold": map.threshold,
            "max": values.iter().copied().fold(0.0, f64::max),
            "max_daily_probability": (!daily.is_empty()).then(|| daily.iter().copied().fold(0.0, f64::max)),
            "usual_daily": map.usual_daily,
        }))?;
    } else {
        println!(
            "{} on {}: {} cells ({} x {}), {} with a score at or above the alert threshold {:.3}, max score {:.3} -> {}/map.png, map.json",
            map.model,
            map.date,
            values.len(),
            map.lats.len(),
            map.lons.len(),
            above,
            map.threshold,
            values.iter().copied().fold(0.0, f64::max),
            args.out.display()
        );
        if let Some(u) = map.usual_daily {
            println!(
                "the day's chance of an ignition per cell: up to {:.3} % ({:.1} x the training area's usual {:.3} % a cell-day)",
                daily.iter().copied().fold(0.0, f64::max) * 100.0,
                daily.iter().copied().fold(0.0, f64::max) / u,
                u * 100.0
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn read_points(path: &Path) -> anyhow::Result<Vec<firecast_forecast::predict::Query>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut lines = text.lines().enumerate();
    let (_, header) = lines
        .next()
        .with_context(|| format!("{}: empty file", path.display()))?;
    let cols: Vec<String> = header.split(',').map(|c| c.trim().to_lowercase()).collect();
    let find = |name: &str| {
        cols.iter()
            .position(|c| c == name)
            .with_context(|| format!("{}:1: no `{name}` column (need lat, lon, date)", path.display()))
    };
    let (ilat, ilon, idate) = (find("lat")?, find("lon")?, find("date")?);
    let mut out = Vec::new();
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let get = |k: usize, name: &str| {
            f.get(k)
                .copied()
                .with_context(|| format!("{}:{}: missing `{name}`", path.display(), i + 1))
        };
        let num = |k: usize, name: &str| -> anyhow::Result<f64> {
            let v = get(k, name)?;
            v.parse()
                .with_context(|| format!("{}:{}: `{name}` = `{v}` is not a number", path.display(), i + 1))
        };
        out.push(firecast_forecast::predict::Query {
            lat: num(ilat, "lat")?,
            lon: num(ilon, "lon")?,
            date: get(idate, "date")?.to_string(),
        });
    }
    Ok(out)
}

fn predict(settings: &Settings, args: &PredictArgs) -> anyhow::Result<ExitCode> {
    let queries = match (&args.points, args.lat, args.lon, &args.date) {
        (Some(points), ..) => read_points(&settings.root.join(points))?,
        (None, Some(lat), Some(lon), Some(date)) => vec![firecast_forecast::predict::Query {
            lat,
            lon,
            date: date.clone(),
        }],
        _ => anyhow::bail!("give --lat, --lon and --date, or --points FILE.csv"),
    };
    let device = firecast_forecast::parse_device(&args.device)?;
    firecast_learn::check_threads(args.threads).map_err(|m| anyhow::anyhow!("--threads: {m}"))?;
    firecast_learn::set_threads(args.threads);
    let model_dir = resolve_model(settings, &args.model)?;
    let bundle = firecast_forecast::bundle::load(&model_dir, device)?;
    let gridmet = settings.root.join(&args.gridmet);
    let mut answers = firecast_forecast::predict::predict(&bundle, &gridmet, &queries, device)?;
    firecast_forecast::predict::with_daily(&mut answers, &bundle, &gridmet)?;
    if settings.json {
        output::print_json(&answers)?;
        return Ok(ExitCode::SUCCESS);
    }
    let mut table = output::table(&[
        "lat",
        "lon",
        "date",
        "P(ignition) that day",
        "x usual day",
        "model score",
        "alert threshold",
        "score above it",
        "GRIDMET cell",
    ]);
    let pct = |p: Option<f64>| p.map_or_else(|| "-".to_string(), |p| format!("{:.3} %", p * 100.0));
    for a in &answers {
        table.add_row(vec![
            format!("{:.4}", a.lat),
            format!("{:.4}", a.lon),
            a.date.clone(),
            pct(a.daily_probability),
            a.daily_probability
                .zip(a.usual_daily)
                .map_or_else(|| "-".to_string(), |(d, u)| format!("{:.1}", d / u)),
            format!("{:.3}", a.probability),
            format!("{:.3}", a.threshold),
            if a.ignition_expected { "yes" } else { "no" }.to_string(),
            format!("{:.4}, {:.4}", a.cell_lat, a.cell_lon),
        ]);
    }
    output::print_table(&table)?;
    if let Some(a) = answers.first() {
        println!(
            "model {} ({}, protocol {}, inputs days {}..{}), dataset {} {}",
            a.model, a.kind, a.protocol, a.input_days.0, a.input_days.1, a.dataset, a.dataset_version
        );
        match a.usual_daily {
            Some(u) => println!(
                "the model score is on the training samples' scale (not a daily chance); P(ignition) that day is \
                 it corrected to the training area's usual {:.3} % a cell-day",
                u * 100.0
            ),
            None => println!(
                "the model score is on the training samples' scale, not a daily chance; no daily probability: {}",
                a.daily_unavailable
                    .as_deref()
                    .unwrap_or(firecast_forecast::daily::NOT_RECORDED)
            ),
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// A model folder, or a model an experiment run saved to the artifact store (fetched into
/// `.firecast/cache/models/<run>/…`, checked against the registry's hashes).
fn resolve_model(settings: &Settings, spec: &str) -> anyhow::Result<PathBuf> {
    let as_dir = settings.root.join(spec);
    if as_dir.is_dir() {
        return Ok(as_dir);
    }
    if !spec.contains(':') {
        anyhow::bail!(
            "--model {}",
            firecast_registry::saved_models::SavedModelError::NotAModelName(spec.into())
        );
    }
    let registry = firecast_registry::Registry::open(&settings.registry)?;
    let store = firecast_store::ArtifactStore::open(&settings.store, &settings.root)?;
    let cache = settings.root.join(".firecast/cache/models");
    firecast_registry::saved_models::fetch_saved_model(&registry, &store, &cache, spec)
        .map_err(|e| anyhow::anyhow!("--model `{spec}`: {e}"))
}
