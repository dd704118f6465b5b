//! Explicit-state exploration of a P/T net's token game.
//!
//! Two engines share one loop ([`engine`]): markings of 1-safe nets as
//! bitsets (one bit per place), and markings as counts of 1, 2 or 4 bytes
//! per place for the others. Exploration starts with bitsets when the
//! initial marking is safe; the first firing that would put a second token
//! in a place stops it, and the net is explored again with counts (reported
//! not safe, with a shortest firing sequence to a marking that is not
//! 1-safe). Counts that outgrow their width restart with wider counts.
//!
//! Markings are stored back to back in one arena, without parent links
//! (no allocation per state), and found through a table of 32-bit hash +
//! index entries, compared in full on a hash match. A transition is looked
//! at only when its least-often-marked input place (measured on a first
//! sample of the state space) is marked. With `threads > 1` the state space
//! is split in partitions by hash, one thread each (see [`engine`]).
//!
//! The stored state space is kept ([`Exploration`]) so counterexamples are
//! rebuilt level by level, and loops found by strongly connected components
//! over the arcs kept during the exploration ([`Options::keep_arcs`], see
//! `edges.rs`; the hash tables are freed then), or else over successors
//! regenerated on demand.

mod edges;
mod engine;
mod ids;
mod semantics;
mod store;

use std::cell::RefCell;

use super::graph::{self, Adjacency, Sccs, Successors};
use super::ptnet::PtNet;
use engine::{run, Partitioner, Run};
use ids::{split_id, state_id, MAX_PER_PARTITION, MAX_THREADS};
use semantics::{load_words, mix, push_words, to_bytes, to_words, Bits, Counts, Semantics, Stop};

/// How to explore.
#[derive(Clone, Copy)]
pub struct Options<'a> {
    /// Threads (1 to 16); each owns one partition of the state space.
    pub threads: usize,
    /// Stop storing markings past this many (a "state limit reached"
    /// result): exactly on one thread, after the breadth-first level that
    /// passes it on more.
    pub max_states: u64,
    /// Called now and then with the number of markings stored so far.
    pub progress: Option<&'a (dyn Fn(u64) + Sync)>,
    /// Use several threads only when there are more markings than this
    /// (default 4096: below, one thread is faster). 0 forces the parallel
    /// engine (tests).
    pub parallel_from: u64,
    /// On several threads, split 1-safe state spaces by a few places chosen
    /// on the sample (fewer markings cross between threads) rather than by
    /// hash. Default false: on an idle machine hashing balances the threads
    /// better and wins (BENCHMARKS.md).
    pub partition_by_places: bool,
    /// Keep the successors of every marking as they are found (4 bytes per
    /// arc and 4 per marking, see `edges.rs`; the hash tables
    /// are freed once the exploration ends) so that [`Exploration::loops`]
    /// need not fire every transition again. Default false: `loops` then
    /// recomputes them.
    pub keep_arcs: bool,
}

impl Default for Options<'_> {
    fn default() -> Self {
        Options {
            threads: 1,
            max_states: 100_000_000,
            progress: None,
            parallel_from: u64::from(SAMPLE),
            partition_by_places: false,
            keep_arcs: false,
        }
    }
}

/// Whether the whole state space was explored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Completion {
    Complete,
    /// `max_states` markings were stored and more were reachable.
    StateLimit,
    /// A place would hold more than 2^32 - 1 tokens.
    TokenLimit,
}

/// The marking encoding of the run that produced the figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Engine {
    Bits,
    Counts8,
    Counts16,
    Counts32,
}

/// The figures of an exploration.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Summary {
    /// Reachable markings (stored markings if not complete).
    pub states: u64,
    /// (marking, enabled transition) pairs, as the Model Checking Contest
    /// counts the arcs of a reachability graph.
    pub edges: u64,
    pub dead_markings: u64,
    /// The most tokens in one place of a reachable marking.
    pub max_tokens: u32,
    /// No reachable marking puts two tokens in a place.
    pub safe: bool,
    pub completion: Completion,
    pub engine: Engine,
    pub threads: usize,
    /// Memory holding the stored markings and hash tables.
    pub stored_bytes: u64,
    /// Memory holding the kept successors ([`Options::keep_arcs`]).
    pub arc_bytes: u64,
    /// Transitions that fire in no reachable marking.
    pub never_fired: Vec<usize>,
}

