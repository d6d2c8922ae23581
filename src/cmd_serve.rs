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
    /// The forecaster's model (its name in the experiment) [default: FireCast's recommended
    /// forecaster, as the threat pipeline's report uses it].
    #[arg(long, default_value = "climate_offset")]
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
