//! Background jobs: the threat pipeline for a place and day, run as `firecast pipeline run`
//! (a child process of this binary with its arguments as a list — no shell), so a job from
//! the page goes through the same engine, cache, lockfile and registry as the CLI. One job
//! runs at a time (the places share the trained forecaster and agent); the queue is bounded.
//!
//! A finished job's report files — the `report` stage's outputs, whose paths the pipeline
//! names per place and day (`${lat}`, `${lon}`, `${date}`), expanded here with the same `-S`
//! values the child got — are copied into `.firecast/serve/jobs/<id>/` (written to a
//! temporary folder renamed into place, so a half-copied report is never served).

use std::collections::{HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Condvar, Mutex};

use serde::Serialize;

use crate::error::{ApiError, Code};

/// The report files a job publishes, by the names the API serves them under.
pub const REPORT_FILES: [(&str, &str); 4] = [
    ("html", "report.html"),
    ("pdf", "report.pdf"),
    ("json", "report.json"),
    ("geojson", "report.geojson"),
];

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum JobStatus {
    Queued,
    Running,
    Succeeded,
    Failed,
}

/// A job as the page sees it.
#[derive(Debug, Clone, Serialize)]
pub struct Job {
    pub id: String,
    pub lat: f64,
    pub lon: f64,
    pub date: String,
    pub status: JobStatus,
    /// Seconds since the Unix epoch.
    pub queued_at: f64,
    pub started_at: Option<f64>,
    pub ended_at: Option<f64>,
    pub stages_total: usize,
    pub stages_done: usize,
    /// The stage running now (from the child's log).
    pub current: Option<String>,
    pub error: Option<String>,
    pub log_tail: String,
    /// URLs of the report's files once the job succeeded.
    pub files: HashMap<String, String>,
}

/// Where jobs run and what they run.
#[derive(Debug, Clone)]
pub struct JobSettings {
    pub root: PathBuf,
    pub firecast_bin: PathBuf,
    /// The threat pipeline, relative to the root.
    pub pipeline: PathBuf,
    /// Global flags passed to the child (`--registry`, `--store`).
    pub global_args: Vec<String>,
    /// Queued jobs at most (the running one not counted).
    pub max_queued: usize,
}

struct Inner {
    jobs: HashMap<String, Job>,
    queue: VecDeque<String>,
}

/// The job queue and its worker thread.
#[derive(Clone)]
pub struct Jobs {
    settings: Arc<JobSettings>,
    runs: Arc<crate::runs::Runs>,
    inner: Arc<(Mutex<Inner>, Condvar)>,
}

fn now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// The id of a place and day: the same place and day finds the same job.
pub fn job_id(lat: f64, lon: f64, date: &str) -> String {
    let key = format!("threat:{lat:.6},{lon:.6},{date}");
    blake3::hash(key.as_bytes()).to_hex()[..16].to_string()
}

impl Jobs {
    /// Starts the worker thread.
    pub fn start(settings: JobSettings, runs: Arc<crate::runs::Runs>) -> Self {
        let jobs = Self {
            settings: Arc::new(settings),
            runs,
            inner: Arc::new((
                Mutex::new(Inner {
                    jobs: HashMap::new(),
                    queue: VecDeque::new(),
                }),
                Condvar::new(),
            )),
        };
        let worker = jobs.clone();
        std::thread::Builder::new()
            .name("firecast-serve-jobs".into())
            .spawn(move || worker.work())
            .ok();
        jobs
    }

    /// Whether the threat pipeline exists.
    pub fn available(&self) -> bool {
        self.settings.root.join(&self.settings.pipeline).is_file()
    }

    fn stages_total(&self) -> usize {
        let path = self.settings.root.join(&self.settings.pipeline);
        std::fs::read_to_string(path)
            .ok()
            .and_then(|t| serde_yaml_ng::from_str::<serde_yaml_ng::Value>(&t).ok())
            .and_then(|d| {
                d.get("stages")
                    .and_then(serde_yaml_ng::Value::as_mapping)
                    .map(|m| m.len())
            })
            .unwrap_or(0)
    }

    fn job_dir(&self, id: &str) -> PathBuf {
        self.settings.root.join(".firecast/serve/jobs").join(id)
    }

    /// Queues the threat pipeline for a checked place and day, or answers the job that
    /// already has them (a failed one is queued again).
    pub fn submit(&self, lat: f64, lon: f64, date: &str) -> Result<Job, ApiError> {
        if !self.available() {
            return Err(ApiError::new(
                Code::NoModel,
                format!("no threat pipeline at {}", self.settings.pipeline.display()),
            ));
        }
        let id = job_id(lat, lon, date);
        let (lock, cv) = &*self.inner;
        let mut inner = lock.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(job) = inner.jobs.get(&id)
            && job.status != JobStatus::Failed
        {
            return Ok(job.clone());
        }
        if inner.queue.len() >= self.settings.max_queued {
            return Err(ApiError::new(
                Code::Busy,
                format!(
                    "{} reports are already waiting; try again when one has finished",
                    inner.queue.len()
                ),
            ));
        }
        let job = Job {
            id: id.clone(),
            lat,
            lon,
            date: date.to_string(),
            status: JobStatus::Queued,
            queued_at: now(),
            started_at: None,
            ended_at: None,
            stages_total: self.stages_total(),
            stages_done: 0,
            current: None,
            error: None,
            log_tail: String::new(),
            files: HashMap::new(),
        };
        inner.jobs.insert(id.clone(), job.clone());
        inner.queue.push_back(id);
        cv.notify_all();
        Ok(job)
    }

