//! `data.windows` in shards: shard `i/N` reads the variables `[V·i/N, V·(i+1)/N)` of the
//! configured `V` (for each, every year's file), so each GRIDMET file is read by exactly one
//! shard and the shard count is known from the params when the pipeline is planned. Every
//! shard decides alike which samples have windows (the samples, the file names and the first
//! file's grid, all cheap); shard 0 also carries the samples, the map grid and the truth
//! lookup. The merge joins the variables, drops the samples with days missing in any file and
//! writes through the same code as the unsharded stage, so the outputs are the same bytes.
//!
//! A part is `PART_MAGIC`, the header's length (u64, little-endian), the header (JSON; floats
//! as their bits so they come back exact), then the gathered values as little-endian f32.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use firecast_data::gridmet::GridmetVariable;
use firecast_pipeline::stage::{SHARD_OUTPUT, deserialize_params};
use firecast_pipeline::{ParamsError, Shard, ShardedKind, StageContext, StageError};
use serde::{Deserialize, Serialize};

use crate::card::MapGrid;
use crate::land::LandMask;
use crate::stage::{WindowsStage, finish_windows, windows_line, windows_metrics, windows_source};
use crate::truth::{TruthFile, TruthLookup};
use crate::windows::{ExtractConfig, ExtractHead, ExtractPlan, ExtractReport, Gathered, WindowSample};
use crate::{DatasetError, Tier, table};

const PART_MAGIC: &[u8] = b"firecast data.windows part 1\n";

