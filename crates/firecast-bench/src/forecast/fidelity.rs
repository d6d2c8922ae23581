//! The harness of `firecast bench forecast`: FireCast's models beside their Python references
//! (`crates/firecast-forecast/reference/`, kept beside the models they re-state), in one run.
//!
//! - **Fidelity**: one protocol of an experiment is cut and split as `experiment run` does;
//!   the flattened windows (`x_train`, `x_test`, labels) are exported as `.npy`, and
//!   `reference/baselines_reference.py` fits scikit-learn / xgboost with the hyper-parameters
//!   FireCast resolved (defaults filled) on the same arrays while FireCast fits its own. Each
//!   baseline must land within ±[`ACCURACY_BOUND_POINTS`] points of accuracy — at 0.5
//!   (scikit-learn's `predict`) and at the threshold Table III uses (the model's rule, by
//!   default max F1, chosen on each side's own validation scores) — and ±[`AUROC_BOUND`]
//!   AUROC of its reference.
//! - **Networks**: the tch parameter count of every neural kind against PyTorch eager's count
//!   of the same net (`reference/forecast_torch.py count-spec`), and the training throughput
//!   of the CNN-BiLSTM (variant R) against PyTorch eager: same net, batch and threads.
//! - **Full size**: each model's fit time is measured on n/4, n/2 and n training rows and a
//!   power law `log t = a + b·log n` projects it to the published dataset's size; networks
//!   are projected per epoch from their measured training throughput.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use firecast_forecast::ForecastError;
use firecast_forecast::data::{Block, Windows};
use firecast_forecast::inputs::{FitContext, Inputs};
use firecast_forecast::models::{ModelConfig, ThresholdRule, Trained};
use firecast_forecast::neural::{NeuralConfig, TrainingThroughput};
use firecast_forecast::spec::ExperimentSpec;

/// The scikit-learn / xgboost reference, embedded so an installed binary carries it.
pub const BASELINES_SCRIPT: &str =
    include_str!("../../../firecast-forecast/reference/baselines_reference.py");
/// The PyTorch eager re-statements of the networks.
pub const TORCH_SCRIPT: &str = include_str!("../../../firecast-forecast/reference/forecast_torch.py");

/// The paper's flattened baselines (Table III), compared with their Python references.
pub const FLAT_KINDS: [&str; 8] = [
    "logistic_regression",
    "gaussian_nb",
    "decision_tree",
    "random_forest",
    "gradient_boosting",
    "knn",
    "xgboost",
    "mlp",
];

/// The networks whose parameter counts are compared with PyTorch's.
pub const NEURAL_KINDS: [&str; 6] = [
    "lstm2",
    "lightts",
    "cnn_bilstm",
    "cnn_bilstm_attn",
    "firecast",
    "mlp",
];

/// Largest accepted accuracy difference, in percentage points.
pub const ACCURACY_BOUND_POINTS: f64 = 1.5;
/// Largest accepted AUROC difference.
pub const AUROC_BOUND: f64 = 0.015;
/// Rows of the published CSV (`firecast bench forecast --project-to` default).
pub const PUBLISHED_WINDOWS: usize = 66_568;
/// The power-law exponent used for projections is clamped to this range: fixed costs make
/// small fits look sub-linear, and every fit reads every row at least once.
pub const EXPONENT_RANGE: (f64, f64) = (1.0, 3.0);

/// How the bench runs.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// The experiment's protocol to use (its days and split).
    pub protocol: String,
    /// Threads for both sides: libtorch intra-op, rayon, XGBoost's `nthread`, scikit-learn's
    /// `n_jobs`, PyTorch's `set_num_threads`, and OMP/MKL/OpenBLAS in the Python process.
    pub threads: usize,
    /// Seed of every fit (FireCast's and the references' `random_state`).
    pub seed: u64,
    /// Total windows of the full-size run the projection aims at.
    pub project_to: usize,
    /// Timed training steps of the CNN-BiLSTM throughput comparison (each side).
    pub throughput_steps: usize,
    /// Untimed steps before them (each side).
    pub warmup_steps: usize,
    /// Throughput rounds, alternating the engines; the best round of each side counts.
    pub rounds: usize,
    /// Runs the tch side of the throughput rounds as `PROGRAM ARGS… JOB-JSON` (a fresh
    /// process with the same environment as the Python side, answering
    /// [`run_throughput_job`]'s JSON), so neither engine inherits the other's process state
    /// (OpenMP pools, allocator, earlier fits). `None`: in this process.
    pub tch_worker: Option<(PathBuf, Vec<String>)>,
    /// Timed steps of each other network's throughput, for its projection.
    pub projection_steps: usize,
    /// The Python interpreter with scikit-learn, xgboost and torch.
    pub python: PathBuf,
    /// Folder for the exported arrays and the scripts (created; the caller removes it).
    pub work: PathBuf,
}

/// One flattened baseline, both sides.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BaselineFidelity {
    pub model: String,
    pub kind: String,
    /// The Python class it is compared with.
    pub reference: String,
    /// FireCast's resolved hyper-parameters, passed to both sides.
    pub params: serde_json::Value,
    /// Whether the entry came from the experiment or is the kind's defaults.
    pub from_experiment: bool,
    pub firecast_accuracy: f64,
    pub reference_accuracy: f64,
    /// (FireCast − reference) accuracy in percentage points.
    pub accuracy_delta_points: f64,
    pub firecast_auroc: f64,
    pub reference_auroc: f64,
    pub auroc_delta: f64,
    /// How Table III picks the model's threshold (e.g. `max F1 on validation`).
    #[serde(default)]
    pub threshold_rule: String,
    /// Each side's threshold, chosen by that rule on its own validation scores.
    #[serde(default)]
    pub firecast_threshold: f64,
    #[serde(default)]
    pub reference_threshold: f64,
    /// Test accuracy at each side's own validation threshold, as Table III reports it.
    #[serde(default)]
    pub firecast_accuracy_at_threshold: f64,
    #[serde(default)]
    pub reference_accuracy_at_threshold: f64,
    /// (FireCast − reference) accuracy at the validation thresholds, in points.
    #[serde(default)]
    pub threshold_accuracy_delta_points: f64,
    /// Both accuracies (at 0.5 and at the thresholds) and the AUROC within the bounds.
    pub within_bounds: bool,
    /// Largest |Δ probability| over the test rows.
    pub max_abs_proba_diff: f64,
    pub firecast_fit_seconds: f64,
    pub reference_fit_seconds: f64,
    /// Reference fit time / FireCast fit time (> 1: FireCast is faster).
    pub speed_ratio: f64,
    /// Iterations or epochs where the model has them (FireCast, reference).
    pub firecast_iterations: Option<usize>,
    pub reference_iterations: Option<usize>,
    /// Trainable parameters (the MLP: tch, scikit-learn).
    pub firecast_parameters: Option<i64>,
    pub reference_parameters: Option<i64>,
    /// Why the two sides may differ beyond arithmetic.
    pub note: Option<String>,
}

