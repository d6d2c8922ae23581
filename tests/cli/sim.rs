//! The simulator through the CLI: spread rates, episodes, the sim.episodes stage.

use crate::{Project, describe};

#[test]
fn sim_run_compares_agents_and_writes_outputs() {
    let p = Project::new();
    let out = p.json(&[
        "sim",
        "run",
        "--landscape",
        "procedural:2",
        "--agent",
        "rule",
        "--agent",
        "none",
        "--episodes",
        "2",
        "--seed",
        "4",
        "--wind-mph",
        "8",
        "--wind-from-deg",
        "270",
        "--gif",
        "out/fire.gif",
    ]);
    let runs = out.as_array().unwrap();
    assert_eq!(runs.len(), 2);
    assert_eq!(runs[0]["agent"], "rule");
    assert_eq!(runs[1]["agent"], "none");
    assert_eq!(runs[0]["wind_speed_mph"], 8.0);
    assert_eq!(runs[1]["report"]["helitacks"]["mean"], 0.0);
    assert!(p.path("out/fire-rule.gif").exists() && p.path("out/fire-none.gif").exists());

    let bad = p
        .firecast()
        .args(["sim", "run", "--agent", "robot", "--episodes", "1"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2), "{}", describe(&bad));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("unknown agent `robot`"));
}

#[test]
fn sim_episodes_stage_in_a_pipeline() {
    let p = Project::new();
    p.write(
        "pipelines/fire.yaml",
        r#"
stages:
  helitack:
    uses: sim.episodes
    foreach: [rule, none]
    params:
      landscape: {procedural: {seed: 5, width: 100, height: 80}}
      agent: ${item}
      episodes: 2
      env: {max_steps: 300, sim: {wind: {speed_mph: 6, from_direction_deg: 200}}}
    outputs:
      summary: "build/${item}.json"
      animation: "build/${item}.gif"
"#,
    );
    let outcomes = p.run_pipeline("pipelines/fire.yaml", &[]);
    assert_eq!(outcomes["helitack@rule"], "ran");
    let summary: serde_json::Value = serde_json::from_str(&p.read("build/rule.json")).unwrap();
    assert_eq!(summary["report"]["episodes"].as_array().unwrap().len(), 2);
    let runs = p.json(&["runs", "list", "--stage", "helitack"]);
    let run_id = runs[0]["run_id"].as_str().unwrap().to_string();
    let show = p.json(&["runs", "show", &run_id]);
    let keys: Vec<&str> = show["metrics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["key"].as_str().unwrap())
        .collect();
    assert_eq!(keys, ["cells_burned", "helitacks", "timesteps", "water_used_gal"]);

    p.write(
        "pipelines/bad.yaml",
        &p.read("pipelines/fire.yaml").replace("max_steps", "max_stesp"),
    );
    let out = p
        .firecast()
        .args(["pipeline", "run", "pipelines/bad.yaml"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("stages.helitack.params.env.max_stesp: unknown field `max_stesp`"),
        "{stderr}"
    );
}
