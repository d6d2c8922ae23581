//! Static per-cell fields of the synthetic world: elevation, climatology (as annual harmonics),
//! wind regime, vegetation greenness season, and the human-activity field.
//!
//! Everything here is a function of the global cell `(j, i)` and the seed only, so any region
//! sees exactly the cells a CONUS run would.

use std::f64::consts::TAU;

use super::grid::{grid_lat, grid_lon, pacific_coast_lon};
use super::noise::{Stream, fractal, hash_with, key, normal, unit};

/// Days per year of the seasonal harmonics.
pub(crate) const YEAR_DAYS: f64 = 365.25;

/// `(c, s)` of a seasonal harmonic with amplitude `amp` peaking on day-of-year `peak`:
/// `amp·cos(x − φ) = c·cos(x) + s·sin(x)` with `x = 2π(doy − 0.5)/365.25`.
fn harm(amp: f64, peak: f64) -> (f32, f32) {
    let phi = TAU * (peak - 0.5) / YEAR_DAYS;
    ((amp * phi.cos()) as f32, (amp * phi.sin()) as f32)
}

/// Second-harmonic `(c, s)`: `amp·cos(2(x − φ))`.
fn harm2(amp: f64, peak: f64) -> (f32, f32) {
    let phi = 2.0 * TAU * (peak - 0.5) / YEAR_DAYS;
    ((amp * phi.cos()) as f32, (amp * phi.sin()) as f32)
}

/// A one-sided seasonal bump `amp·(1 + cos(x − φ))²/4` (1 at `peak`, 0 half a year away) as
/// its mean and first and second harmonics: `amp·(3/8 + ½cos u + ⅛cos 2u)`.
fn bump(amp: f64, peak: f64) -> (f64, (f32, f32), (f32, f32)) {
    (0.375 * amp, harm(0.5 * amp, peak), harm2(0.125 * amp, peak))
}

