//! Seeded synthetic sources in the real formats: GRIDMET-style yearly NetCDF files
//! (`gridmet/<short>_<YYYY>.nc`, NetCDF classic CDF-1/CDF-2) and a WFIGS-style incident CSV
//! (`incidents/wfigs_incidents.csv`); on request also the generator's true ignition
//! probability per cell-day in the same layout (`truth/ignition_probability_<YYYY>.nc`,
//! [`SynthConfig::write_truth`]), the oracle of a forecasting experiment.
//!
//! **This is a test bed, not data.** The weather is a seeded stochastic model with plausible
//! climatology, persistence, spatial correlation and NFDRS-style fuel-moisture integration
//! (see [`model_card`]); the ignitions are a documented Poisson function of that weather and
//! of a synthetic human-activity field. Nothing in these files is an observation.
//!
//! ```no_run
//! use firecast_synth::{generate, Region, SynthConfig};
//! let config = SynthConfig::new(42, Region::Box { lat_min: 39.0, lat_max: 40.0, lon_min: -117.0, lon_max: -116.0 }, (2018, 2019));
//! let summary = generate(&config, std::path::Path::new("/tmp/synth"), &mut |_, _| {}).unwrap();
//! println!("{} files, {} ignitions", summary.gridmet_files.len(), summary.ignitions);
//! ```
//!
//! Determinism: the same configuration gives byte-identical files. All randomness is
//! counter-based (a hash of seed, stream, day and global cell), rows are computed in parallel
//! with rayon without any scheduling dependence, and the files contain no time stamps. A box
//! region sees exactly the weather of the same cells in a CONUS run with the same seed and
//! years (only the ignition record numbering differs).

mod climate;
mod files;
mod grid;
mod ignitions;
pub mod netcdf3;
mod noise;
mod place;
mod weather;

use std::fs;
use std::path::{Path, PathBuf};

pub use files::{Packing, Vintage, packing};
pub use grid::{
    CONUS_OUTLINE, GRID_LAT0, GRID_LON0, GRID_N_LAT, GRID_N_LON, GRID_STEP, GridWindow, Region, grid_lat,
    grid_lon, is_land, land_mask, state_of,
};
pub use ignitions::{IgnitionCause, SynthIgnition, WFIGS_HEADER, hub_datetime};
pub use netcdf3::Version as NcVersion;
pub use place::{
    PlaceClimate, PlaceError, PlaceGrid, PlaceLandscape, igbp, place_landscape, world_elevation_m, world_seed,
};

use firecast_data::gridmet::{GridmetVariable, day_to_ymd, ymd_to_day};

/// Version of the synthetic model, written to every file (`firecast_synthetic_model_version`).
pub const MODEL_VERSION: &str = "firecast-synth-1.0";

/// File name of the incidents CSV inside `<out_dir>/incidents/`.
pub const INCIDENTS_CSV: &str = "wfigs_incidents.csv";

/// Folder of the truth files inside the output directory (beside `gridmet/`, never in it, so
/// no GRIDMET reader takes the truth for weather).
pub const TRUTH_DIR: &str = "truth";

/// NetCDF variable (and file-name stem) of the true probability of at least one ignition per
/// cell-day, `1 − exp(−λ)`.
pub const TRUTH_VARIABLE: &str = "ignition_probability";

/// The truth file of `year`: `ignition_probability_<YYYY>.nc`.
pub fn truth_file_name(year: i32) -> String {
    format!("{TRUTH_VARIABLE}_{year:04}.nc")
}

/// The year of a truth file name `ignition_probability_<YYYY>.nc` (directories are ignored).
pub fn truth_file_year(path: impl AsRef<Path>) -> Option<i32> {
    let name = path.as_ref().file_name()?.to_str()?;
    let year = name
        .strip_suffix(".nc")?
        .strip_prefix(TRUTH_VARIABLE)?
        .strip_prefix('_')?;
    if year.len() != 4 || !year.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    year.parse().ok()
}

