//! Rules on synthetic frames: each rule option and expression form, seen
//! through the elaborator.

use elaboration::frame::{extra_crc, serialize};
use elaboration::{Config, Elaborated, Elaborator, Frame, Profile};
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};

const S: u64 = 1_000_000;

fn profile(text: &str) -> Profile {
    Profile::load(&[("test.toml", text)]).unwrap_or_else(|e| panic!("{e}"))
}

fn header(sysid: u8, compid: u8, seq: u8) -> MavHeader {
    MavHeader {
        system_id: sysid as u32,
        component_id: compid,
        sequence: seq,
    }
}

fn heartbeat(armed: bool, custom_mode: u32, status: MavState) -> MavMessage {
    let mut base = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
    if armed {
        base |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
    }
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode,
        mavtype: MavType::MAV_TYPE_QUADROTOR,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: base,
        system_status: status,
        mavlink_version: 3,
    })
}

fn gcs_heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        mavtype: MavType::MAV_TYPE_GCS,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        ..HEARTBEAT_DATA::DEFAULT
    })
}

fn sys_status(remaining: i8) -> MavMessage {
    let mut d = SYS_STATUS_DATA::DEFAULT;
    d.battery_remaining = remaining;
    MavMessage::SYS_STATUS(d)
}

fn text(t: &str) -> MavMessage {
    let mut bytes = [0u8; 50];
    bytes[..t.len()].copy_from_slice(t.as_bytes());
    let mut d = STATUSTEXT_DATA::DEFAULT;
    d.text = mavlink::types::CharArray::new(bytes);
    MavMessage::STATUSTEXT(d)
}

/// Feeds messages from the autopilot 1/1 through frames (bytes, CRC,
/// decoding) and collects the events.
struct Run {
    elab: Elaborator,
    seq: u8,
    out: Vec<Elaborated>,
}

impl Run {
    fn new(text: &str) -> Run {
        Run {
            elab: Elaborator::new(profile(text), Config::default()),
            seq: 0,
            out: Vec::new(),
        }
    }

    fn from(&mut self, t: u64, sysid: u8, compid: u8, msg: &MavMessage) -> &mut Self {
        let bytes = serialize(header(sysid, compid, self.seq), MavlinkVersion::V2, msg);
        self.seq = self.seq.wrapping_add(1);
        let frame = Frame::parse(&bytes).expect("valid frame");
        self.elab.frame(t, &frame);
        self.elab.drain_into(&mut self.out);
        self
    }

    fn send(&mut self, t: u64, msg: &MavMessage) -> &mut Self {
        self.from(t, 1, 1, msg)
    }

    fn tick(&mut self, t: u64) -> &mut Self {
        self.elab.tick(t);
        self.elab.drain_into(&mut self.out);
        self
    }

    fn names(&self) -> Vec<(u64, String)> {
        self.out
            .iter()
            .map(|e| (e.time_us, crate::summary(e)))
            .collect()
    }
}

