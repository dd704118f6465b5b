//! The team verifier (issue 16): the paper's two-robot bottleneck
//! (`examples/ugv-bottleneck`) and the same nets with four robots
//! (`tests/fixtures/ugv4`), and the small team fixtures
//! (`tests/fixtures/team`, `tests/fixtures/team4`), each checked whole
//! (`each_net`, `alone`) with every reduction, with each alone and with
//! none, on one thread.
//!
//! Baselines in the same run: the single-vehicle project check of the team
//! fixture's MOVE net (one robot, no team net), and the P/T explorer's
//! states/s on ParamProductionCell-PT-3 (`../shared/pnml`, 1,465,206
//! states, one thread) beside the project explorer's.
//!
//! Before the timings, `main` runs each configuration in a child process
//! of its own and prints its states, steps, the reductions that ran, its
//! wall and CPU time, states/s of CPU and the child's peak resident memory
//! (VmHWM), idle then with the other core busy (a spinning thread); then
//! divan times the small ones, idle and with the other core busy.
//!
//! Run: `cargo bench -p nets --bench team`
//! One configuration's figures: `PETREL_TEAM_BENCH_CONFIG=N` on the bench
//! binary (N as listed), `PETREL_TEAM_BENCH_BUSY=1` with a core busy.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use divan::Bencher;
use nets::verify::project::{check, Options, ProjectReport, Proviso};
use nets::Project;

use petrel_test_support::busy;
use petrel_test_support::proc;

/// A configuration: name, fixture, symmetry, partial order (with the
/// default cycle proviso, after the search: [`Proviso::Components`]).
type Config = (&'static str, &'static str, bool, bool);

/// The configurations run again with the levels' cycle proviso (during
/// the search), for comparison: by name, in [`CONFIGS`].
const LEVELS: [&str; 4] = [
    "ugv, 2, partial order",
    "ugv, 2, both",
    "ugv, 4, partial order",
    "ugv, 4, both",
];

const CONFIGS: [Config; 17] = [
    ("one robot (baseline)", "one", false, false),
    ("team, 2, no reduction", "team", false, false),
    ("team, 2, symmetry", "team", true, false),
    ("team, 2, partial order", "team", false, true),
    ("team, 2, both", "team", true, true),
    ("team, 4, no reduction", "team4", false, false),
    ("team, 4, symmetry", "team4", true, false),
    ("team, 4, partial order", "team4", false, true),
    ("team, 4, both", "team4", true, true),
    ("ugv, 2, no reduction", "ugv", false, false),
    ("ugv, 2, symmetry", "ugv", true, false),
    ("ugv, 2, partial order", "ugv", false, true),
    ("ugv, 2, both", "ugv", true, true),
    ("ugv, 4, no reduction", "ugv4", false, false),
    ("ugv, 4, symmetry", "ugv4", true, false),
    ("ugv, 4, partial order", "ugv4", false, true),
    ("ugv, 4, both", "ugv4", true, true),
];

fn folder(name: &str) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    match name {
        "one" | "team" => root.join("tests/fixtures/team"),
        "ugv" => root.join("../examples/ugv-bottleneck"),
        other => root.join("tests/fixtures").join(other),
    }
}

fn fixture(name: &str) -> Arc<Project> {
    let dir = folder(name);
    let mut files = BTreeMap::new();
    let entries = std::fs::read_dir(&dir).expect("fixture folder");
    for entry in entries.flatten() {
        let file = entry.file_name().to_string_lossy().into_owned();
        if file.ends_with(".toml") && file != "profile.toml" {
            let text = std::fs::read_to_string(entry.path()).expect("fixture file");
            files.insert(file, text);
        }
    }
    if name == "one" {
        // One robot, MOVE only: the single-vehicle check of the same net.
        let project = &files["project.toml"];
        let start = project.find("[[vehicle]]\nname = \"R2\"").expect("R2");
        let end = project.find("[programs").expect("programs");
        let mut project = project.clone();
        project.replace_range(start..end, "");
        project = project.replace("[[net]]\nfile = \"watch.toml\"\nactive = true\n", "");
        files.insert("project.toml".to_owned(), project);
        files.remove("watch.toml");
    }
    Arc::new(nets::load(&files).unwrap_or_else(|e| panic!("{e:?}")))
}

