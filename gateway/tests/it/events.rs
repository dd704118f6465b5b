//! `petrel events` end to end: the binary on a synthetic log (JSON lines,
//! the timeline for people, the summary on stderr, profiles, exit codes)
//! and on the shared recordings.

use crate::scratch;

use std::path::{Path, PathBuf};
use std::process::Command;

use elaboration::frame::{extra_crc, serialize};
use elaboration::TlogWriter;
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};
use scratch::Scratch;
use serde_json::Value;

fn petrel(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .args(args)
        .output()
        .expect("petrel runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Microseconds since the UNIX epoch of the first frame.
const T0: u64 = 1_700_000_000_000_000;
const S: u64 = 1_000_000;

fn heartbeat(
    armed: bool,
    custom_mode: u32,
    mavtype: MavType,
    autopilot: MavAutopilot,
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
        system_status: MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    })
}

fn copter(armed: bool, custom_mode: u32) -> MavMessage {
    heartbeat(
        armed,
        custom_mode,
        MavType::MAV_TYPE_QUADROTOR,
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
    )
}

fn frame(sysid: u8, compid: u8, seq: u8, v: MavlinkVersion, msg: &MavMessage) -> Vec<u8> {
    let h = MavHeader {
        system_id: sysid as u32,
        component_id: compid,
        sequence: seq,
    };
    serialize(h, v, msg)
}

/// A ground station, then an ArduCopter 1/1 (MAVLink 1 and 2) that arms,
/// changes mode and disarms; between them a record with a bad checksum, a
/// HEARTBEAT with a MAV_TYPE rust-mavlink does not know (valid checksum),
/// and another vehicle's armed heartbeats.
fn synthetic_log() -> Vec<u8> {
    let gcs = heartbeat(
        false,
        0,
        MavType::MAV_TYPE_GCS,
        MavAutopilot::MAV_AUTOPILOT_INVALID,
    );
    let mut bad_crc = frame(1, 1, 9, MavlinkVersion::V2, &copter(true, 6));
    let n = bad_crc.len();
    bad_crc[n - 1] ^= 0x5a;
    let mut unknown_type = frame(1, 1, 3, MavlinkVersion::V2, &copter(true, 0));
    unknown_type[10 + 4] = 250;
    let end = unknown_type.len() - 2;
    let crc = mavlink::calculate_crc(&unknown_type[1..end], extra_crc(0).expect("HEARTBEAT"));
    unknown_type[end..].copy_from_slice(&crc.to_le_bytes());
    let records: Vec<(u64, Vec<u8>)> = vec![
        (0, frame(255, 190, 0, MavlinkVersion::V2, &gcs)),
        (S / 2, frame(1, 1, 0, MavlinkVersion::V1, &copter(false, 0))),
        (S, frame(1, 1, 1, MavlinkVersion::V1, &copter(true, 0))),
        (
            S + S / 4,
            frame(2, 1, 0, MavlinkVersion::V2, &copter(true, 3)),
        ),
        (S + S / 2, unknown_type),
        (S + 3 * S / 4, bad_crc),
        (2 * S, frame(1, 1, 4, MavlinkVersion::V2, &copter(true, 5))),
        (
            2 * S + S / 4,
            frame(2, 1, 1, MavlinkVersion::V2, &copter(false, 3)),
        ),
        (3 * S, frame(1, 1, 5, MavlinkVersion::V2, &copter(false, 5))),
    ];
    let mut w = TlogWriter::new(Vec::new());
    for (t, bytes) in &records {
        w.write_frame(T0 + t, bytes).expect("vec");
    }
    w.into_inner().expect("vec")
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let path = dir.join(name);
    std::fs::write(&path, bytes).expect("written");
    path.display().to_string()
}

fn json_lines(out: &str) -> Vec<Value> {
    out.lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON: {l}: {e}")))
        .collect()
}

