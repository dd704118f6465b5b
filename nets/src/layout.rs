//! A readable, stable drawing of one net: layered left to right (Sugiyama
//! style), for `petrel draw --svg` and the monitor. Pure and deterministic:
//! the layout depends only on the net's structure, never on its marking, so
//! a drawing never moves while the net runs.
//!
//! 1. Cycles are broken by a depth-first search from the initial places
//!    (then the rest in declaration order): the arcs it finds going back are
//!    laid out reversed and drawn as they are.
//! 2. Layers by longest path, so every other arc goes left to right.
//! 3. Arcs spanning several layers pass through invisible bends.
//! 4. Crossings reduced by barycentre sweeps (down and up, the best
//!    ordering kept), ties kept in declaration order.
//! 5. Coordinates: one column per layer, each column centred.

use crate::model::{NetId, PlaceRef, Project, TransitionId};

/// Horizontal distance between layers.
pub const LAYER_GAP: f64 = 110.0;
/// Vertical distance between neighbours in a layer.
pub const ROW_GAP: f64 = 64.0;
/// Margin around the drawing.
pub const MARGIN: f64 = 40.0;
/// The share of a row next to a bend.
const BEND_ROW: f64 = 0.3;

/// Barycentre sweeps (each a down and an up pass).
const SWEEPS: usize = 12;

/// What a laid-out node stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Node {
    Place(PlaceRef),
    Transition(TransitionId),
    /// A bend of an arc spanning several layers.
    Bend,
}

/// A node and where it goes.
#[derive(Debug, Clone, PartialEq)]
pub struct Placed {
    pub node: Node,
    pub layer: usize,
    pub x: f64,
    pub y: f64,
}

/// An arc of the net, as drawn: from its source to its target through
/// its bends.
#[derive(Debug, Clone, PartialEq)]
pub struct ArcPath {
    /// Index into [`Layout::nodes`].
    pub from: usize,
    pub to: usize,
    /// Place to transition (an input) or transition to place (an output).
    pub input: bool,
    /// Laid out against the flow: the arc closes a cycle.
    pub back: bool,
    /// From the source's centre to the target's, bends included.
    pub points: Vec<(f64, f64)>,
}

/// A net laid out.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// The places (its own, then the global places it uses, in first use
    /// order), then its transitions, then the bends.
    pub nodes: Vec<Placed>,
    pub arcs: Vec<ArcPath>,
    pub width: f64,
    pub height: f64,
    /// Arc crossings between neighbouring layers, as laid out.
    pub crossings: usize,
    /// The same count for the declaration order, before the sweeps.
    pub crossings_before: usize,
}

/// A net's structure, all a layout depends on: which of its own places are
/// initially marked, and each transition's input and output places
/// (`PlaceRef::Global(g)` for global place `g`). A net being edited is laid
/// out from this even while it does not load.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Shape {
    /// One entry per local place: initially marked.
    pub initial: Vec<bool>,
    /// One entry per transition: (inputs, outputs).
    pub transitions: Vec<(Vec<PlaceRef>, Vec<PlaceRef>)>,
}

/// Lays out net `net` of `project`.
pub fn layout(project: &Project, net: NetId) -> Layout {
    let n = &project.nets[net];
    layout_shape(&Shape {
        initial: n.places.iter().map(|p| p.initial).collect(),
        transitions: n
            .transitions
            .iter()
            .map(|t| (t.inputs.to_vec(), t.outputs.to_vec()))
            .collect(),
    })
}

