//! The pipeline file as written: strict YAML into raw types, then template
//! expansion (`${var}`, `foreach`, `matrix`) and `-S` overrides.
//!
//! ```yaml
//! description: Demo
//! params_file: pipelines/demo.params.yaml   # optional, overlays `vars`
//! vars: { seed: 7 }
//! stages:
//!   extract:
//!     uses: cmd                             # a registered stage kind
//!     foreach: [tmmx, rmin]                 # -> extract@tmmx, extract@rmin
//!     params: { command: "cp ${inputs.src} ${outputs.out}" }
//!     inputs: { src: "data/${item}.nc" }    # a path, a store URL, or {from: stage.output}
//!     outputs: { out: "build/${item}.nc" }  # a path, or {path: .., artifact: true}
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use indexmap::IndexMap;
use serde::Deserialize;
use serde_yaml_ng::{Mapping, Value};

use crate::error::SpecError;

/// A pipeline file, strictly parsed.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPipeline {
    #[serde(default)]
    pub description: Option<String>,
    /// YAML mapping overlaid on `vars` (like DVC's `params.yaml`), relative to the project root.
    #[serde(default)]
    pub params_file: Option<PathBuf>,
    #[serde(default)]
    pub vars: Mapping,
    pub stages: IndexMap<String, RawStage>,
}

/// One stage as written, before expansion.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawStage {
    pub uses: String,
    #[serde(default)]
    pub description: Option<String>,
    #[serde(default)]
    pub params: Mapping,
    #[serde(default)]
    pub inputs: IndexMap<String, Value>,
    #[serde(default)]
    pub outputs: IndexMap<String, Value>,
    /// A list (`${item}`) or a mapping (`${key}`, `${item}`) to stamp the stage out over.
    #[serde(default)]
    pub foreach: Option<Value>,
    /// Named lists; the stage is stamped out over their Cartesian product (`${item.name}`).
    #[serde(default)]
    pub matrix: Option<IndexMap<String, Vec<Value>>>,
    /// Run every time, even when nothing changed (e.g. a stage that reads the clock).
    #[serde(default)]
    pub always_run: bool,
    /// What one run of the stage needs on a cluster worker (`--executor ray`); not part of
    /// the cache key, ignored by the local executor.
    #[serde(default)]
    pub resources: crate::resources::Resources,
    /// Split the stage's work into this many shards (kinds that support it), run as
    /// separate tasks and merged deterministically: the outputs equal the unsharded run's.
    #[serde(default)]
    pub shards: Option<u32>,
}

/// A `-S key=value` override from the command line.
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    pub key: String,
    pub value: Value,
}

impl Override {
    /// Parse `key=value`; the value is read as a YAML scalar/flow value, so `3`, `true`,
    /// `[1, 2]` keep their types.
    pub fn parse(text: &str) -> Result<Self, String> {
        let (key, value) = text
            .split_once('=')
            .ok_or_else(|| format!("override `{text}` is not of the form key=value"))?;
        let key = key.trim();
        if key.is_empty() {
            return Err(format!("override `{text}` has an empty key"));
        }
        let trimmed = value.trim();
        let looks_like_collection = trimmed.starts_with('[') || trimmed.starts_with('{');
        let value: Value = match serde_yaml_ng::from_str::<Value>(value) {
            Ok(v @ (Value::Sequence(_) | Value::Mapping(_))) if looks_like_collection => v,
            Err(e) if looks_like_collection => {
                return Err(format!("override `{text}`: value is not valid YAML: {e}"));
            }
            // Anything else that is not a plain scalar (`?`, `*x`, `- a`) is taken as text.
            Ok(v @ (Value::Bool(_) | Value::Number(_) | Value::String(_) | Value::Null))
                if !trimmed.is_empty() =>
            {
                v
            }
            _ => Value::String(value.to_string()),
        };
        Ok(Self {
            key: key.to_string(),
            value,
        })
    }
}

/// A stage after expansion and templating: what the planner consumes.
#[derive(Debug, Clone)]
pub struct ExpandedStage {
    /// `extract` or `extract@tmmx`.
    pub name: String,
    /// The key under `stages:` it came from.
    pub base: String,
    pub uses: String,
    pub description: Option<String>,
    pub params: Value,
    pub inputs: IndexMap<String, Value>,
    pub outputs: IndexMap<String, Value>,
    pub always_run: bool,
    pub resources: crate::resources::Resources,
    pub shards: Option<u32>,
}

