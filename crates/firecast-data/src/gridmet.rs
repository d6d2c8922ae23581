//! GRIDMET (METDATA) yearly NetCDF files: `<short>_<YYYY>.nc` (docs/spec/data.md §2).
//!
//! Everything is read from the file, nothing is assumed: the data variable is looked up under
//! each of its known names, the `day`/`lat`/`lon` axes are resolved from the variable's
//! dimension *names* (both the old `(day, lon, lat)` and the new `(day, lat, lon)` orders work),
//! latitude may be stored descending (as GRIDMET does) or ascending, and values are decoded
//! with the CF rules (`_Unsigned`, `_FillValue`/`missing_value` → NaN, `scale_factor`,
//! `add_offset`) by `netcdf-reader`. Both NETCDF3_CLASSIC and NetCDF-4 files are supported.

use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

use netcdf_reader::{NcFile, NcSliceInfo, NcSliceInfoElem, NcVariable};

/// Accepted names of the time dimension/coordinate.
pub const DAY_DIM_NAMES: &[&str] = &["day", "time"];
/// Accepted names of the latitude dimension/coordinate.
pub const LAT_DIM_NAMES: &[&str] = &["lat", "latitude"];
/// Accepted names of the longitude dimension/coordinate.
pub const LON_DIM_NAMES: &[&str] = &["lon", "longitude"];

/// Largest number of values [`GridmetFile::gather`] reads in one hyperslab; a larger request is
/// split along the day axis (each piece is still a single read covering every point).
const MAX_BLOCK_VALUES: usize = 1 << 25;

/// The GRIDMET variables FireCast uses: the 15 of the paper plus `th` (wind direction).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GridmetVariable {
    /// Precipitation (daily total).
    Pr,
    /// Maximum relative humidity.
    Rmax,
    /// Minimum relative humidity.
    Rmin,
    /// Mean specific humidity.
    Sph,
    /// Mean vapour pressure deficit.
    Vpd,
    /// Mean wind speed at 10 m.
    Vs,
    /// Maximum air temperature.
    Tmmx,
    /// Minimum air temperature.
    Tmmn,
    /// Surface downwelling shortwave radiation.
    Srad,
    /// NFDRS burning index, fuel model G.
    Bi,
    /// NFDRS energy release component, fuel model G.
    Erc,
    /// 100-hour dead fuel moisture.
    Fm100,
    /// 1000-hour dead fuel moisture.
    Fm1000,
    /// Reference evapotranspiration, grass.
    Pet,
    /// Reference evapotranspiration, alfalfa.
    Etr,
    /// Wind direction (degrees clockwise from north, direction the wind comes from).
    Th,
}

impl GridmetVariable {
    /// All variables, in the paper's order, then `th`.
    pub const ALL: [GridmetVariable; 16] = [
        Self::Pr,
        Self::Rmax,
        Self::Rmin,
        Self::Sph,
        Self::Vpd,
        Self::Vs,
        Self::Tmmx,
        Self::Tmmn,
        Self::Srad,
        Self::Bi,
        Self::Erc,
        Self::Fm100,
        Self::Fm1000,
        Self::Pet,
        Self::Etr,
        Self::Th,
    ];

