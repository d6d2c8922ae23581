//! The Rothermel–Albini kernel against every behave oracle file, row by row.
//!
//! Fixed-scenario files: relative 1e-6 ("Recommended tolerances" in
//! crates/firecast-sim/tests/fixtures/README.md), widened by half a unit of the oracle's last
//! printed digit where the file prints fewer digits than that needs (e.g. 0.191585 ch/h). Random
//! oracle: two-sided relative 1e-4, direction within 0.01°, exact zeros, stale
//! `lw_ratio`/`back_ftmin`/`flank_ftmin` skipped on zero-ROS rows; no fallback, but 10 listed rows
//! are evaluated at their de-rounded inputs (`DEROUNDED_INPUTS`).

use firecast_sim::rothermel::{FT_PER_MIN_PER_CH_PER_H, FuelMoisture, SpreadInputs, SurfaceFuelBed};
use firecast_sim::spread_csv::OUTPUT_COLUMNS;
use firecast_sim::{FuelModel, SurfaceFireBehavior};

use crate::common::{Checker, Table};

const FIXED_REL: f64 = 1e-6;
const RANDOM_REL: f64 = 1e-4;
const M_PER_FT: f64 = 0.3048;

fn run(
    model: &FuelModel,
    m: [f64; 5],
    wind_mph: f64,
    slope_pct: f64,
    dir: f64,
) -> (SurfaceFuelBed, SurfaceFireBehavior) {
    let bed = SurfaceFuelBed::new(model, &FuelMoisture::from_percent(m[0], m[1], m[2], m[3], m[4])).unwrap();
    let fire = bed.spread(&SpreadInputs {
        midflame_wind_mph: wind_mph,
        slope_percent: slope_pct,
        wind_dir_from_upslope_deg: dir,
    });
    (bed, fire)
}

fn moistures(t: &Table, row: &[String], suffix: &str) -> [f64; 5] {
    ["m1", "m10", "m100", "mherb", "mwoody"].map(|c| t.num(row, &format!("{c}{suffix}")))
}

#[test]
fn anderson13_reference_all_columns() {
    let t = Table::load("behave_reference_anderson13.csv");
    assert_eq!(t.rows.len(), 65);
    let mut c = Checker::new(&t.name);
    for row in &t.rows {
        let model = t.model(row);
        let (wind, slope) = (t.num(row, "midflame_mph"), t.num(row, "slope_pct"));
        let (bed, fire) = run(model, moistures(&t, row, ""), wind, slope, 0.0);
        let ctx = format!(
            "{} wind {wind} slope {slope} m1 {}",
            model.code,
            t.text(row, "m1")
        );
        let mut chk = |col: &str, v: f64| c.check_printed(col, &ctx, v, t.text(row, col), FIXED_REL);
        chk("ros_ftmin", fire.head_ros_ftmin);
        chk("ros_chh", fire.head_ros_chph());
        chk("IR_btu_ft2_min", fire.reaction_intensity_btu_ft2_min);
        chk("HPA_btu_ft2", fire.heat_per_unit_area_btu_ft2);
        chk("FLI_btu_ft_s", fire.fireline_intensity_btu_ft_s);
        chk("FL_ft", fire.flame_length_ft);
        chk("sigma", bed.intermediates().characteristic_sav_per_ft);
        chk("beta", bed.intermediates().packing_ratio);
        chk("beta_ratio", bed.intermediates().relative_packing_ratio);
        chk("bulkdens_lb_ft3", bed.intermediates().bulk_density_lb_ft3);
        chk("heatsink", bed.intermediates().heat_sink_btu_ft3);
        chk("slopefactor", fire.slope_factor);
        chk("LWR", fire.length_to_width_ratio);
        chk("liveMx_pct", 100.0 * bed.intermediates().live_mx_frac);
    }
    c.finish();
}

#[test]
fn scott_burgan_reference() {
    let t = Table::load("behave_reference_scott_burgan.csv");
    assert_eq!(t.rows.len(), 38);
    let mut c = Checker::new(&t.name);
    for row in &t.rows {
        let model = t.model(row);
        assert_eq!(model.code, t.text(row, "code"));
        let (wind, slope) = (t.num(row, "midflame_mph"), t.num(row, "slope_pct"));
        let (_, fire) = run(model, moistures(&t, row, ""), wind, slope, 0.0);
        let ctx = format!("{} slope {slope}", model.code);
        let mut chk = |col: &str, v: f64| c.check_printed(col, &ctx, v, t.text(row, col), FIXED_REL);
        chk("ros_ftmin", fire.head_ros_ftmin);
        chk("ros_chh", fire.head_ros_chph());
        chk("IR_btu_ft2_min", fire.reaction_intensity_btu_ft2_min);
        chk("FL_ft", fire.flame_length_ft);
    }
    c.finish();
}

