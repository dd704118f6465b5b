//! The ground mirror over a lossy radio, in simulated time: the flight-test
//! example flown by the onboard core with its downlink on, the ground
//! mirror's core (`petrel_core::mirror::station::Station`) hearing the
//! vehicle's telemetry and the downlink through a radio that loses frames
//! both ways, its requests going up through it (`simulated.rs`: no socket,
//! no wall clock). The replica must stay exact (every gap repaired, no
//! divergence, the last word an agreement, the digests equal at the end)
//! and the independent check must raise no false alarm, whatever the radio
//! lost; an autopilot's reboot that forgets the mirror's route is repaired
//! by the mirror's hail; a vehicle blind to an event is caught by the
//! check. The processes themselves (`petrel run --downlink`, `petrel
//! mirror`, the router and its wire, the signed downlink against a forger)
//! fly in `mirror.rs`.

use nets::Micros;
use petrel_core::mirror::check::{Disagreement, Side};
use petrel_core::mirror::record::{decode_packet, Record};
use petrel_core::mirror::replica::Report;
use petrel_core::mirror::station::Output;
use sitl_tests::SimState;

use crate::flight::project;
use crate::scratch::Scratch;
use crate::simulated::{fly_mirrored, fly_mirrored_profiled, Mirrored, Radio};

const MAX_SIM_S: f64 = 420.0;

fn over(s: &SimState) -> bool {
    (s.landed && !s.armed && !s.reached.is_empty()) || s.crashed
}

fn reports(m: &Mirrored) -> impl Iterator<Item = (Micros, &Report)> {
    m.outputs.iter().filter_map(|(t, o)| match o {
        Output::Report(r) => Some((*t, r)),
        _ => None,
    })
}

fn disagreements(m: &Mirrored) -> impl Iterator<Item = (Micros, &Disagreement)> {
    m.outputs.iter().filter_map(|(t, o)| match o {
        Output::Disagreement(d) => Some((*t, d)),
        _ => None,
    })
}

/// Flies `faults` through `radio` and checks the mirror stayed exact (each
/// agreement is the vehicle's digest at a step equal to the replica's) and
/// its independent check raised no false alarm.
fn lossy(name: &str, faults: &[&str], radio: Radio) -> Mirrored {
    let m = fly_mirrored(name, faults, radio, MAX_SIM_S, over);
    assert!(m.radio.lost > 0, "{name}: the radio lost nothing");
    exact(name, &m);
    let disagreements: Vec<_> = disagreements(&m).collect();
    assert!(
        disagreements.is_empty(),
        "{name}: false disagreements {disagreements:?}"
    );
    m
}

/// The flight ended landed and the mirror stayed exact to its end.
fn exact(name: &str, m: &Mirrored) {
    let s = &m.flown.state;
    let agreed = reports(m)
        .filter(|(_, r)| matches!(r, Report::Agreed { .. }))
        .count();
    let gaps = reports(m)
        .filter(|(_, r)| matches!(r, Report::Gap { .. }))
        .count();
    let resyncs = reports(m)
        .filter(|(_, r)| matches!(r, Report::Resynced { .. }))
        .count();
    eprintln!(
        "{name}: {:.0} s simulated in {:.1} s; the radio lost {} frames; {agreed} agreements, {gaps} gaps, {resyncs} resyncs",
        s.time_s,
        m.flown.wall.as_secs_f64(),
        m.radio.lost
    );
    assert!(
        s.landed && !s.armed && !s.crashed,
        "{name}: the flight did not end landed and disarmed (mode {}, t {:.0} s)",
        s.mode,
        s.time_s
    );
    let diverged: Vec<_> = reports(m)
        .filter(|(_, r)| matches!(r, Report::Diverged { .. }))
        .collect();
    assert!(
        diverged.is_empty(),
        "{name}: false divergences {diverged:?}"
    );
    // A heartbeat a second while the vehicle flew, and every record.
    assert!(
        agreed as f64 > s.time_s * 0.5,
        "{name}: only {agreed} checks agreed in {:.0} s",
        s.time_s
    );
    assert!(resyncs >= gaps, "{name}: {gaps} gaps, {resyncs} resyncs");
    let last = reports(m)
        .map(|(_, r)| r)
        .filter(|r| !matches!(r, Report::Step { .. } | Report::Timers { .. }))
        .last();
    assert!(
        matches!(last, Some(Report::Agreed { .. } | Report::Resynced { .. })),
        "{name}: the mirror ends with {last:?}"
    );
    // And it agreed lately: within the last two seconds of the flight.
    let end = (s.time_s * 1e6) as Micros;
    let last_agreed = reports(m)
        .filter(|(_, r)| matches!(r, Report::Agreed { .. }))
        .map(|(t, _)| t)
        .last()
        .unwrap_or(0);
    assert!(
        last_agreed + 2_000_000 >= end,
        "{name}: the last agreement at {last_agreed} µs, the flight ended at {end} µs"
    );
    let (code, err) = m.flown.replay_check();
    assert_eq!(
        code,
        Some(0),
        "{name}: the recording does not replay: {err}"
    );
}

#[test]
fn payload_failure_at_ten_percent_loss() {
    lossy(
        "payload-10",
        &["payload_failure@wp3"],
        Radio {
            per_mille: 100,
            seed: 10,
            ..Radio::default()
        },
    );
}

#[test]
fn engine_failure_at_one_percent_loss() {
    lossy(
        "engine-1",
        &["engine_failure@wp2"],
        Radio {
            per_mille: 10,
            seed: 1,
            ..Radio::default()
        },
    );
}

