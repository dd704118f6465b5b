//! What the mirror tests check on the wire and in the mirror's recording,
//! read independently of the gateway's code (docs/mirror.md's encoding).
#![allow(dead_code)] // a module of the `it` and `real` binaries, each using a part

use std::path::Path;
use std::process::Command;

/// The mirror's own (system, component) and Petrel's TUNNEL payload type.
pub const MIRROR_SYSTEM: u8 = 245;
pub const MIRROR_COMPONENT: u8 = 190;
pub const PAYLOAD_TYPE: u16 = 0xD04D;

/// `petrel replay FILE PROJECT --check-against` on the flight-test
/// example: (exit code, stderr).
pub fn check_recording(file: &Path) -> (i32, String) {
    check_recording_of(file, &crate::flight::project())
}

/// `petrel replay FILE PROJECT --check-against`: (exit code, stderr).
pub fn check_recording_of(file: &Path, project: &Path) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("replay")
        .arg(file)
        .arg(project)
        .arg("--check-against")
        .output()
        .expect("petrel replay runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The mirror's recording replays its replica exactly: every call's
/// effects and digest. Returns the number of steps replayed.
pub fn the_recording_checks_out(name: &str, recording: &Path, mirror_err: &str) -> u64 {
    the_recording_of_checks_out(name, recording, &crate::flight::project(), mirror_err)
}

/// The same, of a mirror following `project`.
pub fn the_recording_of_checks_out(
    name: &str,
    recording: &Path,
    project: &Path,
    mirror_err: &str,
) -> u64 {
    let (code, err) = check_recording_of(recording, project);
    assert_eq!(
        code, 0,
        "{name}: petrel replay --check-against on the mirror's recording\n{err}\n{}",
        mirror_err
    );
    let recorded = mirror_err
        .lines()
        .find_map(|l| {
            l.strip_prefix("recorded ")?
                .split(' ')
                .next()?
                .parse::<u64>()
                .ok()
        })
        .unwrap_or_else(|| {
            panic!(
                "{name}: the mirror did not say what it recorded\n{}",
                mirror_err
            )
        });
    let replayed = err
        .lines()
        .find_map(|l| {
            l.strip_prefix("check: the ")?
                .split(' ')
                .next()?
                .parse::<u64>()
                .ok()
        })
        .unwrap_or_else(|| panic!("{name}: {err}"));
    // The start and every call of the replica.
    assert_eq!(replayed, recorded, "{name}: {err}");
    eprintln!("{name}: the mirror's recording replays and checks out ({replayed} steps)");
    replayed
}

/// A uvarint of the documented encoding (docs/mirror.md), read here
/// independently of the gateway's code.
pub fn uvarint(b: &[u8], at: &mut usize) -> Option<u64> {
    let mut v = 0u64;
    for i in 0..10 {
        let byte = *b.get(*at)?;
        *at += 1;
        v |= u64::from(byte & 0x7f) << (7 * i);
        if byte & 0x80 == 0 {
            return Some(v);
        }
    }
    None
}

/// Every frame the mirror sent: a MAVLink 2 TUNNEL from the mirror's
/// (system, component), Petrel's payload type, to the onboard gateway
/// (vehicle 1, component 191), holding only resync requests (kinds 5
/// resend, 6 snapshot, 8 heartbeat). Never a HEARTBEAT, never system 255.
pub fn only_resync_requests(frames: &[Vec<u8>]) -> usize {
    only_requests(frames, false)
}

/// [`only_resync_requests`], and with `uploads` the pieces of a version
/// sent up (kinds 11 offer, 12 piece), in signed frames only.
pub fn only_requests(frames: &[Vec<u8>], uploads: bool) -> usize {
    for bytes in frames {
        // MAVLink 2's incompatibility flags: 0x01, signed.
        let signed = bytes.first() == Some(&0xfd) && bytes.get(2).is_some_and(|f| f & 1 == 1);
        let f = elaboration::Frame::parse(bytes).expect("the mirror's frames are valid MAVLink");
        assert_eq!(
            f.message_id(),
            385,
            "the mirror sent message {}",
            f.message_id()
        );
        assert_eq!(
            (f.system_id(), f.component_id()),
            (MIRROR_SYSTEM, MIRROR_COMPONENT)
        );
        let p = f.payload();
        assert_eq!(u16::from_le_bytes([p[0], p[1]]), PAYLOAD_TYPE);
        assert_eq!((p[2], p[3]), (1, 191), "addressed to the onboard gateway");
        let len = usize::from(p[4]);
        let mut payload = p[5..].to_vec();
        payload.resize(128, 0);
        let payload = &payload[..len];
        assert_eq!(payload[0], 1, "layout version");
        let mut at = 1;
        while at < payload.len() {
            let kind = payload[at];
            at += 1;
            match kind {
                5 => {
                    uvarint(payload, &mut at).expect("from");
                    uvarint(payload, &mut at).expect("count");
                }
                6 => at += 4,
                8 => {
                    uvarint(payload, &mut at).expect("at");
                }
                11 if uploads && signed => {
                    uvarint(payload, &mut at).expect("upload");
                    uvarint(payload, &mut at).expect("length");
                    at += 32;
                }
                12 if uploads && signed => {
                    uvarint(payload, &mut at).expect("upload");
                    uvarint(payload, &mut at).expect("index");
                    let n = uvarint(payload, &mut at).expect("len");
                    at += n as usize;
                }
                k => panic!("the mirror sent a record of kind {k} (signed: {signed}): {payload:?}"),
            }
        }
        assert_eq!(at, payload.len());
    }
    frames.len()
}

/// (time, net, transition) of every firing in a timeline.
pub fn fired(lines: &[serde_json::Value]) -> Vec<String> {
    lines
        .iter()
        .filter(|l| l["effect"] == "fired")
        .map(|l| format!("{} {} {}", l["t"], l["net"], l["transition"]))
        .collect()
}

/// One downlink record, as the budget counts it.
#[derive(Debug, Clone, PartialEq)]
pub struct Down {
    /// 1 step, 2 heartbeat, 3 fragment, 4 snapshot chunk.
    pub kind: u8,
    /// A step's or fragment's record number.
    pub number: Option<u64>,
    /// The record's bytes, its kind byte included.
    pub len: usize,
    /// The name of a step's first input's event (`result` for an outcome,
    /// `answered` for an answer).
    pub first: Option<String>,
}

/// The records of a downlink TUNNEL (the frame's payload: payload type,
/// target system and component, length, payload), read by the documented
/// encoding (docs/mirror.md) independently of the gateway's code; `None`
/// when it is not Petrel's downlink or does not read.
pub fn downlink_records(p: &[u8]) -> Option<Vec<Down>> {
    if p.len() < 5 || u16::from_le_bytes([p[0], p[1]]) != PAYLOAD_TYPE {
        return None;
    }
    let len = usize::from(p[4]);
    let mut payload = p[5..].to_vec();
    payload.resize(128, 0);
    let b = &payload[..len];
    if b.first() != Some(&1) {
        return None;
    }
    let mut at = 1;
    let mut out = Vec::new();
    while at < b.len() {
        let start = at;
        let kind = b[at];
        at += 1;
        let (mut number, mut first) = (None, None);
        match kind {
            1 => {
                number = Some(uvarint(b, &mut at)?);
                first = step_rest(b, &mut at)?;
            }
            2 => {
                at += 4;
                for _ in 0..4 {
                    uvarint(b, &mut at)?;
                }
                at += 16;
            }
            3 => {
                number = Some(uvarint(b, &mut at)?);
                at += 2;
                let n = uvarint(b, &mut at)? as usize;
                at += n;
            }
            4 => {
                at += 4;
                uvarint(b, &mut at)?;
                at += 2;
                let n = uvarint(b, &mut at)? as usize;
                at += n;
            }
            _ => return None,
        }
        if at > b.len() {
            return None;
        }
        out.push(Down {
            kind,
            number,
            len: at - start,
            first,
        });
    }
    Some(out)
}

/// An ivarint (zigzag, then uvarint).
pub fn ivarint(b: &[u8], at: &mut usize) -> Option<i64> {
    let u = uvarint(b, at)?;
    Some((u >> 1) as i64 ^ -((u & 1) as i64))
}

/// A step record after its number: step, before, time − before, inputs,
/// digest; the first input's name.
fn step_rest(b: &[u8], at: &mut usize) -> Option<Option<String>> {
    uvarint(b, at)?;
    uvarint(b, at)?;
    ivarint(b, at)?;
    step_inputs(b, at)
}

/// `uvarint n, input × n, 8 bytes digest`: the first input's name.
fn step_inputs(b: &[u8], at: &mut usize) -> Option<Option<String>> {
    let n = uvarint(b, at)?;
    let mut first = None;
    for _ in 0..n {
        let tag = *b.get(*at)?;
        *at += 1;
        ivarint(b, at)?;
        let name = match tag {
            0 | 2 | 3 => {
                let name = string(b, at)?;
                *at += 1; // category
                params(b, at, 0)?;
                name
            }
            1 => {
                uvarint(b, at)?;
                let outcome = *b.get(*at)?;
                *at += 1;
                if outcome == 0 {
                    params(b, at, 0)?;
                } else {
                    string(b, at)?;
                }
                "result".to_owned()
            }
            4 => {
                uvarint(b, at)?;
                string(b, at)?;
                "answered".to_owned()
            }
            _ => return None,
        };
        first.get_or_insert(name);
    }
    *at += 8;
    Some(first)
}

fn string(b: &[u8], at: &mut usize) -> Option<String> {
    let n = uvarint(b, at)? as usize;
    let s = b.get(*at..*at + n)?;
    *at += n;
    Some(String::from_utf8_lossy(s).into_owned())
}

fn params(b: &[u8], at: &mut usize, depth: u8) -> Option<()> {
    let n = uvarint(b, at)?;
    for _ in 0..n {
        string(b, at)?;
        value(b, at, depth)?;
    }
    Some(())
}

fn value(b: &[u8], at: &mut usize, depth: u8) -> Option<()> {
    if depth > 16 {
        return None;
    }
    let tag = *b.get(*at)?;
    *at += 1;
    match tag {
        0 => *at += 1,
        1 => {
            ivarint(b, at)?;
        }
        2 => *at += 8,
        3 => {
            string(b, at)?;
        }
        4 => {
            for _ in 0..uvarint(b, at)? {
                value(b, at, depth + 1)?;
            }
        }
        5 => params(b, at, depth + 1)?,
        _ => return None,
    }
    Some(())
}
