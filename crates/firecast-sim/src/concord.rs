//! The Concord Consortium / FireCastRL compatibility kernel (docs/spec/fire-model.md §A3–§A5).
//!
//! This is the single-particle spread-rate function FireCastRL inherited from the Concord
//! wildfire model, *quirks included*: the wind-factor exponent E is a product instead of an
//! exponential, the moisture damping is not clamped, the ellipse uses a length-to-width ratio
//! linear in mi/h, and all fuel values come from the target cell. [`SpreadVariant::Compat`]
//! reproduces it; [`SpreadVariant::Corrected`] fixes those points (see its docs). It is *not*
//! the behave model: use [`crate::rothermel`] for physics.

use crate::rothermel::length_to_width_ratio;

/// Heat content used for every Concord fuel, Btu/lb.
const HEAT_CONTENT_BTU_LB: f64 = 8000.0;
/// Total mineral content S_T.
const TOTAL_MINERAL_CONTENT: f64 = 0.0555;
/// Effective mineral content S_e.
const EFFECTIVE_MINERAL_CONTENT: f64 = 0.01;
/// ft/min per mi/h.
const FT_PER_MIN_PER_MPH: f64 = 88.0;

/// Moisture FireCastRL assigns to non-burnable (river / unburnt-island) cells.
pub const NON_BURNABLE_MOISTURE: f64 = f64::INFINITY;

/// MODIS IGBP `LC_Type1` land-cover classes (values 1–17), FireCastRL's vegetation types.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[repr(u8)]
pub enum LandCover {
    /// 1 Evergreen needleleaf forest.
    EvergreenNeedleleaf = 1,
    /// 2 Evergreen broadleaf forest.
    EvergreenBroadleaf = 2,
    /// 3 Deciduous needleleaf forest.
    DeciduousNeedleleaf = 3,
    /// 4 Deciduous broadleaf forest.
    DeciduousBroadleaf = 4,
    /// 5 Mixed forest.
    MixedForest = 5,
    /// 6 Closed shrublands.
    ClosedShrublands = 6,
    /// 7 Open shrublands.
    OpenShrublands = 7,
    /// 8 Woody savannas.
    WoodySavannas = 8,
    /// 9 Savannas.
    Savannas = 9,
    /// 10 Grasslands.
    Grasslands = 10,
    /// 11 Permanent wetlands.
    PermanentWetlands = 11,
    /// 12 Croplands.
    Croplands = 12,
    /// 13 Urban and built-up.
    UrbanBuilt = 13,
    /// 14 Cropland / natural vegetation mosaic.
    CroplandMosaic = 14,
    /// 15 Permanent snow and ice.
    SnowIce = 15,
    /// 16 Barren.
    Barren = 16,
    /// 17 Water bodies.
    Water = 17,
}

impl LandCover {
    /// All classes in MODIS order.
    pub const ALL: [LandCover; 17] = [
        Self::EvergreenNeedleleaf,
        Self::EvergreenBroadleaf,
        Self::DeciduousNeedleleaf,
        Self::DeciduousBroadleaf,
        Self::MixedForest,
        Self::ClosedShrublands,
        Self::OpenShrublands,
        Self::WoodySavannas,
        Self::Savannas,
        Self::Grasslands,
        Self::PermanentWetlands,
        Self::Croplands,
        Self::UrbanBuilt,
        Self::CroplandMosaic,
        Self::SnowIce,
        Self::Barren,
        Self::Water,
    ];

    /// The class for a MODIS `LC_Type1` value 1–17.
    pub fn from_modis_class(class: u8) -> Option<Self> {
        Self::ALL.get(usize::from(class).checked_sub(1)?).copied()
    }

    /// The MODIS `LC_Type1` value (1–17).
    pub fn modis_class(self) -> u8 {
        self as u8
    }

