//! The one way every bench finds the Python it runs its reference with: an explicit
//! `--python` first, then `$FIRECAST_VENV`, then the project's `<root>/.venv`; a peer that
//! needs its own packages (pyretechnics wants numpy 1.26) has its own venv under
//! `<root>/.venv-peers/<name>` instead. An error names every place searched.

use std::path::{Path, PathBuf};

/// Where `cargo xtask setup` installs the peers' venvs, relative to the project root.
pub const PEERS_DIR: &str = ".venv-peers";

/// Which venv a bench's reference runs in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Venv {
    /// The project's venv (`$FIRECAST_VENV`, else `<root>/.venv`).
    Project,
    /// A peer's own venv, `<root>/.venv-peers/<name>`.
    Peer(&'static str),
}

/// No Python where a bench looked for one.
#[derive(Debug, thiserror::Error)]
#[error(
    "no Python for the {}: searched {}; run `cargo xtask setup` (it installs {}), or pass --python",
    purpose(*.venv),
    searched.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "),
    installs(*.venv)
)]
pub struct PythonMissing {
    venv: Venv,
    /// The interpreters tried, in order.
    pub searched: Vec<PathBuf>,
}

fn purpose(venv: Venv) -> String {
    match venv {
        Venv::Project => "reference".into(),
        Venv::Peer(name) => format!("peer {name}"),
    }
}

fn installs(venv: Venv) -> String {
    match venv {
        Venv::Project => "the project's venv into .venv".into(),
        Venv::Peer(name) => format!("{name} into {PEERS_DIR}/{name}"),
    }
}

/// The Python of `venv`: `explicit` (a path that must exist, or a bare command name left to
/// `PATH`), else the venv's `bin/python`.
pub fn find_python(explicit: Option<&Path>, root: &Path, venv: Venv) -> Result<PathBuf, PythonMissing> {
    let mut searched = Vec::new();
    if let Some(p) = explicit {
        if p.is_file() || p.components().count() == 1 {
            return Ok(p.to_path_buf());
        }
        searched.push(p.to_path_buf());
        return Err(PythonMissing { venv, searched });
    }
    match venv {
        Venv::Project => {
            if let Some(dir) = std::env::var_os("FIRECAST_VENV") {
                searched.push(PathBuf::from(dir).join("bin/python"));
            }
            searched.push(root.join(".venv/bin/python"));
        }
        Venv::Peer(name) => searched.push(root.join(PEERS_DIR).join(name).join("bin/python")),
    }
    match searched.iter().find(|p| p.is_file()) {
        Some(p) => Ok(p.clone()),
        None => Err(PythonMissing { venv, searched }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_explicit_python_comes_first_and_a_missing_one_is_named() {
        let dir = tempfile::tempdir().expect("tempdir");
        let python = dir.path().join("python");
        std::fs::write(&python, "").expect("write");
        assert_eq!(
            find_python(Some(&python), dir.path(), Venv::Project).ok(),
            Some(python)
        );
        assert_eq!(
            find_python(Some(Path::new("python3")), dir.path(), Venv::Project).ok(),
            Some(PathBuf::from("python3"))
        );
        let missing = dir.path().join("no/python");
        let err = find_python(Some(&missing), dir.path(), Venv::Peer("pyretechnics"))
            .expect_err("missing")
            .to_string();
        assert!(err.contains(&missing.display().to_string()), "{err}");
        assert!(err.contains("cargo xtask setup"), "{err}");
    }

    #[test]
    fn a_peer_looks_only_in_its_own_venv() {
        let dir = tempfile::tempdir().expect("tempdir");
        let err = find_python(None, dir.path(), Venv::Peer("pyretechnics"))
            .expect_err("no venv")
            .to_string();
        assert!(err.contains(".venv-peers/pyretechnics/bin/python"), "{err}");
        assert!(!err.contains(".venv/bin"), "{err}");
        let python = dir.path().join(".venv-peers/pyretechnics/bin/python");
        std::fs::create_dir_all(python.parent().expect("parent")).expect("mkdir");
        std::fs::write(&python, "").expect("write");
        assert_eq!(
            find_python(None, dir.path(), Venv::Peer("pyretechnics")).ok(),
            Some(python)
        );
    }
}
