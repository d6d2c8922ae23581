//! The synthetic ignition model and its WFIGS-style CSV export.
//!
//! For every land cell-day of the written years, the generator draws `N ~ Poisson(λ)` with
//! `λ = s·(λ_h + λ_l + λ_rx)` (`s` = [`super::SynthConfig::ignition_rate_scale`]; the rates are
//! computed in `weather::ignition_rates`):
//!
//! * human wildfires `λ_h = B_h·H/(1 + H/3)·m_day·exp(η_h)`, `H` the seeded human-activity
//!   field, `m_day` the spring/autumn, weekend and 4–5 July multipliers, and
//!   `η_h = 0.35·x₁ + 0.15·x₂ + 0.2·x₃ + 0.2·x₄ + 0.1·x₅ + 0.1·x₆ − 0.8·ln(1+pr) − 2.5·cold`;
//! * lightning wildfires `λ_l = B_l·L·ramp((Tx−22)/12)·ramp(ea/1.2)·r·exp(1.2·aC − 0.72 +
//!   0.5·x₁ + 0.3·x₂ + 0.3·x₃ − 2.5·cold − max(0, (pr − 5)/4))`, `L` the terrain/monsoon/Florida
//!   propensity, `aC` the convective anomaly, `r` 0.45 without rain and 1 with it;
//! * prescribed fires `λ_rx = B_rx·R·m_rx·exp(−((fm100−14)/5)² − 0.5·max(0, vs−5))` on days
//!   with pr < 1 mm;
//!
//! with `x₁ = (12 − fm100)/4`, `x₂ = (15 − fm1000)/5`, `x₃ = (erc − 40)/25`,
//! `x₄ = (vs − 3.5)/2.5`, `x₅ = (vpd − 1.5)/1.2`, `x₆ = (30 − rmin)/15` and
//! `cold = ramp((3 − Tx[°C])/10)`. Each ignition gets a cause by the three rates' proportions,
//! a point uniformly inside the cell, a discovery time within the GRIDMET day (07:00 UTC to
//! 07:00 UTC the next day) with a mid-afternoon local peak, and a heavy-tailed size
//! `0.1·U^(−1/α)` acres whose tail grows with ERC and wind. A fraction of wildfires is reported
//! twice (a second IRWIN record from another unit 3 to 110 minutes later and 80–700 m away).

use std::cmp::Ordering;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::SynthError;
use super::files::temp_path;
use super::grid::{GRID_STEP, gacc_of, grid_lat, grid_lon, state_of};
use super::noise::{Stream, hash_with, key, mix64};
use super::weather::{Candidate, gid_to_ji};
use firecast_data::gridmet::day_to_ymd;

