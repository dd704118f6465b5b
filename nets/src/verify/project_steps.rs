//! Step outcomes, kept so that a state which differs from one already
//! expanded only in orders the player cannot read is expanded without the
//! player, from key to key.
//!
//! A step of the project explorer runs the player on a concrete state (see
//! [`super::project`]). Its outcome depends on the marking, the active
//! nets, the lockouts, which timers run (net, timer, duration, category)
//! and which results are pending (each net's, in the order they were
//! issued), and on the input. It does not depend on how the pending calls
//! of *different* nets interleave in issue order, nor on the start order
//! of timers: only the expiring timer is due in a step, and the player
//! reads a call by its id only to answer it. Keys keep those orders (later
//! steps report them), so many keys share one [`projection`]: on
//! `examples/uav-flight-test`, about one state in seven has a projection
//! not seen before. The inputs of a state are a function of its projection
//! too: a timer can expire first when no timer started by the same step
//! is due before it, which the projection keeps (each timer's group and
//! its start order within it).
//!
//! An [`Outcome`] says what a step made of a key in the projection's
//! terms: the marking, active nets and lockouts whole; which of the key's
//! timers (by position, in net and timer order) and pending results (by
//! their place in the projection) are left; the timers and results the
//! step started, in order. An [`Entry`] holds the outcomes of every input
//! of a projection; [`Entry::edges`] writes the successors' keys from
//! another key with the same projection, exactly as
//! [`Codec::encode`](super::project_states::Codec::encode) would have
//! written them after running the player. A worker builds an entry with a
//! [`Capture`], checking every outcome against the key the player's run
//! gave; [`Kept`] keeps the entries once for every worker. A test mode
//! ([`Steps::Compare`]) runs the player for every reused outcome too.
//!
//! Pure data and bytes: no player runs here (the locks of [`Kept`] are
//! held only to find or add an entry).

use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use hashbrown::HashTable;
use smallvec::SmallVec;

use super::project_states::{hash, Codec, MAX_SAME_PENDING};
use crate::player::{Pending, State};
use crate::time::Micros;

/// How the project explorer runs its steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Steps {
    /// Reuse the outcomes of a state with the same projection (the
    /// default; the report is the same as [`Steps::Run`]'s).
    #[default]
    Reuse,
    /// Run the player for every step.
    Run,
    /// Run the player for every step, and also work out from kept outcomes
    /// what reuse would have given, comparing the two (for tests: see
    /// [`super::project::compare_steps`]).
    Compare,
}

/// A timer entry's size in a key: `u32 net, u32 timer, u64 duration, u32
/// rank, u8 catastrophic, u32 group`.
const TIMER: usize = 25;
/// The group of a timer the step started (before groups are renumbered).
const FRESH: u32 = u32::MAX;
/// The most the kept outcomes take: past it, states with a new projection
/// are expanded by the player without keeping their outcomes (those kept
/// are still reused). `examples/uav-flight-test` keeps 25 MB for its 55,326
/// states; a project whose states share few projections would otherwise
/// keep several kilobytes per state.
pub(super) const BUDGET: usize = 64 << 20;
/// The most timers, or pending results, a key may hold to be reused (each
/// kept one is a bit of a `u64`).
const MOST: usize = 64;

/// One timer entry of a key.
#[derive(Clone, Copy)]
struct TimerAt {
    at: u32,
    net: u32,
    timer: u32,
    rank: u32,
    group: u32,
}

/// A key's sections, as offsets into it.
#[derive(Default)]
pub(super) struct Parts {
    /// The end of the marking, active nets and lockouts.
    head: usize,
    timers: SmallVec<[TimerAt; 16]>,
    /// Each pending result's entry, in the key's order, with its net.
    pending: SmallVec<[(Range<u32>, u32); 16]>,
    /// Per pending result (in the key's order), its place in the
    /// projection.
    canon: SmallVec<[u8; 16]>,
}

fn u32_at(key: &[u8], at: usize) -> u32 {
    let mut b = [0; 4];
    b.copy_from_slice(&key[at..at + 4]);
    u32::from_le_bytes(b)
}

