//! The gateway's tests in a real browser (Chromium, driven by
//! playwright-core from target/browser-tools): the web monitor and
//! `petrel edit`. `cargo test -p gateway --test browser`.

#[path = "../scenarios/flight.rs"]
mod flight;
#[path = "../mirror/router.rs"]
mod router;
use petrel_test_support::scratch;
#[path = "../support/ugv_team.rs"]
mod ugv_team;

mod browser;

mod edit;
mod monitor;
mod monitor_mirror;
mod monitor_team;

/// The scenarios' mission file in the project (DEC reads it; the
/// `flight` module, shared with benches/mirror.rs, takes it from here).
pub const MISSION_FILE: &str = "mission.toml";
