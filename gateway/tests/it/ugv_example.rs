//! examples/ugv-bottleneck through the `petrel` binary: `petrel check`
//! proves the team project (1-safe, no deadlock, never both robots in the
//! bottleneck) with no warning; without the synchronisation the exclusion
//! fails with an example naming both robots; `petrel play` scripts show
//! the nets' answers to a robot blocked in the bottleneck and to a motor
//! failure.

use crate::scratch;

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

use scratch::Scratch;

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/ugv-bottleneck")
}

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

fn check(dir: &Path) -> (i32, Value) {
    let (code, out, err) = petrel(&["check", dir.to_str().expect("a UTF-8 path"), "--json"]);
    let j = serde_json::from_str(out.trim())
        .unwrap_or_else(|e| panic!("not one JSON object ({e}): {out}{err}"));
    (code, j)
}

#[test]
fn petrel_check_proves_the_team_project_with_no_warning() {
    let (code, j) = check(&example());
    assert_eq!(code, 0, "{j}");
    assert_eq!(j["holds"], true, "{j}");
    assert_eq!(j["complete"], true);
    assert_eq!(j["safe"], true);
    assert_eq!(j["max_tokens"], 1);
    assert_eq!(j["dead_markings"], 0);
    assert_eq!(j["livelocks"], serde_json::json!([]));
    assert_eq!(j["warnings"], serde_json::json!([]), "{}", j["warnings"]);
    // The exclusion is reported only when violated.
    assert!(j.get("exclusion").is_none_or(Value::is_null), "{j}");
    // Seven nets, as in the paper: three per robot, one for the team.
    let mut nets: Vec<&str> = j["nets"]
        .as_object()
        .into_iter()
        .flatten()
        .map(|(n, _)| n.as_str())
        .collect();
    nets.sort_unstable();
    assert_eq!(
        nets,
        [
            "CORRIDOR@R1",
            "CORRIDOR@R2",
            "ROUTE@R1",
            "ROUTE@R2",
            "SAFETY@R1",
            "SAFETY@R2",
            "SYNC"
        ]
    );
    for (name, net) in j["nets"].as_object().into_iter().flatten() {
        assert_eq!(net["safe"], true, "{name}");
        assert_eq!(net["dead_markings"], 0, "{name}");
        assert_eq!(net["alone"]["safe"], true, "{name}");
        assert_eq!(net["alone"]["dead_markings"], 0, "{name}");
    }
    // The state space is explored whole (no reduction yet): a few
    // thousand states.
    let states = j["states"].as_u64().expect("states");
    assert!((1000..100_000).contains(&states), "{states}");
}

/// Copies the example into a scratch folder, with `edit` applied to one
/// net file.
fn variant(name: &str, file: &str, edit: impl Fn(String) -> String) -> Scratch {
    let dir = Scratch::new(&format!("ugv-example-{name}"));
    for entry in std::fs::read_dir(example()).expect("the example") {
        let path = entry.expect("an entry").path();
        if path.is_file() {
            let to = dir.join(path.file_name().expect("a file name"));
            std::fs::copy(&path, &to).expect("copied");
        }
    }
    let path = dir.join(file);
    let text = std::fs::read_to_string(&path).expect("the net");
    let edited = edit(text.clone());
    assert_ne!(edited, text, "the edit changed nothing");
    std::fs::write(&path, edited).expect("written");
    dir
}

