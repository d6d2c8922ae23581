//! Minimum travel time (MTT) on the grid: Dijkstra's algorithm over a stencil of moves
//! (dx, dy) with |dx|, |dy| ≤ r and gcd(dx, dy) = 1, as FlamMap's MTT and Cell2Fire spread a
//! fire. The travel time of a move is the time to cross the straight segment between the two
//! cell centres at the elliptical rate of spread (docs/spec/fire-model.md §B7, §B10.1) of every cell
//! it crosses: the segment is cut into 2·max(|dx|, |dy|) equal pieces, each crossed at the
//! rate of the cell its midpoint lies in. A move through a non-burnable cell, or off the grid,
//! is not taken. In uniform conditions the fastest path is the straight ray, so the front
//! after time t is the kernel's ellipse up to the stencil's angular resolution (docs/spec/fire-model.md §B10.1).
//!
//! Deterministic: ties in the queue are broken by cell index.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use firecast_landscape::{LandCoverScheme, Landscape};
use firecast_sim::automaton::modis_to_fuel_model;
use firecast_sim::{FuelModel, FuelMoisture, RothermelError, SpreadInputs, SurfaceFuelBed, Wind};

/// Engine settings.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MttConfig {
    /// Dead and live fuel moistures, the same in every cell.
    pub moisture: FuelMoisture,
    /// Wind speed, height and the direction it comes from (as the automaton's [`Wind`]).
    pub wind: Wind,
    /// Stencil radius r in cells (1 to 8): every move (dx, dy) with |dx|, |dy| ≤ r and
    /// gcd(|dx|, |dy|) = 1. 8 (the default) gives 160 directions, at most 7.1° apart;
    /// 4 gives 48, at most 14° apart, and loses 11 % of the head at L/B 5 (spread-verification).
    pub stencil_radius: u32,
    /// Stop once every cell reached before this time (hours) is final.
    pub max_time_h: f64,
}

impl Default for MttConfig {
    fn default() -> Self {
        Self {
            moisture: FuelMoisture::from_percent(6.0, 7.0, 8.0, 60.0, 90.0),
            wind: Wind::default(),
            stencil_radius: DEFAULT_STENCIL_RADIUS,
            max_time_h: 8.0,
        }
    }
}

/// The stencil radius the verification chose (docs/results/spread-verification.md).
pub const DEFAULT_STENCIL_RADIUS: u32 = 8;

/// Errors of the MTT engine.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MttError {
    #[error("stencil_radius must be in 1..=8, got {0}")]
    StencilRadius(u32),
    #[error("max_time_h must be positive and finite, got {0}")]
    MaxTime(f64),
    #[error("unknown fuel model {code} at cell x={x}, y={y}")]
    UnknownFuel { code: u16, x: usize, y: usize },
    #[error("ignition cell x={x}, y={y} is outside the {width} x {height} grid")]
    IgnitionOutside {
        x: usize,
        y: usize,
        width: usize,
        height: usize,
    },
    #[error(transparent)]
    Rothermel(#[from] RothermelError),
    #[error("{layer} has {got} cells, expected {width} x {height}")]
    GridSize {
        layer: &'static str,
        got: usize,
        width: usize,
        height: usize,
    },
    #[error("cell size must be positive and finite, got {0} ft")]
    CellSize(f64),
}

/// Per-cell spread ellipses of a landscape: head rate, eccentricity and head direction.
#[derive(Debug, Clone)]
pub struct MttGrid {
    width: usize,
    height: usize,
    cell_size_ft: f64,
    /// Head rate of spread, ft/min (0: the cell does not burn).
    head_ftmin: Vec<f64>,
    eccentricity: Vec<f64>,
    /// (sin, cos) of the head direction's azimuth (clockwise from north, the grid's +y).
    head_dir: Vec<(f64, f64)>,
}

/// Fuel model of a land-cover code, or `None` for a non-burnable cell.
fn fuel_of(scheme: LandCoverScheme, code: u16) -> Result<Option<&'static FuelModel>, u16> {
    let number = match scheme {
        LandCoverScheme::ModisIgbp => {
            if !(1..=17).contains(&code) {
                return Ok(None);
            }
            modis_to_fuel_model(code)
        }
        LandCoverScheme::Fbfm13 | LandCoverScheme::Fbfm40 => code,
    };
    if (91..=99).contains(&number) {
        return Ok(None);
    }
    FuelModel::by_number(number).map(Some).ok_or(code)
}

