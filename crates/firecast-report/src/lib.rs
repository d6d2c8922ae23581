//! Threat-assessment reports: a place and a date, the ignition forecast there, the day's
//! weather and fire behaviour at the point, and the simulated fire without suppression, under
//! the rule-based plan and under the trained agent over many seeds — turned into one report a
//! duty officer can read in two minutes (HTML, and the same page printed to PDF by Chromium)
//! and its machine-readable twins (JSON with a versioned schema, GeoJSON and GeoTIFFs for
//! GIS).
//!
//! [`compute`] turns the inputs into [`model::ThreatReport`]; [`html`], [`geojson`],
//! [`rasters`] and [`pdf`] write it; [`ReportStage`] is the `report` pipeline stage kind.

pub mod compute;
pub mod figures;
pub mod geojson;
pub mod geometry;
pub mod html;
pub mod maps;
pub mod model;
pub mod pdf;
pub mod rasters;
mod stage;
pub mod units;
pub mod weather;

use std::path::PathBuf;

pub use compute::{AssetSpec, ReportSettings, compute};
pub use stage::{ReportFiles, ReportParams, ReportStage, build};

/// Registers this crate's stage kind: `report`.
pub fn register(kinds: &mut firecast_pipeline::StageKinds) {
    kinds.register(ReportStage);
}

/// Errors of report building. Inputs are named by their stage port or key.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("{input}: {message}")]
    Input { input: String, message: String },
    #[error(transparent)]
    Episodes(#[from] firecast_episodes::EpisodeError),
    #[error(transparent)]
    Gridmet(#[from] firecast_data::gridmet::GridmetError),
    #[error("weather {path}: {message}")]
    Weather { path: PathBuf, message: String },
    #[error("drawing a figure: {0}")]
    Figure(String),
    #[error("PDF: {0}")]
    Pdf(String),
    #[error("{context} {path}: {source}")]
    Io {
        context: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("formatting: {0}")]
    Fmt(#[from] std::fmt::Error),
    #[error("JSON: {0}")]
    Json(#[from] serde_json::Error),
}

impl ReportError {
    pub fn input(input: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Input {
            input: input.into(),
            message: message.into(),
        }
    }

    pub(crate) fn io(context: &'static str, path: &std::path::Path) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.to_path_buf();
        move |source| Self::Io {
            context,
            path,
            source,
        }
    }
}

/// The issue time: `SOURCE_DATE_EPOCH` when set (reproducible rebuilds), otherwise now.
pub fn issue_time() -> String {
    let secs = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|v| v.trim().parse::<i64>().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs() as i64)
        });
    let days = secs.div_euclid(86_400);
    let rem = secs.rem_euclid(86_400);
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        (rem / 60) % 60,
        rem % 60
    )
}

/// Days since 1970-01-01 → (year, month, day) (Howard Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

#[cfg(test)]
mod tests {
    #[test]
    fn civil_dates() {
        assert_eq!(super::civil_from_days(0), (1970, 1, 1));
        assert_eq!(super::civil_from_days(19_000), (2022, 1, 8));
        assert_eq!(super::civil_from_days(11_016), (2000, 2, 29));
    }
}