/// Storage layout of the yearly files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DimOrderChoice {
    /// Every year `(day, lat, lon)`, packed i16 with `crs` ([`Vintage::PackedLatLon`]).
    LatLon,
    /// Every year `(day, lon, lat)`, float32 with `missing_value`, no `crs`
    /// ([`Vintage::FloatLonLat`]).
    LonLat,
    /// Like real GRIDMET downloads: years before 2019 in the old layout, later years new.
    #[default]
    ByVintage,
}

impl DimOrderChoice {
    /// The vintage of `year`'s files.
    pub fn vintage(self, year: i32) -> Vintage {
        match self {
            Self::LatLon => Vintage::PackedLatLon,
            Self::LonLat => Vintage::FloatLonLat,
            Self::ByVintage if year < 2019 => Vintage::FloatLonLat,
            Self::ByVintage => Vintage::PackedLatLon,
        }
    }
}

/// What to generate.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthConfig {
    /// Seed of every random number.
    pub seed: u64,
    /// Grid window.
    pub region: Region,
    /// First and last year written (inclusive).
    pub years: (i32, i32),
    /// Variables to write files for (default: all 16). Duplicates are ignored. The whole
    /// model always runs (the ignitions need it); only the file writing is skipped.
    pub variables: Vec<GridmetVariable>,
    /// Storage layout by year.
    pub dim_order: DimOrderChoice,
    /// Multiplier of every ignition rate (1.0 ≈ 27 000 ignitions a year over CONUS).
    pub ignition_rate_scale: f64,
    /// Whether to write `incidents/wfigs_incidents.csv`.
    pub write_incidents: bool,
    /// Days simulated before 1 January of the first year, so fuel moistures and anomalies are
    /// in equilibrium (default 365).
    pub warmup_days: u32,
    /// Fraction of wildfires reported twice (default 0.06).
    pub duplicate_fraction: f64,
    /// NetCDF classic version ([`NcVersion::Auto`]: CDF-2 only when a file exceeds 2 GiB).
    pub netcdf_version: NcVersion,
    /// Whether to write `truth/ignition_probability_<YYYY>.nc` (default false: a CONUS year
    /// is 1.2 GB of float32, and only forecasting experiments need it).
    pub write_truth: bool,
}

impl SynthConfig {
    /// A configuration with the defaults: all 16 variables, [`DimOrderChoice::ByVintage`],
    /// rate scale 1, incidents written, 365 warm-up days, 6 % duplicates, automatic format,
    /// no truth files.
    pub fn new(seed: u64, region: Region, years: (i32, i32)) -> Self {
        Self {
            seed,
            region,
            years,
            variables: GridmetVariable::ALL.to_vec(),
            dim_order: DimOrderChoice::ByVintage,
            ignition_rate_scale: 1.0,
            write_incidents: true,
            warmup_days: 365,
            duplicate_fraction: 0.06,
            netcdf_version: NcVersion::Auto,
            write_truth: false,
        }
    }
}

/// What [`generate`] wrote.
#[derive(Debug, Clone)]
pub struct SynthSummary {
    /// The NetCDF files, by year then in the order of [`SynthConfig::variables`].
    pub gridmet_files: Vec<PathBuf>,
    /// The truth files (`truth/ignition_probability_<YYYY>.nc`), by year; empty unless
    /// [`SynthConfig::write_truth`].
    pub truth_files: Vec<PathBuf>,
    /// The incidents CSV, when written.
    pub incidents_csv: Option<PathBuf>,
    /// The grid window.
    pub window: GridWindow,
    /// Rows (latitudes) of the window.
    pub n_lat: usize,
    /// Columns (longitudes) of the window.
    pub n_lon: usize,
    /// Unmasked (land) cells of the window.
    pub land_cells: usize,
    /// Days written per variable (all years).
    pub days_written: u64,
    /// Days simulated including the warm-up.
    pub days_simulated: u64,
    /// Ignitions (true fires, `WF` and `RX`).
    pub ignitions: u64,
    /// CSV records (ignitions plus duplicate reports).
    pub reported_records: u64,
    /// The ignitions, in discovery order.
    pub events: Vec<SynthIgnition>,
    /// [`MODEL_VERSION`].
    pub model_version: &'static str,
}

