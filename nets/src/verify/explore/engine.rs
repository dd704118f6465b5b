//! The exploration loop, generic over the marking encoding: level-synchronous
//! breadth-first search over `n` partitions of the state space (a marking
//! belongs to the partition its hash picks), one thread per partition.
//!
//! Each level: every thread expands its own frontier, storing successors of
//! its own partition at once and batching the others into an outbox per
//! destination; after a barrier every thread stores what it was sent; after
//! a second barrier all agree whether anything new was found. Parents are
//! recorded when a marking is first stored, always from the previous level,
//! so parent chains are shortest firing sequences. With one partition there
//! are no outboxes and no barriers: a plain breadth-first search.

use std::sync::atomic::{AtomicU32, AtomicU64, Ordering::Relaxed};
use std::sync::{Barrier, Mutex, MutexGuard};

use super::edges::{Edges, PENDING};
use super::ids::{split_id, state_id, MAX_PER_PARTITION, MAX_THREADS};
use super::semantics::{load_words, mix, push_words, to_words, Semantics, Stop};
use super::store::{Inserted, Store};

/// The partition of a marking with hash `h` among `n`.
#[inline]
pub fn partition(h: u64, n: usize) -> usize {
    (((h >> 32) * n as u64) >> 32) as usize
}

/// Which partition (thread) each marking belongs to: by hash, or (1-safe
/// nets) by whether a few chosen places are marked. Places that are marked
/// about half the time and rarely change keep most successors in the
/// partition of their parent, so few markings cross between threads.
#[derive(Debug, Clone)]
pub struct Partitioner {
    n: usize,
    /// Place `places[i]` marked sets bit i of an index; the partition is a
    /// hash of the index.
    places: Vec<u32>,
}

impl Partitioner {
    pub fn by_hash(n: usize) -> Partitioner {
        Partitioner {
            n: n.clamp(1, MAX_THREADS),
            places: Vec::new(),
        }
    }

    /// For bit markings (place `p` is bit `p % 8` of byte `p / 8`).
    pub fn by_places(n: usize, places: Vec<u32>) -> Partitioner {
        Partitioner {
            n: n.clamp(1, MAX_THREADS),
            places,
        }
    }

    pub fn threads(&self) -> usize {
        self.n
    }

    /// The partition of stored marking `m` with hash `h`.
    #[inline]
    pub fn of(&self, m: &[u8], h: u64) -> usize {
        if self.n == 1 {
            return 0;
        }
        if self.places.is_empty() {
            return partition(h, self.n);
        }
        let mut index = 0usize;
        for (i, &p) in self.places.iter().enumerate() {
            if m.get((p >> 3) as usize)
                .is_some_and(|b| (b >> (p & 7)) & 1 == 1)
            {
                index |= 1 << i;
            }
        }
        partition(mix(index as u64 ^ 0x9e37_79b9_7f4a_7c15), self.n)
    }
}

/// What one run of the engine found.
pub struct Run<S> {
    pub sem: S,
    pub partitioner: Partitioner,
    pub stores: Vec<Store>,
    pub edges: u64,
    pub dead: u64,
    pub max_tokens: u32,
    /// A dead marking at the smallest depth.
    pub first_dead: Option<u32>,
    /// A marking with 2 tokens or more in a place, at the smallest depth.
    pub first_unsafe: Option<u32>,
    pub stop: Option<Stop>,
    /// The state limit was reached.
    pub full: bool,
    /// Transitions that fired somewhere (one flag each).
    pub fired: Vec<bool>,
    /// For each partition, where each breadth-first level starts (markings
    /// are stored level after level).
    pub levels: Vec<Vec<u32>>,
    /// For each partition, the successors of its markings (dense numbers, see
    /// [`Edges`]), when asked for and complete; else empty.
    pub arcs: Vec<Edges>,
}

impl<S: Semantics> Run<S> {
    pub fn states(&self) -> u64 {
        self.stores.iter().map(|s| u64::from(s.len())).sum()
    }

    pub fn marking(&self, id: u32) -> &[u8] {
        let (p, l) = split_id(id);
        self.stores[p].get(l)
    }

    /// The breadth-first level (distance from the initial marking) of `id`.
    pub fn level(&self, id: u32) -> usize {
        let (p, l) = split_id(id);
        self.levels[p]
            .partition_point(|&start| start <= l)
            .saturating_sub(1)
    }

