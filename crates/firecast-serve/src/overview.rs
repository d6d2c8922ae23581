//! The overview base map: land cover over hillshade of a FireCast landscape spanning the
//! data's GRIDMET box and a margin, resampled into an image whose axes are longitude and
//! latitude (so the page maps a click to a place linearly). Rendered once per server.

use firecast_landscape::procedural::{self, ProceduralOptions};
use serde::Serialize;

use crate::coverage::Coverage;

const FT_PER_M: f64 = 3.280_839_895;
const M_PER_DEG_LAT: f64 = 111_320.0;
/// Landscape cells across the map's width (the image has two pixels per cell).
const CELLS_ACROSS: usize = 450;

/// Where the base map lies.
#[derive(Debug, Clone, Serialize)]
pub struct OverviewInfo {
    pub url: &'static str,
    pub lat_min: f64,
    pub lat_max: f64,
    pub lon_min: f64,
    pub lon_max: f64,
    pub width: usize,
    pub height: usize,
    pub description: String,
}

/// The PNG and where it lies.
pub struct Overview {
    pub info: OverviewInfo,
    pub png: Vec<u8>,
}

/// A procedural landscape (seed `seed`) over the box and a tenth of it on each side.
pub fn render(coverage: &Coverage, seed: u64) -> Result<Overview, String> {
    let margin_lat = (coverage.lat_max - coverage.lat_min) * 0.1;
    let margin_lon = (coverage.lon_max - coverage.lon_min) * 0.1;
    let (lat_min, lat_max) = (coverage.lat_min - margin_lat, coverage.lat_max + margin_lat);
    let (lon_min, lon_max) = (coverage.lon_min - margin_lon, coverage.lon_max + margin_lon);
    let center_lat = (lat_min + lat_max) / 2.0;
    let center_lon = (lon_min + lon_max) / 2.0;
    let cos = center_lat.to_radians().cos().max(0.05);
    let width_ft = (lon_max - lon_min) * M_PER_DEG_LAT * cos * FT_PER_M;
    let height_ft = (lat_max - lat_min) * M_PER_DEG_LAT * FT_PER_M;
    let cell_ft = width_ft / CELLS_ACROSS as f64;
    // A little extra so the rectangle in degrees lies inside the projected grid.
    let cells_w = CELLS_ACROSS + CELLS_ACROSS / 20;
    let cells_h = (height_ft / cell_ft).ceil() as usize + CELLS_ACROSS / 20;
    let landscape = procedural::generate(&ProceduralOptions {
        width: cells_w,
        height: cells_h,
        cell_size_ft: cell_ft,
        center_lat,
        center_lon,
        ..ProceduralOptions::with_seed(seed)
    })
    .map_err(|e| e.to_string())?;
    let options = firecast_render::RenderOptions {
        scale: 1,
        legend: false,
        ..firecast_render::RenderOptions::default()
    };
    let basemap = firecast_render::basemap::Basemap::new(&landscape, &options);
    let px_w = CELLS_ACROSS * 2;
    let px_h = ((lat_max - lat_min) / ((lon_max - lon_min) * cos) * px_w as f64).round() as usize;
    let mut image = firecast_render::RgbImage::new(px_w, px_h.max(1));
    for py in 0..image.height {
        let lat = lat_max - (py as f64 + 0.5) / image.height as f64 * (lat_max - lat_min);
        for px in 0..image.width {
            let lon = lon_min + (px as f64 + 0.5) / image.width as f64 * (lon_max - lon_min);
            let colour = landscape
                .lat_lon_to_cell(lat, lon)
                .and_then(|(x, y)| basemap.image.pixel(x, landscape.height - 1 - y))
                .unwrap_or([200, 200, 200]);
            image.put(px, py, colour);
        }
    }
    let png = firecast_render::output::encode_png(&image).map_err(|e| e.to_string())?;
    Ok(Overview {
        info: OverviewInfo {
            url: "/api/basemap.png",
            lat_min,
            lat_max,
            lon_min,
            lon_max,
            width: image.width,
            height: image.height,
            description: format!(
                "procedural FireCast landscape (seed {seed}), land cover over hillshade, {:.2} km cells",
                cell_ft / FT_PER_M / 1000.0
            ),
        },
        png,
    })
}
