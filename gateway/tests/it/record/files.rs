//! The folder of the recorded flights shared by the tests, the `petrel`
//! binary, and rewriting a recording (tampering).

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, OnceLock, PoisonError};
use std::time::Duration;

use super::flight::{self, Fed};
use super::record::recorder::{Options, Recorder, Report};
use super::scratch::Scratch;

/// The folder of the recordings several tests share, made once for the
/// process.
static SHARED: Mutex<Option<Scratch>> = Mutex::new(None);
/// Whether any test of the process panicked (failed).
static PANICKED: AtomicBool = AtomicBool::new(false);

/// `name` in the folder of the recordings several tests share. They live
/// in `static`s, which are never dropped, so the folder is removed when the
/// process exits; unless a test failed, then it is kept and its path
/// printed, as a test's own scratch folder is.
fn shared(name: &str) -> PathBuf {
    let mut shared = SHARED.lock().unwrap_or_else(PoisonError::into_inner);
    let dir = shared.get_or_insert_with(|| {
        let hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            PANICKED.store(true, Ordering::Relaxed);
            hook(info)
        }));
        // SAFETY: `atexit` is given a plain function, which does not unwind.
        unsafe { libc::atexit(remove_shared) };
        Scratch::new("record")
    });
    dir.join(name)
}

/// At exit: removes the shared folder, or keeps it if a test failed.
extern "C" fn remove_shared() {
    let shared = SHARED.lock().unwrap_or_else(PoisonError::into_inner).take();
    if let Some(dir) = shared {
        if PANICKED.load(Ordering::Relaxed) {
            let kept = dir.keep();
            let _ = writeln!(
                std::io::stderr(),
                "shared recordings kept for the failed tests: {}",
                kept.display()
            );
        }
    }
}

/// Runs `petrel` from the workspace root: (exit code, stdout, stderr).
pub fn petrel(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .args(args)
        .current_dir(flight::root())
        .output()
        .expect("petrel runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `petrel replay FILE examples/uav-survey --check-against [more]`.
pub fn check(file: &Path, more: &[&str]) -> (i32, String, String) {
    let mut args = vec![
        "replay",
        file.to_str().expect("utf-8 path"),
        "examples/uav-survey",
        "--check-against",
    ];
    args.extend_from_slice(more);
    petrel(&args)
}

/// A recorded flight.
pub struct Flown {
    pub path: PathBuf,
    pub fed: Fed,
    pub report: Report,
}

/// Records the first `limit` frames of the SITL flight into `name`.
pub fn record(name: &str, limit: usize, options: Options) -> Option<Flown> {
    let tlog = flight::tlog()?;
    let path = shared(name);
    let options = Options {
        profile: "ardupilot".into(),
        ..options
    };
    let recorder = Recorder::create(&path, flight::project(), options).expect("recorder");
    let fed = flight::fly(&tlog, &recorder, limit, None);
    let report = recorder.finish().expect("finished");
    Some(Flown { path, fed, report })
}

/// The whole SITL flight, recorded once for every test that reads it.
pub fn whole_flight() -> Option<&'static Flown> {
    static FLOWN: OnceLock<Option<Flown>> = OnceLock::new();
    FLOWN
        .get_or_init(|| {
            record(
                "whole.mcap",
                usize::MAX,
                Options {
                    // Enough room for the whole flight: nothing dropped.
                    queue: 1 << 20,
                    ..Options::default()
                },
            )
        })
        .as_ref()
}

/// The start of the flight with a chunk closed after every step (many
/// chunks, for cutting).
pub fn chunky_flight() -> Option<&'static Flown> {
    static FLOWN: OnceLock<Option<Flown>> = OnceLock::new();
    FLOWN
        .get_or_init(|| {
            record(
                "chunky.mcap",
                3_000,
                Options {
                    queue: 1 << 20,
                    flush_every: Duration::ZERO,
                    ..Options::default()
                },
            )
        })
        .as_ref()
}

/// Copies a recording into `out`, letting `edit` change any JSON message
/// (it returns whether it did); the summary is written anew.
pub fn rewrite(
    input: &Path,
    out: &Path,
    mut edit: impl FnMut(&str, &mut serde_json::Value) -> bool,
) -> usize {
    let bytes = std::fs::read(input).expect("recording");
    let file = std::fs::File::create(out).expect("output");
    let mut writer = mcap::Writer::new(BufWriter::new(file)).expect("writer");
    let mut edits = 0;
    for message in mcap::MessageStream::new(&bytes).expect("MCAP") {
        let mut message = message.expect("message");
        if message.channel.message_encoding == "json" {
            let mut v: serde_json::Value =
                serde_json::from_slice(&message.data).expect("JSON message");
            if edit(&message.channel.topic, &mut v) {
                edits += 1;
                message.data = serde_json::to_vec(&v).expect("JSON").into();
            }
        }
        writer.write(&message).expect("written");
    }
    writer.finish().expect("finished");
    edits
}
