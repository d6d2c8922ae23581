//! A training run: every seed of a [`TrainSpec`], checkpointed in a work folder (so an
//! interrupted run resumes exactly), results published into an output folder: per seed the
//! final policy (a checkpoint), per-update metrics; a training-curve plot; `summary.json`.

use std::io::Write;
use std::path::{Path, PathBuf};

use firecast_ppo::cartpole::CartPoleVec;
use firecast_ppo::env::VecEnvironment;
use firecast_ppo::train::{POLICY_FILE, TrainSink, Trainer};
use serde::{Deserialize, Serialize};
use tch::Device;

use crate::RlError;
use crate::helitack::{FireDraw, HelitackVec};
use crate::policy::{Policy, PolicyConfig};
use crate::spec::{EnvSpec, FiresSpec, TrainSpec};

/// What a run reports while it trains.
pub trait RunSink: Sync {
    fn message(&self, _line: &str) {}
    fn metric(&self, _seed: u64, _timesteps: u64, _key: &str, _value: f64) {}
    fn progress(&self, _seed: u64, _timesteps: u64, _total: u64, _fps: f64, _ep_rew_mean: f64) {}
}

/// One seed's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeedSummary {
    pub seed: u64,
    pub timesteps: u64,
    /// Timesteps of the checkpoint this process resumed from, if it did.
    pub resumed_from: Option<u64>,
    /// Mean return of the last 100 training episodes (`None` before the first ended).
    pub ep_rew_mean: Option<f64>,
    pub ep_len_mean: Option<f64>,
    /// Folder of the final policy (relative to the run's output).
    pub policy: String,
    pub parameters: i64,
    /// Environment steps spent imitating a teacher before PPO (`imitation:`).
    #[serde(default, skip_serializing_if = "firecast_ppo::train::is_zero")]
    pub imitation_timesteps: u64,
}

/// `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainSummary {
    pub name: String,
    pub spec: TrainSpec,
    pub ppo: firecast_ppo::ppo::PpoConfig,
    pub policy: crate::policy::PolicyConfig,
    pub device: String,
    pub seeds: Vec<SeedSummary>,
    /// The fire file (relative to the repository root when inside it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fires_file: Option<PathBuf>,
    /// The training fires (helitack only).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fires: Vec<FireDraw>,
}

pub const SUMMARY_FILE: &str = "summary.json";

/// Version of the `rl.train` kind; also keys the checkpoint folders in `.firecast/rl/`, so a
/// resume never continues a checkpoint that other code made. 2: recurrent weights lead
/// Adam's flat buffer in cuDNN's order (the `paper` policy's gradient-norm sums run in
/// another order).
pub const TRAIN_VERSION: u32 = 2;

struct SeedSink<'a> {
    seed: u64,
    run: &'a dyn RunSink,
    metrics: std::cell::RefCell<std::fs::File>,
}

impl SeedSink<'_> {
    /// One `metrics.jsonl` row: every metric of the update under SB3's names, `time/fps`
    /// included (as SB3's `progress.csv` has it). `time/fps` is the one wall-clock value in
    /// the run's files: every other key is the same for the same config and seed.
    fn write_row(&self, timesteps: u64, imitation_timesteps: Option<u64>, metrics: &[(String, f64)]) {
        let mut row = serde_json::Map::new();
        row.insert("timesteps".into(), timesteps.into());
        if let Some(n) = imitation_timesteps {
            row.insert("imitation/timesteps".into(), n.into());
        }
        for (k, v) in metrics {
            row.insert(
                k.clone(),
                serde_json::Number::from_f64(*v).map_or(serde_json::Value::Null, Into::into),
            );
        }
        let _ = writeln!(self.metrics.borrow_mut(), "{}", serde_json::Value::Object(row));
    }
}

impl TrainSink for SeedSink<'_> {
    fn update(&self, timesteps: u64, metrics: &[(String, f64)]) {
        for (k, v) in metrics {
            self.run.metric(self.seed, timesteps, k, *v);
        }
        self.write_row(timesteps, None, metrics);
    }
    fn progress(&self, timesteps: u64, total: u64, fps: f64, ep_rew_mean: f64) {
        self.run.progress(self.seed, timesteps, total, fps, ep_rew_mean);
    }
    /// Rows at `timesteps` 0 (before PPO's first step), with the imitation's own count.
    fn imitation(&self, imitation_timesteps: u64, metrics: &[(String, f64)]) {
        for (k, v) in metrics {
            self.run.metric(self.seed, imitation_timesteps, k, *v);
        }
        self.write_row(0, Some(imitation_timesteps), metrics);
        let round = metrics.first().map_or(0.0, |(_, v)| *v);
        self.run.message(&format!(
            "seed {}: imitation round {round:.0} done ({imitation_timesteps} steps)",
            self.seed
        ));
    }
    fn checkpoint(&self, dir: &Path, timesteps: u64) {
        self.run.message(&format!(
            "seed {}: checkpoint at {timesteps} steps in {}",
            self.seed,
            dir.display()
        ));
    }
}

