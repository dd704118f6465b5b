//! A mission project served to the nets loader as ordinary nets: the
//! project's own files, project.toml with the mission's nets listed, and
//! the generated net files; the loader's problems in generated text moved
//! back onto the mission line that made it.

use std::collections::{BTreeMap, BTreeSet};
use std::ops::Range;

use nets::action::{self, ActionSyntax};
use nets::load::{Catalog, PROJECT_FILE};
use nets::source::{LoadError, Problem, SourceFile, Sources};
use nets::Category;
use serde::Deserialize;
use toml::Spanned;

use super::check::{check, Known};
use super::compile::{compile, NetFile};

/// The key of project.toml that names the mission file.
pub const MISSION_KEY: &str = "mission";

/// A mission project compiled: project.toml as the nets loader reads it,
/// and the generated net files.
#[derive(Debug, Clone)]
pub struct Compiled {
    /// The mission file, as read.
    pub mission: SourceFile,
    /// project.toml without its `mission` key (commented out, so that
    /// every line keeps its number) and with the generated nets listed at
    /// its end.
    pub project: String,
    /// Lines of `project` up to where the generated nets are listed.
    project_lines: usize,
    /// The `mission = "…"` value in project.toml.
    key: Range<usize>,
    pub nets: Vec<NetFile>,
}

#[derive(Deserialize, Clone)]
struct Head {
    mission: Option<Spanned<toml::Value>>,
    #[serde(default)]
    events: toml::Table,
    #[serde(default)]
    programs: toml::Table,
    #[serde(default)]
    net: Vec<toml::Table>,
    #[serde(default)]
    globals: toml::Table,
}

/// Compiles the mission the project in `sources` names, if it names one
/// (`None`: a project of hand-written nets only, or a project.toml the
/// nets loader will refuse on its own). With `catalog` (the events of the
/// elaboration profile), every event the mission waits for must be one
/// something produces, as `nets::load_with` demands.
pub fn compile_project(
    sources: &dyn Sources,
    catalog: Option<&Catalog>,
) -> Result<Option<Compiled>, LoadError> {
    let Ok(text) = sources.read(PROJECT_FILE) else {
        return Ok(None);
    };
    let Ok(head) = toml::from_str::<Head>(&text) else {
        return Ok(None);
    };
    let Some(key) = head.mission.clone() else {
        return Ok(None);
    };
    let pfile = SourceFile::new(PROJECT_FILE, &text);
    let refuse = |message: String| LoadError {
        problems: vec![Problem::new(&pfile, key.span(), message)],
    };
    let path = match key.get_ref() {
        toml::Value::String(p) if p.ends_with(".toml") && !p.contains("..") && !p.starts_with('/') && p != PROJECT_FILE => p.clone(),
        _ => return Err(refuse("`mission` names the mission file beside project.toml: a relative path ending in `.toml`, such as \"steps.toml\"".to_owned())),
    };
    let mission_text = sources
        .read(&path)
        .map_err(|why| refuse(format!("cannot read the mission {path}: {why}")))?;

    let known = Known {
        events: catalog.map(|catalog| outside_events(sources, &head, catalog, &mission_text)),
        categories: categories(&head, catalog),
        globals: head
            .globals
            .iter()
            .map(|(name, v)| {
                (
                    name.clone(),
                    matches!(v, toml::Value::Boolean(true) | toml::Value::Integer(1)),
                )
            })
            .collect(),
    };
    let mission = check(&path, &mission_text, &known).map_err(|problems| LoadError { problems })?;
    let nets = compile(&mission);

    let listed: BTreeSet<String> = head
        .net
        .iter()
        .filter_map(|n| n.get("file")?.as_str().map(str::to_owned))
        .collect();
    if let Some(clash) = nets
        .iter()
        .find(|n| listed.contains(&n.path) || n.path == PROJECT_FILE)
    {
        return Err(refuse(format!("the mission compiles into {}, which project.toml already lists: rename the mission file", clash.path)));
    }
    for file in &listed {
        let name = sources
            .read(file)
            .ok()
            .and_then(|text| toml::from_str::<toml::Table>(&text).ok())
            .and_then(|t| t.get("name")?.as_str().map(str::to_owned));
        if let Some(clash) = nets.iter().find(|n| Some(&n.net) == name.as_ref()) {
            return Err(refuse(format!("the mission compiles into a net `{}`, the name of the hand-written net of {file}: give the mission (or that net) another `name`", clash.net)));
        }
    }

    let mut project = comment_out(&text, key.span());
    if !project.ends_with('\n') {
        project.push('\n');
    }
    let project_lines = project.lines().count();
    project.push_str(&format!(
        "\n# The nets compiled from {path} (the `mission` above), in priority order.\n"
    ));
    for n in &nets {
        project.push_str(&format!(
            "[[net]]\nfile = \"{}\"\nactive = {}\n\n",
            n.path, n.active
        ));
    }
    Ok(Some(Compiled {
        mission: mission.file,
        project,
        project_lines,
        key: key.span(),
        nets,
    }))
}

