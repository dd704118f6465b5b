//! The built-in vocabulary, rule by rule, on synthetic flights: every event
//! of the minimum vocabulary comes out of `profiles/*.toml` (and
//! disappears when its rules are removed), only from the supervised
//! vehicle's components and the ground station.

use std::collections::BTreeSet;

use elaboration::frame::serialize;
use elaboration::{Config, Elaborated, Elaborator, Frame, Profile};
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};

const S: u64 = 1_000_000;
const MS: u64 = 1_000;

/// The minimum vocabulary of issue 4.
const VOCABULARY: [&str; 26] = [
    "armed",
    "disarmed",
    "mode_changed",
    "ready_for_takeoff",
    "takeoff",
    "landed",
    "mission_item_reached",
    "mission_complete",
    "command_rejected",
    "battery_low",
    "gps_lost",
    "gps_restored",
    "ekf_unhealthy",
    "geofence_breach",
    "rc_lost",
    "autopilot_failsafe",
    "battery_critical",
    "engine_failure",
    "vehicle_emergency",
    "link_lost",
    "link_restored",
    "gcs_lost",
    "gcs_restored",
    "link_degraded",
    "payload_failure",
    "autopilot_rebooted",
];

/// Frames from several senders, fed in time order through bytes, CRC and
/// decoding.
#[derive(Default, Clone)]
struct Script {
    frames: Vec<(u64, u8, u8, MavMessage)>,
}

impl Script {
    fn at(&mut self, t: u64, sysid: u8, compid: u8, msg: MavMessage) {
        self.frames.push((t, sysid, compid, msg));
    }

    fn run(&self, profile: Profile, end: u64) -> Vec<Elaborated> {
        let mut frames = self.frames.clone();
        frames.sort_by_key(|f| f.0);
        let mut elab = Elaborator::new(profile, Config::default());
        let mut seqs = std::collections::HashMap::<(u8, u8), u8>::new();
        let mut out = Vec::new();
        for (t, sysid, compid, msg) in &frames {
            let seq = seqs.entry((*sysid, *compid)).or_default();
            let h = MavHeader {
                system_id: *sysid as u32,
                component_id: *compid,
                sequence: *seq,
            };
            *seq = seq.wrapping_add(1);
            let bytes = serialize(h, MavlinkVersion::V2, msg);
            elab.frame(*t, &Frame::parse(&bytes).expect("valid frame"));
            elab.drain_into(&mut out);
        }
        elab.tick(end);
        elab.drain_into(&mut out);
        out
    }
}

fn timeline(events: &[Elaborated]) -> Vec<(u64, String)> {
    events
        .iter()
        .map(|e| (e.time_us, crate::summary(e)))
        .collect()
}

fn builtin(name: &str) -> Profile {
    Profile::builtin(name).expect("built-in profile")
}

fn heartbeat(
    autopilot: MavAutopilot,
    mavtype: MavType,
    armed: bool,
    custom_mode: u32,
    status: MavState,
) -> MavMessage {
    let mut base = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
    if armed {
        base |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
    }
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode,
        mavtype,
        autopilot,
        base_mode: base,
        system_status: status,
        mavlink_version: 3,
    })
}

fn copter(armed: bool, custom_mode: u32, status: MavState) -> MavMessage {
    heartbeat(
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        MavType::MAV_TYPE_QUADROTOR,
        armed,
        custom_mode,
        status,
    )
}

fn plane(armed: bool, status: MavState) -> MavMessage {
    heartbeat(
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        MavType::MAV_TYPE_FIXED_WING,
        armed,
        10,
        status,
    )
}

fn other(mavtype: MavType, status: MavState) -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        mavtype,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        system_status: status,
        ..HEARTBEAT_DATA::DEFAULT
    })
}

fn text(t: &str) -> MavMessage {
    let mut bytes = [0u8; 50];
    bytes[..t.len()].copy_from_slice(t.as_bytes());
    let mut d = STATUSTEXT_DATA::DEFAULT;
    d.text = mavlink::types::CharArray::new(bytes);
    MavMessage::STATUSTEXT(d)
}

/// SYS_STATUS with the pre-arm check, RC receiver and geofence present and
/// enabled; `unhealthy` of them not healthy.
fn sys_status(remaining: i8, unhealthy: MavSysStatusSensor) -> MavMessage {
    let sensors = MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK
        | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_RC_RECEIVER
        | MavSysStatusSensor::MAV_SYS_STATUS_GEOFENCE;
    let mut d = SYS_STATUS_DATA::DEFAULT;
    d.onboard_control_sensors_present = sensors;
    d.onboard_control_sensors_enabled = sensors;
    d.onboard_control_sensors_health = sensors - unhealthy;
    d.battery_remaining = remaining;
    MavMessage::SYS_STATUS(d)
}

fn gps(fix: GpsFixType, satellites: u8) -> MavMessage {
    let mut d = GPS_RAW_INT_DATA::DEFAULT;
    d.fix_type = fix;
    d.satellites_visible = satellites;
    MavMessage::GPS_RAW_INT(d)
}

