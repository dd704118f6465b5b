//! The downlink's records and their encoding (docs/mirror.md, "The
//! encoding"): what the onboard gateway publishes so that the ground's
//! replica plays the same inputs at the same steps and times, and what the
//! mirror asks back. Pure: bytes in, records out, and back; no MAVLink (the
//! TUNNEL around a packet is `mirror::tunnel`'s), no clock.
//!
//! A packet is one TUNNEL payload (at most [`MAX_PACKET`] bytes):
//!
//! ```text
//! packet  = u8 version (1), record+
//! record  = u8 kind, body
//!   1 step       uvarint number, uvarint step, uvarint before, ivarint time-before,
//!                uvarint n, input × n, 8 bytes digest prefix
//!   2 heartbeat  u32 LE session, uvarint step, uvarint time, uvarint next,
//!                uvarint oldest, 16 bytes digest prefix
//!   3 fragment   uvarint number, u8 index, u8 count, uvarint len, bytes
//!                (a step record too long for one packet: its body, cut)
//!   4 chunk      u32 LE session, uvarint snapshot, u8 index, u8 count, uvarint len, bytes
//!   5 resend     uvarint from, uvarint count                  (uplink)
//!   6 snapshot?  u32 LE session                               (uplink)
//!   7 answer     uvarint id, str choice                       (uplink, only in
//!                a MAVLink 2 signed TUNNEL: `mirror::dialog`)
//!   8 heartbeat? uvarint time                                 (uplink: a heartbeat
//!                once the vehicle's time reaches `time`)
//!   9 boot       uvarint time, uvarint n, { uvarint lane, uvarint boot_ms } × n
//!                (after a heartbeat: at vehicle time `time`, the last
//!                `time_boot_ms` each lane's elaboration read of its autopilot)
//! input   = u8:0 ivarint dt, event               an event the elaboration produced
//!         | u8:5 ivarint dt, uvarint boot_ms, event   the same, with the autopilot's
//!                                                  clock when it fired (`time_boot_ms`)
//!         | u8:1 ivarint dt, uvarint id, outcome a call's or command's outcome
//!         | u8:2 ivarint dt, event               a program's event
//!         | u8:3 ivarint dt, event               (never produced; read, played as an event)
//!         | u8:4 ivarint dt, uvarint id, str choice   an operator's answer
//!         | u8:6 ivarint dt, uvarint number, 32 bytes files' digest
//!                                                  a new version of the project
//!                                                  took over (`crate::version`)
//!   dt = the input's time minus the step's `before`
//! outcome = u8:0 params | u8:1 str reason
//!   10 chunk of a version's snapshot: as 4, the snapshot joined below
//!                (once a new version of the project took over)
//! snapshot (the chunks' bytes, joined) = uvarint step, uvarint next,
//!          32 bytes digest, nets snapshot (nets::player::snapshot)
//!   of kind 10: uvarint step, uvarint next, uvarint version,
//!          32 bytes the version's files' digest, 32 bytes digest, nets snapshot
//! ```
//!
//! Numbers, strings, values and events are in `nets::binary`'s encoding.

use nets::binary::{DecodeError, Reader, Writer};
use nets::{Event, Micros, Outcome};

/// The layout version, the first byte of every packet.
pub const VERSION: u8 = 1;
/// A TUNNEL payload's size.
pub const MAX_PACKET: usize = 128;

/// One record.
#[derive(Debug, Clone, PartialEq)]
pub enum Record {
    Step(StepRecord),
    Heartbeat(Heartbeat),
    Fragment(Fragment),
    Chunk(Chunk),
    /// Uplink: send records `from .. from + count` again.
    Resend {
        from: u64,
        count: u64,
    },
    /// Uplink: send a snapshot of session `session` now.
    SendSnapshot {
        session: u32,
    },
    /// Uplink: send a heartbeat once the vehicle's time reaches `at` (the
    /// independent check's proof that no event came before it).
    SendHeartbeat {
        at: Micros,
    },
    /// How far each vehicle's autopilot clock the onboard elaboration has
    /// read by vehicle time `time` (sent with the heartbeats): by lane
    /// (the team's vehicles in order, 0 without a team), the last
    /// `time_boot_ms` heard, in µs (whole milliseconds).
    Boot {
        time: Micros,
        lanes: Vec<(u64, Micros)>,
    },
    /// Uplink, signed only: the operator's answer to question `id`.
    Answer {
        id: u64,
        choice: String,
    },
    /// Uplink, signed only: a new version of the project is sent up
    /// (`mirror::upload`): its upload number, the length of its bytes and
    /// their SHA-256.
    Upload {
        upload: u64,
        length: u64,
        digest: [u8; 32],
    },
    /// Uplink, signed only: bytes `index × PIECE ..` of upload `upload`.
    Piece {
        upload: u64,
        index: u64,
        data: Vec<u8>,
    },
    /// Downlink: how much of upload `upload` the vehicle holds: `have`
    /// pieces, and the first ranges still missing (`from`, `count`).
    Received {
        upload: u64,
        have: u64,
        missing: Vec<(u64, u64)>,
    },
    /// Downlink: part `part` of `parts` of the vehicle's verdict on upload
    /// `upload` (taken over at a step, or refused and why).
    Verdict {
        upload: u64,
        part: u8,
        parts: u8,
        text: String,
    },
}

