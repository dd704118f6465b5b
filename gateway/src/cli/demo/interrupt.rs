//! Ctrl-C before the flight: the demo's unpacked example removed.
//!
//! Until the onboard gateway watches SIGINT and SIGTERM itself (and stops
//! cleanly, the folder then removed by `demo::run`), the demo is unpacking
//! the example and exploring its nets: a signal would kill the process with
//! the folder left in the temporary directory. This watcher, armed from
//! before the unpacking until the gateway starts, removes the folder and
//! exits with 130, as a shell does for an interrupted command.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use crate::cli::run::Signals;

/// The exit status of a command stopped by SIGINT (128 + 2).
const INTERRUPTED: i32 = 130;

/// The watcher; once [`Watch::disarm`]ed, a signal is the gateway's to
/// handle.
pub(super) struct Watch {
    armed: Arc<AtomicBool>,
    folder: Arc<Mutex<Option<PathBuf>>>,
}

impl Watch {
    /// Watches SIGINT and SIGTERM from now on, on a thread of its own.
    /// `None` (and a warning) when the signals cannot be watched: the demo
    /// then runs as before, a signal killing it.
    pub(super) fn arm() -> Option<Watch> {
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(|e| tracing::warn!("cannot watch for Ctrl-C before the flight: {e}"))
            .ok()?;
        let mut signals = {
            let _in = runtime.enter();
            Signals::new()
                .map_err(|e| tracing::warn!("cannot watch for Ctrl-C before the flight: {e}"))
                .ok()?
        };
        let watch = Watch {
            armed: Arc::new(AtomicBool::new(true)),
            folder: Arc::new(Mutex::new(None)),
        };
        let (armed, folder) = (watch.armed.clone(), watch.folder.clone());
        let spawned = std::thread::Builder::new()
            .name("petrel-demo-interrupt".into())
            .spawn(move || {
                runtime.block_on(async move {
                    loop {
                        signals.recv().await;
                        if !armed.load(Ordering::SeqCst) {
                            continue;
                        }
                        if let Some(folder) = folder.lock().ok().and_then(|f| f.clone()) {
                            let _ = std::fs::remove_dir_all(folder);
                        }
                        say!("petrel demo: interrupted before the flight; nothing recorded");
                        std::process::exit(INTERRUPTED);
                    }
                })
            });
        match spawned {
            Ok(_) => Some(watch),
            Err(e) => {
                tracing::warn!("cannot watch for Ctrl-C before the flight: {e}");
                None
            }
        }
    }

    /// The folder to remove if interrupted.
    pub(super) fn remove_on_interrupt(&self, folder: PathBuf) {
        if let Ok(mut f) = self.folder.lock() {
            *f = Some(folder);
        }
    }

    /// The gateway watches the signals from now on.
    pub(super) fn disarm(&self) {
        self.armed.store(false, Ordering::SeqCst);
    }
}
