//! File-system helpers beyond the atomic write (which is `firecast_fs`'s).

use std::path::Path;

use crate::error::PipelineError;

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
