//! Elaboration proven on the failures the real firmware produces: ArduPilot's
//! own SITL (real ArduCopter and ArduPlane 4.7) flown from this test, failures
//! injected through its simulation parameters as its autotest suite does
//! (SIM_ENGINE_MUL/SIM_ENGINE_FAIL, SIM_GPS1_ENABLE, SIM_BATT_VOLTAGE with
//! BATT_LOW_VOLT and BATT_FS_LOW_ACT, SIM_RC_FAIL, FENCE_*), a 10 s hole on
//! the link, the flight recorded as a tlog, and `petrel events` (the built
//! binary) checked against what was injected and what the autopilot said:
//! every expected event inside its window, no failure event outside the
//! windows that allow it over the whole flight.
//!
//! One copter boot carries the failures one after another, one plane boot
//! flies an AUTO mission with MISSION_ITEM_REACHED requested as a stream
//! and ends with its engine out (instances 3 and 4, each moved by its turn:
//! `crate::sitl_turn`).
//! The tlogs are in the test's scratch folder (printed), left there when
//! the test fails or `PETREL_KEEP` is set.

pub(crate) mod flight;
use crate::scratch;

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use flight::Link;
use mavlink::dialects::ardupilotmega::MavCmd;
use scratch::Scratch;
use serde_json::Value;
use sitl_tests::ardupilot::{self, Firmware, Options, Sitl};

use mavlink::dialects::ardupilotmega::{
    MavFrame, MavMissionType, MavResult, MISSION_ITEM_INT_DATA,
};

/// Simulated seconds per wall second.
const SPEEDUP: u32 = 8;

/// Failure events: every event of these categories must fall in a window.
const FAILURE_CATEGORIES: [&str; 3] = ["safety", "catastrophic", "communication"];

/// A failure injected, in vehicle time, with the events that must come in
/// it and the failure events it allows.
#[derive(Debug)]
struct Window {
    what: &'static str,
    from_us: u64,
    to_us: u64,
    expect: &'static [&'static str],
    allow: &'static [&'static str],
}

/// One event of `petrel events --json`.
#[derive(Debug)]
struct Event {
    /// Vehicle time, µs since boot.
    at_us: u64,
    name: String,
    category: String,
    params: Value,
}

fn petrel_events(tlog: &Path) -> Vec<Event> {
    let out = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .args(["events", &tlog.display().to_string(), "--json"])
        .output()
        .expect("petrel runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "petrel events: {stderr}");
    eprintln!("{stderr}");
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| {
            let v: Value = serde_json::from_str(l).expect("JSON line");
            Event {
                at_us: v["time_us"].as_u64().unwrap_or_default() - Link::tlog_us(0),
                name: v["event"].as_str().unwrap_or_default().to_owned(),
                category: v["category"].as_str().unwrap_or_default().to_owned(),
                params: v["params"].clone(),
            }
        })
        .collect()
}

