//! What a person sees: FireCast's rate of spread on the Worcester LANDFIRE clip beside
//! FlamMap 6's, and their relative difference, as one PNG. Written to a temporary folder, or to
//! `$FIRECAST_BEHAVIOR_PNG` (the docs' `docs/results/fire-behavior-ros.png` is made that way).

use firecast_landscape::gridio::read_band_f32;
use firecast_landscape::landfire::{FuelLayer, LandfireLandscape};
use firecast_render::{RgbImage, draw_text, viridis, write_png};
use firecast_sim::behavior::{
    BehaviorParams, FuelChoice, MoisturePercent, SlopeMode, surface_behavior_grids,
};

const GREY: [u8; 3] = [200, 200, 200];

/// sqrt-scaled viridis over 0–40 ch/h; nodata grey, no fire white.
fn ros_color(v: f32, fire: bool) -> [u8; 3] {
    if !fire {
        return [255, 255, 255];
    }
    viridis((f64::from(v) / 40.0).sqrt())
}

/// Blue (ours lower) – white – red (ours higher), saturating at ±0.5 %.
fn diff_color(rel: f64) -> [u8; 3] {
    let t = (rel / 0.005).clamp(-1.0, 1.0);
    let fade = |c: f64| (255.0 - (255.0 - c) * t.abs()) as u8;
    if t >= 0.0 {
        [fade(202.0), fade(0.0), fade(32.0)]
    } else {
        [fade(5.0), fade(113.0), fade(176.0)]
    }
}

#[test]
fn ros_beside_flammap_png() {
    let fixtures = std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("../firecast-landscape/tests/fixtures/landfire-worcester");
    let land = LandfireLandscape::read_dir(&fixtures.join("landfire"), FuelLayer::Fbfm40).unwrap();
    let params = BehaviorParams {
        fuel: FuelChoice::Fbfm40,
        moisture: MoisturePercent {
            dead_1h: 6.0,
            dead_10h: 8.0,
            dead_100h: 10.0,
            live_herbaceous: 75.0,
            live_woody: 60.0,
        },
        wind_20ft_mph: 0.0,
        wind_from_deg: 0.0,
        slope: SlopeMode::LcpWholeDegrees,
        wind_limit: false,
        // Surface fire everywhere: the picture compares FlamMap's surface cells.
        crown: firecast_sim::crown::CrownMethod::None,
        foliar_moisture_pct: 120.0,
    };
    let ours = surface_behavior_grids(&land, &params).unwrap();
    let (w, h, flammap) = read_band_f32(&fixtures.join("flammap/ROS_ch_hr.tif")).unwrap();
    let (_, _, fire_type) = read_band_f32(&fixtures.join("flammap/fire_type.tif")).unwrap();
    let (gap, header) = (12, 34);
    let mut img = RgbImage::new(3 * w + 4 * gap, h + header + gap);
    img.fill_rect(0, 0, img.width, img.height, [255, 255, 255]);
    let titles = [
        "FireCast ROS, ch/h (sqrt scale 0-40)",
        "FlamMap 6 ROS, ch/h",
        "FireCast / FlamMap - 1 (+-0.5 %)",
    ];
    for (k, title) in titles.iter().enumerate() {
        let x0 = gap + k * (w + gap);
        draw_text(&mut img, x0 as i64, 10, title, 2, [0, 0, 0]);
        for row in 0..h {
            for col in 0..w {
                let i = row * w + col;
                let nodata = land.fuel[i].is_none();
                let c = if nodata {
                    GREY
                } else {
                    match k {
                        0 => ros_color(ours.ros_chph[i], ours.fire_type[i] == 1.0),
                        1 => ros_color(flammap[i], fire_type[i] >= 1.0),
                        _ if fire_type[i] == 1.0 => {
                            diff_color(f64::from(ours.ros_chph[i]) / f64::from(flammap[i]) - 1.0)
                        }
                        // FlamMap's crown cells: black (this picture compares surface fire).
                        _ if fire_type[i] >= 2.0 => [0, 0, 0],
                        _ => [255, 255, 255],
                    }
                };
                img.put(x0 + col, header + row, c);
            }
        }
    }
    let path = std::env::var_os("FIRECAST_BEHAVIOR_PNG").map_or_else(
        || std::env::temp_dir().join(format!("firecast-behavior-{}.png", std::process::id())),
        std::path::PathBuf::from,
    );
    write_png(&img, &path).unwrap();
    assert!(std::fs::metadata(&path).unwrap().len() > 10_000);
    if std::env::var_os("FIRECAST_BEHAVIOR_PNG").is_none() {
        std::fs::remove_file(&path).ok();
    }
}
