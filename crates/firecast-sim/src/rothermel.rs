//! Rothermel (1972) / Albini (1976) surface-fire spread, exactly as the USFS `behave` engine
//! (BehavePlus 6 / Behave 7) implements it: all size classes, Albini size-class weighting,
//! dynamic herbaceous curing, live moisture of extinction, and behave's vector combination of
//! wind and slope.
//!
//! Units are the customary US units the model was fitted in (lb, ft, min, Btu); conversion
//! happens only at the boundaries, and every field name carries its unit.
//!
//! behave details reproduced on purpose (each pinned by an oracle row or unit test):
//! the wind limit is off by default ([`WindLimit`]); dynamic curing uses 1.333 − 1.11·M_herb;
//! the length-to-width ratio uses the mi/h Anderson (1983) coefficients and is capped at 8.
//!
//! Two behave behaviours are **not in docs/spec/fire-model.md Part B** but are in behave's
//! `surfaceFire.cpp` at the oracle commit (d963287f60), run whatever the wind-limit setting, and
//! are required by the random oracle:
//! - `calculateWindSpeedLimit` caps the slope factor φ_s at 0.9·I_R (a dimensionless factor
//!   against a speed in ft/min). This is not the (disabled) effective-wind limit. Without it
//!   cases 184 and 699 are 171 % and 13.6 % off on ROS.
//! - `calculateDirectionOfMaxSpread` snaps an azimuth in [0°, 0.5°) to 0 ("undocumented hack
//!   from BehavePlus code"). It is one-sided: cases 12, 180, 186, 534 and 626 (0.09–0.44°) print
//!   0, while cases 216, 404, 738 and 797 (359.5–360°) are left alone.
//!
//! The computation is split for the cellular automaton's hot path:
//! [`SurfaceFuelBed::new`] does everything that depends only on fuel and moisture (once per
//! fuel model × moisture regime), and [`SurfaceFuelBed::spread`] does the cheap wind/slope
//! part (a handful of `powf`/`exp` calls, no allocation).

use crate::fuel::FuelModel;

/// Oven-dry particle density ρ_p, lb/ft³ (same for every standard particle).
const PARTICLE_DENSITY_LB_FT3: f64 = 32.0;
/// Total mineral content S_T, fraction.
const TOTAL_MINERAL_CONTENT: f64 = 0.0555;
/// Effective (silica-free) mineral content S_e, fraction.
const EFFECTIVE_MINERAL_CONTENT: f64 = 0.010;
/// Residence-time constant (Anderson 1969): t_r = 384/σ minutes.
const RESIDENCE_TIME_NUMERATOR: f64 = 384.0;
/// ft/min per mi/h.
pub const FT_PER_MIN_PER_MPH: f64 = 88.0;
/// ft/min per chain/h (1 ch = 66 ft).
pub const FT_PER_MIN_PER_CH_PER_H: f64 = 1.1;
/// behave caps the length-to-width ratio here.
const MAX_LENGTH_TO_WIDTH_RATIO: f64 = 8.0;
/// Below this effective wind (mi/h) behave treats the fire as circular.
const CALM_EFFECTIVE_WIND_MPH: f64 = 1.0e-7;

/// Fuel moisture content by size class, as fractions of oven-dry weight (0.06 = 6 %).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FuelMoisture {
    /// 1-h dead fuel moisture, fraction.
    pub dead_1h_frac: f64,
    /// 10-h dead fuel moisture, fraction.
    pub dead_10h_frac: f64,
    /// 100-h dead fuel moisture, fraction.
    pub dead_100h_frac: f64,
    /// Live herbaceous moisture, fraction (also drives dynamic curing).
    pub live_herb_frac: f64,
    /// Live woody moisture, fraction.
    pub live_woody_frac: f64,
}

impl FuelMoisture {
    /// Builds moistures from percentages, the unit field data and the oracle files use.
    pub fn from_percent(
        dead_1h_pct: f64,
        dead_10h_pct: f64,
        dead_100h_pct: f64,
        live_herb_pct: f64,
        live_woody_pct: f64,
    ) -> Self {
        Self {
            dead_1h_frac: dead_1h_pct / 100.0,
            dead_10h_frac: dead_10h_pct / 100.0,
            dead_100h_frac: dead_100h_pct / 100.0,
            live_herb_frac: live_herb_pct / 100.0,
            live_woody_frac: live_woody_pct / 100.0,
        }
    }

    /// The five classes with their names, for validation messages.
    fn named(&self) -> [(&'static str, f64); 5] {
        [
            ("dead_1h_frac", self.dead_1h_frac),
            ("dead_10h_frac", self.dead_10h_frac),
            ("dead_100h_frac", self.dead_100h_frac),
            ("live_herb_frac", self.live_herb_frac),
            ("live_woody_frac", self.live_woody_frac),
        ]
    }
}

/// Optional cap on the effective wind speed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum WindLimit {
    /// No cap: behave's default (`isWindLimitEnabled_ = false`), and what the oracles use.
    #[default]
    Off,
    /// Rothermel's (1972) limit U_E ≤ 0.9·I_R (ft/min), as behave applies it when enabled.
    /// Andrews, Cruz & Rothermel (2013) argue it is too restrictive; it is opt-in for that reason.
    Rothermel,
}

/// Wind and terrain for one spread evaluation.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpreadInputs {
    /// Midflame wind speed, mi/h (no wind adjustment factor is applied here). Must be ≥ 0.
    pub midflame_wind_mph: f64,
    /// Terrain slope, percent (100·tan θ). Must be ≥ 0.
    pub slope_percent: f64,
    /// Direction the wind blows *toward*, degrees clockwise from upslope (0 = upslope).
    pub wind_dir_from_upslope_deg: f64,
}

