//! Reaction latency over loopback: from a low-battery SYS_STATUS leaving a
//! scripted autopilot's UDP socket to the RTL COMMAND_LONG arriving back,
//! through `petrel run` (release, recording on, the built-in ArduPilot
//! `battery_low` rule without its debounce, a net that commands `rtl`) —
//! and, in the same harness and run, through a ten-line pymavlink script
//! doing the same (`benches/latency/rtl.py`). Both run side by side and
//! get their trials in turn, so that both meet the same load.
//!
//! Each latency is given twice: until the harness's thread read the
//! command (what it waited for a CPU itself included: on a saturated
//! machine, milliseconds that are no reactor's), and until the command
//! reached the harness's socket (the kernel's receive timestamp).
//!
//! Run: `cargo bench -p gateway --bench latency` (PETREL_LATENCY_TRIALS sets
//! the number of trials, 10,000 by default; PETREL_LATENCY_REALTIME=off
//! runs petrel with `--no-realtime`, PETREL_LATENCY_RECORD=off with
//! `--no-record`, PETREL_LATENCY_CHRT=N under `chrt -f N`,
//! PETREL_LATENCY_BINARY=PATH another petrel binary, to compare two
//! builds in one session). The pymavlink side is skipped,
//! saying so, when pymavlink is not installed.

#[path = "support/autopilot.rs"]
mod autopilot;

