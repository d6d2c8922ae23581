//! Composable YAML files: a file may start from another with `extends: FILE` and change only
//! what differs, so a recipe and its ablations share one base instead of copies.
//!
//! `extends` is a path relative to the folder of the file that names it (as Docker Compose
//! and tsconfig resolve theirs), so a folder of recipes moves as a whole. Mappings merge key
//! by key, the extending file winning; any other value (a list, a number, a string) is
//! replaced whole. Chains are allowed; a cycle is an error naming the files. An error found
//! when the merged document is read names the file and line where the offending key was
//! written (the extending file first, then the files it extends).

use std::path::{Component, Path, PathBuf};

use serde_yaml_ng::{Mapping, Value};

use crate::SpecError;

/// The longest chain of `extends` accepted (a guard against mistakes, not a design limit).
const MAX_DEPTH: usize = 8;

/// A YAML document read through its `extends` chain.
#[derive(Debug, Clone)]
pub struct Layered {
    /// Every file of the chain, the file itself first, then what it extends, …: the path as
    /// errors print it, its source text and its own mapping (before merging).
    layers: Vec<Layer>,
    /// The merged document, without `extends`.
    pub value: Value,
}

#[derive(Debug, Clone)]
struct Layer {
    file: PathBuf,
    source: String,
    own: Value,
}

/// Reads `file` (relative to `root`, or absolute) and the files it extends, and merges them.
pub fn load(root: &Path, file: &Path) -> Result<Layered, SpecError> {
    let mut layers: Vec<Layer> = Vec::new();
    let mut next = Some(file.to_path_buf());
    while let Some(current) = next.take() {
        if layers.len() == MAX_DEPTH {
            let chain: Vec<String> = layers.iter().map(|l| l.file.display().to_string()).collect();
            return Err(SpecError::new(
                &layers[0].file,
                "extends",
                format!(
                    "more than {MAX_DEPTH} files extend one another ({} …)",
                    chain.join(" → ")
                ),
            ));
        }
        let path = root.join(&current);
        let source = std::fs::read_to_string(&path).map_err(|e| match layers.last() {
            // The file named by `extends` is missing: say so where it is named.
            Some(parent) => SpecError::new(
                &parent.file,
                "extends",
                format!("cannot read `{}`: {e}", current.display()),
            )
            .located_in(&parent.source),
            None => SpecError::new(&current, "", format!("cannot read the file: {e}")),
        })?;
        let mut own: Value = crate::spec::deserialize_located(&current, &source)?;
        if let Value::Mapping(map) = &mut own
            && let Some(base) = map.remove("extends")
        {
            let Value::String(base) = base else {
                return Err(SpecError::new(&current, "extends", "a file path (a string)").located_in(&source));
            };
            let resolved = normalize(&current.parent().unwrap_or(Path::new("")).join(&base));
            if resolved == normalize(&current) || layers.iter().any(|l| normalize(&l.file) == resolved) {
                let mut chain: Vec<String> = layers.iter().map(|l| l.file.display().to_string()).collect();
                chain.push(current.display().to_string());
                chain.push(resolved.display().to_string());
                return Err(SpecError::new(
                    &current,
                    "extends",
                    format!("files extend one another in a circle: {}", chain.join(" → ")),
                )
                .located_in(&source));
            }
            next = Some(resolved);
        }
        if !matches!(own, Value::Mapping(_)) {
            return Err(SpecError::new(
                &current,
                "",
                "the file must hold a mapping of keys",
            ));
        }
        layers.push(Layer {
            file: current,
            source,
            own,
        });
    }
    let mut value = Mapping::new();
    for layer in layers.iter().rev() {
        if let Value::Mapping(own) = &layer.own {
            crate::spec::merge_mapping(&mut value, own.clone());
        }
    }
    Ok(Layered {
        layers,
        value: Value::Mapping(value),
    })
}

