//! A project being edited: its files as read, the draft, each edit written
//! back safely, the project loaded again, and `petrel check` run in the
//! background on it.
//!
//! Writes are atomic (a temporary file beside the target, then a rename)
//! and refused when the file on disk is no longer the text the draft was
//! read from (someone else wrote it): the page says so and offers to
//! reload; nothing of theirs is overwritten. Such files are read again at
//! the page's next poll of the version anyway (half a second), so a
//! conflict needs an edit made within that time. An edit after which the
//! project no longer loads is still written (a person adding a
//! transition, then its arcs, passes through such states) and shown with
//! the loader's problems on their elements.
//!
//! Each edit written is kept (its files' texts before and after) so that
//! it can be undone (and redone): the files restored to their exact
//! bytes, under the same rule (refused when one changed on disk since).
//!
//! The check is a child `petrel check --json` on the folder; an edit of a
//! net kills the one still running (the newer draft supersedes it) and
//! starts another. The page never waits for it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex, MutexGuard};

use nets::Project;
use serde_json::{json, Value as Json};

use super::draft::Draft;
use super::locate::{locate, Element};
use super::op::{EditError, Op};
use super::positions;
use super::replay::{replay, Moment};
use super::sketch::sketch;

/// Why an edit was not made.
#[derive(Debug, thiserror::Error)]
pub enum Refusal {
    #[error("{0}")]
    Edit(#[from] EditError),
    #[error("{0} changed on disk since it was loaded: reload to edit it (your edit was not made; nothing was overwritten)")]
    Conflict(String),
    #[error("{0}")]
    Io(String),
    #[error("nothing to undo")]
    NothingToUndo,
    #[error("nothing to redo")]
    NothingToRedo,
}

/// How many edits can be undone (the oldest forgotten beyond): each
/// keeps the whole text of the files it changed, before and after.
pub const UNDO_DEPTH: usize = 200;

/// One edit as written: each file it changed, in the order written, with
/// its text before and after (None: absent).
#[derive(Debug, Clone)]
struct Change {
    what: String,
    files: Vec<(String, Option<String>, Option<String>)>,
}

/// One load problem, and the element it concerns.
#[derive(Debug, Clone, serde::Serialize)]
struct Problem {
    file: String,
    line: usize,
    col: usize,
    message: String,
    #[serde(flatten)]
    element: Element,
}

/// The background check's state.
#[derive(Debug, Clone, Default)]
enum Check {
    /// Not run: the project does not load.
    #[default]
    None,
    Running,
    Done {
        holds: bool,
        report: Json,
        /// The counterexample shown, and its moments.
        title: String,
        moments: Vec<Moment>,
    },
    Failed(String),
}

struct State {
    /// The text each file had when read or last written (None: absent).
    read: BTreeMap<String, Option<String>>,
    draft: Option<Draft>,
    /// Why there is no draft (a file that is not TOML, a missing file).
    broken: Option<String>,
    project: Option<Arc<Project>>,
    problems: Vec<Problem>,
    check: Check,
    /// Bumped by each check started: a finished check of an older one is
    /// dropped.
    generation: u64,
    child: Option<Child>,
    /// Bumped whenever what the page shows changes.
    version: u64,
    /// The edits of this session that can be undone, the last on top.
    undo: Vec<Change>,
    /// The edits undone that can be made again, the last undone on top.
    redo: Vec<Change>,
}

/// A project being edited.
pub struct Session {
    pub dir: PathBuf,
    state: Mutex<State>,
    /// Runs `petrel check`: this binary.
    checker: Option<PathBuf>,
}

fn read_file(dir: &Path, file: &str) -> Result<Option<String>, String> {
    match std::fs::read_to_string(dir.join(file)) {
        Ok(t) => Ok(Some(t)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(format!("cannot read {}: {e}", dir.join(file).display())),
    }
}

/// `text` in a temporary file beside `path` (hidden, named after it and
/// this process), synced: its path.
fn synced_beside(path: &Path, text: &str) -> std::io::Result<PathBuf> {
    use std::io::Write;
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.petrel-edit-{}", std::process::id()));
    let written = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(text.as_bytes())?;
        f.sync_all()
    })();
    match written {
        Ok(()) => Ok(tmp),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// Writes `text` to `path` atomically: a temporary file in the same
/// folder, synced, then renamed over it (keeping its permissions).
pub fn write_atomic(path: &Path, text: &str) -> std::io::Result<()> {
    let tmp = synced_beside(path, text)?;
    let result = (|| {
        if let Ok(meta) = std::fs::metadata(path) {
            std::fs::set_permissions(&tmp, meta.permissions())?;
        }
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Writes `text` to `path`, which must not exist: a temporary file beside
/// it, synced, then linked to `path` (which fails if `path` appeared
/// meanwhile: nothing of anyone's is overwritten) and unlinked.
pub fn write_new(path: &Path, text: &str) -> std::io::Result<()> {
    let tmp = synced_beside(path, text)?;
    let result = std::fs::hard_link(&tmp, path);
    let _ = std::fs::remove_file(&tmp);
    result
}

/// What a net deleted or renamed writes, `before` to `after`: (file, its
/// text, None when removed; new): new net files first, then the net files,
/// the layout and project.toml that changed, the files gone last.
fn all_writes(before: &Draft, after: &Draft) -> Vec<(String, Option<String>, bool)> {
    let mut writes = Vec::new();
    let old = |file: &str| before.nets.iter().find(|n| n.file == file);
    for net in &after.nets {
        if old(&net.file).is_none() {
            writes.push((net.file.clone(), Some(net.doc.to_string()), true));
        }
    }
    for net in &after.nets {
        let text = net.doc.to_string();
        if old(&net.file).is_some_and(|o| o.doc.to_string() != text) {
            writes.push((net.file.clone(), Some(text), false));
        }
    }
    let layout = after.positions.text();
    if layout != before.positions.text() {
        writes.push((positions::FILE.to_owned(), Some(layout), false));
    }
    let project = after.project.to_string();
    if project != before.project.to_string() {
        writes.push((nets::load::PROJECT_FILE.to_owned(), Some(project), false));
    }
    for net in &before.nets {
        if !after.nets.iter().any(|n| n.file == net.file) {
            writes.push((net.file.clone(), None, false));
        }
    }
    writes
}

/// The draft of the files as last read or written.
fn draft_from(read: &BTreeMap<String, Option<String>>) -> Result<Draft, String> {
    let text = |file: &str| read.get(file).cloned().flatten();
    let project =
        text(nets::load::PROJECT_FILE).ok_or_else(|| "project.toml is gone".to_owned())?;
    let mut nets_read = Vec::new();
    for file in Draft::net_files(&project).map_err(|e| e.to_string())? {
        let t =
            text(&file).ok_or_else(|| format!("{file}: no such file (project.toml lists it)"))?;
        nets_read.push((file, t));
    }
    let layout = text(positions::FILE).unwrap_or_default();
    Draft::parse(&project, &nets_read, &layout).map_err(|e| e.to_string())
}

impl Session {
    /// Opens the project in `dir`: an error when it has no project.toml or
    /// that file is not TOML.
    pub fn open(dir: &Path) -> Result<Arc<Session>, String> {
        let project = read_file(dir, nets::load::PROJECT_FILE)?.ok_or_else(|| {
            format!(
                "{} is not a Petrel project: it holds no {}",
                dir.display(),
                nets::load::PROJECT_FILE
            )
        })?;
        Draft::net_files(&project).map_err(|e| e.to_string())?;
        let session = Arc::new(Session {
            dir: dir.to_path_buf(),
            state: Mutex::new(State {
                read: BTreeMap::new(),
                draft: None,
                broken: None,
                project: None,
                problems: Vec::new(),
                check: Check::None,
                generation: 0,
                child: None,
                version: 0,
                undo: Vec::new(),
                redo: Vec::new(),
            }),
            checker: std::env::current_exe().ok(),
        });
        session.reload();
        Ok(session)
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Reads every file again (the draft's unwritten nothing: each edit is
    /// written as it is made), loads and checks.
    pub fn reload(self: &Arc<Self>) {
        let mut s = self.lock();
        let before = std::mem::take(&mut s.read);
        s.draft = None;
        s.broken = None;
        let result = (|| -> Result<Draft, String> {
            let project = read_file(&self.dir, nets::load::PROJECT_FILE)?
                .ok_or_else(|| "project.toml is gone".to_owned())?;
            s.read
                .insert(nets::load::PROJECT_FILE.into(), Some(project.clone()));
            let mut nets_read = Vec::new();
            for file in Draft::net_files(&project).map_err(|e| e.to_string())? {
                // a file missing is remembered as such: the next poll
                // notices it back
                let text = read_file(&self.dir, &file)?;
                s.read.insert(file.clone(), text.clone());
                let text =
                    text.ok_or_else(|| format!("{file}: no such file (project.toml lists it)"))?;
                nets_read.push((file, text));
            }
            let layout = read_file(&self.dir, positions::FILE)?;
            s.read.insert(positions::FILE.into(), layout.clone());
            Draft::parse(&project, &nets_read, layout.as_deref().unwrap_or(""))
                .map_err(|e| e.to_string())
        })();
        match result {
            Ok(d) => s.draft = Some(d),
            Err(e) => s.broken = Some(e),
        }
        // Files changed by someone else: what the history would undo is no
        // longer what is on disk.
        if s.read != before {
            s.undo.clear();
            s.redo.clear();
        }
        self.load_and_check(&mut s);
    }

    /// Makes one edit and writes it back.
    pub fn apply(self: &Arc<Self>, op: &Op) -> Result<(), Refusal> {
        let mut s = self.lock();
        let Some(draft) = &s.draft else {
            return Err(Refusal::Io(
                s.broken.clone().unwrap_or_else(|| "nothing to edit".into()),
            ));
        };
        let mut next = draft.clone();
        let applied = next.apply(op)?;
        // (file, text (None: removed), new): a net added's file first, then
        // project.toml; a net deleted or renamed: the new file first, the
        // one gone last (so that project.toml never names a missing file).
        let mut writes: Vec<(String, Option<String>, bool)> = Vec::new();
        if applied.all {
            writes = all_writes(draft, &next);
        }
        if let Some(n) = applied.net_file {
            writes.push((
                next.nets[n].file.clone(),
                Some(next.nets[n].doc.to_string()),
                applied.project,
            ));
        }
        if applied.layout {
            writes.push((
                positions::FILE.to_owned(),
                Some(next.positions.text()),
                false,
            ));
        }
        if applied.project {
            writes.push((
                nets::load::PROJECT_FILE.to_owned(),
                Some(next.project.to_string()),
                false,
            ));
        }
        // Refused if any file to write is not what it was when read, or a
        // new one exists.
        for (file, _, new) in &writes {
            let on_disk = read_file(&self.dir, file).map_err(Refusal::Io)?;
            if *new {
                if on_disk.is_some() || self.dir.join(file).exists() {
                    return Err(EditError::FileExists(file.clone()).into());
                }
            } else if s.read.get(file) != Some(&on_disk) {
                return Err(Refusal::Conflict(file.clone()));
            }
        }
        let mut change = Change {
            what: op.describe(),
            files: Vec::new(),
        };
        for (file, text, new) in &writes {
            let path = self.dir.join(file);
            let written = match text {
                Some(text) if *new => write_new(&path, text),
                Some(text) => write_atomic(&path, text),
                None => std::fs::remove_file(&path),
            };
            if let Err(e) = written {
                // What was written of the refused edit is put back (a
                // net's new file removed), as far as it can be.
                for (done, before, _) in change.files.iter().rev() {
                    let path = self.dir.join(done);
                    let _ = match before {
                        None => std::fs::remove_file(&path),
                        Some(before) => write_atomic(&path, before),
                    };
                }
                // The disk is the truth, read again.
                drop(s);
                self.reload();
                return Err(if *new && e.kind() == std::io::ErrorKind::AlreadyExists {
                    EditError::FileExists(file.clone()).into()
                } else {
                    Refusal::Io(format!("cannot write {file}: {e}"))
                });
            }
            let before = match text {
                Some(text) => s.read.insert(file.clone(), Some(text.clone())),
                None => s.read.remove(file),
            }
            .flatten();
            change.files.push((file.clone(), before, text.clone()));
        }
        if !change.files.is_empty() {
            s.redo.clear();
            s.undo.push(change);
            if s.undo.len() > UNDO_DEPTH {
                s.undo.remove(0);
            }
        }
        s.draft = Some(next);
        s.version += 1;
        // A move changes no net: nothing to load or check again.
        if applied.net_file.is_some() || applied.all {
            self.load_and_check(&mut s);
        }
        Ok(())
    }

    /// Undoes the last edit of the session not undone yet: each file it
    /// wrote back to its exact previous bytes (a net added: its file
    /// removed, project.toml as it was). Refused, nothing written, when one
    /// of them changed on disk since; the edit stays undoable. Returns what
    /// was undone.
    pub fn undo(self: &Arc<Self>) -> Result<String, Refusal> {
        self.step(false)
    }

    /// Makes again the edit undone last (none once an edit is made after
    /// it): each file back to the bytes the edit wrote, under the same
    /// rule.
    pub fn redo(self: &Arc<Self>) -> Result<String, Refusal> {
        self.step(true)
    }

    fn step(self: &Arc<Self>, redo: bool) -> Result<String, Refusal> {
        let mut s = self.lock();
        let top = if redo { s.redo.last() } else { s.undo.last() };
        let Some(change) = top.cloned() else {
            return Err(if redo {
                Refusal::NothingToRedo
            } else {
                Refusal::NothingToUndo
            });
        };
        // (file, its text on disk now, its text to write). Undone: the
        // last written first (project.toml before the net's file goes).
        let files: Vec<(&String, &Option<String>, &Option<String>)> = if redo {
            change.files.iter().map(|(f, b, a)| (f, b, a)).collect()
        } else {
            change
                .files
                .iter()
                .rev()
                .map(|(f, b, a)| (f, a, b))
                .collect()
        };
        for (file, now, _) in &files {
            let on_disk = read_file(&self.dir, file).map_err(Refusal::Io)?;
            if on_disk != **now {
                return Err(Refusal::Conflict((*file).clone()));
            }
        }
        for (file, now, to) in &files {
            let path = self.dir.join(file);
            let restored = match (now, to) {
                (None, Some(text)) => write_new(&path, text),
                (Some(_), Some(text)) => write_atomic(&path, text),
                (_, None) => std::fs::remove_file(&path),
            };
            if let Err(e) = restored {
                drop(s);
                self.reload();
                return Err(Refusal::Io(format!("cannot restore {file}: {e}")));
            }
            if to.is_none() && *file != positions::FILE {
                s.read.remove(*file);
            } else {
                s.read.insert((*file).clone(), (*to).clone());
            }
        }
        if redo {
            s.redo.pop();
            s.undo.push(change.clone());
        } else {
            s.undo.pop();
            s.redo.push(change.clone());
        }
        let files_changed: Vec<&str> = change.files.iter().map(|(f, _, _)| f.as_str()).collect();
        let next = match &s.draft {
            Some(d) => d.reread(&files_changed, |f| s.read.get(f).cloned().flatten()),
            None => None,
        };
        match next.map_or_else(|| draft_from(&s.read), Ok) {
            Ok(d) => {
                s.draft = Some(d);
                s.broken = None;
            }
            Err(e) => {
                s.draft = None;
                s.broken = Some(e);
            }
        }
        // A move undone changes no net: nothing to load or check again.
        if change.files.iter().all(|(f, _, _)| f == positions::FILE) {
            s.version += 1;
        } else {
            self.load_and_check(&mut s);
        }
        Ok(change.what)
    }

    /// Loads the project as `petrel check` does, keeps its problems, and
    /// starts the check (killing one still running).
    fn load_and_check(self: &Arc<Self>, s: &mut State) {
        s.version += 1;
        s.generation += 1;
        if let Some(mut child) = s.child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
        s.problems.clear();
        s.project = None;
        s.check = Check::None;
        if s.draft.is_none() {
            return;
        }
        match load(&self.dir) {
            Ok(project) => s.project = Some(project),
            Err(Loaded::Problems(e)) => {
                s.problems = e
                    .problems
                    .iter()
                    .map(|p| {
                        let (line, col) = p.line_col();
                        let element = s
                            .draft
                            .as_ref()
                            .and_then(|d| d.nets.iter().find(|n| n.file == p.file.name))
                            .map_or(
                                Element {
                                    net: None,
                                    kind: None,
                                    name: None,
                                },
                                |n| locate(n.name(), &p.file.text, p.span.start),
                            );
                        Problem {
                            file: p.file.name.clone(),
                            line,
                            col,
                            message: p.message.clone(),
                            element,
                        }
                    })
                    .collect();
                return;
            }
            Err(Loaded::Other(e)) => {
                s.problems = vec![Problem {
                    file: nets::load::PROJECT_FILE.into(),
                    line: 1,
                    col: 1,
                    message: e,
                    element: Element {
                        net: None,
                        kind: None,
                        name: None,
                    },
                }];
                return;
            }
        }
        let Some(exe) = &self.checker else {
            s.check = Check::Failed("cannot find the petrel binary to run the check".into());
            return;
        };
        let mut command = Command::new(exe);
        command
            .arg("check")
            .arg("--json")
            .arg(&self.dir)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        die_with_parent(&mut command);
        let child = command.spawn();
        let mut child = match child {
            Ok(c) => c,
            Err(e) => {
                s.check = Check::Failed(format!("cannot start petrel check: {e}"));
                return;
            }
        };
        let (Some(mut out), Some(mut err)) = (child.stdout.take(), child.stderr.take()) else {
            let _ = child.kill();
            let _ = child.wait();
            return;
        };
        s.check = Check::Running;
        s.child = Some(child);
        let generation = s.generation;
        let session = Arc::clone(self);
        let spawned = std::thread::Builder::new()
            .name("petrel-edit-check".into())
            .spawn(move || {
                use std::io::Read;
                let mut text = String::new();
                let mut errors = String::new();
                let _ = out.read_to_string(&mut text);
                let _ = err.read_to_string(&mut errors);
                session.checked(generation, &text, &errors);
            });
        if let Err(e) = spawned {
            s.check = Check::Failed(format!("cannot start the check's thread: {e}"));
        }
    }

    /// A check finished (its output read to the end).
    fn checked(&self, generation: u64, out: &str, errors: &str) {
        let mut s = self.lock();
        if s.generation != generation {
            return; // superseded (and killed)
        }
        if let Some(mut child) = s.child.take() {
            let _ = child.wait();
        }
        s.version += 1;
        let Ok(report) = serde_json::from_str::<Json>(out.trim()) else {
            let why = errors.trim();
            s.check = Check::Failed(if why.is_empty() {
                "petrel check gave no report".into()
            } else {
                why.lines().take(20).collect::<Vec<_>>().join("\n")
            });
            return;
        };
        let holds = report["holds"].as_bool().unwrap_or(false);
        let (title, steps) = counterexample(&report);
        let moments = match (&s.project, &steps) {
            (Some(p), Some(steps)) => replay(p, steps),
            _ => Vec::new(),
        };
        s.check = Check::Done {
            holds,
            report,
            title,
            moments,
        };
    }

    /// What the page shows, and its version.
    pub fn page(&self) -> Json {
        let s = self.lock();
        let name = s
            .draft
            .as_ref()
            .map(|d| d.name.clone())
            .filter(|n| !n.is_empty())
            .unwrap_or_else(|| {
                self.dir
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default()
            });
        let nets: Vec<Json> = s
            .draft
            .as_ref()
            .map(|d| (0..d.nets.len()).map(|n| sketch(d, n)).collect())
            .unwrap_or_default();
        let events: Vec<String> = s
            .project
            .as_ref()
            .map(|p| {
                let mut e: Vec<String> = p.events.keys().cloned().collect();
                e.sort();
                e
            })
            .unwrap_or_default();
        let check = match &s.check {
            Check::None => json!({"state": "none"}),
            Check::Running => json!({"state": "running"}),
            Check::Failed(why) => json!({"state": "failed", "why": why}),
            Check::Done {
                holds,
                report,
                title,
                moments,
            } => json!({"state": "done", "holds": holds, "states": report["states"],
                        "seconds": report["seconds"], "warnings": report["warnings"],
                        "title": title, "moments": moments}),
        };
        json!({"mode": "edit", "name": name, "dir": self.dir.display().to_string(),
               "version": s.version, "nets": nets, "broken": s.broken,
               "globals": s.draft.as_ref().map(|d| d.globals.clone()).unwrap_or_default(),
               "events": events, "loads": s.project.is_some(), "problems": s.problems,
               "check": check, "undo": s.undo.last().map(|c| c.what.clone()),
               "redo": s.redo.last().map(|c| c.what.clone()),
               "undo_depth": s.undo.len(), "petrel": env!("CARGO_PKG_VERSION")})
    }

    /// What the page polls (every half second): the version of what it
    /// shows. A file changed on disk since it was read or written here
    /// (by a text editor, `git checkout`…) is read again first, as Reload
    /// does: the page then shows it within a poll, and the next edit is
    /// made on it.
    pub fn version(self: &Arc<Self>) -> u64 {
        if self.changed_on_disk() {
            self.reload();
        }
        self.lock().version
    }

    /// Whether a file the draft was read from is no longer on disk as it
    /// was read or written (or has appeared, or is gone). A file that
    /// cannot be read now does not count: the next edit reports it.
    fn changed_on_disk(&self) -> bool {
        let s = self.lock();
        s.read
            .iter()
            .any(|(file, text)| read_file(&self.dir, file).is_ok_and(|now| now != *text))
    }

    /// Generates the programs' skeletons (as `petrel stubs`) in `out`
    /// (relative to the project folder).
    pub fn stubs(&self, lang: &str, out: &str, force: bool) -> Result<Vec<String>, String> {
        let lang = match lang {
            "python" => petrel_core::programs::stubs::Lang::Python,
            "rust" => petrel_core::programs::stubs::Lang::Rust,
            other => return Err(format!("no stubs in `{other}`: python or rust")),
        };
        let project = self
            .lock()
            .project
            .clone()
            .ok_or_else(|| "the project does not load: fix its problems first".to_owned())?;
        let out = inside(&self.dir, out)?;
        let written = petrel_core::programs::stubs::write(&self.dir, &project, lang, &out, force)?;
        Ok(written.iter().map(|p| p.display().to_string()).collect())
    }
}

/// The folder of the project at `dir` that `out` names (empty: `stubs`):
/// a relative path without `..`, which stays inside the project once its
/// links are followed. The page may write stubs there and nowhere else.
fn inside(dir: &Path, out: &str) -> Result<PathBuf, String> {
    use std::path::Component;
    let out = match out.trim() {
        "" => "stubs",
        out => out,
    };
    let relative = Path::new(out);
    if !relative
        .components()
        .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(format!(
            "stubs go into a folder of the project: `{out}` is not a path inside it (no `/` at the start, no `..`)"
        ));
    }
    let root = dir
        .canonicalize()
        .map_err(|e| format!("cannot read {}: {e}", dir.display()))?;
    // The deepest part that exists, with its links followed, must be in
    // the project (a link inside it may point anywhere).
    let wanted = dir.join(relative);
    let mut existing = wanted.as_path();
    while !existing.exists() {
        match existing.parent() {
            Some(parent) => existing = parent,
            None => break,
        }
    }
    let real = existing
        .canonicalize()
        .map_err(|e| format!("cannot read {}: {e}", existing.display()))?;
    if !real.starts_with(&root) {
        return Err(format!(
            "stubs go into a folder of the project: `{out}` leads to {}",
            real.display()
        ));
    }
    Ok(wanted)
}

impl Drop for Session {
    fn drop(&mut self) {
        let mut s = self.lock();
        if let Some(mut child) = s.child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// The check dies with the editor, however it ends (a kill included):
/// SIGKILL when the thread that started it exits (the server's, or the
/// main thread, both living as long as the editor).
#[cfg(target_os = "linux")]
fn die_with_parent(command: &mut Command) {
    use std::os::unix::process::CommandExt;
    // SAFETY: between fork and exec the closure only calls prctl(2), which
    // is async-signal-safe, takes plain integers and touches no memory of
    // the parent.
    unsafe {
        command.pre_exec(|| {
            libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL);
            Ok(())
        });
    }
}

#[cfg(not(target_os = "linux"))]
fn die_with_parent(_command: &mut Command) {}

enum Loaded {
    Problems(nets::source::LoadError),
    Other(String),
}

/// Loads the project knowing its elaboration profile's events, as `petrel
/// check` does.
fn load(dir: &Path) -> Result<Arc<Project>, Loaded> {
    let setting = petrel_core::project::gateway_setting(dir, "profile")
        .map_err(|e| Loaded::Other(format!("{e}")))?;
    let layers =
        petrel_core::profile::Layers::pick(None, Some((dir, setting.as_deref())), "ardupilot")
            .map_err(|e| Loaded::Other(format!("{e}")))?;
    let profile = layers.load().map_err(|problems| {
        Loaded::Other(format!(
            "the elaboration profile does not load:\n{problems}"
        ))
    })?;
    nets::load_with(
        &petrel_core::project::Folder(dir.to_path_buf()),
        &petrel_core::project::catalog(&profile),
    )
    .map(Arc::new)
    .map_err(Loaded::Problems)
}

/// The counterexample to show from a check's report: the project's double
/// token, deadlock or livelock, else the first net's.
fn counterexample(report: &Json) -> (String, Option<Vec<String>>) {
    let steps = |v: &Json| -> Option<Vec<String>> {
        v.as_array().map(|a| {
            a.iter()
                .filter_map(|s| s.as_str().map(str::to_owned))
                .collect()
        })
    };
    let pick = |r: &Json, whose: &str| -> Option<(String, Vec<String>)> {
        if let Some(s) = steps(&r["unsafe_example"]) {
            return Some((format!("{whose}: a double token"), s));
        }
        if let Some(s) = steps(&r["deadlock_example"]) {
            return Some((format!("{whose}: a deadlock"), s));
        }
        r["livelocks"]
            .as_array()
            .and_then(|l| l.first())
            .and_then(steps)
            .map(|s| (format!("{whose}: a livelock"), s))
    };
    if let Some((t, s)) = pick(report, "the project") {
        return (t, Some(s));
    }
    if let Some(nets) = report["nets"].as_object() {
        for (name, r) in nets {
            if let Some((t, s)) = pick(r, &format!("net {name}")) {
                return (t, Some(s));
            }
        }
    }
    (String::new(), None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_atomic_write_replaces_the_file_keeps_its_mode_and_leaves_nothing() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = dir.path().join("a.toml");
        std::fs::write(&path, "old").unwrap_or_else(|e| panic!("{e}"));
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o640))
            .unwrap_or_else(|e| panic!("{e}"));
        write_atomic(&path, "new").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(std::fs::read_to_string(&path).ok().as_deref(), Some("new"));
        let mode = std::fs::metadata(&path)
            .map(|m| m.permissions().mode() & 0o777)
            .ok();
        assert_eq!(mode, Some(0o640));
        let names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap_or_else(|e| panic!("{e}"))
            .filter_map(Result::ok)
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, vec!["a.toml"]);
        // A folder that does not exist: an error, no panic.
        assert!(write_atomic(&dir.path().join("no/such/b.toml"), "x").is_err());
    }

    #[test]
    fn a_new_file_is_written_whole_and_never_replaces_one() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = dir.path().join("N.toml");
        write_new(&path, "name = \"N\"\n").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            std::fs::read_to_string(&path).ok().as_deref(),
            Some("name = \"N\"\n")
        );
        // There already: refused, theirs kept.
        std::fs::write(&path, "theirs").unwrap_or_else(|e| panic!("{e}"));
        let e = write_new(&path, "ours").err().map(|e| e.kind());
        assert_eq!(e, Some(std::io::ErrorKind::AlreadyExists));
        assert_eq!(
            std::fs::read_to_string(&path).ok().as_deref(),
            Some("theirs")
        );
        let names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap_or_else(|e| panic!("{e}"))
            .filter_map(Result::ok)
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, vec!["N.toml"], "no temporary file left");
    }

    #[test]
    fn the_counterexample_shown_is_the_projects_first_then_a_nets() {
        let r = json!({"unsafe_example": null, "deadlock_example": ["a → N.t"], "livelocks": [],
                       "nets": {"N": {"unsafe_example": ["b"]}}});
        assert_eq!(
            counterexample(&r),
            (
                "the project: a deadlock".into(),
                Some(vec!["a → N.t".into()])
            )
        );
        let r = json!({"unsafe_example": null, "deadlock_example": null, "livelocks": [],
                       "nets": {"N": {"unsafe_example": null, "deadlock_example": null, "livelocks": [["x", "y"]]}}});
        assert_eq!(
            counterexample(&r),
            (
                "net N: a livelock".into(),
                Some(vec!["x".into(), "y".into()])
            )
        );
        assert_eq!(counterexample(&json!({"livelocks": []})).1, None);
    }

    #[test]
    fn stubs_go_into_a_folder_of_the_project_only() {
        let outside = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let project = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let dir = project.path();
        std::fs::create_dir(dir.join("tools")).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(inside(dir, "").ok(), Some(dir.join("stubs")));
        assert_eq!(inside(dir, " stubs ").ok(), Some(dir.join("stubs")));
        assert_eq!(inside(dir, "tools/new").ok(), Some(dir.join("tools/new")));
        assert_eq!(inside(dir, "./tools").ok(), Some(dir.join("./tools")));
        let elsewhere = outside.path().display().to_string();
        for out in [
            elsewhere.as_str(),
            "../x",
            "../../x",
            "tools/../../x",
            "/tmp",
        ] {
            let e = inside(dir, out).err().unwrap_or_default();
            assert!(e.contains("a folder of the project"), "{out}: {e}");
        }
        // A link inside the project that leads out of it.
        std::os::unix::fs::symlink(outside.path(), dir.join("out"))
            .unwrap_or_else(|e| panic!("{e}"));
        for out in ["out", "out/deeper"] {
            let e = inside(dir, out).err().unwrap_or_default();
            assert!(e.contains("leads to"), "{out}: {e}");
        }
    }
}
