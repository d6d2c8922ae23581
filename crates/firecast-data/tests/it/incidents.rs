//! IRWIN/WFIGS incident reader against hand-made fixtures (`tests/fixtures/incidents/`,
//! written by `make_incidents.py`, which also prints the expected epoch milliseconds, computed
//! with Python's `datetime`).

use std::collections::BTreeMap;
use std::path::PathBuf;

use firecast_data::incidents::{
    Incident, IncidentError, IncidentFilter, IncidentFormat, IncidentTable, LocationSource, RejectReason,
    parse_discovery_time, read_incidents,
};

fn fixture(name: &str) -> PathBuf {
    std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("tests/fixtures/incidents")
    .join(name)
}

fn read(name: &str, filter: &IncidentFilter) -> IncidentTable {
    read_incidents(fixture(name), filter).unwrap()
}

fn counts(pairs: &[(&'static str, u64)]) -> BTreeMap<&'static str, u64> {
    pairs.iter().copied().collect()
}

fn by_row(t: &IncidentTable, row: u64) -> &Incident {
    t.incidents
        .iter()
        .find(|i| i.row == row)
        .unwrap_or_else(|| panic!("row {row} not kept; rejects: {:?}", t.rejects))
}

fn assert_invariants(t: &IncidentTable) {
    assert_eq!(
        t.rows_read,
        (t.incidents.len() + t.rejects.len()) as u64,
        "rows_read = kept + rejected"
    );
    let mut rows: Vec<u64> = t.incidents.iter().map(|i| i.row).collect();
    rows.extend(t.rejects.iter().map(|r| r.row));
    rows.sort_unstable();
    assert_eq!(rows, (1..=t.rows_read).collect::<Vec<_>>(), "each row once");
}

// -------------------------------------------------------------------------------------------
// Dates
// -------------------------------------------------------------------------------------------

#[test]
fn date_encodings_match_python_datetime() {
    // (text, python: int(datetime(..., tzinfo=utc).timestamp() * 1000))
    let cases: &[(&str, i64)] = &[
        ("1596740280000", 1_596_740_280_000),
        ("1596740280000.0", 1_596_740_280_000),
        ("2023/07/04 21:15:00+00", 1_688_505_300_000),
        ("2020-08-06T18:58:00Z", 1_596_740_280_000),
        ("2020-08-06T18:58:00.000Z", 1_596_740_280_000),
        ("2020-08-06T18:58:00.123Z", 1_596_740_280_123),
        ("2020-08-06T18:58:00.5Z", 1_596_740_280_500),
        ("2020-08-06T18:58:00.123456Z", 1_596_740_280_123),
        ("7/4/2023 9:15:00 PM", 1_688_505_300_000),
        ("07/04/2023 09:15:00 pm", 1_688_505_300_000),
        ("1/2/2023 12:05:30 AM", 1_672_617_930_000),
        ("12/31/2022 12:30:00 PM", 1_672_489_800_000),
        ("2023-02-28 23:59:59", 1_677_628_799_000),
        ("2024-02-29", 1_709_164_800_000),
        ("2019-07-01 12:00:00+00:00", 1_561_982_400_000),
        ("  2016-06-15T14:30:00Z  ", 1_466_001_000_000),
        ("6/15/2016 2:30:00 PM", 1_466_001_000_000),
        ("2000-02-29T00:00:00Z", 951_782_400_000),
        ("1969-12-31T23:59:59Z", -1000),
    ];
    for (text, want) in cases {
        assert_eq!(parse_discovery_time(text), Some(*want), "{text:?}");
    }
}

#[test]
fn invalid_dates_are_refused() {
    for text in [
        "",
        "   ",
        "yesterday",
        "2023-13-01",
        "2023-00-10",
        "2023-02-29",
        "1900-02-29",
        "2024-02-30",
        "2023-04-31T00:00:00Z",
        "2023-07-04T24:00:00Z",
        "2023-07-04T23:60:00Z",
        "2023-07-04T23:59:60Z",
        "2023/07/04 21:15:00+00 extra",
        "2023-07/04",
        "7/4/2023 13:00:00 PM",
        "7/4/2023 0:30:00 AM",
        "13/4/2023 1:00:00 AM",
        "1596740280",      // epoch seconds
        "20230704",        // compact date
        "1596740280000.5", // fractional milliseconds
    ] {
        assert_eq!(parse_discovery_time(text), None, "{text:?}");
    }
}

// -------------------------------------------------------------------------------------------
// CSV
// -------------------------------------------------------------------------------------------

#[test]
fn csv_2023_header_awkward_rows() {
    let t = read("wfigs_2023.csv", &IncidentFilter::default());
    assert_eq!(t.format, IncidentFormat::Csv);
    assert_eq!(t.rows_read, 18);
    assert_eq!(t.incidents.len(), 10);
    assert_invariants(&t);
    assert_eq!(
        t.reject_counts(),
        counts(&[
            ("bad-discovery-date", 2),
            ("bad-location", 1),
            ("category-filtered", 2),
            ("missing-category", 1),
            ("missing-discovery-date", 1),
            ("missing-location", 1),
        ])
    );

    // Row 1: Hub date, Initial*, the BOM did not hide the `X` header (X/Y unused here).
    let r1 = by_row(&t, 1);
    assert_eq!(r1.line, 2);
    assert_eq!(r1.discovered_ms, 1_688_505_300_000);
    assert_eq!((r1.lat, r1.lon), (38.74, -120.51));
    assert_eq!(r1.location, LocationSource::InitialLatLon);
    assert_eq!(r1.id.as_deref(), Some("2023-CAENF-012345"));
    assert_eq!(r1.category.as_deref(), Some("WF"));

    // Row 2 spans lines 3-4 (quoted CRLF in the description).
    let r2 = by_row(&t, 2);
    assert_eq!(r2.line, 3);
    assert_eq!(r2.discovered_ms, 1_596_740_280_000);

    // Row 3: InitialLatitude empty → X/Y; fractional seconds.
    let r3 = by_row(&t, 3);
    assert_eq!(r3.line, 5);
    assert_eq!(r3.discovered_ms, 1_596_740_280_123);
    assert_eq!(r3.location, LocationSource::Geometry);
    assert_eq!((r3.lat, r3.lon), (45.78504, -104.45751));

    // Row 4: epoch-ms digits; no UniqueFireIdentifier → IrwinID.
    let r4 = by_row(&t, 4);
    assert_eq!(r4.discovered_ms, 1_689_000_000_000);
    assert_eq!(r4.id.as_deref(), Some("{11111111-2222-3333-4444-555555555555}"));

    assert_eq!(by_row(&t, 5).discovered_ms, 1_688_505_300_000); // 9:15:00 PM
    assert_eq!(by_row(&t, 6).discovered_ms, 1_672_617_930_000); // 12:05:30 AM
    assert_eq!(by_row(&t, 7).discovered_ms, 1_677_628_799_000); // pandas style
    assert_eq!(by_row(&t, 8).discovered_ms, 1_709_164_800_000); // 2024-02-29

    // Row 17 starts on line 19 and spans three lines; row 18 starts on line 22.
    let r17 = by_row(&t, 17);
    assert_eq!(r17.line, 19);
    assert_eq!(r17.discovered_ms, 1_672_489_800_000); // 12:30:00 PM
    let r18 = by_row(&t, 18);
    assert_eq!(r18.line, 22);
    assert_eq!(r18.discovered_ms, 1_685_577_600_000);
    // Initial (0, 0) is a placeholder: the geometry is used.
    assert_eq!(r18.location, LocationSource::Geometry);
    assert_eq!((r18.lat, r18.lon), (37.5, -119.5));

    let rejects: Vec<(u64, u64, RejectReason, &str)> = t
        .rejects
        .iter()
        .map(|r| (r.row, r.line, r.reason, r.detail.as_str()))
        .collect();
    assert_eq!(
        rejects,
        vec![
            (9, 11, RejectReason::CategoryFiltered, "RX"),
            (10, 12, RejectReason::CategoryFiltered, "CX"),
            (11, 13, RejectReason::BadDiscoveryDate, "yesterday"),
            (12, 14, RejectReason::BadDiscoveryDate, "2023/02/29 10:00:00+00"),
            (13, 15, RejectReason::MissingDiscoveryDate, ""),
            (14, 16, RejectReason::MissingLocation, ""),
            (
                15,
                17,
                RejectReason::BadLocation,
                "initial: latitude 95.5 outside ±90; geometry: missing"
            ),
            (16, 18, RejectReason::MissingCategory, ""),
        ]
    );
}

#[test]
fn csv_empty_filter_keeps_every_category() {
    let t = read("wfigs_2023.csv", &IncidentFilter::all());
    assert_invariants(&t);
    assert_eq!(t.incidents.len(), 13);
    assert_eq!(
        t.reject_counts(),
        counts(&[
            ("bad-discovery-date", 2),
            ("bad-location", 1),
            ("missing-discovery-date", 1),
            ("missing-location", 1),
        ])
    );
    assert_eq!(by_row(&t, 9).category.as_deref(), Some("RX"));
    assert_eq!(by_row(&t, 10).category.as_deref(), Some("CX"));
    assert_eq!(by_row(&t, 16).category, None);
}

#[test]
fn csv_filter_on_several_categories() {
    let filter = IncidentFilter {
        categories: vec!["WF".into(), "rx".into()],
    };
    let t = read("wfigs_2023.csv", &filter);
    assert_eq!(t.incidents.len(), 11);
    assert_eq!(t.reject_counts()["category-filtered"], 1);
}

#[test]
fn csv_older_year_maps_columns_by_name() {
    let t = read("wfigs_2016.csv", &IncidentFilter::default());
    assert_invariants(&t);
    assert_eq!(t.rows_read, 4);
    assert_eq!(t.incidents.len(), 3);
    assert_eq!(t.reject_counts(), counts(&[("category-filtered", 1)]));

    let r1 = by_row(&t, 1);
    assert_eq!((r1.lat, r1.lon), (44.25, -121.5));
    assert_eq!(r1.location, LocationSource::InitialLatLon);
    assert_eq!(r1.discovered_ms, 1_466_001_000_000);
    assert_eq!(r1.id.as_deref(), Some("2016-ORDEF-000001"));

    let r3 = by_row(&t, 3);
    assert_eq!((r3.lat, r3.lon), (47.5, -120.25));
    assert_eq!(r3.location, LocationSource::Geometry);
    assert_eq!(r3.discovered_ms, 1_472_774_399_000);

    // Category compared ignoring case; no id at all.
    let r4 = by_row(&t, 4);
    assert_eq!(r4.category.as_deref(), Some("wf"));
    assert_eq!(r4.id, None);
    assert_eq!((r4.lat, r4.lon), (36.125, -115.75));
    assert_eq!(r4.discovered_ms, 1_476_094_210_000);
}

#[test]
fn csv_authors_alias_layout() {
    let t = read("authors_alias.csv", &IncidentFilter::default());
    assert_invariants(&t);
    assert_eq!(t.rows_read, 5);
    assert_eq!(t.incidents.len(), 4);
    assert_eq!(
        t.rejects
            .iter()
            .map(|r| (r.row, r.line, r.reason, r.detail.as_str()))
            .collect::<Vec<_>>(),
        vec![(
            4,
            5,
            RejectReason::BadLocation,
            "initial: missing; geometry: latitude missing"
        )]
    );
    // No category column: nothing filtered, category unknown; x = lon, y = lat.
    for i in &t.incidents {
        assert_eq!(i.category, None);
        assert_eq!(i.id, None);
        assert_eq!(i.location, LocationSource::Geometry);
    }
    let got: Vec<(i64, f64, f64)> = t
        .incidents
        .iter()
        .map(|i| (i.discovered_ms, i.lat, i.lon))
        .collect();
    assert_eq!(
        got,
        vec![
            (1_402_864_200_000, 34.05, -118.25),
            (1_561_982_400_000, 40.5, -105.5),
            (1_745_971_200_000, 35.5, -82.5),
            (1_631_519_100_000, 33.4, -112.1),
        ]
    );
}

#[test]
fn csv_too_many_fields_names_file_and_line() {
    let path = fixture("too_many_fields.csv");
    match read_incidents(&path, &IncidentFilter::default()) {
        Err(IncidentError::Malformed {
            path: p,
            line,
            message,
        }) => {
            assert_eq!(p, path);
            assert_eq!(line, 5);
            assert!(message.contains("5 fields") && message.contains('4'), "{message}");
        }
        other => panic!("expected Malformed, got {other:?}"),
    }
    let text = read_incidents(&path, &IncidentFilter::default())
        .unwrap_err()
        .to_string();
    assert!(
        text.contains("too_many_fields.csv") && text.contains("line 5"),
        "{text}"
    );
}

#[test]
fn csv_crlf_and_blank_lines_keep_physical_line_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("crlf.csv");
    std::fs::write(
        &path,
        "FireDiscoveryDateTime,X,Y,IncidentName\r\n\
         2023-07-04,-120.5,38.7,\"A\r\nB\"\r\n\
         \r\n\
         yesterday,-120.5,38.7,C\r\n\
         2023-07-05,-120.5,38.7,D,extra\r\n",
    )
    .unwrap();
    match read_incidents(&path, &IncidentFilter::default()) {
        Err(IncidentError::Malformed { line, .. }) => assert_eq!(line, 6),
        other => panic!("expected Malformed, got {other:?}"),
    }
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(&path, text.replace(",extra", "")).unwrap();
    let t = read_incidents(&path, &IncidentFilter::default()).unwrap();
    assert_eq!(t.incidents.iter().map(|i| i.line).collect::<Vec<_>>(), [2, 6]);
    assert_eq!(t.rejects.len(), 1);
    assert_eq!((t.rejects[0].row, t.rejects[0].line), (2, 5));
}

#[test]
fn csv_without_date_column() {
    let path = fixture("no_date_column.csv");
    let err = read_incidents(&path, &IncidentFilter::default()).unwrap_err();
    match &err {
        IncidentError::MissingColumn {
            path: p,
            column,
            accepted,
            found,
        } => {
            assert_eq!(p, &path);
            assert_eq!(column, "FireDiscoveryDateTime");
            assert!(accepted.iter().any(|a| a == "Fire Discovery Date Time"));
            assert_eq!(found[..2], ["X".to_owned(), "Y".to_owned()]);
        }
        other => panic!("expected MissingColumn, got {other:?}"),
    }
    let text = err.to_string();
    assert!(text.contains("no_date_column.csv") && text.contains("FireDiscoveryDateTime"));
}

#[test]
fn csv_without_location_columns() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("noloc.csv");
    std::fs::write(
        &path,
        "FireDiscoveryDateTime,InitialLatitude,X\n2023/07/04 21:15:00+00,38.7,-120.5\n",
    )
    .unwrap();
    match read_incidents(&path, &IncidentFilter::default()) {
        Err(IncidentError::MissingColumn { column, .. }) => {
            assert_eq!(column, "InitialLatitude/InitialLongitude or X/Y");
        }
        other => panic!("expected MissingColumn, got {other:?}"),
    }
}

#[test]
fn csv_header_names_are_matched_loosely_after_exact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("loose.csv");
    // Upper-case names match loosely; exact `X` wins over `x`.
    std::fs::write(
        &path,
        "FIREDISCOVERYDATETIME, initiallatitude ,INITIALLONGITUDE,x,X,y\n\
         2023-07-04,,,-1,-120.5,38.7\n\
         2023-07-05,39.5,-121.5,,,\n",
    )
    .unwrap();
    let t = read_incidents(&path, &IncidentFilter::default()).unwrap();
    assert_eq!(t.rejects, vec![]);
    assert_eq!((t.incidents[0].lat, t.incidents[0].lon), (38.7, -120.5));
    assert_eq!((t.incidents[1].lat, t.incidents[1].lon), (39.5, -121.5));
}

