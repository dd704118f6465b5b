//! The built-in rules on what the real firmware says of itself, as ArduPilot
//! 4.7 SITL says it: pre-arm failures and their repeats, its own battery
//! judgement, MISSION_ITEM_REACHED re-sent as a stream, command results by
//! name, a weakened copter motor.

use elaboration::frame::serialize;
use elaboration::{Config, Elaborated, Elaborator, Frame, Profile};
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};

const S: u64 = 1_000_000;
const MS: u64 = 1_000;

/// Feeds messages of the autopilot 1/1 through bytes, CRC and decoding.
struct Run {
    elab: Elaborator,
    seq: u8,
    out: Vec<Elaborated>,
}

impl Run {
    fn new(profile: &str) -> Run {
        Run {
            elab: Elaborator::new(
                Profile::builtin(profile).expect("built-in profile"),
                Config::default(),
            ),
            seq: 0,
            out: Vec::new(),
        }
    }

    fn send(&mut self, t: u64, msg: MavMessage) -> &mut Self {
        let h = MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: self.seq,
        };
        self.seq = self.seq.wrapping_add(1);
        let bytes = serialize(h, MavlinkVersion::V2, &msg);
        self.elab
            .frame(t, &Frame::parse(&bytes).expect("valid frame"));
        self.elab.drain_into(&mut self.out);
        self
    }

    /// The events named `names`, as (time, summary).
    fn only(&self, names: &[&str]) -> Vec<(u64, String)> {
        self.out
            .iter()
            .filter(|e| names.contains(&e.event.name.as_str()))
            .map(|e| (e.time_us, crate::summary(e)))
            .collect()
    }
}

fn heartbeat(autopilot: MavAutopilot, armed: bool, status: MavState) -> MavMessage {
    heartbeat_in(autopilot, 4, armed, status)
}

fn heartbeat_in(
    autopilot: MavAutopilot,
    custom_mode: u32,
    armed: bool,
    status: MavState,
) -> MavMessage {
    let mut base = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
    if armed {
        base |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
    }
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode,
        mavtype: MavType::MAV_TYPE_QUADROTOR,
        autopilot,
        base_mode: base,
        system_status: status,
        mavlink_version: 3,
    })
}

fn copter(armed: bool, status: MavState) -> MavMessage {
    heartbeat(MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA, armed, status)
}

fn text(t: &str) -> MavMessage {
    let mut bytes = [0u8; 50];
    bytes[..t.len()].copy_from_slice(t.as_bytes());
    let mut d = STATUSTEXT_DATA::DEFAULT;
    d.text = mavlink::types::CharArray::new(bytes);
    MavMessage::STATUSTEXT(d)
}

/// SYS_STATUS with the pre-arm check present, healthy or not.
fn prearm(healthy: bool, remaining: i8, millivolts: u16) -> MavMessage {
    let check = MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK;
    let mut d = SYS_STATUS_DATA::DEFAULT;
    d.onboard_control_sensors_present = check;
    d.onboard_control_sensors_enabled = check;
    if healthy {
        d.onboard_control_sensors_health = check;
    }
    d.battery_remaining = remaining;
    d.voltage_battery = millivolts;
    MavMessage::SYS_STATUS(d)
}

#[test]
fn a_prearm_failure_is_said_once_per_reason_until_the_vehicle_was_ready() {
    let mut r = Run::new("ardupilot");
    r.send(0, copter(false, MavState::MAV_STATE_STANDBY));
    r.send(10 * MS, prearm(false, 100, 12600));
    // ArduPilot's reason every 30 s while disarmed, and again (with the
    // "Arm:" prefix) at each refused attempt: one event.
    for t in [S, 31 * S, 61 * S] {
        r.send(
            t,
            text("PreArm: DO_LAND_START set and RTL_AUTOLAND disable"),
        );
    }
    r.send(
        40 * S,
        text("Arm: DO_LAND_START set and RTL_AUTOLAND disable"),
    );
    // Another reason is news. ArduPilot gives several reasons in turn at
    // each attempt (real ArduCopter SITL at boot): each once.
    r.send(70 * S, text("PreArm: Need Position Estimate"));
    for attempt in 0..5u64 {
        let t = 72 * S + attempt * S;
        r.send(t, text("Arm: DO_LAND_START set and RTL_AUTOLAND disable"));
        r.send(t + MS, text("PreArm: Need Position Estimate"));
    }
    // Ready in between (the pre-arm bit healthy): the same reason again is
    // a new occurrence.
    r.send(90 * S, prearm(true, 100, 12600));
    r.send(91 * S, prearm(false, 100, 12600));
    r.send(92 * S, text("PreArm: Need Position Estimate"));
    // Armed, then landed and disarmed: ArduCopter's check of a battery in
    // failsafe is a pre-arm failure, not a failsafe of its own.
    r.send(100 * S, copter(true, MavState::MAV_STATE_STANDBY));
    r.send(110 * S, copter(false, MavState::MAV_STATE_STANDBY));
    r.send(111 * S, text("PreArm: Battery 1 low voltage failsafe"));
    assert_eq!(
        r.only(&["prearm_failed", "autopilot_failsafe"]),
        [
            (
                S,
                "prearm_failed {text: \"DO_LAND_START set and RTL_AUTOLAND disable\"}".to_string()
            ),
            (
                70 * S,
                "prearm_failed {text: \"Need Position Estimate\"}".to_string()
            ),
            (
                92 * S,
                "prearm_failed {text: \"Need Position Estimate\"}".to_string()
            ),
            (
                111 * S,
                "prearm_failed {text: \"Battery 1 low voltage failsafe\"}".to_string()
            ),
        ]
    );
    assert!(r
        .out
        .iter()
        .filter(|e| e.event.name == "prearm_failed")
        .all(|e| e.event.category == nets::Category::Nominal));
}

#[test]
fn px4_preflight_failures_are_prearm_failed_too() {
    let mut r = Run::new("px4");
    r.send(
        0,
        heartbeat(
            MavAutopilot::MAV_AUTOPILOT_PX4,
            false,
            MavState::MAV_STATE_STANDBY,
        ),
    );
    r.send(S, text("Preflight Fail: No valid data from Compass"));
    r.send(2 * S, text("Preflight Fail: No valid data from Compass"));
    r.send(3 * S, text("Arming denied: Resolve system health failures"));
    r.send(4 * S, text("Preflight Fail: GPS failsafe"));
    assert_eq!(
        r.only(&["prearm_failed", "autopilot_failsafe"]),
        [
            (
                S,
                "prearm_failed {text: \"No valid data from Compass\"}".to_string()
            ),
            (
                3 * S,
                "prearm_failed {text: \"Resolve system health failures\"}".to_string()
            ),
            (4 * S, "prearm_failed {text: \"GPS failsafe\"}".to_string()),
        ]
    );
}