/// One network's parameter count in tch and in PyTorch eager.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ParameterCount {
    pub model: String,
    pub kind: String,
    /// Input channels (variables, plus month sin/cos when the model adds them) and days.
    pub width: i64,
    pub days: i64,
    pub hidden: i64,
    pub layers: i64,
    pub tch: i64,
    pub pytorch: i64,
    pub equal: bool,
    pub from_experiment: bool,
}

/// The CNN-BiLSTM's training throughput, tch against PyTorch eager.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ThroughputComparison {
    pub model: String,
    pub kind: String,
    pub width: i64,
    pub days: i64,
    pub rows: i64,
    pub batch: usize,
    pub hidden: i64,
    pub layers: i64,
    pub threads: usize,
    pub warmup_steps: usize,
    pub steps: usize,
    /// Rounds run (tch, then PyTorch, alternating); the best of each side is compared.
    pub rounds: usize,
    /// Best round of each side.
    pub tch_samples_per_s: f64,
    pub pytorch_samples_per_s: f64,
    /// tch / PyTorch of the best rounds (goal ≥ 1).
    pub ratio: f64,
    pub tch_rounds_samples_per_s: Vec<f64>,
    pub pytorch_rounds_samples_per_s: Vec<f64>,
    pub tch_seconds: f64,
    pub pytorch_seconds: f64,
    pub torch_version: String,
}

/// One model's projection to the full-size run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ProjectionRow {
    pub model: String,
    pub kind: String,
    /// `power law` (fit times on subsets) or `per epoch` (training throughput).
    pub method: String,
    /// (training rows, fit seconds) measured.
    pub measured: Vec<(usize, f64)>,
    pub exponent_fitted: Option<f64>,
    pub exponent_used: Option<f64>,
    /// Networks: measured training samples per second and the epochs the spec allows.
    pub samples_per_s: Option<f64>,
    pub epochs: Option<usize>,
    /// Fits in the full run of this protocol (seeds for random models, else 1).
    pub runs: usize,
    pub projected_seconds_per_run: f64,
    pub projected_seconds: f64,
}

/// The full-size projection.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Projection {
    /// Windows of the full-size dataset and the protocol's training share of them.
    pub windows: usize,
    pub train_share: f64,
    pub train_rows: usize,
    /// Training rows of this dataset (the largest measured size).
    pub measured_train_rows: usize,
    pub method: String,
    pub models: Vec<ProjectionRow>,
    /// Sum over models for this protocol.
    pub total_seconds: f64,
    /// Protocols the experiment runs; `total_seconds × protocols` if each costs the same.
    pub protocols_in_experiment: usize,
}

/// Everything `firecast bench forecast` reports.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ForecastBench {
    pub experiment: String,
    pub dataset: String,
    pub dataset_version: String,
    pub protocol: String,
    pub days: (i32, i32),
    pub split: String,
    pub train: usize,
    pub val: usize,
    pub test: usize,
    /// Columns of the flattened inputs (days × variables).
    pub flat_inputs: usize,
    pub variables: usize,
    pub threads: usize,
    pub seed: u64,
    pub device: String,
    pub versions: BTreeMap<String, String>,
    pub bounds: Bounds,
    pub baselines: Vec<BaselineFidelity>,
    pub all_within_bounds: bool,
    pub parameters: Vec<ParameterCount>,
    pub all_parameters_equal: bool,
    pub throughput: ThroughputComparison,
    pub projection: Projection,
    pub notes: Vec<String>,
    pub seconds: f64,
}

#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct Bounds {
    pub accuracy_points: f64,
    pub auroc: f64,
}

/// A model of the comparison: its label, kind, raw params and whether the experiment has it.
#[derive(Debug, Clone)]
struct Entry {
    label: String,
    kind: String,
    config: ModelConfig,
    /// The experiment's threshold rule for it, else the kind's default (as Table III).
    rule: ThresholdRule,
    from_experiment: bool,
}

/// The experiment's entries of `kinds`, plus each missing kind with its defaults.
fn entries(spec: &ExperimentSpec, kinds: &[&str]) -> Result<Vec<Entry>, ForecastError> {
    let mut out = Vec::new();
    for m in spec.models.iter().filter(|m| kinds.contains(&m.kind.as_str())) {
        let config = ModelConfig::parse(&m.kind, &m.params).map_err(|e| e.in_model(&m.label()))?;
        out.push(Entry {
            label: m.label(),
            kind: m.kind.clone(),
            rule: m.threshold.unwrap_or_else(|| config.default_threshold()),
            config,
            from_experiment: true,
        });
    }
    for kind in kinds {
        if !out.iter().any(|e| e.kind == *kind) {
            let mut label = (*kind).to_string();
            if out.iter().any(|e| e.label == label) {
                label = format!("{kind} (defaults)");
            }
            let config = ModelConfig::parse(kind, &serde_json::Value::Null)?;
            out.push(Entry {
                label,
                kind: (*kind).to_string(),
                rule: config.default_threshold(),
                config,
                from_experiment: false,
            });
        }
    }
    Ok(out)
}

/// NPY v1.0 header for a C-order array.
fn npy_header(descr: &str, shape: &str) -> Vec<u8> {
    let dict = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    // Magic (6) + version (2) + length (2) + dict + padding + '\n' ≡ 0 (mod 64).
    let unpadded = 10 + dict.len() + 1;
    let pad = (64 - unpadded % 64) % 64;
    let header = format!("{dict}{}\n", " ".repeat(pad));
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out
}

