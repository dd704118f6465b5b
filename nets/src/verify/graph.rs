//! Graph algorithms shared by every explorer of the verifier.
//!
//! Two ways in:
//! - **Generic states** ([`explore_bfs`]): give an initial state and a step
//!   function that lists the labelled successors of a state; get a
//!   [`StateSpace`]: states numbered in breadth-first order, a parent link per
//!   state (so [`StateSpace::path_to`] is a shortest labelled path from the
//!   initial state), and the explicit graph as a compact [`Csr`]. The
//!   project-level explorer plugs in here: its state is what the player holds
//!   between two external events, its step runs the player on each possible
//!   input (event, timer expiry, call result, both answers of a guard oracle),
//!   its label says what the input was and what fired.
//! - **Dense graphs** ([`Successors`]): anything that numbers its nodes
//!   `0..n` and can list a node's successors, explicitly ([`Csr`]) or by
//!   recomputing them (the P/T explorer regenerates successors from stored
//!   markings instead of storing millions of edges). On those:
//!   [`strongly_connected_components`] (iterative Tarjan: no recursion, fit
//!   for millions of nodes), [`dead_nodes`], [`shortest_path`] and
//!   [`shortest_cycle`] (breadth-first, restricted to allowed nodes, e.g. one
//!   component). [`Filtered`] keeps only some labelled edges, e.g. to look for
//!   loops made of immediate transitions only.

use std::collections::{HashMap, VecDeque};
use std::hash::Hash;
use std::sync::atomic::{
    AtomicBool, AtomicU64,
    Ordering::{Relaxed, SeqCst},
};

/// A graph over dense node numbers `0..node_count()`.
pub trait Successors {
    fn node_count(&self) -> usize;
    /// Appends the successors of `node` to `out` (duplicates allowed).
    fn successors(&self, node: u32, out: &mut Vec<u32>);
}

/// An explicit graph in compressed sparse row form, one label per edge.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Csr<L> {
    offsets: Vec<usize>,
    targets: Vec<u32>,
    labels: Vec<L>,
}

impl<L> Default for Csr<L> {
    fn default() -> Self {
        Csr {
            offsets: vec![0],
            targets: Vec::new(),
            labels: Vec::new(),
        }
    }
}

impl<L> Csr<L> {
    /// Adds the next node (numbered `node_count()`) with its labelled edges.
    pub fn push_node(&mut self, edges: impl IntoIterator<Item = (L, u32)>) {
        for (l, t) in edges {
            self.labels.push(l);
            self.targets.push(t);
        }
        self.offsets.push(self.targets.len());
    }

    /// The labelled edges leaving `node`.
    pub fn edges(&self, node: u32) -> impl Iterator<Item = (&L, u32)> {
        let (a, b) = (self.offsets[node as usize], self.offsets[node as usize + 1]);
        self.labels[a..b]
            .iter()
            .zip(self.targets[a..b].iter().copied())
    }

    /// The number of the first edge leaving `node` (edges are numbered in
    /// the order they were added).
    pub fn first_edge(&self, node: u32) -> usize {
        self.offsets[node as usize]
    }

    /// Number of edges.
    pub fn edge_count(&self) -> usize {
        self.targets.len()
    }
}

impl<L> Successors for Csr<L> {
    fn node_count(&self) -> usize {
        self.offsets.len() - 1
    }
    fn successors(&self, node: u32, out: &mut Vec<u32>) {
        let (a, b) = (self.offsets[node as usize], self.offsets[node as usize + 1]);
        out.extend_from_slice(&self.targets[a..b]);
    }
}

/// The edges of a [`Csr`] whose label passes a test.
pub struct Filtered<'g, L, F: Fn(&L) -> bool> {
    pub graph: &'g Csr<L>,
    pub keep: F,
}

impl<L, F: Fn(&L) -> bool> Successors for Filtered<'_, L, F> {
    fn node_count(&self) -> usize {
        self.graph.node_count()
    }
    fn successors(&self, node: u32, out: &mut Vec<u32>) {
        out.extend(
            self.graph
                .edges(node)
                .filter(|(l, _)| (self.keep)(l))
                .map(|(_, t)| t),
        );
    }
}

/// The reachable states of a generic exploration, in breadth-first order
/// (state 0 is the initial state).
#[derive(Debug, Clone)]
pub struct StateSpace<S, L> {
    pub states: Vec<S>,
    pub index: HashMap<S, u32>,
    /// For each state but the first: the state it was first reached from and
    /// the label of that edge.
    pub parents: Vec<Option<(u32, L)>>,
    pub graph: Csr<L>,
    /// False when the state limit stopped the exploration (then the states
    /// past the limit are missing and the last states have no edges listed).
    pub complete: bool,
}

impl<S, L: Clone> StateSpace<S, L> {
    /// The labels of a shortest path from the initial state to `node`.
    pub fn path_to(&self, node: u32) -> Vec<L> {
        let mut path = Vec::new();
        let mut n = node;
        while let Some((p, l)) = &self.parents[n as usize] {
            path.push(l.clone());
            n = *p;
        }
        path.reverse();
        path
    }
}

/// Breadth-first exploration from `initial`. `step(state, out)` appends the
/// labelled successors of `state` to `out`. Stops adding states at
/// `max_states` (then [`StateSpace::complete`] is false).
pub fn explore_bfs<S, L, F>(initial: S, max_states: usize, mut step: F) -> StateSpace<S, L>
where
    S: Hash + Eq + Clone,
    L: Clone,
    F: FnMut(&S, &mut Vec<(L, S)>),
{
    let mut space = StateSpace {
        states: vec![initial.clone()],
        index: HashMap::from([(initial, 0)]),
        parents: vec![None],
        graph: Csr::default(),
        complete: true,
    };
    let mut out = Vec::new();
    let mut next = 0usize;
    while next < space.states.len() {
        out.clear();
        step(&space.states[next], &mut out);
        let mut edges = Vec::with_capacity(out.len());
        for (label, s) in out.drain(..) {
            let target = match space.index.get(&s) {
                Some(&i) => i,
                None if space.states.len() >= max_states => {
                    space.complete = false;
                    continue;
                }
                None => {
                    let i = space.states.len() as u32;
                    space.index.insert(s.clone(), i);
                    space.states.push(s);
                    space.parents.push(Some((next as u32, label.clone())));
                    i
                }
            };
            edges.push((label, target));
        }
        space.graph.push_node(edges);
        next += 1;
    }
    space
}

/// Nodes without successors.
pub fn dead_nodes(g: &impl Successors) -> Vec<u32> {
    let mut out = Vec::new();
    let mut dead = Vec::new();
    for v in 0..g.node_count() as u32 {
        out.clear();
        g.successors(v, &mut out);
        if out.is_empty() {
            dead.push(v);
        }
    }
    dead
}

/// Strongly connected components of a graph.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sccs {
    /// The component of each node. Components are numbered in reverse
    /// topological order: no edge leads from a component to a higher one.
    pub component: Vec<u32>,
    /// Nodes in each component.
    pub sizes: Vec<u32>,
    /// Whether each component holds a cycle (more than one node, or a node
    /// with an edge to itself).
    pub cyclic: Vec<bool>,
}

impl Sccs {
    pub fn count(&self) -> usize {
        self.sizes.len()
    }
}

const UNSEEN: u32 = u32::MAX;

/// Tarjan's algorithm, iterative (explicit call stack; memory about 13 bytes
/// per node plus the depth of the search times the out-degree).
pub fn strongly_connected_components(g: &impl Successors) -> Sccs {
    let n = g.node_count();
    let mut index = vec![UNSEEN; n];
    let mut low = vec![0u32; n];
    let mut component = vec![UNSEEN; n];
    let mut self_loop = vec![false; n];
    let mut sizes: Vec<u32> = Vec::new();
    let mut cyclic: Vec<bool> = Vec::new();
    let mut stack: Vec<u32> = Vec::new();
    // Frames: (node, first edge in `edges`, next edge to look at).
    let mut calls: Vec<(u32, usize, usize)> = Vec::new();
    let mut edges: Vec<u32> = Vec::new();
    let mut counter = 0u32;
    for root in 0..n as u32 {
        if index[root as usize] != UNSEEN {
            continue;
        }
        index[root as usize] = counter;
        low[root as usize] = counter;
        counter += 1;
        stack.push(root);
        g.successors(root, &mut edges);
        calls.push((root, 0, 0));
        while let Some(frame) = calls.last_mut() {
            let (v, start, pos) = *frame;
            if pos < edges.len() {
                frame.2 += 1;
                let w = edges[pos];
                if w == v {
                    self_loop[v as usize] = true;
                }
                if index[w as usize] == UNSEEN {
                    index[w as usize] = counter;
                    low[w as usize] = counter;
                    counter += 1;
                    stack.push(w);
                    let s = edges.len();
                    g.successors(w, &mut edges);
                    calls.push((w, s, s));
                } else if component[w as usize] == UNSEEN {
                    low[v as usize] = low[v as usize].min(index[w as usize]);
                }
                continue;
            }
            calls.pop();
            edges.truncate(start);
            if low[v as usize] == index[v as usize] {
                let c = sizes.len() as u32;
                let mut size = 0u32;
                let mut has_loop = false;
                while let Some(w) = stack.pop() {
                    component[w as usize] = c;
                    size += 1;
                    has_loop |= self_loop[w as usize];
                    if w == v {
                        break;
                    }
                }
                sizes.push(size);
                cyclic.push(size > 1 || has_loop);
            }
            if let Some(&(p, _, _)) = calls.last() {
                low[p as usize] = low[p as usize].min(low[v as usize]);
            }
        }
    }
    Sccs {
        component,
        sizes,
        cyclic,
    }
}

