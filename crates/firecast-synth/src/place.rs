//! The landscape of a place in the synthetic world: the terrain and land cover that the
//! generator's own static world (`climate.rs`) has at any latitude and longitude, on a grid as
//! fine as a fire simulation needs (500 ft cells by default, ~30 cells per GRIDMET cell).
//!
//! Every value is a pure function of `(lat, lon, seed)`: a grid only chooses where to sample,
//! so two grids that share cells agree on them, the same request gives a bit-identical map,
//! and places far apart get the world's different terrain and climate at each (never one map
//! for every place). It is synthetic — a plausible landscape for the synthetic weather, not
//! LANDFIRE or MODIS data.
//!
//! - **Elevation**: the world's macro relief plus its seeded fractal relief, sampled
//!   continuously between GRIDMET cell centres (at a centre it is that cell's elevation), plus
//!   seven finer seeded octaves (1/16° down to ~110 m, amplitude ∝ spacing^0.6 and the world's
//!   roughness, the coarser four ridged: ridges and valleys of a few hundred metres in the
//!   Rockies, tens of metres on the Plains).
//! - **Climate at the place**: the GRIDMET cells' annual precipitation, mean temperature, peak
//!   greenness and human activity, bilinearly interpolated, with temperature lapsed (4.5 K/km)
//!   and precipitation raised (0.4 mm/m) by the local relief.
//! - **Land cover** (MODIS IGBP classes, as the fire kernels read them): a moisture score
//!   `ln(P / PET) + (greenness − 0.6) + 0.25·patch + 0.15·hollowness`, with
//!   `PET = 350 + 45·max(T, 0)` mm, picks forest, woody savanna, shrub or savanna, grass, open
//!   shrub and barren; forest type from temperature and region; snow (T < −5 °C) and rock
//!   (T < −2 °C) above, alpine grass below the tree line; water and wetlands in the deepest
//!   hollows of the local relief (fewer in dry climates) and outside the world's land outline;
//!   developed patches where the world's human activity is high, in valley bottoms.
//!
//! The whole generator, with its constants: docs/spec/data.md §7.5.

use rayon::prelude::*;

use super::climate::{
    Cell, RELIEF_HURST, RELIEF_STEPS, Settlements, YEAR_DAYS, cell_info, macro_elevation, rockies_front,
};
use super::grid::{GRID_LAT0, GRID_LON0, GRID_N_LAT, GRID_N_LON, GRID_STEP, is_land};
use super::noise::{Stream, fractal_at, value_noise_at};

/// Feet to metres.
const FT_TO_M: f64 = 0.3048;

/// Spacings (GRIDMET cells) of the relief finer than the world's: 1/16° down to ~110 m.
const DETAIL_STEPS: [f64; 7] = [1.5, 0.75, 0.375, 0.1875, 0.093_75, 0.046_875, 0.023_437_5];
/// Amplitude ratio exponent of the fine octaves (weight `(step/1.5)^0.6`): rougher than the
/// world's 0.9, so valleys a few cells wide have slopes a fire feels.
const DETAIL_HURST: f64 = 0.6;
/// Fine relief of the first octave as a fraction of the world's roughness scale.
const DETAIL_AMP: f64 = 0.4;
/// The coarser fine octaves are ridged (`0.8 − |n|`, crests where the noise crosses zero), so
/// the relief has ridge lines and valleys between them rather than round hills only.
const RIDGED_BELOW: usize = 4;
/// Local orographic precipitation gradient (mm per m above the GRIDMET cell's elevation).
const OROGRAPHIC_MM_PER_M: f64 = 0.4;
/// These octaves (~1.7 km to ~430 m) make the local relief whose hollows hold water and towns:
/// coarse enough that a lake is a patch of cells, not a speckle.
const LOCAL_OCTAVES: std::ops::Range<usize> = 2..5;

/// MODIS IGBP classes the generator writes.
pub mod igbp {
    pub const EVERGREEN_NEEDLELEAF: u16 = 1;
    pub const DECIDUOUS_BROADLEAF: u16 = 4;
    pub const MIXED_FOREST: u16 = 5;
    pub const CLOSED_SHRUBLAND: u16 = 6;
    pub const OPEN_SHRUBLAND: u16 = 7;
    pub const WOODY_SAVANNA: u16 = 8;
    pub const SAVANNA: u16 = 9;
    pub const GRASSLAND: u16 = 10;
    pub const WETLAND: u16 = 11;
    pub const URBAN: u16 = 13;
    pub const SNOW_ICE: u16 = 15;
    pub const BARREN: u16 = 16;
    pub const WATER: u16 = 17;
}