    /// File short name, as in `<short>_<YYYY>.nc`.
    pub fn short_name(self) -> &'static str {
        match self {
            Self::Pr => "pr",
            Self::Rmax => "rmax",
            Self::Rmin => "rmin",
            Self::Sph => "sph",
            Self::Vpd => "vpd",
            Self::Vs => "vs",
            Self::Tmmx => "tmmx",
            Self::Tmmn => "tmmn",
            Self::Srad => "srad",
            Self::Bi => "bi",
            Self::Erc => "erc",
            Self::Fm100 => "fm100",
            Self::Fm1000 => "fm1000",
            Self::Pet => "pet",
            Self::Etr => "etr",
            Self::Th => "th",
        }
    }

    /// NetCDF variable names, in lookup order: the yearly-file name, its alternative spellings,
    /// then the name used in the whole-record `agg_met_*` files (docs/spec/data.md §2.2).
    pub fn netcdf_names(self) -> &'static [&'static str] {
        match self {
            Self::Pr => &["precipitation_amount"],
            Self::Rmax => &["relative_humidity", "daily_maximum_relative_humidity"],
            Self::Rmin => &["relative_humidity", "daily_minimum_relative_humidity"],
            Self::Sph => &["specific_humidity", "daily_mean_specific_humidity"],
            Self::Vpd => &["mean_vapor_pressure_deficit", "daily_mean_vapor_pressure_deficit"],
            Self::Vs => &["wind_speed", "daily_mean_wind_speed"],
            Self::Tmmx => &["air_temperature", "daily_maximum_temperature"],
            Self::Tmmn => &["air_temperature", "daily_minimum_temperature"],
            Self::Srad => &[
                "surface_downwelling_shortwave_flux_in_air",
                "daily_mean_shortwave_radiation_at_surface",
            ],
            Self::Bi => &["burning_index_g", "burning_index-g", "daily_mean_burning_index_g"],
            Self::Erc => &[
                "energy_release_component-g",
                "energy_release_component_g",
                "daily_mean_energy_release_component-g",
            ],
            Self::Fm100 => &["dead_fuel_moisture_100hr"],
            Self::Fm1000 => &["dead_fuel_moisture_1000hr"],
            Self::Pet => &[
                "potential_evapotranspiration",
                "daily_mean_reference_evapotranspiration_grass",
            ],
            Self::Etr => &[
                "potential_evapotranspiration",
                "daily_mean_reference_evapotranspiration_alfalfa",
            ],
            Self::Th => &["wind_from_direction", "daily_mean_wind_direction"],
        }
    }

    /// Units after unpacking (docs/spec/data.md §2.2).
    pub fn units(self) -> &'static str {
        match self {
            Self::Pr | Self::Pet | Self::Etr => "mm",
            Self::Rmax | Self::Rmin | Self::Fm100 | Self::Fm1000 => "%",
            Self::Sph => "kg/kg",
            Self::Vpd => "kPa",
            Self::Vs => "m/s",
            Self::Tmmx | Self::Tmmn => "K",
            Self::Srad => "W m-2",
            Self::Bi | Self::Erc => "NFDRS index",
            Self::Th => "degrees clockwise from north",
        }
    }

    /// The variable whose short name is `short` (exact, lower case).
    pub fn from_short_name(short: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|v| v.short_name() == short)
    }

    /// Parses a yearly file name `<short>_<YYYY>.nc` (directories are ignored).
    pub fn from_file_name(path: impl AsRef<Path>) -> Option<(Self, i32)> {
        let name = path.as_ref().file_name()?.to_str()?;
        let stem = name.strip_suffix(".nc")?;
        let (short, year) = stem.rsplit_once('_')?;
        if year.len() != 4 || !year.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        Some((Self::from_short_name(short)?, year.parse().ok()?))
    }

    /// The yearly file name, e.g. `pr_2018.nc`.
    pub fn file_name(self, year: i32) -> String {
        format!("{}_{year:04}.nc", self.short_name())
    }
}

impl fmt::Display for GridmetVariable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.short_name())
    }
}

