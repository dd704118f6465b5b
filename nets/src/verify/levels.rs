//! Breadth-first exploration level by level, on several threads, of states
//! kept as bytes ([`KeyStore`]): the project explorer's search.
//!
//! Each level's states are cut into small chunks that the workers take in
//! turn (threads scoped to the level, joined before it ends); a worker lists
//! a state's labelled successors, resolving those already stored (the store
//! is only read during the level). Then one thread merges the chunks in
//! order: new states get the next numbers, edges and parent links are added
//! as a single-threaded search would add them. The numbering, the edges and
//! the labels are therefore the same whatever the number of threads, and
//! the parent links give shortest paths.
//!
//! Labels are the workers' own numbers until the merge turns them into the
//! search's ([`Explore::label`]), so that a worker never waits on another.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use super::graph::Csr;
use super::project_states::{hash, KeyStore};

/// States per chunk a worker takes at once.
const CHUNK: usize = 16;
/// Levels smaller than this are expanded on the calling thread.
const PARALLEL_FROM: usize = 64;

/// What the search asks of the state space it explores.
pub(super) trait Explore: Sync {
    type Worker: Send;
    /// A worker's own buffers and label numbers.
    fn worker(&self) -> Self::Worker;
    /// Lists the successors of the state `key` into `out`.
    fn expand(&self, worker: &mut Self::Worker, key: &[u8], out: &mut Successors<'_>);
    /// The search's number for a worker's label `local` (called in merge
    /// order, so that labels are numbered as one thread would).
    fn label(&self, worker: &mut Self::Worker, local: u32) -> u32;
}

/// A target already stored, or a new key's place in [`Chunk::bytes`].
enum Target {
    Known(u32),
    New { hash: u64, start: usize, end: usize },
}

/// One chunk's successors.
#[derive(Default)]
struct Chunk {
    /// Successors of each state of the chunk.
    counts: Vec<u32>,
    /// Label, target and the symmetry element that made the target's key.
    edges: Vec<(u32, Target, u8)>,
    bytes: Vec<u8>,
}

/// Where [`Explore::expand`] puts a state's successors.
pub(super) struct Successors<'a> {
    store: &'a KeyStore,
    chunk: &'a mut Chunk,
    count: u32,
    /// The number of the state being expanded.
    from: u32,
}

impl Successors<'_> {
    /// A successor `key` reached by a step labelled `label` (the worker's
    /// number), `key` being the image of the real successor by the element
    /// `perm` of the symmetry group (0, the identity, without symmetry).
    /// Whether it was stored before the state being expanded, or is that
    /// state (numbers grow level by level, so every cycle of the graph has
    /// an edge for which this is true: the one from its highest number).
    pub fn push(&mut self, label: u32, key: &[u8], perm: u8) -> bool {
        let h = hash(key);
        let known;
        let target = match self.store.lookup(key, h) {
            Some(i) => {
                known = i <= self.from;
                Target::Known(i)
            }
            None => {
                known = false;
                let start = self.chunk.bytes.len();
                self.chunk.bytes.extend_from_slice(key);
                Target::New {
                    hash: h,
                    start,
                    end: self.chunk.bytes.len(),
                }
            }
        };
        self.chunk.edges.push((label, target, perm));
        self.count += 1;
        known
    }

    /// Where the successors pushed so far end, for [`Successors::undo`].
    pub fn mark(&self) -> SuccessorsMark {
        SuccessorsMark {
            bytes: self.chunk.bytes.len(),
            edges: self.chunk.edges.len(),
            count: self.count,
        }
    }

    /// Forgets the successors pushed since `mark`.
    pub fn undo(&mut self, mark: SuccessorsMark) {
        self.chunk.bytes.truncate(mark.bytes);
        self.chunk.edges.truncate(mark.edges);
        self.count = mark.count;
    }
}

/// A point in a state's successors (see [`Successors::mark`]).
#[derive(Clone, Copy)]
pub(super) struct SuccessorsMark {
    bytes: usize,
    edges: usize,
    count: u32,
}

/// The reachable states: keys in breadth-first order (state 0 is the
/// initial state), a parent link per state, the labelled graph.
pub(super) struct Space {
    pub store: KeyStore,
    /// For each state but the first: the state it was first reached from and
    /// the label of that edge.
    pub parents: Vec<Option<(u32, u32)>>,
    pub graph: Csr<u32>,
    /// Per edge (in the graph's numbering): the symmetry element that made
    /// its target's key from the real successor's.
    pub perms: Vec<u8>,
    /// Per state: the element of its parent link's edge.
    pub parent_perms: Vec<u8>,
    /// False when the state limit stopped the exploration (then the states
    /// past the limit are missing).
    pub complete: bool,
}

