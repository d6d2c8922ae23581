//! The web app through the real binary: `firecast serve` on a small project (synthetic
//! GRIDMET, a forecaster and a PPO agent trained here), its API from Rust — FireCastRL's
//! endpoints, the probability map, live fires over a websocket, report jobs, the runs
//! browser, bad input and the guards — the CLI working on the project while the server
//! runs, and the page driven in Debian's Chromium by Playwright (tests/browser).

use std::io::{BufRead, BufReader};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::{Project, describe, repo_root, venv_bin};

const DATE: &str = "2019-08-01";

/// Sources, a dataset, a forecaster (logistic regression, two seeds), a tiny agent and its
/// Table IV (with Rerun recordings).
const APP_PIPELINE: &str = r#"
stages:
  sources:
    uses: data.synthesize
    params:
      seed: 5
      region: {lat_min: 39.1, lat_max: 39.5, lon_min: -107.6, lon_max: -107.2}
      years: [2018, 2019]
      variables: [pr, rmax, rmin, sph, srad, tmmn, tmmx, vs, th, bi, fm100, fm1000, erc, etr, pet, vpd]
      ignition_rate_scale: 30
    outputs:
      gridmet: build/app/sources/gridmet
      incidents: build/app/sources/incidents.csv
      model: build/app/sources/MODEL.md
  ignitions:
    uses: data.ignitions
    inputs:
      incidents: {from: sources.incidents}
      gridmet: {from: sources.gridmet}
    outputs:
      ignitions: build/app/ignitions.parquet
      report: build/app/ignitions.json
      rejects: build/app/ignition_rejects.csv
  samples:
    uses: data.negatives
    params:
      variant: paper
      counts: proportional
      seed: 42
      period_start: "2018-03-02"
      period_end: "2019-12-17"
      region: {lat_min: 39.1, lat_max: 39.5, lon_min: -107.6, lon_max: -107.2}
      far_min_km: 4
      near_max_km: 30
    inputs:
      ignitions: {from: ignitions.ignitions}
      gridmet: {from: sources.gridmet}
    outputs:
      samples: build/app/samples.parquet
      report: build/app/samples.json
  windows:
    uses: data.windows
    inputs:
      samples: {from: samples.samples}
      gridmet: {from: sources.gridmet}
    outputs:
      windows: build/app/windows
  dataset:
    uses: data.dataset
    params:
      name: app-ignitions
      framing: {kind: paper}
      split: {method: temporal, test_months: 4}
    inputs:
      windows: {from: windows.windows}
    outputs:
      dataset: build/app/dataset
  forecaster:
    uses: forecast.experiment
    params:
      name: app-forecaster
      protocols:
        leak_free:
          days: [-60, -1]
          split: {method: temporal, test_from: "2019-06-01", val: 0.2, seed: 42}
      headline: leak_free
      seeds: [0, 1]
      evaluation: {bootstrap: 50}
      device: cpu
      models:
        - {kind: logistic_regression}
    inputs:
      dataset: {from: dataset.dataset}
    outputs:
      report: build/app/forecaster
  agent:
    uses: rl.train
    params:
      name: app-agent
      env: {kind: helitack}
      policy: {kind: compact}
      ppo: {preset: paper, n_envs: 2, n_steps: 16, batch_size: 16, n_epochs: 1, total_timesteps: 32}
      seeds: [0]
      device: cpu
    inputs:
      fires: fires.yaml
    outputs:
      run: build/app/agent
  table4:
    uses: rl.evaluate
    params: {resamples: 200, device: cpu}
    inputs:
      run: {from: agent.run}
      fires: fires.yaml
    outputs:
      report: build/app/table4
"#;

/// The threat pipeline's `forecast` stage on the forecaster of `APP_PIPELINE`.
const FORECAST_STAGE: &str = r#"stages:
  forecast:
    uses: forecast.predict
    params: {lat: "${lat}", lon: "${lon}", date: "${date}", model: logistic_regression}
    inputs: {experiment: build/app/forecaster, gridmet: build/app/sources/gridmet}
    outputs: {forecast: build/forecast.json}
"#;

/// A report pipeline that only waits: for the queue's bound.
const SLOW_PIPELINE: &str = r#"
vars:
  lat: 0
  lon: 0
  date: "2019-08-01"
stages:
  wait:
    uses: cmd
    params:
      command: sleep 4 && echo ${lat} ${lon} ${date} > ${outputs.out}
    outputs:
      out: build/slow/${date}.txt
"#;