/// The header of a real 2023 WFIGS "Incident Locations to Date" CSV export (docs/spec/data.md §1.2).
pub const WFIGS_HEADER: [&str; 97] = [
    "X",
    "Y",
    "OBJECTID",
    "SourceOID",
    "ABCDMisc",
    "ADSPermissionState",
    "ContainmentDateTime",
    "ControlDateTime",
    "CreatedBySystem",
    "IncidentSize",
    "DiscoveryAcres",
    "DispatchCenterID",
    "EstimatedCostToDate",
    "FinalAcres",
    "FinalFireReportApprovedByTitle",
    "FinalFireReportApprovedByUnit",
    "FinalFireReportApprovedDate",
    "FireBehaviorGeneral",
    "FireBehaviorGeneral1",
    "FireBehaviorGeneral2",
    "FireBehaviorGeneral3",
    "FireCause",
    "FireCauseGeneral",
    "FireCauseSpecific",
    "FireCode",
    "FireDepartmentID",
    "FireDiscoveryDateTime",
    "FireMgmtComplexity",
    "FireOutDateTime",
    "FireStrategyConfinePercent",
    "FireStrategyFullSuppPercent",
    "FireStrategyMonitorPercent",
    "FireStrategyPointZonePercent",
    "FSJobCode",
    "FSOverrideCode",
    "GACC",
    "ICS209ReportDateTime",
    "ICS209ReportForTimePeriodFrom",
    "ICS209ReportForTimePeriodTo",
    "ICS209ReportStatus",
    "IncidentManagementOrganization",
    "IncidentName",
    "IncidentShortDescription",
    "IncidentTypeCategory",
    "IncidentTypeKind",
    "InitialLatitude",
    "InitialLongitude",
    "InitialResponseAcres",
    "InitialResponseDateTime",
    "IrwinID",
    "IsFireCauseInvestigated",
    "IsFireCodeRequested",
    "IsFSAssisted",
    "IsMultiJurisdictional",
    "IsReimbursable",
    "IsTrespass",
    "IsUnifiedCommand",
    "LocalIncidentIdentifier",
    "ModifiedBySystem",
    "PercentContained",
    "PercentPerimeterToBeContained",
    "POOCity",
    "POOCounty",
    "POODispatchCenterID",
    "POOFips",
    "POOJurisdictionalAgency",
    "POOJurisdictionalUnit",
    "POOJurisdictionalUnitParentUnit",
    "POOLandownerCategory",
    "POOLandownerKind",
    "POOLegalDescPrincipalMeridian",
    "POOLegalDescQtr",
    "POOLegalDescQtrQtr",
    "POOLegalDescRange",
    "POOLegalDescSection",
    "POOLegalDescTownship",
    "POOPredictiveServiceAreaID",
    "POOProtectingAgency",
    "POOProtectingUnit",
    "POOState",
    "PredominantFuelGroup",
    "PredominantFuelModel",
    "PrimaryFuelModel",
    "SecondaryFuelModel",
    "TotalIncidentPersonnel",
    "UniqueFireIdentifier",
    "WFDSSDecisionStatus",
    "EstimatedFinalCost",
    "OrganizationalAssessment",
    "StrategicDecisionPublishDate",
    "CreatedOnDateTime_dt",
    "ModifiedOnDateTime_dt",
    "IsCpxChild",
    "CpxName",
    "CpxID",
    "SourceGlobalID",
    "GlobalID",
];

/// Why an ignition happened (the model component that produced it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IgnitionCause {
    /// Human-caused wildfire (`WF`).
    Human,
    /// Lightning wildfire (`WF`).
    Lightning,
    /// Prescribed fire (`RX`).
    Prescribed,
}

/// One synthetic ignition (the truth behind one or two CSV records).
#[derive(Debug, Clone, PartialEq)]
pub struct SynthIgnition {
    /// `OBJECTID` of its primary record.
    pub object_id: u64,
    /// `UniqueFireIdentifier` of the primary record (`YYYY-<unit>-<number>`).
    pub unique_fire_id: String,
    /// `IrwinID` of the primary record (`{GUID}`).
    pub irwin_id: String,
    /// `WF` or `RX`.
    pub category: &'static str,
    /// The model component that produced it.
    pub cause: IgnitionCause,
    /// True point of origin (what `InitialLatitude`/`InitialLongitude` report).
    pub lat: f64,
    /// True point of origin, longitude.
    pub lon: f64,
    /// Global GRIDMET row of the cell.
    pub lat_index: usize,
    /// Global GRIDMET column of the cell.
    pub lon_index: usize,
    /// The GRIDMET day (days since 1900-01-01) whose weather produced it.
    pub gridmet_day: i32,
    /// Discovery time, seconds since 1970-01-01 UTC (within the GRIDMET day).
    pub discovery_epoch_s: i64,
    /// Final size (acres).
    pub size_acres: f64,
    /// Total Poisson rate λ of its cell-day.
    pub rate: f64,
    /// ERC of the cell-day (as written to `erc_<YYYY>.nc`, before packing).
    pub erc: f32,
    /// 100-h fuel moisture of the cell-day (%).
    pub fm100: f32,
    /// Wind speed of the cell-day (m/s).
    pub vs: f32,
    /// Two-letter state.
    pub state: &'static str,
    /// `OBJECTID`s of duplicate reports of the same fire (empty for most fires).
    pub duplicate_object_ids: Vec<u64>,
}

