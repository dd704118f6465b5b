//! Helpers shared by the end-to-end tests.

use std::path::{Path, PathBuf};

use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};
use sitl_tests::Vehicle;

/// `../shared` beside the workspace, or `None` (with the reason printed)
/// when it is absent; absent under CI=true is a failure.
pub fn shared_file(relative: &str) -> Option<PathBuf> {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared");
    let path = shared.join(relative);
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
    println!("SKIPPED: {reason}");
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
        self.send(MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: p[0],
            param2: p[1],
            param3: p[2],
            param4: p[3],
            param5: p[4],
            param6: p[5],
            param7: p[6],
            command,
            target_system: 1,
            target_component: 1,
            confirmation: 0,
        }));
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
