//! The dataset steps as functions (which the CLI calls) and as pipeline stage kinds (which
//! call the same functions): `data.ignitions`, `data.negatives`, `data.windows`,
//! `data.dataset`, `data.import_kaggle`.

use std::collections::BTreeMap;
use std::path::Path;

use firecast_data::incidents::{IncidentFilter, read_incidents};
use firecast_pipeline::{
    DatasetRecord, ParamsError, Port, Ports, StageContext, StageError, StageKind, typed_params,
};
use serde::{Deserialize, Serialize};

use crate::card::MapGrid;
use crate::dataset::{DatasetConfig, DatasetManifest};
use crate::kaggle::{ImportConfig, ImportReport};
use crate::land::LandMask;
use crate::sampling::{IgnitionCounts, IgnitionRules, IncidentPoint, NegativeConfig, TierReport};
use crate::truth::{TruthLookup, TruthReport};
use crate::windows::{ExtractConfig, ExtractHead, ExtractPlan, ExtractReport, Gathered};
use crate::{DatasetError, table};

/// Params of the ignition step.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IgnitionParams {
    /// `IncidentTypeCategory` values to keep (default `[WF]`).
    #[serde(default = "default_categories")]
    pub categories: Vec<String>,
    #[serde(default, flatten)]
    pub rules: IgnitionRules,
}

fn default_categories() -> Vec<String> {
    vec!["WF".into()]
}

/// What the ignition step did.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct IgnitionsReport {
    pub incidents_file: String,
    pub rows_read: u64,
    /// Rows the reader dropped, by reason.
    pub rejected: BTreeMap<String, u64>,
    /// The de-duplication and region rules, per rule.
    pub rules: IgnitionCounts,
    pub land_mask: Option<String>,
}

/// Incidents → de-duplicated ignitions (`out`, Parquet) and a reject report (CSV: row, line,
/// reason, detail) listing every row that did not become an ignition.
pub fn run_ignitions(
    incidents: &Path,
    gridmet: Option<&Path>,
    params: &IgnitionParams,
    out: &Path,
    reject_report: &Path,
) -> Result<IgnitionsReport, DatasetError> {
    let table = read_incidents(
        incidents,
        &IncidentFilter {
            categories: params.categories.clone(),
        },
    )?;
    let mask = match gridmet {
        Some(dir) if params.rules.land_mask => Some(LandMask::from_gridmet_dir(dir)?),
        _ => None,
    };
    let points: Vec<IncidentPoint> = table
        .incidents
        .iter()
        .map(|i| IncidentPoint {
            row: i.row,
            time_ms: i.discovered_ms,
            lat: i.lat,
            lon: i.lon,
        })
        .collect();
    let kept = crate::sampling::dedup_ignitions(&points, &params.rules, mask.as_ref());

    // One report for every row that did not become an ignition, in row order, with its line.
    let csv_out = table
        .reject_report_csv(&kept.dropped)
        .map_err(DatasetError::io("writing", reject_report))?;
    firecast_fs::write_atomically(reject_report, &csv_out)?;

    let mut kv = BTreeMap::new();
    kv.insert("firecast.ignitions.source".into(), file_name(incidents));
    kv.insert(
        "firecast.ignitions.source_blake3".into(),
        crate::hash_file(incidents)?,
    );
    table::write_sample_list(out, &kept.positives, &kv)?;
    Ok(IgnitionsReport {
        incidents_file: incidents.display().to_string(),
        rows_read: table.rows_read,
        rejected: table
            .reject_counts()
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect(),
        rules: kept.counts,
        land_mask: mask.map(|m| m.source().display().to_string()),
    })
}

/// What the negative-sampling step did.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct NegativesReport {
    pub positives: u64,
    pub far: TierReport,
    pub near: TierReport,
    pub yearly: TierReport,
    /// Per stratum (period and block), when `strata` was given.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub strata: Vec<crate::sampling::StratumReport>,
    pub samples: u64,
    pub config: NegativeConfig,
}

