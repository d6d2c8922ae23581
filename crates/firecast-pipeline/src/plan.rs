//! From an expanded pipeline to an executable plan: kinds looked up, params resolved,
//! inputs wired to files, URLs or upstream outputs, the DAG checked for cycles.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use indexmap::IndexMap;
use serde::Serialize;
use serde_yaml_ng::Value;

use crate::error::SpecError;
use crate::spec::{ExpandedPipeline, Override, scalar_to_string};
// Moved to spec (which parses params with it); still reachable here for the callers that
// name it by this path.
use crate::spec::yaml_to_json;
use crate::stage::StageKinds;

/// Where an input's bytes come from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Source {
    /// A local file or folder, relative to the project root.
    File { path: PathBuf },
    /// An object in a store (`s3://…`, `gs://…`, `file://…`).
    Url { url: String },
    /// Another stage's output.
    Output { stage: String, output: String },
}

/// A declared input: one source, or a list (fan-in).
#[derive(Debug, Clone, Serialize)]
pub struct PlannedInput {
    pub sources: Vec<Source>,
    pub many: bool,
}

/// A declared output.
#[derive(Debug, Clone, Serialize)]
pub struct PlannedOutput {
    pub path: PathBuf,
    /// Also upload to the artifact store when the stage runs.
    pub artifact: bool,
}

/// A stage ready to run.
#[derive(Debug, Clone, Serialize)]
pub struct PlannedStage {
    pub name: String,
    pub base: String,
    pub kind: String,
    pub kind_version: u32,
    pub description: Option<String>,
    pub params: serde_json::Value,
    pub inputs: IndexMap<String, PlannedInput>,
    pub outputs: IndexMap<String, PlannedOutput>,
    /// Indices (into `Plan::stages`) of the stages this one reads from.
    pub upstream: Vec<usize>,
    pub always_run: bool,
    /// Cluster resources one run needs (remote executors only).
    pub resources: crate::resources::Resources,
    /// Shards the work is split into (`None`: one task). Not part of the cache key: the
    /// merged outputs equal the unsharded ones.
    pub shards: Option<u32>,
}

/// A checked, topologically ordered pipeline.
#[derive(Debug, Clone, Serialize)]
pub struct Plan {
    pub name: String,
    pub file: PathBuf,
    pub description: Option<String>,
    pub vars: serde_json::Value,
    pub overrides: Vec<String>,
    pub stages: Vec<PlannedStage>,
}

impl Plan {
    pub fn index_of(&self, stage: &str) -> Option<usize> {
        self.stages.iter().position(|s| s.name == stage)
    }

    /// Indices of the stages that (transitively) read from `index`.
    pub fn downstream_of(&self, index: usize) -> BTreeSet<usize> {
        let mut out = BTreeSet::new();
        let mut frontier = vec![index];
        while let Some(current) = frontier.pop() {
            for (i, stage) in self.stages.iter().enumerate() {
                if stage.upstream.contains(&current) && out.insert(i) {
                    frontier.push(i);
                }
            }
        }
        out
    }
}

/// Load a pipeline file and plan it.
pub fn load_plan(
    root: &Path,
    file: &Path,
    overrides: &[Override],
    kinds: &StageKinds,
) -> Result<Plan, SpecError> {
    let expanded = crate::spec::load(root, file, overrides)?;
    let mut plan = plan(&expanded, kinds)?;
    plan.overrides = overrides
        .iter()
        .map(|o| {
            format!(
                "{}={}",
                o.key,
                scalar_to_string(&o.value).unwrap_or_else(|| format!("{:?}", o.value))
            )
        })
        .collect();
    Ok(plan)
}

