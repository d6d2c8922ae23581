//! The load itself of `firecast bench serve`: a bounded load test of the web app on loopback. It starts a
//! `firecast serve` process (so the server's memory is its own), fills a registry with
//! synthetic runs, then measures
//! 1. the runs page with that many runs in the registry (first answer, then warm),
//! 2. `speed_clients` live fires played at the default 30 frames a second each (the frame
//!    rate each client gets),
//! 3. `clients` live fires for `seconds` while `http_clients` request the runs table at
//!    `http_rate` requests a second between them (0: as fast as they can): frame lateness
//!    against each fire's 30 frames-a-second schedule, first-frame latency (of the fires
//!    started while the others stream — each client starts its next fire when one ends — and
//!    apart, of the opening burst of `clients` fires asked for at the same instant),
//!    requests a second, errors, and the server's peak memory.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use futures::StreamExt;
use serde::Serialize;
use tokio_tungstenite::tungstenite::Message;

/// What to load the server with.
#[derive(Debug, Clone)]
pub struct BenchConfig {
    pub firecast_bin: PathBuf,
    /// The project whose GRIDMET data the fires use.
    pub root: PathBuf,
    pub gridmet: PathBuf,
    /// A place and day inside the data.
    pub lat: f64,
    pub lon: f64,
    pub date: String,
    pub runs: usize,
    pub clients: usize,
    pub speed_clients: usize,
    pub http_clients: usize,
    /// Requests a second offered by the runs-table clients together (0: unpaced).
    pub http_rate: f64,
    pub seconds: f64,
    pub agent: String,
}

/// Percentiles of a sample, milliseconds.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Latency {
    pub count: usize,
    pub p50_ms: f64,
    pub p99_ms: f64,
    pub max_ms: f64,
}

impl Latency {
    fn of(mut v: Vec<f64>) -> Self {
        if v.is_empty() {
            return Self::default();
        }
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        Self {
            count: v.len(),
            p50_ms: at(0.5),
            p99_ms: at(0.99),
            max_ms: at(1.0),
        }
    }
}

/// The measurements.
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    pub runs_in_registry: usize,
    pub runs_page_first_ms: f64,
    pub runs_page_warm: Latency,
    pub speed_clients: usize,
    /// Frames a second each client received (min and median over clients).
    pub speed_fps_min: f64,
    pub speed_fps_median: f64,
    pub clients: usize,
    pub seconds: f64,
    pub frames: u64,
    pub fires_started: u64,
    /// Fires started while the others stream.
    pub first_frame: Latency,
    /// The opening burst: `clients` fires asked for at the same instant.
    pub first_frame_burst: Latency,
    /// How late each frame arrived against its fire's 30 frames-a-second schedule.
    pub frame_lateness: Latency,
    pub http_requests: u64,
    pub http_per_second: f64,
    pub http_latency: Latency,
    pub errors: u64,
    pub error_examples: Vec<String>,
    pub server_peak_rss_mib: f64,
    pub server_rss_after_mib: f64,
}

struct ServerProcess {
    child: Child,
    addr: String,
}

impl Drop for ServerProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `VmHWM` and `VmRSS` of a process, MiB.
fn memory_mib(pid: u32) -> (f64, f64) {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    let field = |name: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
            .map_or(0.0, |kb| kb / 1024.0)
    };
    (field("VmHWM:"), field("VmRSS:"))
}