/// Ignitions → ignitions plus three negative tiers, shuffled (`out`, Parquet).
pub fn run_negatives(
    ignitions: &Path,
    gridmet: Option<&Path>,
    cfg: &NegativeConfig,
    out: &Path,
) -> Result<NegativesReport, DatasetError> {
    let mut positives: Vec<crate::sampling::Sample> = table::read_sample_list(ignitions)?
        .into_iter()
        .map(|s| crate::sampling::Sample {
            lat: s.lat,
            lon: s.lon,
            time_ms: s.time_ms,
            tier: s.tier,
            source_row: s.source_row,
        })
        .collect();
    positives.sort_by_key(|p| (p.time_ms, p.source_row));
    let mask = match gridmet {
        Some(dir) if cfg.land_mask => Some(LandMask::from_gridmet_dir(dir)?),
        _ => None,
    };
    let neg = crate::sampling::sample_negatives(&positives, cfg, mask.as_ref())?;
    let mut kv = BTreeMap::new();
    kv.insert(
        "firecast.negatives.config".into(),
        serde_json::to_string(cfg).unwrap_or_default(),
    );
    table::write_sample_list(out, &neg.samples, &kv)?;
    Ok(NegativesReport {
        positives: positives.len() as u64,
        samples: neg.samples.len() as u64,
        far: neg.far,
        near: neg.near,
        yearly: neg.yearly,
        strata: neg.strata,
        config: cfg.clone(),
    })
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// `windows.json` of an extraction: settings, report and the grid for maps.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct WindowsManifest {
    pub config: ExtractConfig,
    pub report: ExtractReport,
    pub grid: MapGrid,
    /// Where the windows came from (GRIDMET extraction or a Kaggle import).
    pub source: String,
    /// The synthetic generator's truth looked up per sample, when it was given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<TruthReport>,
}

pub const WINDOWS_MANIFEST: &str = "windows.json";

