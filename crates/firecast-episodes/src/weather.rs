//! Scenario weather from GRIDMET: the day's 10-m wind speed (`vs`, m/s) and the direction it
//! comes from (`th`, degrees clockwise from north) at the GRIDMET cell nearest the landscape's
//! centre. The simulator brings the 10-m wind to midflame per fuel (WAF); FireCastRL fixed the
//! wind at 0. With `fuel_moisture`, also the day's dead and live fuel moisture
//! (docs/spec/fire-model.md §B12): 1-h and 10-h from `tmmx` and `rmin`, 100-h and 1000-h from
//! `fm100` and `fm1000`, live herbaceous and woody from the 21-day Growing Season Index of
//! `tmmn`, `vpd` and the day length.

use std::path::{Path, PathBuf};

use firecast_data::gridmet::{self, GridmetFile, GridmetVariable};
use firecast_landscape::Landscape;
use firecast_sim::moisture::{self, StateOfWeather};
use firecast_sim::{FuelMoisture, Wind, WindHeight};
use serde::{Deserialize, Serialize};

use crate::EpisodeError;

/// Metres per second → miles per hour.
const MPH_PER_MS: f64 = 3600.0 / 1609.344;

/// `weather:` in a scenario.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum WeatherSpec {
    /// GRIDMET daily files (`vs_YYYY.nc`, `th_YYYY.nc`) in `dir`, on `date` (YYYY-MM-DD); with
    /// `fuel_moisture`, the day's fuel moisture too (files `tmmx`, `rmin`, `tmmn`, `vpd`,
    /// `fm100`, `fm1000`; the 20 days before `date` for the growing season index).
    Gridmet {
        dir: PathBuf,
        date: String,
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        fuel_moisture: bool,
        /// Cloud cover in the burn period (NFDRS state of weather), for the 1-h and 10-h.
        #[serde(default, skip_serializing_if = "is_clear")]
        sky: StateOfWeather,
    },
}

fn is_clear(sky: &StateOfWeather) -> bool {
    *sky == StateOfWeather::Clear
}

/// The day's fuel moisture and what it was derived from (docs/spec/fire-model.md §B12).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DayFuelMoisture {
    /// Percent of oven-dry weight.
    pub dead_1h_pct: f64,
    pub dead_10h_pct: f64,
    pub dead_100h_pct: f64,
    pub dead_1000h_pct: f64,
    pub live_herbaceous_pct: f64,
    pub live_woody_pct: f64,
    /// The day's maximum temperature (`tmmx`), °F, and minimum relative humidity (`rmin`), %.
    pub max_temperature_f: f64,
    pub min_humidity_pct: f64,
    pub sky: StateOfWeather,
    /// Growing Season Index averaged over `gsi_days` days ending on the date.
    pub gsi_21d: f64,
    pub gsi_days: usize,
    /// One line per moisture class: the method and the GRIDMET variables behind it.
    pub sources: Vec<String>,
}

impl DayFuelMoisture {
    /// As the Rothermel kernel takes it (fractions; 1000-h is not a surface fuel class).
    pub fn fuel_moisture(&self) -> FuelMoisture {
        FuelMoisture::from_percent(
            self.dead_1h_pct,
            self.dead_10h_pct,
            self.dead_100h_pct,
            self.live_herbaceous_pct,
            self.live_woody_pct,
        )
    }
}

/// Days in the growing season index's running mean (NFDRS 2016).
const GSI_DAYS: usize = 21;

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
    /// The day's fuel moisture, when the weather asked for it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fuel_moisture: Option<DayFuelMoisture>,
}

impl WeatherSpec {
    /// The day's wind from GRIDMET files in `dir` (fuel moisture as the scenario gives it).
    pub fn gridmet_wind(dir: PathBuf, date: &str) -> Self {
        Self::Gridmet {
            dir,
            date: date.to_string(),
            fuel_moisture: false,
            sky: StateOfWeather::Clear,
        }
    }

    /// Reads the day's wind at the landscape's centre; relative paths resolve against `root`.
    pub fn resolve(&self, landscape: &Landscape, root: &Path) -> Result<ResolvedWeather, EpisodeError> {
        let Self::Gridmet {
            dir,
            date,
            fuel_moisture,
            sky,
        } = self;
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
        let read =
            |variable: GridmetVariable| read_value(&root.join(dir), variable, day_1900, date, lat, lon);
        let (vs, cell_lat, cell_lon) = read(GridmetVariable::Vs)?;
        let (th, _, _) = read(GridmetVariable::Th)?;
        let fuel_moisture = if *fuel_moisture {
            Some(day_fuel_moisture(
                &root.join(dir),
                day_1900,
                date,
                lat,
                lon,
                *sky,
            )?)
        } else {
            None
        };
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
            fuel_moisture,
        })
    }
}

