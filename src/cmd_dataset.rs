//! `firecast dataset …`: every dataset step on its own, with the same functions and params
//! the pipeline stage kinds use. Params come from `--config FILE.yaml` (strict, the same
//! keys as the stage's `params:`), overridden by flags.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args, Subcommand};
use firecast_dataset::stage;
use serde::de::DeserializeOwned;
use serde_json::{Value, json};

use crate::output;
use crate::settings::Settings;

#[derive(Debug, Subcommand)]
pub enum DatasetCommand {
    /// Write synthetic WFIGS incidents and GRIDMET NetCDF files (a seeded test bed in the
    /// real formats).
    Synthesize(SynthesizeArgs),
    /// Incidents (WFIGS CSV / GeoJSON / Esri JSON) → de-duplicated ignitions (Parquet) and a
    /// reject report listing every dropped row.
    Ignitions(IgnitionsArgs),
    /// Ignitions → ignitions + far, near and yearly negatives (Parquet), seeded.
    Negatives(NegativesArgs),
    /// Samples + GRIDMET files → weather windows (each file read once).
    Windows(WindowsArgs),
    /// Windows → a versioned dataset: framing, splits, normalisation, card, map.
    Build(BuildArgs),
    /// The published FireCastRL CSV (Wildfire_Dataset.csv) → windows, with a report of fill
    /// values, overlapping, contradictory and cut-short windows.
    ImportKaggle(ImportKaggleArgs),
    /// A dataset → a published folder: the tables per split (and the FireCastRL CSV for a
    /// `paper` framing), `croissant.json` (Croissant 1.1), `README.md` (Hugging Face card) and
    /// `dataset-metadata.json` (Kaggle), checked and read back; nothing is uploaded.
    #[command(alias = "publish-kaggle")]
    Publish(PublishArgs),
    /// Check a published folder: every file against croissant.json's SHA-256, and (with
    /// `--dataset`) its tables equal to that dataset.
    VerifyPublished {
        /// The published folder.
        dir: PathBuf,
        /// The dataset it was published from.
        #[arg(long, value_name = "DIR")]
        dataset: Option<PathBuf>,
    },
    /// Show a dataset's manifest.
    Show {
        /// Dataset directory.
        dir: PathBuf,
    },
}

