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
        g.vehicle_event(t, t, None, &e);
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
    let project = crate::team::fixtures::team();
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
    let project = crate::team::fixtures::team();
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
    g.vehicle_event(10_000_000, 10_000_000, None, &ev("engine_failure@R1"));
    g.checks[1].ground(10_000_000, None, &ev("engine_failure@R2"));
    g.advance(Some(29_000_000), |_| None, same);
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
    let project = crate::team::fixtures::team();
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
    g.vehicle_event(12_000_000, 12_000_000, None, &ev("armed@R1"));
    g.vehicle_event(12_000_000, 12_000_000, None, &ev("armed@R2"));
    g.advance(Some(29_000_000), |_| None, same);
    let (vehicle, d) = g.poll_disagreement().expect("R1's");
    assert_eq!((vehicle, d.event.as_str()), (Some("R1"), "armed@R1"));
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
    let project = crate::team::fixtures::team();
    let mut g = ground_of(&project);
    // R1 arms before the downlink's first heartbeat: no time base yet.
    arm_r1_with_no_time_base(&mut g);
    // The time base known (vehicle time = ground time + 5 s): the
    // vehicle's `armed@R1` at 5.1 s matches the ground's of 0.1 s.
    let base = |t: Micros| Some(t + 5_000_000);
    g.drain(base, |_| {});
    g.vehicle_event(
        5_100_000,
        5_100_000,
        None,
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
    let project = crate::team::fixtures::team();
    let mut g = ground_of(&project);
    // R1 arms before the downlink's first heartbeat, and before the
    // vehicle's player started: vehicle time 0 is as far back as it goes.
    arm_r1_with_no_time_base(&mut g);
    // The vehicle started 5 s after the ground: its time clamps at 0.
    let base = |t: Micros| Some(t.saturating_sub(5_000_000));
    g.drain(base, |_| {});
    // The replica holds every record through 10 s: whatever the ground
    // had waiting is judged now (a ground-only event, were it kept).
    g.advance(Some(10_000_000), |_| None, base);
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
    g.advance(Some(11_000_000), |_| None, same);
    assert!(g.poll_disagreement().is_none());
    let c = g.total();
    assert_eq!((c.ground_only, c.unjudged), (0, 1));
    // Past the settling, the same change on the ground alone is reported.
    feed(&mut g, 12_150_000, &plane(12, 10));
    for (i, t) in (13..20u8).zip((13_150_000..).step_by(1_000_000)) {
        feed(&mut g, t, &plane(i, 10));
    }
    g.advance(Some(19_000_000), |_| None, same);
    let (_, d) = g.poll_disagreement().expect("the later change");
    assert_eq!(
        (d.event.as_str(), d.seen_by),
        ("mode_changed", Side::Ground)
    );
}

/// A frame of (1, `component`), sequence `seq`.
fn of(component: u8, seq: u8, message: &MavMessage) -> Vec<u8> {
    let header = MavHeader {
        system_id: 1,
        component_id: component,
        sequence: seq,
    };
    elaboration::frame::serialize(header, MavlinkVersion::V2, message)
}

/// ArduPlane armed in AUTO, its HEARTBEAT of sequence `seq`.
fn plane_in_auto(seq: u8) -> Vec<u8> {
    let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 10,
        mavtype: MavType::MAV_TYPE_FIXED_WING,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
            | MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED,
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    });
    of(1, seq, &hb)
}

/// The onboard gateway's HEARTBEAT (1, 191), sequence `seq`.
fn companion(seq: u8) -> Vec<u8> {
    let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    });
    of(crate::mirror::COMPANION, seq, &hb)
}

/// ArduPlane's STATUSTEXT `text`, sequence `seq`.
fn says(seq: u8, text: &str) -> Vec<u8> {
    use mavlink::dialects::ardupilotmega::{MavSeverity, STATUSTEXT_DATA};
    let msg = MavMessage::STATUSTEXT(STATUSTEXT_DATA {
        severity: MavSeverity::MAV_SEVERITY_CRITICAL,
        text: text.into(),
        id: 0,
        chunk_seq: 0,
    });
    of(1, seq, &msg)
}