/// ArduPilot's EKF report: 0x33f once it uses GPS (no CONST_POS_MODE).
fn ekf(flags: u16, variance: f32) -> MavMessage {
    let mut d = EKF_STATUS_REPORT_DATA::DEFAULT;
    d.flags = EkfStatusFlags::from_bits_retain(flags);
    d.velocity_variance = variance;
    d.pos_horiz_variance = variance;
    d.compass_variance = 0.1;
    MavMessage::EKF_STATUS_REPORT(d)
}

fn mission_current(state: MissionState) -> MavMessage {
    let mut d = MISSION_CURRENT_DATA::DEFAULT;
    d.mission_state = state;
    MavMessage::MISSION_CURRENT(d)
}

fn radio(rssi: u8, noise: u8) -> MavMessage {
    let mut d = RADIO_STATUS_DATA::DEFAULT;
    d.rssi = rssi;
    d.remrssi = rssi;
    d.noise = noise;
    d.remnoise = noise;
    MavMessage::RADIO_STATUS(d)
}

/// A copter flight of the ArduPilot profile that produces every event of
/// the vocabulary once (gcs and payload from their own senders), with a
/// second vehicle beside it whose armed, emergency heartbeats and texts
/// must produce nothing.
fn ardupilot_copter_flight() -> Script {
    use MavState::*;
    let none = MavSysStatusSensor::empty();
    let mut s = Script::default();
    for t in 0..60u64 {
        let at = t * S;
        // The autopilot 1/1, silent from 32 to 38 s.
        if !(32..38).contains(&t) {
            let (armed, mode, status) = match t {
                0..=1 => (false, 0, MAV_STATE_STANDBY),
                2 => (false, 4, MAV_STATE_STANDBY),
                3 => (true, 4, MAV_STATE_STANDBY),
                25 => (true, 4, MAV_STATE_CRITICAL),
                26 => (true, 4, MAV_STATE_EMERGENCY),
                30 => (true, 9, MAV_STATE_STANDBY),
                31.. => (false, 9, MAV_STATE_STANDBY),
                _ => (true, 4, MAV_STATE_ACTIVE),
            };
            s.at(at, 1, 1, copter(armed, mode, status));
            let battery = match t {
                8..=11 => 20,
                12.. => 8,
                _ => 90,
            };
            let mut unhealthy = none;
            if (21..40).contains(&t) {
                unhealthy |= MavSysStatusSensor::MAV_SYS_STATUS_GEOFENCE;
            }
            if (22..40).contains(&t) {
                unhealthy |= MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_RC_RECEIVER;
            }
            s.at(at + 10 * MS, 1, 1, sys_status(battery, unhealthy));
            let fix = if (16..19).contains(&t) {
                GpsFixType::GPS_FIX_TYPE_NO_FIX
            } else {
                GpsFixType::GPS_FIX_TYPE_3D_FIX
            };
            s.at(at + 20 * MS, 1, 1, gps(fix, 10));
            let variance = if (20..25).contains(&t) { 0.9 } else { 0.1 };
            s.at(at + 30 * MS, 1, 1, ekf(0x33f, variance));
            let state = if t >= 7 {
                MissionState::MISSION_STATE_COMPLETE
            } else {
                MissionState::MISSION_STATE_ACTIVE
            };
            s.at(at + 40 * MS, 1, 1, mission_current(state));
            // The autopilot reboots at 58 s: its time since boot from 0.
            let boot_ms = if t < 58 {
                200_000 + t * 1000
            } else {
                500 + (t - 58) * 1000
            };
            let mut st = SYSTEM_TIME_DATA::DEFAULT;
            st.time_boot_ms = boot_ms as u32;
            s.at(at + 45 * MS, 1, 1, MavMessage::SYSTEM_TIME(st));
        }
        // The ground station 255/190, silent from 40 to 50 s.
        if !(40..50).contains(&t) {
            s.at(
                at + 50 * MS,
                255,
                190,
                other(MavType::MAV_TYPE_GCS, MAV_STATE_ACTIVE),
            );
        }
        // A camera 1/100 that stops at 20 s; a gimbal 1/154 that says
        // CRITICAL from 44 s.
        if t < 20 {
            s.at(
                at + 60 * MS,
                1,
                100,
                other(MavType::MAV_TYPE_CAMERA, MAV_STATE_ACTIVE),
            );
        }
        let gimbal = if t >= 44 {
            MAV_STATE_CRITICAL
        } else {
            MAV_STATE_ACTIVE
        };
        s.at(
            at + 70 * MS,
            1,
            154,
            other(MavType::MAV_TYPE_GIMBAL, gimbal),
        );
        // The vehicle's radio 1/68: fade margin 5 from 50 s.
        let (rssi, noise) = if t >= 50 { (50, 45) } else { (150, 40) };
        s.at(at + 80 * MS, 1, 68, radio(rssi, noise));
        // Another vehicle, armed, in emergency, failing: none of it is ours.
        s.at(
            at + 90 * MS,
            2,
            1,
            copter(t % 2 == 0, t as u32 % 7, MAV_STATE_EMERGENCY),
        );
        s.at(
            at + 91 * MS,
            2,
            1,
            sys_status(5, MavSysStatusSensor::MAV_SYS_STATUS_GEOFENCE),
        );
        s.at(at + 92 * MS, 2, 1, text("Potential Thrust Loss (1)"));
    }
    let mut reached = MISSION_ITEM_REACHED_DATA::DEFAULT;
    reached.seq = 1;
    s.at(
        5 * S + 500 * MS,
        1,
        1,
        MavMessage::MISSION_ITEM_REACHED(reached),
    );
    let mut ack = COMMAND_ACK_DATA::DEFAULT;
    ack.command = MavCmd::MAV_CMD_DO_SET_MODE;
    ack.result = MavResult::MAV_RESULT_DENIED;
    s.at(6 * S + 500 * MS, 1, 1, MavMessage::COMMAND_ACK(ack));
    s.at(24 * S + 500 * MS, 1, 1, text("Potential Thrust Loss (2)"));
    s
}

