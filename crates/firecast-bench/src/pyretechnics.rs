//! FireCast beside pyretechnics (PyPI), in the same command, on the same LANDFIRE landscape,
//! inputs and machine, one thread each: `firecast bench behavior` and `firecast bench spread`.
//!
//! pyretechnics runs in its own venv (`.venv-peers/pyretechnics`, installed by `cargo xtask
//! setup`: it needs numpy 1.26) through `reference/pyretechnics_bench.py`, which reads the
//! same GeoTIFF layers with pyretechnics' own LANDFIRE loader and times only the call being
//! compared; FireCast's side is timed here around the same work.
//!
//! - **Behaviour** ([`bench_behavior`], `firecast bench behavior`: [`crate::behavior`]): the fire behaviour of every cell of the grid, FireCast's
//!   [`firecast_sim::behavior::surface_behavior_grids`] (surface and Finney crown fire) against
//!   pyretechnics' `burn_cells.burn_all_cells_as_head_fire` (surface and its crown fire). Before
//!   the times are compared, the two must agree on the head rate of spread: every *comparable*
//!   cell that both call surface fire within [`ROS_TOLERANCE`] (see [`comparable_cell`] for
//!   which cells the two models make the same computation on).
//! - **Spread** ([`bench_spread`], `firecast bench spread`: [`crate::spread`]): one point
//!   ignition spread for a given time, FireCast's minimum-travel-time engine
//!   ([`firecast_spread::mtt`], per-cell ellipses from the landscape's own
//!   slope, aspect and canopy as the behaviour grid computes them) against pyretechnics'
//!   Eulerian level set (`eulerian_level_set.spread_fire_with_phi_field`). Different algorithms:
//!   the burnt areas are compared, not required to be equal.

use std::path::{Path, PathBuf};

use crate::Context;
use crate::python::{Venv, find_python};
use std::process::Command;
use std::time::Instant;

use firecast_landscape::landfire::{LandfireLandscape, LayerKind};
use firecast_sim::FuelModel;
use firecast_sim::behavior::{BehaviorParams, FIRE_TYPE_SURFACE, SlopeMode, surface_behavior_grids};
use firecast_spread::landfire::{LandfireSpreadError, Window, crop, landfire_arrival_lazy_h};
use firecast_spread::mtt::{LazyRun, MttError};

/// The pyretechnics side (kept beside the engine it is compared with), embedded and written
/// next to the job when the bench runs.
pub const PEER_SCRIPT: &str = include_str!("../../firecast-spread/reference/pyretechnics_bench.py");

/// The peer's venv name: `cargo xtask setup` installs it in `.venv-peers/pyretechnics`.
pub const PEER: &str = "pyretechnics";

/// The Worcester, Vermont LANDFIRE clip the parity test uses, relative to the repository root.
pub const WORCESTER: &str = "crates/firecast-landscape/tests/fixtures/landfire-worcester/landfire";

/// Relative difference in head rate of spread allowed on a comparable cell (the FlamMap parity
/// bound; the two agree to about 2×10⁻³, pyretechnics computing in float32).
pub const ROS_TOLERANCE: f64 = 0.005;

const M_MIN_PER_CH_H: f64 = 66.0 * 0.3048 / 60.0;
const FT_PER_M: f64 = 1.0 / 0.3048;
const KMH_PER_MPH: f64 = 1.609_344;

/// Errors of the side-by-side benches.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    PeerMissing(#[from] crate::python::PythonMissing),
    /// Boxed: a landscape error carries the files and cells it names.
    #[error(transparent)]
    Landscape(Box<firecast_landscape::landfire::LandfireError>),
    #[error("{0}")]
    Params(#[from] firecast_sim::behavior::ParamError),
    #[error(transparent)]
    Kernel(#[from] firecast_sim::RothermelError),
    #[error(transparent)]
    Mtt(#[from] MttError),
    #[error(transparent)]
    Spread(#[from] LandfireSpreadError),
    #[error("{0}")]
    Input(String),
    #[error("pyretechnics ({python}) failed with {status}:\n{stderr}", python = python.display())]
    Peer {
        python: PathBuf,
        status: String,
        stderr: String,
    },
    #[error("cannot {what} {}: {source}", path.display())]
    Io {
        what: &'static str,
        path: PathBuf,
        source: std::io::Error,
    },
}

impl From<firecast_landscape::landfire::LandfireError> for BenchError {
    fn from(e: firecast_landscape::landfire::LandfireError) -> Self {
        Self::Landscape(Box::new(e))
    }
}

fn io(what: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> BenchError {
    let path = path.to_path_buf();
    move |source| BenchError::Io { what, path, source }
}

/// The machine, as the results pages name it: the CPU model and the cores this process sees.
pub fn machine() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    format!("{model}, {cores} cores")
}

/// Seconds of each timed repeat, the best, and the rate the best gives.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Timing {
    pub seconds: Vec<f64>,
    pub best_seconds: f64,
    /// Cells (behaviour: grid cells; spread: burnt cells) per second of the best repeat.
    pub cells_per_second: f64,
}

impl Timing {
    fn new(seconds: Vec<f64>, cells: usize) -> Self {
        let best = seconds.iter().copied().fold(f64::INFINITY, f64::min);
        Self {
            cells_per_second: cells as f64 / best.max(1e-12),
            best_seconds: best,
            seconds,
        }
    }
}

/// What the peer's Python reported besides its arrays.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PeerRun {
    pub rows: usize,
    pub cols: usize,
    pub seconds: Vec<f64>,
    pub pyretechnics: String,
    pub python: String,
    pub numpy: String,
    #[serde(default)]
    pub stop_time_min: Option<f64>,
    #[serde(default)]
    pub stop_condition: Option<String>,
}

/// The layer files pyretechnics reads (its loader's names), from the landscape's own files.
fn peer_layers(land: &LandfireLandscape) -> Result<serde_json::Value, BenchError> {
    let fuel = match land.fuel_layer {
        firecast_landscape::landfire::FuelLayer::Fbfm40 => LayerKind::Fbfm40,
        firecast_landscape::landfire::FuelLayer::Fbfm13 => LayerKind::Fbfm13,
    };
    let wanted = [
        ("fuel_model", fuel),
        ("slope", LayerKind::SlopePercent),
        ("aspect", LayerKind::Aspect),
        ("canopy_cover", LayerKind::CanopyCover),
        ("canopy_height", LayerKind::CanopyHeight),
        ("canopy_base_height", LayerKind::CanopyBaseHeight),
        ("canopy_bulk_density", LayerKind::CanopyBulkDensity),
    ];
    let mut layers = serde_json::Map::new();
    for (name, kind) in wanted {
        let path = land
            .files
            .get(&kind)
            .filter(|p| {
                p.extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("tif") || e.eq_ignore_ascii_case("tiff"))
            })
            .ok_or_else(|| {
                BenchError::Input(format!(
                    "the benches need the landscape's {} layer as a LANDFIRE GeoTIFF (pyretechnics reads \
                     those; slope in percent)",
                    kind.name()
                ))
            })?;
        let path = std::fs::canonicalize(path).map_err(io("resolve", path))?;
        layers.insert(name.into(), path.to_string_lossy().into_owned().into());
    }
    Ok(layers.into())
}

