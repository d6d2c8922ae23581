//! Table IV measured properly: every agent on the same held-out fires (paired), the PPO
//! agent once per training seed; mean and IQM with 95 % stratified bootstrap intervals
//! (strata = training seeds, resampling fires; Agarwal et al. 2021), the paired difference
//! against the rule-based agent and the probability that PPO burns less. The best, median
//! and worst PPO episodes are replayed one fire at a time into Rerun recordings.

use std::path::{Path, PathBuf};

use firecast_eval::bootstrap::{Interval, iqm, stratified_bootstrap};
use firecast_ppo::env::ObsBatch;
use firecast_ppo::train::{pick_action, policy_log_probs_of};
use firecast_sim::env::EnvCore;
use firecast_sim::{
    Action, EpisodeContext, FireChaser, NoSuppression, Observation, Policy as SimPolicy, RolloutSearch,
    RuleBasedAgent, SearchConfig,
};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::RlError;
use crate::agent::PpoAgent;
use crate::ensemble::EnsemblePolicy;
use crate::helitack::{self, FireDraw, FireSet};
use crate::spec::FiresSpec;

/// A statistic of (agent, baseline) pairs.
type PairStat<'a> = &'a dyn Fn(&[(f64, f64)]) -> Option<f64>;

/// One episode's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Episode {
    pub agent: String,
    /// Training seed of a PPO agent; `None` for the baselines.
    pub train_seed: Option<u64>,
    pub fire: usize,
    pub cells_burned: u32,
    /// Unsuppressed cells burned minus this agent's, on the same fire and seed.
    pub cells_saved: f64,
    pub timesteps: u32,
    pub helitacks: u32,
    pub water_used_gal: f64,
    /// The fire went out before the step limit.
    pub contained: bool,
}

/// One metric of one agent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetricSummary {
    pub mean: Interval,
    pub iqm: Interval,
}

/// One agent's row of Table IV.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AgentSummary {
    pub agent: String,
    pub runs: usize,
    pub episodes: usize,
    pub cells_burned: MetricSummary,
    pub cells_saved: MetricSummary,
    pub timesteps: MetricSummary,
    pub helitacks: MetricSummary,
    pub water_used_gal: MetricSummary,
    pub contained_rate: Interval,
}

/// The PPO agent against a baseline, paired by fire.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairedComparison {
    pub agent: String,
    pub baseline: String,
    /// Mean of (agent − baseline) cells burned over (seed, fire) pairs.
    pub cells_burned_diff: Interval,
    /// 1 − mean(agent)/mean(baseline): the paper's "69 % fewer cells".
    pub relative_reduction: Interval,
    /// P(agent burns fewer cells than the baseline on a fire), ties counted ½.
    pub probability_better: Interval,
}

/// `evaluation.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvalReport {
    pub fires: Vec<FireDraw>,
    pub deterministic: bool,
    pub resamples: usize,
    pub agents: Vec<AgentSummary>,
    pub comparisons: Vec<PairedComparison>,
    pub episodes: Vec<Episode>,
    /// Rerun recordings of the best, median and worst PPO episodes (none when recordings
    /// were turned off or no PPO agent was evaluated).
    #[serde(default)]
    pub recordings: Vec<RolloutRecording>,
}

/// One PPO episode replayed into a Rerun recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RolloutRecording {
    /// `best` (fewest cells burned), `median` or `worst` (most).
    pub role: String,
    pub train_seed: u64,
    pub fire: usize,
    /// The episode's seed (the fire's stochastic spread).
    pub seed: u64,
    pub cells_burned: u32,
    pub timesteps: u32,
    pub helitacks: u32,
    /// Relative to the report folder: `recordings/ppo-best.rrd`.
    pub path: PathBuf,
}

/// Settings of an evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EvalConfig {
    /// Greedy PPO actions (SB3's `deterministic=True`); otherwise sampled with `seed`.
    pub deterministic: bool,
    pub resamples: usize,
    pub level: f64,
    pub seed: u64,
    /// Replay the best, median and worst PPO episodes into Rerun recordings.
    pub recordings: bool,
    /// Also fly the rollout search over the chaser (agent `search`, [`firecast_sim::search`]),
    /// compared with the chaser and the PPO agent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub search: Option<SearchConfig>,
}

impl Default for EvalConfig {
    fn default() -> Self {
        Self {
            deterministic: true,
            resamples: 10_000,
            level: 0.95,
            seed: 0,
            recordings: true,
            search: None,
        }
    }
}

/// The seed of every agent's episode on held-out `fire` (paired across agents).
pub fn episode_seed(base: u64, fire: usize) -> u64 {
    base.wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (fire as u64).wrapping_add(1).wrapping_mul(0xBF58_476D_1CE4_E5B9)
}

/// The stream sampled PPO actions on `fire` draw from: one per fire, so one fire replayed
/// alone draws what it drew in the batch.
pub fn action_seed(base: u64, train_seed: u64, fire: usize) -> u64 {
    episode_seed(base ^ train_seed.rotate_left(17), fire)
}

struct Raw {
    fire: usize,
    cells_burned: u32,
    timesteps: u32,
    helitacks: u32,
    water: f64,
    contained: bool,
}

