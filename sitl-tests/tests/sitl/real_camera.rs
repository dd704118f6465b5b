//! The camera on its own link against ArduPilot's real ArduPlane SITL
//! (instance 8): the camera on SERIAL1, a client speaking as the gateway
//! (system 1, component 191) on SERIAL0. ArduPilot routes the client's
//! commands for component 100 to SERIAL1 and the camera's answers back,
//! as on a vehicle with a camera on a serial port. Skips with the reason
//! when the SITL binaries are absent; fails then under CI=true.

use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::*;
use mavlink::MavHeader;
use sitl_tests::ardupilot::{self, Firmware, Options, Sitl};
use sitl_tests::{wire, CameraConfig, CameraSim};

const SPEEDUP: u32 = 5;
const GATEWAY: (u8, u8) = (1, 191);

/// A client on a SITL port, speaking as the gateway.
struct Link {
    stream: TcpStream,
    buf: Vec<u8>,
    got: Vec<(MavHeader, MavMessage)>,
    sequence: u8,
    next_heartbeat: Instant,
}

impl Link {
    fn new(stream: TcpStream) -> Link {
        stream
            .set_read_timeout(Some(Duration::from_millis(20)))
            .expect("a read timeout");
        Link {
            stream,
            buf: Vec::new(),
            got: Vec::new(),
            sequence: 0,
            next_heartbeat: Instant::now(),
        }
    }

    fn send(&mut self, msg: &MavMessage) {
        let header = MavHeader {
            system_id: GATEWAY.0 as u32,
            component_id: GATEWAY.1,
            sequence: self.sequence,
        };
        self.sequence = self.sequence.wrapping_add(1);
        self.stream
            .write_all(&wire::frame(header, msg))
            .expect("SITL's SERIAL0 takes our frames");
    }

    /// Reads for a moment; the companion HEARTBEAT (MAV_TYPE_ONBOARD_CONTROLLER)
    /// every 200 ms of wall time (1 s of simulated time at ×5).
    fn pump(&mut self) {
        if Instant::now() >= self.next_heartbeat {
            self.next_heartbeat = Instant::now() + Duration::from_millis(200);
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
            Ok(0) => panic!("SITL closed SERIAL0"),
            Ok(n) => {
                self.buf.extend_from_slice(&chunk[..n]);
                wire::parse_frames(&mut self.buf, &mut self.got);
            }
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(e) => panic!("SERIAL0: {e}"),
        }
    }

    /// Pumps until a frame received from index `from` on matches, within `limit`.
    fn wait(
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
            assert!(
                Instant::now() < end,
                "no {what} within {limit:?} on SERIAL0"
            );
            self.pump();
        }
    }

    fn command(&mut self, command: MavCmd, p: [f32; 7]) {
        self.send(&MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: p[0],
            param2: p[1],
            param3: p[2],
            param4: p[3],
            param5: p[4],
            param6: p[5],
            param7: p[6],
            command,
            target_system: 1,
            target_component: 100,
            confirmation: 0,
        }));
    }
}

fn from_camera(h: &MavHeader) -> bool {
    (h.system_id, h.component_id) == (1, 100)
}

#[test]
fn a_camera_on_serial1_is_commanded_through_the_real_autopilot() {
    let test = "a_camera_on_serial1_is_commanded_through_the_real_autopilot";
    let Some(located) = ardupilot::require(Firmware::Plane, test) else {
        return;
    };
    let started = Instant::now();
    let dir = std::env::temp_dir().join(format!("petrel-sitl-camera-{}", std::process::id()));
    let sitl = Sitl::start(
        &located,
        &Options {
            instance: 8,
            speedup: SPEEDUP,
            ..Options::default()
        },
        &dir,
    )
    .expect("ArduPlane SITL starts");
    // The first client of SERIAL0 starts the simulation.
    let stream = ardupilot::connect(sitl.port(0), Duration::from_secs(10)).expect("SERIAL0");
    let mut link = Link::new(stream);
    let camera = CameraSim::start(
        &sitl.address(1),
        CameraConfig {
            speedup: SPEEDUP as f64,
            ..CameraConfig::default()
        },
    )
    .expect("the camera starts");
    // Its HEARTBEAT comes through the autopilot: routes are learnt both ways.
    link.wait(0, Duration::from_secs(20), "camera HEARTBEAT", |h, m| {
        from_camera(h)
            && matches!(m, MavMessage::HEARTBEAT(x) if x.mavtype == MavType::MAV_TYPE_CAMERA)
    });
    let routed_at = started.elapsed();

    let from = link.got.len();
    link.command(
        MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
        [0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0],
    );
    let ack = link.wait(
        from,
        Duration::from_secs(5),
        "COMMAND_ACK from the camera",
        |h, m| from_camera(h) && matches!(m, MavMessage::COMMAND_ACK(_)),
    );
    assert!(
        matches!(&ack, MavMessage::COMMAND_ACK(a) if a.command == MavCmd::MAV_CMD_IMAGE_START_CAPTURE
            && a.result == MavResult::MAV_RESULT_ACCEPTED
            && (a.target_system, a.target_component) == GATEWAY),
        "{ack:?}"
    );
    link.wait(from, Duration::from_secs(5), "the second image", |h, m| {
        from_camera(h) && matches!(m, MavMessage::CAMERA_IMAGE_CAPTURED(i) if i.image_index == 1)
    });
    let from = link.got.len();
    link.command(
        MavCmd::MAV_CMD_REQUEST_MESSAGE,
        [259.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    link.wait(
        from,
        Duration::from_secs(5),
        "CAMERA_INFORMATION",
        |h, m| from_camera(h) && matches!(m, MavMessage::CAMERA_INFORMATION(_)),
    );
    // The camera's side: what it heard, from whom; the autopilot's position
    // on its own port, asked for there.
    let s = camera
        .wait_for(Duration::from_secs(10), |s| s.position.is_some())
        .unwrap_or_else(|| panic!("no position on SERIAL1: {:?}", camera.state()));
    assert!(s.connected && s.autopilot_heard && s.position_streamed);
    let heard: Vec<(u32, (u8, u8), Option<u8>)> = s
        .commands
        .iter()
        .map(|c| (c.command, c.from, c.result))
        .collect();
    assert_eq!(
        heard,
        vec![(2000, GATEWAY, Some(0)), (512, GATEWAY, Some(0))]
    );
    assert_eq!(s.images, 2);
    // The autopilot does not answer for its camera.
    assert!(!link.got.iter().any(|(h, m)| h.component_id == 1
        && matches!(m, MavMessage::COMMAND_ACK(a) if a.command == MavCmd::MAV_CMD_IMAGE_START_CAPTURE)));
    drop(camera);
    drop(sitl);
    println!(
        "real ArduPlane SITL ×{SPEEDUP}: camera routed {:.1} s after start, test {:.1} s wall",
        routed_at.as_secs_f64(),
        started.elapsed().as_secs_f64()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
