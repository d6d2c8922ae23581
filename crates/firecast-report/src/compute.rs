//! From the ensembles, the forecast and the day's weather to every number of the report.

use firecast_episodes::ensemble::{Ensemble, fuel_model_of, is_burnable, is_developed};
use firecast_landscape::Landscape;
use firecast_sim::{FuelMoisture, SpreadInputs, SurfaceFuelBed, Wind};
use serde::{Deserialize, Serialize};

use crate::ReportError;
use crate::model::*;
use crate::units::*;

/// A place the requester wants watched.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AssetSpec {
    pub name: String,
    pub lat: f64,
    pub lon: f64,
}

/// Everything the report is asked for besides its input files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReportSettings {
    pub lat: f64,
    pub lon: f64,
    pub date: String,
    #[serde(default)]
    pub assets: Vec<AssetSpec>,
    /// Treat developed land of the landscape as assets (one per connected patch).
    #[serde(default = "yes")]
    pub developed_land_assets: bool,
    #[serde(default = "default_bands")]
    pub evacuation: EvacuationBands,
    /// Arrival isochrones drawn and exported, hours.
    #[serde(default = "default_isochrones")]
    pub isochrones_h: Vec<f64>,
    /// Side of a suppression-priority zone, cells.
    #[serde(default = "default_zone_cells")]
    pub zone_cells: usize,
    #[serde(default = "default_zones")]
    pub zones: usize,
    #[serde(default = "default_resamples")]
    pub bootstrap_resamples: usize,
    #[serde(default)]
    pub seed: u64,
    /// Title line.
    #[serde(default = "default_title")]
    pub title: String,
}

fn yes() -> bool {
    true
}
fn default_bands() -> EvacuationBands {
    EvacuationBands {
        go_within_h: 6.0,
        set_within_h: 24.0,
        ready_within_h: 72.0,
        buffer_ft: 1000.0,
    }
}
fn default_isochrones() -> Vec<f64> {
    vec![6.0, 12.0, 24.0, 48.0]
}
fn default_zone_cells() -> usize {
    10
}
fn default_zones() -> usize {
    5
}
fn default_resamples() -> usize {
    2000
}
fn default_title() -> String {
    "Fire threat assessment".into()
}

/// The forecast file written by `forecast.predict`.
#[derive(Debug, Clone, Deserialize)]
pub struct ForecastFile {
    pub lat: f64,
    pub lon: f64,
    pub date: String,
    pub cell_lat: f64,
    pub cell_lon: f64,
    pub model: String,
    pub kind: String,
    pub protocol: String,
    pub dataset: String,
    pub dataset_version: String,
    pub input_days: (i32, i32),
    pub threshold: f64,
    pub probability: f64,
    pub interval: [f64; 2],
    pub interval_method: String,
    pub per_seed: Vec<ForecastSeed>,
    pub validation_auroc: Option<f64>,
    pub test_auroc: Option<f64>,
    /// Where and when the model was trained (absent in forecasts of older bundles).
    #[serde(default)]
    pub training_extent: Option<ForecastExtent>,
    #[serde(default)]
    pub inside_training_extent: Option<bool>,
    /// The day's probability (absent in forecasts of older bundles).
    #[serde(default)]
    pub daily: Option<ForecastDaily>,
    #[serde(default)]
    pub daily_unavailable: Option<String>,
}

/// Why a forecast written before 2026-11-28 has no daily probability (it does not say).
pub(crate) const NO_DAILY_REASON: &str = "the forecast does not carry one (written before 2026-11-28)";

/// `forecast.predict`'s `daily`.
#[derive(Debug, Clone, Deserialize)]
pub struct ForecastDaily {
    pub probability: f64,
    pub interval: [f64; 2],
    pub usual: f64,
    pub method: String,
}

/// `forecast.predict`'s `training_extent` (the report reads the file, not the forecasting
/// crate, so it does not link libtorch).
#[derive(Debug, Clone, Deserialize)]
pub struct ForecastExtent {
    pub lat_min: f64,
    pub lat_max: f64,
    pub lon_min: f64,
    pub lon_max: f64,
    pub first_date: String,
    pub last_date: String,
}

#[derive(Debug, Clone, Deserialize)]
pub struct ForecastSeed {
    pub seed: u64,
    pub probability: f64,
    #[serde(default)]
    pub validation_auprc: Option<f64>,
}

/// The day's GRIDMET values at the point (each None when its file is absent).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DayWeather {
    pub cell_lat: f64,
    pub cell_lon: f64,
    pub tmmx_k: Option<f64>,
    pub tmmn_k: Option<f64>,
    pub rmin_pct: Option<f64>,
    pub rmax_pct: Option<f64>,
    pub pr_mm: Option<f64>,
    pub erc: Option<f64>,
    pub bi: Option<f64>,
    pub fm100_pct: Option<f64>,
    pub fm1000_pct: Option<f64>,
    pub vpd_kpa: Option<f64>,
}

/// Inputs of one report.
pub struct Inputs {
    pub ensembles: Vec<Ensemble>,
    /// The free fire of `sim.ensemble` with `engine: mtt` (the verified engine): where given,
    /// it answers where the fire goes and when; the strategies stay on the automaton.
    pub spread: Option<Ensemble>,
    pub forecast: ForecastFile,
    pub weather: DayWeather,
    pub run_id: String,
    pub issued_at: String,
    pub lineage: Vec<Lineage>,
}

/// The landscape and per-strategy rasters the figures need beside the JSON.
pub struct Computed {
    pub report: ThreatReport,
    pub landscape: Landscape,
    /// Ensembles in report order (none first, the agent last).
    pub ensembles: Vec<Ensemble>,
    /// Index of the agent whose drops and isochrones are drawn (None: only no suppression).
    pub agent: Option<usize>,
    pub baseline: usize,
    /// The verified engine's free fire, when given.
    pub spread: Option<Ensemble>,
    /// Asset cells (for the map).
    pub asset_cells: Vec<Vec<usize>>,
}

/// Key of the verified engine's free fire where strategies are listed (assets' arrival).
pub const FREE_SPREAD_KEY: &str = "free-spread";

/// The engine of a `free_spread` ensemble, as the report names it.
pub const FREE_SPREAD_ENGINE: &str = "minimum travel time (firecast-spread, radius-8 stencil), verified against \
     Rothermel's ellipse in docs/results/spread-verification.md";