#[test]
fn ardupilot_copter_flight_gives_the_whole_vocabulary() {
    let events = ardupilot_copter_flight().run(builtin("ardupilot"), 60 * S);
    let got = timeline(&events);
    let expected: Vec<(u64, &str)> = vec![
        // Disarmed, pre-arm healthy, 3D fix with 10 satellites, battery
        // 90 %: Figure 13's "ready for takeoff" once all are known (the EKF
        // counts once reported: its first report comes after).
        (20 * MS, "ready_for_takeoff {battery: 90, satellites: 10}"),
        (2 * S, "mode_changed {custom_mode: 4, mode: \"GUIDED\"}"),
        (3 * S, "armed {mode: \"GUIDED\"}"),
        (4 * S, "takeoff"),
        (5 * S + 500 * MS, "mission_item_reached {seq: 1}"),
        (
            6 * S + 500 * MS,
            "command_rejected {command: \"DO_SET_MODE\", result: \"DENIED\"}",
        ),
        (7 * S + 40 * MS, "mission_complete"),
        (11 * S + 10 * MS, "battery_low {remaining: 20}"),
        (15 * S + 10 * MS, "battery_critical {remaining: 8}"),
        // No fix from 16.02 s: 2.5 s later, on the 100 ms grid.
        (18 * S + 600 * MS, "gps_lost {fix_type: 1, satellites: 10}"),
        (19 * S + 20 * MS, "gps_restored"),
        (21 * S + 10 * MS, "geofence_breach"),
        (21 * S + 30 * MS, "ekf_unhealthy"),
        (23 * S + 10 * MS, "rc_lost"),
        // The camera's last heartbeat at 19.06 s: silent for more than 5 s.
        (24 * S + 100 * MS, "payload_failure {component: 100}"),
        (24 * S + 500 * MS, "engine_failure {motor: 2}"),
        (
            25 * S,
            "autopilot_failsafe {text: \"system_status CRITICAL\"}",
        ),
        (26 * S, "vehicle_emergency {system_status: 6}"),
        (30 * S, "mode_changed {custom_mode: 9, mode: \"LAND\"}"),
        (30 * S, "landed"),
        (31 * S, "disarmed {mode: \"LAND\"}"),
        // The autopilot's last heartbeat at 31 s: more than 3.5 s.
        (34 * S + 600 * MS, "link_lost"),
        (38 * S, "link_restored"),
        (44 * S + 70 * MS, "payload_failure {component: 154}"),
        // The ground station's last heartbeat at 39.05 s: more than 5 s.
        (44 * S + 100 * MS, "gcs_lost {compid: 190, sysid: 255}"),
        (50 * S + 50 * MS, "gcs_restored"),
        (55 * S + 80 * MS, "link_degraded {remrssi: 50, rssi: 50}"),
        (58 * S + 45 * MS, "autopilot_rebooted {boot_ms: 500}"),
    ];
    let pretty = got
        .iter()
        .map(|(t, s)| format!("{:9.3} {s}", *t as f64 / 1e6))
        .collect::<Vec<_>>()
        .join("\n");
    let want: Vec<(u64, String)> = expected.iter().map(|(t, s)| (*t, s.to_string())).collect();
    assert_eq!(got, want, "got\n{pretty}");
    // Nothing from the other vehicle; the GCS events carry its ids.
    assert!(events.iter().all(|e| e.sysid != 2), "{pretty}");
    let names: BTreeSet<&str> = events.iter().map(|e| e.event.name.as_str()).collect();
    let vocabulary: BTreeSet<&str> = VOCABULARY.into_iter().collect();
    assert_eq!(names, vocabulary);
}

