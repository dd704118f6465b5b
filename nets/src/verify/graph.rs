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
    let mut parent: HashMap<u32, u32> = HashMap::new();
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
                    n = parent[&n];
                    path.push(n);
                }
                path.reverse();
                return Some(path);
            }
            if w != from && allowed(w) && !parent.contains_key(&w) {
                parent.insert(w, v);
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
}