impl Computed {
    /// The fire that answers where the fire goes and when: the verified engine's free fire
    /// when given, otherwise the automaton's unsuppressed runs.
    pub fn free_fire(&self) -> &Ensemble {
        self.spread.as_ref().unwrap_or(&self.ensembles[self.baseline])
    }
}

pub fn strategy_label(s: &str) -> String {
    match s {
        "none" => "No suppression".into(),
        "rule" => "Rule-based plan".into(),
        "rule-concentric" => "Rule-based plan (concentric)".into(),
        "chaser" => "Helicopter chasing the nearest flames".into(),
        "ppo" => "Trained agent (PPO)".into(),
        other => other.to_string(),
    }
}

fn order(s: &str) -> usize {
    match s {
        "none" => 0,
        "rule" => 1,
        "rule-concentric" => 2,
        "chaser" => 3,
        "ppo" => 4,
        _ => 5,
    }
}

/// Builds the report.
pub fn compute(settings: &ReportSettings, inputs: Inputs) -> Result<Computed, ReportError> {
    let Inputs {
        mut ensembles,
        spread,
        forecast,
        weather,
        run_id,
        issued_at,
        lineage,
    } = inputs;
    if ensembles.is_empty() {
        return Err(ReportError::input("ensembles", "no ensemble was given"));
    }
    ensembles.sort_by_key(|e| order(&e.strategy));
    let first = &ensembles[0];
    for e in &ensembles[1..] {
        if e.grid != first.grid || e.ignition != first.ignition || e.land_cover != first.land_cover {
            return Err(ReportError::input(
                "ensembles",
                format!(
                    "`{}` and `{}` burned different landscapes or ignitions: a report compares strategies on one fire",
                    first.strategy, e.strategy
                ),
            ));
        }
        if e.wind != first.wind || e.perturbation != first.perturbation {
            return Err(ReportError::input(
                "ensembles",
                format!(
                    "`{}` and `{}` ran under different winds or perturbations",
                    first.strategy, e.strategy
                ),
            ));
        }
    }
    let baseline = ensembles
        .iter()
        .position(|e| e.strategy == "none")
        .ok_or_else(|| {
            ReportError::input(
                "ensembles",
                "no `none` (unsuppressed) ensemble: nothing to compare with",
            )
        })?;
    if let Some(sp) = &spread {
        check_spread(sp, &ensembles[baseline])?;
    }
    let agent = ensembles
        .iter()
        .position(|e| e.strategy == "ppo")
        .or_else(|| ensembles.iter().position(|e| e.strategy != "none"));
    let landscape = first.landscape()?;
    let cell_acres = crate::units::cell_acres(first.grid.cell_size_ft);
    let burnable = landscape
        .land_cover
        .iter()
        .filter(|&&c| is_burnable(landscape.scheme, c))
        .count()
        .max(1);
    let horizon_h = f64::from(first.max_steps) * first.step_minutes / 60.0;

    // Header.
    let (cell_lat, cell_lon) = (forecast.cell_lat, forecast.cell_lon);
    let header = Header {
        title: settings.title.clone(),
        lat: settings.lat,
        lon: settings.lon,
        grid_cell_lat: cell_lat,
        grid_cell_lon: cell_lon,
        grid_location: format!("GRIDMET cell {}", lat_lon_text(cell_lat, cell_lon)),
        date: settings.date.clone(),
        issued_at,
        valid_from: format!("{}T00:00 (local)", settings.date),
        valid_until: format!(
            "{} h after ignition on {} ({:.0} days)",
            fmt_num(horizon_h, 0),
            settings.date,
            horizon_h / 24.0
        ),
        horizon_h,
        run_id,
        firecast_version: env!("CARGO_PKG_VERSION").to_string(),
        forecaster: format!(
            "{} ({}, protocol {}, dataset {} {})",
            forecast.model,
            forecast.kind,
            forecast.protocol,
            forecast.dataset,
            short(&forecast.dataset_version)
        ),
        agent: agent.map_or_else(|| "none".to_string(), |a| ensembles[a].description.clone()),
        landscape: format!(
            "{:.1} × {:.1} mi in cells of {} ft ({} m; {} × {} grid), {} land cover, centred near {}",
            first.grid.width as f64 * first.grid.cell_size_ft / 5280.0,
            first.grid.height as f64 * first.grid.cell_size_ft / 5280.0,
            fmt_num(first.grid.cell_size_ft, 0),
            fmt_num(first.grid.cell_size_ft * 0.3048, 0),
            first.grid.width,
            first.grid.height,
            first.grid.scheme,
            lat_lon_text(first.ignition_lat_lon[0], first.ignition_lat_lon[1])
        ),
        cell_size_ft: first.grid.cell_size_ft,
        crs: first.grid.crs.clone(),
    };

    // Weather of the day.
    let wind = first.wind;
    let vs_m_s = first
        .weather
        .as_ref()
        .map_or(wind.speed_mph / MPH_PER_M_S, |w| w.vs_m_s);
    let weather_out = Weather {
        date: settings.date.clone(),
        source: if first.weather.is_some() {
            "GRIDMET (daily, 4 km)".into()
        } else {
            "scenario wind (no GRIDMET day)".into()
        },
        cell_lat: weather.cell_lat,
        cell_lon: weather.cell_lon,
        max_temp_f: weather.tmmx_k.map(k_to_f),
        max_temp_c: weather.tmmx_k.map(k_to_c),
        min_temp_f: weather.tmmn_k.map(k_to_f),
        min_temp_c: weather.tmmn_k.map(k_to_c),
        min_rh_pct: weather.rmin_pct,
        max_rh_pct: weather.rmax_pct,
        precip_in: weather.pr_mm.map(|v| v / 25.4),
        precip_mm: weather.pr_mm,
        wind_10m_mph: vs_m_s * MPH_PER_M_S,
        wind_10m_m_s: vs_m_s,
        wind_from_deg: wind.from_direction_deg,
        wind_from: compass(wind.from_direction_deg).into(),
        erc: weather.erc,
        burning_index: weather.bi,
        fm100_pct: weather.fm100_pct,
        fm1000_pct: weather.fm1000_pct,
        vpd_kpa: weather.vpd_kpa,
    };

    let fc = forecast_block(&forecast);
    let (fire_behaviour, contingencies) = fire_behaviour(first, &landscape)?;

    // Strategies.
    let mut strategies = Vec::new();
    for (k, e) in ensembles.iter().enumerate() {
        strategies.push(strategy_summary(e, settings, cell_acres, burnable, k as u64)?);
    }
    let free_spread = match &spread {
        Some(sp) => {
            let fire = strategy_summary(sp, settings, cell_acres, burnable, ensembles.len() as u64)?;
            let mut acres: Vec<f64> = sp
                .episodes
                .iter()
                .map(|r| f64::from(r.cells_burned) * cell_acres)
                .collect();
            acres.sort_by(f64::total_cmp);
            let edge_hours: Vec<f64> = sp
                .episodes
                .iter()
                .filter(|r| r.edge_cells_burned > 0)
                .filter_map(|r| r.edge_first_hour)
                .collect();
            let edge_runs = sp.episodes.iter().filter(|r| r.edge_cells_burned > 0).count();
            Some(FreeSpread {
                engine: FREE_SPREAD_ENGINE.into(),
                edge_runs_pct: edge_runs as f64 / sp.runs().max(1) as f64 * 100.0,
                edge_first_h_median: (!edge_hours.is_empty()).then(|| median(&edge_hours)),
                burned_acres_p10: percentile(&acres, 0.1),
                burned_acres_p90: percentile(&acres, 0.9),
                automaton_burned_acres: strategies[baseline].burned_acres.value,
                grid_cells: [sp.grid.width, sp.grid.height],
                grown_from_cells: sp.domain.filter(|d| d.base != d.size).map(|d| d.base),
                grown_map_held: sp.domain.filter(|d| d.base != d.size).map(|d| d.contained),
                fire,
            })
        }
        None => None,
    };
    let base = &ensembles[baseline];
    let mut comparisons = Vec::new();
    for (k, e) in ensembles.iter().enumerate() {
        if k == baseline {
            continue;
        }
        comparisons.push(compare(base, e, cell_acres, settings)?);
    }

    // Drops of the agent's representative run.
    // The agent's drops; when its representative run made none (an untrained agent), the
    // drops of the next strategy that made some, and the report says whose they are.
    let dropper = agent.into_iter().chain((0..ensembles.len()).rev()).find(|&k| {
        k != baseline
            && !ensembles[k].episodes[representative_run(&ensembles[k])]
                .drops
                .is_empty()
    });
    let drops = match dropper.or(agent) {
        Some(a) => drop_plan(&ensembles[a], &landscape, cell_acres),
        None => DropPlan {
            strategy: "none".into(),
            run_seed: None,
            run_burned_acres: None,
            drops: Vec::new(),
        },
    };

    // Assets and evacuation bands.
    let (assets, asset_cells) = assets(settings, &ensembles, spread.as_ref(), &landscape, cell_acres)?;

    let priority_zones = match agent {
        Some(a) => priority_zones(base, &ensembles[a], &landscape, settings, cell_acres),
        None => Vec::new(),
    };

    let free_acres = free_spread
        .as_ref()
        .map_or(strategies[baseline].burned_acres.value, |f| {
            f.fire.burned_acres.value
        });
    let burned_fraction_pct = free_acres / cell_acres / burnable as f64 * 100.0;
    let risk = risk(burned_fraction_pct, &assets);

    let moisture = first.moisture;
    let mut assumptions = vec![
        format!(
            "Weather: the {} daily values at {} (the GRIDMET cell nearest the point); the wind is held at its daily mean \
             ({:.1} mi/h at 10 m from {}) for the whole simulation.",
            settings.date,
            lat_lon_text(weather.cell_lat, weather.cell_lon),
            weather_out.wind_10m_mph,
            weather_out.wind_from
        ),
        format!(
            "Fire spread: FireCast's cellular automaton with the {} kernel; one step is {:.1} simulated minutes; the \
             fire starts at the point at hour 0.",
            if moisture.is_some() {
                "Rothermel (behave)"
            } else {
                "Concord (FireCastRL)"
            },
            first.step_minutes
        ),
        format!("Landscape: {}; {}", header.landscape, landscape_source(first)),
        format!(
            "Ensemble: {} runs per strategy, the same runs for every strategy; each run scales the day's wind speed by \
             up to ±{:.0} %, turns it by up to ±{:.0}° and shifts dead fuel moisture by up to ±{:.1} points (uniform \
             draws). Intervals are 95 % percentile bootstrap intervals over runs.",
            ensembles.iter().map(Ensemble::runs).min().unwrap_or(0),
            first.perturbation.wind_speed_frac * 100.0,
            first.perturbation.wind_direction_deg,
            first.perturbation.dead_moisture_frac * 100.0
        ),
        format!(
            "Forecast: model `{}` trained on `{}` ({}), averaged over {} training seeds; the interval is their range, \
             not a calibrated predictive interval. {}",
            forecast.model,
            forecast.dataset,
            short(&forecast.dataset_version),
            forecast.per_seed.len(),
            match &forecast.daily {
                Some(d) => format!(
                    "The model scores on its training samples' scale (about 40 % fires); the day's probability is \
                     {}. Its calibration over all cell-days is measured by forecast.cell_days (docs/results/table3.md).",
                    d.method
                ),
                None => format!(
                    "The model scores on its training samples' scale (about 40 % fires), not a daily chance; no daily \
                     probability is given: {}.",
                    forecast.daily_unavailable.as_deref().unwrap_or(NO_DAILY_REASON)
                ),
            }
        ),
        if spread.is_some() {
            "Times are hours after ignition; areas are acres and hectares. Evacuation bands use the earliest \
             arrival within the asset buffer over every run of the verified engine's free fire (the worst case \
             without suppression)."
                .into()
        } else {
            "Times are hours after ignition; areas are acres and hectares. Evacuation bands use the earliest arrival \
             within the asset buffer over every run of every strategy (the worst case)."
                .into()
        },
    ];
    if let Some(f) = &free_spread {
        // Which engine drew what, with both engines' free fires measured on the same runs.
        assumptions.insert(
            2,
            format!(
                "Where the fire goes and when: the minimum-travel-time engine verified against Rothermel's ellipse \
                 (docs/results/spread-verification.md) draws the isochrones, the final perimeter, the burn \
                 probability, the GeoTIFFs, the free fire's burnt area, the assets' arrival and the risk level; the \
                 strategies are compared on FireCastRL's automaton because drops act on its state; the automaton's \
                 free fire burned {} acres against the verified engine's {} (means over {} and {} runs; the \
                 automaton's head advances at most 2.5 cells a step).",
                fmt_num(f.automaton_burned_acres, 0),
                fmt_num(f.fire.burned_acres.value, 0),
                strategies[baseline].runs,
                f.fire.runs
            ),
        );
    }
    let day_moisture = first.weather.as_ref().and_then(|w| w.fuel_moisture.as_ref());
    if let Some(d) = day_moisture {
        assumptions.push(format!(
            "Fuel moistures are the day's (dead 1/10/100/1000-h {:.1}/{:.1}/{:.1}/{:.1} %, live herbaceous {:.0} %, \
             woody {:.0} %): {}.",
            d.dead_1h_pct,
            d.dead_10h_pct,
            d.dead_100h_pct,
            d.dead_1000h_pct,
            d.live_herbaceous_pct,
            d.live_woody_pct,
            d.sources.join("; ")
        ));
    } else if let Some(m) = moisture {
        assumptions.push(format!(
            "Fuel moistures are the scenario's fixed values (dead 1/10/100-h {:.0}/{:.0}/{:.0} %, live herbaceous {:.0} %, \
             woody {:.0} %), not derived from the day's GRIDMET 100-h moisture{}.",
            m.dead_1h_frac * 100.0,
            m.dead_10h_frac * 100.0,
            m.dead_100h_frac * 100.0,
            m.live_herb_frac * 100.0,
            m.live_woody_frac * 100.0,
            weather
                .fm100_pct
                .map_or(String::new(), |v| format!(" ({v:.1} %)"))
        ));
    }
    let mut what_would_change = vec![
        "A stronger or shifting wind: the contingency table gives the wind at which each suppression limit is \
         passed."
            .to_string(),
        "Drier fuels than assumed (a lower 1-h moisture raises spread rate and flame length).".into(),
        "An ignition elsewhere than the point: arrival times are measured from this ignition.".into(),
        "Suppression resources other than the simulated helicopter (drops of 800 gal, one per step at most).".into(),
    ];
    if fc.ignition_expected {
        what_would_change
            .push("Rain or higher humidity on the day would lower the score of the next forecast.".into());
    } else {
        what_would_change.push(format!(
            "The forecast's score is below its alert threshold ({:.2}); the simulations show what happens if a fire \
             starts anyway.",
            fc.threshold
        ));
    }

    let report = ThreatReport {
        schema: SCHEMA_ID.into(),
        schema_version: SCHEMA_VERSION.into(),
        header,
        weather: weather_out,
        forecast: fc,
        fire_behaviour,
        contingencies,
        free_spread,
        strategies,
        comparisons,
        drops,
        assets,
        evacuation_bands: settings.evacuation.clone(),
        priority_zones,
        risk,
        assumptions,
        what_would_change,
        lineage,
    };
    Ok(Computed {
        report,
        landscape,
        ensembles,
        agent,
        baseline,
        spread,
        asset_cells,
    })
}

