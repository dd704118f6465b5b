//! One flight of examples/uav-flight-test against ArduPilot's own ArduPlane
//! SITL: the real `petrel run` on SERIAL0 (through a relay that can open a
//! hole in the link), DEC on a thread, and an observer on SERIAL1 that
//! sees what ArduPilot itself does (modes, arming, texts, items reached,
//! position: the truth the assertions read) and injects failures the way
//! ArduPilot's autotest does, with PARAM_SET of its SIM_ and failsafe
//! parameters.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use elaboration::Firmware as Family;
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavConnection, MavHeader};
use sitl_tests::ardupilot::{self, Firmware, Options, Sitl};
use sitl_tests::{CameraConfig, CameraSim, CameraState};

use super::flight::{self, Dec, Flown};
use crate::scratch::Scratch;

/// Simulated seconds per wall second, for SITL and the gateway's clock.
pub const SPEEDUP: u32 = 10;

/// What ArduPilot did, as a ground station on SERIAL1 saw it. Times are
/// simulated seconds since the autopilot booted (its time_boot_ms).
#[derive(Debug, Clone, Default)]
pub struct Truth {
    pub t: f64,
    pub mode: String,
    pub armed: bool,
    /// Mode changes, in order.
    pub modes: Vec<(f64, String)>,
    /// Arming changes (true: armed), in order.
    pub arming: Vec<(f64, bool)>,
    /// Every STATUSTEXT, a long text's chunks put back together.
    pub texts: Vec<(f64, String)>,
    chunks: elaboration::statustext::Joiner,
    /// Items reached (each once: ArduPilot repeats its last one).
    pub reached: Vec<(f64, u16)>,
    pub lat: f64,
    pub lon: f64,
    /// Metres above home.
    pub alt: f64,
    pub groundspeed: f64,
    /// The highest it flew, metres above home.
    pub max_alt: f64,
    /// When each failure was injected (name, time).
    pub injected: Vec<(f64, String)>,
    /// A new version of the project took over in the gateway (read off
    /// its timeline, not ArduPilot's: issue 38's flights).
    pub swapped: bool,
}

impl Truth {
    /// Was flying, and is now down and disarmed.
    pub fn down(&self) -> bool {
        self.max_alt > 20.0 && !self.armed && self.alt < 5.0
    }

    /// A text ArduPilot sent, containing `needle`, and when.
    pub fn text(&self, needle: &str) -> Option<f64> {
        self.texts
            .iter()
            .find(|(_, t)| t.contains(needle))
            .map(|(t, _)| *t)
    }

    /// The modes it went through after `t`.
    pub fn modes_after(&self, t: f64) -> Vec<&str> {
        self.modes
            .iter()
            .filter(|(at, _)| *at >= t)
            .map(|(_, m)| m.as_str())
            .collect()
    }

    /// When a failure was injected.
    pub fn injected_at(&self, name: &str) -> Option<f64> {
        self.injected
            .iter()
            .find(|(_, n)| n == name)
            .map(|(t, _)| *t)
    }