impl Parts {
    /// Reads the sections of `key` (written by `codec`, never from
    /// outside); `false` when it holds too many timers or results to be
    /// reused.
    pub fn read(&mut self, codec: &Codec, key: &[u8]) -> bool {
        self.head = codec.head_len(key);
        self.timers.clear();
        self.pending.clear();
        self.canon.clear();
        let mut at = self.head;
        let n = u32_at(key, at) as usize;
        at += 4;
        if n > MOST {
            return false;
        }
        for _ in 0..n {
            self.timers.push(TimerAt {
                at: at as u32,
                net: u32_at(key, at),
                timer: u32_at(key, at + 4),
                rank: u32_at(key, at + 16),
                group: u32_at(key, at + 21),
            });
            at += TIMER;
        }
        let n = u32_at(key, at) as usize;
        at += 4;
        if n > MOST {
            return false;
        }
        for _ in 0..n {
            let start = at;
            let net = u32_at(key, at);
            at += 5;
            let kind = key[at];
            at += 1;
            at += match kind {
                0 => 8,
                1 | 3 => 4,
                _ => 4 + u32_at(key, at) as usize,
            };
            self.pending.push((start as u32..at as u32, net));
        }
        // The projection's order of results: by net, each net's in issue
        // order.
        let mut order: SmallVec<[u8; 16]> = (0..n as u8).collect();
        order.sort_by_key(|&j| self.pending[j as usize].1);
        self.canon.resize(n, 0);
        for (c, &j) in order.iter().enumerate() {
            self.canon[j as usize] = c as u8;
        }
        true
    }

    /// How many pending results the key holds.
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// The projection's place of the key's pending result number `j`
    /// (past every place if the key has no such result).
    pub fn canon(&self, j: usize) -> usize {
        self.canon.get(j).map_or(MOST, |&c| usize::from(c))
    }
}

/// Writes the projection of `key` (read into `parts`) into `out`: the key
/// without the start order of timers across groups and without the issue
/// order of results across nets.
pub(super) fn projection(key: &[u8], parts: &Parts, out: &mut Vec<u8>) {
    out.clear();
    out.extend_from_slice(&key[..parts.head]);
    out.extend_from_slice(&(parts.timers.len() as u32).to_le_bytes());
    for t in &parts.timers {
        let at = t.at as usize;
        // Net, timer, duration; the category and the group.
        out.extend_from_slice(&key[at..at + 16]);
        out.extend_from_slice(&key[at + 20..at + TIMER]);
        let within = parts
            .timers
            .iter()
            .filter(|u| u.group == t.group && u.rank < t.rank)
            .count() as u32;
        out.extend_from_slice(&within.to_le_bytes());
    }
    out.extend_from_slice(&(parts.pending.len() as u32).to_le_bytes());
    let mut order: SmallVec<[u8; 16]> = (0..parts.pending.len() as u8).collect();
    order.sort_by_key(|&j| parts.canon[j as usize]);
    for j in order {
        let r = &parts.pending[j as usize].0;
        out.extend_from_slice(&key[r.start as usize..r.end as usize]);
    }
}

/// The start order of the `k`-th timer a step started, after every timer
/// of the key it ran from (whose start orders are their ranks, below
/// [`MOST`]).
fn new_seq(k: usize) -> u32 {
    (MOST + k) as u32
}

/// A timer a step started.
#[derive(Clone, Copy)]
struct NewTimer {
    net: u32,
    timer: u32,
    duration: u64,
    catastrophic: bool,
}

/// What one run of the player (one input, one sequence of answers) made of
/// a key, in the projection's terms.
#[derive(Clone)]
pub(super) struct Outcome {
    /// The step's label (its number in the explorer's registry, the same
    /// for every worker).
    pub label: u32,
    /// The step fired a transition or faulted (an edge even if the key
    /// stays the same).
    pub flagged: bool,
    /// The earlier outcomes of the same input whose labels end alike (see
    /// [`Entry::edges`]), by position.
    alike: u64,
    /// The marking, active nets and lockouts after it (in `bytes`).
    head: Range<u32>,
    /// The key's timers left, by position.
    timers_kept: u64,
    /// The timers started, in start order (in `new_timers`).
    new_timers: Range<u32>,
    /// The key's results left, by place in the projection.
    pending_kept: u64,
    /// The results issued that something awaits, in issue order: entries
    /// as keys hold them (ranges of `bytes`, in `new_pending`).
    new_pending: Range<u32>,
}

