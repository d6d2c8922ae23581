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
    /// libtorch and XGBoost threads (overrides the file's `threads`; part of the result and its cache key).
    #[arg(long)]
    pub threads: Option<usize>,
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
    /// The day's ignition probability at every GRIDMET cell of a region, by every saved seed
    /// of one model of an experiment: a map (PNG) and its numbers (JSON).
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
    let mut spec = ExperimentSpec::load(&settings.root, &file, &args.set)?;
    if let Some(device) = &args.device {
        spec.device = device.clone();
    }
    if let Some(threads) = args.threads {
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
        crate::cmd_pipeline::OneStage {
            description: Some(format!("experiment {} ({})", spec.name, file.display())),
            force: args.force,
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
    let above = values.iter().filter(|&&p| p >= map.threshold).count();
    if settings.json {
        output::print_json(&serde_json::json!({
            "out": out, "cells": values.len(), "above_threshold": above, "threshold": map.threshold,
            "max": values.iter().copied().fold(0.0, f64::max),
        }))?;
    } else {
        println!(
            "{} on {}: {} cells ({} x {}), {} at or above the threshold {:.3}, max {:.3} -> {}/map.png, map.json",
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

/// `firecast bench forecast`.
#[derive(Debug, Args)]
pub struct BenchForecastArgs {
    /// The experiment whose dataset, protocol and hyper-parameters are compared.
    #[arg(long, default_value = "experiments/table3.yaml", value_name = "FILE")]
    pub experiment: PathBuf,
    /// Override a key of the experiment: `-S models.6.params.n_estimators=20` (value as YAML).
    #[arg(short = 'S', long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// The protocol (days and split) of the experiment to use.
    #[arg(long, default_value = "paper")]
    pub protocol: String,
    /// Threads for both sides (libtorch, rayon, XGBoost, scikit-learn, PyTorch) [default: all cores].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Windows of the full-size run to project to (the published CSV has 66,568).
    #[arg(long, default_value_t = firecast_forecast::bench::PUBLISHED_WINDOWS, value_name = "N")]
    pub project_to: usize,
    /// Seed of every fit, both sides.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Timed training steps of the CNN-BiLSTM throughput comparison (each side).
    #[arg(long, default_value_t = 20)]
    pub steps: usize,
    /// Untimed warm-up steps before them (each side).
    #[arg(long, default_value_t = 3)]
    pub warmup: usize,
    /// Throughput rounds, alternating tch and PyTorch; the best round of each is compared.
    #[arg(long, default_value_t = 3)]
    pub rounds: usize,
    /// Timed training steps of each other network, for the projection.
    #[arg(long, default_value_t = 5)]
    pub projection_steps: usize,
    /// Python with scikit-learn, xgboost and torch [default: $FIRECAST_VENV, ./.venv, python3].
    #[arg(long, value_name = "PATH")]
    pub python: Option<PathBuf>,
    /// Keep the exported arrays, configs and scripts in this folder [default: a temporary one,
    /// removed afterwards].
    #[arg(long, value_name = "DIR")]
    pub keep: Option<PathBuf>,
    /// Internal: run one tch throughput measurement (JSON job) and print it. The bench runs
    /// its tch rounds this way, in a fresh process like the Python side's.
    #[arg(long, hide = true, value_name = "JSON")]
    pub throughput_job: Option<String>,
}

/// Human-readable seconds.
fn duration(s: f64) -> String {
    if !s.is_finite() {
        "—".into()
    } else if s < 1.0 {
        format!("{:.0} ms", s * 1000.0)
    } else if s < 120.0 {
        format!("{s:.1} s")
    } else if s < 7200.0 {
        format!("{:.1} min", s / 60.0)
    } else {
        format!("{:.1} h", s / 3600.0)
    }
}

/// The flattened baselines against scikit-learn / xgboost on the same exported split, the
/// networks' parameter counts and the CNN-BiLSTM's training speed against PyTorch eager, and
/// the full-size run projected. Exit status 1 when a baseline is out of bounds or a count
/// differs (the tables are printed either way).
pub fn bench_forecast(settings: &Settings, args: &BenchForecastArgs) -> anyhow::Result<ExitCode> {
    use firecast_forecast::bench::{self, BenchOptions};
    if let Some(job) = &args.throughput_job {
        let job: bench::ThroughputJob = serde_json::from_str(job).context("--throughput-job: not a job")?;
        // One line: the bench reads the last line of the worker's output.
        println!("{}", serde_json::to_string(&bench::run_throughput_job(&job)?)?);
        return Ok(ExitCode::SUCCESS);
    }
    let file = crate::cmd_pipeline::relative_to_root(settings, &args.experiment);
    let spec = ExperimentSpec::load(&settings.root, &file, &args.set)?;
    let dataset = spec.dataset.clone().with_context(|| {
        format!(
            "{}: `dataset`: the experiment names no dataset folder",
            file.display()
        )
    })?;
    let windows = firecast_forecast::data::Windows::load(&settings.root.join(&dataset))?;
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from))
        .max(1);
    let (work, temporary) = match &args.keep {
        Some(dir) => (settings.root.join(dir), false),
        None => (
            std::env::temp_dir().join(format!("firecast-bench-forecast-{}", std::process::id())),
            true,
        ),
    };
    let opts = BenchOptions {
        protocol: args.protocol.clone(),
        threads,
        seed: args.seed,
        project_to: args.project_to,
        throughput_steps: args.steps.max(1),
        warmup_steps: args.warmup,
        rounds: args.rounds.max(1),
        // The tch rounds run in fresh processes of this program, as the Python rounds do.
        tch_worker: std::env::current_exe().ok().map(|exe| {
            (
                exe,
                vec!["bench".into(), "forecast".into(), "--throughput-job".into()],
            )
        }),
        projection_steps: args.projection_steps.max(1),
        python: firecast_dataset::bench::find_python(args.python.as_deref(), &settings.root),
        work: work.clone(),
    };
    eprintln!(
        "bench forecast: {} on {} ({} windows), protocol {}, {threads} threads, Python {}",
        file.display(),
        dataset.display(),
        windows.len(),
        args.protocol,
        opts.python.display()
    );
    let log = |line: &str| eprintln!("  {line}");
    let result = firecast_learn::exclusive(|| bench::run(&spec, &windows, &opts, &log));
    if temporary {
        let _ = std::fs::remove_dir_all(&work);
    }
    let report = result?;
    let failed = !report.all_within_bounds || !report.all_parameters_equal;
    if settings.json {
        output::print_json(&report)?;
    } else {
        print_bench(&report)?;
    }
    Ok(if failed {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

fn print_bench(r: &firecast_forecast::bench::ForecastBench) -> anyhow::Result<()> {
    let v = |k: &str| r.versions.get(k).cloned().unwrap_or_else(|| "?".into());
    println!(
        "Fidelity — experiment {}, dataset {} {}, protocol `{}` (days {}..{}, {}): train {}, test {}; \
         flattened inputs {} ({} variables x {} days); seed {}, {} threads, {}",
        r.experiment,
        r.dataset,
        r.dataset_version,
        r.protocol,
        r.days.0,
        r.days.1,
        r.split,
        r.train,
        r.test,
        r.flat_inputs,
        r.variables,
        r.flat_inputs / r.variables.max(1),
        r.seed,
        r.threads,
        r.device
    );
    println!(
        "references: scikit-learn {}, xgboost {}, numpy {}, Python {} — same exported arrays, same hyper-parameters",
        v("sklearn"),
        v("xgboost"),
        v("numpy"),
        v("python")
    );
    let mut table = output::table(&[
        "model",
        "reference",
        "FireCast acc %",
        "ref acc %",
        "Δ pts",
        "FireCast acc % @thr",
        "ref acc % @thr",
        "Δ pts @thr",
        "FireCast AUROC",
        "ref AUROC",
        "Δ AUROC",
        "within ±1.5 pts (both) / ±0.015",
        "FireCast fit",
        "ref fit",
        "ref / FireCast",
    ]);
    for b in &r.baselines {
        table.add_row(vec![
            if b.from_experiment {
                b.model.clone()
            } else {
                format!("{} (defaults)", b.model)
            },
            b.reference.clone(),
            format!("{:.2}", b.firecast_accuracy * 100.0),
            format!("{:.2}", b.reference_accuracy * 100.0),
            format!("{:+.2}", b.accuracy_delta_points),
            format!(
                "{:.2} (t {:.3})",
                b.firecast_accuracy_at_threshold * 100.0,
                b.firecast_threshold
            ),
            format!(
                "{:.2} (t {:.3})",
                b.reference_accuracy_at_threshold * 100.0,
                b.reference_threshold
            ),
            format!("{:+.2}", b.threshold_accuracy_delta_points),
            format!("{:.4}", b.firecast_auroc),
            format!("{:.4}", b.reference_auroc),
            format!("{:+.4}", b.auroc_delta),
            if b.within_bounds { "yes" } else { "OUT OF BOUNDS" }.to_string(),
            duration(b.firecast_fit_seconds),
            duration(b.reference_fit_seconds),
            format!("{:.2}x", b.speed_ratio),
        ]);
    }
    output::print_table(&table)?;
    println!(
        "  acc @thr: test accuracy at each side's own threshold, chosen by the model's Table III rule \
         (default max F1) on that side's validation scores; acc: at 0.5 (scikit-learn's predict)"
    );
    for b in &r.baselines {
        if let Some(note) = &b.note {
            println!("  {}: {note}", b.model);
        }
    }
    for note in &r.notes {
        println!("  {note}");
    }

    println!("\nNetworks — trainable parameters, tch against PyTorch eager (the same architecture)");
    let mut table = output::table(&[
        "network",
        "kind",
        "inputs (width x days)",
        "hidden x layers",
        "tch",
        "PyTorch",
        "equal",
    ]);
    for c in &r.parameters {
        table.add_row(vec![
            if c.from_experiment {
                c.model.clone()
            } else {
                format!("{} (defaults)", c.model)
            },
            c.kind.clone(),
            format!("{} x {}", c.width, c.days),
            format!("{} x {}", c.hidden, c.layers),
            c.tch.to_string(),
            c.pytorch.to_string(),
            if c.equal { "yes" } else { "NO" }.to_string(),
        ]);
    }
    output::print_table(&table)?;

    let t = &r.throughput;
    println!(
        "\nTraining throughput — {} ({}): {} x {} inputs, batch {}, hidden {} x {} layers; forward + BCE + backward + \
         AdamW step on random batches of {} rows; {} threads each; {} timed steps after {} warm-up; \
         best of {} alternating rounds, each in a fresh process",
        t.model,
        t.kind,
        t.width,
        t.days,
        t.batch,
        t.hidden,
        t.layers,
        t.rows,
        t.threads,
        t.steps,
        t.warmup_steps,
        t.rounds
    );
    let rounds = |v: &[f64]| v.iter().map(|x| format!("{x:.1}")).collect::<Vec<_>>().join(", ");
    let mut table = output::table(&[
        "engine",
        "best samples/s",
        "seconds (best)",
        "every round (samples/s)",
    ]);
    table.add_row(vec![
        "FireCast (tch)".to_string(),
        format!("{:.1}", t.tch_samples_per_s),
        format!("{:.2}", t.tch_seconds),
        rounds(&t.tch_rounds_samples_per_s),
    ]);
    table.add_row(vec![
        format!("PyTorch eager {}", t.torch_version),
        format!("{:.1}", t.pytorch_samples_per_s),
        format!("{:.2}", t.pytorch_seconds),
        rounds(&t.pytorch_rounds_samples_per_s),
    ]);
    output::print_table(&table)?;
    println!(
        "tch / PyTorch = {:.2} (goal ≥ 1.0: {})",
        t.ratio,
        if t.ratio >= 1.0 { "met" } else { "not met" }
    );

    let p = &r.projection;
    println!(
        "\nFull-size projection — {} windows, train share {:.3} → {} training rows (measured up to {})",
        p.windows, p.train_share, p.train_rows, p.measured_train_rows
    );
    println!("method: {}", p.method);
    let mut table = output::table(&[
        "model",
        "method",
        "measured (rows: fit)",
        "b fitted",
        "b used",
        "runs",
        "per run",
        "projected",
    ]);
    for m in &p.models {
        let measured = match (m.samples_per_s, m.epochs) {
            (Some(sps), Some(epochs)) => format!("{sps:.0} samples/s, {epochs} epochs max"),
            _ => m
                .measured
                .iter()
                .map(|(n, s)| format!("{n}: {}", duration(*s)))
                .collect::<Vec<_>>()
                .join(", "),
        };
        table.add_row(vec![
            m.model.clone(),
            m.method.clone(),
            measured,
            m.exponent_fitted.map_or("—".into(), |b| format!("{b:.2}")),
            m.exponent_used.map_or("—".into(), |b| format!("{b:.2}")),
            m.runs.to_string(),
            duration(m.projected_seconds_per_run),
            duration(m.projected_seconds),
        ]);
    }
    output::print_table(&table)?;
    println!(
        "projected total for protocol `{}`: {} ({} protocols in the experiment: about {} if each costs the same)",
        r.protocol,
        duration(p.total_seconds),
        p.protocols_in_experiment,
        duration(p.total_seconds * p.protocols_in_experiment as f64)
    );

    let out: Vec<&str> = r
        .baselines
        .iter()
        .filter(|b| !b.within_bounds)
        .map(|b| b.model.as_str())
        .collect();
    if out.is_empty() {
        println!(
            "\nall {} baselines within ±{} points and ±{} AUROC of their references",
            r.baselines.len(),
            r.bounds.accuracy_points,
            r.bounds.auroc
        );
    } else {
        println!(
            "\nOUT OF BOUNDS: {} (±{} points, ±{} AUROC)",
            out.join(", "),
            r.bounds.accuracy_points,
            r.bounds.auroc
        );
    }
    if !r.all_parameters_equal {
        println!("PARAMETER COUNTS DIFFER: see the networks table");
    }
    println!("bench took {}", duration(r.seconds));
    Ok(())
}

/// A model folder, or a model an experiment run saved to the artifact store (fetched into
/// `.firecast/cache/models/<run>/…`, checked against the registry's hashes).
fn resolve_model(settings: &Settings, spec: &str) -> anyhow::Result<PathBuf> {
    let as_dir = settings.root.join(spec);
    if as_dir.is_dir() {
        return Ok(as_dir);
    }
    let Some((run, path)) = spec.split_once(':') else {
        anyhow::bail!(
            "--model `{spec}`: no such folder, and not RUN:PROTOCOL/MODEL[/seed-N] (a model saved by an experiment run)"
        );
    };
    let registry = firecast_registry::Registry::open(&settings.registry)?;
    let details = crate::cmd_runs::stage_run_details(&registry, run)?;
    let path = path.trim_matches('/');
    let wanted = if path.split('/').count() == 2 {
        // No seed given: the lowest one saved.
        let prefix = format!("model/{path}/seed-");
        let mut seeds: Vec<(u64, &str)> = details
            .artifacts
            .iter()
            .filter_map(|a| {
                a.name
                    .strip_prefix(&prefix)
                    .and_then(|n| n.parse().ok())
                    .map(|n| (n, a.name.as_str()))
            })
            .collect();
        seeds.sort();
        seeds.first().map(|(_, n)| n.to_string())
    } else {
        Some(format!("model/{path}"))
    };
    let files: Vec<_> = match &wanted {
        Some(name) => details.artifacts.iter().filter(|a| &a.name == name).collect(),
        None => Vec::new(),
    };
    if files.is_empty() {
        let mut saved: Vec<&str> = details
            .artifacts
            .iter()
            .filter_map(|a| a.name.strip_prefix("model/"))
            .collect();
        saved.dedup();
        anyhow::bail!(
            "--model `{spec}`: run {} saved no model `{path}`{}",
            details.run.run_id,
            if saved.is_empty() {
                " (it saved no models: is it an experiment run?)".to_string()
            } else {
                format!("; it saved: {}", saved.join(", "))
            }
        );
    }
    let store = firecast_store::ArtifactStore::open(&settings.store, &settings.root)?;
    let name = wanted.unwrap_or_default();
    let dir = settings
        .root
        .join(".firecast/cache/models")
        .join(&details.run.run_id)
        .join(name.trim_start_matches("model/"));
    for a in files {
        let file = a.uri.rsplit('/').next().unwrap_or_default();
        let dest = dir.join(file);
        store
            .get_to_file(&a.uri, &dest)
            .with_context(|| format!("fetching {} of run {}", a.uri, details.run.run_id))?;
        let hash = blake3::hash(&std::fs::read(&dest)?).to_hex().to_string();
        if !a.hash.is_empty() && a.hash != hash {
            anyhow::bail!(
                "{}: fetched bytes hash to {hash}, the registry recorded {} for this artifact",
                dest.display(),
                a.hash
            );
        }
    }
    Ok(dir)
}
