//! Single-band GeoTIFF rasters (MODIS IGBP land cover, LANDFIRE FBFM13/FBFM40 fuel models,
//! DEMs) with their georeferencing, and resampling onto a simulation [`GridSpec`].
//!
//! Georeferencing comes from ModelPixelScaleTag (33550) + ModelTiepointTag (33922), or from a
//! non-rotated ModelTransformationTag (34264); the CRS from the GeoKeyDirectoryTag (34735):
//! GTModelTypeGeoKey (1024), GTRasterTypeGeoKey (1025), GeographicTypeGeoKey (2048),
//! ProjectedCSTypeGeoKey (3072), and VerticalUnitsGeoKey (4099) if present. Nodata is the
//! GDAL_NODATA ASCII tag (42113); NaN samples are always nodata.
//!
//! Samples u8/u16/i16/f32 (also i8/u32/i32/f64, converted) in strips or tiles, any compression
//! the `tiff` crate decodes (none, LZW, Deflate, PackBits, …). Palette-colour TIFFs are rejected
//! with a hint (the `tiff` crate refuses them); rewrite with
//! `gdal_translate -co PHOTOMETRIC=MINISBLACK`.
//!
//! Resampling: each grid cell centre is taken to the raster CRS (identity when the CRS strings
//! are equal, else via lat/lon when both are EPSG:4326 / WGS84 UTM), then
//! - **classes**: nearest raster pixel; nodata, out-of-extent and codes invalid for the
//!   scheme become [`LandCoverOptions::fill_class`];
//! - **elevation**: bilinear between the four surrounding pixel centres (clamped at the
//!   raster edge); nodata neighbours are dropped and the remaining weights renormalised.
//!   Cells still without data are handled by [`ElevationNoData`]: `NearestValid` (default)
//!   copies the value of the nearest valid *grid cell* (8-connected breadth-first fill),
//!   `Error` fails with the count and the first such cell. A grid that misses every valid
//!   sample is always an error (`NoOverlap`).
//!
//! Elevation values are converted to feet from [`ElevationOptions::units`], else from the
//! VerticalUnitsGeoKey (9001 metre, 9002 foot, 9003 US survey foot), else metres.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::Tag;

use crate::georef::GridSpec;
use crate::{LandCoverScheme, Landscape, LandscapeError, resample};

/// How raster coordinates refer to pixels (GTRasterTypeGeoKey).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RasterType {
    /// 1: a tie point names the outer corner of a pixel (GeoTIFF default).
    PixelIsArea,
    /// 2: a tie point names the pixel centre; we shift the origin by half a pixel, as GDAL does.
    PixelIsPoint,
}

/// The stored sample type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleType {
    U8,
    U16,
    I16,
    F32,
    I8,
    U32,
    I32,
    F64,
}

/// A vertical (or linear) unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LengthUnit {
    Metre,
    Foot,
    UsSurveyFoot,
}

impl LengthUnit {
    /// EPSG unit code → unit (9001, 9002, 9003).
    pub fn from_epsg(code: u16) -> Option<Self> {
        match code {
            9001 => Some(Self::Metre),
            9002 => Some(Self::Foot),
            9003 => Some(Self::UsSurveyFoot),
            _ => None,
        }
    }

    /// Multiply a value in this unit by this to get feet.
    pub fn to_feet(self) -> f64 {
        match self {
            Self::Metre => 1.0 / 0.3048,
            Self::Foot => 1.0,
            Self::UsSurveyFoot => 1200.0 / 3937.0 / 0.3048,
        }
    }
}

