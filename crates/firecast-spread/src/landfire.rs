//! A LANDFIRE landscape's fire for the minimum-travel-time engine: windows cut from the grid
//! ([`Window`], [`crop`]), every cell's surface spread ellipse as the behaviour grid computes
//! it ([`LandfireEllipses`]), and a point fire spread over them, each cell evaluated when the
//! fire first reaches it ([`landfire_arrival_lazy_h`]). The episodes' LANDFIRE fires and
//! `firecast bench spread` both run this.

use firecast_landscape::landfire::LandfireLandscape;
use firecast_sim::behavior::{
    BehaviorParams, SlopeMode, lcp_slope_percent, sheltering_canopy, wind_adjustment_factor,
};
use firecast_sim::{FuelModel, SpreadInputs, SurfaceFuelBed, WindLimit};

use crate::mtt::{Ellipse, MttError, MttGrid, arrival_times_lazy_h};

const FT_PER_M: f64 = 1.0 / 0.3048;

/// Errors of a LANDFIRE fire.
#[derive(Debug, thiserror::Error)]
pub enum LandfireSpreadError {
    /// A fuel model whose bed cannot be prepared.
    #[error(transparent)]
    Kernel(#[from] firecast_sim::RothermelError),
    #[error(transparent)]
    Mtt(#[from] MttError),
}

/// A rectangle of cells, in the landscape's rows (row 0 north) and columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Window {
    pub row0: usize,
    pub col0: usize,
    pub rows: usize,
    pub cols: usize,
}

impl Window {
    /// The whole grid.
    pub fn full(land: &LandfireLandscape) -> Self {
        Self {
            row0: 0,
            col0: 0,
            rows: land.grid.height,
            cols: land.grid.width,
        }
    }

    /// `rows` × `cols` cells centred on (`col`, `row`), moved inside the grid (and cut to it).
    pub fn around(land: &LandfireLandscape, col: usize, row: usize, rows: usize, cols: usize) -> Self {
        let (h, w) = (land.grid.height, land.grid.width);
        let (rows, cols) = (rows.clamp(1, h), cols.clamp(1, w));
        Self {
            row0: row.saturating_sub(rows / 2).min(h - rows),
            col0: col.saturating_sub(cols / 2).min(w - cols),
            rows,
            cols,
        }
    }

    pub fn cells(&self) -> usize {
        self.rows * self.cols
    }

    /// Whether cell (`col`, `row`) of the landscape is inside the window.
    pub fn contains(&self, col: usize, row: usize) -> bool {
        (self.col0..self.col0 + self.cols).contains(&col) && (self.row0..self.row0 + self.rows).contains(&row)
    }
}

/// The landscape cut to `w` (every layer; the grid's origin moved to the window's corner).
pub fn crop(land: &LandfireLandscape, w: Window) -> LandfireLandscape {
    fn cut<T: Copy>(v: &[T], width: usize, w: Window) -> Vec<T> {
        (w.row0..w.row0 + w.rows)
            .flat_map(|r| v[r * width + w.col0..r * width + w.col0 + w.cols].iter().copied())
            .collect()
    }
    let width = land.grid.width;
    let mut out = land.clone();
    out.fuel = cut(&land.fuel, width, w);
    out.slope_percent = cut(&land.slope_percent, width, w);
    out.aspect_deg = cut(&land.aspect_deg, width, w);
    for layer in [
        &mut out.elevation_m,
        &mut out.canopy_cover_pct,
        &mut out.canopy_height_m,
        &mut out.canopy_base_height_m,
        &mut out.canopy_bulk_density_kg_m3,
    ] {
        if let Some(values) = layer.as_mut() {
            *values = cut(values, width, w);
        }
    }
    out.grid.origin_x += w.col0 as f64 * land.grid.pixel_dx;
    out.grid.origin_y += w.row0 as f64 * land.grid.pixel_dy;
    out.grid.width = w.cols;
    out.grid.height = w.rows;
    out
}

/// The surface spread ellipse of a LANDFIRE landscape's cells, as [`firecast_sim::behavior`]
/// evaluates the kernel per cell (slope as given, upslope from the aspect with −1 as 0,
/// FlamMap's wind adjustment under canopy, behave's vector combination of wind and slope).
/// Nodata and non-burnable cells do not burn. Surface fire only: the MTT engine has no crown
/// fire.
pub struct LandfireEllipses<'a> {
    land: &'a LandfireLandscape,
    params: &'a BehaviorParams,
    moisture: firecast_sim::FuelMoisture,
    /// Fuel beds by code, prepared when a cell of that code is first evaluated: `None` not
    /// yet, `Some(None)` the code does not burn.
    beds: Vec<Option<Option<(SurfaceFuelBed, f64)>>>,
    limit: WindLimit,
    wind_toward: f64,
}

