//! `petrel run` end to end over loopback: a scripted autopilot (rust-mavlink)
//! on UDP, the real binary, a project whose nets command the vehicle.

use crate::peer;
use crate::scratch;

use std::path::Path;
use std::time::Duration;

use mavlink::dialects::ardupilotmega::*;
use mavlink::MavHeader;
use scratch::Scratch;

fn petrel() -> tokio::process::Command {
    let mut c = tokio::process::Command::new(env!("CARGO_BIN_EXE_petrel"));
    c.current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."));
    c.kill_on_drop(true);
    c
}

/// A scratch folder holding a project of one net.
fn project(name: &str, net: &str) -> Scratch {
    let dir = Scratch::new(&format!("run-{name}"));
    std::fs::write(
        dir.join("project.toml"),
        "[[net]]\nfile = \"n.toml\"\nactive = true\n",
    )
    .expect("write");
    std::fs::write(dir.join("n.toml"), net).expect("write");
    dir
}

/// A free UDP port on 127.0.0.1 (bound then released).
fn free_port() -> u16 {
    let s = std::net::UdpSocket::bind("127.0.0.1:0").expect("bind");
    s.local_addr().expect("addr").port()
}

/// A scripted ArduCopter on UDP that flips from STABILIZE to GUIDED every
/// 100 ms and accepts every command.
pub(crate) async fn flipping_copter(port: u16) -> peer::Peer {
    let hb = peer::heartbeat(
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        MavType::MAV_TYPE_QUADROTOR,
    );
    let mut guided = hb.clone();
    if let MavMessage::HEARTBEAT(h) = &mut guided {
        h.custom_mode = 4; // GUIDED
    }
    let script: peer::Script = Box::new(|_, m| match peer::command_of(m) {
        Some(c) => vec![peer::now(peer::ack(c, MavResult::MAV_RESULT_ACCEPTED))],
        None => Vec::new(),
    });
    peer::Peer::start(
        &format!("udpout:127.0.0.1:{port}"),
        hb,
        vec![guided],
        script,
    )
    .await
}

