use firecast_dataset::time::DayBoundary;
use firecast_dataset::windows::{ExtractConfig, SampleIn, extract};
use firecast_dataset::{DatasetError, Tier};

use crate::{fixtures, utc};

// The fixture grid (make_gridmet.py): GRIDMET cells j = 224.., i = 474...
fn lat(j: usize) -> f64 {
    49.4 - (224 + j) as f64 / 24.0
}
fn lon(i: usize) -> f64 {
    -124.766_666_633_3 + (474 + i) as f64 / 24.0
}

/// The value make_gridmet.py wrote for a variable on a day of the year at a cell.
fn expected(base: f32, doy: u32, j: usize, i: usize) -> f32 {
    base + doy as f32 + j as f32 / 10.0 + i as f32 / 100.0
}

fn sample(id: u32, j: usize, i: usize, time_ms: i64) -> SampleIn {
    SampleIn {
        sample_id: id,
        lat: lat(j) + 0.01,
        lon: lon(i) - 0.01,
        time_ms,
        tier: Tier::Positive,
        source_row: Some(u64::from(id)),
    }
}

fn config() -> ExtractConfig {
    ExtractConfig {
        variables: vec!["pr".into(), "tmmx".into()],
        ..Default::default()
    }
}

#[test]
fn windows_cross_the_year_boundary_and_both_dimension_orders() {
    let samples = vec![sample(0, 1, 2, utc(2019, 1, 10, 12))];
    let (t, report) = extract(&samples, &fixtures().join("gridmet"), &config(), true, &|_, _| {}).unwrap();
    assert_eq!(t.n_days, 75);
    assert_eq!(t.first_offset, -60);
    assert_eq!(report.files_read, 4);
    assert_eq!(report.source_hashes.len(), 4);
    let s = &t.samples[0];
    assert_eq!(s.cell, (225, 476));
    assert_eq!(firecast_dataset::time::format_date(s.event_day), "2019-01-10");
    // Day −60 is 2018-11-11 (day of year 315); tmmx 2018 is the (day, lon, lat) float file.
    let first = t.row(0, 0);
    assert!((first[0] - expected(0.0, 315, 1, 2)).abs() < 1e-3, "{first:?}");
    assert!((first[1] - expected(300.0, 315, 1, 2)).abs() < 1e-3, "{first:?}");
    // Day 0 is 2019-01-10 (day 10 of the packed NetCDF-4 files).
    let zero = t.row(0, 60);
    assert!((zero[0] - expected(0.0, 10, 1, 2)).abs() < 1e-3, "{zero:?}");
    assert!((zero[1] - expected(300.0, 10, 1, 2)).abs() < 1e-3, "{zero:?}");
    // Every day in order: day +14 is 2019-01-24.
    let last = t.row(0, 74);
    assert!((last[0] - expected(0.0, 24, 1, 2)).abs() < 1e-3);
}

#[test]
fn the_day_boundary_is_mountain_standard_time_unless_asked_otherwise() {
    // 03:00 UTC on the 10th is still the evening of the 9th in MST.
    let samples = vec![sample(0, 0, 0, utc(2019, 3, 10, 3))];
    let dir = fixtures().join("gridmet");
    let (mst, _) = extract(&samples, &dir, &config(), false, &|_, _| {}).unwrap();
    assert_eq!(
        firecast_dataset::time::format_date(mst.samples[0].event_day),
        "2019-03-09"
    );
    let utc_cfg = ExtractConfig {
        day_boundary: DayBoundary::Utc,
        ..config()
    };
    let (u, _) = extract(&samples, &dir, &utc_cfg, false, &|_, _| {}).unwrap();
    assert_eq!(
        firecast_dataset::time::format_date(u.samples[0].event_day),
        "2019-03-10"
    );
    // Day 0 is day 68 (MST) or 69 (UTC) of 2019.
    assert!((mst.row(0, 60)[0] - expected(0.0, 68, 0, 0)).abs() < 1e-3);
    assert!((u.row(0, 60)[0] - expected(0.0, 69, 0, 0)).abs() < 1e-3);
}

#[test]
fn samples_off_the_grid_or_outside_the_years_are_dropped_and_counted() {
    let samples = vec![
        sample(0, 0, 0, utc(2018, 6, 1, 12)),
        sample(1, 3, 4, utc(2018, 6, 1, 12)), // the masked cell: kept, all missing
        sample(2, 0, 0, utc(2018, 1, 20, 12)), // needs 2017
        sample(3, 0, 0, utc(2019, 12, 25, 12)), // needs 2020
        SampleIn {
            lat: 45.0,
            ..sample(4, 0, 0, utc(2018, 6, 1, 12))
        }, // off the grid
    ];
    let (t, report) = extract(
        &samples,
        &fixtures().join("gridmet"),
        &config(),
        false,
        &|_, _| {},
    )
    .unwrap();
    assert_eq!(
        t.samples.iter().map(|s| s.sample_id).collect::<Vec<_>>(),
        vec![0, 1]
    );
    assert_eq!(report.dropped.get("window_outside_gridmet_years"), Some(&2));
    assert_eq!(report.dropped.get("outside_gridmet_grid"), Some(&1));
    assert_eq!(report.missing_values.get("pr"), Some(&75));
    assert_eq!(report.missing_values.get("tmmx"), Some(&75));
    assert!(t.row(1, 10).iter().all(|v| v.is_nan()));
}

