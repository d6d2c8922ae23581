//! Fire behaviour grids: the behave kernel ([`crate::rothermel`]) at every cell of a LANDFIRE
//! landscape (LANDFIRE's GeoTIFF layers or a FARSITE/FlamMap `.lcp`, read into one
//! [`LandfireLandscape`]), as FlamMap's "basic fire behaviour" computes it for a surface fire.
//!
//! Per cell, with one set of moistures and one 20-ft wind for the whole landscape:
//!
//! - **Fuel**: the cell's FBFM40 or FBFM13 model (`docs/spec/fire-model.md §B8`); a fuel bed is
//!   prepared once per model.
//! - **Slope and aspect**: slope in percent, the upslope direction the aspect plus 180°
//!   (LANDFIRE's aspect is the direction the slope faces); aspect −1 (flat) is taken as 0, as
//!   it enters a FlamMap `.lcp`, so its upslope is south (FlamMap's direction on those cells).
//!   With no wind and no slope the direction is the upslope one, as FlamMap reports it. With
//!   [`SlopeMode::LcpWholeDegrees`] the slope goes through what a FlamMap `.lcp` file keeps:
//!   percent → degrees, rounded to a whole degree, back to percent.
//! - **Wind**: the 20-ft wind is reduced to midflame with FlamMap's (and FARSITE's) wind
//!   adjustment factor: under canopy (canopy cover > 0 and canopy height > 0) Albini &
//!   Baughman's (1979) sheltered form with crown ratio 1, WAF = 0.555 / (√(CC/3 · H) ·
//!   ln((20 + 0.36·H)/(0.13·H))), CC a fraction and H the canopy height in ft; otherwise the
//!   unsheltered form on the fuel-bed depth δ, 1.83 / ln((20 + 0.36·δ)/(0.13·δ))
//!   (`docs/spec/fire-model.md §B7`, "Wind height"). This follows pyretechnics, which
//!   reproduces FlamMap; it is not checked against FlamMap here (the Worcester run has no
//!   wind). The wind blows toward `wind_from_deg + 180°`; wind and slope combine as vectors
//!   (behave's method, `docs/spec/fire-model.md §B6`).
//! - **Outputs**: head rate of spread (ch/h), flame length (ft), Byram fireline intensity
//!   (Btu/ft/s), direction of maximum spread (degrees clockwise from north), and fire type.
//!
//! - **Crown fire** ([`crate::crown`], `docs/spec/fire-model.md §B11`): where the cell has a
//!   canopy (cover and height > 0) and the surface intensity reaches Van Wagner's critical
//!   intensity, the fire is passive (2) or active (3) crown fire, by Finney's method (FlamMap's
//!   default) or Scott & Reinhardt's; Rothermel's (1991) crown rate is fuel model 10 at the
//!   cell's slope with the 20-ft wind × 0.4, times 3.34, with the same moistures. Fire type is
//!   0 (no fire: non-burnable, or a fuel past extinction), 1 surface, 2 passive, 3 active.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use firecast_landscape::gridio::{GridPlacement, encode_geotiff_f32};
use firecast_landscape::landfire::{FuelLayer, LANDFIRE_NODATA, LandfireLandscape};
use rayon::prelude::*;

use crate::crown::{Canopy, CrownMethod, SurfaceHead};
use crate::fuel::FuelModel;
use crate::rothermel::{FuelMoisture, SpreadInputs, SurfaceFireHead, SurfaceFuelBed, WindLimit};

/// How slope enters the kernel.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SlopeMode {
    /// The landscape's slope as read (LANDFIRE's percent layer).
    #[default]
    AsGiven,
    /// As a FlamMap `.lcp` landscape stores it: whole degrees (percent → degrees, rounded
    /// half away from zero, → percent).
    LcpWholeDegrees,
}

/// The fuel layer to read, in params.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FuelChoice {
    #[default]
    Fbfm40,
    Fbfm13,
}

impl FuelChoice {
    pub fn layer(self) -> FuelLayer {
        match self {
            Self::Fbfm40 => FuelLayer::Fbfm40,
            Self::Fbfm13 => FuelLayer::Fbfm13,
        }
    }
}

/// Fuel moistures in percent.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MoisturePercent {
    pub dead_1h: f64,
    pub dead_10h: f64,
    pub dead_100h: f64,
    pub live_herbaceous: f64,
    pub live_woody: f64,
}

impl MoisturePercent {
    /// Parse `D1,D10,D100,HERB,WOODY` (percent).
    pub fn parse(text: &str) -> Result<Self, String> {
        let values: Vec<f64> = text
            .split(',')
            .map(|v| v.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("moisture `{text}` is not five numbers D1,D10,D100,HERB,WOODY (percent)"))?;
        let [dead_1h, dead_10h, dead_100h, live_herbaceous, live_woody] = values[..] else {
            return Err(format!(
                "moisture `{text}` has {} values; give five: D1,D10,D100,HERB,WOODY (percent)",
                values.len()
            ));
        };
        Ok(Self {
            dead_1h,
            dead_10h,
            dead_100h,
            live_herbaceous,
            live_woody,
        })
    }

    /// The kernel's fractions.
    pub fn fractions(&self) -> FuelMoisture {
        FuelMoisture::from_percent(
            self.dead_1h,
            self.dead_10h,
            self.dead_100h,
            self.live_herbaceous,
            self.live_woody,
        )
    }
}

