//! One flight of a project against PX4's own SITL (SIH): the real `petrel
//! run` on PX4's onboard link as a companion computer is (through a UDP
//! relay that can open a hole in the link), and an observer on PX4's ground
//! station link that sees what PX4 itself does (modes, arming, landed state,
//! texts, items reached, position: the truth the assertions read) and
//! injects failures with PARAM_SET and MAV_CMD_INJECT_FAILURE.

use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use elaboration::Firmware as Family;
use mavlink::dialects::ardupilotmega::*;
use mavlink::MavHeader;
use sitl_tests::px4::{self, Model, Options, Px4};

use super::flight::{self, Flown};
use crate::scratch::Scratch;

/// Our system id on the ground station link: a ground station's (PX4
/// counts the link as a GCS link only from a MAV_TYPE_GCS heartbeat).
const OBSERVER: (u8, u8) = (255, 190);

/// What PX4 did, as a ground station saw it. Times are simulated seconds
/// since PX4 booted (its time_boot_ms).
#[derive(Debug, Clone, Default)]
pub struct Truth {
    pub t: f64,
    pub mode: String,
    pub armed: bool,
    pub modes: Vec<(f64, String)>,
    pub arming: Vec<(f64, bool)>,
    pub texts: Vec<(f64, String)>,
    /// Items reached (each once).
    pub reached: Vec<(f64, u16)>,
    /// MAV_LANDED_STATE, as a number (1 on ground, 2 in air, 3 taking off,
    /// 4 landing).
    pub landed_state: u8,
    pub lat: f64,
    pub lon: f64,
    /// Metres above home.
    pub alt: f64,
    pub max_alt: f64,
    pub battery: i8,
    /// GPS_RAW_INT.fix_type, satellites.
    pub fix: (u8, u8),
    /// COMMAND_ACKs PX4 sent to the observer: (command, result).
    pub acks: Vec<(f64, String, String)>,
    /// When each act was done (name, time).
    pub injected: Vec<(f64, String)>,
    /// A chunked STATUSTEXT being put together.
    chunks: elaboration::statustext::Joiner,
}

impl Truth {
    /// Was flying, and is now down and disarmed.
    pub fn down(&self) -> bool {
        self.max_alt > 5.0 && !self.armed && self.alt < 2.0 && self.landed_state == 1
    }

    pub fn text(&self, needle: &str) -> Option<f64> {
        self.texts
            .iter()
            .find(|(_, t)| t.contains(needle))
            .map(|(t, _)| *t)
    }

    pub fn modes_after(&self, t: f64) -> Vec<&str> {
        self.modes
            .iter()
            .filter(|(at, _)| *at >= t)
            .map(|(_, m)| m.as_str())
            .collect()
    }

    pub fn injected_at(&self, name: &str) -> Option<f64> {
        self.injected
            .iter()
            .find(|(_, n)| n == name)
            .map(|(t, _)| *t)
    }

    /// How many times it armed: as its HEARTBEATs showed, or as it said
    /// ("Armed by …") when a disarmed spell shorter than the heartbeats
    /// reaching a busy observer went unseen (a landing then a mission start
    /// 0.75 s later).
    pub fn arms(&self) -> usize {
        let seen = self.arming.iter().filter(|(_, a)| *a).count();
        let said = self
            .texts
            .iter()
            .filter(|(_, t)| t.starts_with("Armed by"))
            .count();
        seen.max(said)
    }

