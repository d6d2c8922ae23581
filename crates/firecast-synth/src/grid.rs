//! The real GRIDMET grid (docs/spec/data.md §2.3), region windows on it, and FireCast's rough land
//! mask of the conterminous United States.

use super::SynthError;

/// Latitude cells of the full GRIDMET grid.
pub const GRID_N_LAT: usize = 585;
/// Longitude cells of the full GRIDMET grid.
pub const GRID_N_LON: usize = 1386;
/// Latitude of the first (northernmost) cell centre.
pub const GRID_LAT0: f64 = 49.4;
/// Longitude of the first (westernmost) cell centre.
pub const GRID_LON0: f64 = -124.766_666_633_3;
/// Cell size in degrees (1/24°).
pub const GRID_STEP: f64 = 1.0 / 24.0;

/// Latitude of the centre of global row `j` (descending: row 0 is 49.4°N).
pub fn grid_lat(j: usize) -> f64 {
    GRID_LAT0 - j as f64 / 24.0
}

/// Longitude of the centre of global column `i`.
pub fn grid_lon(i: usize) -> f64 {
    GRID_LON0 + i as f64 / 24.0
}

/// Which part of the GRIDMET grid to generate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Region {
    /// The whole 585 × 1386 grid.
    Conus,
    /// The cells whose centres lie inside the box (inclusive, 1e-6° tolerance); the box is
    /// snapped to the real grid, never resampled.
    Box {
        /// Southern edge (°N).
        lat_min: f64,
        /// Northern edge (°N).
        lat_max: f64,
        /// Western edge (°E, negative).
        lon_min: f64,
        /// Eastern edge (°E, negative).
        lon_max: f64,
    },
}

/// A rectangular window of the global grid: rows `lat_start..lat_start+n_lat` (north to south)
/// and columns `lon_start..lon_start+n_lon` (west to east).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GridWindow {
    /// First global row.
    pub lat_start: usize,
    /// Number of rows.
    pub n_lat: usize,
    /// First global column.
    pub lon_start: usize,
    /// Number of columns.
    pub n_lon: usize,
}

impl GridWindow {
    /// Latitudes of the window's rows (descending).
    pub fn lats(&self) -> Vec<f64> {
        (0..self.n_lat).map(|r| grid_lat(self.lat_start + r)).collect()
    }

    /// Longitudes of the window's columns (ascending).
    pub fn lons(&self) -> Vec<f64> {
        (0..self.n_lon).map(|c| grid_lon(self.lon_start + c)).collect()
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.n_lat * self.n_lon
    }

    pub(crate) fn as_tuple(&self) -> (usize, usize, usize, usize) {
        (self.lat_start, self.n_lat, self.lon_start, self.n_lon)
    }
}

impl Region {
    /// The window of the real grid this region covers.
    pub fn window(&self) -> Result<GridWindow, SynthError> {
        match *self {
            Region::Conus => Ok(GridWindow {
                lat_start: 0,
                n_lat: GRID_N_LAT,
                lon_start: 0,
                n_lon: GRID_N_LON,
            }),
            Region::Box {
                lat_min,
                lat_max,
                lon_min,
                lon_max,
            } => {
                let bad = |why: &str| {
                    SynthError::InvalidConfig(format!(
                        "region box lat {lat_min}..{lat_max}, lon {lon_min}..{lon_max}: {why}"
                    ))
                };
                if ![lat_min, lat_max, lon_min, lon_max].iter().all(|v| v.is_finite()) {
                    return Err(bad("edges must be finite"));
                }
                if lat_min > lat_max || lon_min > lon_max {
                    return Err(bad("min must not exceed max"));
                }
                let eps = 1e-6;
                // Row j has latitude 49.4 - j/24, so lat_max gives the first row.
                let j_lo = ((GRID_LAT0 - lat_max) * 24.0 - eps).ceil().max(0.0);
                let j_hi = ((GRID_LAT0 - lat_min) * 24.0 + eps)
                    .floor()
                    .min((GRID_N_LAT - 1) as f64);
                let i_lo = ((lon_min - GRID_LON0) * 24.0 - eps).ceil().max(0.0);
                let i_hi = ((lon_max - GRID_LON0) * 24.0 + eps)
                    .floor()
                    .min((GRID_N_LON - 1) as f64);
                if j_hi < j_lo || i_hi < i_lo {
                    return Err(bad("no GRIDMET cell centre lies inside it"));
                }
                Ok(GridWindow {
                    lat_start: j_lo as usize,
                    n_lat: (j_hi - j_lo) as usize + 1,
                    lon_start: i_lo as usize,
                    n_lon: (i_hi - i_lo) as usize + 1,
                })
            }
        }
    }
}

