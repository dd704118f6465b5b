//! The ground mirror over a lossy radio, in simulated time: the flight-test
//! example flown by the onboard core with its downlink on, the ground
//! mirror's core (`petrel_core::mirror::station::Station`) hearing the
//! vehicle's telemetry and the downlink through a radio that loses frames
//! both ways, its requests going up through it (`simulated.rs`: no socket,
//! no wall clock). The replica must stay exact (every gap repaired, no
//! divergence, the last word an agreement, the digests equal at the end)
//! and the independent check must raise no false alarm, whatever the radio
//! lost. The processes themselves (`petrel run --downlink`, `petrel
//! mirror`, the router and its wire) fly in `mirror.rs`.

use nets::Micros;
use petrel_core::mirror::replica::Report;
use petrel_core::mirror::station::Output;
use sitl_tests::SimState;

use crate::simulated::{fly_mirrored, Mirrored, Radio};

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

/// Flies `faults` through `radio` and checks the mirror stayed exact (each
/// agreement is the vehicle's digest at a step equal to the replica's).
fn lossy(name: &str, faults: &[&str], radio: Radio) -> Mirrored {
    let m = fly_mirrored(name, faults, radio, MAX_SIM_S, over);
    let s = &m.flown.state;
    let agreed = reports(&m)
        .filter(|(_, r)| matches!(r, Report::Agreed { .. }))
        .count();
    let gaps = reports(&m)
        .filter(|(_, r)| matches!(r, Report::Gap { .. }))
        .count();
    let resyncs = reports(&m)
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
    assert!(m.radio.lost > 0, "{name}: the radio lost nothing");
    let diverged: Vec<_> = reports(&m)
        .filter(|(_, r)| matches!(r, Report::Diverged { .. }))
        .collect();
    assert!(
        diverged.is_empty(),
        "{name}: false divergences {diverged:?}"
    );
    let disagreements: Vec<_> = m
        .outputs
        .iter()
        .filter(|(_, o)| matches!(o, Output::Disagreement(_)))
        .collect();
    assert!(
        disagreements.is_empty(),
        "{name}: false disagreements {disagreements:?}"
    );
    // A heartbeat a second while the vehicle flew, and every record.
    assert!(
        agreed as f64 > s.time_s * 0.5,
        "{name}: only {agreed} checks agreed in {:.0} s",
        s.time_s
    );
    assert!(resyncs >= gaps, "{name}: {gaps} gaps, {resyncs} resyncs");
    let last = reports(&m)
        .map(|(_, r)| r)
        .filter(|r| !matches!(r, Report::Step { .. } | Report::Timers { .. }))
        .last();
    assert!(
        matches!(last, Some(Report::Agreed { .. } | Report::Resynced { .. })),
        "{name}: the mirror ends with {last:?}"
    );
    // And it agreed lately: within the last two seconds of the flight.
    let end = (s.time_s * 1e6) as Micros;
    let last_agreed = reports(&m)
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
    m
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
