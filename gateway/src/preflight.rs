//! The pre-flight check of `petrel run` and `petrel demo` (and of any verb
//! that plays a project for real, such as the ground mirror): the
//! project-level verdict of `petrel check`, remembered once it held.
//!
//! A check that held is remembered under a SHA-256 digest of exactly what
//! the verdict depends on: the files the loader read (project.toml without
//! its `[gateway]` table, which the nets never see, and every net file),
//! the elaboration profile's layers (their text), the check's own limits,
//! and this Petrel (its version and its executable's size and modification
//! time, so that a rebuilt verifier never trusts an older one's verdict).
//! When the same digest comes again the exploration is skipped. A failed
//! check is never remembered; an entry that cannot be read, does not parse
//! or does not name its own digest is ignored and replaced, never believed.
//!
//! Entries live in the user's cache directory (`$XDG_CACHE_HOME/petrel/
//! preflight/`, else `~/.cache/petrel/preflight/`), one small JSON file per
//! digest. No cache directory, or one that cannot be written: the project is
//! checked every time, with a warning in the log.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use nets::verify::project::{check, Options, ProjectReport};
use nets::Project;
use serde_json::json;
use sha2::{Digest as _, Sha256};

/// What the digest covers: the project's files as the loader read them and
/// the profile's layers.
pub struct Inputs<'a> {
    /// `(path, text)` of every file the loader read, in the order read.
    pub files: &'a [(String, String)],
    /// The elaboration profile's layers, `(name, text)`, in order.
    pub layers: &'a [(String, String)],
}

/// The outcome of the pre-flight check.
pub enum Preflight {
    /// It held before on the same inputs: not explored again.
    Remembered { digest: String },
    /// Explored now; it held (and is now remembered, if the cache could be
    /// written).
    Held {
        states: usize,
        edges: usize,
        seconds: f64,
    },
    /// Explored now; it does not hold.
    Failed(Box<ProjectReport>),
}

/// The options `petrel run` checks with: each net in its project (its
/// verdict counts) but not alone (information only).
fn options() -> Options<'static> {
    Options {
        alone: false,
        threads: threads(None),
        ..Options::default()
    }
}

/// Checks `project` before it flies, unless a check of the same inputs
/// held before (`recheck` explores anyway).
pub fn check_project(project: &Arc<Project>, inputs: &Inputs, recheck: bool) -> Preflight {
    let options = options();
    let digest = digest(inputs, &options);
    let entry = cache_dir().map(|d| d.join(format!("{digest}.json")));
    if let (Some(entry), false) = (&entry, recheck) {
        if remembered(entry, &digest) {
            return Preflight::Remembered { digest };
        }
    }
    let start = Instant::now();
    let report = check(project, &options);
    let seconds = start.elapsed().as_secs_f64();
    give_back_memory();
    if !report.holds() {
        return Preflight::Failed(Box::new(report));
    }
    if let Some(entry) = &entry {
        remember(entry, &digest, &report);
    }
    Preflight::Held {
        states: report.project.states,
        edges: report.project.edges,
        seconds,
    }
}

/// Gives the memory the exploration freed back to the system. glibc's
/// allocator keeps it for the process otherwise: `petrel run` on the
/// flight-test example held 75 MB for the whole flight after a check that
/// peaked at 112 MB, against 20 MB when the check was remembered (the hour
/// soak's 72-75 MB of 2026-12-07, docs/reliability.md).
fn give_back_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only hands the free pages of glibc's heaps back
    // to the kernel; it touches no memory in use.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Remembers a check of `petrel check` that held, when it is the check
/// `petrel run` makes (the same limits and reductions; the digest then
/// covers the same inputs): a crew that checks the project before the
/// flight does not pay for the exploration again when the gateway starts.
/// Whether it was remembered.
pub fn remember_held(inputs: &Inputs, checked: &Options, report: &ProjectReport) -> bool {
    let run = options();
    let same = checked.max_states == run.max_states
        && checked.each_net == run.each_net
        && checked.symmetry == run.symmetry
        && checked.partial_order == run.partial_order
        && checked.proviso == run.proviso;
    if !same || !report.holds() {
        return false;
    }
    let digest = digest(inputs, &run);
    match cache_dir() {
        Some(dir) => remember(&dir.join(format!("{digest}.json")), &digest, report),
        None => false,
    }
}