/// The inputs as pyretechnics takes them: fractions, the 10-m wind in km/h (its 20-ft wind is
/// the 10-m one / 1.15), the direction the wind comes from.
fn peer_inputs(params: &BehaviorParams) -> serde_json::Value {
    let m = &params.moisture;
    serde_json::json!({
        "moisture": {
            "fuel_moisture_dead_1hr": m.dead_1h / 100.0,
            "fuel_moisture_dead_10hr": m.dead_10h / 100.0,
            "fuel_moisture_dead_100hr": m.dead_100h / 100.0,
            "fuel_moisture_live_herbaceous": m.live_herbaceous / 100.0,
            "fuel_moisture_live_woody": m.live_woody / 100.0,
            "foliar_moisture": params.foliar_moisture_pct / 100.0,
        },
        "wind_speed_10m_kmh": params.wind_20ft_mph * 1.15 * KMH_PER_MPH,
        "upwind_direction_deg": params.wind_from_deg,
        "use_wind_limit": params.wind_limit,
    })
}

/// Run the peer's script on `job` in `work` (a fresh folder), returning its report.
fn run_peer(python: &Path, work: &Path, mut job: serde_json::Value) -> Result<PeerRun, BenchError> {
    std::fs::create_dir_all(work).map_err(io("create", work))?;
    let script = work.join("pyretechnics_bench.py");
    std::fs::write(&script, PEER_SCRIPT).map_err(io("write", &script))?;
    job["out"] = work.to_string_lossy().into_owned().into();
    let job_path = work.join("job.json");
    std::fs::write(&job_path, job.to_string()).map_err(io("write", &job_path))?;
    let output = Command::new(python)
        .arg(&script)
        .arg(&job_path)
        .output()
        .map_err(io("run", python))?;
    if !output.status.success() {
        return Err(BenchError::Peer {
            python: python.to_path_buf(),
            status: output.status.to_string(),
            stderr: String::from_utf8_lossy(&output.stderr).trim_end().to_string(),
        });
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    let line = stdout.lines().last().unwrap_or("");
    serde_json::from_str(line).map_err(|e| BenchError::Peer {
        python: python.to_path_buf(),
        status: "unexpected output".into(),
        stderr: format!("{e}: `{line}`"),
    })
}

fn read_f32(path: &Path, n: usize) -> Result<Vec<f32>, BenchError> {
    let bytes = std::fs::read(path).map_err(io("read", path))?;
    if bytes.len() != 4 * n {
        return Err(BenchError::Input(format!(
            "{} holds {} bytes, expected {n} float32 values",
            path.display(),
            bytes.len()
        )));
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}

fn read_u8(path: &Path, n: usize) -> Result<Vec<u8>, BenchError> {
    let bytes = std::fs::read(path).map_err(io("read", path))?;
    if bytes.len() != n {
        return Err(BenchError::Input(format!(
            "{} holds {} bytes, expected {n}",
            path.display(),
            bytes.len()
        )));
    }
    Ok(bytes)
}

/// Run `f` on a rayon pool of one thread (FireCast's grids use rayon).
fn one_thread<T: Send>(f: impl FnOnce() -> T + Send) -> Result<T, BenchError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| BenchError::Input(format!("cannot build a one-thread pool: {e}")))?;
    Ok(pool.install(f))
}

/// Most timed repeats of FireCast's side (a bound for very short calls).
const MAX_REPEATS: usize = 10_000;

