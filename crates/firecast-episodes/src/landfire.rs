//! LANDFIRE landscapes for ensembles and episodes: a folder of LANDFIRE GeoTIFF layers or a
//! FARSITE/FlamMap `.lcp` (read by [`firecast_landscape::landfire`], with its checks: unknown
//! fuel codes, grids that disagree, a geographic CRS, a corrupt file are errors naming the file,
//! the layer and the cell), cut to a window around a place or taken whole, at LANDFIRE's own
//! resolution (no resampling).
//!
//! The simulator's landscape keeps the fuel model of every cell (FBFM40 or FBFM13 codes, which
//! the Rothermel kernel knows by number) and the elevation; a cell whose fuel layer holds no
//! data becomes non-burnable (NB9, [`NODATA_FUEL_CODE`]), and every such cell is counted in the
//! landscape's label. Both spread engines take slope and aspect from the elevation between
//! cells, as they do on every landscape; the window's slope, aspect and canopy layers are kept
//! ([`LandfireSite::layers`]), and [`LandfireSite::mtt_arrival_h`] spreads a fire with the MTT
//! engine over them (LANDFIRE's slope and aspect, FlamMap's wind adjustment under the canopy), as
//! `firecast bench spread` does.

use std::collections::{BTreeMap, VecDeque};
use std::path::{Path, PathBuf};

use firecast_landscape::landfire::{FuelLayer, LandfireError, LandfireLandscape, LayerKind};
use firecast_landscape::{Crs, GeoReference, Landscape};
use firecast_sim::FuelModel;
use firecast_sim::behavior::{BehaviorParams, FuelChoice, MoisturePercent, SlopeMode};
use firecast_sim::crown::CrownMethod;
use firecast_spread::landfire::{Window, crop, landfire_arrival_lazy_h};
use firecast_spread::mtt::MttConfig;
use serde::{Deserialize, Serialize};

use crate::EpisodeError;

/// Feet per metre (international foot).
const FT_PER_M: f64 = 1.0 / 0.3048;

/// The fuel code of a cell whose fuel layer holds no data: NB9 (bare ground), non-burnable.
pub const NODATA_FUEL_CODE: u16 = 99;

/// Which LANDFIRE fuel-model layer to read, as written in YAML.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FuelLayerName {
    /// Scott & Burgan's 40 fuel models (FBFM40).
    #[default]
    Fbfm40,
    /// Anderson's 13 fuel models (FBFM13).
    Fbfm13,
}

impl FuelLayerName {
    /// The reader's layer.
    pub fn layer(self) -> FuelLayer {
        match self {
            Self::Fbfm40 => FuelLayer::Fbfm40,
            Self::Fbfm13 => FuelLayer::Fbfm13,
        }
    }

    fn is_default(&self) -> bool {
        *self == Self::Fbfm40
    }
}

/// Serde's `skip_serializing_if` for the fuel layer (the default, FBFM40, is not written).
pub(crate) fn is_fbfm40(name: &FuelLayerName) -> bool {
    name.is_default()
}

/// The cells of a LANDFIRE landscape by what its fuel layer held.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FuelCellCounts {
    /// Cells with a burnable fuel model.
    pub burnable: u64,
    /// Cells with a non-burnable code (91–99), by code.
    pub nonburnable: BTreeMap<u16, u64>,
    /// Cells whose fuel layer holds nodata: not burnable here (NB9).
    pub fuel_nodata: u64,
    /// Cells whose elevation is nodata (none of them burnable: that is an error); filled from
    /// the nearest cell with an elevation.
    pub elevation_nodata: u64,
    /// Cells with a fuel code the scheme does not know: always 0 here, since any is an error
    /// naming the file, the codes and the first cell.
    pub unknown_codes: u64,
}

/// The part of the LANDFIRE grid a landscape covers, in the grid's columns and rows (row 0
/// north, as GDAL counts).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridWindow {
    pub col0: usize,
    pub row0: usize,
    pub cols: usize,
    pub rows: usize,
    /// The whole grid's size.
    pub grid_cols: usize,
    pub grid_rows: usize,
}

/// A LANDFIRE landscape as the simulator takes it, with what was read to build it.
#[derive(Debug, Clone, PartialEq)]
pub struct LandfireSite {
    /// Fuel codes and elevation, row 0 south.
    pub landscape: Landscape,
    /// Every layer of the window as read (row 0 north; slope, aspect, canopy).
    pub layers: LandfireLandscape,
    pub window: GridWindow,
    /// The folder or `.lcp` as given.
    pub path: PathBuf,
    /// `LANDFIRE GeoTIFF layers` or `FARSITE .lcp`.
    pub format: &'static str,
    /// The files read: one per layer, or the `.lcp` (and its `.prj`).
    pub sources: Vec<PathBuf>,
    pub cells: FuelCellCounts,
}

