//! Property tests of the Rothermel kernel over all burnable standard models.

use firecast_sim::FuelModel;
use firecast_sim::rothermel::{FuelMoisture, SpreadInputs, SurfaceFuelBed};
use proptest::prelude::*;

fn burnable_model() -> impl Strategy<Value = &'static FuelModel> {
    let models: Vec<&'static FuelModel> = FuelModel::standard().iter().filter(|m| m.burnable).collect();
    proptest::sample::select(models)
}

prop_compose! {
    fn moisture()(m1 in 0.02..0.30_f64, d10 in 0.0..0.05_f64, d100 in 0.0..0.05_f64,
                  herb in 0.30..2.0_f64, woody in 0.60..2.5_f64) -> FuelMoisture {
        FuelMoisture {
            dead_1h_frac: m1,
            dead_10h_frac: m1 + d10,
            dead_100h_frac: m1 + d10 + d100,
            live_herb_frac: herb,
            live_woody_frac: woody,
        }
    }
}

/// Slack for round-off in comparisons that should hold exactly in real arithmetic.
fn slack(x: f64) -> f64 {
    1e-12 * x.abs().max(1e-12)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn head_ros_non_decreasing_in_upslope_wind(
        model in burnable_model(), m in moisture(),
        slope in 0.0..100.0_f64, u1 in 0.0..30.0_f64, du in 0.0..10.0_f64,
    ) {
        let bed = SurfaceFuelBed::new(model, &m).unwrap();
        let slow = bed.spread(&SpreadInputs::upslope(u1, slope)).head_ros_ftmin;
        let fast = bed.spread(&SpreadInputs::upslope(u1 + du, slope)).head_ros_ftmin;
        prop_assert!(fast >= slow - slack(slow), "{}: {fast} < {slow}", model.code);
    }

    #[test]
    fn head_ros_non_increasing_in_dead_moisture(
        model in burnable_model(), m in moisture(), dm in 0.0..0.10_f64,
        wind in 0.0..20.0_f64, slope in 0.0..100.0_f64, dir in 0.0..360.0_f64,
    ) {
        let wetter = FuelMoisture {
            dead_1h_frac: m.dead_1h_frac + dm,
            dead_10h_frac: m.dead_10h_frac + dm,
            dead_100h_frac: m.dead_100h_frac + dm,
            ..m
        };
        let inputs = SpreadInputs::new(wind, slope, dir).unwrap();
        let dry = SurfaceFuelBed::new(model, &m).unwrap().spread(&inputs).head_ros_ftmin;
        let wet = SurfaceFuelBed::new(model, &wetter).unwrap().spread(&inputs).head_ros_ftmin;
        prop_assert!(wet <= dry + slack(dry), "{}: wet {wet} > dry {dry}", model.code);
    }

    #[test]
    fn ellipse_is_ordered_and_well_formed(
        model in burnable_model(), m in moisture(),
        wind in 0.0..30.0_f64, slope in 0.0..150.0_f64, dir in -720.0..720.0_f64,
    ) {
        let fire = SurfaceFuelBed::new(model, &m).unwrap().spread(&SpreadInputs::new(wind, slope, dir).unwrap());
        prop_assert!(fire.length_to_width_ratio >= 1.0 && fire.length_to_width_ratio <= 8.0);
        prop_assert!(fire.backing_ros_ftmin >= 0.0);
        prop_assert!(fire.backing_ros_ftmin <= fire.flanking_ros_ftmin + slack(fire.flanking_ros_ftmin));
        prop_assert!(fire.flanking_ros_ftmin <= fire.head_ros_ftmin + slack(fire.head_ros_ftmin));
        prop_assert!(fire.head_ros_ftmin >= fire.no_wind_no_slope_ros_ftmin);
        prop_assert!((0.0..360.0).contains(&fire.dir_max_spread_from_upslope_deg));
        if slope == 0.0 && wind > 0.0 && fire.head_ros_ftmin > 0.0 {
            let d = (fire.dir_max_spread_from_upslope_deg - dir).rem_euclid(360.0);
            prop_assert!(d.min(360.0 - d) < 1e-9, "flat ground: max spread follows the wind");
        }
    }

    #[test]
    fn wind_direction_is_mirror_symmetric(
        model in burnable_model(), m in moisture(),
        wind in 0.0..20.0_f64, slope in 0.0..100.0_f64, dir in 0.0..180.0_f64,
    ) {
        let bed = SurfaceFuelBed::new(model, &m).unwrap();
        let right = bed.spread(&SpreadInputs::new(wind, slope, dir).unwrap());
        let left = bed.spread(&SpreadInputs::new(wind, slope, -dir).unwrap());
        prop_assert!((right.head_ros_ftmin - left.head_ros_ftmin).abs() <= slack(right.head_ros_ftmin) * 10.0);
    }
}
