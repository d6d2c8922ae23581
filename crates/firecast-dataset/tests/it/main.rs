//! Integration tests for firecast-dataset.
#![allow(clippy::unwrap_used)]

mod dataset;
mod kaggle;
mod publish;
mod sampling;
mod truth;
mod windows;

use std::path::PathBuf;

pub fn fixtures() -> PathBuf {
    std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("tests/fixtures")
}

/// Epoch ms of a UTC date-time.
pub fn utc(y: i32, m: u32, d: u32, hour: u32) -> i64 {
    let day = firecast_data::gridmet::ymd_to_day(y, m, d).unwrap();
    firecast_dataset::time::day_start_ms(day) + i64::from(hour) * 3_600_000
}
