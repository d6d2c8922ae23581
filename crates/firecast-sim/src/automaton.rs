//! The Concord / FireCastRL cellular automaton (docs/spec/fire-model.md §A6–§A9), driven by either the
//! Concord compatibility kernel or the behave Rothermel kernel.
//!
//! Semantics (P2 defaults, docs/spec/fire-model.md §A6.3): a cell spreads only at the instant it
//! ignites, scheduling the ignition times of its 20 neighbours (radius 2.5 cells, line of sight
//! through non-burnable cells, docs/spec/fire-model.md §A6.4 "P2 scheme"; the original BFS search
//! is an option, see [`Neighbourhood`]); it burns for at most 500 min, shortened to travel time +
//! 200 min; its burn index (BI) is fixed by the fastest rate that reached it; once the daily
//! low-intensity latch fires, Low-BI cells no longer spread.
//!
//! State is struct-of-arrays over row-major cells (index `y * width + x`, row 0 south). Only
//! cells that burn or are scheduled to ignite are visited per update (active lists); all
//! scratch buffers are reused, so an update does not allocate once warm. Random draws (the
//! latch, once per new day; the cosmetic fire-survivor flag of eligible cells burning out, in
//! row-major order as P2 draws them) come from one seeded generator per automaton.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use firecast_landscape::{LandCoverScheme, Landscape};

use crate::concord::{
    ConcordSpread, ConcordWind, FIRECASTRL_ZONES, LandCover, MoistureTable, NON_BURNABLE_MOISTURE,
    SpreadVariant,
};
use crate::fuel::FuelModel;
use crate::random::{RandomSource, Uniform};
use crate::rothermel::{FuelMoisture, RothermelError, SpreadInputs, SurfaceFuelBed};

/// Fixed simulated time per environment step (docs/spec/fire-model.md §A7): 4 × 2.9916 min.
pub const DEFAULT_DT_MIN: f64 = 11.9664;
/// FireCastRL's daily probabilities of the end-of-low-intensity latch, days 0–7
/// (docs/spec/fire-model.md §A6.3).
pub const FIRECASTRL_LATCH: [f64; 8] = [0.0, 0.1, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0];
/// Concord's daily latch probabilities, days 0–5.
pub const CONCORD_LATCH: [f64; 6] = [0.0, 0.6, 0.6, 0.7, 0.8, 1.0];
/// FireCastRL's non-burnable ("river") MODIS classes (docs/spec/fire-model.md §A3.1; the code's 18
/// does not exist).
pub const FIRECASTRL_RIVER_CLASSES: [u16; 4] = [12, 14, 16, 17];
/// FireCastRL's fire-survivor classes: permanent wetlands (Concord used forests).
pub const FIRECASTRL_SURVIVOR_CLASSES: [u16; 1] = [11];
/// Minutes per simulated day.
const MIN_PER_DAY: f64 = 1440.0;

const FLAG_RIVER: u8 = 1;
const FLAG_FIRE_LINE: u8 = 2;
const FLAG_ISLAND: u8 = 4;
/// [`Automaton::bfs_window`] entry of a window cell outside the radius (or the source).
const BFS_OUTSIDE: u16 = u16::MAX;
/// The original BFS's 4-connected steps, in its order: west, east, south, north (grid y).
const BFS_STEPS: [(i32, i32); 4] = [(-1, 0), (1, 0), (0, -1), (0, 1)];
/// Bit pattern of a [`Automaton::rate_cache`] entry not yet computed (a NaN payload that no
/// arithmetic produces).
const RATE_UNSET: u64 = 0x7ff8_dead_beef_0001;
/// Source cells per block of the rate cache (a power of two).
const RATE_BLOCK_CELLS: usize = 64;

/// The memoised spread rates, allocated a block of source cells at a time when a fire first
/// reaches it: a fire touches a small part of its map, and a server running 200 live fires
/// should not hold (and clear) every map's full table up front. Blocks are shared by clones.
struct RateCache {
    blocks: Box<[std::sync::OnceLock<Box<[AtomicU64]>>]>,
    per_cell: usize,
}

impl RateCache {
    fn new(cells: usize, per_cell: usize) -> Self {
        Self {
            blocks: (0..cells.div_ceil(RATE_BLOCK_CELLS))
                .map(|_| std::sync::OnceLock::new())
                .collect(),
            per_cell,
        }
    }

    /// The entry of source `c` along offset `k`.
    #[inline(always)]
    fn entry(&self, c: usize, k: usize) -> &AtomicU64 {
        let block = self.blocks[c / RATE_BLOCK_CELLS].get_or_init(|| {
            (0..RATE_BLOCK_CELLS * self.per_cell)
                .map(|_| AtomicU64::new(RATE_UNSET))
                .collect()
        });
        &block[(c % RATE_BLOCK_CELLS) * self.per_cell + k]
    }
}

/// Fire state of a cell (docs/spec/fire-model.md §A6.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum FireState {
    Unburnt = 0,
    Burning = 1,
    Burnt = 2,
}

impl FireState {
    fn from_u8(v: u8) -> Self {
        match v {
            1 => Self::Burning,
            2 => Self::Burnt,
            _ => Self::Unburnt,
        }
    }
}

/// Burn index (docs/spec/fire-model.md §A6.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u8)]
pub enum BurnIndex {
    Low = 0,
    Medium = 1,
    High = 2,
}

impl BurnIndex {
    fn from_u8(v: u8) -> Self {
        match v {
            1 => Self::Medium,
            2 => Self::High,
            _ => Self::Low,
        }
    }
}

/// Which spread kernel drives the automaton.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum KernelConfig {
    /// The Concord/FireCastRL kernel (MODIS landscapes only): zone drought → moisture table.
    Concord {
        #[serde(default)]
        variant: SpreadVariant,
        #[serde(default)]
        moisture_table: MoistureTable,
    },
    /// behave's Rothermel kernel. MODIS classes map to Anderson models by
    /// [`modis_to_fuel_model`]; FBFM13/FBFM40 codes are fuel-model numbers. Each helitack drop
    /// on a cell adds `drop_moisture_increment` to its dead 1/10/100-h moistures (capped by
    /// the drop cap), the Rothermel analogue of "drought lowered by one level".
    Rothermel {
        /// Default: the dry-summer scenario of [`KernelConfig::rothermel_default`] (a scenario
        /// that takes the day's moisture from its weather replaces it).
        #[serde(default = "dry_summer_moisture")]
        moisture: FuelMoisture,
        #[serde(default = "default_drop_moisture_increment")]
        drop_moisture_increment: f64,
    },
}

fn default_drop_moisture_increment() -> f64 {
    0.05
}

fn dry_summer_moisture() -> FuelMoisture {
    FuelMoisture::from_percent(6.0, 7.0, 8.0, 60.0, 90.0)
}

impl Default for KernelConfig {
    fn default() -> Self {
        Self::Concord {
            variant: SpreadVariant::default(),
            moisture_table: MoistureTable::default(),
        }
    }
}

impl KernelConfig {
    /// Rothermel with a dry-summer moisture scenario (6/7/8 % dead, 60 % herb, 90 % woody).
    pub fn rothermel_default() -> Self {
        Self::Rothermel {
            moisture: dry_summer_moisture(),
            drop_moisture_increment: default_drop_moisture_increment(),
        }
    }
}