/// Plan an expanded pipeline.
pub fn plan(pipeline: &ExpandedPipeline, kinds: &StageKinds) -> Result<Plan, SpecError> {
    let file = &pipeline.file;
    let source = &pipeline.source;
    let err = |key_path: String, message: String| SpecError::new(file, key_path, message).located_in(source);

    let names: BTreeMap<&str, usize> = pipeline
        .stages
        .iter()
        .enumerate()
        .map(|(i, s)| (s.name.as_str(), i))
        .collect();

    let mut stages = Vec::with_capacity(pipeline.stages.len());
    let mut output_owners: BTreeMap<PathBuf, String> = BTreeMap::new();
    for stage in &pipeline.stages {
        let key_path = format!("stages.{}", stage.base);
        let kind = kinds.get(&stage.uses).ok_or_else(|| {
            let known: Vec<&str> = kinds.names().collect();
            err(
                format!("{key_path}.uses"),
                format!(
                    "unknown stage kind `{}` (known: {})",
                    stage.uses,
                    known.join(", ")
                ),
            )
        })?;
        let raw_params = yaml_to_json(&stage.params).map_err(|m| err(format!("{key_path}.params"), m))?;
        let params = kind.resolve_params(&raw_params).map_err(|e| {
            let path = if e.path.is_empty() {
                format!("{key_path}.params")
            } else {
                format!("{key_path}.params.{}", e.path)
            };
            err(path, e.message)
        })?;
        let ports = kind.ports();
        if let Some(shards) = stage.shards {
            let shard_path = format!("{key_path}.shards");
            let Some(sharded) = kind.sharded() else {
                let able: Vec<&str> = kinds
                    .iter()
                    .filter(|k| k.sharded().is_some())
                    .map(|k| k.name())
                    .collect();
                return Err(err(
                    shard_path,
                    format!(
                        "stage kind `{}` cannot be sharded (kinds that can: {})",
                        stage.uses,
                        if able.is_empty() {
                            "none".to_string()
                        } else {
                            able.join(", ")
                        }
                    ),
                ));
            };
            let units = sharded
                .units(&params)
                .map_err(|e| err(format!("{key_path}.params.{}", e.path), e.message))?;
            if shards == 0 || shards as usize > units {
                return Err(err(
                    shard_path,
                    format!(
                        "{shards} shards for {units} {}: use between 1 and {units} (one {} per shard at least)",
                        sharded.unit_name(),
                        sharded.unit_name().trim_end_matches('s')
                    ),
                ));
            }
        }

        let mut inputs = IndexMap::new();
        for (name, value) in &stage.inputs {
            // `null` (say, a var left unset) leaves an optional input out; a required one is
            // then reported missing below.
            if value.is_null() {
                continue;
            }
            let input_path = format!("{key_path}.inputs.{name}");
            let port = ports.inputs.iter().find(|p| p.name == name);
            if port.is_none() && !ports.open {
                let known: Vec<&str> = ports.inputs.iter().map(|p| p.name).collect();
                return Err(err(
                    input_path,
                    format!(
                        "`{}` has no input `{name}` (inputs: {})",
                        stage.uses,
                        known.join(", ")
                    ),
                ));
            }
            let (sources, is_list) =
                parse_sources(value, pipeline, &names).map_err(|m| err(input_path.clone(), m))?;
            let many = is_list || sources.len() > 1;
            if many && port.is_some_and(|p| !p.many) {
                return Err(err(
                    input_path,
                    format!("input `{name}` takes one source, got {}", sources.len()),
                ));
            }
            inputs.insert(name.clone(), PlannedInput { sources, many });
        }
        for port in ports.inputs.iter().filter(|p| p.required) {
            if !inputs.contains_key(port.name) {
                return Err(err(
                    format!("{key_path}.inputs"),
                    format!("missing input `{}` ({})", port.name, port.description),
                ));
            }
        }

        let mut outputs = IndexMap::new();
        for (name, value) in &stage.outputs {
            let output_path = format!("{key_path}.outputs.{name}");
            if !ports.open && !ports.outputs.iter().any(|p| p.name == name) {
                let known: Vec<&str> = ports.outputs.iter().map(|p| p.name).collect();
                return Err(err(
                    output_path,
                    format!(
                        "`{}` has no output `{name}` (outputs: {})",
                        stage.uses,
                        known.join(", ")
                    ),
                ));
            }
            if name.contains('.') {
                return Err(err(output_path, "output names must not contain `.`".into()));
            }
            let output = parse_output(value).map_err(|m| err(output_path.clone(), m))?;
            if let Some(owner) = output_owners.insert(output.path.clone(), stage.name.clone()) {
                return Err(err(
                    output_path,
                    format!(
                        "`{}` is already an output of stage `{owner}`",
                        output.path.display()
                    ),
                ));
            }
            outputs.insert(name.clone(), output);
        }
        for port in ports.outputs.iter().filter(|p| p.required) {
            if !outputs.contains_key(port.name) {
                return Err(err(
                    format!("{key_path}.outputs"),
                    format!("missing output `{}` ({})", port.name, port.description),
                ));
            }
        }

        stages.push(PlannedStage {
            name: stage.name.clone(),
            base: stage.base.clone(),
            kind: stage.uses.clone(),
            kind_version: kind.version(),
            description: stage.description.clone(),
            params,
            inputs,
            outputs,
            upstream: Vec::new(),
            always_run: stage.always_run,
            resources: stage.resources.clone(),
            shards: stage.shards,
        });
    }

    // Wire upstream edges and check referenced outputs exist.
    for i in 0..stages.len() {
        let mut upstream = BTreeSet::new();
        for (input_name, input) in &stages[i].inputs {
            for source in &input.sources {
                if let Source::Output { stage, output } = source {
                    let j = names[stage.as_str()];
                    if !stages[j].outputs.contains_key(output) {
                        let known: Vec<&str> = stages[j].outputs.keys().map(String::as_str).collect();
                        return Err(err(
                            format!("stages.{}.inputs.{input_name}", stages[i].base),
                            format!(
                                "stage `{stage}` has no output `{output}` (outputs: {})",
                                known.join(", ")
                            ),
                        ));
                    }
                    upstream.insert(j);
                }
            }
        }
        stages[i].upstream = upstream.into_iter().collect();
    }

    let order = topological_order(&stages).map_err(|mut cycle| {
        // Start the story at the stage declared first.
        let first_pos = cycle
            .iter()
            .enumerate()
            .min_by_key(|&(_, &i)| i)
            .map_or(0, |(pos, _)| pos);
        cycle.rotate_left(first_pos);
        let first = &stages[cycle[0]];
        if cycle.len() == 1 {
            return err(
                format!("stages.{}", first.base),
                format!("dependency cycle: `{}` needs itself", first.name),
            );
        }
        let mut story = format!("`{}` needs `{}`", first.name, stages[cycle[1 % cycle.len()]].name);
        for &i in cycle.iter().skip(2).chain(std::iter::once(&cycle[0])) {
            story.push_str(&format!(", which needs `{}`", stages[i].name));
        }
        err(
            format!("stages.{}", first.base),
            format!("dependency cycle: {story}"),
        )
    })?;
    // Reorder, remapping upstream indices.
    let mut new_index = vec![0; stages.len()];
    for (new, &old) in order.iter().enumerate() {
        new_index[old] = new;
    }
    let mut ordered: Vec<PlannedStage> = order.iter().map(|&i| stages[i].clone()).collect();
    for stage in &mut ordered {
        stage.upstream = stage.upstream.iter().map(|&u| new_index[u]).collect();
        stage.upstream.sort_unstable();
    }

    let name = file
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| "pipeline".into());
    Ok(Plan {
        name,
        file: file.clone(),
        description: pipeline.description.clone(),
        vars: yaml_to_json(&Value::Mapping(pipeline.vars.clone())).unwrap_or(serde_json::Value::Null),
        overrides: Vec::new(),
        stages: ordered,
    })
}