/// Everything a behaviour run takes besides the landscape: the `sim.behavior` params and
/// what `firecast sim behavior` resolves its flags into.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BehaviorParams {
    /// Which fuel layer to read.
    #[serde(default)]
    pub fuel: FuelChoice,
    /// Fuel moistures, percent, the same for every fuel model.
    pub moisture: MoisturePercent,
    /// 20-ft wind speed, mi/h.
    #[serde(default)]
    pub wind_20ft_mph: f64,
    /// Direction the wind comes from, degrees clockwise from north (grid north).
    #[serde(default)]
    pub wind_from_deg: f64,
    /// How slope enters the kernel.
    #[serde(default)]
    pub slope: SlopeMode,
    /// Rothermel's effective-wind limit (behave's default, and FlamMap's here: off).
    #[serde(default)]
    pub wind_limit: bool,
    /// Crown fire method: `finney` (FlamMap's default), `scott-reinhardt`, or `none`.
    #[serde(default)]
    pub crown: CrownMethod,
    /// Foliar moisture content, percent (FlamMap's default 100 %).
    #[serde(default = "default_foliar_moisture")]
    pub foliar_moisture_pct: f64,
}

fn default_foliar_moisture() -> f64 {
    100.0
}

/// A params value out of range: `field` names it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field} = {value}: {message}")]
pub struct ParamError {
    pub field: &'static str,
    pub value: f64,
    pub message: &'static str,
}

impl BehaviorParams {
    /// Check ranges: dead moistures 1–100 %, live 30–300 % (the live range behave's
    /// curing and extinction cover), foliar moisture 30–300 %, wind 0–100 mi/h, direction
    /// 0–360°.
    pub fn validate(&self) -> Result<(), ParamError> {
        let m = &self.moisture;
        let checks: [(&'static str, f64, f64, f64, &'static str); 8] = [
            (
                "moisture.dead_1h",
                m.dead_1h,
                1.0,
                100.0,
                "dead moisture must be 1-100 %",
            ),
            (
                "moisture.dead_10h",
                m.dead_10h,
                1.0,
                100.0,
                "dead moisture must be 1-100 %",
            ),
            (
                "moisture.dead_100h",
                m.dead_100h,
                1.0,
                100.0,
                "dead moisture must be 1-100 %",
            ),
            (
                "moisture.live_herbaceous",
                m.live_herbaceous,
                30.0,
                300.0,
                "live moisture must be 30-300 %",
            ),
            (
                "moisture.live_woody",
                m.live_woody,
                30.0,
                300.0,
                "live moisture must be 30-300 %",
            ),
            (
                "foliar_moisture_pct",
                self.foliar_moisture_pct,
                30.0,
                300.0,
                "foliar moisture must be 30-300 %",
            ),
            (
                "wind_20ft_mph",
                self.wind_20ft_mph,
                0.0,
                100.0,
                "wind speed must be 0-100 mi/h",
            ),
            (
                "wind_from_deg",
                self.wind_from_deg,
                0.0,
                360.0,
                "wind direction must be 0-360 degrees",
            ),
        ];
        for (field, value, lo, hi, message) in checks {
            if !(value.is_finite() && (lo..=hi).contains(&value)) {
                return Err(ParamError {
                    field,
                    value,
                    message,
                });
            }
        }
        Ok(())
    }
}

/// Fire type codes, as FlamMap writes them.
pub const FIRE_TYPE_NONE: f32 = 0.0;
pub const FIRE_TYPE_SURFACE: f32 = 1.0;
pub use crate::crown::{FIRE_TYPE_ACTIVE, FIRE_TYPE_PASSIVE};

/// The grids of one run, row 0 north, `nodata` where an input layer (fuel, slope, aspect) has
/// none; direction is `nodata` also where nothing spreads.
#[derive(Debug, Clone, PartialEq)]
pub struct BehaviorGrids {
    pub width: usize,
    pub height: usize,
    pub nodata: f32,
    pub ros_chph: Vec<f32>,
    pub flame_length_ft: Vec<f32>,
    pub fireline_intensity_btu_ft_s: Vec<f32>,
    /// Degrees clockwise from grid north, in [0, 360).
    pub max_spread_dir_deg: Vec<f32>,
    pub fire_type: Vec<f32>,
    /// Midflame wind speed used, mi/h.
    pub midflame_wind_mph: Vec<f32>,
}

/// The grid files, their names and units.
pub const GRID_FILES: [(&str, &str); 5] = [
    ("ros_chph.tif", "head rate of spread, ch/h"),
    ("flame_length_ft.tif", "flame length, ft"),
    (
        "fireline_intensity_btu_ft_s.tif",
        "Byram fireline intensity, Btu/ft/s",
    ),
    (
        "max_spread_direction_deg.tif",
        "direction of maximum spread, degrees clockwise from north",
    ),
    (
        "fire_type.tif",
        "fire type: 0 none, 1 surface, 2 passive crown, 3 active crown",
    ),
];

impl BehaviorGrids {
    fn layers(&self) -> [&[f32]; 5] {
        [
            &self.ros_chph,
            &self.flame_length_ft,
            &self.fireline_intensity_btu_ft_s,
            &self.max_spread_dir_deg,
            &self.fire_type,
        ]
    }
}

/// Slope (percent) as a FlamMap `.lcp` keeps it: whole degrees, back to percent.
pub fn lcp_slope_percent(slope_percent: f64) -> f64 {
    let degrees = (slope_percent / 100.0).atan().to_degrees().round();
    degrees.to_radians().tan() * 100.0
}

/// The canopy that shelters cell `i`'s surface fuel from the wind: cover as a fraction and
/// height in feet (none where the layers are absent or nodata).
pub fn sheltering_canopy(land: &LandfireLandscape, i: usize) -> (f64, f64) {
    let cover = land
        .canopy_cover_pct
        .as_ref()
        .map_or(0.0, |c| f64::from(c[i]) / 100.0);
    let canopy_ft = land
        .canopy_height_m
        .as_ref()
        .map_or(0.0, |c| f64::from(c[i]) / 0.3048);
    if cover.is_nan() || canopy_ft.is_nan() {
        (0.0, 0.0)
    } else {
        (cover, canopy_ft)
    }
}

