//! LANDFIRE landscapes: the Worcester, Vermont clip (tests/fixtures/landfire-worcester, EPL-2.0,
//! from pyretechnics' test data) and broken copies of it.

use std::path::{Path, PathBuf};

use firecast_landscape::gridio::{GridPlacement, encode_geotiff_f32};
use firecast_landscape::landfire::{FuelLayer, LandfireError, LandfireFiles, LandfireLandscape, LayerKind};

fn worcester() -> PathBuf {
    std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("tests/fixtures/landfire-worcester/landfire")
}

#[test]
fn reads_every_layer_of_the_worcester_clip() {
    let land = LandfireLandscape::read_dir(&worcester(), FuelLayer::Fbfm40).expect("reads");
    assert_eq!((land.grid.width, land.grid.height), (549, 613));
    assert_eq!(land.grid.crs, "EPSG:5070");
    assert_eq!((land.grid.pixel_dx, land.grid.pixel_dy), (30.0, -30.0));
    assert_eq!(
        (land.grid.origin_x, land.grid.origin_y),
        (1_833_825.0, 2_617_605.0)
    );
    assert_eq!(land.files.len(), 9 - 1, "FBFM13 is not read with --fuel fbfm40");
    // 108,586 cells outside the clip's polygon are nodata in every layer.
    for layer in &land.report.layers {
        assert_eq!(layer.nodata_cells, 108_586, "{}", layer.layer);
    }
    assert_eq!(land.report.fuel_nodata_cells, 108_586);
    let nb: usize = land.report.nonburnable_cells.values().sum();
    let burnable: usize = land.report.burnable_cells.values().sum();
    assert_eq!(nb + burnable + 108_586, 549 * 613);
    assert_eq!(land.report.nonburnable_cells.get(&91), Some(&4321));
    assert_eq!(land.report.nonburnable_cells.get(&98), Some(&1154));
    assert_eq!(land.report.burnable_cells.get(&186), Some(&(134_510 + 51)));
    // Scale factors: canopy height 270 → 27 m, CBD 45 → 0.45 kg/m³, CBH ×10.
    let ch = land.canopy_height_m.as_ref().expect("CH");
    assert!((ch.iter().copied().filter(|v| !v.is_nan()).fold(0.0f32, f32::max) - 27.0).abs() < 1e-5);
    let cbd = land.canopy_bulk_density_kg_m3.as_ref().expect("CBD");
    assert!((cbd.iter().copied().filter(|v| !v.is_nan()).fold(0.0f32, f32::max) - 0.45).abs() < 1e-6);
    let cbh = land.canopy_base_height_m.as_ref().expect("CBH");
    assert!((cbh.iter().copied().filter(|v| !v.is_nan()).fold(0.0f32, f32::max) - 10.0).abs() < 1e-5);
    // Slope stays in percent, aspect −1 marks flat cells.
    let max_slope = land
        .slope_percent
        .iter()
        .copied()
        .filter(|v| !v.is_nan())
        .fold(0.0f32, f32::max);
    assert_eq!(max_slope, 109.0);
    assert!(land.aspect_deg.contains(&-1.0));
}

#[test]
fn reads_fbfm13_too() {
    let land = LandfireLandscape::read_dir(&worcester(), FuelLayer::Fbfm13).expect("reads");
    assert!(land.files.contains_key(&LayerKind::Fbfm13));
    assert!(land.report.burnable_cells.keys().all(|c| (1..=13).contains(c)));
    assert!(
        land.report
            .nonburnable_cells
            .keys()
            .all(|c| (91..=99).contains(c))
    );
}

#[test]
fn file_names_name_layers() {
    assert_eq!(
        LayerKind::from_file_name("LC22_F40_230.tif"),
        Some(LayerKind::Fbfm40)
    );
    assert_eq!(
        LayerKind::from_file_name("LC20_SlpP_220.tif"),
        Some(LayerKind::SlopePercent)
    );
    assert_eq!(
        LayerKind::from_file_name("LC20_SlpD_220.tif"),
        Some(LayerKind::SlopeDegrees)
    );
    assert_eq!(
        LayerKind::from_file_name("LC22_CBD_230.tif"),
        Some(LayerKind::CanopyBulkDensity)
    );
    assert_eq!(LayerKind::from_file_name("notes.txt"), None);
}