/// The free fire must be the verified engine's, on the automaton's fire: same landscape,
/// ignition, wind and perturbations, and the same seeds.
fn check_spread(sp: &Ensemble, base: &Ensemble) -> Result<(), ReportError> {
    let bad = |m: String| Err(ReportError::input("spread", m));
    if sp.strategy != "none" || sp.description != firecast_episodes::free_spread::MTT_DESCRIPTION {
        return bad(format!(
            "`{}` ({}) is not a free fire of the minimum-travel-time engine: give `sim.ensemble` with `engine: mtt`",
            sp.strategy, sp.description
        ));
    }
    if sp.grid != base.grid || sp.ignition != base.ignition || sp.land_cover != base.land_cover {
        return bad("burned another landscape or ignition than the strategies' ensembles".into());
    }
    if sp.wind != base.wind || sp.perturbation != base.perturbation || sp.moisture != base.moisture {
        return bad("ran under another wind, moisture or perturbation than the strategies' ensembles".into());
    }
    let seeds = |e: &Ensemble| e.episodes.iter().map(|r| r.seed).collect::<Vec<_>>();
    if seeds(sp) != seeds(base) {
        return bad(
            "ran other seeds than the unsuppressed automaton: give both the same `runs` and `seed`".into(),
        );
    }
    Ok(())
}