/// A flight in the operations area on the ground's link: the autopilot's
/// heartbeat every 0.25 s from 0.15 s to `until`, its frames numbered
/// whole but for those `lost` drops (by the autopilot's own count), and
/// the onboard gateway's heartbeat every 0.25 s whose numbers jump by 4 (a
/// camera command a second and its mission and parameter traffic, which
/// the autopilot keeps). The vehicle publishes every event the ground
/// elaborates but those named in `missed`. Returns the autopilot's next
/// sequence number.
fn operations(
    g: &mut Ground,
    until: Micros,
    lost: impl Fn(u32) -> bool,
    missed: &[&str],
    mut extra: impl FnMut(Micros) -> Option<String>,
) -> u32 {
    let mut seq = 0u32;
    let mut t = 150_000;
    let mut k = 0u8;
    while t < until {
        let mut frames = vec![plane_in_auto(seq as u8)];
        seq += 1;
        if let Some(text) = extra(t) {
            frames.push(says(seq as u8, &text));
            seq += 1;
        }
        for (n, bytes) in frames.iter().enumerate() {
            if lost(seq - (frames.len() - n) as u32) {
                continue;
            }
            for e in elaborate(g, t, bytes) {
                if !missed.contains(&e.name.as_str()) {
                    g.vehicle_event(t, t, None, &e);
                }
            }
        }
        feed(g, t + 1_000, &companion(k));
        k = k.wrapping_add(4);
        g.advance(Some(t), |_| None, same);
        t += 250_000;
    }
    seq
}

#[test]
fn the_onboard_gateways_numbers_are_no_loss_and_a_missed_engine_failure_is_reported() {
    // The companion's numbers jump at every command it sends the
    // autopilot (which keeps it): before, each jump counted as radio
    // loss and the check ignored ground-only events for 20 s, so an
    // engine failure the vehicle missed in the operations area (a camera
    // command a second) was never reported.
    let (project, _) = crate::mirror::tests::example();
    for (loss, lost) in [
        ("no loss", (|_| false) as fn(u32) -> bool),
        // A frame of the autopilot's in ten lost: no hole in the ground's view.
        ("10 % loss", |s| s % 10 == 7),
    ] {
        let mut g = ground_of(&project);
        operations(&mut g, 20_000_000, lost, &["engine_failure"], |t| {
            (t == 12_150_000).then(|| "Potential Thrust Loss (3)".to_owned())
        });
        g.advance(Some(20_000_000), |_| None, same);
        let total = g.total();
        let (_, d) = g
            .poll_disagreement()
            .unwrap_or_else(|| panic!("{loss}: no disagreement; {total:?}"));
        assert_eq!(
            (d.event.as_str(), d.seen_by, d.time),
            ("engine_failure", Side::Ground, 12_150_000),
            "{loss}"
        );
        assert!(g.poll_disagreement().is_none(), "{loss}");
        // And the check was never blind (no hole in the ground's view).
        assert_eq!(g.blind(same), [(19_750_000, 0)], "{loss}");
    }
}

#[test]
fn a_hole_in_the_grounds_view_is_not_judged_for_a_while() {
    // The radio down from 5 s to 8 s (the autopilot's numbers jump by
    // twelve): an event the ground alone elaborates 10 s later may come
    // from that silence, and is not judged; 30 s later it is.
    let (project, _) = crate::mirror::tests::example();
    let mut g = ground_of(&project);
    let texts = |t: Micros| {
        [18_150_000, 35_150_000]
            .contains(&t)
            .then(|| "Potential Thrust Loss (3)".to_owned())
    };
    operations(
        &mut g,
        40_000_000,
        |s| (20..32).contains(&s),
        &["engine_failure"],
        texts,
    );
    g.advance(Some(40_000_000), |_| None, same);
    let mut reported = Vec::new();
    while let Some((_, d)) = g.poll_disagreement() {
        reported.push(d.time);
    }
    assert_eq!(reported, [35_150_000]);
    assert_eq!(g.total().unjudged, 1);
    // Blind from the last frame before the hole (4.9 s) to 20 s after
    // the first after it (8.15 s).
    let (followed, blind) = g.blind(same)[0];
    assert_eq!((followed, blind), (39_750_000, 28_150_000 - 4_900_000));
}

