//! The runner on 127.0.0.1, over TCP and UDP: a client connects (the
//! vehicle boots), asks for telemetry, uploads a short mission and flies
//! it at high speedup; the sim accepts a new TCP client after the first
//! leaves. Every wait is bounded by a wall-clock deadline (no timing is
//! asserted on the wall clock).

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpStream, UdpSocket};
use std::time::{Duration, Instant};

use elaboration::Frame;
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};
use sitl_tests::{BootTimeline, Home, Sim, SimConfig, SimState};

use super::common::mission_item;

/// The longest any step may take on a loaded 2-core machine.
const DEADLINE: Duration = Duration::from_secs(30);

/// A byte pipe to the sim.
trait Pipe {
    fn send(&mut self, bytes: &[u8]);
    /// Whatever arrives within a short wait.
    fn recv(&mut self, buf: &mut Vec<u8>);
}

struct Tcp(TcpStream);

impl Pipe for Tcp {
    fn send(&mut self, bytes: &[u8]) {
        self.0.write_all(bytes).expect("write to the sim");
    }
    fn recv(&mut self, buf: &mut Vec<u8>) {
        let mut chunk = [0u8; 8192];
        match self.0.read(&mut chunk) {
            Ok(n) => buf.extend_from_slice(&chunk[..n]),
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(e) => panic!("read from the sim: {e}"),
        }
    }
}

struct Udp(UdpSocket, std::net::SocketAddr);

impl Pipe for Udp {
    fn send(&mut self, bytes: &[u8]) {
        self.0.send_to(bytes, self.1).expect("send to the sim");
    }
    fn recv(&mut self, buf: &mut Vec<u8>) {
        let mut d = [0u8; 65536];
        match self.0.recv_from(&mut d) {
            Ok((n, _)) => buf.extend_from_slice(&d[..n]),
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(e) => panic!("recv from the sim: {e}"),
        }
    }
}

/// A client speaking as Petrel's gateway does (system 1, component 191).
struct Client<P: Pipe> {
    pipe: P,
    buf: Vec<u8>,
    got: Vec<(MavHeader, MavMessage)>,
    seq: u8,
}

impl<P: Pipe> Client<P> {
    fn new(pipe: P) -> Self {
        Client {
            pipe,
            buf: Vec::new(),
            got: Vec::new(),
            seq: 0,
        }
    }

    fn send(&mut self, msg: MavMessage) {
        let header = MavHeader {
            system_id: 1,
            component_id: 191,
            sequence: self.seq,
        };
        self.seq = self.seq.wrapping_add(1);
        let bytes = elaboration::frame::serialize(header, MavlinkVersion::V2, &msg);
        self.pipe.send(&bytes);
    }

    fn pump(&mut self) {
        self.pipe.recv(&mut self.buf);
        let mut pos = 0;
        while pos < self.buf.len() {
            match Frame::parse(&self.buf[pos..]) {
                Ok(f) => {
                    pos += f.bytes().len();
                    if let Ok(m) = f.decode() {
                        self.got.push((f.header(), m));
                    }
                }
                Err(elaboration::FrameError::Truncated { .. }) => break,
                Err(_) => pos += 1,
            }
        }
        self.buf.drain(..pos);
    }

    /// Reads until a received message satisfies `pick`; bounded by DEADLINE.
    fn wait<T>(&mut self, what: &str, pick: impl Fn(&MavHeader, &MavMessage) -> Option<T>) -> T {
        let end = Instant::now() + DEADLINE;
        let mut seen = 0;
        loop {
            for (h, m) in &self.got[seen..] {
                if let Some(t) = pick(h, m) {
                    return t;
                }
            }
            seen = self.got.len();
            assert!(
                Instant::now() < end,
                "no {what} from the sim within {DEADLINE:?}"
            );
            self.pump();
        }
    }

    fn command(&mut self, command: MavCmd, p: [f32; 7]) -> MavResult {
        self.got.clear();
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
        self.wait("COMMAND_ACK", |_, m| match m {
            MavMessage::COMMAND_ACK(a) if a.command == command => Some(a.result),
            _ => None,
        })
    }

