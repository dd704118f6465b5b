//! The programs a deployment puts between the autopilot and Petrel, as
//! test peers: MAVProxy as a router, a `socat` pseudo-terminal pair as the
//! serial cable, and a client that keeps ArduPilot SITL's SERIAL0 busy.
//! Each is reaped on drop, even when a test panics.

use std::io::{Read, Write};
use std::net::{Shutdown, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::MavMessage;
use sitl_tests::ardupilot;

/// `name` on the PATH, or `None` after printing why `test` is skipped;
/// panics under `CI=true`, where a missing peer is a failure.
pub fn require_program(name: &str, test: &str, install: &str) -> Option<PathBuf> {
    let found = std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|dir| dir.join(name))
            .find(|p| p.is_file())
    });
    match found {
        Some(p) => Some(p),
        None if ardupilot::in_ci() => {
            panic!("{test}: {name} is required in CI ({install})")
        }
        None => {
            sitl_tests::skip::skip(&format!("{name} is not on the PATH ({install})"));
            None
        }
    }
}

/// A child process, killed and reaped on drop.
pub struct Peer {
    name: &'static str,
    child: Option<Child>,
}

impl Peer {
    fn spawn(name: &'static str, mut command: Command, log: &Path) -> Peer {
        let out = std::fs::File::create(log).expect("peer log");
        let err = out.try_clone().expect("peer log");
        let child = command
            .stdin(Stdio::null())
            .stdout(Stdio::from(out))
            .stderr(Stdio::from(err))
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {name}: {e}"));
        Peer {
            name,
            child: Some(child),
        }
    }

