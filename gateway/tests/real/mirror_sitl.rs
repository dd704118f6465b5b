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

use crate::flight;
use crate::real;
use crate::scratch;
use crate::wire;

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
/// mirror sends, and loses a share of the frames each way as a radio
/// would (whole frames, picked by a seeded generator). SITL listens first;
/// the mirror connects here.
struct Tap {
    port: u16,
    from_mirror: Arc<Mutex<Vec<u8>>>,
    /// What SITL sent the mirror: (µs since the UNIX epoch, bytes), read by
    /// read, for a tlog of the ground's telemetry.
    to_mirror: Stamped,
    /// What SITL sent toward the mirror before the losses: the radio's
    /// load, which the downlink's budget counts.
    sent_down: Arc<Mutex<Vec<u8>>>,
    stop: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
}

impl Tap {
    fn start(serial0: u16, loss: f64) -> Tap {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a local port");
        let port = listener.local_addr().expect("its address").port();
        let from_mirror = Arc::new(Mutex::new(Vec::new()));
        let to_mirror = Arc::new(Mutex::new(Vec::new()));
        let sent_down = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let (kept, heard, stopping) = (from_mirror.clone(), to_mirror.clone(), stop.clone());
        let radio = sent_down.clone();
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
                        stamped: Option<Stamped>,
                        seed: u64| {
                let stopping = stopping.clone();
                std::thread::spawn(move || {
                    let _ = from.set_read_timeout(Some(Duration::from_millis(100)));
                    let mut chunk = [0u8; 4096];
                    let (mut pending, mut rng) = (Vec::new(), Lossy::new(loss, seed));
                    while !stopping.load(Ordering::Relaxed) {
                        match from.read(&mut chunk) {
                            Ok(0) => break,
                            Ok(n) => {
                                if let Some(k) = &keep {
                                    if let Ok(mut k) = k.lock() {
                                        k.extend_from_slice(&chunk[..n]);
                                    }
                                }
                                // What goes on: whole frames, less those lost.
                                pending.extend_from_slice(&chunk[..n]);
                                let passed = rng.pass(&mut pending);
                                if let Some(k) = &stamped {
                                    let now = std::time::SystemTime::now()
                                        .duration_since(std::time::UNIX_EPOCH)
                                        .map(|d| d.as_micros() as u64)
                                        .unwrap_or(0);
                                    if let Ok(mut k) = k.lock() {
                                        k.push((now, passed.clone()));
                                    }
                                }
                                if to.write_all(&passed).is_err() {
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
            let up = pump(mirror, sitl, Some(kept), None, 1);
            let down = pump(s2, m2, Some(radio), Some(heard), 2);
            let _ = up.join();
            let _ = down.join();
        });
        Tap {
            port,
            from_mirror,
            to_mirror,
            sent_down,
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

/// Loses whole frames at a rate, by a seeded xorshift: the same losses
/// for the same bytes.
struct Lossy {
    loss: f64,
    state: u64,
}

impl Lossy {
    fn new(loss: f64, seed: u64) -> Lossy {
        Lossy {
            loss,
            state: 0x9E37_79B9_7F4A_7C15 ^ seed,
        }
    }

    fn lost(&mut self) -> bool {
        self.state ^= self.state << 13;
        self.state ^= self.state >> 7;
        self.state ^= self.state << 17;
        ((self.state >> 11) as f64 / (1u64 << 53) as f64) < self.loss
    }

    /// The bytes of `pending` to pass on: its whole frames less those
    /// lost (bytes that are no frame pass as they are); a frame cut at
    /// the end stays pending.
    fn pass(&mut self, pending: &mut Vec<u8>) -> Vec<u8> {
        if self.loss <= 0.0 {
            return std::mem::take(pending);
        }
        let (mut out, mut pos) = (Vec::new(), 0);
        while pos < pending.len() {
            match Frame::parse(&pending[pos..]) {
                Ok(f) => {
                    let len = f.bytes().len();
                    if !self.lost() {
                        out.extend_from_slice(f.bytes());
                    }
                    pos += len;
                }
                Err(FrameError::Truncated { .. }) => break,
                Err(_) => {
                    out.push(pending[pos]);
                    pos += 1;
                }
            }
        }
        pending.drain(..pos);
        out
    }
}

impl Tap {
    /// The frames SITL sent that reached the mirror, each with its time
    /// (µs since the UNIX epoch).
    fn delivered(&self) -> Vec<(u64, Vec<u8>)> {
        let chunks = self.to_mirror.lock().map(|c| c.clone()).unwrap_or_default();
        let (mut buf, mut frames) = (Vec::new(), Vec::new());
        for (t, chunk) in chunks {
            buf.extend_from_slice(&chunk);
            let mut pos = 0;
            while pos < buf.len() {
                match Frame::parse(&buf[pos..]) {
                    Ok(f) => {
                        frames.push((t, f.bytes().to_vec()));
                        pos += f.bytes().len();
                    }
                    Err(FrameError::Truncated { .. }) => break,
                    Err(_) => pos += 1,
                }
            }
            buf.drain(..pos);
        }
        frames
    }

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

/// What the downlink cost the radio toward the ground (before its
/// losses), on the autopilot's clock: average and worst 10 s, and what
/// the bytes were spent on.
#[derive(Debug, Default)]
struct Budget {
    /// The downlink's first TUNNEL to its last, autopilot seconds.
    span_s: f64,
    bytes: usize,
    average: f64,
    worst_10s: f64,
    /// Record bytes by what they carry: fresh steps, steps sent again,
    /// heartbeats, snapshot chunks; and the framing (MAVLink's and the
    /// packet's version byte).
    steps: usize,
    resent: usize,
    heartbeats: usize,
    snapshots: usize,
    framing: usize,
    packets: usize,
    records: usize,
    /// Fresh step records' bytes by their first input, most first.
    by_input: Vec<(String, usize, usize)>,
}

impl std::fmt::Display for Budget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let share = |n: usize| 100.0 * n as f64 / self.bytes.max(1) as f64;
        write!(
            f,
            "downlink {:.1} B/s average, {:.1} B/s over its worst 10 s ({} B in {} packets, {} step records, over {:.0} s); steps {:.0} %, resent {:.0} %, heartbeats {:.0} %, snapshots {:.0} %, framing {:.0} %; fresh steps by first input:",
            self.average,
            self.worst_10s,
            self.bytes,
            self.packets,
            self.records,
            self.span_s,
            share(self.steps),
            share(self.resent),
            share(self.heartbeats),
            share(self.snapshots),
            share(self.framing),
        )?;
        for (name, n, bytes) in self.by_input.iter().take(6) {
            write!(f, " {name} {n}× {bytes} B;")?;
        }
        Ok(())
    }
}

impl Tap {
    /// The downlink as the radio carried it toward the ground, before the
    /// losses: each TUNNEL of the onboard gateway (1, 191) at the
    /// autopilot's time (its last `time_boot_ms` before it).
    fn budget(&self) -> Budget {
        let bytes = self.sent_down.lock().map(|b| b.clone()).unwrap_or_default();
        let mut now = None;
        let mut tunnels: Vec<(f64, usize, Vec<wire::Down>)> = Vec::new();
        let mut pos = 0;
        while pos < bytes.len() {
            let f = match Frame::parse(&bytes[pos..]) {
                Ok(f) => f,
                Err(FrameError::Truncated { .. }) => break,
                Err(_) => {
                    pos += 1;
                    continue;
                }
            };
            pos += f.bytes().len();
            match (f.system_id(), f.component_id(), f.message_id()) {
                (1, 1, 2 | 30 | 33) => {
                    now = match f.decode() {
                        Ok(MavMessage::SYSTEM_TIME(d)) => Some(d.time_boot_ms),
                        Ok(MavMessage::ATTITUDE(d)) => Some(d.time_boot_ms),
                        Ok(MavMessage::GLOBAL_POSITION_INT(d)) => Some(d.time_boot_ms),
                        _ => now,
                    }
                }
                (1, 191, 385) => {
                    if let (Some(t), Some(records)) = (now, wire::downlink_records(f.payload())) {
                        tunnels.push((f64::from(t) / 1e3, f.bytes().len(), records));
                    }
                }
                _ => {}
            }
        }
        let mut b = Budget::default();
        let (Some(first), Some(last)) = (tunnels.first(), tunnels.last()) else {
            return b;
        };
        b.span_s = (last.0 - first.0).max(1.0);
        let mut highest: Option<u64> = None;
        let mut inputs: std::collections::BTreeMap<String, (usize, usize)> = Default::default();
        for (_, len, records) in &tunnels {
            b.bytes += len;
            b.packets += 1;
            let mut used = 0;
            for r in records {
                used += r.len;
                match r.kind {
                    1 | 3 => {
                        let n = r.number.unwrap_or(0);
                        let fresh =
                            highest.is_none_or(|h| n > h) || (r.kind == 3 && highest == Some(n));
                        if fresh {
                            b.steps += r.len;
                            if r.kind != 3 {
                                b.records += 1;
                                let e = inputs
                                    .entry(r.first.clone().unwrap_or_default())
                                    .or_default();
                                e.0 += 1;
                                e.1 += r.len;
                            }
                            highest = Some(highest.map_or(n, |h| h.max(n)));
                        } else {
                            b.resent += r.len;
                        }
                    }
                    2 => b.heartbeats += r.len,
                    4 => b.snapshots += r.len,
                    _ => {}
                }
            }
            b.framing += len - used;
        }
        b.average = b.bytes as f64 / b.span_s;
        let mut worst = 0;
        let mut from = 0;
        let mut sum = 0;
        for (t, len, _) in &tunnels {
            sum += len;
            while tunnels[from].0 < t - 10.0 {
                sum -= tunnels[from].1;
                from += 1;
            }
            worst = worst.max(sum);
        }
        b.worst_10s = worst as f64 / 10.0;
        let mut by: Vec<(String, usize, usize)> =
            inputs.into_iter().map(|(k, (n, s))| (k, n, s)).collect();
        by.sort_by_key(|e| std::cmp::Reverse(e.2));
        b.by_input = by;
        b
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

    /// PARAM_SET to the autopilot, as ArduPilot's autotest injects failures.
    fn param(&self, name: &str, value: f32) {
        let header = MavHeader {
            system_id: u32::from(GCS.0),
            component_id: GCS.1,
            sequence: 0,
        };
        let _ = self.link.send(
            &header,
            &MavMessage::PARAM_SET(PARAM_SET_DATA {
                param_value: value,
                target_system: 1,
                target_component: 1,
                param_id: name.into(),
                param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
            }),
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
    // A turn to fly (real/main.rs: at most two flights at once, each on
    // instances of its own).
    let turn = crate::sitl_turn();
    let dir = Scratch::new("mirror-sitl");
    let mut sitl = Sitl::start(
        &located,
        &Options {
            instance: turn.instance(INSTANCE),
            speedup: SPEEDUP,
            params: PARAMS.iter().map(|(n, v)| ((*n).to_owned(), *v)).collect(),
            ..Options::default()
        },
        &dir.join("sitl"),
    )
    .expect("ArduPlane SITL starts");
    let max_wall = Duration::from_secs_f64(MAX_SIM_S / f64::from(SPEEDUP) * 3.0 + 60.0);
    // The mirror first: SITL waits for SERIAL0 before it simulates.
    let tap = Tap::start(sitl.port(0), 0.0);
    let mut mirror = mirror_on_serial0(&sitl, &tap, max_wall, Some(&dir.join("mirror.mcap")), &[]);
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
    eprintln!("routing flight at 0 %: {}", tap.budget());
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
    // companion's; what it judged must agree. At the touchdown the
    // vehicle says `landed` (and `emergency_landed`) from
    // EXTENDED_SYS_STATE, which SERIAL0 does not carry here: unobservable
    // on the ground, counted as such, never a disagreement.
    let summary = mirror
        .iter()
        .find(|l| l["summary"] == "mirror")
        .expect("the mirror's summary");
    eprintln!("independent check: {summary}");
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

/// The SITL instance of the independent check's flights.
const CHECK_INSTANCE: u8 = 12;

/// A flight of the independent check's test, and what it left.
struct Checked {
    mirror: Vec<serde_json::Value>,
    run: Vec<serde_json::Value>,
    run_err: String,
    mirror_err: String,
    truth: Truth,
    /// When the engine was failed (SITL's time), if it was.
    injected: Option<f64>,
    /// The same instant on the vehicle's player clock (`t` of the timelines).
    injected_player: Option<f64>,
    /// The share of the flight a ground-only event would have gone
    /// unjudged, by the rule before this branch (any gap in any
    /// component's numbers, the onboard gateway's included, hid the
    /// ground's events for 20 s), from the frames the mirror received.
    blind_before: f64,
    /// What the downlink cost the radio.
    budget: Budget,
    dir: Scratch,
}

impl Checked {
    fn lines(&self, kind: &str) -> Vec<&serde_json::Value> {
        self.mirror.iter().filter(|l| l["mirror"] == kind).collect()
    }

    /// The mirror's closing summary of the check (its one vehicle).
    fn summary(&self) -> &serde_json::Value {
        self.mirror
            .iter()
            .find(|l| l["summary"] == "mirror")
            .map(|s| &s["vehicles"][0])
            .unwrap_or_else(|| panic!("no summary from the mirror\n{}", self.mirror_err))
    }

    /// The share of the flight the check was blind to ground events (the
    /// mirror's own count, by the new rule).
    fn blind_after(&self) -> f64 {
        let s = self.summary();
        let followed = s["followed_s"].as_f64().unwrap_or(0.0);
        if followed > 0.0 {
            s["blind_s"].as_f64().unwrap_or(0.0) / followed
        } else {
            1.0
        }
    }
}

/// The share of the time from the autopilot's first frame to its last in
/// which, by the rule before this branch, a ground event would not have
/// been judged: a gap in a component's sequence numbers that is also one
/// in the system's hid the next 20 s.
fn blind_before(frames: &[(u64, Vec<u8>)]) -> f64 {
    let mut last: std::collections::BTreeMap<u8, (u8, u64)> = Default::default();
    let mut system: Option<u8> = None;
    let mut spans: Vec<(u64, u64)> = Vec::new();
    let (mut first, mut end) = (None, 0);
    // Ground time runs SPEEDUP times slower than the vehicle's.
    let silence = 20_000_000 / u64::from(SPEEDUP);
    for (t, bytes) in frames {
        let Ok(f) = Frame::parse(bytes) else { continue };
        if f.system_id() != 1 {
            continue;
        }
        let (c, seq) = (f.component_id(), f.sequence());
        if c == 1 {
            first.get_or_insert(*t);
            end = *t;
        }
        let system_gap = system.is_some_and(|s| seq != s.wrapping_add(1));
        system = Some(seq);
        if let Some((l, at)) = last.get(&c) {
            if seq != l.wrapping_add(1) && system_gap {
                spans.push((*at, t + silence));
            }
        }
        last.insert(c, (seq, *t));
    }
    let Some(first) = first else { return 1.0 };
    let (mut blind, mut reached) = (0, first);
    for (a, b) in spans {
        let (a, b) = (a.max(reached), b.min(end));
        if b > a {
            blind += b - a;
            reached = b;
        }
    }
    blind as f64 / (end - first).max(1) as f64
}

/// The project's elaboration layer with every rule of `engine_failure`
/// removed: the vehicle that misses it.
fn blind_profile(dir: &Scratch) -> String {
    let layer =
        std::fs::read_to_string(project().join("profile.toml")).expect("the project's profile");
    let mut altered = String::new();
    for line in layer.lines() {
        altered.push_str(line);
        altered.push('\n');
        if line.starts_with("[rules.engine_failure") {
            altered.push_str("enabled = false\n");
        }
    }
    let file = dir.join("blind.toml");
    std::fs::write(&file, altered).expect("the altered profile");
    file.to_string_lossy().into_owned()
}

/// The flight-test mission on ArduPlane, the vehicle blind to
/// `engine_failure`, the mirror on SERIAL0 losing `loss` of the frames
/// each way and a ground station alive on SERIAL2. With `fail`, the
/// engine fails 3 s after the first operations-area waypoint (the camera
/// commanded every second) and the flight ends 15 s later; without, it
/// flies to its landing.
fn fly_checked(
    turn: &crate::Turn,
    located: &ardupilot::Located,
    name: &str,
    loss: f64,
    fail: bool,
) -> Checked {
    fly_checked_pushing(turn, located, name, loss, fail, None)
}

/// A new version pushed from the mirror at the start of the flight
/// (issue 38): the operator key both hold, the version's folder; a 10 s
/// hole on the gateway's link (SERIAL1, through a relay) once the vehicle
/// took it over.
struct Pushing {
    key: String,
    version: String,
}

fn fly_checked_pushing(
    turn: &crate::Turn,
    located: &ardupilot::Located,
    name: &str,
    loss: f64,
    fail: bool,
    pushing: Option<Pushing>,
) -> Checked {
    let dir = Scratch::new(name);
    let blind = blind_profile(&dir);
    let mut sitl = Sitl::start(
        located,
        &Options {
            instance: turn.instance(CHECK_INSTANCE),
            speedup: SPEEDUP,
            params: PARAMS.iter().map(|(n, v)| ((*n).to_owned(), *v)).collect(),
            ..Options::default()
        },
        &dir.join("sitl"),
    )
    .expect("ArduPlane SITL starts");
    let max_wall = Duration::from_secs_f64(MAX_SIM_S / f64::from(SPEEDUP) * 3.0 + 60.0);
    let tap = Tap::start(sitl.port(0), loss);
    let mirror_args: Vec<&str> = match &pushing {
        None => Vec::new(),
        Some(p) => vec!["--operator-key", &p.key, "--push-rate", "10000"],
    };
    let (mut mirror, mut typed) =
        mirror_on_serial0_with_stdin(&sitl, &tap, max_wall, None, &mirror_args);
    let mut pushed = false;
    let programs = format!("tcp:127.0.0.1:{}", free_port());
    // With a version pushed, the gateway's link goes through a relay that
    // can cut it.
    let relay = pushing
        .as_ref()
        .map(|_| crate::real::Relay::start(sitl.port(1)));
    let address = match &relay {
        Some(r) => format!("tcpout:127.0.0.1:{}", r.port()),
        None => sitl.address(1),
    };
    let mut run_args = vec!["--downlink", "--unchecked", "--profile", &blind];
    if let Some(p) = &pushing {
        run_args.extend(["--operator-key", p.key.as_str()]);
    }
    let run = flight::petrel_run(
        &address,
        &programs,
        f64::from(SPEEDUP),
        &dir.join("flight.mcap"),
        max_wall + Duration::from_secs(10),
        &run_args,
    );
    let mut run = Running::new(run);
    let mut holed = false;
    let dec = Dec::start(&programs);
    let ground = Ground::start(sitl.port(2));
    let started = Instant::now();
    let (mut injected, mut down_at) = (None, None);
    let mut truth;
    loop {
        std::thread::sleep(Duration::from_millis(50));
        truth = ground.truth();
        // The first operations-area waypoint (item 3, O1): the camera
        // starts there and is commanded every second of its loiter.
        let operations = truth.reached.iter().find(|(_, s)| *s == 3).map(|r| r.0);
        if fail && injected.is_none() && operations.is_some_and(|t| truth.t >= t + 3.0) {
            ground.param("SIM_ENGINE_MUL", 0.0);
            ground.param("SIM_ENGINE_FAIL", 4.0);
            injected = Some(truth.t);
            eprintln!("{name}: the engine fails at {:.1} s", truth.t);
        }
        if down_at.is_none() && truth.down() {
            down_at = Some(truth.t);
        }
        // The version typed to the mirror once the vehicle flies its
        // mission (`push DIR` on its stdin).
        if let (Some(p), Some(stdin), false) = (&pushing, typed.as_mut(), pushed) {
            if truth.reached.iter().any(|(_, s)| *s >= 1) {
                pushed = true;
                let _ = writeln!(stdin, "push {}", p.version);
                eprintln!("{name}: the version pushed at {:.1} s", truth.t);
            }
        }
        if let Some(r) = &relay {
            if !holed && run.printed("\"input\":\"version\"") {
                holed = true;
                r.hole(Duration::from_secs_f64(10.0 / f64::from(SPEEDUP)));
                eprintln!(
                    "{name}: the gateway's link cut for 10 s at {:.1} s",
                    truth.t
                );
            }
        }
        if injected.is_some_and(|t| truth.t > t + 15.0)
            || down_at.is_some_and(|t| truth.t > t + 5.0)
            || truth.t > MAX_SIM_S
            || started.elapsed() > max_wall
            || !sitl.running()
            || run.exited()
            || mirror.exited()
        {
            break;
        }
    }
    std::thread::sleep(Duration::from_secs(1));
    let (run_out, run_err, _) = run.stop();
    std::thread::sleep(Duration::from_millis(500));
    let (mirror_out, mirror_err, _) = mirror.stop();
    dec.stop();
    let delivered = tap.delivered();
    let budget = tap.budget();
    eprintln!("{name}: {budget}");
    tap.write_ground_tlog(&dir.join("ground.tlog"));
    sitl.stop();
    drop(ground);
    drop(tap);
    let _ = std::fs::write(dir.join("run.jsonl"), &run_out);
    let _ = std::fs::write(dir.join("run.err"), &run_err);
    let _ = std::fs::write(dir.join("mirror.jsonl"), &mirror_out);
    let _ = std::fs::write(dir.join("mirror.err"), &mirror_err);
    eprintln!(
        "{name}: {:.0} s simulated in {:.1} s; modes {:?}; in {}",
        truth.t,
        started.elapsed().as_secs_f64(),
        truth.modes,
        dir.display()
    );
    let run = flight::timeline(&run_out);
    // The player's clock against SITL's: item 3 reached on both.
    let offset = truth
        .reached
        .iter()
        .find(|(_, s)| *s == 3)
        .and_then(|(at, _)| {
            run.iter()
                .find(|l| {
                    l["input"] == "event"
                        && l["event"] == "mission_item_reached"
                        && l["params"]["seq"].as_f64() == Some(3.0)
                })
                .and_then(|l| l["t"].as_f64())
                .map(|t| t - at)
        });
    Checked {
        mirror: flight::timeline(&mirror_out),
        run,
        run_err,
        mirror_err,
        injected,
        injected_player: injected.zip(offset).map(|(i, o)| i + o),
        truth,
        blind_before: blind_before(&delivered),
        budget,
        dir,
    }
}

#[test]
fn a_vehicle_that_misses_engine_failure_is_reported_within_2_s_at_0_and_10_percent_loss() {
    let Some(located) = ardupilot::require(Firmware::Plane, "mirror_sitl (the check)") else {
        return;
    };
    // A turn to fly (real/main.rs: at most two flights at once, each on
    // instances of its own).
    let turn = crate::sitl_turn();
    let flights = [
        fly_checked(&turn, &located, "mirror-check-nominal-10", 0.10, false),
        fly_checked(&turn, &located, "mirror-check-engine-0", 0.0, true),
        fly_checked(&turn, &located, "mirror-check-engine-10", 0.10, true),
    ];
    let mut problems = Vec::new();
    for (f, (what, loss)) in flights.iter().zip([
        ("nominal", 10),
        ("engine failure", 0),
        ("engine failure", 10),
    ]) {
        let summary = f.summary();
        eprintln!(
            "{what} at {loss} %: blind to ground events {:.0} % of the flight before, {:.0} % after; check {summary}",
            f.blind_before * 100.0,
            f.blind_after() * 100.0,
        );
        let disagreements = f.lines("mirror_disagreement");
        let (engine, others): (Vec<&&serde_json::Value>, Vec<_>) = disagreements
            .iter()
            .partition(|d| d["event"] == "engine_failure" && d["seen_by"] == "ground");
        if !others.is_empty() {
            problems.push(format!(
                "{what} at {loss} %: false alarms {others:#?}\n{}",
                f.mirror_err
            ));
        }
        if f.blind_after() > 0.05 {
            problems.push(format!(
                "{what} at {loss} %: blind {:.0} % of the flight",
                f.blind_after() * 100.0
            ));
        }
        let Some(injected) = f.injected else {
            assert!(
                what == "nominal",
                "the engine never failed at {loss} %: reached {:?}, modes {:?} ({})",
                f.truth.reached,
                f.truth.modes,
                f.dir.display()
            );
            if !f.truth.down() {
                problems.push(format!(
                    "the nominal flight did not land: modes {:?}",
                    f.truth.modes
                ));
            }
            if !engine.is_empty() {
                problems.push(format!("nominal at {loss} %: {engine:?}"));
            }
            continue;
        };
        // The vehicle never heard it; the camera was being commanded
        // around the failure (the onboard gateway's traffic the ground
        // never sees: ArduPlane refuses each IMAGE_START_CAPTURE, once a
        // second, to the onboard gateway alone).
        assert!(
            !f.run
                .iter()
                .any(|l| l["input"] == "event" && l["event"] == "engine_failure"),
            "the blind vehicle elaborated engine_failure"
        );
        let at = f.injected_player.unwrap_or(f64::NAN);
        let commands = f
            .run
            .iter()
            .filter(|l| l["input"] == "event" && l["event"] == "command_rejected")
            .filter_map(|l| l["t"].as_f64())
            .filter(|t| (at - 3.0..=at).contains(t))
            .count();
        let Some(d) = engine.first() else {
            problems.push(format!(
                "engine failure at {loss} % (at {injected:.1} s, {commands} commands answered in the 3 s before): not reported; check {summary}\n{}",
                f.mirror_err
            ));
            continue;
        };
        let seen = d["t"].as_f64().unwrap_or(f64::NAN);
        let reported = d["reported_t"].as_f64().unwrap_or(f64::NAN);
        eprintln!(
            "engine failure at {loss} %: failed at {at:.2} s ({commands} commands answered in the 3 s before), seen by the ground at {seen:.2} s, reported at {reported:.2} s: {:.2} s after the ground saw it, {:.2} s after the failure",
            reported - seen,
            reported - at,
        );
        if (reported - seen).is_nan() || reported - seen >= 2.0 {
            problems.push(format!(
                "engine failure at {loss} %: reported {:.2} s after the ground saw it: {d}",
                reported - seen
            ));
        }
        if commands < 2 {
            problems.push(format!(
                "engine failure at {loss} %: {commands} command answered in the 3 s before the failure (at {at:.2} s of the player)"
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n\n"));
}

/// The downlink's budget (docs/mirror.md, "Budget and pacing"): under
/// 100 B/s on average over a whole flight on real ArduPlane, to its
/// landing, with the radio losing 30 % of the frames each way (the
/// resends and snapshots that loss costs included), the camera refused
/// once a second over the operations area.
#[test]
fn the_downlink_keeps_under_100_bytes_a_second_at_30_percent_loss() {
    let Some(located) = ardupilot::require(Firmware::Plane, "mirror_sitl (the budget)") else {
        return;
    };
    // A turn to fly (real/main.rs: at most two flights at once, each on
    // instances of its own).
    let turn = crate::sitl_turn();
    let f = fly_checked(&turn, &located, "mirror-budget-nominal-30", 0.30, false);
    let diverged = f.lines("mirror_diverged");
    eprintln!(
        "nominal at 30 %: {}; {} divergences; check {}",
        f.budget,
        diverged.len(),
        f.summary()
    );
    assert!(
        f.truth.down(),
        "the flight did not land: modes {:?} ({})",
        f.truth.modes,
        f.dir.display()
    );
    assert!(
        f.budget.span_s > 120.0,
        "the downlink was heard {:.0} s only ({})",
        f.budget.span_s,
        f.dir.display()
    );
    assert!(
        f.budget.average < 100.0,
        "over budget at 30 % loss: {} ({})",
        f.budget,
        f.dir.display()
    );
}

/// `petrel mirror` on the tap in front of SITL's SERIAL0 (`--json`,
/// recording to `record` or not), once SITL has opened SERIAL1: SITL opens
/// SERIAL1 once SERIAL0 has its client (the mirror, which connects at
/// once: it checks nothing before).
fn mirror_on_serial0(
    sitl: &Sitl,
    tap: &Tap,
    max_wall: Duration,
    record: Option<&std::path::Path>,
    extra: &[&str],
) -> Running {
    mirror_on_serial0_with_stdin(sitl, tap, max_wall, record, extra).0
}

/// [`mirror_on_serial0`], its stdin kept for lines typed to it (`push
/// DIR`).
fn mirror_on_serial0_with_stdin(
    sitl: &Sitl,
    tap: &Tap,
    max_wall: Duration,
    record: Option<&std::path::Path>,
    extra: &[&str],
) -> (Running, Option<std::process::ChildStdin>) {
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_petrel"));
    command
        .arg("mirror")
        .arg(project())
        .args(["--mavlink", &format!("tcpout:127.0.0.1:{}", tap.port)])
        .args(["--time-scale", &SPEEDUP.to_string()])
        .args([
            "--duration",
            &format!("{:.0}", max_wall.as_secs_f64() + 20.0),
        ]);
    match record {
        Some(path) => command.arg("--record").arg(path),
        None => command.arg("--no-record"),
    };
    let mut mirror = command
        .args(extra)
        .arg("--json")
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("petrel mirror runs");
    let stdin = mirror.stdin.take();
    let mut mirror = Running::new(mirror);
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
    (mirror, stdin)
}

/// Issue 38 on real ArduPlane, sent from the ground: `push DIR` typed to
/// `petrel mirror` once the vehicle flies its mission sends
/// COMMUNICATION's version 1 (a link hole ends in a return)
/// up through ArduPilot's own routing, signed with the operator key both
/// hold; the vehicle proves it from the state it is in and takes it over,
/// says so down, and the replica follows it and stays exact; the
/// vehicle's recording replays. (A 10 s hole on the gateway's link follows
/// the swap when there is flight left for it.)
#[test]
fn a_version_pushed_from_the_mirror_takes_over_and_the_replica_follows() {
    let Some(located) = ardupilot::require(Firmware::Plane, "mirror_sitl (a version pushed)")
    else {
        return;
    };
    // The machine to itself: a debug build proves the version for tens
    // of simulated seconds on a whole core, which another flight beside
    // would miss.
    let turn = crate::sitl_turn_alone();
    let keys = Scratch::new("mirror-push-key");
    let key = keys.join("operator.key");
    std::fs::write(&key, "ef".repeat(32)).expect("write");
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o600)).expect("chmod");
    let version = flight::example_copy(&keys.join("version-1"));
    std::fs::write(
        version.join("communication.toml"),
        flight::returning_after_a_link_hole(&project()),
    )
    .expect("write");
    let pushing = Pushing {
        key: key.to_string_lossy().into_owned(),
        version: version.to_string_lossy().into_owned(),
    };
    let f = fly_checked_pushing(&turn, &located, "mirror-push", 0.0, false, Some(pushing));
    assert!(
        f.mirror_err
            .contains("push: the vehicle's verdict: version 1 took over at step"),
        "{}",
        f.mirror_err
    );
    assert!(
        f.run_err.contains(": version 1 took over at step"),
        "{}",
        f.run_err
    );
    // The replica followed: it agreed with the vehicle after the swap (by
    // the swap's record, or by a snapshot of version 1 if the radio lost
    // it), with no divergence.
    let swapped_at = swap_step(&f.run_err);
    assert!(
        f.lines("agreed")
            .iter()
            .any(|l| l["step"].as_u64().is_some_and(|s| s > swapped_at)),
        "no agreement after step {swapped_at}: {}",
        f.mirror_err
    );
    assert!(
        f.lines("mirror_diverged").is_empty(),
        "{:?}",
        f.lines("mirror_diverged")
    );
    // The swap in the timeline; when it comes depends on how long a
    // debug build takes to prove the version beside the flight (the
    // hole's reaction after a swap on real ArduPlane is
    // real_plane::a_new_version_in_flight_…, and in simulated time
    // it/reload.rs).
    assert!(
        f.run
            .iter()
            .any(|l| l["input"] == "version" && l["version"] == 1),
        "({})",
        f.dir.display()
    );
    assert!(f.truth.down(), "{:?}", f.truth.modes);
    let (code, err) = crate::wire::check_recording(&f.dir.join("flight.mcap"));
    assert_eq!(code, 0, "{err}");
}

/// The step a new version took over at, as `petrel run` says it
/// (`version N took over at step S`).
fn swap_step(run_err: &str) -> u64 {
    run_err
        .lines()
        .find_map(|l| {
            l.split("took over at step ")
                .nth(1)?
                .split(|c: char| !c.is_ascii_digit())
                .next()?
                .parse()
                .ok()
        })
        .unwrap_or_else(|| panic!("no swap said: {run_err}"))
}