/// Wind: speed (mi/h) at a stated height and the direction it comes FROM (degrees, 0 = north,
/// 90 = east, as GRIDMET `th`).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wind {
    pub speed_mph: f64,
    pub from_direction_deg: f64,
    /// Where `speed_mph` was measured. Midflame (the default, and FireCastRL's) is used as
    /// given; a 20-ft or 10-m wind is brought to midflame per fuel with the unsheltered wind
    /// adjustment factor of that fuel's bed depth.
    #[serde(default)]
    pub measured_at: WindHeight,
}

/// Height of a wind speed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WindHeight {
    #[default]
    Midflame,
    /// 20 ft above the vegetation (US fire-weather convention).
    TwentyFoot,
    /// 10 m above ground (GRIDMET `vs`, METAR): 20-ft = 10-m / 1.15 (behave's convention).
    TenMetre,
}

impl Wind {
    /// Midflame speed over a fuel bed `depth_ft` deep (docs/spec/fire-model.md §B7, docs/spec/data.md §9).
    pub fn midflame_mph(&self, depth_ft: f64) -> f64 {
        let speed = self.speed_mph.max(0.0);
        match self.measured_at {
            WindHeight::Midflame => speed,
            WindHeight::TwentyFoot => unsheltered_waf(depth_ft) * speed,
            WindHeight::TenMetre => unsheltered_waf(depth_ft) * speed / 1.15,
        }
    }
}

/// Albini & Baughman (1979) unsheltered wind adjustment factor, 1.83 / ln((20 + 0.36 δ) /
/// (0.13 δ)) for a bed δ ft deep, as behave computes it (0.362 for GR2's 1-ft bed); 0 for an
/// empty bed.
pub fn unsheltered_waf(depth_ft: f64) -> f64 {
    if depth_ft > 0.0 {
        1.83 / ((20.0 + 0.36 * depth_ft) / (0.13 * depth_ft)).ln()
    } else {
        0.0
    }
}

/// Helitack footprint shape (docs/spec/fire-model.md §A8).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum HelitackFootprint {
    /// FireCastRL's mirrored loop: the radius-r disc minus the cell (−r, 0) (80 cells at r = 5).
    #[default]
    FireCastRl,
    /// The full disc (81 cells at r = 5).
    FullDisc,
    /// Physical units (docs/spec/fire-model.md §B13): `helitack_volume_gal` laid at the coverage
    /// level the fuel under the drop needs wets 100 · V / level ft², a disc over the grid
    /// whatever the cell size; a cell is treated each time the coverage it has received adds
    /// up to a whole cell at its own fuel's level. `helitack_radius_ft` is not used.
    Coverage,
}

/// How a spreading cell finds its neighbours (docs/spec/fire-model.md §A6.4). Both reach the same
/// cells (the offsets within the radius); they differ in which are blocked by non-burnable cells
/// and in the order they are offered, which decides ties of ignition time.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Neighbourhood {
    /// P2 (`aisystems-lab/wildfire-env` HEAD, FireCast's default): the offsets in row-major
    /// order, each skipped when it, or any intermediate point of the line from the source to
    /// it, is outside the grid or not burnable for the source's BI.
    #[default]
    LineOfSight,
    /// The original search of Concord, the FireCastRL TypeScript engine (T), P1 and 7a1edf8: a
    /// breadth-first search over 4-connected steps (west, east, south, north) from the source,
    /// within the radius. A reached cell not burnable for the source's BI blocks (it is not
    /// offered or expanded) and, from then on, a cell is offered and expanded only if the
    /// Bresenham line from it to the source (endpoints included, ties not stepped) is clear.
    /// Cells are offered in BFS order. Slower: the search runs per spreading cell.
    Bfs,
}

/// Automaton configuration. Defaults reproduce the P2 engine with zero wind.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimConfig {
    pub kernel: KernelConfig,
    pub wind: Wind,
    /// Simulated minutes per step.
    pub dt_min: f64,
    /// Daily probability of the low-intensity latch, indexed by day; missing days count as 0.
    pub latch_daily_probability: Vec<f64>,
    /// MODIS classes treated as non-burnable "river" cells (block spread and line of sight).
    pub river_classes: Vec<u16>,
    /// Neighbourhood radius in cells (2.5 → 20 neighbours).
    pub neighbour_radius_cells: f64,
    /// Neighbour search: `line_of_sight` (P2, the default) or `bfs` (Concord, T, P1, 7a1edf8).
    pub neighbourhood: Neighbourhood,
    pub max_burn_time_min: f64,
    pub min_cell_burn_time_min: f64,
    pub helitack_radius_ft: f64,
    pub helitack_footprint: HelitackFootprint,
    /// US gallons per drop (`coverage` footprint only): the paper's Table IV implies 800.
    pub helitack_volume_gal: f64,
    /// Drops counted in the drought/moisture formula at most this many times.
    pub helitack_drop_cap: u8,
    pub fire_line_depth_ft: f64,
    pub max_fire_line_length_ft: f64,
    /// Probability that an eligible cell (MODIS class in `fire_survivor_classes`, BI Low)
    /// burning out is flagged a survivor. Cosmetic, but each eligible burnout consumes a
    /// draw, as in the originals, so the latch days match theirs under `random: python_mt`.
    pub fire_survival_probability: f64,
    pub fire_survivor_classes: Vec<u16>,
    /// The generator behind every draw.
    pub random: RandomSource,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            kernel: KernelConfig::default(),
            wind: Wind::default(),
            dt_min: DEFAULT_DT_MIN,
            latch_daily_probability: FIRECASTRL_LATCH.to_vec(),
            river_classes: FIRECASTRL_RIVER_CLASSES.to_vec(),
            neighbour_radius_cells: 2.5,
            neighbourhood: Neighbourhood::LineOfSight,
            max_burn_time_min: 500.0,
            min_cell_burn_time_min: 200.0,
            helitack_radius_ft: 2640.0,
            helitack_footprint: HelitackFootprint::FireCastRl,
            helitack_volume_gal: 800.0,
            helitack_drop_cap: 3,
            fire_line_depth_ft: 2000.0,
            max_fire_line_length_ft: 15_000.0,
            fire_survival_probability: 0.1,
            fire_survivor_classes: FIRECASTRL_SURVIVOR_CLASSES.to_vec(),
            random: RandomSource::default(),
        }
    }
}

/// Errors building or driving the automaton.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    #[error("the Concord kernel needs a MODIS IGBP landscape, got {0:?}")]
    SchemeMismatch(LandCoverScheme),
    #[error("unknown fuel model {0} in the landscape")]
    UnknownFuelModel(u16),
    #[error(transparent)]
    Rothermel(#[from] RothermelError),
    #[error("invalid configuration: {0}")]
    Config(String),
    #[error("cell ({x}, {y}) is outside the {width} x {height} grid")]
    OutOfBounds {
        x: i64,
        y: i64,
        width: usize,
        height: usize,
    },
    #[error("fire line of {length_ft:.0} ft exceeds the maximum {max_ft:.0} ft")]
    FireLineTooLong { length_ft: f64, max_ft: f64 },
}

