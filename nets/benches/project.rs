//! The project check (issue 15): `nets::verify::project::check` on
//! `examples/uav-flight-test` (55,326 states, 1,426,434 steps), the whole
//! check `petrel check` runs (each net in its project and alone), without
//! process start-up and loading, on one and two threads.
//!
//! The project is loaded without the elaboration profile's catalog (the
//! nets crate does not know the profiles); the `PETREL_PROJECT_BENCH_CATALOG`
//! file (`EVENT CATEGORY|- [=PARAM,PARAM...]` a line, what `petrel check` gets
//! from the profile) makes it the same as `petrel check`'s.
//!
//! Baseline in the same run: the P/T explorer's states/s on
//! ParamProductionCell-PT-3 (`../shared/pnml`, 1,465,206 states, one
//! thread) beside the project explorer's.
//!
//! Before the timings, `main` prints states, steps, CPU time of the
//! calling thread and states/s, idle then with the other core busy; then
//! divan times the check, idle and with the other core busy.
//!
//! Run: `cargo bench -p nets --bench project`
//! Figures only, N times (no divan): `PETREL_PROJECT_BENCH_RUNS=N`.
//! A profiling loop: `PETREL_PROJECT_BENCH_ONLY=1` (one check, one thread).
//! The player for every step, without reusing outcomes:
//! `PETREL_PROJECT_BENCH_STEPS=run`.
//! The whole report, to compare two builds: `PETREL_PROJECT_BENCH_DUMP=FILE`
//! (written for one thread and, to `FILE.2`, for two).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use divan::Bencher;
use nets::verify::project::{check, Options, ProjectReport};
use nets::Project;

use petrel_test_support::busy;
use petrel_test_support::proc;

const PT_NAME: &str = "ParamProductionCell-PT-3";

/// The example checked: `uav-flight-test` unless `PETREL_PROJECT_BENCH_EXAMPLE`
/// names another folder of `examples/`.
fn example() -> PathBuf {
    let name = std::env::var("PETREL_PROJECT_BENCH_EXAMPLE")
        .unwrap_or_else(|_| "uav-flight-test".to_owned());
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name)
}

/// Reads the project's files from its folder.
struct Folder(PathBuf);

impl nets::source::Sources for Folder {
    fn read(&self, path: &str) -> Result<String, String> {
        std::fs::read_to_string(self.0.join(path)).map_err(|e| e.to_string())
    }
}

/// The catalog the environment names, if any (see the module's text).
fn catalog() -> Option<nets::load::Catalog> {
    let mut out = nets::load::Catalog::new();
    let path = std::env::var("PETREL_PROJECT_BENCH_CATALOG")
        .ok()
        .filter(|p| !p.is_empty())?;
    let text = std::fs::read_to_string(path).expect("the catalog file");
    for line in text.lines() {
        let mut words = line.split_whitespace();
        let (Some(name), Some(category)) = (words.next(), words.next()) else {
            continue;
        };
        let params = words.next().and_then(|p| p.strip_prefix('=')).map(|p| {
            p.split(',')
                .filter(|s| !s.is_empty())
                .map(str::to_owned)
                .collect()
        });
        out.insert(
            name.to_owned(),
            nets::model::EventDecl {
                category: category.parse().ok(),
                params,
            },
        );
    }
    Some(out)
}

/// The example, with the catalog when one is named (a catalog is every
/// event from outside: `load_with` refuses an awaited event it lacks),
/// else without (`load`: any awaited event may come from outside).
fn project() -> Arc<Project> {
    let folder = Folder(example());
    let project = match catalog() {
        Some(catalog) => nets::load::load_with(&folder, &catalog),
        None => nets::load::load(&folder),
    };
    Arc::new(project.unwrap_or_else(|e| panic!("{e:?}")))
}

fn options(threads: usize) -> Options<'static> {
    Options {
        threads,
        steps: steps(),
        ..Options::default()
    }
}

/// How steps run: `PETREL_PROJECT_BENCH_STEPS=run` runs the player for
/// every step (the reuse of outcomes off), to compare.
fn steps() -> nets::verify::project::Steps {
    match std::env::var("PETREL_PROJECT_BENCH_STEPS").as_deref() {
        Ok("run") => nets::verify::project::Steps::Run,
        _ => nets::verify::project::Steps::Reuse,
    }
}

