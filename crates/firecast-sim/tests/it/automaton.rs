//! The cellular automaton: footprint, non-burnable cells, fire lines, spread shape, determinism.

use firecast_landscape::LandCoverScheme;
use firecast_sim::automaton::{FIRECASTRL_RIVER_CLASSES, HelitackFootprint};
use firecast_sim::{
    Automaton, EdgeCasePolicy, FireState, FuelModel, FuelMoisture, KernelConfig, Neighbourhood, SimConfig,
    SpreadInputs, SpreadVariant, SurfaceFuelBed, Wind, WindHeight, unsheltered_waf,
};

use crate::scenes::{landscape, modis_rough, noise, rough};

fn run_until_out(a: &mut Automaton, max_steps: usize) -> usize {
    for s in 0..max_steps {
        a.step();
        if a.fire_out() {
            return s + 1;
        }
    }
    max_steps
}

/// Time-ordered burn sequence: per step, the sorted list of cells that changed state.
fn burn_sequence(seed: u64, drops: &[(usize, usize, usize)]) -> (Vec<Vec<u32>>, Vec<u64>) {
    let land = modis_rough(6);
    let mut a = Automaton::new(&land, &SimConfig::default()).unwrap();
    a.reset(seed);
    a.ignite(119, 79, 0.0).unwrap();
    let mut seq = Vec::new();
    let mut prev = a.fire_states().to_vec();
    for step in 0..2000 {
        for &(s, x, y) in drops {
            if s == step {
                a.helitack(x, y);
            }
        }
        a.step();
        let changed: Vec<u32> = (0..prev.len())
            .filter(|&i| prev[i] != a.fire_states()[i])
            .map(|i| i as u32)
            .collect();
        prev.copy_from_slice(a.fire_states());
        seq.push(changed);
        if a.fire_out() {
            break;
        }
    }
    let ign_bits = a.ignition_times().iter().map(|t| t.to_bits()).collect();
    (seq, ign_bits)
}

#[test]
fn same_seed_and_actions_give_identical_burns_different_seeds_differ() {
    let drops = [(40, 125, 85), (41, 110, 70), (90, 119, 79)];
    let a = burn_sequence(2, &drops);
    let b = burn_sequence(2, &drops);
    assert_eq!(a.0, b.0, "burn sequence must be bit-identical for the same seed");
    assert_eq!(a.1, b.1, "ignition times must be bit-identical for the same seed");
    assert!(
        a.0.iter().map(Vec::len).sum::<usize>() > 500,
        "the fire must actually spread"
    );
    // The only random draw is the daily latch: over a few seeds the outcome must vary.
    let burnt: Vec<usize> = (1..=6).map(|s| burn_sequence(s, &drops).0.len()).collect();
    assert!(
        burnt.iter().any(|&n| n != burnt[0]),
        "different seeds gave identical episodes: {burnt:?}"
    );
    assert_ne!(burn_sequence(1, &drops).0, a.0, "seeds 1 and 2 must differ");
}

