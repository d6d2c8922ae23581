//! `firecast serve`: the web app. Resolves its settings (flags > defaults that follow what
//! the demo and the threat pipeline build) and hands them to `firecast-serve`.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::Args;

use crate::settings::Settings;

#[derive(Debug, Args)]
pub struct ServeArgs {
    /// Address to listen on. Anything but loopback needs a token (given or generated).
    #[arg(long, default_value = "127.0.0.1:8080", value_name = "IP:PORT")]
    pub addr: SocketAddr,
    /// The token requests must carry (Authorization: Bearer, or ?token= once).
    #[arg(
        long,
        env = "FIRECAST_SERVE_TOKEN",
        value_name = "TOKEN",
        hide_env_values = true
    )]
    pub token: Option<String>,
    /// GRIDMET folder the page's places and days come from.
    #[arg(long, value_name = "DIR", default_value = "build/demo/sources/gridmet")]
    pub gridmet: PathBuf,
    /// A `forecast.experiment` folder [default: build/threat/forecaster if trained, else
    /// build/demo/table3].
    #[arg(long, value_name = "DIR")]
    pub forecaster: Option<PathBuf>,
    /// The forecaster's model (its name in the experiment).
    #[arg(long, default_value = "xgboost")]
    pub model: String,
    /// An `rl train` run folder: the PPO agent [default: build/threat/agent if trained, else
    /// build/demo/helitack_agent].
    #[arg(long, value_name = "DIR")]
    pub agent_run: Option<PathBuf>,
    /// The threat pipeline report jobs run (its `vars` also set the live fires' landscape,
    /// wind and moisture).
    #[arg(long, value_name = "FILE", default_value = "pipelines/threat.yaml")]
    pub threat: PathBuf,
    /// Report jobs waiting at most (beyond: 429).
    #[arg(long, default_value_t = 8)]
    pub max_jobs: usize,
    /// Live fires at once at most (beyond: 429).
    #[arg(long, default_value_t = 256)]
    pub max_fires: usize,
    /// The `rerun` CLI whose web viewer opens recordings [default: the venv's].
    #[arg(long, value_name = "PATH")]
    pub rerun: Option<PathBuf>,
}

pub fn run(settings: &Settings, args: &ServeArgs) -> anyhow::Result<ExitCode> {
    let root = &settings.root;
    // Named ones only; else what the threat pipeline trains (once it has), then the demo's.
    let forecasters = match &args.forecaster {
        Some(dir) => vec![dir.clone()],
        None => vec!["build/threat/forecaster".into(), "build/demo/table3".into()],
    };
    let agent_runs = match &args.agent_run {
        Some(dir) => vec![dir.clone()],
        None => vec!["build/threat/agent".into(), "build/demo/helitack_agent".into()],
    };
    let token = match (&args.token, args.addr.ip().is_loopback()) {
        (Some(t), _) if t.trim().is_empty() => anyhow::bail!("--token is empty"),
        (Some(t), _) => Some(t.clone()),
        (None, true) => None,
        (None, false) => Some(firecast_serve::generate_token()?),
    };
    let mut job_args = vec![
        "--registry".to_string(),
        settings.registry.display().to_string(),
        "--store".to_string(),
        settings.store.clone(),
    ];
    if let Some(url) = &settings.rerun_connect {
        job_args.extend(["--rerun-connect".to_string(), url.clone()]);
    }
    let config = firecast_serve::ServeConfig {
        addr: args.addr,
        token: token.clone(),
        root: root.clone(),
        registry: settings.registry.clone(),
        store: settings.store.clone(),
        gridmet: args.gridmet.clone(),
        forecasters,
        model: args.model.clone(),
        agent_runs,
        threat_pipeline: args.threat.clone(),
        firecast_bin: std::env::current_exe().context("cannot find this firecast binary")?,
        job_args,
        max_queued_jobs: args.max_jobs.max(1),
        max_fires: args.max_fires.max(1),
        rerun_cli: args
            .rerun
            .clone()
            .unwrap_or_else(|| firecast_serve::rerun_viewer::default_cli(root)),
    };
    let json = settings.json;
    firecast_serve::serve(config, |addr| {
        let url = firecast_serve::api::page_url(addr, token.as_deref());
        if json {
            println!("{}", serde_json::json!({"url": url, "addr": addr.to_string()}));
        } else {
            println!("FireCast web app at {url} (Ctrl-C stops it)");
        }
    })?;
    Ok(ExitCode::SUCCESS)
}

#[derive(Debug, Args)]
pub struct BenchServeArgs {
    /// GRIDMET folder of the project (the fires' weather).
    #[arg(long, value_name = "DIR", default_value = "build/demo/sources/gridmet")]
    pub gridmet: PathBuf,
    /// The fires' day.
    #[arg(long, default_value = "2019-08-01")]
    pub date: String,
    /// Live fires at once in the load phase.
    #[arg(long, default_value_t = 200)]
    pub clients: usize,
    /// Live fires in the frame-rate phase.
    #[arg(long, default_value_t = 20)]
    pub speed_clients: usize,
    /// Clients requesting the runs table.
    #[arg(long, default_value_t = 8)]
    pub http_clients: usize,
    /// Runs-table requests a second the clients offer together (0: as fast as they can).
    #[arg(long, default_value_t = 1250.0)]
    pub http_rate: f64,
    /// Seconds of the load phase.
    #[arg(long, default_value_t = 30.0)]
    pub seconds: f64,
    /// Runs in the benchmark's registry.
    #[arg(long, default_value_t = 10_000)]
    pub runs: usize,
    /// The agent playing the fires.
    #[arg(long, default_value = "rule")]
    pub agent: String,
}

