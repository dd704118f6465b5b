//! Helpers shared by the end-to-end tests.

use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};
use sitl_tests::{wire, Vehicle};

/// The gateway's identity: the vehicle's system, component 191.
pub const GATEWAY: (u8, u8) = (1, 191);

/// ArduPilot SITL instance 8 (TCP 5840…) is this crate's: one test at a time.
pub static SITL_INSTANCE_8: Mutex<()> = Mutex::new(());

/// `../shared` beside the workspace, or `None` (with the reason printed)
/// when it is absent; absent under CI=true is a failure.
pub fn shared_file(relative: &str) -> Option<PathBuf> {
    let path = sitl_tests::skip::shared_dir().join(relative);
    if path.is_file() {
        return Some(path);
    }
    let reason = format!(
        "{} not found (shared data beside the workspace)",
        path.display()
    );
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("{reason}: required under CI=true");
    }
    sitl_tests::skip::skip(&reason);
    None
}

/// A frame the vehicle sent, as a client decodes it off the wire.
#[derive(Debug, Clone)]
pub struct Sent {
    /// Sim microseconds since boot.
    pub time_us: u64,
    pub header: MavHeader,
    pub msg: MavMessage,
    /// The frame's bytes.
    pub bytes: Vec<u8>,
}

/// Drains the vehicle's output through the wire format: each message is
/// serialized by rust-mavlink and decoded again with `elaboration::Frame`,
/// as the gateway reads it.
pub fn drain(v: &mut Vehicle, out: &mut Vec<Sent>) {
    while let Some((header, msg)) = v.poll_transmit() {
        let bytes = elaboration::frame::serialize(header, MavlinkVersion::V2, &msg);
        let frame = match elaboration::Frame::parse(&bytes) {
            Ok(f) => f,
            Err(e) => panic!("the vehicle sent an unparsable frame: {e} ({msg:?})"),
        };
        let decoded = match frame.decode() {
            Ok(m) => m,
            Err(e) => panic!("the vehicle sent an undecodable frame: {e:?} ({msg:?})"),
        };
        assert_eq!(frame.header(), header);
        out.push(Sent {
            time_us: v.now_us(),
            header,
            msg: decoded,
            bytes,
        });
    }
}

/// The message's name.
pub fn name(m: &MavMessage) -> &'static str {
    use mavlink::Message;
    m.message_name()
}

/// A client driving a [`Vehicle`] in simulated time, as the gateway would
/// over a link: what it sends is stamped with the vehicle's time, what the
/// vehicle sends is read back through the wire format.
pub struct Client {
    pub v: Vehicle,
    pub got: Vec<Sent>,
    pub id: (u8, u8),
}

impl Client {
    pub fn new(cfg: sitl_tests::SimConfig) -> Client {
        Client {
            v: Vehicle::new(cfg),
            got: Vec::new(),
            id: (1, 191),
        }
    }

    /// Runs until `t` seconds of sim time.
    pub fn run_to(&mut self, t: f64) {
        let end = (t * 1e6) as u64;
        while self.v.now_us() < end {
            let next = (self.v.now_us() + 20_000).min(end);
            self.v.advance(next);
            drain(&mut self.v, &mut self.got);
        }
    }

    /// Runs until `cond` holds on the truth, or `limit` seconds.
    pub fn run_until(&mut self, limit: f64, cond: impl Fn(&sitl_tests::SimState) -> bool) -> bool {
        while self.v.now_us() < (limit * 1e6) as u64 {
            if cond(&self.v.state()) {
                return true;
            }
            let t = self.v.now_us() as f64 / 1e6 + 0.1;
            self.run_to(t);
        }
        cond(&self.v.state())
    }

    pub fn send(&mut self, msg: MavMessage) {
        let header = MavHeader {
            system_id: self.id.0 as u32,
            component_id: self.id.1,
            sequence: 0,
        };
        let now = self.v.now_us();
        self.v.handle(now, &header, &msg);
        drain(&mut self.v, &mut self.got);
    }

    fn ack_since(&self, from: usize, command: MavCmd) -> Option<MavResult> {
        self.got[from..].iter().find_map(|s| match &s.msg {
            MavMessage::COMMAND_ACK(a) if a.command == command => Some(a.result),
            _ => None,
        })
    }

    pub fn command(&mut self, command: MavCmd, p: [f32; 7]) -> Option<MavResult> {
        let from = self.got.len();
        self.send(sitl_tests::wire::command_long((1, 1), command, p));
        self.ack_since(from, command)
    }

    pub fn reposition(&mut self, lat: f64, lon: f64, alt: f32, radius: f32) -> Option<MavResult> {
        let from = self.got.len();
        self.send(MavMessage::COMMAND_INT(COMMAND_INT_DATA {
            param1: -1.0,
            param2: 1.0,
            param3: radius,
            param4: 0.0,
            x: (lat * 1e7) as i32,
            y: (lon * 1e7) as i32,
            z: alt,
            command: MavCmd::MAV_CMD_DO_REPOSITION,
            target_system: 1,
            target_component: 1,
            frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            current: 0,
            autocontinue: 0,
        }));
        self.ack_since(from, MavCmd::MAV_CMD_DO_REPOSITION)
    }

