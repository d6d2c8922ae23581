//! Every section reference in the code can be checked from a clone: each section sign (U+00A7)
//! in `crates/`, `src/`, `tests/`, `xtask/`, `experiments/`, `pipelines/` and ARCHITECTURE.md
//! follows, on the same line, the path of a Markdown file of the repository
//! (`docs/spec/fire-model.md <sign>A6.4`, `docs/spec/data.md <sign>4.2–4.5`,
//! `docs/spec/fire-model.md <sign>A6–<sign>A9`), and the section id is a heading of that file
//! (`### <sign>A6.4 Neighbourhood`). A specification page named without its folder
//! (the file name of a page in `docs/spec/` alone) fails too.
//!
//! In Rust files only comments are read (string literals may hold the sign for other reasons);
//! every other text file is read whole. Standards outside the repository are cited without the
//! sign ("RFC 6455, section 7.4.1").

use std::collections::{BTreeSet, HashMap, HashSet};
use std::fs;
use std::path::{Path, PathBuf};

/// The section sign, written as an escape so this file holds no reference of its own.
const SECTION: char = '\u{a7}';
/// What is scanned, relative to the repository root.
const SCANNED: [&str; 7] = [
    "crates",
    "src",
    "tests",
    "xtask",
    "experiments",
    "pipelines",
    "ARCHITECTURE.md",
];
/// Folders never scanned: build outputs and tool caches (hidden folders are skipped too).
const SKIPPED_DIRS: [&str; 4] = ["target", "node_modules", "__pycache__", "venv"];
/// Where the specification pages live.
const SPEC_DIR: &str = "docs/spec";

fn repo_root() -> PathBuf {
    PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()))
}

/// One section reference found in a scanned file.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Reference {
    /// The Markdown path written before the sign on the same line, if any.
    file: Option<String>,
    /// The section id after the sign (`A6.4`, `2.3`); empty when nothing follows the sign.
    id: String,
}

fn is_path_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '/' | '-')
}

fn is_id_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '.'
}

/// The section id that starts at `rest`: letters, digits and dots, without a trailing dot.
fn section_id(rest: &str) -> String {
    let id: String = rest.chars().take_while(|&c| is_id_char(c)).collect();
    id.trim_end_matches('.').to_string()
}

/// The path-like words of `text` (runs of letters, digits, `_ . / -`), in order.
fn words(text: &str) -> impl Iterator<Item = &str> {
    text.split(|c: char| !is_path_char(c)).filter(|w| !w.is_empty())
}

/// The references of one line: for each sign, the last Markdown path before it on the line.
fn references_in_line(line: &str) -> Vec<Reference> {
    line.match_indices(SECTION)
        .map(|(at, sign)| {
            let before = &line[..at];
            let file = words(before)
                .filter(|w| w.ends_with(".md"))
                .last()
                .map(|w| w.trim_end_matches('/').to_string());
            Reference {
                file,
                id: section_id(&line[at + sign.len()..]),
            }
        })
        .collect()
}

/// `src` with everything that is not a comment blanked (newlines kept), so that line numbers
/// and the order of words within a comment stay as they are. A small Rust lexer: line and
/// nested block comments, strings with escapes, raw strings, char literals and lifetimes.
fn rust_comments(src: &str) -> String {
    enum State {
        Code,
        Line,
        Block(u32),
        Str,
        Raw(usize),
    }
    let chars: Vec<char> = src.chars().collect();
    let ident = |c: Option<&char>| c.is_some_and(|c| c.is_alphanumeric() || *c == '_');
    let mut out = String::with_capacity(src.len());
    let mut state = State::Code;
    let mut i = 0;
    // Pushes `n` source characters starting at `i`, as themselves or as blanks.
    let emit = |out: &mut String, from: usize, n: usize, keep: bool| {
        for &c in &chars[from..(from + n).min(chars.len())] {
            out.push(if keep || c == '\n' { c } else { ' ' });
        }
    };
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        match state {
            State::Code => {
                if c == '/' && next == Some('/') {
                    emit(&mut out, i, 2, false);
                    i += 2;
                    state = State::Line;
                } else if c == '/' && next == Some('*') {
                    emit(&mut out, i, 2, false);
                    i += 2;
                    state = State::Block(1);
                } else if c == '"' {
                    emit(&mut out, i, 1, false);
                    i += 1;
                    state = State::Str;
                } else if c == 'r'
                    && (!ident(i.checked_sub(1).and_then(|p| chars.get(p)))
                        || (i >= 1
                            && chars[i - 1] == 'b'
                            && !ident(i.checked_sub(2).and_then(|p| chars.get(p)))))
                    && {
                        let hashes = chars[i + 1..].iter().take_while(|&&h| h == '#').count();
                        chars.get(i + 1 + hashes) == Some(&'"')
                    }
                {
                    let hashes = chars[i + 1..].iter().take_while(|&&h| h == '#').count();
                    emit(&mut out, i, hashes + 2, false);
                    i += hashes + 2;
                    state = State::Raw(hashes);
                } else if c == '\'' {
                    // A char literal ('x', '\n', '\u{a7}') or a lifetime ('a).
                    let len = if next == Some('\\') {
                        chars
                            .get(i + 3..)
                            .and_then(|rest| rest.iter().position(|&q| q == '\''))
                            .map_or(1, |p| p + 4)
                    } else if chars.get(i + 2) == Some(&'\'') {
                        3
                    } else {
                        1
                    };
                    emit(&mut out, i, len, false);
                    i += len;
                } else {
                    emit(&mut out, i, 1, false);
                    i += 1;
                }
            }
            State::Line => {
                if c == '\n' {
                    state = State::Code;
                }
                emit(&mut out, i, 1, true);
                i += 1;
            }
            State::Block(depth) => {
                if c == '*' && next == Some('/') {
                    emit(&mut out, i, 2, false);
                    i += 2;
                    state = if depth == 1 {
                        State::Code
                    } else {
                        State::Block(depth - 1)
                    };
                } else if c == '/' && next == Some('*') {
                    emit(&mut out, i, 2, false);
                    i += 2;
                    state = State::Block(depth + 1);
                } else {
                    emit(&mut out, i, 1, true);
                    i += 1;
                }
            }
            State::Str => {
                let len = if c == '\\' { 2 } else { 1 };
                if c == '"' {
                    state = State::Code;
                }
                emit(&mut out, i, len, false);
                i += len;
            }
            State::Raw(hashes) => {
                let closes =
                    c == '"' && chars[i + 1..].iter().take(hashes).filter(|&&h| h == '#').count() == hashes;
                if closes {
                    emit(&mut out, i, hashes + 1, false);
                    i += hashes + 1;
                    state = State::Code;
                } else {
                    emit(&mut out, i, 1, false);
                    i += 1;
                }
            }
        }
    }
    out
}

