//! A mission project through the `petrel` binary: `check`, `play` and
//! `compile` on examples/uav-survey-mission (docs/missions.md).

use crate::cli::{petrel, root};
use crate::scratch;

use scratch::Scratch;

const EXAMPLE: &str = "examples/uav-survey-mission";

fn fired(play: &str) -> Vec<String> {
    play.lines()
        .filter_map(|l| {
            l.split_once(" fire ")?
                .1
                .split_whitespace()
                .next()
                .map(str::to_owned)
        })
        .collect()
}

#[test]
fn a_mission_project_checks_and_plays_its_scripts() {
    let (code, out, err) = petrel(&["check", EXAMPLE]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("every property holds"), "{out}");
    let script = format!("{EXAMPLE}/scripts/link_loss.jsonl");
    let (code, out, err) = petrel(&["play", EXAMPLE, "--events", &script]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(
        fired(&out)[4..],
        [
            "MISSION.transit__link_lost_begins",
            "MISSION.link_lost_clears",
            "MISSION.transit__link_lost_begins",
            "MISSION.transit__link_lost",
            "MISSION.transit__link_lost_resume",
            "MISSION.transit_mission_item_reached",
        ]
    );
}

#[test]
fn compile_writes_nets_that_play_as_the_mission() {
    let scratch = Scratch::new("compile");
    let out_dir = scratch.path().join("nets");
    let out_arg = out_dir.to_string_lossy().into_owned();
    let (code, _, err) = petrel(&["compile", EXAMPLE, "--out", &out_arg]);
    assert_eq!(code, 0, "{err}");
    assert!(out_dir.join("steps.mission.toml").is_file());
    assert!(out_dir.join("scripts/nominal.jsonl").is_file());
    assert!(
        !out_dir.join("steps.toml").exists(),
        "the mission is not copied"
    );
    for script in ["nominal", "link_loss", "engine_failure"] {
        let events = format!("{EXAMPLE}/scripts/{script}.jsonl");
        let mission = petrel(&["play", EXAMPLE, "--events", &events, "--json"]);
        let by_hand = petrel(&["play", &out_arg, "--events", &events, "--json"]);
        assert_eq!(mission.0, 0, "{}", mission.2);
        assert_eq!(mission, by_hand, "{script}");
        assert!(mission.1.contains("\"digest\""));
    }
    // Never over an existing folder.
    let (code, _, err) = petrel(&["compile", EXAMPLE, "--out", &out_arg]);
    assert_eq!(code, 2);
    assert!(err.contains("exists"), "{err}");
}

#[test]
fn compile_refuses_bad_input_and_writes_nothing() {
    let scratch = Scratch::new("compile-bad");
    let project = scratch.path().join("p");
    std::fs::create_dir(&project).expect("a folder");
    let copy = |name: &str| {
        std::fs::copy(root().join(EXAMPLE).join(name), project.join(name)).expect("copied");
    };
    copy("project.toml");
    let steps = std::fs::read_to_string(root().join(EXAMPLE).join("steps.toml")).expect("steps");
    std::fs::write(
        project.join("steps.toml"),
        steps.replace("\"10s\"", "\"10 parsecs\""),
    )
    .expect("written");
    let out_dir = scratch.path().join("out");
    let (code, _, err) = petrel(&[
        "compile",
        &project.to_string_lossy(),
        "--out",
        &out_dir.to_string_lossy(),
    ]);
    assert_eq!(code, 2);
    assert!(
        err.contains("steps.toml:6:59: malformed duration `10 parsecs`"),
        "{err}"
    );
    let left: Vec<_> = std::fs::read_dir(scratch.path())
        .expect("listed")
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert_eq!(left, [std::ffi::OsString::from("p")], "nothing written");
    // A project without a mission has nothing to compile.
    let (code, _, err) = petrel(&[
        "compile",
        "examples/uav-survey",
        "--out",
        &out_dir.to_string_lossy(),
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("names no mission"), "{err}");
    assert!(!out_dir.exists());
}

#[test]
fn edit_refuses_a_mission_project_whose_nets_it_would_lose() {
    let (code, _, err) = petrel(&["edit", EXAMPLE, "--http", "127.0.0.1:0"]);
    assert_eq!(code, 2);
    assert!(
        err.contains("compiled from its mission steps.toml"),
        "{err}"
    );
}

#[test]
fn check_says_a_mission_problem_at_its_line_with_exit_2() {
    let scratch = Scratch::new("check-mission");
    let project = scratch.path().join("p");
    std::fs::create_dir(&project).expect("a folder");
    std::fs::copy(
        root().join(EXAMPLE).join("project.toml"),
        project.join("project.toml"),
    )
    .expect("copied");
    let steps = std::fs::read_to_string(root().join(EXAMPLE).join("steps.toml")).expect("steps");
    let steps = steps.replace("until = \"landed\"", "until = \"landd\"");
    std::fs::write(project.join("steps.toml"), steps).expect("written");
    let (code, out, err) = petrel(&["check", &project.to_string_lossy()]);
    assert_eq!(code, 2, "{out}");
    assert!(
        err.contains("steps.toml:10:38: unknown event `landd`")
            && err.contains("did you mean `landed`?"),
        "{err}"
    );
    assert!(err.contains("1 problem in the project"), "{err}");
}