/// A graph over dense node numbers whose successor lists are read without
/// allocating (explicit edges, e.g. kept by an exploration).
pub trait Adjacency {
    /// The successors of a node, one by one.
    type Targets<'a>: Iterator<Item = u32>
    where
        Self: 'a;
    /// Nodes are numbered `0..nodes()`.
    fn nodes(&self) -> usize;
    /// The successors of `node` (duplicates allowed).
    fn targets(&self, node: u32) -> Self::Targets<'_>;
    /// A hint that the successors of `node` will be read soon: where they
    /// start (`near` false, well ahead), or the successors themselves
    /// (`near` true, after their start). Nothing by default.
    #[inline]
    fn prefetch(&self, _node: u32, _near: bool) {}
    /// The successors of `nodes` as stored, when they are stored node
    /// after node: stretches in increasing order that cover `nodes`
    /// exactly. The sweeps then read them without looking each node up.
    /// `None` by default (the sweeps read [`Adjacency::targets`]).
    fn stretches(&self, _nodes: std::ops::Range<u32>) -> Option<Vec<Stretch<'_>>> {
        None
    }
}

/// Nodes whose successors are stored one after the other: node
/// `first + i`'s are `targets[starts[i]..starts[i + 1]]`.
#[derive(Debug, Clone, Copy)]
pub struct Stretch<'a> {
    /// The first node.
    pub first: u32,
    /// Where each node's successors start in `targets`, then where the
    /// last one's end: one more than the nodes.
    pub starts: &'a [u32],
    /// Successors.
    pub targets: &'a [u32],
}

impl Stretch<'_> {
    /// The nodes it holds.
    fn nodes(&self) -> std::ops::Range<u32> {
        let len = self.starts.len().saturating_sub(1) as u32;
        self.first..self.first.saturating_add(len)
    }

    /// The successors of `v`, one of its nodes (none if it is not, or if
    /// its starts lie outside `targets`).
    #[inline]
    fn of(&self, v: u32) -> &[u32] {
        let i = v.wrapping_sub(self.first) as usize;
        match (self.starts.get(i), self.starts.get(i + 1)) {
            (Some(&a), Some(&b)) => self.targets.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        }
    }
}

impl<L> Adjacency for Csr<L> {
    type Targets<'a>
        = std::iter::Copied<std::slice::Iter<'a, u32>>
    where
        L: 'a;
    fn nodes(&self) -> usize {
        self.offsets.len() - 1
    }
    fn targets(&self, node: u32) -> Self::Targets<'_> {
        self.targets[self.offsets[node as usize]..self.offsets[node as usize + 1]]
            .iter()
            .copied()
    }
}

/// The work the sweeps may do before giving up on finding the component
/// of the root that way (see [`strongly_connected_components_from`]), in
/// nodes looked at, per node of the graph. A sweep reads its nodes in
/// order and a bitset that stays in cache; Pearce's search, which follows
/// the edges, costs several sweeps of the whole graph.
const SWEEP_BUDGET: usize = 8;

/// [`SWEEP_BUDGET`] for a graph of `n` nodes.
fn sweep_budget(n: usize) -> u64 {
    (SWEEP_BUDGET * n) as u64
}

/// Strongly connected components of a graph whose nodes are all reachable
/// from `root` (a reachability graph from its initial state), as
/// [`strongly_connected_components`] finds them, in a cheaper way when the
/// root's component is large. The sweeps go over the node numbers, best
/// given in breadth-first order from `root` (as an exploration stores each
/// partition's; the sweeps settle in few passes then). `order` gives every
/// node once, in such an order, `root` first: it is built only if the last
/// node's component is searched (it is the last one there; a list of
/// another length is not searched). `entered` is false when
/// no arc leads to `root` (then its component is itself alone, found
/// without a sweep); true when some may. `seeds` are nodes known to reach
/// `root` (e.g. a cycle through it: nodes at many depths, from which the
/// first sweep joins many more); they may be empty. With `threads` above
/// 1, large sweeps run on `threads` threads, each over its own nodes.
///
/// The root's component is then exactly the set of nodes from which the
/// root can be reached: it is found first by sweeps over the nodes (see
/// [`reaching`]), then the others' components by Pearce's algorithm
/// restricted to them (no edge leaves them for the root's component). When
/// the root's component is small (a net that leaves its initial marking for
/// good), the last node's component is found the same way if it is
/// terminal — the nodes it reaches, all of which reach it back — and
/// Pearce's algorithm runs on the nodes left. Before that, with a
/// `prefix` (the nodes the root passes through before its cycles, see
/// [`peel`]), the nodes after it are tried as one terminal component
/// first ([`component_after`]): without a search of the whole graph. If the sweeps have not
/// settled within their budget ([`SWEEP_BUDGET`]), Pearce's algorithm runs
/// on the whole graph. Components are numbered in reverse topological
/// order, as by [`strongly_connected_components`], but the numbers may
/// differ.
pub fn strongly_connected_components_from(
    g: &(impl Adjacency + Sync),
    root: u32,
    entered: bool,
    seeds: &[u32],
    order: impl FnOnce() -> Vec<u32>,
    threads: usize,
    prefix: Option<&Prefix>,
) -> Sccs {
    let n = g.nodes();
    let outside = |v: &u32| *v as usize >= n;
    if n == 0
        || root as usize >= n
        || seeds.iter().any(outside)
        || prefix.is_some_and(|p| p.transient.iter().chain(&p.entries).any(outside))
    {
        return pearce(g, None, None);
    }
    let mut reach = vec![0u64; n.div_ceil(64)];
    set_bit(&mut reach, root);
    if entered {
        for &s in seeds {
            set_bit(&mut reach, s);
        }
    }
    // most arcs lead forward in a breadth-first order: the first sweep goes
    // down, so that a path forward then back to the root joins in one go
    let left = if entered {
        let swept =
            reaching_everywhere(g, &mut reach, n, Direction::Down, threads, sweep_budget(n));
        let Some(left) = swept else {
            return pearce(g, None, None);
        };
        left as usize
    } else {
        n - 1
    };
    // A root alone (or nearly: a few transient markings before the net
    // settles into its cycles) leaves Pearce's search the whole graph. The
    // last node (of the deepest level) is then likely in a terminal
    // component, found the same way: the nodes it reaches, all of which
    // reach it back.
    let terminal = if left > n / 2 {
        prefix
            .filter(|_| !entered)
            .and_then(|p| component_after(g, p, n, threads))
            .or_else(|| {
                // the nodes left, in `order` (not a permutation: no search)
                let mut rest = order();
                if rest.len() != n {
                    return None;
                }
                rest.retain(|&v| !bit(&reach, v));
                let last = rest.last().copied()?;
                terminal_component(g, last, rest, n, threads).map(|set| (last, set))
            })
    } else {
        None
    };
    pearce(
        g,
        Some((root, &reach)),
        terminal.as_ref().map(|(r, set)| (*r, set.as_slice())),
    )
}

/// The nodes a reachability graph passes through from its root before it
/// enters its cycles, and where it enters them: found by [`peel`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Prefix {
    /// Nodes on no cycle, closed under predecessors (no arc leads into
    /// them from a node outside), the root among them.
    pub transient: Vec<u32>,
    /// The nodes outside `transient` that its arcs lead to, in increasing
    /// order: every node outside `transient` is reached from one of them.
    pub entries: Vec<u32>,
}

/// Peels a graph from `root` as Kahn's topological sort does: `root` first
/// (no arc may lead to it), then every node all of whose arcs in come from
/// peeled nodes. Only the nodes `counted` gives an index are peeled;
/// `arcs_in` holds, at that index, how many arcs lead to the node
/// (duplicates included). Peeling stops at the first cycle met on each
/// path: a node on a cycle waits for a node that waits for it.
pub fn peel(
    g: &impl Adjacency,
    root: u32,
    counted: impl Fn(u32) -> Option<usize>,
    mut arcs_in: Vec<u32>,
) -> Prefix {
    let n = g.nodes();
    let none = Prefix::default();
    if root as usize >= n || counted(root).is_none_or(|i| arcs_in.get(i) != Some(&0)) {
        return none;
    }
    let mut peeled = vec![0u64; n.div_ceil(64)];
    let mut transient = Vec::new();
    let mut next = vec![root];
    while let Some(v) = next.pop() {
        set_bit(&mut peeled, v);
        transient.push(v);
        for w in g.targets(v) {
            if w as usize >= n {
                return none;
            }
            if let Some(c) = counted(w).and_then(|i| arcs_in.get_mut(i)) {
                // more arcs in than counted: the counts are wrong
                let Some(left) = c.checked_sub(1) else {
                    return none;
                };
                *c = left;
                if left == 0 {
                    next.push(w);
                }
            }
        }
    }
    let mut entries: Vec<u32> = transient
        .iter()
        .flat_map(|&v| g.targets(v))
        .filter(|&w| !bit(&peeled, w))
        .collect();
    entries.sort_unstable();
    entries.dedup();
    Prefix { transient, entries }
}

/// The nodes after `prefix` (every node but its transient ones) as one
/// terminal component, with the entry it is named by, if they are one:
/// the first entry reaches every other (a search that stops as soon as it
/// has found them, within a budget), so it reaches every node after the
/// prefix, which no arc leaves; and every one of them reaches it (sweeps
/// over every node, on `threads`). `None` when they
/// are not one component, or that was not shown within the budgets.
fn component_after(
    g: &(impl Adjacency + Sync),
    prefix: &Prefix,
    n: usize,
    threads: usize,
) -> Option<(u32, Vec<u64>)> {
    let &entry = prefix.entries.first()?;
    if !reaches_all(g, entry, &prefix.entries, n / ENTRY_SEARCH + 64) {
        return None;
    }
    // No arc leads from a node after the prefix into it: marking the
    // transient nodes joined changes nothing the sweeps find there, and
    // keeps them out of the candidates.
    let mut reach = vec![0u64; n.div_ceil(64)];
    for &v in prefix.transient.iter().chain([&entry]) {
        set_bit(&mut reach, v);
    }
    if reaching_everywhere(g, &mut reach, n, Direction::Down, threads, sweep_budget(n))? > 0 {
        return None;
    }
    for &v in &prefix.transient {
        reach[(v >> 6) as usize] &= !(1 << (v & 63));
    }
    Some((entry, reach))
}