/// The pipeline after parsing, overrides and expansion.
#[derive(Debug, Clone)]
pub struct ExpandedPipeline {
    pub file: PathBuf,
    pub source: String,
    pub description: Option<String>,
    /// Resolved variables (defaults, then params file, then `-S`).
    pub vars: Mapping,
    pub stages: Vec<ExpandedStage>,
    /// Bases stamped out by `foreach`/`matrix`, with their expansions in order.
    pub groups: BTreeMap<String, Vec<String>>,
}

/// Read, parse and expand a pipeline file. `root` resolves `params_file`.
pub fn load(root: &Path, file: &Path, overrides: &[Override]) -> Result<ExpandedPipeline, SpecError> {
    let path = root.join(file);
    let source = std::fs::read_to_string(&path)
        .map_err(|e| SpecError::new(file, "", format!("cannot read pipeline file: {e}")))?;
    parse(root, file, &source, overrides)
}

/// Parse and expand pipeline source text (the file name is used in errors).
pub fn parse(
    root: &Path,
    file: &Path,
    source: &str,
    overrides: &[Override],
) -> Result<ExpandedPipeline, SpecError> {
    let raw: RawPipeline = deserialize_located(file, source)?;
    let mut vars = raw.vars.clone();
    if let Some(params_file) = &raw.params_file {
        let params_path = root.join(params_file);
        let text = std::fs::read_to_string(&params_path).map_err(|e| {
            SpecError::new(
                file,
                "params_file",
                format!("cannot read `{}`: {e}", params_file.display()),
            )
            .located_in(source)
        })?;
        let overlay: Mapping = deserialize_located(params_file, &text)?;
        merge_mapping(&mut vars, overlay);
    }

    // Overrides: a first segment naming a stage sets that stage's params; otherwise a var.
    let mut stage_overrides: BTreeMap<String, Vec<(Vec<String>, Value)>> = BTreeMap::new();
    for o in overrides {
        let segments: Vec<String> = o.key.split('.').map(str::to_string).collect();
        let first = &segments[0];
        let is_stage = raw.stages.contains_key(first);
        let is_var = vars.contains_key(first.as_str());
        match (is_stage, is_var) {
            (true, true) => {
                return Err(SpecError::new(
                    file,
                    "",
                    format!(
                        "override `{}` is ambiguous: `{first}` is both a stage and a var",
                        o.key
                    ),
                ));
            }
            (true, false) => {
                if segments.len() < 2 {
                    return Err(SpecError::new(
                        file,
                        "",
                        format!(
                            "override `{}` names a stage but no param (use {first}.PARAM=VALUE)",
                            o.key
                        ),
                    ));
                }
                stage_overrides
                    .entry(first.clone())
                    .or_default()
                    .push((segments[1..].to_vec(), o.value.clone()));
            }
            (false, true) => set_existing_var(&mut vars, &segments, o.value.clone())
                .map_err(|m| SpecError::new(file, "", format!("override `{}`: {m}", o.key)))?,
            (false, false) => {
                let mut known: Vec<String> = vars
                    .keys()
                    .filter_map(|k| k.as_str())
                    .map(str::to_string)
                    .collect();
                known.extend(raw.stages.keys().cloned());
                return Err(SpecError::new(
                    file,
                    "",
                    format!(
                        "override `{}`: `{first}` is neither a var nor a stage (known: {})",
                        o.key,
                        known.join(", ")
                    ),
                ));
            }
        }
    }

    let mut stages = Vec::new();
    let mut groups = BTreeMap::new();
    for (base, raw_stage) in &raw.stages {
        validate_stage_name(base)
            .map_err(|m| SpecError::new(file, format!("stages.{base}"), m).located_in(source))?;
        let key_path = format!("stages.{base}");
        // `foreach: ${list_var}` takes its list from the vars.
        let mut raw_stage = raw_stage.clone();
        if let Some(Value::String(template)) = &raw_stage.foreach {
            let scope = Scope {
                depth: 0,
                vars: &vars,
                item: None,
                key: None,
            };
            let rendered = render_string(template, &scope)
                .map_err(|m| SpecError::new(file, format!("{key_path}.foreach"), m).located_in(source))?;
            raw_stage.foreach = Some(rendered);
        }
        let raw_stage = &raw_stage;
        let instances = expansions(raw_stage, &key_path)
            .map_err(|e| SpecError::new(file, e.0, e.1).located_in(source))?;
        let expanded = instances.len() > 1 || raw_stage.foreach.is_some() || raw_stage.matrix.is_some();
        let mut names = Vec::new();
        for (suffix, scope) in instances {
            let name = match &suffix {
                Some(s) => format!("{base}@{s}"),
                None => base.clone(),
            };
            let ctx = Scope {
                depth: 0,
                vars: &vars,
                item: scope.item.as_ref(),
                key: scope.key.as_deref(),
            };
            let render_err = |e: (String, String)| SpecError::new(file, e.0, e.1).located_in(source);
            let mut params = render(
                &Value::Mapping(raw_stage.params.clone()),
                &ctx,
                &format!("{key_path}.params"),
            )
            .map_err(render_err)?;
            if let Some(list) = stage_overrides.get(base) {
                for (segments, value) in list {
                    set_path(&mut params, segments, value.clone());
                }
            }
            let mut inputs = IndexMap::new();
            for (input, value) in &raw_stage.inputs {
                let v = render(value, &ctx, &format!("{key_path}.inputs.{input}")).map_err(render_err)?;
                inputs.insert(input.clone(), v);
            }
            let mut outputs = IndexMap::new();
            for (output, value) in &raw_stage.outputs {
                let v = render(value, &ctx, &format!("{key_path}.outputs.{output}")).map_err(render_err)?;
                outputs.insert(output.clone(), v);
            }
            let description = match &raw_stage.description {
                Some(d) => match render(
                    &Value::String(d.clone()),
                    &ctx,
                    &format!("{key_path}.description"),
                )
                .map_err(render_err)?
                {
                    Value::String(s) => Some(s),
                    other => Some(scalar_to_string(&other).unwrap_or_default()),
                },
                None => None,
            };
            names.push(name.clone());
            stages.push(ExpandedStage {
                name,
                base: base.clone(),
                uses: raw_stage.uses.clone(),
                description,
                params,
                inputs,
                outputs,
                always_run: raw_stage.always_run,
                resources: raw_stage.resources.clone(),
                shards: raw_stage.shards,
            });
        }
        if expanded {
            groups.insert(base.clone(), names);
        }
    }
    Ok(ExpandedPipeline {
        file: file.to_path_buf(),
        source: source.to_string(),
        description: raw.description,
        vars,
        stages,
        groups,
    })
}