/// The outcomes of the inputs of one projection, in groups: the events and
/// timers, then each pending result by its place in the projection. Kept
/// once for every worker.
#[derive(Default)]
pub(super) struct Entry {
    /// Per group, its inputs (a range of `inputs`).
    groups: Vec<Range<u32>>,
    /// Per input, its outcomes (a range of `outcomes`).
    inputs: Vec<Range<u32>>,
    outcomes: Vec<Outcome>,
    new_timers: Vec<NewTimer>,
    new_pending: Vec<Range<u32>>,
    bytes: Vec<u8>,
}

impl Entry {
    /// The inputs of group `g`, as ranges of outcomes.
    fn group(&self, g: usize) -> &[Range<u32>] {
        self.groups
            .get(g)
            .map_or(&[], |r| &self.inputs[r.start as usize..r.end as usize])
    }

    fn outcomes(&self, r: &Range<u32>) -> &[Outcome] {
        &self.outcomes[r.start as usize..r.end as usize]
    }

    fn push_bytes(&mut self, b: &[u8]) -> Range<u32> {
        let start = self.bytes.len() as u32;
        self.bytes.extend_from_slice(b);
        start..self.bytes.len() as u32
    }

    /// The bytes it takes, about.
    fn size(&self) -> usize {
        self.bytes.len()
            + self.outcomes.len() * std::mem::size_of::<Outcome>()
            + (self.inputs.len() + self.groups.len() + self.new_pending.len())
                * std::mem::size_of::<Range<u32>>()
            + self.new_timers.len() * std::mem::size_of::<NewTimer>()
            + std::mem::size_of::<Entry>()
    }

    /// The edges of the state `key` (read into `parts`) by these outcomes,
    /// in the order the player's runs would give them, to `push` (label,
    /// successor's key). Of the outcomes of one input that end alike (same
    /// label but for the oracle's answers, same successor), only the first
    /// is an edge. `next`, `pushed` and `keys` are buffers.
    pub fn edges(
        &self,
        key: &[u8],
        parts: &Parts,
        next: &mut Vec<u8>,
        pushed: &mut Vec<(usize, Range<usize>)>,
        keys: &mut Vec<u8>,
        push: &mut dyn FnMut(u32, &[u8]),
    ) {
        for j in 0..=parts.pending() {
            // The events and timers, then the results in the key's order.
            let group = if j == 0 { 0 } else { 1 + parts.canon(j - 1) };
            for input in self.group(group) {
                pushed.clear();
                keys.clear();
                for (k, o) in self.outcomes(input).iter().enumerate() {
                    self.apply(o, key, parts, next);
                    if !o.flagged && next[..] == *key {
                        continue; // nothing happened: not an edge
                    }
                    if pushed
                        .iter()
                        .any(|(i, range)| o.alike & 1 << i != 0 && keys[range.clone()] == next[..])
                    {
                        continue;
                    }
                    let start = keys.len();
                    keys.extend_from_slice(next);
                    pushed.push((k, start..keys.len()));
                    push(o.label, next);
                }
            }
        }
    }