impl Layered {
    /// The file that was asked for (the last of the chain to be applied).
    pub fn file(&self) -> &Path {
        &self.layers[0].file
    }

    /// The files it extends, nearest first.
    pub fn bases(&self) -> impl Iterator<Item = &Path> {
        self.layers[1..].iter().map(|l| l.file.as_path())
    }

    /// The merged document read strictly through JSON values (enums as one-key mappings, as
    /// [`deserialize_mapping_enums`](crate::spec::deserialize_mapping_enums) reads them);
    /// an error names the file and line that wrote the key.
    pub fn deserialize<T: serde::de::DeserializeOwned>(&self) -> Result<T, SpecError> {
        let json = crate::spec::yaml_to_json(&self.value).map_err(|m| SpecError::new(self.file(), "", m))?;
        crate::stage::deserialize_params(&json).map_err(|e| self.error(e.path.replace(".?", ""), e.message))
    }

    /// An error about `key_path` of the merged document, placed in the file that wrote the
    /// deepest part of the path (the extending file when both wrote it).
    pub fn error(&self, key_path: impl Into<String>, message: impl Into<String>) -> SpecError {
        let key_path = key_path.into();
        let message = message.into();
        // serde names an unknown key in its message, not its path: look that key up.
        let lookup = match unknown_field(&message) {
            Some(field) if key_path.is_empty() => field.to_string(),
            Some(field) => format!("{key_path}.{field}"),
            None => key_path.clone(),
        };
        let segments = segments(&lookup);
        let layer = (1..=segments.len())
            .rev()
            .find_map(|depth| self.layers.iter().find(|l| has_path(&l.own, &segments[..depth])))
            .unwrap_or(&self.layers[0]);
        let mut error = SpecError::new(&layer.file, key_path.as_str(), message);
        if let Some((line, column)) = crate::locate::locate_path(&layer.source, &lookup) {
            error.line = Some(line);
            error.column = Some(column);
        }
        error
    }
}

/// `unknown field `x`, expected …` → `x`.
fn unknown_field(message: &str) -> Option<&str> {
    let rest = message.strip_prefix("unknown field `")?;
    rest.split_once('`').map(|(field, _)| field)
}

/// One step of a key path: a mapping key or a list index.
#[derive(Debug, PartialEq)]
enum Step<'a> {
    Key(&'a str),
    Index(usize),
}

/// `train.ignitions[2].x` (or `train.ignitions.2.x`) → keys and indices.
fn segments(key_path: &str) -> Vec<Step<'_>> {
    let mut out = Vec::new();
    for part in key_path.split('.').filter(|s| !s.is_empty()) {
        let (key, mut rest) = part.split_at(part.find('[').unwrap_or(part.len()));
        if !key.is_empty() {
            out.push(match key.parse::<usize>() {
                Ok(i) => Step::Index(i),
                Err(_) => Step::Key(key),
            });
        }
        while let Some(inner) = rest.strip_prefix('[') {
            let Some(end) = inner.find(']') else { break };
            if let Ok(i) = inner[..end].parse::<usize>() {
                out.push(Step::Index(i));
            }
            rest = &inner[end + 1..];
        }
    }
    out
}