/// FireCast's rough outline of the conterminous United States, `(lon, lat)` vertices,
/// clockwise from Cape Flattery: the 49th parallel to Lake of the Woods, the south shore of
/// Lake Superior, round Lake Michigan (so that it is water), the Lake Huron, Erie and Ontario
/// shores, the St. Lawrence and Maine borders, the Atlantic and Gulf coasts, the Rio Grande and
/// the Mexican border, and the Pacific coast. About 0.1–0.3° accurate; small bays, sounds and
/// islands are ignored (Puget Sound, Chesapeake Bay and Long Island Sound count as land).
/// Cells whose centres fall outside it are masked (`_FillValue`) in every variable, as GRIDMET
/// masks the ocean, the Great Lakes, Canada and Mexico.
pub const CONUS_OUTLINE: &[(f64, f64)] = &[
    (-124.72, 48.38),
    (-123.10, 48.20),
    (-122.75, 49.00),
    (-95.15, 49.00),
    (-94.70, 48.75),
    (-92.00, 48.40),
    (-89.60, 48.00),
    (-92.10, 46.75),
    (-90.85, 46.60),
    (-87.40, 46.50),
    (-84.95, 46.75),
    (-84.35, 46.50),
    (-84.75, 45.90),
    (-85.60, 46.05),
    (-86.60, 45.90),
    (-87.05, 45.75),
    (-87.60, 45.10),
    (-88.00, 44.55),
    (-87.70, 43.75),
    (-87.90, 43.04),
    (-87.60, 41.85),
    (-87.30, 41.60),
    (-86.90, 41.72),
    (-86.50, 42.10),
    (-86.25, 43.20),
    (-86.45, 43.95),
    (-86.25, 44.65),
    (-85.30, 45.32),
    (-84.75, 45.78),
    (-84.45, 45.65),
    (-83.45, 45.05),
    (-83.35, 44.30),
    (-83.90, 43.65),
    (-83.00, 44.05),
    (-82.42, 43.00),
    (-83.05, 42.33),
    (-83.45, 41.73),
    (-81.70, 41.50),
    (-80.08, 42.13),
    (-78.90, 42.88),
    (-79.05, 43.25),
    (-77.60, 43.27),
    (-76.50, 43.47),
    (-76.35, 44.13),
    (-74.90, 45.00),
    (-71.50, 45.01),
    (-70.30, 45.90),
    (-69.22, 47.45),
    (-67.79, 47.07),
    (-67.78, 45.70),
    (-66.98, 44.82),
    (-68.20, 44.30),
    (-70.25, 43.60),
    (-70.60, 42.65),
    (-70.95, 42.30),
    (-69.95, 41.70),
    (-71.40, 41.45),
    (-73.70, 40.95),
    (-74.00, 40.45),
    (-74.95, 38.93),
    (-75.10, 38.30),
    (-75.97, 36.85),
    (-75.52, 35.22),
    (-76.50, 34.70),
    (-77.95, 33.85),
    (-79.90, 32.75),
    (-81.40, 30.35),
    (-80.55, 28.40),
    (-80.05, 26.70),
    (-80.12, 25.78),
    (-80.40, 25.20),
    (-81.10, 25.12),
    (-81.80, 26.15),
    (-82.75, 27.70),
    (-82.70, 28.70),
    (-83.05, 29.15),
    (-84.20, 30.05),
    (-85.00, 29.65),
    (-85.70, 30.10),
    (-88.05, 30.35),
    (-89.40, 30.15),
    (-89.20, 29.20),
    (-90.20, 29.10),
    (-92.30, 29.55),
    (-93.85, 29.70),
    (-94.80, 29.30),
    (-96.40, 28.40),
    (-97.20, 27.60),
    (-97.15, 25.95),
    (-98.30, 26.10),
    (-99.50, 27.50),
    (-100.50, 28.70),
    (-100.90, 29.35),
    (-102.40, 29.80),
    (-103.10, 29.00),
    (-104.40, 29.56),
    (-106.50, 31.78),
    (-108.20, 31.78),
    (-108.20, 31.33),
    (-111.07, 31.33),
    (-114.80, 32.49),
    (-117.12, 32.53),
    (-117.70, 33.45),
    (-118.40, 33.75),
    (-119.20, 34.15),
    (-120.47, 34.45),
    (-120.87, 35.37),
    (-121.90, 36.30),
    (-121.90, 36.60),
    (-122.00, 36.95),
    (-122.52, 37.78),
    (-123.00, 38.00),
    (-123.70, 38.95),
    (-124.40, 40.44),
    (-124.20, 41.75),
    (-124.56, 42.84),
    (-124.10, 44.60),
    (-123.95, 46.20),
    (-124.25, 47.30),
    (-124.65, 47.90),
];