/// Run FireCast's timed `ours` around the peer's run (half of `repeats` before, the rest after),
/// so that both engines' best times come from the same stretch of the machine's load. After
/// the peer it goes on until it has run `repeats` times *and* spent at least the peer's timed
/// seconds (at most [`MAX_REPEATS`]): both sides' best is then taken over the same wall time
/// of samples, where five repeats of a millisecond call would leave its best to chance.
/// Returns FireCast's seconds, its last result, and the peer's report.
fn around_peer<T>(
    repeats: usize,
    mut ours: impl FnMut() -> Result<(f64, T), BenchError>,
    peer: impl FnOnce() -> Result<PeerRun, BenchError>,
) -> Result<(Vec<f64>, T, PeerRun), BenchError> {
    let mut seconds = Vec::with_capacity(repeats);
    let mut last = None;
    let before = repeats.div_ceil(2);
    for _ in 0..before {
        let (s, r) = ours()?;
        seconds.push(s);
        last = Some(r);
    }
    let peer = peer()?;
    let peer_total: f64 = peer.seconds.iter().sum();
    while seconds.len() < MAX_REPEATS && (seconds.len() < repeats || seconds.iter().sum::<f64>() < peer_total)
    {
        let (s, r) = ours()?;
        seconds.push(s);
        last = Some(r);
    }
    let last = last.ok_or_else(|| BenchError::Input("repeats must be at least 1".into()))?;
    Ok((seconds, last, peer))
}

/// Settings shared by both benches.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// The LANDFIRE landscape folder (GeoTIFF layers; slope in percent).
    pub landscape: PathBuf,
    /// Fuel moistures, wind, foliar moisture, crown method (behaviour), wind limit.
    pub params: BehaviorParams,
    /// Timed repeats per engine, the least (FireCast's side also runs until it has spent the
    /// peer's timed seconds); the best counts.
    pub repeats: usize,
    /// The peer's Python.
    pub python: PathBuf,
    /// A scratch folder for the peer's job and arrays (created; the caller removes it).
    pub work: PathBuf,
}

impl BenchOptions {
    fn check(&self) -> Result<LandfireLandscape, BenchError> {
        self.params.validate()?;
        if self.params.slope != SlopeMode::AsGiven {
            return Err(BenchError::Input(
                "the benches take slope as given (pyretechnics reads LANDFIRE's percent layer)".into(),
            ));
        }
        if self.repeats == 0 {
            return Err(BenchError::Input("repeats must be at least 1".into()));
        }
        Ok(LandfireLandscape::read_dir(
            &self.landscape,
            self.params.fuel.layer(),
        )?)
    }
}

// ---------------------------------------------------------------------------------------------
// Behaviour
// ---------------------------------------------------------------------------------------------

/// Whether a cell is one where FireCast and pyretechnics make the same surface computation, so
/// their head rates must agree:
///
/// - without wind, every cell (both reproduce FlamMap's no-wind grids);
/// - with wind, only flat cells (slope 0) whose wind adjustment both take the same way.
///   pyretechnics projects the wind onto the slope-tangential plane before it combines wind and
///   slope (behave and FlamMap combine them in the horizontal plane), which changes the rate on
///   sloped cells by about 1 % (median) under wind; and it calls a canopy sheltering only when
///   cover/3 ≥ 0.05 and height ≥ 6 ft (BehavePlus's rule), where FlamMap's, and FireCast's, is
///   cover > 0 and height > 0 — cells in between get different midflame winds. Cover 15 % sits
///   on pyretechnics' threshold in float32, so cells within 1 % of it are left out too.
pub fn comparable_cell(
    wind_20ft_mph: f64,
    slope_percent: f32,
    canopy_cover_pct: f32,
    canopy_height_m: f32,
) -> bool {
    if wind_20ft_mph <= 0.0 {
        return true;
    }
    if slope_percent != 0.0 {
        return false;
    }
    let (cc, ch_ft) = if canopy_cover_pct.is_finite() && canopy_height_m.is_finite() {
        (f64::from(canopy_cover_pct), f64::from(canopy_height_m) * FT_PER_M)
    } else {
        (0.0, 0.0)
    };
    if (cc - 15.0).abs() < 0.15 || (ch_ft - 6.0).abs() < 0.06 {
        return false;
    }
    let firecast_sheltered = cc > 0.0 && ch_ft > 0.0;
    let peer_sheltered = cc >= 15.0 && ch_ft >= 6.0;
    firecast_sheltered == peer_sheltered
}

/// The agreement of the two behaviour grids.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BehaviorAgreement {
    pub tolerance: f64,
    /// Which cells are compared ([`comparable_cell`]).
    pub rule: String,
    /// Comparable cells both call surface fire, and how many agree within the tolerance.
    pub compared_cells: usize,
    pub within_tolerance: usize,
    pub max_relative_difference: f64,
    /// Every cell both call surface fire, comparable or not (for information).
    pub surface_cells: usize,
    pub surface_within_tolerance: usize,
    pub surface_max_relative_difference: f64,
    /// Cells by fire type (0 none or nodata, 1 surface, 2 passive, 3 active) in each.
    pub firecast_fire_types: [usize; 4],
    pub pyretechnics_fire_types: [usize; 4],
    pub fire_type_equal_cells: usize,
}