#[test]
fn acknowledgements_to_the_onboard_gateway_alone_raise_no_alarm() {
    // The vehicle's `command_rejected` comes from a COMMAND_ACK the
    // autopilot sent the onboard gateway alone: the ground never sees it.
    let (project, _) = crate::mirror::tests::example();
    let mut g = ground_of(&project);
    operations(&mut g, 10_000_000, |_| false, &[], |_| None);
    let rejected = Event::new("command_rejected")
        .param("command", "MAV_CMD_IMAGE_START_CAPTURE")
        .param("result", "MAV_RESULT_UNSUPPORTED");
    g.vehicle_event(5_000_000, 5_000_000, None, &rejected);
    g.advance(Some(10_000_000), |_| None, same);
    assert!(g.poll_disagreement().is_none());
    assert_eq!(g.total().addressed, 1);
}

#[test]
fn a_frame_lost_between_two_batches_leaves_no_hole() {
    // ArduPlane SITL at 10x, read through TCP: the autopilot's 30 frames
    // of a second come in one batch. One lost at the end of a batch is a
    // second between the frames heard on either side, but one frame
    // missing: no hole in the ground's view, the check still judges.
    let (project, _) = crate::mirror::tests::example();
    let mut g = ground_of(&project);
    let mut seq = 0u8;
    for second in 0..20u64 {
        let t = 150_000 + second * 1_000_000;
        for _ in 0..30 {
            let bytes = plane_in_auto(seq);
            seq = seq.wrapping_add(1);
            if !seq.is_multiple_of(30) {
                for e in elaborate(&mut g, t, &bytes) {
                    g.vehicle_event(t, t, None, &e);
                }
            }
        }
        if second == 12 {
            elaborate(&mut g, t, &says(seq, "Potential Thrust Loss (3)"));
            seq = seq.wrapping_add(1);
        }
        g.advance(Some(t), |_| None, same);
    }
    g.advance(Some(20_000_000), |_| None, same);
    let (_, d) = g.poll_disagreement().expect("the engine failure");
    assert_eq!(
        (d.event.as_str(), d.seen_by),
        ("engine_failure", Side::Ground)
    );
    assert_eq!(g.blind(same)[0].1, 0);
}

/// The autopilot's ATTITUDE at its `time_boot_ms`.
fn attitude(seq: u8, boot_ms: u32) -> Vec<u8> {
    let header = MavHeader {
        system_id: 1,
        component_id: 1,
        sequence: seq,
    };
    let m = MavMessage::ATTITUDE(mavlink::dialects::ardupilotmega::ATTITUDE_DATA {
        time_boot_ms: boot_ms,
        ..Default::default()
    });
    elaboration::frame::serialize(header, MavlinkVersion::V2, &m)
}

