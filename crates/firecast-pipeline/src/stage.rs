//! Stage kinds: what a `uses:` names. Crates register their kinds; the runner calls them
//! with a [`StageContext`] that hands out input paths, temporary output paths, progress
//! bars and the tracking hooks. Also what a kind tells the others about its outputs: the
//! metrics and plot files the DVC export declares ([`MetricsAndPlots`]) and the artifacts it
//! asks the runner to upload ([`PendingArtifact`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::error::StageError;
use crate::observer::{DatasetRecord, RunObserver};

/// A named input or output a stage kind expects.
#[derive(Debug, Clone, Copy)]
pub struct Port {
    pub name: &'static str,
    pub required: bool,
    /// Accepts a list of sources (fan-in).
    pub many: bool,
    pub description: &'static str,
}

/// The inputs and outputs of a kind. `open` kinds (like `cmd`) accept any names.
#[derive(Debug, Clone, Copy)]
pub struct Ports {
    pub inputs: &'static [Port],
    pub outputs: &'static [Port],
    pub open: bool,
}

/// A rejected params mapping: the key path inside `params` and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParamsError {
    pub path: String,
    pub message: String,
}

/// Deserialize params strictly into `T` and return them with their resolved JSON
/// (defaults filled in), which is what the cache key hashes.
pub fn typed_params<T: DeserializeOwned + Serialize>(
    raw: &serde_json::Value,
) -> Result<(T, serde_json::Value), ParamsError> {
    let typed: T = deserialize_params(raw)?;
    let resolved = serde_json::to_value(&typed).map_err(|e| ParamsError {
        path: String::new(),
        message: e.to_string(),
    })?;
    Ok((typed, resolved))
}

/// Deserialize a params value strictly into `T`, reporting the key path of a problem.
pub fn deserialize_params<T: DeserializeOwned>(raw: &serde_json::Value) -> Result<T, ParamsError> {
    serde_path_to_error::deserialize(raw).map_err(|e| {
        let path = e.path().to_string();
        ParamsError {
            path: if path == "." { String::new() } else { path },
            message: e.into_inner().to_string(),
        }
    })
}

/// A kind of stage. Implementations live in the crates that own the concept
/// (`gridmet.extract` in the data crate, `sim.episodes` in the simulator crate).
pub trait StageKind: Send + Sync {
    /// The name used in `uses:`.
    fn name(&self) -> &'static str;
    /// Bump when the kind's behaviour changes: it is part of every cache key.
    fn version(&self) -> u32;
    /// One line for `--help` style listings.
    fn summary(&self) -> &'static str;
    fn ports(&self) -> Ports;
    /// Check params and return them resolved (defaults filled).
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError>;
    /// Do the work: read inputs, write every declared output at `ctx.output(..)`.
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError>;
    /// Kinds whose work splits into independent shards return their sharding here.
    fn sharded(&self) -> Option<&dyn ShardedKind> {
        None
    }
    /// The metrics and plot files (DVC's formats) this kind writes inside its outputs, given
    /// the resolved params and each output's path relative to the root; the DVC export
    /// declares them so `dvc metrics show` and `dvc plots show` find them.
    fn metrics_and_plots(
        &self,
        _params: &serde_json::Value,
        _outputs: &BTreeMap<String, PathBuf>,
    ) -> MetricsAndPlots {
        MetricsAndPlots::default()
    }
}

/// The metrics and plot files a stage writes inside its outputs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MetricsAndPlots {
    /// JSON or YAML files of numbers (`dvc metrics`), relative to the project root.
    pub metrics: Vec<PathBuf>,
    pub plots: Vec<Plot>,
}

/// A `dvc plots` definition: one series per data file, as DVC 3's top-level `plots:` takes
/// it (`y: {file: field}`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plot {
    /// Unique within the stage; the export prefixes the DVC stage name.
    #[serde(skip)]
    pub id: String,
    /// A DVC template: `simple`, `linear`, `confusion`, …
    pub template: String,
    pub x: String,
    /// Data file (relative to the project root) → the field plotted on y.
    pub y: BTreeMap<String, String>,
    pub title: String,
    pub x_label: String,
    pub y_label: String,
}

