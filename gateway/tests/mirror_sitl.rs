//! The ground mirror against ArduPilot's own ArduPlane SITL, with
//! ArduPilot itself routing the downlink (no router of ours): the real
//! `petrel run --downlink` and DEC on SERIAL1 (the companion's port), the
//! real `petrel mirror` on SERIAL0 (the ground's telemetry port) behind a
//! pass-through that keeps every byte the mirror sends, and a ground
//! station (system 255) on SERIAL2 that falls silent in flight. The
//! replica must equal the vehicle over the whole flight, every frame the
//! mirror sent must be a resync request, and ArduPlane's own GCS failsafe
//! must still trigger with the mirror running. Without the SITL binary the
//! test says why and returns; with `CI=true` it fails.

#[path = "scenarios/flight.rs"]
mod flight;
#[path = "scenarios/real.rs"]
mod real;
#[path = "support/scratch.rs"]
mod scratch;
#[path = "mirror/wire.rs"]
mod wire;

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use elaboration::{Frame, FrameError};
use flight::{free_port, project, Dec, Running};
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavConnection, MavHeader};
use real::Truth;
use scratch::Scratch;
use sitl_tests::ardupilot::{self, Firmware, Options, Sitl};
use wire::{fired, only_resync_requests, the_recording_checks_out};

/// The mission file DEC reads, in the project folder.
pub const MISSION_FILE: &str = "mission.toml";

/// SITL instance of this test (docs: one instance per test binary).
const INSTANCE: u8 = 9;
const SPEEDUP: u32 = 10;
const MAX_SIM_S: f64 = 700.0;
/// The ground station ArduPlane watches (`SYSID_MYGCS`'s default).
const GCS: (u8, u8) = (255, 190);

/// What the mission needs of ArduPlane (docs/flight-test.md), the GCS
/// failsafe on (heartbeat, 5 s, then RTL, which RTL_AUTOLAND turns into
/// the landing sequence), and SERIAL0 streaming what a ground station's
/// telemetry carries (nothing asks for it: the mirror never speaks but to
/// ask for records).
const PARAMS: &[(&str, f64)] = &[
    ("RTL_AUTOLAND", 2.0),
    ("FS_GCS_ENABL", 1.0),
    ("FS_LONG_ACTN", 1.0),
    ("FS_LONG_TIMEOUT", 5.0),
    ("SERIAL1_BAUD", 921.0),
    ("SERIAL2_BAUD", 921.0),
    ("SR0_EXT_STAT", 2.0),
    ("SR0_POSITION", 4.0),
    ("SR0_EXTRA1", 4.0),
    ("SR0_EXTRA2", 4.0),
    ("SR0_EXTRA3", 2.0),
    ("SR0_RAW_SENS", 2.0),
    ("SR0_RC_CHAN", 2.0),
];

/// Bytes kept with the time they were read (µs since the UNIX epoch).
type Stamped = Arc<Mutex<Vec<(u64, Vec<u8>)>>>;

/// A pass-through between the mirror and SERIAL0 that keeps the bytes the
/// mirror sends. SITL listens first; the mirror connects here.
struct Tap {
    port: u16,
    from_mirror: Arc<Mutex<Vec<u8>>>,
    /// What SITL sent the mirror: (µs since the UNIX epoch, bytes), read by
    /// read, for a tlog of the ground's telemetry.
    to_mirror: Stamped,
    stop: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
}

