//! FireCastRL map images (docs/spec/fire-model.md §A2): a land-cover palette PNG and a 16-bit
//! heightmap PNG, sampled onto the simulation grid exactly as FireCastRL P2 (`populate_grid`
//! in `firecastrl_env/envs/environment/helper.py`, itself Concord's `populateGrid`) does:
//!
//! - the walk starts at the **bottom** image row (grid row 0 = south) and the left column;
//! - land cover (no interpolation): the image index advances by `W/w` columns and `H/h`
//!   rows per grid cell, accumulated in f64 and truncated — nearest-neighbour sampling;
//! - heightmap (interpolation): the steps are `(W−1)/(w−1)` and `(H−1)/(h−1)`, and the value
//!   is the bilinear blend of the current pixel, its east neighbour and the pixel one row up
//!   (north), with the same edge fallbacks;
//! - colours map to MODIS IGBP classes 1–17 by exact RGB match (alpha ignored), unknown → 1;
//! - height = ((R << 8) | G) / 65535 × `max_elevation_ft` (10,000 ft);
//! - `fill_terrain_edges` sets the outermost ring of grid cells to elevation 0.
//!
//! Python would index out of range (or wrap negative rows) if float accumulation overshot the
//! image; we clamp indices instead. Palette, grey and 16-bit PNGs are normalised to 8-bit RGBA
//! first (like PIL's `convert("RGBA")`, 16-bit channels keep their high byte).
//!
//! The images carry no georeference; [`FireCastRlOptions`] places the grid with
//! [`GridSpec::geographic_centered`] (default: FireCastRL's demo point, Pacific Palisades).

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use crate::georef::GridSpec;
use crate::{LandCoverScheme, Landscape, LandscapeError};

/// MODIS IGBP class → palette RGB (docs/spec/fire-model.md §A2.1).
pub const PALETTE: [(u16, [u8; 3]); 17] = [
    (1, [0, 100, 0]),
    (2, [34, 139, 34]),
    (3, [50, 205, 50]),
    (4, [0, 128, 0]),
    (5, [60, 179, 113]),
    (6, [240, 230, 140]),
    (7, [218, 165, 32]),
    (8, [128, 128, 0]),
    (9, [154, 205, 50]),
    (10, [144, 238, 144]),
    (11, [143, 188, 143]),
    (12, [210, 180, 140]),
    (13, [128, 128, 128]),
    (14, [222, 184, 135]),
    (15, [255, 255, 255]),
    (16, [211, 211, 211]),
    (17, [0, 0, 255]),
];

/// Default heightmap scale, ft.
pub const HEIGHTMAP_MAX_ELEVATION_FT: f64 = 10_000.0;

/// Exact-match palette lookup; unknown colours → 1.
pub fn palette_class(rgb: [u8; 3]) -> u16 {
    PALETTE.iter().find(|(_, c)| *c == rgb).map_or(1, |(k, _)| *k)
}

/// Palette colour of a class.
pub fn class_color(class: u16) -> Option<[u8; 3]> {
    PALETTE.iter().find(|(k, _)| *k == class).map(|(_, c)| *c)
}

/// Decoded 16-bit height of a heightmap pixel, in ft: ((R << 8) | G) / 65535 × max.
pub fn height_ft(r: u8, g: u8, max_elevation_ft: f64) -> f64 {
    f64::from((u16::from(r) << 8) | u16::from(g)) / 65535.0 * max_elevation_ft
}

/// An 8-bit RGBA image, row 0 at the top.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbaImage {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<[u8; 4]>,
}

fn png_err(path: &Path, e: impl std::fmt::Display) -> LandscapeError {
    LandscapeError::Format {
        format: "PNG",
        message: e.to_string(),
        path: path.to_path_buf(),
    }
}

/// Read a PNG as 8-bit RGBA.
pub fn read_png_rgba(path: impl AsRef<Path>) -> Result<RgbaImage, LandscapeError> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|source| LandscapeError::Io {
        source,
        path: path.to_path_buf(),
    })?;
    let mut dec = png::Decoder::new(BufReader::new(file));
    dec.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = dec.read_info().map_err(|e| png_err(path, e))?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| png_err(path, "image too large"))?;
    let mut buf = vec![0u8; size];
    let info = reader.next_frame(&mut buf).map_err(|e| png_err(path, e))?;
    let (w, h) = (info.width as usize, info.height as usize);
    let bytes = &buf[..info.buffer_size()];
    let line = info.line_size;
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => return Err(png_err(path, "indexed colour was not expanded")),
    };
    if info.bit_depth != png::BitDepth::Eight || w == 0 || h == 0 {
        return Err(png_err(
            path,
            format!("unsupported {:?} {w}x{h} image", info.bit_depth),
        ));
    }
    let mut pixels = Vec::with_capacity(w * h);
    for row in 0..h {
        let r = bytes
            .get(row * line..row * line + w * channels)
            .ok_or_else(|| png_err(path, "truncated image data"))?;
        for p in r.chunks_exact(channels) {
            pixels.push(match channels {
                1 => [p[0], p[0], p[0], 255],
                2 => [p[0], p[0], p[0], p[1]],
                3 => [p[0], p[1], p[2], 255],
                _ => [p[0], p[1], p[2], p[3]],
            });
        }
    }
    Ok(RgbaImage {
        width: w,
        height: h,
        pixels,
    })
}