/// Writes `rows × cols` little-endian `f32` values as `.npy`.
pub fn write_npy_f32(path: &Path, rows: usize, cols: usize, data: &[f32]) -> Result<(), ForecastError> {
    if rows * cols != data.len() {
        return Err(ForecastError::Model(format!(
            "{}: {rows} × {cols} does not hold {} values",
            path.display(),
            data.len()
        )));
    }
    let mut out = npy_header("<f4", &format!("({rows}, {cols})"));
    out.reserve(data.len() * 4);
    for v in data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(path, out).map_err(ForecastError::io("writing", path))
}

/// Writes labels as `.npy` (`|u1`, 0/1).
pub fn write_npy_labels(path: &Path, y: &[bool]) -> Result<(), ForecastError> {
    let mut out = npy_header("|u1", &format!("({},)", y.len()));
    out.extend(y.iter().map(|&b| u8::from(b)));
    std::fs::write(path, out).map_err(ForecastError::io("writing", path))
}

/// Least squares of `ln t = a + b · ln n` over `(n, t)` points: `(a, b)`, or `None` with
/// fewer than two distinct sizes or a non-positive value.
pub fn fit_power_law(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    if points.iter().any(|&(n, t)| !(n > 0.0 && t > 0.0)) {
        return None;
    }
    let xs: Vec<f64> = points.iter().map(|p| p.0.ln()).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.1.ln()).collect();
    let k = xs.len() as f64;
    let mx = xs.iter().sum::<f64>() / k;
    let my = ys.iter().sum::<f64>() / k;
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    if sxx <= 1e-12 {
        return None;
    }
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let b = sxy / sxx;
    Some((my - b * mx, b))
}

/// Projects fit time from the largest measured point `(n, t)` to `target` rows with the
/// power-law exponent fitted on `points`, clamped to [`EXPONENT_RANGE`] (1 when it cannot
/// be fitted): `t · (target / n)^b`. Returns (fitted b, used b, projected seconds).
pub fn project_power_law(points: &[(f64, f64)], target: f64) -> (Option<f64>, f64, f64) {
    let fitted = fit_power_law(points).map(|(_, b)| b);
    let used = fitted.map_or(1.0, |b| b.clamp(EXPONENT_RANGE.0, EXPONENT_RANGE.1));
    let (n, t) = points
        .iter()
        .copied()
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap_or((1.0, 0.0));
    (fitted, used, t * (target / n.max(1.0)).powf(used))
}

/// A stratified, seeded share of `rows` (indices into `labels`), both classes kept.
fn stratified_subset(rows: &[usize], labels: &[bool], share: f64, seed: u64) -> Vec<usize> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    for class in [true, false] {
        let mut group: Vec<usize> = rows.iter().copied().filter(|&r| labels[r] == class).collect();
        for i in (1..group.len()).rev() {
            let j = rng.random_range(0..=i);
            group.swap(i, j);
        }
        let n = ((group.len() as f64 * share).round() as usize).clamp(group.len().min(2), group.len());
        out.extend_from_slice(&group[..n]);
    }
    out.sort_unstable();
    out
}

fn accuracy_at_half(y: &[bool], p: &[f64]) -> f64 {
    // scikit-learn's `predict`: class 1 when P(1) > 0.5.
    let right = y.iter().zip(p).filter(|(l, q)| **l == (**q > 0.5)).count();
    right as f64 / y.len().max(1) as f64
}

/// Table III's threshold for one side: `rule` applied to that side's validation scores
/// (firecast-eval's `choose_threshold`, as `experiment run` does), and the test accuracy
/// at it (class 1 strictly above the threshold).
fn accuracy_at_validation_threshold(
    rule: ThresholdRule,
    y_val: &[bool],
    p_val: &[f64],
    y_test: &[bool],
    p_test: &[f64],
) -> (f64, f64) {
    use firecast_eval::metrics::{Confusion, ThresholdRule as EvalRule, choose_threshold};
    let eval_rule = match rule {
        ThresholdRule::Fixed(t) => EvalRule::Fixed(t),
        ThresholdRule::MaxF1 => EvalRule::MaxF1,
        ThresholdRule::Youden => EvalRule::Youden,
    };
    let threshold = choose_threshold(y_val, p_val, eval_rule);
    (threshold, Confusion::at(y_test, p_test, threshold).accuracy())
}

fn rule_label(rule: ThresholdRule) -> String {
    match rule {
        ThresholdRule::Fixed(t) => format!("fixed {t}"),
        ThresholdRule::MaxF1 => "max F1 on validation".into(),
        ThresholdRule::Youden => "Youden J on validation".into(),
    }
}

/// Columns of the day-major flattened block that the variables `features` occupy, or
/// `None` when they are every variable in the block's order.
fn columns(block: &Block, features: &[String]) -> Option<Vec<usize>> {
    if features == block.features.as_slice() {
        return None;
    }
    let nf = block.n_features();
    let idx: Vec<usize> = features
        .iter()
        .filter_map(|f| block.features.iter().position(|n| n == f))
        .collect();
    Some(
        (0..block.n_days)
            .flat_map(|d| idx.iter().map(move |&f| d * nf + f))
            .collect(),
    )
}

fn resolved_params(config: &ModelConfig) -> Result<serde_json::Value, ForecastError> {
    let v = match config {
        ModelConfig::Baseline { spec, .. } => serde_json::to_value(spec),
        ModelConfig::Xgboost(e)
        | ModelConfig::WindowStatsXgboost(e)
        | ModelConfig::ClimateBoost(e)
        | ModelConfig::ClimateOffset(firecast_forecast::models::ClimateOffsetParams { boost: e, .. }) => {
            serde_json::to_value(&e.params)
        }
        ModelConfig::Neural(n) => serde_json::to_value(n),
        other => serde_json::to_value(other),
    };
    v.map_err(|e| ForecastError::Model(e.to_string()))
}

