//! The I/O around the vehicles: a thread owning the socket and the sim
//! clock, feeding every [`Vehicle`] what arrives and sending what each
//! polls. `tcpin:` serves one client at a time and accepts again after it
//! leaves, as ArduPilot SITL's TCP port; `udpin:` answers the last sender.
//!
//! A [`Fleet`] runs several vehicles, each its own MAVLink system, behind
//! one socket: what a router (mavlink-router, one radio) shows a ground
//! station. Every frame that arrives reaches every vehicle, and each obeys
//! what is addressed to its system (or to all); their frames go out
//! interleaved on the one link. A [`Sim`] is a fleet of one. For vehicles
//! on links of their own, start one [`Sim`] (or fleet) per socket.

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavHeader, MavlinkVersion};

use crate::clock::SimClock;
use crate::config::SimConfig;
use crate::faults::{Fault, FaultKind};
use crate::state::SimState;
use crate::vehicle::{Vehicle, WireFaults};
use crate::wire::parse_frames;

/// Why the simulation could not start.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error("bad listen address `{0}`: expected tcpin:IP:PORT or udpin:IP:PORT")]
    BadAddress(String),
    #[error("bad speedup {0}: expected a finite number above 0")]
    BadSpeedup(f64),
    #[error("cannot listen on {address}: {source}")]
    Listen {
        address: String,
        source: std::io::Error,
    },
    #[error("cannot start the simulation thread: {0}")]
    Thread(std::io::Error),
    #[error("a fleet needs at least one vehicle")]
    NoVehicle,
    #[error("two vehicles have system id {0}: each needs its own")]
    SameSystem(u8),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Transport {
    Tcp,
    Udp,
}

fn parse_listen(address: &str) -> Result<(Transport, SocketAddr), SimError> {
    let bad = || SimError::BadAddress(address.to_owned());
    let (kind, rest) = address.split_once(':').ok_or_else(bad)?;
    let transport = match kind {
        "tcpin" => Transport::Tcp,
        "udpin" => Transport::Udp,
        _ => return Err(bad()),
    };
    let addr: SocketAddr = rest.parse().map_err(|_| bad())?;
    Ok((transport, addr))
}

struct Shared {
    vehicles: Mutex<Vec<Vehicle>>,
    stop: AtomicBool,
    connected: AtomicBool,
}

impl Shared {
    fn vehicles(&self) -> MutexGuard<'_, Vec<Vehicle>> {
        match self.vehicles.lock() {
            Ok(v) => v,
            Err(poisoned) => poisoned.into_inner(),
        }
    }

    /// Runs `f` on the vehicle of system `system`, if there is one.
    fn with<T>(&self, system: u8, f: impl FnOnce(&mut Vehicle) -> T) -> Option<T> {
        self.vehicles()
            .iter_mut()
            .find(|v| v.system_id() == system)
            .map(f)
    }
}

/// Several simulated vehicles on one link, on their own thread, behind
/// one socket; each is addressed by its MAVLink system id. Stops when
/// dropped.
pub struct Fleet {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
    local_addr: SocketAddr,
    transport: Transport,
    systems: Vec<u8>,
}

/// A running simulation: one vehicle on its own thread, behind a socket.
/// Stops when dropped.
pub struct Sim {
    fleet: Fleet,
    system: u8,
}

impl Sim {
    /// Binds the socket and starts the simulation thread. As ArduPilot SITL,
    /// the vehicle boots when the first client connects (TCP) or the first
    /// datagram arrives (UDP): sim time 0 is that moment.
    pub fn start(cfg: SimConfig) -> Result<Sim, SimError> {
        let system = cfg.system_id;
        let listen = cfg.listen.clone();
        let speedup = cfg.speedup;
        Ok(Sim {
            fleet: Fleet::start(&listen, speedup, vec![cfg])?,
            system,
        })
    }

    /// The bound address.
    pub fn local_addr(&self) -> SocketAddr {
        self.fleet.local_addr()
    }

