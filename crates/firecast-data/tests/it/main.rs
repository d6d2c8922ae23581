//! Integration tests for firecast-data.
#![allow(clippy::unwrap_used)]

mod gridmet;
mod incidents;
