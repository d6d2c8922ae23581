//! Pipeline semantics: caching, strict YAML errors, interruption, parallelism, failures.

use std::time::{Duration, Instant};

use crate::{Project, describe, outcomes, repo_root, stage_report};

const CHAIN: &str = r#"
vars:
  greeting: hello
stages:
  source:
    uses: cmd
    params:
      command: printf '%s\n' "${greeting}" > ${outputs.text}
    outputs:
      text: build/source.txt
  shout:
    uses: cmd
    params:
      command: tr a-z A-Z < ${inputs.text} > ${outputs.text}
      env: {SUFFIX: "!"}
    inputs:
      text: {from: source.text}
    outputs:
      text: build/shout.txt
  count:
    uses: cmd
    params:
      command: wc -c < ${inputs.text} > ${outputs.n}
    inputs:
      text: {from: shout.text}
    outputs:
      n: build/count.txt
"#;

fn all(map: &std::collections::BTreeMap<String, String>, outcome: &str) -> bool {
    map.values().all(|o| o == outcome)
}

#[test]
fn second_run_skips_everything_and_param_changes_rerun_only_dependents() {
    let p = Project::new();
    p.write("pipelines/chain.yaml", CHAIN);

    let first = p.run_pipeline("pipelines/chain.yaml", &[]);
    assert!(all(&first, "ran"), "{first:?}");
    assert_eq!(p.read("build/shout.txt"), "HELLO\n");

    let second = p.run_pipeline("pipelines/chain.yaml", &[]);
    assert!(all(&second, "up_to_date"), "{second:?}");

    // Changing a stage param reruns that stage; downstream reruns only if its input changed.
    let changed = p.run_pipeline("pipelines/chain.yaml", &["-S", "shout.env.SUFFIX=?"]);
    assert_eq!(changed["source"], "up_to_date");
    assert_eq!(changed["shout"], "ran");
    assert_eq!(
        changed["count"], "up_to_date",
        "same bytes out of `shout`: early cutoff"
    );

    // A var change reruns the chain; reverting it is a cache hit again (restored, not rerun).
    let changed = p.run_pipeline("pipelines/chain.yaml", &["-S", "greeting=bonjour"]);
    assert!(all(&changed, "ran"), "{changed:?}");
    assert_eq!(p.read("build/shout.txt"), "BONJOUR\n");
    let reverted = p.run_pipeline("pipelines/chain.yaml", &[]);
    assert_eq!(reverted["source"], "restored");
    assert_eq!(reverted["shout"], "restored");
    assert_eq!(reverted["count"], "restored");
    assert_eq!(p.read("build/shout.txt"), "HELLO\n");

    // A deleted output is restored from the run-cache; nothing downstream reruns.
    std::fs::remove_file(p.path("build/shout.txt")).unwrap();
    let after_delete = p.run_pipeline("pipelines/chain.yaml", &[]);
    assert_eq!(after_delete["shout"], "restored");
    assert_eq!(after_delete["count"], "up_to_date");
    assert_eq!(p.read("build/shout.txt"), "HELLO\n");

    // A hand-edited output is detected and replaced.
    p.write("build/count.txt", "garbage");
    let after_edit = p.run_pipeline("pipelines/chain.yaml", &[]);
    assert_eq!(after_edit["count"], "restored");
    assert_eq!(p.read("build/count.txt").trim(), "6");

    // --force runs everything.
    let forced = p.run_pipeline("pipelines/chain.yaml", &["--force"]);
    assert!(all(&forced, "ran"), "{forced:?}");

    // The lockfile records cache keys and hashes per stage.
    let lock = p.read("pipelines/chain.lock");
    assert!(lock.starts_with("schema: firecast-lock/1"), "{lock}");
    for key in ["cache_key:", "hash:", "build/shout.txt", "run_id:"] {
        assert!(lock.contains(key), "lockfile lacks {key}:\n{lock}");
    }
}