    #[allow(deprecated)]
    fn upload(&mut self, items: &[MISSION_ITEM_INT_DATA]) -> MavMissionResult {
        let mut all = vec![MISSION_ITEM_INT_DATA::default()];
        all.extend(items.iter().cloned());
        for (i, it) in all.iter_mut().enumerate() {
            it.seq = i as u16;
            it.target_system = 1;
            it.target_component = 1;
        }
        self.got.clear();
        self.send(MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count: all.len() as u16,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        }));
        loop {
            let next = self.wait("a mission request or ack", |_, m| match m {
                MavMessage::MISSION_REQUEST(r) => Some(Err(r.seq)),
                MavMessage::MISSION_ACK(a) => Some(Ok(a.mavtype)),
                _ => None,
            });
            self.got.clear();
            match next {
                Ok(r) => return r,
                Err(seq) => {
                    let it = all[seq as usize].clone();
                    self.send(MavMessage::MISSION_ITEM_INT(it));
                }
            }
        }
    }
}

fn wait_state(sim: &Sim, what: &str, cond: impl Fn(&SimState) -> bool) -> SimState {
    match sim.wait_for(DEADLINE, cond) {
        Some(s) => s,
        None => panic!("{what}: not within {DEADLINE:?}; state {:?}", {
            let mut s = sim.state();
            s.statustexts.drain(..s.statustexts.len().saturating_sub(5));
            (s.time_s, s.mode, s.armed, s.alt, s.statustexts)
        }),
    }
}

fn config(listen: &str) -> SimConfig {
    SimConfig {
        listen: listen.to_owned(),
        speedup: 40.0,
        boot: BootTimeline::quick(),
        ..SimConfig::default()
    }
}