/// A registry holding `n` synthetic finished stage runs of four pipelines.
fn fill_registry(path: &Path, n: usize) -> Result<(), String> {
    let reg = firecast_registry::Registry::open(path).map_err(|e| e.to_string())?;
    let t0 = chrono::DateTime::from_timestamp(1_790_000_000, 0).unwrap_or_default();
    let kinds = ["sim.episodes", "rl.train", "forecast.experiment", "data.windows"];
    let time = |t: chrono::DateTime<chrono::Utc>| t.format("%Y-%m-%d %H:%M:%S%.3f").to_string();
    let rows: Vec<firecast_registry::RunRow> = (0..n)
        .map(|i| {
            let started = t0 + chrono::Duration::seconds(i as i64);
            let secs = 1.0 + (i % 5000) as f64 / 1000.0;
            firecast_registry::RunRow {
                run_id: format!("bench{i:06}"),
                pipeline_run_id: Some(format!("benchpipe{:05}", i / 8)),
                parent_run_id: None,
                pipeline: format!("bench-{}", i % 4),
                stage: Some(format!("stage{}", i % 8)),
                kind: kinds[i % kinds.len()].to_string(),
                kind_version: Some(1),
                params: serde_json::json!({"seed": i % 10, "runs": 20 + i % 7, "name": format!("bench-{}", i % 13)}),
                status: if i % 17 == 0 { "failed" } else { "succeeded" }.to_string(),
                started_at: time(started),
                ended_at: Some(time(started + chrono::Duration::milliseconds((secs * 1000.0) as i64))),
                duration_secs: Some(secs),
                git_commit: None,
                cache_key: None,
                error: (i % 17 == 0).then(|| "synthetic failure".to_string()),
            }
        })
        .collect();
    reg.import_runs(&rows).map_err(|e| e.to_string())
}

/// Runs the load test; `say` prints progress lines.
pub fn run(cfg: &BenchConfig, say: &dyn Fn(&str)) -> Result<BenchReport, String> {
    let dir = std::env::temp_dir().join(format!("firecast-bench-serve-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let registry = dir.join("registry.duckdb");
    let _ = std::fs::remove_file(&registry);
    say(&format!("filling a registry with {} runs …", cfg.runs));
    fill_registry(&registry, cfg.runs)?;
    let mut child = Command::new(&cfg.firecast_bin)
        .arg("-C")
        .arg(&cfg.root)
        .arg("--registry")
        .arg(&registry)
        .args([
            "--json",
            "--no-progress",
            "serve",
            "--addr",
            "127.0.0.1:0",
            "--gridmet",
        ])
        .arg(&cfg.gridmet)
        .args(["--max-fires", &(cfg.clients + cfg.speed_clients + 16).to_string()])
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("cannot start {}: {e}", cfg.firecast_bin.display()))?;
    let mut line = String::new();
    {
        use std::io::BufRead;
        let stdout = child.stdout.take().ok_or("no stdout")?;
        std::io::BufReader::new(stdout)
            .read_line(&mut line)
            .map_err(|e| e.to_string())?;
    }
    let ready: serde_json::Value =
        serde_json::from_str(&line).map_err(|e| format!("serve printed `{line}`: {e}"))?;
    let server = ServerProcess {
        addr: ready["addr"].as_str().unwrap_or_default().to_string(),
        child,
    };
    let pid = server.child.id();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| e.to_string())?;
    let report = runtime.block_on(load(cfg, &server.addr, pid, say));
    drop(server);
    let _ = std::fs::remove_dir_all(&dir);
    report
}

