//! The report's maps as inline SVG: a raster (land cover over hillshade, or burn probability)
//! under vector layers — arrival bands labelled in hours, perimeters, a drop path, assets, the
//! ignition, the head's direction — and on every map a north arrow and a scale bar. Every map
//! is [`MAP_WIDTH`](crate::figures::MAP_WIDTH) units wide whatever the grid's size, so symbols
//! and labels keep their size on the page.

use std::fmt::Write;

use firecast_landscape::{LandCoverScheme, Landscape};

use crate::figures::{self, hex};
use crate::geometry;
use crate::html::esc;
use crate::model::Drop;
use crate::units::fmt_num;

const MILE_FT: f64 = 5280.0;
const HALO: &str = "stroke=\"#fff\" stroke-width=\"3\" paint-order=\"stroke\"";

/// Colour of the k-th of n arrival bands, earliest dark red to latest pale yellow.
pub fn band_color(k: usize, n: usize) -> [u8; 3] {
    let t = if n <= 1 { 0.0 } else { k as f64 / (n - 1) as f64 };
    let (a, b) = ([110.0, 0.0, 30.0], [250.0, 210.0, 90.0]);
    [0, 1, 2].map(|i| (a[i] + t * (b[i] - a[i])).round() as u8)
}

/// One map being drawn: a window of the grid, [x0, y0, width, height] in cells (x0 from the
/// west edge, y0 from the south edge).
pub struct MapFrame<'a> {
    land: &'a Landscape,
    window: [usize; 4],
    s: f64,
    pw: f64,
    ph: f64,
    svg: String,
    /// Hour labels of the arrival bands, written last so nothing covers them: (x, y, text).
    labels: Vec<(f64, f64, String)>,
    /// Boxes already holding text (centre x, centre y, half width, half height).
    taken: Vec<(f64, f64, f64, f64)>,
}

impl<'a> MapFrame<'a> {
    /// A map of `window` of `land` over the raster `png` (the window's pixels, row 0 north).
    pub fn new(land: &'a Landscape, window: [usize; 4], png: &[u8], aria: &str) -> Self {
        let s = figures::vector_scale(window[2]);
        let (pw, ph) = (window[2] as f64 * s, window[3] as f64 * s);
        let mut svg = String::new();
        let _ = write!(
            svg,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {pw:.0} {ph:.0}\" width=\"{pw:.0}\" height=\"{ph:.0}\" \
             role=img aria-label=\"{}\" font-family=\"DejaVu Sans, Arial, sans-serif\" class=map>\
             <image href=\"{}\" x=\"0\" y=\"0\" width=\"{pw:.0}\" height=\"{ph:.0}\" preserveAspectRatio=\"none\" \
             style=\"image-rendering:pixelated\"/>",
            esc(aria),
            figures::data_uri(png)
        );
        Self {
            land,
            window,
            s,
            pw,
            ph,
            svg,
            labels: Vec::new(),
            taken: Vec::new(),
        }
    }

    /// Map coordinates of a cell's centre (grid coordinates).
    pub fn px(&self, x: f64, y: f64) -> (f64, f64) {
        let [x0, y0, _, h] = self.window;
        (
            (x - x0 as f64 + 0.5) * self.s,
            ((y0 + h) as f64 - y - 0.5) * self.s,
        )
    }

    /// Whether a grid cell lies in the window.
    fn shows(&self, x: f64, y: f64) -> bool {
        let [x0, y0, w, h] = self.window;
        x >= x0 as f64 && y >= y0 as f64 && x < (x0 + w) as f64 && y < (y0 + h) as f64
    }

    /// The grid index of the window's cell `i` (row-major from the window's south-west).
    fn global(&self, i: usize) -> usize {
        let [x0, y0, w, _] = self.window;
        (y0 + i / w) * self.land.width + x0 + i % w
    }