#[test]
fn helitack_footprint_is_80_cells_and_full_disc_81() {
    let land = landscape(40, 40, LandCoverScheme::ModisIgbp, |_, _| 6, rough);
    let mut a = Automaton::new(&land, &SimConfig::default()).unwrap();
    let fp = a.helitack_footprint().to_vec();
    assert_eq!(fp.len(), 80);
    assert!(!fp.contains(&(-5, 0)), "the mirrored loop loses (-5, 0)");
    assert!(fp.contains(&(5, 0)) && fp.contains(&(0, -5)) && fp.contains(&(0, 5)) && fp.contains(&(-4, 3)));
    assert!(fp.iter().all(|&(dx, dy)| dx * dx + dy * dy <= 25));

    // Effect: drops counted on exactly the 80 cells, burning cells quenched, ignitions cancelled.
    a.ignite(20, 20, 0.0).unwrap();
    for _ in 0..60 {
        a.step();
    }
    let burning_before = a.cells_burning();
    assert!(burning_before > 3);
    let inside: u32 = a
        .burning_cells()
        .iter()
        .filter(|&&c| {
            let (dx, dy) = ((c % 40) as i32 - 20, (c / 40) as i32 - 20);
            fp.contains(&(dx, dy))
        })
        .count() as u32;
    let out = a.helitack(20, 20);
    assert_eq!(out.cells, 80);
    assert_eq!(out.quenched, inside);
    assert_eq!(a.cells_burning(), burning_before - inside);
    let dropped: Vec<usize> = (0..1600).filter(|&i| a.helitack_drops(i) == 1).collect();
    assert_eq!(dropped.len(), 80);
    for &i in &dropped {
        assert!(
            a.ignition_times()[i].is_infinite(),
            "scheduled ignition not cancelled"
        );
        assert_ne!(a.fire_state(i), FireState::Burning);
    }
    // Clipped at the grid edge (FireCastRL checks all four bounds).
    assert_eq!(
        a.helitack(0, 0).cells,
        fp.iter().filter(|&&(dx, dy)| dx >= 0 && dy >= 0).count() as u32
    );

    let full = SimConfig {
        helitack_footprint: HelitackFootprint::FullDisc,
        ..SimConfig::default()
    };
    assert_eq!(
        Automaton::new(&land, &full).unwrap().helitack_footprint().len(),
        81
    );
}

#[test]
fn non_burnable_cells_never_burn() {
    // Shrubland with scattered water/barren/cropland cells and a solid water column at x = 70.
    let class = |x: usize, y: usize| {
        if x == 70 {
            17
        } else if noise(x, y, 3) < 0.08 {
            FIRECASTRL_RIVER_CLASSES[(noise(x, y, 4) * 4.0) as usize % 4]
        } else if noise(x, y, 5) < 0.05 {
            13 // urban: not a river cell, but its fuel never burns
        } else {
            6
        }
    };
    let land = landscape(120, 80, LandCoverScheme::ModisIgbp, class, rough);
    let cfg = SimConfig {
        latch_daily_probability: vec![],
        ..SimConfig::default()
    };
    let mut a = Automaton::new(&land, &cfg).unwrap();
    a.ignite(40, 40, 0.0).unwrap();
    let mut ever = vec![false; 120 * 80];
    for _ in 0..3000 {
        a.step();
        for (i, &s) in a.fire_states().iter().enumerate() {
            ever[i] |= s != 0;
        }
        if a.fire_out() {
            break;
        }
    }
    let burnt_west = (0..ever.len()).filter(|&i| ever[i] && i % 120 < 70).count();
    assert!(
        burnt_west > 1500,
        "fire should cover most of the west side, got {burnt_west}"
    );
    for (i, &burned) in ever.iter().enumerate() {
        let (x, y) = (i % 120, i / 120);
        let c = class(x, y);
        if FIRECASTRL_RIVER_CLASSES.contains(&c) || c == 13 {
            assert!(!burned, "non-burnable class {c} cell ({x}, {y}) burned");
            if c != 13 {
                assert!(a.is_non_burnable(i));
            }
        }
        assert!(!(burned && x > 70), "fire crossed the water column at ({x}, {y})");
    }
}

/// Flat uniform closed shrubland, Corrected kernel (spreads on flat ground), no latch, with a
/// vertical fire line at x = 50; ignition at x = 30. Returns cells burned east of the line.
fn burned_beyond_fire_line(wind_mph: f64) -> (usize, usize, f64) {
    let land = landscape(100, 60, LandCoverScheme::ModisIgbp, |_, _| 6, |_, _| 1000.0);
    let cfg = SimConfig {
        kernel: KernelConfig::Concord {
            variant: SpreadVariant::Corrected,
            moisture_table: Default::default(),
        },
        wind: Wind {
            speed_mph: wind_mph,
            from_direction_deg: 270.0,
            ..Wind::default()
        },
        latch_daily_probability: vec![],
        dt_min: 2.0,
        ..SimConfig::default()
    };
    let mut a = Automaton::new(&land, &cfg).unwrap();
    // Two segments (each ≤ 15,000 ft) spanning the grid's height.
    a.add_fire_line((50, 0), (50, 29)).unwrap();
    a.add_fire_line((50, 30), (50, 59)).unwrap();
    assert!(a.is_fire_line(50 + 100 * 45));
    assert!(
        a.add_fire_line((0, 0), (99, 59)).is_err(),
        "longer than 15,000 ft"
    );
    a.ignite(30, 30, 0.0).unwrap();
    run_until_out(&mut a, 200_000);
    let (mut east, mut west) = (0, 0);
    for (i, &s) in a.fire_states().iter().enumerate() {
        let x = i % 100;
        if s != 0 {
            if x > 50 {
                east += 1;
            } else if x < 50 {
                west += 1;
            }
        }
    }
    let max_rate = a.spread_rates().iter().copied().fold(0.0, f64::max);
    (west, east, max_rate)
}

