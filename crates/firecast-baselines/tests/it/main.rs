//! Integration tests of firecast-baselines: agreement with scikit-learn 1.9.1 on a
//! realistic dataset (`fidelity`), and the crate's behaviour through its public API
//! (`behaviour`).
#![allow(clippy::unwrap_used)]

mod behaviour;
mod data;
mod fidelity;
