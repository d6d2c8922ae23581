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
    /// Override a key: `-S seeds=[1,2,3]`, `-S models.3.params.max_epochs=5` (value read as YAML).
    #[arg(short = 'S', long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Torch device: auto, cpu, cuda, cuda:N (overrides the file's `device`).
    #[arg(long)]
    pub device: Option<String>,
    /// Report folder [default: experiments/runs/<name>].
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Run even when nothing changed.
    #[arg(short, long)]
    pub force: bool,
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
    /// Ignition probability of a place and date from a trained model (the paper's
    /// predictWildfire), or of every row of a CSV of points.
    Predict(PredictArgs),
}

#[derive(Debug, Args)]
pub struct PredictArgs {
    /// A model folder written by an experiment (…/models/<protocol>/<model>/seed-<n>).
    #[arg(long, value_name = "DIR")]
    pub model: PathBuf,
    /// GRIDMET folder with `<var>_<year>.nc` files covering the input window.
    #[arg(long, value_name = "DIR")]
    pub gridmet: PathBuf,
    #[arg(long, allow_hyphen_values = true)]
    pub lat: Option<f64>,
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
}

pub fn run_experiment_command(settings: &Settings, command: ExperimentCommand) -> anyhow::Result<ExitCode> {
    match command {
        ExperimentCommand::Run(args) => run(settings, &args),
        ExperimentCommand::Compare(args) => compare(settings, &args),
    }
}

fn run(settings: &Settings, args: &RunArgs) -> anyhow::Result<ExitCode> {
    let file = crate::cmd_pipeline::relative_to_root(settings, &args.file);
    let mut spec = ExperimentSpec::load(&settings.root, &file, &args.set)?;
    if let Some(device) = &args.device {
        spec.device = device.clone();
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
    let (outcome, secs, run_id) = crate::cmd_pipeline::run_one_stage(
        settings,
        &file,
        "experiment",
        &spec.name,
        stage,
        Some(format!("experiment {} ({})", spec.name, file.display())),
        args.force,
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
    }
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
    let bundle = firecast_forecast::bundle::load(&settings.root.join(&args.model), device)?;
    let answers =
        firecast_forecast::predict::predict(&bundle, &settings.root.join(&args.gridmet), &queries, device)?;
    if settings.json {
        output::print_json(&answers)?;
        return Ok(ExitCode::SUCCESS);
    }
    let mut table = output::table(&[
        "lat",
        "lon",
        "date",
        "P(ignition)",
        "threshold",
        "ignition expected",
        "GRIDMET cell",
    ]);
    for a in &answers {
        table.add_row(vec![
            format!("{:.4}", a.lat),
            format!("{:.4}", a.lon),
            a.date.clone(),
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
    }
    Ok(ExitCode::SUCCESS)
}
