//! Find the line of a key path in block-style YAML source.
//!
//! serde reports a location only for errors it raises while parsing; errors found
//! later (a params struct rejecting a key, a missing input, a cycle) know only the
//! key path. This scanner maps that path back to a line so every error can name one.
//! It understands block mappings (the style pipelines are written in); inside flow
//! collections it stops at the deepest key it could match.

/// 1-based (line, column) of the deepest key of `path` found in `source`.
pub fn locate_key(source: &str, path: &[&str]) -> Option<(usize, usize)> {
    let mut best = None;
    // Indentation of each matched key, one entry per matched segment.
    let mut matched_indents: Vec<usize> = Vec::new();
    for (index, raw_line) in source.lines().enumerate() {
        let trimmed = raw_line.trim_start();
        if trimmed.is_empty() || trimmed.starts_with('#') || trimmed.starts_with("---") {
            continue;
        }
        let mut indent = raw_line.len() - trimmed.len();
        // Leaving the block of the last matched key ends the search: keys are unique in a
        // mapping, so the next segment is not elsewhere (a key of the same name further down,
        // say a `windows:` input of another stage, must not match).
        if matched_indents.last().is_some_and(|&top| indent <= top) {
            break;
        }
        let depth = matched_indents.len();
        if depth >= path.len() {
            continue;
        }
        // `- key: value` opens a mapping inside a sequence item.
        let mut body = trimmed;
        while let Some(rest) = body.strip_prefix("- ") {
            indent += 2;
            body = rest.trim_start();
        }
        if let Some(key) = mapping_key(body)
            && key == path[depth]
        {
            matched_indents.push(indent);
            best = Some((index + 1, indent + 1));
        }
    }
    best
}

/// The key of a `key: value` or `key:` line, unquoted.
fn mapping_key(body: &str) -> Option<&str> {
    if let Some(rest) = body.strip_prefix('"') {
        let end = rest.find('"')?;
        return rest[end + 1..].starts_with(':').then(|| &rest[..end]);
    }
    if let Some(rest) = body.strip_prefix('\'') {
        let end = rest.find('\'')?;
        return rest[end + 1..].starts_with(':').then(|| &rest[..end]);
    }
    let colon = body.find(':')?;
    let after = &body[colon + 1..];
    if !(after.is_empty() || after.starts_with(' ') || after.starts_with('\t')) {
        return None;
    }
    let key = body[..colon].trim_end();
    (!key.is_empty() && !key.starts_with('{') && !key.starts_with('[')).then_some(key)
}

#[cfg(test)]
mod tests {
    use super::locate_key;

    const SOURCE: &str = "\
# comment
vars:
  seed: 3
stages:
  extract:
    uses: cmd
    params:
      command: echo hi
      params: nested
  train:
    uses: cmd
    params: {command: x}
";

    #[test]
    fn finds_nested_keys() {
        assert_eq!(locate_key(SOURCE, &["vars", "seed"]), Some((3, 3)));
        assert_eq!(
            locate_key(SOURCE, &["stages", "extract", "params", "command"]),
            Some((8, 7))
        );
        assert_eq!(locate_key(SOURCE, &["stages", "train", "uses"]), Some((11, 5)));
    }

    #[test]
    fn stops_at_deepest_match() {
        // `command` sits in a flow mapping: the best we can do is the `params` line.
        assert_eq!(
            locate_key(SOURCE, &["stages", "train", "params", "command"]),
            Some((12, 5))
        );
        assert_eq!(locate_key(SOURCE, &["stages", "missing"]), Some((4, 1)));
        assert_eq!(locate_key(SOURCE, &["nothing"]), None);
    }

    #[test]
    fn a_later_key_of_the_same_name_does_not_match() {
        // `windows` reappears as an input of the next stage.
        let source = "stages:\n  windows:\n    uses: data.windows\n    shards: 16\n  dataset:\n    inputs:\n      windows: {from: windows.windows}\n";
        assert_eq!(locate_key(source, &["stages", "windows", "shards"]), Some((4, 5)));
        assert_eq!(locate_key(source, &["stages", "windows", "params"]), Some((2, 3)));
    }
}
