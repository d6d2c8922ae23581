//! FireCast's benchmark harnesses, one module per `firecast bench` command: each parses its
//! own flags (a clap [`clap::Args`] struct), runs FireCast beside its reference in the same
//! command (`run`), and returns a report that serialises to the command's `--json` and
//! renders the human tables ([`Report`]). The CLI only resolves the settings into a
//! [`Context`] and prints.
//!
//! Harness code stays out of the engine crates: what a bench needs of an engine is that
//! engine's public API. The one Python finder every bench uses is [`python::find_python`].
//!
//! Errors are `anyhow`: a harness is an edge, like the CLI, whose errors are only printed.

pub mod behavior;
pub mod forecast;
pub mod gridmet;
pub mod ppo;
pub mod pyretechnics;
pub mod python;
pub mod quality;
pub mod serve;
pub mod sim;
pub mod spread;

use std::path::PathBuf;

use comfy_table::{ContentArrangement, Table, presets};

/// What every bench takes from the CLI's resolved settings.
#[derive(Debug, Clone)]
pub struct Context {
    /// Project root: relative paths in the flags resolve against it.
    pub root: PathBuf,
    /// `--json`: the report is printed as JSON (some benches then keep their progress quiet).
    pub json: bool,
    /// Progress bars may be drawn.
    pub progress: bool,
}

/// A finished bench's report: `--json` prints it serialised, otherwise its rendering.
pub trait Report: serde::Serialize {
    /// The human output: the tables and lines the command prints without `--json`.
    fn render(&self) -> String;

    /// The exit status: 0, or 1 where the bench's goals or bounds failed.
    fn exit_code(&self) -> u8 {
        0
    }
}

/// A Markdown-style table (pastes into notes and reports), as the CLI draws every table.
pub fn table(header: &[&str]) -> Table {
    let mut table = Table::new();
    table
        .load_preset(presets::ASCII_MARKDOWN)
        .set_content_arrangement(ContentArrangement::Disabled)
        .set_header(header.iter().copied());
    table
}
