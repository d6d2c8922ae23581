use firecast_landscape::geotiff::{
    ElevationNoData, ElevationOptions, LandCoverOptions, LengthUnit, RasterType, SampleType, read_geotiff,
    resample_elevation, resample_land_cover,
};
use firecast_landscape::{Crs, GeoReference, GridSpec, LandCoverScheme, LandscapeError};

use crate::fixture;

const FT: f64 = 0.3048;

fn lc_value(row: usize, col: usize) -> u16 {
    if row == 0 && col == 0 {
        255
    } else {
        1 + ((row * 10 + col) % 17) as u16
    }
}

#[test]
fn land_cover_u8_utm_strips_georef_and_values() {
    let r = read_geotiff(fixture("landcover_utm11_u8.tif")).unwrap();
    assert_eq!((r.width, r.height), (10, 8));
    assert_eq!(r.sample_type, SampleType::U8);
    assert_eq!(r.crs, "EPSG:32611");
    assert_eq!(r.raster_type, RasterType::PixelIsArea);
    assert_eq!(
        (r.origin_x, r.origin_y, r.pixel_dx, r.pixel_dy),
        (360000.0, 3770000.0, 30.0, -30.0)
    );
    assert_eq!(r.nodata, Some(255.0));
    assert_eq!(r.geokeys.proj_linear_units, Some(9001));
    assert_eq!(r.bounds(), (360000.0, 3769760.0, 360300.0, 3770000.0));
    for row in 0..8 {
        for col in 0..10 {
            assert_eq!(r.data[row * 10 + col], f32::from(lc_value(row, col)));
        }
    }
    // A grid with the raster's own pixels: grid row 0 (south) = raster row 7.
    let grid = GridSpec::new(
        10,
        8,
        30.0 / FT,
        GeoReference {
            crs: "EPSG:32611".into(),
            origin_x: 360000.0,
            origin_y: 3769760.0,
            cell_size_x: 30.0,
            cell_size_y: 30.0,
        },
    )
    .unwrap();
    let opts = LandCoverOptions::new(LandCoverScheme::ModisIgbp);
    let lc = resample_land_cover(&r, &grid, &opts).unwrap();
    for y in 0..8 {
        for x in 0..10 {
            let want = if (x, y) == (0, 7) { 17 } else { lc_value(7 - y, x) };
            assert_eq!(lc[y * 10 + x], want, "cell ({x}, {y})");
        }
    }
    // Configurable fill class.
    let opts = LandCoverOptions {
        fill_class: 16,
        ..opts
    };
    assert_eq!(resample_land_cover(&r, &grid, &opts).unwrap()[7 * 10], 16);
}

#[test]
fn land_cover_through_lat_lon_grid() {
    let r = read_geotiff(fixture("landcover_utm11_u8.tif")).unwrap();
    // Centre of raster pixel (row 3, col 4) in lat/lon, then a one-cell EPSG:4326 grid there.
    let (lat, lon) = Crs::parse("EPSG:32611")
        .to_lat_lon(360000.0 + 4.5 * 30.0, 3770000.0 - 3.5 * 30.0)
        .unwrap();
    let grid = GridSpec::geographic_centered(1, 1, 20.0, lat, lon).unwrap();
    let lc = resample_land_cover(&r, &grid, &LandCoverOptions::new(LandCoverScheme::ModisIgbp)).unwrap();
    assert_eq!(lc, vec![lc_value(3, 4)]);
    // Far away: no overlap at all.
    let far = GridSpec::geographic_centered(2, 2, 500.0, 10.0, 10.0).unwrap();
    let err = resample_land_cover(&r, &far, &LandCoverOptions::new(LandCoverScheme::ModisIgbp)).unwrap_err();
    assert!(matches!(err, LandscapeError::NoOverlap { .. }), "{err}");
}

fn dem_value(row: f64, col: f64) -> f64 {
    100.0 + 10.0 * col - 5.0 * row
}

fn grid_4326(w: usize, h: usize, lon0: f64, lat0: f64, d: f64) -> GridSpec {
    GridSpec::new(
        w,
        h,
        100.0,
        GeoReference {
            crs: "EPSG:4326".into(),
            origin_x: lon0,
            origin_y: lat0,
            cell_size_x: d,
            cell_size_y: d,
        },
    )
    .unwrap()
}

#[test]
fn dem_i16_tiled_pixel_is_point_bilinear_metres_to_feet() {
    let r = read_geotiff(fixture("dem_4326_i16_tiled.tif")).unwrap();
    assert_eq!((r.width, r.height, r.sample_type), (32, 32, SampleType::I16));
    assert_eq!(r.crs, "EPSG:4326");
    assert_eq!(r.raster_type, RasterType::PixelIsPoint);
    assert!((r.origin_x - (-119.005)).abs() < 1e-12 && (r.origin_y - 35.005).abs() < 1e-12);
    assert_eq!(r.nodata, Some(-32768.0));
    assert_eq!(r.data[5 * 32 + 7], -32768.0);
    assert_eq!(r.data[20 * 32 + 30], dem_value(20.0, 30.0) as f32); // second tile column/row
    // Grid centres half-way between pixel centres: (col + 0.5, row + 0.5) for col 10..14, row 20..17.
    let grid = grid_4326(4, 3, -119.0 + 0.01 * 10.0, 35.0 - 0.01 * 20.5, 0.01);
    let el = resample_elevation(std::slice::from_ref(&r), &grid, &ElevationOptions::default()).unwrap();
    for y in 0..3 {
        for x in 0..4 {
            let (col, row) = (10.0 + x as f64 + 0.5, 20.0 - y as f64);
            let want = dem_value(row, col) / FT;
            assert!(
                (f64::from(el[y * 4 + x]) - want).abs() < 1e-2,
                "({x},{y}) {} vs {want}",
                el[y * 4 + x]
            );
        }
    }
    // Explicit units override: feet means no conversion.
    let opts = ElevationOptions {
        units: Some(LengthUnit::Foot),
        ..ElevationOptions::default()
    };
    let el = resample_elevation(std::slice::from_ref(&r), &grid, &opts).unwrap();
    assert!((f64::from(el[0]) - dem_value(20.0, 10.5)).abs() < 1e-3);
}