impl BehaviorAgreement {
    /// Every comparable cell agrees (and there is at least one).
    pub fn holds(&self) -> bool {
        self.compared_cells > 0 && self.within_tolerance == self.compared_cells
    }
}

/// `firecast bench behavior`'s result.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BehaviorBench {
    pub landscape: PathBuf,
    pub window: Window,
    /// Grid cells computed per run (nodata included: both engines visit every cell).
    pub cells: usize,
    /// Cells FireCast calls burnable (fire type 1 to 3).
    pub burning_cells: usize,
    pub params: BehaviorParams,
    pub machine: String,
    pub threads: usize,
    pub agreement: BehaviorAgreement,
    pub firecast: Timing,
    pub pyretechnics: Timing,
    /// pyretechnics' best seconds over FireCast's (= the cells-per-second ratio).
    pub ratio: f64,
    pub peer: PeerRun,
}

/// Fire behaviour of every cell in `window` (the whole grid by default), FireCast and
/// pyretechnics on one thread each; the agreement on rate of spread, the best of `repeats`
/// times of each, and their ratio.
pub fn bench_behavior(opts: &BenchOptions, window: Option<Window>) -> Result<BehaviorBench, BenchError> {
    let full = opts.check()?;
    let window = window.unwrap_or_else(|| Window::full(&full));
    let land = crop(&full, window);
    let n = window.cells();

    // pyretechnics: the timed runs, and the last run's rates and fire types.
    let mut job = peer_inputs(&opts.params);
    job["mode"] = "behavior".into();
    job["layers"] = peer_layers(&full)?;
    job["window"] = serde_json::json!([
        window.row0,
        window.row0 + window.rows,
        window.col0,
        window.col0 + window.cols
    ]);
    job["repeats"] = opts.repeats.into();
    // FireCast: the same cells on one thread, timed around pyretechnics' timed runs.
    let (seconds, grids, peer) = around_peer(
        opts.repeats,
        || {
            let (s, g) = one_thread(|| {
                let started = Instant::now();
                let g = surface_behavior_grids(&land, &opts.params);
                (started.elapsed().as_secs_f64(), g)
            })?;
            Ok((s, g?))
        },
        || run_peer(&opts.python, &opts.work, job),
    )?;
    if (peer.rows, peer.cols) != (window.rows, window.cols) {
        return Err(BenchError::Input(format!(
            "pyretechnics computed {} x {} cells, FireCast {} x {}",
            peer.cols, peer.rows, window.cols, window.rows
        )));
    }
    let peer_ros = read_f32(&opts.work.join("spread_rate_m_min.f32"), n)?;
    let peer_type = read_u8(&opts.work.join("fire_type.u8"), n)?;

    let agreement = behavior_agreement(&land, &opts.params, &grids, &peer_ros, &peer_type);
    let burning_cells = agreement.firecast_fire_types[1..].iter().sum();
    let firecast = Timing::new(seconds, n);
    let pyretechnics = Timing::new(peer.seconds.clone(), n);
    Ok(BehaviorBench {
        landscape: opts.landscape.clone(),
        window,
        cells: n,
        burning_cells,
        params: opts.params.clone(),
        machine: machine(),
        threads: 1,
        ratio: pyretechnics.best_seconds / firecast.best_seconds.max(1e-12),
        agreement,
        firecast,
        pyretechnics,
        peer,
    })
}

fn behavior_agreement(
    land: &LandfireLandscape,
    params: &BehaviorParams,
    grids: &firecast_sim::behavior::BehaviorGrids,
    peer_ros: &[f32],
    peer_type: &[u8],
) -> BehaviorAgreement {
    let layer = |l: &Option<Vec<f32>>, i: usize| l.as_ref().map_or(f32::NAN, |v| v[i]);
    let mut a = BehaviorAgreement {
        tolerance: ROS_TOLERANCE,
        rule: if params.wind_20ft_mph > 0.0 {
            "with wind: flat cells whose wind adjustment both take the same way (pyretechnics projects \
             the wind onto the slope plane and shelters only at cover >= 15 % and height >= 6 ft)"
                .into()
        } else {
            "no wind: every cell both call surface fire".into()
        },
        compared_cells: 0,
        within_tolerance: 0,
        max_relative_difference: 0.0,
        surface_cells: 0,
        surface_within_tolerance: 0,
        surface_max_relative_difference: 0.0,
        firecast_fire_types: [0; 4],
        pyretechnics_fire_types: [0; 4],
        fire_type_equal_cells: 0,
    };
    for i in 0..peer_ros.len() {
        let ours = grids.fire_type[i];
        let ours_type = if ours == grids.nodata { 0 } else { ours as usize };
        let theirs_type = usize::from(peer_type[i]);
        a.firecast_fire_types[ours_type.min(3)] += 1;
        a.pyretechnics_fire_types[theirs_type.min(3)] += 1;
        if ours_type == theirs_type {
            a.fire_type_equal_cells += 1;
        }
        if ours != FIRE_TYPE_SURFACE || theirs_type != 1 {
            continue;
        }
        let ours_m_min = f64::from(grids.ros_chph[i]) * M_MIN_PER_CH_H;
        let rel = (f64::from(peer_ros[i]) / ours_m_min - 1.0).abs();
        let rel = if rel.is_finite() { rel } else { f64::INFINITY };
        a.surface_cells += 1;
        a.surface_max_relative_difference = a.surface_max_relative_difference.max(rel);
        if rel <= ROS_TOLERANCE {
            a.surface_within_tolerance += 1;
        }
        if comparable_cell(
            params.wind_20ft_mph,
            land.slope_percent[i],
            layer(&land.canopy_cover_pct, i),
            layer(&land.canopy_height_m, i),
        ) {
            a.compared_cells += 1;
            a.max_relative_difference = a.max_relative_difference.max(rel);
            if rel <= ROS_TOLERANCE {
                a.within_tolerance += 1;
            }
        }
    }
    a
}

