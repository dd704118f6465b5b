//! Recordings that survive (issue 14): the real `petrel run` process,
//! supervising the simulated ArduPlane (in this process, over loopback) on
//! examples/uav-survey, is
//!
//! - killed with SIGKILL at random instants, several times: each recording
//!   is read by the Python `mcap` package (seeking and streaming reader) up
//!   to at most about a second before the kill, replays with
//!   `--check-against`, and `petrel recover` makes a clean indexed copy;
//! - run with its recording on a tmpfs that fills up in flight: the
//!   recording stops with a clear message and a count, commands still reach
//!   the vehicle, and `petrel run` ends only when told.
//!
//! The Python package is a peer: without it the Python checks skip with the
//! reason, and fail under `CI=true` (or `PETREL_PYTHON_MCAP=required`).

use crate::scratch;

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use scratch::Scratch;
use serde_json::Value;
use sitl_tests::{BootTimeline, Sim, SimConfig};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn project() -> PathBuf {
    root().join("examples/uav-survey")
}

fn required() -> bool {
    std::env::var("CI").as_deref() == Ok("true")
        || std::env::var("PETREL_PYTHON_MCAP").as_deref() == Ok("required")
}

/// Whether python3 with the `mcap` package is here (else skip, or fail
/// under CI).
fn python_mcap() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import mcap"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            !required(),
            "the Python mcap package is missing (pip install mcap), and CI=true"
        );
        sitl_tests::skip::skip("the Python reader's checks: python3 with the mcap package is not installed (pip install mcap)");
    }
    ok
}

