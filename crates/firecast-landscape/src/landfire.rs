//! LANDFIRE landscapes as LANDFIRE ships them: one single-band int16 GeoTIFF per layer
//! (nodata 32767), all on one grid (Albers EPSG:5070 for CONUS, 30 m).
//!
//! Layers and their stored units (LANDFIRE's product descriptions):
//!
//! | layer | file name token | stored | read as |
//! |---|---|---|---|
//! | FBFM40 | `F40`, `FBFM40` | Scott & Burgan number (91–99, 101–204) | code |
//! | FBFM13 | `F13`, `FBFM13` | Anderson number (1–13, 91–99) | code |
//! | slope | `SlpP` (percent) or `SlpD` (degrees) | integer | percent (degrees converted) |
//! | aspect | `Asp` | degrees clockwise from north the slope faces; −1 flat | degrees |
//! | elevation | `Elev` | m | m |
//! | canopy cover | `CC` | % | % |
//! | canopy height | `CH` | m × 10 | m |
//! | canopy base height | `CBH` | m × 10 | m |
//! | canopy bulk density | `CBD` | kg/m³ × 100 | kg/m³ |
//!
//! Nodata is the file's GDAL_NODATA value and, always, 32767 (LANDFIRE's int16 nodata). Every
//! nodata cell is counted per layer. Fuel codes are checked against the scheme: the standard
//! numbers of `docs/spec/fire-model.md §B8.2` (FBFM40: 101–109, 121–124, 141–149, 161–165,
//! 181–189, 201–204; FBFM13: 1–13) and the non-burnable codes 91–99 that the fuel table
//! knows (NB1 91, NB2 92, NB3 93, NB8 98, NB9 99, and behave's reserved 94/95); any other value is
//! an unknown code, counted by value and an error naming the file, the layer and the first cell.
//! Grids that disagree in size, transform or CRS are an error naming both files; a geographic
//! CRS (degrees) is an error; a layer that cannot be decoded names the layer, the file and,
//! where the TIFF's directory is intact, the first strip or tile that fails.
//!
//! A FARSITE/FlamMap `.lcp` ([`crate::lcp`]) is decoded into the same layers, and both
//! formats then go through the same checks ([`LandfireLandscape::read_path`] takes either).
//! [`LandfireLandscape::check_burnable_cells`] is what fire behaviour asks on top: every cell
//! whose fuel burns has slope, aspect and (for crown fire) canopy values.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::geotiff::{GeoRaster, read_geotiff};
use crate::{LandCoverScheme, LandscapeError};

/// LANDFIRE's int16 nodata value.
pub const LANDFIRE_NODATA: i32 = 32767;

/// Which fuel-model layer to read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FuelLayer {
    /// Scott & Burgan (2005) 40 fuel models (FBFM40).
    Fbfm40,
    /// Anderson (1982) 13 fuel models (FBFM13).
    Fbfm13,
}

impl FuelLayer {
    /// The land-cover scheme of the codes.
    pub fn scheme(self) -> LandCoverScheme {
        match self {
            Self::Fbfm40 => LandCoverScheme::Fbfm40,
            Self::Fbfm13 => LandCoverScheme::Fbfm13,
        }
    }

    /// `fbfm40` or `fbfm13`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Fbfm40 => "fbfm40",
            Self::Fbfm13 => "fbfm13",
        }
    }

    /// Parse `fbfm40` / `fbfm13` (case-insensitive; `f40`, `f13` too).
    pub fn parse(text: &str) -> Option<Self> {
        match text.to_ascii_lowercase().as_str() {
            "fbfm40" | "f40" => Some(Self::Fbfm40),
            "fbfm13" | "f13" => Some(Self::Fbfm13),
            _ => None,
        }
    }
}

/// One LANDFIRE layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum LayerKind {
    Fbfm40,
    Fbfm13,
    SlopePercent,
    SlopeDegrees,
    Aspect,
    Elevation,
    CanopyCover,
    CanopyHeight,
    CanopyBaseHeight,
    CanopyBulkDensity,
}

