//! Charts for model evaluation and fire reports, drawn into an [`RgbImage`] and written with
//! [`write_png`] (atomically).
//!
//! - [`Chart`]: x–y plots on linear axes: lines, post-steps, scatter markers, translucent
//!   bands (confidence intervals) and dashed reference lines, with a title, axis titles,
//!   "nice" 1-2-5 ticks, an optional grid and a legend of the labelled series.
//! - [`Heatmap`]: small matrices such as a confusion matrix, cells coloured by [`viridis`]
//!   with each value (and optionally a percentage) printed in a contrasting colour.
//! - [`BarChart`]: horizontal bars with error bars, one per label, in the order given (a
//!   forest-style plot of, say, AUROC with its 95 % interval per model).
//!
//! Series without an explicit colour take the [`OKABE_ITO`] colours in the order they were
//! added. Text comes from the embedded bitmap font in [`crate::font`]; rendering is
//! deterministic (same input, same bytes).

use std::path::Path;

use crate::font::{self, Align, CAP_HEIGHT, TextStyle};
use crate::{RenderError, RgbImage, write_png};

/// The Okabe & Ito (2008) colour-blind-safe qualitative palette, in the order handed to
/// series: blue, orange, bluish green, vermilion, reddish purple, sky blue, black and yellow
/// (last, because it is faint on white).
pub const OKABE_ITO: [[u8; 3]; 8] = [
    [0, 114, 178],
    [230, 159, 0],
    [0, 158, 115],
    [213, 94, 0],
    [204, 121, 167],
    [86, 180, 233],
    [0, 0, 0],
    [240, 228, 66],
];

const BACKGROUND: [u8; 3] = [255, 255, 255];
const INK: [u8; 3] = [25, 25, 25];
const AXIS: [u8; 3] = [70, 70, 70];
const GRID: [u8; 3] = [228, 228, 228];
const REFERENCE: [u8; 3] = [110, 110, 110];
const LEGEND_BORDER: [u8; 3] = [185, 185, 185];
const MISSING_CELL: [u8; 3] = [235, 235, 235];

/// Viridis sampled at 0, 1/8, …, 1 (matplotlib's table), interpolated linearly.
const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],
    [72, 40, 120],
    [62, 73, 137],
    [49, 104, 142],
    [38, 130, 142],
    [31, 158, 137],
    [53, 183, 121],
    [110, 206, 88],
    [253, 231, 37],
];

/// Viridis colour of `t` in [0, 1] (clamped; NaN gives the low end): dark purple to yellow,
/// perceptually uniform and readable in greyscale.
pub fn viridis(t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let pos = t * (VIRIDIS.len() - 1) as f64;
    let i = (pos.floor() as usize).min(VIRIDIS.len() - 2);
    let f = pos - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |k: usize| (f64::from(a[k]) + (f64::from(b[k]) - f64::from(a[k])) * f).round() as u8;
    [mix(0), mix(1), mix(2)]
}

/// Black or white, whichever reads better on `bg`.
fn contrasting(bg: [u8; 3]) -> [u8; 3] {
    let luma = 0.2126 * f64::from(bg[0]) + 0.7152 * f64::from(bg[1]) + 0.0722 * f64::from(bg[2]);
    if luma > 140.0 { [0, 0, 0] } else { [255, 255, 255] }
}

// ---------------------------------------------------------------------------------------
// Ticks
// ---------------------------------------------------------------------------------------

/// `k × m × 10^e`, computed so that e.g. 3 × 0.2 is exactly the double nearest 0.6.
fn tick_value(k: i64, m: i64, e: i32) -> f64 {
    let n = (k * m) as f64;
    if e >= 0 {
        n * 10f64.powi(e)
    } else {
        n / 10f64.powi(-e)
    }
}

/// Tick values between `min` and `max` (either order, ends included) at the smallest 1-2-5 step (×10ⁿ) that puts
/// at most `max_intervals` intervals between the first and the last tick: `(0, 1, 5)` gives
/// 0, 0.2, …, 1; `(0, 37, 5)` gives 0, 10, 20, 30; `(-0.05, 1.05, 5)` gives 0, 0.2, …, 1.
/// An empty or non-finite range gives no ticks, a single value gives just that value.
pub fn nice_ticks(min: f64, max: f64, max_intervals: usize) -> Vec<f64> {
    let (lo, hi) = if min <= max { (min, max) } else { (max, min) };
    if !lo.is_finite() || !hi.is_finite() {
        return Vec::new();
    }
    let span = hi - lo;
    if span <= 0.0 || !span.is_finite() {
        return vec![lo];
    }
    let n = max_intervals.max(1);
    // Start below the answer and walk up the 1-2-5 ladder; a handful of steps at most.
    let mut e = (span / (n + 2) as f64).log10().floor() as i32;
    let mut i = 0;
    loop {
        let m = [1, 2, 5][i];
        let step = tick_value(1, m, e);
        // Past ~2^53 the integer multiples are no longer exact; fall back to the ends.
        if lo.abs().max(hi.abs()) / step > 1e15 {
            return vec![lo, hi];
        }
        let k0 = (lo / step - 1e-9).ceil() as i64;
        let k1 = (hi / step + 1e-9).floor() as i64;
        if k1 - k0 <= n as i64 {
            return (k0..=k1).map(|k| tick_value(k, m, e)).collect();
        }
        i += 1;
        if i == 3 {
            i = 0;
            e += 1;
        }
    }
}

/// Labels for `ticks` with one shared number of decimals, enough to tell neighbours apart
/// ("0", "0.2", …, "1.0" becomes "0.0", "0.2", …, "1.0"); scientific notation ("2e-7")
/// beyond six decimals or from 10⁹ on. Never prints "-0".
pub fn format_ticks(ticks: &[f64]) -> Vec<String> {
    let step = ticks
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min);
    let biggest = ticks.iter().fold(0.0f64, |a, t| a.max(t.abs()));
    let step = if step.is_finite() {
        step
    } else if biggest > 0.0 {
        // A single tick: show it with three significant digits.
        biggest / 100.0
    } else {
        1.0
    };
    let decimals = (-step.log10() - 1e-9).ceil().max(0.0) as usize;
    let scientific = decimals > 6 || biggest >= 1e9;
    ticks
        .iter()
        .map(|&t| {
            let t = if t.abs() < step * 1e-6 { 0.0 } else { t };
            if scientific {
                format!("{t:e}")
            } else {
                format!("{t:.decimals$}")
            }
        })
        .collect()
}

/// Decimals shared by the values printed in heatmap cells: none when all are integers,
/// otherwise enough for three significant digits of the largest magnitude, less any
/// decimals that are zero in every value (0.91 and 0.05 print as "0.91", "0.05").
fn value_decimals(values: &[f64]) -> usize {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let biggest = finite.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if biggest == 0.0 {
        return 0;
    }
    let most = (2 - biggest.log10().floor() as i32).clamp(0, 6) as usize;
    (0..=most)
        .find(|&d| {
            let k = 10f64.powi(d as i32);
            finite
                .iter()
                .all(|v| ((v * k).round() - v * k).abs() < 1e-6 * (v * k).abs().max(1.0))
        })
        .unwrap_or(most)
}

// ---------------------------------------------------------------------------------------
// Coverage masks: anti-aliased shapes rasterised once, then blended once
// ---------------------------------------------------------------------------------------

/// Dash pattern state along a polyline: `on` pixels drawn, `off` skipped, `phase` = length
/// already travelled.
#[derive(Debug, Clone, Copy)]
struct Dash {
    on: f64,
    off: f64,
    phase: f64,
}

/// Per-pixel coverage in [0, 1] over a rectangle of the image. Shapes take the maximum
/// coverage, so the joints of a polyline are not blended twice.
struct Mask {
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
    cov: Vec<f32>,
}

impl Mask {
    /// A mask over `[x0, x1) × [y0, y1)`.
    fn new(x0: usize, y0: usize, x1: usize, y1: usize) -> Self {
        let (w, h) = (x1.saturating_sub(x0), y1.saturating_sub(y0));
        Self {
            x0,
            y0,
            w,
            h,
            cov: vec![0.0; w * h],
        }
    }

    /// Clamp a float pixel range to the mask's columns (`true`) or rows, as a half-open range.
    fn span(&self, lo: f64, hi: f64, cols: bool) -> (usize, usize) {
        let (origin, n) = if cols {
            (self.x0, self.w)
        } else {
            (self.y0, self.h)
        };
        let clamp = |v: f64| (v - origin as f64).clamp(0.0, n as f64) as usize;
        (clamp(lo.floor()), clamp(hi.ceil() + 1.0))
    }

    fn add(&mut self, x: usize, y: usize, c: f64) {
        let i = (y - self.y0) * self.w + (x - self.x0);
        let c = c.clamp(0.0, 1.0) as f32;
        if c > self.cov[i] {
            self.cov[i] = c;
        }
    }