/// MODIS IGBP class → Anderson (1982) fuel model for the Rothermel kernel. Documented choice:
///
/// | MODIS | Model | | MODIS | Model |
/// |---|---|---|---|---|
/// | 1 Evergreen needleleaf | 10 timber (litter + understory) | | 10 Grasslands | 1 short grass |
/// | 2 Evergreen broadleaf | 8 closed timber litter | | 11 Wetlands | 3 tall grass |
/// | 3 Deciduous needleleaf | 8 | | 12 Croplands | 93 NB3 agricultural |
/// | 4 Deciduous broadleaf | 9 hardwood litter | | 13 Urban | 91 NB1 |
/// | 5 Mixed forest | 9 | | 14 Cropland mosaic | 93 NB3 |
/// | 6 Closed shrublands | 4 chaparral | | 15 Snow/ice | 92 NB2 |
/// | 7 Open shrublands | 6 dormant brush | | 16 Barren | 99 NB9 |
/// | 8 Woody savannas | 2 timber grass | | 17 Water | 98 NB8 |
/// | 9 Savannas | 2 timber grass | | other | 99 NB9 |
pub fn modis_to_fuel_model(class: u16) -> u16 {
    match class {
        1 => 10,
        2 | 3 => 8,
        4 | 5 => 9,
        6 => 4,
        7 => 6,
        8 | 9 => 2,
        10 => 1,
        11 => 3,
        12 | 14 => 93,
        13 => 91,
        15 => 92,
        17 => 98,
        _ => 99,
    }
}

/// One neighbour offset with its Bresenham intermediates (source → target, endpoints excluded).
#[derive(Debug, Clone, Copy)]
struct Offset {
    dx: i32,
    dy: i32,
    dist_ft: f64,
    /// Azimuth of the offset, degrees clockwise from north (Rothermel kernel).
    azimuth_deg: f64,
    inter_start: usize,
    inter_end: usize,
}

/// Integer points of a Bresenham line from a to b, both included.
pub fn bresenham(a: (i64, i64), b: (i64, i64)) -> Vec<(i64, i64)> {
    let (mut x, mut y) = a;
    let dx = (b.0 - a.0).abs();
    let dy = -(b.1 - a.1).abs();
    let sx = if a.0 < b.0 { 1 } else { -1 };
    let sy = if a.1 < b.1 { 1 } else { -1 };
    let mut err = dx + dy;
    let mut out = vec![(x, y)];
    while (x, y) != b {
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
        out.push((x, y));
    }
    out
}

/// Integer points of the line from a to b, both included, stepping on strict error tests (the
/// original engines' `forEachPointBetween`): ties go to a single-axis step, so the line is
/// not symmetric and its direction matters.
fn strict_line(a: (i32, i32), b: (i32, i32)) -> Vec<(i32, i32)> {
    let (mut x, mut y) = a;
    let dx = (b.0 - a.0).abs();
    let dy = (b.1 - a.1).abs();
    let sx = if a.0 < b.0 { 1 } else { -1 };
    let sy = if a.1 < b.1 { 1 } else { -1 };
    let mut err = dx - dy;
    let mut out = vec![(x, y)];
    while (x, y) != b {
        let e2 = 2 * err;
        if e2 > -dy {
            err -= dy;
            x += sx;
        }
        if e2 < dx {
            err += dx;
            y += sy;
        }
        out.push((x, y));
    }
    out
}

/// The kernel's tables, indexed by fuel slot (winds) and slot × drop level (fuels).
#[derive(Clone)]
enum Kernel {
    Concord {
        spreads: Vec<ConcordSpread>,
        winds: Vec<ConcordWind>,
    },
    Rothermel {
        beds: Vec<SurfaceFuelBed>,
        wind_mph: Vec<f64>,
        wind_toward_deg: f64,
    },
}

/// Result of one helitack drop.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DropOutcome {
    /// Footprint cells inside the grid (`coverage` footprint: cells the drop completed a
    /// treatment of).
    pub cells: u32,
    /// Burning cells set back to Unburnt.
    pub quenched: u32,
}

/// The cells one drop wets: (dx, dy, fraction of the cell).
type DropPattern = Vec<(i32, i32, f32)>;

/// Physical drops' per-cell data (the `coverage` footprint).
#[derive(Clone)]
struct Coverage {
    /// Coverage level the cell's fuel needs, gal/100 ft² (0: non-burnable).
    level: Vec<f32>,
    /// (level, the drop's cells with the fraction of each it wets) per level in the landscape.
    patterns: Vec<(f32, DropPattern)>,
    /// Whole-cell coverages received this episode.
    received: Vec<f32>,
}

/// The cellular automaton.
///
/// A clone shares the spread-rate cache with its original (the cache is a pure function of
/// landscape and configuration), so the environments of a `VecEnv` fill and read one cache
/// instead of one 6 MB cache each.
#[derive(Clone)]
pub struct Automaton {
    width: usize,
    height: usize,
    cell_size_ft: f64,
    cfg: SimConfig,
    kernel: Kernel,
    levels: usize,
    offsets: Vec<Offset>,
    intermediates: Vec<(i32, i32)>,
    footprint: Vec<(i32, i32)>,
    coverage: Option<Box<Coverage>>,
    // BFS neighbourhood: a (2r+1)² window around the source (index (dy+r)·side + dx+r) mapping
    // to offset indices, per offset the line points from it to the source (candidate
    // excluded, source included), and scratch.
    bfs_radius: i32,
    bfs_window: Vec<u16>,
    bfs_lines: Vec<(i32, i32)>,
    bfs_line_range: Vec<(u32, u32)>,
    /// Window cells reached in the current search carry the current stamp.
    bfs_seen: Vec<u32>,
    bfs_stamp: u32,
    bfs_queue: Vec<u16>,
    /// Offset indices offered by the current search, in BFS order.
    bfs_found: Vec<u16>,
    // Static per cell.
    slot: Vec<u16>,
    base_flags: Vec<u8>,
    base_elev: Vec<f64>,
    /// (Medium, High) rate thresholds (ft/min) per fuel slot.
    slot_bi: Vec<[f64; 2]>,
    // Dynamic per cell.
    flags: Vec<u8>,
    elev: Vec<f64>,
    state: Vec<u8>,
    ign: Vec<f64>,
    burn_time: Vec<f64>,
    spread_rate: Vec<f64>,
    bi: Vec<u8>,
    drops: Vec<u8>,
    /// Static: the cell's class may be flagged a fire survivor.
    survivor_eligible: Vec<bool>,
    survivor: Vec<bool>,
    in_sched: Vec<bool>,
    new_ign: Vec<f64>,
    /// Memoised spread rate from source cell `c` along offset `k` (one source's entries
    /// contiguous, in blocks of sources allocated on first use) for the unmodified landscape: no helitack drop on
    /// the target, no fire line on the target or the source. The rate is then a pure function
    /// of (fuel entry, offset, rise), so entries stay valid across resets; `RATE_UNSET` marks
    /// an entry not yet computed. Shared by clones: two threads filling the same entry store
    /// the same bits, so relaxed atomics suffice and results do not depend on the schedule.
    rate_cache: Arc<RateCache>,
    // Active lists and scratch.
    burning: Vec<u32>,
    scheduled: Vec<u32>,
    touched: Vec<u32>,
    igniting: Vec<u32>,
    burnouts: Vec<u32>,
    dirty: Vec<u32>,
    // Scalars.
    time: f64,
    day: u64,
    latch: bool,
    fire_did_stop: bool,
    n_burning: u32,
    n_burnt: u32,
    rng: Uniform,
}