/// The GeoKeys we read (raw values; `None` when absent).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GeoKeys {
    /// 1024: 1 projected, 2 geographic, 3 geocentric.
    pub model_type: Option<u16>,
    /// 1025: 1 PixelIsArea, 2 PixelIsPoint.
    pub raster_type: Option<u16>,
    /// 1026.
    pub citation: Option<String>,
    /// 2048, e.g. 4326.
    pub geographic_type: Option<u16>,
    /// 3072, e.g. 32611.
    pub projected_cs_type: Option<u16>,
    /// 3076.
    pub proj_linear_units: Option<u16>,
    /// 4096.
    pub vertical_cs_type: Option<u16>,
    /// 4099.
    pub vertical_units: Option<u16>,
}

/// A decoded single-band raster. `data` is in file order: row 0 is the **north** (top) row.
/// Pixel (col, row) covers `[origin_x + col·dx, origin_x + (col+1)·dx] ×
/// [origin_y + row·dy, origin_y + (row+1)·dy]` in CRS units (`dy < 0` for north-up).
#[derive(Debug, Clone, PartialEq)]
pub struct GeoRaster {
    pub path: PathBuf,
    pub width: usize,
    pub height: usize,
    pub sample_type: SampleType,
    pub data: Vec<f32>,
    pub nodata: Option<f64>,
    /// `EPSG:nnnn`, or `USER-DEFINED:<citation>` for user-defined projections.
    pub crs: String,
    pub raster_type: RasterType,
    /// CRS x of the outer corner of pixel (0, 0).
    pub origin_x: f64,
    /// CRS y of the outer corner of pixel (0, 0).
    pub origin_y: f64,
    pub pixel_dx: f64,
    pub pixel_dy: f64,
    pub geokeys: GeoKeys,
}

impl GeoRaster {
    /// Whether `v` is data (not NaN, not the nodata value).
    pub fn is_valid(&self, v: f32) -> bool {
        !v.is_nan() && self.nodata.is_none_or(|nd| v != nd as f32)
    }

    /// The valid value at (col, row), row 0 north.
    pub fn value(&self, col: usize, row: usize) -> Option<f32> {
        if col >= self.width || row >= self.height {
            return None;
        }
        let v = self.data[row * self.width + col];
        self.is_valid(v).then_some(v)
    }

    /// Continuous pixel coordinates (col, row) of a CRS point; pixel centres are at `i + 0.5`.
    pub fn pixel_coords(&self, x: f64, y: f64) -> (f64, f64) {
        (
            (x - self.origin_x) / self.pixel_dx,
            (y - self.origin_y) / self.pixel_dy,
        )
    }

    /// Nearest-pixel value at a CRS point (`None` outside or nodata).
    pub fn sample_nearest(&self, x: f64, y: f64) -> Option<f32> {
        let (u, v) = self.pixel_coords(x, y);
        if !(u >= 0.0 && v >= 0.0 && u < self.width as f64 && v < self.height as f64) {
            return None;
        }
        self.value(u as usize, v as usize)
    }

    /// Bilinear value at a CRS point between pixel centres, clamped at the raster edge;
    /// nodata neighbours are dropped and the weights renormalised. `None` outside the raster
    /// or when all four neighbours are nodata.
    pub fn sample_bilinear(&self, x: f64, y: f64) -> Option<f64> {
        let (u, v) = self.pixel_coords(x, y);
        if !(u >= 0.0 && v >= 0.0 && u <= self.width as f64 && v <= self.height as f64) {
            return None;
        }
        let (fu, fv) = (u - 0.5, v - 0.5);
        let (c0, r0) = (fu.floor(), fv.floor());
        let (tu, tv) = (fu - c0, fv - r0);
        let clamp_c = |c: f64| c.clamp(0.0, (self.width - 1) as f64) as usize;
        let clamp_r = |r: f64| r.clamp(0.0, (self.height - 1) as f64) as usize;
        let (mut sum, mut wsum) = (0.0, 0.0);
        for (dc, wc) in [(0.0, 1.0 - tu), (1.0, tu)] {
            for (dr, wr) in [(0.0, 1.0 - tv), (1.0, tv)] {
                let w = wc * wr;
                if w <= 1e-9 {
                    continue;
                }
                if let Some(val) = self.value(clamp_c(c0 + dc), clamp_r(r0 + dr)) {
                    sum += w * f64::from(val);
                    wsum += w;
                }
            }
        }
        (wsum > 0.0).then(|| sum / wsum)
    }