#[test]
fn a_missing_file_or_unknown_variable_is_an_error_that_names_it() {
    let tmp = tempfile::tempdir().unwrap();
    for f in ["pr_2018.nc", "pr_2019.nc", "tmmx_2018.nc"] {
        std::fs::copy(fixtures().join("gridmet").join(f), tmp.path().join(f)).unwrap();
    }
    let samples = vec![sample(0, 0, 0, utc(2019, 1, 10, 12))];
    let err = extract(&samples, tmp.path(), &config(), false, &|_, _| {}).unwrap_err();
    assert!(matches!(err, DatasetError::MissingSource { .. }), "{err}");
    assert!(err.to_string().contains("tmmx_2019.nc"), "{err}");

    let bad = ExtractConfig {
        variables: vec!["pr".into(), "tmax".into()],
        ..Default::default()
    };
    let err = extract(&samples, tmp.path(), &bad, false, &|_, _| {}).unwrap_err();
    assert_eq!(
        err.to_string().split(" (known").next().unwrap(),
        "`variables[1]`: unknown GRIDMET variable `tmax`"
    );
}

/// What a sharded `data.windows` does: the variables gathered in separate ranges and put
/// together give the whole extraction, with every kind of dropped sample (outside the years,
/// off the grid, days missing in a file: `*_2020.nc` are copies of 2019's files, so 2020's
/// days are not in them). The stage's shards and merge are checked end to end by the CLI
/// tests (`tests/cli/ray.rs`).
#[test]
fn variables_gathered_in_ranges_assemble_into_the_whole_extraction() {
    use firecast_dataset::windows::{ExtractPlan, assemble};

    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    for f in ["pr_2018.nc", "pr_2019.nc", "tmmx_2018.nc", "tmmx_2019.nc"] {
        std::fs::copy(fixtures().join("gridmet").join(f), dir.join(f)).unwrap();
    }
    for v in ["pr", "tmmx"] {
        std::fs::copy(
            fixtures().join("gridmet").join(format!("{v}_2019.nc")),
            dir.join(format!("{v}_2020.nc")),
        )
        .unwrap();
    }
    let samples = vec![
        sample(0, 0, 0, utc(2018, 6, 1, 12)),
        sample(1, 3, 4, utc(2018, 6, 1, 12)), // the masked cell: kept, all missing
        sample(2, 1, 2, utc(2019, 1, 10, 12)), // across the year boundary
        sample(3, 0, 0, utc(2018, 1, 20, 12)), // needs 2017
        sample(4, 2, 3, utc(2019, 12, 25, 12)), // needs 2020's days: not in the files
        SampleIn {
            lat: 45.0,
            ..sample(5, 0, 0, utc(2018, 6, 1, 12))
        }, // off the grid
        sample(6, 2, 1, utc(2019, 7, 4, 20)),
    ];
    let (whole, report) = extract(&samples, dir, &config(), true, &|_, _| {}).unwrap();
    assert_eq!(report.samples_out, 4);
    for reason in [
        "window_outside_gridmet_years",
        "outside_gridmet_grid",
        "days_missing_in_gridmet_file",
    ] {
        assert_eq!(report.dropped.get(reason), Some(&1), "{reason}: {report:?}");
    }
    assert_eq!(report.files_read, 6);

    let plan = ExtractPlan::new(&samples, dir, &config()).unwrap();
    let parts = vec![
        plan.gather(0..1, true, &|_, _| {}).unwrap(),
        plan.gather(1..2, true, &|_, _| {}).unwrap(),
    ];
    assert!(parts.iter().all(|p| p.files_read == 3));
    let (joined, joined_report, slots) = assemble(plan.head().clone(), parts.clone()).unwrap();
    assert_eq!(joined_report, report);
    assert_eq!(joined.samples, whole.samples);
    assert_eq!(joined.features, whole.features);
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&joined.values), bits(&whole.values));
    // Slots are positions among the samples with windows: sample 4 (slot 3) was dropped.
    assert_eq!(slots, vec![0, 1, 2, 4]);

    // Parts out of order, or not covering every variable, are refused.
    let swapped = vec![parts[1].clone(), parts[0].clone()];
    assert!(matches!(
        assemble(plan.head().clone(), swapped),
        Err(DatasetError::Shard(_))
    ));
    let err = assemble(plan.head().clone(), vec![parts[0].clone()]).unwrap_err();
    assert_eq!(err.to_string(), "the gathered variables cover 1 of 2");
}
