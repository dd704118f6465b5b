//! The vehicle side of the gateway: the nets' `command` effects turned
//! into MAVLink for ArduPilot and PX4, and the autopilot's answers turned
//! into outcomes. Sans-IO (quinn-proto style): no clock, no sockets; time
//! is `nets::Micros` given by the caller. The link itself is the driver's (`gateway::link`).
//! The verb table, retry rules and the `[gateway]` keys: docs/vehicle.md.
//!
//! # Using it
//!
//! ```text
//! let origin = Instant::now();                                  // one clock origin for the gateway
//! let (mut reader, writer) = link::Link::open(&address, origin).await?;
//! // a task: loop { tx.send(reader.recv().await?) }             (frames: bytes, time_us, header, message)
//! let config = config::VehicleConfig::from_project_toml("project.toml", &text)?; // errors: file:line:col
//! let mut commander = commander::Commander::new(config);
//! commander.request_streams(&[(33, 4.0), (1, 2.0)], now);     // message ids and Hz, from the profile
//! loop {
//!     // 1. every frame received:    commander.message(frame.time_us, &frame.header, &message)
//!     //                             (frames that decode; the raw bytes go to elaboration and the recorder)
//!     // 2. every Effect::Command:   commander.command(id, &verb, &args, now)
//!     //    every Effect::Forgotten: commander.forget(id)
//!     // 3. when nothing arrives:    commander.tick(now), at commander.next_deadline() at the latest
//!     // 4. after each of the above, drain:
//!     //    while let Some(m) = commander.poll_transmit() { writer.send(commander.sender(), &m).await }
//!     //    while let Some((id, outcome)) = commander.poll_outcome() { player.result(id, outcome, now) }
//! }
//! // shutdown: keep steps 1, 3, 4 going while commander.busy() (bounded by the retry rules),
//! // so that no mission upload is left half done
//! ```
//!
//! The commander learns the autopilot (system, component, firmware) from
//! its first HEARTBEAT unless configured, and speaks as the vehicle's
//! system id, component 191, with a 1 Hz HEARTBEAT as
//! MAV_TYPE_ONBOARD_CONTROLLER / MAV_AUTOPILOT_INVALID. Its HEARTBEAT goes
//! out from the start, under the configured or default system id
//! (`sender()`) until the vehicle's is known, so that endpoints waiting for
//! their client to speak first hear it; nothing else is transmitted before
//! it knows the system id (`identity()`).

pub mod commander;
pub mod config;
pub mod crew;
pub mod mission;
pub mod modes;
pub mod parameters;
pub mod plan;
pub mod request;
pub mod streams;

#[cfg(test)]
mod tests;