impl MttGrid {
    /// Evaluates the Rothermel kernel once per cell: slope and aspect from the elevation
    /// gradient (central differences, one-sided at the edges), the wind as configured.
    pub fn new(landscape: &Landscape, cfg: &MttConfig) -> Result<Self, MttError> {
        let (w, h) = (landscape.width, landscape.height);
        let cell = landscape.cell_size_ft;
        let mut beds: Vec<(u16, Option<(SurfaceFuelBed, f64)>)> = Vec::new();
        let n = landscape.len();
        let mut head_ftmin = vec![0.0; n];
        let mut eccentricity = vec![0.0; n];
        let mut head_dir = vec![(0.0, 1.0); n];
        let wind_toward = cfg.wind.from_direction_deg + 180.0;
        let z = |x: usize, y: usize| f64::from(landscape.elevation_ft[y * w + x]);
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let code = landscape.land_cover[i];
                let slot = match beds.iter().position(|(c, _)| *c == code) {
                    Some(s) => s,
                    None => {
                        let model = fuel_of(landscape.scheme, code)
                            .map_err(|code| MttError::UnknownFuel { code, x, y })?;
                        let bed = match model {
                            Some(m) => Some((
                                SurfaceFuelBed::new(m, &cfg.moisture)?,
                                cfg.wind.midflame_mph(m.depth_ft),
                            )),
                            None => None,
                        };
                        beds.push((code, bed));
                        beds.len() - 1
                    }
                };
                let Some((bed, midflame)) = beds[slot].1 else {
                    continue;
                };
                let (x0, x1) = (x.saturating_sub(1), (x + 1).min(w - 1));
                let (y0, y1) = (y.saturating_sub(1), (y + 1).min(h - 1));
                let gx = if x1 > x0 {
                    (z(x1, y) - z(x0, y)) / ((x1 - x0) as f64 * cell)
                } else {
                    0.0
                };
                let gy = if y1 > y0 {
                    (z(x, y1) - z(x, y0)) / ((y1 - y0) as f64 * cell)
                } else {
                    0.0
                };
                let slope = gx.hypot(gy);
                let upslope_deg = if slope > 0.0 {
                    gx.atan2(gy).to_degrees()
                } else {
                    0.0
                };
                let b = bed.spread(&SpreadInputs {
                    midflame_wind_mph: midflame,
                    slope_percent: 100.0 * slope,
                    wind_dir_from_upslope_deg: wind_toward - upslope_deg,
                });
                head_ftmin[i] = b.head_ros_ftmin;
                eccentricity[i] = b.eccentricity;
                head_dir[i] = (upslope_deg + b.dir_max_spread_from_upslope_deg)
                    .to_radians()
                    .sin_cos();
            }
        }
        Ok(Self {
            width: w,
            height: h,
            cell_size_ft: cell,
            head_ftmin,
            eccentricity,
            head_dir,
        })
    }

    /// Per-cell ellipses computed elsewhere (e.g. from a LANDFIRE landscape's own slope, aspect
    /// and canopy layers), cell index `y * width + x` with row 0 south as in a [`Landscape`]:
    /// head rate in ft/min (0, or not finite, where the cell does not burn), eccentricity in
    /// [0, 1), and the head's azimuth in degrees clockwise from north.
    pub fn from_ellipses(
        width: usize,
        height: usize,
        cell_size_ft: f64,
        head_ftmin: Vec<f64>,
        eccentricity: Vec<f64>,
        head_azimuth_deg: &[f64],
    ) -> Result<Self, MttError> {
        let n = width * height;
        for (layer, got) in [
            ("head_ftmin", head_ftmin.len()),
            ("eccentricity", eccentricity.len()),
            ("head_azimuth_deg", head_azimuth_deg.len()),
        ] {
            if got != n || n == 0 {
                return Err(MttError::GridSize {
                    layer,
                    got,
                    width,
                    height,
                });
            }
        }
        if !(cell_size_ft > 0.0 && cell_size_ft.is_finite()) {
            return Err(MttError::CellSize(cell_size_ft));
        }
        let head_ftmin = head_ftmin
            .into_iter()
            .map(|r| if r.is_finite() && r > 0.0 { r } else { 0.0 })
            .collect();
        Ok(Self {
            width,
            height,
            cell_size_ft,
            head_ftmin,
            eccentricity,
            head_dir: head_azimuth_deg
                .iter()
                .map(|a| a.to_radians().sin_cos())
                .collect(),
        })
    }

    /// Rate of spread in cell `i` toward the unit direction (ux east, uy north), ft/min:
    /// R·(1 − e)/(1 − e·cos ψ), ψ the angle from the head direction.
    #[inline]
    pub fn ros_toward_ftmin(&self, i: usize, ux: f64, uy: f64) -> f64 {
        let (s, c) = self.head_dir[i];
        let e = self.eccentricity[i];
        self.head_ftmin[i] * (1.0 - e) / (1.0 - e * (ux * s + uy * c))
    }

    /// Whether cell `i` can burn.
    pub fn burnable(&self, i: usize) -> bool {
        self.head_ftmin[i] > 0.0
    }

    /// Arrival time per cell in hours (`f64::INFINITY` where the fire does not arrive by
    /// `max_time_h`) from ignitions at time 0; an ignition on a cell that cannot burn burns
    /// nothing.
    pub fn arrival_times_h(
        &self,
        ignitions: &[(usize, usize)],
        stencil_radius: u32,
        max_time_h: f64,
    ) -> Result<Vec<f64>, MttError> {
        let mut ellipses = self;
        let grid = GridShape {
            width: self.width,
            height: self.height,
            cell_size_ft: self.cell_size_ft,
        };
        let reached = dijkstra(&mut ellipses, grid, ignitions, stencil_radius, max_time_h)?;
        let mut t = vec![f64::INFINITY; self.width * self.height];
        for (i, h) in reached {
            t[i] = h;
        }
        Ok(t)
    }
}