#[test]
fn fire_lines_block_except_at_high_burn_index() {
    // Calm: shrub spreads below 50 ft/min (BI < High); the line holds.
    let (west, east, max_rate) = burned_beyond_fire_line(0.0);
    assert!(
        max_rate < 50.0,
        "calm shrub rate {max_rate} should stay below the High threshold"
    );
    assert!(west > 1000, "fire should fill the west side, got {west}");
    assert_eq!(east, 0, "a fire line must stop a low/medium-intensity fire");
    // Strong westerly: head rates exceed 50 ft/min (BI High) and the fire jumps the line.
    let (_, east, max_rate) = burned_beyond_fire_line(25.0);
    assert!(max_rate >= 50.0, "windy shrub rate {max_rate} should reach High");
    assert!(east > 500, "a High-BI fire must cross the fire line, got {east}");
}

/// Extent of the region that ignited by time `t`: (x_min, x_max, y_min, y_max).
fn extent(a: &Automaton, w: usize, t: f64) -> (usize, usize, usize, usize) {
    let mut e = (usize::MAX, 0, usize::MAX, 0);
    for (i, &ign) in a.ignition_times().iter().enumerate() {
        if ign <= t && a.fire_state(i) != FireState::Unburnt {
            let (x, y) = (i % w, i / w);
            e = (e.0.min(x), e.1.max(x), e.2.min(y), e.3.max(y));
        }
    }
    e
}

/// Burns FM1 short grass on flat ground from `ignition` until the fire comes within 3 cells of
/// the edge; returns the automaton and the time then.
fn grass_fire(wind_mph: f64, ignition: (usize, usize)) -> (Automaton, f64) {
    let land = landscape(201, 161, LandCoverScheme::Fbfm13, |_, _| 1, |_, _| 500.0);
    let cfg = SimConfig {
        kernel: KernelConfig::rothermel_default(),
        wind: Wind {
            speed_mph: wind_mph,
            from_direction_deg: 270.0,
            ..Wind::default()
        },
        latch_daily_probability: vec![],
        dt_min: 1.0,
        ..SimConfig::default()
    };
    let mut a = Automaton::new(&land, &cfg).unwrap();
    a.ignite(ignition.0, ignition.1, 0.0).unwrap();
    loop {
        a.step();
        let (x0, x1, y0, y1) = extent(&a, 201, a.time_min());
        if x0 <= 3 || x1 >= 197 || y0 <= 3 || y1 >= 157 {
            let t = a.time_min();
            return (a, t);
        }
    }
}

