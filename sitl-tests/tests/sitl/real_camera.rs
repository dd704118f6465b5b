//! The camera on its own link against ArduPilot's real ArduPlane SITL
//! (instance 8): the camera on SERIAL1, a client speaking as the gateway
//! (system 1, component 191) on SERIAL0. ArduPilot routes the client's
//! commands for component 100 to SERIAL1 and the camera's answers back,
//! as on a vehicle with a camera on a serial port. Skips with the reason
//! when the SITL binaries are absent; fails then under CI=true.

use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::*;
use mavlink::MavHeader;
use sitl_tests::ardupilot::{self, Firmware, Options, Sitl};
use sitl_tests::{CameraConfig, CameraSim};

use super::common::{Link, GATEWAY, SITL_INSTANCE_8};
use crate::scratch::Scratch;

const SPEEDUP: u32 = 5;

fn from_camera(h: &MavHeader) -> bool {
    (h.system_id, h.component_id) == (1, 100)
}

#[test]
fn a_camera_on_serial1_is_commanded_through_the_real_autopilot() {
    let test = "a_camera_on_serial1_is_commanded_through_the_real_autopilot";
    let Some(located) = ardupilot::require(Firmware::Plane, test) else {
        return;
    };
    let _instance = SITL_INSTANCE_8.lock().unwrap_or_else(|p| p.into_inner());
    let started = Instant::now();
    let dir = Scratch::new("sitl-camera");
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
    let mut link = Link::new(stream, Duration::from_millis(1000 / SPEEDUP as u64));
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
        100,
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
        100,
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
    // The autopilot's clock runs with the camera's (both ×5), SITL's ahead
    // by the seconds it ran before the camera powered on (bounded, and
    // not negative beyond a frame's delay).
    let offset = s.autopilot_offset_s.expect("the autopilot's time");
    assert!((-0.5..30.0).contains(&offset), "offset {offset} s");
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
}
