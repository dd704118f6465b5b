//! The project explorer's abstract states as bytes, and where they are
//! kept.
//!
//! An abstract state is the player's state with time taken out (see
//! [`super::project`]): no `now`, each timer's duration instead of its
//! deadline and the step that started it (its *group*), ids and timer
//! sequence numbers renumbered in order, pending calls whose result nothing
//! awaits dropped, at most [`MAX_SAME_PENDING`] identical ones kept. Its
//! [`Codec`] writes it as a compact key straight from the player's borrowed
//! state (no copy of the state per step: only a successor never seen before
//! is ever rebuilt), and reads a key back into the [`State`] the player
//! restores. The [`KeyStore`] keeps every key once, back to back, with an
//! open-addressing table of indices (no allocation per state).
//!
//! Key layout (little-endian): the marking words (u64 each), one byte per
//! net (active), the lockout byte (1: the team's; 2 | team: then u32
//! vehicles and the u32 vehicles locked out one by one), u32 timers then per timer `u32 net, u32
//! timer, u64 duration, u32 rank, u8 catastrophic, u32 group`, u32 pending
//! then per pending (in id order; for a team's reduced exploration, in the
//! order of their bytes, and a timer's rank is then its start order within
//! its group only: orders the player cannot tell apart, which would keep
//! apart states partial-order reduction must find equal) `u32 net, u8 catastrophic` and its kind (`0, u32
//! program, u32 function` for a call; `1, u32 verb` for a command whose verb
//! the project's actions name; `2, u32 length, bytes` for any other). The
//! marking and the active flags are at fixed offsets: [`Codec::marked`] and
//! [`Codec::active`] read them without decoding.

use std::hash::BuildHasher;

use hashbrown::HashTable;
use smallvec::SmallVec;

use crate::model::{Action, NetId, Project};
use crate::player::{Pending, PendingKind, State, Timer};
use crate::time::Micros;

/// How many identical pending calls (same net, same function or verb) an
/// abstract state keeps: more copies add no behaviour a step can tell apart
/// except how many results may still come, and would make the state space
/// infinite for nets that never collect a result.
pub(super) const MAX_SAME_PENDING: usize = 2;

/// The group of a timer started by the step being encoded.
const FRESH: u32 = u32::MAX;

/// An abstract state, decoded: the player's state to restore (`now` 0, each
/// timer's `deadline` its duration, timers in net and timer order) and per
/// timer the step that started it.
pub(super) struct Abs {
    pub state: State,
    pub groups: Vec<u32>,
}

/// Reusable buffers of [`Codec::encode`].
#[derive(Default)]
pub(super) struct Scratch {
    timers: Vec<(Timer, u32)>,
    seqs: Vec<u64>,
    groups: Vec<(u32, u32)>,
}

/// Writes and reads abstract states for one project.
pub(super) struct Codec {
    words: usize,
    nets: usize,
    /// Every verb the project's actions command, sorted, and their numbers.
    verbs: Vec<String>,
    verb_numbers: std::collections::HashMap<String, u32, foldhash::fast::FixedState>,
    /// Keep no order the player cannot tell apart (a team's reduced
    /// exploration): a timer's rank is its start order within its group
    /// only, and pending calls are listed sorted, not in issue order.
    order_free: bool,
}

impl Codec {
    pub fn new(project: &Project, order_free: bool) -> Codec {
        let mut verbs: Vec<String> = project
            .nets
            .iter()
            .flat_map(|n| &n.transitions)
            .flat_map(|t| &t.actions)
            .filter_map(|a| match a {
                Action::Command { verb, .. } => Some(verb.clone()),
                _ => None,
            })
            .collect();
        verbs.sort();
        verbs.dedup();
        Codec {
            words: project.place_count.div_ceil(64).max(1),
            nets: project.nets.len(),
            verb_numbers: verbs
                .iter()
                .enumerate()
                .map(|(i, v)| (v.clone(), i as u32))
                .collect(),
            verbs,
            order_free,
        }
    }

    /// Whether keys keep no order the player cannot tell apart.
    pub fn order_free(&self) -> bool {
        self.order_free
    }

    /// Whether flat place `p` is marked in `key`.
    pub fn marked(&self, key: &[u8], p: usize) -> bool {
        key[p / 8] & (1 << (p % 8)) != 0
    }

    /// Whether net `n` is active in `key`.
    pub fn active(&self, key: &[u8], n: NetId) -> bool {
        key[self.words * 8 + n] != 0
    }

    /// The length of `key`'s marking, active nets and lockouts (where its
    /// timers begin).
    pub fn head_len(&self, key: &[u8]) -> usize {
        let at = self.words * 8 + self.nets;
        if key[at] & 2 == 0 {
            at + 1
        } else {
            let mut b = [0; 4];
            b.copy_from_slice(&key[at + 1..at + 5]);
            at + 5 + 4 * u32::from_le_bytes(b) as usize
        }
    }

