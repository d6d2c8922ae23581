//! The report's data: every number the HTML, PDF and GeoJSON show, as one JSON document
//! (`report.json`). Its schema is `schemas/threat-report-1.schema.json` at the repository
//! root; `SCHEMA_VERSION` changes with it. Units are in the field names and in every
//! field's description (the doc comments below, which become the schema's descriptions).
//!
//! Conventions: times are hours after ignition (`_h`) unless named a date or time; shares and
//! probabilities are percent 0–100 (`_pct`), except the forecast's `probability`,
//! `interval` and `threshold`, which keep the 0–1 fractions `forecast.predict` writes; areas
//! are acres (`_acres`) and hectares (`_hectares`); grid cells are named as cells.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Version of the JSON layout (semantic: a new field is a minor bump).
pub const SCHEMA_VERSION: &str = "1.4.0";
/// `$id` of the schema.
pub const SCHEMA_ID: &str = "https://firecast.dev/schemas/threat-report-1.schema.json";

/// The threat-assessment report of one place and day.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ThreatReport {
    /// `$id` of the JSON Schema this document follows.
    pub schema: String,
    /// Version of the layout (semantic versioning; a new field is a minor bump).
    pub schema_version: String,
    /// Place, day, issue time, period simulated and what produced the report.
    pub header: Header,
    /// The day's GRIDMET weather at the point.
    pub weather: Weather,
    /// The ignition forecast at the point on the day.
    pub forecast: Forecast,
    /// Surface fire behaviour at the ignition cell (behave's Rothermel model).
    pub fire_behaviour: FireBehaviour,
    /// The 10-m winds at which the head fire passes the flame-length limits of suppression
    /// resources (4, 8 and 11 ft).
    pub contingencies: Vec<Contingency>,
    /// The free fire spread by the minimum-travel-time engine verified against Rothermel's
    /// ellipse, when the report was given it (absent otherwise): then it, not the automaton,
    /// gives the isochrones, burn probability, GeoTIFFs, assets' arrival and risk.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub free_spread: Option<FreeSpread>,
    /// One entry per strategy simulated on FireCastRL's automaton (no suppression first).
    pub strategies: Vec<StrategySummary>,
    /// Each strategy against no suppression on the same runs (paired).
    pub comparisons: Vec<Comparison>,
    /// The drops of one representative run of the agent (or the rule-based plan).
    pub drops: DropPlan,
    /// Listed assets and developed land, most urgent first, with Ready/Set/Go bands.
    pub assets: Vec<Asset>,
    /// The hours after ignition that define the GO, SET and READY bands, and the asset buffer.
    pub evacuation_bands: EvacuationBands,
    /// Squares where the agent lowered the burn probability most, highest first.
    pub priority_zones: Vec<PriorityZone>,
    /// The overall risk level and the rule that set it.
    pub risk: Risk,
    /// Assumptions behind the numbers, one sentence each.
    pub assumptions: Vec<String>,
    /// What would change the assessment, one sentence each.
    pub what_would_change: Vec<String>,
    /// Every input file the report was made from.
    pub lineage: Vec<Lineage>,
}

/// Place, day, issue time, period simulated and what produced the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Header {
    /// Title line of the report.
    pub title: String,
    /// Latitude of the point asked for (the ignition), degrees north (WGS84).
    pub lat: f64,
    /// Longitude of the point asked for (the ignition), degrees east (WGS84; west negative).
    pub lon: f64,
    /// Latitude of the centre of the GRIDMET cell the weather and forecast were read from,
    /// degrees north.
    pub grid_cell_lat: f64,
    /// Longitude of the centre of that GRIDMET cell, degrees east.
    pub grid_cell_lon: f64,
    /// The GRIDMET cell as text, e.g. "GRIDMET cell 39.2500° N, 107.5000° W".
    pub grid_location: String,
    /// The forecast day, YYYY-MM-DD.
    pub date: String,
    /// When the report was issued: ISO 8601 UTC (SOURCE_DATE_EPOCH when set, so a rebuilt
    /// report is identical).
    pub issued_at: String,
    /// Start of the period the report covers: the day at local midnight, as text.
    pub valid_from: String,
    /// End of the period the report covers, as text (hours after ignition and days).
    pub valid_until: String,
    /// Hours simulated after ignition (the cut-off of every run), h.
    pub horizon_h: f64,
    /// Id of the `report` stage run that wrote the report.
    pub run_id: String,
    /// FireCast version that wrote the report.
    pub firecast_version: String,
    /// The forecaster: model, kind, protocol, dataset and its version.
    pub forecaster: String,
    /// The agent whose runs are reported (its ensemble's description), or "none".
    pub agent: String,
    /// The landscape: size on the ground in miles, resolution in feet, grid size in cells,
    /// land-cover scheme and centre.
    pub landscape: String,
    /// Side of one grid cell on the ground, ft.
    pub cell_size_ft: f64,
    /// Coordinate reference system of the landscape grid, e.g. "EPSG:4326".
    pub crs: String,
}

