//! The camera on its own, running: a thread owning a TCP client to one of
//! the autopilot's serial ports (ArduPilot SITL's SERIAL1 or SERIAL2) and
//! the camera's clock, around a [`CameraComponent`]. The autopilot then
//! routes to it the commands addressed to component 100, as it would to a
//! camera on a real serial port. The link is opened again when it breaks;
//! the thread stops and is joined on drop.

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::camera_component::{CameraComponent, CameraConfig, CameraState};
use crate::clock::SimClock;
use crate::faults::PayloadFailure;
use crate::wire;

/// Why the camera could not start.
#[derive(Debug, thiserror::Error)]
pub enum CameraSimError {
    #[error("bad camera link address `{0}`: expected tcpout:IP:PORT or IP:PORT")]
    BadAddress(String),
    #[error("bad speedup {0}: expected a finite number above 0")]
    BadSpeedup(f64),
    #[error("cannot start the camera thread: {0}")]
    Thread(std::io::Error),
}

/// `tcpout:IP:PORT` (as [`crate::ardupilot::Sitl::address`] gives it) or
/// `IP:PORT`.
fn parse_address(address: &str) -> Result<SocketAddr, CameraSimError> {
    let rest = address.strip_prefix("tcpout:").unwrap_or(address);
    rest.parse()
        .map_err(|_| CameraSimError::BadAddress(address.to_owned()))
}

struct Shared {
    camera: Mutex<CameraComponent>,
    stop: AtomicBool,
    connected: AtomicBool,
}

impl Shared {
    fn camera(&self) -> MutexGuard<'_, CameraComponent> {
        match self.camera.lock() {
            Ok(c) => c,
            Err(poisoned) => poisoned.into_inner(),
        }
    }
}

/// A camera running on its own link. Stops when dropped.
pub struct CameraSim {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
    address: SocketAddr,
}

impl CameraSim {
    /// Powers the camera on (its time 0 is now) and starts its thread, which
    /// connects to `address` and keeps connecting (every 100 ms) until the
    /// port accepts, and again whenever the link breaks.
    pub fn start(address: &str, cfg: CameraConfig) -> Result<CameraSim, CameraSimError> {
        if !(cfg.speedup.is_finite() && cfg.speedup > 0.0) {
            return Err(CameraSimError::BadSpeedup(cfg.speedup));
        }
        let addr = parse_address(address)?;
        let mut clock = SimClock::new(cfg.speedup);
        clock.start();
        let shared = Arc::new(Shared {
            camera: Mutex::new(CameraComponent::new(cfg)),
            stop: AtomicBool::new(false),
            connected: AtomicBool::new(false),
        });
        let s = shared.clone();
        let thread = std::thread::Builder::new()
            .name("petrel-camera".to_owned())
            .spawn(move || run(s, addr, clock))
            .map_err(CameraSimError::Thread)?;
        Ok(CameraSim {
            shared,
            thread: Some(thread),
            address: addr,
        })
    }

    /// The address it connects to.
    pub fn address(&self) -> SocketAddr {
        self.address
    }

    /// Whether the link is up.
    pub fn connected(&self) -> bool {
        self.shared.connected.load(Ordering::Relaxed)
    }

    /// A snapshot: commands heard with their answers, captures, images, the
    /// position heard, the failure injected.
    pub fn state(&self) -> CameraState {
        let mut s = self.shared.camera().state();
        s.connected = self.connected();
        s
    }

    /// A payload failure, at once, until [`CameraSim::clear`].
    pub fn inject(&self, failure: PayloadFailure) {
        self.shared.camera().inject(Some(failure));
    }

    /// Ends the payload failure.
    pub fn clear(&self) {
        self.shared.camera().inject(None);
    }

