//! The `report` stage kind: ensembles + forecast + GRIDMET folder → HTML, PDF, JSON, GeoJSON,
//! GeoTIFFs.

use std::path::{Path, PathBuf};

use firecast_episodes::ensemble::Ensemble;
use firecast_pipeline::{ParamsError, Port, Ports, StageContext, StageError, StageKind, typed_params};

use crate::compute::{ForecastFile, Inputs, ReportSettings};
use crate::model::Lineage;
use crate::{ReportError, compute, geojson, html, pdf, rasters, weather};

/// `report` params: the request (place, date, assets, bands) as [`ReportSettings`].
pub type ReportParams = ReportSettings;

#[derive(Debug, Default)]
pub struct ReportStage;

const INPUTS: &[Port] = &[
    Port {
        name: "ensembles",
        required: true,
        many: true,
        description: "ensemble files of sim.ensemble / rl.ensemble, one of them `none`",
    },
    Port {
        name: "ignition_map",
        required: false,
        many: false,
        description: "forecast.predict's `map`: the day's ignition probability at every GRIDMET cell around the place",
    },
    Port {
        name: "spread",
        required: false,
        many: false,
        description: "the free fire of sim.ensemble with `engine: mtt` (the verified engine): isochrones, burn probability, GeoTIFFs and arrival at assets come from it",
    },
    Port {
        name: "forecast",
        required: true,
        many: false,
        description: "the forecast.predict output (JSON)",
    },
    Port {
        name: "gridmet",
        required: true,
        many: false,
        description: "GRIDMET folder holding the day (tmmx, rmin, erc, fm100, …)",
    },
];
const OUTPUTS: &[Port] = &[
    Port {
        name: "html",
        required: true,
        many: false,
        description: "the report, one self-contained HTML file",
    },
    Port {
        name: "pdf",
        required: false,
        many: false,
        description: "the same page printed to PDF by headless Chromium",
    },
    Port {
        name: "json",
        required: true,
        many: false,
        description: "every number of the report (schemas/threat-report-1.schema.json)",
    },
    Port {
        name: "geojson",
        required: false,
        many: false,
        description: "isochrones, burn-probability zones, drops, assets, priority zones (WGS84)",
    },
    Port {
        name: "arrival_tif",
        required: false,
        many: false,
        description: "GeoTIFF of the free fire's median arrival (the verified engine's when `spread` is given), hours after ignition (nodata -9999)",
    },
    Port {
        name: "burn_probability_tif",
        required: false,
        many: false,
        description: "GeoTIFF of the free fire's burn probability (the verified engine's when `spread` is given), percent 0-100",
    },
];

fn check(params: &ReportSettings) -> Result<(), ParamsError> {
    let bad = |path: &str, message: String| ParamsError {
        path: path.into(),
        message,
    };
    if !(-90.0..=90.0).contains(&params.lat) {
        return Err(bad("lat", format!("{} is not a latitude", params.lat)));
    }
    if !(-180.0..=180.0).contains(&params.lon) {
        return Err(bad("lon", format!("{} is not a longitude", params.lon)));
    }
    let parts: Vec<&str> = params.date.split('-').collect();
    if parts.len() != 3 || parts.iter().any(|p| p.parse::<u32>().is_err()) {
        return Err(bad("date", format!("`{}` is not YYYY-MM-DD", params.date)));
    }
    let b = &params.evacuation;
    if !(b.go_within_h > 0.0 && b.go_within_h < b.set_within_h && b.set_within_h < b.ready_within_h) {
        return Err(bad(
            "evacuation",
            "need 0 < go_within_h < set_within_h < ready_within_h".into(),
        ));
    }
    if params.isochrones_h.is_empty() || params.isochrones_h.iter().any(|t| t.is_nan() || *t <= 0.0) {
        return Err(bad("isochrones_h", "need one or more positive hours".into()));
    }
    for (i, a) in params.assets.iter().enumerate() {
        if !(-90.0..=90.0).contains(&a.lat) || !(-180.0..=180.0).contains(&a.lon) {
            return Err(bad(
                &format!("assets[{i}]"),
                format!("({}, {}) is not a place", a.lat, a.lon),
            ));
        }
    }
    Ok(())
}