/// The inputs of one onboard step that changed, or may have changed, the
/// player, with the player's time before it and the step's own.
#[derive(Debug, Clone, PartialEq)]
pub struct StepRecord {
    /// The record's number: 0, 1, 2… with no gap, per session.
    pub number: u64,
    /// The supervisor's step number (steps that changed nothing but the
    /// player's time send no record).
    pub step: u64,
    /// The player's time before the step.
    pub before: Micros,
    /// The step's time (the player is advanced to it after the inputs).
    pub time: Micros,
    pub inputs: Vec<Input>,
    /// The first bytes of the player's digest after the step.
    pub digest: [u8; 8],
}

/// One input of a step, with its time.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// An event the onboard elaboration produced, and the autopilot's
    /// clock when it did (`Elaborated::boot_us`), when known.
    Elaborated {
        time: Micros,
        boot: Option<Micros>,
        event: Event,
    },
    /// A call's or command's outcome.
    Result {
        time: Micros,
        id: u64,
        outcome: Outcome,
    },
    /// An event a software program sent (or `program_lost`).
    Program { time: Micros, event: Event },
    /// Never produced (an early placeholder for answers): read, and played
    /// as a plain event, which the player drops if it bears an answer's
    /// name.
    Answer { time: Micros, event: Event },
    /// The operator's answer to question `id` (the onboard gateway checked
    /// its signature): played as `Player::answer`.
    Answered {
        time: Micros,
        id: u64,
        choice: String,
    },
    /// A new version of the project took over (`crate::version`), named by
    /// its number and the digest of its files
    /// (`crate::version::digest`): the replica takes it over too, if it
    /// has it.
    Version {
        time: Micros,
        number: u32,
        digest: [u8; 32],
    },
}

/// The vehicle's step counter and digest, at least once a second.
#[derive(Debug, Clone, PartialEq)]
pub struct Heartbeat {
    /// The onboard gateway's run (a restart starts another).
    pub session: u32,
    pub step: u64,
    pub time: Micros,
    /// The number the next step record will get.
    pub next: u64,
    /// The oldest record the ring still holds (`next` when empty).
    pub oldest: u64,
    /// The first bytes of the player's digest after `step`.
    pub digest: [u8; 16],
}

/// A piece of a step record too long for one packet.
#[derive(Debug, Clone, PartialEq)]
pub struct Fragment {
    pub number: u64,
    pub index: u8,
    pub count: u8,
    pub data: Vec<u8>,
}

/// A piece of a snapshot.
#[derive(Debug, Clone, PartialEq)]
pub struct Chunk {
    pub session: u32,
    /// The snapshot's number in its session.
    pub snapshot: u64,
    pub index: u8,
    pub count: u8,
    pub data: Vec<u8>,
    /// A snapshot of a version that took over in flight (kind 10): it
    /// says which ([`Snapshot::version`]).
    pub versioned: bool,
}

/// A snapshot, whole: the player's state after `step`, and the number of
/// the first record after it.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    pub step: u64,
    pub next: u64,
    /// The project's version the state is of: `None` the one the run
    /// started with, else its number and files' digest.
    pub version: Option<(u32, [u8; 32])>,
    pub digest: [u8; 32],
    /// The state, in `nets::player::snapshot`'s encoding.
    pub state: Vec<u8>,
}