impl Tap {
    fn start(serial0: u16) -> Tap {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a local port");
        let port = listener.local_addr().expect("its address").port();
        let from_mirror = Arc::new(Mutex::new(Vec::new()));
        let to_mirror = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let (kept, heard, stopping) = (from_mirror.clone(), to_mirror.clone(), stop.clone());
        let accept = std::thread::spawn(move || {
            let _ = listener.set_nonblocking(true);
            let started = Instant::now();
            let mirror = loop {
                match listener.accept() {
                    Ok((s, _)) => break s,
                    Err(_) if stopping.load(Ordering::Relaxed) => return,
                    Err(_) if started.elapsed() > Duration::from_secs(240) => return,
                    Err(_) => std::thread::sleep(Duration::from_millis(20)),
                }
            };
            let Ok(sitl) = ardupilot::connect(serial0, Duration::from_secs(20)) else {
                return;
            };
            let _ = mirror.set_nonblocking(false);
            let pump = |mut from: TcpStream,
                        mut to: TcpStream,
                        keep: Option<Arc<Mutex<Vec<u8>>>>,
                        stamped: Option<Stamped>| {
                let stopping = stopping.clone();
                std::thread::spawn(move || {
                    let _ = from.set_read_timeout(Some(Duration::from_millis(100)));
                    let mut chunk = [0u8; 4096];
                    while !stopping.load(Ordering::Relaxed) {
                        match from.read(&mut chunk) {
                            Ok(0) => break,
                            Ok(n) => {
                                if let Some(k) = &keep {
                                    if let Ok(mut k) = k.lock() {
                                        k.extend_from_slice(&chunk[..n]);
                                    }
                                }
                                if let Some(k) = &stamped {
                                    let now = std::time::SystemTime::now()
                                        .duration_since(std::time::UNIX_EPOCH)
                                        .map(|d| d.as_micros() as u64)
                                        .unwrap_or(0);
                                    if let Ok(mut k) = k.lock() {
                                        k.push((now, chunk[..n].to_vec()));
                                    }
                                }
                                if to.write_all(&chunk[..n]).is_err() {
                                    break;
                                }
                            }
                            Err(e)
                                if matches!(
                                    e.kind(),
                                    ErrorKind::WouldBlock | ErrorKind::TimedOut
                                ) => {}
                            Err(_) => break,
                        }
                    }
                    let _ = to.shutdown(std::net::Shutdown::Both);
                })
            };
            let (m2, s2) = match (mirror.try_clone(), sitl.try_clone()) {
                (Ok(m), Ok(s)) => (m, s),
                _ => return,
            };
            let up = pump(mirror, sitl, Some(kept), None);
            let down = pump(s2, m2, None, Some(heard));
            let _ = up.join();
            let _ = down.join();
        });
        Tap {
            port,
            from_mirror,
            to_mirror,
            stop,
            threads: vec![accept],
        }
    }

    fn frames(&self) -> Vec<Vec<u8>> {
        let bytes = self
            .from_mirror
            .lock()
            .map(|b| b.clone())
            .unwrap_or_default();
        let mut frames = Vec::new();
        let mut pos = 0;
        while pos < bytes.len() {
            match Frame::parse(&bytes[pos..]) {
                Ok(f) => {
                    frames.push(f.bytes().to_vec());
                    pos += f.bytes().len();
                }
                Err(FrameError::Truncated { .. }) => {
                    panic!("the mirror's last frame is cut: {:?}", &bytes[pos..])
                }
                Err(e) => panic!("the mirror sent bytes that are no MAVLink frame ({e}) at {pos}"),
            }
        }
        frames
    }
}

impl Tap {
    /// The ground's telemetry as a tlog (each frame stamped with the read
    /// that completed it), for `petrel events` after a failure.
    fn write_ground_tlog(&self, path: &std::path::Path) {
        let chunks = self.to_mirror.lock().map(|c| c.clone()).unwrap_or_default();
        let Ok(file) = std::fs::File::create(path) else {
            return;
        };
        let mut tlog = elaboration::TlogWriter::new(std::io::BufWriter::new(file));
        let mut buf: Vec<u8> = Vec::new();
        for (t, chunk) in chunks {
            buf.extend_from_slice(&chunk);
            let mut pos = 0;
            while pos < buf.len() {
                match Frame::parse(&buf[pos..]) {
                    Ok(f) => {
                        let _ = tlog.write_frame(t, f.bytes());
                        pos += f.bytes().len();
                    }
                    Err(FrameError::Truncated { .. }) => break,
                    Err(_) => pos += 1,
                }
            }
            buf.drain(..pos);
        }
    }
}

