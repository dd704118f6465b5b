//! The live monitor on a team (docs/monitor.md, "A team"): `petrel run
//! --http` on examples/ugv-bottleneck with its two simulated rovers (the
//! harness of tests/ugv_bottleneck.rs, `ugv/team.rs`), the page in Debian's
//! chromium (`monitor/driver.js team`). The page must show one group per
//! rover, holding that rover's nets, and the team's group with SYNC; two
//! markers on the one map, each its colour and label, that move. Then the
//! test fails R1's motor: R1's group shows the catastrophic lockout, R2's
//! does not.
//!
//! Skipped without chromium, node or playwright-core (tests/monitor.rs),
//! failed so under `CI=true`. Screenshots go to `target/tmp/monitor/`.

use crate::browser;
use crate::flight;
use crate::scratch;
use crate::ugv_team as team;

use std::time::{Duration, Instant};

use serde_json::Value as Json;
use sitl_tests::Fault;

use browser::{assert_readable, drive_script, require, strings};
use scratch::Scratch;
use team::Team;

#[test]
fn each_rover_its_group_and_marker_and_a_motor_failure_locks_out_its_rover_only() {
    let Some(tools) = require() else { return };
    let shots = browser::shots();
    let shots = shots.to_string_lossy().to_string();
    let signals = Scratch::new("monitor-team-signals");
    let address = format!("127.0.0.1:{}", flight::free_port());
    // At 4× (not the ugv tests' 10×) the rovers drive for half a minute:
    // a browser starting on a loaded machine still sees them move.
    let mut team = Team::start_at("monitor-team", &[], &["--http", &address], 4.0);
    let url = format!("http://{address}/");
    let signals_s = signals.path().to_string_lossy().to_string();
    let (seen, failed) = std::thread::scope(|s| {
        let page = s.spawn(|| {
            drive_script(
                &tools,
                "gateway/tests/monitor/driver.js",
                &["team", &url, &shots],
                &[("MONITOR_SIGNALS", &signals_s)],
                Duration::from_secs(300),
            )
        });
        // The rovers moving on the page: R1's motor fails.
        let until = Instant::now() + Duration::from_secs(240);
        let moved = signals.path().join("moved");
        while !moved.exists() && !page.is_finished() && Instant::now() < until {
            std::thread::sleep(Duration::from_millis(50));
        }
        let failed = moved.exists() && team.fleet.inject(1, Fault::EngineFailure);
        let seen = page.join();
        (seen, failed)
    });
    let exited = team.exited();
    let (out, err, _recording) = team.stop();
    let seen = seen.unwrap_or_else(|_| panic!("the driver failed\n{out}\n{err}"));
    assert!(!exited, "petrel run ended early\n{err}");
    assert!(failed, "R1's motor was not failed: {seen}");

    // One group per rover with its three nets, then the team's with SYNC.
    let groups = seen["groups"].as_array().cloned().unwrap_or_default();
    let vehicles: Vec<&Json> = groups.iter().map(|g| &g["vehicle"]).collect();
    assert_eq!(
        vehicles,
        [&Json::from("R1"), &Json::from("R2"), &Json::Null],
        "{seen}"
    );
    for (g, r) in groups.iter().zip(["R1", "R2"]) {
        let mut nets = strings(&g["nets"]);
        nets.sort();
        assert_eq!(
            nets,
            [
                format!("CORRIDOR@{r}"),
                format!("ROUTE@{r}"),
                format!("SAFETY@{r}")
            ],
            "{g}"
        );
        let system = if r == "R1" { "system 1" } else { "system 2" };
        assert!(
            g["head"].as_str().is_some_and(|h| h.contains(system)),
            "{g}"
        );
    }
    assert_eq!(strings(&groups[2]["nets"]), ["SYNC"]);
    assert_readable(&seen);
    assert_eq!(
        seen["strip_hidden"], true,
        "a team's strips are its groups'"
    );

    // Two markers, each its vehicle's colour and label, both moved.
    let first = seen["markers_first"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let moved = seen["markers_moved"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    assert_eq!(first.len(), 2, "{first:?}");
    assert_eq!(moved.len(), 2, "{moved:?}");
    let labels: Vec<&Json> = moved.iter().map(|m| &m["label"]).collect();
    assert_eq!(labels, [&Json::from("R1"), &Json::from("R2")]);
    assert_ne!(moved[0]["fill"], moved[1]["fill"], "one colour per vehicle");
    for a in &first {
        let b = moved
            .iter()
            .find(|m| m["vehicle"] == a["vehicle"])
            .unwrap_or_else(|| panic!("{a} gone"));
        let d = (b["lat"].as_f64().unwrap_or(0.0) - a["lat"].as_f64().unwrap_or(0.0)).abs()
            + (b["lon"].as_f64().unwrap_or(0.0) - a["lon"].as_f64().unwrap_or(0.0)).abs();
        assert!(d > 2e-5, "{} did not move: {a} then {b}", a["vehicle"]);
    }
    // Each marker its vehicle's track, in its colour.
    let tracks = seen["tracks"].as_array().cloned().unwrap_or_default();
    for m in &moved {
        assert!(
            tracks
                .iter()
                .any(|t| t["vehicle"] == m["vehicle"] && t["stroke"] == m["fill"]),
            "no track for {m}: {tracks:?}"
        );
    }

    // R1's motor failure: R1 locked out, R2 not; the team's nets follow
    // the team's lockout (none).
    let locked = seen["locked"].as_array().cloned().unwrap_or_default();
    let state: Vec<(Json, Json, Json)> = locked
        .iter()
        .map(|g| {
            (
                g["vehicle"].clone(),
                g["locked"].clone(),
                g["badge"].clone(),
            )
        })
        .collect();
    assert_eq!(
        state,
        [
            ("R1".into(), true.into(), true.into()),
            ("R2".into(), false.into(), false.into()),
            (Json::Null, false.into(), false.into()),
        ],
        "{seen}"
    );
    assert!(
        locked[0]["events"]
            .as_str()
            .is_some_and(|e| e.contains("engine_failure@R1")),
        "R1's last events: {}",
        locked[0]["events"]
    );
    assert!(
        seen["banner"]["text"]
            .as_str()
            .is_some_and(|t| t.contains("@R1") && !t.contains("R2")),
        "{}",
        seen["banner"]
    );
}
