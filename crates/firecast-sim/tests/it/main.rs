//! Integration tests of firecast-sim: the behave oracles (copied into `tests/fixtures/`),
//! consistency identities, the Concord reference values, the CSV front end and properties.
#![allow(clippy::unwrap_used)]

mod agents;
mod automaton;
mod behave_oracles;
mod common;
mod concord_kernel;
mod env;
mod flammap_parity;
mod identities;
mod perf;
mod properties;
mod python_random;
mod scenes;
mod spread_csv;
