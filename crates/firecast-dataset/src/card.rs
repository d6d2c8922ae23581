//! The dataset card (Markdown), its statistics (computed with polars) and its map (PNG).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use polars::prelude::*;
use serde::{Deserialize, Serialize};

use crate::dataset::{BuiltDataset, DatasetConfig, FeatureMoments, FramingKind, Normalization, TRAIN};
use crate::land::LandMask;
use crate::windows::WindowTable;
use crate::{DatasetError, Tier, time};

fn pe(e: PolarsError) -> DatasetError {
    DatasetError::Polars(e.to_string())
}

/// Statistics of one feature over one split's rows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeatureStats {
    pub split: String,
    pub feature: String,
    pub rows: u64,
    pub missing: u64,
    pub min: Option<f64>,
    pub mean: Option<f64>,
    pub max: Option<f64>,
    pub std: Option<f64>,
}

/// Samples per (split, tier) and their positives.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TierCount {
    pub split: String,
    pub tier: String,
    pub samples: u64,
    pub positives: u64,
    pub first_date: String,
    pub last_date: String,
}

/// Per-split, per-feature statistics of the model-input rows, and sample counts, in one
/// polars query each.
pub fn statistics(
    table: &WindowTable,
    splits: &[&str],
) -> Result<(Vec<FeatureStats>, Vec<TierCount>), DatasetError> {
    let nd = table.n_days;
    let nf = table.n_features();
    let rows = table.samples.len() * nd;
    let mut columns: Vec<Column> = Vec::with_capacity(nf + 1);
    columns.push(Column::new(
        "split".into(),
        (0..rows).map(|r| splits[r / nd.max(1)]).collect::<Vec<&str>>(),
    ));
    for (f, name) in table.features.iter().enumerate() {
        let v: Vec<Option<f32>> = table
            .values
            .iter()
            .skip(f)
            .step_by(nf)
            .map(|x| (!x.is_nan()).then_some(*x))
            .collect();
        columns.push(Column::new(name.as_str().into(), v));
    }
    let days = DataFrame::new(rows, columns).map_err(pe)?;
    let mut aggs = vec![len().alias("__rows")];
    for name in &table.features {
        let c = || col(name.as_str()).cast(DataType::Float64);
        aggs.push(
            col(name.as_str())
                .null_count()
                .cast(DataType::Float64)
                .alias(format!("{name}__missing")),
        );
        aggs.push(c().min().alias(format!("{name}__min")));
        aggs.push(c().mean().alias(format!("{name}__mean")));
        aggs.push(c().max().alias(format!("{name}__max")));
        aggs.push(c().std(1).alias(format!("{name}__std")));
    }
    let by_split = days
        .lazy()
        .group_by([col("split")])
        .agg(aggs)
        .sort(["split"], SortMultipleOptions::default())
        .collect()
        .map_err(pe)?;
    let split_col = by_split.column("split").map_err(pe)?.str().map_err(pe)?.clone();
    let n_rows = by_split
        .column("__rows")
        .map_err(pe)?
        .cast(&DataType::UInt64)
        .map_err(pe)?;
    let n_rows = n_rows.u64().map_err(pe)?.clone();
    let get = |name: &str, i: usize| -> Result<Option<f64>, DatasetError> {
        Ok(by_split.column(name).map_err(pe)?.f64().map_err(pe)?.get(i))
    };
    let mut stats = Vec::new();
    for i in 0..by_split.height() {
        for name in &table.features {
            stats.push(FeatureStats {
                split: split_col.get(i).unwrap_or_default().to_string(),
                feature: name.clone(),
                rows: n_rows.get(i).unwrap_or(0),
                missing: get(&format!("{name}__missing"), i)?.unwrap_or(0.0) as u64,
                min: get(&format!("{name}__min"), i)?,
                mean: get(&format!("{name}__mean"), i)?,
                max: get(&format!("{name}__max"), i)?,
                std: get(&format!("{name}__std"), i)?,
            });
        }
    }

    let s = &table.samples;
    let samples = DataFrame::new(
        s.len(),
        vec![
            Column::new("split".into(), splits.to_vec()),
            Column::new(
                "tier".into(),
                s.iter().map(|x| x.tier.as_str()).collect::<Vec<_>>(),
            ),
            Column::new(
                "positive".into(),
                s.iter().map(|x| u32::from(x.label())).collect::<Vec<_>>(),
            ),
            Column::new("day".into(), s.iter().map(|x| x.event_day).collect::<Vec<_>>()),
        ],
    )
    .map_err(pe)?;
    let counts = samples
        .lazy()
        .group_by([col("split"), col("tier")])
        .agg([
            len().cast(DataType::UInt64).alias("samples"),
            col("positive").sum().cast(DataType::UInt64).alias("positives"),
            col("day").min().alias("first"),
            col("day").max().alias("last"),
        ])
        .sort(["split", "tier"], SortMultipleOptions::default())
        .collect()
        .map_err(pe)?;
    let col_str = |n: &str| -> Result<StringChunked, DatasetError> {
        Ok(counts.column(n).map_err(pe)?.str().map_err(pe)?.clone())
    };
    let col_u64 = |n: &str| -> Result<UInt64Chunked, DatasetError> {
        Ok(counts.column(n).map_err(pe)?.u64().map_err(pe)?.clone())
    };
    let col_i32 = |n: &str| -> Result<Int32Chunked, DatasetError> {
        Ok(counts.column(n).map_err(pe)?.i32().map_err(pe)?.clone())
    };
    let (sp, ti, ns, np, first, last) = (
        col_str("split")?,
        col_str("tier")?,
        col_u64("samples")?,
        col_u64("positives")?,
        col_i32("first")?,
        col_i32("last")?,
    );
    let tiers = (0..counts.height())
        .map(|i| TierCount {
            split: sp.get(i).unwrap_or_default().to_string(),
            tier: ti.get(i).unwrap_or_default().to_string(),
            samples: ns.get(i).unwrap_or(0),
            positives: np.get(i).unwrap_or(0),
            first_date: first.get(i).map(time::format_date).unwrap_or_default(),
            last_date: last.get(i).map(time::format_date).unwrap_or_default(),
        })
        .collect();
    Ok((stats, tiers))
}