#[test]
fn reject_report_content() {
    let t = read("wfigs_2023.csv", &IncidentFilter::default());
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rejects.csv");
    t.write_reject_report(&out).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(
        text,
        "row,line,reason,detail\n\
         9,11,category-filtered,RX\n\
         10,12,category-filtered,CX\n\
         11,13,bad-discovery-date,yesterday\n\
         12,14,bad-discovery-date,2023/02/29 10:00:00+00\n\
         13,15,missing-discovery-date,\n\
         14,16,missing-location,\n\
         15,17,bad-location,initial: latitude 95.5 outside ±90; geometry: missing\n\
         16,18,missing-category,\n"
    );

    let t = read("authors_alias.csv", &IncidentFilter::default());
    t.write_reject_report(&out).unwrap();
    assert_eq!(
        std::fs::read_to_string(&out).unwrap(),
        "row,line,reason,detail\n4,5,bad-location,initial: missing; geometry: latitude missing\n"
    );
}

// -------------------------------------------------------------------------------------------
// JSON
// -------------------------------------------------------------------------------------------

#[test]
fn geojson_feature_collection() {
    let t = read("wfigs.geojson", &IncidentFilter::default());
    assert_eq!(t.format, IncidentFormat::GeoJson);
    assert_invariants(&t);
    assert_eq!(t.rows_read, 6);
    assert_eq!(t.incidents.len(), 3);
    assert_eq!(
        t.reject_counts(),
        counts(&[
            ("bad-discovery-date", 1),
            ("category-filtered", 1),
            ("missing-discovery-date", 1),
        ])
    );
    let r1 = by_row(&t, 1);
    assert_eq!(r1.line, 0);
    assert_eq!(r1.discovered_ms, 1_596_740_280_000);
    assert_eq!((r1.lat, r1.lon), (34.31, -111.03));
    assert_eq!(r1.location, LocationSource::InitialLatLon);

    let r2 = by_row(&t, 2);
    assert_eq!(r2.discovered_ms, 1_626_231_845_000);
    assert_eq!((r2.lat, r2.lon), (36.5, -119.75));
    assert_eq!(r2.location, LocationSource::Geometry);
    assert_eq!(r2.id.as_deref(), Some("{AAAAAAAA-BBBB-CCCC-DDDD-EEEEEEEEEEEE}"));

    // Null geometry, Initial* set.
    let r4 = by_row(&t, 4);
    assert_eq!(r4.discovered_ms, 1_650_000_000_000);
    assert_eq!((r4.lat, r4.lon), (46.5, -114.25));
    assert_eq!(r4.location, LocationSource::InitialLatLon);

    let rejects: Vec<(u64, RejectReason, &str)> = t
        .rejects
        .iter()
        .map(|r| (r.row, r.reason, r.detail.as_str()))
        .collect();
    assert_eq!(
        rejects,
        vec![
            (3, RejectReason::CategoryFiltered, "RX"),
            (5, RejectReason::MissingDiscoveryDate, ""),
            (6, RejectReason::BadDiscoveryDate, "1596740280"),
        ]
    );
}