/// A baseline on every fire (in parallel).
fn run_baseline(cores: &[EnvCore], make: &(dyn Fn() -> Box<dyn SimPolicy> + Sync), seed: u64) -> Vec<Raw> {
    cores
        .par_iter()
        .enumerate()
        .map(|(f, proto)| {
            let mut env = proto.clone();
            let mut frames = vec![0u8; env.frames_len()];
            let mut agent = make();
            env.reset_into(episode_seed(seed, f), &mut frames);
            let (w, h) = env.grid_size();
            agent.reset(&EpisodeContext {
                width: w,
                height: h,
                ignition: env.ignition_cell(),
            });
            loop {
                let obs = Observation {
                    frames: &frames,
                    width: w,
                    height: h,
                    agent: env.helicopter(),
                    on_fire: env.on_fire(),
                };
                let d = agent.decide(&env, &obs);
                let (_, te, tr, info) = env.step_into(d.action, d.teleport, &mut frames);
                if te || tr {
                    return Raw {
                        fire: f,
                        cells_burned: info.cells_burnt + info.cells_burning,
                        timesteps: info.step,
                        helitacks: info.drops,
                        water: info.water_used_gal,
                        contained: te,
                    };
                }
            }
        })
        .collect()
}

/// The PPO policy on every fire, all fires stepped together with one batched forward.
fn run_ppo(cores: &[EnvCore], agent: &EnsemblePolicy, cfg: &EvalConfig) -> Result<Vec<Raw>, RlError> {
    let (policy, train_seed) = (&agent.policy, agent.seed);
    let n = cores.len();
    let mut envs: Vec<EnvCore> = cores.to_vec();
    let mut frames: Vec<Vec<u8>> = envs.iter().map(|e| vec![0u8; e.frames_len()]).collect();
    for (f, (env, fr)) in envs.iter_mut().zip(frames.iter_mut()).enumerate() {
        env.reset_into(episode_seed(cfg.seed, f), fr);
    }
    let (w, h) = envs[0].grid_size();
    let space = helitack::space(w, h);
    if !policy.accepts(space) {
        return Err(RlError::config(
            "policy",
            format!(
                "the policy was trained on observations {:?}, these fires give {space:?}",
                policy.space
            ),
        ));
    }
    let mut rngs: Vec<ChaCha8Rng> = (0..n)
        .map(|f| ChaCha8Rng::seed_from_u64(action_seed(cfg.seed, train_seed, f)))
        .collect();
    let mut done: Vec<Option<Raw>> = (0..n).map(|_| None).collect();
    let il = space.image_len();
    // A recurrent policy's state of every fire (each fire is one episode, from zero).
    let mut hidden = policy.initial_hidden(n);
    loop {
        let active: Vec<usize> = (0..n).filter(|&f| done[f].is_none()).collect();
        if active.is_empty() {
            break;
        }
        let mut obs = ObsBatch::new(space, active.len());
        for (row, &f) in active.iter().enumerate() {
            let (img, vec) = (
                &mut obs.image[row * il..(row + 1) * il],
                &mut obs.vector[row * 3..(row + 1) * 3],
            );
            helitack::encode(
                &frames[f],
                envs[f].helicopter(),
                envs[f].on_fire(),
                w,
                h,
                img,
                vec,
            );
        }
        // As training saw them: the frozen normaliser on the vector part.
        if let Some(norm) = &agent.normalize {
            norm.normalize_obs(&mut obs.vector);
        }
        let logp = policy_log_probs_of(policy, &obs, hidden.as_mut(), &active);
        let actions: Vec<u8> = logp
            .chunks(policy.num_actions)
            .zip(&active)
            .map(|(row, &f)| pick_action(row, cfg.deterministic, &mut rngs[f]))
            .collect();
        // Environments and frames are disjoint: step the active ones in parallel.
        let mut stepped: Vec<(usize, Option<Raw>)> = envs
            .par_iter_mut()
            .zip(frames.par_iter_mut())
            .enumerate()
            .filter_map(|(f, (env, fr))| {
                let row = active.binary_search(&f).ok()?;
                let action = Action::try_from(actions[row]).unwrap_or(Action::North);
                let (_, te, tr, info) = env.step_into(action, None, fr);
                Some((
                    f,
                    (te || tr).then(|| Raw {
                        fire: f,
                        cells_burned: info.cells_burnt + info.cells_burning,
                        timesteps: info.step,
                        helitacks: info.drops,
                        water: info.water_used_gal,
                        contained: te,
                    }),
                ))
            })
            .collect();
        for (f, r) in stepped.drain(..) {
            if r.is_some() {
                done[f] = r;
            }
        }
    }
    Ok(done.into_iter().flatten().collect())
}