/// Errors from reading GRIDMET files. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum GridmetError {
    /// The file does not exist.
    #[error("GRIDMET file {} does not exist", path.display())]
    MissingFile {
        /// The file.
        path: PathBuf,
    },
    /// The NetCDF library failed to open or read the file.
    #[error("GRIDMET file {}: cannot read {what}: {message}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What was being read.
        what: String,
        /// The library's message.
        message: String,
    },
    /// None of the variable's known names is in the file.
    #[error(
        "GRIDMET file {}: no variable for `{short}` (looked for {expected:?}); the file has {available:?}",
        path.display()
    )]
    MissingVariable {
        /// The file.
        path: PathBuf,
        /// The requested short name (or coordinate role).
        short: String,
        /// Names looked for.
        expected: Vec<String>,
        /// Variables the file has.
        available: Vec<String>,
    },
    /// A required dimension is not among the variable's dimensions.
    #[error(
        "GRIDMET file {}: variable `{variable}` has no `{dimension}` dimension (accepted names \
         {accepted:?}); its dimensions are {found:?}",
        path.display()
    )]
    MissingDimension {
        /// The file.
        path: PathBuf,
        /// The data variable.
        variable: String,
        /// The missing dimension's canonical name (`day`, `lat` or `lon`).
        dimension: &'static str,
        /// Accepted names for it.
        accepted: Vec<String>,
        /// The variable's dimensions.
        found: Vec<String>,
    },
    /// The data variable does not have exactly three dimensions.
    #[error(
        "GRIDMET file {}: variable `{variable}` must have the 3 dimensions day, lat, lon (any order); \
         it has {found:?}",
        path.display()
    )]
    WrongDimensionCount {
        /// The file.
        path: PathBuf,
        /// The data variable.
        variable: String,
        /// The variable's dimensions.
        found: Vec<String>,
    },
    /// The units of the time coordinate are not `days since <date>`.
    #[error(
        "GRIDMET file {}: cannot parse units {units:?} of `{variable}` (expected \"days since YYYY-MM-DD\")",
        path.display()
    )]
    DayUnits {
        /// The file.
        path: PathBuf,
        /// The time coordinate variable.
        variable: String,
        /// The units found (empty when absent).
        units: String,
    },
    /// A coordinate variable has the wrong length or is not monotonic/integral.
    #[error("GRIDMET file {}: bad coordinate `{variable}`: {reason}", path.display())]
    BadCoordinate {
        /// The file.
        path: PathBuf,
        /// The coordinate variable.
        variable: String,
        /// What is wrong.
        reason: String,
    },
    /// An index passed to a read is outside the file's extent.
    #[error("GRIDMET file {}, variable `{variable}`: {what}", path.display())]
    OutOfRange {
        /// The file.
        path: PathBuf,
        /// The data variable.
        variable: String,
        /// Which index and the valid extent.
        what: String,
    },
}

/// Result alias for this module.
pub type Result<T> = std::result::Result<T, GridmetError>;

/// Days since 1900-01-01 of 1900-01-01 relative to 1970-01-01 (civil-days epoch).
const EPOCH_1900: i64 = -25_567;

/// Days since 1970-01-01 of a proleptic Gregorian date (Hinnant's `days_from_civil`).
pub(crate) fn days_from_civil(year: i64, month: u32, day: u32) -> i64 {
    let y = if month <= 2 { year - 1 } else { year };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let m = i64::from(month);
    let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + i64::from(day) - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// Converts GRIDMET's `day` value (days since 1900-01-01) to `(year, month, day)`.
pub fn day_to_ymd(days_since_1900: i32) -> (i32, u32, u32) {
    let z = i64::from(days_since_1900) + EPOCH_1900 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    // Every i32 day count maps to a year well inside i32.
    (y as i32, m as u32, d as u32)
}

/// Converts `(year, month, day)` to days since 1900-01-01 (`None` for an invalid date).
pub fn ymd_to_day(year: i32, month: u32, day: u32) -> Option<i32> {
    if !(1..=12).contains(&month) || day == 0 || day > days_in_month(year, month) {
        return None;
    }
    i32::try_from(days_from_civil(i64::from(year), month, day) - EPOCH_1900).ok()
}

pub(crate) fn days_in_month(year: i32, month: u32) -> u32 {
    match month {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        _ if (year % 4 == 0 && year % 100 != 0) || year % 400 == 0 => 29,
        _ => 28,
    }
}

/// Parses `days since YYYY-MM-DD[( |T)hh:mm[:ss]][ UTC|Z]` into the reference date's offset from
/// 1900-01-01 in days. Only a midnight reference time is accepted.
pub fn parse_day_units(units: &str) -> Option<i32> {
    let rest = units
        .trim()
        .strip_prefix("days")?
        .trim_start()
        .strip_prefix("since")?
        .trim();
    let rest = rest
        .strip_suffix("UTC")
        .or_else(|| rest.strip_suffix('Z'))
        .unwrap_or(rest)
        .trim();
    let (date, time) = match rest.split_once([' ', 'T']) {
        Some((d, t)) => (d, Some(t.trim())),
        None => (rest, None),
    };
    let mut parts = date.split('-');
    let year: i32 = parts.next()?.parse().ok()?;
    let month: u32 = parts.next()?.parse().ok()?;
    let day: u32 = parts.next()?.parse().ok()?;
    if parts.next().is_some() {
        return None;
    }
    if let Some(time) = time {
        let mut fields = 0;
        for f in time.split(':') {
            fields += 1;
            if f.parse::<f64>().ok()? != 0.0 {
                return None;
            }
        }
        if !(2..=3).contains(&fields) {
            return None;
        }
    }
    ymd_to_day(year, month, day)
}

/// Storage order of the data variable's lat/lon axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DimOrder {
    /// `(day, lat, lon)`: files since about August 2019.
    DayLatLon,
    /// `(day, lon, lat)`: older files without a `crs` variable.
    DayLonLat,
    /// Any other permutation (time not first).
    Other,
}

