//! Publishing: the three metadata files rendered from one `Publication` agree with each other
//! and with the files, the folder reads back as the dataset, and damage is named.

use firecast_dataset::dataset::read_window_table;
use firecast_dataset::publish::{PublishConfig, compare, publish, read_published, table_file, verify};
use serde_json::{Value, json};

fn config() -> PublishConfig {
    serde_json::from_value(json!({
        "id": "someone/firecast-it-test",
        "title": "FireCast publish test",
        "date_published": "2026-11-28",
    }))
    .unwrap()
}

fn read_json(path: &std::path::Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn a_published_folder_reads_back_as_the_dataset_and_its_three_descriptions_agree() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("ds");
    crate::dataset::write_small_dataset(&ds);
    let out = tmp.path().join("pub");
    let r = publish(&ds, &out, &config()).unwrap();
    // Two features, not the paper's fifteen: no FireCastRL CSV.
    assert!(r.csv_rows.is_none());
    assert!(!out.join("Wildfire_Dataset.csv").exists());

    let dataset = read_window_table(&ds).unwrap();
    let back = read_published(&out).unwrap();
    compare(&dataset, &back).unwrap();
    let report = verify(&out, Some(&ds)).unwrap();
    assert_eq!(report.samples, 30);

    let croissant = read_json(&out.join("croissant.json"));
    let kaggle = read_json(&out.join("dataset-metadata.json"));
    let readme = std::fs::read_to_string(out.join("README.md")).unwrap();
    assert_eq!(croissant["conformsTo"], "http://mlcommons.org/croissant/1.1");
    assert_eq!(croissant["version"], r.version);
    assert_eq!(croissant["datePublished"], "2026-11-28");
    assert_eq!(croissant["license"], "https://spdx.org/licenses/CC-BY-4.0.html");
    assert_eq!(kaggle["licenses"][0]["name"], "CC-BY-4.0");
    assert!(readme.starts_with("---\nlicense: cc-by-4.0\n"), "{readme}");
    // No truth column in this dataset: not called synthetic.
    assert!(!croissant["description"].as_str().unwrap().contains("SYNTHETIC"));

    // Splits: Croissant's cr:Split record set, the card's configs and the files agree.
    let record_sets = croissant["recordSet"].as_array().unwrap();
    let by_id = |id: &str| record_sets.iter().find(|r| r["@id"] == id).unwrap();
    let splits = by_id("splits");
    assert_eq!(splits["dataType"], "cr:Split");
    let names: Vec<&str> = splits["data"]
        .as_array()
        .unwrap()
        .iter()
        .map(|row| row["splits/name"].as_str().unwrap())
        .collect();
    let expected: Vec<&str> = r.splits.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, expected);
    for s in &r.splits {
        for t in ["samples", "days"] {
            let file = table_file(t, &s.name);
            assert!(
                readme.contains(&format!("  - split: {}\n    path: {file}\n", s.name)),
                "{file}"
            );
            assert!(
                kaggle["resources"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .any(|x| x["path"] == file.as_str() && x["schema"]["fields"].is_array()),
                "{file}"
            );
            let object = croissant["distribution"]
                .as_array()
                .unwrap()
                .iter()
                .find(|d| d["contentUrl"] == file.as_str())
                .unwrap_or_else(|| panic!("{file} is not a FileObject"));
            assert_eq!(object["encodingFormat"], "application/x-parquet");
            assert_eq!(
                object["sha256"],
                firecast_dataset::sha256::file_hex(&out.join(&file)).unwrap()
            );
        }
    }

    // One field per Parquet column, with the column's type.
    let days = by_id("days");
    let fields: Vec<(&str, &str)> = days["field"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| (f["name"].as_str().unwrap(), f["dataType"].as_str().unwrap()))
        .collect();
    assert_eq!(
        fields,
        [
            ("sample_id", "cr:UInt32"),
            ("day_index", "cr:Int32"),
            ("day_offset", "cr:Int32"),
            ("date", "sc:Date"),
            ("wildfire", "sc:Boolean"),
            ("pr", "cr:Float32"),
            ("tmmx", "cr:Float32"),
            ("split", "sc:Text"),
        ]
    );
    let samples = by_id("samples");
    let split_field = samples["field"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["name"] == "split")
        .unwrap();
    assert_eq!(split_field["references"]["field"]["@id"], "splits/name");
    for key in [
        "rai:dataCollection",
        "rai:dataLimitations",
        "rai:dataBiases",
        "rai:personalSensitiveInformation",
        "rai:dataUseCases",
        "rai:dataPreprocessingProtocol",
    ] {
        assert!(croissant[key].is_string() || croissant[key].is_array(), "{key}");
    }

    // An existing folder is never replaced.
    let again = publish(&ds, &out, &config()).err().unwrap().to_string();
    assert!(again.contains("already exists"), "{again}");

    // A damaged published file is refused by its own name.
    let victim = out.join(table_file("days", &r.splits[0].name));
    let mut bytes = std::fs::read(&victim).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x5A;
    std::fs::write(&victim, &bytes).unwrap();
    let e = verify(&out, None).err().unwrap();
    let msg = e.to_string();
    assert!(
        matches!(e, firecast_dataset::DatasetError::Damaged { .. })
            && msg.contains(victim.file_name().unwrap().to_str().unwrap()),
        "{msg}"
    );
}

#[test]
fn a_folder_that_differs_from_the_dataset_is_told_apart() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("ds");
    crate::dataset::write_small_dataset(&ds);
    let out = tmp.path().join("pub");
    publish(&ds, &out, &config()).unwrap();
    let dataset = read_window_table(&ds).unwrap();
    let mut back = read_published(&out).unwrap();
    back.table.values[7] += 1.0;
    let msg = compare(&dataset, &back).unwrap_err();
    assert!(msg.contains("`"), "{msg}");
    let mut back = read_published(&out).unwrap();
    if let Some(s) = back.splits.as_mut() {
        s[0] = "elsewhere".into();
    }
    assert!(compare(&dataset, &back).unwrap_err().contains("split"));
}

#[test]
fn bad_settings_name_their_key() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("ds");
    crate::dataset::write_small_dataset(&ds);
    for (key, value) in [
        ("release", "1.0"),
        ("date_published", "2026-13-01"),
        ("license", "WTFPL"),
    ] {
        let mut cfg = config();
        match key {
            "release" => cfg.release = value.into(),
            "date_published" => cfg.date_published = Some(value.into()),
            _ => cfg.license = value.into(),
        }
        let out = tmp.path().join(format!("pub-{key}"));
        let msg = publish(&ds, &out, &cfg).err().unwrap().to_string();
        assert!(msg.contains(key) && msg.contains(value), "{msg}");
        assert!(!out.exists(), "{key}: a refused folder must not appear");
    }
}
