//! `rl.ensemble`: the trained PPO policies of a run folder against one fire, replayed over
//! many seeds, written as the ensemble file `sim.ensemble` writes (arrival times, burn
//! probability, drops). Run `k` is seeded `seed + k`, meets the weather and moisture
//! `sim.ensemble`'s run `k` meets (so strategies compare paired), and is played by policy
//! `k mod P` (the run's training seeds in order); all runs step together with one batched
//! forward pass per policy and step.

use std::path::Path;

use firecast_episodes::ensemble::{EpisodeRecord, RunConditions, Setup, Tracker};
use firecast_episodes::{EnsembleParams, prepare_ensemble};
use firecast_pipeline::{ParamsError, Port, Ports, StageContext, StageError, StageKind, typed_params};
use firecast_ppo::env::{ObsBatch, ObsSpace};
use firecast_ppo::normalize::VecNormalize;
use firecast_ppo::train::{pick_action, policy_log_probs_of};
use firecast_sim::env::EnvCore;
use firecast_sim::{Action, StepInfo};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rayon::prelude::*;
use serde::Deserialize;

use crate::RlError;
use crate::helitack;
use crate::policy::{Policy, PolicyKind};
use crate::run::TrainSummary;

/// Runs stepped together at most; bounds memory for large ensembles (the chunking is fixed,
/// so the output does not depend on the machine).
const CHUNK: usize = 256;

/// One trained policy of a run.
pub struct EnsemblePolicy {
    /// The training seed.
    pub seed: u64,
    pub policy: Policy,
    /// The observation normaliser frozen at the end of training (SB3's `VecNormalize` in
    /// evaluation mode); `None` when training did not normalise observations.
    pub normalize: Option<VecNormalize>,
}

/// Loads every policy of a training-run folder, with its frozen observation normaliser.
pub fn load_policies(
    dir: &Path,
    device: tch::Device,
) -> Result<(TrainSummary, Vec<EnsemblePolicy>), RlError> {
    #[derive(Deserialize)]
    struct Head {
        normalize: Option<VecNormalize>,
    }
    let (summary, policies) = crate::run::load_run(dir, device)?;
    let mut out = Vec::with_capacity(policies.len());
    for ((seed, policy), s) in policies.into_iter().zip(&summary.seeds) {
        let path = dir.join(&s.policy).join("trainer.json");
        let text = std::fs::read(&path).map_err(|e| RlError::io("reading the policy", &path, e))?;
        let head: Head = serde_json::from_slice(&text).map_err(|e| RlError::Checkpoint {
            path: path.clone(),
            message: e.to_string(),
        })?;
        out.push(EnsemblePolicy {
            seed,
            policy,
            normalize: head.normalize.filter(|n| n.config.obs),
        });
    }
    if out.is_empty() {
        return Err(RlError::Checkpoint {
            path: dir.to_path_buf(),
            message: "the training run holds no policies".into(),
        });
    }
    Ok((summary, out))
}

/// One run in flight.
struct Live {
    core: EnvCore,
    conditions: RunConditions,
    frames: Vec<u8>,
    tracker: Tracker,
    last: StepInfo,
    /// `Some(terminated)` once the run ended.
    ended: Option<bool>,
}

