//! A whole report on a small fire: synthetic GRIDMET files (the real NetCDF format), a
//! procedural landscape, the no-suppression and rule-based ensembles, a forecast file — then
//! the report's files are checked against where every number came from, against the JSON
//! Schema (Python's `jsonschema`, an independent validator), and in a real headless Chromium.

use std::path::{Path, PathBuf};
use std::process::Command;

use firecast_data::gridmet::GridmetVariable;
use firecast_episodes::ensemble::{Ensemble, Setup, run_agent};
use firecast_episodes::free_spread::run_mtt;
use firecast_episodes::{AgentKind, LandscapeSpec, Scenario, WeatherSpec};
use firecast_report::model::ThreatReport;
use firecast_report::{ReportFiles, ReportSettings, build};
use firecast_synth::{Region, SynthConfig};

const DATE: &str = "2019-08-01";

fn root() -> PathBuf {
    firecast_testkit::workspace_root()
}

struct Fixture {
    _dir: tempfile::TempDir,
    dir: PathBuf,
    settings: ReportSettings,
    ensembles: Vec<PathBuf>,
    /// The same fire spread by the verified (MTT) engine.
    spread: PathBuf,
    forecast: PathBuf,
    gridmet: PathBuf,
}

fn fixture() -> Fixture {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path().to_path_buf();
    let mut cfg = SynthConfig::new(
        3,
        Region::Box {
            lat_min: 39.0,
            lat_max: 39.6,
            lon_min: -107.7,
            lon_max: -107.1,
        },
        (2019, 2019),
    );
    cfg.variables = vec![
        GridmetVariable::Vs,
        GridmetVariable::Th,
        GridmetVariable::Tmmx,
        GridmetVariable::Tmmn,
        GridmetVariable::Rmin,
        GridmetVariable::Rmax,
        GridmetVariable::Pr,
        GridmetVariable::Erc,
        GridmetVariable::Fm100,
    ];
    cfg.write_incidents = false;
    cfg.warmup_days = 20;
    firecast_synth::generate(&cfg, &dir.join("sources"), &mut |_, _| {}).expect("synthetic GRIDMET");
    let gridmet = dir.join("sources/gridmet");

    let env: firecast_sim::EnvConfig = serde_json::from_value(serde_json::json!({
        "max_steps": 240,
        "sim": {"kernel": {"rothermel": {"moisture": {"dead_1h_frac": 0.06, "dead_10h_frac": 0.07,
            "dead_100h_frac": 0.08, "live_herb_frac": 0.6, "live_woody_frac": 0.9}}}}
    }))
    .expect("env");
    // The first landscape seed whose default ignition cell can burn.
    let (setup_none, setup_rule) = (1..20)
        .find_map(|seed| {
            let scenario = || Scenario {
                landscape: LandscapeSpec::Procedural {
                    seed,
                    width: 96,
                    height: 64,
                    center: Some([39.3, -107.4]),
                },
                weather: Some(WeatherSpec::gridmet_wind(gridmet.clone(), DATE)),
                env: env.clone(),
            };
            Some((
                Setup::new(scenario(), &dir, None).ok()?,
                Setup::new(scenario(), &dir, None).ok()?,
            ))
        })
        .expect("a burnable ignition");
    let none = run_agent(&setup_none, AgentKind::None, 6, 0, |_| {}).expect("none");
    let rule = run_agent(&setup_rule, AgentKind::Rule, 6, 0, |_| {}).expect("rule");
    let mtt = run_mtt(&setup_none, 6, 0, |_| {}).expect("mtt");
    let spread = dir.join("mtt.json");
    std::fs::write(&spread, serde_json::to_vec(&mtt).expect("json")).expect("write");
    let [lat, lon] = none.ignition_lat_lon;
    let mut ensembles = Vec::new();
    for e in [&none, &rule] {
        let p = dir.join(format!("{}.json", e.strategy));
        std::fs::write(&p, serde_json::to_vec(e).expect("json")).expect("write");
        ensembles.push(p);
    }
    let forecast = dir.join("forecast.json");
    std::fs::write(
        &forecast,
        serde_json::to_vec(&serde_json::json!({
            "version": 1, "lat": lat, "lon": lon, "date": DATE, "cell_lat": 39.3, "cell_lon": -107.4,
            "model": "xgboost", "kind": "xgboost", "protocol": "leak_free", "dataset": "test",
            "dataset_version": "0123456789abcdef", "input_days": [-60, -1], "threshold": 0.41,
            "probability": 0.62, "interval": [0.55, 0.7], "interval_method": "range over 3 training seeds",
            "per_seed": [
                {"seed": 0, "probability": 0.55, "threshold": 0.4, "validation_auroc": 0.8, "validation_auprc": 0.6},
                {"seed": 1, "probability": 0.61, "threshold": 0.41, "validation_auroc": 0.82, "validation_auprc": 0.62},
                {"seed": 2, "probability": 0.7, "threshold": 0.42, "validation_auroc": 0.78, "validation_auprc": 0.58}
            ],
            "validation_auroc": 0.8, "test_auroc": 0.75, "ignition_expected": true
        }))
        .expect("json"),
    )
    .expect("write");
    let settings: ReportSettings = serde_json::from_value(serde_json::json!({
        "lat": lat, "lon": lon, "date": DATE,
        "assets": [{"name": "Ridge camp", "lat": lat + 0.01, "lon": lon + 0.01}],
        "bootstrap_resamples": 300
    }))
    .expect("settings");
    Fixture {
        _dir: tmp,
        dir,
        settings,
        ensembles,
        spread,
        forecast,
        gridmet,
    }
}

