//! `petrel draw PROJECT [--net NAME] [--dot | --svg]`: the nets as Graphviz
//! DOT (places as circles with their tokens, transitions as boxes labelled
//! with their event, guard and actions; pipe it to `dot -Tsvg`), or as SVG
//! laid out by Petrel itself (`nets::layout`: no Graphviz needed).

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
    /// Write Graphviz DOT (the default).
    #[arg(long, conflicts_with = "svg")]
    pub dot: bool,
    /// Write SVG, laid out left to right by Petrel (no Graphviz needed).
    #[arg(long)]
    pub svg: bool,
    /// Write to this file instead of standard output.
    #[arg(long, short, value_name = "FILE")]
    pub output: Option<PathBuf>,
}

pub fn run(args: Args) -> VerbResult {
    let Some(project) = super::load_profiled(&args.project)? else {
        return Ok(Outcome::BadInput);
    };
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
    let drawing = Drawing { net, marking: None };
    let text = if args.svg {
        nets::svg::svg(&project, &drawing)
    } else {
        dot(&project, &drawing)
    };
    match &args.output {
        Some(path) => std::fs::write(path, text)
            .map_err(|e| miette::miette!("cannot write {}: {e}", path.display()))?,
        None => std::io::stdout()
            .write_all(text.as_bytes())
            .map_err(|e| miette::miette!("cannot write the drawing: {e}"))?,
    }
    Ok(Outcome::Success)
}