/// FlamMap's wind adjustment factor (see the module documentation). `canopy_cover` a fraction,
/// heights in ft.
pub fn wind_adjustment_factor(fuel_bed_depth_ft: f64, canopy_height_ft: f64, canopy_cover: f64) -> f64 {
    if canopy_cover > 0.0 && canopy_height_ft > 0.0 {
        let h = canopy_height_ft;
        0.555 / ((canopy_cover / 3.0 * h).sqrt() * ((20.0 + 0.36 * h) / (0.13 * h)).ln())
    } else if fuel_bed_depth_ft > 0.0 {
        let d = fuel_bed_depth_ft;
        1.83 / ((20.0 + 0.36 * d) / (0.13 * d)).ln()
    } else {
        0.0
    }
}

/// Compute the surface fire behaviour of every cell. The landscape must have been read with
/// the fuel layer `params.fuel` names; params must be valid ([`BehaviorParams::validate`]).
/// The kernel is evaluated for the head of the fire only ([`SurfaceFuelBed::head_with_limit`]:
/// the grids are the bits the full ellipse gives, a test compares them).
pub fn surface_behavior_grids(
    land: &LandfireLandscape,
    params: &BehaviorParams,
) -> Result<BehaviorGrids, crate::RothermelError> {
    behavior_grids_with(land, params, SurfaceFuelBed::head_with_limit, true)
}

/// Terms of a cell's fire that depend on few values, computed once for each value a thread meets
/// (direct-mapped: a slot holds the last value hashed to it). Every term is the function of its
/// key the grid computes otherwise, so the grids are the same bits (a test compares them with and
/// without the memo): the midflame wind and the wind factor φ_w of a fuel code under a canopy
/// (LANDFIRE's cover and height take a few values: 374 combinations on the Worcester clip, for
/// FlamMap's logarithm and square root and Rothermel's power), the upslope direction, the wind's
/// direction from it and that direction's sine and cosine of an aspect (361 values), and Van
/// Wagner's critical intensity (a power) of a canopy base height.
struct CellMemo {
    wind: Vec<Option<WindTerms>>,
    aspect: Vec<Option<AspectTerms>>,
    critical: Vec<Option<(u64, f64)>>,
}

#[derive(Clone, Copy)]
struct WindTerms {
    code: u16,
    cover_bits: u64,
    canopy_ft_bits: u64,
    midflame_mph: f64,
    wind_factor: f64,
}

#[derive(Clone, Copy)]
struct AspectTerms {
    aspect_bits: u32,
    upslope_deg: f64,
    wind_dir_from_upslope_deg: f64,
    sin_cos: (f64, f64),
}

const MEMO_BITS: u32 = 10;

/// Slot of a key in a memo of 2^MEMO_BITS slots.
#[inline]
fn memo_slot(key: u64) -> usize {
    (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> (64 - MEMO_BITS)) as usize
}

impl CellMemo {
    fn new() -> Self {
        Self {
            wind: vec![None; 1 << MEMO_BITS],
            aspect: vec![None; 1 << MEMO_BITS],
            critical: vec![None; 1 << MEMO_BITS],
        }
    }

    /// (midflame wind, φ_w) of `bed` (code `code`, depth `depth`) under the canopy (`cover`,
    /// `canopy_ft`) at a 20-ft wind `wind_20ft_mph`.
    #[inline]
    fn wind(
        &mut self,
        code: u16,
        bed: &SurfaceFuelBed,
        depth: f64,
        cover: f64,
        canopy_ft: f64,
        wind_20ft_mph: f64,
    ) -> (f64, f64) {
        let (cover_bits, canopy_ft_bits) = (cover.to_bits(), canopy_ft.to_bits());
        let slot = memo_slot(cover_bits ^ canopy_ft_bits.rotate_left(23) ^ (u64::from(code) << 48));
        if let Some(t) = self.wind[slot]
            && (t.code, t.cover_bits, t.canopy_ft_bits) == (code, cover_bits, canopy_ft_bits)
        {
            return (t.midflame_mph, t.wind_factor);
        }
        // As the grid computes it without the memo.
        let midflame_mph = if wind_20ft_mph > 0.0 {
            wind_20ft_mph * wind_adjustment_factor(depth, canopy_ft, cover)
        } else {
            0.0
        };
        let wind_factor = bed.midflame_wind_factor(midflame_mph);
        self.wind[slot] = Some(WindTerms {
            code,
            cover_bits,
            canopy_ft_bits,
            midflame_mph,
            wind_factor,
        });
        (midflame_mph, wind_factor)
    }

    /// (upslope, wind direction from upslope, its sine and cosine) of an aspect.
    #[inline]
    fn aspect(&mut self, aspect: f32, wind_toward: f64) -> AspectTerms {
        let aspect_bits = aspect.to_bits();
        let slot = memo_slot(u64::from(aspect_bits));
        if let Some(t) = self.aspect[slot]
            && t.aspect_bits == aspect_bits
        {
            return t;
        }
        let upslope_deg = wrap_degrees(f64::from(aspect.max(0.0)) + 180.0);
        let wind_dir_from_upslope_deg = wrap_degrees(wind_toward - upslope_deg);
        let t = AspectTerms {
            aspect_bits,
            upslope_deg,
            wind_dir_from_upslope_deg,
            sin_cos: wind_dir_from_upslope_deg.to_radians().sin_cos(),
        };
        self.aspect[slot] = Some(t);
        t
    }

    /// Van Wagner's critical surface intensity, kW/m, of a canopy base height (m).
    #[inline]
    fn critical_intensity(&mut self, cbh: f64, foliar_moisture_pct: f64) -> f64 {
        let bits = cbh.to_bits();
        let slot = memo_slot(bits);
        if let Some((key, value)) = self.critical[slot]
            && key == bits
        {
            return value;
        }
        let value = crate::crown::critical_surface_intensity_kw_m(cbh, foliar_moisture_pct);
        self.critical[slot] = Some((bits, value));
        value
    }
}

