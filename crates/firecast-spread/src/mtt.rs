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
        if !(1..=8).contains(&stencil_radius) {
            return Err(MttError::StencilRadius(stencil_radius));
        }
        if !(max_time_h > 0.0 && max_time_h.is_finite()) {
            return Err(MttError::MaxTime(max_time_h));
        }
        let (w, h) = (self.width, self.height);
        let moves = stencil(stencil_radius as i32);
        let max_min = max_time_h * 60.0;
        let mut t = vec![f64::INFINITY; w * h];
        let mut done = vec![false; w * h];
        let mut heap = BinaryHeap::new();
        for &(x, y) in ignitions {
            if x >= w || y >= h {
                return Err(MttError::IgnitionOutside {
                    x,
                    y,
                    width: w,
                    height: h,
                });
            }
            let i = y * w + x;
            if self.burnable(i) {
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
                    let r = self.ros_toward_ftmin(cy * w + cx, m.ux, m.uy);
                    if r.is_nan() || r <= 0.0 {
                        continue 'moves;
                    }
                    cost += 1.0 / r;
                }
                let tj = ti + cost * m.len_cells * self.cell_size_ft / f64::from(m.pieces);
                if tj < t[j] {
                    t[j] = tj;
                    heap.push(Entry { t: tj, i: j });
                }
            }
        }
        Ok(t.into_iter()
            .map(|v| if v <= max_min { v / 60.0 } else { f64::INFINITY })
            .collect())
    }
}

/// One-shot: build the per-cell ellipses and run the engine.
pub fn arrival_times_h(
    landscape: &Landscape,
    cfg: &MttConfig,
    ignitions: &[(usize, usize)],
) -> Result<Vec<f64>, MttError> {
    MttGrid::new(landscape, cfg)?.arrival_times_h(ignitions, cfg.stencil_radius, cfg.max_time_h)
}

struct Move {
    dx: i32,
    dy: i32,
    len_cells: f64,
    ux: f64,
    uy: f64,
    pieces: u32,
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
