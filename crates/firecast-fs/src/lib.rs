//! One atomic write for the whole workspace: a partial output is never visible under its
//! final name.
//!
//! - [`write_atomically`] writes a file's bytes to a temporary sibling, syncs it and renames
//!   it onto the destination.
//! - [`TempPath`] reserves a temporary sibling for an output written piece by piece (a file
//!   or a whole folder; [`TempPath::dir`] is the staging folder), [`TempPath::publish`]es it
//!   with one rename that replaces an existing destination, and removes it when dropped
//!   unpublished.
//! - Every temporary name follows one scheme, `.firecast-tmp-<name>-<pid>-<counter>`, in the
//!   destination's folder (so the final rename is atomic); [`parse_temp_name`] recognises
//!   it and [`remove_stale`] removes the leftovers of processes that are gone.
//!
//! Errors are [`FsError`]s naming the operation and the path; crates wrap them in their
//! own error types.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Prefix of every temporary name; anything whose name starts with it is unfinished.
pub const TEMP_PREFIX: &str = ".firecast-tmp-";

/// A failed file-system operation: what was attempted, on which path, and why.
#[derive(Debug, thiserror::Error)]
#[error("{op} {}: {source}", path.display())]
pub struct FsError {
    /// What was attempted, e.g. "cannot write".
    pub op: &'static str,
    /// The path it was attempted on.
    pub path: PathBuf,
    /// The underlying error.
    #[source]
    pub source: std::io::Error,
}

impl FsError {
    fn new(op: &'static str, path: &Path, source: std::io::Error) -> Self {
        Self {
            op,
            path: path.to_path_buf(),
            source,
        }
    }
}

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// A fresh temporary name beside `dest`: `.firecast-tmp-<name>-<pid>-<counter>` in the same
/// folder. Nothing is created; the name is unique within this process.
pub fn temp_path(dest: &Path) -> PathBuf {
    let name = dest
        .file_name()
        .map_or_else(|| "output".to_string(), |n| n.to_string_lossy().into_owned());
    let counter = COUNTER.fetch_add(1, Ordering::Relaxed);
    let file = format!("{TEMP_PREFIX}{name}-{}-{counter}", std::process::id());
    match dest.parent() {
        Some(parent) => parent.join(file),
        None => PathBuf::from(file),
    }
}

/// A recognised temporary name: the destination's file name and the writing process.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TempName {
    /// The file name of the destination the temporary stands for.
    pub dest_name: String,
    /// The process that created it.
    pub pid: u32,
    /// Its number within that process.
    pub counter: u64,
}

/// Recognise a file name made by [`temp_path`]; `None` for any other name.
pub fn parse_temp_name(file_name: &str) -> Option<TempName> {
    let rest = file_name.strip_prefix(TEMP_PREFIX)?;
    let mut parts = rest.rsplitn(3, '-');
    let counter = parts.next()?;
    let pid = parts.next()?;
    let dest_name = parts.next()?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if dest_name.is_empty() || !digits(counter) || !digits(pid) {
        return None;
    }
    Some(TempName {
        dest_name: dest_name.to_string(),
        pid: pid.parse().ok()?,
        counter: counter.parse().ok()?,
    })
}

/// Whether `file_name` is a temporary name of this scheme.
pub fn is_temp_name(file_name: &str) -> bool {
    parse_temp_name(file_name).is_some()
}

/// Whether process `pid` may still be running. On Linux `/proc/<pid>` answers; elsewhere
/// (or without `/proc`) every process counts as alive, so nothing is removed.
pub fn process_alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    if cfg!(target_os = "linux") && Path::new("/proc/self").exists() {
        return Path::new("/proc").join(pid.to_string()).exists();
    }
    true
}

/// Remove the temporary files and folders in `dir` (not below it) whose process is gone;
/// returns how many were removed. A missing or unreadable folder removes nothing.
pub fn remove_stale(dir: &Path) -> usize {
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(temp) = name.to_str().and_then(parse_temp_name) else {
            continue;
        };
        if !process_alive(temp.pid) {
            remove_path(&entry.path());
            removed += 1;
        }
    }
    removed
}

/// Remove a file or a folder tree; a missing path is fine and errors are ignored.
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

/// Create `dest`'s parent folder (and its parents) if it has one.
pub fn create_parent(dest: &Path) -> Result<(), FsError> {
    match dest.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(parent) => {
            std::fs::create_dir_all(parent).map_err(|e| FsError::new("cannot create folder", parent, e))
        }
        None => Ok(()),
    }
}

/// Sync a folder so that a rename inside it survives a crash; best effort (some systems
/// cannot open folders).
fn sync_dir(dir: &Path) {
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    if let Ok(f) = std::fs::File::open(dir) {
        let _ignored = f.sync_all();
    }
}