/// Why a place's landscape cannot be built.
#[derive(Debug, thiserror::Error)]
pub enum PlaceError {
    /// A grid parameter is out of range.
    #[error("synthetic landscape: {key} = {value}: {reason}")]
    Grid {
        key: &'static str,
        value: String,
        reason: String,
    },
    /// The folder holds no GRIDMET files.
    #[error("{}: no GRIDMET files (*.nc) to read the synthetic world's seed from", dir.display())]
    NoFiles { dir: std::path::PathBuf },
    /// A file cannot be opened.
    #[error("{}: cannot read the global attribute `firecast_seed`: {message}", path.display())]
    Read {
        path: std::path::PathBuf,
        message: String,
    },
    /// A file has no seed: real GRIDMET, or another generator's.
    #[error(
        "{}: no global attribute `firecast_seed`: this is not FireCast's synthetic GRIDMET, so there is \
         no synthetic world to take the landscape from; for a real place give LANDFIRE layers or a \
         GeoTIFF landscape (land cover and elevation)",
        path.display()
    )]
    NotSynthetic { path: std::path::PathBuf },
    /// The seed is not a whole number.
    #[error("{}: global attribute `firecast_seed` = {value:?} is not a whole number", path.display())]
    BadSeed { path: std::path::PathBuf, value: String },
    /// Two files come from different worlds.
    #[error("{} has firecast_seed {a} but {} has {b}: the GRIDMET folder mixes synthetic worlds", first.display(), other.display())]
    MixedSeeds {
        first: std::path::PathBuf,
        a: u64,
        other: std::path::PathBuf,
        b: u64,
    },
}

/// A grid on the world's lattice: square cells of `cell_size_ft` whose size in degrees comes
/// from the latitude of the GRIDMET row at the centre, with edges on whole multiples of it, so
/// grids around nearby points share their cells exactly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaceGrid {
    pub width: usize,
    pub height: usize,
    pub cell_size_ft: f64,
    /// Longitude of the west edge and latitude of the south edge (degrees).
    pub west_lon: f64,
    pub south_lat: f64,
    /// Cell size along longitude and latitude (degrees).
    pub cell_lon_deg: f64,
    pub cell_lat_deg: f64,
}

/// Metres per degree of latitude and of longitude on the WGS84 ellipsoid.
fn metres_per_degree(lat: f64) -> (f64, f64) {
    const A: f64 = 6_378_137.0;
    const F: f64 = 1.0 / 298.257_223_563;
    let e2 = F * (2.0 - F);
    let phi = lat.to_radians();
    let w = (1.0 - e2 * phi.sin().powi(2)).sqrt();
    (
        (A * (1.0 - e2) / (w * w * w)).to_radians(),
        (A / w * phi.cos()).to_radians(),
    )
}