/// The search of [`component_after`] from the first entry to the others
/// stops after `n / ENTRY_SEARCH` nodes (then the last node's component
/// is searched as before).
const ENTRY_SEARCH: usize = 16;

/// Whether `from` reaches every node of `targets` (sorted), found by a
/// breadth-first search that stops once it has, or after `budget` nodes.
fn reaches_all(g: &impl Adjacency, from: u32, targets: &[u32], budget: usize) -> bool {
    let n = g.nodes();
    let mut seen = vec![0u64; n.div_ceil(64)];
    let mut wanted = vec![0u64; n.div_ceil(64)];
    for &t in targets {
        if t as usize >= n {
            return false;
        }
        set_bit(&mut wanted, t);
    }
    let mut left = targets.len();
    let mut queue = VecDeque::from([from]);
    set_bit(&mut seen, from);
    if bit(&wanted, from) {
        left -= 1;
    }
    let mut visited = 0usize;
    while let Some(v) = queue.pop_front() {
        if left == 0 {
            return true;
        }
        visited += 1;
        if visited > budget {
            return false;
        }
        for w in g.targets(v) {
            if w as usize >= n || bit(&seen, w) {
                continue;
            }
            set_bit(&mut seen, w);
            if bit(&wanted, w) {
                left -= 1;
            }
            queue.push_back(w);
        }
    }
    left == 0
}

/// Which way the first sweep goes over the candidates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Direction {
    /// In their order: best when the target comes first.
    Up,
    /// Against it: best when the target comes last.
    Down,
}

fn bit(set: &[u64], v: u32) -> bool {
    (set[(v >> 6) as usize] >> (v & 63)) & 1 == 1
}

/// Whether `v` is in a bitset shared between threads.
fn joined_in(set: &[AtomicU64], v: u32) -> bool {
    (set[(v >> 6) as usize].load(Relaxed) >> (v & 63)) & 1 == 1
}

fn set_bit(set: &mut [u64], v: u32) {
    set[(v >> 6) as usize] |= 1 << (v & 63);
}

/// Sweeps `candidates` until every one that reaches a node of `reach` has
/// joined it: the candidates that do not reach it (in their order), or
/// `None` when the sweeps did not settle within their budget
/// ([`SWEEP_BUDGET`] times `n` nodes looked at). A candidate joins when one
/// of its successors has joined; the sweeps go along the candidates' order
/// and against it in turn, starting with `first`, on a bitset that stays
/// in cache.
fn reaching(
    g: &(impl Adjacency + Sync),
    reach: &mut [u64],
    mut rest: Vec<u32>,
    n: usize,
    first: Direction,
    threads: usize,
) -> Option<Vec<u32>> {
    if threads > 1 && rest.len() >= PARALLEL_SWEEPS {
        let parts = threads.min(MAX_PARTS);
        reaching_in_parts(g, reach, Some(&rest), first, parts, sweep_budget(n))?;
        rest.retain(|&v| !bit(reach, v));
        return Some(rest);
    }
    rest.retain(|&v| !bit(reach, v));
    sweeps(g, reach, rest, n, first, None)
}

/// [`reaching`] with every node a candidate, swept in the order of their
/// numbers (a breadth-first order within each partition of an
/// exploration), reading the successors as stored where the graph gives
/// them so ([`Adjacency::stretches`]) and skipping 64 joined nodes at a
/// time: how many nodes do not reach `reach`, or `None` when the sweeps
/// did not settle within `budget` nodes looked at ([`sweep_budget`]).
fn reaching_everywhere(
    g: &(impl Adjacency + Sync),
    reach: &mut [u64],
    n: usize,
    first: Direction,
    threads: usize,
    budget: u64,
) -> Option<u64> {
    if threads > 1 && n >= PARALLEL_SWEEPS {
        return reaching_in_parts(g, reach, None, first, threads.min(MAX_PARTS), budget);
    }
    let mut work = 0u64;
    let mut up = first == Direction::Up;
    loop {
        let (joined, looked) = pass_range(g, &mut { &mut *reach }, 0..n as u32, up);
        work += looked;
        if joined == 0 || joined == looked {
            return Some(looked - joined);
        }
        if work > budget {
            return None;
        }
        up = !up;
    }
}

/// A bitset the sweeps join nodes to: plain, or shared with a thread
/// that joins nodes at the same time ([`help`]).
trait Joined {
    /// The word holding nodes `64 at` to `64 at + 63`.
    fn word(&self, at: usize) -> u64;
    /// Joins `v` if `hit` is 1 (it is 0 or 1).
    fn join(&mut self, v: u32, hit: u64);
    /// [`Joined::join`] by the one thread that writes `v`'s word (the
    /// sweeps by words, [`pass_bits`]): without a branch, a store whether
    /// it joins or not. (Written once for the word instead, the nodes of
    /// a chain within a word would join one a sweep: a ring of 100,000
    /// nodes ran out of budget.)
    fn join_owned(&mut self, v: u32, hit: u64);
}

impl Joined for &mut [u64] {
    #[inline]
    fn word(&self, at: usize) -> u64 {
        self[at]
    }

    /// Without a branch: whether a node joins is unpredictable.
    #[inline]
    fn join(&mut self, v: u32, hit: u64) {
        self[(v >> 6) as usize] |= hit << (v & 63);
    }

    #[inline]
    fn join_owned(&mut self, v: u32, hit: u64) {
        self.join(v, hit);
    }
}

impl Joined for &[AtomicU64] {
    #[inline]
    fn word(&self, at: usize) -> u64 {
        self[at].load(Relaxed)
    }

    /// Written only when it joins (a store to a word the other thread
    /// reads takes the line from its cache), without a locked instruction:
    /// a join the helper made in the same word at the same moment may be
    /// overwritten; the helper then said it helped during that sweep, so
    /// another follows and joins that node again.
    #[inline]
    fn join(&mut self, v: u32, hit: u64) {
        if hit != 0 {
            let word = &self[(v >> 6) as usize];
            word.store(word.load(Relaxed) | 1 << (v & 63), Relaxed);
        }
    }

    #[inline]
    fn join_owned(&mut self, v: u32, hit: u64) {
        let word = &self[(v >> 6) as usize];
        word.store(word.load(Relaxed) | hit << (v & 63), Relaxed);
    }
}

/// The sweeps of [`reaching`] over `reach`; with `helped`, another thread
/// may join nodes at the same time and says so there: the sweeps then end
/// with one in which neither joined anything.
fn sweeps(
    g: &impl Adjacency,
    mut reach: impl Joined,
    mut rest: Vec<u32>,
    n: usize,
    first: Direction,
    helped: Option<&AtomicBool>,
) -> Option<Vec<u32>> {
    let mut work = 0usize;
    for sweep in 0usize.. {
        if work as u64 > sweep_budget(n) {
            return None;
        }
        work += rest.len();
        if let Some(h) = helped {
            h.store(false, SeqCst);
        }
        let up = (sweep % 2 == 0) == (first == Direction::Up);
        let mut changed = pass(g, &mut reach, &rest, up) > 0;
        // the helper's joins count too: one may have made a node this
        // sweep passed joinable
        if let Some(h) = helped {
            changed |= h.load(SeqCst);
        }
        if changed {
            rest.retain(|&v| (reach.word((v >> 6) as usize) >> (v & 63)) & 1 == 0);
        }
        if !changed || rest.is_empty() {
            return Some(rest);
        }
    }
    None
}

/// One sweep over `nodes`, in their order (`up`) or against it: each
/// joins `reach` when one of its successors has; how many joined. Every
/// successor is looked at, without a branch per successor: whether a node
/// joins is unpredictable, and most candidates of the first sweeps do not
/// (so read all their successors anyway).
fn pass(g: &impl Adjacency, reach: &mut impl Joined, nodes: &[u32], up: bool) -> u64 {
    let mut joined = 0u64;
    let mut one = |v: u32| {
        let hit = successor_joined(g, &*reach, v);
        reach.join(v, hit);
        joined += hit;
    };
    if up {
        nodes.iter().for_each(|&v| one(v));
    } else {
        nodes.iter().rev().for_each(|&v| one(v));
    }
    joined
}

/// Whether one of `v`'s successors has joined `reach` (1 or 0), every one
/// read without a branch.
#[inline]
fn successor_joined(g: &impl Adjacency, reach: &impl Joined, v: u32) -> u64 {
    let mut hit = 0u64;
    for w in g.targets(v) {
        hit |= reach.word((w >> 6) as usize) >> (w & 63);
    }
    hit & 1
}

/// One sweep over the nodes `nodes` not joined in `reach`, in increasing
/// order (`up`) or decreasing, as [`pass`]: how many joined, and how many
/// were looked at. Successors are read as stored when the graph gives
/// them so ([`Adjacency::stretches`]).
fn pass_range(
    g: &impl Adjacency,
    reach: &mut impl Joined,
    nodes: std::ops::Range<u32>,
    up: bool,
) -> (u64, u64) {
    let Some(stretches) = g.stretches(nodes.clone()) else {
        return pass_bits(reach, nodes, up, |reach, v| successor_joined(g, reach, v));
    };
    let (mut joined, mut looked) = (0, 0);
    let mut each = |s: &Stretch| {
        let held = s.nodes();
        let part = held.start.max(nodes.start)..held.end.min(nodes.end);
        let (j, l) = pass_bits(reach, part, up, |reach, v| any_joined(reach, s.of(v)));
        joined += j;
        looked += l;
    };
    if up {
        stretches.iter().for_each(&mut each);
    } else {
        stretches.iter().rev().for_each(&mut each);
    }
    (joined, looked)
}