    /// (west, south, east, north) in CRS units.
    pub fn bounds(&self) -> (f64, f64, f64, f64) {
        let x1 = self.origin_x + self.width as f64 * self.pixel_dx;
        let y1 = self.origin_y + self.height as f64 * self.pixel_dy;
        (
            self.origin_x.min(x1),
            self.origin_y.min(y1),
            self.origin_x.max(x1),
            self.origin_y.max(y1),
        )
    }

    /// The vertical unit declared by VerticalUnitsGeoKey, if any.
    pub fn vertical_unit(&self) -> Option<LengthUnit> {
        self.geokeys.vertical_units.and_then(LengthUnit::from_epsg)
    }
}

// Defined beside the resampling that applies it; named here too, where the options are.
pub use crate::resample::ElevationNoData;

/// Elevation resampling options.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ElevationOptions {
    /// Unit of the raster values; `None` = VerticalUnitsGeoKey if present, else metres.
    pub units: Option<LengthUnit>,
    pub nodata: ElevationNoData,
}

/// Land-cover resampling options.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LandCoverOptions {
    pub scheme: LandCoverScheme,
    /// Code for nodata / outside / invalid cells.
    pub fill_class: u16,
    /// Treat codes that are not valid for `scheme` (e.g. MODIS 255, LANDFIRE −9999) as nodata.
    pub invalid_as_nodata: bool,
}

impl LandCoverOptions {
    /// Defaults: fill with a non-burnable code — MODIS 17 (water), FBFM13/FBFM40 99 (NB9 bare).
    pub fn new(scheme: LandCoverScheme) -> Self {
        Self {
            scheme,
            fill_class: default_fill_class(scheme),
            invalid_as_nodata: true,
        }
    }
}

/// The default non-burnable fill code of a scheme.
pub fn default_fill_class(scheme: LandCoverScheme) -> u16 {
    match scheme {
        LandCoverScheme::ModisIgbp => 17,
        LandCoverScheme::Fbfm13 | LandCoverScheme::Fbfm40 => 99,
    }
}

/// Whether `code` is a valid code of `scheme`.
pub fn is_valid_class(scheme: LandCoverScheme, code: u16) -> bool {
    match scheme {
        LandCoverScheme::ModisIgbp => (1..=17).contains(&code),
        LandCoverScheme::Fbfm13 => (1..=13).contains(&code) || (91..=99).contains(&code),
        LandCoverScheme::Fbfm40 => matches!(
            code,
            91..=99 | 101..=109 | 121..=124 | 141..=149 | 161..=165 | 181..=189 | 201..=204
        ),
    }
}

fn tiff_err(path: &Path, e: impl std::fmt::Display) -> LandscapeError {
    LandscapeError::Format {
        format: "TIFF",
        message: e.to_string(),
        path: path.to_path_buf(),
    }
}

/// Where a TIFF whose image failed to decode first fails: decode strip by strip (or tile by
/// tile) and name the first one that does not decode, with the cells it holds.
fn first_unreadable_chunk(path: &Path, width: usize, height: usize) -> Option<String> {
    let file = File::open(path).ok()?;
    let mut dec = Decoder::new(BufReader::new(file)).ok()?;
    let (cw, ch) = dec.chunk_dimensions();
    let (cw, ch) = (cw.max(1) as usize, ch.max(1) as usize);
    let chunk_type = dec.get_chunk_type();
    let count = match chunk_type {
        tiff::decoder::ChunkType::Strip => dec.strip_count().ok()?,
        tiff::decoder::ChunkType::Tile => dec.tile_count().ok()?,
    };
    let across = width.div_ceil(cw).max(1);
    for k in 0..count {
        if dec.read_chunk(k).is_err() {
            let k = k as usize;
            let (col, row) = match chunk_type {
                tiff::decoder::ChunkType::Strip => (0, k * ch),
                tiff::decoder::ChunkType::Tile => ((k % across) * cw, (k / across) * ch),
            };
            let last_row = (row + ch).min(height).saturating_sub(1);
            let what = match chunk_type {
                tiff::decoder::ChunkType::Strip => "strip",
                tiff::decoder::ChunkType::Tile => "tile",
            };
            return Some(format!(
                "{what} {k} of {count} does not decode: cells from column {col}, row {row} (rows {row}-{last_row}) are unreadable"
            ));
        }
    }
    None
}

