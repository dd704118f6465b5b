//! The ground's view of a team: each vehicle's frames in its own lane,
//! counted and watched for losses per system, checked per vehicle.

use std::path::Path;

use elaboration::Frame;
use mavlink::dialects::ardupilotmega::{
    MavAutopilot, MavMessage, MavModeFlag, MavState, MavType, HEARTBEAT_DATA,
};
use mavlink::{MavHeader, MavlinkVersion};
use nets::{Category, Event, Micros};

use super::ground::Ground;
use crate::mirror::check::{Side, WINDOW};

/// A HEARTBEAT of (`system`, `component`), sequence `seq`.
fn heartbeat(system: u8, component: u8, seq: u8, armed: bool, autopilot: MavAutopilot) -> Vec<u8> {
    let header = MavHeader {
        system_id: u32::from(system),
        component_id: component,
        sequence: seq,
    };
    let mut base_mode = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
    if armed {
        base_mode |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
    }
    let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 4,
        mavtype: MavType::MAV_TYPE_GROUND_ROVER,
        autopilot,
        base_mode,
        system_status: MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    });
    elaboration::frame::serialize(header, MavlinkVersion::V2, &hb)
}

fn rover(system: u8, seq: u8, armed: bool) -> Vec<u8> {
    heartbeat(
        system,
        1,
        seq,
        armed,
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
    )
}

fn gcs(seq: u8) -> Vec<u8> {
    heartbeat(255, 190, seq, false, MavAutopilot::MAV_AUTOPILOT_INVALID)
}

fn ground_of(project: &nets::Project) -> Ground {
    let layers = crate::profile::Layers::builtin("ardupilot");
    let profile = layers.load().expect("profile");
    let lanes = crate::team::lanes(
        project,
        Path::new("."),
        &profile,
        crate::team::family(&layers.layers),
        &elaboration::Config::default(),
    )
    .expect("lanes");
    Ground::new(lanes, WINDOW)
}

/// Vehicle time is the ground's in these tests.
fn same(t: Micros) -> Option<Micros> {
    Some(t)
}

/// Feeds `bytes` at `t` as the mirror does; the events the ground
/// elaborated.
fn elaborate(g: &mut Ground, t: Micros, bytes: &[u8]) -> Vec<Event> {
    let frame = Frame::parse(bytes).expect("a frame");
    g.heard(t, &frame, same);
    g.elaborate(t, &frame);
    let mut events = Vec::new();
    g.drain(same, |e| events.push(e.clone()));
    events
}

/// Their names.
fn feed(g: &mut Ground, t: Micros, bytes: &[u8]) -> Vec<String> {
    elaborate(g, t, bytes).into_iter().map(|e| e.name).collect()
}

/// Feeds `bytes` at `t`, and the vehicle publishes the same events (it
/// elaborates the same frames): they all match.
fn both(g: &mut Ground, t: Micros, bytes: &[u8]) {
    for e in elaborate(g, t, bytes) {
        g.vehicle_event(t, &e);
    }
}

fn armed(names: &[String]) -> Vec<&str> {
    names
        .iter()
        .map(String::as_str)
        .filter(|n| n.starts_with("armed") || n.starts_with("disarmed"))
        .collect()
}

#[test]
fn each_vehicles_frames_go_to_its_lane_and_its_events_are_qualified() {
    let project = crate::team::supervised::team();
    let mut g = ground_of(&project);
    assert!(g.team());
    assert!(armed(&feed(&mut g, 100_000, &rover(1, 0, false))).is_empty());
    assert!(armed(&feed(&mut g, 200_000, &rover(2, 0, false))).is_empty());
    assert_eq!(
        armed(&feed(&mut g, 300_000, &rover(2, 1, true))),
        ["armed@R2"]
    );
    assert_eq!(
        armed(&feed(&mut g, 400_000, &rover(1, 1, true))),
        ["armed@R1"]
    );
    // A ground station is no vehicle of the team: said once, not counted.
    feed(&mut g, 500_000, &gcs(0));
    feed(&mut g, 600_000, &gcs(1));
    assert_eq!(g.poll_foreign(), Some(255));
    assert_eq!(g.poll_foreign(), None);
    assert_eq!(g.foreign().get(&255), Some(&2));
    let seen: Vec<_> = g
        .watches()
        .iter()
        .map(|w| (w.name.clone(), w.system, w.frames, w.heard))
        .collect();
    assert_eq!(
        seen,
        [
            (Some("R1".to_owned()), Some(1), 2, true),
            (Some("R2".to_owned()), Some(2), 2, true)
        ]
    );
    // Requests go to the first vehicle's companion, as the onboard
    // gateway speaks as it.
    assert_eq!(g.companion(), Some((1, crate::mirror::COMPANION)));
}