async fn load(cfg: &BenchConfig, addr: &str, pid: u32, say: &dyn Fn(&str)) -> Result<BenchReport, String> {
    let http = reqwest::Client::builder()
        .pool_max_idle_per_host(64)
        .timeout(Duration::from_secs(30))
        .build()
        .map_err(|e| e.to_string())?;
    let base = format!("http://{addr}");
    // 1. The runs page.
    let t = Instant::now();
    let first = http
        .get(format!("{base}/api/runs?limit=100"))
        .send()
        .await
        .map_err(|e| e.to_string())?;
    let body: serde_json::Value = json_of(first).await?;
    let runs_page_first_ms = t.elapsed().as_secs_f64() * 1e3;
    if body["total"].as_u64() != Some(cfg.runs as u64) {
        return Err(format!(
            "the runs page says {} runs, expected {}",
            body["total"], cfg.runs
        ));
    }
    let mut warm = Vec::new();
    for _ in 0..50 {
        let t = Instant::now();
        http.get(format!("{base}/api/runs?limit=100&sort=duration_secs&q=rl"))
            .send()
            .await
            .and_then(reqwest::Response::error_for_status)
            .map_err(|e| e.to_string())?
            .bytes()
            .await
            .map_err(|e| e.to_string())?;
        warm.push(t.elapsed().as_secs_f64() * 1e3);
    }
    say(&format!(
        "runs page with {} runs: first {runs_page_first_ms:.0} ms",
        cfg.runs
    ));
    let env = http
        .post(format!(
            "{base}/api/createEnvironment?lat={}&lon={}&date={}",
            cfg.lat, cfg.lon, cfg.date
        ))
        .send()
        .await
        .map_err(|e| e.to_string())?;
    let env = json_of(env).await?;
    let id = env["id"]
        .as_str()
        .ok_or_else(|| format!("createEnvironment answered {env}"))?
        .to_string();
    let ws_url = format!("ws://{addr}/api/environments/{id}/simulate?agent={}", cfg.agent);

    // 2. Frame rate at the default speed.
    say(&format!(
        "{} clients at 30 frames a second for 10 s …",
        cfg.speed_clients
    ));
    let stats = Arc::new(Stats::default());
    let deadline = Instant::now() + Duration::from_secs(10);
    let tasks: Vec<_> = (0..cfg.speed_clients)
        .map(|k| tokio::spawn(fire_client(ws_url.clone(), k as u64, deadline, stats.clone())))
        .collect();
    let mut fps = Vec::new();
    for t in tasks {
        let (frames, secs) = t.await.map_err(|e| e.to_string())?;
        fps.push(frames as f64 / secs.max(1e-9));
    }
    fps.sort_by(f64::total_cmp);
    let speed_fps_min = fps.first().copied().unwrap_or(0.0);
    let speed_fps_median = fps.get(fps.len() / 2).copied().unwrap_or(0.0);

    // 3. Many fires and the runs table at once.
    say(&format!(
        "{} fires and {} clients on the runs table for {:.0} s …",
        cfg.clients, cfg.http_clients, cfg.seconds
    ));
    let stats = Arc::new(Stats::default());
    let deadline = Instant::now() + Duration::from_secs_f64(cfg.seconds);
    let fires: Vec<_> = (0..cfg.clients)
        .map(|k| {
            tokio::spawn(fire_client(
                ws_url.clone(),
                1000 + k as u64,
                deadline,
                stats.clone(),
            ))
        })
        .collect();
    let started = Instant::now();
    let pages: Vec<_> = (0..cfg.http_clients)
        .map(|_| {
            tokio::spawn(page_client(
                http.clone(),
                format!("{base}/api/runs?limit=50"),
                cfg.http_rate / cfg.http_clients.max(1) as f64,
                deadline,
                stats.clone(),
            ))
        })
        .collect();
    for t in fires {
        let _ = t.await;
    }
    for t in pages {
        let _ = t.await;
    }
    let elapsed = started.elapsed().as_secs_f64();
    let (peak, after) = memory_mib(pid);
    let lock = |m: &std::sync::Mutex<Vec<f64>>| m.lock().map(|v| v.clone()).unwrap_or_default();
    let requests = stats.requests.load(Ordering::Relaxed);
    Ok(BenchReport {
        runs_in_registry: cfg.runs,
        runs_page_first_ms,
        runs_page_warm: Latency::of(warm),
        speed_clients: cfg.speed_clients,
        speed_fps_min,
        speed_fps_median,
        clients: cfg.clients,
        seconds: cfg.seconds,
        frames: stats.frames.load(Ordering::Relaxed),
        fires_started: stats.fires.load(Ordering::Relaxed),
        first_frame: Latency::of(lock(&stats.first_frame)),
        first_frame_burst: Latency::of(lock(&stats.first_frame_burst)),
        frame_lateness: Latency::of(lock(&stats.lateness)),
        http_requests: requests,
        http_per_second: requests as f64 / elapsed,
        http_latency: Latency::of(lock(&stats.http)),
        errors: stats.errors.load(Ordering::Relaxed),
        error_examples: stats.examples.lock().map(|v| v.clone()).unwrap_or_default(),
        server_peak_rss_mib: peak,
        server_rss_after_mib: after,
    })
}

async fn json_of(r: reqwest::Response) -> Result<serde_json::Value, String> {
    let bytes = r.bytes().await.map_err(|e| e.to_string())?;
    serde_json::from_slice(&bytes).map_err(|e| format!("not JSON ({e}): {}", String::from_utf8_lossy(&bytes)))
}