/// "Every built-in event is defined by a rule in profiles/*.toml, none in
/// Rust code: a test that removes a rule sees its event disappear."
#[test]
fn removing_the_rules_of_an_event_removes_only_that_event() {
    let script = ardupilot_copter_flight();
    let base = elaboration::profile::ARDUPILOT;
    let all = builtin("ardupilot");
    let before = timeline(&script.run(all.clone(), 60 * S));
    for name in VOCABULARY {
        // The rules that produce `name`, as event or as cleared event.
        let rules: Vec<&elaboration::Rule> = all
            .rules()
            .iter()
            .filter(|r| r.event == name || r.cleared.as_ref().is_some_and(|c| c.0 == name))
            .collect();
        assert!(!rules.is_empty(), "no rule produces {name}");
        let gone: BTreeSet<&str> = rules
            .iter()
            .flat_map(|r| {
                std::iter::once(r.event.as_str()).chain(r.cleared.as_ref().map(|c| c.0.as_str()))
            })
            .collect();
        let layer: String = rules
            .iter()
            .map(|r| format!("[rules.{}]\nenabled = false\n", r.name))
            .collect();
        let profile =
            Profile::load(&[("ardupilot.toml", base), ("project.toml", &layer)]).expect("profile");
        let after = timeline(&script.run(profile, 60 * S));
        let kept: Vec<(u64, String)> = before
            .iter()
            .filter(|(_, s)| !gone.contains(s.split(' ').next().unwrap_or_default()))
            .cloned()
            .collect();
        assert_eq!(after, kept, "without the rules of {name}");
    }
    // With every rule removed, nothing at all.
    let layer: String = all
        .rules()
        .iter()
        .map(|r| format!("[rules.{}]\nenabled = false\n", r.name))
        .collect();
    let profile =
        Profile::load(&[("ardupilot.toml", base), ("project.toml", &layer)]).expect("profile");
    assert_eq!(script.run(profile, 60 * S), vec![]);
}

#[test]
fn a_project_recategorizes_a_rule_and_its_declaration_wins() {
    let layer = "[rules.battery_low]\ncategory = \"catastrophic\"\n\n[rules.gps_lost]\ncategory = \"mission\"\ncleared_category = \"nominal\"\n";
    let profile = Profile::load(&[
        ("ardupilot.toml", elaboration::profile::ARDUPILOT),
        ("project.toml", layer),
    ])
    .expect("profile");
    let events = ardupilot_copter_flight().run(profile, 60 * S);
    let category = |name: &str| -> Vec<nets::Category> {
        events
            .iter()
            .filter(|e| e.event.name == name)
            .map(|e| e.event.category)
            .collect()
    };
    assert_eq!(category("battery_low"), [nets::Category::Catastrophic]);
    assert_eq!(category("gps_lost"), [nets::Category::Mission]);
    assert_eq!(category("gps_restored"), [nets::Category::Nominal]);
    // The rest keeps the built-in categories.
    assert_eq!(category("battery_critical"), [nets::Category::Catastrophic]);
    assert_eq!(category("rc_lost"), [nets::Category::Safety]);
}

#[test]
fn both_builtin_profiles_define_the_whole_vocabulary_with_its_categories() {
    use nets::Category::*;
    let category = |name: &str| match name {
        "armed" | "disarmed" | "mode_changed" | "ready_for_takeoff" | "prearm_failed" => Nominal,
        "takeoff"
        | "landed"
        | "mission_item_reached"
        | "goto_reached"
        | "mission_complete"
        | "command_rejected"
        | "payload_failure" => Mission,
        "battery_low" | "gps_lost" | "gps_restored" | "ekf_unhealthy" | "geofence_breach"
        | "rc_lost" | "autopilot_failsafe" | "motor_imbalance" | "autopilot_rebooted" => Safety,
        "battery_critical" | "engine_failure" | "vehicle_emergency" | "loss_of_control" => {
            Catastrophic
        }
        _ => Communication,
    };
    for name in ["ardupilot", "px4"] {
        let profile = builtin(name);
        let catalog = profile.catalog();
        for event in VOCABULARY {
            let entry = catalog
                .get(event)
                .unwrap_or_else(|| panic!("{name}.toml has no rule for {event}"));
            assert_eq!(entry.category, Some(category(event)), "{name}: {event}");
        }
        // Every rule of an event agrees on its category.
        for r in profile.rules() {
            assert_eq!(r.category, category(&r.event), "{name}: rule {}", r.name);
        }
    }
}