/// The running server, stopped when dropped (also when a test panics).
struct Server {
    child: Child,
    base: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start(p: &Project, extra: &[&str]) -> Server {
    let addr: &[&str] = if extra.contains(&"--addr") {
        &[]
    } else {
        &["--addr", "127.0.0.1:0"]
    };
    let mut child = p
        .firecast()
        .args(["--json", "serve"])
        .args(addr)
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let ready: serde_json::Value =
        serde_json::from_str(&line).unwrap_or_else(|e| panic!("serve printed `{line}`: {e}"));
    Server {
        child,
        base: format!("http://{}", ready["addr"].as_str().unwrap()),
    }
}

fn client() -> reqwest::blocking::Client {
    reqwest::blocking::Client::builder()
        .timeout(Duration::from_secs(120))
        .build()
        .unwrap()
}

/// Status and JSON body.
fn call(method: reqwest::Method, url: &str) -> (u16, serde_json::Value) {
    let r = client().request(method, url).send().unwrap();
    let status = r.status().as_u16();
    let text = r.text().unwrap();
    (
        status,
        serde_json::from_str(&text).unwrap_or(serde_json::Value::String(text)),
    )
}

fn get(s: &Server, path: &str) -> (u16, serde_json::Value) {
    call(reqwest::Method::GET, &format!("{}{path}", s.base))
}

fn post(s: &Server, path: &str) -> (u16, serde_json::Value) {
    call(reqwest::Method::POST, &format!("{}{path}", s.base))
}

fn error_code(body: &serde_json::Value) -> &str {
    body["error"]["code"]
        .as_str()
        .unwrap_or_else(|| panic!("not an API error: {body}"))
}

/// One decoded live-fire frame.
#[derive(Debug)]
struct Frame {
    step: u32,
    hours: f32,
    burning: u32,
    burnt: u32,
    last: bool,
    changes: Vec<(u32, u8)>,
}

fn parse_frame(b: &[u8]) -> Frame {
    let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap());
    let n = u32_at(24) as usize;
    assert_eq!(b.len(), 28 + 4 * n, "frame length");
    Frame {
        step: u32_at(0),
        hours: f32::from_le_bytes(b[4..8].try_into().unwrap()),
        burning: u32_at(8),
        burnt: u32_at(12),
        last: b[20] & 2 != 0,
        changes: (0..n)
            .map(|k| {
                let c = u32_at(28 + 4 * k);
                (c >> 8, (c & 0xff) as u8)
            })
            .collect(),
    }
}

type Socket = tungstenite::WebSocket<tungstenite::stream::MaybeTlsStream<TcpStream>>;

fn connect(s: &Server, path: &str) -> Socket {
    let url = format!("{}{path}", s.base.replacen("http://", "ws://", 1));
    tungstenite::connect(url.as_str()).unwrap().0
}

