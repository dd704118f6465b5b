//! The paper's UAV mission end to end (examples/uav-flight-test), each
//! scenario asserting on what the vehicle did (the simulator's truth) and on
//! the gateway's timeline, and replaying its recording with
//! `--check-against`. The nominal mission flies the real `petrel run`
//! process, the simulated ArduPlane and DEC over loopback, their clocks
//! `flight::SPEED` times faster than real time; the failures fly the same
//! cores in this process in simulated time (`simulated.rs`: no socket, no
//! wall clock).

use crate::{flight, simulated};

use flight::{fly, metres, site, Flown, Injection};
use sitl_tests::{Fault, PayloadFailure, SimState};

/// Simulated seconds a scenario may take.
const MAX_SIM_S: f64 = 420.0;

/// Down and disarmed, or crashed.
fn over(s: &SimState) -> bool {
    (s.landed && !s.armed && !s.reached.is_empty()) || s.crashed
}

/// Where the aircraft came to rest.
fn landed_at(s: &SimState) -> (f64, f64) {
    (s.lat, s.lon)
}

/// Common checks: the flight ended as the nets meant and replays exactly.
fn ended_well(name: &str, f: &Flown) {
    let s = &f.state;
    eprintln!(
        "{name}: {:.0} s of flight simulated in {:.1} s",
        s.time_s,
        f.wall.as_secs_f64()
    );
    assert!(
        s.landed && !s.armed && !s.crashed,
        "{name}: the flight did not end landed and disarmed (landed {}, armed {}, crashed {}, mode {}, t {:.0} s)\n{}",
        s.landed,
        s.armed,
        s.crashed,
        s.mode,
        s.time_s,
        f.stderr
    );
    let (code, err) = f.replay_check();
    assert_eq!(
        code,
        Some(0),
        "{name}: the recording does not replay exactly: {err}"
    );
}

fn at_seq(seq: u16) -> Box<dyn Fn(&SimState) -> bool> {
    Box::new(move |s: &SimState| s.reached.iter().any(|r| r.seq == seq))
}

#[test]
fn nominal_mission_completes_with_every_payload() {
    let f = fly("nominal", &[], Vec::new(), MAX_SIM_S, over);
    ended_well("nominal", &f);
    let home = site("Runway");
    assert!(
        metres(landed_at(&f.state), home) < 400.0,
        "landed far from home"
    );
    // Both camera waypoints: the camera started and stopped twice.
    let camera: Vec<String> = f
        .state
        .camera
        .iter()
        .map(|c| format!("{:?}", c.action))
        .collect();
    assert_eq!(
        camera.iter().filter(|a| a.contains("Start")).count(),
        2,
        "{camera:?}"
    );
    assert_eq!(
        camera.iter().filter(|a| a.contains("Stop")).count(),
        2,
        "{camera:?}"
    );
    // The sensor's relay went on and off.
    assert!(
        f.state.payload_actions.len() >= 2,
        "{:?}",
        f.state.payload_actions
    );
    assert!(f.calls().contains(&"plan".to_owned()));
}

#[test]
fn payload_failure_replans_without_the_camera_and_completes() {
    let f = simulated::fly(
        "payload",
        &["payload_failure@wp3"],
        Vec::new(),
        MAX_SIM_S,
        over,
    );
    ended_well("payload", &f);
    assert!(
        f.events().contains(&"payload_failure".to_owned()),
        "{:?}",
        f.events()
    );
    assert!(f.calls().contains(&"replan".to_owned()), "{:?}", f.calls());
    // The last camera waypoint (O3) is not flown: no camera start after the failure.
    let o3 = (-35.360557, 149.171282);
    assert!(
        f.state.reached.iter().all(|r| {
            f.state
                .mission
                .get(r.seq as usize)
                .is_none_or(|i| metres((i.lat(), i.lon()), o3) > 50.0)
        }),
        "O3 was still flown"
    );
}

#[test]
fn engine_failure_glides_to_the_nearest_site_and_another_position_picks_another() {
    let early = simulated::fly(
        "engine-early",
        &["engine_failure@wp2"],
        Vec::new(),
        MAX_SIM_S,
        over,
    );
    ended_well("engine-early", &early);
    let late = simulated::fly(
        "engine-late",
        &["engine_failure@wp6"],
        Vec::new(),
        MAX_SIM_S,
        over,
    );
    ended_well("engine-late", &late);
    for f in [&early, &late] {
        assert!(
            f.calls().contains(&"emergency_site".to_owned()),
            "{:?}",
            f.calls()
        );
    }
    let near = |f: &Flown| {
        ["Runway", "North field", "East field"]
            .into_iter()
            .min_by(|a, b| {
                metres(landed_at(&f.state), site(a))
                    .total_cmp(&metres(landed_at(&f.state), site(b)))
            })
            .expect("a site")
    };
    let (a, b) = (near(&early), near(&late));
    assert!(metres(landed_at(&early.state), site(a)) < 300.0);
    assert!(metres(landed_at(&late.state), site(b)) < 300.0);
    assert_ne!(a, b, "both engine failures landed at {a}");
}