/// Figure 13's elaboration: each condition of ready_for_takeoff alone keeps
/// it from firing.
#[test]
fn ready_for_takeoff_needs_every_condition() {
    use MavState::*;
    let none = MavSysStatusSensor::empty();
    type Spoil = fn(&mut (MavMessage, MavMessage, MavMessage, MavMessage));
    let cases: [(&str, Spoil); 7] = [
        ("all good", |_| {}),
        ("pre-arm check failing", |m| {
            m.1 = sys_status(90, MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK)
        }),
        ("2D fix", |m| m.2 = gps(GpsFixType::GPS_FIX_TYPE_2D_FIX, 10)),
        ("5 satellites", |m| {
            m.2 = gps(GpsFixType::GPS_FIX_TYPE_3D_FIX, 5)
        }),
        // Before ArduPilot's EKF uses GPS: CONST_POS_MODE, no absolute position.
        ("EKF in constant-position mode", |m| m.3 = ekf(0xa7, 0.1)),
        ("battery 40 %", |m| {
            m.1 = sys_status(40, MavSysStatusSensor::empty())
        }),
        ("armed and flying", |m| {
            m.0 = copter(true, 4, MAV_STATE_ACTIVE)
        }),
    ];
    for (i, (what, spoil)) in cases.iter().enumerate() {
        let mut m = (
            copter(false, 4, MAV_STATE_STANDBY),
            sys_status(90, none),
            gps(GpsFixType::GPS_FIX_TYPE_3D_FIX, 10),
            ekf(0x33f, 0.1),
        );
        spoil(&mut m);
        let mut s = Script::default();
        for t in 0..3 {
            s.at(t * S, 1, 1, m.0.clone());
            s.at(t * S + 1, 1, 1, m.3.clone());
            s.at(t * S + 2, 1, 1, m.1.clone());
            s.at(t * S + 3, 1, 1, m.2.clone());
        }
        let ready = s
            .run(builtin("ardupilot"), 3 * S)
            .iter()
            .filter(|e| e.event.name == "ready_for_takeoff")
            .count();
        assert_eq!(ready, usize::from(i == 0), "{what}");
    }
    // Armed but still on the ground (STANDBY) is ready; a firmware without
    // the pre-arm bit present is judged on the rest.
    let mut s = Script::default();
    let mut no_prearm = SYS_STATUS_DATA::DEFAULT;
    no_prearm.battery_remaining = -1;
    s.at(0, 1, 1, copter(true, 4, MAV_STATE_STANDBY));
    s.at(1, 1, 1, MavMessage::SYS_STATUS(no_prearm));
    s.at(2, 1, 1, gps(GpsFixType::GPS_FIX_TYPE_3D_FIX, 6));
    let events = s.run(builtin("ardupilot"), S);
    assert_eq!(
        timeline(&events),
        [(
            2,
            "ready_for_takeoff {battery: -1, satellites: 6}".to_string()
        )]
    );
}

#[test]
fn ardupilot_takeoff_and_landing_from_extended_sys_state() {
    let landed = |state: MavLandedState| {
        let mut d = EXTENDED_SYS_STATE_DATA::DEFAULT;
        d.landed_state = state;
        MavMessage::EXTENDED_SYS_STATE(d)
    };
    let mut s = Script::default();
    use MavLandedState::*;
    use MavState::*;
    // Where EXTENDED_SYS_STATE is streamed it decides, and the status edges
    // (STANDBY -> ACTIVE at 2 s, ACTIVE -> STANDBY at 6 s) are not taken
    // (the events come 1 µs later, with EXTENDED_SYS_STATE). Off the ground
    // is TAKEOFF or IN_AIR: the take-off climb is flying already.
    let states = [
        (MAV_LANDED_STATE_ON_GROUND, false, MAV_STATE_STANDBY),
        (MAV_LANDED_STATE_ON_GROUND, true, MAV_STATE_STANDBY),
        (MAV_LANDED_STATE_TAKEOFF, true, MAV_STATE_ACTIVE),
        (MAV_LANDED_STATE_IN_AIR, true, MAV_STATE_ACTIVE),
        (MAV_LANDED_STATE_IN_AIR, true, MAV_STATE_ACTIVE),
        (MAV_LANDED_STATE_LANDING, true, MAV_STATE_ACTIVE),
        (MAV_LANDED_STATE_ON_GROUND, true, MAV_STATE_STANDBY),
        (MAV_LANDED_STATE_ON_GROUND, false, MAV_STATE_STANDBY),
    ];
    for (t, (state, armed, status)) in states.into_iter().enumerate() {
        let t = t as u64 * S;
        s.at(t, 1, 1, copter(armed, 5, status));
        s.at(t + 1, 1, 1, landed(state));
    }
    let got: Vec<(u64, String)> = timeline(&s.run(builtin("ardupilot"), 8 * S))
        .into_iter()
        .filter(|(_, e)| e == "takeoff" || e == "landed")
        .collect();
    assert_eq!(
        got,
        [
            (2 * S + 1, "takeoff".to_string()),
            (6 * S + 1, "landed".to_string())
        ]
    );
}

