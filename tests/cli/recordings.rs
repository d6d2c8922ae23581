//! Every stage run's metrics as a Rerun recording: `metrics.rrd` in the artifact store,
//! registered with the run (also a failed one), read back with the venv's Rerun SDK and
//! compared with the registry; live streaming to a running `rerun`, and a viewer that is
//! not there (a warning, the file still written).

use std::path::Path;
use std::process::{Child, Command, Stdio};

use crate::{Project, describe, venv_bin};

type Series = firecast_testkit::Series;

fn read_rrd(path: &Path) -> Series {
    firecast_testkit::read_scalars(path)
}

fn verify_rrd(path: &Path) {
    firecast_testkit::verify_rrd(path);
}

/// `<name>.yaml`: CartPole PPO, 2 envs x 32 steps per update, `updates` updates of one
/// epoch. Each run gets its own name: a name's checkpoints would be resumed.
fn cartpole(p: &Project, name: &str, updates: u64) -> String {
    let file = format!("{name}.yaml");
    p.write(
        &file,
        &format!(
            "name: {name}\nenv: {{kind: cartpole}}\nppo: {{preset: cartpole_zoo, n_envs: 2, n_steps: 32, batch_size: 32, n_epochs: 1, total_timesteps: {}}}\nseeds: [0]\ndevice: cpu\n",
            64 * updates
        ),
    );
    file
}

fn query(p: &Project, sql: &str) -> Vec<serde_json::Value> {
    p.json(&["query", sql]).as_array().unwrap().clone()
}

/// The registry's metrics of a run, as the recording should hold them.
fn registry_series(p: &Project, run_id: &str) -> Series {
    let mut series = Series::new();
    for row in query(
        p,
        &format!("SELECT key, step, value FROM metrics WHERE run_id = '{run_id}' ORDER BY key, step"),
    ) {
        series
            .entry(firecast_recorder::entity_path(row["key"].as_str().unwrap()))
            .or_default()
            .push((row["step"].as_i64().unwrap(), row["value"].as_f64().unwrap()));
    }
    for rows in series.values_mut() {
        rows.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    }
    series
}

/// The latest `rl.train` run, its status, and its `metrics.rrd` fetched through the CLI.
fn latest_run_recording(p: &Project, dest: &str) -> (String, String, Series) {
    let runs = query(
        p,
        "SELECT run_id, status FROM runs WHERE kind = 'rl.train' ORDER BY started_at DESC LIMIT 1",
    );
    let run_id = runs[0]["run_id"].as_str().unwrap().to_string();
    let status = runs[0]["status"].as_str().unwrap().to_string();
    let artifacts = query(
        p,
        &format!("SELECT uri, size FROM artifacts WHERE run_id = '{run_id}' AND name = 'metrics'"),
    );
    assert_eq!(artifacts.len(), 1, "one metrics.rrd registered: {artifacts:?}");
    let uri = artifacts[0]["uri"].as_str().unwrap();
    assert!(
        uri.ends_with(&format!("runs/{run_id}/metrics/metrics.rrd")),
        "{uri}"
    );
    p.ok(&["artifacts", "get", uri, "-o", dest]);
    assert_eq!(
        std::fs::metadata(p.path(dest)).unwrap().len(),
        artifacts[0]["size"].as_u64().unwrap()
    );
    verify_rrd(&p.path(dest));
    (run_id, status, read_rrd(&p.path(dest)))
}

/// No staging file may be left behind (nothing half-written).
fn assert_no_partial_recordings(p: &Project) {
    let dir = p.path(".firecast/state/recordings");
    let left: Vec<_> = std::fs::read_dir(&dir)
        .map(|d| d.map(|e| e.unwrap().file_name()).collect())
        .unwrap_or_default();
    assert!(left.is_empty(), "left in {}: {left:?}", dir.display());
}

