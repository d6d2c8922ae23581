//! `forecast.experiment` in shards, by training unit ([`Unit`]: protocol × model × seed).
//! Unit `k` goes to shard `k mod N`: the seeds of one model, which cost alike, land on
//! different shards, so shards get similar work. A shard fits its units as the unsharded run
//! does and writes a part folder: `units.json` (each unit's validation and test scores, floats
//! as their bits, and facts about its fit) and `models/` (its units' saved models).
//!
//! The merge splits the dataset again (cheap: no windows are copied), checks the parts cover
//! every unit once, copies the models into the report and computes the thresholds, reports,
//! bootstrap intervals, paired tests, oracle, table and plots from the units' saved scores
//! through the unsharded code ([`crate::experiment::assemble`]), so the report is the same
//! bytes; it records the seed-averaged metrics and the models as artifacts as the unsharded
//! run does, while each shard recorded its units' metrics.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use firecast_pipeline::stage::{SHARD_OUTPUT, deserialize_params};
use firecast_pipeline::{ParamsError, Shard, ShardedKind, StageContext, StageError};
use serde::{Deserialize, Serialize};

use crate::ForecastError;
use crate::experiment::{Sink, Unit, UnitScores};
use crate::spec::ExperimentSpec;
use crate::stage::{ExperimentStage, StageSink, finish_experiment};

/// The part's description of its units, inside the part folder.
const PART_FILE: &str = "units.json";
const PART_SCHEMA: &str = "firecast forecast.experiment part 1";

/// The units of `units` that `shard` fits: every `count`-th from its index.
pub fn shard_units(units: usize, shard: Shard) -> Vec<usize> {
    (shard.index as usize..units)
        .step_by(shard.count as usize)
        .collect()
}