#[test]
fn calm_flat_fire_is_round_and_wind_elongates_it_to_the_rothermel_ratio() {
    // Calm: a circle around the ignition (the 16-direction stencil makes it a 16-gon).
    let (a, t) = grass_fire(0.0, (100, 80));
    let (x0, x1, y0, y1) = extent(&a, 201, t);
    let (lx, ly) = ((x1 - x0) as f64, (y1 - y0) as f64);
    assert!((lx / ly - 1.0).abs() < 0.03, "calm fire not round: {lx} x {ly}");
    assert!(
        ((100 - x0) as f64 / (x1 - 100) as f64 - 1.0).abs() < 0.03,
        "calm fire not centred"
    );
    // Diagonal reach vs axial reach: ≤ 3 % apart (stencil anisotropy is ≈ 2.7 % at worst).
    let r_diag = a
        .ignition_times()
        .iter()
        .enumerate()
        .filter(|&(_, &ign)| ign <= t)
        .map(|(i, _)| ((i % 201) as f64 - 100.0 + (i / 201) as f64 - 80.0) / 2f64.sqrt())
        .fold(0.0, f64::max);
    assert!(
        (r_diag / (lx / 2.0) - 1.0).abs() < 0.04,
        "diagonal {r_diag} vs axis {}",
        lx / 2.0
    );

    // 5 mi/h westerly (from 270°, blowing east): ellipse elongated along x.
    let (a, t) = grass_fire(5.0, (40, 80));
    let (x0, x1, y0, y1) = extent(&a, 201, t);
    let (len, wid) = ((x1 - x0) as f64, (y1 - y0) as f64);
    let bed = SurfaceFuelBed::new(
        FuelModel::by_number(1).unwrap(),
        &FuelMoisture::from_percent(6.0, 7.0, 8.0, 60.0, 90.0),
    )
    .unwrap();
    let lw = bed
        .spread(&SpreadInputs::new(5.0, 0.0, 0.0).unwrap())
        .length_to_width_ratio;
    println!(
        "lw expected {lw:.3}, got {:.3} ({len} x {wid}), backing {}",
        len / wid,
        40 - x0
    );
    assert!(len / wid > 1.2, "wind must elongate the fire");
    assert!(
        (len / wid / lw - 1.0).abs() < 0.10,
        "L/W {:.3} vs Rothermel {lw:.3}",
        len / wid
    );
    // Symmetric about the wind axis, and the head runs downwind of the ignition.
    assert!(((80 - y0) as f64 / (y1 - 80) as f64 - 1.0).abs() < 0.05);
    assert!(x1 - 40 > 3 * (40 - x0));
}

#[test]
fn unburnt_islands_block_until_a_spark_lands_inside() {
    let land = landscape(60, 40, LandCoverScheme::ModisIgbp, |_, _| 6, rough);
    let cfg = SimConfig {
        latch_daily_probability: vec![],
        ..SimConfig::default()
    };
    let island: Vec<(usize, usize)> = (10..20).flat_map(|y| (30..40).map(move |x| (x, y))).collect();
    let mut a = Automaton::new(&land, &cfg).unwrap();
    a.add_unburnt_island(&island).unwrap();
    a.ignite(10, 30, 0.0).unwrap();
    run_until_out(&mut a, 20_000);
    assert!(a.cells_burnt() > 1500);
    for &(x, y) in &island {
        assert_eq!(
            a.fire_state(y * 60 + x),
            FireState::Unburnt,
            "island cell ({x}, {y}) burned"
        );
    }
    // A spark inside removes the whole island (flood fill): it burns like the rest.
    a.reset(0);
    a.add_unburnt_island(&island).unwrap();
    a.ignite(35, 15, 0.0).unwrap();
    assert!(island.iter().all(|&(x, y)| !a.is_unburnt_island(y * 60 + x)));
    run_until_out(&mut a, 20_000);
    assert!(
        island
            .iter()
            .filter(|&&(x, y)| a.fire_state(y * 60 + x) != FireState::Unburnt)
            .count()
            > 80
    );
}

/// Unsheltered WAF as behave computes it: 0.362 for a 1-ft bed (GR2, FM1), growing with depth.
#[test]
fn wind_adjustment_factor_matches_behave() {
    assert!(
        (unsheltered_waf(1.0) - 0.3623).abs() < 5e-4,
        "{}",
        unsheltered_waf(1.0)
    );
    assert!(unsheltered_waf(6.0) > unsheltered_waf(1.0));
    assert_eq!(unsheltered_waf(0.0), 0.0);
}

