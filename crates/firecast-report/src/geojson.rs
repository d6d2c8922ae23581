//! The report for GIS users: arrival isochrones (median over runs) per strategy,
//! burn-probability zones, drops, assets with their bands, priority zones and the ignition,
//! as one RFC 7946 FeatureCollection in WGS84 with valid OGC geometries.
//!
//! Property conventions (documented per property in `docs/guides/report.md`, "GeoJSON
//! properties"): times are hours after ignition (`_h`), probabilities and shares percent
//! 0–100 (`_pct`), areas acres and hectares (`_acres`, `_ha`); every feature has `kind`.

use serde_json::{Value, json};

use crate::ReportError;
use crate::compute::Computed;
use crate::geometry::{self, geojson_multipolygon, round7};
use crate::units::HA_PER_ACRE;

/// `engine` of the features drawn from the verified engine's free fire.
pub const ENGINE_MTT: &str = "minimum travel time";
/// `engine` of the features drawn from FireCastRL's automaton (every strategy).
pub const ENGINE_AUTOMATON: &str = "automaton";

/// The minimum burn probabilities of the burn-probability zones, percent.
pub const BURN_PROBABILITY_ZONES_PCT: [f64; 3] = [10.0, 50.0, 90.0];

fn point(lat: f64, lon: f64) -> Value {
    json!({"type": "Point", "coordinates": [round7(lon), round7(lat)]})
}

fn feature(geometry: Value, properties: Value) -> Value {
    json!({"type": "Feature", "geometry": geometry, "properties": properties})
}

/// The FeatureCollection.
pub fn build(c: &Computed) -> Result<Value, ReportError> {
    let land = &c.landscape;
    let (w, h) = (land.width, land.height);
    let cell_acres = crate::units::cell_acres(land.cell_size_ft);
    let no_georef = || {
        ReportError::input(
            "landscape",
            format!("its CRS `{}` cannot be converted to WGS84", land.georef.crs),
        )
    };
    let mut features = Vec::new();
    let r = &c.report;
    // The verified engine's free fire first (when given), then the strategies on the automaton.
    let fires = c
        .spread
        .iter()
        .map(|e| (e, ENGINE_MTT))
        .chain(c.ensembles.iter().map(|e| (e, ENGINE_AUTOMATON)));
    for (e, engine) in fires {
        for iso in &r.strategies[0].isochrone_acres {
            let t = iso[0];
            let reached = |i: usize| e.arrival_median_h[i].is_some_and(|a| f64::from(a) <= t);
            let rings = geometry::rings(w, h, reached);
            if rings.is_empty() {
                continue;
            }
            let acres = (0..w * h).filter(|&i| reached(i)).count() as f64 * cell_acres;
            let geom = geojson_multipolygon(land, &geometry::polygons(rings)).ok_or_else(no_georef)?;
            features.push(feature(
                geom,
                json!({
                    "kind": "arrival_isochrone",
                    "strategy": e.strategy,
                    "engine": engine,
                    "arrival_h": t,
                    "statistic": "median arrival over runs",
                    "area_acres": acres,
                    "area_ha": acres * HA_PER_ACRE,
                }),
            ));
        }
        let runs = e.runs() as f64;
        for p in BURN_PROBABILITY_ZONES_PCT {
            // Integer counts against the threshold: no rounding at the zone's edge.
            let zone = |i: usize| f64::from(e.burn_count[i]) * 100.0 >= p * runs;
            let rings = geometry::rings(w, h, zone);
            if rings.is_empty() {
                continue;
            }
            let acres = (0..w * h).filter(|&i| zone(i)).count() as f64 * cell_acres;
            let geom = geojson_multipolygon(land, &geometry::polygons(rings)).ok_or_else(no_georef)?;
            features.push(feature(
                geom,
                json!({
                    "kind": "burn_probability_zone",
                    "strategy": e.strategy,
                    "engine": engine,
                    "min_burn_probability_pct": p,
                    "runs": e.runs(),
                    "area_acres": acres,
                    "area_ha": acres * HA_PER_ACRE,
                    "note": "burn probability, not a progression map",
                }),
            ));
        }
    }
    for d in &r.drops.drops {
        let acres = f64::from(d.quenched_cells) * cell_acres;
        features.push(feature(
            point(d.lat, d.lon),
            json!({"kind": "drop", "strategy": r.drops.strategy, "number": d.number,
                   "drop_h": d.hour, "run_seed": r.drops.run_seed,
                   "quenched_acres": acres, "quenched_ha": acres * HA_PER_ACRE}),
        ));
    }
    for a in &r.assets {
        features.push(feature(
            point(a.lat, a.lon),
            json!({"kind": "asset", "name": a.name, "source": a.source, "band": a.band,
                   "first_arrival_h": a.first_arrival_h, "trigger_h": a.trigger_h,
                   "area_acres": a.area_acres, "area_ha": a.area_acres * HA_PER_ACRE,
                   "buffer_ft": r.evacuation_bands.buffer_ft, "advice": a.advice}),
        ));
    }
    for z in &r.priority_zones {
        let [x0, y0, x1, y1] = z.cells;
        let ring = vec![
            (x0 as i64, y0 as i64),
            (x1 as i64, y0 as i64),
            (x1 as i64, y1 as i64),
            (x0 as i64, y1 as i64),
        ];
        let geom = geojson_multipolygon(land, &[vec![ring]]).ok_or_else(no_georef)?;
        features.push(feature(
            geom,
            json!({"kind": "priority_zone", "rank": z.rank,
                   "protected_acres": z.acres_protected, "protected_ha": z.acres_protected * HA_PER_ACRE,
                   "drops_per_run": z.drops_per_run,
                   "burn_probability_unsuppressed_pct": z.burn_probability_unsuppressed_pct,
                   "burn_probability_agent_pct": z.burn_probability_agent_pct}),
        ));
    }
    let [ilat, ilon] = c.ensembles[0].ignition_lat_lon;
    features.push(feature(
        point(ilat, ilon),
        json!({"kind": "ignition", "date": r.header.date,
               "ignition_score_pct": r.forecast.probability * 100.0,
               // The score's name before the day's chance existed, kept for readers of 1.3.
               "ignition_probability_pct": r.forecast.probability * 100.0,
               "ignition_threshold_pct": r.forecast.threshold * 100.0,
               "daily_ignition_probability_pct": r.forecast.daily_probability.map(|p| p * 100.0),
               "usual_daily_ignition_probability_pct": r.forecast.usual_daily_probability.map(|p| p * 100.0)}),
    ));
    Ok(json!({
        "type": "FeatureCollection",
        "name": format!("{} {}", r.header.title, r.header.date),
        "firecast_schema_version": r.schema_version,
        "features": features,
    }))
}