#[test]
fn json_lines_have_exactly_the_documented_keys_and_the_summary_goes_to_stderr() {
    let dir = Scratch::new("events");
    let log = write(dir.path(), "flight.tlog", &synthetic_log());
    let (code, out, err) = petrel(&["events", &log, "--json"]);
    assert_eq!(code, 0, "{err}");
    let events = json_lines(&out);
    let expected = [
        (S, "armed", "nominal", r#"{"mode":"STABILIZE"}"#),
        (
            2 * S,
            "mode_changed",
            "nominal",
            r#"{"custom_mode":5,"mode":"LOITER"}"#,
        ),
        (3 * S, "disarmed", "nominal", r#"{"mode":"LOITER"}"#),
    ];
    assert_eq!(events.len(), expected.len(), "{out}");
    for (e, (t, name, category, params)) in events.iter().zip(expected) {
        let keys: Vec<&str> = e
            .as_object()
            .expect("an object")
            .keys()
            .map(String::as_str)
            .collect();
        let mut sorted = keys.clone();
        sorted.sort_unstable();
        assert_eq!(
            sorted,
            ["category", "compid", "event", "params", "sysid", "t", "time_us"],
            "{e}"
        );
        assert_eq!(e["time_us"], T0 + t, "the frame's tlog timestamp: {e}");
        assert_eq!(e["t"].as_f64(), Some(t as f64 / 1e6), "{e}");
        assert_eq!(e["event"], name);
        assert_eq!(e["category"], category);
        assert_eq!(
            e["params"],
            serde_json::from_str::<Value>(params).expect("json")
        );
        assert_eq!(
            (e["sysid"].as_u64(), e["compid"].as_u64()),
            (Some(1), Some(1))
        );
    }
    // The summary: frames, what was skipped, decode failures by id, events
    // by name.
    assert!(err.contains("flight.tlog: 8 frames"), "{err}");
    assert!(err.contains("1 bad-CRC records {0: 1}"), "{err}");
    assert!(
        err.contains("decode failures by message id: {0: 1}"),
        "{err}"
    );
    assert!(err.contains("vehicle autopilot: 1/1"), "{err}");
    assert!(
        err.contains(r#"events: {"armed": 1, "disarmed": 1, "mode_changed": 1}"#),
        "{err}"
    );
}

#[test]
fn without_json_a_timeline_for_people() {
    let dir = Scratch::new("events");
    let log = write(dir.path(), "flight.tlog", &synthetic_log());
    let (code, out, err) = petrel(&["events", &log]);
    assert_eq!(code, 0, "{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 3, "{out}");
    let words = |l: &str| l.split_whitespace().map(str::to_owned).collect::<Vec<_>>();
    assert_eq!(
        words(lines[0]),
        [
            "1.000s",
            "nominal",
            "armed",
            "{mode:",
            "\"STABILIZE\"}",
            "[1/1]"
        ]
    );
    assert_eq!(
        words(lines[1]),
        [
            "2.000s",
            "nominal",
            "mode_changed",
            "{custom_mode:",
            "5,",
            "mode:",
            "\"LOITER\"}",
            "[1/1]"
        ]
    );
    assert!(
        lines.iter().all(|l| !l.trim_start().starts_with('{')),
        "{out}"
    );
    assert!(err.contains("8 frames"), "{err}");
}

#[test]
fn a_project_file_layers_over_the_builtin_profile() {
    let dir = Scratch::new("events");
    let log = write(dir.path(), "flight.tlog", &synthetic_log());
    let profile = write(
        dir.path(),
        "project.toml",
        b"[rules.armed]\ncategory = \"safety\"\n\n[rules.mode_changed]\nenabled = false\n\n[rules.other_vehicle_armed]\nevent = \"intruder_armed\"\ncategory = \"safety\"\nsource = { sysid = 2 }\nwhen = \"HEARTBEAT.base_mode & MAV_MODE_FLAG_SAFETY_ARMED\"\n",
    );
    let (code, out, err) = petrel(&["events", &log, "--profile", &profile, "--json"]);
    assert_eq!(code, 0, "{err}");
    let got: Vec<(String, String, u64)> = json_lines(&out)
        .iter()
        .map(|e| {
            (
                e["event"].as_str().unwrap_or_default().to_owned(),
                e["category"].as_str().unwrap_or_default().to_owned(),
                e["sysid"].as_u64().unwrap_or_default(),
            )
        })
        .collect();
    let want = [
        ("armed", "safety", 1),
        ("intruder_armed", "safety", 2),
        ("disarmed", "nominal", 1),
    ]
    .map(|(a, b, c)| (a.to_owned(), b.to_owned(), c));
    assert_eq!(got, want);
    // `--profile px4` names the same events with the PX4 profile.
    let (code, out, err) = petrel(&["events", &log, "--profile", "px4", "--json"]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(json_lines(&out).len(), 3, "{out}");
}

#[test]
fn bad_input_exits_2_with_every_profile_problem_located() {
    let dir = Scratch::new("events");
    let log = write(dir.path(), "flight.tlog", &synthetic_log());
    let profile = write(
        dir.path(),
        "bad.toml",
        b"[rules.x]\ncategory = \"sometimes\"\nwhen = \"HEARTBEAT.colour == 1\"\nfor = \"2 parsecs\"\n",
    );
    let (code, out, err) = petrel(&["events", &log, "--profile", &profile, "--json"]);
    assert_eq!(code, 2, "{err}");
    assert!(out.is_empty(), "{out}");
    for at in ["bad.toml:2:12", "bad.toml:3:9", "bad.toml:4:7"] {
        assert!(err.contains(at), "{at} missing from\n{err}");
    }
    let missing = dir.path().join("missing.tlog").display().to_string();
    let (code, _, err) = petrel(&["events", &missing]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("missing.tlog"), "{err}");
    let (code, _, err) = petrel(&["events", &log, "--firmware", "zeppelin"]);
    assert_eq!(code, 2, "{err}");
    let (code, _, err) = petrel(&["events", &log, "--profile", "/nonexistent/p.toml"]);
    assert_eq!(code, 2, "{err}");
}

#[test]
fn garbage_is_counted_not_fatal() {
    let dir = Scratch::new("events");
    let mut bytes: Vec<u8> = (0..5000u32).map(|i| (i * 7919 % 251) as u8).collect();
    bytes.extend(synthetic_log());
    bytes.extend_from_slice(&[0xFD, 9, 0]); // ends inside a frame
    let log = write(dir.path(), "garbage.tlog", &bytes);
    let (code, out, err) = petrel(&["events", &log, "--json"]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(json_lines(&out).len(), 3, "{out}");
    assert!(err.contains("8 frames"), "{err}");
    assert!(!err.contains(" 0 bytes of garbage"), "{err}");
}

fn shared_log(name: &str) -> Option<PathBuf> {
    let path = sitl_tests::skip::shared_dir().join("telemetry").join(name);
    if path.is_file() {
        return Some(path);
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "{} is missing (CI=true)",
        path.display()
    );
    sitl_tests::skip::skip(&format!("{} is not there", path.display()));
    None
}

/// On a real recording: `time_us` is the very tlog timestamp of the
/// HEARTBEAT that changed (read here with the library's reader).
#[test]
fn on_the_sitl_copter_flight_times_are_the_frames_timestamps() {
    let Some(path) = shared_log("SITL_arducopter-4.7.0dev_guided_takeoff_land.tlog") else {
        return;
    };
    let bytes = std::fs::read(&path).expect("readable");
    let mut changes = Vec::new();
    let mut last: Option<bool> = None;
    for rec in elaboration::TlogReader::new(&bytes) {
        let f = rec.frame;
        if (f.system_id(), f.component_id(), f.message_id()) != (1, 1, 0) {
            continue;
        }
        if let Ok(MavMessage::HEARTBEAT(hb)) = f.decode() {
            let armed = hb
                .base_mode
                .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED);
            if last.is_some_and(|l| l != armed) {
                changes.push((rec.time_us, if armed { "armed" } else { "disarmed" }));
            }
            last = Some(armed);
        }
    }
    assert_eq!(changes.len(), 2);
    let (code, out, err) = petrel(&["events", &path.display().to_string(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let got: Vec<(u64, String)> = json_lines(&out)
        .iter()
        .filter(|e| e["event"] == "armed" || e["event"] == "disarmed")
        .map(|e| {
            (
                e["time_us"].as_u64().unwrap_or_default(),
                e["event"].as_str().unwrap_or_default().to_owned(),
            )
        })
        .collect();
    let want: Vec<(u64, String)> = changes.iter().map(|(t, n)| (*t, n.to_string())).collect();
    assert_eq!(got, want);
    assert!(err.contains("vehicle autopilot: 1/1"), "{err}");
}

/// The ArduSub log's 1967 bad-CRC records are counted in the summary and
/// survived.
#[test]
fn on_the_ardusub_log_bad_checksums_are_counted() {
    let Some(path) = shared_log("ardusub_2023-04-18_sub_qgc_baddata.tlog") else {
        return;
    };
    let (code, out, err) = petrel(&["events", &path.display().to_string(), "--json"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains(": 50136 frames"), "{err}");
    assert!(err.contains("1967 bad-CRC records"), "{err}");
    assert!(err.contains("132: 1949"), "{err}");
    let names: Vec<String> = json_lines(&out)
        .iter()
        .map(|e| e["event"].as_str().unwrap_or_default().to_owned())
        .collect();
    assert_eq!(names, ["autopilot_failsafe", "command_rejected"]);
}