    /// Writes into `out` the key `outcome` makes of `key` (read into
    /// `parts`), whose projection is the one the outcome was kept for.
    pub fn apply(&self, outcome: &Outcome, key: &[u8], parts: &Parts, out: &mut Vec<u8>) {
        out.clear();
        let h = &outcome.head;
        out.extend_from_slice(&self.bytes[h.start as usize..h.end as usize]);
        // Timers: the kept ones and the new, in net and timer order, start
        // order renumbered by rank, groups by first appearance.
        // (net, timer, position: a kept one's, or 64 + a new one's.)
        let mut timers: SmallVec<[(u32, u32, u32); 16]> = SmallVec::new();
        let mut seqs: SmallVec<[u32; 16]> = SmallVec::new();
        for (i, t) in parts.timers.iter().enumerate() {
            if outcome.timers_kept & 1 << i != 0 {
                timers.push((t.net, t.timer, i as u32));
                seqs.push(t.rank);
            }
        }
        let fresh =
            &self.new_timers[outcome.new_timers.start as usize..outcome.new_timers.end as usize];
        for (k, t) in fresh.iter().enumerate() {
            timers.push((t.net, t.timer, (MOST + k) as u32));
            seqs.push(new_seq(k));
        }
        if !fresh.is_empty() {
            // (The kept ones alone are in net and timer order already.)
            timers.sort_unstable_by_key(|&(net, timer, _)| (net, timer));
        }
        seqs.sort_unstable();
        let mut groups: SmallVec<[u32; 16]> = SmallVec::new();
        out.extend_from_slice(&(timers.len() as u32).to_le_bytes());
        for &(_, _, i) in &timers {
            let i = i as usize;
            // Net, timer, duration; the start order (`seq`, ranked below),
            // the category and the group.
            let (seq, catastrophic, group) = if i < MOST {
                let t = &parts.timers[i];
                let at = t.at as usize;
                out.extend_from_slice(&key[at..at + 16]);
                (t.rank, key[at + 20], t.group)
            } else {
                let t = &fresh[i - MOST];
                out.extend_from_slice(&t.net.to_le_bytes());
                out.extend_from_slice(&t.timer.to_le_bytes());
                out.extend_from_slice(&t.duration.to_le_bytes());
                (new_seq(i - MOST), u8::from(t.catastrophic), FRESH)
            };
            let rank = seqs.binary_search(&seq).unwrap_or(0) as u32;
            out.extend_from_slice(&rank.to_le_bytes());
            out.push(catastrophic);
            let g = match groups.iter().position(|&old| old == group) {
                Some(g) => g,
                None => {
                    groups.push(group);
                    groups.len() - 1
                }
            };
            out.extend_from_slice(&(g as u32).to_le_bytes());
        }
        // Pending results: the kept ones in the key's order, then the new
        // ones, at most `MAX_SAME_PENDING` alike.
        let count_at = out.len();
        out.extend_from_slice(&0u32.to_le_bytes());
        let mut kept: SmallVec<[Range<usize>; 16]> = SmallVec::new();
        for (j, (r, _)) in parts.pending.iter().enumerate() {
            if outcome.pending_kept & 1 << parts.canon(j) != 0 {
                let start = out.len();
                out.extend_from_slice(&key[r.start as usize..r.end as usize]);
                kept.push(start..out.len());
            }
        }
        let news =
            &self.new_pending[outcome.new_pending.start as usize..outcome.new_pending.end as usize];
        for r in news {
            let entry = &self.bytes[r.start as usize..r.end as usize];
            if kept.iter().filter(|k| out[(*k).clone()] == *entry).count() < MAX_SAME_PENDING {
                let start = out.len();
                out.extend_from_slice(entry);
                kept.push(start..out.len());
            }
        }
        out[count_at..count_at + 4].copy_from_slice(&(kept.len() as u32).to_le_bytes());
    }
}

/// The entry of one state being captured by a worker (see
/// [`Capture::begin`]).
#[derive(Default)]
pub(super) struct Capture {
    entry: Entry,
    /// A state's outcomes are being captured.
    active: bool,
    /// The group of the input being captured, and its first outcome.
    group: usize,
    input_start: u32,
}

/// What [`Capture::outcome`] needs of the step.
pub(super) struct Step<'a> {
    /// The key the step ran from, and its parts.
    pub key: &'a [u8],
    pub parts: &'a Parts,
    /// The player's state after it.
    pub after: &'a State,
    /// The timers numbered from `seq_before` on, and the results from
    /// `next_id` on, are the step's.
    pub seq_before: u64,
    pub next_id: u64,
    /// The instant the step ran at.
    pub step_time: Micros,
    /// The successor's key, as encoded.
    pub next: &'a [u8],
    pub relevant: &'a dyn Fn(&Pending) -> bool,
}

impl Capture {
    /// Starts capturing the outcomes of a state with `pending` results.
    pub fn begin(&mut self, pending: usize) {
        let e = &mut self.entry;
        e.inputs.clear();
        e.outcomes.clear();
        e.new_timers.clear();
        e.new_pending.clear();
        e.bytes.clear();
        e.groups.clear();
        e.groups.resize(pending + 1, 0..0);
        self.active = true;
        self.group = 0;
        self.input_start = 0;
    }

