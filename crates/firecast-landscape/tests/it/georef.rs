use firecast_landscape::georef::{tm_forward, tm_inverse};
use firecast_landscape::{Crs, GridSpec, LandCoverScheme, Landscape};
use proptest::prelude::*;

fn landscape(grid: &GridSpec) -> Landscape {
    let n = grid.width * grid.height;
    Landscape::new(
        grid.width,
        grid.height,
        grid.cell_size_ft,
        LandCoverScheme::ModisIgbp,
        vec![1; n],
        vec![0.0; n],
        grid.georef.clone(),
    )
    .unwrap()
}

#[test]
fn crs_parsing() {
    assert_eq!(Crs::parse("EPSG:4326"), Crs::Wgs84Geographic);
    assert_eq!(
        Crs::parse("epsg:32611"),
        Crs::Utm {
            zone: 11,
            north: true
        }
    );
    assert_eq!(
        Crs::parse("EPSG:32756"),
        Crs::Utm {
            zone: 56,
            north: false
        }
    );
    assert_eq!(Crs::parse("EPSG:5070"), Crs::Other("EPSG:5070".into()));
    assert_eq!(Crs::utm_for(34.07, -118.54).code(), "EPSG:32611");
    assert_eq!(Crs::utm_for(-33.87, 151.21).code(), "EPSG:32756");
}

/// Reference values from an independent implementation (Snyder 1987 series, WGS84).
#[test]
fn utm_known_points() {
    let cases = [
        ((43.642567, -79.387139), "EPSG:32617", (630084.3008, 4833438.5859)), // CN Tower
        ((34.07022, -118.54453), "EPSG:32611", (357476.9952, 3771018.1965)),
        ((-33.8688, 151.2093), "EPSG:32756", (334368.6336, 6250948.3453)),
    ];
    for ((lat, lon), code, (e, n)) in cases {
        let crs = Crs::utm_for(lat, lon);
        assert_eq!(crs.code(), code);
        let (x, y) = crs.from_lat_lon(lat, lon).unwrap();
        assert!((x - e).abs() < 0.01 && (y - n).abs() < 0.01, "{code}: {x} {y}");
    }
    assert_eq!(tm_forward(3.0, 0.0, 3.0), (0.0, 0.0));
}

/// NAD83 / CONUS Albers (EPSG:5070, LANDFIRE's grid) against PROJ (rasterio 1.4.4's
/// `rasterio.warp.transform` from EPSG:4326), to a millimetre and 1e-8 degrees.
#[test]
fn conus_albers_known_points() {
    let albers = Crs::parse("EPSG:5070");
    assert!(albers.is_supported());
    let cases = [
        (
            (44.35, -72.55),
            (1_845_526.246_837_990_8, 2_602_196.498_799_409_3),
        ),
        ((23.0, -96.0), (0.0, 0.0)),
        ((40.0, -120.0), (-2_009_423.593_183_725_4, 2_142_068.028_382_626)),
        // The centre of the Worcester LANDFIRE clip's cell (274, 306).
        (
            (44.411_668_017_141_42, -72.573_208_977_519_64),
            (1_842_060.0, 2_608_410.0),
        ),
        (
            (44.885_680_667_496_25, -83.284_132_929_445_22),
            (1_000_000.0, 2_500_000.0),
        ),
    ];
    for ((lat, lon), (x, y)) in cases {
        let (px, py) = albers.from_lat_lon(lat, lon).unwrap();
        assert!(
            (px - x).abs() < 1e-3 && (py - y).abs() < 1e-3,
            "({lat}, {lon}) -> ({px}, {py})"
        );
        let (plat, plon) = albers.to_lat_lon(x, y).unwrap();
        assert!(
            (plat - lat).abs() < 1e-8 && (plon - lon).abs() < 1e-8,
            "({x}, {y}) -> ({plat}, {plon})"
        );
    }
}

#[test]
fn unsupported_crs_gives_nan_and_none() {
    let grid = GridSpec::new(
        2,
        2,
        100.0,
        firecast_landscape::GeoReference {
            crs: "USER-DEFINED:Albers".into(),
            origin_x: 0.0,
            origin_y: 0.0,
            cell_size_x: 30.0,
            cell_size_y: 30.0,
        },
    )
    .unwrap();
    let l = landscape(&grid);
    assert!(l.cell_to_lat_lon(0, 0).0.is_nan());
    assert!(l.try_cell_to_lat_lon(0, 0).is_err());
    assert_eq!(l.lat_lon_to_cell(0.0, 0.0), None);
}

proptest! {
    #[test]
    fn tm_round_trip(lat in -80.0f64..84.0, dlon in -6.0f64..6.0) {
        let (e, n) = tm_forward(0.0, lat, dlon);
        let (lat2, lon2) = tm_inverse(0.0, e, n);
        prop_assert!((lat2 - lat).abs() < 1e-9 && (lon2 - dlon).abs() < 1e-9, "{lat2} {lon2}");
    }

    #[test]
    fn utm_round_trip(lat in -80.0f64..84.0, lon in -180.0f64..180.0) {
        let crs = Crs::utm_for(lat, lon);
        let (x, y) = crs.from_lat_lon(lat, lon).unwrap();
        prop_assert!((100_000.0..900_000.0).contains(&x));
        let (lat2, lon2) = crs.to_lat_lon(x, y).unwrap();
        prop_assert!((lat2 - lat).abs() < 1e-9, "{} vs {}", lat2, lat);
        prop_assert!((lon2 - lon).abs() < 1e-9 || (lon2 - lon).abs() > 359.0);
    }

    #[test]
    fn cell_round_trip_geographic(lat in -70.0f64..70.0, lon in -170.0f64..170.0,
                                  x in 0usize..240, y in 0usize..160) {
        let l = landscape(&GridSpec::geographic_centered(240, 160, 500.0, lat, lon).unwrap());
        let (clat, clon) = l.cell_to_lat_lon(x, y);
        prop_assert_eq!(l.lat_lon_to_cell(clat, clon), Some((x, y)));
    }

    #[test]
    fn cell_round_trip_utm(lat in -79.0f64..83.0, lon in -179.0f64..179.0,
                           x in 0usize..240, y in 0usize..160) {
        let l = landscape(&GridSpec::utm_centered(240, 160, 500.0, lat, lon).unwrap());
        let (clat, clon) = l.cell_to_lat_lon(x, y);
        prop_assert_eq!(l.lat_lon_to_cell(clat, clon), Some((x, y)));
        // The centre of the grid is the requested point (to a millimetre or so).
        let (cx, cy) = Crs::parse(&l.georef.crs).from_lat_lon(lat, lon).unwrap();
        let g = &l.georef;
        prop_assert!((g.origin_x + 120.0 * g.cell_size_x - cx).abs() < 1e-6);
        prop_assert!((g.origin_y + 80.0 * g.cell_size_y - cy).abs() < 1e-6);
    }
}
