//! What the data covers: the GRIDMET box and days of the project's GRIDMET folder, read
//! from the files themselves (every pick in the page is checked against it).

use std::path::{Path, PathBuf};

use firecast_data::gridmet::{self, GridmetFile, GridmetVariable};
use serde::Serialize;

use crate::error::{ApiError, Code};

/// The GRIDMET cells and days the folder holds.
#[derive(Debug, Clone, Serialize)]
pub struct Coverage {
    pub gridmet: PathBuf,
    /// Cell centres, south to north and west to east.
    pub lats: Vec<f64>,
    pub lons: Vec<f64>,
    /// Half a cell around the outer centres: the box drawn on the map.
    pub lat_min: f64,
    pub lat_max: f64,
    pub lon_min: f64,
    pub lon_max: f64,
    pub cell_deg: f64,
    /// First and last day with every variable's file (YYYY-MM-DD).
    pub first_date: String,
    pub last_date: String,
    pub variables: Vec<String>,
    pub years: Vec<i32>,
}

fn ymd(day: i32) -> String {
    let (y, m, d) = gridmet::day_to_ymd(day);
    format!("{y:04}-{m:02}-{d:02}")
}

impl Coverage {
    /// Reads the folder's `<var>_<year>.nc` files: the grid from the wind-speed file (the
    /// simulator's wind needs it), the years every variable has.
    pub fn scan(dir: &Path) -> Result<Self, String> {
        let entries = std::fs::read_dir(dir)
            .map_err(|e| format!("cannot read the GRIDMET folder {}: {e}", dir.display()))?;
        let mut files: std::collections::BTreeMap<&'static str, std::collections::BTreeSet<i32>> =
            Default::default();
        for entry in entries.flatten() {
            if let Some((var, year)) = GridmetVariable::from_file_name(entry.path()) {
                files.entry(var.short_name()).or_default().insert(year);
            }
        }
        let vs = files
            .get(GridmetVariable::Vs.short_name())
            .ok_or_else(|| format!("{}: no wind-speed files (vs_YYYY.nc)", dir.display()))?;
        // Years every variable present has.
        let years: Vec<i32> = vs
            .iter()
            .copied()
            .filter(|y| files.values().all(|ys| ys.contains(y)))
            .collect();
        let (Some(&first_year), Some(&last_year)) = (years.first(), years.last()) else {
            return Err(format!("{}: no year has every variable's file", dir.display()));
        };
        let first = GridmetFile::open(
            dir.join(GridmetVariable::Vs.file_name(first_year)),
            GridmetVariable::Vs,
        )
        .map_err(|e| e.to_string())?;
        let last = if last_year == first_year {
            None
        } else {
            Some(
                GridmetFile::open(
                    dir.join(GridmetVariable::Vs.file_name(last_year)),
                    GridmetVariable::Vs,
                )
                .map_err(|e| e.to_string())?,
            )
        };
        let mut lats = first.lats().to_vec();
        let mut lons = first.lons().to_vec();
        lats.sort_by(f64::total_cmp);
        lons.sort_by(f64::total_cmp);
        let cell = |v: &[f64]| {
            if v.len() > 1 {
                (v[v.len() - 1] - v[0]) / (v.len() - 1) as f64
            } else {
                1.0 / 24.0
            }
        };
        let cell_deg = cell(&lats).max(cell(&lons));
        let first_day = first.days().iter().copied().min().ok_or("empty GRIDMET file")?;
        let last_day = last
            .as_ref()
            .unwrap_or(&first)
            .days()
            .iter()
            .copied()
            .max()
            .ok_or("empty GRIDMET file")?;
        let (Some(&lat0), Some(&lat1), Some(&lon0), Some(&lon1)) =
            (lats.first(), lats.last(), lons.first(), lons.last())
        else {
            return Err(format!("{}: the grid has no cells", dir.display()));
        };
        Ok(Self {
            gridmet: dir.to_path_buf(),
            lat_min: lat0 - cell_deg / 2.0,
            lat_max: lat1 + cell_deg / 2.0,
            lon_min: lon0 - cell_deg / 2.0,
            lon_max: lon1 + cell_deg / 2.0,
            lats,
            lons,
            cell_deg,
            first_date: ymd(first_day),
            last_date: ymd(last_day),
            variables: files.keys().map(|v| v.to_string()).collect(),
            years,
        })
    }

    /// Checks a place and a day against the data; the message says what is covered.
    pub fn check(&self, lat: f64, lon: f64, date: &str) -> Result<(), ApiError> {
        if !lat.is_finite()
            || !lon.is_finite()
            || !(-90.0..=90.0).contains(&lat)
            || !(-180.0..=180.0).contains(&lon)
        {
            return Err(ApiError::bad(format!(
                "({lat}, {lon}) is not a latitude and longitude"
            )));
        }
        if !(self.lat_min..=self.lat_max).contains(&lat) || !(self.lon_min..=self.lon_max).contains(&lon) {
            return Err(ApiError::new(
                Code::OutsideData,
                format!(
                    "({lat:.4}, {lon:.4}) is outside the data: GRIDMET covers {:.3}–{:.3} °N, {:.3}–{:.3} °E",
                    self.lat_min, self.lat_max, self.lon_min, self.lon_max
                ),
            ));
        }
        let Some(day) = parse_date(date) else {
            return Err(ApiError::bad(format!(
                "`{date}` is not a calendar date YYYY-MM-DD"
            )));
        };
        if day.as_str() < self.first_date.as_str() || day.as_str() > self.last_date.as_str() {
            return Err(ApiError::new(
                Code::NoWeather,
                format!(
                    "no weather for {day}: the GRIDMET files hold {} to {}",
                    self.first_date, self.last_date
                ),
            ));
        }
        Ok(())
    }
}

/// `YYYY-MM-DD` of a real day, normalised; `None` otherwise.
pub fn parse_date(date: &str) -> Option<String> {
    let mut parts = date.trim().splitn(3, '-');
    let y: i32 = parts.next()?.parse().ok()?;
    let m: u32 = parts.next()?.parse().ok()?;
    let d: u32 = parts.next()?.parse().ok()?;
    gridmet::ymd_to_day(y, m, d)?;
    Some(format!("{y:04}-{m:02}-{d:02}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_must_exist() {
        assert_eq!(parse_date("2019-8-1").as_deref(), Some("2019-08-01"));
        assert_eq!(parse_date("2019-02-29"), None);
        assert_eq!(parse_date("2019-08"), None);
        assert_eq!(parse_date("x"), None);
    }
}