/// Runs `program args` in `work` with the bench's thread settings in its environment; the
/// last non-empty stdout line is its JSON answer. `hint` follows a failure.
fn run_child(
    opts: &BenchOptions,
    program: &Path,
    args: &[String],
    what: &str,
    hint: &str,
) -> Result<serde_json::Value, ForecastError> {
    let threads = opts.threads.max(1).to_string();
    let out = Command::new(program)
        .args(args)
        .env("OMP_NUM_THREADS", &threads)
        .env("MKL_NUM_THREADS", &threads)
        .env("OPENBLAS_NUM_THREADS", &threads)
        .current_dir(&opts.work)
        .output()
        .map_err(|e| {
            ForecastError::Model(format!(
                "cannot run {} for {what}: {e}; {hint}",
                program.display()
            ))
        })?;
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = stderr.lines().rev().take(15).collect();
        return Err(ForecastError::Model(format!(
            "{what}: {} failed ({}):\n{}\n{hint}",
            program.display(),
            out.status,
            tail.into_iter().rev().collect::<Vec<_>>().join("\n")
        )));
    }
    let line = out
        .stdout
        .split(|&b| b == b'\n')
        .rfind(|l| !l.iter().all(u8::is_ascii_whitespace))
        .unwrap_or_default();
    serde_json::from_slice(line).map_err(|e| {
        ForecastError::Model(format!(
            "{what}: {} printed no JSON ({e}): {}",
            program.display(),
            String::from_utf8_lossy(&out.stdout)
        ))
    })
}

/// Runs one of the embedded Python scripts (written into `work`).
fn run_python(
    opts: &BenchOptions,
    script: &str,
    args: &[String],
    what: &str,
) -> Result<serde_json::Value, ForecastError> {
    let mut all = vec![opts.work.join(script).display().to_string()];
    all.extend_from_slice(args);
    run_child(
        opts,
        &opts.python,
        &all,
        what,
        "run `cargo xtask setup` if scikit-learn, xgboost or torch is missing (or pass --python)",
    )
}

/// One tch throughput measurement, run in a fresh process (see [`BenchOptions::tch_worker`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ThroughputJob {
    pub kind: String,
    /// The network's resolved settings (as [`NeuralConfig`] serialises them).
    pub params: serde_json::Value,
    pub width: i64,
    pub days: i64,
    pub rows: i64,
    pub warmup: usize,
    pub steps: usize,
    pub seed: u64,
    pub threads: usize,
}

/// Runs a [`ThroughputJob`] in this process (the worker's side).
pub fn run_throughput_job(job: &ThroughputJob) -> Result<TrainingThroughput, ForecastError> {
    let kind = firecast_forecast::neural::NeuralKind::parse(&job.kind).ok_or_else(|| {
        ForecastError::UnknownModel {
            kind: job.kind.clone(),
        }
    })?;
    let mut params = job.params.clone();
    if let Some(m) = params.as_object_mut() {
        m.remove("kind");
    }
    let cfg = NeuralConfig::parse(kind, &params)?;
    firecast_learn::set_threads(job.threads.max(1));
    firecast_forecast::neural::training_throughput(
        &cfg, job.width, job.days, job.rows, job.warmup, job.steps, job.seed,
    )
}

/// The input width (variables, plus month sin/cos) a network reads from `features`.
fn network_width(cfg: &NeuralConfig, features: &[String]) -> Result<i64, ForecastError> {
    Ok(cfg.features.resolve(features)?.len() as i64 + if cfg.month_features { 2 } else { 0 })
}

/// What one FireCast fit of the fidelity table produced.
struct OwnFit {
    proba: Vec<f64>,
    /// Scores of the validation rows (for Table III's threshold).
    proba_val: Vec<f64>,
    seconds: f64,
    iterations: Option<usize>,
    parameters: Option<i64>,
}