/// Deserialize strictly, turning serde's error into file:line:col + key path.
pub fn deserialize_located<T: serde::de::DeserializeOwned>(
    file: &Path,
    source: &str,
) -> Result<T, SpecError> {
    let deserializer = serde_yaml_ng::Deserializer::from_str(source);
    serde_path_to_error::deserialize(deserializer).map_err(|e| {
        let key_path = clean_serde_path(&e.path().to_string());
        let inner = e.inner();
        let location = inner.location();
        let mut message = inner.to_string();
        // serde_yaml_ng appends " at line L column C" and may prefix its own path
        // ("stages.a: ..."); we print both up front.
        if let Some(at) = message.find(" at line ") {
            message.truncate(at);
        }
        if let Some((prefix, rest)) = message.split_once(": ")
            && !prefix.contains(char::is_whitespace)
            && !prefix.contains('`')
        {
            message = rest.to_string();
        }
        // The classic trap: `{command: echo ${x}}` closes the flow mapping at `}`.
        let line_text = location
            .as_ref()
            .and_then(|l| source.lines().nth(l.line().saturating_sub(1)));
        if message.contains("expected ',' or '}'") && line_text.is_some_and(|t| t.contains("${")) {
            message.push_str(" (hint: quote values that contain `${...}` inside `{...}`)");
        }
        let mut error = SpecError::new(file, key_path, message);
        if let Some(loc) = location {
            error.line = Some(loc.line());
            error.column = Some(loc.column());
        }
        error.located_in(source)
    })
}

/// Deserialize YAML strictly through JSON values, so externally tagged enums are written
/// as one-key mappings (`{procedural: {seed: 1}}`) rather than YAML tags (`!procedural`).
/// Errors still name the file, line and key path.
pub fn deserialize_mapping_enums<T: serde::de::DeserializeOwned>(
    file: &Path,
    source: &str,
) -> Result<T, SpecError> {
    let value: Value = deserialize_located(file, source)?;
    let json = yaml_to_json(&value).map_err(|m| SpecError::new(file, "", m))?;
    crate::stage::deserialize_params(&json)
        .map_err(|e| SpecError::new(file, e.path.replace(".?", ""), e.message).located_in(source))
}

