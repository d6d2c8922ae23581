//! The trainer's correctness gate (issue: RL-Zoo's CartPole-v1 hyper-parameters reach a mean
//! return ≥ 475 over 100 episodes within 100,000 steps, on each of 3 seeds), and exact
//! resumption (N + N steps with a checkpoint = 2N steps straight).

use firecast_ppo::cartpole::{CartPole, CartPoleVec};
use firecast_ppo::env::{ObsBatch, VecEnvironment};
use firecast_ppo::policy::MlpConfig;
use firecast_ppo::ppo::PpoConfig;
use firecast_ppo::train::{NoSink, Trainer, policy_actions};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use tch::Device;

fn mlp() -> MlpConfig {
    MlpConfig::default()
}

/// Mean return over `episodes` fresh episodes, greedy or sampled.
fn evaluate(trainer: &Trainer<MlpConfig>, episodes: u64, seed: u64, deterministic: bool) -> f64 {
    let mut total = 0.0;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for e in 0..episodes {
        let mut env = CartPole::new(seed.wrapping_mul(1_000_003).wrapping_add(e));
        let mut obs = ObsBatch::new(trainer.policy.space, 1);
        obs.vector.copy_from_slice(&env.obs());
        loop {
            let a = policy_actions(&trainer.policy, &obs, None, deterministic, &mut rng)[0];
            let (o, r, te, tr) = env.step(a == 1);
            total += r;
            if te || tr {
                break;
            }
            obs.vector.copy_from_slice(&o);
        }
    }
    total / episodes as f64
}

#[test]
fn ppo_solves_cartpole_with_the_zoo_settings_on_three_seeds() {
    firecast_learn::set_threads(1);
    let mut returns = Vec::new();
    for seed in [0u64, 1, 2] {
        let ppo = PpoConfig::cartpole_zoo();
        let env = Box::new(CartPoleVec::new(ppo.n_envs, seed));
        let mut t = Trainer::new(ppo, &mlp(), env, seed, Device::Cpu).expect("trainer");
        t.learn(&NoSink, None).expect("training");
        assert!(t.num_timesteps <= 100_000 + 256, "{}", t.num_timesteps);
        // SB3's `rollout/ep_rew_mean`: the last 100 training episodes.
        let last100: Vec<f64> = t.all_episodes.iter().rev().take(100).map(|e| e.reward).collect();
        let train_mean = last100.iter().sum::<f64>() / last100.len() as f64;
        let sampled = evaluate(&t, 100, 10_000 + seed, false);
        let greedy = evaluate(&t, 100, 20_000 + seed, true);
        eprintln!(
            "seed {seed} after {} steps: last 100 training episodes {train_mean:.1}, 100 new episodes sampled {sampled:.1}, greedy {greedy:.1}",
            t.num_timesteps
        );
        returns.push((train_mean, sampled));
    }
    for (seed, (train, sampled)) in returns.iter().enumerate() {
        assert!(
            *train >= 475.0 && *sampled >= 475.0,
            "seed {seed}: {train} / {sampled} < 475 ({returns:?})"
        );
    }
}

