//! The commander on a simulated clock, no network.

#![allow(deprecated)] // MISSION_REQUEST, MISSION_SET_CURRENT, REQUEST_DATA_STREAM: the fallbacks

use elaboration::Firmware;
use mavlink::dialects::ardupilotmega::*;
use mavlink::MavHeader;
use nets::{Outcome, Params, Value};

use super::commander::Commander;
use super::config::{Payload, VehicleConfig};

const S: u64 = 1_000_000;

fn params(pairs: &[(&str, Value)]) -> Params {
    pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.clone()))
        .collect()
}

fn from(system: u8, component: u8) -> MavHeader {
    MavHeader {
        system_id: system as u32,
        component_id: component,
        sequence: 0,
    }
}

fn autopilot_heartbeat(autopilot: MavAutopilot, mavtype: MavType) -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype,
        autopilot,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    })
}

struct Sim {
    c: Commander,
    now: u64,
}

impl Sim {
    fn new(fw: Firmware) -> Sim {
        let mut config = VehicleConfig::default();
        config
            .payloads
            .insert("camera".into(), Payload::Camera { component: 100 });
        config.payloads.insert(
            "sprayer".into(),
            Payload::Relay {
                instance: 2,
                start: 1,
                stop: 0,
            },
        );
        config.payloads.insert(
            "dropper".into(),
            Payload::Servo {
                instance: 9,
                start: 1900,
                stop: 1100,
            },
        );
        let mut sim = Sim {
            c: Commander::new(config),
            now: 0,
        };
        let (ap, ty) = match fw {
            Firmware::Px4 => (MavAutopilot::MAV_AUTOPILOT_PX4, MavType::MAV_TYPE_QUADROTOR),
            Firmware::Plane => (
                MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                MavType::MAV_TYPE_FIXED_WING,
            ),
            Firmware::Rover => (
                MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                MavType::MAV_TYPE_GROUND_ROVER,
            ),
            _ => (
                MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                MavType::MAV_TYPE_QUADROTOR,
            ),
        };
        sim.recv(1, 1, autopilot_heartbeat(ap, ty));
        assert_eq!(sim.c.firmware(), Some(fw));
        sim.sent(); // our first heartbeat
        sim
    }

    fn recv(&mut self, sys: u8, comp: u8, m: MavMessage) {
        self.c.message(self.now, &from(sys, comp), &m);
    }

    fn at(&mut self, t: u64) {
        self.now = t;
        self.c.tick(t);
    }

    /// Everything transmitted, heartbeats left out.
    fn sent(&mut self) -> Vec<MavMessage> {
        std::iter::from_fn(|| self.c.poll_transmit())
            .filter(|m| !matches!(m, MavMessage::HEARTBEAT(_)))
            .collect()
    }

    fn outcomes(&mut self) -> Vec<(u64, Outcome)> {
        std::iter::from_fn(|| self.c.poll_outcome()).collect()
    }

    fn command(&mut self, id: u64, verb: &str, args: &[(&str, Value)]) {
        self.c.command(id, verb, &params(args), self.now);
    }

    fn ack(&mut self, command: MavCmd, result: MavResult) {
        self.ack_from(1, command, result);
    }

    fn ack_from(&mut self, comp: u8, command: MavCmd, result: MavResult) {
        self.recv(
            1,
            comp,
            MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                command,
                result,
                progress: 0,
                result_param2: 0,
                target_system: 1,
                target_component: 191,
            }),
        );
    }

    fn one_long(&mut self) -> COMMAND_LONG_DATA {
        match self.sent().as_slice() {
            [MavMessage::COMMAND_LONG(c)] => c.clone(),
            other => panic!("expected one COMMAND_LONG, got {other:?}"),
        }
    }
}

fn ok(result: &str) -> Outcome {
    Outcome::Done(params(&[("result", Value::Str(result.into()))]))
}

fn failed(reason: &str) -> Outcome {
    Outcome::Failed(reason.into())
}

#[test]
fn heartbeat_identity_and_rate() {
    let mut c = Commander::new(VehicleConfig::default());
    c.tick(0);
    // Before the vehicle is known: only the announcing HEARTBEAT, under the
    // default system id.
    assert!(matches!(c.poll_transmit(), Some(MavMessage::HEARTBEAT(_))));
    assert!(c.poll_transmit().is_none(), "nothing but the heartbeat");
    assert_eq!(c.identity(), None);
    assert_eq!(c.sender(), (1, 191));
    assert!(!c.heard());
    // A ground station's heartbeat is not the autopilot.
    c.message(
        10,
        &from(255, 190),
        &autopilot_heartbeat(MavAutopilot::MAV_AUTOPILOT_INVALID, MavType::MAV_TYPE_GCS),
    );
    assert_eq!(c.target(), None);
    c.message(
        20,
        &from(7, 1),
        &autopilot_heartbeat(
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            MavType::MAV_TYPE_FIXED_WING,
        ),
    );
    assert_eq!(c.target(), Some((7, 1)));
    assert_eq!(c.identity(), Some((7, 191)));
    let mut beats = Vec::new();
    for t in (20..=5 * S + 20).step_by(100_000) {
        c.tick(t);
        while let Some(m) = c.poll_transmit() {
            if let MavMessage::HEARTBEAT(h) = m {
                assert_eq!(h.mavtype, MavType::MAV_TYPE_ONBOARD_CONTROLLER);
                assert_eq!(h.autopilot, MavAutopilot::MAV_AUTOPILOT_INVALID);
                beats.push(t);
            }
        }
        assert!(c.next_deadline().is_some_and(|d| d <= t + S));
    }
    // 1 Hz, continuing the rhythm of the announcing heartbeat sent at 0.
    assert_eq!(
        beats,
        [1, 2, 3, 4, 5].map(|k| k * S + 20),
        "1 Hz over 5 s: {beats:?}"
    );
}

