//! State-space exploration speed on the two big Model Checking Contest nets
//! of `../shared/pnml/` (ParamProductionCell-PT-3: 1,465,206 states;
//! LamportFastMutEx-PT-4: 1,914,784 states), on one thread and on two.
//!
//! Baseline in the same run: the plain reference explorer
//! (`HashMap<Vec<u32>, _>` breadth-first search) on the same nets.
//! Before the timings, `main` prints the bytes stored per state and checks
//! the state counts.
//!
//! `explore_and_loops_*`: the whole analysis of `petrel check --pnml`
//! (exploration keeping its arcs, then the loops over them), beside
//! `bits_one_thread` / `bits_two_threads_by_hash` (exploration alone, as
//! `--no-loops`) in the same run.
//!
//! Run: `cargo bench -p nets --bench explore`

use std::path::{Path, PathBuf};

use divan::counter::ItemsCount;
use divan::Bencher;
use nets::verify::explore::{explore, Options};
use nets::verify::pnml::read_ptnet;
use nets::verify::ptnet::PtNet;
use nets::verify::reference::explore_reference;

const NETS: [(&str, u64); 2] = [
    ("ParamProductionCell-PT-3", 1_465_206),
    ("LamportFastMutEx-PT-4", 1_914_784),
];

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/pnml")
}

fn load(name: &str) -> Option<PtNet> {
    let text = std::fs::read_to_string(dir().join(format!("{name}.pnml"))).ok()?;
    read_ptnet(&text).ok()
}

fn main() {
    if load(NETS[0].0).is_none() {
        eprintln!(
            "SKIPPED: {} not found; nothing to benchmark",
            dir().display()
        );
        return;
    }
    for (name, states) in NETS {
        let Some(net) = load(name) else { continue };
        for threads in [1, 2] {
            let x = explore(
                &net,
                &Options {
                    threads,
                    ..Options::default()
                },
            );
            assert_eq!(x.summary.states, states, "{name}");
            println!(
                "{name}: {} states, {} threads: {:.1} bytes per stored state ({} bytes)",
                x.summary.states,
                threads,
                x.summary.stored_bytes as f64 / x.summary.states as f64,
                x.summary.stored_bytes
            );
            let kept = explore(
                &net,
                &Options {
                    threads,
                    keep_arcs: true,
                    ..Options::default()
                },
            );
            println!(
                "{name}: {} threads, arcs kept: {:.1} bytes per state more ({} bytes)",
                threads,
                kept.summary.arc_bytes as f64 / kept.summary.states as f64,
                kept.summary.arc_bytes
            );
        }
    }
    divan::main();
}

fn bench(bencher: Bencher, name: &str, states: u64, threads: usize, partition_by_places: bool) {
    let Some(net) = load(name) else { return };
    bencher.counter(ItemsCount::new(states)).bench(|| {
        let x = explore(
            &net,
            &Options {
                threads,
                partition_by_places,
                ..Options::default()
            },
        );
        assert_eq!(x.summary.states, states);
        x.summary.edges
    });
}

#[divan::bench(args = NETS, sample_count = 10, sample_size = 1)]
fn bits_one_thread(bencher: Bencher, net: (&str, u64)) {
    bench(bencher, net.0, net.1, 1, true);
}

#[divan::bench(args = NETS, sample_count = 10, sample_size = 1)]
fn bits_two_threads(bencher: Bencher, net: (&str, u64)) {
    bench(bencher, net.0, net.1, 2, true);
}

/// Two threads, markings split by hash (half the successors cross).
#[divan::bench(args = NETS, sample_count = 10, sample_size = 1)]
fn bits_two_threads_by_hash(bencher: Bencher, net: (&str, u64)) {
    bench(bencher, net.0, net.1, 2, false);
}

/// The baseline: the plain `HashMap<Vec<u32>, _>` breadth-first search.
#[divan::bench(args = NETS, sample_count = 2, sample_size = 1)]
fn reference_baseline(bencher: Bencher, net: (&str, u64)) {
    let Some(pt) = load(net.0) else { return };
    bencher.counter(ItemsCount::new(net.1)).bench(|| {
        let r = explore_reference(&pt, usize::MAX);
        assert_eq!(r.map(|r| r.states), Some(net.1));
    });
}

fn bench_with_loops(bencher: Bencher, name: &str, states: u64, threads: usize) {
    let Some(net) = load(name) else { return };
    bencher.counter(ItemsCount::new(states)).bench(|| {
        let x = explore(
            &net,
            &Options {
                threads,
                keep_arcs: true,
                ..Options::default()
            },
        );
        assert_eq!(x.summary.states, states);
        x.loops(5).cyclic_components
    });
}

/// Exploration keeping its arcs, then the loops (as `petrel check`).
#[divan::bench(args = NETS, sample_count = 10, sample_size = 1)]
fn explore_and_loops_one_thread(bencher: Bencher, net: (&str, u64)) {
    bench_with_loops(bencher, net.0, net.1, 1);
}

#[divan::bench(args = NETS, sample_count = 10, sample_size = 1)]
fn explore_and_loops_two_threads(bencher: Bencher, net: (&str, u64)) {
    bench_with_loops(bencher, net.0, net.1, 2);
}
