//! Petrel on a companion computer, as deployed (docs/deploy.md):
//!
//! - the systemd unit shipped in `deploy/` passes `systemd-analyze verify`
//!   and keeps its promises (restart on failure, its own user, the
//!   recordings directory, the journal), and its command line is one
//!   `petrel run` accepts;
//! - `petrel run` against ArduPilot's real ArduPlane SITL behind MAVProxy
//!   used as a router (`--out udp:` to Petrel's `udpin:`), and over a
//!   serial link (a socat pseudo-terminal pair between SITL's
//!   `--serial1 uart:` and Petrel's `serial:`): the bench project's net
//!   hears the vehicle become ready, commands FBWA, gets `command.ok`, and
//!   sees the mode change in the autopilot's telemetry; the router then
//!   restarts and Petrel is answered through the new one; on the serial
//!   link a ground station on another port of the autopilot sees Petrel's
//!   companion HEARTBEAT;
//! - a USB serial device pulled out and plugged in again: `link_lost`, no
//!   spinning meanwhile, `link_restored` once it is back.
//!
//! The real-SITL tests use SITL instance 5 (TCP 5810..5813), moved by
//! their turn (`crate::sitl_turn`). Without the SITL binaries, MAVProxy, socat or systemd-analyze they
//! print why they are skipped; with `CI=true` they fail instead.

use crate::scratch;

mod gateway;
mod peers;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use gateway::{assert_bench_flight, bench_over, Gateway};
use mavlink::dialects::ardupilotmega::{MavMessage, MavType};
use scratch::Scratch;
use sitl_tests::ardupilot::{self, Firmware, Options, Sitl};

fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn unit_file() -> PathBuf {
    repository().join("deploy/petrel.service")
}

/// Where the unit installs the binary; the tests put the one just built
/// there instead.
const INSTALLED_BINARY: &str = "/usr/local/bin/petrel";

/// The `[Service]`-style `Key=value` lines of a unit or environment file,
/// in order (comments and section headers left out).
fn settings(text: &str) -> Vec<(String, String)> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#') && !l.starts_with(';'))
        .filter(|l| !l.starts_with('['))
        .filter_map(|l| l.split_once('='))
        .map(|(k, v)| (k.trim().to_owned(), v.trim().to_owned()))
        .collect()
}

fn setting<'a>(all: &'a [(String, String)], key: &str) -> Vec<&'a str> {
    all.iter()
        .filter(|(k, _)| k == key)
        .map(|(_, v)| v.as_str())
        .collect()
}

#[test]
fn the_unit_passes_systemd_analyze_verify() {
    let Some(analyze) = peers::require_program(
        "systemd-analyze",
        "the_unit_passes_systemd_analyze_verify",
        "apt-get install -y systemd",
    ) else {
        return;
    };
    let text = std::fs::read_to_string(unit_file()).expect("deploy/petrel.service");
    assert!(
        text.contains(INSTALLED_BINARY),
        "ExecStart moved: update this test"
    );
    // verify checks that ExecStart's binary exists: point it at ours.
    let dir = Scratch::new("deploy");
    let unit = dir.path().join("petrel.service");
    std::fs::write(
        &unit,
        text.replace(INSTALLED_BINARY, env!("CARGO_BIN_EXE_petrel")),
    )
    .expect("write the unit");
    let out = Command::new(&analyze)
        .args(["verify", "--man=no"])
        .arg(&unit)
        .output()
        .expect("run systemd-analyze");
    let stderr = String::from_utf8_lossy(&out.stderr);
    // Unknown keys and bad values are only warnings (exit 0): any line
    // about our unit fails the test.
    let about_unit: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("petrel.service"))
        .collect();
    assert!(
        out.status.success() && about_unit.is_empty(),
        "systemd-analyze verify: {}\n{stderr}",
        out.status
    );

    // And it catches a broken unit, so the check above means something.
    let broken = dir.path().join("broken.service");
    std::fs::write(
        &broken,
        std::fs::read_to_string(&unit)
            .expect("unit")
            .replace("Restart=on-failure", "Restart=on-failur"),
    )
    .expect("write");
    let out = Command::new(&analyze)
        .args(["verify", "--man=no"])
        .arg(&broken)
        .output()
        .expect("run systemd-analyze");
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("broken.service"),
        "systemd-analyze did not notice a bad Restart= value"
    );
}