/// The text of a scanned file in which references count: comments for Rust, all of it else.
fn referencing_text(path: &Path, text: &str) -> String {
    if path.extension().is_some_and(|ext| ext == "rs") {
        rust_comments(text)
    } else {
        text.to_string()
    }
}

/// Every scanned file under `rel` (a file or folder relative to `root`), sorted.
fn collect(root: &Path, rel: &Path, out: &mut Vec<PathBuf>) {
    let full = root.join(rel);
    if full.is_file() {
        out.push(rel.to_path_buf());
        return;
    }
    if !full.is_dir() {
        return;
    }
    let mut entries: Vec<_> = fs::read_dir(&full)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", rel.display()))
        .map(|entry| entry.unwrap_or_else(|e| panic!("cannot list {}: {e}", rel.display())))
        .collect();
    entries.sort_by_key(|entry| entry.file_name());
    for entry in entries {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let kind = entry
            .file_type()
            .unwrap_or_else(|e| panic!("cannot stat {name}: {e}"));
        if kind.is_dir() {
            if !name.starts_with('.') && !SKIPPED_DIRS.contains(&&*name) {
                collect(root, &rel.join(&*name), out);
            }
        } else if kind.is_file() {
            out.push(rel.join(&*name));
        }
    }
}

/// The section ids of a Markdown file: the id after the first sign of each heading (a line
/// starting with `#`, outside fenced code blocks).
fn heading_ids(text: &str) -> BTreeSet<String> {
    let mut ids = BTreeSet::new();
    let mut fenced = false;
    for line in text.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("```") || trimmed.starts_with("~~~") {
            fenced = !fenced;
            continue;
        }
        if fenced || !trimmed.starts_with('#') {
            continue;
        }
        if let Some(at) = trimmed.find(SECTION) {
            let id = section_id(&trimmed[at + SECTION.len_utf8()..]);
            if !id.is_empty() {
                ids.insert(id);
            }
        }
    }
    ids
}

/// The file names of the specification pages in `docs/spec/` (its README aside).
fn spec_page_names(root: &Path) -> Vec<String> {
    let dir = root.join(SPEC_DIR);
    let mut names: Vec<String> = fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot list {SPEC_DIR}: {e}"))
        .map(|entry| {
            entry
                .unwrap_or_else(|e| panic!("cannot list {SPEC_DIR}: {e}"))
                .file_name()
        })
        .map(|name| name.to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".md") && name != "README.md")
        .collect();
    names.sort();
    names
}

