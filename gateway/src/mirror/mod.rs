//! The ground mirror (docs/mirror.md): the vehicle's player reproduced on
//! the ground, step for step, from a downlink of records in MAVLink TUNNEL
//! messages.
//!
//! - `call`: the replica's calls on its player, as the mirror records them
//!   and `petrel replay` plays them back.
//! - `record`: the records and their versioned binary encoding (pure).
//! - `publisher`: on board, sans-IO — numbers the steps' inputs, keeps a
//!   ring, sends heartbeats and snapshots, answers the ground's requests.
//! - `check`: on the ground, sans-IO — the independent check of the
//!   ground's own elaboration against the vehicle's published events.
//! - `ground`: on the ground, sans-IO — the ground's own elaboration in
//!   the team's lanes, each vehicle's frames counted and watched for
//!   losses, one check per vehicle.
//! - `replica`: on the ground, sans-IO — plays the records, compares
//!   digests, sees gaps, asks for what it lacks, reports
//!   `mirror_resynced` / `mirror_diverged`.
//! - `signed`: on the ground, sans-IO — with the vehicle's signing key,
//!   only downlink frames signed with it, fresh, reach the replica.
//!
//! Neither opens a socket or reads a clock; `petrel run` and `petrel mirror`
//! carry their packets.

pub mod call;
pub mod check;
pub mod dialog;
pub mod ground;
pub mod publisher;
pub mod record;
pub mod replica;
pub mod signed;
pub mod tunnel;
pub mod uplink;

use crate::supervisor::{Input as SupervisorInput, Step};

/// The mirror's MAVLink system id by default: not 255, the ground
/// station's that ArduPilot's GCS failsafe watches (`SYSID_MYGCS`).
pub const MIRROR_SYSTEM: u8 = 245;
/// The onboard gateway's component (MAV_COMP_ID_ONBOARD_COMPUTER): the
/// downlink's source, the uplink's target.
pub const COMPANION: u8 = 191;
use record::Input;

/// The inputs of a supervisor step that reached the player, as the
/// downlink carries them; `None` for a step that only let time pass (a
/// frame or tick that elaborated nothing).
pub fn step_inputs(input: &SupervisorInput, step: &Step) -> Option<Vec<Input>> {
    let inputs: Vec<Input> = match input {
        SupervisorInput::Frame(_) | SupervisorInput::Tick => step
            .events
            .iter()
            .map(|(e, _)| Input::Elaborated {
                time: e.time_us,
                boot: e.boot_us,
                event: e.event.clone(),
            })
            .collect(),
        SupervisorInput::Result { id, outcome } => vec![Input::Result {
            time: step.time,
            id: *id,
            outcome: outcome.clone(),
        }],
        SupervisorInput::Event(event) => vec![Input::Program {
            time: step.time,
            event: event.clone(),
        }],
        SupervisorInput::Answer { id, choice } => vec![Input::Answered {
            time: step.time,
            id: *id,
            choice: choice.clone(),
        }],
    };
    (!inputs.is_empty()).then_some(inputs)
}

#[cfg(test)]
mod tests;

#[cfg(test)]
#[path = "ground/tests.rs"]
mod ground_tests;
