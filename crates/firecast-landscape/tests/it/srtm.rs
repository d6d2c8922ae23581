use std::path::Path;

use firecast_landscape::GridSpec;
use firecast_landscape::geotiff::{ElevationNoData, ElevationOptions, RasterType};
use firecast_landscape::srtm::{HGT_VOID, load_elevation, parse_tile_name, read_hgt};

const FT: f64 = 0.3048;

/// A 1201×1201 (3″) tile: value = col + 2·row metres, one void at (row 600, col 600).
fn write_tile(dir: &Path, name: &str) -> std::path::PathBuf {
    let n = 1201usize;
    let mut bytes = Vec::with_capacity(n * n * 2);
    for row in 0..n {
        for col in 0..n {
            let v: i16 = if (row, col) == (600, 600) {
                HGT_VOID
            } else {
                (col + 2 * row) as i16
            };
            bytes.extend_from_slice(&v.to_be_bytes());
        }
    }
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn plane(lat: f64, lon: f64) -> f64 {
    let col = (lon + 119.0) * 1200.0;
    let row = (35.0 - lat) * 1200.0;
    col + 2.0 * row
}

#[test]
fn tile_names() {
    assert_eq!(parse_tile_name("N34W119.hgt"), Some((34, -119)));
    assert_eq!(parse_tile_name("/data/s05e012.HGT"), Some((-5, 12)));
    assert_eq!(parse_tile_name("X34W119.hgt"), None);
    assert_eq!(parse_tile_name("N34W11.hgt"), None);
}

#[test]
fn hgt_parse_and_georef() {
    let dir = tempfile::tempdir().unwrap();
    let r = read_hgt(write_tile(dir.path(), "N34W119.hgt")).unwrap();
    assert_eq!((r.width, r.height, r.crs.as_str()), (1201, 1201, "EPSG:4326"));
    assert_eq!(r.raster_type, RasterType::PixelIsPoint);
    assert_eq!(r.data[0], 0.0);
    assert_eq!(r.data[1200], 1200.0);
    assert_eq!(r.data[1201 * 1200], 2400.0);
    assert_eq!(r.data[600 * 1201 + 600], -32768.0);
    // The SW sample is at exactly (34, −119), the NW at (35, −119).
    assert_eq!(r.sample_nearest(-119.0, 34.0), Some(2400.0));
    assert_eq!(r.sample_nearest(-119.0, 35.0), Some(0.0));
    assert_eq!(r.sample_nearest(-118.0, 35.0), Some(1200.0));
    assert_eq!(r.sample_nearest(-118.75, 34.25), Some(2100.0));
}

#[test]
fn hgt_resamples_like_geotiff() {
    let dir = tempfile::tempdir().unwrap();
    let tile = write_tile(dir.path(), "N34W119.hgt");
    // Geographic grid at an arbitrary point: the plane is reproduced exactly by bilinear.
    let g = GridSpec::geographic_centered(6, 4, 500.0, 34.3, -118.7).unwrap();
    let el = load_elevation(&[&tile], &g, &ElevationOptions::default()).unwrap();
    for y in 0..4 {
        for x in 0..6 {
            let (cx, cy) = g.cell_center(x, y);
            let want = plane(cy, cx) / FT;
            assert!((f64::from(el[y * 6 + x]) - want).abs() < 0.05, "({x},{y})");
        }
    }
    // UTM grid over the tile: each cell matches the plane at its own lat/lon.
    let g = GridSpec::utm_centered(5, 5, 500.0, 34.4, -118.6).unwrap();
    let el = load_elevation(&[&tile], &g, &ElevationOptions::default()).unwrap();
    let land = firecast_landscape::Landscape::new(
        5,
        5,
        500.0,
        firecast_landscape::LandCoverScheme::ModisIgbp,
        vec![1; 25],
        el.clone(),
        g.georef.clone(),
    )
    .unwrap();
    for y in 0..5 {
        for x in 0..5 {
            let (lat, lon) = land.cell_to_lat_lon(x, y);
            assert!((f64::from(el[y * 5 + x]) - plane(lat, lon) / FT).abs() < 0.05);
        }
    }
}

#[test]
fn hgt_void_policy_and_bad_files() {
    let dir = tempfile::tempdir().unwrap();
    let tile = write_tile(dir.path(), "N34W119.hgt");
    // One cell exactly on the void sample (lat 34.5, lon −118.5).
    let g = GridSpec::geographic_centered(3, 1, 250.0, 34.5, -118.5).unwrap();
    let strict = ElevationOptions {
        nodata: ElevationNoData::Error,
        ..ElevationOptions::default()
    };
    let msg = load_elevation(&[&tile], &g, &strict).unwrap_err().to_string();
    assert!(
        msg.contains("no valid elevation") && msg.ends_with("N34W119.hgt"),
        "{msg}"
    );

    let bad = dir.path().join("N10E010.hgt");
    std::fs::write(&bad, [0u8; 7]).unwrap();
    let msg = read_hgt(&bad).unwrap_err().to_string();
    assert!(
        msg.starts_with("SRTM hgt: odd length 7 bytes: ") && msg.ends_with("N10E010.hgt"),
        "{msg}"
    );
    let badname = dir.path().join("tile.hgt");
    std::fs::write(&badname, [0u8; 8]).unwrap();
    assert!(
        read_hgt(&badname)
            .unwrap_err()
            .to_string()
            .contains("not a tile name")
    );
    // Small square tiles are accepted with the same corner rule.
    let small = dir.path().join("N00E000.hgt");
    let vals: [i16; 4] = [10, 20, 30, 40];
    std::fs::write(
        &small,
        vals.iter().flat_map(|v| v.to_be_bytes()).collect::<Vec<u8>>(),
    )
    .unwrap();
    let r = read_hgt(&small).unwrap();
    assert_eq!(r.sample_bilinear(0.5, 0.5), Some(25.0));
    assert_eq!(r.sample_nearest(0.0, 0.0), Some(30.0));
}
