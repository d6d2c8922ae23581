//! Coordinate reference systems, WGS84 transverse Mercator, and the simulation grid.
//!
//! Supported CRSs for coordinate transforms: `EPSG:4326` (x = longitude, y = latitude, in
//! degrees), WGS84 UTM `EPSG:326zz` (north) / `EPSG:327zz` (south), zones 1–60, and NAD83 /
//! CONUS Albers `EPSG:5070` (LANDFIRE's grid; [`albers_forward`]). Any other CRS string is
//! carried through unchanged ([`Crs::Other`]); readers then require the grid and the raster to
//! use the *same* string, and lat/lon helpers return `NaN` / `None`.
//!
//! The transverse Mercator maths is the Krüger series to order n⁴ as given by Karney (2011),
//! "Transverse Mercator with an accuracy of a few nanometers", eqs. (7)–(11), (35)–(36):
//! sub-millimetre within a UTM zone and well below a metre several degrees outside it.

use crate::{GeoReference, Landscape, LandscapeError};

/// WGS84 semi-major axis, metres.
pub const WGS84_A: f64 = 6_378_137.0;
/// WGS84 flattening.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;
/// UTM scale factor on the central meridian.
pub const UTM_K0: f64 = 0.9996;
/// Feet → metres (international foot).
pub const FT_TO_M: f64 = 0.3048;

/// A coordinate reference system we can (or cannot) transform.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Crs {
    /// EPSG:4326, x = longitude, y = latitude (degrees).
    Wgs84Geographic,
    /// WGS84 / UTM zone `zone` (1–60), northern (EPSG:326zz) or southern (EPSG:327zz) hemisphere.
    Utm { zone: u8, north: bool },
    /// Anything else, kept verbatim; no transforms available except for `EPSG:5070` (CONUS
    /// Albers, LANDFIRE's grid), which [`Crs::to_lat_lon`] and [`Crs::from_lat_lon`] convert
    /// by [`albers_forward`] / [`albers_inverse`].
    Other(String),
}

impl Crs {
    /// Parse `EPSG:4326`, `EPSG:326zz`, `EPSG:327zz` (case-insensitive); anything else is `Other`.
    pub fn parse(s: &str) -> Crs {
        let t = s.trim();
        let code = t
            .get(..5)
            .filter(|p| p.eq_ignore_ascii_case("EPSG:"))
            .and_then(|_| t[5..].parse::<u32>().ok());
        match code {
            Some(4326) => Crs::Wgs84Geographic,
            Some(c @ 32601..=32660) => Crs::Utm {
                zone: (c - 32600) as u8,
                north: true,
            },
            Some(c @ 32701..=32760) => Crs::Utm {
                zone: (c - 32700) as u8,
                north: false,
            },
            _ => Crs::Other(t.to_string()),
        }
    }

    /// The UTM CRS whose zone contains `lon` (standard 6° zones, no Norway/Svalbard exceptions).
    pub fn utm_for(lat: f64, lon: f64) -> Crs {
        let lon = wrap_lon(lon);
        let zone = (((lon + 180.0) / 6.0).floor() as i64).clamp(0, 59) as u8 + 1;
        Crs::Utm {
            zone,
            north: lat >= 0.0,
        }
    }

    /// Canonical `EPSG:nnnn` string (or the original text for `Other`).
    pub fn code(&self) -> String {
        match self {
            Crs::Wgs84Geographic => "EPSG:4326".to_string(),
            Crs::Utm { zone, north } => format!("EPSG:{}", if *north { 32600 } else { 32700 } + *zone as u32),
            Crs::Other(s) => s.clone(),
        }
    }

    /// Whether lat/lon transforms are available.
    pub fn is_supported(&self) -> bool {
        match self {
            Crs::Other(s) => is_conus_albers(s),
            _ => true,
        }
    }

