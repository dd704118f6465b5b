//! The gateway's tests against real firmware and real peers: ArduPilot
//! and PX4 SITL, MAVProxy, socat, pymavlink, and the hour's soak
//! (`#[ignore]`d). `cargo test -p gateway --test real`.
//!
//! Every test that starts a SITL (ArduPilot or PX4) holds [`sitl_turn`]
//! for as long as its SITLs run: one firmware at a time in this process,
//! so that SITL instance numbers (TCP 5760 + 10 × instance) never clash
//! and two simulations do not share the machine's cores. The soak's
//! flights (the simulated plane at 5-10×) take it too.
//!
//! ArduPilot SITL instances, each used by one module only (unique even
//! without the lock): real_plane 0, real_failures 3 and 4, deploy 5,
//! multi_vehicle 6 and 7, mirror_sitl 9 and 12, real_px4's ArduCopter 10
//! and 13, signing 11, events 14, team 15 and 16. PX4 SITL takes its own
//! instances 0-3 (sitl-tests' pool; ports 14540+, 18570+, apart from
//! ArduPilot's).

use std::sync::{Mutex, MutexGuard};

#[path = "../scenarios/flight.rs"]
mod flight;
#[path = "../support/gateways.rs"]
mod gateways;
#[path = "../support/harness.rs"]
mod harness;
#[path = "../support/scratch.rs"]
mod scratch;
#[path = "../support/team_run.rs"]
mod team_run;
#[path = "../support/wire.rs"]
mod wire;

mod px4;
mod real;

mod deploy;
mod events;
mod mirror_sitl;
mod multi_vehicle;
mod real_failures;
mod real_plane;
mod real_px4;
mod signing;
mod soak;
mod team;

static SITL: Mutex<()> = Mutex::new(());

/// The turn of a test that starts SITLs: held until dropped. A test that
/// failed while holding it does not stop the others (poison is ignored).
pub fn sitl_turn() -> MutexGuard<'static, ()> {
    SITL.lock().unwrap_or_else(|e| e.into_inner())
}

/// The scenarios' mission file in the project (DEC reads it; the
/// `flight` module, shared with benches/mirror.rs, takes it from here).
pub const MISSION_FILE: &str = "mission.toml";