fn metric(groups: &[Vec<f64>], cfg: &EvalConfig, salt: u64) -> Result<MetricSummary, RlError> {
    let mean = |g: &[Vec<f64>]| {
        let v: Vec<f64> = g.iter().flatten().copied().collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let iqm_of = |g: &[Vec<f64>]| {
        let v: Vec<f64> = g.iter().flatten().copied().collect();
        (!v.is_empty()).then(|| iqm(&v))
    };
    let err = |e: firecast_eval::EvalError| RlError::config("evaluation", e.to_string());
    Ok(MetricSummary {
        mean: stratified_bootstrap(groups, cfg.resamples, cfg.seed ^ salt, cfg.level, mean).map_err(err)?,
        iqm: stratified_bootstrap(groups, cfg.resamples, cfg.seed ^ salt, cfg.level, iqm_of).map_err(err)?,
    })
}

/// The training seeds of some episodes, sorted, once each (`[None]` for a baseline).
fn train_seeds<'a>(eps: impl IntoIterator<Item = &'a Episode>) -> Vec<Option<u64>> {
    let mut seeds: Vec<Option<u64>> = eps.into_iter().map(|e| e.train_seed).collect();
    seeds.sort_unstable();
    seeds.dedup();
    seeds
}

fn summarize(agent: &str, eps: &[&Episode], cfg: &EvalConfig) -> Result<AgentSummary, RlError> {
    // Strata: training seeds (one stratum for a baseline); values: fires.
    let seeds = train_seeds(eps.iter().copied());
    let groups = |f: &dyn Fn(&Episode) -> f64| -> Vec<Vec<f64>> {
        seeds
            .iter()
            .map(|s| eps.iter().filter(|e| e.train_seed == *s).map(|e| f(e)).collect())
            .collect()
    };
    let rate = metric(&groups(&|e| if e.contained { 1.0 } else { 0.0 }), cfg, 6)?.mean;
    Ok(AgentSummary {
        agent: agent.to_string(),
        runs: seeds.len(),
        episodes: eps.len(),
        cells_burned: metric(&groups(&|e| f64::from(e.cells_burned)), cfg, 1)?,
        cells_saved: metric(&groups(&|e| e.cells_saved), cfg, 2)?,
        timesteps: metric(&groups(&|e| f64::from(e.timesteps)), cfg, 3)?,
        helitacks: metric(&groups(&|e| f64::from(e.helitacks)), cfg, 4)?,
        water_used_gal: metric(&groups(&|e| e.water_used_gal), cfg, 5)?,
        contained_rate: rate,
    })
}

fn compare(
    agent: &str,
    baseline: &str,
    episodes: &[Episode],
    cfg: &EvalConfig,
) -> Result<PairedComparison, RlError> {
    let base: std::collections::BTreeMap<usize, f64> = episodes
        .iter()
        .filter(|e| e.agent == baseline)
        .map(|e| (e.fire, f64::from(e.cells_burned)))
        .collect();
    let seeds = train_seeds(episodes.iter().filter(|e| e.agent == agent));
    // Per stratum: (agent, baseline) pairs over fires, encoded as 2 values per fire.
    let pairs: Vec<Vec<(f64, f64)>> = seeds
        .iter()
        .map(|s| {
            episodes
                .iter()
                .filter(|e| e.agent == agent && e.train_seed == *s)
                .filter_map(|e| base.get(&e.fire).map(|&b| (f64::from(e.cells_burned), b)))
                .collect()
        })
        .collect();
    // stratified_bootstrap resamples values; resample pair indices instead.
    let index_groups: Vec<Vec<f64>> = pairs
        .iter()
        .map(|g| (0..g.len()).map(|i| i as f64).collect())
        .collect();
    let stat = |g: &[Vec<f64>], f: PairStat<'_>| {
        let chosen: Vec<(f64, f64)> = g
            .iter()
            .zip(&pairs)
            .flat_map(|(idx, p)| idx.iter().map(move |&i| p[i as usize]))
            .collect();
        f(&chosen)
    };
    let diff = |c: &[(f64, f64)]| {
        (!c.is_empty()).then(|| c.iter().map(|(a, b)| a - b).sum::<f64>() / c.len() as f64)
    };
    let reduction = |c: &[(f64, f64)]| {
        let (a, b): (f64, f64) = c.iter().fold((0.0, 0.0), |(x, y), (a, b)| (x + a, y + b));
        (b > 0.0).then(|| 1.0 - a / b)
    };
    let better = |c: &[(f64, f64)]| {
        (!c.is_empty()).then(|| {
            c.iter()
                .map(|(a, b)| {
                    if a < b {
                        1.0
                    } else if a == b {
                        0.5
                    } else {
                        0.0
                    }
                })
                .sum::<f64>()
                / c.len() as f64
        })
    };
    let err = |e: firecast_eval::EvalError| RlError::config("evaluation", e.to_string());
    let run = |f: PairStat<'_>, salt: u64| {
        stratified_bootstrap(&index_groups, cfg.resamples, cfg.seed ^ salt, cfg.level, |g| {
            stat(g, f)
        })
        .map_err(err)
    };
    Ok(PairedComparison {
        agent: agent.to_string(),
        baseline: baseline.to_string(),
        cells_burned_diff: run(&diff, 11)?,
        relative_reduction: run(&reduction, 11)?,
        probability_better: run(&better, 11)?,
    })
}