    /// The rust-mavlink address a client (the gateway) connects with:
    /// `tcpout:127.0.0.1:PORT` or `udpout:127.0.0.1:PORT`.
    pub fn client_address(&self) -> String {
        self.fleet.client_address()
    }

    /// A snapshot of the simulated truth.
    pub fn state(&self) -> SimState {
        self.fleet.state(self.system).unwrap_or_default()
    }

    /// Whether a client is connected (TCP) or has spoken (UDP).
    pub fn connected(&self) -> bool {
        self.fleet.connected()
    }

    /// Injects a fault at once; it stays until [`Sim::clear`].
    pub fn inject(&self, fault: Fault) {
        self.fleet.inject(self.system, fault);
    }

    /// Injects a fault at once for `duration_s` sim seconds.
    pub fn inject_for(&self, fault: Fault, duration_s: f64) {
        self.fleet.inject_for(self.system, fault, duration_s);
    }

    /// Ends the active faults of a kind.
    pub fn clear(&self, kind: FaultKind) {
        self.fleet.clear(self.system, kind);
    }

    /// Waits (at most `timeout` of wall time) until the state satisfies
    /// `cond`; returns the state that did, or `None` on timeout.
    pub fn wait_for(
        &self,
        timeout: Duration,
        cond: impl Fn(&SimState) -> bool,
    ) -> Option<SimState> {
        let system = self.system;
        self.fleet
            .wait_for(timeout, |all| {
                all.iter().any(|(sys, s)| *sys == system && cond(s))
            })
            .and_then(|all| all.into_iter().find(|(sys, _)| *sys == system))
            .map(|(_, s)| s)
    }

    /// Stops the simulation and waits for its thread.
    pub fn stop(self) {
        self.fleet.stop();
    }
}

impl Fleet {
    /// Binds `listen` and starts the vehicles (their `listen` and
    /// `speedup` are not read: the fleet's are). Every vehicle boots when
    /// the first client connects (TCP) or the first datagram arrives (UDP).
    pub fn start(listen: &str, speedup: f64, vehicles: Vec<SimConfig>) -> Result<Fleet, SimError> {
        if !(speedup.is_finite() && speedup > 0.0) {
            return Err(SimError::BadSpeedup(speedup));
        }
        if vehicles.is_empty() {
            return Err(SimError::NoVehicle);
        }
        let mut systems: Vec<u8> = Vec::new();
        for v in &vehicles {
            if systems.contains(&v.system_id) {
                return Err(SimError::SameSystem(v.system_id));
            }
            systems.push(v.system_id);
        }
        let (transport, addr) = parse_listen(listen)?;
        let listen_err = |source| SimError::Listen {
            address: listen.to_owned(),
            source,
        };
        let socket = match transport {
            Transport::Tcp => {
                let l = TcpListener::bind(addr).map_err(listen_err)?;
                l.set_nonblocking(true).map_err(listen_err)?;
                Socket::Tcp {
                    listener: l,
                    client: None,
                    buf: Vec::new(),
                }
            }
            Transport::Udp => {
                let s = UdpSocket::bind(addr).map_err(listen_err)?;
                s.set_nonblocking(true).map_err(listen_err)?;
                Socket::Udp {
                    socket: s,
                    peer: None,
                }
            }
        };
        let local_addr = socket.local_addr().map_err(listen_err)?;
        let clock = SimClock::new(speedup);
        let kinds: Vec<String> = vehicles
            .iter()
            .map(|c| format!("{:?}:{}", c.firmware, c.system_id))
            .collect();
        let shared = Arc::new(Shared {
            vehicles: Mutex::new(vehicles.into_iter().map(Vehicle::new).collect()),
            stop: AtomicBool::new(false),
            connected: AtomicBool::new(false),
        });
        let s = shared.clone();
        let thread = std::thread::Builder::new()
            .name("petrel-sim".to_owned())
            .spawn(move || run(s, socket, clock))
            .map_err(SimError::Thread)?;
        tracing::info!(%local_addr, vehicles = ?kinds, "simulated vehicles listening");
        Ok(Fleet {
            shared,
            thread: Some(thread),
            local_addr,
            transport,
            systems,
        })
    }