impl SpreadInputs {
    /// Validated constructor: speeds and slope must be finite and non-negative, the direction
    /// finite. [`SurfaceFuelBed::spread`] itself does not re-check (hot path).
    pub fn new(
        midflame_wind_mph: f64,
        slope_percent: f64,
        wind_dir_from_upslope_deg: f64,
    ) -> Result<Self, RothermelError> {
        let checks = [
            ("midflame_wind_mph", midflame_wind_mph, true),
            ("slope_percent", slope_percent, true),
            ("wind_dir_from_upslope_deg", wind_dir_from_upslope_deg, false),
        ];
        for (name, value, non_negative) in checks {
            if !value.is_finite() || (non_negative && value < 0.0) {
                return Err(RothermelError::InvalidInput { name, value });
            }
        }
        Ok(Self {
            midflame_wind_mph,
            slope_percent,
            wind_dir_from_upslope_deg,
        })
    }

    /// Wind blowing straight upslope (the alignment of all fixed-scenario oracles).
    pub fn upslope(midflame_wind_mph: f64, slope_percent: f64) -> Self {
        Self {
            midflame_wind_mph,
            slope_percent,
            wind_dir_from_upslope_deg: 0.0,
        }
    }
}

/// Invalid input to the Rothermel kernel.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RothermelError {
    /// A moisture that is negative or not a finite number.
    #[error("fuel moisture {class} = {value} must be a finite, non-negative fraction")]
    InvalidMoisture {
        /// Which size class.
        class: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A fuel-model parameter outside its physical domain.
    #[error("fuel model {code}: {parameter} = {value} is not physically valid")]
    InvalidFuelModel {
        /// Fuel-model code.
        code: &'static str,
        /// Which parameter.
        parameter: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A wind/slope input that is negative or not finite.
    #[error("spread input {name} = {value} must be finite (and non-negative for speeds/slopes)")]
    InvalidInput {
        /// Which input.
        name: &'static str,
        /// The offending value.
        value: f64,
    },
}

/// One fuel particle class after curing transfer.
#[derive(Debug, Clone, Copy, Default)]
struct Particle {
    load_lb_ft2: f64,
    sav_per_ft: f64,
    moisture_frac: f64,
    heat_btu_lb: f64,
}

impl Particle {
    fn surface_area(&self) -> f64 {
        self.load_lb_ft2 * self.sav_per_ft / PARTICLE_DENSITY_LB_FT3
    }

    /// Effective heating number ε = exp(−138/σ); 0 for a degenerate SAV.
    fn heating_number(&self) -> f64 {
        if self.sav_per_ft > 0.0 {
            (-138.0 / self.sav_per_ft).exp()
        } else {
            0.0
        }
    }
}

/// Albini's (1976) SAV bins for the size-sorted net-load weights g_ik, ft⁻¹ lower bounds.
/// Particles below the last bound get a bin of their own.
fn size_bin(sav_per_ft: f64) -> usize {
    const BOUNDS: [f64; 5] = [1200.0, 192.0, 96.0, 48.0, 16.0];
    BOUNDS
        .iter()
        .position(|&b| sav_per_ft >= b)
        .unwrap_or(BOUNDS.len())
}

/// Per-category (dead or live) aggregates of docs/spec/fire-model.md §B2/§B4.
#[derive(Debug, Clone, Copy, Default)]
struct Category {
    surface_area: f64,
    sav_per_ft: f64,
    net_load_lb_ft2: f64,
    moisture_frac: f64,
    heat_btu_lb: f64,
    /// Σ_k f_ik·ε_k·Q_ig,k.
    heat_sink_per_density: f64,
}

impl Category {
    fn from_particles(particles: &[Particle]) -> Self {
        let surface_area: f64 = particles.iter().map(Particle::surface_area).sum();
        if surface_area <= 0.0 {
            return Self::default();
        }
        // Size-sorted weights: sum of area fractions of particles in the same SAV bin.
        let mut bin_fraction = [0.0_f64; 6];
        for p in particles {
            bin_fraction[size_bin(p.sav_per_ft)] += p.surface_area() / surface_area;
        }
        let mut cat = Self {
            surface_area,
            ..Self::default()
        };
        for p in particles {
            let f = p.surface_area() / surface_area;
            cat.sav_per_ft += f * p.sav_per_ft;
            cat.moisture_frac += f * p.moisture_frac;
            cat.heat_btu_lb += f * p.heat_btu_lb;
            cat.heat_sink_per_density += f * p.heating_number() * (250.0 + 1116.0 * p.moisture_frac);
            cat.net_load_lb_ft2 +=
                bin_fraction[size_bin(p.sav_per_ft)] * p.load_lb_ft2 * (1.0 - TOTAL_MINERAL_CONTENT);
        }
        cat
    }
}

/// Rothermel's moisture damping polynomial; exactly 0 at and beyond extinction.
fn moisture_damping(moisture_frac: f64, extinction_frac: f64) -> f64 {
    if extinction_frac <= 0.0 {
        return 0.0;
    }
    let r = moisture_frac / extinction_frac;
    if r >= 1.0 {
        0.0
    } else {
        1.0 - 2.59 * r + 5.11 * r * r - 3.52 * r * r * r
    }
}

/// Length-to-width ratio of the spread ellipse, Anderson (1983) with behave's mi/h
/// coefficients (0.1147/0.0692; the 0.2566/0.1548 pair would need m/s), capped at 8.
pub fn length_to_width_ratio(effective_wind_mph: f64) -> f64 {
    if effective_wind_mph > CALM_EFFECTIVE_WIND_MPH {
        let u = effective_wind_mph;
        let lw = 0.936 * (0.1147 * u).exp() + 0.461 * (-0.0692 * u).exp() - 0.397;
        lw.min(MAX_LENGTH_TO_WIDTH_RATIO)
    } else {
        1.0
    }
}

/// The wind- and slope-independent intermediates of a prepared fuel bed (behave's
/// `SurfaceFuelbedIntermediates` plus R₀), for diagnostics and for localising mismatches.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct FuelBedIntermediates {
    /// Characteristic SAV σ of the whole bed, ft⁻¹ (0 for a non-burnable bed).
    pub characteristic_sav_per_ft: f64,
    /// Packing ratio β.
    pub packing_ratio: f64,
    /// Relative packing ratio β/β_op.
    pub relative_packing_ratio: f64,
    /// Bulk density ρ_b, lb/ft³.
    pub bulk_density_lb_ft3: f64,
    /// Heat sink ρ_b·Σ f_i Σ f_ik ε_ik Q_ig,ik, Btu/ft³.
    pub heat_sink_btu_ft3: f64,
    /// Propagating flux ratio ξ.
    pub propagating_flux_ratio: f64,
    /// Dead moisture of extinction, fraction.
    pub dead_mx_frac: f64,
    /// Live moisture of extinction (Albini 1976), fraction; 0 when the bed has no live fuel.
    pub live_mx_frac: f64,
    /// Reaction intensity I_R, Btu/ft²/min.
    pub reaction_intensity_btu_ft2_min: f64,
    /// Flame residence time 384/σ, min (0 for a non-burnable bed).
    pub residence_time_min: f64,
    /// No-wind, no-slope spread rate R₀, ft/min.
    pub no_wind_no_slope_ros_ftmin: f64,
}