#[test]
fn anderson_table_conditions() {
    let t = Table::load("behave_anderson_conditions.csv");
    assert_eq!(t.rows.len(), 13);
    let mut c = Checker::new(&t.name);
    for row in &t.rows {
        let model = t.model(row);
        let (_, fire) = run(model, [8.0, 8.0, 8.0, 100.0, 100.0], 5.0, 0.0, 0.0);
        let mut chk = |col: &str, v: f64| c.check_printed(col, model.code, v, t.text(row, col), FIXED_REL);
        chk("ros_ftmin", fire.head_ros_ftmin);
        chk("ros_chh", fire.head_ros_chph());
        chk("FL_ft", fire.flame_length_ft);
    }
    c.finish();
}

/// `S3_wind5_slope30_6-7-8-60-90` → (slope %, moistures %).
fn parse_scenario(s: &str) -> (f64, [f64; 5]) {
    let parts: Vec<&str> = s.split('_').collect();
    let slope = parts
        .iter()
        .find_map(|p| p.strip_prefix("slope"))
        .map_or(0.0, |v| v.parse().unwrap());
    let m: Vec<f64> = parts
        .last()
        .unwrap()
        .split('-')
        .map(|v| v.parse().unwrap())
        .collect();
    (slope, [m[0], m[1], m[2], m[3], m[4]])
}

#[test]
fn rothermel_reference_six_scenarios() {
    let t = Table::load("rothermel_reference_behave.csv");
    assert_eq!(t.rows.len(), 210);
    let mut c = Checker::new(&t.name);
    for row in &t.rows {
        let model = t.model(row);
        assert_eq!(model.code, t.text(row, "code"));
        let scenario = t.text(row, "scenario");
        let (slope, m) = parse_scenario(scenario);
        let (_, fire) = run(model, m, t.num(row, "midflame_mph"), slope, 0.0);
        let ctx = format!("{scenario} {}", model.code);
        let mut chk = |col: &str, v: f64| c.check_printed(col, &ctx, v, t.text(row, col), FIXED_REL);
        chk("ros_chph", fire.head_ros_chph());
        chk("ros_mmin", fire.head_ros_ftmin * M_PER_FT);
        chk("flame_ft", fire.flame_length_ft);
        chk("fli_btuftsec", fire.fireline_intensity_btu_ft_s);
        chk("IR_btuft2min", fire.reaction_intensity_btu_ft2_min);
        chk("hpua_btuft2", fire.heat_per_unit_area_btu_ft2);
        chk("lw_ratio", fire.length_to_width_ratio);
    }
    c.finish();
}

#[test]
fn shape_reference_ellipse() {
    let t = Table::load("rothermel_shape_reference_behave.csv");
    assert_eq!(t.rows.len(), 12);
    let mut c = Checker::new(&t.name);
    for row in &t.rows {
        let model = t.model(row);
        let wind = t.num(row, "midflame_mph");
        let (_, fire) = run(
            model,
            [6.0, 7.0, 8.0, 60.0, 90.0],
            wind,
            t.num(row, "slope_pct"),
            0.0,
        );
        let ctx = format!("{} wind {wind}", model.code);
        let mut chk = |col: &str, v: f64| c.check_printed(col, &ctx, v, t.text(row, col), FIXED_REL);
        chk("head_chph", fire.head_ros_chph());
        chk("back_chph", fire.backing_ros_ftmin / FT_PER_MIN_PER_CH_PER_H);
        chk("flank_chph", fire.flanking_ros_ftmin / FT_PER_MIN_PER_CH_PER_H);
        chk("LW", fire.length_to_width_ratio);
        chk("head_mmin", fire.head_ros_ftmin * M_PER_FT);
        chk("back_mmin", fire.backing_ros_ftmin * M_PER_FT);
        chk("flank_mmin", fire.flanking_ros_ftmin * M_PER_FT);
        // The spread ellipse: ψ = 180° from the head is the backing rate; with no wind, a circle.
        c.check(
            "ros_from_head(180)",
            &ctx,
            fire.ros_from_head_ftmin(180.0),
            fire.backing_ros_ftmin,
            1e-12,
            0.0,
        );
        if wind == 0.0 {
            c.check_exact("circle back", &ctx, fire.backing_ros_ftmin, fire.head_ros_ftmin);
            c.check_exact("circle flank", &ctx, fire.flanking_ros_ftmin, fire.head_ros_ftmin);
        }
    }
    // README example: FM1 at 5 mph has a head distance after 1 h of 1888.787 m.
    let (_, fm1) = run(
        FuelModel::by_code("FM1").unwrap(),
        [6.0, 7.0, 8.0, 60.0, 90.0],
        5.0,
        0.0,
        0.0,
    );
    c.check(
        "FM1 head distance 1 h (m)",
        "FM1 5 mph",
        fm1.head_ros_ftmin * M_PER_FT * 60.0,
        1888.787,
        0.0,
        5e-4,
    );
    c.finish();
}

