//! The I/O around the vehicle: a thread owning the socket and the sim
//! clock, feeding the [`Vehicle`] what arrives and sending what it polls.
//! `tcpin:` serves one client at a time and accepts again after it leaves,
//! as ArduPilot SITL's TCP port; `udpin:` answers the last sender.

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
    vehicle: Mutex<Vehicle>,
    stop: AtomicBool,
    connected: AtomicBool,
}

impl Shared {
    fn vehicle(&self) -> MutexGuard<'_, Vehicle> {
        match self.vehicle.lock() {
            Ok(v) => v,
            Err(poisoned) => poisoned.into_inner(),
        }
    }
}

/// A running simulation: the vehicle on its own thread, behind a socket.
/// Stops when dropped.
pub struct Sim {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
    local_addr: SocketAddr,
    transport: Transport,
}

impl Sim {
    /// Binds the socket and starts the simulation thread. As ArduPilot SITL,
    /// the vehicle boots when the first client connects (TCP) or the first
    /// datagram arrives (UDP): sim time 0 is that moment.
    pub fn start(cfg: SimConfig) -> Result<Sim, SimError> {
        if !(cfg.speedup.is_finite() && cfg.speedup > 0.0) {
            return Err(SimError::BadSpeedup(cfg.speedup));
        }
        let (transport, addr) = parse_listen(&cfg.listen)?;
        let listen_err = |source| SimError::Listen {
            address: cfg.listen.clone(),
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
        let clock = SimClock::new(cfg.speedup);
        let shared = Arc::new(Shared {
            vehicle: Mutex::new(Vehicle::new(cfg)),
            stop: AtomicBool::new(false),
            connected: AtomicBool::new(false),
        });
        let s = shared.clone();
        let thread = std::thread::Builder::new()
            .name("petrel-sim".to_owned())
            .spawn(move || run(s, socket, clock))
            .map_err(SimError::Thread)?;
        tracing::info!(%local_addr, "simulated ArduPlane listening");
        Ok(Sim {
            shared,
            thread: Some(thread),
            local_addr,
            transport,
        })
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

    /// A snapshot of the simulated truth.
    pub fn state(&self) -> SimState {
        self.shared.vehicle().state()
    }

    /// Whether a client is connected (TCP) or has spoken (UDP).
    pub fn connected(&self) -> bool {
        self.shared.connected.load(Ordering::Relaxed)
    }

    /// Injects a fault at once; it stays until [`Sim::clear`].
    pub fn inject(&self, fault: Fault) {
        self.shared.vehicle().inject(fault);
    }

    /// Injects a fault at once for `duration_s` sim seconds.
    pub fn inject_for(&self, fault: Fault, duration_s: f64) {
        self.shared.vehicle().inject_for(fault, duration_s);
    }

    /// Ends the active faults of a kind.
    pub fn clear(&self, kind: FaultKind) {
        self.shared.vehicle().clear(kind);
    }

    /// Waits (at most `timeout` of wall time) until the state satisfies
    /// `cond`; returns the state that did, or `None` on timeout.
    pub fn wait_for(
        &self,
        timeout: Duration,
        cond: impl Fn(&SimState) -> bool,
    ) -> Option<SimState> {
        let end = Instant::now() + timeout;
        loop {
            let s = self.state();
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

impl Drop for Sim {
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
    let mut wire = Wire::default();
    while !shared.stop.load(Ordering::Relaxed) {
        socket.receive(&mut incoming);
        let connected = socket.connected();
        shared.connected.store(connected, Ordering::Relaxed);
        if connected && !clock.started() {
            // The vehicle boots when its first client arrives, as SITL waits.
            clock.start();
        }
        let wait = {
            let mut v = shared.vehicle();
            let now = clock.now_us();
            for (header, msg) in incoming.drain(..) {
                v.handle(now, &header, &msg);
            }
            if clock.started() {
                v.advance(clock.now_us());
            }
            let faults = v.take_wire_faults();
            while let Some((header, msg)) = v.poll_transmit() {
                let bytes = elaboration::frame::serialize(header, MavlinkVersion::V2, &msg);
                wire.send(&mut socket, bytes, faults);
            }
            wire.end(&mut socket, faults);
            clock.wall_until(v.next_deadline())
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
