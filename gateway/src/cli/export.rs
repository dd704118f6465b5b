//! `petrel export PROJECT --pnml OUT`: each net as a PNML document that other
//! Petri net tools read (`OUT/<NET>.pnml`; global places as reference places,
//! events, guards and actions in `<toolspecific tool="petrel">`).

use std::path::PathBuf;

use nets::verify::export::export_net;

use super::{Outcome, VerbResult};

#[derive(clap::Args)]
pub struct Args {
    /// The project folder (holding project.toml).
    pub project: PathBuf,
    /// The folder to write one PNML file per net into (created if missing).
    #[arg(long, value_name = "OUT")]
    pub pnml: PathBuf,
}

pub fn run(args: Args) -> VerbResult {
    let Some(project) = super::load_profiled(&args.project)? else {
        return Ok(Outcome::BadInput);
    };
    std::fs::create_dir_all(&args.pnml)
        .map_err(|e| miette::miette!("cannot create {}: {e}", args.pnml.display()))?;
    for (n, net) in project.nets.iter().enumerate() {
        let path = args.pnml.join(format!("{}.pnml", net.name));
        std::fs::write(&path, export_net(&project, n))
            .map_err(|e| miette::miette!("cannot write {}: {e}", path.display()))?;
        say!("wrote {}", path.display());
    }
    Ok(Outcome::Success)
}
