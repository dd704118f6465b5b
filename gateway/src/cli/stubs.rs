//! `petrel stubs PROJECT --lang python|rust OUT`: ready-to-fill skeletons of
//! the software programs the nets call, as EdiPet generated function
//! prototypes (docs/programs.md). Existing files are never overwritten
//! unless `--force`.

use std::path::{Path, PathBuf};

use nets::Project;

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

/// Writes the skeletons of the programs `project` (in `dir`) calls into
/// `out`, refusing to overwrite a file unless `force`; the files written
/// (none when the nets call no program). `petrel edit` generates them
/// with this too.
pub fn write(
    dir: &Path,
    project: &Project,
    lang: Lang,
    out: &Path,
    force: bool,
) -> Result<Vec<PathBuf>, String> {
    let config = Config::from_project_dir(dir).map_err(|e| e.to_string())?;
    let files = stubs(project, lang, &config.address.to_string());
    if !force {
        let existing: Vec<String> = files
            .iter()
            .map(|f| out.join(&f.path))
            .filter(|p| p.exists())
            .map(|p| p.display().to_string())
            .collect();
        if !existing.is_empty() {
            return Err(format!(
                "not overwriting {} (use --force)",
                existing.join(", ")
            ));
        }
    }
    let mut written = Vec::new();
    for file in &files {
        let path = out.join(&file.path);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir)
                .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        }
        std::fs::write(&path, &file.text)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        written.push(path);
    }
    Ok(written)
}
