//! firecast-sim: the fire simulator's spread-rate kernels.
//!
//! - [`rothermel`]: Rothermel (1972) / Albini (1976) surface spread exactly as the USFS
//!   `behave` engine implements it, over the standard fuel models of [`fuel`].
//! - [`concord`]: the Concord / FireCastRL single-particle compatibility kernel, quirks
//!   included, with a corrected variant.
//! - [`behavior`]: fire behaviour grids over a LANDFIRE landscape (surface fire, as FlamMap
//!   computes it), written as GeoTIFFs with a JSON summary.
//! - [`spread_csv`]: the CSV front end of `firecast sim spread-rate`.
//! - [`automaton`]: the Concord/FireCastRL cellular automaton on a `firecast_landscape`
//!   grid, driven by either kernel.
//! - [`env`]: the helitack environment (Gymnasium semantics) and [`env::VecEnv`].
//! - [`moisture`]: the day's dead and live fuel moisture from daily weather (NFDRS methods).
//! - [`drops`]: helitack drops in physical units (coverage levels by fuel model).
//! - [`agents`]: rule-based and no-suppression baselines, the episode runner, frames.
//! - [`search`]: decision-time search, a helicopter that plans with the simulator.

pub mod agents;
pub mod automaton;
pub mod behavior;
pub mod bench;
pub mod concord;
pub mod crown;
pub mod drops;
pub mod env;
pub mod fuel;
pub mod moisture;
pub mod random;
pub mod reference;
pub mod rothermel;
pub mod search;
pub mod spread_csv;

pub use agents::{
    Decision, EpisodeContext, EpisodeFrames, EpisodeStats, EvalReport, FireChaser, MeanStd, NoSuppression,
    Policy, RuleBasedAgent, RuleNavigation, record_frames, run_episode, run_episodes,
};
pub use automaton::{
    Automaton, BurnIndex, DEFAULT_DT_MIN, FireState, HelitackFootprint, KernelConfig, Neighbourhood,
    SimConfig, SimError, Wind, WindHeight, unsheltered_waf,
};
pub use concord::{
    ConcordCell, ConcordFuel, ConcordFuelConstants, ConcordSpread, ConcordWind, DroughtLevel, EdgeCasePolicy,
    LandCover, MoistureTable, SpreadVariant,
};
pub use env::{Action, EnvConfig, Observation, RewardWeights, StepInfo, Termination, VecEnv, WildfireEnv};
pub use fuel::{FuelModel, UnknownFuelModel};
pub use random::{PythonRandom, RandomSource};
pub use rothermel::{
    FuelBedIntermediates, FuelMoisture, RothermelError, SpreadInputs, SurfaceFireBehavior, SurfaceFireHead,
    SurfaceFuelBed, WindLimit,
};
pub use search::{RolloutSearch, SearchConfig};
pub use spread_csv::{SpreadCsvError, spread_rate_csv};
