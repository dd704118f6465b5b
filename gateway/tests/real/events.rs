//! `petrel events` on a real ArduCopter SITL flight: gotos in a row, as
//! ArduCopter says them and as `petrel events` finds them (the tests on
//! synthetic logs and shared recordings: it's `events`).

// The ground station's link to ArduPilot's SITL that real_failures.rs
// flies with.
use crate::real_failures::flight;
use crate::scratch;

use std::process::Command;

use mavlink::dialects::ardupilotmega::*;
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

fn json_lines(out: &str) -> Vec<Value> {
    out.lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON: {l}: {e}")))
        .collect()
}

/// Simulated seconds per wall second of the copter flight below.
const COPTER_SPEEDUP: u32 = 10;

/// The copter's home (sitl_tests::ardupilot::Options' default).
const HOME: (f64, f64) = (-35.363261, 149.165230);

/// A point `north`, `east` metres from home.
fn from_home(north: f64, east: f64) -> (f64, f64) {
    let m_per_deg = 111_319.5;
    (
        HOME.0 + north / m_per_deg,
        HOME.1 + east / (m_per_deg * HOME.0.to_radians().cos()),
    )
}

/// Metres between two points (flat earth: tens of metres apart).
fn metres(a: (f64, f64), b: (f64, f64)) -> f64 {
    let m_per_deg = 111_319.5;
    let north = (a.0 - b.0) * m_per_deg;
    let east = (a.1 - b.1) * m_per_deg * HOME.0.to_radians().cos();
    north.hypot(east)
}

/// A goto as the gateway sends it (docs/vehicle.md): COMMAND_INT
/// DO_REPOSITION, GLOBAL_RELATIVE_ALT, the CHANGE_MODE flag; its result.
fn reposition(
    link: &mut flight::Link,
    (lat, lon): (f64, f64),
    alt: f32,
) -> Result<MavResult, String> {
    let before = link.said.acks.len();
    link.send(MavMessage::COMMAND_INT(COMMAND_INT_DATA {
        param1: -1.0,
        param2: 1.0,
        param3: 0.0,
        param4: f32::NAN,
        x: (lat * 1e7).round() as i32,
        y: (lon * 1e7).round() as i32,
        z: alt,
        command: MavCmd::MAV_CMD_DO_REPOSITION,
        target_system: 1,
        target_component: 1,
        frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
        current: 0,
        autocontinue: 0,
    }))?;
    let repositioned = |s: &flight::Said| {
        s.acks[before..]
            .iter()
            .any(|(c, _)| *c == MavCmd::MAV_CMD_DO_REPOSITION)
    };
    link.wait("DO_REPOSITION acknowledged", 5.0, repositioned)?;
    Ok(link.said.acks[before..]
        .iter()
        .find(|(c, _)| *c == MavCmd::MAV_CMD_DO_REPOSITION)
        .map_or(MavResult::MAV_RESULT_FAILED, |(_, r)| *r))
}

/// Take-off in GUIDED, a goto with the default GUID_OPTIONS (0), then
/// GUID_OPTIONS 64 and two gotos in a row, each waited for by its
/// MISSION_ITEM_REACHED: the number of those frames after the first goto.
fn fly_gotos(link: &mut flight::Link, targets: [(f64, f64); 3], alt: f32) -> Result<u64, String> {
    const GUIDED: u32 = 4;
    link.arm(GUIDED, 120.0, |l| {
        l.command(
            MavCmd::MAV_CMD_NAV_TAKEOFF,
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, alt],
        )
        .map(|_| ())
    })?;
    link.wait("at altitude", 40.0, |s| s.altitude > f64::from(alt) - 1.5)?;
    // GUID_OPTIONS 0: the position controller flies it, silently.
    let accepted = MavResult::MAV_RESULT_ACCEPTED;
    let r = reposition(link, targets[0], alt)?;
    if r != accepted {
        return Err(format!("the first goto: {r:?}"));
    }
    link.hold(15.0)?;
    let silent = link.said.reached_frames;
    // GUID_OPTIONS 64 (WPNavUsedForPosControl): each destination reached
    // is said.
    link.param("GUID_OPTIONS", 64.0)?;
    for (n, target) in targets[1..].iter().enumerate() {
        let r = reposition(link, *target, alt)?;
        if r != accepted {
            return Err(format!("goto {}: {r:?}", n + 2));
        }
        let want = silent + n as u64 + 1;
        link.wait("the goto reached", 40.0, |s| s.reached_frames >= want)?;
    }
    link.hold(3.0)?;
    Ok(silent)
}

