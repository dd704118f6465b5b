//! The paper's UAV survey example (examples/uav-survey) on its three scripts.
//! The expected firings are written here by hand from the nets, not
//! regenerated from the player's output.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::common;
use nets::player::{DropReason, Effect};
use nets::{script, Category, Player, Project, Value};

fn example_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-survey")
}

fn example() -> Arc<Project> {
    let dir = example_dir();
    let mut files = BTreeMap::new();
    for name in ["project.toml", "mission.toml", "events.toml"] {
        let text = std::fs::read_to_string(dir.join(name)).expect("example file");
        files.insert(name.to_owned(), text);
    }
    Arc::new(nets::load(&files).unwrap_or_else(|e| panic!("{e}")))
}

/// Plays a script; returns every effect and the final player.
fn play(name: &str) -> (Vec<Effect>, Player) {
    let project = example();
    let text = std::fs::read_to_string(example_dir().join("scripts").join(name)).expect("script");
    let lines = script::parse(&text).expect("script parses");
    let mut player = Player::start(project, 0);
    let mut effects: Vec<Effect> = player.effects().collect();
    for line in &lines {
        script::play_line(&mut player, line).unwrap_or_else(|e| panic!("{name}:{e}"));
        effects.extend(player.effects());
    }
    (effects, player)
}

fn fired(player: &Player, effects: &[Effect]) -> Vec<String> {
    common::fired(player.project(), effects)
}

#[test]
fn nominal_flight() {
    let (effects, player) = play("nominal.jsonl");
    assert_eq!(
        fired(&player, &effects),
        [
            "MISSION.arm",
            "MISSION.roll",
            "MISSION.takeoff",
            "MISSION.climb",
            "MISSION.transit",
            "MISSION.arrive",
            "MISSION.work_done",
            "MISSION.transit",
            "MISSION.arrive",
            "MISSION.work_done",
            "MISSION.go_home",
            "MISSION.approach",
            "MISSION.touchdown",
        ]
    );
    assert_eq!(common::marking(&player, "MISSION"), ["landed"]);
    assert_eq!(common::marking(&player, "EVENTS"), ["watching"]);
    assert!(!common::global(&player, "flying"));
    // Commands, in order, with the waypoint's parameters flowing into the
    // guidance call.
    let commands: Vec<&str> = effects
        .iter()
        .filter_map(|e| match e {
            Effect::Command { verb, .. } => Some(verb.as_str()),
            _ => None,
        })
        .collect();
    assert_eq!(commands, ["arm", "takeoff", "land", "disarm"]);
    let gotos: Vec<(f64, f64)> = effects
        .iter()
        .filter_map(|e| match e {
            Effect::Call { args, .. } if args.contains_key("lat") => {
                Some((args["lat"].as_f64()?, args["alt"].as_f64()?))
            }
            _ => None,
        })
        .collect();
    assert_eq!(gotos, [(43.5612, 120.0), (43.5655, 150.0)]);
    let payloads: Vec<&Value> = effects
        .iter()
        .filter_map(|e| match e {
            Effect::Call { args, .. } => args.get("payload"),
            _ => None,
        })
        .collect();
    assert_eq!(payloads, [&Value::from("camera"), &Value::from("lidar")]);
    // The payload timer fires at 110 s and 170 s, 20 s after each arrival.
    let expiries: Vec<u64> = effects
        .iter()
        .filter_map(|e| match e {
            Effect::TimerExpired { time, .. } => Some(*time),
            _ => None,
        })
        .collect();
    assert_eq!(expiries, [110_000_000, 170_000_000]);
    assert!(
        player.state().pending.is_empty(),
        "every call and command answered"
    );
    assert!(!effects
        .iter()
        .any(|e| matches!(e, Effect::Dropped { .. } | Effect::Fault { .. })));
}