/// An open GRIDMET yearly file for one variable (or for a companion grid in the same layout,
/// such as the synthetic generator's true ignition probability; see [`GridmetFile::open_named`]).
pub struct GridmetFile {
    nc: NcFile,
    path: PathBuf,
    /// `None` for a file opened by variable name.
    variable: Option<GridmetVariable>,
    var_name: String,
    /// Positions of the day, lat and lon axes among the variable's dimensions.
    axis_pos: [usize; 3],
    lats: Vec<f64>,
    lons: Vec<f64>,
    days: Vec<i32>,
}

impl fmt::Debug for GridmetFile {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GridmetFile")
            .field("path", &self.path)
            .field("variable", &self.variable)
            .field("var_name", &self.var_name)
            .field("dim_order", &self.dim_order())
            .field("n_days", &self.days.len())
            .field("n_lat", &self.lats.len())
            .field("n_lon", &self.lons.len())
            .finish()
    }
}

impl GridmetFile {
    /// Opens `path` (NetCDF-3 classic or NetCDF-4) and validates the variable and its grid.
    pub fn open(path: impl AsRef<Path>, variable: GridmetVariable) -> Result<Self> {
        Self::open_impl(
            path.as_ref(),
            variable.netcdf_names(),
            variable.short_name(),
            Some(variable),
        )
    }

    /// Opens the data variable `var_name` of a file laid out like a GRIDMET yearly file (the
    /// same axes, dimension names and CF decoding), for grids that are not GRIDMET variables,
    /// e.g. `ignition_probability` in the synthetic generator's `truth/` files.
    pub fn open_named(path: impl AsRef<Path>, var_name: &str) -> Result<Self> {
        Self::open_impl(path.as_ref(), &[var_name], var_name, None)
    }

