//! Distances, geodesic offsets, the CONUS box and a bucketed point index.
//!
//! The authors measured every distance with the haversine formula on R = 6371.0088 km and
//! placed near negatives with geopy's geodesic destination on WGS84 (docs/spec/data.md §4, §10.1).
//! FireCast does the same, so "≥ 100 km" means what it meant for them.

use serde::{Deserialize, Serialize};

/// Mean Earth radius used by the authors' BallTree (km).
pub const EARTH_RADIUS_KM: f64 = 6371.0088;

/// Milliseconds per day.
pub const DAY_MS: i64 = 86_400_000;

/// Haversine great-circle distance in km.
pub fn haversine_km(lat1: f64, lon1: f64, lat2: f64, lon2: f64) -> f64 {
    let (p1, p2) = (lat1.to_radians(), lat2.to_radians());
    let dp = p2 - p1;
    let dl = (lon2 - lon1).to_radians();
    let a = (dp / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
    2.0 * EARTH_RADIUS_KM * a.sqrt().min(1.0).asin()
}

/// Destination on the WGS84 ellipsoid after `distance_km` along `bearing_deg` (clockwise
/// from north): Vincenty's direct formula, which is what geopy's geodesic destination
/// computes to well under a metre at these distances.
pub fn geodesic_destination(lat: f64, lon: f64, bearing_deg: f64, distance_km: f64) -> (f64, f64) {
    const A: f64 = 6_378_137.0;
    const F: f64 = 1.0 / 298.257_223_563;
    const B: f64 = A * (1.0 - F);
    let s = distance_km * 1000.0;
    let alpha1 = bearing_deg.to_radians();
    let (sin_a1, cos_a1) = alpha1.sin_cos();
    let tan_u1 = (1.0 - F) * lat.to_radians().tan();
    let cos_u1 = 1.0 / (1.0 + tan_u1 * tan_u1).sqrt();
    let sin_u1 = tan_u1 * cos_u1;
    let sigma1 = tan_u1.atan2(cos_a1);
    let sin_alpha = cos_u1 * sin_a1;
    let cos2_alpha = 1.0 - sin_alpha * sin_alpha;
    let u2 = cos2_alpha * (A * A - B * B) / (B * B);
    let big_a = 1.0 + u2 / 16384.0 * (4096.0 + u2 * (-768.0 + u2 * (320.0 - 175.0 * u2)));
    let big_b = u2 / 1024.0 * (256.0 + u2 * (-128.0 + u2 * (74.0 - 47.0 * u2)));
    let mut sigma = s / (B * big_a);
    let (mut sin_s, mut cos_s, mut cos2sm);
    let mut iterations = 0;
    loop {
        cos2sm = (2.0 * sigma1 + sigma).cos();
        sin_s = sigma.sin();
        cos_s = sigma.cos();
        let delta = big_b
            * sin_s
            * (cos2sm
                + big_b / 4.0
                    * (cos_s * (-1.0 + 2.0 * cos2sm * cos2sm)
                        - big_b / 6.0
                            * cos2sm
                            * (-3.0 + 4.0 * sin_s * sin_s)
                            * (-3.0 + 4.0 * cos2sm * cos2sm)));
        let next = s / (B * big_a) + delta;
        iterations += 1;
        if (next - sigma).abs() < 1e-12 || iterations > 200 {
            sigma = next;
            break;
        }
        sigma = next;
    }
    sin_s = sigma.sin();
    cos_s = sigma.cos();
    cos2sm = (2.0 * sigma1 + sigma).cos();
    let tmp = sin_u1 * sin_s - cos_u1 * cos_s * cos_a1;
    let lat2 =
        (sin_u1 * cos_s + cos_u1 * sin_s * cos_a1).atan2((1.0 - F) * (sin_alpha.powi(2) + tmp * tmp).sqrt());
    let lambda = (sin_s * sin_a1).atan2(cos_u1 * cos_s - sin_u1 * sin_s * cos_a1);
    let c = F / 16.0 * cos2_alpha * (4.0 + F * (4.0 - 3.0 * cos2_alpha));
    let l = lambda
        - (1.0 - c)
            * F
            * sin_alpha
            * (sigma + c * sin_s * (cos2sm + c * cos_s * (-1.0 + 2.0 * cos2sm * cos2sm)));
    let mut lon2 = lon + l.to_degrees();
    if lon2 > 180.0 {
        lon2 -= 360.0;
    } else if lon2 < -180.0 {
        lon2 += 360.0;
    }
    (lat2.to_degrees(), lon2)
}

/// A latitude/longitude box, bounds inclusive.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeoBox {
    pub lat_min: f64,
    pub lat_max: f64,
    pub lon_min: f64,
    pub lon_max: f64,
}

impl GeoBox {
    /// The authors' CONUS box (docs/spec/data.md §4.1), bounds inclusive.
    pub const CONUS: GeoBox = GeoBox {
        lat_min: 24.396308,
        lat_max: 49.384358,
        lon_min: -125.0,
        lon_max: -66.93457,
    };

