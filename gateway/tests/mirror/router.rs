#![allow(dead_code)] // shared by the mirror test binaries, each using a part
//! An autopilot's MAVLink routing between two serial ports, in front of the
//! simulated ArduPlane (which has one port): the companion's port (where
//! `petrel run` sits) and the ground's (where `petrel mirror` sits, behind a
//! radio that loses frames). It routes as ArduPilot's
//! `MAVLink_routing.cpp` does for what the mirror needs: the vehicle's own
//! frames to every port; a frame targeted at another system to the ports
//! where that system has been heard (rule 2c), at the vehicle's system and
//! another component to where that (system, component) has been heard
//! (2d); broadcasts and the rest to the vehicle; HEARTBEATs also to the
//! other ports. Every frame the ground sends is kept for the test to check.

use std::collections::BTreeSet;
use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use elaboration::{Frame, FrameError};

/// How the radio between the vehicle and the ground loses frames.
#[derive(Debug, Clone, Default)]
pub struct Loss {
    /// Frames lost in a thousand, at random (seeded).
    pub per_mille: u64,
    pub seed: u64,
    /// Every frame lost during these windows (wall seconds after start).
    pub bursts: Vec<(f64, f64)>,
}

/// What went through.
#[derive(Debug, Default)]
pub struct Traffic {
    /// Every frame the ground sent, as bytes.
    pub from_ground: Vec<Vec<u8>>,
    /// Frames and bytes delivered to the ground: (all, Petrel's TUNNEL).
    pub to_ground: (u64, u64),
    pub to_ground_bytes: (u64, u64),
    /// Frames the radio lost, both ways.
    pub lost: u64,
    /// Frames delivered to the companion's port.
    pub to_companion: u64,
    /// (wall seconds since start, bytes, Petrel's TUNNEL) of every frame
    /// delivered to the ground.
    pub delivered: Vec<(f64, usize, bool)>,
}

pub struct Router {
    pub companion_port: u16,
    pub ground_port: u16,
    stop: Arc<AtomicBool>,
    /// Everything toward the ground lost while set (the uplink still
    /// works): a radio that fades one way.
    muted: Arc<AtomicBool>,
    /// Everything from the ground lost while set (still kept in
    /// `Traffic::from_ground`).
    up_muted: Arc<AtomicBool>,
    /// Set: the routes learned are forgotten (an autopilot that rebooted).
    forget: Arc<AtomicBool>,
    /// Set: a hostile transmitter on the radio sends, after each downlink
    /// frame, what this makes of it.
    forge: Arc<Mutex<Option<Forger>>>,
    traffic: Arc<Mutex<Traffic>>,
    thread: Option<JoinHandle<()>>,
}

/// Forged frames made of a downlink frame.
pub type Forger = fn(&[u8]) -> Vec<Vec<u8>>;

const VEHICLE: u8 = 1;
const TUNNEL: u32 = 385;
const HEARTBEAT: u32 = 0;

struct Port {
    stream: Option<TcpStream>,
    listener: Option<TcpListener>,
    buf: Vec<u8>,
    /// (system, component) heard on this port.
    heard: BTreeSet<(u8, u8)>,
}

impl Port {
    fn listen() -> Port {
        let l = TcpListener::bind("127.0.0.1:0").expect("a port");
        l.set_nonblocking(true).expect("non-blocking");
        Port {
            stream: None,
            listener: Some(l),
            buf: Vec::new(),
            heard: BTreeSet::new(),
        }
    }

    fn port(&self) -> u16 {
        self.listener
            .as_ref()
            .and_then(|l| l.local_addr().ok())
            .map_or(0, |a| a.port())
    }

