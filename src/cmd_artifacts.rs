//! `firecast artifacts ls|get`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Subcommand;
use firecast_store::ArtifactStore;

use crate::output;
use crate::settings::Settings;

#[derive(Debug, Subcommand)]
pub enum ArtifactsCommand {
    /// List artifacts in the store (optionally under a key prefix, e.g. `runs/<run>`).
    Ls {
        /// Key prefix.
        prefix: Option<String>,
    },
    /// Download an artifact by URL or key.
    Get {
        /// The artifact's URL (as `artifacts ls` prints it) or its key.
        artifact: String,
        /// Where to write it [default: its file name in the current folder].
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
}

pub fn run(settings: &Settings, command: ArtifactsCommand) -> anyhow::Result<ExitCode> {
    let store = ArtifactStore::open(&settings.store, &settings.root)?;
    match command {
        ArtifactsCommand::Ls { prefix } => {
            let entries = store.list(prefix.as_deref())?;
            if settings.json {
                let list: Vec<_> = entries
                    .iter()
                    .map(|e| serde_json::json!({"uri": e.uri, "key": e.key, "size": e.size, "last_modified": e.last_modified}))
                    .collect();
                output::print_json(&list)?;
            } else {
                let mut table = output::table(&["key", "bytes", "modified"]);
                for e in &entries {
                    table.add_row(vec![e.key.clone(), e.size.to_string(), e.last_modified.clone()]);
                }
                output::print_table(&table)?;
                println!("{} artifacts in {}", entries.len(), store.url());
            }
        }
        ArtifactsCommand::Get { artifact, output } => {
            let key = store.key_of(&artifact);
            let dest = output.unwrap_or_else(|| PathBuf::from(key.rsplit('/').next().unwrap_or("artifact")));
            let dest = settings.root.join(dest);
            let bytes = store.get_to_file(&artifact, &dest)?;
            if settings.json {
                output::print_json(
                    &serde_json::json!({"uri": store.uri_of(&key), "path": dest, "size": bytes}),
                )?;
            } else {
                println!("{} -> {} ({bytes} bytes)", store.uri_of(&key), dest.display());
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