#[test]
fn the_unit_restarts_records_and_logs_as_documented() {
    let text = std::fs::read_to_string(unit_file()).expect("deploy/petrel.service");
    let s = settings(&text);
    let one = |key: &str| -> &str {
        match setting(&s, key)[..] {
            [v] => v,
            ref v => panic!("{key}: expected one value, found {v:?}"),
        }
    };
    assert_eq!(one("Restart"), "on-failure");
    assert_eq!(
        one("RestartPreventExitStatus"),
        "1",
        "petrel check refusals only"
    );
    assert_eq!(
        one("StartLimitIntervalSec"),
        "0",
        "never give up restarting"
    );
    let user = one("User");
    assert!(!user.is_empty() && user != "root", "User={user}");
    assert!(setting(&s, "SupplementaryGroups")
        .iter()
        .any(|g| g.split_whitespace().any(|g| g == "dialout")));
    // Recordings: petrel writes recordings/ under its working directory,
    // which must be the state directory systemd creates for it.
    assert_eq!(one("WorkingDirectory"), "/var/lib/petrel");
    let state: Vec<&str> = one("StateDirectory").split_whitespace().collect();
    assert!(state.contains(&"petrel") && state.contains(&"petrel/recordings"));
    assert_eq!(one("StandardOutput"), "journal");
    assert_eq!(one("StandardError"), "journal");
    assert_eq!(one("KillSignal"), "SIGTERM");
    assert_eq!(
        one("ExecStart"),
        format!("{INSTALLED_BINARY} run ${{PETREL_PROJECT}} $PETREL_OPTIONS")
    );
}

/// The unit's command line with the example environment file's values
/// (deploy/petrel.env), the project swapped for `deploy/listen` (which
/// commands nothing) and the serial port for a loopback UDP port: every
/// option it passes is one `petrel run` takes, it records under
/// `recordings/` of its working directory, and SIGTERM stops it with 0.
#[test]
fn the_units_command_line_runs() {
    let unit = settings(&std::fs::read_to_string(unit_file()).expect("unit"));
    let env_text = std::fs::read_to_string(repository().join("deploy/petrel.env")).expect("env");
    let mut env: HashMap<String, String> = HashMap::new();
    for (k, v) in setting(&unit, "Environment")
        .iter()
        .filter_map(|kv| kv.split_once('='))
    {
        env.insert(k.to_owned(), v.to_owned());
    }
    for (k, v) in settings(&env_text) {
        env.insert(k, v);
    }
    let options = env
        .get("PETREL_OPTIONS")
        .expect("PETREL_OPTIONS in petrel.env");
    assert!(
        options.starts_with("--mavlink serial:"),
        "the example is a serial link: {options}"
    );
    let exec = setting(&unit, "ExecStart")[0];
    let words: Vec<String> = exec
        .split_whitespace()
        .skip(1) // the binary
        .flat_map(|w| match w {
            // The link-check project shipped beside the unit.
            "${PETREL_PROJECT}" => vec![repository().join("deploy/listen").display().to_string()],
            // Unbraced: split into words, as systemd does. The serial port
            // of the example is not on this machine: a loopback UDP port.
            "$PETREL_OPTIONS" => options
                .split_whitespace()
                .map(|o| {
                    if o.starts_with("serial:") {
                        "udpin:127.0.0.1:0".to_owned()
                    } else {
                        o.to_owned()
                    }
                })
                .collect(),
            other => vec![other.to_owned()],
        })
        .collect();
    assert_eq!(words[0], "run");
    let dir = Scratch::new("deploy");
    let started = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .args(&words)
        .current_dir(dir.path())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("petrel run");
    // Let it open the link and start recording, then stop it as systemd does.
    std::thread::sleep(Duration::from_millis(1500));
    let pid = libc::pid_t::try_from(child.id()).expect("pid");
    // SAFETY: kill(2) on our own child, not yet reaped.
    unsafe {
        libc::kill(pid, libc::SIGTERM);
    }
    let deadline = Instant::now() + Duration::from_secs(20);
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            break child.wait().expect("reap");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let out = child.wait_with_output().expect("stderr");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(status.code(), Some(0), "{words:?}\n{stderr}");
    assert!(stderr.contains("stopped after"), "{stderr}");
    let recordings: Vec<PathBuf> = std::fs::read_dir(dir.path().join("recordings"))
        .expect("recordings/ made in the working directory")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .collect();
    assert_eq!(recordings.len(), 1, "{recordings:?}");
    let name = recordings[0]
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or("");
    assert!(
        name.starts_with("petrel-") && name.ends_with(".mcap"),
        "{name}"
    );
    eprintln!(
        "the_units_command_line_runs: {:.1} s",
        started.elapsed().as_secs_f64()
    );
}

