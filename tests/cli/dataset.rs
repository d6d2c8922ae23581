//! `firecast dataset …` end to end on synthetic sources, and `bench gridmet`.

use crate::{Project, describe, venv_bin};

pub(crate) const REGION: &str = "39.0,39.75,-107.5,-106.5";

/// Synthetic sources → ignitions → negatives → windows → a paper dataset, all through the CLI.
pub(crate) fn build_paper_dataset(p: &Project, out: &str) -> serde_json::Value {
    let incidents = p.path("src/incidents/wfigs_incidents.csv");
    let gridmet = p.path("src/gridmet");
    p.ok(&[
        "dataset",
        "ignitions",
        "--incidents",
        incidents.to_str().unwrap(),
        "--gridmet",
        gridmet.to_str().unwrap(),
        "--out",
        "work/ignitions.parquet",
    ]);
    p.write(
        "negatives.yaml",
        "variant: paper\nperiod_start: \"2019-03-02\"\nperiod_end: \"2019-12-17\"\nfar_min_km: 10\n",
    );
    p.ok(&[
        "dataset",
        "negatives",
        "--ignitions",
        "work/ignitions.parquet",
        "--gridmet",
        gridmet.to_str().unwrap(),
        "--out",
        "work/samples.parquet",
        "--config",
        "negatives.yaml",
    ]);
    if !p.path("work/windows").exists() {
        p.ok(&[
            "dataset",
            "windows",
            "--samples",
            "work/samples.parquet",
            "--gridmet",
            gridmet.to_str().unwrap(),
            "--truth",
            p.path("src/truth").to_str().unwrap(),
            "--out",
            "work/windows",
        ]);
    }
    p.json(&[
        "dataset",
        "build",
        "--windows",
        "work/windows",
        "--out",
        out,
        "--name",
        "cli-test",
        "--framing",
        "paper",
        "--source-model",
        p.path("src/MODEL.md").to_str().unwrap(),
    ])
}

