//! `firecast`: the command line of the FireCast wildfire platform. It stays thin: every
//! command resolves its settings, calls a library crate, and prints a table or JSON.

mod cmd_artifacts;
mod cmd_pipeline;
mod cmd_runs;
mod output;
mod settings;

use std::path::PathBuf;
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
    /// Fire simulation tools.
    #[command(subcommand)]
    Sim(SimCommand),
    /// Show what this firecast links and sees: versions, libtorch device, DuckDB, Rerun.
    Doctor,
}

#[derive(Debug, Subcommand)]
enum SimCommand {
    /// Rothermel/Albini surface spread (as behave computes it) for every row of a CSV.
    ///
    /// Input columns, by header name (the inputs of behave's random oracle): `fm` or `code`
    /// or `fuel_model` (number or code, e.g. 102 or GR2); `m1_pct`, `m10_pct`, `m100_pct`,
    /// `mherb_pct`, `mwoody_pct` (percent); `midflame_mph`; `slope_pct`;
    /// `wind_dir_rel_upslope_deg` (where the wind blows toward, clockwise from upslope).
    /// Output adds R0_ftmin, ros_ftmin, ros_chph, dir_max_spread_rel_upslope_deg,
    /// IR_btuft2min, flame_ft, fli_btufts, hpua_btuft2, lw_ratio, back_ftmin, flank_ftmin.
    SpreadRate {
        /// Cases to evaluate.
        #[arg(long, value_name = "CSV")]
        input: PathBuf,
        /// Where to write the results (written atomically).
        #[arg(long, value_name = "CSV")]
        output: PathBuf,
    },
}

fn main() -> ExitCode {
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
            eprintln!("error: {error:#}");
            ExitCode::from(2)
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
        Command::Sim(SimCommand::SpreadRate { input, output }) => {
            let rows =
                firecast_sim::spread_rate_csv(&settings.root.join(&input), &settings.root.join(&output))?;
            if settings.json {
                output::print_json(&serde_json::json!({ "rows": rows, "output": output }))?;
            } else {
                println!("{rows} cases written to {}", output.display());
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Doctor => doctor(&settings),
    }
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