    /// CRS coordinates → (lat, lon) in degrees; `None` for `Other` or non-finite input.
    pub fn to_lat_lon(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        if !(x.is_finite() && y.is_finite()) {
            return None;
        }
        match self {
            Crs::Wgs84Geographic => Some((y, x)),
            Crs::Utm { zone, north } => {
                let northing = if *north { y } else { y - 10_000_000.0 };
                let (lat, lon) = tm_inverse(utm_central_meridian(*zone), x - 500_000.0, northing);
                Some((lat, wrap_lon(lon)))
            }
            Crs::Other(s) if is_conus_albers(s) => Some(albers_inverse(x, y)),
            Crs::Other(_) => None,
        }
    }

    /// (lat, lon) in degrees → CRS coordinates; `None` for `Other` or non-finite input.
    pub fn from_lat_lon(&self, lat: f64, lon: f64) -> Option<(f64, f64)> {
        if !(lat.is_finite() && lon.is_finite()) {
            return None;
        }
        match self {
            Crs::Wgs84Geographic => Some((lon, lat)),
            Crs::Utm { zone, north } => {
                let (e, n) = tm_forward(utm_central_meridian(*zone), lat, lon);
                Some((e + 500_000.0, if *north { n } else { n + 10_000_000.0 }))
            }
            Crs::Other(s) if is_conus_albers(s) => Some(albers_forward(lat, lon)),
            Crs::Other(_) => None,
        }
    }
}

/// Central meridian of a UTM zone, degrees.
pub fn utm_central_meridian(zone: u8) -> f64 {
    f64::from(zone) * 6.0 - 183.0
}

fn wrap_lon(lon: f64) -> f64 {
    let mut l = (lon + 180.0).rem_euclid(360.0) - 180.0;
    if l == -180.0 && lon > 0.0 {
        l = 180.0;
    }
    l
}

struct TmConsts {
    a_hat: f64,
    e: f64,
    alpha: [f64; 4],
    beta: [f64; 4],
    delta: [f64; 4],
}

fn tm_consts() -> TmConsts {
    let f = WGS84_F;
    let n = f / (2.0 - f);
    let (n2, n3, n4) = (n * n, n * n * n, n * n * n * n);
    TmConsts {
        a_hat: WGS84_A / (1.0 + n) * (1.0 + n2 / 4.0 + n4 / 64.0),
        e: (f * (2.0 - f)).sqrt(),
        alpha: [
            n / 2.0 - 2.0 * n2 / 3.0 + 5.0 * n3 / 16.0 + 41.0 * n4 / 180.0,
            13.0 * n2 / 48.0 - 3.0 * n3 / 5.0 + 557.0 * n4 / 1440.0,
            61.0 * n3 / 240.0 - 103.0 * n4 / 140.0,
            49561.0 * n4 / 161_280.0,
        ],
        beta: [
            n / 2.0 - 2.0 * n2 / 3.0 + 37.0 * n3 / 96.0 - n4 / 360.0,
            n2 / 48.0 + n3 / 15.0 - 437.0 * n4 / 1440.0,
            17.0 * n3 / 480.0 - 37.0 * n4 / 840.0,
            4397.0 * n4 / 161_280.0,
        ],
        delta: [
            2.0 * n - 2.0 * n2 / 3.0 - 2.0 * n3 + 116.0 * n4 / 45.0,
            7.0 * n2 / 3.0 - 8.0 * n3 / 5.0 - 227.0 * n4 / 45.0,
            56.0 * n3 / 15.0 - 136.0 * n4 / 35.0,
            4279.0 * n4 / 630.0,
        ],
    }
}

/// WGS84 transverse Mercator with scale `UTM_K0`, false origin (0, 0) on the central meridian
/// `lon0` at the equator: (lat, lon) degrees → (easting, northing) metres.
pub fn tm_forward(lon0: f64, lat: f64, lon: f64) -> (f64, f64) {
    let c = tm_consts();
    let phi = lat.to_radians();
    let lam = wrap_lon(lon - lon0).to_radians();
    let sin_phi = phi.sin();
    let t = (sin_phi.atanh() - c.e * (c.e * sin_phi).atanh()).sinh();
    let xi_p = t.atan2(lam.cos());
    let eta_p = (lam.sin() / (1.0 + t * t).sqrt()).atanh();
    let (mut xi, mut eta) = (xi_p, eta_p);
    for (j, a) in c.alpha.iter().enumerate() {
        let k = 2.0 * (j as f64 + 1.0);
        xi += a * (k * xi_p).sin() * (k * eta_p).cosh();
        eta += a * (k * xi_p).cos() * (k * eta_p).sinh();
    }
    (UTM_K0 * c.a_hat * eta, UTM_K0 * c.a_hat * xi)
}