/// A PX4 event of its events protocol, as v1.18 SITL sends it.
fn px4_event(id: u32, log_levels: u8, sequence: u16) -> MavMessage {
    MavMessage::EVENT(EVENT_DATA {
        id,
        log_levels,
        sequence,
        ..EVENT_DATA::DEFAULT
    })
}

/// PX4 v1.18 names the failing check only through its events protocol
/// (STATUSTEXT: "Resolve system health failures first"), and says
/// "Preflight:" where older releases said "Preflight Fail:". Checks at
/// WARNING or worse are reasons; INFO ones and the summary events are not;
/// an unknown id says nothing; the refusal comes as an event too.
#[test]
fn px4_events_protocol_names_the_failing_check() {
    let mut r = Run::new("px4");
    r.send(
        0,
        heartbeat(
            MavAutopilot::MAV_AUTOPILOT_PX4,
            false,
            MavState::MAV_STATE_STANDBY,
        ),
    );
    r.send(S, text("Preflight: GPS fix too low\t"));
    r.send(2 * S, px4_event(0x198_c273, 0x33, 1)); // no global position
    r.send(3 * S, px4_event(0x106_ed29, 0x44, 2)); // no manual control input
    r.send(4 * S, px4_event(0x1a8_93e0, 0x88, 3)); // arming check summary
    r.send(5 * S, px4_event(0x0fff_ffff, 0x33, 4)); // unknown
    r.send(6 * S, px4_event(0x198_c273, 0x33, 5)); // again: a repeat
    r.send(7 * S, px4_event(0x101_3630, 0x66, 6)); // home not set: INFO
    r.send(8 * S, px4_event(0x102_089d, 0x62, 7)); // the refusal
    assert_eq!(
        r.only(&["prearm_failed"]),
        [
            (S, "prearm_failed {text: \"GPS fix too low\"}".to_string()),
            (
                2 * S,
                "prearm_failed {text: \"Navigation error: No valid global position estimate\"}"
                    .to_string()
            ),
            (
                3 * S,
                "prearm_failed {text: \"No manual control input\"}".to_string()
            ),
            (
                8 * S,
                "prearm_failed {text: \"Resolve system health failures first\"}".to_string()
            ),
        ]
    );
}

fn battery(state: MavBatteryChargeState, remaining: i8) -> MavMessage {
    let mut d = BATTERY_STATUS_DATA::DEFAULT;
    d.charge_state = state;
    d.battery_remaining = remaining;
    MavMessage::BATTERY_STATUS(d)
}

/// A battery failsafe on voltage: ArduPilot says LOW while the remaining
/// capacity stays at 90 %.
#[test]
fn battery_low_from_ardupilots_own_judgement() {
    use MavBatteryChargeState::*;
    let mut r = Run::new("ardupilot");
    for step in 0..20u64 {
        let t = step * S;
        r.send(t, copter(true, MavState::MAV_STATE_ACTIVE));
        let (state, mv) = match step {
            0..=4 => (MAV_BATTERY_CHARGE_STATE_OK, 12600),
            5..=14 => (MAV_BATTERY_CHARGE_STATE_LOW, 10400),
            _ => (MAV_BATTERY_CHARGE_STATE_CRITICAL, 9800),
        };
        r.send(t + MS, prearm(true, 90, mv));
        r.send(t + 2 * MS, battery(state, 90));
    }
    let got: Vec<(u64, String)> = r.only(&["battery_low", "battery_critical"]);
    assert_eq!(
        got,
        [
            (
                5 * S + 2 * MS,
                "battery_low {charge_state: \"LOW\", remaining: 90}".to_string()
            ),
            (
                15 * S + 2 * MS,
                "battery_critical {charge_state: \"CRITICAL\", remaining: 90}".to_string()
            ),
        ]
    );
    let voltage = r
        .out
        .iter()
        .find(|e| e.event.name == "battery_low")
        .and_then(|e| e.event.params.get("voltage").cloned());
    assert_eq!(voltage, Some(nets::Value::Float(10.4)));
}

/// ArduPilot LOW and the capacity under 25 % at once: one battery_low.
#[test]
fn one_battery_low_when_judgement_and_capacity_agree() {
    use MavBatteryChargeState::*;
    let mut r = Run::new("ardupilot");
    for step in 0..12u64 {
        let t = step * S;
        r.send(t, copter(true, MavState::MAV_STATE_ACTIVE));
        let (state, remaining) = if step >= 4 {
            (MAV_BATTERY_CHARGE_STATE_LOW, 20)
        } else {
            (MAV_BATTERY_CHARGE_STATE_OK, 40)
        };
        r.send(t + MS, prearm(true, remaining, 11000));
        r.send(t + 2 * MS, battery(state, remaining));
    }
    assert_eq!(
        r.only(&["battery_low"]),
        [(
            4 * S + 2 * MS,
            "battery_low {charge_state: \"LOW\", remaining: 20}".to_string()
        )]
    );
}

/// Without BATTERY_STATUS (not streamed, or older firmware), ArduPilot's
/// text says it: "Battery 1 is low", "Low battery" (Copter 3.4), "Battery 1
/// is critical".
#[test]
fn battery_low_from_ardupilots_text_where_battery_status_is_absent() {
    for (said, event) in [
        ("Battery 1 is low 10.41V used 120 mAh", "battery_low"),
        ("Low battery", "battery_low"),
        (
            "Battery 2 is critical 9.80V used 130 mAh",
            "battery_critical",
        ),
    ] {
        let mut r = Run::new("ardupilot");
        r.send(0, copter(true, MavState::MAV_STATE_ACTIVE));
        r.send(MS, prearm(true, 90, 10400));
        r.send(S, text(said));
        let got = r.only(&["battery_low", "battery_critical"]);
        assert_eq!(got.len(), 1, "{said}: {got:?}");
        assert!(got[0].1.starts_with(event), "{said}: {got:?}");
        assert!(got[0].1.contains("remaining: 90"), "{said}: {got:?}");
        // Streamed BATTERY_STATUS decides instead: the text is not counted
        // twice.
        let mut r = Run::new("ardupilot");
        r.send(0, copter(true, MavState::MAV_STATE_ACTIVE));
        r.send(
            MS,
            battery(MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_OK, 90),
        );
        r.send(S, text(said));
        assert_eq!(r.only(&["battery_low", "battery_critical"]), [], "{said}");
    }
}

