//! Stages on a Ray cluster through Ray's Jobs REST API (the dashboard, port 8265):
//! every stage run is one Ray job whose entrypoint is this `firecast` binary on a worker
//! (`firecast pipeline stage-exec`), with the stage's `resources:` as the entrypoint's
//! resources, so Ray queues stage runs onto free CPUs, memory and GPUs.
//!
//! - `POST /api/jobs/` submits, `GET /api/jobs/<id>` polls, `GET /api/jobs/<id>/logs`
//!   fetches the log, `POST /api/jobs/<id>/stop` stops;
//! - a job that stays `PENDING` longer than the pending timeout is stopped and reported
//!   (Ray itself may leave it pending for 15 minutes or more);
//! - a job that fails without writing a result (its worker was killed, its node died)
//!   is submitted again, up to `max_attempts`; a stage that fails writes a result with
//!   its error and is not retried; a missing binary (exit 127) is not retried either.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use firecast_pipeline::Shard;
use firecast_pipeline::executor::{
    Invocation, JobFailure, JobOutcome, RecordingObserver, StageExecutor, StageJob, invoke_merge,
};
use firecast_pipeline::stage::SHARD_OUTPUT;
use firecast_store::ArtifactStore;
use serde_json::{Value, json};

use crate::ExecutorError;
use crate::task::{TaskResult, get_json, result_key};
use crate::{cas, driver};

/// Settings of the Ray executor.
#[derive(Debug, Clone)]
pub struct RayOptions {
    /// The dashboard's HTTP address, e.g. `http://127.0.0.1:8265`.
    pub address: String,
    /// The `firecast` binary as workers see it.
    pub firecast_bin: PathBuf,
    /// A job still `PENDING` after this long is stopped and reported.
    pub pending_timeout: Duration,
    /// Submissions per stage run when workers die (1 = no retry).
    pub max_attempts: u32,
    /// Extra environment for the workers (non-secret store settings such as
    /// `AWS_ENDPOINT_URL`); credentials belong in the workers' own environment.
    pub env: BTreeMap<String, String>,
    /// Where workers unpack tasks; `None` = their temporary folder.
    pub scratch: Option<PathBuf>,
}

impl RayOptions {
    pub fn new(address: &str, firecast_bin: PathBuf) -> Self {
        Self {
            address: normalize_address(address),
            firecast_bin,
            pending_timeout: Duration::from_secs(120),
            max_attempts: 3,
            env: BTreeMap::new(),
            scratch: None,
        }
    }
}

/// `127.0.0.1:8265` → `http://127.0.0.1:8265`; no trailing slash.
pub fn normalize_address(address: &str) -> String {
    let trimmed = address.trim().trim_end_matches('/');
    if trimmed.contains("://") {
        trimmed.to_string()
    } else {
        format!("http://{trimmed}")
    }
}

/// A thin client of the Jobs REST API.
#[derive(Debug, Clone)]
pub struct RayJobs {
    address: String,
    http: reqwest::blocking::Client,
}

/// A job's state as the API reports it.
#[derive(Debug, Clone)]
pub struct JobInfo {
    pub status: String,
    pub message: String,
    pub node: Option<String>,
    pub exit_code: Option<i64>,
}

impl JobInfo {
    pub fn is_terminal(&self) -> bool {
        matches!(self.status.as_str(), "SUCCEEDED" | "FAILED" | "STOPPED")
    }
}

impl RayJobs {
    /// Connect and check the cluster answers (`GET /api/version`); returns the client and
    /// the cluster's Ray version.
    pub fn connect(address: &str) -> Result<(Self, String), ExecutorError> {
        let address = normalize_address(address);
        let http = reqwest::blocking::Client::builder()
            .timeout(Duration::from_secs(30))
            .connect_timeout(Duration::from_secs(5))
            .build()
            .map_err(|e| ExecutorError::Ray(format!("cannot create the HTTP client: {e}")))?;
        let client = Self { address, http };
        let version = client.get("/api/version").map_err(|e| {
            ExecutorError::Ray(format!(
                "cannot reach the Ray dashboard at {} (start a cluster with `ray start --head`, and pass the dashboard address, port 8265 by default): {e}",
                client.address
            ))
        })?;
        let ray_version = version
            .get("ray_version")
            .and_then(Value::as_str)
            .unwrap_or("unknown")
            .to_string();
        Ok((client, ray_version))
    }