const STEP: u8 = 1;
const HEARTBEAT: u8 = 2;
const FRAGMENT: u8 = 3;
const CHUNK: u8 = 4;
const RESEND: u8 = 5;
const SEND_SNAPSHOT: u8 = 6;
const ANSWER: u8 = 7;
const SEND_HEARTBEAT: u8 = 8;
const BOOT: u8 = 9;
const VERSIONED_CHUNK: u8 = 10;
const UPLOAD: u8 = 11;
const PIECE: u8 = 12;
const RECEIVED: u8 = 13;
const VERDICT: u8 = 14;

/// Why a packet does not decode.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PacketError {
    #[error("empty packet")]
    Empty,
    #[error("packet layout version {0}; this build reads version {VERSION}")]
    Version(u8),
    #[error("unknown record kind {0}")]
    Kind(u8),
    #[error("{0}")]
    Decode(#[from] DecodeError),
}

/// Encodes one record (its kind byte first).
pub fn encode(record: &Record, w: &mut Writer) {
    match record {
        Record::Step(s) => {
            w.u8(STEP);
            step_body(s, w);
        }
        Record::Heartbeat(h) => {
            w.u8(HEARTBEAT);
            w.raw(&h.session.to_le_bytes());
            w.uvarint(h.step);
            w.uvarint(h.time);
            w.uvarint(h.next);
            w.uvarint(h.oldest);
            w.raw(&h.digest);
        }
        Record::Fragment(f) => {
            w.u8(FRAGMENT);
            w.uvarint(f.number);
            w.u8(f.index);
            w.u8(f.count);
            w.len(f.data.len());
            w.raw(&f.data);
        }
        Record::Chunk(c) => {
            w.u8(if c.versioned { VERSIONED_CHUNK } else { CHUNK });
            w.raw(&c.session.to_le_bytes());
            w.uvarint(c.snapshot);
            w.u8(c.index);
            w.u8(c.count);
            w.len(c.data.len());
            w.raw(&c.data);
        }
        Record::Resend { from, count } => {
            w.u8(RESEND);
            w.uvarint(*from);
            w.uvarint(*count);
        }
        Record::SendSnapshot { session } => {
            w.u8(SEND_SNAPSHOT);
            w.raw(&session.to_le_bytes());
        }
        Record::SendHeartbeat { at } => {
            w.u8(SEND_HEARTBEAT);
            w.uvarint(*at);
        }
        Record::Boot { time, lanes } => {
            w.u8(BOOT);
            w.uvarint(*time);
            w.len(lanes.len());
            for (lane, boot) in lanes {
                w.uvarint(*lane);
                w.uvarint(boot / 1000);
            }
        }
        Record::Answer { id, choice } => {
            w.u8(ANSWER);
            w.uvarint(*id);
            w.str(choice);
        }
        Record::Upload {
            upload,
            length,
            digest,
        } => {
            w.u8(UPLOAD);
            w.uvarint(*upload);
            w.uvarint(*length);
            w.raw(digest);
        }
        Record::Piece {
            upload,
            index,
            data,
        } => {
            w.u8(PIECE);
            w.uvarint(*upload);
            w.uvarint(*index);
            w.len(data.len());
            w.raw(data);
        }
        Record::Received {
            upload,
            have,
            missing,
        } => {
            w.u8(RECEIVED);
            w.uvarint(*upload);
            w.uvarint(*have);
            w.len(missing.len());
            for (from, count) in missing {
                w.uvarint(*from);
                w.uvarint(*count);
            }
        }
        Record::Verdict {
            upload,
            part,
            parts,
            text,
        } => {
            w.u8(VERDICT);
            w.uvarint(*upload);
            w.u8(*part);
            w.u8(*parts);
            w.str(text);
        }
    }
}

