//! Broken projects: each problem with its exact message and position.

use std::collections::BTreeMap;

const PROJECT: &str = r#"[globals]
flying = false
[events.wp]
params = ["seq"]
[programs.DEC.functions]
next = { args = ["index"], returns = ["lat"] }
[[net]]
file = "n.toml"
active = true
"#;

/// Loads PROJECT with the given net file; returns "file:line:col: message"
/// for every problem.
fn problems_with(project: &str, net: &str) -> Vec<String> {
    let files: BTreeMap<String, String> = [
        ("project.toml".to_owned(), project.to_owned()),
        ("n.toml".to_owned(), net.to_owned()),
    ]
    .into();
    match nets::load(&files) {
        Ok(_) => Vec::new(),
        Err(e) => e.problems.iter().map(|p| p.to_string()).collect(),
    }
}

fn problems(net: &str) -> Vec<String> {
    problems_with(PROJECT, net)
}

const HEAD: &str = "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n";

fn transition(body: &str) -> String {
    format!("{HEAD}[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\n{body}")
}

#[test]
fn a_correct_project_loads() {
    assert_eq!(
        problems(&transition(
            "on = \"wp\"\nwhen = \"seq == 3\"\ndo = [\"call DEC.next {index: $seq}\"]\n"
        )),
        Vec::<String>::new()
    );
}