/// Kahn's algorithm, stable (declaration order among ready stages). On a cycle,
/// returns the stages of one cycle.
fn topological_order(stages: &[PlannedStage]) -> Result<Vec<usize>, Vec<usize>> {
    let n = stages.len();
    let mut indegree: Vec<usize> = stages.iter().map(|s| s.upstream.len()).collect();
    let mut order = Vec::with_capacity(n);
    let mut done = vec![false; n];
    while let Some(next) = (0..n).find(|&i| !done[i] && indegree[i] == 0) {
        done[next] = true;
        order.push(next);
        for (i, stage) in stages.iter().enumerate() {
            if stage.upstream.contains(&next) {
                indegree[i] -= 1;
            }
        }
    }
    if order.len() == n {
        return Ok(order);
    }
    // Walk upstream edges among the remaining stages until a stage repeats.
    let start = (0..n).find(|&i| !done[i]).unwrap_or(0);
    let mut path = vec![start];
    let mut current = start;
    loop {
        let Some(&next) = stages[current].upstream.iter().find(|&&u| !done[u]) else {
            return Err(path);
        };
        if let Some(pos) = path.iter().position(|&p| p == next) {
            // Each stage in `path` reads from the next one.
            return Err(path[pos..].to_vec());
        }
        path.push(next);
        current = next;
    }
}

