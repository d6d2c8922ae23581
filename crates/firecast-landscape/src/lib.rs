//! Georeferenced landscapes: the terrain a fire burns on.
//!
//! A [`Landscape`] is a regular grid of square cells (row 0 is the **south** edge, as in
//! the Concord/FireCastRL model; +x is east, +y is north) carrying, per cell, a land-cover
//! or fuel-model code and an elevation. Every landscape knows where it is on Earth
//! ([`GeoReference`]), so simulations and reports can speak in latitude/longitude.
//!
//! Readers (GeoTIFF, SRTM `.hgt`, FireCastRL PNG maps) and the procedural generator build
//! landscapes; the simulator consumes them.
//!
//! Modules:
//! - [`georef`]: CRS parsing (EPSG:4326, WGS84 UTM 326xx/327xx), a WGS84 transverse Mercator
//!   written from Karney's (2011) Krüger series, [`georef::GridSpec`] (the simulation grid a
//!   reader resamples onto) and the cell ⇄ lat/lon helpers on [`Landscape`];
//! - [`geotiff`]: single-band GeoTIFF land cover / elevation with georeferencing;
//! - [`landfire`]: LANDFIRE landscapes (fuel models, slope, aspect, elevation, canopy layers)
//!   as LANDFIRE ships them, with nodata and unknown codes counted;
//! - [`lcp`]: FARSITE/FlamMap `.lcp` landscape files, read into the same landscape with their
//!   units converted; [`prj`]: the CRS of a `.prj` sidecar (ESRI/OGC WKT);
//! - [`gridio`]: float32 GeoTIFF grids written with the input's georeference;
//! - [`srtm`]: SRTM `.hgt` tiles;
//! - [`firecastrl`]: FireCastRL palette PNG + 16-bit heightmap PNG (docs/spec/fire-model.md §A2);
//! - [`procedural`]: seeded synthetic landscapes.

use std::path::PathBuf;

pub mod firecastrl;
pub mod georef;
pub mod geotiff;
pub mod gridio;
pub mod landfire;
pub mod lcp;
pub mod prj;
pub mod procedural;
mod resample;
pub mod srtm;

pub use georef::{Crs, GridSpec};

/// What the per-cell codes mean.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LandCoverScheme {
    /// MODIS MCD12Q1 `LC_Type1` (IGBP) classes 1–17, as FireCastRL uses them.
    ModisIgbp,
    /// LANDFIRE FBFM13: Anderson fuel models 1–13, 91–99 non-burnable.
    Fbfm13,
    /// LANDFIRE FBFM40: Scott & Burgan fuel-model numbers (101–204), 91–99 non-burnable.
    Fbfm40,
}

/// Where the grid sits on Earth. Cell (x, y) covers the square whose south-west corner is
/// `origin + (x, y) * cell_size` in the projected coordinates of `crs`.
#[derive(Debug, Clone, PartialEq)]
pub struct GeoReference {
    /// Coordinate reference system of `origin_x`/`origin_y`, e.g. `EPSG:4326` or `EPSG:32611`.
    pub crs: String,
    /// Projected x (easting, or longitude for EPSG:4326) of the grid's south-west corner.
    pub origin_x: f64,
    /// Projected y (northing, or latitude for EPSG:4326) of the grid's south-west corner.
    pub origin_y: f64,
    /// Cell size along x in CRS units (degrees for EPSG:4326, metres for UTM).
    pub cell_size_x: f64,
    /// Cell size along y in CRS units.
    pub cell_size_y: f64,
}

/// A landscape grid. Cell index = `y * width + x`, row 0 south.
#[derive(Debug, Clone, PartialEq)]
pub struct Landscape {
    pub width: usize,
    pub height: usize,
    /// Side of a square cell on the ground, in feet (the simulator's unit; 500 ft by default).
    pub cell_size_ft: f64,
    pub scheme: LandCoverScheme,
    /// Land-cover or fuel-model code per cell (meaning set by `scheme`).
    pub land_cover: Vec<u16>,
    /// Elevation above sea level per cell, in feet.
    pub elevation_ft: Vec<f32>,
    pub georef: GeoReference,
}

