//! Shaded-relief land-cover basemap.

use firecast_landscape::Landscape;

use crate::palette::{self, land_cover_color};
use crate::{RenderOptions, RgbImage};

/// Feet in a statute mile, the scale-bar unit.
const MILE_FT: f64 = 5280.0;

/// The static background of every frame: land cover × hillshade, upscaled, plus the legend.
#[derive(Debug, Clone, PartialEq)]
pub struct Basemap {
    /// Grid size in cells.
    pub grid_width: usize,
    pub grid_height: usize,
    /// Pixels per cell.
    pub scale: usize,
    /// Ground size of a cell in feet.
    pub cell_size_ft: f64,
    /// Height in pixels of the map part (the legend strip, if any, lies below it).
    pub map_height_px: usize,
    /// Lambertian hillshade per cell in [0, 1], row-major, row 0 south.
    pub shade: Vec<f32>,
    /// The rendered basemap (map + legend strip).
    pub image: RgbImage,
}

impl Basemap {
    /// Render the basemap of `landscape`.
    pub fn new(landscape: &Landscape, options: &RenderOptions) -> Self {
        let (w, h) = (landscape.width, landscape.height);
        let s = options.scale.max(1);
        let shade = hillshade(
            landscape,
            options.sun_azimuth_deg,
            options.sun_altitude_deg,
            options.z_factor,
        );
        let floor = options.shade_floor.clamp(0.0, 1.0);
        let map_h = h * s;
        let legend_h = if options.legend {
            options.legend_height_px
        } else {
            0
        };
        let mut image = RgbImage::new(w * s, map_h + legend_h);
        let row_bytes = w * s * 3;
        let mut row = vec![0u8; row_bytes];
        for gy in 0..h {
            for gx in 0..w {
                let i = gy * w + gx;
                let code = landscape.land_cover.get(i).copied().unwrap_or(0);
                let base = land_cover_color(landscape.scheme, code);
                let k = floor + (1.0 - floor) * shade[i];
                let c = base.map(|v| (f32::from(v) * k).round().clamp(0.0, 255.0) as u8);
                for px in 0..s {
                    let o = (gx * s + px) * 3;
                    row[o..o + 3].copy_from_slice(&c);
                }
            }
            // Row 0 is south: it goes to the bottom of the map.
            let top = (h - 1 - gy) * s;
            for py in 0..s {
                let o = (top + py) * row_bytes;
                image.data[o..o + row_bytes].copy_from_slice(&row);
            }
        }
        let mut basemap = Self {
            grid_width: w,
            grid_height: h,
            scale: s,
            cell_size_ft: landscape.cell_size_ft,
            map_height_px: map_h,
            shade,
            image,
        };
        if legend_h > 0 {
            basemap.draw_legend(options);
        }
        basemap
    }

    /// Width of rendered frames in pixels.
    pub fn width_px(&self) -> usize {
        self.image.width
    }

    /// Height of rendered frames in pixels (map + legend).
    pub fn height_px(&self) -> usize {
        self.image.height
    }

    /// Pixel rectangle `(x0, y0, x1, y1)` (exclusive ends) covered by grid cell (x, y),
    /// `None` outside the grid.
    pub fn cell_rect(&self, x: i64, y: i64) -> Option<(usize, usize, usize, usize)> {
        let (x, y) = (usize::try_from(x).ok()?, usize::try_from(y).ok()?);
        if x >= self.grid_width || y >= self.grid_height {
            return None;
        }
        let s = self.scale;
        let top = (self.grid_height - 1 - y) * s;
        Some((x * s, top, x * s + s, top + s))
    }

    /// Pixel-space centre of grid cell (x, y) (may lie outside the image).
    pub fn cell_center_px(&self, x: f64, y: f64) -> (f64, f64) {
        let s = self.scale as f64;
        ((x + 0.5) * s, (self.grid_height as f64 - 1.0 - y + 0.5) * s)
    }

