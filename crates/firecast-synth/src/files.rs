//! GRIDMET-style yearly files (`<short>_<YYYY>.nc`, and the true ignition probability
//! `truth/ignition_probability_<YYYY>.nc` in the same layout): schema, packing, atomic writing.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::grid::{GRID_STEP, GridWindow};
use super::netcdf3::{Attr, ClassicWriter, NcType, Schema, Version};
use super::{MODEL_VERSION, SynthError, TRUTH_VARIABLE, truth_file_name};
use firecast_data::gridmet::GridmetVariable;

/// What a yearly file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Content {
    /// A GRIDMET variable (`gridmet/<short>_<YYYY>.nc`).
    Weather(GridmetVariable),
    /// The generator's probability of at least one ignition per cell-day,
    /// `1 − exp(−λ)` (`truth/ignition_probability_<YYYY>.nc`, always float32).
    Truth,
}

impl Content {
    pub fn file_name(self, year: i32) -> String {
        match self {
            Self::Weather(v) => v.file_name(year),
            Self::Truth => truth_file_name(year),
        }
    }
}

/// The fill of float32 data variables (GRIDMET's old `missing_value`).
const FLOAT_FILL: f32 = -32767.0;

/// How a year's file is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Vintage {
    /// Post-2019 style: `(day, lat, lon)`, packed 16-bit integers (`scale_factor`,
    /// `add_offset`, `_FillValue`/`missing_value`, `_Unsigned` on some variables), a `crs`
    /// variable, `day` as double.
    PackedLatLon,
    /// Pre-2019 style: `(day, lon, lat)`, float32 with `missing_value = -32767`, no `crs`,
    /// `day` as int.
    FloatLonLat,
}

/// Packing of one variable in [`Vintage::PackedLatLon`] files: `value = raw·scale + offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Packing {
    /// `scale_factor`.
    pub scale: f64,
    /// `add_offset`.
    pub offset: f64,
    /// Stored as `short` with `_Unsigned = "true"` (raw 0..=65534, fill 65535 stored as -1);
    /// otherwise signed (raw -32766..=32767, fill -32767).
    pub unsigned: bool,
}

impl Packing {
    /// The `_FillValue` as stored (a `short`).
    pub fn fill(&self) -> i16 {
        if self.unsigned { -1 } else { -32767 }
    }

    /// Packs one value (NaN → fill), clamping to the representable range.
    #[inline]
    pub fn pack(&self, v: f32) -> i16 {
        if v.is_nan() {
            return self.fill();
        }
        let raw = ((f64::from(v) - self.offset) / self.scale).round();
        if self.unsigned {
            // Reinterpreting 0..=65534 as i16 is what `_Unsigned` declares.
            raw.clamp(0.0, 65534.0) as u16 as i16
        } else {
            raw.clamp(-32766.0, 32767.0) as i16
        }
    }

    /// Unpacks a raw value (`None` for the fill value).
    pub fn unpack(&self, raw: i16) -> Option<f64> {
        if raw == self.fill() {
            return None;
        }
        let r = if self.unsigned {
            f64::from(raw as u16)
        } else {
            f64::from(raw)
        };
        Some(r * self.scale + self.offset)
    }
}

/// FireCast's packing of each variable (finer than GRIDMET's, whose exact packing is
/// unverified; the unsigned ones use raw values above 32767, so a reader that ignores
/// `_Unsigned` gets them wrong).
pub fn packing(v: GridmetVariable) -> Packing {
    use GridmetVariable as G;
    let (scale, offset, unsigned) = match v {
        G::Pr => (0.01, 0.0, true),
        G::Rmax | G::Rmin => (0.002, 0.0, true),
        G::Sph => (5e-7, 0.0, true),
        G::Srad => (0.01, 0.0, true),
        G::Vpd => (0.0003, 0.0, true),
        G::Th => (0.01, 0.0, true),
        G::Tmmx | G::Tmmn => (0.01, 273.15, false),
        G::Vs => (0.001, 0.0, false),
        G::Bi => (0.01, 0.0, false),
        G::Erc => (0.005, 0.0, false),
        G::Fm100 | G::Fm1000 => (0.002, 0.0, false),
        G::Pet | G::Etr => (0.001, 0.0, false),
    };
    Packing {
        scale,
        offset,
        unsigned,
    }
}

