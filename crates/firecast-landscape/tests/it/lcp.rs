//! FARSITE/FlamMap `.lcp` landscapes against the same layers read from LANDFIRE's GeoTIFFs.
//!
//! The `.lcp` files are written by an independent writer, GDAL's LCP driver (rasterio 1.4.4,
//! `tests/fixtures/make_lcp.py`): the committed crop of the Worcester clip
//! (`tests/fixtures/landfire-worcester/lcp/worcester_crop.lcp`, EPL-2.0 like its source) and,
//! at test time with the project's venv, the other units an `.lcp` header can declare.

use std::path::{Path, PathBuf};

use firecast_landscape::landfire::{FuelLayer, LandfireError, LandfireLandscape, LayerKind};
use firecast_landscape::lcp::{LCP_HEADER_BYTES, LcpHeader};

fn fixtures() -> PathBuf {
    std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("tests/fixtures")
}

fn worcester() -> PathBuf {
    fixtures().join("landfire-worcester/landfire")
}

fn crop() -> PathBuf {
    fixtures().join("landfire-worcester/lcp/worcester_crop.lcp")
}

/// The crop's window in the clip: column, row, width, height (make_lcp.py --window).
const WINDOW: (usize, usize, usize, usize) = (70, 400, 48, 40);

/// The project's Python (`cargo xtask setup`), with rasterio.
fn python() -> PathBuf {
    firecast_testkit::python_with(&["rasterio"])
}