/// What the landscape is and where its fuels come from: the landscape's own line (LANDFIRE's
/// files, window and cell counts; the synthetic world's seed) and, for land cover classes, the
/// crosswalk to fuel models.
fn landscape_source(e: &Ensemble) -> String {
    let mut parts = Vec::new();
    if let Some(label) = &e.landscape {
        parts.push(label.note.trim_end_matches('.').to_string());
    }
    if e.grid.scheme.contains("modis") {
        parts.push("land cover is mapped to fuel models by FireCast's MODIS crosswalk".to_string());
    }
    if parts.is_empty() {
        parts.push("land cover codes are fuel models".to_string());
    }
    format!("{}.", parts.join("; "))
}

fn short(version: &str) -> &str {
    &version[..version.len().min(12)]
}

fn forecast_block(f: &ForecastFile) -> Forecast {
    let auprc: Vec<f64> = f.per_seed.iter().filter_map(|s| s.validation_auprc).collect();
    let interval_method = if f.interval[1] - f.interval[0] < 1e-9 {
        format!(
            "{} — no spread: {}",
            f.interval_method,
            if f.per_seed.len() < 2 {
                "one trained model, so no interval"
            } else {
                "the seeds agree (the model does not depend on its seed)"
            }
        )
    } else {
        f.interval_method.clone()
    };
    Forecast {
        probability: f.probability,
        interval: f.interval,
        interval_method,
        threshold: f.threshold,
        ignition_expected: f.probability > f.threshold,
        daily_probability: f.daily.as_ref().map(|d| d.probability),
        daily_interval: f.daily.as_ref().map(|d| d.interval),
        usual_daily_probability: f.daily.as_ref().map(|d| d.usual),
        daily_method: f.daily.as_ref().map(|d| d.method.clone()),
        daily_unavailable: f.daily_unavailable.clone(),
        model: f.model.clone(),
        kind: f.kind.clone(),
        protocol: f.protocol.clone(),
        dataset: f.dataset.clone(),
        dataset_version: f.dataset_version.clone(),
        seeds: f.per_seed.len(),
        validation_auroc: f.validation_auroc,
        validation_auprc: (!auprc.is_empty()).then(|| auprc.iter().sum::<f64>() / auprc.len() as f64),
        test_auroc: f.test_auroc,
        input_days: [f.input_days.0, f.input_days.1],
        pattern: None,
        training_area: f.training_extent.as_ref().map(|e| TrainingArea {
            lat_min: e.lat_min,
            lat_max: e.lat_max,
            lon_min: e.lon_min,
            lon_max: e.lon_max,
            first_date: e.first_date.clone(),
            last_date: e.last_date.clone(),
            place_inside: f.inside_training_extent.unwrap_or(true),
        }),
    }
}