fn reached(seq: u16) -> MavMessage {
    MavMessage::MISSION_ITEM_REACHED(MISSION_ITEM_REACHED_DATA { seq })
}

fn current(seq: u16) -> MavMessage {
    let mut d = MISSION_CURRENT_DATA::DEFAULT;
    d.seq = seq;
    d.mission_state = MissionState::MISSION_STATE_ACTIVE;
    MavMessage::MISSION_CURRENT(d)
}

/// MISSION_ITEM_REACHED requested as a stream: ArduPilot re-sends its last
/// one (65535 before any) every period. Only new reaches are events.
#[test]
fn mission_item_reached_repeats_and_65535_are_not_events() {
    for profile in ["ardupilot", "px4"] {
        let mut r = Run::new(profile);
        r.send(0, copter(true, MavState::MAV_STATE_ACTIVE));
        let mut cur = 1;
        // Every 250 ms the autopilot re-sends its last reach (65535 before
        // any) and its current item.
        for period in 0..200u64 {
            let t = period * 250 * MS;
            let last = match period {
                0..=19 => 65535,
                20..=59 => 1,
                // Item 2 reached, then the mission is restarted at 100
                // (current back to 1) ...
                60..=139 => 2,
                // ... item 1 reached again at 140; a loop (DO_JUMP) back
                // to item 1 at 165, reached again at 170.
                _ => 1,
            };
            cur = match period {
                20 => 2,
                60 => 3,
                100 => 1,
                140 => 2,
                165 => 1,
                170 => 2,
                _ => cur,
            };
            // A stale MISSION_CURRENT right after the reach (still item 1)
            // must not re-arm the repeat.
            let said_current = if period == 20 || period == 21 { 1 } else { cur };
            r.send(t, reached(last));
            r.send(t + MS, current(said_current));
        }
        let items: Vec<u64> = r
            .only(&["mission_item_reached"])
            .into_iter()
            .map(|(t, _)| t / (250 * MS))
            .collect();
        let seqs: Vec<String> = r
            .only(&["mission_item_reached"])
            .into_iter()
            .map(|(_, s)| s)
            .collect();
        // 1 at 20, 2 at 60, 1 at 140 (another seq than the last), and 1
        // again when MISSION_CURRENT moved past it at 170 after coming
        // back to it at 165 (not on the stale repeats from 165 to 170).
        assert_eq!(items, [20, 60, 140, 170], "{profile}: {seqs:?}");
        assert!(seqs.iter().all(|s| !s.contains("65535")), "{profile}");
    }
}

/// A HEARTBEAT of an ArduPilot vehicle of `mavtype`, armed and flying, in
/// `custom_mode`.
fn ardupilot_in(mavtype: MavType, custom_mode: u32) -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode,
        mavtype,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
            | MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED,
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    })
}

/// GLOBAL_POSITION_INT at `north` metres north of (-35.36, 149.16),
/// `alt` metres above home.
fn position(north: f64, alt: f64) -> MavMessage {
    let mut d = GLOBAL_POSITION_INT_DATA::DEFAULT;
    d.lat = (-35.36e7 + north * 90.0) as i32;
    d.lon = 149.16e7 as i32;
    d.relative_alt = (alt * 1000.0) as i32;
    d.alt = ((584.0 + alt) * 1000.0) as i32;
    MavMessage::GLOBAL_POSITION_INT(d)
}

/// Each (time, lat, alt) of the `goto_reached` events, and the
/// `mission_item_reached` summaries.
fn gotos_and_items(r: &Run) -> (Vec<(u64, f64, f64)>, Vec<String>) {
    let float = |e: &Elaborated, k: &str| match e.event.params.get(k) {
        Some(nets::Value::Float(x)) => *x,
        other => panic!("goto_reached {k}: {other:?}"),
    };
    let gotos = r
        .out
        .iter()
        .filter(|e| e.event.name == "goto_reached")
        .map(|e| {
            assert_eq!(e.event.category, nets::Category::Mission);
            (e.time_us, float(e, "lat"), float(e, "alt"))
        })
        .collect();
    let items = r
        .only(&["mission_item_reached"])
        .into_iter()
        .map(|(_, s)| s)
        .collect();
    (gotos, items)
}

/// ArduCopter, ArduRover and ArduPlane in GUIDED say each destination
/// reached with MISSION_ITEM_REACHED 0 (mode_guided.cpp,
/// `send_mission_item_reached_message(0)`; ArduPlane's update_loiter), and
/// MISSION_CURRENT stays where it was: two gotos in a row are two
/// `goto_reached`, each where the vehicle was, and neither a mission item.
#[test]
fn every_guided_goto_reached_is_heard_and_is_no_mission_item() {
    for (mavtype, guided) in [
        (MavType::MAV_TYPE_QUADROTOR, 4),
        (MavType::MAV_TYPE_GROUND_ROVER, 15),
        (MavType::MAV_TYPE_FIXED_WING, 15),
    ] {
        let mut r = Run::new("ardupilot");
        for period in 0..40u64 {
            let t = period * 250 * MS;
            r.send(t, ardupilot_in(mavtype, guided));
            r.send(t + MS, current(0));
            r.send(t + 2 * MS, position(period as f64, 20.0));
            if period == 8 || period == 28 {
                r.send(t + 3 * MS, reached(0));
            }
        }
        let (gotos, items) = gotos_and_items(&r);
        assert_eq!(
            gotos.iter().map(|g| g.0).collect::<Vec<_>>(),
            [2 * S + 3 * MS, 7 * S + 3 * MS],
            "{mavtype:?}"
        );
        // Where the vehicle was at each: 8 and 28 m north, 20 m up.
        let north = |lat: f64| (lat * 1e7 + 35.36e7) / 90.0;
        assert!((north(gotos[0].1) - 8.0).abs() < 0.1, "{gotos:?}");
        assert!((north(gotos[1].1) - 28.0).abs() < 0.1, "{gotos:?}");
        assert!(gotos.iter().all(|g| (g.2 - 20.0).abs() < 1e-9), "{gotos:?}");
        assert!(items.is_empty(), "{mavtype:?}: {items:?}");
    }
    // Where the vehicle was is a state the gateway asks for
    // (GLOBAL_POSITION_INT, 33); the reach itself is not streamed (46).
    let telemetry = Profile::builtin("ardupilot")
        .expect("built-in profile")
        .telemetry();
    assert!(telemetry.contains(&33) && !telemetry.contains(&46));
}