    /// Rings of the window's cells where `inside` (a grid index) holds, as an SVG path.
    fn path(&self, inside: impl Fn(usize) -> bool) -> Option<String> {
        let [_, _, w, h] = self.window;
        let rings = geometry::rings(w, h, |i| inside(self.global(i)));
        (!rings.is_empty()).then(|| geometry::svg_path(&rings, h, self.s))
    }

    /// Filled arrival bands: the cells reached by each of `times` (hours, ascending), the
    /// earliest drawn last so every band shows; each band's edge is labelled with its hour
    /// where it reaches farthest along `head_deg` (the direction the head runs toward) from
    /// `from`.
    pub fn arrival_bands(
        &mut self,
        arrival_h: &[Option<f32>],
        times: &[f64],
        head_deg: f64,
        from: [usize; 2],
    ) {
        let w = self.land.width;
        let n = times.len();
        let (dx, dy) = (head_deg.to_radians().sin(), head_deg.to_radians().cos());
        let cells = self.window[2] * self.window[3];
        let mut labels = Vec::new();
        for (k, &t) in times.iter().enumerate().rev() {
            let inside = |i: usize| arrival_h[i].is_some_and(|a| f64::from(a) <= t);
            let Some(path) = self.path(inside) else {
                continue;
            };
            let c = hex(band_color(k, n));
            let _ = write!(
                self.svg,
                "<path d=\"{path}\" fill=\"{c}\" fill-opacity=\"0.75\" stroke=\"{c}\" stroke-width=\"1.2\" fill-rule=\"evenodd\"><title>reached within {} h in half of the runs</title></path>",
                fmt_num(t, 0)
            );
            // The farthest cell along the head's direction.
            let best = (0..cells)
                .map(|i| self.global(i))
                .filter(|&i| inside(i))
                .max_by(|&a, &b| {
                    let score = |i: usize| {
                        ((i % w) as f64 - from[0] as f64) * dx + ((i / w) as f64 - from[1] as f64) * dy
                    };
                    score(a).total_cmp(&score(b))
                });
            if let Some(i) = best {
                labels.push((i, t));
            }
        }
        // Labels on top of every band (written by `finish`).
        for (i, t) in labels {
            let (x, y) = self.px((i % w) as f64, (i / w) as f64);
            let (x, y) = (x + dx * 8.0, y - dy * 8.0);
            self.labels.push((x, y, format!("{} h", fmt_num(t, 0))));
        }
    }

    /// The outline of the cells where `inside` holds.
    pub fn perimeter(
        &mut self,
        inside: impl Fn(usize) -> bool,
        color: &str,
        width: f64,
        dash: bool,
        title: &str,
    ) {
        let Some(path) = self.path(inside) else {
            return;
        };
        let _ = write!(
            self.svg,
            "<path d=\"{path}\" fill=\"none\" stroke=\"{color}\" stroke-width=\"{width:.1}\"{} fill-rule=\"evenodd\"><title>{}</title></path>",
            if dash { " stroke-dasharray=\"7 4\"" } else { "" },
            esc(title)
        );
    }