fn geo_err(path: &Path, tag: impl Into<String>, problem: impl Into<String>) -> LandscapeError {
    LandscapeError::GeoTag {
        tag: tag.into(),
        problem: problem.into(),
        path: path.to_path_buf(),
    }
}

const TAG_SCALE: &str = "ModelPixelScaleTag (33550)";
const TAG_TIE: &str = "ModelTiepointTag (33922)";
const TAG_TRANSFORM: &str = "ModelTransformationTag (34264)";
const TAG_KEYS: &str = "GeoKeyDirectoryTag (34735)";
const TAG_NODATA: &str = "GDAL_NODATA (42113)";

/// Read a single-band GeoTIFF (first image) with its georeferencing.
pub fn read_geotiff(path: impl AsRef<Path>) -> Result<GeoRaster, LandscapeError> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|source| LandscapeError::Io {
        source,
        path: path.to_path_buf(),
    })?;
    let mut dec = Decoder::new(BufReader::new(file)).map_err(|e| tiff_err(path, e))?;
    let (w, h) = dec.dimensions().map_err(|e| tiff_err(path, e))?;
    let (width, height) = (w as usize, h as usize);

    let spp: u16 = dec
        .find_tag_unsigned(Tag::SamplesPerPixel)
        .map_err(|e| tiff_err(path, e))?
        .unwrap_or(1);
    if spp != 1 {
        return Err(tiff_err(
            path,
            format!("SamplesPerPixel = {spp}; only single-band rasters are supported"),
        ));
    }
    let photometric: Option<u16> = dec
        .find_tag_unsigned(Tag::PhotometricInterpretation)
        .map_err(|e| tiff_err(path, e))?;
    if photometric == Some(3) {
        return Err(tiff_err(
            path,
            "palette-colour TIFF (PhotometricInterpretation = 3) is not supported; \
             rewrite with `gdal_translate -co PHOTOMETRIC=MINISBLACK`",
        ));
    }

    // --- georeferencing tags ---
    let f64_tag = |dec: &mut Decoder<BufReader<File>>, tag: Tag, name: &str| -> Result<_, LandscapeError> {
        match dec.find_tag(tag).map_err(|e| tiff_err(path, e))? {
            None => Ok(None),
            Some(v) => v
                .into_f64_vec()
                .map(Some)
                .map_err(|e| geo_err(path, name, format!("not a list of doubles ({e})"))),
        }
    };
    let scale = f64_tag(&mut dec, Tag::ModelPixelScaleTag, TAG_SCALE)?;
    let tie = f64_tag(&mut dec, Tag::ModelTiepointTag, TAG_TIE)?;
    let transform = f64_tag(&mut dec, Tag::ModelTransformationTag, TAG_TRANSFORM)?;

    let keys_raw: Vec<u16> = match dec
        .find_tag(Tag::GeoKeyDirectoryTag)
        .map_err(|e| tiff_err(path, e))?
    {
        None => return Err(geo_err(path, TAG_KEYS, "is missing")),
        Some(v) => v
            .into_u16_vec()
            .map_err(|e| geo_err(path, TAG_KEYS, format!("not a list of shorts ({e})")))?,
    };
    let doubles = f64_tag(&mut dec, Tag::GeoDoubleParamsTag, "GeoDoubleParamsTag (34736)")?;
    let ascii = match dec
        .find_tag(Tag::GeoAsciiParamsTag)
        .map_err(|e| tiff_err(path, e))?
    {
        None => None,
        Some(v) => v.into_string().ok(),
    };
    let geokeys = parse_geokeys(path, &keys_raw, doubles.as_deref(), ascii.as_deref())?;

    let nodata = match dec.find_tag(Tag::GdalNodata).map_err(|e| tiff_err(path, e))? {
        None => None,
        Some(v) => {
            let s = v
                .into_string()
                .map_err(|e| geo_err(path, TAG_NODATA, format!("not an ASCII string ({e})")))?;
            let t = s.trim_matches(|c: char| c == '\0' || c.is_whitespace());
            Some(
                t.parse::<f64>()
                    .map_err(|_| geo_err(path, TAG_NODATA, format!("{t:?} is not a number")))?,
            )
        }
    };

    let raster_type = match geokeys.raster_type {
        None | Some(1) => RasterType::PixelIsArea,
        Some(2) => RasterType::PixelIsPoint,
        Some(v) => {
            return Err(geo_err(
                path,
                "GeoKey GTRasterTypeGeoKey (1025)",
                format!("value {v} is neither 1 (PixelIsArea) nor 2 (PixelIsPoint)"),
            ));
        }
    };

    let (mut ox, mut oy, dx, dy) = match (scale, tie, transform) {
        (Some(s), Some(t), _) => {
            if s.len() < 2 {
                return Err(geo_err(
                    path,
                    TAG_SCALE,
                    format!("has {} values, expected 3", s.len()),
                ));
            }
            if t.len() < 6 || !t.len().is_multiple_of(6) {
                return Err(geo_err(
                    path,
                    TAG_TIE,
                    format!("has {} values, expected 6", t.len()),
                ));
            }
            let (sx, sy) = (s[0], s[1]);
            if !(sx.is_finite() && sy.is_finite() && sx != 0.0 && sy != 0.0) {
                return Err(geo_err(
                    path,
                    TAG_SCALE,
                    format!("pixel size ({sx}, {sy}) must be non-zero"),
                ));
            }
            let (i, j, x, y) = (t[0], t[1], t[3], t[4]);
            // Model y decreases as the row index grows (north-up) for positive ScaleY.
            (x - i * sx, y + j * sy, sx, -sy)
        }
        (None, _, Some(m)) | (Some(_), None, Some(m)) => {
            if m.len() != 16 {
                return Err(geo_err(
                    path,
                    TAG_TRANSFORM,
                    format!("has {} values, expected 16", m.len()),
                ));
            }
            if m[1] != 0.0 || m[4] != 0.0 {
                return Err(geo_err(
                    path,
                    TAG_TRANSFORM,
                    "rotated/sheared rasters are not supported",
                ));
            }
            (m[3], m[7], m[0], m[5])
        }
        (None, _, None) => return Err(geo_err(path, TAG_SCALE, "is missing")),
        (Some(_), None, None) => return Err(geo_err(path, TAG_TIE, "is missing")),
    };
    if !(dx.is_finite() && dy.is_finite() && dx != 0.0 && dy != 0.0 && ox.is_finite() && oy.is_finite()) {
        return Err(geo_err(path, TAG_SCALE, "degenerate pixel size or origin"));
    }
    if raster_type == RasterType::PixelIsPoint {
        ox -= 0.5 * dx;
        oy -= 0.5 * dy;
    }
    let crs = crs_from_keys(path, &geokeys)?;

    // --- samples ---
    let img = dec
        .read_image()
        .map_err(|e| match first_unreadable_chunk(path, width, height) {
            Some(place) => tiff_err(path, format!("{e}; {place}")),
            None => tiff_err(path, e),
        })?;
    let (sample_type, data): (SampleType, Vec<f32>) = match img {
        DecodingResult::U8(v) => (SampleType::U8, v.into_iter().map(f32::from).collect()),
        DecodingResult::U16(v) => (SampleType::U16, v.into_iter().map(f32::from).collect()),
        DecodingResult::I16(v) => (SampleType::I16, v.into_iter().map(f32::from).collect()),
        DecodingResult::F32(v) => (SampleType::F32, v),
        DecodingResult::I8(v) => (SampleType::I8, v.into_iter().map(f32::from).collect()),
        DecodingResult::U32(v) => (SampleType::U32, v.into_iter().map(|x| x as f32).collect()),
        DecodingResult::I32(v) => (SampleType::I32, v.into_iter().map(|x| x as f32).collect()),
        DecodingResult::F64(v) => (SampleType::F64, v.into_iter().map(|x| x as f32).collect()),
        DecodingResult::U64(_) => return Err(tiff_err(path, "unsupported sample type u64")),
        DecodingResult::I64(_) => return Err(tiff_err(path, "unsupported sample type i64")),
        DecodingResult::F16(_) => return Err(tiff_err(path, "unsupported sample type f16")),
    };
    if data.len() != width * height {
        return Err(tiff_err(
            path,
            format!("decoded {} samples, expected {width} x {height}", data.len()),
        ));
    }
    Ok(GeoRaster {
        path: path.to_path_buf(),
        width,
        height,
        sample_type,
        data,
        nodata,
        crs,
        raster_type,
        origin_x: ox,
        origin_y: oy,
        pixel_dx: dx,
        pixel_dy: dy,
        geokeys,
    })
}