/// The plots DVCLive writes for a binary classifier (`dvclive.plots.sklearn`), with the
/// template, axes, title and labels DVCLive gives them; the data files are DVCLive's too
/// (`firecast_eval::dvc` writes them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SklearnPlot {
    /// `{"roc": [{"fpr", "tpr", "threshold"}, …]}`.
    Roc,
    /// `{"precision_recall": [{"precision", "recall", "threshold"}, …]}`.
    PrecisionRecall,
    /// `{"calibration": [{"prob_true", "prob_pred"}, …]}`.
    Calibration,
    /// `[{"actual", "predicted"}, …]`, one row per sample.
    ConfusionMatrix,
}

impl SklearnPlot {
    /// (template, x, y, title, x label, y label) as DVCLive sets them.
    fn properties(self) -> [&'static str; 6] {
        match self {
            Self::Roc => [
                "simple",
                "fpr",
                "tpr",
                "Receiver operating characteristic (ROC)",
                "False Positive Rate",
                "True Positive Rate",
            ],
            Self::PrecisionRecall => [
                "simple",
                "recall",
                "precision",
                "Precision-Recall Curve",
                "Recall",
                "Precision",
            ],
            Self::Calibration => [
                "simple",
                "prob_pred",
                "prob_true",
                "Calibration Curve",
                "Mean Predicted Probability",
                "Fraction of Positives",
            ],
            Self::ConfusionMatrix => [
                "confusion",
                "actual",
                "predicted",
                "Confusion Matrix",
                "True Label",
                "Predicted Label",
            ],
        }
    }

    /// A plot of these files (one series, or one confusion matrix, per file), titled
    /// `<DVCLive's title>, <what>`.
    pub fn plot(self, id: impl Into<String>, what: &str, files: impl IntoIterator<Item = PathBuf>) -> Plot {
        let [template, x, y, title, x_label, y_label] = self.properties();
        Plot {
            id: id.into(),
            template: template.into(),
            x: x.into(),
            y: files
                .into_iter()
                .map(|f| (f.display().to_string(), y.to_string()))
                .collect(),
            title: if what.is_empty() {
                title.into()
            } else {
                format!("{title}, {what}")
            },
            x_label: x_label.into(),
            y_label: y_label.into(),
        }
    }
}

/// An artifact a stage asked for from inside one of its outputs: uploaded by the runner
/// after the output is published, from the finished file and under its final name.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PendingArtifact {
    /// The artifact name the stage gave.
    pub name: String,
    /// The output it lies in.
    pub output: String,
    /// Path inside a folder output; `None` when it is the output file itself.
    pub rel: Option<String>,
}

/// One shard of a sharded stage: `index` of `count` (`--shard 2/8`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
}

