//! Recurrent PPO (`memory: lstm`): the sequences a minibatch replays give back the rollout's
//! own log-probabilities (stored states, resets at episode starts inside a sequence), the
//! state matters, a resumed run equals a straight one, and bad settings are refused.

use firecast_ppo::env::VecEnvironment;
use firecast_ppo::policy::{Hidden, ObsTensors, SEQUENCE};
use firecast_ppo::ppo::PpoConfig;
use firecast_ppo::train::{NoSink, Trainer};
use firecast_rl::policy::{Memory, PolicyConfig, PolicyKind, View};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use tch::{Device, Kind, Tensor};

fn lstm_policy() -> PolicyConfig {
    PolicyConfig {
        kind: PolicyKind::Compact,
        view: View::Helicopter,
        memory: Memory::Lstm,
        ..PolicyConfig::default()
    }
}

/// Small fires with 12-step episodes, so episodes start inside 16-step sequences.
fn env(n: usize, seed: u64) -> Box<dyn VecEnvironment> {
    Box::new(crate::tiny::small_env(n, seed, 12))
}

fn ppo() -> PpoConfig {
    PpoConfig {
        n_envs: 2,
        n_steps: 32,
        batch_size: 32,
        n_epochs: 2,
        total_timesteps: 4 * 64,
        ..PpoConfig::paper()
    }
}

/// Log-probabilities of the taken actions when the minibatch's sequences are replayed from
/// `hidden`.
fn replayed(
    trainer: &Trainer<PolicyConfig>,
    mb: &firecast_ppo::buffer::Minibatch,
    hidden: &Hidden,
) -> Vec<f32> {
    let seq = mb.sequences.as_ref().expect("a sequence minibatch");
    let (logits, _, _) = tch::no_grad(|| {
        trainer.policy.sequence(
            &ObsTensors::from_batch(&mb.obs, Device::Cpu),
            hidden,
            &seq.starts,
            seq.steps,
            false,
        )
    });
    let actions: Vec<i64> = mb.actions.iter().map(|&a| i64::from(a)).collect();
    let lp = logits
        .log_softmax(-1, Kind::Float)
        .gather(1, &Tensor::from_slice(&actions).unsqueeze(1), false)
        .squeeze_dim(1);
    Vec::<f32>::try_from(lp).expect("log-probabilities")
}

fn max_abs_diff(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

#[test]
fn replayed_sequences_give_the_rollouts_log_probabilities() {
    firecast_learn::set_threads(1);
    let mut t = Trainer::new(ppo(), &lstm_policy(), env(2, 3), 3, Device::Cpu).expect("trainer");
    let buffer = t.collect_rollout().expect("rollout").clone();
    // Episodes of 12 steps: starts fall inside the 16-step sequences.
    let inner_starts = (0..buffer.n_steps)
        .filter(|s| s % SEQUENCE != 0)
        .filter(|s| buffer.episode_starts[s * buffer.n_envs] == 1.0)
        .count();
    assert!(inner_starts > 0, "no episode starts inside a sequence");
    let firsts = buffer.sequence_permutation(SEQUENCE, &mut ChaCha8Rng::seed_from_u64(1));
    assert_eq!(firsts.len(), buffer.n_envs * buffer.n_steps / SEQUENCE);
    let mb = buffer.gather_sequences(&firsts, SEQUENCE);
    let seq = mb.sequences.as_ref().expect("sequences");
    let stored = Hidden::from_host(&seq.hidden, seq.count, Device::Cpu);
    let worst = max_abs_diff(&replayed(&t, &mb, &stored), &mb.log_probs);
    assert!(
        worst < 1e-5,
        "replayed log-probabilities differ from the rollout's by {worst}"
    );
    // From zero states instead of the stored ones they differ: the memory is used.
    let zero = t.policy.initial_hidden(seq.count).expect("recurrent");
    let off = max_abs_diff(&replayed(&t, &mb, &zero), &mb.log_probs);
    assert!(
        off > 1e-4,
        "zero states replay the rollout too ({off}): the state is not used"
    );
}

#[test]
fn a_resumed_recurrent_run_equals_a_straight_run() {
    firecast_learn::set_threads(1);
    let dir = tempfile::tempdir().expect("tempdir");
    let ppo = ppo();
    let straight = {
        let mut t = Trainer::new(ppo.clone(), &lstm_policy(), env(2, 5), 5, Device::Cpu).expect("trainer");
        t.learn(&NoSink, None).expect("training");
        t
    };
    let mut first = Trainer::new(ppo.clone(), &lstm_policy(), env(2, 5), 5, Device::Cpu).expect("trainer");
    first
        .learn_until(&NoSink, Some((dir.path(), 0)), Some(2 * 64))
        .expect("first half");
    let ckpt = firecast_ppo::train::latest_checkpoint(dir.path()).expect("a checkpoint");
    drop(first);
    let mut resumed = Trainer::<PolicyConfig>::resume(&ckpt, ppo, env(2, 99), Device::Cpu).expect("resume");
    resumed.learn(&NoSink, None).expect("second half");
    assert_eq!(resumed.num_timesteps, straight.num_timesteps);
    let a = straight.policy.vs.variables();
    let b = resumed.policy.vs.variables();
    for (name, t) in &a {
        assert!(t.equal(&b[name]), "{name} differs after resuming");
    }
}

#[test]
fn recurrent_settings_are_checked() {
    let mut bad = ppo();
    bad.n_steps = 24;
    bad.batch_size = 24;
    let err = Trainer::new(bad, &lstm_policy(), env(2, 0), 0, Device::Cpu)
        .err()
        .expect("refused");
    assert!(err.to_string().contains("ppo.n_steps"), "{err}");
    let mlp_lstm = PolicyConfig {
        kind: PolicyKind::Paper,
        memory: Memory::Lstm,
        ..PolicyConfig::default()
    };
    let err = Trainer::new(ppo(), &mlp_lstm, env(2, 0), 0, Device::Cpu)
        .err()
        .expect("refused");
    assert!(err.to_string().contains("policy.memory"), "{err}");
}
