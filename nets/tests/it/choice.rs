//! Intended choices between siblings (transitions waiting for one event
//! that share an input place): `else` and `priority` are what the player
//! does and what the verifier explores; guards proven exclusive, declared
//! ranks and conflicts that never arise are not warned about; every other
//! conflict is.

use crate::common;
use nets::verify::project::{check, Options};
use nets::{Event, Player};

const EVENTS: &str = "[events.e]\nparams = [\"x\"]\n";

fn project(net: &str) -> std::sync::Arc<nets::Project> {
    common::project(&[
        (
            "project.toml",
            &format!("{EVENTS}[[net]]\nfile = \"n.toml\"\nactive = true\n"),
        ),
        ("n.toml", net),
    ])
}

const HEAD: &str = "name = \"N\"\nplaces = [\"p\", \"q\", \"r\", \"s\"]\ninitial = [\"p\"]\nfinal = [\"q\", \"r\", \"s\"]\n";

fn transition(name: &str, to: &str, extra: &str) -> String {
    format!(
        "[[transition]]\nname = \"{name}\"\nfrom = [\"p\"]\nto = [\"{to}\"]\non = \"e\"\n{extra}"
    )
}

/// What fires on one occurrence of `e {x}` in the initial state.
fn fires(project: &std::sync::Arc<nets::Project>, x: i64) -> Vec<String> {
    let mut player = Player::start(project.clone(), 0);
    common::drain(&mut player);
    common::fire(&mut player, &Event::new("e").param("x", x), 1)
}

fn conflicts(project: &std::sync::Arc<nets::Project>) -> Vec<String> {
    check(project, &Options::default())
        .project
        .warnings
        .into_iter()
        .filter(|w| w.starts_with("conflict"))
        .collect()
}

#[test]
fn an_else_declared_first_is_still_tried_after_its_siblings() {
    let p = project(&format!(
        "{HEAD}{}{}",
        transition("fallback", "q", "else = true\n"),
        transition("main", "r", "when = \"x > 1\"\n"),
    ));
    assert_eq!(fires(&p, 2), ["N.main"]);
    assert_eq!(fires(&p, 0), ["N.fallback"]);
    // The verifier explores both, and the choice is intended.
    let report = check(&p, &Options::default());
    assert!(report.holds(), "{report:#?}");
    assert!(report.project.warnings.is_empty(), "{report:#?}");
}

#[test]
fn the_higher_priority_wins_whatever_the_declaration_order() {
    let p = project(&format!(
        "{HEAD}{}{}{}",
        transition("low", "q", ""),
        transition("high", "r", "priority = 2\n"),
        transition("fallback", "s", "else = true\n"),
    ));
    assert_eq!(fires(&p, 0), ["N.high"]);
    // The verifier runs the same player: `low` and `fallback` never fire.
    let w = check(&p, &Options::default()).project.warnings;
    assert_eq!(
        w,
        [
            "transition N.low can never fire",
            "transition N.fallback can never fire"
        ],
        "{w:#?}"
    );
}

#[test]
fn a_rejected_sibling_leaves_the_event_to_the_else() {
    // `main` would put a second token in `q`: rejected, so `fallback`
    // takes the event, as a later declared sibling did before.
    let p = project(
        "name = \"N\"\nplaces = [\"p\", \"q\", \"r\"]\ninitial = [\"p\", \"q\"]\nfinal = [\"r\"]\n\
         [[transition]]\nname = \"main\"\nfrom = [\"p\"]\nto = [\"q\"]\non = \"e\"\n\
         [[transition]]\nname = \"fallback\"\nfrom = [\"p\"]\nto = [\"r\"]\non = \"e\"\nelse = true\n",
    );
    assert_eq!(fires(&p, 0), ["N.fallback"]);
}

#[test]
fn without_declarations_the_first_declared_still_wins() {
    let p = project(&format!(
        "{HEAD}{}{}",
        transition("first", "q", ""),
        transition("second", "r", ""),
    ));
    assert_eq!(fires(&p, 0), ["N.first"]);
    assert_eq!(
        conflicts(&p),
        ["conflict on `e`: N.first and N.second share input place N.p; N.first is declared first and wins"]
    );
}

#[test]
fn guards_proven_exclusive_are_an_intended_choice_others_are_warned_about() {
    let silent = project(&format!(
        "{HEAD}{}{}{}",
        transition("one", "q", "when = \"x == 1\"\n"),
        transition("two", "r", "when = \"x == 2\"\n"),
        transition("many", "s", "when = \"x > 2 || x < 1\"\n"),
    ));
    assert_eq!(conflicts(&silent), Vec::<String>::new());
    let overlapping = project(&format!(
        "{HEAD}{}{}",
        transition("one", "q", "when = \"x == 1\"\n"),
        transition("some", "r", "when = \"x >= 1\"\n"),
    ));
    assert_eq!(
        conflicts(&overlapping),
        ["conflict on `e`: N.one and N.some share input place N.p; N.one is declared first and wins"]
    );
}