#[test]
fn payload_failure_replans_and_resumes() {
    let (effects, player) = play("payload_failure.jsonl");
    assert_eq!(
        fired(&player, &effects),
        [
            "MISSION.arm",
            "MISSION.roll",
            "MISSION.takeoff",
            "MISSION.climb",
            "MISSION.transit",
            "MISSION.arrive",
            "EVENTS.payload_failure",
            "EVENTS.replanned",
            "MISSION.resume",
            "MISSION.transit",
            "MISSION.arrive",
            "MISSION.work_done",
            "MISSION.go_home",
            "MISSION.approach",
            "MISSION.touchdown",
        ]
    );
    let p = player.project().clone();
    let mission = p.net("MISSION").expect("MISSION");
    // Deactivating MISSION cancelled its payload timer and forgot its call.
    let cancelled = effects
        .iter()
        .position(|e| matches!(e, Effect::TimerCancelled { net, .. } if *net == mission));
    assert!(cancelled.is_some());
    assert!(effects
        .iter()
        .any(|e| matches!(e, Effect::Forgotten { id: 6, .. })));
    assert!(effects
        .iter()
        .any(|e| matches!(e, Effect::LateResult { id: 6, .. })));
    // The timer set at 90 s for 110 s never expired; the next one did, at 150 s.
    let expiries: Vec<u64> = effects
        .iter()
        .filter_map(|e| match e {
            Effect::TimerExpired { time, .. } => Some(*time),
            _ => None,
        })
        .collect();
    assert_eq!(expiries, [150_000_000]);
    // The failed component flowed from the event into DEC's call.
    assert!(effects.iter().any(|e| matches!(e, Effect::Call { args, .. } if args.get("failed") == Some(&Value::from("camera")))));
    assert_eq!(common::marking(&player, "MISSION"), ["landed"]);
    assert_eq!(common::marking(&player, "EVENTS"), ["watching"]);
    assert!(
        !common::global(&player, "replanned"),
        "resume consumed @replanned"
    );
}

#[test]
fn engine_failure_glides_to_the_emergency_site_under_the_lockout() {
    let (effects, player) = play("engine_failure.jsonl");
    assert_eq!(
        fired(&player, &effects),
        [
            "MISSION.arm",
            "MISSION.roll",
            "MISSION.takeoff",
            "MISSION.climb",
            "MISSION.transit",
            "EVENTS.engine_failure",
            "EVENTS.glide",
            "EVENTS.site_reached",
            "EVENTS.down",
        ]
    );
    assert!(player.locked_out());
    let dropped: Vec<(&str, DropReason)> = effects
        .iter()
        .filter_map(|e| match e {
            Effect::Dropped { event, reason, .. } => Some((event.name.as_str(), *reason)),
            _ => None,
        })
        .collect();
    assert_eq!(
        dropped,
        [
            ("payload_failure", DropReason::Lockout),
            ("landed", DropReason::Lockout)
        ]
    );
    assert!(effects
        .iter()
        .any(|e| matches!(e, Effect::LateResult { id: 4, .. })));
    // The glide goes to DEC's site.
    assert!(effects.iter().any(
        |e| matches!(e, Effect::Call { args, .. } if args.get("lat") == Some(&Value::Float(43.558)))
    ));
    assert!(common::marking(&player, "MISSION").is_empty());
    assert_eq!(common::marking(&player, "EVENTS"), ["down"]);
    // The lockout effect names the catastrophic event.
    assert!(effects
        .iter()
        .any(|e| matches!(e, Effect::Lockout { event, .. } if event == "engine_failure")));
    let disarm = effects.iter().find_map(|e| match e {
        Effect::Command { verb, .. } if verb == "disarm" => Some(()),
        _ => None,
    });
    assert!(disarm.is_some());
    assert_eq!(
        player.project().declared_category("engine_failure"),
        Some(Category::Catastrophic)
    );
}

#[test]
fn the_example_scripts_are_deterministic() {
    for name in [
        "nominal.jsonl",
        "payload_failure.jsonl",
        "engine_failure.jsonl",
    ] {
        let (a, pa) = play(name);
        let (b, pb) = play(name);
        assert_eq!(a, b, "{name}");
        assert_eq!(pa.digest(), pb.digest(), "{name}");
    }
}