impl Automaton {
    /// Builds the automaton for a landscape (all cells unburnt, time 0).
    pub fn new(landscape: &Landscape, cfg: &SimConfig) -> Result<Self, SimError> {
        let (w, h) = (landscape.width, landscape.height);
        let n = landscape.len();
        if !(cfg.dt_min > 0.0 && cfg.dt_min.is_finite()) {
            return Err(SimError::Config(format!(
                "dt_min must be positive, got {}",
                cfg.dt_min
            )));
        }
        if !(cfg.neighbour_radius_cells >= 1.0 && cfg.neighbour_radius_cells <= 8.0) {
            return Err(SimError::Config(
                "neighbour_radius_cells must be in [1, 8]".into(),
            ));
        }
        if u32::try_from(n).is_err() {
            return Err(SimError::Config("grid too large".into()));
        }
        let levels = usize::from(cfg.helitack_drop_cap) + 1;
        let cell = landscape.cell_size_ft;
        let mut slot = vec![0u16; n];
        let mut base_flags = vec![0u8; n];
        let kernel;
        let mut slot_bi = Vec::new();
        match &cfg.kernel {
            KernelConfig::Concord {
                variant,
                moisture_table,
            } => {
                if landscape.scheme != LandCoverScheme::ModisIgbp {
                    return Err(SimError::SchemeMismatch(landscape.scheme));
                }
                // Slot = MODIS class 0..=17; slot 0 (unknown codes) never burns.
                let mut spreads = Vec::with_capacity(18 * levels);
                for class in 0..18u16 {
                    let lc = LandCover::from_modis_class(class as u8);
                    for d in 0..levels {
                        let spread = match lc {
                            Some(lc) if !cfg.river_classes.contains(&class) => {
                                let drought = FIRECASTRL_ZONES[usize::from(class)]
                                    .default_drought
                                    .after_helitack_drops(d as u32);
                                ConcordSpread::new(
                                    &lc.fuel(),
                                    lc.moisture_frac(*moisture_table, drought),
                                    *variant,
                                )
                            }
                            _ => ConcordSpread::new(
                                &LandCover::Grasslands.fuel(),
                                NON_BURNABLE_MOISTURE,
                                *variant,
                            ),
                        };
                        spreads.push(spread);
                    }
                    slot_bi.push(concord_bi_thresholds(class));
                }
                for (i, &code) in landscape.land_cover.iter().enumerate() {
                    let valid = (1..=17).contains(&code);
                    slot[i] = if valid { code } else { 0 };
                    if !valid || cfg.river_classes.contains(&code) {
                        base_flags[i] |= FLAG_RIVER;
                    }
                }
                let winds = (0..18u8)
                    .map(|class| ConcordWind {
                        speed_mph: match cfg.wind.measured_at {
                            // As given, bit for bit (FireCastRL parity).
                            WindHeight::Midflame => cfg.wind.speed_mph,
                            _ => cfg.wind.midflame_mph(
                                LandCover::from_modis_class(class).map_or(0.0, |lc| lc.fuel().depth_ft),
                            ),
                        },
                        from_direction_deg: cfg.wind.from_direction_deg,
                    })
                    .collect();
                kernel = Kernel::Concord { spreads, winds };
            }
            KernelConfig::Rothermel {
                moisture,
                drop_moisture_increment,
            } => {
                let mut models: Vec<u16> = Vec::new();
                for (i, &code) in landscape.land_cover.iter().enumerate() {
                    let (model, river) = match landscape.scheme {
                        LandCoverScheme::ModisIgbp => {
                            let river = !(1..=17).contains(&code) || cfg.river_classes.contains(&code);
                            (modis_to_fuel_model(code), river)
                        }
                        LandCoverScheme::Fbfm13 | LandCoverScheme::Fbfm40 => {
                            (code, (91..=99).contains(&code))
                        }
                    };
                    let s = match models.iter().position(|&m| m == model) {
                        Some(s) => s,
                        None => {
                            models.push(model);
                            models.len() - 1
                        }
                    };
                    slot[i] = s as u16;
                    if river {
                        base_flags[i] |= FLAG_RIVER;
                    }
                }
                let mut beds = Vec::with_capacity(models.len() * levels);
                let mut wind_mph = Vec::with_capacity(models.len());
                for &m in &models {
                    let model = FuelModel::by_number(m).ok_or(SimError::UnknownFuelModel(m))?;
                    wind_mph.push(cfg.wind.midflame_mph(model.depth_ft));
                    for d in 0..levels {
                        let add = drop_moisture_increment * d as f64;
                        let mst = FuelMoisture {
                            dead_1h_frac: moisture.dead_1h_frac + add,
                            dead_10h_frac: moisture.dead_10h_frac + add,
                            dead_100h_frac: moisture.dead_100h_frac + add,
                            ..*moisture
                        };
                        beds.push(SurfaceFuelBed::new(model, &mst)?);
                    }
                    slot_bi.push(flame_length_bi_thresholds(&beds[beds.len() - levels]));
                }
                kernel = Kernel::Rothermel {
                    beds,
                    wind_mph,
                    wind_toward_deg: cfg.wind.from_direction_deg + 180.0,
                };
            }
        }

        // Neighbour offsets (P2 scheme) with their Bresenham intermediates.
        let r = cfg.neighbour_radius_cells;
        let ri = r.floor() as i32;
        let mut offsets = Vec::new();
        let mut intermediates = Vec::new();
        for dy in -ri..=ri {
            for dx in -ri..=ri {
                let d2 = f64::from(dx * dx + dy * dy);
                if (dx, dy) == (0, 0) || d2 > r * r {
                    continue;
                }
                // P2 walks source → target with strict error tests; the symmetric Bresenham
                // picks the other cell on the 8 knight's-move offsets.
                let line = strict_line((0, 0), (dx, dy));
                let start = intermediates.len();
                intermediates.extend_from_slice(&line[1..line.len() - 1]);
                offsets.push(Offset {
                    dx,
                    dy,
                    dist_ft: d2.sqrt() * cell,
                    azimuth_deg: f64::from(dx).atan2(f64::from(dy)).to_degrees(),
                    inter_start: start,
                    inter_end: intermediates.len(),
                });
            }
        }

        // BFS neighbourhood tables (docs/spec/fire-model.md §A6.4, original scheme).
        let side = (2 * ri + 1) as usize;
        let mut bfs_window = vec![BFS_OUTSIDE; side * side];
        let mut bfs_lines = Vec::new();
        let mut bfs_line_range = Vec::with_capacity(offsets.len());
        for (k, off) in offsets.iter().enumerate() {
            bfs_window[(off.dy + ri) as usize * side + (off.dx + ri) as usize] = k as u16;
            let start = bfs_lines.len() as u32;
            // The candidate is known burnable when its line is checked; the source is checked.
            bfs_lines.extend(strict_line((off.dx, off.dy), (0, 0)).into_iter().skip(1));
            bfs_line_range.push((start, bfs_lines.len() as u32));
        }

        // Helitack footprint (docs/spec/fire-model.md §A8).
        let rad = (cfg.helitack_radius_ft / cell).round() as i32;
        let mut footprint = Vec::new();
        for dy in -rad..=rad {
            for dx in -rad..=rad {
                if dx * dx + dy * dy > rad * rad {
                    continue;
                }
                if cfg.helitack_footprint == HelitackFootprint::FireCastRl && dx == -rad {
                    continue;
                }
                footprint.push((dx, dy));
            }
        }

        let coverage = if cfg.helitack_footprint == HelitackFootprint::Coverage {
            if !(cfg.helitack_volume_gal > 0.0 && cfg.helitack_volume_gal.is_finite()) {
                return Err(SimError::Config(format!(
                    "helitack_volume_gal must be positive, got {}",
                    cfg.helitack_volume_gal
                )));
            }
            let level: Vec<f32> = landscape
                .land_cover
                .iter()
                .map(|&code| {
                    let model = match landscape.scheme {
                        LandCoverScheme::ModisIgbp => modis_to_fuel_model(code),
                        LandCoverScheme::Fbfm13 | LandCoverScheme::Fbfm40 => code,
                    };
                    crate::drops::coverage_level(model).unwrap_or(0.0) as f32
                })
                .collect();
            let mut levels_seen: Vec<f32> = level.iter().copied().filter(|&l| l > 0.0).collect();
            levels_seen.push(crate::drops::DEFAULT_COVERAGE_LEVEL as f32);
            levels_seen.sort_by(f32::total_cmp);
            levels_seen.dedup();
            let patterns = levels_seen
                .into_iter()
                .map(|l| {
                    let area = crate::drops::wetted_area_ft2(cfg.helitack_volume_gal, f64::from(l));
                    (l, crate::drops::disc_coverage(area, cell))
                })
                .collect();
            Some(Box::new(Coverage {
                level,
                patterns,
                received: vec![0.0; n],
            }))
        } else {
            None
        };
        let rate_cache = Arc::new(RateCache::new(n, offsets.len()));
        let base_elev: Vec<f64> = landscape.elevation_ft.iter().map(|&e| f64::from(e)).collect();
        let mut a = Self {
            width: w,
            height: h,
            cell_size_ft: cell,
            cfg: cfg.clone(),
            kernel,
            levels,
            offsets,
            intermediates,
            footprint,
            coverage,
            bfs_radius: ri,
            bfs_window,
            bfs_lines,
            bfs_line_range,
            bfs_seen: vec![0; side * side],
            bfs_stamp: 0,
            bfs_queue: Vec::with_capacity(side * side),
            bfs_found: Vec::with_capacity(side * side),
            slot,
            flags: base_flags.clone(),
            base_flags,
            elev: base_elev.clone(),
            base_elev,
            slot_bi,
            state: vec![0; n],
            ign: vec![f64::INFINITY; n],
            burn_time: vec![cfg.max_burn_time_min; n],
            spread_rate: vec![0.0; n],
            bi: vec![0; n],
            drops: vec![0; n],
            survivor_eligible: landscape
                .land_cover
                .iter()
                .map(|c| {
                    landscape.scheme == LandCoverScheme::ModisIgbp && cfg.fire_survivor_classes.contains(c)
                })
                .collect(),
            survivor: vec![false; n],
            in_sched: vec![false; n],
            new_ign: vec![f64::INFINITY; n],
            rate_cache,
            burning: Vec::new(),
            scheduled: Vec::new(),
            touched: Vec::new(),
            igniting: Vec::new(),
            burnouts: Vec::new(),
            dirty: Vec::new(),
            time: 0.0,
            day: 0,
            latch: false,
            fire_did_stop: true,
            n_burning: 0,
            n_burnt: 0,
            rng: Uniform::new(cfg.random, 0),
        };
        a.reset(0);
        Ok(a)
    }