    /// Fuel constants of docs/spec/fire-model.md §A4 (identical in P1, P2 and T).
    pub fn fuel(self) -> ConcordFuelConstants {
        let c = ConcordFuelConstants::new;
        match self {
            Self::Grasslands => c(2100.0, 0.294, 3.0, 0.00306, 0.15),
            Self::ClosedShrublands => c(1672.0, 0.239, 1.2, 0.01198, 0.30),
            Self::OpenShrublands => c(1500.0, 0.20, 1.0, 0.010, 0.30),
            Self::EvergreenNeedleleaf => c(1716.0, 0.0459, 0.10, 0.04878, 0.20),
            Self::DeciduousNeedleleaf => c(1650.0, 0.040, 0.10, 0.045, 0.20),
            Self::EvergreenBroadleaf => c(1500.0, 0.06, 0.12, 0.035, 0.25),
            Self::DeciduousBroadleaf => c(1400.0, 0.05, 0.10, 0.030, 0.25),
            // FireCastRL derives it as the mean of its neighbours: (1716+1500)/2, (0.0459+0.06)/2.
            Self::MixedForest => c(1608.0, 0.05295, 0.11, 0.042, 0.22),
            Self::WoodySavannas => c(1400.0, 0.18, 0.8, 0.008, 0.30),
            Self::Savannas => c(1450.0, 0.17, 0.7, 0.0085, 0.25),
            Self::Croplands => c(1200.0, 0.20, 0.50, 0.015, 0.30),
            Self::CroplandMosaic => c(1300.0, 0.18, 0.60, 0.012, 0.25),
            Self::PermanentWetlands => c(800.0, 0.12, 0.50, 0.007, 0.50),
            Self::Barren => c(600.0, 0.01, 0.05, 0.002, 0.10),
            Self::UrbanBuilt | Self::SnowIce | Self::Water => c(0.0, 0.0, 0.0, 0.0, 0.0),
        }
    }

    /// FireCastRL's `UNBURNABLE_VEGETATION` (all-zero fuel constants, spread rate 0).
    pub fn is_unburnable_vegetation(self) -> bool {
        matches!(self, Self::UrbanBuilt | Self::SnowIce | Self::Water)
    }

    /// Moisture content (fraction) from the chosen FireCastRL table (docs/spec/fire-model.md §A3.3).
    pub fn moisture_frac(self, table: MoistureTable, drought: DroughtLevel) -> f64 {
        let row: [f64; 4] = match table {
            MoistureTable::FireCastRlPython => match self {
                Self::EvergreenNeedleleaf => [0.30, 0.25, 0.20, 0.15],
                Self::EvergreenBroadleaf => [0.32, 0.27, 0.22, 0.17],
                Self::DeciduousNeedleleaf => [0.28, 0.23, 0.18, 0.13],
                Self::DeciduousBroadleaf => [0.30, 0.25, 0.20, 0.15],
                Self::MixedForest => [0.29, 0.24, 0.19, 0.14],
                Self::ClosedShrublands => [0.25, 0.20, 0.15, 0.10],
                Self::OpenShrublands => [0.22, 0.17, 0.12, 0.08],
                Self::WoodySavannas => [0.24, 0.19, 0.14, 0.10],
                Self::Savannas => [0.21, 0.17, 0.13, 0.09],
                Self::Grasslands => [0.20, 0.16, 0.12, 0.08],
                Self::PermanentWetlands => [0.35, 0.30, 0.25, 0.20],
                Self::Croplands => [0.23, 0.18, 0.13, 0.09],
                Self::CroplandMosaic => [0.22, 0.17, 0.12, 0.08],
                Self::UrbanBuilt => [0.10, 0.08, 0.06, 0.04],
                Self::Barren => [0.05, 0.04, 0.03, 0.02],
                Self::SnowIce | Self::Water => [0.0; 4],
            },
            // Not monotonic in drought level: reproduced as found in `zone.ts`.
            MoistureTable::FireCastRlTypeScript => match self {
                Self::EvergreenNeedleleaf => [0.25, 0.27, 0.22, 0.26],
                Self::EvergreenBroadleaf => [0.28, 0.30, 0.25, 0.29],
                Self::DeciduousNeedleleaf => [0.20, 0.24, 0.18, 0.21],
                Self::DeciduousBroadleaf => [0.22, 0.26, 0.20, 0.23],
                Self::MixedForest => [0.19, 0.23, 0.17, 0.21],
                Self::ClosedShrublands => [0.14, 0.18, 0.12, 0.15],
                Self::OpenShrublands => [0.10, 0.14, 0.08, 0.11],
                Self::WoodySavannas => [0.12, 0.16, 0.10, 0.13],
                Self::Savannas => [0.09, 0.13, 0.08, 0.10],
                Self::Grasslands => [0.08, 0.12, 0.07, 0.09],
                Self::PermanentWetlands => [0.30, 0.33, 0.28, 0.31],
                Self::Croplands => [0.13, 0.16, 0.12, 0.15],
                Self::CroplandMosaic => [0.12, 0.15, 0.10, 0.13],
                Self::UrbanBuilt => [0.05, 0.08, 0.04, 0.06],
                Self::SnowIce => [0.0, 0.01, 0.0, 0.0],
                Self::Barren => [0.01, 0.02, 0.01, 0.01],
                Self::Water => [0.0; 4],
            },
        };
        row[drought.index()]
    }
}

