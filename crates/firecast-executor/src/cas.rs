//! Content-addressed data movement through the artifact store: the shared disk between
//! the driver and the workers. A file is stored once under `cas/objects/<hash>`; a folder
//! is its files plus a manifest (the same manifest and hash as the run-cache and the
//! lockfile), so the same bytes never travel twice and a reader can check what it got.
//!
//! Objects are written with object_store's atomic, write-once puts: a worker killed
//! mid-upload leaves no object, and an object that exists is complete.

use std::path::Path;

use firecast_pipeline::hash::{ContentHash, HashCache, ManifestEntry, hash_file_contents, manifest_hash};
use firecast_store::{ArtifactStore, StoreError};
use serde::{Deserialize, Serialize};

use crate::ExecutorError;

/// A file or folder in the store: its content hash, and for a folder its manifest.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct StoredContent {
    #[serde(flatten)]
    pub content: ContentHash,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub manifest: Option<Vec<ManifestEntry>>,
}

/// `cas/objects/ab/cdef…`
pub fn object_key(hash: &str) -> String {
    let (head, tail) = hash.split_at(hash.len().min(2));
    format!("cas/objects/{head}/{tail}")
}

/// Upload a local file or folder (unless its objects are already there).
pub fn put_path(
    store: &ArtifactStore,
    local: &Path,
    hashes: &HashCache,
) -> Result<StoredContent, ExecutorError> {
    let meta = std::fs::metadata(local).map_err(|e| ExecutorError::io("cannot read", local, e))?;
    if meta.is_dir() {
        let manifest = hashes.manifest(local)?;
        for entry in &manifest {
            put_object(store, &local.join(&entry.path), &entry.hash)?;
        }
        Ok(StoredContent {
            content: manifest_hash(&manifest),
            manifest: Some(manifest),
        })
    } else {
        let content = hashes.hash_path(local)?;
        put_object(store, local, &content.hash)?;
        Ok(StoredContent {
            content,
            manifest: None,
        })
    }
}

fn put_object(store: &ArtifactStore, file: &Path, hash: &str) -> Result<(), ExecutorError> {
    let key = object_key(hash);
    if store.exists(&key)? {
        return Ok(());
    }
    match store.put_file(&key, file) {
        Ok(stored) if stored.hash == hash => Ok(()),
        Ok(stored) => Err(ExecutorError::Integrity(format!(
            "{} changed while it was uploaded (hash {} expected, {} sent)",
            file.display(),
            hash,
            stored.hash
        ))),
        // Another stage uploaded the same bytes meanwhile.
        Err(StoreError::AlreadyExists(_)) => Ok(()),
        Err(e) => Err(e.into()),
    }
}

/// Download a stored file or folder to `dest` (which must not exist yet), checking every
/// byte against its hash.
pub fn get_path(store: &ArtifactStore, stored: &StoredContent, dest: &Path) -> Result<(), ExecutorError> {
    match &stored.manifest {
        None => get_object(store, &stored.content.hash, dest),
        Some(files) => {
            if manifest_hash(files).hash != stored.content.hash {
                return Err(ExecutorError::Integrity(format!(
                    "the manifest for {} does not match its hash {}",
                    dest.display(),
                    stored.content.hash
                )));
            }
            std::fs::create_dir_all(dest).map_err(|e| ExecutorError::io("cannot create folder", dest, e))?;
            for file in files {
                get_object(store, &file.hash, &dest.join(&file.path))?;
            }
            Ok(())
        }
    }
}

