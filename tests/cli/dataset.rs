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

    // Publish (Croissant, Hugging Face card, Kaggle metadata, tables per split), then import
    // the published CSV back.
    let published = p.json(&[
        "dataset",
        "publish",
        "--dataset",
        "data/a",
        "--out",
        "kaggle",
        "--id",
        "someone/firecast-cli-test",
        "--title",
        "FireCast CLI test",
        "--date-published",
        "2026-11-28",
    ]);
    let meta: serde_json::Value = serde_json::from_str(&p.read("kaggle/dataset-metadata.json")).unwrap();
    assert_eq!(
        meta["resources"][0]["schema"]["fields"].as_array().unwrap().len(),
        19
    );
    let csv = p.read("kaggle/Wildfire_Dataset.csv");
    assert!(csv.starts_with("latitude,longitude,datetime,Wildfire,pr,rmax,rmin,sph,srad,tmmn,tmmx,vs,bi,fm100,fm1000,erc,etr,pet,vpd\n"));
    check_publication(&p, "data/a", "kaggle", &first, &published, &meta);
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

    // A forecast-framed dataset publishes the same way, without the FireCastRL CSV.
    let forecast = p.json(&[
        "dataset",
        "build",
        "--windows",
        "work/windows",
        "--out",
        "data/forecast",
        "--name",
        "cli-forecast",
    ]);
    let published_forecast = p.json(&[
        "dataset",
        "publish",
        "--dataset",
        "data/forecast",
        "--out",
        "published-forecast",
        "--id",
        "someone/firecast-cli-forecast",
        "--title",
        "FireCast CLI forecast test",
        "--date-published",
        "2026-11-28",
    ]);
    assert!(published_forecast["csv_rows"].is_null(), "{published_forecast}");
    assert!(!p.path("published-forecast/Wildfire_Dataset.csv").exists());
    let meta_forecast: serde_json::Value =
        serde_json::from_str(&p.read("published-forecast/dataset-metadata.json")).unwrap();
    check_publication(
        &p,
        "data/forecast",
        "published-forecast",
        &forecast,
        &published_forecast,
        &meta_forecast,
    );

    // A slug Kaggle would refuse is caught before anything is written.
    let out = p
        .firecast()
        .args([
            "dataset",
            "publish-kaggle", // the command's former name, kept as an alias
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

    // A dataset whose files do not match dataset.json is refused, the damaged file named.
    let path = p.path("data/b/samples.parquet");
    let mut bytes = std::fs::read(&path).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x55;
    std::fs::write(&path, &bytes).unwrap();
    let out = p
        .firecast()
        .args([
            "dataset",
            "publish",
            "--dataset",
            "data/b",
            "--out",
            "k3",
            "--id",
            "someone/firecast-cli-test",
            "--title",
            "FireCast CLI test",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success(), "{}", describe(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("samples.parquet") && err.contains("do not match dataset.json"),
        "{err}"
    );
    assert!(!p.path("k3").exists());
}

/// Checks a folder `firecast dataset publish` wrote from the dataset `first` describes: the
/// three metadata files say the same things, `verify-published` finds it equal to the
/// dataset, mlcroissant validates `croissant.json` and reads every record set back equal to
/// the Parquet files, and a damaged file is named.
fn check_publication(
    p: &Project,
    dataset: &str,
    folder: &str,
    first: &serde_json::Value,
    published: &serde_json::Value,
    kaggle: &serde_json::Value,
) {
    let croissant: serde_json::Value =
        serde_json::from_str(&p.read(&format!("{folder}/croissant.json"))).unwrap();
    assert_eq!(croissant["conformsTo"], "http://mlcommons.org/croissant/1.1");
    assert_eq!(croissant["datePublished"], "2026-11-28");
    let version = published["version"].as_str().unwrap();
    assert_eq!(croissant["version"], version);
    assert_eq!(version, format!("1.0.0+{}", first["version"].as_str().unwrap()));
    // Synthetic sources: the notice opens every description.
    let notice = "SYNTHETIC DATA";
    assert!(
        croissant["description"].as_str().unwrap().starts_with(notice),
        "{croissant}"
    );
    assert!(kaggle["description"].as_str().unwrap().contains(notice));
    for key in [
        "rai:dataCollection",
        "rai:dataLimitations",
        "rai:dataBiases",
        "rai:personalSensitiveInformation",
        "rai:dataUseCases",
        "rai:dataPreprocessingProtocol",
        "citeAs",
        "license",
    ] {
        assert!(!croissant[key].is_null(), "croissant.json has no {key}");
    }
    // The splits, from the one source: Croissant's split record set, the card's front matter
    // and Kaggle's resources name the same files.
    let splits: Vec<String> = published["splits"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap().to_string())
        .collect();
    let manifest_splits = first["splits"].as_object().unwrap();
    assert_eq!(splits.len(), manifest_splits.len(), "{published}");
    let readme = p.read(&format!("{folder}/README.md"));
    assert!(readme.starts_with("---\nlicense: cc-by-4.0\n"), "{readme}");
    for s in &splits {
        for t in ["samples", "days"] {
            let file = format!("{t}-{s}.parquet");
            assert!(p.path(folder).join(&file).is_file(), "{file}");
            assert!(
                readme.contains(&format!("  - split: {s}\n    path: {file}\n")),
                "{readme}"
            );
            assert!(
                kaggle["resources"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .any(|r| r["path"] == file.as_str()),
                "{kaggle}"
            );
            assert!(
                croissant["distribution"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .any(|d| d["contentUrl"] == file.as_str() && d["sha256"].as_str().unwrap().len() == 64),
                "{file} has no checksummed FileObject"
            );
        }
    }

    // Read back: every file matches its SHA-256 and the tables equal the dataset's.
    let verified = p.json(&["dataset", "verify-published", folder, "--dataset", dataset]);
    assert_eq!(verified["samples"], first["samples"], "{verified}");
    assert_eq!(verified["splits"], first["splits"], "{verified}");

    // mlcroissant (PyPI, pinned by xtask) validates the file and reads every record set.
    let python = venv_bin("python");
    let has_mlcroissant = std::process::Command::new(&python)
        .args(["-c", "import mlcroissant"])
        .output()
        .is_ok_and(|o| o.status.success());
    if has_mlcroissant {
        let jsonld = p.path(folder).join("croissant.json");
        let cli = std::process::Command::new(venv_bin("mlcroissant"))
            .args(["validate", "--jsonld", jsonld.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(cli.status.success(), "{}", describe(&cli));
        let out = std::process::Command::new(&python)
            .args(["-c", CROISSANT_READ_BACK, p.path(folder).to_str().unwrap()])
            .env("CROISSANT_CACHE", p.path("croissant-cache"))
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", describe(&out));
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let samples = first["samples"].as_u64().unwrap();
        let offsets = first["day_offsets"].as_array().unwrap();
        let n_days = (offsets[1].as_i64().unwrap() - offsets[0].as_i64().unwrap() + 1) as u64;
        assert_eq!(report["samples"]["rows"], samples, "{report}");
        assert_eq!(report["days"]["rows"], samples * n_days, "{report}");
        assert_eq!(report["wildfire_csv"]["rows"], published["csv_rows"], "{report}");
        assert_eq!(report["splits"]["rows"], splits.len(), "{report}");
        assert_eq!(
            report["hf_configs"],
            serde_json::json!(["days", "samples"]),
            "{report}"
        );
        assert_eq!(report["samples"]["by_split"], first["splits"], "{report}");
        for s in &splits {
            assert_eq!(
                report["days"]["by_split"][s].as_u64().unwrap(),
                first["splits"][s].as_u64().unwrap() * n_days,
                "{report}"
            );
        }
    } else {
        eprintln!(
            "skipped the mlcroissant checks: {} cannot import mlcroissant (`cargo xtask setup` installs it)",
            python.display()
        );
    }

    // A damaged published file is refused by its own name.
    let victim = format!("days-{}.parquet", splits[0]);
    let path = p.path(folder).join(&victim);
    let mut bytes = std::fs::read(&path).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x55;
    std::fs::write(&path, &bytes).unwrap();
    let out = p
        .firecast()
        .args(["dataset", "verify-published", folder])
        .output()
        .unwrap();
    assert!(!out.status.success(), "{}", describe(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&victim) && err.contains("do not match croissant.json"),
        "{err}"
    );
    bytes[mid] ^= 0x55;
    std::fs::write(&path, &bytes).unwrap();
}

/// mlcroissant validates `croissant.json` (a `ValidationError` otherwise), hashlib checks
/// every FileObject's SHA-256, and every record set is generated: its rows, rows per split,
/// and for each split every value of its first and last records compared with the Parquet
/// file pandas reads.
const CROISSANT_READ_BACK: &str = r#"
import datetime, hashlib, json, os, sys
import numpy as np, pandas as pd
import mlcroissant as mlc

folder = sys.argv[1]
path = os.path.join(folder, "croissant.json")
ds = mlc.Dataset(jsonld=path)
meta = json.load(open(path))
for d in meta["distribution"]:
    if d["@type"] == "cr:FileObject":
        with open(os.path.join(folder, d["contentUrl"]), "rb") as f:
            assert hashlib.sha256(f.read()).hexdigest() == d["sha256"], d["contentUrl"]

def norm(v):
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, (pd.Timestamp, datetime.datetime, datetime.date)):
        t = pd.Timestamp(v)
        if t.tzinfo is not None:
            t = t.tz_convert("UTC").tz_localize(None)
        return t.isoformat()
    if v is None or (np.isscalar(v) and not isinstance(v, str) and pd.isna(v)):
        return None
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return float(v)
    return v

# The Hugging Face card's front matter: every config's data file per split exists, and its
# features (names, dtypes as `datasets` spells Arrow's) and row counts are the file's.
import pyarrow.parquet as pq, yaml
readme = open(os.path.join(folder, "README.md")).read()
assert readme.startswith("---\n"), readme[:100]
front = yaml.safe_load(readme.split("---\n", 2)[1])
info = {c["config_name"]: c for c in front["dataset_info"]}
spelled = {"float": "float32", "double": "float64", "date32[day]": "date32", "large_string": "string"}
for config in front["configs"]:
    name = config["config_name"]
    features = [(f["name"], f["dtype"]) for f in info[name]["features"]]
    rows = {s["name"]: s["num_examples"] for s in info[name]["splits"]}
    for spec in config["data_files"]:
        schema = pq.read_schema(os.path.join(folder, spec["path"]))
        have = [(f.name, spelled.get(str(f.type), str(f.type))) for f in schema]
        assert have == features, (spec, have, features)
        assert pq.ParquetFile(os.path.join(folder, spec["path"])).metadata.num_rows == rows[spec["split"]]

out = {"hf_configs": sorted(info)}
for rs in meta["recordSet"]:
    rid = rs["@id"]
    records = [{k.split("/", 1)[1]: norm(v) for k, v in r.items()} for r in ds.records(rid)]
    info = {"rows": len(records)}
    if rid in ("samples", "days"):
        by_split = {}
        for r in records:
            by_split.setdefault(r["split"], []).append(r)
        info["by_split"] = {k: len(v) for k, v in by_split.items()}
        for split, rows in by_split.items():
            df = pd.read_parquet(os.path.join(folder, f"{rid}-{split}.parquet"))
            assert len(df) == len(rows), (rid, split, len(df), len(rows))
            key = ["sample_id"] if rid == "samples" else ["sample_id", "day_index"]
            mine = {tuple(r[k] for k in key): r for r in rows}
            for i in sorted({0, len(df) // 2, len(df) - 1}):
                want = {c: norm(df[c].iloc[i]) for c in df.columns}
                got = mine[tuple(want[k] for k in key)]
                for c, v in want.items():
                    assert got[c] == v, (rid, split, i, c, got[c], v)
    if rid == "wildfire_csv":
        df = pd.read_csv(os.path.join(folder, "Wildfire_Dataset.csv"))
        assert len(df) == len(records)
        assert records[0]["Wildfire"] == df["Wildfire"].iloc[0]
        assert abs(records[0]["latitude"] - df["latitude"].iloc[0]) < 1e-9
    out[rid] = info
print(json.dumps(out))
"#;

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
