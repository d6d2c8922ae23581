//! What FireCast's tests share (a dev-dependency only): the workspace's folders, the venv
//! from `cargo xtask setup` and the tools in it found one way, Rerun recordings read back
//! and checked by the Rerun SDK, and [`Project`], a scratch project that drives the real
//! `firecast` binary.
//!
//! A missing venv or tool fails the test that needs it with the command that installs it:
//! a reference check is never skipped.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod project;
mod rrd;

pub use project::{Project, describe, outcomes};
pub use rrd::{Series, read_scalars, verify_rrd};

use std::path::{Path, PathBuf};
use std::process::Command;

/// The workspace root: the nearest folder holding `Cargo.lock` above the crate under test
/// (`cargo test` sets `CARGO_MANIFEST_DIR` when it runs a test; the compiled-in value of
/// this crate is the fallback, and may name another clone that shared the target folder).
pub fn workspace_root() -> PathBuf {
    let start = std::env::var_os("CARGO_MANIFEST_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")));
    start
        .ancestors()
        .find(|dir| dir.join("Cargo.lock").is_file())
        .map(Path::to_path_buf)
        .unwrap_or(start)
}

/// The project's venv: `FIRECAST_VENV` (cargo sets it from `.cargo/config.toml`), else
/// `<workspace>/.venv`.
pub fn venv() -> PathBuf {
    std::env::var_os("FIRECAST_VENV")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join(".venv"))
}

/// A program of the venv (`python`, `rerun`, `pytest`); fails the test if it is missing.
pub fn venv_bin(name: &str) -> PathBuf {
    let path = venv().join("bin").join(name);
    assert!(
        path.exists(),
        "{} is missing: run `cargo xtask setup` (it creates the venv and installs the references)",
        path.display()
    );
    path
}

/// The venv's Python.
pub fn python() -> PathBuf {
    venv_bin("python")
}

/// The venv's Python, checked to import `modules` (e.g. `["rasterio", "numpy"]`).
pub fn python_with(modules: &[&str]) -> PathBuf {
    let python = python();
    let out = Command::new(&python)
        .arg("-c")
        .arg(format!("import {}", modules.join(", ")))
        .output()
        .expect("running the venv's Python");
    assert!(
        out.status.success(),
        "{} cannot import {}: run `cargo xtask setup`\n{}",
        python.display(),
        modules.join(", "),
        String::from_utf8_lossy(&out.stderr)
    );
    python
}

/// The Rerun CLI of the venv (`rerun-sdk`, the version the recordings are written for).
pub fn rerun_cli() -> PathBuf {
    venv_bin("rerun")
}

/// A peer's own venv (`.venv-peers/<name>`, from `cargo xtask setup`) if it is installed
/// and imports `modules`; `None` otherwise, for tests that check the message saying so.
pub fn peer_python(name: &str, modules: &[&str]) -> Option<PathBuf> {
    let python = workspace_root().join(".venv-peers").join(name).join("bin/python");
    let ok = python.is_file()
        && Command::new(&python)
            .arg("-c")
            .arg(format!("import {}", modules.join(", ")))
            .status()
            .is_ok_and(|s| s.success());
    ok.then_some(python)
}
