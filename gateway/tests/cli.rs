//! `petrel play` end to end: the binary on the example's scripts.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn petrel(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("petrel runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn play_prints_json_lines_of_inputs_firings_and_effects() {
    let (code, out, err) = petrel(&[
        "play",
        "examples/uav-survey",
        "--events",
        "examples/uav-survey/scripts/payload_failure.jsonl",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let lines: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).expect("every line is JSON"))
        .collect();
    let fired: Vec<String> = lines
        .iter()
        .filter(|l| l["effect"] == "fired")
        .map(|l| {
            format!(
                "{}.{}",
                l["net"].as_str().unwrap_or("?"),
                l["transition"].as_str().unwrap_or("?")
            )
        })
        .collect();
    assert_eq!(
        &fired[5..9],
        [
            "MISSION.arrive",
            "EVENTS.payload_failure",
            "EVENTS.replanned",
            "MISSION.resume"
        ]
    );
    // Every line has its time; times never go backwards.
    let times: Vec<f64> = lines.iter().map(|l| l["t"].as_f64().expect("t")).collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]));
    // The replan call carries the failed component from the event.
    assert!(lines.iter().any(|l| l["effect"] == "call"
        && l["function"] == "replan"
        && l["args"]["failed"] == "camera"));
    // Markings are printed by name.
    assert!(lines.iter().any(|l| l["effect"] == "marking"
        && l["net"] == "MISSION"
        && l["marked"] == serde_json::json!(["landed"])));
    let end = lines.last().expect("an end line");
    assert_eq!(end["end"], true);
    assert_eq!(end["digest"].as_str().map(str::len), Some(64));
}

#[test]
fn play_for_people_shows_the_lockout() {
    let (code, out, _) = petrel(&[
        "play",
        "examples/uav-survey",
        "--events",
        "examples/uav-survey/scripts/engine_failure.jsonl",
    ]);
    assert_eq!(code, 0);
    assert!(
        out.contains("EVENT  engine_failure [catastrophic]"),
        "{out}"
    );
    assert!(
        out.contains("LOCKOUT catastrophic engine_failure fired EVENTS.engine_failure"),
        "{out}"
    );
    assert!(out.contains("drop   landed [nominal]: lockout"), "{out}");
}

#[test]
fn play_reports_bad_input_with_exit_2() {
    let dir = std::env::temp_dir().join(format!("petrel-play-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let script = dir.join("bad.jsonl");
    std::fs::write(
        &script,
        "{\"t\": 1, \"event\": \"x\"}\n{\"t\": 0.5, \"event\": \"y\"}\n",
    )
    .expect("write");
    let (code, _, err) = petrel(&[
        "play",
        "examples/uav-survey",
        "--events",
        script.to_str().expect("utf-8"),
    ]);
    assert_eq!(code, 2);
    assert!(
        err.contains("bad.jsonl:2:1: `t` goes backwards (0.5 after 1)"),
        "{err}"
    );

    std::fs::write(dir.join("project.toml"), "[[net]]\nfile = \"n.toml\"\n").expect("write");
    std::fs::write(
        dir.join("n.toml"),
        "name = \"N\"\nplaces = [\"a\"]\ninitial = [\"b\"]\n",
    )
    .expect("write");
    let (code, _, err) = petrel(&[
        "play",
        dir.to_str().expect("utf-8"),
        "--events",
        script.to_str().expect("utf-8"),
    ]);
    assert_eq!(code, 2);
    assert!(
        err.contains("n.toml:3:12: unknown place `b` in `initial`: it is not in `places`"),
        "{err}"
    );

    let (code, _, _) = petrel(&["play", "examples/uav-survey"]);
    assert_eq!(code, 2, "a missing --events is a usage error");
    let _ = std::fs::remove_dir_all(&dir);
}