/// One variable's value on `day_1900` at the GRIDMET cell nearest (lat, lon), with the cell's
/// centre; the file is the variable's file of that day's year in `dir`.
fn read_value(
    dir: &Path,
    variable: GridmetVariable,
    day_1900: i32,
    date: &str,
    lat: f64,
    lon: f64,
) -> Result<(f64, f64, f64), EpisodeError> {
    let (year, _, _) = gridmet::day_to_ymd(day_1900);
    let path = dir.join(variable.file_name(year));
    let file = GridmetFile::open(&path, variable)?;
    let t = file
        .days()
        .iter()
        .position(|&d| d == day_1900)
        .ok_or_else(|| EpisodeError::Weather {
            path: path.clone(),
            message: format!("no day {} in the file (needed for {date})", fmt_day(day_1900)),
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
                "`{}` is missing on {} at ({:.4}, {:.4}) (a masked cell)",
                file.var_name(),
                fmt_day(day_1900),
                file.lats()[j],
                file.lons()[i]
            ),
        });
    }
    Ok((f64::from(value), file.lats()[j], file.lons()[i]))
}

fn fmt_day(day_1900: i32) -> String {
    let (y, m, d) = gridmet::day_to_ymd(day_1900);
    format!("{y:04}-{m:02}-{d:02}")
}

/// The day's fuel moisture at the GRIDMET cell nearest (lat, lon) (docs/spec/fire-model.md §B12).
fn day_fuel_moisture(
    dir: &Path,
    day_1900: i32,
    date: &str,
    lat: f64,
    lon: f64,
    sky: StateOfWeather,
) -> Result<DayFuelMoisture, EpisodeError> {
    let read =
        |variable: GridmetVariable, day: i32| read_value(dir, variable, day, date, lat, lon).map(|v| v.0);
    let tmmx_k = read(GridmetVariable::Tmmx, day_1900)?;
    let rmin = read(GridmetVariable::Rmin, day_1900)?;
    let fm100 = read(GridmetVariable::Fm100, day_1900)?;
    let fm1000 = read(GridmetVariable::Fm1000, day_1900)?;
    let temp_f = moisture::kelvin_to_f(tmmx_k);
    let (dead_1h, dead_10h) = moisture::fine_dead_moisture_pct(temp_f, rmin, sky);
    // The growing season index of the 21 days ending on the date (the landscape centre's
    // latitude for the day length).
    let mut gsi_sum = 0.0;
    for back in 0..GSI_DAYS as i32 {
        let day = day_1900 - back;
        let tmin_c = read(GridmetVariable::Tmmn, day)? - 273.15;
        let vpd_pa = read(GridmetVariable::Vpd, day)? * 1000.0;
        let (y, _, _) = gridmet::day_to_ymd(day);
        let doy = (day - gridmet::ymd_to_day(y, 1, 1).unwrap_or(day)) as u32 + 1;
        gsi_sum += moisture::growing_season_index(tmin_c, vpd_pa, moisture::day_length_s(lat, doy));
    }
    let gsi = gsi_sum / GSI_DAYS as f64;
    let sky_name = match sky {
        StateOfWeather::Clear => "clear",
        StateOfWeather::Scattered => "scattered clouds",
        StateOfWeather::Broken => "broken clouds",
        StateOfWeather::Overcast => "overcast",
    };
    Ok(DayFuelMoisture {
        dead_1h_pct: dead_1h,
        dead_10h_pct: dead_10h,
        dead_100h_pct: fm100,
        dead_1000h_pct: fm1000,
        live_herbaceous_pct: moisture::live_herbaceous_pct(gsi),
        live_woody_pct: moisture::live_woody_pct(gsi),
        max_temperature_f: temp_f,
        min_humidity_pct: rmin,
        sky,
        gsi_21d: gsi,
        gsi_days: GSI_DAYS,
        sources: vec![
            format!(
                "1-h and 10-h: NFDRS 1978 (1.03 and 1.28 × Simard's equilibrium moisture) at the day's maximum \
                 temperature {temp_f:.0} °F (GRIDMET tmmx) and minimum humidity {rmin:.0} % (rmin), {sky_name} sky"
            ),
            "100-h and 1000-h: GRIDMET fm100 and fm1000 of the day".to_string(),
            format!(
                "live herbaceous and woody: NFDRS 2016, growing season index {gsi:.2} over the {GSI_DAYS} days to the \
                 date (GRIDMET tmmn, vpd, day length)"
            ),
        ],
    })
}

fn parse_date(s: &str) -> Option<(i32, u32, u32)> {
    let mut parts = s.split('-');
    let year = parts.next()?.parse().ok()?;
    let month = parts.next()?.parse().ok()?;
    let day = parts.next()?.parse().ok()?;
    parts.next().is_none().then_some((year, month, day))
}
