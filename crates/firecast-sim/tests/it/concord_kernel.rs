//! The Concord/FireCastRL compatibility kernel against the Concord reference test values
//! (docs/spec/fire-model.md §A5), plus edge-case policies and the corrected variant.

use firecast_sim::concord::{
    ConcordCell, ConcordFuel, ConcordSpread, ConcordWind, DroughtLevel, EdgeCasePolicy, LandCover,
    MoistureTable, SpreadVariant, direction_factor, fire_spread_rate_ftmin,
};

const COMPAT: SpreadVariant = SpreadVariant::Compat(EdgeCasePolicy::Python);
const COMPAT_JS: SpreadVariant = SpreadVariant::Compat(EdgeCasePolicy::Js);

/// `get-fire-spread-rate.test.ts` setup: source (10, 11) at elevation 0, target (10, 10) at
/// tan(0.1)·cellSize, cellSize 1, M = 0.06.
fn concord_reference(
    fuel: ConcordFuel,
    speed_mph: f64,
    from_direction_deg: f64,
    variant: SpreadVariant,
) -> f64 {
    let source = ConcordCell {
        x: 10,
        y: 11,
        elevation_ft: 0.0,
    };
    let target = ConcordCell {
        x: 10,
        y: 10,
        elevation_ft: 0.1_f64.tan(),
    };
    let wind = ConcordWind {
        speed_mph,
        from_direction_deg,
    };
    fire_spread_rate_ftmin(&source, &target, &fuel.fuel(), 0.06, &wind, 1.0, variant)
}

/// Compares to a value printed in docs/spec/fire-model.md §A5, within one unit of its last printed digit.
fn assert_printed(actual: f64, printed: &str, what: &str) {
    let expected: f64 = printed.parse().unwrap();
    let decimals = printed.split_once('.').map_or(0, |(_, f)| f.len());
    let tol = 10f64.powi(-(decimals as i32));
    assert!(
        (actual - expected).abs() <= tol,
        "{what}: got {actual:.12}, expected {printed} (±{tol:e})"
    );
}

#[test]
fn concord_reference_values() {
    let table = [
        (ConcordFuel::Grass, ["19.40563588", "33.46252017", "802.7428356"]),
        (
            ConcordFuel::Shrub,
            ["14.1437344760", "27.647260880", "541.68779579"],
        ),
        (ConcordFuel::Forest, ["1.275686811", "2.831591284", "64.40222588"]),
        (
            ConcordFuel::ForestWithSuppression,
            ["6.268576733", "12.42085772", "212.927632"],
        ),
    ];
    for variant in [COMPAT, COMPAT_JS] {
        for (fuel, values) in table {
            for (speed, printed) in [1.0, 2.0, 20.0].into_iter().zip(values) {
                let rate = concord_reference(fuel, speed, 0.0, variant);
                assert_printed(rate, printed, &format!("{fuel:?} {speed} mph {variant:?}"));
            }
        }
    }
}

#[test]
fn concord_wind_direction_values() {
    for (dir, printed) in [
        (0.0, "27.647260880"),
        (90.0, "7.0274244"),
        (-90.0, "7.0274244"),
        (180.0, "3.86127"),
    ] {
        let rate = concord_reference(ConcordFuel::Shrub, 2.0, dir, COMPAT);
        assert_printed(rate, printed, &format!("Shrub 2 mph from {dir}°"));
    }
}

#[test]
fn concord_direction_factor_values() {
    // U_E = 100 ft/min; the cell-centre vector points toward −y (angle −π/2).
    let e = COMPAT.eccentricity(100.0);
    let spread_angle = -std::f64::consts::FRAC_PI_2;
    for (max_angle, expected) in [
        (-std::f64::consts::FRAC_PI_2, 1.0),
        (0.0, 0.37),
        (std::f64::consts::PI, 0.37),
        (std::f64::consts::FRAC_PI_2, 0.23),
    ] {
        let df = direction_factor(e, (spread_angle - max_angle).cos());
        assert!(
            (df - expected).abs() < 0.005,
            "max-spread angle {max_angle}: DF {df}, expected {expected}"
        );
    }
}

