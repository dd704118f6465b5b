//! The ground mirror following a team end to end: examples/ugv-bottleneck's
//! two simulated rovers (sitl-tests' `Fleet`, systems 1 and 2, one link)
//! behind the mirror tests' router, the real `petrel run --downlink`
//! supervising both on the companion's port (PLN started by it), the real
//! `petrel mirror` on the ground's. The replica — one player holding both
//! vehicles' instances and the team nets — agrees with the vehicle at
//! every record and heartbeat, its firings are the vehicle's, and the
//! independent check, done per vehicle in each vehicle's lane, matches
//! each vehicle's events with nothing seen on one side only.

use crate::flight;
use crate::process;
use crate::router;
use crate::scratch;
use crate::ugv_team as team;
use crate::wire;

use std::time::Duration;

use flight::{timeline, Running};
use process::petrel_mirror;
use router::{Loss, Router};
use scratch::Scratch;
use team::{near, project, state, Team};
use wire::{fired, only_resync_requests, the_recording_of_checks_out};

/// Simulated seconds per wall second: a quarter of ugv_bottleneck.rs's
/// pace, so that three processes and the simulator keep their time stamps
/// on a busy two-core machine: the check compares receive times, and a
/// 0.3 s stall of `run` is 1.5 s of vehicle time at 5×, past the window
/// (seen at a load average of 9.6; docs/mirror.md "Timing under load").
const SPEED: f64 = 2.5;

#[test]
fn the_mirror_follows_both_rovers_through_the_bottleneck() {
    let dir = Scratch::new("mirror-team");
    let fleet = team::fleet_at("tcpin", &[], SPEED);
    let mut router = Router::start(fleet.local_addr(), Loss::default());
    let recording = dir.join("mirror.mcap");
    let mirror = Running::new(petrel_mirror(
        &project(),
        &format!("tcpout:127.0.0.1:{}", router.ground_port),
        &recording,
        SPEED,
        Duration::from_secs(300),
        &[],
    ));
    let mut team = Team::run_at(
        "mirror-team-run",
        fleet,
        &format!("tcpout:127.0.0.1:{}", router.companion_port),
        // `petrel check` is ugv_bottleneck's and the verifier's business.
        &["--downlink", "--unchecked"],
        SPEED,
    );
    let done = team.run_until(Duration::from_secs(200), |all| {
        near(state(all, 1), 55.0, -20.0)
            && near(state(all, 2), 5.0, 20.0)
            && all.iter().all(|(_, s)| s.mode == "HOLD")
    });
    // Five simulated seconds more: the last heartbeats reach the mirror.
    std::thread::sleep(Duration::from_secs(2));
    let (run_out, run_err, _recording) = team.stop();
    std::thread::sleep(Duration::from_millis(500));
    let (mirror_out, mirror_err, _) = mirror.stop();
    router.stop();
    let traffic = std::mem::take(&mut *router.traffic());
    let _ = std::fs::write(dir.join("run.jsonl"), &run_out);
    let _ = std::fs::write(dir.join("mirror.jsonl"), &mirror_out);
    let _ = std::fs::write(dir.join("mirror.err"), &mirror_err);
    assert!(done, "not both at their goals\n{run_err}");
    let run = timeline(&run_out);
    let mirror = timeline(&mirror_out);
    let lines = |kind: &str| -> Vec<&serde_json::Value> {
        mirror.iter().filter(|l| l["mirror"] == kind).collect()
    };
    // The replica agrees with the vehicle: no divergence, checked every
    // second the gateway ran.
    assert!(
        lines("mirror_diverged").is_empty(),
        "{:?}\n{mirror_err}",
        lines("mirror_diverged")
    );
    let agreed = lines("agreed").len();
    assert!(agreed > 20, "only {agreed} checks agreed\n{mirror_err}");
    // Its firings are the vehicle's: both robots' instances (SYNC, the
    // team net, fires on a failure only).
    let vehicle = fired(&run);
    let replica = fired(&mirror);
    for net in ["@R1", "@R2"] {
        assert!(
            replica.iter().any(|f| f.contains(net)),
            "the replica never fired {net}: {replica:#?}"
        );
    }
    assert!(
        vehicle.ends_with(&replica),
        "the replica's firings are not the vehicle's:\nvehicle {vehicle:#?}\nreplica {replica:#?}"
    );
    // The independent check, per vehicle: each rover's events matched,
    // none on one side only.
    assert!(
        lines("mirror_disagreement").is_empty(),
        "{:#?}\n{mirror_err}",
        lines("mirror_disagreement")
    );
    let summary = mirror
        .iter()
        .find(|l| l["summary"] == "mirror")
        .expect("the mirror's closing summary");
    let vehicles = summary["vehicles"].as_array().expect("vehicles");
    let names: Vec<_> = vehicles
        .iter()
        .map(|v| (v["vehicle"].as_str(), v["system"].as_u64()))
        .collect();
    assert_eq!(names, [(Some("R1"), Some(1)), (Some("R2"), Some(2))]);
    for v in vehicles {
        assert!(v["heard"] == true, "{v}");
        assert!(v["frames"].as_u64().unwrap_or(0) > 500, "{v}");
        assert!(v["matched"].as_u64().unwrap_or(0) >= 5, "{v}");
        assert_eq!(v["ground_only"], 0, "{v}");
        assert_eq!(v["vehicle_only"], 0, "{v}");
        // A clean link: nothing excused as lost.
        assert_eq!(v["unjudged"], 0, "{v}");
    }
    // The vehicles' events reached the timeline qualified.
    for r in ["R1", "R2"] {
        assert!(
            mirror.iter().any(|l| l["event"]
                .as_str()
                .is_some_and(|e| e.ends_with(&format!("@{r}")))),
            "no event of {r} in the mirror's timeline"
        );
    }
    // The mirror only ever asked the onboard gateway (R1's companion).
    only_resync_requests(&traffic.from_ground);
    the_recording_of_checks_out("mirror_team", &recording, &project(), &mirror_err);
}