/// Plays `runs` runs of `setup` (run `k`: seed `seed + k`, its weather and moisture drawn by
/// [`Setup::run_env`] as `sim.ensemble` draws them, policy `k mod P`) with greedy actions;
/// returns each run's record and per-cell arrival hours, in run order. `on_run` is called
/// once per finished run.
pub fn run_policies(
    setup: &Setup,
    policies: &[EnsemblePolicy],
    runs: usize,
    seed: u64,
    on_run: &(dyn Fn() + Sync),
) -> Result<Vec<(EpisodeRecord, Vec<f32>)>, RlError> {
    if policies.is_empty() {
        return Err(RlError::config("run", "no policies to play"));
    }
    let (w, h) = (setup.landscape.width, setup.landscape.height);
    let space = helitack::space(w, h);
    for p in policies {
        if !p.policy.accepts(space) {
            return Err(RlError::config(
                "run",
                format!(
                    "the policy of training seed {} was trained on observations of {}, this {w}×{h} landscape gives {}",
                    p.seed,
                    space_text(p.policy.space),
                    space_text(space)
                ),
            ));
        }
    }
    // Greedy actions draw nothing; the stream exists for pick_action's signature.
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let il = space.image_len();
    let mut out = Vec::with_capacity(runs);
    for start in (0..runs).step_by(CHUNK) {
        let ks: Vec<usize> = (start..(start + CHUNK).min(runs)).collect();
        let mut live: Vec<Live> = ks
            .par_iter()
            .map(|&k| {
                let s = seed.wrapping_add(k as u64);
                let (cfg, conditions) = setup.run_env(s);
                let mut core = EnvCore::new(&setup.landscape, &cfg)?;
                let mut frames = vec![0u8; core.frames_len()];
                let info = core.reset_into(s, &mut frames);
                Ok(Live {
                    tracker: Tracker::new(&core, &info),
                    core,
                    conditions,
                    frames,
                    last: info,
                    ended: None,
                })
            })
            .collect::<Result<_, RlError>>()?;
        // Recurrent policies' states, one row per run of the chunk (each run is one episode).
        let mut hiddens: Vec<_> = policies
            .iter()
            .map(|p| p.policy.initial_hidden(ks.len()))
            .collect();
        loop {
            // Per run of this chunk: its action this step (None: ended).
            let mut actions: Vec<Option<u8>> = vec![None; ks.len()];
            for (g, p) in policies.iter().enumerate() {
                let rows: Vec<usize> = (0..ks.len())
                    .filter(|&i| live[i].ended.is_none() && ks[i] % policies.len() == g)
                    .collect();
                if rows.is_empty() {
                    continue;
                }
                let mut obs = ObsBatch::new(space, rows.len());
                for (row, &i) in rows.iter().enumerate() {
                    let r = &live[i];
                    helitack::encode(
                        &r.frames,
                        r.core.helicopter(),
                        r.core.on_fire(),
                        w,
                        h,
                        &mut obs.image[row * il..(row + 1) * il],
                        &mut obs.vector[row * 3..(row + 1) * 3],
                    );
                }
                if let Some(n) = &p.normalize {
                    n.normalize_obs(&mut obs.vector);
                }
                let acts: Vec<u8> = policy_log_probs_of(&p.policy, &obs, hiddens[g].as_mut(), &rows)
                    .chunks(p.policy.num_actions)
                    .map(|row| pick_action(row, true, &mut rng))
                    .collect();
                for (&i, a) in rows.iter().zip(acts) {
                    actions[i] = Some(a);
                }
            }
            if actions.iter().all(Option::is_none) {
                break;
            }
            // Runs are disjoint: step them in parallel, each in its own slot.
            live.par_iter_mut().zip(&actions).for_each(|(r, a)| {
                let Some(a) = *a else { return };
                let action = Action::try_from(a).unwrap_or(Action::North);
                let (_, te, tr, info) = r.core.step_into(action, None, &mut r.frames);
                r.tracker.observe(&r.core, &info);
                r.last = info;
                if te || tr {
                    r.ended = Some(te);
                    on_run();
                }
            });
        }
        for (r, &k) in live.into_iter().zip(&ks) {
            let s = seed.wrapping_add(k as u64);
            let p = &policies[k % policies.len()];
            out.push(r.tracker.finish(
                &r.core,
                &r.last,
                r.ended.unwrap_or(false),
                s,
                Some(format!("training seed {}", p.seed)),
                r.conditions,
            ));
        }
    }
    Ok(out)
}

/// An observation space in words: `5×160×240 cells + 3 numbers`.
fn space_text(space: ObsSpace) -> String {
    match space.image {
        Some([c, h, w]) => format!("{c}×{h}×{w} cells + {} numbers", space.vector),
        None => format!("{} numbers", space.vector),
    }
}

fn kind_name(kind: PolicyKind) -> &'static str {
    match kind {
        PolicyKind::Mlp => "mlp",
        PolicyKind::Compact => "compact",
        PolicyKind::Paper => "paper",
    }
}