/// [`surface_behavior_grids`] with the head of the fire at a cell given by `head` (the full
/// kernel, or its head-only path), through the per-thread [`CellMemo`] where `memo` (then the
/// surface head is [`SurfaceFuelBed::head_with_wind_factor`], the bits `head_with_limit` gives).
fn behavior_grids_with<H>(
    land: &LandfireLandscape,
    params: &BehaviorParams,
    head: H,
    memo: bool,
) -> Result<BehaviorGrids, crate::RothermelError>
where
    H: Fn(&SurfaceFuelBed, &SpreadInputs, WindLimit) -> SurfaceFireHead + Sync,
{
    let moisture = params.moisture.fractions();
    // One prepared bed per code present, indexed by code.
    let mut beds: Vec<Option<(SurfaceFuelBed, f64)>> = Vec::new();
    for &code in land.fuel.iter().flatten() {
        // The reader only lets through codes the fuel table holds; any other is nodata here.
        let k = usize::from(code);
        if k >= beds.len() {
            beds.resize(k + 1, None);
        }
        if beds[k].is_none()
            && let Some(model) = FuelModel::by_number(code)
        {
            beds[k] = Some((SurfaceFuelBed::new(model, &moisture)?, model.depth_ft));
        }
    }
    let (width, height) = (land.grid.width, land.grid.height);
    let nodata = LANDFIRE_NODATA as f32;
    let limit = if params.wind_limit {
        WindLimit::Rothermel
    } else {
        WindLimit::Off
    };
    let wind_toward = (params.wind_from_deg + 180.0).rem_euclid(360.0);
    // Rothermel's (1991) crown rate is fuel model 10's, with the same moistures.
    let fm10 = FuelModel::by_number(10).expect("fuel model 10 is in the table");
    let fm10 = SurfaceFuelBed::new(fm10, &moisture)?;
    let layer = |layer: &Option<Vec<f32>>, i: usize| layer.as_ref().map_or(f64::NAN, |c| f64::from(c[i]));
    let cell = |cache: &mut CellMemo, i: usize| -> [f32; 6] {
        let none = [nodata; 6];
        let (Some(code), slope, aspect) = (land.fuel[i], land.slope_percent[i], land.aspect_deg[i]) else {
            return none;
        };
        if slope.is_nan() || aspect.is_nan() {
            return none;
        }
        let Some((bed, depth)) = beds.get(usize::from(code)).and_then(Option::as_ref) else {
            return none;
        };
        let mut slope = f64::from(slope);
        if params.slope == SlopeMode::LcpWholeDegrees {
            slope = lcp_slope_percent(slope);
        }
        // LANDFIRE's flat aspect −1 enters an `.lcp` as 0 (north-facing), so FlamMap's upslope
        // there is south; it reports that direction even where the slope rounds to 0.
        let (cover, canopy_ft) = sheltering_canopy(land, i);
        let (upslope, inputs, fire, midflame);
        if memo {
            let a = cache.aspect(aspect, wind_toward);
            let (mid, wind_factor) = cache.wind(code, bed, *depth, cover, canopy_ft, params.wind_20ft_mph);
            (upslope, midflame) = (a.upslope_deg, mid);
            inputs = SpreadInputs {
                midflame_wind_mph: midflame,
                slope_percent: slope,
                wind_dir_from_upslope_deg: a.wind_dir_from_upslope_deg,
            };
            fire =
                bed.head_with_wind_factor(wind_factor, a.wind_dir_from_upslope_deg, a.sin_cos, slope, limit);
        } else {
            upslope = wrap_degrees(f64::from(aspect.max(0.0)) + 180.0);
            // Without wind the midflame wind is 0 whatever the adjustment factor (always finite).
            midflame = if params.wind_20ft_mph > 0.0 {
                params.wind_20ft_mph * wind_adjustment_factor(*depth, canopy_ft, cover)
            } else {
                0.0
            };
            inputs = SpreadInputs {
                midflame_wind_mph: midflame,
                slope_percent: slope,
                wind_dir_from_upslope_deg: wrap_degrees(wind_toward - upslope),
            };
            fire = head(bed, &inputs, limit);
        }
        if fire.head_ros_ftmin > 0.0 {
            let dir = wrap_degrees(upslope + fire.dir_max_spread_from_upslope_deg);
            let canopy = Canopy {
                cover_pct: layer(&land.canopy_cover_pct, i),
                height_m: layer(&land.canopy_height_m, i),
                base_height_m: layer(&land.canopy_base_height_m, i),
                bulk_density_kg_m3: layer(&land.canopy_bulk_density_kg_m3, i),
            };
            let canopy_known = [
                canopy.cover_pct,
                canopy.height_m,
                canopy.base_height_m,
                canopy.bulk_density_kg_m3,
            ]
            .iter()
            .all(|v| v.is_finite());
            // `crown_fire` gives no crown fire below Van Wagner's critical surface intensity (with
            // FlamMap's guard on a zero base height); that test first, so Rothermel's crown rate
            // (a second kernel evaluation) is computed only where the canopy can ignite.
            let mut may_ignite = || {
                let cbh = if canopy.base_height_m == 0.0 {
                    0.01
                } else {
                    canopy.base_height_m
                };
                let fli_kw = fire.fireline_intensity_btu_ft_s * crate::crown::KW_M_PER_BTU_FT_S;
                fli_kw > 0.0
                    && fli_kw
                        >= if memo {
                            cache.critical_intensity(cbh, params.foliar_moisture_pct)
                        } else {
                            crate::crown::critical_surface_intensity_kw_m(cbh, params.foliar_moisture_pct)
                        }
            };
            if params.crown != CrownMethod::None && canopy_known && canopy.has_canopy() && may_ignite() {
                let crown_wind = params.wind_20ft_mph * crate::crown::CROWN_WIND_REDUCTION;
                let crown_inputs = SpreadInputs {
                    midflame_wind_mph: crown_wind,
                    ..inputs
                };
                let fm10_fire = head(&fm10, &crown_inputs, limit);
                let r_active = crate::crown::ROTHERMEL_CROWN_FACTOR * fm10_fire.head_ros_ftmin * FT_TO_M;
                let surface = SurfaceHead {
                    ros_m_min: fire.head_ros_ftmin * FT_TO_M,
                    intensity_btu_ft_s: fire.fireline_intensity_btu_ft_s,
                };
                let waf = if params.wind_20ft_mph > 0.0 {
                    midflame / params.wind_20ft_mph
                } else {
                    wind_adjustment_factor(*depth, canopy_ft, cover)
                };
                let r_sa =
                    |r_crit: f64| surface_rate_at_critical_wind(&head, bed, &fm10, slope, waf, r_crit, limit);
                if let Some(crown) = crate::crown::crown_fire(
                    params.crown,
                    surface,
                    canopy,
                    params.foliar_moisture_pct,
                    r_active,
                    r_sa,
                ) {
                    let dir = if crown.crown_spread {
                        wrap_degrees(upslope + fm10_fire.dir_max_spread_from_upslope_deg)
                    } else {
                        dir
                    };
                    return [
                        (crown.ros_m_min / FT_TO_M * 60.0 / 66.0) as f32,
                        crown.flame_length_ft as f32,
                        crown.intensity_btu_ft_s as f32,
                        dir as f32,
                        crown.fire_type,
                        midflame as f32,
                    ];
                }
            }
            [
                fire.head_ros_chph() as f32,
                fire.flame_length_ft as f32,
                fire.fireline_intensity_btu_ft_s as f32,
                dir as f32,
                FIRE_TYPE_SURFACE,
                midflame as f32,
            ]
        } else {
            [0.0, 0.0, 0.0, nodata, FIRE_TYPE_NONE, midflame as f32]
        }
    };
    let n = width * height;
    let mut columns: [Vec<f32>; 6] = std::array::from_fn(|_| vec![0.0; n]);
    let [ros, flame, intensity, dir, fire_type, midflame] = &mut columns;
    (
        ros.par_iter_mut(),
        flame.par_iter_mut(),
        intensity.par_iter_mut(),
        dir.par_iter_mut(),
        fire_type.par_iter_mut(),
        midflame.par_iter_mut(),
    )
        .into_par_iter()
        .enumerate()
        .for_each_init(CellMemo::new, |cache, (i, (a, b, c, d, e, f))| {
            [*a, *b, *c, *d, *e, *f] = cell(cache, i);
        });
    let [ros, flame, intensity, dir, fire_type, midflame] = columns;
    Ok(BehaviorGrids {
        width,
        height,
        nodata,
        ros_chph: ros,
        flame_length_ft: flame,
        fireline_intensity_btu_ft_s: intensity,
        max_spread_dir_deg: dir,
        fire_type,
        midflame_wind_mph: midflame,
    })
}

