//! `petrel stubs PROJECT --lang python|rust OUT`: ready-to-fill skeletons of
//! the software programs the nets call, as EdiPet generated function
//! prototypes (docs/programs.md). Existing files are never overwritten
//! unless `--force`.

use std::path::PathBuf;

use crate::programs::roster::Config;
use crate::programs::stubs::{stubs, Lang};

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
    let project = crate::project::load(&args.project)?;
    let config = Config::from_project_dir(&args.project).map_err(|e| miette::miette!("{e}"))?;
    let lang = match args.lang {
        Language::Python => Lang::Python,
        Language::Rust => Lang::Rust,
    };
    let files = stubs(&project, lang, &config.address.to_string());
    if files.is_empty() {
        say!("the nets call no program: nothing to write");
        return Ok(Outcome::Success);
    }
    if !args.force {
        let existing: Vec<String> = files
            .iter()
            .map(|f| args.out.join(&f.path))
            .filter(|p| p.exists())
            .map(|p| p.display().to_string())
            .collect();
        if !existing.is_empty() {
            return Err(miette::miette!(
                "not overwriting {} (use --force)",
                existing.join(", ")
            ));
        }
    }
    for file in &files {
        let path = args.out.join(&file.path);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir)
                .map_err(|e| miette::miette!("cannot create {}: {e}", dir.display()))?;
        }
        std::fs::write(&path, &file.text)
            .map_err(|e| miette::miette!("cannot write {}: {e}", path.display()))?;
        println!("{}", path.display());
    }
    Ok(Outcome::Success)
}