/// Write `bytes` to `dest` so that readers see either the old content or the whole new
/// content: a temporary sibling is written and synced, renamed onto `dest`, and the folder
/// synced. Creates `dest`'s parent folders.
pub fn write_atomically(dest: &Path, bytes: &[u8]) -> Result<(), FsError> {
    create_parent(dest)?;
    let tmp = TempPath::new(dest)?;
    let mut file = std::fs::File::create(tmp.path()).map_err(|e| FsError::new("cannot write", dest, e))?;
    file.write_all(bytes)
        .and_then(|()| file.sync_all())
        .map_err(|e| FsError::new("cannot write", dest, e))?;
    drop(file);
    tmp.publish()
}

/// Move the finished `tmp` (a file or a folder) onto `dest`, replacing what is there.
///
/// A file replaces a file in one atomic rename. An existing folder (or any destination of
/// another type) is first renamed aside to a temporary name, then `tmp` is renamed into
/// place and the old one removed: `dest` is at worst briefly absent, never half-written or
/// half-deleted; if the second rename fails the old destination is put back.
pub fn publish(tmp: &Path, dest: &Path) -> Result<(), FsError> {
    create_parent(dest)?;
    let replacing = match std::fs::symlink_metadata(dest) {
        Ok(old) => {
            old.is_dir()
                || std::fs::symlink_metadata(tmp)
                    .map(|t| t.is_dir())
                    .unwrap_or(false)
        }
        Err(_) => false,
    };
    let parent = dest.parent().unwrap_or(Path::new(""));
    if !replacing {
        std::fs::rename(tmp, dest).map_err(|e| FsError::new("cannot move into place", dest, e))?;
        sync_dir(parent);
        return Ok(());
    }
    let aside = temp_path(dest);
    std::fs::rename(dest, &aside).map_err(|e| FsError::new("cannot replace", dest, e))?;
    if let Err(e) = std::fs::rename(tmp, dest) {
        let _ignored = std::fs::rename(&aside, dest);
        return Err(FsError::new("cannot move into place", dest, e));
    }
    sync_dir(parent);
    remove_path(&aside);
    Ok(())
}

/// A temporary sibling of a destination, removed when dropped unless published.
///
/// [`TempPath::new`] only reserves the name (the caller or a stage writes a file or a
/// folder there); [`TempPath::dir`] also creates the folder, the staging folder for a whole
/// output folder.
#[derive(Debug)]
pub struct TempPath {
    path: PathBuf,
    dest: PathBuf,
    armed: bool,
}

impl TempPath {
    /// Reserve a fresh temporary name beside `dest`. Nothing is created (not even `dest`'s
    /// folder: writing into a missing folder fails as it would for `dest`). Infallible
    /// today; a `Result` so callers need not change if reserving ever touches the disk.
    pub fn new(dest: &Path) -> Result<Self, FsError> {
        Ok(Self {
            path: temp_path(dest),
            dest: dest.to_path_buf(),
            armed: true,
        })
    }

    /// A staging folder: `dest`'s parent folders and the temporary folder are created.
    pub fn dir(dest: &Path) -> Result<Self, FsError> {
        create_parent(dest)?;
        let staged = Self::new(dest)?;
        std::fs::create_dir(&staged.path)
            .map_err(|e| FsError::new("cannot create folder", &staged.path, e))?;
        Ok(staged)
    }

    /// The temporary path to write to.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The destination it will be published to.
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Move the finished temporary onto the destination (see [`publish`]). On error the
    /// temporary is removed.
    pub fn publish(mut self) -> Result<(), FsError> {
        publish(&self.path, &self.dest)?;
        self.armed = false;
        Ok(())
    }

    /// Stop owning the temporary: it is no longer removed on drop.
    pub fn into_path(mut self) -> PathBuf {
        self.armed = false;
        std::mem::take(&mut self.path)
    }
}

impl Drop for TempPath {
    fn drop(&mut self) {
        if self.armed {
            remove_path(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn write_replaces_old_content_and_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("sub").join("a.json");
        write_atomically(&dest, b"old").unwrap();
        write_atomically(&dest, b"new content").unwrap();
        assert_eq!(std::fs::read(&dest).unwrap(), b"new content");
        assert_eq!(names(&dir.path().join("sub")), ["a.json"]);
    }

    #[test]
    fn write_error_names_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let blocker = dir.path().join("file");
        std::fs::write(&blocker, b"x").unwrap();
        let err = write_atomically(&blocker.join("a.json"), b"x").unwrap_err();
        assert!(err.to_string().contains(&blocker.display().to_string()), "{err}");
    }

    #[test]
    fn staging_folder_dropped_unpublished_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("out");
        {
            let staged = TempPath::dir(&dest).unwrap();
            std::fs::write(staged.path().join("part"), b"half").unwrap();
            assert!(is_temp_name(
                &staged.path().file_name().unwrap().to_string_lossy()
            ));
        }
        assert!(names(dir.path()).is_empty());
    }