/// The bytes of a step record's body (what fragments carry).
pub fn step_body(s: &StepRecord, w: &mut Writer) {
    w.uvarint(s.number);
    w.uvarint(s.step);
    w.uvarint(s.before);
    w.ivarint(delta(s.time, s.before));
    w.len(s.inputs.len());
    for input in &s.inputs {
        match input {
            Input::Elaborated { time, boot, event } => {
                w.u8(if boot.is_some() { 5 } else { 0 });
                w.ivarint(delta(*time, s.before));
                if let Some(boot) = boot {
                    w.uvarint(boot / 1000);
                }
                w.event(event);
            }
            Input::Result { time, id, outcome } => {
                w.u8(1);
                w.ivarint(delta(*time, s.before));
                w.uvarint(*id);
                match outcome {
                    Outcome::Done(params) => {
                        w.u8(0);
                        w.params(params);
                    }
                    Outcome::Failed(reason) => {
                        w.u8(1);
                        w.str(reason);
                    }
                }
            }
            Input::Program { time, event } => {
                w.u8(2);
                w.ivarint(delta(*time, s.before));
                w.event(event);
            }
            Input::Answer { time, event } => {
                w.u8(3);
                w.ivarint(delta(*time, s.before));
                w.event(event);
            }
            Input::Answered { time, id, choice } => {
                w.u8(4);
                w.ivarint(delta(*time, s.before));
                w.uvarint(*id);
                w.str(choice);
            }
            Input::Version {
                time,
                number,
                digest,
            } => {
                w.u8(6);
                w.ivarint(delta(*time, s.before));
                w.uvarint(u64::from(*number));
                w.raw(digest);
            }
        }
    }
    w.raw(&s.digest);
}

fn delta(t: Micros, base: Micros) -> i64 {
    (t as i128 - base as i128).clamp(i64::MIN as i128, i64::MAX as i128) as i64
}

fn offset(r: &Reader, base: Micros, dt: i64) -> Result<Micros, DecodeError> {
    base.checked_add_signed(dt)
        .ok_or_else(|| r.invalid("a time out of range"))
}

/// Decodes a step record's body.
pub fn decode_step(r: &mut Reader) -> Result<StepRecord, DecodeError> {
    let number = r.uvarint()?;
    let step = r.uvarint()?;
    let before = r.uvarint()?;
    let dt = r.ivarint()?;
    let time = offset(r, before, dt)?;
    let n = r.count(3)?;
    let mut inputs = Vec::with_capacity(n);
    for _ in 0..n {
        let tag = r.u8()?;
        let dt = r.ivarint()?;
        let time = offset(r, before, dt)?;
        inputs.push(match tag {
            0 => Input::Elaborated {
                time,
                boot: None,
                event: r.event()?,
            },
            5 => Input::Elaborated {
                time,
                boot: Some(
                    r.uvarint()?
                        .checked_mul(1000)
                        .ok_or_else(|| r.invalid("an autopilot time out of range"))?,
                ),
                event: r.event()?,
            },
            1 => {
                let id = r.uvarint()?;
                let outcome = match r.u8()? {
                    0 => Outcome::Done(r.params()?),
                    1 => Outcome::Failed(r.str()?),
                    _ => return Err(r.invalid("an unknown outcome")),
                };
                Input::Result { time, id, outcome }
            }
            2 => Input::Program {
                time,
                event: r.event()?,
            },
            3 => Input::Answer {
                time,
                event: r.event()?,
            },
            4 => Input::Answered {
                time,
                id: r.uvarint()?,
                choice: r.str()?,
            },
            6 => Input::Version {
                time,
                number: u32::try_from(r.uvarint()?)
                    .map_err(|_| r.invalid("a version number out of range"))?,
                digest: r
                    .raw(32)?
                    .try_into()
                    .map_err(|_| r.invalid("a version's digest"))?,
            },
            _ => return Err(r.invalid("an unknown input")),
        });
    }
    let digest = r.raw(8)?.try_into().map_err(|_| r.invalid("a digest"))?;
    Ok(StepRecord {
        number,
        step,
        before,
        time,
        inputs,
        digest,
    })
}

fn session(r: &mut Reader) -> Result<u32, DecodeError> {
    let b: [u8; 4] = r.raw(4)?.try_into().map_err(|_| r.invalid("a session"))?;
    Ok(u32::from_le_bytes(b))
}

/// A fragment's or chunk's `u8 index, u8 count, uvarint len, bytes`.
fn piece(r: &mut Reader) -> Result<(u8, u8, Vec<u8>), DecodeError> {
    let (index, count) = (r.u8()?, r.u8()?);
    if index >= count {
        return Err(r.invalid("a piece's index beyond its count"));
    }
    let n = r.count(1)?;
    Ok((index, count, r.raw(n)?.to_vec()))
}