/// Two trained agents (several training seeds each) on the same fires: a bootstrap that
/// resamples the fires (paired: a fire drawn counts for both), the first agent's training
/// seeds and the second's, each independently (three strata of
/// [`stratified_bootstrap`]), so the interval carries both runs' seed-to-seed spread. On a
/// resample, Δ = mean over fires of (mean over the first's seeds − mean over the second's);
/// P(better) counts every (seed, seed) pair of a fire, ties ½.
pub fn compare_runs(
    agent: &str,
    other: &str,
    episodes: &[Episode],
    cfg: &EvalConfig,
) -> Result<PairedComparison, RlError> {
    // Cells burned as [seed][fire], over the fires both agents played with every seed.
    let table = |name: &str| -> Vec<std::collections::BTreeMap<usize, f64>> {
        train_seeds(episodes.iter().filter(|e| e.agent == name))
            .into_iter()
            .map(|s| {
                episodes
                    .iter()
                    .filter(|e| e.agent == name && e.train_seed == s)
                    .map(|e| (e.fire, f64::from(e.cells_burned)))
                    .collect()
            })
            .collect()
    };
    let (ta, tb) = (table(agent), table(other));
    let fires: Vec<usize> = ta
        .first()
        .map(|m| m.keys().copied().collect::<Vec<_>>())
        .unwrap_or_default()
        .into_iter()
        .filter(|f| ta.iter().chain(&tb).all(|m| m.contains_key(f)))
        .collect();
    let grid = |t: &[std::collections::BTreeMap<usize, f64>]| -> Vec<Vec<f64>> {
        t.iter().map(|m| fires.iter().map(|f| m[f]).collect()).collect()
    };
    let (a, b) = (grid(&ta), grid(&tb));
    let index = |n: usize| (0..n).map(|i| i as f64).collect::<Vec<f64>>();
    let groups = vec![index(a.len()), index(b.len()), index(fires.len())];
    // Per drawn fire: the two agents' means over their drawn seeds.
    let means = |g: &[Vec<f64>]| -> Option<Vec<(f64, f64)>> {
        let (sa, sb, fs) = (&g[0], &g[1], &g[2]);
        if sa.is_empty() || sb.is_empty() || fs.is_empty() {
            return None;
        }
        let mean = |rows: &[Vec<f64>], seeds: &[f64], f: usize| {
            seeds.iter().map(|&s| rows[s as usize][f]).sum::<f64>() / seeds.len() as f64
        };
        Some(
            fs.iter()
                .map(|&f| (mean(&a, sa, f as usize), mean(&b, sb, f as usize)))
                .collect(),
        )
    };
    let diff = |g: &[Vec<f64>]| {
        let m = means(g)?;
        Some(m.iter().map(|(x, y)| x - y).sum::<f64>() / m.len() as f64)
    };
    let reduction = |g: &[Vec<f64>]| {
        let (x, y) = means(g)?.iter().fold((0.0, 0.0), |(p, q), (x, y)| (p + x, q + y));
        (y > 0.0).then(|| 1.0 - x / y)
    };
    let better = |g: &[Vec<f64>]| {
        let (sa, sb, fs) = (&g[0], &g[1], &g[2]);
        if sa.is_empty() || sb.is_empty() || fs.is_empty() {
            return None;
        }
        let mut wins = 0.0;
        for &f in fs {
            for &s in sa {
                for &t in sb {
                    let (x, y) = (a[s as usize][f as usize], b[t as usize][f as usize]);
                    wins += if x < y {
                        1.0
                    } else if x == y {
                        0.5
                    } else {
                        0.0
                    };
                }
            }
        }
        Some(wins / (fs.len() * sa.len() * sb.len()) as f64)
    };
    let err = |e: firecast_eval::EvalError| RlError::config("evaluation", e.to_string());
    let run = |f: &dyn Fn(&[Vec<f64>]) -> Option<f64>| {
        stratified_bootstrap(&groups, cfg.resamples, cfg.seed ^ 12, cfg.level, f).map_err(err)
    };
    Ok(PairedComparison {
        agent: agent.to_string(),
        baseline: other.to_string(),
        cells_burned_diff: run(&diff)?,
        relative_reduction: run(&reduction)?,
        probability_better: run(&better)?,
    })
}

/// Agent names in Table IV order.
pub const PPO: &str = "ppo";
pub const RULE: &str = "rule";
pub const RULE_CONCENTRIC: &str = "rule-concentric";
/// Flies like the PPO agent (no teleport): what a simple rule achieves under the same moves.
pub const CHASER: &str = "chaser";
/// Plans with the simulator: rollouts of the chaser from each action ([`RolloutSearch`]).
pub const SEARCH: &str = "search";
pub const NONE: &str = "none";

/// Another training run evaluated beside the PPO agent, as agent `ppo:<name>`.
pub struct Against<'a> {
    pub name: &'a str,
    pub policies: &'a [EnsemblePolicy],
}

impl Against<'_> {
    pub fn agent(&self) -> String {
        format!("{PPO}:{}", self.name)
    }
}

