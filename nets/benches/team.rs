//! The team verifier (issue 16): the two-robot fixture
//! (`tests/fixtures/team`) and the same nets with four robots
//! (`tests/fixtures/team4`), checked whole (`each_net`, `alone`) with every
//! reduction, with each alone and with none, on one thread.
//!
//! Baseline in the same run: the single-vehicle project check of the same
//! MOVE net (one robot, no team net). Before the timings, `main` runs each
//! configuration in a child process of its own and prints its states (and
//! the unreduced count), the reductions that ran, its CPU time and the
//! child's peak resident memory (VmHWM); then divan times each, idle and
//! with the other core busy (a spinning thread).
//!
//! Run: `cargo bench -p nets --bench team`

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use divan::Bencher;
use nets::verify::project::{check, Options, ProjectReport};
use nets::Project;

/// The configurations: name, fixture, reductions (symmetry, partial order).
const CONFIGS: [(&str, &str, bool, bool); 9] = [
    ("one robot (baseline)", "one", false, false),
    ("two robots, no reduction", "team", false, false),
    ("two robots, symmetry", "team", true, false),
    ("two robots, partial order", "team", false, true),
    ("two robots, both", "team", true, true),
    ("four robots, no reduction", "team4", false, false),
    ("four robots, symmetry", "team4", true, false),
    ("four robots, partial order", "team4", false, true),
    ("four robots, both", "team4", true, true),
];

fn fixture(name: &str) -> Arc<Project> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    let mut files = BTreeMap::new();
    let folder = if name == "one" { "team" } else { name };
    for file in ["project.toml", "move.toml", "watch.toml"] {
        let text = std::fs::read_to_string(dir.join(folder).join(file)).expect("fixture file");
        files.insert(file.to_owned(), text);
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

fn options(symmetry: bool, partial_order: bool, compare: bool) -> Options<'static> {
    Options {
        symmetry,
        partial_order,
        compare_unreduced: compare,
        ..Options::default()
    }
}

fn run(config: usize, compare: bool) -> ProjectReport {
    let (_, name, symmetry, partial_order) = CONFIGS[config];
    check(&fixture(name), &options(symmetry, partial_order, compare))
}

/// VmHWM of this process, in kB.
fn peak_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or(0)
}

/// CPU time of this process (user + system), in seconds.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .map(|(_, rest)| rest.split_whitespace().collect())
        .unwrap_or_default();
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|f| f.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    // utime and stime are fields 14 and 15 (1-based), 12 and 13 after the
    // name; clock ticks are 100 per second on Linux.
    (ticks(11) + ticks(12)) / 100.0
}

const CHILD: &str = "PETREL_TEAM_BENCH_CONFIG";

fn main() {
    if let Some(config) = std::env::var(CHILD)
        .ok()
        .and_then(|c| c.parse::<usize>().ok())
    {
        // A child: one configuration, its figures on one line.
        let before = cpu_seconds();
        let start = std::time::Instant::now();
        let report = run(config, false);
        let wall = start.elapsed().as_secs_f64();
        let cpu = cpu_seconds() - before;
        let r = &report.project;
        println!(
            "{}\t{}\t{}\t{}\t{:.3}\t{:.3}\t{}",
            r.states,
            r.reduction.group,
            r.reduction.partial_order,
            r.holds(),
            wall,
            cpu,
            peak_kb()
        );
        return;
    }
    let exe = std::env::current_exe().expect("the bench's own path");
    println!(
        "{:<28} {:>7} {:>10} {:>6} {:>5} {:>6} {:>9} {:>8} {:>9}",
        "configuration",
        "states",
        "unreduced",
        "factor",
        "group",
        "POR",
        "wall s",
        "CPU s",
        "peak MB"
    );
    for (i, (name, _, _, _)) in CONFIGS.iter().enumerate() {
        let report = run(i, true).project;
        for note in &report.reduction.notes {
            println!("  ({name}: {note})");
        }
        let unreduced = report.reduction.unreduced_states;
        let out = std::process::Command::new(&exe)
            .env(CHILD, i.to_string())
            .output()
            .expect("the bench runs itself");
        let line = String::from_utf8_lossy(&out.stdout);
        let f: Vec<&str> = line.trim().split('\t').collect();
        if f.len() < 7 {
            println!(
                "{name}: child failed: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            continue;
        }
        let states: f64 = f[0].parse().unwrap_or(0.0);
        let whole = unreduced.map_or(states, |u| u as f64);
        println!(
            "{:<28} {:>7} {:>10} {:>6.2} {:>5} {:>6} {:>9} {:>8} {:>9.1}",
            name,
            f[0],
            whole,
            whole / states.max(1.0),
            f[1],
            f[2],
            f[4],
            f[5],
            f[6].parse::<f64>().unwrap_or(0.0) / 1024.0
        );
    }
    divan::main();
}

/// Runs `measure` with one thread spinning beside it.
fn with_a_core_busy(measure: impl FnOnce()) {
    use std::sync::atomic::{AtomicBool, Ordering};
    let stop = Arc::new(AtomicBool::new(false));
    let spinner = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let mut x = 0u64;
            while !stop.load(Ordering::Relaxed) {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
                std::hint::black_box(x);
            }
        })
    };
    measure();
    stop.store(true, Ordering::Relaxed);
    let _ = spinner.join();
}

/// The configurations' short names, for divan.
const NAMES: [&str; 9] = [
    "1 robot",
    "2 whole",
    "2 symmetry",
    "2 partial order",
    "2 both",
    "4 whole",
    "4 symmetry",
    "4 partial order",
    "4 both",
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
    bencher.bench(|| check(&project, &options(symmetry, partial_order, false)));
}

#[divan::bench(args = NAMES, sample_count = 10)]
fn other_core_busy(bencher: Bencher, config_name: &str) {
    let (name, symmetry, partial_order) = config(config_name);
    let project = fixture(name);
    with_a_core_busy(|| {
        bencher.bench(|| check(&project, &options(symmetry, partial_order, false)));
    });
}
