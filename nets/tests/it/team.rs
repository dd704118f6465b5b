//! A team of vehicles: templates instantiated per vehicle, events routed to
//! the right instance, commands and calls addressed to a vehicle, a global
//! place the instances take turns on, and the load errors of a team.

use std::collections::BTreeMap;
use std::sync::Arc;

use nets::model::PlaceRef;
use nets::{Effect, Event, Player, Project};

const FIXTURE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/team");

fn fixture_files() -> BTreeMap<String, String> {
    ["project.toml", "move.toml", "watch.toml"]
        .into_iter()
        .map(|f| {
            let text = std::fs::read_to_string(format!("{FIXTURE}/{f}")).expect("fixture file");
            (f.to_owned(), text)
        })
        .collect()
}

fn fixture() -> Arc<Project> {
    match nets::load(&fixture_files()) {
        Ok(p) => Arc::new(p),
        Err(e) => panic!("{e:?}"),
    }
}

fn net(project: &Project, name: &str) -> usize {
    project.net(name).unwrap_or_else(|| panic!("no net {name}"))
}

fn marked(player: &Player, net_name: &str, place: &str) -> bool {
    let project = player.project();
    let n = net(project, net_name);
    let p = project.nets[n]
        .places
        .iter()
        .position(|q| q.name == place)
        .expect("place");
    player.is_marked(n, PlaceRef::Local(p))
}

const S: u64 = 1_000_000;

#[test]
fn a_template_becomes_one_instance_per_vehicle_named_at_its_vehicle() {
    let project = fixture();
    let names: Vec<&str> = project.nets.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, ["MOVE@R1", "MOVE@R2", "WATCH"]);
    let vehicles: Vec<Option<usize>> = project.nets.iter().map(|n| n.vehicle).collect();
    assert_eq!(vehicles, [Some(0), Some(1), None]);
    let team: Vec<(&str, u8, u8)> = project
        .vehicles
        .iter()
        .map(|v| (v.name.as_str(), v.system, v.component))
        .collect();
    assert_eq!(team, [("R1", 1, 1), ("R2", 2, 1)]);
    assert_eq!(
        project.vehicles[0].profile.as_deref(),
        Some("ardupilot-rover")
    );
    // Each instance has its own places: flat numbering after the global.
    assert_eq!(project.place_offsets, [1, 5, 9]);
    // Instances wait for their vehicle's events; own timers stay local.
    let events: Vec<Option<&str>> = project.nets[1]
        .transitions
        .iter()
        .map(|t| t.event.as_deref())
        .collect();
    assert_eq!(
        events,
        [Some("at_gate@R2"), None, Some("through@R2"), Some("stuck")]
    );
    // A vehicle's event has its base event's category.
    assert_eq!(
        project.declared_category("engine_failure@R2"),
        Some(nets::Category::Catastrophic)
    );
}

#[test]
fn the_shared_resource_lists_each_vehicles_places() {
    let project = fixture();
    let [bottleneck] = project.exclusive.as_slice() else {
        panic!("one resource")
    };
    assert_eq!(bottleneck.name, "bottleneck");
    let inside = |n: &str| {
        let id = net(&project, n);
        project.flat(id, PlaceRef::Local(2))
    };
    assert_eq!(
        bottleneck.held,
        [(0, vec![inside("MOVE@R1")]), (1, vec![inside("MOVE@R2")])]
    );
    assert_eq!(bottleneck.holders(|p| p == inside("MOVE@R2")), [1]);
}

#[test]
fn an_event_of_one_vehicle_reaches_that_vehicles_instance_only() {
    let mut player = Player::start(fixture(), 0);
    player.handle(&Event::new("at_gate@R2"), S);
    assert!(marked(&player, "MOVE@R2", "inside"));
    assert!(marked(&player, "MOVE@R1", "outside"));
    // The bare event is no vehicle's: no instance hears it.
    player.handle(&Event::new("at_gate"), 2 * S);
    assert!(marked(&player, "MOVE@R1", "outside"));
}

fn commands(player: &mut Player) -> Vec<(String, Option<usize>, String)> {
    let project = Arc::clone(player.project());
    player
        .effects()
        .filter_map(|e| match e {
            Effect::Command {
                verb, vehicle, net, ..
            } => Some((verb, vehicle, project.nets[net].name.clone())),
            _ => None,
        })
        .collect()
}