fn options(symmetry: bool, partial_order: bool) -> Options<'static> {
    options_with(symmetry, partial_order, Proviso::default())
}

fn options_with(symmetry: bool, partial_order: bool, proviso: Proviso) -> Options<'static> {
    let max_states = std::env::var("PETREL_TEAM_BENCH_MAX")
        .ok()
        .and_then(|m| m.parse().ok())
        .unwrap_or(Options::default().max_states);
    Options {
        symmetry,
        partial_order,
        max_states,
        proviso,
        ..Options::default()
    }
}

/// Configuration `config`: one of [`CONFIGS`], then those of [`LEVELS`].
fn run(config: usize) -> ProjectReport {
    let (i, proviso) = match config.checked_sub(CONFIGS.len()) {
        None => (config, Proviso::Components),
        Some(k) => (config_index(LEVELS[k]), Proviso::Levels),
    };
    let (_, name, symmetry, partial_order) = CONFIGS[i];
    check(
        &fixture(name),
        &options_with(symmetry, partial_order, proviso),
    )
}

fn config_index(name: &str) -> usize {
    CONFIGS.iter().position(|c| c.0 == name).unwrap_or(0)
}

/// Every configuration's name, [`CONFIGS`] then [`LEVELS`].
fn names() -> Vec<String> {
    CONFIGS
        .iter()
        .map(|c| c.0.to_owned())
        .chain(LEVELS.iter().map(|n| format!("{n} (levels proviso)")))
        .collect()
}

/// VmHWM of this process, in kB.
fn peak_kb() -> u64 {
    proc::rss_kb(std::process::id()).map_or(0, |(_, peak)| peak)
}

/// CPU time of this thread (user + system), in seconds: the spinning
/// thread of a busy run is not counted.
fn cpu_seconds() -> f64 {
    proc::cpu_in("/proc/thread-self/stat").map_or(0.0, |d| d.as_secs_f64())
}

const CHILD: &str = "PETREL_TEAM_BENCH_CONFIG";
const BUSY: &str = "PETREL_TEAM_BENCH_BUSY";
const PTNET: &str = "PETREL_TEAM_BENCH_PTNET";
const PT_NAME: &str = "ParamProductionCell-PT-3";

/// One child's figures, tab-separated.
fn child(config: usize) {
    let before = cpu_seconds();
    let start = std::time::Instant::now();
    let report = run(config);
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu_seconds() - before;
    let r = &report.project;
    println!(
        "{}\t{}\t{}\t{}\t{}\t{}\t{:.3}\t{:.3}\t{}",
        r.states,
        r.edges,
        r.reduction.group,
        r.reduction.partial_order,
        r.holds(),
        r.complete,
        wall,
        cpu,
        peak_kb()
    );
    for note in &r.reduction.notes {
        eprintln!("note: {note}");
    }
}

/// The P/T explorer on [`PT_NAME`], one thread: states, CPU seconds.
fn ptnet_child() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/pnml")
        .join(format!("{PT_NAME}.pnml"));
    let Some(net) = std::fs::read_to_string(path)
        .ok()
        .and_then(|t| nets::verify::pnml::read_ptnet(&t).ok())
    else {
        return;
    };
    let before = cpu_seconds();
    let x = nets::verify::explore::explore(
        &net,
        &nets::verify::explore::Options {
            threads: 1,
            ..nets::verify::explore::Options::default()
        },
    );
    println!("{}\t{:.3}", x.summary.states, cpu_seconds() - before);
}

fn spawn(exe: &Path, var: &str, value: &str, busy: bool) -> Option<Vec<String>> {
    let mut command = std::process::Command::new(exe);
    command.env(var, value);
    if busy {
        command.env(BUSY, "1");
    }
    let out = command.output().ok()?;
    let line = String::from_utf8_lossy(&out.stdout);
    let fields: Vec<String> = line.trim().split('\t').map(str::to_owned).collect();
    (fields.len() > 1).then_some(fields)
}

