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

/// 1-based (line, column) of a dotted key path whose segments may index a sequence
/// (`models[3].kind`), in block-style YAML: the deepest part found (inside a flow item such as
/// `- {kind: x}`, the item's line).
pub fn locate_path(source: &str, dotted: &str) -> Option<(usize, usize)> {
    let lines: Vec<&str> = source.lines().collect();
    let content = |i: usize| {
        let raw = lines[i];
        let t = raw.trim_start();
        (!t.is_empty() && !t.starts_with('#')).then(|| (raw.len() - t.len(), t))
    };
    let mut best = None;
    // Search lines from `start`, inside the block deeper than `parent` (the line `start`
    // itself may sit at `parent` when it is a sequence item holding the key after its dash).
    let (mut start, mut parent): (usize, Option<usize>) = (0, None);
    for segment in dotted.split('.') {
        let (key, index) = match segment.find('[') {
            Some(b) => (
                &segment[..b],
                segment[b + 1..].trim_end_matches(']').parse::<usize>().ok(),
            ),
            None => (segment, None),
        };
        let mut found = None;
        for i in start..lines.len() {
            let Some((mut indent, mut body)) = content(i) else {
                continue;
            };
            if parent.is_some_and(|p| indent <= p) && !(i == start && body.starts_with("- ")) {
                break;
            }
            while let Some(rest) = body.strip_prefix("- ") {
                indent += 2;
                body = rest.trim_start();
            }
            if mapping_key(body) == Some(key) {
                found = Some((i, indent));
                break;
            }
        }
        let Some((line, indent)) = found else { break };
        best = Some((line + 1, indent + 1));
        (start, parent) = (line + 1, Some(indent));
        let Some(n) = index else { continue };
        // The n-th item of the sequence under the key (block sequences may sit at the key's
        // own indentation).
        let (mut count, mut item_indent, mut item) = (0, None, None);
        for i in start..lines.len() {
            let Some((ind, body)) = content(i) else { continue };
            if ind < indent || (ind == indent && !body.starts_with('-')) {
                break;
            }
            if !body.starts_with('-') || item_indent.is_some_and(|ii| ind != ii) {
                continue;
            }
            item_indent = Some(ind);
            if count == n {
                item = Some((i, ind));
                break;
            }
            count += 1;
        }
        let Some((line, ind)) = item else { break };
        best = Some((line + 1, ind + 1));
        (start, parent) = (line, Some(ind));
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
    use super::{locate_key, locate_path};

    #[test]
    fn finds_keys_inside_sequence_items() {
        let source = "name: t\nmodels:\n  - {kind: a}\n  - kind: b\n    params:\n      depth: 3\n  - {kind: c}\nseeds: [0]\n";
        assert_eq!(locate_path(source, "models[0].kind"), Some((3, 3)));
        assert_eq!(locate_path(source, "models[1].kind"), Some((4, 5)));
        assert_eq!(locate_path(source, "models[1].params.depth"), Some((6, 7)));
        assert_eq!(locate_path(source, "models[2].kind"), Some((7, 3)));
        assert_eq!(locate_path(source, "seeds"), Some((8, 1)));
        // An index past the end stops at the sequence's key.
        assert_eq!(locate_path(source, "models[5].kind"), Some((2, 1)));
        let unindented = "models:\n- {kind: a}\n- {kind: b}\nname: x\n";
        assert_eq!(locate_path(unindented, "models[1].kind"), Some((3, 1)));
    }

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