#[test]
fn esri_json_feature_set() {
    let t = read("wfigs_esri.json", &IncidentFilter::default());
    assert_eq!(t.format, IncidentFormat::EsriJson);
    assert_invariants(&t);
    assert_eq!(t.rows_read, 5);
    assert_eq!(t.incidents.len(), 3);
    assert_eq!(
        t.reject_counts(),
        counts(&[("category-filtered", 1), ("missing-location", 1)])
    );
    let r1 = by_row(&t, 1);
    assert_eq!(r1.discovered_ms, 1_756_225_560_000);
    // Initial* preferred over the (slightly different) geometry, docs/spec/data.md §1.3.
    assert_eq!((r1.lat, r1.lon), (45.78496, -104.4958));
    assert_eq!(r1.location, LocationSource::InitialLatLon);
    assert_eq!(r1.id.as_deref(), Some("2025-MTCUS-000347"));

    let r2 = by_row(&t, 2);
    assert_eq!((r2.lat, r2.lon), (61.25, -149.75));
    assert_eq!(r2.location, LocationSource::InitialLatLon);

    let r5 = by_row(&t, 5);
    assert_eq!((r5.lat, r5.lon), (34.0625, -117.125));
    assert_eq!(r5.location, LocationSource::Geometry);
    assert_eq!(r5.id.as_deref(), Some("{DF258F6C-4B18-478F-A661-9D278F480072}"));
    assert_eq!(t.rejects[0].row, 3);
    assert_eq!(t.rejects[1].row, 4);
    assert_eq!(t.rejects[1].reason, RejectReason::MissingLocation);
}

