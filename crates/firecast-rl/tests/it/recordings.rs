//! `rl evaluate`'s Rerun recordings: the best, median and worst PPO episodes replayed one
//! fire at a time reproduce the batched evaluation (two training seeds with an observation
//! normaliser, four held-out fires of 40 steps on a 48×32 grid).

use std::path::Path;

use firecast_rl::agent::PpoAgent;
use firecast_rl::ensemble::load_policies;
use firecast_rl::evaluate::{EvalConfig, EvalReport, PPO, action_seed, episode_seed};
use firecast_rl::spec::FiresSpec;
use tch::Device;

use crate::tiny::{tiny_run, tiny_run_with};

const FIRES: &str = r#"
train:
  landscape_seeds: [1]
  width: 48
  height: 32
  fires: 2
  seed: 0
  wind_speed_mph: [2, 6]
  dead_1h_frac: [0.04, 0.06]
  ignition_margin_cells: 8
  env: {max_steps: 40}
evaluate:
  landscape_seeds: [2, 3]
  width: 48
  height: 32
  fires: 4
  seed: 1
  wind_speed_mph: [2, 6]
  dead_1h_frac: [0.04, 0.08]
  ignition_margin_cells: 8
  env: {max_steps: 40}
"#;

fn evaluate(run: &Path, fires: &Path, out: &Path, cfg: &EvalConfig) -> EvalReport {
    firecast_rl::stage::evaluate_run(run, fires, None, out, cfg, Device::Cpu, &|_| {})
        .expect("the evaluation")
}

/// Every PPO episode, played again alone through the `firecast_sim::Policy` adapter.
fn replay_all(run: &Path, fires: &Path, report: &EvalReport, cfg: &EvalConfig) {
    let (_, policies) = load_policies(run, Device::Cpu).expect("loading the run");
    let set = FiresSpec::load(fires).expect("the fire file").evaluate;
    for e in report.episodes.iter().filter(|e| e.agent == PPO) {
        let seed = e.train_seed.expect("a PPO episode has a training seed");
        let p = policies.iter().find(|p| p.seed == seed).expect("its policy");
        let (landscape, env_cfg) = set.fire(&report.fires[e.fire]).expect("the fire");
        let mut env = firecast_sim::WildfireEnv::new(&landscape, &env_cfg).expect("the environment");
        let mut agent = PpoAgent::new(
            &p.policy,
            p.normalize.as_ref(),
            48,
            32,
            cfg.deterministic,
            action_seed(cfg.seed, seed, e.fire),
        )
        .expect("the agent");
        let stats =
            firecast_sim::run_episode(&mut env, &mut agent, episode_seed(cfg.seed, e.fire), |_, _| {});
        assert_eq!(
            (
                stats.cells_burned,
                stats.timesteps,
                stats.helitacks,
                stats.terminated
            ),
            (e.cells_burned, e.timesteps, e.helitacks, e.contained),
            "training seed {seed}, fire {}",
            e.fire
        );
    }
}

