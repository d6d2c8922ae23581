use std::fmt::Write as _;

use firecast_dataset::kaggle::{
    ImportConfig, KaggleLicense, KaggleMetadata, Policy, import, validate_metadata,
};

const HEADER: &str =
    "latitude,longitude,datetime,Wildfire,pr,rmax,rmin,sph,srad,tmmn,tmmx,vs,bi,fm100,fm1000,erc,etr,pet,vpd";

/// 75 rows of one window starting at `first` (a date), with labels and an optional fill row.
fn window(
    csv: &mut String,
    lat: f64,
    lon: f64,
    first: (i32, u32, u32),
    positive: bool,
    rows: usize,
    fill_row: Option<usize>,
) {
    let day0 = firecast_data::gridmet::ymd_to_day(first.0, first.1, first.2).unwrap();
    for r in 0..rows {
        let date = firecast_dataset::time::format_date(day0 + r as i32);
        let label = if positive && r >= 60 { "Yes" } else { "No" };
        let values: Vec<String> = (0..15)
            .map(|f| {
                if Some(r) == fill_row {
                    "32767.0".into()
                } else {
                    format!("{}.5", f + r)
                }
            })
            .collect();
        let _ = writeln!(csv, "{lat},{lon},{date},{label},{}", values.join(","));
    }
}

fn sample_csv() -> String {
    let mut csv = format!("{HEADER}\n");
    window(&mut csv, 25.26027, -80.80099, (2016, 2, 10), true, 75, None); // good positive
    window(&mut csv, 40.1, -105.2, (2017, 5, 1), false, 75, None); // good negative
    window(&mut csv, 41.0, -110.0, (2018, 1, 1), false, 40, None); // cut short
    window(&mut csv, 42.0, -111.0, (2018, 3, 1), false, 75, Some(10)); // a fill row
    window(&mut csv, 43.0, -112.0, (2019, 1, 1), false, 75, None); // overlaps the next one
    window(&mut csv, 43.0, -112.0, (2019, 2, 1), true, 75, None);
    // Contradictory: a negative-looking window with one Yes in the middle.
    let mut bad = String::new();
    window(&mut bad, 44.0, -113.0, (2020, 1, 1), false, 75, None);
    csv.push_str(&bad.replacen(",No,", ",Yes,", 31).replacen(",Yes,", ",No,", 30));
    csv
}

#[test]
fn import_detects_and_counts_every_flaw() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("Wildfire_Dataset.csv");
    std::fs::write(&path, sample_csv()).unwrap();
    let (t, r) = import(&path, &ImportConfig::default(), &mut |_| {}).unwrap();
    assert_eq!(r.rows, 6 * 75 + 40);
    assert_eq!(r.windows, 7);
    assert_eq!(r.complete_windows, 6);
    assert_eq!((r.cut_short_windows, r.cut_short_rows), (1, 40));
    assert_eq!((r.fill_rows, r.fill_windows), (1, 1));
    assert_eq!(r.overlapping_windows, 2);
    assert_eq!(r.duplicate_place_dates, 75 - 31);
    assert_eq!(r.contradictory_windows, 1);
    assert_eq!((r.kept_windows, r.kept_positive, r.kept_negative), (2, 1, 1));
    assert_eq!(t.n_days, 75);
    assert_eq!(t.first_offset, -60);
    // Row 61 is the event day.
    assert_eq!(
        firecast_dataset::time::format_date(t.samples[0].event_day),
        "2016-04-10"
    );
    assert_eq!(t.row(0, 3)[2], 5.5);
    // Keeping fill windows turns the sentinel into missing values.
    let keep = ImportConfig {
        fill_windows: Policy::Keep,
        ..Default::default()
    };
    let (t, r) = import(&path, &keep, &mut |_| {}).unwrap();
    assert_eq!(r.kept_windows, 3);
    let fill = t.samples.iter().position(|s| s.lat == 42.0).unwrap();
    assert!(t.row(fill, 10).iter().all(|v| v.is_nan()));
    assert!(t.row(fill, 11).iter().all(|v| !v.is_nan()));
}

#[test]
fn a_malformed_row_or_missing_column_is_an_error_naming_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.csv");
    let mut csv = format!("{HEADER}\n");
    window(&mut csv, 40.0, -105.0, (2016, 1, 1), false, 3, None);
    csv.push_str("40.0,-105.0,2016-01-04,Maybe,1,2,3,4,5,6,7,8,9,10,11,12,13,14,15\n");
    std::fs::write(&path, csv).unwrap();
    let err = import(&path, &ImportConfig::default(), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert_eq!(
        err,
        format!("{}:5: column `Wildfire`: cannot read `Maybe`", path.display())
    );

    std::fs::write(&path, "latitude,longitude,datetime\n1,2,2016-01-01\n").unwrap();
    let err = import(&path, &ImportConfig::default(), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with(&format!("{}:1: no column `Wildfire`", path.display())),
        "{err}"
    );
}

#[test]
fn metadata_validation_applies_the_kaggle_client_rules() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("a.csv"), "x\n").unwrap();
    let mut meta = KaggleMetadata {
        title: "US wildfire ignitions".into(),
        subtitle: Some("too short".into()),
        description: String::new(),
        id: "someone/fires".into(),
        licenses: vec![
            KaggleLicense {
                name: "CC-BY-4.0".into(),
            },
            KaggleLicense { name: "MIT".into() },
        ],
        keywords: vec![],
        resources: vec![firecast_dataset::kaggle::KaggleResource {
            path: "missing.csv".into(),
            description: String::new(),
            schema: None,
        }],
    };
    let problems = validate_metadata(&meta, dir.path());
    assert_eq!(problems.len(), 5, "{problems:#?}");
    assert!(problems[0].starts_with("id: slug `fires` must be 6 to 50 characters"));
    assert!(problems.iter().any(|p| p.starts_with("subtitle:")));
    assert!(problems.iter().any(|p| p.starts_with("licenses: exactly one")));
    assert!(
        problems
            .iter()
            .any(|p| p.starts_with("licenses: unknown licence `MIT`"))
    );
    assert!(problems.iter().any(|p| p.starts_with("resources[0].path")));
    meta.id = "someone/us-wildfire-ignitions".into();
    meta.subtitle = Some("Daily GRIDMET windows around IRWIN ignitions".into());
    meta.licenses.truncate(1);
    meta.resources[0].path = "a.csv".into();
    assert!(validate_metadata(&meta, dir.path()).is_empty());
}
