//! Outlines of cell sets (arrival isochrones, burn-probability zones) as rings of grid
//! vertices, and the same rings as SVG paths and GeoJSON polygons in WGS84.
//!
//! The rings are valid OGC geometries: every ring is simple (no vertex visited twice, no
//! edge crossing another), exterior rings run counter-clockwise and holes clockwise (RFC
//! 7946 with y north), and the rings of different polygons meet at most at single points.
//! Cells are joined across their edges only (4-connectivity): two cells that touch at a
//! corner are two polygons meeting at that point, and an empty cell enclosed by cells that
//! touch at a corner is a hole whose ring touches the exterior ring there — never a ring
//! that runs through one vertex twice.

use std::collections::{BTreeMap, HashMap};

use firecast_landscape::Landscape;
use firecast_landscape::georef::Crs;

/// A closed ring of grid vertices (x right, y north; the last vertex joins the first).
pub type Ring = Vec<(i64, i64)>;

/// Boundary rings of the cells where `inside` holds: exterior rings counter-clockwise, holes
/// clockwise (RFC 7946's orientation with y north), each ring simple. Cells touching only at
/// a corner get separate rings.
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
        for simple in split_at_repeats(ring) {
            rings.push(simplify(simple));
        }
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

/// Cuts a traced boundary into simple rings at the vertices it passes twice (the corners
/// where cells of one piece touch diagonally around an enclosed empty cell, or two holes
/// meet). Each loop between two visits of a vertex becomes its own ring; its orientation
/// says what it is (counter-clockwise: an exterior ring, clockwise: a hole touching the
/// ring it came from at that vertex).
fn split_at_repeats(ring: Ring) -> Vec<Ring> {
    let mut loops = Vec::new();
    let mut stack: Ring = Vec::with_capacity(ring.len());
    let mut seen: HashMap<(i64, i64), usize> = HashMap::with_capacity(ring.len());
    for v in ring {
        if let Some(&k) = seen.get(&v) {
            // The walk came back to `v`: stack[k..] is a closed loop through it.
            let tail = stack.split_off(k + 1);
            for p in &tail {
                seen.remove(p);
            }
            let mut lp = Vec::with_capacity(tail.len() + 1);
            lp.push(v);
            lp.extend(tail);
            loops.push(lp);
        } else {
            seen.insert(v, stack.len());
            stack.push(v);
        }
    }
    loops.push(stack);
    loops
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
    multipolygon(polys, |x, y| vertex_lon_lat(land, &crs, x, y))
}

/// A GeoJSON MultiPolygon of `polys` with each grid vertex placed by `place` (`None`: no
/// place for it, and no geometry); every ring closed by repeating its first position.
pub fn multipolygon(
    polys: &[Vec<Ring>],
    place: impl Fn(i64, i64) -> Option<[f64; 2]>,
) -> Option<serde_json::Value> {
    let mut out = Vec::with_capacity(polys.len());
    for poly in polys {
        let mut rings = Vec::with_capacity(poly.len());
        for ring in poly {
            let mut coords = Vec::with_capacity(ring.len() + 1);
            for &(x, y) in ring.iter().chain(ring.first()) {
                coords.push(place(x, y)?);
            }
            rings.push(coords);
        }
        out.push(rings);
    }
    Some(serde_json::json!({"type": "MultiPolygon", "coordinates": out}))
}

#[cfg(test)]
mod tests {
    use std::collections::HashSet;

    use proptest::prelude::*;

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

    /// The case the old tracing got wrong: a ring of cells closed only by a diagonal touch
    /// around an empty cell. The boundary passes the touching corner twice; it must come
    /// out as an exterior ring and a hole meeting at that corner, not one ring through the
    /// corner twice (OGC: "Ring Self-intersection").
    #[test]
    fn a_hole_closed_by_a_corner_touch_is_a_hole() {
        // X X X     (row 2 is the top; the centre cell (1, 1) is empty, and cells (0, 1)
        // X . X      and (1, 0) touch only at the corner (1, 1); the rest is joined
        // . X X      edge to edge)
        let mask = [
            false, true, true, // y = 0
            true, false, true, // y = 1
            true, true, true, // y = 2
        ];
        let r = rings(3, 3, |i| mask[i]);
        for ring in &r {
            assert_simple(ring);
        }
        let polys = polygons(r);
        assert_eq!(polys.len(), 1, "{polys:?}");
        assert_eq!(polys[0].len(), 2, "shell and hole: {polys:?}");
        assert_eq!(signed_area2(&polys[0][1]), -2);
    }