/// A fuel bed prepared for a given fuel model and moisture: every quantity that does not
/// depend on wind or slope, including the no-wind, no-slope spread rate R₀.
///
/// Build once per (fuel model, moisture) and call [`spread`](Self::spread) per cell/neighbour.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SurfaceFuelBed {
    intermediates: FuelBedIntermediates,
    /// Wind-factor exponent B (φ_w = C·U^B·(β/β_op)^−E).
    wind_exponent_b: f64,
    /// C·(β/β_op)^−E, so that φ_w = wind_coefficient·U[ft/min]^B.
    wind_coefficient: f64,
    /// 5.275·β^−0.3, so that φ_s = slope_coefficient·tan²θ.
    slope_coefficient: f64,
}

/// Everything behave reports for one surface-fire evaluation. Rates in ft/min, directions in
/// degrees clockwise from upslope.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SurfaceFireBehavior {
    /// No-wind, no-slope rate R₀, ft/min.
    pub no_wind_no_slope_ros_ftmin: f64,
    /// Head-fire (maximum) rate of spread, ft/min.
    pub head_ros_ftmin: f64,
    /// Backing rate (opposite the head), ft/min.
    pub backing_ros_ftmin: f64,
    /// Flanking rate, ft/min.
    pub flanking_ros_ftmin: f64,
    /// Direction of maximum spread, degrees clockwise from upslope, in [0, 360).
    pub dir_max_spread_from_upslope_deg: f64,
    /// Wind factor φ_w.
    pub wind_factor: f64,
    /// Slope factor φ_s as used, i.e. after behave's cap at 0.9·I_R.
    pub slope_factor: f64,
    /// Effective wind speed U_E, ft/min (after the wind limit, if enabled).
    pub effective_wind_ftmin: f64,
    /// Whether the wind limit was enabled and capped U_E.
    pub wind_limit_applied: bool,
    /// Length-to-width ratio of the spread ellipse (≥ 1).
    pub length_to_width_ratio: f64,
    /// Eccentricity of the spread ellipse, in [0, 1).
    pub eccentricity: f64,
    /// Reaction intensity I_R, Btu/ft²/min.
    pub reaction_intensity_btu_ft2_min: f64,
    /// Heat per unit area H_A = I_R·t_r, Btu/ft².
    pub heat_per_unit_area_btu_ft2: f64,
    /// Byram fireline intensity at the head, Btu/ft/s.
    pub fireline_intensity_btu_ft_s: f64,
    /// Byram flame length at the head, ft.
    pub flame_length_ft: f64,
}

impl SurfaceFireBehavior {
    /// Head rate in chains per hour.
    pub fn head_ros_chph(&self) -> f64 {
        self.head_ros_ftmin / FT_PER_MIN_PER_CH_PER_H
    }

    /// Effective wind speed in mi/h.
    pub fn effective_wind_mph(&self) -> f64 {
        self.effective_wind_ftmin / FT_PER_MIN_PER_MPH
    }

    /// Rate of spread of the elliptical front at angle ψ (degrees) from the head direction,
    /// measured at the ignition point: R·(1 − e)/(1 − e·cos ψ).
    pub fn ros_from_head_ftmin(&self, psi_deg: f64) -> f64 {
        let e = self.eccentricity;
        self.head_ros_ftmin * (1.0 - e) / (1.0 - e * psi_deg.to_radians().cos())
    }

    /// Rate of spread toward a direction given in degrees clockwise from upslope.
    pub fn ros_toward_ftmin(&self, dir_from_upslope_deg: f64) -> f64 {
        self.ros_from_head_ftmin(dir_from_upslope_deg - self.dir_max_spread_from_upslope_deg)
    }

    /// The behaviour of a bed that cannot burn: all rates and energies zero, circular shape.
    fn no_fire(bed: &SurfaceFuelBed) -> Self {
        Self {
            no_wind_no_slope_ros_ftmin: 0.0,
            head_ros_ftmin: 0.0,
            backing_ros_ftmin: 0.0,
            flanking_ros_ftmin: 0.0,
            dir_max_spread_from_upslope_deg: 0.0,
            wind_factor: 0.0,
            slope_factor: 0.0,
            effective_wind_ftmin: 0.0,
            wind_limit_applied: false,
            length_to_width_ratio: 1.0,
            eccentricity: 0.0,
            // R₀ = 0 only happens when I_R = 0 (non-burnable or past extinction).
            reaction_intensity_btu_ft2_min: bed.reaction_intensity_btu_ft2_min(),
            heat_per_unit_area_btu_ft2: bed.heat_per_unit_area_btu_ft2(),
            fireline_intensity_btu_ft_s: 0.0,
            flame_length_ft: 0.0,
        }
    }
}