#[test]
fn every_verb_ardupilot_copter() {
    let mut s = Sim::new(Firmware::Copter);
    s.recv(
        1,
        1,
        MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
            lat: -353_632_610,
            lon: 1_491_652_300,
            alt: 600_000,
            relative_alt: 15_000,
            ..GLOBAL_POSITION_INT_DATA::DEFAULT
        }),
    );
    type Case = (&'static str, Vec<(&'static str, Value)>, MavCmd, [f32; 7]);
    let cases: Vec<Case> = vec![
        (
            "arm",
            vec![],
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [1., 0., 0., 0., 0., 0., 0.],
        ),
        (
            "arm",
            vec![("force", Value::Bool(true))],
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [1., 21196., 0., 0., 0., 0., 0.],
        ),
        (
            "disarm",
            vec![],
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [0.; 7],
        ),
        (
            "mode",
            vec![("mode", Value::Str("GUIDED".into()))],
            MavCmd::MAV_CMD_DO_SET_MODE,
            [1., 4., 0., 0., 0., 0., 0.],
        ),
        (
            "takeoff",
            vec![("alt", Value::Int(20))],
            MavCmd::MAV_CMD_NAV_TAKEOFF,
            [0., 0., 0., 0., 0., 0., 20.],
        ),
        ("land", vec![], MavCmd::MAV_CMD_NAV_LAND, [0.; 7]),
        ("rtl", vec![], MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH, [0.; 7]),
        (
            "set_speed",
            vec![("speed", Value::Int(5))],
            MavCmd::MAV_CMD_DO_CHANGE_SPEED,
            [1., 5., -1., 0., 0., 0., 0.],
        ),
        (
            "start_mission",
            vec![],
            MavCmd::MAV_CMD_MISSION_START,
            [0.; 7],
        ),
        (
            "set_current",
            vec![("seq", Value::Int(3))],
            MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT,
            [3., 0., 0., 0., 0., 0., 0.],
        ),
        (
            "payload_start",
            vec![("payload", Value::Str("sprayer".into()))],
            MavCmd::MAV_CMD_DO_SET_RELAY,
            [2., 1., 0., 0., 0., 0., 0.],
        ),
        (
            "payload_stop",
            vec![("payload", Value::Str("sprayer".into()))],
            MavCmd::MAV_CMD_DO_SET_RELAY,
            [2., 0., 0., 0., 0., 0., 0.],
        ),
        (
            "payload_start",
            vec![("payload", Value::Str("dropper".into()))],
            MavCmd::MAV_CMD_DO_SET_SERVO,
            [9., 1900., 0., 0., 0., 0., 0.],
        ),
        (
            "payload_stop",
            vec![("payload", Value::Str("dropper".into()))],
            MavCmd::MAV_CMD_DO_SET_SERVO,
            [9., 1100., 0., 0., 0., 0., 0.],
        ),
    ];
    for (n, (verb, args, cmd, p)) in cases.into_iter().enumerate() {
        let id = n as u64 + 1;
        s.command(id, verb, &args);
        let c = s.one_long();
        assert_eq!(c.command, cmd, "{verb}");
        assert_eq!(
            (c.target_system, c.target_component, c.confirmation),
            (1, 1, 0)
        );
        assert_eq!(
            [c.param1, c.param2, c.param3, c.param4, c.param5, c.param6, c.param7],
            p,
            "{verb} {args:?}"
        );
        s.ack(cmd, MavResult::MAV_RESULT_ACCEPTED);
        assert_eq!(s.outcomes(), vec![(id, ok("ACCEPTED"))], "{verb}");
    }
    // goto: COMMAND_INT DO_REPOSITION, relative altitude, current altitude when none given.
    s.command(
        50,
        "goto",
        &[("lat", Value::Float(-35.36)), ("lon", Value::Float(149.16))],
    );
    match s.sent().as_slice() {
        [MavMessage::COMMAND_INT(c)] => {
            assert_eq!(c.command, MavCmd::MAV_CMD_DO_REPOSITION);
            assert_eq!(c.frame, MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT);
            assert_eq!((c.x, c.y, c.z), (-353_600_000, 1_491_600_000, 15.0));
            assert_eq!((c.param1, c.param2), (-1.0, 1.0));
            assert!(c.param4.is_nan());
        }
        other => panic!("{other:?}"),
    }
    s.ack(
        MavCmd::MAV_CMD_DO_REPOSITION,
        MavResult::MAV_RESULT_ACCEPTED,
    );
    assert_eq!(s.outcomes(), vec![(50, ok("ACCEPTED"))]);
    // The camera payload is addressed to its own component, and acked by it.
    s.command(
        51,
        "payload_start",
        &[
            ("payload", Value::Str("camera".into())),
            ("interval", Value::Int(2)),
        ],
    );
    let c = s.one_long();
    assert_eq!(
        (c.command, c.target_component, c.param2),
        (MavCmd::MAV_CMD_IMAGE_START_CAPTURE, 100, 2.0)
    );
    s.ack(
        MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
        MavResult::MAV_RESULT_ACCEPTED,
    );
    assert!(
        s.outcomes().is_empty(),
        "the autopilot's ack is not the camera's"
    );
    s.ack_from(
        100,
        MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
        MavResult::MAV_RESULT_ACCEPTED,
    );
    assert_eq!(s.outcomes(), vec![(51, ok("ACCEPTED"))]);
    s.command(
        52,
        "payload_stop",
        &[("payload", Value::Str("camera".into()))],
    );
    let c = s.one_long();
    assert_eq!(
        (c.command, c.target_component),
        (MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE, 100)
    );
    // Bad requests fail at once.
    s.command(
        53,
        "payload_start",
        &[("payload", Value::Str("laser".into()))],
    );
    s.command(
        54,
        "land",
        &[("lat", Value::Float(1.0)), ("lon", Value::Float(2.0))],
    );
    s.command(55, "mode", &[("mode", Value::Str("FBWA".into()))]);
    let out = s.outcomes();
    assert_eq!(out.len(), 3);
    assert!(
        out.iter().all(|(_, o)| matches!(o, Outcome::Failed(_))),
        "{out:?}"
    );
    assert!(s.sent().is_empty());
}