/// `(description, standard_name, cell_methods)` in GRIDMET's style.
fn describe(v: GridmetVariable) -> (&'static str, Option<&'static str>, &'static str) {
    use GridmetVariable as G;
    const MEAN: &str = "time: mean(interval: 24 hours)";
    const MAX: &str = "time: maximum(interval: 24 hours)";
    const MIN: &str = "time: minimum(interval: 24 hours)";
    match v {
        G::Pr => (
            "Daily Accumulated Precipitation",
            Some("precipitation_amount"),
            "time: sum(interval: 24 hours)",
        ),
        G::Rmax => ("Daily Maximum Relative Humidity", Some("relative_humidity"), MAX),
        G::Rmin => ("Daily Minimum Relative Humidity", Some("relative_humidity"), MIN),
        G::Sph => ("Daily Mean Specific Humidity", Some("specific_humidity"), MEAN),
        G::Vpd => ("Daily Mean Vapor Pressure Deficit", None, MEAN),
        G::Vs => ("Daily Mean Wind Speed (10m)", Some("wind_speed"), MEAN),
        G::Tmmx => ("Daily Maximum Temperature (2m)", Some("air_temperature"), MAX),
        G::Tmmn => ("Daily Minimum Temperature (2m)", Some("air_temperature"), MIN),
        G::Srad => (
            "Daily Mean Downward Shortwave Radiation At Surface",
            Some("surface_downwelling_shortwave_flux_in_air"),
            MEAN,
        ),
        G::Bi => (
            "Burning Index - Fuel Model G (FireCast synthetic surrogate)",
            None,
            MEAN,
        ),
        G::Erc => (
            "Energy Release Component - Fuel Model G (FireCast synthetic surrogate)",
            None,
            MEAN,
        ),
        G::Fm100 => ("100-hour Dead Fuel Moisture", None, MEAN),
        G::Fm1000 => ("1000-hour Dead Fuel Moisture", None, MEAN),
        G::Pet => (
            "Daily Reference Evapotranspiration (short grass)",
            Some("water_potential_evaporation_amount"),
            "time: sum(interval: 24 hours)",
        ),
        G::Etr => (
            "Daily Reference Evapotranspiration (tall reference crop, alfalfa)",
            Some("water_potential_evaporation_amount"),
            "time: sum(interval: 24 hours)",
        ),
        G::Th => ("Daily Mean Wind Direction", Some("wind_from_direction"), MEAN),
    }
}