fn sigmoid(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

fn gauss(x: f64) -> f64 {
    (-0.5 * x * x).exp()
}

fn ramp(x: f64) -> f64 {
    x.clamp(0.0, 1.0)
}

/// Octave spacings (GRIDMET cells: 8° down to 1/8°) and Hurst exponent of the seeded fractal
/// relief added to [`macro_elevation`]; `place.rs` samples the same field between cell centres.
pub(crate) const RELIEF_STEPS: [usize; 7] = [192, 96, 48, 24, 12, 6, 3];
pub(crate) const RELIEF_HURST: f64 = 0.9;

/// Longitude of the eastern front of the Rocky Mountains at `lat` (Front Range at 105.3°W
/// south of 41°N, the Bighorns/Wind Rivers in Wyoming, the Rocky Mountain Front in Montana).
pub(crate) fn rockies_front(lat: f64) -> f64 {
    if lat <= 41.0 {
        -105.3
    } else if lat <= 45.0 {
        -105.3 - (lat - 41.0) * 0.5
    } else {
        -107.3 - (lat - 45.0) * 1.3
    }
}

/// Large-scale relief of the lower 48 (metres) and a roughness scale for the fractal relief:
/// the intermountain plateau with the Sonoran/Mojave low deserts and the Columbia Basin cut
/// out, the Colorado Plateau, the Rocky Mountain block, the Sierra Nevada and Cascades, the
/// Coast Ranges, the Great Plains slope, the Appalachians and the eastern lowlands.
pub(crate) fn macro_elevation(lat: f64, lon: f64) -> (f64, f64) {
    let front = rockies_front(lat);
    let dpac = (lon - pacific_coast_lon(lat)).max(0.0);
    // Intermountain plateau ~1500 m between the Sierra/Cascades and the Rockies' front.
    let west = sigmoid((lon + 120.7) / 0.3) * sigmoid((front - lon) / 0.2) * (1.0 - (-dpac / 1.2).exp());
    let sonoran = sigmoid((34.2 - lat) / 0.3) * sigmoid(-(lon + 110.8) / 0.4);
    let mojave =
        0.7 * sigmoid((37.0 - lat) / 0.4) * sigmoid(-(lon + 114.2) / 0.4) * sigmoid((lon + 118.0) / 0.4);
    let low_sw = (sonoran + mojave).min(1.0);
    let columbia = gauss((lon + 119.0) / 1.3) * gauss((lat - 46.4) / 0.9);
    let colorado = 500.0 * gauss((lon + 110.5) / 2.0) * gauss((lat - 36.8) / 1.6);
    let plateau = west * (1500.0 - 1200.0 * low_sw - 1000.0 * columbia + colorado);
    // Rocky Mountain block: ~1100 m above the plateau, 2.5° wide, west of the front.
    let rockies = 1100.0
        * sigmoid((front - lon) / 0.15)
        * sigmoid((lon - front + 2.5) / 0.6)
        * sigmoid((lat - 33.0) / 0.5);
    // Sierra Nevada (36–40°N) and Cascades (40–49°N).
    let sierra_lon = if lat < 40.0 {
        -119.0 - (lat - 36.5) * 0.55
    } else {
        -121.3 - (lat - 40.0) * 0.02
    };
    let sierra = (1900.0 * gauss((lat - 37.8) / 1.6) + 1200.0 * sigmoid((lat - 40.5) / 0.6))
        * gauss((lon - sierra_lon) / 0.45)
        * sigmoid((lat - 35.3) / 0.3);
    // Coast Ranges.
    let coast = 550.0 * gauss((dpac - 0.6) / 0.3);
    // Great Plains: ~1600 m at the mountain front down to ~300 m at 96°W.
    let plains = sigmoid((lon - front) / 0.2)
        * sigmoid(-(lon + 95.0) / 1.0)
        * (300.0 + 1300.0 * ((lon + 96.0) / (front + 96.0)).clamp(0.0, 1.0));
    // Appalachians: a ridge from north Georgia to the Adirondacks.
    let (x0, y0, x1, y1) = (-84.5, 34.7, -74.2, 43.5);
    let t = (((lon - x0) * (x1 - x0) + (lat - y0) * (y1 - y0)) / ((x1 - x0).powi(2) + (y1 - y0).powi(2)))
        .clamp(0.0, 1.0);
    let (ax, ay) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
    let app = 750.0 * gauss(((lon - ax).powi(2) + (lat - ay).powi(2)).sqrt() / 0.8);
    // Eastern interior and coastal plain.
    let east = sigmoid((lon + 95.0) / 1.0) * 200.0 * sigmoid((lat - 31.0) / 1.5) + 15.0;
    let relief = rockies + sierra + coast + app;
    let rough = 50.0 + 0.35 * relief + 0.12 * plateau;
    (plateau + relief + plains + east, rough)
}

/// One land cell's static parameters (f32 to keep the per-day memory traffic small).
/// Seasonal quantities are `base + c·cos(x) + s·sin(x)` (and `c2`, `s2` for second
/// harmonics) with `x = 2π(doy − 0.5)/365.25`.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Cell {
    /// Local column in the window.
    pub col: u32,
    /// Global cell id `j·1386 + i` (hash key).
    pub gid: u32,
    pub elev: f32,
    /// Surface pressure (kPa).
    pub press: f32,
    /// Mean temperature (°C) harmonic.
    pub t: [f32; 3],
    /// Standard deviation of the synoptic temperature anomaly (K), harmonic.
    pub sig_t: [f32; 3],
    /// Diurnal temperature range (K), harmonic.
    pub dtr: [f32; 3],
    /// Mean precipitation (mm/day).
    pub p_mean: f32,
    /// Relative precipitation seasonality `[c1, s1, c2, s2]`.
    pub p_season: [f32; 4],
    /// Annual-mean wet-day fraction.
    pub f0: f32,
    /// Dew-point depression below Tmin (K): base, first and second harmonics.
    pub dd: [f32; 5],
    /// Mean 10 m wind speed (m/s), harmonic.
    pub vs: [f32; 3],
    /// Mean flow toward east / north (m/s), harmonics.
    pub u: [f32; 3],
    pub v: [f32; 3],
    /// Live-fuel greenness (0–1), harmonic.
    pub green: [f32; 3],
    /// Weight of convective (mesoscale) precipitation and lightning.
    pub convective: f32,
    /// Human activity (relative, mean ≈ 1 over land).
    pub human: f32,
    /// Relative propensity for prescribed burning.
    pub rx: f32,
    /// Relative lightning-ignition propensity (terrain, monsoon, Florida).
    pub lightning: f32,
}

