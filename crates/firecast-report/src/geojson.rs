//! The report for GIS users: arrival isochrones (median over runs) per strategy,
//! burn-probability zones, drops, assets with their bands, priority zones and the ignition,
//! as one RFC 7946 FeatureCollection in WGS84.

use serde_json::{Value, json};

use crate::ReportError;
use crate::compute::Computed;
use crate::geometry::{self, geojson_multipolygon, round7};

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
    let no_georef = || {
        ReportError::input(
            "landscape",
            format!("its CRS `{}` cannot be converted to WGS84", land.georef.crs),
        )
    };
    let mut features = Vec::new();
    let r = &c.report;
    for e in &c.ensembles {
        for iso in &r.strategies[0].isochrone_acres {
            let t = iso[0];
            let rings = geometry::rings(w, h, |i| e.arrival_median_h[i].is_some_and(|a| f64::from(a) <= t));
            if rings.is_empty() {
                continue;
            }
            let cells = e
                .arrival_median_h
                .iter()
                .flatten()
                .filter(|&&a| f64::from(a) <= t)
                .count();
            let geom = geojson_multipolygon(land, &geometry::polygons(rings)).ok_or_else(no_georef)?;
            features.push(feature(
                geom,
                json!({
                    "kind": "arrival_isochrone",
                    "strategy": e.strategy,
                    "hours_after_ignition": t,
                    "statistic": "median arrival over runs",
                    "acres": cells as f64 * crate::units::cell_acres(land.cell_size_ft),
                }),
            ));
        }
        for p in [0.1, 0.5, 0.9] {
            let runs = e.runs() as f64;
            let rings = geometry::rings(w, h, |i| f64::from(e.burn_count[i]) / runs >= p);
            if rings.is_empty() {
                continue;
            }
            let geom = geojson_multipolygon(land, &geometry::polygons(rings)).ok_or_else(no_georef)?;
            features.push(feature(
                geom,
                json!({
                    "kind": "burn_probability_zone",
                    "strategy": e.strategy,
                    "min_probability": p,
                    "runs": e.runs(),
                    "note": "burn probability, not a progression map",
                }),
            ));
        }
    }
    for d in &r.drops.drops {
        features.push(feature(
            point(d.lat, d.lon),
            json!({"kind": "drop", "strategy": r.drops.strategy, "number": d.number,
                   "hours_after_ignition": d.hour, "run_seed": r.drops.run_seed,
                   "quenched_cells": d.quenched_cells}),
        ));
    }
    for a in &r.assets {
        features.push(feature(
            point(a.lat, a.lon),
            json!({"kind": "asset", "name": a.name, "source": a.source, "band": a.band,
                   "first_arrival_h": a.first_arrival_h, "trigger_h": a.trigger_h,
                   "advice": a.advice}),
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
            json!({"kind": "priority_zone", "rank": z.rank, "acres_protected": z.acres_protected,
                   "drops_per_run": z.drops_per_run}),
        ));
    }
    let [ilat, ilon] = c.ensembles[0].ignition_lat_lon;
    features.push(feature(
        point(ilat, ilon),
        json!({"kind": "ignition", "date": r.header.date, "probability": r.forecast.probability}),
    ));
    Ok(json!({
        "type": "FeatureCollection",
        "name": format!("{} {}", r.header.title, r.header.date),
        "firecast_schema_version": r.schema_version,
        "features": features,
    }))
}