/// Write an `.lcp` of the Worcester layers with GDAL, in the given units.
fn gdal_lcp(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let run = std::process::Command::new(python())
        .arg(fixtures().join("make_lcp.py"))
        .arg(worcester())
        .arg(&out)
        .args(args)
        .output()
        .expect("python runs");
    assert!(
        run.status.success(),
        "make_lcp.py {args:?}: {}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    out
}

/// The window of a whole-clip layer, row by row.
fn window<T: Copy>(values: &[T], (col, row, w, h): (usize, usize, usize, usize)) -> Vec<T> {
    (row..row + h)
        .flat_map(|r| values[r * 549 + col..r * 549 + col + w].to_vec())
        .collect()
}

fn same_bits(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
}

/// Percent slope as FlamMap's `.lcp` keeps it: whole degrees.
fn whole_degrees(percent: f32) -> f32 {
    if percent.is_nan() {
        return f32::NAN;
    }
    let degrees = (f64::from(percent) / 100.0).atan().to_degrees().round();
    (degrees.to_radians().tan() * 100.0) as f32
}

fn assert_close(what: &str, lcp: &[f32], tif: &[f32], tol: f32) {
    assert_eq!(lcp.len(), tif.len(), "{what}");
    for (i, (a, b)) in lcp.iter().zip(tif).enumerate() {
        assert!(
            (a.is_nan() && b.is_nan()) || (a - b).abs() <= tol,
            "{what}: cell {i}: lcp {a} against GeoTIFF {b}"
        );
    }
}

#[test]
fn the_committed_crop_reads_as_the_geotiff_layers_of_its_window() {
    let tif = LandfireLandscape::read_dir(&worcester(), FuelLayer::Fbfm40).expect("GeoTIFFs");
    let lcp = LandfireLandscape::read_lcp(&crop(), FuelLayer::Fbfm40).expect("lcp");
    let (col, row, w, h) = WINDOW;
    assert_eq!((lcp.grid.width, lcp.grid.height), (w, h));
    assert_eq!(lcp.grid.crs, "EPSG:5070", "from the .prj GDAL wrote");
    assert_eq!(
        (lcp.grid.origin_x, lcp.grid.origin_y),
        (
            tif.grid.origin_x + col as f64 * 30.0,
            tif.grid.origin_y - row as f64 * 30.0
        )
    );
    assert_eq!((lcp.grid.pixel_dx, lcp.grid.pixel_dy), (30.0, -30.0));
    assert_eq!(&lcp.grid.geokeys.directory[12..16], &[3072, 0, 1, 5070]);
    assert_eq!(lcp.report.format, "FARSITE .lcp");
    assert_eq!(
        lcp.report.stored_units["slope (degrees)"],
        "degrees (converted to percent)"
    );
    assert!(lcp.files.values().all(|p| p == &crop()));

    assert_eq!(lcp.fuel, window(&tif.fuel, WINDOW));
    assert!(same_bits(&lcp.aspect_deg, &window(&tif.aspect_deg, WINDOW)));
    assert!(lcp.aspect_deg.contains(&-1.0), "the crop holds flat cells");
    for (name, a, b) in [
        ("elevation", &lcp.elevation_m, &tif.elevation_m),
        ("canopy cover", &lcp.canopy_cover_pct, &tif.canopy_cover_pct),
        ("canopy height", &lcp.canopy_height_m, &tif.canopy_height_m),
        (
            "canopy base height",
            &lcp.canopy_base_height_m,
            &tif.canopy_base_height_m,
        ),
        (
            "canopy bulk density",
            &lcp.canopy_bulk_density_kg_m3,
            &tif.canopy_bulk_density_kg_m3,
        ),
    ] {
        let (a, b) = (a.as_ref().expect(name), b.as_ref().expect(name));
        assert!(same_bits(a, &window(b, WINDOW)), "{name}");
    }
    // Slope: the .lcp keeps whole degrees; read back to percent it is LANDFIRE's percent
    // rounded through whole degrees.
    let rounded: Vec<f32> = window(&tif.slope_percent, WINDOW)
        .into_iter()
        .map(whole_degrees)
        .collect();
    assert_close("slope", &lcp.slope_percent, &rounded, 1e-4);
    // Nodata: the cells outside the clip's outline, in every layer.
    let nodata = lcp.fuel.iter().filter(|f| f.is_none()).count();
    assert_eq!(
        nodata,
        window(&tif.fuel, WINDOW).iter().filter(|f| f.is_none()).count()
    );
    assert!(nodata > 0);
    assert!(
        lcp.report.layers.iter().all(|l| l.nodata_cells == nodata),
        "{:?}",
        lcp.report.layers
    );
    assert!(lcp.report.nonburnable_cells.values().sum::<usize>() > 0);
    lcp.check_burnable_cells(true)
        .expect("every burnable cell has its layers");

    // A folder holding the one .lcp reads the same.
    let via_folder =
        LandfireLandscape::read_path(crop().parent().expect("dir"), FuelLayer::Fbfm40).expect("folder");
    assert_eq!(
        (&via_folder.fuel, &via_folder.files, &via_folder.grid),
        (&lcp.fuel, &lcp.files, &lcp.grid)
    );
    assert!(same_bits(&via_folder.slope_percent, &lcp.slope_percent));
}

#[test]
fn gdal_lcps_in_every_unit_read_as_the_geotiff_layers() {
    let dir = tempfile::tempdir().expect("tmp");
    let tif = LandfireLandscape::read_dir(&worcester(), FuelLayer::Fbfm40).expect("GeoTIFFs");
    let win = "70,400,48,40";

    // Percent slope, LANDFIRE's own units otherwise: every layer equal, bit for bit.
    let percent = gdal_lcp(
        dir.path(),
        "percent.lcp",
        &["--window", win, "--slope", "percent"],
    );
    let lcp = LandfireLandscape::read_lcp(&percent, FuelLayer::Fbfm40).expect("percent");
    assert!(same_bits(&lcp.slope_percent, &window(&tif.slope_percent, WINDOW)));
    assert_eq!(lcp.fuel, window(&tif.fuel, WINDOW));
    assert!(lcp.files.contains_key(&LayerKind::SlopePercent));

    // Feet, feet x 10, lb/ft3 x 1000 and GRASS degrees: converted back within the rounding
    // of the units written.
    let imperial = gdal_lcp(
        dir.path(),
        "imperial.lcp",
        &[
            "--window",
            win,
            "--slope",
            "percent",
            "--elevation",
            "feet",
            "--height",
            "feet-x10",
            "--cbd",
            "lb-x1000",
            "--aspect",
            "grass-degrees",
        ],
    );
    let lcp = LandfireLandscape::read_lcp(&imperial, FuelLayer::Fbfm40).expect("imperial");
    assert_eq!(lcp.report.stored_units["elevation"], "ft (converted to m)");
    assert_eq!(
        lcp.report.stored_units["canopy height"],
        "ft x 10 (converted to m)"
    );
    assert_eq!(
        lcp.report.stored_units["canopy bulk density"],
        "lb/ft3 x 1000 (converted to kg/m3)"
    );
    let w = |v: &Option<Vec<f32>>| window(v.as_ref().expect("layer"), WINDOW);
    assert_close(
        "elevation",
        lcp.elevation_m.as_ref().expect("elev"),
        &w(&tif.elevation_m),
        0.1525,
    );
    assert_close(
        "canopy height",
        lcp.canopy_height_m.as_ref().expect("ch"),
        &w(&tif.canopy_height_m),
        0.01525,
    );
    assert_close(
        "canopy base height",
        lcp.canopy_base_height_m.as_ref().expect("cbh"),
        &w(&tif.canopy_base_height_m),
        0.01525,
    );
    // Half a thousandth of a lb/ft3.
    assert_close(
        "canopy bulk density",
        lcp.canopy_bulk_density_kg_m3.as_ref().expect("cbd"),
        &w(&tif.canopy_bulk_density_kg_m3),
        0.0081,
    );
    // GRASS degrees have no flat marker: LANDFIRE's flat cells (-1) went in as 0, east.
    for (a, b) in lcp.aspect_deg.iter().zip(window(&tif.aspect_deg, WINDOW)) {
        if b == -1.0 {
            assert_eq!(*a, 90.0);
        } else if !b.is_nan() {
            assert_eq!(a.rem_euclid(360.0), b.rem_euclid(360.0));
        }
    }

    // GRASS aspect categories, canopy cover categories, no crown bands.
    let classes = gdal_lcp(
        dir.path(),
        "classes.lcp",
        &[
            "--window",
            win,
            "--aspect",
            "grass-categories",
            "--cover",
            "categories",
            "--no-crown",
        ],
    );
    let lcp = LandfireLandscape::read_lcp(&classes, FuelLayer::Fbfm40).expect("classes");
    assert!(lcp.canopy_height_m.is_none() && lcp.canopy_bulk_density_kg_m3.is_none());
    for (a, b) in lcp.aspect_deg.iter().zip(window(&tif.aspect_deg, WINDOW)) {
        if b == -1.0 {
            assert_eq!(*a, -1.0, "category 25 is flat");
        } else if !b.is_nan() {
            let d = (a - b).rem_euclid(360.0);
            assert!(d.min(360.0 - d) <= 7.5, "{a} against {b}");
        }
    }
    for (a, b) in lcp
        .canopy_cover_pct
        .as_ref()
        .expect("cc")
        .iter()
        .zip(w(&tif.canopy_cover_pct))
    {
        let farsite = match b {
            b if b.is_nan() => f32::NAN,
            0.0 => 0.0,
            b if b <= 20.0 => 10.0,
            b if b <= 50.0 => 30.0,
            b if b <= 80.0 => 60.0,
            _ => 75.0,
        };
        assert!(same_bits(&[*a], &[farsite]), "{a} from {b}");
    }

    // GDAL reads back what it wrote, and so does the header parser: the whole clip.
    let full = gdal_lcp(dir.path(), "full.lcp", &[]);
    let bytes = std::fs::read(&full).expect("read");
    let header = LcpHeader::parse(&bytes, &full).expect("header");
    assert_eq!((header.width, header.height, header.bands()), (549, 613, 8));
    assert_eq!(header.latitude, 46);
    assert_eq!(bytes.len(), LCP_HEADER_BYTES + 549 * 613 * 8 * 2);
    let lcp = LandfireLandscape::read_lcp(&full, FuelLayer::Fbfm40).expect("full");
    assert_eq!(lcp.fuel, tif.fuel);
    assert_eq!(lcp.report.burnable_cells, tif.report.burnable_cells);
    assert_eq!(lcp.report.nonburnable_cells, tif.report.nonburnable_cells);
}

/// A copy of the committed crop (and its .prj) in a temporary folder.
fn crop_copy(dir: &Path) -> PathBuf {
    let lcp = dir.join("crop.lcp");
    std::fs::copy(crop(), &lcp).expect("copy");
    std::fs::copy(crop().with_extension("prj"), dir.join("crop.prj")).expect("copy prj");
    lcp
}

/// Overwrite band `band` of cell (col, row) of the crop.
fn poke(lcp: &Path, col: usize, row: usize, band: usize, value: i16) {
    let mut bytes = std::fs::read(lcp).expect("read");
    let at = LCP_HEADER_BYTES + ((row * WINDOW.2 + col) * 8 + band) * 2;
    bytes[at..at + 2].copy_from_slice(&value.to_le_bytes());
    std::fs::write(lcp, bytes).expect("write");
}

#[test]
fn a_truncated_or_corrupt_lcp_names_the_file_and_the_cells() {
    let dir = tempfile::tempdir().expect("tmp");
    let lcp = crop_copy(dir.path());
    let bytes = std::fs::read(&lcp).expect("read");
    // 1,000 bytes of cells: 62 whole cells of 8 bands; the 63rd is column 14 of row 1.
    std::fs::write(&lcp, &bytes[..LCP_HEADER_BYTES + 1000]).expect("truncate");
    let err = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm40).expect_err("truncated");
    let text = err.to_string();
    assert!(
        matches!(err, LandfireError::LcpTruncated { col: 14, row: 1, .. }),
        "{text}"
    );
    assert!(
        text.contains("crop.lcp") && text.contains("48 x 40 grid of 8 int16 bands"),
        "{text}"
    );
    std::fs::write(&lcp, &bytes[..5000]).expect("truncate the header");
    let text = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm40)
        .expect_err("no header")
        .to_string();
    assert!(text.contains("fewer than the 7316-byte header"), "{text}");

    let mut broken = bytes.clone();
    broken[0] = 22;
    std::fs::write(&lcp, &broken).expect("write");
    let text = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm40)
        .expect_err("flag")
        .to_string();
    assert!(
        text.contains("crown fuels flag (byte 0): 22 is neither 20") && text.contains("crop.lcp"),
        "{text}"
    );
    let mut broken = bytes.clone();
    broken[4238..4240].copy_from_slice(&9i16.to_le_bytes());
    std::fs::write(&lcp, &broken).expect("write");
    let text = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm40)
        .expect_err("unit")
        .to_string();
    assert!(text.contains("PUnits (byte 4238): unit code 9"), "{text}");
}

