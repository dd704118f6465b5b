//! The ground mirror's per-frame path for a team of N vehicles: each frame
//! routed to its vehicle's lane, elaborated there, counted and watched for
//! losses, and the events checked against the vehicle's (the independent
//! check) — `mirror::ground::Ground`, the code `petrel mirror` runs on
//! every telemetry frame, called through the gateway's library.
//!
//! Each iteration is one second of the team's telemetry: N vehicles × 50
//! messages (`support/telemetry.rs`: HEARTBEAT, ATTITUDE,
//! GLOBAL_POSITION_INT, VFR_HUD, GPS_RAW_INT, SYS_STATUS,
//! EKF_STATUS_REPORT, SYSTEM_TIME, BATTERY_STATUS, each vehicle its own
//! system id and sequence), interleaved in time, with the ground's ticks
//! every 100 ms; the vehicle's published events are the ground's own (as a
//! vehicle elaborating the same frames publishes them), so every event is
//! matched. Divan's items/s is frames per second of CPU on one core:
//! `N = 1 s / (50 × cost per frame)` vehicles. N = 1 is the single-vehicle
//! cost in the same run.
//!
//! Run: `cargo bench -p gateway --bench mirror_ground` (idle), and with the
//! other core busy: `stress-ng --cpu 1 & cargo bench ...`.

// Its `tlog` is for the other benches.
#[allow(dead_code)]
#[path = "support/telemetry.rs"]
mod telemetry;

use elaboration::{Config, Frame};
use petrel_core::mirror::check::WINDOW;
use petrel_core::mirror::ground::Ground;
use petrel_core::supervisor::Lane;

fn main() {
    divan::main();
}

const TEAMS: &[usize] = &[1, 10, 50, 100, 200];

/// A team of `n` vehicles (systems 1..=n) as `team::lanes` builds it, on
/// ArduPilot's built-in profile.
fn lanes(n: usize) -> Vec<Lane> {
    let profile = elaboration::Profile::builtin("ardupilot").expect("the built-in profile");
    if n == 1 {
        return vec![Lane {
            vehicle: None,
            profile,
            config: Config::default(),
        }];
    }
    (1..=n)
        .map(|i| Lane {
            vehicle: Some(format!("R{i}")),
            profile: profile.clone(),
            config: Config {
                sysid: Some(i as u8),
                compid: Some(1),
                ..Config::default()
            },
        })
        .collect()
}

/// Second `s` of the team's telemetry, interleaved in time.
fn second(n: usize, s: u64, seqs: &mut [u8]) -> Vec<(u64, Vec<u8>)> {
    let mut frames: Vec<(u64, Vec<u8>)> = (0..n)
        .flat_map(|i| {
            // Each vehicle's second shifted by a little, as radios interleave.
            telemetry::second_of(i as u8 + 1, s, &mut seqs[i])
                .into_iter()
                .map(move |(t, b)| (t + i as u64 * 37, b))
        })
        .collect();
    frames.sort_by_key(|(t, _)| *t);
    frames
}

/// One second of frames through the ground path.
fn play(ground: &mut Ground, frames: &[(u64, Vec<u8>)], events: &mut Vec<nets::Event>) {
    let same = Some;
    let mut next_tick = frames.first().map_or(0, |(t, _)| *t / 100_000 * 100_000);
    for (t, bytes) in frames {
        while next_tick <= *t {
            ground.tick(next_tick);
            next_tick += 100_000;
        }
        let Ok(frame) = Frame::parse(bytes) else {
            continue;
        };
        ground.heard(*t, &frame, same);
        ground.elaborate(*t, &frame);
        ground.drain(same, |e| events.push(e.clone()));
        for e in events.drain(..) {
            ground.vehicle_event(*t, *t, None, &e);
        }
        ground.advance(Some(*t), |_| None, same);
        while ground.poll_disagreement().is_some() {}
    }
}

#[divan::bench(args = TEAMS, sample_count = 20, sample_size = 1)]
fn one_second_of_the_team(bencher: divan::Bencher, n: usize) {
    let mut ground = Ground::new(lanes(n), WINDOW);
    let mut seqs = vec![0u8; n];
    let mut events = Vec::new();
    // Two seconds first: every vehicle heard, its lanes warm.
    for s in 0..2 {
        play(&mut ground, &second(n, s, &mut seqs), &mut events);
    }
    let mut s = 2;
    bencher
        .counter(divan::counter::ItemsCount::new(n * 50))
        .with_inputs(|| {
            s += 1;
            second(n, s, &mut seqs)
        })
        .bench_local_refs(|frames| play(&mut ground, frames, &mut events));
}