/// Slope (percent) and aspect (degrees the slope faces, clockwise from north) at a cell, by
/// central differences (one-sided at the edges).
pub fn slope_aspect(land: &Landscape, x: usize, y: usize) -> (f64, f64) {
    let (w, h) = (land.width, land.height);
    let z = |x: usize, y: usize| f64::from(land.elevation_ft[y * w + x]);
    let (x0, x1) = (x.saturating_sub(1), (x + 1).min(w - 1));
    let (y0, y1) = (y.saturating_sub(1), (y + 1).min(h - 1));
    let c = land.cell_size_ft;
    let gx = if x1 > x0 {
        (z(x1, y) - z(x0, y)) / ((x1 - x0) as f64 * c)
    } else {
        0.0
    };
    // Row 0 is south: y grows northward.
    let gy = if y1 > y0 {
        (z(x, y1) - z(x, y0)) / ((y1 - y0) as f64 * c)
    } else {
        0.0
    };
    let slope = 100.0 * gx.hypot(gy);
    // The slope faces downhill: bearing of (−gx, −gy).
    let aspect = (-gx).atan2(-gy).to_degrees().rem_euclid(360.0);
    (slope, aspect)
}

fn fire_behaviour(e: &Ensemble, land: &Landscape) -> Result<(FireBehaviour, Vec<Contingency>), ReportError> {
    let [x, y] = e.ignition;
    let code = land.land_cover[land.index(x, y)];
    let model = fuel_model_of(land.scheme, code)
        .ok_or_else(|| ReportError::input("ensembles", format!("land cover {code} has no fuel model")))?;
    // The Concord kernel has no moisture scenario: describe behaviour with behave's dry
    // summer default, as the Rothermel kernel would.
    let moisture = e
        .moisture
        .unwrap_or_else(|| FuelMoisture::from_percent(6.0, 7.0, 8.0, 60.0, 90.0));
    let bed =
        SurfaceFuelBed::new(model, &moisture).map_err(|err| ReportError::input("fuel", err.to_string()))?;
    let (slope, aspect) = slope_aspect(land, x, y);
    let upslope = (aspect + 180.0).rem_euclid(360.0);
    let toward = (e.wind.from_direction_deg + 180.0).rem_euclid(360.0);
    let behave_at = |wind: Wind| {
        let inputs = SpreadInputs {
            midflame_wind_mph: wind.midflame_mph(model.depth_ft),
            slope_percent: slope,
            wind_dir_from_upslope_deg: (toward - upslope).rem_euclid(360.0),
        };
        bed.spread(&inputs)
    };
    let b = behave_at(e.wind);
    let ros_chph = b.head_ros_chph();
    let fl_ft = b.flame_length_ft;
    let fli = b.fireline_intensity_btu_ft_s;
    let hpa = b.heat_per_unit_area_btu_ft2;
    let head = (upslope + b.dir_max_spread_from_upslope_deg).rem_euclid(360.0);
    let midflame = e.wind.midflame_mph(model.depth_ft);
    let waf = if e.wind.speed_mph > 0.0 {
        midflame / e.wind.speed_mph
    } else {
        firecast_sim::unsheltered_waf(model.depth_ft)
    };
    let fb = FireBehaviour {
        fuel_model: model.code.to_string(),
        fuel_model_name: model.name.to_string(),
        land_cover_code: code,
        slope_pct: slope,
        aspect_deg: aspect,
        midflame_wind_mph: midflame,
        wind_adjustment_factor: waf,
        dead_1h_pct: moisture.dead_1h_frac * 100.0,
        dead_10h_pct: moisture.dead_10h_frac * 100.0,
        dead_100h_pct: moisture.dead_100h_frac * 100.0,
        live_herb_pct: moisture.live_herb_frac * 100.0,
        live_woody_pct: moisture.live_woody_frac * 100.0,
        rate_of_spread: Quantity {
            field: ros_chph,
            field_unit: "ch/h".into(),
            si: ros_chph * M_MIN_PER_CH_H,
            si_unit: "m/min".into(),
            class: Some(ros_class(ros_chph).into()),
        },
        flame_length: Quantity {
            field: fl_ft,
            field_unit: "ft".into(),
            si: fl_ft * M_PER_FT,
            si_unit: "m".into(),
            class: Some(flame_class(fl_ft).into()),
        },
        fireline_intensity: Quantity {
            field: fli,
            field_unit: "Btu/ft/s".into(),
            si: fli * KW_M_PER_BTU_FT_S,
            si_unit: "kW/m".into(),
            class: Some(intensity_class(fli).into()),
        },
        heat_per_unit_area: Quantity {
            field: hpa,
            field_unit: "Btu/ft²".into(),
            si: hpa * KJ_M2_PER_BTU_FT2,
            si_unit: "kJ/m²".into(),
            class: None,
        },
        head_direction_deg: head,
        head_direction: compass(head).into(),
        length_to_width: b.length_to_width_ratio,
        tactic: tactic(fl_ft).into(),
    };
    // The wind (at the ensemble's measuring height) that takes the head fire to each limit.
    let search_to = 100.0;
    let fl_at = |mph: f64| {
        behave_at(Wind {
            speed_mph: mph,
            ..e.wind
        })
        .flame_length_ft
    };
    let mut contingencies = Vec::new();
    for (limit, resource) in [
        (4.0, "hand crews (direct attack with hand tools)"),
        (8.0, "engines, dozers and retardant"),
        (11.0, "any direct attack at the head"),
    ] {
        let exceeded_today = fl_ft > limit;
        let wind = if fl_at(0.0) > limit {
            Some(0.0)
        } else if fl_at(search_to) <= limit {
            None
        } else {
            let (mut lo, mut hi) = (0.0, search_to);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if fl_at(mid) > limit {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            Some(hi)
        };
        let statement = match wind {
            Some(w) if w <= 0.0 => format!(
                "Flame length passes {limit} ft even in calm air in {}: beyond {resource}.",
                model.code
            ),
            Some(w) => format!(
                "Above {:.0} mi/h of 10-m wind from {} the head fire passes {limit} ft: beyond {resource}{}.",
                w,
                compass(e.wind.from_direction_deg),
                if exceeded_today {
                    " — already the case today"
                } else {
                    ""
                }
            ),
            None => format!(
                "Flame length stays below {limit} ft up to {search_to:.0} mi/h of wind: within reach of {resource}."
            ),
        };
        contingencies.push(Contingency {
            flame_length_ft: limit,
            resource: resource.into(),
            wind_10m_mph: wind,
            searched_to_mph: search_to,
            exceeded_today,
            statement,
        });
    }
    Ok((fb, contingencies))
}

/// Per-run burned cells at step k (a finished run keeps its final area).
fn burned_at(e: &firecast_episodes::ensemble::EpisodeRecord, k: usize) -> u32 {
    let s = &e.burned_per_step;
    s.get(k).or_else(|| s.last()).copied().unwrap_or(0)
}

fn mean_interval(values: &[f64], settings: &ReportSettings, salt: u64) -> Result<Estimate, ReportError> {
    let y = vec![false; values.len()];
    let ci = firecast_eval::bootstrap::ci(
        &y,
        values,
        None,
        settings.bootstrap_resamples,
        settings.seed ^ salt.wrapping_mul(0x9E37_79B9_7F4A_7C15),
        0.95,
        |_, p| (!p.is_empty()).then(|| p.iter().sum::<f64>() / p.len() as f64),
    )
    .map_err(|e| ReportError::input("bootstrap", e.to_string()))?;
    Ok(Estimate {
        value: ci.estimate,
        low: ci.low,
        high: ci.high,
    })
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let pos = q * (sorted.len() - 1) as f64;
    let (i, f) = (pos.floor() as usize, pos - pos.floor());
    let j = (i + 1).min(sorted.len() - 1);
    sorted[i] + f * (sorted[j] - sorted[i])
}

fn median(values: &[f64]) -> f64 {
    sorted_percentile(values, 0.5)
}

/// Percentile of unsorted values.
fn sorted_percentile(values: &[f64], q: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    percentile(&v, q)
}

fn strategy_summary(
    e: &Ensemble,
    settings: &ReportSettings,
    cell_acres: f64,
    burnable: usize,
    salt: u64,
) -> Result<StrategySummary, ReportError> {
    let acres: Vec<f64> = e
        .episodes
        .iter()
        .map(|r| f64::from(r.cells_burned) * cell_acres)
        .collect();
    let burned_acres = mean_interval(&acres, settings, salt)?;
    let ha = |v: f64| v * HA_PER_ACRE;
    let contained: Vec<f64> = e
        .episodes
        .iter()
        .filter(|r| r.contained)
        .map(|r| r.hours)
        .collect();
    let peak: Vec<f64> = e.episodes.iter().map(|r| r.peak_burning_hour).collect();
    // Hourly series (one point every hour of simulated time, up to the longest run).
    let steps = e
        .episodes
        .iter()
        .map(|r| r.burned_per_step.len())
        .max()
        .unwrap_or(1);
    let per_hour = (60.0 / e.step_minutes).max(1e-9);
    let hours_total = ((steps - 1) as f64 / per_hour).ceil() as usize;
    let (mut hours, mut mean, mut p10, mut p90) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for hr in 0..=hours_total {
        let k = ((hr as f64 * per_hour).round() as usize).min(steps - 1);
        let mut v: Vec<f64> = e
            .episodes
            .iter()
            .map(|r| f64::from(burned_at(r, k)) * cell_acres)
            .collect();
        v.sort_by(f64::total_cmp);
        hours.push(hr as f64);
        mean.push(v.iter().sum::<f64>() / v.len() as f64);
        p10.push(percentile(&v, 0.1));
        p90.push(percentile(&v, 0.9));
    }
    let isochrone_acres = settings
        .isochrones_h
        .iter()
        .map(|&t| {
            let n = e
                .arrival_median_h
                .iter()
                .flatten()
                .filter(|&&a| f64::from(a) <= t)
                .count();
            [t, n as f64 * cell_acres]
        })
        .collect();
    Ok(StrategySummary {
        strategy: e.strategy.clone(),
        label: strategy_label(&e.strategy),
        description: e.description.clone(),
        runs: e.runs(),
        burned_acres,
        burned_hectares: Estimate {
            value: ha(burned_acres.value),
            low: ha(burned_acres.low),
            high: ha(burned_acres.high),
        },
        burned_acres_median: median(&acres),
        burned_acres_p10: sorted_percentile(&acres, 0.1),
        burned_acres_p90: sorted_percentile(&acres, 0.9),
        burned_fraction_pct: burned_acres.value / cell_acres / burnable as f64 * 100.0,
        contained_pct: contained.len() as f64 / e.runs() as f64 * 100.0,
        containment_hours_median: (!contained.is_empty()).then(|| median(&contained)),
        peak_burning_hours_median: median(&peak),
        helitacks_mean: e.episodes.iter().map(|r| f64::from(r.helitacks)).sum::<f64>() / e.runs() as f64,
        water_gal_mean: e.episodes.iter().map(|r| r.water_used_gal).sum::<f64>() / e.runs() as f64,
        series_hours: hours,
        series_acres_mean: mean,
        series_acres_p10: p10,
        series_acres_p90: p90,
        isochrone_acres,
    })
}

fn compare(
    base: &Ensemble,
    e: &Ensemble,
    cell_acres: f64,
    settings: &ReportSettings,
) -> Result<Comparison, ReportError> {
    let by_seed: std::collections::BTreeMap<u64, u32> =
        base.episodes.iter().map(|r| (r.seed, r.cells_burned)).collect();
    let (mut b, mut s) = (Vec::new(), Vec::new());
    for r in &e.episodes {
        if let Some(&c) = by_seed.get(&r.seed) {
            b.push(f64::from(c) * cell_acres);
            s.push(f64::from(r.cells_burned) * cell_acres);
        }
    }
    if b.is_empty() {
        return Err(ReportError::input(
            "ensembles",
            format!(
                "`{}` and `none` share no seed: run both with the same `seed`",
                e.strategy
            ),
        ));
    }
    let y = vec![false; b.len()];
    let mean = |_: &[bool], p: &[f64]| (!p.is_empty()).then(|| p.iter().sum::<f64>() / p.len() as f64);
    let d = firecast_eval::bootstrap::paired_diff_ci(
        &y,
        &b,
        &s,
        None,
        settings.bootstrap_resamples,
        settings.seed ^ 0x5EED,
        0.95,
        mean,
    )
    .map_err(|err| ReportError::input("bootstrap", err.to_string()))?;
    let base_mean = b.iter().sum::<f64>() / b.len() as f64;
    let better = b.iter().zip(&s).filter(|(b, s)| s < b).count();
    let saved: Vec<f64> = b.iter().zip(&s).map(|(b, s)| b - s).collect();
    Ok(Comparison {
        strategy: e.strategy.clone(),
        baseline: base.strategy.clone(),
        paired_runs: b.len(),
        acres_saved: Estimate {
            value: d.estimate,
            low: d.low,
            high: d.high,
        },
        reduction_pct: if base_mean > 0.0 {
            d.estimate / base_mean * 100.0
        } else {
            0.0
        },
        runs_better_pct: better as f64 / b.len() as f64 * 100.0,
        acres_saved_median: median(&saved),
        acres_saved_p10: sorted_percentile(&saved, 0.1),
        acres_saved_p90: sorted_percentile(&saved, 0.9),
    })
}

/// The run with the median burnt area (the lower one for an even count).
pub fn representative_run(e: &Ensemble) -> usize {
    let mut idx: Vec<usize> = (0..e.runs()).collect();
    idx.sort_by_key(|&i| (e.episodes[i].cells_burned, e.episodes[i].seed));
    idx[(idx.len() - 1) / 2]
}

fn drop_plan(e: &Ensemble, land: &Landscape, cell_acres: f64) -> DropPlan {
    let run = &e.episodes[representative_run(e)];
    let drops = run
        .drops
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let (x, y) = (
                d.x.clamp(0, land.width as i32 - 1) as usize,
                d.y.clamp(0, land.height as i32 - 1) as usize,
            );
            let (lat, lon) = land.cell_to_lat_lon(x, y);
            Drop {
                number: i + 1,
                hour: d.hour,
                lat,
                lon,
                x: d.x,
                y: d.y,
                quenched_cells: d.quenched,
            }
        })
        .collect();
    DropPlan {
        strategy: e.strategy.clone(),
        run_seed: Some(run.seed),
        run_burned_acres: Some(f64::from(run.cells_burned) * cell_acres),
        drops,
    }
}