#[test]
fn bad_cells_of_an_lcp_name_the_layer_and_the_cell() {
    let dir = tempfile::tempdir().expect("tmp");
    let lcp = crop_copy(dir.path());
    let pristine = std::fs::read(&lcp).expect("read");

    // Unknown fuel codes, counted, the first cell named.
    poke(&lcp, 5, 3, 3, 150);
    poke(&lcp, 7, 9, 3, 150);
    let err = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm40).expect_err("unknown");
    let text = err.to_string();
    assert!(
        matches!(
            err,
            LandfireError::UnknownFuelCode {
                count: 2,
                col: 5,
                row: 3,
                ..
            }
        ),
        "{text}"
    );
    assert!(
        text.contains("150: 2 cells") && text.contains("crop.lcp"),
        "{text}"
    );
    // FBFM40 codes read as FBFM13: the message says so.
    std::fs::write(&lcp, &pristine).expect("restore");
    let text = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm13)
        .expect_err("other scheme")
        .to_string();
    assert!(text.contains("every one of them is an fbfm40 code"), "{text}");

    // An aspect that is no azimuth.
    poke(&lcp, 2, 4, 2, 400);
    let err = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm40).expect_err("aspect");
    assert!(
        matches!(
            err,
            LandfireError::BadValue {
                layer: "aspect",
                col: 2,
                row: 4,
                ..
            }
        ),
        "{err}"
    );
    std::fs::write(&lcp, &pristine).expect("restore");

    // Nodata slope at a burnable cell: readable, but not usable for fire behaviour.
    let land = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm40).expect("reads");
    let i = land
        .fuel
        .iter()
        .position(|f| f.is_some_and(|c| c > 100))
        .expect("a burnable cell");
    poke(&lcp, i % 48, i / 48, 1, -9999);
    let land = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm40).expect("reads");
    let err = land.check_burnable_cells(true).expect_err("needed");
    let text = err.to_string();
    assert!(
        matches!(&err, LandfireError::NodataAtBurnableCell { layer: "slope (degrees)", count: 1, col, row, .. }
            if (*col, *row) == (i % 48, i / 48)),
        "{text}"
    );
    assert!(text.contains("crop.lcp"), "{text}");
}

