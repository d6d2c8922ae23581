//! Integration tests for firecast-landscape.
#![allow(clippy::unwrap_used)]

mod firecastrl;
mod georef;
mod geotiff;
mod procedural;
mod srtm;

use std::path::PathBuf;

pub fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}