    /// Frames read since the last call.
    fn read(&mut self) -> Vec<Vec<u8>> {
        if self.stream.is_none() {
            if let Some(l) = &self.listener {
                if let Ok((s, _)) = l.accept() {
                    let _ = s.set_nonblocking(true);
                    let _ = s.set_nodelay(true);
                    self.stream = Some(s);
                }
            }
        }
        let Some(s) = &mut self.stream else {
            return Vec::new();
        };
        let mut chunk = [0u8; 4096];
        loop {
            match s.read(&mut chunk) {
                Ok(0) => {
                    self.stream = None;
                    break;
                }
                Ok(n) => self.buf.extend_from_slice(&chunk[..n]),
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(_) => {
                    self.stream = None;
                    break;
                }
            }
        }
        let mut frames = Vec::new();
        let mut pos = 0;
        while pos < self.buf.len() {
            match Frame::parse(&self.buf[pos..]) {
                Ok(f) => {
                    self.heard.insert((f.system_id(), f.component_id()));
                    frames.push(f.bytes().to_vec());
                    pos += f.bytes().len();
                }
                Err(FrameError::Truncated { .. }) => break,
                Err(_) => pos += 1,
            }
        }
        self.buf.drain(..pos);
        frames
    }

    fn write(&mut self, bytes: &[u8]) {
        let Some(s) = &mut self.stream else { return };
        let deadline = Instant::now() + Duration::from_millis(200);
        let mut at = 0;
        while at < bytes.len() && Instant::now() < deadline {
            match s.write(&bytes[at..]) {
                Ok(n) => at += n,
                Err(e) if e.kind() == ErrorKind::WouldBlock => {
                    std::thread::sleep(Duration::from_micros(200))
                }
                Err(_) => {
                    self.stream = None;
                    return;
                }
            }
        }
    }
}

/// (target system, target component) of a frame, for the messages the
/// router needs: TUNNEL's are its payload's bytes 2 and 3 (after the u16
/// payload type), COMMAND_LONG's and the rest are not looked at.
fn tunnel_target(f: &Frame) -> Option<(u8, u8)> {
    if f.message_id() != TUNNEL {
        return None;
    }
    let p = f.payload();
    Some((
        p.get(2).copied().unwrap_or(0),
        p.get(3).copied().unwrap_or(0),
    ))
}

struct Radio {
    loss: Loss,
    seed: u64,
    start: Instant,
}

impl Radio {
    fn loses(&mut self) -> bool {
        self.seed ^= self.seed << 13;
        self.seed ^= self.seed >> 7;
        self.seed ^= self.seed << 17;
        let t = self.start.elapsed().as_secs_f64();
        self.seed % 1000 < self.loss.per_mille
            || self.loss.bursts.iter().any(|(a, b)| (*a..*b).contains(&t))
    }
}