    /// Back to time 0, every cell unburnt, no fire lines or drops; reseeds the RNG.
    pub fn reset(&mut self, seed: u64) {
        self.flags.copy_from_slice(&self.base_flags);
        self.elev.copy_from_slice(&self.base_elev);
        self.state.fill(0);
        self.ign.fill(f64::INFINITY);
        self.burn_time.fill(self.cfg.max_burn_time_min);
        self.spread_rate.fill(0.0);
        self.bi.fill(0);
        self.drops.fill(0);
        if let Some(c) = &mut self.coverage {
            c.received.fill(0.0);
        }
        self.survivor.fill(false);
        self.in_sched.fill(false);
        self.new_ign.fill(f64::INFINITY);
        for v in [
            &mut self.burning,
            &mut self.scheduled,
            &mut self.touched,
            &mut self.igniting,
            &mut self.burnouts,
            &mut self.dirty,
        ] {
            v.clear();
        }
        self.time = 0.0;
        self.day = 0;
        self.latch = false;
        self.fire_did_stop = true;
        self.n_burning = 0;
        self.n_burnt = 0;
        self.rng = Uniform::new(self.cfg.random, seed);
    }

    /// Replaces the random draws still to come (survivors, latch days) with those of `seed`:
    /// a copy of a fire that must not know the original's future.
    pub fn reseed(&mut self, seed: u64) {
        self.rng = Uniform::new(self.cfg.random, seed);
    }

    fn check(&self, x: i64, y: i64) -> Result<usize, SimError> {
        if x < 0 || y < 0 || x as usize >= self.width || y as usize >= self.height {
            return Err(SimError::OutOfBounds {
                x,
                y,
                width: self.width,
                height: self.height,
            });
        }
        Ok(y as usize * self.width + x as usize)
    }

    /// Schedules a spark: cell (x, y) ignites on the first update whose time exceeds `time`.
    /// A spark inside an unburnt island removes that island first (4-connected flood fill).
    pub fn ignite(&mut self, x: usize, y: usize, time: f64) -> Result<(), SimError> {
        let i = self.check(x as i64, y as i64)?;
        if self.flags[i] & FLAG_ISLAND != 0 {
            let mut stack = vec![i];
            self.flags[i] &= !FLAG_ISLAND;
            while let Some(c) = stack.pop() {
                let (cx, cy) = (c % self.width, c / self.width);
                let mut visit = |n: usize, flags: &mut Vec<u8>| {
                    if flags[n] & FLAG_ISLAND != 0 {
                        flags[n] &= !FLAG_ISLAND;
                        stack.push(n);
                    }
                };
                if cx > 0 {
                    visit(c - 1, &mut self.flags);
                }
                if cx + 1 < self.width {
                    visit(c + 1, &mut self.flags);
                }
                if cy > 0 {
                    visit(c - self.width, &mut self.flags);
                }
                if cy + 1 < self.height {
                    visit(c + self.width, &mut self.flags);
                }
            }
        }
        if self.state[i] == FireState::Unburnt as u8 {
            self.ign[i] = self.ign[i].min(time);
            self.schedule(i);
        }
        Ok(())
    }

    fn schedule(&mut self, i: usize) {
        if !self.in_sched[i] {
            self.in_sched[i] = true;
            self.scheduled.push(i as u32);
        }
    }

