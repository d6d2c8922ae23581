//! The verification as a picture (docs/results/spread-verification.png): for GR2 in a
//! 15 mi/h and a 4 mi/h midflame wind heading 22.5° from east, 60 m cells, one map per wind
//! (north up, east to the right, equal scales) with the kernel's ellipses after 1, 2 and 4 h
//! (thin black, the ignition at the rear focus), the MTT engine's fronts at the same times
//! (the polygons the table reads, so their ratios are the table's), the automaton's burnt
//! cells by then (nested light fills), the ignition, the wind and a scale bar.

use std::f64::consts::PI;
use std::path::Path;

use firecast_render::{
    Align, Chart, LegendPosition, Marker, PlotArea, RenderError, RgbImage, Series, draw_text,
    draw_text_aligned, write_png,
};

use crate::verify::{
    self, Case, Engine, Exact, Row, TIMES_H, VerifyOptions, arrival_field, front_polygon, landscape, rows_of,
};

const WIDTH: usize = 1400;
const HEIGHT: usize = 700;
const TEXT: usize = 2;
const ELLIPSE: [u8; 3] = [0, 0, 0];
const MTT: [u8; 3] = [86, 180, 233];
const AUTOMATON: [u8; 3] = [213, 94, 0];
const WIND: [u8; 3] = [90, 90, 90];
const INK: [u8; 3] = [20, 20, 20];

/// The cases drawn: GR2, 15 and 4 mi/h at 22.5°, 60 m cells.
pub fn picture_cases() -> Vec<Case> {
    vec![
        Case::new(102, 15.0, 22.5, 0.0, 60.0),
        Case::new(102, 4.0, 22.5, 0.0, 60.0),
    ]
}

/// The exact ellipse at `t_h` hours as (east, north) km from the ignition: centre ahead of
/// the ignition by (head − back)/2·t, semi-axes (head + back)/2·t and the flanking rate·t.
fn ellipse_km(ex: &Exact, t_h: f64) -> Vec<(f64, f64)> {
    let t = t_h * 60.0 / 1000.0;
    let (a, b) = (0.5 * (ex.head_m_min + ex.back_m_min) * t, ex.semi_minor_m_min * t);
    let c = 0.5 * (ex.head_m_min - ex.back_m_min) * t;
    let (s, co) = ex.head_azimuth_deg.to_radians().sin_cos();
    (0..=360)
        .map(|k| {
            let th = f64::from(k) * PI / 180.0;
            let (u, v) = (c + a * th.cos(), b * th.sin());
            (u * s + v * co, u * co - v * s)
        })
        .collect()
}

/// The x and y ranges (km) around `pts` that fill the plot area of `chart` at equal scales.
fn equal_ranges(chart: &Chart, pts: &[(f64, f64)]) -> ((f64, f64), (f64, f64)) {
    let fold = |f: fn(&(f64, f64)) -> f64| {
        pts.iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |r, v| {
                (r.0.min(v), r.1.max(v))
            })
    };
    let (xr, yr) = (fold(|p| p.0), fold(|p| p.1));
    let (cx, cy) = (0.5 * (xr.0 + xr.1), 0.5 * (yr.0 + yr.1));
    let (mut w, mut h) = (1.3 * (xr.1 - xr.0), 1.3 * (yr.1 - yr.0));
    let mut ranges = ((cx - w / 2.0, cx + w / 2.0), (cy - h / 2.0, cy + h / 2.0));
    // The plot area depends a little on the tick labels, so twice.
    for _ in 0..2 {
        let (_, area) = chart
            .clone()
            .x_range(ranges.0.0, ranges.0.1)
            .y_range(ranges.1.0, ranges.1.1)
            .render_with_area();
        let (pw, ph) = ((area.right - area.left) as f64, (area.bottom - area.top) as f64);
        let km_per_px = (w / pw).max(h / ph);
        (w, h) = (km_per_px * pw, km_per_px * ph);
        ranges = ((cx - w / 2.0, cx + w / 2.0), (cy - h / 2.0, cy + h / 2.0));
    }
    ranges
}

