//! The project explorer's memo of runs (`nets/src/verify/project_memo.rs`)
//! against the player: with the cross-check on, every hit runs the player
//! too and compares its successors and labels with the memo's; the reports
//! with the memo, without it and cross-checked are the same, on one and
//! two threads.

mod common;

use std::sync::atomic::Ordering;
use std::sync::Arc;

use nets::verify::project::{check_probed, MemoProbe, Options};
use nets::Project;

/// The files of a project folder (`project.toml` and the nets it lists).
fn folder(dir: &std::path::Path) -> Vec<(String, String)> {
    let read = |n: &str| std::fs::read_to_string(dir.join(n)).expect("project file");
    let project = read("project.toml");
    let table: toml::Table = toml::from_str(&project).expect("project.toml");
    let mut files = vec![("project.toml".to_owned(), project.clone())];
    for net in table["net"].as_array().expect("[[net]]") {
        let file = net["file"].as_str().expect("file");
        files.push((file.to_owned(), read(file)));
    }
    files
}

fn load(path: &str) -> Arc<Project> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    let files = folder(&dir);
    let refs: Vec<(&str, &str)> = files
        .iter()
        .map(|(a, b)| (a.as_str(), b.as_str()))
        .collect();
    common::project(&refs)
}

fn probe(off: bool, cross_check: bool) -> Arc<MemoProbe> {
    Arc::new(MemoProbe {
        off,
        cross_check,
        ..MemoProbe::default()
    })
}

/// Checks `project` with the memo cross-checked, left out and used, on
/// one and two threads (cut at `max_states`); returns the cross-check's
/// hits on one thread.
fn same_reports(name: &str, project: &Arc<Project>, max_states: usize) -> u64 {
    let mut hits = 0;
    for threads in [1, 2] {
        let options = Options {
            threads,
            max_states,
            ..Options::default()
        };
        let off = check_probed(project, &options, Some(&probe(true, false)));
        let checked = probe(false, true);
        let cross = check_probed(project, &options, Some(&checked));
        let used = check_probed(project, &options, None);
        assert_eq!(
            checked.mismatches(),
            Vec::<String>::new(),
            "{name}, {threads} thread(s): the memo and the player differ"
        );
        assert_eq!(cross, off, "{name}, {threads} thread(s), cross-checked");
        assert_eq!(used, off, "{name}, {threads} thread(s), with the memo");
        if threads == 1 {
            hits = checked.hits.load(Ordering::Relaxed);
        }
    }
    hits
}

#[test]
fn the_memo_gives_what_the_player_gives_on_the_examples() {
    // Whole for the survey (two nets: each input meets each projection
    // once, no hit); the flight test cut at 4,000 states (timers, calls,
    // questions, guards answered both ways, the catastrophic reaction's
    // immediate transitions), where most inputs hit.
    for (path, max_states, hit) in [
        ("../examples/uav-survey", 1_000_000, false),
        ("../examples/uav-flight-test", 4_000, true),
    ] {
        let project = load(path);
        let hits = same_reports(path, &project, max_states);
        assert_eq!(hits > 0, hit, "{path}: {hits} hits");
    }
}

#[test]
fn teams_do_not_use_the_memo() {
    // Symmetry reads the whole state at each step: a team's exploration
    // runs the player for every input, its report unchanged.
    for (path, max_states) in [
        ("../examples/ugv-bottleneck", 3_000),
        ("tests/fixtures/team", 3_000),
        ("tests/fixtures/team4", 3_000),
        ("tests/fixtures/ugv4", 3_000),
    ] {
        let project = load(path);
        assert!(!project.vehicles.is_empty(), "{path} is a team");
        let hits = same_reports(path, &project, max_states);
        assert_eq!(hits, 0, "{path}");
    }
}
