//! Reaction latency over loopback: from a low-battery SYS_STATUS leaving a
//! scripted autopilot's UDP socket to the RTL COMMAND_LONG arriving back,
//! through `petrel run` (release, recording on, the built-in ArduPilot
//! `battery_low` rule without its debounce, a net that commands `rtl`) —
//! and, in the same harness and run, through a ten-line pymavlink script
//! doing the same (`benches/latency/rtl.py`).
//!
//! Run: `cargo bench -p gateway --bench latency` (PETREL_LATENCY_TRIALS sets
//! the number of trials, 10,000 by default). The pymavlink side is skipped,
//! saying so, when pymavlink is not installed.

use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use elaboration::Frame;
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};

const AUTOPILOT: MavHeader = MavHeader {
    system_id: 1,
    component_id: 1,
    sequence: 0,
};

fn encode(seq: u8, message: &MavMessage) -> Vec<u8> {
    let mut out = Vec::new();
    let header = MavHeader {
        sequence: seq,
        ..AUTOPILOT
    };
    if let Err(e) = mavlink::write_versioned_msg(&mut out, MavlinkVersion::V2, header, message) {
        panic!("cannot encode {message:?}: {e}");
    }
    out
}

fn heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 4,
        mavtype: MavType::MAV_TYPE_QUADROTOR,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED,
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    })
}

fn sys_status(remaining: i8) -> MavMessage {
    MavMessage::SYS_STATUS(SYS_STATUS_DATA {
        battery_remaining: remaining,
        voltage_battery: 11_800,
        ..SYS_STATUS_DATA::default()
    })
}

/// The scripted autopilot's side of one reactor (petrel or the script).
struct Autopilot {
    socket: UdpSocket,
    seq: u8,
}

impl Autopilot {
    fn send(&mut self, message: &MavMessage) {
        self.seq = self.seq.wrapping_add(1);
        let bytes = encode(self.seq, message);
        let _ = self.socket.send(&bytes);
    }

    /// Waits for an RTL COMMAND_LONG, acking every command on the way.
    fn wait_rtl(&mut self, deadline: Instant) -> Option<Instant> {
        let mut buf = [0u8; 2048];
        while Instant::now() < deadline {
            let Ok(n) = self.socket.recv(&mut buf) else {
                continue;
            };
            let arrived = Instant::now();
            let mut at = 0;
            let mut rtl = false;
            while at < n {
                let Ok(frame) = Frame::parse(&buf[at..n]) else {
                    break;
                };
                at += frame.bytes().len();
                if let Ok(MavMessage::COMMAND_LONG(c)) = frame.decode() {
                    self.send(&MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                        command: c.command,
                        result: MavResult::MAV_RESULT_ACCEPTED,
                        progress: 0,
                        result_param2: 0,
                        target_system: frame.system_id(),
                        target_component: frame.component_id(),
                    }));
                    rtl |= c.command == MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH;
                }
            }
            if rtl {
                return Some(arrived);
            }
        }
        None
    }
}

struct Stats {
    name: &'static str,
    micros: Vec<f64>,
    lost: usize,
}

impl Stats {
    fn pct(&self, p: f64) -> f64 {
        let i = ((self.micros.len() as f64 - 1.0) * p).round() as usize;
        self.micros[i.min(self.micros.len() - 1)]
    }
}