#[test]
fn the_prj_decides_the_crs() {
    let dir = tempfile::tempdir().expect("tmp");
    let lcp = crop_copy(dir.path());
    let prj = dir.path().join("crop.prj");

    // Geographic: refused.
    std::fs::write(
        &prj,
        r#"GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#,
    )
    .expect("write");
    let err = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm40).expect_err("geographic");
    assert!(matches!(err, LandfireError::GeographicCrs { .. }), "{err}");
    assert!(err.to_string().contains("crop.prj"), "{err}");

    // A CRS in feet where the header says metres.
    let albers = std::fs::read_to_string(crop().with_extension("prj")).expect("prj");
    std::fs::write(
        &prj,
        albers.replace(r#"UNIT["Meter",1.0]"#, r#"UNIT["Foot",0.3048]"#),
    )
    .expect("write");
    let text = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm40)
        .expect_err("units")
        .to_string();
    assert!(
        text.contains("GridUnits (byte 4204)") && text.contains("0.3048 m"),
        "{text}"
    );

    // Not WKT.
    std::fs::write(&prj, "not a projection").expect("write");
    let text = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm40)
        .expect_err("junk")
        .to_string();
    assert!(
        text.starts_with("projection file:") && text.contains("crop.prj"),
        "{text}"
    );

    // None: the grid's CRS is unknown, and written grids carry none.
    std::fs::remove_file(&prj).expect("rm");
    let land = LandfireLandscape::read_lcp(&lcp, FuelLayer::Fbfm40).expect("reads");
    assert_eq!(land.grid.crs, "UNKNOWN");
    assert!(land.grid.geokeys.directory.is_empty());
}

