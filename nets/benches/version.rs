//! A new version taking over in flight (issue 38): how long
//! `nets::version::swap` takes on `examples/uav-flight-test` from a state
//! in the middle of its mission — the mapping, then the exploration of the
//! new version from that state — beside the project check from the start
//! (the same options: the whole project's verdict, one thread), which is
//! what `petrel run` proves before it flies. Here the new version is the
//! running one again (the worst case for the exploration from a state: all
//! of it is reachable).
//!
//! The mid-mission state: the example's nominal script
//! (`scripts/nominal.jsonl`) played to its line `PETREL_VERSION_BENCH_LINES`
//! (26, in the operations area).
//!
//! Run: `cargo bench -p nets --bench version` (`PETREL_VERSION_BENCH_RUNS`,
//! 5: the figure is the median of the runs, each pair alternated).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use nets::player::Player;
use nets::verify::project::{check, Options};
use nets::Project;

struct Folder(PathBuf);

impl nets::source::Sources for Folder {
    fn read(&self, path: &str) -> Result<String, String> {
        std::fs::read_to_string(self.0.join(path)).map_err(|e| e.to_string())
    }
}

fn project() -> Arc<Project> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-flight-test");
    Arc::new(nets::load::load(&Folder(dir)).unwrap_or_else(|e| panic!("{e:?}")))
}

fn options() -> Options<'static> {
    Options {
        each_net: false,
        alone: false,
        threads: 1,
        ..Options::default()
    }
}

/// The player after the first `lines` lines of the example's nominal
/// script, and the last line played.
fn mid_mission(project: &Arc<Project>, lines: usize) -> (Player, String) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-flight-test");
    let text = std::fs::read_to_string(dir.join("scripts/nominal.jsonl")).expect("the script");
    let script = nets::script::parse(&text).unwrap_or_else(|e| panic!("{e:?}"));
    let mut player = Player::start(project.clone(), 0);
    let _ = player.effects().count();
    let mut last = String::new();
    for line in script.iter().take(lines) {
        nets::script::play_line(&mut player, line).unwrap_or_else(|e| panic!("{e:?}"));
        let _ = player.effects().count();
        last = format!("{line:?}");
    }
    (player, last)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let project = project();
    let lines = std::env::var("PETREL_VERSION_BENCH_LINES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(26);
    let runs = std::env::var("PETREL_VERSION_BENCH_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5usize);
    let (player, last) = mid_mission(&project, lines);
    println!("mid-mission, after line {lines} of the nominal script: {last}");
    let (mut swaps, mut checks) = (Vec::new(), Vec::new());
    let (mut from_states, mut states) = (0, 0);
    for _ in 0..runs {
        let t = Instant::now();
        let report = check(&project, &options());
        checks.push(t.elapsed().as_secs_f64());
        states = report.project.states;
        let t = Instant::now();
        let swapped = nets::version::swap(&project, player.state(), &project, &options());
        swaps.push(t.elapsed().as_secs_f64());
        let swapped = swapped.unwrap_or_else(|r| panic!("refused: {r:?}"));
        assert_eq!(swapped.digest(), player.digest());
        from_states = nets::verify::project::check_from(&project, player.state(), &options())
            .map(|r| r.states)
            .unwrap_or(0);
    }
    let (swap, base) = (median(swaps), median(checks));
    println!(
        "swap onto the same version, mid-mission: {:.3} s ({from_states} states explored from there); project check from the start: {:.3} s ({states} states); ratio {:.2} (median of {runs})",
        swap,
        base,
        swap / base
    );
}
