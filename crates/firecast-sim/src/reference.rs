//! Side by side with the FireCastRL Python environment (`aisystems-lab/wildfire-env`, the P2
//! engine, docs/spec/fire-model.md §A0): the same map, seeds and actions in both, compared episode
//! by episode (steps, burnt cells, peak burning cells, a checksum of the final fire-state grid) and
//! timed.
//!
//! FireCast ships only a small driver ([`DRIVER`]) that imports the user's checkout of that
//! environment and steps it; the environment itself is not part of FireCast.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use firecast_landscape::Landscape;

use crate::automaton::SimError;
use crate::env::{Action, EnvConfig, Termination, WildfireEnv};
use crate::random::RandomSource;

/// The Python driver (written to a work folder and run with the user's interpreter).
pub const DRIVER: &str = include_str!("../reference/firecastrl_env_driver.py");

/// One episode for both engines: Python's `random.seed(seed)`, then the actions cyclically.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ParityEpisode {
    pub seed: u64,
    /// FireCastRL action numbers (0 y+3, 1 y−3, 2 x−3, 3 x+3, 4 drop).
    pub actions: Vec<u8>,
    pub max_steps: u32,
}

/// How an episode ended, as both engines report it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EpisodeOutcome {
    pub seed: u64,
    pub steps: u32,
    pub burnt: u32,
    pub burning: u32,
    pub peak_burning: u32,
    /// Σ over row-major cells of index × fire state (0 unburnt, 1 burning, 2 burnt).
    pub checksum: u64,
    pub terminated: bool,
    /// Seconds inside `step` (observation and reward included; reset excluded).
    pub seconds: f64,
}

impl EpisodeOutcome {
    /// Same fire: every compared field but the time.
    pub fn same_fire(&self, other: &Self) -> bool {
        (
            self.steps,
            self.burnt,
            self.burning,
            self.peak_burning,
            self.checksum,
            self.terminated,
        ) == (
            other.steps,
            other.burnt,
            other.burning,
            other.peak_burning,
            other.checksum,
            other.terminated,
        )
    }
}