/// A vehicle armed at 5.25 s (vehicle time) whose autopilot booted 100 s
/// before, heard by a ground that stamps its frames 3.3 s late from 3 s
/// on (a computer starved of CPU; its time base still says the vehicle's
/// time is its own); ATTITUDE (with `time_boot_ms`) between the
/// heartbeats when `clock`. The vehicle published `armed` (at its time,
/// with the autopilot's when `clock`) unless `missed`. The check's
/// disagreements and counts.
fn late_ground(clock: bool, missed: bool) -> (Vec<(Side, String)>, crate::mirror::check::Counts) {
    let (project, _) = crate::mirror::tests::example();
    let mut g = ground_of(&project);
    let mut armed_at = None;
    let mut seq = 0u8;
    for i in 0..60u32 {
        let vt = Micros::from(i) * 250_000;
        let gt = if vt >= 3_000_000 { vt + 3_300_000 } else { vt };
        let boot_ms = 100_000 + vt as u32 / 1000;
        let bytes = if i % 2 == 0 {
            if !clock {
                continue;
            }
            attitude(seq, boot_ms)
        } else {
            rover(1, seq, vt >= 5_000_000)
        };
        seq = seq.wrapping_add(1);
        let events = elaborate(&mut g, gt, &bytes);
        if events.iter().any(|e| e.name == "armed") && armed_at.is_none() {
            armed_at = Some(gt);
        }
        if vt == 5_250_000 && !missed {
            let boot = clock.then_some(Micros::from(boot_ms) * 1000);
            g.vehicle_event(gt, vt, boot, &Event::new("armed"));
        }
    }
    assert!(armed_at.is_some(), "the ground saw `armed`");
    // The replica holds every record through 15 s, where the vehicle had
    // read its autopilot's clock to 114.75 s.
    let vehicle_boot = |_| clock.then_some(114_750_000);
    g.advance(Some(15_000_000), vehicle_boot, same);
    let mut seen = Vec::new();
    while let Some((_, d)) = g.poll_disagreement() {
        seen.push((d.seen_by, d.event));
    }
    (seen, g.total())
}

#[test]
fn a_ground_that_stamps_its_frames_late_raises_no_disagreement_on_the_autopilots_clock() {
    // On the autopilot's clock: the same event, matched.
    let (seen, counts) = late_ground(true, false);
    assert_eq!(seen, [], "{counts:?}");
    assert_eq!(counts.matched, 1);
    assert!(counts.ground_late_max <= 250_000, "{counts:?}");
    // Without a message carrying `time_boot_ms`, on the receive times:
    // 3.3 s apart, reported both ways (what the check did before).
    let (seen, _) = late_ground(false, false);
    assert_eq!(
        seen,
        [
            (Side::Ground, "armed".to_owned()),
            (Side::Vehicle, "armed".to_owned())
        ]
    );
}

#[test]
fn a_real_miss_is_still_reported_on_the_autopilots_clock() {
    let (seen, counts) = late_ground(true, true);
    assert_eq!(seen, [(Side::Ground, "armed".to_owned())], "{counts:?}");
}

/// ArduPlane's EXTENDED_SYS_STATE.
fn extended_sys_state(
    seq: u8,
    landed: mavlink::dialects::ardupilotmega::MavLandedState,
) -> Vec<u8> {
    let header = MavHeader {
        system_id: 1,
        component_id: 1,
        sequence: seq,
    };
    let m =
        MavMessage::EXTENDED_SYS_STATE(mavlink::dialects::ardupilotmega::EXTENDED_SYS_STATE_DATA {
            landed_state: landed,
            ..Default::default()
        });
    elaboration::frame::serialize(header, MavlinkVersion::V2, &m)
}