/// Samples + GRIDMET directory → a window table in `out_dir`.
pub fn run_windows(
    samples: &Path,
    gridmet: &Path,
    cfg: &ExtractConfig,
    out_dir: &Path,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<WindowsManifest, DatasetError> {
    run_windows_with_truth(samples, gridmet, None, cfg, out_dir, progress)
}

/// [`run_windows`], plus, with `truth` (a synthetic source's `truth/` folder), each sample's
/// true ignition probability at its cell and event day ([`crate::truth::attach_truth`]).
pub fn run_windows_with_truth(
    samples: &Path,
    gridmet: &Path,
    truth: Option<&Path>,
    cfg: &ExtractConfig,
    out_dir: &Path,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<WindowsManifest, DatasetError> {
    let input = table::read_sample_list(samples)?;
    let plan = ExtractPlan::new(&input, gridmet, cfg)?;
    let gathered = plan.gather(0..plan.n_features(), true, progress)?;
    // Looked up before samples with missing days are dropped, as a sharded run must.
    let truth = truth
        .map(|dir| crate::truth::lookup_truth(&plan.head().kept, dir, true))
        .transpose()?;
    let grid = MapGrid::from_mask(&LandMask::from_gridmet_dir(gridmet)?);
    finish_windows(
        cfg,
        plan.into_head(),
        vec![gathered],
        truth,
        grid,
        windows_source(gridmet),
        out_dir,
    )
}

/// Names, not absolute paths, so the same data built elsewhere is byte-identical; the files
/// themselves are identified by their hashes in the report.
pub(crate) fn windows_source(gridmet: &Path) -> String {
    format!("GRIDMET files in `{}`", file_name(gridmet))
}

/// The gathered variables (all of them, or every shard's) → the window table and its
/// manifest in `out_dir`: the one place both the whole and the sharded `data.windows` write.
pub(crate) fn finish_windows(
    cfg: &ExtractConfig,
    head: ExtractHead,
    parts: Vec<Gathered>,
    truth: Option<TruthLookup>,
    grid: MapGrid,
    source: String,
    out_dir: &Path,
) -> Result<WindowsManifest, DatasetError> {
    let (mut windows, report, slots) = crate::windows::assemble(head, parts)?;
    let truth = match truth {
        Some(lookup) => Some(lookup.apply(&mut windows.samples, &slots)?),
        None => None,
    };
    let manifest = WindowsManifest {
        config: cfg.clone(),
        report,
        grid,
        source,
        truth,
    };
    write_windows(out_dir, &windows, &manifest)?;
    Ok(manifest)
}

fn write_windows(
    out_dir: &Path,
    windows: &crate::windows::WindowTable,
    manifest: &WindowsManifest,
) -> Result<(), DatasetError> {
    table::write_window_table(out_dir, windows, None, &BTreeMap::new())?;
    let text = serde_json::to_string_pretty(manifest).unwrap_or_default();
    Ok(firecast_fs::write_atomically(
        &out_dir.join(WINDOWS_MANIFEST),
        text.as_bytes(),
    )?)
}

fn read_windows_manifest(dir: &Path) -> Result<WindowsManifest, DatasetError> {
    let path = dir.join(WINDOWS_MANIFEST);
    let text = std::fs::read_to_string(&path).map_err(DatasetError::io("reading", &path))?;
    serde_json::from_str(&text).map_err(|e| DatasetError::InputLine {
        path,
        line: e.line() as u64,
        message: e.to_string(),
    })
}

/// The published CSV → a window table in `out_dir`.
pub fn run_import_kaggle(
    csv: &Path,
    cfg: &ImportConfig,
    out_dir: &Path,
    progress: &mut dyn FnMut(u64),
) -> Result<(ImportReport, WindowsManifest), DatasetError> {
    let (windows, report) = crate::kaggle::import(csv, cfg, progress)?;
    let mut source_hashes = BTreeMap::new();
    let name = csv
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    source_hashes.insert(name, crate::hash_file(csv)?);
    let manifest = WindowsManifest {
        config: ExtractConfig::default(),
        report: ExtractReport {
            samples_in: report.windows,
            samples_out: report.kept_windows,
            dropped: crate::kaggle::report_lines(&report)
                .into_iter()
                .filter(|(k, _)| k.ends_with("_windows") && *k != "kept_windows" && *k != "complete_windows")
                .map(|(k, v)| (k.to_string(), v))
                .collect(),
            files_read: 1,
            missing_values: BTreeMap::new(),
            years: (0, 0),
            source_hashes,
        },
        grid: MapGrid::conus(),
        source: format!("Kaggle CSV `{}`", file_name(csv)),
        truth: None,
    };
    write_windows(out_dir, &windows, &manifest)?;
    Ok((report, manifest))
}

/// Windows → a finished, versioned dataset in `out_dir`.
pub fn run_dataset(
    windows_dir: &Path,
    source_model: Option<&Path>,
    cfg: &DatasetConfig,
    out_dir: &Path,
) -> Result<DatasetManifest, DatasetError> {
    let stored = crate::dataset::read_window_table(windows_dir)?;
    let wm = read_windows_manifest(windows_dir)?;
    let built = crate::dataset::build(&stored.table, cfg)?;
    let mut provenance = BTreeMap::new();
    provenance.insert("windows".into(), wm.source.clone());
    for (name, hash) in &wm.report.source_hashes {
        provenance.insert(format!("source {name}"), format!("blake3 {hash}"));
    }
    for (reason, n) in &wm.report.dropped {
        provenance.insert(format!("dropped at extraction: {reason}"), n.to_string());
    }
    if let Some(truth) = &wm.truth {
        for (name, hash) in &truth.source_hashes {
            provenance.insert(format!("truth {name}"), format!("blake3 {hash}"));
        }
    }
    let model = match source_model {
        Some(p) => Some(std::fs::read_to_string(p).map_err(DatasetError::io("reading", p))?),
        None => None,
    };
    crate::folder::write(out_dir, &built, cfg, &wm.grid, &provenance, model.as_deref())
}

// ---------------------------------------------------------------------------------------
// Stage kinds

fn stage_err(e: DatasetError) -> StageError {
    StageError::from(e)
}

fn write_json(path: &Path, value: &impl Serialize) -> Result<(), StageError> {
    let text = serde_json::to_string_pretty(value).map_err(|e| StageError::msg(e.to_string()))?;
    firecast_fs::write_atomically(path, text.as_bytes()).map_err(|e| stage_err(e.into()))
}

const fn port(name: &'static str, required: bool, description: &'static str) -> Port {
    Port {
        name,
        required,
        many: false,
        description,
    }
}

/// `data.ignitions`.
#[derive(Debug, Default)]
pub struct IgnitionsStage;

impl StageKind for IgnitionsStage {
    fn name(&self) -> &'static str {
        "data.ignitions"
    }
    fn version(&self) -> u32 {
        // 2: provenance names files instead of absolute paths. 3: the reject report gains
        // the physical line of each row. 4: the JSON report's paths are relative to the root.
        4
    }
    fn summary(&self) -> &'static str {
        "IRWIN/WFIGS incidents -> de-duplicated ignitions (5 km / 2 h rule, CONUS box, GRIDMET land mask)"
    }
    fn ports(&self) -> Ports {
        const IN: &[Port] = &[
            port("incidents", true, "WFIGS CSV, GeoJSON or Esri JSON"),
            port("gridmet", false, "GRIDMET directory (land mask)"),
        ];
        const OUT: &[Port] = &[
            port("ignitions", true, "ignitions (Parquet)"),
            port("report", true, "counts per rule (JSON)"),
            port("rejects", true, "every dropped row with its reason (CSV)"),
        ];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        typed_params::<IgnitionParams>(raw).map(|(_, v)| v)
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let params: IgnitionParams = ctx.params()?;
        let incidents = ctx.input("incidents")?.to_path_buf();
        let gridmet = ctx.input_list("gridmet").first().cloned();
        let out = ctx.output("ignitions")?.to_path_buf();
        let rejects = ctx.output("rejects")?.to_path_buf();
        let mut report =
            run_ignitions(&incidents, gridmet.as_deref(), &params, &out, &rejects).map_err(stage_err)?;
        // Paths in the report relative to the project root: the same bytes wherever the
        // project (or a remote worker's copy of it) lives.
        fn relative(path: &str, root: &Path) -> String {
            Path::new(path)
                .strip_prefix(root)
                .map_or_else(|_| path.to_string(), |p| p.display().to_string())
        }
        report.incidents_file = relative(&report.incidents_file, ctx.root());
        report.land_mask = report.land_mask.as_deref().map(|p| relative(p, ctx.root()));
        ctx.metric("ignitions_kept", 0, report.rules.kept as f64);
        ctx.metric("incident_rows", 0, report.rows_read as f64);
        ctx.log(format!(
            "{} rows -> {} ignitions ({} rejected by the reader)",
            report.rows_read,
            report.rules.kept,
            report.rejected.values().sum::<u64>()
        ));
        ctx.artifact("rejects.csv", &rejects)?;
        write_json(ctx.output("report")?, &report)
    }
}

