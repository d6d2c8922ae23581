//! Imitation before PPO: the chaser teacher reads the trainer's observation exactly as the
//! chaser reads the environment's, imitation makes the policy act like its teacher on fires
//! it never saw, a run with imitation is reproducible and resumes exactly, and bad settings
//! are refused with the key named.

use std::path::Path;

use firecast_ppo::env::{ObsBatch, VecEnvironment};
use firecast_ppo::imitation::Teacher;
use firecast_ppo::ppo::PpoConfig;
use firecast_ppo::train::{NoSink, Trainer, policy_actions};
use firecast_rl::imitation::{ChaserTeacher, ImitationConfig, TeacherKind};
use firecast_rl::policy::{PolicyConfig, PolicyKind, View};
use firecast_rl::spec::{EnvSpec, PpoSpec, TrainSpec};
use firecast_rl::{Device, RlError};
use firecast_sim::agents::{FireChaser, Policy as _};
use firecast_sim::env::{FRAME_STACK, Observation};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;

use crate::tiny::{Quiet, small_env};

fn env(n: usize, seed: u64) -> Box<dyn VecEnvironment> {
    Box::new(small_env(n, seed, 60))
}

fn compact() -> PolicyConfig {
    PolicyConfig {
        kind: PolicyKind::Compact,
        view: View::Helicopter,
        ..PolicyConfig::default()
    }
}

#[test]
fn the_teacher_reads_the_observation_as_the_chaser_reads_the_environment() {
    let n = 4;
    let mut vec = small_env(n, 7, 60);
    vec.reset(7);
    let mut teacher = ChaserTeacher::new(vec.space()).expect("teacher");
    let mut chaser = FireChaser::default();
    let mut obs = ObsBatch::new(vec.space(), n);
    let mut labels = vec![0u8; n];
    let (mut drops, mut moves) = (0, 0);
    for step in 0..150usize {
        vec.observe(&mut obs);
        teacher.act(&obs, &mut labels);
        let inner = vec.inner();
        let (w, h) = (32, 24);
        for (i, &label) in labels.iter().enumerate() {
            let frames = &inner.frames()[i * inner.obs_len()..][..FRAME_STACK * w * h];
            let pos = &inner.agent_positions()[2 * i..2 * i + 2];
            let seen = Observation {
                frames,
                width: w,
                height: h,
                agent: [pos[0], pos[1]],
                on_fire: false,
            };
            assert_eq!(label, chaser.act(&seen).action as u8, "env {i}, step {step}");
            if label == 4 { drops += 1 } else { moves += 1 }
        }
        // The teacher flies half the time, a fixed pattern the other half.
        let actions: Vec<u8> = (0..n)
            .map(|i| {
                if (step + i) % 2 == 0 {
                    labels[i]
                } else {
                    ((step / 3 + i) % 5) as u8
                }
            })
            .collect();
        vec.step(&actions).expect("step");
    }
    assert!(
        drops > 20 && moves > 20,
        "{drops} drops, {moves} moves: not a test of both"
    );
}

/// The search teacher labels every environment with what a rollout search decides on that
/// environment's own fire, and it overrules the chaser where another move burns less.
#[test]
fn the_search_teacher_plans_on_each_environments_own_fire() {
    use firecast_rl::imitation::SearchTeacher;
    use firecast_sim::{RolloutSearch, SearchConfig};
    let n = 4;
    let cfg = SearchConfig {
        horizon: 12,
        ..SearchConfig::default()
    };
    let mut vec = small_env(n, 7, 60);
    vec.reset(7);
    let mut teacher = SearchTeacher::new(vec.space(), cfg).expect("teacher");
    // The same searches, one per environment, fed the same states in lockstep.
    let mut searches: Vec<RolloutSearch> = (0..n as u64)
        .map(|k| RolloutSearch::over_chaser(cfg.stream(k)))
        .collect();
    let mut obs = ObsBatch::new(vec.space(), n);
    let mut labels = vec![0u8; n];
    let mut overruled = 0;
    for step in 0..60usize {
        vec.observe(&mut obs);
        let inner = vec.inner();
        let mut expected = Vec::new();
        for (i, search) in searches.iter_mut().enumerate() {
            let core = &inner.envs()[i];
            let (w, h) = core.grid_size();
            let seen = Observation {
                frames: &inner.frames()[i * inner.obs_len()..][..FRAME_STACK * w * h],
                width: w,
                height: h,
                agent: core.helicopter(),
                on_fire: core.on_fire(),
            };
            let planned = search.decide(core, &seen).action as u8;
            overruled += usize::from(planned != FireChaser::default().act(&seen).action as u8);
            expected.push(planned);
        }
        teacher.act_in(&vec, &obs, &mut labels);
        assert_eq!(labels, expected, "step {step}");
        vec.step(&labels).expect("step");
    }
    assert!(
        overruled > 0,
        "the search never overruled the chaser in {} labels",
        60 * n
    );
}