#[test]
fn events_whose_every_rule_reads_a_message_the_ground_does_not_receive_are_unobservable() {
    use mavlink::dialects::ardupilotmega::MavLandedState;
    // The ground's port carries HEARTBEAT and ATTITUDE, never
    // EXTENDED_SYS_STATE: the vehicle's `landed` (from its landed_state,
    // or by HEARTBEAT where it is not streamed: `!seen(...)`) is not the
    // ground's to judge; its `armed` (HEARTBEAT) is.
    let (project, _) = crate::mirror::tests::example();
    let mut g = ground_of(&project);
    for i in 0..40u32 {
        let t = Micros::from(i) * 250_000;
        let bytes = if i % 2 == 0 {
            attitude(i as u8, 100_000 + t as u32 / 1000)
        } else {
            rover(1, i as u8, false)
        };
        elaborate(&mut g, t, &bytes);
    }
    g.vehicle_event(
        5_000_000,
        5_000_000,
        Some(105_000_000),
        &Event::new("landed"),
    );
    g.vehicle_event(
        5_000_000,
        5_000_000,
        Some(105_000_000),
        &Event::new("takeoff"),
    );
    g.vehicle_event(
        6_000_000,
        6_000_000,
        Some(106_000_000),
        &Event::new("armed"),
    );
    g.advance(Some(10_000_000), |_| Some(110_000_000), same);
    let (_, d) = g.poll_disagreement().expect("`armed`, heard by the ground");
    assert_eq!((d.event.as_str(), d.seen_by), ("armed", Side::Vehicle));
    assert!(g.poll_disagreement().is_none());
    let c = g.total();
    assert_eq!((c.unobservable, c.vehicle_only), (2, 1), "{c:?}");

    // Where the ground does receive EXTENDED_SYS_STATE, `landed` is
    // judged; once it stops coming (past QUIET), it no longer is.
    let mut g = ground_of(&project);
    for i in 0..40u32 {
        let t = Micros::from(i) * 250_000;
        let bytes = match i % 3 {
            0 => attitude(i as u8, 100_000 + t as u32 / 1000),
            1 => rover(1, i as u8, false),
            _ if t < 3_000_000 => {
                extended_sys_state(i as u8, MavLandedState::MAV_LANDED_STATE_ON_GROUND)
            }
            _ => rover(1, i as u8, false),
        };
        elaborate(&mut g, t, &bytes);
    }
    g.vehicle_event(
        4_000_000,
        4_000_000,
        Some(104_000_000),
        &Event::new("landed"),
    );
    g.vehicle_event(
        9_500_000,
        9_500_000,
        Some(109_500_000),
        &Event::new("landed"),
    );
    for i in 40..80u32 {
        let t = Micros::from(i) * 250_000;
        let bytes = if i % 2 == 0 {
            attitude(i as u8, 100_000 + t as u32 / 1000)
        } else {
            rover(1, i as u8, false)
        };
        elaborate(&mut g, t, &bytes);
    }
    g.advance(Some(20_000_000), |_| Some(120_000_000), same);
    let (_, d) = g.poll_disagreement().expect("the first `landed`");
    assert_eq!((d.event.as_str(), d.time), ("landed", 4_000_000));
    let mut more = Vec::new();
    while let Some((_, d)) = g.poll_disagreement() {
        more.push(d);
    }
    assert!(more.is_empty(), "{more:?}");
    assert_eq!(g.total().unobservable, 1);
}

/// The vehicle armed at 5 s; the ground's radio lost the heartbeats of 5
/// to 8 s (ATTITUDE at 4 Hz came through: no hole in its view) and heard
/// `armed` at 9 s only. The ground's late sighting is no disagreement
/// (CI's 30 % loss flight: `armed` 5 s after the vehicle), and with every
/// heartbeat heard a ground-only `armed` still is. With `camera`, the
/// camera's own HEARTBEAT (component 100) comes through every second,
/// half a second after the autopilot's.
fn heartbeats_lost(
    lost: bool,
    vehicle_armed: bool,
    camera: bool,
) -> (Vec<(Side, String)>, crate::mirror::check::Counts) {
    let (project, _) = crate::mirror::tests::example();
    let mut g = ground_of(&project);
    let mut seq = 0u8;
    for i in 0..60u32 {
        let t = Micros::from(i) * 250_000;
        let heartbeat = i % 4 == 0;
        let bytes = if heartbeat {
            rover(1, seq, t >= 5_000_000)
        } else {
            attitude(seq, 100_000 + t as u32 / 1000)
        };
        seq = seq.wrapping_add(1);
        if camera && i % 4 == 2 {
            let hb = self::heartbeat(1, 100, seq, false, MavAutopilot::MAV_AUTOPILOT_INVALID);
            elaborate(&mut g, t, &hb);
        }
        if heartbeat && lost && (5_000_000..9_000_000).contains(&t) {
            continue;
        }
        elaborate(&mut g, t, &bytes);
        if t == 5_000_000 && vehicle_armed {
            g.vehicle_event(t, t, Some(100_000_000 + t), &Event::new("armed"));
        }
    }
    g.advance(Some(15_000_000), |_| Some(114_750_000), same);
    let mut seen = Vec::new();
    while let Some((_, d)) = g.poll_disagreement() {
        seen.push((d.seen_by, d.event));
    }
    (seen, g.total())
}

