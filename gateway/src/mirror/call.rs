//! The replica's calls on its player, one at a time: what `petrel mirror
//! --record` records as its steps and `petrel replay` plays back
//! (docs/mirror.md, "The mirror's recording"). Both sides play a call with
//! [`apply`], so a replayed mirror recording gives the replica's digests.

use std::sync::Arc;

use nets::player::{snapshot, Digest};
use nets::{Effect, Micros, Player, Project};

use super::record::Input;

/// One call of the replica on its player, at a vehicle time.
#[derive(Debug, Clone, PartialEq)]
pub enum Call {
    /// The player started afresh at the time (a session's first records).
    Restart,
    /// A step record played, as the onboard supervisor played its inputs:
    /// advanced to `before`, each input at its own time, advanced to the
    /// call's time.
    Record { before: Micros, inputs: Vec<Input> },
    /// Time passed to the call's time (a heartbeat's or a snapshot's).
    Advance,
    /// The player restored from a snapshot's state
    /// (`nets::player::snapshot`'s encoding).
    Restore(Vec<u8>),
}

/// A call made, with what it caused: recorded by the mirror.
#[derive(Debug, Clone)]
pub struct Played {
    /// Vehicle time.
    pub time: Micros,
    pub call: Call,
    pub effects: Vec<Effect>,
    /// The player's digest after the call.
    pub digest: Digest,
}

/// Why a recorded call cannot be played.
#[derive(Debug, thiserror::Error)]
pub enum CallError {
    #[error("the recorded snapshot does not decode: {0}")]
    Snapshot(#[from] snapshot::SnapshotError),
    #[error("{0}")]
    Restore(#[from] nets::player::RestoreError),
}

/// Plays `call` at `time` on `player` (replaced by a restart or a restore)
/// and returns the effects it caused.
pub fn apply(player: &mut Player, time: Micros, call: &Call) -> Result<Vec<Effect>, CallError> {
    match call {
        Call::Restart => *player = start(player.project().clone(), time),
        Call::Record { before, inputs } => return Ok(play(player, *before, inputs, time)),
        Call::Advance => player.advance(time),
        Call::Restore(state) => *player = restore(player.project().clone(), state)?,
    }
    Ok(player.effects().collect())
}

/// A player started at `time`.
pub fn start(project: Arc<Project>, time: Micros) -> Player {
    Player::start(project, time)
}

/// A player restored from a snapshot's state bytes.
pub fn restore(project: Arc<Project>, state: &[u8]) -> Result<Player, CallError> {
    Ok(Player::restore(project, snapshot::decode(state)?)?)
}

/// Plays a step record's inputs: advance to `before`, each input at its
/// time, advance to `time`; the effects in order.
pub fn play(player: &mut Player, before: Micros, inputs: &[Input], time: Micros) -> Vec<Effect> {
    player.advance(before);
    let mut effects: Vec<Effect> = player.effects().collect();
    for input in inputs {
        match input {
            Input::Elaborated { time, event }
            | Input::Program { time, event }
            | Input::Answer { time, event } => player.handle(event, *time),
            Input::Result { time, id, outcome } => player.result(*id, outcome.clone(), *time),
            Input::Answered { time, id, choice } => {
                // Refused or not, as on board: the same effects.
                let _ = player.answer(*id, choice, *time);
            }
        }
        effects.extend(player.effects());
    }
    player.advance(time);
    effects.extend(player.effects());
    effects
}
