//! A fitted model on disk: `model.json` (what it is, what it was trained on, its threshold
//! and its non-neural parameters) and, for networks, `weights.safetensors`. Loading a bundle
//! back gives the same predictions. Written into a temporary sibling and renamed, so a
//! folder with `model.json` is always complete. [`seed_bundles`] finds the bundles an
//! experiment saved, one per seed.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::ForecastError;
use crate::models::Trained;
use crate::neural::{NeuralHeader, NeuralModel};

pub const MODEL_FILE: &str = "model.json";
pub const WEIGHTS_FILE: &str = "weights.safetensors";
/// Bumped when the bundle layout changes.
pub const BUNDLE_VERSION: u32 = 1;

/// What a bundle says about its model.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BundleInfo {
    pub model: String,
    pub kind: String,
    pub protocol: String,
    /// Inclusive input day offsets relative to the predicted date.
    pub days: (i32, i32),
    pub seed: u64,
    pub threshold: f64,
    pub threshold_rule: String,
    pub dataset: String,
    pub dataset_version: String,
    pub validation_auroc: Option<f64>,
    pub validation_auprc: Option<f64>,
    pub test_auroc: Option<f64>,
    /// The dataset variables the protocol's inputs carry, in order.
    pub features: Vec<String>,
    /// Where and when the training windows lie (None in bundles written before 2026-11-28):
    /// a forecast outside it is an extrapolation, and says so.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub training_extent: Option<TrainingExtent>,
}

/// The box and the period of a model's training windows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainingExtent {
    pub lat_min: f64,
    pub lat_max: f64,
    pub lon_min: f64,
    pub lon_max: f64,
    /// First and last predicted date, `YYYY-MM-DD`.
    pub first_date: String,
    pub last_date: String,
    pub samples: usize,
    /// The fires among them (their share is what the model learnt at), and the distinct GRIDMET
    /// cell-days of the area's fires in the box and period (the training and validation
    /// windows' fires: a temporal protocol validates on cell groups of the same period, whose
    /// cells the area's count includes): with the area's cells they give the usual daily rate a
    /// score is corrected to ([`crate::daily`]). None in bundles written before 2026-11-28's
    /// daily probabilities.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub positives: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ignition_cell_days: Option<usize>,
}

impl TrainingExtent {
    /// The extent of these windows (None when there are none).
    pub fn of<'a>(meta: impl IntoIterator<Item = &'a crate::data::SampleMeta> + Clone) -> Option<Self> {
        let positives = meta.clone().into_iter().filter(|m| m.tier.is_positive()).count();
        let mut it = meta.into_iter();
        let first = it.next()?;
        let mut e = Self {
            lat_min: first.lat,
            lat_max: first.lat,
            lon_min: first.lon,
            lon_max: first.lon,
            first_date: String::new(),
            last_date: String::new(),
            samples: 1,
            positives: Some(positives),
            ignition_cell_days: None,
        };
        let (mut d0, mut d1) = (first.event_day, first.event_day);
        for m in it {
            e.lat_min = e.lat_min.min(m.lat);
            e.lat_max = e.lat_max.max(m.lat);
            e.lon_min = e.lon_min.min(m.lon);
            e.lon_max = e.lon_max.max(m.lon);
            d0 = d0.min(m.event_day);
            d1 = d1.max(m.event_day);
            e.samples += 1;
        }
        e.first_date = firecast_dataset::time::format_date(d0);
        e.last_date = firecast_dataset::time::format_date(d1);
        Some(e)
    }

    /// With the area's ignition cell-days counted from `area` (the training and validation
    /// windows): the distinct (GRIDMET cell, day) of its fires inside this box and period.
    pub fn with_area_fires<'a>(
        mut self,
        area: impl IntoIterator<Item = &'a crate::data::SampleMeta>,
    ) -> Self {
        let (first, last) = (
            firecast_dataset::time::parse_date(&self.first_date),
            firecast_dataset::time::parse_date(&self.last_date),
        );
        self.ignition_cell_days = Some(crate::daily::ignition_cell_days(area.into_iter().filter(|m| {
            self.contains(m.lat, m.lon, 0.0)
                && first.is_some_and(|d| m.event_day >= d)
                && last.is_some_and(|d| m.event_day <= d)
        })));
        self
    }

    /// Whether a place lies in the box widened by `margin_deg` on every side.
    pub fn contains(&self, lat: f64, lon: f64, margin_deg: f64) -> bool {
        (self.lat_min - margin_deg..=self.lat_max + margin_deg).contains(&lat)
            && (self.lon_min - margin_deg..=self.lon_max + margin_deg).contains(&lon)
    }
}

#[derive(Serialize, Deserialize)]
struct ModelFile {
    bundle_version: u32,
    info: BundleInfo,
    /// Non-neural models in full; networks as their header (weights alongside).
    model: Option<Trained>,
    neural: Option<NeuralHeader>,
}

/// A bundle read back.
pub struct Bundle {
    pub info: BundleInfo,
    pub model: Trained,
    pub dir: PathBuf,
}

