//! `petrel run` as a deployment runs it: the real binary on the bench
//! project, its JSON timeline read line by line as it comes, stopped with
//! SIGTERM as systemd stops it, and killed and reaped on drop.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use serde_json::Value;

/// The bench project: on `ready_for_takeoff`, `command mode {mode: FBWA}`,
/// then wait for the autopilot's HEARTBEAT to show FLY_BY_WIRE_A.
pub fn bench_project() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/deploy/bench")
}

/// A running `petrel run`.
pub struct Gateway {
    child: Option<Child>,
    lines: mpsc::Receiver<String>,
    /// Every timeline line read so far.
    pub timeline: Vec<Value>,
    stderr: Option<std::process::ChildStderr>,
    pub started: Instant,
}

/// How it ended.
pub struct Stopped {
    pub status: ExitStatus,
    pub timeline: Vec<Value>,
    pub stderr: String,
    /// From SIGTERM to its exit.
    pub stop_time: Duration,
}

impl Gateway {
    /// `petrel run bench --mavlink ADDRESS --json --record RECORDING`.
    pub fn start(address: &str, recording: &Path) -> Gateway {
        let mut child = Command::new(env!("CARGO_BIN_EXE_petrel"))
            .arg("run")
            .arg(bench_project())
            .args(["--mavlink", address, "--json", "--record"])
            .arg(recording)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start petrel run");
        let stdout = child.stdout.take().expect("stdout");
        let stderr = child.stderr.take();
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Gateway {
            child: Some(child),
            lines,
            timeline: Vec::new(),
            stderr,
            started: Instant::now(),
        }
    }

    /// Reads the timeline until a line satisfies `done`, at most `limit`
    /// after the start; true when one did.
    pub fn wait_for(&mut self, limit: Duration, done: impl Fn(&Value) -> bool) -> bool {
        let deadline = self.started + limit;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) => {
                    let value: Value = serde_json::from_str(&line)
                        .unwrap_or_else(|e| panic!("not a JSON line ({e}): {line}"));
                    let hit = done(&value);
                    self.timeline.push(value);
                    if hit {
                        return true;
                    }
                }
                Err(_) => return false,
            }
        }
    }

    /// CPU time (user + system) the process has used so far, from
    /// `/proc/PID/stat`.
    pub fn cpu_time(&self) -> Duration {
        let pid = self.child.as_ref().map(Child::id).expect("running");
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).expect("/proc/PID/stat");
        // Fields after the command name (in parentheses): utime and stime
        // are the 12th and 13th of them, in clock ticks.
        let rest = &stat[stat.rfind(')').expect("comm") + 2..];
        let fields: Vec<&str> = rest.split_whitespace().collect();
        let ticks: u64 =
            fields[11].parse::<u64>().expect("utime") + fields[12].parse::<u64>().expect("stime");
        // SAFETY: sysconf has no preconditions.
        let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) }.max(1) as u64;
        Duration::from_micros(ticks * 1_000_000 / hz)
    }

    /// SIGTERM, as `systemctl stop` sends; waits at most 20 s for a clean
    /// exit (then kills it, and the test fails on the status).
    pub fn stop(mut self) -> Stopped {
        let mut child = self.child.take().expect("running");
        let pid = libc::pid_t::try_from(child.id()).expect("pid");
        let asked = Instant::now();
        // SAFETY: kill(2) on our own child's pid, which is not reaped yet.
        unsafe {
            libc::kill(pid, libc::SIGTERM);
        }
        let status = loop {
            match child.try_wait().expect("wait for petrel") {
                Some(status) => break status,
                None if asked.elapsed() > Duration::from_secs(20) => {
                    let _ = child.kill();
                    break child.wait().expect("reap petrel");
                }
                None => std::thread::sleep(Duration::from_millis(20)),
            }
        };
        let stop_time = asked.elapsed();
        // The reader thread ends at EOF, once the process is gone.
        while let Ok(line) = self.lines.recv_timeout(Duration::from_secs(5)) {
            self.timeline
                .push(serde_json::from_str(&line).unwrap_or(Value::String(line)));
        }
        let mut stderr = String::new();
        if let Some(mut e) = self.stderr.take() {
            let _ = e.read_to_string(&mut stderr);
        }
        Stopped {
            status,
            timeline: std::mem::take(&mut self.timeline),
            stderr,
            stop_time,
        }
    }
}