/// Which FireCastRL moisture table to use (docs/spec/fire-model.md §A3.3).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum MoistureTable {
    /// Python environments P1 = P2 (`moisture_lookup_by_land_cover`).
    #[default]
    FireCastRlPython,
    /// Browser TypeScript engine T (`zone.ts moistureLookupByLandCover`).
    FireCastRlTypeScript,
}

/// The four fuels of the original Concord model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum ConcordFuel {
    /// Grass (= FireCastRL Grasslands).
    Grass,
    /// Shrub (= FireCastRL ClosedShrublands).
    Shrub,
    /// Forest (= FireCastRL EvergreenNeedleleaf).
    Forest,
    /// Forest with suppression.
    ForestWithSuppression,
}

impl ConcordFuel {
    /// Fuel constants (docs/spec/fire-model.md §A4).
    pub fn fuel(self) -> ConcordFuelConstants {
        match self {
            Self::Grass => LandCover::Grasslands.fuel(),
            Self::Shrub => LandCover::ClosedShrublands.fuel(),
            Self::Forest => LandCover::EvergreenNeedleleaf.fuel(),
            Self::ForestWithSuppression => ConcordFuelConstants::new(1500.0, 0.689, 0.5, 0.02224, 0.25),
        }
    }

    /// Concord's original `moistureLookups[drought][vegetation]`: Mx × {0.85, 0.60, 0.35, 0.10}.
    pub fn moisture_frac(self, drought: DroughtLevel) -> f64 {
        let row: [f64; 4] = match self {
            Self::Grass => [0.1275, 0.09, 0.0525, 0.015],
            Self::Shrub => [0.255, 0.18, 0.105, 0.03],
            Self::Forest => [0.17, 0.12, 0.07, 0.02],
            Self::ForestWithSuppression => [0.2125, 0.15, 0.0875, 0.025],
        };
        row[drought.index()]
    }
}

/// Drought level of a zone; each helitack drop lowers it by one (docs/spec/fire-model.md §A3.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
pub enum DroughtLevel {
    /// No drought (0).
    No = 0,
    /// Mild drought (1).
    Mild = 1,
    /// Medium drought (2).
    Medium = 2,
    /// Severe drought (3).
    Severe = 3,
}

impl DroughtLevel {
    /// The level for an index 0–3.
    pub fn from_index(index: u8) -> Option<Self> {
        [Self::No, Self::Mild, Self::Medium, Self::Severe]
            .get(usize::from(index))
            .copied()
    }

    /// The index 0–3.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Effective drought max(zone drought − drops, 0). P2's cap of 3 drops cannot change the
    /// result because levels never exceed 3.
    pub fn after_helitack_drops(self, helitack_drops: u32) -> Self {
        let level = (self as u32).saturating_sub(helitack_drops);
        match level {
            0 => Self::No,
            1 => Self::Mild,
            2 => Self::Medium,
            _ => Self::Severe,
        }
    }
}

