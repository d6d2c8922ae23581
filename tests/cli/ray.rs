//! `--executor ray` against a real Ray cluster on loopback: a head and a second worker
//! node (`ray start` from `.venv`, each in its own session so teardown kills exactly its
//! processes), an S3 store (moto) as the shared disk. Checks the lockfile and outputs equal
//! the local run's (with sharded `sim.episodes`, `data.windows` and `forecast.experiment`
//! stages on the cluster),
//! that nothing is shipped twice, and the faults: a killed worker is retried, a pending job times out, a
//! failing stage names its worker and log, a killed driver resumes from what finished.

use std::collections::BTreeMap;
use std::io::{Read as _, Write as _};
use std::net::{TcpListener, TcpStream};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::store::Moto;
use crate::{
    Project, describe, files_under, first_stage_run_id, lock_without_run_ids, outcomes, recorded, stage_log,
    stage_report, venv_bin,
};

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// `GET path` on loopback; (status line, body).
fn http_get(port: u16, path: &str) -> Option<(String, String)> {
    let mut stream = TcpStream::connect(("127.0.0.1", port)).ok()?;
    stream.set_read_timeout(Some(Duration::from_secs(10))).ok()?;
    write!(stream, "GET {path} HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n").ok()?;
    let mut text = String::new();
    stream.read_to_string(&mut text).ok()?;
    let (head, body) = text.split_once("\r\n\r\n")?;
    Some((head.lines().next()?.to_string(), body.to_string()))
}

/// A Ray head plus one worker node on 127.0.0.1, torn down on drop.
struct RayCluster {
    /// Session ids of the `ray start` processes: every Ray process they spawn stays in them.
    sessions: Vec<u32>,
    dashboard_port: u16,
    dir: tempfile::TempDir,
}

impl RayCluster {
    fn start(env: &[(String, String)]) -> Self {
        // Short path: Ray's socket paths must fit in 107 bytes.
        let dir = tempfile::Builder::new()
            .prefix("fcray")
            .tempdir_in("/tmp")
            .unwrap();
        let mut cluster = Self {
            sessions: Vec::new(),
            dashboard_port: free_port(),
            dir,
        };
        let gcs_port = free_port();
        let head_args = vec![
            "--head".to_string(),
            format!("--port={gcs_port}"),
            format!("--dashboard-port={}", cluster.dashboard_port),
            "--dashboard-host=127.0.0.1".into(),
            format!("--temp-dir={}", cluster.dir.path().display()),
            format!("--ray-client-server-port={}", free_port()),
        ];
        cluster.launch("head", &head_args, env);
        let worker_args = vec![format!("--address=127.0.0.1:{gcs_port}")];
        cluster.launch("worker", &worker_args, env);
        let deadline = Instant::now() + Duration::from_secs(90);
        loop {
            let nodes = http_get(cluster.dashboard_port, "/nodes?view=summary")
                .map(|(_, body)| body.matches("\"ALIVE\"").count())
                .unwrap_or(0);
            let api =
                http_get(cluster.dashboard_port, "/api/version").is_some_and(|(s, _)| s.contains("200"));
            if api && nodes >= 2 {
                break;
            }
            assert!(
                Instant::now() < deadline,
                "the Ray cluster did not come up with 2 nodes (logs in {})",
                cluster.dir.path().display()
            );
            std::thread::sleep(Duration::from_millis(300));
        }
        cluster
    }

    fn launch(&mut self, name: &str, args: &[String], env: &[(String, String)]) {
        let log = std::fs::File::create(self.dir.path().join(format!("{name}.out"))).unwrap();
        let mut command = Command::new("setsid");
        command
            .arg(venv_bin("ray"))
            .arg("start")
            .args(args)
            .args([
                "--node-ip-address=127.0.0.1",
                "--num-cpus=1",
                "--object-store-memory=80000000",
                "--disable-usage-stats",
            ])
            .arg(format!("--dashboard-agent-listen-port={}", free_port()))
            .env("RAY_USAGE_STATS_ENABLED", "0")
            .stdin(Stdio::null())
            .stdout(log.try_clone().unwrap())
            .stderr(log);
        for (k, v) in env {
            command.env(k, v);
        }
        let mut child = command.spawn().unwrap();
        self.sessions.push(child.id());
        let status = child.wait().unwrap();
        assert!(
            status.success(),
            "ray start ({name}) failed: {}",
            std::fs::read_to_string(self.dir.path().join(format!("{name}.out"))).unwrap_or_default()
        );
    }

