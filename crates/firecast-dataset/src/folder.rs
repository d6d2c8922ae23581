//! Writes the folder of a finished dataset: its two Parquet tables, statistics, card, map
//! and `dataset.json`. Kept above [`crate::dataset`] and [`crate::card`], which it joins:
//! the card is computed from the dataset.

use std::collections::BTreeMap;

use crate::DatasetError;
use crate::dataset::{
    BuiltDataset, CARD_FILE, DatasetConfig, DatasetManifest, MANIFEST_FILE, MAP_FILE, NORMALIZATION_FILE,
    STATS_FILE,
};
use crate::time;

/// Writes a finished dataset into `dir`: the two Parquet tables (with the manifest in
/// their key-value metadata), `normalization.json`, `stats.json`, `card.md`, `map.png`
/// and `dataset.json` last — a reader that finds `dataset.json` finds everything.
pub fn write(
    dir: &std::path::Path,
    ds: &BuiltDataset,
    cfg: &DatasetConfig,
    grid: &crate::card::MapGrid,
    provenance: &BTreeMap<String, String>,
    source_model: Option<&str>,
) -> Result<DatasetManifest, DatasetError> {
    std::fs::create_dir_all(dir).map_err(DatasetError::io("creating", dir))?;
    let (stats, tiers) = crate::card::statistics(&ds.table, &ds.splits)?;
    let norm = crate::card::normalization(&stats);
    let mut per_split: BTreeMap<String, u64> = BTreeMap::new();
    for s in &ds.splits {
        *per_split.entry(s.to_string()).or_default() += 1;
    }
    let mut manifest = DatasetManifest {
        name: cfg.name.clone(),
        version: ds.version.clone(),
        schema_version: crate::table::SCHEMA_VERSION.into(),
        framing: cfg.framing,
        day_offsets: ds.label_offsets,
        features: ds.table.features.clone(),
        samples: ds.table.samples.len() as u64,
        positives: ds.table.samples.iter().filter(|s| s.label()).count() as u64,
        day_rows: (ds.table.samples.len() * ds.table.n_days) as u64,
        splits: per_split,
        test_from: ds.test_from.map(time::format_date),
        groups: ds.groups,
        config: cfg.clone(),
        provenance: provenance.clone(),
        files: BTreeMap::new(),
        true_probability: crate::truth::summarize(&ds.table),
    };
    let json = |v: &dyn erased::Json| v.to_json();
    let mut kv = BTreeMap::new();
    kv.insert("firecast.dataset.name".to_string(), cfg.name.clone());
    kv.insert("firecast.dataset.version".to_string(), ds.version.clone());
    kv.insert("firecast.dataset.manifest".to_string(), json(&manifest));
    crate::table::write_window_table(dir, &ds.table, Some(&ds.splits), &kv)?;
    firecast_fs::write_atomically(&dir.join(NORMALIZATION_FILE), json(&norm).as_bytes())?;
    let stats_doc = serde_json::json!({ "features": stats, "tiers": tiers });
    firecast_fs::write_atomically(&dir.join(STATS_FILE), stats_doc.to_string().as_bytes())?;
    let card = crate::card::render_card(
        ds,
        &crate::card::CardContext {
            config: cfg,
            stats: &stats,
            tiers: &tiers,
            normalization: &norm,
            provenance,
            source_model,
        },
    );
    firecast_fs::write_atomically(&dir.join(CARD_FILE), card.as_bytes())?;
    crate::card::draw_map(&ds.table, grid, &dir.join(MAP_FILE))?;
    for f in [
        crate::table::SAMPLES_FILE,
        crate::table::DAYS_FILE,
        NORMALIZATION_FILE,
        STATS_FILE,
        CARD_FILE,
        MAP_FILE,
    ] {
        manifest
            .files
            .insert(f.to_string(), crate::hash_file(&dir.join(f))?);
    }
    firecast_fs::write_atomically(&dir.join(MANIFEST_FILE), json(&manifest).as_bytes())?;
    Ok(manifest)
}

mod erased {
    /// Pretty JSON of anything serializable (serialization of these plain structs cannot fail).
    pub trait Json {
        fn to_json(&self) -> String;
    }
    impl<T: serde::Serialize> Json for T {
        fn to_json(&self) -> String {
            serde_json::to_string_pretty(self).unwrap_or_default()
        }
    }
}