/// Evaluates the PPO policies (one per training seed, each with its frozen observation
/// normaliser) and the baselines on the held-out fires of `fires`; with `against`, another
/// run's policies too, compared with PPO pair by pair ([`compare_runs`]).
pub fn evaluate(
    fires: &FiresSpec,
    policies: &[EnsemblePolicy],
    against: Option<&Against<'_>>,
    cfg: &EvalConfig,
    progress: &dyn Fn(&str),
) -> Result<EvalReport, RlError> {
    let (draws, cores) = fires.evaluate.build("evaluate")?;
    let mut raw: Vec<(String, Option<u64>, Vec<Raw>)> = Vec::new();
    progress("no suppression");
    let none = run_baseline(&cores, &|| Box::new(NoSuppression), cfg.seed);
    progress("rule-based agent (one circle)");
    let rule = run_baseline(&cores, &|| Box::new(RuleBasedAgent::single_circle()), cfg.seed);
    progress("rule-based agent (concentric circles)");
    let conc = run_baseline(
        &cores,
        &|| Box::new(RuleBasedAgent::concentric_circles()),
        cfg.seed,
    );
    progress("helicopter chasing the nearest flames");
    let chaser = run_baseline(&cores, &|| Box::new(FireChaser::default()), cfg.seed);
    let search = cfg.search.map(|sc| {
        progress(&format!(
            "rollout search over the chaser ({} steps ahead, 5 actions a step)",
            sc.horizon
        ));
        run_baseline(&cores, &|| Box::new(RolloutSearch::over_chaser(sc)), cfg.seed)
    });
    for p in policies {
        progress(&format!("PPO (training seed {})", p.seed));
        raw.push((PPO.into(), Some(p.seed), run_ppo(&cores, p, cfg)?));
    }
    let other = against.map(Against::agent);
    if let (Some(a), Some(name)) = (against, &other) {
        for p in a.policies {
            progress(&format!("{name} (training seed {})", p.seed));
            raw.push((name.clone(), Some(p.seed), run_ppo(&cores, p, cfg)?));
        }
    }
    // The baselines that ran, in the order the tables list them (`none` last).
    let mut baselines = vec![RULE, RULE_CONCENTRIC, CHASER];
    raw.push((RULE.into(), None, rule));
    raw.push((RULE_CONCENTRIC.into(), None, conc));
    raw.push((CHASER.into(), None, chaser));
    if let Some(search) = search {
        baselines.push(SEARCH);
        raw.push((SEARCH.into(), None, search));
    }
    baselines.push(NONE);
    let unsuppressed: Vec<f64> = {
        let mut v = vec![0.0; cores.len()];
        for r in &none {
            v[r.fire] = f64::from(r.cells_burned);
        }
        v
    };
    raw.push((NONE.into(), None, none));
    let mut episodes = Vec::new();
    for (agent, seed, rs) in raw {
        for r in rs {
            episodes.push(Episode {
                agent: agent.clone(),
                train_seed: seed,
                fire: r.fire,
                cells_burned: r.cells_burned,
                cells_saved: unsuppressed[r.fire] - f64::from(r.cells_burned),
                timesteps: r.timesteps,
                helitacks: r.helitacks,
                water_used_gal: r.water,
                contained: r.contained,
            });
        }
    }
    let mut agents = Vec::new();
    let mut names = vec![PPO];
    names.extend(other.as_deref());
    names.extend(&baselines);
    for name in names {
        let eps: Vec<&Episode> = episodes.iter().filter(|e| e.agent == name).collect();
        if !eps.is_empty() {
            agents.push(summarize(name, &eps, cfg)?);
        }
    }
    let mut comparisons = Vec::new();
    if !policies.is_empty() {
        if let Some(name) = &other {
            comparisons.push(compare_runs(PPO, name, &episodes, cfg)?);
        }
        for &base in &baselines {
            comparisons.push(compare(PPO, base, &episodes, cfg)?);
        }
    }
    if baselines.contains(&SEARCH) {
        for base in [CHASER, RULE] {
            comparisons.push(compare(SEARCH, base, &episodes, cfg)?);
        }
    }
    Ok(EvalReport {
        fires: draws,
        deterministic: cfg.deterministic,
        resamples: cfg.resamples,
        agents,
        comparisons,
        episodes,
        recordings: Vec::new(),
    })
}

/// The held-out fires with the rule circle flown on each once, against which one policy at a
/// time is judged: what `firecast bench quality` asks of every checkpoint it stamps.
pub struct HeldOut {
    cores: Vec<EnvCore>,
    rule: Vec<Episode>,
    cfg: EvalConfig,
}

/// One policy on the held-out fires beside the rule circle (paired by fire, as Table IV).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Judgement {
    /// Mean cells burned by the policy.
    pub cells_burned: f64,
    /// Mean cells burned by the rule circle on the same fires.
    pub rule_cells_burned: f64,
    /// Policy − circle (its interval below zero: the policy beats the circle) and the
    /// relative reduction 1 − policy / circle.
    pub comparison: PairedComparison,
}

impl Judgement {
    /// The paired interval of policy − circle lies below zero.
    pub fn beats_rule(&self) -> bool {
        self.comparison.cells_burned_diff.high < 0.0
    }

    /// The point estimate of the reduction against the circle (0.69 for 69 % fewer cells).
    pub fn fewer(&self) -> f64 {
        self.comparison.relative_reduction.estimate
    }
}

