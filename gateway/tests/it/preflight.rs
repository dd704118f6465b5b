//! `petrel run`'s pre-flight check, remembered in the user's cache
//! directory: skipped when the same nets, profile and Petrel held before,
//! explored again when any of them differs, with `--recheck`, or when the
//! entry is corrupt; a failed check never remembered. A `petrel check`
//! that held with the run's own limits is remembered too.

use crate::scratch;

use std::path::{Path, PathBuf};
use std::process::Command;

use scratch::Scratch;

const NET: &str = "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n\
[[transition]]\nname = \"up\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"armed\"\n\
[[transition]]\nname = \"down\"\nfrom = [\"b\"]\nto = [\"a\"]\non = \"disarmed\"\n";

/// A project folder and a cache directory of its own.
struct Preflight {
    dir: Scratch,
}

impl Preflight {
    fn new(net: &str) -> Preflight {
        let dir = Scratch::new("preflight");
        std::fs::create_dir(dir.path().join("project")).expect("project dir");
        std::fs::write(
            dir.path().join("project/project.toml"),
            "[[net]]\nfile = \"n.toml\"\nactive = true\n",
        )
        .expect("write");
        std::fs::write(dir.path().join("project/n.toml"), net).expect("write");
        Preflight { dir }
    }

    fn project(&self) -> PathBuf {
        self.dir.path().join("project")
    }

    fn cache(&self) -> PathBuf {
        self.dir.path().join("cache")
    }

    /// The remembered verdicts.
    fn entries(&self) -> Vec<PathBuf> {
        let dir = self.cache().join("petrel/preflight");
        let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|x| x == "json"))
            .collect();
        out.sort();
        out
    }

    /// `petrel VERB PROJECT ARGS… EXTRA…` with this cache: exit code and
    /// stderr.
    fn petrel(&self, verb: &str, args: &[&str], extra: &[&str]) -> (Option<i32>, String) {
        let out = Command::new(env!("CARGO_BIN_EXE_petrel"))
            .arg(verb)
            .arg(self.project())
            .args(args)
            .args(extra)
            .env("XDG_CACHE_HOME", self.cache())
            .output()
            .expect("petrel runs");
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    }

    /// `petrel run` for a tenth of a second.
    fn run(&self, extra: &[&str]) -> (Option<i32>, String) {
        let link = [
            "--mavlink",
            "udpin:127.0.0.1:0",
            "--duration",
            "0.1",
            "--no-record",
        ];
        self.petrel("run", &link, extra)
    }

    /// `petrel check`.
    fn check(&self, extra: &[&str]) -> (Option<i32>, String) {
        self.petrel("check", &[], extra)
    }
}

fn explored(err: &str) -> bool {
    err.contains("pre-flight check: holds (") && err.contains("explored in")
}

fn remembered(err: &str) -> bool {
    err.contains("pre-flight check: holds (remembered")
}

fn write(path: &Path, text: &str) {
    std::fs::write(path, text).expect("write");
}