fn rel(root: &Path, p: &Path) -> String {
    p.strip_prefix(root).unwrap_or(p).display().to_string()
}

/// The files a report is made from.
#[derive(Debug, Clone, Copy)]
pub struct ReportFiles<'a> {
    /// Ensemble files (`sim.ensemble`, `rl.ensemble`), one of them `none`.
    pub ensembles: &'a [PathBuf],
    /// The verified engine's free fire (`sim.ensemble` with `engine: mtt`), if any.
    pub spread: Option<&'a Path>,
    /// The `forecast.predict` output.
    pub forecast: &'a Path,
    /// The GRIDMET folder holding the day.
    pub gridmet: &'a Path,
    /// `forecast.predict`'s `map`: the day's probability around the place, if any.
    pub ignition_map: Option<&'a Path>,
}

/// What the report reads of `forecast.predict`'s `map` file.
#[derive(Debug, serde::Deserialize)]
struct IgnitionMapFile {
    date: String,
    threshold: f64,
    lats: Vec<f64>,
    lons: Vec<f64>,
    probability: Vec<Vec<Option<f64>>>,
    #[serde(default)]
    daily_probability: Option<Vec<Vec<Option<f64>>>>,
    #[serde(default)]
    usual_daily: Option<f64>,
}

/// The ignition pattern of a `map` file, checked against the report's day.
fn ignition_pattern(
    root: &Path,
    path: &Path,
    date: &str,
) -> Result<crate::model::IgnitionPattern, ReportError> {
    let bytes = std::fs::read(path).map_err(ReportError::io("reading the ignition map", path))?;
    let m: IgnitionMapFile = serde_json::from_slice(&bytes)
        .map_err(|e| ReportError::input(rel(root, path), format!("line {}: {e}", e.line())))?;
    if m.date != date {
        return Err(ReportError::input(
            rel(root, path),
            format!("the ignition map is for {}, the report for {date}", m.date),
        ));
    }
    // Each grid of the file is `lats` rows of `lons` cells.
    let check = |name: &str, grid: &[Vec<Option<f64>>]| {
        if grid.len() != m.lats.len() || grid.iter().any(|row| row.len() != m.lons.len()) {
            return Err(ReportError::input(
                rel(root, path),
                format!("`{name}` is not {} rows of {} cells", m.lats.len(), m.lons.len()),
            ));
        }
        Ok(())
    };
    check("probability", &m.probability)?;
    let values: Vec<f64> = m.probability.iter().flatten().flatten().copied().collect();
    let relative = match (&m.daily_probability, m.usual_daily) {
        (Some(daily), Some(usual)) if usual > 0.0 => {
            check("daily_probability", daily)?;
            Some(
                daily
                    .iter()
                    .map(|row| row.iter().map(|p| p.map(|p| p / usual)).collect())
                    .collect(),
            )
        }
        _ => None,
    };
    Ok(crate::model::IgnitionPattern {
        relative_to_usual: relative,
        usual_daily_pct: m.usual_daily.map(|u| u * 100.0),
        cells: values.len(),
        threshold_pct: m.threshold * 100.0,
        cells_above_threshold: values.iter().filter(|&&p| p >= m.threshold).count(),
        max_pct: values.iter().copied().reduce(f64::max).map(|p| p * 100.0),
        probability_pct: m
            .probability
            .iter()
            .map(|row| row.iter().map(|p| p.map(|p| p * 100.0)).collect())
            .collect(),
        lats: m.lats,
        lons: m.lons,
    })
}