impl HeldOut {
    /// Builds the evaluation fires of `fires` and flies the rule circle on each.
    pub fn new(fires: &FiresSpec, cfg: EvalConfig) -> Result<Self, RlError> {
        let (_, cores) = fires.evaluate.build("evaluate")?;
        let rule = run_baseline(&cores, &|| Box::new(RuleBasedAgent::single_circle()), cfg.seed);
        let rule = rule.into_iter().map(|r| episode(RULE, None, &r)).collect();
        Ok(Self { cores, rule, cfg })
    }

    /// How many held-out fires.
    pub fn fires(&self) -> usize {
        self.cores.len()
    }

    /// The fires' grid, `[width, height]`.
    pub fn grid(&self) -> [usize; 2] {
        let (w, h) = self.cores.first().map_or((0, 0), EnvCore::grid_size);
        [w, h]
    }

    /// The rule circle's mean cells burned.
    pub fn rule_cells_burned(&self) -> f64 {
        mean(self.rule.iter().map(|e| f64::from(e.cells_burned)))
    }

    /// Plays `policy` (greedy unless the config samples) on every held-out fire and compares
    /// it with the circle, pair by pair.
    pub fn judge(&self, policy: &EnsemblePolicy) -> Result<Judgement, RlError> {
        let raw = run_ppo(&self.cores, policy, &self.cfg)?;
        let mut episodes: Vec<Episode> = raw.iter().map(|r| episode(PPO, Some(policy.seed), r)).collect();
        let cells_burned = mean(episodes.iter().map(|e| f64::from(e.cells_burned)));
        episodes.extend(self.rule.iter().cloned());
        Ok(Judgement {
            cells_burned,
            rule_cells_burned: self.rule_cells_burned(),
            comparison: compare(PPO, RULE, &episodes, &self.cfg)?,
        })
    }
}

/// An episode of `agent` without the unsuppressed fire beside it (`cells_saved` NaN).
fn episode(agent: &str, train_seed: Option<u64>, r: &Raw) -> Episode {
    Episode {
        agent: agent.into(),
        train_seed,
        fire: r.fire,
        cells_burned: r.cells_burned,
        cells_saved: f64::NAN,
        timesteps: r.timesteps,
        helitacks: r.helitacks,
        water_used_gal: r.water,
        contained: r.contained,
    }
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { f64::NAN } else { sum / n as f64 }
}

/// The best (fewest cells burned), median and worst (most) PPO episodes, over every
/// training seed and fire. Ties go to the lower training seed, then the lower fire; the
/// median of an even count is the lower one.
pub fn pick_rollouts(episodes: &[Episode]) -> Vec<(&'static str, &Episode)> {
    let mut ppo: Vec<&Episode> = episodes
        .iter()
        .filter(|e| e.agent == PPO && e.train_seed.is_some())
        .collect();
    ppo.sort_by_key(|e| (e.cells_burned, e.train_seed, e.fire));
    let (Some(first), Some(last)) = (ppo.first(), ppo.last()) else {
        return Vec::new();
    };
    let worst = ppo
        .iter()
        .find(|e| e.cells_burned == last.cells_burned)
        .unwrap_or(last);
    vec![
        ("best", *first),
        ("median", ppo[(ppo.len() - 1) / 2]),
        ("worst", *worst),
    ]
}

/// The folder of the recordings inside the report folder.
pub const RECORDINGS_DIR: &str = "recordings";