/// One entry of FireCastRL's `config.py` ZONES list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Zone {
    /// Vegetation (land-cover class).
    pub vegetation: LandCover,
    /// Terrain label (cosmetic).
    pub terrain: &'static str,
    /// Default drought level.
    pub default_drought: DroughtLevel,
}

const fn zone(vegetation: LandCover, terrain: &'static str, default_drought: DroughtLevel) -> Zone {
    Zone {
        vegetation,
        terrain,
        default_drought,
    }
}

/// FireCastRL's ZONES, indexed by MODIS class; index 0 is a dummy copy of class 1.
pub const FIRECASTRL_ZONES: [Zone; 18] = {
    use DroughtLevel::{Medium, Mild, No, Severe};
    use LandCover::*;
    [
        zone(EvergreenNeedleleaf, "Mountains", Mild),
        zone(EvergreenNeedleleaf, "Mountains", Mild),
        zone(EvergreenBroadleaf, "Tropical", No),
        zone(DeciduousNeedleleaf, "Plains", Mild),
        zone(DeciduousBroadleaf, "Plains", Mild),
        zone(MixedForest, "Hills", Medium),
        zone(ClosedShrublands, "Desert", Medium),
        zone(OpenShrublands, "Desert", Severe),
        zone(WoodySavannas, "Plains", Mild),
        zone(Savannas, "Plains", Medium),
        zone(Grasslands, "Plains", Mild),
        zone(PermanentWetlands, "Wetlands", No),
        zone(Croplands, "Agricultural", Mild),
        zone(UrbanBuilt, "Urban", Severe),
        zone(CroplandMosaic, "Mixed", Medium),
        zone(SnowIce, "Ice", No),
        zone(Barren, "Desert", Severe),
        zone(Water, "Water", No),
    ]
};

/// Zone indices FireCastRL treats as non-burnable "river" cells. The code lists
/// {12, 14, 16, 17, 18}; 18 does not exist, so it is dropped. Urban (13) and snow/ice (15)
/// are *not* in the set: they are merely unburnable vegetation.
pub const FIRECASTRL_NON_BURNABLE_ZONES: [usize; 4] = [12, 14, 16, 17];

/// Whether FireCastRL treats cells of this zone index as non-burnable (river) cells.
pub fn is_firecastrl_river_zone(zone_index: usize) -> bool {
    FIRECASTRL_NON_BURNABLE_ZONES.contains(&zone_index)
}

/// Inputs of the single-particle spread function (docs/spec/fire-model.md §A4).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ConcordFuelConstants {
    /// Surface-area-to-volume ratio σ, ft⁻¹.
    pub sav_per_ft: f64,
    /// Net fuel load, lb/ft² (mineral-free).
    pub net_load_lb_ft2: f64,
    /// Fuel-bed depth, ft.
    pub depth_ft: f64,
    /// Packing ratio β: a table input, not derived from load and depth.
    pub packing_ratio: f64,
    /// Moisture of extinction, fraction.
    pub mx_frac: f64,
}

impl ConcordFuelConstants {
    /// Builds a constant set in table order (σ, net load, depth, β, Mx).
    pub const fn new(
        sav_per_ft: f64,
        net_load_lb_ft2: f64,
        depth_ft: f64,
        packing_ratio: f64,
        mx_frac: f64,
    ) -> Self {
        Self {
            sav_per_ft,
            net_load_lb_ft2,
            depth_ft,
            packing_ratio,
            mx_frac,
        }
    }

    /// P2's rule: any parameter ≤ 0 (or not finite) means the fuel cannot burn.
    pub fn is_burnable(&self) -> bool {
        [
            self.sav_per_ft,
            self.net_load_lb_ft2,
            self.depth_ft,
            self.packing_ratio,
            self.mx_frac,
        ]
        .iter()
        .all(|v| v.is_finite() && *v > 0.0)
    }
}