/// Mean and standard deviation per feature over the training rows only, so no statistic of
/// validation or test data leaks into training.
pub fn normalization(stats: &[FeatureStats]) -> Normalization {
    let mut out = Normalization {
        split: TRAIN.into(),
        ..Default::default()
    };
    for s in stats.iter().filter(|s| s.split == TRAIN) {
        out.rows = s.rows;
        out.features.insert(
            s.feature.clone(),
            FeatureMoments {
                mean: s.mean.unwrap_or(0.0),
                std: s.std.filter(|v| *v > 0.0).unwrap_or(1.0),
            },
        );
    }
    out
}

/// Inputs of the card beyond the dataset itself.
pub struct CardContext<'a> {
    pub config: &'a DatasetConfig,
    pub stats: &'a [FeatureStats],
    pub tiers: &'a [TierCount],
    pub normalization: &'a Normalization,
    /// Provenance lines (source files and their hashes, upstream reports).
    pub provenance: &'a BTreeMap<String, String>,
    /// Markdown describing how the sources were made (the synthetic generator's model).
    pub source_model: Option<&'a str>,
}

/// The dataset card.
pub fn render_card(ds: &BuiltDataset, ctx: &CardContext<'_>) -> String {
    let cfg = ctx.config;
    let t = &ds.table;
    let mut md = String::new();
    let _ = writeln!(md, "# {} ({})\n", cfg.name, ds.version);
    if !cfg.description.is_empty() {
        let _ = writeln!(md, "{}\n", cfg.description.trim());
    }
    let positives = t.samples.iter().filter(|s| s.label()).count();
    let _ = writeln!(
        md,
        "{} samples ({} positive, {:.1} %), {} day rows, {} features. Version `{}` is the \
         BLAKE3 hash of the configuration and every value.\n",
        t.samples.len(),
        positives,
        100.0 * positives as f64 / t.samples.len().max(1) as f64,
        t.samples.len() * t.n_days,
        t.n_features(),
        ds.version
    );
    if let Some(truth) = crate::truth::summarize(t) {
        let fmt = |v: Option<f64>| v.map_or("—".to_string(), |x| format!("{x:.4}"));
        let _ = writeln!(
            md,
            "`samples.parquet` has a column `{}`: the synthetic generator's true probability of at \
             least one ignition at the sample's GRIDMET cell on its date, 1 − exp(−λ) ({} samples; \
             mean {} on positives, {} on negatives) — the oracle that bounds any model's skill, \
             **not a feature**: never use it as a model input.\n",
            truth.column,
            truth.samples_with_value,
            fmt(truth.mean_positive),
            fmt(truth.mean_negative)
        );
    }
    let _ = writeln!(md, "## Framing\n");
    match cfg.framing.kind {
        FramingKind::Paper => {
            let _ = writeln!(
                md,
                "`paper`: days {}…{} around each sample's date, the layout of the published \
                 FireCastRL CSV. Positive windows are labelled `No` on days −60…−1 and `Yes` on \
                 the ignition day and the 14 days after. **The inputs include those 15 \
                 post-ignition days**, so a classifier trained on them is not a forecast.\n",
                ds.label_offsets.0, ds.label_offsets.1
            );
        }
        FramingKind::Forecast => {
            let _ = writeln!(
                md,
                "`forecast`: {} days of weather ending {} day(s) before the predicted date \
                 (offsets {}…{}); one label per sample: was an ignition recorded at this place on \
                 that date. No input day is on or after the predicted date.\n",
                cfg.framing.window_days, cfg.framing.lead_days, ds.label_offsets.0, ds.label_offsets.1
            );
        }
    }
    let _ = writeln!(md, "## Splits\n");
    match ds.test_from {
        Some(day) => {
            let _ = writeln!(
                md,
                "Temporal holdout: samples on or after **{}** are the test split. ",
                time::format_date(day)
            );
        }
        None => {
            let _ = writeln!(
                md,
                "Stratified random split by groups ({} % test), seed {}. ",
                cfg.split.test_fraction * 100.0,
                cfg.split.seed
            );
        }
    }
    let _ = writeln!(
        md,
        "Samples at the same GRIDMET cell whose day ranges overlap form a group ({} groups) and a \
         group never straddles two splits, so no (place, date) appears in two splits. {} % of \
         the remaining groups are validation.\n",
        ds.groups,
        cfg.split.val_fraction * 100.0
    );
    // Prevalence per split: every split should hold the design's share of positives.
    let _ = writeln!(md, "## Prevalence per split\n");
    let _ = writeln!(md, "| split | samples | positive | prevalence |");
    let _ = writeln!(md, "|---|---:|---:|---:|");
    let mut per_split: std::collections::BTreeMap<&str, (u64, u64)> = std::collections::BTreeMap::new();
    for c in ctx.tiers {
        let e = per_split.entry(c.split.as_str()).or_default();
        e.0 += c.samples;
        e.1 += c.positives;
    }
    for (split, (n, pos)) in &per_split {
        let _ = writeln!(
            md,
            "| {split} | {n} | {pos} | {:.3} |",
            *pos as f64 / (*n).max(1) as f64
        );
    }
    let _ = writeln!(md);
    let _ = writeln!(md, "## Samples per tier\n");
    let _ = writeln!(
        md,
        "| split | tier | samples | positive | first date | last date |"
    );
    let _ = writeln!(md, "|---|---|---:|---:|---|---|");
    for c in ctx.tiers {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} |",
            c.split, c.tier, c.samples, c.positives, c.first_date, c.last_date
        );
    }
    let _ = writeln!(md, "\n![Where the samples are](map.png)\n");
    let _ = writeln!(
        md,
        "Map: GRIDMET cells with data in grey; positives red, far negatives blue, near \
         negatives orange, yearly negatives purple (imported negatives grey-blue).\n"
    );
    let _ = writeln!(md, "## Features (model-input rows)\n");
    let _ = writeln!(md, "| split | feature | rows | missing | min | mean | max |");
    let _ = writeln!(md, "|---|---|---:|---:|---:|---:|---:|");
    let fmt = |v: Option<f64>| v.map_or("—".to_string(), |x| format!("{x:.4}"));
    for s in ctx.stats {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} |",
            s.split,
            s.feature,
            s.rows,
            s.missing,
            fmt(s.min),
            fmt(s.mean),
            fmt(s.max)
        );
    }
    let _ = writeln!(
        md,
        "\n## Normalisation\n\nMean and standard deviation per feature over the {} training rows \
         only (`normalization.json`).\n",
        ctx.normalization.rows
    );
    let _ = writeln!(md, "| feature | mean | std |\n|---|---:|---:|");
    for (f, m) in &ctx.normalization.features {
        let _ = writeln!(md, "| {f} | {:.6} | {:.6} |", m.mean, m.std);
    }
    if !ctx.provenance.is_empty() {
        let _ = writeln!(md, "\n## Provenance\n");
        for (k, v) in ctx.provenance {
            let _ = writeln!(md, "- `{k}`: {v}");
        }
    }
    if let Some(model) = ctx.source_model {
        let _ = writeln!(md, "\n## How the sources were made\n\n{}", model.trim());
    }
    let _ = writeln!(
        md,
        "\n## Configuration\n\n```json\n{}\n```",
        serde_json::to_string_pretty(cfg).unwrap_or_default()
    );
    md
}