#[test]
fn edges_fire_once_and_initial_decides_the_start() {
    let rules = r#"
[rules.armed]
category = "nominal"
when = "HEARTBEAT.base_mode & MAV_MODE_FLAG_SAFETY_ARMED"
initial = false
[rules.critical]
category = "safety"
when = "HEARTBEAT.system_status == MAV_STATE_CRITICAL"
"#;
    let mut r = Run::new(rules);
    // Starts armed and critical: `armed` is silent (initial = false), the
    // critical state is reported (initial defaults to true).
    r.send(0, &heartbeat(true, 0, MavState::MAV_STATE_CRITICAL));
    r.send(S, &heartbeat(true, 0, MavState::MAV_STATE_CRITICAL));
    r.send(2 * S, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    r.send(3 * S, &heartbeat(true, 0, MavState::MAV_STATE_STANDBY));
    r.send(4 * S, &heartbeat(true, 0, MavState::MAV_STATE_STANDBY));
    assert_eq!(
        r.names(),
        vec![(0, "critical".into()), (3 * S, "armed".into())]
    );
}

#[test]
fn modes_by_name_and_changed_with_each() {
    let rules = r#"
[rules.mode_changed]
category = "nominal"
when = "changed(mode())"
each = true
params = { mode = "mode()" }
[rules.in_rtl]
category = "mission"
when = "mode() == \"RTL\""
"#;
    let mut r = Run::new(rules);
    r.send(0, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    r.send(S, &heartbeat(false, 5, MavState::MAV_STATE_STANDBY));
    r.send(2 * S, &heartbeat(false, 6, MavState::MAV_STATE_STANDBY));
    r.send(3 * S, &heartbeat(false, 6, MavState::MAV_STATE_STANDBY));
    assert_eq!(
        r.names(),
        vec![
            (S, "mode_changed {mode: \"LOITER\"}".into()),
            (2 * S, "mode_changed {mode: \"RTL\"}".into()),
            (2 * S, "in_rtl".into()),
        ]
    );
}

#[test]
fn for_debounces_and_clear_gives_hysteresis_and_a_cleared_event() {
    let rules = r#"
[rules.battery_low]
category = "safety"
when = "SYS_STATUS.battery_remaining >= 0 && SYS_STATUS.battery_remaining < 25"
for = "2s"
clear = "SYS_STATUS.battery_remaining >= 30"
cleared = "battery_ok"
cleared_category = "nominal"
params = { remaining = "SYS_STATUS.battery_remaining" }
"#;
    let mut r = Run::new(rules);
    r.send(0, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    r.send(S, &sys_status(20));
    r.send(2 * S, &sys_status(40)); // 1 s below: debounced away
    r.send(3 * S, &sys_status(20));
    r.tick(4 * S + S / 2);
    assert!(r.out.is_empty(), "{:?}", r.names());
    r.tick(5 * S); // held 2 s: fires on the tick
    r.send(6 * S, &sys_status(27)); // above 25 but below 30: still low
    r.send(7 * S, &sys_status(22));
    r.send(8 * S, &sys_status(31));
    assert_eq!(
        r.names(),
        vec![
            (5 * S, "battery_low {remaining: 20}".into()),
            (8 * S, "battery_ok".into())
        ]
    );
    assert_eq!(r.out[1].event.category, nets::Category::Nominal);
    assert_eq!(r.out[0].event.category, nets::Category::Safety);
}

#[test]
fn age_fires_between_frames_and_restores_on_the_frame() {
    let rules = r#"
[rules.link_lost]
category = "communication"
when = "age(HEARTBEAT) > 3.5"
cleared = "link_restored"
"#;
    let mut r = Run::new(rules);
    for t in 0..3 {
        r.send(t * S, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    }
    // A 3 s gap (2 -> 5) does not fire; then silence from 5 s.
    r.send(5 * S, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    r.tick(8 * S);
    assert!(r.out.is_empty());
    r.tick(9 * S);
    r.send(
        12 * S + 7,
        &heartbeat(false, 0, MavState::MAV_STATE_STANDBY),
    );
    let names = r.names();
    assert_eq!(names.len(), 2, "{names:?}");
    assert_eq!(names[0].1, "link_lost");
    assert!(
        names[0].0 > 8 * S + S / 2 && names[0].0 <= 8 * S + S / 2 + 100_000,
        "{names:?}"
    );
    assert_eq!(names[1], (12 * S + 7, "link_restored".into()));
}

#[test]
fn liveness_counts_frames_that_do_not_decode() {
    let rules = r#"
[rules.link_lost]
category = "communication"
when = "age(HEARTBEAT) > 3.5"
[rules.armed]
category = "nominal"
when = "HEARTBEAT.base_mode & MAV_MODE_FLAG_SAFETY_ARMED"
"#;
    let mut elab = Elaborator::new(profile(rules), Config::default());
    let ok = serialize(
        header(1, 1, 0),
        MavlinkVersion::V2,
        &heartbeat(false, 0, MavState::MAV_STATE_STANDBY),
    );
    elab.frame(0, &Frame::parse(&ok).expect("frame"));
    // A newer firmware's MAV_TYPE (250): valid CRC, but rust-mavlink
    // rejects the message.
    for i in 1..10u64 {
        let mut bytes = serialize(
            header(1, 1, i as u8),
            MavlinkVersion::V2,
            &heartbeat(true, 0, MavState::MAV_STATE_STANDBY),
        );
        bytes[10 + 4] = 250;
        let end = bytes.len() - 2;
        let crc = mavlink::calculate_crc(&bytes[1..end], extra_crc(0).expect("HEARTBEAT"));
        bytes[end..].copy_from_slice(&crc.to_le_bytes());
        let frame = Frame::parse(&bytes).expect("CRC is valid");
        assert!(frame.decode().is_err());
        elab.frame(i * S, &frame);
    }
    elab.tick(10 * S);
    assert_eq!(
        elab.poll_event(),
        None,
        "no link loss, no arming from undecodable frames"
    );
    assert_eq!(elab.stats().decode_failures.get(&0), Some(&9));
}

#[test]
fn statustext_captures_become_parameters() {
    let rules = r#"
[rules.thrust_loss]
category = "catastrophic"
each = true
when = 'STATUSTEXT.text ~ "Potential Thrust Loss \((?P<motor>\d+)\)"'
params = { text = "STATUSTEXT.text" }
"#;
    let mut r = Run::new(rules);
    r.send(0, &heartbeat(true, 0, MavState::MAV_STATE_ACTIVE));
    r.send(S, &text("Potential Thrust Loss (3)"));
    r.send(2 * S, &text("All good"));
    r.send(3 * S, &text("Potential Thrust Loss (1)"));
    assert_eq!(
        r.names(),
        vec![
            (
                S,
                "thrust_loss {motor: 3, text: \"Potential Thrust Loss (3)\"}".into()
            ),
            (
                3 * S,
                "thrust_loss {motor: 1, text: \"Potential Thrust Loss (1)\"}".into()
            ),
        ]
    );
}

#[test]
fn sources_other_systems_gcs_and_components() {
    let rules = r#"
[rules.armed]
category = "nominal"
when = "HEARTBEAT.base_mode & MAV_MODE_FLAG_SAFETY_ARMED"
[rules.gcs_lost]
category = "communication"
source = "gcs"
when = "age(HEARTBEAT) > 5"
cleared = "gcs_restored"
[rules.camera_lost]
event = "payload_failure"
category = "mission"
source = "vehicle"
when = "HEARTBEAT.type == MAV_TYPE_CAMERA && age(HEARTBEAT) > 5"
params = { component = "compid()" }
[rules.from_seven]
category = "nominal"
source = { sysid = 7 }
when = "SYS_STATUS.battery_remaining < 50"
"#;
    let camera = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        mavtype: MavType::MAV_TYPE_CAMERA,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        ..HEARTBEAT_DATA::DEFAULT
    });
    let mut r = Run::new(rules);
    r.send(0, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    // Another vehicle's armed autopilot is not ours.
    r.from(
        S / 10,
        2,
        1,
        &heartbeat(true, 0, MavState::MAV_STATE_ACTIVE),
    );
    r.from(S / 5, 255, 190, &gcs_heartbeat());
    r.from(S / 4, 1, 100, &camera);
    r.from(S / 2, 7, 1, &sys_status(40));
    for t in 1..10 {
        r.send(t * S, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    }
    r.from(10 * S, 255, 190, &gcs_heartbeat());
    let names = r.names();
    let just: Vec<&str> = names.iter().map(|(_, n)| n.as_str()).collect();
    assert_eq!(
        just,
        [
            "from_seven",
            "gcs_lost",
            "payload_failure {component: 100}",
            "gcs_restored"
        ],
        "{names:?}"
    );
    assert_eq!(r.out[1].sysid, 255);
    assert_eq!(r.out[2].compid, 100);
}

#[test]
fn missing_messages_leave_rules_as_they_are() {
    let rules = r#"
[rules.ready]
category = "nominal"
when = "GPS_RAW_INT.fix_type >= GPS_FIX_TYPE_3D_FIX && SYS_STATUS.battery_remaining > 50"
"#;
    let mut r = Run::new(rules);
    r.send(0, &sys_status(90));
    r.send(S, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    assert!(r.out.is_empty());
    let mut gps = GPS_RAW_INT_DATA::DEFAULT;
    gps.fix_type = GpsFixType::GPS_FIX_TYPE_3D_FIX;
    r.send(2 * S, &MavMessage::GPS_RAW_INT(gps));
    assert_eq!(r.names(), vec![(2 * S, "ready".into())]);
}

#[test]
fn decoded_messages_from_a_live_link_work_too() {
    let mut elab = Elaborator::new(
        Profile::builtin("ardupilot").expect("profile"),
        Config::default(),
    );
    elab.message(
        0,
        &header(1, 1, 0),
        &heartbeat(false, 3, MavState::MAV_STATE_STANDBY),
    );
    elab.message(
        S,
        &header(1, 1, 1),
        &heartbeat(true, 3, MavState::MAV_STATE_STANDBY),
    );
    let e = elab.poll_event().expect("armed");
    assert_eq!(e.event.name, "armed");
    assert_eq!(
        e.event.params.get("mode"),
        Some(&nets::Value::Str("AUTO".into()))
    );
    assert_eq!((e.time_us, e.sysid, e.compid), (S, 1, 1));
}

#[test]
fn mavlink1_frames_are_read() {
    let mut elab = Elaborator::new(
        Profile::builtin("ardupilot").expect("profile"),
        Config::default(),
    );
    for (i, armed) in [false, true].into_iter().enumerate() {
        let bytes = serialize(
            header(1, 1, i as u8),
            MavlinkVersion::V1,
            &heartbeat(armed, 0, MavState::MAV_STATE_STANDBY),
        );
        elab.frame(i as u64 * S, &Frame::parse(&bytes).expect("v1 frame"));
    }
    assert_eq!(
        elab.poll_event().map(|e| e.event.name),
        Some("armed".into())
    );
}

#[test]
fn senders_are_bounded() {
    let mut elab = Elaborator::new(
        Profile::builtin("ardupilot").expect("profile"),
        Config::default(),
    );
    let mut n = 0u64;
    for sysid in 0..=255u8 {
        for compid in [1u8, 2] {
            let bytes = serialize(
                header(sysid, compid, 0),
                MavlinkVersion::V2,
                &sys_status(50),
            );
            elab.frame(n, &Frame::parse(&bytes).expect("frame"));
            n += 1;
        }
    }
    assert_eq!(elab.stats().frames, 512);
    assert_eq!(
        elab.stats().ignored_senders,
        512 - elaboration::elaborator::MAX_SOURCES as u64
    );
}

/// The built-in ArduPilot rules that no shared recording exercises, on a
/// synthetic armed copter.
#[test]
fn builtin_ardupilot_safety_and_catastrophic_rules() {
    let sensors = |present: MavSysStatusSensor, health: MavSysStatusSensor, remaining: i8| {
        let mut d = SYS_STATUS_DATA::DEFAULT;
        d.onboard_control_sensors_present = present;
        d.onboard_control_sensors_enabled = present;
        d.onboard_control_sensors_health = health;
        d.battery_remaining = remaining;
        MavMessage::SYS_STATUS(d)
    };
    let none = MavSysStatusSensor::empty();
    let fence = MavSysStatusSensor::MAV_SYS_STATUS_GEOFENCE;
    let mut ekf = EKF_STATUS_REPORT_DATA::DEFAULT;
    ekf.velocity_variance = 0.9;
    ekf.pos_horiz_variance = 0.9;
    ekf.compass_variance = 0.1;
    ekf.flags = EkfStatusFlags::from_bits_retain(0x33f);
    let mut esc = ESC_TELEMETRY_1_TO_4_DATA::DEFAULT;
    esc.rpm = [1000, 0, 1100, 1050];
    let mut battery = BATTERY_STATUS_DATA::DEFAULT;
    battery.charge_state = MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_CRITICAL;
    battery.battery_remaining = 7;
    let schedule: Vec<(u64, MavMessage)> = vec![
        (S, sensors(none, none, 20)),
        (5 * S, sensors(none, none, 8)),
        (9 * S, text("Potential Thrust Loss (2)")),
        (10 * S, MavMessage::EKF_STATUS_REPORT(ekf)),
        (12 * S, sensors(fence, none, 8)),
        (13 * S, text("Radio Failsafe")),
        (14 * S, MavMessage::ESC_TELEMETRY_1_TO_4(esc)),
        (16 * S, MavMessage::BATTERY_STATUS(battery)),
    ];
    let mut elab = Elaborator::new(
        Profile::builtin("ardupilot").expect("profile"),
        Config::default(),
    );
    let mut out = Vec::new();
    let mut seq = 0u8;
    let mut send = |elab: &mut Elaborator, t: u64, msg: &MavMessage| {
        let bytes = serialize(header(1, 1, seq), MavlinkVersion::V2, msg);
        seq = seq.wrapping_add(1);
        elab.frame(t, &Frame::parse(&bytes).expect("frame"));
    };
    for step in 0..=36u64 {
        let t = step * S / 2;
        if step % 2 == 0 {
            let status = if t == 17 * S {
                MavState::MAV_STATE_EMERGENCY
            } else {
                MavState::MAV_STATE_ACTIVE
            };
            send(&mut elab, t, &heartbeat(true, 5, status));
        }
        for (at, msg) in &schedule {
            if *at == t {
                send(&mut elab, t, msg);
            }
        }
        elab.drain_into(&mut out);
    }
    let got: Vec<(u64, String)> = out.iter().map(|e| (e.time_us, crate::summary(e))).collect();
    assert_eq!(
        got,
        vec![
            (4 * S, "battery_low {remaining: 20}".into()),
            (8 * S, "battery_critical {remaining: 8}".into()),
            (9 * S, "engine_failure {motor: 2}".into()),
            (11 * S, "ekf_unhealthy".into()),
            (12 * S, "geofence_breach".into()),
            (13 * S, "rc_lost".into()),
            (
                13 * S,
                "autopilot_failsafe {text: \"Radio Failsafe\"}".into()
            ),
            (15 * S, "engine_failure".into()),
            // ArduPilot's own judgement (CRITICAL, so low too) after the
            // capacity rules: one event from each source.
            (
                16 * S,
                "battery_low {charge_state: \"CRITICAL\", remaining: 7}".into()
            ),
            (
                16 * S,
                "battery_critical {charge_state: \"CRITICAL\", remaining: 7}".into()
            ),
            (17 * S, "vehicle_emergency {system_status: 6}".into()),
        ]
    );
    assert!(out.iter().all(|e| (e.sysid, e.compid) == (1, 1)));
}

/// The built-in PX4 rules on a synthetic PX4 quad: modes by main/sub mode,
/// takeoff and landing from EXTENDED_SYS_STATE, arming.
#[test]
fn builtin_px4_modes_takeoff_and_landing() {
    let hb = |armed: bool, main: u32, sub: u32| {
        let mut base = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
        if armed {
            base |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
        }
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: (main << 16) | (sub << 24),
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_PX4,
            base_mode: base,
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        })
    };
    let landed = |state: MavLandedState| {
        let mut d = EXTENDED_SYS_STATE_DATA::DEFAULT;
        d.landed_state = state;
        MavMessage::EXTENDED_SYS_STATE(d)
    };
    let mut r = Run {
        elab: Elaborator::new(Profile::builtin("px4").expect("profile"), Config::default()),
        seq: 0,
        out: Vec::new(),
    };
    r.send(0, &hb(false, 3, 0));
    r.send(S / 2, &landed(MavLandedState::MAV_LANDED_STATE_ON_GROUND));
    r.send(S, &hb(true, 3, 0));
    r.send(2 * S, &hb(true, 4, 4));
    r.send(
        2 * S + S / 2,
        &landed(MavLandedState::MAV_LANDED_STATE_IN_AIR),
    );
    r.send(3 * S, &hb(true, 4, 5));
    r.send(
        3 * S + S / 2,
        &landed(MavLandedState::MAV_LANDED_STATE_ON_GROUND),
    );
    r.send(4 * S, &hb(false, 4, 5));
    assert_eq!(
        r.names(),
        vec![
            (S, "armed {mode: \"POSCTL\"}".into()),
            (
                2 * S,
                "mode_changed {custom_mode: 67371008, mode: \"AUTO_MISSION\"}".into()
            ),
            (2 * S + S / 2, "takeoff".into()),
            (
                3 * S,
                "mode_changed {custom_mode: 84148224, mode: \"AUTO_RTL\"}".into()
            ),
            (3 * S + S / 2, "landed".into()),
            (4 * S, "disarmed {mode: \"AUTO_RTL\"}".into()),
        ]
    );
}

/// `mode()` and `firmware()` by autopilot and vehicle type: the same
/// `custom_mode` names a different mode on each ArduPilot vehicle; PX4
/// packs main and sub modes.
#[test]
fn modes_are_named_per_autopilot_and_vehicle_type() {
    let rules = r#"
[rules.mode]
category = "nominal"
each = true
when = "HEARTBEAT.custom_mode >= 0"
params = { mode = "mode()", firmware = "firmware()" }
"#;
    let ardupilot = MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA;
    let px4 = MavAutopilot::MAV_AUTOPILOT_PX4;
    let cases = [
        (ardupilot, MavType::MAV_TYPE_QUADROTOR, 6, "RTL", "copter"),
        (
            ardupilot,
            MavType::MAV_TYPE_HEXAROTOR,
            16,
            "POSHOLD",
            "copter",
        ),
        (
            ardupilot,
            MavType::MAV_TYPE_HELICOPTER,
            5,
            "LOITER",
            "copter",
        ),
        (
            ardupilot,
            MavType::MAV_TYPE_FIXED_WING,
            6,
            "FLY_BY_WIRE_B",
            "plane",
        ),
        (ardupilot, MavType::MAV_TYPE_FIXED_WING, 11, "RTL", "plane"),
        // A QuadPlane reports a VTOL type: plane modes.
        (
            ardupilot,
            MavType::MAV_TYPE_VTOL_TILTROTOR,
            17,
            "QSTABILIZE",
            "plane",
        ),
        (
            ardupilot,
            MavType::MAV_TYPE_GROUND_ROVER,
            6,
            "FOLLOW",
            "rover",
        ),
        (
            ardupilot,
            MavType::MAV_TYPE_SURFACE_BOAT,
            4,
            "HOLD",
            "rover",
        ),
        (ardupilot, MavType::MAV_TYPE_SUBMARINE, 19, "MANUAL", "sub"),
        (ardupilot, MavType::MAV_TYPE_SUBMARINE, 2, "ALT_HOLD", "sub"),
        (px4, MavType::MAV_TYPE_QUADROTOR, 3 << 16, "POSCTL", "px4"),
        (
            px4,
            MavType::MAV_TYPE_FIXED_WING,
            (4 << 16) | (5 << 24),
            "AUTO_RTL",
            "px4",
        ),
        (
            px4,
            MavType::MAV_TYPE_QUADROTOR,
            (4 << 16) | (3 << 24),
            "AUTO_LOITER",
            "px4",
        ),
        (px4, MavType::MAV_TYPE_QUADROTOR, 6 << 16, "OFFBOARD", "px4"),
        (
            ardupilot,
            MavType::MAV_TYPE_QUADROTOR,
            999,
            "MODE_999",
            "copter",
        ),
    ];
    for (autopilot, mavtype, custom_mode, mode, firmware) in cases {
        let mut r = Run::new(rules);
        r.send(
            0,
            &MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                custom_mode,
                mavtype,
                autopilot,
                base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                system_status: MavState::MAV_STATE_STANDBY,
                mavlink_version: 3,
            }),
        );
        assert_eq!(
            r.names(),
            [(
                0,
                format!("mode {{firmware: \"{firmware}\", mode: \"{mode}\"}}")
            )],
            "{autopilot:?} {mavtype:?} {custom_mode}"
        );
    }
}

#[test]
fn clear_for_holds_the_clear_condition_before_re_arming() {
    let rules = r#"
[rules.low]
category = "safety"
when = "SYS_STATUS.battery_remaining < 25"
clear_for = "3s"
cleared = "low_over"
"#;
    let mut r = Run::new(rules);
    r.send(0, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    r.send(S, &sys_status(20));
    r.send(2 * S, &sys_status(40)); // above for 1 s only
    r.send(3 * S, &sys_status(20)); // still the same episode: no new event
    r.send(4 * S, &sys_status(40));
    r.tick(7 * S - 1);
    assert_eq!(r.names(), [(S, "low".to_string())]);
    r.tick(7 * S); // above for 3 s: cleared, on the tick
    r.send(8 * S, &sys_status(20)); // a new episode
    assert_eq!(
        r.names(),
        [
            (S, "low".to_string()),
            (7 * S, "low_over".to_string()),
            (8 * S, "low".to_string())
        ]
    );
}

/// A rule is evaluated on the messages it reads, nothing else; frames of
/// messages no rule reads are not decoded.
#[test]
fn only_the_rules_reading_a_message_are_evaluated_on_it() {
    let rules = r#"
[rules.battery]
category = "nominal"
each = true
when = "SYS_STATUS.battery_remaining >= 0"
[rules.gps]
category = "nominal"
each = true
when = "GPS_RAW_INT.satellites_visible >= 0"
"#;
    let mut r = Run::new(rules);
    let attitude = MavMessage::ATTITUDE(ATTITUDE_DATA::DEFAULT);
    r.send(0, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    for i in 1..=5 {
        r.send(i * S, &attitude);
        r.send(i * S + 1, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    }
    r.send(6 * S, &sys_status(50));
    r.send(7 * S, &attitude);
    r.send(8 * S, &sys_status(50));
    r.send(9 * S, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    assert_eq!(
        r.names(),
        [
            (6 * S, "battery".to_string()),
            (8 * S, "battery".to_string())
        ]
    );
    let stats = r.elab.stats();
    assert_eq!(stats.frames, 15);
    // 7 HEARTBEATs (always decoded: they name the senders) and 2
    // SYS_STATUS; the 6 ATTITUDE frames are only counted.
    assert_eq!(stats.decoded, 9);
}

/// An undecodable HEARTBEAT (a MAV_TYPE rust-mavlink does not know) from
/// the autopilot restores the link on its own frame, while the rules that
/// read HEARTBEAT fields keep their state.
#[test]
fn an_undecodable_heartbeat_restores_the_link_on_its_own_frame() {
    let rules = r#"
[rules.link_lost]
category = "communication"
when = "age(HEARTBEAT) > 3.5"
cleared = "link_restored"
[rules.mode_changed]
category = "nominal"
each = true
when = "changed(HEARTBEAT.custom_mode)"
"#;
    let undecodable = |seq: u8, custom_mode: u32| {
        let mut bytes = serialize(
            header(1, 1, seq),
            MavlinkVersion::V2,
            &heartbeat(false, custom_mode, MavState::MAV_STATE_STANDBY),
        );
        bytes[10 + 4] = 250; // HEARTBEAT.type
        let end = bytes.len() - 2;
        let crc = mavlink::calculate_crc(&bytes[1..end], extra_crc(0).expect("HEARTBEAT"));
        bytes[end..].copy_from_slice(&crc.to_le_bytes());
        bytes
    };
    let mut r = Run::new(rules);
    r.send(0, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    let late = undecodable(1, 5);
    let frame = Frame::parse(&late).expect("CRC is valid");
    assert!(frame.decode().is_err());
    r.elab.frame(6 * S + 123, &frame);
    r.elab.drain_into(&mut r.out);
    assert_eq!(
        r.names(),
        [
            (3 * S + 600_000, "link_lost".to_string()),
            (6 * S + 123, "link_restored".to_string())
        ]
    );
    assert_eq!(r.elab.stats().decode_failures.get(&0), Some(&1));
}

/// `distinct = N`: the same parameters as one of the last N events are a
/// repeat; `clear` rising after the last event forgets them; a message
/// read only by `clear` never fires the rule.
#[test]
fn distinct_remembers_the_last_events_until_clear_rises() {
    let rules = r#"
[rules.said]
category = "nominal"
each = true
distinct = 2
when = 'STATUSTEXT.text ~ "^Said: (?P<what>.+)$"'
clear = "SYS_STATUS.battery_remaining > 50"
"#;
    let mut r = Run::new(rules);
    r.send(0, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    r.send(S, &sys_status(10));
    for (i, what) in ["A", "B", "A", "B", "C", "A"].iter().enumerate() {
        r.send((2 + i as u64) * S, &text(&format!("Said: {what}")));
    }
    // Clear true after having been false: re-armed; the SYS_STATUS itself
    // fires nothing, though the last text still matches.
    r.send(10 * S, &sys_status(80));
    r.send(11 * S, &text("Said: A"));
    // True again without having been false since the event: not re-armed.
    r.send(12 * S, &sys_status(80));
    r.send(13 * S, &text("Said: A"));
    assert_eq!(
        r.names(),
        vec![
            (2 * S, "said {what: \"A\"}".into()),
            (3 * S, "said {what: \"B\"}".into()),
            (6 * S, "said {what: \"C\"}".into()),
            // A was pushed out by B and C.
            (7 * S, "said {what: \"A\"}".into()),
            (11 * S, "said {what: \"A\"}".into()),
        ]
    );
}

fn reached(seq: u16) -> MavMessage {
    MavMessage::MISSION_ITEM_REACHED(MISSION_ITEM_REACHED_DATA { seq })
}

fn system_time() -> MavMessage {
    MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA::DEFAULT)
}

/// `on` keeps a rule to the frames of the messages it names: a HEARTBEAT
/// that `mode()` reads, before, after or at the very instant of the
/// MISSION_ITEM_REACHED, does not fire it again; the same rule without
/// `on` fires on each of them.
#[test]
fn on_keeps_a_rule_to_its_triggering_messages() {
    let rules = r#"
[rules.reached]
category = "mission"
each = true
on = "MISSION_ITEM_REACHED"
when = 'MISSION_ITEM_REACHED.seq == 0 && mode() == "GUIDED"'
[rules.plain]
category = "mission"
each = true
when = 'MISSION_ITEM_REACHED.seq == 0 && mode() == "GUIDED"'
[rules.sampled]
category = "mission"
each = true
on = ["SYSTEM_TIME", "MISSION_ITEM_REACHED"]
when = "SYS_STATUS.battery_remaining < 20"
"#;
    let guided = || heartbeat(true, 4, MavState::MAV_STATE_ACTIVE);
    let mut r = Run::new(rules);
    r.send(0, &guided());
    r.send(S, &reached(0));
    r.send(2 * S, &guided());
    r.send(3 * S, &guided());
    r.send(4 * S, &reached(0));
    r.send(4 * S, &guided());
    r.send(5 * S, &sys_status(10));
    r.send(6 * S, &system_time());
    r.send(7 * S, &reached(3));
    r.send(8 * S, &guided());
    let only = |name: &str| -> Vec<u64> {
        r.names()
            .into_iter()
            .filter(|(_, n)| n == name)
            .map(|(t, _)| t / S)
            .collect()
    };
    assert_eq!(only("reached"), [1, 4]);
    assert_eq!(only("plain"), [1, 2, 3, 4, 4]);
    // Never on the SYS_STATUS it reads; on both messages it names, read
    // or not.
    assert_eq!(only("sampled"), [6, 7]);
}

/// A rule with `on` is not evaluated on ticks: `age()` is read and `for`
/// measured at its frames only.
#[test]
fn on_takes_a_rule_off_the_ticks() {
    let rules = r#"
[rules.stale]
category = "safety"
on = "SYSTEM_TIME"
when = "age(GPS_RAW_INT) > 2"
[rules.stale_ticked]
category = "safety"
when = "age(GPS_RAW_INT) > 2"
[rules.low]
category = "safety"
on = "SYS_STATUS"
when = "SYS_STATUS.battery_remaining < 20"
for = "2s"
[rules.low_ticked]
category = "safety"
when = "SYS_STATUS.battery_remaining < 20"
for = "2s"
"#;
    let gps = MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA::DEFAULT);
    let mut r = Run::new(rules);
    r.send(0, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    r.send(S / 2, &gps);
    r.send(S, &sys_status(10));
    r.send(2 * S, &sys_status(10));
    r.tick(3 * S + S / 2);
    r.send(3 * S + S / 2, &sys_status(10));
    r.tick(5 * S);
    r.send(5 * S, &system_time());
    let got: Vec<(u64, String)> = r
        .names()
        .into_iter()
        .map(|(t, n)| (t / 100_000, n))
        .collect();
    assert_eq!(
        got,
        [
            // age(GPS_RAW_INT) passes 2 s at 2.5 s: the first tick after.
            (26, "stale_ticked".to_string()),
            // Held 2 s at 3.0 s: the tick; at 3.5 s, the SYS_STATUS.
            (30, "low_ticked".to_string()),
            (35, "low".to_string()),
            (50, "stale".to_string()),
        ]
    );
}

/// An explicit `clear` is still watched on the messages it reads: a
/// distinct rule is re-armed by a ready vehicle between two texts, and a
/// state rule clears on the message that shows it; without `clear` (not
/// `when`), a rule clears on its `on` messages only.
#[test]
fn on_leaves_clear_on_its_own_messages() {
    let rules = r#"
[rules.said]
category = "nominal"
each = true
distinct = true
on = "STATUSTEXT"
when = 'STATUSTEXT.text ~ "^Said: (?P<what>.+)$" && mode() == "GUIDED"'
clear = "SYS_STATUS.battery_remaining > 50"
[rules.low]
category = "safety"
on = "SYSTEM_TIME"
when = "SYS_STATUS.battery_remaining < 20"
clear = "SYS_STATUS.battery_remaining >= 30"
cleared = "ok"
[rules.low2]
category = "safety"
on = "SYSTEM_TIME"
when = "SYS_STATUS.battery_remaining < 20"
cleared = "ok2"
"#;
    let mut r = Run::new(rules);
    r.send(0, &heartbeat(true, 4, MavState::MAV_STATE_ACTIVE));
    r.send(S, &sys_status(10));
    r.send(2 * S, &text("Said: A"));
    r.send(2 * S, &system_time());
    // Ready between two texts: re-armed though no text came meanwhile.
    r.send(3 * S, &sys_status(80));
    r.send(4 * S, &sys_status(10));
    r.send(5 * S, &text("Said: A"));
    r.send(6 * S, &sys_status(40));
    r.send(7 * S, &system_time());
    r.send(8 * S, &sys_status(10));
    r.send(9 * S, &system_time());
    assert_eq!(
        r.names(),
        [
            (2 * S, "said {what: \"A\"}".to_string()),
            (2 * S, "low".to_string()),
            (2 * S, "low2".to_string()),
            (3 * S, "ok".to_string()),
            (5 * S, "said {what: \"A\"}".to_string()),
            (7 * S, "ok2".to_string()),
            (9 * S, "low".to_string()),
            (9 * S, "low2".to_string()),
        ]
    );
}

#[test]
fn events_carry_the_autopilots_clock_and_a_stall_adds_at_most_its_period() {
    use mavlink::dialects::ardupilotmega::ATTITUDE_DATA;
    let rules = r#"
[rules.armed]
category = "nominal"
when = "HEARTBEAT.base_mode & MAV_MODE_FLAG_SAFETY_ARMED"
initial = false
"#;
    let attitude = |ms: u32| {
        MavMessage::ATTITUDE(ATTITUDE_DATA {
            time_boot_ms: ms,
            ..Default::default()
        })
    };
    let mut r = Run::new(rules);
    // No `time_boot_ms` heard yet: none.
    r.send(0, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    r.send(100_000, &heartbeat(true, 0, MavState::MAV_STATE_STANDBY));
    assert_eq!(r.out.last().map(|e| e.boot_us), Some(None));
    // ATTITUDE every 250 ms of the autopilot's clock (booted 100 s before);
    // a heartbeat 100 ms after one: 100 ms added.
    for i in 0..4u32 {
        r.send(
            200_000 + u64::from(i) * 250_000,
            &attitude(100_200 + i * 250),
        );
    }
    r.send(1_050_000, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    r.send(1_050_000, &heartbeat(true, 0, MavState::MAV_STATE_STANDBY));
    assert_eq!(r.out.last().map(|e| e.boot_us), Some(Some(101_050_000)));
    // The receiver stalled 3 s: the first frame after it, a heartbeat, is
    // read 3.3 s after the last ATTITUDE: at most a period (250 ms) added.
    r.send(4_250_000, &heartbeat(false, 0, MavState::MAV_STATE_STANDBY));
    r.send(4_260_000, &heartbeat(true, 0, MavState::MAV_STATE_STANDBY));
    assert_eq!(r.out.last().map(|e| e.boot_us), Some(Some(101_200_000)));
}