/// How the ports treat zero wind on flat ground, where the effective wind is exactly 0.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum EdgeCasePolicy {
    /// FireCastRL Python (P1/P2): rate 0 whenever φ_E/(C·ratio^−E) ≤ 0, so level
    /// neighbours never spread in calm air; negative R₀ gives 0.
    #[default]
    Python,
    /// Concord / FireCastRL TypeScript: U_E = 0 gives a circle (rate R₀); negative R₀
    /// (NaN ignition time in JS) gives 0, i.e. no ignition.
    Js,
}

/// Which maths the kernel runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum SpreadVariant {
    /// Bit-compatible with Concord/FireCastRL: E = 0.715·(−0.000359·σ) (a product), η_M not
    /// clamped, linear length-to-width ratio Z = 1 + 0.25·U_E[mi/h].
    Compat(EdgeCasePolicy),
    /// Rothermel-consistent fixes: E = 0.715·exp(−0.000359·σ), η_M = 0 at and beyond
    /// extinction, behave's Anderson (1983) length-to-width ratio (mi/h coefficients, capped
    /// at 8), and calm flat ground spreads at R₀ (a circle).
    Corrected,
}

impl Default for SpreadVariant {
    /// The published FireCastRL environment (P2): compatibility maths, Python edge cases.
    fn default() -> Self {
        Self::Compat(EdgeCasePolicy::Python)
    }
}

impl SpreadVariant {
    /// Eccentricity of the spread ellipse for an effective wind speed in ft/min.
    pub fn eccentricity(self, effective_wind_ftmin: f64) -> f64 {
        let lw = match self {
            Self::Compat(_) => 1.0 + 0.25 * (effective_wind_ftmin / FT_PER_MIN_PER_MPH),
            Self::Corrected => length_to_width_ratio(effective_wind_ftmin / FT_PER_MIN_PER_MPH),
        };
        (lw * lw - 1.0).sqrt() / lw
    }
}

/// Wind as the Concord engine takes it.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ConcordWind {
    /// Wind speed, mi/h.
    pub speed_mph: f64,
    /// Direction the wind comes *from*, degrees: 0 = northerly (blows toward −y, south),
    /// 90 = easterly (blows toward −x).
    pub from_direction_deg: f64,
}

/// A cell as the spread function sees it: grid position (x east, y north) and elevation.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ConcordCell {
    /// Column (east).
    pub x: i32,
    /// Row (north).
    pub y: i32,
    /// Elevation, ft (fire-line lowering already applied).
    pub elevation_ft: f64,
}

/// Elliptical direction factor DF = (1 − e)/(1 − e·cos θ), θ the angle between the spread
/// direction and the max-spread direction.
pub fn direction_factor(eccentricity: f64, cos_theta: f64) -> f64 {
    (1.0 - eccentricity) / (1.0 - eccentricity * cos_theta)
}

/// The spread kernel prepared for one target fuel at one moisture (docs/spec/fire-model.md §A12:
/// precompute R₀, the wind coefficient C·ratio^−E and the slope coefficient 5.275·β^−0.3 per fuel ×
/// drought).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ConcordSpread {
    variant: SpreadVariant,
    /// R₀ as computed, ft/min; can be negative or NaN in compatibility mode (unclamped η_M,
    /// infinite moisture) and is then treated as "does not burn".
    no_wind_no_slope_ros_ftmin: f64,
    wind_exponent_b: f64,
    wind_coefficient: f64,
    slope_coefficient: f64,
}

