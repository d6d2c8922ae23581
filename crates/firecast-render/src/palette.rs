//! Colours: land-cover / fuel-model palettes and the overlay colours.

use firecast_landscape::LandCoverScheme;

/// Burning cells (opaque).
pub const FIRE: [u8; 3] = [255, 69, 0];
/// Burnt cells (blended over the terrain with `RenderOptions::burnt_alpha`).
pub const CHARCOAL: [u8; 3] = [38, 34, 32];
/// Drop-footprint fill (translucent).
pub const DROP_FILL: [u8; 3] = [30, 144, 255];
/// Drop-footprint rim.
pub const DROP_RIM: [u8; 3] = [0, 70, 220];
/// Helicopter marker body and outline.
pub const HELI_BODY: [u8; 3] = [255, 0, 255];
pub const HELI_OUTLINE: [u8; 3] = [255, 255, 255];
/// Legend strip background.
pub const LEGEND_BG: [u8; 3] = [24, 24, 24];
/// Colour of a code the palette does not know.
pub const UNKNOWN: [u8; 3] = [200, 200, 200];

/// MODIS IGBP classes 1–17, the FireCastRL colours of docs/spec/fire-model.md §A2.1.
const IGBP: [[u8; 3]; 17] = [
    [0, 100, 0],     // 1 Evergreen Needleleaf
    [34, 139, 34],   // 2 Evergreen Broadleaf
    [50, 205, 50],   // 3 Deciduous Needleleaf
    [0, 128, 0],     // 4 Deciduous Broadleaf
    [60, 179, 113],  // 5 Mixed Forest
    [240, 230, 140], // 6 Closed Shrublands
    [218, 165, 32],  // 7 Open Shrublands
    [128, 128, 0],   // 8 Woody Savannas
    [154, 205, 50],  // 9 Savannas
    [144, 238, 144], // 10 Grasslands
    [143, 188, 143], // 11 Permanent Wetlands
    [210, 180, 140], // 12 Croplands
    [128, 128, 128], // 13 Urban
    [222, 184, 135], // 14 Cropland Mosaic
    [255, 255, 255], // 15 Snow/Ice
    [211, 211, 211], // 16 Barren
    [0, 0, 255],     // 17 Water
];

/// Colour of a land-cover / fuel-model code under `scheme`.
pub fn land_cover_color(scheme: LandCoverScheme, code: u16) -> [u8; 3] {
    match scheme {
        LandCoverScheme::ModisIgbp => match code {
            1..=17 => IGBP[usize::from(code - 1)],
            _ => UNKNOWN,
        },
        LandCoverScheme::Fbfm13 => fbfm13(code),
        LandCoverScheme::Fbfm40 => fbfm40(code),
    }
}

/// Non-burnable LANDFIRE codes 91–99 (shared by FBFM13 and FBFM40).
fn non_burnable(code: u16) -> Option<[u8; 3]> {
    Some(match code {
        91 => [128, 128, 128], // urban / developed
        92 => [245, 245, 250], // snow / ice
        93 => [205, 195, 150], // agriculture
        98 => [40, 90, 220],   // open water
        99 => [185, 185, 180], // barren
        94..=97 => [160, 160, 160],
        _ => return None,
    })
}

fn fbfm13(code: u16) -> [u8; 3] {
    if let Some(c) = non_burnable(code) {
        return c;
    }
    match code {
        1 => [235, 225, 100], // short grass: yellow
        2 => [205, 190, 80],  // timber (grass and understory)
        3 => [240, 200, 60],  // tall grass: deep yellow
        4 => [140, 125, 55],  // chaparral: olive
        5 => [195, 170, 110], // brush: tan
        6 => [180, 150, 95],  // dormant brush
        7 => [160, 150, 80],  // southern rough: olive
        8 => [30, 100, 40],   // closed timber litter: dark green
        9 => [55, 125, 50],   // hardwood litter
        10 => [45, 145, 70],  // timber understory: green
        11 => [170, 120, 75], // light slash: brown
        12 => [145, 95, 55],  // medium slash
        13 => [115, 70, 40],  // heavy slash
        _ => UNKNOWN,
    }
}

/// Linear ramp from `a` (t = 0) to `b` (t = 1).
fn ramp(a: [u8; 3], b: [u8; 3], t: f32) -> [u8; 3] {
    let mut out = [0u8; 3];
    for k in 0..3 {
        let v = f32::from(a[k]) + (f32::from(b[k]) - f32::from(a[k])) * t.clamp(0.0, 1.0);
        out[k] = v.round() as u8;
    }
    out
}

fn fbfm40(code: u16) -> [u8; 3] {
    if let Some(c) = non_burnable(code) {
        return c;
    }
    // (first code, last code, lightest colour, heaviest-load colour)
    let groups: [(u16, u16, [u8; 3], [u8; 3]); 6] = [
        (101, 109, [245, 235, 120], [220, 180, 40]), // GR grass: yellows
        (121, 124, [215, 200, 100], [170, 160, 70]), // GS grass-shrub: yellow-olive
        (141, 149, [205, 180, 125], [125, 115, 50]), // SH shrub: tan → olive
        (161, 165, [90, 165, 80], [40, 120, 55]),    // TU timber-understory: greens
        (181, 189, [45, 115, 45], [15, 70, 30]),     // TL timber litter: dark greens
        (201, 204, [175, 125, 80], [110, 65, 35]),   // SB slash-blowdown: browns
    ];
    for (lo, hi, a, b) in groups {
        if (lo..=hi).contains(&code) {
            let t = f32::from(code - lo) / f32::from((hi - lo).max(1));
            return ramp(a, b, t);
        }
    }
    UNKNOWN
}
