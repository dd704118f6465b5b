//! The digest of a player's state: SHA-256 over a canonical byte layout, so
//! that it is the same across builds and machines, and equal on two players
//! iff their states are equal.
//!
//! The layout (all integers little-endian; `str` is a u32 byte length then
//! UTF-8; documented in docs/nets.md, "The state digest"):
//!
//! ```text
//! "petrel.player.state" u8:1                      magic and layout version
//! u64 now, u8 lockout                             0 none, 1 the team's;
//!     2 | team: u32 n, u32 vehicle × n follow (the vehicles locked out,
//!     ascending; a state without a vehicle's lockout hashes as before)
//! u32 words, u64 × words                          marking bitset (flat places)
//! u32 nets, u8 × nets                             active flags
//! u32 timers, { u32 net, u32 timer, u64 deadline, u64 seq, u8 catastrophic } × timers
//! 5 × ( u32 len, { event, u8 has_target, u32 target } × len )   queues, catastrophic first
//! u32 pending, { u64 id, u32 net, u8 catastrophic, kind } × pending   by id
//!     kind = u8:0 u32 program u32 function | u8:1 str verb | u8:2 u32 ask
//! u64 next_id, u64 next_timer_seq
//! event = str name, u8 category (0 catastrophic … 4 nominal), params
//! params = u32 n, { str key, value } × n          keys in order
//! value = u8:0 u8 bool | u8:1 i64 | u8:2 u64 float bits | u8:3 str | u8:4 u32 n value×n | u8:5 params
//! ```

use std::fmt;

use sha2::{Digest as _, Sha256};

use super::state::{PendingKind, State};
use crate::event::Event;
use crate::value::{Params, Value};

/// The hash algorithm of [`Digest`].
pub const DIGEST_ALGORITHM: &str = "SHA-256";

/// A state digest; displays as 64 lowercase hex digits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Digest(pub [u8; 32]);

impl fmt::Display for Digest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for b in self.0 {
            write!(f, "{b:02x}")?;
        }
        Ok(())
    }
}

/// The canonical bytes of a state (what the digest hashes).
pub fn canonical_bytes(state: &State) -> Vec<u8> {
    let mut w = Writer(Vec::with_capacity(256));
    w.0.extend_from_slice(b"petrel.player.state");
    w.u8(1);
    w.u64(state.now);
    if state.locked.is_empty() {
        w.u8(state.lockout.into());
    } else {
        w.u8(2 | u8::from(state.lockout));
        w.u32(state.locked.len());
        for v in &state.locked {
            w.u32(*v);
        }
    }
    w.u32(state.marking.len());
    for word in &state.marking {
        w.u64(*word);
    }
    w.u32(state.active.len());
    for a in &state.active {
        w.u8((*a).into());
    }
    w.u32(state.timers.len());
    for t in &state.timers {
        w.u32(t.net);
        w.u32(t.timer);
        w.u64(t.deadline);
        w.u64(t.seq);
        w.u8(t.catastrophic.into());
    }
    for queue in &state.queue {
        w.u32(queue.len());
        for q in queue {
            w.event(&q.event);
            w.u8(q.target.is_some().into());
            w.u32(q.target.unwrap_or(0));
        }
    }
    w.u32(state.pending.len());
    for (id, p) in &state.pending {
        w.u64(*id);
        w.u32(p.net);
        w.u8(p.catastrophic.into());
        match &p.kind {
            PendingKind::Call { program, function } => {
                w.u8(0);
                w.u32(*program);
                w.u32(*function);
            }
            PendingKind::Command { verb } => {
                w.u8(1);
                w.str(verb);
            }
            PendingKind::Question { ask } => {
                w.u8(2);
                w.u32(*ask);
            }
        }
    }
    w.u64(state.next_id);
    w.u64(state.next_timer_seq);
    w.0
}

/// The digest of a state.
pub fn digest(state: &State) -> Digest {
    Digest(Sha256::digest(canonical_bytes(state)).into())
}

struct Writer(Vec<u8>);

impl Writer {
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn u32(&mut self, v: usize) {
        self.0.extend_from_slice(&(v as u32).to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn str(&mut self, s: &str) {
        self.u32(s.len());
        self.0.extend_from_slice(s.as_bytes());
    }
    fn event(&mut self, e: &Event) {
        self.str(&e.name);
        self.u8(e.category.priority() as u8);
        self.params(&e.params);
    }
    fn params(&mut self, params: &Params) {
        self.u32(params.len());
        for (k, v) in params {
            self.str(k);
            self.value(v);
        }
    }
    fn value(&mut self, v: &Value) {
        match v {
            Value::Bool(b) => {
                self.u8(0);
                self.u8((*b).into());
            }
            Value::Int(i) => {
                self.u8(1);
                self.0.extend_from_slice(&i.to_le_bytes());
            }
            Value::Float(f) => {
                self.u8(2);
                self.u64(f.to_bits());
            }
            Value::Str(s) => {
                self.u8(3);
                self.str(s);
            }
            Value::List(l) => {
                self.u8(4);
                self.u32(l.len());
                for v in l {
                    self.value(v);
                }
            }
            Value::Map(m) => {
                self.u8(5);
                self.params(m);
            }
        }
    }
}