    #[test]
    fn published_folder_replaces_existing_one() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("out");
        std::fs::create_dir(&dest).unwrap();
        std::fs::write(dest.join("old"), b"old").unwrap();
        let staged = TempPath::dir(&dest).unwrap();
        std::fs::write(staged.path().join("new"), b"new").unwrap();
        staged.publish().unwrap();
        assert_eq!(names(&dest), ["new"]);
        assert_eq!(names(dir.path()), ["out"]);
    }

    #[test]
    fn published_file_replaces_existing_file_and_folder() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("out");
        std::fs::create_dir(&dest).unwrap();
        let staged = TempPath::new(&dest).unwrap();
        std::fs::write(staged.path(), b"file").unwrap();
        staged.publish().unwrap();
        assert_eq!(std::fs::read(&dest).unwrap(), b"file");
        let staged = TempPath::new(&dest).unwrap();
        std::fs::write(staged.path(), b"again").unwrap();
        staged.publish().unwrap();
        assert_eq!(std::fs::read(&dest).unwrap(), b"again");
        assert_eq!(names(dir.path()), ["out"]);
    }

    #[test]
    fn temp_names_are_recognised() {
        let t = temp_path(Path::new("/x/data-v1.2-final.csv"));
        assert_eq!(t.parent(), Some(Path::new("/x")));
        let parsed = parse_temp_name(&t.file_name().unwrap().to_string_lossy()).unwrap();
        assert_eq!(parsed.dest_name, "data-v1.2-final.csv");
        assert_eq!(parsed.pid, std::process::id());
        assert_ne!(temp_path(Path::new("a")), temp_path(Path::new("a")));
        assert_eq!(
            parse_temp_name(".firecast-tmp-out-12-3"),
            Some(TempName {
                dest_name: "out".into(),
                pid: 12,
                counter: 3
            })
        );
        for other in [
            "out",
            ".out.tmp",
            ".firecast-tmp-",
            ".firecast-tmp-out",
            ".firecast-tmp-out-12",
            ".firecast-tmp--12-3",
            ".firecast-tmp-out-x-3",
            ".firecast-tmp-out-12-",
            ".out.firecast-tmp-run1",
        ] {
            assert!(!is_temp_name(other), "{other}");
        }
    }

    #[test]
    fn stale_temp_of_dead_pid_is_removed_and_live_one_kept() {
        let dir = tempfile::tempdir().unwrap();
        // A child that has exited and been reaped: its pid is gone (unless reused at once).
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let dead_file = dir.path().join(format!("{TEMP_PREFIX}a.csv-{dead}-0"));
        let dead_dir = dir.path().join(format!("{TEMP_PREFIX}folder-{dead}-1"));
        std::fs::write(&dead_file, b"x").unwrap();
        std::fs::create_dir(&dead_dir).unwrap();
        std::fs::write(dead_dir.join("inner"), b"x").unwrap();
        let live = TempPath::dir(&dir.path().join("b")).unwrap();
        std::fs::write(dir.path().join("keep.tmp-1"), b"not ours").unwrap();
        let removed = remove_stale(dir.path());
        if cfg!(target_os = "linux") && !process_alive(dead) {
            assert_eq!(removed, 2);
            assert!(!dead_file.exists() && !dead_dir.exists());
        }
        assert!(live.path().exists());
        assert!(dir.path().join("keep.tmp-1").exists());
        assert_eq!(remove_stale(&dir.path().join("missing")), 0);
    }

    proptest::proptest! {
        #[test]
        fn any_bytes_round_trip(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..4096),
                                name in "[a-zA-Z0-9_.-]{1,40}") {
            proptest::prop_assume!(name != "." && name != "..");
            let dir = tempfile::tempdir().unwrap();
            let dest = dir.path().join(&name);
            write_atomically(&dest, &bytes).unwrap();
            proptest::prop_assert_eq!(std::fs::read(&dest).unwrap(), bytes);
            proptest::prop_assert_eq!(names(dir.path()), vec![name.clone()]);
            let t = temp_path(&dest);
            let parsed = parse_temp_name(&t.file_name().unwrap().to_string_lossy()).unwrap();
            proptest::prop_assert_eq!(parsed.dest_name, name);
        }
    }
}