impl SurfaceFuelBed {
    /// Prepares the fuel bed: dynamic curing, Albini weighting, reaction intensity, heat sink
    /// and R₀. Errors on negative or non-finite moisture and on invalid fuel parameters;
    /// a non-burnable model (or one past extinction) yields a bed with R₀ = 0.
    pub fn new(model: &FuelModel, moisture: &FuelMoisture) -> Result<Self, RothermelError> {
        for (class, value) in moisture.named() {
            if !value.is_finite() || value < 0.0 {
                return Err(RothermelError::InvalidMoisture { class, value });
            }
        }
        validate_model(model)?;
        if !model.burnable {
            return Ok(Self::non_burnable(model));
        }

        // Dynamic curing (docs/spec/fire-model.md §B7): part of the herbaceous load moves to a dead
        // class that keeps the herbaceous SAV and takes the 1-h moisture. 1.333 − 1.11·M is
        // behave's BehavePlus-consistent form.
        let herb = model.load_live_herb_lb_ft2;
        let cured_fraction = if model.dynamic && herb > 0.0 {
            let m = moisture.live_herb_frac;
            if m < 0.30 {
                1.0
            } else if m <= 1.20 {
                1.333 - 1.11 * m
            } else {
                0.0
            }
        } else {
            0.0
        };
        let dead_herb_load = herb * cured_fraction;
        let live_herb_load = herb - dead_herb_load;

        let dead_particle = |load_lb_ft2: f64, sav_per_ft: f64, moisture_frac: f64| Particle {
            load_lb_ft2,
            sav_per_ft,
            moisture_frac,
            heat_btu_lb: model.heat_dead_btu_lb,
        };
        let live_particle = |load_lb_ft2: f64, sav_per_ft: f64, moisture_frac: f64| Particle {
            load_lb_ft2,
            sav_per_ft,
            moisture_frac,
            heat_btu_lb: model.heat_live_btu_lb,
        };
        let dead = [
            dead_particle(model.load_1h_lb_ft2, model.sav_1h_per_ft, moisture.dead_1h_frac),
            dead_particle(
                model.load_10h_lb_ft2,
                model.sav_10h_per_ft,
                moisture.dead_10h_frac,
            ),
            dead_particle(
                model.load_100h_lb_ft2,
                model.sav_100h_per_ft,
                moisture.dead_100h_frac,
            ),
            dead_particle(dead_herb_load, model.sav_live_herb_per_ft, moisture.dead_1h_frac),
        ];
        let live = [
            live_particle(
                live_herb_load,
                model.sav_live_herb_per_ft,
                moisture.live_herb_frac,
            ),
            live_particle(
                model.load_live_woody_lb_ft2,
                model.sav_live_woody_per_ft,
                moisture.live_woody_frac,
            ),
        ];
        Ok(Self::from_particles(model, &dead, &live))
    }

    /// A bed for a non-burnable code: nothing burns, nothing spreads.
    fn non_burnable(model: &FuelModel) -> Self {
        Self {
            intermediates: FuelBedIntermediates {
                dead_mx_frac: model.mx_dead_frac,
                ..FuelBedIntermediates::default()
            },
            wind_exponent_b: 1.0,
            wind_coefficient: 0.0,
            slope_coefficient: 0.0,
        }
    }

    fn from_particles(model: &FuelModel, dead: &[Particle; 4], live: &[Particle; 2]) -> Self {
        let dead_cat = Category::from_particles(dead);
        let live_cat = Category::from_particles(live);
        let total_area = dead_cat.surface_area + live_cat.surface_area;
        let total_load: f64 = dead.iter().chain(live).map(|p| p.load_lb_ft2).sum();
        if total_area <= 0.0 || total_load <= 0.0 {
            return Self::non_burnable(model);
        }
        let f_dead = dead_cat.surface_area / total_area;
        let f_live = live_cat.surface_area / total_area;

        let sigma = f_dead * dead_cat.sav_per_ft + f_live * live_cat.sav_per_ft;
        let bulk_density = total_load / model.depth_ft;
        let beta = bulk_density / PARTICLE_DENSITY_LB_FT3;
        let beta_op = 3.348 * sigma.powf(-0.8189);
        let ratio = beta / beta_op;

        // Live moisture of extinction (Albini 1976), from the fine dead/live load ratio.
        let live_mx = live_moisture_of_extinction(model.mx_dead_frac, dead, live);

        // Optimum reaction velocity Γ' with A = 133·σ^−0.7913 (behave/BehavePlus/FARSITE form).
        let sigma_15 = sigma.powf(1.5);
        let gamma_max = sigma_15 / (495.0 + 0.0594 * sigma_15);
        let a = 133.0 * sigma.powf(-0.7913);
        let gamma = gamma_max * ratio.powf(a) * (a * (1.0 - ratio)).exp();

        let mineral_damping = (0.174 * EFFECTIVE_MINERAL_CONTENT.powf(-0.19)).min(1.0);
        let dead_term = dead_cat.net_load_lb_ft2
            * dead_cat.heat_btu_lb
            * moisture_damping(dead_cat.moisture_frac, model.mx_dead_frac);
        let live_term = if live_cat.surface_area > 0.0 {
            live_cat.net_load_lb_ft2
                * live_cat.heat_btu_lb
                * moisture_damping(live_cat.moisture_frac, live_mx)
        } else {
            0.0
        };
        let reaction_intensity = gamma * (dead_term + live_term) * mineral_damping;

        let xi = ((0.792 + 0.681 * sigma.sqrt()) * (beta + 0.1)).exp() / (192.0 + 0.2595 * sigma);
        let heat_sink = bulk_density
            * (f_dead * dead_cat.heat_sink_per_density + f_live * live_cat.heat_sink_per_density);
        let r0 = if reaction_intensity > 0.0 && heat_sink > 0.0 {
            reaction_intensity * xi / heat_sink
        } else {
            0.0
        };

        let c = 7.47 * (-0.133 * sigma.powf(0.55)).exp();
        let b = 0.02526 * sigma.powf(0.54);
        let e = 0.715 * (-3.59e-4 * sigma).exp();

        Self {
            intermediates: FuelBedIntermediates {
                characteristic_sav_per_ft: sigma,
                packing_ratio: beta,
                relative_packing_ratio: ratio,
                bulk_density_lb_ft3: bulk_density,
                heat_sink_btu_ft3: heat_sink,
                propagating_flux_ratio: xi,
                dead_mx_frac: model.mx_dead_frac,
                live_mx_frac: live_mx,
                reaction_intensity_btu_ft2_min: reaction_intensity,
                residence_time_min: RESIDENCE_TIME_NUMERATOR / sigma,
                no_wind_no_slope_ros_ftmin: r0,
            },
            wind_exponent_b: b,
            wind_coefficient: c * ratio.powf(-e),
            slope_coefficient: 5.275 * beta.powf(-0.3),
        }
    }