#[test]
fn link_loss_and_radio_bursts_of_thirty_and_fifty_seconds() {
    let m = lossy(
        "link-bursts",
        &["link_loss@wp3:10s"],
        Radio {
            per_mille: 20,
            seed: 7,
            bursts: vec![(40.0, 70.0), (100.0, 150.0)],
            ..Radio::default()
        },
    );
    let gaps = reports(&m)
        .filter(|(_, r)| matches!(r, Report::Gap { .. }))
        .count();
    assert!(gaps > 0, "the bursts opened no gap");
}

#[test]
fn low_battery_at_ten_percent_loss_and_a_burst() {
    lossy(
        "battery-10",
        &["battery=22@wp4"],
        Radio {
            per_mille: 100,
            seed: 22,
            bursts: vec![(80.0, 110.0)],
            ..Radio::default()
        },
    );
}

#[test]
fn a_third_of_the_frames_lost_at_random_over_the_nominal_mission() {
    let m = lossy(
        "nominal-30",
        &[],
        Radio {
            per_mille: 300,
            seed: 30,
            ..Radio::default()
        },
    );
    let gaps = reports(&m)
        .filter(|(_, r)| matches!(r, Report::Gap { .. }))
        .count();
    assert!(gaps > 0, "a third of the frames lost opened no gap");
}

#[test]
fn after_an_autopilot_reboot_the_mirror_is_heard_again_and_resyncs() {
    // The routes forgotten 60 s in, in flight: the records to the mirror
    // go nowhere until the mirror speaks.
    let m = fly_mirrored(
        "reboot",
        &[],
        Radio {
            forget_routes_at: Some(60.0),
            ..Radio::default()
        },
        MAX_SIM_S,
        over,
    );
    exact("reboot", &m);
    assert_eq!(disagreements(&m).count(), 0, "false disagreements");
    let forgot = m.forgot_at.expect("the routes were forgotten");
    // The mirror hailed the silent downlink: a heartbeat asked for.
    let hails = m
        .uplink
        .iter()
        .filter(|(t, bytes)| {
            *t >= forgot
                && decode_packet(bytes).is_ok_and(|records| {
                    records
                        .iter()
                        .any(|r| matches!(r, Record::SendHeartbeat { .. }))
                })
        })
        .count();
    assert!(hails >= 1, "the mirror never hailed the silent downlink");
    // The mirror heard the vehicle again soon: three silent seconds, the
    // hail, the next heartbeat (without the hail, the silence lasts to
    // the end of the flight).
    let agreed: Vec<Micros> = reports(&m)
        .filter(|(_, r)| matches!(r, Report::Agreed { .. }))
        .map(|(t, _)| t)
        .collect();
    let silence = agreed.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(0);
    assert!(
        silence < 10_000_000,
        "the mirror heard nothing for {} s",
        silence as f64 / 1e6
    );
    // And it agreed with the vehicle to the end (the flight lasts well
    // over 60 s after the reboot).
    let last = agreed.last().copied().expect("agreements");
    assert!(
        last > forgot + 60_000_000,
        "the last agreement at {last} µs, the routes forgotten at {forgot} µs"
    );
    eprintln!(
        "reboot: routes forgotten at {:.0} s, {hails} hails, the longest silence {:.1} s",
        forgot as f64 / 1e6,
        silence as f64 / 1e6
    );
}

#[test]
fn a_vehicle_that_misses_engine_failure_is_caught_by_the_independent_check() {
    // The onboard profile altered: the project's layer with every rule of
    // `engine_failure` removed (`enabled = false`). The ground elaborates
    // with the project's own.
    let dir = Scratch::new("simulated-blind-profile");
    let layer =
        std::fs::read_to_string(project().join("profile.toml")).expect("the project's profile");
    let mut altered = String::new();
    let mut removed = 0;
    for line in layer.lines() {
        altered.push_str(line);
        altered.push('\n');
        if line.starts_with("[rules.engine_failure") {
            altered.push_str("enabled = false\n");
            removed += 1;
        }
    }
    assert_eq!(
        removed, 4,
        "the four engine_failure rules of the project's layer"
    );
    let file = dir.join("blind.toml");
    std::fs::write(&file, altered).expect("the altered profile");
    let m = fly_mirrored_profiled(
        "engine-blind",
        &["engine_failure@wp2"],
        Radio::default(),
        MAX_SIM_S,
        over,
        &file.to_string_lossy(),
    );
    // The vehicle never heard it...
    assert!(
        !m.flown
            .timeline
            .iter()
            .any(|l| l["input"] == "event" && l["event"] == "engine_failure"),
        "the altered vehicle still elaborated engine_failure"
    );
    // ...the ground says so, with its evidence.
    let found: Vec<_> = disagreements(&m).collect();
    let (reported, d) = found
        .iter()
        .find(|(_, d)| d.event == "engine_failure" && d.seen_by == Side::Ground)
        .unwrap_or_else(|| panic!("no disagreement on engine_failure: {found:?}"));
    assert!(!d.params.is_empty(), "{d:?}");
    // From the frame or tick that completed the ground's rule to the
    // report: the vehicle's window (1 s), then the heartbeat the mirror
    // asked for at its end; the issue asks for less than 2 s.
    let late = reported - d.time;
    eprintln!(
        "engine_failure seen by the ground at {:.2} s, the disagreement reported {:.2} s later (the vehicle's window {:.1} s)",
        d.time as f64 / 1e6,
        late as f64 / 1e6,
        d.window as f64 / 1e6
    );
    assert!(late < 2_000_000, "{d:?}");
    // And the replica still agrees with the (wrong) vehicle.
    let diverged = reports(&m)
        .filter(|(_, r)| matches!(r, Report::Diverged { .. }))
        .count();
    assert_eq!(diverged, 0, "the replica diverged");
}
