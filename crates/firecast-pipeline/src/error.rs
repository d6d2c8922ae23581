//! Errors of the pipeline engine.

use std::fmt;
use std::path::{Path, PathBuf};

/// A problem in a pipeline file, located by file, line and key path.
///
/// Displayed as `FILE:LINE:COLUMN: KEY.PATH: message` so editors can jump to it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SpecError {
    pub file: PathBuf,
    pub line: Option<usize>,
    pub column: Option<usize>,
    /// Dotted key path inside the YAML document, e.g. `stages.extract.params.lead_days`.
    pub key_path: String,
    pub message: String,
}

impl SpecError {
    pub fn new(file: &Path, key_path: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            file: file.to_path_buf(),
            line: None,
            column: None,
            key_path: key_path.into(),
            message: message.into(),
        }
    }

    /// Attach a location found by looking the key path up in the YAML source.
    pub fn located_in(mut self, source: &str) -> Self {
        if self.line.is_none() {
            let segments: Vec<&str> = split_key_path(&self.key_path);
            if let Some((line, column)) = crate::locate::locate_key(source, &segments) {
                self.line = Some(line);
                self.column = Some(column);
            }
        }
        self
    }
}

/// Split a key path on dots, keeping `[..]` index segments attached as their own segment.
pub(crate) fn split_key_path(path: &str) -> Vec<&str> {
    path.split('.').filter(|s| !s.is_empty()).collect()
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
            if let Some(column) = self.column {
                write!(f, ":{column}")?;
            }
        }
        if self.key_path.is_empty() {
            write!(f, ": {}", self.message)
        } else {
            write!(f, ": {}: {}", self.key_path, self.message)
        }
    }
}

impl std::error::Error for SpecError {}

/// Everything that can go wrong while planning or running a pipeline.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error(transparent)]
    Spec(#[from] SpecError),
    #[error("{context}: {path}: {source}")]
    Io {
        context: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("lockfile {path}: {message}")]
    Lock { path: PathBuf, message: String },
    #[error("stage `{stage}`: {message}")]
    Stage { stage: String, message: String },
    #[error(transparent)]
    Store(#[from] firecast_store::StoreError),
}

impl From<firecast_fs::FsError> for PipelineError {
    fn from(e: firecast_fs::FsError) -> Self {
        Self::Io {
            context: e.op,
            path: e.path,
            source: e.source,
        }
    }
}

impl PipelineError {
    pub(crate) fn io(context: &'static str, path: &Path, source: std::io::Error) -> Self {
        Self::Io {
            context,
            path: path.to_path_buf(),
            source,
        }
    }
}

/// The error a stage kind returns from `run`. Any error converts into it; its
/// chain is printed in the run report.
#[derive(Debug)]
pub struct StageError(pub Box<dyn std::error::Error + Send + Sync>);

impl StageError {
    pub fn msg(message: impl Into<String>) -> Self {
        Self(message.into().into())
    }
}

impl fmt::Display for StageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&chain_text(&*self.0))
    }
}

/// An error and its causes joined by `: `, each once. Many errors already print their source
/// inline (`{context}: {source}`); a cause whose text ends what is written so far is not
/// repeated. Stage errors and the CLI's top-level error both print this way.
pub fn chain_text(error: &(dyn std::error::Error + 'static)) -> String {
    let mut text = error.to_string();
    let mut source = error.source();
    while let Some(cause) = source {
        let cause_text = cause.to_string();
        if !text.ends_with(&cause_text) {
            text.push_str(": ");
            text.push_str(&cause_text);
        }
        source = cause.source();
    }
    text
}

impl<E: std::error::Error + Send + Sync + 'static> From<E> for StageError {
    fn from(error: E) -> Self {
        Self(Box::new(error))
    }
}

#[cfg(test)]
mod tests {
    use super::StageError;

    #[derive(Debug, thiserror::Error)]
    enum Inner {
        #[error("libxgboost.so not found")]
        Missing,
    }

    #[derive(Debug, thiserror::Error)]
    enum Outer {
        /// Prints its source inline, as many errors here do.
        #[error("model `xgboost`: {source}")]
        Inline {
            #[source]
            source: Inner,
        },
        /// Leaves the source to the chain.
        #[error("cannot fit")]
        Chained {
            #[source]
            source: Inner,
        },
    }

    #[test]
    fn the_chain_is_printed_once() {
        let inline = StageError::from(Outer::Inline {
            source: Inner::Missing,
        });
        assert_eq!(inline.to_string(), "model `xgboost`: libxgboost.so not found");
        let chained = StageError::from(Outer::Chained {
            source: Inner::Missing,
        });
        assert_eq!(chained.to_string(), "cannot fit: libxgboost.so not found");
    }
}