/// Replays the best, median and worst PPO episodes of `report` (see [`pick_rollouts`]) one
/// fire at a time with their policy, episode seed and action stream, writing
/// `recordings/ppo-<role>.rrd` into the report folder `out`; fails if a replay does not
/// reproduce its evaluated episode. An episode picked twice (few episodes) is replayed once
/// and copied.
pub fn record_rollouts(
    fires: &FiresSpec,
    policies: &[EnsemblePolicy],
    report: &EvalReport,
    cfg: &EvalConfig,
    out: &Path,
) -> Result<Vec<RolloutRecording>, RlError> {
    let set: &FireSet = &fires.evaluate;
    let dir = out.join(RECORDINGS_DIR);
    std::fs::create_dir_all(&dir).map_err(|e| RlError::io("creating the recordings folder", &dir, e))?;
    let mut done: Vec<RolloutRecording> = Vec::new();
    for (role, ep) in pick_rollouts(&report.episodes) {
        let train_seed = ep.train_seed.unwrap_or_default();
        let file = format!("ppo-{role}.rrd");
        let path = dir.join(&file);
        let seed = episode_seed(cfg.seed, ep.fire);
        let entry = RolloutRecording {
            role: role.to_string(),
            train_seed,
            fire: ep.fire,
            seed,
            cells_burned: ep.cells_burned,
            timesteps: ep.timesteps,
            helitacks: ep.helitacks,
            path: Path::new(RECORDINGS_DIR).join(&file),
        };
        if let Some(twin) = done
            .iter()
            .find(|r| r.train_seed == train_seed && r.fire == ep.fire)
        {
            std::fs::copy(out.join(&twin.path), &path)
                .map_err(|e| RlError::io("copying a recording", &path, e))?;
            done.push(entry);
            continue;
        }
        let policy = policies.iter().find(|p| p.seed == train_seed).ok_or_else(|| {
            RlError::config("recordings", format!("no policy of training seed {train_seed}"))
        })?;
        let draw = report
            .fires
            .iter()
            .find(|d| d.index == ep.fire)
            .ok_or_else(|| RlError::config("recordings", format!("no held-out fire {}", ep.fire)))?;
        let (landscape, env_cfg) = set.fire(draw)?;
        let mut env = firecast_sim::WildfireEnv::new(&landscape, &env_cfg)?;
        let mut agent = PpoAgent::new(
            &policy.policy,
            policy.normalize.as_ref(),
            landscape.width,
            landscape.height,
            cfg.deterministic,
            action_seed(cfg.seed, train_seed, ep.fire),
        )?;
        let label = format!(
            "ppo agent (training seed {train_seed}), held-out fire {}, {role} of {} episodes",
            ep.fire,
            report.episodes.iter().filter(|e| e.agent == PPO).count()
        );
        let outputs = firecast_episodes::Outputs {
            recording: Some(path.clone()),
            ..Default::default()
        };
        let stats =
            firecast_episodes::record_episode(&mut env, &mut agent, &landscape, &label, seed, &outputs)?;
        let replayed = (
            stats.cells_burned,
            stats.timesteps,
            stats.helitacks,
            stats.terminated,
        );
        let evaluated = (ep.cells_burned, ep.timesteps, ep.helitacks, ep.contained);
        if replayed != evaluated {
            // No recording of an episode that was not the evaluated one.
            let _ = std::fs::remove_file(&path);
            let show = |(c, t, h, done): (u32, u32, u32, bool)| {
                format!(
                    "{c} cells in {t} steps with {h} drops ({})",
                    if done { "contained" } else { "not contained" }
                )
            };
            return Err(RlError::ReplayDiverged {
                role: role.to_string(),
                train_seed,
                fire: ep.fire,
                evaluated: show(evaluated),
                replayed: show(replayed),
            });
        }
        done.push(entry);
    }
    Ok(done)
}

/// Table IV as markdown.
pub fn markdown(report: &EvalReport) -> String {
    let f = |i: &Interval, d: usize| format!("{:.d$} [{:.d$}, {:.d$}]", i.estimate, i.low, i.high);
    let mut s = String::new();
    s.push_str(&format!(
        "Table IV over {} held-out fires ({} actions; 95 % stratified bootstrap, {} resamples)\n\n",
        report.fires.len(),
        if report.deterministic {
            "greedy PPO"
        } else {
            "sampled PPO"
        },
        report.resamples
    ));
    s.push_str("| agent | runs × fires | cells burned, mean | cells burned, IQM | cells saved vs none, mean | timesteps, mean | helitacks, mean | water (gal), mean | contained |\n|---|---|---|---|---|---|---|---|---|\n");
    for a in &report.agents {
        s.push_str(&format!(
            "| {} | {} × {} | {} | {} | {} | {} | {} | {} | {} |\n",
            a.agent,
            a.runs,
            a.episodes / a.runs.max(1),
            f(&a.cells_burned.mean, 0),
            f(&a.cells_burned.iqm, 0),
            f(&a.cells_saved.mean, 0),
            f(&a.timesteps.mean, 0),
            f(&a.helitacks.mean, 1),
            f(&a.water_used_gal.mean, 0),
            f(&a.contained_rate, 2),
        ));
    }
    let mut compared: Vec<&str> = report.comparisons.iter().map(|c| c.agent.as_str()).collect();
    compared.dedup();
    for agent in compared {
        let name = if agent == PPO { "PPO" } else { agent };
        s.push_str(&format!(
            "\n| {name} vs | Δ cells burned ({name} − baseline) | reduction | P({name} burns less) |\n|---|---|---|---|\n"
        ));
        for c in report.comparisons.iter().filter(|c| c.agent == agent) {
            s.push_str(&format!(
                "| {} | {} | {} | {} |\n",
                c.baseline,
                f(&c.cells_burned_diff, 0),
                f(&c.relative_reduction, 3),
                f(&c.probability_better, 3)
            ));
        }
    }
    if !report.recordings.is_empty() {
        s.push_str(
            "\nRerun recordings of PPO episodes (fire state, helicopter path, drops, burning and burnt \
             cells per step; open with `rerun FILE`):\n\n| episode | training seed | fire | cells burned | steps | helitacks | file |\n|---|---|---|---|---|---|---|\n",
        );
        for r in &report.recordings {
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} | {} |\n",
                r.role,
                r.train_seed,
                r.fire,
                r.cells_burned,
                r.timesteps,
                r.helitacks,
                r.path.display()
            ));
        }
    }
    s
}