/// Cells within `r` cells (Chebyshev) of any of `cells`.
fn buffer(land: &Landscape, cells: &[usize], r: usize) -> Vec<usize> {
    let (w, h) = (land.width, land.height);
    let mut mark = vec![false; w * h];
    for &c in cells {
        let (x, y) = (c % w, c / w);
        for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
            for xx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                mark[yy * w + xx] = true;
            }
        }
    }
    (0..w * h).filter(|&i| mark[i]).collect()
}

/// Connected (8-neighbour) patches of developed land.
fn developed_patches(land: &Landscape) -> Vec<Vec<usize>> {
    let (w, h) = (land.width, land.height);
    let dev: Vec<bool> = land
        .land_cover
        .iter()
        .map(|&c| is_developed(land.scheme, c))
        .collect();
    let mut seen = vec![false; w * h];
    let mut patches = Vec::new();
    for start in 0..w * h {
        if !dev[start] || seen[start] {
            continue;
        }
        let mut patch = Vec::new();
        let mut stack = vec![start];
        seen[start] = true;
        while let Some(c) = stack.pop() {
            patch.push(c);
            let (x, y) = ((c % w) as i64, (c / w) as i64);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let n = ny as usize * w + nx as usize;
                    if dev[n] && !seen[n] {
                        seen[n] = true;
                        stack.push(n);
                    }
                }
            }
        }
        patch.sort_unstable();
        patches.push(patch);
    }
    patches
}

