//! Where `libxgboost.so` is: `FIRECAST_XGBOOST_LIB`, else the Python venv's xgboost wheel.

use std::ffi::OsString;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::XgbError;

/// Environment variable naming the shared library itself (highest priority).
pub const LIB_ENV: &str = "FIRECAST_XGBOOST_LIB";
/// Environment variable naming the project's Python venv (set by `.cargo/config.toml`).
pub const VENV_ENV: &str = "FIRECAST_VENV";

/// The venv this crate was built against: `.cargo/config.toml` sets `FIRECAST_VENV` to the
/// workspace's absolute `.venv` path, so binaries built here find the library without setup.
const BUILD_VENV: Option<&str> = option_env!("FIRECAST_VENV");

const SETUP_HINT: &str = "run `cargo xtask setup` (it installs xgboost==3.2.0 into .venv), \
                          or set FIRECAST_XGBOOST_LIB to the path of libxgboost.so";

/// The path of `libxgboost.so` this process would load, in this order:
/// 1. `$FIRECAST_XGBOOST_LIB` (must exist; there is no fallback when it is set);
/// 2. `$FIRECAST_VENV/lib/python3*/site-packages/xgboost/lib/libxgboost.so` with
///    `FIRECAST_VENV` from the run-time environment;
/// 3. the same with the `FIRECAST_VENV` cargo saw when building this crate.
///
/// The error lists everything searched and says to run `cargo xtask setup`.
pub fn library_path() -> Result<PathBuf, XgbError> {
    resolve(
        std::env::var_os(LIB_ENV),
        std::env::var_os(VENV_ENV),
        BUILD_VENV.map(OsString::from),
    )
}

fn non_empty(value: Option<OsString>) -> Option<OsString> {
    value.filter(|v| !v.is_empty())
}

pub(crate) fn resolve(
    lib: Option<OsString>,
    runtime_venv: Option<OsString>,
    build_venv: Option<OsString>,
) -> Result<PathBuf, XgbError> {
    if let Some(lib) = non_empty(lib) {
        let path = PathBuf::from(lib);
        if path.is_file() {
            return Ok(path);
        }
        return Err(XgbError::Library(format!(
            "XGBoost library not found: {LIB_ENV}={} does not exist or is not a file; {SETUP_HINT}",
            path.display()
        )));
    }
    let mut searched = String::new();
    let venvs = [
        ("run-time", non_empty(runtime_venv)),
        ("build-time", non_empty(build_venv)),
    ];
    for (when, venv) in venvs {
        let Some(venv) = venv else {
            let _ = write!(searched, "\n  - {VENV_ENV} ({when}): not set");
            continue;
        };
        let venv = PathBuf::from(venv);
        match find_in_venv(&venv) {
            Some(path) => return Ok(path),
            None => {
                let _ = write!(
                    searched,
                    "\n  - {VENV_ENV} ({when}) = {}: no {}/lib/python3*/site-packages/xgboost/lib/libxgboost.so",
                    venv.display(),
                    venv.display()
                );
            }
        }
    }
    Err(XgbError::Library(format!(
        "XGBoost library (libxgboost.so) not found; {SETUP_HINT}. {LIB_ENV} is not set; searched:{searched}"
    )))
}

/// `VENV/lib/python3*/site-packages/xgboost/lib/libxgboost.so`, newest-sorting python first.
fn find_in_venv(venv: &Path) -> Option<PathBuf> {
    let entries = std::fs::read_dir(venv.join("lib")).ok()?;
    let mut pythons: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .filter(|e| e.file_name().to_string_lossy().starts_with("python3"))
        .map(|e| e.path())
        .collect();
    pythons.sort();
    pythons
        .into_iter()
        .rev()
        .map(|p| p.join("site-packages/xgboost/lib/libxgboost.so"))
        .find(|p| p.is_file())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn explicit_missing_library_is_an_error_without_fallback() {
        let dir = tempfile::tempdir().expect("tempdir");
        let missing = dir.path().join("nope/libxgboost.so");
        let err = resolve(Some(missing.clone().into()), None, None).expect_err("must fail");
        let msg = err.to_string();
        assert!(msg.contains(&missing.display().to_string()), "{msg}");
        assert!(msg.contains("cargo xtask setup"), "{msg}");
    }

    #[test]
    fn venv_search_lists_what_was_searched() {
        let dir = tempfile::tempdir().expect("tempdir");
        let err = resolve(None, Some(dir.path().into()), None).expect_err("must fail");
        let msg = err.to_string();
        assert!(msg.contains(&dir.path().display().to_string()), "{msg}");
        assert!(msg.contains("build-time): not set"), "{msg}");
        assert!(msg.contains("cargo xtask setup"), "{msg}");
    }

    #[test]
    fn finds_library_in_venv_layout_and_prefers_runtime_venv() {
        let dir = tempfile::tempdir().expect("tempdir");
        let lib_dir = dir.path().join("lib/python3.11/site-packages/xgboost/lib");
        std::fs::create_dir_all(&lib_dir).expect("mkdir");
        std::fs::write(lib_dir.join("libxgboost.so"), b"").expect("write");
        let other = tempfile::tempdir().expect("tempdir");
        let found = resolve(None, Some(dir.path().into()), Some(other.path().into())).expect("found");
        assert_eq!(found, lib_dir.join("libxgboost.so"));
        // An empty run-time value counts as unset: the build-time venv is used.
        let found = resolve(None, Some("".into()), Some(dir.path().into())).expect("found");
        assert_eq!(found, lib_dir.join("libxgboost.so"));
    }
}