/// Signed angle a − b wrapped into (−180, 180], degrees.
fn signed_angle_diff_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    if d > 180.0 { d - 360.0 } else { d }
}

/// Output columns of the random oracle, in `spread_csv::OUTPUT_COLUMNS` order.
pub fn random_outputs(fire: &SurfaceFireBehavior) -> [f64; 11] {
    [
        fire.no_wind_no_slope_ros_ftmin,
        fire.head_ros_ftmin,
        fire.head_ros_chph(),
        fire.dir_max_spread_from_upslope_deg,
        fire.reaction_intensity_btu_ft2_min,
        fire.flame_length_ft,
        fire.fireline_intensity_btu_ft_s,
        fire.heat_per_unit_area_btu_ft2,
        fire.length_to_width_ratio,
        fire.backing_ros_ftmin,
        fire.flanking_ros_ftmin,
    ]
}

const DIR: usize = 3;
/// The printed input columns of the random oracle (the direction is an integer, exact).
const INPUT_COLUMNS: [&str; 7] = [
    "m1_pct",
    "m10_pct",
    "m100_pct",
    "mherb_pct",
    "mwoody_pct",
    "midflame_mph",
    "slope_pct",
];

/// The only random-oracle rows compared at inputs other than the printed ones.
///
/// The oracle prints its inputs to 4 decimals, but behave ran on the unrounded draws. For these
/// 10 rows that rounding alone moves outputs by more than 1e-4. Nine sit at 96.7–99.98 % of a
/// moisture of extinction (the dead one; for case 358 the live one, which itself depends on
/// m1), where η_M ≈ 2.93·(1 − M_f/Mx) makes I_R (hence R₀, ROS and the intensities)
/// hypersensitive to the 4th decimal of m1 (case 489: ∂ROS/ROS = 9.5e-3 per 0.00005 % of m1).
/// In case 716 a weak wind (0.4189 mi/h) nearly cancels the slope, so the direction moves 0.076°
/// per 0.00005 mi/h.
///
/// An independent Python implementation of behave's equations
/// (`tests/tools/behave_rounding_check.py`) agrees with this kernel to ≤ 1e-13 at the printed
/// inputs on all 800 rows. For every positive-ROS row, these 10 included, it finds inputs inside
/// the ±½-unit rounding box at which R₀, ROS, direction, I_R and L/W all reproduce the oracle
/// to about half a unit of its last printed digit (≤ 0.95 half-units here, ≤ 1.23 on all 685).
/// The values below are the script's recovered inputs for the 10 rows, in [`INPUT_COLUMNS`]
/// order; run it without arguments to regenerate them.
///
/// [`random_oracle_800_cases`] holds every row to the README tolerances, with no fallback. It
/// asserts that each value here rounds to the printed input, and that the row fails at the
/// printed inputs, so the list cannot silently outlive its reason.
const DEROUNDED_INPUTS: [(u32, [f64; 7]); 10] = [
    (
        67,
        [
            19.8790105584,
            20.3195,
            21.1109,
            130.1463,
            160.3159990445,
            11.4778053592,
            10.6200807714,
        ],
    ),
    (
        134,
        [
            19.269531711,
            20.212883802,
            21.4309806775,
            120.0175,
            157.466,
            0.1086697514,
            0.0,
        ],
    ),
    (
        184,
        [
            14.7794684553,
            14.9623,
            16.6272,
            142.5505575186,
            190.6273,
            0.0,
            72.6133,
        ],
    ),
    (
        197,
        [
            14.6423482307,
            16.7730003997,
            19.6202011827,
            46.5493129557,
            115.1143,
            7.9918435703,
            41.6012704755,
        ],
    ),
    (
        358,
        [
            10.9199281036,
            11.3338,
            13.731,
            78.1965460368,
            103.126,
            6.1298836581,
            71.283200002,
        ],
    ),
    (
        489,
        [
            19.9328731086,
            20.9334,
            23.5262,
            66.3088,
            117.2852362379,
            6.9548528645,
            15.8938606205,
        ],
    ),
    (
        508,
        [
            14.5288625248,
            15.7114,
            17.4538,
            60.7197039909,
            121.1676,
            6.6426228218,
            0.0,
        ],
    ),
    (
        614,
        [
            14.7641481409,
            16.9638,
            17.1038,
            94.425,
            169.5578142758,
            5.7538045134,
            26.03124995,
        ],
    ),
    (
        716,
        [
            7.1013097881,
            9.4760430648,
            12.4408,
            39.45794995,
            74.3312590289,
            0.4188543212,
            14.7101300121,
        ],
    ),
    (
        734,
        [
            19.327360218,
            19.7648000135,
            21.7244,
            73.4853,
            178.0200820899,
            0.3612550424,
            47.6944330626,
        ],
    ),
];