/// `data.negatives`.
#[derive(Debug, Default)]
pub struct NegativesStage;

impl StageKind for NegativesStage {
    fn name(&self) -> &'static str {
        "data.negatives"
    }
    fn version(&self) -> u32 {
        1
    }
    fn summary(&self) -> &'static str {
        "ignitions -> ignitions + far/near/yearly negatives (paper or code variant, seeded)"
    }
    fn ports(&self) -> Ports {
        const IN: &[Port] = &[
            port("ignitions", true, "ignitions (Parquet)"),
            port("gridmet", false, "GRIDMET directory (land mask)"),
        ];
        const OUT: &[Port] = &[
            port("samples", true, "samples (Parquet)"),
            port("report", true, "per-tier counts (JSON)"),
        ];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        typed_params::<NegativeConfig>(raw).map(|(_, v)| v)
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let cfg: NegativeConfig = ctx.params()?;
        let ignitions = ctx.input("ignitions")?.to_path_buf();
        let gridmet = ctx.input_list("gridmet").first().cloned();
        let out = ctx.output("samples")?.to_path_buf();
        let report = run_negatives(&ignitions, gridmet.as_deref(), &cfg, &out).map_err(stage_err)?;
        for (tier, r) in [
            ("far", &report.far),
            ("near", &report.near),
            ("yearly", &report.yearly),
        ] {
            ctx.metric(&format!("negatives_{tier}"), 0, r.accepted as f64);
        }
        ctx.log(format!(
            "{} positives, {} far, {} near, {} yearly",
            report.positives, report.far.accepted, report.near.accepted, report.yearly.accepted
        ));
        for s in &report.strata {
            let negatives = s.far + s.near + s.yearly;
            ctx.log(format!(
                "  {} to {}{}: {} positives, {} negatives ({} far, {} near, {} yearly; {} asked){}, prevalence {:.2}",
                s.first_day,
                s.last_day,
                s.block.map_or_else(String::new, |(lat, lon)| format!(", block {lat}° {lon}°")),
                s.positives,
                negatives,
                s.far,
                s.near,
                s.yearly,
                s.requested,
                if s.moved_to_near + s.moved_to_far > 0 {
                    format!(", {} moved to near and {} to far", s.moved_to_near, s.moved_to_far)
                } else {
                    String::new()
                },
                s.positives as f64 / (s.positives + negatives).max(1) as f64
            ));
        }
        write_json(ctx.output("report")?, &report)
    }
}