const INSTANCE: u8 = 5;
const SPEEDUP: u32 = 10;
/// From the gateway's start to the bench net's end: boot and EKF/GPS take
/// 30-45 s of simulated time (3-5 s at speedup 10 on an idle machine).
const BENCH_LIMIT: Duration = Duration::from_secs(90);

fn free_udp_port() -> u16 {
    let s = std::net::UdpSocket::bind("127.0.0.1:0").expect("bind");
    s.local_addr().expect("addr").port()
}

#[test]
fn through_mavproxy_as_a_router() {
    let test = "through_mavproxy_as_a_router";
    let Some(plane) = ardupilot::require(Firmware::Plane, test) else {
        return;
    };
    let Some(mavproxy) = peers::require_program("mavproxy.py", test, "pip install MAVProxy") else {
        return;
    };
    let turn = crate::sitl_turn();
    let started = Instant::now();
    let scratch = Scratch::new("deploy");
    let options = Options {
        instance: turn.instance(INSTANCE),
        speedup: SPEEDUP,
        ..Options::default()
    };
    let sitl = Sitl::start(&plane, &options, &scratch.path().join("sitl")).expect("SITL starts");
    let recording = scratch.path().join("router.mcap");
    let port = free_udp_port();
    // Petrel listens first; MAVProxy then connects to SERIAL0 (starting
    // the simulation) and forwards to Petrel's port, and Petrel's replies
    // go back to MAVProxy's address, which it learnt.
    let mut petrel = Gateway::start(&format!("udpin:127.0.0.1:{port}"), &recording);
    let first_log = scratch.path().join("mavproxy.log");
    let mut router = peers::mavproxy(&mavproxy, sitl.port(0), port, &first_log);
    let done = petrel.wait_for(BENCH_LIMIT, bench_over);
    let bench_at = started.elapsed();
    router.assert_running(&first_log);
    // The router restarts (`systemctl restart mavlink-router`): it comes
    // back from another UDP port, which Petrel must learn to answer.
    drop(router);
    let within = |petrel: &Gateway, s: u64| petrel.started.elapsed() + Duration::from_secs(s);
    let lost = done && petrel.wait_for(within(&petrel, 15), |l| l["event"] == "link_lost");
    let lost_at = started.elapsed();
    let second_log = scratch.path().join("mavproxy-again.log");
    let _router = peers::mavproxy(&mavproxy, sitl.port(0), port, &second_log);
    let restored = lost && petrel.wait_for(within(&petrel, 60), |l| l["event"] == "link_restored");
    let restored_after = started.elapsed();
    let restored_at = petrel.timeline.last().and_then(|l| l["time_us"].as_u64());
    // Petrel asks for its telemetry again on the link's return: give the
    // answers 5 s to come back (checked in the recording below).
    if restored {
        petrel.wait_for(within(&petrel, 5), |_| false);
    }
    let stopped = petrel.stop();
    let logs = || {
        format!(
            "SITL:\n{}\nMAVProxy:\n{}\nMAVProxy again:\n{}",
            sitl.output(),
            std::fs::read_to_string(&first_log).unwrap_or_default(),
            std::fs::read_to_string(&second_log).unwrap_or_default()
        )
    };
    assert!(
        done,
        "the bench net did not end within {BENCH_LIMIT:?}: {:?}\n{}",
        gateway::fired(&stopped.timeline),
        logs()
    );
    assert!(lost, "no link_lost once the router was gone\n{}", logs());
    assert!(
        restored,
        "no link_restored once the router was back\n{}",
        logs()
    );
    assert_bench_flight(&stopped, &recording, "udpin behind MAVProxy");
    // After the restart the autopilot answered Petrel (component 191)
    // through the new router: Petrel's replies found its new address.
    let restored_at = restored_at.expect("link_restored's time");
    let answered = gateway::recorded_frames(&recording, "/mavlink/raw")
        .into_iter()
        .filter(|(t, h, _)| *t > restored_at && (h.system_id, h.component_id) == (1, 1))
        .filter(
            |(_, _, m)| matches!(m, Some(MavMessage::COMMAND_ACK(a)) if a.target_component == 191),
        )
        .count();
    assert!(
        answered > 0,
        "no COMMAND_ACK to Petrel after the router came back\n{}",
        logs()
    );
    eprintln!(
        "{test}: {:.1} s (bench net done at {:.1} s, link_lost at {:.1} s, link_restored at {:.1} s; stop on SIGTERM {:.2} s)",
        started.elapsed().as_secs_f64(),
        bench_at.as_secs_f64(),
        lost_at.as_secs_f64(),
        restored_after.as_secs_f64(),
        stopped.stop_time.as_secs_f64()
    );
}