/// In AUTO a MISSION_ITEM_REACHED 0 is no goto (ArduCopter's and
/// ArduRover's NAV_GUIDED_ENABLE) and no mission item either (item 0 is
/// home); ArduPlane's AVOID_ADSB (its GUIDED under another name, flying to
/// its own escape point) is neither; and a mission flown before the gotos
/// keeps its items, and is not told of the gotos once back in AUTO.
#[test]
fn no_goto_reached_outside_guided_and_the_mission_keeps_its_items() {
    for (mavtype, auto) in [
        (MavType::MAV_TYPE_QUADROTOR, 3),
        (MavType::MAV_TYPE_GROUND_ROVER, 10),
        (MavType::MAV_TYPE_FIXED_WING, 10),
    ] {
        let mut r = Run::new("ardupilot");
        r.send(0, ardupilot_in(mavtype, auto));
        r.send(MS, position(0.0, 20.0));
        r.send(S, reached(0));
        r.send(2 * S, ardupilot_in(mavtype, auto));
        let (gotos, items) = gotos_and_items(&r);
        assert!(gotos.is_empty(), "{mavtype:?} in AUTO: {gotos:?}");
        assert!(items.is_empty(), "{mavtype:?} in AUTO: {items:?}");
    }

    let plane = MavType::MAV_TYPE_FIXED_WING;
    let mut r = Run::new("ardupilot");
    r.send(0, ardupilot_in(plane, 14));
    r.send(MS, position(0.0, 100.0));
    r.send(S, reached(0));
    assert_eq!(gotos_and_items(&r), (vec![], vec![]), "AVOID_ADSB");

    // A copter's mission (items 1 and 2 in AUTO), then two gotos in GUIDED
    // with MISSION_CURRENT left at 2.
    let copter = MavType::MAV_TYPE_QUADROTOR;
    let mut r = Run::new("ardupilot");
    r.send(0, ardupilot_in(copter, 3));
    r.send(MS, position(0.0, 20.0));
    r.send(S, current(1));
    r.send(2 * S, reached(1));
    r.send(2 * S + MS, current(2));
    r.send(3 * S, reached(2));
    r.send(4 * S, ardupilot_in(copter, 4));
    // A heartbeat and the first goto reached at one instant, then the
    // second with no heartbeat between.
    r.send(5 * S, ardupilot_in(copter, 4));
    r.send(5 * S, reached(0));
    r.send(5 * S + MS, current(2));
    r.send(6 * S, reached(0));
    // Heartbeats after the second goto, the first at its very instant,
    // then back to AUTO and on to item 3.
    r.send(6 * S, ardupilot_in(copter, 4));
    r.send(7 * S, ardupilot_in(copter, 4));
    r.send(8 * S, ardupilot_in(copter, 3));
    r.send(8 * S + MS, current(3));
    r.send(9 * S, ardupilot_in(copter, 3));
    r.send(10 * S, reached(3));
    let (gotos, items) = gotos_and_items(&r);
    assert_eq!(
        items,
        [
            "mission_item_reached {seq: 1}",
            "mission_item_reached {seq: 2}",
            "mission_item_reached {seq: 3}"
        ]
    );
    assert_eq!(
        gotos.iter().map(|g| g.0).collect::<Vec<_>>(),
        [5 * S, 6 * S]
    );
}

#[test]
fn command_rejected_names_the_command_and_the_result() {
    let mut r = Run::new("ardupilot");
    r.send(0, copter(false, MavState::MAV_STATE_STANDBY));
    let mut ack = COMMAND_ACK_DATA::DEFAULT;
    ack.command = MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL;
    ack.result = MavResult::MAV_RESULT_DENIED;
    r.send(S, MavMessage::COMMAND_ACK(ack.clone()));
    ack.result = MavResult::MAV_RESULT_ACCEPTED;
    r.send(2 * S, MavMessage::COMMAND_ACK(ack));
    let rejected: Vec<&Elaborated> = r
        .out
        .iter()
        .filter(|e| e.event.name == "command_rejected")
        .collect();
    assert_eq!(rejected.len(), 1);
    let params = &rejected[0].event.params;
    assert_eq!(
        params.get("command"),
        Some(&nets::Value::Str("SET_MESSAGE_INTERVAL".into()))
    );
    assert_eq!(
        params.get("result"),
        Some(&nets::Value::Str("DENIED".into()))
    );
}

fn servos(outputs: [u16; 4]) -> MavMessage {
    let mut d = SERVO_OUTPUT_RAW_DATA::DEFAULT;
    d.servo1_raw = outputs[0];
    d.servo2_raw = outputs[1];
    d.servo3_raw = outputs[2];
    d.servo4_raw = outputs[3];
    MavMessage::SERVO_OUTPUT_RAW(d)
}