impl ShardedKind for WindowsStage {
    fn unit_name(&self) -> &'static str {
        "variables"
    }

    fn units(&self, params: &serde_json::Value) -> Result<usize, ParamsError> {
        let cfg: ExtractConfig = deserialize_params(params)?;
        Ok(cfg.variables.len())
    }

    fn run_shard(&self, ctx: &mut StageContext<'_>, shard: Shard) -> Result<(), StageError> {
        let started = Instant::now();
        let cfg: ExtractConfig = ctx.params()?;
        let samples = ctx.input("samples")?.to_path_buf();
        let gridmet = ctx.input("gridmet")?.to_path_buf();
        let truth = ctx.input_list("truth").first().cloned();
        let input = table::read_sample_list(&samples)?;
        let plan = ExtractPlan::new(&input, &gridmet, &cfg)?;
        let features = shard.range(plan.n_features());
        if features.is_empty() {
            return Err(StageError::msg(format!(
                "shard {shard} covers none of the {} variables: use at most {} shards",
                plan.n_features(),
                plan.n_features()
            )));
        }
        let planned = started.elapsed().as_secs_f64();
        let gathered = plan.gather(features.clone(), true, &|_, _| {})?;
        let read = started.elapsed().as_secs_f64() - planned;
        let head = if shard.index == 0 {
            let truth = truth
                .map(|dir| crate::truth::lookup_truth(&plan.head().kept, &dir, true))
                .transpose()?;
            let grid = MapGrid::from_mask(&LandMask::from_gridmet_dir(&gridmet)?);
            Some(PartHead::new(plan.head(), &grid, windows_source(&gridmet), truth))
        } else {
            None
        };
        let header = PartHeader {
            shard,
            features: [features.start, features.end],
            slots: plan.head().kept.len(),
            n_days: plan.head().n_days,
            kept_fingerprint: fingerprint(&plan.head().kept),
            invalid: (0..gathered.invalid.len())
                .filter(|&s| gathered.invalid[s])
                .collect(),
            files_read: gathered.files_read,
            source_hashes: gathered.source_hashes.clone(),
            head,
        };
        write_part(ctx.output(SHARD_OUTPUT)?, &header, &gathered.values)?;
        ctx.log(format!(
            "shard {shard}: variables {} ({} files read) for {} samples with windows; \
             plan {planned:.3} s, read {read:.3} s, shard {:.3} s",
            cfg.variables[features].join(","),
            gathered.files_read,
            plan.head().kept.len(),
            started.elapsed().as_secs_f64()
        ));
        Ok(())
    }

    /// Records the metrics of the unsharded run (the shards record none).
    fn merge(&self, ctx: &mut StageContext<'_>, parts: &[PathBuf]) -> Result<(), StageError> {
        let started = Instant::now();
        let cfg: ExtractConfig = ctx.params()?;
        let n_vars = cfg.variables.len();
        let mut head: Option<PartHead> = None;
        let mut expected: Option<(usize, usize, String)> = None;
        let mut gathered = Vec::with_capacity(parts.len());
        for (i, path) in parts.iter().enumerate() {
            let (header, values) = read_part(path)?;
            let shard = Shard {
                index: i as u32,
                count: parts.len() as u32,
            };
            let range = shard.range(n_vars);
            if header.shard != shard || header.features != [range.start, range.end] {
                return Err(StageError::msg(format!(
                    "shard part {} is shard {} with variables {}..{}, expected shard {shard} with \
                     variables {}..{} of {n_vars}",
                    path.display(),
                    header.shard,
                    header.features[0],
                    header.features[1],
                    range.start,
                    range.end
                )));
            }
            let this = (header.slots, header.n_days, header.kept_fingerprint.clone());
            match &expected {
                None => expected = Some(this),
                Some(first) if *first != this => {
                    return Err(StageError::msg(format!(
                        "shard {shard} planned other windows ({} samples x {} days) than shard 0 \
                         ({} x {}): the shards did not read the same inputs",
                        this.0, this.1, first.0, first.1
                    )));
                }
                Some(_) => {}
            }
            let mut invalid = vec![false; header.slots];
            for s in header.invalid {
                *invalid
                    .get_mut(s)
                    .ok_or_else(|| StageError::msg(format!("shard {shard}: slot {s} out of range")))? = true;
            }
            if i == 0 {
                head = header.head;
            }
            gathered.push(Gathered {
                features: range,
                values,
                invalid,
                files_read: header.files_read,
                source_hashes: header.source_hashes,
            });
        }
        let (Some(head), Some((_, n_days, kept_fingerprint))) = (head, expected) else {
            return Err(StageError::msg("shard 0 carries no samples to merge"));
        };
        let (head, grid, source, truth) = head.into_parts(n_days)?;
        if fingerprint(&head.kept) != kept_fingerprint {
            return Err(StageError::msg("shard 0's samples do not match its fingerprint"));
        }
        let out = ctx.output("windows")?.to_path_buf();
        let m = finish_windows(&cfg, head, gathered, truth, grid, source, &out)?;
        windows_metrics(ctx, &m);
        ctx.log(windows_line(&m));
        ctx.log(format!(
            "merged {} shards in {:.3} s",
            parts.len(),
            started.elapsed().as_secs_f64()
        ));
        Ok(())
    }

    /// Of `gridmet`: the shard's variables, the first variable's first file (the grid) and,
    /// for shard 0, the first file by name (the land mask); of `truth`: everything for shard 0
    /// only. Files that are not GRIDMET files by name are kept.
    fn shard_reads(
        &self,
        params: &serde_json::Value,
        shard: Shard,
        input: &str,
        files: &[&str],
    ) -> Option<Vec<bool>> {
        let cfg: ExtractConfig = deserialize_params(params).ok()?;
        match input {
            "truth" => Some(vec![shard.index == 0; files.len()]),
            "gridmet" => {
                let parsed: Vec<Option<(GridmetVariable, i32)>> = files
                    .iter()
                    .map(|f| {
                        // Only the folder's own files are GRIDMET files (the listing is flat).
                        (!f.contains('/'))
                            .then(|| GridmetVariable::from_file_name(Path::new(f)))
                            .flatten()
                    })
                    .collect();
                let mine: Vec<&str> = cfg.variables[shard.range(cfg.variables.len())]
                    .iter()
                    .map(String::as_str)
                    .collect();
                let first_var = cfg.variables.first()?;
                // As `ExtractPlan::new` and `LandMask::from_gridmet_dir` choose them.
                let grid = (0..files.len())
                    .filter(|&k| parsed[k].is_some_and(|(v, _)| v.short_name() == first_var))
                    .min_by_key(|&k| parsed[k].map(|(_, y)| y));
                let first_by_name = (0..files.len())
                    .filter(|&k| parsed[k].is_some())
                    .min_by_key(|&k| files[k]);
                let grid = grid.or(first_by_name);
                Some(
                    (0..files.len())
                        .map(|k| match parsed[k] {
                            None => true,
                            Some((v, _)) => {
                                mine.contains(&v.short_name())
                                    || Some(k) == grid
                                    || (shard.index == 0 && Some(k) == first_by_name)
                            }
                        })
                        .collect(),
                )
            }
            _ => None,
        }
    }
}

