//! The replica's calls on its player, one at a time: what `petrel mirror
//! --record` records as its steps and `petrel replay` plays back
//! (docs/mirror.md, "The mirror's recording"). Both sides play a call with
//! [`apply`], so a replayed mirror recording gives the replica's digests.

use std::sync::Arc;

use nets::player::{snapshot, Digest};
use nets::{Effect, Event, Micros, Outcome, Player, Project};
use serde::Deserialize as _;
use serde_json::{json, Value as Json};

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
    /// A new version of the project took over, the state mapped onto it
    /// by name (`nets::version::map`; the step record that says so is
    /// played after it).
    Version(Arc<crate::version::Version>),
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
    #[error("version {number} cannot take over: {why}")]
    Version { number: u32, why: String },
}

/// Plays `call` at `time` on `player` (replaced by a restart or a restore)
/// and returns the effects it caused.
pub fn apply(player: &mut Player, time: Micros, call: &Call) -> Result<Vec<Effect>, CallError> {
    match call {
        Call::Restart => *player = start(player.project().clone(), time),
        Call::Record { before, inputs } => return Ok(play(player, *before, inputs, time)),
        Call::Advance => player.advance(time),
        Call::Restore(state) => *player = restore(player.project().clone(), state)?,
        Call::Version(version) => *player = take_over(player, version)?,
    }
    Ok(player.effects().collect())
}

/// A player started at `time`.
pub fn start(project: Arc<Project>, time: Micros) -> Player {
    Player::start(project, time)
}

/// `version` taking over from `player`, its state mapped by name.
pub fn take_over(player: &Player, version: &crate::version::Version) -> Result<Player, CallError> {
    let why = |why: String| CallError::Version {
        number: version.number,
        why,
    };
    let state =
        nets::version::map(player.project(), player.state(), &version.project).map_err(|r| {
            why(r
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join("; "))
        })?;
    Player::restore(version.project.clone(), state).map_err(|e| why(e.to_string()))
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
            Input::Elaborated { time, event, .. }
            | Input::Program { time, event }
            | Input::Answer { time, event } => player.handle(event, *time),
            Input::Result { time, id, outcome } => player.result(*id, outcome.clone(), *time),
            Input::Answered { time, id, choice } => {
                // Refused or not, as on board: the same effects.
                let _ = player.answer(*id, choice, *time);
            }
            // Taken over before the record is played (`Call::Version`).
            Input::Version { .. } => {}
        }
        effects.extend(player.effects());
    }
    player.advance(time);
    effects.extend(player.effects());
    effects
}

/// A call as recorded (`"replica"` of an input on `/petrel/inputs`):
/// `{"call": "restart" | "advance"}`, `{"call": "record", "before",
/// "inputs"}`, `{"call": "restore", "state": hex}`.
pub fn call_json(call: &Call) -> Json {
    match call {
        Call::Restart => json!({"call": "restart"}),
        Call::Advance => json!({"call": "advance"}),
        Call::Record { before, inputs } => {
            let inputs: Vec<Json> = inputs.iter().map(input_json).collect();
            json!({"call": "record", "before": before, "inputs": inputs})
        }
        Call::Restore(state) => json!({"call": "restore", "state": hex(state)}),
        Call::Version(v) => {
            let files: Vec<Json> = v
                .files
                .iter()
                .map(|(name, text)| json!({"name": name, "text": text}))
                .collect();
            json!({"call": "version", "number": v.number, "files": files})
        }
    }
}

/// Reads [`call_json`] back.
pub fn call_from(json: &Json) -> Option<Call> {
    Some(match json.get("call")?.as_str()? {
        "restart" => Call::Restart,
        "advance" => Call::Advance,
        "record" => Call::Record {
            before: json.get("before")?.as_u64()?,
            inputs: json
                .get("inputs")?
                .as_array()?
                .iter()
                .map(input_from)
                .collect::<Option<_>>()?,
        },
        "restore" => Call::Restore(unhex(json.get("state")?.as_str()?)?),
        "version" => {
            let number = u32::try_from(json.get("number")?.as_u64()?).ok()?;
            let files = json
                .get("files")?
                .as_array()?
                .iter()
                .map(|f| {
                    Some((
                        f.get("name")?.as_str()?.to_owned(),
                        f.get("text")?.as_str()?.to_owned(),
                    ))
                })
                .collect::<Option<Vec<_>>>()?;
            Call::Version(Arc::new(
                crate::version::Version::from_files(number, files).ok()?,
            ))
        }
        _ => return None,
    })
}

/// An event or an outcome as JSON: its serde form (what the recording's
/// layout writes too).
fn to_json<T: serde::Serialize>(value: &T) -> Json {
    serde_json::to_value(value).unwrap_or(Json::Null)
}

