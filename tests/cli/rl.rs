//! `firecast rl train|evaluate` on tiny budgets: CartPole, the helitack fires on a small
//! grid, interruption and exact resumption, Table IV, and bad input.

use crate::{Project, describe, venv_bin};

const FIRES: &str = r#"
profile: p2
train:
  landscape_seeds: [1, 2]
  width: 48
  height: 32
  fires: 6
  seed: 1
  wind_speed_mph: [3, 6]
  dead_1h_frac: [0.06, 0.1]
  ignition_margin_cells: 8
  env: {max_steps: 40}
evaluate:
  landscape_seeds: [11, 12]
  width: 48
  height: 32
  fires: 5
  seed: 2
  wind_speed_mph: [3, 6]
  dead_1h_frac: [0.06, 0.1]
  ignition_margin_cells: 8
  env: {max_steps: 40}
"#;

fn spec(name: &str) -> String {
    format!(
        r#"
name: {name}
env: {{kind: helitack, fires: fires.yaml}}
policy: {{kind: compact}}
ppo: {{preset: paper, n_envs: 2, n_steps: 16, batch_size: 16, n_epochs: 2, total_timesteps: 96}}
seeds: [3]
checkpoint_every: 1
device: cpu
"#
    )
}

fn project() -> Project {
    let p = Project::new();
    p.write("fires.yaml", FIRES);
    p.write("a.yaml", &spec("heli-a"));
    p.write("b.yaml", &spec("heli-b"));
    p
}

#[test]
fn cartpole_trains_and_reports_sb3_metrics() {
    let p = Project::new();
    p.write(
        "cp.yaml",
        "name: cp\nenv: {kind: cartpole}\nppo: {preset: cartpole_zoo, total_timesteps: 2048}\nseeds: [0, 1]\ndevice: cpu\n",
    );
    let s = p.json(&["rl", "train", "--config", "cp.yaml"]);
    let seeds = s["seeds"].as_array().unwrap();
    assert_eq!(seeds.len(), 2);
    for seed in seeds {
        assert_eq!(seed["timesteps"], 2048);
        assert!(seed["ep_rew_mean"].as_f64().unwrap() > 9.0, "{seed}");
    }
    let metrics = p.read("experiments/runs/cp/seed-0/metrics.jsonl");
    let last: serde_json::Value = serde_json::from_str(metrics.lines().last().unwrap()).unwrap();
    for key in [
        "rollout/ep_rew_mean",
        "train/approx_kl",
        "train/clip_fraction",
        "train/entropy_loss",
        "train/explained_variance",
        "train/value_loss",
        "train/policy_gradient_loss",
        "time/total_timesteps",
    ] {
        assert!(last.get(key).is_some(), "{key} missing in {last}");
    }
    // Wall-clock speed is in the run's files too (SB3's `time/fps`), the one key a forced
    // rerun changes.
    assert!(last["time/fps"].as_f64().is_some_and(|f| f > 0.0), "{last}");
    let without_fps = |text: &str| -> Vec<serde_json::Value> {
        text.lines()
            .map(|l| {
                let mut row: serde_json::Value = serde_json::from_str(l).unwrap();
                assert!(row.as_object_mut().unwrap().remove("time/fps").is_some(), "{l}");
                row
            })
            .collect()
    };
    let summary = p.read("experiments/runs/cp/summary.json");
    // Re-invoking a finished run is up to date; `--fresh` trains again from scratch.
    let again = p.ok(&["rl", "train", "--config", "cp.yaml"]);
    assert!(
        String::from_utf8_lossy(&again.stdout).contains("up to date"),
        "{}",
        describe(&again)
    );
    p.ok(&["rl", "train", "--config", "cp.yaml", "--fresh"]);
    assert_eq!(
        without_fps(&p.read("experiments/runs/cp/seed-0/metrics.jsonl")),
        without_fps(&metrics)
    );
    assert_eq!(p.read("experiments/runs/cp/summary.json"), summary);
    assert!(p.path("experiments/runs/cp/training.png").exists());
    // The registry has the per-update metrics under SB3's names.
    let rows = p.json(&[
        "query",
        "SELECT count(*) AS n FROM metrics WHERE key LIKE '%train/approx_kl'",
    ]);
    assert!(rows.to_string().contains("32"), "{rows}");
    let fps = p.json(&[
        "query",
        "SELECT count(*) AS n FROM metrics WHERE key LIKE '%time/fps'",
    ]);
    assert!(fps.to_string().contains("32"), "{fps}");
}