#[test]
fn plane_and_px4_specifics() {
    let mut s = Sim::new(Firmware::Plane);
    s.command(1, "mode", &[("mode", Value::Str("FBWA".into()))]);
    let c = s.one_long();
    assert_eq!(
        (c.command, c.param1, c.param2),
        (MavCmd::MAV_CMD_DO_SET_MODE, 1.0, 5.0)
    );
    s.ack(MavCmd::MAV_CMD_DO_SET_MODE, MavResult::MAV_RESULT_ACCEPTED);
    s.command(2, "takeoff", &[("alt", Value::Int(50))]);
    s.command(3, "land", &[]);
    s.command(4, "set_speed", &[("speed", Value::Int(18))]);
    let sent = s.sent();
    // takeoff waits behind nothing: DO_SET_MODE is free again.
    let cmds: Vec<(MavCmd, f32, f32)> = sent
        .iter()
        .map(|m| match m {
            MavMessage::COMMAND_LONG(c) => (c.command, c.param1, c.param2),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(
        cmds,
        vec![
            (MavCmd::MAV_CMD_DO_SET_MODE, 1.0, 13.0),
            (MavCmd::MAV_CMD_DO_LAND_START, 0.0, 0.0),
            (MavCmd::MAV_CMD_DO_CHANGE_SPEED, 0.0, 18.0),
        ]
    );

    let mut p = Sim::new(Firmware::Px4);
    p.command(1, "mode", &[("mode", Value::Str("AUTO_MISSION".into()))]);
    let c = p.one_long();
    assert_eq!((c.param1, c.param2, c.param3), (1.0, 4.0, 4.0));
    p.ack(MavCmd::MAV_CMD_DO_SET_MODE, MavResult::MAV_RESULT_ACCEPTED);
    p.command(2, "takeoff", &[("alt", Value::Int(10))]);
    assert_eq!(
        p.outcomes(),
        vec![
            (1, ok("ACCEPTED")),
            (
                2,
                failed("takeoff: home altitude unknown (no GLOBAL_POSITION_INT yet)")
            )
        ]
    );
    p.recv(
        1,
        1,
        MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
            alt: 999_000,
            relative_alt: 0,
            ..GLOBAL_POSITION_INT_DATA::DEFAULT
        }),
    );
    p.command(9, "takeoff", &[("alt", Value::Int(10))]);
    assert_eq!(
        p.outcomes(),
        vec![(
            9,
            failed("takeoff: home altitude unknown (no GLOBAL_POSITION_INT yet)")
        )],
        "a position of 0, 0 is no position"
    );
    p.recv(
        1,
        1,
        MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
            lat: 473_977_420,
            lon: 85_455_940,
            alt: 488_000,
            relative_alt: 0,
            ..GLOBAL_POSITION_INT_DATA::DEFAULT
        }),
    );
    p.command(3, "takeoff", &[("alt", Value::Int(10))]);
    let c = p.one_long();
    assert_eq!((c.command, c.param7), (MavCmd::MAV_CMD_NAV_TAKEOFF, 498.0));
    p.command(
        4,
        "goto",
        &[
            ("lat", Value::Float(47.0)),
            ("lon", Value::Float(8.5)),
            ("alt", Value::Int(20)),
        ],
    );
    match p.sent().as_slice() {
        [MavMessage::COMMAND_INT(c)] => {
            assert_eq!((c.frame, c.z), (MavFrame::MAV_FRAME_GLOBAL, 508.0));
        }
        other => panic!("{other:?}"),
    }
    p.command(5, "land", &[]);
    let c = p.one_long();
    assert_eq!(c.command, MavCmd::MAV_CMD_NAV_LAND);
    assert!(c.param5.is_nan() && c.param7.is_nan());
    // HOME_POSITION, when it comes, is the home altitude.
    p.ack(MavCmd::MAV_CMD_NAV_TAKEOFF, MavResult::MAV_RESULT_ACCEPTED);
    p.recv(
        1,
        1,
        MavMessage::HOME_POSITION(HOME_POSITION_DATA {
            altitude: 490_000,
            ..HOME_POSITION_DATA::DEFAULT
        }),
    );
    p.command(6, "takeoff", &[("alt", Value::Int(10))]);
    assert_eq!(p.one_long().param7, 500.0);
}

#[test]
fn no_ack_resends_with_confirmation_then_times_out() {
    let mut s = Sim::new(Firmware::Copter);
    s.command(1, "rtl", &[]);
    assert_eq!(s.one_long().confirmation, 0);
    for (n, t) in [(1, 1), (2, 2), (3, 3)] {
        s.at(t * S - 1);
        assert!(s.sent().is_empty(), "not before the timeout");
        s.at(t * S);
        assert_eq!(s.one_long().confirmation, n);
    }
    s.at(4 * S);
    assert!(s.sent().is_empty());
    assert_eq!(s.outcomes(), vec![(1, failed("timeout"))]);
}

#[test]
fn rejections_in_progress_and_temporary_rejection() {
    let mut s = Sim::new(Firmware::Copter);
    for (id, result, reason) in [
        (1, MavResult::MAV_RESULT_DENIED, "DENIED"),
        (2, MavResult::MAV_RESULT_UNSUPPORTED, "UNSUPPORTED"),
        (3, MavResult::MAV_RESULT_FAILED, "FAILED"),
    ] {
        s.command(id, "arm", &[]);
        s.one_long();
        s.ack(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, result);
        assert_eq!(s.outcomes(), vec![(id, failed(reason))]);
    }
    // IN_PROGRESS: keep waiting past the ack timeout, no resend.
    s.command(4, "takeoff", &[("alt", Value::Int(10))]);
    s.one_long();
    s.ack(
        MavCmd::MAV_CMD_NAV_TAKEOFF,
        MavResult::MAV_RESULT_IN_PROGRESS,
    );
    s.at(5 * S);
    assert!(s.sent().is_empty() && s.outcomes().is_empty());
    s.ack(MavCmd::MAV_CMD_NAV_TAKEOFF, MavResult::MAV_RESULT_ACCEPTED);
    assert_eq!(s.outcomes(), vec![(4, ok("ACCEPTED"))]);
    // TEMPORARILY_REJECTED, then ACCEPTED on the resend.
    s.command(5, "mode", &[("mode", Value::Str("AUTO".into()))]);
    s.one_long();
    s.ack(
        MavCmd::MAV_CMD_DO_SET_MODE,
        MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
    );
    assert!(s.outcomes().is_empty());
    s.at(6 * S);
    assert_eq!(s.one_long().confirmation, 1);
    s.ack(MavCmd::MAV_CMD_DO_SET_MODE, MavResult::MAV_RESULT_ACCEPTED);
    assert_eq!(s.outcomes(), vec![(5, ok("ACCEPTED"))]);
    // Always TEMPORARILY_REJECTED: bounded.
    s.command(6, "mode", &[("mode", Value::Str("AUTO".into()))]);
    let mut sends = 0;
    for t in 7..20 {
        sends += s.sent().len();
        s.ack(
            MavCmd::MAV_CMD_DO_SET_MODE,
            MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
        );
        s.at(t * S);
    }
    assert_eq!(sends, 4);
    assert_eq!(s.outcomes(), vec![(6, failed("TEMPORARILY_REJECTED"))]);
}

#[test]
fn one_command_per_mav_cmd_in_flight_and_forget() {
    let mut s = Sim::new(Firmware::Copter);
    s.command(1, "mode", &[("mode", Value::Str("GUIDED".into()))]);
    s.command(2, "mode", &[("mode", Value::Str("LAND".into()))]);
    s.command(3, "arm", &[]);
    let sent = s.sent();
    assert_eq!(sent.len(), 2, "the second mode change waits: {sent:?}");
    s.ack(MavCmd::MAV_CMD_DO_SET_MODE, MavResult::MAV_RESULT_ACCEPTED);
    assert_eq!(s.outcomes(), vec![(1, ok("ACCEPTED"))]);
    assert_eq!(s.one_long().param2, 9.0, "then LAND goes");
    // Forgotten while in flight: the late ack is swallowed, not given to the next.
    s.c.forget(2);
    s.command(4, "mode", &[("mode", Value::Str("RTL".into()))]);
    assert!(s.sent().is_empty(), "waits for the forgotten one's answer");
    s.ack(MavCmd::MAV_CMD_DO_SET_MODE, MavResult::MAV_RESULT_ACCEPTED);
    assert!(s.outcomes().is_empty());
    assert_eq!(s.one_long().param2, 6.0);
    // Forgotten while waiting: never sent, never reported.
    s.c.forget(3);
    s.ack(
        MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        MavResult::MAV_RESULT_ACCEPTED,
    );
    assert!(s.outcomes().is_empty());
    assert!(s.c.busy(), "RTL (4) is still in flight");
    s.ack(MavCmd::MAV_CMD_DO_SET_MODE, MavResult::MAV_RESULT_ACCEPTED);
    assert_eq!(s.outcomes(), vec![(4, ok("ACCEPTED"))]);
    assert!(!s.c.busy());
}