fn spec_error(reason: String) -> EpisodeError {
    EpisodeError::LandscapeSpec {
        spec: "landfire".into(),
        reason,
    }
}

fn reader_error(e: LandfireError) -> EpisodeError {
    spec_error(e.to_string())
}

/// Reads the LANDFIRE landscape at `path` (a folder of layers, an `.lcp`, or a folder holding
/// one) and cuts the `size` = [width, height] cells around `center` ([lat, lon]) from it
/// (moved inside the grid, and cut to it when larger), or takes the whole grid without a
/// center.
pub fn load(
    path: &Path,
    fuel: FuelLayerName,
    center: Option<[f64; 2]>,
    size: Option<[usize; 2]>,
) -> Result<LandfireSite, EpisodeError> {
    let full = LandfireLandscape::read_path(path, fuel.layer()).map_err(reader_error)?;
    let fuel_file = full
        .file(match fuel {
            FuelLayerName::Fbfm40 => LayerKind::Fbfm40,
            FuelLayerName::Fbfm13 => LayerKind::Fbfm13,
        })
        .unwrap_or(path)
        .to_path_buf();
    let g = &full.grid;
    let crs = Crs::parse(&g.crs);
    if !crs.is_supported() {
        return Err(spec_error(format!(
            "the grid's CRS `{}` ({}) cannot be converted to latitude and longitude, which the ignition \
             point and the weather need (EPSG:5070, LANDFIRE's, WGS84 UTM and EPSG:4326 can)",
            g.crs,
            fuel_file.display()
        )));
    }
    if (g.pixel_dx.abs() - g.pixel_dy.abs()).abs() > 1e-6 * g.pixel_dx.abs() {
        return Err(spec_error(format!(
            "cells are {} x {} m, not square ({})",
            g.pixel_dx.abs(),
            g.pixel_dy.abs(),
            fuel_file.display()
        )));
    }
    let window = match (center, size) {
        (None, None) => Window::full(&full),
        (None, Some(_)) => {
            return Err(spec_error(
                "width and height cut a window around `center`: give center too (or neither, for the whole grid)"
                    .into(),
            ));
        }
        (Some([lat, lon]), size) => {
            let [width, height] = size.unwrap_or([crate::default_width(), crate::default_height()]);
            if width == 0 || height == 0 {
                return Err(spec_error(format!(
                    "width and height must be at least 1, got {width} x {height}"
                )));
            }
            let (x, y) = crs.from_lat_lon(lat, lon).ok_or_else(|| {
                spec_error(format!("center ({lat}, {lon}) is not a latitude and longitude"))
            })?;
            let col = ((x - g.origin_x) / g.pixel_dx).floor();
            let row = ((y - g.origin_y) / g.pixel_dy).floor();
            if !(col >= 0.0 && row >= 0.0 && col < g.width as f64 && row < g.height as f64) {
                return Err(spec_error(format!(
                    "center ({lat}, {lon}) is outside the LANDFIRE grid ({} x {} cells of {} m in {}): {}",
                    g.width,
                    g.height,
                    g.pixel_dx.abs(),
                    g.crs,
                    fuel_file.display()
                )));
            }
            Window::around(&full, col as usize, row as usize, height, width)
        }
    };
    let layers = crop(&full, window);
    let grid_window = GridWindow {
        col0: window.col0,
        row0: window.row0,
        cols: window.cols,
        rows: window.rows,
        grid_cols: g.width,
        grid_rows: g.height,
    };
    let locate = |i: usize| (window.col0 + i % window.cols, window.row0 + i / window.cols);

    // The engines need slope and aspect (and, from the elevation, their own) where fuel burns.
    layers.check_burnable_cells(false).map_err(|e| match e {
        LandfireError::NodataAtBurnableCell {
            layer,
            count,
            col,
            row,
            fuel,
            path,
        } => {
            let (col, row) = locate(row * window.cols + col);
            reader_error(LandfireError::NodataAtBurnableCell {
                layer,
                count,
                col,
                row,
                fuel,
                path,
            })
        }
        other => reader_error(other),
    })?;
    let elevation_file = full.file(LayerKind::Elevation).unwrap_or(path).to_path_buf();
    let elevation_m = layers.elevation_m.as_ref().ok_or_else(|| {
        spec_error(format!(
            "the landscape has no elevation layer (a GeoTIFF whose name holds Elev), which the spread \
             engines take slope and aspect from: {}",
            path.display()
        ))
    })?;
    let burnable = |code: &Option<u16>| code.is_some_and(|c| !(91..=99).contains(&c));
    let missing: Vec<usize> = (0..layers.len())
        .filter(|&i| elevation_m[i].is_nan() && burnable(&layers.fuel[i]))
        .collect();
    if let Some(&first) = missing.first() {
        let (col, row) = locate(first);
        return Err(reader_error(LandfireError::NodataAtBurnableCell {
            layer: LayerKind::Elevation.name(),
            count: missing.len(),
            col,
            row,
            fuel: layers.fuel[first].unwrap_or_default(),
            path: elevation_file,
        }));
    }

    let mut cells = FuelCellCounts::default();
    for code in &layers.fuel {
        match code {
            None => cells.fuel_nodata += 1,
            Some(c) if (91..=99).contains(c) => *cells.nonburnable.entry(*c).or_default() += 1,
            Some(_) => cells.burnable += 1,
        }
    }
    cells.elevation_nodata = elevation_m.iter().filter(|v| v.is_nan()).count() as u64;

    // Row 0 south, as the simulator counts.
    let (w, h) = (window.cols, window.rows);
    let north = |x: usize, y: usize| (h - 1 - y) * w + x;
    let filled = fill_nearest(elevation_m, w, h);
    let mut land_cover = Vec::with_capacity(w * h);
    let mut elevation_ft = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let i = north(x, y);
            land_cover.push(layers.fuel[i].unwrap_or(NODATA_FUEL_CODE));
            elevation_ft.push((f64::from(filled[i]) * FT_PER_M) as f32);
        }
    }
    let lg = &layers.grid;
    let landscape = Landscape::new(
        w,
        h,
        lg.pixel_dx.abs() * FT_PER_M,
        fuel.layer().scheme(),
        land_cover,
        elevation_ft,
        GeoReference {
            crs: crs.code(),
            origin_x: lg.origin_x,
            origin_y: lg.origin_y + h as f64 * lg.pixel_dy,
            cell_size_x: lg.pixel_dx,
            cell_size_y: -lg.pixel_dy,
        },
    )?;
    let mut sources: Vec<PathBuf> = full.files.values().cloned().collect();
    sources.sort();
    sources.dedup();
    if full.report.format != "LANDFIRE GeoTIFF layers" {
        for lcp in sources.clone() {
            let prj = lcp.with_extension("prj");
            if prj.is_file() {
                sources.push(prj);
            }
        }
    }
    Ok(LandfireSite {
        landscape,
        path: path.to_path_buf(),
        format: full.report.format,
        layers,
        window: grid_window,
        sources,
        cells,
    })
}

