//! `firecast report`: a threat-assessment report from ensembles, a forecast and the GRIDMET
//! folder, run as a one-stage pipeline of the `report` kind (cached and registered).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;

use crate::output;
use crate::settings::Settings;

#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Ensemble files from `sim.ensemble` / `rl.ensemble` (one must be the `none` strategy).
    #[arg(long = "ensemble", value_name = "FILE", required = true)]
    pub ensembles: Vec<PathBuf>,
    /// The free fire of `sim.ensemble` with `engine: mtt` (the verified engine): it then draws
    /// the isochrones, burn probability, GeoTIFFs and assets' arrival.
    #[arg(long, value_name = "FILE")]
    pub spread: Option<PathBuf>,
    /// The `forecast.predict` output for the same place and date.
    #[arg(long, value_name = "FILE")]
    pub forecast: PathBuf,
    /// GRIDMET folder holding the day.
    #[arg(long, value_name = "DIR")]
    pub gridmet: PathBuf,
    #[arg(long, allow_hyphen_values = true)]
    pub lat: f64,
    #[arg(long, allow_hyphen_values = true)]
    pub lon: f64,
    /// YYYY-MM-DD.
    #[arg(long)]
    pub date: String,
    /// An asset to watch, `NAME,LAT,LON` (repeatable).
    #[arg(long = "asset", value_name = "NAME,LAT,LON", allow_hyphen_values = true)]
    pub assets: Vec<String>,
    /// Output folder: report.html, report.pdf, report.json, report.geojson, arrival_h.tif,
    /// burn_probability_pct.tif.
    #[arg(long, value_name = "DIR", default_value = "build/report")]
    pub out: PathBuf,
    /// Skip the PDF (no Chromium needed).
    #[arg(long)]
    pub no_pdf: bool,
    /// Run even when nothing changed.
    #[arg(short, long)]
    pub force: bool,
}

fn parse_asset(s: &str) -> anyhow::Result<firecast_report::AssetSpec> {
    let parts: Vec<&str> = s.rsplitn(3, ',').collect();
    let [lon, lat, name] = parts.as_slice() else {
        anyhow::bail!("--asset `{s}`: expected NAME,LAT,LON");
    };
    Ok(firecast_report::AssetSpec {
        name: name.trim().to_string(),
        lat: lat
            .trim()
            .parse()
            .with_context(|| format!("--asset `{s}`: latitude"))?,
        lon: lon
            .trim()
            .parse()
            .with_context(|| format!("--asset `{s}`: longitude"))?,
    })
}

pub fn run(settings: &Settings, args: &ReportArgs) -> anyhow::Result<ExitCode> {
    let assets = args
        .assets
        .iter()
        .map(|a| parse_asset(a))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let rel = |p: &PathBuf| {
        crate::cmd_pipeline::relative_to_root(settings, p)
            .display()
            .to_string()
    };
    let out = crate::cmd_pipeline::relative_to_root(settings, &args.out);
    let mut params = serde_json::json!({"lat": args.lat, "lon": args.lon, "date": args.date});
    if !assets.is_empty() {
        params["assets"] = serde_json::to_value(&assets)?;
    }
    let mut outputs = serde_json::json!({
        "html": out.join("report.html").display().to_string(),
        "json": out.join("report.json").display().to_string(),
        "geojson": out.join("report.geojson").display().to_string(),
        "arrival_tif": out.join("arrival_h.tif").display().to_string(),
        "burn_probability_tif": out.join("burn_probability_pct.tif").display().to_string(),
    });
    if !args.no_pdf {
        outputs["pdf"] = serde_json::Value::String(out.join("report.pdf").display().to_string());
    }
    let mut stage = serde_json::json!({
        "uses": "report",
        "description": format!("Threat report for ({}, {}) on {}", args.lat, args.lon, args.date),
        "params": params,
        "inputs": {
            "ensembles": args.ensembles.iter().map(rel).collect::<Vec<_>>(),
            "forecast": rel(&args.forecast),
            "gridmet": rel(&args.gridmet),
        },
        "outputs": outputs,
    });
    if let Some(spread) = &args.spread {
        stage["inputs"]["spread"] = serde_json::Value::String(rel(spread));
    }
    let file = settings.root.join("firecast-report.yaml");
    let (outcome, secs, run_id) = crate::cmd_pipeline::run_one_stage(
        settings,
        &file,
        "report",
        "report",
        stage,
        crate::cmd_pipeline::OneStage {
            force: args.force,
            ..Default::default()
        },
    )?;
    let json_path = settings.root.join(&out).join("report.json");
    let report: firecast_report::model::ThreatReport = serde_json::from_slice(
        &std::fs::read(&json_path).with_context(|| format!("reading {}", json_path.display()))?,
    )?;
    if settings.json {
        output::print_json(&report)?;
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "report {outcome} in {secs:.1} s (run {run_id}): risk {}, ignition probability {:.2}",
        report.risk.level, report.forecast.probability
    );
    if let Some(f) = &report.free_spread {
        println!(
            "  {:<28} {:>9.0} acres [{:.0}, {:.0}]",
            "Free fire (verified engine)",
            f.fire.burned_acres.value,
            f.fire.burned_acres.low,
            f.fire.burned_acres.high
        );
    }
    for s in &report.strategies {
        println!(
            "  {:<28} {:>9.0} acres [{:.0}, {:.0}]",
            s.label, s.burned_acres.value, s.burned_acres.low, s.burned_acres.high
        );
    }
    println!("  written to {}", out.display());
    Ok(ExitCode::SUCCESS)
}