/// Errors of landscape construction and reading. Paths come last.
#[derive(Debug, thiserror::Error)]
pub enum LandscapeError {
    #[error("landscape grid must not be empty ({width} x {height})")]
    Empty { width: usize, height: usize },
    #[error("{layer} has {got} cells, expected {width} x {height} = {expected}")]
    LayerSize {
        layer: &'static str,
        got: usize,
        width: usize,
        height: usize,
        expected: usize,
    },
    #[error("cell size must be positive and finite, got {0} ft")]
    CellSize(f64),
    /// The file could not be opened or read.
    #[error("cannot read file: {source}: {path}")]
    Io { source: std::io::Error, path: PathBuf },
    /// The container (TIFF, PNG, HGT) is malformed or uses an unsupported layout.
    #[error("{format}: {message}: {path}")]
    Format {
        format: &'static str,
        message: String,
        path: PathBuf,
    },
    /// A GeoTIFF tag or GeoKey is missing or holds a value we cannot use.
    /// `tag` names it, e.g. `ModelPixelScaleTag (33550)` or `GeoKey GTRasterTypeGeoKey (1025)`.
    #[error("GeoTIFF {tag}: {problem}: {path}")]
    GeoTag {
        tag: String,
        problem: String,
        path: PathBuf,
    },
    /// The simulation grid and the raster use different coordinate systems and at least one
    /// of them is not one we can transform (EPSG:4326, EPSG:326xx, EPSG:327xx).
    #[error("cannot transform grid CRS {grid} to raster CRS {raster}: {path}")]
    CrsMismatch {
        grid: String,
        raster: String,
        path: PathBuf,
    },
    /// A CRS string we cannot interpret where one is required.
    #[error("unsupported CRS {0:?} (expected EPSG:4326, EPSG:326xx or EPSG:327xx)")]
    UnsupportedCrs(String),
    /// No grid cell centre falls on valid raster data.
    #[error("grid does not overlap any valid {layer} data: {path}")]
    NoOverlap { layer: &'static str, path: PathBuf },
    /// Elevation nodata remained and the policy is [`geotiff::ElevationNoData::Error`].
    #[error("{count} grid cells have no valid elevation (first at cell x={x}, y={y}): {path}")]
    ElevationNoData {
        count: usize,
        x: usize,
        y: usize,
        path: PathBuf,
    },
    /// A generator or reader option is out of range.
    #[error("invalid option {name}: {message}")]
    InvalidOption { name: &'static str, message: String },
}

impl Landscape {
    /// Build a landscape, checking that every layer has one value per cell.
    pub fn new(
        width: usize,
        height: usize,
        cell_size_ft: f64,
        scheme: LandCoverScheme,
        land_cover: Vec<u16>,
        elevation_ft: Vec<f32>,
        georef: GeoReference,
    ) -> Result<Self, LandscapeError> {
        if width == 0 || height == 0 {
            return Err(LandscapeError::Empty { width, height });
        }
        if !(cell_size_ft.is_finite() && cell_size_ft > 0.0) {
            return Err(LandscapeError::CellSize(cell_size_ft));
        }
        let expected = width * height;
        for (layer, got) in [
            ("land_cover", land_cover.len()),
            ("elevation_ft", elevation_ft.len()),
        ] {
            if got != expected {
                return Err(LandscapeError::LayerSize {
                    layer,
                    got,
                    width,
                    height,
                    expected,
                });
            }
        }
        Ok(Self {
            width,
            height,
            cell_size_ft,
            scheme,
            land_cover,
            elevation_ft,
            georef,
        })
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.width * self.height
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Row-major index of cell (x, y).
    pub fn index(&self, x: usize, y: usize) -> usize {
        y * self.width + x
    }
}