    pub fn address(&self) -> &str {
        &self.address
    }

    fn get(&self, path: &str) -> Result<Value, String> {
        let url = format!("{}{path}", self.address);
        let response = self.http.get(&url).send().map_err(|e| error_chain(&e))?;
        read_json(response)
    }

    fn post(&self, path: &str, body: &Value) -> Result<Value, String> {
        let url = format!("{}{path}", self.address);
        let response = self
            .http
            .post(&url)
            .header("content-type", "application/json")
            .body(body.to_string())
            .send()
            .map_err(|e| error_chain(&e))?;
        read_json(response)
    }

    /// `POST /api/jobs/`.
    pub fn submit(&self, body: &Value) -> Result<(), ExecutorError> {
        self.post("/api/jobs/", body)
            .map(|_| ())
            .map_err(|e| ExecutorError::Ray(format!("job submission to {} failed: {e}", self.address)))
    }

    /// `GET /api/jobs/<id>`.
    pub fn info(&self, id: &str) -> Result<JobInfo, ExecutorError> {
        let v = self
            .get(&format!("/api/jobs/{id}"))
            .map_err(|e| ExecutorError::Ray(format!("cannot read job {id}: {e}")))?;
        let text = |key: &str| v.get(key).and_then(Value::as_str).map(str::to_string);
        let node = v
            .get("driver_info")
            .and_then(|d| d.get("node_ip_address"))
            .and_then(Value::as_str)
            .map(str::to_string)
            .or_else(|| text("driver_node_id").map(|id| id.chars().take(12).collect()));
        Ok(JobInfo {
            status: text("status").unwrap_or_else(|| "UNKNOWN".into()),
            message: text("message").unwrap_or_default(),
            node,
            exit_code: v.get("driver_exit_code").and_then(Value::as_i64),
        })
    }

    /// `GET /api/jobs/<id>/logs` (empty when the API has none).
    pub fn logs(&self, id: &str) -> String {
        self.get(&format!("/api/jobs/{id}/logs"))
            .ok()
            .and_then(|v| v.get("logs").and_then(Value::as_str).map(str::to_string))
            .unwrap_or_default()
    }

    /// `POST /api/jobs/<id>/stop`.
    pub fn stop(&self, id: &str) -> Result<(), ExecutorError> {
        self.post(&format!("/api/jobs/{id}/stop"), &json!({}))
            .map(|_| ())
            .map_err(|e| ExecutorError::Ray(format!("cannot stop job {id}: {e}")))
    }
}

fn read_json(response: reqwest::blocking::Response) -> Result<Value, String> {
    let status = response.status();
    let text = response.text().map_err(|e| error_chain(&e))?;
    if !status.is_success() {
        let short: String = text.chars().take(600).collect();
        return Err(format!("HTTP {status}: {short}"));
    }
    serde_json::from_str(&text)
        .map_err(|e| format!("not JSON ({e}): {}", text.chars().take(200).collect::<String>()))
}

fn error_chain(e: &dyn std::error::Error) -> String {
    let mut out = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        out.push_str(": ");
        out.push_str(&cause.to_string());
        source = cause.source();
    }
    out
}

/// Runs each stage as a Ray job.
pub struct RayExecutor {
    jobs: RayJobs,
    ray_version: String,
    opts: RayOptions,
    store: Arc<ArtifactStore>,
    /// This driver's jobs Ray reports as running: a job queued behind them is waiting its
    /// turn, not stuck, so the pending timeout only counts while none runs.
    running: std::sync::atomic::AtomicUsize,
}