/// The Python reader's view of a file (gateway/tests/survive/read_cut.py).
fn python_read(path: &Path) -> Value {
    let out = Command::new("python3")
        .arg(root().join("gateway/tests/survive/read_cut.py"))
        .arg(path)
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON from read_cut.py")
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

fn sim() -> Sim {
    Sim::start(SimConfig {
        listen: "tcpin:127.0.0.1:0".into(),
        boot: BootTimeline::quick(),
        ..SimConfig::default()
    })
    .expect("the simulated vehicle starts")
}

/// `petrel run` on uav-survey, its clock at the wall's pace.
fn run_args(sim: &Sim, record: &Path) -> Vec<String> {
    vec![
        "run".into(),
        project().display().to_string(),
        "--mavlink".into(),
        sim.client_address(),
        "--programs".into(),
        format!("tcp:127.0.0.1:{}", free_port()),
        "--record".into(),
        record.display().to_string(),
        "--json".into(),
    ]
}

/// A child killed and reaped when the test ends, however it ends.
struct Reaped(Option<Child>);

impl Drop for Reaped {
    fn drop(&mut self) {
        if let Some(mut c) = self.0.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

fn petrel(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_petrel"))
        .args(args)
        .output()
        .expect("petrel runs")
}

fn unix_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

/// A small generator for the kill instants (xorshift), seeded from the
/// clock and printed, so that a failure can be reproduced with
/// PETREL_KILL_SEED.
struct Instants(u64);

impl Instants {
    fn new() -> Instants {
        let seed = std::env::var("PETREL_KILL_SEED")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| unix_ns() | 1);
        eprintln!("kill instants seeded with PETREL_KILL_SEED={seed}");
        Instants(seed)
    }

    /// Milliseconds in `lo..hi`.
    fn next(&mut self, lo: u64, hi: u64) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        lo + self.0 % (hi - lo)
    }
}

/// The seconds of flight lost to a kill are at most this: chunks close
/// every second; the rest is the writer's 10 ms batches and scheduling on a
/// loaded machine.
const LOSS_LIMIT_S: f64 = 1.25;

#[test]
fn kill_9_at_random_instants_leaves_recordings_every_reader_opens() {
    let python = python_mcap();
    let dir = Scratch::new("survive-kill");
    let mut instants = Instants::new();
    let mut worst_loss: f64 = 0.0;
    for round in 0..4 {
        let sim = sim();
        let file = dir.join(format!("killed-{round}.mcap"));
        let wait = Duration::from_millis(instants.next(2_500, 9_000));
        let mut child = Reaped(Some(
            Command::new(env!("CARGO_BIN_EXE_petrel"))
                .current_dir(&dir)
                .args(run_args(&sim, &file))
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .expect("petrel run starts"),
        ));
        // Counted from the recording's creation, not the process's start.
        let give_up = Instant::now() + Duration::from_secs(60);
        while !file.exists() && Instant::now() < give_up {
            std::thread::sleep(Duration::from_millis(20));
        }
        assert!(file.exists(), "petrel run made no recording in 60 s");
        std::thread::sleep(wait);
        let c = child.0.as_mut().expect("the child");
        assert!(
            c.try_wait().expect("the child's status").is_none(),
            "petrel run ended before it was killed"
        );
        c.kill().expect("SIGKILL");
        let killed_at = unix_ns();
        let status = c.wait().expect("the child ends");
        let mut stderr = String::new();
        if let Some(mut e) = c.stderr.take() {
            let _ = e.read_to_string(&mut stderr);
        }
        child.0 = None;
        assert!(!status.success(), "{stderr}");
        drop(sim);

        // `petrel replay` says what it recovered and replays it exactly.
        let path = file.display().to_string();
        let project = project().display().to_string();
        let out = petrel(&["replay", &path, &project, "--check-against"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "round {round}: {err}");
        assert!(err.contains("was cut short"), "round {round}: {err}");
        assert!(err.contains("is recovered:"), "round {round}: {err}");
        assert!(err.contains("match the recording"), "round {round}: {err}");

        // `petrel recover` writes a clean, indexed copy.
        let fixed = dir.join(format!("recovered-{round}.mcap"));
        let fixed_path = fixed.display().to_string();
        let out = petrel(&["recover", &path, "-o", &fixed_path, "--json"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "round {round}: {err}");
        let got: Value = serde_json::from_slice(&out.stdout).expect("recover --json");
        assert!(got["messages"].as_u64().unwrap_or(0) > 100, "{got}");
        assert_eq!(got["had_summary"], false, "{got}");
        let out = petrel(&["replay", &fixed_path, &project, "--check-against"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "round {round}: {err}");
        assert!(!err.contains("cut short"), "round {round}: {err}");

        if !python {
            continue;
        }
        // The reference reader, seeking and streaming, on the killed file.
        let v = python_read(&file);
        let seeking = &v["seeking"];
        let streaming = &v["streaming"];
        assert_eq!(seeking["error"], Value::Null, "round {round}: {v}");
        assert_eq!(streaming["error"], Value::Null, "round {round}: {v}");
        let n = seeking["messages"].as_u64().unwrap_or(0);
        assert!(n > 100, "round {round}: {v}");
        assert_eq!(
            streaming["messages"].as_u64(),
            Some(n),
            "round {round}: {v}"
        );
        let last = seeking["last_log_time"].as_u64().unwrap_or(0);
        let loss = killed_at.saturating_sub(last) as f64 / 1e9;
        eprintln!(
            "round {round}: killed {:.2} s after the recording began, {n} messages readable, the last {loss:.3} s before the kill lost",
            wait.as_secs_f64()
        );
        worst_loss = worst_loss.max(loss);
        assert!(
            loss <= LOSS_LIMIT_S,
            "round {round}: {loss:.3} s of flight lost to the kill (at most about a second): {v}"
        );
        // And the recovered copy has its summary: chunk indexes and
        // statistics that agree with what the reader reads.
        let v = python_read(&fixed);
        assert_eq!(v["seeking"]["error"], Value::Null, "{v}");
        assert_eq!(v["seeking"]["messages"].as_u64(), Some(n), "{v}");
        assert!(
            v["summary"]["chunk_indexes"].as_u64().unwrap_or(0) > 1,
            "{v}"
        );
        assert_eq!(v["summary"]["message_count"].as_u64(), Some(n), "{v}");
        assert_eq!(v["summary"]["indexed_messages"].as_u64(), Some(n), "{v}");
    }
    eprintln!("worst loss over the kills: {worst_loss:.3} s");
}

/// The recording on a 1 MiB tmpfs already nearly full, in a mount
/// namespace of its own (`unshare`: nothing is left mounted, whatever
/// happens): it fills up a second or so into the flight, before the
/// vehicle is armed.
const FULL_DISK: &str = r#"
set -u
mount -t tmpfs -o size=1m petrel-full "$DISK" || exit 97
head -c "$FILL" /dev/zero > "$DISK/filler" 2>/dev/null
"$PETREL" "$@"
code=$?
cp "$DISK/flight.mcap" "$OUT/flight.mcap"
exit $code
"#;

#[test]
fn a_full_disk_stops_the_recording_and_the_flight_goes_on() {
    let dir = Scratch::new("survive-full");
    let disk = dir.join("disk");
    std::fs::create_dir_all(&disk).expect("the mount point");
    let sim = sim();
    let file = disk.join("flight.mcap");
    let mut args = run_args(&sim, &file);
    args.extend(["--duration".into(), "18".into()]);
    // As root, a mount namespace; otherwise a user namespace too.
    // SAFETY: geteuid has no preconditions and cannot fail.
    let root_user = unsafe { libc::geteuid() } == 0;
    let mut unshare = Command::new("unshare");
    if !root_user {
        unshare.arg("--map-root-user");
    }
    let out = unshare
        .args([
            "--mount",
            "--propagation",
            "private",
            "sh",
            "-c",
            FULL_DISK,
            "sh",
        ])
        .args(&args)
        .env("DISK", &disk)
        .env("OUT", dir.path())
        .env("FILL", (1024 * 1024 - 40 * 1024).to_string())
        .env("PETREL", env!("CARGO_BIN_EXE_petrel"))
        .current_dir(&dir)
        .output();
    let out = match out {
        Ok(o) if o.status.code() != Some(97) && o.status.code().is_some() => o,
        other => {
            let why = match other {
                Ok(o) => String::from_utf8_lossy(&o.stderr).into_owned(),
                Err(e) => e.to_string(),
            };
            assert!(
                std::env::var("CI").as_deref() != Ok("true"),
                "cannot mount a small tmpfs (unshare --mount; mount -t tmpfs), and CI=true: {why}"
            );
            sitl_tests::skip::skip(&format!(
                "cannot mount a small tmpfs here (unshare --mount; mount -t tmpfs): {}",
                why.trim()
            ));
            return;
        }
    };
    let state = sim.state();
    drop(sim);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    // `petrel run` stopped because --duration said so, and cleanly.
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("stopped after"), "{stderr}");
    // The message, once, with the reason.
    let stop = stderr
        .lines()
        .find(|l| l.contains("RECORDING STOPPED"))
        .unwrap_or_else(|| panic!("no RECORDING STOPPED line: {stderr}"));
    assert!(stop.contains("No space left on device"), "{stop}");
    assert_eq!(stderr.matches("RECORDING STOPPED").count(), 1, "{stderr}");
    let stopped_at: f64 = stop
        .split("at t = ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no time in {stop}"));
    // The count of what was not recorded, at the end.
    let end = stderr
        .lines()
        .find(|l| l.starts_with("the recording stopped in flight"))
        .unwrap_or_else(|| panic!("no end-of-recording line: {stderr}"));
    let not_recorded: u64 = end
        .split("; ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no count in {end}"));
    assert!(not_recorded > 100, "{end}");
    // Supervision went on: the nets commanded the arming and the take-off
    // after the recording stopped, the vehicle obeyed, and the take-off
    // was heard.
    let timeline: Vec<Value> = stdout
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    let after = |pred: &dyn Fn(&Value) -> bool| {
        timeline
            .iter()
            .any(|l| pred(l) && l["t"].as_f64().unwrap_or(0.0) > stopped_at)
    };
    assert!(
        after(&|l| l["effect"] == "command" && l["verb"] == "takeoff"),
        "no take-off commanded after the recording stopped at {stopped_at} s: {stdout}"
    );
    assert!(
        after(&|l| l["input"] == "event" && l["event"] == "takeoff"),
        "no take-off heard after the recording stopped: {stdout}"
    );
    assert!(state.armed && state.alt > 10.0, "{state:?}");
    // What was written before the disk filled is a readable recording.
    let copy = dir.join("flight.mcap");
    let path = copy.display().to_string();
    let project = project().display().to_string();
    let out = petrel(&["replay", &path, &project, "--check-against"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(err.contains("was cut short"), "{err}");
    if python_mcap() {
        let v = python_read(&copy);
        assert_eq!(v["seeking"]["error"], Value::Null, "{v}");
        assert!(v["seeking"]["messages"].as_u64().unwrap_or(0) > 0, "{v}");
    }
}