    pub fn contains(&self, lat: f64, lon: f64) -> bool {
        (self.lat_min..=self.lat_max).contains(&lat) && (self.lon_min..=self.lon_max).contains(&lon)
    }
}

impl Default for GeoBox {
    fn default() -> Self {
        Self::CONUS
    }
}

/// Points bucketed by 1° of latitude and longitude, for "anything within r km?" queries
/// that stay exact (every candidate is checked with the haversine distance).
#[derive(Debug, Default, Clone)]
pub struct PointIndex {
    buckets: std::collections::HashMap<(i32, i32), Vec<u32>>,
    lats: Vec<f64>,
    lons: Vec<f64>,
}

impl PointIndex {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a point and returns its index (insertion order).
    pub fn insert(&mut self, lat: f64, lon: f64) -> u32 {
        let id = self.lats.len() as u32;
        self.lats.push(lat);
        self.lons.push(lon);
        self.buckets.entry(bucket(lat, lon)).or_default().push(id);
        id
    }

    pub fn len(&self) -> usize {
        self.lats.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lats.is_empty()
    }

    /// Calls `visit(id, distance_km)` for every point within `radius_km`; stops early when
    /// `visit` returns `true` and then returns `true`.
    pub fn any_within(
        &self,
        lat: f64,
        lon: f64,
        radius_km: f64,
        mut visit: impl FnMut(u32, f64) -> bool,
    ) -> bool {
        let dlat = (radius_km / 110.5).ceil() as i32 + 1;
        // Longitude degrees shrink with latitude; use the widest latitude the disc reaches.
        let widest = (lat.abs() + radius_km / 110.5).min(89.0);
        let dlon = (radius_km / (111.3 * widest.to_radians().cos())).ceil() as i32 + 1;
        let (bl, bo) = bucket(lat, lon);
        for i in bl - dlat..=bl + dlat {
            for j in bo - dlon..=bo + dlon {
                let Some(ids) = self.buckets.get(&(i, j)) else {
                    continue;
                };
                for &id in ids {
                    let d = haversine_km(lat, lon, self.lats[id as usize], self.lons[id as usize]);
                    if d < radius_km && visit(id, d) {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// Distance to the nearest point within `radius_km`, if any.
    pub fn nearest_within(&self, lat: f64, lon: f64, radius_km: f64) -> Option<f64> {
        let mut best: Option<f64> = None;
        self.any_within(lat, lon, radius_km, |_, d| {
            best = Some(best.map_or(d, |b: f64| b.min(d)));
            false
        });
        best
    }
}

fn bucket(lat: f64, lon: f64) -> (i32, i32) {
    (lat.floor() as i32, lon.floor() as i32)
}

/// Index `(row from the north, column from the west)` of a GRIDMET cell centre on the full
/// CONUS grid (docs/spec/data.md §2.3), so cells compare across files, subsets and imports.
pub fn gridmet_cell_index(cell_lat: f64, cell_lon: f64) -> (u32, u32) {
    let j = ((49.4 - cell_lat) * 24.0).round().clamp(0.0, 584.0);
    let i = ((cell_lon + 124.766_666_633_3) * 24.0).round().clamp(0.0, 1385.0);
    (j as u32, i as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn haversine_matches_the_spec_reference() {
        // London -> Paris, docs/spec/data.md §10.1: 343,556.535 m.
        let d = haversine_km(51.5074, -0.1278, 48.8566, 2.3522);
        assert!((d - 343.556535).abs() < 1e-3, "{d}");
    }

    #[test]
    fn geodesic_destination_inverts_a_known_geodesic() {
        // Geodesic London -> Paris is 343,923.120 m (docs/spec/data.md §10.1); the initial bearing that
        // reaches Paris lands within a metre of it.
        let mut best = (f64::MAX, 0.0);
        let mut b = 140.0;
        while b < 160.0 {
            let (la, lo) = geodesic_destination(51.5074, -0.1278, b, 343.923120);
            let miss = haversine_km(la, lo, 48.8566, 2.3522);
            if miss < best.0 {
                best = (miss, b);
            }
            b += 0.0005;
        }
        assert!(
            best.0 < 0.002,
            "closest approach {} km at bearing {}",
            best.0,
            best.1
        );
    }

    #[test]
    fn index_finds_exactly_the_points_within_the_radius() {
        let mut idx = PointIndex::new();
        idx.insert(40.0, -105.0);
        idx.insert(40.0, -104.0); // ~85 km east
        idx.insert(41.5, -105.0); // ~167 km north
        let mut found = Vec::new();
        idx.any_within(40.0, -105.0, 100.0, |id, _| {
            found.push(id);
            false
        });
        found.sort();
        assert_eq!(found, vec![0, 1]);
        assert!(idx.nearest_within(42.0, -105.0, 100.0).is_some());
        assert!(idx.nearest_within(45.0, -105.0, 100.0).is_none());
    }
}