    /// Whether a state's outcomes are being captured.
    pub fn active(&self) -> bool {
        self.active
    }

    /// The next outcomes captured belong to an input of group `g`.
    pub fn input(&mut self, g: usize) {
        if !self.active {
            return;
        }
        if g >= self.entry.groups.len() {
            self.active = false;
            return;
        }
        self.group = g;
        self.input_start = self.entry.outcomes.len() as u32;
    }

    /// Ends the input begun by [`Capture::input`].
    pub fn end_input(&mut self) {
        if !self.active {
            return;
        }
        let e = &mut self.entry;
        let end = e.outcomes.len() as u32;
        let i = e.inputs.len() as u32;
        let r = &mut e.groups[self.group];
        if r.start == r.end {
            *r = i..i;
        }
        if r.end != i {
            // Inputs of one group are listed together: anything else is
            // not kept.
            self.active = false;
            return;
        }
        r.end = i + 1;
        e.inputs.push(self.input_start..end);
    }

    /// Gives up the state's outcomes (they cannot all be kept).
    pub fn abandon(&mut self) {
        self.active = false;
    }

    /// Captures the outcome of one run of the player, checked: the outcome
    /// applied to the key it ran from must give the key the player's state
    /// was encoded to, or the state's outcomes are not kept. `alike` says
    /// whether two labels end alike.
    pub fn outcome(
        &mut self,
        codec: &Codec,
        s: &Step<'_>,
        label: u32,
        flagged: bool,
        alike: &dyn Fn(u32, u32) -> bool,
        scratch: &mut Vec<u8>,
    ) {
        if !self.active {
            return;
        }
        let e = &mut self.entry;
        let earlier = &e.outcomes[self.input_start as usize..];
        if earlier.len() >= MOST {
            self.active = false;
            return;
        }
        let alike = earlier
            .iter()
            .enumerate()
            .filter(|(_, o)| alike(o.label, label))
            .fold(0u64, |bits, (k, _)| bits | 1 << k);
        let head_len = codec.head_len(s.next);
        let head = e.push_bytes(&s.next[..head_len]);
        let mut timers_kept = 0u64;
        let mut fresh: SmallVec<[(u64, NewTimer); 4]> = SmallVec::new();
        for t in &s.after.timers {
            if t.seq < s.seq_before {
                match s
                    .parts
                    .timers
                    .iter()
                    .position(|o| o.net as usize == t.net && o.timer as usize == t.timer)
                {
                    Some(i) => timers_kept |= 1 << i,
                    None => {
                        self.active = false;
                        return;
                    }
                }
            } else {
                fresh.push((
                    t.seq,
                    NewTimer {
                        net: t.net as u32,
                        timer: t.timer as u32,
                        duration: t.deadline.saturating_sub(s.step_time.min(t.deadline)),
                        catastrophic: t.catastrophic,
                    },
                ));
            }
        }
        fresh.sort_by_key(|(seq, _)| *seq);
        let start = e.new_timers.len() as u32;
        e.new_timers.extend(fresh.iter().map(|(_, t)| *t));
        let new_timers = start..e.new_timers.len() as u32;
        let mut pending_kept = 0u64;
        let start = e.new_pending.len() as u32;
        for (&id, p) in &s.after.pending {
            if id < s.next_id {
                let j = id.wrapping_sub(1) as usize;
                if j >= s.parts.pending() {
                    self.active = false;
                    return;
                }
                pending_kept |= 1 << s.parts.canon(j);
            } else if (s.relevant)(p) {
                scratch.clear();
                codec.write_pending(p, scratch);
                let r = e.push_bytes(&scratch[..]);
                e.new_pending.push(r);
            }
        }
        let new_pending = start..e.new_pending.len() as u32;
        let outcome = Outcome {
            label,
            flagged,
            alike,
            head,
            timers_kept,
            new_timers,
            pending_kept,
            new_pending,
        };
        scratch.clear();
        e.apply(&outcome, s.key, s.parts, scratch);
        if scratch[..] != *s.next {
            self.active = false;
            return;
        }
        e.outcomes.push(outcome);
    }