impl Drop for Tap {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// A ground station on SERIAL2: system 255's HEARTBEAT at 2 Hz of the
/// vehicle's time while `alive`, and the truth of what ArduPlane does.
struct Ground {
    link: Arc<mavlink::Connection<MavMessage>>,
    truth: Arc<Mutex<Truth>>,
    alive: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
}

impl Ground {
    fn start(port: u16) -> Ground {
        let address = format!("tcpout:127.0.0.1:{port}");
        let started = Instant::now();
        let link = loop {
            match mavlink::connect::<MavMessage>(&address) {
                Ok(c) => break c,
                Err(e) if started.elapsed() > Duration::from_secs(20) => {
                    panic!("SERIAL2 ({address}) never opened: {e}")
                }
                Err(_) => std::thread::sleep(Duration::from_millis(200)),
            }
        };
        let link = Arc::new(link);
        let truth = Arc::new(Mutex::new(Truth::default()));
        let alive = Arc::new(AtomicBool::new(true));
        let stop = Arc::new(AtomicBool::new(false));
        let (l, t, s) = (link.clone(), truth.clone(), stop.clone());
        let reader = std::thread::spawn(move || {
            while !s.load(Ordering::Relaxed) {
                match l.recv() {
                    Ok((h, m)) if (h.system_id, h.component_id) == (1, 1) => {
                        if let Ok(mut t) = t.lock() {
                            t.heard(&m);
                        }
                    }
                    Ok(_) | Err(mavlink::error::MessageReadError::Parse(_)) => {}
                    Err(mavlink::error::MessageReadError::Io(e))
                        if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                    Err(_) => break,
                }
            }
        });
        let (l, a, s) = (link.clone(), alive.clone(), stop.clone());
        let beating = std::thread::spawn(move || {
            let header = MavHeader {
                system_id: u32::from(GCS.0),
                component_id: GCS.1,
                sequence: 0,
            };
            while !s.load(Ordering::Relaxed) {
                if a.load(Ordering::Relaxed) {
                    let _ = l.send(
                        &header,
                        &MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                            custom_mode: 0,
                            mavtype: MavType::MAV_TYPE_GCS,
                            autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
                            base_mode: MavModeFlag::empty(),
                            system_status: MavState::MAV_STATE_ACTIVE,
                            mavlink_version: 3,
                        }),
                    );
                }
                std::thread::sleep(Duration::from_millis(500 / u64::from(SPEEDUP)));
            }
        });
        let ground = Ground {
            link,
            truth,
            alive,
            stop,
            threads: vec![reader, beating],
        };
        for (id, hz) in [(0u32, 10.0f32), (33, 4.0), (74, 2.0), (2, 2.0)] {
            ground.command(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, [id as f32, 1e6 / hz]);
        }
        ground
    }

    fn command(&self, command: MavCmd, [p1, p2]: [f32; 2]) {
        let header = MavHeader {
            system_id: u32::from(GCS.0),
            component_id: GCS.1,
            sequence: 0,
        };
        let _ = self.link.send(
            &header,
            &sitl_tests::wire::command_long((1, 1), command, [p1, p2, 0.0, 0.0, 0.0, 0.0, 0.0]),
        );
    }

    fn truth(&self) -> Truth {
        self.truth.lock().map(|t| t.clone()).unwrap_or_default()
    }
}