/// Builds the training environments of `spec` for `seed`.
pub fn train_env(
    spec: &TrainSpec,
    fires: Option<&TrainingFires>,
    n_envs: usize,
    seed: u64,
) -> Result<Box<dyn VecEnvironment>, RlError> {
    Ok(match &spec.env {
        EnvSpec::Cartpole => Box::new(CartPoleVec::new(n_envs, seed)),
        EnvSpec::Helitack { .. } => {
            let Some((_, _, cores)) = fires else {
                return Err(RlError::config(
                    "env.fires",
                    "the helitack environment needs a fire file",
                ));
            };
            Box::new(HelitackVec::new(cores.clone(), n_envs, seed)?)
        }
    })
}

/// A helitack spec's fire file (its reward applied) and its training fires; `None` for
/// CartPole.
pub fn training_fires(spec: &TrainSpec, fires_file: Option<&Path>) -> Result<Option<TrainingFires>, RlError> {
    match (&spec.env, fires_file) {
        (EnvSpec::Helitack { reward, .. }, Some(path)) => {
            let f = FiresSpec::load(path)?.with_reward(reward.as_ref())?;
            let (draws, cores) = f.train.build("train")?;
            Ok(Some((f, draws, cores)))
        }
        (EnvSpec::Helitack { .. }, None) => Err(RlError::config(
            "env.fires",
            "the helitack environment needs a fire file",
        )),
        (EnvSpec::Cartpole, _) => Ok(None),
    }
}

/// A fire file, its training draws and their environments.
pub type TrainingFires = (FiresSpec, Vec<FireDraw>, Vec<firecast_sim::env::EnvCore>);