#[test]
fn acks_for_someone_else_are_ignored() {
    let mut s = Sim::new(Firmware::Copter);
    s.command(1, "rtl", &[]);
    s.one_long();
    // Addressed to the ground station (extension fields present).
    s.recv(
        1,
        1,
        MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
            command: MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH,
            result: MavResult::MAV_RESULT_ACCEPTED,
            target_system: 255,
            target_component: 190,
            ..COMMAND_ACK_DATA::DEFAULT
        }),
    );
    // From another system.
    s.recv(
        2,
        1,
        MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
            command: MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH,
            result: MavResult::MAV_RESULT_ACCEPTED,
            ..COMMAND_ACK_DATA::DEFAULT
        }),
    );
    assert!(s.outcomes().is_empty());
    // MAVLink 1 style ack without the extension fields: matched by command.
    s.recv(
        1,
        1,
        MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
            command: MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH,
            result: MavResult::MAV_RESULT_ACCEPTED,
            ..COMMAND_ACK_DATA::DEFAULT
        }),
    );
    assert_eq!(s.outcomes(), vec![(1, ok("ACCEPTED"))]);
}

#[test]
fn set_current_falls_back_to_mission_set_current() {
    let mut s = Sim::new(Firmware::Copter);
    s.command(1, "set_current", &[("seq", Value::Int(4))]);
    s.one_long();
    s.ack(
        MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT,
        MavResult::MAV_RESULT_UNSUPPORTED,
    );
    match s.sent().as_slice() {
        [MavMessage::MISSION_SET_CURRENT(m)] => assert_eq!(m.seq, 4),
        other => panic!("{other:?}"),
    }
    s.recv(
        1,
        1,
        MavMessage::MISSION_CURRENT(MISSION_CURRENT_DATA {
            seq: 2,
            ..MISSION_CURRENT_DATA::DEFAULT
        }),
    );
    assert!(s.outcomes().is_empty());
    s.recv(
        1,
        1,
        MavMessage::MISSION_CURRENT(MISSION_CURRENT_DATA {
            seq: 4,
            ..MISSION_CURRENT_DATA::DEFAULT
        }),
    );
    assert_eq!(s.outcomes(), vec![(1, ok("MISSION_CURRENT"))]);
}

#[test]
fn commands_before_the_vehicle_wait_then_fail() {
    let mut c = Commander::new(VehicleConfig::default());
    c.command(1, "arm", &Params::new(), 0);
    c.command(2, "takeoff", &Params::new(), 0);
    assert_eq!(
        c.poll_outcome(),
        Some((2, failed("takeoff: missing argument alt")))
    );
    c.tick(3 * S);
    assert!(c.poll_outcome().is_none());
    c.message(
        3 * S,
        &from(1, 1),
        &autopilot_heartbeat(
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            MavType::MAV_TYPE_QUADROTOR,
        ),
    );
    let sent: Vec<_> = std::iter::from_fn(|| c.poll_transmit()).collect();
    assert!(sent.iter().any(|m| matches!(m, MavMessage::COMMAND_LONG(l) if l.command == MavCmd::MAV_CMD_COMPONENT_ARM_DISARM)));
    let mut lone = Commander::new(VehicleConfig::default());
    lone.command(9, "rtl", &Params::new(), 0);
    lone.tick(
        lone.next_deadline()
            .expect("a deadline for the waiting command"),
    );
    assert_eq!(lone.poll_outcome(), Some((9, failed("no_vehicle"))));
}

fn items(n: usize) -> Value {
    Value::List(
        (0..n)
            .map(|i| {
                Value::Map(
                    [
                        ("lat".to_string(), Value::Float(43.0 + i as f64 * 0.001)),
                        ("lon".to_string(), Value::Float(1.0)),
                        ("alt".to_string(), Value::Int(100)),
                    ]
                    .into(),
                )
            })
            .collect(),
    )
}

fn request_int(seq: u16) -> MavMessage {
    MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
        seq,
        target_system: 1,
        target_component: 191,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
    })
}

fn mission_ack(result: MavMissionResult) -> MavMessage {
    MavMessage::MISSION_ACK(MISSION_ACK_DATA {
        target_system: 1,
        target_component: 191,
        mavtype: result,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        opaque_id: 0,
    })
}

fn item_seqs(sent: &[MavMessage]) -> Vec<u16> {
    sent.iter()
        .filter_map(|m| match m {
            MavMessage::MISSION_ITEM_INT(i) => Some(i.seq),
            _ => None,
        })
        .collect()
}

#[test]
fn mission_upload_with_duplicates_out_of_order_and_home() {
    let mut s = Sim::new(Firmware::Copter);
    s.recv(
        1,
        1,
        MavMessage::HOME_POSITION(HOME_POSITION_DATA {
            latitude: -353_632_610,
            longitude: 1_491_652_300,
            altitude: 584_000,
            ..HOME_POSITION_DATA::DEFAULT
        }),
    );
    s.command(1, "upload_mission", &[("items", items(3))]);
    match s.sent().as_slice() {
        [MavMessage::MISSION_COUNT(c)] => assert_eq!(c.count, 4, "home + 3"),
        other => panic!("{other:?}"),
    }
    let mut got = Vec::new();
    for seq in [0, 1, 1, 3, 2] {
        s.recv(1, 1, request_int(seq));
        let sent = s.sent();
        if seq == 0 {
            match &sent[0] {
                MavMessage::MISSION_ITEM_INT(i) => {
                    assert_eq!(
                        (i.x, i.y, i.frame),
                        (-353_632_610, 1_491_652_300, MavFrame::MAV_FRAME_GLOBAL)
                    )
                }
                other => panic!("{other:?}"),
            }
        }
        if seq == 1 {
            match &sent[0] {
                MavMessage::MISSION_ITEM_INT(i) => {
                    assert_eq!(
                        (i.x, i.z, i.command),
                        (430_000_000, 100.0, MavCmd::MAV_CMD_NAV_WAYPOINT)
                    );
                    assert_eq!(i.frame, MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT);
                }
                other => panic!("{other:?}"),
            }
        }
        got.extend(item_seqs(&sent));
    }
    assert_eq!(got, vec![0, 1, 1, 3, 2]);
    // A request beyond the count is ignored.
    s.recv(1, 1, request_int(9));
    assert!(s.sent().is_empty());
    s.recv(1, 1, mission_ack(MavMissionResult::MAV_MISSION_ACCEPTED));
    let out = s.outcomes();
    assert_eq!(out.len(), 1);
    match &out[0] {
        (1, Outcome::Done(p)) => assert_eq!(p.get("count"), Some(&Value::Int(4))),
        other => panic!("{other:?}"),
    }
}