    /// Legend strip: alternating one-mile scale-bar segments on the left, colour swatches
    /// (fire, burnt, drop, helicopter) on the right. Text-free.
    fn draw_legend(&mut self, options: &RenderOptions) {
        let y0 = self.map_height_px;
        let (w, h) = (self.image.width, self.image.height);
        self.image.fill_rect(0, y0, w, h, palette::LEGEND_BG);
        let strip = h - y0;
        let pad = (strip / 4).max(1);
        let bar_y0 = y0 + strip / 2 - (strip / 6).max(1);
        let bar_y1 = y0 + strip / 2 + (strip / 6).max(1);
        // Swatches, right-aligned.
        let sw = strip.saturating_sub(2 * pad).max(2);
        let burnt = {
            let mut px = [120u8, 120, 120];
            crate::blend_px(&mut px, palette::CHARCOAL, options.burnt_alpha);
            px
        };
        let swatches = [palette::FIRE, burnt, palette::DROP_FILL, palette::HELI_BODY];
        let swatch_x0 = w.saturating_sub(pad + swatches.len() * (sw + pad));
        let mut x = swatch_x0;
        for c in swatches {
            self.image.fill_rect(x, y0 + pad, x + sw, y0 + pad + sw, c);
            x += sw + pad;
        }
        // Scale bar: whole miles, up to 5, within ~40 % of the width and left of the swatches;
        // left out when not even one mile fits.
        let mile_px = MILE_FT / self.cell_size_ft * self.scale as f64;
        if mile_px >= 2.0 && swatch_x0 > 2 * pad + 2 {
            let room = (w as f64 * 0.4).min(swatch_x0 as f64 - 2.0 * pad as f64 - 2.0);
            let miles = ((room / mile_px).floor().max(0.0) as usize).min(5);
            let x_start = pad as f64 + 1.0;
            for m in 0..miles {
                let xa = (x_start + m as f64 * mile_px).round() as usize;
                let xb = (x_start + (m + 1) as f64 * mile_px).round() as usize;
                let c = if m % 2 == 0 {
                    [240, 240, 240]
                } else {
                    [110, 110, 110]
                };
                self.image.fill_rect(xa, bar_y0, xb, bar_y1, c);
                // Tick at the start of every mile.
                self.image
                    .fill_rect(xa, y0 + pad, xa + 1, h - pad, [240, 240, 240]);
            }
            if miles > 0 {
                let xe = (x_start + miles as f64 * mile_px).round() as usize;
                self.image
                    .fill_rect(xe, y0 + pad, xe + 1, h - pad, [240, 240, 240]);
            }
        }
    }
}

/// Horn (1981) hillshade of the landscape's elevation, in [0, 1] per cell (row 0 south).
///
/// Gradients use Horn's 3 × 3 weighted differences with edge cells replicated; elevations
/// and the cell size are both in feet, so `z_factor` is pure vertical exaggeration. The
/// value is the cosine of the angle between the surface normal and the sun direction
/// (azimuth clockwise from north, altitude above the horizon), clamped at 0. A flat cell
/// gets sin(altitude).
pub fn hillshade(landscape: &Landscape, azimuth_deg: f64, altitude_deg: f64, z_factor: f64) -> Vec<f32> {
    let (w, h) = (landscape.width, landscape.height);
    let n = w * h;
    let elev = &landscape.elevation_ft;
    if elev.len() < n || n == 0 {
        return vec![altitude_deg.to_radians().sin() as f32; n];
    }
    let az = azimuth_deg.to_radians();
    let alt = altitude_deg.to_radians();
    // Unit vector towards the sun: x east, y north, z up.
    let sun = [az.sin() * alt.cos(), az.cos() * alt.cos(), alt.sin()];
    let cell = if landscape.cell_size_ft > 0.0 {
        landscape.cell_size_ft
    } else {
        1.0
    };
    let z = |x: isize, y: isize| -> f64 {
        let xi = x.clamp(0, w as isize - 1) as usize;
        let yi = y.clamp(0, h as isize - 1) as usize;
        let v = f64::from(elev[yi * w + xi]);
        if v.is_finite() { v } else { 0.0 }
    };
    let mut out = Vec::with_capacity(n);
    for y in 0..h as isize {
        for x in 0..w as isize {
            // dz/d(east): right column minus left column, rows weighted 1-2-1.
            let gx = ((z(x + 1, y + 1) + 2.0 * z(x + 1, y) + z(x + 1, y - 1))
                - (z(x - 1, y + 1) + 2.0 * z(x - 1, y) + z(x - 1, y - 1)))
                / (8.0 * cell);
            // dz/d(north): grid row y + 1 is north of row y.
            let gy = ((z(x - 1, y + 1) + 2.0 * z(x, y + 1) + z(x + 1, y + 1))
                - (z(x - 1, y - 1) + 2.0 * z(x, y - 1) + z(x + 1, y - 1)))
                / (8.0 * cell);
            let (gx, gy) = (gx * z_factor, gy * z_factor);
            // Surface normal (−gx, −gy, 1), normalised.
            let norm = (gx * gx + gy * gy + 1.0).sqrt();
            let cos = (-gx * sun[0] - gy * sun[1] + sun[2]) / norm;
            out.push(cos.clamp(0.0, 1.0) as f32);
        }
    }
    out
}