fn make(f: &Fixture, pdf: bool) -> (ThreatReport, PathBuf) {
    make_with(f, pdf, None, "report").expect("report")
}

/// A report into `f.dir/folder`, with the verified engine's free fire when `spread` is given.
fn make_with(
    f: &Fixture,
    pdf: bool,
    spread: Option<&Path>,
    folder: &str,
) -> Result<(ThreatReport, PathBuf), firecast_report::ReportError> {
    let out = f.dir.join(folder);
    std::fs::create_dir_all(&out).expect("out");
    let o = out.clone();
    let outputs = move |name: &str| -> Option<PathBuf> {
        let file = match name {
            "html" => "report.html",
            "json" => "report.json",
            "geojson" => "report.geojson",
            "arrival_tif" => "arrival_h.tif",
            "burn_probability_tif" => "burn_probability_pct.tif",
            "pdf" if pdf => "report.pdf",
            _ => return None,
        };
        Some(o.join(file))
    };
    let report = build(
        &f.dir,
        &f.settings,
        ReportFiles {
            ensembles: &f.ensembles,
            spread,
            forecast: &f.forecast,
            gridmet: &f.gridmet,
            ignition_map: None,
        },
        "test-run",
        &outputs,
        &|_| {},
    )?;
    Ok((report, out))
}

#[test]
fn every_number_comes_from_its_source() {
    let f = fixture();
    let (report, out) = make(&f, false);
    let written = std::fs::read(out.join("report.json")).expect("json");
    assert_eq!(
        written,
        serde_json::to_vec_pretty(&report).expect("json"),
        "the JSON is the report"
    );

    let none = Ensemble::read(&f.ensembles[0]).expect("none");
    let rule = Ensemble::read(&f.ensembles[1]).expect("rule");
    let acres = none.grid.cell_size_ft.powi(2) / 43_560.0;
    let mean =
        |e: &Ensemble| e.episodes.iter().map(|r| f64::from(r.cells_burned)).sum::<f64>() / e.runs() as f64;
    let s_none = &report.strategies[0];
    let s_rule = &report.strategies[1];
    assert_eq!(s_none.strategy, "none");
    assert!((s_none.burned_acres.value - mean(&none) * acres).abs() < 1e-6);
    assert!((s_rule.burned_acres.value - mean(&rule) * acres).abs() < 1e-6);
    assert!(
        s_none.burned_acres.low <= s_none.burned_acres.value
            && s_none.burned_acres.value <= s_none.burned_acres.high
    );
    assert!(
        (s_rule.helitacks_mean - rule.episodes.iter().map(|r| f64::from(r.helitacks)).sum::<f64>() / 6.0)
            .abs()
            < 1e-9
    );
    let cmp = &report.comparisons[0];
    assert!((cmp.acres_saved.value - (mean(&none) - mean(&rule)) * acres).abs() < 1e-6);
    assert_eq!(report.forecast.probability, 0.62);
    assert_eq!(report.forecast.interval, [0.55, 0.7]);
    assert_eq!(report.forecast.seeds, 3);
    assert!((report.forecast.validation_auprc.expect("auprc") - 0.6).abs() < 1e-12);
    // The series ends at the final burnt area of each run (mean over runs).
    let last = *s_none.series_acres_mean.last().expect("series");
    assert!(
        (last - mean(&none) * acres).abs() < 1e-6,
        "{last} vs {}",
        mean(&none) * acres
    );
    // Hours, not steps: the series is hourly.
    assert_eq!(s_none.series_hours[1] - s_none.series_hours[0], 1.0);

    // Drops: the representative run's, with coordinates that round-trip through the
    // landscape's georeference to the cells the simulator used.
    let land = rule.landscape().expect("landscape");
    let k = firecast_report::compute::representative_run(&rule);
    assert_eq!(report.drops.run_seed, Some(rule.episodes[k].seed));
    assert_eq!(report.drops.drops.len(), rule.episodes[k].drops.len());
    assert!(!report.drops.drops.is_empty(), "the rule agent drops water");
    for (d, src) in report.drops.drops.iter().zip(&rule.episodes[k].drops) {
        assert_eq!((d.x, d.y), (src.x, src.y));
        assert_eq!(d.hour, src.hour);
        let cell = land.lat_lon_to_cell(d.lat, d.lon).expect("inside");
        assert_eq!(
            cell,
            (src.x as usize, src.y as usize),
            "drop {} round trip",
            d.number
        );
    }
    // Weather from the GRIDMET files: the wind the ensembles used.
    let w = none.weather.as_ref().expect("weather");
    assert!((report.weather.wind_10m_m_s - w.vs_m_s).abs() < 1e-12);
    assert!(report.weather.max_temp_c.is_some() && report.weather.fm100_pct.is_some());
    assert!(report.weather.vpd_kpa.is_none(), "no vpd file was written");
    // The listed asset is first or after developed land, with a band.
    assert!(report.assets.iter().any(|a| a.name == "Ridge camp"));
    for a in &report.assets {
        if let (Some(t), "SET") = (a.first_arrival_h, a.band.as_str()) {
            assert!((a.trigger_h.expect("trigger") - (t - 6.0)).abs() < 1e-9);
        }
    }
    // Fire behaviour: classes follow the numbers.
    let fb = &report.fire_behaviour;
    assert_eq!(
        fb.flame_length.class.as_deref(),
        Some(firecast_report::units::flame_class(fb.flame_length.field))
    );
    assert!((fb.flame_length.si - fb.flame_length.field * 0.3048).abs() < 1e-9);

    // The GeoJSON: a FeatureCollection whose drops are the report's.
    let gj: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.geojson")).expect("geojson")).expect("parse");
    assert_eq!(gj["type"], "FeatureCollection");
    let features = gj["features"].as_array().expect("features");
    let drops: Vec<&serde_json::Value> = features
        .iter()
        .filter(|f| f["properties"]["kind"] == "drop")
        .collect();
    assert_eq!(drops.len(), report.drops.drops.len());
    assert!(
        features
            .iter()
            .any(|f| f["properties"]["kind"] == "arrival_isochrone")
    );
    for f in features {
        if f["geometry"]["type"] == "MultiPolygon" {
            for poly in f["geometry"]["coordinates"].as_array().expect("polys") {
                for ring in poly.as_array().expect("rings") {
                    let r = ring.as_array().expect("ring");
                    assert!(r.len() >= 4 && r.first() == r.last(), "closed ring");
                }
            }
        }
    }

    // Self-contained HTML: no scripts, every src/href a data URI or a fragment.
    let html = std::fs::read_to_string(out.join("report.html")).expect("html");
    assert!(!html.to_lowercase().contains("<script"));
    for attr in ["src=\"", "href=\""] {
        for part in html.split(attr).skip(1) {
            assert!(
                part.starts_with("data:") || part.starts_with('#'),
                "external reference: {attr}{}",
                &part[..part.len().min(60)]
            );
        }
    }
    for section in [
        "Ignition forecast",
        "Evacuation advisories",
        "not a progression map",
        "Contingency thresholds",
    ] {
        assert!(html.contains(section), "missing {section}");
    }
    assert!(
        !html.contains(" steps") && !html.contains(" cells burned"),
        "no simulation units"
    );

    // The JSON against the committed schema, by an independent validator.
    {
        let py = firecast_testkit::python_with(&["jsonschema"]);
        let schema = root().join("schemas/threat-report-1.schema.json");
        let status = Command::new(py)
            .args([
                "-c",
                "import json,sys,jsonschema; s=json.load(open(sys.argv[1])); jsonschema.Draft202012Validator.check_schema(s); \
                 jsonschema.validate(json.load(open(sys.argv[2])), s, cls=jsonschema.Draft202012Validator)",
            ])
            .arg(&schema)
            .arg(out.join("report.json"))
            .status()
            .expect("python");
        assert!(
            status.success(),
            "report.json does not validate against {}",
            schema.display()
        );
    }
}

