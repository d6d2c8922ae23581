//! Crown fire as FlamMap computes it for one cell (`docs/spec/fire-model.md §B11`): Van
//! Wagner's (1977) initiation, Rothermel's (1991) active crown spread rate (fuel model 10 with
//! the 20-ft wind × 0.4, times 3.34), Van Wagner's critical active rate 3/CBD, and the crown
//! fraction burned by one of two methods — Finney's (FARSITE/FlamMap's default, Van Wagner's
//! 1993 exponential form) or Scott & Reinhardt's (2001, linear between the initiation rate and
//! the surface rate at the critical wind for active crowning).
//!
//! Units follow FlamMap's crown code: metres, m/min, kW/m, kg/m², kg/m³; the constants it uses
//! for conversions are kept (3.4613 kW/m per Btu/ft/s, 1586.01 Btu/ft² per kg/m² of fuel at
//! 18,000 kJ/kg, 18.288 (m/min) per (ft/s)), so that borderline cells fall on FlamMap's side.

/// Which crown fraction burned (and so which passive/active split) to use.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CrownMethod {
    /// Finney (1998), FARSITE's and FlamMap's default (`docs/spec/fire-model.md §B11.3`).
    #[default]
    Finney,
    /// Scott & Reinhardt (2001) (`docs/spec/fire-model.md §B11.4`).
    ScottReinhardt,
    /// No crown fire: every burning cell is surface fire.
    None,
}

impl CrownMethod {
    pub fn parse(text: &str) -> Option<Self> {
        match text {
            "finney" => Some(Self::Finney),
            "scott-reinhardt" => Some(Self::ScottReinhardt),
            "none" => Some(Self::None),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Finney => "finney",
            Self::ScottReinhardt => "scott-reinhardt",
            Self::None => "none",
        }
    }
}

/// FlamMap's kW/m per Btu/ft/s (the exact factor is 3.46141).
pub const KW_M_PER_BTU_FT_S: f64 = 3.4613;
/// Btu/ft² released by 1 kg/m² of fuel at 18,000 kJ/kg (Rothermel 1991), FlamMap's constant.
pub const BTU_FT2_PER_KG_M2: f64 = 1586.01;
/// (m/min) per (ft/s): 0.3048 · 60.
pub const M_MIN_PER_FT_S: f64 = 0.3048 * 60.0;
/// Rothermel's (1991) ratio of the average crown spread rate to fuel model 10's.
pub const ROTHERMEL_CROWN_FACTOR: f64 = 3.34;
/// Rothermel's (1991) reduction of the 20-ft wind to fuel model 10's midflame wind.
pub const CROWN_WIND_REDUCTION: f64 = 0.4;

/// Van Wagner's (1977) critical surface fireline intensity for crown initiation, kW/m:
/// I₀ = (0.010 · CBH · (460 + 25.9 · FMC))^1.5, CBH in m, FMC (foliar moisture) in percent.
pub fn critical_surface_intensity_kw_m(canopy_base_height_m: f64, foliar_moisture_pct: f64) -> f64 {
    (0.010 * canopy_base_height_m * (460.0 + 25.9 * foliar_moisture_pct)).powf(1.5)
}

/// Surface fuel consumed, kg/m², from Van Wagner's I = 300 · SFC · R (I kW/m, R m/min; 300 =
/// 18,000 kJ/kg / 60 s/min).
pub fn surface_fuel_consumption_kg_m2(intensity_kw_m: f64, ros_m_min: f64) -> f64 {
    intensity_kw_m / (300.0 * ros_m_min)
}

/// The critical surface spread rate for initiation, R'₀ = I₀ / (300 · SFC), m/min.
pub fn critical_surface_ros_m_min(critical_intensity_kw_m: f64, sfc_kg_m2: f64) -> f64 {
    critical_intensity_kw_m / (300.0 * sfc_kg_m2)
}

/// Van Wagner's (1977) critical rate for active crown fire, R'_active = 3.0 / CBD, m/min
/// (CBD in kg/m³).
pub fn critical_active_ros_m_min(canopy_bulk_density_kg_m3: f64) -> f64 {
    3.0 / canopy_bulk_density_kg_m3
}

