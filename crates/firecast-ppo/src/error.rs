//! Errors of the PPO engine. An application whose environment fails for its own reasons
//! carries its error in [`PpoError::Env`] and takes it back out of it.

use std::path::PathBuf;

/// Errors of settings, tensors, training, checkpoints and environments. Paths come last in
/// messages.
#[derive(Debug, thiserror::Error)]
pub enum PpoError {
    /// A setting is wrong; `key` is its path in the config (e.g. `ppo.batch_size`).
    #[error("{key}: {message}")]
    Config { key: String, message: String },
    #[error(transparent)]
    Torch(#[from] tch::TchError),
    #[error(
        "training diverged at update {update}: {what} is not finite; the last good checkpoint is kept{}",
        checkpoint.as_ref().map(|p| format!(" at {}", p.display())).unwrap_or_default()
    )]
    NonFinite {
        update: u64,
        what: String,
        checkpoint: Option<PathBuf>,
    },
    #[error("checkpoint {path}: {message}")]
    Checkpoint { path: PathBuf, message: String },
    #[error("{context}: {path}: {source}")]
    Io {
        context: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// An environment's own error (see [`VecEnvironment`](crate::env::VecEnvironment)).
    #[error(transparent)]
    Env(Box<dyn std::error::Error + Send + Sync>),
}

impl PpoError {
    pub fn config(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Config {
            key: key.into(),
            message: message.into(),
        }
    }
    pub(crate) fn io(context: &'static str, path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            context,
            path: path.into(),
            source,
        }
    }
}