/// Lays out a net given by its structure alone.
pub fn layout_shape(shape: &Shape) -> Layout {
    // Nodes: local places, globals used, transitions.
    let mut places: Vec<PlaceRef> = (0..shape.initial.len()).map(PlaceRef::Local).collect();
    for (inputs, outputs) in &shape.transitions {
        for p in inputs.iter().chain(outputs) {
            if matches!(p, PlaceRef::Global(_)) && !places.contains(p) {
                places.push(*p);
            }
        }
    }
    let index_of = |p: &PlaceRef| places.iter().position(|q| q == p).unwrap_or(0);
    let mut nodes: Vec<Node> = places.iter().copied().map(Node::Place).collect();
    let first_transition = nodes.len();
    nodes.extend((0..shape.transitions.len()).map(Node::Transition));
    let real = nodes.len();
    // Arcs of the net: (from, to, input).
    let mut arcs: Vec<(usize, usize, bool)> = Vec::new();
    for (ti, (inputs, outputs)) in shape.transitions.iter().enumerate() {
        let tn = first_transition + ti;
        for p in inputs {
            arcs.push((index_of(p), tn, true));
        }
        for p in outputs {
            arcs.push((tn, index_of(p), false));
        }
    }
    let back = back_arcs(real, &arcs, |i| match nodes[i] {
        Node::Place(PlaceRef::Local(p)) => shape.initial.get(p).copied().unwrap_or(false),
        _ => false,
    });
    // The acyclic orientation, and layers by longest path.
    let oriented: Vec<(usize, usize)> = arcs
        .iter()
        .zip(&back)
        .map(|(&(a, b, _), &r)| if r { (b, a) } else { (a, b) })
        .collect();
    let mut layer = longest_path(real, &oriented);
    // Bends for arcs spanning several layers.
    let mut chains: Vec<Vec<usize>> = Vec::with_capacity(arcs.len());
    for &(a, b) in &oriented {
        let mut chain = vec![a];
        let (la, lb) = (layer[a], layer[b]);
        for l in la + 1..lb {
            nodes.push(Node::Bend);
            layer.push(l);
            chain.push(nodes.len() - 1);
        }
        chain.push(b);
        chains.push(chain);
    }
    let layers_count = layer.iter().max().map_or(0, |m| m + 1);
    let mut layers: Vec<Vec<usize>> = vec![Vec::new(); layers_count];
    for (v, &l) in layer.iter().enumerate() {
        layers[l].push(v);
    }
    // Segments between neighbouring layers, oriented left to right.
    let segments: Vec<(usize, usize)> = chains
        .iter()
        .flat_map(|c| c.windows(2).map(|w| (w[0], w[1])))
        .filter(|(a, b)| a != b)
        .collect();
    let crossings_before = count_crossings(&layers, &segments, nodes.len());
    let (layers, crossings) = order(layers, &segments, nodes.len(), crossings_before);
    // Coordinates: a full row between two nodes, a narrow one next to a
    // bend (bends are thin: they must not stretch a column).
    let gap = |a: usize, b: usize| {
        if nodes[a] == Node::Bend || nodes[b] == Node::Bend {
            ROW_GAP * BEND_ROW
        } else {
            ROW_GAP
        }
    };
    // Offsets down a column, from 0: two real nodes stay a full row apart
    // whatever bends lie between them.
    let offsets = |column: &[usize]| -> Vec<f64> {
        let mut out = Vec::with_capacity(column.len());
        let mut last_real: Option<f64> = None;
        for (i, &v) in column.iter().enumerate() {
            let mut y: f64 = if i == 0 {
                0.0
            } else {
                out[i - 1] + gap(column[i - 1], v)
            };
            if nodes[v] != Node::Bend {
                if let Some(r) = last_real {
                    y = y.max(r + ROW_GAP);
                }
                last_real = Some(y);
            }
            out.push(y);
        }
        out
    };
    let columns: Vec<Vec<f64>> = layers.iter().map(|c| offsets(c)).collect();
    let tallest = columns
        .iter()
        .filter_map(|c| c.last().copied())
        .fold(0.0, f64::max);
    let height = MARGIN * 2.0 + tallest;
    let width = MARGIN * 2.0 + (layers_count.saturating_sub(1)) as f64 * LAYER_GAP;
    let mut xy = vec![(0.0, 0.0); nodes.len()];
    for (l, column) in layers.iter().enumerate() {
        let span = columns[l].last().copied().unwrap_or(0.0);
        let top = (height - span) / 2.0;
        for (i, &v) in column.iter().enumerate() {
            xy[v] = (MARGIN + l as f64 * LAYER_GAP, top + columns[l][i]);
        }
    }
    let placed: Vec<Placed> = nodes
        .iter()
        .enumerate()
        .map(|(v, &node)| Placed {
            node,
            layer: layer[v],
            x: xy[v].0,
            y: xy[v].1,
        })
        .collect();
    let paths = arcs
        .iter()
        .zip(&back)
        .zip(&chains)
        .map(|((&(from, to, input), &back), chain)| {
            let mut points: Vec<(f64, f64)> = chain.iter().map(|&v| xy[v]).collect();
            if back {
                points.reverse();
            }
            ArcPath {
                from,
                to,
                input,
                back,
                points,
            }
        })
        .collect();
    Layout {
        nodes: placed,
        arcs: paths,
        width,
        height,
        crossings,
        crossings_before,
    }
}

