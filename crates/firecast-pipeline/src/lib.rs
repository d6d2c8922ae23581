//! Declarative YAML pipelines for FireCast.
//!
//! A pipeline file (`pipelines/*.yaml`) names stages; each `uses:` a stage kind that a
//! crate registers (`cmd` is built in). The engine:
//!
//! 1. parses the file strictly ([`spec`]): unknown keys and wrong types are errors that
//!    name the file, line and key path; `${var}`, `foreach`, `matrix` and `-S` overrides
//!    are resolved here;
//! 2. plans it ([`plan`]): kinds looked up, params validated and resolved with their
//!    defaults, inputs wired to files, store URLs or upstream outputs, cycles rejected;
//! 3. runs it ([`runner`]): independent stages in parallel, each skipped when its cache
//!    key (kind + version, resolved params, input content hashes) matches the lockfile
//!    and its outputs are intact, restored from the run-cache when that key was seen
//!    before, and otherwise executed with outputs published atomically.
//!
//! Tracking (registry, artifacts) plugs in through [`observer::RunObserver`], so this
//! crate does not depend on DuckDB.

pub mod cmd;
pub mod dvc;
pub mod error;
pub mod executor;
pub mod extends;
pub mod hash;
mod locate;
pub mod lock;
pub mod observer;
pub mod plan;
pub mod resources;
pub mod runner;
pub mod spec;
pub mod stage;

pub use error::{PipelineError, SpecError, StageError, chain_text};
pub use executor::{JobFailure, JobOutcome, StageExecutor, StageJob};
pub use locate::locate_path;
pub use observer::{DatasetRecord, NoObserver, RunObserver, RunStatus};
pub use plan::{Plan, load_plan};
pub use resources::Resources;
pub use runner::{Engine, Outcome, RunOptions, RunReport};
pub use spec::Override;
pub use stage::{
    ParamsError, Port, Ports, Shard, ShardedKind, StageContext, StageKind, StageKinds, typed_params,
};

/// The kinds every `firecast` knows, whatever crates are linked.
pub fn builtin_kinds() -> StageKinds {
    let mut kinds = StageKinds::new();
    kinds.register(cmd::CmdStage);
    kinds
}