/// The grid a map is drawn on: GRIDMET cells, north-west first, with their data mask.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapGrid {
    pub lat_north: f64,
    pub lon_west: f64,
    pub step_deg: f64,
    pub n_lat: usize,
    pub n_lon: usize,
    /// Run lengths of alternating no-data / data cells in row-major order from the north-west
    /// corner (the first run is no-data, possibly empty). Empty: no mask known.
    #[serde(default)]
    pub land_runs: Vec<u32>,
}

impl MapGrid {
    /// The full GRIDMET CONUS grid with no mask.
    pub fn conus() -> Self {
        Self {
            lat_north: 49.4,
            lon_west: -124.766_666_633_3,
            step_deg: 1.0 / 24.0,
            n_lat: 585,
            n_lon: 1386,
            land_runs: Vec::new(),
        }
    }

    /// The grid and data mask of a GRIDMET file (north-up whatever the storage order).
    pub fn from_mask(mask: &LandMask) -> Self {
        let lats = mask.lats();
        let lons = mask.lons();
        let north_first = lats.len() < 2 || lats[0] > lats[lats.len() - 1];
        let step = if lons.len() > 1 {
            (lons[lons.len() - 1] - lons[0]) / (lons.len() - 1) as f64
        } else {
            1.0 / 24.0
        };
        let mut runs = Vec::new();
        let mut current = false;
        let mut run = 0u32;
        for r in 0..lats.len() {
            let j = if north_first { r } else { lats.len() - 1 - r };
            for i in 0..lons.len() {
                let v = mask.is_valid(j, i);
                if v != current {
                    runs.push(run);
                    run = 0;
                    current = v;
                }
                run += 1;
            }
        }
        runs.push(run);
        Self {
            lat_north: if north_first {
                lats[0]
            } else {
                lats[lats.len() - 1]
            },
            lon_west: lons[0],
            step_deg: step,
            n_lat: lats.len(),
            n_lon: lons.len(),
            land_runs: runs,
        }
    }

