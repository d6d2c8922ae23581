//! FARSITE/FlamMap landscape files (`.lcp`, "FARSITE v.4"): one little-endian file holding a
//! 7,316-byte header and then, cell by cell (row 0 north, west to east), the int16 values of
//! every band, interleaved.
//!
//! Format facts from GDAL's LCP driver documentation (`doc/source/drivers/raster/lcp.rst`) and
//! the unit handling of FARSITE's and FlamMap's own readers:
//!
//! | byte | field | used here |
//! |---|---|---|
//! | 0, 4 | crown fuels, ground fuels: 20 absent, 21 present | which bands follow |
//! | 8 | latitude (int32) | checked to be −90…90 |
//! | 12–43 | legacy extents (doubles) | — |
//! | 44–4163 | per theme (elevation, slope, aspect, fuel, cover, height, base, density, duff, woody): low, high, number of classes, 100 class values (int32) | — (legend tables) |
//! | 4164, 4168 | columns, rows (int32) | grid size |
//! | 4172–4203 | east, west, north, south (doubles) | origin west/north; checked against size × cell |
//! | 4204 | grid units: 0 m, 1 ft, 2 km (int32) | checked against the `.prj` |
//! | 4208, 4216 | cell width, height (doubles) | pixel size |
//! | 4224 | elevation units: 0 m, 1 ft | ft → m |
//! | 4226 | slope units: 0 degrees, 1 percent | degrees → percent by the shared reader |
//! | 4228 | aspect units: 0 GRASS categories, 1 GRASS degrees, 2 azimuth degrees | → azimuth |
//! | 4230 | fuel options: 0 none, 1 custom models, 2 conversion file, 3 both | named in errors |
//! | 4232 | canopy cover units: 0 categories, 1 percent | categories → percent |
//! | 4234, 4236 | canopy height, base height units: 1 m, 2 ft, 3 m × 10, 4 ft × 10 | → m |
//! | 4238 | bulk density units: 1 kg/m³, 2 lb/ft³, 3 kg/m³ × 100, 4 lb/ft³ × 1000 | → kg/m³ |
//! | 4240, 4242 | duff units, coarse woody option | — |
//! | 4244–6803 | ten 256-byte source file names | — |
//! | 6804–7315 | description (512 bytes) | — |
//!
//! Bands: elevation, slope, aspect, fuel model, canopy cover; then canopy height, canopy base
//! height, canopy bulk density with crown fuels; then duff and coarse woody with ground fuels
//! (5, 7, 8 or 10 bands).
//!
//! Units, as FARSITE and FlamMap read them: the canopy height and base height bands are
//! **always tenths** (FARSITE divides them by 10 whatever the code; FlamMap names codes 1 and 3
//! metres, 2 and 4 feet), and bulk density is **kg/m³ × 100** for codes 1 and 3 and
//! **lb/ft³ × 1000** for 2 and 4 (FARSITE: `p / 100`, or `p / 1000 × 16.01845`). GDAL's table
//! calls codes 1 and 2 unscaled; for 3 and 4, which GDAL writes by default, all three agree.
//! Aspect in GRASS degrees is counter-clockwise from east (azimuth = 90 − a); GRASS categories
//! are 15° classes with 1 east, 7 north, 13 west, 19 south and 25 flat (azimuth =
//! 90 − 15 (c − 1); FARSITE sets slope 0 on category 25, read here as aspect −1, flat).
//! Canopy cover categories are FARSITE's: 0 → 0 %, 1 → 10 %, 2 → 30 %, 3 → 60 %, 4 → 75 %, 99
//! → 0 %. Elevation in feet is × 0.3048 to metres.
//!
//! Nodata: the LCP convention −9999, and LANDFIRE's int16 nodata 32767 (an `.lcp` made from
//! LANDFIRE rasters without translating it), in every band.
//!
//! The CRS comes from the `.prj` beside the file (same stem), ESRI or OGC WKT
//! ([`crate::prj`]); without one it is `UNKNOWN` and the grids written from it carry no CRS.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::landfire::{DecodedLandscape, DecodedLayer, FuelLayer, LandfireError, LandfireGrid, LayerKind};