    /// Advances by one fixed step: `update_fire(time + dt)`.
    pub fn step(&mut self) {
        let t = self.time + self.cfg.dt_min;
        self.update_fire(t);
    }

    fn burnable_for(&self, i: usize, src_high: bool) -> bool {
        let f = self.flags[i];
        f & (FLAG_RIVER | FLAG_ISLAND) == 0 && (f & FLAG_FIRE_LINE == 0 || src_high)
    }

    fn bi_for(&self, i: usize, rate: f64) -> u8 {
        let [med, high] = self.slot_bi[usize::from(self.slot[i])];
        if rate >= high {
            2
        } else if rate >= med {
            1
        } else {
            0
        }
    }

    fn rate(&self, target: usize, off: &Offset, rise_ft: f64) -> f64 {
        let slot = usize::from(self.slot[target]);
        let entry = slot * self.levels + usize::from(self.drops[target]).min(self.levels - 1);
        match &self.kernel {
            Kernel::Concord { spreads, winds } => {
                spreads[entry].rate_ftmin(off.dx, off.dy, rise_ft, &winds[slot], self.cell_size_ft)
            }
            Kernel::Rothermel {
                beds,
                wind_mph,
                wind_toward_deg,
            } => {
                let bed = &beds[entry];
                if bed.no_wind_no_slope_ros_ftmin() <= 0.0 {
                    return 0.0;
                }
                let upslope = if rise_ft >= 0.0 {
                    off.azimuth_deg
                } else {
                    off.azimuth_deg + 180.0
                };
                let inputs = SpreadInputs {
                    midflame_wind_mph: wind_mph[slot],
                    slope_percent: 100.0 * rise_ft.abs() / off.dist_ft,
                    wind_dir_from_upslope_deg: wind_toward_deg - upslope,
                };
                bed.spread(&inputs).ros_toward_ftmin(off.azimuth_deg - upslope)
            }
        }
    }

    /// `updateFire(time)` (docs/spec/fire-model.md §A6.3), with the configured [`Neighbourhood`].
    pub fn update_fire(&mut self, time: f64) {
        self.time = time;
        let day = (time / MIN_PER_DAY).floor().max(0.0) as u64;
        if day != self.day {
            self.day = day;
            let r = self.rng.next_f64();
            let p = usize::try_from(day)
                .ok()
                .and_then(|d| self.cfg.latch_daily_probability.get(d))
                .copied()
                .unwrap_or(0.0);
            if r <= p {
                self.latch = true;
            }
        }

        // Burnouts.
        self.burnouts.clear();
        for &c in &self.burning {
            let c = c as usize;
            if time - self.ign[c] > self.burn_time[c] {
                self.burnouts.push(c as u32);
            }
        }
        // Ignitions (scheduled list, pruned of stale entries), processed in row-major order.
        self.igniting.clear();
        let mut k = 0;
        while k < self.scheduled.len() {
            let c = self.scheduled[k] as usize;
            let stale = self.state[c] != FireState::Unburnt as u8 || self.ign[c] == f64::INFINITY;
            let fires = !stale && time > self.ign[c];
            if stale || fires {
                self.in_sched[c] = false;
                self.scheduled.swap_remove(k);
                if fires {
                    self.igniting.push(c as u32);
                }
            } else {
                k += 1;
            }
        }
        self.fire_did_stop = self.burning.is_empty() && self.scheduled.is_empty() && self.igniting.is_empty();
        self.igniting.sort_unstable();

        for j in 0..self.igniting.len() {
            let c = self.igniting[j] as usize;
            if self.latch && self.bi[c] == BurnIndex::Low as u8 {
                continue;
            }
            self.spread_from(c);
        }

        // Apply the buffers: states, then ignition times. Survivor draws go in row-major
        // order, as the originals' per-cell pass makes them.
        self.burnouts.sort_unstable();
        for j in 0..self.burnouts.len() {
            let c = self.burnouts[j] as usize;
            self.state[c] = FireState::Burnt as u8;
            self.dirty.push(c as u32);
            if self.survivor_eligible[c]
                && self.bi[c] == BurnIndex::Low as u8
                && self.rng.next_f64() < self.cfg.fire_survival_probability
            {
                self.survivor[c] = true;
            }
        }
        self.n_burning -= self.burnouts.len() as u32;
        self.n_burnt += self.burnouts.len() as u32;
        if !self.burnouts.is_empty() {
            let state = &self.state;
            self.burning
                .retain(|&c| state[c as usize] == FireState::Burning as u8);
        }
        for j in 0..self.igniting.len() {
            let c = self.igniting[j];
            self.state[c as usize] = FireState::Burning as u8;
            self.burning.push(c);
            self.dirty.push(c);
        }
        self.n_burning += self.igniting.len() as u32;
        for j in 0..self.touched.len() {
            let c = self.touched[j] as usize;
            self.ign[c] = self.new_ign[c];
            self.new_ign[c] = f64::INFINITY;
            if self.state[c] == FireState::Unburnt as u8 {
                self.schedule(c);
            }
        }
        self.touched.clear();
    }

    fn spread_from(&mut self, c: usize) {
        match self.cfg.neighbourhood {
            Neighbourhood::LineOfSight => self.spread_line_of_sight(c),
            Neighbourhood::Bfs => self.spread_bfs(c),
        }
    }

    /// P2 scheme: the offsets in order, skipping blocked lines (the hot loop).
    fn spread_line_of_sight(&mut self, c: usize) {
        let (x, y) = ((c % self.width) as i32, (c / self.width) as i32);
        let (w, h) = (self.width as i32, self.height as i32);
        let src_high = self.bi[c] == BurnIndex::High as u8;
        let t_src = self.ign[c];
        for k in 0..self.offsets.len() {
            let off = self.offsets[k];
            let (nx, ny) = (x + off.dx, y + off.dy);
            if nx < 0 || ny < 0 || nx >= w || ny >= h {
                continue;
            }
            let n = (ny * w + nx) as usize;
            if !self.burnable_for(n, src_high) || self.state[n] != FireState::Unburnt as u8 {
                continue;
            }
            let blocked = self.intermediates[off.inter_start..off.inter_end]
                .iter()
                .any(|&(px, py)| !self.burnable_for(((y + py) * w + x + px) as usize, src_high));
            if blocked {
                continue;
            }
            self.offer(c, k, n, t_src);
        }
    }

    /// Original scheme: the neighbours the BFS offers, in its order. Burning and burnt cells
    /// are searched through but not updated.
    fn spread_bfs(&mut self, c: usize) {
        let src_high = self.bi[c] == BurnIndex::High as u8;
        self.bfs_neighbours(c, src_high);
        let (x, y) = ((c % self.width) as i32, (c / self.width) as i32);
        let w = self.width as i32;
        let t_src = self.ign[c];
        for j in 0..self.bfs_found.len() {
            let k = usize::from(self.bfs_found[j]);
            let off = self.offsets[k];
            let n = ((y + off.dy) * w + x + off.dx) as usize;
            if self.state[n] == FireState::Unburnt as u8 {
                self.offer(c, k, n, t_src);
            }
        }
    }

