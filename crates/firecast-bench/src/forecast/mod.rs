//! `firecast bench forecast`: forecasting models beside their references in the same command
//! ([`fidelity`]): the flattened baselines against scikit-learn / xgboost on the same exported
//! split, every network's parameter count and the CNN-BiLSTM's training throughput against
//! PyTorch eager, and the full-size run projected. Exit status 1 when out of bounds.

pub mod fidelity;

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context as _;
use firecast_forecast::spec::ExperimentSpec;

use crate::Context;
use crate::python::{Venv, find_python};

/// `firecast bench forecast`'s flags.
#[derive(Debug, clap::Args)]
pub struct Args {
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
    #[arg(long, default_value_t = fidelity::PUBLISHED_WINDOWS, value_name = "N")]
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
    /// Python with scikit-learn, xgboost and torch [default: $FIRECAST_VENV, ./.venv].
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
pub fn run(ctx: &Context, args: &Args) -> anyhow::Result<ForecastReport> {
    use fidelity::{self as bench, BenchOptions};
    // The CLI has made `--experiment` relative to the root where it lies inside it.
    let file = args.experiment.clone();
    let spec = ExperimentSpec::load(&ctx.root, &file, &args.set)?;
    let dataset = spec.dataset.clone().with_context(|| {
        format!(
            "{}: `dataset`: the experiment names no dataset folder",
            file.display()
        )
    })?;
    let windows = firecast_forecast::data::Windows::load(&ctx.root.join(&dataset))?;
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from))
        .max(1);
    let (work, temporary) = match &args.keep {
        Some(dir) => (ctx.root.join(dir), false),
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
        python: find_python(args.python.as_deref(), &ctx.root, Venv::Project)?,
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
    Ok(ForecastReport(result?))
}

/// `firecast bench forecast --throughput-job JSON`: the bench's own worker, one tch throughput
/// measurement in a fresh process; its result as one line of JSON (the bench reads the last
/// line of the worker's output).
pub fn throughput_job(job: &str) -> anyhow::Result<String> {
    let job: fidelity::ThroughputJob = serde_json::from_str(job).context("--throughput-job: not a job")?;
    Ok(serde_json::to_string(&fidelity::run_throughput_job(&job)?)?)
}

/// `firecast bench forecast`'s report.
#[derive(Debug, serde::Serialize)]
#[serde(transparent)]
pub struct ForecastReport(pub fidelity::ForecastBench);

impl crate::Report for ForecastReport {
    fn render(&self) -> String {
        let mut out = String::new();
        let _ = print_bench(&mut out, &self.0);
        out
    }

    /// 1 when a baseline is out of bounds or a parameter count differs.
    fn exit_code(&self) -> u8 {
        u8::from(!self.0.all_within_bounds || !self.0.all_parameters_equal)
    }
}

fn print_bench(w: &mut String, r: &fidelity::ForecastBench) -> std::fmt::Result {
    let v = |k: &str| r.versions.get(k).cloned().unwrap_or_else(|| "?".into());
    writeln!(
        w,
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
    )?;
    writeln!(
        w,
        "references: scikit-learn {}, xgboost {}, numpy {}, Python {} — same exported arrays, same hyper-parameters",
        v("sklearn"),
        v("xgboost"),
        v("numpy"),
        v("python")
    )?;
    let mut table = crate::table(&[
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
    writeln!(w, "{table}")?;
    writeln!(
        w,
        "  acc @thr: test accuracy at each side's own threshold, chosen by the model's Table III rule \
         (default max F1) on that side's validation scores; acc: at 0.5 (scikit-learn's predict)"
    )?;
    for b in &r.baselines {
        if let Some(note) = &b.note {
            writeln!(w, "  {}: {note}", b.model)?;
        }
    }
    for note in &r.notes {
        writeln!(w, "  {note}")?;
    }

    writeln!(
        w,
        "\nNetworks — trainable parameters, tch against PyTorch eager (the same architecture)"
    )?;
    let mut table = crate::table(&[
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
    writeln!(w, "{table}")?;

    let t = &r.throughput;
    writeln!(
        w,
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
    )?;
    let rounds = |v: &[f64]| v.iter().map(|x| format!("{x:.1}")).collect::<Vec<_>>().join(", ");
    let mut table = crate::table(&[
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
    writeln!(w, "{table}")?;
    writeln!(
        w,
        "tch / PyTorch = {:.2} (goal ≥ 1.0: {})",
        t.ratio,
        if t.ratio >= 1.0 { "met" } else { "not met" }
    )?;

    let p = &r.projection;
    writeln!(
        w,
        "\nFull-size projection — {} windows, train share {:.3} → {} training rows (measured up to {})",
        p.windows, p.train_share, p.train_rows, p.measured_train_rows
    )?;
    writeln!(w, "method: {}", p.method)?;
    let mut table = crate::table(&[
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
    writeln!(w, "{table}")?;
    writeln!(
        w,
        "projected total for protocol `{}`: {} ({} protocols in the experiment: about {} if each costs the same)",
        r.protocol,
        duration(p.total_seconds),
        p.protocols_in_experiment,
        duration(p.total_seconds * p.protocols_in_experiment as f64)
    )?;

    let out: Vec<&str> = r
        .baselines
        .iter()
        .filter(|b| !b.within_bounds)
        .map(|b| b.model.as_str())
        .collect();
    if out.is_empty() {
        writeln!(
            w,
            "\nall {} baselines within ±{} points and ±{} AUROC of their references",
            r.baselines.len(),
            r.bounds.accuracy_points,
            r.bounds.auroc
        )?;
    } else {
        writeln!(
            w,
            "\nOUT OF BOUNDS: {} (±{} points, ±{} AUROC)",
            out.join(", "),
            r.bounds.accuracy_points,
            r.bounds.auroc
        )?;
    }
    if !r.all_parameters_equal {
        writeln!(w, "PARAMETER COUNTS DIFFER: see the networks table")?;
    }
    writeln!(w, "bench took {}", duration(r.seconds))?;
    Ok(())
}