impl PlaceGrid {
    /// A `width × height` grid of `cell_size_ft` cells around (`lat`, `lon`), snapped to the
    /// world's lattice (its centre within half a cell of the point). The grid must lie on the
    /// GRIDMET grid, where the synthetic world is defined.
    pub fn around(
        lat: f64,
        lon: f64,
        width: usize,
        height: usize,
        cell_size_ft: f64,
    ) -> Result<Self, PlaceError> {
        let bad = |key: &'static str, value: String, reason: &str| PlaceError::Grid {
            key,
            value,
            reason: reason.to_string(),
        };
        if !(1..=8192).contains(&width) {
            return Err(bad("width", width.to_string(), "must be 1 to 8192 cells"));
        }
        if !(1..=8192).contains(&height) {
            return Err(bad("height", height.to_string(), "must be 1 to 8192 cells"));
        }
        if !(cell_size_ft.is_finite() && (10.0..=10_000.0).contains(&cell_size_ft)) {
            return Err(bad(
                "cell_size_ft",
                cell_size_ft.to_string(),
                "must be 10 to 10,000 ft",
            ));
        }
        let (lat_s, lat_n) = (GRID_LAT0 - (GRID_N_LAT - 1) as f64 * GRID_STEP, GRID_LAT0);
        let (lon_w, lon_e) = (GRID_LON0, GRID_LON0 + (GRID_N_LON - 1) as f64 * GRID_STEP);
        if !(lat.is_finite()
            && lon.is_finite()
            && (lat_s..=lat_n).contains(&lat)
            && (lon_w..=lon_e).contains(&lon))
        {
            return Err(bad(
                "center",
                format!("[{lat}, {lon}]"),
                &format!(
                    "the synthetic world covers the GRIDMET grid, lat {lat_s:.4} to {lat_n:.4}, lon {lon_w:.4} to {lon_e:.4}"
                ),
            ));
        }
        let row_lat = GRID_LAT0 - ((GRID_LAT0 - lat) / GRID_STEP).round() * GRID_STEP;
        let (m_lat, m_lon) = metres_per_degree(row_lat);
        let cell_m = cell_size_ft * FT_TO_M;
        let (dy, dx) = (cell_m / m_lat, cell_m / m_lon);
        let west = (lon / dx - width as f64 / 2.0).round();
        let south = (lat / dy - height as f64 / 2.0).round();
        let grid = Self {
            width,
            height,
            cell_size_ft,
            west_lon: west * dx,
            south_lat: south * dy,
            cell_lon_deg: dx,
            cell_lat_deg: dy,
        };
        let (n, e) = (
            grid.south_lat + height as f64 * dy,
            grid.west_lon + width as f64 * dx,
        );
        if grid.south_lat < lat_s - 0.5 || n > lat_n + 0.5 || grid.west_lon < lon_w - 0.5 || e > lon_e + 0.5 {
            return Err(bad(
                "width, height",
                format!("{width} × {height} cells of {cell_size_ft} ft"),
                "the grid reaches more than half a degree beyond the GRIDMET grid",
            ));
        }
        Ok(grid)
    }

    /// Latitude and longitude of the centre of cell (`x`, `y`), row 0 south.
    pub fn cell_centre(&self, x: usize, y: usize) -> (f64, f64) {
        (
            self.south_lat + (y as f64 + 0.5) * self.cell_lat_deg,
            self.west_lon + (x as f64 + 0.5) * self.cell_lon_deg,
        )
    }
}

/// The world's climate at the grid's centre (what the land cover was drawn from).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaceClimate {
    /// Elevation of the centre cell (m).
    pub elevation_m: f64,
    /// Annual precipitation (mm) and mean temperature (°C) there.
    pub annual_precip_mm: f64,
    pub mean_temp_c: f64,
    /// Peak live-fuel greenness (0–1) and human activity (mean ≈ 1 over land).
    pub peak_greenness: f64,
    pub human_activity: f64,
}

/// The landscape of a place.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaceLandscape {
    pub grid: PlaceGrid,
    /// The synthetic world's seed.
    pub seed: u64,
    /// MODIS IGBP class per cell, row-major, row 0 south.
    pub land_cover: Vec<u16>,
    /// Elevation per cell (ft).
    pub elevation_ft: Vec<f32>,
    pub climate: PlaceClimate,
}

impl PlaceLandscape {
    /// `(class, share of cells)` for every class present, by class.
    pub fn class_shares(&self) -> Vec<(u16, f64)> {
        let mut counts = [0usize; 18];
        for &c in &self.land_cover {
            counts[usize::from(c).min(17)] += 1;
        }
        let n = self.land_cover.len() as f64;
        (0u16..18)
            .filter(|&c| counts[usize::from(c)] > 0)
            .map(|c| (c, counts[usize::from(c)] as f64 / n))
            .collect()
    }
}

/// What the land cover needs from the GRIDMET cells around a point.
#[derive(Debug, Clone, Copy, Default)]
struct Climate {
    elev: f64,
    t_ann: f64,
    p_ann: f64,
    green_peak: f64,
    human: f64,
}

impl From<&Cell> for Climate {
    fn from(c: &Cell) -> Self {
        Self {
            elev: f64::from(c.elev),
            t_ann: f64::from(c.t[0]),
            p_ann: f64::from(c.p_mean) * YEAR_DAYS,
            green_peak: f64::from(c.green[0]) + f64::from(c.green[1]).hypot(f64::from(c.green[2])),
            human: f64::from(c.human),
        }
    }
}

/// The world's cells over a window of the GRIDMET grid.
struct ClimateWindow {
    j0: usize,
    i0: usize,
    n_lon: usize,
    cells: Vec<Climate>,
}

