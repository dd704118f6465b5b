//! `petrel compile PROJECT --out DIR`: a mission project written out as
//! hand-written nets (docs/missions.md "Compiled"): DIR gets the project's
//! files, project.toml listing the compiled nets instead of the mission,
//! and each net file, all at once or nothing.

use std::path::{Path, PathBuf};

use super::{Outcome, VerbResult};

#[derive(clap::Args)]
pub struct Args {
    /// The project folder (holding project.toml, which names the mission).
    pub project: PathBuf,
    /// The folder to create with the compiled project (must not exist).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

pub fn run(args: Args) -> VerbResult {
    // The whole project loads with its profile, as every verb loads it.
    if super::load_profiled(&args.project)?.is_none() {
        return Ok(Outcome::BadInput);
    }
    let Some(compiled) = petrel_core::project::compiled(&args.project)? else {
        return Err(miette::miette!(
            "{} names no mission (project.toml has no `{}` key): its nets are written by hand already",
            args.project.display(),
            petrel_mission::MISSION_KEY
        ));
    };
    if args.out.exists() {
        return Err(miette::miette!(
            "{} exists: give a new folder, nothing is written over",
            args.out.display()
        ));
    }
    let parent = match args.out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = args
        .out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // Written beside DIR, then renamed: DIR holds the whole project or
    // does not exist.
    let scratch = parent.join(format!(".{name}.compiling-{}", std::process::id()));
    std::fs::create_dir(&scratch)
        .map_err(|e| miette::miette!("cannot create {}: {e}", scratch.display()))?;
    let written = copy(&args.project, &scratch, &compiled.mission.name).and_then(|()| {
        for (path, text) in compiled.files() {
            let to = scratch.join(&path);
            std::fs::write(&to, text)
                .map_err(|e| miette::miette!("cannot write {}: {e}", to.display()))?;
        }
        std::fs::rename(&scratch, &args.out).map_err(|e| {
            miette::miette!(
                "cannot move the compiled project to {}: {e}",
                args.out.display()
            )
        })
    });
    if let Err(e) = written {
        let _ = std::fs::remove_dir_all(&scratch);
        return Err(e);
    }
    for (path, _) in compiled.files() {
        say!("wrote {}", args.out.join(path).display());
    }
    Ok(Outcome::Success)
}

/// Copies the project's files (not the mission, hidden entries nor build
/// folders named `target`) from `from` to `to`.
fn copy(from: &Path, to: &Path, mission: &str) -> Result<(), miette::Report> {
    let entries = std::fs::read_dir(from)
        .map_err(|e| miette::miette!("cannot read {}: {e}", from.display()))?;
    for entry in entries {
        let entry = entry.map_err(|e| miette::miette!("cannot read {}: {e}", from.display()))?;
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if name.starts_with('.') || name == "target" || (from.join(mission) == entry.path()) {
            continue;
        }
        let path = entry.path();
        let target = to.join(&*name);
        if path.is_dir() {
            std::fs::create_dir(&target)
                .map_err(|e| miette::miette!("cannot create {}: {e}", target.display()))?;
            copy(&path, &target, "")?;
        } else {
            std::fs::copy(&path, &target)
                .map_err(|e| miette::miette!("cannot copy {}: {e}", path.display()))?;
        }
    }
    Ok(())
}