fn table(exe: &Path, busy: bool) {
    let ptnet = spawn(exe, PTNET, "1", busy).and_then(|f| {
        let states: f64 = f[0].parse().ok()?;
        let cpu: f64 = f[1].parse().ok()?;
        Some(states / cpu.max(1e-3))
    });
    match ptnet {
        Some(rate) => println!("P/T explorer, {PT_NAME}, one thread: {rate:.0} states/s of CPU"),
        None => println!("P/T explorer: ../shared/pnml/{PT_NAME}.pnml not found"),
    }
    println!(
        "{:<40} {:>8} {:>9} {:>5} {:>5} {:>5} {:>8} {:>8} {:>9} {:>7} {:>8}",
        "configuration",
        "states",
        "steps",
        "group",
        "POR",
        "holds",
        "wall s",
        "CPU s",
        "states/s",
        "vs P/T",
        "peak MB"
    );
    for (i, name) in names().iter().enumerate() {
        let Some(f) = spawn(exe, CHILD, &i.to_string(), busy) else {
            println!("{name}: the child failed");
            continue;
        };
        let states: f64 = f[0].parse().unwrap_or(0.0);
        let cpu: f64 = f[7].parse().unwrap_or(0.0);
        let rate = states / cpu.max(0.01);
        let holds = if f[5] == "true" { &f[4] } else { "limit" };
        println!(
            "{:<40} {:>8} {:>9} {:>5} {:>5} {:>5} {:>8} {:>8} {:>9.0} {:>7} {:>8.1}",
            name,
            f[0],
            f[1],
            f[2],
            f[3],
            holds,
            f[6],
            f[7],
            rate,
            ptnet.map_or("-".to_owned(), |p| format!("{:.3}", rate / p)),
            f[8].parse::<f64>().unwrap_or(0.0) / 1024.0
        );
    }
}

fn main() {
    let busy = std::env::var(BUSY).is_ok();
    if let Some(config) = std::env::var(CHILD)
        .ok()
        .and_then(|c| c.parse::<usize>().ok())
        .filter(|&c| c < CONFIGS.len() + LEVELS.len())
    {
        if busy {
            busy::with_a_core_busy(|| child(config));
        } else {
            child(config);
        }
        return;
    }
    if std::env::var(PTNET).is_ok() {
        if busy {
            busy::with_a_core_busy(ptnet_child);
        } else {
            ptnet_child();
        }
        return;
    }
    let exe = std::env::current_exe().expect("the bench's own path");
    println!("idle:");
    table(&exe, false);
    println!("the other core busy (a spinning thread):");
    table(&exe, true);
    divan::main();
}

/// The configurations divan times (the large ones are timed once above).
const NAMES: [&str; 13] = [
    "1 robot",
    "team 2 whole",
    "team 2 symmetry",
    "team 2 partial order",
    "team 2 both",
    "team 4 whole",
    "team 4 symmetry",
    "team 4 partial order",
    "team 4 both",
    "ugv 2 whole",
    "ugv 2 symmetry",
    "ugv 2 partial order",
    "ugv 2 both",
];

fn config(name: &str) -> (&'static str, bool, bool) {
    let i = NAMES.iter().position(|n| *n == name).unwrap_or(0);
    let (_, fixture, symmetry, partial_order) = CONFIGS[i];
    (fixture, symmetry, partial_order)
}

#[divan::bench(args = NAMES, sample_count = 10)]
fn idle(bencher: Bencher, config_name: &str) {
    let (name, symmetry, partial_order) = config(config_name);
    let project = fixture(name);
    bencher.bench(|| check(&project, &options(symmetry, partial_order)));
}

#[divan::bench(args = NAMES, sample_count = 10)]
fn other_core_busy(bencher: Bencher, config_name: &str) {
    let (name, symmetry, partial_order) = config(config_name);
    let project = fixture(name);
    busy::with_a_core_busy(|| {
        bencher.bench(|| check(&project, &options(symmetry, partial_order)));
    });
}