/// The digest of what the verdict depends on (see the module doc).
pub fn digest(inputs: &Inputs, options: &Options) -> String {
    let mut h = Sha256::new();
    let mut part = |bytes: &[u8]| {
        h.update((bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    };
    part(b"petrel pre-flight check 1");
    part(env!("CARGO_PKG_VERSION").as_bytes());
    part(executable_identity().as_bytes());
    part(
        format!(
            "max_states {} each_net {}",
            options.max_states, options.each_net
        )
        .as_bytes(),
    );
    for (path, text) in inputs.files {
        part(path.as_bytes());
        if path == nets::load::PROJECT_FILE {
            part(without_gateway(text).as_bytes());
        } else {
            part(text.as_bytes());
        }
    }
    part(b"profile");
    // A layer's name is where it was found: only its text counts.
    for (_, text) in inputs.layers {
        part(text.as_bytes());
    }
    let bytes = h.finalize();
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// project.toml without its `[gateway]` table (the nets never read it), in
/// a canonical form; the text itself if it does not parse (the loader then
/// refused it already).
fn without_gateway(text: &str) -> String {
    match toml::from_str::<toml::Table>(text) {
        Ok(mut table) => {
            table.remove("gateway");
            toml::to_string(&table).unwrap_or_else(|_| text.to_owned())
        }
        Err(_) => text.to_owned(),
    }
}

/// This executable's size and modification time (empty if unknown).
fn executable_identity() -> String {
    let Ok(exe) = std::env::current_exe() else {
        return String::new();
    };
    let Ok(meta) = std::fs::metadata(&exe) else {
        return String::new();
    };
    let modified = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos());
    format!("{} {modified}", meta.len())
}

/// The cache directory of pre-flight verdicts, if the user has one.
pub fn cache_dir() -> Option<PathBuf> {
    let base = match std::env::var_os("XDG_CACHE_HOME") {
        Some(d) if Path::new(&d).is_absolute() => PathBuf::from(d),
        _ => PathBuf::from(std::env::var_os("HOME")?).join(".cache"),
    };
    Some(base.join("petrel").join("preflight"))
}

/// Whether `entry` says, readably, that the check of `digest` held.
fn remembered(entry: &Path, digest: &str) -> bool {
    let Ok(text) = std::fs::read_to_string(entry) else {
        return false;
    };
    let ok = serde_json::from_str::<serde_json::Value>(&text)
        .is_ok_and(|v| v["format"] == 1 && v["digest"] == digest && v["holds"] == true);
    if !ok {
        tracing::warn!(
            "ignoring the unreadable pre-flight cache entry {}",
            entry.display()
        );
    }
    ok
}

/// Writes the entry of a check that held (atomically: a temporary file
/// renamed), or warns; whether it was written.
fn remember(entry: &Path, digest: &str, report: &ProjectReport) -> bool {
    let text = json!({
        "format": 1,
        "digest": digest,
        "holds": true,
        "states": report.project.states,
        "edges": report.project.edges,
        "petrel": env!("CARGO_PKG_VERSION"),
    })
    .to_string();
    let write = || -> std::io::Result<()> {
        let dir = entry.parent().unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir)?;
        let tmp = dir.join(format!(".{digest}.{}.tmp", std::process::id()));
        std::fs::write(&tmp, text.as_bytes())?;
        std::fs::rename(&tmp, entry)
    };
    match write() {
        Ok(()) => true,
        Err(e) => {
            tracing::warn!(
                "cannot remember the pre-flight check in {}: {e}",
                entry.display()
            );
            false
        }
    }
}

/// `--threads`, else the number of cores (at most 16).
pub fn threads(asked: Option<u16>) -> usize {
    match asked {
        Some(n) => usize::from(n),
        None => std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .min(16),
    }
}