impl LayerKind {
    /// The layer's name in messages and summaries.
    pub fn name(self) -> &'static str {
        match self {
            Self::Fbfm40 => "fbfm40",
            Self::Fbfm13 => "fbfm13",
            Self::SlopePercent => "slope (percent)",
            Self::SlopeDegrees => "slope (degrees)",
            Self::Aspect => "aspect",
            Self::Elevation => "elevation",
            Self::CanopyCover => "canopy cover",
            Self::CanopyHeight => "canopy height",
            Self::CanopyBaseHeight => "canopy base height",
            Self::CanopyBulkDensity => "canopy bulk density",
        }
    }

    /// How LANDFIRE stores the layer.
    pub fn landfire_unit(self) -> &'static str {
        match self {
            Self::Fbfm40 | Self::Fbfm13 => "fuel model number",
            Self::SlopePercent => "percent",
            Self::SlopeDegrees => "degrees (converted to percent)",
            Self::Aspect => "azimuth degrees, -1 flat",
            Self::Elevation => "m",
            Self::CanopyCover => "percent",
            Self::CanopyHeight | Self::CanopyBaseHeight => "m x 10 (converted to m)",
            Self::CanopyBulkDensity => "kg/m3 x 100 (converted to kg/m3)",
        }
    }

    /// Factor turning a stored value into the unit we keep (m, kg/m³, %, degrees).
    pub(crate) fn scale(self) -> f32 {
        match self {
            Self::CanopyHeight | Self::CanopyBaseHeight => 0.1,
            Self::CanopyBulkDensity => 0.01,
            _ => 1.0,
        }
    }

    /// The layer a file name stands for: the first `_`/`-`/`.`-separated token of the stem
    /// that names one (`LC22_F40_230` → FBFM40, `LC20_SlpP_220` → slope in percent).
    pub fn from_file_name(name: &str) -> Option<Self> {
        let stem = name.strip_suffix(".tif").or_else(|| name.strip_suffix(".tiff"))?;
        stem.split(['_', '-', '.']).find_map(|token| {
            Some(match token.to_ascii_lowercase().as_str() {
                "f40" | "fbfm40" => Self::Fbfm40,
                "f13" | "fbfm13" => Self::Fbfm13,
                "slpp" | "slope" => Self::SlopePercent,
                "slpd" => Self::SlopeDegrees,
                "asp" | "aspect" => Self::Aspect,
                "elev" | "elevation" | "dem" => Self::Elevation,
                "cc" => Self::CanopyCover,
                "ch" => Self::CanopyHeight,
                "cbh" => Self::CanopyBaseHeight,
                "cbd" => Self::CanopyBulkDensity,
                _ => return None,
            })
        })
    }
}

