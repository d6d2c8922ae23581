//! Ignition forecasts for the page: one place (the paper's `predictWildfire`, answered as
//! `forecast.predict` answers it: mean and range over the experiment's training seeds) and
//! the day's map over every GRIDMET cell of the data.

use std::path::{Path, PathBuf};

use firecast_forecast::predict::Query;
use firecast_forecast::stage::{PointForecast, PredictParams};
use serde::Serialize;

use crate::coverage::Coverage;
use crate::error::{ApiError, Code};

/// The forecaster the server answers with: one model of a `forecast.experiment` folder.
#[derive(Debug, Clone, Serialize)]
pub struct ForecasterInfo {
    pub experiment: PathBuf,
    pub model: String,
}

/// The day's probability over the GRIDMET cells, row 0 south.
#[derive(Debug, Clone, Serialize)]
pub struct ProbabilityMap {
    pub date: String,
    pub model: String,
    pub protocol: String,
    pub threshold: f64,
    pub seeds: usize,
    pub lats: Vec<f64>,
    pub lons: Vec<f64>,
    /// `lats.len()` rows of `lons.len()` values (mean over seeds); `null` where a cell has no
    /// complete weather window (masked or outside the files).
    pub probability: Vec<Vec<Option<f64>>>,
}

fn forecast_error(e: firecast_forecast::ForecastError) -> ApiError {
    let text = e.to_string();
    if text.contains("no saved") || text.contains("no models") || text.contains("protocol") {
        ApiError::new(Code::NoModel, text)
    } else if text.contains("no complete") || text.contains("missing value") {
        ApiError::new(Code::NoWeather, text)
    } else {
        ApiError::internal(text)
    }
}

impl ForecasterInfo {
    /// Fails with `no_model` when the folder holds no saved model.
    pub fn check(&self) -> Result<(), ApiError> {
        if !self.experiment.join("models").is_dir() {
            return Err(ApiError::new(
                Code::NoModel,
                format!(
                    "no trained forecaster: {} holds no saved models (run `cargo xtask demo`, or start the server with --forecaster DIR)",
                    self.experiment.display()
                ),
            ));
        }
        Ok(())
    }

    /// The point forecast at a checked place and day.
    pub fn point(
        &self,
        coverage: &Coverage,
        lat: f64,
        lon: f64,
        date: &str,
    ) -> Result<PointForecast, ApiError> {
        self.check()?;
        let params = PredictParams {
            lat,
            lon,
            date: date.to_string(),
            model: self.model.clone(),
            protocol: None,
            device: "cpu".into(),
            threads: 1,
        };
        firecast_forecast::stage::forecast_point(&self.experiment, &coverage.gridmet, &params, tch_cpu())
            .map_err(forecast_error)
    }

    /// Every GRIDMET cell of the data on `date`, mean over the model's seeds.
    pub fn map(&self, coverage: &Coverage, date: &str) -> Result<ProbabilityMap, ApiError> {
        self.check()?;
        let results: Option<serde_json::Value> = std::fs::read(self.experiment.join("results.json"))
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok());
        let available = sub_folders(&self.experiment.join("models"));
        let headline = results.as_ref().and_then(|r| r.get("headline")?.as_str());
        let protocol =
            firecast_forecast::stage::choose_protocol(&available, headline, None).map_err(forecast_error)?;
        let bundles = firecast_forecast::stage::seed_bundles(
            &self.experiment,
            results.as_ref(),
            &protocol,
            &self.model,
        )
        .map_err(forecast_error)?;
        let queries: Vec<Query> = coverage
            .lats
            .iter()
            .flat_map(|&lat| {
                coverage.lons.iter().map(move |&lon| Query {
                    lat,
                    lon,
                    date: date.to_string(),
                })
            })
            .collect();
        let mut sum = vec![0.0; queries.len()];
        let mut count = vec![0usize; queries.len()];
        let mut threshold = 0.0;
        for (_, rel) in &bundles {
            let bundle = firecast_forecast::bundle::load(&self.experiment.join(rel), tch_cpu())
                .map_err(forecast_error)?;
            threshold += bundle.info.threshold;
            let (answers, _) = firecast_forecast::predict::predict_available(
                &bundle,
                &coverage.gridmet,
                &queries,
                tch_cpu(),
            )
            .map_err(forecast_error)?;
            for (i, a) in answers.iter().enumerate() {
                if let Some(p) = a {
                    sum[i] += p.probability;
                    count[i] += 1;
                }
            }
        }
        let n_lon = coverage.lons.len();
        let probability = (0..coverage.lats.len())
            .map(|r| {
                (0..n_lon)
                    .map(|c| {
                        let i = r * n_lon + c;
                        (count[i] == bundles.len() && count[i] > 0).then(|| sum[i] / count[i] as f64)
                    })
                    .collect()
            })
            .collect();
        Ok(ProbabilityMap {
            date: date.to_string(),
            model: self.model.clone(),
            protocol,
            threshold: threshold / bundles.len().max(1) as f64,
            seeds: bundles.len(),
            lats: coverage.lats.clone(),
            lons: coverage.lons.clone(),
            probability,
        })
    }
}

fn tch_cpu() -> firecast_rl::Device {
    firecast_rl::Device::Cpu
}

fn sub_folders(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.path().is_dir())
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .collect();
    names.sort();
    names
}
