//! Player throughput on the uav-survey example: its nominal flight (every
//! event and reply of `scripts/nominal.jsonl`) with three non-matching
//! telemetry events between each pair of inputs, played from start to
//! landing again and again.
//!
//! Baseline in the same run: the bare dispatch any event-driven supervisor
//! does — looking the event's name up in a hash map of waiting transitions —
//! over the same input sequence.
//!
//! Run: `cargo bench -p nets --bench player`

use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::sync::Arc;

use divan::counter::ItemsCount;
use divan::{black_box, Bencher};
use nets::player::Outcome;
use nets::script::{self, Input};
use nets::{Category, Event, Player, Project};

fn main() {
    divan::main();
}

enum Step {
    Event(Event),
    Reply(u64, Outcome),
    Advance,
}

struct Flight {
    project: Arc<Project>,
    steps: Vec<(u64, Step)>,
}

fn flight() -> Flight {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-survey");
    let files: BTreeMap<String, String> = ["project.toml", "mission.toml", "events.toml"]
        .iter()
        .map(|n| {
            (
                n.to_string(),
                std::fs::read_to_string(dir.join(n)).expect("example"),
            )
        })
        .collect();
    let project = Arc::new(nets::load(&files).expect("example loads"));
    let text = std::fs::read_to_string(dir.join("scripts/nominal.jsonl")).expect("script");
    let lines = script::parse(&text).expect("script parses");
    // Resolve replies to ids once, on a dry run.
    let mut player = Player::start(project.clone(), 0);
    let noise = [
        Event::new("gps_ok")
            .param("satellites", 14)
            .param("hdop", 0.8),
        Event::new("link_quality")
            .category(Category::Communication)
            .param("rssi", 180),
        Event::new("mode_changed").param("mode", "AUTO"),
    ];
    let mut steps = Vec::new();
    for line in &lines {
        for n in &noise {
            steps.push((line.time, Step::Event(n.clone())));
        }
        let step = match &line.input {
            Input::Event(e) => Step::Event(e.clone()),
            Input::Advance => Step::Advance,
            Input::Reply { to, outcome } => {
                player.advance(line.time);
                let id = script::resolve(&player, line, to).expect("reply resolves");
                Step::Reply(id, outcome.clone())
            }
            Input::Answer { .. } => panic!("the example's script answers no question"),
        };
        script::play_line(&mut player, line).expect("plays");
        let _ = player.effects().count();
        steps.push((line.time, step));
    }
    assert!(player.state().pending.is_empty());
    Flight { project, steps }
}

#[divan::bench]
fn player_nominal_flight_with_noise(bencher: Bencher) {
    let f = flight();
    bencher
        .counter(ItemsCount::new(f.steps.len()))
        .bench_local(|| {
            let mut player = Player::start(f.project.clone(), 0);
            let mut n = 0usize;
            for (t, step) in &f.steps {
                match step {
                    Step::Event(e) => player.handle(e, *t),
                    Step::Reply(id, o) => player.result(*id, o.clone(), *t),
                    Step::Advance => player.advance(*t),
                }
                n += player.effects().count();
            }
            black_box(n)
        });
}

#[divan::bench]
fn player_non_matching_events_only(bencher: Bencher) {
    let f = flight();
    let mut player = Player::start(f.project.clone(), 0);
    let _ = player.effects().count();
    let e = Event::new("gps_ok").param("satellites", 14);
    let mut t = 0;
    bencher.counter(ItemsCount::new(1usize)).bench_local(|| {
        t += 1;
        player.handle(black_box(&e), t);
        black_box(player.effects().count())
    });
}

#[divan::bench]
fn baseline_hash_dispatch(bencher: Bencher) {
    let f = flight();
    let table: HashMap<String, Vec<(usize, usize)>> = f.project.triggers.clone();
    bencher
        .counter(ItemsCount::new(f.steps.len()))
        .bench_local(|| {
            let mut hits = 0usize;
            for (_, step) in &f.steps {
                if let Step::Event(e) = step {
                    if let Some(list) = table.get(black_box(e.name.as_str())) {
                        hits += list.len();
                    }
                } else {
                    hits += 1;
                }
            }
            black_box(hits)
        });
}