#[test]
fn mission_upload_px4_starts_at_zero_and_accepts_mission_request() {
    let mut s = Sim::new(Firmware::Px4);
    s.command(1, "upload_mission", &[("items", items(2))]);
    match s.sent().as_slice() {
        [MavMessage::MISSION_COUNT(c)] => assert_eq!(c.count, 2),
        other => panic!("{other:?}"),
    }
    for seq in 0..2 {
        s.recv(
            1,
            1,
            MavMessage::MISSION_REQUEST(MISSION_REQUEST_DATA {
                seq,
                target_system: 1,
                target_component: 191,
                mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            }),
        );
        match s.sent().as_slice() {
            [MavMessage::MISSION_ITEM_INT(i)] => {
                assert_eq!(i.seq, seq);
                assert_eq!(i.x, 430_000_000 + seq as i32 * 10_000);
            }
            other => panic!("{other:?}"),
        }
    }
    s.recv(1, 1, mission_ack(MavMissionResult::MAV_MISSION_ACCEPTED));
    // PX4 checks the mission after accepting it and refuses MISSION_START
    // until then: done only once MISSION_CURRENT shows it valid.
    assert!(s.outcomes().is_empty());
    s.recv(
        1,
        1,
        px4_mission_current(0, MissionState::MISSION_STATE_NO_MISSION),
    );
    assert!(s.outcomes().is_empty());
    s.recv(
        1,
        1,
        px4_mission_current(2, MissionState::MISSION_STATE_NOT_STARTED),
    );
    assert!(matches!(s.outcomes().as_slice(), [(1, Outcome::Done(_))]));
}

fn px4_mission_current(total: u16, mission_state: MissionState) -> MavMessage {
    MavMessage::MISSION_CURRENT(MISSION_CURRENT_DATA {
        total,
        mission_state,
        ..MISSION_CURRENT_DATA::DEFAULT
    })
}

#[test]
fn a_px4_mission_accepted_then_found_infeasible_fails_invalid() {
    let mut s = Sim::new(Firmware::Px4);
    s.command(1, "upload_mission", &[("items", items(2))]);
    s.sent();
    for seq in 0..2 {
        s.recv(
            1,
            1,
            MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
                seq,
                target_system: 1,
                target_component: 191,
                mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            }),
        );
    }
    s.recv(1, 1, mission_ack(MavMissionResult::MAV_MISSION_ACCEPTED));
    s.recv(
        1,
        1,
        px4_mission_current(2, MissionState::MISSION_STATE_NO_MISSION),
    );
    // ack_timeout 1 s × (mission_retries 5 + 1): still checking at 5 s.
    s.at(5_000_000);
    assert!(s.outcomes().is_empty());
    s.at(6_500_000);
    assert_eq!(s.outcomes(), vec![(1, Outcome::Failed("INVALID".into()))]);
}

#[test]
fn a_px4_mission_never_shown_is_taken_as_accepted() {
    let mut s = Sim::new(Firmware::Px4);
    s.command(1, "upload_mission", &[("items", items(1))]);
    s.recv(
        1,
        1,
        MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq: 0,
            target_system: 1,
            target_component: 191,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        }),
    );
    s.recv(1, 1, mission_ack(MavMissionResult::MAV_MISSION_ACCEPTED));
    s.at(6_500_000);
    assert!(matches!(s.outcomes().as_slice(), [(1, Outcome::Done(_))]));
}

#[test]
fn mission_errors_retries_and_timeouts() {
    // A failing ack the vehicle does not follow up: failed with its name.
    let mut s = Sim::new(Firmware::Copter);
    s.command(1, "upload_mission", &[("items", items(2))]);
    s.sent();
    s.recv(1, 1, request_int(0));
    s.recv(1, 1, mission_ack(MavMissionResult::MAV_MISSION_NO_SPACE));
    assert!(s.outcomes().is_empty());
    s.at(S / 2);
    s.at(S + S / 2);
    assert_eq!(s.outcomes(), vec![(1, failed("NO_SPACE"))]);
    // A failing ack, then the vehicle keeps asking: the upload goes on.
    s.command(2, "upload_mission", &[("items", items(1))]);
    s.sent();
    s.recv(1, 1, request_int(0));
    s.recv(
        1,
        1,
        mission_ack(MavMissionResult::MAV_MISSION_INVALID_SEQUENCE),
    );
    s.recv(1, 1, request_int(1));
    assert_eq!(item_seqs(&s.sent()), vec![0, 1]);
    s.recv(1, 1, mission_ack(MavMissionResult::MAV_MISSION_ACCEPTED));
    assert!(matches!(s.outcomes().as_slice(), [(2, Outcome::Done(_))]));
    // Silence: MISSION_COUNT resent a bounded number of times, then cancelled.
    s.at(10 * S);
    s.command(3, "upload_mission", &[("items", items(1))]);
    let mut counts = s.sent().len();
    for t in 11..20 {
        s.at(t * S);
        for m in s.sent() {
            match m {
                MavMessage::MISSION_COUNT(_) => counts += 1,
                MavMessage::MISSION_ACK(a) => {
                    assert_eq!(a.mavtype, MavMissionResult::MAV_MISSION_OPERATION_CANCELLED)
                }
                other => panic!("{other:?}"),
            }
        }
    }
    assert_eq!(counts, 6, "first send and 5 retries");
    assert_eq!(s.outcomes(), vec![(3, failed("timeout"))]);
    // Forgotten mid-upload: cancelled on the vehicle, nothing reported.
    s.command(4, "upload_mission", &[("items", items(1))]);
    s.sent();
    s.c.forget(4);
    assert!(matches!(s.sent().as_slice(), [MavMessage::MISSION_ACK(_)]));
    assert!(!s.c.busy());
}