/// Real ArduCopter SITL (`../shared/ardupilot-sitl`): two gotos in a row,
/// each reached, are two `goto_reached` from the built `petrel events` on
/// the flight's tlog, each where the copter was, and no mission item. With
/// the default GUID_OPTIONS, ArduCopter says nothing when a goto is reached
/// (the position controller flies it): no MISSION_ITEM_REACHED at all.
#[test]
fn two_gotos_in_a_row_on_real_arducopter_are_two_goto_reached() {
    // A turn to fly (real/main.rs: at most two flights at once, each on
    // instances of its own).
    let turn = crate::sitl_turn();
    use sitl_tests::ardupilot::{self, Firmware, Options, Sitl};
    use std::time::Instant;
    let test = "two_gotos_in_a_row_on_real_arducopter_are_two_goto_reached";
    let Some(located) = ardupilot::require(Firmware::Copter, test) else {
        return;
    };
    let started = Instant::now();
    let dir = Scratch::new("events-gotos-copter");
    let options = Options {
        // Unique in this binary (real/main.rs).
        instance: turn.instance(14),
        speedup: COPTER_SPEEDUP,
        ..Options::default()
    };
    let mut sitl = Sitl::start(&located, &options, &dir).expect("SITL starts");
    let tlog = dir.join("copter.tlog");
    let alt = 20.0;
    let targets = [
        from_home(30.0, 0.0),
        from_home(40.0, 30.0),
        from_home(0.0, 60.0),
    ];
    let flown = flight::Link::open(&sitl, COPTER_SPEEDUP, &tlog).and_then(|mut link| {
        let flown = fly_gotos(&mut link, targets, alt);
        let said = (link.said.reached_frames, link.said.reached.clone());
        let sim_s = link.now_us() as f64 / 1e6;
        link.finish().and(flown).map(|silent| (silent, said, sim_s))
    });
    sitl.stop();
    let (silent, (frames, seqs), sim_s) =
        flown.unwrap_or_else(|e| panic!("the flight: {e}\nSITL said:\n{}", sitl.output()));
    eprintln!(
        "copter: {sim_s:.1} s of vehicle time flown in {:.1} s wall at {COPTER_SPEEDUP}x",
        started.elapsed().as_secs_f64()
    );
    // What ArduCopter itself said: nothing for the first goto, one
    // MISSION_ITEM_REACHED 0 for each of the other two.
    assert_eq!((silent, frames, seqs), (0, 2, vec![0]));
    let (code, out, err) = petrel(&["events", &tlog.display().to_string(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let events = json_lines(&out);
    let named =
        |name: &str| -> Vec<&Value> { events.iter().filter(|e| e["event"] == name).collect() };
    let gotos = named("goto_reached");
    let timeline: Vec<String> = events
        .iter()
        .map(|e| format!("{} {}", e["event"], e["params"]))
        .collect();
    for g in &gotos {
        let at_s = g["time_us"].as_u64().unwrap_or_default() as f64 / 1e6
            - flight::Link::tlog_us(0) as f64 / 1e6;
        eprintln!("copter: goto_reached at {at_s:.2} s {}", g["params"]);
    }
    assert_eq!(gotos.len(), 2, "{timeline:#?}");
    assert!(named("mission_item_reached").is_empty(), "{timeline:#?}");
    for (goto, target) in gotos.iter().zip(&targets[1..]) {
        assert_eq!(goto["category"], "mission");
        let p = &goto["params"];
        let at = (
            p["lat"].as_f64().unwrap_or(f64::NAN),
            p["lon"].as_f64().unwrap_or(f64::NAN),
        );
        // WPNAV_RADIUS is 2 m; the last position came at most 250 ms
        // before, at the end of the approach.
        assert!(metres(at, *target) < 4.0, "{at:?} is not {target:?}: {p}");
        let up = p["alt"].as_f64().unwrap_or(f64::NAN);
        assert!((up - f64::from(alt)).abs() < 2.0, "{p}");
    }
    eprintln!(
        "copter: done in {:.1} s wall",
        started.elapsed().as_secs_f64()
    );
}
