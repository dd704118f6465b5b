//! examples/ugv-bottleneck end to end: two simulated rovers on one UDP
//! link (sitl-tests' `Fleet`, in this process), PLN (pln.py, started by
//! the gateway from project.toml's `run`) and the real `petrel run`,
//! asserting on the simulated positions, not only on the marking.
//!
//! One `petrel run` supervises both rovers (a team project: events tagged
//! `@R1`/`@R2`, commands routed by system id, `"vehicle"` in PLN's calls).
//! They need python3 (PLN), which every machine running the tests has.

#[path = "scenarios/flight.rs"]
mod flight;

#[path = "ugv/team.rs"]
mod team;

use std::time::Duration;

use sitl_tests::Fault;
use team::{at, in_bottleneck, near, state, Team};

/// The shared flight module's DEC reads this (not used here: PLN is
/// started by the gateway).
pub const MISSION_FILE: &str = "mission.toml";

#[test]
fn both_rovers_cross_in_turn_and_reach_their_goals() {
    let mut team = Team::start("ugv-nominal", &[]);
    let done = team.run_until(Duration::from_secs(60), |all| {
        near(state(all, 1), 55.0, -20.0)
            && near(state(all, 2), 5.0, 20.0)
            && all.iter().all(|(_, s)| s.mode == "HOLD")
    });
    let seen = std::mem::take(&mut team.seen);
    let (out, err) = team.stop();
    assert!(done, "not both at their goals\n{out}\n{err}");
    // Each went through the bottleneck, one after the other.
    for sys in [1u8, 2] {
        assert!(
            seen.iter().any(|all| in_bottleneck(state(all, sys))),
            "rover {sys} never in the bottleneck"
        );
    }
}

#[test]
fn a_rover_stuck_in_the_bottleneck_makes_the_other_go_round() {
    // The first rover into the bottleneck (whichever reaches its gate
    // first) stays stuck there.
    let mut team = Team::start("ugv-stuck", &[]);
    let entered = team.run_until(Duration::from_secs(30), |all| {
        in_bottleneck(state(all, 1)) || in_bottleneck(state(all, 2))
    });
    assert!(entered, "no rover entered the bottleneck");
    let all = team.fleet.states();
    let stuck: u8 = if in_bottleneck(state(&all, 1)) { 1 } else { 2 };
    let other: u8 = 3 - stuck;
    assert!(team.fleet.inject(stuck, Fault::Stuck));
    let stuck_at = at(state(&team.fleet.states(), stuck));
    // The other waits at its gate, then PLN sends it round by its ring (R1
    // west, east = -30; R2 east, east = 30: pln.py's DETOURS) to its goal.
    let (goal, ring_side) = if other == 2 {
        ((5.0, 20.0), 1.0)
    } else {
        ((55.0, -20.0), -1.0)
    };
    let done = team.run_until(Duration::from_secs(60), |all| {
        near(state(all, other), goal.0, goal.1) && state(all, other).mode == "HOLD"
    });
    let seen = std::mem::take(&mut team.seen);
    let (out, err) = team.stop();
    assert!(done, "R{other} did not finish\n{out}\n{err}");
    assert!(
        // Snapshots are too sparse to catch the ring's corner itself.
        seen.iter()
            .any(|all| at(state(all, other)).1 * ring_side > 25.0),
        "R{other} did not take its ring"
    );
    // The other never entered the bottleneck after the stuck one did.
    let first_inside = seen
        .iter()
        .position(|all| in_bottleneck(state(all, stuck)))
        .expect("the stuck rover inside");
    assert!(
        !seen[first_inside..]
            .iter()
            .any(|all| in_bottleneck(state(all, other))),
        "R{other} entered the bottleneck"
    );
    // The stuck rover never moved again.
    let last = seen.last().expect("snapshots");
    let (n, e) = at(state(last, stuck));
    assert!((n - stuck_at.0).hypot(e - stuck_at.1) < 0.5);
    assert!(
        out.contains("SYNC") && out.contains(&format!("r{stuck}_detour")),
        "{out}"
    );
}

#[test]
fn a_motor_failure_is_catastrophic_and_the_team_holds() {
    let mut team = Team::start("ugv-motor", &[(1, "engine_failure@12s")]);
    let held = team.run_until(Duration::from_secs(30), |all| {
        all.iter().all(|(_, s)| s.mode == "HOLD") && state(all, 1).time_s > 14.0
    });
    let seen = std::mem::take(&mut team.seen);
    let (out, err) = team.stop();
    assert!(held, "not both holding\n{out}\n{err}");
    let last = seen.last().expect("snapshots");
    assert!(!state(last, 1).engine_running);
    assert!(state(last, 2).engine_running || state(last, 2).groundspeed == 0.0);
    // The lockout began on R1's motor failure.
    assert!(out.contains("engine_failure@R1"), "{out}");
}
