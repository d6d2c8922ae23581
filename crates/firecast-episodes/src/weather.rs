//! Scenario weather from GRIDMET: the day's 10-m wind speed (`vs`, m/s) and the direction it
//! comes from (`th`, degrees clockwise from north) at the GRIDMET cell nearest the landscape's
//! centre. The simulator brings the 10-m wind to midflame per fuel (WAF); FireCastRL fixed the
//! wind at 0.

use std::path::{Path, PathBuf};

use firecast_data::gridmet::{self, GridmetFile, GridmetVariable};
use firecast_landscape::Landscape;
use firecast_sim::{Wind, WindHeight};
use serde::{Deserialize, Serialize};

use crate::EpisodeError;

/// Metres per second → miles per hour.
const MPH_PER_MS: f64 = 3600.0 / 1609.344;

/// `weather:` in a scenario.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum WeatherSpec {
    /// GRIDMET daily files (`vs_YYYY.nc`, `th_YYYY.nc`) in `dir`, on `date` (YYYY-MM-DD).
    Gridmet { dir: PathBuf, date: String },
}

/// The wind a scenario's weather resolved to, with where it came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResolvedWeather {
    pub wind: Wind,
    /// 10-m wind speed as read, m/s.
    pub vs_m_s: f64,
    pub th_deg: f64,
    /// GRIDMET cell centre used.
    pub lat: f64,
    pub lon: f64,
    pub date: String,
}

impl WeatherSpec {
    /// Reads the day's wind at the landscape's centre; relative paths resolve against `root`.
    pub fn resolve(&self, landscape: &Landscape, root: &Path) -> Result<ResolvedWeather, EpisodeError> {
        let Self::Gridmet { dir, date } = self;
        let bad = |message: String| EpisodeError::Weather {
            path: root.join(dir),
            message,
        };
        let (year, month, day) = parse_date(date)
            .ok_or_else(|| bad(format!("date `{date}` is not a calendar date YYYY-MM-DD")))?;
        let day_1900 = gridmet::ymd_to_day(year, month, day)
            .ok_or_else(|| bad(format!("date `{date}` does not exist")))?;
        let (cx, cy) = (landscape.width / 2, landscape.height / 2);
        let (lat, lon) = landscape.try_cell_to_lat_lon(cx, cy)?;
        let read = |variable: GridmetVariable| -> Result<(f64, f64, f64), EpisodeError> {
            let path = root.join(dir).join(variable.file_name(year));
            let file = GridmetFile::open(&path, variable)?;
            let t = file
                .days()
                .iter()
                .position(|&d| d == day_1900)
                .ok_or_else(|| EpisodeError::Weather {
                    path: path.clone(),
                    message: format!("no day {date} in the file"),
                })?;
            let (j, i) = file.nearest_cell(lat, lon).ok_or_else(|| EpisodeError::Weather {
                path: path.clone(),
                message: format!("no grid cell near ({lat:.4}, {lon:.4})"),
            })?;
            let value = file.gather(&[(j, i)], t..t + 1)?[0][0];
            if !value.is_finite() {
                return Err(EpisodeError::Weather {
                    path,
                    message: format!(
                        "`{}` is missing on {date} at ({:.4}, {:.4}) (a masked cell)",
                        file.var_name(),
                        file.lats()[j],
                        file.lons()[i]
                    ),
                });
            }
            Ok((f64::from(value), file.lats()[j], file.lons()[i]))
        };
        let (vs, cell_lat, cell_lon) = read(GridmetVariable::Vs)?;
        let (th, _, _) = read(GridmetVariable::Th)?;
        Ok(ResolvedWeather {
            wind: Wind {
                speed_mph: vs * MPH_PER_MS,
                from_direction_deg: th,
                measured_at: WindHeight::TenMetre,
            },
            vs_m_s: vs,
            th_deg: th,
            lat: cell_lat,
            lon: cell_lon,
            date: date.clone(),
        })
    }
}

fn parse_date(s: &str) -> Option<(i32, u32, u32)> {
    let mut parts = s.split('-');
    let year = parts.next()?.parse().ok()?;
    let month = parts.next()?.parse().ok()?;
    let day = parts.next()?.parse().ok()?;
    parts.next().is_none().then_some((year, month, day))
}
