use super::*;
use crate::verify::reference::explore_reference;

fn check_against_reference(net: &PtNet) {
    let reference = explore_reference(net, 1_000_000).expect("small net");
    let mut first = None;
    for threads in [1, 2, 3] {
        let e = explore(
            net,
            &Options {
                threads,
                parallel_from: 0,
                ..Options::default()
            },
        );
        let s = &e.summary;
        assert_eq!(s.completion, Completion::Complete);
        assert_eq!(
            (s.states, s.edges, s.dead_markings, s.max_tokens, s.safe),
            (
                reference.states,
                reference.edges,
                reference.dead_markings,
                reference.max_tokens,
                reference.safe
            ),
            "threads {threads}"
        );
        assert_eq!(
            e.deadlock_example().map(|p| p.len()),
            reference.deadlock_depth
        );
        assert_eq!(e.unsafe_example().map(|p| p.len()), reference.unsafe_depth);
        // the same counterexamples and loops whatever the threads (one
        // thread keeps the sample's run, whose successors come in another
        // order: compared from two threads on)
        let found = (e.deadlock_example(), e.unsafe_example(), e.loops(3));
        match &first {
            _ if threads == 1 => {}
            None => first = Some(found),
            Some(two) => assert_eq!(two, &found, "threads {threads}"),
        }
    }
}

/// A cycle of `n` places with one token, plus a sink transition at the end.
fn ring(n: usize) -> PtNet {
    let mut net = PtNet::new("ring");
    let ps: Vec<usize> = (0..n)
        .map(|i| net.add_place(format!("p{i}"), u32::from(i == 0)))
        .collect();
    for i in 0..n {
        net.add_transition(format!("t{i}"), &[(ps[i], 1)], &[(ps[(i + 1) % n], 1)]);
    }
    net
}

#[test]
fn a_ring_has_one_loop_and_no_deadlock() {
    let net = ring(5);
    check_against_reference(&net);
    let e = explore(&net, &Options::default());
    assert_eq!(e.summary.engine, Engine::Bits);
    let loops = e.loops(10);
    assert_eq!(loops.cyclic_components, 1);
    assert_eq!(loops.largest, 5);
    assert_eq!(loops.listed[0].prefix, Vec::<usize>::new());
    assert_eq!(
        e.names(&loops.listed[0].cycle),
        vec!["t0", "t1", "t2", "t3", "t4"]
    );
}

#[test]
fn an_unsafe_net_is_explored_with_counts() {
    // a -> t -> b, b twice: t produces into b while b may hold a token.
    let mut net = PtNet::new("unsafe");
    let a = net.add_place("a", 1);
    let b = net.add_place("b", 1);
    let c = net.add_place("c", 0);
    net.add_transition("fill", &[(a, 1)], &[(b, 1)]);
    net.add_transition("drain", &[(b, 2)], &[(c, 3)]);
    check_against_reference(&net);
    let e = explore(&net, &Options::default());
    assert_eq!(e.summary.engine, Engine::Counts8);
    assert!(!e.summary.safe);
    assert_eq!(e.summary.max_tokens, 3);
    assert_eq!(e.names(&e.unsafe_example().unwrap()), vec!["fill"]);
    assert_eq!(
        e.names(&e.deadlock_example().unwrap()),
        vec!["fill", "drain"]
    );
}

#[test]
fn wide_counts_and_the_limits() {
    // 300 tokens in a place: needs 16-bit counts.
    let mut net = PtNet::new("wide");
    let a = net.add_place("a", 0);
    let b = net.add_place("b", 0);
    let _ = net.add_place("src", 1);
    net.add_transition("gen", &[(2, 1)], &[(2, 1), (a, 1)]);
    net.add_transition("stop", &[(2, 1), (a, 300)], &[(b, 1)]);
    // unbounded: the state limit stops it
    let e = explore(
        &net,
        &Options {
            max_states: 1000,
            ..Options::default()
        },
    );
    assert_eq!(e.summary.completion, Completion::StateLimit);
    assert_eq!(e.summary.states, 1000);
    assert_eq!(e.summary.engine, Engine::Counts16);
    assert!(!e.summary.safe);
    // a count past u32
    let mut net = PtNet::new("huge");
    let a = net.add_place("a", u32::MAX - 1);
    net.add_transition("grow", &[(a, 1)], &[(a, 3)]);
    let e = explore(&net, &Options::default());
    assert_eq!(e.summary.completion, Completion::TokenLimit);
    assert_eq!(e.summary.engine, Engine::Counts32);
}

#[test]
fn transitions_that_never_fire_are_listed() {
    let mut net = ring(3);
    let p = net.add_place("never", 0);
    net.add_transition("stuck", &[(p, 1)], &[]);
    net.add_transition("heavy", &[(0, 2)], &[]);
    let e = explore(&net, &Options::default());
    assert_eq!(e.names(&e.summary.never_fired), vec!["stuck", "heavy"]);
}

/// The loops found over kept arcs are those found by firing again, on one
/// thread and on several.
fn same_loops_with_kept_arcs(net: &PtNet) {
    let again = explore(net, &Options::default()).loops(10);
    for threads in [1, 2, 3] {
        let e = explore(
            net,
            &Options {
                threads,
                parallel_from: 0,
                keep_arcs: true,
                ..Options::default()
            },
        );
        assert!(on_space!(&e.space, r => !r.arcs.is_empty()), "arcs kept");
        assert_eq!(e.loops(10), again, "threads {threads}");
    }
}