/// `x.rem_euclid(360.0)`, bit for bit, without the `fmod` call for the angles the grid meets
/// (−360° < x < 720°).
#[inline]
fn wrap_degrees(x: f64) -> f64 {
    if (0.0..360.0).contains(&x) {
        x
    } else if (360.0..720.0).contains(&x) {
        // Exact (Sterbenz), as fmod is.
        x - 360.0
    } else if -360.0 < x && x < 0.0 {
        // fmod leaves x as it is; rem_euclid then adds 360.
        x + 360.0
    } else {
        x.rem_euclid(360.0)
    }
}

const FT_TO_M: f64 = 0.3048;

/// Scott & Reinhardt's R'_SA, m/min: the surface head rate (wind blowing upslope) at the 20-ft
/// wind for which Rothermel's crown rate 3.34 · R₁₀ (wind × 0.4, upslope) reaches `r_crit`
/// (m/min), found by bisection; `waf` reduces the 20-ft wind to the surface fuel's midflame.
fn surface_rate_at_critical_wind(
    head: impl Fn(&SurfaceFuelBed, &SpreadInputs, WindLimit) -> SurfaceFireHead,
    bed: &SurfaceFuelBed,
    fm10: &SurfaceFuelBed,
    slope_percent: f64,
    waf: f64,
    r_crit_m_min: f64,
    limit: WindLimit,
) -> f64 {
    let upslope = |wind: f64| SpreadInputs {
        midflame_wind_mph: wind,
        slope_percent,
        wind_dir_from_upslope_deg: 0.0,
    };
    let crown_rate = |u20: f64| {
        crate::crown::ROTHERMEL_CROWN_FACTOR
            * head(fm10, &upslope(u20 * crate::crown::CROWN_WIND_REDUCTION), limit).head_ros_ftmin
            * FT_TO_M
    };
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    if crown_rate(lo) >= r_crit_m_min {
        hi = 0.0;
    } else {
        while crown_rate(hi) < r_crit_m_min && hi < 1e4 {
            lo = hi;
            hi *= 2.0;
        }
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if crown_rate(mid) < r_crit_m_min {
                lo = mid;
            } else {
                hi = mid;
            }
        }
    }
    head(bed, &upslope(hi * waf), limit).head_ros_ftmin * FT_TO_M
}

/// Minimum, maximum and mean of a grid over the cells that burn.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Range {
    pub min: f64,
    pub max: f64,
    pub mean: f64,
}

fn range_over(values: &[f32], mask: &[bool]) -> Option<Range> {
    let (mut min, mut max, mut sum, mut n) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0usize);
    for (v, m) in values.iter().zip(mask) {
        if *m {
            let v = f64::from(*v);
            min = min.min(v);
            max = max.max(v);
            sum += v;
            n += 1;
        }
    }
    (n > 0).then(|| Range {
        min,
        max,
        mean: sum / n as f64,
    })
}