/// Metro areas `(lon, lat, weight, radius°)` that shape the human-activity field.
const METROS: &[(f64, f64, f64, f64)] = &[
    (-118.25, 34.05, 3.0, 0.9),
    (-122.10, 37.60, 2.0, 0.7),
    (-117.10, 32.80, 1.2, 0.5),
    (-121.50, 38.60, 1.0, 0.6),
    (-119.80, 36.75, 0.7, 0.6),
    (-122.30, 47.50, 1.5, 0.6),
    (-122.70, 45.50, 1.0, 0.5),
    (-117.40, 47.70, 0.5, 0.4),
    (-116.20, 43.60, 0.5, 0.4),
    (-119.80, 39.50, 0.4, 0.3),
    (-115.15, 36.15, 1.0, 0.4),
    (-112.05, 33.45, 1.8, 0.6),
    (-110.95, 32.20, 0.6, 0.4),
    (-106.65, 35.10, 0.6, 0.4),
    (-106.45, 31.80, 0.5, 0.3),
    (-111.90, 40.75, 1.0, 0.5),
    (-104.95, 39.75, 1.4, 0.6),
    (-96.90, 32.80, 2.0, 0.8),
    (-95.40, 29.80, 2.0, 0.7),
    (-98.00, 29.90, 1.5, 0.7),
    (-97.50, 35.50, 0.8, 0.5),
    (-95.95, 36.15, 0.6, 0.4),
    (-94.60, 39.10, 0.9, 0.5),
    (-96.00, 41.25, 0.5, 0.4),
    (-93.25, 44.95, 1.2, 0.6),
    (-87.80, 41.85, 2.5, 0.8),
    (-83.20, 42.40, 1.5, 0.6),
    (-90.20, 38.65, 1.0, 0.5),
    (-90.00, 35.10, 0.6, 0.4),
    (-86.80, 36.15, 0.8, 0.5),
    (-84.40, 33.75, 2.0, 0.8),
    (-80.85, 35.20, 1.0, 0.6),
    (-78.70, 35.80, 0.8, 0.5),
    (-81.65, 30.30, 0.7, 0.5),
    (-81.40, 28.50, 1.2, 0.5),
    (-82.50, 27.95, 1.2, 0.5),
    (-80.25, 25.90, 1.8, 0.4),
    (-90.10, 29.95, 0.7, 0.4),
    (-86.80, 33.50, 0.6, 0.4),
    (-76.90, 39.00, 2.0, 0.7),
    (-75.15, 39.95, 1.8, 0.6),
    (-74.00, 40.70, 3.5, 0.9),
    (-71.10, 42.35, 1.8, 0.6),
    (-80.00, 40.45, 0.8, 0.5),
    (-81.70, 41.45, 0.8, 0.5),
    (-84.50, 39.10, 0.7, 0.5),
    (-86.15, 39.80, 0.8, 0.5),
    (-83.00, 39.95, 0.7, 0.4),
    (-87.95, 43.05, 0.6, 0.4),
    (-85.75, 38.25, 0.6, 0.4),
    (-78.85, 42.90, 0.5, 0.4),
];

/// Number of seeded small towns added to the metro areas.
const TOWNS: u64 = 400;