#[test]
fn plane_engine_failure_from_efi_and_from_esc_telemetry() {
    use MavState::*;
    let vfr = |throttle: u16| {
        let mut d = VFR_HUD_DATA::DEFAULT;
        d.throttle = throttle;
        MavMessage::VFR_HUD(d)
    };
    // ArduPlane reports its throttle motor's ESC (servo 3: index 2).
    let esc = |rpm: u16| {
        let mut d = ESC_TELEMETRY_1_TO_4_DATA::DEFAULT;
        d.rpm = [0, 0, rpm, 0];
        d.count = [0, 0, 100, 0];
        MavMessage::ESC_TELEMETRY_1_TO_4(d)
    };
    let efi = |rpm: f32, throttle: f32| {
        let mut d = EFI_STATUS_DATA::DEFAULT;
        d.rpm = rpm;
        d.throttle_out = throttle;
        MavMessage::EFI_STATUS(d)
    };
    let failures = |s: &Script, until: u64| -> Vec<(u64, String)> {
        timeline(&s.run(builtin("ardupilot"), until))
            .into_iter()
            .filter(|(_, e)| e.starts_with("engine_failure"))
            .collect()
    };
    // Electric: the motor stops at 10 s under 60 % throttle; a 1.5 s dip
    // at 4 s and an idle motor at 0 % throttle (20-25 s) are not failures.
    let mut s = Script::default();
    for step in 0..60u64 {
        let t = step * S / 2;
        s.at(t, 1, 1, plane(true, MAV_STATE_ACTIVE));
        let throttle = if (40..50).contains(&step) { 0 } else { 60 };
        s.at(t + 1, 1, 1, vfr(throttle));
        let rpm = match step {
            8..=10 => 100,
            20..=29 => 0,
            40..=49 => 0,
            _ => 3500,
        };
        s.at(t + 2, 1, 1, esc(rpm));
    }
    let got = failures(&s, 30 * S);
    assert_eq!(
        got,
        [(12 * S + 2, "engine_failure {throttle: 60}".to_string())]
    );
    // A glide after the failure: the throttle falls under 20 % and rises
    // again while the motor stays stopped (the autopilot asks for power to
    // hold its airspeed). One failure, not two; the motor turning again
    // re-arms the rule, and its second stop is a second failure.
    let mut s = Script::default();
    for step in 0..60u64 {
        let t = step * S / 2;
        s.at(t, 1, 1, plane(true, MAV_STATE_ACTIVE));
        let throttle = if (20..30).contains(&step) { 10 } else { 60 };
        s.at(t + 1, 1, 1, vfr(throttle));
        let rpm = if (10..40).contains(&step) || step >= 50 {
            0
        } else {
            3500
        };
        s.at(t + 2, 1, 1, esc(rpm));
    }
    let got = failures(&s, 30 * S);
    assert_eq!(
        got,
        [
            (7 * S + 2, "engine_failure {throttle: 60}".to_string()),
            (27 * S + 2, "engine_failure {throttle: 60}".to_string())
        ]
    );
    // All ESCs silent (count 0, as SITL copters report): nothing.
    let mut s = Script::default();
    for step in 0..20u64 {
        s.at(step * S, 1, 1, plane(true, MAV_STATE_ACTIVE));
        s.at(step * S + 1, 1, 1, vfr(60));
        s.at(
            step * S + 2,
            1,
            1,
            MavMessage::ESC_TELEMETRY_1_TO_4(ESC_TELEMETRY_1_TO_4_DATA::DEFAULT),
        );
    }
    assert!(s
        .run(builtin("ardupilot"), 20 * S)
        .iter()
        .all(|e| e.event.name != "engine_failure"));
    // Combustion: EFI rpm under idle with throttle 50 % for 2 s. The ESC
    // telemetry that also reports the stopped engine (as the simulated
    // ArduPlane sends both) does not give a second event.
    // The throttle's dip under 20 % (12-14 s) during the glide gives no
    // second event either.
    let mut s = Script::default();
    for step in 0..20u64 {
        s.at(step * S, 1, 1, plane(true, MAV_STATE_ACTIVE));
        let rpm = if step >= 5 { 0.0 } else { 5200.0 };
        let throttle = if (12..15).contains(&step) { 5 } else { 50 };
        s.at(step * S + 1, 1, 1, efi(rpm, throttle as f32));
        s.at(step * S + 2, 1, 1, vfr(throttle));
        s.at(step * S + 3, 1, 1, esc(rpm as u16));
    }
    let got = failures(&s, 20 * S);
    assert_eq!(got, [(7 * S + 1, "engine_failure".to_string())]);
}