macro_rules! on_space {
    ($space:expr, $r:ident => $e:expr) => {
        match $space {
            Space::Bits($r) => $e,
            Space::C8($r) => $e,
            Space::C16($r) => $e,
            Space::C32($r) => $e,
        }
    };
}

enum Space {
    Bits(Run<Bits>),
    C8(Run<Counts<1>>),
    C16(Run<Counts<2>>),
    C32(Run<Counts<4>>),
}

/// A finished exploration: its figures and its stored markings.
pub struct Exploration<'n> {
    net: &'n PtNet,
    pub summary: Summary,
    space: Space,
}

/// A cycle of the reachability graph.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Loop {
    /// Markings in its strongly connected component.
    pub states: u32,
    /// A shortest firing sequence from the initial marking to the component.
    pub prefix: Vec<usize>,
    /// A shortest firing sequence from there back to the same marking.
    pub cycle: Vec<usize>,
}

/// The cycles of the reachability graph.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Loops {
    /// Strongly connected components holding a cycle.
    pub cyclic_components: u64,
    /// Markings in the largest of them.
    pub largest: u32,
    /// Some of them (the first reached), with a cycle each.
    pub listed: Vec<Loop>,
}

/// Markings explored first, on one thread, to measure how often each place
/// is marked (which picks each transition's trigger place). When the whole
/// state space fits, this sample is the answer.
const SAMPLE: u32 = 4096;

/// What the sample tells: how many sampled markings mark each place, the
/// places to partition bit markings by on `threads` threads (see
/// [`Partitioner`]), and the sample itself when it is a complete exploration.
struct Sample {
    frequencies: Vec<u64>,
    partition_places: Vec<u32>,
    complete: Option<Space>,
}

fn frequencies<S: Semantics>(r: &Run<S>, freq: &mut [u64]) {
    for store in &r.stores {
        for i in 0..store.len() {
            for (f, c) in freq.iter_mut().zip(r.sem.counts(store.get(i))) {
                *f += u64::from(c > 0);
            }
        }
    }
}

/// Places marked in 25 % to 75 % of the sampled markings and changed by
/// the fewest sampled firings, enough of them to number `threads`
/// partitions, if they split the sample evenly enough.
fn partition_places(r: &Run<Bits>, marked: &[u64], threads: usize) -> Vec<u32> {
    // a few more places than needed to number the partitions: the
    // partition of a marking is a hash of their 2^k combinations, which
    // evens out the shares
    let k = (usize::BITS - (threads.max(2) - 1).leading_zeros() + 5).min(16);
    let states = r.states().max(1);
    let mut flips = vec![0u64; marked.len()];
    let mut child = Vec::new();
    let store = &r.stores[0];
    for i in 0..store.len() {
        let m = to_words(store.get(i));
        let _ = r.sem.expand(&m, r.sem.key(&m), &mut child, |_, c, _| {
            for (w, (a, b)) in m.iter().zip(c).enumerate() {
                let mut x = a ^ b;
                while x != 0 {
                    let p = w * 64 + x.trailing_zeros() as usize;
                    x &= x - 1;
                    if let Some(f) = flips.get_mut(p) {
                        *f += 1;
                    }
                }
            }
        });
    }
    let mut candidates: Vec<usize> = (0..marked.len())
        .filter(|&p| marked[p] * 4 >= states && marked[p] * 4 <= 3 * states)
        .collect();
    candidates.sort_by_key(|&p| (flips[p], p));
    if candidates.len() < 2 {
        return Vec::new();
    }
    // skip places that always agree (or always disagree) with one taken
    // already on the sample: they add nothing to the index
    let bit = |i: u32, p: usize| (store.get(i)[p >> 3] >> (p & 7)) & 1;
    let mut chosen: Vec<usize> = Vec::new();
    for &q in &candidates {
        if chosen.len() == k as usize {
            break;
        }
        let redundant = chosen.iter().any(|&p| {
            let same = (0..store.len()).filter(|&i| bit(i, p) == bit(i, q)).count() as u32;
            same == 0 || same == store.len()
        });
        if !redundant {
            chosen.push(q);
        }
    }
    let places: Vec<u32> = chosen.iter().map(|&p| p as u32).collect();
    let partitioner = Partitioner::by_places(threads, places.clone());
    let mut share = vec![0u64; threads];
    for i in 0..store.len() {
        share[partitioner.of(store.get(i), 0)] += 1;
    }
    let fair = states / threads as u64;
    if share.iter().any(|&s| s * 2 < fair) {
        return Vec::new();
    }
    places
}