/// The JSON summary written beside the grids.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BehaviorSummary {
    pub landscape: PathBuf,
    /// `LANDFIRE GeoTIFF layers` or `FARSITE .lcp`.
    pub landscape_format: &'static str,
    /// How each input layer was stored (and what it was converted from), by layer.
    pub layer_units: BTreeMap<&'static str, String>,
    pub width: usize,
    pub height: usize,
    pub crs: String,
    pub params: BehaviorParams,
    pub wind_adjustment: &'static str,
    pub crown_fire: &'static str,
    /// Canopy layers the landscape lacks: with any missing, no cell can crown.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub crown_fire_missing_layers: Vec<&'static str>,
    /// Cells without data in fuel, slope or aspect (written as `nodata`).
    pub nodata_cells: usize,
    pub nodata_value: f32,
    /// Nodata cells per input layer, by layer name.
    pub layer_nodata_cells: BTreeMap<String, usize>,
    /// Cells by fire type among cells with data: `none`, `surface`, `passive_crown`,
    /// `active_crown`.
    pub fire_type_cells: BTreeMap<&'static str, usize>,
    /// Of the `none` cells: non-burnable codes, and burnable fuel that does not spread
    /// (past its moisture of extinction).
    pub nonburnable_cells: usize,
    pub extinct_cells: usize,
    /// Cells by fuel code among cells with data.
    pub fuel_cells: BTreeMap<u16, usize>,
    /// Ranges over the burning cells.
    pub ros_chph: Option<Range>,
    pub flame_length_ft: Option<Range>,
    pub fireline_intensity_btu_ft_s: Option<Range>,
    pub midflame_wind_mph: Option<Range>,
    /// The files written, with what each holds.
    pub files: BTreeMap<&'static str, &'static str>,
}

/// Summarise a run.
pub fn summarize(
    land: &LandfireLandscape,
    params: &BehaviorParams,
    grids: &BehaviorGrids,
) -> BehaviorSummary {
    let burning: Vec<bool> = grids
        .fire_type
        .iter()
        .map(|t| *t != FIRE_TYPE_NONE && *t != grids.nodata)
        .collect();
    let nodata_cells = grids.fire_type.iter().filter(|t| **t == grids.nodata).count();
    let count = |code: f32| grids.fire_type.iter().filter(|t| **t == code).count();
    let (surface, passive, active) = (
        count(FIRE_TYPE_SURFACE),
        count(FIRE_TYPE_PASSIVE),
        count(FIRE_TYPE_ACTIVE),
    );
    let none = grids.fire_type.iter().filter(|t| **t == FIRE_TYPE_NONE).count();
    let mut fuel_cells: BTreeMap<u16, usize> = BTreeMap::new();
    let mut nonburnable = 0;
    for (code, t) in land.fuel.iter().zip(&grids.fire_type) {
        if let Some(code) = code
            && *t != grids.nodata
        {
            *fuel_cells.entry(*code).or_default() += 1;
            if FuelModel::by_number(*code).is_some_and(|m| !m.burnable) {
                nonburnable += 1;
            }
        }
    }
    BehaviorSummary {
        landscape: land
            .files
            .values()
            .next()
            .and_then(|p| p.parent())
            .map(Path::to_path_buf)
            .unwrap_or_default(),
        landscape_format: land.report.format,
        layer_units: land.report.stored_units.clone(),
        width: grids.width,
        height: grids.height,
        crs: land.grid.crs.clone(),
        params: params.clone(),
        wind_adjustment: "FlamMap/FARSITE: sheltered Albini & Baughman (1979), crown ratio 1, where canopy \
                          cover and height > 0; else unsheltered on the fuel-bed depth",
        crown_fire: match params.crown {
            CrownMethod::Finney => {
                "Finney (FlamMap's default): Van Wagner (1977) initiation, Rothermel (1991) crown rate \
                 (fuel model 10, 20-ft wind x 0.4, x 3.34), crown fraction burned by Van Wagner's \
                 (1993) exponential form; passive cells spread at the surface rate"
            }
            CrownMethod::ScottReinhardt => {
                "Scott & Reinhardt (2001): Van Wagner (1977) initiation, Rothermel (1991) crown rate, \
                 crown fraction burned linear between the initiation rate and the surface rate at the \
                 critical wind for active crowning; passive ROS = R + CFB (R_active - R)"
            }
            CrownMethod::None => "none: every burning cell is reported as surface fire (type 1)",
        },
        nodata_cells,
        nodata_value: grids.nodata,
        layer_nodata_cells: land
            .report
            .layers
            .iter()
            .map(|l| (l.layer.to_string(), l.nodata_cells))
            .collect(),
        crown_fire_missing_layers: if params.crown == CrownMethod::None {
            Vec::new()
        } else {
            [
                ("canopy cover", land.canopy_cover_pct.is_none()),
                ("canopy height", land.canopy_height_m.is_none()),
                ("canopy base height", land.canopy_base_height_m.is_none()),
                ("canopy bulk density", land.canopy_bulk_density_kg_m3.is_none()),
            ]
            .into_iter()
            .filter_map(|(name, missing)| missing.then_some(name))
            .collect()
        },
        fire_type_cells: BTreeMap::from([
            ("none", none),
            ("surface", surface),
            ("passive_crown", passive),
            ("active_crown", active),
        ]),
        nonburnable_cells: nonburnable,
        extinct_cells: none - nonburnable,
        fuel_cells,
        ros_chph: range_over(&grids.ros_chph, &burning),
        flame_length_ft: range_over(&grids.flame_length_ft, &burning),
        fireline_intensity_btu_ft_s: range_over(&grids.fireline_intensity_btu_ft_s, &burning),
        midflame_wind_mph: range_over(&grids.midflame_wind_mph, &burning),
        files: GRID_FILES
            .iter()
            .copied()
            .chain([("summary.json", "this summary")])
            .collect(),
    }
}