/// Greedy agreement of a trainer's policy with the chaser on observations of fires flown by
/// the chaser from another seed.
fn agreement(trainer: &Trainer<PolicyConfig>, seed: u64) -> f64 {
    let mut vec = env(4, seed);
    vec.reset(seed);
    let mut teacher = ChaserTeacher::new(vec.space()).expect("teacher");
    let mut obs = ObsBatch::new(vec.space(), 4);
    let mut labels = vec![0u8; 4];
    let (mut same, mut total) = (0usize, 0usize);
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    for _ in 0..100 {
        vec.observe(&mut obs);
        teacher.act(&obs, &mut labels);
        let mut seen = obs.clone();
        trainer.normalize.normalize_obs(&mut seen.vector);
        let acts = policy_actions(&trainer.policy, &seen, None, true, &mut rng);
        same += acts.iter().zip(&labels).filter(|(a, l)| a == l).count();
        total += labels.len();
        vec.step(&labels).expect("step");
    }
    same as f64 / total as f64
}

fn small_ppo() -> PpoConfig {
    PpoConfig {
        n_envs: 4,
        n_steps: 32,
        batch_size: 32,
        n_epochs: 1,
        total_timesteps: 256,
        ..PpoConfig::paper()
    }
}

/// Six rounds of imitating the chaser (two of behaviour cloning), 128 steps each.
fn imitate_the_chaser_briefly(t: &mut Trainer<PolicyConfig>) {
    let cfg = ImitationConfig {
        teacher: TeacherKind::Chaser,
        rounds: 6,
        teacher_rounds: 2,
        updates: 80,
        batch_size: 32,
        learning_rate: 1e-3,
        kickstart: 0.0,
    };
    let mut teacher = ChaserTeacher::new(t.policy.space).expect("teacher");
    t.imitate(&cfg, &mut teacher, &NoSink).expect("imitation");
}

#[test]
fn imitation_makes_the_policy_fly_like_its_teacher_on_unseen_fires() {
    firecast_learn::set_threads(1);
    let mut t = Trainer::new(small_ppo(), &compact(), env(4, 1), 1, Device::Cpu).expect("trainer");
    let before = agreement(&t, 99);
    imitate_the_chaser_briefly(&mut t);
    let after = agreement(&t, 99);
    eprintln!("agreement with the chaser on unseen fires: {before:.3} before, {after:.3} after");
    assert!(after > 0.8 && after > before + 0.15, "{before:.3} → {after:.3}");
    // Imitation's steps are its own: PPO's budget and episode window start empty.
    assert_eq!(t.imitation_timesteps, 6 * 128);
    assert_eq!(t.num_timesteps, 0);
    assert!(t.episodes.is_empty());
}

/// With the pointer to the nearest flames, the student sees what its teacher steers by, so
/// the same short imitation copies the chaser more closely on unseen fires than without it.
#[test]
fn a_student_that_sees_the_nearest_flames_copies_the_chaser_closer() {
    firecast_learn::set_threads(1);
    let imitated = |policy: PolicyConfig| {
        let mut t = Trainer::new(small_ppo(), &policy, env(4, 1), 1, Device::Cpu).expect("trainer");
        imitate_the_chaser_briefly(&mut t);
        agreement(&t, 99)
    };
    let blind = imitated(compact());
    let pointed = imitated(PolicyConfig {
        nearest_flames: true,
        ..compact()
    });
    eprintln!(
        "agreement with the chaser on unseen fires: {blind:.3} without the pointer, {pointed:.3} with it"
    );
    assert!(pointed > 0.95 && pointed > blind, "{blind:.3} → {pointed:.3}");
}

const FIRES: &str = r#"
profile: suppression
train:
  landscape_seeds: [1]
  width: 32
  height: 24
  fires: 3
  seed: 0
  wind_speed_mph: [0, 3]
  dead_1h_frac: [0.09, 0.12]
  ignition_margin_cells: 6
  env: {max_steps: 40}
evaluate:
  landscape_seeds: [2]
  width: 32
  height: 24
  fires: 1
  seed: 1
  wind_speed_mph: [0, 3]
  dead_1h_frac: [0.09, 0.12]
  ignition_margin_cells: 6
"#;

fn spec(imitation: Option<ImitationConfig>) -> TrainSpec {
    let overrides = serde_json::json!({
        "n_envs": 2, "n_steps": 16, "batch_size": 16, "n_epochs": 1, "total_timesteps": 64,
        "normalize": {"obs": true, "reward": true}
    });
    TrainSpec {
        name: "imitate".into(),
        description: None,
        env: EnvSpec::Helitack {
            fires: None,
            reward: None,
        },
        policy: Some(compact()),
        ppo: PpoSpec {
            preset: "paper".into(),
            overrides: overrides.as_object().cloned().unwrap_or_default(),
        },
        imitation,
        seeds: vec![3],
        checkpoint_every: 1,
        device: "cpu".into(),
        threads: 1,
    }
}

fn imitation() -> ImitationConfig {
    ImitationConfig {
        teacher: TeacherKind::Chaser,
        rounds: 3,
        teacher_rounds: 1,
        updates: 5,
        batch_size: 8,
        learning_rate: 1e-3,
        kickstart: 0.5,
    }
}