fn decode_one(r: &mut Reader) -> Result<Record, PacketError> {
    let kind = r.u8()?;
    Ok(match kind {
        STEP => Record::Step(decode_step(r)?),
        HEARTBEAT => Record::Heartbeat(Heartbeat {
            session: session(r)?,
            step: r.uvarint()?,
            time: r.uvarint()?,
            next: r.uvarint()?,
            oldest: r.uvarint()?,
            digest: r.raw(16)?.try_into().map_err(|_| r.invalid("a digest"))?,
        }),
        FRAGMENT => {
            let number = r.uvarint()?;
            let (index, count, data) = piece(r)?;
            Record::Fragment(Fragment {
                number,
                index,
                count,
                data,
            })
        }
        CHUNK | VERSIONED_CHUNK => {
            let session = session(r)?;
            let snapshot = r.uvarint()?;
            let (index, count, data) = piece(r)?;
            Record::Chunk(Chunk {
                session,
                snapshot,
                index,
                count,
                data,
                versioned: kind == VERSIONED_CHUNK,
            })
        }
        RESEND => Record::Resend {
            from: r.uvarint()?,
            count: r.uvarint()?,
        },
        SEND_SNAPSHOT => Record::SendSnapshot {
            session: session(r)?,
        },
        ANSWER => Record::Answer {
            id: r.uvarint()?,
            choice: r.str()?,
        },
        SEND_HEARTBEAT => Record::SendHeartbeat { at: r.uvarint()? },
        BOOT => {
            let time = r.uvarint()?;
            let n = r.count(2)?;
            let mut lanes = Vec::with_capacity(n);
            for _ in 0..n {
                let lane = r.uvarint()?;
                let boot = r
                    .uvarint()?
                    .checked_mul(1000)
                    .ok_or_else(|| r.invalid("an autopilot time out of range"))?;
                lanes.push((lane, boot));
            }
            Record::Boot { time, lanes }
        }
        UPLOAD => Record::Upload {
            upload: r.uvarint()?,
            length: r.uvarint()?,
            digest: r
                .raw(32)?
                .try_into()
                .map_err(|_| r.invalid("an upload's digest"))?,
        },
        PIECE => {
            let upload = r.uvarint()?;
            let index = r.uvarint()?;
            let n = r.count(1)?;
            Record::Piece {
                upload,
                index,
                data: r.raw(n)?.to_vec(),
            }
        }
        RECEIVED => {
            let upload = r.uvarint()?;
            let have = r.uvarint()?;
            let n = r.count(2)?;
            let mut missing = Vec::with_capacity(n);
            for _ in 0..n {
                missing.push((r.uvarint()?, r.uvarint()?));
            }
            Record::Received {
                upload,
                have,
                missing,
            }
        }
        VERDICT => Record::Verdict {
            upload: r.uvarint()?,
            part: r.u8()?,
            parts: r.u8()?,
            text: r.str()?,
        },
        k => return Err(PacketError::Kind(k)),
    })
}

/// Decodes a packet: its records, in order, or why none is taken.
pub fn decode_packet(bytes: &[u8]) -> Result<Vec<Record>, PacketError> {
    let (&version, body) = bytes.split_first().ok_or(PacketError::Empty)?;
    if version != VERSION {
        return Err(PacketError::Version(version));
    }
    let mut r = Reader::new(body);
    let mut records = Vec::new();
    while !r.is_empty() {
        records.push(decode_one(&mut r)?);
    }
    if records.is_empty() {
        return Err(PacketError::Empty);
    }
    Ok(records)
}

/// One packet holding `records` (the caller keeps it under [`MAX_PACKET`]).
pub fn packet(records: &[Record]) -> Vec<u8> {
    let mut w = Writer::new();
    w.u8(VERSION);
    for r in records {
        encode(r, &mut w);
    }
    w.bytes
}

/// The encoded size of one record.
pub fn size(record: &Record) -> usize {
    let mut w = Writer::new();
    encode(record, &mut w);
    w.bytes.len()
}

impl Snapshot {
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::new();
        w.uvarint(self.step);
        w.uvarint(self.next);
        if let Some((number, digest)) = &self.version {
            w.uvarint(u64::from(*number));
            w.raw(digest);
        }
        w.raw(&self.digest);
        w.raw(&self.state);
        w.bytes
    }

    /// Decodes a snapshot's joined chunks (`versioned`: of kind 10).
    pub fn decode(bytes: &[u8], versioned: bool) -> Result<Snapshot, DecodeError> {
        let mut r = Reader::new(bytes);
        let step = r.uvarint()?;
        let next = r.uvarint()?;
        let version = match versioned {
            false => None,
            true => Some((
                u32::try_from(r.uvarint()?)
                    .map_err(|_| r.invalid("a version number out of range"))?,
                r.raw(32)?
                    .try_into()
                    .map_err(|_| r.invalid("a version's digest"))?,
            )),
        };
        let digest = r.raw(32)?.try_into().map_err(|_| r.invalid("a digest"))?;
        let state = r.raw(r.remaining())?.to_vec();
        Ok(Snapshot {
            step,
            next,
            version,
            digest,
            state,
        })
    }
}

