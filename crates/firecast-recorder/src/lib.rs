//! Rerun recordings (`.rrd`) of pipeline and training runs, written into the artifact
//! store. Later crates log rollouts and training curves through [`Recording`];
//! [`MetricsMirror`] turns every stage run's metrics into a `metrics.rrd` of scalar time
//! series, and can stream them to a running viewer as well ([`Viewer`]).
//!
//! Files are byte for byte reproducible: the same rows logged in the same order give the
//! same `.rrd` (recording id from the application and recording name, row and chunk ids
//! counted, no `log_time`/`log_tick`, no start time, chunks cut by size and never by a
//! timer), so the content hashes of stage outputs (the lockfile) do not change between runs.
//!
//! `.rrd` is a viewing format, not an archive: Rerun only promises that a viewer reads
//! files of its own and the previous minor version. Canonical numbers live in the
//! registry and in Parquet; recordings can be regenerated. Open them with the viewer of
//! the same version: `pip install rerun-sdk==0.36.3` then `rerun FILE.rrd`.

use std::path::{Path, PathBuf};
use std::time::Duration;

use firecast_store::{ArtifactStore, StoredArtifact};

mod metrics;
mod rrd;

pub use metrics::{METRICS_ARTIFACT, MetricsMirror, entity_path};
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
    #[error("cannot write the Rerun recording {path}: {message}")]
    Write { path: PathBuf, message: String },
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
    #[error(
        "`{url}` is not a Rerun viewer address: {message} (expected rerun+http://HOST:PORT/proxy, e.g. rerun+http://127.0.0.1:9876/proxy)"
    )]
    ViewerUrl { url: String, message: String },
    #[error("no Rerun viewer listens at {url}: {message}")]
    ViewerUnreachable { url: String, message: String },
}

/// A running Rerun viewer (or `rerun --serve-grpc`) that recordings also stream to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Viewer {
    url: String,
    /// `host:port` to probe.
    address: String,
}

impl Viewer {
    /// A viewer's gRPC address: `rerun+http://HOST:PORT/proxy` (what `rerun` prints).
    pub fn parse(url: &str) -> Result<Self, RecorderError> {
        use std::str::FromStr as _;
        let bad = |message: String| RecorderError::ViewerUrl {
            url: url.to_string(),
            message,
        };
        let uri = rerun::external::re_uri::ProxyUri::from_str(url).map_err(|e| bad(e.to_string()))?;
        Ok(Self {
            url: url.to_string(),
            address: format!("{}:{}", uri.origin.host, uri.origin.port),
        })
    }

    pub fn url(&self) -> &str {
        &self.url
    }

    /// Whether something accepts connections there. Rerun's gRPC sink retries an absent
    /// viewer forever and then blocks the logging thread once its queue is full, so a
    /// stream is only opened to a viewer that answered.
    pub fn probe(&self, timeout: Duration) -> Result<(), RecorderError> {
        use std::net::ToSocketAddrs as _;
        let unreachable = |message: String| RecorderError::ViewerUnreachable {
            url: self.url.clone(),
            message,
        };
        let addresses = self
            .address
            .to_socket_addrs()
            .map_err(|e| unreachable(e.to_string()))?;
        let mut last = String::from("the host name resolves to no address");
        for address in addresses {
            match std::net::TcpStream::connect_timeout(&address, timeout) {
                Ok(_) => return Ok(()),
                Err(e) => last = e.to_string(),
            }
        }
        Err(unreachable(last))
    }
}

/// A recording being written to a local staging file (and, optionally, to a viewer).
///
/// The file is deterministic: the same rows logged in the same order give the same bytes
/// (ids, batching and properties come from what is logged, never from the clock), so a
/// stage's `.rrd` outputs hash the same on every run. Time is the recording's own (set with
/// [`Recording::set_time_sequence`] and friends), not per thread as in a Rerun
/// `RecordingStream`.
pub struct Recording {
    file: rrd::RrdWriter,
    /// The time the next [`Recording::log`] is logged at.
    now: rerun::TimePoint,
    /// A second stream with the same recording id to a live viewer. Separate from the file
    /// so a viewer that goes away never fails the file.
    live: Option<rerun::RecordingStream>,
    /// Removed when dropped unpublished (after `file`, declared first, is closed).
    staging: firecast_fs::TempPath,
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
    /// forbids `/` and `.` in it); `recording_name` names this one, and with the
    /// application id fixes its recording id, so name what makes it unique (agent, seed).
    pub fn create(
        application_id: &str,
        recording_name: &str,
        staging_dir: &Path,
    ) -> Result<Self, RecorderError> {
        Self::create_with_viewer(application_id, recording_name, None, staging_dir, None)
    }

    /// Like [`Recording::create`], with a given recording id (so the file and a live view
    /// are the same recording in the viewer) and everything also streamed to `viewer`. Check
    /// the viewer with [`Viewer::probe`] first: an absent one would block logging.
    pub fn create_with_viewer(
        application_id: &str,
        recording_name: &str,
        recording_id: Option<&str>,
        staging_dir: &Path,
        viewer: Option<&Viewer>,
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
        // Leftovers of processes that are gone, then a fresh temporary name.
        firecast_fs::remove_stale(staging_dir);
        let staging =
            firecast_fs::TempPath::new(&staging_dir.join(format!("{safe_name}.rrd"))).map_err(|e| {
                RecorderError::Io {
                    context: "cannot create staging folder",
                    path: e.path,
                    source: e.source,
                }
            })?;
        let recording_id = match recording_id {
            Some(id) => id.to_string(),
            None => rrd::derived_recording_id(application_id, recording_name),
        };
        let store_id = rerun::StoreId::recording(app_id.clone(), recording_id.as_str());
        let live = match viewer {
            Some(v) => Some(
                rerun::RecordingStreamBuilder::new(app_id)
                    .recording_name(recording_name)
                    .recording_id(recording_id.as_str())
                    .enabled(true)
                    .connect_grpc_opts(v.url())?,
            ),
            None => None,
        };
        let file = rrd::RrdWriter::create(staging.path(), store_id, recording_name)?;
        Ok(Self {
            file,
            now: rerun::TimePoint::default(),
            live,
            staging,
        })
    }

