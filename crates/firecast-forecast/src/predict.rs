//! A trained model asked about places and dates (the paper's `predictWildfire`): the window
//! the model needs is read from GRIDMET files exactly as the dataset's windows were.

use std::path::Path;

use serde::Serialize;

use crate::ForecastError;
use crate::bundle::Bundle;
use crate::data::{Block, SampleMeta};
use crate::inputs::Inputs;

/// A place and a date to score.
#[derive(Debug, Clone, PartialEq)]
pub struct Query {
    pub lat: f64,
    pub lon: f64,
    /// `YYYY-MM-DD`: the day whose ignition is predicted.
    pub date: String,
}

/// One answer.
#[derive(Debug, Clone, Serialize)]
pub struct Prediction {
    pub lat: f64,
    pub lon: f64,
    pub date: String,
    /// The model's score, on the training samples' scale (about 40 % fires by the paper's
    /// design): not a daily chance.
    pub probability: f64,
    /// The day's probability of an ignition in the GRIDMET cell: the score corrected to the
    /// training area's usual daily rate ([`crate::daily`]); None where the bundle does not
    /// record its training fires.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub daily_probability: Option<f64>,
    /// That usual daily rate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub usual_daily: Option<f64>,
    /// Why there is no daily probability.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub daily_unavailable: Option<String>,
    pub threshold: f64,
    pub ignition_expected: bool,
    /// The GRIDMET cell whose weather was read.
    pub cell_lat: f64,
    pub cell_lon: f64,
    pub model: String,
    pub kind: String,
    pub protocol: String,
    pub dataset: String,
    pub dataset_version: String,
    pub input_days: (i32, i32),
}

/// Scores `queries` with `bundle`, reading weather from the GRIDMET folder `gridmet`; a query
/// without a complete window is an error naming it.
pub fn predict(
    bundle: &Bundle,
    gridmet: &Path,
    queries: &[Query],
    device: tch::Device,
) -> Result<Vec<Prediction>, ForecastError> {
    let (answers, dropped) = predict_available(bundle, gridmet, queries, device)?;
    let missing: Vec<String> = queries
        .iter()
        .zip(&answers)
        .filter(|(_, a)| a.is_none())
        .map(|(q, _)| format!("({}, {}) on {}", q.lat, q.lon, q.date))
        .collect();
    if !missing.is_empty() {
        return Err(ForecastError::Data {
            path: gridmet.to_path_buf(),
            message: format!(
                "no complete {}-day window for {} ({dropped}): outside the files' grid or years, or on a masked cell",
                bundle.info.days.1 - bundle.info.days.0 + 1,
                missing.join(", "),
            ),
        });
    }
    Ok(answers.into_iter().flatten().collect())
}

/// Adds the day's probability (or why there is none) to `answers` of `bundle`: the training
/// area's usual rate is counted once from the GRIDMET folder's land mask ([`crate::daily`]).
pub fn with_daily(answers: &mut [Prediction], bundle: &Bundle, gridmet: &Path) -> Result<(), ForecastError> {
    let base = crate::daily::base_of(bundle.info.training_extent.as_ref(), gridmet)?;
    for a in answers {
        match &base {
            Ok(base) => {
                a.daily_probability = Some(crate::cell_days::prior_corrected(
                    a.probability,
                    base.sampled_prevalence,
                    base.usual,
                ));
                a.usual_daily = Some(base.usual);
            }
            Err(why) => a.daily_unavailable = Some(why.clone()),
        }
    }
    Ok(())
}

/// Scores the queries that have a complete window (a map of many cells, some masked): one
/// answer per query in order, `None` where the window is incomplete, and what was dropped
/// in words.
pub fn predict_available(
    bundle: &Bundle,
    gridmet: &Path,
    queries: &[Query],
    device: tch::Device,
) -> Result<(Vec<Option<Prediction>>, String), ForecastError> {
    let mut samples = Vec::with_capacity(queries.len());
    for (i, q) in queries.iter().enumerate() {
        let day = firecast_dataset::time::parse_date(&q.date).ok_or_else(|| ForecastError::Config {
            key: format!("date[{i}]"),
            message: format!("`{}` is not a YYYY-MM-DD date", q.date),
        })?;
        if !(-90.0..=90.0).contains(&q.lat) || !(-180.0..=180.0).contains(&q.lon) {
            return Err(ForecastError::Config {
                key: format!("point[{i}]"),
                message: format!("({}, {}) is not a latitude/longitude", q.lat, q.lon),
            });
        }
        // Noon in Mountain Standard Time: the GRIDMET day is the MST day.
        samples.push(firecast_dataset::windows::SampleIn {
            sample_id: i as u32,
            lat: q.lat,
            lon: q.lon,
            time_ms: firecast_dataset::time::day_start_ms(day) + 19 * 3_600_000,
            tier: firecast_dataset::Tier::Far,
            source_row: None,
        });
    }
    let cfg = firecast_dataset::windows::ExtractConfig {
        first_offset: bundle.info.days.0,
        last_offset: bundle.info.days.1,
        variables: bundle.info.features.clone(),
        ..Default::default()
    };
    let (table, report) = firecast_dataset::windows::extract(&samples, gridmet, &cfg, false, &|_, _| {})
        .map_err(|e| ForecastError::dataset(gridmet, e))?;
    let dropped = format!("{:?}", report.dropped);
    if let Some(at) = table.values.iter().position(|v| !v.is_finite()) {
        let s = at / (table.n_days * table.n_features());
        let q = &queries[table.samples[s].sample_id as usize];
        return Err(ForecastError::Data {
            path: gridmet.to_path_buf(),
            message: format!(
                "missing value in `{}` in the window of ({}, {}) on {}",
                table.features[at % table.n_features()],
                q.lat,
                q.lon,
                q.date
            ),
        });
    }
    let block = Block {
        features: table.features.clone(),
        first_offset: table.first_offset,
        n_days: table.n_days,
        values: table.values.clone(),
    };
    let meta: Vec<SampleMeta> = table.samples.iter().map(|s| SampleMeta::of(s, None)).collect();
    let inputs = Inputs {
        block: &block,
        meta: meta.iter().collect(),
    };
    let p = if meta.is_empty() {
        Vec::new()
    } else {
        bundle.model.predict(&inputs, device)?
    };
    let mut answers: Vec<Option<Prediction>> = vec![None; queries.len()];
    for (s, prob) in table.samples.iter().zip(p) {
        answers[s.sample_id as usize] = Some({
            let q = &queries[s.sample_id as usize];
            Prediction {
                lat: q.lat,
                lon: q.lon,
                date: q.date.clone(),
                probability: prob,
                daily_probability: None,
                usual_daily: None,
                daily_unavailable: None,
                threshold: bundle.info.threshold,
                ignition_expected: prob > bundle.info.threshold,
                cell_lat: s.cell_lat,
                cell_lon: s.cell_lon,
                model: bundle.info.model.clone(),
                kind: bundle.info.kind.clone(),
                protocol: bundle.info.protocol.clone(),
                dataset: bundle.info.dataset.clone(),
                dataset_version: bundle.info.dataset_version.clone(),
                input_days: bundle.info.days,
            }
        });
    }
    Ok((answers, dropped))
}