    /// The wind- and slope-independent intermediates.
    pub fn intermediates(&self) -> &FuelBedIntermediates {
        &self.intermediates
    }

    /// No-wind, no-slope spread rate R₀, ft/min (0 when the bed cannot burn).
    pub fn no_wind_no_slope_ros_ftmin(&self) -> f64 {
        self.intermediates.no_wind_no_slope_ros_ftmin
    }

    /// Reaction intensity I_R, Btu/ft²/min.
    pub fn reaction_intensity_btu_ft2_min(&self) -> f64 {
        self.intermediates.reaction_intensity_btu_ft2_min
    }

    /// Heat per unit area I_R·t_r, Btu/ft² (independent of wind and slope).
    pub fn heat_per_unit_area_btu_ft2(&self) -> f64 {
        self.intermediates.reaction_intensity_btu_ft2_min * self.intermediates.residence_time_min
    }

    /// Slope factor φ_s = 5.275·β^−0.3·tan²θ for a slope in percent (before behave's
    /// 0.9·I_R cap, which [`spread`](Self::spread) applies).
    pub fn slope_factor(&self, slope_percent: f64) -> f64 {
        let tan = slope_percent / 100.0;
        self.slope_coefficient * tan * tan
    }

    /// Wind factor φ_w = C·U^B·(β/β_op)^−E, with U the midflame wind in ft/min.
    pub fn wind_factor(&self, midflame_wind_ftmin: f64) -> f64 {
        if midflame_wind_ftmin > 0.0 {
            self.wind_coefficient * midflame_wind_ftmin.powf(self.wind_exponent_b)
        } else {
            0.0
        }
    }

    /// Spread with behave's defaults (wind limit off).
    pub fn spread(&self, inputs: &SpreadInputs) -> SurfaceFireBehavior {
        self.spread_with_limit(inputs, WindLimit::Off)
    }

    /// Head, backing and flanking spread, direction, shape and intensities for given wind and
    /// slope, combining them as vectors (behave's method) for any wind direction.
    pub fn spread_with_limit(&self, inputs: &SpreadInputs, limit: WindLimit) -> SurfaceFireBehavior {
        let r0 = self.no_wind_no_slope_ros_ftmin();
        if r0 <= 0.0 {
            return SurfaceFireBehavior::no_fire(self);
        }
        let v = self.head_vector(r0, inputs);
        let (head_ros, effective_wind, wind_limit_applied) = self.limit_head(r0, v.head_ros_ftmin, limit);

        let lw = length_to_width_ratio(effective_wind / FT_PER_MIN_PER_MPH);
        let eccentricity = (lw * lw - 1.0).sqrt() / lw;
        let backing = head_ros * (1.0 - eccentricity) / (1.0 + eccentricity);
        let flanking = 0.5 * (head_ros + backing) / lw;
        let (fireline_intensity, flame_length) = self.head_intensity(head_ros);

        SurfaceFireBehavior {
            no_wind_no_slope_ros_ftmin: r0,
            head_ros_ftmin: head_ros,
            backing_ros_ftmin: backing,
            flanking_ros_ftmin: flanking,
            dir_max_spread_from_upslope_deg: v.dir_deg,
            wind_factor: v.phi_w,
            slope_factor: v.phi_s,
            effective_wind_ftmin: effective_wind,
            wind_limit_applied,
            length_to_width_ratio: lw,
            eccentricity,
            reaction_intensity_btu_ft2_min: self.reaction_intensity_btu_ft2_min(),
            heat_per_unit_area_btu_ft2: self.heat_per_unit_area_btu_ft2(),
            fireline_intensity_btu_ft_s: fireline_intensity,
            flame_length_ft: flame_length,
        }
    }

    /// The head of the fire alone: [`spread_with_limit`](Self::spread_with_limit)'s head rate,
    /// direction of maximum spread, fireline intensity and flame length, the same bits, without
    /// the rest of the ellipse (the effective wind's power, unless the wind limit needs it; the
    /// length-to-width ratio's two exponentials; backing and flanking rates). What a fire
    /// behaviour grid writes.
    pub fn head_with_limit(&self, inputs: &SpreadInputs, limit: WindLimit) -> SurfaceFireHead {
        let r0 = self.no_wind_no_slope_ros_ftmin();
        if r0 <= 0.0 {
            return SurfaceFireHead {
                head_ros_ftmin: 0.0,
                dir_max_spread_from_upslope_deg: 0.0,
                fireline_intensity_btu_ft_s: 0.0,
                flame_length_ft: 0.0,
            };
        }
        let v = self.head_vector(r0, inputs);
        self.head_of(r0, &v, limit)
    }

    /// The wind factor φ_w of a midflame wind in mi/h, as [`head_with_limit`](Self::head_with_limit)
    /// computes it: the same bits, for callers that meet the same fuel bed and midflame wind in many
    /// cells and compute it once ([`head_with_wind_factor`](Self::head_with_wind_factor)).
    pub fn midflame_wind_factor(&self, midflame_wind_mph: f64) -> f64 {
        self.wind_factor(midflame_wind_mph * FT_PER_MIN_PER_MPH)
    }