#[test]
fn the_committed_schema_is_the_model() {
    let path = root().join("schemas/threat-report-1.schema.json");
    let generated =
        serde_json::to_string_pretty(&firecast_report::model::json_schema()).expect("schema") + "\n";
    if std::env::var_os("FIRECAST_BLESS").is_some() {
        std::fs::write(&path, &generated).expect("write schema");
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "{} is out of date: run `FIRECAST_BLESS=1 cargo test -p firecast-report --test report` and commit it",
        path.display()
    );
}

/// What the page looks like at a window width, measured by the browser: the script is added
/// to a copy of the report (the report itself has none).
fn layout(chromium: &Path, html: &Path, dir: &Path, width: u32) -> serde_json::Value {
    let page = std::fs::read_to_string(html).expect("html");
    let probe = r#"<script>
const W = document.documentElement.clientWidth;
const wide = [];
for (const e of document.querySelectorAll('main *')) {
  const r = e.getBoundingClientRect();
  if (r.width > 0 && r.right > W + 1) wide.push(e.tagName + (e.className ? '.' + e.className : '') + ':' + Math.round(r.right));
}
const m = document.querySelector('#answer svg.map').getBoundingClientRect();
document.body.setAttribute('data-look', JSON.stringify({width: W, scroll_width: document.documentElement.scrollWidth,
  wide: wide.slice(0, 12), map_top: m.top, map_bottom: m.bottom, map_width: m.width}));
</script></body>"#;
    let probe_html = dir.join(format!("probe-{width}.html"));
    std::fs::write(&probe_html, page.replace("</body>", probe)).expect("probe");
    let run = Command::new(chromium)
        .args(firecast_report::pdf::headless_args(
            &dir.join(format!("profile-{width}")),
        ))
        .args([
            "--dump-dom",
            "--hide-scrollbars",
            &format!("--window-size={width},900"),
        ])
        .arg(format!("file://{}", probe_html.display()))
        .output()
        .expect("chromium");
    let dom = String::from_utf8_lossy(&run.stdout);
    let attr = dom
        .split("data-look=\"")
        .nth(1)
        .and_then(|rest| rest.split('"').next())
        .expect("the probe ran");
    serde_json::from_str(&attr.replace("&quot;", "\"").replace("&amp;", "&")).expect("probe JSON")
}