    /// Any shape given by a signed distance (negative inside) over a bounding box.
    fn shape(&mut self, bbox: (f64, f64, f64, f64), sd: impl Fn(f64, f64) -> f64) {
        let (xa, xb) = self.span(bbox.0 - 1.0, bbox.2 + 1.0, true);
        let (ya, yb) = self.span(bbox.1 - 1.0, bbox.3 + 1.0, false);
        for y in ya..yb {
            let (py, yc) = (self.y0 + y, (self.y0 + y) as f64 + 0.5);
            for x in xa..xb {
                let px = self.x0 + x;
                let c = 0.5 - sd(px as f64 + 0.5, yc);
                if c > 0.0 {
                    self.add(px, py, c);
                }
            }
        }
    }

    /// A segment of half-width `hw` with round caps (butt ends inside a dash pattern).
    /// Only the pixels near the segment are visited, so long lines stay cheap.
    fn segment(&mut self, a: (f64, f64), b: (f64, f64), hw: f64, dash: Option<&mut Dash>) {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len2 = dx * dx + dy * dy;
        let len = len2.sqrt();
        if !len.is_finite() {
            return;
        }
        let dash_state = dash.map(|d| {
            let s = *d;
            d.phase += len;
            s
        });
        if len < 1e-9 {
            if dash_state.is_none() {
                self.shape((a.0 - hw, a.1 - hw, a.0 + hw, a.1 + hw), |x, y| {
                    ((x - a.0).powi(2) + (y - a.1).powi(2)).sqrt() - hw
                });
            }
            return;
        }
        let r = hw + 1.0;
        let (ya, yb) = self.span(a.1.min(b.1) - r, a.1.max(b.1) + r, false);
        for y in ya..yb {
            let py = self.y0 + y;
            let yc = py as f64 + 0.5;
            let ry = yc - a.1;
            // Columns whose centre lies within r of the infinite line, and whose projection
            // lies within r of the segment.
            let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
            if dy.abs() > 1e-12 {
                let p = a.0 + (dx * ry - r * len) / dy;
                let q = a.0 + (dx * ry + r * len) / dy;
                lo = lo.max(p.min(q));
                hi = hi.min(p.max(q));
            } else if (dx * ry).abs() > r * len {
                continue;
            }
            if dx.abs() > 1e-12 {
                let p = a.0 + (-r * len - dy * ry) / dx;
                let q = a.0 + (len2 + r * len - dy * ry) / dx;
                lo = lo.max(p.min(q));
                hi = hi.min(p.max(q));
            } else if dy * ry < -r * len || dy * ry > len2 + r * len {
                continue;
            }
            if lo > hi {
                continue;
            }
            let (xa, xb) = self.span(lo - 0.5, hi - 0.5, true);
            for x in xa..xb {
                let px = self.x0 + x;
                let xc = px as f64 + 0.5;
                let along = ((xc - a.0) * dx + ry * dy) / len;
                if let Some(d) = dash_state {
                    let pos = (d.phase + along.clamp(0.0, len)).rem_euclid(d.on + d.off);
                    if pos >= d.on || along < 0.0 || along > len {
                        continue;
                    }
                }
                let t = (along / len).clamp(0.0, 1.0);
                let dist = ((xc - a.0 - t * dx).powi(2) + (yc - a.1 - t * dy).powi(2)).sqrt();
                let c = hw + 0.5 - dist;
                if c > 0.0 {
                    self.add(px, py, c);
                }
            }
        }
    }

    /// A polyline through pixel points; non-finite points break it.
    fn polyline(&mut self, pts: &[(f64, f64)], hw: f64, dash: Option<(f64, f64)>) {
        let mut state = dash.map(|(on, off)| Dash { on, off, phase: 0.0 });
        let mut prev: Option<(f64, f64)> = None;
        let mut drew = false;
        for &p in pts {
            if !(p.0.is_finite() && p.1.is_finite()) {
                if let (Some(q), false) = (prev, drew) {
                    self.segment(q, q, hw, None);
                }
                prev = None;
                drew = false;
                continue;
            }
            if let Some(q) = prev {
                self.segment(q, p, hw, state.as_mut());
                drew = true;
            }
            prev = Some(p);
        }
        // A lone point still shows as a dot.
        if let (Some(q), false) = (prev, drew) {
            self.segment(q, q, hw, None);
        }
    }

    /// A marker of diameter `size` centred on `c`.
    fn marker(&mut self, marker: Marker, c: (f64, f64), size: f64) {
        let r = size / 2.0;
        // Diamonds and triangles are enlarged to about the area of the disc.
        let big = r * 1.4;
        let bbox = (c.0 - big, c.1 - big, c.0 + big, c.1 + big);
        match marker {
            Marker::Circle => self.shape(bbox, |x, y| ((x - c.0).powi(2) + (y - c.1).powi(2)).sqrt() - r),
            Marker::Square => {
                let h = r * 0.85;
                self.shape(bbox, |x, y| (x - c.0).abs().max((y - c.1).abs()) - h)
            }
            Marker::Diamond => self.shape(bbox, |x, y| {
                ((x - c.0).abs() + (y - c.1).abs() - r * 1.2) * std::f64::consts::FRAC_1_SQRT_2
            }),
            Marker::Triangle => {
                // Upward triangle inscribed in the circle of radius `big`.
                let (s3, r) = (3f64.sqrt(), big);
                let half = r / 2.0;
                self.shape(bbox, move |x, y| {
                    let (px, py) = (x - c.0, y - c.1);
                    let bottom = py - half;
                    let right = (s3 * px - py - r) / 2.0;
                    let left = (-s3 * px - py - r) / 2.0;
                    bottom.max(right).max(left)
                })
            }
            Marker::Cross => {
                let (k, hw) = (r * 0.8, (size / 8.0).max(0.75));
                self.segment((c.0 - k, c.1 - k), (c.0 + k, c.1 + k), hw, None);
                self.segment((c.0 - k, c.1 + k), (c.0 + k, c.1 - k), hw, None);
            }
        }
    }

    /// Fill between two curves given at increasing pixel x: `(x, y_a, y_b)`. `step`: each
    /// value holds until the next x (post-step); otherwise interpolate linearly.
    fn band(&mut self, pts: &[(f64, f64, f64)], step: bool) {
        if pts.len() < 2 {
            return;
        }
        let (first, last) = (pts[0].0, pts[pts.len() - 1].0);
        let (xa, xb) = self.span(first - 1.0, last + 1.0, true);
        for x in xa..xb {
            let px = self.x0 + x;
            let xc = px as f64 + 0.5;
            if xc < first || xc > last {
                continue;
            }
            // Last point whose x is <= xc.
            let i = pts.partition_point(|p| p.0 <= xc).clamp(1, pts.len() - 1) - 1;
            let (p, q) = (pts[i], pts[i + 1]);
            let f = if step || q.0 <= p.0 {
                0.0
            } else {
                (xc - p.0) / (q.0 - p.0)
            };
            let ya = p.1 + (q.1 - p.1) * f;
            let yb = p.2 + (q.2 - p.2) * f;
            let (top, bottom) = (ya.min(yb), ya.max(yb));
            let (ra, rb) = self.span(top, bottom, false);
            for y in ra..rb {
                let py = self.y0 + y;
                // Fraction of the pixel row inside [top, bottom]: soft edges.
                let c = (bottom.min(py as f64 + 1.0) - top.max(py as f64)).clamp(0.0, 1.0);
                if c > 0.0 {
                    self.add(px, py, c);
                }
            }
        }
    }

    /// Fill `[x0, x1) × [y0, y1)` (pixel edges, fractional coverage at the borders).
    fn rect(&mut self, x0: f64, y0: f64, x1: f64, y1: f64) {
        let (xa, xb) = self.span(x0, x1, true);
        let (ya, yb) = self.span(y0, y1, false);
        for y in ya..yb {
            let py = self.y0 + y;
            let cy = (y1.min(py as f64 + 1.0) - y0.max(py as f64)).clamp(0.0, 1.0);
            for x in xa..xb {
                let px = self.x0 + x;
                let cx = (x1.min(px as f64 + 1.0) - x0.max(px as f64)).clamp(0.0, 1.0);
                if cx * cy > 0.0 {
                    self.add(px, py, cx * cy);
                }
            }
        }
    }

    /// Blend `color` at `alpha` × coverage into `img`.
    fn composite(&self, img: &mut RgbImage, color: [u8; 3], alpha: f32) {
        for y in 0..self.h {
            for x in 0..self.w {
                let c = self.cov[y * self.w + x];
                if c > 0.0 {
                    img.blend(self.x0 + x, self.y0 + y, color, c * alpha);
                }
            }
        }
    }
}

/// Fill a one-pixel-wide (or wider) rectangle given by inclusive-exclusive coordinates that
/// may lie partly off the image.
fn fill(img: &mut RgbImage, x0: i64, y0: i64, x1: i64, y1: i64, c: [u8; 3]) {
    let cx = |v: i64| v.clamp(0, img.width as i64) as usize;
    let cy = |v: i64| v.clamp(0, img.height as i64) as usize;
    let (a, b, p, q) = (cx(x0), cx(x1), cy(y0), cy(y1));
    img.fill_rect(a, p, b, q, c);
}

// ---------------------------------------------------------------------------------------
// Axes layout shared by Chart and BarChart
// ---------------------------------------------------------------------------------------

