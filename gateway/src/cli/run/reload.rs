//! A new version of the project in flight (docs/run.md, "A new version in
//! flight"): on SIGHUP (`petrel reload`, systemd's `reload`), the project
//! folder is read again, loaded and checked from its own start (the
//! pre-flight check, remembered like `run`'s) on a thread of its own; the
//! core ([`petrel_core::version`]) then has it proved from the running
//! state, on another. Both threads take the normal policy: a loop given a
//! real-time priority (docs/run.md "On a busy computer") is never
//! preempted by them, and on a loaded computer they still get their share
//! (in the batch policy a proof took five times as long beside a flight at
//! ten times the wall). The driver only moves the results back to the
//! core; the decisions are the core's.

use std::path::PathBuf;
use std::sync::Arc;

use nets::Project;
use petrel_core::version::{Files, Proof, Proved};
use tokio::sync::mpsc;

use crate::preflight::{Inputs, Preflight};

/// What a background thread brings back to the loop.
pub(super) enum Background {
    /// The project read again: loaded and checked from its start, or why
    /// not (for people).
    Loaded(Result<(Arc<Project>, Files), String>),
    /// A proof's answer.
    Proved(Box<Proved>),
    /// A version sent up from the ground (its upload number), unpacked,
    /// loaded and checked, or why not.
    Uploaded(u64, Result<(Arc<Project>, Files), String>),
}

/// Reading the project again and running the core's proofs, off the loop.
pub(super) struct Reload {
    dir: PathBuf,
    catalog: nets::load::Catalog,
    layers: Vec<(String, String)>,
    /// The version is checked from its own start, as `run` checked the
    /// first (not with `--unchecked`).
    check: bool,
    tx: mpsc::UnboundedSender<Background>,
    /// A load under way (a second SIGHUP meanwhile loads again after it).
    loading: bool,
    again: bool,
}

impl Reload {
    pub(super) fn new(
        dir: PathBuf,
        catalog: nets::load::Catalog,
        layers: Vec<(String, String)>,
        check: bool,
    ) -> (Reload, mpsc::UnboundedReceiver<Background>) {
        let (tx, rx) = mpsc::unbounded_channel();
        let reload = Reload {
            dir,
            catalog,
            layers,
            check,
            tx,
            loading: false,
            again: false,
        };
        (reload, rx)
    }

    /// SIGHUP: read the project again (once the load under way, if any,
    /// is back).
    pub(super) fn request(&mut self) {
        if self.loading {
            self.again = true;
            return;
        }
        self.loading = true;
        let (dir, catalog, layers, check) = (
            self.dir.clone(),
            self.catalog.clone(),
            self.layers.clone(),
            self.check,
        );
        let tx = self.tx.clone();
        let spawned = std::thread::Builder::new()
            .name("petrel-reload".into())
            .spawn(move || {
                let _ = crate::scheduling::normal();
                let _ = tx.send(Background::Loaded(load(&dir, &catalog, &layers, check)));
            });
        if let Err(e) = spawned {
            self.loading = false;
            let _ = self.tx.send(Background::Loaded(Err(format!(
                "cannot start the thread that reads it: {e}"
            ))));
        }
    }

    /// A load came back: whether another was asked for meanwhile (then it
    /// starts now).
    pub(super) fn loaded(&mut self) {
        self.loading = false;
        if std::mem::take(&mut self.again) {
            self.request();
        }
    }

    /// A version sent up whole from the ground: unpacked, loaded and
    /// checked from its start on a thread of its own.
    pub(super) fn uploaded(&self, upload: u64, bytes: Vec<u8>) {
        let (catalog, layers, check) = (self.catalog.clone(), self.layers.clone(), self.check);
        let tx = self.tx.clone();
        let spawned = std::thread::Builder::new()
            .name("petrel-upload".into())
            .spawn(move || {
                let _ = crate::scheduling::normal();
                let loaded = crate::upload::unpack(&bytes)
                    .and_then(|files| load_files(files, &catalog, &layers, check));
                let _ = tx.send(Background::Uploaded(upload, loaded));
            });
        if let Err(e) = spawned {
            let _ = self.tx.send(Background::Uploaded(
                upload,
                Err(format!("cannot start the thread that loads it: {e}")),
            ));
        }
    }

    /// Runs one of the core's proofs on a thread of its own.
    pub(super) fn prove(&self, proof: Proof) {
        let tx = self.tx.clone();
        let id = proof.id;
        let state = proof.state.clone();
        let spawned = std::thread::Builder::new()
            .name("petrel-proof".into())
            .spawn(move || {
                let _ = crate::scheduling::normal();
                let _ = tx.send(Background::Proved(Box::new(proof.run())));
            });
        if let Err(e) = spawned {
            let _ = self.tx.send(Background::Proved(Box::new(Proved {
                id,
                state,
                refusals: vec![format!("cannot start the thread that proves it: {e}")],
            })));
        }
    }
}

/// A version's files loaded with `catalog` (as the loader reads a folder)
/// and, with `check`, checked from its start.
fn load_files(
    files: Vec<(String, String)>,
    catalog: &nets::load::Catalog,
    layers: &[(String, String)],
    check: bool,
) -> Result<(Arc<Project>, Files), String> {
    let sources: std::collections::BTreeMap<String, String> = files.iter().cloned().collect();
    // A mission project's version compiles its mission first.
    let project = petrel_mission::load(&sources, Some(catalog)).map_err(|e| {
        e.problems
            .iter()
            .map(|p| format!("{}", miette::Report::new(p.clone())))
            .map(|p| p.trim_end().to_owned())
            .collect::<Vec<_>>()
            .join("\n")
    })?;
    let project = Arc::new(project);
    if check {
        checked(&project, &files, layers)?;
    }
    Ok((project, files))
}

/// `project` checked from its start as `run` checks before the flight.
fn checked(
    project: &Arc<Project>,
    files: &[(String, String)],
    layers: &[(String, String)],
) -> Result<(), String> {
    let inputs = Inputs { files, layers };
    if let Preflight::Failed(report) = crate::preflight::check_project(project, &inputs, false) {
        return Err(format!(
            "{}\nit fails `petrel check`",
            crate::cli::check_project::human(&project.name, &report, 0.0).trim_end()
        ));
    }
    Ok(())
}

/// The project in `dir` loaded with `catalog` and, with `check`, checked
/// from its start as `run` checks before the flight.
fn load(
    dir: &std::path::Path,
    catalog: &nets::load::Catalog,
    layers: &[(String, String)],
    check: bool,
) -> Result<(Arc<Project>, Files), String> {
    let (project, files) = petrel_core::project::load_read(dir, catalog)
        .map_err(|e| petrel_core::project::for_people(&e))?;
    if check {
        checked(&project, &files, layers)?;
    }
    Ok((project, files))
}
