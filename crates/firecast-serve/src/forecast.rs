//! Ignition forecasts for the page: one place (the paper's `predictWildfire`, answered as
//! `forecast.predict` answers it: mean and range over the experiment's training seeds) and
//! the day's map over every GRIDMET cell of the data.

use std::path::PathBuf;

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

/// The day's probability over the GRIDMET cells, row 0 south (`firecast-forecast`'s).
pub use firecast_forecast::stage::ProbabilityMap;

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
            map_radius_deg: None,
        };
        firecast_forecast::stage::forecast_point(&self.experiment, &coverage.gridmet, &params, tch_cpu())
            .map_err(forecast_error)
    }

    /// Every GRIDMET cell of the data on `date`, mean over the model's seeds.
    pub fn map(&self, coverage: &Coverage, date: &str) -> Result<ProbabilityMap, ApiError> {
        self.check()?;
        let params = PredictParams {
            lat: 0.0,
            lon: 0.0,
            date: date.to_string(),
            model: self.model.clone(),
            protocol: None,
            device: "cpu".into(),
            threads: 1,
            map_radius_deg: None,
        };
        firecast_forecast::stage::forecast_map(
            &self.experiment,
            &coverage.gridmet,
            &params,
            &coverage.lats,
            &coverage.lons,
            tch_cpu(),
        )
        .map_err(forecast_error)
    }
}

fn tch_cpu() -> firecast_rl::Device {
    firecast_rl::Device::Cpu
}
