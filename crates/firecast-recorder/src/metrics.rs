//! Every stage run's metrics as Rerun scalar time series: [`MetricsMirror`] wraps the
//! observer the runner reports to (the registry) and passes everything on, and for each
//! stage run that reports a metric it keeps a recording with one entity per metric key and
//! the metric's step on the `step` timeline. When the run ends (succeeded or failed) the
//! recording is finished into the artifact store as `runs/<run>/metrics/metrics.rrd` and
//! registered as the run's `metrics` artifact. Until then it is a staging file (`firecast_fs`'s temporary name)
//! that is never published, so a killed process leaves nothing that looks finished.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Duration;

use firecast_pipeline::observer::{LineageRecord, ObserverError, PipelineRunInfo, StageRunInfo};
use firecast_pipeline::{DatasetRecord, RunObserver, RunStatus};
use firecast_store::ArtifactStore;

use crate::{RecorderError, Recording, Viewer};

/// The artifact name (and file stem) of a run's metrics recording.
pub const METRICS_ARTIFACT: &str = "metrics";

/// The Rerun application the metric recordings group under.
const APPLICATION_ID: &str = "firecast_metrics";

/// The sequence timeline metric steps go on.
const TIMELINE: &str = "step";

/// How long a viewer may take to answer, and to take what is queued when a run ends.
const PROBE_TIMEOUT: Duration = Duration::from_secs(1);
const VIEWER_FLUSH_TIMEOUT: Duration = Duration::from_secs(10);

type Warn = Box<dyn Fn(&str) + Send + Sync>;

/// A run that has started, and its recording once it reported a metric.
struct Run {
    label: String,
    recording: Option<Recording>,
    /// Its recording failed (and that was said once): its metrics go to `inner` only.
    failed: bool,
}

impl Run {
    fn new(label: String) -> Self {
        Self {
            label,
            recording: None,
            failed: false,
        }
    }
}

/// A [`RunObserver`] that passes everything to `inner` and mirrors metrics into Rerun.
pub struct MetricsMirror {
    inner: Arc<dyn RunObserver>,
    store: Arc<ArtifactStore>,
    staging: PathBuf,
    viewer: Option<Viewer>,
    /// Set once the viewer did not answer: later runs record to their file only.
    viewer_lost: OnceLock<()>,
    warn: Warn,
    runs: Mutex<HashMap<String, Run>>,
}

impl std::fmt::Debug for MetricsMirror {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MetricsMirror")
            .field("staging", &self.staging)
            .field("viewer", &self.viewer)
            .finish_non_exhaustive()
    }
}

/// A metric key as a Rerun entity path: `/`-separated parts, each reduced to letters,
/// digits, `_`, `-` and `.` (anything else becomes `_`); empty parts are dropped and a
/// leading `__` (Rerun's reserved prefix) loses one `_`.
pub fn entity_path(key: &str) -> String {
    let parts: Vec<String> = key
        .split('/')
        .filter(|p| !p.is_empty())
        .map(|part| {
            let clean: String = part
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || "_-.".contains(c) {
                        c
                    } else {
                        '_'
                    }
                })
                .collect();
            match clean.strip_prefix("__") {
                Some(rest) => format!("_{rest}"),
                None => clean,
            }
        })
        .collect();
    if parts.is_empty() {
        "_".to_string()
    } else {
        parts.join("/")
    }
}

impl MetricsMirror {
    /// `staging` holds the recordings being written (e.g. `.firecast/state/recordings`);
    /// `warn` receives problems that must not fail a run (a viewer that does not answer,
    /// a recording that could not be written), each viewer problem once.
    pub fn new(
        inner: Arc<dyn RunObserver>,
        store: Arc<ArtifactStore>,
        staging: PathBuf,
        viewer: Option<Viewer>,
        warn: impl Fn(&str) + Send + Sync + 'static,
    ) -> Self {
        Self {
            inner,
            store,
            staging,
            viewer,
            viewer_lost: OnceLock::new(),
            warn: Box::new(warn),
            runs: Mutex::new(HashMap::new()),
        }
    }

    /// The viewer to stream a new recording to, if it answers now.
    fn live_viewer(&self) -> Option<&Viewer> {
        let viewer = self.viewer.as_ref()?;
        if self.viewer_lost.get().is_some() {
            return None;
        }
        match viewer.probe(PROBE_TIMEOUT) {
            Ok(()) => Some(viewer),
            Err(e) => {
                if self.viewer_lost.set(()).is_ok() {
                    (self.warn)(&format!("{e}; metrics are recorded to metrics.rrd only"));
                }
                None
            }
        }
    }

    fn start_recording(&self, run_id: &str, label: &str) -> Result<Recording, RecorderError> {
        let name = format!("{label} ({run_id})");
        if let Some(viewer) = self.live_viewer() {
            match Recording::create_with_viewer(
                APPLICATION_ID,
                &name,
                Some(run_id),
                &self.staging,
                Some(viewer),
            ) {
                Ok(recording) => return Ok(recording),
                Err(e) => {
                    if self.viewer_lost.set(()).is_ok() {
                        (self.warn)(&format!(
                            "cannot stream to the Rerun viewer at {}: {e}; metrics are recorded to metrics.rrd only",
                            viewer.url()
                        ));
                    }
                }
            }
        }
        Recording::create_with_viewer(APPLICATION_ID, &name, Some(run_id), &self.staging, None)
    }