#[test]
fn an_interrupted_helitack_run_resumes_to_the_same_policy() {
    let p = project();
    // Interrupted after 32 of 96 steps: the command fails, the checkpoint stays.
    let out = p
        .firecast()
        .args(["rl", "train", "--config", "a.yaml", "--stop-after", "32"])
        .output()
        .unwrap();
    assert!(!out.status.success(), "{}", describe(&out));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("resume"),
        "{}",
        describe(&out)
    );
    assert!(
        !p.path("experiments/runs/heli-a/summary.json").exists(),
        "no finished-looking output"
    );
    // The spec as a positional FILE, as `experiment run` takes it (`--config` still works).
    let resumed = p.json(&["rl", "train", "a.yaml", "--resume"]);
    assert_eq!(resumed["seeds"][0]["resumed_from"], 32, "{resumed}");
    assert_eq!(resumed["seeds"][0]["timesteps"], 96);
    // The same spec under another name, straight through.
    let straight = p.json(&["rl", "train", "--config", "b.yaml"]);
    assert!(straight["seeds"][0]["resumed_from"].is_null());
    let a = std::fs::read(p.path("experiments/runs/heli-a/seed-3/policy/policy.safetensors")).unwrap();
    let b = std::fs::read(p.path("experiments/runs/heli-b/seed-3/policy/policy.safetensors")).unwrap();
    assert!(a == b, "resumed and straight policies differ");
    // Nothing left to resume once finished and cached; --resume without checkpoints errors.
    let out = p
        .firecast()
        .args(["rl", "train", "--config", "b.yaml", "--fresh", "--resume"])
        .output()
        .unwrap();
    assert!(!out.status.success());

    // Table IV on the held-out fires, paired across agents.
    let r = p.json(&[
        "rl",
        "evaluate",
        "--run",
        "experiments/runs/heli-a",
        "--resamples",
        "200",
    ]);
    // The agents of an evaluation report, in its order.
    fn agent_names(r: &serde_json::Value) -> Vec<&str> {
        r["agents"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| a["agent"].as_str().unwrap())
            .collect()
    }
    assert_eq!(
        agent_names(&r),
        ["ppo", "rule", "rule-concentric", "chaser", "none"]
    );
    assert_eq!(r["episodes"].as_array().unwrap().len(), 5 * 5);
    assert_eq!(r["fires"].as_array().unwrap().len(), 5);
    let none = &r["agents"][4];
    assert_eq!(none["helitacks"]["mean"]["estimate"], 0.0);
    assert_eq!(none["cells_saved"]["mean"]["estimate"], 0.0);
    assert_eq!(r["comparisons"].as_array().unwrap().len(), 4);
    for f in [
        "table4.md",
        "episodes.csv",
        "table4.png",
        "ppo_vs_rule.png",
        "recordings/ppo-best.rrd",
        "recordings/ppo-median.rrd",
        "recordings/ppo-worst.rrd",
    ] {
        assert!(
            p.path(&format!("experiments/runs/heli-a/evaluation/{f}"))
                .exists(),
            "{f}"
        );
    }
    let roles: Vec<&str> = r["recordings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["role"].as_str().unwrap())
        .collect();
    assert_eq!(roles, ["best", "median", "worst"], "{}", r["recordings"]);

    // With the rollout search beside them: its row after the chaser, compared with the
    // chaser and the circle, and PPO compared with it.
    let r = p.json(&[
        "rl",
        "evaluate",
        "--run",
        "experiments/runs/heli-a",
        "--resamples",
        "200",
        "--no-recordings",
        "--search",
        "10",
        "--out",
        "experiments/runs/heli-a/evaluation-search",
    ]);
    assert_eq!(
        agent_names(&r),
        ["ppo", "rule", "rule-concentric", "chaser", "search", "none"]
    );
    let pairs: Vec<(&str, &str)> = r["comparisons"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| (c["agent"].as_str().unwrap(), c["baseline"].as_str().unwrap()))
        .collect();
    assert_eq!(
        pairs,
        [
            ("ppo", "rule"),
            ("ppo", "rule-concentric"),
            ("ppo", "chaser"),
            ("ppo", "search"),
            ("ppo", "none"),
            ("search", "chaser"),
            ("search", "rule")
        ]
    );
    let table =
        std::fs::read_to_string(p.path("experiments/runs/heli-a/evaluation-search/table4.md")).unwrap();
    assert!(
        table.contains("| search vs | Δ cells burned (search − baseline)"),
        "{table}"
    );
    assert!(
        table.contains("| PPO vs | Δ cells burned (PPO − baseline)"),
        "{table}"
    );
}

