//! File-system helpers: atomic writes, temporary output names, moving outputs into place.

use std::path::{Path, PathBuf};

use crate::error::PipelineError;

/// Marker in the names of in-progress outputs; anything carrying it is unfinished.
pub const TMP_MARKER: &str = ".firecast-tmp-";

/// Write a file so that readers see either the old content or the whole new content.
pub fn write_atomically(dest: &Path, bytes: &[u8]) -> Result<(), PipelineError> {
    if let Some(parent) = dest.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| PipelineError::io("cannot create folder", parent, e))?;
    }
    let tmp = temp_sibling(dest, &std::process::id().to_string());
    std::fs::write(&tmp, bytes).map_err(|e| PipelineError::io("cannot write", &tmp, e))?;
    std::fs::rename(&tmp, dest).map_err(|e| {
        let _ignored = std::fs::remove_file(&tmp);
        PipelineError::io("cannot move into place", dest, e)
    })
}

/// `dir/.name.firecast-tmp-<tag>`: hidden, in the same folder so the final rename is atomic.
pub fn temp_sibling(dest: &Path, tag: &str) -> PathBuf {
    let name = dest
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_else(|| "output".into());
    dest.with_file_name(format!(".{name}{TMP_MARKER}{tag}"))
}

/// Remove leftovers of interrupted runs next to `dest`.
pub fn remove_stale_temps(dest: &Path) {
    let Some(parent) = dest.parent() else { return };
    let Some(name) = dest.file_name().map(|n| n.to_string_lossy().to_string()) else {
        return;
    };
    let prefix = format!(".{name}{TMP_MARKER}");
    let dir = if parent.as_os_str().is_empty() {
        Path::new(".")
    } else {
        parent
    };
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        if entry.file_name().to_string_lossy().starts_with(&prefix) {
            remove_path(&entry.path());
        }
    }
}

/// Remove a file or a folder; missing is fine.
pub fn remove_path(path: &Path) {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_dir() => {
            let _ignored = std::fs::remove_dir_all(path);
        }
        Ok(_) => {
            let _ignored = std::fs::remove_file(path);
        }
        Err(_) => {}
    }
}

/// Replace `dest` with the finished `tmp` (file or folder). Between the removal and the
/// rename `dest` is absent, never half-written.
pub fn move_into_place(tmp: &Path, dest: &Path) -> Result<(), PipelineError> {
    if let Some(parent) = dest.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| PipelineError::io("cannot create folder", parent, e))?;
    }
    if std::fs::symlink_metadata(dest)
        .map(|m| m.is_dir())
        .unwrap_or(false)
    {
        std::fs::remove_dir_all(dest).map_err(|e| PipelineError::io("cannot replace output", dest, e))?;
    }
    std::fs::rename(tmp, dest).map_err(|e| PipelineError::io("cannot move output into place", dest, e))
}

/// Copy a file or folder tree.
pub fn copy_tree(from: &Path, to: &Path) -> Result<(), PipelineError> {
    let meta = std::fs::metadata(from).map_err(|e| PipelineError::io("cannot read", from, e))?;
    if meta.is_dir() {
        std::fs::create_dir_all(to).map_err(|e| PipelineError::io("cannot create folder", to, e))?;
        let entries = std::fs::read_dir(from).map_err(|e| PipelineError::io("cannot list", from, e))?;
        for entry in entries {
            let entry = entry.map_err(|e| PipelineError::io("cannot list", from, e))?;
            copy_tree(&entry.path(), &to.join(entry.file_name()))?;
        }
        Ok(())
    } else {
        if let Some(parent) = to.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|e| PipelineError::io("cannot create folder", parent, e))?;
        }
        std::fs::copy(from, to)
            .map(|_| ())
            .map_err(|e| PipelineError::io("cannot copy", from, e))
    }
}
