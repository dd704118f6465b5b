//! The first minute of a gateway's session, played against ArduPilot's
//! real ArduPlane SITL (instance 8) and against the simulated ArduPlane at
//! once, with the same client: what a gateway reacts to must be the same on
//! both (SET_MESSAGE_INTERVAL answers and texts, MISSION_ITEM_REACHED
//! repeats, RTL_AUTOLAND over the PARAM protocol, the DO_LAND_START pre-arm
//! refusal with its texts and the pre-arm bit, arming once RTL_AUTOLAND is
//! set). Skips with the reason when the SITL binaries are absent; fails then
//! under CI=true.

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::*;
use sitl_tests::ardupilot::{self, Firmware, Options, Sitl};
use sitl_tests::{Sim, SimConfig};

use super::common::{Link, SITL_INSTANCE_8};
use crate::scratch::Scratch;

const SPEEDUP: u32 = 10;
/// The messages Petrel's ArduPilot profile reads (HEARTBEAT aside), and
/// MISSION_ACK.
const ASKED: [u32; 14] = [1, 24, 33, 42, 46, 47, 74, 77, 109, 147, 166, 193, 245, 253];
/// Wall time a session may take at most.
const LIMIT: Duration = Duration::from_secs(90);

/// What the client saw that a gateway acts on.
#[derive(Debug, Clone, PartialEq)]
struct Seen {
    /// (message id, COMMAND_ACK result) per SET_MESSAGE_INTERVAL.
    intervals: Vec<(u32, u8)>,
    /// "No ap_message for mavlink id (N)" texts, in order.
    refusal_texts: Vec<String>,
    mission: MavMissionResult,
    /// RTL_AUTOLAND read by name: (value, type, param_index).
    rtl_autoland: (f32, MavParamType, u16),
    /// The first "PreArm:" report: (severity, text).
    prearm: (MavSeverity, String),
    /// SYS_STATUS pre-arm bit (present, enabled, healthy) after the report.
    prearm_bit: (bool, bool, bool),
    /// The refused arming: (result, severity, text).
    arm: (MavResult, MavSeverity, String),
    /// RTL_AUTOLAND after PARAM_SET 2.
    rtl_autoland_set: f32,
    armed: bool,
    /// MISSION_ITEM_REACHED sequence numbers seen (never flown: 65535).
    reached: BTreeSet<u16>,
}

fn boot_ms(link: &Link) -> u32 {
    link.got
        .iter()
        .rev()
        .find_map(|(h, m)| match m {
            MavMessage::SYSTEM_TIME(t) if h.component_id == 1 => Some(t.time_boot_ms),
            _ => None,
        })
        .unwrap_or(0)
}

/// Pumps until the vehicle's clock (SYSTEM_TIME) reaches `ms`.
fn run_to(link: &mut Link, ms: u32, end: Instant) {
    while boot_ms(link) < ms {
        assert!(
            Instant::now() < end,
            "the vehicle's clock stopped at {} ms",
            boot_ms(link)
        );
        link.pump();
    }
}

fn item(seq: u16, command: MavCmd, lat: f64, lon: f64, alt: f32) -> MavMessage {
    MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
        param1: if command == MavCmd::MAV_CMD_NAV_TAKEOFF {
            15.0
        } else {
            0.0
        },
        x: (lat * 1e7) as i32,
        y: (lon * 1e7) as i32,
        z: alt,
        seq,
        command,
        target_system: 1,
        target_component: 1,
        frame: if seq == 0 {
            MavFrame::MAV_FRAME_GLOBAL
        } else {
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
        },
        autocontinue: 1,
        ..Default::default()
    })
}

