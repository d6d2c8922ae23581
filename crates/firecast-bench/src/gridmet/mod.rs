//! `firecast bench gridmet`: GRIDMET window extraction, FireCast beside the authors' xarray
//! method ([`reference`], Python, run in the same command on the same files and windows),
//! with the ratio and a projection to the paper's scale.

pub mod reference;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use firecast_dataset::stage::SynthParams;
use serde_json::{Value, json};

use crate::Context;
use crate::python::{Venv, find_python};

/// `firecast bench gridmet`'s flags.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Where the benchmark's GRIDMET files live; missing ones are generated (synthetic,
    /// full CONUS grid unless --region says otherwise).
    #[arg(long, value_name = "DIR", default_value = ".firecast/bench/gridmet")]
    pub dir: PathBuf,
    /// Windows to extract.
    #[arg(long, default_value_t = 2000)]
    pub samples: usize,
    /// Years of files, e.g. 2020-2020.
    #[arg(long, default_value = "2020-2020", value_name = "YYYY-YYYY")]
    pub years: String,
    /// GRIDMET variables.
    #[arg(long, default_value = "pr,tmmx,rmin,vs", value_name = "LIST")]
    pub variables: String,
    /// `conus` (585 x 1386 cells) or LAT_MIN,LAT_MAX,LON_MIN,LON_MAX.
    #[arg(long, default_value = "conus")]
    pub region: String,
    /// Python with xarray and netCDF4 [default: $FIRECAST_VENV, ./.venv].
    #[arg(long, value_name = "PATH")]
    pub python: Option<PathBuf>,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// `firecast bench gridmet`'s report.
#[derive(Debug, serde::Serialize)]
pub struct BenchGridmetReport {
    grid: (usize, usize),
    files: u64,
    windows: usize,
    variables: usize,
    days_per_window: usize,
    firecast_seconds: f64,
    firecast_quarter_seconds: f64,
    reference_seconds: f64,
    reference_wall_seconds: f64,
    speedup: f64,
    agreement: reference::Agreement,
    paper_scale_firecast_seconds: f64,
    paper_scale_reference_seconds: f64,
    paper_scale_speedup: f64,
    threads: usize,
    xarray: String,
}

/// `firecast bench gridmet`: FireCast's window extraction beside the reference's on the same
/// files and windows, with the ratio and a projection to the paper's scale.
pub fn run(ctx: &Context, a: &Args) -> anyhow::Result<BenchGridmetReport> {
    use reference as bench;

    let (y0, y1) = a
        .years
        .split_once('-')
        .and_then(|(x, y)| Some((x.trim().parse::<i32>().ok()?, y.trim().parse::<i32>().ok()?)))
        .with_context(|| format!("--years: `{}` is not YYYY-YYYY", a.years))?;
    let variables: Vec<String> = a.variables.split(',').map(|s| s.trim().to_string()).collect();
    let extract_cfg = firecast_dataset::windows::ExtractConfig {
        variables: variables.clone(),
        ..Default::default()
    };
    let vars = extract_cfg.resolve_variables()?;
    let dir = ctx.root.join(&a.dir);
    let gridmet = dir.join("gridmet");
    let missing: Vec<_> = (y0..=y1)
        .flat_map(|y| vars.iter().map(move |v| (*v, y)))
        .filter(|(v, y)| !gridmet.join(v.file_name(*y)).is_file())
        .collect();
    if !missing.is_empty() {
        let region = region_param(&a.region)?;
        let p: SynthParams = firecast_pipeline::stage::deserialize_params(&json!({
            "seed": a.seed,
            "years": [y0, y1],
            "region": region,
            "variables": variables,
            "dim_order": "lat_lon",
            "warmup_days": 30,
        }))
        .map_err(|e| {
            let key = if e.path.is_empty() {
                String::new()
            } else {
                format!("{}: ", e.path)
            };
            anyhow::anyhow!("flags: {key}{}", e.message)
        })?;
        eprintln!(
            "generating {} synthetic GRIDMET file(s) in {} (kept for later runs)",
            missing.len(),
            gridmet.display()
        );
        // Removed when dropped, whatever happens.
        let staged = firecast_fs::TempPath::new(&dir.join("generate"))?;
        let scratch = staged.path();
        std::fs::create_dir_all(&gridmet).with_context(|| format!("cannot create {}", gridmet.display()))?;
        let mut cfg = p.to_config()?;
        cfg.write_incidents = false;
        let bar = progress_bar(ctx, "simulated days");
        firecast_synth::generate(&cfg, scratch, &mut |d, t| {
            bar.set_length(t);
            bar.set_position(d);
        })?;
        bar.finish_and_clear();
        for (v, y) in &missing {
            let name = v.file_name(*y);
            firecast_fs::publish(&scratch.join("gridmet").join(&name), &gridmet.join(&name))?;
        }
        drop(staged);
    }

    let mask = firecast_dataset::land::LandMask::from_gridmet_dir(&gridmet)?;
    let offsets = (extract_cfg.first_offset, extract_cfg.last_offset);
    let samples = bench::random_samples(&mask, (y0, y1), offsets, a.samples, a.seed)?;
    let quarter = &samples[..samples.len() / 4];
    let no_progress = |_: u64, _: u64| {};

    eprintln!(
        "FireCast: {} windows x {} variables ...",
        samples.len(),
        vars.len()
    );
    let start = Instant::now();
    let (table, report) =
        firecast_dataset::windows::extract(&samples, &gridmet, &extract_cfg, false, &no_progress)?;
    let firecast_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    firecast_dataset::windows::extract(quarter, &gridmet, &extract_cfg, false, &no_progress)?;
    let firecast_quarter_seconds = start.elapsed().as_secs_f64();

    let python = find_python(a.python.as_deref(), &ctx.root, Venv::Project)?;
    eprintln!(
        "reference (xarray + netCDF4, {}) on the same windows ...",
        python.display()
    );
    let work = tempfile_dir(&dir)?;
    let reference = bench::run_reference(&python, &gridmet, &table, &work);
    let _ = std::fs::remove_dir_all(&work);
    let reference = reference?;
    let agreement = bench::compare(&table.values, &reference.values);

    // Paper scale: 126,800 windows x 15 variables over 12 years of CONUS files.
    // FireCast costs per file plus per window: fit both from the full and the quarter run.
    let files = report.files_read as f64;
    let n = samples.len() as f64;
    let per_window = ((firecast_seconds - firecast_quarter_seconds) / (n - n / 4.0)).max(0.0);
    let per_file = ((firecast_seconds - per_window * n) / files).max(0.0);
    let paper_files = bench::PAPER_VARIABLES * bench::PAPER_YEARS;
    let paper_firecast = per_file * paper_files
        + per_window * bench::PAPER_WINDOWS * (bench::PAPER_VARIABLES / vars.len() as f64);
    // The reference costs per window and variable.
    let per_selection = reference.seconds / (n * vars.len() as f64);
    let paper_reference = per_selection * bench::PAPER_WINDOWS * bench::PAPER_VARIABLES;
    let out = BenchGridmetReport {
        grid: (mask.lats().len(), mask.lons().len()),
        files: report.files_read,
        windows: samples.len(),
        variables: vars.len(),
        days_per_window: table.n_days,
        firecast_seconds,
        firecast_quarter_seconds,
        reference_seconds: reference.seconds,
        reference_wall_seconds: reference.wall_seconds,
        speedup: reference.seconds / firecast_seconds,
        agreement,
        paper_scale_firecast_seconds: paper_firecast,
        paper_scale_reference_seconds: paper_reference,
        paper_scale_speedup: paper_reference / paper_firecast,
        threads: rayon_threads(),
        xarray: reference.xarray.clone(),
    };
    Ok(out)
}