fn parse_geokeys(
    path: &Path,
    raw: &[u16],
    doubles: Option<&[f64]>,
    ascii: Option<&str>,
) -> Result<GeoKeys, LandscapeError> {
    if raw.len() < 4 {
        return Err(geo_err(
            path,
            TAG_KEYS,
            format!("has {} values, header needs 4", raw.len()),
        ));
    }
    if raw[0] != 1 {
        return Err(geo_err(
            path,
            TAG_KEYS,
            format!("KeyDirectoryVersion is {}, expected 1", raw[0]),
        ));
    }
    let n = raw[3] as usize;
    if raw.len() < 4 + 4 * n {
        return Err(geo_err(
            path,
            TAG_KEYS,
            format!("declares {n} keys but holds {} values", raw.len()),
        ));
    }
    let _ = doubles; // no double-valued key is needed yet
    let mut keys = GeoKeys::default();
    for k in 0..n {
        let e = &raw[4 + 4 * k..8 + 4 * k];
        let (id, loc, count, off) = (e[0], e[1], e[2] as usize, e[3] as usize);
        let short = if loc == 0 { Some(off as u16) } else { None };
        let text = || {
            if loc == 34737 {
                ascii
                    .and_then(|s| s.get(off..off + count))
                    .map(|s| s.trim_end_matches(['|', '\0']).to_string())
            } else {
                None
            }
        };
        match id {
            1024 => keys.model_type = short,
            1025 => keys.raster_type = short,
            1026 => keys.citation = text(),
            2048 => keys.geographic_type = short,
            3072 => keys.projected_cs_type = short,
            3073 if keys.citation.is_none() => keys.citation = text(),
            3076 => keys.proj_linear_units = short,
            4096 => keys.vertical_cs_type = short,
            4099 => keys.vertical_units = short,
            _ => {}
        }
    }
    Ok(keys)
}