#[test]
fn kept_arcs_give_the_same_loops() {
    same_loops_with_kept_arcs(&ring(5));
    let mut net = ring(4);
    let p = net.add_place("side", 0);
    net.add_transition("out", &[(1, 1)], &[(p, 1)]);
    net.add_transition("back", &[(p, 1)], &[(2, 1)]);
    net.add_transition("stay", &[(p, 1)], &[(p, 1)]);
    same_loops_with_kept_arcs(&net);
    // a net whose initial marking is left for good: several components
    let mut net = PtNet::new("chain");
    let a = net.add_place("a", 2);
    let b = net.add_place("b", 0);
    let c = net.add_place("c", 0);
    net.add_transition("ab", &[(a, 1)], &[(b, 1)]);
    net.add_transition("bc", &[(b, 1)], &[(c, 1)]);
    net.add_transition("cb", &[(c, 1)], &[(b, 1)]);
    same_loops_with_kept_arcs(&net);
    // ... one of them a single marking with a loop to itself
    net.add_transition("idle", &[(a, 2)], &[(a, 2)]);
    same_loops_with_kept_arcs(&net);
    let e = explore(&net, &Options::default());
    assert_eq!(e.loops(10).cyclic_components, 3);
}

/// The breadth-first order the loop analysis sweeps in, filled from each
/// level's range of numbers, is the order of the markings level by level
/// (`level_ids`, partition after partition) in dense numbers: every
/// marking once, at its level, on one thread and on several.
#[test]
fn the_breadth_first_order_is_level_by_level() {
    // three independent rings of 5 places: 125 markings over 13 levels
    let mut net = PtNet::new("rings");
    for r in 0..3 {
        let ps: Vec<usize> = (0..5)
            .map(|i| net.add_place(format!("r{r}p{i}"), u32::from(i == 0)))
            .collect();
        for i in 0..5 {
            net.add_transition(format!("r{r}t{i}"), &[(ps[i], 1)], &[(ps[(i + 1) % 5], 1)]);
        }
    }
    for threads in [1, 2, 3] {
        let e = explore(
            &net,
            &Options {
                threads,
                parallel_from: 0,
                keep_arcs: true,
                ..Options::default()
            },
        );
        assert_eq!(e.summary.states, 125);
        on_space!(&e.space, r => {
            let offsets = r.offsets();
            let order = breadth_first_order(r, &offsets);
            let depths = r.levels.iter().map(Vec::len).max().unwrap_or(0);
            let by_ids: Vec<u32> = (0..depths)
                .flat_map(|k| r.level_ids(k))
                .map(|id| dense_of(&offsets, id))
                .collect();
            assert_eq!(order, by_ids, "threads {threads}");
            let mut sorted = order.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (0..125).collect::<Vec<u32>>(), "threads {threads}");
            // levels do not decrease along the order
            let levels: Vec<usize> = order.iter().map(|&v| r.level(id_of(&offsets, v))).collect();
            assert!(levels.windows(2).all(|w| w[0] <= w[1]), "threads {threads}");
            assert_eq!(levels.last().copied(), Some(12));
        });
    }
}

/// The cycle through the initial marking found from the levels is a
/// cycle, as short as a search finds, and the same markings whatever the
/// threads, where several are as short (two rings of three places share
/// the initial one's place, and a longer third).
#[test]
fn the_cycle_through_the_initial_marking_from_the_levels() {
    let mut net = PtNet::new("rings");
    let a = net.add_place("a", 1);
    let places: Vec<usize> = ["b1", "b2", "c1", "c2", "d1", "d2", "d3"]
        .iter()
        .map(|&n| net.add_place(n, 0))
        .collect();
    for ring in [&places[0..2], &places[2..4], &places[4..7]] {
        let mut from = a;
        for &p in ring {
            net.add_transition(format!("to{p}"), &[(from, 1)], &[(p, 1)]);
            from = p;
        }
        net.add_transition(format!("back{from}"), &[(from, 1)], &[(a, 1)]);
    }
    let mut first: Option<Vec<Vec<u8>>> = None;
    for threads in [1, 2, 3] {
        let e = explore(
            &net,
            &Options {
                threads,
                parallel_from: 0,
                keep_arcs: true,
                ..Options::default()
            },
        );
        on_space!(&e.space, r => {
            let kept = Kept { arcs: &r.arcs, offsets: r.offsets() };
            let initial = dense_of(&kept.offsets, r.level_ids(0).next().expect("a marking"));
            let cycle = cycle_through_initial(r, &net, &kept, initial).expect("a cycle");
            let searched = graph::shortest_cycle(&kept, initial, |_| true).expect("a cycle");
            assert_eq!(cycle.len(), 3);
            assert_eq!(cycle.len(), searched.len());
            assert_eq!(cycle[0], initial);
            for (i, &v) in cycle.iter().enumerate() {
                let next = cycle.get(i + 1).copied().unwrap_or(initial);
                assert!(kept.targets(v).any(|w| w == next), "an arc {v} -> {next}");
            }
            let markings: Vec<Vec<u8>> = cycle
                .iter()
                .map(|&v| r.marking(id_of(&kept.offsets, v)).to_vec())
                .collect();
            match &first {
                None => first = Some(markings),
                Some(one) => assert_eq!(one, &markings, "threads {threads}"),
            }
        });
    }
}