impl ConcordSpread {
    /// Precomputes the wind- and slope-independent part of `getFireSpreadRate` for the target
    /// cell's fuel and moisture (fraction; +∞ for non-burnable cells).
    pub fn new(fuel: &ConcordFuelConstants, moisture_frac: f64, variant: SpreadVariant) -> Self {
        if !fuel.is_burnable() {
            return Self {
                variant,
                no_wind_no_slope_ros_ftmin: 0.0,
                wind_exponent_b: 1.0,
                wind_coefficient: 0.0,
                slope_coefficient: 0.0,
            };
        }
        let sigma = fuel.sav_per_ft;
        let beta = fuel.packing_ratio;
        let rm = moisture_frac / fuel.mx_frac;

        let a = 133.0 * sigma.powf(-0.7913);
        let b = 0.02526 * sigma.powf(0.54);
        let c = 7.47 * (-0.133 * sigma.powf(0.55)).exp();
        let e = match variant {
            // The Concord quirk: a product where Rothermel has an exponential.
            SpreadVariant::Compat(_) => 0.715 * (-0.000359 * sigma),
            SpreadVariant::Corrected => 0.715 * (-0.000359 * sigma).exp(),
        };

        let sigma_15 = sigma.powf(1.5);
        let gamma_max = sigma_15 / (495.0 + 0.0594 * sigma_15);
        let beta_op = 3.348 * sigma.powf(-0.8189);
        let ratio = beta / beta_op;
        let gamma = gamma_max * ratio.powf(a) * (a * (1.0 - ratio)).exp();

        let eta_m = match variant {
            SpreadVariant::Compat(_) => 1.0 - 2.59 * rm + 5.11 * rm * rm - 3.52 * rm * rm * rm,
            SpreadVariant::Corrected if rm >= 1.0 => 0.0,
            SpreadVariant::Corrected => 1.0 - 2.59 * rm + 5.11 * rm * rm - 3.52 * rm * rm * rm,
        };
        let eta_s = 0.174 * EFFECTIVE_MINERAL_CONTENT.powf(-0.19);
        let reaction_intensity = gamma * fuel.net_load_lb_ft2 * HEAT_CONTENT_BTU_LB * eta_m * eta_s;

        let xi = ((0.792 + 0.681 * sigma.sqrt()) * (beta + 0.1)).exp() / (192.0 + 0.2595 * sigma);
        // Net load back to oven-dry load before dividing by depth.
        let bulk_density = (fuel.net_load_lb_ft2 / (1.0 - TOTAL_MINERAL_CONTENT)) / fuel.depth_ft;
        let epsilon = (-138.0 / sigma).exp();
        let q_ig = 250.0 + 1116.0 * moisture_frac;
        let r0 = reaction_intensity * xi / (bulk_density * epsilon * q_ig);

        Self {
            variant,
            no_wind_no_slope_ros_ftmin: r0,
            wind_exponent_b: b,
            wind_coefficient: c * ratio.powf(-e),
            slope_coefficient: 5.275 * beta.powf(-0.3),
        }
    }

    /// R₀ as computed (ft/min); may be ≤ 0 or NaN in compatibility mode.
    pub fn no_wind_no_slope_ros_ftmin(&self) -> f64 {
        self.no_wind_no_slope_ros_ftmin
    }

    /// Whether this fuel/moisture can spread at all (R₀ > 0).
    pub fn can_burn(&self) -> bool {
        self.no_wind_no_slope_ros_ftmin > 0.0
    }

    /// Spread rate (ft/min) from a burning cell to a neighbour at grid offset (dx, dy) that is
    /// `rise_ft` higher (negative: lower). Returns 0 where the fire cannot spread.
    pub fn rate_ftmin(&self, dx: i32, dy: i32, rise_ft: f64, wind: &ConcordWind, cell_size_ft: f64) -> f64 {
        let r0 = self.no_wind_no_slope_ros_ftmin;
        // Negative R₀ (past extinction, unclamped) or NaN (infinite moisture): never burns.
        if !self.can_burn() || (dx == 0 && dy == 0) {
            return 0.0;
        }
        let (dxf, dyf) = (f64::from(dx), f64::from(dy));
        let offset_len = (dxf * dxf + dyf * dyf).sqrt();

        let phi_w = if wind.speed_mph > 0.0 {
            self.wind_coefficient * (FT_PER_MIN_PER_MPH * wind.speed_mph).powf(self.wind_exponent_b)
        } else {
            0.0
        };
        let tan_slope = rise_ft / (offset_len * cell_size_ft);
        let phi_s = self.slope_coefficient * tan_slope * tan_slope;

        // Wind vector: (0, −1) rotated by −d, i.e. (−sin d, −cos d).
        let (sin_d, cos_d) = wind.from_direction_deg.to_radians().sin_cos();
        let wind_len = r0 * phi_w;
        // Slope vector points along the offset when going uphill (or level), against it downhill.
        let slope_scale = if rise_ft >= 0.0 { 1.0 } else { -1.0 } * r0 * phi_s / offset_len;
        let max_x = -sin_d * wind_len + dxf * slope_scale;
        let max_y = -cos_d * wind_len + dyf * slope_scale;
        let max_len = max_x.hypot(max_y);

        let head_ros = r0 + max_len;
        let phi_e = head_ros / r0 - 1.0;
        let inversion_base = phi_e / self.wind_coefficient;
        let effective_wind = if inversion_base > 0.0 {
            inversion_base.powf(1.0 / self.wind_exponent_b)
        } else {
            match self.variant {
                SpreadVariant::Compat(EdgeCasePolicy::Python) => return 0.0,
                SpreadVariant::Compat(EdgeCasePolicy::Js) | SpreadVariant::Corrected => 0.0,
            }
        };
        let eccentricity = self.variant.eccentricity(effective_wind);
        let cos_theta = if max_len > 0.0 {
            (dxf * max_x + dyf * max_y) / (offset_len * max_len)
        } else {
            1.0
        };
        head_ros * direction_factor(eccentricity, cos_theta)
    }
}