/// Renders the report in a real browser at a phone's and a desk's width and prints it, and
/// checks what a reader sees: nothing wider than the page, the map on the first screen, a
/// running header and page numbers on every printed page. With `FIRECAST_LOOK_DIR` set the
/// screenshots and page images are kept there to look at.
#[test]
fn renders_in_chromium_and_prints_to_pdf() {
    let Ok(chromium) = firecast_report::pdf::chromium() else {
        panic!("no Chromium: `cargo xtask setup` installs Debian's chromium");
    };
    let f = fixture();
    let (_, out) = make(&f, true);
    let html = out.join("report.html");
    // Rendered by a real browser without console errors.
    let profile = f.dir.join("profile");
    let run = Command::new(&chromium)
        .args(firecast_report::pdf::headless_args(&profile))
        .args(["--enable-logging=stderr", "--v=0", "--dump-dom"])
        .arg(format!("file://{}", html.display()))
        .output()
        .expect("chromium");
    assert!(run.status.success());
    let dom = String::from_utf8_lossy(&run.stdout);
    assert!(dom.contains("Evacuation advisories") && dom.contains("<svg"));
    let stderr = String::from_utf8_lossy(&run.stderr);
    let console: Vec<&str> = stderr.lines().filter(|l| l.contains(":CONSOLE")).collect();
    assert!(console.is_empty(), "console messages: {console:?}");
    // A phone and a desk: nothing sticks out, the map is on the first screen.
    for width in [390u32, 1280] {
        let look = layout(&chromium, &html, &f.dir, width);
        let w = look["width"].as_f64().expect("width");
        assert!(
            look["scroll_width"].as_f64() <= Some(w) && look["wide"].as_array().is_some_and(Vec::is_empty),
            "at {width} px something is wider than the page: {look}"
        );
        let top = look["map_top"].as_f64().expect("map");
        assert!(
            top < 450.0,
            "at {width} px the map starts {top} px down: not on the first screen ({look})"
        );
        assert!(
            look["map_width"].as_f64() >= Some((w * 0.9).min(560.0)),
            "at {width} px the map is too small: {look}"
        );
    }
    let keep = std::env::var_os("FIRECAST_LOOK_DIR").map(PathBuf::from);
    if let Some(dir) = &keep {
        std::fs::create_dir_all(dir).expect("look dir");
        for (width, height) in [(390u32, 2400u32), (1280, 1600)] {
            let shot = dir.join(format!("report-{width}.png"));
            let status = Command::new(&chromium)
                .args(firecast_report::pdf::headless_args(&f.dir.join("profile-shot")))
                .args(["--hide-scrollbars", &format!("--window-size={width},{height}")])
                .arg(format!("--screenshot={}", shot.display()))
                .arg(format!("file://{}", html.display()))
                .output()
                .expect("chromium");
            assert!(status.status.success());
        }
    }
    // The PDF opens and carries the report, page by page (poppler), each page with the place,
    // the day and its number.
    let pdf = out.join("report.pdf");
    let bytes = std::fs::read(&pdf).expect("pdf");
    assert!(bytes.starts_with(b"%PDF-"));
    let info = Command::new("pdfinfo")
        .arg(&pdf)
        .output()
        .expect("pdfinfo (poppler-utils)");
    let info = String::from_utf8_lossy(&info.stdout);
    let pages: usize = info
        .lines()
        .find_map(|l| l.strip_prefix("Pages:"))
        .and_then(|v| v.trim().parse().ok())
        .expect("page count");
    assert!((3..=12).contains(&pages), "{pages} pages");
    let page_text = |k: usize| {
        let text = Command::new("pdftotext")
            .args(["-layout", "-f", &k.to_string(), "-l", &k.to_string()])
            .arg(&pdf)
            .arg("-")
            .output()
            .expect("pdftotext");
        String::from_utf8_lossy(&text.stdout).into_owned()
    };
    let mut all = String::new();
    for k in 1..=pages {
        let text = page_text(k);
        assert!(
            text.contains(&format!("Page {k} of {pages}")),
            "page {k} has no page number:\n{text}"
        );
        assert!(
            text.contains("forecast day 2019-08-01") && text.contains("39.") && text.contains("107."),
            "page {k} lacks the running header with place and day:\n{text}"
        );
        // No page (the last included) holds only a few lines.
        let lines = text.lines().filter(|l| !l.trim().is_empty()).count();
        assert!(lines >= 8, "page {k} is nearly empty ({lines} lines):\n{text}");
        all.push_str(&text);
    }
    for needle in [
        "Fire threat assessment",
        "Where it goes and how fast",
        "Evacuation advisories",
        "Model score",
    ] {
        assert!(all.contains(needle), "PDF text lacks {needle}");
    }
    if let Some(dir) = &keep {
        let status = Command::new("pdftoppm")
            .args(["-r", "50", "-png"])
            .arg(&pdf)
            .arg(dir.join("report-page"))
            .status()
            .expect("pdftoppm");
        assert!(status.success());
    }
}

/// `.venv`'s Python, which `cargo xtask setup` installs with shapely and rasterio.
fn gis_python() -> PathBuf {
    firecast_testkit::python_with(&["shapely", "rasterio"])
}