#[test]
fn the_check_is_per_vehicle() {
    let project = crate::team::supervised::team();
    let mut g = ground_of(&project);
    let ev = |name: &str| Event {
        name: name.to_owned(),
        category: Category::Catastrophic,
        params: nets::Params::new(),
    };
    // Both vehicles heard through 30 s.
    for (i, t) in (0..30u8).zip((0..).step_by(1_000_000)) {
        both(&mut g, t, &rover(1, i, false));
        both(&mut g, t + 1, &rover(2, i, false));
    }
    // The ground saw R2's engine fail; the vehicle published R1's: the
    // same name, another vehicle's, so neither matches.
    g.vehicle_event(10_000_000, &ev("engine_failure@R1"));
    g.checks[1].ground(10_000_000, &ev("engine_failure@R2"));
    g.advance(Some(29_000_000), same);
    let mut got = Vec::new();
    while let Some((vehicle, d)) = g.poll_disagreement() {
        got.push((vehicle.map(str::to_owned), d.event, d.seen_by));
    }
    got.sort_by(|a, b| a.0.cmp(&b.0));
    assert_eq!(
        got,
        [
            (
                Some("R1".to_owned()),
                "engine_failure@R1".to_owned(),
                Side::Vehicle
            ),
            (
                Some("R2".to_owned()),
                "engine_failure@R2".to_owned(),
                Side::Ground
            )
        ]
    );
    let counts: Vec<_> = g
        .counts()
        .map(|c| (c.ground_only, c.vehicle_only))
        .collect();
    assert_eq!(counts, [(0, 1), (1, 0)]);
    assert_eq!(g.total().ground_only + g.total().vehicle_only, 2);
}

#[test]
fn losses_are_watched_per_vehicle() {
    let project = crate::team::supervised::team();
    let mut g = ground_of(&project);
    // R1 heard at every second; R2 loses frames 10 to 14 (seq 10..=14).
    for (i, t) in (0..30u8).zip((0..).step_by(1_000_000)) {
        both(&mut g, t, &rover(1, i, false));
        if !(10..15).contains(&i) {
            both(&mut g, t + 1, &rover(2, i, false));
        }
    }
    let ev = |name: &str| Event {
        name: name.to_owned(),
        category: Category::Mission,
        params: nets::Params::new(),
    };
    // The vehicle published one event of each at 12 s that the ground did
    // not see: R2's falls in R2's loss (not judged), R1's does not.
    g.vehicle_event(12_000_000, &ev("landed@R1"));
    g.vehicle_event(12_000_000, &ev("landed@R2"));
    g.advance(Some(29_000_000), same);
    let (vehicle, d) = g.poll_disagreement().expect("R1's");
    assert_eq!((vehicle, d.event.as_str()), (Some("R1"), "landed@R1"));
    assert!(g.poll_disagreement().is_none());
    let unjudged: Vec<_> = g.counts().map(|c| c.unjudged).collect();
    assert_eq!(unjudged, [0, 1]);
}

#[test]
fn one_vehicle_is_the_first_autopilot_heard() {
    let (project, _) = crate::mirror::tests::example();
    let mut g = ground_of(&project);
    assert!(!g.team());
    // A ground station first: not the vehicle, and not said (no team).
    feed(&mut g, 100_000, &gcs(0));
    assert_eq!(g.watches()[0].system, None);
    assert_eq!(g.companion(), None);
    feed(&mut g, 200_000, &rover(7, 0, false));
    let names = feed(&mut g, 300_000, &rover(7, 1, true));
    assert_eq!(armed(&names), ["armed"]);
    assert_eq!(g.watches()[0].system, Some(7));
    assert_eq!(g.watches()[0].frames, 2);
    assert_eq!(g.poll_foreign(), None);
    assert_eq!(g.companion(), Some((7, crate::mirror::COMPANION)));
}