/// Inverse of [`tm_forward`]: (easting, northing) metres → (lat, lon) degrees.
pub fn tm_inverse(lon0: f64, easting: f64, northing: f64) -> (f64, f64) {
    let c = tm_consts();
    let xi = northing / (UTM_K0 * c.a_hat);
    let eta = easting / (UTM_K0 * c.a_hat);
    let (mut xi_p, mut eta_p) = (xi, eta);
    for (j, b) in c.beta.iter().enumerate() {
        let k = 2.0 * (j as f64 + 1.0);
        xi_p -= b * (k * xi).sin() * (k * eta).cosh();
        eta_p -= b * (k * xi).cos() * (k * eta).sinh();
    }
    let chi = (xi_p.sin() / eta_p.cosh()).asin();
    let mut phi = chi;
    for (j, d) in c.delta.iter().enumerate() {
        phi += d * (2.0 * (j as f64 + 1.0) * chi).sin();
    }
    let lam = eta_p.sinh().atan2(xi_p.cos());
    (phi.to_degrees(), lon0 + lam.to_degrees())
}

/// Whether a CRS string is NAD83 / CONUS Albers (`EPSG:5070`, case-insensitive).
fn is_conus_albers(s: &str) -> bool {
    s.trim().eq_ignore_ascii_case("EPSG:5070")
}

/// The constants of NAD83 / CONUS Albers (EPSG:5070): Albers equal-area conic on the GRS 1980
/// ellipsoid, standard parallels 29.5° and 45.5° N, origin 23° N, 96° W, no false origin.
struct AlbersConsts {
    e: f64,
    e2: f64,
    n: f64,
    c: f64,
    rho0: f64,
}

const GRS80_A: f64 = 6_378_137.0;
const GRS80_F: f64 = 1.0 / 298.257_222_101;
const ALBERS_LON0: f64 = -96.0;

/// Snyder (1987), *Map Projections: A Working Manual*, eq. (3-12): q of latitude `phi` (radians).
fn albers_q(e: f64, e2: f64, phi: f64) -> f64 {
    let s = phi.sin();
    (1.0 - e2) * (s / (1.0 - e2 * s * s) - (1.0 / (2.0 * e)) * ((1.0 - e * s) / (1.0 + e * s)).ln())
}

fn albers_consts() -> AlbersConsts {
    let e2 = GRS80_F * (2.0 - GRS80_F);
    let e = e2.sqrt();
    // Snyder eq. (14-15): m = cos φ / √(1 − e² sin² φ).
    let m = |phi: f64| phi.cos() / (1.0 - e2 * phi.sin().powi(2)).sqrt();
    let (p1, p2, p0) = (
        29.5_f64.to_radians(),
        45.5_f64.to_radians(),
        23.0_f64.to_radians(),
    );
    let (m1, m2) = (m(p1), m(p2));
    let (q1, q2, q0) = (albers_q(e, e2, p1), albers_q(e, e2, p2), albers_q(e, e2, p0));
    // Snyder eqs. (14-14), (14-13), (14-12a).
    let n = (m1 * m1 - m2 * m2) / (q2 - q1);
    let c = m1 * m1 + n * q1;
    let rho0 = GRS80_A * (c - n * q0).sqrt() / n;
    AlbersConsts { e, e2, n, c, rho0 }
}

/// NAD83 / CONUS Albers (EPSG:5070): (lat, lon) degrees → (x, y) metres, Snyder (1987)
/// eqs. (14-1)–(14-4) on GRS 1980. Latitude and longitude are taken as NAD83, which differs
/// from WGS84 by about a metre in CONUS (ignored: a thirtieth of a LANDFIRE cell).
pub fn albers_forward(lat: f64, lon: f64) -> (f64, f64) {
    let k = albers_consts();
    let q = albers_q(k.e, k.e2, lat.to_radians());
    let rho = GRS80_A * (k.c - k.n * q).max(0.0).sqrt() / k.n;
    let theta = k.n * wrap_lon(lon - ALBERS_LON0).to_radians();
    (rho * theta.sin(), k.rho0 - rho * theta.cos())
}

