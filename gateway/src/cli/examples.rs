//! The examples built into the binary (`build.rs`): `petrel demo` flies
//! them, `petrel view` shows them when given no file.

use std::path::PathBuf;

mod embedded {
    include!(concat!(env!("OUT_DIR"), "/examples.rs"));
}

/// The examples built into the binary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Example {
    /// The ProCoSA paper's UAV flight test: an ArduPlane, DEC.
    #[default]
    UavFlightTest,
    /// The paper's UGV lab test: two rovers, one bottleneck, PLN.
    UgvBottleneck,
}

impl Example {
    /// Its folder's name under examples/.
    pub fn folder(self) -> &'static str {
        match self {
            Example::UavFlightTest => "uav-flight-test",
            Example::UgvBottleneck => "ugv-bottleneck",
        }
    }

    fn files(self) -> &'static [(&'static str, &'static str)] {
        match self {
            Example::UavFlightTest => embedded::FLIGHT_TEST,
            Example::UgvBottleneck => embedded::UGV_BOTTLENECK,
        }
    }
}

/// Writes a built-in example into a fresh folder.
pub(crate) fn unpack(example: Example) -> Result<PathBuf, miette::Report> {
    let prefix = format!("petrel-demo-{}-", example.folder());
    sweep(&std::env::temp_dir(), &prefix);
    let dir = std::env::temp_dir().join(format!("{prefix}{}", std::process::id()));
    std::fs::create_dir_all(&dir)
        .map_err(|e| miette::miette!("cannot create {}: {e}", dir.display()))?;
    for (name, text) in example.files() {
        std::fs::write(dir.join(name), text)
            .map_err(|e| miette::miette!("cannot write {}: {e}", dir.join(name).display()))?;
    }
    Ok(dir)
}

/// Removes the folders `PREFIX<pid>` in `tmp` whose process is gone: a
/// demo or view killed (SIGKILL, a test's end) never removed its own.
/// Only where `/proc` tells which processes run.
fn sweep(tmp: &std::path::Path, prefix: &str) {
    let proc = std::path::Path::new("/proc");
    if !proc.join("self").is_dir() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(tmp) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name
            .to_str()
            .and_then(|n| n.strip_prefix(prefix))
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id() && !proc.join(pid.to_string()).exists() {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_folders_of_demos_that_are_gone_are_swept() {
        let tmp = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let prefix = "petrel-demo-uav-flight-test-";
        // A process that cannot exist (above Linux's pid limit), this one,
        // and a folder of another name.
        for name in [
            format!("{prefix}999999999"),
            format!("{prefix}{}", std::process::id()),
            format!("{prefix}x"),
            "petrel-other-999999999".to_owned(),
        ] {
            std::fs::create_dir(tmp.path().join(&name)).unwrap_or_else(|e| panic!("{e}"));
        }
        sweep(tmp.path(), prefix);
        let mut left: Vec<String> = std::fs::read_dir(tmp.path())
            .unwrap_or_else(|e| panic!("{e}"))
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        let mut want = vec![
            "petrel-other-999999999".to_owned(),
            format!("{prefix}{}", std::process::id()),
            format!("{prefix}x"),
        ];
        want.sort();
        assert_eq!(left, want);
    }
}