    fn address(&self) -> String {
        format!("http://127.0.0.1:{}", self.dashboard_port)
    }

    fn jobs(&self) -> usize {
        http_get(self.dashboard_port, "/api/jobs/")
            .map(|(_, body)| body.matches("\"submission_id\"").count())
            .unwrap_or(0)
    }

    /// Processes still alive in the cluster's sessions.
    fn processes(&self) -> Vec<u32> {
        let mut out = Vec::new();
        for entry in std::fs::read_dir("/proc").unwrap().flatten() {
            let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else {
                continue;
            };
            let Ok(stat) = std::fs::read_to_string(entry.path().join("stat")) else {
                continue;
            };
            // pid (comm) state ppid pgrp session …; comm may contain spaces.
            let Some((_, rest)) = stat.rsplit_once(") ") else {
                continue;
            };
            let fields: Vec<&str> = rest.split_whitespace().collect();
            if fields.first() == Some(&"Z") {
                continue;
            }
            if let Some(sid) = fields.get(3).and_then(|s| s.parse::<u32>().ok())
                && self.sessions.contains(&sid)
            {
                out.push(pid);
            }
        }
        out
    }
}

impl Drop for RayCluster {
    fn drop(&mut self) {
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let pids = self.processes();
            if pids.is_empty() || Instant::now() > deadline {
                break;
            }
            let _ = Command::new("kill")
                .arg("-9")
                .args(pids.iter().map(u32::to_string))
                .stderr(Stdio::null())
                .status();
            std::thread::sleep(Duration::from_millis(200));
        }
    }
}

const PIPELINE: &str = r#"
vars:
  fuel_models: [GR2, SH5]
stages:
  cases:
    uses: cmd
    foreach: ${fuel_models}
    params:
      command: >-
        { echo fm,m1_pct,m10_pct,m100_pct,mherb_pct,mwoody_pct,midflame_mph,slope_pct,wind_dir_rel_upslope_deg;
        for wind in 0 5 10; do echo ${item},5,6,8,60,90,$wind,20,0; done; } > ${outputs.csv}
    outputs:
      csv: "build/cases/${item}.csv"
  spread:
    uses: cmd
    foreach: ${fuel_models}
    params:
      command: $FIRECAST_BIN sim spread-rate --input ${inputs.cases} --output ${outputs.csv}
    inputs:
      cases: {from: "cases@${item}.csv"}
    outputs:
      csv: "build/spread/${item}.csv"
  helitack:
    uses: sim.episodes
    resources: {cpus: 1, memory: 200MiB}
    params:
      landscape: {procedural: {seed: 5, width: 100, height: 80}}
      agent: rule
      episodes: 4
      seed: 3
      env: {max_steps: 300, sim: {wind: {speed_mph: 6, from_direction_deg: 200}}}
    outputs:
      summary: build/helitack.json
      trace: build/helitack.trace.json
"#;

const OUTPUTS: &[&str] = &[
    "build/cases/GR2.csv",
    "build/spread/SH5.csv",
    "build/helitack.json",
    "build/helitack.trace.json",
];

/// Synthetic sources, ignitions and samples: the inputs of the `data.windows` tests.
const WINDOW_SOURCES: &str = r#"
stages:
  sources:
    uses: data.synthesize
    params:
      seed: 3
      region: {lat_min: 39.0, lat_max: 39.5, lon_min: -107.5, lon_max: -106.9}
      years: [2019, 2019]
      ignition_rate_scale: 3.5
    outputs:
      gridmet: build/sources/gridmet
      incidents: build/sources/wfigs.csv
      model: build/sources/MODEL.md
      truth: build/sources/truth
  ignitions:
    uses: data.ignitions
    inputs:
      incidents: {from: sources.incidents}
      gridmet: {from: sources.gridmet}
    outputs:
      ignitions: build/ignitions.parquet
      report: build/ignitions.json
      rejects: build/rejects.csv
  samples:
    uses: data.negatives
    params:
      variant: paper
      seed: 42
      period_start: "2019-03-02"
      period_end: "2019-12-17"
      far_min_km: 4
      near_max_km: 30
    inputs:
      ignitions: {from: ignitions.ignitions}
      gridmet: {from: sources.gridmet}
    outputs:
      samples: build/samples.parquet
      report: build/samples.json
"#;

