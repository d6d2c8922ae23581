//! One simulation step drawn over the basemap.

use crate::palette;
use crate::{Basemap, RenderOptions, RgbImage, blend_px};

/// Cell states of `FireFrame::fire_state`.
pub const UNBURNT: u8 = 0;
pub const BURNING: u8 = 1;
pub const BURNT: u8 = 2;

/// What one frame shows. Grids are row-major with row 0 on the south edge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FireFrame<'a> {
    /// Per cell: 0 unburnt, 1 burning, 2 burnt (other values are drawn as unburnt).
    pub fire_state: &'a [u8],
    /// Helicopter cell (x, y); a cell outside the grid draws no marker.
    pub helicopter: [i32; 2],
    /// Centres of the helitack drops made at this step.
    pub drops: &'a [[i32; 2]],
}

impl<'a> FireFrame<'a> {
    /// A frame without drops.
    pub fn new(fire_state: &'a [u8], helicopter: [i32; 2]) -> Self {
        Self {
            fire_state,
            helicopter,
            drops: &[],
        }
    }

    /// The same frame with these drop centres.
    pub fn with_drops(self, drops: &'a [[i32; 2]]) -> Self {
        Self { drops, ..self }
    }
}

/// Render `frame` over `basemap` into a new image (see [`render_frame_into`]).
pub fn render_frame(basemap: &Basemap, frame: &FireFrame<'_>, options: &RenderOptions) -> RgbImage {
    let mut out = RgbImage::new(0, 0);
    render_frame_into(basemap, frame, options, &mut out);
    out
}

/// Render `frame` over `basemap` into `out`, reusing its allocation.
///
/// Burning cells are opaque [`palette::FIRE`]; burnt cells are [`palette::CHARCOAL`] at
/// `options.burnt_alpha` over the terrain; each drop is a translucent blue disc of radius
/// `options.drop_radius_cells` with a darker rim; the helicopter is a magenta square with a
/// white outline and a black halo. Cells beyond `fire_state.len()` are drawn as unburnt. Geometry (scale,
/// legend) comes from the basemap; `options` supplies the overlay styling.
pub fn render_frame_into(
    basemap: &Basemap,
    frame: &FireFrame<'_>,
    options: &RenderOptions,
    out: &mut RgbImage,
) {
    out.clone_from(&basemap.image);
    let (gw, gh, s) = (basemap.grid_width, basemap.grid_height, basemap.scale);
    let row_bytes = out.width * 3;
    for gy in 0..gh {
        let states = match frame.fire_state.get(gy * gw..(gy + 1) * gw) {
            Some(r) => r,
            None => break,
        };
        let top = (gh - 1 - gy) * s;
        for (gx, &st) in states.iter().enumerate() {
            if st != BURNING && st != BURNT {
                continue;
            }
            for py in 0..s {
                let o = (top + py) * row_bytes + gx * s * 3;
                let px = &mut out.data[o..o + s * 3];
                if st == BURNING {
                    for c in px.chunks_exact_mut(3) {
                        c.copy_from_slice(&palette::FIRE);
                    }
                } else {
                    for c in px.chunks_exact_mut(3) {
                        blend_px(c, palette::CHARCOAL, options.burnt_alpha);
                    }
                }
            }
        }
    }
    for &[x, y] in frame.drops {
        draw_drop(basemap, out, x, y, options);
    }
    draw_helicopter(basemap, out, frame.helicopter);
}

/// Translucent disc with a rim, clipped to the map area.
fn draw_drop(basemap: &Basemap, out: &mut RgbImage, x: i32, y: i32, options: &RenderOptions) {
    let s = basemap.scale as f64;
    let (cx, cy) = basemap.cell_center_px(f64::from(x), f64::from(y));
    let r = options.drop_radius_cells.max(0.0) * s;
    let rim = (s * 0.5).clamp(1.0, 2.0);
    let x0 = (cx - r - 1.0).floor().max(0.0) as usize;
    let y0 = (cy - r - 1.0).floor().max(0.0) as usize;
    let x1 = ((cx + r + 1.0).ceil().max(0.0) as usize).min(out.width);
    let y1 = ((cy + r + 1.0).ceil().max(0.0) as usize).min(basemap.map_height_px);
    for py in y0..y1 {
        for px in x0..x1 {
            let dx = px as f64 + 0.5 - cx;
            let dy = py as f64 + 0.5 - cy;
            let d = (dx * dx + dy * dy).sqrt();
            if d <= r {
                if d > r - rim {
                    out.blend(px, py, palette::DROP_RIM, 0.9);
                } else {
                    out.blend(px, py, palette::DROP_FILL, options.drop_fill_alpha);
                }
            }
        }
    }
}

/// Magenta square with a white outline and a thin black halo, centred on the helicopter
/// cell and clipped to the map area.
fn draw_helicopter(basemap: &Basemap, out: &mut RgbImage, [x, y]: [i32; 2]) {
    if basemap.cell_rect(i64::from(x), i64::from(y)).is_none() {
        return;
    }
    let (cx, cy) = basemap.cell_center_px(f64::from(x), f64::from(y));
    let half = (basemap.scale as f64 * 2.0).max(4.0);
    let x0 = (cx - half).floor().max(0.0) as usize;
    let y0 = (cy - half).floor().max(0.0) as usize;
    let x1 = ((cx + half).ceil() as usize).min(out.width);
    let y1 = ((cy + half).ceil() as usize).min(basemap.map_height_px);
    for py in y0..y1 {
        for px in x0..x1 {
            let ring = (px - x0).min(py - y0).min(x1 - 1 - px).min(y1 - 1 - py);
            let c = match ring {
                0 => [0, 0, 0],
                1 | 2 => palette::HELI_OUTLINE,
                _ => palette::HELI_BODY,
            };
            out.put(px, py, c);
        }
    }
}