#[test]
fn over_a_serial_link() {
    let test = "over_a_serial_link";
    let Some(plane) = ardupilot::require(Firmware::Plane, test) else {
        return;
    };
    let Some(socat) = peers::require_program("socat", test, "apt-get install -y socat") else {
        return;
    };
    let turn = crate::sitl_turn();
    let started = Instant::now();
    let scratch = Scratch::new("deploy");
    let cable = peers::PtyPair::open(&socat, scratch.path());
    // SERIAL1 as the flight controller's TELEM port to the companion
    // computer: MAVLink 2 at 57600 baud, on the pseudo-terminal.
    let wired = peers::with_serial1_uart(&plane, &cable.autopilot, 57600, scratch.path());
    let options = Options {
        instance: turn.instance(INSTANCE),
        speedup: SPEEDUP,
        params: vec![
            ("SERIAL1_PROTOCOL".into(), 2.0),
            ("SERIAL1_BAUD".into(), 57.0),
            // Accept MAVLink from the ground station's system id only
            // (SYSID_ENFORCE before 4.7): the vehicle's own components,
            // Petrel among them, are still obeyed.
            ("MAV_OPTIONS".into(), 1.0),
        ],
        ..Options::default()
    };
    let sitl = Sitl::start(&wired, &options, &scratch.path().join("sitl")).expect("SITL starts");
    let recording = scratch.path().join("serial.mcap");
    let mut petrel = Gateway::start(
        &format!("serial:{}:57600", cable.companion.display()),
        &recording,
    );
    // SITL simulates nothing until SERIAL0 has a client: a ground station
    // that only listens.
    let ground = peers::GroundStation::connect(sitl.port(0));
    let done = petrel.wait_for(BENCH_LIMIT, bench_over);
    let stopped = petrel.stop();
    let heard = peers::frames(&ground.finish());
    assert!(
        done,
        "the bench net did not end within {BENCH_LIMIT:?}: {:?}\nSITL:\n{}",
        gateway::fired(&stopped.timeline),
        sitl.output()
    );
    assert!(
        sitl.output().contains("UART connection"),
        "SITL did not open the pseudo-terminal:\n{}",
        sitl.output()
    );
    assert_bench_flight(&stopped, &recording, "serial");
    // ArduPilot routes between its ports: the ground station's port heard
    // Petrel's companion HEARTBEAT (1, 191), never a GCS one.
    let companion: Vec<&MavMessage> = heard
        .iter()
        .filter(|(sys, comp, _)| (*sys, *comp) == (1, 191))
        .filter_map(|(_, _, m)| m.as_ref())
        .collect();
    assert!(
        companion.iter().any(|m| matches!(m,
            MavMessage::HEARTBEAT(h) if h.mavtype == MavType::MAV_TYPE_ONBOARD_CONTROLLER)),
        "the ground station's port never heard Petrel's HEARTBEAT ({} frames heard, {} from 1/191)",
        heard.len(),
        companion.len()
    );
    // And the other way: Petrel heard the ground station through the
    // autopilot, and still took only the autopilot for the vehicle.
    assert!(
        !gateway::recorded_json(&recording, "/mavlink/255/190/HEARTBEAT").is_empty(),
        "the ground station's HEARTBEAT did not reach Petrel"
    );
    eprintln!(
        "{test}: {:.1} s (stop on SIGTERM {:.2} s)",
        started.elapsed().as_secs_f64(),
        stopped.stop_time.as_secs_f64()
    );
}