/// Explores up to [`SAMPLE`] markings on one thread.
fn sample(net: &PtNet, initial: &[u32], threads: usize, keep_arcs: bool) -> Sample {
    let zero = vec![0u64; net.places.len()];
    let mut freq = zero.clone();
    if initial.iter().all(|&c| c <= 1) {
        let sem = Bits::new(net, &zero);
        let m = sem.encode(initial);
        let r = run(sem, &m, Partitioner::by_hash(1), SAMPLE, None, keep_arcs);
        frequencies(&r, &mut freq);
        let partition_places = if threads > 1 {
            partition_places(&r, &freq, threads)
        } else {
            Vec::new()
        };
        let complete = !r.full && r.stop.is_none();
        Sample {
            frequencies: freq,
            partition_places,
            complete: complete.then_some(Space::Bits(r)),
        }
    } else {
        let sem = Counts::<4>::new(net, &zero);
        let mut s = Sample {
            frequencies: Vec::new(),
            partition_places: Vec::new(),
            complete: None,
        };
        if let Some(m) = sem.encode(initial) {
            let r = run(sem, &m, Partitioner::by_hash(1), SAMPLE, None, keep_arcs);
            frequencies(&r, &mut freq);
            let complete = !r.full && r.stop.is_none();
            s.complete = complete.then_some(Space::C32(r));
        }
        s.frequencies = freq;
        s
    }
}

fn counts_run<const W: usize>(
    net: &PtNet,
    freq: &[u64],
    initial: &[u32],
    threads: usize,
    limit: u32,
    progress: Option<&(dyn Fn(u64) + Sync)>,
    keep_arcs: bool,
) -> Option<Run<Counts<W>>> {
    let sem = Counts::<W>::new(net, freq);
    let m = sem.encode(initial)?;
    Some(run(
        sem,
        &m,
        Partitioner::by_hash(threads),
        limit,
        progress,
        keep_arcs,
    ))
}

/// Explores the reachable markings of `net`.
pub fn explore<'n>(net: &'n PtNet, options: &Options) -> Exploration<'n> {
    let threads = options.threads.clamp(1, MAX_THREADS);
    let per_partition = options.max_states.clamp(1, u64::from(MAX_PER_PARTITION)) as u32;
    let initial = net.initial_marking();
    let Sample {
        frequencies: freq,
        partition_places,
        complete: small,
    } = sample(net, &initial, threads, options.keep_arcs);
    if let Some(space) = small {
        let states = on_space!(&space, r => r.states());
        if states <= options.max_states && (threads == 1 || states <= options.parallel_from) {
            return Exploration::new(net, space, 1);
        }
    }
    let progress = options.progress;
    let keep = options.keep_arcs;
    let mut space = None;
    if initial.iter().all(|&c| c <= 1) {
        let sem = Bits::new(net, &freq);
        let m = sem.encode(&initial);
        let partitioner = if options.partition_by_places {
            Partitioner::by_places(threads, partition_places)
        } else {
            Partitioner::by_hash(threads)
        };
        let r = run(sem, &m, partitioner, per_partition, progress, keep);
        if r.stop != Some(Stop::Unsafe) {
            space = Some(Space::Bits(r));
        }
    }
    let space = match space {
        Some(s) => s,
        None => match counts_run::<1>(net, &freq, &initial, threads, per_partition, progress, keep)
        {
            Some(r) if r.stop != Some(Stop::Overflow) => Space::C8(r),
            _ => {
                match counts_run::<2>(net, &freq, &initial, threads, per_partition, progress, keep)
                {
                    Some(r) if r.stop != Some(Stop::Overflow) => Space::C16(r),
                    _ => {
                        match counts_run::<4>(
                            net,
                            &freq,
                            &initial,
                            threads,
                            per_partition,
                            progress,
                            keep,
                        ) {
                            Some(r) => Space::C32(r),
                            // u32 counts always hold the initial marking
                            None => unreachable_run(net, &freq, threads),
                        }
                    }
                }
            }
        },
    };
    Exploration::new(net, space, threads)
}

impl<'n> Exploration<'n> {
    fn new(net: &'n PtNet, space: Space, threads: usize) -> Self {
        let summary = match &space {
            Space::Bits(r) => summarize(r, Engine::Bits, threads, net.transitions.len()),
            Space::C8(r) => summarize(r, Engine::Counts8, threads, net.transitions.len()),
            Space::C16(r) => summarize(r, Engine::Counts16, threads, net.transitions.len()),
            Space::C32(r) => summarize(r, Engine::Counts32, threads, net.transitions.len()),
        };
        let mut space = space;
        on_space!(&mut space, r => {
            if !r.arcs.is_empty() {
                // the loop analysis and the counterexamples read the kept
                // arcs: nothing is looked up again
                for store in &mut r.stores {
                    store.drop_table();
                }
            }
        });
        Exploration {
            net,
            summary,
            space,
        }
    }
}