    fn heard(&mut self, message: &MavMessage) {
        match message {
            MavMessage::HEARTBEAT(hb) => {
                let mode = elaboration::constants::mode_name(Family::Px4, hb.custom_mode);
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
            MavMessage::SYSTEM_TIME(s) => self.t = self.t.max(f64::from(s.time_boot_ms) / 1000.0),
            MavMessage::GLOBAL_POSITION_INT(p) => {
                self.t = self.t.max(f64::from(p.time_boot_ms) / 1000.0);
                if (p.lat, p.lon) != (0, 0) {
                    self.lat = f64::from(p.lat) / 1e7;
                    self.lon = f64::from(p.lon) / 1e7;
                    self.alt = f64::from(p.relative_alt) / 1000.0;
                    self.max_alt = self.max_alt.max(self.alt);
                }
            }
            MavMessage::EXTENDED_SYS_STATE(s) => self.landed_state = s.landed_state as u8,
            MavMessage::SYS_STATUS(s) => self.battery = s.battery_remaining,
            MavMessage::GPS_RAW_INT(g) => self.fix = (g.fix_type as u8, g.satellites_visible),
            // PX4 sends a text longer than 50 bytes in chunks of one `id`.
            MavMessage::STATUSTEXT(s) => {
                let raw = String::from_utf8_lossy(&s.text[..]);
                let (part, last) = match raw.find('\0') {
                    Some(end) => (&raw[..end], true),
                    None => (&raw[..], false),
                };
                let text = match self.chunks.push(s.id, s.chunk_seq, part, last) {
                    elaboration::statustext::Piece::Whole => part.to_owned(),
                    elaboration::statustext::Piece::Joined(whole) => whole,
                    elaboration::statustext::Piece::Pending => return,
                };
                self.texts
                    .push((self.t, text.trim_end_matches('\t').to_owned()));
            }
            MavMessage::COMMAND_ACK(a) => self.acks.push((
                self.t,
                format!("{:?}", a.command),
                format!("{:?}", a.result),
            )),
            MavMessage::MISSION_ITEM_REACHED(r)
                if self.reached.last().map(|l| l.1) != Some(r.seq) =>
            {
                self.reached.push((self.t, r.seq));
            }
            _ => {}
        }
    }
}

/// A ground station on PX4's GCS link (UDP 18570+I): speaks first so that
/// PX4 sends to it, then reads on a thread until stopped.
pub struct Observer {
    socket: UdpSocket,
    px4: SocketAddr,
    target: (u8, u8),
    truth: Arc<Mutex<Truth>>,
    /// Sending MANUAL_CONTROL (sticks centred), as a joystick would.
    manual: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
}

impl Observer {
    pub fn start(px4: &Px4) -> Observer {
        let socket = UdpSocket::bind("127.0.0.1:0").expect("an observer port");
        let _ = socket.set_read_timeout(Some(Duration::from_millis(100)));
        let to: SocketAddr = ([127, 0, 0, 1], px4.gcs_port()).into();
        let truth = Arc::new(Mutex::new(Truth::default()));
        let stop = Arc::new(AtomicBool::new(false));
        let sysid = px4.system_id();
        let mut threads = Vec::new();
        {
            let (s, t, stop) = (
                socket.try_clone().expect("the socket"),
                truth.clone(),
                stop.clone(),
            );
            threads.push(std::thread::spawn(move || {
                let mut buf = vec![0u8; 65536];
                let mut frames = Vec::new();
                while !stop.load(Ordering::Relaxed) {
                    let Ok(n) = s.recv(&mut buf) else { continue };
                    let mut bytes = buf[..n].to_vec();
                    frames.clear();
                    sitl_tests::wire::parse_frames(&mut bytes, &mut frames);
                    if let Ok(mut truth) = t.lock() {
                        for (header, message) in &frames {
                            if (header.system_id as u8, header.component_id) == (sysid, 1) {
                                truth.heard(message);
                            }
                        }
                    }
                }
            }));
        }
        {
            // A ground station's heartbeat, 5 times a wall second.
            let (s, stop) = (socket.try_clone().expect("the socket"), stop.clone());
            threads.push(std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                        custom_mode: 0,
                        mavtype: MavType::MAV_TYPE_GCS,
                        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
                        base_mode: MavModeFlag::empty(),
                        system_status: MavState::MAV_STATE_ACTIVE,
                        mavlink_version: 3,
                    });
                    let _ = s.send_to(&sitl_tests::wire::frame(header(), &hb), to);
                    std::thread::sleep(Duration::from_millis(200));
                }
            }));
        }
        let manual = Arc::new(AtomicBool::new(false));
        {
            // MANUAL_CONTROL, 20 times a wall second while `manual` is set:
            // PX4's manual control input when COM_RC_IN_MODE takes MAVLink
            // (1, the SITL's). Sticks centred, throttle half (z 500).
            let (s, stop, manual) = (
                socket.try_clone().expect("the socket"),
                stop.clone(),
                manual.clone(),
            );
            threads.push(std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    if manual.load(Ordering::Relaxed) {
                        let m = MavMessage::MANUAL_CONTROL(MANUAL_CONTROL_DATA {
                            x: 0,
                            y: 0,
                            z: 500,
                            r: 0,
                            buttons: 0,
                            target: sysid,
                            ..MANUAL_CONTROL_DATA::DEFAULT
                        });
                        let _ = s.send_to(&sitl_tests::wire::frame(header(), &m), to);
                    }
                    std::thread::sleep(Duration::from_millis(50));
                }
            }));
        }
        let observer = Observer {
            socket,
            px4: to,
            target: (sysid, 1),
            truth,
            manual,
            stop,
            threads,
        };
        // What the assertions read, often enough to see a mode held for a
        // moment.
        for (id, hz) in [
            (0, 10.0),
            (2, 2.0),
            (33, 4.0),
            (245, 4.0),
            (1, 2.0),
            (24, 2.0),
        ] {
            observer.command(
                MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                [id as f32, 1e6 / hz, 0.0, 0.0, 0.0, 0.0, 0.0],
            );
        }
        observer
    }

    pub fn send(&self, message: &MavMessage) {
        let _ = self
            .socket
            .send_to(&sitl_tests::wire::frame(header(), message), self.px4);
    }

    pub fn command(&self, command: MavCmd, params: [f32; 7]) {
        self.send(&sitl_tests::wire::command_long(
            self.target,
            command,
            params,
        ));
    }

    /// PARAM_SET (a SIH parameter, a failsafe setting).
    pub fn set(&self, name: &str, value: f32, kind: MavParamType) {
        // PX4 reads an INT32 parameter's value as the float's bytes.
        let param_value = match kind {
            MavParamType::MAV_PARAM_TYPE_INT32 => f32::from_bits(value as i32 as u32),
            _ => value,
        };
        self.send(&MavMessage::PARAM_SET(PARAM_SET_DATA {
            param_value,
            target_system: self.target.0,
            target_component: self.target.1,
            param_id: name.into(),
            param_type: kind,
        }));
    }

    /// Starts or stops sending MANUAL_CONTROL.
    pub fn manual_control(&self, on: bool) {
        self.manual.store(on, Ordering::Relaxed);
    }

    pub fn truth(&self) -> Truth {
        self.truth.lock().map(|t| t.clone()).unwrap_or_default()
    }

    pub fn record(&self, what: &str) {
        if let Ok(mut t) = self.truth.lock() {
            let now = t.t;
            t.injected.push((now, what.to_owned()));
        }
    }

    pub fn finish(mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for Observer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

fn header() -> MavHeader {
    MavHeader {
        system_id: u32::from(OBSERVER.0),
        component_id: OBSERVER.1,
        sequence: 0,
    }
}

/// A UDP relay on PX4's onboard link: PX4 sends to 14540+I, where the relay
/// listens; the gateway listens on `port` (`udpin:`). Everything both ways
/// can be dropped for a while: a hole on the gateway's link only.
pub struct Relay {
    pub port: u16,
    /// The gateway has spoken (its first frame reached PX4).
    heard_gateway: Arc<AtomicBool>,
    hole_until: Arc<Mutex<Option<Instant>>>,
    stop: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
}

impl Relay {
    /// Also writes what reaches the gateway from PX4 to `tlog`, stamped
    /// with PX4's own time (its latest time_boot_ms): a simulation that
    /// falls behind its speed-up on a busy machine makes no silence there.
    pub fn start(px4: &Px4, tlog: &Path) -> Relay {
        let mut tlog = std::fs::File::create(tlog)
            .map(|f| elaboration::TlogWriter::new(std::io::BufWriter::new(f)))
            .expect("the tlog");
        let mut vehicle_us = 0u64;
        let vehicle = UdpSocket::bind(("127.0.0.1", px4.onboard_port())).expect("the onboard port");
        let gateway = UdpSocket::bind("127.0.0.1:0").expect("a relay port");
        let port = flight::free_udp_port();
        let to_gateway: SocketAddr = ([127, 0, 0, 1], port).into();
        for s in [&vehicle, &gateway] {
            let _ = s.set_read_timeout(Some(Duration::from_millis(100)));
        }
        let hole_until: Arc<Mutex<Option<Instant>>> = Arc::new(Mutex::new(None));
        let stop = Arc::new(AtomicBool::new(false));
        let px4_addr: Arc<Mutex<Option<SocketAddr>>> = Arc::new(Mutex::new(None));
        let open = {
            let hole = hole_until.clone();
            move || {
                hole.lock()
                    .map(|h| h.is_none_or(|until| Instant::now() >= until))
                    .unwrap_or(true)
            }
        };
        let sysid = px4.system_id();
        let mut threads = Vec::new();
        {
            let (from, to, stop, open, px4_addr) = (
                vehicle.try_clone().expect("socket"),
                gateway.try_clone().expect("socket"),
                stop.clone(),
                open.clone(),
                px4_addr.clone(),
            );
            threads.push(std::thread::spawn(move || {
                let mut buf = vec![0u8; 65536];
                let mut slowed = false;
                while !stop.load(Ordering::Relaxed) {
                    let Ok((n, src)) = from.recv_from(&mut buf) else {
                        continue;
                    };
                    if let Ok(mut a) = px4_addr.lock() {
                        *a = Some(src);
                    }
                    if !slowed {
                        slowed = true;
                        slow_onboard_streams(&from, src, sysid);
                    }
                    if open() {
                        let _ = to.send_to(&buf[..n], to_gateway);
                        let mut rest = &buf[..n];
                        while let Some(len) = elaboration::frame::announced_len(rest) {
                            if len > rest.len() {
                                break;
                            }
                            vehicle_us = vehicle_us.max(boot_us(&rest[..len]));
                            let _ = tlog.write_frame(vehicle_us, &rest[..len]);
                            rest = &rest[len..];
                        }
                    }
                }
                let _ = tlog.into_inner();
            }));
        }
        let heard_gateway = Arc::new(AtomicBool::new(false));
        {
            let (from, to, stop, heard) = (gateway, vehicle, stop.clone(), heard_gateway.clone());
            threads.push(std::thread::spawn(move || {
                let mut buf = vec![0u8; 65536];
                while !stop.load(Ordering::Relaxed) {
                    let Ok(n) = from.recv(&mut buf) else { continue };
                    heard.store(true, Ordering::Relaxed);
                    let dest = px4_addr.lock().ok().and_then(|a| *a);
                    if let (true, Some(dest)) = (open(), dest) {
                        let _ = to.send_to(&buf[..n], dest);
                    }
                }
            }));
        }
        Relay {
            port,
            heard_gateway,
            hole_until,
            stop,
            threads,
        }
    }

    /// Waits until the gateway has sent something to PX4, at most `limit`.
    pub fn wait_gateway(&self, limit: Duration) -> bool {
        let started = Instant::now();
        while started.elapsed() < limit {
            if self.heard_gateway.load(Ordering::Relaxed) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        false
    }

    pub fn hole(&self, wall: Duration) {
        if let Ok(mut h) = self.hole_until.lock() {
            *h = Some(Instant::now() + wall);
        }
    }
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// PX4's boot time in a frame that carries it, in µs (0 otherwise).
fn boot_us(bytes: &[u8]) -> u64 {
    let Ok(frame) = elaboration::Frame::parse(bytes) else {
        return 0;
    };
    if !matches!(frame.message_id(), 2 | 30 | 31 | 32 | 33) {
        return 0;
    }
    let ms = match frame.decode() {
        Ok(MavMessage::SYSTEM_TIME(m)) => m.time_boot_ms,
        Ok(MavMessage::ATTITUDE(m)) => m.time_boot_ms,
        Ok(MavMessage::ATTITUDE_QUATERNION(m)) => m.time_boot_ms,
        Ok(MavMessage::LOCAL_POSITION_NED(m)) => m.time_boot_ms,
        Ok(MavMessage::GLOBAL_POSITION_INT(m)) => m.time_boot_ms,
        _ => 0,
    };
    u64::from(ms) * 1000
}

/// PX4's onboard mode streams attitude, IMU, odometry and the like at 50 to
/// 250 Hz; at 10× speed that is over 3000 frames a wall second, which a
/// debug build on a busy 2-core machine cannot record. A companion sets its
/// link's rates (MAV_n_RATE, or as here, SET_MESSAGE_INTERVAL on its link):
/// these, none of which the PX4 profile reads, go to 2 Hz before the
/// gateway starts. Messages the profile reads are the gateway's to ask for.
fn slow_onboard_streams(socket: &UdpSocket, px4: SocketAddr, sysid: u8) {
    const HEAVY: [u32; 13] = [30, 31, 32, 36, 74, 83, 85, 105, 132, 141, 291, 331, 33];
    let header = MavHeader {
        system_id: 250,
        component_id: 190,
        sequence: 0,
    };
    for id in HEAVY {
        let m = sitl_tests::wire::command_long(
            (sysid, 1),
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            [id as f32, 500_000.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        let _ = socket.send_to(&sitl_tests::wire::frame(header, &m), px4);
    }
}

/// Something done to the vehicle during a flight.
#[derive(Debug, Clone)]
pub enum Act {
    /// PARAM_SET of an integer parameter.
    IntParam(&'static str, i32),
    /// MAV_CMD_INJECT_FAILURE: unit (FAILURE_UNIT), type (FAILURE_TYPE),
    /// instance (0: all).
    Failure(f32, f32, f32),
    /// Nothing through the gateway's link, both ways, for this many
    /// simulated seconds.
    LinkHole(f64),
    /// MANUAL_CONTROL from the ground station link, started (true) or
    /// stopped (false): a joystick, or an RC link lost.
    ManualControl(bool),
}

/// An act, when a condition on the truth first holds, named for the
/// assertions (`Truth::injected_at`).
pub type Step = (&'static str, Box<dyn Fn(&Truth) -> bool + Send>, Vec<Act>);

/// One flight's set-up.
pub struct Plan {
    pub name: &'static str,
    pub project: PathBuf,
    pub model: Model,
    /// PX4 parameters at start (`PX4_PARAM_<NAME>`).
    pub params: Vec<(&'static str, f64)>,
    pub steps: Vec<Step>,
    pub max_sim_s: f64,
    /// `petrel run` checks the project first (else `--unchecked`).
    pub checked: bool,
    /// Extra arguments to `petrel run`.
    pub args: Vec<String>,
}

impl Plan {
    pub fn new(name: &'static str, project: PathBuf) -> Plan {
        Plan {
            name,
            project,
            model: Model::Quad,
            params: Vec::new(),
            steps: Vec::new(),
            max_sim_s: 300.0,
            checked: false,
            args: Vec::new(),
        }
    }
}

/// Simulated seconds per wall second, for PX4 and the gateway's clock. At
/// 10× a PX4 stalled 0.35 s by a busy machine is a 3.5 s silence to the
/// gateway's clock (link_lost); 5× halves that risk.
pub const SPEED: u32 = 5;

/// A flight's result: the gateway's side and PX4's.
pub struct Px4Flown {
    pub flown: Flown,
    /// What reached the gateway from PX4, as a tlog.
    pub tlog: PathBuf,
    pub truth: Truth,
}

impl Px4Flown {
    /// Transitions fired, in order.
    pub fn fired(&self) -> Vec<String> {
        self.flown
            .effects("fired")
            .iter()
            .filter_map(|l| l["transition"].as_str().map(str::to_owned))
            .collect()
    }

    /// Events heard with their params.
    pub fn heard(&self, name: &str) -> Vec<serde_json::Value> {
        self.flown
            .timeline
            .iter()
            .filter(|l| l["input"] == "event" && l["event"] == name)
            .map(|l| l["params"].clone())
            .collect()
    }
}

/// Flies `plan`; ends 3 simulated seconds after `done` holds, after
/// `max_sim_s`, or when the gateway stops. `None`: no PX4 build (skipped).
pub fn fly(plan: Plan, done: impl Fn(&Truth) -> bool) -> Option<Px4Flown> {
    let Plan {
        name,
        project,
        model,
        params,
        mut steps,
        max_sim_s,
        checked,
        args,
    } = plan;
    let located = px4::require(name)?;
    // A turn to fly (real/main.rs: at most two flights at once, each on
    // instances of its own).
    let _turn = crate::sitl_turn();
    let scratch = Scratch::new(&format!("px4-{name}"));
    let dir = scratch.to_path_buf();
    let mut sitl = Px4::start(
        &located,
        &Options {
            model,
            speed: SPEED,
            params: params.iter().map(|(n, v)| ((*n).to_owned(), *v)).collect(),
            log: false,
        },
        &dir.join("px4"),
    )
    .expect("PX4 SITL starts");
    let tlog = dir.join("onboard.tlog");
    let relay = Relay::start(&sitl, &tlog);
    let recording = dir.join("flight.mcap");
    let max_wall = Duration::from_secs_f64(max_sim_s / f64::from(SPEED) * 4.0 + 60.0);
    let observer = Observer::start(&sitl);
    let started = Instant::now();
    let mut extra: Vec<&str> = args.iter().map(String::as_str).collect();
    if !checked {
        extra.push("--unchecked");
    }
    let mut petrel = flight::Running::new(flight::petrel_run_project(
        &project,
        &format!("udpin:127.0.0.1:{}", relay.port),
        &format!("tcp:127.0.0.1:{}", flight::free_port()),
        f64::from(SPEED),
        &recording,
        max_wall + Duration::from_secs(10),
        &extra,
    ));
    // PX4 runs from its start; the flight's time counts from the gateway's
    // first word (a debug build on a busy machine may take seconds).
    assert!(
        relay.wait_gateway(Duration::from_secs(60)),
        "{name}: the gateway never spoke to PX4"
    );
    let start = observer.truth().t;
    let mut finished_at: Option<f64> = None;
    let ended: &str;
    loop {
        std::thread::sleep(Duration::from_millis(100));
        let truth = observer.truth();
        steps.retain(|(what, when, acts)| {
            if !when(&truth) {
                return true;
            }
            observer.record(what);
            for act in acts {
                match act {
                    Act::IntParam(name, value) => {
                        observer.set(name, *value as f32, MavParamType::MAV_PARAM_TYPE_INT32)
                    }
                    Act::Failure(unit, kind, instance) => observer.command(
                        MavCmd::MAV_CMD_INJECT_FAILURE,
                        [*unit, *kind, *instance, 0.0, 0.0, 0.0, 0.0],
                    ),
                    Act::LinkHole(sim_s) => {
                        relay.hole(Duration::from_secs_f64(sim_s / f64::from(SPEED)))
                    }
                    Act::ManualControl(on) => observer.manual_control(*on),
                }
            }
            false
        });
        if finished_at.is_none() && done(&truth) {
            finished_at = Some(truth.t);
        }
        // Why the flight ended, said with the figures (a test that fails
        // after an early end says which side stopped).
        ended = if finished_at.is_some_and(|t| truth.t > t + 3.0) {
            "done"
        } else if truth.t - start > max_sim_s {
            "max_sim_s reached"
        } else if started.elapsed() > max_wall {
            "max_wall reached"
        } else if !sitl.running() {
            "PX4 exited"
        } else if petrel.exited() {
            "the gateway exited"
        } else {
            continue;
        };
        break;
    }
    let wall = started.elapsed();
    let (stdout, stderr, code) = petrel.stop();
    let truth = observer.truth();
    observer.finish();
    sitl.stop();
    drop(relay);
    let _ = std::fs::write(dir.join("timeline.jsonl"), &stdout);
    let _ = std::fs::write(dir.join("petrel.err"), &stderr);
    eprintln!(
        "{name}: {:.0} s simulated in {:.1} s, ended: {ended} (gateway exit code {code:?}); in {}",
        truth.t,
        wall.as_secs_f64(),
        dir.display()
    );
    Some(Px4Flown {
        tlog,
        flown: Flown {
            state: Default::default(),
            timeline: flight::timeline(&stdout),
            stderr,
            recording,
            scratch,
            wall,
        },
        truth,
    })
}

/// `petrel events TLOG --json`: (name, category) in order.
pub fn petrel_events(tlog: &Path) -> Vec<(String, String)> {
    let out = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .args(["events", &tlog.display().to_string(), "--json"])
        .output()
        .expect("petrel runs");
    assert_eq!(
        out.status.code(),
        Some(0),
        "petrel events: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter_map(|v| {
            Some((
                v["event"].as_str()?.to_owned(),
                v["category"].as_str()?.to_owned(),
            ))
        })
        .collect()
}

/// A project of the tests' own (gateway/tests/px4/NAME).
pub fn project(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/px4")
        .join(name)
}