/// The (column, ours, oracle, within tolerance) comparisons the README prescribes for one
/// random-oracle row, `ours` in `OUTPUT_COLUMNS` order: exact zeros on zero-ROS rows (the stale
/// `lw_ratio`/`back_ftmin`/`flank_ftmin` skipped there), otherwise relative 1e-4 and direction
/// within 0.01° (skipped when wind = slope = 0).
fn random_row_comparisons(
    t: &Table,
    row: &[String],
    ours: &[f64; 11],
) -> Vec<(&'static str, f64, f64, bool)> {
    let oracle: Vec<f64> = OUTPUT_COLUMNS.iter().map(|c| t.num(row, c)).collect();
    let mut out = Vec::new();
    if oracle[1] == 0.0 {
        for (i, col) in OUTPUT_COLUMNS.iter().enumerate() {
            if !matches!(*col, "lw_ratio" | "back_ftmin" | "flank_ftmin") {
                out.push((*col, ours[i], oracle[i], ours[i] == 0.0 && oracle[i] == 0.0));
            }
        }
        return out;
    }
    let check_dir = t.num(row, "midflame_mph") > 0.0 || t.num(row, "slope_pct") > 0.0;
    for (i, col) in OUTPUT_COLUMNS.iter().enumerate() {
        if i == DIR {
            if check_dir {
                let diff = signed_angle_diff_deg(ours[i], oracle[i]).abs();
                out.push(("dir_diff_deg", diff, 0.0, diff <= 0.01));
            }
        } else {
            let ok = (ours[i] - oracle[i]).abs() <= RANDOM_REL * oracle[i].abs();
            out.push((*col, ours[i], oracle[i], ok));
        }
    }
    out
}

/// Checks one random-oracle row against `ours` under the README rules, recording into `c`.
pub fn check_random_row(c: &mut Checker, t: &Table, row: &[String], ours: &[f64; 11]) {
    let ctx = format!("case {} {}", t.text(row, "case"), t.text(row, "code"));
    for (col, actual, expected, ok) in random_row_comparisons(t, row, ours) {
        c.record(col, &ctx, actual, expected, ok);
    }
}

/// The de-rounded inputs of a row listed in [`DEROUNDED_INPUTS`], if it is one.
pub fn derounded_inputs(t: &Table, row: &[String]) -> Option<[f64; 7]> {
    let case: u32 = t.num(row, "case") as u32;
    DEROUNDED_INPUTS.iter().find(|(c, _)| *c == case).map(|(_, v)| *v)
}

/// Kernel outputs for a random-oracle row at the given [`INPUT_COLUMNS`] values.
fn random_row_outputs(t: &Table, row: &[String], inputs: [f64; 7]) -> [f64; 11] {
    let (_, fire) = run(
        t.model(row),
        [inputs[0], inputs[1], inputs[2], inputs[3], inputs[4]],
        inputs[5],
        inputs[6],
        t.num(row, "wind_dir_rel_upslope_deg"),
    );
    random_outputs(&fire)
}

