//! The artifact store: models, reports, recordings and remote pipeline inputs,
//! behind one URL.
//!
//! - a plain path or `file:///abs/path`: a local folder (the default, `artifacts/`);
//! - `s3://bucket/prefix`: S3 or any S3-compatible server, configured from the
//!   standard `AWS_*` environment variables (`AWS_ENDPOINT_URL`, `AWS_ALLOW_HTTP`, ...);
//! - `gs://bucket/prefix`, `az://container/prefix`: Google Cloud Storage / Azure,
//!   credentials from their environment variables;
//! - `memory://`: in-process, for tests.
//!
//! Artifacts are written once: `put` uses `PutMode::Create`, so a finished
//! artifact is never overwritten, and a partially written one is never visible
//! (object_store writes are atomic).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use futures::TryStreamExt as _;
use object_store::path::Path as ObjectPath;
use object_store::{ObjectStore, ObjectStoreExt as _, PutMode, PutOptions, PutPayload};

/// Errors of the artifact store. URLs and paths come last in the message.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("invalid artifact store location: {0}")]
    InvalidUrl(String),
    #[error(
        "unsupported artifact store scheme `{scheme}` (use a path, file://, s3://, gs://, az:// or memory://): {url}"
    )]
    UnsupportedScheme { scheme: String, url: String },
    #[error("artifact already exists (artifacts are write-once): {0}")]
    AlreadyExists(String),
    #[error("artifact not found: {0}")]
    NotFound(String),
    #[error("object store error at {location}: {source}")]
    Backend {
        location: String,
        #[source]
        source: object_store::Error,
    },
    #[error("{context}: {path}: {source}")]
    Io {
        context: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot start the I/O runtime: {0}")]
    Runtime(std::io::Error),
}

/// One stored object.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ArtifactEntry {
    /// Full URL, e.g. `s3://bucket/prefix/runs/abc/model.pt`.
    pub uri: String,
    /// Key relative to the store root, e.g. `runs/abc/model.pt`.
    pub key: String,
    pub size: u64,
    pub last_modified: String,
}

/// An artifact that was written: where, its content hash and size.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StoredArtifact {
    pub uri: String,
    pub key: String,
    /// BLAKE3 of the content, hex.
    pub hash: String,
    pub size: u64,
}

/// A synchronous handle over an `ObjectStore`, rooted at a prefix.
pub struct ArtifactStore {
    store: Arc<dyn ObjectStore>,
    prefix: ObjectPath,
    /// The URL as given, without a trailing slash; keys are appended to it.
    base_url: String,
    runtime: tokio::runtime::Runtime,
}

impl std::fmt::Debug for ArtifactStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ArtifactStore")
            .field("url", &self.base_url)
            .finish()
    }
}

impl ArtifactStore {
    /// Open a store from a URL or a local path (relative paths resolve against `root`).
    pub fn open(location: &str, root: &Path) -> Result<Self, StoreError> {
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(StoreError::Runtime)?;
        let (store, prefix, base_url): (Arc<dyn ObjectStore>, ObjectPath, String) =
            match location.split_once("://") {
                None => local(&root.join(location))?,
                Some(("file", rest)) => local(Path::new(rest))?,
                Some((scheme, _)) => {
                    let url = url::Url::parse(location)
                        .map_err(|e| StoreError::InvalidUrl(format!("{e}: {location}")))?;
                    let prefix = ObjectPath::from(url.path().trim_matches('/'));
                    let store: Arc<dyn ObjectStore> = match scheme {
                        "memory" => Arc::new(object_store::memory::InMemory::new()),
                        "s3" | "s3a" => Arc::new(
                            object_store::aws::AmazonS3Builder::from_env()
                                .with_url(location)
                                .build()
                                .map_err(|e| backend(location, e))?,
                        ),
                        "gs" => Arc::new(
                            object_store::gcp::GoogleCloudStorageBuilder::from_env()
                                .with_url(location)
                                .build()
                                .map_err(|e| backend(location, e))?,
                        ),
                        "az" | "abfs" | "abfss" | "azure" => Arc::new(
                            object_store::azure::MicrosoftAzureBuilder::from_env()
                                .with_url(location)
                                .build()
                                .map_err(|e| backend(location, e))?,
                        ),
                        other => {
                            return Err(StoreError::UnsupportedScheme {
                                scheme: other.to_string(),
                                url: location.to_string(),
                            });
                        }
                    };
                    (store, prefix, location.trim_end_matches('/').to_string())
                }
            };
        Ok(Self {
            store,
            prefix,
            base_url,
            runtime,
        })
    }