impl Shard {
    /// `i/N` with `0 <= i < N`.
    pub fn parse(text: &str) -> Result<Self, String> {
        let bad = || format!("shard `{text}` is not INDEX/COUNT with 0 <= INDEX < COUNT, e.g. 0/4");
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let index: u32 = i.trim().parse().map_err(|_| bad())?;
        let count: u32 = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Self { index, count })
    }

    /// The units (episodes, years, …) this shard covers out of `units`: contiguous,
    /// in order, sizes differing by at most one.
    pub fn range(&self, units: usize) -> std::ops::Range<usize> {
        let at = |i: u32| units * i as usize / self.count as usize;
        at(self.index)..at(self.index + 1)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The output name a shard writes its part to.
pub const SHARD_OUTPUT: &str = "shard";

/// The sharding contract of a kind, independent of where shards run: shard `i/N` reads
/// the stage's inputs and writes one part (`ctx.output(SHARD_OUTPUT)`, a file or a folder);
/// `merge` turns the parts, in shard order, into the stage's outputs, byte for byte what the
/// unsharded run writes, and reports what the unsharded run reports beyond what the shards
/// did, so a sharded run records the same metrics.
pub trait ShardedKind: Send + Sync {
    /// What a shard splits, for messages (`episodes`).
    fn unit_name(&self) -> &'static str;
    /// How many units the resolved params have (shards split them).
    fn units(&self, params: &serde_json::Value) -> Result<usize, ParamsError>;
    /// Run one shard (`ctx.shard()` says which).
    fn run_shard(&self, ctx: &mut StageContext<'_>, shard: Shard) -> Result<(), StageError>;
    /// Merge the parts (shard 0 first) into the outputs (`ctx.output(..)`). `ctx` is the
    /// stage's own, on the machine that merges (the runner's, or a remote executor's driver):
    /// its params, inputs and outputs, its log, metrics and artifacts; `ctx.shard()` is `None`.
    fn merge(&self, ctx: &mut StageContext<'_>, parts: &[PathBuf]) -> Result<(), StageError>;
    /// Which of `files` (paths inside the folder given as input `input`) shard `shard` reads;
    /// `None` (the default): all of them. A remote worker fetches only these and leaves the
    /// others as empty files, so the folder lists the same in every shard while each shard
    /// moves only its own data (a shard that opens one anyway fails on an empty file).
    fn shard_reads(
        &self,
        _params: &serde_json::Value,
        _shard: Shard,
        _input: &str,
        _files: &[&str],
    ) -> Option<Vec<bool>> {
        None
    }
}

/// The kinds a `firecast` binary knows.
#[derive(Clone, Default)]
pub struct StageKinds {
    kinds: BTreeMap<&'static str, Arc<dyn StageKind>>,
}

impl StageKinds {
    pub fn new() -> Self {
        Self::default()
    }

    /// Register a kind; a later registration of the same name replaces it.
    pub fn register(&mut self, kind: impl StageKind + 'static) -> &mut Self {
        self.kinds.insert(kind.name(), Arc::new(kind));
        self
    }

    pub fn get(&self, name: &str) -> Option<&Arc<dyn StageKind>> {
        self.kinds.get(name)
    }

    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.kinds.keys().copied()
    }

    pub fn iter(&self) -> impl Iterator<Item = &Arc<dyn StageKind>> {
        self.kinds.values()
    }
}

/// What a running stage sees.
pub struct StageContext<'a> {
    pub(crate) stage: &'a str,
    pub(crate) run_id: &'a str,
    pub(crate) root: &'a Path,
    pub(crate) params: &'a serde_json::Value,
    pub(crate) inputs: &'a BTreeMap<String, Vec<PathBuf>>,
    pub(crate) outputs: &'a BTreeMap<String, PathBuf>,
    pub(crate) final_outputs: &'a BTreeMap<String, PathBuf>,
    pub(crate) progress: &'a indicatif::MultiProgress,
    pub(crate) observer: &'a dyn RunObserver,
    pub(crate) store: Option<&'a firecast_store::ArtifactStore>,
    pub(crate) log: &'a Mutex<Vec<String>>,
    pub(crate) warnings: &'a Mutex<Vec<String>>,
    pub(crate) pending_artifacts: &'a Mutex<Vec<PendingArtifact>>,
    pub(crate) jobs: usize,
    pub(crate) shard: Option<Shard>,
}

impl StageContext<'_> {
    /// The stage's expanded name, e.g. `extract@tmmx`.
    pub fn stage(&self) -> &str {
        self.stage
    }

    pub fn run_id(&self) -> &str {
        self.run_id
    }

    /// The project root all relative paths resolve against.
    pub fn root(&self) -> &Path {
        self.root
    }

    /// The shard this run covers, when the stage is sharded.
    pub fn shard(&self) -> Option<Shard> {
        self.shard
    }

    /// Stages the runner runs at once (`--jobs`). Not a thread count for work whose numbers
    /// depend on it: such kinds take a `threads` param, which is part of the cache key.
    pub fn jobs(&self) -> usize {
        self.jobs
    }

    /// The stage's resolved params as the kind's typed struct.
    pub fn params<T: DeserializeOwned>(&self) -> Result<T, StageError> {
        serde_json::from_value(self.params.clone()).map_err(StageError::from)
    }

    pub fn params_json(&self) -> &serde_json::Value {
        self.params
    }

    /// The single local path of input `name`.
    pub fn input(&self, name: &str) -> Result<&Path, StageError> {
        match self.inputs.get(name).map(Vec::as_slice) {
            Some([one]) => Ok(one),
            Some(many) => Err(StageError::msg(format!(
                "input `{name}` has {} sources; this stage expects one",
                many.len()
            ))),
            None => Err(StageError::msg(format!("input `{name}` is not declared"))),
        }
    }

    /// All local paths of input `name` (a fan-in input), in declaration order.
    pub fn input_list(&self, name: &str) -> &[PathBuf] {
        self.inputs.get(name).map_or(&[], Vec::as_slice)
    }

    /// Names of the declared inputs.
    pub fn input_names(&self) -> impl Iterator<Item = &str> {
        self.inputs.keys().map(String::as_str)
    }

    /// Where to write output `name`: a temporary path the runner moves into place
    /// when the stage succeeds.
    pub fn output(&self, name: &str) -> Result<&Path, StageError> {
        self.outputs
            .get(name)
            .map(PathBuf::as_path)
            .ok_or_else(|| StageError::msg(format!("output `{name}` is not declared")))
    }

    /// Where output `name` will be once published (relative to the root): for records
    /// that outlive the run, such as a dataset's location.
    pub fn output_final_path(&self, name: &str) -> Option<&Path> {
        self.final_outputs.get(name).map(PathBuf::as_path)
    }

    pub fn output_names(&self) -> impl Iterator<Item = &str> {
        self.outputs.keys().map(String::as_str)
    }

    /// A progress bar shown under the stage's line.
    pub fn progress_bar(&self, len: u64, message: &str) -> indicatif::ProgressBar {
        let bar = self.progress.add(indicatif::ProgressBar::new(len));
        bar.set_style(
            indicatif::ProgressStyle::with_template("  {msg:30} [{bar:30}] {pos}/{len} ({eta})")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_message(format!("{}: {message}", self.stage));
        bar
    }

    /// Append a line to the stage's log (kept in `.firecast/logs/<run>.log`).
    pub fn log(&self, line: impl Into<String>) {
        self.log
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(line.into());
    }

    /// Record a metric value at a step.
    pub fn metric(&self, key: &str, step: i64, value: f64) {
        if let Err(e) = self.observer.metric(self.run_id, key, step, value) {
            self.warn(format!("metric `{key}` not recorded: {e}"));
        }
    }

    /// Upload a local file to the artifact store under `runs/<run>/<name>/<file name>` and
    /// register it; returns its URI.
    ///
    /// A file inside one of this stage's outputs (which are still being written under
    /// temporary names) is uploaded by the runner once the output is published: from the
    /// finished file, under its final name.
    pub fn artifact(&self, name: &str, file: &Path) -> Result<String, StageError> {
        let store = self
            .store
            .ok_or_else(|| StageError::msg("no artifact store is configured"))?;
        for (output, tmp) in self.outputs {
            let rel = if file == tmp.as_path() {
                None
            } else if let Ok(rel) = file.strip_prefix(tmp) {
                Some(rel.to_string_lossy().to_string())
            } else {
                continue;
            };
            let final_path = self
                .final_outputs
                .get(output)
                .cloned()
                .unwrap_or_else(|| PathBuf::from(output));
            let final_file = rel
                .as_ref()
                .map_or_else(|| final_path.clone(), |r| final_path.join(r));
            let key = artifact_key(self.run_id, name, &final_file);
            self.pending_artifacts
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push(PendingArtifact {
                    name: name.to_string(),
                    output: output.clone(),
                    rel,
                });
            return Ok(store.uri_of(&key));
        }
        let key = artifact_key(self.run_id, name, file);
        let stored = store.put_file(&key, file)?;
        if let Err(e) = self
            .observer
            .artifact(self.run_id, name, &stored.uri, &stored.hash, stored.size)
        {
            self.warn(format!("artifact `{name}` not registered: {e}"));
        }
        Ok(stored.uri)
    }

    /// Register a dataset version this stage wrote.
    pub fn dataset(&self, record: &DatasetRecord) {
        if let Err(e) = self.observer.dataset(self.run_id, record) {
            self.warn(format!("dataset `{}` not registered: {e}", record.name));
        }
    }

    fn warn(&self, message: String) {
        self.warnings
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(format!("{}: {message}", self.stage));
    }
}

/// `runs/<run>/<name>/<file name>`: where an artifact is stored.
pub fn artifact_key(run_id: &str, name: &str, file: &Path) -> String {
    let file_name = file
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_else(|| name.to_string());
    format!("runs/{run_id}/{name}/{file_name}")
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::Shard;

    #[test]
    fn shards_parse_and_cover_every_unit_once() {
        assert_eq!(Shard::parse("2/8").unwrap(), Shard { index: 2, count: 8 });
        for bad in ["8/8", "1/0", "a/2", "3", "-1/2"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
        for (units, count) in [(10, 3), (4, 4), (7, 1), (10_000, 64)] {
            let mut next = 0;
            for index in 0..count {
                let r = Shard { index, count }.range(units);
                assert_eq!(r.start, next);
                assert!(r.len() == units / count as usize || r.len() == units / count as usize + 1);
                next = r.end;
            }
            assert_eq!(next, units);
        }
    }
}