/// The outputs real ArduCopter SITL gave (SIM_ENGINE_MUL 0.65 on motor 1,
/// holding position): 1910 / 1591 / 1591 / 1591 µs.
#[test]
fn motor_imbalance_from_one_output_far_above_the_others() {
    // (from, to in 100 ms steps, outputs, armed and flying)
    type Phase = (u64, u64, [u16; 4], bool);
    let phases: [Phase; 7] = [
        // Hover.
        (0, 50, [1591, 1591, 1590, 1591], true),
        // A yaw move raises a pair for 1 s.
        (50, 60, [1632, 1631, 1572, 1570], true),
        // A hard yaw raises a pair far above the other for 4 s.
        (60, 100, [1800, 1790, 1400, 1390], true),
        // A steady diagonal torque with motor 2 pinned at its minimum (the
        // flood log): motor 1 far above, the others far apart.
        (100, 200, [1818, 1150, 1543, 1615], true),
        // Motor 3 weakened: 2.5 s, not yet sustained.
        (200, 225, [1591, 1591, 1910, 1591], true),
        (225, 230, [1591, 1591, 1591, 1591], true),
        // Then for good.
        (230, 300, [1591, 1590, 1910, 1591], true),
    ];
    let mut r = Run::new("ardupilot");
    for step in 0..300u64 {
        let t = step * 100 * MS;
        let Some(&(_, _, outputs, flying)) = phases.iter().find(|p| p.0 <= step && step < p.1)
        else {
            continue;
        };
        if step % 5 == 0 {
            let status = if flying {
                MavState::MAV_STATE_ACTIVE
            } else {
                MavState::MAV_STATE_STANDBY
            };
            r.send(t, copter(flying, status));
        }
        r.send(t + MS, servos(outputs));
    }
    let got = r.only(&["motor_imbalance"]);
    assert_eq!(got.len(), 1, "{got:?}");
    // Held from 23.0 s: fires on the frame at 26.0 s.
    assert_eq!(got[0].0, 26 * S + MS, "{got:?}");
    assert!(
        got[0]
            .1
            .starts_with("motor_imbalance {motor: 3, output: 1910"),
        "{got:?}"
    );
    assert_eq!(
        r.out
            .iter()
            .find(|e| e.event.name == "motor_imbalance")
            .map(|e| e.event.category),
        Some(nets::Category::Safety)
    );
    // On the ground (disarmed, outputs at idle apart), nothing.
    let mut r = Run::new("ardupilot");
    for step in 0..100u64 {
        let t = step * 100 * MS;
        if step % 5 == 0 {
            r.send(t, copter(false, MavState::MAV_STATE_STANDBY));
        }
        r.send(t + MS, servos([1400, 1000, 1000, 1000]));
    }
    assert_eq!(r.only(&["motor_imbalance"]), []);
}

/// ATTITUDE, angles in degrees.
fn attitude(roll: f32, pitch: f32) -> MavMessage {
    let mut d = ATTITUDE_DATA::DEFAULT;
    d.roll = roll.to_radians();
    d.pitch = pitch.to_radians();
    MavMessage::ATTITUDE(d)
}

/// NAV_CONTROLLER_OUTPUT: ArduCopter's attitude target, in degrees.
fn target(roll: f32, pitch: f32) -> MavMessage {
    let mut d = NAV_CONTROLLER_OUTPUT_DATA::DEFAULT;
    d.nav_roll = roll;
    d.nav_pitch = pitch;
    MavMessage::NAV_CONTROLLER_OUTPUT(d)
}

/// The attitude more than 80° off its target for 0.2 s (two samples at
/// 4 Hz), armed and flying: what real ArduCopter SITL showed with a motor
/// killed (87-100° off on two samples in a row, then spinning down 60-75°
/// off). Not a hard move tracked, not STABILIZE flown at 50° with the
/// target reported level (APM 2.x), not 1 s at 70° off, not one sample at
/// 95°, not ACRO inverted, not a copter lying on its side landed or
/// disarmed; and one loss is one event.
#[test]
fn loss_of_control_from_the_attitude_far_from_its_target() {
    use MavState::*;
    const GUIDED: u32 = 4;
    const STABILIZE: u32 = 0;
    const ACRO: u32 = 1;
    // (from, to in 250 ms steps, mode, armed, status, attitude, target)
    type Phase = (u64, u64, u32, bool, MavState, (f32, f32), (f32, f32));
    let phases: [Phase; 14] = [
        (
            0,
            40,
            GUIDED,
            true,
            MAV_STATE_ACTIVE,
            (0.0, 0.0),
            (0.0, 0.0),
        ),
        // A hard move, tracked.
        (
            40,
            56,
            GUIDED,
            true,
            MAV_STATE_ACTIVE,
            (2.0, -42.0),
            (0.0, -45.0),
        ),
        // STABILIZE flown hard, the target reported level (APM 2.x).
        (
            56,
            80,
            STABILIZE,
            true,
            MAV_STATE_ACTIVE,
            (20.0, -50.0),
            (0.0, 0.0),
        ),
        // 1 s at 70° off, then one sample at 95°.
        (
            80,
            84,
            STABILIZE,
            true,
            MAV_STATE_ACTIVE,
            (70.0, -10.0),
            (0.0, 0.0),
        ),
        (
            84,
            85,
            STABILIZE,
            true,
            MAV_STATE_ACTIVE,
            (95.0, 0.0),
            (0.0, 0.0),
        ),
        (
            85,
            100,
            STABILIZE,
            true,
            MAV_STATE_ACTIVE,
            (0.0, 0.0),
            (0.0, 0.0),
        ),
        // ACRO, inverted on purpose.
        (
            100,
            120,
            ACRO,
            true,
            MAV_STATE_ACTIVE,
            (180.0, 0.0),
            (0.0, 0.0),
        ),
        // Landed on its side, still armed.
        (
            120,
            132,
            GUIDED,
            true,
            MAV_STATE_STANDBY,
            (90.0, 0.0),
            (0.0, 0.0),
        ),
        (
            132,
            140,
            GUIDED,
            true,
            MAV_STATE_ACTIVE,
            (0.0, 0.0),
            (0.0, 0.0),
        ),
        // A motor lost in a failsafe's return (CRITICAL): the tumble, then
        // spinning down 70° off, a moment level, 90° off again.
        (
            140,
            143,
            GUIDED,
            true,
            MAV_STATE_CRITICAL,
            (85.0, 30.0),
            (-5.0, 5.0),
        ),
        (
            143,
            148,
            GUIDED,
            true,
            MAV_STATE_CRITICAL,
            (70.0, 20.0),
            (0.0, 0.0),
        ),
        (
            148,
            149,
            GUIDED,
            true,
            MAV_STATE_CRITICAL,
            (0.0, 0.0),
            (0.0, 0.0),
        ),
        (
            149,
            152,
            GUIDED,
            true,
            MAV_STATE_CRITICAL,
            (90.0, 0.0),
            (0.0, 0.0),
        ),
        // On the ground, disarmed, upside down.
        (
            152,
            170,
            GUIDED,
            false,
            MAV_STATE_STANDBY,
            (180.0, 0.0),
            (0.0, 0.0),
        ),
    ];
    let mut r = Run::new("ardupilot");
    for step in 0..170u64 {
        let t = step * 250 * MS;
        let Some(&(_, _, mode, armed, status, (roll, pitch), (troll, tpitch))) =
            phases.iter().find(|p| p.0 <= step && step < p.1)
        else {
            continue;
        };
        if step % 4 == 0 || phases.iter().any(|p| p.0 == step) {
            r.send(
                t,
                heartbeat_in(
                    MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                    mode,
                    armed,
                    status,
                ),
            );
        }
        r.send(t + MS, target(troll, tpitch));
        r.send(t + 2 * MS, attitude(roll, pitch));
    }
    let got: Vec<&Elaborated> = r
        .out
        .iter()
        .filter(|e| e.event.name == "loss_of_control")
        .collect();
    assert_eq!(got.len(), 1, "{got:?}");
    // 90° off its target from 35.0 s: fired on the next sample.
    assert_eq!(got[0].time_us, 35 * S + 250 * MS + 2 * MS, "{got:?}");
    assert_eq!(got[0].event.category, nets::Category::Catastrophic);
    let param = |name: &str| match got[0].event.params.get(name) {
        Some(nets::Value::Float(f)) => *f,
        other => panic!("{name}: {other:?}"),
    };
    assert!((param("roll") - 85.0).abs() < 0.01, "{got:?}");
    assert!((param("pitch") - 30.0).abs() < 0.01, "{got:?}");
    assert!((param("target_roll") + 5.0).abs() < 0.01, "{got:?}");
}

