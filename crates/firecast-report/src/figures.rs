//! The report's pictures, as PNG bytes (embedded in the HTML as data URIs): the shaded-relief
//! basemap, the burn-probability map, burnt area over time, and the fire-characteristics
//! (haul) chart.

use base64::Engine;
use firecast_episodes::ensemble::Ensemble;
use firecast_landscape::Landscape;
use firecast_render::{Basemap, Chart, RenderOptions, RgbImage, Series};

use crate::ReportError;
use crate::model::{FireBehaviour, StrategySummary};

/// Width of every map in the report, in SVG units (pixels at 100 %): whatever the grid's size,
/// symbols and labels keep their size on the page.
pub const MAP_WIDTH: f64 = 900.0;

/// Pixels per cell of the maps' rasters: about [`MAP_WIDTH`] wide, at least one per cell.
pub fn raster_scale(width: usize) -> usize {
    ((MAP_WIDTH / width.max(1) as f64).round() as usize).max(1)
}

/// Map units per cell of the maps' vector layers (lines, symbols).
pub fn vector_scale(width: usize) -> f64 {
    MAP_WIDTH / width.max(1) as f64
}

/// Strategy colours, shared by charts and the map.
pub fn strategy_color(s: &str) -> [u8; 3] {
    match s {
        "none" => [200, 40, 30],
        "rule" => [230, 150, 20],
        "rule-concentric" => [150, 100, 200],
        "chaser" => [40, 150, 90],
        "ppo" => [20, 110, 200],
        _ => [90, 90, 90],
    }
}

pub fn hex(c: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// PNG bytes of an image.
pub fn png_bytes(image: &RgbImage) -> Result<Vec<u8>, ReportError> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, image.width as u32, image.height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc
            .write_header()
            .map_err(|e| ReportError::Figure(e.to_string()))?;
        w.write_image_data(&image.data)
            .map_err(|e| ReportError::Figure(e.to_string()))?;
    }
    Ok(out)
}

pub fn data_uri(png: &[u8]) -> String {
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(png)
    )
}

fn map_options(scale: usize) -> RenderOptions {
    RenderOptions {
        scale,
        legend: false,
        ..RenderOptions::default()
    }
}

/// Land cover over hillshade, no legend strip.
pub fn basemap(land: &Landscape) -> RgbImage {
    basemap_at(land, raster_scale(land.width))
}

/// The basemap at `scale` pixels per cell.
pub fn basemap_at(land: &Landscape, scale: usize) -> RgbImage {
    Basemap::new(land, &map_options(scale)).image
}

/// The pixels of `window` (cells: x0, y0 from the south-west, width, height) of a map image
/// drawn at `scale` pixels per cell of a grid `grid_height` cells high (row 0 north).
pub fn crop(img: &RgbImage, scale: usize, grid_height: usize, window: [usize; 4]) -> RgbImage {
    let [x0, y0, w, h] = window;
    let (px0, py0) = (x0 * scale, (grid_height - y0 - h) * scale);
    let mut out = RgbImage::new(w * scale, h * scale);
    for row in 0..h * scale {
        let src = ((py0 + row) * img.width + px0) * 3;
        let dst = row * out.width * 3;
        out.data[dst..dst + w * scale * 3].copy_from_slice(&img.data[src..src + w * scale * 3]);
    }
    out
}

/// The basemap faded toward white, under coloured layers that must stand out from the land
/// cover (arrival bands, burn probability).
pub fn faded_basemap(land: &Landscape, scale: usize) -> RgbImage {
    let mut img = basemap_at(land, scale);
    for p in img.data.iter_mut() {
        *p = (f32::from(*p) * 0.55 + 255.0 * 0.45) as u8;
    }
    img
}

/// Colour of a burn probability in (0, 1]: pale yellow → orange → dark red.
pub fn probability_color(p: f64) -> [u8; 3] {
    let stops: [(f64, [f64; 3]); 4] = [
        (0.0, [255.0, 240.0, 150.0]),
        (0.33, [253.0, 160.0, 60.0]),
        (0.66, [225.0, 60.0, 30.0]),
        (1.0, [120.0, 0.0, 20.0]),
    ];
    let p = p.clamp(0.0, 1.0);
    for w in stops.windows(2) {
        let ((a, ca), (b, cb)) = (w[0], w[1]);
        if p <= b {
            let t = (p - a) / (b - a);
            return [0, 1, 2].map(|k| (ca[k] + t * (cb[k] - ca[k])).round() as u8);
        }
    }
    [120, 0, 20]
}