/// Errors of the generator.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    /// The configuration cannot be generated.
    #[error("invalid synthetic-source configuration: {0}")]
    InvalidConfig(String),
    /// A file-system operation failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The path involved.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Writing a NetCDF file failed.
    #[error("{}: {source}", path.display())]
    NetCdf {
        /// The file.
        path: PathBuf,
        /// The error.
        source: netcdf3::NcWriteError,
    },
    /// Writing the CSV failed.
    #[error("{}: CSV error: {message}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// The csv crate's message.
        message: String,
    },
}

impl SynthError {
    fn io(path: &Path, source: std::io::Error) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    fn netcdf(path: &Path, source: netcdf3::NcWriteError) -> Self {
        Self::NetCdf {
            path: path.to_path_buf(),
            source,
        }
    }
}

fn validate(config: &SynthConfig) -> Result<(), SynthError> {
    let bad = |m: String| Err(SynthError::InvalidConfig(m));
    let (y0, y1) = config.years;
    if y0 > y1 {
        return bad(format!("years ({y0}, {y1}): the first year is after the last"));
    }
    if !(1850..=2300).contains(&y0) || !(1850..=2300).contains(&y1) {
        return bad(format!("years ({y0}, {y1}) must lie within 1850..=2300"));
    }
    if config.warmup_days > 3660 {
        return bad(format!("warmup_days {} exceeds 10 years", config.warmup_days));
    }
    if !config.ignition_rate_scale.is_finite() || config.ignition_rate_scale < 0.0 {
        return bad(format!(
            "ignition_rate_scale {} must be finite and >= 0",
            config.ignition_rate_scale
        ));
    }
    if !(0.0..=1.0).contains(&config.duplicate_fraction) {
        return bad(format!(
            "duplicate_fraction {} must be in [0, 1]",
            config.duplicate_fraction
        ));
    }
    Ok(())
}

