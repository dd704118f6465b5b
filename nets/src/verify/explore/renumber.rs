//! The markings of an exploration on several threads numbered again in
//! breadth-first order, with their kept arcs laid out in that order.
//!
//! Each thread stores its partition's markings level by level, but within
//! a level in the order they reached it: first the successors of its own
//! markings, then those the other threads sent. After a few levels the
//! markings close in breadth-first order are spread over the whole level
//! of both partitions, and so are their arcs: the loop analysis, which
//! follows the arcs (a breadth-first search) and sweeps the nodes with a
//! bitset, reads memory at random where, after one thread, it read it
//! nearly in order (BENCHMARKS.md, stop 29: 2.8 times as long a search).
//!
//! One breadth-first pass over the kept arcs from the initial marking
//! gives every marking the number the one-thread exploration would have
//! given it (arcs are kept in firing order on any number of threads), and
//! copies each marking's arcs, in the new numbers, after the previous
//! one's.

use super::edges::Edges;
use super::engine::split_id;

/// Not numbered yet.
const UNSET: u32 = u32::MAX;

/// How far ahead in the queue the pass asks for the arcs it will copy.
const AHEAD: usize = 8;

/// The arcs in breadth-first numbers and, for each number, the state id
/// of its marking.
pub struct Renumbered {
    pub arcs: Edges,
    pub ids: Vec<u32>,
}

/// Numbers the markings of `arcs` (one [`Edges`] per partition, successors
/// as state ids, all answered; `sizes[p]` markings in partition `p`) in
/// breadth-first order from `initial`. `None` when an arc names no
/// marking, or some marking is not reached.
pub fn renumber(arcs: &[Edges], sizes: &[u32], initial: u32) -> Option<Renumbered> {
    let total: usize = sizes.iter().map(|&s| s as usize).sum();
    let arc_count: usize = arcs.iter().map(Edges::arc_count).sum();
    let mut new_of: Vec<Vec<u32>> = sizes.iter().map(|&s| vec![UNSET; s as usize]).collect();
    let (p0, l0) = split_id(initial);
    *new_of.get_mut(p0)?.get_mut(l0 as usize)? = 0;
    let mut ids: Vec<u32> = Vec::with_capacity(total);
    ids.push(initial);
    let mut starts: Vec<u32> = Vec::with_capacity(total + 1);
    starts.push(0);
    let mut targets: Vec<u32> = Vec::with_capacity(arc_count);
    let mut to_first = false;
    let mut head = 0;
    while let Some(&id) = ids.get(head) {
        // the queue's markings are spread over the partitions: load the
        // ones ahead in two steps (where their arcs start, then these)
        if let Some(&u) = ids.get(head + 2 * AHEAD) {
            let (p, l) = split_id(u);
            arcs.get(p)?.prefetch_start(l);
        }
        if let Some(&u) = ids.get(head + AHEAD) {
            let (p, l) = split_id(u);
            arcs.get(p)?.prefetch_targets(l);
        }
        head += 1;
        let (p, l) = split_id(id);
        for &t in arcs.get(p)?.targets_checked(l)? {
            let (q, m) = split_id(t);
            let slot = new_of.get_mut(q)?.get_mut(m as usize)?;
            if *slot == UNSET {
                *slot = ids.len() as u32;
                ids.push(t);
            }
            to_first |= *slot == 0;
            targets.push(*slot);
        }
        starts.push(targets.len() as u32);
    }
    (ids.len() == total).then(|| Renumbered {
        arcs: Edges::from_lists(starts, targets, to_first),
        ids,
    })
}

#[cfg(test)]
mod tests {
    use super::super::edges::PENDING;
    use super::super::engine::state_id;
    use super::*;
    use proptest::prelude::*;

    /// Partitions' arcs from successor lists of (partition, index) pairs.
    fn partitions(lists: &[Vec<Vec<(usize, u32)>>]) -> Vec<Edges> {
        lists
            .iter()
            .map(|part| {
                let mut e = Edges::new();
                for l in part {
                    e.node(l.len() as u32);
                    for &(q, i) in l {
                        e.push(state_id(q, i));
                    }
                }
                e
            })
            .collect()
    }

