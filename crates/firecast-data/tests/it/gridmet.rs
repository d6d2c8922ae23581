//! GRIDMET reader against fixtures written by Python netCDF4 (`tests/fixtures/make_fixtures.py`).

use std::path::PathBuf;

use firecast_data::gridmet::{
    DimOrder, GridmetError, GridmetFile, GridmetVariable, day_to_ymd, parse_day_units, ymd_to_day,
};

const NAN: f32 = f32::NAN;

fn fixture(rel: &str) -> PathBuf {
    std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("tests/fixtures")
    .join(rel)
}

/// Expected vpd_2021.nc, [day][lat][lon], as printed by make_fixtures.py.
#[rustfmt::skip]
const VPD: [f32; 60] = [
    0.5, 0.51, 0.52, 0.53, 0.6, 0.61, 0.62, 0.63, 0.7, 0.71, 0.72, 0.73,
    0.8, 0.81, 0.82, 0.83, 0.9, 0.91, 0.92, 0.93,
    1.5, 1.51, 1.52, 1.53, 1.6, 1.61, 1.62, 1.63, 1.7, 1.71, 1.72, NAN,
    1.8, 1.81, 1.82, 1.83, 1.9, 1.91, 1.92, 1.93,
    2.5, 2.51, 2.52, 2.53, 2.6, 2.61, 2.62, 2.63, 2.7, 2.71, 2.72, 2.73,
    2.8, 2.81, 2.82, 2.83, 400.0, 2.91, 2.92, 2.93,
];

/// Expected pr_2018.nc (both storage orders), [day][lat][lon].
#[rustfmt::skip]
const PR: [f32; 60] = [
    0.0, 0.25, 0.5, 0.75, 1.5, 1.75, 2.0, 2.25, 3.0, 3.25, 3.5, 3.75,
    4.5, NAN, 5.0, 5.25, 6.0, 6.25, 6.5, 6.75,
    10.0, 10.25, 10.5, 10.75, 11.5, 11.75, 12.0, 12.25, 13.0, 13.25, 13.5, 13.75,
    14.5, 14.75, 15.0, 15.25, 16.0, 16.25, 16.5, 16.75,
    20.0, 20.25, 20.5, 20.75, 21.5, 21.75, 22.0, 22.25, 23.0, 23.25, 23.5, 23.75,
    24.5, 24.75, 25.0, 25.25, 26.0, 26.25, 26.5, 26.75,
];

fn assert_close(got: &[f32], want: &[f32], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        if w.is_nan() {
            assert!(g.is_nan(), "{what}[{k}]: got {g}, want NaN");
        } else {
            assert!(
                (g - w).abs() <= 1e-5 * w.abs().max(1.0),
                "{what}[{k}]: got {g}, want {w}"
            );
        }
    }
}

fn all_days(f: &GridmetFile) -> Vec<f32> {
    (0..f.days().len()).flat_map(|t| f.read_day(t).unwrap()).collect()
}

#[test]
fn variable_table() {
    assert_eq!(GridmetVariable::ALL.len(), 16);
    for v in GridmetVariable::ALL {
        assert_eq!(GridmetVariable::from_short_name(v.short_name()), Some(v));
        assert!(!v.netcdf_names().is_empty() && !v.units().is_empty());
        assert_eq!(
            GridmetVariable::from_file_name(v.file_name(2018)),
            Some((v, 2018))
        );
    }
    assert!(GridmetVariable::Bi.netcdf_names().contains(&"burning_index-g"));
    assert!(
        GridmetVariable::Erc
            .netcdf_names()
            .contains(&"energy_release_component_g")
    );
    assert_eq!(GridmetVariable::Tmmx.units(), "K");
    assert_eq!(
        GridmetVariable::from_file_name("/x/pr_2018.nc"),
        Some((GridmetVariable::Pr, 2018))
    );
    assert_eq!(GridmetVariable::from_file_name("pr_18.nc"), None);
    assert_eq!(GridmetVariable::from_file_name("pdsi_2018.nc"), None);
}