/// One cell's spread ellipse: head rate in ft/min (0, or not finite, where the cell does not
/// burn), eccentricity in [0, 1), the head's azimuth in degrees clockwise from north.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipse {
    pub head_ftmin: f64,
    pub eccentricity: f64,
    pub head_azimuth_deg: f64,
}

/// What [`arrival_times_lazy_h`] computed.
#[derive(Debug, Clone, PartialEq)]
pub struct LazyRun {
    /// The cells the fire reaches by the time limit, (cell index, arrival time in hours), in
    /// order of arrival; every other cell is not reached.
    pub reached_h: Vec<(usize, f64)>,
    /// Cells whose ellipse was evaluated (the cells the fire's moves reached or crossed).
    pub ellipses_evaluated: usize,
}

impl LazyRun {
    /// Arrival time per cell in hours, `f64::INFINITY` where not reached (as
    /// [`MttGrid::arrival_times_h`] gives it).
    pub fn arrival_h(&self, cells: usize) -> Vec<f64> {
        let mut t = vec![f64::INFINITY; cells];
        for &(i, h) in &self.reached_h {
            t[i] = h;
        }
        t
    }
}

/// [`MttGrid::arrival_times_h`] with the per-cell ellipses computed on first use, by
/// `ellipse(i)` for cell index `i = y * width + x` (row 0 south): a small fire on a large
/// landscape evaluates the kernel only where its moves go. The arrival times are the ones an
/// [`MttGrid::from_ellipses`] of every cell's ellipse gives, bit for bit.
pub fn arrival_times_lazy_h(
    width: usize,
    height: usize,
    cell_size_ft: f64,
    ellipse: impl FnMut(usize) -> Ellipse,
    ignitions: &[(usize, usize)],
    stencil_radius: u32,
    max_time_h: f64,
) -> Result<LazyRun, MttError> {
    if width == 0 || height == 0 {
        return Err(MttError::GridSize {
            layer: "grid",
            got: 0,
            width,
            height,
        });
    }
    if !(cell_size_ft > 0.0 && cell_size_ft.is_finite()) {
        return Err(MttError::CellSize(cell_size_ft));
    }
    let n = width * height;
    if n >= u32::MAX as usize {
        return Err(MttError::GridSize {
            layer: "grid",
            got: n,
            width,
            height,
        });
    }
    let mut lazy = LazyEllipses {
        ellipse,
        // Sized to the engine's window by `prepare`.
        slot: Vec::new(),
        heads: Vec::new(),
        inverse: Vec::new(),
        ux: Vec::new(),
        uy: Vec::new(),
    };
    let grid = GridShape {
        width,
        height,
        cell_size_ft,
    };
    let reached = dijkstra(&mut lazy, grid, ignitions, stencil_radius, max_time_h)?;
    Ok(LazyRun {
        reached_h: reached,
        ellipses_evaluated: lazy.heads.len(),
    })
}

#[derive(Debug, Clone, Copy)]
struct GridShape {
    width: usize,
    height: usize,
    cell_size_ft: f64,
}

/// The rates the engine reads: an [`MttGrid`]'s, or [`LazyEllipses`]. A cell is named by its
/// index `i` in the grid and its index `l` in the engine's [`Window`].
trait Rates {
    /// The stencil's moves (move `k` of the later calls is `moves[k]`) and the first window,
    /// before the search starts.
    fn prepare(&mut self, moves: &[Move], window: &Window);
    /// 1 / the rate of spread in cell `i` along stencil move `k`, `m`, min/ft; +∞ where the fire
    /// does not spread that way (no rate, or not a number), which drops the move (below).
    fn inverse_rate(&mut self, i: usize, l: usize, k: usize, m: &Move) -> f64;
    fn burnable(&mut self, i: usize, l: usize) -> bool;
    /// The cost of move `k` (`m`) from cell `i` (window index `il`) whose pieces lie in `pieces`
    /// (each piece's cell as offsets from `i` in the grid and the window): the sum of the
    /// pieces' 1/rate in order along the segment, or `None` as soon as the partial sum passes
    /// `limit` (every later piece only adds, so the move cannot come under it).
    #[inline]
    fn move_cost(
        &mut self,
        i: usize,
        il: usize,
        k: usize,
        m: &Move,
        pieces: &[(isize, isize)],
        limit: f64,
    ) -> Option<f64> {
        let mut cost = 0.0;
        for &(offset, local) in pieces {
            cost += self.inverse_rate(i.wrapping_add_signed(offset), il.wrapping_add_signed(local), k, m);
            if cost > limit {
                return None;
            }
        }
        Some(cost)
    }
    /// The engine's window grew from `old` to `new`: per-cell state kept by window index moves.
    fn rewindow(&mut self, old: &Window, new: &Window);
}

/// `cost` plus each piece's 1/rate along move `k`, in order, from [`LazyEllipses`]' tables,
/// until the sum passes `limit` or a piece's cell is not evaluated: (the number of pieces added,
/// their sum), or (`usize::MAX`, the sum) when it passed the limit. Kept out of line: inside
/// the engine's loop the compiler held the running sum in memory (the evaluation's call
/// clobbers every float register), one store-to-load more on each piece's chain; a pair comes
/// back in registers.
#[inline(never)]
fn sum_evaluated(
    slot: &[usize],
    inverse: &[f64],
    il: usize,
    k: usize,
    pieces: &[(isize, isize)],
    mut cost: f64,
    limit: f64,
) -> (usize, f64) {
    for (at, &(_, local)) in pieces.iter().enumerate() {
        let slot = slot[il.wrapping_add_signed(local)];
        if slot == 0 {
            return (at, cost);
        }
        cost += inverse[slot + k];
        if cost > limit {
            return (usize::MAX, cost);
        }
    }
    (pieces.len(), cost)
}