/// Runs the trials against a reactor listening on `port`.
fn trials(name: &'static str, port: u16, n: usize) -> Option<Stats> {
    let socket = UdpSocket::bind("127.0.0.1:0").ok()?;
    socket.connect(("127.0.0.1", port)).ok()?;
    socket
        .set_read_timeout(Some(Duration::from_millis(50)))
        .ok()?;
    let mut ap = Autopilot { socket, seq: 0 };
    // Let the reactor hear the autopilot (and take its identity) first.
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(3) {
        ap.send(&heartbeat());
        ap.send(&sys_status(90));
        std::thread::sleep(Duration::from_millis(50));
    }
    let mut drain = [0u8; 2048];
    // Reads what is waiting, without waiting for more.
    let drain_for = |ap: &mut Autopilot, buf: &mut [u8], t: Duration| {
        let until = Instant::now() + t;
        let _ = ap.socket.set_nonblocking(true);
        while Instant::now() < until && ap.socket.recv(buf).is_ok() {}
        let _ = ap.socket.set_nonblocking(false);
    };
    drain_for(&mut ap, &mut drain, Duration::from_millis(100));
    // Each reactor gets at most this long, whatever happens.
    let give_up = Instant::now() + Duration::from_secs(90);
    let mut micros = Vec::with_capacity(n);
    let mut lost = 0;
    let mut last_hb = Instant::now();
    for trial in 0..n {
        if trial % 1000 == 0 {
            eprintln!("{name}: trial {trial}, {lost} lost");
        }
        if last_hb.elapsed() > Duration::from_millis(500) {
            ap.send(&heartbeat());
            last_hb = Instant::now();
        }
        let sent = Instant::now();
        ap.send(&sys_status(20));
        match ap.wait_rtl(sent + Duration::from_secs(1)) {
            Some(arrived) => micros.push((arrived - sent).as_secs_f64() * 1e6),
            None => lost += 1,
        }
        // Re-arm the rule.
        ap.send(&sys_status(90));
        std::thread::sleep(Duration::from_micros(300));
        drain_for(&mut ap, &mut drain, Duration::from_millis(2));
        if lost > 20 {
            eprintln!("{name}: more than 20 trials lost; stopping");
            break;
        }
        if Instant::now() > give_up {
            eprintln!("{name}: out of time after {trial} trials; stopping");
            break;
        }
    }
    micros.sort_by(f64::total_cmp);
    (!micros.is_empty()).then_some(Stats { name, micros, lost })
}

/// `(battery_low events, rtl commands)` in a recording that replays with
/// no difference.
fn recorded(project: &Path, recording: &Path) -> Option<(usize, usize)> {
    let out = Command::new(env!("CARGO_BIN_EXE_petrel"))
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
    let mut results = Vec::new();

    let port = free_port();
    let petrel = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("run")
        .arg(&here)
        .args(["--mavlink", &format!("udpin:127.0.0.1:{port}"), "--profile"])
        .arg(here.join("profile.toml"))
        .arg("--record")
        .arg(scratch.join("latency.mcap"))
        .args(["--duration", "3600"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn();
    let mut in_recording = None;
    match petrel {
        Ok(child) => {
            let mut guard = Killed(child);
            std::thread::sleep(Duration::from_millis(500));
            results.extend(trials("petrel run (recording on)", port, n));
            // Stop it cleanly, then find the rule's events and the net's
            // commands in its recording (replayed and checked against it).
            let pid = guard.0.id().to_string();
            let _ = Command::new("kill").args(["-TERM", &pid]).status();
            let _ = guard.0.wait();
            in_recording = recorded(&here, &scratch.join("latency.mcap"));
        }
        Err(e) => eprintln!("cannot start petrel: {e}"),
    }

    let port = free_port();
    let has_pymavlink = Command::new("python3")
        .args(["-c", "import pymavlink"])
        .status()
        .is_ok_and(|s| s.success());
    if has_pymavlink {
        let script = Command::new("python3")
            .arg(here.join("rtl.py"))
            .arg(format!("udpin:127.0.0.1:{port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn();
        if let Ok(child) = script {
            let _guard = Killed(child);
            std::thread::sleep(Duration::from_millis(1500));
            results.extend(trials("pymavlink script (baseline)", port, n));
        }
    } else {
        eprintln!(
            "skipped the pymavlink baseline: pymavlink is not installed (pip install pymavlink)"
        );
    }
    let _ = std::fs::remove_dir_all(&scratch);

    println!(
        "{:<30} {:>8} {:>10} {:>10} {:>10} {:>6}",
        "reactor", "trials", "p50 µs", "p99 µs", "max µs", "lost"
    );
    for s in &results {
        println!(
            "{:<30} {:>8} {:>10.1} {:>10.1} {:>10.1} {:>6}",
            s.name,
            s.micros.len(),
            s.pct(0.5),
            s.pct(0.99),
            s.pct(1.0),
            s.lost
        );
    }
    match in_recording {
        Some((events, commands)) => println!(
            "in the recording (replayed with --check-against: no difference): {events} battery_low events, {commands} rtl commands"
        ),
        None => println!("the recording could not be replayed and checked"),
    }
    if let [a, b] = results.as_slice() {
        println!(
            "ratio petrel / script: p50 {:.2}, p99 {:.2}",
            a.pct(0.5) / b.pct(0.5),
            a.pct(0.99) / b.pct(0.99)
        );
    }
}
