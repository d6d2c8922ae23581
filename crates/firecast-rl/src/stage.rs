//! Pipeline stage kinds: `rl.train` (a [`TrainSpec`] → a run folder with policies, metrics,
//! curves) and `rl.evaluate` (a run folder + fire file → Table IV). Checkpoints live in
//! `.firecast/rl/<name>-<key>/` outside the stage's output, so a killed stage resumes from
//! its last checkpoint when run again (exactly: the result equals an uninterrupted run).

use firecast_pipeline::{ParamsError, Port, Ports, StageContext, StageError, StageKind, typed_params};

use crate::RlError;
use crate::evaluate::EvalConfig;
use crate::run::{RunSink, SUMMARY_FILE, TRAIN_VERSION};
use crate::spec::{EnvSpec, FiresSpec, TrainSpec};

fn stage_error(e: RlError) -> StageError {
    StageError::msg(e.to_string())
}

fn params_error(e: RlError) -> ParamsError {
    match e {
        RlError::Config { key, message } => ParamsError { path: key, message },
        other => ParamsError {
            path: String::new(),
            message: other.to_string(),
        },
    }
}

struct StageSink<'a, 'b> {
    ctx: &'a StageContext<'b>,
    bar: indicatif::ProgressBar,
}

impl RunSink for StageSink<'_, '_> {
    fn message(&self, line: &str) {
        self.ctx.log(line);
    }
    fn metric(&self, seed: u64, timesteps: u64, key: &str, value: f64) {
        if value.is_finite() {
            self.ctx
                .metric(&format!("seed-{seed}/{key}"), timesteps as i64, value);
        }
    }
    fn progress(&self, seed: u64, timesteps: u64, total: u64, fps: f64, ep_rew_mean: f64) {
        self.bar.set_length(total);
        self.bar.set_position(timesteps);
        self.bar.set_message(format!(
            "{}: seed {seed}, {fps:.0} steps/s, ep_rew_mean {ep_rew_mean:.2}",
            self.ctx.stage()
        ));
    }
}

/// Registers this crate's stage kinds: `rl.train` (uninterrupted), `rl.evaluate`,
/// `rl.ensemble`.
pub fn register(kinds: &mut firecast_pipeline::StageKinds) {
    kinds
        .register(TrainStage::default())
        .register(EvaluateStage)
        .register(crate::ensemble::EnsembleStage);
}

/// The `rl.train` stage kind. `stop_after` interrupts every seed after that many steps (for
/// testing resumption: `rl train --stop-after N`); the stage then fails and keeps its
/// checkpoints. Pipelines register it with `stop_after: None`.
#[derive(Debug, Default)]
pub struct TrainStage {
    pub stop_after: Option<u64>,
}

