//! `petrel draw PROJECT [--net NAME] --dot`: the nets as Graphviz DOT
//! (places as circles with their tokens, transitions as boxes labelled with
//! their event, guard and actions). Pipe it to `dot -Tsvg`.

use std::io::Write;
use std::path::PathBuf;

use nets::dot::{dot, Drawing};

use super::{Outcome, VerbResult};

#[derive(clap::Args)]
pub struct Args {
    /// The project folder (holding project.toml).
    pub project: PathBuf,
    /// Draw only this net (with the global places it uses).
    #[arg(long, value_name = "NAME")]
    pub net: Option<String>,
    /// Write Graphviz DOT (the only format, and the default).
    #[arg(long)]
    pub dot: bool,
    /// Write to this file instead of standard output.
    #[arg(long, short, value_name = "FILE")]
    pub output: Option<PathBuf>,
}

pub fn run(args: Args) -> VerbResult {
    let project = crate::project::load(&args.project)?;
    let net = match &args.net {
        None => None,
        Some(name) => Some(project.net(name).ok_or_else(|| {
            let names: Vec<&str> = project.nets.iter().map(|n| n.name.as_str()).collect();
            miette::miette!(
                "no net `{name}` in the project (it has: {})",
                names.join(", ")
            )
        })?),
    };
    let text = dot(&project, &Drawing { net, marking: None });
    match &args.output {
        Some(path) => std::fs::write(path, text)
            .map_err(|e| miette::miette!("cannot write {}: {e}", path.display()))?,
        None => std::io::stdout()
            .write_all(text.as_bytes())
            .map_err(|e| miette::miette!("cannot write the drawing: {e}"))?,
    }
    Ok(Outcome::Success)
}