/// Builds every output of a report; `out` maps an output name to where to write it.
pub fn build(
    root: &Path,
    settings: &ReportSettings,
    files: ReportFiles<'_>,
    run_id: &str,
    out: &dyn Fn(&str) -> Option<PathBuf>,
    log: &dyn Fn(String),
) -> Result<crate::model::ThreatReport, ReportError> {
    let ReportFiles {
        ensembles,
        spread,
        forecast,
        gridmet,
        ignition_map,
    } = files;
    let mut lineage = Vec::new();
    let mut loaded = Vec::new();
    for p in ensembles {
        let e = Ensemble::read(p)?;
        lineage.push(Lineage {
            role: format!("ensemble ({})", e.strategy),
            path: rel(root, p),
            detail: format!("{} runs — {}", e.runs(), e.description),
        });
        loaded.push(e);
    }
    let spread = match spread {
        Some(p) => {
            let e = Ensemble::read(p)?;
            lineage.push(Lineage {
                role: "free fire (none, minimum travel time)".into(),
                path: rel(root, p),
                detail: format!("{} runs — {}", e.runs(), e.description),
            });
            Some(e)
        }
        None => None,
    };
    let text = std::fs::read(forecast).map_err(ReportError::io("reading the forecast", forecast))?;
    let fc: ForecastFile = serde_json::from_slice(&text)
        .map_err(|e| ReportError::input(rel(root, forecast), format!("line {}: {e}", e.line())))?;
    if (fc.lat - settings.lat).abs() > 1e-6
        || (fc.lon - settings.lon).abs() > 1e-6
        || fc.date != settings.date
    {
        return Err(ReportError::input(
            rel(root, forecast),
            format!(
                "the forecast is for ({}, {}) on {}, the report for ({}, {}) on {}",
                fc.lat, fc.lon, fc.date, settings.lat, settings.lon, settings.date
            ),
        ));
    }
    lineage.push(Lineage {
        role: "forecast".into(),
        path: rel(root, forecast),
        detail: format!(
            "{} ({}) on {} {}",
            fc.model, fc.kind, fc.dataset, fc.dataset_version
        ),
    });
    let day = weather::read_day(gridmet, settings.lat, settings.lon, &settings.date)?;
    lineage.push(Lineage {
        role: "weather".into(),
        path: rel(root, gridmet),
        detail: format!(
            "GRIDMET {} at ({:.4}, {:.4})",
            settings.date, day.cell_lat, day.cell_lon
        ),
    });
    let pattern = match ignition_map {
        Some(p) => {
            lineage.push(Lineage {
                role: "ignition map".into(),
                path: rel(root, p),
                detail: format!("the day's probability around the place, {}", settings.date),
            });
            Some(ignition_pattern(root, p, &settings.date)?)
        }
        None => None,
    };
    let mut computed = compute::compute(
        settings,
        Inputs {
            ensembles: loaded,
            spread,
            forecast: fc,
            weather: day,
            run_id: run_id.to_string(),
            issued_at: crate::issue_time(),
            lineage,
        },
    )?;
    computed.report.forecast.pattern = pattern;
    let doc = html::render(&computed)?;
    let write = |name: &str, bytes: &[u8]| -> Result<(), ReportError> {
        if let Some(p) = out(name) {
            std::fs::write(&p, bytes).map_err(ReportError::io("writing", &p))?;
        }
        Ok(())
    };
    write("html", doc.as_bytes())?;
    write("json", &serde_json::to_vec_pretty(&computed.report)?)?;
    write("geojson", &serde_json::to_vec(&geojson::build(&computed)?)?)?;
    // The GeoTIFFs answer where the free fire goes: the verified engine's when given.
    let baseline = computed.free_fire();
    if out("arrival_tif").is_some() {
        write("arrival_tif", &rasters::arrival_h(&computed.landscape, baseline)?)?;
    }
    if out("burn_probability_tif").is_some() {
        write(
            "burn_probability_tif",
            &rasters::burn_probability_pct(&computed.landscape, baseline)?,
        )?;
    }
    if let Some(target) = out("pdf") {
        // Chromium needs a `.html` name to render the page as HTML.
        let dir = std::env::temp_dir().join(format!("firecast-report-{}-{run_id}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(ReportError::io("creating", &dir))?;
        let page = dir.join("report.html");
        let printed = dir.join("report.pdf");
        let result = std::fs::write(&page, doc.as_bytes())
            .map_err(ReportError::io("writing", &page))
            .and_then(|()| pdf::print(&page, &printed))
            .and_then(|()| {
                std::fs::copy(&printed, &target)
                    .map(|_| ())
                    .map_err(ReportError::io("writing", &target))
            });
        let _ = std::fs::remove_dir_all(&dir);
        result?;
    }
    log(format!(
        "risk {}: unsuppressed {:.0} acres{}; {} assets in GO, {} in SET",
        computed.report.risk.level,
        computed.report.strategies[computed.baseline].burned_acres.value,
        computed
            .report
            .free_spread
            .as_ref()
            .map_or(String::new(), |f| format!(
                " on the automaton, {:.0} by the verified engine",
                f.fire.burned_acres.value
            )),
        computed.report.risk.assets_go,
        computed.report.risk.assets_set
    ));
    Ok(computed.report)
}

impl StageKind for ReportStage {
    fn name(&self) -> &'static str {
        "report"
    }

    fn version(&self) -> u32 {
        // 2: valid GeoJSON rings, properties with units, the GeoTIFFs.
        // 3: the verified engine's free fire (`spread`) draws where the fire goes and when;
        //    GeoJSON isochrones and zones carry their `engine`.
        // 4: the free fire's edge (`free_spread.edge_runs_pct`, `edge_first_h_median`).
        // 5: the answer on the first screen, outcome ranges (schema 1.2.0), maps with legends,
        //    per-strategy maps, a window around the fire on a grown map, print and phone.
        5
    }

    fn summary(&self) -> &'static str {
        "threat-assessment report: forecast, fire behaviour, strategies, evacuation (HTML, PDF, JSON, GeoJSON, GeoTIFF)"
    }

    fn ports(&self) -> Ports {
        Ports {
            inputs: INPUTS,
            outputs: OUTPUTS,
            open: false,
        }
    }

    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (params, resolved): (ReportSettings, serde_json::Value) = typed_params(raw)?;
        check(&params)?;
        Ok(resolved)
    }

    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let params: ReportSettings = ctx.params()?;
        let ensembles = ctx.input_list("ensembles").to_vec();
        let spread = match ctx.input_list("spread") {
            [] => None,
            _ => Some(ctx.input("spread")?.to_path_buf()),
        };
        let forecast = ctx.input("forecast")?.to_path_buf();
        let gridmet = ctx.input("gridmet")?.to_path_buf();
        let ignition_map = match ctx.input_list("ignition_map") {
            [] => None,
            _ => Some(ctx.input("ignition_map")?.to_path_buf()),
        };
        let outputs: Vec<(String, PathBuf)> = ctx
            .output_names()
            .map(str::to_string)
            .collect::<Vec<_>>()
            .into_iter()
            .filter_map(|n| ctx.output(&n).ok().map(|p| (n, p.to_path_buf())))
            .collect();
        let out = |name: &str| outputs.iter().find(|(n, _)| n == name).map(|(_, p)| p.clone());
        let report = build(
            ctx.root(),
            &params,
            ReportFiles {
                ensembles: &ensembles,
                spread: spread.as_deref(),
                forecast: &forecast,
                gridmet: &gridmet,
                ignition_map: ignition_map.as_deref(),
            },
            ctx.run_id(),
            &out,
            &|line| ctx.log(line),
        )?;
        ctx.metric("ignition_probability", 0, report.forecast.probability);
        if let Some(d) = report.forecast.daily_probability {
            ctx.metric("daily_ignition_probability", 0, d);
        }
        for s in &report.strategies {
            ctx.metric(&format!("burned_acres_{}", s.strategy), 0, s.burned_acres.value);
        }
        if let Some(f) = &report.free_spread {
            ctx.metric("burned_acres_free_spread", 0, f.fire.burned_acres.value);
        }
        Ok(())
    }
}
