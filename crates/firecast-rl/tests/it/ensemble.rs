//! `rl.ensemble`'s runner on a tiny trained run: two training seeds on a 48×32 grid, three
//! runs of 60 steps.

use std::path::Path;

use firecast_episodes::ensemble::{Ensemble, Setup, assemble};
use firecast_episodes::{LandscapeSpec, Scenario};
use firecast_rl::ensemble::{EnsemblePolicy, load_policies, run_policies};
use firecast_rl::policy::{PolicyConfig, PolicyKind, View};
use firecast_sim::EnvConfig;
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
  landscape_seeds: [2]
  width: 48
  height: 32
  fires: 1
  seed: 1
  wind_speed_mph: [2, 6]
  dead_1h_frac: [0.04, 0.06]
  ignition_margin_cells: 8
"#;

fn setup(width: usize, height: usize) -> Setup {
    let env = EnvConfig {
        max_steps: 60,
        ..EnvConfig::default()
    };
    let scenario = Scenario::new(
        LandscapeSpec::Procedural {
            seed: 5,
            width,
            height,
            center: None,
        },
        env,
    );
    Setup::new(scenario, Path::new("."), None).expect("the scenario")
}

fn ensemble(setup: &Setup, policies: &[EnsemblePolicy], runs: usize, seed: u64) -> Ensemble {
    let out = run_policies(setup, policies, runs, seed, &|| {}).expect("the runs");
    assemble(setup, "ppo", "test".into(), out).expect("the ensemble")
}

#[test]
fn a_runs_policies_play_an_ensemble_reproducibly() {
    let tmp = tempfile::tempdir().expect("a temporary folder");
    let (run, _) = tiny_run(tmp.path(), FIRES);
    let (summary, policies) = load_policies(&run, Device::Cpu).expect("loading the run");
    assert_eq!(summary.seeds.len(), 2);
    assert!(policies.iter().all(|p| p.normalize.is_some()));
    assert_eq!(policies.iter().map(|p| p.seed).collect::<Vec<_>>(), vec![0, 1]);
    let s = setup(48, 32);
    let e = ensemble(&s, &policies, 3, 11);
    assert_eq!(e.runs(), 3);
    for (k, ep) in e.episodes.iter().enumerate() {
        assert_eq!(ep.seed, 11 + k as u64);
        assert_eq!(
            ep.policy.as_deref(),
            Some(["training seed 0", "training seed 1"][k % 2])
        );
        // The same perturbed weather as sim.ensemble's run with this seed.
        assert_eq!(ep.conditions, s.run_env(ep.seed).1);
        assert!(ep.burned_per_step.len() >= 2 && ep.burned_per_step.len() <= 61);
        assert_eq!(ep.burned_per_step.last().copied(), Some(ep.cells_burned));
        assert!(ep.helitacks as usize >= ep.drops.len());
    }
    let cells = 48 * 32;
    assert_eq!(e.burn_count.len(), cells);
    for i in 0..cells {
        assert!(e.burn_count[i] <= 3);
        assert_eq!(e.arrival_first_h[i].is_some(), e.burn_count[i] > 0, "cell {i}");
        // The median arrival exists where at least half of the runs (2 of 3) burned.
        assert_eq!(e.arrival_median_h[i].is_some(), e.burn_count[i] >= 2, "cell {i}");
        if let (Some(f), Some(m)) = (e.arrival_first_h[i], e.arrival_median_h[i]) {
            assert!(f <= m, "cell {i}: first {f} > median {m}");
        }
    }
    assert_eq!(
        e.burn_count[s.ignition[1] * 48 + s.ignition[0]],
        3,
        "the ignition burns in every run"
    );
    assert!(
        e.burn_count.iter().filter(|&&c| c > 0).count() > 1,
        "the fire spreads"
    );
    // Same seed, same bytes.
    let again = ensemble(&s, &policies, 3, 11);
    assert_eq!(serde_json::to_vec(&e).ok(), serde_json::to_vec(&again).ok());
    assert_eq!(e, again);

    // The compact policy plays a larger landscape than it was trained on (its features are
    // pooled to the training grid); a smaller one is refused.
    let larger = ensemble(&setup(80, 56), &policies, 2, 11);
    assert_eq!(larger.runs(), 2);
    assert_eq!(larger.burn_count.len(), 80 * 56);
    assert!(larger.episodes.iter().all(|ep| ep.cells_burned > 0));
    let err = run_policies(&setup(40, 32), &policies, 1, 0, &|| {})
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(err.contains("trained on observations"), "{err}");
}

/// A policy with a window around the helicopter plays landscapes of any size, smaller ones
/// than its training map included, and reproducibly.
#[test]
fn a_windowed_policy_plays_any_landscape() {
    let tmp = tempfile::tempdir().expect("a temporary folder");
    let windowed = PolicyConfig {
        kind: PolicyKind::Compact,
        view: View::Helicopter,
        focus: 4,
        window: Some([16, 24]),
        context: 3,
        ..PolicyConfig::default()
    };
    let (run, _) = tiny_run_with(tmp.path(), FIRES, Some(windowed));
    let (_, policies) = load_policies(&run, Device::Cpu).expect("loading the run");
    for (w, h) in [(40, 32), (24, 16), (80, 56)] {
        let e = ensemble(&setup(w, h), &policies, 2, 11);
        assert_eq!((e.runs(), e.burn_count.len()), (2, w * h), "{w}×{h}");
        assert!(e.episodes.iter().all(|ep| ep.cells_burned > 0), "{w}×{h}");
        assert_eq!(e, ensemble(&setup(w, h), &policies, 2, 11), "{w}×{h}");
    }
}
