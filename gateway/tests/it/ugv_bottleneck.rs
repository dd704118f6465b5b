//! examples/ugv-bottleneck end to end: two simulated rovers on one UDP
//! link (sitl-tests' `Fleet`, in this process), PLN (pln.py, started by
//! the gateway from project.toml's `run`) and the real `petrel run`,
//! asserting on the simulated positions, not only on the marking.
//!
//! One `petrel run` supervises both rovers (a team project: events tagged
//! `@R1`/`@R2`, commands routed by system id, `"vehicle"` in PLN's calls).
//! They need python3 (PLN), which every machine running the tests has.

use crate::flight;
use crate::scratch;
use crate::ugv_team as team;

use std::time::{Duration, Instant};

use flight::Running;
use scratch::Scratch;
use sitl_tests::Fault;
use team::{at, in_bottleneck, near, project, state, Team};

#[test]
fn both_rovers_cross_in_turn_and_reach_their_goals() {
    let mut team = Team::start("ugv-nominal", &[]);
    let done = team.run_until(Duration::from_secs(60), |all| {
        near(state(all, 1), 55.0, -20.0)
            && near(state(all, 2), 5.0, 20.0)
            && all.iter().all(|(_, s)| s.mode == "HOLD")
    });
    let seen = std::mem::take(&mut team.seen);
    let (out, err, _recording) = team.stop();
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
    let (out, err, _recording) = team.stop();
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
    let (out, err, _recording) = team.stop();
    assert!(held, "not both holding\n{out}\n{err}");
    let last = seen.last().expect("snapshots");
    assert!(!state(last, 1).engine_running);
    assert!(state(last, 2).engine_running || state(last, 2).groundspeed == 0.0);
    // The lockout began on R1's motor failure.
    assert!(out.contains("engine_failure@R1"), "{out}");
}

/// `petrel demo --example ugv-bottleneck`: its exit code, stdout (the live
/// log and the summary), stderr and its folder (the recording `demo.mcap`);
/// stopped after `wall` if it has not ended by then.
fn demo(name: &str, args: &[&str], wall: Duration) -> (Option<i32>, String, String, Scratch) {
    demo_read(name, args, wall, true)
}

/// [`demo`], its stdout read (`true`) or closed at once (`| head`).
fn demo_read(
    name: &str,
    args: &[&str],
    wall: Duration,
    read: bool,
) -> (Option<i32>, String, String, Scratch) {
    let _turn = team::turn();
    let dir = Scratch::new(name);
    let record = dir.join("demo.mcap");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_petrel"))
        .args([
            "demo",
            "--example",
            "ugv-bottleneck",
            "--no-http",
            "--record",
        ])
        .arg(&record)
        .args(args)
        .current_dir(&dir)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("petrel demo starts");
    if !read {
        drop(child.stdout.take());
    }
    let mut running = Running::new(child);
    let end = Instant::now() + wall;
    while !running.exited() && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(50));
    }
    let (out, err, code) = running.stop();
    (code, out, err, dir)
}

/// The demo's recording replays and agrees with what it recorded.
fn assert_replays(dir: &Scratch) {
    let replay = std::process::Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("replay")
        .arg(dir.join("demo.mcap"))
        .arg(project())
        .arg("--check-against")
        .output()
        .expect("petrel replay runs");
    assert!(
        replay.status.success(),
        "{}",
        String::from_utf8_lossy(&replay.stderr)
    );
}

#[test]
fn the_demo_drives_the_blocked_scenario_and_its_recording_replays() {
    let (code, out, err, dir) = demo(
        "ugv-demo-blocked",
        &["--scenario", "blocked", "--speed", "10", "--timeout", "100"],
        Duration::from_secs(120),
    );
    assert_eq!(code, Some(0), "{out}\n{err}");
    // The first rover in was stuck there; both reached their goals in the
    // end, never both in the bottleneck (the demo watched the positions).
    assert!(out.contains("was stuck in the bottleneck"), "{out}");
    for r in ["R1", "R2"] {
        assert!(out.contains(&format!("{r}: at its goal")), "{out}");
    }
    assert!(out.contains(", 0 with both inside"), "{out}");
    // SYNC asked PLN to replan, and the other rover was sent round.
    assert!(out.contains("PLN.replan"), "{out}");
    assert!(out.contains("PLN.detour"), "{out}");
    assert_replays(&dir);
}

/// The motor-failure scenario, ten times real time.
const MOTOR_FAILURE: &[&str] = &[
    "--scenario",
    "motor-failure",
    "--speed",
    "10",
    "--timeout",
    "60",
];

#[test]
fn the_demo_s_motor_failure_locks_out_that_rover_alone() {
    let (code, out, err, _) = demo("ugv-demo-motor", MOTOR_FAILURE, Duration::from_secs(80));
    assert_eq!(code, Some(0), "{out}\n{err}");
    assert!(out.contains("locked out at the end: R1\n"), "{out}");
    assert!(out.contains("engine_failure@R1"), "{out}");
}

#[test]
fn the_demo_flies_on_when_its_reader_stops_reading() {
    // `petrel demo | head`: the live log's reader is gone at once. The demo
    // neither panics nor stops mid-drive: it finishes, says so on exit 0,
    // and its recording is whole.
    let (code, _, err, dir) = demo_read(
        "ugv-demo-head",
        MOTOR_FAILURE,
        Duration::from_secs(80),
        false,
    );
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(code, Some(0), "{err}");
    assert_replays(&dir);
}

#[test]
fn the_demo_refuses_a_scenario_of_the_other_example() {
    let (code, out, err, _) = demo(
        "ugv-demo-payload",
        &["--scenario", "payload"],
        Duration::from_secs(20),
    );
    assert_eq!(code, Some(2), "{out}\n{err}");
    assert!(
        err.contains("ugv-bottleneck has no scenario payload; its scenarios: blocked, nominal, motor-failure"),
        "{err}"
    );
}