/// The day's GRIDMET weather at the point (None where its file is absent).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Weather {
    /// The day, YYYY-MM-DD.
    pub date: String,
    /// Where the weather came from, e.g. "GRIDMET (daily, 4 km)".
    pub source: String,
    /// Latitude of the GRIDMET cell centre, degrees north.
    pub cell_lat: f64,
    /// Longitude of the GRIDMET cell centre, degrees east.
    pub cell_lon: f64,
    /// Daily maximum air temperature, °F.
    pub max_temp_f: Option<f64>,
    /// Daily maximum air temperature, °C.
    pub max_temp_c: Option<f64>,
    /// Daily minimum air temperature, °F.
    pub min_temp_f: Option<f64>,
    /// Daily minimum air temperature, °C.
    pub min_temp_c: Option<f64>,
    /// Daily minimum relative humidity, percent (0–100).
    pub min_rh_pct: Option<f64>,
    /// Daily maximum relative humidity, percent (0–100).
    pub max_rh_pct: Option<f64>,
    /// Daily precipitation, inches.
    pub precip_in: Option<f64>,
    /// Daily precipitation, mm.
    pub precip_mm: Option<f64>,
    /// Mean wind speed at 10 m, miles per hour (the wind every run starts from).
    pub wind_10m_mph: f64,
    /// Mean wind speed at 10 m, m/s.
    pub wind_10m_m_s: f64,
    /// Direction the wind comes from, degrees clockwise from true north.
    pub wind_from_deg: f64,
    /// Direction the wind comes from as a 16-point compass name.
    #[schemars(extend("enum" = ["N", "NNE", "NE", "ENE", "E", "ESE", "SE", "SSE", "S", "SSW", "SW", "WSW", "W", "WNW", "NW", "NNW"]))]
    pub wind_from: String,
    /// NFDRS energy release component (fuel model G), index (no unit).
    pub erc: Option<f64>,
    /// NFDRS burning index (fuel model G), index (no unit; about 10 × flame length in ft).
    pub burning_index: Option<f64>,
    /// 100-hour dead fuel moisture, percent of dry weight.
    pub fm100_pct: Option<f64>,
    /// 1000-hour dead fuel moisture, percent of dry weight.
    pub fm1000_pct: Option<f64>,
    /// Mean vapour pressure deficit, kPa.
    pub vpd_kpa: Option<f64>,
}