impl ClimateWindow {
    /// The cells whose centres surround every point of `grid` (clamped to the GRIDMET grid).
    fn new(seed: u64, grid: &PlaceGrid) -> Self {
        let north = grid.south_lat + grid.height as f64 * grid.cell_lat_deg;
        let east = grid.west_lon + grid.width as f64 * grid.cell_lon_deg;
        let row = |lat: f64| ((GRID_LAT0 - lat) / GRID_STEP).clamp(0.0, (GRID_N_LAT - 1) as f64);
        let col = |lon: f64| ((lon - GRID_LON0) / GRID_STEP).clamp(0.0, (GRID_N_LON - 1) as f64);
        let (j0, j1) = (row(north).floor() as usize, row(grid.south_lat).ceil() as usize);
        let (i0, i1) = (col(grid.west_lon).floor() as usize, col(east).ceil() as usize);
        let settlements = Settlements::new(seed);
        let n_lon = i1 - i0 + 1;
        let cells = (j0..=j1)
            .flat_map(|j| (i0..=i1).map(move |i| (j, i)))
            .collect::<Vec<_>>()
            .par_iter()
            .map(|&(j, i)| Climate::from(&cell_info(seed, &settlements, j, i, 0)))
            .collect();
        Self { j0, i0, n_lon, cells }
    }

    /// Bilinear interpolation between the four cell centres around grid position (`y`, `x`).
    fn at(&self, y: f64, x: f64) -> Climate {
        let rows = self.cells.len() / self.n_lon;
        let split = |v: f64, start: usize, n: usize| {
            let v = (v - start as f64).clamp(0.0, (n - 1) as f64);
            let k = (v.floor() as usize).min(n.saturating_sub(2));
            (k, (v - k as f64).clamp(0.0, 1.0))
        };
        let (r, ty) = split(y, self.j0, rows);
        let (c, tx) = split(x, self.i0, self.n_lon);
        let get = |r: usize, c: usize| self.cells[r.min(rows - 1) * self.n_lon + c.min(self.n_lon - 1)];
        let (a, b, cc, d) = (get(r, c), get(r, c + 1), get(r + 1, c), get(r + 1, c + 1));
        let mix = |f: fn(&Climate) -> f64| {
            let top = f(&a) * (1.0 - tx) + f(&b) * tx;
            let bottom = f(&cc) * (1.0 - tx) + f(&d) * tx;
            top * (1.0 - ty) + bottom * ty
        };
        Climate {
            elev: mix(|c| c.elev),
            t_ann: mix(|c| c.t_ann),
            p_ann: mix(|c| c.p_ann),
            green_peak: mix(|c| c.green_peak),
            human: mix(|c| c.human),
        }
    }
}

/// Fractional GRIDMET grid position (row, column) of a point.
fn grid_position(lat: f64, lon: f64) -> (f64, f64) {
    ((GRID_LAT0 - lat) / GRID_STEP, (lon - GRID_LON0) / GRID_STEP)
}

/// The world's own elevation (m) at any point: macro relief plus the seeded fractal relief,
/// continuous between GRIDMET cell centres and equal to the cell's elevation at a centre
/// (before the sea-level floor).
pub fn world_elevation_m(seed: u64, lat: f64, lon: f64) -> f64 {
    let (y, x) = grid_position(lat, lon);
    let (macro_z, rough) = macro_elevation(lat, lon);
    macro_z + rough * fractal_at(seed, Stream::Elevation, &RELIEF_STEPS, RELIEF_HURST, y, x)
}

/// Elevation (m, before the sea-level floor) and local lowness (unit variance: positive in
/// hollows of the fine relief) at a point.
fn terrain(seed: u64, lat: f64, lon: f64) -> (f64, f64) {
    let (y, x) = grid_position(lat, lon);
    let (macro_z, rough) = macro_elevation(lat, lon);
    let world = macro_z + rough * fractal_at(seed, Stream::Elevation, &RELIEF_STEPS, RELIEF_HURST, y, x);
    let (mut detail, mut local, mut local_w2) = (0.0, 0.0, 0.0);
    for (o, &step) in DETAIL_STEPS.iter().enumerate() {
        let w = (step / DETAIL_STEPS[0]).powf(DETAIL_HURST);
        let v = value_noise_at(seed, Stream::TerrainDetail, o as i64, step, y, x);
        // E|N(0,1)| = 0.798 and sd |N| = 0.603: the ridged octave keeps zero mean, unit variance.
        let v = if o < RIDGED_BELOW {
            (0.798 - v.abs()) / 0.603
        } else {
            v
        };
        let n = w * v;
        detail += n;
        if LOCAL_OCTAVES.contains(&o) {
            local += n;
            local_w2 += w * w;
        }
    }
    (world + rough * DETAIL_AMP * detail, -local / local_w2.sqrt())
}

