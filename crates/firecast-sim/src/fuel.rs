//! Standard surface fuel models (Anderson 1982 and Scott & Burgan 2005) with the parameter
//! values exactly as the USFS `behave` engine stores them (`fuelModels.cpp`).
//!
//! Two deliberate behave-isms are kept because the oracles depend on them: FM4's live load
//! is *woody* (not herbaceous) and FM7's live SAV is 1500 ft⁻¹.

use std::fmt;

/// 1 ton/acre expressed in lb/ft² (2000 lb / 43 560 ft²). behave converts Scott & Burgan's
/// t/ac loads with this exact factor, so the table stores t/ac and converts at compile time.
pub const LB_PER_FT2_PER_TON_PER_ACRE: f64 = 2000.0 / 43_560.0;

/// A surface fuel model: the Rothermel fuel-bed description of one stylised fuel complex.
///
/// Loads are oven-dry, in lb/ft²; surface-area-to-volume ratios (SAV) in ft⁻¹; heat content
/// in Btu/lb; moistures of extinction as fractions of oven-dry weight.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FuelModel {
    /// Fuel-model number: 1–13 (Anderson), 91–99 (non-burnable), 101–204 (Scott & Burgan).
    pub number: u16,
    /// Short code, e.g. `FM4`, `GR2`, `NB1`.
    pub code: &'static str,
    /// Descriptive name as behave has it.
    pub name: &'static str,
    /// Fuel-bed depth δ, ft.
    pub depth_ft: f64,
    /// Dead-fuel moisture of extinction, fraction.
    pub mx_dead_frac: f64,
    /// Heat content of dead fuel, Btu/lb.
    pub heat_dead_btu_lb: f64,
    /// Heat content of live fuel, Btu/lb.
    pub heat_live_btu_lb: f64,
    /// 1-h dead load, lb/ft².
    pub load_1h_lb_ft2: f64,
    /// 10-h dead load, lb/ft².
    pub load_10h_lb_ft2: f64,
    /// 100-h dead load, lb/ft².
    pub load_100h_lb_ft2: f64,
    /// Live herbaceous load, lb/ft² (before any dynamic curing transfer).
    pub load_live_herb_lb_ft2: f64,
    /// Live woody load, lb/ft².
    pub load_live_woody_lb_ft2: f64,
    /// 1-h dead SAV, ft⁻¹.
    pub sav_1h_per_ft: f64,
    /// 10-h dead SAV, ft⁻¹ (109 in every standard model).
    pub sav_10h_per_ft: f64,
    /// 100-h dead SAV, ft⁻¹ (30 in every standard model).
    pub sav_100h_per_ft: f64,
    /// Live herbaceous SAV, ft⁻¹ (also the SAV of cured herbage moved to dead).
    pub sav_live_herb_per_ft: f64,
    /// Live woody SAV, ft⁻¹.
    pub sav_live_woody_per_ft: f64,
    /// behave's dynamic flag: herbaceous load cures into the dead class with herb moisture.
    pub dynamic: bool,
    /// `false` for the NB codes, which never burn.
    pub burnable: bool,
}

/// Why a fuel-model designation could not be resolved.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown fuel model {0:?} (expected a standard number 1-13, 91-99, 101-204 or a code such as FM4, GR2, NB1)"
)]
pub struct UnknownFuelModel(pub String);

impl FuelModel {
    /// All standard models as behave stores them: FM1–FM13, NB1–NB5/NB8/NB9, then the
    /// Scott & Burgan 40, ordered by number.
    pub fn standard() -> &'static [FuelModel] {
        &STANDARD_FUEL_MODELS
    }

    /// Looks a standard model up by its number (e.g. 4 or 124).
    pub fn by_number(number: u16) -> Option<&'static FuelModel> {
        STANDARD_FUEL_MODELS.iter().find(|m| m.number == number)
    }

    /// Looks a standard model up by its code, ignoring ASCII case (e.g. `"gr2"`, `"FM4"`).
    pub fn by_code(code: &str) -> Option<&'static FuelModel> {
        let code = code.trim();
        STANDARD_FUEL_MODELS
            .iter()
            .find(|m| m.code.eq_ignore_ascii_case(code))
    }

    /// Resolves a user designation that is either a number (`"4"`, `"124"`) or a code
    /// (`"FM4"`, `"GS4"`).
    pub fn lookup(designation: &str) -> Result<&'static FuelModel, UnknownFuelModel> {
        let trimmed = designation.trim();
        let found = match trimmed.parse::<u16>() {
            Ok(number) => Self::by_number(number),
            Err(_) => Self::by_code(trimmed),
        };
        found.ok_or_else(|| UnknownFuelModel(designation.to_owned()))
    }

    /// Total oven-dry load of all classes, lb/ft².
    pub fn total_load_lb_ft2(&self) -> f64 {
        self.load_1h_lb_ft2
            + self.load_10h_lb_ft2
            + self.load_100h_lb_ft2
            + self.load_live_herb_lb_ft2
            + self.load_live_woody_lb_ft2
    }
}

