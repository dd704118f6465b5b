//! Exchanges read from the ArduPilot SITL recordings in ../shared/telemetry:
//! each request of the recording's client (system 255) and the vehicle's
//! answers to it, so that the scripted peer answers as ArduPilot did.

#![allow(deprecated)] // MISSION_REQUEST: what ArduPilot sent in the recording

use std::path::{Path, PathBuf};

use elaboration::TlogReader;
use mavlink::dialects::ardupilotmega::*;

pub struct Exchange {
    pub request: MavMessage,
    pub replies: Vec<MavMessage>,
}

/// The shared telemetry folder beside the workspace root.
pub fn telemetry(name: &str) -> Option<PathBuf> {
    let path = sitl_tests::skip::shared_dir().join("telemetry").join(name);
    if path.is_file() {
        return Some(path);
    }
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!(
            "{} is missing (CI=true: shared recordings are required)",
            path.display()
        );
    }
    sitl_tests::skip::skip(&format!("{} is absent", path.display()));
    None
}

fn is_request(m: &MavMessage) -> bool {
    matches!(
        m,
        MavMessage::COMMAND_LONG(_)
            | MavMessage::COMMAND_INT(_)
            | MavMessage::MISSION_COUNT(_)
            | MavMessage::MISSION_ITEM_INT(_)
    )
}

fn is_reply(m: &MavMessage) -> bool {
    matches!(
        m,
        MavMessage::COMMAND_ACK(_)
            | MavMessage::MISSION_REQUEST(_)
            | MavMessage::MISSION_REQUEST_INT(_)
            | MavMessage::MISSION_ACK(_)
    )
}

/// The client's requests and the autopilot's (1/1) answers, in order.
pub fn exchanges(path: &Path) -> Vec<Exchange> {
    let bytes = std::fs::read(path).expect("recording readable");
    let mut out: Vec<Exchange> = Vec::new();
    for record in TlogReader::new(&bytes) {
        let Ok(message) = record.frame.decode() else {
            continue;
        };
        let (sys, comp) = (record.frame.system_id(), record.frame.component_id());
        if sys == 255 && is_request(&message) {
            out.push(Exchange {
                request: message,
                replies: Vec::new(),
            });
        } else if (sys, comp) == (1, 1) && is_reply(&message) {
            if let Some(last) = out.last_mut() {
                last.replies.push(message);
            }
        }
    }
    out
}

/// A recorded answer, readdressed from the recording's client (255/190) to
/// the gateway (1/191).
pub fn readdress(m: &MavMessage) -> MavMessage {
    let mut m = m.clone();
    match &mut m {
        MavMessage::COMMAND_ACK(a) => {
            a.target_system = 1;
            a.target_component = 191;
        }
        MavMessage::MISSION_REQUEST(r) => {
            r.target_system = 1;
            r.target_component = 191;
        }
        MavMessage::MISSION_REQUEST_INT(r) => {
            r.target_system = 1;
            r.target_component = 191;
        }
        MavMessage::MISSION_ACK(a) => {
            a.target_system = 1;
            a.target_component = 191;
        }
        _ => {}
    }
    m
}

/// Whether the gateway's message is the recorded request (same command and
/// parameters, same mission item); item 0 (home, which ArduPilot
/// overwrites) is compared on position only. `Err` says how they differ.
pub fn same_request(ours: &MavMessage, recorded: &MavMessage) -> Result<(), String> {
    let close = |a: f32, b: f32| (a.is_nan() && b.is_nan()) || (a - b).abs() < 1e-3;
    match (ours, recorded) {
        (MavMessage::COMMAND_LONG(a), MavMessage::COMMAND_LONG(b)) => {
            let pa = [
                a.param1, a.param2, a.param3, a.param4, a.param5, a.param6, a.param7,
            ];
            let pb = [
                b.param1, b.param2, b.param3, b.param4, b.param5, b.param6, b.param7,
            ];
            if a.command == b.command
                && (a.target_system, a.target_component) == (b.target_system, b.target_component)
                && pa.iter().zip(pb).all(|(x, y)| close(*x, y))
                && a.confirmation == b.confirmation
            {
                Ok(())
            } else {
                Err(format!("ours {a:?}\nrecorded {b:?}"))
            }
        }
        (MavMessage::MISSION_COUNT(a), MavMessage::MISSION_COUNT(b)) if a.count == b.count => {
            Ok(())
        }
        (MavMessage::MISSION_ITEM_INT(a), MavMessage::MISSION_ITEM_INT(b)) => {
            let same_place = a.seq == b.seq && a.x == b.x && a.y == b.y && a.command == b.command;
            let same_rest = a.frame == b.frame
                && close(a.z, b.z)
                && close(a.param1, b.param1)
                && close(a.param2, b.param2)
                && close(a.param3, b.param3)
                && close(a.param4, b.param4)
                && a.autocontinue == b.autocontinue
                && a.current == b.current;
            if same_place && (a.seq == 0 || same_rest) {
                Ok(())
            } else {
                Err(format!("ours {a:?}\nrecorded {b:?}"))
            }
        }
        _ => Err(format!("ours {ours:?}\nrecorded {recorded:?}")),
    }
}