/// Which arcs close a cycle, found by an iterative depth-first search from
/// the roots `root` says (then every other node), in index order.
fn back_arcs(
    nodes: usize,
    arcs: &[(usize, usize, bool)],
    root: impl Fn(usize) -> bool,
) -> Vec<bool> {
    let mut out_arcs: Vec<Vec<usize>> = vec![Vec::new(); nodes];
    for (i, &(a, _, _)) in arcs.iter().enumerate() {
        out_arcs[a].push(i);
    }
    // 0 unseen, 1 on the stack, 2 done.
    let mut state = vec![0u8; nodes];
    let mut back = vec![false; arcs.len()];
    let starts: Vec<usize> = (0..nodes)
        .filter(|&v| root(v))
        .chain((0..nodes).filter(|&v| !root(v)))
        .collect();
    for s in starts {
        if state[s] != 0 {
            continue;
        }
        let mut stack: Vec<(usize, usize)> = vec![(s, 0)];
        state[s] = 1;
        while let Some(top) = stack.last_mut() {
            let (v, next) = *top;
            if let Some(&arc) = out_arcs[v].get(next) {
                top.1 += 1;
                let w = arcs[arc].1;
                match state[w] {
                    0 => {
                        state[w] = 1;
                        stack.push((w, 0));
                    }
                    1 => back[arc] = true,
                    _ => {}
                }
            } else {
                state[v] = 2;
                stack.pop();
            }
        }
    }
    back
}

/// Longest-path layers of an acyclic graph (every arc `a → b` gets
/// `layer[b] > layer[a]`); ties and sources in index order.
fn longest_path(nodes: usize, arcs: &[(usize, usize)]) -> Vec<usize> {
    let mut indegree = vec![0usize; nodes];
    let mut out: Vec<Vec<usize>> = vec![Vec::new(); nodes];
    for &(a, b) in arcs {
        if a != b {
            indegree[b] += 1;
            out[a].push(b);
        }
    }
    let mut layer = vec![0usize; nodes];
    let mut ready: std::collections::BTreeSet<usize> =
        (0..nodes).filter(|&v| indegree[v] == 0).collect();
    while let Some(v) = ready.pop_first() {
        for &w in &out[v] {
            layer[w] = layer[w].max(layer[v] + 1);
            indegree[w] -= 1;
            if indegree[w] == 0 {
                ready.insert(w);
            }
        }
    }
    layer
}

/// Crossings between neighbouring layers for `segments` (each from a layer
/// to the next).
fn count_crossings(layers: &[Vec<usize>], segments: &[(usize, usize)], nodes: usize) -> usize {
    let mut pos = vec![0usize; nodes];
    let mut layer_of = vec![0usize; nodes];
    for (l, column) in layers.iter().enumerate() {
        for (i, &v) in column.iter().enumerate() {
            pos[v] = i;
            layer_of[v] = l;
        }
    }
    let mut by_layer: Vec<Vec<(usize, usize)>> = vec![Vec::new(); layers.len()];
    for &(a, b) in segments {
        by_layer[layer_of[a]].push((pos[a], pos[b]));
    }
    by_layer
        .iter()
        .map(|s| {
            let mut n = 0;
            for (i, &(a1, b1)) in s.iter().enumerate() {
                for &(a2, b2) in &s[i + 1..] {
                    if (a1 < a2 && b1 > b2) || (a1 > a2 && b1 < b2) {
                        n += 1;
                    }
                }
            }
            n
        })
        .sum()
}

