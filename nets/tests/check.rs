//! The project-level verifier: seeded faults with their counterexamples, the
//! warnings, and a project whose player semantics reach less than the plain
//! token game.

mod common;

use nets::verify::explore::{explore, Options as PtOptions};
use nets::verify::project::{check, token_game, Options, ProjectReport};

fn verify(files: &[(&str, &str)]) -> ProjectReport {
    check(&common::project(files), &Options::default())
}

#[test]
fn the_uav_survey_example_passes() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-survey");
    let read = |n: &str| std::fs::read_to_string(dir.join(n)).expect("example");
    let (p, m, e) = (
        read("project.toml"),
        read("mission.toml"),
        read("events.toml"),
    );
    let report = verify(&[
        ("project.toml", &p),
        ("mission.toml", &m),
        ("events.toml", &e),
    ]);
    assert!(report.holds(), "{report:#?}");
    let r = &report.project;
    assert!(r.complete && r.safe && r.dead_markings == 0 && r.livelocks.is_empty());
    // The waypoint loop is listed as information.
    assert!(
        r.loops
            .iter()
            .any(|l| l.iter().any(|s| s.contains("MISSION.work_done"))
                && l.iter().any(|s| s.contains("MISSION.arrive"))),
        "{:#?}",
        r.loops
    );
    // The "else" branch by priority is a known conflict.
    assert!(r.warnings.iter().any(|w| w
        .starts_with("conflict on `DEC.next_waypoint.done`: MISSION.transit and MISSION.go_home")));
    assert!(
        !r.warnings.iter().any(|w| w.contains("can never fire")),
        "{:#?}",
        r.warnings
    );
    assert_eq!(report.nets.len(), 2);
    assert!(report.nets.iter().all(|(_, n)| n.dead_markings == 0));
}

const TWO_NETS: &str =
    "[[net]]\nfile = \"a.toml\"\nactive = true\n[[net]]\nfile = \"b.toml\"\nactive = true\n";

#[test]
fn a_seeded_unsafe_place_is_found_with_the_shortest_sequence() {
    let report = verify(&[
        (
            "project.toml",
            "[globals]\nbusy = false\n[[net]]\nfile = \"a.toml\"\nactive = true\n",
        ),
        (
            "a.toml",
            r#"name = "A"
places = ["idle", "one", "two"]
initial = ["idle"]
final = ["idle"]
[[transition]]
name = "start"
from = ["idle"]
to = ["one", "@busy"]
on = "go"
[[transition]]
name = "again"
from = ["one"]
to = ["two", "@busy"]
on = "go"
[[transition]]
name = "reset"
from = ["two", "@busy"]
to = ["idle"]
on = "reset"
"#,
        ),
    ]);
    let r = &report.project;
    assert!(!r.safe);
    assert_eq!(
        r.unsafe_example.as_deref(),
        Some(
            &[
                "go → A.start".to_owned(),
                "go ✗ A.again would put a second token in @busy".to_owned()
            ][..]
        )
    );
    assert!(!report.holds());
    assert!(!report.nets[0].1.safe, "the net's own verdict says so too");
}

#[test]
fn a_deadlock_is_found_with_the_shortest_sequence_and_final_places_are_not_deadlocks() {
    let report = verify(&[
        (
            "project.toml",
            "[programs.DEC.functions]\nplan = {}\n[[net]]\nfile = \"a.toml\"\nactive = true\n",
        ),
        (
            "a.toml",
            r#"name = "A"
places = ["ground", "asking", "flying", "stuck", "landed"]
initial = ["ground"]
final = ["landed"]
[[transition]]
name = "ask"
from = ["ground"]
to = ["asking"]
on = "ready"
do = ["call DEC.plan"]
[[transition]]
name = "fly"
from = ["asking"]
to = ["flying"]
on = "DEC.plan.done"
[[transition]]
name = "land"
from = ["flying"]
to = ["landed"]
on = "landed"
"#,
        ),
    ]);
    let r = &report.project;
    // DEC.plan.failed is not handled: A waits in `asking` forever.
    assert_eq!(r.dead_markings, 1);
    assert_eq!(
        r.deadlock_example.as_deref(),
        Some(&["ready → A.ask".to_owned(), "DEC.plan.failed".to_owned()][..])
    );
    assert!(r.safe);
}