    /// The store's root URL.
    pub fn url(&self) -> &str {
        &self.base_url
    }

    fn full_path(&self, key: &str) -> ObjectPath {
        let key = key.trim_matches('/');
        if self.prefix.as_ref().is_empty() {
            ObjectPath::from(key)
        } else {
            ObjectPath::from(format!("{}/{key}", self.prefix))
        }
    }

    /// The URL an artifact key will have.
    pub fn uri_of(&self, key: &str) -> String {
        format!("{}/{}", self.base_url, key.trim_matches('/'))
    }

    /// Turn a URL of this store (or a bare key) back into a key.
    pub fn key_of(&self, uri_or_key: &str) -> String {
        uri_or_key
            .strip_prefix(&self.base_url)
            .unwrap_or(uri_or_key)
            .trim_matches('/')
            .to_string()
    }

    /// Write bytes under `key`, failing if it already exists.
    pub fn put_bytes(&self, key: &str, bytes: Vec<u8>) -> Result<StoredArtifact, StoreError> {
        let hash = blake3::hash(&bytes).to_hex().to_string();
        let size = bytes.len() as u64;
        let path = self.full_path(key);
        let uri = self.uri_of(key);
        let options = PutOptions {
            mode: PutMode::Create,
            ..Default::default()
        };
        self.runtime
            .block_on(self.store.put_opts(&path, PutPayload::from(bytes), options))
            .map_err(|e| match e {
                object_store::Error::AlreadyExists { .. } => StoreError::AlreadyExists(uri.clone()),
                other => backend(&uri, other),
            })?;
        Ok(StoredArtifact {
            uri,
            key: key.trim_matches('/').to_string(),
            hash,
            size,
        })
    }

    /// Upload a local file under `key` (write-once).
    pub fn put_file(&self, key: &str, file: &Path) -> Result<StoredArtifact, StoreError> {
        let bytes = std::fs::read(file).map_err(|source| StoreError::Io {
            context: "cannot read artifact",
            path: file.to_path_buf(),
            source,
        })?;
        self.put_bytes(key, bytes)
    }

    /// Whether an object exists under `key` (or URL).
    pub fn exists(&self, uri_or_key: &str) -> Result<bool, StoreError> {
        let key = self.key_of(uri_or_key);
        let path = self.full_path(&key);
        match self.runtime.block_on(self.store.head(&path)) {
            Ok(_) => Ok(true),
            Err(object_store::Error::NotFound { .. }) => Ok(false),
            Err(e) => Err(backend(&self.uri_of(&key), e)),
        }
    }

    /// Read an artifact's bytes by key or URL.
    pub fn get_bytes(&self, uri_or_key: &str) -> Result<Vec<u8>, StoreError> {
        let key = self.key_of(uri_or_key);
        let path = self.full_path(&key);
        let uri = self.uri_of(&key);
        self.runtime
            .block_on(async {
                let result = self.store.get(&path).await?;
                result.bytes().await
            })
            .map(|b| b.to_vec())
            .map_err(|e| match e {
                object_store::Error::NotFound { .. } => StoreError::NotFound(uri),
                other => backend(&uri, other),
            })
    }

