//! Helitack drops in physical units (docs/spec/fire-model.md §B13).
//!
//! A drop of V US gallons laid at coverage level CL (gallons per 100 ft²) wets
//! 100 · V / CL ft². The level a fuel needs is tabulated by fuel model (aerial retardant coverage
//! levels); the pilot lays the drop at the level the fuel under the drop needs. FireCast spreads
//! that area as a disc centred on the cell's centre over the grid, whatever the cell size: an
//! 800-gallon drop in short grass (level 1) covers about 8 cells of 30 m, a third of a 500 ft cell.
//! A cell counts as treated once the coverage it has received adds up to a whole cell at its own
//! fuel's level, so several drops are needed where cells are larger than a drop.

/// Coverage level (US gallons per 100 ft²) that a fuel model needs, or `None` for non-burnable
/// codes (91–99) and unknown models.
///
/// Anderson's 13 models follow the coverage-level table of the USDA Forest Service's airtanker
/// drop guides (level 1 for short grass up to "more than 6" for heavy slash, taken as 8);
/// Scott & Burgan's 40 take the level of the Anderson model closest in fuel type and load
/// (FireCast's assignment, docs/spec/fire-model.md §B13.1).
pub fn coverage_level(fuel_model: u16) -> Option<f64> {
    let level = match fuel_model {
        // Anderson (1982).
        1 => 1.0,
        2 | 8 => 2.0,
        3 | 5 | 9 | 11 => 3.0,
        6 | 7 => 4.0,
        4 | 10 | 12 => 6.0,
        13 => 8.0,
        // Scott & Burgan (2005): grass as short grass (GR1–2) or tall grass (GR3–9).
        101 | 102 => 1.0,
        103..=109 => 3.0,
        // Grass-shrub as timber-grass-understory.
        121..=124 => 2.0,
        // Shrub: light (as 5), moderate (as 6/7), heavy (as 4).
        141..=143 => 3.0,
        144..=146 => 4.0,
        147..=149 => 6.0,
        // Timber understory: as 2, then as 10 for the heaviest.
        161..=163 => 2.0,
        164 => 3.0,
        165 => 6.0,
        // Timber litter: compact (as 8), broadleaf and long-needle (as 9).
        181..=185 => 2.0,
        186..=189 => 3.0,
        // Slash-blowdown: as 11, 12, 12, 13.
        201 => 3.0,
        202 | 203 => 6.0,
        204 => 8.0,
        _ => return None,
    };
    Some(level)
}

/// The level a drop on a non-burnable target (water, rock, developed land) is laid at.
pub const DEFAULT_COVERAGE_LEVEL: f64 = 2.0;

/// Area wetted by `volume_gal` at `level` gallons per 100 ft², in ft².
pub fn wetted_area_ft2(volume_gal: f64, level: f64) -> f64 {
    100.0 * volume_gal / level
}

/// The cells a disc of `area_ft2` centred on a cell's centre overlaps, with the fraction of each
/// cell it covers: (dx, dy, fraction), fractions summing to `area_ft2` / cell area. A disc that
/// fits inside its cell covers that fraction of it exactly; a larger one is integrated on a
/// 32 × 32 grid of points per cell, the partly covered cells rescaled so the total is exact.
pub fn disc_coverage(area_ft2: f64, cell_ft: f64) -> Vec<(i32, i32, f32)> {
    let cell_area = cell_ft * cell_ft;
    let radius = (area_ft2 / std::f64::consts::PI).sqrt();
    if radius <= cell_ft / 2.0 {
        return vec![(0, 0, (area_ft2 / cell_area) as f32)];
    }
    const SUB: usize = 32;
    let reach = (radius / cell_ft + 0.5).ceil() as i32;
    let mut cells = Vec::new();
    let mut total = 0.0;
    for dy in -reach..=reach {
        for dx in -reach..=reach {
            let mut inside = 0usize;
            for sy in 0..SUB {
                for sx in 0..SUB {
                    let x = (f64::from(dx) - 0.5 + (sx as f64 + 0.5) / SUB as f64) * cell_ft;
                    let y = (f64::from(dy) - 0.5 + (sy as f64 + 0.5) / SUB as f64) * cell_ft;
                    if x * x + y * y <= radius * radius {
                        inside += 1;
                    }
                }
            }
            if inside > 0 {
                let fraction = inside as f64 / (SUB * SUB) as f64;
                total += fraction;
                cells.push((dx, dy, fraction));
            }
        }
    }
    // Cells wholly inside stay whole; the partial ones absorb the sampling error.
    let whole = cells.iter().filter(|c| c.2 >= 1.0).count() as f64;
    let scale = (area_ft2 / cell_area - whole) / (total - whole);
    cells
        .into_iter()
        .map(|(dx, dy, f)| {
            (
                dx,
                dy,
                if f >= 1.0 {
                    1.0
                } else {
                    (f * scale).min(1.0) as f32
                },
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coverage_levels_rise_with_fuel_load_and_skip_non_burnable() {
        assert_eq!(coverage_level(1), Some(1.0));
        assert_eq!(coverage_level(2), Some(2.0));
        assert_eq!(coverage_level(4), Some(6.0));
        assert_eq!(coverage_level(13), Some(8.0));
        assert_eq!(coverage_level(102), Some(1.0));
        assert_eq!(coverage_level(165), Some(6.0));
        for code in [0, 14, 91, 93, 98, 99, 100, 110, 205] {
            assert_eq!(coverage_level(code), None, "{code}");
        }
        // Every Scott & Burgan burnable code has a level.
        for code in (101..=109)
            .chain(121..=124)
            .chain(141..=149)
            .chain(161..=165)
            .chain(181..=189)
            .chain(201..=204)
        {
            assert!(coverage_level(code).is_some(), "{code}");
        }
    }

    #[test]
    fn an_800_gallon_drop_in_grass_wets_under_two_acres() {
        let a = wetted_area_ft2(800.0, 1.0);
        assert_eq!(a, 80_000.0);
        assert!((a / 43_560.0 - 1.8365).abs() < 1e-3);
        assert_eq!(wetted_area_ft2(800.0, 8.0), 10_000.0);
    }

    #[test]
    fn disc_coverage_keeps_the_wetted_area_at_every_cell_size() {
        for cell_ft in [98.4252, 196.85, 492.126, 500.0] {
            for area in [10_000.0, 40_000.0, 80_000.0, 400_000.0] {
                let cells = disc_coverage(area, cell_ft);
                let covered: f64 = cells.iter().map(|c| f64::from(c.2)).sum::<f64>() * cell_ft * cell_ft;
                assert!(
                    (covered - area).abs() / area < 1e-4,
                    "{cell_ft} ft, {area} ft²: {covered}"
                );
                assert!(cells.iter().all(|c| c.2 > 0.0 && c.2 <= 1.0));
                // Symmetric under a quarter turn.
                for &(dx, dy, f) in &cells {
                    let turned = cells
                        .iter()
                        .find(|c| (c.0, c.1) == (-dy, dx))
                        .expect("turned cell");
                    assert!((turned.2 - f).abs() < 1e-6);
                }
            }
        }
        // A drop smaller than a 500 ft cell wets a fraction of it, nothing else.
        assert_eq!(disc_coverage(40_000.0, 500.0), vec![(0, 0, 0.16)]);
        // On a 30 m grid, 80,000 ft² covers about 8 whole cells' worth.
        let cells = disc_coverage(80_000.0, 98.4252);
        let full = cells.iter().filter(|c| c.2 >= 0.999).count();
        assert!((4..=9).contains(&full), "{full} full cells");
    }
}