#[test]
fn an_instance_commands_its_vehicle_and_a_team_net_the_vehicle_it_names() {
    let mut player = Player::start(fixture(), 0);
    player.effects().for_each(drop);
    player.handle(&Event::new("at_gate@R2"), S);
    assert_eq!(
        commands(&mut player),
        [("goto".to_owned(), Some(1), "MOVE@R2".to_owned())]
    );
    // The rendering names the vehicle.
    player.handle(&Event::new("at_gate@R1"), 2 * S);
    player.handle(&Event::new("through@R2"), 3 * S);
    let project = Arc::clone(player.project());
    let lines: Vec<String> = player
        .effects()
        .filter(|e| matches!(e, Effect::Command { .. }))
        .map(|e| nets::player::effect_json(&project, &e).to_string())
        .collect();
    assert_eq!(lines.len(), 1);
    assert!(lines[0].contains(r#""vehicle":"R1""#), "{}", lines[0]);
    player.handle(&Event::new("obstacle@R2"), 4 * S);
    assert_eq!(
        commands(&mut player),
        [("mode".to_owned(), Some(0), "WATCH".to_owned())]
    );
}

#[test]
fn the_global_place_makes_the_instances_take_turns() {
    let mut player = Player::start(fixture(), 0);
    player.handle(&Event::new("at_gate@R1"), S);
    player.handle(&Event::new("at_gate@R2"), 2 * S);
    assert!(marked(&player, "MOVE@R1", "inside"));
    assert!(marked(&player, "MOVE@R2", "waiting"));
    player.handle(&Event::new("through@R1"), 3 * S);
    assert!(marked(&player, "MOVE@R1", "through"));
    assert!(marked(&player, "MOVE@R2", "inside"));
}

#[test]
fn each_instance_has_its_own_timer_and_its_calls_carry_its_vehicle() {
    let mut player = Player::start(fixture(), 0);
    player.handle(&Event::new("at_gate@R1"), 0);
    player.handle(&Event::new("at_gate@R2"), S);
    // R1 leaves at 10 s: its timer is cancelled, R2 enters and starts its own.
    player.handle(&Event::new("through@R1"), 10 * S);
    player.effects().for_each(drop);
    player.advance(65 * S);
    assert!(
        marked(&player, "MOVE@R2", "inside"),
        "R1's cancelled timer must not move R2"
    );
    player.advance(70 * S);
    assert!(marked(&player, "MOVE@R2", "through"));
    let calls: Vec<Option<usize>> = player
        .effects()
        .filter_map(|e| match e {
            Effect::Call { vehicle, .. } => Some(vehicle),
            _ => None,
        })
        .collect();
    assert_eq!(calls, [Some(1)]);
}

#[test]
fn a_team_plays_deterministically() {
    let run = || {
        let mut player = Player::start(fixture(), 0);
        let mut out = Vec::new();
        for (i, name) in [
            "at_gate@R2",
            "at_gate@R1",
            "engine_failure@R2",
            "through@R2",
        ]
        .into_iter()
        .enumerate()
        {
            player.handle(&Event::new(name), i as u64 * S);
            out.extend(player.effects().map(|e| format!("{e:?}")));
        }
        player.advance(200 * S);
        out.extend(player.effects().map(|e| format!("{e:?}")));
        (out, player.digest())
    };
    assert_eq!(run(), run());
}

/// Loads the fixture with one file replaced (or added); the problems as
/// "file:line:col: message".
fn problems_with(file: &str, text: &str) -> Vec<String> {
    let mut files = fixture_files();
    files.insert(file.to_owned(), text.to_owned());
    match nets::load(&files) {
        Ok(_) => Vec::new(),
        Err(e) => e.problems.iter().map(|p| p.to_string()).collect(),
    }
}

fn project_with(extra_vehicle: &str) -> String {
    let project = std::fs::read_to_string(format!("{FIXTURE}/project.toml")).expect("fixture");
    format!("{project}\n{extra_vehicle}")
}

#[test]
fn a_team_reports_its_mistakes_where_they_are() {
    let dup = problems_with(
        "project.toml",
        &project_with("[[vehicle]]\nname = \"R1\"\nsystem = 3\n"),
    );
    assert_eq!(dup.len(), 1, "{dup:?}");
    assert!(
        dup[0].contains("duplicate vehicle `R1` (first declared at project.toml:16:8)"),
        "{dup:?}"
    );
    assert!(dup[0].starts_with("project.toml:44:8"), "{dup:?}");
    let system = problems_with(
        "project.toml",
        &project_with("[[vehicle]]\nname = \"R3\"\nsystem = 2\n"),
    );
    assert_eq!(system.len(), 1, "{system:?}");
    assert!(
        system[0]
            .contains("vehicle `R3` has the MAVLink system id 2 (component 1) of vehicle `R2`"),
        "{system:?}"
    );
    let range = problems_with(
        "project.toml",
        &project_with("[[vehicle]]\nname = \"R3\"\nsystem = 300\n"),
    );
    assert!(range[0].contains("out of range"), "{range:?}");

    let move_net = std::fs::read_to_string(format!("{FIXTURE}/move.toml")).expect("fixture");
    let unknown = problems_with(
        "move.toml",
        &move_net.replace("vehicles = \"all\"", "vehicles = [\"R1\", \"R3\"]"),
    );
    assert_eq!(
        unknown,
        ["move.toml:3:12: unknown vehicle `R3` in `vehicles` (the team: R1, R2)"]
    );
    let qualified = problems_with(
        "move.toml",
        &move_net.replace("on = \"at_gate\"", "on = \"at_gate@R2\""),
    );
    assert_eq!(qualified.len(), 1, "{qualified:?}");
    assert!(
        qualified[0].starts_with("move.toml:12:6: `at_gate@R2` in a net instantiated per vehicle"),
        "{qualified:?}"
    );
    let commanded = problems_with(
        "move.toml",
        &move_net.replace("command goto {", "command goto @R2 {"),
    );
    assert_eq!(commanded.len(), 1, "{commanded:?}");
    assert!(commanded[0].contains("`@R2`: an instance commands its own vehicle only"));

    let watch = std::fs::read_to_string(format!("{FIXTURE}/watch.toml")).expect("fixture");
    let nobody = problems_with("watch.toml", &watch.replace("obstacle@R2", "obstacle@R3"));
    assert_eq!(
        nobody,
        ["watch.toml:11:6: `obstacle@R3`: `@R3` names no vehicle (the team: R1, R2)"]
    );
    let no_target = problems_with("watch.toml", &watch.replace("mode @R1", "mode"));
    assert_eq!(no_target.len(), 1, "{no_target:?}");
    assert!(no_target[0].contains("in a team net: name the vehicle"));
    let bad_command = problems_with("watch.toml", &watch.replace("mode @R1", "mode @R9"));
    assert!(
        bad_command[0].contains("`@R9` names no vehicle"),
        "{bad_command:?}"
    );
}

#[test]
fn a_template_in_a_project_without_a_team_is_an_error() {
    let files: BTreeMap<String, String> = [
        (
            "project.toml".to_owned(),
            "[[net]]\nfile = \"n.toml\"\nactive = true\n".to_owned(),
        ),
        (
            "n.toml".to_owned(),
            "name = \"N\"\nvehicles = \"all\"\nplaces = [\"a\"]\ninitial = [\"a\"]\n".to_owned(),
        ),
    ]
    .into();
    let problems: Vec<String> = match nets::load(&files) {
        Ok(_) => panic!("loads"),
        Err(e) => e.problems.iter().map(|p| p.to_string()).collect(),
    };
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(
        problems[0].starts_with("n.toml:2:12: `vehicles`: the project declares no vehicle"),
        "{problems:?}"
    );
}

#[test]
fn a_resource_names_places_of_a_template() {
    let with = |places: &str| {
        let project = std::fs::read_to_string(format!("{FIXTURE}/project.toml"))
            .expect("fixture")
            .replace("places = [\"MOVE.inside\"]", places);
        problems_with("project.toml", &project)
    };
    assert!(with("places = [\"MOVE.inside\", \"MOVE.waiting\"]").is_empty());
    assert!(with("places = [\"WATCH.stopped\"]")[0]
        .contains("`WATCH` is not a net instantiated per vehicle (it has no `vehicles`"));
    assert!(with("places = [\"MOVE.nowhere\"]")[0].contains("net `MOVE` has no place `nowhere`"));
    assert!(with("places = [\"inside\"]")[0].contains("write TEMPLATE.place"));
}

fn check(project: Project) -> nets::verify::project::Report {
    let options = nets::verify::project::Options {
        each_net: false,
        ..Default::default()
    };
    nets::verify::project::check(&Arc::new(project), &options).project
}

#[test]
fn the_verifier_proves_the_bottleneck_is_never_held_by_both_robots() {
    let report = check((*fixture()).clone());
    assert!(report.holds(), "{report:?}");
    assert_eq!(report.exclusion, []);
    // Vehicle events count as declared by their base event.
    assert!(
        !report
            .warnings
            .iter()
            .any(|w| w.contains("produced by nothing")),
        "{:?}",
        report.warnings
    );
}

#[test]
fn the_verifier_shows_two_robots_in_the_bottleneck_step_by_step() {
    let mut files = fixture_files();
    let unguarded = files["move.toml"]
        .replace(
            "from = [\"waiting\", \"@bottleneck_free\"]",
            "from = [\"waiting\"]",
        )
        .replace(
            "to = [\"through\", \"@bottleneck_free\"]",
            "to = [\"through\"]",
        );
    files.insert("move.toml".to_owned(), unguarded);
    let project = nets::load(&files).unwrap_or_else(|e| panic!("{e:?}"));
    let report = check(project);
    assert!(!report.holds());
    let [violation] = report.exclusion.as_slice() else {
        panic!("one violation: {:?}", report.exclusion)
    };
    assert_eq!(violation.resource, "bottleneck");
    assert_eq!(violation.vehicles, ["R1", "R2"]);
    assert_eq!(violation.example.len(), 2, "{:?}", violation.example);
    assert!(
        violation.example[0].contains("at_gate@R1"),
        "{:?}",
        violation.example
    );
    assert!(
        violation.example[1].contains("at_gate@R2"),
        "{:?}",
        violation.example
    );
}

/// The fixture with WATCH reacting to `event` (a catastrophic event)
/// instead of R2's obstacle.
fn with_watch_on(event: &str) -> Arc<Project> {
    let mut files = fixture_files();
    let watch = files["watch.toml"].replace("obstacle@R2", event);
    files.insert("watch.toml".to_owned(), watch);
    Arc::new(nets::load(&files).unwrap_or_else(|e| panic!("{e:?}")))
}

#[test]
fn one_vehicles_catastrophic_event_locks_out_that_vehicle_only() {
    // docs/nets.md, "The catastrophic lockout in a team".
    let mut player = Player::start(with_watch_on("engine_failure@R2"), 0);
    // R2 enters the bottleneck (its `stuck` timer runs), R1 waits for it.
    player.handle(&Event::new("at_gate@R2"), S);
    player.handle(&Event::new("at_gate@R1"), 2 * S);
    player.effects().for_each(drop);
    player.handle(&Event::new("engine_failure@R2"), 3 * S);
    let project = Arc::clone(player.project());
    let lockouts: Vec<Effect> = player
        .effects()
        .filter(|e| matches!(e, Effect::Lockout { .. }))
        .collect();
    let [lockout] = lockouts.as_slice() else {
        panic!("one lockout: {lockouts:?}")
    };
    assert!(
        matches!(lockout, Effect::Lockout { vehicle: Some(1), event, .. } if event == "engine_failure@R2"),
        "{lockout:?}"
    );
    let json = nets::player::effect_json(&project, lockout).to_string();
    assert!(json.contains(r#""vehicle":"R2""#), "{json}");
    let text = nets::player::effect_text(&project, lockout);
    assert!(text.contains("LOCKOUT @R2"), "{text}");
    assert!(!player.locked_out(), "the team goes on");
    assert!(player.vehicle_locked_out(1));
    assert!(!player.vehicle_locked_out(0));
    // R2's other events are dropped, its own non-catastrophic timer too:
    // it stays in the bottleneck, and R1 waits (the nets say so).
    player.handle(&Event::new("through@R2"), 4 * S);
    let dropped: Vec<String> = player
        .effects()
        .filter_map(|e| match e {
            Effect::Dropped { event, reason, .. } => {
                Some(format!("{} {}", event.name, reason.as_str()))
            }
            _ => None,
        })
        .collect();
    assert_eq!(dropped, ["through@R2 lockout"]);
    player.advance(120 * S);
    assert!(marked(&player, "MOVE@R2", "inside"));
    assert!(marked(&player, "MOVE@R1", "waiting"));
    // R1's own events are still handled: a second robot's obstacle is heard.
    let mut player = Player::start(with_watch_on("engine_failure@R2"), 0);
    player.handle(&Event::new("engine_failure@R2"), S);
    player.handle(&Event::new("at_gate@R1"), 2 * S);
    assert!(marked(&player, "MOVE@R1", "inside"));
}

#[test]
fn a_catastrophic_event_of_no_vehicle_locks_the_whole_team_out() {
    let mut player = Player::start(with_watch_on("engine_failure"), 0);
    player.handle(&Event::new("engine_failure"), S);
    assert!(player.locked_out());
    assert!(player.vehicle_locked_out(0) && player.vehicle_locked_out(1));
    player.handle(&Event::new("at_gate@R1"), 2 * S);
    assert!(marked(&player, "MOVE@R1", "outside"));
}

#[test]
fn a_vehicles_lockout_survives_snapshot_and_changes_the_digest() {
    let project = with_watch_on("engine_failure@R2");
    let mut locked = Player::start(Arc::clone(&project), 0);
    locked.handle(&Event::new("engine_failure@R2"), S);
    let a = locked.snapshot();
    assert_eq!(a.locked, [1]);
    assert!(!a.lockout);
    // The same state but for the lockout: another digest.
    let mut b = a.clone();
    b.locked.clear();
    let free = Player::restore(Arc::clone(&project), b).unwrap_or_else(|e| panic!("{e}"));
    assert_ne!(locked.digest(), free.digest());
    let bytes = nets::player::snapshot::encode(&a);
    let back = nets::player::snapshot::decode(&bytes).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back, a);
    let restored = Player::restore(Arc::clone(&project), back).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(restored.digest(), locked.digest());
    assert!(restored.vehicle_locked_out(1));
    // A vehicle the project does not have is refused, not believed.
    let mut bad = a.clone();
    bad.locked = vec![7];
    assert!(Player::restore(project, bad).is_err());
    // A list out of order is corrupt.
    let mut unordered = a;
    unordered.locked = vec![1, 0];
    let bytes = nets::player::snapshot::encode(&unordered);
    assert!(nets::player::snapshot::decode(&bytes).is_err());
}

#[test]
fn the_verifier_knows_a_locked_out_robot_blocks_the_bottleneck() {
    // R2 locked out inside the bottleneck never leaves it (its `through`
    // and its `stuck` timer are dropped): R1 waits for ever, a dead marking
    // of MOVE@R1 the verifier finds, reached through R2's failure.
    let project = Arc::new((*with_watch_on("engine_failure@R2")).clone());
    let options = nets::verify::project::Options {
        each_net: true,
        ..Default::default()
    };
    let report = nets::verify::project::check(&project, &options);
    let (_, r1) = report
        .nets
        .iter()
        .find(|(name, _)| name == "MOVE@R1")
        .expect("MOVE@R1's verdict");
    assert!(r1.dead_markings > 0, "{r1:?}");
    let example = r1.deadlock_example.clone().unwrap_or_default();
    assert!(
        example.iter().any(|s| s.contains("engine_failure@R2")),
        "{example:?}"
    );
    // Under a team-wide lockout R1 would be stuck outside already (two
    // steps: R2 enters, fails); locked out alone, R2 stops R1 only once R1
    // has come to the gate: three steps, R1's own among them.
    assert_eq!(example.len(), 3, "{example:?}");
    assert!(
        example.iter().any(|s| s.contains("at_gate@R1")),
        "{example:?}"
    );
    assert!(!report.holds());
}

#[test]
fn the_fixtures_script_plays_the_robots_in_turn() {
    let text = std::fs::read_to_string(format!("{FIXTURE}/turns.jsonl")).expect("fixture");
    let lines = nets::script::parse(&text).unwrap_or_else(|e| panic!("{e:?}"));
    let project = fixture();
    nets::script::check(&project, &lines).unwrap_or_else(|e| panic!("{e:?}"));
    let mut player = Player::start(project, 0);
    for line in &lines {
        nets::script::play_line(&mut player, line).unwrap_or_else(|e| panic!("{e:?}"));
    }
    assert!(marked(&player, "MOVE@R1", "through"));
    assert!(marked(&player, "MOVE@R2", "inside"));
}

#[test]
fn a_team_net_names_the_instance_it_activates() {
    let watch = std::fs::read_to_string(format!("{FIXTURE}/watch.toml")).expect("fixture");
    let bare = problems_with(
        "watch.toml",
        &watch.replace("\"command mode @R1 {mode: HOLD}\"", "\"deactivate MOVE\""),
    );
    assert_eq!(
        bare,
        ["watch.toml:12:19: unknown net `MOVE`: `MOVE` is instantiated per vehicle, name the instance (`MOVE@VEHICLE`)"]
    );
    let mut files = fixture_files();
    files.insert(
        "watch.toml".to_owned(),
        watch.replace(
            "\"command mode @R1 {mode: HOLD}\"",
            "\"deactivate MOVE@R1\"",
        ),
    );
    let project = nets::load(&files).unwrap_or_else(|e| panic!("{e:?}"));
    let mut player = Player::start(Arc::new(project), 0);
    player.handle(&Event::new("obstacle@R2"), S);
    let project = Arc::clone(player.project());
    assert!(!player.is_active(net(&project, "MOVE@R1")));
    assert!(player.is_active(net(&project, "MOVE@R2")));
}
