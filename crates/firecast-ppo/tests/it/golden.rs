//! Golden tests against Stable-Baselines3 itself (SB3 2.9.2, torch, numpy from the venv):
//! `sb3_reference.py` builds SB3 objects, runs SB3's own `PPO.train()`,
//! `RolloutBuffer.compute_returns_and_advantage` and `collect_rollouts`, and writes their
//! inputs and outputs; these tests feed the same inputs to firecast-ppo.
//!
//! Tolerances: losses, approx_kl, clip_fraction, gradients (before and after clipping), the
//! gradient norm and the weights after Adam agree within 1e-5·max(1, |SB3|) (absolute below
//! 1, relative above); GAE, returns and the rollout buffer within 1e-6 absolute.
//!
//! Python: the venv's (`firecast_testkit::python_with`); without it, or without
//! stable_baselines3 in it, the tests fail and say to run `cargo xtask setup`.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::Command;
use std::sync::OnceLock;

use firecast_ppo::PpoError;
use firecast_ppo::buffer::RolloutBuffer;
use firecast_ppo::env::{ObsBatch, ObsSpace, VecEnvironment};
use firecast_ppo::policy::{ActorCritic, MlpConfig, MlpPolicy, ObsTensors};
use firecast_ppo::ppo::{Adam, LossSettings, PpoConfig, PpoMinibatch, log_prob_entropy, ppo_losses};
use firecast_ppo::train::Trainer;
use serde_json::Value;
use tch::{Device, Kind, Tensor};

const LOSS_TOL: f64 = 1e-5;
const GAE_TOL: f64 = 1e-6;

/// The fixtures of every case, generated once per test process.
fn fixtures() -> &'static Value {
    static FIXTURES: OnceLock<Value> = OnceLock::new();
    FIXTURES.get_or_init(|| {
        let python = firecast_testkit::python_with(&["stable_baselines3", "torch", "gymnasium", "numpy"]);
        let dir = tempfile::tempdir().expect("temp dir");
        let out = dir.path().join("sb3.json");
        let script = PathBuf::from(
            std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
        )
        .join("tests/it/sb3_reference.py");
        let res = Command::new(&python)
            .arg(&script)
            .arg(&out)
            .env("OMP_NUM_THREADS", "1")
            .output()
            .expect("running sb3_reference.py");
        assert!(
            res.status.success(),
            "sb3_reference.py failed:\n{}",
            String::from_utf8_lossy(&res.stderr)
        );
        let text = std::fs::read(&out).expect("reading the fixtures");
        serde_json::from_slice(&text).expect("parsing the fixtures")
    })
}

fn cases(kind: &str) -> Vec<(&'static str, &'static Value)> {
    let cases = fixtures()["cases"].as_object().expect("cases");
    let found: Vec<_> = cases
        .iter()
        .filter(|(_, c)| c["kind"] == kind)
        .map(|(k, c)| (k.as_str(), c))
        .collect();
    assert!(!found.is_empty(), "no `{kind}` cases in the fixtures");
    found
}

fn floats(v: &Value) -> Vec<f32> {
    v.as_array()
        .expect("a float list")
        .iter()
        .map(|x| x.as_f64().expect("a number") as f32)
        .collect()
}

fn num(v: &Value) -> f64 {
    v.as_f64().expect("a number")
}

fn to_vec(t: &Tensor) -> Vec<f32> {
    Vec::<f32>::try_from(t.detach().to_kind(Kind::Float).flatten(0, -1)).expect("tensor to vec")
}

/// Largest difference, asserting each against `tol·max(1, |expected|)` (`rel`) or `tol`.
fn compare(what: &str, ours: &[f32], sb3: &[f32], tol: f64, rel: bool) -> f64 {
    assert_eq!(ours.len(), sb3.len(), "{what}: lengths differ");
    let mut worst = 0.0f64;
    for (k, (&a, &b)) in ours.iter().zip(sb3).enumerate() {
        let d = (f64::from(a) - f64::from(b)).abs();
        let bound = if rel {
            tol * f64::from(b).abs().max(1.0)
        } else {
            tol
        };
        assert!(
            d <= bound,
            "{what}[{k}]: ours {a} vs SB3 {b} (|Δ| = {d:e} > {bound:e})"
        );
        worst = worst.max(d);
    }
    worst
}

