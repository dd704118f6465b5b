//! The memo of runs of the project explorer ([`super::project`]): what one
//! input did to the part of a state it can reach, kept and applied to other
//! states that agree on that part, instead of running the player again.
//!
//! An input's *cone* is the set of nets its run can read or change: the
//! nets the input reaches first (the nets waiting for an external event; a
//! timer's, result's or answer's net), closed under each of their
//! transitions' `emit` (the nets waiting for that event), `activate` and
//! `deactivate` (that net) and rejection (the nets waiting for
//! `net_fault`), and under the immediate transitions of other nets that
//! read a global place a cone transition writes. A run then reads only the
//! cone's places, every global place, the cone's active flags, the lockout,
//! the cone's timers (which ones run, not their durations: a step expires
//! only its own timer) and the cone's pending calls (in id order); it
//! writes only those, and takes new ids and timer numbers from the
//! counters. One more thing outside the cone could act: an immediate
//! transition of another net already enabled before the input (after a
//! livelock was cut, every run fires it); in such a state the memo is not
//! used (see [`Cone::blocked`]).
//!
//! The memo's key is the input and the state's projection on its cone; its
//! value, per oracle answer sequence in the order the explorer runs them,
//! the run's [`Outcome`]: the cone's marking and active flags after it, the
//! lockout, the timers it removed and started, the pending calls it
//! collected or forgot (by rank among the cone's) and issued, and the
//! step's label. Applied to the state ([`Memo::apply`]) it gives the state
//! the player would have left, which is then encoded as any successor.
//! docs/verify.md ("The memo of runs") argues it; a cross-check mode runs
//! the player on every hit too and compares ([`MemoProbe`]).
//!
//! Teams (projects with vehicles) do not use it: symmetry reads the whole
//! state at each step.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use hashbrown::HashTable;

use super::project_states::hash;
use crate::model::{names, Action, NetId, Project};
use crate::player::{Pending, PendingKind, State, Timer};

/// What the memo may hold per worker, roughly, in bytes: past it, it is
/// emptied and fills again (the search goes level by level: what recent
/// levels met is what the next ones meet).
pub(super) const MEMO_BYTES: usize = 64 << 20;

/// How the explorer uses the memo of runs, and what it counted (for the
/// bench and the cross-check test; a check without a probe uses the memo,
/// counts nothing).
#[derive(Debug, Default)]
pub struct MemoProbe {
    /// Leave the memo out: every input runs the player.
    pub off: bool,
    /// Run the player on every hit too and compare its successors and
    /// labels with the memo's; differences go to `mismatches`.
    pub cross_check: bool,
    /// (state, input) pairs whose outcome the memo gave.
    pub hits: AtomicU64,
    /// Pairs run by the player and remembered.
    pub misses: AtomicU64,
    /// Pairs run by the player without the memo (an immediate transition
    /// outside the cone was enabled, or the run changed something outside
    /// its cone: then its outcome is not kept).
    pub bypassed: AtomicU64,
    /// The most bytes one worker's memo held.
    pub peak_bytes: AtomicU64,
    /// Times a worker's memo was emptied for its size.
    pub cleared: AtomicU64,
    /// What differed between the memo and the player (cross-check only).
    pub mismatches: Mutex<Vec<String>>,
}

impl MemoProbe {
    pub(super) fn count(&self, what: &AtomicU64) {
        what.fetch_add(1, Ordering::Relaxed);
    }

    /// The mismatches found (cross-check).
    pub fn mismatches(&self) -> Vec<String> {
        self.mismatches
            .lock()
            .map(|m| m.clone())
            .unwrap_or_else(|e| e.into_inner().clone())
    }
}

/// An input's cone in one state: the transitions its run may fire, and
/// what they may read or write (see the module doc).
#[derive(Default)]
pub(super) struct Cone {
    /// The transitions (flat numbering, as bits).
    set: Vec<u64>,
    /// The nets whose flags, timers and pending calls the run may read or
    /// change (as bits: projects of at most 64 nets use the memo).
    nets: u64,
    /// Per marking word: the places it may read or write.
    mask: Vec<u64>,
    /// Scratch of [`Cones::cone`]: the places marked or written, the
    /// transitions that may be triggered, those still to look at.
    marked: Vec<u64>,
    candidates: Vec<u64>,
    work: Vec<u64>,
}