#[test]
fn events_are_never_asked_for_and_a_denied_message_falls_back_only_by_its_group() {
    // Real ArduPlane 4.7 answers DENIED for STATUSTEXT, COMMAND_ACK,
    // RADIO_STATUS and RADIO, and re-sends its last MISSION_ITEM_REACHED on
    // every period when asked for it: none of them is asked for.
    let mut s = Sim::new(Firmware::Plane);
    s.c.request_streams(
        &[
            (253, 4.0),
            (77, 4.0),
            (109, 4.0),
            (166, 4.0),
            (46, 4.0),
            (225, 4.0),
            (33, 4.0),
        ],
        0,
    );
    // EFI_STATUS (in no stream group) is DENIED: nothing else asks for it
    // (REQUEST_DATA_STREAM would have to ask for every stream).
    assert_eq!(s.one_long().param1, 225.0);
    s.ack(
        MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
        MavResult::MAV_RESULT_DENIED,
    );
    // GLOBAL_POSITION_INT is DENIED too: its group, POSITION, is asked for.
    let c = s.one_long();
    assert_eq!(
        (c.command, c.param1),
        (MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, 33.0)
    );
    s.ack(
        MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
        MavResult::MAV_RESULT_DENIED,
    );
    let rest: Vec<MavMessage> = s.sent();
    #[allow(deprecated)]
    let streams: Vec<MavDataStream> = rest
        .iter()
        .filter_map(|m| match m {
            MavMessage::REQUEST_DATA_STREAM(r) => Some(r.req_stream_id),
            _ => None,
        })
        .collect();
    assert_eq!(
        streams,
        [MavDataStream::MAV_DATA_STREAM_POSITION],
        "{rest:?}"
    );
    assert!(
        !rest
            .iter()
            .any(|m| matches!(m, MavMessage::COMMAND_LONG(_))),
        "{rest:?}"
    );
}

#[test]
fn streams_are_asked_again_after_the_autopilot_reboots() {
    let mut s = Sim::new(Firmware::Plane);
    let system_time = |ms: u32| {
        MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
            time_unix_usec: 0,
            time_boot_ms: ms,
        })
    };
    s.c.request_streams(&[(33, 4.0)], 0);
    assert_eq!(s.one_long().param1, 33.0);
    s.ack(
        MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
        MavResult::MAV_RESULT_ACCEPTED,
    );
    s.recv(1, 1, system_time(600_000));
    s.at(S / 2);
    s.recv(1, 1, system_time(600_500));
    // Time going on, or back by less than 2 s: nothing asked.
    s.recv(1, 1, system_time(599_000));
    assert!(s.sent().is_empty());
    // Back to the start of a boot (a silence shorter than the link
    // timeout): the intervals are forgotten, asked again.
    s.at(S);
    s.recv(1, 1, system_time(700));
    assert_eq!(s.one_long().param1, 33.0);
    assert!(!s.c.link_lost());
}

#[test]
fn streams_by_interval_then_fallback_and_again_after_link_loss() {
    let mut s = Sim::new(Firmware::Copter);
    s.c.request_streams(&[(33, 4.0), (1, 2.0)], 0);
    let c = s.one_long();
    assert_eq!(
        (c.command, c.param1, c.param2),
        (MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, 33.0, 250_000.0)
    );
    s.ack(
        MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
        MavResult::MAV_RESULT_ACCEPTED,
    );
    let c = s.one_long();
    assert_eq!((c.param1, c.param2), (1.0, 500_000.0));
    s.ack(
        MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
        MavResult::MAV_RESULT_ACCEPTED,
    );
    assert!(s.sent().is_empty());
    // Link lost, then back: asked again.
    s.at(4 * S);
    assert!(s.c.link_lost());
    s.recv(
        1,
        1,
        autopilot_heartbeat(
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            MavType::MAV_TYPE_QUADROTOR,
        ),
    );
    assert!(!s.c.link_lost());
    assert_eq!(s.one_long().param1, 33.0);
    // This time UNSUPPORTED: the rest goes by REQUEST_DATA_STREAM.
    s.ack(
        MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
        MavResult::MAV_RESULT_UNSUPPORTED,
    );
    let streams: Vec<(MavDataStream, u16)> = s
        .sent()
        .iter()
        .map(|m| match m {
            MavMessage::REQUEST_DATA_STREAM(r) => (r.req_stream_id, r.req_message_rate),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(
        streams,
        vec![
            (MavDataStream::MAV_DATA_STREAM_POSITION, 4),
            (MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS, 2)
        ]
    );
    // The autopilot keeps talking but never answers: fallback after the retries.
    let mut q = Sim::new(Firmware::Copter);
    q.c.request_streams(&[(30, 10.0)], 0);
    q.one_long();
    q.now = S / 2;
    q.recv(
        1,
        1,
        autopilot_heartbeat(
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            MavType::MAV_TYPE_QUADROTOR,
        ),
    );
    q.at(S);
    assert_eq!(q.one_long().confirmation, 1);
    q.at(2 * S);
    match q.sent().as_slice() {
        [MavMessage::REQUEST_DATA_STREAM(r)] => assert_eq!(
            (r.req_stream_id, r.req_message_rate, r.start_stop),
            (MavDataStream::MAV_DATA_STREAM_EXTRA1, 10, 1)
        ),
        other => panic!("{other:?}"),
    }
    // Total silence is the link, not the command: asked again, no fallback.
    let mut r = Sim::new(Firmware::Copter);
    r.at(S / 2);
    r.c.request_streams(&[(30, 10.0)], S / 2);
    assert_eq!(r.one_long().confirmation, 0);
    r.at(S + S / 2);
    assert_eq!(r.one_long().confirmation, 1);
    r.at(2 * S + S / 2);
    let again = r.one_long();
    assert_eq!(
        (again.command, again.confirmation),
        (MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, 0)
    );
}

#[test]
fn garbage_from_the_vehicle_never_panics() {
    let mut s = Sim::new(Firmware::Copter);
    s.command(1, "upload_mission", &[("items", items(1))]);
    s.command(2, "arm", &[]);
    for seq in [u16::MAX, 0, 65000] {
        s.recv(1, 1, request_int(seq));
    }
    s.recv(
        1,
        1,
        MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
            alt: i32::MIN,
            relative_alt: i32::MAX,
            ..GLOBAL_POSITION_INT_DATA::DEFAULT
        }),
    );
    s.recv(
        1,
        1,
        MavMessage::MISSION_CURRENT(MISSION_CURRENT_DATA::DEFAULT),
    );
    s.c.message(
        s.now,
        &MavHeader {
            system_id: 70_000,
            component_id: 1,
            sequence: 0,
        },
        &request_int(0),
    );
    for r in [
        MavResult::MAV_RESULT_CANCELLED,
        MavResult::MAV_RESULT_COMMAND_INT_ONLY,
    ] {
        s.ack(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, r);
    }
    for t in 1..=20 {
        s.at(t * S);
    }
    let _ = s.sent();
    let out = s.outcomes();
    assert_eq!(out.len(), 2, "{out:?}");
}

/// A small deterministic generator (xorshift64*), so that failures replay.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