/// An empty run, never used in practice (u32 counts hold any initial marking).
fn unreachable_run(net: &PtNet, freq: &[u64], threads: usize) -> Space {
    let sem = Counts::<4>::new(net, freq);
    let m = vec![0u8; sem.width()];
    let mut r = run(sem, &m, Partitioner::by_hash(threads), 1, None, false);
    r.stop = Some(Stop::Overflow);
    Space::C32(r)
}

fn summarize<S: Semantics>(
    r: &Run<S>,
    engine: Engine,
    threads: usize,
    transitions: usize,
) -> Summary {
    Summary {
        states: r.states(),
        edges: r.edges,
        dead_markings: r.dead,
        max_tokens: r.max_tokens,
        safe: r.max_tokens <= 1,
        completion: if r.stop == Some(Stop::Overflow) {
            Completion::TokenLimit
        } else if r.full {
            Completion::StateLimit
        } else {
            Completion::Complete
        },
        engine,
        threads,
        stored_bytes: r.stores.iter().map(|s| s.bytes()).sum(),
        arc_bytes: r.arcs.iter().map(|a| a.bytes()).sum(),
        never_fired: (0..transitions)
            .filter(|&t| !r.fired.get(t).copied().unwrap_or(false))
            .collect(),
    }
}

/// The transitions along a chain of state ids (between two markings, the
/// transition of smallest index that leads from one to the other).
fn firing_sequence<S: Semantics>(r: &Run<S>, chain: &[u32]) -> Vec<usize> {
    let mut child = Vec::with_capacity(r.sem.words());
    chain
        .windows(2)
        .filter_map(|w| {
            let from = r.marking(w[0]);
            let to = r.marking(w[1]);
            let mut found = None;
            let from = to_words(from);
            let _ = r
                .sem
                .expand(&from, r.sem.key(&from), &mut child, |t, m, _| {
                    if to_bytes(m, to.len()) == to {
                        found = Some(found.map_or(t as usize, |f: usize| f.min(t as usize)));
                    }
                });
            found
        })
        .collect()
}

/// State ids from the initial marking to `id`: a shortest path, rebuilt
/// backwards level by level (no parent links are stored): a predecessor of
/// a marking of level k is a marking of level k - 1 with it as successor,
/// and the one taken is the smallest (in stored form), so that the path is
/// the same whatever the threads that stored the markings. The
/// predecessors are found in the arcs of level k - 1 when they are kept,
/// else by firing each transition backwards and looking the result up.
fn chain_to<S: Semantics>(r: &Run<S>, net: &PtNet, id: u32) -> Vec<u32> {
    let offsets = r.offsets();
    let mut chain = vec![id];
    let mut cur = id;
    for k in (0..r.level(id)).rev() {
        let before = if r.arcs.is_empty() {
            fired_backwards(r, net, cur, k)
        } else {
            leading_to(r, k, dense_of(&offsets, cur)).collect()
        };
        match before
            .into_iter()
            .min_by(|&a, &b| r.marking(a).cmp(r.marking(b)))
        {
            Some(p) => {
                chain.push(p);
                cur = p;
            }
            None => break,
        }
    }
    chain.reverse();
    chain
}

/// The ids of the markings of level `k` with a kept arc to dense node
/// `target`: each partition's arcs of that level looked at all at once
/// first (most hold none to it), then marking by marking.
fn leading_to<S: Semantics>(r: &Run<S>, k: usize, target: u32) -> impl Iterator<Item = u32> + '_ {
    r.arcs.iter().enumerate().flat_map(move |(p, arcs)| {
        let range = r.level_range(p, k);
        let any = arcs.span(range.clone()).contains(&target);
        range
            .filter(move |_| any)
            .filter(move |&l| arcs.targets(l).contains(&target))
            .map(move |l| state_id(p, l))
    })
}

