//! The README's consistency identities and the ellipse relations, on the kernel's own outputs
//! over all 800 random-oracle inputs (and checked on the oracle rows themselves as a fixture
//! sanity check).

use firecast_sim::rothermel::{FuelMoisture, SpreadInputs, SurfaceFuelBed};

use crate::common::{Checker, Table};

#[test]
fn identities_hold_on_kernel_outputs() {
    let t = Table::load("rothermel_random_oracle_behave.csv");
    let mut c = Checker::new("identities (kernel outputs)");
    for row in &t.rows {
        let m = ["m1_pct", "m10_pct", "m100_pct", "mherb_pct", "mwoody_pct"].map(|col| t.num(row, col));
        let bed = SurfaceFuelBed::new(
            t.model(row),
            &FuelMoisture::from_percent(m[0], m[1], m[2], m[3], m[4]),
        )
        .unwrap();
        let fire = bed.spread(&SpreadInputs {
            midflame_wind_mph: t.num(row, "midflame_mph"),
            slope_percent: t.num(row, "slope_pct"),
            wind_dir_from_upslope_deg: t.num(row, "wind_dir_rel_upslope_deg"),
        });
        let ctx = format!("case {}", t.text(row, "case"));
        assert!(fire.length_to_width_ratio >= 1.0, "{ctx}");
        assert!(fire.backing_ros_ftmin <= fire.flanking_ros_ftmin, "{ctx}");
        assert!(fire.flanking_ros_ftmin <= fire.head_ros_ftmin, "{ctx}");
        if fire.head_ros_ftmin <= 0.0 {
            continue;
        }
        let ros = fire.head_ros_ftmin;
        let rel = 1e-12;
        c.check(
            "fli = hpua·ros/60",
            &ctx,
            fire.fireline_intensity_btu_ft_s,
            fire.heat_per_unit_area_btu_ft2 * ros / 60.0,
            rel,
            0.0,
        );
        c.check(
            "flame = 0.45·fli^0.46",
            &ctx,
            fire.flame_length_ft,
            0.45 * fire.fireline_intensity_btu_ft_s.powf(0.46),
            rel,
            0.0,
        );
        c.check(
            "ros_ftmin = 1.1·ros_chph",
            &ctx,
            ros,
            1.1 * fire.head_ros_chph(),
            rel,
            0.0,
        );
        c.check(
            "hpua = IR·384/σ",
            &ctx,
            fire.heat_per_unit_area_btu_ft2,
            fire.reaction_intensity_btu_ft2_min * 384.0 / bed.intermediates().characteristic_sav_per_ft,
            rel,
            0.0,
        );
        let lw = fire.length_to_width_ratio;
        let e = (lw * lw - 1.0).sqrt() / lw;
        c.check("e = √(LW²−1)/LW", &ctx, fire.eccentricity, e, rel, 1e-15);
        c.check(
            "back = head·(1−e)/(1+e)",
            &ctx,
            fire.backing_ros_ftmin,
            ros * (1.0 - e) / (1.0 + e),
            rel,
            0.0,
        );
        c.check(
            "flank = ½(head+back)/LW",
            &ctx,
            fire.flanking_ros_ftmin,
            0.5 * (ros + fire.backing_ros_ftmin) / lw,
            rel,
            0.0,
        );
        c.check(
            "ros toward max-spread dir",
            &ctx,
            fire.ros_toward_ftmin(fire.dir_max_spread_from_upslope_deg),
            ros,
            rel,
            0.0,
        );
        if t.num(row, "midflame_mph") == 0.0 && t.num(row, "slope_pct") == 0.0 {
            c.check_exact(
                "ros = R0 when calm and flat",
                &ctx,
                ros,
                fire.no_wind_no_slope_ros_ftmin,
            );
        }
    }
    c.finish();
}

#[test]
fn identities_hold_on_oracle_rows() {
    let t = Table::load("rothermel_random_oracle_behave.csv");
    let mut c = Checker::new("identities (oracle rows)");
    for row in &t.rows {
        let ros = t.num(row, "ros_ftmin");
        if ros <= 0.0 {
            continue;
        }
        let ctx = format!("case {}", t.text(row, "case"));
        let (fli, hpua) = (t.num(row, "fli_btufts"), t.num(row, "hpua_btuft2"));
        c.check("fli = hpua·ros/60", &ctx, fli, hpua * ros / 60.0, 1e-6, 0.0);
        c.check(
            "flame = 0.45·fli^0.46",
            &ctx,
            t.num(row, "flame_ft"),
            0.45 * fli.powf(0.46),
            1e-6,
            0.0,
        );
        c.check(
            "ros_ftmin = 1.1·ros_chph",
            &ctx,
            ros,
            1.1 * t.num(row, "ros_chph"),
            1e-6,
            0.0,
        );
    }
    c.finish();
}