impl Drop for Gateway {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// The transitions fired, in order.
pub fn fired(timeline: &[Value]) -> Vec<String> {
    timeline
        .iter()
        .filter(|l| l["effect"] == "fired")
        .filter_map(|l| l["transition"].as_str().map(str::to_owned))
        .collect()
}

/// True for the timeline line of the bench net reaching `switched` or
/// `refused` (its end, either way).
pub fn bench_over(line: &Value) -> bool {
    line["effect"] == "fired"
        && (line["transition"] == "switched" || line["transition"] == "refused")
}

/// A recording's messages on `topic`, decoded JSON.
pub fn recorded_json(recording: &Path, topic: &str) -> Vec<Value> {
    let bytes = std::fs::read(recording).expect("the recording");
    mcap::MessageStream::new(&bytes)
        .expect("MCAP")
        .filter_map(Result::ok)
        .filter(|m| m.channel.topic == topic)
        .map(|m| serde_json::from_slice(&m.data).expect("JSON message"))
        .collect()
}

/// A recording's raw frames on `topic` (`/mavlink/raw`, `/mavlink/sent`):
/// the Supervisor time (µs) each was received or sent at, its header and
/// its message where it decodes.
pub fn recorded_frames(
    recording: &Path,
    topic: &str,
) -> Vec<(
    u64,
    mavlink::MavHeader,
    Option<mavlink::dialects::ardupilotmega::MavMessage>,
)> {
    let bytes = std::fs::read(recording).expect("the recording");
    mcap::MessageStream::new(&bytes)
        .expect("MCAP")
        .filter_map(Result::ok)
        .filter(|m| m.channel.topic == topic && m.data.len() > 8)
        .filter_map(|m| {
            let time = u64::from_be_bytes(m.data[..8].try_into().ok()?);
            let frame = elaboration::Frame::parse(&m.data[8..]).ok()?;
            Some((time, frame.header(), frame.decode().ok()))
        })
        .collect()
}

/// What the bench flight must show, whatever the link: the nets heard the
/// real autopilot become ready, commanded FBWA, got `command.ok`, and saw
/// the mode change in the autopilot's own HEARTBEAT; the gateway stopped
/// cleanly on SIGTERM; the recording holds the command as sent, the
/// autopilot's HEARTBEAT in FBWA, and replays to the same decisions.
pub fn assert_bench_flight(stopped: &Stopped, recording: &Path, link: &str) {
    let all = stopped
        .timeline
        .iter()
        .map(Value::to_string)
        .collect::<Vec<_>>();
    let context = || {
        format!(
            "{link}: timeline (last lines):\n{}\nstderr:\n{}",
            all[all.len().saturating_sub(40)..].join("\n"),
            stopped.stderr
        )
    };
    assert_eq!(stopped.status.code(), Some(0), "{}", context());
    let timeline = &stopped.timeline;
    assert_eq!(
        fired(timeline),
        ["ready", "accepted", "switched"],
        "{}",
        context()
    );
    let command = timeline
        .iter()
        .find(|l| l["effect"] == "command")
        .unwrap_or_else(|| panic!("no command effect\n{}", context()));
    assert_eq!(command["verb"], "mode", "{}", context());
    assert_eq!(command["args"]["mode"], "FBWA", "{}", context());
    // The mode change is the autopilot's (system 1, component 1), as its
    // HEARTBEAT says it.
    let changed = timeline
        .iter()
        .find(|l| l["event"] == "mode_changed" && l["params"]["mode"] == "FLY_BY_WIRE_A")
        .unwrap_or_else(|| panic!("no mode_changed to FBWA\n{}", context()));
    assert_eq!(
        (changed["sysid"].as_u64(), changed["compid"].as_u64()),
        (Some(1), Some(1))
    );
    assert_eq!(changed["params"]["custom_mode"], 5);
    assert_eq!(
        timeline.last().map(|l| l["end"].clone()),
        Some(Value::Bool(true)),
        "{}",
        context()
    );
    assert!(
        stopped.stderr.contains("stopped after"),
        "no clean stop on SIGTERM\n{}",
        context()
    );

    // The recording: the gateway spoke as the companion computer (1, 191),
    // never as a GCS, and sent DO_SET_MODE FBWA (custom mode 5)...
    let heartbeats = recorded_json(recording, "/mavlink/sent/1/191/HEARTBEAT");
    assert!(
        !heartbeats.is_empty(),
        "{link}: no companion HEARTBEAT sent"
    );
    assert!(heartbeats
        .iter()
        .all(|h| h["type_name"] == "MAV_TYPE_ONBOARD_CONTROLLER"));
    let set_mode: Vec<Value> = recorded_json(recording, "/mavlink/sent/1/191/COMMAND_LONG")
        .into_iter()
        .filter(|c| c["command_name"] == "MAV_CMD_DO_SET_MODE")
        .collect();
    assert_eq!(set_mode.len(), 1, "{link}: {set_mode:?}");
    assert_eq!(
        (
            set_mode[0]["param1"].as_f64(),
            set_mode[0]["param2"].as_f64()
        ),
        (Some(1.0), Some(5.0))
    );
    // ...which the autopilot acknowledged, to us, and then flew in.
    let acks: Vec<Value> = recorded_json(recording, "/mavlink/1/1/COMMAND_ACK")
        .into_iter()
        .filter(|a| a["command_name"] == "MAV_CMD_DO_SET_MODE")
        .collect();
    assert!(
        acks.iter()
            .any(|a| a["result_name"] == "MAV_RESULT_ACCEPTED" && a["target_component"] == 191),
        "{link}: {acks:?}"
    );
    assert!(
        recorded_json(recording, "/mavlink/1/1/HEARTBEAT")
            .iter()
            .any(|h| h["custom_mode"] == 5),
        "{link}: no autopilot HEARTBEAT in FBWA recorded"
    );

    // The recording replays to the same decisions.
    let replay = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("replay")
        .arg(recording)
        .arg(bench_project())
        .arg("--check-against")
        .output()
        .expect("petrel replay");
    assert_eq!(
        replay.status.code(),
        Some(0),
        "{link}: replay --check-against\n{}{}",
        String::from_utf8_lossy(&replay.stdout),
        String::from_utf8_lossy(&replay.stderr)
    );
}