#[test]
fn evaluation_records_the_best_median_and_worst_ppo_episodes() {
    let tmp = tempfile::tempdir().expect("a temporary folder");
    let (run, fires) = tiny_run(tmp.path(), FIRES);
    let cfg = EvalConfig {
        resamples: 50,
        ..EvalConfig::default()
    };
    assert!(cfg.recordings, "recording is the default");
    let out = tmp.path().join("greedy");
    let report = evaluate(&run, &fires, &out, &cfg);
    let ppo: Vec<_> = report.episodes.iter().filter(|e| e.agent == PPO).collect();
    assert_eq!(ppo.len(), 2 * 4);
    replay_all(&run, &fires, &report, &cfg);

    let roles: Vec<&str> = report.recordings.iter().map(|r| r.role.as_str()).collect();
    assert_eq!(roles, ["best", "median", "worst"]);
    let min = ppo.iter().map(|e| e.cells_burned).min();
    let max = ppo.iter().map(|e| e.cells_burned).max();
    assert_eq!(Some(report.recordings[0].cells_burned), min);
    assert_eq!(Some(report.recordings[2].cells_burned), max);
    for r in &report.recordings {
        assert!(r.cells_burned >= report.recordings[0].cells_burned);
        assert!(r.cells_burned <= report.recordings[2].cells_burned);
        // The replayed episode is the evaluated one (evaluate_run fails otherwise).
        let e = ppo
            .iter()
            .find(|e| e.train_seed == Some(r.train_seed) && e.fire == r.fire)
            .expect("the recorded episode is an evaluated one");
        assert_eq!(
            (r.cells_burned, r.timesteps, r.helitacks),
            (e.cells_burned, e.timesteps, e.helitacks)
        );
        assert_eq!(r.seed, episode_seed(cfg.seed, r.fire));
        assert_eq!(
            r.path,
            Path::new("recordings").join(format!("ppo-{}.rrd", r.role))
        );
        let file = out.join(&r.path);
        let size = std::fs::metadata(&file).map(|m| m.len()).unwrap_or(0);
        assert!(size > 0, "{} is missing or empty", file.display());
    }
    // Listed in evaluation.json and table4.md.
    let json: EvalReport =
        serde_json::from_slice(&std::fs::read(out.join("evaluation.json")).expect("evaluation.json"))
            .expect("evaluation.json parses");
    assert_eq!(json.recordings, report.recordings);
    let table = std::fs::read_to_string(out.join("table4.md")).expect("table4.md");
    assert!(table.contains("recordings/ppo-median.rrd"), "{table}");
    // Nothing half-written is left beside them.
    let leftovers: Vec<String> = std::fs::read_dir(out.join("recordings"))
        .expect("the recordings folder")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !n.ends_with(".rrd") || n.starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");

    for r in &report.recordings {
        firecast_testkit::verify_rrd(&out.join(&r.path));
    }

    // Evaluated again: the same recordings, byte for byte (the stage's outputs hash the same).
    let again = tmp.path().join("greedy-again");
    let report_again = evaluate(&run, &fires, &again, &cfg);
    assert_eq!(report_again.recordings, report.recordings);
    for r in &report.recordings {
        let (first, second) = (
            std::fs::read(out.join(&r.path)).expect("the recording"),
            std::fs::read(again.join(&r.path)).expect("the recording again"),
        );
        assert!(
            first == second,
            "{} differs between two evaluations",
            r.path.display()
        );
    }

    // Sampled actions: one action stream per fire, so single-fire replays draw the same.
    let sampled = EvalConfig {
        deterministic: false,
        ..cfg.clone()
    };
    let report = evaluate(&run, &fires, &tmp.path().join("sampled"), &sampled);
    replay_all(&run, &fires, &report, &sampled);
    assert_eq!(report.recordings.len(), 3);

    // Turned off: no recordings and no folder.
    let off = EvalConfig {
        recordings: false,
        ..cfg
    };
    let out = tmp.path().join("off");
    let report = evaluate(&run, &fires, &out, &off);
    assert!(report.recordings.is_empty());
    assert!(!out.join("recordings").exists());
}

#[test]
fn a_recurrent_agent_replays_its_evaluated_episodes() {
    // The batched evaluation carries each fire's LSTM state in its own row; the one-fire
    // adapter carries its own: greedy and sampled, every episode must come out the same.
    let tmp = tempfile::tempdir().expect("a temporary folder");
    let policy = firecast_rl::policy::PolicyConfig {
        kind: firecast_rl::policy::PolicyKind::Compact,
        memory: firecast_rl::policy::Memory::Lstm,
        ..Default::default()
    };
    let (run, fires) = tiny_run_with(tmp.path(), FIRES, Some(policy));
    for deterministic in [true, false] {
        let cfg = EvalConfig {
            resamples: 50,
            deterministic,
            ..EvalConfig::default()
        };
        let out = tmp.path().join(format!("eval-{deterministic}"));
        let report = evaluate(&run, &fires, &out, &cfg);
        assert_eq!(report.recordings.len(), 3);
        replay_all(&run, &fires, &report, &cfg);
    }
}