impl Cone {
    fn has(&self, n: NetId) -> bool {
        self.nets & (1 << n) != 0
    }
}

/// The cones computed by one worker, by input and the marking and active
/// flags they depend on (many states share them: they differ in timers and
/// pending calls), so that a state met again does not work them out again.
#[derive(Default)]
pub(super) struct ConeCache {
    index: std::collections::HashMap<Vec<u8>, u32, foldhash::fast::FixedState>,
    /// Per cone: its transitions, nets and places, back to back.
    cones: Vec<(Vec<u64>, u64, Vec<u64>)>,
    key: Vec<u8>,
}

/// The most cones a worker keeps (then it starts again).
const MAX_CONES: usize = 1 << 16;

impl ConeCache {
    /// Puts into `out` the cone of the input `tag` (what names it, the
    /// same for every input with the same `start` and `net`) in `state`,
    /// from the cache or worked out by `cones`.
    #[allow(clippy::too_many_arguments)]
    pub fn cone(
        &mut self,
        cones: &Cones,
        tag: (u8, u32),
        start: &[u64],
        net: Option<NetId>,
        state: &State,
        enabled: &[u64],
        out: &mut Cone,
    ) {
        self.key.clear();
        self.key.push(tag.0);
        self.key.extend_from_slice(&tag.1.to_le_bytes());
        for w in &state.marking {
            self.key.extend_from_slice(&w.to_le_bytes());
        }
        self.key.extend(state.active.iter().map(|&a| u8::from(a)));
        if let Some(&i) = self.index.get(&self.key) {
            let (set, nets, mask) = &self.cones[i as usize];
            out.set.clone_from(set);
            out.nets = *nets;
            out.mask.clone_from(mask);
            return;
        }
        cones.cone(start, net, state, enabled, out);
        if self.cones.len() >= MAX_CONES {
            self.index.clear();
            self.cones.clear();
        }
        self.index.insert(self.key.clone(), self.cones.len() as u32);
        self.cones
            .push((out.set.clone(), out.nets, out.mask.clone()));
    }
}

/// What one transition may do, for the cones.
struct Reach {
    net: NetId,
    /// Input places (word, bits).
    inputs: Vec<(usize, u64)>,
    /// Output places, and input and output places, as marking words.
    outputs: Vec<u64>,
    places: Vec<u64>,
    /// The transitions its firing may trigger: those waiting for the
    /// events it emits, for its own timers' expiries (a timer of no
    /// duration expires in the step), for `net_fault` (a firing may be
    /// rejected).
    next: Vec<u64>,
    /// The nets it activates; the nets it activates or deactivates (all
    /// their places may change); those and its own (as bits).
    activates: u64,
    whole: u64,
    nets: u64,
    /// The transitions whose place in a cone its own may decide: those
    /// with an input place it writes, or in a net it activates.
    dependents: Vec<u64>,
}

/// What the cones of a project's inputs are made of.
pub(super) struct Cones {
    reach: Vec<Reach>,
    /// Per net: its places (marking words); its transitions' first flat
    /// number; the transitions an event of its own (a timer's, a
    /// result's, an answer's) may trigger: every transition of it waiting
    /// for an event.
    net_places: Vec<Vec<u64>>,
    net_start: Vec<Vec<u64>>,
    /// Per external event: the transitions waiting for it.
    event_start: Vec<Vec<u64>>,
    /// Every immediate transition (they may fire whenever enabled).
    immediates: Vec<u64>,
}

fn bits_of(n: usize) -> Vec<u64> {
    vec![0; n.div_ceil(64).max(1)]
}

fn set_bit(bits: &mut [u64], i: usize) {
    bits[i / 64] |= 1 << (i % 64);
}

fn or(into: &mut [u64], from: &[u64]) {
    into.iter_mut().zip(from).for_each(|(a, b)| *a |= b);
}