fn crs_from_keys(path: &Path, k: &GeoKeys) -> Result<String, LandscapeError> {
    let model = match k.model_type {
        Some(m) => m,
        None if k.projected_cs_type.is_some() => 1,
        None if k.geographic_type.is_some() => 2,
        None => return Err(geo_err(path, "GeoKey GTModelTypeGeoKey (1024)", "is missing")),
    };
    let user = |code: u16| {
        if code == 32767 {
            format!("USER-DEFINED:{}", k.citation.clone().unwrap_or_default())
        } else {
            format!("EPSG:{code}")
        }
    };
    match model {
        1 => k.projected_cs_type.map(user).ok_or_else(|| {
            geo_err(
                path,
                "GeoKey ProjectedCSTypeGeoKey (3072)",
                "is missing (model is projected)",
            )
        }),
        2 => k.geographic_type.map(user).ok_or_else(|| {
            geo_err(
                path,
                "GeoKey GeographicTypeGeoKey (2048)",
                "is missing (model is geographic)",
            )
        }),
        m => Err(geo_err(
            path,
            "GeoKey GTModelTypeGeoKey (1024)",
            format!("value {m} is not supported (1 projected, 2 geographic)"),
        )),
    }
}

/// Resample a land-cover / fuel-model raster onto `grid` (nearest neighbour).
pub fn resample_land_cover(
    raster: &GeoRaster,
    grid: &GridSpec,
    opts: &LandCoverOptions,
) -> Result<Vec<u16>, LandscapeError> {
    let points = resample::raster_points(grid, &raster.crs, &raster.path)?;
    let mut any = false;
    let out = points
        .iter()
        .map(|p| {
            let v = p.and_then(|(x, y)| raster.sample_nearest(x, y));
            let code = v.and_then(|v| {
                if v < 0.0 || v > f32::from(u16::MAX) || v.fract() != 0.0 {
                    return None;
                }
                let c = v as u16;
                (!opts.invalid_as_nodata || is_valid_class(opts.scheme, c)).then_some(c)
            });
            any |= code.is_some();
            code.unwrap_or(opts.fill_class)
        })
        .collect();
    if !any {
        return Err(LandscapeError::NoOverlap {
            layer: "land cover",
            path: raster.path.clone(),
        });
    }
    Ok(out)
}