    /// The ids of the markings of level `k`, all partitions.
    pub fn level_ids(&self, k: usize) -> impl Iterator<Item = u32> + '_ {
        (0..self.levels.len())
            .flat_map(move |p| self.level_range(p, k).map(move |l| state_id(p, l)))
    }

    /// The indices in partition `p` of the markings of level `k` (empty
    /// past the last level, or for no such partition).
    pub fn level_range(&self, p: usize, k: usize) -> std::ops::Range<u32> {
        let Some(starts) = self.levels.get(p) else {
            return 0..0;
        };
        let lo = starts.get(k).copied().unwrap_or(0);
        let hi = match (starts.get(k), starts.get(k + 1)) {
            (Some(_), Some(&next)) => next,
            (Some(_), None) => self.stores.get(p).map_or(0, Store::len),
            _ => 0,
        };
        lo..hi
    }

    /// Where each partition's markings start in the dense numbering (all
    /// partitions one after the other), and the total at the end.
    pub fn offsets(&self) -> Vec<u32> {
        let mut offsets = vec![0u32];
        for s in &self.stores {
            let last = offsets.last().copied().unwrap_or(0);
            offsets.push(last + s.len());
        }
        offsets
    }

    /// The id of a stored marking with (mixed) hash `h`.
    pub fn lookup_hashed(&self, m: &[u8], h: u64) -> Option<u32> {
        let p = self.partitioner.of(m, h);
        self.stores[p].lookup(m, h).map(|l| state_id(p, l))
    }

    /// See [`Store::prefetch_slot`].
    pub fn prefetch_slot(&self, m: &[u8], h: u64) {
        self.stores[self.partitioner.of(m, h)].prefetch_slot(h);
    }

    /// See [`Store::prefetch_record`].
    pub fn prefetch_record(&self, m: &[u8], h: u64) {
        self.stores[self.partitioner.of(m, h)].prefetch_record(h);
    }
}

struct Shared<'a> {
    n: usize,
    partitioner: &'a Partitioner,
    barrier: Barrier,
    /// outboxes[from * n + to]: records (marking words, hash).
    outboxes: Vec<Mutex<Vec<u8>>>,
    /// replies[from * n + to], with `keep_arcs`: the ids of the markings
    /// `to` sent, in the order of its records (it keeps their slots).
    replies: Vec<Mutex<Vec<u32>>>,
    keep_arcs: bool,
    /// The smallest level at which some thread asked to stop.
    stop_level: AtomicU32,
    total: AtomicU64,
    stored: AtomicU64,
    progress: Option<&'a (dyn Fn(u64) + Sync)>,
    /// Stop after a level that ends with more markings than this.
    limit: u64,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

#[derive(Default)]
struct Found {
    edges: u64,
    dead: u64,
    max_tokens: u32,
    first_dead: Option<(u32, u32)>,
    first_unsafe: Option<(u32, u32)>,
    /// The marking `first_unsafe` names.
    unsafe_bytes: Vec<u8>,
    stop: Option<Stop>,
    full: bool,
    new_since_report: u64,
    fired: Vec<bool>,
    levels: Vec<u32>,
}

impl Found {
    #[inline]
    fn stored<S: Semantics>(&mut self, sem: &S, m: &[u8], level: u32, index: u32) {
        let t = sem.max_tokens(m);
        if t > self.max_tokens {
            self.max_tokens = t;
        }
        // at the smallest depth, the smallest marking there: the same one
        // whatever the threads
        if t >= 2
            && self
                .first_unsafe
                .is_none_or(|(l, _)| level < l || (level == l && m < &self.unsafe_bytes[..]))
        {
            self.first_unsafe = Some((level, index));
            self.unsafe_bytes.clear();
            self.unsafe_bytes.extend_from_slice(m);
        }
        self.new_since_report += 1;
    }
}