/// R1's autopilot heard disarmed at 0 s, then armed at 0.1 s, before the
/// downlink's first heartbeat (no time base).
fn arm_r1_with_no_time_base(g: &mut Ground) {
    let none = |_: Micros| None;
    for (i, armed) in [(0u8, false), (1, true)] {
        let frame = rover(1, i, armed);
        let frame = Frame::parse(&frame).expect("a frame");
        g.heard(u64::from(i) * 100_000, &frame, none);
        g.elaborate(u64::from(i) * 100_000, &frame);
        g.drain(none, |_| {});
    }
}

#[test]
fn events_before_the_time_base_are_judged_once_it_is_known() {
    let project = crate::team::supervised::team();
    let mut g = ground_of(&project);
    // R1 arms before the downlink's first heartbeat: no time base yet.
    arm_r1_with_no_time_base(&mut g);
    // The time base known (vehicle time = ground time + 5 s): the
    // vehicle's `armed@R1` at 5.1 s matches the ground's of 0.1 s.
    let base = |t: Micros| Some(t + 5_000_000);
    g.drain(base, |_| {});
    g.vehicle_event(
        5_100_000,
        &Event {
            name: "armed@R1".to_owned(),
            category: Category::Mission,
            params: nets::Params::new(),
        },
    );
    assert!(g.counts().next().is_some_and(|c| c.matched == 1));
}

#[test]
fn events_from_before_the_vehicle_started_are_not_judged() {
    let project = crate::team::supervised::team();
    let mut g = ground_of(&project);
    // R1 arms before the downlink's first heartbeat, and before the
    // vehicle's player started: vehicle time 0 is as far back as it goes.
    arm_r1_with_no_time_base(&mut g);
    // The vehicle started 5 s after the ground: its time clamps at 0.
    let base = |t: Micros| Some(t.saturating_sub(5_000_000));
    g.drain(base, |_| {});
    // The replica holds every record through 10 s: whatever the ground
    // had waiting is judged now (a ground-only event, were it kept).
    g.advance(Some(10_000_000), base);
    assert!(g.poll_disagreement().is_none());
    let counts = g.counts().next().expect("R1's counts");
    assert_eq!(
        (counts.ground_only, counts.unjudged, counts.matched),
        (0, 0, 0)
    );
}

/// ArduPlane's HEARTBEAT in `custom_mode` (16 INITIALISING, 0 MANUAL).
fn plane(seq: u8, custom_mode: u32) -> Vec<u8> {
    let header = MavHeader {
        system_id: 1,
        component_id: 1,
        sequence: seq,
    };
    let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode,
        mavtype: MavType::MAV_TYPE_FIXED_WING,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        system_status: MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    });
    elaboration::frame::serialize(header, MavlinkVersion::V2, &hb)
}

#[test]
fn a_mode_change_the_ground_alone_heard_at_boot_is_not_judged() {
    // Real ArduPlane at boot: the ground's port carried INITIALISING at
    // 0.15 s, then MANUAL at 1.15 s (a `mode_changed`); the vehicle's first
    // heartbeat was already MANUAL (its first reading: no event).
    let (project, _) = crate::mirror::tests::example();
    let mut g = ground_of(&project);
    feed(&mut g, 150_000, &plane(0, 16));
    let names = feed(&mut g, 1_150_000, &plane(1, 0));
    assert!(names.iter().any(|n| n == "mode_changed"), "{names:?}");
    for (i, t) in (2..12u8).zip((2_150_000..).step_by(1_000_000)) {
        feed(&mut g, t, &plane(i, 0));
    }
    g.advance(Some(11_000_000), same);
    assert!(g.poll_disagreement().is_none());
    let c = g.total();
    assert_eq!((c.ground_only, c.unjudged), (0, 1));
    // Past the settling, the same change on the ground alone is reported.
    feed(&mut g, 12_150_000, &plane(12, 10));
    for (i, t) in (13..20u8).zip((13_150_000..).step_by(1_000_000)) {
        feed(&mut g, t, &plane(i, 10));
    }
    g.advance(Some(19_000_000), same);
    let (_, d) = g.poll_disagreement().expect("the later change");
    assert_eq!(
        (d.event.as_str(), d.seen_by),
        ("mode_changed", Side::Ground)
    );
}
