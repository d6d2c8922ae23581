//! SRTM `.hgt` tiles: headerless big-endian `i16` metres, rows north → south, voids −32768.
//!
//! A tile `N34W119.hgt` covers 1° × 1°; its name is the **centre of the south-west sample**, so
//! sample (col, row) is at lon = −119 + col/(n−1), lat = 35 − row/(n−1) (point samples, adjacent
//! tiles share an edge row/column). n = 1201 (3″) or 3601 (1″); any other square size n ≥ 2 is
//! accepted with the same rule (handy for tests). Resampling is that of
//! [`geotiff::resample_elevation`](crate::geotiff::resample_elevation): bilinear, voids dropped,
//! metres → feet, and the same [`ElevationNoData`](crate::geotiff::ElevationNoData) policy.

use std::path::Path;

use crate::LandscapeError;
use crate::georef::{Crs, GridSpec};
use crate::geotiff::{ElevationOptions, GeoKeys, GeoRaster, RasterType, SampleType, resample_elevation};

/// The void value.
pub const HGT_VOID: i16 = -32768;

/// Parse a tile name such as `N34W119.hgt` / `s05e012.HGT` (directories ignored) into the
/// integer (lat, lon) of its south-west sample.
pub fn parse_tile_name(name: &str) -> Option<(i32, i32)> {
    let file = name.rsplit(['/', '\\']).next()?;
    let stem = file.split('.').next()?.to_ascii_uppercase();
    let b = stem.as_bytes();
    if b.len() != 7 {
        return None;
    }
    let lat: i32 = stem.get(1..3)?.parse().ok()?;
    let lon: i32 = stem.get(4..7)?.parse().ok()?;
    let lat = match b[0] {
        b'N' => lat,
        b'S' => -lat,
        _ => return None,
    };
    let lon = match b[3] {
        b'E' => lon,
        b'W' => -lon,
        _ => return None,
    };
    (lat.abs() <= 90 && lon.abs() <= 180).then_some((lat, lon))
}

fn hgt_err(path: &Path, message: impl Into<String>) -> LandscapeError {
    LandscapeError::Format {
        format: "SRTM hgt",
        message: message.into(),
        path: path.to_path_buf(),
    }
}

/// Read a `.hgt` tile; the south-west corner comes from the file name.
pub fn read_hgt(path: impl AsRef<Path>) -> Result<GeoRaster, LandscapeError> {
    let path = path.as_ref();
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    let (lat, lon) = parse_tile_name(name)
        .ok_or_else(|| hgt_err(path, "file name is not a tile name like N34W119.hgt"))?;
    let bytes = std::fs::read(path).map_err(|source| LandscapeError::Io {
        source,
        path: path.to_path_buf(),
    })?;
    hgt_from_bytes(&bytes, lat, lon, path)
}

/// Decode tile bytes whose south-west sample is at integer (`lat`, `lon`); `path` is for errors.
pub fn hgt_from_bytes(bytes: &[u8], lat: i32, lon: i32, path: &Path) -> Result<GeoRaster, LandscapeError> {
    if !bytes.len().is_multiple_of(2) {
        return Err(hgt_err(path, format!("odd length {} bytes", bytes.len())));
    }
    let count = bytes.len() / 2;
    let n = (count as f64).sqrt().round() as usize;
    if n < 2 || n * n != count {
        return Err(hgt_err(
            path,
            format!(
                "{} bytes is not a square grid of i16 (expected 1201² or 3601² samples)",
                bytes.len()
            ),
        ));
    }
    let data: Vec<f32> = bytes
        .chunks_exact(2)
        .map(|c| f32::from(i16::from_be_bytes([c[0], c[1]])))
        .collect();
    let step = 1.0 / (n - 1) as f64;
    Ok(GeoRaster {
        path: path.to_path_buf(),
        width: n,
        height: n,
        sample_type: SampleType::I16,
        data,
        nodata: Some(f64::from(HGT_VOID)),
        crs: Crs::Wgs84Geographic.code(),
        raster_type: RasterType::PixelIsPoint,
        origin_x: f64::from(lon) - 0.5 * step,
        origin_y: f64::from(lat) + 1.0 + 0.5 * step,
        pixel_dx: step,
        pixel_dy: -step,
        geokeys: GeoKeys {
            model_type: Some(2),
            raster_type: Some(2),
            geographic_type: Some(4326),
            vertical_units: Some(9001),
            ..GeoKeys::default()
        },
    })
}

/// Read one or more (adjacent) tiles and resample their elevation onto `grid`, in feet.
pub fn load_elevation<P: AsRef<Path>>(
    tiles: &[P],
    grid: &GridSpec,
    opts: &ElevationOptions,
) -> Result<Vec<f32>, LandscapeError> {
    let rasters = tiles.iter().map(read_hgt).collect::<Result<Vec<_>, _>>()?;
    resample_elevation(&rasters, grid, opts)
}
