//! `firecast bench serve`: the web app under load on loopback ([`load`]): a registry of many
//! runs, live fires at 30 frames a second, many fires at once beside clients hammering the
//! runs table; latencies, frame rates, requests a second, errors and the server's peak memory
//! against the goals (exit status 1 when one is not met).

pub mod load;

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context as _;

use crate::Context;

/// `firecast bench serve`'s flags.
#[derive(Debug, clap::Args)]
pub struct Args {
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

/// `firecast bench serve`: the web app under load on loopback, against the goals.
pub fn run(ctx: &Context, args: &Args) -> anyhow::Result<ServeReport> {
    let gridmet = ctx.root.join(&args.gridmet);
    let coverage = firecast_serve::coverage::Coverage::scan(&gridmet)
        .map_err(|e| anyhow::anyhow!("{e} (run `cargo xtask demo` first, or pass --gridmet)"))?;
    // The middle GRIDMET cell of the data.
    let lat = coverage.lats[coverage.lats.len() / 2];
    let lon = coverage.lons[coverage.lons.len() / 2];
    let config = load::BenchConfig {
        firecast_bin: std::env::current_exe().context("cannot find this firecast binary")?,
        root: ctx.root.clone(),
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
    let json = ctx.json;
    let r = load::run(&config, &|line| {
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
    Ok(ServeReport {
        report: r,
        goals,
        http_rate: args.http_rate,
    })
}

/// `firecast bench serve`'s report: the load test's numbers and each goal, met or not.
#[derive(Debug)]
pub struct ServeReport {
    pub report: load::BenchReport,
    pub goals: [(&'static str, bool); 6],
    /// The runs-table requests a second offered (0: as fast as the clients can).
    pub http_rate: f64,
}

impl serde::Serialize for ServeReport {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut v = serde_json::to_value(&self.report).map_err(serde::ser::Error::custom)?;
        v["goals"] = self
            .goals
            .iter()
            .map(|(g, ok)| serde_json::json!({"goal": g, "met": ok}))
            .collect();
        v.serialize(s)
    }
}

impl crate::Report for ServeReport {
    fn render(&self) -> String {
        let mut out = String::new();
        let _ = self.write(&mut out);
        out
    }

    fn exit_code(&self) -> u8 {
        u8::from(!self.goals.iter().all(|(_, ok)| *ok))
    }
}

impl ServeReport {
    fn write(&self, out: &mut String) -> std::fmt::Result {
        let (r, goals) = (&self.report, &self.goals);
        writeln!(
            out,
            "runs page, {} runs in the registry: first {:.0} ms, then p50 {:.1} ms, p99 {:.1} ms",
            r.runs_in_registry, r.runs_page_first_ms, r.runs_page_warm.p50_ms, r.runs_page_warm.p99_ms
        )?;
        writeln!(
            out,
            "{} fires at the default 30 frames/s: {:.1} frames/s to the slowest client, {:.1} median",
            r.speed_clients, r.speed_fps_min, r.speed_fps_median
        )?;
        writeln!(
            out,
            "{} fires for {:.0} s ({} fires started, {} frames) beside the runs table:",
            r.clients, r.seconds, r.fires_started, r.frames
        )?;
        writeln!(
            out,
            "  first frame   p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms ({} fires started while the others stream)",
            r.first_frame.p50_ms, r.first_frame.p99_ms, r.first_frame.max_ms, r.first_frame.count
        )?;
        writeln!(
            out,
            "                p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms (the opening burst: {} asked for at once)",
            r.first_frame_burst.p50_ms,
            r.first_frame_burst.p99_ms,
            r.first_frame_burst.max_ms,
            r.first_frame_burst.count
        )?;
        writeln!(
            out,
            "  frame late    p50 {:.1} ms, p99 {:.1} ms (against 30 frames/s)",
            r.frame_lateness.p50_ms, r.frame_lateness.p99_ms
        )?;
        writeln!(
            out,
            "  runs table    {:.0} requests/s ({}), p50 {:.1} ms, p99 {:.1} ms",
            r.http_per_second,
            if self.http_rate > 0.0 {
                format!("{:.0} offered", self.http_rate)
            } else {
                "as fast as the clients can".to_string()
            },
            r.http_latency.p50_ms,
            r.http_latency.p99_ms
        )?;
        writeln!(
            out,
            "  errors        {}{}",
            r.errors,
            if r.error_examples.is_empty() {
                String::new()
            } else {
                format!(" (e.g. {})", r.error_examples.join("; "))
            }
        )?;
        writeln!(
            out,
            "  server memory peak {:.0} MiB, {:.0} MiB after",
            r.server_peak_rss_mib, r.server_rss_after_mib
        )?;
        for (goal, ok) in goals {
            writeln!(out, "goal {goal}: {}", if *ok { "met" } else { "NOT met" })?;
        }
        Ok(())
    }
}