    /// Writes the abstract form of the player's `state` into `out`.
    /// `prev` is the state the step ran on (`None` at start-up): its timers
    /// keep their group and duration; timers numbered from `seq_before` on
    /// were started by the step, at `step_time`. `relevant` says whether
    /// anything awaits a pending result (given its id too).
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        state: &State,
        seq_before: u64,
        step_time: Micros,
        prev: Option<&Abs>,
        relevant: &dyn Fn(u64, &Pending) -> bool,
        scratch: &mut Scratch,
        out: &mut Vec<u8>,
    ) {
        out.clear();
        for w in &state.marking {
            out.extend_from_slice(&w.to_le_bytes());
        }
        out.extend(state.active.iter().map(|&a| u8::from(a)));
        if state.locked.is_empty() {
            out.push(u8::from(state.lockout));
        } else {
            out.push(2 | u8::from(state.lockout));
            out.extend_from_slice(&(state.locked.len() as u32).to_le_bytes());
            for &v in &state.locked {
                out.extend_from_slice(&(v as u32).to_le_bytes());
            }
        }
        // Timers: group and duration, in net and timer order (unique, since
        // restarting replaces), start order renumbered by rank.
        let timers = &mut scratch.timers;
        timers.clear();
        for t in &state.timers {
            let (group, duration) = match prev {
                Some(prev) if t.seq < seq_before => prev
                    .state
                    .timers
                    .iter()
                    .zip(&prev.groups)
                    .find(|(p, _)| p.net == t.net && p.timer == t.timer)
                    .map_or((FRESH, 0), |(p, g)| (*g, p.deadline)),
                _ => (FRESH, t.deadline.saturating_sub(step_time.min(t.deadline))),
            };
            let mut t = t.clone();
            t.deadline = duration;
            timers.push((t, group));
        }
        timers.sort_by_key(|(t, _)| (t.net, t.timer));
        scratch.seqs.clear();
        scratch.seqs.extend(timers.iter().map(|(t, _)| t.seq));
        scratch.seqs.sort_unstable();
        scratch.groups.clear();
        out.extend_from_slice(&(timers.len() as u32).to_le_bytes());
        for (t, g) in timers.iter() {
            let rank = if self.order_free {
                // Only the start order within the group can matter.
                timers
                    .iter()
                    .filter(|(u, h)| h == g && u.seq < t.seq)
                    .count() as u32
            } else {
                scratch.seqs.binary_search(&t.seq).unwrap_or(0) as u32
            };
            let group = match scratch.groups.iter().find(|(old, _)| old == g) {
                Some((_, new)) => *new,
                None => {
                    let new = scratch.groups.len() as u32;
                    scratch.groups.push((*g, new));
                    new
                }
            };
            out.extend_from_slice(&(t.net as u32).to_le_bytes());
            out.extend_from_slice(&(t.timer as u32).to_le_bytes());
            out.extend_from_slice(&t.deadline.to_le_bytes());
            out.extend_from_slice(&rank.to_le_bytes());
            out.push(u8::from(t.catastrophic));
            out.extend_from_slice(&group.to_le_bytes());
        }
        // Pending calls and commands, in id order.
        let mut kept: SmallVec<[&Pending; 16]> = SmallVec::new();
        for (&id, p) in &state.pending {
            if relevant(id, p) && kept.iter().filter(|k| **k == p).count() < MAX_SAME_PENDING {
                kept.push(p);
            }
        }
        out.extend_from_slice(&(kept.len() as u32).to_le_bytes());
        if self.order_free {
            // Ids only name results: any order will do, so the order of
            // the entries' bytes.
            let mut entries: SmallVec<[Vec<u8>; 16]> = kept
                .iter()
                .map(|p| {
                    let mut e = Vec::new();
                    self.write_pending(p, &mut e);
                    e
                })
                .collect();
            entries.sort_unstable();
            for e in entries {
                out.extend_from_slice(&e);
            }
        } else {
            for p in kept {
                self.write_pending(p, out);
            }
        }
    }

    /// One pending call, command or question, as a key holds it.
    pub fn write_pending(&self, p: &Pending, out: &mut Vec<u8>) {
        out.extend_from_slice(&(p.net as u32).to_le_bytes());
        out.push(u8::from(p.catastrophic));
        match &p.kind {
            PendingKind::Call { program, function } => {
                out.push(0);
                out.extend_from_slice(&(*program as u32).to_le_bytes());
                out.extend_from_slice(&(*function as u32).to_le_bytes());
            }
            PendingKind::Question { ask } => {
                out.push(3);
                out.extend_from_slice(&(*ask as u32).to_le_bytes());
            }
            PendingKind::Command { verb } => match self.verb_numbers.get(verb.as_str()) {
                Some(i) => {
                    out.push(1);
                    out.extend_from_slice(&i.to_le_bytes());
                }
                None => {
                    out.push(2);
                    out.extend_from_slice(&(verb.len() as u32).to_le_bytes());
                    out.extend_from_slice(verb.as_bytes());
                }
            },
        }
    }

    /// Reads a key written by [`Codec::encode`] back.
    pub fn decode(&self, key: &[u8]) -> Abs {
        let mut r = Reader { key, at: 0 };
        let marking = (0..self.words).map(|_| r.u64()).collect();
        let active = (0..self.nets).map(|_| r.u8() != 0).collect();
        let byte = r.u8();
        let lockout = byte & 1 != 0;
        let locked = if byte & 2 != 0 {
            let n = r.u32() as usize;
            (0..n).map(|_| r.u32() as usize).collect()
        } else {
            Vec::new()
        };
        let n = r.u32() as usize;
        let mut timers = Vec::with_capacity(n);
        let mut groups = Vec::with_capacity(n);
        for _ in 0..n {
            let net = r.u32() as usize;
            let timer = r.u32() as usize;
            let deadline = r.u64();
            let seq = u64::from(r.u32());
            let catastrophic = r.u8() != 0;
            groups.push(r.u32());
            timers.push(Timer {
                net,
                timer,
                deadline,
                seq,
                catastrophic,
            });
        }
        let count = r.u32() as u64;
        let mut pending = std::collections::BTreeMap::new();
        for id in 1..=count {
            let net = r.u32() as usize;
            let catastrophic = r.u8() != 0;
            let kind = match r.u8() {
                0 => PendingKind::Call {
                    program: r.u32() as usize,
                    function: r.u32() as usize,
                },
                1 => PendingKind::Command {
                    verb: self.verbs[r.u32() as usize].clone(),
                },
                3 => PendingKind::Question {
                    ask: r.u32() as usize,
                },
                _ => {
                    let len = r.u32() as usize;
                    PendingKind::Command {
                        verb: String::from_utf8_lossy(r.bytes(len)).into_owned(),
                    }
                }
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
        let next_timer_seq = timers.len() as u64;
        Abs {
            state: State {
                now: 0,
                marking,
                active,
                timers,
                queue: Default::default(),
                lockout,
                locked,
                pending,
                next_id: count + 1,
                next_timer_seq,
            },
            groups,
        }
    }
}

/// Reads what [`Codec::encode`] wrote (keys never come from outside).
struct Reader<'a> {
    key: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn bytes(&mut self, n: usize) -> &'a [u8] {
        let b = &self.key[self.at..self.at + n];
        self.at += n;
        b
    }
    fn u8(&mut self) -> u8 {
        self.bytes(1)[0]
    }
    fn u32(&mut self) -> u32 {
        let mut b = [0; 4];
        b.copy_from_slice(self.bytes(4));
        u32::from_le_bytes(b)
    }
    fn u64(&mut self) -> u64 {
        let mut b = [0; 8];
        b.copy_from_slice(self.bytes(8));
        u64::from_le_bytes(b)
    }
}

