//! The gateway's integration tests that need no real firmware (ArduPilot,
//! PX4 SITL) and no browser: the `petrel` binary, the library, and the
//! simulated vehicle (sitl-tests, in this process). One binary: the tests
//! run in parallel, so a test that needs to run alone takes a lock shared
//! with what it conflicts with (issue 36). `cargo test -p gateway --test it`.

// Shared with the other test binaries of gateway (the scratch folders with
// every crate's tests: petrel-test-support).
#[path = "../scenarios/flight.rs"]
mod flight;
#[path = "../support/gateways.rs"]
mod gateways;
#[path = "../support/harness.rs"]
mod harness;
#[path = "../mirror/router.rs"]
mod router;
use petrel_test_support::scratch;
#[path = "../support/team_run.rs"]
mod team_run;
#[path = "../support/ugv_team.rs"]
mod ugv_team;
#[path = "../support/wire.rs"]
mod wire;

// This binary's own helpers.
mod peer;
mod process;
mod simulated;

mod check;
mod cli;
mod compile;
mod events;
mod flight_test_example;
mod mirror;
mod mirror_dialog;
mod mirror_simulated;
mod mirror_team;
mod multi_vehicle;
mod preflight;
mod programs;
mod record;
mod reload;
mod run;
mod scenarios;
mod signing;
mod survive;
mod team;
mod ugv_bottleneck;
mod ugv_example;
mod vehicle;

/// The scenarios' mission file in the project (DEC reads it; the
/// `flight` module, shared with benches/mirror.rs, takes it from here).
pub const MISSION_FILE: &str = "mission.toml";
