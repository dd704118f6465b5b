//! `petrel stubs PROJECT --lang python|rust OUT`: ready-to-fill skeletons of
//! the software programs the nets call, as EdiPet generated function
//! prototypes (docs/programs.md). Existing files are never overwritten
//! unless `--force`.

use std::path::PathBuf;

use petrel_core::programs::stubs::{write, Lang};

use super::{Outcome, VerbResult};

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum Language {
    /// One file per program, standard library only.
    Python,
    /// A Cargo project per program (std and serde_json).
    Rust,
}

#[derive(clap::Args)]
pub struct Args {
    /// The project folder (holding project.toml).
    pub project: PathBuf,
    /// The skeletons' language.
    #[arg(long, value_enum)]
    pub lang: Language,
    /// The folder to write them in (created if needed).
    pub out: PathBuf,
    /// Overwrite files that exist.
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: Args) -> VerbResult {
    let Some(project) = super::load_profiled(&args.project)? else {
        return Ok(Outcome::BadInput);
    };
    let lang = match args.lang {
        Language::Python => Lang::Python,
        Language::Rust => Lang::Rust,
    };
    let written = write(&args.project, &project, lang, &args.out, args.force)
        .map_err(|e| miette::miette!("{e}"))?;
    if written.is_empty() {
        say!("the nets call no program: nothing to write");
    }
    for path in written {
        show!("{}", path.display());
    }
    Ok(Outcome::Success)
}
