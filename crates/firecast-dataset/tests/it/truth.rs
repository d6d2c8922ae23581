//! The synthetic generator's truth carried into a dataset: looked up per sample at its cell
//! and event day, stored as the nullable `true_ignition_probability` column of
//! `samples.parquet`, never a feature, and absent (with unchanged versions) without truth.

use std::fs::File;
use std::path::Path;

use firecast_data::gridmet::GridmetFile;
use firecast_dataset::DatasetError;
use firecast_dataset::dataset::read_window_table;
use firecast_dataset::dataset::{DatasetConfig, DatasetManifest, Framing, FramingKind};
use firecast_dataset::sampling::NegativeConfig;
use firecast_dataset::stage::{self, IgnitionParams, SynthParams};
use firecast_dataset::table::SAMPLES_FILE;
use firecast_dataset::truth::{TRUE_PROBABILITY_COLUMN, attach_truth};
use firecast_dataset::windows::ExtractConfig;
use firecast_synth::{TRUTH_VARIABLE, truth_file_name};
use parquet::file::reader::{FileReader, SerializedFileReader};

fn synth_params() -> SynthParams {
    serde_json::from_value(serde_json::json!({
        "seed": 3,
        "region": {"lat_min": 38.5, "lat_max": 40.0, "lon_min": -108.5, "lon_max": -106.5},
        "years": [2019, 2019],
        "ignition_rate_scale": 0.5,
    }))
    .unwrap()
}

fn negatives() -> NegativeConfig {
    serde_json::from_value(serde_json::json!({
        "variant": "paper", "period_start": "2019-03-02", "period_end": "2019-12-17",
        "region": {"lat_min": 38.5, "lat_max": 40.0, "lon_min": -108.5, "lon_max": -106.5},
        "far_min_km": 15, "near_max_km": 30,
    }))
    .unwrap()
}

/// Synthetic sources (with `truth/`), ignitions and samples under `root`.
fn sources(root: &Path) {
    let r = stage::run_synthesize(&synth_params(), &root.join("src"), &mut |_, _| {}).unwrap();
    assert_eq!(r.truth_files, 1);
    let gridmet = root.join("src/gridmet");
    stage::run_ignitions(
        &root.join("src/incidents/wfigs_incidents.csv"),
        Some(&gridmet),
        &IgnitionParams {
            categories: vec!["WF".into()],
            ..Default::default()
        },
        &root.join("ignitions.parquet"),
        &root.join("rejects.csv"),
    )
    .unwrap();
    stage::run_negatives(
        &root.join("ignitions.parquet"),
        Some(&gridmet),
        &negatives(),
        &root.join("samples.parquet"),
    )
    .unwrap();
}

/// Windows (with or without truth) and a dataset of `kind` built from them.
fn build(root: &Path, name: &str, truth: bool, kind: FramingKind) -> DatasetManifest {
    let windows = root.join(format!("windows-{name}"));
    let truth_dir = root.join("src").join("truth");
    let wm = stage::run_windows_with_truth(
        &root.join("samples.parquet"),
        &root.join("src/gridmet"),
        truth.then_some(truth_dir.as_path()),
        &ExtractConfig::default(),
        &windows,
        &|_, _| {},
    )
    .unwrap();
    assert_eq!(wm.truth.is_some(), truth);
    let cfg = DatasetConfig {
        name: "truth-test".into(),
        framing: Framing {
            kind,
            ..Default::default()
        },
        split: Default::default(),
        description: String::new(),
    };
    stage::run_dataset(&windows, None, &cfg, &root.join(format!("dataset-{name}"))).unwrap()
}

fn parquet_columns(path: &Path) -> Vec<String> {
    let reader = SerializedFileReader::new(File::open(path).unwrap()).unwrap();
    reader
        .metadata()
        .file_metadata()
        .schema_descr()
        .columns()
        .iter()
        .map(|c| c.name().to_string())
        .collect()
}

