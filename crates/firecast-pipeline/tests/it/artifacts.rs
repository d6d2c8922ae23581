//! Artifacts a stage registers from inside its outputs are stored under their final
//! names, from the finished files; per-stage `resources:` are strict.

use std::path::Path;
use std::sync::{Arc, Mutex};

use firecast_pipeline::observer::ObserverError;
use firecast_pipeline::{
    Engine, Outcome, ParamsError, Port, Ports, RunObserver, StageContext, StageError, StageKind, StageKinds,
};

/// Writes `report.csv` (a file output) and `bundle/` (a folder output with `card.md`) and
/// registers both as artifacts while they are still being written, like `data.ignitions`
/// (`rejects.csv`) and `data.dataset` (the card) do.
struct Report;

impl StageKind for Report {
    fn name(&self) -> &'static str {
        "test.report"
    }
    fn version(&self) -> u32 {
        1
    }
    fn summary(&self) -> &'static str {
        "test"
    }
    fn ports(&self) -> Ports {
        const OUT: &[Port] = &[
            Port {
                name: "rejects",
                required: true,
                many: false,
                description: "csv",
            },
            Port {
                name: "bundle",
                required: true,
                many: false,
                description: "folder",
            },
        ];
        Ports {
            inputs: &[],
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, _raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        Ok(serde_json::json!({}))
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let rejects = ctx.output("rejects")?.to_path_buf();
        std::fs::write(&rejects, "row,reason\n3,outside CONUS\n")?;
        ctx.artifact("rejects.csv", &rejects)?;
        let bundle = ctx.output("bundle")?.to_path_buf();
        std::fs::create_dir_all(&bundle)?;
        std::fs::write(bundle.join("card.md"), "# card\n")?;
        ctx.artifact("card", &bundle.join("card.md"))?;
        // Written after the registration: the stored artifact is the finished file.
        std::fs::write(bundle.join("card.md"), "# card\nfinished\n")?;
        Ok(())
    }
}

#[derive(Default)]
struct Artifacts(Mutex<Vec<(String, String, String)>>);

impl RunObserver for Artifacts {
    fn artifact(
        &self,
        run_id: &str,
        name: &str,
        uri: &str,
        _hash: &str,
        _size: u64,
    ) -> Result<(), ObserverError> {
        self.0
            .lock()
            .unwrap()
            .push((run_id.to_string(), name.to_string(), uri.to_string()));
        Ok(())
    }
}

#[test]
fn artifacts_from_outputs_carry_final_names_and_final_bytes() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("p.yaml"),
        "stages:\n  ignitions:\n    uses: test.report\n    outputs: {rejects: build/ignition_rejects.csv, bundle: build/bundle}\n",
    )
    .unwrap();
    let mut kinds = StageKinds::new();
    kinds.register(Report);
    let plan = firecast_pipeline::load_plan(dir.path(), Path::new("p.yaml"), &[], &kinds).unwrap();
    let observer = Arc::new(Artifacts::default());
    let store = Arc::new(firecast_store::ArtifactStore::open("artifacts", dir.path()).unwrap());
    let engine = Engine {
        root: dir.path().to_path_buf(),
        kinds,
        observer: observer.clone(),
        store: Some(store.clone()),
        git_commit: None,
        executor: None,
    };
    let opts = firecast_pipeline::RunOptions {
        progress: false,
        ..Default::default()
    };
    let report = engine.run(&plan, &opts).unwrap();
    assert_eq!(report.stages[0].outcome, Outcome::Ran, "{report:?}");
    let run = report.stages[0].run_id.clone().unwrap();

    let recorded = observer.0.lock().unwrap().clone();
    let uris: Vec<&str> = recorded.iter().map(|(_, _, uri)| uri.as_str()).collect();
    assert_eq!(recorded.len(), 2, "{recorded:?}");
    assert!(recorded.iter().all(|(r, _, _)| *r == run));
    assert!(
        uris.iter().all(|u| !u.contains(firecast_fs::TEMP_PREFIX)),
        "{uris:?}"
    );
    let keys: Vec<String> = store
        .list(Some("runs"))
        .unwrap()
        .into_iter()
        .map(|e| e.key)
        .collect();
    assert_eq!(
        keys,
        vec![
            format!("runs/{run}/card/card.md"),
            format!("runs/{run}/rejects.csv/ignition_rejects.csv"),
        ]
    );
    assert_eq!(
        store.get_bytes(&format!("runs/{run}/card/card.md")).unwrap(),
        b"# card\nfinished\n"
    );
    assert_eq!(
        store
            .get_bytes(&format!("runs/{run}/rejects.csv/ignition_rejects.csv"))
            .unwrap(),
        std::fs::read(dir.path().join("build/ignition_rejects.csv")).unwrap()
    );
}

#[test]
fn stage_resources_are_strict_and_located() {
    let dir = tempfile::tempdir().unwrap();
    let mut kinds = StageKinds::new();
    kinds.register(Report);
    let write = |resources: &str| {
        std::fs::write(
            dir.path().join("p.yaml"),
            format!(
                "stages:\n  ignitions:\n    uses: test.report\n    resources: {resources}\n    outputs: {{rejects: r.csv, bundle: b}}\n"
            ),
        )
        .unwrap();
    };
    write("{cpus: 2, memory: 1GiB, gpus: 0.5}");
    let plan = firecast_pipeline::load_plan(dir.path(), Path::new("p.yaml"), &[], &kinds).unwrap();
    let r = &plan.stages[0].resources;
    assert_eq!((r.cpus, r.memory, r.gpus), (Some(2.0), Some(1 << 30), Some(0.5)));

    write("{cpus: 2, mem: 1GiB}");
    let err = firecast_pipeline::load_plan(dir.path(), Path::new("p.yaml"), &[], &kinds).unwrap_err();
    let text = err.to_string();
    assert!(
        text.starts_with("p.yaml:4:")
            && text.contains("stages.ignitions.resources")
            && text.contains("unknown field `mem`"),
        "{text}"
    );
    write("{memory: 2 gallons}");
    let text = firecast_pipeline::load_plan(dir.path(), Path::new("p.yaml"), &[], &kinds)
        .unwrap_err()
        .to_string();
    assert!(
        text.starts_with("p.yaml:4:") && text.contains("unknown unit `gallons`"),
        "{text}"
    );
}