/// Errors running the reference environment.
#[derive(Debug, thiserror::Error)]
pub enum ReferenceError {
    #[error("{action} {path}: {source}")]
    Io {
        action: &'static str,
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(
        "the FireCastRL environment failed under {python} (is {env_dir} a checkout of \
         aisystems-lab/wildfire-env, with gymnasium, numpy, pillow, websockets and requests \
         installed for that interpreter?):\n{stderr}"
    )]
    Failed {
        python: PathBuf,
        env_dir: PathBuf,
        stderr: String,
    },
    #[error("unexpected output from {script}: {message}")]
    Output { script: PathBuf, message: String },
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// The P2 engine's settings: FireCast's defaults (which follow P2) with P2's ending ("no cell
/// burning") and CPython's generator, so that seed `s` is `random.seed(s)` there.
pub fn p2_parity_config() -> EnvConfig {
    let mut cfg = EnvConfig {
        termination: Termination::NoBurningCells,
        ..EnvConfig::default()
    };
    cfg.sim.random = RandomSource::PythonMt;
    cfg
}

/// The compared action scripts: no suppression (always action 0, which only moves the
/// helicopter), and a helitack run that waits 200 steps while the fire grows, flies to the
/// spark and then drops on a square around it with pauses, so part of the fire escapes.
/// The script repeats from the start if the episode outlasts it.
pub fn parity_scripts() -> Vec<(&'static str, Vec<u8>)> {
    let mut helitack = Vec::new();
    // Hover: y+3, y−3 (the helicopter starts at (70, 30)).
    for _ in 0..100 {
        helitack.extend([0u8, 1]);
    }
    // To (118, 78): 16 moves x+3, 16 moves y+3.
    helitack.extend(std::iter::repeat_n(3u8, 16));
    helitack.extend(std::iter::repeat_n(0u8, 16));
    // Stops on a square 15 cells out from the spark (where the front is by then), five moves
    // per leg, a drop at each stop and four idle steps after it.
    for leg in [3u8, 0, 2, 2, 1, 1, 3, 3] {
        helitack.extend([leg; 5]);
        helitack.extend([4, 0, 1, 0, 1]);
    }
    vec![("no suppression", vec![0]), ("helitack script", helitack)]
}

/// Runs the episodes in FireCast.
pub fn run_firecast(
    landscape: &Landscape,
    cfg: &EnvConfig,
    episodes: &[ParityEpisode],
) -> Result<Vec<EpisodeOutcome>, SimError> {
    let mut env = WildfireEnv::new(landscape, cfg)?;
    let mut out = Vec::with_capacity(episodes.len());
    for ep in episodes {
        let actions = ep
            .actions
            .iter()
            .map(|&a| Action::try_from(a))
            .collect::<Result<Vec<_>, _>>()?;
        if actions.is_empty() {
            return Err(SimError::Config("an episode needs at least one action".into()));
        }
        env.reset(ep.seed);
        let (mut steps, mut peak, mut seconds) = (0u32, 0u32, 0.0);
        let (terminated, info) = loop {
            let a = actions[steps as usize % actions.len()];
            let t = Instant::now();
            let (obs, _, terminated, truncated, info) = env.step(a);
            std::hint::black_box(obs.current_frame());
            seconds += t.elapsed().as_secs_f64();
            steps += 1;
            peak = peak.max(info.cells_burning);
            if terminated || truncated || steps >= ep.max_steps {
                break (terminated, info);
            }
        };
        out.push(EpisodeOutcome {
            seed: ep.seed,
            steps,
            burnt: info.cells_burnt,
            burning: info.cells_burning,
            peak_burning: peak,
            checksum: fire_state_checksum(env.automaton().fire_states()),
            terminated,
            seconds,
        });
    }
    Ok(out)
}

/// Σ index × state over the row-major fire-state grid.
pub fn fire_state_checksum(states: &[u8]) -> u64 {
    states
        .iter()
        .enumerate()
        .map(|(i, &s)| i as u64 * u64::from(s))
        .sum()
}

/// What the reference run returned.
#[derive(Debug, Clone)]
pub struct ReferenceRun {
    /// Seconds to construct the environment (map loading).
    pub construct_seconds: f64,
    pub episodes: Vec<EpisodeOutcome>,
    /// Wall time of the whole Python process.
    pub wall_seconds: f64,
}

/// Runs the episodes in the FireCastRL environment found in `env_dir` with `python`.
pub fn run_reference(
    python: &Path,
    env_dir: &Path,
    episodes: &[ParityEpisode],
    workdir: &Path,
) -> Result<ReferenceRun, ReferenceError> {
    let io = |action: &'static str, path: &Path| {
        let path = path.to_path_buf();
        move |source| ReferenceError::Io { action, path, source }
    };
    if !env_dir.join("firecastrl_env").is_dir() {
        return Err(ReferenceError::Failed {
            python: python.to_path_buf(),
            env_dir: env_dir.to_path_buf(),
            stderr: format!("{} has no firecastrl_env package folder", env_dir.display()),
        });
    }
    let script = workdir.join("firecastrl_env_driver.py");
    std::fs::write(&script, DRIVER).map_err(io("writing", &script))?;
    let request = workdir.join("episodes.json");
    let text = serde_json::to_string(episodes).map_err(|e| ReferenceError::Output {
        script: request.clone(),
        message: e.to_string(),
    })?;
    std::fs::write(&request, text).map_err(io("writing", &request))?;
    let started = Instant::now();
    let output = Command::new(python)
        .arg(&script)
        .arg(env_dir)
        .arg(&request)
        .current_dir(env_dir)
        .output()
        .map_err(io("running", python))?;
    let wall_seconds = started.elapsed().as_secs_f64();
    if !output.status.success() {
        return Err(ReferenceError::Failed {
            python: python.to_path_buf(),
            env_dir: env_dir.to_path_buf(),
            stderr: String::from_utf8_lossy(&output.stderr).into_owned(),
        });
    }
    #[derive(serde::Deserialize)]
    struct Reply {
        construct_seconds: f64,
        episodes: Vec<EpisodeOutcome>,
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    let line = stdout.lines().last().unwrap_or("");
    let reply: Reply = serde_json::from_str(line).map_err(|e| ReferenceError::Output {
        script: script.clone(),
        message: format!("`{line}`: {e}"),
    })?;
    if reply.episodes.len() != episodes.len() {
        return Err(ReferenceError::Output {
            script,
            message: format!(
                "{} episodes requested, {} returned",
                episodes.len(),
                reply.episodes.len()
            ),
        });
    }
    Ok(ReferenceRun {
        construct_seconds: reply.construct_seconds,
        episodes: reply.episodes,
        wall_seconds,
    })
}