/// Whether one of `targets` has joined (1 or 0), all read without a
/// branch; up to [`UNROLLED`] of them without a loop either (the last read
/// again in the place of those missing): how many successors a node has
/// is unpredictable, and a loop's exit mispredicted costs more than the
/// few reads in cache it saves.
#[inline]
fn any_joined(reach: &impl Joined, targets: &[u32]) -> u64 {
    let bit = |w: u32| reach.word((w >> 6) as usize) >> (w & 63);
    let mut hit = 0u64;
    match targets.len() {
        0 => {}
        k @ 1..=UNROLLED => {
            for j in 0..UNROLLED {
                hit |= bit(targets[j.min(k - 1)]);
            }
        }
        _ => {
            for &w in targets {
                hit |= bit(w);
            }
        }
    }
    hit & 1
}

/// Successors read at once by [`any_joined`].
const UNROLLED: usize = 6;

/// [`pass_range`] over the nodes `nodes`, `hit(reach, v)` telling whether
/// node `v` has a successor joined (1 or 0): the nodes not joined are
/// found 64 at a time in `reach`'s words.
#[inline]
fn pass_bits<R: Joined>(
    reach: &mut R,
    nodes: std::ops::Range<u32>,
    up: bool,
    mut hit: impl FnMut(&R, u32) -> u64,
) -> (u64, u64) {
    let (lo, hi) = (nodes.start, nodes.end);
    if lo >= hi {
        return (0, 0);
    }
    let (mut joined, mut looked) = (0u64, 0u64);
    let mut word = |k: usize| {
        let base = (k as u32) << 6;
        let mut left = !reach.word(k);
        if base < lo {
            left &= u64::MAX << (lo - base);
        }
        if hi - base < 64 {
            left &= (1u64 << (hi - base)) - 1;
        }
        looked += u64::from(left.count_ones());
        let mut joins = 0u64;
        while left != 0 {
            let b = if up {
                left.trailing_zeros()
            } else {
                63 - left.leading_zeros()
            };
            left &= !(1u64 << b);
            let hit = hit(reach, base + b);
            reach.join_owned(base + b, hit);
            joins |= hit << b;
        }
        joined += u64::from(joins.count_ones());
    };
    let words = (lo >> 6) as usize..=((hi - 1) >> 6) as usize;
    if up {
        words.for_each(&mut word);
    } else {
        words.rev().for_each(&mut word);
    }
    (joined, looked)
}

/// Candidates from which several threads sweep at once (below, one is
/// faster).
const PARALLEL_SWEEPS: usize = 1 << 16;

/// At most this many threads sweep at once.
const MAX_PARTS: usize = 16;

/// [`reaching`] on `threads` threads, each owning a range of node numbers
/// (equal ranges of whole bitset words): each sweeps its own candidates
/// (those `rest` lists, or with `None` every node of its range, as
/// [`reaching_everywhere`]), in their order and against it in turn, on
/// one bitset that all read and each writes only in its own words (no
/// locked instruction, no join lost). A thread whose sweep joined nothing
/// waits; the sweeps end when every thread has swept all its candidates
/// since the last join anywhere: how many candidates are left then, or
/// `None` if the budget ran out. After an exploration on as many threads,
/// a range is about one partition: each thread reads its own partition's
/// arcs, about in the order of the levels, as one thread sweeping them all
/// would.
fn reaching_in_parts(
    g: &(impl Adjacency + Sync),
    reach: &mut [u64],
    rest: Option<&[u32]>,
    first: Direction,
    threads: usize,
    budget: u64,
) -> Option<u64> {
    let n = g.nodes();
    let per = reach.len().div_ceil(threads).max(1);
    let shared: Vec<AtomicU64> = reach.iter().map(|&w| AtomicU64::new(w)).collect();
    let sweeps = Sweeps {
        joins: AtomicU64::new(0),
        quiet: (0..threads).map(|_| AtomicU64::new(NOT_QUIET)).collect(),
        stop: AtomicBool::new(false),
        budget,
        work: AtomicU64::new(0),
        left: AtomicU64::new(0),
    };
    // each thread picks its own candidates (the words it owns)
    let owner = move |v: u32| ((v >> 6) as usize / per).min(threads - 1);
    let part = |i: usize| {
        let (lo, hi) = (
            i * per * 64,
            if i + 1 == threads {
                n
            } else {
                (i + 1) * per * 64
            },
        );
        lo.min(n) as u32..hi.min(n) as u32
    };
    let run = |i: usize| {
        let reach = shared.as_slice();
        match rest {
            Some(rest) => {
                let mut nodes: Vec<u32> = rest
                    .iter()
                    .copied()
                    .filter(|&v| owner(v) == i && !joined_in(reach, v))
                    .collect();
                sweeps.run(i, first, |up| {
                    let looked = nodes.len() as u64;
                    // this thread alone writes its nodes' words: a plain store
                    let joined = pass(g, &mut { reach }, &nodes, up);
                    if joined > 0 {
                        nodes.retain(|&v| !joined_in(reach, v));
                    }
                    (joined, looked)
                })
            }
            None => {
                let nodes = part(i);
                sweeps.run(i, first, |up| {
                    pass_range(g, &mut { reach }, nodes.clone(), up)
                })
            }
        }
    };
    let settled = std::thread::scope(|scope| {
        let run = &run;
        let handles: Vec<_> = (1..threads).map(|i| scope.spawn(move || run(i))).collect();
        let mut all = run(0);
        for h in handles {
            match h.join() {
                Ok(settled) => all &= settled,
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
        all
    });
    for (w, a) in reach.iter_mut().zip(&shared) {
        *w = a.load(Relaxed);
    }
    settled.then(|| sweeps.left.load(SeqCst))
}

/// A thread of [`reaching_in_parts`] that has joined something since its
/// last sweep, or is sweeping.
const NOT_QUIET: u64 = u64::MAX;

/// What the threads of [`reaching_in_parts`] share besides the bitset.
struct Sweeps {
    /// Nodes joined so far, added by each thread at the end of each sweep.
    joins: AtomicU64,
    /// For each thread, `joins` when it began its last sweep if that
    /// sweep joined nothing, else [`NOT_QUIET`].
    quiet: Vec<AtomicU64>,
    /// Set when a thread gives up (budget spent) or panics: all stop.
    stop: AtomicBool,
    /// Nodes looked at, all threads together, before giving up.
    budget: u64,
    work: AtomicU64,
    /// Candidates left when the sweeps settled, all threads together.
    left: AtomicU64,
}

impl Sweeps {
    /// Thread `me`'s sweeps, `sweep(up)` each (how many of its candidates
    /// joined, and how many it looked at): whether they settled.
    fn run(&self, me: usize, first: Direction, mut sweep: impl FnMut(bool) -> (u64, u64)) -> bool {
        // a panic here stops the others too
        let _stop = Done(&self.stop);
        let mut up = first == Direction::Up;
        loop {
            if self.stop.load(Relaxed) {
                return false;
            }
            self.quiet[me].store(NOT_QUIET, SeqCst);
            let start = self.joins.load(SeqCst);
            let (count, looked) = sweep(up);
            up = !up;
            if self.work.fetch_add(looked, Relaxed).saturating_add(looked) > self.budget {
                return false;
            }
            if count > 0 {
                self.joins.fetch_add(count, SeqCst);
                continue;
            }
            // nothing joined here: settled once every thread has swept
            // since the last join, else sweep again after the next one
            self.quiet[me].store(start, SeqCst);
            loop {
                if self.stop.load(Relaxed) {
                    return false;
                }
                let now = self.joins.load(SeqCst);
                if now != start {
                    break;
                }
                if self.quiet.iter().all(|q| q.load(SeqCst) == now) {
                    self.left.fetch_add(looked, SeqCst);
                    // the others may still be checking: leave them the
                    // same answer (nothing sets `stop` on the way out)
                    std::mem::forget(_stop);
                    return true;
                }
                std::hint::spin_loop();
                std::thread::yield_now();
            }
        }
    }
}

/// [`reaching`] on a bitset another thread may join nodes of at the same
/// time ([`help`]), saying so through `helped`: the sweeps end with one
/// in which neither this thread nor the helper joined anything (see
/// [`Joined`] for `&[AtomicU64]`).
fn reaching_helped(
    g: &(impl Adjacency + Sync),
    reach: &[AtomicU64],
    mut rest: Vec<u32>,
    n: usize,
    first: Direction,
    helped: &AtomicBool,
) -> Option<Vec<u32>> {
    rest.retain(|&v| !joined_in(reach, v));
    sweeps(g, reach, rest, n, first, Some(helped))
}

/// Sweeps `candidates` up and down, joining to `reach` each that has a
/// joined successor (a locked or: never overwrites another join), and
/// saying so through `helped`, until `done`.
fn help(
    g: &impl Adjacency,
    reach: &[AtomicU64],
    candidates: &[u32],
    helped: &AtomicBool,
    done: &AtomicBool,
) {
    let joined = |v: u32| joined_in(reach, v);
    let join = |v: u32| {
        if joined(v) {
            return;
        }
        if g.targets(v).any(joined) {
            reach[(v >> 6) as usize].fetch_or(1 << (v & 63), SeqCst);
            helped.store(true, SeqCst);
        }
    };
    loop {
        for chunk in candidates.chunks(1024) {
            if done.load(Relaxed) {
                return;
            }
            chunk.iter().for_each(|&v| join(v));
        }
        for chunk in candidates.rchunks(1024) {
            if done.load(Relaxed) {
                return;
            }
            chunk.iter().rev().for_each(|&v| join(v));
        }
    }
}

/// Sets its flag when dropped: the sweeps' end, even by a panic (the
/// helper then stops, and the scope can join it).
struct Done<'a>(&'a AtomicBool);

impl Drop for Done<'_> {
    fn drop(&mut self) {
        self.0.store(true, SeqCst);
    }
}