impl Cones {
    /// What the cones are made of, or `None` when the project cannot use
    /// the memo (a team, or more than 64 nets). `externals`: the
    /// transitions waiting for each external event.
    pub fn of(project: &Project, externals: &[Vec<(NetId, usize)>]) -> Option<Cones> {
        if !project.vehicles.is_empty() || project.nets.len() > 64 {
            return None;
        }
        let mut first = Vec::with_capacity(project.nets.len());
        let mut count = 0;
        for net in &project.nets {
            first.push(count);
            count += net.transitions.len();
        }
        let words = project.place_count.div_ceil(64).max(1);
        let waiting = |event: &str, only: Option<NetId>| {
            let mut bits = bits_of(count);
            for &(n, t) in project.triggers.get(event).into_iter().flatten() {
                if only.is_none_or(|o| o == n) {
                    set_bit(&mut bits, first[n] + t);
                }
            }
            bits
        };
        let net_fault = waiting(names::NET_FAULT, None);
        let mut reach = Vec::with_capacity(count);
        let mut immediates = bits_of(count);
        let mut net_start = Vec::with_capacity(project.nets.len());
        let mut net_places = Vec::with_capacity(project.nets.len());
        for (n, net) in project.nets.iter().enumerate() {
            let mut start = bits_of(count);
            let mut own = vec![0u64; words];
            let offset = project.place_offsets[n];
            (offset..offset + net.places.len()).for_each(|p| set_bit(&mut own, p));
            net_places.push(own);
            for (t, tr) in net.transitions.iter().enumerate() {
                if tr.event.is_some() {
                    set_bit(&mut start, first[n] + t);
                } else {
                    set_bit(&mut immediates, first[n] + t);
                }
                let mut inputs: Vec<(usize, u64)> = Vec::new();
                for &p in &tr.flat_inputs {
                    let (w, bit) = (p / 64, 1u64 << (p % 64));
                    match inputs.iter_mut().find(|(x, _)| *x == w) {
                        Some((_, b)) => *b |= bit,
                        None => inputs.push((w, bit)),
                    }
                }
                let mut outputs = vec![0u64; words];
                tr.flat_outputs
                    .iter()
                    .for_each(|&p| set_bit(&mut outputs, p));
                let mut places = outputs.clone();
                tr.flat_inputs.iter().for_each(|&p| set_bit(&mut places, p));
                let mut next = net_fault.clone();
                let (mut activates, mut whole) = (0u64, 0u64);
                for a in &tr.actions {
                    match a {
                        Action::Emit { event, .. } => or(&mut next, &waiting(event, None)),
                        Action::Activate(m) => {
                            activates |= 1 << m;
                            whole |= 1 << m;
                        }
                        Action::Deactivate(m) => whole |= 1 << m,
                        Action::Timer { timer, .. } => {
                            or(&mut next, &waiting(&net.timers[*timer], Some(n)));
                        }
                        Action::Ask { ask, .. } => {
                            let timer = net.asks[*ask].timer;
                            or(&mut next, &waiting(&net.timers[timer], Some(n)));
                        }
                        _ => {}
                    }
                }
                reach.push(Reach {
                    net: n,
                    inputs,
                    outputs,
                    places,
                    next,
                    activates,
                    whole,
                    nets: whole | 1 << n,
                    dependents: Vec::new(),
                });
            }
            net_start.push(start);
        }
        // Who depends on whom: a transition reading a place another
        // writes, or in a net another activates.
        for t in 0..reach.len() {
            let mut dependents = bits_of(count);
            for (u, r) in reach.iter().enumerate() {
                let reads_written = r.inputs.iter().any(|&(w, b)| reach[t].outputs[w] & b != 0);
                if reads_written || reach[t].activates & 1 << r.net != 0 {
                    set_bit(&mut dependents, u);
                }
            }
            reach[t].dependents = dependents;
        }
        Some(Cones {
            event_start: externals
                .iter()
                .map(|w| {
                    let mut bits = bits_of(count);
                    w.iter()
                        .for_each(|&(n, t)| set_bit(&mut bits, first[n] + t));
                    bits
                })
                .collect(),
            reach,
            net_places,
            net_start,
            immediates,
        })
    }