/// Counts a job as running from its first non-PENDING status until `wait` returns.
struct RunningJob<'a>(Option<&'a std::sync::atomic::AtomicUsize>);

impl<'a> RunningJob<'a> {
    fn start(running: &'a std::sync::atomic::AtomicUsize) -> Self {
        running.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        RunningJob(Some(running))
    }
}

impl Drop for RunningJob<'_> {
    fn drop(&mut self) {
        if let Some(running) = self.0 {
            running.fetch_sub(1, std::sync::atomic::Ordering::SeqCst);
        }
    }
}

impl RayExecutor {
    /// Check the cluster is reachable and the store is one workers can reach.
    pub fn connect(opts: RayOptions, store: Arc<ArtifactStore>) -> Result<Self, ExecutorError> {
        if store.url().starts_with("memory://") {
            return Err(ExecutorError::Config(
                "--executor ray needs an artifact store the workers share (s3://…, gs://…, az://…, or a folder on a shared file system); memory:// lives in this process only".into(),
            ));
        }
        if opts.max_attempts == 0 {
            return Err(ExecutorError::Config("Ray attempts must be at least 1".into()));
        }
        let (jobs, ray_version) = RayJobs::connect(&opts.address)?;
        Ok(Self {
            jobs,
            ray_version,
            opts,
            store,
            running: std::sync::atomic::AtomicUsize::new(0),
        })
    }

    pub fn ray_version(&self) -> &str {
        &self.ray_version
    }

    fn entrypoint(&self, task_key: &str, result_key: &str, shard: Option<Shard>) -> String {
        let bin = shell_quote(&self.opts.firecast_bin.to_string_lossy());
        let mut command = format!(
            "if [ ! -x {bin} ]; then echo \"firecast: the firecast binary {} is missing on worker $(hostname)\" >&2; exit 127; fi; exec {bin} --no-progress --store {} pipeline stage-exec --task {} --result {}",
            self.opts.firecast_bin.display(),
            shell_quote(self.store.url()),
            shell_quote(task_key),
            shell_quote(result_key),
        );
        if let Some(shard) = shard {
            command.push_str(&format!(" --shard {shard}"));
        }
        if let Some(scratch) = &self.opts.scratch {
            command.push_str(&format!(" --scratch {}", shell_quote(&scratch.to_string_lossy())));
        }
        command
    }

    fn submission(
        &self,
        job: &StageJob<'_>,
        id: &str,
        task_key: &str,
        result_key: &str,
        shard: Option<Shard>,
    ) -> Value {
        let mut body = json!({
            "entrypoint": self.entrypoint(task_key, result_key, shard),
            "submission_id": id,
            "metadata": {
                "firecast_pipeline": job.pipeline,
                "firecast_stage": job.stage.name,
                "firecast_run": job.run_id,
            },
            "entrypoint_num_cpus": job.stage.resources.cpus.unwrap_or(1.0),
        });
        if let Some(memory) = job.stage.resources.memory {
            body["entrypoint_memory"] = json!(memory);
        }
        if let Some(gpus) = job.stage.resources.gpus {
            body["entrypoint_num_gpus"] = json!(gpus);
        }
        if !self.opts.env.is_empty() {
            body["runtime_env"] = json!({ "env_vars": self.opts.env });
        }
        body
    }