/// Finney's (FARSITE) crown fraction burned, Van Wagner's (1993) exponential form:
/// a = −ln 0.1 / (0.9 · (R'_active − R'₀)), CFB = 1 − exp(−a · (R − R'₀)), clamped to
/// (0.01, 1] as FlamMap does; 1 when R'_active ≤ R'₀.
pub fn finney_crown_fraction_burned(ros_m_min: f64, r0_m_min: f64, r_active_crit_m_min: f64) -> f64 {
    if r_active_crit_m_min > r0_m_min {
        let a = -(0.1f64.ln()) / (0.9 * (r_active_crit_m_min - r0_m_min));
        let cfb = 1.0 - (-a * (ros_m_min - r0_m_min)).exp();
        if cfb <= 0.0 { 0.01 } else { cfb.min(1.0) }
    } else {
        1.0
    }
}

/// Scott & Reinhardt's (2001) crown fraction burned: (R − R'₀) / (R'_SA − R'₀), at most 1,
/// with R'_SA the surface rate at the critical wind for active crowning.
pub fn scott_reinhardt_crown_fraction_burned(ros_m_min: f64, r0_m_min: f64, r_sa_m_min: f64) -> f64 {
    if r_sa_m_min > r0_m_min {
        ((ros_m_min - r0_m_min) / (r_sa_m_min - r0_m_min)).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Fire types, as FlamMap writes them.
pub const FIRE_TYPE_PASSIVE: f32 = 2.0;
pub const FIRE_TYPE_ACTIVE: f32 = 3.0;

/// A cell's canopy, as FlamMap takes it from the landscape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Canopy {
    /// Canopy cover, percent.
    pub cover_pct: f64,
    pub height_m: f64,
    pub base_height_m: f64,
    pub bulk_density_kg_m3: f64,
}

impl Canopy {
    /// Whether FlamMap evaluates crown fire at all: canopy cover and height above 0.
    pub fn has_canopy(&self) -> bool {
        self.cover_pct > 0.0 && self.height_m > 0.0
    }
}

/// The surface fire at the head, what the crown model starts from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceHead {
    pub ros_m_min: f64,
    /// Byram's fireline intensity, Btu/ft/s.
    pub intensity_btu_ft_s: f64,
}

/// A crown fire: the cell's behaviour when the canopy ignites.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrownFire {
    /// [`FIRE_TYPE_PASSIVE`] or [`FIRE_TYPE_ACTIVE`].
    pub fire_type: f32,
    /// Whether the fire spreads at the crown rate (else at the surface rate).
    pub crown_spread: bool,
    pub ros_m_min: f64,
    pub intensity_btu_ft_s: f64,
    /// Thomas's flame length, 0.2 · I^(2/3) ft (I in Btu/ft/s), as Rothermel (1991) gives it.
    pub flame_length_ft: f64,
    pub crown_fraction_burned: f64,
    pub critical_intensity_kw_m: f64,
}