/// `table4.png`: cells burned per agent (mean with its interval, IQM marked), and the
/// per-fire burned cells of PPO against the rule-based agent.
pub fn plot(report: &EvalReport, out: &Path) -> Result<(), RlError> {
    use firecast_render::chart::{Chart, LegendPosition, Marker, OKABE_ITO, Series};
    let mut chart = Chart::new(900, 420)
        .title("Table IV: cells burned on held-out fires (mean, 95 % interval; IQM diamond)")
        .x_label("agent")
        .y_label("cells burned")
        .legend(Some(LegendPosition::TopRight));
    for (k, a) in report.agents.iter().enumerate() {
        let x = k as f64 + 1.0;
        let c = OKABE_ITO[k % OKABE_ITO.len()];
        let m = &a.cells_burned.mean;
        chart = chart
            .series(
                Series::segment((x, m.low), (x, m.high))
                    .color(c)
                    .width(3.0)
                    .dashed(false),
            )
            .series(
                Series::scatter([(x, m.estimate)])
                    .color(c)
                    .marker(Marker::Circle, 8.0)
                    .label(a.agent.clone()),
            )
            .series(
                Series::scatter([(x, a.cells_burned.iqm.estimate)])
                    .color(c)
                    .marker(Marker::Diamond, 8.0),
            );
    }
    // Room above the highest interval for the legend (one row per agent), which would
    // otherwise hide the last agents' points.
    let top = report
        .agents
        .iter()
        .map(|a| a.cells_burned.mean.high.max(a.cells_burned.iqm.high))
        .fold(1.0, f64::max);
    let legend_share = (0.1 * report.agents.len() as f64 + 0.1).min(0.7);
    chart = chart
        .x_range(0.0, report.agents.len() as f64 + 1.0)
        .y_range(0.0, top / (1.0 - legend_share));
    chart.save_png(out.join("table4.png"))?;
    // PPO (mean over seeds) vs rule, per fire.
    let per_fire = |agent: &str| -> std::collections::BTreeMap<usize, f64> {
        let mut m: std::collections::BTreeMap<usize, (f64, f64)> = Default::default();
        for e in report.episodes.iter().filter(|e| e.agent == agent) {
            let s = m.entry(e.fire).or_default();
            s.0 += f64::from(e.cells_burned);
            s.1 += 1.0;
        }
        m.into_iter().map(|(k, (s, n))| (k, s / n)).collect()
    };
    let (ppo, rule) = (per_fire(PPO), per_fire(RULE));
    if !ppo.is_empty() {
        let pts: Vec<(f64, f64)> = rule
            .iter()
            .filter_map(|(f, r)| ppo.get(f).map(|p| (*r, *p)))
            .collect();
        let max = pts.iter().map(|(a, b)| a.max(*b)).fold(1.0, f64::max);
        Chart::new(640, 600)
            .title("cells burned per held-out fire: PPO (mean over seeds) vs rule-based")
            .x_label("rule-based agent")
            .y_label("PPO agent")
            .x_range(0.0, max * 1.05)
            .y_range(0.0, max * 1.05)
            .series(
                Series::segment((0.0, 0.0), (max, max))
                    .dashed(true)
                    .color([120, 120, 120]),
            )
            .series(
                Series::scatter(pts)
                    .color(OKABE_ITO[1])
                    .marker(Marker::Circle, 4.0),
            )
            .save_png(out.join("ppo_vs_rule.png"))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn episode(agent: &str, seed: u64, fire: usize, cells: u32) -> Episode {
        Episode {
            agent: agent.into(),
            train_seed: Some(seed),
            fire,
            cells_burned: cells,
            cells_saved: 0.0,
            timesteps: 1,
            helitacks: 0,
            water_used_gal: 0.0,
            contained: false,
        }
    }

    /// B burns 10 more cells than A on every fire whatever the seeds: every resample says
    /// Δ = −10 and P(A burns less) = 1; the reduction is 1 − ΣA/ΣB.
    #[test]
    fn runs_compare_pair_by_pair_across_both_runs_seeds() {
        let mut eps = Vec::new();
        for f in 0..20 {
            let base = 100 + 7 * f as u32;
            for s in 0..3 {
                eps.push(episode("a", s, f, base + s as u32 % 2));
            }
            for s in 0..4 {
                eps.push(episode("b", 10 + s, f, base + 11 + s as u32 % 2 - 1));
            }
        }
        let cfg = EvalConfig {
            resamples: 300,
            ..EvalConfig::default()
        };
        let c = compare_runs("a", "b", &eps, &cfg).expect("comparison");
        assert_eq!(c.probability_better.estimate, 1.0);
        assert_eq!((c.probability_better.low, c.probability_better.high), (1.0, 1.0));
        // A's seeds average 0.333 above base, B's 0.5 above base + 10.
        let d = c.cells_burned_diff;
        assert!((d.estimate - (1.0 / 3.0 - 10.5)).abs() < 1e-9, "{d:?}");
        assert!(d.low >= -11.0 && d.high <= -9.0 && d.low <= d.estimate && d.estimate <= d.high);
        let (sa, sb): (f64, f64) = (0..20).fold((0.0, 0.0), |(x, y), f| {
            let base = f64::from(100 + 7 * f);
            (x + base + 1.0 / 3.0, y + base + 10.5)
        });
        assert!((c.relative_reduction.estimate - (1.0 - sa / sb)).abs() < 1e-9);
    }
}