#[test]
fn the_true_probability_reaches_the_dataset_and_ranks_positives_above_negatives() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    sources(root);
    let with = build(root, "with", true, FramingKind::Forecast);
    let without = build(root, "without", false, FramingKind::Forecast);

    // With truth: every sample has a value (the samples are on land), positives score higher.
    let ds = root.join("dataset-with");
    let stored = read_window_table(&ds).unwrap();
    let samples = &stored.table.samples;
    assert!(samples.len() > 50, "{} samples", samples.len());
    assert!(samples.iter().all(|s| s.true_probability.is_some()));
    assert!(
        samples
            .iter()
            .all(|s| (0.0..=1.0).contains(&s.true_probability.unwrap()))
    );
    let mean = |positive: bool| {
        let v: Vec<f64> = samples
            .iter()
            .filter(|s| s.label() == positive)
            .map(|s| f64::from(s.true_probability.unwrap()))
            .collect();
        assert!(!v.is_empty());
        v.iter().sum::<f64>() / v.len() as f64
    };
    let (pos, neg) = (mean(true), mean(false));
    println!("mean true probability: positives {pos:.5}, negatives {neg:.5}");
    assert!(pos > neg, "positives {pos} <= negatives {neg}");
    let summary = with.true_probability.clone().unwrap();
    assert_eq!(summary.column, TRUE_PROBABILITY_COLUMN);
    assert_eq!(summary.samples_with_value, samples.len() as u64);
    assert!((summary.mean_positive.unwrap() - pos).abs() < 1e-9);

    // The value is the truth file's at the sample's cell and event day.
    let f =
        GridmetFile::open_named(root.join("src/truth").join(truth_file_name(2019)), TRUTH_VARIABLE).unwrap();
    for s in samples.iter().step_by(7) {
        let (j, i) = f.nearest_cell(s.cell_lat, s.cell_lon).unwrap();
        let t = f.days().binary_search(&s.event_day).unwrap();
        assert_eq!(
            f.gather(&[(j, i)], t..t + 1).unwrap()[0][0],
            s.true_probability.unwrap()
        );
    }

    // Never a feature: not in the features, not in days.parquet; a column of samples.parquet.
    assert!(!with.features.iter().any(|f| f.contains("probability")));
    assert_eq!(with.features, without.features);
    assert!(
        !parquet_columns(&ds.join("days.parquet"))
            .iter()
            .any(|c| c == TRUE_PROBABILITY_COLUMN)
    );
    assert_eq!(
        parquet_columns(&ds.join(SAMPLES_FILE)).last().map(String::as_str),
        Some(TRUE_PROBABILITY_COLUMN)
    );
    let card = std::fs::read_to_string(ds.join("card.md")).unwrap();
    assert!(
        card.contains(TRUE_PROBABILITY_COLUMN) && card.contains("**not a feature**"),
        "{card}"
    );
    assert!(with.provenance.contains_key("truth ignition_probability_2019.nc"));

    // Without truth: no column, all None, no card line; the same data otherwise.
    let plain = root.join("dataset-without");
    assert!(without.true_probability.is_none());
    assert!(
        !parquet_columns(&plain.join(SAMPLES_FILE))
            .iter()
            .any(|c| c == TRUE_PROBABILITY_COLUMN)
    );
    let back = read_window_table(&plain).unwrap();
    assert!(back.table.samples.iter().all(|s| s.true_probability.is_none()));
    assert!(
        !std::fs::read_to_string(plain.join("card.md"))
            .unwrap()
            .contains(TRUE_PROBABILITY_COLUMN)
    );
    assert_eq!(back.table.values.len(), stored.table.values.len());
    assert!(
        back.table
            .values
            .iter()
            .zip(&stored.table.values)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    // Only the truth changes the version.
    assert_ne!(with.version, without.version);

    // Deterministic: the same inputs give the same version and bytes.
    let again = build(root, "again", true, FramingKind::Forecast);
    assert_eq!(again.version, with.version);
    assert_eq!(again.files, with.files);
}