/// Whether `value` holds the mapping keys and list indices of `steps`.
fn has_path(value: &Value, steps: &[Step<'_>]) -> bool {
    let mut node = value;
    for step in steps {
        let child = match (node, step) {
            (Value::Mapping(map), Step::Key(key)) => map.get(*key),
            (Value::Sequence(items), Step::Index(i)) => items.get(*i),
            _ => None,
        };
        match child {
            Some(child) => node = child,
            None => return false,
        }
    }
    true
}

/// `a/b/../c.yaml` → `a/c.yaml`, without touching the file system (the files may be
/// relative to a root that is not the working directory).
fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir if matches!(out.components().next_back(), Some(Component::Normal(_))) => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn project(files: &[(&str, &str)]) -> tempfile::TempDir {
        let dir = tempfile::tempdir().expect("a temporary folder");
        for (name, text) in files {
            let path = dir.path().join(name);
            std::fs::create_dir_all(path.parent().expect("a parent")).expect("a folder");
            std::fs::write(path, text).expect("a file");
        }
        dir
    }

    #[test]
    fn an_extending_file_changes_only_what_it_names() {
        let dir = project(&[
            (
                "rl/base.yaml",
                "name: base\nppo:\n  preset: paper\n  gamma: 0.9\nseeds: [0, 1]\n",
            ),
            (
                "rl/ablations/a.yaml",
                "extends: ../base.yaml\nname: a\nppo:\n  gamma: 0.99\nseeds: [3]\n",
            ),
        ]);
        let layered = load(dir.path(), Path::new("rl/ablations/a.yaml")).expect("loads");
        let expected: Value =
            serde_yaml_ng::from_str("name: a\nppo: {preset: paper, gamma: 0.99}\nseeds: [3]\n")
                .expect("yaml");
        assert_eq!(layered.value, expected);
        assert_eq!(
            layered.bases().collect::<Vec<_>>(),
            vec![Path::new("rl/base.yaml")]
        );
    }

    #[test]
    fn errors_name_the_file_and_line_that_wrote_the_key() {
        #[derive(Debug, serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct Spec {
            name: String,
            ppo: Ppo,
        }
        #[derive(Debug, serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct Ppo {
            gamma: f64,
        }
        let dir = project(&[
            ("base.yaml", "name: base\nppo:\n  gamma: 0.9\n"),
            (
                "child.yaml",
                "extends: base.yaml\nname: child\nppo:\n  gamma: oops\n",
            ),
        ]);
        let layered = load(dir.path(), Path::new("child.yaml")).expect("loads");
        let error = layered.deserialize::<Spec>().expect_err("a bad gamma");
        assert_eq!(error.file, Path::new("child.yaml"));
        assert_eq!(error.line, Some(4), "{error}");
        // The unknown key is the base's: the base is named.
        std::fs::write(
            dir.path().join("base.yaml"),
            "name: base\nppo:\n  gamma: 0.9\n  gama: 1\n",
        )
        .expect("write");
        std::fs::write(dir.path().join("child.yaml"), "extends: base.yaml\nname: child\n").expect("write");
        let layered = load(dir.path(), Path::new("child.yaml")).expect("loads");
        let error = layered.deserialize::<Spec>().expect_err("an unknown key");
        assert_eq!(error.file, Path::new("base.yaml"), "{error}");
        assert_eq!(error.line, Some(4), "{error}");
    }

    #[test]
    fn key_paths_split_into_keys_and_indices() {
        assert_eq!(
            segments("train.ignitions[2].x"),
            vec![
                Step::Key("train"),
                Step::Key("ignitions"),
                Step::Index(2),
                Step::Key("x")
            ]
        );
        assert_eq!(segments("models.3"), vec![Step::Key("models"), Step::Index(3)]);
        assert_eq!(segments(""), vec![]);
    }

    #[test]
    fn circles_and_missing_bases_are_named() {
        let dir = project(&[
            ("a.yaml", "extends: b.yaml\nname: a\n"),
            ("b.yaml", "extends: ./a.yaml\nname: b\n"),
            ("c.yaml", "name: c\nextends: gone.yaml\n"),
        ]);
        let error = load(dir.path(), Path::new("a.yaml")).expect_err("a circle");
        assert!(error.to_string().contains("a.yaml → b.yaml → a.yaml"), "{error}");
        let error = load(dir.path(), Path::new("c.yaml")).expect_err("a missing base");
        assert_eq!(error.file, Path::new("c.yaml"));
        assert_eq!(error.line, Some(2), "{error}");
        assert!(error.to_string().contains("gone.yaml"), "{error}");
    }
}