    #[test]
    fn breadth_first_numbers_and_arcs_in_order() {
        // partition 0: a0 -> b1, a1; a1 -> b0; partition 1: b0 -> a0; b1 -> a1, b0
        let arcs = partitions(&[
            vec![vec![(1, 1), (0, 1)], vec![(1, 0)]],
            vec![vec![(0, 0)], vec![(0, 1), (1, 0)]],
        ]);
        let r = renumber(&arcs, &[2, 2], state_id(0, 0)).expect("all reached");
        // a0 = 0, then its successors in firing order: b1 = 1, a1 = 2, then
        // b1's new successor b0 = 3
        assert_eq!(
            r.ids,
            vec![
                state_id(0, 0),
                state_id(1, 1),
                state_id(0, 1),
                state_id(1, 0)
            ]
        );
        assert_eq!(r.arcs.targets(0), &[1, 2]);
        assert_eq!(r.arcs.targets(1), &[2, 3]);
        assert_eq!(r.arcs.targets(2), &[3]);
        assert_eq!(r.arcs.targets(3), &[0]);
        assert!(r.arcs.leads_to_first(0));
    }

    #[test]
    fn unreached_markings_or_stray_ids_number_nothing() {
        // b0 is never reached
        let arcs = partitions(&[vec![vec![(0, 0)]], vec![vec![]]]);
        assert!(renumber(&arcs, &[1, 1], state_id(0, 0)).is_none());
        // an arc to a marking past the partition's end
        let arcs = partitions(&[vec![vec![(1, 3)]], vec![vec![]]]);
        assert!(renumber(&arcs, &[1, 1], state_id(0, 0)).is_none());
        // an arc never answered
        let mut e = Edges::new();
        e.node(1);
        e.push(PENDING);
        assert!(renumber(&[e], &[1], state_id(0, 0)).is_none());
    }

    proptest! {
        /// Any graph whose nodes are all reached, spread over any number
        /// of partitions: the new numbers are a breadth-first order (each
        /// node numbered after the node that first reaches it), and each
        /// node's arcs are its old arcs, in order, in the new numbers.
        #[test]
        fn the_same_graph_in_breadth_first_numbers(
            parts in 1usize..=4,
            n in 1u32..60,
            extra in prop::collection::vec((0u32..1000, 0u32..1000), 0..120),
            parents in prop::collection::vec(0u32..1000, 60),
            homes in prop::collection::vec(0usize..4, 60),
        ) {
            // node v > 0 is reached from an earlier node; extra arcs anywhere
            let mut succ: Vec<Vec<u32>> = vec![Vec::new(); n as usize];
            for v in 1..n {
                succ[(parents[v as usize] % v) as usize].push(v);
            }
            for &(a, b) in &extra {
                succ[(a % n) as usize].push(b % n);
            }
            // node v lives in partition homes[v] (node 0 in partition 0),
            // in increasing order there
            let home = |v: u32| if v == 0 { 0 } else { homes[v as usize] % parts };
            let mut local = vec![0u32; n as usize];
            let mut sizes = vec![0u32; parts];
            for v in 0..n {
                local[v as usize] = sizes[home(v)];
                sizes[home(v)] += 1;
            }
            let mut lists: Vec<Vec<Vec<(usize, u32)>>> = vec![Vec::new(); parts];
            for v in 0..n {
                let l = succ[v as usize].iter().map(|&w| (home(w), local[w as usize])).collect();
                lists[home(v)].push(l);
            }
            let arcs = partitions(&lists);
            let r = renumber(&arcs, &sizes, state_id(0, 0));
            let r = r.expect("every node is reached from node 0");
            let old = |id: u32| {
                let (q, i) = split_id(id);
                (0..n).find(|&v| home(v) == q && local[v as usize] == i).unwrap_or(u32::MAX)
            };
            // the nodes come in the order the arcs, read in the new
            // order, first reach them: 1, 2, 3...
            let mut seen = vec![false; n as usize];
            seen[0] = true;
            let mut next = 1u32;
            for u in 0..n {
                let want: Vec<u32> = succ[old(r.ids[u as usize]) as usize].clone();
                let got: Vec<u32> = r.arcs.targets(u).iter().map(|&w| old(r.ids[w as usize])).collect();
                prop_assert_eq!(got, want);
                for &w in r.arcs.targets(u) {
                    if !seen[w as usize] {
                        seen[w as usize] = true;
                        prop_assert_eq!(w, next);
                        next += 1;
                    }
                }
            }
            prop_assert_eq!(next, n);
        }
    }
}
