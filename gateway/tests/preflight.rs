//! `petrel run`'s pre-flight check, remembered in the user's cache
//! directory: skipped when the same nets, profile and Petrel held before,
//! explored again when any of them differs, with `--recheck`, or when the
//! entry is corrupt; a failed check never remembered. A `petrel check`
//! that held with the run's own limits is remembered too.

#[path = "support/scratch.rs"]
mod scratch;

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
