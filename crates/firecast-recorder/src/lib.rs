//! Rerun recordings (`.rrd`) of pipeline and training runs, written into the artifact
//! store. Later crates log rollouts and training curves through [`Recording`].
//!
//! `.rrd` is a viewing format, not an archive: Rerun only promises that a viewer reads
//! files of its own and the previous minor version. Canonical numbers live in the
//! registry and in Parquet; recordings can be regenerated. Open them with the viewer of
//! the same version: `pip install rerun-sdk==0.36.3` then `rerun FILE.rrd`.

use std::path::{Path, PathBuf};

use firecast_store::{ArtifactStore, StoredArtifact};

pub use rerun;

/// The Rerun version recordings are written with (the viewer must match).
pub const RERUN_VERSION: &str = "0.36.3";

#[derive(Debug, thiserror::Error)]
pub enum RecorderError {
    #[error("cannot start the Rerun recording: {0}")]
    Start(#[from] rerun::RecordingStreamError),
    #[error("invalid Rerun timeline name `{0}`: {1}")]
    Timeline(String, String),
    #[error("cannot log to the Rerun recording: {0}")]
    Log(String),
    #[error("cannot flush the Rerun recording: {0}")]
    Flush(String),
    #[error("invalid Rerun application id `{0}`: use letters, digits, `_`, `-`, space or `:`")]
    ApplicationId(String),
    #[error("{context}: {path}: {source}")]
    Io {
        context: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Store(#[from] firecast_store::StoreError),
}

/// A recording being written to a local staging file.
pub struct Recording {
    stream: rerun::RecordingStream,
    staging: PathBuf,
}

impl std::fmt::Debug for Recording {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recording")
            .field("staging", &self.staging)
            .finish()
    }
}

impl Recording {
    /// Start a recording. `application_id` groups recordings in the viewer (Rerun 0.36
    /// forbids `/` and `.` in it); `recording_name` names this one (e.g. the run id).
    pub fn create(
        application_id: &str,
        recording_name: &str,
        staging_dir: &Path,
    ) -> Result<Self, RecorderError> {
        // Rerun would silently rewrite an invalid id (and append a hash); refuse instead,
        // so recordings group under the name the user chose.
        let valid_char = |c: char| c.is_ascii_alphanumeric() || "_- :[]()".contains(c);
        if application_id.len() > 180 || !application_id.chars().all(valid_char) {
            return Err(RecorderError::ApplicationId(application_id.to_string()));
        }
        let app_id = rerun::ApplicationId::try_new(application_id)
            .map_err(|_| RecorderError::ApplicationId(application_id.to_string()))?;
        std::fs::create_dir_all(staging_dir).map_err(|source| RecorderError::Io {
            context: "cannot create staging folder",
            path: staging_dir.to_path_buf(),
            source,
        })?;
        let safe_name: String = recording_name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let staging = staging_dir.join(format!(".{safe_name}.rrd.partial"));
        let stream = rerun::RecordingStreamBuilder::new(app_id)
            .recording_name(recording_name)
            .enabled(true)
            .save(&staging)?;
        Ok(Self { stream, staging })
    }

    /// The Rerun stream, for logging any archetype.
    pub fn stream(&self) -> &rerun::RecordingStream {
        &self.stream
    }

    /// Log one scalar at a step of a sequence timeline.
    pub fn scalar(
        &self,
        entity_path: &str,
        timeline: &str,
        step: i64,
        value: f64,
    ) -> Result<(), RecorderError> {
        let timeline = rerun::TimelineName::try_new(timeline)
            .map_err(|e| RecorderError::Timeline(timeline.to_string(), e.to_string()))?;
        self.stream.set_time_sequence(timeline, step);
        self.stream.log(entity_path, &rerun::Scalars::single(value))?;
        Ok(())
    }

    fn close(self) -> Result<PathBuf, RecorderError> {
        self.stream
            .flush_blocking()
            .map_err(|e| RecorderError::Flush(e.to_string()))?;
        let Self { stream, staging } = self;
        // Dropping the last handle closes the file sink.
        drop(stream);
        Ok(staging)
    }

    /// Finish and move the recording to `dest` (never visible half-written).
    pub fn finish_to_file(self, dest: &Path) -> Result<(), RecorderError> {
        let staging = self.close()?;
        std::fs::rename(&staging, dest).map_err(|source| RecorderError::Io {
            context: "cannot move recording into place",
            path: dest.to_path_buf(),
            source,
        })
    }

    /// Finish and upload the recording to the artifact store under `key` (write-once).
    pub fn finish_to_store(self, store: &ArtifactStore, key: &str) -> Result<StoredArtifact, RecorderError> {
        let staging = self.close()?;
        let stored = store.put_file(key, &staging);
        let _ignored = std::fs::remove_file(&staging);
        Ok(stored?)
    }
}