const TAKEOFF_NET: &str = r#"name = "N"
places = ["wait", "taking_off", "up"]
initial = ["wait"]
final = ["up"]
[[transition]]
name = "go"
from = ["wait"]
to = ["taking_off"]
on = "mode_changed"
when = 'mode == "GUIDED"'
do = ["command takeoff {alt: 20}"]
[[transition]]
name = "ok"
from = ["taking_off"]
to = ["up"]
on = "command.ok"
when = 'verb == "takeoff"'
[[transition]]
name = "refused"
from = ["taking_off"]
to = ["wait"]
on = "command.failed"
"#;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn run_commands_the_vehicle_from_the_nets_and_hears_the_ack() {
    let dir = project("takeoff", TAKEOFF_NET);
    let recording = dir.join("flight.mcap");
    let port = free_port();
    // The copter flips from STABILIZE to GUIDED every 100 ms: mode_changed
    // fires on a change, not on the first mode heard.
    let vehicle = flipping_copter(port).await;
    let out = tokio::time::timeout(
        Duration::from_secs(30),
        petrel()
            .args([
                "run",
                dir.to_str().expect("utf-8"),
                "--mavlink",
                &format!("udpin:127.0.0.1:{port}"),
                "--duration",
                "3",
                "--json",
                "--record",
                recording.to_str().expect("utf-8"),
            ])
            .output(),
    )
    .await
    .expect("petrel stops by itself")
    .expect("petrel runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    let fired: Vec<&str> = lines
        .iter()
        .filter(|l| l["effect"] == "fired")
        .filter_map(|l| l["transition"].as_str())
        .collect();
    assert_eq!(fired, ["go", "ok"], "{stdout}");
    assert!(lines
        .iter()
        .any(|l| l["effect"] == "command" && l["verb"] == "takeoff"));
    assert_eq!(lines.last().expect("end")["end"], true);

    let seen = vehicle.seen.lock().expect("peer log").clone();
    // The gateway speaks as the vehicle's companion computer, never as a GCS.
    let hb = seen.iter().find_map(|s| match &s.message {
        MavMessage::HEARTBEAT(h) => Some((s.header, h.clone())),
        _ => None,
    });
    let (header, hb) = hb.expect("the gateway's heartbeat");
    assert_eq!((header.system_id, header.component_id), (1, 191));
    assert_eq!(hb.mavtype, MavType::MAV_TYPE_ONBOARD_CONTROLLER);
    assert_eq!(hb.autopilot, MavAutopilot::MAV_AUTOPILOT_INVALID);
    // It asked for telemetry.
    assert!(seen.iter().any(|s| matches!(&s.message, MavMessage::COMMAND_LONG(c) if c.command == MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL)));
    // And commanded the takeoff the net asked for.
    let takeoff = seen.iter().find_map(|s| match &s.message {
        MavMessage::COMMAND_LONG(c) if c.command == MavCmd::MAV_CMD_NAV_TAKEOFF => Some(c.clone()),
        _ => None,
    });
    assert_eq!(takeoff.expect("takeoff commanded").param7, 20.0);

    // Every frame the gateway sent is in the recording, byte for byte as
    // the vehicle received it: the takeoff command among them.
    let bytes = std::fs::read(&recording).expect("recording");
    let sent: Vec<Vec<u8>> = mcap::MessageStream::new(&bytes)
        .expect("MCAP")
        .filter_map(Result::ok)
        .filter(|m| m.channel.topic == "/mavlink/sent")
        .map(|m| m.data[8..].to_vec())
        .collect();
    let takeoffs: Vec<(MavHeader, MavMessage)> = sent
        .iter()
        .filter_map(|bytes| {
            let frame = elaboration::Frame::parse(bytes).ok()?;
            let message = frame.decode().ok()?;
            matches!(&message, MavMessage::COMMAND_LONG(c) if c.command == MavCmd::MAV_CMD_NAV_TAKEOFF)
                .then(|| (frame.header(), message))
        })
        .collect();
    assert_eq!(takeoffs.len(), 1, "{} frames sent", sent.len());
    let (header, message) = &takeoffs[0];
    assert!(
        seen.iter()
            .any(|s| s.header == *header && s.message == *message),
        "the recorded frame is not the one the vehicle received"
    );

    // The recording replays the flight's decisions exactly.
    let replay = petrel()
        .args([
            "replay",
            recording.to_str().expect("utf-8"),
            dir.to_str().expect("utf-8"),
            "--check-against",
            "--json",
        ])
        .output()
        .await
        .expect("petrel replay runs");
    let replayed = String::from_utf8_lossy(&replay.stdout);
    assert_eq!(
        replay.status.code(),
        Some(0),
        "{replayed}{}",
        String::from_utf8_lossy(&replay.stderr)
    );
    let fired_again: Vec<String> = replayed
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|l| l["effect"] == "fired")
        .filter_map(|l| l["transition"].as_str().map(str::to_owned))
        .collect();
    assert_eq!(fired_again, ["go", "ok"]);
}