impl Drop for Ground {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

#[test]
fn arduplane_routes_the_downlink_and_its_gcs_failsafe_still_triggers_with_the_mirror_running() {
    let Some(located) = ardupilot::require(Firmware::Plane, "mirror_sitl") else {
        return;
    };
    let dir = Scratch::new("mirror-sitl");
    let mut sitl = Sitl::start(
        &located,
        &Options {
            instance: INSTANCE,
            speedup: SPEEDUP,
            params: PARAMS.iter().map(|(n, v)| ((*n).to_owned(), *v)).collect(),
            ..Options::default()
        },
        &dir.join("sitl"),
    )
    .expect("ArduPlane SITL starts");
    let max_wall = Duration::from_secs_f64(MAX_SIM_S / f64::from(SPEEDUP) * 3.0 + 60.0);
    // The mirror first: SITL waits for SERIAL0 before it simulates.
    let tap = Tap::start(sitl.port(0));
    let mirror = std::process::Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("mirror")
        .arg(project())
        .args(["--mavlink", &format!("tcpout:127.0.0.1:{}", tap.port)])
        .args(["--time-scale", &SPEEDUP.to_string()])
        .args([
            "--duration",
            &format!("{:.0}", max_wall.as_secs_f64() + 20.0),
        ])
        .arg("--record")
        .arg(dir.join("mirror.mcap"))
        .arg("--json")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("petrel mirror runs");
    let mut mirror = Running::new(mirror);
    // SITL opens SERIAL1 once SERIAL0 has its client (the mirror, which
    // connects at once: it checks nothing before).
    let serial1 = format!("SERIAL1 on TCP port {}", sitl.port(1));
    let waiting = Instant::now();
    while !sitl.output().contains(&serial1) {
        assert!(
            waiting.elapsed() < Duration::from_secs(60) && !mirror.exited(),
            "SITL never opened SERIAL1 (the mirror did not connect to SERIAL0?):\n{}",
            sitl.output()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let programs = format!("tcp:127.0.0.1:{}", free_port());
    let run = flight::petrel_run(
        &sitl.address(1),
        &programs,
        f64::from(SPEEDUP),
        &dir.join("flight.mcap"),
        max_wall + Duration::from_secs(10),
        &["--downlink", "--unchecked"],
    );
    let mut run = Running::new(run);
    let dec = Dec::start(&programs);
    let ground = Ground::start(sitl.port(2));
    let started = Instant::now();
    let mut silent_at: Option<f64> = None;
    let mut down_at: Option<f64> = None;
    let mut truth;
    loop {
        std::thread::sleep(Duration::from_millis(100));
        truth = ground.truth();
        // The ground station falls silent in cruise, past the second item.
        if silent_at.is_none() && truth.reached.iter().any(|(_, s)| *s >= 2) {
            ground.alive.store(false, Ordering::Relaxed);
            silent_at = Some(truth.t);
            eprintln!("the ground station falls silent at {:.1} s", truth.t);
        }
        if down_at.is_none() && truth.down() {
            down_at = Some(truth.t);
        }
        if down_at.is_some_and(|t| truth.t > t + 5.0)
            || truth.t > MAX_SIM_S
            || started.elapsed() > max_wall
            || !sitl.running()
            || run.exited()
            || mirror.exited()
        {
            break;
        }
    }
    // A moment for the last records and heartbeat to reach the mirror.
    std::thread::sleep(Duration::from_secs(1));
    let (run_out, run_err, _) = run.stop();
    std::thread::sleep(Duration::from_millis(500));
    let (mirror_out, mirror_err, _) = mirror.stop();
    dec.stop();
    let frames = tap.frames();
    tap.write_ground_tlog(&dir.join("ground.tlog"));
    sitl.stop();
    drop(ground);
    drop(tap);
    let _ = std::fs::write(dir.join("run.jsonl"), &run_out);
    let _ = std::fs::write(dir.join("run.err"), &run_err);
    let _ = std::fs::write(dir.join("mirror.jsonl"), &mirror_out);
    let _ = std::fs::write(dir.join("mirror.err"), &mirror_err);
    let _ = std::fs::write(dir.join("truth.txt"), format!("{truth:#?}"));
    eprintln!(
        "{:.0} s simulated in {:.1} s; modes {:?}; the mirror sent {} frames; in {}",
        truth.t,
        started.elapsed().as_secs_f64(),
        truth.modes,
        frames.len(),
        dir.display()
    );

    // ArduPlane's own GCS failsafe, with the mirror running all along.
    let silent_at = silent_at.unwrap_or_else(|| {
        panic!(
            "the flight never reached its second item: modes {:?}, texts {:?}\n{run_err}",
            truth.modes, truth.texts
        )
    });
    let failsafe = truth
        .texts
        .iter()
        .find(|(t, text)| *t >= silent_at && text.contains("GCS") && text.contains("ailsafe"));
    assert!(
        failsafe.is_some(),
        "no GCS failsafe after the ground station fell silent at {silent_at:.1} s: texts {:?}",
        truth.texts
    );
    // RTL, which RTL_AUTOLAND 2 turns into the landing sequence (flown in
    // AUTO) at once: the RTL may last less than one heartbeat.
    let rtl = truth.modes_after(silent_at);
    let landing = truth
        .texts
        .iter()
        .any(|(t, text)| *t >= silent_at && text.contains("Landing sequence start"));
    assert!(
        rtl.contains(&"RTL") || landing,
        "ArduPlane did not return after the GCS failsafe: modes after {silent_at:.1} s {rtl:?}, texts {:?}",
        truth.texts
    );
    assert!(
        truth.down(),
        "the flight did not end landed and disarmed: alt {:.1} m, armed {}, modes {:?}",
        truth.alt,
        truth.armed,
        truth.modes
    );

    // The replica equals the vehicle, ArduPilot routing the records.
    let run = flight::timeline(&run_out);
    let mirror = flight::timeline(&mirror_out);
    let lines = |kind: &str| -> Vec<&serde_json::Value> {
        mirror.iter().filter(|l| l["mirror"] == kind).collect()
    };
    let diverged = lines("mirror_diverged");
    assert!(
        diverged.is_empty(),
        "false divergences {diverged:?}\n{mirror_err}"
    );
    let agreed = lines("agreed").len();
    let ran = run
        .iter()
        .find(|l| l["end"] == true)
        .and_then(|l| l["t"].as_f64())
        .expect("the gateway's closing line");
    assert!(
        agreed as f64 > ran * 0.5,
        "only {agreed} checks agreed in {ran:.0} s\n{mirror_err}"
    );
    let last = mirror
        .iter()
        .rev()
        .find(|l| l["mirror"].is_string())
        .expect("the mirror reported");
    assert!(
        last["mirror"] == "agreed" || last["mirror"] == "mirror_resynced",
        "the mirror ends with {last}\n{mirror_err}"
    );
    let vehicle = fired(&run);
    let replica = fired(&mirror);
    assert!(replica.len() > 10, "{replica:?}");
    assert!(
        vehicle.ends_with(&replica),
        "the replica's firings are not the vehicle's:\nvehicle {vehicle:#?}\nreplica {replica:#?}"
    );
    // The independent check: ArduPilot's stream on SERIAL0 is not the
    // companion's; what it judged must agree.
    let disagreements = lines("mirror_disagreement");
    assert!(
        disagreements.is_empty(),
        "disagreements {disagreements:#?}\n{mirror_err}"
    );
    // On the wire: resync requests only.
    only_resync_requests(&frames);
    // The mirror's own recording replays its replica exactly.
    the_recording_checks_out("mirror_sitl", &dir.join("mirror.mcap"), &mirror_err);
}