/// FireCastRL's `populate_grid`: sample a row-major image (row 0 at the top) onto a
/// `width × height` grid whose row 0 is the bottom image row. See the module docs.
pub fn populate_grid(
    width: usize,
    height: usize,
    image: &[f64],
    image_width: usize,
    image_height: usize,
    interpolate: bool,
) -> Vec<f64> {
    let mut out = Vec::with_capacity(width * height);
    if image_width == 0 || image_height == 0 || image.len() < image_width * image_height {
        return out;
    }
    let px = |r: usize, c: usize| image[r * image_width + c];
    let step = |img: usize, grid: usize| {
        if interpolate {
            if grid > 1 {
                (img - 1) as f64 / (grid - 1) as f64
            } else {
                0.0
            }
        } else {
            img as f64 / grid as f64
        }
    };
    let (row_step, col_step) = (step(image_height, height), step(image_width, width));
    let mut row_idx = image_height as i64 - 1;
    let mut row_adv = 0.0f64;
    for _ in 0..height {
        let r = row_idx.clamp(0, image_height as i64 - 1) as usize;
        let mut col_idx = 0usize;
        let mut col_adv = 0.0f64;
        for _ in 0..width {
            let c = col_idx.min(image_width - 1);
            let bl = px(r, c);
            let value = if interpolate {
                let has_right = c + 1 < image_width;
                let has_up = r >= 1;
                let br = if has_right { px(r, c + 1) } else { bl };
                let tl = if has_up { px(r - 1, c) } else { bl };
                let tr = match (has_up, has_right) {
                    (true, true) => px(r - 1, c + 1),
                    (true, false) => tl,
                    (false, _) => br,
                };
                bl * (1.0 - col_adv) * (1.0 - row_adv)
                    + br * col_adv * (1.0 - row_adv)
                    + tl * (1.0 - col_adv) * row_adv
                    + tr * col_adv * row_adv
            } else {
                bl
            };
            out.push(value);
            col_adv += col_step;
            if col_adv >= 1.0 {
                let a = col_adv.trunc();
                col_idx += a as usize;
                col_adv -= a;
            }
        }
        row_adv += row_step;
        if row_adv >= 1.0 {
            let a = row_adv.trunc();
            row_idx -= a as i64;
            row_adv -= a;
        }
    }
    out
}

/// Land-cover classes of an RGBA image on a `width × height` grid (nearest, row 0 south).
pub fn land_cover_from_image(img: &RgbaImage, width: usize, height: usize) -> Vec<u16> {
    let codes: Vec<f64> = img
        .pixels
        .iter()
        .map(|p| f64::from(palette_class([p[0], p[1], p[2]])))
        .collect();
    populate_grid(width, height, &codes, img.width, img.height, false)
        .into_iter()
        .map(|v| v as u16)
        .collect()
}

/// Heightmap elevations (ft) of an RGBA image on a `width × height` grid (bilinear, row 0 south).
pub fn elevation_from_image(
    img: &RgbaImage,
    width: usize,
    height: usize,
    max_elevation_ft: f64,
    fill_terrain_edges: bool,
) -> Vec<f32> {
    let h: Vec<f64> = img
        .pixels
        .iter()
        .map(|p| height_ft(p[0], p[1], max_elevation_ft))
        .collect();
    let mut out: Vec<f32> = populate_grid(width, height, &h, img.width, img.height, true)
        .into_iter()
        .map(|v| v as f32)
        .collect();
    if fill_terrain_edges {
        for y in 0..height {
            for x in 0..width {
                if x == 0 || y == 0 || x + 1 == width || y + 1 == height {
                    out[y * width + x] = 0.0;
                }
            }
        }
    }
    out
}

/// Options for [`load`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FireCastRlOptions {
    pub width: usize,
    pub height: usize,
    pub cell_size_ft: f64,
    pub max_elevation_ft: f64,
    pub fill_terrain_edges: bool,
    /// Where to place the (un-georeferenced) map.
    pub center_lat: f64,
    pub center_lon: f64,
}

impl Default for FireCastRlOptions {
    /// 240 × 160 cells of 500 ft, 10,000 ft heightmap scale, edges filled, centred on
    /// FireCastRL's demo point (34.07022, −118.54453).
    fn default() -> Self {
        Self {
            width: 240,
            height: 160,
            cell_size_ft: 500.0,
            max_elevation_ft: HEIGHTMAP_MAX_ELEVATION_FT,
            fill_terrain_edges: true,
            center_lat: 34.07022,
            center_lon: -118.54453,
        }
    }
}

/// Load `landcover_N.png` + `heightmap_N.png` into a MODIS-IGBP landscape.
pub fn load(
    land_cover_png: impl AsRef<Path>,
    heightmap_png: impl AsRef<Path>,
    opts: &FireCastRlOptions,
) -> Result<Landscape, LandscapeError> {
    let grid = GridSpec::geographic_centered(
        opts.width,
        opts.height,
        opts.cell_size_ft,
        opts.center_lat,
        opts.center_lon,
    )?;
    if !(opts.max_elevation_ft.is_finite() && opts.max_elevation_ft >= 0.0) {
        return Err(LandscapeError::InvalidOption {
            name: "max_elevation_ft",
            message: format!("{} must be finite and >= 0", opts.max_elevation_ft),
        });
    }
    let lc = read_png_rgba(land_cover_png)?;
    let hm = read_png_rgba(heightmap_png)?;
    let classes = land_cover_from_image(&lc, opts.width, opts.height);
    let elev = elevation_from_image(
        &hm,
        opts.width,
        opts.height,
        opts.max_elevation_ft,
        opts.fill_terrain_edges,
    );
    Landscape::new(
        grid.width,
        grid.height,
        grid.cell_size_ft,
        LandCoverScheme::ModisIgbp,
        classes,
        elev,
        grid.georef,
    )
}