#[test]
fn dem_nodata_is_dropped_or_reported() {
    let r = read_geotiff(fixture("dem_4326_i16_tiled.tif")).unwrap();
    // Midway between the void (row 5, col 7) and (row 5, col 8): only the valid one counts.
    let g = grid_4326(1, 1, -119.0 + 0.075 - 0.005, 35.0 - 0.05 - 0.005, 0.01);
    let el = resample_elevation(std::slice::from_ref(&r), &g, &ElevationOptions::default()).unwrap();
    assert!(
        (f64::from(el[0]) - dem_value(5.0, 8.0) / FT).abs() < 1e-2,
        "{}",
        el[0]
    );
    // Exactly on the void: nothing valid → Error policy reports it, NearestValid fills from a neighbour.
    let g = grid_4326(3, 1, -119.0 + 0.06 - 0.005, 35.0 - 0.05 - 0.005, 0.01);
    let strict = ElevationOptions {
        nodata: ElevationNoData::Error,
        ..ElevationOptions::default()
    };
    let err = resample_elevation(std::slice::from_ref(&r), &g, &strict).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.starts_with("1 grid cells have no valid elevation (first at cell x=1, y=0)"),
        "{msg}"
    );
    assert!(msg.ends_with("dem_4326_i16_tiled.tif"), "{msg}");
    let el = resample_elevation(std::slice::from_ref(&r), &g, &ElevationOptions::default()).unwrap();
    assert!(
        (f64::from(el[1]) - dem_value(5.0, 6.0) / FT).abs() < 1e-2,
        "{el:?}"
    );
}

#[test]
fn dem_f32_feet_vertical_units_and_nan() {
    let r = read_geotiff(fixture("dem_utm11_f32_feet.tif")).unwrap();
    assert_eq!(r.sample_type, SampleType::F32);
    assert_eq!(r.vertical_unit(), Some(LengthUnit::Foot));
    assert_eq!(r.nodata, None);
    assert!(r.data[2 * 6 + 3].is_nan());
    let g = GridSpec::new(
        1,
        1,
        100.0 / FT,
        GeoReference {
            crs: "EPSG:32611".into(),
            origin_x: 360100.0,
            origin_y: 3770000.0 - 200.0,
            cell_size_x: 100.0,
            cell_size_y: 100.0,
        },
    )
    .unwrap();
    let el = resample_elevation(std::slice::from_ref(&r), &g, &ElevationOptions::default()).unwrap();
    assert!(
        (f64::from(el[0]) - (1000.0 + 2.5 + 0.5)).abs() < 1e-3,
        "{}",
        el[0]
    );
    assert_eq!(r.sample_nearest(360000.0 + 350.0, 3770000.0 - 250.0), None); // the NaN pixel
}

#[test]
fn missing_pixel_scale_names_tag_and_file() {
    let err = read_geotiff(fixture("broken_no_scale_u16.tif")).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.starts_with("GeoTIFF ModelPixelScaleTag (33550): is missing: ")
            && msg.ends_with("broken_no_scale_u16.tif"),
        "{msg}"
    );
}

#[test]
fn missing_projected_cs_key_names_key_and_file() {
    let err = read_geotiff(fixture("broken_no_pcs.tif")).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("GeoKey ProjectedCSTypeGeoKey (3072): is missing"),
        "{msg}"
    );
    assert!(msg.ends_with("broken_no_pcs.tif"), "{msg}");
}

#[test]
fn not_a_tiff_and_missing_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("junk.tif");
    std::fs::write(&p, b"definitely not a tiff").unwrap();
    let msg = read_geotiff(&p).unwrap_err().to_string();
    assert!(msg.starts_with("TIFF: ") && msg.ends_with("junk.tif"), "{msg}");
    let msg = read_geotiff(dir.path().join("nope.tif")).unwrap_err().to_string();
    assert!(
        msg.starts_with("cannot read file: ") && msg.ends_with("nope.tif"),
        "{msg}"
    );
}

#[test]
fn class_validity_per_scheme() {
    use firecast_landscape::geotiff::is_valid_class;
    assert!(is_valid_class(LandCoverScheme::ModisIgbp, 17));
    assert!(!is_valid_class(LandCoverScheme::ModisIgbp, 255));
    assert!(is_valid_class(LandCoverScheme::Fbfm13, 13) && is_valid_class(LandCoverScheme::Fbfm13, 98));
    assert!(!is_valid_class(LandCoverScheme::Fbfm13, 14));
    assert!(is_valid_class(LandCoverScheme::Fbfm40, 102) && is_valid_class(LandCoverScheme::Fbfm40, 204));
    assert!(!is_valid_class(LandCoverScheme::Fbfm40, 110));
}