#[test]
fn a_check_that_held_is_remembered_until_an_input_changes() {
    let s = Preflight::new(NET);
    let (code, err) = s.run(&[]);
    assert_eq!(code, Some(0), "{err}");
    assert!(explored(&err), "{err}");
    assert_eq!(s.entries().len(), 1, "{err}");

    let (code, err) = s.run(&[]);
    assert_eq!(code, Some(0), "{err}");
    assert!(remembered(&err), "{err}");

    // --recheck explores again.
    let (code, err) = s.run(&["--recheck"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(explored(&err), "{err}");

    // What the nets never read (a comment, the [gateway] table) changes
    // nothing.
    let toml = s.project().join("project.toml");
    write(
        &toml,
        "# the same project\n[[net]]\nfile = \"n.toml\"\nactive = true\n\n[gateway]\nprograms = \"tcp:127.0.0.1:5791\"\n",
    );
    let (code, err) = s.run(&[]);
    assert_eq!(code, Some(0), "{err}");
    assert!(remembered(&err), "{err}");

    // A net that differs is explored again (and remembered too).
    write(
        &s.project().join("n.toml"),
        &NET.replace("on = \"disarmed\"", "on = \"landed\""),
    );
    let (code, err) = s.run(&[]);
    assert_eq!(code, Some(0), "{err}");
    assert!(explored(&err), "{err}");
    assert_eq!(s.entries().len(), 2);

    // So is another elaboration profile.
    let (code, err) = s.run(&["--profile", "px4"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(explored(&err), "{err}");
    let (code, err) = s.run(&["--profile", "px4"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(remembered(&err), "{err}");
    assert_eq!(s.entries().len(), 3);
}

#[test]
fn a_corrupt_entry_is_ignored_and_replaced() {
    let s = Preflight::new(NET);
    let (code, err) = s.run(&[]);
    assert_eq!(code, Some(0), "{err}");
    let entry = s.entries().pop().expect("an entry");
    let good = std::fs::read_to_string(&entry).expect("read");
    let digest = entry
        .file_stem()
        .and_then(|s| s.to_str())
        .expect("named by its digest")
        .to_owned();
    assert!(good.contains(&digest), "{good}");
    let corrupt = [
        String::new(),
        "not json".to_owned(),
        good[..good.len() / 2].to_owned(),
        // Whole, but for another digest, or not holding.
        good.replace(&digest, &"0".repeat(64)),
        good.replace("\"holds\":true", "\"holds\":false"),
        good.replace("\"format\":1", "\"format\":99"),
    ];
    for text in corrupt {
        write(&entry, &text);
        let (code, err) = s.run(&[]);
        assert_eq!(code, Some(0), "{err}");
        assert!(explored(&err), "believed {text:?}: {err}");
        assert_eq!(
            std::fs::read_to_string(&entry).expect("rewritten"),
            good,
            "after {text:?}"
        );
    }
    let (_, err) = s.run(&[]);
    assert!(remembered(&err), "{err}");
}

#[test]
fn a_failed_check_is_never_remembered() {
    // b is dead and not final: a deadlock.
    let s = Preflight::new(
        "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n\
         [[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"armed\"\n",
    );
    for _ in 0..2 {
        let (code, err) = s.run(&[]);
        assert_eq!(code, Some(1), "{err}");
        assert!(err.contains("refusing to run"), "{err}");
        assert!(err.contains("deadlocks        FAILED"), "{err}");
    }
    // Nor by `petrel check`.
    let (code, err) = s.check(&[]);
    assert_eq!(code, Some(1), "{err}");
    assert!(s.entries().is_empty(), "{:?}", s.entries());
}

#[test]
fn a_petrel_check_that_held_spares_the_run_its_exploration() {
    let s = Preflight::new(NET);
    // Another limit than the run's: not the run's check, not remembered.
    let (code, err) = s.check(&["--max-states", "1000"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(s.entries().is_empty(), "{:?}", s.entries());
    // As the run checks: remembered (said at a terminal only: a script's
    // stderr stays empty).
    let (code, err) = s.check(&[]);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.is_empty(), "{err}");
    assert_eq!(s.entries().len(), 1, "{err}");
    let (code, err) = s.run(&[]);
    assert_eq!(code, Some(0), "{err}");
    assert!(remembered(&err), "{err}");
    // Checked against another profile than the run's: the run explores.
    write(
        &s.project().join("n.toml"),
        &NET.replace("on = \"disarmed\"", "on = \"landed\""),
    );
    let (code, err) = s.check(&["--profile", "px4"]);
    assert_eq!(code, Some(0), "{err}");
    let (code, err) = s.run(&[]);
    assert_eq!(code, Some(0), "{err}");
    assert!(explored(&err), "{err}");
}

#[test]
fn ctrl_c_during_the_demos_pre_flight_check_leaves_nothing_behind() {
    // `petrel demo` unpacks its example into the temporary directory, then
    // explores it (`--recheck`: seconds). Interrupted then, it removes the
    // folder, records nothing and exits 130, as an interrupted command.
    let scratch = Scratch::new("demo-interrupted");
    let tmp = scratch.path().join("tmp");
    std::fs::create_dir(&tmp).expect("tmp");
    let record = scratch.path().join("demo.mcap");
    let child = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .args(["demo", "--recheck", "--no-http", "--record"])
        .arg(&record)
        .env("TMPDIR", &tmp)
        .env("XDG_CACHE_HOME", scratch.path().join("cache"))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("petrel demo starts");
    // Reaped however the test ends.
    struct Reaped(std::process::Child);
    impl Drop for Reaped {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
    let mut child = Reaped(child);
    let unpacked = |tmp: &Path| -> Vec<PathBuf> {
        std::fs::read_dir(tmp)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.path())
            .filter(|p| {
                p.file_name()
                    .is_some_and(|n| n.to_string_lossy().starts_with("petrel-demo-"))
            })
            .collect()
    };
    let until = std::time::Instant::now() + std::time::Duration::from_secs(20);
    while unpacked(&tmp).is_empty() {
        assert!(
            std::time::Instant::now() < until,
            "the demo never unpacked its example"
        );
        assert!(
            child.0.try_wait().ok().flatten().is_none(),
            "the demo ended before unpacking"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // Its files written (a few kB), the exploration under way.
    std::thread::sleep(std::time::Duration::from_millis(300));
    assert!(
        child.0.try_wait().ok().flatten().is_none(),
        "the demo ended before it could be interrupted"
    );
    let pid = libc::pid_t::try_from(child.0.id()).expect("a pid");
    // SAFETY: kill(2) on our own child, which is not reaped yet.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
    let until = std::time::Instant::now() + std::time::Duration::from_secs(10);
    let status = loop {
        if let Some(status) = child.0.try_wait().expect("wait") {
            break status;
        }
        assert!(
            std::time::Instant::now() < until,
            "the demo did not stop on SIGINT"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let mut err = String::new();
    if let Some(mut e) = child.0.stderr.take() {
        use std::io::Read;
        let _ = e.read_to_string(&mut err);
    }
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted before the flight"), "{err}");
    assert_eq!(unpacked(&tmp), Vec::<PathBuf>::new(), "{err}");
    assert!(!record.exists(), "a recording was started");
}