    /// The immediate transitions enabled in `state` (their net active,
    /// their input places marked), into `out`: once per state, for the
    /// cones of all its inputs.
    pub fn enabled_immediates(&self, state: &State, out: &mut Vec<u64>) {
        out.clear();
        out.resize(self.immediates.len(), 0);
        for (w, &bits) in self.immediates.iter().enumerate() {
            let mut left = bits;
            while left != 0 {
                let t = w * 64 + left.trailing_zeros() as usize;
                left &= left - 1;
                let r = &self.reach[t];
                if state.active[r.net] && r.inputs.iter().all(|&(x, b)| state.marking[x] & b == b) {
                    out[w] |= 1 << (t % 64);
                }
            }
        }
    }

    /// The transitions an external event may trigger first.
    pub fn event(&self, i: usize) -> &[u64] {
        &self.event_start[i]
    }

    /// The transitions a timer, result or answer of net `n` may trigger
    /// first.
    pub fn net(&self, n: NetId) -> &[u64] {
        &self.net_start[n]
    }

    /// The cone of an input in `state` into `out`: `start`, the
    /// transitions the input may trigger first; `net`, the net a timer,
    /// result or answer is for. A transition is in it if something in it
    /// (or the input) may trigger it, or it is immediate, and its net is
    /// active or activated in it, and each of its input places is marked
    /// or written in it; then what it may trigger is looked at too.
    /// `enabled`: the immediate transitions enabled in `state`
    /// ([`Cones::enabled_immediates`]); the others join only when one in
    /// the cone writes an input place of theirs or activates their net.
    pub fn cone(
        &self,
        start: &[u64],
        net: Option<NetId>,
        state: &State,
        enabled: &[u64],
        out: &mut Cone,
    ) {
        out.set.clear();
        out.set.resize(start.len(), 0);
        out.candidates.clear();
        out.candidates.extend_from_slice(start);
        or(&mut out.candidates, &self.immediates);
        out.work.clear();
        out.work.extend_from_slice(start);
        or(&mut out.work, enabled);
        out.marked.clone_from(&state.marking);
        let mut active = state
            .active
            .iter()
            .enumerate()
            .filter(|(_, a)| **a)
            .fold(0u64, |b, (n, _)| b | 1 << n);
        // A work list: a transition is looked at when it may be triggered,
        // and again when one it depends on joins.
        let mut w = 0;
        while w < out.work.len() {
            let bits = out.work[w];
            if bits == 0 {
                w += 1;
                continue;
            }
            let t = w * 64 + bits.trailing_zeros() as usize;
            out.work[w] &= bits - 1;
            let r = &self.reach[t];
            if out.set[w] & 1 << (t % 64) != 0
                || active & 1 << r.net == 0
                || !r.inputs.iter().all(|&(x, b)| out.marked[x] & b == b)
            {
                continue;
            }
            out.set[w] |= 1 << (t % 64);
            or(&mut out.marked, &r.outputs);
            let mut act = r.activates;
            active |= act;
            while act != 0 {
                let m = act.trailing_zeros() as usize;
                act &= act - 1;
                or(&mut out.marked, &self.net_places[m]);
            }
            let mut lowest = w;
            for (i, ((c, k), (n, d))) in out
                .candidates
                .iter_mut()
                .zip(out.work.iter_mut())
                .zip(r.next.iter().zip(&r.dependents))
                .enumerate()
            {
                let fresh = n & !*c;
                *c |= n;
                let again = fresh | (d & *c & !out.set[i]);
                if again != 0 {
                    *k |= again;
                    lowest = lowest.min(i);
                }
            }
            w = lowest;
        }
        out.mask.clear();
        out.mask.resize(state.marking.len(), 0);
        out.nets = net.map_or(0, |n| 1 << n);
        let mut whole = 0u64;
        for w in 0..out.set.len() {
            let mut bits = out.set[w];
            while bits != 0 {
                let t = w * 64 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let r = &self.reach[t];
                or(&mut out.mask, &r.places);
                out.nets |= r.nets;
                whole |= r.whole;
            }
        }
        let mut nets = whole;
        while nets != 0 {
            let m = nets.trailing_zeros() as usize;
            nets &= nets - 1;
            or(&mut out.mask, &self.net_places[m]);
        }
    }
}