#[test]
fn a_path_is_a_folder_an_lcp_or_an_error() {
    let dir = tempfile::tempdir().expect("tmp");
    let lcp = crop_copy(dir.path());
    // Beside LANDFIRE layers the folder is ambiguous.
    let fuel = LandfireLandscape::read_dir(&worcester(), FuelLayer::Fbfm40)
        .expect("tif")
        .files[&LayerKind::Fbfm40]
        .clone();
    std::fs::copy(&fuel, dir.path().join("LC22_F40_230.tif")).expect("copy");
    let text = LandfireLandscape::read_path(dir.path(), FuelLayer::Fbfm40)
        .expect_err("both")
        .to_string();
    assert!(text.contains("both LANDFIRE layer GeoTIFFs and"), "{text}");
    // A single GeoTIFF is not a landscape.
    let text = LandfireLandscape::read_path(&dir.path().join("LC22_F40_230.tif"), FuelLayer::Fbfm40)
        .expect_err("tif")
        .to_string();
    assert!(text.contains("a single file, not an .lcp"), "{text}");
    // The .lcp itself reads.
    assert!(LandfireLandscape::read_path(&lcp, FuelLayer::Fbfm40).is_ok());
    // Nothing there.
    let text = LandfireLandscape::read_path(&dir.path().join("nowhere"), FuelLayer::Fbfm40)
        .expect_err("missing")
        .to_string();
    assert!(text.contains("nowhere"), "{text}");
}