impl Space {
    /// The labels of a shortest path to `node`, each with the symmetry
    /// element its edge's target was canonicalised by.
    pub fn path_with_perms(&self, node: u32) -> Vec<(u32, u8)> {
        let mut path = Vec::new();
        let mut n = node;
        while let Some((p, l)) = self.parents[n as usize] {
            path.push((l, self.parent_perms[n as usize]));
            n = p;
        }
        path.reverse();
        path
    }
}

/// Explores from `initial` with `threads` workers (at least one), storing
/// at most `max_states` states; `progress` is told how many states were
/// expanded after each one.
pub(super) fn explore<E: Explore>(
    space: &E,
    initial: &[u8],
    max_states: usize,
    threads: usize,
    progress: &mut dyn FnMut(usize),
) -> Space {
    let mut store = KeyStore::new();
    store.insert(initial, hash(initial));
    let mut out = Space {
        store,
        parents: vec![None],
        graph: Csr::default(),
        perms: Vec::new(),
        parent_perms: vec![0],
        complete: true,
    };
    let mut workers: Vec<E::Worker> = (0..threads.max(1)).map(|_| space.worker()).collect();
    let mut level = 0..1usize;
    let mut edges: Vec<(u32, u32)> = Vec::new();
    while !level.is_empty() {
        let chunks = expand_level(space, &mut workers, &out.store, level.clone());
        // Merge in order.
        let mut node = level.start as u32;
        for (w, chunk) in chunks {
            let mut e = chunk.edges.into_iter();
            for count in chunk.counts {
                edges.clear();
                for (local, target, perm) in e.by_ref().take(count as usize) {
                    let label = space.label(&mut workers[w], local);
                    let target = match target {
                        Target::Known(i) => i,
                        Target::New { hash, start, end } => {
                            let key = &chunk.bytes[start..end];
                            match out.store.lookup(key, hash) {
                                Some(i) => i,
                                None if out.store.len() >= max_states => {
                                    out.complete = false;
                                    continue;
                                }
                                None => {
                                    out.parents.push(Some((node, label)));
                                    out.parent_perms.push(perm);
                                    out.store.insert(key, hash)
                                }
                            }
                        }
                    };
                    edges.push((label, target));
                    out.perms.push(perm);
                }
                out.graph.push_node(edges.drain(..));
                node += 1;
                progress(node as usize);
            }
        }
        level = level.end..out.store.len();
    }
    out
}

/// The successors of one state, outside a search: each with the worker's
/// label and its key.
pub(super) fn expand_one<E: Explore>(
    space: &E,
    worker: &mut E::Worker,
    key: &[u8],
) -> Vec<(u32, Vec<u8>)> {
    let store = KeyStore::new();
    let mut chunk = Chunk::default();
    let mut out = Successors {
        store: &store,
        chunk: &mut chunk,
        count: 0,
        from: u32::MAX,
    };
    space.expand(worker, key, &mut out);
    chunk
        .edges
        .iter()
        .filter_map(|(label, target, _)| match target {
            Target::New { start, end, .. } => Some((*label, chunk.bytes[*start..*end].to_vec())),
            Target::Known(_) => None,
        })
        .collect()
}

/// The chunks of one level, in order, each with the worker that made it.
fn expand_level<E: Explore>(
    space: &E,
    workers: &mut [E::Worker],
    store: &KeyStore,
    level: std::ops::Range<usize>,
) -> Vec<(usize, Chunk)> {
    let expand_chunk = |worker: &mut E::Worker, states: std::ops::Range<usize>| {
        let mut chunk = Chunk::default();
        for s in states {
            let mut out = Successors {
                store,
                chunk: &mut chunk,
                count: 0,
                from: s as u32,
            };
            space.expand(worker, store.get(s as u32), &mut out);
            let count = out.count;
            chunk.counts.push(count);
        }
        chunk
    };
    if workers.len() == 1 || level.len() < PARALLEL_FROM {
        return vec![(0, expand_chunk(&mut workers[0], level))];
    }
    let n = level.len().div_ceil(CHUNK);
    let next = AtomicUsize::new(0);
    let done: Mutex<Vec<(usize, usize, Chunk)>> = Mutex::new(Vec::with_capacity(n));
    std::thread::scope(|scope| {
        for (w, worker) in workers.iter_mut().enumerate() {
            let (next, done, level, expand_chunk) = (&next, &done, &level, &expand_chunk);
            scope.spawn(move || {
                let mut mine = Vec::new();
                loop {
                    let c = next.fetch_add(1, Ordering::Relaxed);
                    if c >= n {
                        break;
                    }
                    let start = level.start + c * CHUNK;
                    let end = (start + CHUNK).min(level.end);
                    mine.push((c, w, expand_chunk(worker, start..end)));
                }
                if let Ok(mut d) = done.lock() {
                    d.extend(mine);
                }
            });
        }
    });
    let mut chunks = done.into_inner().unwrap_or_default();
    chunks.sort_by_key(|(c, _, _)| *c);
    chunks.into_iter().map(|(_, w, chunk)| (w, chunk)).collect()
}