fn sensors(
    present: MavSysStatusSensor,
    enabled: MavSysStatusSensor,
    healthy: MavSysStatusSensor,
) -> MavMessage {
    let mut d = SYS_STATUS_DATA::DEFAULT;
    d.onboard_control_sensors_present = present;
    d.onboard_control_sensors_enabled = enabled;
    d.onboard_control_sensors_health = healthy;
    d.battery_remaining = 90;
    MavMessage::SYS_STATUS(d)
}

/// Real ArduCopter 4.7 with its fence on and breached reports the geofence
/// present but not enabled, and unhealthy; FENCE_STATUS says it plainly.
#[test]
fn geofence_breach_from_fence_status_or_the_health_bit() {
    let fence = MavSysStatusSensor::MAV_SYS_STATUS_GEOFENCE;
    let none = MavSysStatusSensor::empty();
    let fence_status = |breached: bool| {
        let mut d = FENCE_STATUS_DATA::DEFAULT;
        d.breach_status = u8::from(breached);
        d.breach_count = 1;
        d.breach_type = if breached {
            FenceBreach::FENCE_BREACH_MAXALT
        } else {
            FenceBreach::FENCE_BREACH_NONE
        };
        MavMessage::FENCE_STATUS(d)
    };
    // Without FENCE_STATUS: present, not enabled, unhealthy from 3 s to 6 s.
    let mut r = Run::new("ardupilot");
    r.send(0, copter(true, MavState::MAV_STATE_ACTIVE));
    for t in 0..10u64 {
        let healthy = if (3..6).contains(&t) { none } else { fence };
        r.send(t * S + MS, sensors(fence, none, healthy));
    }
    assert_eq!(
        r.only(&["geofence_breach"]),
        [(3 * S + MS, "geofence_breach".to_string())]
    );
    // With FENCE_STATUS it decides, and names the breach.
    let mut r = Run::new("ardupilot");
    r.send(0, copter(true, MavState::MAV_STATE_ACTIVE));
    for t in 0..10u64 {
        let breached = (3..6).contains(&t);
        r.send(
            t * S + MS,
            sensors(fence, none, if breached { none } else { fence }),
        );
        r.send(t * S + 2 * MS, fence_status(breached));
    }
    assert_eq!(
        r.only(&["geofence_breach"]),
        [(
            3 * S + 2 * MS,
            "geofence_breach {breach: \"MAXALT\"}".to_string()
        )]
    );
}

/// ArduCopter 4.7 says "Radio Failsafe - Continuing Guided Mode" and clears
/// SYS_STATUS's RC receiver health: one rc_lost, from SYS_STATUS. Where
/// SYS_STATUS does not report the receiver, the text says it.
#[test]
fn one_rc_lost_per_loss() {
    let rc = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_RC_RECEIVER;
    let none = MavSysStatusSensor::empty();
    let mut r = Run::new("ardupilot");
    r.send(0, copter(true, MavState::MAV_STATE_ACTIVE));
    for t in 0..10u64 {
        let healthy = if t >= 3 { none } else { rc };
        r.send(t * S + MS, sensors(rc, rc, healthy));
        if t == 3 {
            r.send(
                t * S + 2 * MS,
                text("Radio Failsafe - Continuing Guided Mode"),
            );
        }
    }
    assert_eq!(r.only(&["rc_lost"]), [(4 * S + MS, "rc_lost".to_string())]);
    let mut r = Run::new("ardupilot");
    r.send(0, copter(true, MavState::MAV_STATE_ACTIVE));
    r.send(MS, sensors(none, none, none));
    r.send(S, text("Radio Failsafe - Continuing Guided Mode"));
    r.send(2 * S, text("Radio Failsafe Cleared"));
    assert_eq!(r.only(&["rc_lost"]), [(S, "rc_lost".to_string())]);
}

/// PX4 without any manual control reports the receiver enabled, unhealthy
/// and not present (v1.18 SITL, 2 s after boot): no radio, not a radio
/// lost. A receiver it has (present) that goes unhealthy is rc_lost.
#[test]
fn px4_without_a_radio_has_not_lost_it() {
    let rc = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_RC_RECEIVER;
    let none = MavSysStatusSensor::empty();
    let px4 = || {
        heartbeat(
            MavAutopilot::MAV_AUTOPILOT_PX4,
            false,
            MavState::MAV_STATE_STANDBY,
        )
    };
    let mut r = Run::new("px4");
    r.send(0, px4());
    for t in 0..10u64 {
        let enabled = if t >= 2 { rc } else { none };
        r.send(t * S + MS, sensors(none, enabled, none));
    }
    assert_eq!(r.only(&["rc_lost"]), []);
    let mut r = Run::new("px4");
    r.send(0, px4());
    for t in 0..10u64 {
        let healthy = if t >= 3 { none } else { rc };
        r.send(t * S + MS, sensors(rc, rc, healthy));
    }
    assert_eq!(r.only(&["rc_lost"]), [(4 * S + MS, "rc_lost".to_string())]);
}