fn train(dir: &Path, spec: &TrainSpec, stop_after: Option<u64>) -> Result<Vec<u8>, RlError> {
    let fires = dir.join("fires.yaml");
    std::fs::write(&fires, FIRES).expect("fire file");
    let out = dir.join("run");
    firecast_rl::run::train(
        spec,
        Some(&fires),
        &dir.join("work"),
        &out,
        Device::Cpu,
        &Quiet,
        stop_after,
    )?;
    Ok(std::fs::read(out.join("seed-3/policy/policy.safetensors")).expect("policy"))
}

#[test]
fn a_run_with_imitation_is_reproducible_and_resumes_exactly() {
    firecast_learn::set_threads(1);
    let with = spec(Some(imitation()));
    let (a, b, c, d) = (
        tempfile::tempdir().expect("tmp"),
        tempfile::tempdir().expect("tmp"),
        tempfile::tempdir().expect("tmp"),
        tempfile::tempdir().expect("tmp"),
    );
    let straight = train(a.path(), &with, None).expect("straight");
    assert_eq!(
        straight,
        train(b.path(), &with, None).expect("again"),
        "same seed, other bytes"
    );
    // Interrupted after 32 PPO steps, then resumed: no second imitation, the teacher back for
    // kickstarting, the same weights.
    assert!(matches!(
        train(c.path(), &with, Some(32)),
        Err(RlError::Interrupted)
    ));
    assert_eq!(straight, train(c.path(), &with, None).expect("resumed"));
    // And imitation changed the run.
    assert_ne!(straight, train(d.path(), &spec(None), None).expect("without"));
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.path().join("run/summary.json")).expect("summary"))
            .expect("json");
    assert_eq!(summary["seeds"][0]["imitation_timesteps"], 3 * 32);
    let metrics = std::fs::read_to_string(a.path().join("run/seed-3/metrics.jsonl")).expect("metrics");
    assert_eq!(
        metrics
            .lines()
            .filter(|l| l.contains("imitation/accuracy"))
            .count(),
        3
    );
    assert_eq!(
        metrics
            .lines()
            .filter(|l| l.contains("train/kickstart_cross_entropy"))
            .count(),
        2,
        "one kickstarted update per 32-step rollout"
    );
    // Kickstarting changed the run too.
    let plain = spec(Some(ImitationConfig {
        kickstart: 0.0,
        ..imitation()
    }));
    let e = tempfile::tempdir().expect("tmp");
    assert_ne!(straight, train(e.path(), &plain, None).expect("no kickstart"));
    // A policy that only imitates: no PPO step, the imitated policy is the run's.
    let mut only = spec(Some(imitation()));
    only.ppo.overrides.insert("total_timesteps".into(), 0.into());
    only.validate().expect("0 PPO steps with imitation");
    let f = tempfile::tempdir().expect("tmp");
    let imitated = train(f.path(), &only, None).expect("imitation only");
    assert_ne!(imitated, straight);
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(f.path().join("run/summary.json")).expect("summary"))
            .expect("json");
    assert_eq!(summary["seeds"][0]["timesteps"], 0);
    assert_eq!(summary["seeds"][0]["imitation_timesteps"], 3 * 32);
}

#[test]
fn bad_imitation_settings_name_their_key() {
    let key = |s: &TrainSpec| match s.validate() {
        Err(RlError::Config { key, .. }) => key,
        other => panic!("expected a config error, got {other:?}"),
    };
    let mut s = spec(Some(ImitationConfig {
        teacher_rounds: 4,
        ..imitation()
    }));
    assert_eq!(key(&s), "imitation.teacher_rounds");
    s.imitation = Some(ImitationConfig {
        batch_size: 64,
        ..imitation()
    });
    assert_eq!(key(&s), "imitation.batch_size");
    s.imitation = Some(ImitationConfig {
        learning_rate: f64::NAN,
        ..imitation()
    });
    assert_eq!(key(&s), "imitation.learning_rate");
    s.imitation = Some(ImitationConfig {
        kickstart: -1.0,
        ..imitation()
    });
    assert_eq!(key(&s), "imitation.kickstart");
    s.imitation = Some(imitation());
    s.policy = Some(PolicyConfig {
        memory: firecast_rl::policy::Memory::Lstm,
        ..compact()
    });
    assert_eq!(key(&s), "imitation");
    s.policy = None;
    s.env = EnvSpec::Cartpole;
    assert_eq!(key(&s), "imitation.teacher");
    let mut s = spec(None);
    s.ppo.overrides.insert("total_timesteps".into(), 0.into());
    assert_eq!(key(&s), "ppo.total_timesteps");
    // Unknown keys are refused when the spec is read.
    let dir = tempfile::tempdir().expect("tmp");
    let file = dir.path().join("spec.yaml");
    std::fs::write(
        &file,
        "name: x\nenv: {kind: helitack, fires: f.yaml}\nimitation: {teacher: chaser, epochs: 3}\n",
    )
    .expect("spec");
    let err = TrainSpec::load(dir.path(), Path::new("spec.yaml"), &[]).expect_err("unknown key");
    assert!(err.to_string().contains("epochs"), "{err}");
}