/// Errors reading a LANDFIRE landscape. Each names the file; cell errors name the layer and
/// the cell (column and row from the north-west corner, as GDAL counts them).
#[derive(Debug, thiserror::Error)]
pub enum LandfireError {
    #[error("{0}")]
    Raster(#[from] LandscapeError),
    /// A layer's file could not be read or decoded (a missing, truncated or corrupt GeoTIFF).
    #[error("{layer} layer: {source}")]
    Layer {
        layer: &'static str,
        source: LandscapeError,
    },
    #[error("cannot list landscape folder: {source}: {path}")]
    Io { source: std::io::Error, path: PathBuf },
    #[error("landscape folder has no {layer} layer (a GeoTIFF whose name holds {tokens}): {dir}")]
    MissingLayer {
        layer: &'static str,
        tokens: &'static str,
        dir: PathBuf,
    },
    #[error("two files for the {layer} layer: {first} and {second}")]
    DuplicateLayer {
        layer: &'static str,
        first: PathBuf,
        second: PathBuf,
    },
    #[error(
        "a landscape is a folder of LANDFIRE GeoTIFF layers, a FARSITE/FlamMap .lcp file, or a folder holding one .lcp; {found}: {path}"
    )]
    NotALandscape { found: String, path: PathBuf },
    #[error("{layer} grid {second} disagrees with {first}: {what}")]
    GridMismatch {
        layer: &'static str,
        first: PathBuf,
        second: PathBuf,
        what: String,
    },
    /// The landscape's CRS is geographic (degrees): cells have no size in metres or feet.
    #[error(
        "{layer}: the landscape's CRS {crs} is geographic (latitude/longitude degrees); fire behaviour needs a \
         projected grid in metres or feet (LANDFIRE ships EPSG:5070): {path}"
    )]
    GeographicCrs {
        layer: &'static str,
        crs: String,
        path: PathBuf,
    },
    #[error(
        "{layer}: {count} cells hold fuel codes unknown to {scheme} ({codes}); first at column {col}, row {row}{hint}: {path}"
    )]
    UnknownFuelCode {
        layer: &'static str,
        scheme: &'static str,
        count: usize,
        codes: String,
        col: usize,
        row: usize,
        /// Empty, or `; ` and a note (the other scheme's codes, an LCP's custom fuel models).
        hint: Box<str>,
        path: PathBuf,
    },
    #[error("{layer}: value {value} at column {col}, row {row} is {problem}: {path}")]
    BadValue {
        layer: &'static str,
        value: f32,
        col: usize,
        row: usize,
        problem: &'static str,
        path: PathBuf,
    },
    /// A cell with a burnable fuel model lacks a value fire behaviour needs there.
    #[error(
        "{layer}: {count} cells with a burnable fuel model have no data (first at column {col}, row {row}, fuel \
         model {fuel}); fire behaviour needs a value at every burnable cell: {path}"
    )]
    NodataAtBurnableCell {
        layer: &'static str,
        count: usize,
        col: usize,
        row: usize,
        fuel: u16,
        path: PathBuf,
    },
    /// A FARSITE `.lcp` header field holds a value the format does not allow.
    #[error("LCP header {field} (byte {offset}): {problem}: {path}")]
    LcpHeader {
        field: &'static str,
        offset: usize,
        problem: String,
        path: PathBuf,
    },
    /// The `.lcp` ends before its last cell.
    #[error(
        "LCP is truncated: {bytes} bytes, where a {width} x {height} grid of {bands} int16 bands needs {expected}; \
         the cells from column {col}, row {row} on are missing: {path}"
    )]
    LcpTruncated {
        bytes: u64,
        expected: u64,
        width: usize,
        height: usize,
        bands: usize,
        col: usize,
        row: usize,
        path: PathBuf,
    },
    /// The `.prj` beside an `.lcp` cannot be read or parsed.
    #[error("projection file: {message}: {path}")]
    Prj { message: String, path: PathBuf },
}

/// The files of one landscape, by layer. Fuel, slope and aspect are required for fire
/// behaviour; the others are optional here.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LandfireFiles {
    pub layers: BTreeMap<LayerKind, PathBuf>,
}

impl LandfireFiles {
    /// Find the layers in `dir` and its sub-folders (two levels, as LANDFIRE's download
    /// unpacks: `LF2022_FBFM40_230_CONUS/LC22_F40_230.tif`) by file-name token.
    pub fn discover(dir: &Path) -> Result<Self, LandfireError> {
        let mut files = Vec::new();
        collect_files(dir, 2, &["tif", "tiff"], &mut files)?;
        files.sort();
        let mut layers: BTreeMap<LayerKind, PathBuf> = BTreeMap::new();
        for path in files {
            let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
                continue;
            };
            let Some(kind) = LayerKind::from_file_name(name) else {
                continue;
            };
            if let Some(first) = layers.get(&kind) {
                return Err(LandfireError::DuplicateLayer {
                    layer: kind.name(),
                    first: first.clone(),
                    second: path,
                });
            }
            layers.insert(kind, path);
        }
        if let (Some(first), Some(second)) = (
            layers.get(&LayerKind::SlopePercent),
            layers.get(&LayerKind::SlopeDegrees),
        ) {
            return Err(LandfireError::DuplicateLayer {
                layer: "slope",
                first: first.clone(),
                second: second.clone(),
            });
        }
        Ok(Self { layers })
    }
}

fn collect_files(
    dir: &Path,
    depth: usize,
    extensions: &[&str],
    out: &mut Vec<PathBuf>,
) -> Result<(), LandfireError> {
    let io = |source| LandfireError::Io {
        source,
        path: dir.to_path_buf(),
    };
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let path = entry.map_err(io)?.path();
        if path.is_dir() {
            if depth > 0 {
                collect_files(&path, depth - 1, extensions, out)?;
            }
        } else if path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| extensions.iter().any(|x| e.eq_ignore_ascii_case(x)))
        {
            out.push(path);
        }
    }
    Ok(())
}

