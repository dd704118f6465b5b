//! The simulated ArduPlane: a vehicle that behaves on the wire as ArduPlane
//! 4.7 SITL does (checked against a recording of it and against ArduPilot's
//! own SITL, see the README), for Petrel's end-to-end tests and `petrel
//! demo`; the same core as a ground rover behaving as ArduPilot Rover
//! ([`SimConfig::rover`], [`Firmware::ArduRover`]); several vehicles on one
//! link ([`Fleet`]); the payload camera on its own link; the harness for
//! ArduPilot's real SITL.
//!
//! It owns a sans-IO core, [`Vehicle`] (the autopilot, its camera and a
//! point-mass fixed-wing model: fed `(now, header, message)` and
//! `advance(now)` in sim microseconds, polled for `(header, message)` to
//! send), and the I/O around it, [`Sim`] (a thread, a TCP or UDP socket and
//! a sim clock running `speedup` times faster than the wall clock). It never
//! parses or checksums MAVLink itself (rust-mavlink does, through
//! `elaboration::Frame`), and the core never reads a clock or touches a
//! socket.
//!
//! ```no_run
//! use sitl_tests::{Fault, Home, Schedule, Sim, SimConfig};
//! # fn main() -> Result<(), sitl_tests::SimError> {
//! let sim = Sim::start(SimConfig {
//!     listen: "tcpin:127.0.0.1:0".into(), // or "udpin:127.0.0.1:0"; port 0 picks one
//!     speedup: 10.0,
//!     home: Home { lat: -35.363261, lon: 149.165230, alt_amsl: 584.0, heading: 353.0 },
//!     wind: (0.0, 0.0), // m/s toward north, east
//!     first_arm_refused: true,
//!     faults: Schedule::parse(&["engine_failure@90s"]).expect("a valid schedule"),
//!     ..SimConfig::default()
//! })?;
//! let gateway_address = sim.client_address(); // "tcpout:127.0.0.1:PORT"
//! # let _ = gateway_address;
//! // ... the gateway connects: the vehicle boots (sim time 0) ...
//! let state = sim.state(); // the truth: position, mode, mission, commands, texts…
//! # let _ = state;
//! sim.inject(Fault::EngineFailure);
//! sim.stop(); // also on drop
//! # Ok(())
//! # }
//! ```
//!
//! Public API:
//! - [`Sim::start`], [`Sim::local_addr`], [`Sim::client_address`],
//!   [`Sim::state`], [`Sim::connected`], [`Sim::inject`],
//!   [`Sim::inject_for`], [`Sim::clear`], [`Sim::wait_for`], [`Sim::stop`];
//! - [`Fleet::start`] (several vehicles, each its own system id, on one
//!   socket), [`Fleet::states`], [`Fleet::state`], [`Fleet::inject`],
//!   [`Fleet::inject_for`], [`Fleet::clear`], [`Fleet::wait_for`],
//!   [`Fleet::systems`], and the socket's as [`Sim`]'s;
//! - [`SimConfig`] (with [`Firmware`], [`Home`], [`Airframe`],
//!   [`BootTimeline`], [`Schedule`]; [`SimConfig::rover`]); [`SimState`]
//!   and its records;
//! - [`Fault`], [`FaultKind`], [`Schedule`] (`--fault` syntax in
//!   [`faults`]);
//! - the core [`Vehicle`] (`new`, `handle`, `advance`, `poll_transmit`,
//!   `next_deadline`, `state`, `inject`, `inject_for`, `clear`) for tests
//!   that drive simulated time directly;
//! - [`ardupilot`]: ArduPilot's own SITL (the real firmware) found, started
//!   and reaped, for the tests that fly against it;
//! - [`px4`]: PX4's own SITL (v1.18 with its SIH simulator) found, started
//!   on an instance of its own and reaped, for the tests that fly PX4;
//! - [`CameraSim`] (`start(address, CameraConfig)`, `state`, `inject`,
//!   `clear`, `wait_for`, `connected`, `stop`): the payload camera on its
//!   own link, a MAVLink component of the vehicle's system on one of the
//!   real autopilot's serial ports, around the sans-IO [`CameraComponent`];
//! - [`wire`]: MAVLink frames on a byte stream (through rust-mavlink);
//! - [`drive`]: the rover's kinematic model.

pub mod ardupilot;
mod arming;
mod auto;
pub mod boot;
pub mod camera;
pub mod camera_component;
mod camera_sim;
pub mod clock;
mod commands;
mod config;
pub mod drive;
pub mod faults;
pub mod flight;
pub mod geo;
pub mod guidance;
mod messages;
pub mod mission;
pub mod model;
pub mod modes;
pub mod nav_state;
pub mod params;
pub mod px4;
mod rover;
mod runner;
pub use petrel_test_support::skip;
pub mod state;
pub mod streams;
mod telemetry;
mod vehicle;
pub mod wire;

// The unit tests' scratch folders.
#[cfg(test)]
use petrel_test_support::scratch;

pub use boot::BootTimeline;
pub use camera_component::{CameraCommand, CameraComponent, CameraConfig, CameraState};
pub use camera_sim::{CameraSim, CameraSimError};
pub use config::{Firmware, SimConfig};
pub use faults::{
    Fault, FaultKind, PayloadFailure, Refusal, Schedule, ScheduleError, ScheduledFault, Trigger,
};
pub use geo::Home;
pub use mission::MissionItem;
pub use model::Airframe;
pub use params::Params;
pub use runner::{Fleet, Sim, SimError};
pub use state::SimState;
pub use vehicle::{Vehicle, WireFaults, AUTOPILOT};

/// MAV_COMP_ID_CAMERA: the camera component's id.
pub const CAMERA: u8 = camera::COMPONENT;