/// The plot rectangle of a rendered [`Chart`] or [`BarChart`] and the data ranges it shows.
///
/// The interior is the pixels `[left, right) × [top, bottom)`; the axes frame is drawn
/// just outside it. `x_range.0` maps to the centre of column `left`, `x_range.1` to the
/// centre of column `right - 1`; `y_range.0` to the centre of row `bottom - 1` and
/// `y_range.1` to the centre of row `top`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlotArea {
    /// First column inside the frame.
    pub left: usize,
    /// First row inside the frame.
    pub top: usize,
    /// One past the last column inside the frame.
    pub right: usize,
    /// One past the last row inside the frame.
    pub bottom: usize,
    /// Data x at the left and right interior edges.
    pub x_range: (f64, f64),
    /// Data y at the bottom and top interior edges.
    pub y_range: (f64, f64),
}

impl PlotArea {
    /// Image x (fractional pixels, pixel centres at .5) of data `x`.
    pub fn x_to_px(&self, x: f64) -> f64 {
        let w = self.right.saturating_sub(self.left).max(1) - 1;
        let (a, b) = self.x_range;
        self.left as f64 + 0.5 + (x - a) / (b - a) * w as f64
    }

    /// Image y (fractional pixels, growing downwards) of data `y`.
    pub fn y_to_px(&self, y: f64) -> f64 {
        let h = self.bottom.saturating_sub(self.top).max(1) - 1;
        let (a, b) = self.y_range;
        self.bottom as f64 - 0.5 - (y - a) / (b - a) * h as f64
    }

    /// Image position of the data point (`x`, `y`).
    pub fn to_px(&self, x: f64, y: f64) -> (f64, f64) {
        (self.x_to_px(x), self.y_to_px(y))
    }

    /// The integer pixel that contains data point (`x`, `y`), if it lies in the image.
    pub fn pixel_of(&self, x: f64, y: f64) -> Option<(usize, usize)> {
        let (px, py) = self.to_px(x, y);
        (px >= 0.0 && py >= 0.0 && px.is_finite() && py.is_finite()).then_some((px as usize, py as usize))
    }

    fn mask(&self) -> Mask {
        Mask::new(self.left, self.top, self.right, self.bottom)
    }
}

/// Sizes derived from the text scale.
#[derive(Debug, Clone, Copy)]
struct Metrics {
    s: usize,
    line: usize,
    cap: usize,
    pad: usize,
    gap: usize,
    tick: usize,
}

impl Metrics {
    fn new(scale: usize) -> Self {
        let s = scale.max(1);
        Self {
            s,
            line: font::text_height(s),
            cap: CAP_HEIGHT * s,
            pad: 6 * s,
            gap: 3 * s,
            tick: 3 * s,
        }
    }

    fn title_style(&self) -> TextStyle {
        TextStyle::new(self.s + 1, INK).align(Align::Center)
    }
}

/// A padded data range, or a fallback when there is no data.
fn auto_range(values: impl Iterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if lo > hi {
        return (0.0, 1.0);
    }
    if hi - lo <= f64::EPSILON * hi.abs().max(1.0) {
        let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
        return (lo - d, hi + d);
    }
    let d = (hi - lo) * pad;
    (lo - d, hi + d)
}

/// A usable fixed range: ordered, finite and not empty; otherwise `None`.
fn fixed_range(r: Option<(f64, f64)>) -> Option<(f64, f64)> {
    let (a, b) = r?;
    if !(a.is_finite() && b.is_finite()) || a == b {
        return None;
    }
    Some((a.min(b), a.max(b)))
}

/// Texts of the axes frame.
struct AxesText<'a> {
    title: Option<&'a str>,
    x_label: Option<&'a str>,
    y_label: Option<&'a str>,
}

/// The y axis is numeric (ticks from the range) or categorical (one label per row, top
/// first, at y = n - 1 - i).
enum YAxis<'a> {
    Numeric((f64, f64)),
    Categories(&'a [String]),
}

/// A laid-out frame: the plot area plus its ticks and labels.
struct Axes {
    area: PlotArea,
    x_ticks: Vec<(f64, String)>,
    y_ticks: Vec<(f64, String)>,
    m: Metrics,
}

fn some_text(t: Option<&str>) -> Option<&str> {
    t.filter(|t| !t.trim().is_empty())
}

/// Place the plot rectangle in a `width × height` image: margins for the title, tick
/// labels and axis titles; at most as many ticks as fit without overlapping labels.
fn layout_axes(
    width: usize,
    height: usize,
    m: Metrics,
    text: &AxesText,
    x_range: (f64, f64),
    y: YAxis,
    extra_right: usize,
) -> Axes {
    let title_h = font::text_height(m.title_style().scale);
    let top = if some_text(text.title).is_some() {
        m.pad + title_h + 2 * m.gap
    } else {
        // Room for half of the topmost y tick label.
        m.pad + m.line / 2
    };
    let mut bottom = m.tick + m.gap + m.line + m.pad;
    if some_text(text.x_label).is_some() {
        bottom += m.line + m.gap;
    }
    let plot_h = height.saturating_sub(top + bottom).max(2);

    let (y_range, y_ticks) = match y {
        YAxis::Numeric(r) => {
            // One y tick per ~4 text lines.
            let n = (plot_h / (4 * m.line)).max(1);
            let ticks = nice_ticks(r.0, r.1, n);
            let labels = format_ticks(&ticks);
            (r, ticks.into_iter().zip(labels).collect::<Vec<_>>())
        }
        YAxis::Categories(cats) => {
            let n = cats.len();
            let ticks = cats
                .iter()
                .enumerate()
                .map(|(i, c)| ((n - 1 - i) as f64, c.clone()))
                .collect::<Vec<_>>();
            ((-0.5, n.max(1) as f64 - 0.5), ticks)
        }
    };
    let y_label_w = y_ticks
        .iter()
        .map(|(_, l)| font::text_width(l, m.s))
        .max()
        .unwrap_or(0);
    let mut left = m.pad + y_label_w + m.gap + m.tick;
    if some_text(text.y_label).is_some() {
        left += m.line + 2 * m.gap;
    }

    // The right margin must hold half of the last x tick label; try, then widen if needed.
    let mut right_margin = m.pad + 2 * m.line + extra_right;
    let mut x_ticks = Vec::new();
    for _ in 0..3 {
        let plot_w = width.saturating_sub(left + right_margin).max(2);
        x_ticks = x_ticks_fitting(x_range, plot_w, m);
        let area = PlotArea {
            left,
            top,
            right: left + plot_w,
            bottom: top + plot_h,
            x_range,
            y_range,
        };
        let overhang = x_ticks
            .last()
            .map(|(v, l)| {
                (area.x_to_px(*v) + font::text_width(l, m.s) as f64 / 2.0 - area.right as f64).ceil()
            })
            .unwrap_or(0.0)
            .max(0.0) as usize;
        let need = m.pad + overhang + extra_right;
        if need <= right_margin {
            break;
        }
        right_margin = need;
    }
    let plot_w = width.saturating_sub(left + right_margin).max(2);
    Axes {
        area: PlotArea {
            left,
            top,
            right: left + plot_w,
            bottom: top + plot_h,
            x_range,
            y_range,
        },
        x_ticks,
        y_ticks,
        m,
    }
}

/// Ticks on an x axis `plot_w` pixels wide: as many as fit with a gap of two text lines
/// between neighbouring labels.
fn x_ticks_fitting(range: (f64, f64), plot_w: usize, m: Metrics) -> Vec<(f64, String)> {
    let span = range.1 - range.0;
    let mut n = (plot_w / (5 * m.line)).max(1);
    loop {
        let ticks = nice_ticks(range.0, range.1, n);
        let labels = format_ticks(&ticks);
        let widest = labels.iter().map(|l| font::text_width(l, m.s)).max().unwrap_or(0);
        let step_px = if ticks.len() >= 2 {
            (ticks[1] - ticks[0]) / span * plot_w as f64
        } else {
            f64::INFINITY
        };
        if n == 1 || step_px >= (widest + 2 * m.line) as f64 {
            return ticks.into_iter().zip(labels).collect();
        }
        n -= 1;
    }
}

impl Axes {
    /// Light grid lines at the ticks, inside the plot area.
    fn draw_grid(&self, img: &mut RgbImage, vertical: bool, horizontal: bool) {
        let a = &self.area;
        if vertical {
            for (v, _) in &self.x_ticks {
                let x = a.x_to_px(*v).floor() as i64;
                fill(img, x, a.top as i64, x + 1, a.bottom as i64, GRID);
            }
        }
        if horizontal {
            for (v, _) in &self.y_ticks {
                let y = a.y_to_px(*v).floor() as i64;
                fill(img, a.left as i64, y, a.right as i64, y + 1, GRID);
            }
        }
    }