// ---------------------------------------------------------------------------------------------
// Spread
// ---------------------------------------------------------------------------------------------

/// The burnt areas of the two engines.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BurntAreas {
    pub cell_area_ha: f64,
    pub firecast_cells: usize,
    pub pyretechnics_cells: usize,
    pub both_cells: usize,
    pub firecast_only_cells: usize,
    pub pyretechnics_only_cells: usize,
    /// Cells pyretechnics burnt as passive or active crown fire (FireCast's MTT spreads surface
    /// fire only).
    pub pyretechnics_crown_cells: usize,
    /// FireCast's burnt area over pyretechnics'.
    pub area_ratio: f64,
    /// Cells both burnt over cells either burnt.
    pub jaccard: f64,
    /// Mean |arrival time difference| over the cells both burnt, hours.
    pub mean_abs_arrival_difference_h: f64,
}

/// `firecast bench spread`'s result.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SpreadBench {
    pub landscape: PathBuf,
    pub window: Window,
    /// The ignition cell (column, row; row 0 north) in the landscape.
    pub ignition: (usize, usize),
    pub hours: f64,
    pub stencil_radius: u32,
    pub params: BehaviorParams,
    pub machine: String,
    pub threads: usize,
    pub firecast: Timing,
    /// Cells whose ellipse FireCast evaluated (those the fire's moves reached or crossed).
    pub firecast_ellipses_evaluated: usize,
    pub pyretechnics: Timing,
    /// pyretechnics' best wall seconds over FireCast's (the same 8-hour fire).
    pub wall_ratio: f64,
    /// FireCast's burnt cells per second over pyretechnics'.
    pub cells_per_second_ratio: f64,
    pub areas: BurntAreas,
    pub peer: PeerRun,
}

/// One point ignition at (`col`, `row`) (row 0 north) spread for `hours`, FireCast's MTT engine
/// and pyretechnics' level set on one thread each; times (best of `repeats`), burnt cells per
/// second, their ratios and the burnt areas.
pub fn bench_spread(
    opts: &BenchOptions,
    ignition: (usize, usize),
    hours: f64,
    stencil_radius: u32,
    window: Option<Window>,
) -> Result<SpreadBench, BenchError> {
    let full = opts.check()?;
    if !(hours > 0.0 && hours.is_finite()) {
        return Err(BenchError::Input(format!("hours must be positive, got {hours}")));
    }
    let (col, row) = ignition;
    let window = window.unwrap_or_else(|| Window::full(&full));
    if !window.contains(col, row) {
        return Err(BenchError::Input(format!(
            "ignition cell col={col}, row={row} is outside the {} x {} cells compared (from col {}, row {})",
            window.cols, window.rows, window.col0, window.row0
        )));
    }
    let land = crop(&full, window);
    let (w, h) = (window.cols, window.rows);
    let (icol, irow) = (col - window.col0, row - window.row0);
    let i = irow * w + icol;
    let burnable = land.fuel[i]
        .and_then(FuelModel::by_number)
        .is_some_and(|m| m.burnable);
    if !burnable {
        return Err(BenchError::Input(format!(
            "ignition cell col={col}, row={row} cannot burn (fuel {})",
            land.fuel[i].map_or("nodata".to_string(), |c| c.to_string())
        )));
    }

    // pyretechnics.
    let mut job = peer_inputs(&opts.params);
    job["mode"] = "spread".into();
    job["layers"] = peer_layers(&full)?;
    job["window"] = serde_json::json!([
        window.row0,
        window.row0 + window.rows,
        window.col0,
        window.col0 + window.cols
    ]);
    job["repeats"] = opts.repeats.into();
    job["ignition_row_col"] = serde_json::json!([irow, icol]);
    job["max_duration_min"] = (hours * 60.0).into();
    job["cell_size_m"] = land.grid.pixel_dx.abs().into();

    // FireCast: the fuel beds, then the spread with each cell's ellipse evaluated when the
    // fire's moves first reach it; timed together, on one thread, around pyretechnics' runs.
    let ours = || -> Result<(f64, LazyRun), BenchError> {
        let started = Instant::now();
        let run = landfire_arrival_lazy_h(
            &land,
            &opts.params,
            &[(icol, h - 1 - irow)],
            stencil_radius,
            hours,
        )?;
        Ok((started.elapsed().as_secs_f64(), run))
    };
    let (seconds, run, peer) = around_peer(opts.repeats, ours, || run_peer(&opts.python, &opts.work, job))?;
    let n = w * h;
    let peer_toa = read_f32(&opts.work.join("time_of_arrival_min.f32"), n)?;
    let peer_type = read_u8(&opts.work.join("fire_type.u8"), n)?;
    let ellipses_evaluated = run.ellipses_evaluated;
    let reached = run.reached_h;
    // The reached cells on the landscape's grid (row 0 north).
    let mut ours_h = vec![f64::INFINITY; n];
    for (j, hours) in reached {
        ours_h[(h - 1 - j / w) * w + j % w] = hours;
    }
    let areas = burnt_areas(&land, &ours_h, &peer_toa, &peer_type, hours);
    let firecast = Timing::new(seconds, areas.firecast_cells);
    let pyretechnics = Timing::new(peer.seconds.clone(), areas.pyretechnics_cells);
    Ok(SpreadBench {
        landscape: opts.landscape.clone(),
        window,
        ignition,
        hours,
        stencil_radius,
        params: opts.params.clone(),
        machine: machine(),
        threads: 1,
        wall_ratio: pyretechnics.best_seconds / firecast.best_seconds.max(1e-12),
        cells_per_second_ratio: firecast.cells_per_second / pyretechnics.cells_per_second.max(1e-12),
        firecast_ellipses_evaluated: ellipses_evaluated,
        firecast,
        pyretechnics,
        areas,
        peer,
    })
}