    /// Fills `bfs_found` with the offsets the original BFS offers from source `c`, in order.
    fn bfs_neighbours(&mut self, c: usize, src_high: bool) {
        let (x0, y0) = ((c % self.width) as i32, (c / self.width) as i32);
        let (w, h) = (self.width as i32, self.height as i32);
        let r = self.bfs_radius;
        let side = 2 * r + 1;
        self.bfs_stamp = self.bfs_stamp.wrapping_add(1);
        if self.bfs_stamp == 0 {
            // Wrapped: old stamps could alias the new one.
            self.bfs_seen.fill(0);
            self.bfs_stamp = 1;
        }
        let stamp = self.bfs_stamp;
        let centre = (r * side + r) as usize;
        self.bfs_seen[centre] = stamp;
        self.bfs_queue.clear();
        self.bfs_queue.push(centre as u16);
        self.bfs_found.clear();
        // As in the original, lines are checked only once a blocking cell has been met.
        let mut any_non_burnable = false;
        let mut head = 0;
        while head < self.bfs_queue.len() {
            let q = i32::from(self.bfs_queue[head]);
            head += 1;
            let (qx, qy) = (q % side - r, q / side - r);
            for (sx, sy) in BFS_STEPS {
                let (dx, dy) = (qx + sx, qy + sy);
                let (nx, ny) = (x0 + dx, y0 + dy);
                // Outside the window is outside the radius.
                if nx < 0 || ny < 0 || nx >= w || ny >= h || dx.abs() > r || dy.abs() > r {
                    continue;
                }
                let wi = ((dy + r) * side + dx + r) as usize;
                let k = self.bfs_window[wi];
                if k == BFS_OUTSIDE || self.bfs_seen[wi] == stamp {
                    continue;
                }
                self.bfs_seen[wi] = stamp;
                if !self.burnable_for((ny * w + nx) as usize, src_high) {
                    any_non_burnable = true;
                } else if !any_non_burnable || self.bfs_line_clear(x0, y0, usize::from(k), src_high) {
                    self.bfs_found.push(k);
                    self.bfs_queue.push(wi as u16);
                }
            }
        }
    }

    /// The line from offset `k` to the source `(x0, y0)` has no cell non-burnable for the
    /// source's BI (the line lies inside the grid, between two cells in it).
    fn bfs_line_clear(&self, x0: i32, y0: i32, k: usize, src_high: bool) -> bool {
        let (start, end) = self.bfs_line_range[k];
        let w = self.width as i32;
        self.bfs_lines[start as usize..end as usize]
            .iter()
            .all(|&(px, py)| self.burnable_for(((y0 + py) * w + x0 + px) as usize, src_high))
    }

    /// Offers neighbour `n` (offset `k` from the burning source `c`, which ignited at
    /// `t_src`): schedules its ignition, shortens its burn time and raises its spread rate.
    #[inline(always)]
    fn offer(&mut self, c: usize, k: usize, n: usize, t_src: f64) {
        let off = self.offsets[k];
        let cacheable = self.drops[n] == 0 && (self.flags[n] | self.flags[c]) & FLAG_FIRE_LINE == 0;
        let r = if cacheable {
            let v = self.rate_cache.entry(c, k).load(Ordering::Relaxed);
            if v == RATE_UNSET {
                let r = self.rate(n, &off, self.elev[n] - self.elev[c]);
                self.rate_cache.entry(c, k).store(r.to_bits(), Ordering::Relaxed);
                r
            } else {
                f64::from_bits(v)
            }
        } else {
            self.rate(n, &off, self.elev[n] - self.elev[c])
        };
        if r.is_nan() || r <= 0.0 {
            return;
        }
        let cand = t_src + off.dist_ft / r;
        if self.new_ign[n] == f64::INFINITY {
            self.touched.push(n as u32);
        }
        let v = cand.min(self.new_ign[n]).min(self.ign[n]);
        self.new_ign[n] = v;
        self.burn_time[n] = self.burn_time[n].min(v - t_src + self.cfg.min_cell_burn_time_min);
        if r > self.spread_rate[n] {
            self.spread_rate[n] = r;
            let b = self.bi_for(n, r);
            if b != self.bi[n] {
                self.bi[n] = b;
                self.dirty.push(n as u32);
            }
        }
    }

    /// Helitack drop centred on (cx, cy) (docs/spec/fire-model.md §A8): every footprint cell gets
    /// one more drop, loses any scheduled ignition, and is set back to Unburnt if it was burning.
    ///
    /// With the `coverage` footprint (docs/spec/fire-model.md §B13) a cell is treated so only
    /// when the coverage it has received completes another whole cell at its fuel's level.
    pub fn helitack(&mut self, cx: usize, cy: usize) -> DropOutcome {
        let mut out = DropOutcome::default();
        let (w, h) = (self.width as i64, self.height as i64);
        if let Some(mut coverage) = self.coverage.take() {
            let at = cy.min(self.height - 1) * self.width + cx.min(self.width - 1);
            let target = match coverage.level[at] {
                l if l > 0.0 => l,
                _ => crate::drops::DEFAULT_COVERAGE_LEVEL as f32,
            };
            let pattern = coverage.patterns.iter().position(|p| p.0 == target).unwrap_or(0);
            for k in 0..coverage.patterns[pattern].1.len() {
                let (dx, dy, fraction) = coverage.patterns[pattern].1[k];
                let (x, y) = (cx as i64 + i64::from(dx), cy as i64 + i64::from(dy));
                if x < 0 || y < 0 || x >= w || y >= h {
                    continue;
                }
                let i = (y * w + x) as usize;
                let level = coverage.level[i];
                if level <= 0.0 {
                    continue;
                }
                // Laid at the target's level: a cell needing more gets proportionally less.
                let before = coverage.received[i];
                let after = before + fraction * target / level;
                coverage.received[i] = after;
                // A tiny tolerance so a drop meant to cover a cell whole does.
                let whole = |v: f32| (v + 1e-4).floor();
                let treated = whole(after) - whole(before);
                if treated >= 1.0 {
                    self.treat(i, treated as u8, &mut out);
                }
            }
            self.coverage = Some(coverage);
        } else {
            for k in 0..self.footprint.len() {
                let (dx, dy) = self.footprint[k];
                let (x, y) = (cx as i64 + i64::from(dx), cy as i64 + i64::from(dy));
                if x < 0 || y < 0 || x >= w || y >= h {
                    continue;
                }
                self.treat((y * w + x) as usize, 1, &mut out);
            }
        }
        if out.quenched > 0 {
            self.n_burning -= out.quenched;
            let state = &self.state;
            self.burning
                .retain(|&c| state[c as usize] == FireState::Burning as u8);
        }
        out
    }

    /// One cell treated `times` times by drops: more drops counted in its moisture, any scheduled
    /// ignition cancelled, flames put out.
    fn treat(&mut self, i: usize, times: u8, out: &mut DropOutcome) {
        out.cells += 1;
        self.drops[i] = self.drops[i].saturating_add(times);
        self.ign[i] = f64::INFINITY;
        if self.state[i] == FireState::Burning as u8 {
            self.state[i] = FireState::Unburnt as u8;
            self.dirty.push(i as u32);
            out.quenched += 1;
        }
    }

    /// Whole-cell coverages each cell has received from drops this episode (`coverage`
    /// footprint; `None` for FireCastRL's footprints).
    pub fn drop_coverage(&self) -> Option<&[f32]> {
        self.coverage.as_ref().map(|c| c.received.as_slice())
    }