    /// Frame, ticks, tick labels, axis titles and the title.
    fn draw_frame(&self, img: &mut RgbImage, text: &AxesText) {
        let (a, m) = (&self.area, self.m);
        let (l, t, r, b) = (a.left as i64, a.top as i64, a.right as i64, a.bottom as i64);
        fill(img, l - 1, t - 1, r + 1, t, AXIS);
        fill(img, l - 1, b, r + 1, b + 1, AXIS);
        fill(img, l - 1, t - 1, l, b + 1, AXIS);
        fill(img, r, t - 1, r + 1, b + 1, AXIS);
        let tick = m.tick as i64;
        let label_style = TextStyle::new(m.s, INK);
        for (v, label) in &self.x_ticks {
            let x = a.x_to_px(*v).floor() as i64;
            fill(img, x, b + 1, x + 1, b + 1 + tick, AXIS);
            let y = b + 1 + tick + m.gap as i64;
            font::draw_text_styled(img, x, y, label, &label_style.align(Align::Center));
        }
        for (v, label) in &self.y_ticks {
            let y = a.y_to_px(*v).floor() as i64;
            fill(img, l - 1 - tick, y, l - 1, y + 1, AXIS);
            // Centre the capitals (not the descenders) on the tick.
            let top = y - (m.cap as i64 - 1) / 2;
            let x = l - 1 - tick - m.gap as i64;
            font::draw_text_styled(img, x, top, label, &label_style.align(Align::Right));
        }
        let cx = (l + r) / 2;
        if let Some(xl) = some_text(text.x_label) {
            let y = b + 1 + tick + (2 * m.gap + m.line) as i64;
            font::draw_text_styled(img, cx, y, xl, &label_style.align(Align::Center));
        }
        if let Some(yl) = some_text(text.y_label) {
            font::draw_text_vertical(img, m.pad as i64, (t + b) / 2, yl, m.s, INK, Align::Center);
        }
        if let Some(title) = some_text(text.title) {
            draw_title(img, title, cx, m);
        }
    }
}

/// The title centred on `cx`, moved left or right to stay inside the image if it can.
fn draw_title(img: &mut RgbImage, title: &str, cx: i64, m: Metrics) {
    let pad = m.pad as i64;
    // Step the scale down rather than cut a long title off.
    let room = img.width.saturating_sub(2 * m.pad);
    let big = m.title_style().scale;
    let scale = (1..=big)
        .rev()
        .find(|&k| font::text_width(title, k) <= room)
        .unwrap_or(1);
    let style = TextStyle {
        scale,
        ..m.title_style()
    };
    let w = font::text_width(title, scale) as i64;
    let max_cx = img.width as i64 - pad - w / 2;
    let cx = cx.min(max_cx).max(pad + w / 2);
    font::draw_text_styled(img, cx, pad, title, &style);
}

// ---------------------------------------------------------------------------------------
// Chart
// ---------------------------------------------------------------------------------------

/// Corner of the plot area that holds the legend.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LegendPosition {
    /// Upper right corner (the default).
    #[default]
    TopRight,
    /// Lower right corner (e.g. ROC curves, which fill the upper left).
    BottomRight,
    /// Upper left corner.
    TopLeft,
    /// Lower left corner.
    BottomLeft,
}

/// Shape of scatter markers (and of markers on line vertices).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Marker {
    /// Filled disc.
    #[default]
    Circle,
    /// Filled square.
    Square,
    /// Filled diamond.
    Diamond,
    /// Filled upward triangle.
    Triangle,
    /// Diagonal cross.
    Cross,
}

#[derive(Debug, Clone, PartialEq)]
enum Kind {
    Line(Vec<(f64, f64)>),
    Step(Vec<(f64, f64)>),
    Scatter(Vec<(f64, f64)>),
    Band(Vec<(f64, f64, f64)>),
    /// Squares of the given side centred on the points.
    Cells(Vec<(f64, f64)>, f64),
    HLine(f64),
    VLine(f64),
    Segment((f64, f64), (f64, f64)),
}

impl Kind {
    fn is_reference(&self) -> bool {
        matches!(self, Kind::HLine(_) | Kind::VLine(_) | Kind::Segment(..))
    }

    /// Drawing layer above the bands (layer 0): reference lines, then lines, then markers.
    fn layer(&self) -> u8 {
        match self {
            Kind::Band(_) | Kind::Cells(..) => 0,
            Kind::HLine(_) | Kind::VLine(_) | Kind::Segment(..) => 1,
            Kind::Line(_) | Kind::Step(_) => 2,
            Kind::Scatter(_) => 3,
        }
    }
}

/// One thing drawn on a [`Chart`]: build it with [`Series::line`], [`Series::step`],
/// [`Series::scatter`], [`Series::band`], [`Series::cells`] or a reference line ([`Series::hline`],
/// [`Series::vline`], [`Series::segment`]), then set options.
///
/// Drawing order, bottom to top: bands (including those attached with
/// [`Series::with_band`], and cells), reference lines, lines and steps, scatter markers; within a
/// layer, the order series were added.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    kind: Kind,
    label: Option<String>,
    color: Option<[u8; 3]>,
    width: f64,
    dashed: bool,
    alpha: f32,
    marker: Option<(Marker, f64)>,
    band: Option<Vec<(f64, f64, f64)>>,
}

/// Opacity of a band attached with [`Series::with_band`], and the default of a plain band.
const BAND_ALPHA: f32 = 0.25;

impl Series {
    fn of(kind: Kind) -> Self {
        let reference = kind.is_reference();
        let alpha = if matches!(kind, Kind::Band(_) | Kind::Cells(..)) {
            BAND_ALPHA
        } else {
            1.0
        };
        Self {
            kind,
            label: None,
            color: None,
            width: if reference { 1.5 } else { 2.0 },
            dashed: reference,
            alpha,
            marker: None,
            band: None,
        }
    }

    /// A polyline through the points in the order given; a non-finite coordinate breaks it.
    pub fn line(points: impl IntoIterator<Item = (f64, f64)>) -> Self {
        Self::of(Kind::Line(points.into_iter().collect()))
    }

    /// A post-step line: each y holds from its x until the next point's x (ROC and
    /// precision–recall curves, survival curves).
    pub fn step(points: impl IntoIterator<Item = (f64, f64)>) -> Self {
        Self::of(Kind::Step(points.into_iter().collect()))
    }

    /// Markers at the points (filled circles of 7 px unless [`Series::marker`] says otherwise).
    pub fn scatter(points: impl IntoIterator<Item = (f64, f64)>) -> Self {
        let mut s = Self::of(Kind::Scatter(points.into_iter().collect()));
        s.marker = Some((Marker::Circle, 7.0));
        s
    }

    /// A translucent fill between two curves, given as `(x, low, high)` (sorted by x when
    /// drawn); interpolated linearly between points.
    pub fn band(points: impl IntoIterator<Item = (f64, f64, f64)>) -> Self {
        Self::of(Kind::Band(points.into_iter().collect()))
    }

    /// Translucent squares of side `size` (data units) centred on the points, drawn in the
    /// band layer (e.g. the cells of a grid that a fire has reached), their edges on whole
    /// pixels; neighbours meet without a seam and overlapping squares are not blended twice.
    pub fn cells(centres: impl IntoIterator<Item = (f64, f64)>, size: f64) -> Self {
        Self::of(Kind::Cells(centres.into_iter().collect(), size.abs()))
    }

    /// A dashed horizontal reference line across the plot at `y` (e.g. prevalence).
    pub fn hline(y: f64) -> Self {
        Self::of(Kind::HLine(y))
    }

    /// A dashed vertical reference line across the plot at `x`.
    pub fn vline(x: f64) -> Self {
        Self::of(Kind::VLine(x))
    }

    /// A dashed reference segment between two data points (e.g. the chance diagonal from
    /// (0, 0) to (1, 1)).
    pub fn segment(from: (f64, f64), to: (f64, f64)) -> Self {
        Self::of(Kind::Segment(from, to))
    }

    /// Name shown in the legend; unlabelled series are left out of it.
    pub fn label(mut self, label: impl Into<String>) -> Self {
        self.label = Some(label.into());
        self
    }

    /// Colour instead of the next palette colour (reference lines default to grey).
    pub fn color(mut self, color: [u8; 3]) -> Self {
        self.color = Some(color);
        self
    }

    /// Line width in pixels (default 2; 1.5 for reference lines).
    pub fn width(mut self, px: f64) -> Self {
        self.width = if px.is_finite() { px.max(0.0) } else { self.width };
        self
    }

    /// Dash the line (reference lines are dashed by default).
    pub fn dashed(mut self, dashed: bool) -> Self {
        self.dashed = dashed;
        self
    }

    /// Opacity of the series in [0, 1] (default 1; for a plain band, 0.25).
    pub fn alpha(mut self, alpha: f32) -> Self {
        self.alpha = alpha.clamp(0.0, 1.0);
        self
    }

    /// Marker shape and diameter in pixels: for scatter series, the marker; for lines and
    /// steps, a marker at every vertex.
    pub fn marker(mut self, marker: Marker, size_px: f64) -> Self {
        self.marker = Some((marker, size_px.max(1.0)));
        self
    }

    /// A confidence band drawn under this line or step in its colour at opacity 0.25,
    /// given as `(x, low, high)`; stepped like the line for a step series.
    pub fn with_band(mut self, band: impl IntoIterator<Item = (f64, f64, f64)>) -> Self {
        self.band = Some(band.into_iter().collect());
        self
    }