pub fn save(dir: &Path, info: &BundleInfo, model: &Trained) -> Result<(), ForecastError> {
    let parent = dir.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent).map_err(ForecastError::io("creating", parent))?;
    // The staging folder is removed when dropped unpublished (any error below).
    let staged =
        firecast_fs::TempPath::dir(dir).map_err(|e| ForecastError::io("creating", &e.path)(e.source))?;
    let tmp = staged.path();
    let (file, neural) = match model {
        Trained::Neural(n) => {
            n.save_weights(&tmp.join(WEIGHTS_FILE))?;
            (
                ModelFile {
                    bundle_version: BUNDLE_VERSION,
                    info: info.clone(),
                    model: None,
                    neural: Some(n.header()),
                },
                true,
            )
        }
        other => (
            ModelFile {
                bundle_version: BUNDLE_VERSION,
                info: info.clone(),
                model: Some(clone_trained(other)?),
                neural: None,
            },
            false,
        ),
    };
    let _ = neural;
    let json = serde_json::to_vec_pretty(&file).map_err(|e| ForecastError::Model(e.to_string()))?;
    std::fs::write(tmp.join(MODEL_FILE), json)
        .map_err(ForecastError::io("writing", &tmp.join(MODEL_FILE)))?;
    staged
        .publish()
        .map_err(|e| ForecastError::io("renaming into place", dir)(e.source))
}

/// Serialises through JSON (non-neural models are plain data).
fn clone_trained(model: &Trained) -> Result<Trained, ForecastError> {
    let v = serde_json::to_value(model).map_err(|e| ForecastError::Model(e.to_string()))?;
    serde_json::from_value(v).map_err(|e| ForecastError::Model(e.to_string()))
}

pub fn load(dir: &Path, device: tch::Device) -> Result<Bundle, ForecastError> {
    let path = dir.join(MODEL_FILE);
    let text = std::fs::read_to_string(&path).map_err(|e| ForecastError::Data {
        path: path.clone(),
        message: format!("not a FireCast model folder ({e})"),
    })?;
    let file: ModelFile = serde_json::from_str(&text).map_err(|e| ForecastError::Data {
        path: path.clone(),
        message: format!("line {}: {e}", e.line()),
    })?;
    if file.bundle_version != BUNDLE_VERSION {
        return Err(ForecastError::Data {
            path,
            message: format!(
                "bundle version {}, this FireCast reads {BUNDLE_VERSION}",
                file.bundle_version
            ),
        });
    }
    let model = match (file.model, file.neural) {
        (Some(m), _) => m,
        (None, Some(h)) => Trained::Neural(NeuralModel::load(h, &dir.join(WEIGHTS_FILE), device)?),
        (None, None) => {
            return Err(ForecastError::Data {
                path,
                message: "the bundle holds neither a model nor a network header".into(),
            });
        }
    };
    Ok(Bundle {
        info: file.info,
        model,
        dir: dir.to_path_buf(),
    })
}

/// The seed bundles of `model` under `protocol`, as (seed, folder relative to the
/// experiment), by seed: the runs results.json lists when it has them, else every
/// `seed-<n>` folder holding a model.
pub fn seed_bundles(
    experiment: &std::path::Path,
    results: Option<&serde_json::Value>,
    protocol: &str,
    model: &str,
) -> Result<Vec<(u64, String)>, crate::ForecastError> {
    let listed: Vec<(u64, String)> = results
        .and_then(|r| r.get("results")?.as_array())
        .into_iter()
        .flatten()
        .filter(|r| {
            r.get("protocol").and_then(serde_json::Value::as_str) == Some(protocol)
                && r.get("model").and_then(serde_json::Value::as_str) == Some(model)
        })
        .flat_map(|r| {
            r.get("runs")
                .and_then(serde_json::Value::as_array)
                .into_iter()
                .flatten()
        })
        .filter_map(|run| {
            Some((
                run.get("seed")?.as_u64()?,
                run.get("model_dir")?.as_str()?.to_string(),
            ))
        })
        .collect();
    let mut found = if listed.is_empty() {
        let dir = experiment.join("models").join(protocol).join(model);
        sub_folders(&dir)?
            .into_iter()
            .filter_map(|name| {
                let seed = name.strip_prefix("seed-")?.parse().ok()?;
                dir.join(&name)
                    .join(MODEL_FILE)
                    .is_file()
                    .then(|| (seed, format!("models/{protocol}/{model}/{name}")))
            })
            .collect()
    } else {
        listed
    };
    found.sort();
    if found.is_empty() {
        let models = sub_folders(&experiment.join("models").join(protocol))?;
        return Err(crate::ForecastError::Config {
            key: "model".into(),
            message: format!(
                "{}: no saved `{model}` model under protocol `{protocol}`; it has: {}",
                experiment.display(),
                if models.is_empty() {
                    "none".to_string()
                } else {
                    models.join(", ")
                }
            ),
        });
    }
    Ok(found)
}

/// Sorted names of the sub-folders of `dir` (none when it does not exist).
pub(crate) fn sub_folders(dir: &std::path::Path) -> Result<Vec<String>, crate::ForecastError> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(crate::ForecastError::io("reading", dir)(e)),
    };
    let mut names = Vec::new();
    for entry in entries {
        let entry = entry.map_err(crate::ForecastError::io("reading", dir))?;
        if entry.path().is_dir()
            && let Some(name) = entry.file_name().to_str()
        {
            names.push(name.to_string());
        }
    }
    names.sort();
    Ok(names)
}