#[test]
fn a_year_or_cell_the_truth_lacks_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    sources(root);
    build(root, "with", true, FramingKind::Paper);
    let stored = read_window_table(&root.join("windows-with")).unwrap();
    let truth = root.join("src/truth");

    let mut next_year = stored.table.samples.clone();
    next_year[0].event_day += 365;
    next_year[0].true_probability = None;
    match attach_truth(&mut next_year, &truth, false) {
        Err(DatasetError::MissingSource { path, .. }) => assert_eq!(path, truth.join(truth_file_name(2020))),
        other => panic!("{other:?}"),
    }

    let mut elsewhere = stored.table.samples.clone();
    elsewhere[0].cell_lat += 1.0;
    let e = attach_truth(&mut elsewhere, &truth, false).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("ignition_probability_2019.nc") && msg.contains("not on this file's grid"),
        "{msg}"
    );

    // Re-attaching gives what the windows stored.
    let mut same = stored.table.samples.clone();
    let report = attach_truth(&mut same, &truth, true).unwrap();
    assert_eq!(same, stored.table.samples);
    assert_eq!(report.files_read, 1);
    assert_eq!(report.samples_with_value, same.len() as u64);
    assert_eq!(report.source_hashes.len(), 1);
}

/// The stage kinds: `data.synthesize` writes `truth` only when the output is declared, and
/// `data.windows` takes it as an optional input (the demo's wiring).
#[test]
fn the_stages_wire_the_truth_as_optional_ports() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let pipeline = r#"
vars:
  region: {lat_min: 38.5, lat_max: 40.0, lon_min: -108.5, lon_max: -106.5}
stages:
  sources:
    uses: data.synthesize
    params:
      seed: 3
      region: ${region}
      years: [2019, 2019]
      ignition_rate_scale: 0.5
      variables: [erc, fm100]
    outputs:
      gridmet: src/gridmet
      incidents: src/wfigs_incidents.csv
      model: src/MODEL.md
      truth: src/truth
  plain:
    uses: data.synthesize
    params:
      seed: 3
      region: ${region}
      years: [2019, 2019]
      ignition_rate_scale: 0.5
      variables: [erc]
    outputs:
      gridmet: plain/gridmet
      incidents: plain/wfigs_incidents.csv
      model: plain/MODEL.md
  ignitions:
    uses: data.ignitions
    inputs: {incidents: {from: sources.incidents}, gridmet: {from: sources.gridmet}}
    outputs: {ignitions: w/ignitions.parquet, report: w/ignitions.json, rejects: w/rejects.csv}
  samples:
    uses: data.negatives
    params:
      variant: paper
      period_start: "2019-03-02"
      period_end: "2019-12-17"
      region: ${region}
      far_min_km: 15
      near_max_km: 30
    inputs: {ignitions: {from: ignitions.ignitions}, gridmet: {from: sources.gridmet}}
    outputs: {samples: w/samples.parquet, report: w/samples.json}
  windows:
    uses: data.windows
    params: {variables: [erc, fm100]}
    inputs: {samples: {from: samples.samples}, gridmet: {from: sources.gridmet}, truth: {from: sources.truth}}
    outputs: {windows: w/windows}
  dataset:
    uses: data.dataset
    params: {name: pipeline-truth, framing: {kind: forecast}}
    inputs: {windows: {from: windows.windows}}
    outputs: {dataset: w/dataset}
"#;
    std::fs::write(root.join("p.yaml"), pipeline).unwrap();
    let mut kinds = firecast_pipeline::StageKinds::new();
    firecast_dataset::stage::register(&mut kinds);
    let plan = firecast_pipeline::load_plan(root, Path::new("p.yaml"), &[], &kinds).unwrap();
    let engine = firecast_pipeline::Engine {
        root: root.to_path_buf(),
        kinds,
        observer: std::sync::Arc::new(firecast_pipeline::NoObserver),
        store: Some(std::sync::Arc::new(
            firecast_store::ArtifactStore::open("artifacts", root).unwrap(),
        )),
        git_commit: None,
        executor: None,
    };
    let opts = firecast_pipeline::RunOptions {
        progress: false,
        jobs: 2,
        ..Default::default()
    };
    let report = engine.run(&plan, &opts).unwrap();
    assert!(report.succeeded(), "{report:?}");
    assert!(root.join("src/truth").join(truth_file_name(2019)).is_file());
    assert!(!root.join("plain/truth").exists() && !root.join("plain/gridmet/truth").exists());
    assert!(!root.join("src/gridmet").join(truth_file_name(2019)).exists());
    let stored = read_window_table(&root.join("w/dataset")).unwrap();
    assert!(!stored.table.samples.is_empty());
    assert!(stored.table.samples.iter().all(|s| s.true_probability.is_some()));
    assert_eq!(stored.table.features, ["erc", "fm100"]);
}