#[test]
fn day_conversion() {
    assert_eq!(ymd_to_day(1900, 1, 1), Some(0));
    assert_eq!(ymd_to_day(2018, 1, 1), Some(43099));
    assert_eq!(ymd_to_day(2018, 1, 3), Some(43101));
    assert_eq!(ymd_to_day(2021, 2, 29), None);
    assert_eq!(day_to_ymd(43101), (2018, 1, 3));
    assert_eq!(day_to_ymd(-1), (1899, 12, 31));
    for d in -1000..60_000 {
        let (y, m, dd) = day_to_ymd(d);
        assert_eq!(ymd_to_day(y, m, dd), Some(d));
    }
    assert_eq!(parse_day_units("days since 1900-01-01 00:00:00"), Some(0));
    assert_eq!(parse_day_units("days since 1900-1-1"), Some(0));
    assert_eq!(
        parse_day_units("days since 1979-01-01T00:00:00Z"),
        ymd_to_day(1979, 1, 1)
    );
    assert_eq!(parse_day_units("days since 1900-01-01 12:00:00"), None);
    assert_eq!(parse_day_units("hours since 1900-01-01"), None);
}

#[test]
fn netcdf4_packed_u16_values() {
    let f = GridmetFile::open(fixture("vpd_2021.nc"), GridmetVariable::Vpd).unwrap();
    assert_eq!(f.var_name(), "mean_vapor_pressure_deficit");
    assert_eq!(f.dim_order(), DimOrder::DayLatLon);
    assert_eq!(f.grid_shape(), (5, 4));
    assert_eq!(f.days(), &[44195, 44196, 44197]);
    assert_eq!(f.dates(), vec![(2021, 1, 1), (2021, 1, 2), (2021, 1, 3)]);
    assert!((f.lats()[0] - 49.4).abs() < 1e-12 && (f.lats()[4] - (49.4 - 4.0 / 24.0)).abs() < 1e-12);
    assert!((f.lons()[0] + 124.7666666667).abs() < 1e-12);
    // Masked (_FillValue) -> NaN; raw 40000 > i16::MAX decodes as unsigned.
    assert_close(&all_days(&f), &VPD, "vpd");
    assert!(f.read_day(1).unwrap()[2 * 4 + 3].is_nan());
}

#[test]
fn alternative_spelling_and_short_unsigned() {
    let f = GridmetFile::open(fixture("erc_2021.nc"), GridmetVariable::Erc).unwrap();
    assert_eq!(f.var_name(), "energy_release_component_g");
    let want: Vec<f32> = VPD
        .iter()
        .map(|v| if *v == 400.0 { 4000.0 } else { v * 10.0 })
        .collect();
    assert_close(&all_days(&f), &want, "erc");
}

#[test]
fn classic_both_dimension_orders_agree() {
    let old = GridmetFile::open(fixture("lonlat/pr_2018.nc"), GridmetVariable::Pr).unwrap();
    let new = GridmetFile::open(fixture("latlon/pr_2018.nc"), GridmetVariable::Pr).unwrap();
    assert_eq!(old.dim_order(), DimOrder::DayLonLat);
    assert_eq!(new.dim_order(), DimOrder::DayLatLon);
    assert_eq!(old.days(), &[43099, 43100, 43101]);
    assert_eq!(old.lats(), new.lats());
    assert_eq!(old.lons(), new.lons());
    assert_close(&all_days(&old), &PR, "pr (day, lon, lat)");
    assert_close(&all_days(&new), &PR, "pr (day, lat, lon)");
    let cells = [(3, 1), (0, 0), (4, 3), (2, 1)];
    assert_eq!(
        format!("{:?}", old.gather(&cells, 0..3).unwrap()),
        format!("{:?}", new.gather(&cells, 0..3).unwrap())
    );
}

#[test]
fn nearest_cell() {
    let f = GridmetFile::open(fixture("vpd_2021.nc"), GridmetVariable::Vpd).unwrap();
    let (lat0, lon0) = (49.4, -124.7666666667);
    assert_eq!(f.nearest_cell(lat0, lon0), Some((0, 0)));
    assert_eq!(
        f.nearest_cell(lat0 - 2.0 / 24.0 + 0.01, lon0 + 3.0 / 24.0 - 0.01),
        Some((2, 3))
    );
    // Within half a cell of the outer centres is inside; beyond is rejected, not snapped.
    assert_eq!(f.nearest_cell(lat0 + 0.4 / 24.0, lon0 - 0.4 / 24.0), Some((0, 0)));
    assert_eq!(f.nearest_cell(lat0 + 0.6 / 24.0, lon0), None);
    assert_eq!(f.nearest_cell(lat0, lon0 + 3.6 / 24.0), None);
    assert_eq!(f.nearest_cell(lat0 - 4.6 / 24.0, lon0), None);
    assert_eq!(f.nearest_cell(40.0, -100.0), None);
    assert_eq!(f.nearest_cell(f64::NAN, lon0), None);
    // Same answer with the old storage order (coordinates are read by name).
    let old = GridmetFile::open(fixture("lonlat/pr_2018.nc"), GridmetVariable::Pr).unwrap();
    assert_eq!(
        old.nearest_cell(lat0 - 3.0 / 24.0, lon0 + 1.0 / 24.0),
        Some((3, 1))
    );
}