#[test]
fn a_resumed_run_equals_a_straight_run() {
    firecast_learn::set_threads(1);
    let dir = tempfile::tempdir().expect("tempdir");
    let mut ppo = PpoConfig::cartpole_zoo();
    ppo.normalize.obs = true;
    ppo.normalize.reward = true;
    ppo.total_timesteps = 2 * 256 * 3;
    let straight = {
        let env = Box::new(CartPoleVec::new(ppo.n_envs, 7));
        let mut t = Trainer::new(ppo.clone(), &mlp(), env, 7, Device::Cpu).expect("trainer");
        t.learn(&NoSink, None).expect("training");
        t
    };
    let env = Box::new(CartPoleVec::new(ppo.n_envs, 7));
    let mut first = Trainer::new(ppo.clone(), &mlp(), env, 7, Device::Cpu).expect("trainer");
    first
        .learn_until(&NoSink, Some((dir.path(), 0)), Some(256 * 3))
        .expect("first half");
    assert_eq!(first.num_timesteps, 256 * 3);
    let ckpt = firecast_ppo::train::latest_checkpoint(dir.path()).expect("a checkpoint");
    drop(first);
    let env = Box::new(CartPoleVec::new(ppo.n_envs, 999));
    let mut resumed = Trainer::<MlpConfig>::resume(&ckpt, ppo.clone(), env, Device::Cpu).expect("resume");
    resumed.learn(&NoSink, None).expect("second half");
    assert_eq!(resumed.num_timesteps, straight.num_timesteps);
    assert_eq!(resumed.normalize, straight.normalize);
    let a = straight.policy.vs.variables();
    let b = resumed.policy.vs.variables();
    assert_eq!(a.len(), b.len());
    for (name, t) in &a {
        let u = &b[name];
        assert!(t.equal(u), "{name} differs after resuming");
    }
    // A changed hyper-parameter is refused.
    let mut other = ppo.clone();
    other.n_epochs = 3;
    let env = Box::new(CartPoleVec::new(ppo.n_envs, 7));
    let err = Trainer::<MlpConfig>::resume(&ckpt, other, env, Device::Cpu)
        .err()
        .expect("refused");
    assert!(err.to_string().contains("PPO settings differ"), "{err}");
    // So is a folder that is not a checkpoint.
    let env: Box<dyn VecEnvironment> = Box::new(CartPoleVec::new(ppo.n_envs, 7));
    let err = Trainer::<MlpConfig>::resume(dir.path(), ppo, env, Device::Cpu)
        .err()
        .expect("refused");
    assert!(err.to_string().contains("not a FireCast PPO checkpoint"), "{err}");
}

/// The last rollout overshoots the budget (64 steps for 40): SB3's progress would be −0.6 and
/// RL-Zoo's linear schedules a negative learning rate and clip range. FireCast stops the
/// progress at 0, so the last update runs at the schedules' end (0 here) and leaves the
/// weights as they were.
#[test]
fn linear_schedules_stop_at_the_budgets_end() {
    use std::cell::RefCell;
    struct Record(RefCell<Vec<(u64, f64, f64)>>);
    impl firecast_ppo::train::TrainSink for Record {
        fn update(&self, timesteps: u64, metrics: &[(String, f64)]) {
            let get = |k: &str| metrics.iter().find(|(n, _)| n == k).map_or(f64::NAN, |(_, v)| *v);
            self.0
                .borrow_mut()
                .push((timesteps, get("train/learning_rate"), get("train/clip_range")));
        }
    }
    firecast_learn::set_threads(1);
    let ppo = PpoConfig {
        n_envs: 2,
        n_steps: 16,
        batch_size: 32,
        n_epochs: 2,
        total_timesteps: 40,
        ..PpoConfig::cartpole_zoo()
    };
    let env = Box::new(CartPoleVec::new(ppo.n_envs, 0));
    let mut t = Trainer::new(ppo, &mlp(), env, 0, Device::Cpu).expect("trainer");
    let record = Record(RefCell::new(Vec::new()));
    t.learn_until(&record, None, Some(32)).expect("first rollout");
    let weights = |t: &Trainer<MlpConfig>| -> Vec<f32> {
        let mut vars: Vec<(String, tch::Tensor)> = t.policy.vs.variables().into_iter().collect();
        vars.sort_by(|a, b| a.0.cmp(&b.0));
        vars.iter()
            .flat_map(|(_, v)| Vec::<f32>::try_from(v.flatten(0, -1)).expect("f32"))
            .collect()
    };
    let after_first = weights(&t);
    t.learn(&record, None).expect("the overshooting rollout");
    let rows = record.0.into_inner();
    assert_eq!(rows.len(), 2, "{rows:?}");
    let (steps, lr, clip) = rows[0];
    assert_eq!(steps, 32);
    assert!(
        (lr - 1e-3 * 0.2).abs() < 1e-12 && (clip - 0.2 * 0.2).abs() < 1e-12,
        "{rows:?}"
    );
    assert_eq!(rows[1], (64, 0.0, 0.0), "never below the schedules' end");
    assert_eq!(weights(&t), after_first, "a zero learning rate moves nothing");
}