impl crate::Report for BenchGridmetReport {
    fn render(&self) -> String {
        let mut out = String::new();
        let _ = self.write(&mut out);
        out
    }
}

impl BenchGridmetReport {
    fn write(&self, out: &mut String) -> std::fmt::Result {
        writeln!(
            out,
            "GRIDMET window extraction: {} windows x {} variables x {} days, {} files of {} x {} cells",
            self.windows, self.variables, self.days_per_window, self.files, self.grid.0, self.grid.1
        )?;
        let mut t = crate::table(&["extractor", "seconds", "windows/s", "ratio"]);
        t.add_row(vec![
            "reference: xarray + netCDF4, nearest cell per window (authors' method)".into(),
            format!("{:.2}", self.reference_seconds),
            format!("{:.0}", self.windows as f64 / self.reference_seconds),
            "1.0x".into(),
        ]);
        t.add_row(vec![
            format!(
                "FireCast: each file opened once, all its windows gathered, {} threads",
                self.threads
            ),
            format!("{:.2}", self.firecast_seconds),
            format!("{:.0}", self.windows as f64 / self.firecast_seconds),
            format!("{:.1}x", self.speedup),
        ]);
        writeln!(out, "{t}")?;
        writeln!(
            out,
            "agreement: {} values, max |difference| {:.2e}, missing-value mismatches {}",
            self.agreement.values, self.agreement.max_abs_diff, self.agreement.missing_mismatches
        )?;
        writeln!(
            out,
            "projection to the paper's scale (126,800 windows x 15 variables, 12 years of CONUS files): \
             reference {:.0} s ({:.1} h), FireCast {:.0} s, {:.0}x",
            self.paper_scale_reference_seconds,
            self.paper_scale_reference_seconds / 3600.0,
            self.paper_scale_firecast_seconds,
            self.paper_scale_speedup
        )?;
        writeln!(
            out,
            "(reference time is measured inside Python, without interpreter start: {:.2} s wall)",
            self.reference_wall_seconds
        )?;
        Ok(())
    }
}

/// `--region`: `conus`, or `LAT_MIN,LAT_MAX,LON_MIN,LON_MAX`, as the synthesize params (also
/// `firecast dataset synthesize --region`).
fn region_param(r: &str) -> anyhow::Result<Value> {
    let region: firecast_dataset::stage::RegionParam =
        r.parse().map_err(|e| anyhow::anyhow!("--region: {e}"))?;
    Ok(serde_json::to_value(region)?)
}

fn progress_bar(ctx: &Context, message: &'static str) -> indicatif::ProgressBar {
    if !ctx.progress || ctx.json {
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

fn rayon_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

fn tempfile_dir(parent: &Path) -> anyhow::Result<PathBuf> {
    let dir = parent.join(format!(".reference-{}", std::process::id()));
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    Ok(dir)
}