fn compare_scalar(what: &str, ours: f64, sb3: f64, tol: f64) -> f64 {
    let d = (ours - sb3).abs();
    let bound = tol * sb3.abs().max(1.0);
    assert!(
        d <= bound,
        "{what}: ours {ours} vs SB3 {sb3} (|Δ| = {d:e} > {bound:e})"
    );
    d
}

/// Maximum differences per quantity across cases (printed for the record).
#[derive(Default)]
struct Worst(BTreeMap<String, f64>);

impl Worst {
    fn note(&mut self, what: &str, d: f64) {
        let e = self.0.entry(what.to_string()).or_insert(0.0);
        *e = e.max(d);
    }
    fn print(&self, title: &str) {
        eprintln!("{title}: max |ours − SB3|");
        for (k, v) in &self.0 {
            eprintln!("  {k:<28} {v:.3e}");
        }
    }
}

fn mlp_policy(obs_dim: usize, actions: usize) -> MlpPolicy {
    let cfg = MlpConfig::default();
    let space = ObsSpace {
        image: None,
        vector: obs_dim,
    };
    MlpPolicy::new(&cfg, space, actions, Device::Cpu).expect("policy")
}

/// Copies SB3's `state_dict` into the policy's variables, by name; the two name sets must be
/// the same.
fn load_sb3_weights(policy: &MlpPolicy, weights: &Value) {
    let weights = weights.as_object().expect("weights");
    let vars = policy.vs.variables();
    let ours: Vec<&String> = vars.keys().collect();
    let theirs: Vec<&String> = weights.keys().collect();
    let mut ours_sorted = ours.clone();
    ours_sorted.sort();
    let mut theirs_sorted = theirs.clone();
    theirs_sorted.sort();
    assert_eq!(
        ours_sorted, theirs_sorted,
        "parameter names differ from SB3's state_dict"
    );
    for (name, var) in vars {
        let w = &weights[&name];
        let shape: Vec<i64> = w["shape"]
            .as_array()
            .expect("shape")
            .iter()
            .map(|d| d.as_i64().expect("dim"))
            .collect();
        assert_eq!(var.size(), shape, "{name}: shape");
        let data = Tensor::from_slice(&floats(&w["data"])).view(shape.as_slice());
        let mut var = var;
        tch::no_grad(|| var.copy_(&data));
    }
}

fn obs_tensors(obs: &[f32], obs_dim: usize) -> ObsTensors {
    let n = (obs.len() / obs_dim) as i64;
    ObsTensors {
        image: None,
        vector: Tensor::from_slice(obs).view([n, obs_dim as i64]),
    }
}