/// Writes `state`'s projection on `cone` after the input's own bytes
/// (already in `out`).
pub(super) fn project_key(cone: &Cone, state: &State, out: &mut Vec<u8>) {
    for w in &cone.set {
        out.extend_from_slice(&w.to_le_bytes());
    }
    for (w, m) in state.marking.iter().zip(&cone.mask) {
        out.extend_from_slice(&(w & m).to_le_bytes());
    }
    let active = state
        .active
        .iter()
        .enumerate()
        .filter(|&(n, &a)| a && cone.has(n))
        .fold(0u64, |b, (n, _)| b | 1 << n);
    out.extend_from_slice(&active.to_le_bytes());
    out.push(u8::from(state.lockout));
    // Timers in the state's order (a key's: net and timer order).
    for t in state.timers.iter().filter(|t| cone.has(t.net)) {
        out.push(b'T');
        out.extend_from_slice(&(t.net as u32).to_le_bytes());
        out.extend_from_slice(&(t.timer as u32).to_le_bytes());
        out.push(u8::from(t.catastrophic));
    }
    for p in state.pending.values().filter(|p| cone.has(p.net)) {
        out.push(b'P');
        out.extend_from_slice(&(p.net as u32).to_le_bytes());
        out.push(u8::from(p.catastrophic));
        match &p.kind {
            PendingKind::Call { program, function } => {
                out.push(0);
                out.extend_from_slice(&(*program as u32).to_le_bytes());
                out.extend_from_slice(&(*function as u32).to_le_bytes());
            }
            PendingKind::Question { ask } => {
                out.push(1);
                out.extend_from_slice(&(*ask as u32).to_le_bytes());
            }
            PendingKind::Command { verb } => {
                out.push(2);
                out.extend_from_slice(&(verb.len() as u32).to_le_bytes());
                out.extend_from_slice(verb.as_bytes());
            }
        }
    }
    out.push(b'.');
}

/// The rank of pending call `id` among the cone's pending calls of
/// `state` (id order).
pub(super) fn pending_rank(cone: &Cone, state: &State, id: u64) -> u32 {
    state
        .pending
        .iter()
        .filter(|(i, p)| **i < id && cone.has(p.net))
        .count() as u32
}

/// What one run (one oracle answer sequence) did to its cone, and its
/// label (the worker's number).
#[derive(Debug, Clone)]
pub(super) struct Outcome {
    pub label: u32,
    /// The cone's marking after the run (its words masked), from
    /// [`Memo`]'s word store.
    words: u32,
    /// The cone's active flags after the run.
    active: u64,
    lockout: bool,
    /// Timers removed (net, timer) and started (net, timer, deadline,
    /// start order after the state's counter, catastrophic), ranges of the
    /// memo's stores.
    removed_timers: std::ops::Range<u32>,
    new_timers: std::ops::Range<u32>,
    /// Pending calls removed (rank among the cone's) and issued (id after
    /// the state's counter, the call).
    removed_pending: std::ops::Range<u32>,
    new_pending: std::ops::Range<u32>,
    /// How far the run moved the id and timer counters.
    ids: u64,
    seqs: u64,
}

/// One worker's memo of runs.
#[derive(Default)]
pub(super) struct Memo {
    table: HashTable<u32>,
    keys: Vec<u8>,
    /// Per entry: its key's end in `keys`, and its outcomes' range.
    entries: Vec<(usize, std::ops::Range<u32>)>,
    outcomes: Vec<Outcome>,
    words: Vec<u64>,
    removed_timers: Vec<(NetId, usize)>,
    new_timers: Vec<Timer>,
    removed_pending: Vec<u32>,
    new_pending: Vec<(u64, Pending)>,
    /// Outcomes of the entry being recorded (a miss).
    recording: Option<(u64, usize)>,
    /// Bytes held, roughly.
    bytes: usize,
}