/// CPU time of the whole process (user + system), in seconds.
fn cpu_seconds() -> f64 {
    proc::cpu_in("/proc/self/stat").map_or(0.0, |d| d.as_secs_f64())
}

/// CPU time of the calling thread, in seconds (a spinning thread beside
/// it is not counted).
fn thread_cpu_seconds() -> f64 {
    proc::cpu_in("/proc/thread-self/stat").map_or(0.0, |d| d.as_secs_f64())
}

/// The P/T explorer's states/s of CPU on [`PT_NAME`], one thread.
fn ptnet_rate() -> Option<f64> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/pnml")
        .join(format!("{PT_NAME}.pnml"));
    let net = std::fs::read_to_string(path)
        .ok()
        .and_then(|t| nets::verify::pnml::read_ptnet(&t).ok())?;
    let before = thread_cpu_seconds();
    let x = nets::verify::explore::explore(
        &net,
        &nets::verify::explore::Options {
            threads: 1,
            ..nets::verify::explore::Options::default()
        },
    );
    Some(x.summary.states as f64 / (thread_cpu_seconds() - before).max(1e-3))
}

/// One check's figures: the report, wall and CPU seconds (of the process
/// for two threads, of the calling thread for one).
fn timed(project: &Arc<Project>, threads: usize) -> (ProjectReport, f64, f64) {
    let cpu = if threads == 1 {
        thread_cpu_seconds
    } else {
        cpu_seconds
    };
    let before = cpu();
    let start = std::time::Instant::now();
    let report = check(project, &options(threads));
    (report, start.elapsed().as_secs_f64(), cpu() - before)
}

fn figures(project: &Arc<Project>, busy: bool) {
    let label = if busy { "other core busy" } else { "idle" };
    let pt = ptnet_rate();
    for threads in [1, 2] {
        let (r, wall, cpu) = timed(project, threads);
        let states = r.project.states as f64;
        println!(
            "{label}: {threads} thread(s): {} states, {} steps, holds {}, wall {wall:.2} s, CPU {cpu:.2} s, {:.0} states/s of CPU; P/T explorer {} states/s (ratio {})",
            r.project.states,
            r.project.edges,
            r.holds(),
            states / cpu.max(1e-3),
            pt.map_or("-".to_owned(), |p| format!("{p:.0}")),
            pt.map_or("-".to_owned(), |p| format!("{:.4}", states / cpu.max(1e-3) / p)),
        );
    }
}

fn main() {
    let project = project();
    if let Ok(file) = std::env::var("PETREL_PROJECT_BENCH_DUMP") {
        for (threads, path) in [(1, file.clone()), (2, format!("{file}.2"))] {
            let report = check(&project, &options(threads));
            std::fs::write(path, format!("{report:#?}\n")).expect("the dump is written");
        }
        return;
    }
    if let Ok(only) = std::env::var("PETREL_PROJECT_BENCH_ONLY") {
        let (r, wall, cpu) = timed(&project, only.parse().unwrap_or(1));
        println!(
            "{} states, {} steps, wall {wall:.2} s, CPU {cpu:.2} s",
            r.project.states, r.project.edges
        );
        return;
    }
    let runs: Option<usize> = std::env::var("PETREL_PROJECT_BENCH_RUNS")
        .ok()
        .and_then(|r| r.parse().ok());
    for _ in 0..runs.unwrap_or(1) {
        figures(&project, false);
        busy::with_a_core_busy(|| figures(&project, true));
    }
    if runs.is_none() {
        divan::main();
    }
}

#[divan::bench(args = [1, 2], sample_count = 3, sample_size = 1)]
fn idle(bencher: Bencher, threads: usize) {
    let project = project();
    bencher.bench(|| check(&project, &options(threads)));
}

#[divan::bench(args = [1, 2], sample_count = 3, sample_size = 1)]
fn other_core_busy(bencher: Bencher, threads: usize) {
    let project = project();
    busy::with_a_core_busy(|| {
        bencher.bench(|| check(&project, &options(threads)));
    });
}