/// Runs `tests/gis_check.py` and fails with its findings.
fn gis_check(args: &[&std::ffi::OsStr]) {
    let out = Command::new(gis_python())
        .arg(
            std::path::PathBuf::from(
                std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
            )
            .join("tests/gis_check.py"),
        )
        .args(args)
        .output()
        .expect("python");
    assert!(
        out.status.success(),
        "gis_check.py {:?}:\n{}{}",
        args,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn gis_files_are_valid_and_agree_with_the_report() {
    let f = fixture();
    let (_, out) = make(&f, false);
    // Every geometry valid by GEOS (shapely), rings closed and wound as RFC 7946 says.
    gis_check(&["geojson".as_ref(), out.join("report.geojson").as_os_str()]);
    // The GeoTIFFs as GDAL reads them: the ensemble's grid, CRS and values, and the
    // report's numbers recomputed from them.
    gis_check(&[
        "rasters".as_ref(),
        out.join("report.json").as_os_str(),
        f.ensembles[0].as_os_str(),
        out.join("arrival_h.tif").as_os_str(),
        out.join("burn_probability_pct.tif").as_os_str(),
    ]);
}

/// The polygon tracing on masks full of corner touches, checked by shapely: many random
/// masks (half the cells set, where diagonal touches are most frequent), a checkerboard and
/// rings of cells closed only at a corner. Coordinates are grid vertices, so each polygon's
/// area must be its number of cells.
#[test]
fn traced_polygons_are_valid_for_shapely_on_any_mask() {
    use firecast_report::geometry::{multipolygon, polygons, rings};
    let mut masks: Vec<(usize, usize, Vec<bool>)> = Vec::new();
    let mut state = 0x2545_f491_4f6c_dd1du64;
    for k in 0..400 {
        let (w, h) = if k % 4 == 0 { (40, 30) } else { (12, 9) };
        let density = [0.35, 0.5, 0.65][k % 3];
        let cells = (0..w * h)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 11) as f64 / (1u64 << 53) as f64 <= density
            })
            .collect();
        masks.push((w, h, cells));
    }
    masks.push((9, 7, (0..63).map(|i| (i % 9 + i / 9) % 2 == 0).collect()));
    masks.push((3, 3, vec![false, true, true, true, false, true, true, true, true]));
    // One MultiPolygon per mask: shapely also checks that its polygons do not overlap and
    // meet at points only; its area is counted from the mask, not from the rings.
    let mut features = Vec::new();
    for (k, (w, h, cells)) in masks.iter().enumerate() {
        let polys = polygons(rings(*w, *h, |i| cells[i]));
        if polys.is_empty() {
            continue;
        }
        let geometry = multipolygon(&polys, |x, y| Some([x as f64, y as f64])).expect("coordinates");
        features.push(serde_json::json!({
            "type": "Feature", "geometry": geometry,
            "properties": {"kind": format!("mask {k} ({w} x {h})"),
                           "cells": cells.iter().filter(|&&c| c).count()},
        }));
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("masks.geojson");
    std::fs::write(
        &path,
        serde_json::to_vec(&serde_json::json!({"type": "FeatureCollection", "features": features}))
            .expect("json"),
    )
    .expect("write");
    gis_check(&["geojson".as_ref(), path.as_os_str(), "--area".as_ref()]);
}

/// Every property of the committed schema says what it is, with its unit; the closed
/// vocabularies are enumerations.
#[test]
fn every_schema_property_is_described() {
    let path = root().join("schemas/threat-report-1.schema.json");
    let schema: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).expect("schema")).expect("json");
    fn walk(at: &str, v: &serde_json::Value, missing: &mut Vec<String>, count: &mut usize) {
        match v {
            serde_json::Value::Object(map) => {
                if let Some(serde_json::Value::Object(props)) = map.get("properties") {
                    for (name, p) in props {
                        *count += 1;
                        let described = p
                            .get("description")
                            .and_then(serde_json::Value::as_str)
                            .is_some_and(|d| d.trim().len() > 3);
                        if !described {
                            missing.push(format!("{at}/properties/{name}"));
                        }
                    }
                }
                for (k, child) in map {
                    walk(&format!("{at}/{k}"), child, missing, count);
                }
            }
            serde_json::Value::Array(items) => {
                for (i, child) in items.iter().enumerate() {
                    walk(&format!("{at}/{i}"), child, missing, count);
                }
            }
            _ => {}
        }
    }
    let (mut missing, mut count) = (Vec::new(), 0);
    walk("#", &schema, &mut missing, &mut count);
    assert!(count > 150, "only {count} properties found");
    assert!(
        missing.is_empty(),
        "{} of {count} properties have no description: {missing:#?}",
        missing.len()
    );
    let defs = &schema["$defs"];
    assert_eq!(
        defs["RiskLevel"]["enum"],
        serde_json::json!(["LOW", "MODERATE", "HIGH", "SEVERE"])
    );
    assert_eq!(
        defs["Band"]["enum"],
        serde_json::json!(["GO", "SET", "READY", "NONE"])
    );
    assert_eq!(
        defs["AssetSource"]["enum"],
        serde_json::json!(["listed", "developed"])
    );
    for (def, prop) in [
        ("Weather", "wind_from"),
        ("FireBehaviour", "head_direction"),
        ("Quantity", "class"),
        ("Quantity", "field_unit"),
        ("Quantity", "si_unit"),
        ("Contingency", "resource"),
    ] {
        assert!(
            defs[def]["properties"][prop]["enum"].is_array(),
            "{def}.{prop} is not an enumeration"
        );
    }
}