/// Explores from `initial` on `threads` partitions. Stops at `limit`
/// markings: exactly on one thread, after the level that passes it on more
/// (each partition also stops at `limit`).
/// With `keep_arcs`, the successors of every marking are kept too
/// ([`Run::arcs`]).
pub fn run<S: Semantics>(
    sem: S,
    initial: &[u8],
    partitioner: Partitioner,
    limit: u32,
    progress: Option<&(dyn Fn(u64) + Sync)>,
    keep_arcs: bool,
) -> Run<S> {
    let n = partitioner.threads();
    let limit = limit.clamp(1, MAX_PER_PARTITION);
    let mut stores: Vec<Store> = (0..n).map(|_| Store::new(sem.width(), limit)).collect();
    let h0 = mix(sem.key(&to_words(initial)));
    let p0 = partitioner.of(initial, h0);
    stores[p0].insert(initial, h0);
    let shared = Shared {
        n,
        partitioner: &partitioner,
        barrier: Barrier::new(n),
        outboxes: (0..n * n).map(|_| Mutex::new(Vec::new())).collect(),
        replies: (0..n * n).map(|_| Mutex::new(Vec::new())).collect(),
        keep_arcs,
        stop_level: AtomicU32::new(u32::MAX),
        total: AtomicU64::new(1),
        stored: AtomicU64::new(1),
        progress,
        limit: u64::from(limit),
    };
    let mut found: Vec<(Store, Found, Edges)> = if n == 1 {
        let store = stores
            .pop()
            .unwrap_or_else(|| Store::new(sem.width(), limit));
        vec![worker(0, &sem, &shared, store)]
    } else {
        std::thread::scope(|scope| {
            let mut it = stores.into_iter().enumerate();
            let first = it.next();
            let handles: Vec<_> = it
                .map(|(i, store)| {
                    let (sem, shared) = (&sem, &shared);
                    scope.spawn(move || worker(i, sem, shared, store))
                })
                .collect();
            let mut all = Vec::with_capacity(n);
            if let Some((i, store)) = first {
                all.push(worker(i, &sem, &shared, store));
            }
            for h in handles {
                match h.join() {
                    Ok(r) => all.push(r),
                    Err(panic) => std::panic::resume_unwind(panic),
                }
            }
            all
        })
    };
    let init_tokens = sem.max_tokens(initial);
    let mut run = Run {
        sem,
        partitioner: partitioner.clone(),
        stores: Vec::with_capacity(n),
        edges: 0,
        dead: 0,
        max_tokens: init_tokens,
        first_dead: None,
        first_unsafe: if init_tokens >= 2 {
            Some(state_id(p0, 0))
        } else {
            None
        },
        stop: None,
        full: false,
        fired: Vec::new(),
        levels: Vec::with_capacity(n),
        arcs: Vec::new(),
    };
    let mut dead_at: Option<(u32, u32)> = None;
    let mut unsafe_at: Option<(u32, u32)> = None;
    let mut arcs = Vec::with_capacity(n);
    for (part, (store, f, a)) in found.drain(..).enumerate() {
        run.edges += f.edges;
        if run.fired.len() < f.fired.len() {
            run.fired.resize(f.fired.len(), false);
        }
        for (a, b) in run.fired.iter_mut().zip(&f.fired) {
            *a |= *b;
        }
        run.dead += f.dead;
        run.max_tokens = run.max_tokens.max(f.max_tokens);
        run.stop = run.stop.or(f.stop);
        run.full |= f.full;
        run.stores.push(store);
        // the smallest depth, then the smallest marking: whatever the
        // partitions
        let first = |at: Option<(u32, u32)>, found: Option<(u32, u32)>, run: &Run<S>| match found {
            Some((level, i)) => {
                let id = state_id(part, i);
                let better = at.is_none_or(|(l, best)| {
                    level < l || (level == l && run.marking(id) < run.marking(best))
                });
                if better {
                    Some((level, id))
                } else {
                    at
                }
            }
            None => at,
        };
        dead_at = first(dead_at, f.first_dead, &run);
        unsafe_at = first(unsafe_at, f.first_unsafe, &run);
        run.levels.push(f.levels);
        arcs.push(a);
    }
    let whole = run.stop.is_none() && !run.full;
    if keep_arcs
        && whole
        && arcs
            .iter()
            .zip(&run.stores)
            .all(|(a, s)| a.complete(s.len()))
    {
        let offsets = run.offsets();
        let number = |a: &mut Edges| {
            a.shrink();
            a.number(&offsets)
        };
        // state ids to dense numbers: one pass over the arcs, each
        // partition's on its own thread
        let numbered = if n == 1 {
            arcs.iter_mut().all(number)
        } else {
            std::thread::scope(|scope| {
                let handles: Vec<_> = arcs
                    .iter_mut()
                    .map(|a| scope.spawn(move || number(a)))
                    .collect();
                handles.into_iter().all(|h| h.join().unwrap_or(false))
            })
        };
        if numbered {
            run.arcs = arcs;
        }
    }
    run.first_dead = dead_at.map(|(_, id)| id);
    if run.first_unsafe.is_none() {
        run.first_unsafe = unsafe_at.map(|(_, id)| id);
    }
    run
}

