//! Seeded procedural landscapes (MODIS IGBP classes, real elevations in feet).
//!
//! Everything is drawn from one `ChaCha8Rng` seeded with [`ProceduralOptions::seed`], so the
//! same options give a bit-identical landscape on every platform and every seed is a new,
//! held-out map.
//!
//! - **Relief**: summed-octave value noise (smoothstep-interpolated random lattices, wavelength
//!   halving and amplitude × `persistence` per octave), min–max normalised, raised to the
//!   power 1.4 (flat basins, steeper tops), then `min_elevation_ft + relief_ft · h`.
//! - **Moisture**: its own octave noise blended with "lowness" (1 − h) and a north-facing
//!   bonus (slopes falling toward +y are wetter).
//! - **Classes** from the elevation rank r and moisture rank q (both uniform in [0, 1]):
//!   water (17) in the lowest `water_fraction` of cells (the low basins), wetlands (11) just
//!   above where wet; the top 4 % barren (16), the top 1.5 % snow (15) if above `snowline_ft`;
//!   wet and high → forests (1 evergreen needleleaf highest, 5 mixed, 4 deciduous broadleaf);
//!   moist → woody savanna (8), or croplands (12) / mosaic (14) in the lowlands; dry slopes →
//!   closed shrub (6), open shrub (7) high, grass (10) low, savanna (9) in between; plus
//!   `urban_patches` irregular blobs of urban (13) on gentle low-to-mid ground.
//! - **Georeference**: EPSG:4326 centred on (`center_lat`, `center_lon`) with the local
//!   equirectangular cell size of [`GridSpec::geographic_centered`].

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::georef::GridSpec;
use crate::{LandCoverScheme, Landscape, LandscapeError};

/// Generator options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProceduralOptions {
    pub seed: u64,
    pub width: usize,
    pub height: usize,
    pub cell_size_ft: f64,
    /// Elevation of the lowest cell, ft.
    pub min_elevation_ft: f64,
    /// Highest minus lowest elevation, ft.
    pub relief_ft: f64,
    pub center_lat: f64,
    pub center_lon: f64,
    /// Fraction of cells that are water (0 – 0.5).
    pub water_fraction: f64,
    pub urban_patches: usize,
    /// Top cells above this become snow/ice (15), else barren (16).
    pub snowline_ft: f64,
    /// Noise octaves (1 – 12).
    pub octaves: u32,
    /// Amplitude ratio between octaves (0 – 1): higher is rougher.
    pub persistence: f64,
}

impl Default for ProceduralOptions {
    /// FireCastRL's 240 × 160 × 500 ft grid, 300–6,300 ft relief, near 37.5 N 119.5 W.
    fn default() -> Self {
        Self {
            seed: 0,
            width: 240,
            height: 160,
            cell_size_ft: 500.0,
            min_elevation_ft: 300.0,
            relief_ft: 6000.0,
            center_lat: 37.5,
            center_lon: -119.5,
            water_fraction: 0.04,
            urban_patches: 3,
            snowline_ft: 9000.0,
            octaves: 6,
            persistence: 0.5,
        }
    }
}

impl ProceduralOptions {
    /// Defaults with a seed.
    pub fn with_seed(seed: u64) -> Self {
        Self {
            seed,
            ..Self::default()
        }
    }
}

fn invalid(name: &'static str, message: String) -> LandscapeError {
    LandscapeError::InvalidOption { name, message }
}

/// One octave of value noise on a `w × h` grid with lattice spacing `wl` cells.
fn value_noise(rng: &mut ChaCha8Rng, w: usize, h: usize, wl: f64) -> Vec<f64> {
    let nx = (w as f64 / wl).ceil() as usize + 2;
    let ny = (h as f64 / wl).ceil() as usize + 2;
    let lattice: Vec<f64> = (0..nx * ny).map(|_| rng.random::<f64>()).collect();
    let (ox, oy) = (rng.random::<f64>(), rng.random::<f64>());
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        let fy = (y as f64 + 0.5) / wl + oy;
        let (y0, ty) = (fy.floor() as usize, s(fy.fract()));
        for x in 0..w {
            let fx = (x as f64 + 0.5) / wl + ox;
            let (x0, tx) = (fx.floor() as usize, s(fx.fract()));
            let (x1, y1) = ((x0 + 1).min(nx - 1), (y0 + 1).min(ny - 1));
            let (x0, y0) = (x0.min(nx - 1), y0.min(ny - 1));
            let l = |xx: usize, yy: usize| lattice[yy * nx + xx];
            let a = l(x0, y0) + (l(x1, y0) - l(x0, y0)) * tx;
            let b = l(x0, y1) + (l(x1, y1) - l(x0, y1)) * tx;
            out.push(a + (b - a) * ty);
        }
    }
    out
}

fn fractal(
    rng: &mut ChaCha8Rng,
    w: usize,
    h: usize,
    base_wl: f64,
    octaves: u32,
    persistence: f64,
) -> Vec<f64> {
    let mut sum = vec![0.0; w * h];
    let (mut amp, mut wl) = (1.0, base_wl);
    for _ in 0..octaves {
        let n = value_noise(rng, w, h, wl.max(1.0));
        for (s, v) in sum.iter_mut().zip(n) {
            *s += amp * v;
        }
        amp *= persistence;
        wl /= 2.0;
    }
    normalise(&mut sum);
    sum
}

fn normalise(v: &mut [f64]) {
    let (lo, hi) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
        (a.min(x), b.max(x))
    });
    let span = hi - lo;
    for x in v.iter_mut() {
        *x = if span > 0.0 { (*x - lo) / span } else { 0.0 };
    }
}