/// 1/r, or `None` where r is not a positive number.
#[inline]
fn inverse_of(r: f64) -> Option<f64> {
    if r.is_nan() || r <= 0.0 {
        None
    } else {
        Some(1.0 / r)
    }
}

impl Rates for &MttGrid {
    fn prepare(&mut self, _moves: &[Move], _window: &Window) {}

    #[inline]
    fn inverse_rate(&mut self, i: usize, _l: usize, _k: usize, m: &Move) -> f64 {
        inverse_of(MttGrid::ros_toward_ftmin(self, i, m.ux, m.uy)).unwrap_or(f64::INFINITY)
    }

    fn burnable(&mut self, i: usize, _l: usize) -> bool {
        MttGrid::burnable(self, i)
    }

    fn rewindow(&mut self, _old: &Window, _new: &Window) {}
}

/// Ellipses computed on first use, each kept as its 1/rate along every move of the stencil
/// (computed by [`MttGrid::ros_toward_ftmin`]'s formula, so the same bits; +∞ where the fire
/// does not spread that way), in the order they were first needed after one unused table;
/// `slot[l]` is where window cell `l`'s table starts in `inverse` (0, the unused table: not yet
/// evaluated). The engine reads a cell's 1/rate along a move many times (once for each source
/// whose move crosses it), here one load each.
struct LazyEllipses<F> {
    ellipse: F,
    slot: Vec<usize>,
    /// Head rate of each evaluated cell (0: it does not burn).
    heads: Vec<f64>,
    /// 1/rate along every move, `moves` values for each evaluated cell.
    inverse: Vec<f64>,
    ux: Vec<f64>,
    uy: Vec<f64>,
}

impl<F: FnMut(usize) -> Ellipse> LazyEllipses<F> {
    /// Where cell `i`'s table (window index `l`) starts, its ellipse evaluated the first time.
    #[inline]
    fn get(&mut self, i: usize, l: usize) -> usize {
        match self.slot[l] {
            0 => self.evaluate(i, l),
            slot => slot,
        }
    }

    #[inline(never)]
    fn evaluate(&mut self, i: usize, l: usize) -> usize {
        let e = (self.ellipse)(i);
        let head = if e.head_ftmin.is_finite() && e.head_ftmin > 0.0 {
            e.head_ftmin
        } else {
            0.0
        };
        let (s, c) = e.head_azimuth_deg.to_radians().sin_cos();
        let ecc = e.eccentricity;
        // MttGrid::ros_toward_ftmin's head·(1 − e)/(1 − e·(ux·s + uy·c)), the product first as
        // there.
        let numerator = head * (1.0 - ecc);
        let base = self.inverse.len();
        // A cell that does not burn stops every move (+∞ each way, as the formula gives it).
        self.inverse.resize(base + self.ux.len(), f64::INFINITY);
        if head > 0.0 {
            for ((out, &ux), &uy) in self.inverse[base..].iter_mut().zip(&self.ux).zip(&self.uy) {
                let r = numerator / (1.0 - ecc * (ux * s + uy * c));
                // inverse_of(r), +∞ where None, as a select the compiler can vectorise.
                *out = if r > 0.0 { 1.0 / r } else { f64::INFINITY };
            }
        }
        self.heads.push(head);
        self.slot[l] = base;
        base
    }
}

impl<F: FnMut(usize) -> Ellipse> Rates for LazyEllipses<F> {
    fn prepare(&mut self, moves: &[Move], window: &Window) {
        self.slot = vec![0; window.cells()];
        // Room for a few hundred cells' tables (pages are touched only as they fill), after the
        // unused one that slot 0 names.
        self.inverse = Vec::with_capacity(512 * moves.len());
        self.inverse.resize(moves.len(), f64::INFINITY);
        self.ux = moves.iter().map(|m| m.ux).collect();
        self.uy = moves.iter().map(|m| m.uy).collect();
    }

    #[inline]
    fn inverse_rate(&mut self, i: usize, l: usize, k: usize, _m: &Move) -> f64 {
        let slot = self.get(i, l);
        self.inverse[slot + k]
    }

    fn burnable(&mut self, i: usize, l: usize) -> bool {
        let slot = self.get(i, l);
        self.heads[slot / self.ux.len() - 1] > 0.0
    }

    #[inline]
    fn move_cost(
        &mut self,
        i: usize,
        il: usize,
        k: usize,
        _m: &Move,
        pieces: &[(isize, isize)],
        limit: f64,
    ) -> Option<f64> {
        // [`Rates::move_cost`]'s loop, left for a cell not yet evaluated and resumed after it.
        let mut cost = 0.0;
        let mut rest = pieces;
        loop {
            let (at, sum) = sum_evaluated(&self.slot, &self.inverse, il, k, rest, cost, limit);
            if at == usize::MAX {
                return None;
            }
            if at == rest.len() {
                return Some(sum);
            }
            cost = sum;
            rest = &rest[at..];
            let (offset, local) = rest[0];
            self.evaluate(i.wrapping_add_signed(offset), il.wrapping_add_signed(local));
        }
    }