    /// [`head_with_limit`](Self::head_with_limit) from terms computed once for many cells, the same
    /// bits: `wind_factor` is [`midflame_wind_factor`](Self::midflame_wind_factor) of the
    /// midflame wind, `wind_dir_sin_cos` the sine and cosine of
    /// `wind_dir_from_upslope_deg.to_radians()`.
    pub fn head_with_wind_factor(
        &self,
        wind_factor: f64,
        wind_dir_from_upslope_deg: f64,
        wind_dir_sin_cos: (f64, f64),
        slope_percent: f64,
        limit: WindLimit,
    ) -> SurfaceFireHead {
        let r0 = self.no_wind_no_slope_ros_ftmin();
        if r0 <= 0.0 {
            return SurfaceFireHead {
                head_ros_ftmin: 0.0,
                dir_max_spread_from_upslope_deg: 0.0,
                fireline_intensity_btu_ft_s: 0.0,
                flame_length_ft: 0.0,
            };
        }
        let v = self.head_vector_with(r0, wind_factor, slope_percent, wind_dir_from_upslope_deg, || {
            wind_dir_sin_cos
        });
        self.head_of(r0, &v, limit)
    }

    /// The head's fields from its vector (the wind limit applied as `limit` says).
    #[inline]
    fn head_of(&self, r0: f64, v: &HeadVector, limit: WindLimit) -> SurfaceFireHead {
        let head_ros = match limit {
            WindLimit::Off => v.head_ros_ftmin,
            WindLimit::Rothermel => self.limit_head(r0, v.head_ros_ftmin, limit).0,
        };
        let (fireline_intensity, flame_length) = self.head_intensity(head_ros);
        SurfaceFireHead {
            head_ros_ftmin: head_ros,
            dir_max_spread_from_upslope_deg: v.dir_deg,
            fireline_intensity_btu_ft_s: fireline_intensity,
            flame_length_ft: flame_length,
        }
    }

    /// Wind and slope factors, and the head rate and direction before any wind limit, for a
    /// bed with R₀ = `r0` > 0.
    #[inline]
    fn head_vector(&self, r0: f64, inputs: &SpreadInputs) -> HeadVector {
        let phi_w = self.wind_factor(inputs.midflame_wind_mph * FT_PER_MIN_PER_MPH);
        let dir = inputs.wind_dir_from_upslope_deg;
        self.head_vector_with(r0, phi_w, inputs.slope_percent, dir, || {
            dir.to_radians().sin_cos()
        })
    }

    /// [`head_vector`](Self::head_vector) from the wind factor, the slope, the wind's direction
    /// from upslope and (called only where the wind blows) its sine and cosine.
    #[inline]
    fn head_vector_with(
        &self,
        r0: f64,
        phi_w: f64,
        slope_percent: f64,
        wind_dir_from_upslope_deg: f64,
        sin_cos: impl FnOnce() -> (f64, f64),
    ) -> HeadVector {
        let phi_s = self.slope_factor(slope_percent);

        // behave's `calculateWindSpeedLimit` (surfaceFire.cpp), run whatever the wind-limit
        // setting: φ_s is capped at 0.9·I_R, a dimensionless factor against a speed in ft/min. Not
        // in docs/spec/fire-model.md Part B. It only bites on steep slopes with a weak reaction;
        // random-oracle cases 184 and 699 need it.
        let phi_s = phi_s.min(0.9 * self.reaction_intensity_btu_ft2_min());

        // Vector sum in a frame whose x axis points upslope, y axis 90° clockwise from it.
        let wind_rate = r0 * phi_w;
        if wind_rate == 0.0 && wind_dir_from_upslope_deg.is_finite() {
            // No wind: the sum below is x = r0·φ_s + (±0) = r0·φ_s ≥ 0 and y = ±0, so its length
            // is x (hypot(x, ±0) = |x|) and its azimuth atan2(±0, x) = ±0, which behave reports
            // as 0: the same bits without the sine, cosine, hypot and atan2.
            return HeadVector {
                phi_w,
                phi_s,
                head_ros_ftmin: r0 + r0 * phi_s,
                dir_deg: 0.0,
            };
        }
        let (sin_w, cos_w) = sin_cos();
        let x = r0 * phi_s + wind_rate * cos_w;
        let y = wind_rate * sin_w;
        let vector_rate = x.hypot(y);
        HeadVector {
            phi_w,
            phi_s,
            head_ros_ftmin: r0 + vector_rate,
            dir_deg: behave_azimuth_deg(y.atan2(x).to_degrees()),
        }
    }

    /// The effective wind (the wind speed that alone would give the head rate, ft/min) and, with
    /// Rothermel's limit, the head rate capped where it exceeds 0.9·I_R: (head rate, effective
    /// wind, whether the limit capped it).
    #[inline]
    fn limit_head(&self, r0: f64, head_ros: f64, limit: WindLimit) -> (f64, f64, bool) {
        let phi_e = head_ros / r0 - 1.0;
        let effective_wind = if phi_e > 0.0 {
            (phi_e / self.wind_coefficient).powf(1.0 / self.wind_exponent_b)
        } else {
            0.0
        };
        if limit == WindLimit::Rothermel {
            let max_wind = 0.9 * self.reaction_intensity_btu_ft2_min();
            if effective_wind > max_wind {
                return (r0 * (1.0 + self.wind_factor(max_wind)), max_wind, true);
            }
        }
        (head_ros, effective_wind, false)
    }

    /// Byram's fireline intensity (Btu/ft/s) and flame length (ft) at a head rate (ft/min).
    #[inline]
    fn head_intensity(&self, head_ros: f64) -> (f64, f64) {
        let fireline_intensity = self.heat_per_unit_area_btu_ft2() * head_ros / 60.0;
        let flame_length = if fireline_intensity > 0.0 {
            0.45 * fireline_intensity.powf(0.46)
        } else {
            0.0
        };
        (fireline_intensity, flame_length)
    }
}

