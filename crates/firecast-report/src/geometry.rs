//! Outlines of cell sets (arrival isochrones, burn-probability zones) as rings of grid
//! vertices, and the same rings as SVG paths and GeoJSON polygons in WGS84.

use std::collections::BTreeMap;

use firecast_landscape::Landscape;
use firecast_landscape::georef::Crs;

/// A closed ring of grid vertices (x right, y north; the last vertex joins the first).
pub type Ring = Vec<(i64, i64)>;

/// Boundary rings of the cells where `inside` holds: exterior rings counter-clockwise, holes
/// clockwise (RFC 7946's orientation with y north). Cells touching only at a corner get
/// separate rings.
pub fn rings(w: usize, h: usize, inside: impl Fn(usize) -> bool) -> Vec<Ring> {
    let at = |x: i64, y: i64| {
        x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h && inside(y as usize * w + x as usize)
    };
    // Directed boundary edges, interior on the left.
    let mut out: BTreeMap<(i64, i64), Vec<(i64, i64)>> = BTreeMap::new();
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            if !at(x, y) {
                continue;
            }
            let mut edge = |a: (i64, i64), b: (i64, i64)| out.entry(a).or_default().push(b);
            if !at(x, y - 1) {
                edge((x, y), (x + 1, y));
            }
            if !at(x + 1, y) {
                edge((x + 1, y), (x + 1, y + 1));
            }
            if !at(x, y + 1) {
                edge((x + 1, y + 1), (x, y + 1));
            }
            if !at(x - 1, y) {
                edge((x, y + 1), (x, y));
            }
        }
    }
    let mut rings = Vec::new();
    while let Some((&start, _)) = out.iter().find(|(_, v)| !v.is_empty()) {
        let mut ring = vec![start];
        let mut prev = start;
        let mut cur = take(&mut out, start, None);
        while cur != start {
            ring.push(cur);
            let dir = (cur.0 - prev.0, cur.1 - prev.1);
            let next = take(&mut out, cur, Some(dir));
            prev = cur;
            cur = next;
        }
        rings.push(simplify(ring));
    }
    rings
}

/// Removes and returns the edge leaving `v`, turning left before going straight before
/// turning right (keeps corner-touching cells apart).
fn take(
    out: &mut BTreeMap<(i64, i64), Vec<(i64, i64)>>,
    v: (i64, i64),
    dir: Option<(i64, i64)>,
) -> (i64, i64) {
    let Some(list) = out.get_mut(&v) else {
        return v;
    };
    let pick = match dir {
        Some((dx, dy)) if list.len() > 1 => {
            let rank = |b: &(i64, i64)| {
                let d = (b.0 - v.0, b.1 - v.1);
                if d == (-dy, dx) {
                    0
                } else if d == (dx, dy) {
                    1
                } else {
                    2
                }
            };
            (0..list.len()).min_by_key(|&i| rank(&list[i])).unwrap_or(0)
        }
        _ => 0,
    };
    let b = list.swap_remove(pick);
    if list.is_empty() {
        out.remove(&v);
    }
    b
}

/// Drops vertices in the middle of straight runs.
fn simplify(ring: Ring) -> Ring {
    let n = ring.len();
    if n < 4 {
        return ring;
    }
    (0..n)
        .filter(|&i| {
            let (a, b, c) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
            (b.0 - a.0) * (c.1 - b.1) - (b.1 - a.1) * (c.0 - b.0) != 0
        })
        .map(|i| ring[i])
        .collect()
}

/// Twice the signed area (positive: counter-clockwise).
pub fn signed_area2(ring: &Ring) -> i64 {
    let n = ring.len();
    (0..n)
        .map(|i| {
            let (a, b) = (ring[i], ring[(i + 1) % n]);
            a.0 * b.1 - b.0 * a.1
        })
        .sum()
}

fn contains(ring: &Ring, p: (f64, f64)) -> bool {
    let n = ring.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (ring[i], ring[(i + 1) % n]);
        let (ax, ay, bx, by) = (a.0 as f64, a.1 as f64, b.0 as f64, b.1 as f64);
        if (ay > p.1) != (by > p.1) && p.0 < ax + (p.1 - ay) / (by - ay) * (bx - ax) {
            inside = !inside;
        }
    }
    inside
}