    /// All streams at `hz` (REQUEST_DATA_STREAM, as the recorded client).
    #[allow(deprecated)]
    pub fn streams(&mut self, hz: u16) {
        self.send(MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
            req_message_rate: hz,
            target_system: 1,
            target_component: 1,
            req_stream_id: MavDataStream::MAV_DATA_STREAM_ALL,
            start_stop: 1,
        }));
    }

    /// Uploads `items` after a home item, answering each request.
    #[allow(deprecated)]
    pub fn upload(&mut self, items: &[MISSION_ITEM_INT_DATA]) -> Option<MavMissionResult> {
        let mut all = vec![MISSION_ITEM_INT_DATA::default()];
        all.extend(items.iter().cloned());
        for (i, it) in all.iter_mut().enumerate() {
            it.seq = i as u16;
            it.target_system = 1;
            it.target_component = 1;
        }
        let mut from = self.got.len();
        self.send(MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count: all.len() as u16,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        }));
        for _ in 0..all.len() * 2 {
            let reply = self.got[from..].iter().find_map(|s| match &s.msg {
                MavMessage::MISSION_REQUEST(r) => Some(Err(r.seq)),
                MavMessage::MISSION_REQUEST_INT(r) => Some(Err(r.seq)),
                MavMessage::MISSION_ACK(a) => Some(Ok(a.mavtype)),
                _ => None,
            });
            from = self.got.len();
            match reply {
                Some(Ok(r)) => return Some(r),
                Some(Err(seq)) => {
                    let it = all.get(seq as usize)?.clone();
                    self.send(MavMessage::MISSION_ITEM_INT(it));
                }
                None => return None,
            }
        }
        None
    }

    /// The messages of a type received after index `from`.
    pub fn since(&self, from: usize, n: &str) -> Vec<&Sent> {
        self.got[from..]
            .iter()
            .filter(|s| name(&s.msg) == n)
            .collect()
    }
}

/// A MISSION_ITEM_INT at (north, east) metres from `home`, `alt` above home.
pub fn mission_item(
    home: &sitl_tests::Home,
    command: MavCmd,
    north: f64,
    east: f64,
    alt: f32,
) -> MISSION_ITEM_INT_DATA {
    let (lat, lon) = sitl_tests::geo::location(home, sitl_tests::geo::V2::new(north, east));
    MISSION_ITEM_INT_DATA {
        x: (lat * 1e7).round() as i32,
        y: (lon * 1e7).round() as i32,
        z: alt,
        command,
        frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
        autocontinue: 1,
        ..Default::default()
    }
}

/// A client on a SITL port, speaking as the gateway.
pub struct Link {
    stream: TcpStream,
    pub buf: Vec<u8>,
    /// Every frame received so far.
    pub got: Vec<(MavHeader, MavMessage)>,
    sequence: u8,
    next_heartbeat: Instant,
    heartbeat_every: Duration,
}

impl Link {
    /// `heartbeat_every`: the companion HEARTBEAT's period (wall time).
    pub fn new(stream: TcpStream, heartbeat_every: Duration) -> Link {
        stream
            .set_read_timeout(Some(Duration::from_millis(20)))
            .expect("a read timeout");
        Link {
            stream,
            buf: Vec::new(),
            got: Vec::new(),
            sequence: 0,
            next_heartbeat: Instant::now(),
            heartbeat_every,
        }
    }

    pub fn send(&mut self, msg: &MavMessage) {
        let header = MavHeader {
            system_id: GATEWAY.0 as u32,
            component_id: GATEWAY.1,
            sequence: self.sequence,
        };
        self.sequence = self.sequence.wrapping_add(1);
        self.stream
            .write_all(&wire::frame(header, msg))
            .expect("the vehicle takes our frames");
    }

    /// Reads for a moment (at most 20 ms); the companion HEARTBEAT
    /// (MAV_TYPE_ONBOARD_CONTROLLER) when due.
    pub fn pump(&mut self) {
        if Instant::now() >= self.next_heartbeat {
            self.next_heartbeat = Instant::now() + self.heartbeat_every;
            self.send(&MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                custom_mode: 0,
                mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
                autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
                base_mode: MavModeFlag::empty(),
                system_status: MavState::MAV_STATE_ACTIVE,
                mavlink_version: 3,
            }));
        }
        let mut chunk = [0u8; 8192];
        match self.stream.read(&mut chunk) {
            Ok(0) => panic!("the vehicle closed the link"),
            Ok(n) => {
                self.buf.extend_from_slice(&chunk[..n]);
                wire::parse_frames(&mut self.buf, &mut self.got);
            }
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(e) => panic!("link: {e}"),
        }
    }

    /// Pumps until a frame received from index `from` on matches, within `limit`.
    pub fn wait(
        &mut self,
        from: usize,
        limit: Duration,
        what: &str,
        pred: impl Fn(&MavHeader, &MavMessage) -> bool,
    ) -> MavMessage {
        let end = Instant::now() + limit;
        loop {
            if let Some((_, m)) = self.got[from..].iter().find(|(h, m)| pred(h, m)) {
                return m.clone();
            }
            assert!(Instant::now() < end, "no {what} within {limit:?}");
            self.pump();
        }
    }

    /// COMMAND_LONG to component `component` of system 1.
    pub fn command(&mut self, component: u8, command: MavCmd, p: [f32; 7]) {
        self.send(&sitl_tests::wire::command_long((1, component), command, p));
    }
}