/// `text` with every line the span touches commented out.
fn comment_out(text: &str, span: Range<usize>) -> String {
    let mut out = String::with_capacity(text.len() + 16);
    let mut at = 0;
    for line in text.split_inclusive('\n') {
        let end = at + line.len();
        let touched = at <= span.start && span.start < end
            || at < span.end && span.end <= end
            || span.start <= at && end <= span.end;
        if touched {
            out.push_str("# (compiled) ");
        }
        out.push_str(line);
        at = end;
    }
    out
}

/// Every event that may reach the mission from outside it: the profile's,
/// the project's `[events]`, results of its programs' functions and of
/// commands, `net_fault`, what the project's own net files emit, and what
/// the mission's actions produce (emits, timers, answers).
fn outside_events(
    sources: &dyn Sources,
    head: &Head,
    catalog: &Catalog,
    mission: &str,
) -> BTreeSet<String> {
    let mut known: BTreeSet<String> = catalog.keys().cloned().collect();
    known.extend(head.events.keys().cloned());
    known.extend(["command.ok", "command.failed", "net_fault"].map(str::to_owned));
    for (program, table) in &head.programs {
        if let Some(functions) = table.get("functions").and_then(toml::Value::as_table) {
            for function in functions.keys() {
                known.insert(format!("{program}.{function}.done"));
                known.insert(format!("{program}.{function}.failed"));
            }
        }
    }
    let mut actions = Vec::new();
    for entry in &head.net {
        let Some(file) = entry.get("file").and_then(toml::Value::as_str) else {
            continue;
        };
        if let Ok(text) = sources.read(file) {
            strings(
                &toml::from_str::<toml::Table>(&text)
                    .unwrap_or_default()
                    .into(),
                &mut actions,
            );
        }
    }
    strings(
        &toml::from_str::<toml::Table>(mission)
            .unwrap_or_default()
            .into(),
        &mut actions,
    );
    for a in actions {
        match action::parse(&a) {
            Ok(ActionSyntax::Emit { event, .. }) => {
                known.insert(event.0);
            }
            Ok(ActionSyntax::Timer { name, .. }) => {
                known.insert(name.0);
            }
            Ok(ActionSyntax::Ask { name, choices, .. }) => {
                known.insert(format!("{}.timeout", name.0));
                known.extend(choices.into_iter().map(|c| format!("{}.{}", name.0, c.0)));
            }
            _ => {}
        }
    }
    known
}

/// Every string in a TOML value (the actions are among them).
fn strings(value: &toml::Value, out: &mut Vec<String>) {
    match value {
        toml::Value::String(s) => out.push(s.clone()),
        toml::Value::Array(items) => items.iter().for_each(|v| strings(v, out)),
        toml::Value::Table(t) => t.values().for_each(|v| strings(v, out)),
        _ => {}
    }
}