/// serde_path_to_error prints `.` for the root and `?` for unknown positions.
fn clean_serde_path(path: &str) -> String {
    if path == "." || path == "?" {
        String::new()
    } else {
        path.replace(".?", "").trim_start_matches('.').to_string()
    }
}

fn validate_stage_name(name: &str) -> Result<(), String> {
    if name.is_empty() {
        return Err("a stage name must not be empty".into());
    }
    if let Some(bad) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '_' || *c == '-'))
    {
        return Err(format!(
            "stage name `{name}` contains `{bad}`: use letters, digits, `_` and `-`"
        ));
    }
    Ok(())
}

struct Instance {
    item: Option<Value>,
    key: Option<String>,
}

type KeyedError = (String, String);

fn expansions(stage: &RawStage, key_path: &str) -> Result<Vec<(Option<String>, Instance)>, KeyedError> {
    match (&stage.foreach, &stage.matrix) {
        (Some(_), Some(_)) => Err((
            key_path.to_string(),
            "use either `foreach` or `matrix`, not both".to_string(),
        )),
        (None, None) => Ok(vec![(
            None,
            Instance {
                item: None,
                key: None,
            },
        )]),
        (Some(Value::Sequence(items)), None) => {
            let mut out = Vec::new();
            for (i, item) in items.iter().enumerate() {
                // Scalars name the instance by value, mappings by position, like DVC.
                let suffix = scalar_to_string(item).map_or_else(|| i.to_string(), |s| sanitize_suffix(&s));
                out.push((
                    Some(suffix),
                    Instance {
                        item: Some(item.clone()),
                        key: None,
                    },
                ));
            }
            check_unique(&out, key_path, "foreach")?;
            Ok(out)
        }
        (Some(Value::Mapping(map)), None) => {
            let mut out = Vec::new();
            for (k, v) in map {
                let key = scalar_to_string(k).ok_or_else(|| {
                    (
                        format!("{key_path}.foreach"),
                        "foreach keys must be scalars".to_string(),
                    )
                })?;
                out.push((
                    Some(sanitize_suffix(&key)),
                    Instance {
                        item: Some(v.clone()),
                        key: Some(key),
                    },
                ));
            }
            check_unique(&out, key_path, "foreach")?;
            Ok(out)
        }
        (Some(_), None) => Err((
            format!("{key_path}.foreach"),
            "foreach must be a list or a mapping".to_string(),
        )),
        (None, Some(matrix)) => {
            let mut combos: Vec<(Vec<String>, Mapping)> = vec![(Vec::new(), Mapping::new())];
            for (name, values) in matrix {
                if values.is_empty() {
                    return Err((
                        format!("{key_path}.matrix.{name}"),
                        "matrix lists must not be empty".into(),
                    ));
                }
                let mut next = Vec::new();
                for (labels, map) in &combos {
                    for (i, value) in values.iter().enumerate() {
                        let mut labels = labels.clone();
                        labels.push(
                            scalar_to_string(value).map_or_else(|| i.to_string(), |s| sanitize_suffix(&s)),
                        );
                        let mut map = map.clone();
                        map.insert(Value::String(name.clone()), value.clone());
                        next.push((labels, map));
                    }
                }
                combos = next;
            }
            let out: Vec<_> = combos
                .into_iter()
                .map(|(labels, map)| {
                    (
                        Some(labels.join("-")),
                        Instance {
                            item: Some(Value::Mapping(map)),
                            key: None,
                        },
                    )
                })
                .collect();
            check_unique(&out, key_path, "matrix")?;
            Ok(out)
        }
    }
}

fn check_unique(out: &[(Option<String>, Instance)], key_path: &str, what: &str) -> Result<(), KeyedError> {
    let mut seen = std::collections::BTreeSet::new();
    for (suffix, _) in out {
        if let Some(s) = suffix
            && !seen.insert(s.clone())
        {
            return Err((
                format!("{key_path}.{what}"),
                format!("two expansions would both be named `@{s}`"),
            ));
        }
    }
    Ok(())
}