// ArduPlane 4.7 asks for items with the deprecated MISSION_REQUEST.
#[allow(deprecated)]
fn session(mut link: Link) -> Seen {
    let end = Instant::now() + LIMIT;
    // Ready: MANUAL.
    link.wait(0, LIMIT, "MANUAL", |h, m| {
        h.component_id == 1 && matches!(m, MavMessage::HEARTBEAT(x) if x.custom_mode == 0)
    });
    let mut intervals = Vec::new();
    for id in ASKED {
        let from = link.got.len();
        link.command(
            1,
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            [id as f32, 250_000.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        let ack = link.wait(from, Duration::from_secs(5), "SET_MESSAGE_INTERVAL ack", |_, m| {
            matches!(m, MavMessage::COMMAND_ACK(a) if a.command == MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL)
        });
        if let MavMessage::COMMAND_ACK(a) = ack {
            intervals.push((id, a.result as u8));
        }
    }
    // The mission: home, take-off, a waypoint, DO_LAND_START, a waypoint, land.
    let (lat, lon) = (-35.363261, 149.165230);
    let items = [
        item(0, MavCmd::MAV_CMD_NAV_WAYPOINT, lat, lon, 0.0),
        item(1, MavCmd::MAV_CMD_NAV_TAKEOFF, lat + 0.001, lon, 50.0),
        item(2, MavCmd::MAV_CMD_NAV_WAYPOINT, lat + 0.004, lon, 80.0),
        item(3, MavCmd::MAV_CMD_DO_LAND_START, 0.0, 0.0, 0.0),
        item(
            4,
            MavCmd::MAV_CMD_NAV_WAYPOINT,
            lat + 0.005,
            lon + 0.001,
            50.0,
        ),
        item(5, MavCmd::MAV_CMD_NAV_LAND, lat + 0.0008, lon, 0.0),
    ];
    let from = link.got.len();
    link.send(&MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
        count: items.len() as u16,
        target_system: 1,
        target_component: 1,
        ..Default::default()
    }));
    let mut answered = from;
    let mission = loop {
        assert!(Instant::now() < end, "the mission upload did not end");
        link.pump();
        let next = link.got[answered..].iter().find_map(|(_, m)| match m {
            MavMessage::MISSION_REQUEST(r) => Some(Err(r.seq)),
            MavMessage::MISSION_REQUEST_INT(r) => Some(Err(r.seq)),
            MavMessage::MISSION_ACK(a) => Some(Ok(a.mavtype)),
            _ => None,
        });
        answered = link.got.len();
        match next {
            Some(Ok(result)) => break result,
            Some(Err(seq)) => {
                if let Some(it) = items.get(seq as usize) {
                    link.send(it);
                }
            }
            None => {}
        }
    };
    let from = link.got.len();
    link.send(&MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
        param_index: -1,
        target_system: 1,
        target_component: 1,
        param_id: "RTL_AUTOLAND".into(),
    }));
    let is_rtl_autoland = |m: &MavMessage| matches!(m, MavMessage::PARAM_VALUE(p) if p.param_id.to_str() == Ok("RTL_AUTOLAND"));
    let rtl_autoland = match link.wait(from, Duration::from_secs(5), "RTL_AUTOLAND", |_, m| {
        is_rtl_autoland(m)
    }) {
        MavMessage::PARAM_VALUE(p) => (p.param_value, p.param_type, p.param_index),
        _ => unreachable!(),
    };
    // The pre-arm report, 30 s after boot.
    run_to(&mut link, 32_000, end);
    let text = |m: &MavMessage, prefix: &str| match m {
        MavMessage::STATUSTEXT(t) => t
            .text
            .to_str()
            .ok()
            .filter(|s| s.starts_with(prefix))
            .map(|s| (t.severity, s.to_owned())),
        _ => None,
    };
    let prearm = link
        .got
        .iter()
        .find_map(|(_, m)| text(m, "PreArm:"))
        .expect("a PreArm report by 32 s");
    let prearm_bit = link
        .got
        .iter()
        .rev()
        .find_map(|(h, m)| match m {
            MavMessage::SYS_STATUS(s) if h.component_id == 1 => {
                let bit = |x: u32| x & 0x1000_0000 != 0;
                Some((
                    bit(s.onboard_control_sensors_present.bits()),
                    bit(s.onboard_control_sensors_enabled.bits()),
                    bit(s.onboard_control_sensors_health.bits()),
                ))
            }
            _ => None,
        })
        .expect("SYS_STATUS at 1 Hz, unasked");
    let arm_cmd = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let from = link.got.len();
    link.command(1, MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm_cmd);
    let said = link.wait(from, Duration::from_secs(5), "Arm: text", |_, m| {
        text(m, "Arm:").is_some()
    });
    let result = link.got[from..]
        .iter()
        .find_map(|(_, m)| match m {
            MavMessage::COMMAND_ACK(a) if a.command == MavCmd::MAV_CMD_COMPONENT_ARM_DISARM => {
                Some(a.result)
            }
            _ => None,
        })
        .expect("the ack before the text");
    let (severity, words) = text(&said, "Arm:").expect("an Arm: text");
    // RTL_AUTOLAND 2: arming is accepted (retried while other checks settle).
    let from = link.got.len();
    link.send(&MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: 2.0,
        target_system: 1,
        target_component: 1,
        param_id: "RTL_AUTOLAND".into(),
        param_type: MavParamType::MAV_PARAM_TYPE_INT8,
    }));
    let rtl_autoland_set =
        match link.wait(from, Duration::from_secs(5), "RTL_AUTOLAND set", |_, m| {
            is_rtl_autoland(m)
        }) {
            MavMessage::PARAM_VALUE(p) => p.param_value,
            _ => unreachable!(),
        };
    let armed = |link: &Link| {
        link.got.iter().rev().find_map(|(h, m)| match m {
            MavMessage::HEARTBEAT(x) if h.component_id == 1 => Some(x.base_mode.bits() & 128 != 0),
            _ => None,
        }) == Some(true)
    };
    let mut tries = 0;
    while !armed(&link) && boot_ms(&link) < 70_000 {
        tries += 1;
        link.command(1, MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm_cmd);
        let next = boot_ms(&link) + 3_000;
        run_to(&mut link, next, end);
    }
    let reached = link
        .got
        .iter()
        .filter_map(|(_, m)| match m {
            MavMessage::MISSION_ITEM_REACHED(r) => Some(r.seq),
            _ => None,
        })
        .collect();
    let reached_count = link
        .got
        .iter()
        .filter(|(_, m)| matches!(m, MavMessage::MISSION_ITEM_REACHED(_)))
        .count();
    // Asked at 4 Hz a few seconds after boot, the session lasts ≥ 35 s: about
    // 130 repeats (at least 20 even if a loaded machine drops some).
    assert!(reached_count >= 20, "{reached_count} MISSION_ITEM_REACHED");
    println!("armed after {tries} tries at {} ms", boot_ms(&link));
    let refusal_texts = link
        .got
        .iter()
        .filter_map(|(_, m)| text(m, "No ap_message"))
        .map(|(_, t)| t)
        .collect();
    Seen {
        intervals,
        refusal_texts,
        mission,
        rtl_autoland,
        prearm,
        prearm_bit,
        arm: (result, severity, words),
        rtl_autoland_set,
        armed: armed(&link),
        reached,
    }
}