/// Groups rings into polygons: each exterior ring with the holes it directly contains.
pub fn polygons(rings: Vec<Ring>) -> Vec<Vec<Ring>> {
    let (outer, holes): (Vec<Ring>, Vec<Ring>) = rings.into_iter().partition(|r| signed_area2(r) > 0);
    let mut polys: Vec<Vec<Ring>> = outer.into_iter().map(|r| vec![r]).collect();
    for hole in holes {
        // A point just inside the hole: the centre of the cell left of its first edge
        // seen from the hole (holes run clockwise, so their interior is on the right).
        let (a, b) = (hole[0], hole[1 % hole.len()]);
        let (dx, dy) = ((b.0 - a.0).signum(), (b.1 - a.1).signum());
        let p = (
            a.0 as f64 + 0.5 * dx as f64 + 0.5 * dy as f64,
            a.1 as f64 + 0.5 * dy as f64 - 0.5 * dx as f64,
        );
        let host = polys
            .iter()
            .enumerate()
            .filter(|(_, poly)| contains(&poly[0], p))
            .min_by_key(|(_, poly)| signed_area2(&poly[0]))
            .map(|(i, _)| i);
        if let Some(i) = host {
            polys[i].push(hole);
        }
    }
    polys
}

/// An SVG path (`fill-rule: evenodd`) of the rings on a map of `scale` px per cell whose
/// top row is grid row `height − 1`.
pub fn svg_path(rings: &[Ring], height: usize, scale: f64) -> String {
    let mut d = String::new();
    for ring in rings {
        for (k, &(x, y)) in ring.iter().enumerate() {
            let (px, py) = (x as f64 * scale, (height as i64 - y) as f64 * scale);
            d.push_str(&format!(
                "{}{} {}",
                if k == 0 { "M" } else { "L" },
                fmt_px(px),
                fmt_px(py)
            ));
        }
        d.push('Z');
    }
    d
}

fn fmt_px(v: f64) -> String {
    let s = format!("{v:.1}");
    s.strip_suffix(".0").map_or(s.clone(), str::to_string)
}

/// WGS84 [lon, lat] of a grid vertex (cell corners), 7 decimals (~1 cm).
pub fn vertex_lon_lat(land: &Landscape, crs: &Crs, x: i64, y: i64) -> Option<[f64; 2]> {
    let g = &land.georef;
    let (px, py) = (
        g.origin_x + x as f64 * g.cell_size_x,
        g.origin_y + y as f64 * g.cell_size_y,
    );
    let (lat, lon) = crs.to_lat_lon(px, py)?;
    Some([round7(lon), round7(lat)])
}

pub fn round7(v: f64) -> f64 {
    (v * 1e7).round() / 1e7
}

/// GeoJSON MultiPolygon coordinates of `polys` (rings closed, first vertex repeated).
pub fn geojson_multipolygon(land: &Landscape, polys: &[Vec<Ring>]) -> Option<serde_json::Value> {
    let crs = land.crs();
    let mut out = Vec::new();
    for poly in polys {
        let mut rings = Vec::new();
        for ring in poly {
            let mut coords = Vec::with_capacity(ring.len() + 1);
            for &(x, y) in ring.iter().chain(ring.first()) {
                coords.push(vertex_lon_lat(land, &crs, x, y)?);
            }
            rings.push(coords);
        }
        out.push(rings);
    }
    Some(serde_json::json!({"type": "MultiPolygon", "coordinates": out}))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_with_a_hole() {
        // 3×3 block minus its centre.
        let rings = rings(5, 5, |i| {
            let (x, y) = (i % 5, i / 5);
            (1..4).contains(&x) && (1..4).contains(&y) && !(x == 2 && y == 2)
        });
        assert_eq!(rings.len(), 2);
        let areas: Vec<i64> = rings.iter().map(signed_area2).collect();
        assert!(areas.contains(&18) && areas.contains(&-2), "{areas:?}");
        let polys = polygons(rings);
        assert_eq!(polys.len(), 1);
        assert_eq!(polys[0].len(), 2);
        assert_eq!(polys[0][0].len(), 4, "collinear vertices removed");
    }

    #[test]
    fn corner_touching_cells_stay_apart() {
        let rings = rings(3, 3, |i| i == 0 || i == 4);
        assert_eq!(rings.len(), 2);
        assert!(rings.iter().all(|r| signed_area2(r) == 2 && r.len() == 4));
    }

    #[test]
    fn areas_add_up_for_any_shape() {
        // Law: the signed areas of the rings equal the number of cells.
        let mut state = 12345u64;
        for _ in 0..50 {
            let cells: Vec<bool> = (0..64)
                .map(|_| {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    (state >> 33).is_multiple_of(3)
                })
                .collect();
            let r = rings(8, 8, |i| cells[i]);
            let total: i64 = r.iter().map(signed_area2).sum();
            assert_eq!(total, 2 * cells.iter().filter(|&&c| c).count() as i64);
        }
    }
}