/// Download the files of a stored folder flagged in `keep` (one flag per manifest entry) to
/// `dest`, each checked against its hash, and leave the others as empty files: a sharded
/// kind's word that the shard does not read them. Returns how many were fetched.
pub fn get_folder_files(
    store: &ArtifactStore,
    stored: &StoredContent,
    dest: &Path,
    keep: &[bool],
) -> Result<usize, ExecutorError> {
    let Some(files) = &stored.manifest else {
        return Err(ExecutorError::Integrity(format!(
            "{} is a file, not a folder",
            stored.content.hash
        )));
    };
    if keep.len() != files.len() || manifest_hash(files).hash != stored.content.hash {
        return Err(ExecutorError::Integrity(format!(
            "the manifest for {} does not match its hash {} or the {} files chosen",
            dest.display(),
            stored.content.hash,
            keep.len()
        )));
    }
    let mut fetched = 0;
    for (file, &wanted) in files.iter().zip(keep) {
        let path = dest.join(&file.path);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|e| ExecutorError::io("cannot create folder", parent, e))?;
        }
        if wanted {
            get_object(store, &file.hash, &path)?;
            fetched += 1;
        } else {
            std::fs::File::create(&path).map_err(|e| ExecutorError::io("cannot create", &path, e))?;
        }
    }
    Ok(fetched)
}

fn get_object(store: &ArtifactStore, hash: &str, dest: &Path) -> Result<(), ExecutorError> {
    store.get_to_file(&object_key(hash), dest)?;
    let got = hash_file_contents(dest)?;
    if got != hash {
        let _ignored = std::fs::remove_file(dest);
        return Err(ExecutorError::Integrity(format!(
            "object {} came back with hash {got}",
            object_key(hash)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn files_and_folders_round_trip_by_content() {
        let dir = tempfile::tempdir().unwrap();
        let store = ArtifactStore::open("store", dir.path()).unwrap();
        let hashes = HashCache::default();
        let folder = dir.path().join("in/folder");
        std::fs::create_dir_all(folder.join("sub")).unwrap();
        std::fs::write(folder.join("a.txt"), b"alpha").unwrap();
        std::fs::write(folder.join("sub/b.txt"), b"beta").unwrap();
        std::fs::write(dir.path().join("in/same.txt"), b"alpha").unwrap();

        let stored = put_path(&store, &folder, &hashes).unwrap();
        assert_eq!(stored.manifest.as_ref().unwrap().len(), 2);
        assert_eq!(stored.content, hashes.hash_path(&folder).unwrap());
        // Same bytes, second upload: nothing new stored.
        let single = put_path(&store, &dir.path().join("in/same.txt"), &hashes).unwrap();
        assert_eq!(store.list(Some("cas/objects")).unwrap().len(), 2);

        let out = dir.path().join("out/folder");
        get_path(&store, &stored, &out).unwrap();
        assert_eq!(std::fs::read(out.join("sub/b.txt")).unwrap(), b"beta");
        assert_eq!(hashes.hash_path(&out).unwrap(), stored.content);
        get_path(&store, &single, &dir.path().join("out/one.txt")).unwrap();
        assert_eq!(std::fs::read(dir.path().join("out/one.txt")).unwrap(), b"alpha");

        // A shard's share of the folder: the other file is there, empty.
        let part = dir.path().join("out/part");
        let names: Vec<&str> = stored
            .manifest
            .as_ref()
            .unwrap()
            .iter()
            .map(|f| f.path.as_str())
            .collect();
        assert_eq!(names, ["a.txt", "sub/b.txt"]);
        assert_eq!(
            get_folder_files(&store, &stored, &part, &[false, true]).unwrap(),
            1
        );
        assert_eq!(std::fs::read(part.join("a.txt")).unwrap(), b"");
        assert_eq!(std::fs::read(part.join("sub/b.txt")).unwrap(), b"beta");
        assert!(get_folder_files(&store, &stored, &dir.path().join("out/bad"), &[true]).is_err());
    }

    #[test]
    fn a_tampered_object_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let store = ArtifactStore::open("store", dir.path()).unwrap();
        let hashes = HashCache::default();
        std::fs::write(dir.path().join("x.txt"), b"honest").unwrap();
        let stored = put_path(&store, &dir.path().join("x.txt"), &hashes).unwrap();
        let object = dir.path().join("store").join(object_key(&stored.content.hash));
        std::fs::write(&object, b"forged").unwrap();
        let err = get_path(&store, &stored, &dir.path().join("y.txt")).unwrap_err();
        assert!(err.to_string().contains("came back with hash"), "{err}");
        assert!(!dir.path().join("y.txt").exists());
    }
}