/// Successors stored per batch: the table slots and records they need are
/// loaded first, all together (independent loads overlap), then stored.
const BATCH: usize = 512;

/// Parses a record (marking padded to whole words, hash): the stored
/// marking, its hash.
#[inline]
fn parse_record(r: &[u8], width: usize, words: usize) -> (&[u8], u64) {
    let at = words * 8;
    let mut h = [0u8; 8];
    h.copy_from_slice(&r[at..at + 8]);
    (&r[..width], u64::from_le_bytes(h))
}

/// Where a batch comes from.
enum Source<'a> {
    /// This thread's own expansions: successors of other partitions go to
    /// `outs`; with `arcs`, every successor takes the next slot, and those
    /// sent away have theirs noted in `sent` (one list per partition, in
    /// the order of their records).
    Own {
        outs: &'a mut [Vec<u8>],
        arcs: Option<(&'a mut Edges, &'a mut [Vec<u32>])>,
    },
    /// Another thread's mail (all for this partition); with `replies`, each
    /// stored or found id goes back, in the order of the records.
    Mail { replies: Option<&'a mut Vec<u32>> },
}

/// Stores the successors in `batch` that belong to partition `me` and moves
/// the others to their outboxes. False when the store is full.
#[allow(clippy::too_many_arguments)]
fn store_batch<S: Semantics>(
    sem: &S,
    partitioner: &Partitioner,
    store: &mut Store,
    f: &mut Found,
    batch: &[u8],
    record: usize,
    me: usize,
    mut source: Source,
    level: u32,
) -> bool {
    let width = sem.width();
    let words = sem.words();
    let count = batch.len() / record;
    let at = |i: usize| &batch[i * record..(i + 1) * record];
    let part = |r: &[u8], h: u64| partitioner.of(r, h);
    // Software pipeline: fetch the table slot of successor i + 2D, the
    // record of successor i + D (its slot has arrived by then), store i.
    const D: usize = 8;
    for i in 0..count + 2 * D {
        if i < count {
            let (m, h) = parse_record(at(i), width, words);
            if part(m, h) == me {
                store.prefetch_slot(h);
            }
        }
        if i >= D && i - D < count {
            let (m, h) = parse_record(at(i - D), width, words);
            if part(m, h) == me {
                store.prefetch_record(h);
            }
        }
        if i >= 2 * D {
            let r = at(i - 2 * D);
            let (m, h) = parse_record(r, width, words);
            let p = part(m, h);
            if p == me {
                let local = match store.insert(m, h) {
                    Inserted::New(index) => {
                        f.stored(sem, m, level + 1, index);
                        index
                    }
                    Inserted::Old(index) => index,
                    Inserted::Full => return false,
                };
                let id = state_id(me, local);
                match &mut source {
                    Source::Own {
                        arcs: Some((arcs, _)),
                        ..
                    } => {
                        arcs.push(id);
                    }
                    Source::Mail {
                        replies: Some(replies),
                    } => replies.push(id),
                    _ => {}
                }
            } else if let Source::Own { outs, arcs } = &mut source {
                outs[p].extend_from_slice(r);
                if let Some((arcs, sent)) = arcs {
                    sent[p].push(arcs.push(PENDING));
                }
            }
        }
    }
    true
}

