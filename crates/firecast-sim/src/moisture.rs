//! The day's fuel moisture from daily weather (docs/spec/fire-model.md §B12).
//!
//! GRIDMET gives 100-h and 1000-h dead fuel moisture (`fm100`, `fm1000`) but no 1-h, 10-h or
//! live moisture. FireCast derives them with the National Fire Danger Rating System's methods:
//!
//! - **Dead 1-h and 10-h** (NFDRS 1978, Cohen & Deeming 1985): the equilibrium moisture content
//!   of Simard (1968) at the air in contact with the fuel — the afternoon temperature and
//!   humidity corrected for sunshine by the state of the weather (Byram & Jemison 1943) — times
//!   1.03 (1-h) and 1.28 (10-h). FireCast uses the day's maximum temperature and minimum
//!   humidity (GRIDMET `tmmx`, `rmin`): the burn period's conditions.
//! - **Live herbaceous and woody** (NFDRS 2016): the Growing Season Index of Jolly, Nemani &
//!   Running (2005) — minimum temperature, vapour pressure deficit and day length, averaged over
//!   the 21 days ending on the day — scaled from dormant to fully green above a green-up
//!   threshold of 0.5: herbaceous 30–250 %, woody 60–200 %.

use serde::{Deserialize, Serialize};

/// Simard's (1968) equilibrium moisture content (percent of dry weight) at `temp_f` °F and
/// `rh_pct` % relative humidity, the three-range fit NFDRS uses.
pub fn equilibrium_moisture_pct(temp_f: f64, rh_pct: f64) -> f64 {
    let (t, h) = (temp_f, rh_pct.clamp(0.0, 100.0));
    let emc = if h < 10.0 {
        0.03229 + 0.281073 * h - 0.000578 * h * t
    } else if h < 50.0 {
        2.22749 + 0.160107 * h - 0.014784 * t
    } else {
        21.0606 + 0.005565 * h * h - 0.00035 * h * t - 0.483199 * h
    };
    emc.max(0.0)
}

/// Cloud cover at the afternoon observation (NFDRS state-of-weather codes 0–3): how much the
/// sun heats the fuel surface above the air.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StateOfWeather {
    /// Code 0, less than 1/10 cloud: fuel surface 25 °F warmer, humidity × 0.75.
    #[default]
    Clear,
    /// Code 1, 1/10 to 5/10: +19 °F, × 0.83.
    Scattered,
    /// Code 2, 6/10 to 9/10: +12 °F, × 0.92.
    Broken,
    /// Code 3, overcast: +5 °F, × 1.0.
    Overcast,
}

impl StateOfWeather {
    /// Byram & Jemison's correction from instrument height to the fuel-atmosphere interface:
    /// (°F added, humidity factor).
    fn correction(self) -> (f64, f64) {
        match self {
            Self::Clear => (25.0, 0.75),
            Self::Scattered => (19.0, 0.83),
            Self::Broken => (12.0, 0.92),
            Self::Overcast => (5.0, 1.0),
        }
    }
}

/// Dead 1-h and 10-h fuel moisture (percent) from the afternoon's temperature (°F) and relative
/// humidity (%), NFDRS 1978 without fuel sticks.
pub fn fine_dead_moisture_pct(temp_f: f64, rh_pct: f64, sky: StateOfWeather) -> (f64, f64) {
    let (dt, factor) = sky.correction();
    let emc = equilibrium_moisture_pct(temp_f + dt, rh_pct * factor);
    (1.03 * emc, 1.28 * emc)
}

/// Hours of daylight, in seconds, at latitude `lat_deg` on day `day_of_year` (1–366): the
/// sunrise hour angle for the solar declination of Cooper (1969), clamped to polar day/night.
pub fn day_length_s(lat_deg: f64, day_of_year: u32) -> f64 {
    let declination =
        (23.45f64).to_radians() * (std::f64::consts::TAU * (284.0 + f64::from(day_of_year)) / 365.0).sin();
    let x = -lat_deg.to_radians().tan() * declination.tan();
    let hour_angle = x.clamp(-1.0, 1.0).acos();
    hour_angle / std::f64::consts::PI * 86_400.0
}

/// Jolly, Nemani & Running's (2005) Growing Season Index of one day, 0 (dormant) to 1: the
/// product of ramps in minimum temperature (−2 → 5 °C), vapour pressure deficit (4,100 → 900 Pa)
/// and day length (10 → 11 h).
pub fn growing_season_index(tmin_c: f64, vpd_pa: f64, day_length_s: f64) -> f64 {
    let ramp = |x: f64, lo: f64, hi: f64| ((x - lo) / (hi - lo)).clamp(0.0, 1.0);
    ramp(tmin_c, -2.0, 5.0) * (1.0 - ramp(vpd_pa, 900.0, 4_100.0)) * ramp(day_length_s, 36_000.0, 39_600.0)
}