/// The markings of level `k` from which a transition leads to `id`: each
/// transition fired backwards from it (when it holds what the transition
/// puts), the result looked up.
fn fired_backwards<S: Semantics>(r: &Run<S>, net: &PtNet, id: u32, k: usize) -> Vec<u32> {
    let m = r.sem.counts(r.marking(id));
    net.transitions
        .iter()
        .filter_map(|t| {
            if t.post.iter().any(|&(p, w)| m.get(p).is_none_or(|&c| c < w)) {
                return None;
            }
            let mut prev = m.clone();
            for &(p, w) in &t.post {
                let c = prev.get_mut(p)?;
                *c = c.checked_sub(w)?;
            }
            for &(p, w) in &t.pre {
                let c = prev.get_mut(p)?;
                *c = c.checked_add(w)?;
            }
            let bytes = r.sem.stored(&prev)?;
            let p = r.lookup_hashed(&bytes, mix(r.sem.key(&to_words(&bytes))))?;
            (r.level(p) == k).then_some(p)
        })
        .collect()
}

/// Scratch space of [`Graph`]: the marking as words, a successor, the
/// successors as bytes, their hashes.
type Scratch = (Vec<u64>, Vec<u64>, Vec<u8>, Vec<u64>);

/// The reachability graph over dense node numbers, successors recomputed
/// from the stored markings.
pub struct Graph<'r, S> {
    run: &'r Run<S>,
    offsets: Vec<u32>,
    /// Scratch: the marking as words, a successor, a successor as bytes.
    scratch: RefCell<Scratch>,
}

impl<'r, S: Semantics> Graph<'r, S> {
    fn new(run: &'r Run<S>) -> Self {
        let mut offsets = vec![0u32];
        for s in &run.stores {
            let last = offsets.last().copied().unwrap_or(0);
            offsets.push(last + s.len());
        }
        Graph {
            run,
            offsets,
            scratch: RefCell::new(Scratch::default()),
        }
    }

    fn dense(&self, id: u32) -> u32 {
        let (p, l) = split_id(id);
        self.offsets[p] + l
    }

    fn id(&self, node: u32) -> u32 {
        let p = self.offsets.partition_point(|&o| o <= node) - 1;
        state_id(p, node - self.offsets[p])
    }
}

impl<S: Semantics> Successors for Graph<'_, S> {
    fn node_count(&self) -> usize {
        self.offsets.last().copied().unwrap_or(0) as usize
    }

    fn successors(&self, node: u32, out: &mut Vec<u32>) {
        let sem = &self.run.sem;
        let width = sem.width();
        let record = sem.words() * 8;
        let mut scratch = self.scratch.borrow_mut();
        let (m, child, bytes, hashes) = &mut *scratch;
        m.resize(sem.words(), 0);
        load_words(self.run.marking(self.id(node)), m);
        bytes.clear();
        hashes.clear();
        let _ = sem.expand(m, sem.key(m), child, |_, c, k| {
            push_words(bytes, c);
            hashes.push(mix(k));
        });
        // fetch all table slots, then all records, then look up (the cache
        // misses overlap)
        for (i, &h) in hashes.iter().enumerate() {
            self.run
                .prefetch_slot(&bytes[i * record..i * record + width], h);
        }
        for (i, &h) in hashes.iter().enumerate() {
            self.run
                .prefetch_record(&bytes[i * record..i * record + width], h);
        }
        for (i, &h) in hashes.iter().enumerate() {
            if let Some(id) = self
                .run
                .lookup_hashed(&bytes[i * record..i * record + width], h)
            {
                out.push(self.dense(id));
            }
        }
    }
}

/// The reachability graph over the successors kept by the exploration
/// ([`Options::keep_arcs`]), in dense numbers.
struct Kept<'r> {
    arcs: &'r [edges::Edges],
    offsets: Vec<u32>,
}

impl Kept<'_> {
    /// The partition of `node` and its index there.
    #[inline]
    fn local(&self, node: u32) -> (usize, u32) {
        // a few partitions: a scan beats a binary search
        let mut p = 0;
        while p + 1 < self.arcs.len() && node >= self.offsets[p + 1] {
            p += 1;
        }
        (p, node - self.offsets[p])
    }

    #[inline]
    fn of(&self, node: u32) -> &[u32] {
        let (p, i) = self.local(node);
        self.arcs[p].targets(i)
    }
}