/// Builds the header of one yearly file.
pub(crate) fn schema(
    content: Content,
    vintage: Vintage,
    window: &GridWindow,
    n_days: usize,
    seed: u64,
) -> Schema {
    let mut s = Schema::default();
    let lon_d = s.add_dim("lon", window.n_lon);
    let lat_d = s.add_dim("lat", window.n_lat);
    let day_d = s.add_dim("day", n_days);
    let lats = window.lats();
    let lons = window.lons();
    let (lat_n, lat_s) = (lats[0], lats[lats.len() - 1]);
    let (lon_w, lon_e) = (lons[0], lons[lons.len() - 1]);
    let packed = vintage == Vintage::PackedLatLon;

    let g = &mut s.attrs;
    let truth = content == Content::Truth;
    g.push(Attr::text(
        "title",
        if truth {
            "FireCast SYNTHETIC true ignition probability on the GRIDMET grid (generator truth, \
             not a weather variable)"
        } else {
            "FireCast SYNTHETIC daily weather in GRIDMET format (not observations)"
        },
    ));
    // Names the crate the generator was born in: written into every file, so kept as it is
    // (the files' bytes are checked).
    g.push(Attr::text(
        "source",
        format!(
            "FireCast synthetic weather generator (firecast-data synth, model {MODEL_VERSION}); \
             seeded stochastic model, not GRIDMET/METDATA data"
        ),
    ));
    g.push(Attr::text("firecast_synthetic_model_version", MODEL_VERSION));
    g.push(Attr::text("firecast_seed", seed.to_string()));
    g.push(Attr::text(
        "comment",
        if truth {
            "The generator's probability of at least one ignition in each land cell-day, \
             1 - exp(-lambda) of the Poisson rate it drew the ignitions from: the oracle of a \
             forecasting experiment. Never a model input."
        } else {
            "Synthetic test-bed data: realistic formats and plausible physics, no real weather. \
             Do not use for science about the real world."
        },
    ));
    if packed {
        g.push(Attr::text("Conventions", "CF-1.6"));
        g.push(Attr::text("geospatial_bounds_crs", "EPSG:4326"));
        g.push(Attr::text(
            "geospatial_bounds",
            format!(
                "POLYGON(({lon_w:.10} {lat_n:.10}, {lon_w:.10} {lat_s:.10}, {lon_e:.10} {lat_s:.10}, \
                 {lon_e:.10} {lat_n:.10}, {lon_w:.10} {lat_n:.10}))"
            ),
        ));
    }
    g.push(Attr::double("geospatial_lat_min", lat_s - GRID_STEP / 2.0));
    g.push(Attr::double("geospatial_lat_max", lat_n + GRID_STEP / 2.0));
    g.push(Attr::double("geospatial_lon_min", lon_w - GRID_STEP / 2.0));
    g.push(Attr::double("geospatial_lon_max", lon_e + GRID_STEP / 2.0));
    g.push(Attr::double("geospatial_lat_resolution", 0.041_666_666_666_666));
    g.push(Attr::double("geospatial_lon_resolution", 0.041_666_666_666_666));
    g.push(Attr::text("geospatial_lat_units", "decimal_degrees north"));
    g.push(Attr::text("geospatial_lon_units", "decimal_degrees east"));
    g.push(Attr::text(
        "note1",
        "The projection information for this file is: GCS WGS 1984.",
    ));
    g.push(Attr::text(
        "note2",
        "Synthetic data generated by FireCast to mimic the GRIDMET (METDATA) file layout; \
         cite FireCast, not Abatzoglou (2013).",
    ));
    g.push(Attr::text(
        "note5",
        "Days correspond approximately to calendar days ending at midnight, Mountain Standard \
         Time (7 UTC the next calendar day)",
    ));

    s.add_var(
        "lon",
        NcType::Double,
        &[lon_d],
        vec![
            Attr::text("units", "degrees_east"),
            Attr::text("description", "longitude"),
            Attr::text("long_name", "longitude"),
            Attr::text("standard_name", "longitude"),
            Attr::text("axis", "X"),
        ],
    );
    s.add_var(
        "lat",
        NcType::Double,
        &[lat_d],
        vec![
            Attr::text("units", "degrees_north"),
            Attr::text("description", "latitude"),
            Attr::text("long_name", "latitude"),
            Attr::text("standard_name", "latitude"),
            Attr::text("axis", "Y"),
        ],
    );
    s.add_var(
        "day",
        if packed { NcType::Double } else { NcType::Int },
        &[day_d],
        vec![
            Attr::text("units", "days since 1900-01-01 00:00:00"),
            Attr::text("calendar", "gregorian"),
            Attr::text("description", "days since 1900-01-01"),
            Attr::text("long_name", "time"),
            Attr::text("standard_name", "time"),
            Attr::text("axis", "T"),
        ],
    );
    if packed {
        s.add_var(
            "crs",
            NcType::Int,
            &[],
            vec![
                Attr::text("grid_mapping_name", "latitude_longitude"),
                Attr::double("longitude_of_prime_meridian", 0.0),
                Attr::double("semi_major_axis", 6_378_137.0),
                Attr::double("inverse_flattening", 298.257_223_563),
                Attr::text(
                    "spatial_ref",
                    "GEOGCS[\"WGS 84\",DATUM[\"WGS_1984\",SPHEROID[\"WGS 84\",6378137,298.257223563]],\
                     PRIMEM[\"Greenwich\",0],UNIT[\"degree\",0.0174532925199433]]",
                ),
                Attr::text("long_name", "WGS 84"),
            ],
        );
    }

    let mut attrs = Vec::new();
    let name = match content {
        Content::Weather(var) => {
            let (description, standard, cell_methods) = describe(var);
            if packed {
                let p = packing(var);
                if p.unsigned {
                    attrs.push(Attr::text("_Unsigned", "true"));
                }
                attrs.push(Attr::short("_FillValue", p.fill()));
                attrs.push(Attr::short("missing_value", p.fill()));
                attrs.push(Attr::double("scale_factor", p.scale));
                attrs.push(Attr::double("add_offset", p.offset));
            } else {
                attrs.push(Attr::float("missing_value", FLOAT_FILL));
            }
            attrs.push(Attr::text("units", var.units()));
            attrs.push(Attr::text("description", description));
            attrs.push(Attr::text("long_name", var.short_name()));
            if let Some(sn) = standard {
                attrs.push(Attr::text("standard_name", sn));
            }
            attrs.push(Attr::text("cell_methods", cell_methods));
            var.netcdf_names()[0]
        }
        Content::Truth => {
            // Unpacked float32: probabilities down to 1e-9 matter for ranking, and a fixed
            // 16-bit step would flatten them.
            attrs.push(Attr::float("_FillValue", FLOAT_FILL));
            attrs.push(Attr::float("missing_value", FLOAT_FILL));
            attrs.push(Attr::text("units", "1"));
            attrs.push(Attr::text(
                "description",
                "Probability of at least one ignition in the cell on the day, 1 - exp(-lambda), \
                 lambda = s*(lambda_h + lambda_l + lambda_rx) of the synthetic ignition model \
                 (generator truth; not a feature)",
            ));
            attrs.push(Attr::text("long_name", TRUTH_VARIABLE));
            TRUTH_VARIABLE
        }
    };
    attrs.push(Attr::text("coordinates", "lon lat"));
    if packed {
        attrs.push(Attr::text("grid_mapping", "crs"));
    }
    let dims = if packed {
        vec![day_d, lat_d, lon_d]
    } else {
        vec![day_d, lon_d, lat_d]
    };
    let dtype = match content {
        Content::Weather(_) if packed => NcType::Short,
        _ => NcType::Float,
    };
    s.add_var(name, dtype, &dims, attrs);
    s
}