/// The grid every layer shares: size, transform (north-up; origin at the north-west corner)
/// and CRS, taken from the fuel layer.
#[derive(Debug, Clone, PartialEq)]
pub struct LandfireGrid {
    pub width: usize,
    pub height: usize,
    pub crs: String,
    pub origin_x: f64,
    pub origin_y: f64,
    pub pixel_dx: f64,
    pub pixel_dy: f64,
    /// The raw GeoKeyDirectory, GeoDoubleParams and GeoAsciiParams of the fuel layer, so
    /// written grids carry the input's georeference unchanged.
    pub geokeys: crate::gridio::GeoKeyTags,
}

/// Per-layer counts for the summary.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerReport {
    pub layer: &'static str,
    pub path: PathBuf,
    pub nodata_cells: usize,
}

/// What the reader found.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LandfireReport {
    /// `LANDFIRE GeoTIFF layers` or `FARSITE .lcp`.
    pub format: &'static str,
    /// How each layer was stored, by layer name, and what it was converted from (e.g.
    /// `ft x 10 (converted to m)`).
    pub stored_units: BTreeMap<&'static str, String>,
    pub layers: Vec<LayerReport>,
    /// Cells whose fuel code is a non-burnable one (91–99), by code.
    pub nonburnable_cells: BTreeMap<u16, usize>,
    /// Cells whose fuel code is burnable, by code.
    pub burnable_cells: BTreeMap<u16, usize>,
    /// Cells where the fuel layer is nodata.
    pub fuel_nodata_cells: usize,
}

/// A LANDFIRE landscape, row 0 north (file order). Missing values are `NaN` in the float
/// layers and `None` in `fuel`. Read from LANDFIRE's GeoTIFF layers ([`Self::read_dir`]) or a
/// FARSITE/FlamMap `.lcp` ([`Self::read_lcp`], units converted as its header says);
/// [`Self::read_path`] takes either.
#[derive(Debug, Clone, PartialEq)]
pub struct LandfireLandscape {
    pub grid: LandfireGrid,
    pub fuel_layer: FuelLayer,
    pub fuel: Vec<Option<u16>>,
    /// Slope in percent (100·tan θ); a degrees layer is converted.
    pub slope_percent: Vec<f32>,
    /// Aspect, degrees clockwise from north the slope faces; −1 (flat) is kept.
    pub aspect_deg: Vec<f32>,
    pub elevation_m: Option<Vec<f32>>,
    pub canopy_cover_pct: Option<Vec<f32>>,
    pub canopy_height_m: Option<Vec<f32>>,
    pub canopy_base_height_m: Option<Vec<f32>>,
    pub canopy_bulk_density_kg_m3: Option<Vec<f32>>,
    pub report: LandfireReport,
    /// The file of each layer read (the `.lcp` for every layer of one).
    pub files: BTreeMap<LayerKind, PathBuf>,
}

/// One layer as a reader decoded it, before the shared checks: values in FireCast's unit
/// (slope still in the layer's own, percent or degrees; fuel codes as read), `NaN` where
/// nodata.
#[derive(Debug, Clone)]
pub(crate) struct DecodedLayer {
    pub kind: LayerKind,
    pub path: PathBuf,
    pub values: Vec<f32>,
}

impl DecodedLayer {
    fn nodata_cells(&self) -> usize {
        self.values.iter().filter(|v| v.is_nan()).count()
    }
}

/// Every layer of a landscape as decoded, whatever the format; [`Self::finish`] applies the
/// checks both formats share.
#[derive(Debug, Clone)]
pub(crate) struct DecodedLandscape {
    pub grid: LandfireGrid,
    pub fuel_layer: FuelLayer,
    pub format: &'static str,
    pub stored_units: BTreeMap<&'static str, String>,
    pub fuel: DecodedLayer,
    /// [`LayerKind::SlopePercent`] or [`LayerKind::SlopeDegrees`].
    pub slope: DecodedLayer,
    pub aspect: DecodedLayer,
    /// Elevation, canopy cover, height, base height, bulk density: those present.
    pub optional: Vec<DecodedLayer>,
    /// A note for unknown fuel codes (e.g. an LCP's declared custom fuel models).
    pub fuel_note: Option<String>,
}