#[tokio::test]
async fn run_refuses_a_project_that_fails_check_unless_unchecked() {
    let dir = project(
        "deadlock",
        "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"armed\"\n",
    );
    let out = petrel()
        .args([
            "run",
            dir.to_str().expect("utf-8"),
            "--mavlink",
            "udpin:127.0.0.1:0",
            "--duration",
            "0.3",
            "--no-record",
        ])
        .output()
        .await
        .expect("petrel runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("refusing to run"), "{err}");
    assert!(err.contains("deadlocks        FAILED"), "{err}");
    let out = petrel()
        .args([
            "run",
            dir.to_str().expect("utf-8"),
            "--mavlink",
            "udpin:127.0.0.1:0",
            "--duration",
            "0.3",
            "--unchecked",
            "--no-record",
        ])
        .output()
        .await
        .expect("petrel runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    // No autopilot on the link and no `[gateway] firmware`: the wait for
    // its HEARTBEAT (up to 3 s) stays within `--duration`.
    assert!(err.contains("no autopilot HEARTBEAT yet"), "{err}");
    let after: f64 = err
        .split("stopped after ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no `stopped after`: {err}"));
    assert!(
        after < 2.5,
        "held {after} s for a --duration of 0.3 s: {err}"
    );
}

/// A team runs (gateway/tests/team.rs), but a vehicle whose `profile` does
/// not load is refused before any link opens, naming the vehicle.
#[tokio::test]
async fn run_refuses_a_team_vehicle_whose_profile_does_not_load() {
    let team = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../nets/tests/fixtures/team");
    let out = petrel()
        .args([
            "run",
            team.to_str().expect("utf-8"),
            "--mavlink",
            "udpin:127.0.0.1:0",
            "--duration",
            "0.3",
            "--no-record",
            "--unchecked",
        ])
        .output()
        .await
        .expect("petrel runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("vehicle R1: cannot read the profile") && err.contains("ardupilot-rover"),
        "{err}"
    );
}

/// A profile layer named in `[gateway]`, beside project.toml, and a clock
/// running faster than the wall: the layer's event starts a net timer whose
/// command comes exactly its duration later on the gateway's clock; the
/// recording carries the layer, so the replay needs neither `--profile` nor
/// the file.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn run_takes_the_project_profile_and_a_faster_clock() {
    let dir = project(
        "layer",
        r#"name = "N"
places = ["wait", "waiting", "taking_off", "up"]
initial = ["wait"]
final = ["up"]
[[transition]]
name = "seen"
from = ["wait"]
to = ["waiting"]
on = "guided"
when = "custom == 4"
do = ["timer settle after 2s"]
[[transition]]
name = "settled"
from = ["waiting"]
to = ["taking_off"]
on = "settle"
do = ["command takeoff {alt: 30}"]
[[transition]]
name = "ok"
from = ["taking_off"]
to = ["up"]
on = "command.ok"
[[transition]]
name = "refused"
from = ["taking_off"]
to = ["wait"]
on = "command.failed"
"#,
    );
    std::fs::write(
        dir.join("project.toml"),
        "[[net]]\nfile = \"n.toml\"\nactive = true\n[gateway]\nprofile = \"extra.toml\"\n",
    )
    .expect("write");
    std::fs::write(
        dir.join("extra.toml"),
        "[rules.guided]\ncategory = \"nominal\"\nwhen = 'mode() == \"GUIDED\"'\nparams = { custom = \"HEARTBEAT.custom_mode\" }\n",
    )
    .expect("write");
    let recording = dir.join("fast.mcap");
    let port = free_port();
    let _vehicle = flipping_copter(port).await;
    let wall = std::time::Instant::now();
    let out = tokio::time::timeout(
        Duration::from_secs(30),
        petrel()
            .args([
                "run",
                dir.to_str().expect("utf-8"),
                "--mavlink",
                &format!("udpin:127.0.0.1:{port}"),
                "--time-scale",
                "4",
                "--duration",
                "2",
                "--json",
                "--record",
                recording.to_str().expect("utf-8"),
            ])
            .output(),
    )
    .await
    .expect("petrel stops by itself")
    .expect("petrel runs");
    let wall = wall.elapsed();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    let time_of = |pred: &dyn Fn(&serde_json::Value) -> bool| {
        lines
            .iter()
            .find(|l| pred(l))
            .and_then(|l| l["time_us"].as_u64())
            .unwrap_or_else(|| panic!("not in the timeline:\n{stdout}"))
    };
    let guided_at = time_of(&|l| l["input"] == "event" && l["event"] == "guided");
    let takeoff_at = time_of(&|l| l["effect"] == "command" && l["verb"] == "takeoff");
    // The timer runs on the gateway's clock: exactly 2 s of it (the
    // deadline is slept to, never early; a wake-up is late by a few ms of
    // wall time at most, 4 times that on this clock).
    let waited = takeoff_at - guided_at;
    assert!(
        (2_000_000..2_400_000).contains(&waited),
        "{waited} µs\n{stdout}"
    );
    // The gateway's clock ran about 4 times the wall: its last time is well
    // past the 2 s of wall-clock time the run lasted.
    let end = lines.last().expect("end")["time_us"]
        .as_u64()
        .expect("time");
    assert!(
        end >= 6_000_000 && (end as f64) <= wall.as_secs_f64() * 4.0e6,
        "{end} µs in {wall:?}"
    );
    let fired: Vec<&str> = lines
        .iter()
        .filter(|l| l["effect"] == "fired")
        .filter_map(|l| l["transition"].as_str())
        .collect();
    assert_eq!(fired, ["seen", "settled", "ok"], "{stdout}");

    // The layer travels in the recording: remove the file, replay as is.
    std::fs::remove_file(dir.join("extra.toml")).expect("removed");
    let replay = petrel()
        .args([
            "replay",
            recording.to_str().expect("utf-8"),
            dir.to_str().expect("utf-8"),
            "--check-against",
        ])
        .output()
        .await
        .expect("petrel replay runs");
    assert_eq!(
        replay.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&replay.stderr)
    );
}

