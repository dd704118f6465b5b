//! A test's scratch folder: fresh and unique in the temporary directory
//! (`petrel-<name>-XXXXXX`, so a person can find it), removed when the
//! test is done with it, but left in place, its path printed on stderr,
//! when the test fails (the thread is panicking), so that the failed
//! test's recordings and logs can be read. `PETREL_KEEP=1` keeps them
//! all, passed tests' too.
//!
//! Shared by the test binaries of every crate.
//! A test that hands the path to a child process keeps the guard alive
//! until the child is reaped; a helper that makes a folder returns the
//! guard, not its path.

use std::ops::Deref;
use std::path::{Path, PathBuf};

/// Set (to anything), it keeps every scratch folder, passed tests' too.
pub const KEEP: &str = "PETREL_KEEP";

/// A scratch folder, removed on drop unless the thread is panicking (or
/// `PETREL_KEEP` is set).
#[derive(Debug)]
pub struct Scratch {
    /// Always `Some` until dropped.
    dir: Option<tempfile::TempDir>,
}

impl Scratch {
    /// A fresh folder `petrel-<name>-XXXXXX` in the temporary directory.
    pub fn new(name: &str) -> Scratch {
        let dir = tempfile::Builder::new()
            .prefix(&format!("petrel-{name}-"))
            .tempdir()
            .unwrap_or_else(|e| panic!("a scratch folder petrel-{name}-: {e}"));
        Scratch { dir: Some(dir) }
    }

    pub fn path(&self) -> &Path {
        match &self.dir {
            Some(dir) => dir.path(),
            None => unreachable!("a scratch folder is only taken on drop"),
        }
    }

    /// The folder's path, for a thread or a struct that outlives a borrow
    /// (the guard must still outlive its use).
    pub fn to_path_buf(&self) -> PathBuf {
        self.path().to_path_buf()
    }

    /// Leaves the folder in place, for good: its path.
    pub fn keep(mut self) -> PathBuf {
        match self.dir.take() {
            Some(dir) => dir.keep(),
            None => unreachable!("a scratch folder is only taken on drop"),
        }
    }
}

impl Deref for Scratch {
    type Target = Path;

    fn deref(&self) -> &Path {
        self.path()
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        self.path()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let Some(dir) = self.dir.take() else { return };
        let why = if std::thread::panicking() {
            "for the failed test"
        } else if std::env::var_os(KEEP).is_some() {
            "as PETREL_KEEP is set"
        } else {
            if let Err(e) = dir.close() {
                eprintln!("scratch folder not removed: {e}");
            }
            return;
        };
        eprintln!("scratch folder kept {why}: {}", dir.keep().display());
    }
}

#[cfg(test)]
mod tests {
    // Paths in full: a bench that includes this file compiles the module
    // with cfg(test) but without its #[test] functions.

    #[test]
    fn a_scratch_folder_is_fresh_named_and_removed_after_a_normal_drop() {
        let one = super::Scratch::new("scratch-test");
        let two = super::Scratch::new("scratch-test");
        assert_ne!(one.path(), two.path());
        for dir in [&one, &two] {
            assert!(dir.is_dir(), "{}", dir.display());
            assert_eq!(dir.parent(), Some(std::env::temp_dir().as_path()));
            let name = dir.file_name().and_then(|n| n.to_str()).unwrap_or("");
            assert!(name.starts_with("petrel-scratch-test-"), "{name}");
        }
        std::fs::create_dir_all(one.join("inner")).expect("a folder inside");
        std::fs::write(one.join("inner/flight.mcap"), b"x").expect("a file inside");
        let (one_path, two_path) = (one.to_path_buf(), two.to_path_buf());
        drop(one);
        drop(two);
        // Removed, or kept when asked to keep them all.
        let kept = std::env::var_os(super::KEEP).is_some();
        assert_eq!(
            one_path.join("inner/flight.mcap").exists(),
            kept,
            "{}",
            one_path.display()
        );
        assert_eq!(two_path.exists(), kept, "{}", two_path.display());
        if kept {
            let _ = std::fs::remove_dir_all(&one_path);
            let _ = std::fs::remove_dir_all(&two_path);
        }
    }

    #[test]
    fn a_scratch_folder_is_kept_after_a_panic() {
        let mut path = std::path::PathBuf::new();
        let unwound = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let dir = super::Scratch::new("scratch-test-panic");
            std::fs::write(dir.join("log.txt"), b"what failed").expect("a file inside");
            path = dir.to_path_buf();
            // A panic without the panic hook (no "thread panicked" noise,
            // nothing for a hook to count): the guard drops while
            // unwinding, as in a failed assertion.
            std::panic::resume_unwind(Box::new("a failed test"));
        }));
        assert!(unwound.is_err());
        let kept = std::fs::read(path.join("log.txt"));
        let _ = std::fs::remove_dir_all(&path);
        assert_eq!(
            kept.ok().as_deref(),
            Some(&b"what failed"[..]),
            "{}",
            path.display()
        );
    }
}
