//! Integration tests for firecast-synth.
#![allow(clippy::unwrap_used)]

mod synth;
