//! Stage kinds: what a `uses:` names. Crates register their kinds; the runner calls them
//! with a [`StageContext`] that hands out input paths, temporary output paths, progress
//! bars and the tracking hooks.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use serde::Serialize;
use serde::de::DeserializeOwned;

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
    pub(crate) jobs: usize,
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

    /// Threads this stage may use (the runner's `--jobs`).
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

    /// Upload a local file to the artifact store under `runs/<run>/<name>` and register it.
    pub fn artifact(&self, name: &str, file: &Path) -> Result<String, StageError> {
        let store = self
            .store
            .ok_or_else(|| StageError::msg("no artifact store is configured"))?;
        let file_name = file
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_else(|| name.to_string());
        let key = format!("runs/{}/{name}/{file_name}", self.run_id);
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