#[test]
fn bad_training_specs_name_the_key() {
    let p = project();
    let cases = [
        ("-S", "ppo.bogus=1", "ppo.bogus"),
        ("-S", "ppo.batch_size=20", "does not divide the rollout"),
        ("-S", "ppo.preset=fast", "unknown preset `fast`"),
        ("-S", "policy.kind=mlp", "policy.kind"),
        ("-S", "seeds=[]", "seeds"),
        ("-S", "policy.view=sideways", "policy.view"),
        ("-S", "policy.focus=4", "needs `view: helicopter`"),
        ("-S", "threads=0", "threads"),
    ];
    // `rl train` with these arguments: whether it succeeded, and its stderr.
    let train = |args: &[&str]| {
        let out = p
            .firecast()
            .args(["rl", "train", "--config"])
            .args(args)
            .output()
            .unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    for (flag, value, expect) in cases {
        let (ok, err) = train(&["a.yaml", flag, value]);
        assert!(!ok, "{value}");
        assert!(err.contains(expect), "{value}: expected `{expect}` in\n{err}");
    }
    p.write("c.yaml", "name: c\nenv: {kind: cartpole}\nlearning_rate: 1\n");
    let (_, err) = train(&["c.yaml"]);
    assert!(err.contains("c.yaml:3") && err.contains("learning_rate"), "{err}");
    // Each cause once: the key's message, and a missing file's path and OS error.
    assert_eq!(err.matches("unknown field").count(), 1, "{err}");
    p.write(
        "m.yaml",
        &spec("heli-m").replace("fires.yaml", "absent-fires.yaml"),
    );
    let (_, err) = train(&["m.yaml"]);
    assert!(err.contains("absent-fires.yaml"), "{err}");
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");

    // Reward weights: the profile's, replaced by the top-level `reward`; not under `env`.
    for (fires, expect) in [
        (
            FIRES.replace("profile: p2", "profile: suppression\nreward: {bogus: 1}"),
            "bogus",
        ),
        (
            FIRES.replace("profile: p2", "profile: suppression\nreward: {approach: yes}"),
            "reward.approach",
        ),
        (
            FIRES.replace(
                "env: {max_steps: 40}\nevaluate",
                "env: {max_steps: 40, reward: {step: -1}}\nevaluate",
            ),
            "train.env.reward",
        ),
        (
            FIRES.replace("profile: p2", "profile: gentle"),
            "unknown profile `gentle`",
        ),
    ] {
        p.write("bad-fires.yaml", &fires);
        p.write("d.yaml", &spec("heli-d").replace("fires.yaml", "bad-fires.yaml"));
        let (ok, err) = train(&["d.yaml"]);
        assert!(!ok, "{fires}");
        assert!(err.contains(expect), "expected `{expect}` in\n{err}");
    }
}

/// `bench ppo` part (b) on a tiny budget: FireCast's compact policy and SB3's re-statement
/// (driving `firecast.HelitackVecEnv`) have equal parameter counts and both sides ran, twice. Needs
/// the project venv (`cargo xtask setup`): without it the test fails.
#[test]
fn bench_ppo_helitack_runs_both_sides_with_equal_networks() {
    let p = Project::new();
    let python = venv_bin("python");
    let python = python.to_str().unwrap();
    let r = p.json(&[
        "bench",
        "ppo",
        "--parts",
        "b,c",
        "--helitack-steps",
        "32",
        "-S",
        "n_steps=4",
        "-S",
        "batch_size=16",
        "-S",
        "n_epochs=1",
        "--threads",
        "1",
        "--repeats",
        "2",
        "--python",
        python,
    ]);
    let parts = r["parts"].as_array().unwrap();
    assert_eq!(parts.len(), 1, "{r}");
    let b = &parts[0];
    assert_eq!(b["part"], "b");
    let ours = b["firecast"]["parameters"].as_i64().unwrap();
    assert!(ours > 0, "{b}");
    assert_eq!(b["sb3"]["parameters"].as_i64(), Some(ours), "{b}");
    for k in ["env", "rollout", "update", "train"] {
        let ratio = b["ratios"][k].as_f64().unwrap();
        assert!(ratio.is_finite() && ratio > 0.0, "{k}: {b}");
        assert!(b["firecast"][format!("{k}_sps")].as_f64().unwrap() > 0.0, "{b}");
    }
    // The arithmetic yardstick: torch's FLOP count per step and the machine's sgemm rate; the
    // goal's GFLOP/s is the goal times SB3's.
    let w = &b["arithmetic"];
    let num = |k: &str| w[k].as_f64().unwrap_or(f64::NAN);
    assert!(num("flops_per_step") > 1e5, "{w}");
    assert!(num("sgemm_gflops") > 0.0 && num("firecast_gflops") > 0.0, "{w}");
    // The yardstick is the fastest matrix product timed, float32 or bfloat16; the compact
    // policy has no recurrent layer to count by hand.
    assert!(num("bf16_gflops") > 0.0, "{w}");
    assert_eq!(
        num("peak_gflops"),
        num("sgemm_gflops").max(num("bf16_gflops")),
        "{w}"
    );
    assert_eq!(num("recurrent_flops_per_step"), 0.0, "{w}");
    assert!(
        (num("goal_gflops") - 3.0 * num("sb3_gflops")).abs() < 1e-9 * num("goal_gflops"),
        "{w}"
    );
    // Both sides ran twice, alternating; the tables hold medians.
    let each = b["train_ratios"].as_array().unwrap();
    assert_eq!(each.len(), 2, "{b}");
    assert!(each.iter().all(|r| r.as_f64().unwrap() > 0.0), "{b}");
    // (c) needs a FireCastRL checkout: it says how to run it.
    let skipped = r["skipped"].as_array().unwrap();
    assert!(skipped[0].as_str().unwrap().contains("--reference-env"), "{r}");
}

/// An ignition off the map in a fire file names the file, the line and the column of its key
/// (issue 31's rough edges), through the real binary.
#[test]
fn an_ignition_off_the_map_names_the_fire_files_key_and_line() {
    let p = project();
    p.write(
        "far-fires.yaml",
        &FIRES.replace(
            "  env: {max_steps: 40}\nevaluate",
            "  env:\n    max_steps: 40\n    ignition: [120, 5]\nevaluate",
        ),
    );
    p.write(
        "far.yaml",
        &spec("heli-far").replace("fires.yaml", "far-fires.yaml"),
    );
    let out = p
        .firecast()
        .args(["rl", "train", "--config", "far.yaml"])
        .output()
        .unwrap();
    assert!(!out.status.success(), "{}", describe(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("far-fires.yaml:14:5: train.env.ignition: cell (120, 5) is outside the 48 × 32 map"),
        "{err}"
    );
}

#[test]
fn a_recipe_extends_another_and_a_dry_run_prints_what_would_train() {
    let p = project();
    p.write(
        "ablations/no-ppo.yaml",
        "# What imitation alone gives.\nextends: ../a.yaml\nname: heli-no-ppo\nenv:\n  reward: {profile: suppression, quenched: 0, new_burnt: -1}\nppo: {n_epochs: 1}\n",
    );
    let out = p.ok(&["rl", "train", "ablations/no-ppo.yaml", "-n", "-S", "seeds=[4]"]);
    let stage: serde_json::Value = serde_yaml_ng::from_slice(&out.stdout).unwrap();
    assert_eq!(stage["uses"], "rl.train");
    let params = &stage["params"];
    assert_eq!(params["name"], "heli-no-ppo");
    assert_eq!(params["seeds"], serde_json::json!([4]), "-S over the file");
    // Mappings merge: the base's PPO settings stay, the ablation's one key replaces its own.
    assert_eq!(params["ppo"]["n_epochs"], 1);
    assert_eq!(params["ppo"]["n_steps"], 16);
    assert_eq!(params["env"]["reward"]["new_burnt"], -1);
    assert_eq!(stage["inputs"]["fires"], "fires.yaml");
    assert_eq!(stage["outputs"]["run"], "experiments/runs/heli-no-ppo");
    assert!(!p.path("experiments/runs").exists(), "a dry run trains nothing");

    // A typo in the base is placed in the base, with its line.
    p.write("a.yaml", &spec("heli-a").replace("policy:", "polcy:"));
    let out = p
        .firecast()
        .args(["rl", "train", "ablations/no-ppo.yaml", "-n"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", describe(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("a.yaml:4:"), "{err}");
    assert!(err.contains("polcy"), "{err}");
}

#[test]
fn settings_say_where_each_value_came_from() {
    let p = Project::new();
    p.write("firecast.yaml", "jobs: 3\nstore: file-store\n");
    let out = p
        .firecast()
        .args(["--json", "settings"])
        .env("FIRECAST_REGISTRY", "reg.duckdb")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", describe(&out));
    let s: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(s["jobs"], serde_json::json!({"value": "3", "from": "file"}));
    assert_eq!(
        s["store"],
        serde_json::json!({"value": "file-store", "from": "file"})
    );
    assert_eq!(s["registry"]["from"], "env");
    assert!(s["registry"]["value"].as_str().unwrap().ends_with("reg.duckdb"));
    assert_eq!(
        s["executor"],
        serde_json::json!({"value": "local", "from": "default"})
    );
    // A flag wins over the file.
    let s = p.json(&["--store", "flag-store", "settings"]);
    assert_eq!(
        s["store"],
        serde_json::json!({"value": "flag-store", "from": "flag"})
    );
}

/// A stand-in for the FireCastRL package with the contract quality_sb3.py reads (a Gymnasium
/// env with `gridWidth`/`gridHeight`, `cell_state.fire_state`/`is_nonburnable` and the
/// helicopter's cell in the observation) on the test's 48 × 32 grid: its "fire" is one
/// burning cell and episodes last 10 steps. It exercises the reference row's plumbing, not
/// FireCastRL's physics.
const FAKE_FIRECASTRL: &str = r#"
import gymnasium as gym
import numpy as np
from gymnasium import spaces

class _State:
    def __init__(self):
        self.fire_state = np.zeros((32, 48), dtype=np.int8)
        self.fire_state[16, 24] = 1
        self.is_nonburnable = np.zeros((32, 48), dtype=bool)

class WildfireEnv(gym.Env):
    def __init__(self, render_mode=None):
        self.gridWidth, self.gridHeight = 48, 32
        self.action_space = spaces.Discrete(5)
        self.observation_space = spaces.Dict({"helicopter_coord": spaces.Box(0, 47, (2,), np.int32)})
        self.cell_state = _State()
    def reset(self, seed=None, options=None):
        super().reset(seed=seed)
        self.t, self.xy = 0, np.array([14, 10], dtype=np.int32)
        return {"helicopter_coord": self.xy.copy()}, {}
    def step(self, action):
        self.t += 1
        dx, dy = [(0, 1), (0, -1), (-1, 0), (1, 0), (0, 0)][int(action)]
        self.xy = np.clip(self.xy + [dx, dy], 0, [47, 31]).astype(np.int32)
        return {"helicopter_coord": self.xy.copy()}, -1.0, self.t >= 10, False, {}
"#;

/// `bench quality` on tiny budgets: FireCast's recipe (imitation, then PPO), the control row
/// (SB3 on HelitackVecEnv over the recipe's training fires) and the reference row (SB3 on a
/// stand-in FireCastRL environment): every side stamps, every stamp is judged against the
/// circle on the same held-out fires, the first stamp beating it is the one the clock names,
/// and SB3's weights act in FireCast's engine as in SB3 (the probe).
#[test]
fn bench_quality_times_every_side_to_the_same_held_out_fires() {
    let p = project();
    p.write(
        "recipe.yaml",
        r#"
name: tiny-recipe
env: {kind: helitack, fires: fires.yaml, reward: {profile: suppression, quenched: 0, new_burnt: -1}}
policy: {kind: compact, view: helicopter, focus: 4}
imitation: {teacher: chaser, rounds: 3, teacher_rounds: 1, updates: 4, batch_size: 16, learning_rate: 0.001, kickstart: 1.0}
ppo: {preset: paper, n_envs: 2, n_steps: 16, batch_size: 16, n_epochs: 1, total_timesteps: 64}
seeds: [0]
"#,
    );
    p.write(
        "paper.yaml",
        r#"
name: tiny-paper
env: {kind: helitack, fires: fires.yaml}
policy: {kind: compact}
ppo: {preset: paper, n_envs: 2, n_steps: 16, batch_size: 16, n_epochs: 1, total_timesteps: 64}
"#,
    );
    p.write("wildfire-env/firecastrl_env/__init__.py", "");
    p.write("wildfire-env/firecastrl_env/envs/__init__.py", "");
    p.write(
        "wildfire-env/firecastrl_env/envs/wildfire_env.py",
        FAKE_FIRECASTRL,
    );
    let python = venv_bin("python");
    let python = python.to_str().unwrap();
    let r = p.json(&[
        "bench",
        "quality",
        "--config",
        "recipe.yaml",
        "--paper-config",
        "paper.yaml",
        "--seeds",
        "0,1",
        "--budget",
        "30",
        "--every",
        "0.05",
        "--control",
        "--reference-env",
        "wildfire-env",
        "--reference-budget",
        "30",
        "--threads",
        "1",
        "--resamples",
        "200",
        "--python",
        python,
    ]);
    assert_eq!(r["fires"], 5, "{r}");
    assert_eq!(r["grid"], serde_json::json!([48, 32]));
    let circle = r["rule_cells_burned"].as_f64().unwrap();
    assert!(circle > 0.0, "{r}");
    let sides = r["sides"].as_array().unwrap();
    let names: Vec<&str> = sides.iter().map(|s| s["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["firecast", "control", "reference"]);
    for side in sides {
        let seeds = side["seeds"].as_array().unwrap();
        let want = if side["name"] == "firecast" { 2 } else { 1 };
        assert_eq!(seeds.len(), want, "{side}");
        for s in seeds {
            let stamps = s["stamps"].as_array().unwrap();
            assert!(stamps.len() >= 2, "stamps every 0.05 s: {s}");
            let secs: Vec<f64> = stamps.iter().map(|x| x["seconds"].as_f64().unwrap()).collect();
            assert!(secs.windows(2).all(|w| w[0] <= w[1]), "{secs:?}");
            // Both budgets outlast the tiny recipes: the last stamp is the finished policy.
            let last = stamps.last().unwrap();
            assert_eq!(last["timesteps"], 64, "{s}");
            assert_eq!(s["trained_seconds"].as_f64(), secs.last().copied());
            // The clock names the first judged stamp whose interval lies below zero.
            let first_beating = stamps.iter().find_map(|x| {
                let j = x.get("judgement").filter(|j| !j.is_null())?;
                assert_eq!(j["rule_cells_burned"].as_f64(), Some(circle));
                (j["comparison"]["cells_burned_diff"]["high"].as_f64().unwrap() < 0.0)
                    .then(|| x["seconds"].as_f64().unwrap())
            });
            assert_eq!(s["beats_circle_at"].as_f64(), first_beating, "{s}");
            assert!(
                stamps[0]["judgement"].is_object(),
                "the first stamp is always judged"
            );
        }
    }
    // FireCast's recipe imitates before PPO: its first stamps are imitation rounds.
    let ours = &sides[0]["seeds"][0]["stamps"];
    assert!(ours[0]["imitation_timesteps"].as_u64().unwrap() > 0, "{ours}");
    assert_eq!(ours[0]["timesteps"], 0, "{ours}");
    assert_eq!(
        sides[2]["detail"]
            .as_str()
            .map(|d| d.contains("at most 64 steps")),
        Some(true)
    );

    // The human rendering prints the goals, whatever they say.
    let out = p
        .firecast()
        .args([
            "bench",
            "quality",
            "--config",
            "recipe.yaml",
            "--seeds",
            "0",
            "--budget",
            "30",
        ])
        .args(["--every", "1", "--resamples", "100", "--threads", "1"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for line in [
        "goal: beat the circle in <= 300 s a seed:",
        "goal: >= 20x less wall-clock",
        "not measured (pass --reference-env)",
    ] {
        assert!(text.contains(line), "{line}: {text}");
    }

    // A folder without the FireCastRL package is refused by name before anything trains.
    let out = p
        .firecast()
        .args([
            "bench",
            "quality",
            "--config",
            "recipe.yaml",
            "--reference-env",
            "nowhere",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--reference-env nowhere") && err.contains("wildfire_env.py"),
        "{err}"
    );
}