impl fmt::Display for FuelModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.code, self.number)
    }
}

/// Anderson (1982) model; loads already in lb/ft² exactly as behave stores them.
#[allow(clippy::too_many_arguments)]
const fn anderson(
    number: u16,
    code: &'static str,
    name: &'static str,
    depth_ft: f64,
    mx_dead_frac: f64,
    loads_lb_ft2: [f64; 5],
    sav_1h_per_ft: f64,
) -> FuelModel {
    FuelModel {
        number,
        code,
        name,
        depth_ft,
        mx_dead_frac,
        heat_dead_btu_lb: 8000.0,
        heat_live_btu_lb: 8000.0,
        load_1h_lb_ft2: loads_lb_ft2[0],
        load_10h_lb_ft2: loads_lb_ft2[1],
        load_100h_lb_ft2: loads_lb_ft2[2],
        load_live_herb_lb_ft2: loads_lb_ft2[3],
        load_live_woody_lb_ft2: loads_lb_ft2[4],
        sav_1h_per_ft,
        sav_10h_per_ft: 109.0,
        sav_100h_per_ft: 30.0,
        sav_live_herb_per_ft: 1500.0,
        sav_live_woody_per_ft: 1500.0,
        dynamic: false,
        burnable: true,
    }
}

/// Scott & Burgan (2005) model; loads given in t/ac (as published) and converted to lb/ft².
/// `savs` is [1-h, live herb, live woody] in ft⁻¹.
#[allow(clippy::too_many_arguments)]
const fn scott_burgan(
    number: u16,
    code: &'static str,
    name: &'static str,
    depth_ft: f64,
    mx_dead_frac: f64,
    heat_btu_lb: f64,
    loads_t_ac: [f64; 5],
    savs: [f64; 3],
) -> FuelModel {
    let k = LB_PER_FT2_PER_TON_PER_ACRE;
    FuelModel {
        number,
        code,
        name,
        depth_ft,
        mx_dead_frac,
        heat_dead_btu_lb: heat_btu_lb,
        heat_live_btu_lb: heat_btu_lb,
        load_1h_lb_ft2: loads_t_ac[0] * k,
        load_10h_lb_ft2: loads_t_ac[1] * k,
        load_100h_lb_ft2: loads_t_ac[2] * k,
        load_live_herb_lb_ft2: loads_t_ac[3] * k,
        load_live_woody_lb_ft2: loads_t_ac[4] * k,
        sav_1h_per_ft: savs[0],
        sav_10h_per_ft: 109.0,
        sav_100h_per_ft: 30.0,
        sav_live_herb_per_ft: savs[1],
        sav_live_woody_per_ft: savs[2],
        // behave flags every Scott & Burgan model dynamic; only those with herb load transfer.
        dynamic: true,
        burnable: true,
    }
}

/// Non-burnable code: behave's placeholder parameters with zero load.
const fn non_burnable(number: u16, code: &'static str, name: &'static str) -> FuelModel {
    FuelModel {
        number,
        code,
        name,
        depth_ft: 1.0,
        mx_dead_frac: 0.1,
        heat_dead_btu_lb: 8000.0,
        heat_live_btu_lb: 8000.0,
        load_1h_lb_ft2: 0.0,
        load_10h_lb_ft2: 0.0,
        load_100h_lb_ft2: 0.0,
        load_live_herb_lb_ft2: 0.0,
        load_live_woody_lb_ft2: 0.0,
        sav_1h_per_ft: 1500.0,
        sav_10h_per_ft: 109.0,
        sav_100h_per_ft: 30.0,
        sav_live_herb_per_ft: 1500.0,
        sav_live_woody_per_ft: 1500.0,
        dynamic: false,
        burnable: false,
    }
}

