//! The day's GRIDMET values at the report's point, from whichever variables' files the folder
//! holds (the wind comes with the ensembles; the rest is for the reader).

use std::path::Path;

use firecast_data::gridmet::{self, GridmetFile, GridmetVariable};

use crate::ReportError;
use crate::compute::DayWeather;

/// Reads `date` (YYYY-MM-DD) at the GRIDMET cell nearest (`lat`, `lon`). A variable without a
/// file is `None`; a point off the grid, a date outside the files or a masked cell is an error
/// naming the file.
pub fn read_day(dir: &Path, lat: f64, lon: f64, date: &str) -> Result<DayWeather, ReportError> {
    let bad = |message: String| ReportError::Weather {
        path: dir.to_path_buf(),
        message,
    };
    let mut parts = date.split('-').map(str::parse::<u32>);
    let (Some(Ok(y)), Some(Ok(m)), Some(Ok(d)), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(bad(format!("date `{date}` is not YYYY-MM-DD")));
    };
    let year = y as i32;
    let day = gridmet::ymd_to_day(year, m, d).ok_or_else(|| bad(format!("date `{date}` does not exist")))?;
    let mut out = DayWeather::default();
    let mut found = false;
    for variable in [
        GridmetVariable::Tmmx,
        GridmetVariable::Tmmn,
        GridmetVariable::Rmin,
        GridmetVariable::Rmax,
        GridmetVariable::Pr,
        GridmetVariable::Erc,
        GridmetVariable::Bi,
        GridmetVariable::Fm100,
        GridmetVariable::Fm1000,
        GridmetVariable::Vpd,
    ] {
        let path = dir.join(variable.file_name(year));
        if !path.exists() {
            continue;
        }
        let file = GridmetFile::open(&path, variable)?;
        let t = file
            .days()
            .iter()
            .position(|&x| x == day)
            .ok_or_else(|| ReportError::Weather {
                path: path.clone(),
                message: format!("no day {date} in the file"),
            })?;
        let (j, i) = file.nearest_cell(lat, lon).ok_or_else(|| ReportError::Weather {
            path: path.clone(),
            message: format!("({lat}, {lon}) is outside the file's grid"),
        })?;
        let v = f64::from(file.gather(&[(j, i)], t..t + 1)?[0][0]);
        if !v.is_finite() {
            return Err(ReportError::Weather {
                path,
                message: format!(
                    "`{}` is missing on {date} at ({:.4}, {:.4}): a masked (water or off-land) cell",
                    file.var_name(),
                    file.lats()[j],
                    file.lons()[i]
                ),
            });
        }
        out.cell_lat = file.lats()[j];
        out.cell_lon = file.lons()[i];
        found = true;
        let slot = match variable {
            GridmetVariable::Tmmx => &mut out.tmmx_k,
            GridmetVariable::Tmmn => &mut out.tmmn_k,
            GridmetVariable::Rmin => &mut out.rmin_pct,
            GridmetVariable::Rmax => &mut out.rmax_pct,
            GridmetVariable::Pr => &mut out.pr_mm,
            GridmetVariable::Erc => &mut out.erc,
            GridmetVariable::Bi => &mut out.bi,
            GridmetVariable::Fm100 => &mut out.fm100_pct,
            GridmetVariable::Fm1000 => &mut out.fm1000_pct,
            _ => &mut out.vpd_kpa,
        };
        *slot = Some(v);
    }
    if !found {
        return Err(bad(format!(
            "no GRIDMET file for {year} among tmmx, tmmn, rmin, rmax, pr, erc, bi, fm100, fm1000, vpd"
        )));
    }
    Ok(out)
}