/// UTC date-time in the ArcGIS Hub CSV encoding `YYYY/MM/DD HH:MM:SS+00`.
pub fn hub_datetime(epoch_s: i64) -> String {
    let days = epoch_s.div_euclid(86_400);
    let secs = epoch_s.rem_euclid(86_400);
    let (y, m, d) = day_to_ymd((days + 25_567) as i32);
    format!(
        "{y:04}/{m:02}/{d:02} {:02}:{:02}:{:02}+00",
        secs / 3600,
        (secs / 60) % 60,
        secs % 60
    )
}

/// Seconds since 1970 of 00:00 UTC on GRIDMET day `day`.
fn day_epoch(day: i32) -> i64 {
    (i64::from(day) - 25_567) * 86_400
}

const NAME_A: &[&str] = &[
    "Bear",
    "Cedar",
    "Pine",
    "Oak",
    "Juniper",
    "Sage",
    "Rock",
    "Deer",
    "Elk",
    "Coyote",
    "Hawk",
    "Eagle",
    "Willow",
    "Aspen",
    "Cottonwood",
    "Mesa",
    "Lone",
    "Dry",
    "Red",
    "Black",
    "White",
    "Little",
    "Big",
    "Mill",
    "Spring",
    "Horse",
    "Cow",
    "Antelope",
    "Rabbit",
    "Quail",
    "Owl",
    "Buck",
    "Bull",
    "Salt",
    "Sand",
    "Gold",
    "Silver",
    "Copper",
    "Iron",
    "Sheep",
    "Wolf",
    "Fox",
    "Badger",
    "Beaver",
    "Crane",
    "Cherry",
    "Walnut",
    "Hickory",
    "Magnolia",
    "Cypress",
    "Palmetto",
    "Mustang",
    "Rattlesnake",
    "Lookout",
    "Sawmill",
    "Granite",
];
const NAME_B: &[&str] = &[
    "Creek", "Ridge", "Canyon", "Flat", "Butte", "Peak", "Hollow", "Springs", "Lake", "Road", "Gulch",
    "Draw", "Valley", "Meadow", "Hill", "Point", "Wash", "Fork", "Trail", "Pass", "Bluff", "Branch",
    "Bottom", "Knob",
];
const HUMAN_GENERAL: &[&str] = &[
    "Debris and Open Burning",
    "Equipment and Vehicle Use",
    "Arson/Incendiarism",
    "Recreation and Ceremony",
    "Smoking",
    "Power Generation/Transmission/Distribution",
    "Railroad Operations and Maintenance",
    "Firearms and Explosives Use",
    "Misuse of Fire by a Minor",
    "Other Human Cause",
];
const SYSTEMS: &[&str] = &["wildcad", "ifmcad", "firecode", "wfdss", "inform", "emberwildcad"];

fn incident_name(rng: &mut ChaCha8Rng, rx: bool) -> String {
    let a = NAME_A[rng.random_range(0..NAME_A.len())];
    let b = NAME_B[rng.random_range(0..NAME_B.len())];
    if rx {
        return match rng.random_range(0..3) {
            0 => format!("{a} {b} RX"),
            1 => format!("Unit {} Rx", rng.random_range(1..60)),
            _ => format!("{a} {b} Prescribed Burn"),
        };
    }
    match rng.random_range(0..100) {
        0..70 => format!("{a} {b}"),
        70..78 => format!("Highway {}", rng.random_range(1..400)),
        78..85 => format!("MM {}", rng.random_range(1..300)),
        85..93 => a.to_string(),
        _ => format!("{a} {b} Rd"),
    }
}

