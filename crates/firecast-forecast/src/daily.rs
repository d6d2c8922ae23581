//! From a model's score to the day's chance of an ignition in one GRIDMET cell.
//!
//! A model trained on case-control samples (about 40 % fires by the paper's design) scores on
//! that scale: 0.4 means "as likely as the training samples' fires", not a 40 % chance that a
//! cell burns today. Over all cell-days ignitions are rare (about 10⁻³ a cell-day in the demo).
//! What a responder needs is the day's probability, so a forecast also gives the score after
//! King & Zeng's (2001) prior correction ([`crate::cell_days::prior_corrected`]) from the
//! training samples' fire share π_s to the training area's usual daily rate π: the ignition
//! cell-days of the training and validation windows in the training windows' box and period
//! over every cell-day of that area and period (the GRIDMET cells with data whose centre lies
//! in the box, widened by half a cell, times the days from the first to the last training
//! date). A temporal protocol validates on cell groups of the training period, so both are the
//! area's fires; a spatial protocol's test blocks are left out of the count but not of the
//! cells, which makes π low by their share there. The correction keeps the
//! ranking; its calibration over all cell-days is what `forecast.cell_days` measures
//! (docs/results/table3.md).

use std::collections::HashSet;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::ForecastError;
use crate::bundle::TrainingExtent;

/// The two rates the correction needs, and where the usual rate comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DailyBase {
    /// Share of fires among the training samples (π_s).
    pub sampled_prevalence: f64,
    /// Ignition cell-days over cell-days of the training area and period (π).
    pub usual: f64,
    pub ignition_cell_days: usize,
    /// GRIDMET cells with data in the training area.
    pub cells: usize,
    /// Days from the first to the last training date, inclusive.
    pub days: usize,
}

/// The day's probability of an ignition in the place's GRIDMET cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DailyForecast {
    /// Mean over the seeds of each seed's corrected score (0–1).
    pub probability: f64,
    /// [min, max] over seeds.
    pub interval: [f64; 2],
    /// The training area's usual daily probability (π).
    pub usual: f64,
    /// `probability / usual`: how many times the usual day's chance.
    pub relative_to_usual: f64,
    pub base: DailyBase,
    pub method: String,
}

/// Distinct (GRIDMET cell, day) pairs among the positives of `meta`.
pub fn ignition_cell_days<'a>(meta: impl IntoIterator<Item = &'a crate::data::SampleMeta>) -> usize {
    meta.into_iter()
        .filter(|m| m.tier.is_positive())
        .map(|m| (m.cell, m.event_day))
        .collect::<HashSet<_>>()
        .len()
}

/// Why a forecast has no daily probability, in words a reader of the forecast understands.
pub const NOT_RECORDED: &str = "the model does not record its training fires (saved before 2026-11-28): retrain it to get the day's probability";

/// The usual daily rate of the training area read from the GRIDMET folder's land mask, or why
/// there is none (the model does not record its training fires, its training area held no
/// ignition, or these GRIDMET files do not cover that area): a forecast without it still gives
/// the score. Errors only where the GRIDMET folder cannot be read.
pub fn daily_base(
    extent: &TrainingExtent,
    gridmet: &Path,
) -> Result<Result<DailyBase, String>, ForecastError> {
    let (Some(positives), Some(fired)) = (extent.positives, extent.ignition_cell_days) else {
        return Ok(Err(NOT_RECORDED.into()));
    };
    if fired == 0 || extent.samples == 0 {
        return Ok(Err(
            "the model's training windows hold no fire, so there is no usual daily rate".into(),
        ));
    }
    let day = |s: &str| {
        firecast_dataset::time::parse_date(s).ok_or_else(|| ForecastError::Data {
            path: gridmet.to_path_buf(),
            message: format!("the model's training extent has a date `{s}` that is not YYYY-MM-DD"),
        })
    };
    let days = match (day(&extent.last_date), day(&extent.first_date)) {
        (Ok(last), Ok(first)) => (last - first + 1).max(1) as usize,
        (Err(e), _) | (_, Err(e)) => return Ok(Err(e.to_string())),
    };
    let mask = firecast_dataset::land::LandMask::from_gridmet_dir(gridmet)
        .map_err(|e| ForecastError::dataset(gridmet, e))?;
    let half_cell = |axis: &[f64]| {
        axis.windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(f64::INFINITY, f64::min)
            .min(1.0)
            / 2.0
    };
    let (dlat, dlon) = (half_cell(mask.lats()), half_cell(mask.lons()));
    let (dlat, dlon) = (
        if dlat.is_finite() { dlat } else { 0.0 },
        if dlon.is_finite() { dlon } else { 0.0 },
    );
    let mut cells = 0usize;
    for (j, &lat) in mask.lats().iter().enumerate() {
        if !(extent.lat_min - dlat..=extent.lat_max + dlat).contains(&lat) {
            continue;
        }
        for (i, &lon) in mask.lons().iter().enumerate() {
            if (extent.lon_min - dlon..=extent.lon_max + dlon).contains(&lon) && mask.is_valid(j, i) {
                cells += 1;
            }
        }
    }
    if cells == 0 {
        return Ok(Err(format!(
            "these GRIDMET files have no cell with data in the model's training area ({}–{}° N, {}–{}° E), so its \
             usual daily rate cannot be counted",
            extent.lat_min, extent.lat_max, extent.lon_min, extent.lon_max
        )));
    }
    Ok(Ok(DailyBase {
        sampled_prevalence: positives as f64 / extent.samples as f64,
        usual: fired as f64 / (cells as f64 * days as f64),
        ignition_cell_days: fired,
        cells,
        days,
    }))
}