#[test]
fn a_state_heard_late_after_its_stream_was_lost_is_no_disagreement() {
    for camera in [false, true] {
        // The camera's heartbeats do not hide the autopilot's silence (a
        // false disagreement in CI, 2026-12-07: the two streams were one).
        let (seen, counts) = heartbeats_lost(true, true, camera);
        assert_eq!(seen, [], "camera {camera}: {counts:?}");
        // A ground that heard every heartbeat and a vehicle that saw
        // nothing: reported.
        let (seen, counts) = heartbeats_lost(false, false, camera);
        assert_eq!(
            seen,
            [(Side::Ground, "armed".to_owned())],
            "camera {camera}: {counts:?}"
        );
    }
}

/// A sample is stale past two of its stream's periods and a second, or
/// when from before the onset of a condition held since and overdue: the
/// ground's ESC telemetry held 2 s while its frames were lost, beside a
/// fresh throttle, made an `engine_failure` the vehicle never had (CI's
/// real ArduPlane flights at 10 % loss); a heartbeat a second late is not.
#[test]
fn a_sample_is_stale_past_two_periods_and_a_second_or_overdue_since_the_onset() {
    let (project, _) = crate::mirror::tests::example();
    let mut g = ground_of(&project);
    let mut seq = 0u8;
    // ATTITUDE at 4 Hz through 10 s, heartbeats at 1 Hz through 6 s.
    for i in 0..40u32 {
        let t = Micros::from(i) * 250_000;
        let bytes = if i % 4 == 0 && t <= 6_000_000 {
            rover(1, seq, false)
        } else {
            attitude(seq, 100_000 + t as u32 / 1000)
        };
        seq = seq.wrapping_add(1);
        elaborate(&mut g, t, &bytes);
    }
    let w = &g.watches()[0];
    let (attitude_id, heartbeat_id) = (30, 0);
    // ATTITUDE's last at 9.75 s (every 0.25 s): fresh at 10 s, stale past
    // 10.75 s.
    assert!(!w.stale(attitude_id, 10_000_000, 10_000_000));
    assert!(!w.stale(attitude_id, 10_700_000, 10_700_000));
    assert!(w.stale(attitude_id, 10_800_000, 10_800_000));
    // The heartbeat's last at 6 s (every second): fresh through 8 s.
    assert!(!w.stale(heartbeat_id, 7_000_000, 7_000_000));
    assert!(!w.stale(heartbeat_id, 8_000_000, 8_000_000));
    assert!(w.stale(heartbeat_id, 8_100_000, 8_100_000));
    // A message never heard is not stale: it is not received
    // (`unobservable`).
    assert!(!w.stale(245, 10_000_000, 10_000_000));
    // A condition held since an onset after the heartbeat's last sample
    // (6 s), and one due since (every second): the condition rests on a
    // sample from before what started it (CI's real ArduPlane flight at
    // 10 % loss: ESC telemetry at 1 Hz from 0.1 s before a throttle step,
    // its next two frames lost, an `engine_failure` held its 2 s), stale
    // though younger than two periods.
    assert!(w.stale(heartbeat_id, 7_500_000, 6_050_000));
    // A sample at or after the onset confirms it; one not yet due is no
    // loss.
    assert!(!w.stale(heartbeat_id, 7_500_000, 5_900_000));
    assert!(!w.stale(heartbeat_id, 7_500_000, 6_000_000));
    assert!(!w.stale(heartbeat_id, 6_900_000, 6_500_000));
}