/// BLAKE3 over the kept samples' ids, days and cells: every shard must plan the same windows.
fn fingerprint(kept: &[WindowSample]) -> String {
    let mut h = blake3::Hasher::new();
    for s in kept {
        h.update(&s.sample_id.to_le_bytes());
        h.update(&s.event_day.to_le_bytes());
        h.update(&s.cell.0.to_le_bytes());
        h.update(&s.cell.1.to_le_bytes());
    }
    h.finalize().to_hex().to_string()
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PartHeader {
    shard: Shard,
    /// Variables `start..end` of the configured ones.
    features: [usize; 2],
    /// Samples with windows (before days-missing drops); the values are
    /// `slots × n_days × (end − start)` floats.
    slots: usize,
    n_days: usize,
    kept_fingerprint: String,
    /// Slots with a day missing in one of this shard's files.
    invalid: Vec<usize>,
    files_read: u64,
    source_hashes: BTreeMap<String, String>,
    /// Shard 0 only.
    head: Option<PartHead>,
}

/// What only shard 0 hands to the merge.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PartHead {
    features: Vec<String>,
    first_offset: i32,
    samples: Vec<PartSample>,
    report: ExtractReport,
    grid: PartGrid,
    source: String,
    truth: Option<PartTruth>,
}

impl PartHead {
    fn new(head: &ExtractHead, grid: &MapGrid, source: String, truth: Option<TruthLookup>) -> Self {
        Self {
            features: head.features.clone(),
            first_offset: head.first_offset,
            samples: head.kept.iter().map(PartSample::from).collect(),
            report: head.report.clone(),
            grid: PartGrid {
                lat_north_bits: grid.lat_north.to_bits(),
                lon_west_bits: grid.lon_west.to_bits(),
                step_deg_bits: grid.step_deg.to_bits(),
                n_lat: grid.n_lat,
                n_lon: grid.n_lon,
                land_runs: grid.land_runs.clone(),
            },
            source,
            truth: truth.map(PartTruth::from),
        }
    }

