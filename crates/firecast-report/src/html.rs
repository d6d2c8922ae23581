//! The report as one self-contained HTML file: no scripts, no external references (images are
//! data URIs, the map is inline SVG), readable on a phone and printable (the PDF is this page
//! printed by Chromium).

use std::fmt::Write;

use crate::ReportError;
use crate::compute::Computed;
use crate::figures::{self, MAP_SCALE, hex, strategy_color};
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
main{max-width:960px;margin:0 auto;padding:12px}
h1{font-size:1.5em;margin:.2em 0}
h2{font-size:1.15em;border-bottom:2px solid var(--ink);margin:1.2em 0 .4em;padding-bottom:2px}
h3{font-size:1em;margin:.8em 0 .3em}
table{border-collapse:collapse;width:100%;margin:.3em 0;font-size:.92em}
th,td{border-bottom:1px solid var(--line);padding:3px 6px;text-align:left;vertical-align:top}
th{background:#f2f2f2}
td.n{text-align:right;white-space:nowrap}
.ci{color:var(--muted);font-size:.9em}
.muted{color:var(--muted);font-size:.9em}
.badge{display:inline-block;padding:2px 10px;border-radius:4px;font-weight:bold;color:#fff}
.LOW{background:#2e7d32}.MODERATE{background:#f9a825;color:#111}.HIGH{background:#ef6c00}.SEVERE{background:#b71c1c}
.GO{background:#b71c1c;color:#fff}.SET{background:#ef6c00;color:#fff}.READY{background:#f9a825}.NONE{background:#e0e0e0}
.band{font-weight:bold;padding:1px 6px;border-radius:3px;white-space:nowrap}
.box{border:2px solid var(--ink);padding:8px 12px;margin:.6em 0;border-radius:4px}
.box ul{margin:.2em 0;padding-left:1.2em}
.grid2{display:grid;grid-template-columns:1fr 1fr;gap:12px}
img,svg{max-width:100%;height:auto;display:block}
figure{margin:.5em 0}
figcaption{font-size:.85em;color:var(--muted)}
.legend span{display:inline-block;margin-right:12px;font-size:.85em;white-space:nowrap}
.sw{display:inline-block;width:22px;height:0;border-top:3px solid;vertical-align:middle;margin-right:4px}
.swf{display:inline-block;width:14px;height:14px;vertical-align:middle;margin-right:4px}
header .meta{font-size:.85em;color:var(--muted)}
@media (max-width:640px){.grid2{grid-template-columns:1fr}body{font-size:14px}table{font-size:.85em}}
@media print{main{max-width:none;padding:0}h2,h3{break-after:avoid}tr{break-inside:avoid}figure,.box,.keep{break-inside:avoid}.pb{break-before:page}}
@page{size:Letter;margin:12mm}
"#;

/// Renders the report.
pub fn render(c: &Computed) -> Result<String, ReportError> {
    let r = &c.report;
    let mut h = String::new();
    let w = |h: &mut String, s: &str| h.push_str(s);
    let hd = &r.header;
    write!(
        h,
        "<!DOCTYPE html>\n<html lang=en><head><meta charset=utf-8>\
         <meta name=viewport content=\"width=device-width, initial-scale=1\">\
         <link rel=icon href=\"data:,\">\
         <title>{} — {} on {}</title><style>{CSS}</style></head><body><main>",
        esc(&hd.title),
        esc(&lat_lon_text(hd.lat, hd.lon)),
        esc(&hd.date)
    )?;

    // Header.
    write!(
        h,
        "<header><h1>{}</h1>\
         <div><b>{}</b> · {} · forecast day <b>{}</b> · risk <span class=\"badge {}\">{}</span></div>\
         <div class=meta>Issued {} · valid from {} for {} · run <code>{}</code> · FireCast {}</div>\
         <div class=meta>Forecaster: {} · Agent: {}</div></header>",
        esc(&hd.title),
        esc(&lat_lon_text(hd.lat, hd.lon)),
        esc(&hd.grid_location),
        esc(&hd.date),
        r.risk.level.as_str(),
        r.risk.level.as_str(),
        esc(&hd.issued_at),
        esc(&hd.valid_from),
        esc(&hd.valid_until),
        esc(&hd.run_id),
        esc(&hd.firecast_version),
        esc(&hd.forecaster),
        esc(&hd.agent)
    )?;

    // Bottom line.
    let base = &r.strategies[c.baseline];
    let day = |s: &StrategySummary, hours: f64| {
        let k = s
            .series_hours
            .iter()
            .position(|&x| x >= hours)
            .unwrap_or(s.series_hours.len() - 1);
        s.series_acres_mean[k]
    };
    w(
        &mut h,
        "<section class=box><h2 style=\"margin-top:0\">Bottom line</h2><ul>",
    );
    let spread = if r.forecast.interval[1] - r.forecast.interval[0] > 1e-9 {
        format!(
            "range over {} model seeds {:.0}–{:.0} %",
            r.forecast.seeds,
            r.forecast.interval[0] * 100.0,
            r.forecast.interval[1] * 100.0
        )
    } else {
        "no interval: the trained models agree".to_string()
    };
    write!(
        h,
        "<li>Ignition probability <b>{:.0} %</b> ({spread}; threshold {:.0} %): {}.</li>",
        r.forecast.probability * 100.0,
        r.forecast.threshold * 100.0,
        if r.forecast.ignition_expected {
            "<b>a fire is expected</b>"
        } else {
            "below the alert threshold"
        }
    )?;
    write!(
        h,
        "<li>Head fire at the point: <b>{} ft flames</b>, {} ch/h ({} class) — {}</li>",
        fmt_num(r.fire_behaviour.flame_length.field, 1),
        fmt_num(r.fire_behaviour.rate_of_spread.field, 1),
        esc(r.fire_behaviour.flame_length.class.as_deref().unwrap_or("")),
        esc(&r.fire_behaviour.tactic)
    )?;
    match &r.free_spread {
        Some(f) => write!(
            h,
            "<li>Unsuppressed, the fire burns <b>{} acres</b> (median of {} runs; 10–90 % of runs {}–{}; mean {}, 95 % \
             interval {}–{}); {} acres after 24 h — spread by the verified minimum-travel-time engine. On the \
             automaton the strategies are compared on, the free fire burns {} acres.{}</li>",
            fmt_num(f.fire.burned_acres_median, 0),
            f.fire.runs,
            fmt_num(f.burned_acres_p10, 0),
            fmt_num(f.burned_acres_p90, 0),
            fmt_num(f.fire.burned_acres.value, 0),
            fmt_num(f.fire.burned_acres.low, 0),
            fmt_num(f.fire.burned_acres.high, 0),
            fmt_num(day(&f.fire, 24.0), 0),
            fmt_num(f.automaton_burned_acres, 0),
            match f.edge_first_h_median {
                Some(t) if f.edge_runs_pct > 0.0 => format!(
                    " The fire reached the map's edge in <b>{:.0} % of runs</b> (median hour {}): the burnt area is a lower \
                     bound.",
                    f.edge_runs_pct,
                    fmt_num(t, 0)
                ),
                _ => String::new(),
            }
        )?,
        None => write!(
            h,
            "<li>Unsuppressed, the fire burns <b>{} acres</b> on average (95 % interval {}–{}); {} acres after 24 h.</li>",
            fmt_num(base.burned_acres.value, 0),
            fmt_num(base.burned_acres.low, 0),
            fmt_num(base.burned_acres.high, 0),
            fmt_num(day(base, 24.0), 0)
        )?,
    }
    for cmp in &r.comparisons {
        let label = crate::compute::strategy_label(&cmp.strategy);
        write!(
            h,
            "<li>{}: saves <b>{} acres</b> [{}, {}] ({:.0} %) against no suppression; burns less in {:.0} % of runs.</li>",
            esc(&label),
            fmt_num(cmp.acres_saved.value, 0),
            fmt_num(cmp.acres_saved.low, 0),
            fmt_num(cmp.acres_saved.high, 0),
            cmp.reduction_pct,
            cmp.runs_better_pct
        )?;
    }
    let go: Vec<&Asset> = r.assets.iter().filter(|a| a.band == Band::Go).collect();
    let set: Vec<&Asset> = r.assets.iter().filter(|a| a.band == Band::Set).collect();
    write!(
        h,
        "<li>Evacuation: <b>{}</b> asset(s) in GO, <b>{}</b> in SET{}.</li>",
        go.len(),
        set.len(),
        go.first().map_or(String::new(), |a| format!(
            " (first: {}, fire within {} h)",
            esc(&a.name),
            opt(a.first_arrival_h, 1, "")
        ))
    )?;
    w(&mut h, "</ul></section>");

    // Forecast.
    let f = &r.forecast;
    write!(
        h,
        "<h2>1. Ignition forecast</h2><table><tr><th>Ignition probability</th><td class=n><b>{:.1} %</b> \
         <span class=ci>[{:.1}, {:.1}]</span></td><td class=muted>{}</td></tr>\
         <tr><th>Decision threshold</th><td class=n>{:.1} %</td><td class=muted>chosen on validation data; {}</td></tr>\
         <tr><th>Model</th><td colspan=2>{} ({}) under the <i>{}</i> protocol, inputs from day {} to {} relative to the date</td></tr>\
         <tr><th>Validation skill</th><td colspan=2>AUROC {} · AUPRC {} · test AUROC {}</td></tr>\
         <tr><th>Trained on</th><td colspan=2>{} <code>{}</code></td></tr></table>",
        f.probability * 100.0,
        f.interval[0] * 100.0,
        f.interval[1] * 100.0,
        esc(&f.interval_method),
        f.threshold * 100.0,
        if f.ignition_expected {
            "the probability is above it"
        } else {
            "the probability is below it"
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
        esc(&f.dataset_version)
    )?;

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
    w(
        &mut h,
        "<h3>Contingency thresholds</h3><table><tr><th>Limit</th><th>Wind at 10 m that passes it</th><th>Today</th><th></th></tr>",
    );
    for ct in &r.contingencies {
        write!(
            h,
            "<tr><td>{} ft — {}</td><td class=n>{}</td><td>{}</td><td>{}</td></tr>",
            ct.flame_length_ft,
            esc(&ct.resource),
            ct.wind_10m_mph.map_or_else(
                || format!("not below {:.0} mi/h", ct.searched_to_mph),
                |v| format!("{} mi/h", fmt_num(v, 1))
            ),
            if ct.exceeded_today {
                "<b>exceeded</b>"
            } else {
                "within"
            },
            esc(&ct.statement)
        )?;
    }
    w(&mut h, "</table>");

    // Map.
    w(
        &mut h,
        if c.spread.is_some() {
            "<h2 class=pb>3. Map: where the free fire goes and when, and the agent's drops</h2>"
        } else {
            "<h2 class=pb>3. Map: fire arrival and the agent's drops</h2>"
        },
    );
    h.push_str(&map_svg(c)?);
    let agent_label = c
        .agent
        .map(|a| crate::compute::strategy_label(&c.ensembles[a].strategy))
        .unwrap_or_default();
    if c.spread.is_some() {
        write!(
            h,
            "<div class=legend><span><i class=sw style=\"border-color:{}\"></i>free fire, minimum-travel-time engine</span>\
             <span>isochrones: {} h after ignition (thicker = later), median arrival over runs</span>\
             <span><i class=sw style=\"border-color:{}\"></i>final perimeter: burnt in at least half of the runs</span>\
             <span>● numbered drops ({}, on the automaton: section 5)</span><span>■ assets</span><span>★ ignition</span></div>",
            hex(strategy_color("none")),
            r.header_isochrones(),
            FINAL_PERIMETER,
            esc(&crate::compute::strategy_label(&r.drops.strategy))
        )?;
    } else {
        write!(
            h,
            "<div class=legend><span><i class=sw style=\"border-color:{}\"></i>no suppression</span>{}\
         <span>isochrones: {} h after ignition (thicker = later), median arrival over runs</span>\
         <span>● numbered drops ({})</span><span>■ assets</span><span>★ ignition</span></div>",
            hex(strategy_color("none")),
            c.agent.map_or(String::new(), |a| format!(
                "<span><i class=sw style=\"border-color:{}\"></i>{}</span>",
                hex(strategy_color(&c.ensembles[a].strategy)),
                esc(&agent_label)
            )),
            r.header_isochrones(),
            esc(&crate::compute::strategy_label(&r.drops.strategy))
        )?;
    }
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
             (seed {}, {} acres); {} drops{}.{}</p><table><tr><th>#</th><th>hour</th><th>latitude</th><th>longitude</th><th>burning acres put out</th></tr>",
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
        // Consecutive drops on one spot share a row.
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
            write!(
                h,
                "<tr><td>{numbers}</td><td class=n>{hours}</td><td class=n>{:.5}</td><td class=n>{:.5}</td><td class=n>{}</td></tr>",
                first.lat,
                first.lon,
                fmt_num(f64::from(quenched) * crate::units::cell_acres(hd.cell_size_ft), 1)
            )?;
            i = j + 1;
        }
        w(&mut h, "</table>");
    }

    // Burn probability.
    let agent_ens = c.agent.map_or(&c.ensembles[c.baseline], |a| &c.ensembles[a]);
    let bp = figures::png_bytes(&figures::burn_probability(&c.landscape, &c.ensembles[c.baseline]))?;
    let bp_free = match &c.spread {
        Some(sp) => Some(figures::png_bytes(&figures::burn_probability(&c.landscape, sp))?),
        None => None,
    };
    let bp_agent = figures::png_bytes(&figures::burn_probability(&c.landscape, agent_ens))?;
    let swatches: String = [0.1, 0.3, 0.5, 0.7, 0.9, 1.0]
        .iter()
        .map(|&p| {
            format!(
                "<span><i class=swf style=\"background:{}\"></i>{:.0} %</span>",
                hex(figures::probability_color(p)),
                p * 100.0
            )
        })
        .collect();
    write!(
        h,
        "<h2>4. Burn probability across the runs</h2><p><b>This is a probability map, not a progression map:</b> \
         the colour is the share of simulated runs in which the cell burned, not when it burned.</p>"
    )?;
    if let (Some(png), Some(sp)) = (&bp_free, &c.spread) {
        write!(
            h,
            "<div class=keep><figure><img alt=\"Burn probability of the free fire, minimum-travel-time engine\" src=\"{}\">\
             <figcaption>Free fire, verified minimum-travel-time engine, {} runs</figcaption></figure></div>\
             <p class=muted>Below: the same runs on FireCastRL's automaton, where the strategies are compared (its head \
             advances at most 2.5 cells a step, so its fires are smaller).</p>",
            figures::data_uri(png),
            sp.runs()
        )?;
    }
    write!(
        h,
        "<div class=keep><div class=grid2><figure><img alt=\"Burn probability without suppression\" src=\"{}\"><figcaption>No suppression, {} runs</figcaption></figure>\
         <figure><img alt=\"Burn probability with the agent\" src=\"{}\"><figcaption>{}, {} runs</figcaption></figure></div>\
         <div class=legend>{swatches}</div></div>",
        figures::data_uri(&bp),
        c.ensembles[c.baseline].runs(),
        figures::data_uri(&bp_agent),
        esc(&crate::compute::strategy_label(&agent_ens.strategy)),
        agent_ens.runs()
    )?;

    // Strategies.
    let chart = figures::png_bytes(&figures::burnt_area_chart(&r.strategies))?;
    write!(
        h,
        "<h2 class=pb>5. Strategies compared (Table IV){}</h2><figure><img alt=\"Burnt area over time\" src=\"{}\"></figure>\
         <table><tr><th>Strategy</th><th>runs</th><th>burnt acres, mean [95 %]</th><th>hectares</th><th>median acres</th>\
         <th>share of burnable land</th><th>fire out</th><th>hours to out (median)</th><th>peak spread at (median)</th><th>drops</th><th>water, gal</th></tr>",
        if c.spread.is_some() {
            ", on FireCastRL's automaton"
        } else {
            ""
        },
        figures::data_uri(&chart)
    )?;
    for s in &r.strategies {
        write!(
            h,
            "<tr><td><i class=sw style=\"border-color:{}\"></i>{}</td><td class=n>{}</td><td class=n>{}</td><td class=n>{}</td>\
             <td class=n>{}</td><td class=n>{:.1} %</td><td class=n>{:.0} %</td><td class=n>{}</td><td class=n>{} h</td><td class=n>{}</td><td class=n>{}</td></tr>",
            hex(strategy_color(&s.strategy)),
            esc(&s.label),
            s.runs,
            est(&s.burned_acres, 0),
            est(&s.burned_hectares, 0),
            fmt_num(s.burned_acres_median, 0),
            s.burned_fraction_pct,
            s.contained_pct,
            opt(s.containment_hours_median, 1, "h"),
            fmt_num(s.peak_burning_hours_median, 1),
            fmt_num(s.helitacks_mean, 1),
            fmt_num(s.water_gal_mean, 0)
        )?;
    }
    w(
        &mut h,
        "</table><table><tr><th>Against no suppression</th><th>paired runs</th><th>acres saved [95 %]</th><th>reduction</th><th>runs with less burnt</th></tr>",
    );
    for cmp in &r.comparisons {
        write!(
            h,
            "<tr><td>{}</td><td class=n>{}</td><td class=n>{}</td><td class=n>{:.1} %</td><td class=n>{:.0} %</td></tr>",
            esc(&crate::compute::strategy_label(&cmp.strategy)),
            cmp.paired_runs,
            est(&cmp.acres_saved, 0),
            cmp.reduction_pct,
            cmp.runs_better_pct
        )?;
    }
    w(&mut h, "</table>");

    // Evacuation.
    let b = &r.evacuation_bands;
    write!(
        h,
        "<h2>6. Evacuation advisories (Ready, Set, Go)</h2><p class=muted>Earliest simulated fire arrival within {} ft \
         of each asset over every run of every strategy. GO: arrival within {} h of ignition; SET: within {} h; \
         READY: within {} h. Trigger = the hour after ignition at which to move to the next band.</p>\
         <table><tr><th>Band</th><th>Asset</th><th>where</th><th>area, acres</th><th>earliest arrival</th><th>trigger</th><th>advice</th></tr>",
        fmt_num(b.buffer_ft, 0),
        fmt_num(b.go_within_h, 0),
        fmt_num(b.set_within_h, 0),
        fmt_num(b.ready_within_h, 0)
    )?;
    if r.assets.is_empty() {
        w(
            &mut h,
            "<tr><td colspan=7>No assets: none were listed and the landscape has no developed land.</td></tr>",
        );
    }
    for a in &r.assets {
        write!(
            h,
            "<tr><td><span class=\"band {}\">{}</span></td><td>{}</td><td class=n>{:.5}, {:.5}</td><td class=n>{}</td>\
             <td class=n>{}</td><td class=n>{}</td><td>{}</td></tr>",
            a.band.as_str(),
            a.band.as_str(),
            esc(&a.name),
            a.lat,
            a.lon,
            fmt_num(a.area_acres, 0),
            opt(a.first_arrival_h, 1, "h"),
            opt(a.trigger_h, 1, "h"),
            esc(&a.advice)
        )?;
    }
    w(&mut h, "</table>");

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
        w(
            &mut h,
            "<table><tr><th>rank</th><th>centre</th><th>acres kept from burning</th><th>drops per run</th><th>burn probability: none → agent</th></tr>",
        );
        for z in &r.priority_zones {
            write!(
                h,
                "<tr><td>{}</td><td class=n>{:.5}, {:.5}</td><td class=n>{}</td><td class=n>{}</td><td class=n>{:.0} % → {:.0} %</td></tr>",
                z.rank,
                z.lat,
                z.lon,
                fmt_num(z.acres_protected, 0),
                fmt_num(z.drops_per_run, 1),
                z.burn_probability_unsuppressed_pct,
                z.burn_probability_agent_pct
            )?;
        }
        w(&mut h, "</table>");
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
    w(
        &mut h,
        "</ul><h3>Lineage</h3><table><tr><th>role</th><th>file</th><th>detail</th></tr>",
    );
    for l in &r.lineage {
        write!(
            h,
            "<tr><td>{}</td><td><code>{}</code></td><td>{}</td></tr>",
            esc(&l.role),
            esc(&l.path),
            esc(&l.detail)
        )?;
    }
    writeln!(
        h,
        "</table><p class=muted>Landscape: {} ({}). Every number in this report is in <code>report.json</code> \
         (schema {} v{}); perimeters, drops, assets and zones are in <code>report.geojson</code>. Simulated fires are \
         a planning aid, not a prediction of where a real fire will go.</p></main></body></html>",
        esc(&hd.landscape),
        esc(&hd.crs),
        esc(&r.schema),
        esc(&r.schema_version)
    )?;
    Ok(h)
}

impl ThreatReport {
    fn header_isochrones(&self) -> String {
        self.strategies
            .first()
            .map(|s| {
                s.isochrone_acres
                    .iter()
                    .map(|[t, _]| fmt_num(*t, 0))
                    .collect::<Vec<_>>()
                    .join(", ")
            })
            .unwrap_or_default()
    }
}

/// The map: basemap image, isochrones of the unsuppressed fire and of the agent, drops,
/// assets, ignition, north arrow and scale bar.
fn map_svg(c: &Computed) -> Result<String, ReportError> {
    let land = &c.landscape;
    let (gw, gh) = (land.width, land.height);
    let s = MAP_SCALE as f64;
    let (pw, ph) = (gw as f64 * s, gh as f64 * s);
    let base = figures::png_bytes(&figures::basemap(land))?;
    let mut svg = String::new();
    write!(
        svg,
        "<figure><svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {pw} {ph}\" width=\"{pw}\" height=\"{ph}\" \
         role=img aria-label=\"Map of fire arrival times and drops\" font-family=\"DejaVu Sans, Arial, sans-serif\">\
         <image href=\"{}\" x=\"0\" y=\"0\" width=\"{pw}\" height=\"{ph}\"/>",
        figures::data_uri(&base)
    )?;
    let times: Vec<f64> = c.report.strategies[0]
        .isochrone_acres
        .iter()
        .map(|p| p[0])
        .collect();
    // With the verified engine's free fire, the map shows it alone: the agent's isochrones
    // are on the automaton, whose capped head would read as suppression.
    let mut strategies: Vec<(&firecast_episodes::ensemble::Ensemble, bool)> = Vec::new();
    match &c.spread {
        Some(sp) => strategies.push((sp, true)),
        None => {
            strategies.push((&c.ensembles[c.baseline], true));
            strategies.extend(c.agent.map(|a| (&c.ensembles[a], false)));
        }
    }
    for &(e, free) in &strategies {
        let color = hex(strategy_color(&e.strategy));
        for (j, &t) in times.iter().enumerate() {
            let rings = geometry::rings(gw, gh, |i| {
                e.arrival_median_h[i].is_some_and(|a| f64::from(a) <= t)
            });
            if rings.is_empty() {
                continue;
            }
            write!(
                svg,
                "<path d=\"{}\" fill=\"none\" stroke=\"{color}\" stroke-width=\"{:.1}\" stroke-opacity=\"0.9\" fill-rule=\"evenodd\"{}><title>{} — {} h</title></path>",
                geometry::svg_path(&rings, gh, s),
                1.0 + j as f64 * 0.8,
                if free { " stroke-dasharray=\"6 3\"" } else { "" },
                esc(&crate::compute::strategy_label(&e.strategy)),
                fmt_num(t, 0)
            )?;
        }
    }
    // The verified free fire's final perimeter: the cells at least half of the runs burnt.
    if let Some(sp) = &c.spread {
        let rings = geometry::rings(gw, gh, |i| sp.arrival_median_h[i].is_some());
        if !rings.is_empty() {
            write!(
                svg,
                "<path d=\"{}\" fill=\"none\" stroke=\"{FINAL_PERIMETER}\" stroke-width=\"3.5\" fill-rule=\"evenodd\"><title>Free fire: final perimeter ({} h)</title></path>",
                geometry::svg_path(&rings, gh, s),
                fmt_num(c.report.header.horizon_h, 0)
            )?;
        }
    }
    // Assets.
    for (a, cells) in c.report.assets.iter().zip(&c.asset_cells) {
        let (x, y) = land
            .lat_lon_to_cell(a.lat, a.lon)
            .unwrap_or((cells[0] % gw, cells[0] / gw));
        let (px, py) = ((x as f64 + 0.5) * s, (gh as f64 - y as f64 - 0.5) * s);
        write!(
            svg,
            "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"9\" height=\"9\" fill=\"#222\" stroke=\"#fff\"/>\
             <text x=\"{:.1}\" y=\"{:.1}\" font-size=\"11\" fill=\"#000\" stroke=\"#fff\" stroke-width=\"3\" paint-order=\"stroke\">{}</text>",
            px - 4.5,
            py - 4.5,
            px + 7.0,
            py + 4.0,
            esc(&a.name)
        )?;
    }
    // Drops.
    for d in &c.report.drops.drops {
        let (px, py) = ((f64::from(d.x) + 0.5) * s, (gh as f64 - f64::from(d.y) - 0.5) * s);
        if d.number <= DROPS_LISTED {
            write!(
                svg,
                "<circle cx=\"{px:.1}\" cy=\"{py:.1}\" r=\"6\" fill=\"#1565c0\" stroke=\"#fff\"/>\
                 <text x=\"{px:.1}\" y=\"{:.1}\" font-size=\"8\" text-anchor=\"middle\" fill=\"#fff\">{}</text>",
                py + 3.0,
                d.number
            )?;
        } else {
            write!(
                svg,
                "<circle cx=\"{px:.1}\" cy=\"{py:.1}\" r=\"2\" fill=\"#1565c0\"/>"
            )?;
        }
    }
    // Ignition.
    let [ix, iy] = c.ensembles[0].ignition;
    let (px, py) = ((ix as f64 + 0.5) * s, (gh as f64 - iy as f64 - 0.5) * s);
    let star: String = (0..10)
        .map(|k| {
            let r = if k % 2 == 0 { 10.0 } else { 4.0 };
            let a = std::f64::consts::PI * f64::from(k) / 5.0 - std::f64::consts::FRAC_PI_2;
            format!("{:.1},{:.1} ", px + r * a.cos(), py + r * a.sin())
        })
        .collect();
    write!(
        svg,
        "<polygon points=\"{}\" fill=\"#ffeb3b\" stroke=\"#000\"/>",
        star.trim_end()
    )?;
    // North arrow and a one-mile scale bar.
    let mile_px = 5280.0 / land.cell_size_ft * s;
    write!(
        svg,
        "<g><polygon points=\"{0:.1},14 {1:.1},34 {0:.1},28 {2:.1},34\" fill=\"#000\"/>\
         <text x=\"{0:.1}\" y=\"46\" font-size=\"12\" text-anchor=\"middle\" stroke=\"#fff\" stroke-width=\"3\" paint-order=\"stroke\">N</text></g>\
         <g><rect x=\"10\" y=\"{3:.1}\" width=\"{4:.1}\" height=\"6\" fill=\"#000\" stroke=\"#fff\"/>\
         <text x=\"10\" y=\"{5:.1}\" font-size=\"11\" stroke=\"#fff\" stroke-width=\"3\" paint-order=\"stroke\">1 mile ({6} m)</text></g>",
        pw - 20.0,
        pw - 28.0,
        pw - 12.0,
        ph - 16.0,
        mile_px,
        ph - 20.0,
        1609
    )?;
    write!(
        svg,
        "</svg><figcaption>Land cover over hillshade; north is up. {:.1} × {:.1} mi at {} ft resolution in {}; corners \
         {} (south-west) to {} (north-east).</figcaption></figure>",
        gw as f64 * land.cell_size_ft / 5280.0,
        gh as f64 * land.cell_size_ft / 5280.0,
        land.cell_size_ft,
        esc(&land.georef.crs),
        esc(&corner(land, 0, 0)),
        esc(&corner(land, gw as i64, gh as i64))
    )?;
    Ok(svg)
}

fn corner(land: &firecast_landscape::Landscape, x: i64, y: i64) -> String {
    geometry::vertex_lon_lat(land, &land.crs(), x, y)
        .map_or_else(|| "?".into(), |[lon, lat]| lat_lon_text(lat, lon))
}