    /// Every vertex of a ring once, axis-aligned edges, no straight-through vertex.
    fn assert_simple(ring: &Ring) {
        let n = ring.len();
        assert!(n >= 4, "a ring of {n} vertices: {ring:?}");
        let mut seen = HashSet::new();
        for i in 0..n {
            let (a, b, c) = (ring[i], ring[(i + 1) % n], ring[(i + 2) % n]);
            assert!(
                (a.0 == b.0) != (a.1 == b.1),
                "edge {a:?}→{b:?} is not a grid edge"
            );
            assert!(
                (b.0 - a.0) * (c.1 - b.1) - (b.1 - a.1) * (c.0 - b.0) != 0,
                "{b:?} lies on a straight run"
            );
            // Every lattice point along the edge, the end excluded.
            let (dx, dy) = ((b.0 - a.0).signum(), (b.1 - a.1).signum());
            let mut p = a;
            while p != b {
                assert!(seen.insert(p), "the ring passes {p:?} twice: {ring:?}");
                p = (p.0 + dx, p.1 + dy);
            }
        }
    }

    /// Unit edges of a ring, undirected.
    fn unit_edges(ring: &Ring) -> Vec<((i64, i64), (i64, i64))> {
        let n = ring.len();
        let mut out = Vec::new();
        for i in 0..n {
            let (a, b) = (ring[i], ring[(i + 1) % n]);
            let (dx, dy) = ((b.0 - a.0).signum(), (b.1 - a.1).signum());
            let mut p = a;
            while p != b {
                let q = (p.0 + dx, p.1 + dy);
                out.push((p.min(q), p.max(q)));
                p = q;
            }
        }
        out
    }

    fn mask() -> impl Strategy<Value = (usize, usize, Vec<bool>)> {
        (1usize..13, 1usize..13, 0.15f64..0.85).prop_flat_map(|(w, h, p)| {
            (
                Just(w),
                Just(h),
                proptest::collection::vec(proptest::bool::weighted(p), w * h),
            )
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        /// On any mask: every ring simple and closed, exterior rings counter-clockwise and
        /// holes clockwise inside them, rings sharing no edge (they meet at points at most),
        /// the polygons covering exactly the mask's cells, each polygon one 4-connected
        /// piece, and their area the number of cells.
        #[test]
        fn polygons_of_any_mask_are_valid((w, h, cells) in mask()) {
            let polys = polygons(rings(w, h, |i| cells[i]));
            let mut edges = HashSet::new();
            let mut area2 = 0;
            for poly in &polys {
                prop_assert!(signed_area2(&poly[0]) > 0, "exterior ring clockwise");
                for (k, ring) in poly.iter().enumerate() {
                    assert_simple(ring);
                    prop_assert_eq!(k == 0, signed_area2(ring) > 0, "a hole runs clockwise");
                    for e in unit_edges(ring) {
                        prop_assert!(edges.insert(e), "edge {:?} in two rings", e);
                    }
                    area2 += signed_area2(ring);
                }
                let closed = multipolygon(std::slice::from_ref(poly), |x, y| Some([x as f64, y as f64]))
                    .expect("coordinates");
                for ring in closed["coordinates"][0].as_array().expect("rings") {
                    let r = ring.as_array().expect("ring");
                    prop_assert!(r.len() >= 5 && r.first() == r.last(), "closed ring");
                }
            }
            let count = cells.iter().filter(|&&c| c).count() as i64;
            prop_assert_eq!(area2, 2 * count, "area = cells");
            // Which polygon holds each cell's centre.
            let mut owner = vec![None; w * h];
            for (i, owner) in owner.iter_mut().enumerate() {
                let p = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
                let holders: Vec<usize> = (0..polys.len())
                    .filter(|&k| contains(&polys[k][0], p) && !polys[k][1..].iter().any(|hole| contains(hole, p)))
                    .collect();
                prop_assert!(holders.len() <= 1, "cell {} in polygons {:?}", i, holders);
                *owner = holders.first().copied();
                prop_assert_eq!(owner.is_some(), cells[i], "cell {} covered wrongly", i);
            }
            // Each polygon's interior is connected: its cells are one 4-connected piece.
            for k in 0..polys.len() {
                let mine: Vec<usize> = (0..w * h).filter(|&i| owner[i] == Some(k)).collect();
                prop_assert!(!mine.is_empty(), "polygon {} holds no cell", k);
                let mut reached = HashSet::from([mine[0]]);
                let mut todo = vec![mine[0]];
                while let Some(i) = todo.pop() {
                    let (x, y) = (i % w, i / w);
                    let next = [
                        (x > 0).then(|| i - 1),
                        (x + 1 < w).then(|| i + 1),
                        (y > 0).then(|| i - w),
                        (y + 1 < h).then(|| i + w),
                    ];
                    for j in next.into_iter().flatten() {
                        if owner[j] == Some(k) && reached.insert(j) {
                            todo.push(j);
                        }
                    }
                }
                prop_assert_eq!(reached.len(), mine.len(), "polygon {} is in pieces", k);
            }
        }
    }
}