    pub fn get(&self, id: &str) -> Result<Job, ApiError> {
        let (lock, _) = &*self.inner;
        let inner = lock.lock().unwrap_or_else(|e| e.into_inner());
        inner.jobs.get(id).cloned().ok_or_else(|| {
            ApiError::not_found(format!("no job `{}`", id.chars().take(40).collect::<String>()))
        })
    }

    /// A finished job's report file.
    pub fn file(&self, id: &str, name: &str) -> Result<PathBuf, ApiError> {
        let job = self.get(id)?;
        if job.status != JobStatus::Succeeded {
            return Err(ApiError::not_found(format!(
                "job {id} has no report yet ({:?})",
                job.status
            )));
        }
        if !REPORT_FILES.iter().any(|(_, f)| *f == name) {
            return Err(ApiError::not_found(format!("a job has no file `{name}`")));
        }
        let path = self.job_dir(id).join(name);
        if !path.is_file() {
            return Err(ApiError::not_found(format!("job {id}: {name} was not written")));
        }
        Ok(path)
    }

    fn update(&self, id: &str, f: impl FnOnce(&mut Job)) {
        let (lock, _) = &*self.inner;
        let mut inner = lock.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(job) = inner.jobs.get_mut(id) {
            f(job);
        }
    }

    fn work(&self) {
        loop {
            let id = {
                let (lock, cv) = &*self.inner;
                let mut inner = lock.lock().unwrap_or_else(|e| e.into_inner());
                loop {
                    if let Some(id) = inner.queue.pop_front() {
                        break id;
                    }
                    inner = cv.wait(inner).unwrap_or_else(|e| e.into_inner());
                }
            };
            let Ok(job) = self.get(&id) else { continue };
            self.update(&id, |j| {
                j.status = JobStatus::Running;
                j.started_at = Some(now());
            });
            let result = self.run(&job);
            self.update(&id, |j| {
                j.ended_at = Some(now());
                match result {
                    Ok(files) => {
                        j.status = JobStatus::Succeeded;
                        j.stages_done = j.stages_total;
                        j.current = None;
                        j.files = files;
                    }
                    Err(e) => {
                        j.status = JobStatus::Failed;
                        j.error = Some(e);
                    }
                }
            });
        }
    }

    /// Runs the pipeline, following its log for progress; then publishes the report files.
    fn run(&self, job: &Job) -> Result<HashMap<String, String>, String> {
        let s = &self.settings;
        let dir = self.job_dir(&job.id);
        std::fs::create_dir_all(dir.parent().unwrap_or(&dir))
            .map_err(|e| format!("{}: {e}", dir.display()))?;
        let log_path = self
            .settings
            .root
            .join(".firecast/serve/jobs")
            .join(format!("{}.log", job.id));
        let log = std::fs::File::create(&log_path).map_err(|e| format!("{}: {e}", log_path.display()))?;
        let log_err = log.try_clone().map_err(|e| e.to_string())?;
        let mut cmd = Command::new(&s.firecast_bin);
        cmd.current_dir(&s.root)
            .arg("-C")
            .arg(&s.root)
            .args(&s.global_args)
            .arg("--no-progress")
            .args(["pipeline", "run"])
            .arg(&s.pipeline);
        for set in overrides(job) {
            cmd.arg("-S").arg(set);
        }
        cmd.stdin(Stdio::null())
            .stdout(Stdio::from(log))
            .stderr(Stdio::from(log_err));
        let mut child = cmd
            .spawn()
            .map_err(|e| format!("cannot start {}: {e}", s.firecast_bin.display()))?;
        let status = loop {
            match child.try_wait() {
                Ok(Some(status)) => break status,
                Ok(None) => {}
                Err(e) => return Err(format!("waiting for the pipeline: {e}")),
            }
            self.follow(&job.id, &log_path);
            std::thread::sleep(std::time::Duration::from_millis(250));
        };
        self.follow(&job.id, &log_path);
        if !status.success() {
            let tail = tail(&log_path, 20);
            let reason = tail
                .lines()
                .rev()
                .find(|l| l.starts_with("error"))
                .unwrap_or("the threat pipeline failed")
                .to_string();
            return Err(reason);
        }
        self.publish(job, &dir)
    }