#[test]
fn gather_equals_per_point_reads() {
    for (rel, var) in [
        ("vpd_2021.nc", GridmetVariable::Vpd),
        ("erc_2021.nc", GridmetVariable::Erc),
        ("lonlat/pr_2018.nc", GridmetVariable::Pr),
        ("latlon/pr_2018.nc", GridmetVariable::Pr),
    ] {
        let f = GridmetFile::open(fixture(rel), var).unwrap();
        let cells = [(2, 3), (0, 0), (4, 0), (2, 3), (3, 1), (1, 2)];
        for range in [0..3, 1..3, 2..2] {
            let got = f.gather(&cells, range.clone()).unwrap();
            assert_eq!(got.len(), cells.len());
            for (series, &(j, i)) in got.iter().zip(&cells) {
                let want: Vec<f32> = range.clone().map(|t| f.read_day(t).unwrap()[j * 4 + i]).collect();
                assert_close(series, &want, rel);
            }
        }
        assert!(matches!(
            f.gather(&[(5, 0)], 0..1),
            Err(GridmetError::OutOfRange { .. })
        ));
        assert!(matches!(
            f.gather(&[(0, 0)], 0..4),
            Err(GridmetError::OutOfRange { .. })
        ));
        assert!(matches!(f.read_day(3), Err(GridmetError::OutOfRange { .. })));
    }
}

fn err_text(rel: &str, var: GridmetVariable) -> (GridmetError, String) {
    let e = GridmetFile::open(fixture(rel), var).unwrap_err();
    let s = e.to_string();
    (e, s)
}

#[test]
fn error_missing_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tmmn_1999.nc");
    let e = GridmetFile::open(&path, GridmetVariable::Tmmn).unwrap_err();
    assert!(matches!(e, GridmetError::MissingFile { .. }));
    assert!(e.to_string().contains("tmmn_1999.nc"), "{e}");
}

#[test]
fn error_missing_variable_lists_file_contents() {
    let (e, s) = err_text("vpd_2021.nc", GridmetVariable::Pr);
    assert!(matches!(e, GridmetError::MissingVariable { .. }));
    for needle in [
        "vpd_2021.nc",
        "`pr`",
        "precipitation_amount",
        "mean_vapor_pressure_deficit",
        "lat",
    ] {
        assert!(s.contains(needle), "{needle:?} not in {s}");
    }
}

#[test]
fn error_wrong_dimension_names_file_and_dimension() {
    let (e, s) = err_text("bad_dim/tmmx_2021.nc", GridmetVariable::Tmmx);
    assert!(
        matches!(e, GridmetError::MissingDimension { dimension: "lat", .. }),
        "{e:?}"
    );
    for needle in ["tmmx_2021.nc", "air_temperature", "`lat`", "\"y\"", "\"x\""] {
        assert!(s.contains(needle), "{needle:?} not in {s}");
    }
}

#[test]
fn error_unparsable_day_units() {
    let (e, s) = err_text("bad_units/fm100_2021.nc", GridmetVariable::Fm100);
    assert!(matches!(e, GridmetError::DayUnits { .. }), "{e:?}");
    for needle in ["fm100_2021.nc", "`day`", "fortnights after the flood"] {
        assert!(s.contains(needle), "{needle:?} not in {s}");
    }
}

#[test]
fn error_not_netcdf() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("srad_2020.nc");
    std::fs::write(&path, b"this is not a netcdf file").unwrap();
    let e = GridmetFile::open(&path, GridmetVariable::Srad).unwrap_err();
    assert!(matches!(e, GridmetError::Read { .. }));
    assert!(e.to_string().contains("srad_2020.nc"), "{e}");
}