#[test]
fn the_first_minute_is_the_same_on_the_real_firmware_and_the_simulation() {
    let test = "the_first_minute_is_the_same_on_the_real_firmware_and_the_simulation";
    let Some(located) = ardupilot::require(Firmware::Plane, test) else {
        return;
    };
    let _instance = SITL_INSTANCE_8.lock().unwrap_or_else(|p| p.into_inner());
    let started = Instant::now();
    let heartbeat = Duration::from_millis(1000 / SPEEDUP as u64);
    let dir = Scratch::new("sitl-parity");
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
    let sim = Sim::start(SimConfig {
        speedup: SPEEDUP as f64,
        ..SimConfig::default()
    })
    .expect("the simulation starts");
    let sim_port = sim.local_addr().port();
    let simulated = std::thread::spawn(move || {
        let stream = ardupilot::connect(sim_port, Duration::from_secs(5)).expect("the sim's port");
        session(Link::new(stream, heartbeat))
    });
    let stream = ardupilot::connect(sitl.port(0), Duration::from_secs(10)).expect("SERIAL0");
    let real = session(Link::new(stream, heartbeat));
    let simulated = simulated.join().expect("the simulated session");
    drop(sim);
    drop(sitl);
    println!("real ArduPlane SITL: {real:#?}");
    println!(
        "both sessions ×{SPEEDUP}: {:.1} s wall",
        started.elapsed().as_secs_f64()
    );
    // What the real firmware said, checked here so that a change of firmware shows.
    let denied: Vec<u32> = real
        .intervals
        .iter()
        .filter(|(_, r)| *r == MavResult::MAV_RESULT_DENIED as u8)
        .map(|(id, _)| *id)
        .collect();
    assert_eq!(denied, vec![47, 77, 109, 166, 253]);
    assert_eq!(
        real.arm,
        (
            MavResult::MAV_RESULT_FAILED,
            MavSeverity::MAV_SEVERITY_CRITICAL,
            "Arm: DO_LAND_START set and RTL_AUTOLAND disabled".to_owned()
        )
    );
    assert_eq!(
        real.prearm.1,
        "PreArm: DO_LAND_START set and RTL_AUTOLAND disable"
    );
    assert_eq!(real.prearm_bit, (true, true, false));
    assert_eq!(real.reached, BTreeSet::from([65535]));
    assert!(real.armed);
    // And the simulation says the same.
    assert_eq!(simulated, real);
}
