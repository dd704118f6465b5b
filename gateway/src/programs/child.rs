//! Started programs: a `[programs.NAME]` table with `run = [...]` is started
//! by the gateway in the project folder, with `PETREL_PROGRAMS` (the address
//! to connect to) and `PETREL_PROGRAM` (its name) in its environment; its
//! standard output and error are logged line by line; it is started again
//! after it exits as its `restart` policy says, after a backoff that doubles
//! up to a bound. On shutdown it gets SIGTERM, then SIGKILL after a grace
//! period, and is always waited for (no zombie).

use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncReadExt};
use tokio::process::{Child, Command};
use tokio::sync::{mpsc, watch};
use tokio::time::Instant;

use petrel_core::programs::roster::Restart;

/// The environment variable holding the gateway's programs address.
pub const ENV_ADDRESS: &str = "PETREL_PROGRAMS";
/// The token a started program gives in its hello, when one is required.
pub const ENV_TOKEN: &str = "PETREL_PROGRAMS_TOKEN";
/// The environment variable holding the program's name.
pub const ENV_NAME: &str = "PETREL_PROGRAM";

/// Longest output line logged whole; longer ones are logged in pieces.
const MAX_LOG_LINE: usize = 16 * 1024;

/// How to start one program.
#[derive(Debug, Clone)]
pub struct Launch {
    pub program: usize,
    pub name: String,
    pub run: Vec<String>,
    pub restart: Restart,
    pub dir: PathBuf,
    pub address: String,
    /// Given to the program as `PETREL_PROGRAMS_TOKEN` when the gateway
    /// requires a token.
    pub token: Option<String>,
    pub backoff_min: Duration,
    pub backoff_max: Duration,
    pub stable_after: Duration,
    pub grace: Duration,
}

/// What happens to a started program.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ChildEvent {
    /// A process was started.
    Spawned { program: usize, pid: u32 },
    /// It exited (or could not be started); `restart`: it will be started
    /// again after the backoff.
    Exited {
        program: usize,
        status: String,
        restart: bool,
    },
}

/// Starts the program and keeps it running as its policy says, until `stop`
/// turns true (or its sender is dropped).
pub async fn supervise(
    launch: Launch,
    events: mpsc::UnboundedSender<ChildEvent>,
    mut stop: watch::Receiver<bool>,
) {
    let mut backoff = launch.backoff_min;
    loop {
        if *stop.borrow() {
            return;
        }
        let started = Instant::now();
        let (failed, status) = match spawn(&launch) {
            Err(e) => {
                tracing::error!(program = %launch.name, "cannot start {:?}: {e}", launch.run);
                (true, format!("cannot start: {e}"))
            }
            Ok(mut child) => {
                let pid = child.id().unwrap_or(0);
                tracing::info!(program = %launch.name, pid, "started {:?}", launch.run);
                let _ = events.send(ChildEvent::Spawned {
                    program: launch.program,
                    pid,
                });
                tokio::select! {
                    status = child.wait() => match status {
                        Ok(s) => (!s.success(), s.to_string()),
                        Err(e) => (true, e.to_string()),
                    },
                    _ = stopped(&mut stop) => {
                        terminate(&mut child, &launch).await;
                        return;
                    }
                }
            }
        };
        let restart = match launch.restart {
            Restart::Always => true,
            Restart::OnFailure => failed,
            Restart::Never => false,
        };
        if failed {
            tracing::warn!(program = %launch.name, "program exited: {status}");
        } else {
            tracing::info!(program = %launch.name, "program exited: {status}");
        }
        let _ = events.send(ChildEvent::Exited {
            program: launch.program,
            status,
            restart,
        });
        if !restart {
            return;
        }
        if started.elapsed() >= launch.stable_after {
            backoff = launch.backoff_min;
        }
        tracing::info!(program = %launch.name, "restarting in {backoff:?}");
        tokio::select! {
            _ = tokio::time::sleep(backoff) => {}
            _ = stopped(&mut stop) => return,
        }
        backoff = (backoff * 2).min(launch.backoff_max);
    }
}