/// `data.windows`.
#[derive(Debug, Default)]
pub struct WindowsStage;

impl StageKind for WindowsStage {
    fn name(&self) -> &'static str {
        "data.windows"
    }
    fn version(&self) -> u32 {
        // 2: provenance names files instead of absolute paths. 3: the optional `truth` input.
        3
    }
    fn summary(&self) -> &'static str {
        "samples + GRIDMET NetCDF -> weather windows (each file read once, in parallel)"
    }
    fn ports(&self) -> Ports {
        const IN: &[Port] = &[
            port("samples", true, "samples (Parquet)"),
            port("gridmet", true, "GRIDMET directory (<short>_<YYYY>.nc)"),
            port(
                "truth",
                false,
                "synthetic truth directory (ignition_probability_<YYYY>.nc): each sample's true \
                 ignition probability, stored beside the features, never as one",
            ),
        ];
        const OUT: &[Port] = &[port("windows", true, "window table (directory)")];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (cfg, v) = typed_params::<ExtractConfig>(raw)?;
        cfg.resolve_variables().map_err(|e| ParamsError {
            path: "variables".into(),
            message: e.to_string(),
        })?;
        Ok(v)
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let cfg: ExtractConfig = ctx.params()?;
        let samples = ctx.input("samples")?.to_path_buf();
        let gridmet = ctx.input("gridmet")?.to_path_buf();
        let truth = ctx.input_list("truth").first().cloned();
        let out = ctx.output("windows")?.to_path_buf();
        let bar = ctx.progress_bar(0, "GRIDMET files");
        let progress = |done: u64, total: u64| {
            bar.set_length(total);
            bar.set_position(done);
        };
        let m = run_windows_with_truth(&samples, &gridmet, truth.as_deref(), &cfg, &out, &progress)
            .map_err(stage_err)?;
        bar.finish_and_clear();
        windows_metrics(ctx, &m);
        ctx.log(windows_line(&m));
        Ok(())
    }
    fn sharded(&self) -> Option<&dyn firecast_pipeline::ShardedKind> {
        Some(self)
    }
}

/// The stage log's summary of a windows extraction.
/// The metrics a windows run records, sharded (in the merge) or not.
pub(crate) fn windows_metrics(ctx: &StageContext<'_>, m: &WindowsManifest) {
    if let Some(t) = &m.truth {
        ctx.metric("samples_with_true_probability", 0, t.samples_with_value as f64);
    }
    ctx.metric("windows", 0, m.report.samples_out as f64);
    ctx.metric("gridmet_files_read", 0, m.report.files_read as f64);
}

pub(crate) fn windows_line(m: &WindowsManifest) -> String {
    format!(
        "{} of {} samples have windows; {} files read; dropped {:?}",
        m.report.samples_out, m.report.samples_in, m.report.files_read, m.report.dropped
    )
}

/// `data.import_kaggle`.
#[derive(Debug, Default)]
pub struct ImportKaggleStage;

impl StageKind for ImportKaggleStage {
    fn name(&self) -> &'static str {
        "data.import_kaggle"
    }
    fn version(&self) -> u32 {
        // 2: provenance names files instead of absolute paths.
        2
    }
    fn summary(&self) -> &'static str {
        "the published FireCastRL CSV -> a window table (fill values, overlaps, short windows reported)"
    }
    fn ports(&self) -> Ports {
        const IN: &[Port] = &[port("csv", true, "Wildfire_Dataset.csv, or a folder holding it")];
        const OUT: &[Port] = &[
            port("windows", true, "window table (directory)"),
            port("report", true, "what the import found (JSON)"),
        ];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        typed_params::<ImportConfig>(raw).map(|(_, v)| v)
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let cfg: ImportConfig = ctx.params()?;
        let mut csv = ctx.input("csv")?.to_path_buf();
        // A Kaggle upload or download folder: its Wildfire_Dataset.csv.
        if csv.is_dir() {
            csv = csv.join("Wildfire_Dataset.csv");
        }
        let out = ctx.output("windows")?.to_path_buf();
        let bar = ctx.progress_bar(0, "CSV rows");
        let (report, _) =
            run_import_kaggle(&csv, &cfg, &out, &mut |rows| bar.set_position(rows)).map_err(stage_err)?;
        bar.finish_and_clear();
        ctx.metric("kaggle_windows_kept", 0, report.kept_windows as f64);
        write_json(ctx.output("report")?, &report)
    }
}

