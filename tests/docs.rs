//! The documentation holds together: every relative Markdown link in README.md,
//! ARCHITECTURE.md, experiments/README.md and the book (`docs/**/*.md`) names a file or folder
//! of the repository, every `#anchor` names a heading of its Markdown target (GitHub's slug
//! rule), and README.md stays short. Links to the web (`http:`, `https:`, `mailto:`, …) and
//! anything inside code (fenced blocks, inline code spans) are not checked.

use std::collections::HashMap;
use std::fs;
use std::path::{Component, Path, PathBuf};

/// The README is the first screen; everything longer belongs in the book.
const README_MAX_LINES: usize = 300;

fn repo_root() -> PathBuf {
    PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()))
}

/// The Markdown files whose links are checked, relative to `root`, in a stable order.
fn checked_files(root: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = ["README.md", "ARCHITECTURE.md", "experiments/README.md"]
        .iter()
        .map(PathBuf::from)
        .collect();
    let mut book = Vec::new();
    collect_markdown(root, Path::new("docs"), &mut book);
    book.sort();
    files.extend(book);
    files
}

fn collect_markdown(root: &Path, dir: &Path, out: &mut Vec<PathBuf>) {
    let entries =
        fs::read_dir(root.join(dir)).unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()));
    for entry in entries {
        let entry = entry.unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()));
        let rel = dir.join(entry.file_name());
        let kind = entry
            .file_type()
            .unwrap_or_else(|e| panic!("cannot stat {}: {e}", rel.display()));
        if kind.is_dir() {
            collect_markdown(root, &rel, out);
        } else if rel.extension().is_some_and(|ext| ext == "md") {
            out.push(rel);
        }
    }
}

/// `text` with the lines of fenced code blocks (``` or ~~~) emptied; line numbers are kept.
fn without_fences(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut fence: Option<(char, usize)> = None;
    for line in text.split('\n') {
        let trimmed = line.trim_start();
        let run = |c: char| trimmed.chars().take_while(|&x| x == c).count();
        match fence {
            Some((c, n)) => {
                let t = trimmed.trim_end();
                if run(c) >= n && t.chars().all(|x| x == c) {
                    fence = None;
                }
            }
            None => {
                let (ticks, tildes) = (run('`'), run('~'));
                if ticks >= 3 {
                    fence = Some(('`', ticks));
                } else if tildes >= 3 {
                    fence = Some(('~', tildes));
                } else {
                    out.push_str(line);
                }
            }
        }
        out.push('\n');
    }
    out
}

/// `text` with inline code spans blanked (line breaks kept): a run of n backticks up to the
/// next run of exactly n backticks within the same paragraph.
fn without_code_spans(text: &str) -> String {
    let mut chars: Vec<char> = text.chars().collect();
    let run_at = |chars: &[char], i: usize| chars[i..].iter().take_while(|&&c| c == '`').count();
    let mut i = 0;
    while i < chars.len() {
        if chars[i] != '`' {
            i += 1;
            continue;
        }
        let n = run_at(&chars, i);
        let mut j = i + n;
        let mut close = None;
        while j < chars.len() {
            if chars[j] == '`' {
                let m = run_at(&chars, j);
                if m == n {
                    close = Some(j);
                    break;
                }
                j += m;
            } else if chars[j] == '\n' && paragraph_ends_after(&chars, j) {
                break;
            } else {
                j += 1;
            }
        }
        match close {
            Some(j) => {
                for c in &mut chars[i..j + n] {
                    if *c != '\n' {
                        *c = ' ';
                    }
                }
                i = j + n;
            }
            None => i += n,
        }
    }
    chars.into_iter().collect()
}

/// Whether the line after the line break at `i` is blank (a paragraph ends there).
fn paragraph_ends_after(chars: &[char], i: usize) -> bool {
    chars[i + 1..]
        .iter()
        .take_while(|&&c| c != '\n')
        .all(|c| c.is_whitespace())
}

/// A link target and the (1-based) line it is on.
#[derive(Debug, PartialEq)]
struct Link {
    line: usize,
    target: String,
}

/// The targets of inline links and images (`[text](target "title")`) and of reference
/// definitions (`[label]: target`), outside code.
fn links(text: &str) -> Vec<Link> {
    let masked = without_code_spans(&without_fences(text));
    let mut found = Vec::new();
    let mut previous_blank = true;
    for (n, line) in masked.split('\n').enumerate() {
        let chars: Vec<char> = line.chars().collect();
        let mut i = 0;
        while i + 1 < chars.len() {
            if chars[i] == ']' && chars[i + 1] == '(' {
                let target = inline_target(&chars[i + 2..]);
                if !target.is_empty() {
                    found.push(Link { line: n + 1, target });
                }
                i += 2;
            } else {
                i += 1;
            }
        }
        // A reference definition starts a paragraph; it cannot continue one.
        let trimmed = line.trim_start();
        let starts_paragraph = std::mem::replace(&mut previous_blank, trimmed.is_empty());
        if starts_paragraph
            && trimmed.starts_with('[')
            && let Some(end) = trimmed.find("]:")
        {
            let rest = trimmed[end + 2..].trim();
            let target = rest.split_whitespace().next().unwrap_or("");
            let target = target.trim_start_matches('<').trim_end_matches('>');
            if !target.is_empty() {
                found.push(Link {
                    line: n + 1,
                    target: target.to_string(),
                });
            }
        }
    }
    found
}