    pub fn heard(&mut self, message: &MavMessage) {
        match message {
            MavMessage::HEARTBEAT(hb) => {
                let mode = elaboration::constants::mode_name(Family::Plane, hb.custom_mode);
                if mode != self.mode {
                    self.modes.push((self.t, mode.clone()));
                    self.mode = mode;
                }
                let armed = hb
                    .base_mode
                    .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED);
                if armed != self.armed || self.arming.is_empty() {
                    self.arming.push((self.t, armed));
                }
                self.armed = armed;
            }
            MavMessage::SYSTEM_TIME(s) => self.t = f64::from(s.time_boot_ms) / 1000.0,
            MavMessage::GLOBAL_POSITION_INT(p) => {
                self.t = self.t.max(f64::from(p.time_boot_ms) / 1000.0);
                if (p.lat, p.lon) != (0, 0) {
                    self.lat = f64::from(p.lat) / 1e7;
                    self.lon = f64::from(p.lon) / 1e7;
                    self.alt = f64::from(p.relative_alt) / 1000.0;
                    self.max_alt = self.max_alt.max(self.alt);
                }
            }
            MavMessage::VFR_HUD(v) => self.groundspeed = f64::from(v.groundspeed),
            // ArduPilot sends a text longer than 50 bytes in chunks of one `id`.
            MavMessage::STATUSTEXT(s) => {
                use elaboration::statustext::Piece;
                let raw = String::from_utf8_lossy(&s.text[..]);
                let (part, last) = match raw.find('\0') {
                    Some(end) => (&raw[..end], true),
                    None => (&raw[..], false),
                };
                let text = match self.chunks.push(s.id, s.chunk_seq, part, last) {
                    Piece::Whole => part.to_owned(),
                    Piece::Joined(whole) => whole,
                    Piece::Pending => return,
                };
                self.texts.push((self.t, text));
            }
            MavMessage::MISSION_ITEM_REACHED(r)
                if r.seq != u16::MAX && self.reached.last().map(|l| l.1) != Some(r.seq) =>
            {
                self.reached.push((self.t, r.seq));
            }
            _ => {}
        }
    }
}

type Link = Arc<mavlink::Connection<MavMessage>>;

/// A ground station's view on SERIAL1: reads on a thread until the link
/// closes (SITL killed).
pub struct Observer {
    link: Link,
    truth: Arc<Mutex<Truth>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

/// Our system id on the observer link: not 255, so that it is never taken
/// for the ground station whose loss ArduPilot watches.
const OBSERVER: (u8, u8) = (250, 190);

impl Observer {
    fn start(port: u16) -> Observer {
        let address = format!("tcpout:127.0.0.1:{port}");
        let started = Instant::now();
        let link = loop {
            match mavlink::connect::<MavMessage>(&address) {
                Ok(c) => break c,
                Err(e) if started.elapsed() > Duration::from_secs(20) => {
                    panic!("SERIAL1 ({address}) never opened: {e}")
                }
                Err(_) => std::thread::sleep(Duration::from_millis(200)),
            }
        };
        let link: Link = Arc::new(link);
        let truth = Arc::new(Mutex::new(Truth::default()));
        let (l, t) = (link.clone(), truth.clone());
        let thread = std::thread::spawn(move || {
            loop {
                match l.recv() {
                    // The autopilot's own messages only: ArduPilot routes
                    // the gateway's (and a camera's) to this port too.
                    Ok((header, message)) if (header.system_id, header.component_id) == (1, 1) => {
                        if let Ok(mut truth) = t.lock() {
                            truth.heard(&message);
                        }
                    }
                    Ok(_) => {}
                    // A message this dialect cannot decode: skip it.
                    Err(mavlink::error::MessageReadError::Parse(_)) => {}
                    // rust-mavlink's TCP reads time out now and then.
                    Err(mavlink::error::MessageReadError::Io(e))
                        if matches!(
                            e.kind(),
                            std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                        ) => {}
                    Err(e) => {
                        eprintln!("observer: SERIAL1 closed: {e}");
                        break;
                    }
                }
            }
        });
        let observer = Observer {
            link,
            truth,
            thread: Some(thread),
        };
        // What this port streams is its own: ask for what the truth reads,
        // HEARTBEAT often enough to see a mode held for a moment (an RTL
        // that RTL_AUTOLAND turns into the landing sequence at once).
        for (id, hz) in [(0, 10.0), (33, 4.0), (74, 2.0), (2, 2.0)] {
            observer.command(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, [id as f32, 1e6 / hz]);
        }
        observer
    }

    fn send(&self, message: &MavMessage) {
        let header = MavHeader {
            system_id: u32::from(OBSERVER.0),
            component_id: OBSERVER.1,
            sequence: 0,
        };
        let _ = self.link.send(&header, message);
    }

    fn command(&self, command: MavCmd, params: [f32; 2]) {
        let [p1, p2] = params;
        self.send(&sitl_tests::wire::command_long(
            (1, 1),
            command,
            [p1, p2, 0.0, 0.0, 0.0, 0.0, 0.0],
        ));
    }