/// Cuts `bytes` into pieces that fit a packet beside a record header of
/// `header` bytes: at most 255 pieces (`None` when that is not enough).
pub fn pieces(bytes: &[u8], header: usize) -> Option<Vec<Vec<u8>>> {
    // version byte, kind, header, u8 index, u8 count, a two-byte length.
    let room = MAX_PACKET - 1 - 1 - header - 2 - 2;
    let pieces: Vec<Vec<u8>> = if bytes.is_empty() {
        vec![Vec::new()]
    } else {
        bytes.chunks(room).map(<[u8]>::to_vec).collect()
    };
    (pieces.len() <= 255).then_some(pieces)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nets::{Category, Params, Value};
    use proptest::prelude::*;

    fn event() -> impl Strategy<Value = Event> {
        (
            "[a-z_.]{1,20}",
            0usize..5,
            prop::collection::btree_map(
                "[a-z]{1,6}",
                prop_oneof![
                    any::<bool>().prop_map(Value::Bool),
                    any::<i64>().prop_map(Value::Int),
                    any::<f64>().prop_map(Value::Float),
                    "\\PC{0,8}".prop_map(Value::Str),
                ],
                0..4,
            ),
        )
            .prop_map(|(name, c, params)| Event {
                name,
                category: Category::ALL[c],
                params,
            })
    }

    fn input() -> impl Strategy<Value = Input> {
        let t = 0u64..u64::MAX / 2;
        prop_oneof![
            (
                t.clone(),
                proptest::option::of(0..u64::from(u32::MAX)),
                event()
            )
                .prop_map(|(time, boot, event)| Input::Elaborated {
                    time,
                    boot: boot.map(|ms| ms * 1000),
                    event
                }),
            (t.clone(), any::<u64>(), any::<bool>(), "[a-z ]{0,12}").prop_map(
                |(time, id, ok, reason)| Input::Result {
                    time,
                    id,
                    outcome: if ok {
                        Outcome::Done(Params::from([("x".into(), Value::Int(3))]))
                    } else {
                        Outcome::Failed(reason)
                    },
                }
            ),
            (t.clone(), event()).prop_map(|(time, event)| Input::Program { time, event }),
            (t.clone(), event()).prop_map(|(time, event)| Input::Answer { time, event }),
            (t.clone(), any::<u64>(), "[a-z_]{1,8}")
                .prop_map(|(time, id, choice)| { Input::Answered { time, id, choice } }),
            (t, any::<u32>(), any::<[u8; 32]>()).prop_map(|(time, number, digest)| {
                Input::Version {
                    time,
                    number,
                    digest,
                }
            }),
        ]
    }

    fn record() -> impl Strategy<Value = Record> {
        let t = 0u64..u64::MAX / 2;
        prop_oneof![
            (any::<u64>(), "[a-z_]{1,8}").prop_map(|(id, choice)| Record::Answer { id, choice }),
            (
                any::<u64>(),
                any::<u64>(),
                t.clone(),
                t.clone(),
                prop::collection::vec(input(), 0..3),
                any::<[u8; 8]>()
            )
                .prop_map(|(number, step, before, time, inputs, digest)| {
                    Record::Step(StepRecord {
                        number,
                        step,
                        before,
                        time,
                        inputs,
                        digest,
                    })
                }),
            (
                any::<u32>(),
                any::<u64>(),
                any::<u64>(),
                any::<u64>(),
                any::<u64>(),
                any::<[u8; 16]>()
            )
                .prop_map(|(session, step, time, next, oldest, digest)| {
                    Record::Heartbeat(Heartbeat {
                        session,
                        step,
                        time,
                        next,
                        oldest,
                        digest,
                    })
                }),
            (
                any::<u64>(),
                0u8..10,
                prop::collection::vec(any::<u8>(), 0..40)
            )
                .prop_map(|(number, index, data)| Record::Fragment(Fragment {
                    number,
                    index,
                    count: index + 1,
                    data
                })),
            (
                any::<u32>(),
                any::<u64>(),
                0u8..10,
                prop::collection::vec(any::<u8>(), 0..40),
                any::<bool>()
            )
                .prop_map(|(session, snapshot, index, data, versioned)| {
                    Record::Chunk(Chunk {
                        session,
                        snapshot,
                        index,
                        count: index + 1,
                        data,
                        versioned,
                    })
                }),
            (any::<u64>(), any::<u64>()).prop_map(|(from, count)| Record::Resend { from, count }),
            any::<u32>().prop_map(|session| Record::SendSnapshot { session }),
            (any::<u64>(), any::<u64>(), any::<[u8; 32]>()).prop_map(|(upload, length, digest)| {
                Record::Upload {
                    upload,
                    length,
                    digest,
                }
            }),
            (
                any::<u64>(),
                any::<u64>(),
                prop::collection::vec(any::<u8>(), 0..60)
            )
                .prop_map(|(upload, index, data)| Record::Piece {
                    upload,
                    index,
                    data
                }),
            (
                any::<u64>(),
                any::<u64>(),
                prop::collection::vec((any::<u64>(), any::<u64>()), 0..4)
            )
                .prop_map(|(upload, have, missing)| Record::Received {
                    upload,
                    have,
                    missing
                }),
            (any::<u64>(), any::<u8>(), any::<u8>(), "[a-z ]{0,30}").prop_map(
                |(upload, part, parts, text)| Record::Verdict {
                    upload,
                    part,
                    parts,
                    text
                }
            ),
            any::<u64>().prop_map(|at| Record::SendHeartbeat { at }),
            (
                any::<u64>(),
                prop::collection::vec((0u64..300, 0..u64::from(u32::MAX)), 0..4)
            )
                .prop_map(|(time, lanes)| Record::Boot {
                    time,
                    lanes: lanes.into_iter().map(|(l, ms)| (l, ms * 1000)).collect()
                }),
        ]
    }

    proptest! {
        #[test]
        fn packets_round_trip(records in prop::collection::vec(record(), 1..4)) {
            let bytes = packet(&records);
            let back = decode_packet(&bytes).expect("decodes");
            // Floats compare by bits: NaN payloads survive too.
            prop_assert_eq!(packet(&back), bytes);
            prop_assert_eq!(format!("{back:?}"), format!("{records:?}"));
        }

        #[test]
        fn corrupt_packets_never_panic(
            records in prop::collection::vec(record(), 1..3),
            flips in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..4),
            cut in any::<prop::sample::Index>(),
            garbage in prop::collection::vec(any::<u8>(), 0..130),
        ) {
            let mut bytes = packet(&records);
            for (at, x) in &flips {
                let i = at.index(bytes.len());
                bytes[i] ^= x;
            }
            let _ = decode_packet(&bytes);
            let good = packet(&records);
            let cut = cut.index(good.len());
            // Cut short: refused, or fewer records (cut between two).
            prop_assert!(decode_packet(&good[..cut]).map_or(true, |r| r.len() < records.len()));
            let _ = decode_packet(&garbage);
        }
    }

    #[test]
    fn an_answer_is_laid_out_as_documented() {
        // docs/mirror.md: version 1, kind 7, uvarint id, str choice (the
        // fuzz corpus's `packet-answer`).
        let bytes = [0x01, 0x07, 0x05, 0x03, b'y', b'e', b's'];
        let answer = Record::Answer {
            id: 5,
            choice: "yes".into(),
        };
        assert_eq!(packet(std::slice::from_ref(&answer)), bytes);
        assert_eq!(decode_packet(&bytes).ok(), Some(vec![answer]));
    }

    #[test]
    fn other_versions_and_kinds_are_refused() {
        assert_eq!(decode_packet(&[]), Err(PacketError::Empty));
        assert_eq!(decode_packet(&[1]), Err(PacketError::Empty));
        assert_eq!(decode_packet(&[2, 5, 0, 0]), Err(PacketError::Version(2)));
        assert_eq!(decode_packet(&[1, 99]), Err(PacketError::Kind(99)));
    }

    #[test]
    fn a_heartbeat_costs_little() {
        // Twelve minutes into a flight, 40 000 steps, 200 records.
        let h = Record::Heartbeat(Heartbeat {
            session: 7,
            step: 40_000,
            time: 720_000_000,
            next: 200,
            oldest: 0,
            digest: [0xab; 16],
        });
        assert_eq!(size(&h), 1 + 4 + 3 + 5 + 2 + 1 + 16);
    }
}