impl DecodedLandscape {
    /// Classify fuel codes (unknown codes are an error naming the first cell), count nodata,
    /// check value ranges, turn degrees of slope into percent.
    pub(crate) fn finish(self) -> Result<LandfireLandscape, LandfireError> {
        let Self {
            grid,
            fuel_layer,
            format,
            stored_units,
            fuel: fuel_layer_values,
            slope,
            aspect,
            optional,
            fuel_note,
        } = self;
        let width = grid.width;
        let mut report = LandfireReport {
            format,
            stored_units,
            ..LandfireReport::default()
        };
        let mut files = BTreeMap::new();

        // Fuel codes.
        let scheme = fuel_layer.scheme();
        let mut fuel = Vec::with_capacity(fuel_layer_values.values.len());
        let mut unknown: BTreeMap<i64, usize> = BTreeMap::new();
        let mut first_unknown = None;
        let mut nodata = 0;
        for (i, &v) in fuel_layer_values.values.iter().enumerate() {
            if v.is_nan() {
                nodata += 1;
                fuel.push(None);
                continue;
            }
            let code = v as i64;
            let known = v.fract() == 0.0 && (0..=i64::from(u16::MAX)).contains(&code) && {
                let c = code as u16;
                crate::geotiff::is_valid_class(scheme, c) && fuel_known(c)
            };
            if !known {
                *unknown.entry(code).or_default() += 1;
                first_unknown.get_or_insert(i);
                fuel.push(None);
                continue;
            }
            let c = code as u16;
            if (91..=99).contains(&c) {
                *report.nonburnable_cells.entry(c).or_default() += 1;
            } else {
                *report.burnable_cells.entry(c).or_default() += 1;
            }
            fuel.push(Some(c));
        }
        report.fuel_nodata_cells = nodata;
        report.layers.push(LayerReport {
            layer: fuel_layer_values.kind.name(),
            path: fuel_layer_values.path.clone(),
            nodata_cells: nodata,
        });
        if let Some(i) = first_unknown {
            let count = unknown.values().sum();
            let codes = unknown
                .iter()
                .map(|(c, n)| format!("{c}: {n} cells"))
                .collect::<Vec<_>>()
                .join(", ");
            let other = match fuel_layer {
                FuelLayer::Fbfm40 => FuelLayer::Fbfm13,
                FuelLayer::Fbfm13 => FuelLayer::Fbfm40,
            };
            let other_known = unknown.keys().all(|c| {
                u16::try_from(*c)
                    .is_ok_and(|c| crate::geotiff::is_valid_class(other.scheme(), c) && fuel_known(c))
            });
            let mut notes = Vec::new();
            if other_known {
                notes.push(format!(
                    "every one of them is an {} code: read the fuel as {}",
                    other.name(),
                    other.name()
                ));
            }
            notes.extend(fuel_note);
            let hint: Box<str> = if notes.is_empty() {
                "".into()
            } else {
                format!("; {}", notes.join("; ")).into()
            };
            return Err(LandfireError::UnknownFuelCode {
                layer: fuel_layer_values.kind.name(),
                scheme: fuel_layer.name(),
                count,
                codes,
                col: i % width,
                row: i / width,
                hint,
                path: fuel_layer_values.path,
            });
        }
        files.insert(fuel_layer_values.kind, fuel_layer_values.path.clone());

        for layer in std::iter::once(&slope).chain([&aspect]).chain(&optional) {
            report.layers.push(LayerReport {
                layer: layer.kind.name(),
                path: layer.path.clone(),
                nodata_cells: layer.nodata_cells(),
            });
            files.insert(layer.kind, layer.path.clone());
        }

        // Range checks: the values that would make the kernel meaningless.
        let bad = |layer: &DecodedLayer, i: usize, problem| LandfireError::BadValue {
            layer: layer.kind.name(),
            value: layer.values[i],
            col: i % width,
            row: i / width,
            problem,
            path: layer.path.clone(),
        };
        let slope_kind = slope.kind;
        let mut slope_percent = slope.values.clone();
        if slope_kind == LayerKind::SlopeDegrees {
            for (i, s) in slope_percent.iter_mut().enumerate() {
                if s.is_nan() {
                    continue;
                }
                if !(0.0..90.0).contains(s) {
                    return Err(bad(&slope, i, "not a slope in [0, 90) degrees"));
                }
                *s = (f64::from(*s).to_radians().tan() * 100.0) as f32;
            }
        } else if let Some(i) = slope_percent.iter().position(|s| *s < 0.0) {
            return Err(bad(&slope, i, "a negative slope"));
        }
        if let Some(i) = aspect
            .values
            .iter()
            .position(|a| !a.is_nan() && *a != -1.0 && !(0.0..=360.0).contains(a))
        {
            return Err(bad(&aspect, i, "not an aspect in [0, 360] degrees or -1 (flat)"));
        }
        for layer in &optional {
            if matches!(
                layer.kind,
                LayerKind::CanopyCover
                    | LayerKind::CanopyHeight
                    | LayerKind::CanopyBaseHeight
                    | LayerKind::CanopyBulkDensity
            ) && let Some(i) = layer
                .values
                .iter()
                .position(|v| *v < 0.0 || (layer.kind == LayerKind::CanopyCover && *v > 100.0))
            {
                return Err(bad(layer, i, "out of range"));
            }
        }

        let pick = |kind: LayerKind| optional.iter().find(|l| l.kind == kind).map(|l| l.values.clone());
        Ok(LandfireLandscape {
            grid,
            fuel_layer,
            fuel,
            slope_percent,
            aspect_deg: aspect.values,
            elevation_m: pick(LayerKind::Elevation),
            canopy_cover_pct: pick(LayerKind::CanopyCover),
            canopy_height_m: pick(LayerKind::CanopyHeight),
            canopy_base_height_m: pick(LayerKind::CanopyBaseHeight),
            canopy_bulk_density_kg_m3: pick(LayerKind::CanopyBulkDensity),
            report,
            files,
        })
    }
}