#[test]
fn dataset_steps_build_a_deterministic_versioned_dataset_and_a_kaggle_folder() {
    let p = Project::new();
    let synth = p.json(&[
        "dataset",
        "synthesize",
        "--out",
        "src",
        "--seed",
        "3",
        "--years",
        "2019-2019",
        "--region",
        REGION,
    ]);
    assert!(synth["ignitions"].as_u64().unwrap() > 10, "{synth}");
    assert!(p.path("src/gridmet/vpd_2019.nc").is_file());
    assert!(p.path("src/truth/ignition_probability_2019.nc").is_file());
    assert!(
        p.read("src/incidents/wfigs_incidents.csv")
            .starts_with("X,Y,OBJECTID,")
    );

    let first = build_paper_dataset(&p, "data/a");
    assert_eq!(first["day_offsets"], serde_json::json!([-60, 14]));
    assert!(first["positives"].as_u64().unwrap() > 0, "{first}");
    for f in [
        "samples.parquet",
        "days.parquet",
        "card.md",
        "map.png",
        "normalization.json",
        "dataset.json",
    ] {
        assert!(p.path("data/a").join(f).is_file(), "{f} missing");
    }
    // The generator's truth rides along per sample, not as a feature.
    let truth = &first["true_probability"];
    assert_eq!(truth["column"], "true_ignition_probability", "{first}");
    assert_eq!(truth["samples_with_value"], first["samples"]);
    // This small box yields no negatives (the forecasting tests build a denser dataset and
    // check the separation there): the negative mean is null exactly when there are none.
    assert!(truth["mean_positive"].as_f64().unwrap() > 0.0, "{first}");
    assert_eq!(
        truth["mean_negative"].is_null(),
        first["samples"] == first["positives"],
        "{first}"
    );
    assert!(
        !first["features"]
            .as_array()
            .unwrap()
            .iter()
            .any(|f| f == "true_ignition_probability")
    );
    let card = p.read("data/a/card.md");
    assert!(
        card.contains("## Samples per tier") && card.contains("How the sources were made"),
        "{card}"
    );
    // Every dropped row with its physical line: rows count from 1 after the header line and
    // the synthetic CSV has no multi-line records, so line = row + 1.
    let rejects = p.read("work/ignitions.rejects.csv");
    let mut lines = rejects.lines();
    assert_eq!(lines.next(), Some("row,line,reason,detail"));
    let mut n = 0;
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        let (row, line): (u64, u64) = (f[0].parse().unwrap(), f[1].parse().unwrap());
        assert_eq!(line, row + 1, "{l}");
        n += 1;
    }
    assert!(n > 0, "the synthetic sources have duplicate reports to drop");

    // pandas' default Parquet (snappy, pandas metadata) reads like our own: the same windows.
    let py = venv_bin("python");
    let rewrite = std::process::Command::new(&py)
        .args([
            "-c",
            "import sys, pandas as pd, pyarrow.parquet as pq\n\
             pd.read_parquet(sys.argv[1]).to_parquet(sys.argv[2])\n\
             print(pq.ParquetFile(sys.argv[2]).metadata.row_group(0).column(0).compression)",
            p.path("work/samples.parquet").to_str().unwrap(),
            p.path("work/samples-pandas.parquet").to_str().unwrap(),
        ])
        .output()
        .unwrap_or_else(|e| panic!("{}: {e} (run `cargo xtask setup`)", py.display()));
    assert!(rewrite.status.success(), "{}", describe(&rewrite));
    assert_eq!(String::from_utf8_lossy(&rewrite.stdout).trim(), "SNAPPY");
    let windows_from_pandas = p.json(&[
        "dataset",
        "windows",
        "--samples",
        "work/samples-pandas.parquet",
        "--gridmet",
        p.path("src/gridmet").to_str().unwrap(),
        "--out",
        "work/windows-pandas",
    ]);
    assert_eq!(
        windows_from_pandas["samples_out"], first["samples"],
        "{windows_from_pandas}"
    );
    assert_eq!(
        std::fs::read(p.path("work/windows-pandas/days.parquet")).unwrap(),
        std::fs::read(p.path("work/windows/days.parquet")).unwrap(),
        "the same samples read from pandas' file give other windows"
    );

    // Same sources, config and seeds: the same version, byte-identical tables.
    std::fs::remove_dir_all(p.path("work/windows")).unwrap();
    let second = build_paper_dataset(&p, "data/b");
    assert_eq!(first["version"], second["version"]);
    assert_eq!(
        std::fs::read(p.path("data/a/days.parquet")).unwrap(),
        std::fs::read(p.path("data/b/days.parquet")).unwrap()
    );

    // An existing output is never replaced.
    let out = p
        .firecast()
        .args([
            "dataset",
            "build",
            "--windows",
            "work/windows",
            "--out",
            "data/a",
            "--name",
            "x",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("already exists"),
        "{}",
        describe(&out)
    );

    // Publish for Kaggle, then import the published CSV back.
    let published = p.json(&[
        "dataset",
        "publish-kaggle",
        "--dataset",
        "data/a",
        "--out",
        "kaggle",
        "--id",
        "someone/firecast-cli-test",
        "--title",
        "FireCast CLI test",
    ]);
    let meta: serde_json::Value = serde_json::from_str(&p.read("kaggle/dataset-metadata.json")).unwrap();
    assert_eq!(
        meta["resources"][0]["schema"]["fields"].as_array().unwrap().len(),
        19
    );
    let csv = p.read("kaggle/Wildfire_Dataset.csv");
    assert!(csv.starts_with("latitude,longitude,datetime,Wildfire,pr,rmax,rmin,sph,srad,tmmn,tmmx,vs,bi,fm100,fm1000,erc,etr,pet,vpd\n"));
    let imported = p.json(&[
        "dataset",
        "import-kaggle",
        "--csv",
        "kaggle/Wildfire_Dataset.csv",
        "--out",
        "work/imported",
    ]);
    assert_eq!(imported["rows"], published["csv_rows"]);
    assert_eq!(imported["kept_positive"], first["positives"]);
    // The imported windows build a dataset an experiment can use, labels intact.
    let rebuilt = p.json(&[
        "dataset",
        "build",
        "--windows",
        "work/imported",
        "--out",
        "data/kaggle",
        "--name",
        "kaggle-import",
        "--framing",
        "paper",
    ]);
    assert_eq!(rebuilt["samples"], first["samples"], "{rebuilt}");
    assert_eq!(rebuilt["positives"], first["positives"], "{rebuilt}");

    // A slug Kaggle would refuse is caught before anything is written.
    let out = p
        .firecast()
        .args([
            "dataset",
            "publish-kaggle",
            "--dataset",
            "data/a",
            "--out",
            "k2",
            "--id",
            "me/abc",
            "--title",
            "FireCast CLI test",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("slug `abc` must be 6 to 50 characters"),
        "{}",
        describe(&out)
    );
    assert!(!p.path("k2").exists());
}

#[test]
fn bad_params_name_the_file_and_key() {
    let p = Project::new();
    p.write(
        "neg.yaml",
        "variant: paper\nfar_count: 10\nfar_min_kilometres: 5\n",
    );
    let out = p
        .firecast()
        .args([
            "dataset",
            "negatives",
            "--ignitions",
            "none.parquet",
            "--out",
            "x.parquet",
            "--config",
            "neg.yaml",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("neg.yaml: far_min_kilometres: unknown field `far_min_kilometres`"),
        "{err}"
    );
}

#[test]
fn bench_gridmet_runs_the_xarray_reference_beside_firecast() {
    let p = Project::new();
    let python = venv_bin("python");
    let report = p.json(&[
        "bench",
        "gridmet",
        "--dir",
        "bench",
        "--samples",
        "40",
        "--years",
        "2019-2019",
        "--variables",
        "pr,tmmx",
        "--region",
        REGION,
        "--python",
        python.to_str().unwrap(),
    ]);
    let agreement = &report["agreement"];
    assert_eq!(agreement["values"].as_u64().unwrap(), 40 * 75 * 2);
    assert_eq!(agreement["missing_mismatches"].as_u64().unwrap(), 0, "{report}");
    assert!(agreement["max_abs_diff"].as_f64().unwrap() < 1e-3, "{report}");
    assert!(report["speedup"].as_f64().unwrap() > 0.0);
}