#[derive(Default)]
struct Stats {
    frames: AtomicU64,
    fires: AtomicU64,
    requests: AtomicU64,
    errors: AtomicU64,
    first_frame: std::sync::Mutex<Vec<f64>>,
    first_frame_burst: std::sync::Mutex<Vec<f64>>,
    lateness: std::sync::Mutex<Vec<f64>>,
    http: std::sync::Mutex<Vec<f64>>,
    examples: std::sync::Mutex<Vec<String>>,
}

impl Stats {
    fn error(&self, e: String) {
        self.errors.fetch_add(1, Ordering::Relaxed);
        if let Ok(mut v) = self.examples.lock()
            && v.len() < 5
        {
            v.push(e);
        }
    }
}

/// Plays fires until the deadline (a fire that ends is followed by the next seed); returns
/// frames received and seconds spent.
async fn fire_client(url: String, first_seed: u64, deadline: Instant, stats: Arc<Stats>) -> (u64, f64) {
    let period = 1.0 / 30.0;
    let began = Instant::now();
    let mut frames = 0u64;
    let mut seed = first_seed;
    let mut opening = true;
    'fires: while Instant::now() < deadline {
        let asked = Instant::now();
        let burst = std::mem::take(&mut opening);
        let mut ws = match tokio_tungstenite::connect_async(format!("{url}&seed={}", seed % 1_000_000)).await
        {
            Ok((ws, _)) => ws,
            Err(e) => {
                stats.error(format!("connect: {e}"));
                tokio::time::sleep(Duration::from_millis(100)).await;
                continue;
            }
        };
        stats.fires.fetch_add(1, Ordering::Relaxed);
        seed += 7919;
        let mut first: Option<Instant> = None;
        let mut k = 0u32;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                let _ = ws.close(None).await;
                break 'fires;
            }
            match tokio::time::timeout(left, ws.next()).await {
                Err(_) => {
                    let _ = ws.close(None).await;
                    break 'fires;
                }
                Ok(None) => continue 'fires,
                Ok(Some(Err(e))) => {
                    stats.error(format!("frame: {e}"));
                    continue 'fires;
                }
                Ok(Some(Ok(Message::Binary(_)))) => {
                    let now = Instant::now();
                    frames += 1;
                    stats.frames.fetch_add(1, Ordering::Relaxed);
                    match first {
                        None => {
                            first = Some(now);
                            let sample = if burst {
                                &stats.first_frame_burst
                            } else {
                                &stats.first_frame
                            };
                            if let Ok(mut v) = sample.lock() {
                                v.push((now - asked).as_secs_f64() * 1e3);
                            }
                        }
                        Some(f) => {
                            let due = f64::from(k) * period;
                            let late = ((now - f).as_secs_f64() - due).max(0.0) * 1e3;
                            if let Ok(mut v) = stats.lateness.lock() {
                                v.push(late);
                            }
                        }
                    }
                    k += 1;
                }
                Ok(Some(Ok(Message::Text(t)))) => {
                    if t.as_str().contains("\"error\"") {
                        stats.error(format!("server: {t}"));
                    }
                }
                Ok(Some(Ok(Message::Close(_)))) => continue 'fires,
                Ok(Some(Ok(_))) => {}
            }
        }
    }
    (frames, began.elapsed().as_secs_f64())
}

/// Requests the page until the deadline, `per_second` a second (0: back to back).
async fn page_client(
    http: reqwest::Client,
    url: String,
    per_second: f64,
    deadline: Instant,
    stats: Arc<Stats>,
) {
    let began = Instant::now();
    let mut sent = 0u32;
    while Instant::now() < deadline {
        if per_second > 0.0 {
            let due = began + Duration::from_secs_f64(f64::from(sent) / per_second);
            tokio::time::sleep_until(due.into()).await;
        }
        sent += 1;
        let t = Instant::now();
        match http
            .get(&url)
            .send()
            .await
            .and_then(reqwest::Response::error_for_status)
        {
            Ok(r) => match r.bytes().await {
                Ok(_) => {
                    stats.requests.fetch_add(1, Ordering::Relaxed);
                    if let Ok(mut v) = stats.http.lock() {
                        v.push(t.elapsed().as_secs_f64() * 1e3);
                    }
                }
                Err(e) => stats.error(format!("runs page body: {e}")),
            },
            Err(e) => stats.error(format!("runs page: {e}")),
        }
    }
}