/// Random traffic from the vehicle (any field values the dialect decodes),
/// random commands, forgets and time jumps: nothing panics, every command
/// gets exactly one outcome unless forgotten, and once the vehicle falls
/// silent every command is answered in bounded time.
#[test]
fn random_traffic_never_panics_and_every_command_is_answered() {
    use mavlink::{MavlinkVersion, Message};
    let ids = [0u32, 77, 40, 51, 47, 42, 33, 242];
    let verbs: [(&str, Params); 8] = [
        ("arm", Params::new()),
        ("mode", params(&[("mode", Value::Str("AUTO".into()))])),
        ("takeoff", params(&[("alt", Value::Int(10))])),
        ("rtl", Params::new()),
        ("set_current", params(&[("seq", Value::Int(2))])),
        ("upload_mission", params(&[("items", items(2))])),
        (
            "goto",
            params(&[
                ("lat", Value::Float(1.0)),
                ("lon", Value::Float(2.0)),
                ("alt", Value::Int(5)),
            ]),
        ),
        (
            "payload_start",
            params(&[("payload", Value::Str("camera".into()))]),
        ),
    ];
    let (mut done, mut failed_count) = (0, 0);
    for seed in 1..=150u64 {
        let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
        let fw = [Firmware::Copter, Firmware::Plane, Firmware::Px4][(seed % 3) as usize];
        let mut s = Sim::new(fw);
        let mut issued = std::collections::BTreeSet::new();
        let mut forgotten = std::collections::BTreeSet::new();
        let mut answered: std::collections::BTreeMap<u64, usize> = Default::default();
        let mut next_id = 1u64;
        let mut recent: Vec<MavMessage> = Vec::new();
        for _ in 0..300 {
            match rng.below(12) {
                10 | 11 if !recent.is_empty() => {
                    // An answer to something we sent, with a random result.
                    let m = recent[rng.below(recent.len() as u64) as usize].clone();
                    let answer = match m {
                        MavMessage::COMMAND_LONG(c) => Some((
                            c.target_component,
                            MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                                command: c.command,
                                result: num_traits::FromPrimitive::from_u64(rng.below(11))
                                    .unwrap_or(MavResult::MAV_RESULT_ACCEPTED),
                                target_system: 1,
                                target_component: 191,
                                ..COMMAND_ACK_DATA::DEFAULT
                            }),
                        )),
                        MavMessage::COMMAND_INT(c) => Some((
                            c.target_component,
                            MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                                command: c.command,
                                result: num_traits::FromPrimitive::from_u64(rng.below(11))
                                    .unwrap_or(MavResult::MAV_RESULT_ACCEPTED),
                                ..COMMAND_ACK_DATA::DEFAULT
                            }),
                        )),
                        MavMessage::MISSION_COUNT(_) | MavMessage::MISSION_ITEM_INT(_) => Some((
                            1,
                            match rng.below(3) {
                                0 => mission_ack(
                                    num_traits::FromPrimitive::from_u64(rng.below(16))
                                        .unwrap_or(MavMissionResult::MAV_MISSION_ACCEPTED),
                                ),
                                _ => request_int(rng.below(5) as u16),
                            },
                        )),
                        _ => None,
                    };
                    if let Some((comp, a)) = answer {
                        s.recv(1, comp, a);
                    }
                }
                0..=5 => {
                    let id = ids[rng.below(ids.len() as u64) as usize];
                    let mut payload = vec![0u8; 64];
                    for b in payload.iter_mut() {
                        *b = rng.below(256) as u8;
                    }
                    // Mostly small numbers, so that results and sequence numbers hit.
                    for b in payload.iter_mut().skip(2) {
                        if rng.below(2) == 0 {
                            *b %= 8;
                        }
                    }
                    if let Ok(m) = MavMessage::parse(MavlinkVersion::V2, id, &payload) {
                        let comp = [1, 1, 1, 100, 0][rng.below(5) as usize];
                        s.recv(1, comp, m);
                    }
                }
                6 | 7 => {
                    let (verb, args) = &verbs[rng.below(verbs.len() as u64) as usize];
                    s.c.command(next_id, verb, args, s.now);
                    issued.insert(next_id);
                    next_id += 1;
                }
                8 if next_id > 1 => {
                    let id = 1 + rng.below(next_id - 1);
                    if !answered.contains_key(&id) {
                        s.c.forget(id);
                        forgotten.insert(id);
                    }
                }
                _ => {
                    let t = s.now + rng.below(1_500_000);
                    s.at(t);
                }
            }
            for m in s.sent() {
                if recent.len() >= 8 {
                    recent.remove(0);
                }
                recent.push(m);
            }
            for (id, o) in s.outcomes() {
                *answered.entry(id).or_default() += 1;
                match o {
                    Outcome::Done(_) => done += 1,
                    Outcome::Failed(_) => failed_count += 1,
                }
            }
        }
        // The vehicle falls silent: everything ends within the bounds.
        let end = s.now + 600 * S;
        while s.now < end {
            let t = s.now + S;
            s.at(t);
            let _ = s.sent();
            for (id, _) in s.outcomes() {
                *answered.entry(id).or_default() += 1;
            }
        }
        for id in &issued {
            let n = answered.get(id).copied().unwrap_or(0);
            if forgotten.contains(id) {
                assert!(n <= 1, "seed {seed}: forgotten {id} answered {n} times");
            } else {
                assert_eq!(n, 1, "seed {seed}: command {id} answered {n} times");
            }
        }
        assert!(!s.c.busy(), "seed {seed}: still busy");
    }
    assert!(
        done > 100 && failed_count > 100,
        "the traffic reaches both ends: {done} done, {failed_count} failed"
    );
}