/// Whether `(lat, lon)` is inside [`CONUS_OUTLINE`] (even–odd rule).
pub fn is_land(lat: f64, lon: f64) -> bool {
    let mut inside = false;
    let n = CONUS_OUTLINE.len();
    for k in 0..n {
        let (x1, y1) = CONUS_OUTLINE[k];
        let (x2, y2) = CONUS_OUTLINE[(k + 1) % n];
        if (y1 > lat) != (y2 > lat) {
            let x = x1 + (lat - y1) * (x2 - x1) / (y2 - y1);
            if lon < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// The land mask of a window, `[row][col]` flattened (row-major, north to south).
pub fn land_mask(window: &GridWindow) -> Vec<bool> {
    let lons = window.lons();
    let mut out = Vec::with_capacity(window.cells());
    for r in 0..window.n_lat {
        let lat = grid_lat(window.lat_start + r);
        // Crossings of this latitude with the outline, sorted: cells between pairs are land.
        let mut xs: Vec<f64> = Vec::new();
        let n = CONUS_OUTLINE.len();
        for k in 0..n {
            let (x1, y1) = CONUS_OUTLINE[k];
            let (x2, y2) = CONUS_OUTLINE[(k + 1) % n];
            if (y1 > lat) != (y2 > lat) {
                xs.push(x1 + (lat - y1) * (x2 - x1) / (y2 - y1));
            }
        }
        xs.sort_by(f64::total_cmp);
        for &lon in &lons {
            let crossings = xs.iter().filter(|&&x| lon < x).count();
            out.push(crossings % 2 == 1);
        }
    }
    out
}

/// Longitude of the Pacific coast at latitude `lat` (piecewise linear through outline points).
pub(crate) fn pacific_coast_lon(lat: f64) -> f64 {
    const COAST: &[(f64, f64)] = &[
        (32.53, -117.12),
        (33.45, -117.70),
        (33.75, -118.40),
        (34.15, -119.20),
        (34.45, -120.47),
        (35.37, -120.87),
        (36.30, -121.90),
        (37.78, -122.52),
        (38.95, -123.70),
        (40.44, -124.40),
        (41.75, -124.20),
        (42.84, -124.56),
        (44.60, -124.10),
        (46.20, -123.95),
        (47.30, -124.25),
        (48.38, -124.72),
    ];
    if lat <= COAST[0].0 {
        return COAST[0].1;
    }
    for w in COAST.windows(2) {
        let ((a, x), (b, y)) = (w[0], w[1]);
        if lat <= b {
            return x + (lat - a) / (b - a) * (y - x);
        }
    }
    COAST[COAST.len() - 1].1
}

/// Approximate geographic centres `(code, lon, lat)` of the lower-48 states (several points for
/// the large or oddly shaped ones); a point's state is the nearest centre.
const STATE_CENTRES: &[(&str, f64, f64)] = &[
    ("AL", -86.8, 32.8),
    ("AZ", -111.7, 34.3),
    ("AR", -92.4, 34.9),
    ("CA", -119.5, 37.2),
    ("CA", -122.0, 40.5),
    ("CA", -116.8, 34.4),
    ("CA", -120.4, 35.6),
    ("CO", -105.5, 39.0),
    ("CT", -72.7, 41.6),
    ("DE", -75.5, 39.0),
    ("FL", -81.6, 28.4),
    ("FL", -81.0, 26.2),
    ("FL", -85.6, 30.5),
    ("FL", -83.2, 30.0),
    ("GA", -83.4, 32.7),
    ("ID", -114.6, 44.4),
    ("ID", -116.4, 47.4),
    ("IL", -89.2, 40.0),
    ("IN", -86.3, 39.9),
    ("IA", -93.5, 42.1),
    ("KS", -98.4, 38.5),
    ("KY", -85.3, 37.5),
    ("LA", -92.0, 31.0),
    ("ME", -69.2, 45.4),
    ("MD", -76.8, 39.0),
    ("MA", -71.8, 42.3),
    ("MI", -84.7, 43.7),
    ("MI", -87.0, 46.3),
    ("MN", -94.3, 46.3),
    ("MS", -89.7, 32.7),
    ("MO", -92.5, 38.4),
    ("MT", -109.6, 47.0),
    ("MT", -113.5, 47.0),
    ("NE", -99.8, 41.5),
    ("NV", -116.9, 39.3),
    ("NV", -115.0, 36.5),
    ("NH", -71.6, 43.7),
    ("NJ", -74.7, 40.1),
    ("NM", -106.1, 34.4),
    ("NY", -75.5, 42.9),
    ("NY", -78.0, 42.6),
    ("NC", -79.4, 35.55),
    ("NC", -77.0, 35.5),
    ("ND", -100.5, 47.45),
    ("OH", -82.8, 40.3),
    ("OK", -97.5, 35.6),
    ("OK", -101.5, 36.7),
    ("OR", -120.55, 43.9),
    ("PA", -77.8, 40.9),
    ("RI", -71.5, 41.7),
    ("SC", -80.9, 33.9),
    ("SD", -100.2, 44.4),
    ("TN", -86.4, 35.85),
    ("TN", -83.9, 36.0),
    ("TX", -99.3, 31.4),
    ("TX", -101.9, 34.0),
    ("TX", -98.2, 27.5),
    ("TX", -104.0, 30.7),
    ("TX", -95.3, 30.8),
    ("UT", -111.7, 39.3),
    ("VT", -72.7, 44.0),
    ("VA", -78.8, 37.5),
    ("VA", -81.5, 36.9),
    ("WA", -120.4, 47.4),
    ("WA", -123.0, 47.3),
    ("WV", -80.6, 38.6),
    ("WI", -89.9, 44.6),
    ("WY", -107.55, 43.0),
];

/// States whose borders are (nearly) parallels and meridians, as `(code, lat_min, lat_max,
/// lon_min, lon_max)`; the first box containing a point wins (so the Utah notch is Wyoming's
/// first, the Nebraska notch Colorado's, the Texas part of the Rio Grande valley before New
/// Mexico).
const STATE_BOXES: &[(&str, f64, f64, f64, f64)] = &[
    ("WY", 41.0, 45.0, -111.05, -104.05),
    ("CO", 37.0, 41.0, -109.05, -102.05),
    ("UT", 37.0, 42.0, -114.05, -109.05),
    ("TX", 25.0, 32.0, -106.65, -93.5),
    ("NM", 31.33, 37.0, -109.05, -103.05),
    ("AZ", 31.33, 37.0, -114.8, -109.05),
    ("OK", 36.5, 37.0, -103.05, -100.0),
    ("TX", 32.0, 36.5, -103.05, -100.0),
    ("ND", 45.94, 49.0, -104.05, -97.0),
    ("SD", 42.5, 45.94, -104.05, -96.6),
    ("NE", 40.0, 43.0, -104.05, -95.8),
    ("KS", 37.0, 40.0, -102.05, -94.6),
    ("MT", 44.4, 49.0, -111.05, -104.05),
    ("MT", 47.0, 49.0, -116.05, -111.05),
    ("MT", 45.6, 47.0, -114.3, -111.05),
    ("ID", 42.0, 49.0, -117.05, -111.05),
    ("NV", 35.0, 42.0, -120.0, -114.05),
    ("OR", 42.0, 46.0, -124.7, -116.9),
    ("WA", 46.0, 49.0, -124.8, -117.05),
];

/// Two-letter state code of a land point: a box for the states with straight borders, else the
/// nearest state centre (rough near the other borders; Nevada's diagonal border with California
/// is approximated by 120°W).
pub fn state_of(lat: f64, lon: f64) -> &'static str {
    for &(code, la0, la1, lo0, lo1) in STATE_BOXES {
        if (la0..la1).contains(&lat) && (lo0..lo1).contains(&lon) {
            // Nevada's border with California runs diagonally south of Lake Tahoe.
            if code == "NV" && lat < 39.0 && lon < -120.0 + (39.0 - lat) * (5.4 / 4.0) {
                break;
            }
            return code;
        }
    }
    let c = lat.to_radians().cos();
    let mut best = ("", f64::INFINITY);
    for &(code, x, y) in STATE_CENTRES {
        let d = ((lon - x) * c).powi(2) + (lat - y).powi(2);
        if d < best.1 {
            best = (code, d);
        }
    }
    best.0
}

/// Geographic Area Coordination Center of a state (GACC codes as WFIGS writes them).
pub fn gacc_of(state: &str, lat: f64, lon: f64) -> &'static str {
    match state {
        "WA" | "OR" => "NWCC",
        "CA" if lat >= 37.5 || (lat >= 36.0 && lon < -120.0) => "ONCC",
        "CA" => "OSCC",
        "NV" | "UT" => "GBCC",
        "ID" if lat >= 45.5 => "NRCC",
        "ID" => "GBCC",
        "MT" | "ND" => "NRCC",
        "WY" | "CO" | "SD" | "NE" | "KS" => "RMCC",
        "AZ" | "NM" => "SWCC",
        "TX" if lon < -103.5 => "SWCC",
        "TX" | "OK" | "AR" | "LA" | "MS" | "AL" | "GA" | "FL" | "SC" | "NC" | "TN" | "KY" | "VA" => "SACC",
        _ => "EACC",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_points() {
        for (name, lat, lon, land) in [
            ("Denver", 39.74, -104.99, true),
            ("Chicago suburbs", 41.85, -87.75, true),
            ("Lake Michigan", 43.5, -87.0, false),
            ("Lake Superior", 47.5, -88.0, false),
            ("Pacific", 40.0, -125.0, false),
            ("Gulf of Mexico", 27.0, -90.0, false),
            ("Atlantic", 35.0, -72.0, false),
            ("Mexico", 30.0, -108.0, false),
            ("Canada", 49.3, -100.0, false),
            ("Reno", 39.53, -119.81, true),
            ("Miami", 25.9, -80.3, true),
            ("Maine", 45.5, -69.0, true),
            ("Michigan UP", 46.3, -87.0, true),
            ("Michigan LP", 43.5, -84.5, true),
            ("Seattle", 47.6, -122.3, true),
            ("El Paso", 31.85, -106.45, true),
        ] {
            assert_eq!(is_land(lat, lon), land, "{name}");
        }
        assert_eq!(state_of(39.74, -104.99), "CO");
        assert_eq!(state_of(34.05, -118.25), "CA");
        assert_eq!(state_of(33.45, -112.07), "AZ");
        assert_eq!(state_of(40.7, -74.0), "NJ"); // near a border: rough is fine
        assert_eq!(state_of(32.66, -104.57), "NM");
        assert_eq!(state_of(31.8, -104.5), "TX");
        assert_eq!(state_of(41.5, -110.5), "WY");
        assert_eq!(state_of(40.76, -111.89), "UT");
        assert_eq!(state_of(36.17, -115.14), "NV");
        assert_eq!(state_of(36.0, -118.0), "CA");
        assert_eq!(state_of(43.6, -116.2), "ID");
        assert_eq!(state_of(46.87, -113.99), "MT");
        assert_eq!(state_of(47.66, -117.43), "WA");
    }

    #[test]
    fn conus_mask_fraction() {
        let w = Region::Conus.window().expect("conus");
        let mask = land_mask(&w);
        let f = mask.iter().filter(|&&m| m).count() as f64 / mask.len() as f64;
        // Real GRIDMET has ~57% valid cells.
        assert!((0.5..0.65).contains(&f), "land fraction {f}");
        // The scanline mask and the point test agree.
        for (k, &m) in mask.iter().enumerate().step_by(997) {
            let (r, c) = (k / w.n_lon, k % w.n_lon);
            assert_eq!(m, is_land(grid_lat(r), grid_lon(c)));
        }
    }

    #[test]
    fn box_snaps_to_grid() {
        let w = Region::Box {
            lat_min: 49.4 - 19.0 / 24.0,
            lat_max: 49.4,
            lon_min: GRID_LON0,
            lon_max: GRID_LON0 + 29.0 / 24.0,
        }
        .window()
        .expect("box");
        assert_eq!((w.lat_start, w.n_lat, w.lon_start, w.n_lon), (0, 20, 0, 30));
        assert!(
            Region::Box {
                lat_min: 10.0,
                lat_max: 11.0,
                lon_min: -100.0,
                lon_max: -99.0
            }
            .window()
            .is_err()
        );
    }
}