#[test]
fn link_loss_of_ten_seconds_and_the_mission_goes_on() {
    let f = simulated::fly("link", &["link_loss@wp3:10s"], Vec::new(), MAX_SIM_S, over);
    ended_well("link", &f);
    assert!(
        f.events().contains(&"link_lost".to_owned()),
        "{:?}",
        f.events()
    );
    assert!(f.events().contains(&"link_restored".to_owned()));
    assert!(!f.verbs().contains(&"rtl".to_owned()), "{:?}", f.verbs());
}

#[test]
fn low_battery_returns() {
    let f = simulated::fly("battery", &["battery=22@wp4"], Vec::new(), MAX_SIM_S, over);
    ended_well("battery", &f);
    assert!(
        f.events().contains(&"battery_low".to_owned()),
        "{:?}",
        f.events()
    );
    // The return: RTL, or (ArduPlane) the mission's landing sequence at home.
    let after: Vec<String> = f
        .timeline
        .iter()
        .skip_while(|l| !(l["input"] == "event" && l["event"] == "battery_low"))
        .filter(|l| l["effect"] == "command")
        .filter_map(|l| l["verb"].as_str().map(str::to_owned))
        .collect();
    assert!(
        after.iter().any(|v| v == "rtl" || v == "land"),
        "no return after battery_low: {after:?}"
    );
    assert!(
        metres(landed_at(&f.state), site("Runway")) < 400.0,
        "not back home"
    );
    // The last operations-area waypoint (O3) is not flown.
    let o3 = (-35.360557, 149.171282);
    let low_at = f.state.faults.first().map_or(0.0, |fault| fault.time_s);
    assert!(
        f.state
            .reached
            .iter()
            .filter(|r| r.time_s > low_at + 5.0)
            .all(|r| f
                .state
                .mission
                .get(r.seq as usize)
                .is_none_or(|i| metres((i.lat(), i.lon()), o3) > 50.0)),
        "O3 still flown after the low battery"
    );
}

#[test]
fn after_a_catastrophic_event_only_its_reaction_runs() {
    // The engine fails over the first operations-area waypoint; 8 s later
    // (once the catastrophic reaction has begun) the camera fails and the
    // battery runs low.
    let after_engine = |s: &SimState| {
        s.faults
            .first()
            .is_some_and(|f| f.fault == Fault::EngineFailure && s.time_s > f.time_s + 8.0)
    };
    let injections: Vec<Injection> = vec![
        (at_seq(3), Fault::EngineFailure),
        (
            Box::new(after_engine),
            Fault::PayloadFailure(PayloadFailure::Critical),
        ),
        (
            Box::new(after_engine),
            Fault::BatteryRemaining { percent: 22.0 },
        ),
    ];
    let f = simulated::fly("catastrophic-first", &[], injections, MAX_SIM_S, over);
    let (code, err) = f.replay_check();
    assert_eq!(code, Some(0), "{err}");
    assert!(
        f.calls().contains(&"emergency_site".to_owned()),
        "{:?}",
        f.calls()
    );
    assert!(!f.calls().contains(&"replan".to_owned()), "{:?}", f.calls());
    assert!(!f.verbs().contains(&"rtl".to_owned()), "{:?}", f.verbs());
    let dropped: Vec<&str> = f
        .effects("dropped")
        .iter()
        .filter_map(|l| l["event"].as_str())
        .collect();
    assert!(
        dropped.contains(&"battery_low") && dropped.contains(&"payload_failure"),
        "the later failures were not dropped under the lockout: {dropped:?}"
    );
}

#[test]
fn cumulative_failures_payload_link_then_battery() {
    let f = simulated::fly(
        "cumulative",
        // After the replan the mission is numbered anew: later faults by time.
        &["payload_failure@wp3", "link_loss@60s:10s", "battery=22@90s"],
        Vec::new(),
        MAX_SIM_S,
        over,
    );
    let events = f.events();
    for e in ["payload_failure", "link_lost", "battery_low"] {
        assert!(events.contains(&e.to_owned()), "{e} not heard: {events:?}");
    }
    assert!(f.calls().contains(&"replan".to_owned()));
    ended_well("cumulative", &f);
    assert!(
        metres(landed_at(&f.state), site("Runway")) < 400.0,
        "not back home"
    );
    let (code, err) = f.replay_check();
    assert_eq!(code, Some(0), "{err}");
}