/// A 10-m wind burns exactly like the midflame wind it implies: FM1's 1-ft bed gives
/// midflame = WAF(1 ft) × U10 / 1.15, so both automata must ignite the same cells.
#[test]
fn ten_metre_wind_is_brought_to_midflame_per_fuel() {
    let land = landscape(
        80,
        60,
        LandCoverScheme::Fbfm13,
        |_, _| 1,
        |x, y| 500.0 + 3.0 * (x + y) as f32,
    );
    let run = |wind: Wind| {
        let cfg = SimConfig {
            kernel: KernelConfig::rothermel_default(),
            wind,
            latch_daily_probability: vec![],
            dt_min: 1.0,
            ..SimConfig::default()
        };
        let mut a = Automaton::new(&land, &cfg).unwrap();
        a.ignite(20, 30, 0.0).unwrap();
        for _ in 0..120 {
            a.step();
        }
        a.fire_states().to_vec()
    };
    let ten_metre = Wind {
        speed_mph: 20.0,
        from_direction_deg: 250.0,
        measured_at: WindHeight::TenMetre,
    };
    let midflame = Wind {
        speed_mph: unsheltered_waf(1.0) * 20.0 / 1.15,
        from_direction_deg: 250.0,
        measured_at: WindHeight::Midflame,
    };
    let as_midflame = Wind {
        speed_mph: 20.0,
        ..midflame
    };
    let burnt = |s: &[u8]| s.iter().filter(|&&v| v != 0).count();
    assert_eq!(run(ten_metre), run(midflame));
    // And it is weaker than the same number taken as midflame.
    assert!(burnt(&run(ten_metre)) < burnt(&run(as_midflame)));
}

/// Offsets from the source (4, 4) of a flat 9×9 closed-shrub grid, with water at `water`
/// (offsets too), that the source's single spread schedules. Calm air with the JS edge case
/// gives every burnable neighbour the rate R₀ > 0, so exactly the offered cells get an
/// ignition time (all later than the first step).
fn offered(water: &[(i32, i32)], neighbourhood: Neighbourhood, radius: f64) -> Vec<(i32, i32)> {
    let class = |x: usize, y: usize| {
        let d = (x as i32 - 4, y as i32 - 4);
        if water.contains(&d) { 17 } else { 6 }
    };
    let land = landscape(9, 9, LandCoverScheme::ModisIgbp, class, |_, _| 1000.0);
    let cfg = SimConfig {
        kernel: KernelConfig::Concord {
            variant: SpreadVariant::Compat(EdgeCasePolicy::Js),
            moisture_table: Default::default(),
        },
        latch_daily_probability: vec![],
        neighbour_radius_cells: radius,
        neighbourhood,
        ..SimConfig::default()
    };
    let mut a = Automaton::new(&land, &cfg).unwrap();
    a.ignite(4, 4, 0.0).unwrap();
    a.step();
    assert_eq!(a.fire_state(4 * 9 + 4), FireState::Burning);
    let mut out: Vec<(i32, i32)> = (0..81)
        .filter(|&i| a.fire_state(i) == FireState::Unburnt && a.ignition_times()[i].is_finite())
        .map(|i| ((i % 9) as i32 - 4, (i / 9) as i32 - 4))
        .collect();
    out.sort_unstable();
    out
}

#[test]
fn bfs_does_not_reach_around_non_burnable_cells_that_line_of_sight_sees_past() {
    const W: (i32, i32) = (-1, 0);
    const E: (i32, i32) = (1, 0);
    const S: (i32, i32) = (0, -1);
    const N: (i32, i32) = (0, 1);
    let diagonals = vec![(-1, -1), (-1, 1), (1, -1), (1, 1)];
    // Radius 1.5 (8 neighbours, no intermediate points). Water west and south: the south-west
    // diagonal is in sight, but every 4-connected path to it crosses water.
    let water = [W, S];
    assert_eq!(
        offered(&water, Neighbourhood::LineOfSight, 1.5),
        vec![(-1, -1), (-1, 1), (0, 1), (1, -1), (1, 0), (1, 1)]
    );
    assert_eq!(
        offered(&water, Neighbourhood::Bfs, 1.5),
        vec![(-1, 1), (0, 1), (1, -1), (1, 0), (1, 1)]
    );
    // Water on all four sides: line of sight still reaches the four diagonals, BFS nothing.
    let walled = [W, E, S, N];
    assert_eq!(offered(&walled, Neighbourhood::LineOfSight, 1.5), diagonals);
    assert_eq!(offered(&walled, Neighbourhood::Bfs, 1.5), vec![]);
    // The same at the default radius 2.5: BFS offers nothing; line of sight offers the
    // diagonals but not the cells two steps out along the axes (their line crosses water).
    assert_eq!(offered(&walled, Neighbourhood::Bfs, 2.5), vec![]);
    let los = offered(&walled, Neighbourhood::LineOfSight, 2.5);
    assert!(diagonals.iter().all(|d| los.contains(d)), "{los:?}");
    assert!(
        [(-2, 0), (2, 0), (0, -2), (0, 2)]
            .iter()
            .all(|d| !los.contains(d)),
        "{los:?}"
    );
}