/// Resample elevation onto `grid` (bilinear), in feet. With several rasters (e.g. adjacent
/// SRTM tiles), each cell takes the first raster that has valid data there.
pub fn resample_elevation(
    rasters: &[GeoRaster],
    grid: &GridSpec,
    opts: &ElevationOptions,
) -> Result<Vec<f32>, LandscapeError> {
    let n = grid.width * grid.height;
    let mut out: Vec<Option<f32>> = vec![None; n];
    for r in rasters {
        let to_ft = opts
            .units
            .or_else(|| r.vertical_unit())
            .unwrap_or(LengthUnit::Metre)
            .to_feet();
        let points = resample::raster_points(grid, &r.crs, &r.path)?;
        for (o, p) in out.iter_mut().zip(points) {
            if o.is_none() {
                *o = p
                    .and_then(|(x, y)| r.sample_bilinear(x, y))
                    .map(|v| (v * to_ft) as f32);
            }
        }
    }
    let path = rasters.first().map(|r| r.path.clone()).unwrap_or_default();
    resample::finish_elevation(out, grid.width, opts.nodata, &path)
}

/// Read a land-cover GeoTIFF and an elevation GeoTIFF and build a landscape on `grid`.
pub fn load_landscape(
    land_cover: impl AsRef<Path>,
    elevation: impl AsRef<Path>,
    grid: &GridSpec,
    lc_opts: &LandCoverOptions,
    el_opts: &ElevationOptions,
) -> Result<Landscape, LandscapeError> {
    let lc = read_geotiff(land_cover)?;
    let el = read_geotiff(elevation)?;
    let classes = resample_land_cover(&lc, grid, lc_opts)?;
    let elev = resample_elevation(std::slice::from_ref(&el), grid, el_opts)?;
    Landscape::new(
        grid.width,
        grid.height,
        grid.cell_size_ft,
        lc_opts.scheme,
        classes,
        elev,
        grid.georef.clone(),
    )
}
