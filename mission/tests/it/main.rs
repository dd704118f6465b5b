//! The integration tests of `petrel-mission`, one test binary: every plan
//! and waypoint file of `../shared/plans` (real files from public
//! projects: QGroundControl's, MAVSDK's, PX4's, ArduPilot's and MAVProxy's
//! own) read, or refused with the reason its format gives.

// `Skipped` and the closing `SKIPPED:` line, shared by every crate's tests.
use petrel_test_support::skip;

mod language;
mod play;
mod shared_plans;