fn guid(rng: &mut ChaCha8Rng) -> (u32, u16, u16, u16, u64) {
    let a: u32 = rng.random();
    let b: u16 = rng.random();
    let c: u16 = (rng.random::<u16>() & 0x0FFF) | 0x4000;
    let d: u16 = (rng.random::<u16>() & 0x3FFF) | 0x8000;
    let e: u64 = rng.random::<u64>() & 0xFFFF_FFFF_FFFF;
    (a, b, c, d, e)
}

fn guid_braced(rng: &mut ChaCha8Rng) -> String {
    let (a, b, c, d, e) = guid(rng);
    format!("{{{a:08X}-{b:04X}-{c:04X}-{d:04X}-{e:012X}}}")
}

fn guid_plain(rng: &mut ChaCha8Rng) -> String {
    let (a, b, c, d, e) = guid(rng);
    format!("{a:08x}-{b:04x}-{c:04x}-{d:04x}-{e:012x}")
}

/// A synthetic unit identifier `<ST><3 letters>` for the 1° tile around a point; `salt`
/// selects another agency's unit in the same tile.
fn unit_id(seed: u64, state: &str, lat: f64, lon: f64, salt: u64) -> String {
    let tile = ((lat.floor() as i64 + 90) * 400 + (lon.floor() as i64 + 200)) as u64;
    let st = state.as_bytes();
    let h = hash_with(
        key(seed, Stream::Towns, 7 + salt as i64),
        tile ^ (u64::from(st[0]) << 40 | u64::from(st[1]) << 32),
    );
    let letters: String = (0..3)
        .map(|k| char::from(b'A' + ((h >> (8 * k)) % 26) as u8))
        .collect();
    format!("{state}{letters}")
}

/// Moves `(lat, lon)` by `dist_m` metres toward `bearing` (radians from north).
fn offset(lat: f64, lon: f64, dist_m: f64, bearing: f64) -> (f64, f64) {
    let dlat = dist_m * bearing.cos() / 111_195.0;
    let dlon = dist_m * bearing.sin() / (111_195.0 * lat.to_radians().cos());
    (lat + dlat, lon + dlon)
}