/// `data.dataset`.
#[derive(Debug, Default)]
pub struct DatasetStage;

impl StageKind for DatasetStage {
    fn name(&self) -> &'static str {
        "data.dataset"
    }
    fn version(&self) -> u32 {
        // 2: provenance names files instead of absolute paths. 3: carries the synthetic
        // truth column of the windows (`true_ignition_probability`).
        3
    }
    fn summary(&self) -> &'static str {
        "windows -> versioned Parquet dataset (paper or forecast framing, leak-free splits, card, map, normalisation)"
    }
    fn ports(&self) -> Ports {
        const IN: &[Port] = &[
            port("windows", true, "window table (directory)"),
            port(
                "source_model",
                false,
                "Markdown describing how the sources were made",
            ),
        ];
        const OUT: &[Port] = &[port("dataset", true, "the dataset (directory)")];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (cfg, v) = typed_params::<DatasetConfig>(raw)?;
        cfg.framing.offsets().map_err(|e| ParamsError {
            path: "framing".into(),
            message: e.to_string(),
        })?;
        Ok(v)
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let cfg: DatasetConfig = ctx.params()?;
        let windows = ctx.input("windows")?.to_path_buf();
        let model = ctx.input_list("source_model").first().cloned();
        let out = ctx.output("dataset")?.to_path_buf();
        let m = run_dataset(&windows, model.as_deref(), &cfg, &out).map_err(stage_err)?;
        let dir = ctx.output_final_path("dataset").unwrap_or(&out).to_path_buf();
        let mut metadata = BTreeMap::new();
        metadata.insert(
            "framing".to_string(),
            serde_json::to_string(&m.framing).unwrap_or_default(),
        );
        metadata.insert("positives".to_string(), m.positives.to_string());
        metadata.insert(
            "splits".to_string(),
            serde_json::to_string(&m.splits).unwrap_or_default(),
        );
        metadata.insert("directory".to_string(), dir.display().to_string());
        // Two views for `firecast query`: the long per-day table under the dataset's name and
        // the per-sample table under `<name>_samples`; they join on sample_id.
        ctx.dataset(&DatasetRecord {
            name: m.name.clone(),
            version: m.version.clone(),
            schema_json: serde_json::to_string(&m.features).unwrap_or_default(),
            rows: m.day_rows,
            location: dir.join(crate::table::DAYS_FILE).display().to_string(),
            metadata: metadata.clone(),
        });
        ctx.dataset(&DatasetRecord {
            name: format!("{}_samples", m.name),
            version: m.version.clone(),
            schema_json: serde_json::to_string(&crate::table::sample_columns_with(
                m.true_probability.is_some(),
            ))
            .unwrap_or_default(),
            rows: m.samples,
            location: dir.join(crate::table::SAMPLES_FILE).display().to_string(),
            metadata,
        });
        ctx.metric("samples", 0, m.samples as f64);
        ctx.metric("positives", 0, m.positives as f64);
        let card = out.join(crate::dataset::CARD_FILE);
        ctx.artifact(&format!("{}-{}-card.md", m.name, m.version), &card)?;
        ctx.log(format!("dataset {} {}: {} samples", m.name, m.version, m.samples));
        Ok(())
    }
}

/// Registers this crate's stage kinds.
pub fn register(kinds: &mut firecast_pipeline::StageKinds) {
    kinds
        .register(SynthesizeStage)
        .register(IgnitionsStage)
        .register(NegativesStage)
        .register(WindowsStage)
        .register(ImportKaggleStage)
        .register(DatasetStage);
}

// ---------------------------------------------------------------------------------------
// Synthetic sources

/// A synthetic region: `conus`, or a box snapped to the GRIDMET grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum RegionParam {
    Named(String),
    Box(crate::geo::GeoBox),
}

impl Default for RegionParam {
    fn default() -> Self {
        RegionParam::Named("conus".into())
    }
}

/// `conus` or `LAT_MIN,LAT_MAX,LON_MIN,LON_MAX`, as command lines write a region.
impl std::str::FromStr for RegionParam {
    type Err = String;

