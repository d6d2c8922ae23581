//! Synthetic landscapes for the automaton, environment and agent tests.

use firecast_landscape::{GeoReference, LandCoverScheme, Landscape};

fn georef() -> GeoReference {
    GeoReference {
        crs: "EPSG:32611".into(),
        origin_x: 0.0,
        origin_y: 0.0,
        cell_size_x: 152.4,
        cell_size_y: 152.4,
    }
}

/// A landscape from a class function and an elevation function of (x, y).
pub fn landscape(
    w: usize,
    h: usize,
    scheme: LandCoverScheme,
    class: impl Fn(usize, usize) -> u16,
    elev: impl Fn(usize, usize) -> f32,
) -> Landscape {
    let mut lc = Vec::with_capacity(w * h);
    let mut el = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            lc.push(class(x, y));
            el.push(elev(x, y));
        }
    }
    Landscape::new(w, h, 500.0, scheme, lc, el, georef()).unwrap()
}

/// Deterministic per-cell noise in [0, 1).
pub fn noise(x: usize, y: usize, salt: u64) -> f32 {
    let mut z = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ salt;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
}

/// Rough hilly terrain (the P2 kernel spreads only across elevation differences).
pub fn rough(x: usize, y: usize) -> f32 {
    let (xf, yf) = (x as f32, y as f32);
    1000.0 + 300.0 * (xf / 13.0).sin() * (yf / 17.0).cos() + 60.0 * noise(x, y, 7)
}

/// 240×160 MODIS map of one class on rough terrain.
pub fn modis_rough(class: u16) -> Landscape {
    landscape(240, 160, LandCoverScheme::ModisIgbp, |_, _| class, rough)
}