/// Generates the configured sources under `out_dir` (`gridmet/` and `incidents/` are created,
/// and `truth/` with [`SynthConfig::write_truth`]).
///
/// `progress(done, total)` is called after every simulated day (warm-up included). Every file
/// is written to a temporary name (`firecast_fs`'s scheme) in its directory and renamed when
/// complete.
pub fn generate(
    config: &SynthConfig,
    out_dir: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<SynthSummary, SynthError> {
    validate(config)?;
    let window = config.region.window()?;
    let mut variables: Vec<GridmetVariable> = Vec::new();
    for &v in &config.variables {
        if !variables.contains(&v) {
            variables.push(v);
        }
    }
    let (y0, y1) = config.years;
    let date = |y: i32, m: u32, d: u32| {
        ymd_to_day(y, m, d).ok_or_else(|| SynthError::InvalidConfig(format!("year {y} out of range")))
    };
    let first_day = date(y0, 1, 1)?;
    let last_day = date(y1, 12, 31)?;
    let day0 = first_day - config.warmup_days as i32;

    let grid_dir = out_dir.join("gridmet");
    let inc_dir = out_dir.join("incidents");
    let truth_dir = out_dir.join(TRUTH_DIR);
    if !variables.is_empty() {
        fs::create_dir_all(&grid_dir).map_err(|e| SynthError::io(&grid_dir, e))?;
    }
    if config.write_incidents {
        fs::create_dir_all(&inc_dir).map_err(|e| SynthError::io(&inc_dir, e))?;
    }
    if config.write_truth {
        fs::create_dir_all(&truth_dir).map_err(|e| SynthError::io(&truth_dir, e))?;
    }

    let mut world = weather::World::new(config.seed, window, day0);
    let mut state = vec![weather::FuelState::default(); world.land_cells()];
    let all_index = |v: GridmetVariable| GridmetVariable::ALL.iter().position(|&a| a == v).unwrap_or(0);
    // One output grid per file written each day: the variables, then the truth.
    let mut contents: Vec<files::Content> = variables.iter().map(|&v| files::Content::Weather(v)).collect();
    let mut slots: Vec<(usize, usize)> = variables
        .iter()
        .enumerate()
        .map(|(k, &v)| (all_index(v), k))
        .collect();
    if config.write_truth {
        slots.push((weather::idx::TRUTH, contents.len()));
        contents.push(files::Content::Truth);
    }
    let mut outputs: Vec<Vec<f32>> = vec![vec![f32::NAN; window.cells()]; contents.len()];
    let total = (last_day - day0 + 1) as u64;
    let mut candidates = Vec::new();
    let mut writers: Vec<(files::Content, files::GridmetWriter)> = Vec::new();
    let mut gridmet_files = Vec::new();
    let mut truth_files = Vec::new();

    for (done, day) in (day0..=last_day).enumerate() {
        world.advance(day);
        let record = day >= first_day;
        let (y, m, d) = day_to_ymd(day);
        if record && m == 1 && d == 1 && !contents.is_empty() {
            let days: Vec<i32> = (date(y, 1, 1)?..=date(y, 12, 31)?).collect();
            let vintage = config.dim_order.vintage(y);
            writers = contents
                .iter()
                .map(|&c| {
                    let dir = match c {
                        files::Content::Weather(_) => &grid_dir,
                        files::Content::Truth => &truth_dir,
                    };
                    files::GridmetWriter::create(
                        dir,
                        c,
                        y,
                        &days,
                        vintage,
                        &window,
                        config.seed,
                        config.netcdf_version,
                    )
                    .map(|w| (c, w))
                })
                .collect::<Result<_, _>>()?;
        }
        let ctx = weather::day_ctx(day, record, config.ignition_rate_scale);
        let (outs, sl): (&mut [Vec<f32>], &[(usize, usize)]) = if record {
            (&mut outputs, &slots)
        } else {
            (&mut [], &[])
        };
        candidates.extend(world.run_day(&ctx, record, &mut state, outs, sl));
        if record {
            for ((_, w), grid) in writers.iter_mut().zip(&outputs) {
                w.write_day(grid)?;
            }
            if m == 12 && d == 31 {
                for (c, w) in writers.drain(..) {
                    let path = w.finish()?;
                    match c {
                        files::Content::Weather(_) => gridmet_files.push(path),
                        files::Content::Truth => truth_files.push(path),
                    }
                }
            }
        }
        progress(done as u64 + 1, total);
    }

    let set = ignitions::build(config.seed, &candidates, config.duplicate_fraction);
    let incidents_csv = if config.write_incidents {
        Some(ignitions::write_csv(&set, &inc_dir.join(INCIDENTS_CSV))?)
    } else {
        None
    };
    Ok(SynthSummary {
        gridmet_files,
        truth_files,
        incidents_csv,
        window,
        n_lat: window.n_lat,
        n_lon: window.n_lon,
        land_cells: world.land_cells(),
        days_written: (last_day - first_day + 1) as u64,
        days_simulated: total,
        ignitions: set.events.len() as u64,
        reported_records: set.n_records(),
        model_version: MODEL_VERSION,
        events: set.events,
    })
}

/// The model card (Markdown) that the dataset card embeds: what the generator is, its
/// equations and constants (the rates and response factors are formatted from the code's own
/// constants), calibration notes and limits.
pub fn model_card() -> String {
    use weather::{BASE_HUMAN, BASE_LIGHTNING, BASE_RX, K_BDY, K100, K1000, PDSI_RHO};
    let n_vertices = CONUS_OUTLINE.len();
    format!(
        "# FireCast synthetic sources — model card (`{MODEL_VERSION}`)

**Synthetic test-bed data: not observations, not GRIDMET, not WFIGS.** The files reproduce the
real formats (GRIDMET yearly NetCDF, WFIGS CSV) and plausible physics so that the FireCast
pipeline, its loaders and an ignition classifier can be exercised without downloads. Any
resemblance of a fire or a weather day to reality is chance. Same seed and configuration →
byte-identical files.

## Files

* `gridmet/<short>_<YYYY>.nc` for pr, rmax, rmin, sph, vpd, vs, tmmx, tmmn, srad, bi, erc,
  fm100, fm1000, pet, etr, th on the real GRIDMET grid (1/24°; lat 49.4 → 25.0667 descending,
  lon −124.7667 → −67.0583; a box region is a window of it), `day` in days since 1900-01-01
  (gregorian). NetCDF classic CDF-1, or CDF-2 (64-bit offsets) when a file exceeds 2 GiB.
* Two layouts, as GRIDMET had: *packed* — `(day, lat, lon)` 16-bit integers with
  `scale_factor`, `add_offset`, `_FillValue` = `missing_value` (−32767, or 65535 stored as −1
  with `_Unsigned = \"true\"` for pr, rmax, rmin, sph, srad, vpd, th), a `crs` grid-mapping
  variable, `day` double; *old* — `(day, lon, lat)` float32 with `missing_value = -32767`, no
  `crs`, `day` int. By default years before 2019 use the old layout.
* Cells outside FireCast's rough {n_vertices}-vertex outline of the lower 48 states (ocean,
  Great Lakes, Canada, Mexico) are masked in every variable.
* `incidents/wfigs_incidents.csv`: the 97 columns of a real 2023 WFIGS export in order, dates
  `YYYY/MM/DD HH:MM:SS+00` (UTC), fields FireCast has filled, the rest empty.
* `truth/ignition_probability_<YYYY>.nc` (when asked for: the `truth` output of
  `data.synthesize`, `firecast dataset synthesize`): the generator's true probability of at least
  one ignition in each land cell-day, `ignition_probability = 1 − exp(−λ)` with λ the Poisson rate
  of the Ignitions section, float32 with `_FillValue` = `missing_value` = −32767 off land, in the
  layout of that year's GRIDMET files (dimension order, `lat`/`lon`/`day` axes, day numbering,
  `crs`). It is the oracle of a forecasting experiment — the best any model can score on these
  data — never a weather variable nor a model input, hence its own folder.

## Static world (per cell; seeded, identical for any region)

* Elevation z: hand-made macro relief (intermountain plateau ~1500 m with the Sonoran/Mojave
  deserts and the Columbia Basin cut out, the Colorado Plateau, a Rocky Mountain block west of
  the Front Range, the Sierra Nevada and Cascades, the Coast Ranges, the Great Plains sloping
  from ~1600 m to ~300 m, the Appalachians) plus seeded 7-octave fractal value noise (1/8°–8°),
  rougher in the mountains.
* Annual precipitation P from Gulf/Atlantic moisture access (east of ~99°W, more to the south),
  Pacific access (a coastal term cut by the Sierra/Cascade rain shadow and a weaker far-reaching
  one, both mostly north of 38°N), orography (0.2 mm per m above 900 m), the monsoon, and a
  seeded ±15 % field: ~150–350 mm in the interior West, ~800–1500 mm in the East, >1000 mm on the
  Northwest coast. Aridity `A = clamp(1 − (P − 220)/850, 0, 1)`.
* Seasonal cycles as annual and semi-annual harmonics: Mediterranean winter rain near the Pacific,
  a one-sided Jul–Sep monsoon bump `(1 + cos(x − φ))²/4` in Arizona/New Mexico, a June Plains
  maximum, a Florida wet summer. Wet-day fraction `f_w = f₀·√P_rel`,
  `f₀ = 0.07 + 0.33(1 − e^(−P/800))`.
* Temperature `T̄ = 27 − 0.85(lat − 25) + maritime + desert heat + interior-West mildness −
  4.5 K/km·z` °C, seasonal half-range `(5.5 + 0.45(lat − 25))·continentality` (0.3 on the Pacific
  coast, ~1.1 inland), peak late July (later on the coast). Diurnal range
  `8.5 + 3A + 1.5·min(z/2000, 1.5) − coastal fog`, larger in summer.
* Dew-point depression below Tmin: `0.8 + 11A^1.2` K, drier summers in arid and Mediterranean
  climates, moister under the monsoon and on the immediate coast.
* Wind climatology (windy Plains and mountains, calm Southeast, spring maximum), westerlies
  strengthening north and in winter, summer southerlies over the Plains, northerlies on the
  California coast, easterlies in south Florida.
* Human activity H: ~50 metro areas and 400 seeded towns (saturating), a rural base larger in
  the East, ×2.5 in the rural Southeast, × a seeded log-normal fractal. Lightning propensity L:
  terrain, monsoon, Florida. Prescribed-fire propensity R: Southeast, wetter forests.

## Daily weather (per land cell and day)

Anomalies are smooth Gaussian fields: lattices of independent AR(1) processes, smoothstep-
bilinearly upsampled with variance normalisation — temperature `aT = 0.8·T(2°, φ 0.75) +
0.6·T(0.5°, φ 0.6)`, moisture `aP = 0.8·P(2°, φ 0.55) + 0.6·P(0.5°, φ 0.35)`, convection `aC`
(0.25°, φ 0.1), wind `aU, aV` (2°, φ 0.55), gustiness `aW` (1°, φ 0.45), drought regime `aD`
(4°, φ 0.993) — plus white per-cell noise ε (counter-based hashes).

* Precipitation: wet when `z = (0.8aP + 0.35ε + c·aC)/‖·‖ > θ = Φ⁻¹(1 − f_w) + 0.12aD`
  (c > 0 on warm days: convective patchiness); amount
  `α(1 − 0.06aD)·(−ln q)^1.25/Γ(2.25)`, `q = Q(z)/Q(θ)` — a Weibull(0.8) with the climatological
  wet-day mean α = P_clim/f_w; 0.1–400 mm.
* Cloud `c = ½ + ½x/(1 + |x|)`, `x = 1.5(z − θ) + 0.5`. Mean temperature
  `T̄ + σ_T·aT + 0.5ε + 0.9aD − 1.8(c − 0.35)` (σ_T larger in winter and inland); daily range
  `DTR·(1.3 − 0.75c)` (×0.85 on wet days, ≥ 2 K); tmmx/tmmn = mean ± range/2.
* Humidity: `Td = Tmin − D`, `D = D_clim − 2.2aP + 1.2aD + 0.8ε ≥ 0` (×0.15 on wet days);
  `es(T) = 0.6108·exp(17.27T/(T + 237.3))` kPa, `ea = es(Td)`; rmax = 100·ea/es(Tmin),
  rmin = 100·ea/es(Tmax), vpd = (es(Tmax) + es(Tmin))/2 − ea ≥ 0, sph = 0.622·ea/(p − 0.378·ea)
  with p from elevation.
* srad = Ra·(0.75 + 2·10⁻⁵z)·(1 − 0.65c) (FAO-56 extraterrestrial radiation Ra), W m⁻².
* Wind: flow (u, v) = climatology + 2.8·(aU, aV); th = the direction it comes from + 14°·ε;
  vs = vs_clim·exp(0.33aW + 0.1ε − 0.06) + 0.12·max(0, |(u, v)| − 3), 0.1–29 m/s.
* pet (grass) = 0.0135·(T̄ + 17.8)·0.408·Rs + 0.22·u₂·vpd (Hargreaves 1975 radiation form plus
  an aerodynamic term, u₂ = 0.748·vs), 0–17 mm; etr = pet·(1.15 + 0.04·min(u₂, 6) +
  0.03·min(vpd, 6)) ≥ pet, ≤ 27 mm.

## Fuel moisture and fire danger (NFDRS 1978 style)

* EMC (Simard 1968; T °F, H %): H < 10: `0.03229 + 0.281073H − 0.000578HT`; 10 ≤ H < 50:
  `2.22749 + 0.160107H − 0.014784T`; H ≥ 50: `21.0606 + 0.005565H² − 0.00035HT − 0.483199H`.
  EMCmin from (Tmax, rmin), EMCmax from (Tmin, rmax), weighted by day length N:
  `EMC̄ = (N·EMCmin + (24 − N)·EMCmax)/24`.
* Precipitation duration `d = min(8, 1 + pr/4)` h when pr ≥ 0.25 mm, else 0.
* 100-h: `B = ((24 − d)·EMC̄ + d·(0.5d + 41))/24`; `fm100 += (B − fm100)·{K100:.4}`
  (1 − 0.87·e^(−24/100)); 0.3–33 %.
* 1000-h: `B = ((24 − d)·EMC̄ + d·(2.7d + 76))/24`, a 7-day running mean of it
  (`{K_BDY:.4}`/day), `fm1000 += (B̄ − fm1000)·{K1000:.4}` (the NFDRS weekly factor
  1 − 0.82·e^(−168/1000) spread over 7 days); 0.4–48 %.
* 1-h / 10-h (internal): 1.03 / 1.28 × EMCmin, 35 % on wet days.
* ERC (fuel model G) surrogate: `Δ = 0.15(1 − m₁/30)⁺ + 0.10(1 − m₁₀/30)⁺ + 0.25(1 − fm100/30)⁺ +
  0.50(1 − fm1000/35)⁺`, greenness G (seasonal, 0–1), `ERC = min(132, 158·(Δ(1 − 0.3G))^2.5)`.
* BI surrogate: spread component `SC = 4·η·(1 + 0.12·U₂₀^1.5)` (U₂₀ = vs/1.15 in mi/h; η =
  Rothermel's moisture damping of m₁, m₁₀ with extinction 25 %), `BI = min(214, 3.01·(SC·ERC)^0.46)`
  (the NFDRS BI formula).
* Drought index (internal, not written): `X = ρX + 0.1203/√f_w·(pr/α − f_w)`, ρ = {PDSI_RHO:.6}
  (Palmer's monthly 0.897 per day).
* Spin-up: the state starts at fm100 = 18 %, fm1000 = 22 % and runs `warmup_days` (default
  365) before the first written day; anomaly lattices start from their stationary distribution.

## Ignitions

Per land cell-day `N ~ Poisson(λ)`, `λ = s·(λ_h + λ_l + λ_rx)` (s = `ignition_rate_scale`), with
`x₁ = (12 − fm100)/4`, `x₂ = (15 − fm1000)/5`, `x₃ = (erc − 40)/25`, `x₄ = (vs − 3.5)/2.5`,
`x₅ = (vpd − 1.5)/1.2`, `x₆ = (30 − rmin)/15`, `cold = clamp((3 − Tmax°C)/10, 0, 1)`:

* human WF: `λ_h = {BASE_HUMAN:e}·H/(1 + H/3)·m_day·exp(0.35x₁ + 0.15x₂ + 0.2x₃ + 0.2x₄ +
  0.1x₅ + 0.1x₆ − 0.8·ln(1 + pr) − 2.5·cold)`; `m_day`: spring (×1.45 late March) and autumn
  bumps, ×1.15 on weekends, ×2.5 on 4–5 July;
* lightning WF: `λ_l = {BASE_LIGHTNING:e}·L·ramp((Tmax − 22)/12)·ramp(ea/1.2)·r·exp(1.2aC − 0.72 +
  0.5x₁ + 0.3x₂ + 0.3x₃ − 2.5·cold − max(0, (pr − 5)/4))`, r = 0.45 without rain, 1 with it —
  warm, moist, convective days, most efficient with little rain;
* prescribed RX: `λ_rx = {BASE_RX:e}·R·m_rx·exp(−((fm100 − 14)/5)² − 0.5·max(0, vs − 5))` on days
  with pr < 1 mm; `m_rx` peaks in late winter and autumn.

Each ignition: cause by the rates' proportions; a point uniform in the cell; a discovery hour
(local solar) ~N(14.5, 3.2) (85 %) or uniform for human fires, ~N(16.5, 3) lightning,
~N(11, 1.5) RX, converted to UTC and kept inside the GRIDMET day (07:00 to 07:00 UTC); size
`0.1·U^(−1/α)` acres, `α = 0.85 − 0.4·ramp((erc − 30)/70) − 0.15·ramp((vs − 4)/6)` (−0.05 for
lightning; heavier tails when dry and windy), ≤ 500 000 acres; RX log-normal around 40 acres.
X/Y differ from InitialLatitude/InitialLongitude by 0–60 m (85 %), 60–800 m (12 %) or
1–2.5 km (3 %); 3 % of records have no Initial* values. A fraction (default 6 %) of wildfires
gets a second record from another unit 3–110 min later (25 %: earlier) and 80–700 m away, with
its own IrwinID and UniqueFireIdentifier, which a 5 km / 2 h de-duplication removes.
`POOState` comes from the nearest of ~70 state centres; units, GACCs, names and causes are
invented but WFIGS-shaped.

Calibration (seed 42, CONUS, 2021, scale 1): ~27 000 ignitions (~84 % human, ~13 % lightning,
~3 % RX) and ~29 000 records; most in CA, TX, AZ, UT, OK, CO, ID; human fires peak in spring in
the Southeast and in summer in the West. Ignition cell-days are markedly drier than average
(the rate varies by two orders of magnitude between wet and dry fuels).

## Limits

No snow, no terrain shading, no moving fronts, no lakes but the Great Lakes; ERC and BI are
surrogates of the NFDRS fuel-model-G indices (the same inputs and behaviour, not the full
Rothermel computation); a single cell's annual precipitation varies more from year to year
(CV ≈ 0.3) than in reality; states, units, GACCs and names in the CSV are rough or invented; the
real GRIDMET packing is unverified and this generator's is finer.
"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_card_is_complete() {
        let card = model_card();
        assert!(card.starts_with("# FireCast synthetic sources"));
        assert!(card.contains(MODEL_VERSION));
        assert!(card.contains("0.3156") && card.contains("0.0510") && card.contains("3.2e-4"));
        assert!(
            !card.contains('{') && !card.contains('}'),
            "unformatted placeholder"
        );
    }

    #[test]
    fn invalid_configs_are_rejected() {
        let dir = std::env::temp_dir().join("firecast-synth-invalid");
        let mut c = SynthConfig::new(1, Region::Conus, (2020, 2019));
        assert!(matches!(
            generate(&c, &dir, &mut |_, _| {}),
            Err(SynthError::InvalidConfig(_))
        ));
        c.years = (2020, 2020);
        c.ignition_rate_scale = f64::NAN;
        assert!(matches!(
            generate(&c, &dir, &mut |_, _| {}),
            Err(SynthError::InvalidConfig(_))
        ));
        c.ignition_rate_scale = 1.0;
        c.region = Region::Box {
            lat_min: 10.0,
            lat_max: 11.0,
            lon_min: 0.0,
            lon_max: 1.0,
        };
        assert!(matches!(
            generate(&c, &dir, &mut |_, _| {}),
            Err(SynthError::InvalidConfig(_))
        ));
        assert!(!dir.exists(), "nothing is created for an invalid configuration");
    }
}