fn burnt_areas(
    land: &LandfireLandscape,
    ours_h: &[f64],
    peer_toa_min: &[f32],
    peer_type: &[u8],
    hours: f64,
) -> BurntAreas {
    let cell_m = land.grid.pixel_dx.abs();
    let mut a = BurntAreas {
        cell_area_ha: cell_m * cell_m / 10_000.0,
        firecast_cells: 0,
        pyretechnics_cells: 0,
        both_cells: 0,
        firecast_only_cells: 0,
        pyretechnics_only_cells: 0,
        pyretechnics_crown_cells: 0,
        area_ratio: 0.0,
        jaccard: 0.0,
        mean_abs_arrival_difference_h: 0.0,
    };
    let mut diff = 0.0;
    for k in 0..ours_h.len() {
        let ours = ours_h[k].is_finite() && ours_h[k] <= hours;
        let theirs_h = f64::from(peer_toa_min[k]) / 60.0;
        let theirs = theirs_h.is_finite() && theirs_h <= hours + 1e-9;
        a.firecast_cells += usize::from(ours);
        a.pyretechnics_cells += usize::from(theirs);
        if theirs && peer_type[k] >= 2 {
            a.pyretechnics_crown_cells += 1;
        }
        match (ours, theirs) {
            (true, true) => {
                a.both_cells += 1;
                diff += (ours_h[k] - theirs_h).abs();
            }
            (true, false) => a.firecast_only_cells += 1,
            (false, true) => a.pyretechnics_only_cells += 1,
            (false, false) => {}
        }
    }
    let either = a.both_cells + a.firecast_only_cells + a.pyretechnics_only_cells;
    a.area_ratio = a.firecast_cells as f64 / (a.pyretechnics_cells as f64).max(1.0);
    a.jaccard = a.both_cells as f64 / (either as f64).max(1.0);
    a.mean_abs_arrival_difference_h = diff / (a.both_cells as f64).max(1.0);
    a
}

// ---------------------------------------------------------------------------------------------
// The flags and lines `firecast bench behavior` and `firecast bench spread` share
// ---------------------------------------------------------------------------------------------

/// The speed goal: FireCast at least this many times pyretechnics on one core.
pub const GOAL: f64 = 20.0;

/// What both benches take.
#[derive(Debug, clap::Args)]
pub struct FireBenchArgs {
    /// LANDFIRE landscape folder (GeoTIFF layers, slope in percent) [default: the Worcester
    /// clip of the FlamMap parity test]
    #[arg(long, value_name = "DIR")]
    pub landscape: Option<PathBuf>,
    /// Fuel layer: fbfm40 or fbfm13.
    #[arg(long, default_value = "fbfm40", value_name = "LAYER")]
    pub fuel: String,
    /// Fuel moisture, percent: D1,D10,D100,HERB,WOODY [default: FlamMap's run on the
    /// Worcester clip].
    #[arg(long, default_value = "6,8,10,75,60", value_name = "D1,D10,D100,HERB,WOODY")]
    pub moisture: String,
    /// Foliar moisture content, percent.
    #[arg(long, default_value_t = 120.0, value_name = "PCT")]
    pub foliar_moisture: f64,
    /// Direction the wind comes from, degrees clockwise from north.
    #[arg(long, default_value_t = 225.0, value_name = "DEG")]
    pub wind_from_deg: f64,
    /// Timed repeats of each engine, the least: FireCast's side goes on until it has spent as
    /// many seconds as pyretechnics' repeats (the best counts).
    #[arg(long, default_value_t = 5, value_name = "N")]
    pub repeats: usize,
    /// A small window of cells and one repeat (for tests).
    #[arg(long)]
    pub quick: bool,
    /// pyretechnics' Python [default: .venv-peers/pyretechnics/bin/python, from `cargo xtask
    /// setup`].
    #[arg(long, value_name = "PYTHON")]
    pub python: Option<PathBuf>,
}

/// The Worcester clip's grass cell (GR2) the spread bench ignites by default.
pub const DEFAULT_IGNITION: (usize, usize) = (362, 457);
/// `--quick` windows: the behaviour grid's centre, and around the ignition.
pub const QUICK_BEHAVIOR: usize = 128;
pub const QUICK_SPREAD: usize = 160;