#[test]
fn bfs_checks_the_line_from_the_candidate_to_the_source() {
    // One water cell west of the source, radius 2.5 (20 offsets). Once BFS has met it, a cell
    // is offered only if the line from it to the source is clear: (-2, 0) is hidden behind
    // the water, but (-2, ±1) are offered, as their line from the candidate passes the
    // diagonal (-1, ±1) (drawn from the source instead, it would pass the water).
    let got = offered(&[(-1, 0)], Neighbourhood::Bfs, 2.5);
    assert_eq!(got.len(), 18, "{got:?}");
    for d in [(-1, 0), (-2, 0)] {
        assert!(!got.contains(&d), "{d:?} offered: {got:?}");
    }
    for d in [(-2, -1), (-2, 1), (-1, -2), (-1, 2), (2, 0), (0, 2), (0, -2)] {
        assert!(got.contains(&d), "{d:?} not offered: {got:?}");
    }
    // Without water both schemes offer all 20.
    assert_eq!(offered(&[], Neighbourhood::Bfs, 2.5).len(), 20);
    assert_eq!(offered(&[], Neighbourhood::LineOfSight, 2.5).len(), 20);
}

/// Per step, the cells that changed state; and the final ignition times' bits. Shrubland
/// with scattered non-burnable and urban cells on rough terrain, P2 kernel and latch.
fn scattered_river_burn(neighbourhood: Neighbourhood, seed: u64) -> (Vec<Vec<u32>>, Vec<u64>) {
    let class = |x: usize, y: usize| {
        if noise(x, y, 3) < 0.15 {
            FIRECASTRL_RIVER_CLASSES[(noise(x, y, 4) * 4.0) as usize % 4]
        } else if noise(x, y, 5) < 0.03 {
            13
        } else {
            6
        }
    };
    let land = landscape(120, 80, LandCoverScheme::ModisIgbp, class, rough);
    let cfg = SimConfig {
        neighbourhood,
        ..SimConfig::default()
    };
    let mut a = Automaton::new(&land, &cfg).unwrap();
    a.reset(seed);
    a.ignite(60, 40, 0.0).unwrap();
    let mut seq = Vec::new();
    let mut prev = a.fire_states().to_vec();
    for _ in 0..3000 {
        a.step();
        let changed: Vec<u32> = (0..prev.len())
            .filter(|&i| prev[i] != a.fire_states()[i])
            .map(|i| i as u32)
            .collect();
        prev.copy_from_slice(a.fire_states());
        seq.push(changed);
        if a.fire_out() {
            break;
        }
    }
    for (i, &s) in a.fire_states().iter().enumerate() {
        assert!(s == 0 || !a.is_non_burnable(i), "non-burnable cell {i} burned");
    }
    (seq, a.ignition_times().iter().map(|t| t.to_bits()).collect())
}

#[test]
fn bfs_mode_is_deterministic_and_differs_from_line_of_sight() {
    let bfs = scattered_river_burn(Neighbourhood::Bfs, 3);
    assert_eq!(
        bfs,
        scattered_river_burn(Neighbourhood::Bfs, 3),
        "BFS runs differ"
    );
    let burnt = bfs.0.iter().map(Vec::len).sum::<usize>();
    assert!(burnt > 1000, "the fire must spread, {burnt} state changes");
    let los = scattered_river_burn(Neighbourhood::LineOfSight, 3);
    assert_ne!(bfs.0, los.0, "the neighbourhood option has no effect");
}