    /// Log one metric into its run's recording; a failure is said once per run and never
    /// fails the run (the registry has the value).
    fn record(&self, run_id: &str, key: &str, step: i64, value: f64) {
        let mut runs = self.runs.lock().unwrap_or_else(|e| e.into_inner());
        // Metrics for a run this observer did not see start still get a recording.
        let run = runs
            .entry(run_id.to_string())
            .or_insert_with(|| Run::new(run_id.to_string()));
        if run.failed {
            return;
        }
        if run.recording.is_none() {
            match self.start_recording(run_id, &run.label) {
                Ok(recording) => run.recording = Some(recording),
                Err(e) => {
                    run.failed = true;
                    (self.warn)(&format!("metrics of run {run_id} are not recorded to Rerun: {e}"));
                    return;
                }
            }
        }
        // Logged under the lock: stages report from several threads, and Rerun's time is
        // per thread, so each scalar sets its step and logs it in one go.
        if let Some(recording) = &mut run.recording
            && let Err(e) = recording.scalar(&entity_path(key), TIMELINE, step, value)
        {
            run.failed = true;
            (self.warn)(&format!(
                "metric `{key}` of run {run_id} is not recorded to Rerun: {e}"
            ));
        }
    }

    /// Finish a run's recording into the store and register it with `inner`.
    fn publish(&self, run_id: &str, mut recording: Recording) -> Result<(), String> {
        if recording.is_live()
            && let Err(e) = recording.disconnect_viewer(VIEWER_FLUSH_TIMEOUT)
            && self.viewer_lost.set(()).is_ok()
        {
            (self.warn)(&format!(
                "the Rerun viewer did not take all metrics of run {run_id}: {e}; later runs are recorded to metrics.rrd only"
            ));
        }
        let key = firecast_pipeline::stage::artifact_key(
            run_id,
            METRICS_ARTIFACT,
            std::path::Path::new(&format!("{METRICS_ARTIFACT}.rrd")),
        );
        let stored = recording
            .finish_to_store(&self.store, &key)
            .map_err(|e| format!("metrics.rrd of run {run_id} not written: {e}"))?;
        self.inner
            .artifact(run_id, METRICS_ARTIFACT, &stored.uri, &stored.hash, stored.size)
            .map_err(|e| format!("metrics.rrd of run {run_id} not registered: {e}"))
    }
}

impl Drop for MetricsMirror {
    fn drop(&mut self) {
        // Runs that never ended (the runner stopped early): nothing is published.
        let runs = std::mem::take(self.runs.get_mut().unwrap_or_else(|e| e.into_inner()));
        for run in runs.into_values() {
            if let Some(recording) = run.recording {
                recording.abandon();
            }
        }
    }
}

impl RunObserver for MetricsMirror {
    fn pipeline_started(&self, run: &PipelineRunInfo) -> Result<(), ObserverError> {
        self.inner.pipeline_started(run)
    }

    fn pipeline_finished(
        &self,
        run_id: &str,
        status: RunStatus,
        ended_at: chrono::DateTime<chrono::Utc>,
    ) -> Result<(), ObserverError> {
        self.inner.pipeline_finished(run_id, status, ended_at)
    }

    fn stage_started(&self, run: &StageRunInfo) -> Result<(), ObserverError> {
        self.runs.lock().unwrap_or_else(|e| e.into_inner()).insert(
            run.run_id.clone(),
            Run::new(format!("{} {}", run.pipeline, run.stage)),
        );
        self.inner.stage_started(run)
    }

    fn stage_finished(
        &self,
        run_id: &str,
        status: RunStatus,
        ended_at: chrono::DateTime<chrono::Utc>,
        error: Option<&str>,
    ) -> Result<(), ObserverError> {
        let run = self.runs.lock().unwrap_or_else(|e| e.into_inner()).remove(run_id);
        // Published before the run's end is registered, so a finished run already lists it.
        if let Some(recording) = run.and_then(|r| r.recording)
            && let Err(message) = self.publish(run_id, recording)
        {
            (self.warn)(&message);
        }
        self.inner.stage_finished(run_id, status, ended_at, error)
    }

    fn metric(&self, run_id: &str, key: &str, step: i64, value: f64) -> Result<(), ObserverError> {
        self.record(run_id, key, step, value);
        self.inner.metric(run_id, key, step, value)
    }

    fn artifact(
        &self,
        run_id: &str,
        name: &str,
        uri: &str,
        hash: &str,
        size: u64,
    ) -> Result<(), ObserverError> {
        self.inner.artifact(run_id, name, uri, hash, size)
    }

    fn dataset(&self, run_id: &str, dataset: &DatasetRecord) -> Result<(), ObserverError> {
        self.inner.dataset(run_id, dataset)
    }

    fn lineage(&self, run_id: &str, record: &LineageRecord) -> Result<(), ObserverError> {
        self.inner.lineage(run_id, record)
    }
}

#[cfg(test)]
mod tests {
    use super::entity_path;

    #[test]
    fn metric_keys_become_entity_paths() {
        assert_eq!(
            entity_path("seed-0/rollout/ep_rew_mean"),
            "seed-0/rollout/ep_rew_mean"
        );
        assert_eq!(
            entity_path("paper/lstm2/seed-1/val_auprc"),
            "paper/lstm2/seed-1/val_auprc"
        );
        assert_eq!(entity_path("/a//b c/"), "a/b_c");
        assert_eq!(entity_path("__x/auroc@0.5"), "_x/auroc_0.5");
        assert_eq!(entity_path("//"), "_");
    }
}