/// Connects, streams, arms (refused first, as SITL), flies a short
/// mission and lands.
fn fly<P: Pipe>(sim: &Sim, c: &mut Client<P>) {
    // The vehicle talks as ArduPlane: its heartbeat, and the camera's.
    c.wait("the autopilot's HEARTBEAT", |h, m| match m {
        MavMessage::HEARTBEAT(hb) if h.component_id == 1 => {
            assert_eq!(hb.mavtype, MavType::MAV_TYPE_FIXED_WING);
            Some(())
        }
        _ => None,
    });
    c.wait("the camera's HEARTBEAT", |h, m| match m {
        MavMessage::HEARTBEAT(hb) if h.component_id == 100 => {
            assert_eq!(hb.mavtype, MavType::MAV_TYPE_CAMERA);
            Some(())
        }
        _ => None,
    });
    let r = c.command(
        MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
        [33.0, 250_000.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    assert_eq!(r, MavResult::MAV_RESULT_ACCEPTED);
    c.wait("GLOBAL_POSITION_INT", |_, m| {
        matches!(m, MavMessage::GLOBAL_POSITION_INT(_)).then_some(())
    });
    let home = Home::default();
    let mut to = mission_item(&home, MavCmd::MAV_CMD_NAV_TAKEOFF, 0.0, 0.0, 30.0);
    to.param1 = 15.0;
    let items = [
        to,
        mission_item(&home, MavCmd::MAV_CMD_NAV_WAYPOINT, 500.0, 0.0, 30.0),
        mission_item(&home, MavCmd::MAV_CMD_NAV_WAYPOINT, 500.0, 300.0, 30.0),
        mission_item(&home, MavCmd::MAV_CMD_NAV_LAND, 100.0, 300.0, 0.0),
    ];
    assert_eq!(c.upload(&items), MavMissionResult::MAV_MISSION_ACCEPTED);
    assert_eq!(sim.state().mission.len(), 5);
    assert_eq!(
        c.command(
            MavCmd::MAV_CMD_DO_SET_MODE,
            [1.0, 10.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        ),
        MavResult::MAV_RESULT_ACCEPTED
    );
    // Ready (EKF on GPS, gyros settled), then armed.
    wait_state(sim, "gyros settled", |s| s.time_s > 3.1);
    let arm = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    assert_eq!(
        c.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm),
        MavResult::MAV_RESULT_ACCEPTED
    );
    c.got.clear();
    let last = c.wait("MISSION_ITEM_REACHED 3", |_, m| match m {
        MavMessage::MISSION_ITEM_REACHED(r) if r.seq == 3 => Some(r.seq),
        _ => None,
    });
    assert_eq!(last, 3);
    let s = wait_state(sim, "landing and disarming", |s| !s.armed && s.landed);
    assert!(!s.crashed);
    assert_eq!(
        s.reached.iter().map(|r| r.seq).collect::<Vec<_>>(),
        vec![1, 2, 3]
    );
    assert!(s.texts_with("Auto disarmed").len() == 1);
}

#[test]
fn over_tcp_one_client_at_a_time() {
    let sim = Sim::start(config("tcpin:127.0.0.1:0")).expect("the sim starts");
    assert!(sim.client_address().starts_with("tcpout:127.0.0.1:"));
    assert_eq!(
        sim.state().time_s,
        0.0,
        "nothing runs before a client connects"
    );
    let stream = TcpStream::connect(sim.local_addr()).expect("connect");
    stream
        .set_read_timeout(Some(Duration::from_millis(20)))
        .expect("timeout");
    let mut c = Client::new(Tcp(stream));
    // The first arming, before the gyros settle, is refused as on SITL.
    c.wait("HEARTBEAT", |_, m| {
        matches!(m, MavMessage::HEARTBEAT(_)).then_some(())
    });
    wait_state(&sim, "the EKF on the GPS", |s| s.time_s > 2.3);
    let arm = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    if sim.state().time_s < 2.9 {
        assert_eq!(
            c.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm),
            MavResult::MAV_RESULT_FAILED
        );
        c.wait("the refusal", |_, m| match m {
            MavMessage::STATUSTEXT(t) if t.text.to_str() == Ok("Arm: Gyros inconsistent") => {
                Some(())
            }
            _ => None,
        });
    }
    fly(&sim, &mut c);
    assert!(sim.connected());
    // A second client waits while the first is connected, and is served
    // once it leaves.
    let second = TcpStream::connect(sim.local_addr()).expect("connect again");
    second
        .set_read_timeout(Some(Duration::from_millis(20)))
        .expect("timeout");
    drop(c);
    let mut c2 = Client::new(Tcp(second));
    c2.wait("HEARTBEAT on the second connection", |_, m| {
        matches!(m, MavMessage::HEARTBEAT(_)).then_some(())
    });
    sim.stop();
}

#[test]
fn over_udp_replies_go_to_the_last_sender() {
    let sim = Sim::start(config("udpin:127.0.0.1:0")).expect("the sim starts");
    assert!(sim.client_address().starts_with("udpout:127.0.0.1:"));
    let socket = UdpSocket::bind("127.0.0.1:0").expect("bind");
    socket
        .set_read_timeout(Some(Duration::from_millis(20)))
        .expect("timeout");
    let mut c = Client::new(Udp(socket, sim.local_addr()));
    // Nothing is sent before someone speaks; the vehicle boots then.
    c.send(MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    }));
    fly(&sim, &mut c);
    // Another sender takes over the replies.
    let other = UdpSocket::bind("127.0.0.1:0").expect("bind");
    other
        .set_read_timeout(Some(Duration::from_millis(20)))
        .expect("timeout");
    let mut c2 = Client::new(Udp(other, sim.local_addr()));
    let r = c2.command(
        MavCmd::MAV_CMD_DO_SET_MODE,
        [1.0, 11.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    assert_eq!(r, MavResult::MAV_RESULT_ACCEPTED);
    assert_eq!(sim.state().mode, "RTL");
    drop(sim); // stops on drop
}

#[test]
fn bad_addresses_are_refused() {
    for bad in ["tcp:127.0.0.1:0", "udpin:nowhere", "serial:/dev/null:57600"] {
        let e = Sim::start(config(bad)).err().expect("refused");
        assert!(e.to_string().contains(bad), "{e}");
    }
    let e = Sim::start(SimConfig {
        speedup: 0.0,
        ..config("tcpin:127.0.0.1:0")
    })
    .err()
    .expect("refused");
    assert!(e.to_string().contains("speedup"));
}