/// One CSV record (primary report or duplicate).
#[derive(Debug, Clone)]
struct Record {
    event: usize,
    duplicate: bool,
    t: i64,
    lat: f64,
    lon: f64,
    initial_present: bool,
    x: f64,
    y: f64,
    unit: String,
    name: String,
    irwin: String,
    source_global: String,
    global: String,
    cause_field: &'static str,
    cause_general: &'static str,
    created_by: &'static str,
    created_after_s: i64,
    size: f64,
    out_after_s: Option<i64>,
    landowner: (&'static str, &'static str, &'static str),
    object_id: u64,
    local_number: u32,
}

/// Ignitions plus the CSV records derived from them, in discovery order.
pub(crate) struct IncidentSet {
    pub events: Vec<SynthIgnition>,
    records: Vec<Record>,
}

impl IncidentSet {
    /// Number of CSV records.
    pub fn n_records(&self) -> u64 {
        self.records.len() as u64
    }
}

fn round_size(acres: f64) -> f64 {
    if acres < 10.0 {
        ((acres * 10.0).round() / 10.0).max(0.1)
    } else if acres < 1000.0 {
        acres.round()
    } else {
        (acres / 10.0).round() * 10.0
    }
}

fn fmt_size(acres: f64) -> String {
    if acres < 10.0 {
        format!("{acres:.1}")
    } else {
        format!("{acres:.0}")
    }
}

fn landowner(rng: &mut ChaCha8Rng, lon: f64) -> (&'static str, &'static str, &'static str) {
    // (category, kind, protecting agency); the West has more federal land.
    let west = lon < -102.0;
    let r: f64 = rng.random();
    let federal = if west { 0.55 } else { 0.12 };
    if r < federal {
        const FED: [(&str, &str); 5] = [
            ("USFS", "Federal"),
            ("BLM", "Federal"),
            ("NPS", "Federal"),
            ("BIA", "Federal"),
            ("USFWS", "Federal"),
        ];
        let k = if west {
            rng.random_range(0..5)
        } else {
            [0, 0, 2, 4][rng.random_range(0..4)]
        };
        let (cat, kind) = FED[k];
        (cat, kind, cat)
    } else if r < federal + 0.12 {
        ("State", "Other", "State")
    } else if r < federal + 0.17 {
        ("County", "Other", "County")
    } else {
        ("Private", "Private", "State")
    }
}

/// Turns the day-by-day candidates into ignitions and CSV records (deterministic: every
/// ignition's details come from a ChaCha8 stream seeded by `(seed, day, cell, k)`).
pub(crate) fn build(seed: u64, candidates: &[Candidate], duplicate_fraction: f64) -> IncidentSet {
    struct Pending {
        ev: SynthIgnition,
        gid: u32,
        k: u32,
        primary: Record,
        dup: Option<Record>,
    }
    let mut pending: Vec<Pending> = Vec::new();
    for cand in candidates {
        let (j, i) = gid_to_ji(cand.gid);
        let (clat, clon) = (grid_lat(j), grid_lon(i));
        let kd = key(seed, Stream::IgnitionDetail, i64::from(cand.day));
        for k in 0..cand.count {
            let mut rng = ChaCha8Rng::seed_from_u64(hash_with(kd, u64::from(cand.gid) << 8 | u64::from(k)));
            let total = f64::from(cand.lam_human + cand.lam_lightning + cand.lam_rx);
            let pick = rng.random::<f64>() * total;
            let cause = if pick < f64::from(cand.lam_human) {
                IgnitionCause::Human
            } else if pick < f64::from(cand.lam_human + cand.lam_lightning) {
                IgnitionCause::Lightning
            } else {
                IgnitionCause::Prescribed
            };
            let lat = clat + (rng.random::<f64>() - 0.5) * GRID_STEP;
            let lon = clon + (rng.random::<f64>() - 0.5) * GRID_STEP;

            // Local (solar) hour of discovery, then UTC, kept inside the GRIDMET day.
            let normal = |rng: &mut ChaCha8Rng| {
                let u1: f64 = rng.random::<f64>().max(1e-12);
                let u2: f64 = rng.random();
                (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
            };
            let local_h = match cause {
                IgnitionCause::Prescribed => 11.0 + 1.5 * normal(&mut rng),
                IgnitionCause::Lightning => 16.5 + 3.0 * normal(&mut rng),
                IgnitionCause::Human => {
                    if rng.random::<f64>() < 0.85 {
                        14.5 + 3.2 * normal(&mut rng)
                    } else {
                        24.0 * rng.random::<f64>()
                    }
                }
            }
            .rem_euclid(24.0);
            let start = day_epoch(cand.day) + 7 * 3600;
            let mut t = day_epoch(cand.day) + ((local_h - lon / 15.0) * 3600.0) as i64;
            t = (t / 60) * 60;
            while t < start {
                t += 86_400;
            }
            while t >= start + 86_400 {
                t -= 86_400;
            }

            let rx = cause == IgnitionCause::Prescribed;
            let size = if rx {
                (40.0 * (1.2 * normal(&mut rng)).exp()).clamp(1.0, 5000.0)
            } else {
                let ramp = |x: f32| f64::from(x.clamp(0.0, 1.0));
                let mut alpha =
                    0.85 - 0.4 * ramp((cand.erc - 30.0) / 70.0) - 0.15 * ramp((cand.vs - 4.0) / 6.0);
                if cause == IgnitionCause::Lightning {
                    alpha -= 0.05;
                }
                let u: f64 = rng.random::<f64>().max(1e-9);
                (0.1 * u.powf(-1.0 / alpha)).min(500_000.0)
            };
            let size = round_size(size);
            let state = state_of(lat, lon);
            let unit = unit_id(seed, state, lat, lon, 0);

            // X/Y (current point of origin) vs the initial report.
            let initial_present = rng.random::<f64>() >= 0.03;
            let r: f64 = rng.random();
            let shift = if !initial_present || r < 0.85 {
                60.0 * rng.random::<f64>()
            } else if r < 0.97 {
                60.0 + 740.0 * rng.random::<f64>()
            } else {
                1000.0 + 1500.0 * rng.random::<f64>()
            };
            let (y, x) = offset(lat, lon, shift, std::f64::consts::TAU * rng.random::<f64>());

            let (cause_field, cause_general) = match cause {
                IgnitionCause::Prescribed => ("Human", ""),
                IgnitionCause::Lightning => {
                    if rng.random::<f64>() < 0.88 {
                        ("Natural", "")
                    } else {
                        ("Undetermined", "")
                    }
                }
                IgnitionCause::Human => {
                    let r: f64 = rng.random();
                    if r < 0.72 {
                        let g = if rng.random::<f64>() < 0.45 {
                            HUMAN_GENERAL[rng.random_range(0..HUMAN_GENERAL.len())]
                        } else {
                            ""
                        };
                        ("Human", g)
                    } else if r < 0.95 {
                        ("Undetermined", "")
                    } else {
                        ("", "")
                    }
                }
            };
            let out_after_s = (rng.random::<f64>() < 0.8).then(|| {
                let hours = 1.5 + 6.0 * (size / 1.0).powf(0.45) * (0.5 + rng.random::<f64>());
                (hours.min(24.0 * 120.0) * 3600.0) as i64
            });
            let primary = Record {
                event: 0,
                duplicate: false,
                t,
                lat,
                lon,
                initial_present,
                x,
                y,
                unit: unit.clone(),
                name: incident_name(&mut rng, rx),
                irwin: guid_braced(&mut rng),
                source_global: guid_braced(&mut rng),
                global: guid_plain(&mut rng),
                cause_field,
                cause_general,
                created_by: SYSTEMS[rng.random_range(0..SYSTEMS.len())],
                created_after_s: rng.random_range(120..10_800),
                size,
                out_after_s,
                landowner: landowner(&mut rng, lon),
                object_id: 0,
                local_number: 0,
            };
            let dup = (!rx && rng.random::<f64>() < duplicate_fraction).then(|| {
                let minutes: i64 = rng.random_range(3..=110);
                let dt = if rng.random::<f64>() < 0.25 {
                    -minutes
                } else {
                    minutes
                } * 60;
                let (dlat, dlon) = offset(
                    lat,
                    lon,
                    80.0 + 620.0 * rng.random::<f64>(),
                    std::f64::consts::TAU * rng.random::<f64>(),
                );
                let (dy, dx) = offset(
                    dlat,
                    dlon,
                    40.0 * rng.random::<f64>(),
                    std::f64::consts::TAU * rng.random::<f64>(),
                );
                Record {
                    event: 0,
                    duplicate: true,
                    t: t + dt,
                    lat: dlat,
                    lon: dlon,
                    initial_present: true,
                    x: dx,
                    y: dy,
                    unit: unit_id(seed, state, lat, lon, 1),
                    name: if rng.random::<f64>() < 0.6 {
                        primary.name.clone()
                    } else {
                        incident_name(&mut rng, false)
                    },
                    irwin: guid_braced(&mut rng),
                    source_global: guid_braced(&mut rng),
                    global: guid_plain(&mut rng),
                    cause_field: if rng.random::<f64>() < 0.5 {
                        primary.cause_field
                    } else {
                        "Undetermined"
                    },
                    cause_general: "",
                    created_by: SYSTEMS[rng.random_range(0..SYSTEMS.len())],
                    created_after_s: rng.random_range(120..10_800),
                    size: if rng.random::<f64>() < 0.5 { size } else { 0.1 },
                    out_after_s: primary.out_after_s,
                    landowner: primary.landowner,
                    object_id: 0,
                    local_number: 0,
                }
            });
            pending.push(Pending {
                ev: SynthIgnition {
                    object_id: 0,
                    unique_fire_id: String::new(),
                    irwin_id: primary.irwin.clone(),
                    category: if rx { "RX" } else { "WF" },
                    cause,
                    lat,
                    lon,
                    lat_index: j,
                    lon_index: i,
                    gridmet_day: cand.day,
                    discovery_epoch_s: t,
                    size_acres: size,
                    rate: total,
                    erc: cand.erc,
                    fm100: cand.fm100,
                    vs: cand.vs,
                    state,
                    duplicate_object_ids: Vec::new(),
                },
                gid: cand.gid,
                k,
                primary,
                dup,
            });
        }
    }
    // Discovery order (ties broken by cell and draw, so the order is total).
    pending.sort_by(|a, b| {
        a.ev.discovery_epoch_s
            .cmp(&b.ev.discovery_epoch_s)
            .then(a.gid.cmp(&b.gid))
            .then(a.k.cmp(&b.k))
    });
    let mut events = Vec::with_capacity(pending.len());
    let mut records = Vec::with_capacity(pending.len() + pending.len() / 10);
    for (e, p) in pending.into_iter().enumerate() {
        events.push(p.ev);
        let mut primary = p.primary;
        primary.event = e;
        records.push(primary);
        if let Some(mut d) = p.dup {
            d.event = e;
            records.push(d);
        }
    }
    records.sort_by(|a, b| match a.t.cmp(&b.t) {
        Ordering::Equal => (a.event, a.duplicate).cmp(&(b.event, b.duplicate)),
        o => o,
    });
    // OBJECTIDs in record order; local numbers in order within (year, unit).
    let mut counters: std::collections::BTreeMap<(i32, String), u32> = std::collections::BTreeMap::new();
    for (n, r) in records.iter_mut().enumerate() {
        r.object_id = n as u64 + 1;
        let year = day_to_ymd((r.t.div_euclid(86_400) + 25_567) as i32).0;
        let c = counters.entry((year, r.unit.clone())).or_insert(0);
        *c += 1;
        r.local_number = *c;
        let ev = &mut events[r.event];
        if r.duplicate {
            ev.duplicate_object_ids.push(r.object_id);
        } else {
            ev.object_id = r.object_id;
            ev.unique_fire_id = format!("{year}-{}-{:06}", r.unit, r.local_number);
        }
    }
    IncidentSet { events, records }
}

fn col(name: &str) -> usize {
    WFIGS_HEADER.iter().position(|h| *h == name).unwrap_or(0)
}

/// Writes `set` as a WFIGS CSV at `path` (via a temporary file renamed into place).
pub(crate) fn write_csv(set: &IncidentSet, path: &Path) -> Result<PathBuf, SynthError> {
    let staged = temp_path(path)?;
    let tmp = staged.path();
    let result = (|| -> Result<(), SynthError> {
        let file = File::create(tmp).map_err(|e| SynthError::io(tmp, e))?;
        let mut w = csv::WriterBuilder::new().from_writer(BufWriter::with_capacity(1 << 20, file));
        let csv_err = |e: csv::Error| SynthError::Csv {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        w.write_record(WFIGS_HEADER).map_err(csv_err)?;
        let c = |n: &str| col(n);
        let mut row: Vec<String> = vec![String::new(); WFIGS_HEADER.len()];
        for r in &set.records {
            row.iter_mut().for_each(String::clear);
            let ev = &set.events[r.event];
            let year = day_to_ymd((r.t.div_euclid(86_400) + 25_567) as i32).0;
            let ufi = format!("{year}-{}-{:06}", r.unit, r.local_number);
            let mix = mix64(r.object_id ^ 0xA5A5);
            row[c("X")] = format!("{:.7}", r.x);
            row[c("Y")] = format!("{:.7}", r.y);
            row[c("OBJECTID")] = r.object_id.to_string();
            row[c("SourceOID")] = (100_000 + (mix % 9_000_000)).to_string();
            row[c("CreatedBySystem")] = r.created_by.to_string();
            row[c("ModifiedBySystem")] = r.created_by.to_string();
            row[c("IncidentSize")] = fmt_size(r.size);
            row[c("DiscoveryAcres")] = fmt_size(r.size.min(0.1 * (1 + (mix >> 20) % 5) as f64));
            row[c("FireCause")] = r.cause_field.to_string();
            row[c("FireCauseGeneral")] = r.cause_general.to_string();
            row[c("FireDiscoveryDateTime")] = hub_datetime(r.t);
            row[c("GACC")] = gacc_of(ev.state, r.lat, r.lon).to_string();
            row[c("IncidentName")] = r.name.clone();
            row[c("IncidentTypeCategory")] = ev.category.to_string();
            row[c("IncidentTypeKind")] = "FI".to_string();
            if r.initial_present {
                row[c("InitialLatitude")] = format!("{:.5}", r.lat);
                row[c("InitialLongitude")] = format!("{:.5}", r.lon);
            }
            row[c("IrwinID")] = r.irwin.clone();
            row[c("LocalIncidentIdentifier")] = format!("{:06}", r.local_number);
            row[c("POOJurisdictionalUnit")] = r.unit.clone();
            row[c("POOProtectingUnit")] = r.unit.clone();
            row[c("POOLandownerCategory")] = r.landowner.0.to_string();
            row[c("POOLandownerKind")] = r.landowner.1.to_string();
            row[c("POOProtectingAgency")] = r.landowner.2.to_string();
            row[c("POOJurisdictionalAgency")] = r.landowner.2.to_string();
            row[c("POOState")] = format!("US-{}", ev.state);
            row[c("UniqueFireIdentifier")] = ufi;
            let created = r.t + r.created_after_s;
            row[c("CreatedOnDateTime_dt")] = hub_datetime(created);
            let mut modified = created + 3600;
            if let Some(out) = r.out_after_s {
                let out_t = r.t + out;
                row[c("ContainmentDateTime")] = hub_datetime(r.t + out * 6 / 10);
                row[c("ControlDateTime")] = hub_datetime(r.t + out * 8 / 10);
                row[c("FireOutDateTime")] = hub_datetime(out_t);
                row[c("PercentContained")] = "100".to_string();
                row[c("FinalAcres")] = fmt_size(r.size);
                modified = modified.max(out_t + 1800);
            }
            row[c("ModifiedOnDateTime_dt")] = hub_datetime(modified);
            row[c("IsCpxChild")] = "0".to_string();
            row[c("SourceGlobalID")] = r.source_global.clone();
            row[c("GlobalID")] = r.global.clone();
            w.write_record(&row).map_err(csv_err)?;
        }
        let buf = w.into_inner().map_err(|e| SynthError::io(tmp, e.into_error()))?;
        let file = buf
            .into_inner()
            .map_err(|e| SynthError::io(tmp, e.into_error()))?;
        file.sync_all().map_err(|e| SynthError::io(tmp, e))?;
        Ok(())
    })();
    // On an error `staged` is dropped, which removes the partial file.
    result?;
    staged.publish().map_err(|e| SynthError::io(path, e.source))?;
    Ok(path.to_path_buf())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_is_complete_and_unique() {
        let mut h: Vec<&str> = WFIGS_HEADER.to_vec();
        h.sort_unstable();
        h.dedup();
        assert_eq!(h.len(), 97);
        assert_eq!(WFIGS_HEADER[0], "X");
        assert_eq!(WFIGS_HEADER[96], "GlobalID");
    }

    #[test]
    fn hub_dates() {
        // 2018-01-01 00:00:00 UTC = 1514764800.
        assert_eq!(hub_datetime(1_514_764_800), "2018/01/01 00:00:00+00");
        assert_eq!(hub_datetime(1_514_764_800 + 86_399), "2018/01/01 23:59:59+00");
        assert_eq!(day_epoch(43_099), 1_514_764_800);
    }
}