    /// Fire line between two cells (Bresenham, docs/spec/fire-model.md §A9): each cell blocks
    /// spread from sources below High BI, loses its scheduled ignition and is lowered by
    /// `fire_line_depth_ft`.
    pub fn add_fire_line(&mut self, a: (usize, usize), b: (usize, usize)) -> Result<(), SimError> {
        self.check(a.0 as i64, a.1 as i64)?;
        self.check(b.0 as i64, b.1 as i64)?;
        let (dx, dy) = (a.0 as f64 - b.0 as f64, a.1 as f64 - b.1 as f64);
        let length_ft = dx.hypot(dy) * self.cell_size_ft;
        if length_ft > self.cfg.max_fire_line_length_ft {
            return Err(SimError::FireLineTooLong {
                length_ft,
                max_ft: self.cfg.max_fire_line_length_ft,
            });
        }
        for (x, y) in bresenham((a.0 as i64, a.1 as i64), (b.0 as i64, b.1 as i64)) {
            let i = y as usize * self.width + x as usize;
            if self.flags[i] & FLAG_FIRE_LINE == 0 {
                self.flags[i] |= FLAG_FIRE_LINE;
                self.elev[i] -= self.cfg.fire_line_depth_ft;
            }
            self.ign[i] = f64::INFINITY;
        }
        Ok(())
    }

    /// Marks cells as an unburnt island (Concord only, docs/spec/fire-model.md §A6.5): non-burnable
    /// until a spark lands in the island. Islands last until [`reset`](Self::reset); activating
    /// each island with probability 0.5 is the loader's choice.
    pub fn add_unburnt_island(&mut self, cells: &[(usize, usize)]) -> Result<(), SimError> {
        for &(x, y) in cells {
            let i = self.check(x as i64, y as i64)?;
            self.flags[i] |= FLAG_ISLAND;
        }
        Ok(())
    }

    /// Whether the cell belongs to an active unburnt island.
    pub fn is_unburnt_island(&self, i: usize) -> bool {
        self.flags[i] & FLAG_ISLAND != 0
    }

    /// Cells whose fire state or BI may have changed since the last call (may repeat).
    pub fn take_dirty(&mut self, out: &mut Vec<u32>) {
        out.clear();
        std::mem::swap(out, &mut self.dirty);
    }

    pub fn width(&self) -> usize {
        self.width
    }
    pub fn height(&self) -> usize {
        self.height
    }
    pub fn cell_size_ft(&self) -> f64 {
        self.cell_size_ft
    }
    pub fn config(&self) -> &SimConfig {
        &self.cfg
    }
    /// Simulation time, minutes.
    pub fn time_min(&self) -> f64 {
        self.time
    }
    /// Whether the end-of-low-intensity latch has fired.
    pub fn latch(&self) -> bool {
        self.latch
    }
    /// Concord's `fireDidStop` at the last update: nothing burnt or was scheduled to.
    pub fn fire_did_stop(&self) -> bool {
        self.fire_did_stop
    }
    /// Nothing burns and no ignition is scheduled.
    pub fn fire_out(&self) -> bool {
        self.fire_out_before(f64::INFINITY)
    }
    /// Nothing burns and no scheduled ignition comes before `time` (minutes): with `time` the
    /// end of the episode, the fire is out for as long as anyone watches. A cell rescheduled
    /// by a very slow spread rate (say 0.01 ft/min: 35 days per cell) then no longer keeps an
    /// episode alive until truncation.
    pub fn fire_out_before(&self, time: f64) -> bool {
        self.n_burning == 0
            && self
                .scheduled
                .iter()
                .all(|&c| self.state[c as usize] != 0 || self.ign[c as usize] >= time)
    }
    pub fn cells_burning(&self) -> u32 {
        self.n_burning
    }
    pub fn cells_burnt(&self) -> u32 {
        self.n_burnt
    }
    /// Burning cells (unordered).
    pub fn burning_cells(&self) -> &[u32] {
        &self.burning
    }
    pub fn fire_state(&self, i: usize) -> FireState {
        FireState::from_u8(self.state[i])
    }
    pub fn burn_index(&self, i: usize) -> BurnIndex {
        BurnIndex::from_u8(self.bi[i])
    }
    /// Fire state per cell as u8 (0 unburnt, 1 burning, 2 burnt), row-major.
    pub fn fire_states(&self) -> &[u8] {
        &self.state
    }
    /// Burn index per cell as u8 (0 low, 1 medium, 2 high).
    pub fn burn_indices(&self) -> &[u8] {
        &self.bi
    }
    /// Ignition time per cell, minutes (+∞ when none is scheduled).
    pub fn ignition_times(&self) -> &[f64] {
        &self.ign
    }
    /// Max incoming spread rate per cell, ft/min.
    pub fn spread_rates(&self) -> &[f64] {
        &self.spread_rate
    }
    /// Whether the cell survived the fire (cosmetic, docs/spec/fire-model.md §A6.3 a).
    pub fn is_fire_survivor(&self, i: usize) -> bool {
        self.survivor[i]
    }
    pub fn helitack_drops(&self, i: usize) -> u8 {
        self.drops[i]
    }
    /// Helitack drops per cell, row-major (what [`Self::helitack_drops`] gives cell by cell).
    pub fn helitack_drop_counts(&self) -> &[u8] {
        &self.drops
    }
    /// Non-burnable ("river") cell.
    pub fn is_non_burnable(&self, i: usize) -> bool {
        self.flags[i] & FLAG_RIVER != 0
    }
    pub fn is_fire_line(&self, i: usize) -> bool {
        self.flags[i] & FLAG_FIRE_LINE != 0
    }
    /// Number of neighbour offsets (20 at radius 2.5).
    pub fn neighbour_count(&self) -> usize {
        self.offsets.len()
    }
    /// Footprint offsets of a helitack drop.
    pub fn helitack_footprint(&self) -> &[(i32, i32)] {
        &self.footprint
    }
}

/// BI thresholds (docs/spec/fire-model.md §A6.2) per MODIS class: Grass rule for grasslands, Shrub
/// for closed/open shrublands, Forest for classes 1–5, always Low otherwise.
fn concord_bi_thresholds(class: u16) -> [f64; 2] {
    match class {
        10 => [45.0, f64::INFINITY],
        6 | 7 => [10.0, 50.0],
        1..=5 => [25.0, f64::INFINITY],
        _ => [f64::INFINITY; 2],
    }
}

/// Rothermel BI by flame length (Byram): Medium from 4 ft (hand-line limit), High from 8 ft
/// (equipment limit), converted to spread rates with the bed's heat per unit area.
fn flame_length_bi_thresholds(bed: &SurfaceFuelBed) -> [f64; 2] {
    let hpua = bed.heat_per_unit_area_btu_ft2();
    if hpua.is_nan() || hpua <= 0.0 || bed.no_wind_no_slope_ros_ftmin() <= 0.0 {
        return [f64::INFINITY; 2];
    }
    let rate_for = |flame_ft: f64| 60.0 * (flame_ft / 0.45).powf(1.0 / 0.46) / hpua;
    [rate_for(4.0), rate_for(8.0)]
}