fn system_time(boot_ms: u32) -> MavMessage {
    let mut d = SYSTEM_TIME_DATA::DEFAULT;
    d.time_boot_ms = boot_ms;
    d.time_unix_usec = 1_700_000_000_000_000 + boot_ms as u64 * 1000;
    MavMessage::SYSTEM_TIME(d)
}

fn gps(fix: GpsFixType, satellites: u8) -> MavMessage {
    let mut d = GPS_RAW_INT_DATA::DEFAULT;
    d.fix_type = fix;
    d.satellites_visible = satellites;
    MavMessage::GPS_RAW_INT(d)
}

fn landed(state: MavLandedState) -> MavMessage {
    let mut d = EXTENDED_SYS_STATE_DATA::DEFAULT;
    d.landed_state = state;
    MavMessage::EXTENDED_SYS_STATE(d)
}

/// An ArduCopter (and a PX4 copter) that flies, reboots in flight (its time since boot back to
/// zero, its sequence numbers from 0 again), comes back disarmed without a
/// GPS fix, then gets its fix and is ready again.
#[test]
fn an_autopilot_reboot_is_detected_and_the_old_boot_is_no_baseline() {
    for profile in ["ardupilot", "px4"] {
        let mut r = Run::new(profile);
        let hb = |armed| {
            let autopilot = if profile == "px4" {
                MavAutopilot::MAV_AUTOPILOT_PX4
            } else {
                MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA
            };
            let status = if armed {
                MavState::MAV_STATE_ACTIVE
            } else {
                MavState::MAV_STATE_STANDBY
            };
            heartbeat(autopilot, armed, status)
        };
        // On the ground, ready (fix, battery, pre-arm checks), then armed
        // and flying for a minute.
        let mut boot_ms = 20_000u32;
        let mut t = 0;
        for _ in 0..5 {
            r.send(t, hb(false));
            r.send(
                t + MS / 2,
                MavMessage::HOME_POSITION(HOME_POSITION_DATA::DEFAULT),
            );
            r.send(t + MS, prearm(true, 100, 12600));
            r.send(t + 2 * MS, gps(GpsFixType::GPS_FIX_TYPE_3D_FIX, 12));
            r.send(t + 3 * MS, system_time(boot_ms));
            t += S;
            boot_ms += 1000;
        }
        for _ in 0..60 {
            r.send(t, hb(true));
            r.send(t + 2 * MS, landed(MavLandedState::MAV_LANDED_STATE_IN_AIR));
            r.send(t + 3 * MS, system_time(boot_ms));
            // A duplicated, late frame goes back a little: no reboot.
            r.send(t + 4 * MS, system_time(boot_ms - 300));
            t += S;
            boot_ms += 1000;
        }
        let before = r.out.len();
        let lost_before = r.elab.stats().sequence_lost;
        // The reboot: silence for 1.5 s (less than the link-loss time),
        // then a new boot: time since boot and sequence numbers from 0.
        t += 1_500 * MS;
        r.seq = 0;
        boot_ms = 300;
        r.send(t, system_time(boot_ms));
        let rebooted = r.only(&["autopilot_rebooted"]);
        assert_eq!(
            rebooted,
            [(t, "autopilot_rebooted {boot_ms: 300}".to_string())],
            "{profile}"
        );
        let e = r
            .out
            .iter()
            .find(|e| e.event.name == "autopilot_rebooted")
            .expect("the event");
        assert_eq!(e.event.category, nets::Category::Safety, "{profile}");
        assert_eq!(r.elab.stats().reboots, 1, "{profile}");
        // The new boot: disarmed (a real change, announced), no fix yet
        // but the previous boot's GPS fix and pre-arm health are forgotten:
        // not ready until the new boot says so.
        for _ in 0..5 {
            t += S;
            boot_ms += 1000;
            r.send(t, hb(false));
            r.send(t + 3 * MS, system_time(boot_ms));
        }
        let after: Vec<&str> = r.out[before..]
            .iter()
            .map(|e| e.event.name.as_str())
            .collect();
        assert!(after.contains(&"disarmed"), "{profile}: {after:?}");
        assert!(
            !after.contains(&"ready_for_takeoff"),
            "{profile}: {after:?}"
        );
        // Nothing invented: no link loss (the autopilot never went silent
        // for long), no loss counted for the sequence numbers' restart.
        assert!(!after.contains(&"link_lost"), "{profile}: {after:?}");
        assert_eq!(r.elab.stats().sequence_lost, lost_before, "{profile}");
        // Fresh data from the new boot: ready again (PX4 also needs its
        // home again, as it sends it once it has a fix).
        t += S;
        r.send(
            t - MS,
            MavMessage::HOME_POSITION(HOME_POSITION_DATA::DEFAULT),
        );
        r.send(t, prearm(true, 100, 12600));
        r.send(t + MS, gps(GpsFixType::GPS_FIX_TYPE_3D_FIX, 12));
        r.send(
            t + 2 * MS,
            landed(MavLandedState::MAV_LANDED_STATE_ON_GROUND),
        );
        r.send(t + 3 * MS, hb(false));
        let names: Vec<&str> = r.out[before..]
            .iter()
            .map(|e| e.event.name.as_str())
            .collect();
        assert!(names.contains(&"ready_for_takeoff"), "{profile}: {names:?}");
        // Only one reboot in all that.
        assert_eq!(r.only(&["autopilot_rebooted"]).len(), 1, "{profile}");
    }
}

/// A PX4 arming check with the modes it stops arming in (its first
/// argument, navigation_mode_group_t).
fn px4_check(id: u32, sequence: u16, modes: u32) -> MavMessage {
    let mut arguments = [0u8; 40];
    arguments[..4].copy_from_slice(&modes.to_le_bytes());
    MavMessage::EVENT(EVENT_DATA {
        id,
        log_levels: 0x44,
        sequence,
        arguments,
        ..EVENT_DATA::DEFAULT
    })
}

fn px4_heartbeat(custom_mode: u32, armed: bool) -> MavMessage {
    heartbeat_in(
        MavAutopilot::MAV_AUTOPILOT_PX4,
        custom_mode,
        armed,
        MavState::MAV_STATE_STANDBY,
    )
}