/// Rank of each value in [0, 1] (ties broken by index, so deterministic).
fn ranks(v: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]).then(a.cmp(&b)));
    let denom = (v.len().max(2) - 1) as f64;
    let mut r = vec![0.0; v.len()];
    for (k, i) in idx.into_iter().enumerate() {
        r[i] = k as f64 / denom;
    }
    r
}

/// Generate a landscape.
pub fn generate(opts: &ProceduralOptions) -> Result<Landscape, LandscapeError> {
    let (w, h) = (opts.width, opts.height);
    let grid = GridSpec::geographic_centered(w, h, opts.cell_size_ft, opts.center_lat, opts.center_lon)?;
    if !(opts.relief_ft.is_finite() && opts.relief_ft >= 0.0 && opts.min_elevation_ft.is_finite()) {
        return Err(invalid(
            "relief_ft",
            format!("{} must be finite and >= 0", opts.relief_ft),
        ));
    }
    if !(0.0..=0.5).contains(&opts.water_fraction) {
        return Err(invalid(
            "water_fraction",
            format!("{} not in [0, 0.5]", opts.water_fraction),
        ));
    }
    if !(1..=12).contains(&opts.octaves) {
        return Err(invalid("octaves", format!("{} not in 1..=12", opts.octaves)));
    }
    if !(opts.persistence > 0.0 && opts.persistence <= 1.0) {
        return Err(invalid(
            "persistence",
            format!("{} not in (0, 1]", opts.persistence),
        ));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let base_wl = (w.max(h) as f64 / 2.0).max(2.0);

    // Relief.
    let mut hn = fractal(&mut rng, w, h, base_wl, opts.octaves, opts.persistence);
    for v in hn.iter_mut() {
        *v = v.powf(1.4);
    }
    let elev: Vec<f64> = hn
        .iter()
        .map(|v| opts.min_elevation_ft + opts.relief_ft * v)
        .collect();

    // Slope (ft/ft) and north-facing-ness.
    let cell = opts.cell_size_ft;
    let at = |x: usize, y: usize| elev[y * w + x];
    let mut slope = vec![0.0; w * h];
    let mut north = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let (xa, xb) = (x.saturating_sub(1), (x + 1).min(w - 1));
            let (ya, yb) = (y.saturating_sub(1), (y + 1).min(h - 1));
            let dzdx = if xb > xa {
                (at(xb, y) - at(xa, y)) / ((xb - xa) as f64 * cell)
            } else {
                0.0
            };
            let dzdy = if yb > ya {
                (at(x, yb) - at(x, ya)) / ((yb - ya) as f64 * cell)
            } else {
                0.0
            };
            slope[y * w + x] = dzdx.hypot(dzdy);
            north[y * w + x] = (-dzdy * 4.0).clamp(-1.0, 1.0);
        }
    }

    // Moisture.
    let m0 = fractal(&mut rng, w, h, base_wl / 1.5, opts.octaves.min(5), 0.5);
    let moist: Vec<f64> = (0..w * h)
        .map(|i| 0.55 * m0[i] + 0.35 * (1.0 - hn[i]) + 0.10 * north[i])
        .collect();
    let r = ranks(&elev);
    let q = ranks(&moist);

    let wf = opts.water_fraction;
    let mut classes: Vec<u16> = (0..w * h)
        .map(|i| {
            let (r, q) = (r[i], q[i]);
            if r < wf {
                17
            } else if r < wf + 0.02 && q > 0.5 {
                11
            } else if r > 0.985 {
                if elev[i] >= opts.snowline_ft { 15 } else { 16 }
            } else if r > 0.96 {
                16
            } else if q > 0.6 && r > 0.4 {
                if r > 0.75 {
                    1
                } else if r > 0.58 {
                    5
                } else {
                    4
                }
            } else if q > 0.55 {
                if r < 0.3 {
                    if slope[i] < 0.05 { 12 } else { 14 }
                } else {
                    8
                }
            } else if q < 0.25 {
                if r > 0.5 { 7 } else { 10 }
            } else if q < 0.4 {
                6
            } else {
                9
            }
        })
        .collect();

    // Urban patches on gentle, low-to-mid ground.
    let radius_base = (w.min(h) as f64 / 25.0).max(1.5);
    let candidates: Vec<usize> = (0..w * h)
        .filter(|&i| r[i] > wf + 0.03 && r[i] < 0.5 && slope[i] < 0.08)
        .collect();
    let edge = value_noise(&mut rng, w, h, 3.0);
    for _ in 0..opts.urban_patches {
        if candidates.is_empty() {
            break;
        }
        let c = candidates[rng.random_range(0..candidates.len())];
        let rad = radius_base * rng.random_range(0.7..1.6);
        let (cx, cy) = ((c % w) as f64, (c / w) as f64);
        let ri = rad.ceil() as isize + 1;
        for dy in -ri..=ri {
            for dx in -ri..=ri {
                let (x, y) = (cx as isize + dx, cy as isize + dy);
                if x < 0 || y < 0 || x >= w as isize || y >= h as isize {
                    continue;
                }
                let j = y as usize * w + x as usize;
                let d = (dx as f64).hypot(dy as f64);
                if d <= rad * (0.7 + 0.6 * edge[j]) && !matches!(classes[j], 17 | 11 | 15 | 16) {
                    classes[j] = 13;
                }
            }
        }
    }

    Landscape::new(
        w,
        h,
        opts.cell_size_ft,
        LandCoverScheme::ModisIgbp,
        classes,
        elev.iter().map(|&v| v as f32).collect(),
        grid.georef,
    )
}