/// One input of a downlink step record as JSON.
fn input_json(input: &Input) -> Json {
    match input {
        Input::Elaborated { time, event, .. } => {
            json!({"kind": "elaborated", "time_us": time, "event": to_json(event)})
        }
        Input::Program { time, event } => {
            json!({"kind": "program", "time_us": time, "event": to_json(event)})
        }
        Input::Answer { time, event } => {
            json!({"kind": "answer_event", "time_us": time, "event": to_json(event)})
        }
        Input::Result { time, id, outcome } => {
            json!({"kind": "result", "time_us": time, "id": id, "outcome": to_json(outcome)})
        }
        Input::Answered { time, id, choice } => {
            json!({"kind": "answered", "time_us": time, "id": id, "choice": choice})
        }
        Input::Version {
            time,
            number,
            digest,
        } => {
            json!({"kind": "version", "time_us": time, "number": number, "digest": hex(digest)})
        }
    }
}

fn input_from(json: &Json) -> Option<Input> {
    let time = json.get("time_us")?.as_u64()?;
    let event = || Event::deserialize(json.get("event")?).ok();
    Some(match json.get("kind")?.as_str()? {
        "elaborated" => Input::Elaborated {
            time,
            boot: None,
            event: event()?,
        },
        "program" => Input::Program {
            time,
            event: event()?,
        },
        "answer_event" => Input::Answer {
            time,
            event: event()?,
        },
        "result" => Input::Result {
            time,
            id: json.get("id")?.as_u64()?,
            outcome: Outcome::deserialize(json.get("outcome")?).ok()?,
        },
        "answered" => Input::Answered {
            time,
            id: json.get("id")?.as_u64()?,
            choice: json.get("choice")?.as_str()?.to_owned(),
        },
        "version" => Input::Version {
            time,
            number: u32::try_from(json.get("number")?.as_u64()?).ok()?,
            digest: unhex(json.get("digest")?.as_str()?)?.try_into().ok()?,
        },
        _ => return None,
    })
}

/// Bytes as lower-case hex digits.
fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex(text: &str) -> Option<Vec<u8>> {
    if !text.len().is_multiple_of(2) {
        return None;
    }
    (0..text.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(text.get(i..i + 2)?, 16).ok())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nets::{Event, Outcome};

    #[test]
    fn calls_round_trip_through_their_recorded_json() {
        let calls = [
            Call::Restart,
            Call::Advance,
            Call::Restore(vec![1, 0, 0xab, 0xff]),
            Call::Record {
                before: 900,
                inputs: vec![
                    Input::Elaborated {
                        time: 950,
                        boot: None,
                        event: Event::new("reached").param("wp", 2i64),
                    },
                    Input::Program {
                        time: 960,
                        event: Event::new("photo_taken"),
                    },
                    Input::Answer {
                        time: 970,
                        event: Event::new("go.yes"),
                    },
                    Input::Result {
                        time: 980,
                        id: 4,
                        outcome: Outcome::Failed("denied".into()),
                    },
                    Input::Answered {
                        time: 990,
                        id: 5,
                        choice: "no".into(),
                    },
                    Input::Version {
                        time: 995,
                        number: 2,
                        digest: [7; 32],
                    },
                ],
            },
            Call::Version(Arc::new(
                crate::version::Version::from_files(
                    3,
                    vec![
                        (
                            "project.toml".into(),
                            "[[net]]\nfile = \"n.toml\"\nactive = true\n".into(),
                        ),
                        (
                            "n.toml".into(),
                            "name = \"N\"\nplaces = [\"a\"]\ninitial = [\"a\"]\nfinal = [\"a\"]\n"
                                .into(),
                        ),
                    ],
                )
                .expect("it loads"),
            )),
        ];
        for call in &calls {
            // Through its text, as the recording keeps it.
            let line = call_json(call).to_string();
            let json: Json = serde_json::from_str(&line).expect("a call's JSON reads back");
            assert_eq!(call_from(&json).as_ref(), Some(call), "{line}");
        }
        for bad in [
            json!({}),
            json!({"call": "jump"}),
            json!({"call": "restore", "state": "abc"}),
            json!({"call": "restore", "state": "zz"}),
            json!({"call": "record", "before": 1, "inputs": [{"kind": "warp", "time_us": 1}]}),
            json!({"call": "record", "inputs": []}),
            // A version whose files do not load is no call.
            json!({"call": "version", "number": 1, "files": [{"name": "project.toml", "text": "[[net"}]}),
        ] {
            assert_eq!(call_from(&bad), None, "{bad}");
        }
    }
}