fn spawn(launch: &Launch) -> std::io::Result<Child> {
    let Some((program, args)) = launch.run.split_first() else {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "an empty command line",
        ));
    };
    let mut command = Command::new(program_path(&launch.dir, program));
    command
        .args(args)
        .current_dir(&launch.dir)
        .env(ENV_ADDRESS, &launch.address)
        .env(ENV_NAME, &launch.name)
        .envs(launch.token.as_ref().map(|t| (ENV_TOKEN, t)))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .kill_on_drop(true)
        // Its own process group: signals reach its children too, and a
        // Ctrl-C on the gateway's terminal reaches the gateway only.
        .process_group(0);
    // SAFETY: between fork and exec, in_program makes two system calls and
    // allocates nothing.
    unsafe {
        // Never the real-time priority a crew may give the gateway, nor the
        // loop's short slice: docs/run.md "On a busy computer".
        command.pre_exec(crate::scheduling::in_program);
    }
    let mut child = command.spawn()?;
    if let Some(out) = child.stdout.take() {
        tokio::spawn(log_lines(out, launch.name.clone(), "stdout"));
    }
    if let Some(err) = child.stderr.take() {
        tokio::spawn(log_lines(err, launch.name.clone(), "stderr"));
    }
    Ok(child)
}

/// A relative path with a folder in it (`bin/dec`, `./dec.py`) is relative to
/// the project folder; a bare name is looked up in PATH.
fn program_path(dir: &Path, program: &str) -> PathBuf {
    let path = Path::new(program);
    if path.is_relative() && path.components().count() > 1 {
        dir.join(path)
    } else {
        path.to_path_buf()
    }
}

/// SIGTERM to the program's process group, SIGKILL after the grace period,
/// and wait for it.
async fn terminate(child: &mut Child, launch: &Launch) {
    let Some(pid) = child.id() else {
        let _ = child.wait().await;
        return;
    };
    signal_group(pid, libc::SIGTERM);
    if tokio::time::timeout(launch.grace, child.wait())
        .await
        .is_err()
    {
        tracing::warn!(program = %launch.name, "no exit {:?} after SIGTERM: SIGKILL", launch.grace);
        signal_group(pid, libc::SIGKILL);
        let _ = child.kill().await;
    }
    tracing::info!(program = %launch.name, "stopped");
}

fn signal_group(pid: u32, signal: libc::c_int) {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return;
    };
    // SAFETY: kill(2) takes plain integers and has no memory effects; the
    // negative pid names the process group the child leads (process_group(0)).
    unsafe {
        libc::kill(-pid, signal);
    }
}

/// Logs a program's output line by line through tracing, bounding the line
/// length so that a program cannot grow the gateway's memory.
async fn log_lines(mut stream: impl AsyncRead + Unpin, program: String, which: &'static str) {
    let mut buffer: Vec<u8> = Vec::new();
    let mut chunk = vec![0u8; 8192];
    let log = |line: &[u8]| {
        let text = String::from_utf8_lossy(line);
        let text = text.trim_end_matches('\r');
        if which == "stderr" {
            tracing::info!(program = %program, "{which}: {text}");
        } else {
            tracing::debug!(program = %program, "{which}: {text}");
        }
    };
    loop {
        let n = match stream.read(&mut chunk).await {
            Ok(0) | Err(_) => break,
            Ok(n) => n,
        };
        buffer.extend_from_slice(&chunk[..n]);
        while let Some(i) = buffer.iter().position(|&b| b == b'\n') {
            log(&buffer[..i]);
            buffer.drain(..=i);
        }
        if buffer.len() > MAX_LOG_LINE {
            log(&buffer);
            buffer.clear();
        }
    }
    if !buffer.is_empty() {
        log(&buffer);
    }
}

/// Resolves when the stop flag turns true or its sender is gone.
pub(super) async fn stopped(stop: &mut watch::Receiver<bool>) {
    let _ = stop.wait_for(|s| *s).await;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_programs_with_a_folder_are_in_the_project() {
        let dir = Path::new("/p");
        assert_eq!(program_path(dir, "python3"), PathBuf::from("python3"));
        assert_eq!(program_path(dir, "./dec.py"), PathBuf::from("/p/./dec.py"));
        assert_eq!(program_path(dir, "bin/dec"), PathBuf::from("/p/bin/dec"));
        assert_eq!(
            program_path(dir, "/usr/bin/env"),
            PathBuf::from("/usr/bin/env")
        );
    }
}