    fn from_str(r: &str) -> Result<Self, String> {
        if r == "conus" {
            return Ok(Self::default());
        }
        let v: Vec<f64> = r
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("`{r}` is not `conus` or LAT_MIN,LAT_MAX,LON_MIN,LON_MAX"))?;
        match v[..] {
            [lat_min, lat_max, lon_min, lon_max] => Ok(Self::Box(crate::geo::GeoBox {
                lat_min,
                lat_max,
                lon_min,
                lon_max,
            })),
            _ => Err(format!("expected 4 numbers, got {}", v.len())),
        }
    }
}

/// Storage layout of the synthetic files by year.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DimOrderParam {
    /// Years before 2019 `(day, lon, lat)` float32, later years `(day, lat, lon)` packed int16.
    #[default]
    ByVintage,
    LatLon,
    LonLat,
}

/// Params of the synthetic-source step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SynthParams {
    #[serde(default = "default_synth_seed")]
    pub seed: u64,
    #[serde(default)]
    pub region: RegionParam,
    /// First and last year, inclusive.
    pub years: (i32, i32),
    /// GRIDMET short names to write (default: all 16).
    #[serde(default)]
    pub variables: Vec<String>,
    #[serde(default)]
    pub dim_order: DimOrderParam,
    /// Multiplier of every ignition rate (1.0 is about 30–40 thousand wildfires a year over CONUS).
    #[serde(default = "default_rate_scale")]
    pub ignition_rate_scale: f64,
    #[serde(default = "default_warmup")]
    pub warmup_days: u32,
    /// Fraction of wildfires reported twice.
    #[serde(default = "default_duplicates")]
    pub duplicate_fraction: f64,
}

fn default_synth_seed() -> u64 {
    42
}
fn default_rate_scale() -> f64 {
    1.0
}
fn default_warmup() -> u32 {
    365
}
fn default_duplicates() -> f64 {
    0.06
}

impl SynthParams {
    /// The generator's configuration, checked.
    pub fn to_config(&self) -> Result<firecast_synth::SynthConfig, DatasetError> {
        use firecast_synth::{DimOrderChoice, Region, SynthConfig};
        let region = match &self.region {
            RegionParam::Named(n) if n == "conus" => Region::Conus,
            RegionParam::Named(other) => {
                return Err(DatasetError::Config {
                    key: "region".into(),
                    message: format!(
                        "`{other}`: expected `conus` or a box {{lat_min, lat_max, lon_min, lon_max}}"
                    ),
                });
            }
            RegionParam::Box(b) => Region::Box {
                lat_min: b.lat_min,
                lat_max: b.lat_max,
                lon_min: b.lon_min,
                lon_max: b.lon_max,
            },
        };
        let mut cfg = SynthConfig::new(self.seed, region, self.years);
        if !self.variables.is_empty() {
            cfg.variables = ExtractConfig {
                variables: self.variables.clone(),
                ..Default::default()
            }
            .resolve_variables()?;
        }
        cfg.dim_order = match self.dim_order {
            DimOrderParam::ByVintage => DimOrderChoice::ByVintage,
            DimOrderParam::LatLon => DimOrderChoice::LatLon,
            DimOrderParam::LonLat => DimOrderChoice::LonLat,
        };
        cfg.ignition_rate_scale = self.ignition_rate_scale;
        cfg.warmup_days = self.warmup_days;
        cfg.duplicate_fraction = self.duplicate_fraction;
        Ok(cfg)
    }
}

/// What the synthetic step wrote.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SynthReport {
    pub gridmet_files: usize,
    pub incidents_csv: Option<String>,
    pub grid: (usize, usize),
    pub land_cells: usize,
    pub ignitions: u64,
    pub reported_records: u64,
    pub model_version: String,
    /// Truth files written (`truth/ignition_probability_<YYYY>.nc`).
    #[serde(default)]
    pub truth_files: usize,
}

/// The file inside a synthetic source directory that documents the generative model.
pub const SOURCE_MODEL_FILE: &str = "MODEL.md";