impl ShardedKind for ExperimentStage {
    fn unit_name(&self) -> &'static str {
        "training units"
    }

    fn units(&self, params: &serde_json::Value) -> Result<usize, ParamsError> {
        let spec: ExperimentSpec = deserialize_params(params)?;
        crate::experiment::units(&spec)
            .map(|u| u.len())
            .map_err(|e| match e {
                ForecastError::Config { key, message } => ParamsError { path: key, message },
                other => ParamsError {
                    path: "models".into(),
                    message: other.to_string(),
                },
            })
    }

    fn run_shard(&self, ctx: &mut StageContext<'_>, shard: Shard) -> Result<(), StageError> {
        // libtorch's one generator: stages using it run one at a time (reproducible).
        firecast_learn::exclusive(|| {
            let started = Instant::now();
            let spec: ExperimentSpec = ctx.params()?;
            let dataset = ctx.input("dataset")?.to_path_buf();
            let part = ctx.output(SHARD_OUTPUT)?.to_path_buf();
            let device = crate::parse_device(&spec.device)?;
            let all = crate::experiment::units(&spec)?;
            let mine = shard_units(all.len(), shard);
            if mine.is_empty() {
                return Err(StageError::msg(format!(
                    "shard {shard} covers none of the {} training units: use at most {} shards",
                    all.len(),
                    all.len()
                )));
            }
            firecast_learn::set_threads(spec.threads);
            let windows = crate::data::Windows::load(&dataset)?;
            let units: Vec<Unit> = mine.iter().map(|&k| all[k].clone()).collect();
            let sink = StageSink::new(ctx, "training units");
            let sides = crate::experiment::prepare(&spec, &windows, &sink)?;
            std::fs::create_dir_all(&part)
                .map_err(|e| StageError::msg(format!("creating shard part {}: {e}", part.display())))?;
            let scores = crate::experiment::fit_units(&spec, &windows, &sides, &units, device, &part, &sink)?;
            sink.bar.finish_and_clear();
            let seconds = started.elapsed().as_secs_f64();
            let header = Part {
                schema: PART_SCHEMA.into(),
                shard,
                units: all.len(),
                dataset_version: windows.manifest.version.clone(),
                device: crate::experiment::device_label(device),
                seconds,
                fitted: mine
                    .iter()
                    .zip(scores)
                    .map(|(&k, s)| PartUnit::new(k, s))
                    .collect(),
            };
            let file = part.join(PART_FILE);
            std::fs::write(&file, serde_json::to_vec(&header)?)
                .map_err(|e| StageError::msg(format!("writing shard part {}: {e}", file.display())))?;
            ctx.log(format!(
                "shard {shard}: {} of {} training units in {seconds:.1} s",
                mine.len(),
                all.len()
            ));
            Ok(())
        })
    }

    fn merge(&self, ctx: &mut StageContext<'_>, parts: &[PathBuf]) -> Result<(), StageError> {
        let started = Instant::now();
        let spec: ExperimentSpec = ctx.params()?;
        let dataset = ctx.input("dataset")?.to_path_buf();
        let out = ctx.output("report")?.to_path_buf();
        let windows = crate::data::Windows::load(&dataset)?;
        let all = crate::experiment::units(&spec)?;
        let mut slots: Vec<Option<UnitScores>> = vec![None; all.len()];
        let mut device: Option<String> = None;
        let mut shard_seconds = 0.0;
        for (i, dir) in parts.iter().enumerate() {
            let shard = Shard {
                index: i as u32,
                count: parts.len() as u32,
            };
            let part = read_part(dir)?;
            let bad = |why: String| StageError::msg(format!("shard part {}: {why}", dir.display()));
            if part.shard != shard || part.units != all.len() {
                return Err(bad(format!(
                    "it is shard {} of {} training units, expected shard {shard} of {}",
                    part.shard,
                    part.units,
                    all.len()
                )));
            }
            if part.dataset_version != windows.manifest.version {
                return Err(bad(format!(
                    "fitted on dataset version {}, the stage's input is {}",
                    part.dataset_version, windows.manifest.version
                )));
            }
            match &device {
                None => device = Some(part.device.clone()),
                Some(first) if *first != part.device => {
                    return Err(bad(format!(
                        "fitted on {}, shard 0 on {first}: results would differ from an unsharded run; \
                         give the stage one `device`",
                        part.device
                    )));
                }
                Some(_) => {}
            }
            let expected = shard_units(all.len(), shard);
            let got: Vec<usize> = part.fitted.iter().map(|u| u.index).collect();
            if got != expected {
                return Err(bad(format!("it holds units {got:?}, expected {expected:?}")));
            }
            for fitted in part.fitted {
                let index = fitted.index;
                let scores = fitted.scores();
                if scores.unit != all[index] {
                    return Err(bad(format!(
                        "its unit {index} is {}, the experiment's is {}",
                        scores.unit, all[index]
                    )));
                }
                slots[index] = Some(scores);
            }
            copy_tree(&dir.join("models"), &out.join("models"))?;
            shard_seconds += part.seconds;
        }
        let scores = slots
            .into_iter()
            .enumerate()
            .map(|(k, s)| s.ok_or_else(|| StageError::msg(format!("no shard part holds unit {}", all[k]))))
            .collect::<Result<Vec<_>, _>>()?;
        let device = device.ok_or_else(|| StageError::msg("no shard parts to merge"))?;
        let sink = StageSink::new(ctx, "merge");
        let sides = crate::experiment::prepare(&spec, &windows, &sink)?;
        let (result, predictions) =
            crate::experiment::assemble(&spec, &windows, &sides, scores, &device, &sink)?;
        sink.bar.finish_and_clear();
        // The shards' time and the merge's: what the unsharded run spends in one process.
        sink.metric(
            "experiment_seconds",
            0,
            shard_seconds + started.elapsed().as_secs_f64(),
        );
        finish_experiment(ctx, &out, &result, &predictions)?;
        ctx.log(format!(
            "merged {} shards: {} training units, {} table rows, {:.1} s",
            parts.len(),
            all.len(),
            result.results.len(),
            started.elapsed().as_secs_f64()
        ));
        Ok(())
    }
}

/// What a shard hands to the merge (`units.json` in its part folder).
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Part {
    schema: String,
    shard: Shard,
    /// The experiment's units, all shards together.
    units: usize,
    dataset_version: String,
    device: String,
    /// The shard's own time (for the `experiment_seconds` metric only).
    seconds: f64,
    /// This shard's units in order.
    fitted: Vec<PartUnit>,
}

/// One fitted unit; floats travel as their bits, so the merge scores the very numbers the
/// unsharded run scores.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PartUnit {
    /// The unit's number in the experiment.
    index: usize,
    unit: Unit,
    val_bits: Vec<u64>,
    test_bits: Vec<u64>,
    epochs: Option<usize>,
    best_epoch: Option<usize>,
    parameters: Option<i64>,
    curves: BTreeMap<String, Vec<(i64, u64)>>,
}

