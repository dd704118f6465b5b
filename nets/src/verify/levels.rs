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

use super::graph::{strongly_connected_components, Csr, Successors as _};
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
    /// Whether each state was expanded by an ample set only.
    reduced: Vec<bool>,
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
    /// The cycle proviso the search applies.
    proviso: Proviso,
    /// The state must be expanded fully (no ample set).
    full: bool,
    /// The state was expanded by an ample set only.
    reduced: bool,
}

/// The cycle proviso of a reduced search: how it makes sure no input is
/// put off for ever around a cycle of reduced states (docs/verify.md,
/// "Partial-order reduction").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Proviso {
    /// During the search: an ample set one of whose steps leads to a state
    /// stored no later than the one expanded is not taken
    /// ([`Successors::push`] says so); every cycle then has a fully
    /// expanded state.
    Levels,
    /// After the search: each terminal strongly connected component of the
    /// reduced graph with no fully expanded state gets one (its first
    /// state is expanded again, fully) and the search goes on from what
    /// that finds, until every terminal component has one.
    #[default]
    Components,
}

impl Successors<'_> {
    /// A successor `key` reached by a step labelled `label` (the worker's
    /// number), `key` being the image of the real successor by the element
    /// `perm` of the symmetry group (0, the identity, without symmetry).
    /// Whether it was stored before the state being expanded, or is that
    /// state (numbers grow level by level, so every cycle of the graph has
    /// an edge for which this is true: the one from its highest number).
    /// Under [`Proviso::Components`], always false: the proviso is applied
    /// after the search.
    pub fn push(&mut self, label: u32, key: &[u8], perm: u8) -> bool {
        let h = hash(key);
        let known;
        let target = match self.store.lookup(key, h) {
            Some(i) => {
                known = self.proviso == Proviso::Levels && i <= self.from;
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

    /// Whether the state must be expanded fully (no ample set).
    pub fn full(&self) -> bool {
        self.full
    }

    /// Records that the state was expanded by an ample set only.
    pub fn set_reduced(&mut self) {
        self.reduced = true;
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

/// A state's edges (label, target).
type Edges = Vec<(u32, u32)>;

/// A state expanded again: its number, edges and their elements.
type Redone = (u32, Edges, Vec<u8>);

/// A chunk, with the worker that made it and its states.
type Made = (usize, Chunk, Vec<u32>);

/// Explores from `initial` with `threads` workers (at least one), storing
/// at most `max_states` states; `progress` is told how many states were
/// expanded after each one. `proviso` says how reduced states are kept
/// from putting an input off for ever (see [`Proviso`]).
pub(super) fn explore<E: Explore>(
    space: &E,
    initial: &[u8],
    max_states: usize,
    threads: usize,
    proviso: Proviso,
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
    // Per state: expanded by an ample set only.
    let mut reduced: Vec<bool> = Vec::new();
    let mut level: Vec<u32> = vec![0];
    let mut expanded = 0usize;
    loop {
        while !level.is_empty() {
            let from = out.store.len();
            let chunks = expand_level(space, &mut workers, &out.store, &level, proviso, false);
            merge(
                space,
                &mut workers,
                &mut out,
                chunks,
                max_states,
                |out, _, edges, perms, r| {
                    out.graph.push_node(edges.drain(..));
                    out.perms.append(perms);
                    reduced.push(r);
                    expanded += 1;
                    progress(expanded);
                },
            );
            level = (from as u32..out.store.len() as u32).collect();
        }
        if proviso != Proviso::Components || !out.complete {
            break;
        }
        // Terminal components without a fully expanded state: their first
        // state is expanded again, fully, and the search goes on from the
        // new states that finds.
        let again = unexpanded_terminal_states(&out.graph, &reduced);
        if again.is_empty() {
            break;
        }
        let from = out.store.len();
        let chunks = expand_level(space, &mut workers, &out.store, &again, proviso, true);
        let mut replaced: Vec<Redone> = Vec::with_capacity(again.len());
        merge(
            space,
            &mut workers,
            &mut out,
            chunks,
            max_states,
            |_, node, edges, perms, r| {
                replaced.push((node, std::mem::take(edges), std::mem::take(perms)));
                reduced[node as usize] = r;
            },
        );
        replace_edges(&mut out, &again, replaced);
        level = (from as u32..out.store.len() as u32).collect();
    }
    out
}

/// Merges a level's chunks in order: new targets get the next numbers
/// (while there is room), labels the search's numbers; `sink` gets each
/// expanded state's number, edges, their elements and whether it was
/// reduced.
fn merge<E: Explore>(
    space: &E,
    workers: &mut [E::Worker],
    out: &mut Space,
    chunks: Vec<Made>,
    max_states: usize,
    mut sink: impl FnMut(&mut Space, u32, &mut Edges, &mut Vec<u8>, bool),
) {
    let mut edges: Edges = Vec::new();
    let mut perms: Vec<u8> = Vec::new();
    for (w, chunk, nodes) in chunks {
        let mut e = chunk.edges.into_iter();
        for ((count, r), node) in chunk.counts.into_iter().zip(chunk.reduced).zip(nodes) {
            edges.clear();
            perms.clear();
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
                perms.push(perm);
            }
            sink(out, node, &mut edges, &mut perms, r);
        }
    }
}

/// The first state of each terminal strongly connected component of
/// `graph` none of whose states is fully expanded, in order.
fn unexpanded_terminal_states(graph: &Csr<u32>, reduced: &[bool]) -> Vec<u32> {
    let sccs = strongly_connected_components(graph);
    let c = sccs.count();
    let mut terminal = vec![true; c];
    let mut full = vec![false; c];
    let mut first = vec![u32::MAX; c];
    for s in 0..reduced.len() as u32 {
        let own = sccs.component[s as usize] as usize;
        if graph
            .edges(s)
            .any(|(_, t)| sccs.component[t as usize] as usize != own)
        {
            terminal[own] = false;
        }
        full[own] |= !reduced[s as usize];
        first[own] = first[own].min(s);
    }
    let mut again: Vec<u32> = (0..c)
        .filter(|&k| terminal[k] && !full[k])
        .map(|k| first[k])
        .collect();
    again.sort_unstable();
    again
}

/// The graph with the edges of the states `again` (in order) replaced.
fn replace_edges(out: &mut Space, again: &[u32], replaced: Vec<Redone>) {
    let n = out.graph.node_count();
    let mut graph = Csr::default();
    let mut perms = Vec::with_capacity(out.perms.len());
    let mut next = replaced.into_iter().peekable();
    for s in 0..n as u32 {
        match next.peek() {
            Some((node, ..)) if *node == s => {
                let Some((_, edges, p)) = next.next() else {
                    continue;
                };
                graph.push_node(edges);
                perms.extend(p);
            }
            _ => {
                let first = out.graph.first_edge(s);
                let edges: Vec<(u32, u32)> = out.graph.edges(s).map(|(l, t)| (*l, t)).collect();
                perms.extend_from_slice(&out.perms[first..first + edges.len()]);
                graph.push_node(edges);
            }
        }
    }
    debug_assert!(again.windows(2).all(|w| w[0] < w[1]));
    out.graph = graph;
    out.perms = perms;
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
        proviso: Proviso::Levels,
        full: false,
        reduced: false,
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

/// The chunks of one level (the states `level`), in order, each with the
/// worker that made it and its states; `full`: every state is expanded
/// fully.
fn expand_level<E: Explore>(
    space: &E,
    workers: &mut [E::Worker],
    store: &KeyStore,
    level: &[u32],
    proviso: Proviso,
    full: bool,
) -> Vec<Made> {
    let expand_chunk = |worker: &mut E::Worker, states: &[u32]| {
        let mut chunk = Chunk::default();
        for &s in states {
            let mut out = Successors {
                store,
                chunk: &mut chunk,
                count: 0,
                from: s,
                proviso,
                full,
                reduced: false,
            };
            space.expand(worker, store.get(s), &mut out);
            let (count, reduced) = (out.count, out.reduced);
            chunk.counts.push(count);
            chunk.reduced.push(reduced);
        }
        (chunk, states.to_vec())
    };
    if workers.len() == 1 || level.len() < PARALLEL_FROM {
        let (chunk, nodes) = expand_chunk(&mut workers[0], level);
        return vec![(0, chunk, nodes)];
    }
    let n = level.len().div_ceil(CHUNK);
    let next = AtomicUsize::new(0);
    let done: Mutex<Vec<(usize, Made)>> = Mutex::new(Vec::with_capacity(n));
    std::thread::scope(|scope| {
        for (w, worker) in workers.iter_mut().enumerate() {
            let (next, done, expand_chunk) = (&next, &done, &expand_chunk);
            scope.spawn(move || {
                let mut mine = Vec::new();
                loop {
                    let c = next.fetch_add(1, Ordering::Relaxed);
                    if c >= n {
                        break;
                    }
                    let start = c * CHUNK;
                    let end = (start + CHUNK).min(level.len());
                    let (chunk, nodes) = expand_chunk(worker, &level[start..end]);
                    mine.push((c, (w, chunk, nodes)));
                }
                if let Ok(mut d) = done.lock() {
                    d.extend(mine);
                }
            });
        }
    });
    let mut chunks = done.into_inner().unwrap_or_default();
    chunks.sort_by_key(|(c, _)| *c);
    chunks.into_iter().map(|(_, made)| made).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn terminal_components_without_a_fully_expanded_state_are_expanded_again() {
        // 0 → {1, 2} (a cycle with 2 fully expanded), 0 → 3 (a loop on
        // itself, reduced), 4 alone (reduced, no edge); 0 is not terminal.
        let mut graph: Csr<u32> = Csr::default();
        graph.push_node([(0, 1), (0, 3)]);
        graph.push_node([(0, 2)]);
        graph.push_node([(0, 1)]);
        graph.push_node([(0, 3)]);
        graph.push_node([]);
        let reduced = [true, true, false, true, true];
        assert_eq!(unexpanded_terminal_states(&graph, &reduced), [3, 4]);
        // Every state fully expanded: nothing to do.
        assert!(unexpanded_terminal_states(&graph, &[false; 5]).is_empty());
        // A reduced cycle of two: its first state.
        let all_reduced = [false, true, true, false, false];
        assert_eq!(unexpanded_terminal_states(&graph, &all_reduced), [1]);
    }
}
