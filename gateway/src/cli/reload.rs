//! `petrel reload PROJECT`: tells the `petrel run` supervising PROJECT to
//! take its new version (SIGHUP; docs/run.md, "A new version in flight").
//! The version is loaded and checked here first, so that a file that does
//! not load (file:line:col) or a version that fails `petrel check` is said
//! at once and nothing is sent; the check is remembered, so the run does
//! not explore it again. The run then proves it from the state the
//! vehicle is in, and says its verdict in its own output and recording.

use std::path::{Path, PathBuf};

use super::{Outcome, VerbResult};

#[derive(clap::Args)]
pub struct Args {
    /// The project folder the running gateway supervises.
    pub project: PathBuf,
    /// The process to tell (default: every `petrel run` of PROJECT of this
    /// user, found in /proc).
    #[arg(long)]
    pub pid: Option<u32>,
}

pub fn run(args: Args) -> VerbResult {
    // Loaded and checked with the project's `[gateway] profile` (ArduPilot's
    // if none), as `run` checks before the flight: remembered, the run's
    // own check of the same files and profile is then not explored again.
    match checked(&args.project) {
        Ok(Outcome::Success) => {}
        Ok(outcome) => {
            say!("nothing sent: the running version goes on");
            return Ok(outcome);
        }
        Err(e) => {
            say!("{}", petrel_core::project::for_people(&e));
            say!("nothing sent: the running version goes on");
            return Ok(Outcome::BadInput);
        }
    }
    let pids = match args.pid {
        Some(pid) => vec![pid],
        None => runs_of(&args.project),
    };
    if pids.is_empty() {
        say!(
            "no `petrel run {}` of this user is running (give --pid PID)",
            args.project.display()
        );
        return Ok(Outcome::BadInput);
    }
    for pid in pids {
        let Ok(id) = libc::pid_t::try_from(pid) else {
            say!("--pid {pid}: not a process id");
            return Ok(Outcome::BadInput);
        };
        // SAFETY: kill(2) with a valid signal number touches no memory.
        if unsafe { libc::kill(id, libc::SIGHUP) } != 0 {
            let e = std::io::Error::last_os_error();
            say!("cannot tell process {pid}: {e}");
            return Ok(Outcome::Failed);
        }
        say!(
            "told `petrel run` (process {pid}) to take the new version of {}: its verdict is in its output (`reload: ...`) and recording",
            args.project.display()
        );
    }
    Ok(Outcome::Success)
}

/// The new version loaded and given the pre-flight check (remembered).
fn checked(dir: &Path) -> VerbResult {
    let Some((layers, profile)) = super::project_profile(dir, None)? else {
        return Ok(Outcome::BadInput);
    };
    let (project, files) =
        petrel_core::project::load_read(dir, &petrel_core::project::catalog(&profile))?;
    let inputs = crate::preflight::Inputs {
        files: &files,
        layers: &layers.layers,
    };
    match crate::preflight::check_project(&project, &inputs, false) {
        crate::preflight::Preflight::Failed(report) => {
            say_part!(
                "{}",
                super::check_project::human(&project.name, &report, 0.0)
            );
            say!("the new version fails `petrel check`");
            Ok(Outcome::Failed)
        }
        _ => Ok(Outcome::Success),
    }
}

/// The `petrel run` processes of this user whose project is `project`:
/// a process whose executable is named `petrel`, whose arguments hold
/// `run` and then a path that is `project` (relative paths read from the
/// process's own folder).
fn runs_of(project: &Path) -> Vec<u32> {
    let Ok(wanted) = project.canonicalize() else {
        return Vec::new();
    };
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    let me = std::process::id();
    let mut found = Vec::new();
    for entry in entries.flatten() {
        let Some(pid) = entry
            .file_name()
            .to_str()
            .and_then(|n| n.parse::<u32>().ok())
        else {
            continue;
        };
        if pid == me {
            continue;
        }
        let proc = entry.path();
        let is_petrel = std::fs::read_link(proc.join("exe"))
            .ok()
            .and_then(|exe| exe.file_name().map(|n| n.to_string_lossy().into_owned()))
            .is_some_and(|n| n == "petrel");
        if !is_petrel {
            continue;
        }
        let Ok(cmdline) = std::fs::read(proc.join("cmdline")) else {
            continue;
        };
        let Ok(cwd) = std::fs::read_link(proc.join("cwd")) else {
            continue;
        };
        let args: Vec<&[u8]> = cmdline.split(|&b| b == 0).collect();
        let Some(run) = args.iter().position(|a| *a == b"run") else {
            continue;
        };
        let runs_it = args[run + 1..].iter().any(|a| {
            let path = Path::new(<std::ffi::OsStr as std::os::unix::ffi::OsStrExt>::from_bytes(a));
            cwd.join(path).canonicalize().ok().as_ref() == Some(&wanted)
        });
        if runs_it {
            found.push(pid);
        }
    }
    found
}