    fn open_impl(
        path: &Path,
        names: &[&str],
        short: &str,
        variable: Option<GridmetVariable>,
    ) -> Result<Self> {
        let path = path.to_path_buf();
        if !path.is_file() {
            return Err(GridmetError::MissingFile { path });
        }
        let nc = NcFile::open(&path).map_err(|e| GridmetError::Read {
            path: path.clone(),
            what: "NetCDF header".into(),
            message: e.to_string(),
        })?;
        let all_vars: Vec<&NcVariable> = nc
            .variables()
            .map_err(|e| GridmetError::Read {
                path: path.clone(),
                what: "variable list".into(),
                message: e.to_string(),
            })?
            .iter()
            .collect();
        let available = || all_vars.iter().map(|v| v.name().to_string()).collect::<Vec<_>>();

        let var = names
            .iter()
            .find_map(|n| all_vars.iter().find(|v| v.name() == *n))
            .ok_or_else(|| GridmetError::MissingVariable {
                path: path.clone(),
                short: short.to_string(),
                expected: names.iter().map(|s| s.to_string()).collect(),
                available: available(),
            })?;
        let var_name = var.name().to_string();
        let dim_names: Vec<String> = var.dimensions().iter().map(|d| d.name.clone()).collect();
        if dim_names.len() != 3 {
            return Err(GridmetError::WrongDimensionCount {
                path,
                variable: var_name,
                found: dim_names,
            });
        }
        let find_axis = |canonical: &'static str, accepted: &[&str]| {
            dim_names
                .iter()
                .position(|n| accepted.contains(&n.as_str()))
                .ok_or_else(|| GridmetError::MissingDimension {
                    path: path.clone(),
                    variable: var_name.clone(),
                    dimension: canonical,
                    accepted: accepted.iter().map(|s| s.to_string()).collect(),
                    found: dim_names.clone(),
                })
        };
        let axis_pos = [
            find_axis("day", DAY_DIM_NAMES)?,
            find_axis("lat", LAT_DIM_NAMES)?,
            find_axis("lon", LON_DIM_NAMES)?,
        ];
        let sizes: Vec<usize> = var.dimensions().iter().map(|d| d.size as usize).collect();

        let read_coord = |axis: usize| -> Result<(String, Vec<f64>)> {
            let name = dim_names[axis_pos[axis]].clone();
            let Some(cv) = all_vars.iter().find(|v| v.name() == name) else {
                return Err(GridmetError::MissingVariable {
                    path: path.clone(),
                    short: format!("coordinate `{name}`"),
                    expected: vec![name.clone()],
                    available: available(),
                });
            };
            let data = nc.read_variable_as_f64(&name).map_err(|e| GridmetError::Read {
                path: path.clone(),
                what: format!("coordinate `{name}`"),
                message: e.to_string(),
            })?;
            let values: Vec<f64> = data.iter().copied().collect();
            let want = sizes[axis_pos[axis]];
            if cv.ndim() != 1 || values.len() != want {
                return Err(GridmetError::BadCoordinate {
                    path: path.clone(),
                    variable: name,
                    reason: format!("expected 1-D with {want} values, found {} values", values.len()),
                });
            }
            Ok((name, values))
        };
        let bad = |variable: &str, reason: String| GridmetError::BadCoordinate {
            path: path.clone(),
            variable: variable.to_string(),
            reason,
        };

        let (day_name, day_raw) = read_coord(0)?;
        let units = all_vars
            .iter()
            .find(|v| v.name() == day_name)
            .and_then(|v| v.attribute("units"))
            .and_then(|a| a.value.as_string())
            .unwrap_or_default();
        let offset = parse_day_units(&units).ok_or_else(|| GridmetError::DayUnits {
            path: path.clone(),
            variable: day_name.clone(),
            units: units.clone(),
        })?;
        let mut days = Vec::with_capacity(day_raw.len());
        for &d in &day_raw {
            let r = d.round();
            if !d.is_finite() || (d - r).abs() > 1e-6 || r.abs() > 1e9 {
                return Err(bad(&day_name, format!("value {d} is not a whole number of days")));
            }
            days.push(r as i32 + offset);
        }
        if days.windows(2).any(|w| w[1] <= w[0]) {
            return Err(bad(&day_name, "values are not strictly increasing".into()));
        }

        let (lat_name, lats) = read_coord(1)?;
        let (lon_name, lons) = read_coord(2)?;
        for (name, values) in [(&lat_name, &lats), (&lon_name, &lons)] {
            if values.is_empty() {
                return Err(bad(name, "is empty".into()));
            }
            if !values.iter().all(|v| v.is_finite()) || !strictly_monotonic(values) {
                return Err(bad(name, "values are not finite and strictly monotonic".into()));
            }
        }