/// Errors of a behaviour run.
#[derive(Debug, thiserror::Error)]
pub enum BehaviorError {
    #[error(transparent)]
    Landscape(#[from] firecast_landscape::landfire::LandfireError),
    #[error("{0}")]
    Params(#[from] ParamError),
    #[error(transparent)]
    Kernel(#[from] crate::RothermelError),
    #[error("{0}")]
    Encode(#[from] firecast_landscape::LandscapeError),
    #[error("cannot write {path}: {source}")]
    Io { source: std::io::Error, path: PathBuf },
}

/// Read the landscape (a LANDFIRE folder or a FARSITE `.lcp`:
/// [`LandfireLandscape::read_path`]), check that every burnable cell has the layers the
/// kernel needs there ([`LandfireLandscape::check_burnable_cells`]; the canopy layers too
/// unless crown fire is off), compute the grids and write them with the summary into `out` (a
/// folder): staged in a temporary sibling folder and renamed into place, so `out` is either
/// the old folder or the complete new one. Nothing is written when an input is bad.
pub fn run_behavior(
    landscape: &Path,
    params: &BehaviorParams,
    out: &Path,
) -> Result<BehaviorSummary, BehaviorError> {
    params.validate()?;
    let land = LandfireLandscape::read_path(landscape, params.fuel.layer())?;
    land.check_burnable_cells(params.crown != CrownMethod::None)?;
    let grids = surface_behavior_grids(&land, params)?;
    let mut summary = summarize(&land, params, &grids);
    summary.landscape = landscape.to_path_buf();
    write_outputs(&land, &grids, &summary, out)?;
    Ok(summary)
}

/// Write the grids (float32 GeoTIFFs with the landscape's georeference, nodata 32767) and
/// `summary.json` into `out`, atomically as a folder.
pub fn write_outputs(
    land: &LandfireLandscape,
    grids: &BehaviorGrids,
    summary: &BehaviorSummary,
    out: &Path,
) -> Result<(), BehaviorError> {
    let placement = GridPlacement {
        width: grids.width,
        height: grids.height,
        origin_x: land.grid.origin_x,
        origin_y: land.grid.origin_y,
        pixel_dx: land.grid.pixel_dx,
        pixel_dy: land.grid.pixel_dy,
        geokeys: land.grid.geokeys.clone(),
    };
    let mut files = Vec::new();
    for ((name, _), data) in GRID_FILES.iter().zip(grids.layers()) {
        files.push((
            *name,
            encode_geotiff_f32(&placement, data, Some(f64::from(grids.nodata)))?,
        ));
    }
    let json = serde_json::to_vec_pretty(summary).map_err(|e| BehaviorError::Io {
        source: std::io::Error::other(e),
        path: out.join("summary.json"),
    })?;
    files.push(("summary.json", json));
    publish_folder(out, &files)
}

/// Stage `files` in a temporary sibling of `out` and publish it (`firecast_fs`: an existing
/// `out` is replaced whole; a failure leaves the old one and no staging folder).
fn publish_folder(out: &Path, files: &[(&str, Vec<u8>)]) -> Result<(), BehaviorError> {
    let fs_err = |e: firecast_fs::FsError| BehaviorError::Io {
        path: e.path,
        source: e.source,
    };
    let stage = firecast_fs::TempPath::dir(out).map_err(fs_err)?;
    for (file, bytes) in files {
        let path = stage.path().join(file);
        std::fs::write(&path, bytes).map_err(|source| BehaviorError::Io { source, path })?;
    }
    stage.publish().map_err(fs_err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lcp_rounding_goes_through_whole_degrees() {
        assert_eq!(lcp_slope_percent(0.0), 0.0);
        // 23 % is 12.95°, kept as 13° = 23.087 %.
        assert!((lcp_slope_percent(23.0) - 23.0868).abs() < 1e-4);
        assert!((lcp_slope_percent(100.0) - 100.0).abs() < 1e-9);
    }

    #[test]
    fn wrapped_degrees_equal_rem_euclid_bit_for_bit() {
        let mut x = -800.0f64;
        while x < 800.0 {
            for v in [x, x + 1e-13, x - 1e-13, -x * 1e-17] {
                assert_eq!(wrap_degrees(v).to_bits(), v.rem_euclid(360.0).to_bits(), "{v}");
            }
            x += 0.37;
        }
        for v in [
            -720.0,
            -360.0,
            -0.0,
            0.0,
            360.0,
            720.0,
            -1e-300,
            359.999_999_999_999_94,
        ] {
            assert_eq!(wrap_degrees(v).to_bits(), v.rem_euclid(360.0).to_bits(), "{v}");
        }
    }

    #[test]
    fn wind_adjustment_matches_the_unsheltered_spec_value() {
        // docs/spec/fire-model.md §B9: unsheltered WAF 0.362 for GR2 (depth 1 ft).
        assert!((wind_adjustment_factor(1.0, 0.0, 0.0) - 0.362).abs() < 5e-4);
        let sheltered = wind_adjustment_factor(1.0, 60.0, 0.5);
        assert!(sheltered > 0.0 && sheltered < 0.2, "{sheltered}");
        assert_eq!(wind_adjustment_factor(0.0, 0.0, 0.0), 0.0);
    }

    #[test]
    fn critical_wind_surface_rate_by_construction() {
        // With fuel model 10 as the surface fuel and its wind reduced by 0.4 too, the surface
        // rate at O'_active is Rothermel's R10 there: R'_active / 3.34.
        let moisture = MoisturePercent::parse("6,8,10,75,60").expect("five").fractions();
        let fm10 = SurfaceFuelBed::new(FuelModel::by_number(10).expect("FM10"), &moisture).expect("bed");
        for (slope, r_crit) in [(0.0, 20.0), (30.0, 12.0), (80.0, 40.0)] {
            let r_sa = surface_rate_at_critical_wind(
                SurfaceFuelBed::head_with_limit,
                &fm10,
                &fm10,
                slope,
                0.4,
                r_crit,
                WindLimit::Off,
            );
            assert!(
                (r_sa / (r_crit / 3.34) - 1.0).abs() < 1e-9,
                "{slope} {r_crit} {r_sa}"
            );
        }
        // Slope alone past the threshold: the critical wind is 0.
        let steep = surface_rate_at_critical_wind(
            SurfaceFuelBed::head_with_limit,
            &fm10,
            &fm10,
            100.0,
            0.4,
            0.5,
            WindLimit::Off,
        );
        let calm = fm10.spread(&SpreadInputs::upslope(0.0, 100.0)).head_ros_ftmin * FT_TO_M;
        assert_eq!(steep, calm);
    }

    /// The head-only kernel gives the grids the full ellipse gives, bit for bit, on the
    /// Worcester clip in every configuration that takes another path through the kernel: no
    /// wind, wind from several sides, the wind limit, `.lcp` slope, both crown methods and none,
    /// dry fuel (crown fire), FBFM13.
    #[test]
    fn the_head_only_kernel_gives_the_full_kernels_grids() {
        // `cargo test` sets the variable at run time; the compiled-in value may name another
        // clone that shared the target folder.
        let crate_dir =
            std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into());
        let dir =
            Path::new(&crate_dir).join("../firecast-landscape/tests/fixtures/landfire-worcester/landfire");
        let f40 = LandfireLandscape::read_dir(&dir, FuelLayer::Fbfm40).expect("Worcester FBFM40");
        let f13 = LandfireLandscape::read_dir(&dir, FuelLayer::Fbfm13).expect("Worcester FBFM13");
        let base: BehaviorParams = serde_json::from_value(serde_json::json!({
            "moisture": {"dead_1h": 6, "dead_10h": 8, "dead_100h": 10, "live_herbaceous": 75, "live_woody": 60},
            "foliar_moisture_pct": 120
        }))
        .expect("valid");
        let dry = MoisturePercent::parse("3,4,5,30,60").expect("five");
        let with = |f: &dyn Fn(&mut BehaviorParams)| {
            let mut p = base.clone();
            f(&mut p);
            p
        };
        let configs = [
            base.clone(),
            with(&|p| (p.wind_20ft_mph, p.wind_from_deg) = (15.0, 225.0)),
            with(&|p| (p.wind_20ft_mph, p.wind_from_deg) = (8.0, 0.0)),
            with(&|p| (p.wind_20ft_mph, p.crown) = (12.0, CrownMethod::ScottReinhardt)),
            with(&|p| (p.wind_20ft_mph, p.slope, p.wind_limit) = (25.0, SlopeMode::LcpWholeDegrees, true)),
            with(&|p| (p.moisture, p.wind_20ft_mph, p.wind_from_deg) = (dry, 25.0, 200.0)),
            with(&|p| {
                (p.moisture, p.wind_20ft_mph, p.crown, p.wind_limit) =
                    (dry, 40.0, CrownMethod::ScottReinhardt, true)
            }),
            with(&|p| (p.moisture, p.wind_20ft_mph, p.crown) = (dry, 20.0, CrownMethod::None)),
        ];
        let bits = |g: &BehaviorGrids| -> Vec<u32> {
            [
                &g.ros_chph,
                &g.flame_length_ft,
                &g.fireline_intensity_btu_ft_s,
                &g.max_spread_dir_deg,
                &g.fire_type,
                &g.midflame_wind_mph,
            ]
            .iter()
            .flat_map(|v| v.iter().map(|x| x.to_bits()))
            .collect()
        };
        let full = |bed: &SurfaceFuelBed, inputs: &SpreadInputs, limit: WindLimit| {
            SurfaceFireHead::from(&bed.spread_with_limit(inputs, limit))
        };
        let mut crown_cells = 0;
        for (k, params) in configs.iter().enumerate() {
            for (land, name) in [(&f40, "fbfm40"), (&f13, "fbfm13")] {
                if name == "fbfm13" && k % 3 != 0 {
                    continue;
                }
                let head = surface_behavior_grids(land, params).expect("grids");
                let ellipse = behavior_grids_with(land, params, full, false).expect("grids");
                assert!(bits(&head) == bits(&ellipse), "config {k} on {name}: {params:?}");
                crown_cells += head.fire_type.iter().filter(|&&t| t >= 2.0).count();
            }
        }
        assert!(
            crown_cells > 1000,
            "{crown_cells} crown cells: the crown paths ran"
        );
    }

    #[test]
    fn params_are_strict_and_checked() {
        let ok: BehaviorParams = serde_json::from_value(serde_json::json!({
            "moisture": {"dead_1h": 6, "dead_10h": 8, "dead_100h": 10, "live_herbaceous": 75, "live_woody": 60}
        }))
        .expect("valid");
        assert!(ok.validate().is_ok());
        assert_eq!(ok.fuel, FuelChoice::Fbfm40);
        assert_eq!((ok.crown, ok.foliar_moisture_pct), (CrownMethod::Finney, 100.0));
        let mut dry = ok.clone();
        dry.foliar_moisture_pct = 20.0;
        assert_eq!(dry.validate().expect_err("FMC").field, "foliar_moisture_pct");
        let crown = serde_json::from_value::<BehaviorParams>(serde_json::json!({
            "moisture": {"dead_1h": 6, "dead_10h": 8, "dead_100h": 10, "live_herbaceous": 75, "live_woody": 60},
            "crown": "scott-reinhardt"
        }))
        .expect("crown method");
        assert_eq!(crown.crown, CrownMethod::ScottReinhardt);
        let unknown = serde_json::from_value::<BehaviorParams>(serde_json::json!({
            "moisture": {"dead_1h": 6, "dead_10h": 8, "dead_100h": 10, "live_herbaceous": 75, "live_woody": 60},
            "wind": 3
        }));
        assert!(unknown.is_err());
        let mut bad = ok.clone();
        bad.wind_20ft_mph = -1.0;
        assert_eq!(bad.validate().expect_err("negative").field, "wind_20ft_mph");
        bad = ok;
        bad.moisture.live_woody = 10.0;
        assert_eq!(bad.validate().expect_err("dry live").field, "moisture.live_woody");
        assert!(MoisturePercent::parse("6,8,10,75").is_err());
        assert_eq!(
            MoisturePercent::parse("6, 8,10,75,60").expect("five").live_woody,
            60.0
        );
    }
}