impl Adjacency for Kept<'_> {
    type Targets<'a>
        = std::iter::Copied<std::slice::Iter<'a, u32>>
    where
        Self: 'a;

    fn nodes(&self) -> usize {
        self.offsets.last().copied().unwrap_or(0) as usize
    }

    #[inline]
    fn targets(&self, node: u32) -> Self::Targets<'_> {
        self.of(node).iter().copied()
    }

    /// Each partition's markings among `nodes`, with their arcs as kept.
    fn stretches(&self, nodes: std::ops::Range<u32>) -> Option<Vec<graph::Stretch<'_>>> {
        let mut out = Vec::with_capacity(self.arcs.len());
        for (p, arcs) in self.arcs.iter().enumerate() {
            let (lo, hi) = (*self.offsets.get(p)?, *self.offsets.get(p + 1)?);
            let (a, b) = (nodes.start.max(lo), nodes.end.min(hi));
            if a < b {
                let (starts, targets) = arcs.stretch(a - lo..b - lo)?;
                out.push(graph::Stretch {
                    first: a,
                    starts,
                    targets,
                });
            }
        }
        Some(out)
    }

    #[inline]
    fn prefetch(&self, node: u32, near: bool) {
        let (p, i) = self.local(node);
        if let Some(a) = self.arcs.get(p) {
            if near {
                a.prefetch_targets(i);
            } else {
                a.prefetch_start(i);
            }
        }
    }
}

impl Successors for Kept<'_> {
    fn node_count(&self) -> usize {
        self.offsets.last().copied().unwrap_or(0) as usize
    }

    fn successors(&self, node: u32, out: &mut Vec<u32>) {
        out.extend_from_slice(self.of(node));
    }
}

/// The state id of dense node `node` (partitions numbered one after the
/// other from `offsets`).
fn id_of(offsets: &[u32], node: u32) -> u32 {
    let p = offsets.partition_point(|&o| o <= node) - 1;
    state_id(p, node - offsets[p])
}

fn loops_of<S: Semantics>(r: &Run<S>, net: &PtNet, max_listed: usize, threads: usize) -> Loops {
    if r.arcs.is_empty() {
        let g = Graph::new(r);
        let sccs = graph::strongly_connected_components(&g);
        loops_in(r, net, &g, &sccs, max_listed, None)
    } else {
        let kept = Kept {
            arcs: &r.arcs,
            offsets: r.offsets(),
        };
        let first = r.level_ids(0).next().unwrap_or(0);
        let initial = dense_of(&kept.offsets, first);
        let (p0, l0) = split_id(first);
        let entered = l0 != 0 || r.arcs.iter().any(|a| a.leads_to_first(p0));
        // A shortest cycle through the initial marking: listed first (its
        // component is the first reached), and its markings, at every
        // depth down to the deepest on the cycle, all reach the initial
        // one: the sweeps start from them. Found from the levels, not by
        // a search (the loop analysis of ParamProductionCell-PT-3 in
        // 39-45 ms instead of 49-52).
        let cycle = if entered && max_listed > 0 {
            cycle_through_initial(r, net, &kept, initial)
        } else {
            None
        };
        let seeds = cycle.as_deref().unwrap_or_default();
        let prefix = (!entered).then(|| prefix_of(r, &kept, initial, threads));
        let sccs = graph::strongly_connected_components_from(
            &kept,
            initial,
            entered,
            seeds,
            || breadth_first_order(r, &kept.offsets),
            threads,
            prefix.as_ref(),
        );
        let known = cycle.map(|c| (initial, c));
        loops_in(r, net, &kept, &sccs, max_listed, known)
    }
}

/// A shortest cycle through the initial marking (dense number `initial`),
/// as [`graph::shortest_cycle`] gives it (the initial marking first, not
/// repeated at the end), found from the levels rather than by a search:
/// it is one step longer than the smallest level of a marking with an arc
/// back to the initial one, and leads there by [`chain_to`]'s path. Of
/// the markings of that level with such an arc, the smallest (in stored
/// form): the same cycle whatever the threads.
fn cycle_through_initial<S: Semantics>(
    r: &Run<S>,
    net: &PtNet,
    kept: &Kept,
    initial: u32,
) -> Option<Vec<u32>> {
    let depths = r.levels.iter().map(Vec::len).max().unwrap_or(0);
    (0..depths).find_map(|k| {
        let back = leading_to(r, k, initial).min_by(|&a, &b| r.marking(a).cmp(r.marking(b)))?;
        let chain = chain_to(r, net, back);
        Some(
            chain
                .iter()
                .map(|&id| dense_of(&kept.offsets, id))
                .collect(),
        )
    })
}