/// The destination of an inline link, from the character after `](`.
fn inline_target(rest: &[char]) -> String {
    if rest.first() == Some(&'<') {
        return rest[1..].iter().take_while(|&&c| c != '>').collect();
    }
    let mut depth = 0usize;
    let mut target = String::new();
    for &c in rest {
        match c {
            '(' => depth += 1,
            ')' if depth == 0 => break,
            ')' => depth -= 1,
            c if c.is_whitespace() => break,
            _ => {}
        }
        target.push(c);
    }
    target
}

/// GitHub's anchor for a heading: its text as rendered (link targets, code and emphasis marks
/// dropped), lowercased, with every character other than letters, digits, `-` and `_` removed
/// and each space turned into `-`.
fn slug(heading: &str) -> String {
    let chars: Vec<char> = heading.chars().collect();
    let mut text = String::new();
    let mut i = 0;
    while i < chars.len() {
        if chars[i] == ']' && chars.get(i + 1) == Some(&'(') {
            let target = inline_target(&chars[i + 2..]);
            i += 2 + target.chars().count();
            // Skip a title, if any, up to the link's closing parenthesis.
            while i < chars.len() && chars[i] != ')' {
                i += 1;
            }
            i += 1;
            continue;
        }
        text.push(chars[i]);
        i += 1;
    }
    let mut slug = String::new();
    for c in text.trim().chars() {
        if c == ' ' {
            slug.push('-');
        } else if c.is_alphanumeric() || c == '-' || c == '_' {
            slug.extend(c.to_lowercase());
        }
    }
    slug
}

/// The anchors of a Markdown file: its ATX headings' slugs (a repeated slug gets `-1`, `-2`, …
/// as on GitHub) and explicit HTML `id="…"` / `name="…"` anchors.
fn anchors(text: &str) -> Vec<String> {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut anchors = Vec::new();
    for line in without_fences(text).split('\n') {
        let indent = line.len() - line.trim_start_matches(' ').len();
        let trimmed = line.trim_start_matches(' ');
        let level = trimmed.chars().take_while(|&c| c == '#').count();
        let after = &trimmed[level..];
        if indent <= 3 && (1..=6).contains(&level) && (after.is_empty() || after.starts_with([' ', '\t'])) {
            let title = after.trim().trim_end_matches('#').trim_end();
            let base = slug(title);
            let count = seen.entry(base.clone()).or_insert(0);
            anchors.push(if *count == 0 {
                base
            } else {
                format!("{base}-{count}")
            });
            *count += 1;
        }
        for attr in ["id=\"", "name=\""] {
            let mut rest = line;
            while let Some(start) = rest.find(attr) {
                rest = &rest[start + attr.len()..];
                if let Some(end) = rest.find('"') {
                    anchors.push(rest[..end].to_string());
                    rest = &rest[end..];
                }
            }
        }
    }
    anchors
}