/// Behind an endpoint that waits for its client to speak first (a
/// mavlink-router `Mode = Server` UDP endpoint, pymavlink's `udpin`), the
/// gateway announces itself from the start, says on stderr that no vehicle
/// answers, and adopts the vehicle's system id once it is heard.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn run_speaks_first_and_says_when_no_vehicle_is_heard() {
    let dir = project("speaks-first", TAKEOFF_NET);
    let server = std::net::UdpSocket::bind("127.0.0.1:0").expect("bind");
    let port = server.local_addr().expect("addr").port();
    server
        .set_read_timeout(Some(Duration::from_millis(200)))
        .expect("timeout");
    let child = petrel()
        .args([
            "run",
            dir.to_str().expect("utf-8"),
            "--mavlink",
            &format!("udpout:127.0.0.1:{port}"),
            "--unchecked",
            "--no-record",
            "--duration",
            "9",
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("petrel runs");
    let listen = tokio::task::spawn_blocking(move || {
        let start = std::time::Instant::now();
        // (seconds since start, sender, the gateway's heartbeats)
        let mut heard: Vec<(f64, (u8, u8))> = Vec::new();
        let mut answered = None;
        let mut buf = [0u8; 512];
        while start.elapsed() < Duration::from_secs(12) {
            let Ok((n, from)) = server.recv_from(&mut buf) else {
                continue;
            };
            let Ok(frame) = elaboration::Frame::parse(&buf[..n]) else {
                continue;
            };
            let header = frame.header();
            if let Ok(MavMessage::HEARTBEAT(hb)) = frame.decode() {
                assert_eq!(hb.mavtype, MavType::MAV_TYPE_ONBOARD_CONTROLLER);
                heard.push((
                    start.elapsed().as_secs_f64(),
                    (header.system_id as u8, header.component_id),
                ));
            }
            // Silent for 6 s, then the vehicle (system 7) answers, and keeps
            // heartbeating.
            let copter = |sequence: u8| {
                let hb = peer::heartbeat(
                    MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                    MavType::MAV_TYPE_QUADROTOR,
                );
                let header = MavHeader {
                    system_id: 7,
                    component_id: 1,
                    sequence,
                };
                let mut out = Vec::new();
                mavlink::write_v2_msg(&mut out, header, &hb).expect("encode");
                out
            };
            if answered.is_none() && start.elapsed() > Duration::from_secs(6) {
                for _ in 0..3 {
                    let _ = server.send_to(&copter(0), from);
                }
                answered = Some(start.elapsed().as_secs_f64());
            }
            if answered.is_some_and(|a| start.elapsed().as_secs_f64() > a + 1.0) {
                let out = copter(1);
                let _ = server.send_to(&out, from);
            }
        }
        (heard, answered)
    });
    let out = tokio::time::timeout(Duration::from_secs(30), child.wait_with_output())
        .await
        .expect("petrel stops by itself")
        .expect("petrel runs");
    let (heard, answered) = listen.await.expect("listener");
    let stderr = String::from_utf8_lossy(&out.stderr);
    let first = heard.first().expect("the gateway spoke first");
    assert!(first.0 < 3.0, "first heartbeat at {} s", first.0);
    assert_eq!(first.1, (1, 191), "announced as system 1, component 191");
    assert!(
        stderr.contains("no vehicle heard") && stderr.contains(&format!("127.0.0.1:{port}")),
        "{stderr}"
    );
    let answered = answered.expect("the vehicle answered");
    let after: Vec<_> = heard.iter().filter(|h| h.0 > answered + 0.5).collect();
    assert!(
        !after.is_empty(),
        "heartbeats after the vehicle answered: {heard:?}"
    );
    assert!(
        after.iter().all(|h| h.1 == (7, 191)),
        "adopted the vehicle's system id: {heard:?}"
    );
}

/// A thread's scheduling policy and real-time priority, from
/// /proc/PID/task/TID/stat (fields 41 and 40); `None` once it has gone.
fn policy_of(pid: u32, tid: &str) -> Option<(u32, u32)> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/task/{tid}/stat")).ok()?;
    // Fields after the command's name (which may hold spaces) and state:
    // field N is at index N - 3.
    let fields: Vec<&str> = stat[stat.rfind(')')? + 2..].split_whitespace().collect();
    Some((fields.get(38)?.parse().ok()?, fields.get(37)?.parse().ok()?))
}