fn parse_sources(
    value: &Value,
    pipeline: &ExpandedPipeline,
    names: &BTreeMap<&str, usize>,
) -> Result<(Vec<Source>, bool), String> {
    match value {
        Value::Sequence(items) => {
            let mut out = Vec::new();
            for item in items {
                out.extend(parse_sources(item, pipeline, names)?.0);
            }
            Ok((out, true))
        }
        Value::String(s) => {
            if s.trim().is_empty() {
                return Err("an input path must not be empty".into());
            }
            if s.contains("://") {
                Ok((vec![Source::Url { url: s.clone() }], false))
            } else {
                Ok((
                    vec![Source::File {
                        path: PathBuf::from(s),
                    }],
                    false,
                ))
            }
        }
        Value::Mapping(map) => {
            if map.len() != 1 {
                return Err("an input mapping must be exactly `{from: STAGE.OUTPUT}`".into());
            }
            let reference = map
                .get("from")
                .and_then(Value::as_str)
                .ok_or("an input mapping must be exactly `{from: STAGE.OUTPUT}`")?;
            let (stage, output) = reference
                .rsplit_once('.')
                .ok_or_else(|| format!("`from: {reference}` must be STAGE.OUTPUT"))?;
            if names.contains_key(stage) {
                Ok((
                    vec![Source::Output {
                        stage: stage.to_string(),
                        output: output.to_string(),
                    }],
                    false,
                ))
            } else if let Some(group) = pipeline.groups.get(stage) {
                // A foreach/matrix base: fan in every expansion's output.
                Ok((
                    group
                        .iter()
                        .map(|s| Source::Output {
                            stage: s.clone(),
                            output: output.to_string(),
                        })
                        .collect(),
                    true,
                ))
            } else {
                let known: Vec<&str> = names.keys().copied().collect();
                Err(format!("no stage `{stage}` (stages: {})", known.join(", ")))
            }
        }
        other => Err(format!(
            "an input is a path, a URL, a list, or {{from: STAGE.OUTPUT}}, not {}",
            type_name(other)
        )),
    }
}

fn parse_output(value: &Value) -> Result<PlannedOutput, String> {
    match value {
        Value::String(s) if !s.trim().is_empty() => {
            if s.contains("://") {
                return Err("outputs are local paths; publish to a store with `artifact: true`".into());
            }
            Ok(PlannedOutput {
                path: PathBuf::from(s),
                artifact: false,
            })
        }
        Value::Mapping(map) => {
            let mut path = None;
            let mut artifact = false;
            for (k, v) in map {
                match k.as_str() {
                    Some("path") => path = v.as_str().map(PathBuf::from),
                    Some("artifact") => {
                        artifact = v.as_bool().ok_or("`artifact` must be true or false")?;
                    }
                    _ => {
                        return Err(format!(
                            "unknown output key `{}` (expected `path`, `artifact`)",
                            scalar_to_string(k).unwrap_or_default()
                        ));
                    }
                }
            }
            let path = path.ok_or("an output mapping needs `path`")?;
            Ok(PlannedOutput { path, artifact })
        }
        other => Err(format!(
            "an output is a path or {{path, artifact}}, not {}",
            type_name(other)
        )),
    }
}

fn type_name(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Sequence(_) => "a list",
        Value::Mapping(_) => "a mapping",
        Value::Tagged(_) => "a tagged value",
    }
}

/// Params flattened to dotted key paths (`env.sim.wind.speed_mph`) with their leaf values,
/// for diffs and side-by-side comparisons. Empty objects are leaves.
pub fn flatten_params(value: &serde_json::Value) -> std::collections::BTreeMap<String, serde_json::Value> {
    fn walk(
        prefix: &str,
        value: &serde_json::Value,
        out: &mut std::collections::BTreeMap<String, serde_json::Value>,
    ) {
        match value {
            serde_json::Value::Object(map) if !map.is_empty() => {
                for (k, v) in map {
                    let key = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    walk(&key, v, out);
                }
            }
            // Lists of mappings (an experiment's models) by index, as `-S models.2.x=…`
            // spells them; lists of plain values stay whole (`seeds: [0, 1, 2]`).
            serde_json::Value::Array(items) if items.iter().any(serde_json::Value::is_object) => {
                for (i, v) in items.iter().enumerate() {
                    let key = if prefix.is_empty() {
                        i.to_string()
                    } else {
                        format!("{prefix}.{i}")
                    };
                    walk(&key, v, out);
                }
            }
            other => {
                out.insert(prefix.to_string(), other.clone());
            }
        }
    }
    let mut out = std::collections::BTreeMap::new();
    walk("", value, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    #[test]
    fn flattened_params_index_lists_of_mappings_and_keep_plain_lists_whole() {
        let flat = super::flatten_params(&json!({
            "seeds": [0, 1, 2],
            "models": [{"kind": "majority"}, {"kind": "xgboost", "params": {"n_estimators": 20}}],
            "evaluation": {"bootstrap": 1000, "extra": {}},
        }));
        let keys: Vec<&str> = flat.keys().map(String::as_str).collect();
        assert_eq!(
            keys,
            [
                "evaluation.bootstrap",
                "evaluation.extra",
                "models.0.kind",
                "models.1.kind",
                "models.1.params.n_estimators",
                "seeds"
            ]
        );
        assert_eq!(flat["models.1.params.n_estimators"], json!(20));
        assert_eq!(flat["seeds"], json!([0, 1, 2]));
    }
}