/// The ignition forecast at the point on the day (from `forecast.predict`). Probabilities
/// here are 0–1 fractions, as that stage writes them. The model's score is on its training
/// samples' scale (about 40 % fires by the paper's design), not a daily chance; the day's
/// chance is `daily_probability`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Forecast {
    /// The model's score at the point on the day, 0–1 fraction (mean over the model's training
    /// seeds): on the training samples' scale (about 40 % fires), not a daily chance.
    pub probability: f64,
    /// Lowest and highest score over the training seeds, 0–1 fractions.
    pub interval: [f64; 2],
    /// How the interval was obtained, and why it is empty when it is.
    pub interval_method: String,
    /// Alert threshold on the score, chosen on validation data, 0–1 fraction.
    pub threshold: f64,
    /// Whether the score is above the threshold (the alert).
    pub ignition_expected: bool,
    /// The day's probability of an ignition in the place's GRIDMET cell, 0–1 fraction: each
    /// seed's score corrected from the training samples' fire share to the training area's
    /// usual daily rate (King & Zeng's prior correction), mean over seeds (null: the model does
    /// not record its training fires).
    #[serde(default)]
    pub daily_probability: Option<f64>,
    /// Lowest and highest daily probability over the training seeds, 0–1 fractions.
    #[serde(default)]
    pub daily_interval: Option<[f64; 2]>,
    /// The training area's usual daily probability of an ignition in a cell, 0–1 fraction
    /// (ignition cell-days over cell-days of the training area and period).
    #[serde(default)]
    pub usual_daily_probability: Option<f64>,
    /// How the daily probability was obtained.
    #[serde(default)]
    pub daily_method: Option<String>,
    /// Why there is no daily probability (null when there is one, or the forecast does not say).
    #[serde(default)]
    pub daily_unavailable: Option<String>,
    /// Name of the model in the forecasting experiment.
    pub model: String,
    /// Kind of the model, e.g. "xgboost".
    pub kind: String,
    /// Evaluation protocol the model was trained under, e.g. "leak_free".
    pub protocol: String,
    /// Dataset the model was trained on.
    pub dataset: String,
    /// Content version (hash) of that dataset.
    pub dataset_version: String,
    /// Number of training seeds averaged (models).
    pub seeds: usize,
    /// Area under the ROC curve on validation data (0–1), mean over seeds.
    pub validation_auroc: Option<f64>,
    /// Area under the precision-recall curve on validation data (0–1), mean over seeds.
    pub validation_auprc: Option<f64>,
    /// Area under the ROC curve on held-out test data (0–1).
    pub test_auroc: Option<f64>,
    /// First and last day of the model's inputs, in days relative to the forecast day
    /// (inclusive; e.g. [-60, -1]).
    pub input_days: [i32; 2],
    /// The day's ignition probability at every GRIDMET cell around the place, by the same
    /// model (null: the report was not given `forecast.predict`'s `map`).
    #[serde(default)]
    pub pattern: Option<IgnitionPattern>,
    /// Where and when the model's training windows lie (null: the model does not say). A
    /// place outside the area makes the probability an extrapolation.
    #[serde(default)]
    pub training_area: Option<TrainingArea>,
}

/// The box and period of a forecaster's training windows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TrainingArea {
    /// Southern edge of the training windows' places, degrees north.
    pub lat_min: f64,
    /// Northern edge, degrees north.
    pub lat_max: f64,
    /// Western edge, degrees east (negative west).
    pub lon_min: f64,
    /// Eastern edge, degrees east (negative west).
    pub lon_max: f64,
    /// First forecast day among the training windows, YYYY-MM-DD.
    pub first_date: String,
    /// Last forecast day among the training windows, YYYY-MM-DD.
    pub last_date: String,
    /// Whether the report's place lies in the box widened by one GRIDMET cell (1/24°).
    pub place_inside: bool,
}

/// The forecasted ignition pattern: the day's probability over the GRIDMET cells around the
/// place.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct IgnitionPattern {
    /// Latitudes of the cells' centres, south to north, degrees north.
    pub lats: Vec<f64>,
    /// Longitudes of the cells' centres, west to east, degrees east.
    pub lons: Vec<f64>,
    /// The model's score per cell (the training samples' scale, not a daily chance), rows
    /// south to north and columns west to east, percent (0–100); null where the cell has no
    /// complete weather window.
    pub probability_pct: Vec<Vec<Option<f64>>>,
    /// The day's probability of an ignition per cell relative to the training area's usual
    /// day (1 = usual), same layout (null: the model does not record its training fires).
    #[serde(default)]
    pub relative_to_usual: Option<Vec<Vec<Option<f64>>>>,
    /// The training area's usual daily probability of an ignition in a cell, percent (0–100).
    #[serde(default)]
    pub usual_daily_pct: Option<f64>,
    /// Cells with a probability.
    pub cells: usize,
    /// The map's decision threshold (the mean of its seeds' thresholds, as `forecast.threshold`),
    /// percent (0–100).
    pub threshold_pct: f64,
    /// Cells at or above `threshold_pct`.
    pub cells_above_threshold: usize,
    /// Highest probability over the cells, percent (0–100; null: no cell has one).
    pub max_pct: Option<f64>,
}