    /// Poll until the job ends; stop it and fail if it stays pending too long.
    fn wait(&self, id: &str, job: &StageJob<'_>) -> Result<JobInfo, String> {
        use std::sync::atomic::Ordering;
        let submitted = Instant::now();
        // Time pending while none of this driver's other jobs ran.
        let mut stuck_since = Instant::now();
        let mut counted = RunningJob(None);
        let mut delay = Duration::from_millis(50);
        loop {
            let info = self.jobs.info(id).map_err(|e| e.to_string())?;
            if info.is_terminal() {
                return Ok(info);
            }
            if info.status != "PENDING" && counted.0.is_none() {
                counted = RunningJob::start(&self.running);
            }
            if info.status == "PENDING" && self.running.load(Ordering::SeqCst) > 0 {
                stuck_since = Instant::now();
            }
            if info.status == "PENDING" && stuck_since.elapsed() > self.opts.pending_timeout {
                let stopped = self.jobs.stop(id);
                let r = &job.stage.resources;
                return Err(format!(
                    "ray job {id} stayed PENDING for {:.0} s while no other job of this run was running (asked for {} CPU{}{}{}): the cluster lacks these resources or has no live worker node{}",
                    submitted.elapsed().as_secs_f64(),
                    r.cpus.unwrap_or(1.0),
                    if r.cpus.unwrap_or(1.0) == 1.0 { "" } else { "s" },
                    r.memory
                        .map(|m| format!(", {m} bytes of memory"))
                        .unwrap_or_default(),
                    r.gpus.map(|g| format!(", {g} GPU")).unwrap_or_default(),
                    match stopped {
                        Ok(()) => "; the job was stopped".to_string(),
                        Err(e) => format!("; stopping it failed too: {e}"),
                    }
                ));
            }
            std::thread::sleep(delay);
            delay = (delay * 2).min(Duration::from_millis(250));
        }
    }