impl<'a> LandfireEllipses<'a> {
    pub fn new(land: &'a LandfireLandscape, params: &'a BehaviorParams) -> Self {
        Self {
            land,
            params,
            moisture: params.moisture.fractions(),
            beds: Vec::new(),
            limit: if params.wind_limit {
                WindLimit::Rothermel
            } else {
                WindLimit::Off
            },
            wind_toward: (params.wind_from_deg + 180.0).rem_euclid(360.0),
        }
    }

    fn bed(&mut self, code: u16) -> Result<Option<(SurfaceFuelBed, f64)>, LandfireSpreadError> {
        let k = usize::from(code);
        if k >= self.beds.len() {
            self.beds.resize(k + 1, None);
        }
        if self.beds[k].is_none() {
            let bed = match FuelModel::by_number(code).filter(|m| m.burnable) {
                Some(model) => Some((SurfaceFuelBed::new(model, &self.moisture)?, model.depth_ft)),
                None => None,
            };
            self.beds[k] = Some(bed);
        }
        Ok(self.beds[k].flatten())
    }

    /// Cell side, ft.
    pub fn cell_size_ft(&self) -> f64 {
        self.land.grid.pixel_dx.abs() * FT_PER_M
    }

    /// The ellipse of the landscape's cell `i` (row 0 north).
    pub fn at(&mut self, i: usize) -> Result<Ellipse, LandfireSpreadError> {
        let none = Ellipse {
            head_ftmin: 0.0,
            eccentricity: 0.0,
            head_azimuth_deg: 0.0,
        };
        let land = self.land;
        let (Some(code), slope, aspect) = (land.fuel[i], land.slope_percent[i], land.aspect_deg[i]) else {
            return Ok(none);
        };
        if slope.is_nan() || aspect.is_nan() {
            return Ok(none);
        }
        let Some((bed, depth)) = self.bed(code)? else {
            return Ok(none);
        };
        let mut slope = f64::from(slope);
        if self.params.slope == SlopeMode::LcpWholeDegrees {
            slope = lcp_slope_percent(slope);
        }
        let upslope = (f64::from(aspect.max(0.0)) + 180.0).rem_euclid(360.0);
        let (cover, canopy_ft) = sheltering_canopy(land, i);
        let fire = bed.spread_with_limit(
            &SpreadInputs {
                midflame_wind_mph: self.params.wind_20ft_mph
                    * wind_adjustment_factor(depth, canopy_ft, cover),
                slope_percent: slope,
                wind_dir_from_upslope_deg: (self.wind_toward - upslope).rem_euclid(360.0),
            },
            self.limit,
        );
        Ok(Ellipse {
            head_ftmin: fire.head_ros_ftmin,
            eccentricity: fire.eccentricity,
            head_azimuth_deg: upslope + fire.dir_max_spread_from_upslope_deg,
        })
    }

    /// The landscape's cell of the MTT grid's cell `j` (row 0 south).
    pub fn landscape_index(&self, j: usize) -> usize {
        let (w, h) = (self.land.grid.width, self.land.grid.height);
        (h - 1 - j / w) * w + j % w
    }

    /// Every cell's ellipse in an [`MttGrid`] (row 0 south: the landscape's rows reversed).
    pub fn grid(&mut self) -> Result<MttGrid, LandfireSpreadError> {
        let (w, h) = (self.land.grid.width, self.land.grid.height);
        let ellipses: Vec<Ellipse> = (0..w * h)
            .map(|j| self.at(self.landscape_index(j)))
            .collect::<Result<_, _>>()?;
        Ok(MttGrid::from_ellipses(
            w,
            h,
            self.cell_size_ft(),
            ellipses.iter().map(|e| e.head_ftmin).collect(),
            ellipses.iter().map(|e| e.eccentricity).collect(),
            &ellipses.iter().map(|e| e.head_azimuth_deg).collect::<Vec<_>>(),
        )?)
    }
}

/// A fire on a LANDFIRE landscape spread by the MTT engine over the cells' own slope, aspect and
/// canopy ([`LandfireEllipses`]), each cell's ellipse evaluated when the fire's moves first
/// reach it: `ignitions` as (column, row) of the MTT grid (row 0 south), `hours` the time limit.
/// A kernel error (a fuel model that cannot be prepared) stops the fire where it occurs and is
/// returned after the run.
pub fn landfire_arrival_lazy_h(
    land: &LandfireLandscape,
    params: &BehaviorParams,
    ignitions: &[(usize, usize)],
    stencil_radius: u32,
    hours: f64,
) -> Result<crate::mtt::LazyRun, LandfireSpreadError> {
    let mut ellipses = LandfireEllipses::new(land, params);
    let cell_ft = ellipses.cell_size_ft();
    let mut failed = None;
    let run = arrival_times_lazy_h(
        land.grid.width,
        land.grid.height,
        cell_ft,
        |j| {
            let i = ellipses.landscape_index(j);
            ellipses.at(i).unwrap_or_else(|e| {
                failed.get_or_insert(e);
                Ellipse {
                    head_ftmin: 0.0,
                    eccentricity: 0.0,
                    head_azimuth_deg: 0.0,
                }
            })
        },
        ignitions,
        stencil_radius,
        hours,
    )?;
    match failed {
        Some(e) => Err(e),
        None => Ok(run),
    }
}