/// Keep expansion names usable on a command line and in file names.
fn sanitize_suffix(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

pub(crate) fn scalar_to_string(v: &Value) -> Option<String> {
    match v {
        Value::String(s) => Some(s.clone()),
        Value::Number(n) => Some(n.to_string()),
        Value::Bool(b) => Some(b.to_string()),
        Value::Null => Some("null".into()),
        _ => None,
    }
}

/// YAML to JSON (for params): mapping keys must be strings, numbers must be finite.
pub fn yaml_to_json(v: &Value) -> Result<serde_json::Value, String> {
    Ok(match v {
        Value::Null => serde_json::Value::Null,
        Value::Bool(b) => serde_json::Value::Bool(*b),
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                serde_json::Value::from(i)
            } else if let Some(u) = n.as_u64() {
                serde_json::Value::from(u)
            } else {
                let f = n.as_f64().unwrap_or(f64::NAN);
                serde_json::Number::from_f64(f)
                    .map(serde_json::Value::Number)
                    .ok_or_else(|| format!("number {f} is not finite"))?
            }
        }
        Value::String(s) => serde_json::Value::String(s.clone()),
        Value::Sequence(items) => {
            serde_json::Value::Array(items.iter().map(yaml_to_json).collect::<Result<_, _>>()?)
        }
        Value::Mapping(map) => {
            let mut out = serde_json::Map::new();
            for (k, v) in map {
                let key = scalar_to_string(k).ok_or("mapping keys must be scalars")?;
                out.insert(key, yaml_to_json(v)?);
            }
            serde_json::Value::Object(out)
        }
        Value::Tagged(t) => yaml_to_json(&t.value)?,
    })
}

struct Scope<'a> {
    vars: &'a Mapping,
    item: Option<&'a Value>,
    key: Option<&'a str>,
    /// How many variables deep this lookup is (vars may refer to vars).
    depth: usize,
}

/// Deeper than this, variables referring to variables are taken for a cycle.
const MAX_VAR_DEPTH: usize = 16;

impl Scope<'_> {
    fn lookup(&self, name: &str) -> Result<Value, String> {
        let mut segments = name.split('.');
        let first = segments.next().unwrap_or_default();
        let root = match first {
            "item" => self
                .item
                .cloned()
                .ok_or("`${item}` is only defined inside `foreach`/`matrix`")?,
            "key" => Value::String(
                self.key
                    .ok_or("`${key}` is only defined inside a `foreach` over a mapping")?
                    .to_string(),
            ),
            _ => {
                let value = self.vars.get(first).ok_or_else(|| {
                    let known: Vec<&str> = self.vars.keys().filter_map(|k| k.as_str()).collect();
                    format!(
                        "unknown variable `{name}` (vars: {})",
                        if known.is_empty() {
                            "none".into()
                        } else {
                            known.join(", ")
                        }
                    )
                })?;
                if self.depth >= MAX_VAR_DEPTH {
                    return Err(format!(
                        "variable `{first}` refers to itself through other variables"
                    ));
                }
                // A var may use other vars (`landscape: {center: ["${lat}", "${lon}"]}`).
                let inner = Scope {
                    vars: self.vars,
                    item: self.item,
                    key: self.key,
                    depth: self.depth + 1,
                };
                render(value, &inner, first).map_err(|(_, m)| m)?
            }
        };
        let mut current = root;
        for segment in segments {
            current = match &current {
                Value::Mapping(m) => m.get(segment).cloned(),
                Value::Sequence(s) => segment.parse::<usize>().ok().and_then(|i| s.get(i).cloned()),
                _ => None,
            }
            .ok_or_else(|| format!("`{name}`: no key `{segment}`"))?;
        }
        Ok(current)
    }
}

/// Placeholders resolved when the stage runs, not at load time.
fn is_runtime_placeholder(name: &str) -> bool {
    name.starts_with("inputs.") || name.starts_with("outputs.")
}

fn render(value: &Value, scope: &Scope<'_>, key_path: &str) -> Result<Value, KeyedError> {
    match value {
        Value::String(s) => render_string(s, scope).map_err(|m| (key_path.to_string(), m)),
        Value::Sequence(items) => items
            .iter()
            .enumerate()
            .map(|(i, v)| render(v, scope, &format!("{key_path}.{i}")))
            .collect::<Result<Vec<_>, _>>()
            .map(Value::Sequence),
        Value::Mapping(map) => {
            let mut out = Mapping::new();
            for (k, v) in map {
                let key_name = scalar_to_string(k).unwrap_or_default();
                out.insert(k.clone(), render(v, scope, &format!("{key_path}.{key_name}"))?);
            }
            Ok(Value::Mapping(out))
        }
        other => Ok(other.clone()),
    }
}