/// The markings the initial one passes through before the net's cycles,
/// and where it enters them ([`graph::Prefix`]), when no arc leads back to
/// it: the arcs into the markings of the first levels (up to [`SHALLOW`]
/// markings, at least the first level) counted in one pass over the arcs
/// (each partition's on its own thread), then [`graph::peel`]ed. A
/// marking past those levels is never transient here.
fn prefix_of<S: Semantics>(r: &Run<S>, kept: &Kept, initial: u32, threads: usize) -> graph::Prefix {
    let n = kept.nodes();
    let cap = (n / SHALLOW).max(SHALLOW_MIN);
    let depths = r.levels.iter().map(Vec::len).max().unwrap_or(0);
    // the first `m` levels, m at least 1
    let (mut m, mut total) = (0, 0usize);
    while m < depths {
        let size: usize = (0..r.levels.len()).map(|p| r.level_range(p, m).len()).sum();
        if m > 0 && total + size > cap {
            break;
        }
        total += size;
        m += 1;
    }
    // (first dense number, how many, first index) for each partition
    let mut ranges = Vec::with_capacity(r.levels.len());
    let mut base = 0u32;
    if r.levels.is_empty() {
        return graph::Prefix::default();
    }
    for (p, &start) in kept.offsets.iter().enumerate().take(r.levels.len()) {
        let len = r.levels[p]
            .get(m)
            .copied()
            .unwrap_or_else(|| r.stores.get(p).map_or(0, store::Store::len));
        ranges.push((start, len, base));
        base += len;
    }
    let index = |t: u32| {
        ranges
            .iter()
            .find(|&&(o, len, _)| t.wrapping_sub(o) < len)
            .map(|&(o, _, b)| (b + (t - o)) as usize)
    };
    // two partitions at most (or more, each tested): most chunks of arcs
    // lead into none of the first levels, tested without a branch per arc
    let two = ranges.len() <= 2;
    let Some(&a) = ranges.first() else {
        return graph::Prefix::default();
    };
    let b = ranges.get(1).copied().unwrap_or((0, 0, 0));
    let any_in = |chunk: &[u32]| {
        if two {
            chunk.iter().fold(false, |hit, &t| {
                hit | (t.wrapping_sub(a.0) < a.1) | (t.wrapping_sub(b.0) < b.1)
            })
        } else {
            chunk.iter().any(|&t| index(t).is_some())
        }
    };
    let count = |targets: &[u32]| {
        let mut arcs_in = vec![0u32; base as usize];
        for chunk in targets.chunks(64) {
            if any_in(chunk) {
                for &t in chunk {
                    if let Some(i) = index(t) {
                        arcs_in[i] += 1;
                    }
                }
            }
        }
        arcs_in
    };
    let counts: Vec<Vec<u32>> = if threads > 1 && kept.arcs.len() > 1 {
        std::thread::scope(|scope| {
            let handles: Vec<_> = kept
                .arcs
                .iter()
                .map(|a| scope.spawn(move || count(a.all_targets())))
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_default())
                .collect()
        })
    } else {
        kept.arcs.iter().map(|a| count(a.all_targets())).collect()
    };
    let mut arcs_in = vec![0u32; base as usize];
    for c in &counts {
        if c.len() != arcs_in.len() {
            // a thread failed: no prefix
            return graph::Prefix::default();
        }
        for (a, b) in arcs_in.iter_mut().zip(c) {
            *a += b;
        }
    }
    graph::peel(kept, initial, index, arcs_in)
}

/// [`prefix_of`] counts the arcs into the first levels' markings, up to
/// one in `SHALLOW` of them (and at least [`SHALLOW_MIN`]).
const SHALLOW: usize = 64;
const SHALLOW_MIN: usize = 4096;

/// Every dense node number once, in breadth-first order over all
/// partitions: level by level, each level's markings partition after
/// partition (the order of [`Run::level_ids`]), filled from each level's
/// range of numbers rather than id by id (a quarter of the time).
fn breadth_first_order<S: Semantics>(r: &Run<S>, offsets: &[u32]) -> Vec<u32> {
    let depths = r.levels.iter().map(Vec::len).max().unwrap_or(0);
    let mut order = Vec::with_capacity(offsets.last().copied().unwrap_or(0) as usize);
    for k in 0..depths {
        for (p, &base) in offsets.iter().enumerate().take(r.levels.len()) {
            let range = r.level_range(p, k);
            order.extend(base + range.start..base + range.end);
        }
    }
    order
}

/// The dense number of state id `id`.
fn dense_of(offsets: &[u32], id: u32) -> u32 {
    let (p, l) = split_id(id);
    offsets[p] + l
}