impl Memo {
    /// The outcomes remembered for `key` (of hash `h`), if any.
    pub fn get(&self, key: &[u8], h: u64) -> Option<&[Outcome]> {
        let e = self.table.find(h, |&i| self.key(i) == key)?;
        let r = &self.entries[*e as usize].1;
        Some(&self.outcomes[r.start as usize..r.end as usize])
    }

    fn key(&self, i: u32) -> &[u8] {
        let i = i as usize;
        let start = if i == 0 { 0 } else { self.entries[i - 1].0 };
        &self.keys[start..self.entries[i].0]
    }

    /// Starts recording the outcomes of `key` (missed): emptied first if
    /// it holds more than [`MEMO_BYTES`].
    pub fn begin(&mut self, key: &[u8], h: u64, probe: Option<&MemoProbe>) {
        if self.bytes > MEMO_BYTES {
            if let Some(p) = probe {
                p.count(&p.cleared);
            }
            *self = Memo::default();
        }
        self.keys.extend_from_slice(key);
        self.bytes += key.len() + 64;
        self.recording = Some((h, self.outcomes.len()));
    }

    /// Records one run's outcome: `before` the concrete state it ran on,
    /// `after` the player's state after it. False (and the entry is
    /// dropped) if the run changed something outside its cone.
    pub fn record(&mut self, cone: &Cone, before: &State, after: &State, label: u32) -> bool {
        // Outside the cone nothing may change (checked, cheaply: the
        // marking, the flags; timers and calls by the cone's nets only).
        let outside_same = before
            .marking
            .iter()
            .zip(&after.marking)
            .zip(&cone.mask)
            .all(|((b, a), m)| b & !m == a & !m)
            && before
                .active
                .iter()
                .zip(&after.active)
                .enumerate()
                .all(|(n, (b, a))| cone.has(n) || a == b)
            && after.queued() == 0
            && after.locked == before.locked;
        if !outside_same {
            return false;
        }
        let words = self.words.len() as u32;
        self.words
            .extend(after.marking.iter().zip(&cone.mask).map(|(w, m)| w & m));
        let active = after
            .active
            .iter()
            .enumerate()
            .filter(|&(n, &a)| a && cone.has(n))
            .fold(0u64, |b, (n, _)| b | 1 << n);
        let start = self.removed_timers.len() as u32;
        for t in &before.timers {
            let kept = after
                .timers
                .iter()
                .any(|u| u.net == t.net && u.timer == t.timer && u.seq == t.seq);
            if !kept {
                if !cone.has(t.net) {
                    return false;
                }
                self.removed_timers.push((t.net, t.timer));
            }
        }
        let removed_timers = start..self.removed_timers.len() as u32;
        let start = self.new_timers.len() as u32;
        for t in after
            .timers
            .iter()
            .filter(|t| t.seq >= before.next_timer_seq)
        {
            let mut t = t.clone();
            t.seq -= before.next_timer_seq;
            self.new_timers.push(t);
        }
        let new_timers = start..self.new_timers.len() as u32;
        let start = self.removed_pending.len() as u32;
        let mut rank = 0u32;
        for (id, p) in &before.pending {
            let cone_net = cone.has(p.net);
            if !after.pending.contains_key(id) {
                if !cone_net {
                    return false;
                }
                self.removed_pending.push(rank);
            }
            rank += u32::from(cone_net);
        }
        let removed_pending = start..self.removed_pending.len() as u32;
        let start = self.new_pending.len() as u32;
        for (id, p) in after.pending.range(before.next_id..) {
            self.new_pending.push((id - before.next_id, p.clone()));
        }
        let new_pending = start..self.new_pending.len() as u32;
        self.bytes += std::mem::size_of::<Outcome>()
            + 8 * cone.mask.len()
            + 16 * removed_timers.len()
            + 48 * new_timers.len()
            + 4 * removed_pending.len()
            + 64 * new_pending.len();
        self.outcomes.push(Outcome {
            label,
            words,
            active,
            lockout: after.lockout,
            removed_timers,
            new_timers,
            removed_pending,
            new_pending,
            ids: after.next_id - before.next_id,
            seqs: after.next_timer_seq - before.next_timer_seq,
        });
        true
    }

