//! Petrel's decisions, without I/O: what the onboard gateway and the
//! ground mirror decide, as state machines fed with input and its time and
//! polled for output (as quinn-proto is to quinn).
//!
//! It owns:
//! - [`supervisor`]: elaboration and the player as one state machine, and
//!   [`team`]: a team's lanes (one elaborator per vehicle);
//! - [`onboard`]: the core on board (`petrel run` minus the sockets):
//!   frames, ticks and program outcomes in; commands, downlink records,
//!   program calls and settled steps out;
//! - [`vehicle`]: the commanders that turn the nets' commands into MAVLink
//!   exchanges with the autopilot, and the crew of them;
//! - [`programs`]: one program connection's session and the protocol;
//! - [`mirror`]: the downlink's record codec, publisher, replica, check,
//!   dialog, and [`mirror::station::Station`], the ground's core;
//! - [`signing`]: MAVLink 2 signing's keys and checks (rust-mavlink signs);
//! - [`version`]: a new version of the running project, proved from the
//!   state the vehicle is in and taken over at a step boundary;
//! - [`frame`]: a frame as received, parsed once;
//! - [`profile`], [`project`]: loading a project and its elaboration
//!   profile from its files.
//!
//! It never opens a socket, starts a thread or a process, reads the clock,
//! sleeps or prints: time comes in with every input, and the only files it
//! touches are a project's own (its nets, profile and key, read when asked
//! to load them; program skeletons, written into it when asked). Its dependencies say so: no tokio, axum, mcap or libc. The
//! drivers that move bytes are in the `gateway` crate.

pub mod frame;
pub mod mirror;
pub mod onboard;
pub mod profile;
pub mod programs;
pub mod project;
pub mod signing;
pub mod supervisor;
pub mod team;
pub mod vehicle;
pub mod version;
