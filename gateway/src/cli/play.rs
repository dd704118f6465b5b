//! `petrel play PROJECT --events FILE`.

use std::path::PathBuf;

use super::{Outcome, VerbResult};

#[derive(clap::Args)]
pub struct Args {
    /// The project folder (holding project.toml).
    pub project: PathBuf,
    /// Timed events, one JSON object a line: {"t": 12.5, "event": "name", "params": {}}.
    #[arg(long)]
    pub events: PathBuf,
    /// Print JSON lines instead of text for people.
    #[arg(long)]
    pub json: bool,
}

pub fn run(_args: Args) -> VerbResult {
    Ok(Outcome::Success)
}