fn assets(
    settings: &ReportSettings,
    ensembles: &[Ensemble],
    spread: Option<&Ensemble>,
    land: &Landscape,
    cell_acres: f64,
) -> Result<(Vec<Asset>, Vec<Vec<usize>>), ReportError> {
    let bands = &settings.evacuation;
    let r = (bands.buffer_ft / land.cell_size_ft).round().max(0.0) as usize;
    let mut list: Vec<(String, AssetSource, Vec<usize>)> = Vec::new();
    for (i, a) in settings.assets.iter().enumerate() {
        let (x, y) = land.lat_lon_to_cell(a.lat, a.lon).ok_or_else(|| {
            ReportError::input(
                format!("assets[{i}]"),
                format!(
                    "`{}` at ({}, {}) is outside the simulated landscape",
                    a.name, a.lat, a.lon
                ),
            )
        })?;
        list.push((a.name.clone(), AssetSource::Listed, vec![land.index(x, y)]));
    }
    if settings.developed_land_assets {
        for (k, patch) in developed_patches(land).into_iter().enumerate() {
            list.push((format!("Developed area {}", k + 1), AssetSource::Developed, patch));
        }
    }
    let mut out = Vec::new();
    let mut cells_out = Vec::new();
    for (name, source, cells) in list {
        let zone = buffer(land, &cells, r);
        let (mut first, mut who) = (f64::INFINITY, None);
        let mut half = f64::INFINITY;
        let mut reached = Vec::new();
        // With the verified engine's free fire, arrival comes from it alone (the automaton's
        // capped head arrives late); its reach is listed first, the strategies' after it.
        let arriving: Vec<(&Ensemble, String)> = match spread {
            Some(sp) => std::iter::once((sp, FREE_SPREAD_KEY.to_string()))
                .chain(ensembles.iter().map(|e| (e, e.strategy.clone())))
                .collect(),
            None => ensembles.iter().map(|e| (e, e.strategy.clone())).collect(),
        };
        for (k, (e, key)) in arriving.iter().enumerate() {
            let counts_arrival = spread.is_none() || k == 0;
            // The ensemble keeps per-cell statistics over runs: the earliest arrival in the
            // zone is the minimum of its cells' earliest arrivals; the share of runs that
            // reached the zone is at least the burn probability of its most-burned cell.
            let mut best_count = 0u32;
            for &c in &zone {
                if let Some(t) = e.arrival_median_h[c].filter(|_| counts_arrival) {
                    half = half.min(f64::from(t));
                }
                if let Some(t) = e.arrival_first_h[c].filter(|_| counts_arrival) {
                    let t = f64::from(t);
                    if t < first {
                        first = t;
                        who = Some(key.clone());
                    }
                }
                best_count = best_count.max(e.burn_count[c]);
            }
            reached.push((key.clone(), f64::from(best_count) / e.runs() as f64 * 100.0));
        }
        let first_arrival = first.is_finite().then_some(first);
        let (band, advice, trigger) = match first_arrival {
            Some(t) if t <= bands.go_within_h => (
                Band::Go,
                format!(
                    "Fire can reach it within {} h of ignition: evacuate as soon as a fire is reported.",
                    fmt_num(t, 1)
                ),
                None,
            ),
            Some(t) if t <= bands.set_within_h => (
                Band::Set,
                format!(
                    "Earliest arrival {} h after ignition: be ready to leave; move to GO at hour {} ({} h before arrival).",
                    fmt_num(t, 1),
                    fmt_num(t - bands.go_within_h, 1),
                    fmt_num(bands.go_within_h, 0)
                ),
                Some(t - bands.go_within_h),
            ),
            Some(t) if t <= bands.ready_within_h => (
                Band::Ready,
                format!(
                    "Earliest arrival {} h after ignition: prepare; move to SET at hour {}.",
                    fmt_num(t, 1),
                    fmt_num(t - bands.set_within_h, 1)
                ),
                Some(t - bands.set_within_h),
            ),
            Some(t) => (
                Band::None,
                format!(
                    "Reached only after {} h in the worst run; watch for changes.",
                    fmt_num(t, 1)
                ),
                None,
            ),
            None => (Band::None, "No simulated fire reached it.".to_string(), None),
        };
        let (cx, cy) = centroid(land, &cells);
        let (lat, lon) = land.cell_to_lat_lon(cx, cy);
        out.push(Asset {
            name,
            source,
            lat,
            lon,
            area_acres: cells.len() as f64 * cell_acres,
            first_arrival_h: first_arrival,
            first_arrival_strategy: who.filter(|_| first_arrival.is_some()),
            half_runs_by_h: half.is_finite().then_some(half),
            reached_pct: reached,
            band,
            advice,
            trigger_h: trigger,
        });
        cells_out.push(cells);
    }
    // Most urgent first.
    let mut idx: Vec<usize> = (0..out.len()).collect();
    idx.sort_by(|&a, &b| {
        let ta = out[a].first_arrival_h.unwrap_or(f64::INFINITY);
        let tb = out[b].first_arrival_h.unwrap_or(f64::INFINITY);
        ta.total_cmp(&tb).then(a.cmp(&b))
    });
    Ok((
        idx.iter().map(|&i| out[i].clone()).collect(),
        idx.iter().map(|&i| cells_out[i].clone()).collect(),
    ))
}