#[test]
fn python_r0_table() {
    // docs/spec/fire-model.md §A5 "R0 in FireCastRL Python", ft/min at No/Mild/Medium/Severe
    // (printed to 2 decimals; the "≈0" entries are near-cancellations).
    let table: [(LandCover, [f64; 4]); 14] = [
        (LandCover::EvergreenNeedleleaf, [-0.90, -0.34, 0.0, 0.17]),
        (LandCover::EvergreenBroadleaf, [-0.44, -0.10, 0.11, 0.23]),
        (LandCover::DeciduousNeedleleaf, [-0.66, -0.18, 0.09, 0.21]),
        (LandCover::DeciduousBroadleaf, [-0.24, 0.0, 0.14, 0.21]),
        (LandCover::MixedForest, [-0.50, -0.11, 0.12, 0.23]),
        (LandCover::ClosedShrublands, [1.56, 2.47, 3.03, 3.70]),
        (LandCover::OpenShrublands, [1.61, 2.09, 2.50, 3.09]),
        (LandCover::WoodySavannas, [0.95, 1.38, 1.67, 1.97]),
        (LandCover::Savannas, [0.81, 1.28, 1.55, 1.83]),
        (LandCover::Grasslands, [-19.5, -2.77, 5.55, 8.53]),
        (LandCover::PermanentWetlands, [0.33, 0.39, 0.44, 0.51]),
        (LandCover::Croplands, [0.66, 0.91, 1.09, 1.31]),
        (LandCover::CroplandMosaic, [0.54, 1.08, 1.36, 1.63]),
        (LandCover::Barren, [0.022, 0.023, 0.025, 0.03]),
    ];
    for (lc, row) in table {
        for (i, expected) in row.into_iter().enumerate() {
            let drought = DroughtLevel::from_index(i as u8).unwrap();
            let m = lc.moisture_frac(MoistureTable::FireCastRlPython, drought);
            let r0 = ConcordSpread::new(&lc.fuel(), m, COMPAT).no_wind_no_slope_ros_ftmin();
            // Half a unit of the printed last digit (plus round-off). One spec entry is off:
            // DeciduousNeedleleaf/No is printed −0.66, but the docs/spec/fire-model.md §A5 formulas
            // give −0.6548 (an independent re-computation agrees), so it gets one extra hundredth.
            let tol = if expected.abs() >= 10.0 {
                0.051
            } else if lc == LandCover::DeciduousNeedleleaf && i == 0 {
                0.0151
            } else {
                0.0051
            };
            assert!(
                (r0 - expected).abs() <= tol,
                "{lc:?} {drought:?}: R0 {r0}, expected {expected}"
            );
        }
    }
    // TypeScript table: grass at Mild has M = 0.12 and burns (R0 5.55).
    let m = LandCover::Grasslands.moisture_frac(MoistureTable::FireCastRlTypeScript, DroughtLevel::Mild);
    let r0 = ConcordSpread::new(&LandCover::Grasslands.fuel(), m, COMPAT).no_wind_no_slope_ros_ftmin();
    assert!((r0 - 5.55).abs() < 0.0051, "{r0}");
}

#[test]
fn closed_shrub_python_example_at_wind_zero() {
    // docs/spec/fire-model.md §A5: closed shrub (default drought Medium), wind 0, 500-ft cells.
    let lc = LandCover::ClosedShrublands;
    let m = lc.moisture_frac(MoistureTable::FireCastRlPython, DroughtLevel::Medium);
    let k = ConcordSpread::new(&lc.fuel(), m, COMPAT);
    let calm = ConcordWind::default();
    for (dz, up, down) in [(0.0, 0.0, 0.0), (1.0, 3.03, 2.91), (100.0, 5.44, 1.89)] {
        let r_up = k.rate_ftmin(1, 0, dz, &calm, 500.0);
        let r_down = k.rate_ftmin(1, 0, -dz, &calm, 500.0);
        assert!((r_up - up).abs() < 0.0051, "dz {dz} upslope {r_up}");
        assert!((r_down - down).abs() < 0.0051, "dz {dz} downslope {r_down}");
    }
}