/// A quantity in field and SI units, with its NWCG adjective class.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Quantity {
    /// The value in US field units (`field_unit`).
    pub field: f64,
    /// US field unit of `field`.
    #[schemars(extend("enum" = ["ch/h", "ft", "Btu/ft/s", "Btu/ft²"]))]
    pub field_unit: String,
    /// The value in SI units (`si_unit`).
    pub si: f64,
    /// SI unit of `si`.
    #[schemars(extend("enum" = ["m/min", "m", "kW/m", "kJ/m²"]))]
    pub si_unit: String,
    /// NWCG (PMS 437) adjective class: for rate of spread and flame length "Very low" to
    /// "Extreme"; for fireline intensity the Fireline Handbook's classes with the resource
    /// that holds them; null where there is no class (heat per unit area).
    #[schemars(extend("enum" = ["Very low", "Low", "Moderate", "High", "Very high", "Extreme",
        "Low (hand crews)", "Moderate (engines, dozers)", "High (head control doubtful)",
        "Very high (no head control)", null]))]
    pub class: Option<String>,
}

/// Surface fire behaviour at the ignition cell under the day's wind (behave's Rothermel
/// model, the kernel the simulations use).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FireBehaviour {
    /// Fuel model code at the ignition cell, e.g. "FM9" or "GR2".
    pub fuel_model: String,
    /// Fuel model name, e.g. "Long needle or hardwood litter".
    pub fuel_model_name: String,
    /// Land-cover code of the ignition cell in the landscape's scheme.
    pub land_cover_code: u16,
    /// Slope at the ignition cell, percent (rise over run × 100).
    pub slope_pct: f64,
    /// Direction the slope faces, degrees clockwise from true north.
    pub aspect_deg: f64,
    /// Wind at midflame height, miles per hour.
    pub midflame_wind_mph: f64,
    /// Midflame wind over the 20-ft wind (no unit).
    pub wind_adjustment_factor: f64,
    /// Dead 1-hour fuel moisture, percent of dry weight.
    pub dead_1h_pct: f64,
    /// Dead 10-hour fuel moisture, percent of dry weight.
    pub dead_10h_pct: f64,
    /// Dead 100-hour fuel moisture, percent of dry weight.
    pub dead_100h_pct: f64,
    /// Live herbaceous fuel moisture, percent of dry weight.
    pub live_herb_pct: f64,
    /// Live woody fuel moisture, percent of dry weight.
    pub live_woody_pct: f64,
    /// Head-fire rate of spread: chains per hour and metres per minute, with its class.
    pub rate_of_spread: Quantity,
    /// Head-fire flame length: feet and metres, with its class.
    pub flame_length: Quantity,
    /// Head-fire (Byram's) fireline intensity: Btu/ft/s and kW/m, with its class.
    pub fireline_intensity: Quantity,
    /// Heat per unit area: Btu/ft² and kJ/m² (no class).
    pub heat_per_unit_area: Quantity,
    /// Compass bearing the head fire runs toward, degrees clockwise from true north.
    pub head_direction_deg: f64,
    /// Direction the head fire runs toward as a 16-point compass name.
    #[schemars(extend("enum" = ["N", "NNE", "NE", "ENE", "E", "ESE", "SE", "SSE", "S", "SSW", "SW", "WSW", "W", "WNW", "NW", "NNW"]))]
    pub head_direction: String,
    /// Length-to-width ratio of the fire ellipse (no unit).
    pub length_to_width: f64,
    /// The tactic the flame length implies (Fireline Handbook, appendix B), one sentence.
    pub tactic: String,
}

/// A flame-length limit of a suppression resource and the wind that passes it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Contingency {
    /// The flame-length limit, ft (4: hand crews, 8: engines and dozers, 11: any direct
    /// attack at the head).
    pub flame_length_ft: f64,
    /// The resource whose limit it is.
    #[schemars(extend("enum" = ["hand crews (direct attack with hand tools)", "engines, dozers and retardant", "any direct attack at the head"]))]
    pub resource: String,
    /// 10-m wind at which the head-fire flame length reaches the limit, miles per hour
    /// (null: not below `searched_to_mph`; 0: already passed in calm air).
    pub wind_10m_mph: Option<f64>,
    /// Highest 10-m wind searched, miles per hour.
    pub searched_to_mph: f64,
    /// Whether today's head fire already passes the limit.
    pub exceeded_today: bool,
    /// The finding as one sentence.
    pub statement: String,
}

