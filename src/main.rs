//! `firecast`: the command line of the FireCast wildfire platform. It stays thin: every
//! command resolves its settings, calls a library crate, and prints a table or JSON.

mod cmd_artifacts;
mod cmd_dataset;
mod cmd_forecast;
mod cmd_pipeline;
mod cmd_report;
mod cmd_rl;
mod cmd_runs;
mod cmd_serve;
mod cmd_sim;
mod output;
mod settings;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use crate::settings::{GlobalArgs, Settings};

/// FireCast: wildfire data pipelines, fire simulation, learning and tracking.
#[derive(Debug, Parser)]
#[command(name = "firecast", version, about, long_about = None, max_term_width = 100)]
struct Cli {
    #[command(flatten)]
    global: GlobalArgs,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run, inspect and export declarative pipelines (pipelines/*.yaml).
    #[command(subcommand)]
    Pipeline(cmd_pipeline::PipelineCommand),
    /// List, show and compare runs in the registry.
    #[command(subcommand)]
    Runs(cmd_runs::RunsCommand),
    /// List and fetch artifacts in the artifact store.
    #[command(subcommand)]
    Artifacts(cmd_artifacts::ArtifactsCommand),
    /// Run SQL (DuckDB) over the registry tables and the registered Parquet datasets.
    ///
    /// Tables: runs, metrics, datasets, artifacts, lineage; every registered dataset is a
    /// view named after it (its latest version).
    Query {
        /// The SQL statement.
        sql: String,
    },
    /// Ignition datasets: synthetic sources, ignitions, negatives, GRIDMET windows,
    /// versioned datasets, Kaggle import and publish.
    #[command(subcommand)]
    Dataset(cmd_dataset::DatasetCommand),
    /// Forecasting experiments: Table III with intervals, plots and saved models.
    #[command(subcommand)]
    Experiment(cmd_forecast::ExperimentCommand),
    /// Ignition forecasts from trained models.
    #[command(subcommand)]
    Forecast(cmd_forecast::ForecastCommand),
    /// Reinforcement learning: PPO helitack agents (train, resume) and Table IV.
    #[command(subcommand)]
    Rl(cmd_rl::RlCommand),
    /// Threat-assessment report (HTML, PDF, JSON, GeoJSON) from ensembles and a forecast.
    Report(cmd_report::ReportArgs),
    /// Fire simulation: spread rates, suppression episodes with helitack agents.
    #[command(subcommand)]
    Sim(cmd_sim::SimCommand),
    /// The web app: forecast, live fires and threat reports for a place and day, and a
    /// browser for runs (http://127.0.0.1:8080 by default).
    Serve(cmd_serve::ServeArgs),
    /// Benchmarks.
    #[command(subcommand)]
    Bench(BenchCommand),
    /// Show what this firecast links and sees: versions, libtorch device, DuckDB, Rerun.
    Doctor,
    /// Print the settings every command resolves (flags > environment > firecast.yaml >
    /// defaults) and where each value came from.
    Settings,
}

#[derive(Debug, Subcommand)]
enum BenchCommand {
    /// Simulator speed: env steps per second (one env on one thread, and vectorised on all
    /// cores) with an active fire, and Rothermel point evaluations per second.
    Sim(firecast_bench::sim::Args),
    /// GRIDMET window extraction: FireCast beside the authors' xarray method (Python, run in
    /// the same command on the same files and windows), with the ratio and a projection to
    /// the paper's scale.
    Gridmet(firecast_bench::gridmet::Args),
    /// PPO speed beside Stable-Baselines3 in the same command, same network, settings and
    /// threads: (a) CartPole-v1 with the MLP policy, (b) the helitack environment with the
    /// compact policy (SB3 through the Python package), (c) SB3 on the FireCastRL Python
    /// environment (`--reference-env DIR`); environment only, rollout, training.
    Ppo(firecast_bench::ppo::Args),
    /// Time to a good helitack agent: FireCast's recipe trained from nothing, a checkpoint
    /// stamped every --every seconds of training, each judged on the held-out fires beside the
    /// rule circle (paired 95 % interval); beside it SB3 with the paper's settings on
    /// FireCast's environment (--control) and on the FireCastRL Python environment
    /// (--reference-env DIR), and the ratio of the times to beat the circle.
    Quality(firecast_bench::quality::Args),
    /// Forecasting models beside their references in the same command: the flattened
    /// baselines against scikit-learn / xgboost on the same exported split (accuracy within
    /// ±1.5 points, AUROC within ±0.015, fit times), every network's parameter count against
    /// PyTorch eager, the CNN-BiLSTM's training throughput against PyTorch eager (same net,
    /// threads), and the full-size run projected. Exit status 1 when out of bounds.
    Forecast(firecast_bench::forecast::Args),
    /// The web app under load on loopback: a registry of many runs, live fires at 30 frames
    /// a second, many fires at once beside clients hammering the runs table; latencies,
    /// frame rates, requests a second, errors and the server's peak memory against the goals.
    Serve(firecast_bench::serve::Args),
    /// Fire behaviour of every cell of a LANDFIRE landscape beside pyretechnics (PyPI, its own
    /// venv from `cargo xtask setup`), one thread each, same landscape and inputs: agreement on
    /// rate of spread first (exit status 1 if it fails), then grid cells per second and the ratio.
    Behavior(firecast_bench::behavior::Args),
    /// A point fire spread for 8 hours beside pyretechnics' level set, one thread each, same
    /// landscape and inputs: FireCast's minimum-travel-time engine, wall seconds, burnt cells per
    /// second, the ratios and both burnt areas.
    Spread(firecast_bench::spread::Args),
}

/// libtorch's OpenMP runtime (libgomp) reads how long an idle worker thread busy-waits once,
/// when it loads, before `main`. Its default (300,000 spins) made a training with 2 libtorch
/// threads beside two busy processes on 2 cores 10.5× slower than alone; 10,000 spins kept
/// its speed alone and made it 2.5× slower there (docs/results/performance.md, "Beside
/// other load"). So the process starts once more, the same program and arguments, with
/// `GOMP_SPINCOUNT=10000`, unless `GOMP_SPINCOUNT` or `OMP_WAIT_POLICY` is already set.
#[cfg(unix)]
fn with_short_openmp_spin() {
    use std::os::unix::process::CommandExt as _;
    if std::env::var_os("GOMP_SPINCOUNT").is_some() || std::env::var_os("OMP_WAIT_POLICY").is_some() {
        return;
    }
    let Ok(exe) = std::env::current_exe() else {
        return;
    };
    let mut args = std::env::args_os();
    let mut command = std::process::Command::new(exe);
    if let Some(arg0) = args.next() {
        command.arg0(arg0);
    }
    // `exec` returns only when it failed: then this process carries on with libgomp's default.
    let _failed = command.args(args).env("GOMP_SPINCOUNT", "10000").exec();
}

#[cfg(not(unix))]
fn with_short_openmp_spin() {}

/// Exit status of an error at this edge: the command could not be carried out (bad
/// arguments, settings or inputs, or the environment refused: a file, the registry). `1` is
/// returned by commands whose work ran and failed (a stage, a check, a benchmark's goals);
/// clap exits `2` for usage errors too; a panic (a bug) exits 101 after the hook's message.
const EXIT_ERROR: u8 = 2;

fn main() -> ExitCode {
    with_short_openmp_spin();
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        default_hook(info);
        eprintln!(
            "error: internal error in firecast {} (a bug, not your input): please report it with the command that led here",
            env!("CARGO_PKG_VERSION")
        );
    }));
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(error) => {
            // A closed pipe (e.g. `firecast runs list | head`) is not an error.
            if error.chain().any(|c| {
                c.downcast_ref::<std::io::Error>()
                    .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
            }) {
                return ExitCode::SUCCESS;
            }
            // Each cause once: many library errors carry their source's text in their own message,
            // which anyhow's `{:#}` would print a second time.
            eprintln!("error: {}", firecast_pipeline::chain_text(error.as_ref()));
            ExitCode::from(EXIT_ERROR)
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    let jobs = match &cli.command {
        Command::Pipeline(cmd_pipeline::PipelineCommand::Run(args)) => args.jobs,
        _ => None,
    };
    let settings = Settings::resolve(&cli.global, jobs)?;
    match cli.command {
        Command::Pipeline(command) => cmd_pipeline::run(&settings, command),
        Command::Runs(command) => cmd_runs::run(&settings, command),
        Command::Artifacts(command) => cmd_artifacts::run(&settings, command),
        Command::Query { sql } => cmd_runs::query(&settings, &sql),
        Command::Dataset(command) => cmd_dataset::run(&settings, command),
        Command::Experiment(command) => cmd_forecast::run_experiment_command(&settings, command),
        Command::Forecast(command) => cmd_forecast::run_forecast_command(&settings, command),
        Command::Rl(command) => cmd_rl::run(&settings, command),
        Command::Report(args) => cmd_report::run(&settings, &args),
        Command::Sim(command) => cmd_sim::run(&settings, command),
        Command::Serve(args) => cmd_serve::run(&settings, &args),
        Command::Bench(command) => bench(&settings, command),
        Command::Doctor => doctor(&settings),
        Command::Settings => print_settings(&settings),
    }
}

/// `firecast bench …`: each bench runs in firecast-bench; its report is printed here.
fn bench(settings: &Settings, command: BenchCommand) -> anyhow::Result<ExitCode> {
    let ctx = settings.bench();
    match command {
        BenchCommand::Sim(args) => print_bench(settings, firecast_bench::sim::run(&ctx, &args)?),
        BenchCommand::Gridmet(args) => print_bench(settings, firecast_bench::gridmet::run(&ctx, &args)?),
        BenchCommand::Ppo(args) => print_bench(settings, firecast_bench::ppo::run(&ctx, &args)?),
        BenchCommand::Quality(args) => print_bench(settings, firecast_bench::quality::run(&ctx, &args)?),
        BenchCommand::Forecast(mut args) => match &args.throughput_job {
            // The bench's own worker: one line of JSON, whatever --json says.
            Some(job) => {
                println!("{}", firecast_bench::forecast::throughput_job(job)?);
                Ok(ExitCode::SUCCESS)
            }
            None => {
                args.experiment = cmd_pipeline::relative_to_root(settings, &args.experiment);
                print_bench(settings, firecast_bench::forecast::run(&ctx, &args)?)
            }
        },
        BenchCommand::Serve(args) => print_bench(settings, firecast_bench::serve::run(&ctx, &args)?),
        BenchCommand::Behavior(args) => print_bench(settings, firecast_bench::behavior::run(&ctx, &args)?),
        BenchCommand::Spread(args) => print_bench(settings, firecast_bench::spread::run(&ctx, &args)?),
    }
}

/// Prints a bench's report (JSON or its tables) and returns its exit status.
fn print_bench(settings: &Settings, report: impl firecast_bench::Report) -> anyhow::Result<ExitCode> {
    if settings.json {
        output::print_json(&report)?;
    } else {
        use std::io::Write as _;
        write!(std::io::stdout().lock(), "{}", report.render())?;
    }
    Ok(ExitCode::from(report.exit_code()))
}

fn print_settings(settings: &Settings) -> anyhow::Result<ExitCode> {
    let o = &settings.origins;
    let rows: Vec<(&str, String, settings::Origin)> = vec![
        ("root", settings.root.display().to_string(), o.root),
        ("registry", settings.registry.display().to_string(), o.registry),
        ("store", settings.store.clone(), o.store),
        ("jobs", settings.jobs.to_string(), o.jobs),
        (
            "executor",
            format!("{:?}", settings.executor).to_lowercase(),
            o.executor,
        ),
        (
            "rerun_connect",
            settings.rerun_connect.clone().unwrap_or_else(|| "-".into()),
            o.rerun_connect,
        ),
    ];
    if settings.json {
        let map: serde_json::Map<String, serde_json::Value> = rows
            .iter()
            .map(|(k, v, origin)| ((*k).to_string(), serde_json::json!({"value": v, "from": origin})))
            .collect();
        output::print_json(&map)?;
    } else {
        for (key, value, origin) in rows {
            let from = match origin {
                settings::Origin::Flag => "flag",
                settings::Origin::Env => "environment",
                settings::Origin::File => "firecast.yaml",
                settings::Origin::Default => "default",
            };
            println!("{key:<14} {value}  ({from})");
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn doctor(settings: &Settings) -> anyhow::Result<ExitCode> {
    let torch = firecast_learn::torch_info();
    let duckdb_version = firecast_registry::duckdb_version()?;
    let report = serde_json::json!({
        "firecast": env!("CARGO_PKG_VERSION"),
        "root": settings.root,
        "registry": settings.registry,
        "store": settings.store,
        "duckdb": duckdb_version,
        "rerun": firecast_recorder::RERUN_VERSION,
        "torch": torch,
    });
    if settings.json {
        output::print_json(&report)?;
    } else {
        println!("firecast   {}", env!("CARGO_PKG_VERSION"));
        println!("root       {}", settings.root.display());
        println!("registry   {}", settings.registry.display());
        println!("store      {}", settings.store);
        println!("duckdb     {duckdb_version}");
        println!(
            "rerun      {} (viewer: pip install rerun-sdk=={0})",
            firecast_recorder::RERUN_VERSION
        );
        println!(
            "libtorch   device {}, CUDA available: {} ({} devices), cuDNN: {}, threads {}",
            torch.device, torch.cuda_available, torch.cuda_device_count, torch.cudnn_available, torch.threads
        );
    }
    Ok(ExitCode::SUCCESS)
}
