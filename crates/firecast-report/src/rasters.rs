//! The report's rasters for GIS, beside the GeoJSON: float32 GeoTIFFs on the landscape's own
//! grid and CRS (no resampling; row 0 north, as GeoTIFF wants), written with
//! firecast-landscape's encoder, which GDAL and rasterio read.
//!
//! - `arrival_h.tif`: the median fire arrival of the **unsuppressed** runs, hours after
//!   ignition — the time by which at least half of the runs had burnt the cell; nodata
//!   (−9999) where fewer than half burnt it. Contouring it at the report's isochrone hours
//!   gives the GeoJSON's `arrival_isochrone` polygons of strategy `none`.
//! - `burn_probability_pct.tif`: the share of the unsuppressed runs that burnt each cell,
//!   percent 0–100 (0 where none did; no cell is nodata).
//!
//! The unsuppressed fire is the one planning starts from (FSPro's and WFDSS's products are
//! unsuppressed too); the other strategies' isochrones and zones are in the GeoJSON. With the
//! report's `spread` input it is the verified minimum-travel-time engine's free fire (the
//! stage passes that ensemble), otherwise the automaton's unsuppressed runs.

use firecast_episodes::ensemble::Ensemble;
use firecast_landscape::Landscape;
use firecast_landscape::georef::Crs;
use firecast_landscape::gridio::{GeoKeyTags, GridPlacement, encode_geotiff_f32};

use crate::ReportError;

/// The nodata value of the rasters.
pub const NODATA: f32 = -9999.0;

/// GeoKeys for the CRSs a landscape can be transformed from (EPSG:4326, WGS84 UTM); `None`
/// for any other.
pub fn geokeys(crs: &Crs) -> Option<GeoKeyTags> {
    // Header (version 1, revision 1.0, key count), then GTModelTypeGeoKey (1024),
    // GTRasterTypeGeoKey (1025: PixelIsArea) and the EPSG code.
    let directory = match crs {
        Crs::Wgs84Geographic => vec![1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, 4326],
        Crs::Utm { zone, north } => {
            let code = if *north { 32600 } else { 32700 } + u16::from(*zone);
            vec![1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, code]
        }
        // CONUS Albers (LANDFIRE's grid): a projected CRS by its EPSG code.
        Crs::Other(code) if code.eq_ignore_ascii_case("EPSG:5070") => {
            vec![1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 5070]
        }
        Crs::Other(_) => return None,
    };
    Some(GeoKeyTags {
        directory,
        ..GeoKeyTags::default()
    })
}

/// Where the landscape's grid lies, north-up.
fn placement(land: &Landscape) -> Result<GridPlacement, ReportError> {
    let g = &land.georef;
    let geokeys = geokeys(&land.crs()).ok_or_else(|| {
        ReportError::input(
            "landscape",
            format!(
                "its CRS `{}` has no GeoTIFF keys here (EPSG:4326, WGS84 UTM and EPSG:5070 do)",
                g.crs
            ),
        )
    })?;
    Ok(GridPlacement {
        width: land.width,
        height: land.height,
        origin_x: g.origin_x,
        // The grid's origin is its south-west corner; a GeoTIFF starts at the north-west.
        origin_y: g.origin_y + land.height as f64 * g.cell_size_y,
        pixel_dx: g.cell_size_x,
        pixel_dy: -g.cell_size_y,
        geokeys,
    })
}

/// A float32 GeoTIFF of `value(cell index)` on the landscape grid (cell index `y·w + x`
/// with row 0 south, as everywhere in FireCast).
fn encode(land: &Landscape, value: impl Fn(usize) -> f32) -> Result<Vec<u8>, ReportError> {
    let (w, h) = (land.width, land.height);
    let mut data = Vec::with_capacity(w * h);
    for row in 0..h {
        let y = h - 1 - row;
        data.extend((0..w).map(|x| value(y * w + x)));
    }
    encode_geotiff_f32(&placement(land)?, &data, Some(f64::from(NODATA)))
        .map_err(|e| ReportError::input("landscape", e.to_string()))
}

/// Median arrival per cell, hours after ignition (nodata where fewer than half the runs
/// burnt it).
pub fn arrival_h(land: &Landscape, e: &Ensemble) -> Result<Vec<u8>, ReportError> {
    encode(land, |i| e.arrival_median_h[i].unwrap_or(NODATA))
}

/// Burn probability per cell, percent of runs.
pub fn burn_probability_pct(land: &Landscape, e: &Ensemble) -> Result<Vec<u8>, ReportError> {
    let runs = e.runs().max(1) as f32;
    encode(land, |i| e.burn_count[i] as f32 * 100.0 / runs)
}