/// Unit-variance noise of `stream` at a point from octaves `(spacing in GRIDMET cells,
/// weight)`, offset by `octave0` so several fields can share a stream.
fn patch(seed: u64, stream: Stream, octave0: i64, octaves: &[(f64, f64)], lat: f64, lon: f64) -> f64 {
    let (y, x) = grid_position(lat, lon);
    let (mut s, mut w2) = (0.0, 0.0);
    for (o, &(step, w)) in octaves.iter().enumerate() {
        s += w * value_noise_at(seed, stream, octave0 + o as i64, step, y, x);
        w2 += w * w;
    }
    s / w2.sqrt()
}

/// The land cover of one point from its terrain and climate.
fn cover(seed: u64, lat: f64, lon: f64, z: f64, lowness: f64, c: &Climate) -> u16 {
    use igbp::*;
    if !is_land(lat, lon) || z <= 0.0 {
        return WATER;
    }
    let t = c.t_ann - 0.0045 * (z - c.elev);
    let p = (c.p_ann + OROGRAPHIC_MM_PER_M * (z - c.elev)).max(40.0);
    let pet = 350.0 + 45.0 * t.max(0.0);
    let wetness = p / pet;
    // Lakes in the lowest hollows, fewer where the climate is dry.
    let lake = 2.3 + 0.8 * (1.0 - wetness).clamp(0.0, 1.0);
    if lowness > lake {
        return WATER;
    }
    if lowness > lake - 0.35 && wetness > 0.7 {
        return WETLAND;
    }
    if t < -5.0 {
        return SNOW_ICE;
    }
    if t < -2.0 {
        return BARREN;
    }
    // Settlements in valley bottoms where the world's people are.
    let town = patch(seed, Stream::Settlement, 0, &[(0.3, 1.0), (0.1, 0.5)], lat, lon) + 0.4 * lowness;
    if town > 2.5 - 0.5 * c.human.max(0.01).ln() {
        return URBAN;
    }
    let patchy = patch(
        seed,
        Stream::CoverPatch,
        0,
        &[(0.4, 1.0), (0.12, 0.6), (0.04, 0.3)],
        lat,
        lon,
    );
    let mix = patch(
        seed,
        Stream::CoverPatch,
        10,
        &[(0.25, 1.0), (0.08, 0.5)],
        lat,
        lon,
    );
    if t < 0.5 {
        // Above the tree line.
        return GRASSLAND;
    }
    let score = wetness.ln() + (c.green_peak - 0.6) + 0.25 * patchy + 0.15 * lowness;
    let front = rockies_front(lat);
    let west = lon < front;
    if score > -0.15 {
        return if west {
            if (3.0..9.0).contains(&t) && mix > 0.6 {
                DECIDUOUS_BROADLEAF
            } else {
                EVERGREEN_NEEDLELEAF
            }
        } else if t < 6.0 {
            if mix > 0.3 {
                EVERGREEN_NEEDLELEAF
            } else {
                MIXED_FOREST
            }
        } else if t < 16.0 {
            if mix > 0.7 {
                MIXED_FOREST
            } else {
                DECIDUOUS_BROADLEAF
            }
        } else if mix > 0.5 {
            MIXED_FOREST
        } else {
            EVERGREEN_NEEDLELEAF
        };
    }
    if score > -0.6 {
        return WOODY_SAVANNA;
    }
    if score > -1.0 {
        return if west { CLOSED_SHRUBLAND } else { SAVANNA };
    }
    if score > -1.7 {
        return if !west || mix > 0.4 {
            GRASSLAND
        } else {
            OPEN_SHRUBLAND
        };
    }
    if score > -2.5 || mix > 0.8 {
        return OPEN_SHRUBLAND;
    }
    BARREN
}