#[test]
fn random_oracle_800_cases() {
    let t = Table::load("rothermel_random_oracle_behave.csv");
    assert_eq!(t.rows.len(), 800);
    let mut c = Checker::new("rothermel_random_oracle_behave.csv");
    let mut zero_rows = 0;
    let mut derounded = 0;
    for row in &t.rows {
        let model = t.model(row);
        assert_eq!(model.code, t.text(row, "code"));
        if t.num(row, "ros_ftmin") == 0.0 {
            zero_rows += 1;
        }
        let printed = INPUT_COLUMNS.map(|col| t.num(row, col));
        let inputs = match derounded_inputs(&t, row) {
            None => printed,
            Some(exact) => {
                derounded += 1;
                let case = t.text(row, "case");
                for (k, col) in INPUT_COLUMNS.iter().enumerate() {
                    let text = t.text(row, col);
                    let decimals = text.split_once('.').map_or(0, |(_, f)| f.len());
                    assert_eq!(
                        format!("{:.*}", decimals, exact[k]),
                        text,
                        "case {case}: de-rounded {col} must round to the printed input"
                    );
                }
                let at_printed = random_row_outputs(&t, row, printed);
                assert!(
                    random_row_comparisons(&t, row, &at_printed)
                        .iter()
                        .any(|cmp| !cmp.3),
                    "case {case} now passes at its printed inputs: drop it from DEROUNDED_INPUTS"
                );
                exact
            }
        };
        check_random_row(&mut c, &t, row, &random_row_outputs(&t, row, inputs));
    }
    assert_eq!(zero_rows, 115, "README: 115 cases have ROS = 0");
    assert_eq!(derounded, DEROUNDED_INPUTS.len());
    c.finish();
}

#[test]
fn fuel_table_matches_behave_csv() {
    let t = Table::load("fuel_models.csv");
    assert_eq!(t.rows.len(), FuelModel::standard().len());
    let mut c = Checker::new(&t.name);
    for (row, model) in t.rows.iter().zip(FuelModel::standard()) {
        assert_eq!(t.text(row, "number"), model.number.to_string());
        assert_eq!(t.text(row, "code"), model.code);
        assert_eq!(t.text(row, "name"), model.name);
        assert_eq!(t.text(row, "dynamic") == "True", model.dynamic, "{}", model.code);
        assert_eq!(
            t.text(row, "burnable") == "True",
            model.burnable,
            "{}",
            model.code
        );
        let fields = [
            ("depth_ft", model.depth_ft),
            ("mx_dead_frac", model.mx_dead_frac),
            ("heat_dead_btu_lb", model.heat_dead_btu_lb),
            ("heat_live_btu_lb", model.heat_live_btu_lb),
            ("load_1h_lb_ft2", model.load_1h_lb_ft2),
            ("load_10h_lb_ft2", model.load_10h_lb_ft2),
            ("load_100h_lb_ft2", model.load_100h_lb_ft2),
            ("load_live_herb_lb_ft2", model.load_live_herb_lb_ft2),
            ("load_live_woody_lb_ft2", model.load_live_woody_lb_ft2),
            ("sav_1h_per_ft", model.sav_1h_per_ft),
            ("sav_10h_per_ft", model.sav_10h_per_ft),
            ("sav_100h_per_ft", model.sav_100h_per_ft),
            ("sav_live_herb_per_ft", model.sav_live_herb_per_ft),
            ("sav_live_woody_per_ft", model.sav_live_woody_per_ft),
        ];
        for (col, v) in fields {
            // Loads are printed to 10 decimals in the CSV; the table holds them exactly.
            c.check_printed(col, model.code, v, t.text(row, col), 0.0);
        }
    }
    c.finish();
}