/// Bytes before the first cell.
pub const LCP_HEADER_BYTES: usize = 7316;

/// The LCP convention for "no data".
pub const LCP_NODATA: i16 = -9999;

/// The header fields the reader uses.
#[derive(Debug, Clone, PartialEq)]
pub struct LcpHeader {
    pub crown_fuels: bool,
    pub ground_fuels: bool,
    pub latitude: i32,
    pub width: usize,
    pub height: usize,
    pub east: f64,
    pub west: f64,
    pub north: f64,
    pub south: f64,
    /// 0 m, 1 ft, 2 km.
    pub grid_units: i32,
    pub cell_x: f64,
    pub cell_y: f64,
    pub elevation_units: i16,
    pub slope_units: i16,
    pub aspect_units: i16,
    pub fuel_options: i16,
    pub cover_units: i16,
    pub height_units: i16,
    pub base_units: i16,
    pub density_units: i16,
    pub description: String,
}

fn i32_at(b: &[u8], at: usize) -> i32 {
    i32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn i16_at(b: &[u8], at: usize) -> i16 {
    i16::from_le_bytes([b[at], b[at + 1]])
}

fn f64_at(b: &[u8], at: usize) -> f64 {
    let mut x = [0u8; 8];
    x.copy_from_slice(&b[at..at + 8]);
    f64::from_le_bytes(x)
}

impl LcpHeader {
    /// Parse and check the header (`bytes` holds at least its 7,316 bytes).
    pub fn parse(bytes: &[u8], path: &Path) -> Result<Self, LandfireError> {
        let bad = |field: &'static str, offset: usize, problem: String| LandfireError::LcpHeader {
            field,
            offset,
            problem,
            path: path.to_path_buf(),
        };
        if bytes.len() < LCP_HEADER_BYTES {
            return Err(bad(
                "length",
                0,
                format!(
                    "the file has {} bytes, fewer than the {LCP_HEADER_BYTES}-byte header",
                    bytes.len()
                ),
            ));
        }
        let flag = |field: &'static str, at: usize| match i32_at(bytes, at) {
            20 => Ok(false),
            21 => Ok(true),
            v => Err(bad(
                field,
                at,
                format!("{v} is neither 20 (absent) nor 21 (present); not a FARSITE v.4 landscape file"),
            )),
        };
        let crown_fuels = flag("crown fuels flag", 0)?;
        let ground_fuels = flag("ground fuels flag", 4)?;
        let latitude = i32_at(bytes, 8);
        if !(-90..=90).contains(&latitude) {
            return Err(bad("latitude", 8, format!("{latitude} is not a latitude")));
        }
        let size = |field: &'static str, at: usize| {
            let v = i32_at(bytes, at);
            usize::try_from(v)
                .ok()
                .filter(|n| *n > 0)
                .ok_or_else(|| bad(field, at, format!("{v} is not a positive number of cells")))
        };
        let width = size("numeast (columns)", 4164)?;
        let height = size("numnorth (rows)", 4168)?;
        let (east, west, north, south) = (
            f64_at(bytes, 4172),
            f64_at(bytes, 4180),
            f64_at(bytes, 4188),
            f64_at(bytes, 4196),
        );
        let grid_units = i32_at(bytes, 4204);
        if !(0..=2).contains(&grid_units) {
            return Err(bad(
                "GridUnits",
                4204,
                format!("{grid_units} is not 0 (m), 1 (ft) or 2 (km)"),
            ));
        }
        let (cell_x, cell_y) = (f64_at(bytes, 4208), f64_at(bytes, 4216));
        for (field, at, v) in [("XResol", 4208, cell_x), ("YResol", 4216, cell_y)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(field, at, format!("cell size {v} is not positive")));
            }
        }
        for (field, at, v) in [
            ("EastUtm", 4172, east),
            ("WestUtm", 4180, west),
            ("NorthUtm", 4188, north),
            ("SouthUtm", 4196, south),
        ] {
            if !v.is_finite() {
                return Err(bad(field, at, format!("{v} is not a coordinate")));
            }
        }
        // The extents must be the grid: size × cell, to half a cell.
        let span_x = width as f64 * cell_x;
        let span_y = height as f64 * cell_y;
        if ((east - west) - span_x).abs() > 0.5 * cell_x {
            return Err(bad(
                "EastUtm",
                4172,
                format!(
                    "east - west = {} but {width} columns x {cell_x} = {span_x}",
                    east - west
                ),
            ));
        }
        if ((north - south) - span_y).abs() > 0.5 * cell_y {
            return Err(bad(
                "NorthUtm",
                4188,
                format!(
                    "north - south = {} but {height} rows x {cell_y} = {span_y}",
                    north - south
                ),
            ));
        }
        let unit = |field: &'static str, at: usize, allowed: std::ops::RangeInclusive<i16>, meaning: &str| {
            let v = i16_at(bytes, at);
            if allowed.contains(&v) {
                Ok(v)
            } else {
                Err(bad(field, at, format!("unit code {v} is not one of {meaning}")))
            }
        };
        let elevation_units = unit("EUnits", 4224, 0..=1, "0 (m), 1 (ft)")?;
        let slope_units = unit("SUnits", 4226, 0..=1, "0 (degrees), 1 (percent)")?;
        let aspect_units = unit(
            "AUnits",
            4228,
            0..=2,
            "0 (GRASS categories), 1 (GRASS degrees), 2 (azimuth degrees)",
        )?;
        let fuel_options = unit(
            "FOptions",
            4230,
            0..=3,
            "0 (no custom models, no conversion file), 1 (custom models), 2 (conversion file), 3 (both)",
        )?;
        let cover_units = unit("CUnits", 4232, 0..=1, "0 (categories 0-4), 1 (percent)")?;
        let (mut height_units, mut base_units, mut density_units) = (0, 0, 0);
        if crown_fuels {
            let heights = "1 (m), 2 (ft), 3 (m x 10), 4 (ft x 10)";
            height_units = unit("HUnits", 4234, 1..=4, heights)?;
            base_units = unit("BUnits", 4236, 1..=4, heights)?;
            density_units = unit(
                "PUnits",
                4238,
                1..=4,
                "1 (kg/m3), 2 (lb/ft3), 3 (kg/m3 x 100), 4 (lb/ft3 x 1000)",
            )?;
        }
        let description = bytes[6804..LCP_HEADER_BYTES]
            .split(|b| *b == 0)
            .next()
            .map(|d| String::from_utf8_lossy(d).trim().to_string())
            .unwrap_or_default();
        Ok(Self {
            crown_fuels,
            ground_fuels,
            latitude,
            width,
            height,
            east,
            west,
            north,
            south,
            grid_units,
            cell_x,
            cell_y,
            elevation_units,
            slope_units,
            aspect_units,
            fuel_options,
            cover_units,
            height_units,
            base_units,
            density_units,
            description,
        })
    }

    /// Number of int16 bands per cell: 5, 7 (ground fuels), 8 (crown) or 10 (both).
    pub fn bands(&self) -> usize {
        5 + if self.crown_fuels { 3 } else { 0 } + if self.ground_fuels { 2 } else { 0 }
    }
}