/// The component of `node` as a bitset, if it is terminal (no edge leaves
/// it): every node `node` reaches reaches it back. `None` when it is not,
/// or when the sweeps did not settle. `candidates` holds every node `node`
/// may reach, `node` last (a breadth-first order: the sweeps go down
/// first).
///
/// On one thread, the nodes `node` reaches are searched first and only
/// they are swept. With `threads` above 1 the search and the sweeps run at
/// once, one on each core: the sweeps then go over all the candidates (a
/// few more nodes than `node` reaches, when transient ones lead into its
/// component) on this thread, which is cheaper than sharing the sweeps
/// between the two cores after the search (docs/benchmarks-history.md, stop 30); once
/// the search is done, its thread sweeps too, the other way, on the same
/// bitset ([`help`]), until the sweeps settle. If they do not settle, the
/// nodes reached are swept alone, as on one thread. Every way gives the same set: the nodes `node` reaches, when
/// all of them reach it back.
fn terminal_component(
    g: &(impl Adjacency + Sync),
    node: u32,
    mut candidates: Vec<u32>,
    n: usize,
    threads: usize,
) -> Option<Vec<u64>> {
    let mut back = vec![0u64; n.div_ceil(64)];
    set_bit(&mut back, node);
    let seen = if threads > 1 {
        // A path from a candidate to `node` never leaves the candidates
        // (the caller's: a node from which the root's component can be
        // reached is in it), so the sweeps over all of them give the same
        // answer for the nodes `node` reaches as sweeps over these alone.
        let all = candidates.clone();
        let shared: Vec<AtomicU64> = back.iter().map(|&w| AtomicU64::new(w)).collect();
        let (helped, done) = (AtomicBool::new(false), AtomicBool::new(false));
        let (seen, settled) = std::thread::scope(|scope| {
            let search = scope.spawn(|| {
                let seen = reached_joining(g, node, n, &shared, &helped);
                // then help the sweeps until they settle
                help(g, &shared, &candidates, &helped, &done);
                seen
            });
            let settled = {
                let _done = Done(&done);
                reaching_helped(g, &shared, all, n, Direction::Down, &helped).is_some()
            };
            match search.join() {
                Ok(seen) => (seen, settled),
                Err(panic) => std::panic::resume_unwind(panic),
            }
        });
        for (w, a) in back.iter_mut().zip(&shared) {
            *w = a.load(Relaxed);
        }
        if settled {
            // terminal when every node reached reaches `node` back
            let all_back = seen.iter().zip(&back).all(|(&s, &b)| s & !b == 0);
            return all_back.then_some(seen);
        }
        // the sweeps over all the candidates ran out of budget (most of
        // them lead into a small component): sweep the nodes reached alone
        back.fill(0);
        set_bit(&mut back, node);
        seen
    } else {
        reached_by_levels(g, node, n)
    };
    // the nodes it reaches, in the candidates' order
    candidates.retain(|&v| bit(&seen, v));
    drop(seen);
    let rest = reaching(g, &mut back, candidates, n, Direction::Down, threads)?;
    rest.is_empty().then_some(back)
}

/// The nodes `node` reaches, as a bitset: a breadth-first search level by
/// level, each level's nodes read in increasing order, so that their
/// successors are read in the order they lie in memory, whatever order the
/// search reaches them in (after an exploration on two threads that order
/// is nowhere near the nodes': docs/benchmarks-history.md, stop 29). The nodes a few
/// places ahead are asked for in two steps (where their successors start,
/// then these).
fn reached_by_levels(g: &impl Adjacency, node: u32, n: usize) -> Vec<u64> {
    search_by_levels(g, node, n, |_| {})
}

/// [`reached_by_levels`], joining to `reach` (nodes known to reach
/// `node`) each node that has a joined successor, and the nodes on its
/// path from `node` in the search (they reach it), saying so through
/// `helped` (see [`reaching_helped`]): sweeps at the same time then find
/// joined nodes at every depth of the search, not only near `node`.
/// `node` must be in `reach`.
fn reached_joining(
    g: &impl Adjacency,
    node: u32,
    n: usize,
    reach: &[AtomicU64],
    helped: &AtomicBool,
) -> Vec<u64> {
    let joined = |v: u32| joined_in(reach, v);
    // zeroed (pages mapped as they are written); `node` has no parent but
    // is never walked past: it is joined
    let mut parent = vec![0u32; n];
    let mut hit = false;
    search_by_levels(g, node, n, |step| match step {
        Visit::Arc { from, to, new } => {
            if new {
                parent[to as usize] = from;
            }
            hit |= joined(to);
        }
        Visit::Done(v) => {
            if std::mem::take(&mut hit) {
                let mut u = v;
                // the walk ends at `node` at the latest, which is joined
                while !joined(u) {
                    reach[(u >> 6) as usize].fetch_or(1 << (u & 63), SeqCst);
                    helped.store(true, SeqCst);
                    u = parent[u as usize];
                }
            }
        }
    })
}

/// What [`search_by_levels`] tells its caller, in order: each arc it
/// reads (whether its target is new), then that a node's arcs were all
/// read.
#[derive(Debug, Clone, Copy)]
enum Visit {
    Arc { from: u32, to: u32, new: bool },
    Done(u32),
}

/// The breadth-first search of [`reached_by_levels`], telling `visit`
/// each arc it reads and each node done ([`Visit`]).
fn search_by_levels(
    g: &impl Adjacency,
    node: u32,
    n: usize,
    mut visit: impl FnMut(Visit),
) -> Vec<u64> {
    let words = n.div_ceil(64);
    let mut seen = vec![0u64; words];
    let mut next = vec![0u64; words];
    set_bit(&mut seen, node);
    let mut level = vec![node];
    while !level.is_empty() {
        let (mut lo, mut hi) = (words, 0);
        for (i, &v) in level.iter().enumerate() {
            if let Some(&u) = level.get(i + 2 * PREFETCH) {
                g.prefetch(u, false);
            }
            if let Some(&u) = level.get(i + PREFETCH) {
                g.prefetch(u, true);
            }
            for w in g.targets(v) {
                let (at, m) = ((w >> 6) as usize, 1u64 << (w & 63));
                let new = seen[at] & m == 0;
                if new {
                    seen[at] |= m;
                    next[at] |= m;
                    lo = lo.min(at);
                    hi = hi.max(at + 1);
                }
                visit(Visit::Arc {
                    from: v,
                    to: w,
                    new,
                });
            }
            visit(Visit::Done(v));
        }
        level.clear();
        for (at, word) in next.iter_mut().enumerate().take(hi).skip(lo) {
            let mut bits = std::mem::take(word);
            while bits != 0 {
                level.push((at * 64) as u32 + bits.trailing_zeros());
                bits &= bits - 1;
            }
        }
    }
    seen
}

/// How far ahead in its level a breadth-first search asks for the nodes it
/// will read ([`Adjacency::prefetch`]).
const PREFETCH: usize = 8;