use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// `(battery_low events, rtl commands)` in a recording that replays with
/// no difference.
fn recorded(project: &Path, recording: &Path) -> Option<(usize, usize)> {
    let out = Command::new(petrel_binary())
        .arg("replay")
        .arg(recording)
        .arg(project)
        .args(["--check-against", "--json"])
        .output()
        .ok()?;
    if !out.status.success() {
        eprintln!("{}", String::from_utf8_lossy(&out.stderr));
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let events = text
        .lines()
        .filter(|l| l.contains(r#""input":"event""#) && l.contains(r#""event":"battery_low""#))
        .count();
    let commands = text
        .lines()
        .filter(|l| l.contains(r#""effect":"command""#) && l.contains(r#""verb":"rtl""#))
        .count();
    Some((events, commands))
}

/// The petrel under test: this build's, or PETREL_LATENCY_BINARY.
fn petrel_binary() -> std::ffi::OsString {
    std::env::var_os("PETREL_LATENCY_BINARY").unwrap_or_else(|| env!("CARGO_BIN_EXE_petrel").into())
}

fn free_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .map(|a| a.port())
        .unwrap_or(14_560)
}

struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn main() {
    let n: usize = std::env::var("PETREL_LATENCY_TRIALS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000);
    let here: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/latency");
    let scratch = std::env::temp_dir().join(format!("petrel-latency-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&scratch);
    // PETREL_LATENCY_RECORD=off: petrel without recording (to compare).
    let record = std::env::var("PETREL_LATENCY_RECORD").map_or(true, |v| v != "off");
    let petrel_port = free_port();
    // PETREL_LATENCY_CHRT=N: petrel under `chrt -f N` (real time, as a crew
    // may run it: docs/run.md; needs the privilege).
    let chrt = std::env::var("PETREL_LATENCY_CHRT").ok();
    let mut command = match &chrt {
        Some(priority) => {
            let mut c = Command::new("chrt");
            c.args(["-f", priority.as_str()]).arg(petrel_binary());
            c
        }
        None => Command::new(petrel_binary()),
    };
    command
        .arg("run")
        .arg(&here)
        .args([
            "--mavlink",
            &format!("udpin:127.0.0.1:{petrel_port}"),
            "--profile",
        ])
        .arg(here.join("profile.toml"));
    if record {
        command.arg("--record").arg(scratch.join("latency.mcap"));
    } else {
        command.arg("--no-record");
    }
    // PETREL_LATENCY_REALTIME=off: petrel with `--no-realtime` (the loop
    // does not ask for a real-time priority itself; docs/run.md).
    if std::env::var("PETREL_LATENCY_REALTIME").is_ok_and(|v| v == "off") {
        command.arg("--no-realtime");
    }
    let mut petrel = match command
        .args(["--duration", "3600"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
    {
        Ok(child) => Some(Killed(child)),
        Err(e) => {
            eprintln!("cannot start petrel: {e}");
            None
        }
    };

    let script_port = free_port();
    let has_pymavlink = Command::new("python3")
        .args(["-c", "import pymavlink"])
        .status()
        .is_ok_and(|s| s.success());
    let script = if has_pymavlink {
        Command::new("python3")
            .arg(here.join("rtl.py"))
            .arg(format!("udpin:127.0.0.1:{script_port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .ok()
            .map(Killed)
    } else {
        eprintln!(
            "skipped the pymavlink baseline: pymavlink is not installed (pip install pymavlink)"
        );
        None
    };
    std::thread::sleep(Duration::from_millis(1500));

    // Both reactors run side by side and get their trials in turn: each
    // meets the machine's load as it comes and goes.
    let mut reactors = Vec::new();
    if petrel.is_some() {
        let name = match (record, chrt.is_some()) {
            (true, false) => "petrel run (recording on)",
            (false, false) => "petrel run (recording OFF)",
            (true, true) => "petrel run (recording, chrt -f)",
            (false, true) => "petrel run (no rec., chrt -f)",
        };
        reactors.extend(autopilot::connect(petrel_port).map(|ap| (name, ap)));
    }
    if script.is_some() {
        reactors
            .extend(autopilot::connect(script_port).map(|ap| ("pymavlink script (baseline)", ap)));
    }
    let results: Vec<_> = autopilot::interleaved(reactors, n, Duration::from_secs(180))
        .into_iter()
        .flatten()
        .collect();
    drop(script);
    let mut in_recording = None;
    if let Some(mut guard) = petrel.take() {
        // Stop it cleanly, then find the rule's events and the net's
        // commands in its recording (replayed and checked against it).
        let pid = guard.0.id().to_string();
        let _ = Command::new("kill").args(["-TERM", &pid]).status();
        let _ = guard.0.wait();
        if record {
            in_recording = recorded(&here, &scratch.join("latency.mcap"));
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);

    println!(
        "{:<30} {:>8} {:>10} {:>10} {:>10} {:>6}   {:>10} {:>10} {:>10}",
        "reactor",
        "trials",
        "p50 µs",
        "p99 µs",
        "max µs",
        "lost",
        "socket p50",
        "socket p99",
        "socket max"
    );
    for s in &results {
        println!(
            "{:<30} {:>8} {:>10.1} {:>10.1} {:>10.1} {:>6}   {:>10.1} {:>10.1} {:>10.1}",
            s.name,
            s.micros.len(),
            s.pct(0.5),
            s.pct(0.99),
            s.pct(1.0),
            s.lost,
            s.socket_pct(0.5),
            s.socket_pct(0.99),
            s.socket_pct(1.0)
        );
    }
    println!(
        "(the first three: until the harness read the command, its own wait for a CPU included; \
         socket: until the command reached its socket, the kernel's receive timestamp)"
    );
    match in_recording {
        Some((events, commands)) => println!(
            "in the recording (replayed with --check-against: no difference): {events} battery_low events, {commands} rtl commands"
        ),
        None if record => println!("the recording could not be replayed and checked"),
        None => println!("not recorded (PETREL_LATENCY_RECORD=off)"),
    }
    if let [a, b] = results.as_slice() {
        println!(
            "ratio petrel / script: p50 {:.2}, p99 {:.2}; at the socket: p50 {:.2}, p99 {:.2}",
            a.pct(0.5) / b.pct(0.5),
            a.pct(0.99) / b.pct(0.99),
            a.socket_pct(0.5) / b.socket_pct(0.5),
            a.socket_pct(0.99) / b.socket_pct(0.99)
        );
    }
}