impl StageKind for TrainStage {
    fn name(&self) -> &'static str {
        "rl.train"
    }
    fn version(&self) -> u32 {
        TRAIN_VERSION
    }
    fn summary(&self) -> &'static str {
        "PPO (SB3 semantics, tch) on CartPole or the helitack fires: policies per seed, metrics, curves"
    }
    fn ports(&self) -> Ports {
        const IN: &[Port] = &[Port {
            name: "fires",
            required: false,
            many: false,
            description: "fire file (helitack): reward profile, training and evaluation fires",
        }];
        const OUT: &[Port] = &[Port {
            name: "run",
            required: true,
            many: false,
            description: "policies, metrics, training.png, summary.json (directory)",
        }];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (spec, v) = typed_params::<TrainSpec>(raw)?;
        if let EnvSpec::Helitack { fires: Some(_), .. } = &spec.env {
            return Err(ParamsError {
                path: "env.fires".into(),
                message: "a stage takes its fire file from its `fires` input".into(),
            });
        }
        spec.validate().map_err(params_error)?;
        Ok(v)
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        // libtorch's one generator: stages using it run one at a time (reproducible).
        firecast_learn::exclusive(|| {
            let spec: TrainSpec = ctx.params()?;
            let fires = ctx
                .input("fires")
                .ok()
                .map(|p| p.strip_prefix(ctx.root()).unwrap_or(p).to_path_buf());
            let fires_abs = fires.as_ref().map(|p| ctx.root().join(p));
            let out = ctx.output("run")?.to_path_buf();
            let device = crate::parse_device(&spec.device).map_err(stage_error)?;
            firecast_learn::set_threads(spec.threads);
            let work = crate::run::work_dir(ctx.root(), &spec, fires_abs.as_deref()).map_err(stage_error)?;
            let stop_after = self.stop_after;
            let bar = ctx.progress_bar(spec.ppo().map_err(stage_error)?.total_timesteps, "steps");
            let sink = StageSink { ctx, bar };
            let result = crate::run::train(
                &spec,
                fires_abs.as_deref(),
                &work,
                &out,
                device,
                &sink,
                stop_after,
            );
            if let (Ok(summary), Some(rel)) = (&result, &fires) {
                // Record the fire file as the pipeline named it (relative), not the absolute path.
                let mut s = summary.clone();
                s.fires_file = Some(rel.clone());
                let path = out.join(SUMMARY_FILE);
                let json = serde_json::to_vec_pretty(&s).map_err(|e| StageError::msg(e.to_string()))?;
                std::fs::write(&path, json)
                    .map_err(|e| StageError::msg(format!("{}: {e}", path.display())))?;
            }
            sink.bar.finish_and_clear();
            let summary = match result {
                Ok(s) => s,
                Err(RlError::Interrupted) => {
                    return Err(StageError::msg(format!(
                        "stopped as asked (after {} steps a seed); checkpoints are in {}: run the stage again to resume",
                        stop_after.unwrap_or_default(),
                        work.display()
                    )));
                }
                Err(e) => return Err(stage_error(e)),
            };
            if ctx.output_final_path("run").is_some() {
                for s in &summary.seeds {
                    let path = out.join(&s.policy).join(firecast_ppo::train::POLICY_FILE);
                    let _ = ctx.artifact(&format!("policy/seed-{}", s.seed), &path)?;
                }
            }
            Ok(())
        })
    }
}

/// `rl.evaluate` params.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvaluateParams {
    #[serde(flatten)]
    pub eval: EvalConfig,
    #[serde(default = "default_device")]
    pub device: String,
    /// libtorch threads: part of the result, so part of the cache key; a fixed default, not
    /// the machine's core count.
    #[serde(default = "firecast_learn::default_threads")]
    pub threads: usize,
}

fn default_device() -> String {
    "auto".into()
}

#[derive(Debug, Default)]
pub struct EvaluateStage;

