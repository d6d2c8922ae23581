//! Library-level tests of the pipeline engine with an in-process stage kind.
#![allow(clippy::unwrap_used)]

mod artifacts;

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use firecast_pipeline::{
    Engine, NoObserver, Outcome, ParamsError, Port, Ports, StageContext, StageError, StageKind, StageKinds,
    spec::Override, typed_params,
};
use proptest::prelude::*;
use serde::{Deserialize, Serialize};

/// Concatenates its inputs and a suffix; counts executions.
struct Concat {
    runs: Arc<AtomicUsize>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ConcatParams {
    suffix: String,
    #[serde(default = "default_repeat")]
    repeat: u32,
}

fn default_repeat() -> u32 {
    1
}

impl StageKind for Concat {
    fn name(&self) -> &'static str {
        "test.concat"
    }
    fn version(&self) -> u32 {
        1
    }
    fn summary(&self) -> &'static str {
        "test"
    }
    fn ports(&self) -> Ports {
        const OUT: &[Port] = &[Port {
            name: "out",
            required: true,
            many: false,
            description: "result",
        }];
        const IN: &[Port] = &[Port {
            name: "parts",
            required: false,
            many: true,
            description: "parts",
        }];
        Ports {
            inputs: IN,
            outputs: OUT,
            open: false,
        }
    }
    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        typed_params::<ConcatParams>(raw).map(|(_, v)| v)
    }
    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        self.runs.fetch_add(1, Ordering::SeqCst);
        let params: ConcatParams = ctx.params()?;
        let mut text = String::new();
        for part in ctx.input_list("parts") {
            text.push_str(&std::fs::read_to_string(part)?);
        }
        for _ in 0..params.repeat {
            text.push_str(&params.suffix);
        }
        std::fs::write(ctx.output("out")?, text)?;
        Ok(())
    }
}

fn engine(root: &Path, runs: &Arc<AtomicUsize>) -> Engine {
    let mut kinds = StageKinds::new();
    kinds.register(Concat { runs: runs.clone() });
    Engine {
        root: root.to_path_buf(),
        kinds,
        observer: Arc::new(NoObserver),
        store: None,
        git_commit: None,
        executor: None,
    }
}

fn kinds(runs: &Arc<AtomicUsize>) -> StageKinds {
    let mut kinds = StageKinds::new();
    kinds.register(Concat { runs: runs.clone() });
    kinds
}

const PIPELINE: &str = "
stages:
  a:
    uses: test.concat
    params: {suffix: A}
    outputs: {out: a.txt}
  b:
    uses: test.concat
    params: {suffix: B}
    inputs: {parts: [{from: a.out}]}
    outputs: {out: b.txt}
";

#[test]
fn defaults_are_part_of_resolved_params_and_skip_works() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("p.yaml"), PIPELINE).unwrap();
    let runs = Arc::new(AtomicUsize::new(0));
    let plan = firecast_pipeline::load_plan(dir.path(), Path::new("p.yaml"), &[], &kinds(&runs)).unwrap();
    assert_eq!(
        plan.stages[0].params,
        serde_json::json!({"suffix": "A", "repeat": 1})
    );

    let engine = engine(dir.path(), &runs);
    let opts = firecast_pipeline::RunOptions {
        progress: false,
        ..Default::default()
    };
    let report = engine.run(&plan, &opts).unwrap();
    assert!(report.stages.iter().all(|s| s.outcome == Outcome::Ran));
    assert_eq!(std::fs::read_to_string(dir.path().join("b.txt")).unwrap(), "AB");
    let report = engine.run(&plan, &opts).unwrap();
    assert!(report.stages.iter().all(|s| s.outcome == Outcome::UpToDate));
    assert_eq!(runs.load(Ordering::SeqCst), 2);

    // Writing the default explicitly does not change the cache key.
    std::fs::write(
        dir.path().join("p.yaml"),
        PIPELINE.replace("{suffix: A}", "{repeat: 1, suffix: A}"),
    )
    .unwrap();
    let plan = firecast_pipeline::load_plan(dir.path(), Path::new("p.yaml"), &[], &kinds(&runs)).unwrap();
    let report = engine.run(&plan, &opts).unwrap();
    assert!(
        report.stages.iter().all(|s| s.outcome == Outcome::UpToDate),
        "{report:?}"
    );
}