    /// Panics with `log` if the process has exited.
    pub fn assert_running(&mut self, log: &Path) {
        if let Some(c) = self.child.as_mut() {
            if let Ok(Some(status)) = c.try_wait() {
                panic!(
                    "{} exited ({status}):\n{}",
                    self.name,
                    std::fs::read_to_string(log).unwrap_or_default()
                );
            }
        }
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// MAVProxy as a router: `--master` on SITL's SERIAL0 (it is that port's
/// one client, which starts the simulation), `--out udp:` to Petrel. No
/// console, no map, no shell, no files; it asks for no streams itself
/// (`--streamrate -1`), so the telemetry Petrel gets is what Petrel asked
/// for through the router.
/// Its output goes to `log`.
pub fn mavproxy(program: &Path, master_port: u16, out_port: u16, log: &Path) -> Peer {
    let mut c = Command::new(program);
    if let Some(dir) = log.parent() {
        c.current_dir(dir);
    }
    c.arg(format!("--master=tcp:127.0.0.1:{master_port}"))
        .arg(format!("--out=udp:127.0.0.1:{out_port}"))
        .args(["--non-interactive", "--no-state", "--streamrate=-1"]);
    Peer::spawn("MAVProxy", c, log)
}

/// A pseudo-terminal pair made by socat: what one end writes the other
/// reads, as over a UART cable. `autopilot` and `companion` are symbolic
/// links to the two `/dev/pts/N`.
pub struct PtyPair {
    pub autopilot: PathBuf,
    pub companion: PathBuf,
    _socat: Peer,
}

impl PtyPair {
    pub fn open(program: &Path, dir: &Path) -> PtyPair {
        let autopilot = dir.join("autopilot-uart");
        let companion = dir.join("companion-uart");
        let mut c = Command::new(program);
        c.arg(format!("pty,raw,echo=0,link={}", autopilot.display()))
            .arg(format!("pty,raw,echo=0,link={}", companion.display()));
        let log = dir.join("socat.log");
        let mut socat = Peer::spawn("socat", c, &log);
        let started = Instant::now();
        while !(autopilot.exists() && companion.exists()) {
            socat.assert_running(&log);
            assert!(
                started.elapsed() < Duration::from_secs(5),
                "socat made no pseudo-terminals within 5 s"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        PtyPair {
            autopilot,
            companion,
            _socat: socat,
        }
    }
}

/// A USB-serial adapter that can be pulled out and plugged in again: socat
/// between a SITL serial port (TCP) and a pseudo-terminal whose symbolic
/// link `device` stays the same across plugs, as `/dev/ttyUSB0` does.
pub struct UsbSerial {
    program: PathBuf,
    port: u16,
    pub device: PathBuf,
    dir: PathBuf,
    socat: Option<Peer>,
}

impl UsbSerial {
    pub fn plugged(program: &Path, port: u16, dir: &Path) -> UsbSerial {
        let mut usb = UsbSerial {
            program: program.to_owned(),
            port,
            device: dir.join("ttyUSB0"),
            dir: dir.to_owned(),
            socat: None,
        };
        usb.plug();
        usb
    }

    /// Plugs it in: the device appears (at most 5 s).
    pub fn plug(&mut self) {
        assert!(self.socat.is_none(), "already plugged in");
        let mut c = Command::new(&self.program);
        // SITL listens on SERIAL1 only once SERIAL0 has its client: retry.
        c.arg(format!(
            "TCP:127.0.0.1:{},retry=40,interval=0.25",
            self.port
        ))
        .arg(format!("pty,raw,echo=0,link={}", self.device.display()));
        let log = self.dir.join("usb-socat.log");
        let mut socat = Peer::spawn("socat", c, &log);
        let started = Instant::now();
        while !self.device.exists() {
            socat.assert_running(&log);
            assert!(
                started.elapsed() < Duration::from_secs(5),
                "socat made no pseudo-terminal within 5 s"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        self.socat = Some(socat);
    }

    /// Pulls it out: the device goes away.
    pub fn pull(&mut self) {
        self.socat = None;
        let started = Instant::now();
        while self.device.exists() && started.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

/// A ground station that only listens and says hello: a TCP client of a
/// SITL serial port that sends a GCS HEARTBEAT (system 255) every second —
/// ArduPilot forwards to a port only once something has spoken on it — and
/// keeps what it reads (at most `GROUND_KEEP` bytes). SITL simulates nothing
/// until SERIAL0 has a client. Stopped on drop.
pub struct GroundStation {
    stop: Arc<AtomicBool>,
    stream: TcpStream,
    thread: Option<JoinHandle<Vec<u8>>>,
}

/// What a `GroundStation` keeps of the stream.
const GROUND_KEEP: usize = 32 << 20;

impl GroundStation {
    pub fn connect(port: u16) -> GroundStation {
        let stream =
            ardupilot::connect(port, Duration::from_secs(10)).expect("connect to SITL's SERIAL0");
        stream
            .set_read_timeout(Some(Duration::from_millis(100)))
            .expect("read timeout");
        let stop = Arc::new(AtomicBool::new(false));
        let mut reader = stream.try_clone().expect("clone the stream");
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            let mut kept = Vec::new();
            let mut sequence = 0u8;
            let mut next_hello = Instant::now();
            while !flag.load(Ordering::Relaxed) {
                if Instant::now() >= next_hello {
                    let _ = reader.write_all(&gcs_heartbeat(sequence));
                    sequence = sequence.wrapping_add(1);
                    next_hello += Duration::from_secs(1);
                }
                match reader.read(&mut buf) {
                    Ok(0) => break,
                    Ok(n) => {
                        let room = GROUND_KEEP.saturating_sub(kept.len());
                        kept.extend_from_slice(&buf[..n.min(room)]);
                    }
                    Err(e)
                        if matches!(
                            e.kind(),
                            std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                        ) => {}
                    Err(_) => break,
                }
            }
            kept
        });
        GroundStation {
            stop,
            stream,
            thread: Some(thread),
        }
    }

    /// Stops listening; what it heard.
    pub fn finish(mut self) -> Vec<u8> {
        self.halt()
    }

    fn halt(&mut self) -> Vec<u8> {
        self.stop.store(true, Ordering::Relaxed);
        let _ = self.stream.shutdown(Shutdown::Both);
        self.thread
            .take()
            .and_then(|t| t.join().ok())
            .unwrap_or_default()
    }
}

impl Drop for GroundStation {
    fn drop(&mut self) {
        self.halt();
    }
}

/// A ground station's HEARTBEAT, as QGroundControl sends it: system 255,
/// MAV_TYPE_GCS.
fn gcs_heartbeat(sequence: u8) -> Vec<u8> {
    use mavlink::dialects::ardupilotmega::*;
    let header = mavlink::MavHeader {
        system_id: 255,
        component_id: 190,
        sequence,
    };
    let heartbeat = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_GCS,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    });
    elaboration::frame::serialize(header, mavlink::MavlinkVersion::V2, &heartbeat)
}

/// The MAVLink frames with a valid checksum in a byte stream, as (system,
/// component, message), skipping what does not parse.
pub fn frames(bytes: &[u8]) -> Vec<(u8, u8, Option<MavMessage>)> {
    let mut out = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        match elaboration::Frame::parse(&bytes[at..]) {
            Ok(frame) => {
                out.push((frame.system_id(), frame.component_id(), frame.decode().ok()));
                at += frame.bytes().len();
            }
            Err(_) => at += 1,
        }
    }
    out
}

/// ArduPilot SITL with `--serial1 uart:DEVICE:BAUD`, which
/// `sitl_tests::ardupilot::Options` cannot pass: a two-line script that
/// `exec`s the real binary with that option added, so that the process
/// `Sitl` kills and reaps is SITL itself.
pub fn with_serial1_uart(
    located: &ardupilot::Located,
    device: &Path,
    baud: u32,
    dir: &Path,
) -> ardupilot::Located {
    use std::os::unix::fs::PermissionsExt;
    std::fs::create_dir_all(dir).expect("scratch folder");
    let script = dir.join("arduplane-serial1");
    std::fs::write(
        &script,
        format!(
            "#!/bin/sh\nexec '{}' \"$@\" --serial1 'uart:{}:{baud}'\n",
            located.binary.display(),
            device.display()
        ),
    )
    .expect("write the wrapper");
    std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    ardupilot::Located {
        binary: script,
        ..located.clone()
    }
}
