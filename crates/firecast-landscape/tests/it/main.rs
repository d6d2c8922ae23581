//! Integration tests for firecast-landscape.
#![allow(clippy::unwrap_used)]

mod firecastrl;
mod georef;
mod geotiff;
mod procedural;
mod srtm;

use std::path::PathBuf;

pub fn fixture(name: &str) -> PathBuf {
    std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("tests/fixtures")
    .join(name)
}
mod landfire;
mod lcp;