/// The hash of a key (fixed seed: the same on every run).
pub(super) fn hash(key: &[u8]) -> u64 {
    foldhash::fast::FixedState::with_seed(0x7065_7472_656c).hash_one(key)
}

/// Every key stored once, back to back, numbered in order of insertion.
pub(super) struct KeyStore {
    bytes: Vec<u8>,
    ends: Vec<usize>,
    table: HashTable<u32>,
}

impl KeyStore {
    pub fn new() -> KeyStore {
        KeyStore {
            bytes: Vec::new(),
            ends: vec![0],
            table: HashTable::new(),
        }
    }

    pub fn len(&self) -> usize {
        self.ends.len() - 1
    }

    /// The key numbered `i`.
    pub fn get(&self, i: u32) -> &[u8] {
        &self.bytes[self.ends[i as usize]..self.ends[i as usize + 1]]
    }

    /// The number of `key` (of hash `hash`), if stored.
    pub fn lookup(&self, key: &[u8], hash: u64) -> Option<u32> {
        self.table.find(hash, |&i| self.get(i) == key).copied()
    }

    /// Stores `key` (of hash `hash`, not stored yet); returns its number.
    pub fn insert(&mut self, key: &[u8], hash: u64) -> u32 {
        let i = self.len() as u32;
        self.bytes.extend_from_slice(key);
        self.ends.push(self.bytes.len());
        let (bytes, ends) = (&self.bytes, &self.ends);
        self.table.insert_unique(hash, i, |&j| {
            self::hash(&bytes[ends[j as usize]..ends[j as usize + 1]])
        });
        i
    }
}