/// A USB serial link pulled out and plugged in again (`/dev/ttyACM0` of a
/// flight controller's USB port, a USB-serial adapter): the nets must hear
/// `link_lost`, the gateway must not spin while the device is gone, and the
/// link must come back by itself once the device is back (a TCP link is
/// reopened every 0.5 s; a serial link should be too).
#[test]
fn a_usb_serial_link_comes_back() {
    let test = "a_usb_serial_link_comes_back";
    let Some(plane) = ardupilot::require(Firmware::Plane, test) else {
        return;
    };
    let Some(socat) = peers::require_program("socat", test, "apt-get install -y socat") else {
        return;
    };
    let turn = crate::sitl_turn();
    let started = Instant::now();
    let scratch = Scratch::new("deploy");
    let options = Options {
        instance: turn.instance(INSTANCE),
        speedup: SPEEDUP,
        ..Options::default()
    };
    let sitl = Sitl::start(&plane, &options, &scratch.path().join("sitl")).expect("SITL starts");
    let _ground = peers::GroundStation::connect(sitl.port(0));
    let mut usb = peers::UsbSerial::plugged(&socat, sitl.port(1), scratch.path());
    let recording = scratch.path().join("usb.mcap");
    let mut petrel = Gateway::start(
        &format!("serial:{}:115200", usb.device.display()),
        &recording,
    );
    assert!(
        petrel.wait_for(BENCH_LIMIT, bench_over),
        "the link never worked: {:?}",
        gateway::fired(&petrel.timeline)
    );
    usb.pull();
    let before = petrel.cpu_time();
    let lost = petrel.wait_for(Duration::from_secs(10) + petrel.started.elapsed(), |l| {
        l["event"] == "link_lost"
    });
    let busy = petrel.cpu_time() - before;
    usb.plug();
    let back = petrel.wait_for(Duration::from_secs(15) + petrel.started.elapsed(), |l| {
        l["event"] == "link_restored"
    });
    let stopped = petrel.stop();
    eprintln!("{test}: {:.1} s", started.elapsed().as_secs_f64());
    let mut problems = Vec::new();
    if !lost {
        problems.push("no link_lost after the device went away".to_owned());
    }
    if busy > Duration::from_millis(500) {
        problems.push(format!(
            "{busy:?} of CPU between the device going away and link_lost: the gateway spins"
        ));
    }
    if !back {
        problems.push("no link_restored within 15 s of the device coming back".to_owned());
    }
    assert!(
        problems.is_empty(),
        "{}\n{}",
        problems.join("\n"),
        stopped.stderr
    );
}