/// behave's own unit tests and other published cross-checks (docs/spec/fire-model.md §B10.2 / §B10.1).
#[test]
fn published_point_checks() {
    let mut c = Checker::new("spec B10 point checks");
    let gs4 = FuelModel::by_code("GS4").unwrap();
    // testSimpleSurface: midflame 5 mph (WAF 1), 30 % slope, wind upslope.
    let (bed, fire) = run(gs4, [6.0, 7.0, 8.0, 60.0, 90.0], 5.0, 30.0, 0.0);
    c.check(
        "GS4 ros_chph",
        "testSimpleSurface",
        fire.head_ros_chph(),
        34.011429,
        1e-6,
        5e-7,
    );
    c.check(
        "GS4 flame_ft",
        "testSimpleSurface",
        fire.flame_length_ft,
        15.811421,
        1e-6,
        5e-7,
    );
    c.check(
        "GS4 fli",
        "testSimpleSurface",
        fire.fireline_intensity_btu_ft_s,
        2292.684759,
        1e-6,
        5e-7,
    );
    // Non-aligned test's wind-independent intermediates.
    c.check(
        "GS4 sigma",
        "testNonAligned",
        bed.intermediates().characteristic_sav_per_ft,
        1631.128734,
        1e-9,
        5e-7,
    );
    c.check(
        "GS4 liveMx %",
        "testNonAligned",
        100.0 * bed.intermediates().live_mx_frac,
        137.968551,
        1e-9,
        5e-7,
    );

    // FM1 intermediates (README): LWR at 5 and 10 mph, φ_s at 30 %.
    let fm1 = FuelModel::by_code("FM1").unwrap();
    let (_, f5) = run(fm1, [6.0, 7.0, 8.0, 60.0, 90.0], 5.0, 0.0, 0.0);
    let (_, f10) = run(fm1, [6.0, 7.0, 8.0, 60.0, 90.0], 10.0, 0.0, 0.0);
    let (_, s2) = run(fm1, [6.0, 7.0, 8.0, 60.0, 90.0], 0.0, 30.0, 0.0);
    c.check(
        "FM1 LWR 5 mph",
        "B10.2",
        f5.length_to_width_ratio,
        1.590064,
        0.0,
        5e-7,
    );
    c.check(
        "FM1 LWR 10 mph",
        "B10.2",
        f10.length_to_width_ratio,
        2.780978,
        0.0,
        5e-7,
    );
    c.check(
        "FM1 LWR slope only",
        "S2",
        s2.length_to_width_ratio,
        1.197205,
        0.0,
        5e-7,
    );
    // Wind-limit check row: FM1 in S5 is 484.612537 ch/h with the limit off (the default).
    let (_, s5) = run(fm1, [3.0, 4.0, 5.0, 30.0, 60.0], 10.0, 0.0, 0.0);
    c.check(
        "FM1 S5 ros_chph",
        "wind limit off",
        s5.head_ros_chph(),
        484.612537,
        1e-6,
        5e-7,
    );

    // ELMFIRE verification case 01 (pins the L/W units): GR2, 1-h 3 %, herb 30 % (fully
    // cured, so the other moistures do not matter), midflame 3.6210 mph: behave 46.1471 ft/min,
    // L/W 1.3797. Midflame is printed to 4 decimals, hence 1e-4.
    let gr2 = FuelModel::by_code("GR2").unwrap();
    let (_, elm) = run(gr2, [3.0, 4.0, 5.0, 30.0, 60.0], 3.6210, 0.0, 0.0);
    c.check(
        "GR2 ros_ftmin",
        "ELMFIRE 01",
        elm.head_ros_ftmin,
        46.1471,
        1e-4,
        0.0,
    );
    c.check(
        "GR2 LWR",
        "ELMFIRE 01",
        elm.length_to_width_ratio,
        1.3797,
        0.0,
        1e-4,
    );

    // pyretechnics' GR1 case: moisture 5/10/15 dead, 90 herb, 60 woody, no wind or slope:
    // behave 0.126403 m/min.
    let gr1 = FuelModel::by_code("GR1").unwrap();
    let (_, py) = run(gr1, [5.0, 10.0, 15.0, 90.0, 60.0], 0.0, 0.0, 0.0);
    c.check(
        "GR1 ros_mmin",
        "pyretechnics",
        py.head_ros_ftmin * M_PER_FT,
        0.126403,
        1e-6,
        5e-7,
    );

    // Non-burnable NB1 (91): zero.
    let (_, nb) = run(
        FuelModel::by_number(91).unwrap(),
        [6.0, 7.0, 8.0, 60.0, 90.0],
        5.0,
        30.0,
        0.0,
    );
    c.check_exact("NB1 ros", "testNonBurnable", nb.head_ros_ftmin, 0.0);
    c.finish();
}