/// Barycentre sweeps; the ordering with the fewest crossings wins (the
/// first found among equals).
fn order(
    mut layers: Vec<Vec<usize>>,
    segments: &[(usize, usize)],
    nodes: usize,
    crossings: usize,
) -> (Vec<Vec<usize>>, usize) {
    let mut pred: Vec<Vec<usize>> = vec![Vec::new(); nodes];
    let mut succ: Vec<Vec<usize>> = vec![Vec::new(); nodes];
    for &(a, b) in segments {
        succ[a].push(b);
        pred[b].push(a);
    }
    let mut best = (layers.clone(), crossings);
    for _ in 0..SWEEPS {
        for down in [true, false] {
            let range: Vec<usize> = if down {
                (1..layers.len()).collect()
            } else {
                (0..layers.len().saturating_sub(1)).rev().collect()
            };
            for l in range {
                let fixed = if down { l - 1 } else { l + 1 };
                let mut pos = vec![0usize; nodes];
                for (i, &v) in layers[fixed].iter().enumerate() {
                    pos[v] = i;
                }
                let neighbours = if down { &pred } else { &succ };
                let mut keyed: Vec<(f64, usize, usize)> = layers[l]
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| {
                        let ns = &neighbours[v];
                        let bary = if ns.is_empty() {
                            i as f64
                        } else {
                            ns.iter().map(|&w| pos[w] as f64).sum::<f64>() / ns.len() as f64
                        };
                        (bary, i, v)
                    })
                    .collect();
                keyed.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                layers[l] = keyed.into_iter().map(|(_, _, v)| v).collect();
            }
            let c = count_crossings(&layers, segments, nodes);
            if c < best.1 {
                best = (layers.clone(), c);
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(net: &str) -> Project {
        crate::load(&[
            (
                "project.toml",
                "[[net]]\nfile = \"n.toml\"\nactive = true\n",
            ),
            ("n.toml", net),
        ])
        .unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn a_cycle_is_broken_once_and_every_other_arc_goes_left_to_right() {
        let p = one("name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n\
             [[transition]]\nname = \"go\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"x\"\n\
             [[transition]]\nname = \"back\"\nfrom = [\"b\"]\nto = [\"a\"]\non = \"y\"\n");
        let l = layout(&p, 0);
        assert_eq!(l.arcs.iter().filter(|a| a.back).count(), 1);
        for a in &l.arcs {
            let (first, last) = (a.points[0], a.points[a.points.len() - 1]);
            assert_eq!(first, (l.nodes[a.from].x, l.nodes[a.from].y));
            assert_eq!(last, (l.nodes[a.to].x, l.nodes[a.to].y));
            if !a.back {
                assert!(first.0 < last.0, "{a:?}");
            }
        }
        // The initial place comes first.
        assert_eq!(l.nodes[0].layer, 0);
    }

    #[test]
    fn a_fork_written_crossed_is_drawn_without_crossings() {
        // a → t1 → {b, c}; b → t2 → d; c → t3 → e, with t3 declared before
        // t2 so that the declaration order crosses.
        let p = one(
            "name = \"N\"\nplaces = [\"a\", \"e\", \"d\", \"b\", \"c\"]\ninitial = [\"a\"]\n\
             [[transition]]\nname = \"t1\"\nfrom = [\"a\"]\nto = [\"b\", \"c\"]\non = \"x\"\n\
             [[transition]]\nname = \"t3\"\nfrom = [\"c\"]\nto = [\"e\"]\non = \"y\"\n\
             [[transition]]\nname = \"t2\"\nfrom = [\"b\"]\nto = [\"d\"]\non = \"z\"\n",
        );
        let l = layout(&p, 0);
        assert_eq!(l.crossings, 0);
        assert!(l.crossings <= l.crossings_before);
        // No two nodes at one spot; layout is the same every time.
        for (i, a) in l.nodes.iter().enumerate() {
            for b in &l.nodes[i + 1..] {
                assert!((a.x, a.y) != (b.x, b.y), "{a:?} {b:?}");
            }
        }
        assert_real_nodes_a_row_apart(&l);
        assert_eq!(layout(&p, 0), l);
    }

    fn assert_real_nodes_a_row_apart(l: &Layout) {
        let real: Vec<&Placed> = l.nodes.iter().filter(|n| n.node != Node::Bend).collect();
        for (i, a) in real.iter().enumerate() {
            for b in &real[i + 1..] {
                if a.layer == b.layer {
                    assert!((a.y - b.y).abs() >= ROW_GAP - 1e-9, "{a:?} {b:?}");
                }
            }
        }
    }

    #[test]
    fn the_examples_nets_are_drawn_with_no_overlap_and_fewer_crossings() {
        for example in ["uav-flight-test", "uav-survey"] {
            let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../examples")
                .join(example);
            let mut files = std::collections::BTreeMap::new();
            for entry in std::fs::read_dir(&dir).expect("example folder").flatten() {
                let path = entry.path();
                if path.extension().is_some_and(|e| e == "toml") {
                    let name = path
                        .file_name()
                        .expect("name")
                        .to_string_lossy()
                        .into_owned();
                    files.insert(name, std::fs::read_to_string(&path).expect("read"));
                }
            }
            let p = crate::load(&files).unwrap_or_else(|e| panic!("{example}: {e}"));
            for net in 0..p.nets.len() {
                let l = layout(&p, net);
                assert_real_nodes_a_row_apart(&l);
                assert!(
                    l.crossings <= l.crossings_before,
                    "{example} {}",
                    p.nets[net].name
                );
                assert_eq!(layout(&p, net), l, "stable");
            }
        }
    }

    #[test]
    fn long_arcs_bend_through_every_layer_they_span() {
        let p = one(
            "name = \"N\"\nplaces = [\"a\", \"b\", \"c\"]\ninitial = [\"a\"]\n\
             [[transition]]\nname = \"t1\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"x\"\n\
             [[transition]]\nname = \"t2\"\nfrom = [\"b\"]\nto = [\"c\"]\non = \"y\"\n\
             [[transition]]\nname = \"skip\"\nfrom = [\"a\"]\nto = [\"c\"]\non = \"z\"\n",
        );
        let l = layout(&p, 0);
        for a in &l.arcs {
            for w in a.points.windows(2) {
                assert!((w[1].0 - w[0].0 - LAYER_GAP).abs() < 1e-9, "{a:?}");
            }
        }
        assert!(l.nodes.iter().any(|n| n.node == Node::Bend));
    }
}