    /// Ends the recording begun by [`Memo::begin`]: kept if `keep`.
    pub fn end(&mut self, keep: bool, probe: Option<&MemoProbe>) {
        let Some((h, first)) = self.recording.take() else {
            return;
        };
        let end = self.entries.last().map_or(0, |e| e.0);
        if !keep {
            self.keys.truncate(end);
            self.outcomes.truncate(first);
            return;
        }
        let i = self.entries.len() as u32;
        self.entries
            .push((self.keys.len(), first as u32..self.outcomes.len() as u32));
        let (keys, entries) = (&self.keys, &self.entries);
        self.table.insert_unique(h, i, |&j| {
            let j = j as usize;
            let start = if j == 0 { 0 } else { entries[j - 1].0 };
            hash(&keys[start..entries[j].0])
        });
        if let Some(p) = probe {
            p.peak_bytes.fetch_max(self.bytes as u64, Ordering::Relaxed);
        }
    }

    /// Puts into `patched` the state `outcome` leaves when its run starts
    /// from `concrete` (whose pending calls `patched` already holds:
    /// [`Memo::undo`] puts them back after).
    pub fn apply(&self, cone: &Cone, outcome: &Outcome, concrete: &State, patched: &mut State) {
        let words = &self.words[outcome.words as usize..];
        for (((p, c), m), w) in patched
            .marking
            .iter_mut()
            .zip(&concrete.marking)
            .zip(&cone.mask)
            .zip(words)
        {
            *p = (c & !m) | w;
        }
        for (n, (p, c)) in patched.active.iter_mut().zip(&concrete.active).enumerate() {
            *p = if cone.has(n) {
                outcome.active & 1 << n != 0
            } else {
                *c
            };
        }
        patched.lockout = outcome.lockout;
        patched.locked.clone_from(&concrete.locked);
        let removed = &self.removed_timers
            [outcome.removed_timers.start as usize..outcome.removed_timers.end as usize];
        patched.timers.clear();
        patched.timers.extend(
            concrete
                .timers
                .iter()
                .filter(|t| !removed.contains(&(t.net, t.timer)))
                .cloned(),
        );
        for t in
            &self.new_timers[outcome.new_timers.start as usize..outcome.new_timers.end as usize]
        {
            let mut t = t.clone();
            t.seq += concrete.next_timer_seq;
            patched.timers.push(t);
        }
        let ranks = &self.removed_pending
            [outcome.removed_pending.start as usize..outcome.removed_pending.end as usize];
        if !ranks.is_empty() {
            let mut rank = 0u32;
            for (id, p) in &concrete.pending {
                if !cone.has(p.net) {
                    continue;
                }
                if ranks.contains(&rank) {
                    patched.pending.remove(id);
                }
                rank += 1;
            }
        }
        for (offset, p) in
            &self.new_pending[outcome.new_pending.start as usize..outcome.new_pending.end as usize]
        {
            patched.pending.insert(concrete.next_id + offset, p.clone());
        }
        patched.next_id = concrete.next_id + outcome.ids;
        patched.next_timer_seq = concrete.next_timer_seq + outcome.seqs;
        patched.now = concrete.now;
    }

    /// Puts `patched`'s pending calls back to `concrete`'s after
    /// [`Memo::apply`] of `outcome`.
    pub fn undo(&self, outcome: &Outcome, concrete: &State, patched: &mut State) {
        if outcome.new_pending.end > outcome.new_pending.start {
            drop(patched.pending.split_off(&concrete.next_id));
        }
        if outcome.removed_pending.end > outcome.removed_pending.start {
            for (id, p) in &concrete.pending {
                patched.pending.entry(*id).or_insert_with(|| p.clone());
            }
        }
    }
}
