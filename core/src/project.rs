//! Reading a project folder from disk for the pure loader in `nets`; a
//! project that names a mission (`mission = "steps.toml"`) is compiled
//! into nets first (`petrel_mission`), so that every verb takes it as it
//! takes nets.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use nets::source::Sources;
use nets::Project;

/// A project folder on disk, as the nets loader reads it: a mission it
/// names is served compiled (project.toml listing its nets, and the
/// generated net files). A mission that does not compile makes
/// project.toml unreadable, with its problems; [`load`] and its siblings
/// report them one by one instead.
pub struct Folder(pub PathBuf);

impl Sources for Folder {
    fn read(&self, path: &str) -> Result<String, String> {
        let disk = Disk(&self.0);
        match petrel_mission::compile_project(&disk, None) {
            Ok(None) => disk.read(path),
            Ok(Some(compiled)) => compiled.sources(&disk).read(path),
            Err(e) if path == nets::load::PROJECT_FILE => {
                Err(format!("its mission does not compile: {e}"))
            }
            Err(_) => disk.read(path),
        }
    }
}

/// The folder's files as they are on disk.
struct Disk<'a>(&'a Path);

impl Sources for Disk<'_> {
    fn read(&self, path: &str) -> Result<String, String> {
        let full = self.0.join(path);
        std::fs::read_to_string(&full).map_err(|e| format!("{}: {e}", full.display()))
    }
}

/// The mission the project in `dir` names, compiled into nets (`None`: a
/// project of hand-written nets only); its problems, if any, as for
/// [`load`]. What `petrel compile` writes out.
pub fn compiled(dir: &Path) -> Result<Option<petrel_mission::Compiled>, miette::Report> {
    if !dir.join(nets::load::PROJECT_FILE).is_file() {
        return Err(not_a_project(dir));
    }
    petrel_mission::compile_project(&Disk(dir), None).map_err(|e| {
        Unloadable {
            dir: dir.to_path_buf(),
            problems: e.problems,
        }
        .into()
    })
}

/// Events the gateway raises itself, beside elaboration's: a program lost
/// (`program_lost {name}`, `programs::session`) and frames refused for
/// their signature (`signature_rejected`, `link::rejections`). Their
/// categories and parameters are the project's declaration, else the
/// gateway's defaults: the catalog names them only as produced.
pub const RAISED: [&str; 2] = ["program_lost", "signature_rejected"];

/// Every event that may come from outside the project's nets when it runs
/// with `profile`, besides its `[events]`: the profile's catalog and the
/// events the gateway raises ([`RAISED`]). A transition waiting for
/// anything else waits for nothing the gateway delivers: a load error.
pub fn catalog(profile: &elaboration::Profile) -> nets::load::Catalog {
    let mut catalog = profile.catalog();
    for name in RAISED {
        catalog.entry(name.to_owned()).or_default();
    }
    catalog
}

/// Loads and checks the project in `dir` without knowing its elaboration
/// profile (any event it waits for may come from outside; see
/// `cli::load_profiled`); problems come back ready for people
/// (file:line:col, with the line and a caret).
pub fn load(dir: &Path) -> Result<Arc<Project>, miette::Report> {
    if !dir.join(nets::load::PROJECT_FILE).is_file() {
        return Err(not_a_project(dir));
    }
    petrel_mission::load(&Disk(dir), None)
        .map(Arc::new)
        .map_err(|e| {
            Unloadable {
                dir: dir.to_path_buf(),
                problems: e.problems,
            }
            .into()
        })
}

fn not_a_project(dir: &Path) -> miette::Report {
    miette::miette!(
        "{} is not a Petrel project: it holds no {}",
        dir.display(),
        nets::load::PROJECT_FILE
    )
}

/// Loads the project knowing the events that may come from outside its
/// nets ([`catalog`]): a transition waiting for an event nothing produces
/// is a load error.
pub fn load_with(
    dir: &Path,
    catalog: &nets::load::Catalog,
) -> Result<Arc<Project>, miette::Report> {
    load_read(dir, catalog).map(|(project, _)| project)
}

/// Files read, `(path, text)`, in the order read.
pub type Files = Vec<(String, String)>;

/// Loads the project as [`load_with`] does, with every file the loader
/// read, `(path, text)` in the order read (what its verdict depends on:
/// `gateway::preflight`).
pub fn load_read(
    dir: &Path,
    catalog: &nets::load::Catalog,
) -> Result<(Arc<Project>, Files), miette::Report> {
    if !dir.join(nets::load::PROJECT_FILE).is_file() {
        return Err(not_a_project(dir));
    }
    let sources = Recorded {
        folder: Disk(dir),
        read: std::sync::Mutex::new(Vec::new()),
    };
    let project = petrel_mission::load(&sources, Some(catalog)).map_err(|e| Unloadable {
        dir: dir.to_path_buf(),
        problems: e.problems,
    })?;
    let read = sources.read.into_inner().unwrap_or_else(|e| e.into_inner());
    Ok((Arc::new(project), read))
}