    /// Drops as the path the aircraft flew between them, with a dot per place dropped on and
    /// a few numbered labels (first, last and some between), never a pile.
    pub fn drop_path(&mut self, drops: &[Drop]) {
        // Places in order, repeated drops on one cell merged.
        let mut places: Vec<(i32, i32, usize, usize)> = Vec::new(); // x, y, first, last number
        for d in drops
            .iter()
            .filter(|d| self.shows(f64::from(d.x), f64::from(d.y)))
        {
            match places.last_mut() {
                Some(p) if (p.0, p.1) == (d.x, d.y) => p.3 = d.number,
                _ => places.push((d.x, d.y, d.number, d.number)),
            }
        }
        if places.is_empty() {
            return;
        }
        let pts: Vec<(f64, f64)> = places
            .iter()
            .map(|p| self.px(f64::from(p.0), f64::from(p.1)))
            .collect();
        if pts.len() > 1 {
            let line: String = pts.iter().map(|(x, y)| format!("{x:.1},{y:.1} ")).collect();
            let _ = write!(
                self.svg,
                "<polyline points=\"{}\" fill=\"none\" stroke=\"#fff\" stroke-width=\"4\"/>\
                 <polyline points=\"{}\" fill=\"none\" stroke=\"#0d47a1\" stroke-width=\"2\"/>",
                line.trim_end(),
                line.trim_end()
            );
        }
        for &(x, y) in &pts {
            let _ = write!(
                self.svg,
                "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"3.5\" fill=\"#1565c0\" stroke=\"#fff\" stroke-width=\"1\"/>"
            );
        }
        // At most six labels, spread over the path.
        let n = pts.len();
        let picks: Vec<usize> = if n <= 6 {
            (0..n).collect()
        } else {
            (0..6).map(|k| k * (n - 1) / 5).collect()
        };
        let mut placed: Vec<(f64, f64)> = Vec::new();
        for k in picks {
            let (x, y) = pts[k];
            if placed
                .iter()
                .any(|&(px, py)| (px - x).abs() < 40.0 && (py - y).abs() < 14.0)
            {
                continue;
            }
            placed.push((x, y));
            let p = places[k];
            let text = if p.2 == p.3 {
                format!("#{}", p.2)
            } else {
                format!("#{}–{}", p.2, p.3)
            };
            let _ = write!(
                self.svg,
                "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"11\" fill=\"#0d47a1\" {HALO}>{text}</text>",
                x + 6.0,
                y - 5.0
            );
        }
    }

    /// Assets as black squares, named when `named`.
    pub fn assets(&mut self, assets: &[(String, f64, f64)], named: bool) {
        let shown: Vec<&(String, f64, f64)> = assets.iter().filter(|(_, x, y)| self.shows(*x, *y)).collect();
        let mut placed: Vec<(f64, f64)> = Vec::new();
        for (name, x, y) in shown {
            let (px, py) = self.px(*x, *y);
            let _ = write!(
                self.svg,
                "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"9\" height=\"9\" fill=\"#222\" stroke=\"#fff\"><title>{}</title></rect>",
                px - 4.5,
                py - 4.5,
                esc(name)
            );
            // A name is left out where it would overlap one already written.
            let clear = !placed
                .iter()
                .any(|&(lx, ly)| (lx - px).abs() < 120.0 && (ly - py).abs() < 18.0);
            if named && !name.is_empty() && clear {
                placed.push((px, py));
                let _ = write!(
                    self.svg,
                    "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"11\" {HALO}>{}</text>",
                    px + 7.0,
                    py + 4.0,
                    esc(name)
                );
            }
        }
    }

    /// The ignition as a yellow star.
    pub fn ignition(&mut self, at: [usize; 2]) {
        let (px, py) = self.px(at[0] as f64, at[1] as f64);
        self.svg.push_str(&star(px, py, 10.0, "ignition"));
    }