#[test]
fn an_immediate_transition_livelock_is_an_error_with_its_sequence() {
    let report = verify(&[
        (
            "project.toml",
            "[limits]\nfirings_per_step = 20\n[[net]]\nfile = \"a.toml\"\nactive = true\n",
        ),
        (
            "a.toml",
            r#"name = "A"
places = ["idle", "ping", "pong"]
initial = ["idle"]
[[transition]]
name = "start"
from = ["idle"]
to = ["ping"]
on = "go"
[[transition]]
name = "there"
from = ["ping"]
to = ["pong"]
[[transition]]
name = "back"
from = ["pong"]
to = ["ping"]
"#,
        ),
    ]);
    let r = &report.project;
    assert!(!r.livelocks.is_empty());
    assert_eq!(r.livelocks[0].len(), 1);
    assert!(
        r.livelocks[0][0].starts_with("go → A.start, A.there, A.back"),
        "{:?}",
        r.livelocks[0]
    );
    assert!(
        r.livelocks[0][0].ends_with("✗ livelock: 20 immediate firings"),
        "{:?}",
        r.livelocks[0]
    );
    assert!(!report.holds());
}

#[test]
fn a_loop_of_internally_emitted_events_is_an_error() {
    let report = verify(&[
        (
            "project.toml",
            "[limits]\nsteps_per_input = 30\n[[net]]\nfile = \"a.toml\"\nactive = true\n",
        ),
        (
            "a.toml",
            r#"name = "A"
places = ["idle", "ping", "pong"]
initial = ["idle"]
[[transition]]
name = "start"
from = ["idle"]
to = ["ping"]
on = "go"
do = ["emit ball"]
[[transition]]
name = "hit"
from = ["ping"]
to = ["pong"]
on = "ball"
do = ["emit ball"]
[[transition]]
name = "back"
from = ["pong"]
to = ["ping"]
on = "ball"
do = ["emit ball"]
"#,
        ),
    ]);
    let r = &report.project;
    assert_eq!(r.livelocks.len(), 1);
    assert!(
        r.livelocks[0][0].ends_with("✗ livelock: 30 emitted events"),
        "{:?}",
        r.livelocks
    );
}

#[test]
fn every_warning() {
    let report = verify(&[
        ("project.toml", TWO_NETS),
        (
            "a.toml",
            r#"name = "A"
places = ["p", "q", "r", "never"]
initial = ["p"]
final = ["q", "r"]
[[transition]]
name = "first"
from = ["p"]
to = ["q"]
on = "e"
do = ["emit shout"]
[[transition]]
name = "second"
from = ["p"]
to = ["r"]
on = "e"
[[transition]]
name = "dead"
from = ["never"]
to = ["p"]
on = "e"
"#,
        ),
        (
            "b.toml",
            r#"name = "B"
places = ["s", "t"]
initial = ["s"]
final = ["t"]
[[transition]]
name = "wait"
from = ["s"]
to = ["t"]
on = "ghost"
"#,
        ),
    ]);
    let w = &report.project.warnings;
    let has = |text: &str| w.iter().any(|x| x == text);
    assert!(has("conflict on `e`: A.first and A.second share input place A.p; A.first is declared first and wins"), "{w:#?}");
    assert!(has("transition A.second can never fire"), "{w:#?}");
    assert!(has("transition A.dead can never fire"), "{w:#?}");
    assert!(
        has("event `shout` is emitted but no transition waits for it"),
        "{w:#?}"
    );
    assert!(
        w.iter()
            .any(|x| x.starts_with("event `ghost` (awaited by B.wait) is produced by nothing")),
        "{w:#?}"
    );
    // Each net's report carries the warnings about it only.
    let b = &report.nets.iter().find(|(n, _)| n == "B").expect("B").1;
    assert!(
        b.warnings.iter().all(|x| !x.contains("A.")),
        "{:#?}",
        b.warnings
    );
    assert!(report.holds(), "warnings do not fail a check");
}

