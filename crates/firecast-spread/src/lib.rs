//! firecast-spread: fire spread engines beside the FireCastRL automaton, and their verification.
//!
//! - [`mtt`]: minimum travel time on the grid (Dijkstra over a large stencil, as FlamMap's MTT
//!   and Cell2Fire do), the travel time along each move taken from the elliptical rate of
//!   spread of every cell it crosses (behave's Rothermel kernel, wind and slope per cell);
//!   arrival time per cell in hours, deterministic.
//! - [`verify`]: constant-condition cases in the manner of ELMFIRE's V&V suite, measured
//!   against the exact ellipse (docs/spec/fire-model.md §B7, §B10.1) for both engines.
//! - [`picture`]: one representative case drawn as a map (ellipses, MTT fronts, the
//!   automaton's burnt cells), `firecast sim verify --png`.
//! - [`landfire`]: a LANDFIRE landscape's fire for the MTT engine: windows of the grid, every
//!   cell's ellipse as the behaviour grid computes it, a point fire evaluating cells as it
//!   reaches them (the episodes' LANDFIRE fires; `firecast bench spread` in firecast-bench).

pub mod landfire;
pub mod mtt;
pub mod picture;
pub mod verify;

pub use mtt::{MttConfig, MttError, MttGrid, arrival_times_h};