/// Writes synthetic WFIGS + GRIDMET sources into `out_dir` (`gridmet/`, `incidents/`,
/// `truth/`, `MODEL.md`).
pub fn run_synthesize(
    params: &SynthParams,
    out_dir: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<SynthReport, DatasetError> {
    run_synthesize_with(params, out_dir, true, progress)
}

/// [`run_synthesize`], writing the `truth/` files only when `write_truth`.
pub fn run_synthesize_with(
    params: &SynthParams,
    out_dir: &Path,
    write_truth: bool,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<SynthReport, DatasetError> {
    let mut cfg = params.to_config()?;
    cfg.write_truth = write_truth;
    let summary = firecast_synth::generate(&cfg, out_dir, progress).map_err(|e| DatasetError::Input {
        path: out_dir.to_path_buf(),
        message: e.to_string(),
    })?;
    firecast_fs::write_atomically(
        &out_dir.join(SOURCE_MODEL_FILE),
        firecast_synth::model_card().as_bytes(),
    )?;
    Ok(SynthReport {
        gridmet_files: summary.gridmet_files.len(),
        incidents_csv: summary
            .incidents_csv
            .map(|p| p.strip_prefix(out_dir).unwrap_or(&p).display().to_string()),
        grid: (summary.n_lat, summary.n_lon),
        land_cells: summary.land_cells,
        ignitions: summary.ignitions,
        reported_records: summary.reported_records,
        model_version: summary.model_version.to_string(),
        truth_files: summary.truth_files.len(),
    })
}

/// `data.synthesize`.
#[derive(Debug, Default)]
pub struct SynthesizeStage;

impl StageKind for SynthesizeStage {
    fn name(&self) -> &'static str {
        "data.synthesize"
    }
    fn version(&self) -> u32 {
        // 2: the optional `truth` output.
        2
    }
    fn summary(&self) -> &'static str {
        "seeded synthetic sources in the real formats: WFIGS CSV + GRIDMET NetCDF (a test bed)"
    }
    fn ports(&self) -> Ports {
        const OUT: &[Port] = &[
            port("gridmet", true, "GRIDMET files <short>_<YYYY>.nc (directory)"),
            port("incidents", true, "WFIGS-style incidents (CSV)"),
            port("model", true, "the generative model (Markdown)"),
            port(
                "truth",
                false,
                "true ignition probability per cell-day, ignition_probability_<YYYY>.nc \
                 (directory; the oracle, not a weather variable)",
            ),
        ];
        Ports {
            inputs: &[],
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (p, v) = typed_params::<SynthParams>(raw)?;
        p.to_config().map_err(|e| ParamsError {
            path: String::new(),
            message: e.to_string(),
        })?;
        Ok(v)
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let params: SynthParams = ctx.params()?;
        let gridmet = ctx.output("gridmet")?.to_path_buf();
        let incidents = ctx.output("incidents")?.to_path_buf();
        let model = ctx.output("model")?.to_path_buf();
        // Optional: only a declared output is worth the generator's time and disk.
        let truth = ctx.output("truth").ok().map(Path::to_path_buf);
        // Generate into a scratch directory beside the outputs, then move each part to its
        // declared (temporary) output path; the runner renames those into place.
        // (Removed when dropped, whatever happens.)
        let staged =
            firecast_fs::TempPath::new(&gridmet.with_extension("synth")).map_err(|e| stage_err(e.into()))?;
        let scratch = staged.path();
        let bar = ctx.progress_bar(0, "simulated days");
        let report = run_synthesize_with(&params, scratch, truth.is_some(), &mut |done, total| {
            bar.set_length(total);
            bar.set_position(done);
        })
        .map_err(stage_err)?;
        bar.finish_and_clear();
        let mut moves = vec![
            (scratch.join("gridmet"), &gridmet),
            (
                scratch.join("incidents").join(firecast_synth::INCIDENTS_CSV),
                &incidents,
            ),
            (scratch.join(SOURCE_MODEL_FILE), &model),
        ];
        if let Some(truth) = &truth {
            moves.push((scratch.join(firecast_synth::TRUTH_DIR), truth));
        }
        for (from, to) in moves {
            firecast_fs::publish(&from, to).map_err(|e| StageError::msg(e.to_string()))?;
        }
        drop(staged);
        ctx.metric("synthetic_ignitions", 0, report.ignitions as f64);
        ctx.log(format!(
            "{} GRIDMET files on a {}x{} grid, {} ignitions in {} records",
            report.gridmet_files, report.grid.0, report.grid.1, report.ignitions, report.reported_records
        ));
        Ok(())
    }
}
