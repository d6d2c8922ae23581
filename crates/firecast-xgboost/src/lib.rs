//! The real XGBoost from Rust, with nothing compiled from C++.
//!
//! The PyPI wheel `xgboost==3.2.0` (installed into `.venv` by `cargo xtask setup`) ships
//! `site-packages/xgboost/lib/libxgboost.so`. This crate opens that library at run time
//! (`dlopen`, `RTLD_NOW | RTLD_LOCAL`, once per process) and calls its C API, so models
//! trained here are bit-for-bit the models Python's `xgboost.train` trains on the same data
//! with the same parameters, seed and thread count.
//!
//! The library is found through, in order: `FIRECAST_XGBOOST_LIB` (a path to the `.so`);
//! `$FIRECAST_VENV/lib/python3*/site-packages/xgboost/lib/libxgboost.so` with
//! `FIRECAST_VENV` from the environment; the same with the `FIRECAST_VENV` cargo set when
//! this crate was built (`.cargo/config.toml` points it at the workspace's `.venv`). See
//! [`library_path`].
//!
//! ```no_run
//! use firecast_xgboost::{Booster, XgbParams};
//! # fn main() -> Result<(), firecast_xgboost::XgbError> {
//! let (rows, cols) = (4, 2);
//! let x = [0.0f32, 1.0, 1.0, 0.0, 0.5, 0.5, f32::NAN, 2.0];
//! let y = [false, true, false, true];
//! let params = XgbParams { n_estimators: 10, ..XgbParams::default() };
//! let model = Booster::fit(&x, rows, cols, &y, &params, 42)?;
//! let p = model.predict_proba(&x, rows, cols)?;
//! let artifact = model.save_json()?;
//! assert_eq!(Booster::load_json(&artifact)?.predict_proba(&x, rows, cols)?, p);
//! # Ok(()) }
//! ```
//!
//! All `unsafe` code lives in one private module (`ffi`).

mod booster;
mod error;
mod ffi;
mod locate;
mod params;

pub use booster::Booster;
pub use error::XgbError;
pub use locate::{LIB_ENV, VENV_ENV, library_path};
pub use params::{KEYS as PARAM_KEYS, XgbParams, available_threads};

/// The version of the process-wide XGBoost library (`XGBoostVersion`), loading it if needed.
pub fn xgboost_version() -> Result<(i32, i32, i32), XgbError> {
    ffi::api().map(ffi::Api::version)
}

/// Opens the XGBoost library at `path` and returns its version, without making it the
/// process-wide library (that one is always found by [`library_path`]). For diagnostics
/// (`firecast doctor`-style checks) and tests; the library stays mapped until exit.
pub fn probe_library(path: &std::path::Path) -> Result<(i32, i32, i32), XgbError> {
    ffi::probe(path)
}
