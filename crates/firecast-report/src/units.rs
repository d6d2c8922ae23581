//! Units, NWCG classes and wording shared by the computation and the documents.

pub const SQFT_PER_ACRE: f64 = 43_560.0;

/// Acres covered by one square cell of `cell_size_ft`.
pub fn cell_acres(cell_size_ft: f64) -> f64 {
    cell_size_ft.powi(2) / SQFT_PER_ACRE
}
pub const HA_PER_ACRE: f64 = 0.404_685_642_2;
pub const M_PER_FT: f64 = 0.3048;
/// 1 ch/h = 20.1168 m / 60 min.
pub const M_MIN_PER_CH_H: f64 = 20.1168 / 60.0;
/// 1 Btu/ft/s = 3.46141 kW/m.
pub const KW_M_PER_BTU_FT_S: f64 = 3.461_42;
/// 1 Btu/ft² = 11.3566 kJ/m².
pub const KJ_M2_PER_BTU_FT2: f64 = 11.356_5;
pub const MPH_PER_M_S: f64 = 3600.0 / 1609.344;

pub fn k_to_c(k: f64) -> f64 {
    k - 273.15
}
pub fn k_to_f(k: f64) -> f64 {
    (k - 273.15) * 9.0 / 5.0 + 32.0
}

/// NWCG (PMS 437) adjective class of a head-fire rate of spread, ch/h.
pub fn ros_class(chph: f64) -> &'static str {
    match chph {
        v if v < 2.0 => "Very low",
        v if v < 5.0 => "Low",
        v if v < 20.0 => "Moderate",
        v if v < 50.0 => "High",
        v if v < 150.0 => "Very high",
        _ => "Extreme",
    }
}

/// NWCG (PMS 437) adjective class of a flame length, ft.
pub fn flame_class(ft: f64) -> &'static str {
    match ft {
        v if v < 1.0 => "Very low",
        v if v < 4.0 => "Low",
        v if v < 8.0 => "Moderate",
        v if v < 12.0 => "High",
        v if v < 25.0 => "Very high",
        _ => "Extreme",
    }
}

/// Fireline-intensity class by the Fireline Handbook's breaks (100/500/1000 Btu/ft/s, the
/// intensities of 4, 8 and 11-ft flames).
pub fn intensity_class(btu_ft_s: f64) -> &'static str {
    match btu_ft_s {
        v if v < 100.0 => "Low (hand crews)",
        v if v < 500.0 => "Moderate (engines, dozers)",
        v if v < 1000.0 => "High (head control doubtful)",
        _ => "Very high (no head control)",
    }
}

/// The tactic a flame length implies (Fireline Handbook, appendix B).
pub fn tactic(flame_ft: f64) -> &'static str {
    match flame_ft {
        v if v < 4.0 => "Direct attack at the head and flanks by hand crews; handline should hold the fire.",
        v if v < 8.0 => {
            "Too intense for hand tools at the head; engines, dozers and retardant aircraft can be effective."
        }
        v if v < 11.0 => {
            "Torching, crowning and spotting possible; control efforts at the head probably ineffective."
        }
        _ => {
            "Crowning, spotting and major runs likely; no direct attack at the head — indirect tactics only."
        }
    }
}

/// 16-point compass name of a bearing.
pub fn compass(deg: f64) -> &'static str {
    const NAMES: [&str; 16] = [
        "N", "NNE", "NE", "ENE", "E", "ESE", "SE", "SSE", "S", "SSW", "SW", "WSW", "W", "WNW", "NW", "NNW",
    ];
    NAMES[((deg.rem_euclid(360.0) / 22.5).round() as usize) % 16]
}

/// A number with `digits` decimals and thousands separators.
pub fn fmt_num(v: f64, digits: usize) -> String {
    if !v.is_finite() {
        return "—".into();
    }
    let s = format!("{:.*}", digits, v.abs());
    let (int, frac) = s
        .split_once('.')
        .map_or((s.as_str(), None), |(a, b)| (a, Some(b)));
    let mut out = String::new();
    for (i, ch) in int.chars().enumerate() {
        if i > 0 && (int.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(ch);
    }
    if let Some(f) = frac {
        out.push('.');
        out.push_str(f);
    }
    if v < 0.0 && out.chars().any(|c| c.is_ascii_digit() && c != '0') {
        out.insert(0, '−');
    }
    out
}

/// "39.2500° N, 107.5000° W".
pub fn lat_lon_text(lat: f64, lon: f64) -> String {
    format!(
        "{:.4}° {}, {:.4}° {}",
        lat.abs(),
        if lat >= 0.0 { "N" } else { "S" },
        lon.abs(),
        if lon >= 0.0 { "E" } else { "W" }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_follow_the_breaks() {
        assert_eq!(flame_class(3.9), "Low");
        assert_eq!(flame_class(4.0), "Moderate");
        assert_eq!(ros_class(19.9), "Moderate");
        assert_eq!(ros_class(200.0), "Extreme");
        assert!(tactic(3.0).contains("hand crews"));
        assert!(tactic(12.0).contains("no direct attack"));
    }

    #[test]
    fn byram_breaks_match_the_intensity_classes() {
        // FL = 0.45 I^0.46: 4, 8 and 11 ft at about 100, 500 and 1000 Btu/ft/s.
        let fl = |i: f64| 0.45 * i.powf(0.46);
        assert!((fl(115.0) - 4.0).abs() < 0.1);
        assert!((fl(522.0) - 8.0).abs() < 0.1);
        assert!((fl(1040.0) - 11.0).abs() < 0.15);
    }

    #[test]
    fn numbers_and_places_read_well() {
        assert_eq!(fmt_num(1234567.891, 1), "1,234,567.9");
        assert_eq!(fmt_num(-12.0, 0), "−12");
        assert_eq!(fmt_num(-0.0, 0), "0");
        assert_eq!(compass(225.0), "SW");
        assert_eq!(compass(359.0), "N");
        assert_eq!(lat_lon_text(39.25, -107.5), "39.2500° N, 107.5000° W");
    }
}