    fn run_job(&self, job: &StageJob<'_>) -> Result<JobOutcome, JobFailure> {
        let fail = |message: String| JobFailure {
            message: format!("stage `{}`: {message}", job.stage.name),
            log: Vec::new(),
        };
        let task_key = driver::prepare(&self.store, job)
            .map_err(|e| fail(format!("cannot stage the inputs in {}: {e}", self.store.url())))?;
        let warnings = Mutex::new(Vec::new());
        let Some(count) = job.stage.shards else {
            let (result, worker) = self.run_task(job, &task_key, None, &warnings)?;
            let mut outcome = driver::collect(&self.store, job, result, worker)
                .map_err(|e| fail(format!("cannot bring back the outputs: {e}")))?;
            outcome.warnings.splice(0..0, into_inner(warnings));
            return Ok(outcome);
        };

        // Every shard is its own Ray job; Ray queues them onto free resources.
        let results: Vec<Result<(TaskResult, String), JobFailure>> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..count)
                .map(|index| {
                    let (task_key, warnings) = (&task_key, &warnings);
                    scope.spawn(move || self.run_task(job, task_key, Some(Shard { index, count }), warnings))
                })
                .collect();
            handles
                .into_iter()
                .map(|h| {
                    h.join()
                        .unwrap_or_else(|_| Err(fail("a shard's thread panicked".into())))
                })
                .collect()
        });
        if job.kind.sharded().is_none() {
            return Err(fail(format!("stage kind `{}` cannot be sharded", job.stage.kind)));
        }
        let parts_dir = job.root.join(".firecast/shards").join(job.run_id);
        firecast_fs::remove_path(&parts_dir);
        let mut outcome = JobOutcome::default();
        let mut parts = Vec::new();
        let mut workers = Vec::new();
        let merged = (|| {
            for (index, result) in results.into_iter().enumerate() {
                let (result, worker) = result?;
                let stored = result
                    .outputs
                    .get(SHARD_OUTPUT)
                    .ok_or_else(|| fail(format!("shard {index}/{count} returned no part")))?;
                let part = parts_dir.join(format!("{index}.part"));
                cas::get_path(&self.store, stored, &part)
                    .map_err(|e| fail(format!("cannot bring back shard {index}/{count}: {e}")))?;
                parts.push(part);
                outcome.log.push(format!("# shard {index}/{count} on {worker}"));
                outcome.log.extend(result.log);
                outcome.warnings.extend(result.warnings);
                outcome.events.extend(result.events);
                outcome.pending_artifacts.extend(result.pending_artifacts);
                workers.push(worker);
            }
            // The merge runs here with the stage's context: what it reports joins the shards'.
            let inputs: BTreeMap<String, Vec<PathBuf>> = job
                .inputs
                .iter()
                .map(|(name, list)| (name.clone(), list.iter().map(|i| i.local.clone()).collect()))
                .collect();
            let observer = RecordingObserver::default();
            let progress =
                indicatif::MultiProgress::with_draw_target(indicatif::ProgressDrawTarget::hidden());
            let (merged, report) = invoke_merge(
                job.kind,
                &Invocation {
                    stage: &job.stage.name,
                    run_id: job.run_id,
                    root: job.root,
                    params: &job.stage.params,
                    inputs: &inputs,
                    outputs: job.tmp_outputs,
                    final_outputs: job.final_outputs,
                    progress: &progress,
                    observer: &observer,
                    store: Some(self.store.as_ref()),
                    jobs: job.jobs,
                    shard: None,
                },
                &parts,
            );
            outcome.log.push(format!("# merged {count} shards on the driver"));
            outcome.log.extend(report.log);
            outcome.warnings.extend(report.warnings);
            outcome.pending_artifacts.extend(report.pending_artifacts);
            outcome.events.extend(observer.into_events());
            merged.map_err(|e| JobFailure {
                message: format!("stage `{}`: merging {count} shards failed: {e}", job.stage.name),
                log: std::mem::take(&mut outcome.log),
            })
        })();
        firecast_fs::remove_path(&parts_dir);
        merged?;
        outcome.warnings.splice(0..0, into_inner(warnings));
        outcome.worker = Some(format!("{count} shards: {}", workers.join("; ")));
        Ok(outcome)
    }

    /// One task on the cluster (the whole stage, or one shard) with its retries; returns the
    /// worker's successful result and where it ran.
    fn run_task(
        &self,
        job: &StageJob<'_>,
        task_key: &str,
        shard: Option<Shard>,
        warnings: &Mutex<Vec<String>>,
    ) -> Result<(TaskResult, String), JobFailure> {
        let what = match shard {
            Some(s) => format!("stage `{}` shard {s}", job.stage.name),
            None => format!("stage `{}`", job.stage.name),
        };
        let fail = |message: String, log: Vec<String>| JobFailure {
            message: format!("{what}: {message}"),
            log,
        };
        let log_hint = format!(".firecast/logs/{}.log", job.run_id);
        for attempt in 1..=self.opts.max_attempts {
            let (id, result_key) = match shard {
                None => (
                    format!("firecast-{}-{attempt}", job.run_id),
                    result_key(job.run_id, attempt),
                ),
                Some(s) => (
                    format!("firecast-{}-s{}-{attempt}", job.run_id, s.index),
                    format!(
                        "remote/{}/shard-{}/attempt-{attempt}/result.json",
                        job.run_id, s.index
                    ),
                ),
            };
            self.jobs
                .submit(&self.submission(job, &id, task_key, &result_key, shard))
                .map_err(|e| fail(e.to_string(), Vec::new()))?;
            let info = match self.wait(&id, job) {
                Ok(info) => info,
                Err(message) => return Err(fail(message, Vec::new())),
            };
            let result: Option<TaskResult> = get_json(&self.store, &result_key)
                .map_err(|e| fail(format!("cannot read the result of ray job {id}: {e}"), Vec::new()))?;
            let node = info.node.clone().unwrap_or_else(|| "unknown node".into());
            match result {
                Some(result) => {
                    let worker = format!("{} (ray job {id}, node {node})", result.worker);
                    if let Some(error) = result.error.clone() {
                        let mut log = result.log.clone();
                        log.push(format!("# ray job {id} log:"));
                        log.extend(self.jobs.logs(&id).lines().map(str::to_string));
                        return Err(fail(
                            format!("failed on worker {worker}: {error} (log: {log_hint})"),
                            log,
                        ));
                    }
                    if info.status != "SUCCEEDED" {
                        return Err(fail(
                            format!(
                                "ray job {id} ended {} after writing its result: {}",
                                info.status,
                                first_line(&info.message)
                            ),
                            result.log,
                        ));
                    }
                    return Ok((result, worker));
                }
                None => {
                    let logs = self.jobs.logs(&id);
                    let lines: Vec<String> = logs.lines().map(str::to_string).collect();
                    // The last line the task printed (not Ray's own job-manager lines).
                    let tail = lines
                        .iter()
                        .rev()
                        .find(|l| {
                            !l.trim().is_empty()
                                && !l.starts_with("Running entrypoint for job")
                                && !l.contains(" INFO job_manager.py")
                        })
                        .cloned()
                        .unwrap_or_default();
                    let why = format!(
                        "ray job {id} on node {node} ended {} without a result ({}){}",
                        info.status,
                        first_line(&info.message),
                        if tail.is_empty() {
                            String::new()
                        } else {
                            format!("; last log line: {tail}")
                        }
                    );
                    // Killed (a signal, or no exit code when the node died): worth another
                    // try. An ordinary exit without a result (127: no binary; 2: firecast could
                    // not read the task or write the result, e.g. a store the worker cannot
                    // write) would fail the same way again.
                    let lost = !matches!(info.exit_code, Some(code) if (0..128).contains(&code));
                    if info.status == "FAILED" && lost && attempt < self.opts.max_attempts {
                        warnings.lock().unwrap_or_else(|e| e.into_inner()).push(format!(
                            "{what}: attempt {attempt} of {} lost its worker, retried: {why}",
                            self.opts.max_attempts
                        ));
                        continue;
                    }
                    let mut log = vec![format!("# ray job {id} log:")];
                    log.extend(lines);
                    return Err(fail(
                        format!(
                            "{why}{} (log: {log_hint})",
                            if attempt > 1 {
                                format!(" after {attempt} attempts")
                            } else {
                                String::new()
                            }
                        ),
                        log,
                    ));
                }
            }
        }
        Err(fail("no attempt was made".into(), Vec::new()))
    }
}