        Ok(Self {
            nc,
            path,
            variable,
            var_name,
            axis_pos,
            lats,
            lons,
            days,
        })
    }

    /// The file path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The variable this file was opened for (`None` when opened by name with
    /// [`GridmetFile::open_named`]).
    pub fn variable(&self) -> Option<GridmetVariable> {
        self.variable
    }

    /// The NetCDF name of the data variable actually found.
    pub fn var_name(&self) -> &str {
        &self.var_name
    }

    /// Latitudes of the cell centres, in file order (GRIDMET: north → south).
    pub fn lats(&self) -> &[f64] {
        &self.lats
    }

    /// Longitudes of the cell centres, in file order.
    pub fn lons(&self) -> &[f64] {
        &self.lons
    }

    /// Days since 1900-01-01 of each time step (see [`day_to_ymd`]).
    pub fn days(&self) -> &[i32] {
        &self.days
    }

    /// Calendar dates `(year, month, day)` of each time step.
    pub fn dates(&self) -> Vec<(i32, u32, u32)> {
        self.days.iter().map(|&d| day_to_ymd(d)).collect()
    }

    /// `(n_lat, n_lon)`.
    pub fn grid_shape(&self) -> (usize, usize) {
        (self.lats.len(), self.lons.len())
    }

    /// How the data variable is stored.
    pub fn dim_order(&self) -> DimOrder {
        match self.axis_pos {
            [0, 1, 2] => DimOrder::DayLatLon,
            [0, 2, 1] => DimOrder::DayLonLat,
            _ => DimOrder::Other,
        }
    }

    /// The cell whose centre is nearest on each axis (independent argmin, first index on exact
    /// ties, as the authors' builder). `None` for a point outside the grid's cell edges (half a
    /// cell beyond the outermost centres) or a non-finite coordinate.
    pub fn nearest_cell(&self, lat: f64, lon: f64) -> Option<(usize, usize)> {
        Some((nearest_index(&self.lats, lat)?, nearest_index(&self.lons, lon)?))
    }

    /// One day's field, unpacked and masked (NaN), in `[lat][lon]` order of the file's
    /// coordinates: element `j * n_lon + i` is at `(lats()[j], lons()[i])`, whatever the storage
    /// order.
    pub fn read_day(&self, day_index: usize) -> Result<Vec<f32>> {
        self.check_days(&(day_index..day_index + 1))?;
        self.read_block(day_index..day_index + 1, 0..self.lats.len(), 0..self.lons.len())
    }

    /// Time series for each `(lat_idx, lon_idx)` over `day_range`: `result[p][t]` is point `p` on
    /// day `day_range.start + t`. Reads the bounding hyperslab of all points once (split along
    /// the day axis only when it would exceed [`MAX_BLOCK_VALUES`] values), never once per point.
    pub fn gather(&self, cells: &[(usize, usize)], day_range: Range<usize>) -> Result<Vec<Vec<f32>>> {
        self.check_days(&day_range)?;
        let (n_lat, n_lon) = self.grid_shape();
        for &(j, i) in cells {
            if j >= n_lat || i >= n_lon {
                return Err(self.out_of_range(format!("cell ({j}, {i}) outside the {n_lat} x {n_lon} grid")));
            }
        }
        let n_days = day_range.len();
        let mut out = vec![Vec::with_capacity(n_days); cells.len()];
        if cells.is_empty() || n_days == 0 {
            return Ok(out);
        }
        let lat_lo = cells.iter().map(|c| c.0).min().unwrap_or(0);
        let lat_hi = cells.iter().map(|c| c.0).max().unwrap_or(0) + 1;
        let lon_lo = cells.iter().map(|c| c.1).min().unwrap_or(0);
        let lon_hi = cells.iter().map(|c| c.1).max().unwrap_or(0) + 1;
        let (bl, bw) = (lat_hi - lat_lo, lon_hi - lon_lo);
        let days_per_read = (MAX_BLOCK_VALUES / (bl * bw)).max(1);
        let mut start = day_range.start;
        while start < day_range.end {
            let end = (start + days_per_read).min(day_range.end);
            let block = self.read_block(start..end, lat_lo..lat_hi, lon_lo..lon_hi)?;
            for (series, &(j, i)) in out.iter_mut().zip(cells) {
                for t in 0..end - start {
                    series.push(block[(t * bl + (j - lat_lo)) * bw + (i - lon_lo)]);
                }
            }
            start = end;
        }
        Ok(out)
    }

    fn out_of_range(&self, what: String) -> GridmetError {
        GridmetError::OutOfRange {
            path: self.path.clone(),
            variable: self.var_name.clone(),
            what,
        }
    }

    fn check_days(&self, range: &Range<usize>) -> Result<()> {
        if range.start > range.end || range.end > self.days.len() {
            return Err(self.out_of_range(format!(
                "day range {range:?} outside the file's {} days",
                self.days.len()
            )));
        }
        Ok(())
    }

    /// Reads one hyperslab and returns it in logical `[day][lat][lon]` order.
    fn read_block(&self, days: Range<usize>, lats: Range<usize>, lons: Range<usize>) -> Result<Vec<f32>> {
        let ranges = [&days, &lats, &lons];
        let mut selections = vec![NcSliceInfoElem::Index(0); 3];
        for (axis, r) in ranges.iter().enumerate() {
            selections[self.axis_pos[axis]] = NcSliceInfoElem::Slice {
                start: r.start as u64,
                end: r.end as u64,
                step: 1,
            };
        }
        let data = self
            .nc
            .read_variable_slice_unpacked_masked(&self.var_name, &NcSliceInfo { selections })
            .map_err(|e| GridmetError::Read {
                path: self.path.clone(),
                what: format!("variable `{}`", self.var_name),
                message: e.to_string(),
            })?;
        let lens = [days.len(), lats.len(), lons.len()];
        let mut file_shape = [0usize; 3];
        for axis in 0..3 {
            file_shape[self.axis_pos[axis]] = lens[axis];
        }
        if data.shape() != file_shape {
            return Err(self.out_of_range(format!(
                "hyperslab came back with shape {:?}, expected {file_shape:?}",
                data.shape()
            )));
        }
        let flat: Vec<f64> = data.iter().copied().collect();
        let file_stride = [file_shape[1] * file_shape[2], file_shape[2], 1];
        let stride = [
            file_stride[self.axis_pos[0]],
            file_stride[self.axis_pos[1]],
            file_stride[self.axis_pos[2]],
        ];
        let clamp_negative = self.variable == Some(GridmetVariable::Pr);
        let mut out = Vec::with_capacity(flat.len());
        for t in 0..lens[0] {
            for j in 0..lens[1] {
                for i in 0..lens[2] {
                    let v = flat[t * stride[0] + j * stride[1] + i * stride[2]];
                    // Packed precipitation unpacks to tiny negatives near 0; clamp as pyMETRIC does.
                    let v = if clamp_negative && v < 0.0 { 0.0 } else { v };
                    out.push(v as f32);
                }
            }
        }
        Ok(out)
    }
}

fn strictly_monotonic(values: &[f64]) -> bool {
    values.windows(2).all(|w| w[1] > w[0]) || values.windows(2).all(|w| w[1] < w[0])
}

/// Index of the nearest centre, or `None` beyond half a cell outside the outermost centres.
fn nearest_index(centres: &[f64], x: f64) -> Option<usize> {
    if !x.is_finite() || centres.is_empty() {
        return None;
    }
    let (first, last) = (centres[0], centres[centres.len() - 1]);
    let half = if centres.len() > 1 {
        (last - first).abs() / (centres.len() - 1) as f64 / 2.0
    } else {
        0.0
    };
    let (lo, hi) = (first.min(last) - half, first.max(last) + half);
    let eps = 1e-9;
    if x < lo - eps || x > hi + eps {
        return None;
    }
    let mut best = 0;
    for (k, c) in centres.iter().enumerate() {
        if (c - x).abs() < (centres[best] - x).abs() {
            best = k;
        }
    }
    Some(best)
}