/// A project that does not load: every problem the loader found. Printed
/// for people by [`for_people`]: each problem once, with its line and
/// caret, then this one closing line.
#[derive(Debug)]
pub struct Unloadable {
    pub dir: PathBuf,
    pub problems: Vec<nets::source::Problem>,
}

impl std::fmt::Display for Unloadable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.problems.len();
        write!(
            f,
            "cannot load project {}: {n} problem{} in the project",
            self.dir.display(),
            if n == 1 { "" } else { "s" }
        )
    }
}

impl std::error::Error for Unloadable {}

impl miette::Diagnostic for Unloadable {}

/// A verb's failure as people read it: a project that does not load is
/// each of its problems (`file:line:col`, the line and a caret), then one
/// closing line; anything else as miette renders it.
pub fn for_people(failure: &miette::Report) -> String {
    let Some(unloadable) = failure.downcast_ref::<Unloadable>() else {
        return format!("{failure:?}").trim_end().to_owned();
    };
    let mut text = String::new();
    for problem in &unloadable.problems {
        text.push_str(&format!("{:?}", miette::Report::new(problem.clone())));
        if !text.ends_with('\n') {
            text.push('\n');
        }
    }
    text.push_str(format!("{failure:?}").trim_end());
    text
}

/// A folder that remembers what was read from it (a mission project's own
/// files: project.toml as written, the mission, the hand-written nets).
struct Recorded<'a> {
    folder: Disk<'a>,
    read: std::sync::Mutex<Files>,
}

impl Sources for Recorded<'_> {
    fn read(&self, path: &str) -> Result<String, String> {
        let text = self.folder.read(path)?;
        // Once each: the mission's compiler reads project.toml (and the
        // hand-written nets) before the nets loader does.
        if let Ok(mut read) = self.read.lock() {
            if !read.iter().any(|(p, _)| p == path) {
                read.push((path.to_owned(), text.clone()));
            }
        }
        Ok(text)
    }
}

/// The `[gateway]` table of the project.toml in `dir` (empty when absent).
pub fn gateway_table(dir: &Path) -> Result<toml::Table, miette::Report> {
    let path = dir.join(nets::load::PROJECT_FILE);
    let text = std::fs::read_to_string(&path)
        .map_err(|e| miette::miette!("cannot read {}: {e}", path.display()))?;
    let table: toml::Table = toml::from_str(&text)
        .map_err(|e| miette::miette!("{}: {}", path.display(), e.message()))?;
    Ok(match table.get("gateway") {
        Some(toml::Value::Table(t)) => t.clone(),
        Some(_) => {
            return Err(miette::miette!(
                "{}: [gateway] must be a table",
                path.display()
            ))
        }
        None => toml::Table::new(),
    })
}

/// A string setting of the `[gateway]` table, if set.
pub fn gateway_setting(dir: &Path, key: &str) -> Result<Option<String>, miette::Report> {
    let table = gateway_table(dir)?;
    match table.get(key) {
        None => Ok(None),
        Some(toml::Value::String(s)) => Ok(Some(s.clone())),
        Some(_) => Err(miette::miette!(
            "{}: [gateway] {key} must be a string",
            dir.join(nets::load::PROJECT_FILE).display()
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../examples")
            .join(name)
    }

    #[test]
    fn a_mission_project_loads_as_its_compiled_nets_by_every_path() {
        let dir = example("uav-survey-mission");
        let names = |p: &Project| p.nets.iter().map(|n| n.name.clone()).collect::<Vec<_>>();
        let loaded = load(&dir).map_err(|e| for_people(&e));
        let loaded = loaded.as_deref().map(names);
        assert_eq!(
            loaded,
            Ok(vec![
                "CATASTROPHIC".to_owned(),
                "SAFETY".to_owned(),
                "COMMUNICATION".to_owned(),
                "MISSION".to_owned()
            ])
        );
        // The folder itself serves the compiled project, as `nets` reads it.
        let by_folder = nets::load(&Folder(dir.clone())).map(|p| names(&p));
        assert_eq!(by_folder.ok(), loaded.ok());
        assert!(matches!(compiled(&dir), Ok(Some(_))));
        assert!(matches!(compiled(&example("uav-survey")), Ok(None)));
    }

    #[test]
    fn what_is_read_is_the_crews_files_not_the_generated_ones() {
        let dir = example("uav-survey-mission");
        let Ok(profile) = elaboration::Profile::builtin("ardupilot") else {
            panic!("the built-in profile compiles");
        };
        let read = load_read(&dir, &catalog(&profile)).map(|(_, files)| files);
        let paths: Vec<String> = read
            .map(|files| files.into_iter().map(|(path, _)| path).collect())
            .unwrap_or_default();
        assert_eq!(paths, ["project.toml", "steps.toml"]);
        // A project of nets is read as before: project.toml, then each net, once.
        let read = load_read(&example("uav-survey"), &catalog(&profile)).map(|(_, files)| files);
        let paths: Vec<String> = read
            .map(|files| files.into_iter().map(|(path, _)| path).collect())
            .unwrap_or_default();
        assert_eq!(paths, ["project.toml", "mission.toml", "events.toml"]);
    }
}