/// Crown fire at one cell, or `None` when the canopy does not ignite (surface fire). Needs
/// `r_active_m_min`, Rothermel's active crown rate 3.34 · R₁₀ at this cell, and, for Scott &
/// Reinhardt's method, `r_sa_m_min`: a function giving R'_SA for the critical active rate
/// (called only when needed).
pub fn crown_fire(
    method: CrownMethod,
    surface: SurfaceHead,
    canopy: Canopy,
    foliar_moisture_pct: f64,
    r_active_m_min: f64,
    r_sa_m_min: impl FnOnce(f64) -> f64,
) -> Option<CrownFire> {
    if method == CrownMethod::None || !canopy.has_canopy() || surface.ros_m_min <= 0.0 {
        return None;
    }
    // FlamMap's guards: zero base height and density become 0.01; a canopy no higher than its
    // base is taken 1 m deep.
    let cbh = if canopy.base_height_m == 0.0 {
        0.01
    } else {
        canopy.base_height_m
    };
    let cbd = if canopy.bulk_density_kg_m3 == 0.0 {
        0.01
    } else {
        canopy.bulk_density_kg_m3
    };
    let height = if canopy.height_m <= cbh {
        cbh + 1.0
    } else {
        canopy.height_m
    };
    let fli_kw = surface.intensity_btu_ft_s * KW_M_PER_BTU_FT_S;
    let i0 = critical_surface_intensity_kw_m(cbh, foliar_moisture_pct);
    if fli_kw <= 0.0 || fli_kw < i0 {
        return None;
    }
    let r = surface.ros_m_min;
    let sfc = surface_fuel_consumption_kg_m2(fli_kw, r);
    let r0 = critical_surface_ros_m_min(i0, sfc);
    let r_crit = critical_active_ros_m_min(cbd);
    let r_active = if r_active_m_min > 0.0 { r_active_m_min } else { r };
    let (cfb, crown_rate, active) = match method {
        CrownMethod::Finney => {
            let cfb = finney_crown_fraction_burned(r, r0, r_crit);
            // FlamMap spreads at the crown rate from the rate at which CFB reaches 0.9, and calls
            // the fire active where that rate reaches 3 / CBD (the layer's CBD, unguarded).
            let threshold = r0 + 0.9 * (r_crit - r0);
            let rate = r + cfb * (r_active - r);
            let spreads = rate >= threshold;
            (
                cfb,
                spreads.then_some(rate),
                spreads && rate >= 3.0 / canopy.bulk_density_kg_m3,
            )
        }
        CrownMethod::ScottReinhardt => {
            // Active where Rothermel's crown rate reaches R'_active (CFB 1); passive otherwise,
            // CFB linear between R'₀ and R'_SA, the rate blended by CFB.
            let active = r_active >= r_crit;
            let cfb = if r0 > r_crit || active {
                1.0
            } else {
                scott_reinhardt_crown_fraction_burned(r, r0, r_sa_m_min(r_crit).min(r_crit))
            };
            (cfb, Some(r + cfb * (r_active - r)), active)
        }
        CrownMethod::None => unreachable!(),
    };
    let canopy_load = cfb * cbd * (height - cbh);
    let ros = crown_rate.unwrap_or(r);
    let fire_type = if active {
        FIRE_TYPE_ACTIVE
    } else {
        FIRE_TYPE_PASSIVE
    };
    let crown_btu = (ros / M_MIN_PER_FT_S * (sfc + canopy_load) * BTU_FT2_PER_KG_M2).abs();
    // FlamMap keeps the larger of the surface and the crown intensity.
    let intensity = crown_btu.max(surface.intensity_btu_ft_s);
    Some(CrownFire {
        fire_type,
        crown_spread: crown_rate.is_some(),
        ros_m_min: ros,
        intensity_btu_ft_s: intensity,
        flame_length_ft: 0.2 * intensity.powf(2.0 / 3.0),
        crown_fraction_burned: cfb,
        critical_intensity_kw_m: i0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn van_wagner_initiation_by_hand() {
        // CBH 2 m, FMC 100 %: 0.010 · 2 · (460 + 2590) = 61; 61^1.5 = 476.425 kW/m.
        let i0 = critical_surface_intensity_kw_m(2.0, 100.0);
        assert!((i0 - 476.425).abs() < 1e-3, "{i0}");
        // I = 1000 kW/m at R = 10 m/min: SFC = 1000 / 3000 = 0.3333 kg/m²; R'₀ = 476.425 / 100.
        let sfc = surface_fuel_consumption_kg_m2(1000.0, 10.0);
        assert!((sfc - 1.0 / 3.0).abs() < 1e-12);
        assert!((critical_surface_ros_m_min(i0, sfc) - 4.76425).abs() < 1e-5);
    }

    #[test]
    fn critical_active_rate_by_hand() {
        assert!((critical_active_ros_m_min(0.15) - 20.0).abs() < 1e-12);
    }

    #[test]
    fn finney_fraction_by_hand() {
        // R'₀ = 2, R'_active = 12: a = ln 10 / 9 = 0.255843; at R = 5: 1 − e^(−0.767528) = 0.535841.
        let cfb = finney_crown_fraction_burned(5.0, 2.0, 12.0);
        assert!((cfb - 0.535_841).abs() < 1e-6, "{cfb}");
        // At R'₀ + 0.9 · (R'_active − R'₀) the fraction is 0.9.
        assert!((finney_crown_fraction_burned(11.0, 2.0, 12.0) - 0.9).abs() < 1e-12);
        assert_eq!(finney_crown_fraction_burned(2.0, 2.0, 12.0), 0.01);
        assert_eq!(finney_crown_fraction_burned(5.0, 13.0, 12.0), 1.0);
    }

    #[test]
    fn scott_reinhardt_fraction_by_hand() {
        // (5 − 2) / (8 − 2) = 0.5.
        assert!((scott_reinhardt_crown_fraction_burned(5.0, 2.0, 8.0) - 0.5).abs() < 1e-12);
        assert_eq!(scott_reinhardt_crown_fraction_burned(9.0, 2.0, 8.0), 1.0);
    }

    #[test]
    fn passive_crown_fire_by_hand() {
        // Surface: R = 10 m/min, I = 300 Btu/ft/s = 1038.39 kW/m. Canopy: CBH 2 m (I₀ 476.425
        // at FMC 100 %), CBD 0.1 (R'_active 30), height 12 m. Rothermel's crown rate 5 m/min.
        let surface = SurfaceHead {
            ros_m_min: 10.0,
            intensity_btu_ft_s: 300.0,
        };
        let canopy = Canopy {
            cover_pct: 60.0,
            height_m: 12.0,
            base_height_m: 2.0,
            bulk_density_kg_m3: 0.1,
        };
        let fire = crown_fire(CrownMethod::Finney, surface, canopy, 100.0, 5.0, |_| 0.0).expect("crowns");
        // SFC = 1038.39 / 3000 = 0.346130; R'₀ = 476.425 / (300 · 0.346130) = 4.58811;
        // a = ln 10 / (0.9 · 25.41189) = 0.100678; CFB = 1 − e^(−0.100678 · 5.41189) = 0.420077.
        assert!((fire.crown_fraction_burned - 0.420_077).abs() < 1e-5, "{fire:?}");
        // The crown rate 10 + 0.42 · (5 − 10) is below the threshold: passive, surface rate.
        assert_eq!(fire.fire_type, FIRE_TYPE_PASSIVE);
        assert!(!fire.crown_spread);
        assert_eq!(fire.ros_m_min, 10.0);
        // I = 10 / 18.288 · (0.346130 + 0.420077 · 0.1 · 10) · 1586.01 = 664.486 Btu/ft/s.
        assert!((fire.intensity_btu_ft_s - 664.486).abs() < 0.01, "{fire:?}");
        assert!((fire.flame_length_ft - 0.2 * 664.486f64.powf(2.0 / 3.0)).abs() < 1e-3);
        // Below I₀: no crown fire.
        let weak = SurfaceHead {
            ros_m_min: 10.0,
            intensity_btu_ft_s: 100.0,
        };
        assert!(crown_fire(CrownMethod::Finney, weak, canopy, 100.0, 5.0, |_| 0.0).is_none());
        // Active: Rothermel's rate well above R'_active.
        let active = crown_fire(CrownMethod::Finney, surface, canopy, 100.0, 60.0, |_| 0.0).expect("crowns");
        assert_eq!(active.fire_type, FIRE_TYPE_ACTIVE);
        // Scott & Reinhardt: R'_SA = 20 → CFB = (10 − 4.58811) / (20 − 4.58811) = 0.351150;
        // rate 10 + 0.351150 · (5 − 10) = 8.24425 m/min, passive.
        let sr =
            crown_fire(CrownMethod::ScottReinhardt, surface, canopy, 100.0, 5.0, |_| 20.0).expect("crowns");
        assert!((sr.crown_fraction_burned - 0.351_150).abs() < 1e-5, "{sr:?}");
        assert!((sr.ros_m_min - 8.244_25).abs() < 1e-4, "{sr:?}");
        assert_eq!(sr.fire_type, FIRE_TYPE_PASSIVE);
    }
}
