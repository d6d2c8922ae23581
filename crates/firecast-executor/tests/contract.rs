//! The driver/worker contract without a cluster: a stage shipped through the artifact
//! store (task, content-addressed inputs and outputs, result) gives the same outputs and
//! lock entries as the local run, and reports its metrics back to the driver.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use firecast_executor::task::{TaskResult, get_json, result_key};
use firecast_executor::{driver, worker};
use firecast_pipeline::executor::{JobFailure, JobOutcome};
use firecast_pipeline::lock::LockFile;
use firecast_pipeline::observer::ObserverError;
use firecast_pipeline::{
    Engine, Outcome, ParamsError, Port, Ports, RunObserver, StageContext, StageError, StageExecutor,
    StageJob, StageKind, StageKinds,
};
use firecast_store::ArtifactStore;

/// Upper-cases its input into `out/<name>` files (a folder output) and a total file.
struct Shout;

impl StageKind for Shout {
    fn name(&self) -> &'static str {
        "test.shout"
    }
    fn version(&self) -> u32 {
        1
    }
    fn summary(&self) -> &'static str {
        "test"
    }
    fn ports(&self) -> Ports {
        const IN: &[Port] = &[Port {
            name: "text",
            required: true,
            many: false,
            description: "text",
        }];
        const OUT: &[Port] = &[
            Port {
                name: "folder",
                required: true,
                many: false,
                description: "folder",
            },
            Port {
                name: "total",
                required: true,
                many: false,
                description: "file",
            },
        ];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        Ok(raw.clone())
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let text = std::fs::read_to_string(ctx.input("text")?)?;
        let folder = ctx.output("folder")?.to_path_buf();
        std::fs::create_dir_all(folder.join("lines"))?;
        for (i, line) in text.lines().enumerate() {
            std::fs::write(folder.join("lines").join(format!("{i}.txt")), line.to_uppercase())?;
        }
        std::fs::write(ctx.output("total")?, format!("{}\n", text.lines().count()))?;
        ctx.metric("lines", 0, text.lines().count() as f64);
        ctx.log(format!("{} lines", text.lines().count()));
        if text.contains("boom") {
            return Err(StageError::msg("the input says boom"));
        }
        Ok(())
    }
}

fn kinds() -> StageKinds {
    let mut kinds = StageKinds::new();
    kinds.register(Shout);
    kinds
}

/// Ships each stage through the store and runs the worker side in this process, as a
/// Slurm or Kubernetes backend would in another.
struct InProcess {
    store: Arc<ArtifactStore>,
    scratch: PathBuf,
}

impl StageExecutor for InProcess {
    fn describe(&self) -> String {
        "in-process worker".into()
    }
    fn run(&self, job: &StageJob<'_>) -> Result<JobOutcome, JobFailure> {
        let fail = |message: String| JobFailure {
            message,
            log: Vec::new(),
        };
        let task = driver::prepare(&self.store, job).map_err(|e| fail(e.to_string()))?;
        let key = result_key(job.run_id, 1);
        worker::exec(&kinds(), &self.store, &task, &key, &self.scratch, None)
            .map_err(|e| fail(e.to_string()))?;
        let result: TaskResult = get_json(&self.store, &key).unwrap().unwrap();
        if let Some(error) = result.error {
            return Err(JobFailure {
                message: error,
                log: result.log,
            });
        }
        driver::collect(&self.store, job, result, "in-process".into()).map_err(|e| fail(e.to_string()))
    }
}

#[derive(Default)]
struct Metrics(Mutex<Vec<(String, f64)>>);

impl RunObserver for Metrics {
    fn metric(&self, _run: &str, key: &str, _step: i64, value: f64) -> Result<(), ObserverError> {
        self.0.lock().unwrap().push((key.to_string(), value));
        Ok(())
    }
}

const PIPELINE: &str = "
stages:
  shout:
    uses: test.shout
    inputs: {text: data/in.txt}
    outputs: {folder: build/shout, total: build/total.txt}
  again:
    uses: test.shout
    inputs: {text: {from: shout.total}}
    outputs: {folder: build/again, total: build/again.txt}
";

fn project(text: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("data")).unwrap();
    std::fs::write(dir.path().join("data/in.txt"), text).unwrap();
    std::fs::write(dir.path().join("p.yaml"), PIPELINE).unwrap();
    dir
}