/// An estimate (a mean over runs) with its 95 % bootstrap interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Estimate {
    /// The estimate, in the unit its field names.
    pub value: f64,
    /// Lower end of the 95 % percentile bootstrap interval of the estimate (not of the
    /// runs' spread), same unit.
    pub low: f64,
    /// Upper end of the 95 % percentile bootstrap interval of the estimate, same unit.
    pub high: f64,
}

/// One strategy's simulated fires.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StrategySummary {
    /// The strategy's key: "none" (no suppression), "rule" (the rule-based plan), "ppo"
    /// (the trained agent) or another agent's name.
    pub strategy: String,
    /// The strategy's name for people.
    pub label: String,
    /// What the strategy did, from its ensemble file.
    pub description: String,
    /// Number of runs (simulated fires).
    pub runs: usize,
    /// Mean burnt area over the runs, acres, with its 95 % bootstrap interval.
    pub burned_acres: Estimate,
    /// Mean burnt area over the runs, hectares, with its 95 % bootstrap interval.
    pub burned_hectares: Estimate,
    /// Median burnt area over the runs, acres.
    pub burned_acres_median: f64,
    /// 10th percentile of the runs' burnt areas, acres: one run in ten burns less.
    pub burned_acres_p10: f64,
    /// 90th percentile of the runs' burnt areas, acres: one run in ten burns more.
    pub burned_acres_p90: f64,
    /// Mean burnt area as a share of the landscape's burnable land, percent (0–100).
    pub burned_fraction_pct: f64,
    /// Share of runs whose fire was out — no cell still burning — by the end of the simulated
    /// period (`header.horizon_h`), percent (0–100). A suppressed fire still burning at the
    /// cut-off counts as not out, even when it is smaller than the unsuppressed one.
    pub contained_pct: f64,
    /// Median hours after ignition until the fire went out, over the runs that went out, h
    /// (null: none went out).
    pub containment_hours_median: Option<f64>,
    /// Median over runs of the hour after ignition at which the most cells were burning at
    /// once (the authors' "containment time"), h.
    pub peak_burning_hours_median: f64,
    /// Mean number of helicopter drops per run.
    pub helitacks_mean: f64,
    /// Mean water dropped per run, US gallons.
    pub water_gal_mean: f64,
    /// Burnt area over time: the hours after ignition of the series, h (one per hour).
    pub series_hours: Vec<f64>,
    /// Burnt area over time: mean over runs at each of `series_hours`, acres.
    pub series_acres_mean: Vec<f64>,
    /// Burnt area over time: 10th percentile over runs at each of `series_hours`, acres.
    pub series_acres_p10: Vec<f64>,
    /// Burnt area over time: 90th percentile over runs at each of `series_hours`, acres.
    pub series_acres_p90: Vec<f64>,
    /// Area inside each arrival isochrone as [hours after ignition, acres]: the cells that at
    /// least half of the runs had burnt by then (median arrival).
    pub isochrone_acres: Vec<[f64; 2]>,
}

/// The free (unsuppressed) fire spread by the verified minimum-travel-time engine.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FreeSpread {
    /// The spread engine, as text.
    pub engine: String,
    /// Its runs summarised like a strategy (key "none"; no drops). Its `isochrone_acres` are
    /// the report's isochrones.
    pub fire: StrategySummary,
    /// 10th percentile over runs of the final burnt area, acres.
    pub burned_acres_p10: f64,
    /// 90th percentile over runs of the final burnt area, acres.
    pub burned_acres_p90: f64,
    /// Share of runs in which the free fire reached the grid's outer ring, percent (0–100):
    /// the fire left the simulated landscape, so its burnt area is a lower bound.
    pub edge_runs_pct: f64,
    /// Median, over the runs that reached the outer ring, of the hour it was first reached,
    /// hours after ignition (null: no run reached it).
    pub edge_first_h_median: Option<f64>,
    /// Mean final burnt area of the automaton's unsuppressed runs (`strategies`' "none") on
    /// the same runs, acres, for comparison.
    pub automaton_burned_acres: f64,
    /// [width, height] of the map the free fire burned on, cells (`header.cell_size_ft`
    /// square).
    pub grid_cells: [usize; 2],
    /// [width, height] of the landscape as given, when the map grew until no run reached its
    /// edge (`grow` on the free-spread ensemble), cells (null: the map did not grow).
    pub grown_from_cells: Option<[usize; 2]>,
    /// Whether the grown map held every run (false: it reached its largest size with runs
    /// still reaching the edge; null: the map did not grow).
    pub grown_map_held: Option<bool>,
}