/// A copy of the clip's fuel, slope and aspect layers in a temporary folder.
fn copy_clip(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("firecast-landfire-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    let files = LandfireFiles::discover(&worcester()).expect("discover");
    for kind in [LayerKind::Fbfm40, LayerKind::SlopePercent, LayerKind::Aspect] {
        let src = &files.layers[&kind];
        std::fs::copy(src, dir.join(src.file_name().expect("name"))).expect("copy");
    }
    dir
}

fn write_int_grid(path: &Path, width: usize, height: usize, origin_x: f64, values: &[f32]) {
    let placement = GridPlacement {
        width,
        height,
        origin_x,
        origin_y: 2_617_605.0,
        pixel_dx: 30.0,
        pixel_dy: -30.0,
        geokeys: firecast_landscape::gridio::GeoKeyTags::read(
            &LandfireFiles::discover(&worcester()).expect("d").layers[&LayerKind::Aspect],
        )
        .expect("keys"),
    };
    let bytes = encode_geotiff_f32(&placement, values, Some(32767.0)).expect("encode");
    std::fs::write(path, bytes).expect("write");
}

#[test]
fn mismatched_grids_name_both_files() {
    let dir = copy_clip("mismatch");
    let slope = dir.join("LC20_SlpP_220.tif");
    write_int_grid(&slope, 549, 612, 1_833_825.0, &vec![5.0; 549 * 612]);
    let err = LandfireLandscape::read_dir(&dir, FuelLayer::Fbfm40).expect_err("size differs");
    let text = err.to_string();
    assert!(matches!(err, LandfireError::GridMismatch { .. }), "{text}");
    assert!(
        text.contains("LC20_SlpP_220.tif") && text.contains("LC22_F40_230.tif"),
        "{text}"
    );
    assert!(text.contains("549 x 612"), "{text}");

    write_int_grid(&slope, 549, 613, 1_833_855.0, &vec![5.0; 549 * 613]);
    let text = LandfireLandscape::read_dir(&dir, FuelLayer::Fbfm40)
        .expect_err("shifted")
        .to_string();
    assert!(text.contains("transform"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn unknown_fuel_codes_are_counted_and_name_the_cell() {
    let dir = copy_clip("unknown");
    let fuel = dir.join("LC22_F40_230.tif");
    let mut values = vec![102.0f32; 549 * 613];
    values[549 * 7 + 3] = 150.0;
    values[549 * 9 + 1] = 150.0;
    values[549 * 10] = 5.0; // an FBFM13 code in an FBFM40 layer
    values[549 * 11] = 32767.0;
    write_int_grid(&fuel, 549, 613, 1_833_825.0, &values);
    let err = LandfireLandscape::read_dir(&dir, FuelLayer::Fbfm40).expect_err("unknown codes");
    let text = err.to_string();
    match err {
        LandfireError::UnknownFuelCode { count, col, row, .. } => {
            assert_eq!((count, col, row), (3, 3, 7));
        }
        other => panic!("{other}"),
    }
    assert!(
        text.contains("150: 2 cells") && text.contains("5: 1 cells"),
        "{text}"
    );
    assert!(
        text.contains("fbfm40") && text.contains("LC22_F40_230.tif"),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_missing_layer_is_named() {
    let dir = copy_clip("missing");
    std::fs::remove_file(dir.join("LC20_Asp_220.tif")).expect("rm");
    let text = LandfireLandscape::read_dir(&dir, FuelLayer::Fbfm40)
        .expect_err("no aspect")
        .to_string();
    assert!(text.contains("no aspect layer"), "{text}");
    let text = LandfireLandscape::read_dir(&dir, FuelLayer::Fbfm13)
        .expect_err("no fbfm13")
        .to_string();
    assert!(text.contains("no fbfm13 layer"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_corrupt_layer_names_its_file() {
    let dir = copy_clip("corrupt");
    let aspect = dir.join("LC20_Asp_220.tif");
    let bytes = std::fs::read(&aspect).expect("read");
    std::fs::write(&aspect, &bytes[..4096]).expect("truncate");
    let text = LandfireLandscape::read_dir(&dir, FuelLayer::Fbfm40)
        .expect_err("corrupt")
        .to_string();
    assert!(text.contains("LC20_Asp_220.tif"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_truncated_layer_names_the_layer_and_the_first_unreadable_rows() {
    let dir = copy_clip("truncated");
    let aspect = dir.join("LC20_Asp_220.tif");
    let bytes = std::fs::read(&aspect).expect("read");
    // The directory is at the start; cut the strips off half way.
    std::fs::write(&aspect, &bytes[..bytes.len() / 2]).expect("truncate");
    let err = LandfireLandscape::read_dir(&dir, FuelLayer::Fbfm40).expect_err("truncated");
    let text = err.to_string();
    assert!(
        matches!(err, LandfireError::Layer { layer: "aspect", .. }),
        "{text}"
    );
    assert!(text.starts_with("aspect layer: TIFF:"), "{text}");
    assert!(
        text.contains("does not decode: cells from column 0, row "),
        "{text}"
    );
    assert!(text.contains("LC20_Asp_220.tif"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_geographic_crs_is_refused() {
    let dir = copy_clip("geographic");
    let fuel = dir.join("LC22_F40_230.tif");
    let values = firecast_landscape::geotiff::read_geotiff(&fuel)
        .expect("fuel")
        .data;
    let placement = GridPlacement {
        width: 549,
        height: 613,
        origin_x: -72.7,
        origin_y: 44.4,
        pixel_dx: 0.0003,
        pixel_dy: -0.0003,
        geokeys: firecast_landscape::gridio::GeoKeyTags {
            directory: vec![1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, 4326],
            doubles: Vec::new(),
            ascii: String::new(),
        },
    };
    std::fs::write(
        &fuel,
        encode_geotiff_f32(&placement, &values, Some(32767.0)).expect("encode"),
    )
    .expect("write");
    let err = LandfireLandscape::read_dir(&dir, FuelLayer::Fbfm40).expect_err("geographic");
    let text = err.to_string();
    assert!(matches!(err, LandfireError::GeographicCrs { .. }), "{text}");
    assert!(
        text.contains("EPSG:4326 is geographic")
            && text.contains("LC22_F40_230.tif")
            && text.contains("fbfm40"),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn nodata_where_fuel_burns_is_an_error_for_fire_behaviour() {
    let land = LandfireLandscape::read_dir(&worcester(), FuelLayer::Fbfm40).expect("reads");
    land.check_burnable_cells(true)
        .expect("the clip's layers share their nodata cells");
    let dir = copy_clip("needed");
    let slope = dir.join("LC20_SlpP_220.tif");
    let mut values = firecast_landscape::geotiff::read_geotiff(&slope)
        .expect("slope")
        .data;
    // Two burnable cells lose their slope.
    let burnable: Vec<usize> = land
        .fuel
        .iter()
        .enumerate()
        .filter(|(_, f)| f.is_some_and(|c| !(91..=99).contains(&c)))
        .map(|(i, _)| i)
        .take(2)
        .collect();
    for &i in &burnable {
        values[i] = 32767.0;
    }
    write_int_grid(&slope, 549, 613, 1_833_825.0, &values);
    let land = LandfireLandscape::read_dir(&dir, FuelLayer::Fbfm40).expect("reads: nodata is counted");
    assert_eq!(land.report.layers[1].nodata_cells, 108_586 + 2);
    let err = land.check_burnable_cells(false).expect_err("needed");
    let text = err.to_string();
    match err {
        LandfireError::NodataAtBurnableCell {
            layer,
            count,
            col,
            row,
            ..
        } => {
            assert_eq!((layer, count), ("slope (percent)", 2));
            assert_eq!((col, row), (burnable[0] % 549, burnable[0] / 549));
        }
        other => panic!("{other}"),
    }
    assert!(text.contains("LC20_SlpP_220.tif"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}