/// A whole live fire as fast as the server computes it: start, frames, end.
fn play(
    s: &Server,
    env: &str,
    agent: &str,
    seed: u64,
) -> (serde_json::Value, Vec<Vec<u8>>, serde_json::Value) {
    let mut ws = connect(
        s,
        &format!("/api/environments/{env}/simulate?agent={agent}&seed={seed}"),
    );
    ws.send(tungstenite::Message::text(r#"{"type":"speed","fps":0}"#))
        .unwrap();
    let mut start = serde_json::Value::Null;
    let mut frames = Vec::new();
    loop {
        match ws.read().unwrap() {
            tungstenite::Message::Text(t) => {
                let v: serde_json::Value = serde_json::from_str(t.as_str()).unwrap();
                match v["type"].as_str() {
                    Some("start") => start = v,
                    Some("end") => return (start, frames, v),
                    _ => panic!("unexpected message {v}"),
                }
            }
            tungstenite::Message::Binary(b) => frames.push(b.to_vec()),
            other => panic!("unexpected {other:?}"),
        }
    }
}

fn fixture() -> Project {
    let p = Project::new();
    p.write("pipelines/app.yaml", APP_PIPELINE);
    p.write("fires.yaml", crate::report::FIRES);
    // The report pipeline of the report tests, with the live fires' settings in its vars and
    // the forecast of the place and day asked for (by the forecaster trained here).
    let threat = crate::report::pipeline(39.3, -107.4)
        .replacen(
            "vars:\n",
            "vars:\n  landscape_seed: 2\n  env: {max_steps: 150}\n",
            1,
        )
        .replacen(
            "      forecast: forecast.json\n",
            "      forecast: {from: forecast.forecast}\n",
            1,
        )
        .replacen("stages:\n", FORECAST_STAGE, 1);
    p.write("pipelines/threat.yaml", &threat);
    p.write("forecast.json", &crate::report::forecast(39.3, -107.4));
    p.write("pipelines/slow.yaml", SLOW_PIPELINE);
    let outcomes = p.run_pipeline("pipelines/app.yaml", &[]);
    assert!(outcomes.values().all(|o| o == "ran"), "{outcomes:?}");
    p
}

fn serve_app(p: &Project) -> Server {
    let rerun = venv_bin("rerun");
    start(
        p,
        &[
            "--gridmet",
            "build/app/sources/gridmet",
            "--forecaster",
            "build/app/forecaster",
            "--model",
            "logistic_regression",
            "--agent-run",
            "build/app/agent",
            "--rerun",
            rerun.to_str().unwrap(),
        ],
    )
}

#[test]
fn web_app_end_to_end() {
    let p = fixture();
    let s = serve_app(&p);

    // FireCastRL's endpoints keep their shapes.
    let (code, health) = get(&s, "/api/health");
    assert_eq!((code, health["status"].as_str()), (200, Some("ok")));
    let (code, cov) = get(&s, "/api/coverage");
    assert_eq!(code, 200, "{cov}");
    assert!((cov["lat_min"].as_f64().unwrap() - 39.1).abs() < 0.05, "{cov}");
    assert!((cov["lon_max"].as_f64().unwrap() + 107.2).abs() < 0.05, "{cov}");
    assert_eq!(cov["first_date"], "2018-01-01");
    assert_eq!(cov["last_date"], "2019-12-31");
    assert_eq!(cov["agents"][0]["id"], "ppo");
    // The fixture's agent has no window around the helicopter: the page says what that means
    // on the live map.
    let note = cov["agents"][0]["reason"].as_str().unwrap_or_default();
    assert!(note.contains("whole map scaled"), "{note}");
    assert_eq!(cov["agents"][0]["available"], true, "{cov}");
    let png = client()
        .get(format!("{}/api/basemap.png", s.base))
        .send()
        .unwrap()
        .bytes()
        .unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");

    let (code, f) = post(
        &s,
        &format!("/api/predictWildfire?lat=39.3&lon=-107.4&date={DATE}"),
    );
    assert_eq!(code, 200, "{f}");
    let prob = f["probability"].as_f64().unwrap();
    assert_eq!(f["prediction"].as_f64(), Some(prob));
    assert_eq!(
        (f["lat"].as_f64(), f["lon"].as_f64(), f["date"].as_str()),
        (Some(39.3), Some(-107.4), Some(DATE))
    );
    let [lo, hi] = [
        f["interval"][0].as_f64().unwrap(),
        f["interval"][1].as_f64().unwrap(),
    ];
    assert!((0.0..=1.0).contains(&prob) && lo <= prob && prob <= hi, "{f}");
    assert_eq!(f["model"], "logistic_regression");
    // Logistic regression is deterministic: the experiment keeps one bundle for its seeds.
    assert!(!f["per_seed"].as_array().unwrap().is_empty(), "{f}");
    // The CLI's forecast of the same place and day through `forecast.predict`.
    p.write(
        "pipelines/predict.yaml",
        &format!(
            "stages:\n  point:\n    uses: forecast.predict\n    params: {{lat: 39.3, lon: -107.4, date: \"{DATE}\", model: logistic_regression}}\n    inputs: {{experiment: build/app/forecaster, gridmet: build/app/sources/gridmet}}\n    outputs: {{forecast: build/app/point.json}}\n"
        ),
    );
    p.run_pipeline("pipelines/predict.yaml", &[]);
    let cli: serde_json::Value = serde_json::from_str(&p.read("build/app/point.json")).unwrap();
    assert_eq!(
        cli["probability"].as_f64(),
        Some(prob),
        "the page and the pipeline disagree"
    );

    // The map: every GRIDMET cell of the data; the clicked cell is the point forecast.
    let (code, map) = get(&s, &format!("/api/probabilityMap?date={DATE}"));
    assert_eq!(code, 200, "{map}");
    let lats: Vec<f64> = serde_json::from_value(map["lats"].clone()).unwrap();
    let lons: Vec<f64> = serde_json::from_value(map["lons"].clone()).unwrap();
    let row = lats
        .iter()
        .position(|&l| (l - f["cell_lat"].as_f64().unwrap()).abs() < 1e-6)
        .unwrap();
    let col = lons
        .iter()
        .position(|&l| (l - f["cell_lon"].as_f64().unwrap()).abs() < 1e-6)
        .unwrap();
    let cell = map["probability"][row][col].as_f64().unwrap();
    assert!((cell - prob).abs() < 1e-9, "map {cell} vs point {prob}");
    assert_eq!(map["probability"].as_array().unwrap().len(), lats.len());

    // Bad input: a clear message and a stable code; the server keeps serving.
    for (query, want) in [
        ("lat=45&lon=-107.4&date=2019-08-01", "outside_data"),
        ("lat=39.3&lon=-107.4&date=2021-08-01", "no_weather"),
        ("lat=39.3&lon=-107.4&date=2019-02-30", "bad_request"),
        ("lon=-107.4&date=2019-08-01", "bad_request"),
        ("lat=north&lon=-107.4&date=2019-08-01", "bad_request"),
    ] {
        let (code, body) = post(&s, &format!("/api/predictWildfire?{query}"));
        assert_eq!((code, error_code(&body)), (400, want), "{query}: {body}");
        assert!(!body["error"]["message"].as_str().unwrap().is_empty());
    }
    let (code, body) = post(&s, "/api/predictWildfire?lat=45&lon=-107.4&date=2019-08-01");
    assert!(
        body["error"]["message"]
            .as_str()
            .unwrap()
            .contains("outside the data"),
        "{code} {body}"
    );

    // The fire's environment, then live fires.
    let (code, env) = post(
        &s,
        &format!("/api/createEnvironment?lat=39.3&lon=-107.4&date={DATE}"),
    );
    assert_eq!(code, 200, "{env}");
    assert_eq!(
        (env["width"].as_u64(), env["height"].as_u64()),
        (Some(240), Some(160))
    );
    assert_eq!(env["max_steps"], 150);
    let id = env["id"].as_str().unwrap().to_string();
    let cells = 240 * 160;

    let (start, frames, end) = play(&s, &id, "rule", 3);
    assert_eq!(start["agent"], "rule");
    assert!(
        frames.len() >= 2 && frames.len() <= 151,
        "{} frames",
        frames.len()
    );
    let mut state = vec![0u8; cells];
    let mut last_area = 0;
    for (k, bytes) in frames.iter().enumerate() {
        let fr = parse_frame(bytes);
        assert_eq!(fr.step as usize, k);
        for &(c, st) in &fr.changes {
            assert!((c as usize) < cells && st <= 3, "change {c} {st}");
            state[c as usize] = st;
        }
        let burning = state.iter().filter(|&&x| x == 1).count() as u32;
        let burnt = state.iter().filter(|&&x| x == 2).count() as u32;
        assert_eq!(
            (burning, burnt),
            (fr.burning, fr.burnt),
            "frame {k}: the changes add up to the counts"
        );
        assert!(fr.burnt >= last_area, "burnt area never shrinks");
        last_area = fr.burnt;
        assert_eq!(fr.last, k + 1 == frames.len());
        assert!(fr.hours >= 0.0);
    }
    let final_frame = parse_frame(frames.last().unwrap());
    assert_eq!(
        end["burnt_cells"].as_u64(),
        Some(u64::from(final_frame.burnt + final_frame.burning))
    );
    assert!(
        end["drops"].as_u64().unwrap() > 0,
        "the rule-based plan drops: {end}"
    );
    // Same fire, same seed: the same frames, byte for byte.
    let (_, again, _) = play(&s, &id, "rule", 3);
    assert_eq!(frames, again);
    // No suppression burns at least as much as the plan on the same fire.
    let (_, free, free_end) = play(&s, &id, "none", 3);
    assert!(
        free_end["burnt_cells"].as_u64() >= end["burnt_cells"].as_u64(),
        "{free_end} vs {end}"
    );
    assert_eq!(
        parse_frame(&free[0]).changes,
        parse_frame(&frames[0]).changes,
        "one ignition for both"
    );
    // The trained agent plays it too.
    let (start, ppo, _) = play(&s, &id, "ppo", 3);
    assert_eq!(start["agent"], "ppo");
    assert!(ppo.len() >= 2);

    // A malformed message closes that socket with a reason, not the server.
    let mut ws = connect(&s, &format!("/api/environments/{id}/simulate?agent=none"));
    ws.send(tungstenite::Message::text("{\"type\":\"rewind\"}"))
        .unwrap();
    let closed = loop {
        match ws.read() {
            Ok(tungstenite::Message::Close(Some(frame))) => break Some(frame),
            Ok(tungstenite::Message::Close(None)) => break None,
            Ok(_) => continue,
            Err(_) => break None,
        }
    };
    let frame = closed.expect("a close frame with a reason");
    assert_eq!(u16::from(frame.code), 1008);
    assert!(frame.reason.as_str().contains("protocol"), "{}", frame.reason);
    // A client that leaves mid-fire frees its slot.
    let mut ws = connect(&s, &format!("/api/environments/{id}/simulate?agent=none"));
    let _ = ws.read().unwrap();
    drop(ws);
    let freed = Instant::now();
    while get(&s, "/api/health").1["live_fires"] != 0 {
        assert!(
            freed.elapsed() < Duration::from_secs(10),
            "the fire of a closed socket still runs"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(get(&s, "/api/environments/nope/landscape.png").0, 404);

    // Guards: other origins cannot start work; oversized bodies are refused.
    let r = client()
        .post(format!(
            "{}/api/createEnvironment?lat=39.3&lon=-107.4&date={DATE}",
            s.base
        ))
        .header("Origin", "http://evil.example")
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 403);
    let r = client()
        .post(format!(
            "{}/api/predictWildfire?lat=39.3&lon=-107.4&date={DATE}",
            s.base
        ))
        .body(vec![b'x'; 100_000])
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 413);

    // The runs browser on this project's runs.
    let (code, page) = get(&s, "/api/runs?limit=5&sort=started_at&order=asc");
    assert_eq!(code, 200, "{page}");
    assert!(page["total"].as_u64().unwrap() >= 8, "{page}");
    assert_eq!(page["runs"].as_array().unwrap().len(), 5);
    let (_, found) = get(&s, "/api/runs?q=rl.train");
    let agent_run = found["runs"][0]["run_id"].as_str().unwrap().to_string();
    assert_eq!(found["runs"][0]["stage"], "agent");
    let (code, details) = get(&s, &format!("/api/runs/{agent_run}"));
    assert_eq!(code, 200, "{details}");
    assert_eq!(details["log"], true);
    let key = details["metrics"][0]["key"].as_str().unwrap().to_string();
    let (_, series) = get(&s, &format!("/api/runs/{agent_run}/metrics/{key}"));
    assert_eq!(
        series["values"]
            .as_array()
            .unwrap_or_else(|| panic!("{key}: {series}"))
            .len() as u64,
        details["metrics"][0]["count"].as_u64().unwrap()
    );
    let log = client()
        .get(format!("{}/api/runs/{agent_run}/log", s.base))
        .send()
        .unwrap()
        .text()
        .unwrap();
    assert_eq!(log, crate::stage_log(&p, &agent_run));
    let rrd = client()
        .get(format!("{}/api/runs/{agent_run}/artifacts/metrics", s.base))
        .send()
        .unwrap();
    assert_eq!(rrd.status().as_u16(), 200);
    let on_disk = std::fs::read(p.path(&format!("artifacts/runs/{agent_run}/metrics/metrics.rrd"))).unwrap();
    assert_eq!(rrd.bytes().unwrap().to_vec(), on_disk);
    for bad in ["metrics/../../registry", "metrics/%2E%2E/x", "nope"] {
        let code = get(&s, &format!("/api/runs/{agent_run}/artifacts/{bad}")).0;
        assert!(code == 400 || code == 404, "{bad}: {code}");
    }
    assert_eq!(error_code(&get(&s, "/api/runs/not-a-run").1), "not_found");
    let forecaster_run = get(&s, "/api/runs?q=forecast.experiment").1["runs"][0]["run_id"]
        .as_str()
        .unwrap()
        .to_string();
    let (code, cmp) = get(&s, &format!("/api/compare?ids={agent_run},{forecaster_run}"));
    assert_eq!(code, 200, "{cmp}");
    assert!(
        cmp["differing"].as_array().unwrap().iter().any(|d| d == "name"),
        "{cmp}"
    );
    result_pages(&s, &agent_run, &forecaster_run);

    let csv = client()
        .get(format!("{}/api/runs.csv", s.base))
        .send()
        .unwrap()
        .text()
        .unwrap();
    assert!(csv.starts_with("run_id,"));
    assert_eq!(
        csv.lines().count() as u64,
        get(&s, "/api/runs").1["total"].as_u64().unwrap() + 1
    );

    // A report job: the threat pipeline through the same engine, cache and registry; the
    // CLI reads the registry while the job's `pipeline run` writes it, and the server too.
    let (code, job) = post(&s, &format!("/api/jobs/threat?lat=39.3&lon=-107.4&date={DATE}"));
    assert_eq!(code, 202, "{job}");
    let job_id = job["id"].as_str().unwrap().to_string();
    let began = Instant::now();
    let done = loop {
        let (_, j) = get(&s, &format!("/api/jobs/{job_id}"));
        assert_eq!(
            get(&s, "/api/runs?limit=1").0,
            200,
            "the runs page answers during the job"
        );
        p.ok(&["runs", "list", "--limit", "1"]);
        if j["status"] == "succeeded" || j["status"] == "failed" {
            break j;
        }
        assert!(began.elapsed() < Duration::from_secs(600), "job still {j}");
        std::thread::sleep(Duration::from_millis(500));
    };
    assert_eq!(done["status"], "succeeded", "{done}");
    assert_eq!(done["stages_done"], done["stages_total"]);
    let html = client()
        .get(format!("{}{}", s.base, done["files"]["html"].as_str().unwrap()))
        .send()
        .unwrap()
        .text()
        .unwrap();
    assert_eq!(
        html,
        p.read(&format!(
            "{}/report.html",
            crate::report::report_dir(39.3, -107.4, DATE)
        ))
    );
    let (code, again) = post(&s, &format!("/api/jobs/threat?lat=39.3&lon=-107.4&date={DATE}"));
    assert_eq!(
        (code, again["id"].as_str()),
        (202, Some(job_id.as_str())),
        "the same place and day is the same job"
    );

    // A card is shown as text: markup in it must not reach the page as markup.
    let card = p.read("build/app/dataset/card.md");
    p.write(
        "build/app/dataset/card.md",
        &format!("{card}\n## Markup stays text\n\n{HOSTILE_MARKDOWN}\n"),
    );

    browser_flow(&p, &s);
}

/// Markdown with HTML and script links, appended to the fixture's dataset card: the page
/// shows it as text (tests/browser/test_app.py checks that nothing of it ran).
const HOSTILE_MARKDOWN: &str = "<script>window.__pwned = 1</script> <img src=x onerror=\"window.__pwned = 2\"> \
[a script link](javascript:window.__pwned=3) ![an image](javascript:alert(1)) <b>not bold</b>";

/// A file the server answers, with its status and content type.
fn fetch(s: &Server, path: &str) -> (u16, String, Vec<u8>) {
    let r = client().get(format!("{}{path}", s.base)).send().unwrap();
    let status = r.status().as_u16();
    let kind = r
        .headers()
        .get("content-type")
        .map(|v| v.to_str().unwrap().to_string())
        .unwrap_or_default();
    (status, kind, r.bytes().unwrap().to_vec())
}

const PNG: &[u8] = b"\x89PNG\r\n\x1a\n";

/// Table III and Table IV of the fixture's runs with their plots and recordings, the
/// datasets, runs grouped by a parameter and Rerun's viewer; paths that leave an output or a
/// dataset folder are refused.
fn result_pages(s: &Server, agent_run: &str, forecaster_run: &str) {
    let (code, t3) = get(s, "/api/tables/forecast");
    assert_eq!(code, 200, "{t3}");
    assert_eq!(
        t3["run"]["run_id"], forecaster_run,
        "the only forecast.experiment run"
    );
    assert_eq!(t3["output"]["path"], "build/app/forecaster");
    assert_eq!(t3["results"]["headline"], "leak_free");
    assert_eq!(t3["results"]["dataset"], "app-ignitions");
    let row = t3["results"]["results"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["model"] == "logistic_regression" && r["protocol"] == "leak_free")
        .unwrap_or_else(|| panic!("no logistic regression row: {t3}"));
    for metric in ["accuracy", "f1", "auroc", "auprc", "brier", "ece"] {
        let v = row["test"][metric].as_f64().unwrap();
        let [lo, hi] = [0, 1].map(|k| row["intervals"][metric][k].as_f64().unwrap());
        assert!(
            lo <= v + 1e-9 && v <= hi + 1e-9,
            "{metric}: {v} not in [{lo}, {hi}]"
        );
    }
    assert_eq!(
        t3["runs"].as_array().unwrap().len(),
        1,
        "the runs to pick from: {t3}"
    );
    let plots: Vec<&str> = t3["plots"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_str().unwrap())
        .collect();
    let roc = plots
        .iter()
        .find(|p| p.starts_with("plots/roc_leak_free"))
        .unwrap_or_else(|| panic!("no ROC plot in {plots:?}"));
    let (code, kind, png) = fetch(s, &format!("/api/runs/{forecaster_run}/outputs/report/{roc}"));
    assert_eq!((code, kind.as_str(), &png[..8]), (200, "image/png", PNG));
    assert_eq!(
        get(s, &format!("/api/tables/forecast?run={forecaster_run}")).0,
        200
    );

    let (code, t4) = get(s, "/api/tables/rl");
    assert_eq!(code, 200, "{t4}");
    let eval_run = t4["run"]["run_id"].as_str().unwrap().to_string();
    assert_eq!(t4["run"]["stage"], "table4");
    let agents: Vec<&str> = t4["evaluation"]["agents"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["agent"].as_str().unwrap())
        .collect();
    for agent in ["ppo", "rule", "none"] {
        assert!(agents.contains(&agent), "{agent} missing from {agents:?}");
    }
    for a in t4["evaluation"]["agents"].as_array().unwrap() {
        let m = &a["cells_burned"]["mean"];
        let [lo, v, hi] = ["low", "estimate", "high"].map(|k| m[k].as_f64().unwrap());
        assert!(lo <= v && v <= hi, "{a}");
    }
    assert!(
        t4["evaluation"]["comparisons"]
            .as_array()
            .unwrap()
            .iter()
            .any(|c| c["agent"] == "ppo" && c["baseline"] == "none"),
        "{t4}"
    );
    assert!(
        t4["plots"].as_array().unwrap().iter().any(|p| p == "table4.png"),
        "{t4}"
    );
    // The recordings are artifacts of the run, served under their own file name (Rerun's
    // viewer tells the format from the URL's end).
    let recordings = t4["recordings"].as_array().unwrap();
    assert!(
        recordings
            .iter()
            .any(|r| r["artifact"].as_str().unwrap().starts_with("recording/")),
        "{t4}"
    );
    for r in recordings {
        let name = r["artifact"].as_str().unwrap().replace('/', "%2F");
        let file = r["file"].as_str().unwrap();
        assert!(file.ends_with(".rrd"), "{r}");
        let (code, _, bytes) = fetch(s, &format!("/api/runs/{eval_run}/artifacts/{name}/{file}"));
        assert_eq!(code, 200, "{r}");
        assert_eq!(bytes.len() as u64, r["size"].as_u64().unwrap(), "{r}");
    }

    // A run of the other kind, an unknown run, a malformed id.
    for path in [
        format!("/api/tables/forecast?run={eval_run}"),
        format!("/api/tables/rl?run={forecaster_run}"),
        format!("/api/tables/rl?run={agent_run}"),
        "/api/tables/rl?run=..%2F..%2Fetc".to_string(),
        "/api/tables/forecast?run=x&other=1".to_string(),
    ] {
        let (code, body) = get(s, &path);
        assert_eq!((code, error_code(&body)), (400, "bad_request"), "{path}: {body}");
    }
    let (code, body) = get(s, "/api/tables/forecast?run=20990101T000000000-abcdef");
    assert_eq!((code, error_code(&body)), (404, "not_found"), "{body}");
    // A run's files: only inside its outputs, only inside the project.
    for bad in [
        "report/..%2F..%2FCargo.toml",
        "report/..%2F..%2F..%2F..%2Fetc%2Fpasswd",
        "report/plots%2F..%2F..%2F..%2Fpipelines%2Fapp.yaml",
    ] {
        let (code, body) = get(s, &format!("/api/runs/{forecaster_run}/outputs/{bad}"));
        assert_eq!((code, error_code(&body)), (400, "bad_request"), "{bad}: {body}");
    }
    let (code, body) = get(
        s,
        &format!("/api/runs/{forecaster_run}/outputs/nope/results.json"),
    );
    assert_eq!((code, error_code(&body)), (404, "not_found"), "{body}");
    let (code, results) = get(
        s,
        &format!("/api/runs/{forecaster_run}/outputs/report/results.json"),
    );
    assert_eq!((code, &results["headline"]), (200, &t3["results"]["headline"]));

    // Datasets: the list, one with its card, map, statistics and versions.
    let (code, list) = get(s, "/api/datasets");
    assert_eq!(code, 200, "{list}");
    assert!(
        list["datasets"]
            .as_array()
            .unwrap()
            .iter()
            .any(|d| d["name"] == "app-ignitions" && d["card"] == true),
        "{list}"
    );
    let (code, ds) = get(s, "/api/datasets/app-ignitions");
    assert_eq!(code, 200, "{ds}");
    assert!(
        ds["card"].as_str().unwrap().starts_with("# app-ignitions"),
        "{ds}"
    );
    assert_eq!(ds["manifest"]["name"], "app-ignitions");
    assert_eq!(ds["versions"][0]["on_disk"], true);
    assert_eq!(ds["versions"][0]["version"], ds["on_disk"]);
    let dataset_run = get(s, "/api/runs?q=data.dataset").1["runs"][0]["run_id"].clone();
    assert_eq!(ds["versions"][0]["run_id"], dataset_run);
    let features = ds["stats"]["features"].as_array().unwrap();
    assert!(
        features
            .iter()
            .any(|f| f["split"] == "train" && f["rows"].as_u64() > Some(0)),
        "{ds}"
    );
    assert!(
        ds["files"].as_array().unwrap().iter().any(|f| f == "map.png"),
        "{ds}"
    );
    let (code, kind, png) = fetch(s, "/api/datasets/app-ignitions/files/map.png");
    assert_eq!((code, kind.as_str(), &png[..8]), (200, "image/png", PNG));
    let (code, body) = get(s, "/api/datasets/no-such-dataset");
    assert_eq!((code, error_code(&body)), (404, "not_found"), "{body}");
    let (code, body) = get(s, "/api/datasets/bad%20name%3B");
    assert_eq!((code, error_code(&body)), (400, "bad_request"), "{body}");
    for bad in [
        "..%2F..%2FCargo.toml",
        "..%2F..%2F..%2Fpipelines%2Fapp.yaml",
        "parquet",
    ] {
        let (code, body) = get(s, &format!("/api/datasets/app-ignitions/files/{bad}"));
        assert!(
            (code == 400 || code == 404) && body["error"]["code"].is_string(),
            "{bad}: {code} {body}"
        );
    }

    // Runs grouped by a parameter: every run in one group, a mean per metric.
    let ids = format!("{agent_run},{forecaster_run},{eval_run}");
    let (code, cmp) = get(s, &format!("/api/compare?ids={ids}&group=name"));
    assert_eq!(code, 200, "{cmp}");
    let grouped = &cmp["grouped"];
    assert_eq!(grouped["param"], "name");
    let groups = grouped["groups"].as_array().unwrap();
    assert_eq!(groups.len(), 3, "{grouped}");
    let mut members: Vec<&str> = groups
        .iter()
        .flat_map(|g| g["runs"].as_array().unwrap())
        .map(|r| r.as_str().unwrap())
        .collect();
    members.sort_unstable();
    let mut want = vec![agent_run, forecaster_run, eval_run.as_str()];
    want.sort_unstable();
    assert_eq!(members, want);
    let agent_group = groups.iter().find(|g| g["runs"][0] == agent_run).unwrap();
    assert_eq!(agent_group["value"], "app-agent");
    let (key, m) = agent_group["metrics"].as_object().unwrap().iter().next().unwrap();
    assert_eq!(m["n"], 1, "{key}: {m}");
    assert!(
        m["mean"].is_number() && m["low"].is_null(),
        "one run, no interval: {m}"
    );
    let (code, body) = get(s, &format!("/api/compare?ids={ids}&grouping=name"));
    assert_eq!((code, error_code(&body)), (400, "bad_request"), "{body}");

    // Rerun's viewer, from this server, offline.
    let (code, kind, page) = fetch(s, "/rerun/");
    assert_eq!((code, kind.as_str()), (200, "text/html; charset=utf-8"));
    let page = String::from_utf8(page).unwrap();
    assert!(page.contains("re_viewer.js"), "{page}");
    assert!(!page.contains("fonts.googleapis") && !page.contains("fonts.gstatic"));
    let (code, kind, wasm) = fetch(s, "/rerun/re_viewer_bg.wasm");
    assert_eq!(
        (code, kind.as_str(), &wasm[..4]),
        (200, "application/wasm", &b"\0asm"[..])
    );
    for bad in [
        "/rerun/evil.js",
        "/rerun/..%2F..%2FCargo.toml",
        "/rerun/index.html%00",
    ] {
        assert_eq!(fetch(s, bad).0, 404, "{bad}");
    }
}

/// The page in Chromium (tests/browser/test_app.py): click a place, the forecast and the
/// map, a live fire with two agents, the report, the runs pages. Screenshots land in
/// `$CARGO_TARGET_TMPDIR/browser-screenshots`.
fn browser_flow(p: &Project, s: &Server) {
    let shots = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("browser-screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    let out = Command::new(venv_bin("python"))
        .args(["-m", "pytest", "-x", "-q", "-p", "no:cacheprovider"])
        .arg(repo_root().join("tests/browser"))
        .env("FIRECAST_URL", &s.base)
        .env("FIRECAST_SCREENSHOTS", &shots)
        .output()
        .unwrap();
    if !out.status.success() {
        // The report jobs' logs say why a report never came.
        let jobs = p.path(".firecast/serve/jobs");
        let logs: Vec<String> = std::fs::read_dir(&jobs)
            .into_iter()
            .flatten()
            .flatten()
            .filter(|e| e.path().extension().is_some_and(|x| x == "log"))
            .map(|e| {
                format!(
                    "{}:\n{}",
                    e.path().display(),
                    std::fs::read_to_string(e.path()).unwrap_or_default()
                )
            })
            .collect();
        panic!(
            "browser tests failed:\n{}\njob logs:\n{}",
            describe(&out),
            logs.join("\n")
        );
    }
}

#[test]
fn the_report_queue_is_bounded_and_other_addresses_need_a_token() {
    let p = Project::new();
    p.write("pipelines/slow.yaml", SLOW_PIPELINE);
    // No data: the server still starts and says why each page is empty.
    let s = start(&p, &["--threat", "pipelines/slow.yaml"]);
    let (code, body) = get(&s, "/api/coverage");
    assert_eq!((code, error_code(&body)), (400, "no_weather"), "{body}");
    assert!(
        body["error"]["message"].as_str().unwrap().contains("GRIDMET"),
        "{body}"
    );
    let (code, body) = get(&s, "/api/runs");
    assert_eq!((code, body["total"].as_u64()), (200, Some(0)), "{body}");
    drop(s);

    // One job runs, one waits, the third is told to come back.
    p.write(
        "pipelines/sources.yaml",
        "stages:\n  sources:\n    uses: data.synthesize\n    params: {seed: 1, region: {lat_min: 39.1, lat_max: 39.3, lon_min: -107.6, lon_max: -107.4}, years: [2019, 2019], variables: [vs, th]}\n    outputs: {gridmet: build/g, incidents: build/i.csv, model: build/m.md}\n",
    );
    p.run_pipeline("pipelines/sources.yaml", &[]);
    let s = start(
        &p,
        &[
            "--threat",
            "pipelines/slow.yaml",
            "--max-jobs",
            "1",
            "--gridmet",
            "build/g",
        ],
    );
    let codes: Vec<u16> = ["39.15", "39.2", "39.25"]
        .iter()
        .map(|lat| {
            post(
                &s,
                &format!("/api/jobs/threat?lat={lat}&lon=-107.5&date=2019-08-01"),
            )
            .0
        })
        .collect();
    assert_eq!(codes, [202, 202, 429]);
    let (code, body) = post(&s, "/api/jobs/threat?lat=39.25&lon=-107.5&date=2019-08-01");
    assert_eq!((code, error_code(&body)), (429, "busy"));
    drop(s);

    let out = p
        .firecast()
        .args(["serve", "--addr", "0.0.0.0:0", "--token", ""])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--token is empty"),
        "{}",
        describe(&out)
    );
    let s = start(&p, &["--addr", "127.0.0.1:0", "--token", "s3cret"]);
    assert_eq!(error_code(&get(&s, "/api/health").1), "unauthorized");
    let r = client()
        .get(format!("{}/api/health", s.base))
        .bearer_auth("s3cret")
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 200);
    let r = client().get(format!("{}/?token=s3cret", s.base)).send().unwrap();
    assert!(
        r.headers()["set-cookie"]
            .to_str()
            .unwrap()
            .starts_with("firecast_token=s3cret")
    );
}