    /// The state's entry, if every outcome of it was captured (in
    /// allocations of its size: the capture's own are used again).
    pub fn finish(&mut self) -> Option<Entry> {
        let active = std::mem::replace(&mut self.active, false);
        let e = &self.entry;
        active.then(|| Entry {
            groups: e.groups.clone(),
            inputs: e.inputs.clone(),
            outcomes: e.outcomes.clone(),
            new_timers: e.new_timers.clone(),
            new_pending: e.new_pending.clone(),
            bytes: e.bytes.clone(),
        })
    }
}

/// Shards of [`Kept`] (each behind its own lock).
const SHARDS: usize = 64;

/// A kept entry: its projection's hash and bytes, and its outcomes.
type Kept1 = (u64, Box<[u8]>, Arc<Entry>);

/// The outcomes kept, by projection, for every worker: shards of a hash
/// table each behind a lock, held only to find or add an entry.
pub(super) struct Kept {
    shards: Vec<Mutex<HashTable<Kept1>>>,
    /// The bytes kept, and the most that may be.
    size: AtomicUsize,
    budget: usize,
}

impl Kept {
    /// Nothing kept yet; at most `budget` bytes will be.
    pub fn new(budget: usize) -> Kept {
        Kept {
            shards: (0..SHARDS).map(|_| Mutex::new(HashTable::new())).collect(),
            size: AtomicUsize::new(0),
            budget,
        }
    }

    fn shard(&self, h: u64) -> std::sync::MutexGuard<'_, HashTable<Kept1>> {
        // The high bits choose the shard (the table uses the low ones).
        self.shards[(h >> 58) as usize % SHARDS]
            .lock()
            .unwrap_or_else(|e| e.into_inner())
    }

    /// The entry of `projection` (of hash `h`), if kept.
    pub fn find(&self, projection: &[u8], h: u64) -> Option<Arc<Entry>> {
        self.shard(h)
            .find(h, |(g, p, _)| *g == h && **p == *projection)
            .map(|(_, _, e)| e.clone())
    }

    /// Whether the outcomes kept take the budget (no more are kept).
    pub fn full(&self) -> bool {
        self.size.load(Ordering::Relaxed) >= self.budget
    }

    /// Keeps `entry` under `projection` (of hash `h`), unless another
    /// worker kept it meanwhile.
    pub fn insert(&self, projection: &[u8], h: u64, entry: Entry) {
        let size = entry.size() + projection.len();
        let mut shard = self.shard(h);
        if shard
            .find(h, |(g, p, _)| *g == h && **p == *projection)
            .is_none()
        {
            shard.insert_unique(h, (h, projection.into(), Arc::new(entry)), |(g, _, _)| *g);
            self.size.fetch_add(size, Ordering::Relaxed);
        }
    }

    /// The hash [`Kept::find`] and [`Kept::insert`] take.
    pub fn hash(projection: &[u8]) -> u64 {
        hash(projection)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn past_the_budget_nothing_is_kept_and_a_group_met_twice_apart_is_not_kept() {
        let kept = Kept::new(0);
        assert!(kept.full());
        let kept = Kept::new(BUDGET);
        assert!(!kept.full());
        kept.insert(b"p", Kept::hash(b"p"), Entry::default());
        assert!(kept.find(b"p", Kept::hash(b"p")).is_some());
        assert!(kept.find(b"q", Kept::hash(b"q")).is_none());
        let mut capture = Capture::default();
        capture.begin(2);
        assert!(capture.active());
        // An input of a group the state does not have: nothing kept.
        capture.input(3);
        assert!(capture.finish().is_none());
        capture.begin(2);
        // A group of inputs met twice apart is not kept.
        capture.input(0);
        capture.end_input();
        capture.input(1);
        capture.end_input();
        capture.input(0);
        capture.end_input();
        assert!(capture.finish().is_none());
        capture.begin(2);
        capture.input(0);
        capture.end_input();
        capture.input(2);
        capture.end_input();
        let entry = capture.finish().unwrap_or_default();
        assert_eq!(entry.inputs.len(), 2);
        assert!(entry.group(1).is_empty());
        assert_eq!(entry.group(2).len(), 1);
    }
}