/// The ensemble's description line.
fn describe(run: &Path, summary: &TrainSummary, policies: &[EnsemblePolicy]) -> String {
    let folder = run
        .file_name()
        .map_or_else(|| run.display().to_string(), |n| n.to_string_lossy().into_owned());
    let seeds: Vec<String> = policies.iter().map(|p| p.seed.to_string()).collect();
    format!(
        "PPO policies of the training run `{folder}` ({}; `{}` network), training seeds {}; greedy actions",
        summary.name,
        kind_name(summary.policy.kind),
        seeds.join(", ")
    )
}

/// Inputs: `run` (the policies), then `sim.ensemble`'s (the scenario's files). Built from
/// `sim.ensemble`'s ports, as `firecast-episodes` exports the kind rather than its port list.
static INPUTS: std::sync::LazyLock<Vec<Port>> = std::sync::LazyLock::new(|| {
    let mut ports = vec![Port {
        name: "run",
        required: true,
        many: false,
        description: "an rl.train run folder (summary.json and one policy per training seed)",
    }];
    ports.extend_from_slice(firecast_episodes::EnsembleStage.ports().inputs);
    ports
});

/// `rl.ensemble`: a training run's PPO policies against one fire over many seeds.
#[derive(Debug, Default)]
pub struct EnsembleStage;

impl StageKind for EnsembleStage {
    fn name(&self) -> &'static str {
        "rl.ensemble"
    }

    fn version(&self) -> u32 {
        // 2: the landscape's label and each run's edge cells in the file (as sim.ensemble v2).
        2
    }

    fn summary(&self) -> &'static str {
        "one fire over many seeds under a run's PPO policies: arrival times, burn probability, drops"
    }

    fn ports(&self) -> Ports {
        Ports {
            inputs: INPUTS.as_slice(),
            // `ensemble`, as sim.ensemble writes it.
            outputs: firecast_episodes::EnsembleStage.ports().outputs,
            open: false,
        }
    }

    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (params, mut resolved): (EnsembleParams, serde_json::Value) = typed_params(raw)?;
        params.validate(false)?;
        let device = params.device.clone().unwrap_or_else(|| "auto".into());
        let threads = params.threads.unwrap_or(firecast_learn::DEFAULT_THREADS);
        firecast_learn::check_threads(threads).map_err(|message| ParamsError {
            path: "threads".into(),
            message,
        })?;
        crate::parse_device(&device).map_err(|e| ParamsError {
            path: "device".into(),
            message: match e {
                RlError::Config { message, .. } => message,
                other => other.to_string(),
            },
        })?;
        if let Some(obj) = resolved.as_object_mut() {
            if params.env.is_null() {
                obj.insert("env".into(), serde_json::json!({}));
            }
            obj.insert("device".into(), device.into());
            obj.insert("threads".into(), threads.into());
        }
        Ok(resolved)
    }

    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        // libtorch's one generator: stages using it run one at a time (reproducible).
        firecast_learn::exclusive(|| {
            let params: EnsembleParams = ctx.params()?;
            let run = ctx.input("run")?.to_path_buf();
            let device = crate::parse_device(params.device.as_deref().unwrap_or("auto"))?;
            firecast_learn::set_threads(params.threads.unwrap_or(firecast_learn::DEFAULT_THREADS));
            let setup = prepare_ensemble(ctx, &params)?;
            let (summary, policies) = load_policies(&run, device)?;
            let (w, h) = (setup.landscape.width, setup.landscape.height);
            let space = helitack::space(w, h);
            if let Some(p) = policies.iter().find(|p| !p.policy.accepts(space)) {
                return Err(StageError::msg(format!(
                    "training run {}: the policy of training seed {} was trained on observations of {}, \
                 but this {w}×{h} landscape gives {} (train on a landscape of the same size; the compact policy also plays larger ones)",
                    run.display(),
                    p.seed,
                    space_text(p.policy.space),
                    space_text(space)
                )));
            }
            let bar = ctx.progress_bar(params.runs as u64, "ppo policy");
            let runs = run_policies(&setup, &policies, params.runs, params.seed, &|| bar.inc(1))?;
            bar.finish_and_clear();
            let description = describe(&run, &summary, &policies);
            let ensemble = firecast_episodes::ensemble::assemble(&setup, "ppo", description, runs)?;
            firecast_episodes::write_ensemble(ctx, &ensemble, &format!("ppo ({} policies)", policies.len()))
        })
    }
}