#[test]
fn esri_json_web_mercator_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mercator.json");
    std::fs::write(
        &path,
        r#"{"spatialReference":{"wkid":102100,"latestWkid":3857},"features":[
            {"attributes":{"FireDiscoveryDateTime":1756225560000},
             "geometry":{"x":-13358338.9,"y":4865942.3}}]}"#,
    )
    .unwrap();
    match read_incidents(&path, &IncidentFilter::default()) {
        Err(e @ IncidentError::SpatialReference { .. }) => {
            let text = e.to_string();
            assert!(
                text.contains("mercator.json") && text.contains("102100"),
                "{text}"
            );
        }
        other => panic!("expected SpatialReference, got {other:?}"),
    }
}

#[test]
fn json_structural_errors() {
    let path = fixture("invalid.geojson");
    match read_incidents(&path, &IncidentFilter::default()) {
        Err(IncidentError::Malformed { path: p, line, .. }) => {
            assert_eq!(p, path);
            assert_eq!(line, 3);
        }
        other => panic!("expected Malformed, got {other:?}"),
    }

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("error.json");
    std::fs::write(
        &path,
        r#"{"error":{"code":400,"message":"Invalid query","details":[]}}"#,
    )
    .unwrap();
    let err = read_incidents(&path, &IncidentFilter::default()).unwrap_err();
    assert!(
        matches!(&err, IncidentError::Malformed { message, .. } if message.contains("Invalid query")),
        "{err}"
    );

    let path = dir.path().join("no_date.geojson");
    std::fs::write(
        &path,
        r#"{"type":"FeatureCollection","features":[{"type":"Feature",
            "properties":{"OBJECTID":1,"IncidentName":"A"},
            "geometry":{"type":"Point","coordinates":[-120.0,40.0]}}]}"#,
    )
    .unwrap();
    match read_incidents(&path, &IncidentFilter::default()) {
        Err(IncidentError::MissingColumn { column, found, .. }) => {
            assert_eq!(column, "FireDiscoveryDateTime");
            assert_eq!(found, vec!["OBJECTID".to_owned(), "IncidentName".to_owned()]);
        }
        other => panic!("expected MissingColumn, got {other:?}"),
    }
}