#[test]
fn kind_params_are_strict() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("p.yaml"),
        PIPELINE.replace("{suffix: B}", "{suffix: B, repaet: 2}"),
    )
    .unwrap();
    let runs = Arc::new(AtomicUsize::new(0));
    let err = firecast_pipeline::load_plan(dir.path(), Path::new("p.yaml"), &[], &kinds(&runs)).unwrap_err();
    assert_eq!(
        err.to_string(),
        "p.yaml:9:5: stages.b.params.repaet: unknown field `repaet`, expected `suffix` or `repeat`"
    );
    let overrides = [Override::parse("b.repeat=two").unwrap()];
    std::fs::write(dir.path().join("p.yaml"), PIPELINE).unwrap();
    let err =
        firecast_pipeline::load_plan(dir.path(), Path::new("p.yaml"), &overrides, &kinds(&runs)).unwrap_err();
    assert_eq!(
        err.to_string(),
        "p.yaml:9:5: stages.b.params.repeat: invalid type: string \"two\", expected u32"
    );
}

/// A random DAG: stage i may read from any earlier stage, declared in shuffled order.
fn dag_yaml(edges: &[Vec<bool>], order: &[usize]) -> String {
    let mut yaml = String::from("stages:\n");
    for &i in order {
        yaml.push_str(&format!(
            "  s{i}:\n    uses: test.concat\n    params: {{suffix: \"{i}\"}}\n"
        ));
        let parts: Vec<String> = (0..i)
            .filter(|&j| edges[i][j])
            .map(|j| format!("{{from: s{j}.out}}"))
            .collect();
        if !parts.is_empty() {
            yaml.push_str(&format!("    inputs: {{parts: [{}]}}\n", parts.join(", ")));
        }
        yaml.push_str(&format!("    outputs: {{out: out/s{i}.txt}}\n"));
    }
    yaml
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Every planned stage comes after all the stages it reads from.
    #[test]
    fn plans_are_topologically_ordered(
        n in 1usize..12,
        seed in any::<u64>(),
    ) {
        let mut rng = seed;
        let mut next = || { rng ^= rng << 13; rng ^= rng >> 7; rng ^= rng << 17; rng };
        let edges: Vec<Vec<bool>> = (0..n).map(|i| (0..n).map(|j| j < i && next() % 3 == 0).collect()).collect();
        let mut order: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() { let j = (next() % (i as u64 + 1)) as usize; order.swap(i, j); }
        let expanded = firecast_pipeline::spec::parse(Path::new("."), Path::new("dag.yaml"), &dag_yaml(&edges, &order), &[]).unwrap();
        let runs = Arc::new(AtomicUsize::new(0));
        let plan = firecast_pipeline::plan::plan(&expanded, &kinds(&runs)).unwrap();
        prop_assert_eq!(plan.stages.len(), n);
        for (position, stage) in plan.stages.iter().enumerate() {
            for &u in &stage.upstream {
                prop_assert!(u < position, "{} before its upstream {}", stage.name, plan.stages[u].name);
            }
            let i: usize = stage.name[1..].parse().unwrap();
            let expected: usize = (0..n).filter(|&j| edges[i][j]).count();
            prop_assert_eq!(stage.upstream.len(), expected);
        }
    }

    /// The order keys are written in does not change a stage's resolved params (and so its key).
    #[test]
    fn param_order_does_not_change_resolution(suffix in "[a-z]{1,8}", repeat in 1u32..5) {
        let runs = Arc::new(AtomicUsize::new(0));
        let k = kinds(&runs);
        let parse = |params: &str| {
            let yaml = format!("stages:\n  a:\n    uses: test.concat\n    params: {params}\n    outputs: {{out: a.txt}}\n");
            let expanded = firecast_pipeline::spec::parse(Path::new("."), Path::new("p.yaml"), &yaml, &[]).unwrap();
            firecast_pipeline::plan::plan(&expanded, &k).unwrap().stages[0].params.clone()
        };
        let one = parse(&format!("{{suffix: {suffix}, repeat: {repeat}}}"));
        let two = parse(&format!("{{repeat: {repeat}, suffix: {suffix}}}"));
        prop_assert_eq!(&one, &two);
        prop_assert_eq!(firecast_pipeline::hash::hash_json(&one), firecast_pipeline::hash::hash_json(&two));
    }
}