#[test]
fn flat_calm_edge_case_policies() {
    let lc = LandCover::ClosedShrublands;
    let m = lc.moisture_frac(MoistureTable::FireCastRlPython, DroughtLevel::Medium);
    let calm = ConcordWind::default();
    let python = ConcordSpread::new(&lc.fuel(), m, COMPAT);
    let js = ConcordSpread::new(&lc.fuel(), m, COMPAT_JS);
    let corrected = ConcordSpread::new(&lc.fuel(), m, SpreadVariant::Corrected);
    assert_eq!(python.rate_ftmin(0, 1, 0.0, &calm, 500.0), 0.0);
    assert_eq!(
        js.rate_ftmin(0, 1, 0.0, &calm, 500.0),
        js.no_wind_no_slope_ros_ftmin()
    );
    assert_eq!(
        js.rate_ftmin(1, 1, 0.0, &calm, 500.0),
        js.no_wind_no_slope_ros_ftmin()
    );
    assert_eq!(
        corrected.rate_ftmin(2, 1, 0.0, &calm, 500.0),
        corrected.no_wind_no_slope_ros_ftmin()
    );
    // Negative R0 (grass at Mild in the Python table) never spreads, whatever the policy.
    let gm = LandCover::Grasslands.moisture_frac(MoistureTable::FireCastRlPython, DroughtLevel::Mild);
    let wind = ConcordWind {
        speed_mph: 10.0,
        from_direction_deg: 0.0,
    };
    for variant in [COMPAT, COMPAT_JS, SpreadVariant::Corrected] {
        let k = ConcordSpread::new(&LandCover::Grasslands.fuel(), gm, variant);
        assert!(!k.can_burn());
        assert_eq!(k.rate_ftmin(0, -1, 50.0, &wind, 500.0), 0.0, "{variant:?}");
    }
}

#[test]
fn corrected_variant_fixes_e_and_damping() {
    // With wind, the E quirk changes the wind factor (spec: grass ×0.53 in compat).
    let fuel = LandCover::Grasslands.fuel();
    let wind = ConcordWind {
        speed_mph: 5.0,
        from_direction_deg: 0.0,
    };
    let compat = ConcordSpread::new(&fuel, 0.06, COMPAT);
    let fixed = ConcordSpread::new(&fuel, 0.06, SpreadVariant::Corrected);
    // R0 does not involve E, and η_M is unclamped only past extinction.
    assert_eq!(
        compat.no_wind_no_slope_ros_ftmin(),
        fixed.no_wind_no_slope_ros_ftmin()
    );
    let r_c = compat.rate_ftmin(0, -1, 0.0, &wind, 500.0);
    let r_f = fixed.rate_ftmin(0, -1, 0.0, &wind, 500.0);
    let r0 = compat.no_wind_no_slope_ros_ftmin();
    let ratio = (r_c / r0 - 1.0) / (r_f / r0 - 1.0);
    assert!((ratio - 0.53).abs() < 0.01, "wind-factor ratio {ratio}");
    // Past extinction the corrected kernel has R0 = 0 exactly (η_M clamped), compat goes negative.
    assert!(ConcordSpread::new(&fuel, 0.2, COMPAT).no_wind_no_slope_ros_ftmin() < 0.0);
    assert_eq!(
        ConcordSpread::new(&fuel, 0.2, SpreadVariant::Corrected).no_wind_no_slope_ros_ftmin(),
        0.0
    );
}

#[test]
fn unburnable_vegetation_and_zones() {
    use firecast_sim::concord::{FIRECASTRL_ZONES, is_firecastrl_river_zone};
    for lc in LandCover::ALL {
        assert_eq!(lc.is_unburnable_vegetation(), !lc.fuel().is_burnable(), "{lc:?}");
    }
    assert_eq!(FIRECASTRL_ZONES[0], FIRECASTRL_ZONES[1]);
    for (i, z) in FIRECASTRL_ZONES.iter().enumerate().skip(1) {
        assert_eq!(usize::from(z.vegetation.modis_class()), i);
    }
    assert_eq!(FIRECASTRL_ZONES[6].default_drought, DroughtLevel::Medium);
    let rivers: Vec<usize> = (0..20).filter(|&i| is_firecastrl_river_zone(i)).collect();
    assert_eq!(rivers, [12, 14, 16, 17]);
}
