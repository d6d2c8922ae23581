//! The PDF is the HTML printed by a headless Chromium (Debian's `chromium`, installed by
//! `cargo xtask setup`): one template, two outputs.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::ReportError;

/// The Chromium binary: `FIRECAST_CHROMIUM`, else the first of chromium, chromium-browser,
/// google-chrome on PATH.
pub fn chromium() -> Result<PathBuf, ReportError> {
    if let Some(p) = std::env::var_os("FIRECAST_CHROMIUM") {
        return Ok(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        for dir in std::env::split_paths(&path) {
            let candidate = dir.join(name);
            if candidate.is_file() {
                return Ok(candidate);
            }
        }
    }
    Err(ReportError::Pdf(
        "no Chromium found (set FIRECAST_CHROMIUM, or run `cargo xtask setup`, which installs Debian's chromium)"
            .into(),
    ))
}

/// Flags for a headless Chromium on a machine without network (no background traffic, no
/// first-run, a fresh profile).
pub fn headless_args(profile: &Path) -> Vec<String> {
    vec![
        "--headless".into(),
        "--no-sandbox".into(),
        "--disable-gpu".into(),
        "--disable-quic".into(),
        "--no-first-run".into(),
        "--disable-background-networking".into(),
        "--disable-component-update".into(),
        "--disable-sync".into(),
        "--disable-dev-shm-usage".into(),
        format!("--user-data-dir={}", profile.display()),
    ]
}

/// Prints `html` (a file) to `pdf`.
pub fn print(html: &Path, pdf: &Path) -> Result<(), ReportError> {
    let exe = chromium()?;
    let profile = std::env::temp_dir().join(format!("firecast-chromium-{}", std::process::id()));
    let html = std::path::absolute(html).map_err(ReportError::io("resolving", html))?;
    let out = std::path::absolute(pdf).map_err(ReportError::io("resolving", pdf))?;
    let result = Command::new(&exe)
        .args(headless_args(&profile))
        .arg("--no-pdf-header-footer")
        .arg(format!("--print-to-pdf={}", out.display()))
        .arg(format!("file://{}", html.display()))
        .output();
    let _ = std::fs::remove_dir_all(&profile);
    let output = result.map_err(|e| ReportError::Pdf(format!("cannot start {}: {e}", exe.display())))?;
    let ok = out.metadata().is_ok_and(|m| m.len() > 0);
    if !output.status.success() || !ok {
        return Err(ReportError::Pdf(format!(
            "{} failed ({}): {}",
            exe.display(),
            output.status,
            String::from_utf8_lossy(&output.stderr)
                .lines()
                .rev()
                .take(5)
                .collect::<Vec<_>>()
                .join(" | ")
        )));
    }
    Ok(())
}