/// `getFireSpreadRate`: spread rate (ft/min) from `source` to `target`, with all fuel values
/// (and moisture) taken from the target cell. For a hot loop, build a [`ConcordSpread`] per
/// fuel × moisture once and call [`ConcordSpread::rate_ftmin`] instead.
pub fn fire_spread_rate_ftmin(
    source: &ConcordCell,
    target: &ConcordCell,
    target_fuel: &ConcordFuelConstants,
    target_moisture_frac: f64,
    wind: &ConcordWind,
    cell_size_ft: f64,
    variant: SpreadVariant,
) -> f64 {
    ConcordSpread::new(target_fuel, target_moisture_frac, variant).rate_ftmin(
        target.x - source.x,
        target.y - source.y,
        target.elevation_ft - source.elevation_ft,
        wind,
        cell_size_ft,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn land_cover_round_trip() {
        for (i, lc) in LandCover::ALL.iter().enumerate() {
            assert_eq!(usize::from(lc.modis_class()), i + 1);
            assert_eq!(LandCover::from_modis_class(lc.modis_class()), Some(*lc));
        }
        assert_eq!(LandCover::from_modis_class(0), None);
        assert_eq!(LandCover::from_modis_class(18), None);
    }

    #[test]
    fn drought_after_drops_saturates() {
        assert_eq!(DroughtLevel::Severe.after_helitack_drops(1), DroughtLevel::Medium);
        assert_eq!(DroughtLevel::Mild.after_helitack_drops(7), DroughtLevel::No);
        assert_eq!(DroughtLevel::from_index(4), None);
    }

    #[test]
    fn concord_moisture_is_mx_times_fraction() {
        let fractions = [0.85, 0.60, 0.35, 0.10];
        for fuel in [
            ConcordFuel::Grass,
            ConcordFuel::Shrub,
            ConcordFuel::Forest,
            ConcordFuel::ForestWithSuppression,
        ] {
            for (i, f) in fractions.iter().enumerate() {
                let drought = DroughtLevel::from_index(i as u8).expect("0..=3");
                let expected = fuel.fuel().mx_frac * f;
                assert!((fuel.moisture_frac(drought) - expected).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn unburnable_and_infinite_moisture_give_zero() {
        let wind = ConcordWind {
            speed_mph: 5.0,
            from_direction_deg: 0.0,
        };
        for variant in [SpreadVariant::default(), SpreadVariant::Corrected] {
            let urban = ConcordSpread::new(&LandCover::UrbanBuilt.fuel(), 0.05, variant);
            assert_eq!(urban.rate_ftmin(0, -1, 10.0, &wind, 500.0), 0.0);
            let river = ConcordSpread::new(&LandCover::Grasslands.fuel(), NON_BURNABLE_MOISTURE, variant);
            assert_eq!(river.rate_ftmin(0, -1, 10.0, &wind, 500.0), 0.0);
        }
    }
}