#[test]
fn the_players_semantics_reach_less_than_the_token_game() {
    // In the plain token game, `late` can fire after `emergency` and put a
    // second token in `done`, and so can `second` in `r`. The player never
    // lets either happen: once the catastrophic `engine_failure` fires a
    // transition, the nominal `tick` is dropped; and `first`, declared
    // first, always takes `p` on `e` before `second` can.
    let files = [
        ("project.toml", "[events]\nengine_failure = \"catastrophic\"\n[[net]]\nfile = \"a.toml\"\nactive = true\n"),
        ("a.toml", r#"name = "A"
places = ["flying", "gliding", "landed", "done", "p", "q", "r"]
initial = ["flying", "done", "p", "r"]
final = ["gliding", "landed"]
[[transition]]
name = "emergency"
from = ["flying"]
to = ["gliding"]
on = "engine_failure"
[[transition]]
name = "late"
from = ["gliding"]
to = ["landed", "done"]
on = "tick"
[[transition]]
name = "first"
from = ["p"]
to = ["q"]
on = "e"
[[transition]]
name = "second"
from = ["p"]
to = ["r"]
on = "e"
"#),
    ];
    let project = common::project(&files);
    let ptnet = token_game(&project);
    let game = explore(&ptnet, &PtOptions::default());
    assert!(!game.summary.safe);
    assert_eq!(game.summary.max_tokens, 2);
    let report = check(&project, &Options::default());
    let r = &report.project;
    assert!(r.safe, "{r:#?}");
    assert_eq!(r.unsafe_example, None);
    assert!(
        r.warnings
            .iter()
            .any(|w| w == "transition A.late can never fire"),
        "{:#?}",
        r.warnings
    );
    assert!(
        r.warnings
            .iter()
            .any(|w| w == "transition A.second can never fire"),
        "{:#?}",
        r.warnings
    );
    assert!(report.holds());
}

fn example_files() -> Vec<(String, String)> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-survey");
    ["project.toml", "mission.toml", "events.toml"]
        .iter()
        .map(|n| {
            (
                n.to_string(),
                std::fs::read_to_string(dir.join(n)).expect("example"),
            )
        })
        .collect()
}

#[test]
fn exported_pnml_is_a_plain_pt_net_with_globals_resolved() {
    use nets::verify::export::export_net;
    use nets::verify::pnml::read_ptnet;
    let files = example_files();
    let refs: Vec<(&str, &str)> = files
        .iter()
        .map(|(a, b)| (a.as_str(), b.as_str()))
        .collect();
    let project = common::project(&refs);
    let events = project.net("EVENTS").expect("EVENTS");
    let pt = read_ptnet(&export_net(&project, events)).expect("other tools can read it");
    let net = &project.nets[events];
    assert_eq!(pt.places.len(), project.globals.len() + net.places.len());
    assert_eq!(pt.transitions.len(), net.transitions.len());
    let place = |name: &str| pt.places.iter().position(|p| p.name == name).expect(name);
    let glide = pt
        .transitions
        .iter()
        .find(|t| t.name == "payload_failure")
        .expect("transition");
    // from watching and @flying (the reference resolved to the global place)
    let mut pre: Vec<usize> = glide.pre.iter().map(|(p, _)| *p).collect();
    pre.sort();
    let mut expected = vec![place("watching"), place("flying")];
    expected.sort();
    assert_eq!(pre, expected);
    assert_eq!(pt.places[place("watching")].initial, 1);
    assert_eq!(pt.places[place("flying")].initial, 0);
}

#[test]
fn importing_what_we_export_gives_the_same_nets_back() {
    use nets::verify::export::{export_net, import_net};
    let files = example_files();
    let refs: Vec<(&str, &str)> = files
        .iter()
        .map(|(a, b)| (a.as_str(), b.as_str()))
        .collect();
    let original = common::project(&refs);
    let mut back: Vec<(String, String)> = vec![files[0].clone()];
    for (file, text) in &files[1..] {
        let name = toml::from_str::<toml::Table>(text).expect("toml")["name"]
            .as_str()
            .expect("name")
            .to_owned();
        let n = original.net(&name).expect("net");
        let (imported, active) = import_net(&export_net(&original, n)).expect("imports");
        assert_eq!(active, original.nets[n].active_at_start);
        back.push((file.clone(), imported));
    }
    let refs: Vec<(&str, &str)> = back.iter().map(|(a, b)| (a.as_str(), b.as_str())).collect();
    let again = common::project(&refs);
    assert_eq!(again.nets.len(), original.nets.len());
    for (a, b) in original.nets.iter().zip(&again.nets) {
        assert_eq!(a.name, b.name);
        let places = |n: &nets::model::Net| {
            n.places
                .iter()
                .map(|p| (p.name.clone(), p.initial, p.is_final))
                .collect::<Vec<_>>()
        };
        assert_eq!(places(a), places(b));
        assert_eq!(a.transitions.len(), b.transitions.len());
        for (x, y) in a.transitions.iter().zip(&b.transitions) {
            assert_eq!(x.name, y.name);
            assert_eq!(x.inputs, y.inputs, "{}", x.name);
            assert_eq!(x.outputs, y.outputs, "{}", x.name);
            assert_eq!(x.event, y.event);
            assert_eq!(
                x.guard.as_ref().map(|g| &g.text),
                y.guard.as_ref().map(|g| &g.text)
            );
            assert_eq!(x.action_source, y.action_source);
        }
    }
}