#[test]
fn without_the_synchronisation_both_robots_can_be_in_the_bottleneck() {
    // CORRIDOR enters without taking the global place, and leaves without
    // giving it back.
    let dir = variant("no-sync", "corridor.toml", |t| {
        t.replace(
            r#"from = ["cleared", "@bottleneck_free"]"#,
            r#"from = ["cleared"]"#,
        )
        .replace(r#"to = ["out", "@bottleneck_free"]"#, r#"to = ["out"]"#)
    });
    let (code, j) = check(&dir);
    assert_eq!(code, 1, "{j}");
    assert_eq!(j["holds"], false);
    let exclusion = j["exclusion"].as_array().expect("an exclusion report");
    assert_eq!(exclusion.len(), 1, "{exclusion:?}");
    let e = &exclusion[0];
    assert_eq!(e["resource"], "bottleneck");
    assert_eq!(e["vehicles"], serde_json::json!(["R1", "R2"]));
    let steps: Vec<&str> = e["example"]
        .as_array()
        .expect("steps")
        .iter()
        .filter_map(Value::as_str)
        .collect();
    // Each robot reaches its gate, then enters: the steps name the robot.
    for robot in ["R1", "R2"] {
        let entered = format!("CORRIDOR@{robot}.enter");
        assert!(
            steps.iter().any(|s| s.contains(&entered)),
            "{entered} not in {steps:?}"
        );
        let at_gate = format!("goto_reached@{robot}");
        assert!(
            steps.iter().any(|s| s.starts_with(&at_gate)),
            "{at_gate} not in {steps:?}"
        );
    }
    // For people too.
    let (_, out, _) = petrel(&["check", dir.to_str().expect("a UTF-8 path")]);
    assert!(
        out.contains("mutual exclusion FAILED: `bottleneck` held by R1 and R2 at once"),
        "{out}"
    );
}

/// `petrel play --json` of one of the example's scripts: its lines.
fn play(script: &str) -> Vec<Value> {
    let dir = example();
    let events = dir.join("scripts").join(script);
    let (code, out, err) = petrel(&[
        "play",
        dir.to_str().expect("a UTF-8 path"),
        "--events",
        events.to_str().expect("a UTF-8 path"),
        "--json",
    ]);
    assert_eq!(code, 0, "{out}{err}");
    out.lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

/// The transitions fired, as `NET.transition`, in order.
fn fired(lines: &[Value]) -> Vec<String> {
    lines
        .iter()
        .filter(|l| l["effect"] == "fired")
        .map(|l| {
            format!(
                "{}.{}",
                l["net"].as_str().unwrap_or("?"),
                l["transition"].as_str().unwrap_or("?")
            )
        })
        .collect()
}

/// The last marking of each net.
fn markings(lines: &[Value]) -> std::collections::BTreeMap<String, Vec<String>> {
    let mut m = std::collections::BTreeMap::new();
    for l in lines.iter().filter(|l| l["effect"] == "marking") {
        let places = l["marked"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(Value::as_str)
            .map(str::to_owned)
            .collect();
        m.insert(l["net"].as_str().unwrap_or("?").to_owned(), places);
    }
    m
}

/// Never both robots inside the bottleneck, in any marking the play went
/// through; returns how many times each robot entered.
fn entries_one_at_a_time(lines: &[Value]) -> (usize, usize) {
    let mut inside = [false, false];
    let mut entered = [0, 0];
    for l in lines.iter().filter(|l| l["effect"] == "marking") {
        let robot = match l["net"].as_str() {
            Some("CORRIDOR@R1") => 0,
            Some("CORRIDOR@R2") => 1,
            _ => continue,
        };
        let now = l["marked"]
            .as_array()
            .into_iter()
            .flatten()
            .any(|p| p == "inside" || p == "blocked");
        if now && !inside[robot] {
            entered[robot] += 1;
        }
        inside[robot] = now;
        assert!(!(inside[0] && inside[1]), "both inside at {}", l["t"]);
    }
    (entered[0], entered[1])
}

#[test]
fn nominal_both_cross_in_turn_and_finish() {
    let lines = play("nominal.jsonl");
    let f = fired(&lines);
    // R2 reached its gate while R1 was inside: it waited, asking again.
    let busy = f
        .iter()
        .position(|t| t == "CORRIDOR@R2.busy")
        .expect("R2 waited");
    let r1_out = f
        .iter()
        .position(|t| t == "CORRIDOR@R1.leave")
        .expect("R1 out");
    let r2_in = f
        .iter()
        .position(|t| t == "CORRIDOR@R2.enter")
        .expect("R2 in");
    assert!(busy < r1_out && r1_out < r2_in, "{f:?}");
    assert_eq!(entries_one_at_a_time(&lines), (1, 1));
    let m = markings(&lines);
    assert_eq!(m["ROUTE@R1"], ["done"]);
    assert_eq!(m["ROUTE@R2"], ["done"]);
    assert_eq!(m["CORRIDOR@R1"], ["out"]);
    assert_eq!(m["CORRIDOR@R2"], ["out"]);
    assert!(!f.iter().any(|t| t.starts_with("SYNC.")), "{f:?}");
}

#[test]
fn a_robot_blocked_inside_sends_the_other_round() {
    let lines = play("blocked.jsonl");
    let f = fired(&lines);
    let order = [
        "CORRIDOR@R1.block",
        "SYNC.r1_blocked",
        "SYNC.r1_detour",
        "CORRIDOR@R2.avoid_asking",
        "CORRIDOR@R2.detoured",
        "ROUTE@R2.rerouted",
        "ROUTE@R2.end",
    ];
    let at: Vec<usize> = order
        .iter()
        .map(|t| {
            f.iter()
                .position(|x| x == t)
                .unwrap_or_else(|| panic!("{t} not in {f:?}"))
        })
        .collect();
    assert!(at.windows(2).all(|w| w[0] < w[1]), "{f:?}");
    // PLN was asked about R1, for the team.
    assert!(
        lines.iter().any(|l| l["effect"] == "call"
            && l["function"] == "replan"
            && l["args"]["blocked"] == "R1"),
        "no replan call"
    );
    // R2 never entered; R1 stays in it, holding it.
    assert_eq!(entries_one_at_a_time(&lines), (1, 0));
    let m = markings(&lines);
    assert_eq!(m["ROUTE@R2"], ["done"]);
    assert_eq!(m["CORRIDOR@R1"], ["blocked"]);
    assert_eq!(m["SYNC"], ["watching", "team"]);
}

#[test]
fn a_motor_failure_stops_the_team() {
    let lines = play("motor_failure.jsonl");
    let lockout: Vec<&Value> = lines.iter().filter(|l| l["effect"] == "lockout").collect();
    assert_eq!(lockout.len(), 1);
    assert_eq!(lockout[0]["event"], "engine_failure@R1");
    // The lockout is R1's alone (docs/nets.md, "The catastrophic lockout
    // in a team").
    assert_eq!(lockout[0]["vehicle"], "R1");
    // Both robots told to hold: R1 by its SAFETY, R2 by the team net.
    let holds: Vec<(&str, &str)> = lines
        .iter()
        .filter(|l| l["effect"] == "command" && l["args"]["mode"] == "HOLD")
        .map(|l| {
            (
                l["net"].as_str().unwrap_or("?"),
                l["vehicle"].as_str().unwrap_or("?"),
            )
        })
        .collect();
    assert_eq!(holds, [("SAFETY@R1", "R1"), ("SYNC", "R2")]);
    let m = markings(&lines);
    for net in ["ROUTE@R1", "ROUTE@R2", "CORRIDOR@R1", "CORRIDOR@R2"] {
        assert!(m[net].is_empty(), "{net}: {:?}", m[net]);
    }
    // R2 is not locked out: its events are heard (its nets are ended, so
    // nothing fires on them), none dropped for a lockout.
    assert!(!lines
        .iter()
        .any(|l| l["effect"] == "dropped" && l["reason"] == "lockout"));
    let end = lines.last().expect("the closing line");
    assert_eq!(end["lockout"], Value::Bool(false));
    assert_eq!(end["locked"], serde_json::json!(["R1"]));
}

/// PLN (pln.py) against a stand-in for the gateway's program server: the
/// hello names every function the nets call, each call is answered for the
/// robot it carries, the points are where the simulator puts them.
#[test]
fn pln_speaks_the_program_protocol() {
    use std::io::{BufRead, BufReader, Write};
    if Command::new("python3").arg("--version").output().is_err() {
        assert_ne!(
            std::env::var("CI").as_deref(),
            Ok("true"),
            "python3 missing (CI=true)"
        );
        sitl_tests::skip::skip("python3 not found");
        return;
    }
    let server = std::net::TcpListener::bind("127.0.0.1:0").expect("a port");
    let port = server.local_addr().expect("its address").port();
    let mut pln = Command::new("python3")
        .arg(example().join("pln.py"))
        .args(["--programs", &format!("tcp:127.0.0.1:{port}")])
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("pln.py starts");
    let (stream, _) = server.accept().expect("PLN connects");
    stream
        .set_read_timeout(Some(std::time::Duration::from_secs(10)))
        .expect("a timeout");
    let mut lines = BufReader::new(stream.try_clone().expect("a clone")).lines();
    let mut out = stream;
    let mut read = move || -> Value {
        let line = lines.next().expect("a line").expect("read");
        serde_json::from_str(&line).unwrap_or_else(|e| panic!("{e}: {line}"))
    };
    let hello = read();
    assert_eq!(hello["hello"], "PLN");
    for f in ["next", "cross", "detour", "replan"] {
        assert!(
            hello["functions"]
                .as_array()
                .is_some_and(|a| a.iter().any(|x| x == f)),
            "{f} not served: {hello}"
        );
    }
    writeln!(
        out,
        r#"{{"welcome": "PLN", "functions": ["cross", "detour", "next", "replan"]}}"#
    )
    .expect("sent");
    let mut id = 0;
    let mut call = |function: &str, args: Value, vehicle: Option<&str>| -> Value {
        id += 1;
        let mut c = serde_json::json!({"call": id, "function": function, "args": args});
        if let Some(v) = vehicle {
            c["vehicle"] = v.into();
        }
        writeln!(out, "{c}").expect("sent");
        let r = read();
        assert_eq!(r["reply"], id, "{r}");
        r
    };
    let home = sitl_tests::geo::Home::default();
    let is_at = |r: &Value, n: f64, e: f64| {
        let (lat, lon) = sitl_tests::geo::location(&home, sitl_tests::geo::V2::new(n, e));
        (r["params"]["lat"].as_f64().unwrap_or(0.0) - lat).abs() < 2e-7
            && (r["params"]["lon"].as_f64().unwrap_or(0.0) - lon).abs() < 2e-7
    };
    let empty = serde_json::json!({});
    // R1's route: a leg, the south gate, across to the north gate, two legs, the end.
    let r = call("next", empty.clone(), Some("R1"));
    assert_eq!(
        (&r["event"], &r["params"]["move"]),
        (&"done".into(), &"leg".into()),
        "{r}"
    );
    assert!(is_at(&r, 15.0, -20.0), "{r}");
    let r = call("next", empty.clone(), Some("R1"));
    assert_eq!(r["params"]["move"], "gate");
    assert!(is_at(&r, 15.0, 0.0), "{r}");
    // R2 not across yet: R1 blocked means R2 goes round.
    let r = call("replan", serde_json::json!({"blocked": "R1"}), None);
    assert_eq!(r["params"]["action"], "detour", "{r}");
    // Asking for the crossing (again and again while the bottleneck is
    // busy) is not crossing: R1 still has it ahead.
    for _ in 0..2 {
        let r = call("cross", empty.clone(), Some("R1"));
        assert!(is_at(&r, 45.0, 0.0), "{r}");
    }
    let r = call("replan", serde_json::json!({"blocked": "R2"}), None);
    assert_eq!(r["params"]["action"], "detour", "{r}");
    for (n, e) in [(55.0, 0.0), (55.0, -20.0)] {
        let r = call("next", empty.clone(), Some("R1"));
        assert_eq!(r["params"]["move"], "leg");
        assert!(is_at(&r, n, e), "{r}");
    }
    // R1 across: R2 blocked means nothing to change for R1.
    let r = call("replan", serde_json::json!({"blocked": "R2"}), None);
    assert_eq!(r["params"]["action"], "hold", "{r}");
    let r = call("next", empty.clone(), Some("R1"));
    assert_eq!(r["params"]["move"], "end", "{r}");
    // R2 sent round: its next moves are the east ring's.
    let r = call("detour", empty.clone(), Some("R2"));
    assert_eq!(r["params"]["legs"], 3);
    let r = call("next", empty.clone(), Some("R2"));
    assert!(is_at(&r, 45.0, 30.0), "{r}");
    // A robot the labyrinth does not know: a failure with its reason.
    let r = call("next", empty, Some("R3"));
    assert_eq!(r["event"], "failed");
    assert!(
        r["params"]["reason"]
            .as_str()
            .is_some_and(|s| s.contains("R3")),
        "{r}"
    );
    let _ = pln.kill();
    let _ = pln.wait();
}