/// [`SurfaceFuelBed::head_vector`]'s result.
struct HeadVector {
    phi_w: f64,
    phi_s: f64,
    head_ros_ftmin: f64,
    dir_deg: f64,
}

/// The head of a surface fire ([`SurfaceFuelBed::head_with_limit`]): the fields of
/// [`SurfaceFireBehavior`] a fire behaviour grid writes, equal to them bit for bit.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SurfaceFireHead {
    /// Head-fire (maximum) rate of spread, ft/min.
    pub head_ros_ftmin: f64,
    /// Direction of maximum spread, degrees clockwise from upslope, in [0, 360).
    pub dir_max_spread_from_upslope_deg: f64,
    /// Byram fireline intensity at the head, Btu/ft/s.
    pub fireline_intensity_btu_ft_s: f64,
    /// Byram flame length at the head, ft.
    pub flame_length_ft: f64,
}

impl SurfaceFireHead {
    /// Head rate in chains per hour.
    pub fn head_ros_chph(&self) -> f64 {
        self.head_ros_ftmin / FT_PER_MIN_PER_CH_PER_H
    }
}

impl From<&SurfaceFireBehavior> for SurfaceFireHead {
    fn from(fire: &SurfaceFireBehavior) -> Self {
        Self {
            head_ros_ftmin: fire.head_ros_ftmin,
            dir_max_spread_from_upslope_deg: fire.dir_max_spread_from_upslope_deg,
            fireline_intensity_btu_ft_s: fire.fireline_intensity_btu_ft_s,
            flame_length_ft: fire.flame_length_ft,
        }
    }
}

/// One-shot convenience: prepare the bed and spread (wind limit off).
pub fn surface_fire_behavior(
    model: &FuelModel,
    moisture: &FuelMoisture,
    inputs: &SpreadInputs,
) -> Result<SurfaceFireBehavior, RothermelError> {
    Ok(SurfaceFuelBed::new(model, moisture)?.spread(inputs))
}

/// Albini's (1976) live moisture of extinction, never below the dead one; 0 without live fuel.
fn live_moisture_of_extinction(dead_mx: f64, dead: &[Particle], live: &[Particle]) -> f64 {
    let live_fine: f64 = live
        .iter()
        .filter(|p| p.sav_per_ft > 0.0)
        .map(|p| p.load_lb_ft2 * (-500.0 / p.sav_per_ft).exp())
        .sum();
    if live_fine <= 0.0 {
        return 0.0;
    }
    let dead_fine: f64 = dead.iter().map(|p| p.load_lb_ft2 * p.heating_number()).sum();
    let dead_fine_moisture = if dead_fine > 0.0 {
        dead.iter()
            .map(|p| p.load_lb_ft2 * p.heating_number() * p.moisture_frac)
            .sum::<f64>()
            / dead_fine
    } else {
        0.0
    };
    let fine_dead_to_live = dead_fine / live_fine;
    let mx = 2.9 * fine_dead_to_live * (1.0 - dead_fine_moisture / dead_mx) - 0.226;
    mx.max(dead_mx)
}

fn validate_model(model: &FuelModel) -> Result<(), RothermelError> {
    let err = |parameter, value| RothermelError::InvalidFuelModel {
        code: model.code,
        parameter,
        value,
    };
    let loads = [
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
        ("heat_dead_btu_lb", model.heat_dead_btu_lb),
        ("heat_live_btu_lb", model.heat_live_btu_lb),
    ];
    for (name, value) in loads {
        if !value.is_finite() || value < 0.0 {
            return Err(err(name, value));
        }
    }
    let positives = [("depth_ft", model.depth_ft), ("mx_dead_frac", model.mx_dead_frac)];
    for (name, value) in positives {
        if model.burnable && (!value.is_finite() || value <= 0.0) {
            return Err(err(name, value));
        }
    }
    Ok(())
}