    /// Download an artifact to a local file, atomically (temporary name, then rename).
    pub fn get_to_file(&self, uri_or_key: &str, dest: &Path) -> Result<u64, StoreError> {
        let bytes = self.get_bytes(uri_or_key)?;
        firecast_fs::write_atomically(dest, &bytes)?;
        Ok(bytes.len() as u64)
    }

    /// List artifacts under a key prefix, sorted by key.
    pub fn list(&self, prefix: Option<&str>) -> Result<Vec<ArtifactEntry>, StoreError> {
        let full = match prefix {
            Some(p) if !p.trim_matches('/').is_empty() => self.full_path(p),
            _ => self.prefix.clone(),
        };
        let listing: Vec<object_store::ObjectMeta> = self
            .runtime
            .block_on(self.store.list(Some(&full)).try_collect())
            .map_err(|e| backend(&self.base_url, e))?;
        let strip = self.prefix.as_ref().to_string();
        let mut entries: Vec<ArtifactEntry> = listing
            .into_iter()
            .map(|meta| {
                let location = meta.location.as_ref();
                let key = location
                    .strip_prefix(&strip)
                    .unwrap_or(location)
                    .trim_start_matches('/')
                    .to_string();
                ArtifactEntry {
                    uri: self.uri_of(&key),
                    key,
                    size: meta.size,
                    last_modified: meta.last_modified.to_rfc3339(),
                }
            })
            .collect();
        entries.sort_by(|a, b| a.key.cmp(&b.key));
        Ok(entries)
    }
}

fn local(dir: &Path) -> Result<(Arc<dyn ObjectStore>, ObjectPath, String), StoreError> {
    std::fs::create_dir_all(dir).map_err(|source| StoreError::Io {
        context: "cannot create artifact folder",
        path: dir.to_path_buf(),
        source,
    })?;
    let dir = dir.canonicalize().map_err(|source| StoreError::Io {
        context: "cannot resolve artifact folder",
        path: dir.to_path_buf(),
        source,
    })?;
    let store = object_store::local::LocalFileSystem::new_with_prefix(&dir)
        .map_err(|e| backend(&dir.display().to_string(), e))?
        .with_automatic_cleanup(true);
    let url = format!("file://{}", dir.display());
    Ok((Arc::new(store), ObjectPath::default(), url))
}

fn backend(location: &str, source: object_store::Error) -> StoreError {
    StoreError::Backend {
        location: location.to_string(),
        source,
    }
}

impl From<firecast_fs::FsError> for StoreError {
    fn from(e: firecast_fs::FsError) -> Self {
        Self::Io {
            context: e.op,
            path: e.path,
            source: e.source,
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn memory_round_trip_is_write_once() {
        let store = ArtifactStore::open("memory://", Path::new(".")).unwrap();
        let stored = store.put_bytes("runs/r1/report.md", b"# fire".to_vec()).unwrap();
        assert_eq!(stored.size, 6);
        assert_eq!(store.get_bytes(&stored.uri).unwrap(), b"# fire");
        assert!(matches!(
            store.put_bytes("runs/r1/report.md", b"x".to_vec()),
            Err(StoreError::AlreadyExists(_))
        ));
        let listed = store.list(Some("runs")).unwrap();
        assert_eq!(listed.len(), 1);
        assert_eq!(listed[0].key, "runs/r1/report.md");
    }

    #[test]
    fn local_folder_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let store = ArtifactStore::open("artifacts", dir.path()).unwrap();
        let stored = store.put_bytes("a/b.txt", b"hello".to_vec()).unwrap();
        assert!(dir.path().join("artifacts/a/b.txt").exists());
        let out = dir.path().join("copy.txt");
        store.get_to_file(&stored.uri, &out).unwrap();
        assert_eq!(std::fs::read(out).unwrap(), b"hello");
        assert!(matches!(
            store.get_bytes("a/missing"),
            Err(StoreError::NotFound(_))
        ));
        assert!(store.exists("a/b.txt").unwrap());
        assert!(!store.exists("a/missing").unwrap());
    }
}