/// The human-activity ingredients that depend on the seed but not on the cell: metro weights
/// jittered by the seed, plus seeded towns.
#[derive(Debug, Clone)]
pub(crate) struct Settlements {
    /// `(lon, lat, weight, radius)`.
    pub places: Vec<(f64, f64, f64, f64)>,
}

impl Settlements {
    pub fn new(seed: u64) -> Self {
        let k = key(seed, Stream::Towns, 0);
        let mut places: Vec<(f64, f64, f64, f64)> = METROS
            .iter()
            .enumerate()
            .map(|(n, &(x, y, w, r))| (x, y, w * (0.3 * normal(hash_with(k, n as u64))).exp(), r))
            .collect();
        let mut n = 0u64;
        let mut tries = 0u64;
        while n < TOWNS && tries < TOWNS * 20 {
            let h = hash_with(k, 1_000_000 + tries);
            tries += 1;
            let lat = 25.2 + 24.0 * unit(h);
            let lon = -124.6 + 57.4 * unit(hash_with(h, 1));
            if !super::grid::is_land(lat, lon) {
                continue;
            }
            // Denser settlement in the East.
            if unit(hash_with(h, 2)) > 0.35 + 0.65 * sigmoid((lon + 98.0) / 3.0) {
                continue;
            }
            let w = 0.08 + 0.25 * unit(hash_with(h, 3));
            places.push((lon, lat, w, 0.12 + 0.15 * unit(hash_with(h, 4))));
            n += 1;
        }
        Self { places }
    }

    fn density(&self, lat: f64, lon: f64) -> f64 {
        let c = lat.to_radians().cos();
        let mut s = 0.0;
        for &(x, y, w, r) in &self.places {
            let dx = (lon - x) * c;
            let dy = lat - y;
            let d2 = dx * dx + dy * dy;
            if d2 < 16.0 * r * r {
                s += w * (-0.5 * d2 / (r * r)).exp();
            }
        }
        s
    }
}

