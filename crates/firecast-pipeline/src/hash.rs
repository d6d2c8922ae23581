//! Content hashes of files and folders, with a cache keyed by (path, size, mtime, inode)
//! so unchanged files are not read again (DVC re-hashes; users notice).

use std::collections::BTreeMap;
use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use crate::error::PipelineError;

/// The content hash of a file or a folder.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ContentHash {
    /// BLAKE3 of the file, or of the folder's sorted manifest, hex.
    pub hash: String,
    pub size: u64,
    /// Number of files for a folder; absent for a file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nfiles: Option<u64>,
}

/// One file of a folder output: relative path, hash, size.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ManifestEntry {
    pub path: String,
    pub hash: String,
    pub size: u64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Eq)]
struct StatKey {
    size: u64,
    mtime_ns: i128,
    inode: u64,
}

/// Hashes already computed, keyed by file identity. Persisted between runs.
#[derive(Debug, Default)]
pub struct HashCache {
    file: Option<PathBuf>,
    entries: Mutex<BTreeMap<PathBuf, (StatKey, String)>>,
    dirty: Mutex<bool>,
}

impl HashCache {
    /// Load from `file` (a missing or unreadable cache just starts empty: it is only a cache).
    pub fn load(file: &Path) -> Self {
        let entries = std::fs::read(file)
            .ok()
            .and_then(|bytes| serde_json::from_slice::<Vec<(PathBuf, StatKey, String)>>(&bytes).ok())
            .map(|list| list.into_iter().map(|(p, k, h)| (p, (k, h))).collect())
            .unwrap_or_default();
        Self {
            file: Some(file.to_path_buf()),
            entries: Mutex::new(entries),
            dirty: Mutex::new(false),
        }
    }

    /// Write the cache back if anything changed.
    pub fn save(&self) -> Result<(), PipelineError> {
        let Some(file) = &self.file else { return Ok(()) };
        if !*self.dirty.lock().unwrap_or_else(|e| e.into_inner()) {
            return Ok(());
        }
        let entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        // Forget files that no longer exist so the cache does not grow forever.
        let list: Vec<(&PathBuf, &StatKey, &String)> = entries
            .iter()
            .filter(|(p, _)| p.exists())
            .map(|(p, (k, h))| (p, k, h))
            .collect();
        let bytes = serde_json::to_vec(&list).map_err(|e| PipelineError::Lock {
            path: file.clone(),
            message: e.to_string(),
        })?;
        Ok(firecast_fs::write_atomically(file, &bytes)?)
    }

    /// Hash a file or folder.
    pub fn hash_path(&self, path: &Path) -> Result<ContentHash, PipelineError> {
        let meta = std::fs::metadata(path).map_err(|e| PipelineError::io("cannot read", path, e))?;
        if meta.is_dir() {
            let manifest = self.manifest(path)?;
            Ok(manifest_hash(&manifest))
        } else {
            let hash = self.hash_file(path, &meta)?;
            Ok(ContentHash {
                hash,
                size: meta.len(),
                nfiles: None,
            })
        }
    }

    /// The sorted list of files under a folder with their hashes.
    pub fn manifest(&self, dir: &Path) -> Result<Vec<ManifestEntry>, PipelineError> {
        let mut files = Vec::new();
        collect_files(dir, dir, &mut files)?;
        files.sort();
        files
            .into_iter()
            .map(|rel| {
                let full = dir.join(&rel);
                let meta =
                    std::fs::metadata(&full).map_err(|e| PipelineError::io("cannot read", &full, e))?;
                Ok(ManifestEntry {
                    hash: self.hash_file(&full, &meta)?,
                    size: meta.len(),
                    path: rel,
                })
            })
            .collect()
    }

    fn hash_file(&self, path: &Path, meta: &std::fs::Metadata) -> Result<String, PipelineError> {
        let key = stat_key(meta);
        let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
        if let Some((cached_key, hash)) = self.entries.lock().unwrap_or_else(|e| e.into_inner()).get(&abs)
            && *cached_key == key
        {
            return Ok(hash.clone());
        }
        let hash = hash_file_contents(path)?;
        self.entries
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(abs, (key, hash.clone()));
        *self.dirty.lock().unwrap_or_else(|e| e.into_inner()) = true;
        Ok(hash)
    }
}

/// BLAKE3 of a file's bytes, streamed.
pub fn hash_file_contents(path: &Path) -> Result<String, PipelineError> {
    let mut file = std::fs::File::open(path).map_err(|e| PipelineError::io("cannot open", path, e))?;
    let mut hasher = blake3::Hasher::new();
    let mut buffer = vec![0u8; 1 << 20];
    loop {
        let n = file
            .read(&mut buffer)
            .map_err(|e| PipelineError::io("cannot read", path, e))?;
        if n == 0 {
            break;
        }
        hasher.update(&buffer[..n]);
    }
    Ok(hasher.finalize().to_hex().to_string())
}

/// The hash of a folder: BLAKE3 over its sorted (path, hash, size) lines.
pub fn manifest_hash(manifest: &[ManifestEntry]) -> ContentHash {
    let mut hasher = blake3::Hasher::new();
    let mut size = 0;
    for entry in manifest {
        hasher.update(entry.path.as_bytes());
        hasher.update(b"\0");
        hasher.update(entry.hash.as_bytes());
        hasher.update(b"\0");
        hasher.update(entry.size.to_string().as_bytes());
        hasher.update(b"\n");
        size += entry.size;
    }
    ContentHash {
        hash: hasher.finalize().to_hex().to_string(),
        size,
        nfiles: Some(manifest.len() as u64),
    }
}

fn collect_files(base: &Path, dir: &Path, out: &mut Vec<String>) -> Result<(), PipelineError> {
    let entries = std::fs::read_dir(dir).map_err(|e| PipelineError::io("cannot list", dir, e))?;
    for entry in entries {
        let entry = entry.map_err(|e| PipelineError::io("cannot list", dir, e))?;
        let path = entry.path();
        let file_type = entry
            .file_type()
            .map_err(|e| PipelineError::io("cannot stat", &path, e))?;
        if file_type.is_dir() {
            collect_files(base, &path, out)?;
        } else {
            let rel = path.strip_prefix(base).unwrap_or(&path);
            // Forward slashes so manifests are the same on every OS.
            out.push(rel.to_string_lossy().replace('\\', "/"));
        }
    }
    Ok(())
}

#[cfg(unix)]
fn stat_key(meta: &std::fs::Metadata) -> StatKey {
    use std::os::unix::fs::MetadataExt as _;
    StatKey {
        size: meta.len(),
        mtime_ns: i128::from(meta.mtime()) * 1_000_000_000 + i128::from(meta.mtime_nsec()),
        inode: meta.ino(),
    }
}

#[cfg(not(unix))]
fn stat_key(meta: &std::fs::Metadata) -> StatKey {
    let mtime_ns = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos() as i128);
    StatKey {
        size: meta.len(),
        mtime_ns,
        inode: 0,
    }
}

/// Hash of any serialisable value, for cache keys.
pub fn hash_json(value: &serde_json::Value) -> String {
    // serde_json with the default (BTreeMap) map keeps keys sorted: canonical.
    blake3::hash(value.to_string().as_bytes()).to_hex().to_string()
}