    /// PARAM_SET, as ArduPilot's autotest injects failures.
    pub fn set(&self, name: &str, value: f32) {
        self.send(&MavMessage::PARAM_SET(PARAM_SET_DATA {
            param_value: value,
            target_system: 1,
            target_component: 1,
            param_id: name.into(),
            param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
        }));
    }

    pub fn truth(&self) -> Truth {
        self.truth.lock().map(|t| t.clone()).unwrap_or_default()
    }

    fn record(&self, what: &str) {
        if let Ok(mut t) = self.truth.lock() {
            let now = t.t;
            t.injected.push((now, what.to_owned()));
        }
    }
}

impl Observer {
    /// Waits for the reading thread, which ends when SITL (stopped first)
    /// closes the link. Without this (a test that panicked), the thread
    /// ends by itself when SITL is reaped.
    fn finish(mut self) {
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// A TCP relay between the gateway and SERIAL0 that can drop everything,
/// both ways, for a while: a telemetry hole on the gateway's link only.
pub struct Relay {
    port: u16,
    hole_until: Arc<Mutex<Option<Instant>>>,
    stop: Arc<AtomicBool>,
    connected: Arc<AtomicBool>,
}

impl Relay {
    /// The port the gateway connects to.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Relays between whoever connects to `port` (again after a
    /// reconnection) and SERIAL0, which it connects to when the gateway
    /// first connects: the simulation starts then, once `petrel run` has
    /// checked its project.
    pub fn start(upstream: u16) -> Relay {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a relay port");
        let port = listener.local_addr().expect("its address").port();
        let connected = Arc::new(AtomicBool::new(false));
        let hole_until: Arc<Mutex<Option<Instant>>> = Arc::new(Mutex::new(None));
        let stop = Arc::new(AtomicBool::new(false));
        let client: Arc<Mutex<Option<TcpStream>>> = Arc::new(Mutex::new(None));
        let open = {
            let hole = hole_until.clone();
            move || {
                hole.lock()
                    .map(|h| h.is_none_or(|until| Instant::now() >= until))
                    .unwrap_or(true)
            }
        };
        let stopping = stop.clone();
        let connecting = connected.clone();
        std::thread::spawn(move || {
            let _ = listener.set_nonblocking(true);
            let mut server: Option<TcpStream> = None;
            while !stopping.load(Ordering::Relaxed) {
                let Ok((c, _)) = listener.accept() else {
                    std::thread::sleep(Duration::from_millis(50));
                    continue;
                };
                let _ = c.set_nonblocking(false);
                let Ok(reader) = c.try_clone() else { continue };
                if let Ok(mut slot) = client.lock() {
                    *slot = Some(c);
                }
                if server.is_none() {
                    let Ok(s) = ardupilot::connect(upstream, Duration::from_secs(10)) else {
                        break;
                    };
                    let Ok(from) = s.try_clone() else { break };
                    let to_client = client.clone();
                    pump(from, stopping.clone(), open.clone(), move |bytes| {
                        if let Ok(mut c) = to_client.lock() {
                            if c.as_mut().is_some_and(|c| c.write_all(bytes).is_err()) {
                                *c = None;
                            }
                        }
                        true
                    });
                    server = Some(s);
                    connecting.store(true, Ordering::Relaxed);
                }
                let Some(Ok(mut up)) = server.as_ref().map(|s| s.try_clone()) else {
                    continue;
                };
                pump(reader, stopping.clone(), open.clone(), move |bytes| {
                    up.write_all(bytes).is_ok()
                });
            }
            if let Some(s) = server {
                let _ = s.shutdown(std::net::Shutdown::Both);
            }
        });
        Relay {
            port,
            hole_until,
            stop,
            connected,
        }
    }

    /// Waits until the gateway has connected (and SITL started), at most
    /// `limit`.
    fn wait_connected(&self, limit: Duration) -> bool {
        let started = Instant::now();
        while started.elapsed() < limit {
            if self.connected.load(Ordering::Relaxed) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        false
    }

    pub fn hole(&self, wall: Duration) {
        if let Ok(mut h) = self.hole_until.lock() {
            *h = Some(Instant::now() + wall);
        }
    }
}

/// One direction of the relay: reads `from` until it closes or the relay
/// stops, handing what it read to `deliver` while the link is `open`.
fn pump(
    mut from: TcpStream,
    stop: Arc<AtomicBool>,
    open: impl Fn() -> bool + Send + 'static,
    mut deliver: impl FnMut(&[u8]) -> bool + Send + 'static,
) {
    std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        let _ = from.set_read_timeout(Some(Duration::from_millis(200)));
        while !stop.load(Ordering::Relaxed) {
            match from.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => {
                    if open() && !deliver(&buf[..n]) {
                        break;
                    }
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) => {}
                Err(_) => break,
            }
        }
    });
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

/// Something done to the vehicle during a flight.
#[derive(Debug, Clone)]
pub enum Act {
    /// Set a parameter (a SIM_ failure, a failsafe setting).
    Param(&'static str, f32),
    /// Nothing through the gateway's link, both ways, for this many
    /// simulated seconds.
    LinkHole(f64),
    /// A new version of the project: these files written over the
    /// flight's copy of the project ([`Plan::project`]), then SIGHUP.
    Reload(Vec<(&'static str, String)>),
}

/// An act, when a condition on the truth first holds, named for the
/// assertions (`Truth::injected_at`).
pub type Step = (&'static str, Box<dyn Fn(&Truth) -> bool + Send>, Vec<Act>);

/// A real flight's result: the gateway's side (`flown`) and ArduPilot's.
pub struct RealFlown {
    pub flown: Flown,
    pub truth: Truth,
    /// The camera's truth: the commands it heard, its captures.
    pub camera: CameraState,
    /// The gateway's exit status.
    pub code: Option<i32>,
}

/// The SITL instance (`-I`) of these flights, moved by their turn
/// (`crate::sitl_turn`; the instances of the binary: real/main.rs).
const INSTANCE: u8 = 0;

/// One flight's set-up.
pub struct Plan {
    pub name: &'static str,
    /// Parameters over plane.parm at boot.
    pub params: Vec<(&'static str, f64)>,
    /// Failures and the like, as they come due.
    pub steps: Vec<Step>,
    /// Simulated seconds the flight may take.
    pub max_sim_s: f64,
    /// `petrel run` checks the project first, as a user's would (a debug
    /// build takes tens of seconds): once is enough for the suite, the
    /// other flights run `--unchecked` (the same project is checked by
    /// tests/flight_test_example.rs).
    pub checked: bool,
    /// The project folder `petrel run` supervises (default: the example
    /// itself); a copy for flights that change it ([`Act::Reload`]).
    pub project: Option<std::path::PathBuf>,
    /// Fly with the machine to itself ([`crate::sitl_turn_alone`]).
    pub alone: bool,
}

impl Plan {
    pub fn new(name: &'static str) -> Plan {
        Plan {
            name,
            params: Vec::new(),
            steps: Vec::new(),
            max_sim_s: 600.0,
            checked: false,
            project: None,
            alone: false,
        }
    }
}

/// The example's mission against real ArduPlane, as `plan` says; ends 3
/// simulated seconds after `done` holds, or after `max_sim_s`, or when the
/// gateway stops.
pub fn fly(plan: Plan, done: impl Fn(&Truth) -> bool) -> Option<RealFlown> {
    let Plan {
        name,
        params,
        mut steps,
        max_sim_s,
        checked,
        project,
        alone,
    } = plan;
    let project = project.unwrap_or_else(flight::project);
    let located = ardupilot::require(Firmware::Plane, name)?;
    let turn = if alone {
        crate::sitl_turn_alone()
    } else {
        crate::sitl_turn()
    };
    let scratch = Scratch::new(&format!("real-{name}"));
    let dir = scratch.to_path_buf();
    let mut sitl = Sitl::start(
        &located,
        &Options {
            instance: turn.instance(INSTANCE),
            speedup: SPEEDUP,
            // The observer's and the camera's ports at 921600 baud: at the
            // default 57600 ArduPilot drops what does not fit.
            params: [("SERIAL1_BAUD", 921.0), ("SERIAL2_BAUD", 921.0)]
                .iter()
                .chain(params.iter())
                .map(|(n, v)| ((*n).to_owned(), *v))
                .collect(),
            ..Options::default()
        },
        &dir.join("sitl"),
    )
    .expect("ArduPlane SITL starts");
    let relay = Relay::start(sitl.port(0));
    let programs = format!("tcp:127.0.0.1:{}", flight::free_port());
    let recording = dir.join("flight.mcap");
    // SITL runs slower than its speed-up on a busy machine (the gateway's
    // clock follows it): the wall-clock bound is generous, the simulated
    // one is the flight's.
    let max_wall = Duration::from_secs_f64(max_sim_s / f64::from(SPEEDUP) * 4.0 + 60.0);
    let dec = Dec::start(&programs);
    let started = Instant::now();
    let mut petrel = flight::Running::new(flight::petrel_run_project(
        &project,
        &format!("tcpout:127.0.0.1:{}", relay.port),
        &programs,
        f64::from(SPEEDUP),
        &recording,
        max_wall + Duration::from_secs(10),
        if checked { &[] } else { &["--unchecked"] },
    ));
    // The gateway connects once it has checked the project; the relay
    // then connects to SERIAL0 and the simulation starts.
    assert!(
        relay.wait_connected(Duration::from_secs(240)),
        "{name}: the gateway never connected"
    );
    let observer = Observer::start(sitl.port(1));
    // The camera the example's payloads need: its own component on
    // SERIAL2, as on a real vehicle; ArduPilot routes the gateway's camera
    // commands to it.
    let camera = CameraSim::start(
        &sitl.address(2).replace("tcpout:", ""),
        CameraConfig {
            speedup: f64::from(SPEEDUP),
            ..CameraConfig::default()
        },
    )
    .expect("the camera starts");
    let mut finished_at: Option<f64> = None;
    loop {
        std::thread::sleep(Duration::from_millis(100));
        let mut truth = observer.truth();
        truth.swapped = petrel.printed("\"input\":\"version\"");
        steps.retain(|(what, when, acts)| {
            if !when(&truth) {
                return true;
            }
            observer.record(what);
            for act in acts {
                match act {
                    Act::Param(name, value) => observer.set(name, *value),
                    Act::LinkHole(sim_s) => {
                        relay.hole(Duration::from_secs_f64(sim_s / f64::from(SPEEDUP)))
                    }
                    Act::Reload(files) => {
                        for (name, text) in files {
                            std::fs::write(project.join(name), text).expect("the version");
                        }
                        petrel.hangup();
                    }
                }
            }
            false
        });
        if finished_at.is_none() && done(&truth) {
            finished_at = Some(truth.t);
        }
        if finished_at.is_some_and(|t| truth.t > t + 3.0)
            || truth.t > max_sim_s
            || started.elapsed() > max_wall
            || !sitl.running()
        {
            break;
        }
        if petrel.exited() {
            break;
        }
    }
    let wall = started.elapsed();
    let (stdout, stderr, code) = petrel.stop();
    dec.stop();
    let truth = observer.truth();
    let camera_state = camera.state();
    camera.stop();
    sitl.stop();
    observer.finish();
    drop(relay);
    let _ = std::fs::write(dir.join("timeline.jsonl"), &stdout);
    let _ = std::fs::write(dir.join("petrel.err"), &stderr);
    eprintln!(
        "{name}: {:.0} s simulated in {:.1} s; SITL in {}",
        truth.t,
        wall.as_secs_f64(),
        dir.display()
    );
    Some(RealFlown {
        flown: Flown {
            state: Default::default(),
            timeline: flight::timeline(&stdout),
            stderr,
            recording,
            scratch,
            wall,
        },
        truth,
        camera: camera_state,
        code,
    })
}