    fn rewindow(&mut self, old: &Window, new: &Window) {
        self.slot = old.moved(&self.slot, new, 0);
    }
}

/// The part of the grid the engine keeps state for: columns `x0..x0 + width`, rows
/// `y0..y0 + height`. It starts around the ignitions and grows (at least doubling) when a cell
/// the fire reaches has moves that leave it, so a small fire on a large grid zeroes and touches
/// only the memory around it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Window {
    x0: usize,
    y0: usize,
    width: usize,
    height: usize,
}

impl Window {
    /// Cells (x0, y0) to (x1, y1) inclusive and `pad` more on each side, inside the grid.
    fn around(x0: usize, y0: usize, x1: usize, y1: usize, pad: usize, grid: &GridShape) -> Self {
        let (ax, ay) = (x0.saturating_sub(pad), y0.saturating_sub(pad));
        let (bx, by) = ((x1 + pad).min(grid.width - 1), (y1 + pad).min(grid.height - 1));
        Self {
            x0: ax,
            y0: ay,
            width: bx + 1 - ax,
            height: by + 1 - ay,
        }
    }

    fn cells(&self) -> usize {
        self.width * self.height
    }

    #[inline]
    fn local(&self, x: usize, y: usize) -> usize {
        (y - self.y0) * self.width + (x - self.x0)
    }