/// `${name}` alone keeps the value's type; inside text it is formatted; `$${` escapes.
fn render_string(s: &str, scope: &Scope<'_>) -> Result<Value, String> {
    let trimmed = s.trim();
    if let Some(inner) = trimmed.strip_prefix("${").and_then(|r| r.strip_suffix('}'))
        && !inner.contains("${")
        && !inner.contains('}')
        && trimmed == s
        && !is_runtime_placeholder(inner.trim())
    {
        return scope.lookup(inner.trim());
    }
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(pos) = rest.find("${") {
        if rest[..pos].ends_with('$') {
            out.push_str(&rest[..pos - 1]);
            out.push_str("${");
            rest = &rest[pos + 2..];
            continue;
        }
        out.push_str(&rest[..pos]);
        let after = &rest[pos + 2..];
        let end = after
            .find('}')
            .ok_or_else(|| format!("unclosed `${{` in `{s}`"))?;
        let name = after[..end].trim();
        if is_runtime_placeholder(name) {
            out.push_str(&rest[pos..pos + 2 + end + 1]);
        } else {
            let value = scope.lookup(name)?;
            let text = scalar_to_string(&value).ok_or_else(|| {
                format!("`${{{name}}}` is a list or mapping and cannot be part of a string")
            })?;
            out.push_str(&text);
        }
        rest = &after[end + 1..];
    }
    out.push_str(rest);
    Ok(Value::String(out))
}