    fn xs_ys(&self) -> (Vec<f64>, Vec<f64>) {
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        match &self.kind {
            Kind::Line(p) | Kind::Step(p) | Kind::Scatter(p) => {
                xs.extend(p.iter().map(|q| q.0));
                ys.extend(p.iter().map(|q| q.1));
            }
            Kind::Band(b) => {
                xs.extend(b.iter().map(|q| q.0));
                ys.extend(b.iter().flat_map(|q| [q.1, q.2]));
            }
            Kind::Cells(p, size) => {
                xs.extend(p.iter().flat_map(|q| [q.0 - size / 2.0, q.0 + size / 2.0]));
                ys.extend(p.iter().flat_map(|q| [q.1 - size / 2.0, q.1 + size / 2.0]));
            }
            Kind::HLine(y) => ys.push(*y),
            Kind::VLine(x) => xs.push(*x),
            Kind::Segment(a, b) => {
                xs.extend([a.0, b.0]);
                ys.extend([a.1, b.1]);
            }
        }
        if let Some(b) = &self.band {
            xs.extend(b.iter().map(|q| q.0));
            ys.extend(b.iter().flat_map(|q| [q.1, q.2]));
        }
        (xs, ys)
    }
}

/// An x–y chart on linear axes, built step by step and rendered to an [`RgbImage`].
///
/// Defaults: text scale 2 (10 × 14 px capitals), grid on, legend top right, axis ranges
/// from the data padded by 5 % on each side.
#[derive(Debug, Clone, PartialEq)]
pub struct Chart {
    width: usize,
    height: usize,
    title: Option<String>,
    x_label: Option<String>,
    y_label: Option<String>,
    x_range: Option<(f64, f64)>,
    y_range: Option<(f64, f64)>,
    grid: bool,
    legend: Option<LegendPosition>,
    text_scale: usize,
    series: Vec<Series>,
}

impl Chart {
    /// An empty chart of `width × height` pixels.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            title: None,
            x_label: None,
            y_label: None,
            x_range: None,
            y_range: None,
            grid: true,
            legend: Some(LegendPosition::TopRight),
            text_scale: 2,
            series: Vec::new(),
        }
    }

    /// Title above the plot.
    pub fn title(mut self, title: impl Into<String>) -> Self {
        self.title = Some(title.into());
        self
    }

    /// Title of the x axis.
    pub fn x_label(mut self, label: impl Into<String>) -> Self {
        self.x_label = Some(label.into());
        self
    }

    /// Title of the y axis (drawn rotated, reading upwards).
    pub fn y_label(mut self, label: impl Into<String>) -> Self {
        self.y_label = Some(label.into());
        self
    }

    /// Fixed x range (e.g. `(0.0, 1.0)` for ROC); data outside is clipped. An empty or
    /// non-finite range falls back to the automatic one.
    pub fn x_range(mut self, min: f64, max: f64) -> Self {
        self.x_range = Some((min, max));
        self
    }

    /// Fixed y range; see [`Chart::x_range`].
    pub fn y_range(mut self, min: f64, max: f64) -> Self {
        self.y_range = Some((min, max));
        self
    }

    /// Draw light grid lines at the ticks (default on).
    pub fn grid(mut self, on: bool) -> Self {
        self.grid = on;
        self
    }

    /// Where the legend goes, or `None` for no legend. Only labelled series are listed; with
    /// none, no legend is drawn.
    pub fn legend(mut self, position: Option<LegendPosition>) -> Self {
        self.legend = position;
        self
    }

    /// Integer scale of all text (default 2; the title is one step larger).
    pub fn text_scale(mut self, scale: usize) -> Self {
        self.text_scale = scale.max(1);
        self
    }

    /// Add a series.
    pub fn series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    /// Add a series through a mutable reference (for loops).
    pub fn push(&mut self, series: Series) -> &mut Self {
        self.series.push(series);
        self
    }

    /// Ranges after padding or fixing.
    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        for s in &self.series {
            let (x, y) = s.xs_ys();
            xs.extend(x);
            ys.extend(y);
        }
        let x = fixed_range(self.x_range).unwrap_or_else(|| auto_range(xs.into_iter(), 0.05));
        let y = fixed_range(self.y_range).unwrap_or_else(|| auto_range(ys.into_iter(), 0.05));
        (x, y)
    }

    /// Each series' colour: explicit, grey for reference lines, else the next palette colour.
    fn colors(&self) -> Vec<[u8; 3]> {
        let mut next = 0;
        self.series
            .iter()
            .map(|s| match s.color {
                Some(c) => c,
                None if s.kind.is_reference() => REFERENCE,
                None => {
                    let c = OKABE_ITO[next % OKABE_ITO.len()];
                    next += 1;
                    c
                }
            })
            .collect()
    }

    /// Render the chart.
    pub fn render(&self) -> RgbImage {
        self.render_with_area().0
    }

    /// Render the chart and return where its plot area ended up (to locate data points in
    /// the image).
    pub fn render_with_area(&self) -> (RgbImage, PlotArea) {
        let mut img = RgbImage::new(self.width, self.height);
        img.data.fill(255);
        let m = Metrics::new(self.text_scale);
        let (xr, yr) = self.ranges();
        let text = AxesText {
            title: self.title.as_deref(),
            x_label: self.x_label.as_deref(),
            y_label: self.y_label.as_deref(),
        };
        let axes = layout_axes(self.width, self.height, m, &text, xr, YAxis::Numeric(yr), 0);
        let area = axes.area;
        if self.grid {
            axes.draw_grid(&mut img, true, true);
        }
        let colors = self.colors();
        for (s, &c) in self.series.iter().zip(&colors) {
            draw_bands(&mut img, &area, s, c);
        }
        for layer in 1..=3 {
            for (s, &c) in self.series.iter().zip(&colors) {
                if s.kind.layer() == layer {
                    draw_series(&mut img, &area, s, c);
                }
            }
        }
        axes.draw_frame(&mut img, &text);
        if let Some(pos) = self.legend {
            let entries = self
                .series
                .iter()
                .zip(&colors)
                .filter_map(|(s, &c)| s.label.as_deref().filter(|l| !l.is_empty()).map(|l| (l, s, c)))
                .collect::<Vec<_>>();
            draw_legend(&mut img, &area, m, pos, &entries);
        }
        (img, area)
    }

    /// Render and write a PNG at `path` (atomically).
    pub fn save_png(&self, path: impl AsRef<Path>) -> Result<(), RenderError> {
        write_png(&self.render(), path)
    }
}

/// Finite `(x, low, high)` in pixels, sorted by x.
fn band_px(area: &PlotArea, band: &[(f64, f64, f64)]) -> Vec<(f64, f64, f64)> {
    let mut pts: Vec<_> = band
        .iter()
        .filter(|p| p.0.is_finite() && p.1.is_finite() && p.2.is_finite())
        .map(|p| (area.x_to_px(p.0), area.y_to_px(p.1), area.y_to_px(p.2)))
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    pts
}

/// The band layer: plain bands and bands attached to lines.
fn draw_bands(img: &mut RgbImage, area: &PlotArea, s: &Series, color: [u8; 3]) {
    if let Kind::Cells(centres, size) = &s.kind {
        let mut mask = area.mask();
        let h = size / 2.0;
        for &(x, y) in centres {
            let (xa, ya) = area.to_px(x - h, y + h);
            let (xb, yb) = area.to_px(x + h, y - h);
            if xa.is_finite() && ya.is_finite() && xb.is_finite() && yb.is_finite() {
                // Whole pixels, so that neighbours meet without a seam.
                let (xa, xb, ya, yb) = (xa.round(), xb.round(), ya.round(), yb.round());
                mask.rect(xa.min(xb), ya.min(yb), xa.max(xb), ya.max(yb));
            }
        }
        mask.composite(img, color, s.alpha);
        return;
    }
    let (band, alpha, step) = match (&s.kind, &s.band) {
        (Kind::Band(b), _) => (b, s.alpha, false),
        (k, Some(b)) => (b, BAND_ALPHA, matches!(k, Kind::Step(_))),
        _ => return,
    };
    let mut mask = area.mask();
    mask.band(&band_px(area, band), step);
    mask.composite(img, color, alpha);
}

/// Dash pattern in pixels for a line of width `w`.
fn dash_pattern(w: f64) -> (f64, f64) {
    let unit = w.max(1.0);
    (unit * 4.0 + 2.0, unit * 2.5 + 2.0)
}

/// Snap an axis-parallel line's centre so that a line of width `w` covers whole pixels.
fn snap(v: f64, w: f64) -> f64 {
    if (w.round() as i64) % 2 == 0 {
        v.round()
    } else {
        v.floor() + 0.5
    }
}