    /// An arrow from the ignition toward where the head runs, with `label` at its tip.
    pub fn head_arrow(&mut self, from: [usize; 2], head_deg: f64, label: &str) {
        let (x0, y0) = self.px(from[0] as f64, from[1] as f64);
        let len = (self.pw.min(self.ph) * 0.16).max(40.0);
        let (dx, dy) = (head_deg.to_radians().sin(), -head_deg.to_radians().cos());
        let (x1, y1) = (x0 + dx * len, y0 + dy * len);
        let (hx, hy) = (x1 - dx * 12.0, y1 - dy * 12.0);
        let (nx, ny) = (-dy * 6.0, dx * 6.0);
        let anchor = if dx > 0.3 {
            "start"
        } else if dx < -0.3 {
            "end"
        } else {
            "middle"
        };
        let (lx, ly) = (x1 + dx * 6.0, y1 + dy * 6.0 + if dy > 0.3 { 12.0 } else { 0.0 });
        let half = label.chars().count() as f64 * 5.5;
        let cx = match anchor {
            "start" => lx + half,
            "end" => lx - half,
            _ => lx,
        };
        self.taken.push((cx, ly - 6.0, half, 11.0));
        let _ = write!(
            self.svg,
            "<g><line x1=\"{x0:.1}\" y1=\"{y0:.1}\" x2=\"{hx:.1}\" y2=\"{hy:.1}\" stroke=\"#fff\" stroke-width=\"6\"/>\
             <line x1=\"{x0:.1}\" y1=\"{y0:.1}\" x2=\"{hx:.1}\" y2=\"{hy:.1}\" stroke=\"#000\" stroke-width=\"3\"/>\
             <polygon points=\"{x1:.1},{y1:.1} {:.1},{:.1} {:.1},{:.1}\" fill=\"#000\" stroke=\"#fff\"/>\
             <text class=big x=\"{:.1}\" y=\"{:.1}\" font-size=\"12\" font-weight=\"bold\" text-anchor=\"{anchor}\" {HALO}>{}</text></g>",
            hx + nx,
            hy + ny,
            hx - nx,
            hy - ny,
            x1 + dx * 6.0,
            y1 + dy * 6.0 + if dy > 0.3 { 12.0 } else { 0.0 },
            esc(label)
        );
    }

    /// Closes the map with a north arrow and a scale bar.
    pub fn finish(mut self) -> String {
        let (pw, ph) = (self.pw, self.ph);
        for (x, y, text) in std::mem::take(&mut self.labels) {
            let half = text.chars().count() as f64 * 6.0;
            let clear = !self
                .taken
                .iter()
                .any(|&(cx, cy, hw, hh)| (cx - x).abs() < hw + half && (cy - (y - 6.0)).abs() < hh + 10.0);
            if !clear {
                continue;
            }
            self.taken.push((x, y - 6.0, half, 10.0));
            let _ = write!(
                self.svg,
                "<text class=big x=\"{x:.1}\" y=\"{y:.1}\" font-size=\"13\" font-weight=\"bold\" text-anchor=\"middle\" {HALO}>{}</text>",
                esc(&text)
            );
        }
        let mile = MILE_FT / self.land.cell_size_ft * self.s;
        // The longest of 0.5, 1, 2, 5, 10, 20, 50 miles within a fifth of the width.
        let miles = [0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0]
            .into_iter()
            .rfind(|m| m * mile <= pw * 0.2)
            .unwrap_or(0.5);
        let bar = miles * mile;
        let _ = write!(
            self.svg,
            "<g><polygon points=\"{0:.1},10 {1:.1},32 {0:.1},26 {2:.1},32\" fill=\"#000\" stroke=\"#fff\"/>\
             <text x=\"{0:.1}\" y=\"46\" font-size=\"13\" font-weight=\"bold\" text-anchor=\"middle\" {HALO}>N</text></g>\
             <g><rect x=\"10\" y=\"{3:.1}\" width=\"{4:.1}\" height=\"7\" fill=\"#000\" stroke=\"#fff\"/>\
             <rect x=\"10\" y=\"{3:.1}\" width=\"{5:.1}\" height=\"7\" fill=\"#fff\" stroke=\"#000\" stroke-width=\"0.5\"/>\
             <text x=\"10\" y=\"{6:.1}\" font-size=\"12\" {HALO}>{7} mi ({8} km)</text></g></svg>",
            pw - 22.0,
            pw - 31.0,
            pw - 13.0,
            ph - 17.0,
            bar,
            bar / 2.0,
            ph - 22.0,
            fmt_num(miles, if miles < 1.0 { 1 } else { 0 }),
            fmt_num(miles * 1.609_344, 1)
        );
        self.svg
    }
}