/// Inverse of [`albers_forward`]: (x, y) metres → (lat, lon) degrees, Snyder eqs. (14-8)–(14-11)
/// and the iteration (3-16) for latitude.
pub fn albers_inverse(x: f64, y: f64) -> (f64, f64) {
    let k = albers_consts();
    let dy = k.rho0 - y;
    let rho = x.hypot(dy);
    let theta = x.atan2(dy);
    let q = (k.c - rho * rho * k.n * k.n / (GRS80_A * GRS80_A)) / k.n;
    let mut phi = (q / 2.0).clamp(-1.0, 1.0).asin();
    for _ in 0..15 {
        let s = phi.sin();
        let w = 1.0 - k.e2 * s * s;
        let step = w * w / (2.0 * phi.cos())
            * (q / (1.0 - k.e2) - s / w + (1.0 / (2.0 * k.e)) * ((1.0 - k.e * s) / (1.0 + k.e * s)).ln());
        phi += step;
        if step.abs() < 1e-14 {
            break;
        }
    }
    (
        phi.to_degrees(),
        wrap_lon(ALBERS_LON0 + (theta / k.n).to_degrees()),
    )
}

/// Metres per degree of latitude and of longitude at `lat` on the WGS84 ellipsoid
/// (meridional radius M and prime-vertical radius N·cos φ).
pub fn metres_per_degree(lat: f64) -> (f64, f64) {
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let phi = lat.to_radians();
    let w = (1.0 - e2 * phi.sin().powi(2)).sqrt();
    let m = WGS84_A * (1.0 - e2) / (w * w * w);
    let n = WGS84_A / w;
    (m.to_radians(), (n * phi.cos()).to_radians())
}

/// The simulation grid a reader resamples onto: `width × height` square cells of
/// `cell_size_ft` ground size, placed by `georef` (row 0 south, as in [`Landscape`]).
#[derive(Debug, Clone, PartialEq)]
pub struct GridSpec {
    pub width: usize,
    pub height: usize,
    pub cell_size_ft: f64,
    pub georef: GeoReference,
}

impl GridSpec {
    /// A grid with an explicit georeference (trusted to agree with `cell_size_ft`).
    pub fn new(
        width: usize,
        height: usize,
        cell_size_ft: f64,
        georef: GeoReference,
    ) -> Result<Self, LandscapeError> {
        if width == 0 || height == 0 {
            return Err(LandscapeError::Empty { width, height });
        }
        if !(cell_size_ft.is_finite() && cell_size_ft > 0.0) {
            return Err(LandscapeError::CellSize(cell_size_ft));
        }
        Ok(Self {
            width,
            height,
            cell_size_ft,
            georef,
        })
    }

    /// An EPSG:4326 grid centred on (`lat`, `lon`), using a **local equirectangular
    /// approximation**: the cell size in degrees is `cell_size_ft · 0.3048 m` divided by the
    /// WGS84 metres-per-degree of latitude and of longitude *at the centre latitude*
    /// ([`metres_per_degree`]). Cells are therefore exactly square on the ground at the centre
    /// row; at 36.6 km × 24.4 km (FireCastRL's extent) the E–W size drifts by < 0.3 % at the
    /// north/south edges at mid latitudes.
    pub fn geographic_centered(
        width: usize,
        height: usize,
        cell_size_ft: f64,
        lat: f64,
        lon: f64,
    ) -> Result<Self, LandscapeError> {
        check_lat_lon(lat, lon)?;
        let cell_m = cell_size_ft * FT_TO_M;
        let (m_lat, m_lon) = metres_per_degree(lat);
        let (dy, dx) = (cell_m / m_lat, cell_m / m_lon);
        let georef = GeoReference {
            crs: Crs::Wgs84Geographic.code(),
            origin_x: lon - dx * width as f64 / 2.0,
            origin_y: lat - dy * height as f64 / 2.0,
            cell_size_x: dx,
            cell_size_y: dy,
        };
        Self::new(width, height, cell_size_ft, georef)
    }