#[test]
fn equal_priorities_leave_a_conflict() {
    let p = project(&format!(
        "{HEAD}{}{}{}",
        transition("a", "q", "priority = 1\n"),
        transition("b", "r", "priority = 1\n"),
        transition("c", "s", ""),
    ));
    assert_eq!(
        conflicts(&p),
        ["conflict on `e`: N.a and N.b share input place N.p; N.a is declared first and wins"]
    );
}

#[test]
fn a_conflict_the_exploration_shows_never_arises_is_not_reported() {
    // `p` and `q` are never marked together: `a` and `b` share `@g` but
    // are never enabled at once.
    let project = common::project(&[
        (
            "project.toml",
            "[globals]\ng = true\n[events]\ne = \"nominal\"\ngo = \"nominal\"\n[[net]]\nfile = \"n.toml\"\nactive = true\n",
        ),
        (
            "n.toml",
            "name = \"N\"\nplaces = [\"p\", \"q\", \"done\"]\ninitial = [\"p\"]\nfinal = [\"done\"]\n\
             [[transition]]\nname = \"move\"\nfrom = [\"p\"]\nto = [\"q\"]\non = \"go\"\n\
             [[transition]]\nname = \"a\"\nfrom = [\"p\", \"@g\"]\nto = [\"done\"]\non = \"e\"\n\
             [[transition]]\nname = \"b\"\nfrom = [\"q\", \"@g\"]\nto = [\"done\"]\non = \"e\"\n",
        ),
    ]);
    assert_eq!(conflicts(&project), Vec::<String>::new());
    // Stopped early, the exploration proves nothing: the conflict is listed.
    let partial = check(
        &project,
        &Options {
            max_states: 1,
            ..Options::default()
        },
    );
    assert!(
        partial
            .project
            .warnings
            .iter()
            .any(|w| w.starts_with("conflict on `e`: N.a and N.b")),
        "{:#?}",
        partial.project.warnings
    );
}

fn example(name: &str) -> Vec<(String, String)> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name);
    let read = |n: &str| std::fs::read_to_string(dir.join(n)).expect("example");
    let project = read("project.toml");
    let table: toml::Table = toml::from_str(&project).expect("project.toml");
    let mut files = vec![("project.toml".to_owned(), project.clone())];
    for net in table["net"].as_array().expect("[[net]]") {
        let file = net["file"].as_str().expect("file");
        files.push((file.to_owned(), read(file)));
    }
    files
}

#[test]
fn a_genuine_conflict_added_to_the_example_is_the_one_warning() {
    let mut files = example("uav-survey");
    let before = check(&common::project_from(&files), &Options::default());
    assert!(
        before.project.warnings.is_empty(),
        "{:#?}",
        before.project.warnings
    );
    // Logging a payload failure from `watching` competes with EVENTS'
    // reaction whenever the vehicle flies: a real conflict.
    let events = files
        .iter_mut()
        .find(|(n, _)| n == "events.toml")
        .expect("events.toml");
    events.1.push_str(
        "\n[[transition]]\nname = \"log_payload_failure\"\nfrom = [\"watching\"]\nto = [\"watching\"]\non = \"payload_failure\"\n",
    );
    let after = check(&common::project_from(&files), &Options::default());
    assert_eq!(
        after.project.warnings,
        ["conflict on `payload_failure`: EVENTS.payload_failure and EVENTS.log_payload_failure share input place EVENTS.watching; EVENTS.payload_failure is declared first and wins"],
    );
}

#[test]
fn the_examples_declarations_keep_the_declaration_order() {
    // Their `else` and priorities state what the first declared winning
    // already did: the player tries every event's transitions in file order.
    for name in ["uav-survey", "uav-flight-test"] {
        let project = common::project_from(&example(name));
        let declared = project
            .triggers
            .values()
            .flatten()
            .filter(|&&(n, t)| {
                project.nets[n].transitions[t].choice != nets::model::Choice::Ordinary
            })
            .count();
        assert!(declared > 0, "{name} declares choices");
        for (event, waiting) in &project.triggers {
            let mut sorted = waiting.clone();
            sorted.sort_unstable();
            assert_eq!(waiting, &sorted, "{name}: {event}");
        }
    }
}

#[test]
fn a_rank_moves_a_transition_before_its_lower_siblings_and_keeps_the_rest_in_order() {
    // x (from p, q), z (from q) and y (from p, priority 5): y outranks its
    // sibling x, which keeps its place before its equal sibling z.
    let p = project(
        "name = \"N\"\nplaces = [\"p\", \"q\", \"r\"]\ninitial = [\"p\", \"q\"]\nfinal = [\"r\"]\n\
         [[transition]]\nname = \"x\"\nfrom = [\"p\", \"q\"]\nto = [\"r\"]\non = \"e\"\n\
         [[transition]]\nname = \"z\"\nfrom = [\"q\"]\nto = [\"r\"]\non = \"e\"\n\
         [[transition]]\nname = \"y\"\nfrom = [\"p\"]\nto = []\non = \"e\"\npriority = 5\n",
    );
    let names: Vec<&str> = p.triggers["e"]
        .iter()
        .map(|&(n, t)| p.nets[n].transitions[t].name.as_str())
        .collect();
    assert_eq!(names, ["y", "x", "z"]);
    assert_eq!(fires(&p, 0), ["N.y", "N.z"]);
}