/// The benches' options from the flags both take, and the work folder to remove after.
pub fn options(
    ctx: &Context,
    a: &FireBenchArgs,
    wind_mph: f64,
    crown: &str,
) -> anyhow::Result<(BenchOptions, PathBuf)> {
    use firecast_sim::behavior::{BehaviorParams, FuelChoice, MoisturePercent, SlopeMode};
    let python = find_python(a.python.as_deref(), &ctx.root, Venv::Peer(PEER))?;
    let fuel = match a.fuel.to_ascii_lowercase().as_str() {
        "fbfm40" => FuelChoice::Fbfm40,
        "fbfm13" => FuelChoice::Fbfm13,
        other => anyhow::bail!("--fuel {other}: expected fbfm40 or fbfm13"),
    };
    let crown = firecast_sim::crown::CrownMethod::parse(crown)
        .ok_or_else(|| anyhow::anyhow!("--crown {crown}: expected finney, scott-reinhardt or none"))?;
    let params = BehaviorParams {
        fuel,
        moisture: MoisturePercent::parse(&a.moisture).map_err(|e| anyhow::anyhow!("--moisture: {e}"))?,
        wind_20ft_mph: wind_mph,
        wind_from_deg: a.wind_from_deg,
        slope: SlopeMode::AsGiven,
        wind_limit: false,
        crown,
        foliar_moisture_pct: a.foliar_moisture,
    };
    params.validate().map_err(|e| anyhow::anyhow!("{e}"))?;
    let landscape = ctx
        .root
        .join(a.landscape.clone().unwrap_or_else(|| WORCESTER.into()));
    let work = std::env::temp_dir().join(format!("firecast-bench-pyretechnics-{}", std::process::id()));
    let opts = BenchOptions {
        landscape,
        params,
        repeats: if a.quick { 1 } else { a.repeats.max(1) },
        python,
        work: work.clone(),
    };
    Ok((opts, work))
}

/// A path inside the project as the user would type it.
pub fn shown<'a>(root: &std::path::Path, path: &'a std::path::Path) -> &'a std::path::Path {
    path.strip_prefix(root).unwrap_or(path)
}

/// The inputs, as the tables' heading line names them.
pub fn inputs_line(p: &firecast_sim::behavior::BehaviorParams) -> String {
    let m = &p.moisture;
    format!(
        "moisture {}/{}/{}/{}/{} %, foliar {} %, 20-ft wind {} mi/h from {}°",
        m.dead_1h,
        m.dead_10h,
        m.dead_100h,
        m.live_herbaceous,
        m.live_woody,
        p.foliar_moisture_pct,
        p.wind_20ft_mph,
        p.wind_from_deg
    )
}

/// A table row of one engine's timing.
pub fn timing_row(name: String, t: &Timing, unit: &str, ratio: f64) -> Vec<String> {
    vec![
        name,
        t.seconds.len().to_string(),
        format!("{:.4}", t.best_seconds),
        format!("{:.0} {unit}", t.cells_per_second),
        format!("{ratio:.1}x"),
    ]
}

/// The goal's line, met or not.
pub fn goal_line(ratio: f64) -> String {
    format!(
        "goal >= {GOAL:.0}x pyretechnics on one core: {} ({ratio:.1}x)",
        if ratio >= GOAL { "met" } else { "NOT met" }
    )
}

#[cfg(test)]
mod tests {
    use firecast_sim::behavior::surface_behavior_grids;

    use super::*;

    #[test]
    fn firecast_side_samples_at_least_the_peers_seconds() {
        let peer = |seconds: Vec<f64>| {
            move || {
                Ok(PeerRun {
                    rows: 1,
                    cols: 1,
                    seconds,
                    pyretechnics: String::new(),
                    python: String::new(),
                    numpy: String::new(),
                    stop_time_min: None,
                    stop_condition: None,
                })
            }
        };
        // A 1 ms call beside a peer that timed 2 × 10 ms: 20 repeats, not 2.
        let (seconds, _, _) = around_peer(2, || Ok((0.001, ())), peer(vec![0.01, 0.01])).expect("runs");
        assert_eq!(seconds.len(), 20);
        // A call slower than the peer's: the repeats asked for, no fewer.
        let (seconds, _, _) = around_peer(5, || Ok((0.5, ())), peer(vec![0.01])).expect("runs");
        assert_eq!(seconds.len(), 5);
        // A call too short to measure stops at the bound.
        let (seconds, _, _) = around_peer(1, || Ok((0.0, ())), peer(vec![1.0])).expect("runs");
        assert_eq!(seconds.len(), MAX_REPEATS);
    }

    #[test]
    fn comparable_cells_follow_the_two_models() {
        // No wind: every cell.
        assert!(comparable_cell(0.0, 40.0, 15.0, 2.0));
        // Wind: sloped cells are not comparable (pyretechnics' slope-plane projection).
        assert!(!comparable_cell(10.0, 5.0, 0.0, 0.0));
        // Flat, open: comparable; flat under a canopy both shelter: comparable.
        assert!(comparable_cell(10.0, 0.0, 0.0, 0.0));
        assert!(comparable_cell(10.0, 0.0, 60.0, 20.0));
        // Sparse canopy (FlamMap shelters, pyretechnics does not), or on the threshold: not.
        assert!(!comparable_cell(10.0, 0.0, 10.0, 20.0));
        assert!(!comparable_cell(10.0, 0.0, 15.0, 20.0));
        assert!(!comparable_cell(10.0, 0.0, 60.0, 1.0));
    }