/// The 15 paper variables' windows (with the generator's truth) and a dataset built on them.
const WINDOWS: &str = r#"
stages:
  windows:
    uses: data.windows
    inputs:
      samples: build/samples.parquet
      gridmet: gridmet
      truth: build/sources/truth
    outputs:
      windows: build/windows
  dataset:
    uses: data.dataset
    params: {name: shard-test}
    inputs:
      windows: {from: windows.windows}
    outputs:
      dataset: build/dataset
"#;

const WINDOW_FILES: &[&str] = &[
    "build/windows/samples.parquet",
    "build/windows/days.parquet",
    "build/windows/windows.json",
];

/// A project whose `data.windows` stage has run unsharded, here. Its `gridmet/` holds the
/// synthetic 2019 files plus copies named `*_2020.nc` (with 2019's days), so the late-December
/// samples reach the merge and are dropped there for days missing in a file.
fn windows_project() -> Project {
    let p = Project::new();
    p.write("pipelines/sources.yaml", WINDOW_SOURCES);
    let ran = p.run_pipeline("pipelines/sources.yaml", &[]);
    assert!(ran.values().all(|o| o == "ran"), "{ran:?}");
    std::fs::create_dir_all(p.path("gridmet")).unwrap();
    for entry in std::fs::read_dir(p.path("build/sources/gridmet")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        std::fs::copy(&path, p.path("gridmet").join(&name)).unwrap();
        std::fs::copy(
            &path,
            p.path("gridmet").join(name.replace("_2019.nc", "_2020.nc")),
        )
        .unwrap();
    }
    p.write("pipelines/windows.yaml", WINDOWS);
    let ran = p.run_pipeline("pipelines/windows.yaml", &[]);
    assert!(ran.values().all(|o| o == "ran"), "{ran:?}");
    let manifest: serde_json::Value = serde_json::from_str(&p.read("build/windows/windows.json")).unwrap();
    let dropped = &manifest["report"]["dropped"];
    assert!(
        dropped["days_missing_in_gridmet_file"].as_u64() > Some(0)
            && dropped["window_outside_gridmet_years"].as_u64() > Some(0),
        "{manifest}"
    );
    assert!(
        manifest["truth"]["samples_with_value"].as_u64() > Some(0),
        "{manifest}"
    );
    p
}

fn read_all(p: &Project, files: &[&str]) -> Vec<Vec<u8>> {
    files.iter().map(|f| std::fs::read(p.path(f)).unwrap()).collect()
}

fn check_windows_equal(p: &Project, whole: &[Vec<u8>], shards: u32) {
    for (file, bytes) in WINDOW_FILES.iter().zip(whole) {
        assert!(
            std::fs::read(p.path(file)).unwrap() == *bytes,
            "{file} differs between the unsharded run and {shards} shards"
        );
    }
}

fn ray_run(p: &Project, moto: &Moto, file: &str, extra: &[&str]) -> std::process::Output {
    let mut cmd = p.firecast();
    moto.env(&mut cmd);
    cmd.args([
        "--json",
        "--store",
        "s3://fc-ray/store",
        "pipeline",
        "run",
        file,
        "--executor",
        "ray",
    ])
    .args(extra)
    .output()
    .unwrap()
}