#[test]
fn configured_target_still_learns_the_firmware() {
    let config = VehicleConfig {
        system: Some(4),
        autopilot_component: Some(1),
        ..VehicleConfig::default()
    };
    let mut c = Commander::new(config);
    c.tick(0);
    assert_eq!(c.identity(), Some((4, 191)));
    assert!(
        matches!(c.poll_transmit(), Some(MavMessage::HEARTBEAT(_))),
        "heartbeat before hearing the vehicle"
    );
    c.command(
        1,
        "mode",
        &params(&[("mode", Value::Str("POSCTL".into()))]),
        0,
    );
    assert!(c.poll_transmit().is_none(), "waits for the firmware");
    c.message(
        10,
        &from(4, 1),
        &autopilot_heartbeat(MavAutopilot::MAV_AUTOPILOT_PX4, MavType::MAV_TYPE_QUADROTOR),
    );
    assert_eq!(c.firmware(), Some(Firmware::Px4));
    match c.poll_transmit() {
        Some(MavMessage::COMMAND_LONG(l)) => {
            assert_eq!((l.target_system, l.param2), (4, 3.0));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn forgotten_in_flight_stops_retrying_and_reports_nothing() {
    let mut s = Sim::new(Firmware::Copter);
    s.command(1, "rtl", &[]);
    assert_eq!(s.one_long().confirmation, 0);
    s.c.forget(1);
    for t in 1..10 {
        s.at(t * S);
        assert!(s.sent().is_empty(), "no resend after forget");
    }
    assert!(s.outcomes().is_empty());
    assert!(!s.c.busy());
    // The MAV_CMD is free again for the next command.
    s.command(2, "rtl", &[]);
    assert_eq!(s.one_long().confirmation, 0);
    // A result already waiting to be polled is withdrawn too.
    s.ack(
        MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH,
        MavResult::MAV_RESULT_DENIED,
    );
    s.c.forget(2);
    assert!(s.outcomes().is_empty());
}

#[test]
fn quadplane_takes_off_vertically_and_lands_in_qland() {
    let config = VehicleConfig {
        quadplane: true,
        ..VehicleConfig::default()
    };
    let mut c = Commander::new(config);
    c.message(
        0,
        &from(1, 1),
        &autopilot_heartbeat(
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            MavType::MAV_TYPE_VTOL_TILTROTOR,
        ),
    );
    assert_eq!(c.firmware(), Some(Firmware::Plane));
    c.command(1, "takeoff", &params(&[("alt", Value::Int(25))]), 0);
    c.command(2, "land", &Params::new(), 0);
    let sent: Vec<(MavCmd, f32, f32)> = std::iter::from_fn(|| c.poll_transmit())
        .filter_map(|m| match m {
            MavMessage::COMMAND_LONG(l) => Some((l.command, l.param2, l.param7)),
            _ => None,
        })
        .collect();
    assert_eq!(
        sent,
        vec![
            (MavCmd::MAV_CMD_NAV_TAKEOFF, 0.0, 25.0),
            (MavCmd::MAV_CMD_DO_SET_MODE, 20.0, 0.0),
        ]
    );
}

#[test]
fn the_projects_parameters_are_read_from_the_autopilot_and_judged() {
    use super::parameters::Expected;
    let mut config = VehicleConfig::default();
    config
        .parameters
        .push(("RTL_AUTOLAND".into(), Expected::OneOf(vec![1.0, 2.0])));
    let mut c = Commander::new(config);
    assert_eq!(c.armed(), None);
    let mut hb = autopilot_heartbeat(
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        MavType::MAV_TYPE_FIXED_WING,
    );
    c.message(0, &from(1, 1), &hb);
    let asked: Vec<MavMessage> = std::iter::from_fn(|| c.poll_transmit())
        .filter(|m| matches!(m, MavMessage::PARAM_REQUEST_READ(_)))
        .collect();
    match asked.as_slice() {
        [MavMessage::PARAM_REQUEST_READ(r)] => {
            assert_eq!(r.param_id.to_str(), Ok("RTL_AUTOLAND"));
            assert_eq!((r.target_system, r.target_component), (1, 1));
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(c.armed(), Some(false));
    // Another vehicle's answer is not ours.
    let value = |v: f32| {
        MavMessage::PARAM_VALUE(PARAM_VALUE_DATA {
            param_value: v,
            param_count: 1406,
            param_index: 65535,
            param_id: "RTL_AUTOLAND".into(),
            param_type: MavParamType::MAV_PARAM_TYPE_INT8,
        })
    };
    c.message(S / 10, &from(2, 1), &value(2.0));
    assert_eq!(c.poll_parameters(), None);
    // The nets' commands wait for the verdict.
    c.command(7, "arm", &Params::new(), S / 10);
    c.command(8, "upload_mission", &params(&[("items", items(3))]), S / 10);
    let held: Vec<MavMessage> = std::iter::from_fn(|| c.poll_transmit())
        .filter(|m| !matches!(m, MavMessage::HEARTBEAT(_)))
        .collect();
    assert!(held.is_empty(), "{held:?}");
    c.message(S / 5, &from(1, 1), &value(0.0));
    let arm: Vec<MavMessage> = std::iter::from_fn(|| c.poll_transmit())
        .filter(|m| {
            matches!(
                m,
                MavMessage::COMMAND_LONG(_) | MavMessage::MISSION_COUNT(_)
            )
        })
        .collect();
    assert_eq!(arm.len(), 2, "sent once judged: {arm:?}");
    let verdict = c.poll_parameters().expect("judged");
    assert_eq!(
        verdict
            .misfits
            .iter()
            .map(|m| m.to_string())
            .collect::<Vec<_>>(),
        ["RTL_AUTOLAND is 0 on the vehicle; the project needs one of 1, 2"]
    );
    if let MavMessage::HEARTBEAT(h) = &mut hb {
        h.base_mode = MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
    }
    c.message(S, &from(1, 1), &hb);
    assert_eq!(c.armed(), Some(true));
}

#[test]
fn a_denied_mission_start_is_tried_again_on_px4_only() {
    // PX4 v1.18 denies a MISSION_START for a moment after its upload showed
    // checked: tried again after 1 s, then 2 s, then 3 s.
    let mut s = Sim::new(Firmware::Px4);
    s.command(1, "start_mission", &[]);
    assert_eq!(s.one_long().command, MavCmd::MAV_CMD_MISSION_START);
    s.ack(MavCmd::MAV_CMD_MISSION_START, MavResult::MAV_RESULT_DENIED);
    assert!(s.outcomes().is_empty());
    s.at(S / 2);
    assert!(s.sent().is_empty(), "the back-off is a whole ack_timeout");
    s.at(S);
    s.one_long();
    s.ack(MavCmd::MAV_CMD_MISSION_START, MavResult::MAV_RESULT_DENIED);
    s.at(2 * S + S / 2);
    assert!(s.sent().is_empty(), "the second back-off is two");
    s.at(3 * S);
    s.one_long();
    s.ack(
        MavCmd::MAV_CMD_MISSION_START,
        MavResult::MAV_RESULT_ACCEPTED,
    );
    assert_eq!(s.outcomes(), vec![(1, ok("ACCEPTED"))]);
    // Always denied (no valid mission): bounded, the reason by name.
    s.command(2, "start_mission", &[]);
    let mut sends = 0;
    for t in 4..20 {
        let sent = s.sent().len();
        if sent > 0 {
            sends += sent;
            s.ack(MavCmd::MAV_CMD_MISSION_START, MavResult::MAV_RESULT_DENIED);
        }
        s.at(t * S);
    }
    assert_eq!(sends, 4);
    assert_eq!(s.outcomes(), vec![(2, failed("DENIED"))]);
    // Another command's DENIED stays final on PX4.
    s.command(3, "arm", &[]);
    s.sent();
    s.ack(
        MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        MavResult::MAV_RESULT_DENIED,
    );
    assert_eq!(s.outcomes(), vec![(3, failed("DENIED"))]);

    // ArduPilot's DENIED MISSION_START is final: it means no mission, or
    // not in a state to start one.
    let mut s = Sim::new(Firmware::Copter);
    s.command(1, "start_mission", &[]);
    s.one_long();
    s.ack(MavCmd::MAV_CMD_MISSION_START, MavResult::MAV_RESULT_DENIED);
    assert_eq!(s.outcomes(), vec![(1, failed("DENIED"))]);
    s.at(5 * S);
    assert!(s.sent().is_empty());
}