/// `values` (row-major, `w × h`) with every `NaN` replaced by the value of the nearest cell
/// that has one (4-neighbour steps, ties to the first found in row-major order); all zero when
/// none has.
fn fill_nearest(values: &[f32], w: usize, h: usize) -> Vec<f32> {
    let mut out = values.to_vec();
    let mut queue: VecDeque<usize> = (0..out.len()).filter(|&i| !out[i].is_nan()).collect();
    if queue.is_empty() {
        return vec![0.0; out.len()];
    }
    while let Some(i) = queue.pop_front() {
        let (x, y) = (i % w, i / w);
        let neighbours = [
            (x > 0).then(|| i - 1),
            (x + 1 < w).then(|| i + 1),
            (y > 0).then(|| i - w),
            (y + 1 < h).then(|| i + w),
        ];
        for j in neighbours.into_iter().flatten() {
            if out[j].is_nan() {
                out[j] = out[i];
                queue.push_back(j);
            }
        }
    }
    out
}

impl LandfireSite {
    /// One line a report can print: the files, the window, and every cell the fuel layer gave
    /// no burnable fuel.
    pub fn note(&self) -> String {
        let win = &self.window;
        let nonburnable = if self.cells.nonburnable.is_empty() {
            "none".to_string()
        } else {
            self.cells
                .nonburnable
                .iter()
                .map(|(code, n)| format!("{n} of code {code}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        format!(
            "LANDFIRE landscape from {} ({}: {}; fuel {}): {} x {} cells of {:.0} m from column {}, row {} of its \
             {} x {} grid ({}); {} cells burnable, non-burnable {nonburnable}, {} without fuel data (not burnable \
             here), {} without elevation (filled from the nearest cell), {} unknown fuel codes; the minimum-travel-time \
             engine reads the fuel models, LANDFIRE's slope and aspect and the canopy (which shelters the wind; \
             surface fire only, no crown fire), the automaton the fuel models and the elevation (slope and aspect \
             between cells from it)",
            self.path.display(),
            self.format,
            self.sources
                .iter()
                .filter_map(|p| p.file_name())
                .map(|n| n.to_string_lossy())
                .collect::<Vec<_>>()
                .join(", "),
            self.layers.fuel_layer.name().to_uppercase(),
            win.cols,
            win.rows,
            self.landscape.cell_size_ft / FT_PER_M,
            win.col0,
            win.row0,
            win.grid_cols,
            win.grid_rows,
            self.landscape.georef.crs,
            self.cells.burnable,
            self.cells.fuel_nodata,
            self.cells.elevation_nodata,
            self.cells.unknown_codes,
        )
    }

    /// Arrival time per cell in hours (`f64::INFINITY` where the fire does not arrive by
    /// `cfg.max_time_h`; simulator cell order, row 0 south) of a fire lit at simulator cell
    /// `ignition`, spread by the MTT engine over the window's own layers: LANDFIRE's slope and
    /// aspect, the 20-ft wind reduced to midflame by FlamMap's adjustment (sheltered under a
    /// canopy), surface fire only, each cell's ellipse evaluated when the fire first reaches it
    /// (`firecast_spread::landfire::LandfireEllipses`). None when the wind is given at midflame (the
    /// adjustment needs a 20-ft or 10-m wind; 10-m = 1.15 × 20-ft).
    pub fn mtt_arrival_h(
        &self,
        cfg: &MttConfig,
        ignition: (usize, usize),
    ) -> Result<Option<Vec<f64>>, EpisodeError> {
        let wind = cfg.wind;
        let wind_20ft_mph = match wind.measured_at {
            firecast_sim::WindHeight::Midflame => return Ok(None),
            firecast_sim::WindHeight::TwentyFoot => wind.speed_mph,
            firecast_sim::WindHeight::TenMetre => wind.speed_mph / 1.15,
        };
        let m = cfg.moisture;
        let params = BehaviorParams {
            fuel: match self.layers.fuel_layer {
                FuelLayer::Fbfm40 => FuelChoice::Fbfm40,
                FuelLayer::Fbfm13 => FuelChoice::Fbfm13,
            },
            moisture: MoisturePercent {
                dead_1h: 100.0 * m.dead_1h_frac,
                dead_10h: 100.0 * m.dead_10h_frac,
                dead_100h: 100.0 * m.dead_100h_frac,
                live_herbaceous: 100.0 * m.live_herb_frac,
                live_woody: 100.0 * m.live_woody_frac,
            },
            wind_20ft_mph,
            wind_from_deg: wind.from_direction_deg,
            slope: SlopeMode::AsGiven,
            wind_limit: false,
            crown: CrownMethod::None,
            foliar_moisture_pct: 100.0,
        };
        let run = landfire_arrival_lazy_h(
            &self.layers,
            &params,
            &[ignition],
            cfg.stencil_radius,
            cfg.max_time_h,
        )
        .map_err(|e| EpisodeError::Engine(format!("minimum travel time on the LANDFIRE layers: {e}")))?;
        Ok(Some(run.arrival_h(self.landscape.len())))
    }

    /// Why simulator cell (`x`, `y`) (row 0 south) cannot burn, naming the LANDFIRE cell and the
    /// fuel layer's file; None where it can.
    pub fn unburnable_cell(&self, x: usize, y: usize) -> Option<String> {
        let win = &self.window;
        if x >= win.cols || y >= win.rows {
            return None;
        }
        let row = win.rows - 1 - y;
        let (gcol, grow) = (win.col0 + x, win.row0 + row);
        let kind = match self.layers.fuel_layer {
            FuelLayer::Fbfm40 => LayerKind::Fbfm40,
            FuelLayer::Fbfm13 => LayerKind::Fbfm13,
        };
        let file = self
            .layers
            .file(kind)
            .map_or_else(String::new, |p| format!(" of {}", p.display()));
        match self.layers.fuel[row * win.cols + x] {
            None => Some(format!(
                "the LANDFIRE {} layer{file} has no data (nodata) at column {gcol}, row {grow}",
                self.layers.fuel_layer.name()
            )),
            Some(code) if (91..=99).contains(&code) => Some(format!(
                "LANDFIRE column {gcol}, row {grow}{file} holds the non-burnable fuel code {code} ({})",
                FuelModel::by_number(code).map_or("non-burnable", |m| m.name)
            )),
            Some(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::fill_nearest;

    #[test]
    fn nodata_takes_the_nearest_value() {
        let nan = f32::NAN;
        let v = [nan, 1.0, nan, nan, nan, nan, nan, nan, 5.0];
        assert_eq!(
            fill_nearest(&v, 3, 3),
            vec![1.0, 1.0, 1.0, 1.0, 1.0, 5.0, 5.0, 5.0, 5.0]
        );
        assert_eq!(fill_nearest(&[nan, nan], 2, 1), vec![0.0, 0.0]);
    }
}