/// Evaluates a run folder on a fire file's evaluation fires and writes `evaluation.json`,
/// `table4.md`, `episodes.csv`, the plots and (when `cfg.recordings`) the Rerun recordings
/// of the best, median and worst PPO episodes (`recordings/`) into `out`.
pub fn evaluate_run(
    run: &std::path::Path,
    fires: &std::path::Path,
    against: Option<&std::path::Path>,
    out: &std::path::Path,
    cfg: &EvalConfig,
    device: tch::Device,
    progress: &dyn Fn(&str),
) -> Result<crate::evaluate::EvalReport, RlError> {
    let (_, policies) = crate::ensemble::load_policies(run, device)?;
    let other = against
        .map(|dir| crate::ensemble::load_policies(dir, device))
        .transpose()?;
    let against = other
        .as_ref()
        .map(|(summary, policies)| crate::evaluate::Against {
            name: &summary.name,
            policies,
        });
    let fires = FiresSpec::load(fires)?;
    let mut report = crate::evaluate::evaluate(&fires, &policies, against.as_ref(), cfg, progress)?;
    std::fs::create_dir_all(out).map_err(|e| RlError::io("creating the report folder", out, e))?;
    if cfg.recordings {
        progress("recording the best, median and worst PPO episodes");
        report.recordings = crate::evaluate::record_rollouts(&fires, &policies, &report, cfg, out)?;
    }
    let json = serde_json::to_vec_pretty(&report).map_err(|e| RlError::config("report", e.to_string()))?;
    let write = |name: &str, bytes: &[u8]| {
        let p = out.join(name);
        std::fs::write(&p, bytes).map_err(|e| RlError::io("writing the report", &p, e))
    };
    write("evaluation.json", &json)?;
    write("table4.md", crate::evaluate::markdown(&report).as_bytes())?;
    let mut csv = String::from(
        "agent,train_seed,fire,cells_burned,cells_saved,timesteps,helitacks,water_used_gal,contained\n",
    );
    for e in &report.episodes {
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{}\n",
            e.agent,
            e.train_seed.map_or(String::new(), |s| s.to_string()),
            e.fire,
            e.cells_burned,
            e.cells_saved,
            e.timesteps,
            e.helitacks,
            e.water_used_gal,
            e.contained
        ));
    }
    write("episodes.csv", csv.as_bytes())?;
    crate::evaluate::plot(&report, out)?;
    Ok(report)
}

impl StageKind for EvaluateStage {
    fn name(&self) -> &'static str {
        "rl.evaluate"
    }
    fn version(&self) -> u32 {
        // 2: observations normalised as in training, one action stream per fire, recordings;
        // 3: the chaser baseline.
        3
    }
    fn summary(&self) -> &'static str {
        "Table IV: PPO per training seed vs rule-based agents and no suppression on the same held-out fires"
    }
    fn ports(&self) -> Ports {
        const IN: &[Port] = &[
            Port {
                name: "run",
                required: true,
                many: false,
                description: "an rl.train run folder",
            },
            Port {
                name: "fires",
                required: true,
                many: false,
                description: "fire file whose `evaluate` fires are used",
            },
            Port {
                name: "against",
                required: false,
                many: false,
                description: "another rl.train run folder, evaluated beside it and compared pair by pair",
            },
        ];
        const OUT: &[Port] = &[Port {
            name: "report",
            required: true,
            many: false,
            description: "table4.md, evaluation.json, episodes.csv, plots, recordings/ppo-{best,median,worst}.rrd (directory)",
        }];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (p, v) = typed_params::<EvaluateParams>(raw)?;
        crate::parse_device(&p.device).map_err(params_error)?;
        firecast_learn::check_threads(p.threads).map_err(|message| ParamsError {
            path: "threads".into(),
            message,
        })?;
        Ok(v)
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        // libtorch's one generator: stages using it run one at a time (reproducible).
        firecast_learn::exclusive(|| {
            let p: EvaluateParams = ctx.params()?;
            let run = ctx.input("run")?.to_path_buf();
            let fires = ctx.input("fires")?.to_path_buf();
            let against = ctx.input_list("against").first().cloned();
            let out = ctx.output("report")?.to_path_buf();
            let device = crate::parse_device(&p.device).map_err(stage_error)?;
            firecast_learn::set_threads(p.threads);
            let report = evaluate_run(&run, &fires, against.as_deref(), &out, &p.eval, device, &|m| {
                ctx.log(format!("evaluating {m}"))
            })
            .map_err(stage_error)?;
            for a in &report.agents {
                ctx.metric(
                    &format!("{}/cells_burned_mean", a.agent),
                    0,
                    a.cells_burned.mean.estimate,
                );
                ctx.metric(
                    &format!("{}/cells_burned_iqm", a.agent),
                    0,
                    a.cells_burned.iqm.estimate,
                );
            }
            if ctx.output_final_path("report").is_some() {
                for r in &report.recordings {
                    let _ = ctx.artifact(&format!("recording/ppo-{}", r.role), &out.join(&r.path))?;
                }
            }
            Ok(())
        })
    }
}