/// The `.prj` beside `path` (same stem, `.prj` or `.PRJ`).
fn prj_path(path: &Path) -> Option<PathBuf> {
    ["prj", "PRJ"]
        .iter()
        .map(|e| path.with_extension(e))
        .find(|p| p.is_file())
}

const FT_TO_M: f32 = 0.3048;
const LB_FT3_TO_KG_M3: f32 = 16.018_463;

/// Decode an `.lcp` into layers in FireCast's units; [`DecodedLandscape::finish`] checks them.
pub(crate) fn decode(path: &Path, fuel_layer: FuelLayer) -> Result<DecodedLandscape, LandfireError> {
    let bytes = std::fs::read(path).map_err(|source| {
        LandfireError::Raster(crate::LandscapeError::Io {
            source,
            path: path.to_path_buf(),
        })
    })?;
    let header = LcpHeader::parse(&bytes, path)?;
    let bands = header.bands();
    let cells = header.width.checked_mul(header.height);
    let expected = cells
        .and_then(|c| c.checked_mul(bands * 2))
        .and_then(|d| d.checked_add(LCP_HEADER_BYTES))
        .ok_or_else(|| LandfireError::LcpHeader {
            field: "numeast (columns)",
            offset: 4164,
            problem: format!("{} x {} cells is too large", header.width, header.height),
            path: path.to_path_buf(),
        })?;
    let cells = header.width * header.height;
    if bytes.len() < expected {
        let whole = (bytes.len() - LCP_HEADER_BYTES) / (bands * 2);
        return Err(LandfireError::LcpTruncated {
            bytes: bytes.len() as u64,
            expected: expected as u64,
            width: header.width,
            height: header.height,
            bands,
            col: whole % header.width,
            row: whole / header.width,
            path: path.to_path_buf(),
        });
    }

    // The CRS, from the .prj beside the file.
    let (crs, geokeys) = match prj_path(path) {
        Some(prj) => {
            let text = std::fs::read_to_string(&prj).map_err(|e| LandfireError::Prj {
                message: e.to_string(),
                path: prj.clone(),
            })?;
            let id = crate::prj::identify(&text).map_err(|message| LandfireError::Prj {
                message,
                path: prj.clone(),
            })?;
            if id.geographic {
                return Err(LandfireError::GeographicCrs {
                    layer: "projection (.prj)",
                    crs: id.crs,
                    path: prj,
                });
            }
            if let Some(m) = id.metres_per_unit {
                let header_m = [1.0, 0.3048, 1000.0][header.grid_units as usize];
                if (m - header_m).abs() > 1e-3 * header_m {
                    return Err(LandfireError::LcpHeader {
                        field: "GridUnits",
                        offset: 4204,
                        problem: format!(
                            "{} (a unit of {header_m} m), but the CRS in {} ({}) is in units of {m} m",
                            header.grid_units,
                            prj.display(),
                            id.name
                        ),
                        path: path.to_path_buf(),
                    });
                }
            }
            let keys = crate::prj::geokeys(&id);
            (id.crs, keys)
        }
        None => ("UNKNOWN".to_string(), crate::gridio::GeoKeyTags::default()),
    };
    let grid = LandfireGrid {
        width: header.width,
        height: header.height,
        crs,
        origin_x: header.west,
        origin_y: header.north,
        pixel_dx: header.cell_x,
        pixel_dy: -header.cell_y,
        geokeys,
    };

    // Band values, nodata as NaN; conversions that can fail name the cell.
    let raw = |band: usize, cell: usize| i16_at(&bytes, LCP_HEADER_BYTES + (cell * bands + band) * 2);
    let is_nodata = |v: i16| v == LCP_NODATA || v == i16::MAX;
    let bad = |kind: LayerKind, cell: usize, value: i16, problem: &'static str| LandfireError::BadValue {
        layer: kind.name(),
        value: f32::from(value),
        col: cell % header.width,
        row: cell / header.width,
        problem,
        path: path.to_path_buf(),
    };
    let band = |kind: LayerKind,
                index: usize,
                convert: &dyn Fn(i16) -> Result<f32, &'static str>|
     -> Result<DecodedLayer, LandfireError> {
        let mut values = Vec::with_capacity(cells);
        for cell in 0..cells {
            let v = raw(index, cell);
            values.push(if is_nodata(v) {
                f32::NAN
            } else {
                convert(v).map_err(|problem| bad(kind, cell, v, problem))?
            });
        }
        Ok(DecodedLayer {
            kind,
            path: path.to_path_buf(),
            values,
        })
    };

    let mut units = BTreeMap::new();
    let elevation = band(LayerKind::Elevation, 0, &|v| {
        Ok(if header.elevation_units == 1 {
            f32::from(v) * FT_TO_M
        } else {
            f32::from(v)
        })
    })?;
    units.insert(
        LayerKind::Elevation.name(),
        if header.elevation_units == 1 {
            "ft (converted to m)"
        } else {
            "m"
        }
        .to_string(),
    );
    let slope_kind = if header.slope_units == 0 {
        LayerKind::SlopeDegrees
    } else {
        LayerKind::SlopePercent
    };
    let slope = band(slope_kind, 1, &|v| Ok(f32::from(v)))?;
    units.insert(
        slope_kind.name(),
        if header.slope_units == 0 {
            "degrees (converted to percent)"
        } else {
            "percent"
        }
        .to_string(),
    );
    let aspect = match header.aspect_units {
        0 => band(LayerKind::Aspect, 2, &|v| match v {
            1..=24 => Ok((90.0 - 15.0 * f32::from(v - 1)).rem_euclid(360.0)),
            25 => Ok(-1.0),
            _ => Err("not a GRASS aspect category (1-24, 25 flat)"),
        })?,
        1 => band(LayerKind::Aspect, 2, &|v| {
            if (0..=360).contains(&v) {
                Ok((90.0 - f32::from(v)).rem_euclid(360.0))
            } else {
                Err("not a GRASS aspect in [0, 360] degrees")
            }
        })?,
        _ => band(LayerKind::Aspect, 2, &|v| Ok(f32::from(v)))?,
    };
    units.insert(
        LayerKind::Aspect.name(),
        match header.aspect_units {
            0 => "GRASS categories (15-degree classes from east, 25 flat; converted to azimuth)",
            1 => "GRASS degrees (counter-clockwise from east; converted to azimuth)",
            _ => "azimuth degrees, -1 flat",
        }
        .to_string(),
    );
    let fuel_kind = match fuel_layer {
        FuelLayer::Fbfm40 => LayerKind::Fbfm40,
        FuelLayer::Fbfm13 => LayerKind::Fbfm13,
    };
    let fuel = band(fuel_kind, 3, &|v| Ok(f32::from(v)))?;
    units.insert(fuel_kind.name(), "fuel model number".to_string());
    let cover = if header.cover_units == 0 {
        band(LayerKind::CanopyCover, 4, &|v| match v {
            0 | 99 => Ok(0.0),
            1 => Ok(10.0),
            2 => Ok(30.0),
            3 => Ok(60.0),
            4 => Ok(75.0),
            _ => Err("not a canopy cover category (0-4, 99)"),
        })?
    } else {
        band(LayerKind::CanopyCover, 4, &|v| Ok(f32::from(v)))?
    };
    units.insert(
        LayerKind::CanopyCover.name(),
        if header.cover_units == 0 {
            "categories 0-4 (converted as FARSITE does: 0, 10, 30, 60, 75 %)"
        } else {
            "percent"
        }
        .to_string(),
    );
    let mut optional = vec![elevation, cover];
    if header.crown_fuels {
        for (kind, index, code) in [
            (LayerKind::CanopyHeight, 5, header.height_units),
            (LayerKind::CanopyBaseHeight, 6, header.base_units),
        ] {
            let feet = code == 2 || code == 4;
            optional.push(band(kind, index, &|v| {
                let tenths = f32::from(v) * LayerKind::CanopyHeight.scale();
                Ok(if feet { tenths * FT_TO_M } else { tenths })
            })?);
            units.insert(
                kind.name(),
                if feet {
                    "ft x 10 (converted to m)"
                } else {
                    "m x 10 (converted to m)"
                }
                .to_string(),
            );
        }
        let pounds = header.density_units == 2 || header.density_units == 4;
        optional.push(band(LayerKind::CanopyBulkDensity, 7, &|v| {
            Ok(if pounds {
                f32::from(v) * 0.001 * LB_FT3_TO_KG_M3
            } else {
                f32::from(v) * LayerKind::CanopyBulkDensity.scale()
            })
        })?);
        units.insert(
            LayerKind::CanopyBulkDensity.name(),
            if pounds {
                "lb/ft3 x 1000 (converted to kg/m3)"
            } else {
                "kg/m3 x 100 (converted to kg/m3)"
            }
            .to_string(),
        );
    }
    // Keep the shared order: elevation, cover, height, base height, bulk density.
    optional.sort_by_key(|l| l.kind);
    let fuel_note = match header.fuel_options {
        1 | 3 => Some(format!(
            "the LCP's header declares custom fuel models (FOptions {}), which FireCast does not read",
            header.fuel_options
        )),
        2 => Some(
            "the LCP's header declares a fuel conversion file (FOptions 2), which FireCast does not read"
                .into(),
        ),
        _ => None,
    };
    Ok(DecodedLandscape {
        grid,
        fuel_layer,
        format: "FARSITE .lcp",
        stored_units: units,
        fuel,
        slope,
        aspect,
        optional,
        fuel_note,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal header: 2 x 1 cells of 30 m, 5 bands, every unit code 0/1 as given.
    fn header_bytes(crown: bool) -> Vec<u8> {
        let mut b = vec![0u8; LCP_HEADER_BYTES];
        b[0..4].copy_from_slice(&(if crown { 21i32 } else { 20 }).to_le_bytes());
        b[4..8].copy_from_slice(&20i32.to_le_bytes());
        b[8..12].copy_from_slice(&44i32.to_le_bytes());
        b[4164..4168].copy_from_slice(&2i32.to_le_bytes());
        b[4168..4172].copy_from_slice(&1i32.to_le_bytes());
        for (at, v) in [
            (4172, 60.0f64),
            (4180, 0.0),
            (4188, 30.0),
            (4196, 0.0),
            (4208, 30.0),
            (4216, 30.0),
        ] {
            b[at..at + 8].copy_from_slice(&v.to_le_bytes());
        }
        b[4228..4230].copy_from_slice(&2i16.to_le_bytes());
        b[4232..4234].copy_from_slice(&1i16.to_le_bytes());
        if crown {
            for at in [4234, 4236, 4238] {
                b[at..at + 2].copy_from_slice(&3i16.to_le_bytes());
            }
        }
        b
    }

    #[test]
    fn header_fields_are_read_and_checked() {
        let path = Path::new("x.lcp");
        let h = LcpHeader::parse(&header_bytes(true), path).expect("valid");
        assert_eq!((h.width, h.height, h.bands()), (2, 1, 8));
        assert_eq!((h.west, h.north, h.cell_x), (0.0, 30.0, 30.0));
        let mut b = header_bytes(false);
        b[0] = 7;
        let text = LcpHeader::parse(&b, path).expect_err("flag").to_string();
        assert!(
            text.contains("crown fuels flag (byte 0)") && text.contains("x.lcp"),
            "{text}"
        );
        let mut b = header_bytes(false);
        b[4226..4228].copy_from_slice(&5i16.to_le_bytes());
        let text = LcpHeader::parse(&b, path).expect_err("slope unit").to_string();
        assert!(text.contains("SUnits (byte 4226): unit code 5"), "{text}");
        let mut b = header_bytes(false);
        b[4172..4180].copy_from_slice(&90.0f64.to_le_bytes());
        let text = LcpHeader::parse(&b, path).expect_err("extent").to_string();
        assert!(
            text.contains("east - west = 90 but 2 columns x 30 = 60"),
            "{text}"
        );
        let text = LcpHeader::parse(&b[..100], path).expect_err("short").to_string();
        assert!(text.contains("fewer than the 7316-byte header"), "{text}");
    }
}