/// Trains every seed. `work` holds checkpoints (`seed-<n>/step-*`): a seed with a
/// checkpoint there resumes from it. With `stop_after`, each seed stops after that many
/// steps (an interruption: the call returns [`RlError::Interrupted`] with checkpoints kept).
pub fn train(
    spec: &TrainSpec,
    fires_file: Option<&Path>,
    work: &Path,
    out: &Path,
    device: Device,
    sink: &dyn RunSink,
    stop_after: Option<u64>,
) -> Result<TrainSummary, RlError> {
    let ppo = spec.ppo()?;
    let policy = spec.policy();
    let fires = training_fires(spec, fires_file)?;
    std::fs::create_dir_all(out).map_err(|e| RlError::io("creating the run folder", out, e))?;
    let mut seeds = Vec::new();
    for &seed in &spec.seeds {
        let ck = work.join(format!("seed-{seed}"));
        std::fs::create_dir_all(&ck).map_err(|e| RlError::io("creating the checkpoint folder", &ck, e))?;
        let env = train_env(spec, fires.as_ref(), ppo.n_envs, seed)?;
        let (mut trainer, resumed_from) = match firecast_ppo::train::latest_checkpoint(&ck) {
            Some(dir) => {
                let t = Trainer::<PolicyConfig>::resume(&dir, ppo.clone(), env, device)?;
                sink.message(&format!(
                    "seed {seed}: resuming from {} at {} steps",
                    dir.display(),
                    t.num_timesteps
                ));
                let at = t.num_timesteps;
                (t, Some(at))
            }
            None => (Trainer::new(ppo.clone(), &policy, env, seed, device)?, None),
        };
        // Metrics rows after the checkpoint belong to a run that did not survive: drop them.
        let metrics_path = ck.join("metrics.jsonl");
        let kept = keep_rows_until(&metrics_path, trainer.num_timesteps)?;
        let mut file = std::fs::File::create(&metrics_path)
            .map_err(|e| RlError::io("writing metrics", &metrics_path, e))?;
        file.write_all(kept.as_bytes())
            .map_err(|e| RlError::io("writing metrics", &metrics_path, e))?;
        let seed_sink = SeedSink {
            seed,
            run: sink,
            metrics: std::cell::RefCell::new(file),
        };
        let started = std::time::Instant::now();
        if let Some(cfg) = &spec.imitation {
            let mut teacher = crate::imitation::teacher(cfg.teacher, trainer.policy.space)?;
            if resumed_from.is_none() {
                trainer.imitate(cfg, teacher.as_mut(), &seed_sink)?;
            }
            trainer.kickstart(teacher, cfg.kickstart)?;
        }
        trainer.learn_until(&seed_sink, Some((&ck, spec.checkpoint_every)), stop_after)?;
        if trainer.num_timesteps < ppo.total_timesteps {
            return Err(RlError::Interrupted);
        }
        // No PPO step (a policy that only imitates): the policy as imitation left it.
        if firecast_ppo::train::latest_checkpoint(&ck).is_none() {
            trainer.save(&ck.join(format!("step-{:09}", trainer.num_timesteps)))?;
        }
        let last = firecast_ppo::train::latest_checkpoint(&ck).ok_or_else(|| RlError::Checkpoint {
            path: ck.clone(),
            message: "no checkpoint after training".into(),
        })?;
        let dest = out.join(format!("seed-{seed}"));
        copy_dir(&last, &dest.join("policy"))?;
        std::fs::copy(&metrics_path, dest.join("metrics.jsonl"))
            .map_err(|e| RlError::io("copying metrics", &dest, e))?;
        let mean = |f: &dyn Fn(&firecast_ppo::train::EpisodeRecord) -> f64| {
            let v: Vec<f64> = trainer.episodes.iter().map(f).collect();
            (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
        };
        seeds.push(SeedSummary {
            seed,
            timesteps: trainer.num_timesteps,
            resumed_from,
            ep_rew_mean: mean(&|e| e.reward),
            ep_len_mean: mean(&|e| e.length as f64),
            policy: format!("seed-{seed}/policy"),
            parameters: trainer.policy.parameter_count(),
            imitation_timesteps: trainer.imitation_timesteps,
        });
        // Seconds of this process's training (not earlier, resumed parts): registry only.
        sink.metric(
            seed,
            trainer.num_timesteps,
            "time/seconds",
            started.elapsed().as_secs_f64(),
        );
    }
    let summary = TrainSummary {
        name: spec.name.clone(),
        spec: spec.clone(),
        ppo,
        policy,
        device: format!("{device:?}"),
        seeds,
        fires_file: fires_file.map(Path::to_path_buf),
        fires: fires.map(|(_, d, _)| d).unwrap_or_default(),
    };
    let path = out.join(SUMMARY_FILE);
    let json = serde_json::to_vec_pretty(&summary).map_err(|e| RlError::config("summary", e.to_string()))?;
    std::fs::write(&path, json).map_err(|e| RlError::io("writing the summary", &path, e))?;
    plot_training(out, &summary)?;
    Ok(summary)
}

/// Lines of a metrics file whose `timesteps` ≤ `until`.
fn keep_rows_until(path: &Path, until: u64) -> Result<String, RlError> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(String::new()),
        Err(e) => return Err(RlError::io("reading metrics", path, e)),
    };
    let mut kept = String::new();
    for line in text.lines() {
        let ts = serde_json::from_str::<serde_json::Value>(line)
            .ok()
            .and_then(|v| v.get("timesteps").and_then(serde_json::Value::as_u64));
        if ts.is_some_and(|t| t <= until) {
            kept.push_str(line);
            kept.push('\n');
        }
    }
    Ok(kept)
}

fn copy_dir(from: &Path, to: &Path) -> Result<(), RlError> {
    std::fs::create_dir_all(to).map_err(|e| RlError::io("copying the policy", to, e))?;
    for entry in std::fs::read_dir(from).map_err(|e| RlError::io("copying the policy", from, e))? {
        let entry = entry.map_err(|e| RlError::io("copying the policy", from, e))?;
        std::fs::copy(entry.path(), to.join(entry.file_name()))
            .map_err(|e| RlError::io("copying the policy", entry.path(), e))?;
    }
    Ok(())
}

/// Reads the per-update metrics of one seed.
pub fn read_metrics(path: &Path) -> Result<Vec<serde_json::Map<String, serde_json::Value>>, RlError> {
    let text = std::fs::read_to_string(path).map_err(|e| RlError::io("reading metrics", path, e))?;
    Ok(text
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter_map(|v| v.as_object().cloned())
        .collect())
}