/// `petrel run`'s threads while it runs: (thread id, policy, priority).
fn threads_of(pid: u32) -> Vec<(String, u32, u32)> {
    let mut threads = Vec::new();
    for entry in std::fs::read_dir(format!("/proc/{pid}/task")).expect("/proc") {
        let tid = entry
            .expect("task")
            .file_name()
            .to_string_lossy()
            .to_string();
        if let Some((policy, priority)) = policy_of(pid, &tid) {
            threads.push((tid, policy, priority));
        }
    }
    threads
}

const SCHED_OTHER: u32 = 0;
const SCHED_FIFO: u32 = 1;
const SCHED_BATCH: u32 = 3;

/// The loop asks for a real-time priority by itself (`--realtime-priority`,
/// 10 by default); the recorder's and the web monitor's threads do not run
/// at it. Without the privilege it says so and runs at the normal priority.
/// `--no-realtime` does not ask.
#[cfg(target_os = "linux")]
#[tokio::test]
async fn the_loop_asks_for_a_real_time_priority_and_nothing_else_inherits_it() {
    let dir = project("realtime", TAKEOFF_NET);
    let recording = dir.join("flight.mcap");
    for (options, asked) in [
        (vec!["--realtime-priority", "12"], Some(12)),
        (vec!["--no-realtime"], None),
    ] {
        let port = free_port();
        let _vehicle = flipping_copter(port).await;
        let mut child = petrel()
            .args([
                "run",
                dir.to_str().expect("utf-8"),
                "--mavlink",
                &format!("udpin:127.0.0.1:{port}"),
                "--unchecked",
                "--record",
                recording.to_str().expect("utf-8"),
                "--http",
                "0",
                "--duration",
                "2",
            ])
            .args(&options)
            .env("PETREL_LOG", "info")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("petrel runs");
        let pid = child.id().expect("a pid");
        // The loop, the recorder's and the monitor's threads have started.
        tokio::time::sleep(Duration::from_millis(1000)).await;
        let threads = threads_of(pid);
        let stderr = {
            let status = tokio::time::timeout(Duration::from_secs(30), child.wait())
                .await
                .expect("petrel stops by itself")
                .expect("petrel runs");
            let mut err = String::new();
            if let Some(mut e) = child.stderr.take() {
                use tokio::io::AsyncReadExt;
                let _ = e.read_to_string(&mut err).await;
            }
            assert!(status.success(), "{options:?}: {err}");
            err
        };
        let main = threads
            .iter()
            .find(|t| t.0 == pid.to_string())
            .expect("the main thread");
        assert!(
            threads.len() >= 3,
            "the loop, recorder, monitor: {threads:?}"
        );
        match asked {
            Some(priority) if stderr.contains("runs at real-time priority") => {
                assert_eq!((main.1, main.2), (SCHED_FIFO, priority), "{threads:?}");
            }
            Some(_) => {
                // Not privileged here: said, and the normal policy kept.
                assert!(
                    stderr.contains("refused") && stderr.contains("--no-realtime"),
                    "{stderr}"
                );
                println!("not privileged for a real-time policy: the refusal checked instead");
                assert_eq!(main.1, SCHED_OTHER, "{threads:?}");
            }
            None => {
                assert_eq!(main.1, SCHED_OTHER, "{threads:?}");
                assert!(!stderr.contains("real-time"), "{stderr}");
            }
        }
        // No other thread runs under a real-time policy.
        for (tid, policy, priority) in &threads {
            if *tid != pid.to_string() {
                assert!(
                    [SCHED_OTHER, SCHED_BATCH].contains(policy) && *priority == 0,
                    "thread {tid}: {threads:?}"
                );
            }
        }
        // The recorder's thread is in the batch policy.
        assert!(threads.iter().any(|t| t.1 == SCHED_BATCH), "{threads:?}");
    }
}