    /// Waits (at most `timeout` of wall time) until the state satisfies
    /// `cond`; returns the state that did, or `None` on timeout.
    pub fn wait_for(
        &self,
        timeout: Duration,
        cond: impl Fn(&CameraState) -> bool,
    ) -> Option<CameraState> {
        let end = Instant::now() + timeout;
        loop {
            let s = self.state();
            if cond(&s) {
                return Some(s);
            }
            if Instant::now() >= end || self.thread.as_ref().is_none_or(|t| t.is_finished()) {
                return None;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Stops the camera and waits for its thread.
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

impl Drop for CameraSim {
    fn drop(&mut self) {
        self.halt();
    }
}

/// Connects within 200 ms, non-blocking once connected.
fn connect(addr: SocketAddr) -> Option<TcpStream> {
    let stream = TcpStream::connect_timeout(&addr, Duration::from_millis(200)).ok()?;
    let _ = stream.set_nodelay(true);
    stream.set_nonblocking(true).ok()?;
    tracing::info!(%addr, "camera connected");
    Some(stream)
}

/// `write_all` on a non-blocking stream: waits out WouldBlock for at most 2 s.
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

/// The camera's thread.
fn run(shared: Arc<Shared>, addr: SocketAddr, clock: SimClock) {
    let mut link: Option<TcpStream> = None;
    let mut next_try = Instant::now();
    let mut buf = Vec::new();
    let mut incoming = Vec::new();
    while !shared.stop.load(Ordering::Relaxed) {
        if link.is_none() && Instant::now() >= next_try {
            link = connect(addr);
            buf.clear();
            next_try = Instant::now() + Duration::from_millis(100);
        }
        if let Some(stream) = link.as_mut() {
            let mut chunk = [0u8; 4096];
            loop {
                match stream.read(&mut chunk) {
                    Ok(0) => {
                        tracing::info!("camera link closed");
                        link = None;
                        break;
                    }
                    Ok(n) => buf.extend_from_slice(&chunk[..n]),
                    Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                    Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                    Err(e) => {
                        tracing::info!(error = %e, "camera link lost");
                        link = None;
                        break;
                    }
                }
            }
            wire::parse_frames(&mut buf, &mut incoming);
        }
        shared.connected.store(link.is_some(), Ordering::Relaxed);
        let wait = {
            let mut c = shared.camera();
            let now = clock.now_us();
            for (header, msg) in incoming.drain(..) {
                c.handle(now, &header, &msg);
            }
            c.advance(clock.now_us());
            while let Some((header, msg)) = c.poll_transmit() {
                // Nobody listens while the link is down: dropped, as on a wire.
                if let Some(stream) = link.as_mut() {
                    if let Err(e) = write_all(stream, &wire::frame(header, &msg)) {
                        tracing::info!(error = %e, "camera link lost while sending");
                        link = None;
                    }
                }
            }
            clock.wall_until(c.next_deadline())
        };
        std::thread::sleep(wait.clamp(Duration::from_micros(200), Duration::from_millis(2)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::*;
    use mavlink::MavHeader;
    use std::net::TcpListener;

    #[test]
    fn addresses() {
        assert!(parse_address("tcpout:127.0.0.1:5842").is_ok());
        assert!(parse_address("127.0.0.1:5842").is_ok());
        for bad in ["udpout:127.0.0.1:1", "tcpout:localhost", "nothing"] {
            assert!(
                matches!(parse_address(bad), Err(CameraSimError::BadAddress(_))),
                "{bad}"
            );
        }
        assert!(matches!(
            CameraSim::start(
                "127.0.0.1:1",
                CameraConfig {
                    speedup: 0.0,
                    ..CameraConfig::default()
                }
            ),
            Err(CameraSimError::BadSpeedup(_))
        ));
    }

    /// Over loopback: it connects when the port listens, beats, answers a
    /// command, and its thread ends on drop.
    #[test]
    fn connects_answers_and_stops() {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let cam = CameraSim::start(
            &format!("tcpout:{addr}"),
            CameraConfig {
                speedup: 10.0,
                ..CameraConfig::default()
            },
        )
        .unwrap();
        // Accepting, bounded: the camera connects within 5 s.
        listener.set_nonblocking(true).unwrap();
        let accept_by = Instant::now() + Duration::from_secs(5);
        let mut peer = loop {
            match listener.accept() {
                Ok((peer, _)) => break peer,
                Err(e) if e.kind() == ErrorKind::WouldBlock && Instant::now() < accept_by => {
                    std::thread::sleep(Duration::from_millis(10));
                }
                Err(e) => panic!("the camera did not connect: {e}"),
            }
        };
        peer.set_nonblocking(false).unwrap();
        peer.set_read_timeout(Some(Duration::from_millis(100)))
            .unwrap();
        let cmd = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param2: 1.0,
            command: MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
            target_system: 1,
            target_component: 100,
            ..Default::default()
        });
        let h = MavHeader {
            system_id: 1,
            component_id: 191,
            sequence: 0,
        };
        peer.write_all(&wire::frame(h, &cmd)).unwrap();
        let mut got = Vec::new();
        let mut buf = Vec::new();
        let end = Instant::now() + Duration::from_secs(10);
        while Instant::now() < end
            && !got
                .iter()
                .any(|(_, m)| matches!(m, MavMessage::COMMAND_ACK(_)))
        {
            let mut chunk = [0u8; 1024];
            if let Ok(n) = peer.read(&mut chunk) {
                buf.extend_from_slice(&chunk[..n]);
                wire::parse_frames(&mut buf, &mut got);
            }
        }
        assert!(
            got.iter().any(|(h, m)| h.component_id == 100
                && matches!(m, MavMessage::COMMAND_ACK(a) if a.result == MavResult::MAV_RESULT_ACCEPTED)),
            "{got:?}"
        );
        let s = cam
            .wait_for(Duration::from_secs(5), |s| s.images >= 2)
            .expect("images every sim second");
        assert!(s.connected);
        assert_eq!(s.results_of(2000), vec![Some(0)]);
        cam.stop();
    }
}