/// Draw one non-band series (lines, steps, markers, reference lines).
fn draw_series(img: &mut RgbImage, area: &PlotArea, s: &Series, color: [u8; 3]) {
    let mut mask = area.mask();
    let hw = s.width / 2.0;
    let dash = s.dashed.then(|| dash_pattern(s.width));
    let (l, r) = (area.left as f64, area.right as f64);
    let (t, b) = (area.top as f64, area.bottom as f64);
    let vertices: &[(f64, f64)] = match &s.kind {
        Kind::Line(p) => {
            let px: Vec<_> = p.iter().map(|q| area.to_px(q.0, q.1)).collect();
            mask.polyline(&px, hw, dash);
            p
        }
        Kind::Step(p) => {
            let mut px = Vec::with_capacity(p.len() * 2);
            for (i, q) in p.iter().enumerate() {
                let here = area.to_px(q.0, q.1);
                if i > 0 {
                    // Hold the previous y until this x.
                    let prev = px.last().copied().unwrap_or(here);
                    px.push((here.0, prev.1));
                }
                px.push(here);
            }
            mask.polyline(&px, hw, dash);
            p
        }
        Kind::Scatter(p) => p,
        Kind::HLine(y) => {
            let py = snap(area.y_to_px(*y), s.width);
            mask.polyline(&[(l, py), (r, py)], hw, dash);
            &[]
        }
        Kind::VLine(x) => {
            let px = snap(area.x_to_px(*x), s.width);
            mask.polyline(&[(px, t), (px, b)], hw, dash);
            &[]
        }
        Kind::Segment(p, q) => {
            mask.polyline(&[area.to_px(p.0, p.1), area.to_px(q.0, q.1)], hw, dash);
            &[]
        }
        Kind::Band(_) | Kind::Cells(..) => &[],
    };
    if let Some((marker, size)) = s.marker {
        for &(x, y) in vertices {
            if x.is_finite() && y.is_finite() {
                mask.marker(marker, area.to_px(x, y), size);
            }
        }
    }
    mask.composite(img, color, s.alpha);
}

/// Legend box in a corner of the plot area: a sample of each labelled series and its label.
fn draw_legend(
    img: &mut RgbImage,
    area: &PlotArea,
    m: Metrics,
    pos: LegendPosition,
    entries: &[(&str, &Series, [u8; 3])],
) {
    if entries.is_empty() {
        return;
    }
    let s = m.s;
    let row_h = m.line + s;
    let swatch_w = 12 * s;
    let inner = 3 * s + 1;
    let text_w = entries
        .iter()
        .map(|e| font::text_width(e.0, s))
        .max()
        .unwrap_or(0);
    let box_w = 2 * inner + swatch_w + m.gap + text_w;
    let box_h = 2 * inner + entries.len() * row_h - s;
    let margin = 3 * s;
    let x0 = match pos {
        LegendPosition::TopLeft | LegendPosition::BottomLeft => area.left + margin,
        _ => area.right.saturating_sub(margin + box_w),
    };
    let y0 = match pos {
        LegendPosition::TopLeft | LegendPosition::TopRight => area.top + margin,
        _ => area.bottom.saturating_sub(margin + box_h),
    };
    img.fill_rect(x0, y0, x0 + box_w, y0 + box_h, BACKGROUND);
    let (l, t, r, b) = (x0 as i64, y0 as i64, (x0 + box_w) as i64, (y0 + box_h) as i64);
    fill(img, l, t, r, t + 1, LEGEND_BORDER);
    fill(img, l, b - 1, r, b, LEGEND_BORDER);
    fill(img, l, t, l + 1, b, LEGEND_BORDER);
    fill(img, r - 1, t, r, b, LEGEND_BORDER);
    for (i, (label, series, color)) in entries.iter().enumerate() {
        let row_top = y0 + inner + i * row_h;
        // Samples sit on the middle of the capitals.
        let cy = row_top as f64 + m.cap as f64 / 2.0;
        let sx0 = (x0 + inner) as f64;
        let sx1 = sx0 + swatch_w as f64;
        let mut mask = Mask::new(
            x0 + inner,
            row_top.saturating_sub(s),
            x0 + inner + swatch_w,
            row_top + m.line,
        );
        let has_band = series.band.is_some() || matches!(series.kind, Kind::Band(_) | Kind::Cells(..));
        if has_band {
            let half = m.cap as f64 / 2.0 + 1.0;
            let mut band = Mask::new(mask.x0, mask.y0, mask.x0 + mask.w, mask.y0 + mask.h);
            band.rect(sx0, cy - half, sx1, cy + half);
            let alpha = match series.kind {
                Kind::Band(_) | Kind::Cells(..) => series.alpha,
                _ => BAND_ALPHA,
            };
            band.composite(img, *color, alpha);
        }
        let line_w = series.width.min(m.cap as f64 / 2.0);
        match series.kind {
            Kind::Band(_) | Kind::Cells(..) | Kind::Scatter(_) => {}
            _ => {
                let y = snap(cy, line_w);
                let dash = series.dashed.then(|| dash_pattern(line_w));
                mask.polyline(&[(sx0, y), (sx1, y)], line_w / 2.0, dash);
            }
        }
        if let Some((marker, size)) = series.marker {
            mask.marker(marker, ((sx0 + sx1) / 2.0, cy), size.min(m.line as f64));
        }
        mask.composite(img, *color, series.alpha);
        let tx = (x0 + inner + swatch_w + m.gap) as i64;
        font::draw_text(img, tx, row_top as i64, label, s, INK);
    }
}

// ---------------------------------------------------------------------------------------
// Heatmap
// ---------------------------------------------------------------------------------------

/// The value printed in a heatmap cell and the percentage under it, if any.
type CellText = (String, Option<String>);

/// What percentage, if any, a [`Heatmap`] prints under each value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CellPercent {
    /// Values only.
    #[default]
    None,
    /// Share of the sum of all cells.
    OfTotal,
    /// Share of the row's sum (for a confusion matrix with actual classes as rows: recall
    /// on the diagonal).
    OfRow,
}

/// A small matrix drawn as coloured cells (viridis, low = dark) with each value printed in
/// black or white, whichever contrasts. Rows go top to bottom, columns left to right.
///
/// Missing cells (short rows) and non-finite values are drawn light grey without text.
#[derive(Debug, Clone, PartialEq)]
pub struct Heatmap {
    values: Vec<Vec<f64>>,
    width: usize,
    height: usize,
    title: Option<String>,
    x_label: Option<String>,
    y_label: Option<String>,
    row_labels: Vec<String>,
    col_labels: Vec<String>,
    percent: CellPercent,
    range: Option<(f64, f64)>,
    colorbar: bool,
    text_scale: usize,
}

impl Heatmap {
    /// A heatmap of `values` (one inner vector per row), 640 × 560 pixels.
    pub fn new(values: Vec<Vec<f64>>) -> Self {
        Self {
            values,
            width: 640,
            height: 560,
            title: None,
            x_label: None,
            y_label: None,
            row_labels: Vec::new(),
            col_labels: Vec::new(),
            percent: CellPercent::None,
            range: None,
            colorbar: false,
            text_scale: 2,
        }
    }

    /// A binary confusion matrix: rows "actual", columns "predicted", both ordered
    /// (negative, positive); titled "Confusion matrix", with percentages of the total.
    pub fn confusion(tn: u64, fp: u64, fn_: u64, tp: u64) -> Self {
        Self::new(vec![vec![tn as f64, fp as f64], vec![fn_ as f64, tp as f64]])
            .title("Confusion matrix")
            .y_label("actual")
            .x_label("predicted")
            .row_labels(["negative", "positive"])
            .col_labels(["negative", "positive"])
            .percent(CellPercent::OfTotal)
    }

    /// Image size in pixels.
    pub fn size(mut self, width: usize, height: usize) -> Self {
        self.width = width;
        self.height = height;
        self
    }

    /// Title above the matrix.
    pub fn title(mut self, title: impl Into<String>) -> Self {
        self.title = Some(title.into());
        self
    }

    /// Title under the column labels (e.g. "predicted").
    pub fn x_label(mut self, label: impl Into<String>) -> Self {
        self.x_label = Some(label.into());
        self
    }

    /// Title left of the row labels, rotated (e.g. "actual").
    pub fn y_label(mut self, label: impl Into<String>) -> Self {
        self.y_label = Some(label.into());
        self
    }

    /// One label per row, drawn left of it.
    pub fn row_labels<S: Into<String>>(mut self, labels: impl IntoIterator<Item = S>) -> Self {
        self.row_labels = labels.into_iter().map(Into::into).collect();
        self
    }

    /// One label per column, drawn under it.
    pub fn col_labels<S: Into<String>>(mut self, labels: impl IntoIterator<Item = S>) -> Self {
        self.col_labels = labels.into_iter().map(Into::into).collect();
        self
    }

    /// Print a percentage under each value.
    pub fn percent(mut self, percent: CellPercent) -> Self {
        self.percent = percent;
        self
    }

    /// Values mapped to the ends of the colour map (default: the data's min and max).
    pub fn range(mut self, min: f64, max: f64) -> Self {
        self.range = Some((min, max));
        self
    }

    /// Draw a colour bar with ticks right of the matrix.
    pub fn colorbar(mut self, on: bool) -> Self {
        self.colorbar = on;
        self
    }

    /// Integer scale of the labels (default 2); cell values are drawn larger when they fit.
    pub fn text_scale(mut self, scale: usize) -> Self {
        self.text_scale = scale.max(1);
        self
    }

    fn value_range(&self) -> (f64, f64) {
        if let Some(r) = fixed_range(self.range) {
            return r;
        }
        let (lo, hi) = self
            .values
            .iter()
            .flatten()
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        if lo > hi { (0.0, 1.0) } else { (lo, hi) }
    }