#[test]
fn ppo_losses_gradients_and_adam_match_sb3_train() {
    firecast_learn::set_threads(1);
    let mut worst = Worst::default();
    for (name, c) in cases("loss") {
        let s = &c["settings"];
        let obs_dim = s["obs"].as_u64().expect("obs") as usize;
        let n_actions = s["act"].as_u64().expect("act") as usize;
        let epochs = s["epochs"].as_u64().expect("epochs") as usize;
        let clip = num(&s["clip"]);
        let clip_vf = s["clip_vf"].as_f64();
        let (ent, vf, mgn, lr) = (num(&s["ent"]), num(&s["vf"]), num(&s["mgn"]), num(&s["lr"]));
        let adam_eps = num(&s["adam_eps"]);
        assert_eq!(adam_eps, PpoConfig::sb3().adam_eps, "{name}: SB3's Adam eps");

        let policy = mlp_policy(obs_dim, n_actions);
        load_sb3_weights(&policy, &c["weights"]);
        let mut vars: Vec<(String, Tensor)> = policy.vs.variables().into_iter().collect();
        vars.sort_by(|a, b| a.0.cmp(&b.0));
        let (names, params): (Vec<String>, Vec<Tensor>) = vars.into_iter().unzip();
        let mut adam = Adam::new(params, adam_eps);

        let actions: Vec<i64> = c["actions"]
            .as_array()
            .expect("actions")
            .iter()
            .map(|a| a.as_i64().expect("action"))
            .collect();
        let mb = PpoMinibatch {
            sequences: None,
            obs: obs_tensors(&floats(&c["obs"]), obs_dim),
            actions: actions
                .iter()
                .map(|&a| u8::try_from(a).expect("action"))
                .collect(),
            old_values: floats(&c["old_values"]),
            old_log_probs: floats(&c["old_log_probs"]),
            advantages: floats(&c["advantages"]),
            returns: floats(&c["returns"]),
        };
        let settings = LossSettings {
            clip_range: clip,
            clip_range_vf: clip_vf,
            ent_coef: ent,
            vf_coef: vf,
            normalize_advantage: true,
        };
        let actions_t = Tensor::from_slice(&actions);

        // The distribution and values before any step (torch's Categorical).
        let (logits, values) = tch::no_grad(|| policy.forward(&mb.obs, true));
        let (logp, entropy) = log_prob_entropy(&logits, &actions_t);
        worst.note(
            "values",
            compare(
                &format!("{name}: values"),
                &to_vec(&values),
                &floats(&c["values"]),
                LOSS_TOL,
                true,
            ),
        );
        worst.note(
            "log_prob",
            compare(
                &format!("{name}: log_prob"),
                &to_vec(&logp),
                &floats(&c["log_prob"]),
                LOSS_TOL,
                true,
            ),
        );
        worst.note(
            "entropy",
            compare(
                &format!("{name}: entropy"),
                &to_vec(&entropy),
                &floats(&c["entropy"]),
                LOSS_TOL,
                true,
            ),
        );
        compare(
            &format!("{name}: evaluate_actions log_prob"),
            &to_vec(&logp),
            &floats(&c["sb3_log_prob"]),
            LOSS_TOL,
            true,
        );
        compare(
            &format!("{name}: evaluate_actions entropy"),
            &to_vec(&entropy),
            &floats(&c["sb3_entropy"]),
            LOSS_TOL,
            true,
        );

        let steps = c["steps"].as_array().expect("steps");
        assert_eq!(steps.len(), epochs);
        let (mut pg, mut vl, mut el, mut cf) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut last_kl, mut last_loss) = (f64::NAN, f64::NAN);
        for (epoch, step) in steps.iter().enumerate() {
            let losses = ppo_losses(&policy, &mb, &settings);
            pg.push(losses.policy_loss);
            vl.push(losses.value_loss);
            el.push(losses.entropy_loss);
            cf.push(losses.clip_fraction);
            last_kl = losses.approx_kl;
            last_loss = losses.loss_value;
            adam.gradients(&losses.surrogate).expect("gradients");
            let grad = adam.gradient().shallow_clone();
            for (label, key) in [("raw grad", "raw_grads"), ("clipped grad", "clipped_grads")] {
                if key == "clipped_grads" {
                    let norm = adam.clip_grad_norm(mgn);
                    worst.note(
                        "grad norm",
                        compare_scalar(
                            &format!("{name} epoch {epoch}: grad norm"),
                            norm,
                            num(&step["total_norm"]),
                            LOSS_TOL,
                        ),
                    );
                }
                let sb3 = step[key].as_object().expect("grads");
                assert_eq!(sb3.len(), names.len(), "{name}: every parameter has a gradient");
                for (n, g) in names.iter().zip(adam.unflatten(&grad)) {
                    let d = compare(
                        &format!("{name} epoch {epoch}: {label} of {n}"),
                        &to_vec(&g),
                        &floats(&sb3[n]),
                        LOSS_TOL,
                        true,
                    );
                    worst.note(label, d);
                }
            }
            adam.step(lr);
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let logged = &c["logged"];
        for (key, ours) in [
            ("train/policy_gradient_loss", mean(&pg)),
            ("train/value_loss", mean(&vl)),
            ("train/entropy_loss", mean(&el)),
            ("train/clip_fraction", mean(&cf)),
            ("train/approx_kl", last_kl),
            ("train/loss", last_loss),
        ] {
            let d = compare_scalar(&format!("{name}: {key}"), ours, num(&logged[key]), LOSS_TOL);
            worst.note(key, d);
        }
        let after = c["weights_after"].as_object().expect("weights_after");
        for (n, p) in names.iter().zip(&adam.params) {
            let d = compare(
                &format!("{name}: {n} after Adam"),
                &to_vec(p),
                &floats(&after[n]),
                LOSS_TOL,
                true,
            );
            worst.note("weights after Adam", d);
        }
    }
    worst.print("PPO losses vs SB3 train()");
}