fn run(root: &Path, remote: Option<&Path>) -> (firecast_pipeline::RunReport, Arc<Metrics>) {
    let plan = firecast_pipeline::load_plan(root, Path::new("p.yaml"), &[], &kinds()).unwrap();
    let metrics = Arc::new(Metrics::default());
    let executor: Option<Arc<dyn StageExecutor>> = remote.map(|store_dir| {
        Arc::new(InProcess {
            store: Arc::new(ArtifactStore::open(&store_dir.display().to_string(), root).unwrap()),
            scratch: store_dir.join("scratch"),
        }) as Arc<dyn StageExecutor>
    });
    let engine = Engine {
        root: root.to_path_buf(),
        kinds: kinds(),
        observer: metrics.clone(),
        store: None,
        git_commit: None,
        executor,
    };
    let opts = firecast_pipeline::RunOptions {
        progress: false,
        jobs: 2,
        ..Default::default()
    };
    (engine.run(&plan, &opts).unwrap(), metrics)
}

fn lock_without_run_ids(root: &Path) -> String {
    let mut lock = LockFile::load(&root.join("p.lock"), "p").unwrap();
    for entry in lock.stages.values_mut() {
        entry.run_id.clear();
    }
    serde_yaml_ng::to_string(&lock).unwrap()
}

#[test]
fn shipped_stages_match_the_local_run() {
    let local = project("a\nb\nc\n");
    let remote = project("a\nb\nc\n");
    let store = tempfile::tempdir().unwrap();
    let (report, _) = run(local.path(), None);
    assert!(report.succeeded());
    let (report, metrics) = run(remote.path(), Some(store.path()));
    assert!(report.succeeded(), "{report:?}");
    assert!(report.stages.iter().all(|s| s.outcome == Outcome::Ran));

    assert_eq!(
        lock_without_run_ids(local.path()),
        lock_without_run_ids(remote.path())
    );
    for file in [
        "build/shout/lines/2.txt",
        "build/total.txt",
        "build/again/lines/0.txt",
    ] {
        assert_eq!(
            std::fs::read(local.path().join(file)).unwrap(),
            std::fs::read(remote.path().join(file)).unwrap(),
            "{file}"
        );
    }
    let mut seen = metrics.0.lock().unwrap().clone();
    seen.sort_by(|a, b| a.1.total_cmp(&b.1));
    assert_eq!(seen, vec![("lines".to_string(), 1.0), ("lines".to_string(), 3.0)]);
    // The worker's log came back to the driver's log folder.
    let run_id = report.stages[0].run_id.clone().unwrap();
    let log = std::fs::read_to_string(remote.path().join(format!(".firecast/logs/{run_id}.log"))).unwrap();
    assert!(
        log.contains("# ran on in-process") && log.contains("3 lines"),
        "{log}"
    );
    // The worker cleaned up its scratch folder.
    assert_eq!(
        std::fs::read_dir(store.path().join("scratch")).unwrap().count(),
        0
    );

    // Second run: nothing is shipped.
    let before = std::fs::read_dir(store.path().join("remote")).unwrap().count();
    let (report, _) = run(remote.path(), Some(store.path()));
    assert!(report.stages.iter().all(|s| s.outcome == Outcome::UpToDate));
    assert_eq!(
        std::fs::read_dir(store.path().join("remote")).unwrap().count(),
        before
    );
}

#[test]
fn a_failing_remote_stage_leaves_nothing_finished() {
    let remote = project("boom\n");
    let store = tempfile::tempdir().unwrap();
    let (report, _) = run(remote.path(), Some(store.path()));
    assert_eq!(report.stages[0].outcome, Outcome::Failed);
    assert_eq!(report.stages[1].outcome, Outcome::Skipped);
    assert!(
        report.stages[0]
            .error
            .as_deref()
            .unwrap()
            .contains("the input says boom")
    );
    for leftover in ["build/shout", "build/total.txt"] {
        assert!(!remote.path().join(leftover).exists(), "{leftover}");
    }
    let names: Vec<String> = std::fs::read_dir(remote.path().join("build"))
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().to_string())
                .collect()
        })
        .unwrap_or_default();
    assert!(names.is_empty(), "{names:?}");
}
