//! The web app: FireCastRL's front end to the whole pipeline (place and date → forecast →
//! live suppression → threat report) and a browser for runs, served by `firecast serve` as
//! one page and a JSON API. The API and the live-fire protocol are described in
//! `docs/web-app.md`; the page (`web/`) is embedded in the binary.

pub mod api;
pub mod coverage;
pub mod error;
pub mod fire;
pub mod forecast;
pub mod jobs;
pub mod overview;
pub mod rerun_viewer;
pub mod results;
pub mod runs;
mod session;

use std::net::SocketAddr;
use std::path::PathBuf;

pub use error::{ApiError, Code, ServeError};

/// Everything `firecast serve` needs, resolved by the CLI.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    pub addr: SocketAddr,
    /// Required on every request when set (always set for a non-loopback address).
    pub token: Option<String>,
    pub root: PathBuf,
    pub registry: PathBuf,
    /// The artifact store (a folder or URL), as the CLI resolves it.
    pub store: String,
    pub gridmet: PathBuf,
    /// `forecast.experiment` folders, the first that holds saved models answers (checked
    /// at each request: a report job may train one while the server runs), and its model.
    pub forecasters: Vec<PathBuf>,
    pub model: String,
    /// `rl train` run folders, the first that holds a trained run plays (checked at each
    /// fire).
    pub agent_runs: Vec<PathBuf>,
    /// The threat pipeline (relative to the root).
    pub threat_pipeline: PathBuf,
    /// This binary: jobs run `firecast pipeline run` with it.
    pub firecast_bin: PathBuf,
    /// Global flags jobs pass on (`--registry`, `--store`).
    pub job_args: Vec<String>,
    /// Report jobs waiting at most.
    pub max_queued_jobs: usize,
    /// Live fires at once at most.
    pub max_fires: usize,
    /// The `rerun` CLI whose web viewer opens the recordings (`rerun-sdk` in the venv).
    pub rerun_cli: PathBuf,
}

impl ServeConfig {
    /// Whether the address is loopback (no token needed).
    pub fn is_loopback(&self) -> bool {
        self.addr.ip().is_loopback()
    }
}

/// A token of 128 random bits from the operating system, as 32 hex digits.
pub fn generate_token() -> Result<String, ServeError> {
    use std::io::Read;
    let mut bytes = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .map_err(|e| ServeError::Config(format!("cannot read /dev/urandom for a token: {e}")))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Serves until Ctrl-C (or SIGTERM). `on_ready` is told the bound address (port 0 picks one).
pub fn serve(config: ServeConfig, on_ready: impl FnOnce(SocketAddr)) -> Result<(), ServeError> {
    if !config.is_loopback() && config.token.is_none() {
        return Err(ServeError::Config(format!(
            "{} is not a loopback address: a token is required",
            config.addr
        )));
    }
    // Inference in live fires: one libtorch thread each, the sessions run side by side.
    firecast_learn::set_threads(1);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .thread_name("firecast-serve")
        .build()?;
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::bind(config.addr)
            .await
            .map_err(|source| ServeError::Bind {
                addr: config.addr,
                source,
            })?;
        let local = listener.local_addr()?;
        let state = api::AppState::new(config);
        let app = api::router(state);
        on_ready(local);
        axum::serve(listener, app.into_make_service_with_connect_info::<SocketAddr>())
            .with_graceful_shutdown(shutdown())
            .await?;
        Ok(())
    })
}

async fn shutdown() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    tokio::select! {
        () = ctrl_c => {},
        () = term => {},
    }
}