    fn timeline(name: &str) -> Result<rerun::TimelineName, RecorderError> {
        rerun::TimelineName::try_new(name)
            .map_err(|e| RecorderError::Timeline(name.to_string(), e.to_string()))
    }

    /// Set a sequence timeline (e.g. `step`) for what is logged next.
    pub fn set_time_sequence(&mut self, timeline: &str, value: i64) -> Result<(), RecorderError> {
        let name = Self::timeline(timeline)?;
        self.now.insert_cell(name, rerun::TimeCell::from_sequence(value));
        Ok(())
    }

    /// Set a duration timeline (e.g. simulated time) for what is logged next.
    pub fn set_duration_secs(&mut self, timeline: &str, secs: f64) -> Result<(), RecorderError> {
        let name = Self::timeline(timeline)?;
        let duration = Duration::try_from_secs_f64(secs)
            .map_err(|e| RecorderError::Timeline(timeline.to_string(), format!("{secs} s: {e}")))?;
        self.now.insert_cell(name, rerun::TimeCell::from(duration));
        Ok(())
    }

    /// Log an archetype at the current time (the timelines set so far).
    pub fn log<AS: ?Sized + rerun::AsComponents>(
        &mut self,
        entity_path: &str,
        archetype: &AS,
    ) -> Result<(), RecorderError> {
        self.log_batches(entity_path, false, archetype.as_serialized_batches())
    }

    /// Log an archetype on no timeline: it holds at every time.
    pub fn log_static<AS: ?Sized + rerun::AsComponents>(
        &mut self,
        entity_path: &str,
        archetype: &AS,
    ) -> Result<(), RecorderError> {
        self.log_batches(entity_path, true, archetype.as_serialized_batches())
    }

    fn log_batches(
        &mut self,
        entity_path: &str,
        is_static: bool,
        batches: Vec<rerun::SerializedComponentBatch>,
    ) -> Result<(), RecorderError> {
        let timepoint = if is_static {
            rerun::TimePoint::default()
        } else {
            self.now.clone()
        };
        let live_batches = self.live.as_ref().map(|_| batches.clone());
        self.file
            .push(rerun::EntityPath::from(entity_path), timepoint.clone(), batches)?;
        if let (Some(live), Some(batches)) = (&self.live, live_batches) {
            // A stream's time is per thread: set it and log on this thread, every time.
            live.reset_time();
            live.set_timepoint(timepoint);
            live.log_serialized_batches(entity_path, is_static, batches)?;
        }
        Ok(())
    }

    /// Log one scalar at a step of a sequence timeline.
    pub fn scalar(
        &mut self,
        entity_path: &str,
        timeline: &str,
        step: i64,
        value: f64,
    ) -> Result<(), RecorderError> {
        self.set_time_sequence(timeline, step)?;
        self.log(entity_path, &rerun::Scalars::single(value))
    }

    /// Whether what is logged is also streamed to a viewer.
    pub fn is_live(&self) -> bool {
        self.live.is_some()
    }

    /// Send what is queued to the viewer (waiting at most `timeout`) and stop streaming to
    /// it; the file is not affected.
    pub fn disconnect_viewer(&mut self, timeout: Duration) -> Result<(), RecorderError> {
        match self.live.take() {
            Some(live) => live
                .flush_with_timeout(timeout)
                .map_err(|e| RecorderError::Flush(e.to_string())),
            None => Ok(()),
        }
    }

    fn close(mut self) -> Result<firecast_fs::TempPath, RecorderError> {
        // A viewer's trouble is not the file's: its error is dropped here (callers that care
        // call `disconnect_viewer` first).
        let _ignored = self.disconnect_viewer(Duration::from_secs(10));
        let Self { file, staging, .. } = self;
        file.finish()?;
        Ok(staging)
    }

    /// Stop without finishing: the staging file is removed, nothing is published.
    pub fn abandon(self) {
        let Self {
            file, live, staging, ..
        } = self;
        drop(live);
        file.abandon();
        drop(staging);
    }

    /// Finish and move the recording to `dest` (never visible half-written).
    pub fn finish_to_file(self, dest: &Path) -> Result<(), RecorderError> {
        let staging = self.close()?;
        firecast_fs::publish(staging.path(), dest).map_err(|e| RecorderError::Io {
            context: "cannot move recording into place",
            path: dest.to_path_buf(),
            source: e.source,
        })
    }

    /// Finish and upload the recording to the artifact store under `key` (write-once).
    pub fn finish_to_store(self, store: &ArtifactStore, key: &str) -> Result<StoredArtifact, RecorderError> {
        let staging = self.close()?;
        let stored = store.put_file(key, staging.path());
        drop(staging);
        Ok(stored?)
    }
}