/// NFDRS 2016's green-up threshold: below it live fuels are dormant.
pub const GREENUP_GSI: f64 = 0.5;

fn live_moisture_pct(gsi: f64, min_pct: f64, max_pct: f64) -> f64 {
    let gsi = gsi.clamp(0.0, 1.0);
    if gsi < GREENUP_GSI {
        min_pct
    } else {
        min_pct + (max_pct - min_pct) * (gsi - GREENUP_GSI) / (1.0 - GREENUP_GSI)
    }
}

/// Live herbaceous moisture (percent) from the 21-day mean GSI: 30 % dormant (fully cured in a
/// dynamic fuel model) to 250 %.
pub fn live_herbaceous_pct(gsi_21d: f64) -> f64 {
    live_moisture_pct(gsi_21d, 30.0, 250.0)
}

/// Live woody moisture (percent) from the 21-day mean GSI: 60 % dormant to 200 %.
pub fn live_woody_pct(gsi_21d: f64) -> f64 {
    live_moisture_pct(gsi_21d, 60.0, 200.0)
}

/// Kelvin → degrees Fahrenheit.
pub fn kelvin_to_f(k: f64) -> f64 {
    (k - 273.15) * 9.0 / 5.0 + 32.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn emc_matches_the_three_ranges_worked_by_hand() {
        // 5 % at 80 °F: 0.03229 + 1.405365 − 0.2312.
        assert!((equilibrium_moisture_pct(80.0, 5.0) - 1.206455).abs() < 1e-9);
        // 30 % at 70 °F: 2.22749 + 4.80321 − 1.03488.
        assert!((equilibrium_moisture_pct(70.0, 30.0) - 5.99582).abs() < 1e-9);
        // 80 % at 60 °F: 21.0606 + 35.616 − 1.68 − 38.65592.
        assert!((equilibrium_moisture_pct(60.0, 80.0) - 16.34068).abs() < 1e-9);
    }

    #[test]
    fn emc_rises_with_humidity_and_falls_with_temperature() {
        let mut last = 0.0;
        for h in 0..=100 {
            let m = equilibrium_moisture_pct(75.0, f64::from(h));
            assert!(m >= last, "EMC falls from {last} to {m} at {h} %");
            last = m;
        }
        for h in [5.0, 30.0, 80.0] {
            assert!(equilibrium_moisture_pct(40.0, h) > equilibrium_moisture_pct(100.0, h));
        }
    }

    #[test]
    fn a_hot_dry_clear_afternoon_gives_fine_fuels_near_three_percent() {
        // 95 °F and 15 % humidity under a clear sky: fuel surface 120 °F, 11.25 %.
        let (m1, m10) = fine_dead_moisture_pct(95.0, 15.0, StateOfWeather::Clear);
        let emc = 2.22749 + 0.160107 * 11.25 - 0.014784 * 120.0;
        assert!((m1 - 1.03 * emc).abs() < 1e-12 && (m10 - 1.28 * emc).abs() < 1e-12);
        assert!((2.0..3.5).contains(&m1), "{m1}");
        // Clouds keep fuels moister.
        let (o1, _) = fine_dead_moisture_pct(95.0, 15.0, StateOfWeather::Overcast);
        assert!(o1 > m1);
    }

    #[test]
    fn day_length_is_twelve_hours_at_the_equinoxes_and_long_in_summer() {
        assert!((day_length_s(0.0, 172) - 43_200.0).abs() < 1.0);
        // 40° N: about 15 h at the June solstice, about 9.2 h at the December one.
        let june = day_length_s(40.0, 172) / 3600.0;
        let december = day_length_s(40.0, 355) / 3600.0;
        assert!((14.8..15.2).contains(&june), "{june}");
        assert!((9.0..9.4).contains(&december), "{december}");
        assert_eq!(day_length_s(80.0, 172), 86_400.0);
        assert_eq!(day_length_s(80.0, 355), 0.0);
    }

    #[test]
    fn gsi_ramps_and_live_moisture_scales_above_greenup() {
        assert_eq!(growing_season_index(10.0, 500.0, 50_000.0), 1.0);
        assert_eq!(growing_season_index(-3.0, 500.0, 50_000.0), 0.0);
        assert_eq!(growing_season_index(10.0, 5_000.0, 50_000.0), 0.0);
        assert_eq!(growing_season_index(10.0, 500.0, 30_000.0), 0.0);
        assert!((growing_season_index(1.5, 2_500.0, 37_800.0) - 0.5 * 0.5 * 0.5).abs() < 1e-12);
        assert_eq!(live_herbaceous_pct(0.3), 30.0);
        assert_eq!(live_woody_pct(0.49), 60.0);
        assert_eq!(live_herbaceous_pct(1.0), 250.0);
        assert_eq!(live_woody_pct(1.0), 200.0);
        assert!((live_herbaceous_pct(0.75) - 140.0).abs() < 1e-9);
        assert!((live_woody_pct(0.75) - 130.0).abs() < 1e-9);
    }
}