/// Every property of every GeoJSON feature kind is in the report guide's table of GeoJSON
/// properties, with its unit.
#[test]
fn every_geojson_property_is_documented() {
    let f = fixture();
    let (_, out) = make(&f, false);
    let gj: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.geojson")).expect("geojson")).expect("parse");
    let guide = std::fs::read_to_string(root().join("docs/guides/report.md")).expect("guide");
    let section = guide
        .split("### GeoJSON properties")
        .nth(1)
        .expect("a `### GeoJSON properties` section in docs/guides/report.md");
    let section = section.split("\n#").next().unwrap_or(section);
    // Rows: | `kind` | `property` | unit | meaning |
    let documented: std::collections::BTreeSet<(String, String)> = section
        .lines()
        .filter_map(|l| {
            let cells: Vec<&str> = l.split('|').map(str::trim).collect();
            (cells.len() >= 5 && !cells[3].is_empty()).then(|| {
                (
                    cells[1].trim_matches('`').to_string(),
                    cells[2].trim_matches('`').to_string(),
                )
            })
        })
        .collect();
    let mut undocumented = std::collections::BTreeSet::new();
    for feature in gj["features"].as_array().expect("features") {
        let props = feature["properties"].as_object().expect("properties");
        let kind = props["kind"].as_str().expect("kind");
        for name in props.keys() {
            if name != "kind"
                && !documented.contains(&(kind.to_string(), name.clone()))
                && !documented.contains(&("*".to_string(), name.clone()))
            {
                undocumented.insert(format!("{kind}.{name}"));
            }
        }
    }
    assert!(
        undocumented.is_empty(),
        "not in the guide's GeoJSON table: {undocumented:?}"
    );
}