/// The first line of Ray's job message, without the log excerpt it appends.
fn first_line(text: &str) -> &str {
    let line = text.lines().next().unwrap_or("").trim();
    let line = line.split(", last available logs").next().unwrap_or(line);
    if line.is_empty() {
        "no message"
    } else {
        line.trim_end_matches(',')
    }
}

fn into_inner<T>(m: Mutex<Vec<T>>) -> Vec<T> {
    m.into_inner().unwrap_or_else(|e| e.into_inner())
}

impl StageExecutor for RayExecutor {
    fn describe(&self) -> String {
        format!("Ray {} at {}", self.ray_version, self.jobs.address())
    }

    fn run(&self, job: &StageJob<'_>) -> Result<JobOutcome, JobFailure> {
        self.run_job(job)
    }
}

/// `'…'` with embedded quotes escaped, for a POSIX shell.
pub fn shell_quote(text: &str) -> String {
    format!("'{}'", text.replace('\'', "'\\''"))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn addresses_and_quoting() {
        assert_eq!(normalize_address("127.0.0.1:8265/"), "http://127.0.0.1:8265");
        assert_eq!(
            normalize_address("https://ray.example:443"),
            "https://ray.example:443"
        );
        assert_eq!(shell_quote("a b'c"), "'a b'\\''c'");
    }

    #[test]
    fn an_unreachable_cluster_is_named() {
        // Port 9 (discard) on loopback: nothing listens there in a test sandbox.
        let err = RayJobs::connect("127.0.0.1:9").unwrap_err().to_string();
        assert!(
            err.contains("cannot reach the Ray dashboard at http://127.0.0.1:9"),
            "{err}"
        );
    }
}