/// [`daily_base`] of a model's training extent, or [`NOT_RECORDED`] when its bundle has none.
pub fn base_of(
    extent: Option<&TrainingExtent>,
    gridmet: &Path,
) -> Result<Result<DailyBase, String>, ForecastError> {
    match extent {
        Some(e) => daily_base(e, gridmet),
        None => Ok(Err(NOT_RECORDED.into())),
    }
}

/// The seeds' scores as the day's probability.
pub fn daily_forecast(scores: &[f64], base: &DailyBase) -> DailyForecast {
    let corrected: Vec<f64> = scores
        .iter()
        .map(|&p| crate::cell_days::prior_corrected(p, base.sampled_prevalence, base.usual))
        .collect();
    let n = corrected.len().max(1) as f64;
    let probability = corrected.iter().sum::<f64>() / n;
    DailyForecast {
        probability,
        interval: [
            corrected.iter().copied().fold(f64::INFINITY, f64::min),
            corrected.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ],
        usual: base.usual,
        relative_to_usual: probability / base.usual,
        method: format!(
            "each seed's score corrected from the training samples' {:.0} % fires to the training area's usual \
             {:.3} % a cell-day ({} ignition cell-days over {} cells x {} days; King & Zeng's prior correction)",
            base.sampled_prevalence * 100.0,
            base.usual * 100.0,
            base.ignition_cell_days,
            base.cells,
            base.days
        ),
        base: base.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base(sampled: f64, usual: f64) -> DailyBase {
        DailyBase {
            sampled_prevalence: sampled,
            usual,
            ignition_cell_days: 10,
            cells: 100,
            days: 100,
        }
    }

    fn sample(cell: (u32, u32), day: i32, lat: f64, fire: bool) -> crate::data::SampleMeta {
        crate::data::SampleMeta {
            sample_id: 0,
            event_day: day,
            year: 2018,
            month: 7,
            day_of_year: 200,
            lat,
            lon: -107.5,
            cell,
            tier: if fire {
                firecast_dataset::Tier::Positive
            } else {
                firecast_dataset::Tier::Far
            },
            dataset_split: None,
            true_probability: None,
        }
    }

    #[test]
    fn the_area_counts_each_burning_cell_day_once_inside_the_training_box_and_period() {
        let day = |s: &str| firecast_dataset::time::parse_date(s).expect("date");
        let d0 = day("2018-06-01");
        let train = [
            sample((1, 1), d0, 39.0, true),
            sample((1, 1), d0, 39.0, true), // the same cell-day twice
            sample((2, 1), d0 + 5, 39.5, true),
            sample((3, 1), d0 + 9, 39.2, false),
        ];
        let extent = TrainingExtent::of(train.iter()).expect("extent");
        assert_eq!((extent.samples, extent.positives), (4, Some(3)));
        assert_eq!(extent.ignition_cell_days, None, "counted only from the area");
        let validation = [
            sample((4, 1), d0 + 2, 39.3, true),  // counts: inside the box and period
            sample((5, 1), d0 + 30, 39.3, true), // after the last training date
            sample((6, 1), d0 + 2, 41.0, true),  // north of the box
        ];
        let area = extent.with_area_fires(train.iter().chain(&validation));
        assert_eq!(area.ignition_cell_days, Some(3));
    }

    #[test]
    fn a_score_at_the_training_share_is_the_usual_day() {
        let d = daily_forecast(&[0.4, 0.4], &base(0.4, 0.001));
        assert!((d.probability - 0.001).abs() < 1e-12, "{d:?}");
        assert!((d.relative_to_usual - 1.0).abs() < 1e-9);
        assert_eq!(d.interval[0], d.interval[1]);
    }

    #[test]
    fn higher_scores_are_higher_daily_chances_and_stay_small() {
        let d = daily_forecast(&[0.6, 0.8], &base(0.4, 0.001));
        assert!(d.interval[0] < d.interval[1]);
        // 0.8 at a 40 % share is 6 times the odds: about 0.6 %, not 80 %.
        assert!(d.interval[1] > 0.005 && d.interval[1] < 0.007, "{d:?}");
        assert!(d.relative_to_usual > 2.0 && d.relative_to_usual < 6.0, "{d:?}");
    }
}
