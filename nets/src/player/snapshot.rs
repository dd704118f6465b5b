//! Snapshots: a player's whole [`State`] in a compact, versioned binary
//! encoding, lossless both ways (`decode(encode(s)) == s`, and bytes that
//! decode encode back to themselves), refusing anything else with a reason
//! and never panicking. The ground mirror sends them down to restore its
//! replica (docs/mirror.md, "Snapshots"); [`crate::Player::restore`] then
//! checks that the state fits the project.
//!
//! The layout, in the [`crate::binary`] vocabulary:
//!
//! ```text
//! u8:1                                               version
//! uvarint now, u8 lockout                           0 none, 1 the team's;
//!     2 | team: vehicles locked out follow: uvarint n, uvarint vehicle × n,
//!     ascending (added without a version bump: states without a vehicle's
//!     lockout encode as before, and an older reader refuses 2 and 3 as
//!     booleans)
//! uvarint words, u64 LE × words                      marking bitset (flat places)
//! uvarint nets, ceil(nets/8) bytes                   active flags, bit i of byte i/8
//! uvarint timers, { uvarint net, uvarint timer, uvarint deadline, uvarint seq,
//!                   bool catastrophic } × timers
//! 5 × ( uvarint len, { event, u8:0 | u8:1 uvarint target } × len )
//!                                                    queues, catastrophic first
//! uvarint pending, { uvarint id, uvarint net, bool catastrophic, kind } × pending
//!     kind = u8:0 uvarint program uvarint function | u8:1 str verb
//!          | u8:2 uvarint ask              (a question; added without a version
//!            bump: states without questions encode as before, and an older
//!            reader refuses kind 2 as an unknown pending kind)
//!     ids strictly increasing
//! uvarint next_id, uvarint next_timer_seq
//! ```

use std::collections::{BTreeMap, VecDeque};

use super::state::{Pending, PendingKind, Queued, State, Timer};
use crate::binary::{DecodeError, Reader, Writer};

/// The digest of a state (what [`crate::Player::digest`] gives for a player
/// in that state), to check a decoded snapshot against the digest sent with
/// it.
pub use super::digest::digest;

/// The snapshot layout's version byte.
pub const SNAPSHOT_VERSION: u8 = 1;

/// Why bytes are not a snapshot.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SnapshotError {
    #[error("snapshot layout version {0}; this build reads version {SNAPSHOT_VERSION}")]
    Version(u8),
    #[error("corrupt snapshot: {0}")]
    Corrupt(#[from] DecodeError),
}

/// Encodes a state.
pub fn encode(state: &State) -> Vec<u8> {
    let mut w = Writer::new();
    encode_into(state, &mut w);
    w.bytes
}

/// Encodes a state at the end of `w`.
pub fn encode_into(state: &State, w: &mut Writer) {
    // Destructured so that a field added to `State` does not compile until
    // it is encoded here too.
    let State {
        now,
        marking,
        active,
        timers,
        queue,
        lockout,
        locked,
        pending,
        next_id,
        next_timer_seq,
    } = state;
    w.u8(SNAPSHOT_VERSION);
    w.uvarint(*now);
    if locked.is_empty() {
        w.bool(*lockout);
    } else {
        w.u8(2 | u8::from(*lockout));
        w.len(locked.len());
        for v in locked {
            w.len(*v);
        }
    }
    w.len(marking.len());
    for word in marking {
        w.u64_le(*word);
    }
    w.len(active.len());
    for byte in active.chunks(8) {
        w.u8(byte
            .iter()
            .enumerate()
            .fold(0u8, |b, (i, on)| b | (u8::from(*on) << i)));
    }
    w.len(timers.len());
    for t in timers {
        let Timer {
            net,
            timer,
            deadline,
            seq,
            catastrophic,
        } = t;
        w.len(*net);
        w.len(*timer);
        w.uvarint(*deadline);
        w.uvarint(*seq);
        w.bool(*catastrophic);
    }
    for q in queue {
        w.len(q.len());
        for Queued { event, target } in q {
            w.event(event);
            match target {
                None => w.u8(0),
                Some(t) => {
                    w.u8(1);
                    w.len(*t);
                }
            }
        }
    }
    w.len(pending.len());
    for (id, p) in pending {
        let Pending {
            net,
            kind,
            catastrophic,
        } = p;
        w.uvarint(*id);
        w.len(*net);
        w.bool(*catastrophic);
        match kind {
            PendingKind::Call { program, function } => {
                w.u8(0);
                w.len(*program);
                w.len(*function);
            }
            PendingKind::Command { verb } => {
                w.u8(1);
                w.str(verb);
            }
            PendingKind::Question { ask } => {
                w.u8(2);
                w.len(*ask);
            }
        }
    }
    w.uvarint(*next_id);
    w.uvarint(*next_timer_seq);
}