    /// A UTM grid (zone of `lon`) centred on (`lat`, `lon`), cells of `cell_size_ft` in metres.
    pub fn utm_centered(
        width: usize,
        height: usize,
        cell_size_ft: f64,
        lat: f64,
        lon: f64,
    ) -> Result<Self, LandscapeError> {
        check_lat_lon(lat, lon)?;
        let crs = Crs::utm_for(lat, lon);
        let (e, n) = crs
            .from_lat_lon(lat, lon)
            .ok_or_else(|| LandscapeError::UnsupportedCrs(crs.code()))?;
        let cell_m = cell_size_ft * FT_TO_M;
        let georef = GeoReference {
            crs: crs.code(),
            origin_x: e - cell_m * width as f64 / 2.0,
            origin_y: n - cell_m * height as f64 / 2.0,
            cell_size_x: cell_m,
            cell_size_y: cell_m,
        };
        Self::new(width, height, cell_size_ft, georef)
    }

    /// The grid of an existing landscape.
    pub fn of(landscape: &Landscape) -> Self {
        Self {
            width: landscape.width,
            height: landscape.height,
            cell_size_ft: landscape.cell_size_ft,
            georef: landscape.georef.clone(),
        }
    }

    /// CRS coordinates of the centre of cell (x, y).
    pub fn cell_center(&self, x: usize, y: usize) -> (f64, f64) {
        cell_center(&self.georef, x as f64, y as f64)
    }
}

fn check_lat_lon(lat: f64, lon: f64) -> Result<(), LandscapeError> {
    if !(lat.is_finite() && lon.is_finite() && lat.abs() < 84.0 && lon.abs() <= 180.0) {
        return Err(LandscapeError::InvalidOption {
            name: "center lat/lon",
            message: format!("({lat}, {lon}) must be finite with |lat| < 84 and |lon| <= 180"),
        });
    }
    Ok(())
}

pub(crate) fn cell_center(g: &GeoReference, x: f64, y: f64) -> (f64, f64) {
    (
        g.origin_x + (x + 0.5) * g.cell_size_x,
        g.origin_y + (y + 0.5) * g.cell_size_y,
    )
}

impl Landscape {
    /// The CRS of this landscape's georeference.
    pub fn crs(&self) -> Crs {
        Crs::parse(&self.georef.crs)
    }

    /// (lat, lon) in degrees of the centre of cell (x, y). For a CRS other than EPSG:4326 /
    /// WGS84 UTM both values are `NaN`; use [`Landscape::try_cell_to_lat_lon`] for an error.
    pub fn cell_to_lat_lon(&self, x: usize, y: usize) -> (f64, f64) {
        self.try_cell_to_lat_lon(x, y).unwrap_or((f64::NAN, f64::NAN))
    }

    /// Like [`Landscape::cell_to_lat_lon`], failing with `UnsupportedCrs`.
    pub fn try_cell_to_lat_lon(&self, x: usize, y: usize) -> Result<(f64, f64), LandscapeError> {
        let (cx, cy) = cell_center(&self.georef, x as f64, y as f64);
        self.crs()
            .to_lat_lon(cx, cy)
            .ok_or_else(|| LandscapeError::UnsupportedCrs(self.georef.crs.clone()))
    }

    /// The cell containing (lat, lon), or `None` when outside the grid or the CRS is unsupported.
    pub fn lat_lon_to_cell(&self, lat: f64, lon: f64) -> Option<(usize, usize)> {
        let (px, py) = self.crs().from_lat_lon(lat, lon)?;
        let g = &self.georef;
        let fx = ((px - g.origin_x) / g.cell_size_x).floor();
        let fy = ((py - g.origin_y) / g.cell_size_y).floor();
        if fx >= 0.0 && fy >= 0.0 && fx < self.width as f64 && fy < self.height as f64 {
            Some((fx as usize, fy as usize))
        } else {
            None
        }
    }
}