impl PartUnit {
    fn new(index: usize, s: UnitScores) -> Self {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect();
        Self {
            index,
            val_bits: bits(&s.val),
            test_bits: bits(&s.test),
            unit: s.unit,
            epochs: s.epochs,
            best_epoch: s.best_epoch,
            parameters: s.parameters,
            curves: s
                .curves
                .into_iter()
                .map(|(k, c)| (k, c.into_iter().map(|(e, v)| (e, v.to_bits())).collect()))
                .collect(),
        }
    }

    fn scores(self) -> UnitScores {
        let floats = |v: &[u64]| v.iter().map(|&b| f64::from_bits(b)).collect();
        UnitScores {
            val: floats(&self.val_bits),
            test: floats(&self.test_bits),
            unit: self.unit,
            epochs: self.epochs,
            best_epoch: self.best_epoch,
            parameters: self.parameters,
            curves: self
                .curves
                .into_iter()
                .map(|(k, c)| (k, c.into_iter().map(|(e, b)| (e, f64::from_bits(b))).collect()))
                .collect(),
        }
    }
}

fn read_part(dir: &Path) -> Result<Part, StageError> {
    let file = dir.join(PART_FILE);
    let bad = |why: String| StageError::msg(format!("shard part {}: {why}", file.display()));
    let bytes = std::fs::read(&file).map_err(|e| bad(e.to_string()))?;
    let part: Part = serde_json::from_slice(&bytes).map_err(|e| bad(e.to_string()))?;
    if part.schema != PART_SCHEMA {
        return Err(bad(format!("schema `{}`, expected `{PART_SCHEMA}`", part.schema)));
    }
    Ok(part)
}

/// Copies the files under `from` to the same paths under `to` (a shard's saved models into
/// the report's `models/`).
fn copy_tree(from: &Path, to: &Path) -> Result<(), StageError> {
    let entries =
        std::fs::read_dir(from).map_err(|e| StageError::msg(format!("reading {}: {e}", from.display())))?;
    std::fs::create_dir_all(to).map_err(|e| StageError::msg(format!("creating {}: {e}", to.display())))?;
    for entry in entries {
        let entry = entry.map_err(|e| StageError::msg(format!("reading {}: {e}", from.display())))?;
        let (src, dest) = (entry.path(), to.join(entry.file_name()));
        if entry
            .file_type()
            .map_err(|e| StageError::msg(format!("reading {}: {e}", src.display())))?
            .is_dir()
        {
            copy_tree(&src, &dest)?;
        } else {
            std::fs::copy(&src, &dest).map_err(|e| {
                StageError::msg(format!("copying {} to {}: {e}", src.display(), dest.display()))
            })?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn shards_take_every_nth_unit_and_cover_each_once() {
        for (units, count) in [(20, 3), (4, 4), (7, 1), (68, 2)] {
            let mut seen = vec![0; units];
            for index in 0..count {
                let mine = shard_units(units, Shard { index, count });
                assert!(!mine.is_empty());
                assert!(mine.windows(2).all(|w| w[1] == w[0] + count as usize));
                for k in mine {
                    seen[k] += 1;
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "{units} units in {count} shards");
        }
    }

    #[test]
    fn scores_travel_as_their_bits() {
        let s = UnitScores {
            unit: Unit {
                protocol: "paper".into(),
                model: "firecast".into(),
                seed: 2,
            },
            val: vec![0.1 + 0.2, f64::NAN, -0.0, 1e-300],
            test: vec![f64::MIN_POSITIVE, 0.999_999_999_999_999_9],
            epochs: Some(3),
            best_epoch: Some(2),
            parameters: Some(1234),
            curves: BTreeMap::from([("val_auprc".to_string(), vec![(1, f64::NAN), (2, 0.3)])]),
        };
        let json = serde_json::to_vec(&PartUnit::new(7, s.clone())).unwrap();
        let back: PartUnit = serde_json::from_slice(&json).unwrap();
        assert_eq!(back.index, 7);
        let back = back.scores();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.val), bits(&s.val));
        assert_eq!(bits(&back.test), bits(&s.test));
        assert_eq!(back.curves["val_auprc"][1], (2, 0.3));
        assert!(back.curves["val_auprc"][0].1.is_nan());
        assert_eq!(
            (back.unit, back.epochs, back.parameters),
            (s.unit, Some(3), Some(1234))
        );
    }
}