/// Direction of maximum spread as behave's `calculateDirectionOfMaxSpread` reports it: the atan2
/// result with 360° added when negative, then |azimuth| < 0.5° snapped to exactly 0 ("undocumented
/// hack from BehavePlus code"; not in docs/spec/fire-model.md Part B, pinned by random-oracle cases
/// 12, 180, 186, 534, 626). One extra step keeps the range [0, 360): for a tiny negative angle,
/// adding 360° rounds to exactly 360.0, which behave would report; this returns 0, the same
/// direction.
fn behave_azimuth_deg(atan2_deg: f64) -> f64 {
    let mut azimuth = atan2_deg;
    if azimuth < -1.0e-20 {
        azimuth += 360.0;
    }
    if azimuth.abs() < 0.5 || azimuth >= 360.0 {
        0.0
    } else {
        azimuth
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fm(number: u16) -> &'static FuelModel {
        FuelModel::by_number(number).expect("standard model")
    }

    #[test]
    fn fm1_intermediates_match_behave() {
        let bed = SurfaceFuelBed::new(fm(1), &FuelMoisture::from_percent(6.0, 7.0, 8.0, 60.0, 90.0))
            .expect("valid");
        assert!((bed.intermediates().characteristic_sav_per_ft - 3500.0).abs() < 1e-9);
        assert!((bed.intermediates().packing_ratio - 0.0010625).abs() < 1e-12);
        assert!((bed.intermediates().relative_packing_ratio - 0.253385).abs() < 1e-6);
        assert!((bed.intermediates().heat_sink_btu_ft3 - 10.36).abs() < 5e-6);
        assert!((bed.slope_factor(30.0) - 3.703107).abs() < 1e-6);
        assert_eq!(bed.intermediates().live_mx_frac, 0.0);
    }

    #[test]
    fn wind_limit_caps_only_when_enabled() {
        let bed = SurfaceFuelBed::new(fm(1), &FuelMoisture::from_percent(3.0, 4.0, 5.0, 30.0, 60.0))
            .expect("valid");
        let inputs = SpreadInputs::upslope(10.0, 0.0);
        let off = bed.spread(&inputs);
        let on = bed.spread_with_limit(&inputs, WindLimit::Rothermel);
        assert!((off.head_ros_chph() - 484.612537).abs() < 1e-5);
        assert!(!off.wind_limit_applied);
        assert!(on.wind_limit_applied);
        assert!(on.head_ros_ftmin < off.head_ros_ftmin);
        assert!((on.effective_wind_ftmin - 0.9 * bed.reaction_intensity_btu_ft2_min()).abs() < 1e-9);
    }

    #[test]
    fn slope_factor_is_capped_at_point_nine_reaction_intensity() {
        // Random-oracle case 184: GR1 near extinction on a 72.6 % slope, no wind.
        let moist = FuelMoisture::from_percent(14.7795, 14.9623, 16.6272, 142.5506, 190.6273);
        let bed = SurfaceFuelBed::new(fm(101), &moist).expect("valid");
        let fire = bed.spread(&SpreadInputs::upslope(0.0, 72.6133));
        let cap = 0.9 * bed.reaction_intensity_btu_ft2_min();
        assert!(bed.slope_factor(72.6133) > cap);
        assert_eq!(fire.slope_factor, cap);
        let r0 = bed.no_wind_no_slope_ros_ftmin();
        assert!((fire.head_ros_ftmin - r0 * (1.0 + cap)).abs() < 1e-15);
    }

    #[test]
    fn non_burnable_and_extinct_beds_do_not_spread() {
        let moist = FuelMoisture::from_percent(6.0, 7.0, 8.0, 60.0, 90.0);
        let nb = surface_fire_behavior(fm(91), &moist, &SpreadInputs::upslope(10.0, 50.0)).expect("valid");
        assert_eq!(nb.head_ros_ftmin, 0.0);
        assert_eq!(nb.length_to_width_ratio, 1.0);
        let wet = FuelMoisture::from_percent(12.0, 12.0, 12.0, 60.0, 90.0);
        let out = surface_fire_behavior(fm(1), &wet, &SpreadInputs::upslope(10.0, 50.0)).expect("valid");
        assert_eq!(out.head_ros_ftmin, 0.0);
        assert_eq!(out.reaction_intensity_btu_ft2_min, 0.0);
    }

    #[test]
    fn invalid_inputs_are_rejected() {
        let mut moist = FuelMoisture::from_percent(6.0, 7.0, 8.0, 60.0, 90.0);
        moist.live_woody_frac = -0.1;
        assert!(matches!(
            SurfaceFuelBed::new(fm(1), &moist),
            Err(RothermelError::InvalidMoisture {
                class: "live_woody_frac",
                ..
            })
        ));
        assert!(SpreadInputs::new(-1.0, 0.0, 0.0).is_err());
        assert!(SpreadInputs::new(1.0, f64::NAN, 0.0).is_err());
        assert!(SpreadInputs::new(1.0, 10.0, -45.0).is_ok());
    }

    #[test]
    fn length_to_width_uses_mph_coefficients() {
        assert!((length_to_width_ratio(5.0) - 1.590064).abs() < 1e-6);
        assert!((length_to_width_ratio(10.0) - 2.780978).abs() < 1e-6);
        assert_eq!(length_to_width_ratio(0.0), 1.0);
        assert_eq!(length_to_width_ratio(1000.0), 8.0);
    }

    #[test]
    fn azimuth_follows_behave() {
        assert_eq!(behave_azimuth_deg(-1e-30), 0.0);
        assert_eq!(behave_azimuth_deg(0.49), 0.0);
        assert_eq!(behave_azimuth_deg(0.51), 0.51);
        assert!((behave_azimuth_deg(-90.0) - 270.0).abs() < 1e-12);
        // Just below 0 maps just below 360: the snap is one-sided, as in behave.
        assert!(behave_azimuth_deg(-0.3) > 359.0);
    }

    /// The head-only path gives the full path's head, direction, intensity and flame length
    /// bit for bit: every standard model, wet and dry, calm and windy from every side, flat
    /// and steep, with and without the wind limit.
    #[test]
    fn the_head_alone_is_the_full_ellipses_head_bit_for_bit() {
        let moistures = [
            FuelMoisture::from_percent(6.0, 8.0, 10.0, 75.0, 60.0),
            FuelMoisture::from_percent(3.0, 4.0, 5.0, 30.0, 60.0),
            FuelMoisture::from_percent(25.0, 25.0, 25.0, 200.0, 200.0),
        ];
        let mut compared = 0;
        for model in FuelModel::standard() {
            for moisture in &moistures {
                let bed = SurfaceFuelBed::new(model, moisture).expect("bed");
                for wind in [0.0, 0.5, 3.0, 12.0, 40.0] {
                    for slope in [0.0, 7.0, 35.0, 120.0] {
                        for dir in [0.0, 45.0, 90.0, 179.9, 180.0, 271.0, -30.0, 359.99] {
                            for limit in [WindLimit::Off, WindLimit::Rothermel] {
                                let inputs = SpreadInputs {
                                    midflame_wind_mph: wind,
                                    slope_percent: slope,
                                    wind_dir_from_upslope_deg: dir,
                                };
                                let full = bed.spread_with_limit(&inputs, limit);
                                let head = bed.head_with_limit(&inputs, limit);
                                let bits = |h: &SurfaceFireHead| {
                                    [
                                        h.head_ros_ftmin.to_bits(),
                                        h.dir_max_spread_from_upslope_deg.to_bits(),
                                        h.fireline_intensity_btu_ft_s.to_bits(),
                                        h.flame_length_ft.to_bits(),
                                    ]
                                };
                                assert_eq!(
                                    bits(&head),
                                    bits(&SurfaceFireHead::from(&full)),
                                    "{} {inputs:?} {limit:?}",
                                    model.code
                                );
                                compared += 1;
                            }
                        }
                    }
                }
            }
        }
        assert!(compared > 40_000, "{compared}");
    }
}