impl LandfireLandscape {
    /// Read a landscape from `path`: a folder of LANDFIRE GeoTIFF layers ([`Self::read_dir`]),
    /// a FARSITE/FlamMap `.lcp` file ([`Self::read_lcp`]), or a folder holding one `.lcp` (and
    /// its `.prj`) and no layer GeoTIFFs.
    pub fn read_path(path: &Path, fuel: FuelLayer) -> Result<Self, LandfireError> {
        if path.is_dir() {
            let files = LandfireFiles::discover(path)?;
            let mut lcps = Vec::new();
            collect_files(path, 2, &["lcp"], &mut lcps)?;
            lcps.sort();
            return match (files.layers.is_empty(), lcps.as_slice()) {
                (true, [one]) => Self::read_lcp(one, fuel),
                (true, [_, _, ..]) => Err(LandfireError::NotALandscape {
                    found: format!(
                        "this folder holds {} .lcp files ({}); name the one to read",
                        lcps.len(),
                        lcps.iter()
                            .map(|p| p.display().to_string())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                    path: path.to_path_buf(),
                }),
                (false, [first, ..]) => Err(LandfireError::NotALandscape {
                    found: format!(
                        "this folder holds both LANDFIRE layer GeoTIFFs and {}; name the .lcp, or keep them apart",
                        first.display()
                    ),
                    path: path.to_path_buf(),
                }),
                _ => Self::read(&files, fuel, path),
            };
        }
        let is_lcp = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("lcp"));
        if is_lcp {
            Self::read_lcp(path, fuel)
        } else if !path.exists() {
            // Names the missing folder as reading it does.
            Self::read_dir(path, fuel)
        } else {
            Err(LandfireError::NotALandscape {
                found: "this is a single file, not an .lcp".to_string(),
                path: path.to_path_buf(),
            })
        }
    }

    /// Read the landscape in `dir` (see [`LandfireFiles::discover`]) with the given fuel layer.
    pub fn read_dir(dir: &Path, fuel: FuelLayer) -> Result<Self, LandfireError> {
        let files = LandfireFiles::discover(dir)?;
        Self::read(&files, fuel, dir)
    }

    /// Read a FARSITE/FlamMap `.lcp` (see [`crate::lcp`]) with the given fuel layer.
    pub fn read_lcp(path: &Path, fuel: FuelLayer) -> Result<Self, LandfireError> {
        crate::lcp::decode(path, fuel)?.finish()
    }

