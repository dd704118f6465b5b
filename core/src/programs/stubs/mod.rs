//! Program skeletons, as EdiPet generated function prototypes: for each
//! program the nets call, every function they call with its arguments and
//! returned parameters, a TODO body, and the protocol around it (hello, the
//! call loop, replies, errors). Python: one file, standard library only.
//! Rust: a small Cargo project (std and serde_json).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use nets::model::Action;
use nets::Project;

use super::roster::called_functions;

mod python;
mod rust;

/// The language of the skeletons.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lang {
    Python,
    Rust,
}

/// One file to write, relative to the output folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct File {
    pub path: String,
    pub text: String,
}

/// What a skeleton needs to know of one function.
#[derive(Debug, Clone)]
struct Prototype {
    name: String,
    args: Vec<String>,
    returns: Vec<String>,
    /// `NET.transition` of each call site.
    callers: Vec<String>,
}

/// What a skeleton needs to know of one program.
#[derive(Debug, Clone)]
struct Skeleton {
    project: String,
    name: String,
    /// The address to use when PETREL_PROGRAMS is not set.
    address: String,
    functions: Vec<Prototype>,
}

/// The skeletons of every program the nets call, in project order.
pub fn stubs(project: &Project, lang: Lang, address: &str) -> Vec<File> {
    let called = called_functions(project);
    let mut callers: BTreeMap<(usize, usize), Vec<String>> = BTreeMap::new();
    for net in &project.nets {
        for t in &net.transitions {
            for a in &t.actions {
                if let Action::Call {
                    program, function, ..
                } = a
                {
                    let site = format!("{}.{}", net.name, t.name);
                    let list = callers.entry((*program, *function)).or_default();
                    if !list.contains(&site) {
                        list.push(site);
                    }
                }
            }
        }
    }
    let mut files = Vec::new();
    for (p, program) in project.programs.iter().enumerate() {
        if called[p].is_empty() {
            continue;
        }
        let skeleton = Skeleton {
            project: project.name.clone(),
            name: program.name.clone(),
            address: address.to_owned(),
            functions: called[p]
                .iter()
                .map(|&f| {
                    let function = &program.functions[f];
                    Prototype {
                        name: function.name.clone(),
                        args: function.args.clone(),
                        returns: function.returns.clone(),
                        callers: callers.remove(&(p, f)).unwrap_or_default(),
                    }
                })
                .collect(),
        };
        match lang {
            Lang::Python => files.push(python::skeleton(&skeleton)),
            Lang::Rust => files.extend(rust::skeleton(&skeleton)),
        }
    }
    files
}

/// A name made safe for a language: a keyword or a taken name gets a `_`.
fn safe(name: &str, taken: &[&str]) -> String {
    if taken.contains(&name) {
        format!("{name}_")
    } else {
        name.to_owned()
    }
}

/// `DEC.replan(failed) -> {waypoints}`, for comments.
fn signature(program: &str, f: &Prototype) -> String {
    format!(
        "{program}.{}({}) -> {{{}}}",
        f.name,
        f.args.join(", "),
        f.returns.join(", ")
    )
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
    let config =
        crate::programs::roster::Config::from_project_dir(dir).map_err(|e| e.to_string())?;
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

#[cfg(test)]
mod tests {
    use super::*;

    pub(super) fn project() -> Project {
        let files = [
            (
                "project.toml",
                "name = \"demo\"\n[[net]]\nfile = \"n.toml\"\nactive = true\n\
                 [programs.DEC.functions]\nnext = { returns = [\"lat\", \"lon\"] }\n\
                 replan = { args = [\"failed\", \"type\", \"pass\"], returns = [\"waypoints\"] }\n\
                 unused = {}\n\
                 [programs.GUI.functions]\nidle = {}\n",
            ),
            (
                "n.toml",
                "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n\
                 [[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"go\"\n\
                 do = [\"call DEC.next\", \"call DEC.replan {failed: 1, type: 2, pass: 3}\"]\n\
                 [[transition]]\nname = \"u\"\nfrom = [\"b\"]\nto = [\"a\"]\non = \"go\"\n\
                 do = [\"call DEC.next\"]\n",
            ),
        ];
        nets::load(&files).expect("loads")
    }

    #[test]
    fn only_called_programs_and_functions_get_a_skeleton() {
        let files = stubs(&project(), Lang::Python, "tcp:127.0.0.1:5790");
        assert_eq!(files.len(), 1, "GUI is never called");
        let text = &files[0].text;
        assert_eq!(files[0].path, "DEC.py");
        assert!(text.contains("def next():") && text.contains("def replan("));
        assert!(!text.contains("def unused"));
        assert!(text.contains("Called by: N.t, N.u"), "{text}");
        assert!(text.contains("DEC.replan(failed, type, pass) -> {waypoints}"));
        let files = stubs(&project(), Lang::Rust, "tcp:127.0.0.1:5790");
        let paths: Vec<&str> = files.iter().map(|f| f.path.as_str()).collect();
        assert_eq!(
            paths,
            vec!["dec/Cargo.toml", "dec/src/main.rs", "dec/src/functions.rs"]
        );
    }

    #[test]
    fn keywords_are_made_safe() {
        let py = &stubs(&project(), Lang::Python, "tcp:127.0.0.1:5790")[0].text;
        assert!(py.contains("def replan(failed, type, pass_):"), "{py}");
        let rs = stubs(&project(), Lang::Rust, "tcp:127.0.0.1:5790");
        let functions = &rs[2].text;
        assert!(
            functions.contains("pub fn replan(failed: &Value, r#type: &Value, pass: &Value)"),
            "{functions}"
        );
    }
}