#[test]
fn neighbourhood_is_configured_in_snake_case_and_defaults_to_line_of_sight() {
    let cfg: SimConfig = serde_json::from_str(r#"{"neighbourhood": "bfs"}"#).unwrap();
    assert_eq!(cfg.neighbourhood, Neighbourhood::Bfs);
    let cfg: SimConfig = serde_json::from_str("{}").unwrap();
    assert_eq!(cfg.neighbourhood, Neighbourhood::LineOfSight);
    assert!(serde_json::from_str::<SimConfig>(r#"{"neighbourhood": "moore"}"#).is_err());
}

#[test]
fn physical_drops_wet_their_volume_whatever_the_cell_size() {
    // Short grass (Anderson 1, coverage level 1): an 800-gallon drop wets 80,000 ft².
    let cfg = SimConfig {
        kernel: KernelConfig::rothermel_default(),
        helitack_footprint: HelitackFootprint::Coverage,
        ..SimConfig::default()
    };
    let mut fine = landscape(41, 41, LandCoverScheme::Fbfm13, |_, _| 1, rough);
    fine.cell_size_ft = 30.0 / 0.3048;
    let mut a = Automaton::new(&fine, &cfg).unwrap();
    let out = a.helitack(20, 20);
    let treated = (0..41 * 41).filter(|&i| a.helitack_drops(i) > 0).count();
    assert_eq!(out.cells as usize, treated);
    assert!((5..=9).contains(&treated), "{treated} cells of 30 m treated");
    let received: f64 = a.drop_coverage().unwrap().iter().map(|&c| f64::from(c)).sum();
    let wetted = received * fine.cell_size_ft.powi(2);
    assert!((wetted - 80_000.0).abs() < 10.0, "{wetted} ft²");

    // On 500 ft cells the same drop wets 0.32 of the cell under it: the fourth treats it.
    let coarse = landscape(41, 41, LandCoverScheme::Fbfm13, |_, _| 1, rough);
    let mut b = Automaton::new(&coarse, &cfg).unwrap();
    for _ in 0..3 {
        assert_eq!(b.helitack(20, 20).cells, 0);
    }
    assert_eq!(b.helitack(20, 20).cells, 1);
    assert_eq!(b.helitack_drops(20 * 41 + 20), 1);
    assert_eq!((0..41 * 41).filter(|&i| b.helitack_drops(i) > 0).count(), 1);

    // Heavy slash (13, level 8) beside the grass: laid at the grass's level, the drop gives the
    // slash an eighth of what it gives the grass.
    let mixed = landscape(
        41,
        41,
        LandCoverScheme::Fbfm13,
        |x, _| if x > 20 { 13 } else { 1 },
        rough,
    );
    let mut m = Automaton::new(&mixed, &{
        let mut c = cfg.clone();
        c.helitack_volume_gal = 8_000.0;
        c
    })
    .unwrap();
    m.helitack(20, 20);
    let cov = m.drop_coverage().unwrap();
    let (grass, slash) = (cov[20 * 41 + 19], cov[20 * 41 + 21]);
    assert!(
        grass > 0.3 && (slash - grass / 8.0).abs() < 1e-5,
        "grass {grass}, slash {slash}"
    );

    // A burning cell a drop completes is put out; FireCastRL's footprint is unchanged.
    let mut f = Automaton::new(&fine, &cfg).unwrap();
    f.ignite(20, 20, 0.0).unwrap();
    f.step();
    assert!(f.cells_burning() >= 1);
    let out = f.helitack(20, 20);
    assert!(out.quenched >= 1);
    assert_eq!(f.fire_state(20 * 41 + 20), FireState::Unburnt);
    let compat = SimConfig {
        kernel: KernelConfig::rothermel_default(),
        ..SimConfig::default()
    };
    assert_eq!(
        Automaton::new(&coarse, &compat).unwrap().helitack(20, 20).cells,
        80
    );
    assert!(
        Automaton::new(&coarse, &compat)
            .unwrap()
            .drop_coverage()
            .is_none()
    );

    let bad = SimConfig {
        helitack_volume_gal: 0.0,
        ..cfg
    };
    assert!(Automaton::new(&coarse, &bad).is_err());
}