    fn worcester() -> LandfireLandscape {
        LandfireLandscape::read_dir(
            &std::path::PathBuf::from(
                std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
            )
            .join("..")
            .join("..")
            .join(WORCESTER),
            firecast_landscape::landfire::FuelLayer::Fbfm40,
        )
        .expect("the Worcester fixture")
    }

    fn windy_params() -> BehaviorParams {
        serde_json::from_value(serde_json::json!({
            "moisture": {"dead_1h": 6, "dead_10h": 8, "dead_100h": 10, "live_herbaceous": 75, "live_woody": 60},
            "foliar_moisture_pct": 120,
            "wind_20ft_mph": 15.0,
            "wind_from_deg": 225.0
        }))
        .expect("params")
    }

    /// Scott & Reinhardt's crown fire under a 15 mi/h wind beside pyretechnics' on the cells where
    /// the two models' wind handling agrees (flat cells whose canopy both shelter the same way,
    /// [`comparable_cell`]) and where pyretechnics looks for crown fire (cover > 40 %): fire type
    /// and, where both spread an active crown fire, the crown rate (Rothermel's 1991 rate here,
    /// Cruz et al.'s 2005 rate there). Skipped when pyretechnics' venv is missing.
    #[test]
    fn scott_reinhardt_crown_fire_under_wind_beside_pyretechnics_on_flat_cells() {
        let root = std::path::PathBuf::from(
            std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
        )
        .join("../..");
        let Ok(python) = crate::python::find_python(None, &root, crate::python::Venv::Peer(PEER)) else {
            eprintln!(
                "skipped: pyretechnics is not installed in .venv-peers/{PEER} (`cargo xtask setup` installs it)"
            );
            return;
        };
        let mut params = windy_params();
        params.crown = firecast_sim::crown::CrownMethod::ScottReinhardt;
        let work = std::env::temp_dir().join(format!("firecast-crown-wind-{}", std::process::id()));
        let opts = BenchOptions {
            landscape: root.join(WORCESTER),
            params: params.clone(),
            repeats: 1,
            python,
            work: work.clone(),
        };
        let bench = bench_behavior(&opts, None).expect("both engines run");
        assert!(bench.agreement.holds(), "{:?}", bench.agreement);
        let land = worcester();
        let n = land.grid.width * land.grid.height;
        let peer_ros = read_f32(&work.join("spread_rate_m_min.f32"), n).expect("rates");
        let peer_type = read_u8(&work.join("fire_type.u8"), n).expect("types");
        std::fs::remove_dir_all(&work).ok();
        let grids = surface_behavior_grids(&land, &params).expect("grids");
        let layer = |l: &Option<Vec<f32>>, i: usize| l.as_ref().map_or(f32::NAN, |v| v[i]);
        let mut confusion = [[0usize; 4]; 4];
        let mut crown_ratio: [Vec<f64>; 4] = Default::default();
        let mut sparse_crown = 0;
        for i in 0..n {
            let cover = layer(&land.canopy_cover_pct, i);
            let ours = grids.fire_type[i];
            if ours == grids.nodata
                || ours < 1.0
                || !comparable_cell(
                    params.wind_20ft_mph,
                    land.slope_percent[i],
                    cover,
                    layer(&land.canopy_height_m, i),
                )
            {
                continue;
            }
            if cover.is_nan() || cover <= 40.0 {
                // pyretechnics does not look for crown fire here.
                sparse_crown += usize::from(ours >= 2.0);
                continue;
            }
            let (a, b) = (ours as usize, usize::from(peer_type[i]).min(3));
            confusion[a][b] += 1;
            if a == b {
                crown_ratio[a].push(f64::from(peer_ros[i]) / (f64::from(grids.ros_chph[i]) * M_MIN_PER_CH_H));
            }
        }
        for r in &mut crown_ratio {
            r.sort_by(f64::total_cmp);
        }
        let range = |r: &[f64]| (r.first().copied(), r.get(r.len() / 2).copied(), r.last().copied());
        let cells: usize = confusion.iter().flatten().sum();
        let equal: usize = (0..4).map(|k| confusion[k][k]).sum();
        let crown_ours: usize = confusion[2..].iter().flatten().sum();
        let crown_both: usize = confusion[2..].iter().map(|r| r[2] + r[3]).sum();
        eprintln!(
            "flat comparable burning cells at cover > 40 %: {cells}; fire type equal {equal}; \
             FireCast crown {crown_ours}, both crown {crown_both}; confusion (rows FireCast \
             surface/passive/active, columns pyretechnics none/surface/passive/active): {:?}; \
             rate pyretechnics/FireCast (min, median, max) where both surface {:?}, both passive {:?}, \
             both active {:?}; FireCast crown cells at cover <= 40 % (not looked for there): {sparse_crown}",
            &confusion[1..],
            range(&crown_ratio[1]),
            range(&crown_ratio[2]),
            range(&crown_ratio[3]),
        );
        // Where the two models' wind and crown rules agree, they call the same fire type.
        assert!(
            cells >= 100 && crown_both > 0,
            "{cells} cells, {crown_both} crown"
        );
        assert_eq!(equal, cells, "{confusion:?}");
    }
}