#[test]
fn gae_matches_sb3_compute_returns_and_advantage() {
    let mut worst = Worst::default();
    for (name, c) in cases("gae") {
        let n_steps = c["n_steps"].as_u64().expect("n_steps") as usize;
        let n_envs = c["n_envs"].as_u64().expect("n_envs") as usize;
        let space = ObsSpace {
            image: None,
            vector: 1,
        };
        let mut buf = RolloutBuffer::new(n_steps, n_envs, space);
        let rewards = floats(&c["rewards"]);
        let values = floats(&c["values"]);
        let starts = floats(&c["episode_starts"]);
        let obs = ObsBatch::new(space, n_envs);
        for t in 0..n_steps {
            let row = t * n_envs..(t + 1) * n_envs;
            let st: Vec<bool> = starts[row.clone()].iter().map(|&s| s > 0.5).collect();
            buf.add(
                &obs,
                &vec![0; n_envs],
                &rewards[row.clone()],
                &st,
                &values[row],
                &vec![0.0; n_envs],
            );
        }
        assert!(buf.is_full());
        let dones: Vec<bool> = c["dones"]
            .as_array()
            .expect("dones")
            .iter()
            .map(|d| d.as_bool().expect("bool"))
            .collect();
        buf.compute_returns_and_advantage(
            &floats(&c["last_values"]),
            &dones,
            num(&c["gamma"]),
            num(&c["gae_lambda"]),
        );
        worst.note(
            "advantages",
            compare(
                &format!("{name}: advantages"),
                &buf.advantages,
                &floats(&c["advantages"]),
                GAE_TOL,
                false,
            ),
        );
        worst.note(
            "returns",
            compare(
                &format!("{name}: returns"),
                &buf.returns,
                &floats(&c["returns"]),
                GAE_TOL,
                false,
            ),
        );
    }
    worst.print("GAE vs SB3 RolloutBuffer");
}

/// `sb3_reference.py`'s `CountingEnv` under a `TimeLimit`, vectorised with same-step
/// autoreset: obs = [episode/2, t/4, env/8 − 1, t²/16 − 1/2], reward = 1 + t/2 − env/4.
struct CountingVec {
    /// (terminate after k steps, time limit) per env.
    envs: Vec<(Option<u32>, u32)>,
    episode: Vec<u32>,
    t: Vec<u32>,
    terminal: Vec<[f32; 4]>,
    rewards: Vec<f64>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
}

impl CountingVec {
    fn new(envs: Vec<(Option<u32>, u32)>) -> Self {
        let n = envs.len();
        Self {
            envs,
            episode: vec![0; n],
            t: vec![0; n],
            terminal: vec![[0.0; 4]; n],
            rewards: vec![0.0; n],
            terminated: vec![false; n],
            truncated: vec![false; n],
        }
    }
    fn obs(&self, i: usize) -> [f32; 4] {
        let (ep, t) = (self.episode[i] as f32, self.t[i] as f32);
        [ep / 2.0, t / 4.0, i as f32 / 8.0 - 1.0, t * t / 16.0 - 0.5]
    }
}

