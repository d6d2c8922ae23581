//! Models an experiment run saved to the artifact store, named as `RUN:PROTOCOL/MODEL` (the
//! lowest seed saved) or `RUN:PROTOCOL/MODEL/seed-N`, fetched into a local cache folder and
//! checked against the hashes the registry recorded.

use std::path::{Path, PathBuf};

use firecast_store::ArtifactStore;

use crate::{Registry, RegistryError, RunDetails};

/// Why a saved model could not be fetched.
#[derive(Debug, thiserror::Error)]
pub enum SavedModelError {
    #[error(
        "`{0}`: no such folder, and not RUN:PROTOCOL/MODEL[/seed-N] (a model saved by an experiment run)"
    )]
    NotAModelName(String),
    #[error("run {run} saved no model `{path}`{}", saved_note(.saved))]
    NotSaved {
        run: String,
        path: String,
        saved: Vec<String>,
    },
    #[error("fetching {uri} of run {run}: {source}")]
    Fetch {
        uri: String,
        run: String,
        /// Boxed: the store's error is large and this one is rare.
        #[source]
        source: Box<firecast_store::StoreError>,
    },
    #[error("{}: {source}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: fetched bytes hash to {found}, the registry recorded {recorded} for this artifact", path.display())]
    Corrupt {
        path: PathBuf,
        found: String,
        recorded: String,
    },
    #[error(transparent)]
    Registry(#[from] RegistryError),
}

fn saved_note(saved: &[String]) -> String {
    if saved.is_empty() {
        " (it saved no models: is it an experiment run?)".to_string()
    } else {
        format!("; it saved: {}", saved.join(", "))
    }
}

impl Registry {
    /// A run's details; for a pipeline run of one stage (what `experiment run` and `rl
    /// train` record), that stage's run.
    pub fn stage_run_details(&self, id: &str) -> Result<RunDetails, RegistryError> {
        let details = self.run_details(id)?;
        if details.run.stage.is_none() && details.children.len() == 1 {
            return self.run_details(&details.children[0].run_id);
        }
        Ok(details)
    }
}

/// Fetches the model `name` (`RUN:PROTOCOL/MODEL[/seed-N]`) into
/// `<cache>/<run>/<PROTOCOL>/<MODEL>/<seed-N>/` and returns that folder.
pub fn fetch_saved_model(
    registry: &Registry,
    store: &ArtifactStore,
    cache: &Path,
    name: &str,
) -> Result<PathBuf, SavedModelError> {
    let Some((run, path)) = name.split_once(':') else {
        return Err(SavedModelError::NotAModelName(name.to_string()));
    };
    let details = registry.stage_run_details(run)?;
    let path = path.trim_matches('/');
    let wanted = if path.split('/').count() == 2 {
        // No seed given: the lowest one saved.
        let prefix = format!("model/{path}/seed-");
        details
            .artifacts
            .iter()
            .filter_map(|a| {
                a.name
                    .strip_prefix(&prefix)
                    .and_then(|n| n.parse::<u64>().ok())
                    .map(|n| (n, a.name.as_str()))
            })
            .min()
            .map(|(_, n)| n.to_string())
    } else {
        Some(format!("model/{path}"))
    };
    let files: Vec<_> = match &wanted {
        Some(name) => details.artifacts.iter().filter(|a| &a.name == name).collect(),
        None => Vec::new(),
    };
    let Some(wanted) = wanted.filter(|_| !files.is_empty()) else {
        let mut saved: Vec<String> = details
            .artifacts
            .iter()
            .filter_map(|a| a.name.strip_prefix("model/").map(str::to_string))
            .collect();
        saved.dedup();
        return Err(SavedModelError::NotSaved {
            run: details.run.run_id.clone(),
            path: path.to_string(),
            saved,
        });
    };
    let dir = cache
        .join(&details.run.run_id)
        .join(wanted.trim_start_matches("model/"));
    for a in files {
        let file = a.uri.rsplit('/').next().unwrap_or_default();
        let dest = dir.join(file);
        store
            .get_to_file(&a.uri, &dest)
            .map_err(|source| SavedModelError::Fetch {
                uri: a.uri.clone(),
                run: details.run.run_id.clone(),
                source: Box::new(source),
            })?;
        let bytes = std::fs::read(&dest).map_err(|source| SavedModelError::Read {
            path: dest.clone(),
            source,
        })?;
        let found = blake3::hash(&bytes).to_hex().to_string();
        if !a.hash.is_empty() && a.hash != found {
            return Err(SavedModelError::Corrupt {
                path: dest,
                found,
                recorded: a.hash.clone(),
            });
        }
    }
    Ok(dir)
}