    /// Whether the cells (x0, y0) to (x1, y1) inclusive are inside.
    fn holds(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> bool {
        x0 >= self.x0 && y0 >= self.y0 && x1 < self.x0 + self.width && y1 < self.y0 + self.height
    }

    /// Per-cell values of this window placed in `new` (which holds it), `fill` elsewhere.
    fn moved<T: Copy>(&self, values: &[T], new: &Window, fill: T) -> Vec<T> {
        let mut out = vec![fill; new.cells()];
        for row in 0..self.height {
            let at = new.local(self.x0, self.y0 + row);
            out[at..at + self.width].copy_from_slice(&values[row * self.width..(row + 1) * self.width]);
        }
        out
    }
}

/// Dijkstra over the stencil (the module documentation); the cells reached by `max_time_h`
/// with their arrival times in hours, in order of arrival.
///
/// A move's travel time adds the pieces' 1/rate in order along the segment (a cell crossed by
/// several consecutive pieces is evaluated once and its 1/rate added once per piece: the same
/// sum). A move is dropped as soon as its partial cost shows that its end cell's time cannot
/// improve or will exceed `max_time_h` (every later piece only adds; the test keeps a margin of
/// 10⁻⁹ over the rounding of the time's own formula), which changes no arrival time up to
/// `max_time_h`. Per-cell state is kept for a [`Window`] of the grid that grows with the fire,
/// so a small fire on a large grid touches only the memory around it; the queue holds grid
/// indices, so ties break as on the whole grid.
fn dijkstra<R: Rates>(
    rates: &mut R,
    grid: GridShape,
    ignitions: &[(usize, usize)],
    stencil_radius: u32,
    max_time_h: f64,
) -> Result<Vec<(usize, f64)>, MttError> {
    // A final cell's time: below every time the search writes (one load and one comparison
    // tell a final cell, a reached one and one not reached: +∞).
    const DONE: f64 = -1.0;
    if !(1..=8).contains(&stencil_radius) {
        return Err(MttError::StencilRadius(stencil_radius));
    }
    if !(max_time_h > 0.0 && max_time_h.is_finite()) {
        return Err(MttError::MaxTime(max_time_h));
    }
    let (w, h) = (grid.width, grid.height);
    for &(x, y) in ignitions {
        if x >= w || y >= h {
            return Err(MttError::IgnitionOutside {
                x,
                y,
                width: w,
                height: h,
            });
        }
    }
    let r = stencil_radius as usize;
    let Stencil {
        moves,
        pieces_xy: crossed_xy,
        spans,
    } = Stencil::of_radius(stencil_radius);
    let offsets = |width: usize| -> Vec<(isize, isize)> {
        crossed_xy
            .iter()
            .map(|&(ox, oy)| {
                (
                    oy as isize * w as isize + ox as isize,
                    oy as isize * width as isize + ox as isize,
                )
            })
            .collect()
    };
    // A move's time is ti + cost·(length·cell)/pieces; the reciprocal of that factor serves
    // the early-drop test only (the time itself keeps its formula).
    let inverse_scale: Vec<f64> = moves
        .iter()
        .map(|m| f64::from(m.pieces) / (m.len_cells * grid.cell_size_ft))
        .collect();
    let max_min = max_time_h * 60.0;
    let margin = |limit: f64| limit * (1.0 + 1e-9) + 1e-9;
    // The window: the ignitions' moves and 32 cells more each way to start with.
    let mut win = match ignitions
        .iter()
        .copied()
        .reduce(|a, b| (a.0.min(b.0), a.1.min(b.1)))
    {
        Some((ax, ay)) => {
            let (bx, by) = ignitions
                .iter()
                .copied()
                .reduce(|a, b| (a.0.max(b.0), a.1.max(b.1)))
                .unwrap_or((ax, ay));
            Window::around(ax, ay, bx, by, r + 32, &grid)
        }
        None => Window {
            x0: 0,
            y0: 0,
            width: 1,
            height: 1,
        },
    };
    rates.prepare(moves, &win);
    let mut crossed = offsets(win.width);
    // Each move's end cell as index offsets in the grid and in the window.
    let targets = |width: usize| -> Vec<(isize, isize)> {
        moves
            .iter()
            .map(|m| {
                (
                    m.dy as isize * w as isize + m.dx as isize,
                    m.dy as isize * width as isize + m.dx as isize,
                )
            })
            .collect()
    };
    let mut ends = targets(win.width);
    // Arrival times in minutes by window index: +∞ not reached yet, DONE once final.
    let mut t = vec![f64::INFINITY; win.cells()];
    let mut heap = BinaryHeap::new();
    for &(x, y) in ignitions {
        let (i, l) = (y * w + x, win.local(x, y));
        if rates.burnable(i, l) {
            t[l] = 0.0;
            heap.push(Entry { t: 0.0, i });
        }
    }
    let mut reached = Vec::new();
    while let Some(Entry { t: ti, i }) = heap.pop() {
        let (x, y) = (i % w, i / w);
        let il = win.local(x, y);
        // A final cell (DONE < ti), or an entry an earlier time replaced.
        if ti != t[il] {
            continue;
        }
        t[il] = DONE;
        if ti > max_min {
            break;
        }
        reached.push((i, ti / 60.0));
        // Every cell the moves from here reach or cross lies within r of it.
        let (bx0, by0) = (x.saturating_sub(r), y.saturating_sub(r));
        let (bx1, by1) = ((x + r).min(w - 1), (y + r).min(h - 1));
        if !win.holds(bx0, by0, bx1, by1) {
            let grown = Window::around(
                bx0.min(win.x0),
                by0.min(win.y0),
                bx1.max(win.x0 + win.width - 1),
                by1.max(win.y0 + win.height - 1),
                win.width.max(win.height) / 2 + r,
                &grid,
            );
            t = win.moved(&t, &grown, f64::INFINITY);
            rates.rewindow(&win, &grown);
            win = grown;
            crossed = offsets(win.width);
            ends = targets(win.width);
        }
        let il = win.local(x, y);
        // Away from the grid's edges every move stays on it.
        let inside = x >= r && y >= r && x + r < w && y + r < h;
        let (x, y) = (x as i32, y as i32);
        'moves: for (k, (((m, span), &inverse_scale), &(end, end_local))) in
            moves.iter().zip(spans).zip(&inverse_scale).zip(&ends).enumerate()
        {
            if !inside {
                let (nx, ny) = (x + m.dx, y + m.dy);
                if nx < 0 || ny < 0 || nx >= w as i32 || ny >= h as i32 {
                    continue;
                }
            }
            let (j, jl) = (i.wrapping_add_signed(end), il.wrapping_add_signed(end_local));
            let bound = t[jl];
            if bound == DONE {
                continue;
            }
            // Past this cost the move cannot give j an earlier time, or gives one past the limit
            // (the margin covers the few roundings between this and the time's formula).
            let cost_limit = (margin(bound.min(max_min)) - ti) * inverse_scale;
            // +∞ (no spread that way) makes the cost pass any limit: the move is dropped.
            let Some(cost) = rates.move_cost(i, il, k, m, &crossed[span.clone()], cost_limit) else {
                continue 'moves;
            };
            let tj = ti + cost * m.len_cells * grid.cell_size_ft / f64::from(m.pieces);
            if tj < bound {
                t[jl] = tj;
                heap.push(Entry { t: tj, i: j });
            }
        }
    }
    Ok(reached)
}

/// One-shot: build the per-cell ellipses and run the engine.
pub fn arrival_times_h(
    landscape: &Landscape,
    cfg: &MttConfig,
    ignitions: &[(usize, usize)],
) -> Result<Vec<f64>, MttError> {
    MttGrid::new(landscape, cfg)?.arrival_times_h(ignitions, cfg.stencil_radius, cfg.max_time_h)
}

/// The stencil's moves and the cells their pieces lie in, computed once per radius.
struct Stencil {
    moves: Vec<Move>,
    /// The cell each piece of each move lies in, as a (dx, dy) offset, in order along the
    /// segment (a cell holding two consecutive pieces is listed twice), all moves' in one list.
    pieces_xy: Vec<(i32, i32)>,
    /// Move k's part of `pieces_xy`.
    spans: Vec<std::ops::Range<usize>>,
}

impl Stencil {
    /// The stencil of radius `r` (1..=8).
    fn of_radius(r: u32) -> &'static Stencil {
        static BY_RADIUS: [std::sync::OnceLock<Stencil>; 8] = [const { std::sync::OnceLock::new() }; 8];
        BY_RADIUS[(r - 1) as usize].get_or_init(|| Stencil::new(r))
    }