pub(crate) fn merge_mapping(base: &mut Mapping, overlay: Mapping) {
    for (k, v) in overlay {
        match (base.get_mut(&k), v) {
            (Some(Value::Mapping(b)), Value::Mapping(o)) => merge_mapping(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

fn set_existing_var(vars: &mut Mapping, segments: &[String], value: Value) -> Result<(), String> {
    let mut current = vars;
    for (i, segment) in segments.iter().enumerate() {
        let last = i + 1 == segments.len();
        let entry = current
            .get_mut(segment.as_str())
            .ok_or_else(|| format!("no var `{}`", segments[..=i].join(".")))?;
        if last {
            *entry = value;
            return Ok(());
        }
        current = match entry {
            Value::Mapping(m) => m,
            _ => return Err(format!("`{}` is not a mapping", segments[..=i].join("."))),
        };
    }
    Ok(())
}

fn set_path(target: &mut Value, segments: &[String], value: Value) {
    if segments.is_empty() {
        *target = value;
        return;
    }
    if !matches!(target, Value::Mapping(_)) {
        *target = Value::Mapping(Mapping::new());
    }
    if let Value::Mapping(map) = target {
        let key = Value::String(segments[0].clone());
        let child = map.entry(key).or_insert(Value::Null);
        set_path(child, &segments[1..], value);
    }
}

/// `a.b.c=value`: sets a nested key (creating mappings), value parsed as YAML. List items
/// are addressed by index: `models.2.params.max_epochs=5`.
pub fn apply_override(root: &mut Value, text: &str) -> Result<(), crate::ParamsError> {
    let (key, raw) = text.split_once('=').ok_or_else(|| crate::ParamsError {
        path: text.into(),
        message: "an override is KEY=VALUE".into(),
    })?;
    let value: Value = serde_yaml_ng::from_str(raw).map_err(|e| crate::ParamsError {
        path: key.into(),
        message: format!("the value is not YAML: {e}"),
    })?;
    let mut node = root;
    let parts: Vec<&str> = key.split('.').collect();
    for (i, part) in parts.iter().enumerate() {
        let last = i + 1 == parts.len();
        node = match node {
            Value::Sequence(items) => {
                let idx: usize = part.parse().map_err(|_| crate::ParamsError {
                    path: key.into(),
                    message: format!("`{part}` indexes a list: use a number"),
                })?;
                let len = items.len();
                items.get_mut(idx).ok_or_else(|| crate::ParamsError {
                    path: key.into(),
                    message: format!("index {idx} is past the list's {len} items"),
                })?
            }
            Value::Mapping(map) => {
                let k = Value::String((*part).to_string());
                if !map.contains_key(&k) {
                    map.insert(k.clone(), Value::Mapping(Default::default()));
                }
                map.get_mut(&k).ok_or_else(|| crate::ParamsError {
                    path: key.into(),
                    message: "cannot set".into(),
                })?
            }
            other => {
                if matches!(other, Value::Null) {
                    *other = Value::Mapping(Default::default());
                    let Value::Mapping(map) = other else {
                        unreachable!()
                    };
                    let k = Value::String((*part).to_string());
                    map.insert(k.clone(), Value::Null);
                    map.get_mut(&k).ok_or_else(|| crate::ParamsError {
                        path: key.into(),
                        message: "cannot set".into(),
                    })?
                } else {
                    return Err(crate::ParamsError {
                        path: key.into(),
                        message: format!("`{part}` is inside a value that is not a mapping"),
                    });
                }
            }
        };
        if last {
            *node = value.clone();
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn parse_str(src: &str, overrides: &[&str]) -> Result<ExpandedPipeline, SpecError> {
        let o: Vec<Override> = overrides.iter().map(|s| Override::parse(s).unwrap()).collect();
        parse(Path::new("."), Path::new("p.yaml"), src, &o)
    }

    #[test]
    fn unknown_stage_key_is_located() {
        let src = "stages:\n  a:\n    uses: cmd\n    outptus: {}\n";
        let e = parse_str(src, &[]).unwrap_err();
        assert_eq!(e.line, Some(4));
        assert_eq!(e.key_path, "stages.a.outptus");
        assert!(e.message.starts_with("unknown field `outptus`"), "{}", e.message);
    }

    #[test]
    fn vars_refer_to_vars_and_cycles_are_named() {
        let src = "vars: {lat: 1.5, land: {center: [\"${lat}\", 2]}}\nstages:\n  s:\n    uses: cmd\n    params: {command: x, land: \"${land}\"}\n";
        let p = parse(Path::new("."), Path::new("p.yaml"), src, &[]).unwrap();
        let land = &p.stages[0].params["land"];
        assert_eq!(land["center"][0], Value::from(1.5));
        let src = "vars: {a: \"${b}\", b: \"${a}\"}\nstages:\n  s:\n    uses: cmd\n    params: {command: \"${a}\"}\n";
        let e = parse(Path::new("."), Path::new("p.yaml"), src, &[])
            .unwrap_err()
            .to_string();
        assert!(e.contains("refers to itself"), "{e}");
    }

    #[test]
    fn foreach_and_vars_expand() {
        let src = "vars: {n: 3}\nstages:\n  s:\n    uses: cmd\n    foreach: [x, y]\n    params: {command: \"echo ${item} ${n} ${outputs.o}\", count: \"${n}\"}\n";
        let p = parse_str(src, &["n=5"]).unwrap();
        assert_eq!(p.stages.len(), 2);
        assert_eq!(p.stages[1].name, "s@y");
        let params = &p.stages[1].params;
        assert_eq!(params["command"], Value::String("echo y 5 ${outputs.o}".into()));
        assert_eq!(params["count"], Value::Number(5.into()));
    }

    #[test]
    fn matrix_is_a_product() {
        let src = "stages:\n  t:\n    uses: cmd\n    matrix: {lr: [0.1, 0.01], seed: [1, 2]}\n    params: {command: \"${item.lr}/${item.seed}\"}\n";
        let p = parse_str(src, &[]).unwrap();
        let names: Vec<_> = p.stages.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["t@0.1-1", "t@0.1-2", "t@0.01-1", "t@0.01-2"]);
        assert_eq!(p.stages[3].params["command"], Value::String("0.01/2".into()));
    }

    #[test]
    fn unknown_var_names_key_path() {
        let src = "stages:\n  a:\n    uses: cmd\n    params:\n      command: \"${nope}\"\n";
        let e = parse_str(src, &[]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "p.yaml:5:7: stages.a.params.command: unknown variable `nope` (vars: none)"
        );
    }

    #[test]
    fn stage_override_sets_param() {
        let src = "stages:\n  a:\n    uses: cmd\n    params: {command: x}\n";
        let p = parse_str(src, &["a.command=y"]).unwrap();
        assert_eq!(p.stages[0].params["command"], Value::String("y".into()));
        assert!(parse_str(src, &["b.x=1"]).is_err());
    }
}