/// The loops of `g`, the reachability graph of `r` in dense numbering,
/// whose strongly connected components are `sccs`; `known`: a node and a
/// shortest cycle through it, found already.
fn loops_in<S: Semantics>(
    r: &Run<S>,
    net: &PtNet,
    g: &impl Successors,
    sccs: &Sccs,
    max_listed: usize,
    mut known: Option<(u32, Vec<u32>)>,
) -> Loops {
    let cyclic_components = sccs.cyclic.iter().filter(|&&c| c).count() as u64;
    let largest = sccs
        .sizes
        .iter()
        .zip(&sccs.cyclic)
        .filter(|(_, &c)| c)
        .map(|(&s, _)| s)
        .max()
        .unwrap_or(0);
    // The first-reached node of each cyclic component (smallest depth, then
    // smallest number), for the first `max_listed` components in that
    // order: markings level by level, in increasing numbers in each.
    let offsets = r.offsets();
    let dense = |id: u32| dense_of(&offsets, id);
    let depths = r.levels.iter().map(Vec::len).max().unwrap_or(0);
    let mut seen = vec![false; sccs.count()];
    // where each component met at the current level is in `met`
    let mut at = vec![usize::MAX; sccs.count()];
    let mut entries: Vec<(usize, u32)> = Vec::new();
    let mut met: Vec<(usize, u32)> = Vec::new();
    for k in 0..depths {
        if entries.len() >= max_listed || entries.len() as u64 == cyclic_components {
            break;
        }
        // the components first met at this level, each by its smallest
        // marking here, listed in the order of those markings: the same
        // whatever the threads that numbered them
        met.clear();
        for id in r.level_ids(k) {
            let v = dense(id);
            let c = sccs.component[v as usize] as usize;
            if !sccs.cyclic[c] || seen[c] {
                continue;
            }
            match at[c] {
                usize::MAX => {
                    at[c] = met.len();
                    met.push((c, v));
                }
                i => {
                    if r.marking(id) < r.marking(id_of(&offsets, met[i].1)) {
                        met[i].1 = v;
                    }
                }
            }
        }
        met.sort_by(|a, b| {
            r.marking(id_of(&offsets, a.1))
                .cmp(r.marking(id_of(&offsets, b.1)))
        });
        for &(c, _) in &met {
            seen[c] = true;
            at[c] = usize::MAX;
        }
        entries.extend_from_slice(&met);
    }
    entries.truncate(max_listed);
    let listed = entries
        .into_iter()
        .map(|(c, v)| {
            let prefix = firing_sequence(r, &chain_to(r, net, id_of(&offsets, v)));
            let cycle_nodes = match known.take_if(|(k, _)| *k == v) {
                Some((_, nodes)) => nodes,
                None => graph::shortest_cycle(g, v, |w| sccs.component[w as usize] as usize == c)
                    .unwrap_or_default(),
            };
            let mut ids: Vec<u32> = cycle_nodes.iter().map(|&w| id_of(&offsets, w)).collect();
            ids.push(id_of(&offsets, v));
            Loop {
                states: sccs.sizes[c],
                prefix,
                cycle: firing_sequence(r, &ids),
            }
        })
        .collect();
    Loops {
        cyclic_components,
        largest,
        listed,
    }
}

impl Exploration<'_> {
    /// A shortest firing sequence (transition indices) to a dead marking.
    pub fn deadlock_example(&self) -> Option<Vec<usize>> {
        on_space!(&self.space, r => r.first_dead.map(|id| firing_sequence(r, &chain_to(r, self.net, id))))
    }

    /// A shortest firing sequence to a marking with two tokens or more in a
    /// place.
    pub fn unsafe_example(&self) -> Option<Vec<usize>> {
        on_space!(&self.space, r => r.first_unsafe.map(|id| firing_sequence(r, &chain_to(r, self.net, id))))
    }

    /// Strongly connected components of the reachability graph, listing at
    /// most `max_listed` cycles. Costs about one more exploration.
    pub fn loops(&self, max_listed: usize) -> Loops {
        on_space!(&self.space, r => loops_of(r, self.net, max_listed, self.summary.threads))
    }

    /// The names of transitions.
    pub fn names(&self, sequence: &[usize]) -> Vec<String> {
        sequence
            .iter()
            .map(|&t| self.net.transitions[t].name.clone())
            .collect()
    }
}

#[cfg(test)]
mod tests;
