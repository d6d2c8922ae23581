//! The lockfile (`pipelines/<name>.lock`, like `dvc.lock`) and the run-cache that
//! lets a reverted param restore earlier outputs instead of recomputing them.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::PipelineError;
use crate::hash::{ContentHash, HashCache, ManifestEntry};

pub const LOCK_SCHEMA: &str = "firecast-lock/1";

/// A path or URL with its content hash.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LockedFile {
    pub path: String,
    #[serde(flatten)]
    pub content: ContentHash,
}

/// What the last successful run of a stage read and wrote.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LockEntry {
    pub kind: String,
    pub kind_version: u32,
    pub cache_key: String,
    pub run_id: String,
    pub params: serde_json::Value,
    #[serde(default)]
    pub inputs: BTreeMap<String, Vec<LockedFile>>,
    #[serde(default)]
    pub outputs: BTreeMap<String, LockedFile>,
}

/// One lockfile per pipeline; stages sorted by name so diffs stay small.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LockFile {
    pub schema: String,
    pub pipeline: String,
    #[serde(default)]
    pub stages: BTreeMap<String, LockEntry>,
}

impl LockFile {
    /// The lockfile that belongs to a pipeline file: same folder, `.lock` extension.
    pub fn path_for(pipeline_file: &Path) -> PathBuf {
        pipeline_file.with_extension("lock")
    }

    pub fn empty(pipeline: &str) -> Self {
        Self {
            schema: LOCK_SCHEMA.into(),
            pipeline: pipeline.into(),
            stages: BTreeMap::new(),
        }
    }

    /// Read a lockfile; a missing one is empty. A corrupt one is an error naming it.
    pub fn load(path: &Path, pipeline: &str) -> Result<Self, PipelineError> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Self::empty(pipeline)),
            Err(e) => return Err(PipelineError::io("cannot read lockfile", path, e)),
        };
        let lock: Self = crate::spec::deserialize_located(path, &text)?;
        if lock.schema != LOCK_SCHEMA {
            return Err(PipelineError::Lock {
                path: path.to_path_buf(),
                message: format!("schema `{}` is not `{LOCK_SCHEMA}`", lock.schema),
            });
        }
        Ok(lock)
    }

    pub fn save(&self, path: &Path) -> Result<(), PipelineError> {
        let text = serde_yaml_ng::to_string(self).map_err(|e| PipelineError::Lock {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        Ok(firecast_fs::write_atomically(path, text.as_bytes())?)
    }
}

/// An output as stored in the run-cache.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CachedOutput {
    pub path: String,
    pub content: ContentHash,
    /// Files of a folder output; `None` for a file.
    pub manifest: Option<Vec<ManifestEntry>>,
}

/// Content-addressed copies of stage outputs, indexed by cache key.
#[derive(Debug, Clone)]
pub struct RunCache {
    dir: PathBuf,
}

impl RunCache {
    pub fn new(state_dir: &Path) -> Self {
        Self {
            dir: state_dir.join("cache"),
        }
    }

    fn record_path(&self, cache_key: &str) -> PathBuf {
        self.dir.join("runs").join(format!("{cache_key}.json"))
    }

    fn object_path(&self, hash: &str) -> PathBuf {
        let (head, tail) = hash.split_at(hash.len().min(2));
        self.dir.join("objects").join(head).join(tail)
    }

    /// The outputs recorded for a cache key, if every object is still present.
    pub fn lookup(&self, cache_key: &str) -> Option<BTreeMap<String, CachedOutput>> {
        let bytes = std::fs::read(self.record_path(cache_key)).ok()?;
        let outputs: BTreeMap<String, CachedOutput> = serde_json::from_slice(&bytes).ok()?;
        let complete = outputs.values().all(|o| match &o.manifest {
            None => self.object_path(&o.content.hash).exists(),
            Some(files) => files.iter().all(|f| self.object_path(&f.hash).exists()),
        });
        complete.then_some(outputs)
    }

    /// Copy finished outputs into the cache and record them under `cache_key`.
    pub fn save(
        &self,
        cache_key: &str,
        outputs: &BTreeMap<String, (PathBuf, String)>,
        hashes: &HashCache,
    ) -> Result<BTreeMap<String, CachedOutput>, PipelineError> {
        let mut record = BTreeMap::new();
        for (name, (local, display_path)) in outputs {
            let meta =
                std::fs::metadata(local).map_err(|e| PipelineError::io("cannot read output", local, e))?;
            let cached = if meta.is_dir() {
                let manifest = hashes.manifest(local)?;
                for entry in &manifest {
                    self.store_object(&local.join(&entry.path), &entry.hash)?;
                }
                CachedOutput {
                    path: display_path.clone(),
                    content: crate::hash::manifest_hash(&manifest),
                    manifest: Some(manifest),
                }
            } else {
                let content = hashes.hash_path(local)?;
                self.store_object(local, &content.hash)?;
                CachedOutput {
                    path: display_path.clone(),
                    content,
                    manifest: None,
                }
            };
            record.insert(name.clone(), cached);
        }
        let bytes = serde_json::to_vec_pretty(&record).map_err(|e| PipelineError::Lock {
            path: self.record_path(cache_key),
            message: e.to_string(),
        })?;
        firecast_fs::write_atomically(&self.record_path(cache_key), &bytes)?;
        Ok(record)
    }

    fn store_object(&self, file: &Path, hash: &str) -> Result<(), PipelineError> {
        let dest = self.object_path(hash);
        if dest.exists() {
            return Ok(());
        }
        let parent = dest.parent().unwrap_or(&self.dir);
        std::fs::create_dir_all(parent)
            .map_err(|e| PipelineError::io("cannot create cache folder", parent, e))?;
        let tmp = firecast_fs::TempPath::new(&dest)?;
        std::fs::copy(file, tmp.path()).map_err(|e| PipelineError::io("cannot copy into cache", file, e))?;
        tmp.publish()
            .map_err(|e| PipelineError::io("cannot move into cache", &dest, e.source))
    }

    /// Rebuild an output at `dest` from cached objects (through a temporary name).
    pub fn restore(&self, output: &CachedOutput, dest: &Path) -> Result<(), PipelineError> {
        firecast_fs::create_parent(dest)?;
        let staged = firecast_fs::TempPath::new(dest)?;
        let tmp = staged.path();
        match &output.manifest {
            None => {
                std::fs::copy(self.object_path(&output.content.hash), tmp)
                    .map_err(|e| PipelineError::io("cannot restore from cache", dest, e))?;
            }
            Some(files) => {
                std::fs::create_dir_all(tmp)
                    .map_err(|e| PipelineError::io("cannot create folder", tmp, e))?;
                for file in files {
                    let target = tmp.join(&file.path);
                    if let Some(parent) = target.parent() {
                        std::fs::create_dir_all(parent)
                            .map_err(|e| PipelineError::io("cannot create folder", parent, e))?;
                    }
                    std::fs::copy(self.object_path(&file.hash), &target)
                        .map_err(|e| PipelineError::io("cannot restore from cache", &target, e))?;
                }
            }
        }
        Ok(staged.publish()?)
    }
}