/// Builds the static parameters of global cell `(j, i)`.
pub(crate) fn cell_info(seed: u64, settlements: &Settlements, j: usize, i: usize, col: u32) -> Cell {
    let lat = grid_lat(j);
    let lon = grid_lon(i);
    let dpac = (lon - pacific_coast_lon(lat)).max(0.0);

    // Elevation: macro relief plus seeded fractal relief (rougher in the mountains).
    let (macro_elev, rough) = macro_elevation(lat, lon);
    let fr = fractal(seed, Stream::Elevation, &RELIEF_STEPS, RELIEF_HURST, j, i);
    let elev = (macro_elev + rough * fr).max(0.0);
    let press = 101.3 * ((293.0 - 0.0065 * elev) / 293.0).powf(5.26);

    // Moisture access: Gulf/Atlantic air in the East, Pacific air near the west coast,
    // orographic enhancement, and a seeded ±15 % modulation.
    let m_east = sigmoid((lon + 99.0) / 3.5) * (0.85 + 0.45 * ramp((36.0 - lat) / 10.0));
    // Pacific moisture: a coastal term (cut by the Sierra/Cascade rain shadow) and a weaker
    // far-reaching one, both mostly north of ~38°N.
    let crest = if lat < 40.0 {
        -119.0 - (lat - 36.5) * 0.55
    } else {
        -121.3 - (lat - 40.0) * 0.02
    };
    let shadow = sigmoid((lon - crest) / 0.3) * sigmoid((lat - 35.5) / 0.5);
    let m_pac = (0.75 * (-dpac / 2.0).exp() * (1.0 - 0.6 * shadow) + 0.25 * (-dpac / 8.0).exp())
        * (0.05 + 0.95 * sigmoid((lat - 40.5) / 2.0));
    let orog = 0.2 * (elev - 900.0).max(0.0) * (0.35 + m_pac + 0.5 * m_east);
    let pmod = (0.14 * fractal(seed, Stream::PrecipShift, &[96, 24], 0.5, j, i)).exp();
    let monsoon = gauss((lon + 108.5) / 3.5) * gauss((lat - 33.8) / 3.2);
    let p_ann =
        ((120.0 + 1150.0 * m_east + 2300.0 * m_pac + orog + 100.0 * monsoon) * pmod).clamp(60.0, 4000.0);
    let aridity = ramp(1.0 - (p_ann - 220.0) / 850.0);

    // Regional weights.
    let plains = gauss((lon + 100.0) / 5.5) * ramp((lat - 28.0) / 4.0);
    let florida = ramp((30.5 - lat) / 3.0) * sigmoid((lon + 89.0) / 1.5);
    let southeast = sigmoid((lon + 96.0) / 2.0) * ramp((37.5 - lat) / 4.0);
    let mediterranean = (-dpac / 5.0).exp() * (1.0 - 0.3 * monsoon);

    // Temperature (°C).
    // The Pacific coast has a flat latitude gradient: cool (California Current) in the south,
    // mild in the Northwest.
    let maritime = (-dpac / 5.0).exp() * (-1.5 + 0.55 * (lat - 38.0).max(0.0));
    // Low deserts of the Southwest are warmer than their latitude suggests.
    let desert_heat = 4.5 * aridity * ramp((2000.0 - elev) / 1000.0) * ramp((40.0 - lat) / 6.0);
    // The interior West north of ~36°N is milder than the Midwest at the same latitude.
    let west_mild =
        4.0 * sigmoid(-(lon + 103.0) / 1.5) * ramp((lat - 36.0) / 3.0) * (1.0 - (-dpac / 2.0).exp());
    let t_ann = 27.0 - 0.85 * (lat - 25.0) + maritime + desert_heat + west_mild - 0.0045 * elev;
    // Continentality: ~0.3 on the Pacific coast, ~1.1 in the interior; Pacific air moderates
    // the interior Northwest, the surrounding seas south Florida.
    let nw = sigmoid((lat - 44.0) / 1.0) * (-dpac / 12.0).exp();
    let cont = 0.3 + 0.8 * (1.0 - (-dpac / 3.0).exp()) - 0.4 * nw - 0.3 * ramp((29.0 - lat) / 3.0);
    let t_amp = (5.5 + 0.45 * (lat - 25.0)) * cont;
    let t_peak = 200.0 + 28.0 * (-dpac / 1.2).exp();
    let (tc, ts) = harm(t_amp, t_peak);
    // Anomaly spread: larger in winter, at high latitude and inland.
    let sig0 = (1.4 + 0.12 * (lat - 25.0)) * cont.sqrt();
    let (sc, ss) = harm(0.3 * sig0, 20.0);

    // Diurnal range (K): dry, high and inland places have larger ranges; fog on the coast.
    let dtr0 = (8.5 + 3.0 * aridity + 1.5 * (elev / 2000.0).min(1.5) - 3.5 * (-dpac / 0.8).exp()).max(5.0);
    let (dc, ds) = harm(1.2 * aridity + 0.8, 185.0);

    // Precipitation seasonality (relative to the annual mean).
    let mut p_season = [0f32; 4];
    let mut add = |c: (f32, f32), second: bool| {
        let o = if second { 2 } else { 0 };
        p_season[o] += c.0;
        p_season[o + 1] += c.1;
    };
    add(harm(0.95 * mediterranean, 15.0), false);
    // The monsoon: a one-sided Jul–Sep bump (its mean is removed: the annual total is p_ann).
    let (_, m1, m2) = bump(1.6 * monsoon, 215.0);
    add(m1, false);
    add(m2, true);
    add(harm(0.55 * plains * (1.0 - monsoon), 165.0), false);
    add(harm(0.55 * florida, 200.0), false);
    let f0 = 0.07 + 0.33 * (1.0 - (-p_ann / 800.0).exp());

    // Humidity: dew-point depression below Tmin (K).
    // The marine layer keeps the immediate coast humid.
    // Summers are drier in arid and Mediterranean climates; the monsoon moistens Jul–Sep only.
    let summer_dry = 5.0 * aridity * (1.0 - 0.8 * monsoon) + 3.0 * mediterranean;
    let (m0, m1, m2) = bump(-6.0 * monsoon, 215.0);
    let dd0 = 0.8 + 11.0 * aridity.powf(1.2) - 8.0 * (-dpac / 1.0).exp() + m0;
    let (ddc, dds) = {
        let a = harm(summer_dry, 190.0);
        (a.0 + m1.0, a.1 + m1.1)
    };

    // Wind (m/s at 10 m).
    let vs0 = (3.0 + 2.0 * plains + 0.7 * (elev / 1500.0).clamp(0.0, 1.5) + 0.8 * (-dpac / 0.6).exp()
        - 0.8 * southeast)
        .max(1.5);
    let (vc, vsn) = harm(0.18 * vs0, 100.0);
    let westerly = 1.5 + 2.5 * ramp((lat - 28.0) / 16.0) - 3.0 * ramp((29.0 - lat) / 3.0);
    let (uc, us) = harm(1.2 * ramp((lat - 28.0) / 10.0), 20.0);
    let v_mean = 1.0 * plains;
    let (vvc, vvs) = {
        let a = harm(2.0 * plains, 180.0);
        let b = harm(-2.5 * (-dpac / 1.0).exp(), 190.0);
        (a.0 + b.0, a.1 + b.1)
    };

    // Greenness: green-up peaks mid-summer in the East and North, in spring in the arid West
    // (then cures), late summer under the monsoon; low amplitude in the subtropics.
    let g0 = 0.45 * (1.0 - 0.5 * aridity);
    let g_peak = 190.0 - 60.0 * aridity * (1.0 - monsoon) + 30.0 * monsoon;
    let (gc, gs) = harm(0.45 * (1.0 - 0.5 * ramp((30.0 - lat) / 5.0)), g_peak);

    // Human activity: settlements (saturating) × a seeded fractal, more in the East.
    let dens = settlements.density(lat, lon);
    let hf = fractal(seed, Stream::Human, &[48, 12, 3], 0.6, j, i);
    // The rural Southeast burns debris and pasture far more than anywhere else.
    let human = (0.06 + 0.5 * sigmoid((lon + 97.0) / 3.0) + 1.2 * dens / (1.0 + 0.5 * dens))
        * (1.0 + 1.5 * southeast)
        * (0.8 * hf).exp();

    let rx = 0.25 * ramp((p_ann - 450.0) / 400.0) + 2.5 * southeast;
    let lightning = 0.35 + 0.7 * (elev / 2000.0).clamp(0.0, 1.3) + 0.8 * monsoon + 0.5 * florida;
    let convective = 0.45 + 0.35 * monsoon + 0.2 * florida;

    let f = |x: f64| x as f32;
    Cell {
        col,
        gid: (j * super::grid::GRID_N_LON + i) as u32,
        elev: f(elev),
        press: f(press),
        t: [f(t_ann), tc, ts],
        sig_t: [f(sig0), sc, ss],
        dtr: [f(dtr0), dc, ds],
        p_mean: f(p_ann / YEAR_DAYS),
        p_season,
        f0: f(f0),
        dd: [f(dd0.max(0.3)), ddc, dds, m2.0, m2.1],
        vs: [f(vs0), vc, vsn],
        u: [f(westerly), uc, us],
        v: [f(v_mean), vvc, vvs],
        green: [f(g0), gc, gs],
        convective: f(convective),
        human: f(human),
        rx: f(rx),
        lightning: f(lightning),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `(name, lat, lon, elevation m, annual mean °C, July−January half range °C, annual
    /// precipitation mm)`: rough real normals, for broad sanity bounds only.
    pub(crate) const CITIES: &[(&str, f64, f64, f64, f64, f64, f64)] = &[
        ("Phoenix", 33.45, -112.07, 340.0, 24.0, 10.5, 200.0),
        ("Las Vegas", 36.17, -115.14, 610.0, 20.5, 12.0, 110.0),
        ("Denver", 39.74, -104.99, 1610.0, 10.4, 12.0, 400.0),
        ("Salt Lake", 40.76, -111.89, 1290.0, 11.5, 14.0, 400.0),
        ("Reno", 39.53, -119.81, 1370.0, 11.0, 11.5, 190.0),
        ("Boise", 43.60, -116.20, 820.0, 11.5, 13.0, 300.0),
        ("Missoula", 46.87, -113.99, 980.0, 7.3, 12.5, 350.0),
        ("Spokane", 47.66, -117.43, 720.0, 9.0, 12.0, 420.0),
        ("Flagstaff", 35.20, -111.65, 2100.0, 7.5, 10.0, 550.0),
        ("El Paso", 31.76, -106.49, 1140.0, 18.0, 11.0, 240.0),
        ("Bismarck", 46.81, -100.78, 510.0, 5.5, 16.5, 450.0),
        ("Kansas City", 39.10, -94.58, 300.0, 12.9, 14.0, 1000.0),
        ("Dallas", 32.78, -96.80, 150.0, 19.0, 10.5, 950.0),
        ("Houston", 29.76, -95.37, 20.0, 21.0, 8.5, 1260.0),
        ("Minneapolis", 44.98, -93.27, 260.0, 7.5, 16.5, 780.0),
        ("Chicago", 41.88, -87.63, 180.0, 10.0, 14.0, 950.0),
        ("Atlanta", 33.75, -84.39, 300.0, 17.0, 10.0, 1250.0),
        ("Tallahassee", 30.44, -84.28, 50.0, 20.0, 8.5, 1500.0),
        ("Miami", 25.90, -80.30, 5.0, 25.0, 4.5, 1500.0),
        ("New York", 40.90, -74.30, 30.0, 12.5, 12.0, 1200.0),
        ("Seattle", 47.61, -122.33, 50.0, 11.5, 7.0, 950.0),
        ("Los Angeles", 34.10, -118.20, 90.0, 18.5, 5.0, 380.0),
        ("San Francisco", 37.77, -122.42, 50.0, 14.5, 3.5, 600.0),
        ("Redding", 40.58, -122.39, 150.0, 17.0, 10.0, 850.0),
    ];

    fn at(lat: f64, lon: f64) -> Cell {
        let j = ((super::super::grid::GRID_LAT0 - lat) * 24.0).round() as usize;
        let i = ((lon - super::super::grid::GRID_LON0) * 24.0).round() as usize;
        cell_info(1, &Settlements::new(1), j, i, 0)
    }

    #[test]
    fn city_climates_are_plausible() {
        let mut bad = Vec::new();
        for &(name, lat, lon, elev, t_ann, t_amp, p_ann) in CITIES {
            let c = at(lat, lon);
            let amp = f64::from(c.t[1]).hypot(f64::from(c.t[2]));
            let p = f64::from(c.p_mean) * YEAR_DAYS;
            let line = format!(
                "{name:14} elev {:5.0} ({elev:5.0})  T {:5.1} ({t_ann:5.1})  amp {:4.1} ({t_amp:4.1})  \
                 P {:5.0} ({p_ann:5.0})  dtr {:4.1} dd {:4.1} vs {:3.1} H {:5.2} L {:4.2}",
                c.elev, c.t[0], amp, p, c.dtr[0], c.dd[0], c.vs[0], c.human, c.lightning
            );
            println!("{line}");
            let ok = (f64::from(c.t[0]) - t_ann).abs() < 4.5
                && (amp - t_amp).abs() < 4.5
                && p / p_ann < 2.0
                && p / p_ann > 0.5;
            if !ok {
                bad.push(line);
            }
        }
        assert!(bad.is_empty(), "implausible climates:\n{}", bad.join("\n"));
    }
}
