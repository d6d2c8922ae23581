//! Scientific visualisation for FireCast: shaded-relief basemaps, fire frames, PNG stills
//! and animated GIFs, and charts for model evaluation and fire reports ([`chart`]: x–y
//! charts, heatmaps, bar charts with error bars; text from the embedded bitmap [`font`]).
//!
//! The pipeline is
//!
//! 1. [`Basemap::new`]: land-cover colours ([`palette`]) multiplied by a Horn hillshade of
//!    the elevation grid, upscaled by an integer pixel scale, plus an optional legend strip
//!    (a mile scale bar and colour swatches) at the bottom;
//! 2. [`render_frame`]: one simulation step ([`FireFrame`]: fire state, helicopter cell,
//!    drop centres) drawn over a copy of the basemap;
//! 3. [`write_png`] for stills, [`GifWriter`] for animations. Both write to a hidden
//!    temporary file (`firecast_fs`'s scheme) in the destination folder and rename it into place,
//!    so a reader never sees a half-written file.
//!
//! Grids are row-major with row 0 on the **south** edge (as in `firecast-landscape`);
//! images are drawn north-up, so image row 0 shows grid row `height - 1`.

use std::path::PathBuf;

pub mod basemap;
pub mod chart;
pub mod font;
pub mod frame;
pub mod output;
pub mod palette;

pub use basemap::{Basemap, hillshade};
pub use chart::{
    Bar, BarChart, CellPercent, Chart, Heatmap, LegendPosition, Marker, OKABE_ITO, PlotArea, Series,
    format_ticks, nice_ticks, viridis,
};
pub use font::{
    Align, TextBox, TextStyle, draw_text, draw_text_aligned, draw_text_styled, draw_text_vertical,
    text_height, text_width,
};
pub use frame::{FireFrame, render_frame, render_frame_into};
pub use output::{GifWriter, write_png};

/// An 8-bit RGB raster, row-major, top row first, 3 bytes per pixel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    /// `width * height * 3` bytes: R, G, B of pixel (0, 0), then (1, 0), …
    pub data: Vec<u8>,
}

impl RgbImage {
    /// A black image.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            data: vec![0; width * height * 3],
        }
    }

    /// The colour of pixel (x, y) (y counted from the top), or `None` outside the image.
    pub fn pixel(&self, x: usize, y: usize) -> Option<[u8; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = (y * self.width + x) * 3;
        Some([self.data[i], self.data[i + 1], self.data[i + 2]])
    }

    /// Set pixel (x, y); ignored outside the image.
    pub fn put(&mut self, x: usize, y: usize, c: [u8; 3]) {
        if x < self.width && y < self.height {
            let i = (y * self.width + x) * 3;
            self.data[i..i + 3].copy_from_slice(&c);
        }
    }

    /// Alpha-blend `c` over pixel (x, y) with opacity `alpha` in [0, 1]; ignored outside.
    pub fn blend(&mut self, x: usize, y: usize, c: [u8; 3], alpha: f32) {
        if x < self.width && y < self.height {
            let i = (y * self.width + x) * 3;
            blend_px(&mut self.data[i..i + 3], c, alpha);
        }
    }

    /// Fill the rectangle `[x0, x1) × [y0, y1)`, clipped to the image.
    pub fn fill_rect(&mut self, x0: usize, y0: usize, x1: usize, y1: usize, c: [u8; 3]) {
        let (x1, y1) = (x1.min(self.width), y1.min(self.height));
        for y in y0..y1 {
            for x in x0..x1 {
                self.put(x, y, c);
            }
        }
    }
}

/// Blend `c` over the 3-byte pixel `px` with opacity `alpha`.
#[inline]
pub(crate) fn blend_px(px: &mut [u8], c: [u8; 3], alpha: f32) {
    let a = alpha.clamp(0.0, 1.0);
    for (p, &q) in px.iter_mut().zip(c.iter()) {
        let v = f32::from(*p) * (1.0 - a) + f32::from(q) * a;
        *p = v.round().clamp(0.0, 255.0) as u8;
    }
}

/// How basemaps and frames are drawn. [`Default`] gives a 3 px/cell map with a legend.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Pixels per grid cell along each axis (integer upscaling; 0 is treated as 1).
    pub scale: usize,
    /// Sun azimuth in degrees clockwise from north (315 = north-west).
    pub sun_azimuth_deg: f64,
    /// Sun altitude above the horizon in degrees.
    pub sun_altitude_deg: f64,
    /// Vertical exaggeration applied on top of the unit conversion. Elevations and the cell
    /// size are both in feet, so 1.0 is true relief.
    pub z_factor: f64,
    /// Brightness of a fully shaded cell: colour × (`shade_floor` + (1 − `shade_floor`) × shade).
    pub shade_floor: f32,
    /// Helitack footprint radius in cells (2640 ft / 500 ft = 5.28 by default).
    pub drop_radius_cells: f64,
    /// Opacity of the burnt-cell charcoal over the terrain.
    pub burnt_alpha: f32,
    /// Opacity of the drop-footprint fill (its rim is drawn nearly opaque).
    pub drop_fill_alpha: f32,
    /// Draw the legend strip (mile scale bar + swatches) below the map.
    pub legend: bool,
    /// Height of the legend strip in pixels.
    pub legend_height_px: usize,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            scale: 3,
            sun_azimuth_deg: 315.0,
            sun_altitude_deg: 45.0,
            z_factor: 1.0,
            shade_floor: 0.55,
            drop_radius_cells: 2640.0 / 500.0,
            burnt_alpha: 0.78,
            drop_fill_alpha: 0.35,
            legend: true,
            legend_height_px: 14,
        }
    }
}

/// Errors of rendering and writing. Each I/O error names its path.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("cannot write file: {source}: {path}")]
    Io { source: std::io::Error, path: PathBuf },
    #[error("PNG encoding failed: {source}: {path}")]
    Png {
        source: png::EncodingError,
        path: PathBuf,
    },
    #[error("GIF encoding failed: {source}: {path}")]
    Gif {
        source: gif::EncodingError,
        path: PathBuf,
    },
    /// Image or frame dimensions that the format cannot hold or that do not match.
    #[error("{message}: {path}")]
    Size { message: String, path: PathBuf },
}