    /// Render the heatmap.
    pub fn render(&self) -> RgbImage {
        let mut img = RgbImage::new(self.width, self.height);
        img.data.fill(255);
        let m = Metrics::new(self.text_scale);
        let rows = self.values.len();
        let cols = self.values.iter().map(Vec::len).max().unwrap_or(0);
        let title = some_text(self.title.as_deref());
        let label = |v: &[String], i: usize| v.get(i).cloned().unwrap_or_default();
        let (vmin, vmax) = self.value_range();

        let mut top = m.pad;
        if title.is_some() {
            top += font::text_height(m.title_style().scale) + 2 * m.gap;
        }
        let mut bottom = m.pad;
        if !self.col_labels.is_empty() {
            bottom += m.line + m.gap;
        }
        if some_text(self.x_label.as_deref()).is_some() {
            bottom += m.line + m.gap;
        }
        let row_label_w = self
            .row_labels
            .iter()
            .map(|l| font::text_width(l, m.s))
            .max()
            .unwrap_or(0);
        let mut left = m.pad + row_label_w + m.gap;
        if some_text(self.y_label.as_deref()).is_some() {
            left += m.line + 2 * m.gap;
        }
        let bar_w = 6 * m.s;
        let bar_ticks = if self.colorbar {
            let avail = self.height.saturating_sub(top + bottom);
            let ticks = nice_ticks(vmin, vmax, (avail / (3 * m.line)).max(1));
            let labels = format_ticks(&ticks);
            ticks.into_iter().zip(labels).collect::<Vec<_>>()
        } else {
            Vec::new()
        };
        let mut right = m.pad;
        if self.colorbar {
            let lw = bar_ticks
                .iter()
                .map(|(_, l)| font::text_width(l, m.s))
                .max()
                .unwrap_or(0);
            right += 3 * m.gap + bar_w + m.tick + m.gap + lw;
        }
        let avail_w = self.width.saturating_sub(left + right);
        let avail_h = self.height.saturating_sub(top + bottom);
        let (cell_w, cell_h) = if rows == 0 || cols == 0 {
            (0, 0)
        } else {
            let c = (avail_w / cols).min(avail_h / rows);
            (c, c)
        };
        let grid_w = cell_w * cols;
        let grid_h = cell_h * rows;
        // Centre the matrix in the space left for it.
        let gx = left + (avail_w - grid_w) / 2;
        let gy = top + (avail_h - grid_h) / 2;

        // Texts first, so that every cell uses the same decimals and the same scale.
        let total: f64 = self.values.iter().flatten().filter(|v| v.is_finite()).sum();
        let flat: Vec<f64> = self.values.iter().flatten().copied().collect();
        let decimals = value_decimals(&flat);
        let cells: Vec<Vec<Option<CellText>>> = self
            .values
            .iter()
            .map(|row| {
                let row_sum: f64 = row.iter().filter(|v| v.is_finite()).sum();
                (0..cols)
                    .map(|c| {
                        let v = row.get(c).copied().filter(|v| v.is_finite())?;
                        let share = match self.percent {
                            CellPercent::None => return Some((format!("{v:.decimals$}"), None)),
                            CellPercent::OfTotal => v / total,
                            CellPercent::OfRow => v / row_sum,
                        };
                        let pct = if share.is_finite() {
                            format!("{:.1}%", share * 100.0)
                        } else {
                            "-".to_string()
                        };
                        Some((format!("{v:.decimals$}"), Some(pct)))
                    })
                    .collect()
            })
            .collect();
        let widest =
            |f: &dyn Fn(&CellText) -> usize| cells.iter().flatten().flatten().map(f).max().unwrap_or(0);
        let pct_h = if self.percent == CellPercent::None {
            0
        } else {
            m.line + m.gap
        };
        let pct_scale =
            if widest(&|c| c.1.as_deref().map_or(0, |p| font::text_width(p, m.s))) <= cell_w * 9 / 10 {
                m.s
            } else {
                1
            };
        // The largest scale (up to 2 above the labels) at which every value fits.
        let value_scale = (1..=m.s + 2)
            .rev()
            .find(|&k| {
                widest(&|c| font::text_width(&c.0, k)) * 10 <= cell_w * 8
                    && (font::text_height(k) + pct_h) * 10 <= cell_h * 8
            })
            .unwrap_or(1);
        let sep = m.s / 2 + 1;
        for (r, row) in self.values.iter().enumerate() {
            for c in 0..cols {
                let (x0, y0) = (gx + c * cell_w, gy + r * cell_h);
                let v = row.get(c).copied().unwrap_or(f64::NAN);
                let bg = if v.is_finite() {
                    let t = if vmax > vmin {
                        (v - vmin) / (vmax - vmin)
                    } else {
                        0.5
                    };
                    viridis(t)
                } else {
                    MISSING_CELL
                };
                // A thin white gap between cells.
                let (a, b) = (sep / 2, sep - sep / 2);
                img.fill_rect(x0 + a, y0 + a, x0 + cell_w - b, y0 + cell_h - b, bg);
                let Some((value, pct)) = cells.get(r).and_then(|row| row.get(c)).cloned().flatten() else {
                    continue;
                };
                let fg = contrasting(bg);
                let vs = value_scale;
                let block_h = CAP_HEIGHT * vs + pct_h;
                let cx = (x0 + cell_w / 2) as i64;
                let ty = (y0 + cell_h / 2) as i64 - block_h as i64 / 2;
                font::draw_text_styled(
                    &mut img,
                    cx,
                    ty,
                    &value,
                    &TextStyle::new(vs, fg).align(Align::Center),
                );
                if let Some(p) = pct {
                    let py = ty + (CAP_HEIGHT * vs + m.gap) as i64;
                    let style = TextStyle::new(pct_scale, fg).align(Align::Center);
                    font::draw_text_styled(&mut img, cx, py, &p, &style);
                }
            }
        }

        let style = TextStyle::new(m.s, INK);
        for r in 0..rows {
            let cy = (gy + r * cell_h + cell_h / 2) as i64;
            let text = label(&self.row_labels, r);
            let y = cy - (m.cap as i64) / 2;
            font::draw_text_styled(
                &mut img,
                (gx - m.gap) as i64,
                y,
                &text,
                &style.align(Align::Right),
            );
        }
        let mut y = (gy + grid_h + m.gap) as i64;
        if !self.col_labels.is_empty() {
            for c in 0..cols {
                let cx = (gx + c * cell_w + cell_w / 2) as i64;
                font::draw_text_styled(
                    &mut img,
                    cx,
                    y,
                    &label(&self.col_labels, c),
                    &style.align(Align::Center),
                );
            }
            y += (m.line + m.gap) as i64;
        }
        let cx = (gx + grid_w / 2) as i64;
        if let Some(xl) = some_text(self.x_label.as_deref()) {
            font::draw_text_styled(&mut img, cx, y, xl, &style.align(Align::Center));
        }
        if let Some(yl) = some_text(self.y_label.as_deref()) {
            let x = (gx - m.gap - row_label_w - 2 * m.gap - m.line) as i64;
            font::draw_text_vertical(&mut img, x, (gy + grid_h / 2) as i64, yl, m.s, INK, Align::Center);
        }
        if let Some(t) = title {
            draw_title(&mut img, t, cx, m);
        }
        if self.colorbar && grid_h > 1 {
            let bx = gx + grid_w + 3 * m.gap;
            for y in 0..grid_h {
                let t = 1.0 - y as f64 / (grid_h - 1) as f64;
                img.fill_rect(bx, gy + y, bx + bar_w, gy + y + 1, viridis(t));
            }
            let (l, t, r, b) = (bx as i64, gy as i64, (bx + bar_w) as i64, (gy + grid_h) as i64);
            fill(&mut img, l - 1, t - 1, r + 1, t, AXIS);
            fill(&mut img, l - 1, b, r + 1, b + 1, AXIS);
            fill(&mut img, l - 1, t - 1, l, b + 1, AXIS);
            fill(&mut img, r, t - 1, r + 1, b + 1, AXIS);
            for (v, text) in &bar_ticks {
                let f = if vmax > vmin {
                    (v - vmin) / (vmax - vmin)
                } else {
                    0.5
                };
                let y = b - 1 - (f * (grid_h - 1) as f64).round() as i64;
                fill(&mut img, r + 1, y, r + 1 + m.tick as i64, y + 1, AXIS);
                let ty = y - (m.cap as i64 - 1) / 2;
                font::draw_text(&mut img, r + 1 + (m.tick + m.gap) as i64, ty, text, m.s, INK);
            }
        }
        img
    }

    /// Render and write a PNG at `path` (atomically).
    pub fn save_png(&self, path: impl AsRef<Path>) -> Result<(), RenderError> {
        write_png(&self.render(), path)
    }
}

// ---------------------------------------------------------------------------------------
// BarChart
// ---------------------------------------------------------------------------------------

/// One bar of a [`BarChart`].
#[derive(Debug, Clone, PartialEq)]
pub struct Bar {
    /// Text left of the bar.
    pub label: String,
    /// Where the bar ends.
    pub value: f64,
    /// Error bar `(low, high)`, e.g. a 95 % confidence interval.
    pub interval: Option<(f64, f64)>,
    /// Colour instead of the chart's bar colour.
    pub color: Option<[u8; 3]>,
}