/// A plane's telemetry at 1 Hz through `until` (seconds): heartbeat,
/// throttle, ESC telemetry; armed with the throttle at 72 % from 10 s; the
/// ESC's rpm `rpm(second)`, its frame lost when `None`. Ticks every
/// 100 ms. The `engine_failure` events the ground elaborated, with
/// whether it judges each stale.
fn plane_throttle_step(rpm: impl Fn(u64) -> Option<f32>, until: u64) -> Vec<(Micros, bool)> {
    use mavlink::dialects::ardupilotmega::{ESC_TELEMETRY_1_TO_4_DATA, VFR_HUD_DATA};
    let (project, profile) = crate::mirror::tests::example();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-flight-test");
    let lanes = crate::team::lanes(
        &project,
        &dir,
        &profile,
        "ardupilot",
        &elaboration::Config::default(),
    )
    .expect("lanes");
    let mut g = Ground::new(lanes, WINDOW);
    let mut seq = 0u8;
    let mut frame = |m: MavMessage| {
        seq = seq.wrapping_add(1);
        let header = MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: seq,
        };
        elaboration::frame::serialize(header, MavlinkVersion::V2, &m)
    };
    let mut fired = Vec::new();
    let mut take = |g: &mut Ground| {
        for e in std::mem::take(&mut g.elaborated) {
            if e.event.name == "engine_failure" {
                fired.push((e.time_us, g.stale(&e)));
            }
        }
    };
    for tenth in 0..until * 10 {
        let now = tenth * 100_000;
        if tenth % 10 == 0 {
            let second = tenth / 10;
            let armed = second >= 10;
            let mut base_mode = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
            if armed {
                base_mode |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
            }
            let mut frames = vec![
                frame(MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                    custom_mode: 10,
                    mavtype: MavType::MAV_TYPE_FIXED_WING,
                    autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                    base_mode,
                    system_status: MavState::MAV_STATE_ACTIVE,
                    mavlink_version: 3,
                })),
                frame(MavMessage::VFR_HUD(VFR_HUD_DATA {
                    throttle: if armed { 72 } else { 0 },
                    ..Default::default()
                })),
            ];
            if let Some(r) = rpm(second) {
                frames.push(frame(MavMessage::ESC_TELEMETRY_1_TO_4(
                    ESC_TELEMETRY_1_TO_4_DATA {
                        rpm: [0, 0, r as u16, 0],
                        count: [0, 0, 50 * second as u16 + 1, 0],
                        ..Default::default()
                    },
                )));
            }
            for bytes in frames {
                let f = Frame::parse(&bytes).expect("a frame");
                g.heard(now, &f, same);
                g.elaborate(now, &f);
                take(&mut g);
            }
        }
        g.tick(now + 50_000);
        take(&mut g);
    }
    fired
}

/// The rule that fired is the one judged: the ESC rule's condition
/// resting on the ESC sample from before the throttle step (its next two
/// frames lost: CI's real ArduPlane flights at 10 % loss, on the takeoff
/// roll and on an approach) is stale, whatever the other rules producing
/// `engine_failure` read (the text rule reads no streamed state and was
/// never stale: the check judged every such event); a real failure, the
/// ESC saying 0 rpm every second, is judged.
#[test]
fn an_event_is_judged_stale_by_the_rule_that_fired_it() {
    let lost = plane_throttle_step(
        |s| match s {
            10 | 11 => None,
            s if s >= 12 => Some(7000.0),
            _ => Some(0.0),
        },
        14,
    );
    assert_eq!(lost.len(), 1, "{lost:?}");
    assert!(lost[0].1, "judged stale: {lost:?}");
    let real = plane_throttle_step(|_| Some(0.0), 14);
    assert_eq!(real.len(), 1, "{real:?}");
    assert!(!real[0].1, "judged: {real:?}");
}
