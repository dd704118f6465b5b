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
pub mod station;
pub mod tunnel;
pub mod upload;

use crate::supervisor::{Input as SupervisorInput, Step};

/// The mirror's MAVLink system id by default: not 255, the ground
/// station's that ArduPilot's GCS failsafe watches (`SYSID_MYGCS`).
pub const MIRROR_SYSTEM: u8 = 245;
/// The onboard gateway's component (MAV_COMP_ID_ONBOARD_COMPUTER): the
/// downlink's source, the uplink's target.
pub const COMPANION: u8 = 191;
use record::Input;

/// The events the downlink may leave out of a step when they changed
/// nothing: those the ground's independent check never compares because
/// each side hears only its own (elaborated only from frames addressed
/// to one system and component, [`elaboration::Profile::addressed_events`]:
/// `command_rejected`, the autopilot's answers to the onboard gateway's
/// commands), per vehicle of the team.
#[derive(Debug, Clone, Default)]
pub struct Unread {
    /// Each lane's vehicle (`None` without a team) and its addressed
    /// events' names, unqualified.
    lanes: Vec<(Option<String>, Vec<String>)>,
}

impl Unread {
    /// Nothing left out.
    #[cfg(test)]
    pub fn none() -> Unread {
        Unread::default()
    }

    /// The lanes' addressed events.
    pub fn of(lanes: &[crate::supervisor::Lane]) -> Unread {
        Unread {
            lanes: lanes
                .iter()
                .map(|l| {
                    let names = l.profile.addressed_events();
                    (
                        l.vehicle.clone(),
                        names.into_iter().map(str::to_owned).collect(),
                    )
                })
                .collect(),
        }
    }

    /// Whether the ground never compares `event` (a vehicle's event,
    /// qualified in a team).
    pub fn unread(&self, event: &nets::Event) -> bool {
        let (name, vehicle) = nets::model::split_vehicle(&event.name);
        self.lanes
            .iter()
            .find(|(v, _)| v.as_deref() == vehicle)
            .is_some_and(|(_, names)| names.iter().any(|n| n == name))
    }
}

/// The inputs of a supervisor step that reached the player, as the
/// downlink carries them; `None` for a step that only let time pass (a
/// frame or tick that elaborated nothing, or only events `unread` by the
/// ground that changed nothing: no firing, no timer, no fault, no effect
/// at all — the replica's player, advanced to the next record's time,
/// is the same without them, and the digests say so).
pub fn step_inputs(input: &SupervisorInput, step: &Step, unread: &Unread) -> Option<Vec<Input>> {
    let inputs: Vec<Input> = match input {
        SupervisorInput::Frame(_) | SupervisorInput::Tick => step
            .events
            .iter()
            .filter(|(e, effects)| !(effects.is_empty() && unread.unread(&e.event)))
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
        SupervisorInput::Version(v) => vec![Input::Version {
            time: step.time,
            number: v.number,
            digest: v.digest(),
        }],
    };
    (!inputs.is_empty()).then_some(inputs)
}

#[cfg(test)]
mod tests;

#[cfg(test)]
#[path = "ground/tests.rs"]
mod ground_tests;