/// How the data variable's values are stored.
#[derive(Debug, Clone, Copy)]
enum Encoding {
    /// `(day, lat, lon)` packed 16-bit integers.
    Packed(Packing),
    /// `(day, lat, lon)` float32 (the truth in a packed-vintage year).
    FloatLatLon,
    /// `(day, lon, lat)` float32.
    FloatLonLat,
}

/// Writes one variable-year to a [`firecast_fs::TempPath`] and renames it to `<name>` on
/// [`GridmetWriter::finish`]; dropping it unfinished removes the temporary file.
pub(crate) struct GridmetWriter {
    writer: Option<ClassicWriter<BufWriter<File>>>,
    tmp: Option<firecast_fs::TempPath>,
    dest: PathBuf,
    encoding: Encoding,
    n_lat: usize,
    n_lon: usize,
    bytes: Vec<u8>,
}

/// A temporary name beside `dest` (removed when dropped unpublished).
pub(crate) fn temp_path(dest: &Path) -> Result<firecast_fs::TempPath, SynthError> {
    firecast_fs::TempPath::new(dest).map_err(|e| SynthError::io(&e.path, e.source))
}

impl GridmetWriter {
    #[allow(clippy::too_many_arguments)]
    pub fn create(
        dir: &Path,
        content: Content,
        year: i32,
        days: &[i32],
        vintage: Vintage,
        window: &GridWindow,
        seed: u64,
        version: Version,
    ) -> Result<Self, SynthError> {
        let dest = dir.join(content.file_name(year));
        let tmp = temp_path(&dest)?;
        let schema = schema(content, vintage, window, days.len(), seed);
        let encoding = match (content, vintage) {
            (Content::Weather(v), Vintage::PackedLatLon) => Encoding::Packed(packing(v)),
            (Content::Truth, Vintage::PackedLatLon) => Encoding::FloatLatLon,
            (_, Vintage::FloatLonLat) => Encoding::FloatLonLat,
        };
        let file = File::create(tmp.path()).map_err(|e| SynthError::io(tmp.path(), e))?;
        let mut me = Self {
            writer: None,
            tmp: Some(tmp),
            dest,
            encoding,
            n_lat: window.n_lat,
            n_lon: window.n_lon,
            bytes: Vec::new(),
        };
        let nc = |e| SynthError::netcdf(&me.dest, e);
        let mut w =
            ClassicWriter::new(BufWriter::with_capacity(1 << 20, file), &schema, version).map_err(nc)?;
        w.write_f64(&window.lons()).map_err(nc)?;
        w.write_f64(&window.lats()).map_err(nc)?;
        if vintage == Vintage::PackedLatLon {
            let d: Vec<f64> = days.iter().map(|&d| f64::from(d)).collect();
            w.write_f64(&d).map_err(nc)?;
            w.write_i32(&[0]).map_err(nc)?; // crs
        } else {
            w.write_i32(days).map_err(nc)?;
        }
        me.writer = Some(w);
        Ok(me)
    }

