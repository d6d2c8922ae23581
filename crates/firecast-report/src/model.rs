//! The report's data: every number the HTML, PDF and GeoJSON show, as one JSON document
//! (`report.json`). Its schema is `schemas/threat-report-1.schema.json` at the repository
//! root; `SCHEMA_VERSION` changes with it. Units are in the field names.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Version of the JSON layout (semantic: a new field is a minor bump).
pub const SCHEMA_VERSION: &str = "1.0.0";
/// `$id` of the schema.
pub const SCHEMA_ID: &str = "https://firecast.dev/schemas/threat-report-1.schema.json";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ThreatReport {
    pub schema: String,
    pub schema_version: String,
    pub header: Header,
    pub weather: Weather,
    pub forecast: Forecast,
    pub fire_behaviour: FireBehaviour,
    pub contingencies: Vec<Contingency>,
    pub strategies: Vec<StrategySummary>,
    pub comparisons: Vec<Comparison>,
    pub drops: DropPlan,
    pub assets: Vec<Asset>,
    pub evacuation_bands: EvacuationBands,
    pub priority_zones: Vec<PriorityZone>,
    pub risk: Risk,
    pub assumptions: Vec<String>,
    pub what_would_change: Vec<String>,
    pub lineage: Vec<Lineage>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Header {
    pub title: String,
    pub lat: f64,
    pub lon: f64,
    /// The GRIDMET cell the weather and forecast were read from.
    pub grid_cell_lat: f64,
    pub grid_cell_lon: f64,
    /// "GRIDMET cell 39.2500° N, 107.5000° W" — the nearest named place on the grid.
    pub grid_location: String,
    pub date: String,
    /// ISO 8601 UTC (SOURCE_DATE_EPOCH when set, so a rebuilt report is identical).
    pub issued_at: String,
    pub valid_from: String,
    pub valid_until: String,
    /// Hours simulated after ignition.
    pub horizon_h: f64,
    pub run_id: String,
    pub firecast_version: String,
    pub forecaster: String,
    pub agent: String,
    /// Landscape: size on the ground and where it lies.
    pub landscape: String,
    pub cell_size_ft: f64,
    pub crs: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Weather {
    pub date: String,
    pub source: String,
    pub cell_lat: f64,
    pub cell_lon: f64,
    pub max_temp_f: Option<f64>,
    pub max_temp_c: Option<f64>,
    pub min_temp_f: Option<f64>,
    pub min_temp_c: Option<f64>,
    pub min_rh_pct: Option<f64>,
    pub max_rh_pct: Option<f64>,
    pub precip_in: Option<f64>,
    pub precip_mm: Option<f64>,
    pub wind_10m_mph: f64,
    pub wind_10m_m_s: f64,
    /// Degrees clockwise from north the wind comes from, and its compass point.
    pub wind_from_deg: f64,
    pub wind_from: String,
    pub erc: Option<f64>,
    pub burning_index: Option<f64>,
    pub fm100_pct: Option<f64>,
    pub fm1000_pct: Option<f64>,
    pub vpd_kpa: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Forecast {
    pub probability: f64,
    pub interval: [f64; 2],
    pub interval_method: String,
    pub threshold: f64,
    pub ignition_expected: bool,
    pub model: String,
    pub kind: String,
    pub protocol: String,
    pub dataset: String,
    pub dataset_version: String,
    pub seeds: usize,
    pub validation_auroc: Option<f64>,
    pub validation_auprc: Option<f64>,
    pub test_auroc: Option<f64>,
    /// Inclusive input day offsets relative to the date.
    pub input_days: [i32; 2],
}

/// A quantity in field and SI units, with its NWCG adjective class.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Quantity {
    pub field: f64,
    pub field_unit: String,
    pub si: f64,
    pub si_unit: String,
    pub class: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FireBehaviour {
    pub fuel_model: String,
    pub fuel_model_name: String,
    pub land_cover_code: u16,
    pub slope_pct: f64,
    /// Direction the slope faces, degrees clockwise from north.
    pub aspect_deg: f64,
    pub midflame_wind_mph: f64,
    pub wind_adjustment_factor: f64,
    pub dead_1h_pct: f64,
    pub dead_10h_pct: f64,
    pub dead_100h_pct: f64,
    pub live_herb_pct: f64,
    pub live_woody_pct: f64,
    pub rate_of_spread: Quantity,
    pub flame_length: Quantity,
    pub fireline_intensity: Quantity,
    pub heat_per_unit_area: Quantity,
    /// Compass bearing the head fire runs toward.
    pub head_direction_deg: f64,
    pub head_direction: String,
    pub length_to_width: f64,
    pub tactic: String,
}

/// A flame-length limit of a suppression resource and the wind that passes it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Contingency {
    pub flame_length_ft: f64,
    pub resource: String,
    /// 10-m wind at which the head-fire flame length reaches the limit (None: not below
    /// `searched_to_mph`); 0 when it is already passed in calm air.
    pub wind_10m_mph: Option<f64>,
    pub searched_to_mph: f64,
    pub exceeded_today: bool,
    pub statement: String,
}

/// An estimate with a 95 % interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Estimate {
    pub value: f64,
    pub low: f64,
    pub high: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StrategySummary {
    pub strategy: String,
    pub label: String,
    pub description: String,
    pub runs: usize,
    /// Mean burnt area with its 95 % bootstrap interval over the runs.
    pub burned_acres: Estimate,
    pub burned_hectares: Estimate,
    pub burned_acres_median: f64,
    pub burned_fraction_pct: f64,
    pub contained_pct: f64,
    /// Median hours until the fire went out, over the runs that went out.
    pub containment_hours_median: Option<f64>,
    /// Median over runs of the hour at which the most cells were burning at once (the
    /// authors' "containment time").
    pub peak_burning_hours_median: f64,
    pub helitacks_mean: f64,
    pub water_gal_mean: f64,
    /// Burnt area over time: hours, then mean and the 10th/90th percentiles over runs.
    pub series_hours: Vec<f64>,
    pub series_acres_mean: Vec<f64>,
    pub series_acres_p10: Vec<f64>,
    pub series_acres_p90: Vec<f64>,
    /// Acres inside each arrival isochrone (median arrival), hours → acres.
    pub isochrone_acres: Vec<[f64; 2]>,
}

/// A strategy against no suppression on the same seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Comparison {
    pub strategy: String,
    pub baseline: String,
    pub paired_runs: usize,
    /// Baseline minus strategy: acres saved (positive = less burnt).
    pub acres_saved: Estimate,
    pub reduction_pct: f64,
    /// Share of paired runs in which the strategy burnt less.
    pub runs_better_pct: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Drop {
    pub number: usize,
    pub hour: f64,
    pub lat: f64,
    pub lon: f64,
    pub x: i32,
    pub y: i32,
    pub quenched_cells: u32,
}

/// The drops of the agent's representative run (the run with the median burnt area).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DropPlan {
    pub strategy: String,
    pub run_seed: Option<u64>,
    pub run_burned_acres: Option<f64>,
    pub drops: Vec<Drop>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Asset {
    pub name: String,
    /// `listed` (named in the request) or `developed` (developed land of the landscape).
    pub source: String,
    pub lat: f64,
    pub lon: f64,
    pub area_acres: f64,
    /// Earliest arrival near the asset over every run of every strategy.
    pub first_arrival_h: Option<f64>,
    pub first_arrival_strategy: Option<String>,
    /// Per strategy: the highest burn probability (percent of runs) among the cells within
    /// the buffer — a lower bound on the share of runs in which fire reached the asset.
    pub reached_pct: Vec<(String, f64)>,
    /// GO, SET, READY or NONE.
    pub band: String,
    pub advice: String,
    /// Hours after ignition at which to move to the next band (None in GO and NONE).
    pub trigger_h: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct EvacuationBands {
    pub go_within_h: f64,
    pub set_within_h: f64,
    pub ready_within_h: f64,
    pub buffer_ft: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PriorityZone {
    pub rank: usize,
    pub lat: f64,
    pub lon: f64,
    /// The zone's cells: [x0, y0, x1, y1) on the grid.
    pub cells: [usize; 4],
    /// Expected acres the agent kept from burning there (burn probability without
    /// suppression minus with the agent, summed over the zone).
    pub acres_protected: f64,
    pub drops_per_run: f64,
    pub burn_probability_unsuppressed_pct: f64,
    pub burn_probability_agent_pct: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Risk {
    pub level: String,
    pub burned_fraction_pct: f64,
    pub assets_go: usize,
    pub assets_set: usize,
    pub rule: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Lineage {
    pub role: String,
    pub path: String,
    pub detail: String,
}

/// The JSON Schema of [`ThreatReport`] (draft 2020-12), as committed in
/// `schemas/threat-report-1.schema.json`.
pub fn json_schema() -> serde_json::Value {
    let mut schema = serde_json::to_value(schemars::schema_for!(ThreatReport)).unwrap_or_default();
    if let Some(obj) = schema.as_object_mut() {
        obj.insert("$id".into(), SCHEMA_ID.into());
        obj.insert(
            "description".into(),
            format!(
                "FireCast threat-assessment report, layout version {SCHEMA_VERSION}: every number the HTML and PDF show. \
                 Units are in the field names (_h hours, _acres, _pct percent, _mph miles per hour, _ft feet)."
            )
            .into(),
        );
    }
    schema
}