/// The basemap, faded, with every cell that burned in any run coloured by its burn
/// probability.
pub fn burn_probability(land: &Landscape, e: &Ensemble, scale: usize) -> RgbImage {
    let mut img = faded_basemap(land, scale);
    let (w, h, s) = (land.width, land.height, scale);
    let runs = e.runs() as f64;
    for y in 0..h {
        for x in 0..w {
            let c = e.burn_count[y * w + x];
            if c == 0 {
                continue;
            }
            let color = probability_color(f64::from(c) / runs);
            let top = (h - 1 - y) * s;
            img.fill_rect(x * s, top, x * s + s, top + s, color);
        }
    }
    img
}

/// Burnt area (acres) over hours, one line per strategy with its 10–90 % band.
/// Colour of the verified engine's free fire where it is drawn beside the strategies.
pub const FREE_FIRE_COLOR: [u8; 3] = [74, 20, 140];

/// Burnt area over hours, one line per strategy with its 10–90 % band, and the verified
/// engine's free fire (`free`) beside them when given.
pub fn burnt_area_chart(strategies: &[StrategySummary], free: Option<&StrategySummary>) -> RgbImage {
    let mut chart = Chart::new(900, 460)
        .title("Burnt area over time (mean, band: 10th-90th percentile of runs)")
        .x_label("hours after ignition")
        .y_label("acres burnt")
        // Fires grow toward the top right: the legend goes where they have not been.
        .legend(Some(firecast_render::chart::LegendPosition::TopLeft));
    let free = free.map(|f| StrategySummary {
        label: "Free fire (verified MTT engine)".into(),
        strategy: "free-spread".into(),
        ..f.clone()
    });
    for s in strategies.iter().chain(free.as_ref()) {
        let color = if s.strategy == "free-spread" {
            FREE_FIRE_COLOR
        } else {
            strategy_color(&s.strategy)
        };
        let pts: Vec<(f64, f64)> = s
            .series_hours
            .iter()
            .zip(&s.series_acres_mean)
            .map(|(&h, &a)| (h, a))
            .collect();
        let band: Vec<(f64, f64, f64)> = s
            .series_hours
            .iter()
            .zip(s.series_acres_p10.iter().zip(&s.series_acres_p90))
            .map(|(&h, (&lo, &hi))| (h, lo, hi))
            .collect();
        chart.push(
            Series::line(pts)
                .label(s.label.clone())
                .color(color)
                .with_band(band),
        );
    }
    chart.render()
}

/// Fire-characteristics chart (Andrews & Rothermel 1982): heat per unit area against rate of
/// spread, with the flame-length curves of the suppression limits (4, 8, 11 ft) and the day's
/// head fire.
pub fn haul_chart(fb: &FireBehaviour) -> RgbImage {
    let hpa = fb.heat_per_unit_area.field;
    let ros = fb.rate_of_spread.field;
    let x_max = (hpa * 1.6).max(1000.0);
    // Byram: FL = 0.45·I^0.46 (ft, Btu/ft/s); I = H·R with R in ft/s.
    let ros_at = |flame_ft: f64, h: f64| {
        let i = (flame_ft / 0.45).powf(1.0 / 0.46);
        i / h * 3600.0 / 66.0
    };
    let y_max = (ros * 1.6).max(ros_at(11.0, x_max) * 1.2).max(10.0);
    let mut chart = Chart::new(900, 520)
        .title("Fire characteristics chart (head fire at the ignition point)")
        .x_label("heat per unit area, Btu/ft2")
        .y_label("rate of spread, ch/h")
        .x_range(0.0, x_max)
        .y_range(0.0, y_max);
    for (ft, label, color) in [
        (4.0, "4 ft: hand crews", [60, 160, 60]),
        (8.0, "8 ft: engines, dozers", [230, 150, 20]),
        (11.0, "11 ft: no direct attack", [200, 40, 30]),
    ] {
        let pts: Vec<(f64, f64)> = (1..=200)
            .map(|k| {
                let h = x_max * f64::from(k) / 200.0;
                (h, ros_at(ft, h).min(y_max * 2.0))
            })
            .collect();
        chart.push(Series::line(pts).label(label).color(color));
    }
    chart.push(
        Series::scatter([(hpa, ros)])
            .label(format!("today: {:.1} ft flames", fb.flame_length.field))
            .color([20, 20, 20])
            .marker(firecast_render::Marker::Diamond, 14.0),
    );
    chart.render()
}