#[cfg(test)]
mod tests {
    use std::time::Instant;

    use firecast_sim::FuelModel;

    use super::*;

    /// The Worcester, Vermont LANDFIRE clip of the FlamMap parity test, from the repository root.
    const WORCESTER: &str = "crates/firecast-landscape/tests/fixtures/landfire-worcester/landfire";

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

    #[test]
    fn windows_stay_inside_the_grid() {
        let land = worcester();
        let w = Window::around(&land, 0, 0, 100, 80);
        assert_eq!((w.row0, w.col0, w.rows, w.cols), (0, 0, 100, 80));
        let w = Window::around(&land, land.grid.width - 1, land.grid.height - 1, 100, 80);
        assert_eq!(w.row0 + w.rows, land.grid.height);
        assert_eq!(w.col0 + w.cols, land.grid.width);
        let c = crop(&land, w);
        assert_eq!((c.grid.width, c.grid.height, c.fuel.len()), (80, 100, 8000));
        let (r, k) = (w.row0 + 7, w.col0 + 3);
        assert_eq!(c.fuel[7 * 80 + 3], land.fuel[r * land.grid.width + k]);
        assert_eq!(
            c.slope_percent[7 * 80 + 3],
            land.slope_percent[r * land.grid.width + k]
        );
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

    /// The bench's fire (the lazy engine: a growing window, each cell's 1/rate table) equals the
    /// engine over every cell's ellipse (`MttGrid`) bit for bit on the Worcester clip, for the
    /// bench's 8 hours and a longer fire whose window grows.
    #[test]
    fn lazy_landfire_fire_equals_the_whole_grids_bit_for_bit() {
        let land = worcester();
        let params = windy_params();
        let grid = LandfireEllipses::new(&land, &params).grid().expect("grid");
        let (w, h) = (land.grid.width, land.grid.height);
        for (ignition, hours) in [
            ((362, h - 1 - 457), 8.0),
            ((362, h - 1 - 457), 40.0),
            ((100, 500), 24.0),
        ] {
            let lazy = landfire_arrival_lazy_h(&land, &params, &[ignition], 8, hours).expect("runs");
            let whole = grid.arrival_times_h(&[ignition], 8, hours).expect("runs");
            assert!(
                lazy.reached_h.len() > 50,
                "{ignition:?} {hours}: {}",
                lazy.reached_h.len()
            );
            assert_eq!(
                lazy.arrival_h(w * h)
                    .iter()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>(),
                whole.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "{ignition:?} {hours}"
            );
        }
    }

    /// For profiling the bench's fire alone: `cargo test --release … --lib -- --ignored
    /// landfire::tests::spread_timing --nocapture`.
    #[test]
    #[ignore]
    fn spread_timing() {
        let land = worcester();
        let params = windy_params();
        let h = land.grid.height;
        let mut best = f64::INFINITY;
        for _ in 0..2000 {
            let started = Instant::now();
            let run = landfire_arrival_lazy_h(&land, &params, &[(362, h - 1 - 457)], 8, 8.0).expect("runs");
            best = best.min(started.elapsed().as_secs_f64());
            assert_eq!(run.reached_h.len(), 273);
        }
        println!("best {:.3} ms", best * 1e3);
    }

    #[test]
    fn mtt_grid_rows_run_south_to_north() {
        // A window's MTT grid: the landscape's north row is the grid's last.
        let land = worcester();
        let w = Window::around(&land, 274, 306, 40, 40);
        let c = crop(&land, w);
        let params: BehaviorParams = serde_json::from_value(serde_json::json!({
            "moisture": {"dead_1h": 6, "dead_10h": 8, "dead_100h": 10, "live_herbaceous": 75, "live_woody": 60}
        }))
        .expect("params");
        let grid = LandfireEllipses::new(&c, &params).grid().expect("grid");
        for row in 0..40 {
            for col in 0..40 {
                let burns = c.fuel[row * 40 + col]
                    .and_then(FuelModel::by_number)
                    .is_some_and(|m| m.burnable);
                assert_eq!(grid.burnable((39 - row) * 40 + col), burns, "{row} {col}");
            }
        }
    }
}