#[test]
fn stage_metrics_become_a_registered_rerun_recording() {
    let p = Project::new();
    let config = cartpole(&p, "cp", 4);
    p.ok(&["rl", "train", "--config", &config]);
    let (run_id, status, series) = latest_run_recording(&p, "metrics.rrd");
    assert_eq!(status, "succeeded");
    // One row per PPO update for an SB3 metric, at the update's timesteps.
    let kl = &series["seed-0/train/approx_kl"];
    assert_eq!(
        kl.iter().map(|r| r.0).collect::<Vec<_>>(),
        [64, 128, 192, 256],
        "{kl:?}"
    );
    assert!(series.contains_key("seed-0/rollout/ep_rew_mean"), "{series:?}");
    // Every metric of the run, step for step and value for value.
    assert_eq!(series, registry_series(&p, &run_id));
    assert_no_partial_recordings(&p);

    // A run stopped halfway fails, and its curves so far are still recorded.
    let config = cartpole(&p, "cp-stopped", 4);
    let out = p
        .firecast()
        .args(["rl", "train", "--config", &config, "--stop-after", "128"])
        .output()
        .unwrap();
    assert!(!out.status.success(), "{}", describe(&out));
    let (failed_id, status, series) = latest_run_recording(&p, "failed.rrd");
    assert_ne!(failed_id, run_id);
    assert_eq!(status, "failed");
    assert_eq!(series["seed-0/train/approx_kl"].len(), 2, "{series:?}");
    assert_eq!(series, registry_series(&p, &failed_id));
    assert_no_partial_recordings(&p);
}

/// A headless `rerun` that saves what it receives, on a free loopback port.
struct Viewer {
    child: Child,
    url: String,
}

impl Viewer {
    fn free_port() -> u16 {
        std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port()
    }

    /// The `rerun` program itself: the venv's `rerun` is a Python wrapper whose child
    /// would outlive a signal sent to the wrapper.
    fn program() -> std::path::PathBuf {
        let out = Command::new(venv_bin("python"))
            .args([
                "-c",
                "import pathlib, rerun_cli; print(pathlib.Path(rerun_cli.__file__).parent / 'rerun')",
            ])
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", describe(&out));
        String::from_utf8_lossy(&out.stdout).trim().into()
    }

    fn start(port: u16, save: &Path) -> Self {
        let child = Command::new(Self::program())
            .args(["--bind", "127.0.0.1", "--port", &port.to_string(), "--save"])
            .arg(save)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(30);
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(
                std::time::Instant::now() < deadline,
                "rerun did not listen on {port}"
            );
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        Self {
            child,
            url: format!("rerun+http://127.0.0.1:{port}/proxy"),
        }
    }

    /// Ctrl-C, so it writes out what it holds; killed if it lingers.
    fn stop(mut self) {
        let _ = Command::new("kill")
            .args(["-INT", &self.child.id().to_string()])
            .status();
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
        while self.child.try_wait().unwrap().is_none() && std::time::Instant::now() < deadline {
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Viewer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn metrics_stream_live_to_a_viewer_and_an_absent_one_is_a_warning() {
    let p = Project::new();
    let port = Viewer::free_port();
    let url = format!("rerun+http://127.0.0.1:{port}/proxy");

    // Nobody listens: one warning, the run succeeds and its recording is written.
    let out = p
        .firecast()
        .args([
            "rl",
            "train",
            "--config",
            &cartpole(&p, "cp-a", 2),
            "--rerun-connect",
            &url,
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", describe(&out));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        stderr.matches("no Rerun viewer listens at").count(),
        1,
        "{stderr}"
    );
    let (_, _, recorded) = latest_run_recording(&p, "first.rrd");
    assert_eq!(recorded["seed-0/train/approx_kl"].len(), 2);

    // A viewer listens (set through the environment this time): it gets the same series.
    let live_file = p.path("live.rrd");
    let viewer = Viewer::start(port, &live_file);
    let out = p
        .firecast()
        .env("FIRECAST_RERUN_CONNECT", &viewer.url)
        .args(["rl", "train", "--config", &cartpole(&p, "cp-b", 2)])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", describe(&out));
    assert!(
        !String::from_utf8_lossy(&out.stderr).contains("warning"),
        "{}",
        describe(&out)
    );
    viewer.stop();
    let (_, _, recorded) = latest_run_recording(&p, "second.rrd");
    let live = read_rrd(&live_file);
    assert_eq!(live, recorded, "the viewer received what the file holds");
    assert_eq!(live["seed-0/train/approx_kl"].len(), 2);

    // A malformed address is refused before anything runs.
    let out = p
        .firecast()
        .args([
            "rl",
            "train",
            "--config",
            &cartpole(&p, "cp-c", 2),
            "--rerun-connect",
            "http://x",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("is not a Rerun viewer address"),
        "{}",
        describe(&out)
    );
}