    /// Read the given files. `dir` is only used to name the landscape in errors.
    pub fn read(files: &LandfireFiles, fuel_layer: FuelLayer, dir: &Path) -> Result<Self, LandfireError> {
        let fuel_kind = match fuel_layer {
            FuelLayer::Fbfm40 => LayerKind::Fbfm40,
            FuelLayer::Fbfm13 => LayerKind::Fbfm13,
        };
        let require = |kind: LayerKind, tokens: &'static str| {
            files
                .layers
                .get(&kind)
                .ok_or_else(|| LandfireError::MissingLayer {
                    layer: kind.name(),
                    tokens,
                    dir: dir.to_path_buf(),
                })
        };
        let fuel_path = require(
            fuel_kind,
            match fuel_layer {
                FuelLayer::Fbfm40 => "F40 or FBFM40",
                FuelLayer::Fbfm13 => "F13 or FBFM13",
            },
        )?;
        let (slope_kind, slope_path) = match (
            files.layers.get(&LayerKind::SlopePercent),
            files.layers.get(&LayerKind::SlopeDegrees),
        ) {
            (Some(p), _) => (LayerKind::SlopePercent, p),
            (None, Some(p)) => (LayerKind::SlopeDegrees, p),
            (None, None) => {
                return Err(LandfireError::MissingLayer {
                    layer: "slope",
                    tokens: "SlpP, SlpD or slope",
                    dir: dir.to_path_buf(),
                });
            }
        };
        let aspect_path = require(LayerKind::Aspect, "Asp or aspect")?;

        let layer_err = |kind: LayerKind| {
            move |source| LandfireError::Layer {
                layer: kind.name(),
                source,
            }
        };
        let fuel_raster = read_geotiff(fuel_path).map_err(layer_err(fuel_kind))?;
        if is_geographic(&fuel_raster) {
            return Err(LandfireError::GeographicCrs {
                layer: fuel_kind.name(),
                crs: fuel_raster.crs.clone(),
                path: fuel_path.clone(),
            });
        }
        let grid = LandfireGrid {
            width: fuel_raster.width,
            height: fuel_raster.height,
            crs: fuel_raster.crs.clone(),
            origin_x: fuel_raster.origin_x,
            origin_y: fuel_raster.origin_y,
            pixel_dx: fuel_raster.pixel_dx,
            pixel_dy: fuel_raster.pixel_dy,
            geokeys: crate::gridio::GeoKeyTags::read(fuel_path).map_err(layer_err(fuel_kind))?,
        };
        let decode = |kind: LayerKind, raster: &GeoRaster, path: &Path| DecodedLayer {
            kind,
            path: path.to_path_buf(),
            values: raster
                .data
                .iter()
                .map(|&v| {
                    if is_nodata(raster, v) {
                        f32::NAN
                    } else {
                        v * kind.scale()
                    }
                })
                .collect(),
        };
        let fuel = decode(fuel_kind, &fuel_raster, fuel_path);
        let read_layer = |kind: LayerKind, path: &Path| -> Result<DecodedLayer, LandfireError> {
            let raster = read_geotiff(path).map_err(layer_err(kind))?;
            check_same_grid(kind, fuel_path, &fuel_raster, path, &raster)?;
            Ok(decode(kind, &raster, path))
        };
        let slope = read_layer(slope_kind, slope_path)?;
        let aspect = read_layer(LayerKind::Aspect, aspect_path)?;
        let mut optional = Vec::new();
        for kind in [
            LayerKind::Elevation,
            LayerKind::CanopyCover,
            LayerKind::CanopyHeight,
            LayerKind::CanopyBaseHeight,
            LayerKind::CanopyBulkDensity,
        ] {
            if let Some(path) = files.layers.get(&kind) {
                optional.push(read_layer(kind, path)?);
            }
        }
        let mut stored_units = BTreeMap::new();
        stored_units.insert(fuel_kind.name(), "fuel model number".to_string());
        for layer in std::iter::once(&slope).chain([&aspect]).chain(&optional) {
            stored_units.insert(layer.kind.name(), layer.kind.landfire_unit().to_string());
        }
        DecodedLandscape {
            grid,
            fuel_layer,
            format: "LANDFIRE GeoTIFF layers",
            stored_units,
            fuel,
            slope,
            aspect,
            optional,
            fuel_note: None,
        }
        .finish()
    }

    /// Check that every cell with a burnable fuel model has the values fire behaviour needs
    /// there: slope and aspect, and (`canopy`) every canopy layer the landscape has. A cell
    /// lacking one is an error naming the layer's file, the count and the first cell.
    pub fn check_burnable_cells(&self, canopy: bool) -> Result<(), LandfireError> {
        let mut layers: Vec<(LayerKind, &[f32])> = Vec::new();
        let slope_kind = if self.files.contains_key(&LayerKind::SlopePercent) {
            LayerKind::SlopePercent
        } else {
            LayerKind::SlopeDegrees
        };
        layers.push((slope_kind, &self.slope_percent));
        layers.push((LayerKind::Aspect, &self.aspect_deg));
        if canopy {
            for (kind, values) in [
                (LayerKind::CanopyCover, &self.canopy_cover_pct),
                (LayerKind::CanopyHeight, &self.canopy_height_m),
                (LayerKind::CanopyBaseHeight, &self.canopy_base_height_m),
                (LayerKind::CanopyBulkDensity, &self.canopy_bulk_density_kg_m3),
            ] {
                if let Some(v) = values {
                    layers.push((kind, v));
                }
            }
        }
        for (kind, values) in layers {
            let mut first = None;
            let mut count = 0;
            for (i, (code, v)) in self.fuel.iter().zip(values).enumerate() {
                if let Some(code) = code
                    && !(91..=99).contains(code)
                    && v.is_nan()
                {
                    count += 1;
                    first.get_or_insert((i, *code));
                }
            }
            if let Some((i, fuel)) = first {
                return Err(LandfireError::NodataAtBurnableCell {
                    layer: kind.name(),
                    count,
                    col: i % self.grid.width,
                    row: i / self.grid.width,
                    fuel,
                    path: self.files.get(&kind).cloned().unwrap_or_default(),
                });
            }
        }
        Ok(())
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.grid.width * self.grid.height
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The file a layer was read from.
    pub fn file(&self, kind: LayerKind) -> Option<&Path> {
        self.files.get(&kind).map(PathBuf::as_path)
    }
}