#[test]
fn ray_runs_match_local_and_survive_faults() {
    let started = Instant::now();
    let moto = Moto::start();
    moto.create_bucket("fc-ray");
    let moto_env: Vec<(String, String)> = {
        let mut probe = Command::new("true");
        moto.env(&mut probe);
        probe
            .get_envs()
            .filter_map(|(k, v)| Some((k.to_str()?.to_string(), v?.to_string_lossy().to_string())))
            .collect()
    };
    let cluster = RayCluster::start(&moto_env);
    let address = cluster.address();
    let up = started.elapsed();

    // Local, unsharded.
    let local = Project::new();
    local.write("pipelines/fire.yaml", PIPELINE);
    let ran = local.run_pipeline("pipelines/fire.yaml", &[]);
    assert!(ran.values().all(|o| o == "ran"), "{ran:?}");

    // On the cluster, the episodes in 2 shards (Ray jobs on the two nodes).
    let remote = Project::new();
    remote.write(
        "pipelines/fire.yaml",
        &PIPELINE.replace("    resources:", "    shards: 2\n    resources:"),
    );
    let out = ray_run(
        &remote,
        &moto,
        "pipelines/fire.yaml",
        &["--ray-address", &address],
    );
    assert!(out.status.success(), "{}", describe(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(outcomes(&report).values().all(|o| o == "ran"), "{report}");
    assert_eq!(
        lock_without_run_ids(&local, "pipelines/fire.lock"),
        lock_without_run_ids(&remote, "pipelines/fire.lock")
    );
    for file in OUTPUTS {
        assert_eq!(
            std::fs::read(local.path(file)).unwrap(),
            std::fs::read(remote.path(file)).unwrap(),
            "{file} differs between the local and the Ray run"
        );
    }
    let log = stage_log(
        &remote,
        stage_report(&report, "helitack")["run_id"].as_str().unwrap(),
    );
    assert!(
        log.contains("# shard 0/2 on") && log.contains("# shard 1/2 on"),
        "{log}"
    );
    let first_run = started.elapsed();

    // data.windows in 2 shards on the cluster (one per node) equals the local unsharded run,
    // and the merge on the driver records its metrics.
    let windows = windows_project();
    let whole = read_all(&windows, WINDOW_FILES);
    let whole_lock = lock_without_run_ids(&windows, "pipelines/windows.lock");
    let whole_metrics = recorded(
        &windows,
        windows.json(&["runs", "list", "--stage", "windows"])[0]["run_id"]
            .as_str()
            .unwrap(),
    )
    .0;
    windows.write(
        "pipelines/windows.yaml",
        &WINDOWS.replace(
            "    uses: data.windows\n",
            "    uses: data.windows\n    shards: 2\n",
        ),
    );
    let out = ray_run(
        &windows,
        &moto,
        "pipelines/windows.yaml",
        &["--ray-address", &address, "--force", "--only", "windows"],
    );
    assert!(out.status.success(), "{}", describe(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(outcomes(&report)["windows"], "ran", "{report}");
    check_windows_equal(&windows, &whole, 2);
    assert_eq!(
        lock_without_run_ids(&windows, "pipelines/windows.lock"),
        whole_lock
    );
    assert_eq!(recorded(&windows, first_stage_run_id(&report)).0, whole_metrics);
    let log = stage_log(&windows, first_stage_run_id(&report));
    assert!(
        log.contains("# shard 1/2 on") && log.contains("# merged 2 shards on the driver"),
        "{log}"
    );
    // Each shard fetched its variables' files (16 variables x 2 years here), the grid's file,
    // and shard 0 also the land mask's and the truth.
    for line in [
        "shard 0/2: fetched 15 of 32 files of input `gridmet` (gridmet, ",
        "shard 1/2: fetched 17 of 32 files of input `gridmet` (gridmet, ",
        "shard 0/2: fetched 1 of 1 files of input `truth` (build/sources/truth, ",
        "shard 1/2: fetched 0 of 1 files of input `truth` (build/sources/truth, 0.0 of ",
    ] {
        assert!(log.contains(line), "{line}:\n{log}");
    }
    let windows_run = started.elapsed() - first_run;

    // forecast.experiment in 2 shards on the cluster (8 training units per node) equals the
    // local unsharded run: the report, the lockfile, the metrics (the shards' come back as
    // events, the merge's are the driver's own) and the saved models as artifacts.
    let exp = crate::forecast::project_with_dataset();
    exp.write("pipelines/exp.yaml", &crate::forecast::experiment_stage(None));
    let report = exp.json(&["pipeline", "run", "pipelines/exp.yaml"]);
    assert_eq!(outcomes(&report)["table3"], "ran", "{report}");
    let whole = files_under(&exp.path("build/table3"));
    let whole_lock = lock_without_run_ids(&exp, "pipelines/exp.lock");
    let whole_recorded = recorded(&exp, first_stage_run_id(&report));
    let local_experiment = started.elapsed() - first_run - windows_run;
    exp.write("pipelines/exp.yaml", &crate::forecast::experiment_stage(Some(2)));
    let out = ray_run(
        &exp,
        &moto,
        "pipelines/exp.yaml",
        &["--ray-address", &address, "--force"],
    );
    assert!(out.status.success(), "{}", describe(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(outcomes(&report)["table3"], "ran", "{report}");
    assert!(
        files_under(&exp.path("build/table3")) == whole,
        "the report differs between the local run and 2 shards on Ray"
    );
    assert_eq!(lock_without_run_ids(&exp, "pipelines/exp.lock"), whole_lock);
    assert_eq!(recorded(&exp, first_stage_run_id(&report)), whole_recorded);
    let log = stage_log(&exp, first_stage_run_id(&report));
    assert!(
        log.contains("shard 1/2: 8 of 16 training units") && log.contains("# merged 2 shards on the driver"),
        "{log}"
    );
    let experiment_run = started.elapsed() - first_run - windows_run;

    // Up to date: nothing is shipped.
    let jobs = cluster.jobs();
    let out = ray_run(
        &remote,
        &moto,
        "pipelines/fire.yaml",
        &["--ray-address", &address],
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(outcomes(&report).values().all(|o| o == "up_to_date"), "{report}");
    assert_eq!(cluster.jobs(), jobs);

    // A worker killed mid-task: the task is submitted again and the run finishes.
    let faults = Project::new();
    let marker = faults.path("killed-once");
    faults.write(
        "pipelines/flaky.yaml",
        &format!(
            "stages:\n  flaky:\n    uses: cmd\n    params:\n      command: \"if mkdir {} 2>/dev/null; then kill -9 $PPID; sleep 30; fi; echo survived > ${{outputs.out}}\"\n    outputs: {{out: flaky.txt}}\n",
            marker.display()
        ),
    );
    let out = ray_run(
        &faults,
        &moto,
        "pipelines/flaky.yaml",
        &["--ray-address", &address],
    );
    assert!(out.status.success(), "{}", describe(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(faults.read("flaky.txt"), "survived\n");
    let warnings = report["warnings"].to_string();
    assert!(
        warnings.contains("stage `flaky`: attempt 1 of 3 lost its worker, retried"),
        "{warnings}"
    );

    // A failing stage: the error names the stage, the worker and the log.
    faults.write(
        "pipelines/bad.yaml",
        "stages:\n  bad:\n    uses: cmd\n    params: {command: \"echo about to fail; exit 3\"}\n    outputs: {out: bad.txt}\n",
    );
    let out = ray_run(&faults, &moto, "pipelines/bad.yaml", &["--ray-address", &address]);
    assert_eq!(out.status.code(), Some(1), "{}", describe(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let error = report["stages"][0]["error"].as_str().unwrap();
    assert!(
        error.starts_with("stage `bad`: failed on worker ")
            && error.contains("(ray job firecast-")
            && error.contains("command exited with code 3")
            && error.contains("(log: .firecast/logs/"),
        "{error}"
    );
    assert!(stage_log(&faults, first_stage_run_id(&report)).contains("about to fail"));
    assert!(!faults.path("bad.txt").exists());

    // More CPUs than the cluster has: reported after the pending timeout, not waited on.
    faults.write(
        "pipelines/big.yaml",
        "stages:\n  big:\n    uses: cmd\n    resources: {cpus: 64}\n    params: {command: \"echo > ${outputs.out}\"}\n    outputs: {out: big.txt}\n",
    );
    let t = Instant::now();
    let out = ray_run(
        &faults,
        &moto,
        "pipelines/big.yaml",
        &["--ray-address", &address, "--ray-pending-timeout", "3"],
    );
    assert_eq!(out.status.code(), Some(1), "{}", describe(&out));
    assert!(t.elapsed() < Duration::from_secs(30));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let error = report["stages"][0]["error"].as_str().unwrap();
    assert!(
        error.starts_with("stage `big`: ray job firecast-")
            && error.contains(
                "stayed PENDING for 3 s while no other job of this run was running (asked for 64 CPUs)"
            )
            && error.contains("the job was stopped"),
        "{error}"
    );

    // Queued behind this run's own jobs is waiting, not stuck: three 1-CPU stages on the
    // two 1-CPU nodes, the third pending for longer than the timeout, all finish. The
    // timeout stays well above a job's own start-up (a job supervisor takes seconds to
    // start on a loaded 2-core machine: 2 s was too tight once in CI).
    let queued: String = (0..3)
        .map(|i| {
            format!(
                "  wait{i}:\n    uses: cmd\n    params: {{command: \"sleep 12; echo {i} > ${{outputs.out}}\"}}\n    outputs: {{out: wait{i}.txt}}\n"
            )
        })
        .collect();
    faults.write("pipelines/queued.yaml", &format!("stages:\n{queued}"));
    let out = ray_run(
        &faults,
        &moto,
        "pipelines/queued.yaml",
        &["--ray-address", &address, "--ray-pending-timeout", "8", "-j", "3"],
    );
    assert_eq!(out.status.code(), Some(0), "{}", describe(&out));

    // The driver killed mid-run: the rerun takes what finished from the lockfile.
    faults.write(
        "pipelines/two.yaml",
        "stages:\n  first:\n    uses: cmd\n    params: {command: \"echo one > ${outputs.out}\"}\n    outputs: {out: one.txt}\n  second:\n    uses: cmd\n    params: {command: \"sleep 2; cat ${inputs.one} > ${outputs.out}\"}\n    inputs: {one: {from: first.out}}\n    outputs: {out: two.txt}\n",
    );
    let mut driver = faults.firecast();
    moto.env(&mut driver);
    let mut driver = driver
        .args([
            "--store",
            "s3://fc-ray/store",
            "pipeline",
            "run",
            "pipelines/two.yaml",
            "--executor",
            "ray",
        ])
        .args(["--ray-address", &address])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !std::fs::read_to_string(faults.path("pipelines/two.lock")).is_ok_and(|t| t.contains("first:")) {
        assert!(Instant::now() < deadline, "stage `first` never finished");
        std::thread::sleep(Duration::from_millis(50));
    }
    driver.kill().unwrap();
    let _ = driver.wait();
    assert!(!faults.path("two.txt").exists());
    let out = ray_run(&faults, &moto, "pipelines/two.yaml", &["--ray-address", &address]);
    assert!(out.status.success(), "{}", describe(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let seen = outcomes(&report);
    assert_eq!(
        seen,
        BTreeMap::from([
            ("first".into(), "up_to_date".into()),
            ("second".into(), "ran".into())
        ])
    );
    assert_eq!(faults.read("two.txt"), "one\n");

    eprintln!(
        "ray test: cluster up in {:.1}s, first pipeline run done at {:.1}s, windows (local, then 2 shards on Ray) in {:.1}s, \
         experiment (dataset and local run {:.1}s, then 2 shards on Ray) in {:.1}s, all done in {:.1}s",
        up.as_secs_f64(),
        first_run.as_secs_f64(),
        windows_run.as_secs_f64(),
        local_experiment.as_secs_f64(),
        experiment_run.as_secs_f64(),
        started.elapsed().as_secs_f64()
    );
    let sessions = cluster.sessions.clone();
    drop(cluster);
    let leftover = RayCluster {
        sessions,
        dashboard_port: 0,
        dir: tempfile::tempdir().unwrap(),
    };
    assert!(leftover.processes().is_empty(), "Ray processes left behind");
}

#[test]
fn ray_executor_bad_input_is_named_before_any_work() {
    let p = Project::new();
    p.write(
        "pipelines/one.yaml",
        "stages:\n  one:\n    uses: cmd\n    params: {command: \"echo > ${outputs.out}\"}\n    outputs: {out: one.txt}\n",
    );
    let port = free_port();
    let out = p
        .firecast()
        .args([
            "pipeline",
            "run",
            "pipelines/one.yaml",
            "--executor",
            "ray",
            "--ray-address",
        ])
        .arg(format!("127.0.0.1:{port}"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", describe(&out));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains(&format!(
            "cannot reach the Ray dashboard at http://127.0.0.1:{port}"
        )),
        "{stderr}"
    );
    assert!(!p.path("one.txt").exists() && !p.path("pipelines/one.lock").exists());

    let out = p
        .firecast()
        .args(["pipeline", "run", "pipelines/one.yaml", "--executor", "ray"])
        .env_remove("FIRECAST_RAY_ADDRESS")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", describe(&out));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--executor ray needs the cluster's dashboard address")
    );

    p.write(
        "firecast.yaml",
        "executor: ray\nray: {address: \"127.0.0.1:1\", atempts: 2}\n",
    );
    let out = p
        .firecast()
        .args(["pipeline", "run", "pipelines/one.yaml"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", describe(&out));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("firecast.yaml:2:") && stderr.contains("atempts"),
        "{stderr}"
    );

    std::fs::remove_file(p.path("firecast.yaml")).unwrap();
    p.write(
        "pipelines/one.yaml",
        "stages:\n  one:\n    uses: cmd\n    shards: 2\n    params: {command: \"echo > ${outputs.out}\"}\n    outputs: {out: one.txt}\n",
    );
    let out = p
        .firecast()
        .args(["pipeline", "status", "pipelines/one.yaml"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("pipelines/one.yaml:4:")
            && stderr
                .contains("stage kind `cmd` cannot be sharded (kinds that can: data.windows, forecast.experiment, sim.episodes)"),
        "{stderr}"
    );
}

#[test]
fn sharded_episodes_equal_unsharded_locally() {
    let whole = Project::new();
    whole.write("pipelines/fire.yaml", PIPELINE);
    let sharded = Project::new();
    sharded.write(
        "pipelines/fire.yaml",
        &PIPELINE.replace("    resources:", "    shards: 3\n    resources:"),
    );
    let mut recorded_by = Vec::new();
    for p in [&whole, &sharded] {
        let report = p.json(&["pipeline", "run", "pipelines/fire.yaml", "--only", "helitack"]);
        assert_eq!(outcomes(&report)["helitack"], "ran", "{report}");
        recorded_by.push(recorded(p, stage_report(&report, "helitack")["run_id"].as_str().unwrap()).0);
    }
    // The shards record the per-episode metrics the unsharded run records.
    assert_eq!(recorded_by[0], recorded_by[1]);
    assert_eq!(recorded_by[0]["cells_burned"][0], 4.0, "{:?}", recorded_by[0]);
    for file in ["build/helitack.json", "build/helitack.trace.json"] {
        assert_eq!(
            std::fs::read(whole.path(file)).unwrap(),
            std::fs::read(sharded.path(file)).unwrap(),
            "{file}"
        );
    }
    assert_eq!(
        lock_without_run_ids(&whole, "pipelines/fire.lock"),
        lock_without_run_ids(&sharded, "pipelines/fire.lock")
    );
    // No part files are left behind.
    assert!(
        !sharded.path(".firecast/shards").exists()
            || std::fs::read_dir(sharded.path(".firecast/shards"))
                .unwrap()
                .count()
                == 0
    );

    sharded.write(
        "pipelines/fire.yaml",
        &PIPELINE.replace("    resources:", "    shards: 5\n    resources:"),
    );
    let out = sharded
        .firecast()
        .args(["pipeline", "status", "pipelines/fire.yaml"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("stages.helitack.shards: 5 shards for 4 episodes: use between 1 and 4"),
        "{stderr}"
    );
}

#[test]
fn sharded_windows_equal_unsharded_locally() {
    let p = windows_project();
    let whole = read_all(&p, WINDOW_FILES);
    let whole_lock = lock_without_run_ids(&p, "pipelines/windows.lock");
    let whole_run = p.json(&["runs", "list", "--stage", "windows"])[0]["run_id"]
        .as_str()
        .unwrap()
        .to_string();
    let (whole_metrics, _) = recorded(&p, &whole_run);
    for key in ["windows", "gridmet_files_read", "samples_with_true_probability"] {
        assert!(whole_metrics.contains_key(key), "{key}: {whole_metrics:?}");
    }
    let sharded = |n: u32| {
        WINDOWS.replace(
            "    uses: data.windows\n",
            &format!("    uses: data.windows\n    shards: {n}\n"),
        )
    };
    for n in [3, 15] {
        p.write("pipelines/windows.yaml", &sharded(n));
        let report = p.json(&[
            "pipeline",
            "run",
            "pipelines/windows.yaml",
            "--force",
            "--only",
            "windows",
        ]);
        assert_eq!(outcomes(&report)["windows"], "ran", "{report}");
        check_windows_equal(&p, &whole, n);
        assert_eq!(lock_without_run_ids(&p, "pipelines/windows.lock"), whole_lock);
        // The merge records the unsharded run's metrics.
        assert_eq!(
            recorded(&p, first_stage_run_id(&report)).0,
            whole_metrics,
            "{n} shards"
        );
        let log = stage_log(&p, first_stage_run_id(&report));
        assert!(
            log.contains(&format!("# shard {}/{n}", n - 1)) && log.contains(&format!("# merged {n} shards")),
            "{log}"
        );
    }
    // The dataset downstream sees the same windows: nothing to do.
    let ran = p.run_pipeline("pipelines/windows.yaml", &[]);
    assert!(ran.values().all(|o| o == "up_to_date"), "{ran:?}");

    p.write("pipelines/windows.yaml", &sharded(16));
    let out = p
        .firecast()
        .args(["pipeline", "status", "pipelines/windows.yaml"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("pipelines/windows.yaml:5:")
            && stderr.contains("stages.windows.shards: 16 shards for 15 variables: use between 1 and 15"),
        "{stderr}"
    );
}