/// The PX4 rules no shared recording exercises, on a synthetic PX4 quad.
#[test]
fn px4_rules_on_a_synthetic_quad() {
    use MavState::*;
    let px4 = |armed: bool, main: u32, sub: u32, status: MavState| {
        heartbeat(
            MavAutopilot::MAV_AUTOPILOT_PX4,
            MavType::MAV_TYPE_QUADROTOR,
            armed,
            (main << 16) | (sub << 24),
            status,
        )
    };
    let estimator = |flags: u16, ratio: f32| {
        let mut d = ESTIMATOR_STATUS_DATA::DEFAULT;
        d.flags = EstimatorStatusFlags::from_bits_retain(flags);
        d.vel_ratio = ratio;
        d.pos_horiz_ratio = ratio;
        d.mag_ratio = 0.1;
        MavMessage::ESTIMATOR_STATUS(d)
    };
    // Attitude, horizontal velocity, horizontal absolute position.
    let good = (EstimatorStatusFlags::ESTIMATOR_ATTITUDE
        | EstimatorStatusFlags::ESTIMATOR_VELOCITY_HORIZ
        | EstimatorStatusFlags::ESTIMATOR_POS_HORIZ_ABS)
        .bits();
    let battery = |state: MavBatteryChargeState| {
        let mut d = BATTERY_STATUS_DATA::DEFAULT;
        d.charge_state = state;
        d.battery_remaining = 18;
        MavMessage::BATTERY_STATUS(d)
    };
    let esc_info = |flags: u16| {
        let mut d = ESC_INFO_DATA::DEFAULT;
        d.failure_flags = [0, flags, 0, 0];
        MavMessage::ESC_INFO(d)
    };
    let mut s = Script::default();
    // Home set (PX4 arms only then): HOME_POSITION, before the rest.
    s.at(
        0,
        1,
        1,
        MavMessage::HOME_POSITION(HOME_POSITION_DATA::DEFAULT),
    );
    for t in 0..20u64 {
        let at = t * S;
        let (armed, main, sub, status) = match t {
            0..=1 => (false, 2, 0, MAV_STATE_STANDBY),
            2..=3 => (true, 4, 2, MAV_STATE_ACTIVE),
            18.. => (true, 10, 0, MAV_STATE_FLIGHT_TERMINATION),
            _ => (true, 4, 4, MAV_STATE_ACTIVE),
        };
        s.at(at, 1, 1, px4(armed, main, sub, status));
        s.at(at + 1, 1, 1, sys_status(-1, MavSysStatusSensor::empty()));
        s.at(at + 2, 1, 1, gps(GpsFixType::GPS_FIX_TYPE_3D_FIX, 12));
        let ratio = if (8..11).contains(&t) { 1.5 } else { 0.2 };
        s.at(at + 3, 1, 1, estimator(good, ratio));
        let state = if t >= 12 {
            MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_LOW
        } else {
            MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_OK
        };
        s.at(at + 4, 1, 1, battery(state));
        s.at(at + 5, 1, 1, esc_info(if t >= 14 { 1 } else { 0 }));
    }
    let got = timeline(&s.run(builtin("px4"), 20 * S));
    let want: Vec<(u64, String)> = [
        // Battery unknown (-1), 3D fix, 12 satellites; no ESTIMATOR_STATUS yet.
        (2, "ready_for_takeoff {battery: -1, satellites: 12}"),
        (2 * S, "armed {mode: \"AUTO_TAKEOFF\"}"),
        (
            2 * S,
            "mode_changed {custom_mode: 33816576, mode: \"AUTO_TAKEOFF\"}",
        ),
        (
            4 * S,
            "mode_changed {custom_mode: 67371008, mode: \"AUTO_MISSION\"}",
        ),
        (9 * S + 3, "ekf_unhealthy"),
        (
            12 * S + 4,
            "battery_low {charge_state: \"LOW\", remaining: 18}",
        ),
        (15 * S + 5, "engine_failure"),
        (
            18 * S,
            "mode_changed {custom_mode: 655360, mode: \"TERMINATION\"}",
        ),
        (18 * S, "vehicle_emergency {system_status: 8}"),
    ]
    .iter()
    .map(|(t, s)| (*t, s.to_string()))
    .collect();
    assert_eq!(got, want);
}

/// `gcs_lost` only once a ground station has been heard: a vehicle flying
/// without one for a minute gives none; a station heard once and then
/// silent gives it, per station.
#[test]
fn gcs_lost_needs_a_ground_station_heard_first() {
    use MavState::*;
    let mut s = Script::default();
    for t in 0..60u64 {
        s.at(t * S, 1, 1, copter(false, 0, MAV_STATE_STANDBY));
    }
    let events = s.run(builtin("ardupilot"), 60 * S);
    assert!(
        events.iter().all(|e| !e.event.name.starts_with("gcs_")),
        "{:?}",
        timeline(&events)
    );
    // Two stations: 255/190 heard until 9 s, 254/1 throughout.
    for t in 0..10u64 {
        s.at(
            t * S + 1,
            255,
            190,
            other(MavType::MAV_TYPE_GCS, MAV_STATE_ACTIVE),
        );
    }
    for t in 0..60u64 {
        s.at(
            t * S + 2,
            254,
            1,
            other(MavType::MAV_TYPE_GCS, MAV_STATE_ACTIVE),
        );
    }
    let got: Vec<(u64, String)> = timeline(&s.run(builtin("ardupilot"), 60 * S))
        .into_iter()
        .filter(|(_, e)| e.starts_with("gcs_"))
        .collect();
    assert_eq!(
        got,
        [(
            14 * S + 100 * MS,
            "gcs_lost {compid: 190, sysid: 255}".to_string()
        )]
    );
}

/// The events of one firmware only, as docs/px4.md lists them ("ArduPilot
/// only: `a`, …", "PX4 only: …"), under its marker comment.
fn documented_as_one_firmware(firmware: &str) -> BTreeSet<String> {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/px4.md"))
        .expect("docs/px4.md");
    let marker = "<!-- read by elaboration/tests/elaboration/vocabulary.rs -->";
    let list = doc
        .split(marker)
        .nth(1)
        .expect("docs/px4.md keeps its list of one-firmware events");
    let prefix = format!("- {firmware} only:");
    let item = list
        .split("\n- ")
        .map(|i| format!("- {}", i.trim_start_matches("- ")))
        .find(|i| i.starts_with(&prefix))
        .unwrap_or_else(|| panic!("docs/px4.md: no `{prefix}` item"));
    // The names in backquotes before the first dash of explanation.
    let names = item[prefix.len()..].split(" — ").next().unwrap_or("");
    names
        .split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_owned)
        .collect()
}

fn events_of(profile: &str) -> BTreeSet<String> {
    builtin(profile).catalog().keys().cloned().collect()
}