/// Declared categories: the project's `[events]` over the catalog's.
fn categories(head: &Head, catalog: Option<&Catalog>) -> BTreeMap<String, Category> {
    let mut out = BTreeMap::new();
    for (name, decl) in catalog.into_iter().flatten() {
        if let Some(c) = decl.category {
            out.insert(name.clone(), c);
        }
    }
    for (name, decl) in &head.events {
        let word = match decl {
            toml::Value::String(s) => Some(s.as_str()),
            toml::Value::Table(t) => t.get("category").and_then(toml::Value::as_str),
            _ => None,
        };
        if let Some(c) = word.and_then(|w| w.parse().ok()) {
            out.insert(name.clone(), c);
        }
    }
    out
}

impl Compiled {
    /// The project as hand-written nets, `(path, text)`: project.toml
    /// listing the compiled nets (its `mission` key commented out), then
    /// each net file. What `petrel compile` writes.
    pub fn files(&self) -> Vec<(String, String)> {
        let mut out = vec![(PROJECT_FILE.to_owned(), self.project.clone())];
        out.extend(self.nets.iter().map(|n| (n.path.clone(), n.text.clone())));
        out
    }

    /// The project as the nets loader reads it: `inner`'s files, this
    /// project.toml and the generated nets.
    pub fn sources<'a>(&'a self, inner: &'a dyn Sources) -> CompiledSources<'a> {
        CompiledSources {
            compiled: self,
            inner,
        }
    }

    /// The loader's problems, those in generated text moved onto the
    /// mission line that made it (the generated place named after).
    pub fn relocate(&self, error: LoadError) -> LoadError {
        let problems = error
            .problems
            .into_iter()
            .map(|p| self.relocated(p))
            .collect();
        LoadError { problems }
    }

    fn relocated(&self, p: Problem) -> Problem {
        let (line, col) = p.line_col();
        if p.file.name == PROJECT_FILE && line > self.project_lines {
            return Problem {
                span: self.key.clone(),
                message: format!("{} (in the nets listed for the mission)", p.message),
                ..p
            };
        }
        let Some(net) = self.nets.iter().find(|n| n.path == p.file.name) else {
            return p;
        };
        let origin = net
            .origins
            .get(line.saturating_sub(1))
            .cloned()
            .unwrap_or(0..0);
        Problem::new(
            &self.mission,
            origin,
            format!(
                "{} (in {}:{line}:{col}, compiled from here)",
                p.message, net.path
            ),
        )
    }
}

/// [`Compiled::sources`].
pub struct CompiledSources<'a> {
    compiled: &'a Compiled,
    inner: &'a dyn Sources,
}

impl Sources for CompiledSources<'_> {
    fn read(&self, path: &str) -> Result<String, String> {
        if path == PROJECT_FILE {
            return Ok(self.compiled.project.clone());
        }
        match self.compiled.nets.iter().find(|n| n.path == path) {
            Some(n) => Ok(n.text.clone()),
            None => self.inner.read(path),
        }
    }
}

/// Loads a project, compiling its mission first if it names one: the
/// mission's own problems first (at the mission file's lines), else the
/// nets loader's on the compiled project, each in generated text moved
/// onto the mission line that made it. `catalog`: as `nets::load_with`
/// (`None`: as `nets::load`).
pub fn load(sources: &dyn Sources, catalog: Option<&Catalog>) -> Result<nets::Project, LoadError> {
    let load = |s: &dyn Sources| match catalog {
        Some(c) => nets::load_with(s, c),
        None => nets::load(s),
    };
    match compile_project(sources, catalog)? {
        None => load(sources),
        Some(compiled) => load(&compiled.sources(sources)).map_err(|e| compiled.relocate(e)),
    }
}

#[cfg(test)]
mod tests {
    use super::comment_out;

    #[test]
    fn commenting_out_keeps_every_line_and_its_number() {
        let text = "name = \"p\"\nmission = \"\"\"\nsteps.toml\"\"\"\n[events]\n";
        let start = text.find("\"\"\"").unwrap_or(0);
        let end = text.rfind("\"\"\"").map_or(0, |e| e + 3);
        let out = comment_out(text, start..end);
        assert_eq!(
            out,
            "name = \"p\"\n# (compiled) mission = \"\"\"\n# (compiled) steps.toml\"\"\"\n[events]\n"
        );
        assert_eq!(out.lines().count(), text.lines().count());
    }
}