/// Decodes a whole snapshot (every byte must belong to it).
pub fn decode(bytes: &[u8]) -> Result<State, SnapshotError> {
    let mut r = Reader::new(bytes);
    let state = decode_from(&mut r)?;
    r.finish()?;
    Ok(state)
}

/// Decodes a snapshot from `r`, leaving what follows it.
pub fn decode_from(r: &mut Reader) -> Result<State, SnapshotError> {
    let version = r.u8()?;
    if version != SNAPSHOT_VERSION {
        return Err(SnapshotError::Version(version));
    }
    let now = r.uvarint()?;
    let (lockout, locked) = match r.u8()? {
        byte @ (0 | 1) => (byte == 1, Vec::new()),
        byte @ (2 | 3) => {
            let n = r.count(1)?;
            if n == 0 {
                return Err(r.invalid("an empty list of vehicles locked out").into());
            }
            let mut locked: Vec<usize> = Vec::with_capacity(n);
            for _ in 0..n {
                let v = r.index(usize::MAX)?;
                if locked.last().is_some_and(|&l| l >= v) {
                    return Err(r.invalid("vehicles locked out out of order").into());
                }
                locked.push(v);
            }
            (byte == 3, locked)
        }
        _ => return Err(r.invalid("an unknown lockout").into()),
    };
    let words = r.count(8)?;
    let mut marking = Vec::with_capacity(words);
    for _ in 0..words {
        marking.push(r.u64_le()?);
    }
    let nets = r.uvarint()?;
    if nets.div_ceil(8) > r.remaining() as u64 {
        return Err(r.invalid("more nets than the bytes left").into());
    }
    let nets = nets as usize;
    let flags = r.raw(nets.div_ceil(8))?;
    let spare = nets % 8;
    if spare != 0 && flags[flags.len() - 1] >> spare != 0 {
        return Err(r.invalid("active flags beyond the last net").into());
    }
    let active = (0..nets)
        .map(|i| flags[i / 8] & (1 << (i % 8)) != 0)
        .collect();
    let n = r.count(5)?;
    let mut timers = Vec::with_capacity(n);
    for _ in 0..n {
        timers.push(Timer {
            net: r.index(usize::MAX)?,
            timer: r.index(usize::MAX)?,
            deadline: r.uvarint()?,
            seq: r.uvarint()?,
            catastrophic: r.bool()?,
        });
    }
    let mut queue: [VecDeque<Queued>; 5] = Default::default();
    for (priority, q) in queue.iter_mut().enumerate() {
        let n = r.count(4)?;
        for _ in 0..n {
            let event = r.event()?;
            if event.category.priority() != priority {
                return Err(r
                    .invalid("a queued event in another category's queue")
                    .into());
            }
            let target = match r.u8()? {
                0 => None,
                1 => Some(r.index(usize::MAX)?),
                _ => return Err(r.invalid("an unknown target tag").into()),
            };
            q.push_back(Queued { event, target });
        }
    }
    let n = r.count(5)?;
    let mut pending = BTreeMap::new();
    let mut last = None;
    for _ in 0..n {
        let id = r.uvarint()?;
        if last.is_some_and(|l| l >= id) {
            return Err(r.invalid("pending ids out of order").into());
        }
        last = Some(id);
        let net = r.index(usize::MAX)?;
        let catastrophic = r.bool()?;
        let kind = match r.u8()? {
            0 => PendingKind::Call {
                program: r.index(usize::MAX)?,
                function: r.index(usize::MAX)?,
            },
            1 => PendingKind::Command { verb: r.str()? },
            2 => PendingKind::Question {
                ask: r.index(usize::MAX)?,
            },
            _ => return Err(r.invalid("an unknown pending kind").into()),
        };
        pending.insert(
            id,
            Pending {
                net,
                kind,
                catastrophic,
            },
        );
    }
    let next_id = r.uvarint()?;
    let next_timer_seq = r.uvarint()?;
    Ok(State {
        now,
        marking,
        active,
        timers,
        queue,
        lockout,
        locked,
        pending,
        next_id,
        next_timer_seq,
    })
}
