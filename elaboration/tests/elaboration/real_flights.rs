//! Expected event timelines of the recorded flights in ../shared/telemetry.
//!
//! Every expected time below was read from the frames themselves with
//! pymavlink 2.4.50 (HEARTBEAT base_mode/custom_mode/system_status changes
//! of the autopilot 1/1, GPS_RAW_INT.fix_type changes, COMMAND_ACK,
//! MISSION_ITEM_REACHED, STATUSTEXT, and the last autopilot HEARTBEAT);
//! times are seconds since the first frame of the file. Frame-triggered
//! events must match to the millisecond; timeouts are evaluated on a
//! 100 ms grid and must fire within 0.1 s after their deadline.

use std::path::PathBuf;

use elaboration::{Config, Profile};

use crate::{elaborate, summary};

fn shared() -> Option<PathBuf> {
    let dir = crate::skip::shared_dir().join("telemetry");
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!(
            "{} is missing: CI must run with ../shared beside the workspace",
            dir.display()
        );
    }
    crate::skip::skip(&format!(
        "{} not found (real-flight tests need ../shared)",
        dir.display()
    ));
    None
}

fn read(name: &str) -> Option<Vec<u8>> {
    let path = shared()?.join(name);
    Some(std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
}

/// (time, summary, tolerance): frame-triggered events 0.001 s; timeouts
/// fire up to 0.1 s after their deadline.
const EXACT: f64 = 0.0015;
const TIMEOUT: f64 = 0.1;

fn check(name: &str, profile: &str, expected: &[(f64, &str, f64)]) {
    let Some(bytes) = read(name) else { return };
    let profile = Profile::builtin(profile).expect("built-in profile");
    let (events, _, _) = elaborate(&bytes, profile, Config::default());
    let got: Vec<(f64, String)> = events.iter().map(|(t, e)| (*t, summary(e))).collect();
    let pretty = got
        .iter()
        .map(|(t, s)| format!("{t:9.3} {s}"))
        .collect::<Vec<_>>()
        .join("\n");
    assert_eq!(got.len(), expected.len(), "{name}: got\n{pretty}");
    for ((t, s), (et, es, tol)) in got.iter().zip(expected) {
        assert_eq!(s, es, "{name} at {t:.3}: got\n{pretty}");
        assert!(
            *t >= et - EXACT && *t <= et + tol,
            "{name}: {s} at {t:.3}, expected {et:.3} (+{tol}); got\n{pretty}"
        );
    }
}

fn items(times: &[(f64, i64)]) -> Vec<(f64, String, f64)> {
    times
        .iter()
        .map(|(t, seq)| (*t, format!("mission_item_reached {{seq: {seq}}}"), EXACT))
        .collect()
}

fn merge(mut a: Vec<(f64, String, f64)>, b: Vec<(f64, String, f64)>) -> Vec<(f64, String, f64)> {
    a.extend(b);
    a.sort_by(|x, y| x.0.total_cmp(&y.0));
    a
}

fn owned(v: &[(f64, &str, f64)]) -> Vec<(f64, String, f64)> {
    v.iter()
        .map(|(t, s, tol)| (*t, s.to_string(), *tol))
        .collect()
}

fn check_owned(name: &str, profile: &str, expected: &[(f64, String, f64)]) {
    let borrowed: Vec<(f64, &str, f64)> = expected
        .iter()
        .map(|(t, s, tol)| (*t, s.as_str(), *tol))
        .collect();
    check(name, profile, &borrowed);
}

#[test]
fn sitl_copter_guided_takeoff_and_land() {
    check(
        "SITL_arducopter-4.7.0dev_guided_takeoff_land.tlog",
        "ardupilot",
        &[
            // EKF flags 0x33f (POS_HORIZ_ABS, no CONST_POS_MODE) with a 3D fix,
            // 10 satellites and the pre-arm bit healthy since 22.53 s.
            (
                40.782,
                "ready_for_takeoff {battery: 100, satellites: 10}",
                EXACT,
            ),
            (
                40.787,
                "mode_changed {custom_mode: 4, mode: \"GUIDED\"}",
                EXACT,
            ),
            (41.022, "armed {mode: \"GUIDED\"}", EXACT),
            // system_status STANDBY -> ACTIVE while armed.
            (45.024, "takeoff", EXACT),
            (
                64.289,
                "mode_changed {custom_mode: 9, mode: \"LAND\"}",
                EXACT,
            ),
            (95.028, "disarmed {mode: \"LAND\"}", EXACT),
            (
                95.028,
                "ready_for_takeoff {battery: 88, satellites: 10}",
                EXACT,
            ),
            (95.028, "landed", EXACT),
        ],
    );
}

#[test]
fn sitl_plane_auto_mission() {
    let base = owned(&[
        // INITIALISING (16) -> MANUAL.
        (
            1.540,
            "mode_changed {custom_mode: 0, mode: \"MANUAL\"}",
            EXACT,
        ),
        (
            20.544,
            "mode_changed {custom_mode: 10, mode: \"AUTO\"}",
            EXACT,
        ),
        // The first arm is refused: COMMAND_ACK 400 result 4 (FAILED), and
        // ArduPlane says why a second later.
        (
            20.561,
            "command_rejected {command: \"COMPONENT_ARM_DISARM\", result: \"FAILED\"}",
            EXACT,
        ),
        (
            21.562,
            "prearm_failed {text: \"Gyros inconsistent\"}",
            EXACT,
        ),
        (
            22.605,
            "ready_for_takeoff {battery: 99, satellites: 10}",
            EXACT,
        ),
        (24.861, "armed {mode: \"AUTO\"}", EXACT),
        (25.865, "takeoff", EXACT),
        // system_status ACTIVE -> STANDBY after touchdown, still armed.
        (
            159.852,
            "ready_for_takeoff {battery: 86, satellites: 10}",
            EXACT,
        ),
        (159.852, "landed", EXACT),
        (179.872, "disarmed {mode: \"AUTO\"}", EXACT),
    ]);
    let expected = merge(
        base,
        items(&[
            (33.523, 1),
            (40.926, 2),
            (57.326, 3),
            (99.730, 4),
            (116.529, 5),
            (131.332, 6),
        ]),
    );
    check_owned(
        "SITL_arduplane-4.7.0dev_auto_mission_land.tlog",
        "ardupilot",
        &expected,
    );
}

#[test]
fn flood_attack_link_losses() {
    // Autopilot heartbeats at 2.045, then nothing until 50.041; during the
    // flight gaps of 4.037 s (62.044 -> 66.081) and 9.014 s (66.081 ->
    // 75.094) fire, the 2.955 s one (80.093 -> 83.048) must not.
    let base = owned(&[
        (5.545, "link_lost", TIMEOUT),
        (
            49.085,
            "ready_for_takeoff {battery: 99, satellites: 10}",
            EXACT,
        ),
        (50.041, "armed {mode: \"GUIDED\"}", EXACT),
        (
            50.041,
            "mode_changed {custom_mode: 4, mode: \"GUIDED\"}",
            EXACT,
        ),
        (50.041, "link_restored", EXACT),
        (
            52.043,
            "mode_changed {custom_mode: 3, mode: \"AUTO\"}",
            EXACT,
        ),
        (65.544, "link_lost", TIMEOUT),
        (66.081, "link_restored", EXACT),
        // The moving average of sequence-number losses of 1/1 (weight 1/32,
        // recomputed from pymavlink's sequence numbers) exceeds 20 % from
        // 63.167 on: held 3 s.
        (66.167, "link_degraded", TIMEOUT),
        (69.581, "link_lost", TIMEOUT),
        (75.094, "link_restored", EXACT),
    ]);
    let expected = merge(
        base,
        items(&[
            (54.299, 1),
            (56.104, 2),
            (57.884, 3),
            (59.632, 4),
            (61.359, 5),
            (68.479, 9),
            (71.988, 11),
            (77.314, 14),
            (79.030, 15),
            (80.729, 16),
            (84.183, 18),
            (85.953, 19),
            (87.739, 20),
            (89.534, 21),
            (91.308, 22),
        ]),
    );
    check_owned(
        "SITL_dvd_2026-04-05_copter_udpflood_linkloss.tlog",
        "ardupilot",
        &expected,
    );
}

#[test]
fn ardusub_bad_crc_frames_are_counted_and_survived() {
    let name = "ardusub_2023-04-18_sub_qgc_baddata.tlog";
    check(
        name,
        "ardupilot",
        &[
            // HEARTBEAT system_status CRITICAL in the first heartbeat.
            (
                0.024,
                "autopilot_failsafe {text: \"system_status CRITICAL\"}",
                EXACT,
            ),
            (
                0.776,
                "command_rejected {command: \"REQUEST_MESSAGE\", result: \"FAILED\"}",
                EXACT,
            ),
        ],
    );
    let Some(bytes) = read(name) else { return };
    let (_, read, _) = elaborate(
        &bytes,
        Profile::builtin("ardupilot").expect("profile"),
        Config::default(),
    );
    // pymavlink: 50136 good messages and 1967 bad ones, most of them
    // DISTANCE_SENSOR (132) from the companion 1/194.
    assert_eq!(read.frames, 50136);
    assert_eq!(read.bad_crc_total(), 1967);
    assert_eq!(read.bad_crc.get(&132), Some(&1949));
    assert_eq!(read.skipped_bytes, 0);
}

#[test]
fn ardusub_gps_chatter_is_debounced() {
    // GPS_RAW_INT 3D <-> NO_GPS: losses of 2.988 s (79.243), 5.007 s
    // (83.231) and 3.003 s (92.231) fire after 2.5 s; the 1-2 s flaps
    // (107.2, 114.2, 117.2, 141.2, 149.2) do not.
    check(
        "ardusub_2023-05-04_small_sub_qgc.tlog",
        "ardupilot",
        &[
            (
                1.043,
                "ready_for_takeoff {battery: -1, satellites: 21}",
                EXACT,
            ),
            (
                1.043,
                "autopilot_failsafe {text: \"system_status CRITICAL\"}",
                EXACT,
            ),
            (81.743, "gps_lost {fix_type: 0, satellites: 21}", TIMEOUT),
            (82.231, "gps_restored", EXACT),
            (85.731, "gps_lost {fix_type: 0, satellites: 21}", TIMEOUT),
            (88.238, "gps_restored", EXACT),
            (94.731, "gps_lost {fix_type: 0, satellites: 21}", TIMEOUT),
            (95.234, "gps_restored", EXACT),
            (206.737, "armed {mode: \"MANUAL\"}", EXACT),
            (222.718, "disarmed {mode: \"MANUAL\"}", EXACT),
            (
                222.718,
                "ready_for_takeoff {battery: -1, satellites: 21}",
                EXACT,
            ),
        ],
    );
}

#[test]
fn apm_copter_mission_flight() {
    let base = owned(&[
        (
            22.922,
            "ready_for_takeoff {battery: -1, satellites: 8}",
            EXACT,
        ),
        (137.859, "armed {mode: \"STABILIZE\"}", EXACT),
        (
            148.844,
            "mode_changed {custom_mode: 5, mode: \"LOITER\"}",
            EXACT,
        ),
        (
            195.984,
            "mode_changed {custom_mode: 3, mode: \"AUTO\"}",
            EXACT,
        ),
        (
            313.266,
            "mode_changed {custom_mode: 5, mode: \"LOITER\"}",
            EXACT,
        ),
        (
            340.312,
            "mode_changed {custom_mode: 0, mode: \"STABILIZE\"}",
            EXACT,
        ),
        (
            385.328,
            "mode_changed {custom_mode: 5, mode: \"LOITER\"}",
            EXACT,
        ),
        (
            407.406,
            "mode_changed {custom_mode: 0, mode: \"STABILIZE\"}",
            EXACT,
        ),
        (472.344, "disarmed {mode: \"STABILIZE\"}", EXACT),
        (
            472.344,
            "ready_for_takeoff {battery: -1, satellites: 10}",
            EXACT,
        ),
        // APM 2.x stays ACTIVE on the ground: the copter has landed when it
        // disarms (the pilot cut the throttle at 470.0 s, 2.3 m of baro
        // drift left on the relative altitude).
        (472.344, "landed", EXACT),
        // The autopilot's last HEARTBEAT is at 510.484 (the ground station
        // goes on alone until 570.8).
        (513.984, "link_lost", TIMEOUT),
        // The ground-side SiK radio (51/68, RADIO) then reports the remote
        // end silent (remrssi 0) from 514.734: a fade margin under 10 for 5 s.
        // In flight the margin dips under 10 for at most 2 s: nothing fires.
        (519.734, "link_degraded {remrssi: 0, rssi: 76}", TIMEOUT),
    ]);
    // APM 2.x has no MISSION_ITEM_REACHED: "Reached Command #n" texts.
    let expected = merge(
        base,
        items(&[
            (231.203, 1),
            (249.422, 2),
            (260.344, 3),
            (273.328, 4),
            (293.203, 5),
            (298.531, 6),
            (302.953, 7),
            (304.906, 8),
            (307.000, 9),
            (308.797, 10),
            (310.531, 11),
            (312.281, 12),
        ]),
    );
    check_owned(
        "codelever_2013-10-13_16-58-51_copter_apm.tlog",
        "ardupilot",
        &expected,
    );
}

#[test]
fn apm_log_starting_in_flight_and_radio_gaps() {
    // Starts armed (no `armed` event); autopilot heartbeat gaps of 2.2 s
    // (167.4) and 2.0 s (384.8) must not fire link_lost; its last
    // HEARTBEAT is at 414.906.
    check(
        "codelever_2013-10-13_18-31-24_copter_apm.tlog",
        "ardupilot",
        &[
            (
                79.188,
                "mode_changed {custom_mode: 5, mode: \"LOITER\"}",
                EXACT,
            ),
            (
                243.609,
                "mode_changed {custom_mode: 0, mode: \"STABILIZE\"}",
                EXACT,
            ),
            (362.344, "disarmed {mode: \"STABILIZE\"}", EXACT),
            (
                362.344,
                "ready_for_takeoff {battery: -1, satellites: 13}",
                EXACT,
            ),
            // Disarmed while still ACTIVE (APM 2.x): landed.
            (362.344, "landed", EXACT),
            (418.406, "link_lost", TIMEOUT),
            // SiK RADIO: remote end silent from 419.625; the in-flight dips
            // under a margin of 10 (81.6, 88.8, 110.7, 131.7, 170.7 s) last
            // 0.9-2.0 s and do not fire.
            (424.625, "link_degraded {remrssi: 0, rssi: 203}", TIMEOUT),
        ],
    );
}

#[test]
fn apm_second_mission_flight() {
    let name = "codelever_2013-10-13_18-50-10_copter_apm.tlog";
    let Some(bytes) = read(name) else { return };
    let (events, read, _) = elaborate(
        &bytes,
        Profile::builtin("ardupilot").expect("profile"),
        Config::default(),
    );
    let named = |n: &str| -> Vec<(f64, String)> {
        events
            .iter()
            .filter(|(_, e)| e.event.name == n)
            .map(|(t, e)| (*t, summary(e)))
            .collect()
    };
    let times = |n: &str| -> Vec<f64> { named(n).iter().map(|(t, _)| *t).collect() };
    let near = |got: Vec<f64>, want: f64| got.len() == 1 && (got[0] - want).abs() < EXACT;
    // Timestamps of this log are quantised to 1/64 s.
    assert!(near(times("armed"), 260.3125), "{:?}", times("armed"));
    assert!(
        near(times("disarmed"), 567.671875),
        "{:?}",
        times("disarmed")
    );
    // APM 2.x stays ACTIVE on the ground: landed when it disarms.
    assert!(near(times("landed"), 567.671875), "{:?}", times("landed"));
    assert!(times("takeoff").is_empty(), "{:?}", times("takeoff"));
    let modes: Vec<String> = named("mode_changed")
        .into_iter()
        .map(|(t, s)| format!("{t:.3} {s}"))
        .collect();
    assert_eq!(
        modes,
        [
            "267.344 mode_changed {custom_mode: 5, mode: \"LOITER\"}",
            "286.250 mode_changed {custom_mode: 0, mode: \"STABILIZE\"}",
            "288.344 mode_changed {custom_mode: 3, mode: \"AUTO\"}",
            "437.516 mode_changed {custom_mode: 5, mode: \"LOITER\"}",
            "475.172 mode_changed {custom_mode: 0, mode: \"STABILIZE\"}",
        ]
    );
    // 26 "Reached Command #n", in order.
    let seqs: Vec<String> = named("mission_item_reached")
        .into_iter()
        .map(|(_, s)| s)
        .collect();
    let want: Vec<String> = (1..=26)
        .map(|n| format!("mission_item_reached {{seq: {n}}}"))
        .collect();
    assert_eq!(seqs, want);
    // Last autopilot HEARTBEAT at 587.625.
    let lost = times("link_lost");
    assert_eq!(lost.len(), 1);
    assert!(lost[0] >= 591.125 && lost[0] <= 591.225, "{lost:?}");
    // The ground-side SiK radio reports the remote end silent from 592.094.
    let degraded = times("link_degraded");
    assert_eq!(degraded.len(), 1);
    assert!(
        degraded[0] >= 597.094 && degraded[0] <= 597.194,
        "{degraded:?}"
    );
    // The log ends inside a frame: the tail is counted, not fatal.
    assert_eq!(read.truncated_tail, 9);
    // armed, disarmed, 5 modes, 26 items, landed, ready_for_takeoff (11.5 s
    // and at the disarm), link_lost, link_degraded.
    assert_eq!(events.len(), 1 + 1 + 5 + 26 + 1 + 2 + 1 + 1, "{events:#?}");
}

#[test]
fn px4_bench_modes_are_named_and_nothing_is_invented() {
    let name = "mavometer_2019_px4_bench_qgc.tlog";
    check(name, "px4", &[]);
    // The mode the PX4 HEARTBEATs carry (custom_mode 65536: main mode 1).
    let Some(bytes) = read(name) else { return };
    let text = "[rules.px4_mode]\ncategory = \"nominal\"\nwhen = \"HEARTBEAT.custom_mode >= 0\"\neach = true\nparams = { mode = \"mode()\" }\n";
    let profile = Profile::load(&[
        ("px4.toml", elaboration::profile::PX4),
        ("probe.toml", text),
    ])
    .expect("profile");
    let (events, read, stats) = elaborate(&bytes, profile, Config::default());
    let modes: Vec<String> = events
        .iter()
        .filter(|(_, e)| e.event.name == "px4_mode")
        .map(|(_, e)| summary(e))
        .collect();
    assert_eq!(modes.len(), 77, "77 autopilot heartbeats");
    assert!(
        modes.iter().all(|m| m == "px4_mode {mode: \"MANUAL\"}"),
        "{modes:?}"
    );
    // 81 MAVLink 1 and 2035 MAVLink 2 frames, all read.
    assert_eq!(read.frames, 2116);
    assert_eq!(stats.frames, 2116);
}

#[test]
fn removing_or_recategorizing_a_rule_changes_the_events() {
    let Some(bytes) = read("SITL_dvd_2026-04-05_copter_udpflood_linkloss.tlog") else {
        return;
    };
    let base = elaboration::profile::ARDUPILOT;
    let user = "[rules.link_lost]\nenabled = false\n\n[rules.armed]\ncategory = \"mission\"\n";
    let profile =
        Profile::load(&[("ardupilot.toml", base), ("project.toml", user)]).expect("profile");
    let (events, _, _) = elaborate(&bytes, profile, Config::default());
    assert!(events
        .iter()
        .all(|(_, e)| e.event.name != "link_lost" && e.event.name != "link_restored"));
    let armed: Vec<_> = events
        .iter()
        .filter(|(_, e)| e.event.name == "armed")
        .collect();
    assert_eq!(armed.len(), 1);
    assert_eq!(armed[0].1.event.category, nets::Category::Mission);
    // The rest is untouched.
    assert!(events.iter().any(|(_, e)| e.event.name == "mode_changed"));

    // Removing the rule from the profile text itself does the same.
    let start = base.find("[rules.link_lost]").expect("rule present");
    let end = start + base[start..].find("\n[rules.gcs_lost]").expect("next rule");
    let cut = format!("{}{}", &base[..start], &base[end..]);
    let profile = Profile::load(&[("ardupilot.toml", &cut)]).expect("profile");
    let (events, _, _) = elaborate(&bytes, profile, Config::default());
    assert!(events.iter().all(|(_, e)| e.event.name != "link_lost"));
}

/// Every recording in ../shared/telemetry has its timeline test above: a
/// new recording fails here until it gets one.
#[test]
fn every_shared_recording_has_a_timeline() {
    const COVERED: [&str; 9] = [
        "SITL_arducopter-4.7.0dev_guided_takeoff_land.tlog",
        "SITL_arduplane-4.7.0dev_auto_mission_land.tlog",
        "SITL_dvd_2026-04-05_copter_udpflood_linkloss.tlog",
        "ardusub_2023-04-18_sub_qgc_baddata.tlog",
        "ardusub_2023-05-04_small_sub_qgc.tlog",
        "codelever_2013-10-13_16-58-51_copter_apm.tlog",
        "codelever_2013-10-13_18-31-24_copter_apm.tlog",
        "codelever_2013-10-13_18-50-10_copter_apm.tlog",
        "mavometer_2019_px4_bench_qgc.tlog",
    ];
    let Some(dir) = shared() else { return };
    let mut found: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tlog"))
        .collect();
    found.sort();
    assert_eq!(found, COVERED);
    // And each is one the tests of this file read.
    let source = include_str!("real_flights.rs");
    for name in COVERED {
        assert!(
            source.matches(&format!("\"{name}\"")).count() >= 2,
            "{name} is not read by a test"
        );
    }
}

/// No loss of control on any recording of ../shared/telemetry — every
/// `.tlog` there, new ones included: the APM 2.x flights (STABILIZE flown
/// hard, 45-50° of pitch for seconds and 70° off level on two samples in a
/// row, the target reported as 0), the SITL
/// copter, plane and flood flights, the subs and the PX4 bench. And the
/// rule does read them: with any attitude error at all taken as a loss of
/// control, it fires on each copter flight that flies (so "never" above
/// is not for want of data), and on nothing else.
#[test]
fn no_loss_of_control_on_any_shared_recording() {
    let Some(dir) = shared() else { return };
    let mut logs: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "tlog"))
        .collect();
    logs.sort();
    assert!(logs.len() >= 9, "{logs:?}");
    let base = elaboration::profile::ARDUPILOT;
    let threshold = "< 0.17364818\n\"\"\"\nfor = \"0.2s\"";
    assert_eq!(
        base.matches(threshold).count(),
        1,
        "loss_of_control's threshold"
    );
    let any_error = base.replace(threshold, "< 1.0\n\"\"\"\nfor = \"0.2s\"");
    let mut judged = Vec::new();
    for path in &logs {
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let (events, _, _) = elaborate(
            &bytes,
            Profile::builtin("ardupilot").expect("built-in profile"),
            Config::default(),
        );
        let lost: Vec<String> = events
            .iter()
            .filter(|(_, e)| e.event.name == "loss_of_control")
            .map(|(t, e)| format!("{t:.3} {:?}", e.event.params))
            .collect();
        assert!(lost.is_empty(), "{name}: loss_of_control at {lost:?}");
        let profile = Profile::load(&[("ardupilot.toml", &any_error)]).expect("profile");
        let (events, _, _) = elaborate(&bytes, profile, Config::default());
        if events
            .iter()
            .any(|(_, e)| e.event.name == "loss_of_control")
        {
            judged.push(name.into_owned());
        }
    }
    assert_eq!(
        judged,
        [
            "SITL_arducopter-4.7.0dev_guided_takeoff_land.tlog",
            "SITL_dvd_2026-04-05_copter_udpflood_linkloss.tlog",
            "codelever_2013-10-13_16-58-51_copter_apm.tlog",
            "codelever_2013-10-13_18-31-24_copter_apm.tlog",
            "codelever_2013-10-13_18-50-10_copter_apm.tlog",
        ]
    );
}