// One model per line, in behave's order: easier to audit against `fuel_models.csv`.
#[rustfmt::skip]
static STANDARD_FUEL_MODELS: [FuelModel; 60] = [
    anderson(1, "FM1", "Short grass [1]", 1.0, 0.12, [0.034, 0.0, 0.0, 0.0, 0.0], 3500.0),
    anderson(2, "FM2", "Timber grass and understory [2]", 1.0, 0.15, [0.092, 0.046, 0.023, 0.023, 0.0], 3000.0),
    anderson(3, "FM3", "Tall grass [3]", 2.5, 0.25, [0.138, 0.0, 0.0, 0.0, 0.0], 1500.0),
    anderson(4, "FM4", "Chaparral [4]", 6.0, 0.2, [0.23, 0.184, 0.092, 0.0, 0.23], 2000.0),
    anderson(5, "FM5", "Brush [5]", 2.0, 0.2, [0.046, 0.023, 0.0, 0.0, 0.092], 2000.0),
    anderson(6, "FM6", "Dormant brush, hardwood slash [6]", 2.5, 0.25, [0.069, 0.115, 0.092, 0.0, 0.0], 1750.0),
    anderson(7, "FM7", "Southern rough [7]", 2.5, 0.4, [0.052, 0.086, 0.069, 0.0, 0.017], 1750.0),
    anderson(8, "FM8", "Short needle litter [8]", 0.2, 0.3, [0.069, 0.046, 0.115, 0.0, 0.0], 2000.0),
    anderson(9, "FM9", "Long needle or hardwood litter [9]", 0.2, 0.25, [0.134, 0.019, 0.007, 0.0, 0.0], 2500.0),
    anderson(10, "FM10", "Timber litter & understory [10]", 1.0, 0.25, [0.138, 0.092, 0.23, 0.0, 0.092], 2000.0),
    anderson(11, "FM11", "Light logging slash [11]", 1.0, 0.15, [0.069, 0.207, 0.253, 0.0, 0.0], 1500.0),
    anderson(12, "FM12", "Medium logging slash [12]", 2.3, 0.2, [0.184, 0.644, 0.759, 0.0, 0.0], 1500.0),
    anderson(13, "FM13", "Heavy logging slash [13]", 3.0, 0.25, [0.322, 1.058, 1.288, 0.0, 0.0], 1500.0),
    non_burnable(91, "NB1", "Urban, developed [91]"),
    non_burnable(92, "NB2", "Snow, ice [92]"),
    non_burnable(93, "NB3", "Agricultural [93]"),
    non_burnable(94, "NB4", "Future standard non-burnable [94]"),
    non_burnable(95, "NB5", "Future standard non-burnable [95]"),
    non_burnable(98, "NB8", "Open water [98]"),
    non_burnable(99, "NB9", "Bare ground [99]"),
    scott_burgan(101, "GR1", "Short, sparse, dry climate grass (D)", 0.4, 0.15, 8000.0, [0.1, 0.0, 0.0, 0.3, 0.0], [2200.0, 2000.0, 1500.0]),
    scott_burgan(102, "GR2", "Low load, dry climate grass (D)", 1.0, 0.15, 8000.0, [0.1, 0.0, 0.0, 1.0, 0.0], [2000.0, 1800.0, 1500.0]),
    scott_burgan(103, "GR3", "Low load, very coarse, humid climate grass (D)", 2.0, 0.3, 8000.0, [0.1, 0.4, 0.0, 1.5, 0.0], [1500.0, 1300.0, 1500.0]),
    scott_burgan(104, "GR4", "Moderate load, dry climate grass (D)", 2.0, 0.15, 8000.0, [0.25, 0.0, 0.0, 1.9, 0.0], [2000.0, 1800.0, 1500.0]),
    scott_burgan(105, "GR5", "Low load, humid climate grass (D)", 1.5, 0.4, 8000.0, [0.4, 0.0, 0.0, 2.5, 0.0], [1800.0, 1600.0, 1500.0]),
    scott_burgan(106, "GR6", "Moderate load, humid climate grass (D)", 1.5, 0.4, 9000.0, [0.1, 0.0, 0.0, 3.4, 0.0], [2200.0, 2000.0, 1500.0]),
    scott_burgan(107, "GR7", "High load, dry climate grass (D)", 3.0, 0.15, 8000.0, [1.0, 0.0, 0.0, 5.4, 0.0], [2000.0, 1800.0, 1500.0]),
    scott_burgan(108, "GR8", "High load, very coarse, humid climate grass (D)", 4.0, 0.3, 8000.0, [0.5, 1.0, 0.0, 7.3, 0.0], [1500.0, 1300.0, 1500.0]),
    scott_burgan(109, "GR9", "Very high load, humid climate grass (D)", 5.0, 0.4, 8000.0, [1.0, 1.0, 0.0, 9.0, 0.0], [1800.0, 1600.0, 1500.0]),
    scott_burgan(121, "GS1", "Low load, dry climate grass-shrub (D)", 0.9, 0.15, 8000.0, [0.2, 0.0, 0.0, 0.5, 0.65], [2000.0, 1800.0, 1800.0]),
    scott_burgan(122, "GS2", "Moderate load, dry climate grass-shrub (D)", 1.5, 0.15, 8000.0, [0.5, 0.5, 0.0, 0.6, 1.0], [2000.0, 1800.0, 1800.0]),
    scott_burgan(123, "GS3", "Moderate load, humid climate grass-shrub (D)", 1.8, 0.4, 8000.0, [0.3, 0.25, 0.0, 1.45, 1.25], [1800.0, 1600.0, 1600.0]),
    scott_burgan(124, "GS4", "High load, humid climate grass-shrub (D)", 2.1, 0.4, 8000.0, [1.9, 0.3, 0.1, 3.4, 7.1], [1800.0, 1600.0, 1600.0]),
    scott_burgan(141, "SH1", "Low load, dry climate shrub (D)", 1.0, 0.15, 8000.0, [0.25, 0.25, 0.0, 0.15, 1.3], [2000.0, 1800.0, 1600.0]),
    scott_burgan(142, "SH2", "Moderate load, dry climate shrub (S)", 1.0, 0.15, 8000.0, [1.35, 2.4, 0.75, 0.0, 3.85], [2000.0, 1800.0, 1600.0]),
    scott_burgan(143, "SH3", "Moderate load, humid climate shrub (S)", 2.4, 0.4, 8000.0, [0.45, 3.0, 0.0, 0.0, 6.2], [1600.0, 1800.0, 1400.0]),
    scott_burgan(144, "SH4", "Low load, humid climate timber-shrub (S)", 3.0, 0.3, 8000.0, [0.85, 1.15, 0.2, 0.0, 2.55], [2000.0, 1800.0, 1600.0]),
    scott_burgan(145, "SH5", "High load, dry climate shrub (S)", 6.0, 0.15, 8000.0, [3.6, 2.1, 0.0, 0.0, 2.9], [750.0, 1800.0, 1600.0]),
    scott_burgan(146, "SH6", "Low load, humid climate shrub (S)", 2.0, 0.3, 8000.0, [2.9, 1.45, 0.0, 0.0, 1.4], [750.0, 1800.0, 1600.0]),
    scott_burgan(147, "SH7", "Very high load, dry climate shrub (S)", 6.0, 0.15, 8000.0, [3.5, 5.3, 2.2, 0.0, 3.4], [750.0, 1800.0, 1600.0]),
    scott_burgan(148, "SH8", "High load, humid climate shrub (S)", 3.0, 0.4, 8000.0, [2.05, 3.4, 0.85, 0.0, 4.35], [750.0, 1800.0, 1600.0]),
    scott_burgan(149, "SH9", "Very high load, humid climate shrub (D)", 4.4, 0.4, 8000.0, [4.5, 2.45, 0.0, 1.55, 7.0], [750.0, 1800.0, 1500.0]),
    scott_burgan(161, "TU1", "Light load, dry climate timber-grass-shrub (D)", 0.6, 0.2, 8000.0, [0.2, 0.9, 1.5, 0.2, 0.9], [2000.0, 1800.0, 1600.0]),
    scott_burgan(162, "TU2", "Moderate load, humid climate timber-shrub (S)", 1.0, 0.3, 8000.0, [0.95, 1.8, 1.25, 0.0, 0.2], [2000.0, 1800.0, 1600.0]),
    scott_burgan(163, "TU3", "Moderate load, humid climate timber-grass-shrub (D)", 1.3, 0.3, 8000.0, [1.1, 0.15, 0.25, 0.65, 1.1], [1800.0, 1600.0, 1400.0]),
    scott_burgan(164, "TU4", "Dwarf conifer understory (S)", 0.5, 0.12, 8000.0, [4.5, 0.0, 0.0, 0.0, 2.0], [2300.0, 1800.0, 2000.0]),
    scott_burgan(165, "TU5", "Very high load, dry climate timber-shrub (S)", 1.0, 0.25, 8000.0, [4.0, 4.0, 3.0, 0.0, 3.0], [1500.0, 1800.0, 750.0]),
    scott_burgan(181, "TL1", "Low load, compact conifer litter (S)", 0.2, 0.3, 8000.0, [1.0, 2.2, 3.6, 0.0, 0.0], [2000.0, 1800.0, 1600.0]),
    scott_burgan(182, "TL2", "Low load broadleaf litter (S)", 0.2, 0.25, 8000.0, [1.4, 2.3, 2.2, 0.0, 0.0], [2000.0, 1800.0, 1600.0]),
    scott_burgan(183, "TL3", "Moderate load conifer litter (S)", 0.3, 0.2, 8000.0, [0.5, 2.2, 2.8, 0.0, 0.0], [2000.0, 1800.0, 1600.0]),
    scott_burgan(184, "TL4", "Small downed logs (S)", 0.4, 0.25, 8000.0, [0.5, 1.5, 4.2, 0.0, 0.0], [2000.0, 1800.0, 1600.0]),
    scott_burgan(185, "TL5", "High load conifer litter (S)", 0.6, 0.25, 8000.0, [1.15, 2.5, 4.4, 0.0, 0.0], [2000.0, 1800.0, 160.0]),
    scott_burgan(186, "TL6", "High load broadleaf litter (S)", 0.3, 0.25, 8000.0, [2.4, 1.2, 1.2, 0.0, 0.0], [2000.0, 1800.0, 1600.0]),
    scott_burgan(187, "TL7", "Large downed logs (S)", 0.4, 0.25, 8000.0, [0.3, 1.4, 8.1, 0.0, 0.0], [2000.0, 1800.0, 1600.0]),
    scott_burgan(188, "TL8", "Long-needle litter (S)", 0.3, 0.35, 8000.0, [5.8, 1.4, 1.1, 0.0, 0.0], [1800.0, 1800.0, 1600.0]),
    scott_burgan(189, "TL9", "Very high load broadleaf litter (S)", 0.6, 0.35, 8000.0, [6.65, 3.3, 4.15, 0.0, 0.0], [1800.0, 1800.0, 1600.0]),
    scott_burgan(201, "SB1", "Low load activity fuel (S)", 1.0, 0.25, 8000.0, [1.5, 3.0, 11.0, 0.0, 0.0], [2000.0, 1800.0, 1600.0]),
    scott_burgan(202, "SB2", "Moderate load activity or low load blowdown (S)", 1.0, 0.25, 8000.0, [4.5, 4.25, 4.0, 0.0, 0.0], [2000.0, 1800.0, 1600.0]),
    scott_burgan(203, "SB3", "High load activity fuel or moderate load blowdown (S)", 1.2, 0.25, 8000.0, [5.5, 2.75, 3.0, 0.0, 0.0], [2000.0, 1800.0, 1600.0]),
    scott_burgan(204, "SB4", "High load blowdown (S)", 2.7, 0.25, 8000.0, [5.25, 3.5, 5.25, 0.0, 0.0], [2000.0, 1800.0, 1600.0]),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookup_by_number_code_and_designation() {
        assert_eq!(FuelModel::by_number(124).map(|m| m.code), Some("GS4"));
        assert_eq!(FuelModel::by_code("gr2").map(|m| m.number), Some(102));
        assert_eq!(FuelModel::lookup(" FM4 ").map(|m| m.number), Ok(4));
        assert_eq!(FuelModel::lookup("13").map(|m| m.code), Ok("FM13"));
        assert!(FuelModel::lookup("FM14").is_err());
        assert!(FuelModel::lookup("100").is_err());
        assert!(FuelModel::lookup("").is_err());
    }

    #[test]
    fn table_is_sorted_and_unique() {
        let models = FuelModel::standard();
        assert_eq!(models.len(), 60);
        assert!(models.windows(2).all(|w| w[0].number < w[1].number));
        assert_eq!(models.iter().filter(|m| m.burnable).count(), 53);
    }

    #[test]
    fn behave_specific_values_are_kept() {
        let fm4 = FuelModel::by_number(4).expect("FM4");
        assert_eq!(fm4.load_live_woody_lb_ft2, 0.23);
        assert_eq!(fm4.load_live_herb_lb_ft2, 0.0);
        let fm7 = FuelModel::by_number(7).expect("FM7");
        assert_eq!(fm7.sav_live_woody_per_ft, 1500.0);
    }
}