/// Runs the whole bench. `log` gets one line per step (for stderr).
pub fn run(
    spec: &ExperimentSpec,
    windows: &Windows,
    opts: &BenchOptions,
    log: &dyn Fn(&str),
) -> Result<ForecastBench, ForecastError> {
    let started = Instant::now();
    let threads = opts.threads.max(1);
    let protocol = spec
        .protocols
        .get(&opts.protocol)
        .ok_or_else(|| ForecastError::Config {
            key: "protocol".into(),
            message: format!(
                "the experiment has no protocol `{}` (it has {})",
                opts.protocol,
                spec.protocols.keys().cloned().collect::<Vec<_>>().join(", ")
            ),
        })?;
    std::fs::create_dir_all(&opts.work).map_err(ForecastError::io("creating", &opts.work))?;
    for (name, text) in [
        ("baselines_reference.py", BASELINES_SCRIPT),
        ("forecast_torch.py", TORCH_SCRIPT),
    ] {
        let path = opts.work.join(name);
        std::fs::write(&path, text).map_err(ForecastError::io("writing", &path))?;
    }
    // Fail before the long fits when the Python side cannot run.
    run_child(
        opts,
        &opts.python,
        &[
            "-c".into(),
            "import numpy, sklearn, xgboost, torch; print('{}')".into(),
        ],
        "the Python references",
        "run `cargo xtask setup` to install scikit-learn, xgboost and torch (or pass --python)",
    )?;
    firecast_learn::set_threads(threads);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| ForecastError::Model(format!("cannot start {threads} threads: {e}")))?;
    let device = tch::Device::Cpu;

    // The protocol's split and inputs, as `experiment run` cuts them.
    let key = format!("protocols.{}", opts.protocol);
    let days = windows.day_range(protocol.days.0, protocol.days.1, &format!("{key}.days"))?;
    let split = firecast_forecast::split::apply(windows, &protocol.split, protocol.days, &key)?;
    let all_features: Vec<usize> = (0..windows.n_features()).collect();
    let cut = |rows: &[usize]| Block::cut(windows, days.clone(), &all_features, rows);
    let (btr, bva, bte) = (cut(&split.train), cut(&split.val), cut(&split.test));
    let labels = |rows: &[usize]| rows.iter().map(|&s| windows.labels[s]).collect::<Vec<_>>();
    let (ytr, yva, yte) = (labels(&split.train), labels(&split.val), labels(&split.test));
    let meta = |rows: &[usize]| rows.iter().map(|&s| &windows.meta[s]).collect::<Vec<_>>();
    log(&format!(
        "protocol {}: days {}..{}, {} (train {}, val {}, test {})",
        opts.protocol,
        protocol.days.0,
        protocol.days.1,
        split.description,
        split.train.len(),
        split.val.len(),
        split.test.len()
    ));

    let fit_one = |config: &ModelConfig, train_rows: &[usize], train_block: &Block, y: &[bool]| {
        let ctx = FitContext {
            train: Inputs {
                block: train_block,
                meta: meta(train_rows),
            },
            train_labels: y,
            val: Inputs {
                block: &bva,
                meta: meta(&split.val),
            },
            val_labels: &yva,
            seed: opts.seed,
            device,
            progress: &|_, _, _| {},
            curve: &|_, _, _| {},
        };
        let t0 = Instant::now();
        let trained = pool.install(|| firecast_forecast::models::fit(config, &ctx))?;
        Ok::<_, ForecastError>((trained, t0.elapsed().as_secs_f64()))
    };

    // 1. Fidelity of the flattened baselines.
    let flat = btr.flat();
    let flat_test = bte.flat();
    let flat_val = bva.flat();
    write_npy_f32(&opts.work.join("x_train.npy"), flat.rows, flat.cols, &flat.data)?;
    write_npy_f32(
        &opts.work.join("x_test.npy"),
        flat_test.rows,
        flat_test.cols,
        &flat_test.data,
    )?;
    write_npy_f32(
        &opts.work.join("x_val.npy"),
        flat_val.rows,
        flat_val.cols,
        &flat_val.data,
    )?;
    write_npy_labels(&opts.work.join("y_train.npy"), &ytr)?;
    write_npy_labels(&opts.work.join("y_test.npy"), &yte)?;
    let baselines = entries(spec, &FLAT_KINDS)?;
    let mut own: Vec<OwnFit> = Vec::new();
    let mut configs = Vec::new();
    let test_inputs = Inputs {
        block: &bte,
        meta: meta(&split.test),
    };
    let val_inputs = Inputs {
        block: &bva,
        meta: meta(&split.val),
    };
    for (i, entry) in baselines.iter().enumerate() {
        let mut config = entry.config.clone();
        // Same threads on both sides (speed only; XGBoost's default is every core).
        if let ModelConfig::Xgboost(e) = &mut config {
            e.params.nthread = u32::try_from(threads).unwrap_or(u32::MAX);
        }
        log(&format!(
            "FireCast {}: fitting on {} rows ...",
            entry.label,
            ytr.len()
        ));
        let (trained, seconds) =
            fit_one(&config, &split.train, &btr, &ytr).map_err(|e| e.in_model(&entry.label))?;
        let proba = trained
            .predict(&test_inputs, device)
            .map_err(|e| e.in_model(&entry.label))?;
        let proba_val = trained
            .predict(&val_inputs, device)
            .map_err(|e| e.in_model(&entry.label))?;
        let (mut columns_of, mut standardize, mut inputs) = (None, false, "flat".to_string());
        let mut iterations = None;
        match (&config, &trained) {
            (ModelConfig::Baseline { inputs: fi, spec: s }, _) => {
                columns_of = columns(&btr, &fi.features.resolve(&btr.features)?);
                standardize = fi.standardize.unwrap_or_else(|| s.wants_standardized());
            }
            (ModelConfig::Xgboost(e), _) => {
                columns_of = columns(&btr, &e.features.resolve(&btr.features)?);
            }
            (ModelConfig::Neural(_), Trained::Neural(net)) => {
                // The MLP's own inputs (per-variable scaling, month features), so scikit-learn
                // fits the very numbers FireCast fitted.
                let train_inputs = Inputs {
                    block: &btr,
                    meta: meta(&split.train),
                };
                let name = format!("net{i}");
                let xtr = net.prepared_inputs(&train_inputs)?;
                let xte = net.prepared_inputs(&test_inputs)?;
                let xva = net.prepared_inputs(&val_inputs)?;
                let cols = (net.days * net.width) as usize;
                write_npy_f32(
                    &opts.work.join(format!("x_train_{name}.npy")),
                    ytr.len(),
                    cols,
                    &xtr,
                )?;
                write_npy_f32(
                    &opts.work.join(format!("x_test_{name}.npy")),
                    yte.len(),
                    cols,
                    &xte,
                )?;
                write_npy_f32(
                    &opts.work.join(format!("x_val_{name}.npy")),
                    yva.len(),
                    cols,
                    &xva,
                )?;
                inputs = name;
                iterations = Some(net.epochs_run);
            }
            _ => {}
        }
        configs.push(serde_json::json!({
            "name": entry.label,
            "kind": entry.kind,
            "params": resolved_params(&config)?,
            "columns": columns_of,
            "standardize": standardize,
            "inputs": inputs,
        }));
        own.push(OwnFit {
            proba,
            proba_val,
            seconds,
            iterations,
            parameters: trained.parameter_count(),
        });
    }
    std::fs::write(
        opts.work.join("config.json"),
        serde_json::json!({"seed": opts.seed, "threads": threads, "models": configs}).to_string(),
    )
    .map_err(ForecastError::io("writing", &opts.work.join("config.json")))?;
    log(&format!(
        "scikit-learn / xgboost: the same {} models on the same arrays ({}) ...",
        baselines.len(),
        opts.python.display()
    ));
    let reference = run_python(
        opts,
        "baselines_reference.py",
        &[opts.work.display().to_string()],
        "the baseline reference",
    )?;
    let mut versions: BTreeMap<String, String> = reference["versions"]
        .as_object()
        .map(|m| {
            m.iter()
                .map(|(k, v)| (k.clone(), v.as_str().unwrap_or_default().to_string()))
                .collect()
        })
        .unwrap_or_default();
    let mut rows = Vec::new();
    for ((entry, mine), params) in baselines.iter().zip(&own).zip(&configs) {
        let theirs = &reference["models"][&entry.label];
        let get = |k: &str| {
            theirs[k].as_f64().ok_or_else(|| {
                ForecastError::Model(format!("the reference gave no `{k}` for {}", entry.label))
            })
        };
        // Scores come as repr() strings (exact); plain numbers are accepted too.
        let floats = |k: &str| -> Vec<f64> {
            theirs[k]
                .as_array()
                .map(|a| {
                    a.iter()
                        .filter_map(|v| v.as_str().and_then(|s| s.parse().ok()).or_else(|| v.as_f64()))
                        .collect()
                })
                .unwrap_or_default()
        };
        let (proba, proba_val) = (floats("proba"), floats("proba_val"));
        if proba_val.len() != yva.len() {
            return Err(ForecastError::Model(format!(
                "the reference gave {} validation scores for {} ({} validation rows)",
                proba_val.len(),
                entry.label,
                yva.len()
            )));
        }
        let (firecast_threshold, firecast_accuracy_at_threshold) =
            accuracy_at_validation_threshold(entry.rule, &yva, &mine.proba_val, &yte, &mine.proba);
        let (reference_threshold, reference_accuracy_at_threshold) =
            accuracy_at_validation_threshold(entry.rule, &yva, &proba_val, &yte, &proba);
        let threshold_accuracy_delta_points =
            100.0 * (firecast_accuracy_at_threshold - reference_accuracy_at_threshold);
        let firecast_accuracy = accuracy_at_half(&yte, &mine.proba);
        let firecast_auroc = firecast_eval::metrics::roc_auc(&yte, &mine.proba).unwrap_or(f64::NAN);
        let (reference_accuracy, reference_auroc) = (get("accuracy")?, get("roc_auc")?);
        let accuracy_delta_points = 100.0 * (firecast_accuracy - reference_accuracy);
        let auroc_delta = firecast_auroc - reference_auroc;
        let reference_fit_seconds = get("fit_seconds")?;
        let note = match entry.kind.as_str() {
            "random_forest" | "decision_tree" | "gradient_boosting" => Some(
                "scikit-learn's trees for the same random_state (its NumPy streams, feature draws, \
                 sort and tie order): probabilities equal to rounding"
                    .into(),
            ),
            "mlp" => Some(
                "FireCast's MLP is scikit-learn's MLPClassifier restated in tch (same net, inputs, Adam \
                 settings and stopping rule); the optimiser's randomness (initial weights, batch order) \
                 differs, so only agreement within the bounds is expected"
                    .into(),
            ),
            "logistic_regression" => {
                Some("scikit-learn fitted on float64 copies (lbfgs stalls on float32)".into())
            }
            "knn" => Some("fitting only stores the rows (brute force); the work is in scoring".into()),
            _ => None,
        };
        rows.push(BaselineFidelity {
            model: entry.label.clone(),
            kind: entry.kind.clone(),
            reference: theirs["class"].as_str().unwrap_or_default().to_string(),
            params: params["params"].clone(),
            from_experiment: entry.from_experiment,
            firecast_accuracy,
            reference_accuracy,
            accuracy_delta_points,
            firecast_auroc,
            reference_auroc,
            auroc_delta,
            threshold_rule: rule_label(entry.rule),
            firecast_threshold,
            reference_threshold,
            firecast_accuracy_at_threshold,
            reference_accuracy_at_threshold,
            threshold_accuracy_delta_points,
            within_bounds: accuracy_delta_points.abs() <= ACCURACY_BOUND_POINTS
                && threshold_accuracy_delta_points.abs() <= ACCURACY_BOUND_POINTS
                && auroc_delta.abs() <= AUROC_BOUND,
            max_abs_proba_diff: mine.proba.iter().zip(&proba).map(|(a, b)| (a - b).abs()).fold(
                if proba.len() == mine.proba.len() {
                    0.0
                } else {
                    f64::NAN
                },
                f64::max,
            ),
            firecast_fit_seconds: mine.seconds,
            reference_fit_seconds,
            speed_ratio: reference_fit_seconds / mine.seconds.max(1e-9),
            firecast_iterations: mine.iterations,
            reference_iterations: theirs["n_iter"].as_u64().map(|v| v as usize),
            firecast_parameters: mine.parameters,
            reference_parameters: theirs["n_parameters"].as_i64(),
            note,
        });
    }
    let all_within_bounds = rows.iter().all(|r| r.within_bounds);

    // 2. Parameter counts of every network, tch against PyTorch eager.
    let n_days = btr.n_days as i64;
    let nets = entries(spec, &NEURAL_KINDS)?;
    let mut counts = Vec::new();
    let mut torch_spec = Vec::new();
    for entry in &nets {
        let ModelConfig::Neural(cfg) = &entry.config else {
            continue;
        };
        let width = network_width(cfg, &windows.features)?;
        torch_spec.push(serde_json::json!({
            "name": entry.label, "kind": entry.kind, "width": width, "days": n_days,
            "hidden": cfg.hidden, "layers": cfg.layers, "dropout": cfg.dropout,
        }));
        counts.push(ParameterCount {
            model: entry.label.clone(),
            kind: entry.kind.clone(),
            width,
            days: n_days,
            hidden: cfg.hidden,
            layers: cfg.layers,
            tch: firecast_forecast::neural::count_parameters(cfg, width, n_days),
            pytorch: 0,
            equal: false,
            from_experiment: entry.from_experiment,
        });
    }
    log("PyTorch eager: parameter counts of the same networks ...");
    let torch_counts = run_python(
        opts,
        "forecast_torch.py",
        &[
            "count-spec".into(),
            serde_json::Value::Array(torch_spec).to_string(),
        ],
        "the PyTorch parameter counts",
    )?;
    for c in &mut counts {
        c.pytorch = torch_counts[&c.model].as_i64().unwrap_or(-1);
        c.equal = c.tch == c.pytorch;
    }
    let all_parameters_equal = counts.iter().all(|c| c.equal);

    // 3. Training throughput of the CNN-BiLSTM (variant R), tch against PyTorch eager.
    let r_entry = nets
        .iter()
        .find(|e| e.kind == "cnn_bilstm")
        .ok_or_else(|| ForecastError::Model("no cnn_bilstm entry".into()))?;
    let ModelConfig::Neural(r_cfg) = &r_entry.config else {
        return Err(ForecastError::Model("cnn_bilstm is not a network".into()));
    };
    let r_width = network_width(r_cfg, &windows.features)?;
    let rows_bench = (ytr.len().max(r_cfg.batch_size)) as i64;
    // Rounds alternate the engines so that load from other processes hits both alike; the
    // best round of each is compared (the least disturbed one).
    let mut tch_rounds: Vec<TrainingThroughput> = Vec::new();
    let mut torch_rounds: Vec<serde_json::Value> = Vec::new();
    for round in 1..=opts.rounds.max(1) {
        log(&format!(
            "throughput round {round}/{}: tch, {} training steps of {} (batch {}, {threads} threads) after {} \
             warm-up ...",
            opts.rounds.max(1),
            opts.throughput_steps,
            r_entry.label,
            r_cfg.batch_size,
            opts.warmup_steps
        ));
        let job = ThroughputJob {
            kind: r_entry.kind.clone(),
            params: serde_json::to_value(r_cfg).map_err(|e| ForecastError::Model(e.to_string()))?,
            width: r_width,
            days: n_days,
            rows: rows_bench,
            warmup: opts.warmup_steps,
            steps: opts.throughput_steps,
            seed: opts.seed,
            threads,
        };
        tch_rounds.push(match &opts.tch_worker {
            Some((program, args)) => {
                let mut all = args.clone();
                all.push(serde_json::to_string(&job).map_err(|e| ForecastError::Model(e.to_string()))?);
                let v = run_child(
                    opts,
                    program,
                    &all,
                    "the tch throughput worker",
                    "the worker is this firecast program run again",
                )?;
                serde_json::from_value(v).map_err(|e| {
                    ForecastError::Model(format!("the tch throughput worker answered no measurement: {e}"))
                })?
            }
            None => run_throughput_job(&job)?,
        });
        log(&format!(
            "throughput round {round}/{}: PyTorch eager, the same steps ...",
            opts.rounds.max(1)
        ));
        torch_rounds.push(run_python(
            opts,
            "forecast_torch.py",
            &[
                "bench".into(),
                "cnn_bilstm".into(),
                r_width.to_string(),
                n_days.to_string(),
                rows_bench.to_string(),
                r_cfg.batch_size.to_string(),
                opts.throughput_steps.to_string(),
                threads.to_string(),
                opts.warmup_steps.to_string(),
                r_cfg.hidden.to_string(),
                r_cfg.layers.to_string(),
                r_cfg.dropout.to_string(),
                r_cfg.lr.to_string(),
                r_cfg.weight_decay.to_string(),
            ],
            "the PyTorch throughput",
        )?);
    }
    let sps = |v: &serde_json::Value| v["samples_per_s"].as_f64().unwrap_or(f64::NAN);
    let tch_run = tch_rounds
        .iter()
        .max_by(|a, b| a.samples_per_s.total_cmp(&b.samples_per_s))
        .cloned()
        .ok_or_else(|| ForecastError::Model("no throughput round ran".into()))?;
    let torch_run = torch_rounds
        .iter()
        .max_by(|a, b| sps(a).total_cmp(&sps(b)))
        .cloned()
        .unwrap_or_default();
    let pytorch_sps = sps(&torch_run);
    let torch_version = torch_run["torch"].as_str().unwrap_or_default().to_string();
    versions.insert("torch".into(), torch_version.clone());
    let throughput = ThroughputComparison {
        model: r_entry.label.clone(),
        kind: r_entry.kind.clone(),
        width: r_width,
        days: n_days,
        rows: rows_bench,
        batch: r_cfg.batch_size,
        hidden: r_cfg.hidden,
        layers: r_cfg.layers,
        threads,
        warmup_steps: opts.warmup_steps,
        steps: opts.throughput_steps,
        rounds: tch_rounds.len(),
        tch_samples_per_s: tch_run.samples_per_s,
        pytorch_samples_per_s: pytorch_sps,
        ratio: tch_run.samples_per_s / pytorch_sps,
        tch_rounds_samples_per_s: tch_rounds.iter().map(|r| r.samples_per_s).collect(),
        pytorch_rounds_samples_per_s: torch_rounds.iter().map(sps).collect(),
        tch_seconds: tch_run.seconds,
        pytorch_seconds: torch_run["seconds"].as_f64().unwrap_or(f64::NAN),
        torch_version,
    };

    // 4. The full-size projection, for every model of the experiment under this protocol.
    let train_share = split.train.len() as f64 / windows.len() as f64;
    let target_rows = ((opts.project_to as f64) * train_share).round().max(1.0) as usize;
    let n = split.train.len();
    let mut projections = Vec::new();
    let subsets: Vec<(f64, Vec<usize>)> = [0.25, 0.5]
        .into_iter()
        .map(|share| {
            (
                share,
                stratified_subset(&split.train, &windows.labels, share, opts.seed ^ 0xb0b5),
            )
        })
        .collect();
    for m in &spec.models {
        let label = m.label();
        let mut config = ModelConfig::parse(&m.kind, &m.params).map_err(|e| e.in_model(&label))?;
        if let ModelConfig::Xgboost(e) | ModelConfig::WindowStatsXgboost(e) = &mut config {
            e.params.nthread = u32::try_from(threads).unwrap_or(u32::MAX);
        }
        let runs = if config.is_stochastic() {
            spec.seeds.len()
        } else {
            1
        };
        if let ModelConfig::Neural(cfg) = &config {
            let width = network_width(cfg, &windows.features)?;
            let measured = if cfg == r_cfg && width == r_width {
                tch_run.clone()
            } else {
                log(&format!(
                    "projection: {label}: {} training steps (batch {}) ...",
                    opts.projection_steps, cfg.batch_size
                ));
                firecast_forecast::neural::training_throughput(
                    cfg,
                    width,
                    n_days,
                    (n.max(cfg.batch_size)) as i64,
                    1,
                    opts.projection_steps.max(1),
                    opts.seed,
                )
                .map_err(|e| e.in_model(&label))?
            };
            let TrainingThroughput { samples_per_s, .. } = measured;
            let per_run = target_rows as f64 / samples_per_s.max(1e-12) * cfg.max_epochs as f64;
            projections.push(ProjectionRow {
                model: label,
                kind: m.kind.clone(),
                method: "per epoch".into(),
                measured: vec![(n, n as f64 / samples_per_s.max(1e-12))],
                exponent_fitted: None,
                exponent_used: Some(1.0),
                samples_per_s: Some(samples_per_s),
                epochs: Some(cfg.max_epochs),
                runs,
                projected_seconds_per_run: per_run,
                projected_seconds: per_run * runs as f64,
            });
            continue;
        }
        // All three sizes back to back, so they share the machine's conditions.
        log(&format!(
            "projection: {label}: fits on n/4, n/2 and n training rows ..."
        ));
        let mut measured = Vec::new();
        for rows_sub in subsets.iter().map(|(_, r)| r).chain([&split.train]) {
            let block = cut(rows_sub);
            let y = labels(rows_sub);
            let (_, seconds) = fit_one(&config, rows_sub, &block, &y).map_err(|e| e.in_model(&label))?;
            measured.push((rows_sub.len(), seconds));
        }
        let points: Vec<(f64, f64)> = measured.iter().map(|&(r, t)| (r as f64, t)).collect();
        let (fitted, used, per_run) = project_power_law(&points, target_rows as f64);
        projections.push(ProjectionRow {
            model: label,
            kind: m.kind.clone(),
            method: "power law".into(),
            measured,
            exponent_fitted: fitted,
            exponent_used: Some(used),
            samples_per_s: None,
            epochs: None,
            runs,
            projected_seconds_per_run: per_run,
            projected_seconds: per_run * runs as f64,
        });
    }
    let total_seconds = projections.iter().map(|p| p.projected_seconds).sum();
    let projection = Projection {
        windows: opts.project_to,
        train_share,
        train_rows: target_rows,
        measured_train_rows: n,
        method: format!(
            "fit time measured on n/4, n/2 and n = {n} training rows (stratified, seeded); least squares of \
             ln t = a + b ln n; b clamped to [{}, {}]; t(N) = t(n) (N/n)^b with N = {} windows x train share \
             {train_share:.3} = {target_rows}; networks: N / (training samples/s, measured as in the throughput \
             bench with their own batch) x max_epochs (an upper bound: early stopping ends sooner; scoring \
             excluded); random models x {} seeds; CPU, {threads} threads",
            EXPONENT_RANGE.0,
            EXPONENT_RANGE.1,
            opts.project_to,
            spec.seeds.len()
        ),
        models: projections,
        total_seconds,
        protocols_in_experiment: spec.protocols.len(),
    };

    let notes = vec![
        format!(
            "bounds: |Δ accuracy| ≤ {ACCURACY_BOUND_POINTS} points, both at threshold 0.5 (scikit-learn's \
             predict) and at each side's Table III threshold (its rule on its own validation scores), and \
             |Δ AUROC| ≤ {AUROC_BOUND}"
        ),
        format!(
            "threads: {threads} on both sides (rayon and libtorch; n_jobs / nthread / torch.set_num_threads and \
             OMP/MKL/OpenBLAS in Python); scikit-learn's trees and gradient boosting are single-threaded by design"
        ),
    ];
    Ok(ForecastBench {
        experiment: spec.name.clone(),
        dataset: windows.manifest.name.clone(),
        dataset_version: windows.manifest.version.clone(),
        protocol: opts.protocol.clone(),
        days: protocol.days,
        split: split.description.clone(),
        train: split.train.len(),
        val: split.val.len(),
        test: split.test.len(),
        flat_inputs: flat.cols,
        variables: btr.n_features(),
        threads,
        seed: opts.seed,
        device: "cpu".into(),
        versions,
        bounds: Bounds {
            accuracy_points: ACCURACY_BOUND_POINTS,
            auroc: AUROC_BOUND,
        },
        baselines: rows,
        all_within_bounds,
        parameters: counts,
        all_parameters_equal,
        throughput,
        projection,
        notes,
        seconds: started.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn power_law_fit_recovers_a_known_exponent() {
        // t = 3e-6 · n^1.7, exactly.
        let points: Vec<(f64, f64)> = [250.0, 500.0, 1000.0]
            .into_iter()
            .map(|n: f64| (n, 3e-6 * n.powf(1.7)))
            .collect();
        let (a, b) = fit_power_law(&points).unwrap();
        assert!((b - 1.7).abs() < 1e-12, "{b}");
        assert!((a - 3e-6f64.ln()).abs() < 1e-9, "{a}");
        let (fitted, used, t) = project_power_law(&points, 8000.0);
        assert_eq!(used, fitted.unwrap());
        let want = 3e-6 * 8000f64.powf(1.7);
        assert!((t / want - 1.0).abs() < 1e-9, "{t} vs {want}");
    }

    #[test]
    fn power_law_exponent_is_clamped_and_guarded() {
        // Fixed costs dominate small fits: flat times would project no growth at all.
        let flat = [(100.0, 0.5), (200.0, 0.5), (400.0, 0.5)];
        let (fitted, used, t) = project_power_law(&flat, 4000.0);
        assert!(fitted.unwrap().abs() < 1e-12);
        assert_eq!(used, 1.0);
        assert!((t - 5.0).abs() < 1e-9, "{t}");
        let steep = [(100.0, 1.0), (200.0, 32.0)];
        assert_eq!(project_power_law(&steep, 400.0).1, 3.0);
        assert!(fit_power_law(&[(100.0, 1.0), (100.0, 2.0)]).is_none());
        assert!(fit_power_law(&[(100.0, 0.0), (200.0, 2.0)]).is_none());
        assert_eq!(project_power_law(&[(100.0, 2.0)], 300.0).2, 6.0);
    }

    #[test]
    fn npy_files_have_numpy_headers() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.npy");
        write_npy_f32(&path, 2, 3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
        let hlen = usize::from(u16::from_le_bytes([bytes[8], bytes[9]]));
        assert_eq!((10 + hlen) % 64, 0, "header padded to 64");
        assert!(String::from_utf8_lossy(&bytes[10..10 + hlen]).contains("'shape': (2, 3)"));
        assert_eq!(bytes.len(), 10 + hlen + 24);
        assert!(write_npy_f32(&path, 2, 2, &[1.0]).is_err());
        let path = dir.path().join("y.npy");
        write_npy_labels(&path, &[true, false, true]).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[bytes.len() - 3..], &[1, 0, 1]);
    }

    #[test]
    fn subsets_are_stratified_seeded_and_keep_both_classes() {
        let labels: Vec<bool> = (0..100).map(|i| i % 4 == 0).collect();
        let rows: Vec<usize> = (0..100).collect();
        let a = stratified_subset(&rows, &labels, 0.5, 7);
        assert_eq!(a, stratified_subset(&rows, &labels, 0.5, 7));
        // 25 positives and 75 negatives, each halved and rounded: 13 + 38.
        assert_eq!(a.len(), 51);
        assert_eq!(a.iter().filter(|&&r| labels[r]).count(), 13);
        let tiny = stratified_subset(&rows, &labels, 0.01, 7);
        assert_eq!(tiny.iter().filter(|&&r| labels[r]).count(), 2);
        assert_eq!(tiny.iter().filter(|&&r| !labels[r]).count(), 2);
    }

    #[test]
    fn accuracy_uses_predicts_strict_half() {
        assert_eq!(accuracy_at_half(&[true, false, false], &[0.7, 0.5, 0.2]), 1.0);
        assert_eq!(accuracy_at_half(&[true], &[0.5]), 0.0);
    }
}