    /// Appends one day; `grid` is `[lat][lon]` in window order, NaN where masked.
    pub fn write_day(&mut self, grid: &[f32]) -> Result<(), SynthError> {
        let (n_lat, n_lon) = (self.n_lat, self.n_lon);
        debug_assert_eq!(grid.len(), n_lat * n_lon);
        let Some(w) = self.writer.as_mut() else {
            return Err(SynthError::netcdf(
                &self.dest,
                super::netcdf3::NcWriteError::Sequence("writer already finished".into()),
            ));
        };
        let fill = |v: f32| if v.is_nan() { FLOAT_FILL } else { v };
        let r = match self.encoding {
            Encoding::Packed(p) => {
                self.bytes.resize(grid.len() * 2, 0);
                self.bytes
                    .par_chunks_mut(n_lon * 2)
                    .zip(grid.par_chunks(n_lon))
                    .for_each(|(out, row)| {
                        for (o, &v) in out.chunks_exact_mut(2).zip(row) {
                            o.copy_from_slice(&p.pack(v).to_be_bytes());
                        }
                    });
                w.write_be_bytes(NcType::Short, &self.bytes)
            }
            Encoding::FloatLatLon => {
                self.bytes.resize(grid.len() * 4, 0);
                self.bytes
                    .par_chunks_mut(n_lon * 4)
                    .zip(grid.par_chunks(n_lon))
                    .for_each(|(out, row)| {
                        for (o, &v) in out.chunks_exact_mut(4).zip(row) {
                            o.copy_from_slice(&fill(v).to_be_bytes());
                        }
                    });
                w.write_be_bytes(NcType::Float, &self.bytes)
            }
            Encoding::FloatLonLat => {
                self.bytes.resize(grid.len() * 4, 0);
                self.bytes
                    .par_chunks_mut(n_lat * 4)
                    .enumerate()
                    .for_each(|(i, out)| {
                        for (j, o) in out.chunks_exact_mut(4).enumerate() {
                            o.copy_from_slice(&fill(grid[j * n_lon + i]).to_be_bytes());
                        }
                    });
                w.write_be_bytes(NcType::Float, &self.bytes)
            }
        };
        r.map_err(|e| SynthError::netcdf(&self.dest, e))
    }

    /// Completes the file and renames it into place.
    pub fn finish(mut self) -> Result<PathBuf, SynthError> {
        let Some(w) = self.writer.take() else {
            return Err(SynthError::netcdf(
                &self.dest,
                super::netcdf3::NcWriteError::Sequence("writer already finished".into()),
            ));
        };
        let buf = w.finish().map_err(|e| SynthError::netcdf(&self.dest, e))?;
        let Some(tmp) = self.tmp.take() else {
            return Err(SynthError::netcdf(
                &self.dest,
                super::netcdf3::NcWriteError::Sequence("writer already finished".into()),
            ));
        };
        let file = buf
            .into_inner()
            .map_err(|e| SynthError::io(tmp.path(), e.into_error()))?;
        file.sync_all().map_err(|e| SynthError::io(tmp.path(), e))?;
        drop(file);
        tmp.publish().map_err(|e| SynthError::io(&self.dest, e.source))?;
        Ok(self.dest.clone())
    }
}

impl Drop for GridmetWriter {
    fn drop(&mut self) {
        // Unfinished (an error happened): close the file; dropping `tmp` (after this)
        // removes the partial file.
        self.writer = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packing_round_trips_and_masks() {
        for v in GridmetVariable::ALL {
            let p = packing(v);
            for x in [0.0f32, 0.5, 1.0, 13.7] {
                let x = match v {
                    GridmetVariable::Tmmx | GridmetVariable::Tmmn => x + 250.0,
                    GridmetVariable::Sph => x * 1e-3,
                    _ => x,
                };
                let back = p.unpack(p.pack(x)).expect("not fill");
                assert!(
                    (back - f64::from(x)).abs() <= p.scale * 0.5 + 1e-9,
                    "{v}: {x} -> {back}"
                );
            }
            assert_eq!(p.unpack(p.pack(f32::NAN)), None);
        }
        // The unsigned variables really use the upper half of u16.
        let p = packing(GridmetVariable::Srad);
        assert!(p.pack(400.0) < 0);
        assert_eq!(p.unpack(p.pack(400.0)), Some(400.0));
    }
}