/// The landscape of the synthetic world `seed` on `grid`.
pub fn place_landscape(seed: u64, grid: PlaceGrid) -> PlaceLandscape {
    let window = ClimateWindow::new(seed, &grid);
    let rows: Vec<Vec<(u16, f32)>> = (0..grid.height)
        .into_par_iter()
        .map(|y| {
            (0..grid.width)
                .map(|x| {
                    let (lat, lon) = grid.cell_centre(x, y);
                    let (z, lowness) = terrain(seed, lat, lon);
                    let (gy, gx) = grid_position(lat, lon);
                    let class = cover(seed, lat, lon, z, lowness, &window.at(gy, gx));
                    (class, (z.max(0.0) / FT_TO_M) as f32)
                })
                .collect()
        })
        .collect();
    let (land_cover, elevation_ft) = rows.into_iter().flatten().unzip();
    let (lat, lon) = grid.cell_centre(grid.width / 2, grid.height / 2);
    let (gy, gx) = grid_position(lat, lon);
    let c = window.at(gy, gx);
    let (z, _) = terrain(seed, lat, lon);
    PlaceLandscape {
        grid,
        seed,
        land_cover,
        elevation_ft,
        climate: PlaceClimate {
            elevation_m: z.max(0.0),
            annual_precip_mm: (c.p_ann + OROGRAPHIC_MM_PER_M * (z - c.elev)).max(40.0),
            mean_temp_c: c.t_ann - 0.0045 * (z - c.elev),
            peak_greenness: c.green_peak,
            human_activity: c.human,
        },
    }
}