/// A round scale-bar length near a fifth of `span_km`, and its label.
fn scale_bar(span_km: f64) -> (f64, String) {
    let want = span_km / 5.0;
    let len = [0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 2.5, 5.0, 10.0]
        .into_iter()
        .rev()
        .find(|&l| l <= want)
        .unwrap_or(0.1);
    let label = if len < 1.0 {
        format!("{} m", (len * 1000.0).round())
    } else {
        format!("{len} km")
    };
    (len, label)
}

/// One engine's 4-hour row.
fn at_4h(rows: &[Row]) -> &Row {
    rows.iter().find(|r| r.time_h == 4.0).expect("a 4-hour row")
}

/// One case's map.
fn panel(case: &Case, opts: &VerifyOptions) -> RgbImage {
    let ex = verify::exact(case);
    let (land, ign) = landscape(case, &ex);
    let mtt = arrival_field(Engine::Mtt, case, &land, ign, opts);
    let aut = arrival_field(Engine::Automaton, case, &land, ign, opts);
    let (mtt_rows, aut_rows) = (
        rows_of(case, Engine::Mtt, &mtt, &land, ign),
        rows_of(case, Engine::Automaton, &aut, &land, ign),
    );
    let km = case.cell_m / 1000.0;
    let cell_km = |i: usize| {
        let (x, y) = (i % land.width, i / land.width);
        ((x as f64 - ign.0 as f64) * km, (y as f64 - ign.1 as f64) * km)
    };

    let title = format!(
        "{}, midflame wind {} mi/h heading {}° from east, {} m cells",
        "GR2", case.wind_mph, case.wind_angle_deg, case.cell_m
    );
    let base = Chart::new(WIDTH, HEIGHT)
        .title(title)
        .x_label("km east of the ignition")
        .y_label("km north of the ignition")
        .text_scale(TEXT)
        .legend(Some(LegendPosition::TopLeft));
    let outer = ellipse_km(&ex, 4.0);
    let mut extent = outer.clone();
    extent.push((0.0, 0.0));
    // Room above the fire for the legend.
    let (lo, hi) = outer
        .iter()
        .fold((0.0f64, 0.0f64), |r, p| (r.0.min(p.1), r.1.max(p.1)));
    extent.push((0.0, hi + 0.35 * (hi - lo)));
    let ((x0, x1), (y0, y1)) = equal_ranges(&base, &extent);
    let mut chart = base.x_range(x0, x1).y_range(y0, y1);

    // Automaton: nested fills, the latest first (the earlier lie on top, darker).
    for (k, &t) in TIMES_H.iter().enumerate().rev() {
        let burnt = (0..aut.len()).filter(|&i| aut[i] <= t).map(cell_km);
        let s = Series::cells(burnt, km).color(AUTOMATON).alpha(0.2);
        chart.push(if k == 2 {
            s.label("automaton: cells burnt by 1, 2, 4 h (darker = earlier)")
        } else {
            s
        });
    }
    for (k, &t) in TIMES_H.iter().enumerate() {
        let mut front: Vec<(f64, f64)> = front_polygon(&mtt, &land, ign, ex.head_azimuth_deg, case.cell_m, t)
            .into_iter()
            .map(|(x, y)| (x / 1000.0, y / 1000.0))
            .collect();
        front.push(front[0]);
        let s = Series::line(front).color(MTT).width(6.0);
        chart.push(if k == 0 {
            s.label("MTT engine: front at 1, 2, 4 h")
        } else {
            s
        });
    }
    for (k, &t) in TIMES_H.iter().enumerate() {
        let s = Series::line(ellipse_km(&ex, t)).color(ELLIPSE).width(1.5);
        chart.push(if k == 0 {
            s.label("Rothermel ellipse (exact) at 1, 2, 4 h")
        } else {
            s
        });
    }
    chart.push(
        Series::scatter([(0.0, 0.0)])
            .marker(Marker::Cross, 13.0)
            .color(INK)
            .label("ignition (rear focus)"),
    );

    // Wind arrow and scale bar in the lower right corner.
    let (w, h) = (x1 - x0, y1 - y0);
    let (len, label) = scale_bar(w);
    let (sx1, sy) = (x1 - 0.04 * w, y0 + 0.07 * h);
    let sx0 = sx1 - len;
    let tick = 0.012 * h;
    for seg in [
        ((sx0, sy), (sx1, sy)),
        ((sx0, sy - tick), (sx0, sy + tick)),
        ((sx1, sy - tick), (sx1, sy + tick)),
    ] {
        chart.push(Series::segment(seg.0, seg.1).dashed(false).width(2.0).color(INK));
    }
    let arrow = 0.07 * w;
    let (dx, dy) = (
        case.wind_angle_deg.to_radians().cos(),
        case.wind_angle_deg.to_radians().sin(),
    );
    let tip = (x1 - 0.06 * w, y0 + 0.30 * h);
    let tail = (tip.0 - arrow * dx, tip.1 - arrow * dy);
    chart.push(
        Series::segment(tail, tip)
            .dashed(false)
            .width(3.0)
            .color(WIND)
            .label(format!("wind, {} mi/h midflame", case.wind_mph)),
    );
    for side in [-1.0, 1.0] {
        let a = (case.wind_angle_deg + 180.0 + side * 28.0).to_radians();
        let barb = (tip.0 + 0.3 * arrow * a.cos(), tip.1 + 0.3 * arrow * a.sin());
        chart.push(Series::segment(tip, barb).dashed(false).width(3.0).color(WIND));
    }

    let (mut img, area) = chart.render_with_area();
    let px = |area: &PlotArea, p: (f64, f64)| {
        let (x, y) = area.to_px(p.0, p.1);
        (x.round() as i64, y.round() as i64)
    };
    let (wx, wy) = px(&area, tail);
    draw_text_aligned(&mut img, wx - 8, wy - 7, "wind", TEXT, WIND, Align::Right);
    let (lx, ly) = px(&area, (0.5 * (sx0 + sx1), sy));
    draw_text_aligned(&mut img, lx, ly - 22, &label, TEXT, INK, Align::Center);
    // Each ellipse's time beside its head.
    let (s, c) = ex.head_azimuth_deg.to_radians().sin_cos();
    for t in TIMES_H {
        let d = ex.head_m_min * t * 60.0 / 1000.0 + 0.015 * w;
        let (hx, hy) = px(&area, (d * s, d * c));
        draw_text(&mut img, hx, hy - 7, &format!("{t} h"), TEXT, INK);
    }
    let (m, a) = (at_4h(&mtt_rows), at_4h(&aut_rows));
    let ratios = |r: &Row| r.ratios.unwrap_or([f64::NAN; 5]);
    let line = format!(
        "At 4 h, measured / exact: MTT head {:.2}, area {:.2}; automaton head {:.2}, area {:.2} (burnt cells {:.2})",
        ratios(m)[0],
        ratios(m)[4],
        ratios(a)[0],
        ratios(a)[4],
        a.measured.cells_area_ha / a.exact_area_ha
    );
    let mut out = RgbImage::new(WIDTH, HEIGHT + 30);
    out.data.fill(255);
    out.data[..img.data.len()].copy_from_slice(&img.data);
    draw_text_aligned(
        &mut out,
        (WIDTH / 2) as i64,
        HEIGHT as i64,
        &line,
        TEXT,
        INK,
        Align::Center,
    );
    out
}

/// The picture: one map per case, stacked.
pub fn picture(cases: &[Case], opts: &VerifyOptions) -> RgbImage {
    let panels: Vec<RgbImage> = cases.iter().map(|c| panel(c, opts)).collect();
    let height = panels.iter().map(|p| p.height).sum();
    let mut out = RgbImage::new(WIDTH, height);
    let mut at = 0;
    for p in panels {
        out.data[at..at + p.data.len()].copy_from_slice(&p.data);
        at += p.data.len();
    }
    out
}

/// Writes [`picture`] of [`picture_cases`] as a PNG at `path` (atomically).
pub fn write_picture(path: &Path, opts: &VerifyOptions) -> Result<(), RenderError> {
    write_png(&picture(&picture_cases(), opts), path)
}