#[test]
fn broken_net_files_report_the_exact_problem_and_position() {
    // (net file body after the transition header, expected problems)
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            format!("{HEAD}[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"c\"]\n"),
            vec!["n.toml:7:7: unknown place `c` in `to` of net `N`"],
        ),
        (
            format!("{HEAD}[[transition]]\nname = \"t\"\nfrom = [\"a\", \"@landed\"]\nto = [\"b\"]\n"),
            vec!["n.toml:6:14: undeclared global place `@landed`: declare it in project.toml [globals]"],
        ),
        (
            format!("{HEAD}[[transition]]\nname = \"t\"\nfrom = [\"flying\"]\nto = [\"b\"]\n"),
            vec!["n.toml:6:9: unknown place `flying` in `from` of net `N` (the global place is written `@flying`)"],
        ),
        (
            transition("on = \"wp\"\nwhen = \"altitude > 3\"\n"),
            vec!["n.toml:9:9: unknown parameter `altitude` of event `wp` (it has: seq)"],
        ),
        (
            transition("on = \"ready\"\nwhen = \"x > 3\"\n"),
            vec!["n.toml:9:9: unknown parameter `x`: event `ready` declares no parameters (declare them in project.toml: [events.\"ready\"] params = [...])"],
        ),
        (
            transition("on = \"wp\"\nwhen = \"seq = 3\"\n"),
            vec!["n.toml:9:13: in guard: `=` is not a comparison: write `==`"],
        ),
        (
            transition("when = \"true\"\n"),
            vec!["n.toml:8:8: immediate transition `t` cannot have a guard: there is no event to test (give it `on = \"EVENT\"`)"],
        ),
        (
            transition("do = [\"emit x {v: $alt}\"]\n"),
            vec!["n.toml:8:19: `$alt`: immediate transition `t` has no triggering event, so no parameters"],
        ),
        (
            transition("on = \"wp\"\ndo = [\"activate MISSON\"]\n"),
            vec!["n.toml:9:17: unknown net `MISSON`"],
        ),
        (
            transition("on = \"wp\"\ndo = [\"call PLN.route\"]\n"),
            vec!["n.toml:9:13: unknown program `PLN`: declare it in project.toml [programs]"],
        ),
        (
            transition("on = \"wp\"\ndo = [\"call DEC.nxt {index: 1}\"]\n"),
            vec!["n.toml:9:17: unknown function `nxt` of program `DEC` (it has: next)"],
        ),
        (
            transition("on = \"wp\"\ndo = [\"call DEC.next {idx: 1}\"]\n"),
            vec![
                "n.toml:9:17: DEC.next takes no argument `idx` (it takes: index)",
                "n.toml:9:17: DEC.next needs argument `index`",
            ],
        ),
        (
            transition("on = \"wp\"\ndo = [\"timer t after 30 seconds\"]\n"),
            vec!["n.toml:9:22: malformed duration `30 seconds`: expected a number and a unit, as in `30s`, `500ms`, `1.5s`, `2min` or `1h`"],
        ),
        (
            transition("on = \"wp\"\ndo = [\"cancel watchdog\"]\n"),
            vec!["n.toml:9:15: unknown timer `watchdog`: net `N` never starts it"],
        ),
        (
            transition("on = \"wp\"\ndo = [\"command fly {to: 3}\"]\n"),
            vec!["n.toml:9:16: unknown command verb `fly` (known: arm, disarm, mode, takeoff, land, rtl, goto, set_speed, upload_mission, start_mission, set_current, payload_start, payload_stop)"],
        ),
        (
            transition("on = \"wp\"\ndo = [\"command takeoff {altitude: 30}\"]\n"),
            vec![
                "n.toml:9:16: command `takeoff` takes no argument `altitude` (it takes: alt, pitch)",
                "n.toml:9:16: command `takeoff` needs argument `alt`",
            ],
        ),
        (
            transition("on = \"wp\"\ndo = [\"lanch\"]\n"),
            vec!["n.toml:9:8: in action: unknown action `lanch`: expected activate, deactivate, emit, timer, cancel, call, command or ask"],
        ),
        (
            format!("{HEAD}[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\n[[transition]]\nname = \"t\"\nfrom = [\"b\"]\nto = [\"a\"]\n"),
            vec!["n.toml:9:8: duplicate transition `t` (first declared at n.toml:5:8)"],
        ),
        (
            "name = \"N\"\nplaces = [\"a\", \"a\"]\ninitial = [\"z\"]\n".to_owned(),
            vec![
                "n.toml:2:16: duplicate place `a`",
                "n.toml:3:12: unknown place `z` in `initial`: it is not in `places`",
            ],
        ),
        (
            format!("{HEAD}[[transition]]\nname = \"t\"\nfrom = [\"a\", \"a\"]\nto = []\n"),
            vec!["n.toml:6:14: place `a` appears twice in `from`: arcs are unary"],
        ),
        (
            format!("{HEAD}[[transition]]\nname = \"t\"\nto = [\"b\"]\n"),
            vec!["n.toml:5:8: transition `t` has no input place: give it `from = [...]`"],
        ),
        (
            format!("{HEAD}[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nguard = \"x\"\n"),
            vec!["n.toml:7:1: unknown field `guard`, expected one of `name`, `description`, `from`, `to`, `on`, `when`, `do`, `else`, `priority`"],
        ),
        (
            format!("{HEAD}[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nfrom = [\"b\"]\n"),
            vec!["n.toml:7:1: duplicate key `from`: a name is declared once"],
        ),
        (
            "name = \"N\"\nplaces = [\"a\"\n".to_owned(),
            vec!["n.toml:2:14: unclosed array, expected `]`"],
        ),
        (
            // Several problems at once, in file order.
            transition("on = \"wp\"\nwhen = \"seq > 1 && alt < 3\"\ndo = [\"activate X\", \"timer w after 5 parsecs\", \"command mode\"]\n"),
            vec![
                "n.toml:9:20: unknown parameter `alt` of event `wp` (it has: seq)",
                "n.toml:10:17: unknown net `X`",
                "n.toml:10:36: malformed duration `5 parsecs`: expected a number and a unit, as in `30s`, `500ms`, `1.5s`, `2min` or `1h`",
                "n.toml:10:57: command `mode` needs argument `mode`",
            ],
        ),
    ];
    let mut failures = Vec::new();
    for (i, (net, expected)) in cases.iter().enumerate() {
        let got = problems(net);
        if got != *expected {
            failures.push(format!(
                "case {i}:\n  expected {expected:#?}\n  got      {got:#?}"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn broken_project_files_report_the_exact_problem_and_position() {
    let net = "name = \"N\"\nplaces = [\"a\"]\ninitial = [\"a\"]\n";
    let cases: Vec<(&str, Vec<&str>)> = vec![
        (
            "[[net]]\nfile = \"missing.toml\"\n",
            vec!["project.toml:2:8: cannot read net file `missing.toml`: no such file"],
        ),
        (
            "[events]\nboom = \"catastrophe\"\n[[net]]\nfile = \"n.toml\"\n",
            vec!["project.toml:2:8: unknown category `catastrophe` (expected catastrophic, safety, communication, mission or nominal)"],
        ),
        (
            "[globals]\nready = 2\n[[net]]\nfile = \"n.toml\"\n",
            vec!["project.toml:2:9: global place `ready` starts with 2 tokens: nets are safe, write 0 or 1 (or false/true)"],
        ),
        (
            "[[net]]\nfile = \"n.toml\"\n[[net]]\nfile = \"n.toml\"\n",
            vec!["n.toml:1:8: duplicate net `N` (first declared at n.toml:1:8)"],
        ),
        (
            "nets = [\"n.toml\"]\n",
            vec!["project.toml:1:1: unknown field `nets`, expected one of `name`, `description`, `net`, `globals`, `programs`, `events`, `limits`, `vehicle`, `exclusive`, `gateway`, `reload`"],
        ),
        ("", vec!["project.toml:1:1: the project has no nets: add [[net]] tables with file = \"NAME.toml\""]),
        (
            "[globals]\nflying = false\nflying = true\n[[net]]\nfile = \"n.toml\"\n",
            vec!["project.toml:3:1: duplicate key `flying`: a name is declared once"],
        ),
        (
            "[programs.DEC.functions]\nf = {}\n[programs.DEC.functions]\ng = {}\n[[net]]\nfile = \"n.toml\"\n",
            vec!["project.toml:3:15: duplicate key `functions`: a name is declared once"],
        ),
        (
            "[events]\nwp = { params = [\"seq\", \"seq\"] }\n[programs.DEC.functions]\nf = { args = [\"a\", \"a\"] }\n[[net]]\nfile = \"n.toml\"\n",
            vec![
                "project.toml:4:20: duplicate argument `a` of DEC.f",
                "project.toml:2:6: duplicate parameter `seq` of event `wp`",
            ],
        ),
        (
            "[[net]]\nfile = \"n.toml\"\ndelay = \"5 parsecs\"\n",
            vec!["project.toml:3:1: unknown field `delay`, expected `file` or `active`"],
        ),
        (
            "[programs.command.functions]\nx = {}\n[[net]]\nfile = \"n.toml\"\n",
            vec!["project.toml:1:11: `command` is reserved for vehicle commands: choose another program name"],
        ),
    ];
    let mut failures = Vec::new();
    for (i, (project, expected)) in cases.iter().enumerate() {
        let got = problems_with(project, net);
        if got != *expected {
            failures.push(format!(
                "case {i}:\n  expected {expected:#?}\n  got      {got:#?}"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn a_missing_project_file_is_a_problem_not_a_panic() {
    let files: BTreeMap<String, String> = BTreeMap::new();
    let e = nets::load(&files).expect_err("no project.toml");
    assert_eq!(
        e.problems[0].to_string(),
        "project.toml:1:1: cannot read project.toml: no such file"
    );
}

#[test]
fn the_miette_report_shows_the_line_and_a_caret() {
    let got = {
        let files: BTreeMap<String, String> = [
            ("project.toml".to_owned(), PROJECT.to_owned()),
            (
                "n.toml".to_owned(),
                transition("on = \"wp\"\ndo = [\"activate MISSON\"]\n"),
            ),
        ]
        .into();
        nets::load(&files).expect_err("broken")
    };
    let mut out = String::new();
    miette::GraphicalReportHandler::new_themed(miette::GraphicalTheme::unicode_nocolor())
        .render_report(&mut out, &got)
        .expect("renders");
    assert!(out.contains("n.toml:9:17: unknown net `MISSON`"), "{out}");
    assert!(out.contains("do = [\"activate MISSON\"]"), "{out}");
    assert!(out.contains("╰── here"), "{out}");
}

/// docs/nets.md shows every construct with an example: each TOML block must
/// be TOML, and each action, guard and duration in it (and in the actions
/// table) must parse.
#[test]
fn the_examples_in_docs_nets_md_parse() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/nets.md");
    let doc = std::fs::read_to_string(&path).expect("docs/nets.md");
    fn walk(v: &toml::Value, key: &str, checked: &mut usize, failures: &mut Vec<String>) {
        match v {
            toml::Value::Table(t) => {
                for (k, v) in t {
                    walk(v, k, checked, failures);
                }
            }
            toml::Value::Array(a) => {
                for item in a {
                    if let (true, toml::Value::String(s)) = (key == "do", item) {
                        *checked += 1;
                        if let Err(e) = nets::action::parse(s) {
                            failures.push(format!("action `{s}`: {}", e.message));
                        }
                    } else {
                        walk(item, key, checked, failures);
                    }
                }
            }
            toml::Value::String(s) if key == "when" => {
                *checked += 1;
                if let Err(e) = nets::expr::parse(s, nets::expr::Context::Guard) {
                    failures.push(format!("guard `{s}`: {}", e.message));
                }
            }
            _ => {}
        }
    }
    let mut failures = Vec::new();
    let mut blocks = 0;
    let mut checked = 0;
    let mut table = 0;
    let mut rest = doc.as_str();
    while let Some(start) = rest.find("```toml\n") {
        let body = &rest[start + 8..];
        let end = body.find("```").expect("a closed block");
        blocks += 1;
        match body[..end].parse::<toml::Table>() {
            Ok(t) => walk(&toml::Value::Table(t), "", &mut checked, &mut failures),
            Err(e) => failures.push(format!("block {blocks}: {e}")),
        }
        rest = &body[end + 3..];
    }
    // The actions table: | `FORM` | `example` | what it does |
    for line in doc.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 4 || !cells[2].starts_with('`') {
            continue;
        }
        let (form, example) = (cells[1], cells[2].trim_matches('`'));
        let is_action = [
            "`activate",
            "`deactivate",
            "`emit",
            "`timer",
            "`cancel",
            "`call",
            "`command",
        ]
        .iter()
        .any(|a| form.starts_with(a));
        if is_action {
            table += 1;
            if let Err(e) = nets::action::parse(example) {
                failures.push(format!("table action `{example}`: {}", e.message));
            }
        }
    }
    assert!(
        blocks >= 5 && checked >= 10,
        "{blocks} blocks, {checked} checked"
    );
    assert_eq!(table, 7, "one row per action in the actions table");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A net with transitions `t` (from `a`, on `wp`, then `t_extra`) and `u`
/// (from `u_from`, on `u_on`, then `u_extra`).
fn siblings(t_extra: &str, u_from: &str, u_on: &str, u_extra: &str) -> String {
    format!(
        "{HEAD}[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"wp\"\n{t_extra}\
         [[transition]]\nname = \"u\"\nfrom = [\"{u_from}\"]\nto = [\"b\"]\n{u_on}{u_extra}"
    )
}

#[test]
fn choices_that_decide_nothing_report_the_exact_problem_and_position() {
    let on = "on = \"wp\"\n";
    let cases: Vec<(String, Vec<&str>)> = vec![
        (siblings("", "a", on, "else = true\n"), vec![]),
        (siblings("priority = -1\n", "a", on, ""), vec![]),
        (
            siblings("else = true\n", "b", on, ""),
            vec!["n.toml:9:8: `else` on transition `t`, but no other transition waiting for `wp` shares an input place with it: there is no choice to fall back from"],
        ),
        (
            siblings("priority = 2\n", "a", "on = \"other\"\n", ""),
            vec!["n.toml:9:12: a priority on transition `t`, but no other transition waiting for `wp` shares an input place with it: there is no conflict to decide"],
        ),
        (
            siblings("else = true\n", "a", on, "else = true\n"),
            vec!["n.toml:15:8: `N.t` and `N.u` are both `else` for `wp` on place N.a: one transition at most falls back when no other takes the event (give the other a guard or a priority)"],
        ),
        (
            siblings("priority = 1\n", "a", on, "priority = 1\n"),
            vec![
                "n.toml:9:12: `priority = 1` on transition `t` decides nothing: its siblings on `wp` (`N.u`) have the same priority",
                "n.toml:15:12: `priority = 1` on transition `u` decides nothing: its siblings on `wp` (`N.t`) have the same priority",
            ],
        ),
        (
            siblings("priority = 0\n", "a", on, ""),
            vec!["n.toml:9:12: `priority = 0` on transition `t` decides nothing: its siblings on `wp` (`N.u`) have the same priority"],
        ),
        (
            siblings("", "a", "", "else = true\n"),
            vec!["n.toml:13:8: immediate transition `u` cannot have `else` or `priority`: immediate transitions fire one at a time in declaration order (give it `on = \"EVENT\"`)"],
        ),
        (
            siblings("else = true\npriority = 3\n", "a", on, ""),
            vec!["n.toml:9:8: transition `t` has both `else` and `priority`: an `else` transition is tried after all its siblings, whatever their priority"],
        ),
        (
            siblings("priority = \"high\"\n", "a", on, ""),
            vec!["n.toml:9:12: invalid type: string \"high\", expected i64"],
        ),
    ];
    let mut failures = Vec::new();
    for (i, (net, expected)) in cases.iter().enumerate() {
        let got = problems(net);
        if got != *expected {
            failures.push(format!(
                "case {i}:\n  expected {expected:#?}\n  got      {got:#?}"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Loads `project.toml` and `n.toml` knowing the outside: an elaboration
/// catalog of `ready_for_takeoff` only; "file:line:col: message" for every
/// problem.
fn problems_knowing_the_outside(project: &str, net: &str) -> Vec<String> {
    let files: BTreeMap<String, String> = [
        ("project.toml".to_owned(), project.to_owned()),
        ("n.toml".to_owned(), net.to_owned()),
    ]
    .into();
    let mut catalog = nets::load::Catalog::new();
    catalog.insert("ready_for_takeoff".to_owned(), Default::default());
    match nets::load_with(&files, &catalog) {
        Ok(_) => Vec::new(),
        Err(e) => e.problems.iter().map(|p| p.to_string()).collect(),
    }
}

const OUTSIDE_PROJECT: &str = r#"[events]
engine_failure = "catastrophic"
[programs.DEC.functions]
next = { returns = ["lat"] }
[[net]]
file = "n.toml"
active = true
"#;

/// A net N whose transition `t` waits for `on`, with a transition `u`
/// doing `u_do` on `ready_for_takeoff` beside it.
fn awaiting(on: &str, u_do: &str) -> String {
    format!(
        "{HEAD}[[transition]]\nname = \"u\"\nfrom = [\"a\"]\nto = [\"a\"]\non = \"ready_for_takeoff\"\ndo = [{u_do}]\n\n[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"{on}\"\n"
    )
}

#[test]
fn a_typo_in_an_awaited_event_is_a_load_error_with_the_name_meant() {
    let net = awaiting("engine_failur", "");
    assert_eq!(
        problems_knowing_the_outside(OUTSIDE_PROJECT, &net),
        ["n.toml:15:6: event `engine_failur` (awaited by N.t) is produced by nothing: no elaboration rule or [events] declaration, no net emits it, and it is no timer, answer or result of N; did you mean `engine_failure`? (an event a program or another outside source sends is declared in project.toml's [events])"]
    );
    // The catalog's events are suggested too; a name far from every
    // produced one gets no suggestion.
    let p = problems_knowing_the_outside(OUTSIDE_PROJECT, &awaiting("ready_for_takeof", ""));
    assert!(p[0].contains("did you mean `ready_for_takeoff`?"), "{p:?}");
    let p = problems_knowing_the_outside(OUTSIDE_PROJECT, &awaiting("battery_low", ""));
    assert_eq!(p.len(), 1, "{p:?}");
    assert!(
        p[0].starts_with(
            "n.toml:15:6: event `battery_low` (awaited by N.t) is produced by nothing"
        ),
        "{p:?}"
    );
    assert!(!p[0].contains("did you mean"), "{p:?}");
    // Not knowing the outside (`load`, no profile), it may come from
    // elaboration: it loads, and `petrel check`'s warning is the same text.
    let files: BTreeMap<String, String> = [
        ("project.toml".to_owned(), OUTSIDE_PROJECT.to_owned()),
        ("n.toml".to_owned(), net),
    ]
    .into();
    let project = nets::load(&files).expect("loads without a profile");
    let warnings = nets::verify::project::static_warnings(&project);
    assert!(
        warnings
            .iter()
            .any(|w| w.text.contains("did you mean `engine_failure`?")),
        "{warnings:?}"
    );
}

#[test]
fn every_producer_of_an_awaited_event_is_known_to_the_loader() {
    // (the event `t` waits for, what `u` does on ready_for_takeoff)
    let produced = [
        // [events] and the catalog (elaboration).
        ("engine_failure", ""),
        ("ready_for_takeoff", ""),
        // A net's emit.
        ("go", "\"emit go\""),
        // Its own timer, its own question's answer and timeout.
        ("w", "\"timer w after 5s\""),
        (
            "q.yes",
            r#""ask q \"Go?\" {choices: [yes, no]} timeout 10s""#,
        ),
        (
            "q.timeout",
            r#""ask q \"Go?\" {choices: [yes, no]} timeout 10s""#,
        ),
        // The results of its own call and command; net_fault.
        ("DEC.next.done", "\"call DEC.next\""),
        ("DEC.next.failed", "\"call DEC.next\""),
        ("command.ok", "\"command arm\""),
        ("command.failed", "\"command arm\""),
        ("net_fault", ""),
    ];
    for (on, u_do) in produced {
        assert_eq!(
            problems_knowing_the_outside(OUTSIDE_PROJECT, &awaiting(on, u_do)),
            Vec::<String>::new(),
            "{on} after {u_do}"
        );
    }
    // Results and answers nobody asked for, another question's answer: a
    // net hears only its own.
    let unproduced = [
        ("DEC.next.done", ""),
        ("command.ok", "\"call DEC.next\""),
        (
            "q.maybe",
            r#""ask q \"Go?\" {choices: [yes, no]} timeout 10s""#,
        ),
        ("w", "\"emit go\""),
    ];
    for (on, u_do) in unproduced {
        let p = problems_knowing_the_outside(OUTSIDE_PROJECT, &awaiting(on, u_do));
        assert_eq!(p.len(), 1, "{on} after {u_do}: {p:?}");
        assert!(
            p[0].starts_with(&format!(
                "n.toml:15:6: event `{on}` (awaited by N.t) is produced by nothing"
            )),
            "{p:?}"
        );
    }
    // A program or a script sending it: declared in [events], it loads.
    let declared = format!("[events.obstacle]\nparams = [\"range\"]\n{OUTSIDE_PROJECT}");
    assert_eq!(
        problems_knowing_the_outside(&declared, &awaiting("obstacle", "")),
        Vec::<String>::new()
    );
}

#[test]
fn a_vehicle_s_event_of_a_family_the_nets_emit_for_others_only_is_a_load_error() {
    // The four-robot fixture: SYNC tells R1 and R2 only to `detour` and
    // `resume`; R3's and R4's CORRIDOR wait in vain. One problem per `on`,
    // naming every instance.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/ugv4");
    let files: BTreeMap<String, String> = std::fs::read_dir(&dir)
        .expect("the fixture")
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let text = std::fs::read_to_string(e.path()).ok()?;
            name.ends_with(".toml").then_some((name, text))
        })
        .collect();
    assert!(nets::load(&files).is_ok(), "without a profile, it loads");
    let e = nets::load_with(&files, &nets::load::Catalog::new()).expect_err("refused");
    let p: Vec<String> = e.problems.iter().map(|p| p.to_string()).collect();
    assert_eq!(p.len(), 4, "{p:#?}");
    assert_eq!(
        p[0],
        "corridor.toml:100:6: event `detour@R3` (awaited by CORRIDOR@R3.told) is produced by nothing: of its family `detour` the nets emit `detour@R1`, `detour@R2` only, and no program or script may send it ([events] does not declare `detour`); so too in CORRIDOR@R4"
    );
}

#[test]
fn a_team_net_s_typo_is_suggested_with_its_vehicle() {
    let project = "[events]\nengine_failure = \"catastrophic\"\n[[vehicle]]\nname = \"R1\"\nsystem = 1\n[[net]]\nfile = \"n.toml\"\nactive = true\n";
    let p = problems_knowing_the_outside(project, &awaiting("engine_failur@R1", ""));
    assert_eq!(p.len(), 1, "{p:?}");
    assert!(p[0].contains("did you mean `engine_failure@R1`?"), "{p:?}");
}