/// Whether `code` is one of the fuel models the simulator's table holds (1–13, 91–95, 98,
/// 99, and the Scott & Burgan numbers): kept in sync with `firecast-sim`'s `fuel.rs`.
fn fuel_known(code: u16) -> bool {
    matches!(code, 1..=13 | 91..=95 | 98 | 99 | 101..=109 | 121..=124 | 141..=149 | 161..=165 | 181..=189 | 201..=204)
}

/// Whether a raster's CRS is geographic (GeoKey model type 2, or no model type and only a
/// geographic CRS key).
fn is_geographic(raster: &GeoRaster) -> bool {
    let k = &raster.geokeys;
    match k.model_type {
        Some(m) => m == 2,
        None => k.projected_cs_type.is_none() && k.geographic_type.is_some(),
    }
}

fn is_nodata(raster: &GeoRaster, v: f32) -> bool {
    !raster.is_valid(v) || v == LANDFIRE_NODATA as f32
}

fn check_same_grid(
    kind: LayerKind,
    first_path: &Path,
    first: &GeoRaster,
    path: &Path,
    raster: &GeoRaster,
) -> Result<(), LandfireError> {
    let mismatch = |what: String| LandfireError::GridMismatch {
        layer: kind.name(),
        first: first_path.to_path_buf(),
        second: path.to_path_buf(),
        what,
    };
    if (raster.width, raster.height) != (first.width, first.height) {
        return Err(mismatch(format!(
            "size {} x {} against {} x {}",
            raster.width, raster.height, first.width, first.height
        )));
    }
    if raster.crs != first.crs {
        return Err(mismatch(format!("CRS {} against {}", raster.crs, first.crs)));
    }
    let tol = 1e-6 * first.pixel_dx.abs();
    let same = |a: f64, b: f64| (a - b).abs() <= tol;
    if !(same(raster.origin_x, first.origin_x)
        && same(raster.origin_y, first.origin_y)
        && same(raster.pixel_dx, first.pixel_dx)
        && same(raster.pixel_dy, first.pixel_dy))
    {
        return Err(mismatch(format!(
            "transform (origin {}, {}; pixel {} x {}) against (origin {}, {}; pixel {} x {})",
            raster.origin_x,
            raster.origin_y,
            raster.pixel_dx,
            raster.pixel_dy,
            first.origin_x,
            first.origin_y,
            first.pixel_dx,
            first.pixel_dy
        )));
    }
    Ok(())
}