/// A yellow five-pointed star centred at (x, y), `radius` to its tips, titled `title`.
pub fn star(x: f64, y: f64, radius: f64, title: &str) -> String {
    let points: String = (0..10)
        .map(|k| {
            let r = if k % 2 == 0 { radius } else { radius * 0.4 };
            let a = std::f64::consts::PI * f64::from(k) / 5.0 - std::f64::consts::FRAC_PI_2;
            format!("{:.1},{:.1} ", x + r * a.cos(), y + r * a.sin())
        })
        .collect();
    format!(
        "<polygon points=\"{}\" fill=\"#ffeb3b\" stroke=\"#000\"><title>{}</title></polygon>",
        points.trim_end(),
        esc(title)
    )
}

/// Legend swatches of burn or ignition probabilities (0–1) at `levels`, labelled in percent.
pub fn probability_swatches(levels: &[f64]) -> String {
    levels
        .iter()
        .map(|&p| {
            format!(
                "<span><i class=swf style=\"background:{}\"></i>{:.0} %</span>",
                hex(figures::probability_color(p)),
                p * 100.0
            )
        })
        .collect()
}

/// IGBP class names (MODIS MCD12Q1 type 1), codes 1–17.
const IGBP: [&str; 17] = [
    "Evergreen needleleaf forest",
    "Evergreen broadleaf forest",
    "Deciduous needleleaf forest",
    "Deciduous broadleaf forest",
    "Mixed forest",
    "Closed shrubland",
    "Open shrubland",
    "Woody savanna",
    "Savanna",
    "Grassland",
    "Permanent wetland",
    "Cropland",
    "Urban and built-up",
    "Cropland/natural mosaic",
    "Snow and ice",
    "Barren",
    "Water",
];

/// The land-cover legend of a map: the classes covering at least 1 % of it, most common
/// first, as HTML swatches.
/// `no_data_cells`: cells the landscape's source had no fuel for (LANDFIRE nodata), which the
/// landscape holds as non-burnable code 99 and the legend names as such.
pub fn land_cover_legend(land: &Landscape, no_data_cells: u64) -> String {
    let mut counts: std::collections::BTreeMap<u16, usize> = std::collections::BTreeMap::new();
    for &c in &land.land_cover {
        *counts.entry(c).or_default() += 1;
    }
    let n = land.land_cover.len().max(1);
    let mut classes: Vec<(u16, usize)> = counts.into_iter().filter(|&(_, k)| k * 100 >= n).collect();
    classes.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let mut out = String::from("<div class=legend><b>Land cover:</b> ");
    for (code, k) in classes {
        let name = match land.scheme {
            LandCoverScheme::ModisIgbp => IGBP
                .get(usize::from(code).wrapping_sub(1))
                .map_or_else(|| format!("class {code}"), |s| (*s).to_string()),
            scheme => firecast_episodes::ensemble::fuel_model_of(scheme, code)
                .map_or_else(|| format!("code {code}"), |m| format!("{} {}", m.code, m.name)),
        };
        let name = if code == firecast_episodes::landfire::NODATA_FUEL_CODE && no_data_cells > 0 {
            // Short: legend entries do not wrap, and a printed column is narrow.
            format!(
                "{name} or no fuel data ({:.0} % none)",
                no_data_cells as f64 / n as f64 * 100.0
            )
        } else {
            name
        };
        let _ = write!(
            out,
            "<span><i class=swf style=\"background:{}\"></i>{} {:.0} %</span>",
            hex(firecast_render::palette::land_cover_color(land.scheme, code)),
            esc(&name),
            k as f64 / n as f64 * 100.0
        );
    }
    out.push_str("</div>");
    out
}

/// The legend of arrival bands.
pub fn bands_legend(times: &[f64], what: &str) -> String {
    let mut out = format!("<div class=legend><b>{}:</b> ", esc(what));
    let mut prev = 0.0;
    for (k, &t) in times.iter().enumerate() {
        let _ = write!(
            out,
            "<span><i class=swf style=\"background:{};opacity:.75\"></i>{}–{} h</span>",
            hex(band_color(k, times.len())),
            fmt_num(prev, 0),
            fmt_num(t, 0)
        );
        prev = t;
    }
    out.push_str("</div>");
    out
}