impl VecEnvironment for CountingVec {
    fn num_envs(&self) -> usize {
        self.envs.len()
    }
    fn space(&self) -> ObsSpace {
        ObsSpace {
            image: None,
            vector: 4,
        }
    }
    fn num_actions(&self) -> usize {
        2
    }
    fn reset(&mut self, _seed: u64) {
        self.episode.fill(0);
        self.t.fill(0);
    }
    fn step(&mut self, _actions: &[u8]) -> Result<(), PpoError> {
        for i in 0..self.envs.len() {
            self.rewards[i] = 1.0 + f64::from(self.t[i]) / 2.0 - i as f64 / 4.0;
            self.t[i] += 1;
            let (term, limit) = self.envs[i];
            self.terminated[i] = term.is_some_and(|k| self.t[i] >= k);
            self.truncated[i] = self.t[i] >= limit;
            if self.terminated[i] || self.truncated[i] {
                self.terminal[i] = self.obs(i);
                self.episode[i] += 1;
                self.t[i] = 0;
            }
        }
        Ok(())
    }
    fn observe(&self, out: &mut ObsBatch) {
        for i in 0..self.envs.len() {
            out.vector_row_mut(i).copy_from_slice(&self.obs(i));
        }
    }
    fn terminal_observation(&self, i: usize, out: &mut ObsBatch, row: usize) {
        out.vector_row_mut(row).copy_from_slice(&self.terminal[i]);
    }
    fn rewards(&self) -> &[f64] {
        &self.rewards
    }
    fn terminated(&self) -> &[bool] {
        &self.terminated
    }
    fn truncated(&self) -> &[bool] {
        &self.truncated
    }
    fn snapshot(&self) -> Value {
        Value::Null
    }
    fn restore(&mut self, _snapshot: &Value) -> Result<(), PpoError> {
        Ok(())
    }
}

#[test]
fn collect_rollouts_bootstraps_time_limits_like_sb3() {
    firecast_learn::set_threads(1);
    let mut worst = Worst::default();
    for (name, c) in cases("timeout") {
        let envs: Vec<(Option<u32>, u32)> = c["envs"]
            .as_array()
            .expect("envs")
            .iter()
            .map(|e| {
                let term = e[0].as_i64().expect("term");
                let limit = e[1].as_u64().expect("limit") as u32;
                ((term >= 0).then_some(term as u32), limit)
            })
            .collect();
        let n_envs = envs.len();
        let n_steps = c["n_steps"].as_u64().expect("n_steps") as usize;
        let ppo = PpoConfig {
            n_envs,
            n_steps,
            batch_size: n_steps,
            gamma: num(&c["gamma"]),
            gae_lambda: num(&c["gae_lambda"]),
            ..PpoConfig::sb3()
        };
        let policy_cfg = MlpConfig::default();
        let mut trainer = Trainer::new(ppo, &policy_cfg, Box::new(CountingVec::new(envs)), 0, Device::Cpu)
            .expect("trainer");
        load_sb3_weights(&trainer.policy, &c["weights"]);
        // At least one truncation is bootstrapped, and the fixture's rewards show it.
        assert!(!c["bootstraps"].as_array().expect("bootstraps").is_empty());
        let buf = trainer.collect_rollout().expect("rollout");
        let actions: Vec<u8> = c["actions"]
            .as_array()
            .expect("actions")
            .iter()
            .map(|a| a.as_u64().expect("action") as u8)
            .collect();
        assert_eq!(buf.actions, actions, "{name}: actions");
        for (what, ours, key) in [
            ("observations", &buf.vectors, "observations"),
            ("rewards", &buf.rewards, "rewards"),
            ("episode_starts", &buf.episode_starts, "episode_starts"),
            ("values", &buf.values, "values"),
            ("log_probs", &buf.log_probs, "log_probs"),
            ("advantages", &buf.advantages, "advantages"),
            ("returns", &buf.returns, "returns"),
        ] {
            worst.note(
                what,
                compare(&format!("{name}: {what}"), ours, &floats(&c[key]), GAE_TOL, false),
            );
        }
    }
    worst.print("collect_rollouts vs SB3");
}
