//! `petrel check --pnml` end to end: exit codes, the JSON object, errors.

use crate::scratch;

use std::path::{Path, PathBuf};
use std::process::Command;

use scratch::Scratch;

fn petrel(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .args(args)
        .output()
        .expect("petrel runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// miette's text for people without its frame and line wrapping.
fn plain(err: &str) -> String {
    err.split_whitespace()
        .filter(|w| !matches!(*w, "×" | "│"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn json_of(out: &str) -> serde_json::Value {
    serde_json::from_str(out.trim()).unwrap_or_else(|e| panic!("not one JSON object ({e}): {out}"))
}

/// Writes `body` (places, transitions, arcs) as a PNML file in a scratch
/// folder: the folder (to hold while the file is used) and the file.
fn pnml_file(name: &str, body: &str) -> (Scratch, PathBuf) {
    let dir = Scratch::new("check-pnml");
    let path = dir.join(name);
    let text = format!(
        "<?xml version=\"1.0\"?>\n<pnml xmlns=\"http://www.pnml.org/version-2009/grammar/pnml\">\n\
         <net id=\"{name}\" type=\"http://www.pnml.org/version-2009/grammar/ptnet\">\n<page id=\"pg\">\n{body}\n</page>\n</net>\n</pnml>\n"
    );
    std::fs::write(&path, text).expect("scratch file");
    (dir, path)
}

fn shared_pnml(file: &str) -> Option<String> {
    let path = sitl_tests::skip::shared_dir().join("pnml").join(file);
    if path.is_file() {
        return Some(path.display().to_string());
    }
    if std::env::var("CI").as_deref() == Ok("true") {
        panic!("{} is missing (CI=true)", path.display());
    }
    sitl_tests::skip::skip(&format!("{} not found", path.display()));
    None
}

/// A 1-safe ring of three places: no deadlock, one loop.
const RING: &str = r#"<place id="a"><initialMarking><text>1</text></initialMarking></place>
<place id="b"/><place id="c"/>
<transition id="ab"/><transition id="bc"/><transition id="ca"/>
<arc id="1" source="a" target="ab"/><arc id="2" source="ab" target="b"/>
<arc id="3" source="b" target="bc"/><arc id="4" source="bc" target="c"/>
<arc id="5" source="c" target="ca"/><arc id="6" source="ca" target="a"/>"#;

#[test]
fn a_safe_live_net_passes_with_exit_0() {
    let (_dir, f) = pnml_file("ring.pnml", RING);
    let (code, out, err) = petrel(&["check", "--pnml", f.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let j = json_of(&out);
    assert_eq!(j["states"], 3);
    assert_eq!(j["edges"], 3);
    assert_eq!(j["dead_markings"], 0);
    assert_eq!(j["safe"], true);
    assert_eq!(j["max_tokens"], 1);
    assert_eq!(j["deadlock_example"], serde_json::Value::Null);
    assert_eq!(j["unsafe_example"], serde_json::Value::Null);
    assert_eq!(
        j["loops"],
        serde_json::json!([{"states": 3, "prefix": [], "cycle": ["ab", "bc", "ca"]}])
    );
    assert_eq!(j["warnings"], serde_json::json!([]));
    assert!(j["seconds"].as_f64().is_some());
    // and the report for people
    let (code, out, _) = petrel(&["check", "--pnml", f.to_str().unwrap()]);
    assert_eq!(code, 0);
    assert!(out.contains("OK: 1-safe and deadlock-free"), "{out}");
}

#[test]
fn an_unsafe_net_with_a_deadlock_fails_with_exit_1() {
    // `go` puts a second token in `b` after `fill`; `stop` empties `a` for good.
    let (_dir, f) = pnml_file(
        "unsafe.pnml",
        r#"<place id="a"><initialMarking><text>1</text></initialMarking></place>
<place id="b"><initialMarking><text>1</text></initialMarking></place>
<transition id="fill"><name><text>fill b</text></name></transition>
<arc id="1" source="a" target="fill"/><arc id="2" source="fill" target="b"/>"#,
    );
    let (code, out, err) = petrel(&[
        "check",
        "--pnml",
        f.to_str().unwrap(),
        "--json",
        "--threads",
        "2",
    ]);
    assert_eq!(code, 1, "{err}");
    let j = json_of(&out);
    assert_eq!(j["states"], 2);
    assert_eq!(j["safe"], false);
    assert_eq!(j["max_tokens"], 2);
    assert_eq!(j["dead_markings"], 1);
    assert_eq!(j["unsafe_example"], serde_json::json!(["fill b"]));
    assert_eq!(j["deadlock_example"], serde_json::json!(["fill b"]));
}

#[test]
fn an_unbounded_net_stops_at_the_state_limit() {
    let (_dir, f) = pnml_file(
        "unbounded.pnml",
        r#"<place id="src"><initialMarking><text>1</text></initialMarking></place><place id="sink"/>
<transition id="gen"/>
<arc id="1" source="src" target="gen"/><arc id="2" source="gen" target="src"/><arc id="3" source="gen" target="sink"/>"#,
    );
    let file = f.to_str().unwrap();
    // exactly at the limit on one thread; after the level passing it on two
    for (threads, most) in [("1", 100), ("2", 200)] {
        let args = [
            "check",
            "--pnml",
            file,
            "--json",
            "--max-states",
            "100",
            "--threads",
            threads,
        ];
        let (code, out, _) = petrel(&args);
        assert_eq!(code, 1);
        let j = json_of(&out);
        assert_eq!(j["complete"], false);
        let states = j["states"].as_u64().unwrap();
        assert!(
            (100..=most).contains(&states),
            "{states} states on {threads} thread(s)"
        );
        let warning = j["warnings"][0].as_str().unwrap();
        assert!(warning.contains("state limit reached"), "{j}");
    }
    let (_, out, _) = petrel(&[
        "check",
        "--pnml",
        file,
        "--max-states",
        "100",
        "--threads",
        "1",
    ]);
    assert!(out.contains("INCONCLUSIVE"), "{out}");
}

#[test]
fn bad_input_exits_2_with_the_position() {
    let (_dir, f) = pnml_file(
        "dangling.pnml",
        "<place id=\"a\"/>\n<arc id=\"x\" source=\"a\" target=\"nowhere\"/>",
    );
    let (code, out, err) = petrel(&["check", "--pnml", f.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(out.is_empty());
    assert!(
        plain(&err)
            .contains("dangling.pnml:6:1: arc `x`: target `nowhere` is not a node of the net"),
        "{err}"
    );
    let (code, _, err) = petrel(&["check", "--pnml", "/no/such/file.pnml"]);
    assert_eq!(code, 2);
    assert!(
        plain(&err).contains("cannot read /no/such/file.pnml"),
        "{err}"
    );
    let (code, _, _) = petrel(&["check"]);
    assert_eq!(code, 2);
    let (code, _, err) = petrel(&["check", "some-project"]);
    assert_eq!(code, 2);
    assert!(plain(&err).contains("some-project"), "{err}");
    let (code, _, _) = petrel(&["check", "--pnml", f.to_str().unwrap(), "--threads", "0"]);
    assert_eq!(code, 2);
}

#[test]
fn mcc_nets_through_the_binary() {
    let Some(phil) = shared_pnml("Philosophers-PT-000005.pnml") else {
        return;
    };
    let (code, out, err) = petrel(&["check", "--pnml", &phil, "--json"]);
    assert_eq!(code, 1, "{err}");
    let j = json_of(&out);
    assert_eq!(
        (
            j["states"].as_u64(),
            j["edges"].as_u64(),
            j["dead_markings"].as_u64()
        ),
        (Some(243), Some(945), Some(2))
    );
    assert_eq!(j["deadlock_example"].as_array().map(Vec::len), Some(5));
    let Some(db) = shared_pnml("DatabaseWithMutex-PT-02.pnml") else {
        return;
    };
    let (code, out, err) = petrel(&["check", "--pnml", &db, "--json"]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(json_of(&out)["states"], 153);
    let Some(cs) = shared_pnml("CSRepetitions-PT-02.pnml") else {
        return;
    };
    let (code, out, _) = petrel(&["check", "--pnml", &cs, "--json", "--threads", "2"]);
    assert_eq!(code, 1);
    let j = json_of(&out);
    assert_eq!(
        (
            j["states"].as_u64(),
            j["edges"].as_u64(),
            j["max_tokens"].as_u64()
        ),
        (Some(7424), Some(37088), Some(2))
    );
    assert_eq!(j["safe"], false);
}

/// A project folder `name` (the project's name) in a scratch folder, of
/// (file name, text) pairs: the scratch folder, to hold while the project
/// is used, and the project's.
fn project_dir(name: &str, files: &[(&str, &str)]) -> (Scratch, PathBuf) {
    let scratch = Scratch::new("check");
    let dir = scratch.join(name);
    std::fs::create_dir(&dir).expect("the project's folder");
    for (file, text) in files {
        std::fs::write(dir.join(file), text).expect("scratch file");
    }
    (scratch, dir)
}

/// A net awaiting events of ArduPilot's built-in profile (declared nowhere
/// in the project) and `strike`, which only the project's profile layer
/// produces. The profile makes `engine_failure` catastrophic: its lockout
/// drops the `landed` (mission) that would put a second token in `home`.
const ELABORATED: &str = r#"name = "A"
places = ["ground", "flying", "gliding", "landed", "home"]
initial = ["ground", "home"]
final = ["gliding", "landed"]
[[transition]]
name = "up"
from = ["ground"]
to = ["flying"]
on = "takeoff"
[[transition]]
name = "crash"
from = ["flying"]
to = ["gliding"]
on = "engine_failure"
[[transition]]
name = "struck"
from = ["flying"]
to = ["gliding"]
on = "strike"
[[transition]]
name = "down"
from = ["flying"]
to = ["landed"]
on = "landed"
[[transition]]
name = "late"
from = ["gliding"]
to = ["home"]
on = "landed"
"#;

#[test]
fn a_project_is_checked_with_the_events_its_profile_produces() {
    let (_scratch, dir) = project_dir(
        "elaborated",
        &[
            (
                "project.toml",
                "[[net]]\nfile = \"a.toml\"\nactive = true\n[gateway]\nprofile = \"extra.toml\"\n",
            ),
            ("a.toml", ELABORATED),
            (
                "extra.toml",
                "[rules.strike]\ncategory = \"catastrophic\"\nwhen = \"HEARTBEAT.custom_mode == 99\"\n",
            ),
        ],
    );
    let d = dir.to_str().unwrap();
    let warnings = |j: &serde_json::Value| -> Vec<String> {
        j["warnings"]
            .as_array()
            .expect("warnings")
            .iter()
            .map(|w| w.as_str().unwrap_or_default().to_owned())
            .collect()
    };
    // `[gateway] profile`: the layer over ArduPilot's.
    let (code, out, err) = petrel(&["check", d, "--json"]);
    assert_eq!(code, 0, "{out}{err}");
    let j = json_of(&out);
    assert_eq!(j["safe"], true, "{j}");
    assert_eq!(warnings(&j), ["transition A.late can never fire"], "{j}");
    // The issue's keys, for the project and for each net under "nets".
    for obj in [&j, &j["nets"]["A"]] {
        for key in [
            "states",
            "edges",
            "dead_markings",
            "safe",
            "max_tokens",
            "deadlock_example",
            "unsafe_example",
            "loops",
            "warnings",
            "seconds",
        ] {
            assert!(obj.get(key).is_some(), "missing {key}: {obj}");
        }
    }
    assert_eq!(j["nets"].as_object().map(|m| m.len()), Some(1));
    // ArduPilot's alone (`--profile`, as `petrel run`): nothing produces
    // `strike`, which A.struck then waits for in vain: the project does
    // not load (bad input), pointing at the `on`.
    let (code, out, err) = petrel(&["check", d, "--json", "--profile", "ardupilot"]);
    assert_eq!(code, 2, "{out}{err}");
    let on = ELABORATED
        .lines()
        .position(|l| l == "on = \"strike\"")
        .expect("A.struck")
        + 1;
    assert!(
        plain(&err).contains(&format!(
            "a.toml:{on}:6: event `strike` (awaited by A.struck) is produced by nothing: no elaboration rule or [events] declaration"
        )),
        "{err}"
    );
    // A profile that cannot be read is bad input.
    let (code, out, err) = petrel(&["check", d, "--profile", "no-such-layer.toml"]);
    assert_eq!(code, 2, "{out}");
    assert!(
        plain(&err).contains("cannot read the profile no-such-layer.toml"),
        "{err}"
    );
    // The project's name defaults to its folder's; no progress line when
    // stderr is not a terminal.
    let (code, out, err) = petrel(&["check", d]);
    assert_eq!(code, 0);
    assert!(out.starts_with("project elaborated: "), "{out}");
    assert!(err.is_empty(), "{err}");
}

#[test]
fn each_net_is_checked_alone_too() {
    // A fills @ready on `go`; B waits for it: alone, B is dead at the start
    // (information, no warning: it relies on A by design); the project
    // holds.
    let (_scratch, dir) = project_dir(
        "alone",
        &[
            (
                "project.toml",
                "[globals]\nready = false\n[[net]]\nfile = \"a.toml\"\nactive = true\n[[net]]\nfile = \"b.toml\"\nactive = true\n[events.go]\ncategory = \"mission\"\n",
            ),
            (
                "a.toml",
                "name = \"A\"\nplaces = [\"idle\", \"sent\"]\ninitial = [\"idle\"]\nfinal = [\"sent\"]\n[[transition]]\nname = \"fill\"\nfrom = [\"idle\"]\nto = [\"sent\", \"@ready\"]\non = \"go\"\n",
            ),
            (
                "b.toml",
                "name = \"B\"\nplaces = [\"waiting\", \"done\"]\ninitial = [\"waiting\"]\nfinal = [\"done\"]\n[[transition]]\nname = \"take\"\nfrom = [\"waiting\", \"@ready\"]\nto = [\"done\"]\n",
            ),
        ],
    );
    let d = dir.to_str().unwrap();
    let (code, out, err) = petrel(&["check", d, "--json"]);
    assert_eq!(code, 0, "{out}{err}");
    let j = json_of(&out);
    assert_eq!(j["holds"], true, "{j}");
    let relies = "B alone can reach a dead marking (it relies on other nets): at the start";
    assert_eq!(j["relies"], serde_json::json!([relies]), "{j}");
    assert_eq!(j["nets"]["B"]["relies"], serde_json::json!([relies]));
    assert_eq!(j["warnings"], serde_json::json!([]), "{j}");
    assert_eq!(j["nets"]["B"]["warnings"], serde_json::json!([]));
    for net in ["A", "B"] {
        let alone = &j["nets"][net]["alone"];
        for key in [
            "states",
            "edges",
            "dead_markings",
            "safe",
            "max_tokens",
            "deadlock_example",
            "unsafe_example",
            "livelocks",
            "loops",
            "warnings",
            "complete",
        ] {
            assert!(alone.get(key).is_some(), "{net}: missing {key}: {alone}");
        }
        // The net in its project keeps its keys beside it.
        assert!(j["nets"][net].get("seconds").is_some());
    }
    let b = &j["nets"]["B"]["alone"];
    assert_eq!(
        (b["states"].as_u64(), b["edges"].as_u64()),
        (Some(1), Some(0))
    );
    assert_eq!(b["dead_markings"], 1);
    assert_eq!(b["deadlock_example"], serde_json::json!([]));
    assert_eq!(b["unsafe_example"], serde_json::Value::Null);
    assert_eq!(b["safe"], true);
    assert_eq!(b["max_tokens"], 1, "`waiting` holds its token");
    let a = &j["nets"]["A"]["alone"];
    assert_eq!(
        (a["states"].as_u64(), a["edges"].as_u64()),
        (Some(2), Some(1))
    );
    assert_eq!(a["dead_markings"], 0);
    assert_eq!(a["max_tokens"], 1);
    // For people: one line per net alone.
    let (code, out, _) = petrel(&["check", d]);
    assert_eq!(code, 0);
    assert!(
        out.contains("  alone: 2 states, 1 steps; safe, no deadlock, no livelock\n"),
        "{out}"
    );
    assert!(
        out.contains(
            "  alone: 1 states, 0 steps; safe, dead without the other nets, no livelock\n"
        ),
        "{out}"
    );
    assert!(
        out.contains(&format!(
            "  nets relying on others (information): 1\n    - {relies}\n"
        )),
        "{out}"
    );
    assert!(!out.contains("warning"), "{out}");
    assert!(!out.contains("DEADLOCK"), "{out}");
}

#[test]
fn a_project_check_stops_at_the_state_limit_given() {
    // The two-robot example: 2,071 states reduced; stopped at 100.
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/ugv-bottleneck");
    let d = example.to_str().unwrap();
    let (code, out, err) = petrel(&[
        "check",
        d,
        "--json",
        "--max-states",
        "100",
        "--threads",
        "1",
    ]);
    assert_eq!(code, 1, "{out}{err}");
    let j = json_of(&out);
    assert_eq!(j["holds"], false, "{j}");
    assert_eq!(j["complete"], false, "{j}");
    let states = j["states"].as_u64().unwrap_or(0);
    assert!((100..2_071).contains(&states), "{states} states");
}

/// The two-robot fixture of `nets` with its bottleneck left unguarded, in a
/// scratch folder.
fn unguarded_team() -> Scratch {
    let from = Path::new(env!("CARGO_MANIFEST_DIR")).join("../nets/tests/fixtures/team");
    let dir = Scratch::new("check-team-unguarded");
    for f in ["project.toml", "move.toml", "watch.toml"] {
        let text = std::fs::read_to_string(from.join(f)).expect("fixture");
        let text = text
            .replace(
                "from = [\"waiting\", \"@bottleneck_free\"]",
                "from = [\"waiting\"]",
            )
            .replace(
                "to = [\"through\", \"@bottleneck_free\"]",
                "to = [\"through\"]",
            );
        std::fs::write(dir.join(f), text).expect("scratch file");
    }
    dir
}

#[test]
fn a_team_project_reports_two_vehicles_in_a_shared_resource_step_by_step() {
    let team = Path::new(env!("CARGO_MANIFEST_DIR")).join("../nets/tests/fixtures/team");
    let (code, out, err) = petrel(&["check", team.to_str().unwrap()]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(!out.contains("mutual exclusion"), "{out}");

    let dir = unguarded_team();
    let (code, out, err) = petrel(&["check", dir.to_str().unwrap()]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(
        out.contains(
            "  mutual exclusion FAILED: `bottleneck` held by R1 and R2 at once, reached by:\n\
             \x20      1. at_gate@R1 → MOVE@R1.arrive, MOVE@R1.enter\n\
             \x20      2. at_gate@R2 → MOVE@R2.arrive, MOVE@R2.enter\n"
        ),
        "{out}"
    );
    let (_, out, _) = petrel(&["check", dir.to_str().unwrap(), "--json"]);
    let report = json_of(&out);
    assert_eq!(
        report["exclusion"][0]["vehicles"],
        serde_json::json!(["R1", "R2"]),
        "{report}"
    );
}

/// examples/uav-survey with one letter missing from an awaited event, in a
/// scratch copy: the copy and the `on`'s line.
fn survey_with_a_typo() -> (Scratch, PathBuf, usize) {
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-survey");
    let read = |f: &str| std::fs::read_to_string(example.join(f)).expect("the example");
    let events = read("events.toml");
    let line = events
        .lines()
        .position(|l| l == "on = \"engine_failure\"")
        .expect("EVENTS waits for engine_failure")
        + 1;
    let typo = events.replacen("on = \"engine_failure\"", "on = \"engine_failur\"", 1);
    let (scratch, dir) = project_dir(
        "typo",
        &[
            ("project.toml", &read("project.toml")),
            ("mission.toml", &read("mission.toml")),
            ("events.toml", &typo),
        ],
    );
    (scratch, dir, line)
}

#[test]
fn a_typo_in_an_awaited_event_is_refused_with_the_name_meant() {
    let (_scratch, dir, line) = survey_with_a_typo();
    let d = dir.to_str().unwrap();
    let expected = format!(
        "events.toml:{line}:6: event `engine_failur` (awaited by EVENTS.engine_failure) is produced by nothing: no elaboration rule or [events] declaration, no net emits it, and it is no timer, answer or result of EVENTS; did you mean `engine_failure`?"
    );
    // `petrel check`: bad input, before exploring.
    let (code, out, err) = petrel(&["check", d]);
    assert_eq!(code, 2, "{out}{err}");
    assert!(plain(&err).contains(&expected), "{err}");
    assert!(!out.contains("every property holds"), "{out}");
    // `petrel run`, even unchecked, refuses it before any link opens; so
    // do `play` and `draw`.
    let (code, _, err) = petrel(&[
        "run",
        d,
        "--mavlink",
        "udpin:127.0.0.1:0",
        "--duration",
        "0.3",
        "--no-record",
        "--unchecked",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(plain(&err).contains(&expected), "{err}");
    let script =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-survey/scripts/nominal.jsonl");
    let (code, _, err) = petrel(&["play", d, "--events", script.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(plain(&err).contains(&expected), "{err}");
    let (code, _, err) = petrel(&["draw", d]);
    assert_eq!(code, 2, "{err}");
    assert!(plain(&err).contains(&expected), "{err}");
}