/// A strategy against no suppression on the same seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Comparison {
    /// The strategy compared (a `strategies[].strategy` key).
    pub strategy: String,
    /// The strategy it is compared with: "none" (no suppression).
    #[schemars(extend("enum" = ["none"]))]
    pub baseline: String,
    /// Number of runs both strategies made with the same seed.
    pub paired_runs: usize,
    /// Mean over paired runs of baseline minus strategy burnt area, acres (positive: less
    /// burnt), with its 95 % bootstrap interval.
    pub acres_saved: Estimate,
    /// Mean acres saved over the baseline's mean burnt area, percent.
    pub reduction_pct: f64,
    /// Share of paired runs in which the strategy burnt less, percent (0–100).
    pub runs_better_pct: f64,
    /// Median over the paired runs of the acres saved (baseline's burnt area minus the
    /// strategy's in the same run), acres.
    pub acres_saved_median: f64,
    /// 10th percentile of the paired runs' acres saved, acres.
    pub acres_saved_p10: f64,
    /// 90th percentile of the paired runs' acres saved, acres.
    pub acres_saved_p90: f64,
}

/// One helicopter drop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Drop {
    /// Order of the drop in the run, from 1.
    pub number: usize,
    /// When the drop was made, hours after ignition.
    pub hour: f64,
    /// Latitude of the centre of the cell dropped on, degrees north.
    pub lat: f64,
    /// Longitude of the centre of the cell dropped on, degrees east.
    pub lon: f64,
    /// Column of the cell dropped on in the landscape grid (0 = west edge), cells.
    pub x: i32,
    /// Row of the cell dropped on in the landscape grid (0 = south edge), cells.
    pub y: i32,
    /// Burning cells the drop put out, cells (each `header.cell_size_ft` square).
    pub quenched_cells: u32,
}

/// The drops of the agent's representative run (the run with the median burnt area).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DropPlan {
    /// The strategy whose run it is (the agent's, or the rule-based plan's when the agent's
    /// representative run made no drop; "none" when no strategy dropped).
    pub strategy: String,
    /// Seed of the representative run (null: no run).
    pub run_seed: Option<u64>,
    /// Burnt area of the representative run, acres (null: no run).
    pub run_burned_acres: Option<f64>,
    /// The run's drops in order.
    pub drops: Vec<Drop>,
}

/// Ready, Set, Go: how soon simulated fire can reach an asset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "UPPERCASE")]
pub enum Band {
    Go,
    Set,
    Ready,
    None,
}

impl Band {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Go => "GO",
            Self::Set => "SET",
            Self::Ready => "READY",
            Self::None => "NONE",
        }
    }
}

impl std::fmt::Display for Band {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Where an asset comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum AssetSource {
    Listed,
    Developed,
}

impl AssetSource {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Listed => "listed",
            Self::Developed => "developed",
        }
    }
}