/// The synthetic world's seed, from the global attribute `firecast_seed` of the GRIDMET files
/// in `dir` (those of `year` when given, else all): every file must carry it and agree.
pub fn world_seed(dir: &std::path::Path, year: Option<i32>) -> Result<u64, PlaceError> {
    let suffix = year.map(|y| format!("_{y}.nc"));
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| PlaceError::Read {
            path: dir.to_path_buf(),
            message: e.to_string(),
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or_default();
            match &suffix {
                Some(s) => name.ends_with(s.as_str()),
                None => name.ends_with(".nc"),
            }
        })
        .collect();
    files.sort();
    let mut first: Option<(std::path::PathBuf, u64)> = None;
    for path in files {
        let read = |message: String| PlaceError::Read {
            path: path.clone(),
            message,
        };
        let nc = netcdf_reader::NcFile::open(&path).map_err(|e| read(e.to_string()))?;
        let Ok(attr) = nc.global_attribute("firecast_seed") else {
            return Err(PlaceError::NotSynthetic { path });
        };
        let text = attr.value.as_string().unwrap_or_default();
        let seed: u64 = text.trim().parse().map_err(|_| PlaceError::BadSeed {
            path: path.clone(),
            value: text.clone(),
        })?;
        match &first {
            None => first = Some((path, seed)),
            Some((p, s)) if *s != seed => {
                return Err(PlaceError::MixedSeeds {
                    first: p.clone(),
                    a: *s,
                    other: path,
                    b: seed,
                });
            }
            Some(_) => {}
        }
    }
    first.map(|(_, s)| s).ok_or_else(|| PlaceError::NoFiles {
        dir: dir.to_path_buf(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{grid_lat, grid_lon};

    fn land(lat: f64, lon: f64, w: usize, h: usize) -> PlaceLandscape {
        place_landscape(5, PlaceGrid::around(lat, lon, w, h, 500.0).expect("grid"))
    }

    #[test]
    fn the_world_elevation_is_the_gridmet_cells_at_their_centres() {
        let settlements = Settlements::new(5);
        for (j, i) in [(100, 300), (240, 410), (333, 1000), (500, 700)] {
            let cell = cell_info(5, &settlements, j, i, 0);
            let z = world_elevation_m(5, grid_lat(j), grid_lon(i));
            assert!(
                (z.max(0.0) - f64::from(cell.elev)).abs() < 0.01,
                "({j}, {i}): {z} vs {}",
                cell.elev
            );
        }
    }

    #[test]
    fn the_same_place_gives_the_same_map_bit_for_bit() {
        let a = land(39.3, -107.4, 60, 40);
        let b = land(39.3, -107.4, 60, 40);
        assert_eq!(a, b);
        let other = place_landscape(6, a.grid);
        assert_ne!(a.elevation_ft, other.elevation_ft, "another world, the same map");
    }

    #[test]
    fn grids_offset_by_a_few_cells_agree_on_their_overlap() {
        let a = land(39.3, -107.4, 60, 40);
        let g = a.grid;
        // 7 cells east and 5 north: the same lattice, shifted.
        let (lat, lon) = (39.3 + 5.0 * g.cell_lat_deg, -107.4 + 7.0 * g.cell_lon_deg);
        let b = land(lat, lon, 60, 40);
        let dx = ((b.grid.west_lon - g.west_lon) / g.cell_lon_deg).round() as usize;
        let dy = ((b.grid.south_lat - g.south_lat) / g.cell_lat_deg).round() as usize;
        assert_eq!((dx, dy), (7, 5));
        let mut shared = 0;
        for y in dy..g.height {
            for x in dx..g.width {
                let (ia, ib) = (y * g.width + x, (y - dy) * g.width + (x - dx));
                assert_eq!(a.land_cover[ia], b.land_cover[ib], "cell ({x}, {y})");
                assert_eq!(
                    a.elevation_ft[ia].to_bits(),
                    b.elevation_ft[ib].to_bits(),
                    "cell ({x}, {y})"
                );
                shared += 1;
            }
        }
        assert_eq!(shared, 53 * 35);
    }

    #[test]
    fn places_87_miles_apart_differ_in_most_cells() {
        // 87 miles ≈ 1.26° of latitude.
        let a = land(39.3, -107.4, 120, 80);
        let b = land(39.3 - 1.26, -107.4, 120, 80);
        let n = a.land_cover.len();
        let cover = a
            .land_cover
            .iter()
            .zip(&b.land_cover)
            .filter(|(x, y)| x != y)
            .count();
        let elev = a
            .elevation_ft
            .iter()
            .zip(&b.elevation_ft)
            .filter(|(x, y)| (**x - **y).abs() > 50.0)
            .count();
        assert!(cover * 2 > n, "only {cover} of {n} cells differ in cover");
        assert!(
            elev * 10 > n * 9,
            "only {elev} of {n} cells differ by 50 ft in elevation"
        );
    }

    #[test]
    fn the_relief_has_hills_at_the_cell_scale() {
        let a = land(39.3, -107.4, 120, 80);
        let g = a.grid;
        let (lo, hi) = a
            .elevation_ft
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), &z| {
                (l.min(z), h.max(z))
            });
        // Mountain country: hundreds of feet of relief over ~11 by 8 miles, and steps
        // between neighbouring cells (not a plane interpolated from 4 km cells).
        assert!(hi - lo > 1000.0, "relief {lo}..{hi} ft");
        let steps = (0..g.height)
            .flat_map(|y| (1..g.width).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                let i = y * g.width + x;
                (a.elevation_ft[i] - a.elevation_ft[i - 1]).abs() > 10.0
            })
            .count();
        assert!(
            steps * 2 > g.height * (g.width - 1),
            "{steps} neighbour steps over 10 ft"
        );
    }

    #[test]
    fn class_proportions_are_sane_across_the_west() {
        use igbp::*;
        let mut waters = 0.0;
        for (lat, lon) in [
            (39.3, -107.4),
            (38.04, -107.4),
            (37.0, -119.8),
            (43.6, -116.0),
            (34.3, -111.5),
            (45.5, -121.8),
        ] {
            let a = land(lat, lon, 160, 120);
            let shares = a.class_shares();
            println!("({lat}, {lon}) {:?} {shares:?}", a.climate);
            let share = |c: u16| shares.iter().find(|s| s.0 == c).map_or(0.0, |s| s.1);
            let burnable: f64 = [1, 4, 5, 6, 7, 8, 9, 10, 11].iter().map(|&c| share(c)).sum();
            assert!(burnable > 0.6, "({lat}, {lon}): burnable share {burnable}");
            assert!(share(WATER) < 0.1, "({lat}, {lon}): water {}", share(WATER));
            assert!(shares.len() >= 3, "({lat}, {lon}): only {shares:?}");
            waters += share(WATER);
        }
        assert!(waters > 0.0, "no water anywhere");
    }

    #[test]
    fn a_grid_off_the_world_or_too_big_is_refused() {
        assert!(PlaceGrid::around(60.0, -107.0, 10, 10, 500.0).is_err());
        assert!(PlaceGrid::around(39.0, -107.0, 0, 10, 500.0).is_err());
        assert!(PlaceGrid::around(39.0, -107.0, 10, 10, f64::NAN).is_err());
        let e = PlaceGrid::around(39.0, -107.0, 10, 10, 1.0).expect_err("1 ft cells");
        assert!(e.to_string().contains("cell_size_ft"), "{e}");
    }
}