#[test]
fn json_polygon_geometry_and_bom() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("perimeters.geojson");
    std::fs::write(
        &path,
        "\u{feff}{\"type\":\"FeatureCollection\",\"features\":[\
         {\"type\":\"Feature\",\"properties\":{\"attr_FireDiscoveryDateTime\":\"2020-08-06T18:58:00Z\",\
          \"attr_IncidentTypeCategory\":\"WF\"},\
          \"geometry\":{\"type\":\"Polygon\",\"coordinates\":[[[-120,40],[-120,41],[-121,41],[-120,40]]]}},\
         {\"type\":\"Feature\",\"properties\":{\"attr_FireDiscoveryDateTime\":\"2020-08-06T18:58:00Z\",\
          \"attr_IncidentTypeCategory\":\"WF\",\"attr_InitialLatitude\":40.5,\"attr_InitialLongitude\":-120.5},\
          \"geometry\":{\"type\":\"Polygon\",\"coordinates\":[[[-120,40],[-120,41],[-121,41],[-120,40]]]}}]}",
    )
    .unwrap();
    let t = read_incidents(&path, &IncidentFilter::default()).unwrap();
    assert_eq!(t.format, IncidentFormat::GeoJson);
    assert_eq!(t.incidents.len(), 1);
    assert_eq!((t.incidents[0].lat, t.incidents[0].lon), (40.5, -120.5));
    assert_eq!(t.incidents[0].discovered_ms, 1_596_740_280_000);
    assert_eq!(t.rejects.len(), 1);
    assert_eq!(t.rejects[0].reason, RejectReason::BadLocation);
    assert_eq!(
        t.rejects[0].detail,
        "initial: missing; geometry: Polygon is not a point"
    );
}

#[test]
fn missing_file() {
    let path = fixture("does_not_exist.csv");
    match read_incidents(&path, &IncidentFilter::default()) {
        Err(IncidentError::MissingFile { path: p }) => assert_eq!(p, path),
        other => panic!("expected MissingFile, got {other:?}"),
    }
}