/// A `tcpin:` link waits for its client: within `--duration`, and a stop
/// (systemd's SIGTERM) meanwhile ends cleanly, saying so, with exit 0 —
/// `run`'s and the ground mirror's.
#[tokio::test]
async fn a_tcpin_link_nobody_connects_to_stops_at_the_duration_and_on_sigterm() {
    for verb in ["run", "mirror"] {
        tcpin_nobody_connects_to(verb).await;
    }
}

async fn tcpin_nobody_connects_to(verb: &str) {
    let dir = project(
        "tcpin",
        "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"up\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"armed\"\n[[transition]]\nname = \"down\"\nfrom = [\"b\"]\nto = [\"a\"]\non = \"disarmed\"\n",
    );
    let record = dir.join("run.mcap");
    let args = |extra: &[&str]| {
        let mut c = petrel();
        c.args([
            "run",
            dir.to_str().expect("utf-8"),
            "--mavlink",
            "tcpin:127.0.0.1:0",
            "--record",
        ])
        .arg(&record)
        .args(extra);
        c
    };
    let out = tokio::time::timeout(
        Duration::from_secs(30),
        args(&["--duration", "0.5"]).output(),
    )
    .await
    .expect("it stops by itself")
    .expect("petrel runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(err.contains("before the link opened"), "{verb}: {err}");
    assert!(!record.exists(), "{err}");

    let child = args(&[])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("petrel runs");
    let pid = libc::pid_t::try_from(child.id().expect("running")).expect("a pid");
    // Sent once the gateway catches SIGTERM (`SigCgt` in /proc), else the
    // default action would kill it before it could say anything.
    let catches_term = || {
        std::fs::read_to_string(format!("/proc/{pid}/status"))
            .ok()
            .and_then(|s| {
                let mask = s.lines().find_map(|l| l.strip_prefix("SigCgt:"))?;
                u64::from_str_radix(mask.trim(), 16).ok()
            })
            .is_some_and(|m| m & (1 << (libc::SIGTERM - 1)) != 0)
    };
    let until = std::time::Instant::now() + Duration::from_secs(20);
    while !catches_term() {
        assert!(std::time::Instant::now() < until, "SIGTERM never caught");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    // Past the pre-flight check, waiting for its client.
    tokio::time::sleep(Duration::from_millis(300)).await;
    // SAFETY: kill(2) on our own child, not reaped yet.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGTERM) }, 0);
    let out = tokio::time::timeout(Duration::from_secs(10), child.wait_with_output())
        .await
        .expect("it stops on SIGTERM")
        .expect("petrel runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(
        err.contains("stopped before the link opened"),
        "{verb}: {err}"
    );
    assert!(!record.exists(), "{err}");
}

/// A bad `[gateway]` value is refused before any link is opened, with the
/// file, line and column of the value (and exit status 2, bad input).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_bad_gateway_setting_is_refused_with_its_line_and_column() {
    let dir = project(
        "bad-gateway",
        "name = \"N\"\nplaces = [\"a\"]\ninitial = [\"a\"]\nfinal = [\"a\"]\n",
    );
    std::fs::write(
        dir.join("project.toml"),
        "[[net]]\nfile = \"n.toml\"\nactive = true\n\n[gateway.payloads]\ncam = { camera = 300 }\n",
    )
    .expect("write");
    let out = tokio::time::timeout(
        Duration::from_secs(30),
        petrel()
            .args([
                "run",
                dir.to_str().expect("utf-8"),
                "--mavlink",
                &format!("udpin:127.0.0.1:{}", free_port()),
                "--duration",
                "5",
            ])
            .output(),
    )
    .await
    .expect("petrel run refuses at once")
    .expect("petrel runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("project.toml:6:18: gateway.payloads.cam.camera: 300 is not in 1..=255"),
        "{err}"
    );
}