#[derive(Debug, Args)]
pub struct CommonArgs {
    /// Params as YAML (the keys of the stage's `params:`); flags override it.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct SynthesizeArgs {
    /// Output directory (gridmet/ and incidents/ are created in it).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    #[arg(long)]
    pub seed: Option<u64>,
    /// First and last year, e.g. 2019-2020.
    #[arg(long, value_name = "YYYY-YYYY")]
    pub years: Option<String>,
    /// `conus`, or a box `LAT_MIN,LAT_MAX,LON_MIN,LON_MAX`.
    #[arg(long, value_name = "REGION")]
    pub region: Option<String>,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct IgnitionsArgs {
    #[arg(long, value_name = "FILE")]
    pub incidents: PathBuf,
    /// GRIDMET directory for the land mask.
    #[arg(long, value_name = "DIR")]
    pub gridmet: Option<PathBuf>,
    /// Ignitions (Parquet).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Reject report (CSV) [default: next to --out].
    #[arg(long, value_name = "FILE")]
    pub rejects: Option<PathBuf>,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct NegativesArgs {
    #[arg(long, value_name = "FILE")]
    pub ignitions: PathBuf,
    #[arg(long, value_name = "DIR")]
    pub gridmet: Option<PathBuf>,
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// `paper` or `code`.
    #[arg(long)]
    pub variant: Option<String>,
    #[arg(long)]
    pub seed: Option<u64>,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct WindowsArgs {
    #[arg(long, value_name = "FILE")]
    pub samples: PathBuf,
    #[arg(long, value_name = "DIR")]
    pub gridmet: PathBuf,
    /// Synthetic truth directory (`truth/` of `dataset synthesize`): each sample's true
    /// ignition probability, stored as `true_ignition_probability` (never a feature).
    #[arg(long, value_name = "DIR")]
    pub truth: Option<PathBuf>,
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct BuildArgs {
    #[arg(long, value_name = "DIR")]
    pub windows: PathBuf,
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    #[arg(long)]
    pub name: Option<String>,
    /// `paper` or `forecast`.
    #[arg(long)]
    pub framing: Option<String>,
    /// Markdown describing the sources, embedded in the card.
    #[arg(long, value_name = "FILE")]
    pub source_model: Option<PathBuf>,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct ImportKaggleArgs {
    /// The published CSV.
    #[arg(long, value_name = "FILE")]
    pub csv: PathBuf,
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    #[command(flatten)]
    pub common: CommonArgs,
}

#[derive(Debug, Args)]
pub struct PublishArgs {
    /// A dataset directory (`firecast dataset build`).
    #[arg(long, value_name = "DIR")]
    pub dataset: PathBuf,
    /// The upload folder to create (must not exist).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// `<owner>/<dataset-slug>`.
    #[arg(long)]
    pub id: Option<String>,
    #[arg(long)]
    pub title: Option<String>,
    #[arg(long)]
    pub subtitle: Option<String>,
    #[arg(long)]
    pub license: Option<String>,
    /// Publication date, `YYYY-MM-DD` (Croissant's `datePublished`; default today, UTC).
    #[arg(long, value_name = "DATE")]
    pub date_published: Option<String>,
    #[command(flatten)]
    pub common: CommonArgs,
}

/// Params from `--config` (YAML) with flag overrides, deserialized strictly.
fn params<T: DeserializeOwned>(
    config: Option<&Path>,
    overrides: &[(&str, Option<Value>)],
) -> anyhow::Result<T> {
    let mut value = match config {
        Some(path) => {
            let text =
                std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
            let yaml: serde_yaml_ng::Value =
                serde_yaml_ng::from_str(&text).with_context(|| format!("{}: not YAML", path.display()))?;
            firecast_pipeline::spec::yaml_to_json(&yaml)
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
        }
        None => json!({}),
    };
    if value.is_null() {
        value = json!({});
    }
    let Some(map) = value.as_object_mut() else {
        anyhow::bail!(
            "{}: expected a mapping of params",
            config.map_or("<flags>".into(), |p| p.display().to_string())
        );
    };
    for (key, v) in overrides {
        if let Some(v) = v {
            map.insert((*key).to_string(), v.clone());
        }
    }
    firecast_pipeline::stage::deserialize_params(&value).map_err(|e| {
        let origin = config.map_or("flags".to_string(), |p| p.display().to_string());
        let key = if e.path.is_empty() {
            String::new()
        } else {
            format!("{}: ", e.path)
        };
        anyhow::anyhow!("{origin}: {key}{}", e.message)
    })
}

fn progress_bar(settings: &Settings, message: &'static str) -> indicatif::ProgressBar {
    if !settings.progress || settings.json {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(message);
    bar
}

fn print(
    settings: &Settings,
    value: &impl serde::Serialize,
    human: impl FnOnce(),
) -> anyhow::Result<ExitCode> {
    if settings.json {
        output::print_json(value)?;
    } else {
        human();
    }
    Ok(ExitCode::SUCCESS)
}

/// A directory output is built under a temporary sibling and renamed into place, so a
/// half-built dataset is never visible; an existing directory is not replaced.
fn with_fresh_dir<R>(out: &Path, build: impl FnOnce(&Path) -> anyhow::Result<R>) -> anyhow::Result<R> {
    if out.exists() {
        anyhow::bail!(
            "{} already exists; remove it or choose another path (nothing was changed)",
            out.display()
        );
    }
    // The staging folder is removed when dropped unpublished (a failed build).
    let staged = firecast_fs::TempPath::dir(out)?;
    let r = build(staged.path())?;
    staged
        .publish()
        .with_context(|| format!("cannot rename into {}", out.display()))?;
    Ok(r)
}

fn parent_dir(path: &Path) -> anyhow::Result<()> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).with_context(|| format!("cannot create {}", parent.display()))?;
    }
    Ok(())
}

pub fn run(settings: &Settings, command: DatasetCommand) -> anyhow::Result<ExitCode> {
    match command {
        DatasetCommand::Synthesize(args) => synthesize(settings, &args),
        DatasetCommand::Ignitions(a) => {
            let p: stage::IgnitionParams = params(a.common.config.as_deref(), &[])?;
            parent_dir(&a.out)?;
            let rejects = a
                .rejects
                .clone()
                .unwrap_or_else(|| a.out.with_extension("rejects.csv"));
            let r = stage::run_ignitions(&a.incidents, a.gridmet.as_deref(), &p, &a.out, &rejects)?;
            print(settings, &r, || {
                println!("{} rows read from {}", r.rows_read, r.incidents_file);
                for (reason, n) in &r.rejected {
                    println!("  rejected by the reader, {reason}: {n}");
                }
                let c = &r.rules;
                println!("  outside the region: {}", c.outside_region);
                println!("  off land (no GRIDMET data): {}", c.off_land);
                println!(
                    "  within the time gap of the last kept report: {}",
                    c.within_gap_hours
                );
                println!(
                    "  within the distance of the last kept report: {}",
                    c.within_distance_km
                );
                println!("{} ignitions -> {}", c.kept, a.out.display());
                println!("reject report -> {}", rejects.display());
            })
        }
        DatasetCommand::Negatives(a) => {
            let cfg: firecast_dataset::sampling::NegativeConfig = params(
                a.common.config.as_deref(),
                &[
                    ("variant", a.variant.clone().map(Value::from)),
                    ("seed", a.seed.map(Value::from)),
                ],
            )?;
            parent_dir(&a.out)?;
            let r = stage::run_negatives(&a.ignitions, a.gridmet.as_deref(), &cfg, &a.out)?;
            print(settings, &r, || {
                let mut t = output::table(&["tier", "requested", "accepted", "candidates", "rejected"]);
                for (name, tr) in [("far", &r.far), ("near", &r.near), ("yearly", &r.yearly)] {
                    t.add_row(vec![
                        name.to_string(),
                        tr.requested.map_or("per positive".into(), |n| n.to_string()),
                        tr.accepted.to_string(),
                        tr.candidates.to_string(),
                        output::ellipsize(&format!("{:?}", tr.rejected), 70),
                    ]);
                }
                let _ = output::print_table(&t);
                println!(
                    "{} positives + negatives = {} samples -> {}",
                    r.positives,
                    r.samples,
                    a.out.display()
                );
            })
        }
        DatasetCommand::Windows(a) => {
            let cfg: firecast_dataset::windows::ExtractConfig = params(a.common.config.as_deref(), &[])?;
            let bar = progress_bar(settings, "GRIDMET files");
            let m = with_fresh_dir(&a.out, |dir| {
                let progress = |done: u64, total: u64| {
                    bar.set_length(total);
                    bar.set_position(done);
                };
                Ok(stage::run_windows_with_truth(
                    &a.samples,
                    &a.gridmet,
                    a.truth.as_deref(),
                    &cfg,
                    dir,
                    &progress,
                )?)
            })?;
            bar.finish_and_clear();
            print(settings, &m.report, || {
                println!(
                    "{} of {} samples have {}-day windows of {} variables; {} GRIDMET files read",
                    m.report.samples_out,
                    m.report.samples_in,
                    m.config.last_offset - m.config.first_offset + 1,
                    m.config.variables.len(),
                    m.report.files_read
                );
                for (reason, n) in &m.report.dropped {
                    println!("  dropped, {reason}: {n}");
                }
                if let Some(t) = &m.truth {
                    println!(
                        "true ignition probability for {} samples ({} on masked cells) from {} file(s)",
                        t.samples_with_value, t.samples_masked, t.files_read
                    );
                }
                println!("-> {}", a.out.display());
            })
        }
        DatasetCommand::Build(a) => {
            let framing = a.framing.clone().map(|k| json!({ "kind": k }));
            let cfg: firecast_dataset::dataset::DatasetConfig = params(
                a.common.config.as_deref(),
                &[("name", a.name.clone().map(Value::from)), ("framing", framing)],
            )?;
            let m = with_fresh_dir(&a.out, |dir| {
                Ok(stage::run_dataset(
                    &a.windows,
                    a.source_model.as_deref(),
                    &cfg,
                    dir,
                )?)
            })?;
            print(settings, &m, || print_manifest(&m, &a.out))
        }
        DatasetCommand::ImportKaggle(a) => {
            let cfg: firecast_dataset::kaggle::ImportConfig = params(a.common.config.as_deref(), &[])?;
            let bar = progress_bar(settings, "CSV rows");
            let (r, _) = with_fresh_dir(&a.out, |dir| {
                Ok(stage::run_import_kaggle(&a.csv, &cfg, dir, &mut |rows| {
                    bar.set_position(rows)
                })?)
            })?;
            bar.finish_and_clear();
            print(settings, &r, || {
                for (k, v) in firecast_dataset::kaggle::report_lines(&r) {
                    println!("{k:>22}: {v}");
                }
                println!(
                    "{:>22}: {} positive, {} negative",
                    "kept", r.kept_positive, r.kept_negative
                );
                println!("{:>22}: {}", "fill rows (>= 30000)", r.fill_rows);
                println!("{:>22}: {}", "duplicate place-dates", r.duplicate_place_dates);
                println!("-> {}", a.out.display());
            })
        }
        DatasetCommand::Publish(a) => {
            let cfg: firecast_dataset::publish::PublishConfig = params(
                a.common.config.as_deref(),
                &[
                    ("id", a.id.clone().map(Value::from)),
                    ("title", a.title.clone().map(Value::from)),
                    ("subtitle", a.subtitle.clone().map(Value::from)),
                    ("license", a.license.clone().map(Value::from)),
                    ("date_published", a.date_published.clone().map(Value::from)),
                ],
            )?;
            let r = firecast_dataset::publish::publish(&a.dataset, &a.out, &cfg)?;
            print(settings, &r, || {
                if let Some(rows) = r.csv_rows {
                    println!("{rows} CSV rows");
                }
                for s in &r.splits {
                    println!("{}: {} samples ({} positive)", s.name, s.samples, s.positives);
                }
                println!("version {}; files: {}", r.version, r.files.join(", "));
                println!(
                    "croissant.json (Croissant 1.1), README.md (Hugging Face card) and \
                     dataset-metadata.json (validated against the kaggle client's rules) written; \
                     the folder reads back as the dataset"
                );
                println!("upload with: kaggle datasets create -p {}", r.folder.display());
            })
        }
        DatasetCommand::VerifyPublished { dir, dataset } => {
            let r = firecast_dataset::publish::verify(&dir, dataset.as_deref())?;
            print(settings, &r, || {
                println!(
                    "{} files match croissant.json's SHA-256; {} samples ({})",
                    r.files_checked,
                    r.samples,
                    r.splits
                        .iter()
                        .map(|(k, v)| format!("{k} {v}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                );
                if let Some(d) = &r.dataset {
                    println!("equal to the dataset {}", d.display());
                }
            })
        }
        DatasetCommand::Show { dir } => {
            let m = firecast_dataset::dataset::read_manifest(&dir)?;
            print(settings, &m, || print_manifest(&m, &dir))
        }
    }
}

fn print_manifest(m: &firecast_dataset::dataset::DatasetManifest, dir: &Path) {
    println!("{} {} -> {}", m.name, m.version, dir.display());
    println!(
        "  {} samples ({} positive), {} day rows, days {}..{}, framing {:?}",
        m.samples, m.positives, m.day_rows, m.day_offsets.0, m.day_offsets.1, m.framing.kind
    );
    let splits: Vec<String> = m.splits.iter().map(|(k, v)| format!("{k} {v}")).collect();
    println!(
        "  splits: {}{}",
        splits.join(", "),
        m.test_from
            .as_ref()
            .map_or(String::new(), |d| format!(" (test from {d})"))
    );
    println!(
        "  card: {}",
        dir.join(firecast_dataset::dataset::CARD_FILE).display()
    );
}

fn synthesize(settings: &Settings, a: &SynthesizeArgs) -> anyhow::Result<ExitCode> {
    let years = match &a.years {
        Some(y) => {
            let (first, last) = y.split_once('-').unwrap_or((y, y));
            let parse = |s: &str| {
                s.trim()
                    .parse::<i32>()
                    .with_context(|| format!("--years: `{y}` is not YYYY-YYYY"))
            };
            Some(json!([parse(first)?, parse(last)?]))
        }
        None => None,
    };
    let region = a
        .region
        .as_deref()
        .map(|r| {
            let region: stage::RegionParam = r.parse().map_err(|e| anyhow::anyhow!("--region: {e}"))?;
            anyhow::Ok(serde_json::to_value(region)?)
        })
        .transpose()?;
    let p: stage::SynthParams = params(
        a.common.config.as_deref(),
        &[
            ("seed", a.seed.map(Value::from)),
            ("years", years),
            ("region", region),
        ],
    )?;
    let bar = progress_bar(settings, "simulated days");
    let r = with_fresh_dir(&a.out, |dir| {
        Ok(stage::run_synthesize(&p, dir, &mut |done, total| {
            bar.set_length(total);
            bar.set_position(done);
        })?)
    })?;
    bar.finish_and_clear();
    print(settings, &r, || {
        println!(
            "{} GRIDMET files ({} x {} cells, {} with data) and {} incident records ({} ignitions) -> {}",
            r.gridmet_files,
            r.grid.0,
            r.grid.1,
            r.land_cells,
            r.reported_records,
            r.ignitions,
            a.out.display()
        );
        println!(
            "synthetic test bed; the generative model is in {}",
            a.out.join(stage::SOURCE_MODEL_FILE).display()
        );
    })
}