/// `training.png`: episode return (mean of the last 100) against steps, one line per seed.
fn plot_training(out: &Path, summary: &TrainSummary) -> Result<(), RlError> {
    use firecast_render::chart::{Chart, LegendPosition, OKABE_ITO, Series};
    let mut chart = Chart::new(900, 520)
        .title(format!(
            "{}: training return (mean of the last 100 episodes)",
            summary.name
        ))
        .x_label("environment steps")
        .y_label("rollout/ep_rew_mean")
        .legend(Some(LegendPosition::BottomRight));
    for (k, s) in summary.seeds.iter().enumerate() {
        let rows = read_metrics(&out.join(format!("seed-{}", s.seed)).join("metrics.jsonl"))?;
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter_map(|r| {
                let x = r.get("timesteps")?.as_f64()?;
                let y = r.get("rollout/ep_rew_mean")?.as_f64()?;
                y.is_finite().then_some((x, y))
            })
            .collect();
        if !pts.is_empty() {
            chart = chart.series(
                Series::line(pts)
                    .label(format!("seed {}", s.seed))
                    .color(OKABE_ITO[k % OKABE_ITO.len()]),
            );
        }
    }
    chart.save_png(out.join("training.png"))?;
    Ok(())
}

/// Where a run keeps its checkpoints: `<root>/.firecast/rl/<name>-<key>` with `key` a hash
/// of the resolved spec and the fire file's bytes, so a changed spec never resumes an
/// unrelated checkpoint.
pub fn work_dir(root: &Path, spec: &TrainSpec, fires_file: Option<&Path>) -> Result<PathBuf, RlError> {
    let mut h = blake3::Hasher::new();
    let mut s = spec.clone();
    // Where the fires come from does not matter, what they are does.
    if let EnvSpec::Helitack { fires, .. } = &mut s.env {
        *fires = None;
    }
    s.description = None;
    h.update(&TRAIN_VERSION.to_le_bytes());
    h.update(&serde_json::to_vec(&s).map_err(|e| RlError::config("", e.to_string()))?);
    if let Some(p) = fires_file {
        h.update(&std::fs::read(p).map_err(|e| RlError::io("reading the fire file", p, e))?);
    }
    let key = h.finalize().to_hex();
    Ok(root
        .join(".firecast/rl")
        .join(format!("{}-{}", spec.name, &key[..16])))
}

/// Reads a run folder's summary and policies.
pub fn load_run(dir: &Path, device: Device) -> Result<(TrainSummary, Vec<(u64, Policy)>), RlError> {
    let path = dir.join(SUMMARY_FILE);
    let text = std::fs::read(&path).map_err(|e| RlError::io("reading the training run", &path, e))?;
    let summary: TrainSummary = serde_json::from_slice(&text).map_err(|e| RlError::Checkpoint {
        path: path.clone(),
        message: e.to_string(),
    })?;
    let policies = summary
        .seeds
        .iter()
        .map(|s| Ok((s.seed, load_policy(&dir.join(&s.policy), device)?)))
        .collect::<Result<Vec<_>, RlError>>()?;
    Ok((summary, policies))
}

/// A trained PPO policy loaded from a checkpoint folder.
pub fn load_policy(dir: &Path, device: Device) -> Result<Policy, RlError> {
    #[derive(Deserialize)]
    struct Head {
        policy: crate::policy::PolicyConfig,
        space: firecast_ppo::env::ObsSpace,
        num_actions: usize,
    }
    let state = dir.join("trainer.json");
    let text = std::fs::read(&state).map_err(|e| RlError::io("reading the policy", &state, e))?;
    let head: Head = serde_json::from_slice(&text).map_err(|e| RlError::Checkpoint {
        path: dir.to_path_buf(),
        message: format!("trainer.json: {e}"),
    })?;
    let mut p = Policy::new(&head.policy, head.space, head.num_actions, device)?;
    p.vs.load(dir.join(POLICY_FILE))
        .map_err(|e| RlError::Checkpoint {
            path: dir.to_path_buf(),
            message: format!("{POLICY_FILE}: {e}"),
        })?;
    Ok(p)
}

/// Whether a seed of `spec` has a checkpoint in `work` short of the budget: an interrupted
/// run, which must run whatever the cache says. A finished run's last checkpoint is not one
/// (invoking it again is `up to date`).
pub fn has_unfinished_checkpoint(work: &Path, spec: &TrainSpec) -> Result<bool, RlError> {
    let total = spec.ppo()?.total_timesteps;
    Ok(spec.seeds.iter().any(|s| {
        firecast_ppo::train::latest_checkpoint(&work.join(format!("seed-{s}"))).is_some_and(|dir| {
            dir.file_name()
                .and_then(|n| n.to_str())
                .and_then(|n| n.strip_prefix("step-"))
                .and_then(|n| n.parse::<u64>().ok())
                .is_none_or(|step| step < total)
        })
    }))
}