/// With the verified engine's free fire, where the fire goes and when comes from it (the
/// GeoTIFFs cell by cell, the isochrones, the free burnt area, the assets' arrival) and the
/// strategy comparison stays on the automaton, paired as without it.
#[test]
fn the_verified_engine_draws_where_the_fire_goes() {
    let f = fixture();
    let (plain, _) = make(&f, false);
    let (report, out) = make_with(&f, false, Some(&f.spread), "with-spread").expect("report");
    let none = Ensemble::read(&f.ensembles[0]).expect("none");
    let rule = Ensemble::read(&f.ensembles[1]).expect("rule");
    let mtt = Ensemble::read(&f.spread).expect("mtt");
    let cell_acres = firecast_report::units::cell_acres(report.header.cell_size_ft);
    let mean_acres = |e: &Ensemble| {
        e.episodes.iter().map(|r| f64::from(r.cells_burned)).sum::<f64>() / e.runs() as f64 * cell_acres
    };
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
    // The two engines burn differently here, so the checks below tell them apart.
    assert!(
        !close(mean_acres(&mtt), mean_acres(&none)),
        "the engines agree on this fire: the test cannot tell them apart"
    );

    // The free fire: the MTT ensemble's runs.
    let free = report.free_spread.as_ref().expect("free_spread");
    assert!(close(free.fire.burned_acres.value, mean_acres(&mtt)));
    assert!(close(free.automaton_burned_acres, mean_acres(&none)));
    let mut acres: Vec<f64> = mtt
        .episodes
        .iter()
        .map(|r| f64::from(r.cells_burned) * cell_acres)
        .collect();
    acres.sort_by(f64::total_cmp);
    assert!(acres[0] <= free.burned_acres_p10 && free.burned_acres_p10 <= free.fire.burned_acres_median);
    assert!(
        free.fire.burned_acres_median <= free.burned_acres_p90
            && free.burned_acres_p90 <= acres[acres.len() - 1]
    );
    let edge = mtt.episodes.iter().filter(|r| r.edge_cells_burned > 0).count();
    assert!(close(free.edge_runs_pct, edge as f64 / mtt.runs() as f64 * 100.0));
    assert_eq!(free.edge_first_h_median.is_some(), edge > 0);
    for &[t, a] in &free.fire.isochrone_acres {
        let n = mtt
            .arrival_median_h
            .iter()
            .flatten()
            .filter(|&&x| f64::from(x) <= t)
            .count();
        assert!(close(a, n as f64 * cell_acres), "isochrone {t} h");
    }

    // The strategy comparison stays on the automaton, identical to the report without MTT.
    assert_eq!(report.strategies, plain.strategies);
    assert_eq!(report.comparisons, plain.comparisons);
    assert_eq!(report.drops, plain.drops);
    assert_eq!(report.priority_zones, plain.priority_zones);
    assert!(close(report.strategies[0].burned_acres.value, mean_acres(&none)));
    let saved: f64 = none
        .episodes
        .iter()
        .zip(&rule.episodes)
        .map(|(n, r)| {
            assert_eq!(n.seed, r.seed);
            (f64::from(n.cells_burned) - f64::from(r.cells_burned)) * cell_acres
        })
        .sum::<f64>()
        / none.runs() as f64;
    assert!(close(report.comparisons[0].acres_saved.value, saved));

    // The GeoTIFFs are the MTT ensemble's, cell by cell (north row first in the file).
    let (w, h, arrival) =
        firecast_landscape::gridio::read_band_f32(&out.join("arrival_h.tif")).expect("arrival");
    let (_, _, bp) = firecast_landscape::gridio::read_band_f32(&out.join("burn_probability_pct.tif"))
        .expect("burn probability");
    assert_eq!((w, h), (mtt.grid.width, mtt.grid.height));
    let mut differs = false;
    for row in 0..h {
        for x in 0..w {
            let i = (h - 1 - row) * w + x;
            assert_eq!(
                arrival[row * w + x],
                mtt.arrival_median_h[i].unwrap_or(-9999.0),
                "arrival at ({x}, {row})"
            );
            assert_eq!(
                bp[row * w + x],
                mtt.burn_count[i] as f32 * 100.0 / mtt.runs() as f32
            );
            differs |= mtt.arrival_median_h[i] != none.arrival_median_h[i];
        }
    }
    assert!(
        differs,
        "the automaton's arrival equals the engine's: nothing was told apart"
    );

    // The assets' earliest arrival: the MTT runs' earliest within the buffer.
    let land = mtt.landscape().expect("landscape");
    let camp = report
        .assets
        .iter()
        .find(|a| a.name == "Ridge camp")
        .expect("listed asset");
    let spec = &f.settings.assets[0];
    let (ax, ay) = land.lat_lon_to_cell(spec.lat, spec.lon).expect("inside");
    let r = (report.evacuation_bands.buffer_ft / land.cell_size_ft).round() as usize;
    let mut first: Option<f32> = None;
    for y in ay.saturating_sub(r)..=(ay + r).min(land.height - 1) {
        for x in ax.saturating_sub(r)..=(ax + r).min(land.width - 1) {
            if let Some(t) = mtt.arrival_first_h[y * land.width + x] {
                first = Some(first.map_or(t, |f| f.min(t)));
            }
        }
    }
    assert_eq!(camp.first_arrival_h, first.map(f64::from));
    assert_eq!(
        camp.first_arrival_strategy.as_deref(),
        first.map(|_| firecast_report::compute::FREE_SPREAD_KEY)
    );
    assert_eq!(camp.reached_pct[0].0, firecast_report::compute::FREE_SPREAD_KEY);

    // Which engine drew what, with both measured burnt areas.
    let fmt = |v: f64| firecast_report::units::fmt_num(v, 0);
    let line = report
        .assumptions
        .iter()
        .find(|a| a.starts_with("Where the fire goes and when: the minimum-travel-time engine verified"))
        .expect("the engines' assumption line");
    assert!(
        line.contains(&format!(
            "burned {} acres against the verified engine's {}",
            fmt(mean_acres(&none)),
            fmt(mean_acres(&mtt))
        )),
        "{line}"
    );
    assert!(
        !plain
            .assumptions
            .iter()
            .any(|a| a.starts_with("Where the fire goes"))
    );
    let html = std::fs::read_to_string(out.join("report.html")).expect("html");
    assert!(html.contains("Free fire, verified minimum-travel-time engine"));
    assert!(html.contains("(verified minimum-travel-time engine, "));

    // The GeoJSON carries both engines' isochrones, named.
    let gj: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.geojson")).expect("geojson")).expect("parse");
    let isochrones = |engine: &str| {
        gj["features"]
            .as_array()
            .expect("features")
            .iter()
            .filter(|f| f["properties"]["kind"] == "arrival_isochrone" && f["properties"]["engine"] == engine)
            .map(|f| f["properties"]["area_acres"].as_f64().expect("acres"))
            .collect::<Vec<f64>>()
    };
    let expected: Vec<f64> = free
        .fire
        .isochrone_acres
        .iter()
        .map(|p| p[1])
        .filter(|&a| a > 0.0)
        .collect();
    let got = isochrones("minimum travel time");
    assert_eq!(got.len(), expected.len());
    assert!(
        got.iter().zip(&expected).all(|(&g, &e)| close(g, e)),
        "{got:?} {expected:?}"
    );
    assert!(!isochrones("automaton").is_empty());

    // GDAL and the schema agree too.
    gis_check(&[
        "rasters".as_ref(),
        out.join("report.json").as_os_str(),
        f.spread.as_os_str(),
        out.join("arrival_h.tif").as_os_str(),
        out.join("burn_probability_pct.tif").as_os_str(),
    ]);
    gis_check(&["geojson".as_ref(), out.join("report.geojson").as_os_str()]);
    {
        let py = firecast_testkit::python_with(&["jsonschema"]);
        let status = Command::new(py)
            .args([
                "-c",
                "import json,sys,jsonschema; s=json.load(open(sys.argv[1])); \
                 jsonschema.validate(json.load(open(sys.argv[2])), s, cls=jsonschema.Draft202012Validator)",
            ])
            .arg(root().join("schemas/threat-report-1.schema.json"))
            .arg(out.join("report.json"))
            .status()
            .expect("python");
        assert!(status.success(), "report.json with free_spread does not validate");
    }
}