/// `%xx` escapes decoded (link destinations may escape spaces and the like).
fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let (Some(hi), Some(lo)) = (hex(bytes[i + 1]), hex(bytes[i + 2]))
        {
            out.push((hi * 16 + lo) as u8);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Whether a link leaves the repository (a URL scheme such as `https:` or `mailto:`).
fn is_external(target: &str) -> bool {
    let head = target.split(['/', '#', '?']).next().unwrap_or("");
    head.contains(':')
}

/// `base` joined with `rel` and normalised lexically, or `None` when it climbs out of the
/// repository.
fn resolve(base: &Path, rel: &str) -> Option<PathBuf> {
    let mut parts: Vec<String> = Vec::new();
    let start = if rel.starts_with('/') {
        PathBuf::new()
    } else {
        base.to_path_buf()
    };
    for component in start.join(rel.trim_start_matches('/')).components() {
        match component {
            Component::Normal(p) => parts.push(p.to_string_lossy().into_owned()),
            Component::ParentDir => {
                parts.pop()?;
            }
            Component::CurDir => {}
            Component::RootDir | Component::Prefix(_) => return None,
        }
    }
    Some(parts.iter().collect())
}

/// Every broken link of `files` (relative to `root`), as `file:line: link `target`: problem`.
fn broken_links(root: &Path, files: &[PathBuf]) -> Vec<String> {
    let mut anchor_cache: HashMap<PathBuf, Vec<String>> = HashMap::new();
    let mut problems = Vec::new();
    for file in files {
        let text = fs::read_to_string(root.join(file))
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", file.display()));
        let dir = file.parent().unwrap_or(Path::new(""));
        for link in links(&text) {
            if is_external(&link.target) {
                continue;
            }
            let mut report = |problem: String| {
                problems.push(format!(
                    "{}:{}: link `{}`: {problem}",
                    file.display(),
                    link.line,
                    link.target
                ));
            };
            let (path, anchor) = match link.target.split_once('#') {
                Some((path, anchor)) => (path, Some(percent_decode(anchor))),
                None => (link.target.as_str(), None),
            };
            let path = percent_decode(path.split('?').next().unwrap_or(""));
            let target = if path.is_empty() {
                file.clone()
            } else {
                match resolve(dir, &path) {
                    Some(target) => target,
                    None => {
                        report("climbs out of the repository".to_string());
                        continue;
                    }
                }
            };
            if !root.join(&target).exists() {
                report(format!("{} does not exist", target.display()));
                continue;
            }
            let Some(anchor) = anchor else { continue };
            if target.extension().is_none_or(|ext| ext != "md") {
                continue; // line anchors of source files (`#L10`) are GitHub's, not headings
            }
            let known = anchor_cache.entry(target.clone()).or_insert_with(|| {
                let text = fs::read_to_string(root.join(&target))
                    .unwrap_or_else(|e| panic!("cannot read {}: {e}", target.display()));
                anchors(&text)
            });
            if !known.contains(&anchor) {
                report(format!(
                    "{} has no heading with the anchor #{anchor}",
                    target.display()
                ));
            }
        }
    }
    problems
}

#[test]
fn every_relative_link_resolves() {
    let root = repo_root();
    let files = checked_files(&root);
    assert!(
        files.iter().any(|f| f.starts_with("docs")),
        "no Markdown file found under docs/"
    );
    let problems = broken_links(&root, &files);
    assert!(
        problems.is_empty(),
        "{} broken link(s) in the documentation:\n{}",
        problems.len(),
        problems.join("\n")
    );
}

#[test]
fn readme_is_short() {
    let text = fs::read_to_string(repo_root().join("README.md")).expect("README.md is readable");
    let lines = text.lines().count();
    assert!(
        lines <= README_MAX_LINES,
        "README.md has {lines} lines; at most {README_MAX_LINES}: move the rest into the book under docs/"
    );
}

#[test]
fn slugs_follow_githubs_rule() {
    assert_eq!(slug("Two commands"), "two-commands");
    assert_eq!(
        slug("The demo's PPO helitack agent"),
        "the-demos-ppo-helitack-agent"
    );
    assert_eq!(
        slug("On the paper's 240 × 160 fires"),
        "on-the-papers-240--160-fires"
    );
    assert_eq!(
        slug("Why (c)'s updates were slower than SB3's, and the fix"),
        "why-cs-updates-were-slower-than-sb3s-and-the-fix"
    );
    assert_eq!(
        slug("§A6.3 Update rule: `updateFire(time)`"),
        "a63-update-rule-updatefiretime"
    );
    assert_eq!(slug("See [the guide](guides/rl.md) now"), "see-the-guide-now");
    assert_eq!(slug("snake_case and *emphasis*"), "snake_case-and-emphasis");
}

#[test]
fn links_outside_code_are_found() {
    let text = "See [a](a.md) and ![b](img/b.png \"title\").\n\
                `[not](code.md)` and [c](<c d.md>)\n\
                ```sh\n[fenced](no.md)\n```\n\
                \n[label]: ref.md#x\n\nsome text\n[0.5, 0.7]: not a definition\n";
    let found = links(text);
    let targets: Vec<(usize, &str)> = found.iter().map(|l| (l.line, l.target.as_str())).collect();
    assert_eq!(
        targets,
        vec![(1, "a.md"), (1, "img/b.png"), (2, "c d.md"), (7, "ref.md#x")]
    );
}

#[test]
fn duplicate_headings_are_numbered_and_fenced_hashes_ignored() {
    let text = "# Notes\n## Run\n```sh\n# not a heading\n```\n## Run\n<a id=\"here\"></a>\n";
    assert_eq!(anchors(text), vec!["notes", "run", "run-1", "here"]);
}

/// The checker itself fails on a missing file, a missing heading and a link out of the
/// repository, naming the file, the line and the link.
#[test]
fn broken_links_are_reported_with_file_and_line() {
    let root = std::env::temp_dir().join(format!("firecast-docs-test-{}", std::process::id()));
    let docs = root.join("docs");
    fs::create_dir_all(&docs).expect("create a temporary docs folder");
    fs::write(docs.join("b.md"), "# B\n## Real heading\n").expect("write b.md");
    fs::write(
        docs.join("a.md"),
        "# A\n[ok](b.md#real-heading) [web](https://example.org/x#y) [self](#a)\n\
         [gone](missing.md)\n[bad anchor](b.md#no-such-heading)\n[out](../../x.md)\n",
    )
    .expect("write a.md");
    let problems = broken_links(&root, &[PathBuf::from("docs/a.md"), PathBuf::from("docs/b.md")]);
    fs::remove_dir_all(&root).expect("remove the temporary folder");
    assert_eq!(
        problems,
        vec![
            "docs/a.md:3: link `missing.md`: docs/missing.md does not exist",
            "docs/a.md:4: link `b.md#no-such-heading`: docs/b.md has no heading with the anchor #no-such-heading",
            "docs/a.md:5: link `../../x.md`: climbs out of the repository",
        ]
    );
}