impl Router {
    /// Connects to the simulator at `sim` (its `tcpin:` port) and opens the
    /// companion's and the ground's ports.
    pub fn start(sim: std::net::SocketAddr, loss: Loss) -> Router {
        let stream = TcpStream::connect(sim).expect("the simulator accepts");
        stream.set_nonblocking(true).expect("non-blocking");
        let _ = stream.set_nodelay(true);
        let mut vehicle = Port {
            stream: Some(stream),
            listener: None,
            buf: Vec::new(),
            heard: BTreeSet::new(),
        };
        let mut companion = Port::listen();
        let mut ground = Port::listen();
        let (companion_port, ground_port) = (companion.port(), ground.port());
        let stop = Arc::new(AtomicBool::new(false));
        let traffic = Arc::new(Mutex::new(Traffic::default()));
        let (flag, shared) = (stop.clone(), traffic.clone());
        let muted = Arc::new(AtomicBool::new(false));
        let mute = muted.clone();
        let up_muted = Arc::new(AtomicBool::new(false));
        let up_mute = up_muted.clone();
        let forget = Arc::new(AtomicBool::new(false));
        let forgetting = forget.clone();
        let forge: Arc<Mutex<Option<Forger>>> = Arc::new(Mutex::new(None));
        let forging = forge.clone();
        let mut radio = Radio {
            seed: loss.seed | 1,
            loss,
            start: Instant::now(),
        };
        let thread = std::thread::spawn(move || {
            while !flag.load(Ordering::Relaxed) {
                let mut idle = true;
                if forgetting.swap(false, Ordering::Relaxed) {
                    ground.heard.clear();
                    companion.heard.clear();
                }
                // Over the radio to the ground, counted.
                let mut downlink = |ground: &mut Port, bytes: &[u8], tunnel: bool| {
                    let mut t = shared.lock().expect("traffic");
                    if radio.loses() || mute.load(Ordering::Relaxed) {
                        t.lost += 1;
                        return;
                    }
                    t.to_ground.0 += 1;
                    t.to_ground_bytes.0 += bytes.len() as u64;
                    let at = radio.start.elapsed().as_secs_f64();
                    t.delivered.push((at, bytes.len(), tunnel));
                    if tunnel {
                        t.to_ground.1 += 1;
                        t.to_ground_bytes.1 += bytes.len() as u64;
                    }
                    drop(t);
                    ground.write(bytes);
                };
                for bytes in vehicle.read() {
                    idle = false;
                    shared.lock().expect("traffic").to_companion += 1;
                    companion.write(&bytes);
                    downlink(&mut ground, &bytes, false);
                }
                for bytes in companion.read() {
                    idle = false;
                    let Ok(f) = Frame::parse(&bytes) else {
                        continue;
                    };
                    let target = tunnel_target(&f);
                    let to_ground = match target {
                        Some((s, _)) if s != VEHICLE && s != 0 => {
                            ground.heard.iter().any(|(gs, _)| *gs == s)
                        }
                        _ => f.message_id() == HEARTBEAT,
                    };
                    if to_ground {
                        downlink(&mut ground, &bytes, target.is_some());
                        let forger = *forging.lock().expect("forger");
                        if let (Some(_), Some(forger)) = (target, forger) {
                            for forged in forger(&bytes) {
                                downlink(&mut ground, &forged, true);
                            }
                        }
                    }
                    if target.is_none() || target.is_some_and(|(s, _)| s == VEHICLE || s == 0) {
                        vehicle.write(&bytes);
                    }
                }
                for bytes in ground.read() {
                    idle = false;
                    shared
                        .lock()
                        .expect("traffic")
                        .from_ground
                        .push(bytes.clone());
                    if radio.loses() || up_mute.load(Ordering::Relaxed) {
                        shared.lock().expect("traffic").lost += 1;
                        continue;
                    }
                    let Ok(f) = Frame::parse(&bytes) else {
                        continue;
                    };
                    match tunnel_target(&f) {
                        Some((VEHICLE, c)) if c != 1 => {
                            if companion.heard.contains(&(VEHICLE, c)) {
                                shared.lock().expect("traffic").to_companion += 1;
                                companion.write(&bytes);
                            }
                        }
                        _ => vehicle.write(&bytes),
                    }
                }
                if idle {
                    std::thread::sleep(Duration::from_millis(1));
                }
            }
        });
        Router {
            companion_port,
            ground_port,
            stop,
            muted,
            up_muted,
            forget,
            forge,
            traffic,
            thread: Some(thread),
        }
    }

    pub fn traffic(&self) -> std::sync::MutexGuard<'_, Traffic> {
        self.traffic.lock().expect("traffic")
    }

    /// Loses every frame toward the ground while `on` (the uplink works).
    pub fn mute_downlink(&self, on: bool) {
        self.muted.store(on, Ordering::Relaxed);
    }

    /// Loses every frame from the ground while `on` (the downlink works).
    pub fn mute_uplink(&self, on: bool) {
        self.up_muted.store(on, Ordering::Relaxed);
    }

    /// Forgets every route learned, as an autopilot does when it reboots:
    /// the downlink to the mirror goes nowhere until the mirror is heard
    /// again.
    pub fn forget_routes(&self) {
        self.forget.store(true, Ordering::Relaxed);
    }

    /// From now on, a hostile transmitter follows every downlink frame
    /// with what `forger` makes of it (none: it stops).
    pub fn forge_downlink(&self, forger: Option<Forger>) {
        *self.forge.lock().expect("forger") = forger;
    }

    pub fn stop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Router {
    fn drop(&mut self) {
        self.stop();
    }
}