/// The cell of `cells` nearest their mean position.
fn centroid(land: &Landscape, cells: &[usize]) -> (usize, usize) {
    let w = land.width;
    let n = cells.len().max(1) as f64;
    let mx = cells.iter().map(|c| (c % w) as f64).sum::<f64>() / n;
    let my = cells.iter().map(|c| (c / w) as f64).sum::<f64>() / n;
    let best = cells
        .iter()
        .min_by(|&&a, &&b| {
            let da = ((a % w) as f64 - mx).powi(2) + ((a / w) as f64 - my).powi(2);
            let db = ((b % w) as f64 - mx).powi(2) + ((b / w) as f64 - my).powi(2);
            da.total_cmp(&db).then(a.cmp(&b))
        })
        .copied()
        .unwrap_or(0);
    (best % w, best / w)
}

fn priority_zones(
    base: &Ensemble,
    agent: &Ensemble,
    land: &Landscape,
    settings: &ReportSettings,
    cell_acres: f64,
) -> Vec<PriorityZone> {
    let (w, h) = (land.width, land.height);
    let z = settings.zone_cells.max(1);
    let (nb, na) = (base.runs() as f64, agent.runs() as f64);
    let mut drops = vec![0usize; w * h];
    for r in &agent.episodes {
        for d in &r.drops {
            if d.x >= 0 && d.y >= 0 && (d.x as usize) < w && (d.y as usize) < h {
                drops[d.y as usize * w + d.x as usize] += 1;
            }
        }
    }
    let mut zones = Vec::new();
    for by in (0..h).step_by(z) {
        for bx in (0..w).step_by(z) {
            let (x1, y1) = ((bx + z).min(w), (by + z).min(h));
            let (mut pb, mut pa, mut d, mut n) = (0.0, 0.0, 0usize, 0usize);
            for y in by..y1 {
                for x in bx..x1 {
                    let i = y * w + x;
                    pb += f64::from(base.burn_count[i]) / nb;
                    pa += f64::from(agent.burn_count[i]) / na;
                    d += drops[i];
                    n += 1;
                }
            }
            let protected = (pb - pa) * cell_acres;
            if protected > 0.0 {
                zones.push((protected, bx, by, x1, y1, d, pb / n as f64, pa / n as f64));
            }
        }
    }
    zones.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    zones
        .into_iter()
        .take(settings.zones)
        .enumerate()
        .map(|(k, (protected, x0, y0, x1, y1, d, pb, pa))| {
            let (lat, lon) = land.cell_to_lat_lon((x0 + x1 - 1) / 2, (y0 + y1 - 1) / 2);
            PriorityZone {
                rank: k + 1,
                lat,
                lon,
                cells: [x0, y0, x1, y1],
                acres_protected: protected,
                drops_per_run: d as f64 / na,
                burn_probability_unsuppressed_pct: pb * 100.0,
                burn_probability_agent_pct: pa * 100.0,
            }
        })
        .collect()
}

fn risk(burned_fraction_pct: f64, assets: &[Asset]) -> Risk {
    let levels = [
        RiskLevel::Low,
        RiskLevel::Moderate,
        RiskLevel::High,
        RiskLevel::Severe,
    ];
    let mut k = if burned_fraction_pct < 1.0 {
        0
    } else if burned_fraction_pct < 5.0 {
        1
    } else if burned_fraction_pct < 15.0 {
        2
    } else {
        3
    };
    let go = assets.iter().filter(|a| a.band == Band::Go).count();
    let set = assets.iter().filter(|a| a.band == Band::Set).count();
    if go > 0 {
        k = (k + 1).min(3);
    }
    Risk {
        level: levels[k],
        burned_fraction_pct,
        assets_go: go,
        assets_set: set,
        rule: "From the mean unsuppressed burnt share of the landscape's burnable land: LOW below 1 %, MODERATE \
               below 5 %, HIGH below 15 %, SEVERE above; one level higher when any asset is in the GO band."
            .into(),
    }
}