/// PX4's arming checks name the modes they stop arming in: a check of
/// other modes only ("No offboard signal" while in POSCTL) is no pre-arm
/// failure, nor is any check once armed (PX4 goes on publishing them in
/// flight); a HEARTBEAT after the check does not say it again.
#[test]
fn px4_arming_checks_are_filtered_by_the_mode_and_by_arming() {
    const POSCTL: u32 = 3 << 16;
    const AUTO_MISSION: u32 = (4 << 16) | (4 << 24);
    const OFFBOARD_ONLY: u32 = 1 << 14;
    const NO_MANUAL: u32 = 0x106_ed29;
    const NO_OFFBOARD: u32 = 0x1ae_ef7e;
    let mut r = Run::new("px4");
    r.send(0, px4_heartbeat(POSCTL, false));
    r.send(S, px4_check(NO_OFFBOARD, 1, OFFBOARD_ONLY));
    // Manual control is needed in POSCTL (bit 2) and other manual modes.
    r.send(2 * S, px4_check(NO_MANUAL, 2, 0b111));
    r.send(3 * S, px4_heartbeat(POSCTL, false));
    r.send(4 * S, px4_heartbeat(AUTO_MISSION, false));
    // In AUTO_MISSION (bit 3) the same check is not a reason.
    r.send(5 * S, px4_check(NO_MANUAL, 3, 0b111));
    r.send(6 * S, px4_heartbeat(AUTO_MISSION, true));
    // Armed: a check that would matter is not a pre-arm failure.
    r.send(7 * S, px4_check(NO_OFFBOARD, 4, u32::MAX));
    assert_eq!(
        r.only(&["prearm_failed"]),
        [(
            2 * S,
            "prearm_failed {text: \"No manual control input\"}".to_string()
        )]
    );
}

/// PX4 v1.18 clears the receiver's present bit as it loses its manual
/// control (a joystick's MANUAL_CONTROL stopped, as tried on its SITL) and
/// says "Manual control lost" in its events protocol: that is rc_lost.
#[test]
fn px4_manual_control_lost_is_rc_lost() {
    let rc = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_RC_RECEIVER;
    let none = MavSysStatusSensor::empty();
    let mut r = Run::new("px4");
    r.send(0, px4_heartbeat((4 << 16) | (4 << 24), true));
    for t in 0..10u64 {
        let (present, healthy) = if t >= 3 { (none, none) } else { (rc, rc) };
        r.send(t * S + MS, sensors(present, rc, healthy));
        if t == 3 {
            // commander_rc_lost, then PX4's failsafe.
            r.send(t * S + 2 * MS, px4_event(0x155_cd44, 0x22, 1));
        }
    }
    assert_eq!(
        r.only(&["rc_lost"]),
        [(3 * S + 2 * MS, "rc_lost".to_string())]
    );
}

/// One chunk of a long STATUSTEXT (MAVLink 2's id, chunk_seq).
fn chunk(id: u16, chunk_seq: u8, t: &str) -> MavMessage {
    let mut m = text(t);
    if let MavMessage::STATUSTEXT(d) = &mut m {
        d.id = id;
        d.chunk_seq = chunk_seq;
    }
    m
}

/// A text longer than 50 bytes comes in chunks: the rules read it whole,
/// once, on its last chunk (PX4's "RTL: start return at 505 m (15 m above
/// destination" + ")" as heard on its SITL; a pre-arm reason cut at 50
/// bytes would be a different reason each time).
#[test]
fn chunked_statustexts_are_read_whole() {
    let reason = "PreArm: Battery 1 below minimum arming voltage of 10.50V and more";
    let mut r = Run::new("ardupilot");
    r.send(0, copter(false, MavState::MAV_STATE_STANDBY));
    r.send(S, chunk(12, 0, &reason[..50]));
    r.send(S + MS, chunk(12, 1, &reason[50..]));
    // The same reason again in one piece is a repeat; a lone last chunk
    // whose beginning was lost is marked cut.
    r.send(2 * S, chunk(13, 0, &reason[..50]));
    r.send(2 * S + MS, chunk(13, 1, &reason[50..]));
    r.send(3 * S, chunk(14, 1, "lost its start"));
    let want = format!("prearm_failed {{text: \"{}\"}}", &reason[8..]);
    assert_eq!(r.only(&["prearm_failed"]), [(S + MS, want)]);
    let failsafe = "Failsafe activated: entering Hold for 5 seconds, then Return";
    let mut r = Run::new("px4");
    r.send(0, px4_heartbeat((4 << 16) | (5 << 24), true));
    r.send(S, chunk(3, 0, &failsafe[..50]));
    r.send(S + MS, chunk(3, 1, &failsafe[50..]));
    assert_eq!(
        r.only(&["autopilot_failsafe"]),
        [(
            S + MS,
            format!("autopilot_failsafe {{text: \"{failsafe}\"}}")
        )]
    );
}

/// The text rules that also read a state (the receiver not reported in
/// SYS_STATUS, BATTERY_STATUS absent or UNDEFINED) fire on the text only
/// (`on = "STATUSTEXT"`): the SYS_STATUS and BATTERY_STATUS that keep
/// coming after it, the last text unchanged, are not a new failsafe.
#[test]
fn a_failsafe_text_is_one_event_whatever_status_follows() {
    let none = MavSysStatusSensor::empty();
    let undefined = || {
        battery(
            MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_UNDEFINED,
            90,
        )
    };
    for (said, event) in [
        ("Radio Failsafe - Continuing Guided Mode", "rc_lost"),
        ("Battery 1 is low 10.41V used 120 mAh", "battery_low"),
        (
            "Battery 1 is critical 9.80V used 130 mAh",
            "battery_critical",
        ),
    ] {
        let mut r = Run::new("ardupilot");
        r.send(0, copter(true, MavState::MAV_STATE_ACTIVE));
        r.send(MS, sensors(none, none, none));
        r.send(2 * MS, undefined());
        r.send(S, text(said));
        for t in 2..6u64 {
            r.send(t * S, copter(true, MavState::MAV_STATE_ACTIVE));
            r.send(t * S + MS, sensors(none, none, none));
            r.send(t * S + 2 * MS, undefined());
        }
        let got = r.only(&[event]);
        assert_eq!(got.len(), 1, "{said}: {got:?}");
        assert_eq!(got[0].0, S, "{said}: {got:?}");
    }
}