    /// The vehicles' system ids, in the order they were given.
    pub fn systems(&self) -> &[u8] {
        &self.systems
    }

    /// The bound address.
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }

    /// The rust-mavlink address a client (the gateway) connects with:
    /// `tcpout:127.0.0.1:PORT` or `udpout:127.0.0.1:PORT`.
    pub fn client_address(&self) -> String {
        let kind = match self.transport {
            Transport::Tcp => "tcpout",
            Transport::Udp => "udpout",
        };
        format!("{kind}:{}", self.local_addr)
    }

    /// A snapshot of the simulated truth of the vehicle of system
    /// `system` (`None`: no such vehicle).
    pub fn state(&self, system: u8) -> Option<SimState> {
        self.shared.with(system, |v| v.state())
    }

    /// The truth of every vehicle at one instant: (system id, state), in
    /// the fleet's order.
    pub fn states(&self) -> Vec<(u8, SimState)> {
        self.shared
            .vehicles()
            .iter()
            .map(|v| (v.system_id(), v.state()))
            .collect()
    }

    /// Whether a client is connected (TCP) or has spoken (UDP).
    pub fn connected(&self) -> bool {
        self.shared.connected.load(Ordering::Relaxed)
    }

    /// Injects a fault into one vehicle at once; it stays until
    /// [`Fleet::clear`]. False when there is no such vehicle.
    pub fn inject(&self, system: u8, fault: Fault) -> bool {
        self.shared.with(system, |v| v.inject(fault)).is_some()
    }

    /// Injects a fault into one vehicle for `duration_s` sim seconds.
    pub fn inject_for(&self, system: u8, fault: Fault, duration_s: f64) -> bool {
        self.shared
            .with(system, |v| v.inject_for(fault, duration_s))
            .is_some()
    }

    /// Ends one vehicle's active faults of a kind.
    pub fn clear(&self, system: u8, kind: FaultKind) -> bool {
        self.shared.with(system, |v| v.clear(kind)).is_some()
    }

    /// Waits (at most `timeout` of wall time) until the states of the
    /// vehicles ([`Fleet::states`]) satisfy `cond`; returns them, or
    /// `None` on timeout.
    pub fn wait_for(
        &self,
        timeout: Duration,
        cond: impl Fn(&[(u8, SimState)]) -> bool,
    ) -> Option<Vec<(u8, SimState)>> {
        let end = Instant::now() + timeout;
        loop {
            let s = self.states();
            if cond(&s) {
                return Some(s);
            }
            if Instant::now() >= end || self.thread.as_ref().is_none_or(|t| t.is_finished()) {
                return None;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    }

    /// Stops the simulation and waits for its thread.
    pub fn stop(mut self) {
        self.halt();
    }

    fn halt(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Fleet {
    fn drop(&mut self) {
        self.halt();
    }
}

enum Socket {
    Tcp {
        listener: TcpListener,
        client: Option<TcpStream>,
        buf: Vec<u8>,
    },
    Udp {
        socket: UdpSocket,
        peer: Option<SocketAddr>,
    },
}

impl Socket {
    fn local_addr(&self) -> std::io::Result<SocketAddr> {
        match self {
            Socket::Tcp { listener, .. } => listener.local_addr(),
            Socket::Udp { socket, .. } => socket.local_addr(),
        }
    }

    fn connected(&self) -> bool {
        match self {
            Socket::Tcp { client, .. } => client.is_some(),
            Socket::Udp { peer, .. } => peer.is_some(),
        }
    }

    /// Reads what has arrived (never blocks).
    fn receive(&mut self, out: &mut Vec<(MavHeader, MavMessage)>) {
        match self {
            Socket::Tcp {
                listener,
                client,
                buf,
            } => {
                if client.is_none() {
                    match listener.accept() {
                        Ok((stream, peer)) => {
                            tracing::info!(%peer, "client connected");
                            let _ = stream.set_nodelay(true);
                            if stream.set_nonblocking(true).is_ok() {
                                *client = Some(stream);
                                buf.clear();
                            }
                        }
                        Err(e) if e.kind() == ErrorKind::WouldBlock => {}
                        Err(e) => tracing::warn!(error = %e, "accept failed"),
                    }
                }
                let Some(stream) = client.as_mut() else {
                    return;
                };
                let mut chunk = [0u8; 4096];
                loop {
                    match stream.read(&mut chunk) {
                        Ok(0) => {
                            tracing::info!("client disconnected");
                            *client = None;
                            break;
                        }
                        Ok(n) => buf.extend_from_slice(&chunk[..n]),
                        Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                        Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                        Err(e) => {
                            tracing::info!(error = %e, "client lost");
                            *client = None;
                            break;
                        }
                    }
                }
                parse_frames(buf, out);
            }
            Socket::Udp { socket, peer } => {
                let mut datagram = [0u8; 65536];
                loop {
                    match socket.recv_from(&mut datagram) {
                        Ok((n, from)) => {
                            if *peer != Some(from) {
                                tracing::info!(%from, "UDP peer");
                            }
                            *peer = Some(from);
                            let mut buf = datagram[..n].to_vec();
                            parse_frames(&mut buf, out);
                        }
                        Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                        Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                        // ICMP port unreachable from a peer gone: keep listening.
                        Err(_) => break,
                    }
                }
            }
        }
    }

    /// Sends one frame (dropped when nobody listens).
    fn send(&mut self, bytes: &[u8]) {
        match self {
            Socket::Tcp { client, .. } => {
                let Some(stream) = client.as_mut() else {
                    return;
                };
                if let Err(e) = write_all(stream, bytes) {
                    tracing::info!(error = %e, "client lost while sending");
                    *client = None;
                }
            }
            Socket::Udp { socket, peer } => {
                if let Some(p) = peer {
                    let _ = socket.send_to(bytes, *p);
                }
            }
        }
    }
}

/// `write_all` on a non-blocking stream: waits out WouldBlock briefly.
fn write_all(stream: &mut TcpStream, mut bytes: &[u8]) -> std::io::Result<()> {
    let deadline = Instant::now() + Duration::from_secs(2);
    while !bytes.is_empty() {
        match stream.write(bytes) {
            Ok(0) => return Err(ErrorKind::WriteZero.into()),
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                if Instant::now() > deadline {
                    return Err(ErrorKind::TimedOut.into());
                }
                std::thread::sleep(Duration::from_micros(200));
            }
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// The link faults on the wire (faults.rs: `garbage`, `duplicate`,
/// `reorder`), applied to the frames the vehicle sends.
struct Wire {
    /// A frame held back to go out after the next one (reorder).
    held: Option<Vec<u8>>,
    /// xorshift state for the garbage.
    rng: u64,
}

impl Default for Wire {
    fn default() -> Wire {
        Wire {
            held: None,
            rng: 0x9e37_79b9_7f4a_7c15,
        }
    }
}

impl Wire {
    fn send(&mut self, socket: &mut Socket, bytes: Vec<u8>, faults: WireFaults) {
        let copies = if faults.duplicate { 2 } else { 1 };
        let mut out = |frame: &[u8]| {
            for _ in 0..copies {
                socket.send(frame);
            }
        };
        if !faults.reorder {
            out(&bytes);
            return;
        }
        match self.held.take() {
            Some(first) => {
                out(&bytes);
                out(&first);
            }
            None => self.held = Some(bytes),
        }
    }

    /// After a round of frames: the garbage due, and a frame held back when
    /// reordering has ended.
    fn end(&mut self, socket: &mut Socket, faults: WireFaults) {
        if !faults.reorder {
            if let Some(held) = self.held.take() {
                socket.send(&held);
            }
        }
        if faults.garbage > 0 {
            let mut burst = Vec::with_capacity(faults.garbage);
            while burst.len() < faults.garbage {
                self.rng ^= self.rng << 13;
                self.rng ^= self.rng >> 7;
                self.rng ^= self.rng << 17;
                burst.extend_from_slice(&self.rng.to_le_bytes());
            }
            burst.truncate(faults.garbage);
            socket.send(&burst);
        }
    }
}

/// The simulation thread.
fn run(shared: Arc<Shared>, mut socket: Socket, mut clock: SimClock) {
    let mut incoming = Vec::new();
    let mut wires: Vec<Wire> = Vec::new();
    while !shared.stop.load(Ordering::Relaxed) {
        socket.receive(&mut incoming);
        let connected = socket.connected();
        shared.connected.store(connected, Ordering::Relaxed);
        if connected && !clock.started() {
            // The vehicle boots when its first client arrives, as SITL waits.
            clock.start();
        }
        let wait = {
            let mut vehicles = shared.vehicles();
            wires.resize_with(vehicles.len(), Wire::default);
            let now = clock.now_us();
            for (header, msg) in incoming.drain(..) {
                for v in vehicles.iter_mut() {
                    v.handle(now, &header, &msg);
                }
            }
            let mut next = u64::MAX;
            for (v, wire) in vehicles.iter_mut().zip(wires.iter_mut()) {
                if clock.started() {
                    v.advance(clock.now_us());
                }
                let faults = v.take_wire_faults();
                while let Some((header, msg)) = v.poll_transmit() {
                    let bytes = elaboration::frame::serialize(header, MavlinkVersion::V2, &msg);
                    wire.send(&mut socket, bytes, faults);
                }
                wire.end(&mut socket, faults);
                next = next.min(v.next_deadline());
            }
            clock.wall_until(next)
        };
        let nap = if clock.started() {
            wait.clamp(Duration::from_micros(100), Duration::from_millis(2))
        } else {
            Duration::from_millis(2)
        };
        std::thread::sleep(nap);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geo::{location, Home, V2};
    use crate::wire::{command_long, frame, parse_frames};
    use mavlink::dialects::ardupilotmega::{MavCmd, MavResult, MavType};

    /// A ground station on the fleet's one UDP link.
    struct Station {
        socket: UdpSocket,
        to: SocketAddr,
        buf: Vec<(MavHeader, MavMessage)>,
    }

    impl Station {
        fn new(to: SocketAddr) -> Station {
            let socket = UdpSocket::bind("127.0.0.1:0").expect("a local port");
            socket
                .set_read_timeout(Some(Duration::from_millis(20)))
                .expect("a timeout");
            Station {
                socket,
                to,
                buf: Vec::new(),
            }
        }

        fn send(&self, msg: &MavMessage) {
            let h = MavHeader {
                system_id: 255,
                component_id: 190,
                sequence: 0,
            };
            self.socket.send_to(&frame(h, msg), self.to).expect("sent");
        }

        /// Reads for `wall` of wall time.
        fn read(&mut self, wall: Duration) {
            let end = Instant::now() + wall;
            let mut datagram = [0u8; 65536];
            while Instant::now() < end {
                if let Ok((n, _)) = self.socket.recv_from(&mut datagram) {
                    let mut b = datagram[..n].to_vec();
                    parse_frames(&mut b, &mut self.buf);
                }
            }
        }

        /// Sends a command and waits for its ack from `system`.
        fn command(&mut self, system: u8, cmd: MavCmd, p: [f32; 7]) -> Option<MavResult> {
            self.buf.clear();
            self.send(&command_long((system, 1), cmd, p));
            for _ in 0..50 {
                self.read(Duration::from_millis(20));
                let ack = self.buf.iter().find_map(|(h, m)| match m {
                    MavMessage::COMMAND_ACK(a)
                        if h.system_id == system as u32 && a.command == cmd =>
                    {
                        Some(a.result)
                    }
                    _ => None,
                });
                if ack.is_some() {
                    return ack;
                }
            }
            None
        }
    }

    fn rover(system: u8) -> SimConfig {
        SimConfig {
            boot: crate::boot::BootTimeline::quick(),
            first_arm_refused: false,
            ..SimConfig::rover(system, Home::default())
        }
    }

    #[test]
    fn a_fleet_on_one_link_obeys_by_system_id() {
        assert!(matches!(
            Fleet::start("udpin:127.0.0.1:0", 10.0, vec![rover(1), rover(1)]),
            Err(SimError::SameSystem(1))
        ));
        assert!(matches!(
            Fleet::start("udpin:127.0.0.1:0", 10.0, vec![]),
            Err(SimError::NoVehicle)
        ));
        let fleet =
            Fleet::start("udpin:127.0.0.1:0", 20.0, vec![rover(1), rover(2)]).expect("a fleet");
        assert_eq!(fleet.systems(), &[1, 2]);
        let mut gcs = Station::new(fleet.local_addr());
        // The first datagram boots both.
        gcs.send(&MavMessage::HEARTBEAT(Default::default()));
        assert!(fleet
            .wait_for(Duration::from_secs(5), |all| all
                .iter()
                .all(|(_, s)| s.time_s > 4.0))
            .is_some());
        gcs.read(Duration::from_millis(200));
        for sys in [1u32, 2] {
            assert!(
                gcs.buf.iter().any(|(h, m)| h.system_id == sys
                    && matches!(m, MavMessage::HEARTBEAT(hb) if hb.mavtype == MavType::MAV_TYPE_GROUND_ROVER)),
                "no heartbeat of system {sys}"
            );
        }
        // Only rover 2 is told to go: GUIDED, armed, 20 m east.
        let guided = [1.0, 15.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(
            gcs.command(2, MavCmd::MAV_CMD_DO_SET_MODE, guided),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let arm = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(
            gcs.command(2, MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let (lat, lon) = location(&Home::default(), V2::new(0.0, 20.0));
        let go = [-1.0, 1.0, 0.0, 0.0, lat as f32, lon as f32, 0.0];
        assert_eq!(
            gcs.command(2, MavCmd::MAV_CMD_DO_REPOSITION, go),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let all = fleet
            .wait_for(Duration::from_secs(10), |all| {
                all.iter()
                    .any(|(sys, s)| *sys == 2 && !s.reached.is_empty())
            })
            .expect("rover 2 arrives");
        let (one, two) = (&all[0].1, &all[1].1);
        assert!((two.east - 20.0).abs() < 3.0, "{}", two.east);
        assert!(one.east.abs() < 1e-9 && !one.armed && one.mode == "MANUAL");
        assert!(one.commands.is_empty(), "{:?}", one.commands);
        // A fault in one vehicle only.
        assert!(fleet.inject(1, Fault::Stuck));
        assert!(!fleet.inject(3, Fault::Stuck));
        let s = fleet.states();
        assert_eq!(s[0].1.faults.len(), 1);
        assert!(s[1].1.faults.is_empty());
        fleet.stop();
    }

    #[test]
    fn addresses() {
        assert!(matches!(
            parse_listen("tcpin:127.0.0.1:0"),
            Ok((Transport::Tcp, _))
        ));
        assert!(matches!(
            parse_listen("udpin:127.0.0.1:14550"),
            Ok((Transport::Udp, _))
        ));
        for bad in [
            "tcp:127.0.0.1:1",
            "tcpin:localhost",
            "udpin:1.2.3.4",
            "nothing",
        ] {
            assert!(
                matches!(parse_listen(bad), Err(SimError::BadAddress(_))),
                "{bad}"
            );
        }
    }
}