/// One vocabulary: every event of the ArduPilot profile is in the PX4
/// profile or documented as ArduPilot's only, and the reverse; nothing is
/// documented as one firmware's that both have.
#[test]
fn one_vocabulary_for_ardupilot_and_px4() {
    let ardupilot = events_of("ardupilot");
    let px4 = events_of("px4");
    let ardupilot_only = documented_as_one_firmware("ArduPilot");
    let px4_only = documented_as_one_firmware("PX4");
    let missing_in_px4: BTreeSet<String> = ardupilot.difference(&px4).cloned().collect();
    let missing_in_ardupilot: BTreeSet<String> = px4.difference(&ardupilot).cloned().collect();
    assert_eq!(
        missing_in_px4, ardupilot_only,
        "ArduPilot's events missing in px4.toml must be those docs/px4.md lists as ArduPilot only"
    );
    assert_eq!(
        missing_in_ardupilot, px4_only,
        "PX4's events missing in ardupilot.toml must be those docs/px4.md lists as PX4 only"
    );
    assert!(ardupilot.contains("prearm_failed") && px4.contains("prearm_failed"));
    // The minimum vocabulary is in both.
    for e in VOCABULARY {
        assert!(ardupilot.contains(e) && px4.contains(e), "{e}");
    }
}

/// PX4 SIH's battery settles at SIM_BAT_MIN_PCT = 50 % (v1.18 reports 51
/// there and holds it, tried on its SITL), the take-off threshold of
/// `ready_for_takeoff`. Landed at the floor: ready once, and not again while
/// it holds. A real battery jittering across 50 % (49, 50, 51 every second)
/// does not make readiness flap either: said again only after 5 s below.
#[test]
fn px4_readiness_does_not_flap_at_the_battery_threshold() {
    use MavState::*;
    let px4 = |armed: bool| {
        heartbeat(
            MavAutopilot::MAV_AUTOPILOT_PX4,
            MavType::MAV_TYPE_QUADROTOR,
            armed,
            (4 << 16) | (3 << 24),
            if armed {
                MAV_STATE_ACTIVE
            } else {
                MAV_STATE_STANDBY
            },
        )
    };
    let landed = |state: MavLandedState| {
        let mut d = EXTENDED_SYS_STATE_DATA::DEFAULT;
        d.landed_state = state;
        MavMessage::EXTENDED_SYS_STATE(d)
    };
    // PX4 v1.18 SITL does not mark the pre-arm check present.
    let battery = |remaining: i8| {
        let mut d = SYS_STATUS_DATA::DEFAULT;
        d.battery_remaining = remaining;
        MavMessage::SYS_STATUS(d)
    };
    let mut s = Script::default();
    s.at(
        0,
        1,
        1,
        MavMessage::HOME_POSITION(HOME_POSITION_DATA::DEFAULT),
    );
    // Every 250 ms: (time in quarter seconds, armed, landed, battery).
    let mut script: Vec<(u64, bool, MavLandedState, i8)> = Vec::new();
    use MavLandedState::*;
    for q in 0..40 {
        script.push((q, false, MAV_LANDED_STATE_ON_GROUND, 100));
    }
    // 60 s of flight draining to 51, then down at 51 and held for 60 s.
    for q in 40..280 {
        let drained = (100 - (q - 40) as i64 / 4).max(51) as i8;
        script.push((q, true, MAV_LANDED_STATE_IN_AIR, drained));
    }
    for q in 280..520 {
        script.push((q, q < 290, MAV_LANDED_STATE_ON_GROUND, 51));
    }
    // A real battery across the threshold, changing every second.
    for q in 520..760 {
        let jitter = [49, 50, 51, 50][(q / 4 % 4) as usize];
        script.push((q, false, MAV_LANDED_STATE_ON_GROUND, jitter));
    }
    // Then 10 s below, and back: said again, once.
    for q in 760..800 {
        script.push((q, false, MAV_LANDED_STATE_ON_GROUND, 49));
    }
    for q in 800..840 {
        script.push((q, false, MAV_LANDED_STATE_ON_GROUND, 50));
    }
    for (q, armed, state, remaining) in script {
        let t = q * S / 4;
        s.at(t + 1, 1, 1, px4(armed));
        s.at(t + 2, 1, 1, landed(state));
        s.at(t + 3, 1, 1, battery(remaining));
        s.at(t + 4, 1, 1, gps(GpsFixType::GPS_FIX_TYPE_3D_FIX, 10));
    }
    let ready: Vec<(u64, String)> = timeline(&s.run(builtin("px4"), 210 * S))
        .into_iter()
        .filter(|(_, e)| e.starts_with("ready_for_takeoff"))
        .collect();
    assert_eq!(
        ready,
        [
            (
                4,
                "ready_for_takeoff {battery: 100, satellites: 10}".to_string()
            ),
            // On the landed state's message (armed, on the ground).
            (
                70 * S + 2,
                "ready_for_takeoff {battery: 51, satellites: 10}".to_string()
            ),
            // On the battery's.
            (
                200 * S + 3,
                "ready_for_takeoff {battery: 50, satellites: 10}".to_string()
            ),
        ]
    );
}