/// Every problem of the scanned files under `root`, as `path:line: message`.
fn problems(root: &Path, scanned: &[&str]) -> Vec<String> {
    let mut files = Vec::new();
    for rel in scanned {
        collect(root, Path::new(rel), &mut files);
    }
    let pages = spec_page_names(root);
    let mut headings: HashMap<String, Option<BTreeSet<String>>> = HashMap::new();
    let mut problems = Vec::new();
    for rel in &files {
        let Ok(bytes) = fs::read(root.join(rel)) else {
            continue;
        };
        // Binary files and files in other encodings hold no references.
        let Ok(text) = String::from_utf8(bytes) else {
            continue;
        };
        if text.contains('\0') {
            continue;
        }
        let shown = rel.to_string_lossy().replace('\\', "/");
        let readable = referencing_text(rel, &text);
        for (n, line) in readable.lines().enumerate() {
            let at = format!("{shown}:{}", n + 1);
            for word in words(line) {
                let word = word.trim_end_matches('.');
                for page in &pages {
                    if word == page {
                        problems.push(format!(
                            "{at}: `{page}` without its path: write {SPEC_DIR}/{page}"
                        ));
                    } else if word.ends_with(&format!("/{page}")) && !root.join(word).is_file() {
                        problems.push(format!("{at}: `{word}` is not a file of the repository"));
                    }
                }
            }
            for reference in references_in_line(line) {
                let Some(file) = reference.file else {
                    problems.push(format!(
                        "{at}: {SECTION}{} names no file: write `<path from the repository root> \
                         {SECTION}<id>` (e.g. {SPEC_DIR}/fire-model.md {SECTION}A6.4), or `section N` \
                         for a standard outside the repository",
                        reference.id
                    ));
                    continue;
                };
                if reference.id.is_empty() {
                    problems.push(format!("{at}: `{file} {SECTION}` has no section id"));
                    continue;
                }
                let ids = headings.entry(file.clone()).or_insert_with(|| {
                    let target = root.join(&file);
                    target
                        .is_file()
                        .then(|| heading_ids(&fs::read_to_string(&target).unwrap_or_default()))
                });
                match ids {
                    None => problems.push(format!("{at}: `{file}` is not a file of the repository")),
                    Some(ids) if !ids.contains(&reference.id) => {
                        problems.push(format!("{at}: `{file}` has no heading {SECTION}{}", reference.id))
                    }
                    Some(_) => {}
                }
            }
        }
    }
    // A path can be reported twice on one line (as a page name and as a reference's file).
    let mut seen = HashSet::new();
    problems.retain(|problem| seen.insert(problem.clone()));
    problems
}

#[test]
fn every_section_reference_names_a_heading_of_a_repository_file() {
    let root = repo_root();
    let found = problems(&root, &SCANNED);
    assert!(
        found.is_empty(),
        "{} broken section reference(s):\n{}",
        found.len(),
        found.join("\n")
    );
}

/// `$` stands for the section sign in the samples below.
fn sample(text: &str) -> String {
    text.replace('$', &SECTION.to_string())
}

fn reference(file: Option<&str>, id: &str) -> Reference {
    Reference {
        file: file.map(str::to_string),
        id: id.to_string(),
    }
}

#[test]
fn references_are_read_with_the_last_path_before_the_sign() {
    let fm = Some("docs/spec/fire-model.md");
    assert_eq!(
        references_in_line(&sample("(docs/spec/fire-model.md $A6–$A9), driven by")),
        [reference(fm, "A6"), reference(fm, "A9")]
    );
    assert_eq!(
        references_in_line(&sample("scripts do (docs/spec/data.md $4.2–4.5): one")),
        [reference(Some("docs/spec/data.md"), "4.2")]
    );
    assert_eq!(
        references_in_line(&sample("aggregates of docs/spec/fire-model.md $B2/$B4.")),
        [reference(fm, "B2"), reference(fm, "B4")]
    );
    assert_eq!(
        references_in_line(&sample(
            "`docs/spec/fire-model.md` $A5, then docs/spec/data.md $9."
        )),
        [reference(fm, "A5"), reference(Some("docs/spec/data.md"), "9")]
    );
    assert_eq!(
        references_in_line(&sample("(RFC 6455 $7.4.1)")),
        [reference(None, "7.4.1")]
    );
    assert_eq!(
        references_in_line(&sample("the paper's agent, $4).")),
        [reference(None, "4")]
    );
}

#[test]
fn only_rust_comments_are_read() {
    let src = sample(
        "let a = \"$A1\"; // docs/spec/x.md $B2\nlet c = '\"'; let r = r#\"$C3 \"# ; /* $D4 */\n\
         fn f<'a>(s: &'a str) {} /// doc $E5\n",
    );
    let lines: Vec<Vec<Reference>> = rust_comments(&src).lines().map(references_in_line).collect();
    assert_eq!(lines[0], [reference(Some("docs/spec/x.md"), "B2")]);
    assert_eq!(lines[1], [reference(None, "D4")]);
    assert_eq!(lines[2], [reference(None, "E5")]);
}

#[test]
fn headings_carry_the_ids() {
    let ids = heading_ids(&sample(
        "# Title\n## $A6 The automaton\n### $A6.4 Neighbourhood\ntext $A7\n```\n# $X1\n```\n",
    ));
    assert_eq!(ids.into_iter().collect::<Vec<_>>(), ["A6", "A6.4"]);
}