/// An automaton ensemble given as the verified engine's free fire is refused.
#[test]
fn only_the_verified_engine_is_taken_as_the_free_fire() {
    let f = fixture();
    let err =
        make_with(&f, false, Some(&f.ensembles[0]), "wrong").expect_err("an automaton fire is not verified");
    assert!(
        err.to_string()
            .contains("not a free fire of the minimum-travel-time engine"),
        "{err}"
    );
}

/// The forecasted ignition pattern: `forecast.predict`'s `map` goes into the JSON in percent
/// and into the page as a map; a map for another day is refused by its file.
#[test]
fn the_ignition_pattern_is_drawn_from_the_forecast_map() {
    let f = fixture();
    let map = f.dir.join("ignition_map.json");
    let write = |date: &str| {
        let doc = serde_json::json!({
            "date": date, "model": "m", "protocol": "leak_free", "threshold": 0.5, "seeds": 1,
            "lats": [39.25, 39.3, 39.35], "lons": [-107.45, -107.4],
            "probability": [[0.1, 0.6], [null, 0.7], [0.2, 0.4]]
        });
        std::fs::write(&map, serde_json::to_vec(&doc).expect("json")).expect("write map");
    };
    write("2019-08-01");
    let out = f.dir.join("pattern");
    std::fs::create_dir_all(&out).expect("out");
    let o = out.clone();
    let outputs = move |name: &str| -> Option<PathBuf> {
        match name {
            "html" => Some(o.join("report.html")),
            "json" => Some(o.join("report.json")),
            _ => None,
        }
    };
    let files = |ignition_map| ReportFiles {
        ensembles: &f.ensembles,
        spread: None,
        forecast: &f.forecast,
        gridmet: &f.gridmet,
        ignition_map,
    };
    let report = build(
        &f.dir,
        &f.settings,
        files(Some(&map)),
        "test-run",
        &outputs,
        &|_| {},
    )
    .expect("report");
    let p = report.forecast.pattern.expect("pattern");
    assert_eq!((p.cells, p.cells_above_threshold), (5, 2));
    assert_eq!(p.probability_pct[1][0], None);
    assert!((p.probability_pct[0][1].expect("cell") - 60.0).abs() < 1e-9);
    assert!((p.max_pct.expect("max") - 70.0).abs() < 1e-9);
    let html = std::fs::read_to_string(out.join("report.html")).expect("html");
    assert!(
        html.contains("Forecasted ignition pattern")
            && html.contains("2 cells with a score at or above the 50 % alert threshold"),
        "{html}"
    );
    // A model that records its training fires: the day's chance, and the map relative to the
    // usual day.
    assert!(
        html.contains("not a daily chance"),
        "a score is not called a chance"
    );
    let mut forecast: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&f.forecast).expect("forecast")).expect("json");
    forecast["daily"] = serde_json::json!({
        "probability": 0.0012, "interval": [0.0009, 0.0016], "usual": 0.0004, "relative_to_usual": 3.0,
        "base": {"sampled_prevalence": 0.4, "usual": 0.0004, "ignition_cell_days": 40, "cells": 100, "days": 1000},
        "method": "each seed's score corrected (test)"
    });
    let daily_forecast = f.dir.join("forecast-daily.json");
    std::fs::write(&daily_forecast, serde_json::to_vec(&forecast).expect("json")).expect("write");
    let doc = serde_json::json!({
        "date": "2019-08-01", "model": "m", "protocol": "leak_free", "threshold": 0.5, "seeds": 1,
        "lats": [39.25, 39.3, 39.35], "lons": [-107.45, -107.4],
        "probability": [[0.1, 0.6], [null, 0.7], [0.2, 0.4]],
        "daily_probability": [[0.0001, 0.0016], [null, 0.0032], [0.0002, 0.0008]],
        "usual_daily": 0.0004
    });
    std::fs::write(&map, serde_json::to_vec(&doc).expect("json")).expect("write map");
    let report = build(
        &f.dir,
        &f.settings,
        ReportFiles {
            forecast: &daily_forecast,
            ..files(Some(&map))
        },
        "test-run",
        &outputs,
        &|_| {},
    )
    .expect("report");
    assert_eq!(report.forecast.daily_probability, Some(0.0012));
    assert_eq!(report.forecast.usual_daily_probability, Some(0.0004));
    let p = report.forecast.pattern.expect("pattern");
    let rel = p.relative_to_usual.expect("relative");
    assert!((rel[1][1].expect("cell") - 8.0).abs() < 1e-9 && rel[1][0].is_none());
    let html = std::fs::read_to_string(out.join("report.html")).expect("html");
    for needle in [
        "Chance of an ignition in this cell on the day: <b>0.12 %</b>, <b>3.0×</b> the usual day (0.040 %)",
        "Chance of an ignition that day",
        "relative to the usual day of the training area (0.040 % a cell): highest 8.0×",
    ] {
        assert!(html.contains(needle), "no `{needle}` in the page");
    }
    write("2019-08-02");
    let err = build(
        &f.dir,
        &f.settings,
        files(Some(&map)),
        "test-run",
        &outputs,
        &|_| {},
    )
    .expect_err("another day");
    assert!(
        err.to_string().contains("ignition_map.json") && err.to_string().contains("2019-08-02"),
        "{err}"
    );
}