#[test]
fn status_and_dry_run_explain_why() {
    let p = Project::new();
    p.write("pipelines/chain.yaml", CHAIN);
    let status = p.json(&["pipeline", "status", "pipelines/chain.yaml"]);
    let stages = status["stages"].as_array().unwrap();
    assert_eq!(stages[0]["outcome"], "would_run");
    assert_eq!(stages[0]["reasons"][0], "never run");
    assert_eq!(stages[1]["reasons"][0], "upstream `source` will run");
    assert!(
        !p.path("build/source.txt").exists(),
        "status must not run anything"
    );

    p.run_pipeline("pipelines/chain.yaml", &[]);
    let dry = p.json(&[
        "pipeline",
        "run",
        "--dry-run",
        "pipelines/chain.yaml",
        "-S",
        "greeting=hi",
    ]);
    let source = &dry["stages"][0];
    assert_eq!(source["outcome"], "would_run");
    let reasons: Vec<&str> = source["reasons"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r.as_str().unwrap())
        .collect();
    assert!(
        reasons.contains(&r#"param `command` changed: "printf '%s\\n' \"hello\" > ${outputs.text}" -> "printf '%s\\n' \"hi\" > ${outputs.text}""#),
        "{reasons:?}"
    );
    assert_eq!(
        p.read("build/source.txt"),
        "hello\n",
        "dry run must not run anything"
    );

    let text = p.ok(&["pipeline", "status", "pipelines/chain.yaml"]);
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(
        text.contains("chain: 0 stale, 0 restorable from cache, 3 up to date"),
        "{text}"
    );
}

#[test]
fn strict_yaml_errors_name_file_line_and_key_path() {
    let p = Project::new();
    let cases = [
        (
            "stages:\n  a:\n    uses: cmd\n    parms: {command: x}\n",
            "error: pipelines/bad.yaml:4:5: stages.a.parms: unknown field `parms`, expected one of `uses`, `description`, `params`, `inputs`, `outputs`, `foreach`, `matrix`, `always_run`, `resources`, `shards`",
        ),
        (
            "stages:\n  a:\n    uses: cmd\n    always_run: sometimes\n    params: {command: x}\n",
            "error: pipelines/bad.yaml:4:17: stages.a.always_run: invalid type: string \"sometimes\", expected a boolean",
        ),
        (
            "stages:\n  a:\n    uses: cmd\n    params:\n      command: x\n      retries: 3\n",
            "error: pipelines/bad.yaml:6:7: stages.a.params.retries: unknown field `retries`, expected `command` or `env`",
        ),
        (
            "stages:\n  a:\n    uses: cmd\n    params: {command: x}\n    inputs:\n      data: {from: nowhere.table}\n",
            "error: pipelines/bad.yaml:6:7: stages.a.inputs.data: no stage `nowhere` (stages: a)",
        ),
        (
            "stages:\n  a:\n    uses: cmd\n    params: {command: x}\n    inputs: {x: {from: b.out}}\n    outputs: {out: a.txt}\n  b:\n    uses: cmd\n    params: {command: x}\n    inputs: {x: {from: a.out}}\n    outputs: {out: b.txt}\n",
            "error: pipelines/bad.yaml:2:3: stages.a: dependency cycle: `a` needs `b`, which needs `a`",
        ),
        (
            "stages:\n  a:\n    uses: cmd\n    params: {command: cat ${inputs.x} > out}\n",
            "error: pipelines/bad.yaml:4:28: stages.a.params: did not find expected ',' or '}' (hint: quote values that contain `${...}` inside `{...}`)",
        ),
        (
            "stages:\n  a:\n    uses: gridmet.nope\n",
            "error: pipelines/bad.yaml:3:5: stages.a.uses: unknown stage kind `gridmet.nope` (known: cmd, data.dataset, data.ignitions, data.import_kaggle, data.negatives, data.synthesize, data.windows, forecast.cell_days, forecast.evaluate, forecast.experiment, forecast.predict, report, rl.ensemble, rl.evaluate, rl.train, sim.behavior, sim.ensemble, sim.episodes, sim.render, sql)",
        ),
        (
            "stages:\n  a:\n    uses: cmd\n    params: {command: \"echo ${nope}\"}\n",
            "error: pipelines/bad.yaml:4:5: stages.a.params.command: unknown variable `nope` (vars: none)",
        ),
        (
            "stages:\n  a:\n    uses: cmd\n     params: x\n",
            "error: pipelines/bad.yaml:4:12: stages.a: mapping values are not allowed in this context",
        ),
        (
            "stages:\n  a:\n    uses: cmd\n    params: {command: x}\n    inputs: {x: {from: a.out}}\n    outputs: {out: a.txt}\n",
            "error: pipelines/bad.yaml:2:3: stages.a: dependency cycle: `a` needs itself",
        ),
    ];
    for (yaml, expected) in cases {
        p.write("pipelines/bad.yaml", yaml);
        let out = p
            .firecast()
            .args(["pipeline", "run", "pipelines/bad.yaml"])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{}", describe(&out));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.lines().any(|l| l.starts_with(expected)),
            "for\n{yaml}\nexpected\n{expected}\ngot\n{stderr}"
        );
    }
    // A missing input file is reported with the stage and the path.
    p.write(
        "pipelines/missing.yaml",
        "stages:\n  a:\n    uses: cmd\n    params: {command: \"cat ${inputs.x} > ${outputs.y}\"}\n    inputs: {x: data/absent.csv}\n    outputs: {y: out.txt}\n",
    );
    let out = p
        .firecast()
        .args(["pipeline", "run", "pipelines/missing.yaml"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", describe(&out));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("stage `a`: input `x` not found: data/absent.csv"),
        "{}",
        describe(&out)
    );
}

#[test]
fn killed_stage_leaves_nothing_half_written_and_rerun_completes() {
    let p = Project::new();
    p.write(
        "pipelines/slow.yaml",
        "vars: {pause: 0}\nstages:\n  slow:\n    uses: cmd\n    params:\n      command: printf 'first half ' > ${outputs.out}; sleep ${pause}; printf 'second half' >> ${outputs.out}\n    outputs: {out: build/result.txt}\n",
    );
    let mut child = p
        .firecast()
        .args(["pipeline", "run", "pipelines/slow.yaml", "-S", "pause=30"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Wait until the command has written its first half to the temporary name.
    let deadline = Instant::now() + Duration::from_secs(30);
    let temp_written = || {
        std::fs::read_dir(p.path("build"))
            .map(|d| {
                d.flatten().any(|e| {
                    e.file_name().to_string_lossy().contains(".firecast-tmp-")
                        && e.metadata().unwrap().len() > 0
                })
            })
            .unwrap_or(false)
    };
    while !temp_written() {
        assert!(Instant::now() < deadline, "the stage never started writing");
        std::thread::sleep(Duration::from_millis(50));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        !p.path("build/result.txt").exists(),
        "a half-written output became visible"
    );
    let lock = std::fs::read_to_string(p.path("pipelines/slow.lock")).unwrap_or_default();
    assert!(
        !lock.contains("slow:"),
        "the killed stage was recorded as done:\n{lock}"
    );

    let rerun = p.run_pipeline("pipelines/slow.yaml", &[]);
    assert_eq!(rerun["slow"], "ran");
    assert_eq!(p.read("build/result.txt"), "first half second half");
    let leftovers: Vec<_> = std::fs::read_dir(p.path("build"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    assert_eq!(leftovers, ["result.txt"], "temporary files were not cleaned up");
}

#[test]
fn independent_stages_run_in_parallel_and_failures_stop_only_dependents() {
    let p = Project::new();
    // `left` and `right` each record when they start and end; `bad` fails; `after_bad` depends on it.
    p.write(
        "pipelines/fan.yaml",
        r#"
stages:
  left:
    uses: cmd
    params: {command: "date +%s.%N > ${outputs.t}; sleep 1; date +%s.%N >> ${outputs.t}"}
    outputs: {t: build/left.txt}
  right:
    uses: cmd
    params: {command: "date +%s.%N > ${outputs.t}; sleep 1; date +%s.%N >> ${outputs.t}"}
    outputs: {t: build/right.txt}
  bad:
    uses: cmd
    params: {command: "echo 'reading the sensor' ; echo 'sensor offline' >&2; exit 3"}
    outputs: {t: build/bad.txt}
  after_bad:
    uses: cmd
    params: {command: "cp ${inputs.t} ${outputs.t}"}
    inputs: {t: {from: bad.t}}
    outputs: {t: build/after_bad.txt}
  join:
    uses: cmd
    params: {command: "cat ${inputs.t} > ${outputs.t}"}
    inputs: {t: [{from: left.t}, {from: right.t}]}
    outputs: {t: build/join.txt}
"#,
    );
    let out = p
        .firecast()
        .args(["--json", "pipeline", "run", "pipelines/fan.yaml", "--jobs", "3"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", describe(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let outcomes = outcomes(&report);
    assert_eq!(outcomes["left"], "ran");
    assert_eq!(outcomes["right"], "ran");
    assert_eq!(outcomes["join"], "ran");
    assert_eq!(outcomes["bad"], "failed");
    assert_eq!(outcomes["after_bad"], "skipped");
    let bad = stage_report(&report, "bad");
    let error = bad["error"].as_str().unwrap();
    assert!(
        error.starts_with("command exited with code 3; last output:"),
        "{error}"
    );
    assert!(error.contains("sensor offline"), "{error}");
    assert!(!p.path("build/bad.txt").exists());

    let times = |rel: &str| -> (f64, f64) {
        let text = p.read(rel);
        let v: Vec<f64> = text.lines().map(|l| l.trim().parse().unwrap()).collect();
        (v[0], v[1])
    };
    let (left_start, left_end) = times("build/left.txt");
    let (right_start, right_end) = times("build/right.txt");
    assert!(
        left_start < right_end && right_start < left_end,
        "left [{left_start}, {left_end}] and right [{right_start}, {right_end}] did not overlap"
    );

    // With one job they cannot overlap.
    let serial = p.run_pipeline(
        "pipelines/fan.yaml",
        &["--force", "--jobs", "1", "--only", "left", "--only", "right"],
    );
    assert_eq!(serial["left"], "ran");
    let (left_start, left_end) = times("build/left.txt");
    let (right_start, right_end) = times("build/right.txt");
    assert!(
        left_end <= right_start || right_end <= left_start,
        "--jobs 1 ran stages at once"
    );
}

#[test]
fn foreach_and_matrix_expand_and_fan_in() {
    let p = Project::new();
    p.write(
        "pipelines/sweep.yaml",
        r#"
stages:
  per_var:
    uses: cmd
    foreach: [tmmx, rmin, vs]
    params: {command: "echo ${item} > ${outputs.out}"}
    outputs: {out: "build/${item}.txt"}
  grid:
    uses: cmd
    matrix: {lead: [1, 3], window: [30]}
    params: {command: "echo lead=${item.lead} window=${item.window} > ${outputs.out}"}
    outputs: {out: "build/grid-${item.lead}-${item.window}.txt"}
  all_vars:
    uses: cmd
    params: {command: "cat ${inputs.parts} > ${outputs.out}"}
    inputs: {parts: {from: per_var.out}}
    outputs: {out: build/all.txt}
"#,
    );
    let outcomes = p.run_pipeline("pipelines/sweep.yaml", &[]);
    let names: Vec<&str> = outcomes.keys().map(String::as_str).collect();
    assert_eq!(
        names,
        [
            "all_vars",
            "grid@1-30",
            "grid@3-30",
            "per_var@rmin",
            "per_var@tmmx",
            "per_var@vs"
        ]
    );
    assert_eq!(p.read("build/all.txt"), "tmmx\nrmin\nvs\n");
    assert_eq!(p.read("build/grid-3-30.txt"), "lead=3 window=30\n");

    let dag = p.ok(&["pipeline", "dag", "pipelines/sweep.yaml"]);
    let dag = String::from_utf8_lossy(&dag.stdout);
    assert!(
        dag.contains("all_vars (cmd)\n  <- per_var@tmmx\n  <- per_var@rmin\n  <- per_var@vs\n"),
        "{dag}"
    );
}

#[test]
fn committed_dvc_yaml_is_in_sync_with_the_pipelines() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_firecast"))
        .current_dir(repo_root())
        .args(["--no-progress", "pipeline", "export-dvc", "--check"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", describe(&out));
}

#[test]
fn demo_pipeline_runs_then_skips_everything() {
    // The committed demo, run in a scratch copy of the repository's pipelines.
    let p = Project::new();
    for entry in std::fs::read_dir(repo_root().join("pipelines")).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name().to_string_lossy().to_string();
        if name.ends_with(".yaml") {
            std::fs::copy(entry.path(), p.path(&format!("pipelines/{name}"))).unwrap();
        }
    }
    // The demo's fire file, with 3 evaluation fires and 100-step episodes.
    let fires = std::fs::read_to_string(repo_root().join("experiments/rl/demo-fires.yaml"))
        .unwrap()
        .replace("fires: 20", "fires: 3")
        .replace("max_steps: 400", "max_steps: 100");
    p.write("experiments/rl/demo-fires.yaml", &fires);
    // The forecasting experiment with two cheap models and the helitack agent with two
    // imitation rounds and one PPO update: the full ones take minutes and are covered by the
    // experiment and rl tests.
    let quick = [
        "-S",
        "forecast_table3.models=[{kind: majority}, {kind: logistic_regression}]",
        "-S",
        "forecast_table3.evaluation={bootstrap: 50}",
        "-S",
        "helitack_agent_imitation_rounds=2",
        "-S",
        "helitack_agent_steps=1024",
        "-S",
        "helitack_agent_seeds=[0]",
        "-S",
        "helitack_table4.resamples=200",
    ];
    let first = p.run_pipeline("pipelines/demo.yaml", &quick);
    assert!(first.values().all(|o| o == "ran"), "{first:?}");
    assert!(p.path("build/demo/table3/table3.md").is_file());
    let table4 = p.read("build/demo/helitack_table4/table4.md");
    assert!(table4.contains("Table IV over 3 held-out fires"), "{table4}");
    assert!(table4.contains("| ppo | 1 × 3 |"), "{table4}");
    let second = p.run_pipeline("pipelines/demo.yaml", &quick);
    assert!(second.values().all(|o| o == "up_to_date"), "{second:?}");
}
