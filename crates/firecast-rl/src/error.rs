//! The crate's error type, and its conversions to and from the PPO engine's.

use std::path::PathBuf;

/// Errors of training, checkpoints and evaluation. Paths come last in messages.
#[derive(Debug, thiserror::Error)]
pub enum RlError {
    /// A setting is wrong; `key` is its path in the config (e.g. `ppo.batch_size`).
    #[error("{key}: {message}")]
    Config { key: String, message: String },
    /// A [`RlError::Config`] of a file, with the line and column of its key.
    #[error("{}:{line}:{column}: {key}: {message}", path.display())]
    ConfigAt {
        path: PathBuf,
        line: usize,
        column: usize,
        key: String,
        message: String,
    },
    #[error(transparent)]
    Torch(#[from] tch::TchError),
    #[error(transparent)]
    Sim(#[from] firecast_sim::SimError),
    #[error(transparent)]
    Landscape(#[from] firecast_landscape::LandscapeError),
    #[error(transparent)]
    Render(#[from] firecast_render::RenderError),
    #[error(transparent)]
    Episode(#[from] firecast_episodes::EpisodeError),
    /// A recorded rollout did not reproduce the evaluated episode.
    #[error(
        "recording the {role} PPO episode (training seed {train_seed}, held-out fire {fire}): the replay \
         gave {replayed}, the evaluation {evaluated}; the policy chose another action on the fire alone \
         than in the batch of fires (the forward passes differ in the last bits, as they can on a GPU); \
         evaluate without recordings (--no-recordings, or `recordings: false`)"
    )]
    ReplayDiverged {
        role: String,
        train_seed: u64,
        fire: usize,
        evaluated: String,
        replayed: String,
    },
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
    #[error("{0}")]
    Spec(#[from] firecast_pipeline::SpecError),
    #[error("interrupted")]
    Interrupted,
    /// An error of the PPO engine that is none of the above.
    #[error(transparent)]
    Ppo(firecast_ppo::PpoError),
}

/// The engine's errors as this crate's own: a setting or a tensor error keeps its variant
/// (so [`RlError::located`] finds its key), and an environment's error its own type.
impl From<firecast_ppo::PpoError> for RlError {
    fn from(e: firecast_ppo::PpoError) -> Self {
        use firecast_ppo::PpoError;
        match e {
            PpoError::Config { key, message } => Self::Config { key, message },
            PpoError::Torch(e) => Self::Torch(e),
            PpoError::NonFinite {
                update,
                what,
                checkpoint,
            } => Self::NonFinite {
                update,
                what,
                checkpoint,
            },
            PpoError::Checkpoint { path, message } => Self::Checkpoint { path, message },
            PpoError::Io {
                context,
                path,
                source,
            } => Self::Io {
                context,
                path,
                source,
            },
            PpoError::Env(e) => match e.downcast::<RlError>() {
                Ok(e) => *e,
                Err(e) => Self::Ppo(PpoError::Env(e)),
            },
        }
    }
}

/// The helitack environment's errors, carried through the engine's interface.
impl From<RlError> for firecast_ppo::PpoError {
    fn from(e: RlError) -> Self {
        Self::Env(Box::new(e))
    }
}

impl RlError {
    pub fn config(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Config {
            key: key.into(),
            message: message.into(),
        }
    }
    /// A [`RlError::Config`] located in the YAML file it came from (FILE:LINE:COL of its key,
    /// as far as `firecast_pipeline::locate_path` finds it); other errors unchanged.
    pub fn located(self, path: &std::path::Path, source: &str) -> Self {
        match self {
            Self::Config { key, message } => match firecast_pipeline::locate_path(source, &key) {
                Some((line, column)) => Self::ConfigAt {
                    path: path.to_path_buf(),
                    line,
                    column,
                    key,
                    message,
                },
                None => Self::Config { key, message },
            },
            other => other,
        }
    }
    /// A [`RlError::Config`] placed in the file of an `extends` chain that wrote its key
    /// (FILE:LINE:COL); other errors unchanged.
    pub fn placed(self, layered: &firecast_pipeline::extends::Layered) -> Self {
        match self {
            Self::Config { key, message } => Self::Spec(layered.error(key, message)),
            other => other,
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