/// `--against` with the run itself: the second agent plays the very same episodes, and the
/// paired comparison is an exact tie (Δ 0, P(better) ½, reduction 0).
#[test]
fn a_run_evaluated_against_itself_is_a_tie() {
    firecast_learn::set_threads(1);
    let tmp = tempfile::tempdir().expect("tmp");
    let (run, fires) = tiny_run(tmp.path(), FIRES);
    let cfg = EvalConfig {
        recordings: false,
        resamples: 500,
        ..EvalConfig::default()
    };
    let report = firecast_rl::stage::evaluate_run(
        &run,
        &fires,
        Some(&run),
        &tmp.path().join("eval"),
        &cfg,
        Device::Cpu,
        &|_| {},
    )
    .expect("the evaluation");
    let agents: Vec<&str> = report.agents.iter().map(|a| a.agent.as_str()).collect();
    assert_eq!(agents[..2], ["ppo", "ppo:tiny"]);
    let key = |e: &&firecast_rl::evaluate::Episode| (e.train_seed, e.fire);
    let mut mine: Vec<_> = report.episodes.iter().filter(|e| e.agent == "ppo").collect();
    let mut theirs: Vec<_> = report.episodes.iter().filter(|e| e.agent == "ppo:tiny").collect();
    mine.sort_by_key(key);
    theirs.sort_by_key(key);
    assert_eq!(mine.len(), theirs.len());
    for (a, b) in mine.iter().zip(&theirs) {
        assert_eq!(
            (a.cells_burned, a.timesteps, a.helitacks),
            (b.cells_burned, b.timesteps, b.helitacks)
        );
    }
    let c = &report.comparisons[0];
    assert_eq!((c.agent.as_str(), c.baseline.as_str()), ("ppo", "ppo:tiny"));
    assert_eq!(c.cells_burned_diff.estimate, 0.0);
    assert_eq!(c.probability_better.estimate, 0.5);
    assert_eq!(c.relative_reduction.estimate, 0.0);
    assert!(c.cells_burned_diff.low <= 0.0 && c.cells_burned_diff.high >= 0.0);
    assert!(firecast_rl::evaluate::markdown(&report).contains("| ppo:tiny |"));
}

/// `HeldOut::judge` (`bench quality`'s checkpoints) says of one policy what `rl evaluate`
/// says of a run holding only that policy: the same mean, the same paired comparison with
/// the rule circle.
#[test]
fn held_out_judges_a_policy_as_the_evaluation_does() {
    use firecast_rl::evaluate::{HeldOut, RULE, evaluate as evaluate_policies};
    let tmp = tempfile::tempdir().expect("a temporary folder");
    let (run, fires) = tiny_run(tmp.path(), FIRES);
    let (_, mut policies) = load_policies(&run, Device::Cpu).expect("loading the run");
    policies.truncate(1);
    let cfg = EvalConfig {
        resamples: 500,
        recordings: false,
        ..EvalConfig::default()
    };
    let spec = FiresSpec::load(&fires).expect("the fire file");
    let report = evaluate_policies(&spec, &policies, None, &cfg, &|_| {}).expect("the evaluation");
    let held_out = HeldOut::new(&spec, cfg.clone()).expect("the held-out fires");
    assert_eq!(held_out.fires(), 4);
    let judged = held_out.judge(&policies[0]).expect("judging");
    let row = |agent: &str| {
        let a = report.agents.iter().find(|a| a.agent == agent).expect("a row");
        a.cells_burned.mean.estimate
    };
    assert_eq!(judged.cells_burned, row(PPO));
    assert_eq!(judged.rule_cells_burned, row(RULE));
    let vs_rule = report
        .comparisons
        .iter()
        .find(|c| c.baseline == RULE)
        .expect("PPO against the circle");
    assert_eq!(&judged.comparison, vs_rule);
    assert_eq!(judged.beats_rule(), vs_rule.cells_burned_diff.high < 0.0);
}