/// Strongly connected components by Pearce's space-efficient variant of
/// Tarjan's algorithm ("A space-efficient algorithm for finding strongly
/// connected components", 2016), iterative: one 32-bit number and one bit
/// per node, plus the depth of the search. With `settled = (root, set)`,
/// `set` (a bitset) is the root's component, and no node outside it
/// reaches it (numbered last); with `terminal = (node, set)`, `set` is
/// `node`'s component and no edge leaves it (numbered first).
fn pearce<G: Adjacency>(
    g: &G,
    settled: Option<(u32, &[u64])>,
    terminal: Option<(u32, &[u64])>,
) -> Sccs {
    let n = g.nodes();
    let top = n as u32;
    // 0: not visited; below `index`: being visited (Tarjan's low link);
    // above `c`: the component, numbered down from `n`
    let mut rindex = vec![0u32; n];
    let mut root = vec![0u64; n.div_ceil(64)];
    let mut sizes: Vec<u32> = Vec::new();
    let mut cyclic: Vec<bool> = Vec::new();
    // the settled component (numbers `top`) comes last: every other node
    // is reachable from it
    let mut last: Option<(u32, bool)> = None;
    if let Some((r, set)) = settled {
        let size = fill(set, &mut rindex, top);
        last = Some((size, size > 1 || g.targets(r).any(|w| w == r)));
    }
    let base = if last.is_some() { top - 1 } else { top };
    let mut c = base;
    // a terminal component, numbered first: no edge leaves it
    if let Some((r, set)) = terminal {
        let size = fill(set, &mut rindex, c);
        c -= 1;
        sizes.push(size);
        cyclic.push(size > 1 || g.targets(r).any(|w| w == r));
    }
    let mut index = 1u32;
    let mut stack: Vec<u32> = Vec::new();
    // frames: node, its successors still to look at, whether it has an
    // edge to itself
    let mut calls: Vec<(u32, G::Targets<'_>, bool)> = Vec::new();
    let is_root = |root: &[u64], v: u32| (root[(v >> 6) as usize] >> (v & 63)) & 1 == 1;
    let set_root = |root: &mut [u64], v: u32, on: bool| {
        let (w, m) = ((v >> 6) as usize, 1u64 << (v & 63));
        if on {
            root[w] |= m;
        } else {
            root[w] &= !m;
        }
    };
    // the nodes of neither set given: the only ones to start from
    let given = |w: usize| {
        settled.map_or(0, |(_, s)| s.get(w).copied().unwrap_or(0))
            | terminal.map_or(0, |(_, s)| s.get(w).copied().unwrap_or(0))
    };
    let starts = (0..n.div_ceil(64)).flat_map(|w| {
        let mut free = !given(w);
        std::iter::from_fn(move || {
            (free != 0).then(|| {
                let v = (w * 64) as u32 + free.trailing_zeros();
                free &= free - 1;
                v
            })
        })
    });
    for start in starts {
        if start >= top || rindex[start as usize] != 0 {
            continue;
        }
        rindex[start as usize] = index;
        index += 1;
        set_root(&mut root, start, true);
        calls.push((start, g.targets(start), false));
        while let Some(frame) = calls.last_mut() {
            let v = frame.0;
            if let Some(w) = frame.1.next() {
                if w == v {
                    frame.2 = true;
                } else if rindex[w as usize] == 0 {
                    rindex[w as usize] = index;
                    index += 1;
                    set_root(&mut root, w, true);
                    calls.push((w, g.targets(w), false));
                } else if rindex[w as usize] < rindex[v as usize] {
                    rindex[v as usize] = rindex[w as usize];
                    set_root(&mut root, v, false);
                }
                continue;
            }
            let self_loop = frame.2;
            calls.pop();
            if is_root(&root, v) {
                index -= 1;
                let mut size = 1u32;
                while let Some(&w) = stack.last() {
                    if rindex[v as usize] > rindex[w as usize] {
                        break;
                    }
                    stack.pop();
                    rindex[w as usize] = c;
                    index -= 1;
                    size += 1;
                }
                rindex[v as usize] = c;
                c -= 1;
                sizes.push(size);
                cyclic.push(size > 1 || self_loop);
            } else {
                stack.push(v);
            }
            if let Some(&(u, _, _)) = calls.last() {
                if rindex[v as usize] < rindex[u as usize] {
                    rindex[u as usize] = rindex[v as usize];
                    set_root(&mut root, u, false);
                }
            }
        }
    }
    let others = sizes.len() as u32;
    for r in &mut rindex {
        *r = if *r == top && last.is_some() {
            others
        } else {
            base - *r
        };
    }
    if let Some((size, has_cycle)) = last {
        sizes.push(size);
        cyclic.push(has_cycle);
    }
    Sccs {
        component: rindex,
        sizes,
        cyclic,
    }
}

/// Sets `rindex` to `value` for the nodes of `set` (whole words at once);
/// how many there are.
fn fill(set: &[u64], rindex: &mut [u32], value: u32) -> u32 {
    let mut size = 0u32;
    for (w, &bits) in set.iter().enumerate() {
        let base = w * 64;
        if bits == !0 && base + 64 <= rindex.len() {
            rindex[base..base + 64].fill(value);
        } else {
            let mut b = bits;
            while b != 0 {
                rindex[base + b.trailing_zeros() as usize] = value;
                b &= b - 1;
            }
        }
        size += bits.count_ones();
    }
    size
}

/// A shortest path (nodes, `from` first) from `from` to a node satisfying
/// `is_target`, visiting only `allowed` nodes after `from`.
pub fn shortest_path(
    g: &impl Successors,
    from: u32,
    is_target: impl Fn(u32) -> bool,
    allowed: impl Fn(u32) -> bool,
) -> Option<Vec<u32>> {
    if is_target(from) {
        return Some(vec![from]);
    }
    search(g, from, is_target, allowed)
}

/// A shortest cycle through `node` (nodes, `node` first and not repeated at
/// the end), visiting only `allowed` nodes.
pub fn shortest_cycle(
    g: &impl Successors,
    node: u32,
    allowed: impl Fn(u32) -> bool,
) -> Option<Vec<u32>> {
    let mut path = search(g, node, |v| v == node, allowed)?;
    path.pop();
    Some(path)
}

/// Breadth-first search from `from` (not itself checked) to a target.
fn search(
    g: &impl Successors,
    from: u32,
    is_target: impl Fn(u32) -> bool,
    allowed: impl Fn(u32) -> bool,
) -> Option<Vec<u32>> {
    // the parent of each node reached (u32::MAX: not reached), in a vector
    // over all nodes (a search may cover millions of them)
    const NONE: u32 = u32::MAX;
    let mut parent: Vec<u32> = vec![NONE; g.node_count()];
    let mut queue = VecDeque::from([from]);
    let mut out = Vec::new();
    while let Some(v) = queue.pop_front() {
        out.clear();
        g.successors(v, &mut out);
        for &w in &out {
            if is_target(w) {
                let mut path = vec![w, v];
                let mut n = v;
                while n != from {
                    n = parent[n as usize];
                    path.push(n);
                }
                path.reverse();
                return Some(path);
            }
            if w != from && allowed(w) && parent[w as usize] == NONE {
                parent[w as usize] = v;
                queue.push_back(w);
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn csr(edges: &[&[u32]]) -> Csr<()> {
        let mut g = Csr::default();
        for e in edges {
            g.push_node(e.iter().map(|&t| ((), t)));
        }
        g
    }

    #[test]
    fn components_of_a_small_graph() {
        // 0 -> 1 -> 2 -> 0 (cycle), 2 -> 3, 3 -> 3 (self loop), 3 -> 4.
        let g = csr(&[&[1], &[2], &[0, 3], &[3, 4], &[]]);
        let s = strongly_connected_components(&g);
        assert_eq!(s.count(), 3);
        assert_eq!(s.component[0], s.component[1]);
        assert_eq!(s.component[1], s.component[2]);
        assert_ne!(s.component[2], s.component[3]);
        // reverse topological order: 4's component first
        assert_eq!(s.component[4], 0);
        assert_eq!(s.component[3], 1);
        assert_eq!(s.sizes, vec![1, 1, 3]);
        assert_eq!(s.cyclic, vec![false, true, true]);
        assert_eq!(dead_nodes(&g), vec![4]);
    }

    #[test]
    fn deep_chains_do_not_overflow_the_stack() {
        let n = 200_000u32;
        let mut g = Csr::default();
        for v in 0..n {
            g.push_node(std::iter::once(((), (v + 1) % n)));
        }
        let s = strongly_connected_components(&g);
        assert_eq!(s.sizes, vec![n]);
        assert_eq!(
            shortest_cycle(&g, 5, |_| true).map(|c| c.len()),
            Some(n as usize)
        );
    }

    /// A random graph of `n` nodes, all reachable from node 0 (a random
    /// tree from 0 plus `extra` random edges, some self-loops).
    fn random_graph(n: u32, extra: u32, seed: u64) -> Csr<()> {
        let mut x = seed;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n as usize];
        for v in 1..n {
            let parent = (next() % u64::from(v)) as u32;
            lists[parent as usize].push(v);
        }
        for _ in 0..extra {
            let a = (next() % u64::from(n)) as u32;
            let b = (next() % u64::from(n)) as u32;
            lists[a as usize].push(b);
        }
        let mut g = Csr::default();
        for l in lists {
            g.push_node(l.into_iter().map(|t| ((), t)));
        }
        g
    }

    /// Same partition into components, same sizes and cycles, and numbers
    /// in reverse topological order.
    fn same_components(g: &Csr<()>, a: &Sccs, b: &Sccs) {
        let n = Adjacency::nodes(g);
        assert_eq!(a.count(), b.count());
        let mut map = vec![u32::MAX; a.count()];
        for v in 0..n {
            let (ca, cb) = (a.component[v] as usize, b.component[v]);
            if map[ca] == u32::MAX {
                map[ca] = cb;
            }
            assert_eq!(map[ca], cb, "node {v}");
            assert_eq!(a.sizes[ca], b.sizes[cb as usize]);
            assert_eq!(a.cyclic[ca], b.cyclic[cb as usize]);
        }
        for v in 0..n as u32 {
            for w in Adjacency::targets(g, v) {
                assert!(b.component[v as usize] >= b.component[w as usize]);
            }
        }
    }

    #[test]
    fn pearce_and_sweeps_agree_with_tarjan() {
        for (n, extra, seed) in [
            (1, 0, 1),
            (1, 1, 2),
            (2, 1, 3),
            (50, 20, 4),
            (50, 80, 5),
            (300, 150, 6),
            (300, 600, 7),
            (2000, 1500, 8),
            (2000, 4000, 9),
        ] {
            let g = random_graph(n, extra, seed);
            let tarjan = strongly_connected_components(&g);
            same_components(&g, &tarjan, &pearce(&g, None, None));
            same_components(
                &g,
                &tarjan,
                &strongly_connected_components_from(&g, 0, true, &[], || (0..n).collect(), 1, None),
            );
            // seeded by a cycle through the root
            let cycle = shortest_cycle(&g, 0, |_| true).unwrap_or_default();
            same_components(
                &g,
                &tarjan,
                &strongly_connected_components_from(
                    &g,
                    0,
                    true,
                    &cycle,
                    || (0..n).collect(),
                    1,
                    None,
                ),
            );
            // any order of the nodes, root first, gives the same components
            let mut shuffled: Vec<u32> = (1..n).collect();
            let mut x = seed;
            for i in (1..shuffled.len()).rev() {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                shuffled.swap(i, (x >> 33) as usize % (i + 1));
            }
            shuffled.insert(0, 0);
            same_components(
                &g,
                &tarjan,
                &strongly_connected_components_from(&g, 0, true, &[], || shuffled, 1, None),
            );
        }
        // large enough for two threads to sweep
        for (n, extra, seed) in [(100_000, 150_000, 10), (100_000, 30_000, 11)] {
            let g = random_graph(n, extra, seed);
            let tarjan = strongly_connected_components(&g);
            let cycle = shortest_cycle(&g, 0, |_| true).unwrap_or_default();
            for seeds in [&[][..], &cycle[..]] {
                same_components(
                    &g,
                    &tarjan,
                    &strongly_connected_components_from(
                        &g,
                        0,
                        true,
                        seeds,
                        || (0..n).collect(),
                        2,
                        None,
                    ),
                );
            }
        }
        // a ring walked against the sweeps: 0 -> 1 -> ... -> n-1 -> 0 in
        // a zig-zag numbering, so that each sweep adds few nodes (Pearce's
        // algorithm then takes over)
        let n = 64u32;
        let order: Vec<u32> = (0..n)
            .map(|i| if i % 2 == 0 { i / 2 } else { n - 1 - i / 2 })
            .collect();
        let mut lists = vec![Vec::new(); n as usize];
        for i in 0..n as usize {
            lists[order[i] as usize].push(order[(i + 1) % n as usize]);
        }
        lists[5].push(40);
        let mut g = Csr::default();
        for l in lists {
            g.push_node(l.into_iter().map(|t| ((), t)));
        }
        let tarjan = strongly_connected_components(&g);
        let from = strongly_connected_components_from(
            &g,
            order[0],
            true,
            &[],
            || (0..n).collect(),
            1,
            None,
        );
        same_components(&g, &tarjan, &from);
        assert_eq!(from.sizes, vec![n]);
    }

    #[test]
    fn two_threads_sweeping_one_bitset_find_the_same_components() {
        // 0 -> 1 -> a strongly connected random graph on 3..n (a cycle
        // through them in a random order, and random arcs among them),
        // with or without an exit to node 2, which has no successor: the
        // root is transient, and the last node's component, terminal or
        // not, is found by the search and the sweeps at once, the
        // search's thread then sweeping too. Run after run (other
        // timings), Tarjan's components.
        for (n, extra, seed, exit) in [
            (60_000u32, 60_000u32, 21u64, false),
            (60_000, 60_000, 22, true),
            (200_000, 200_000, 23, false),
            (200_000, 200_000, 24, true),
        ] {
            let mut x = seed;
            let mut next = move || {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x
            };
            let mut ring: Vec<u32> = (3..n).collect();
            for i in (1..ring.len()).rev() {
                ring.swap(i, (next() % (i as u64 + 1)) as usize);
            }
            let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n as usize];
            lists[0].push(1);
            lists[1].push(ring[0]);
            for (i, &v) in ring.iter().enumerate() {
                lists[v as usize].push(ring[(i + 1) % ring.len()]);
            }
            for _ in 0..extra {
                let a = 3 + (next() % u64::from(n - 3)) as u32;
                let b = 3 + (next() % u64::from(n - 3)) as u32;
                lists[a as usize].push(b);
            }
            if exit {
                lists[ring[ring.len() / 2] as usize].push(2);
            }
            let mut g = Csr::default();
            for l in lists {
                g.push_node(l.into_iter().map(|t| ((), t)));
            }
            let tarjan = strongly_connected_components(&g);
            // 0, 1, 2 alone, and the ring
            assert_eq!(tarjan.count(), 4);
            // and after the prefix 0 -> 1 (one entry), swept on two and
            // three threads at once, each its own range of nodes
            let prefix = prefix_of(&g, u32::MAX);
            assert_eq!(prefix.entries, vec![ring[0]]);
            for _ in 0..3 {
                let from = strongly_connected_components_from(
                    &g,
                    0,
                    false,
                    &[],
                    || (0..n).collect(),
                    2,
                    None,
                );
                same_components(&g, &tarjan, &from);
                for threads in [2, 3] {
                    // never the ring with node 2 (unreached without the
                    // exit, its own component with it)
                    let after = component_after(&g, &prefix, n as usize, threads);
                    assert!(after.is_none());
                    let from = strongly_connected_components_from(
                        &g,
                        0,
                        false,
                        &[],
                        || (0..n).collect(),
                        threads,
                        Some(&prefix),
                    );
                    same_components(&g, &tarjan, &from);
                }
            }
        }
    }

    #[test]
    fn the_search_by_levels_reaches_what_a_plain_search_reaches() {
        for (n, extra, seed) in [(1, 0, 1), (50, 20, 2), (300, 100, 3), (5000, 2000, 4)] {
            let g = random_graph(n, extra, seed);
            for from in [0, n / 2, n - 1] {
                let mut want = vec![false; n as usize];
                let mut stack = vec![from];
                want[from as usize] = true;
                while let Some(v) = stack.pop() {
                    for w in Adjacency::targets(&g, v) {
                        if !want[w as usize] {
                            want[w as usize] = true;
                            stack.push(w);
                        }
                    }
                }
                let got = reached_by_levels(&g, from, n as usize);
                let got: Vec<bool> = (0..n).map(|v| bit(&got, v)).collect();
                assert_eq!(got, want, "n {n}, from {from}");
            }
        }
    }

    #[test]
    fn a_terminal_component_after_transient_nodes() {
        // 0 -> 1 -> 2 -> 3 (transient), then a ring 3..n with chords, all
        // numbered after them: the root's component is the root alone and
        // the last node's (terminal) holds the rest; then the same with an
        // exit from the ring to a last node with no successor (the ring is
        // no longer terminal, the sink is).
        for (exit, n, threads) in [
            (false, 400u32, 1),
            (true, 400, 1),
            (false, 100_000, 2),
            (true, 100_000, 2),
        ] {
            let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n as usize];
            for v in 0..3 {
                lists[v as usize].push(v + 1);
            }
            let ring_end = if exit { n - 1 } else { n };
            for v in 3..ring_end {
                let next = if v + 1 == ring_end { 3 } else { v + 1 };
                lists[v as usize].push(next);
                if v % 7 == 0 {
                    lists[v as usize].push(3 + (v * 13) % (ring_end - 3));
                }
            }
            if exit {
                lists[200].push(n - 1);
            }
            let mut g = Csr::default();
            for l in lists {
                g.push_node(l.into_iter().map(|t| ((), t)));
            }
            let tarjan = strongly_connected_components(&g);
            let from = strongly_connected_components_from(
                &g,
                0,
                true,
                &[],
                || (0..n).collect(),
                threads,
                None,
            );
            same_components(&g, &tarjan, &from);
            // nothing leads back to 0: the same without sweeping for it
            let unentered = strongly_connected_components_from(
                &g,
                0,
                false,
                &[],
                || (0..n).collect(),
                threads,
                None,
            );
            same_components(&g, &tarjan, &unentered);
            let ring = from.component[10] as usize;
            assert_eq!(from.sizes[ring], ring_end - 3);
            assert!(from.cyclic[ring]);
            assert_eq!(from.count(), 4 + usize::from(exit));
        }
    }

    /// The prefix of `g` from node 0, every node's arcs in counted but
    /// those of `uncounted`.
    fn prefix_of(g: &Csr<()>, uncounted: u32) -> Prefix {
        let n = Adjacency::nodes(g);
        let mut arcs_in = vec![0u32; n];
        for v in 0..n as u32 {
            for w in Adjacency::targets(g, v) {
                arcs_in[w as usize] += 1;
            }
        }
        peel(g, 0, |v| (v != uncounted).then_some(v as usize), arcs_in)
    }

    #[test]
    fn the_nodes_after_a_prefix_as_one_terminal_component_or_not() {
        // 0 -> 1, 2 -> 3 (a diamond, transient), 3 -> several nodes of a
        // ring 4..n with chords (one component); then: a transient node
        // that leads into it, its arcs in not counted (an entry the ring
        // never reaches back), an exit from the ring to a sink (not one
        // component), a cycle in the prefix (peeling stops there)
        for (case, n, threads) in [
            ("ring", 400u32, 1),
            ("ring", 100_000, 2),
            ("ring", 100_000, 3),
            ("transient entry", 400, 1),
            ("transient entry", 100_000, 2),
            ("exit", 400, 1),
            ("exit", 100_000, 2),
            ("cycle in the prefix", 100_000, 2),
            ("far entries", 100_000, 2),
        ] {
            let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n as usize];
            lists[0] = vec![1, 2];
            lists[1] = vec![3];
            lists[2] = vec![3];
            let ring = 4..n - 2;
            for v in ring.clone() {
                let next = if v + 1 == ring.end { ring.start } else { v + 1 };
                lists[v as usize].push(next);
                if v % 5 == 0 {
                    lists[v as usize].push(ring.start + (v * 7919) % (ring.end - ring.start));
                }
            }
            let entries = if case == "far entries" {
                vec![4, 9, n / 2, n - 3]
            } else {
                vec![4, 5, 7, 9]
            };
            lists[3] = entries.clone();
            // n - 2: in the ring's component unless a case says otherwise
            lists[n as usize - 2] = vec![5];
            lists[10].push(n - 2);
            // n - 1: the last node, in the ring too
            lists[n as usize - 1] = vec![6];
            lists[11].push(n - 1);
            match case {
                "transient entry" => {
                    lists[10].retain(|&w| w != n - 2);
                    lists[3].push(n - 2);
                }
                "exit" => {
                    lists[n as usize - 1].clear();
                }
                "cycle in the prefix" => {
                    lists[1].push(2);
                    lists[2].push(1);
                }
                _ => {}
            }
            let mut g = Csr::default();
            for l in lists {
                g.push_node(l.into_iter().map(|t| ((), t)));
            }
            let prefix = prefix_of(&g, n - 2);
            match case {
                "cycle in the prefix" => assert_eq!(prefix.transient, vec![0]),
                _ => {
                    let mut t = prefix.transient.clone();
                    t.sort_unstable();
                    assert_eq!(t, vec![0, 1, 2, 3], "{case}");
                    let mut e = entries.clone();
                    if case == "transient entry" {
                        e.push(n - 2);
                    }
                    e.sort_unstable();
                    assert_eq!(prefix.entries, e, "{case}");
                }
            }
            // found without a search of the whole graph, or not at all
            let after = component_after(&g, &prefix, n as usize, threads);
            match case {
                "ring" => {
                    let (entry, set) = after.unwrap_or_else(|| panic!("{case} {n} {threads}"));
                    assert_eq!(entry, 4);
                    for v in 0..n {
                        assert_eq!(bit(&set, v), v >= 4, "{case} {v}");
                    }
                }
                // not one component ("cycle in the prefix": 1 <-> 2 are
                // after the prefix), or not shown so within the budget
                // ("far entries": the search from 4 to the others)
                _ => assert!(after.is_none(), "{case}"),
            }
            let tarjan = strongly_connected_components(&g);
            let from = strongly_connected_components_from(
                &g,
                0,
                false,
                &[],
                || (0..n).collect(),
                threads,
                Some(&prefix),
            );
            same_components(&g, &tarjan, &from);
            let big = from.component[100] as usize;
            let expected = match case {
                "ring" | "cycle in the prefix" | "far entries" => n - 4,
                _ => n - 5,
            };
            assert_eq!(from.sizes[big], expected, "{case} {n} {threads}");
            assert!(from.cyclic[big]);
        }
    }

    #[test]
    fn peeling_stops_at_what_it_did_not_count_and_at_wrong_counts() {
        // 0 -> 1 -> 2 -> 3 -> 1
        let g = csr(&[&[1], &[2], &[3], &[1]]);
        // 1 has two arcs in (0 and 3): peeling stops after 0
        assert_eq!(
            peel(&g, 0, |v| Some(v as usize), vec![0, 2, 1, 1]),
            Prefix {
                transient: vec![0],
                entries: vec![1]
            }
        );
        // only 0 counted
        assert_eq!(
            peel(&g, 0, |v| (v == 0).then_some(0), vec![0]),
            Prefix {
                transient: vec![0],
                entries: vec![1]
            }
        );
        // an arc into the root, or fewer arcs counted than there are
        assert_eq!(
            peel(&g, 1, |v| Some(v as usize), vec![0, 2, 1, 1]),
            Prefix::default()
        );
        assert_eq!(
            peel(&g, 0, |v| Some(v as usize), vec![0, 0, 1, 1]),
            Prefix::default()
        );
    }

    #[test]
    fn a_small_terminal_component_at_the_end_of_a_path_walked_against_the_sweeps() {
        // 0 -> 1 -> n-2 -> 2 -> n-3 -> ... (a zig-zag numbering) -> n-1,
        // a sink: on two threads the sweeps over all the candidates add a
        // node or two each and run out of budget, and the sink (the last
        // node, its own terminal component) is found by sweeping the nodes
        // it reaches alone; one thread sweeps these from the start.
        for n in [8u32, 64, 301] {
            let inner: Vec<u32> = (0..n - 2)
                .map(|i| if i % 2 == 0 { 1 + i / 2 } else { n - 2 - i / 2 })
                .collect();
            let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n as usize];
            let path: Vec<u32> = std::iter::once(0)
                .chain(inner)
                .chain(std::iter::once(n - 1))
                .collect();
            for step in path.windows(2) {
                lists[step[0] as usize].push(step[1]);
            }
            let mut g = Csr::default();
            for l in lists {
                g.push_node(l.into_iter().map(|t| ((), t)));
            }
            let tarjan = strongly_connected_components(&g);
            for threads in [1, 2] {
                let from = strongly_connected_components_from(
                    &g,
                    0,
                    false,
                    &[],
                    || (0..n).collect(),
                    threads,
                    None,
                );
                same_components(&g, &tarjan, &from);
                assert_eq!(from.count(), n as usize);
                assert!(from.cyclic.iter().all(|&c| !c));
            }
        }
    }

    #[test]
    fn bfs_gives_shortest_labelled_paths() {
        // States are numbers; steps +1 and *2 up to 20.
        let space = explore_bfs(1u32, usize::MAX, |&s, out| {
            if s < 20 {
                out.push(("+1", s + 1));
            }
            if s * 2 <= 20 {
                out.push(("*2", s * 2));
            }
        });
        assert!(space.complete);
        assert_eq!(space.states.len(), 20);
        let i = space.index[&20];
        assert_eq!(space.path_to(i), vec!["+1", "*2", "+1", "*2", "*2"]);
        assert_eq!(space.graph.edge_count(), 19 + 10);
        assert_eq!(dead_nodes(&space.graph), vec![i]);
        let limited = explore_bfs(1u32, 5, |&s, out| out.push(((), s + 1)));
        assert!(!limited.complete);
        assert_eq!(limited.states.len(), 5);
    }

    #[test]
    fn filtered_edges_and_paths() {
        let mut g = Csr::default();
        g.push_node([("a", 1), ("b", 2)]);
        g.push_node([("a", 0)]);
        g.push_node([("b", 2)]);
        let only_a = Filtered {
            graph: &g,
            keep: |l: &&str| *l == "a",
        };
        let s = strongly_connected_components(&only_a);
        assert_eq!(s.cyclic.iter().filter(|&&c| c).count(), 1);
        assert_eq!(s.component[0], s.component[1]);
        assert_eq!(shortest_path(&g, 0, |v| v == 2, |_| true), Some(vec![0, 2]));
        assert_eq!(shortest_path(&only_a, 0, |v| v == 2, |_| true), None);
        assert_eq!(shortest_cycle(&g, 2, |_| true), Some(vec![2]));
        assert_eq!(shortest_cycle(&g, 0, |v| v != 1), None);
    }

    /// A graph that gives its successors as stretches (as an exploration's
    /// partitions do), cut at `cuts`.
    struct Cut<'g> {
        g: &'g Csr<()>,
        starts: Vec<u32>,
        cuts: Vec<u32>,
    }

    impl Adjacency for Cut<'_> {
        type Targets<'a>
            = std::iter::Copied<std::slice::Iter<'a, u32>>
        where
            Self: 'a;
        fn nodes(&self) -> usize {
            Adjacency::nodes(self.g)
        }
        fn targets(&self, node: u32) -> Self::Targets<'_> {
            self.g.targets(node)
        }
        fn stretches(&self, nodes: std::ops::Range<u32>) -> Option<Vec<Stretch<'_>>> {
            let n = self.nodes() as u32;
            let bounds: Vec<u32> = [0]
                .into_iter()
                .chain(self.cuts.iter().copied())
                .chain([n])
                .collect();
            Some(
                bounds
                    .windows(2)
                    .map(|w| (w[0].max(nodes.start), w[1].min(nodes.end)))
                    .filter(|(a, b)| a < b)
                    .map(|(a, b)| Stretch {
                        first: a,
                        starts: &self.starts[a as usize..=b as usize],
                        targets: &self.g.targets,
                    })
                    .collect(),
            )
        }
    }

    /// The nodes with a path to one of `to`, by a search over the arcs
    /// reversed.
    fn reaching_by_search(g: &Csr<()>, to: &[u32]) -> Vec<u64> {
        let n = Adjacency::nodes(g);
        let mut into = vec![Vec::new(); n];
        for v in 0..n as u32 {
            for w in g.targets(v) {
                into[w as usize].push(v);
            }
        }
        let mut set = vec![0u64; n.div_ceil(64)];
        let mut next: Vec<u32> = to.to_vec();
        for &v in to {
            set_bit(&mut set, v);
        }
        while let Some(w) = next.pop() {
            for &v in &into[w as usize] {
                if !bit(&set, v) {
                    set_bit(&mut set, v);
                    next.push(v);
                }
            }
        }
        set
    }

    #[test]
    fn sweeps_over_every_node_by_words_node_by_node_or_by_stretches() {
        // sizes about a bitset word, and over the threshold of the sweeps
        // on several threads; stretches cut inside words and at their ends
        for (n, extra) in [
            (1u32, 0u32),
            (63, 20),
            (64, 30),
            (65, 40),
            (200, 60),
            (70_001, 9_000),
        ] {
            let g = random_graph(n, extra, 0x5eed ^ u64::from(n));
            let starts: Vec<u32> = g.offsets.iter().map(|&o| o as u32).collect();
            let cuts: Vec<Vec<u32>> = vec![
                Vec::new(),
                vec![n / 3, n / 3 + 1, (n / 2) & !63],
                vec![(n / 2).max(1)],
            ];
            // the root and a few nodes at every depth to reach
            let to: Vec<u32> = (0..n).filter(|v| v % 7 == 0 || *v == n - 1).collect();
            let want = reaching_by_search(&g, &to);
            let count = |set: &[u64]| set.iter().map(|w| u64::from(w.count_ones())).sum::<u64>();
            for first in [Direction::Up, Direction::Down] {
                for threads in 1..=3 {
                    for cut in &cuts {
                        let c = Cut {
                            g: &g,
                            starts: starts.clone(),
                            cuts: {
                                let mut c: Vec<u32> =
                                    cut.iter().copied().filter(|&x| x > 0 && x < n).collect();
                                c.sort_unstable();
                                c.dedup();
                                c
                            },
                        };
                        for by_stretches in [false, true] {
                            let mut reach = vec![0u64; (n as usize).div_ceil(64)];
                            for &v in &to {
                                set_bit(&mut reach, v);
                            }
                            // however many sweeps it takes
                            let (m, all) = (n as usize, u64::MAX);
                            let left = if by_stretches {
                                reaching_everywhere(&c, &mut reach, m, first, threads, all)
                            } else {
                                reaching_everywhere(&g, &mut reach, m, first, threads, all)
                            };
                            let what = format!("n {n}, {first:?}, {threads} threads, cut {cut:?}, by stretches {by_stretches}");
                            assert_eq!(left, Some(u64::from(n) - count(&want)), "{what}");
                            let wrong = reach.iter().zip(&want).position(|(a, b)| a != b);
                            assert_eq!(wrong, None, "{what}: the first word that differs");
                        }
                    }
                }
            }
        }
    }
}