    fn land(&self) -> Option<Vec<bool>> {
        if self.land_runs.is_empty() {
            return None;
        }
        let mut out = Vec::with_capacity(self.n_lat * self.n_lon);
        let mut value = false;
        for r in &self.land_runs {
            out.extend(std::iter::repeat_n(value, *r as usize));
            value = !value;
        }
        (out.len() == self.n_lat * self.n_lon).then_some(out)
    }
}

/// The map's colours, for a legend beside it (the web app's dataset page).
pub const MAP_LEGEND: [(&str, [u8; 3]); 5] = [
    ("positive (an ignition)", [214, 39, 40]),
    ("far negative", [31, 119, 180]),
    ("near negative", [255, 127, 14]),
    ("yearly negative (same place, earlier year)", [148, 103, 189]),
    ("imported negative", [120, 140, 170]),
];

fn tier_colour(tier: Tier) -> [u8; 3] {
    let entry = match tier {
        Tier::Positive | Tier::ImportedPositive => 0,
        Tier::Far => 1,
        Tier::Near => 2,
        Tier::Yearly => 3,
        Tier::ImportedNegative => 4,
    };
    MAP_LEGEND[entry].1
}

/// Draws the samples over the grid's data mask and writes a PNG (atomically).
pub fn draw_map(table: &WindowTable, grid: &MapGrid, path: &Path) -> Result<(), DatasetError> {
    let scale = (900 / grid.n_lon.max(1)).clamp(1, 12);
    let (w, h) = (grid.n_lon * scale, grid.n_lat * scale);
    let mut px = vec![255u8; w * h * 3];
    if let Some(land) = grid.land() {
        for y in 0..h {
            for x in 0..w {
                if land[(y / scale) * grid.n_lon + x / scale] {
                    px[(y * w + x) * 3..(y * w + x) * 3 + 3].copy_from_slice(&[225, 225, 215]);
                }
            }
        }
    }
    let radius = (scale as i64 / 2).max(2);
    let mut order: Vec<&crate::windows::WindowSample> = table.samples.iter().collect();
    // Negatives first, so positives stay visible on top.
    order.sort_by_key(|s| s.label());
    for s in order {
        let cx = ((s.lon - grid.lon_west) / grid.step_deg + 0.5) * scale as f64;
        let cy = ((grid.lat_north - s.lat) / grid.step_deg + 0.5) * scale as f64;
        let colour = tier_colour(s.tier);
        for dy in -radius..=radius {
            for dx in -radius..=radius {
                if dx * dx + dy * dy > radius * radius {
                    continue;
                }
                let (x, y) = (cx as i64 + dx, cy as i64 + dy);
                if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h {
                    let at = (y as usize * w + x as usize) * 3;
                    px[at..at + 3].copy_from_slice(&colour);
                }
            }
        }
    }
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, w as u32, h as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(|e| DatasetError::Input {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        writer.write_image_data(&px).map_err(|e| DatasetError::Input {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    }
    Ok(firecast_fs::write_atomically(path, &bytes)?)
}
