//! The report as one self-contained HTML file: no scripts, no external references (images are
//! data URIs, the map is inline SVG), readable on a phone and printable (the PDF is this page
//! printed by Chromium).

use std::fmt::Write;

use crate::ReportError;
use crate::compute::Computed;
use crate::figures::{self, hex, strategy_color};
use crate::geometry;
use crate::model::*;
use crate::units::{compass, fmt_num, lat_lon_text};

/// Drops numbered on the map and listed in the table (the rest are in the JSON and GeoJSON).
pub const DROPS_LISTED: usize = 30;
/// Colour of the verified free fire's final perimeter on the map.
const FINAL_PERIMETER: &str = "#4a148c";

pub fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

fn opt(v: Option<f64>, digits: usize, unit: &str) -> String {
    v.map_or_else(
        || "—".into(),
        |v| format!("{} {unit}", fmt_num(v, digits)).trim_end().to_string(),
    )
}

fn est(e: &Estimate, digits: usize) -> String {
    format!(
        "{} <span class=ci>[{}, {}]</span>",
        fmt_num(e.value, digits),
        fmt_num(e.low, digits),
        fmt_num(e.high, digits)
    )
}

const CSS: &str = r#"
:root{--ink:#1b1b1b;--muted:#5b5b5b;--line:#d6d6d6;--bg:#fff}
*{box-sizing:border-box}
body{font-family:"DejaVu Sans","Liberation Sans",Arial,sans-serif;color:var(--ink);background:var(--bg);margin:0;line-height:1.4;font-size:15px}
main{max-width:1180px;margin:0 auto;padding:12px}
h1{font-size:1.45em;margin:.1em 0}
h2{font-size:1.15em;border-bottom:2px solid var(--ink);margin:1.2em 0 .4em;padding-bottom:2px}
h3{font-size:1em;margin:.7em 0 .25em}
table{border-collapse:collapse;width:100%;margin:.3em 0;font-size:.92em}
th,td{border-bottom:1px solid var(--line);padding:3px 6px;text-align:left;vertical-align:top}
th{background:#f2f2f2}
td.n{text-align:right;white-space:nowrap}
.ci{color:var(--muted);font-size:.9em}
.muted{color:var(--muted);font-size:.9em}
.warn{border-left:4px solid #ef6c00;background:#fff3e0;padding:3px 8px}
.badge{display:inline-block;padding:2px 10px;border-radius:4px;font-weight:bold;color:#fff}
.LOW{background:#2e7d32}.MODERATE{background:#f9a825;color:#111}.HIGH{background:#ef6c00}.SEVERE{background:#b71c1c}
.GO{background:#b71c1c;color:#fff}.SET{background:#ef6c00;color:#fff}.READY{background:#f9a825}.NONE{background:#e0e0e0}
.band{font-weight:bold;padding:1px 6px;border-radius:3px;white-space:nowrap}
.box{border:2px solid var(--ink);padding:8px 12px;margin:.6em 0;border-radius:4px}
.box ul,.facts ul{margin:.2em 0;padding-left:1.2em}
.grid2{display:grid;grid-template-columns:minmax(0,1fr) minmax(0,1fr);gap:12px}
.answer{display:grid;grid-template-columns:minmax(0,1.25fr) minmax(0,1fr);gap:16px;align-items:start;margin-top:.4em}
.facts p{margin:.2em 0 .5em}
.facts h3{border-bottom:1px solid var(--line)}
.tw{overflow-x:auto;max-width:100%}
svg.map text{font-size:17px}svg.map text.big{font-size:19px}
img,svg{max-width:100%;height:auto;display:block}
figure{margin:.5em 0}
figcaption{font-size:.85em;color:var(--muted)}
.legend{font-size:.85em;margin:.2em 0}
.legend span{display:inline-block;margin-right:12px;white-space:nowrap}
.sw{display:inline-block;width:22px;height:0;border-top:3px solid;vertical-align:middle;margin-right:4px}
.swd{display:inline-block;width:22px;height:0;border-top:3px dashed;vertical-align:middle;margin-right:4px}
.swf{display:inline-block;width:14px;height:14px;vertical-align:middle;margin-right:4px;border:1px solid #999}
header .meta{font-size:.85em;color:var(--muted)}
@media (max-width:900px){.answer{grid-template-columns:1fr}}
@media (max-width:640px){.grid2{grid-template-columns:1fr}body{font-size:14px}main{padding:8px}
table.stack thead{display:none}table.stack tr{display:block;border-bottom:1px solid var(--line);padding:3px 0}
table.stack td{display:flex;justify-content:space-between;gap:10px;border:0;padding:1px 4px;text-align:right;white-space:normal}
table.stack td::before{content:attr(data-l);font-weight:bold;color:var(--muted);text-align:left;flex:0 0 40%}
table.stack td.n{white-space:normal}.legend span{white-space:normal}
svg.map text{font-size:30px}svg.map text.big{font-size:32px}}
@media print{body{font-size:12px}main{max-width:none;padding:0}.answer{grid-template-columns:minmax(0,1.2fr) minmax(0,1fr)}
h2,h3{break-after:avoid}tr,figure,.box,.keep,.legend{break-inside:avoid}thead{display:table-header-group}.tw{overflow:visible}}
"#;

/// A table whose header row repeats on printed pages and that turns into labelled rows on a
/// phone: `head` are the columns, each row's cells are (html, numeric).
struct Table<'a> {
    head: &'a [&'a str],
    html: String,
}

impl<'a> Table<'a> {
    fn new(head: &'a [&'a str]) -> Self {
        let mut html = String::from("<div class=tw><table class=stack><thead><tr>");
        for c in head {
            let _ = write!(html, "<th>{c}</th>");
        }
        html.push_str("</tr></thead><tbody>");
        Self { head, html }
    }

    fn row(&mut self, cells: &[(String, bool)]) {
        self.html.push_str("<tr>");
        for (k, (cell, numeric)) in cells.iter().enumerate() {
            let label = strip_tags(self.head.get(k).copied().unwrap_or(""));
            let _ = write!(
                self.html,
                "<td data-l=\"{}\"{}>{cell}</td>",
                esc(&label),
                if *numeric { " class=n" } else { "" }
            );
        }
        self.html.push_str("</tr>");
    }

    fn wide(&mut self, html: &str) {
        let _ = write!(self.html, "<tr><td colspan={}>{html}</td></tr>", self.head.len());
    }

    fn finish(mut self) -> String {
        self.html.push_str("</tbody></table></div>");
        self.html
    }
}

fn strip_tags(s: &str) -> String {
    let mut out = String::new();
    let mut inside = false;
    for c in s.chars() {
        match c {
            '<' => inside = true,
            '>' => inside = false,
            c if !inside => out.push(c),
            _ => {}
        }
    }
    out
}

fn n(s: String) -> (String, bool) {
    (s, true)
}
fn t(s: String) -> (String, bool) {
    (s, false)
}

/// The printed page: a running header with the place and day, page numbers in the footer.
fn page_css(hd: &Header) -> String {
    let css_str = |s: &str| s.replace('\\', "\\\\").replace('"', "\\\"");
    format!(
        "@page{{size:Letter;margin:16mm 11mm 14mm 11mm;\
         @top-left{{content:\"{}\";font:8.5pt 'DejaVu Sans',Arial,sans-serif;color:#444}}\
         @top-right{{content:\"{}\";font:8.5pt 'DejaVu Sans',Arial,sans-serif;color:#444}}\
         @bottom-right{{content:\"Page \" counter(page) \" of \" counter(pages);font:8.5pt 'DejaVu Sans',Arial,sans-serif;color:#444}}\
         @bottom-left{{content:\"FireCast {} · simulated fires are a planning aid, not a prediction\";font:8pt 'DejaVu Sans',Arial,sans-serif;color:#777}}}}",
        css_str(&format!("{} · {}", hd.title, lat_lon_text(hd.lat, hd.lon))),
        css_str(&format!("forecast day {} · issued {}", hd.date, hd.issued_at)),
        css_str(&hd.firecast_version)
    )
}

/// Burnt area as a responder reads it: the median run and the range most runs fall in.
fn outcome(median: f64, p10: f64, p90: f64) -> String {
    format!(
        "<b>{} acres</b> in the median run (8 runs in 10: {}–{})",
        fmt_num(median, 0),
        fmt_num(p10, 0),
        fmt_num(p90, 0)
    )
}

/// Renders the report.
pub fn render(c: &Computed) -> Result<String, ReportError> {
    let r = &c.report;
    let mut h = String::new();
    let w = |h: &mut String, s: &str| h.push_str(s);
    let hd = &r.header;
    let fb = &r.fire_behaviour;
    write!(
        h,
        "<!DOCTYPE html>\n<html lang=en><head><meta charset=utf-8>\
         <meta name=viewport content=\"width=device-width, initial-scale=1\">\
         <link rel=icon href=\"data:,\">\
         <title>{} — {} on {}</title><style>{CSS}{}</style></head><body><main>",
        esc(&hd.title),
        esc(&lat_lon_text(hd.lat, hd.lon)),
        esc(&hd.date),
        page_css(hd)
    )?;

    // Header.
    write!(
        h,
        "<header><h1>{} <span class=\"badge {}\">{} risk</span></h1>\
         <div><b>{}</b> · {} · forecast day <b>{}</b> · simulated period <b>{} h</b> after ignition (cut-off at hour {})</div>\
         <div class=meta>Issued {} · valid from {} for {} · run <code>{}</code> · FireCast {} · {}</div></header>",
        esc(&hd.title),
        r.risk.level.as_str(),
        r.risk.level.as_str(),
        esc(&lat_lon_text(hd.lat, hd.lon)),
        esc(&hd.grid_location),
        esc(&hd.date),
        fmt_num(hd.horizon_h, 0),
        fmt_num(hd.horizon_h, 0),
        esc(&hd.issued_at),
        esc(&hd.valid_from),
        esc(&hd.valid_until),
        esc(&hd.run_id),
        esc(&hd.firecast_version),
        landscape_words(c)
    )?;

    // The answer: the map and what a duty officer needs from it.
    let times: Vec<f64> = r.strategies[0].isochrone_acres.iter().map(|p| p[0]).collect();
    let free = c.free_fire();
    let engine_note = if c.spread.is_some() {
        "verified minimum-travel-time engine"
    } else {
        "FireCastRL's automaton"
    };
    w(&mut h, "<section class=answer id=answer><div>");
    let window = map_window(c);
    let scale = figures::raster_scale(window[2]);
    let cropped = |img: &firecast_render::RgbImage| {
        figures::png_bytes(&figures::crop(img, scale, c.landscape.height, window))
    };
    let base_png = cropped(&figures::faded_basemap(&c.landscape, scale))?;
    let mut map = crate::maps::MapFrame::new(
        &c.landscape,
        window,
        &base_png,
        "Map: where the unsuppressed fire goes and when",
    );
    map.arrival_bands(
        &free.arrival_median_h,
        &times,
        fb.head_direction_deg,
        free.ignition,
    );
    let runs = free.runs() as u32;
    map.perimeter(
        |i| free.burn_count[i] * 10 >= runs && free.burn_count[i] > 0,
        "#222",
        1.6,
        true,
        "reached in at least 1 run in 10",
    );
    map.perimeter(
        |i| free.arrival_median_h[i].is_some(),
        FINAL_PERIMETER,
        3.0,
        false,
        "final perimeter: burnt in at least half of the runs",
    );
    map.assets(&asset_points(c, true), true);
    map.ignition(free.ignition);
    map.head_arrow(
        free.ignition,
        fb.head_direction_deg,
        &format!(
            "head → {}, {} mi/h",
            compass(fb.head_direction_deg),
            mph(fb.rate_of_spread.field)
        ),
    );
    write!(
        h,
        "<figure class=keep>{}<figcaption>Where the fire goes without suppression and when ({}, {} runs): colours are \
         the hours after ignition by which half of the runs had burned a cell; the thick line is the final perimeter at hour \
         {} (burnt in at least half of the runs), the dashed line what 1 run in 10 reached. {}</figcaption></figure>{}\
         <div class=legend><span><i class=sw style=\"border-color:{FINAL_PERIMETER}\"></i>final perimeter (half of the runs)</span>\
         <span><i class=swd style=\"border-color:#222\"></i>1 run in 10</span><span>★ ignition</span><span>■ assets</span>\
         <span>→ head of the fire</span></div>{}",
        map.finish(),
        engine_note,
        free.runs(),
        fmt_num(hd.horizon_h, 0),
        esc(&extent(&c.landscape, window)),
        crate::maps::bands_legend(&times, "Fire arrives (hours after ignition)"),
        crate::maps::land_cover_legend(
            &c.landscape,
            c.landscape_label()
                .and_then(|l| l.fuel_cells.as_ref())
                .map_or(0, |f| f.fuel_nodata),
        )
    )?;
    w(&mut h, "</div><div class=facts>");
    write!(
        h,
        "<h3>Where it goes and how fast</h3><p>The head runs toward <b>{} ({:.0}°)</b> at <b>{} ch/h ({} mi/h, {} class)</b> \
         with <b>{} ft flames</b> ({} class). {}</p>",
        esc(&fb.head_direction),
        fb.head_direction_deg,
        fmt_num(
            fb.rate_of_spread.field,
            if fb.rate_of_spread.field < 10.0 { 1 } else { 0 }
        ),
        mph(fb.rate_of_spread.field),
        esc(&class_word(fb.rate_of_spread.class.as_deref())),
        fmt_num(fb.flame_length.field, 1),
        esc(&class_word(fb.flame_length.class.as_deref())),
        esc(&fb.tactic)
    )?;
    let (median_acres, p10, p90) = match &r.free_spread {
        Some(f) => (f.fire.burned_acres_median, f.burned_acres_p10, f.burned_acres_p90),
        None => {
            let b = &r.strategies[c.baseline];
            (b.burned_acres_median, b.burned_acres_p10, b.burned_acres_p90)
        }
    };
    write!(
        h,
        "<h3>How big by hour {}</h3><p>Without suppression {}.{}</p>",
        fmt_num(hd.horizon_h, 0),
        outcome(median_acres, p10, p90),
        match &r.free_spread {
            Some(f) => edge_sentence(f, hd),
            None => String::new(),
        }
    )?;
    // Assets, most urgent first.
    w(&mut h, "<h3>Assets</h3>");
    let at_risk: Vec<&Asset> = r.assets.iter().filter(|a| watched(a)).collect();
    if r.assets.is_empty() {
        w(
            &mut h,
            "<p>No assets: none were listed and the landscape has no developed land.</p>",
        );
    } else if at_risk.is_empty() {
        write!(
            h,
            "<p>No asset in a band: fire reaches none of the {} watched within {} h of ignition{} (section 6).</p>",
            r.assets.len(),
            fmt_num(r.evacuation_bands.ready_within_h.min(r.header.horizon_h), 0),
            if r.header.horizon_h < r.evacuation_bands.ready_within_h {
                format!(
                    ", the period simulated (the READY band would reach out to {} h)",
                    fmt_num(r.evacuation_bands.ready_within_h, 0)
                )
            } else {
                String::new()
            }
        )?;
    } else {
        let mut tb = Table::new(&["Asset", "Band", "Fire first arrives", "In half the runs by"]);
        for a in at_risk.iter().take(6) {
            tb.row(&[
                t(esc(&a.name)),
                t(format!(
                    "<span class=\"band {}\">{}</span>",
                    a.band.as_str(),
                    a.band.as_str()
                )),
                n(a.first_arrival_h
                    .map_or("not reached".into(), |v| format!("hour {}", fmt_num(v, 1)))),
                n(a.half_runs_by_h
                    .map_or("—".into(), |v| format!("hour {}", fmt_num(v, 1)))),
            ]);
        }
        h.push_str(&tb.finish());
        if at_risk.len() > 6 {
            write!(
                h,
                "<p class=muted>{} assets in a band in all; every asset in section 6.</p>",
                at_risk.len()
            )?;
        }
    }
    // What suppression saves.
    write!(
        h,
        "<h3>What suppression saves by hour {}</h3><ul>",
        fmt_num(hd.horizon_h, 0)
    )?;
    for cmp in &r.comparisons {
        let label = crate::compute::strategy_label(&cmp.strategy);
        let meaningful = cmp.acres_saved.low > 0.0;
        write!(
            h,
            "<li>{}: {} acres in the median run (8 runs in 10: {} to {}); burns less in {:.0} % of runs.{}</li>",
            esc(&label),
            if meaningful {
                format!("<b>saves {}</b>", fmt_num(cmp.acres_saved_median, 0))
            } else {
                format!("saves {}", fmt_num(cmp.acres_saved_median, 0))
            },
            fmt_num(cmp.acres_saved_p10, 0),
            fmt_num(cmp.acres_saved_p90, 0),
            cmp.runs_better_pct,
            if !meaningful {
                " <b>No reliable saving</b> (the interval of the mean includes 0).".to_string()
            } else if cmp.reduction_pct < 1.0 {
                format!(
                    " Negligible: {:.2} % of the unsuppressed fire's area.",
                    cmp.reduction_pct
                )
            } else {
                String::new()
            }
        )?;
    }
    w(&mut h, "</ul>");
    let f = &r.forecast;
    let alert = if f.ignition_expected {
        "<b>alert</b> (above it)"
    } else {
        "no alert (below it)"
    };
    let chance = match (f.daily_probability, f.usual_daily_probability) {
        (Some(d), Some(u)) => format!(
            "Chance of an ignition in this cell on the day: <b>{}</b>, <b>{}</b> the usual day ({}){}. The model's \
             score, {:.0} % on its training samples' scale (about 40 % fires, not a daily chance), against its \
             alert threshold {:.0} %: {alert}.",
            daily_pct(d),
            times_usual(d / u),
            daily_pct(u),
            f.daily_interval
                .filter(|i| i[1] - i[0] > 1e-12)
                .map_or_else(String::new, |i| format!(
                    "; {}–{} over {} model seeds",
                    daily_pct(i[0]),
                    daily_pct(i[1]),
                    f.seeds
                )),
            f.probability * 100.0,
            f.threshold * 100.0,
        ),
        _ => format!(
            "Model score <b>{:.0} %</b> on its training samples' scale (about 40 % fires): not a daily chance (no \
             daily probability: {}); against its alert threshold {:.0} %: {alert}.",
            f.probability * 100.0,
            esc(unavailable(f)),
            f.threshold * 100.0,
        ),
    };
    write!(
        h,
        "<h3>Will a fire start?</h3><p>{chance}</p>{}<p class=muted>Risk {}: {}</p></div></section>",
        extrapolation_warning(f).unwrap_or_default(),
        r.risk.level.as_str(),
        esc(&r.risk.rule)
    )?;

    // Forecast.
    let daily_rows = match (f.daily_probability, f.usual_daily_probability) {
        (Some(d), Some(u)) => format!(
            "<tr><th>Chance of an ignition that day</th><td class=n><b>{}</b>{}</td><td class=muted>{}</td></tr>\
             <tr><th>The usual day</th><td class=n>{}</td><td class=muted>the day's chance is {} this</td></tr>",
            daily_pct(d),
            f.daily_interval.map_or_else(String::new, |i| format!(
                " <span class=ci>[{}, {}]</span>",
                daily_pct(i[0]),
                daily_pct(i[1])
            )),
            esc(f.daily_method.as_deref().unwrap_or("")),
            daily_pct(u),
            times_usual(d / u)
        ),
        _ => format!(
            "<tr><th>Chance of an ignition that day</th><td class=n>—</td><td class=muted>{}</td></tr>",
            esc(unavailable(f))
        ),
    };
    write!(
        h,
        "<h2>1. Ignition forecast</h2><table>{daily_rows}<tr><th>Model score</th><td class=n>{:.1} % \
         <span class=ci>[{:.1}, {:.1}]</span></td><td class=muted>on the training samples' scale (about 40 % fires), \
         not a daily chance; {}</td></tr>\
         <tr><th>Alert threshold</th><td class=n>{:.1} %</td><td class=muted>on the score, chosen on validation data; {}</td></tr>\
         <tr><th>Model</th><td colspan=2>{} ({}) under the <i>{}</i> protocol, inputs from day {} to {} relative to the date</td></tr>\
         <tr><th>Validation skill</th><td colspan=2>AUROC {} · AUPRC {} · test AUROC {}</td></tr>\
         <tr><th>Trained on</th><td colspan=2>{} <code>{}</code>{}</td></tr></table>{}",
        f.probability * 100.0,
        f.interval[0] * 100.0,
        f.interval[1] * 100.0,
        esc(&f.interval_method),
        f.threshold * 100.0,
        if f.ignition_expected {
            "the score is above it: alert"
        } else {
            "the score is below it: no alert"
        },
        esc(&f.model),
        esc(&f.kind),
        esc(&f.protocol),
        f.input_days[0],
        f.input_days[1],
        opt(f.validation_auroc, 3, ""),
        opt(f.validation_auprc, 3, ""),
        opt(f.test_auroc, 3, ""),
        esc(&f.dataset),
        esc(&f.dataset_version),
        f.training_area
            .as_ref()
            .map_or_else(String::new, |a| format!(": {}", esc(&training_area_text(a)))),
        extrapolation_warning(f).unwrap_or_default()
    )?;

    if let Some(p) = &f.pattern {
        h.push_str(&ignition_pattern_figure(p, hd.lat, hd.lon));
    }

    // Weather and fire behaviour.
    let wx = &r.weather;
    let fb = &r.fire_behaviour;
    write!(
        h,
        "<h2>2. Weather of the day and fire behaviour at the point</h2><div class=grid2><table>\
         <tr><th colspan=2>Weather, {} ({} at {})</th></tr>\
         <tr><td>Temperature max / min</td><td class=n>{} / {} ({} / {})</td></tr>\
         <tr><td>Relative humidity min / max</td><td class=n>{} / {}</td></tr>\
         <tr><td>Wind at 10 m</td><td class=n>{} mi/h ({} m/s) from {} ({:.0}°)</td></tr>\
         <tr><td>Precipitation</td><td class=n>{} ({})</td></tr>\
         <tr><td>ERC / burning index</td><td class=n>{} / {}</td></tr>\
         <tr><td>100-h / 1000-h fuel moisture</td><td class=n>{} / {}</td></tr></table>",
        esc(&wx.date),
        esc(&wx.source),
        esc(&lat_lon_text(wx.cell_lat, wx.cell_lon)),
        opt(wx.max_temp_f, 0, "°F"),
        opt(wx.min_temp_f, 0, "°F"),
        opt(wx.max_temp_c, 1, "°C"),
        opt(wx.min_temp_c, 1, "°C"),
        opt(wx.min_rh_pct, 0, "%"),
        opt(wx.max_rh_pct, 0, "%"),
        fmt_num(wx.wind_10m_mph, 1),
        fmt_num(wx.wind_10m_m_s, 1),
        esc(&wx.wind_from),
        wx.wind_from_deg,
        opt(wx.precip_in, 2, "in"),
        opt(wx.precip_mm, 1, "mm"),
        opt(wx.erc, 0, ""),
        opt(wx.burning_index, 0, ""),
        opt(wx.fm100_pct, 1, "%"),
        opt(wx.fm1000_pct, 1, "%")
    )?;
    let q = |q: &Quantity, d: usize| {
        format!(
            "<td class=n>{} {}</td><td class=n>{} {}</td><td>{}</td>",
            fmt_num(q.field, d),
            esc(&q.field_unit),
            fmt_num(q.si, d),
            esc(&q.si_unit),
            esc(q.class.as_deref().unwrap_or(""))
        )
    };
    write!(
        h,
        "<table><tr><th colspan=4>Head fire: {} {} on {:.0} % slope facing {}</th></tr>\
         <tr><th></th><th>field</th><th>SI</th><th>NWCG class</th></tr>\
         <tr><td>Rate of spread</td>{}</tr><tr><td>Flame length</td>{}</tr>\
         <tr><td>Fireline intensity</td>{}</tr><tr><td>Heat per unit area</td>{}</tr>\
         <tr><td>Head runs toward</td><td colspan=3>{} ({:.0}°), length-to-width {:.1}</td></tr>\
         <tr><td>Midflame wind</td><td colspan=3>{} mi/h (adjustment factor {:.2})</td></tr>\
         <tr><td>Moistures</td><td colspan=3>dead 1/10/100-h {:.0}/{:.0}/{:.0} %, live herb {:.0} %, woody {:.0} %</td></tr>\
         </table></div>\
         <div class=box><b>Tactic:</b> {}</div>",
        esc(&fb.fuel_model),
        esc(&fb.fuel_model_name),
        fb.slope_pct,
        compass(fb.aspect_deg),
        q(&fb.rate_of_spread, 1),
        q(&fb.flame_length, 1),
        q(&fb.fireline_intensity, 0),
        q(&fb.heat_per_unit_area, 0),
        esc(&fb.head_direction),
        fb.head_direction_deg,
        fb.length_to_width,
        fmt_num(fb.midflame_wind_mph, 1),
        fb.wind_adjustment_factor,
        fb.dead_1h_pct,
        fb.dead_10h_pct,
        fb.dead_100h_pct,
        fb.live_herb_pct,
        fb.live_woody_pct,
        esc(&fb.tactic)
    )?;
    let haul = figures::png_bytes(&figures::haul_chart(fb))?;
    write!(
        h,
        "<figure><img alt=\"Fire characteristics chart\" src=\"{}\"><figcaption>Fire characteristics (haul) chart: \
         the day's head fire against the flame-length limits of hand crews (4 ft), engines and dozers (8 ft) and any \
         direct attack (11 ft).</figcaption></figure>",
        figures::data_uri(&haul)
    )?;
    w(&mut h, "<h3>Contingency thresholds</h3>");
    let mut tb = Table::new(&["Limit", "Wind at 10 m that passes it", "Today", "What it means"]);
    for ct in &r.contingencies {
        tb.row(&[
            t(format!("{} ft — {}", ct.flame_length_ft, esc(&ct.resource))),
            n(ct.wind_10m_mph.map_or_else(
                || format!("not below {:.0} mi/h", ct.searched_to_mph),
                |v| format!("{} mi/h", fmt_num(v, 1)),
            )),
            t(if ct.exceeded_today {
                "<b>exceeded</b>"
            } else {
                "within"
            }
            .to_string()),
            t(esc(&ct.statement)),
        ]);
    }
    h.push_str(&tb.finish());

    // The strategies' fires side by side, and the agent's drops.
    let agent_label = c
        .agent
        .map(|a| crate::compute::strategy_label(&c.ensembles[a].strategy))
        .unwrap_or_default();
    write!(
        h,
        "<h2>3. The fire under each strategy{}</h2><p class=muted>Each map shows one strategy's runs: colours are the \
         hours by which half of them had burned a cell, the line the final perimeter (half of the runs). The drops are \
         the {}'s representative run, as the path the aircraft flew between them.</p><div class=grid2>",
        if c.spread.is_some() {
            ", on FireCastRL's automaton"
        } else {
            ""
        },
        esc(&crate::compute::strategy_label(&r.drops.strategy))
    )?;
    let mut shown: Vec<usize> = vec![c.baseline];
    shown.extend(c.agent.filter(|&a| a != c.baseline));
    for &k in &shown {
        let e = &c.ensembles[k];
        let label = crate::compute::strategy_label(&e.strategy);
        let mut m = crate::maps::MapFrame::new(
            &c.landscape,
            window,
            &base_png,
            &format!("Map: the fire under {label}"),
        );
        m.arrival_bands(&e.arrival_median_h, &times, fb.head_direction_deg, e.ignition);
        m.perimeter(
            |i| e.arrival_median_h[i].is_some(),
            &hex(strategy_color(&e.strategy)),
            3.0,
            false,
            "final perimeter: burnt in at least half of the runs",
        );
        if e.strategy == r.drops.strategy {
            m.drop_path(&r.drops.drops);
        }
        m.assets(&asset_points(c, false), false);
        m.ignition(e.ignition);
        write!(
            h,
            "<figure class=keep>{}<figcaption><i class=sw style=\"border-color:{}\"></i><b>{}</b>: median {} acres by hour {}{}</figcaption></figure>",
            m.finish(),
            hex(strategy_color(&e.strategy)),
            esc(&label),
            fmt_num(r.strategies[k].burned_acres_median, 0),
            fmt_num(hd.horizon_h, 0),
            if e.strategy == r.drops.strategy && !r.drops.drops.is_empty() {
                " · <span style=\"color:#0d47a1\">—●—</span> drops in order, numbered"
            } else {
                ""
            }
        )?;
    }
    w(&mut h, "</div>");
    h.push_str(&crate::maps::bands_legend(
        &times,
        "Fire arrives (hours after ignition)",
    ));
    let d = &r.drops;
    if d.drops.is_empty() {
        w(
            &mut h,
            "<p class=muted>No drops: no suppression strategy was simulated, or it made none.</p>",
        );
    } else {
        write!(
            h,
            "<h3>Drops: {}, representative run</h3><p class=muted>The run with the median burnt area \
             (seed {}, {} acres); {} drops{}; repeated drops on one spot share a row.{}</p>",
            esc(&crate::compute::strategy_label(&d.strategy)),
            d.run_seed.map_or("—".into(), |s| s.to_string()),
            opt(d.run_burned_acres, 0, ""),
            d.drops.len(),
            if d.drops.len() > DROPS_LISTED {
                format!(", the first {DROPS_LISTED} listed (all are in the JSON and GeoJSON)")
            } else {
                String::new()
            },
            match c.agent {
                Some(a) if c.ensembles[a].strategy != d.strategy => format!(
                    " The {} made no drops in its representative run; these are the {}'s.",
                    esc(&agent_label),
                    esc(&crate::compute::strategy_label(&d.strategy))
                ),
                _ => String::new(),
            }
        )?;
        let mut tb = Table::new(&["#", "hour", "latitude", "longitude", "burning acres put out"]);
        let listed = &d.drops[..d.drops.len().min(DROPS_LISTED)];
        let mut i = 0;
        while i < listed.len() {
            let first = &listed[i];
            let mut j = i;
            while j + 1 < listed.len() && (listed[j + 1].x, listed[j + 1].y) == (first.x, first.y) {
                j += 1;
            }
            let last = &listed[j];
            let quenched: u32 = listed[i..=j].iter().map(|d| d.quenched_cells).sum();
            let (numbers, hours) = if i == j {
                (first.number.to_string(), fmt_num(first.hour, 1))
            } else {
                (
                    format!("{}–{}", first.number, last.number),
                    format!("{}–{}", fmt_num(first.hour, 1), fmt_num(last.hour, 1)),
                )
            };
            tb.row(&[
                t(numbers),
                n(hours),
                n(format!("{:.5}", first.lat)),
                n(format!("{:.5}", first.lon)),
                n(fmt_num(
                    f64::from(quenched) * crate::units::cell_acres(hd.cell_size_ft),
                    1,
                )),
            ]);
            i = j + 1;
        }
        h.push_str(&tb.finish());
    }

    // Burn probability.
    let swatches = crate::maps::probability_swatches(&[0.1, 0.3, 0.5, 0.7, 0.9, 1.0]);
    write!(
        h,
        "<h2>4. Burn probability across the runs</h2><p><b>This is a probability map, not a progression map:</b> \
         the colour is the share of simulated runs in which the cell burned by hour {}, not when it burned.</p>",
        fmt_num(hd.horizon_h, 0)
    )?;
    let prob_map = |e: &firecast_episodes::ensemble::Ensemble, what: &str| -> Result<String, ReportError> {
        let mut m = crate::maps::MapFrame::new(
            &c.landscape,
            window,
            &cropped(&figures::burn_probability(&c.landscape, e, scale))?,
            &format!("Burn probability: {what}"),
        );
        m.assets(&asset_points(c, false), false);
        m.ignition(e.ignition);
        Ok(format!(
            "<figure class=keep>{}<figcaption>{}, {} runs</figcaption></figure>",
            m.finish(),
            esc(what),
            e.runs()
        ))
    };
    if let Some(sp) = &c.spread {
        write!(
            h,
            "{}<p class=muted>Below: the same runs on FireCastRL's automaton, where the strategies are compared (its head \
             advances at most 2.5 cells a step, so its fires are smaller).</p>",
            prob_map(sp, "Free fire, verified minimum-travel-time engine")?
        )?;
    }
    let agent_ens = c.agent.map_or(&c.ensembles[c.baseline], |a| &c.ensembles[a]);
    write!(
        h,
        "<div class=grid2>{}{}</div><div class=legend><b>Share of runs that burned the cell:</b> {swatches}\
         <span>★ ignition</span><span>■ assets</span></div>",
        prob_map(&c.ensembles[c.baseline], "No suppression (automaton)")?,
        prob_map(agent_ens, &crate::compute::strategy_label(&agent_ens.strategy))?
    )?;

    // Strategies.
    let chart = figures::png_bytes(&figures::burnt_area_chart(
        &r.strategies,
        r.free_spread.as_ref().map(|f| &f.fire),
    ))?;
    write!(
        h,
        "<h2>5. Strategies compared (Table IV){}</h2><figure class=keep><img alt=\"Burnt area over time\" src=\"{}\"></figure>\
         <p class=muted>Burnt area by hour {}: the median run and the range of 8 runs in 10 (10th–90th percentile) describe \
         the outcomes; the mean's 95 % bootstrap interval says how well the {} runs pin down the average, not how \
         large a single fire can be. <i>Out by the end</i>: the share of runs with no cell still burning at hour {} (a \
         suppressed fire still burning then counts as not out, however small).</p>",
        if c.spread.is_some() {
            ", on FireCastRL's automaton"
        } else {
            ""
        },
        figures::data_uri(&chart),
        fmt_num(hd.horizon_h, 0),
        r.strategies.first().map_or(0, |s| s.runs),
        fmt_num(hd.horizon_h, 0)
    )?;
    let mut tb = Table::new(&[
        "Strategy",
        "runs",
        "burnt acres, median",
        "8 runs in 10",
        "mean [95 % interval of the mean]",
        "hectares, median",
        "share of burnable land",
        "out by the end",
        "hours to out (median)",
        "drops",
        "water, gal",
    ]);
    for s in &r.strategies {
        tb.row(&[
            t(format!(
                "<i class=sw style=\"border-color:{}\"></i>{}",
                hex(strategy_color(&s.strategy)),
                esc(&s.label)
            )),
            n(s.runs.to_string()),
            n(format!("<b>{}</b>", fmt_num(s.burned_acres_median, 0))),
            n(format!(
                "{}–{}",
                fmt_num(s.burned_acres_p10, 0),
                fmt_num(s.burned_acres_p90, 0)
            )),
            n(est(&s.burned_acres, 0)),
            n(fmt_num(s.burned_acres_median * crate::units::HA_PER_ACRE, 0)),
            n(format!("{:.1} %", s.burned_fraction_pct)),
            n(format!("{:.0} %", s.contained_pct)),
            n(opt(s.containment_hours_median, 1, "h")),
            n(fmt_num(s.helitacks_mean, 1)),
            n(fmt_num(s.water_gal_mean, 0)),
        ]);
    }
    h.push_str(&tb.finish());
    let mut tb = Table::new(&[
        "Against no suppression",
        "paired runs",
        "acres saved, median",
        "8 runs in 10",
        "mean saved [95 % interval]",
        "reduction of the mean",
        "runs with less burnt",
    ]);
    for cmp in &r.comparisons {
        tb.row(&[
            t(esc(&crate::compute::strategy_label(&cmp.strategy))),
            n(cmp.paired_runs.to_string()),
            n(format!("<b>{}</b>", fmt_num(cmp.acres_saved_median, 0))),
            n(format!(
                "{} to {}",
                fmt_num(cmp.acres_saved_p10, 0),
                fmt_num(cmp.acres_saved_p90, 0)
            )),
            n(est(&cmp.acres_saved, 0)),
            n(format!("{:.1} %", cmp.reduction_pct)),
            n(format!("{:.0} %", cmp.runs_better_pct)),
        ]);
    }
    h.push_str(&tb.finish());

    // Evacuation.
    let b = &r.evacuation_bands;
    write!(
        h,
        "<h2>6. Evacuation advisories (Ready, Set, Go)</h2><p class=muted>Fire arrival within {} ft of each asset, \
         hours after ignition: the earliest over every run ({}), and the hour by which half of the runs had arrived. \
         GO: earliest arrival within {} h of ignition; SET: within {} h; READY: within {} h. Trigger = the hour after \
         ignition at which to move to the next band.</p>",
        fmt_num(b.buffer_ft, 0),
        engine_note,
        fmt_num(b.go_within_h, 0),
        fmt_num(b.set_within_h, 0),
        fmt_num(b.ready_within_h, 0)
    )?;
    let mut tb = Table::new(&[
        "Band",
        "Asset",
        "where",
        "area, acres",
        "earliest arrival",
        "half the runs by",
        "trigger",
        "advice",
    ]);
    if r.assets.is_empty() {
        tb.wide("No assets: none were listed and the landscape has no developed land.");
    }
    for a in r.assets.iter().filter(|a| watched(a)) {
        tb.row(&[
            t(format!(
                "<span class=\"band {}\">{}</span>",
                a.band.as_str(),
                a.band.as_str()
            )),
            t(esc(&a.name)),
            n(format!("{:.5}, {:.5}", a.lat, a.lon)),
            n(fmt_num(a.area_acres, 0)),
            n(opt(a.first_arrival_h, 1, "h")),
            n(opt(a.half_runs_by_h, 1, "h")),
            n(opt(a.trigger_h, 1, "h")),
            t(esc(&a.advice)),
        ]);
    }
    let unlisted = r.assets.iter().filter(|a| !watched(a)).count();
    if unlisted > 0 {
        tb.wide(&format!(
            "{unlisted} more developed areas, none in a band: fire reaches them late or not at all (every one is in \
             <code>report.json</code> and <code>report.geojson</code>)."
        ));
    }
    h.push_str(&tb.finish());

    // Priority zones.
    write!(
        h,
        "<h2>7. Suppression priority zones</h2><p class=muted>Squares of {} × {} ft ({} acres) where the {} kept the most \
         land from burning: burn probability without suppression minus with it, summed over the square.</p>",
        fmt_num(
            r.priority_zones
                .first()
                .map_or(0.0, |z| (z.cells[2] - z.cells[0]) as f64 * hd.cell_size_ft),
            0
        ),
        fmt_num(
            r.priority_zones
                .first()
                .map_or(0.0, |z| (z.cells[3] - z.cells[1]) as f64 * hd.cell_size_ft),
            0
        ),
        fmt_num(
            r.priority_zones.first().map_or(0.0, |z| {
                ((z.cells[2] - z.cells[0]) * (z.cells[3] - z.cells[1])) as f64
                    * crate::units::cell_acres(hd.cell_size_ft)
            }),
            0
        ),
        esc(&agent_label)
    )?;
    if r.priority_zones.is_empty() {
        w(
            &mut h,
            "<p>No zone: suppression did not lower the burn probability anywhere.</p>",
        );
    } else {
        let mut tb = Table::new(&[
            "rank",
            "centre",
            "acres kept from burning",
            "drops per run",
            "burn probability: none → agent",
        ]);
        for z in &r.priority_zones {
            tb.row(&[
                n(z.rank.to_string()),
                n(format!("{:.5}, {:.5}", z.lat, z.lon)),
                n(fmt_num(z.acres_protected, 0)),
                n(fmt_num(z.drops_per_run, 1)),
                n(format!(
                    "{:.0} % → {:.0} %",
                    z.burn_probability_unsuppressed_pct, z.burn_probability_agent_pct
                )),
            ]);
        }
        h.push_str(&tb.finish());
    }

    // Risk, inputs, lineage.
    write!(
        h,
        "<h2>8. Risk level</h2><p><span class=\"badge {}\">{}</span> — unsuppressed fires burn {:.1} % of the burnable \
         land on average; {} asset(s) in GO, {} in SET.</p><p class=muted>{}</p>",
        r.risk.level.as_str(),
        r.risk.level.as_str(),
        r.risk.burned_fraction_pct,
        r.risk.assets_go,
        r.risk.assets_set,
        esc(&r.risk.rule)
    )?;
    w(&mut h, "<h2>9. Inputs and assumptions</h2><ul>");
    for a in &r.assumptions {
        write!(h, "<li>{}</li>", esc(a))?;
    }
    w(&mut h, "</ul><h3>What would change this assessment</h3><ul>");
    for a in &r.what_would_change {
        write!(h, "<li>{}</li>", esc(a))?;
    }
    w(&mut h, "</ul><h3>Lineage</h3>");
    let mut tb = Table::new(&["role", "file", "detail"]);
    for l in &r.lineage {
        tb.row(&[
            t(esc(&l.role)),
            t(format!("<code>{}</code>", esc(&l.path))),
            t(esc(&l.detail)),
        ]);
    }
    h.push_str(&tb.finish());
    writeln!(
        h,
        "<p class=muted>Landscape: {} ({}). Every number in this report is in <code>report.json</code> \
         (schema {} v{}); perimeters, drops, assets and zones are in <code>report.geojson</code>. Simulated fires are \
         a planning aid, not a prediction of where a real fire will go.</p></main></body></html>",
        esc(&hd.landscape),
        esc(&hd.crs),
        esc(&r.schema),
        esc(&r.schema_version)
    )?;
    Ok(h)
}

/// The forecasted ignition pattern: one square per GRIDMET cell coloured by the day's
/// probability, the cells at or above the threshold outlined, the place starred.
/// Why a forecast has no daily probability.
fn unavailable(f: &Forecast) -> &str {
    f.daily_unavailable
        .as_deref()
        .unwrap_or(crate::compute::NO_DAILY_REASON)
}

/// A small daily probability (0–1) as a percent people can read: 0.036 %, 1.2 %.
fn daily_pct(p: f64) -> String {
    let pct = p * 100.0;
    if pct >= 10.0 {
        format!("{pct:.0} %")
    } else if pct >= 1.0 {
        format!("{pct:.1} %")
    } else {
        // Two significant digits.
        let digits = (1.0 - pct.max(1e-9).log10().floor()) as usize;
        format!("{pct:.digits$} %")
    }
}

/// A ratio to the usual day: "2.3×".
fn times_usual(r: f64) -> String {
    if r < 10.0 {
        format!("{r:.1}×")
    } else {
        format!("{r:.0}×")
    }
}

/// Where a ratio to the usual day lies on the colour scale: days at or below the usual day stay
/// pale (¼× at 0, 1× at 0.2), warmer colours only above it (2× at 0.47, 4× at 0.73, 8× at 1),
/// so an orange cell is one above the usual day; log scale on each side.
fn relative_position(r: f64) -> f64 {
    const USUAL_AT: f64 = 0.2;
    if r > 1.0 {
        (USUAL_AT + (1.0 - USUAL_AT) * r.log2() / 3.0).clamp(USUAL_AT, 1.0)
    } else if r > 0.0 {
        (USUAL_AT * (r.log2() + 2.0) / 2.0).clamp(0.0, USUAL_AT)
    } else {
        0.0
    }
}

fn ignition_pattern_figure(p: &IgnitionPattern, lat: f64, lon: f64) -> String {
    let threshold = p.threshold_pct / 100.0;
    let (rows, cols) = (p.lats.len(), p.lons.len());
    if rows == 0 || cols == 0 {
        return String::new();
    }
    let relative = p.relative_to_usual.as_ref().zip(p.usual_daily_pct);
    let cell = (460.0 / cols.max(rows) as f64).min(40.0);
    let (pw, ph) = (cols as f64 * cell, rows as f64 * cell);
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"-2 -2 {:.0} {:.0}\" width=\"{:.0}\" height=\"{:.0}\" \
         role=img aria-label=\"The day's chance of an ignition around the place\" font-family=\"DejaVu Sans, Arial, sans-serif\">",
        pw + 4.0,
        ph + 4.0,
        pw + 4.0,
        ph + 4.0
    );
    for (r, row) in p.probability_pct.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            let (x, y) = (c as f64 * cell, (rows - 1 - r) as f64 * cell);
            let rel = relative.and_then(|(m, _)| m.get(r)?.get(c).copied().flatten());
            let (fill, stroke, title) = match v {
                Some(v) => (
                    hex(figures::probability_color(match relative {
                        Some(_) => relative_position(rel.unwrap_or(0.0)),
                        None => v / 100.0,
                    })),
                    if *v >= threshold * 100.0 {
                        " stroke=\"#000\" stroke-width=\"1.5\""
                    } else {
                        " stroke=\"#fff\" stroke-width=\"0.5\""
                    },
                    match (rel, relative) {
                        (Some(q), Some((_, usual))) => {
                            format!(
                                "{} chance ({} the usual day), score {v:.0} %",
                                daily_pct(q * usual / 100.0),
                                times_usual(q)
                            )
                        }
                        _ => format!("score {v:.0} %"),
                    },
                ),
                None => (
                    "#e0e0e0".to_string(),
                    " stroke=\"#fff\" stroke-width=\"0.5\"",
                    "no weather window".to_string(),
                ),
            };
            let _ = write!(
                svg,
                "<rect x=\"{x:.1}\" y=\"{y:.1}\" width=\"{cell:.1}\" height=\"{cell:.1}\" fill=\"{fill}\"{stroke}><title>{:.4}° N, {:.4}° E: {title}</title></rect>",
                p.lats[r], p.lons[c],
            );
        }
    }
    // The place, between cell centres.
    let frac = |v: f64, axis: &[f64]| {
        let (a, b) = (axis[0], axis[axis.len() - 1]);
        if axis.len() < 2 || b == a {
            0.5
        } else {
            ((v - a) / (b - a) * (axis.len() - 1) as f64 + 0.5) / axis.len() as f64
        }
    };
    let (sx, sy) = (frac(lon, &p.lons) * pw, (1.0 - frac(lat, &p.lats)) * ph);
    svg.push_str(&crate::maps::star(sx, sy, 9.0, "the place"));
    svg.push_str("</svg>");
    let extent = format!(
        "the {} GRIDMET cells from {:.3}° to {:.3}° N and {:.3}° to {:.3}° E by the same model (north up; the star is \
         the place)",
        p.cells,
        p.lats[0],
        p.lats[rows - 1],
        p.lons[0],
        p.lons[cols - 1]
    );
    let alert = format!(
        "{} cells with a score at or above the {:.0} % alert threshold (outlined)",
        p.cells_above_threshold,
        threshold * 100.0
    );
    let (caption, swatches) = match relative {
        Some((m, usual_pct)) => {
            let highest = m.iter().flatten().flatten().copied().reduce(f64::max);
            (
                format!(
                    "The day's chance of an ignition at each of {extent}, relative to the usual day of the training area \
                     ({} a cell): highest {}; {alert}.",
                    daily_pct(usual_pct / 100.0),
                    highest.map_or("—".into(), times_usual)
                ),
                [0.25, 0.5, 1.0, 2.0, 4.0, 8.0]
                    .iter()
                    .map(|&q| {
                        format!(
                            "<span><i class=swf style=\"background:{}\"></i>{}{}</span>",
                            hex(figures::probability_color(relative_position(q))),
                            match q {
                                0.25 => "¼×".to_string(),
                                0.5 => "½×".to_string(),
                                _ => format!("{q:.0}×"),
                            },
                            if q == 1.0 { " usual" } else { "" }
                        )
                    })
                    .collect::<String>(),
            )
        }
        None => (
            format!(
                "The model's score at each of {extent}, on its training samples' scale (not a daily chance): {alert}, \
                 highest {}.",
                p.max_pct.map_or("—".into(), |m| format!("{m:.0} %"))
            ),
            crate::maps::probability_swatches(&[0.1, 0.3, 0.5, 0.7, 0.9]),
        ),
    };
    format!(
        "<h3>Forecasted ignition pattern</h3><figure class=keep style=\"max-width:480px\">{svg}<figcaption>{caption}\
         </figcaption></figure><div class=legend>{swatches}<span><i class=swf style=\"background:#e0e0e0\"></i>no weather \
         window</span></div>"
    )
}

/// A rate of spread in ch/h as mi/h, with the digits a slow fire needs.
fn mph(chains_per_hour: f64) -> String {
    let v = chains_per_hour * 66.0 / 5280.0;
    fmt_num(v, if v < 0.1 { 2 } else { 1 })
}

/// An asset the page lists by name: one in a band, or one the request named. Developed areas
/// no fire comes near are counted instead (a grown map has hundreds).
fn watched(a: &Asset) -> bool {
    a.band != Band::None || a.source == AssetSource::Listed
}

/// "Moderate class" words for a class (or nothing).
fn class_word(class: Option<&str>) -> String {
    class.map_or_else(String::new, |c| c.split(" (").next().unwrap_or(c).to_string())
}

/// What the free fire did at the map's edge, and how the map grew, in one or two sentences.
fn edge_sentence(f: &FreeSpread, hd: &Header) -> String {
    let mi = |cells: usize| cells as f64 * hd.cell_size_ft / 5280.0;
    let grown = match (f.grown_from_cells, f.grown_map_held) {
        (Some(from), Some(held)) => format!(
            " The map grew from {} × {} mi to {} × {} mi{}.",
            fmt_num(mi(from[0]), 0),
            fmt_num(mi(from[1]), 0),
            fmt_num(mi(f.grid_cells[0]), 0),
            fmt_num(mi(f.grid_cells[1]), 0),
            if held {
                " so that no run reached its edge"
            } else {
                ", its largest size"
            }
        ),
        _ => String::new(),
    };
    let edge = match f.edge_first_h_median {
        Some(t) if f.edge_runs_pct > 0.0 => format!(
            " <b>The fire left the {} × {} mi map in {:.0} % of runs</b> (median hour {}): those runs' areas are lower bounds.",
            fmt_num(mi(f.grid_cells[0]), 0),
            fmt_num(mi(f.grid_cells[1]), 0),
            f.edge_runs_pct,
            fmt_num(t, 0)
        ),
        _ => String::new(),
    };
    format!("{grown}{edge}")
}

/// Assets as (name, x, y) cell positions for the maps; only the GO and SET ones (and listed
/// ones) are named when `named`.
fn asset_points(c: &Computed, named: bool) -> Vec<(String, f64, f64)> {
    let land = &c.landscape;
    c.report
        .assets
        .iter()
        .zip(&c.asset_cells)
        .map(|(a, cells)| {
            let (x, y) = land
                .lat_lon_to_cell(a.lat, a.lon)
                .unwrap_or((cells[0] % land.width, cells[0] / land.width));
            let show = named && (matches!(a.band, Band::Go | Band::Set) || a.source == AssetSource::Listed);
            (
                if show { a.name.clone() } else { String::new() },
                x as f64,
                y as f64,
            )
        })
        .collect()
}

impl Computed {
    /// The label of the map the fires burned on (the verified engine's, which may have grown).
    fn landscape_label(&self) -> Option<&firecast_episodes::LandscapeLabel> {
        self.spread
            .as_ref()
            .and_then(|e| e.landscape.as_ref())
            .or_else(|| self.ensembles.first().and_then(|e| e.landscape.as_ref()))
    }
}

/// What the map is made of, for the header: made up, or which data.
fn landscape_words(c: &Computed) -> String {
    let cell_m = fmt_num(c.landscape.cell_size_ft * 0.3048, 0);
    match c.landscape_label() {
        Some(l) if l.synthetic => "<b>synthetic landscape</b>".into(),
        Some(l) if l.kind == "landfire" => format!("landscape: LANDFIRE fuels and terrain, {cell_m} m cells"),
        Some(l) if l.kind == "geotiff" => {
            format!("landscape: land cover and elevation rasters, {cell_m} m cells")
        }
        Some(l) if l.kind == "firecastrl" => "landscape: FireCastRL's map".into(),
        _ => "landscape from data".into(),
    }
}

/// Where and when a forecaster's training windows lie, in words.
fn training_area_text(a: &TrainingArea) -> String {
    let ns = |v: f64| format!("{:.2}° {}", v.abs(), if v >= 0.0 { "N" } else { "S" });
    let ew = |v: f64| format!("{:.2}° {}", v.abs(), if v >= 0.0 { "E" } else { "W" });
    format!(
        "places {} to {}, {} to {}, days {} to {}",
        ns(a.lat_min),
        ns(a.lat_max),
        ew(a.lon_min),
        ew(a.lon_max),
        a.first_date,
        a.last_date
    )
}

/// A warning when the place lies outside the area the forecaster learnt from.
fn extrapolation_warning(f: &Forecast) -> Option<String> {
    let a = f.training_area.as_ref().filter(|a| !a.place_inside)?;
    Some(format!(
        "<p class=warn><b>Outside the model's experience:</b> the forecaster was trained on {} and this place \
         lies outside that area, so the forecast is an extrapolation; weigh it below local knowledge.</p>",
        esc(&training_area_text(a))
    ))
}

/// The map's extent in words.
fn extent(land: &firecast_landscape::Landscape, window: [usize; 4]) -> String {
    let [x0, y0, w, h] = window;
    let mi = |cells: usize| cells as f64 * land.cell_size_ft / 5280.0;
    format!(
        "North is up; {:.1} × {:.1} mi{} in cells of {} ft ({} m; {}), corners {} (south-west) and {} (north-east).",
        mi(w),
        mi(h),
        if [w, h] == [land.width, land.height] {
            String::new()
        } else {
            format!(
                " around the fire, of the {:.1} × {:.1} mi simulated",
                mi(land.width),
                mi(land.height)
            )
        },
        fmt_num(land.cell_size_ft, 0),
        fmt_num(land.cell_size_ft * 0.3048, 0),
        land.georef.crs,
        corner(land, x0 as i64, y0 as i64),
        corner(land, (x0 + w) as i64, (y0 + h) as i64)
    )
}

/// The part of the grid the maps show, [x0, y0, width, height] in cells: the whole grid,
/// unless the map grew to hold the free fire — then the fire's cells (any run of any
/// ensemble) and the ignition with a margin, at least the landscape's size as given and in
/// its proportions.
fn map_window(c: &Computed) -> [usize; 4] {
    let land = &c.landscape;
    let (gw, gh) = (land.width, land.height);
    let Some(base) = c.report.free_spread.as_ref().and_then(|f| f.grown_from_cells) else {
        return [0, 0, gw, gh];
    };
    let [ix, iy] = c.free_fire().ignition;
    let (mut x0, mut y0, mut x1, mut y1) = (ix, iy, ix + 1, iy + 1);
    for e in c.ensembles.iter().chain(c.spread.as_ref()) {
        for (i, &n) in e.burn_count.iter().enumerate() {
            if n > 0 {
                let (x, y) = (i % gw, i / gw);
                x0 = x0.min(x);
                y0 = y0.min(y);
                x1 = x1.max(x + 1);
                y1 = y1.max(y + 1);
            }
        }
    }
    // A margin of a tenth of the fire's size each side, then the base size's proportions.
    let (fw, fh) = (x1 - x0, y1 - y0);
    let mut w = (fw + fw / 5 + 4).max(base[0]);
    let mut h = (fh + fh / 5 + 4).max(base[1]);
    let aspect = base[0] as f64 / base[1] as f64;
    if (w as f64) < h as f64 * aspect {
        w = (h as f64 * aspect).ceil() as usize;
    } else {
        h = (w as f64 / aspect).ceil() as usize;
    }
    let (w, h) = (w.min(gw), h.min(gh));
    let cx = (x0 + x1) / 2;
    let cy = (y0 + y1) / 2;
    let left = cx.saturating_sub(w / 2).min(gw - w);
    let bottom = cy.saturating_sub(h / 2).min(gh - h);
    [left, bottom, w, h]
}

fn corner(land: &firecast_landscape::Landscape, x: i64, y: i64) -> String {
    geometry::vertex_lon_lat(land, &land.crs(), x, y)
        .map_or_else(|| "?".into(), |[lon, lat]| lat_lon_text(lat, lon))
}