/// The goals of the web app's load test (docs/web-app.md).
const GOAL_FIRST_FRAME_MS: f64 = 200.0;
const GOAL_FPS: f64 = 30.0;
const GOAL_RUNS_PAGE_MS: f64 = 300.0;
const GOAL_HTTP_PER_S: f64 = 1000.0;
/// The server's memory bound under the load phase.
const BOUND_PEAK_MIB: f64 = 2048.0;

pub fn bench(settings: &Settings, args: &BenchServeArgs) -> anyhow::Result<ExitCode> {
    let gridmet = settings.root.join(&args.gridmet);
    let coverage = firecast_serve::coverage::Coverage::scan(&gridmet)
        .map_err(|e| anyhow::anyhow!("{e} (run `cargo xtask demo` first, or pass --gridmet)"))?;
    // The middle GRIDMET cell of the data.
    let lat = coverage.lats[coverage.lats.len() / 2];
    let lon = coverage.lons[coverage.lons.len() / 2];
    let config = firecast_serve::bench::BenchConfig {
        firecast_bin: std::env::current_exe().context("cannot find this firecast binary")?,
        root: settings.root.clone(),
        gridmet,
        lat,
        lon,
        date: args.date.clone(),
        runs: args.runs,
        clients: args.clients,
        speed_clients: args.speed_clients,
        http_clients: args.http_clients,
        http_rate: args.http_rate.max(0.0),
        seconds: args.seconds,
        agent: args.agent.clone(),
    };
    let json = settings.json;
    let r = firecast_serve::bench::run(&config, &|line| {
        if !json {
            eprintln!("{line}");
        }
    })
    .map_err(|e| anyhow::anyhow!(e))?;
    let goals = [
        (
            "first frame p99 <= 200 ms (fires started while the others stream)",
            r.first_frame.p99_ms <= GOAL_FIRST_FRAME_MS,
        ),
        ("30 frames/s to each client", r.speed_fps_min >= GOAL_FPS * 0.98),
        (
            "runs page <= 300 ms",
            r.runs_page_first_ms <= GOAL_RUNS_PAGE_MS && r.runs_page_warm.p99_ms <= GOAL_RUNS_PAGE_MS,
        ),
        (
            "runs table >= 1,000 requests/s",
            r.http_per_second >= GOAL_HTTP_PER_S,
        ),
        ("no errors", r.errors == 0),
        ("peak memory <= 2 GiB", r.server_peak_rss_mib <= BOUND_PEAK_MIB),
    ];
    if json {
        let mut v = serde_json::to_value(&r)?;
        v["goals"] = goals
            .iter()
            .map(|(g, ok)| serde_json::json!({"goal": g, "met": ok}))
            .collect();
        crate::output::print_json(&v)?;
    } else {
        println!(
            "runs page, {} runs in the registry: first {:.0} ms, then p50 {:.1} ms, p99 {:.1} ms",
            r.runs_in_registry, r.runs_page_first_ms, r.runs_page_warm.p50_ms, r.runs_page_warm.p99_ms
        );
        println!(
            "{} fires at the default 30 frames/s: {:.1} frames/s to the slowest client, {:.1} median",
            r.speed_clients, r.speed_fps_min, r.speed_fps_median
        );
        println!(
            "{} fires for {:.0} s ({} fires started, {} frames) beside the runs table:",
            r.clients, r.seconds, r.fires_started, r.frames
        );
        println!(
            "  first frame   p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms ({} fires started while the others stream)",
            r.first_frame.p50_ms, r.first_frame.p99_ms, r.first_frame.max_ms, r.first_frame.count
        );
        println!(
            "                p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms (the opening burst: {} asked for at once)",
            r.first_frame_burst.p50_ms,
            r.first_frame_burst.p99_ms,
            r.first_frame_burst.max_ms,
            r.first_frame_burst.count
        );
        println!(
            "  frame late    p50 {:.1} ms, p99 {:.1} ms (against 30 frames/s)",
            r.frame_lateness.p50_ms, r.frame_lateness.p99_ms
        );
        println!(
            "  runs table    {:.0} requests/s ({}), p50 {:.1} ms, p99 {:.1} ms",
            r.http_per_second,
            if args.http_rate > 0.0 {
                format!("{:.0} offered", args.http_rate)
            } else {
                "as fast as the clients can".to_string()
            },
            r.http_latency.p50_ms,
            r.http_latency.p99_ms
        );
        println!(
            "  errors        {}{}",
            r.errors,
            if r.error_examples.is_empty() {
                String::new()
            } else {
                format!(" (e.g. {})", r.error_examples.join("; "))
            }
        );
        println!(
            "  server memory peak {:.0} MiB, {:.0} MiB after",
            r.server_peak_rss_mib, r.server_rss_after_mib
        );
        for (goal, ok) in &goals {
            println!("goal {goal}: {}", if *ok { "met" } else { "NOT met" });
        }
    }
    Ok(if goals.iter().all(|(_, ok)| *ok) {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
