//! Tests that cannot run here, said so. A test whose peer is missing
//! (`../shared`, ArduPilot's or PX4's SITL, MAVProxy, Chromium, a Python
//! package…) returns early and libtest counts it as passed; [`skip`]
//! remembers why, and when the test binary exits it prints one line after
//! libtest's `test result:` line, counting the tests that did not run and
//! why (libtest shows a test's own output only when it fails). Under
//! `CI=true` the callers fail instead of skipping, as before.
//!
//! The gateway's tests use it through `sitl_tests::skip` (the SITL
//! harnesses skip through it too), the other crates' tests directly.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, Once};

/// `shared/` beside the repository (the workspace's parent folder), or
/// the folder `PETREL_SHARED` names (an empty folder shows which tests
/// need it).
pub fn shared_dir() -> PathBuf {
    match std::env::var_os("PETREL_SHARED") {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared"),
    }
}

/// True when a missing peer must fail the test rather than skip it.
pub fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true")
}

/// The tests skipped, by reason.
#[derive(Default)]
pub struct Skipped(BTreeMap<String, BTreeSet<String>>);

impl Skipped {
    pub const fn new() -> Self {
        Skipped(BTreeMap::new())
    }

    /// `test` skipped for `why` (once per reason, however often it says so).
    pub fn add(&mut self, why: &str, test: &str) {
        self.0
            .entry(why.to_owned())
            .or_default()
            .insert(test.to_owned());
    }

    /// The closing line, or nothing when no test was skipped.
    pub fn line(&self) -> Option<String> {
        let tests: BTreeSet<&String> = self.0.values().flatten().collect();
        if tests.is_empty() {
            return None;
        }
        let reasons: Vec<String> = self
            .0
            .iter()
            .map(|(why, tests)| format!("{} ({})", why, tests.len()))
            .collect();
        let n = tests.len();
        Some(format!(
            "SKIPPED: {n} test{s} counted as passed above did not run: {}",
            reasons.join("; "),
            s = if n == 1 { "" } else { "s" },
        ))
    }
}

/// This test binary's.
static SKIPPED: Mutex<Skipped> = Mutex::new(Skipped::new());
static AT_EXIT: Once = Once::new();

extern "C" {
    fn atexit(callback: extern "C" fn()) -> std::os::raw::c_int;
}

/// The current test skips: `why` is printed (in its captured output) and
/// counted in the line printed at exit.
pub fn skip(why: &str) {
    eprintln!("skipped: {why}");
    // libtest names each test's thread after the test (one thread, the
    // main one: each skip counts).
    static CALLS: AtomicUsize = AtomicUsize::new(0);
    let test = match std::thread::current().name() {
        Some(name) if name != "main" => name.to_owned(),
        _ => format!("#{}", CALLS.fetch_add(1, Ordering::Relaxed)),
    };
    if let Ok(mut skipped) = SKIPPED.lock() {
        skipped.add(why, &test);
    }
    AT_EXIT.call_once(|| {
        // SAFETY: `atexit` is given a plain function that does not unwind
        // (it only locks a mutex and writes what it can to stdout).
        unsafe {
            atexit(report);
        }
    });
}

extern "C" fn report() {
    use std::io::Write as _;
    let line = SKIPPED.lock().ok().and_then(|s| s.line());
    if let Some(line) = line {
        let _ = writeln!(std::io::stdout(), "{line}\n");
    }
}

#[cfg(test)]
mod tests {
    use super::Skipped;

    #[test]
    fn the_closing_line_counts_each_skipped_test_once_by_reason() {
        let mut skipped = Skipped::new();
        assert_eq!(skipped.line(), None, "nothing skipped, nothing said");
        skipped.add("no ArduPilot SITL", "real_plane::a");
        skipped.add("no ArduPilot SITL", "real_plane::a");
        skipped.add("no ArduPilot SITL", "real_plane::b");
        skipped.add("no mavproxy.py", "real_plane::b");
        assert_eq!(
            skipped.line().as_deref(),
            Some("SKIPPED: 2 tests counted as passed above did not run: no ArduPilot SITL (2); no mavproxy.py (1)")
        );
    }
}