/// Horizontal bars with error bars, one per label, top to bottom in the order added; a
/// forest-style plot of, say, AUROC with its 95 % interval per model.
///
/// Bars start at the baseline (default 0; clipped to the plot when the range excludes it).
/// The x range defaults to the baseline, values, intervals and reference lines, padded by
/// 5 % (not below the baseline). With [`BarChart::show_values`] on (the default),
/// "value [low, high]" is printed right of the plot.
#[derive(Debug, Clone, PartialEq)]
pub struct BarChart {
    width: usize,
    height: usize,
    title: Option<String>,
    x_label: Option<String>,
    x_range: Option<(f64, f64)>,
    bars: Vec<Bar>,
    references: Vec<f64>,
    baseline: f64,
    show_values: bool,
    decimals: usize,
    color: [u8; 3],
    grid: bool,
    text_scale: usize,
}

impl BarChart {
    /// An empty bar chart of `width × height` pixels.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            title: None,
            x_label: None,
            x_range: None,
            bars: Vec::new(),
            references: Vec::new(),
            baseline: 0.0,
            show_values: true,
            decimals: 3,
            color: OKABE_ITO[0],
            grid: true,
            text_scale: 2,
        }
    }

    /// Title above the plot.
    pub fn title(mut self, title: impl Into<String>) -> Self {
        self.title = Some(title.into());
        self
    }

    /// Title of the x (value) axis.
    pub fn x_label(mut self, label: impl Into<String>) -> Self {
        self.x_label = Some(label.into());
        self
    }

    /// Fixed x range (e.g. `(0.5, 1.0)` for AUROC).
    pub fn x_range(mut self, min: f64, max: f64) -> Self {
        self.x_range = Some((min, max));
        self
    }

    /// Add a bar with an optional `(low, high)` error bar.
    pub fn bar(mut self, label: impl Into<String>, value: f64, interval: Option<(f64, f64)>) -> Self {
        self.bars.push(Bar {
            label: label.into(),
            value,
            interval,
            color: None,
        });
        self
    }

    /// Add a fully specified bar (e.g. with its own colour) through a mutable reference.
    pub fn push(&mut self, bar: Bar) -> &mut Self {
        self.bars.push(bar);
        self
    }

    /// A dashed vertical reference line at `x` (e.g. 0.5, chance AUROC).
    pub fn reference(mut self, x: f64) -> Self {
        self.references.push(x);
        self
    }

    /// Where bars start (default 0).
    pub fn baseline(mut self, x: f64) -> Self {
        self.baseline = x;
        self
    }

    /// Print "value [low, high]" right of the plot (default on).
    pub fn show_values(mut self, on: bool) -> Self {
        self.show_values = on;
        self
    }

    /// Decimals of the printed values (default 3).
    pub fn decimals(mut self, decimals: usize) -> Self {
        self.decimals = decimals.min(12);
        self
    }

    /// Colour of bars without their own (default Okabe–Ito blue).
    pub fn color(mut self, color: [u8; 3]) -> Self {
        self.color = color;
        self
    }

    /// Vertical grid lines at the x ticks (default on).
    pub fn grid(mut self, on: bool) -> Self {
        self.grid = on;
        self
    }

    /// Integer scale of all text (default 2).
    pub fn text_scale(mut self, scale: usize) -> Self {
        self.text_scale = scale.max(1);
        self
    }

    fn x_range_or_auto(&self) -> (f64, f64) {
        if let Some(r) = fixed_range(self.x_range) {
            return r;
        }
        let mut vals = vec![self.baseline];
        for b in &self.bars {
            vals.push(b.value);
            if let Some((lo, hi)) = b.interval {
                vals.extend([lo, hi]);
            }
        }
        vals.extend(&self.references);
        let (lo, hi) = auto_range(vals.iter().copied(), 0.05);
        // Bars grow from the baseline: no padding on its side.
        let base = self.baseline;
        if base.is_finite() {
            let finite = || vals.iter().copied().filter(|v| v.is_finite());
            if finite().all(|v| v >= base) && hi > base {
                return (base, hi);
            }
            if finite().all(|v| v <= base) && lo < base {
                return (lo, base);
            }
        }
        (lo, hi)
    }

    fn value_text(&self, b: &Bar) -> String {
        let d = self.decimals;
        match b.interval {
            Some((lo, hi)) => format!("{:.d$} [{lo:.d$}, {hi:.d$}]", b.value),
            None => format!("{:.d$}", b.value),
        }
    }

    /// Render the chart.
    pub fn render(&self) -> RgbImage {
        self.render_with_area().0
    }

    /// Render the chart and return its plot area (bar `i` is centred on y = n - 1 - i).
    pub fn render_with_area(&self) -> (RgbImage, PlotArea) {
        let mut img = RgbImage::new(self.width, self.height);
        img.data.fill(255);
        let m = Metrics::new(self.text_scale);
        let labels: Vec<String> = self.bars.iter().map(|b| b.label.clone()).collect();
        let values: Vec<String> = self.bars.iter().map(|b| self.value_text(b)).collect();
        let values_w = if self.show_values {
            values.iter().map(|v| font::text_width(v, m.s)).max().unwrap_or(0) + 2 * m.gap
        } else {
            0
        };
        let text = AxesText {
            title: self.title.as_deref(),
            x_label: self.x_label.as_deref(),
            y_label: None,
        };
        let xr = self.x_range_or_auto();
        let axes = layout_axes(
            self.width,
            self.height,
            m,
            &text,
            xr,
            YAxis::Categories(&labels),
            values_w,
        );
        let area = axes.area;
        if self.grid {
            axes.draw_grid(&mut img, true, false);
        }
        let n = self.bars.len();
        let row_px = (area.bottom - area.top) as f64 / n.max(1) as f64;
        let thick = (row_px * 0.55).clamp(2.0, 16.0 * m.s as f64);
        let base_px = area
            .x_to_px(self.baseline)
            .clamp(area.left as f64, area.right as f64);
        for (i, b) in self.bars.iter().enumerate() {
            let cy = area.y_to_px((n - 1 - i) as f64);
            let color = b.color.unwrap_or(self.color);
            if b.value.is_finite() {
                let vx = area.x_to_px(b.value).clamp(area.left as f64, area.right as f64);
                let mut mask = area.mask();
                mask.rect(
                    base_px.min(vx),
                    cy - thick / 2.0,
                    base_px.max(vx),
                    cy + thick / 2.0,
                );
                mask.composite(&mut img, color, 0.85);
            }
            if let Some((lo, hi)) = b.interval.filter(|(lo, hi)| lo.is_finite() && hi.is_finite()) {
                let mut mask = area.mask();
                let w = m.s as f64;
                let y = snap(cy, w);
                let (xa, xb) = (snap(area.x_to_px(lo), w), snap(area.x_to_px(hi), w));
                mask.polyline(&[(xa, y), (xb, y)], w / 2.0, None);
                let cap = (thick * 0.35).max(3.0);
                mask.polyline(&[(xa, y - cap), (xa, y + cap)], w / 2.0, None);
                mask.polyline(&[(xb, y - cap), (xb, y + cap)], w / 2.0, None);
                mask.composite(&mut img, INK, 1.0);
            }
        }
        for &x in &self.references {
            let mut mask = area.mask();
            let px = snap(area.x_to_px(x), 1.5);
            mask.polyline(
                &[(px, area.top as f64), (px, area.bottom as f64)],
                0.75,
                Some(dash_pattern(1.5)),
            );
            mask.composite(&mut img, REFERENCE, 1.0);
        }
        axes.draw_frame(&mut img, &text);
        if self.show_values {
            let x = (area.right + 2 * m.gap) as i64;
            for (i, v) in values.iter().enumerate() {
                let cy = area.y_to_px((n - 1 - i) as f64).floor() as i64;
                font::draw_text(&mut img, x, cy - (m.cap as i64 - 1) / 2, v, m.s, INK);
            }
        }
        (img, area)
    }

    /// Render and write a PNG at `path` (atomically).
    pub fn save_png(&self, path: impl AsRef<Path>) -> Result<(), RenderError> {
        write_png(&self.render(), path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_ends() {
        assert_eq!(viridis(0.0), VIRIDIS[0]);
        assert_eq!(viridis(1.0), VIRIDIS[8]);
        assert_eq!(viridis(f64::NAN), VIRIDIS[0]);
        assert_eq!(contrasting(viridis(0.0)), [255, 255, 255]);
        assert_eq!(contrasting(viridis(1.0)), [0, 0, 0]);
    }

    #[test]
    fn values_format_compactly() {
        assert_eq!(value_decimals(&[812.0, 95.0, 41.0, 252.0]), 0);
        assert_eq!(value_decimals(&[0.91, 0.05, 0.04, f64::NAN]), 2);
        assert_eq!(value_decimals(&[0.83215, 0.1]), 3);
        assert_eq!(value_decimals(&[12.345, 3.0]), 1);
        assert_eq!(value_decimals(&[0.0, f64::NAN]), 0);
    }
}