fn timeline(events: &[Event]) -> String {
    events
        .iter()
        .map(|e| {
            format!(
                "{:9.3}  {:13} {} {}",
                e.at_us as f64 / 1e6,
                e.category,
                e.name,
                e.params
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Every expected event inside its window; every failure event inside a
/// window that expects or allows it.
fn check(events: &[Event], windows: &[Window]) {
    let pretty = timeline(events);
    let windows_text = windows
        .iter()
        .map(|w| {
            format!(
                "{:>22}: {:.1} .. {:.1} s",
                w.what,
                w.from_us as f64 / 1e6,
                w.to_us as f64 / 1e6
            )
        })
        .collect::<Vec<_>>()
        .join("\n");
    eprintln!("windows:\n{windows_text}");
    for w in windows {
        for name in w.expect {
            assert!(
                events
                    .iter()
                    .any(|e| e.name == *name && (w.from_us..=w.to_us).contains(&e.at_us)),
                "{}: no {name} between {:.1} and {:.1} s\nwindows:\n{windows_text}\nevents:\n{pretty}",
                w.what,
                w.from_us as f64 / 1e6,
                w.to_us as f64 / 1e6
            );
        }
    }
    for e in events {
        if !FAILURE_CATEGORIES.contains(&e.category.as_str()) {
            continue;
        }
        let explained = windows.iter().any(|w| {
            (w.from_us..=w.to_us).contains(&e.at_us)
                && (w.expect.contains(&e.name.as_str()) || w.allow.contains(&e.name.as_str()))
        });
        assert!(
            explained,
            "false alarm: {} at {:.3} s is in no window that allows it\nwindows:\n{windows_text}\nevents:\n{pretty}",
            e.name,
            e.at_us as f64 / 1e6
        );
    }
}

/// The reasons of prearm_failed are the vehicle's own texts.
fn prearm_reasons_are_the_vehicles(events: &[Event], link_texts: &[(u64, String)]) {
    for e in events.iter().filter(|e| e.name == "prearm_failed") {
        let text = e.params["text"].as_str().unwrap_or_default();
        assert!(
            link_texts
                .iter()
                .any(|(_, t)| t.ends_with(text)
                    && (t.starts_with("PreArm: ") || t.starts_with("Arm: "))),
            "prearm_failed {text:?} is no text of the vehicle"
        );
    }
}

fn fly_or_panic<T>(sitl: &Sitl, what: &str, r: Result<T, String>) -> T {
    r.unwrap_or_else(|e| {
        let out = sitl.output();
        let tail: String = out
            .chars()
            .rev()
            .take(2000)
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        panic!("{what}: {e}\nSITL said:\n{tail}")
    })
}

/// What the autopilot said and did in each window, for people.
fn said_in(windows: &[Window], texts: &[(u64, String)], modes: &[(u64, u32)]) {
    for w in windows {
        let inside = |t: &u64| (w.from_us..=w.to_us).contains(t);
        let said: Vec<&str> = texts
            .iter()
            .filter(|(t, _)| inside(t))
            .map(|(_, s)| s.as_str())
            .collect();
        let entered: Vec<u32> = modes
            .iter()
            .filter(|(t, _)| inside(t))
            .map(|(_, m)| *m)
            .collect();
        eprintln!("{}: the autopilot said {said:?}, modes {entered:?}", w.what);
    }
}

// ------------------------------------------------------------ copter

const GUIDED: u32 = 4;
const RTL: u32 = 6;

/// A copter flight with the failures one after another in distinct windows.
fn fly_copter(link: &mut Link) -> Result<Vec<Window>, String> {
    link.arm(GUIDED, 120.0, |l| {
        l.command(
            MavCmd::MAV_CMD_NAV_TAKEOFF,
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 25.0],
        )
        .map(|_| ())
    })?;
    link.wait("at 20 m", 30.0, |s| s.altitude > 20.0)?;
    link.hold(3.0)?;
    let mut windows = Vec::new();

    // One motor weakened: motor 1 at 65 % thrust (arducopter.py's
    // loiter test), the copter holding position.
    let from = link.now_us();
    link.param("SIM_ENGINE_MUL", 0.65)?;
    link.param("SIM_ENGINE_FAIL", 1.0)?;
    link.hold(12.0)?;
    link.param("SIM_ENGINE_MUL", 1.0)?;
    link.param("SIM_ENGINE_FAIL", 0.0)?;
    link.hold(5.0)?;
    windows.push(Window {
        what: "motor 1 at 65 %",
        from_us: from,
        to_us: link.now_us(),
        expect: &["motor_imbalance"],
        allow: &[],
    });

    // RC lost for 8 s (FS_OPTIONS: continue in GUIDED).
    let from = link.now_us();
    link.param("SIM_RC_FAIL", 1.0)?;
    link.hold(8.0)?;
    link.param("SIM_RC_FAIL", 0.0)?;
    link.hold(5.0)?;
    let to = link.now_us();
    windows.push(Window {
        what: "RC lost",
        from_us: from,
        to_us: to,
        expect: &["rc_lost"],
        allow: &["autopilot_failsafe"],
    });
    let said = link.texts_between(from, to);
    assert!(
        said.iter().any(|t| t.contains("Radio Failsafe")),
        "ArduCopter names its radio failsafe: {said:?}"
    );

    // Fence: enabled with its maximum altitude above the copter, then
    // lowered under it (breach reported only: FENCE_ACTION 0).
    let from = link.now_us();
    link.command(
        MavCmd::MAV_CMD_DO_FENCE_ENABLE,
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    )?;
    link.param("FENCE_ALT_MAX", 15.0)?;
    link.hold(6.0)?;
    link.command(
        MavCmd::MAV_CMD_DO_FENCE_ENABLE,
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    )?;
    link.param("FENCE_ALT_MAX", 100.0)?;
    link.hold(4.0)?;
    let said = link.texts_between(from, link.now_us());
    assert!(
        said.iter().any(|t| t.contains("fence breached")),
        "ArduCopter names the breach: {said:?}"
    );
    windows.push(Window {
        what: "fence breached",
        from_us: from,
        to_us: link.now_us(),
        expect: &["geofence_breach"],
        allow: &["autopilot_failsafe"],
    });

    // The link: nothing either way for 10 s.
    let from = link.now_us();
    link.hole(10.0)?;
    link.hold(5.0)?;
    windows.push(Window {
        what: "10 s link hole",
        from_us: from,
        to_us: link.now_us(),
        expect: &["link_lost", "link_restored"],
        allow: &["link_degraded"],
    });

    // GPS off for 20 s (FS_EKF_THRESH 0: the copter dead-reckons in GUIDED).
    let from = link.now_us();
    link.param("SIM_GPS1_ENABLE", 0.0)?;
    link.hold(20.0)?;
    link.param("SIM_GPS1_ENABLE", 1.0)?;
    link.wait("the 3D fix back", 20.0, |s| s.fix_type >= 3)?;
    link.hold(8.0)?;
    windows.push(Window {
        what: "GPS off 20 s",
        from_us: from,
        to_us: link.now_us(),
        expect: &["gps_lost", "gps_restored"],
        allow: &["ekf_unhealthy", "autopilot_failsafe"],
    });

    // Battery voltage under BATT_LOW_VOLT (10.5 V) for BATT_LOW_TIMER
    // (10 s): ArduCopter's low-battery failsafe, BATT_FS_LOW_ACT RTL.
    let from = link.now_us();
    link.param("SIM_BATT_VOLTAGE", 10.0)?;
    link.wait("RTL on the low battery", 25.0, |s| s.custom_mode == RTL)?;
    link.hold(3.0)?;
    let to = link.now_us();
    let said = link.texts_between(from, to);
    assert!(
        said.iter().any(|t| t.starts_with("Battery 1 is low")),
        "ArduCopter says its battery is low: {said:?}"
    );
    link.mode(GUIDED)?;
    link.hold(3.0)?;
    windows.push(Window {
        what: "battery 10.0 V",
        from_us: from,
        to_us: link.now_us(),
        expect: &["battery_low"],
        allow: &["autopilot_failsafe"],
    });

    // Motor 1 killed: the quad cannot fly on three.
    let from = link.now_us();
    link.param("SIM_ENGINE_MUL", 0.0)?;
    link.param("SIM_ENGINE_FAIL", 1.0)?;
    link.wait("down", 20.0, |s| s.altitude < 1.0)?;
    let down = link.now_us();
    // The quad tumbles to the ground in about 2.8 s. SITL's copter
    // reports no ESC rpm (all 0), and ArduCopter's own "Potential Thrust
    // Loss (n)" came 2 to 10 s after the impact in some runs, not at all
    // in others: `loss_of_control` (its attitude far off its target) must
    // tell it before the impact. `engine_failure` when ArduCopter said
    // so, and in any case no false alarm of another failure.
    link.hold(15.0)?;
    let to = link.now_us();
    let said = link.texts_between(from, to);
    let thrust_loss = said.iter().any(|t| t.starts_with("Potential Thrust Loss"));
    // The impact: SITL's own "SIM Hit ground", else the altitude under 1 m.
    let impact = link
        .said
        .texts
        .iter()
        .find(|(at, t)| (from..=to).contains(at) && t.starts_with("SIM Hit ground"))
        .map_or(down, |(at, _)| (*at).min(down));
    eprintln!(
        "motor 1 killed: ArduCopter said it lost thrust: {thrust_loss}; impact {:.3} s after the kill",
        (impact - from) as f64 / 1e6
    );
    windows.push(Window {
        what: "motor 1 killed, before impact",
        from_us: from,
        to_us: impact,
        expect: &["loss_of_control"],
        allow: &[],
    });
    windows.push(Window {
        what: "motor 1 killed",
        from_us: from,
        to_us: to,
        expect: if thrust_loss {
            &["engine_failure"]
        } else {
            &[]
        },
        allow: &[
            "engine_failure",
            "motor_imbalance",
            "vehicle_emergency",
            "ekf_unhealthy",
            "autopilot_failsafe",
        ],
    });
    Ok(windows)
}

#[test]
fn copter_failures_one_after_another() {
    // A turn to fly (real/main.rs: at most two flights at once, each on
    // instances of its own).
    let turn = crate::sitl_turn();
    let Some(located) = ardupilot::require(Firmware::Copter, "copter_failures_one_after_another")
    else {
        return;
    };
    let started = Instant::now();
    let dir = Scratch::new("real-failures-copter");
    let options = Options {
        instance: turn.instance(3),
        speedup: SPEEDUP,
        params: [
            // Continue in GUIDED on RC loss (4), as copter.parm's 16.
            ("FS_OPTIONS", 20.0),
            // No EKF failsafe: the GPS hole is flown in GUIDED.
            ("FS_EKF_THRESH", 0.0),
            ("BATT_FS_LOW_ACT", 2.0),
            // Maximum-altitude fence, reported only.
            ("FENCE_TYPE", 1.0),
            ("FENCE_ACTION", 0.0),
            ("FENCE_ALT_MAX", 100.0),
            ("FENCE_ENABLE", 0.0),
        ]
        .iter()
        .map(|(n, v)| (n.to_string(), *v))
        .collect(),
        ..Options::default()
    };
    let mut sitl = Sitl::start(&located, &options, &dir).expect("SITL starts");
    let tlog = dir.join("copter.tlog");
    eprintln!("copter: SITL and its tlog in {}", dir.display());
    let mut link = fly_or_panic(&sitl, "copter link", Link::open(&sitl, SPEEDUP, &tlog));
    let flown = fly_copter(&mut link);
    let texts = std::mem::take(&mut link.said.texts);
    let modes = link.said.modes.clone();
    let recorded = link.recorded;
    fly_or_panic(&sitl, "copter tlog", link.finish());
    sitl.stop();
    let windows = fly_or_panic(&sitl, "copter flight", flown);
    said_in(&windows, &texts, &modes);
    eprintln!(
        "copter: {recorded} frames, flown in {:.1} s wall; modes {modes:?}",
        started.elapsed().as_secs_f64()
    );
    let events = petrel_events(&tlog);
    eprintln!("{}", timeline(&events));
    check(&events, &windows);
    prearm_reasons_are_the_vehicles(&events, &texts);
    // The weak motor is named; the motor kill is ArduCopter's thrust loss.
    let weak = &windows[0];
    assert!(events.iter().any(|e| e.name == "motor_imbalance"
        && e.params["motor"] == 1
        && (weak.from_us..=weak.to_us).contains(&e.at_us)));
    // The killed motor is a loss of control before the impact, once.
    let killed = windows
        .iter()
        .find(|w| w.what == "motor 1 killed, before impact")
        .expect("the motor-kill window");
    let lost: Vec<&Event> = events
        .iter()
        .filter(|e| e.name == "loss_of_control")
        .collect();
    assert_eq!(lost.len(), 1, "one loss of control: {lost:?}");
    assert_eq!(lost[0].category, "catastrophic");
    eprintln!(
        "copter: loss_of_control {:.3} s after the motor kill, {:.3} s before the impact {}",
        (lost[0].at_us - killed.from_us) as f64 / 1e6,
        (killed.to_us - lost[0].at_us) as f64 / 1e6,
        lost[0].params
    );
    eprintln!(
        "copter: done in {:.1} s wall",
        started.elapsed().as_secs_f64()
    );
}

// ------------------------------------------------------------ plane

const AUTO: u32 = 10;
/// SITL's home (sitl_tests::ardupilot::Options' default).
const HOME: (f64, f64) = (-35.363261, 149.165230);

/// A mission item at `north`, `east` metres from home, `alt` above it.
fn item(command: MavCmd, north: f64, east: f64, alt: f32, param1: f32) -> MISSION_ITEM_INT_DATA {
    let lat = HOME.0 + north / 111_320.0;
    let lon = HOME.1 + east / (111_320.0 * HOME.0.to_radians().cos());
    MISSION_ITEM_INT_DATA {
        param1,
        x: (lat * 1e7) as i32,
        y: (lon * 1e7) as i32,
        z: alt,
        command,
        target_system: 1,
        target_component: 1,
        frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
        autocontinue: 1,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        ..MISSION_ITEM_INT_DATA::DEFAULT
    }
}

/// An AUTO mission with MISSION_ITEM_REACHED requested as a stream (the
/// gateway's mistake that real ArduPlane answers with its last reach
/// every period, 65535 before any); the engine out at cruise on the
/// third leg.
fn fly_plane(link: &mut Link) -> Result<Vec<Window>, String> {
    use MavCmd::*;
    let mut home = item(MAV_CMD_NAV_WAYPOINT, 0.0, 0.0, 0.0, 0.0);
    home.frame = MavFrame::MAV_FRAME_GLOBAL;
    let mission = [
        home,
        item(MAV_CMD_NAV_TAKEOFF, 0.0, 0.0, 50.0, 15.0),
        item(MAV_CMD_NAV_WAYPOINT, 400.0, 0.0, 60.0, 0.0),
        item(MAV_CMD_NAV_WAYPOINT, 400.0, 400.0, 60.0, 0.0),
        item(MAV_CMD_NAV_WAYPOINT, 0.0, 400.0, 60.0, 0.0),
        item(MAV_CMD_NAV_WAYPOINT, 0.0, 0.0, 60.0, 0.0),
    ];
    // Right after boot ArduPlane answers NO_SPACE until its mission
    // storage is ready.
    let mut uploaded = link.upload_mission(&mission);
    for _ in 0..10 {
        if uploaded.is_ok() {
            break;
        }
        link.hold(2.0)?;
        uploaded = link.upload_mission(&mission);
    }
    uploaded?;
    // MISSION_ITEM_REACHED (46) every 250 ms.
    let interval = link.command(
        MAV_CMD_SET_MESSAGE_INTERVAL,
        [46.0, 250_000.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    )?;
    if interval != MavResult::MAV_RESULT_ACCEPTED {
        return Err(format!(
            "SET_MESSAGE_INTERVAL MISSION_ITEM_REACHED: {interval:?}"
        ));
    }
    link.arm(AUTO, 120.0, |_| Ok(()))?;
    link.wait("waypoint 3 reached", 120.0, |s| s.reached.contains(&3))?;
    link.hold(3.0)?;
    // The engine out at cruise: servo 3 (the throttle) at no thrust
    // (ArduPilot 4.7: SIM_ENGINE_FAIL is a mask of outputs).
    let from = link.now_us();
    link.param("SIM_ENGINE_MUL", 0.0)?;
    link.param("SIM_ENGINE_FAIL", 4.0)?;
    link.hold(15.0)?;
    Ok(vec![Window {
        what: "engine out at cruise",
        from_us: from,
        to_us: link.now_us(),
        expect: &["engine_failure"],
        allow: &[],
    }])
}

#[test]
fn plane_engine_out_at_cruise() {
    // A turn to fly (real/main.rs: at most two flights at once, each on
    // instances of its own).
    let turn = crate::sitl_turn();
    let Some(located) = ardupilot::require(Firmware::Plane, "plane_engine_out_at_cruise") else {
        return;
    };
    let started = Instant::now();
    let dir = Scratch::new("real-failures-plane");
    let options = Options {
        instance: turn.instance(4),
        speedup: SPEEDUP,
        ..Options::default()
    };
    let mut sitl = Sitl::start(&located, &options, &dir).expect("SITL starts");
    let tlog = dir.join("plane.tlog");
    eprintln!("plane: SITL and its tlog in {}", dir.display());
    let mut link = fly_or_panic(&sitl, "plane link", Link::open(&sitl, SPEEDUP, &tlog));
    let flown = fly_plane(&mut link);
    let texts = std::mem::take(&mut link.said.texts);
    let recorded = link.recorded;
    let (reached_frames, reached) = (link.said.reached_frames, link.said.reached.clone());
    fly_or_panic(&sitl, "plane tlog", link.finish());
    sitl.stop();
    let windows = fly_or_panic(&sitl, "plane flight", flown);
    said_in(&windows, &texts, &[]);
    eprintln!(
        "plane: {recorded} frames, flown in {:.1} s wall",
        started.elapsed().as_secs_f64()
    );
    let events = petrel_events(&tlog);
    eprintln!("{}", timeline(&events));
    check(&events, &windows);
    prearm_reasons_are_the_vehicles(&events, &texts);
    // Each item reached once, though ArduPlane re-sent its last reach
    // (65535 before any) four times a second.
    let items: Vec<u64> = events
        .iter()
        .filter(|e| e.name == "mission_item_reached")
        .map(|e| e.params["seq"].as_u64().unwrap_or(u64::MAX))
        .collect();
    eprintln!("plane: {reached_frames} MISSION_ITEM_REACHED frames, seqs {reached:?}");
    assert_eq!(
        reached.first(),
        Some(&65535),
        "the stream starts with 65535"
    );
    assert!(
        reached_frames > 40,
        "{reached_frames} MISSION_ITEM_REACHED frames"
    );
    let want: Vec<u64> = reached
        .iter()
        .filter(|s| **s != 65535)
        .map(|s| u64::from(*s))
        .collect();
    assert!(want.starts_with(&[1, 2, 3]), "{reached:?}");
    assert_eq!(items, want, "one mission_item_reached per reach");
    eprintln!(
        "plane: done in {:.1} s wall",
        started.elapsed().as_secs_f64()
    );
}