    fn new(r: u32) -> Self {
        // The moves by angle, so that consecutive moves cross mostly the same cells and read
        // neighbouring entries of a cell's 1/rate table ([`LazyEllipses`]). The order of a cell's
        // moves changes no arrival time: each move ends at a different cell, whose time the
        // others do not read, and the queue orders its entries by (time, index) alone.
        let mut moves = stencil(r as i32);
        moves.sort_by_cached_key(|m| {
            let angle = f64::from(m.dy).atan2(f64::from(m.dx));
            // total_cmp's order as an integer key.
            let bits = angle.to_bits() as i64;
            bits ^ (((bits >> 63) as u64) >> 1) as i64
        });
        // One entry a piece keeps the sum's loop free of a branch on a cell's number of pieces.
        let mut pieces_xy: Vec<(i32, i32)> = Vec::new();
        let mut spans = Vec::with_capacity(moves.len());
        for m in &moves {
            let start = pieces_xy.len();
            for (ox, oy, n) in m.crossed_cells() {
                pieces_xy.extend(std::iter::repeat_n((ox, oy), n as usize));
            }
            spans.push(start..pieces_xy.len());
        }
        Self {
            moves,
            pieces_xy,
            spans,
        }
    }
}

struct Move {
    dx: i32,
    dy: i32,
    len_cells: f64,
    ux: f64,
    uy: f64,
    pieces: u32,
}

impl Move {
    /// The cells the move's pieces lie in, as (dx, dy) offsets from the start cell with the
    /// number of consecutive pieces in each, in order along the segment. Piece k's midpoint is
    /// at fraction f = (k + ½)/pieces; its cell is the midpoint rounded half away from zero,
    /// which for the non-negative coordinates of a move inside the grid is the start cell plus
    /// the offset computed here from any start far enough from 0 (16 > the stencil's radius).
    fn crossed_cells(&self) -> Vec<(i32, i32, u32)> {
        const BASE: f64 = 16.0;
        let mut cells: Vec<(i32, i32, u32)> = Vec::new();
        for k in 0..self.pieces {
            let f = (f64::from(k) + 0.5) / f64::from(self.pieces);
            let ox = ((BASE + f * f64::from(self.dx)).round() - BASE) as i32;
            let oy = ((BASE + f * f64::from(self.dy)).round() - BASE) as i32;
            match cells.last_mut() {
                Some((lx, ly, n)) if (*lx, *ly) == (ox, oy) => *n += 1,
                _ => cells.push((ox, oy, 1)),
            }
        }
        cells
    }
}