/// A place to protect and its evacuation band.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Asset {
    /// The asset's name (as listed, or "Developed area N").
    pub name: String,
    /// "listed" (named in the request) or "developed" (a patch of the landscape's developed
    /// land).
    pub source: AssetSource,
    /// Latitude of the asset (its central cell), degrees north.
    pub lat: f64,
    /// Longitude of the asset (its central cell), degrees east.
    pub lon: f64,
    /// Area of the asset's cells, acres.
    pub area_acres: f64,
    /// Earliest fire arrival within `evacuation_bands.buffer_ft` of the asset, hours after
    /// ignition (null: never reached): over every run of the free fire of the verified engine
    /// when the report has one (`free_spread`), otherwise over every run of every strategy.
    pub first_arrival_h: Option<f64>,
    /// The strategy of the run that arrived first: "free-spread" for the verified engine's
    /// free fire (null: never reached).
    pub first_arrival_strategy: Option<String>,
    /// Hours after ignition by which fire had reached the asset's buffer in at least half of
    /// the runs of the same fire as `first_arrival_h`, at the latest (the earliest over the
    /// buffer's cells of the hour by which half the runs had burned the cell), h (null: fewer
    /// than half the runs burned any cell of the buffer).
    pub half_runs_by_h: Option<f64>,
    /// Per strategy ("free-spread" first when the verified engine's free fire is given):
    /// [strategy, the highest burn probability among the cells within the buffer in percent
    /// (0–100)] — a lower bound on the share of runs in which fire reached the asset.
    pub reached_pct: Vec<(String, f64)>,
    /// The Ready/Set/Go band: GO when fire can arrive within `go_within_h`, SET within
    /// `set_within_h`, READY within `ready_within_h`, NONE otherwise.
    pub band: Band,
    /// What to do, one sentence.
    pub advice: String,
    /// Hours after ignition at which to move to the next band, h (null in GO and NONE).
    pub trigger_h: Option<f64>,
}

/// The bands of the evacuation advisories.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct EvacuationBands {
    /// GO: earliest arrival within this many hours after ignition, h.
    pub go_within_h: f64,
    /// SET: earliest arrival within this many hours after ignition, h.
    pub set_within_h: f64,
    /// READY: earliest arrival within this many hours after ignition, h.
    pub ready_within_h: f64,
    /// Distance around an asset within which fire counts as reaching it, ft.
    pub buffer_ft: f64,
}

/// A square where suppression paid off most.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PriorityZone {
    /// Rank, 1 = most land kept from burning.
    pub rank: usize,
    /// Latitude of the zone's central cell, degrees north.
    pub lat: f64,
    /// Longitude of the zone's central cell, degrees east.
    pub lon: f64,
    /// The zone's cells: [x0, y0, x1, y1) on the landscape grid (x from the west edge, y
    /// from the south edge; x1 and y1 excluded), cells.
    pub cells: [usize; 4],
    /// Expected acres the agent kept from burning there (burn probability without
    /// suppression minus with the agent, summed over the zone's cells), acres.
    pub acres_protected: f64,
    /// Mean number of the agent's drops in the zone per run.
    pub drops_per_run: f64,
    /// Mean burn probability over the zone's cells without suppression, percent (0–100).
    pub burn_probability_unsuppressed_pct: f64,
    /// Mean burn probability over the zone's cells under the agent, percent (0–100).
    pub burn_probability_agent_pct: f64,
}

/// The overall risk level.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "UPPERCASE")]
pub enum RiskLevel {
    Low,
    Moderate,
    High,
    Severe,
}

impl RiskLevel {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Low => "LOW",
            Self::Moderate => "MODERATE",
            Self::High => "HIGH",
            Self::Severe => "SEVERE",
        }
    }
}

impl std::fmt::Display for RiskLevel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The overall risk level and the rule that set it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Risk {
    /// LOW, MODERATE, HIGH or SEVERE, from the unsuppressed burnt share of burnable land
    /// (below 1, 5, 15 % and above; the verified engine's free fire when given), one level
    /// up when an asset is in GO.
    pub level: RiskLevel,
    /// Mean unsuppressed burnt area as a share of the landscape's burnable land (the verified
    /// engine's free fire when given, else the automaton's), percent (0–100).
    pub burned_fraction_pct: f64,
    /// Number of assets in the GO band.
    pub assets_go: usize,
    /// Number of assets in the SET band.
    pub assets_set: usize,
    /// The rule, as text.
    pub rule: String,
}

/// An input file of the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Lineage {
    /// What the file is to the report, e.g. "ensemble (none)", "forecast", "weather".
    pub role: String,
    /// The file or folder, relative to the project root.
    pub path: String,
    /// What it holds.
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
                 Units are in the field names and each property's description: _h hours (after ignition unless \
                 said otherwise), _acres, _hectares, _pct percent 0–100, _mph miles per hour, _ft feet, _deg \
                 degrees clockwise from true north; the forecast's probability, interval and threshold are 0–1 \
                 fractions; lat/lon are WGS84 degrees."
            )
            .into(),
        );
    }
    schema
}