    /// Progress from the registry (the child's stage runs of this pipeline since the job
    /// started) and the tail of its log.
    fn follow(&self, id: &str, log_path: &Path) {
        let text = tail(log_path, 40);
        let started = self.get(id).ok().and_then(|j| j.started_at).unwrap_or(0.0);
        let since = timestamp(started);
        let name = self
            .settings
            .pipeline
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("threat")
            .to_string();
        let (mut done, mut current) = (0, Vec::new());
        if let Ok(rows) = self.runs.all() {
            for r in rows.iter().filter(|r| r.pipeline == name && r.stage.is_some()) {
                if normalise(&r.started_at).as_str() < since.as_str() {
                    continue;
                }
                if r.status == "running" {
                    current.extend(r.stage.clone());
                } else {
                    done += 1;
                }
            }
        }
        self.update(id, |j| {
            j.log_tail = text;
            j.stages_done = done.min(j.stages_total);
            j.current = (!current.is_empty()).then(|| current.join(", "));
        });
    }

    /// Copies the report's outputs (the `report` stage's paths in the pipeline, for the job's
    /// place and day) into the job's folder through a temporary folder.
    fn publish(&self, job: &Job, dir: &Path) -> Result<HashMap<String, String>, String> {
        let outputs = self.report_outputs(job)?;
        // The staging folder is removed when dropped unpublished (any error below).
        let staged = firecast_fs::TempPath::dir(dir).map_err(|e| e.to_string())?;
        let tmp = staged.path();
        let id = dir
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default()
            .to_string();
        let mut files = HashMap::new();
        for (key, name) in REPORT_FILES {
            let Some(src) = outputs.get(key) else { continue };
            let src = self.settings.root.join(src);
            if src.is_file() {
                std::fs::copy(&src, tmp.join(name)).map_err(|e| format!("copying {}: {e}", src.display()))?;
                files.insert(key.to_string(), format!("/api/jobs/{id}/files/{name}"));
            }
        }
        staged
            .publish()
            .map_err(|e| format!("{}: {}", dir.display(), e.source))?;
        if files.is_empty() {
            return Err("the pipeline finished but wrote no report".into());
        }
        Ok(files)
    }

    /// The outputs of the threat pipeline's report stage (the stage named `report`, else the
    /// first of kind `report`) for the job's place and day: name → path. The pipeline is
    /// expanded as the child expanded it (same file, same `-S` values), so paths built from
    /// `${lat}`, `${lon}` and `${date}` are the ones it wrote.
    fn report_outputs(&self, job: &Job) -> Result<HashMap<String, String>, String> {
        let sets = overrides(job)
            .iter()
            .map(|s| firecast_pipeline::Override::parse(s))
            .collect::<Result<Vec<_>, _>>()?;
        let pipeline = firecast_pipeline::spec::load(&self.settings.root, &self.settings.pipeline, &sets)
            .map_err(|e| format!("reading the pipeline: {e}"))?;
        let stage = pipeline
            .stages
            .iter()
            .find(|s| s.name == "report")
            .or_else(|| pipeline.stages.iter().find(|s| s.uses == "report"))
            .ok_or_else(|| format!("{} has no report stage", self.settings.pipeline.display()))?;
        let mut out = HashMap::new();
        for (k, v) in &stage.outputs {
            let path = v
                .as_str()
                .or_else(|| v.get("path").and_then(serde_yaml_ng::Value::as_str));
            if let Some(p) = path {
                out.insert(k.clone(), p.to_string());
            }
        }
        Ok(out)
    }
}

/// The `-S` values of a job's pipeline run.
fn overrides(job: &Job) -> [String; 3] {
    [
        format!("lat={}", job.lat),
        format!("lon={}", job.lon),
        format!("date={}", job.date),
    ]
}

/// Seconds since the epoch as the registry writes times (UTC, `YYYY-MM-DD HH:MM:SS`).
fn timestamp(secs: f64) -> String {
    chrono::DateTime::from_timestamp(secs.floor() as i64, 0)
        .map(|t| t.format("%Y-%m-%d %H:%M:%S").to_string())
        .unwrap_or_default()
}

/// A registry time cut to seconds with a space between date and time.
fn normalise(t: &str) -> String {
    t.chars()
        .take(19)
        .map(|c| if c == 'T' { ' ' } else { c })
        .collect()
}

/// The last `n` lines of a file.
fn tail(path: &Path, n: usize) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(n)..].join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_compare_as_the_registry_writes_them() {
        assert_eq!(timestamp(0.0), "1970-01-01 00:00:00");
        assert_eq!(normalise("2026-11-27T15:10:00.123456"), "2026-11-27 15:10:00");
    }

    #[test]
    fn one_job_per_place_and_day() {
        assert_eq!(
            job_id(39.3, -107.4, "2019-08-01"),
            job_id(39.3, -107.4, "2019-08-01")
        );
        assert_ne!(
            job_id(39.3, -107.4, "2019-08-01"),
            job_id(39.3, -107.5, "2019-08-01")
        );
    }
}