fn gcd(a: i32, b: i32) -> i32 {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// Every (dx, dy) with |dx|, |dy| ≤ r and gcd 1 (so no move is a multiple of another).
fn stencil(r: i32) -> Vec<Move> {
    let mut moves = Vec::new();
    for dy in -r..=r {
        for dx in -r..=r {
            if gcd(dx.abs(), dy.abs()) != 1 {
                continue;
            }
            let len = f64::from(dx).hypot(f64::from(dy));
            moves.push(Move {
                dx,
                dy,
                len_cells: len,
                ux: f64::from(dx) / len,
                uy: f64::from(dy) / len,
                pieces: 2 * dx.abs().max(dy.abs()) as u32,
            });
        }
    }
    moves
}

/// Number of moves of the stencil of radius `r`.
pub fn stencil_moves(r: u32) -> usize {
    stencil(r as i32).len()
}

#[derive(Debug, Clone, Copy)]
struct Entry {
    t: f64,
    i: usize,
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    /// Reversed: the earliest time (then the lowest index) is the heap's maximum.
    fn cmp(&self, other: &Self) -> Ordering {
        other.t.total_cmp(&self.t).then(other.i.cmp(&self.i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The engine as first written (every piece evaluated, no early drop of a move): the
    /// optimised one must give the same arrival times, bit for bit.
    fn reference_arrival_times_h(
        grid: &MttGrid,
        ignitions: &[(usize, usize)],
        r: u32,
        max_time_h: f64,
    ) -> Vec<f64> {
        let (w, h) = (grid.width, grid.height);
        let moves = stencil(r as i32);
        let max_min = max_time_h * 60.0;
        let mut t = vec![f64::INFINITY; w * h];
        let mut done = vec![false; w * h];
        let mut heap = BinaryHeap::new();
        for &(x, y) in ignitions {
            let i = y * w + x;
            if grid.burnable(i) {
                t[i] = 0.0;
                heap.push(Entry { t: 0.0, i });
            }
        }
        while let Some(Entry { t: ti, i }) = heap.pop() {
            if done[i] || ti > t[i] {
                continue;
            }
            done[i] = true;
            if ti > max_min {
                break;
            }
            let (x, y) = ((i % w) as i32, (i / w) as i32);
            'moves: for m in &moves {
                let (nx, ny) = (x + m.dx, y + m.dy);
                if nx < 0 || ny < 0 || nx >= w as i32 || ny >= h as i32 {
                    continue;
                }
                let j = ny as usize * w + nx as usize;
                if done[j] {
                    continue;
                }
                let mut cost = 0.0;
                for k in 0..m.pieces {
                    let f = (f64::from(k) + 0.5) / f64::from(m.pieces);
                    let cx = (f64::from(x) + f * f64::from(m.dx)).round() as usize;
                    let cy = (f64::from(y) + f * f64::from(m.dy)).round() as usize;
                    let r = grid.ros_toward_ftmin(cy * w + cx, m.ux, m.uy);
                    if r.is_nan() || r <= 0.0 {
                        continue 'moves;
                    }
                    cost += 1.0 / r;
                }
                let tj = ti + cost * m.len_cells * grid.cell_size_ft / f64::from(m.pieces);
                if tj < t[j] {
                    t[j] = tj;
                    heap.push(Entry { t: tj, i: j });
                }
            }
        }
        t.into_iter()
            .map(|v| if v <= max_min { v / 60.0 } else { f64::INFINITY })
            .collect()
    }

    /// A varied landscape of ellipses (a small LCG): rates, shapes and directions change from
    /// cell to cell, some cells do not burn.
    fn varied(w: usize, h: usize, seed: u64) -> Vec<Ellipse> {
        let mut s = seed;
        let mut next = move || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..w * h)
            .map(|_| {
                let u = next();
                Ellipse {
                    head_ftmin: if u < 0.08 {
                        0.0
                    } else {
                        0.5 + 40.0 * next() * next()
                    },
                    eccentricity: 0.95 * next(),
                    head_azimuth_deg: 360.0 * next(),
                }
            })
            .collect()
    }

    #[test]
    fn crossed_cells_are_the_pieces_rounded_from_any_start() {
        for m in stencil(8) {
            let cells = m.crossed_cells();
            assert_eq!(cells.iter().map(|c| c.2).sum::<u32>(), m.pieces);
            assert!(
                cells.iter().all(|c| (1..=2).contains(&c.2)),
                "move {} {}",
                m.dx,
                m.dy
            );
            for x in 0..40i32 {
                for y in 0..40i32 {
                    if !(0..40).contains(&(x + m.dx)) || !(0..40).contains(&(y + m.dy)) {
                        continue;
                    }
                    let mut expanded = Vec::new();
                    for &(ox, oy, n) in &cells {
                        expanded.extend(std::iter::repeat_n((x + ox, y + oy), n as usize));
                    }
                    for (k, &(cx, cy)) in expanded.iter().enumerate() {
                        let f = (k as f64 + 0.5) / f64::from(m.pieces);
                        let want_x = (f64::from(x) + f * f64::from(m.dx)).round() as i32;
                        let want_y = (f64::from(y) + f * f64::from(m.dy)).round() as i32;
                        assert_eq!((cx, cy), (want_x, want_y), "move {} {} from {x} {y}", m.dx, m.dy);
                    }
                }
            }
        }
    }

    #[test]
    fn optimised_and_lazy_engines_equal_the_reference_bit_for_bit() {
        for (seed, w, h, r, hours) in [
            (1u64, 37usize, 29usize, 8u32, 3.0),
            (2, 50, 41, 8, 0.7),
            (3, 23, 31, 4, 10.0),
            (4, 30, 30, 1, 5.0),
            (5, 45, 20, 2, 1.5),
            // Grids larger than the engine's first window, which grows several times.
            (6, 160, 130, 8, 40.0),
            (7, 210, 70, 3, 40.0),
        ] {
            let ellipses = varied(w, h, seed);
            let grid = MttGrid::from_ellipses(
                w,
                h,
                98.4,
                ellipses.iter().map(|e| e.head_ftmin).collect(),
                ellipses.iter().map(|e| e.eccentricity).collect(),
                &ellipses.iter().map(|e| e.head_azimuth_deg).collect::<Vec<_>>(),
            )
            .expect("grid");
            let ignitions = [(w / 2, h / 2), (3, 4)];
            let want = reference_arrival_times_h(&grid, &ignitions, r, hours);
            let got = grid.arrival_times_h(&ignitions, r, hours).expect("runs");
            assert!(
                want.iter().filter(|v| v.is_finite()).count() > 10,
                "seed {seed}: the fire spreads"
            );
            assert_eq!(
                want.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "seed {seed}"
            );
            let lazy = arrival_times_lazy_h(w, h, 98.4, |i| ellipses[i], &ignitions, r, hours).expect("runs");
            assert_eq!(
                want.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                lazy.arrival_h(w * h)
                    .iter()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>(),
                "seed {seed}, lazy"
            );
            assert!(lazy.ellipses_evaluated <= w * h);
        }
    }

    #[test]
    fn lazy_engine_evaluates_only_where_the_fire_goes() {
        let (w, h) = (200, 200);
        let slow = Ellipse {
            head_ftmin: 1.0,
            eccentricity: 0.5,
            head_azimuth_deg: 45.0,
        };
        let run = arrival_times_lazy_h(w, h, 98.4, |_| slow, &[(100, 100)], 8, 2.0).expect("runs");
        assert!(!run.reached_h.is_empty());
        assert!(run.ellipses_evaluated < w * h / 20, "{}", run.ellipses_evaluated);
        assert!(matches!(
            arrival_times_lazy_h(w, h, 0.0, |_| slow, &[(1, 1)], 8, 2.0),
            Err(MttError::CellSize(_))
        ));
        assert!(matches!(
            MttGrid::from_ellipses(2, 2, 98.4, vec![1.0; 3], vec![0.0; 4], &[0.0; 4]),
            Err(MttError::GridSize {
                layer: "head_ftmin",
                got: 3,
                ..
            })
        ));
    }
}