fn worker<S: Semantics>(
    me: usize,
    sem: &S,
    sh: &Shared,
    mut store: Store,
) -> (Store, Found, Edges) {
    let n = sh.n;
    let words = sem.words();
    let record = words * 8 + 8;
    let mut f = Found::default();
    let mut arcs = Edges::new();
    // with kept arcs: the slots of the successors sent to each partition,
    // in the order sent (its replies come in that order)
    let mut sent: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut replies: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut cur = vec![0u64; words];
    let mut child: Vec<u64> = Vec::with_capacity(words);
    let mut outs: Vec<Vec<u8>> = vec![Vec::new(); n];
    let mut batch: Vec<u8> = Vec::with_capacity((BATCH + 64) * record);
    let (mut lo, mut level, mut prev_total) = (0u32, 0u32, 1u64);
    let mut expanded = 0u64;
    let mut fired: Vec<bool> = Vec::new();
    let mut hi;
    loop {
        hi = store.len();
        f.levels.push(lo);
        let mut index = lo;
        while index < hi {
            if index & 1023 == 0 && sh.stop_level.load(Relaxed) != u32::MAX {
                break;
            }
            load_words(store.get(index), &mut cur);
            let key = sem.key(&cur);
            let result = sem.expand(&cur, key, &mut child, |t, m, k| {
                let t = t as usize;
                if t >= fired.len() {
                    fired.resize(t + 1, false);
                }
                fired[t] = true;
                push_words(&mut batch, m);
                batch.extend_from_slice(&mix(k).to_le_bytes());
            });
            match result {
                Ok(0) => {
                    f.dead += 1;
                    // at the smallest depth, the smallest marking there
                    if f.first_dead
                        .is_none_or(|(l, i)| l == level && store.get(index) < store.get(i))
                    {
                        f.first_dead = Some((level, index));
                    }
                }
                Ok(k) => f.edges += u64::from(k),
                Err(s) => {
                    f.stop = Some(s);
                    sh.stop_level.fetch_min(level, Relaxed);
                    break;
                }
            }
            if let (true, Ok(k)) = (sh.keep_arcs, result) {
                arcs.node(k);
            }
            index += 1;
            expanded += 1;
            if batch.len() >= BATCH * record || index == hi {
                let ok = store_batch(
                    sem,
                    sh.partitioner,
                    &mut store,
                    &mut f,
                    &batch,
                    record,
                    me,
                    Source::Own {
                        outs: &mut outs,
                        arcs: sh.keep_arcs.then_some((&mut arcs, &mut sent)),
                    },
                    level,
                );
                batch.clear();
                if !ok {
                    f.full = true;
                    sh.stop_level.fetch_min(level, Relaxed);
                    break;
                }
            }
            if f.new_since_report >= 1 << 14 {
                sh.stored.fetch_add(f.new_since_report, Relaxed);
                f.new_since_report = 0;
            }
            if me == 0 && expanded & 0x7fff == 0 {
                if let Some(p) = sh.progress {
                    p(sh.stored.load(Relaxed) + f.new_since_report);
                }
            }
        }
        batch.clear();
        if n > 1 {
            for (to, out) in outs.iter_mut().enumerate() {
                if to != me {
                    std::mem::swap(&mut *lock(&sh.outboxes[me * n + to]), out);
                }
            }
            sh.barrier.wait();
            for (from, answers) in replies.iter_mut().enumerate() {
                if from == me {
                    continue;
                }
                let mut inbox = std::mem::take(&mut *lock(&sh.outboxes[from * n + me]));
                answers.clear();
                for part in inbox.chunks(BATCH * record) {
                    if !store_batch(
                        sem,
                        sh.partitioner,
                        &mut store,
                        &mut f,
                        part,
                        record,
                        me,
                        Source::Mail {
                            replies: sh.keep_arcs.then_some(&mut *answers),
                        },
                        level,
                    ) {
                        f.full = true;
                        sh.stop_level.fetch_min(level, Relaxed);
                        break;
                    }
                }
                inbox.clear();
                *lock(&sh.outboxes[from * n + me]) = inbox;
                if sh.keep_arcs {
                    std::mem::swap(&mut *lock(&sh.replies[me * n + from]), answers);
                }
            }
        }
        sh.total.fetch_add(u64::from(store.len() - hi), Relaxed);
        if n > 1 {
            sh.barrier.wait();
            if sh.keep_arcs {
                // the ids of the markings this thread sent, stored by their
                // partitions' threads before the barrier, in the order sent
                for (from, slots) in sent.iter_mut().enumerate() {
                    if from != me {
                        let ids = lock(&sh.replies[from * n + me]);
                        for (&slot, &id) in slots.iter().zip(ids.iter()) {
                            arcs.answer(slot, id);
                        }
                        slots.clear();
                    }
                }
            }
        }
        let total = sh.total.load(Relaxed);
        if sh.stop_level.load(Relaxed) <= level || total == prev_total {
            break;
        }
        if total > sh.limit {
            f.full = true;
            break;
        }
        prev_total = total;
        lo = hi;
        level += 1;
    }
    // where the markings found by the last level expanded start
    f.levels.push(hi);
    f.fired = fired;
    (store, f, arcs)
}