    fn into_parts(
        self,
        n_days: usize,
    ) -> Result<(ExtractHead, MapGrid, String, Option<TruthLookup>), StageError> {
        let kept: Vec<WindowSample> = self.samples.iter().map(PartSample::sample).collect();
        let truth = match self.truth {
            Some(t) => {
                if t.values.len() != kept.len() {
                    return Err(StageError::msg(format!(
                        "shard 0's truth covers {} samples, its windows {}",
                        t.values.len(),
                        kept.len()
                    )));
                }
                Some(t.lookup())
            }
            None => None,
        };
        let g = self.grid;
        Ok((
            ExtractHead {
                features: self.features,
                first_offset: self.first_offset,
                n_days,
                kept,
                report: self.report,
            },
            MapGrid {
                lat_north: f64::from_bits(g.lat_north_bits),
                lon_west: f64::from_bits(g.lon_west_bits),
                step_deg: f64::from_bits(g.step_deg_bits),
                n_lat: g.n_lat,
                n_lon: g.n_lon,
                land_runs: g.land_runs,
            },
            self.source,
            truth,
        ))
    }
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PartSample {
    sample_id: u32,
    lat_bits: u64,
    lon_bits: u64,
    time_ms: i64,
    event_day: i32,
    tier: Tier,
    source_row: Option<u64>,
    cell: (u32, u32),
    cell_lat_bits: u64,
    cell_lon_bits: u64,
}

impl From<&WindowSample> for PartSample {
    fn from(s: &WindowSample) -> Self {
        Self {
            sample_id: s.sample_id,
            lat_bits: s.lat.to_bits(),
            lon_bits: s.lon.to_bits(),
            time_ms: s.time_ms,
            event_day: s.event_day,
            tier: s.tier,
            source_row: s.source_row,
            cell: s.cell,
            cell_lat_bits: s.cell_lat.to_bits(),
            cell_lon_bits: s.cell_lon.to_bits(),
        }
    }
}

impl PartSample {
    fn sample(&self) -> WindowSample {
        WindowSample {
            sample_id: self.sample_id,
            lat: f64::from_bits(self.lat_bits),
            lon: f64::from_bits(self.lon_bits),
            time_ms: self.time_ms,
            event_day: self.event_day,
            tier: self.tier,
            source_row: self.source_row,
            cell: self.cell,
            cell_lat: f64::from_bits(self.cell_lat_bits),
            cell_lon: f64::from_bits(self.cell_lon_bits),
            true_probability: None,
        }
    }
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PartGrid {
    lat_north_bits: u64,
    lon_west_bits: u64,
    step_deg_bits: u64,
    n_lat: usize,
    n_lon: usize,
    land_runs: Vec<u32>,
}

/// A [`TruthLookup`] with its errors as text (they are raised by the merge only for samples
/// that keep their windows).
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PartTruth {
    source: String,
    /// Per year: `(file name, BLAKE3)` or the error.
    years: BTreeMap<i32, Result<(String, Option<String>), String>>,
    /// Per slot: the probability's bits (`None`: masked) or the error.
    values: Vec<Result<Option<u32>, String>>,
}

impl From<TruthLookup> for PartTruth {
    fn from(t: TruthLookup) -> Self {
        Self {
            source: t.source,
            years: t
                .years
                .into_iter()
                .map(|(y, f)| (y, f.map(|f| (f.name, f.hash)).map_err(|e| e.to_string())))
                .collect(),
            values: t
                .values
                .into_iter()
                .map(|v| v.map(|p| p.map(f32::to_bits)).map_err(|e| e.to_string()))
                .collect(),
        }
    }
}

impl PartTruth {
    fn lookup(self) -> TruthLookup {
        TruthLookup {
            source: self.source,
            years: self
                .years
                .into_iter()
                .map(|(y, f)| {
                    (
                        y,
                        f.map(|(name, hash)| TruthFile { name, hash })
                            .map_err(DatasetError::Shard),
                    )
                })
                .collect(),
            values: self
                .values
                .into_iter()
                .map(|v| v.map(|p| p.map(f32::from_bits)).map_err(DatasetError::Shard))
                .collect(),
        }
    }
}

fn write_part(path: &Path, header: &PartHeader, values: &[f32]) -> Result<(), StageError> {
    let json = serde_json::to_vec(header)?;
    let mut bytes = Vec::with_capacity(PART_MAGIC.len() + 8 + json.len() + values.len() * 4);
    bytes.extend_from_slice(PART_MAGIC);
    bytes.extend_from_slice(&(json.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&json);
    for v in values {
        bytes.extend_from_slice(&v.to_bits().to_le_bytes());
    }
    std::fs::write(path, bytes)
        .map_err(|e| StageError::msg(format!("writing shard part {}: {e}", path.display())))
}

fn read_part(path: &Path) -> Result<(PartHeader, Vec<f32>), StageError> {
    let bad = |why: String| StageError::msg(format!("shard part {}: {why}", path.display()));
    let bytes = std::fs::read(path).map_err(|e| bad(e.to_string()))?;
    let rest = bytes
        .strip_prefix(PART_MAGIC)
        .ok_or_else(|| bad("not a data.windows part".into()))?;
    let (len, rest) = rest
        .split_first_chunk::<8>()
        .ok_or_else(|| bad("truncated".into()))?;
    let len = usize::try_from(u64::from_le_bytes(*len)).map_err(|e| bad(e.to_string()))?;
    if rest.len() < len {
        return Err(bad("truncated header".into()));
    }
    let (json, floats) = rest.split_at(len);
    let header: PartHeader = serde_json::from_slice(json).map_err(|e| bad(e.to_string()))?;
    let width = header.features[1].saturating_sub(header.features[0]);
    let expected = header.slots * header.n_days * width;
    if floats.len() != expected * 4 {
        return Err(bad(format!(
            "{} bytes of values, expected {expected} floats",
            floats.len()
        )));
    }
    let values = floats
        .chunks_exact(4)
        .map(|b| f32::from_bits(u32::from_le_bytes([b[0], b[1], b[2], b[3]])))
        .collect();
    Ok((header, values))
}
