//! `petrel play` end to end: the binary on the example's scripts.

use crate::scratch;

use std::path::{Path, PathBuf};
use std::process::Command;

use scratch::Scratch;

pub(crate) fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Runs the binary from the repository's root: exit status, stdout, stderr.
pub(crate) fn petrel(args: &[&str]) -> (i32, String, String) {
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
    let dir = Scratch::new("play");
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
        err.contains("bad.jsonl:2:2: `t` goes backwards (0.5 after 1)"),
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
}

#[test]
fn a_project_that_does_not_load_prints_each_problem_once_with_its_caret_and_one_closing_line() {
    let dir = Scratch::new("unloadable");
    std::fs::write(
        dir.join("project.toml"),
        "[[net]]\nfile = \"m.toml\"\nactive = true\n",
    )
    .expect("write");
    std::fs::write(
        dir.join("m.toml"),
        "name = \"M\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"go\"\nfrom = [\"a\"]\nto = [\"zzz\"]\non = \"go\"\n",
    )
    .expect("write");
    let script = dir.join("s.jsonl");
    std::fs::write(&script, "{\"t\": 1, \"event\": \"go\"}\n").expect("write");
    let project = dir.to_str().expect("utf-8");
    let problem = "m.toml:7:7: unknown place `zzz` in `to` of net `M`";
    let closing = format!("cannot load project {project}: 1 problem in the project");
    for args in [
        vec!["check", project],
        vec!["play", project, "--events", script.to_str().expect("utf-8")],
        vec!["draw", project],
    ] {
        let (code, out, err) = petrel(&args);
        assert_eq!(code, 2, "{args:?}: {out}{err}");
        assert_eq!(err.matches(problem).count(), 1, "{args:?}: once:\n{err}");
        assert_eq!(
            err.matches("zzz").count(),
            2,
            "{args:?}: the message and the line:\n{err}"
        );
        assert!(
            err.contains(" 7 │ to = [\"zzz\"]"),
            "{args:?}: the line:\n{err}"
        );
        assert!(err.contains("╰── here"), "{args:?}: the caret:\n{err}");
        assert_eq!(err.matches(&closing).count(), 1, "{args:?}:\n{err}");
        let last = err.trim_end().lines().last().unwrap_or("");
        assert!(last.ends_with(&closing), "{args:?}: closes with it:\n{err}");
        assert!(
            !err.lines().any(|l| l.trim() == "Error:"),
            "{args:?}: no empty `Error:` line:\n{err}"
        );
    }
}

#[test]
fn check_project_reports_for_people_and_as_json_with_exit_codes() {
    let (code, out, err) = petrel(&["check", "examples/uav-survey"]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("project uav-survey:"), "{out}");
    assert!(out.contains("every property holds"), "{out}");
    let (code, out, _) = petrel(&["check", "examples/uav-survey", "--json"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(out.trim()).expect("one JSON object");
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
        assert!(v.get(key).is_some(), "missing {key}: {v}");
    }
    assert_eq!(v["safe"], true);
    assert!(v["nets"]["MISSION"]["states"]
        .as_u64()
        .is_some_and(|n| n > 0));

    // A project with a deadlock fails with exit 1 and shows the sequence.
    let dir = Scratch::new("check");
    std::fs::write(
        dir.join("project.toml"),
        "[events]\nready = \"nominal\"\n[programs.DEC.functions]\nplan = {}\n[[net]]\nfile = \"a.toml\"\nactive = true\n",
    )
    .expect("write");
    std::fs::write(
        dir.join("a.toml"),
        "name = \"A\"\nplaces = [\"ground\", \"asking\", \"flying\"]\ninitial = [\"ground\"]\nfinal = [\"flying\"]\n[[transition]]\nname = \"ask\"\nfrom = [\"ground\"]\nto = [\"asking\"]\non = \"ready\"\ndo = [\"call DEC.plan\"]\n[[transition]]\nname = \"fly\"\nfrom = [\"asking\"]\nto = [\"flying\"]\non = \"DEC.plan.done\"\n",
    )
    .expect("write");
    let (code, out, _) = petrel(&["check", dir.to_str().expect("utf-8")]);
    assert_eq!(code, 1, "{out}");
    assert!(
        out.contains("deadlocks        FAILED (1 dead markings)"),
        "{out}"
    );
    assert!(
        out.contains(" 1. ready → A.ask\n       2. DEC.plan.failed"),
        "{out}"
    );
    let (code, _, err) = petrel(&["check", "/nonexistent/project"]);
    assert_eq!(code, 2, "{err}");
}

#[test]
fn export_writes_pnml_that_check_reads_and_draw_writes_dot() {
    let dir = Scratch::new("export");
    let (code, _, err) = petrel(&[
        "export",
        "examples/uav-survey",
        "--pnml",
        dir.to_str().expect("utf-8"),
    ]);
    assert_eq!(code, 0, "{err}");
    let (code, out, _) = petrel(&[
        "check",
        "--pnml",
        dir.join("EVENTS.pnml").to_str().expect("utf-8"),
        "--json",
    ]);
    // The plain token game of EVENTS alone: readable, explored, 1-safe.
    assert!(code == 0 || code == 1, "{out}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).expect("JSON");
    assert_eq!(v["safe"], true);
    let (code, out, _) = petrel(&["draw", "examples/uav-survey", "--net", "MISSION", "--dot"]);
    assert_eq!(code, 0);
    assert!(out.starts_with("digraph \"MISSION\" {"), "{out}");
    assert!(out.contains("\"MISSION:transit\""));
    let (code, _, err) = petrel(&["draw", "examples/uav-survey", "--net", "NOPE"]);
    assert_eq!(code, 2);
    assert!(
        err.contains("no net `NOPE` in the project (it has: MISSION, EVENTS)"),
        "{err}"
    );
}

/// `../shared` beside the workspace root, or why the test cannot run.
fn shared() -> Option<PathBuf> {
    let dir = sitl_tests::skip::shared_dir();
    if dir.join("telemetry").is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "../shared is missing beside the workspace root, and CI=true"
    );
    sitl_tests::skip::skip(&format!(
        "{} is missing (../shared beside the workspace root)",
        dir.join("telemetry").display()
    ));
    None
}

#[test]
fn replay_runs_a_recorded_flight_through_elaboration_and_the_nets() {
    let Some(shared) = shared() else { return };
    let tlog = shared.join("telemetry/SITL_arduplane-4.7.0dev_auto_mission_land.tlog");
    let (code, out, err) = petrel(&[
        "replay",
        tlog.to_str().expect("utf-8"),
        "examples/uav-survey",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let lines: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON"))
        .collect();
    // ArduPlane refuses the first arming (the nets ignore command_rejected:
    // it is not for them), then ready_for_takeoff fires MISSION.arm, which
    // commands an arming — printed, never sent.
    let ready = lines
        .iter()
        .position(|l| l["input"] == "event" && l["event"] == "ready_for_takeoff")
        .expect("ready_for_takeoff elaborated");
    assert_eq!(lines[ready + 1]["effect"], "fired");
    assert_eq!(lines[ready + 1]["transition"], "arm");
    let cmd = lines
        .iter()
        .find(|l| l["effect"] == "command")
        .expect("a command");
    assert_eq!(cmd["verb"], "arm");
    let t = cmd["t"].as_f64().expect("t");
    assert!((20.0..25.0).contains(&t), "{t}");
    assert!(lines
        .iter()
        .any(|l| l["event"] == "takeoff" && l["sysid"] == 1));
    assert_eq!(lines.last().expect("end")["end"], true);
    assert!(err.contains("replayed 21698 frames (0 bad)"), "{err}");
    // Replaying twice gives the same digest.
    let (_, again, _) = petrel(&[
        "replay",
        tlog.to_str().expect("utf-8"),
        "examples/uav-survey",
        "--json",
    ]);
    assert_eq!(out, again);

    let (code, _, err) = petrel(&["replay", "flight.mcap", "examples/uav-survey"]);
    assert_eq!(code, 2);
    assert!(err.contains("MCAP"), "{err}");
}

#[test]
fn play_prints_every_line_in_time_order_with_expiries_before_the_input_that_let_them_fire() {
    let dir = Scratch::new("play-order");
    // `go` and `next` come from the script: declared.
    std::fs::write(
        dir.join("project.toml"),
        "[events]\ngo = \"nominal\"\nnext = \"nominal\"\n[[net]]\nfile = \"n.toml\"\nactive = true\n",
    )
    .expect("write");
    std::fs::write(
        dir.join("n.toml"),
        "name = \"N\"\nplaces = [\"a\", \"b\", \"c\", \"d\"]\ninitial = [\"a\"]\n\
         [[transition]]\nname = \"go\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"go\"\ndo = [\"timer w after 10s\"]\n\
         [[transition]]\nname = \"late\"\nfrom = [\"b\"]\nto = [\"c\"]\non = \"w\"\n\
         [[transition]]\nname = \"on\"\nfrom = [\"c\"]\nto = [\"d\"]\non = \"next\"\n",
    )
    .expect("write");
    let script = dir.join("s.jsonl");
    std::fs::write(
        &script,
        "{\"t\": 1.5, \"event\": \"go\"}\n{\"t\": 30, \"event\": \"next\"}\n{\"t\": 40}\n",
    )
    .expect("write");
    let (code, out, err) = petrel(&[
        "play",
        dir.to_str().expect("utf-8"),
        "--events",
        script.to_str().expect("utf-8"),
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let lines: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    let times: Vec<f64> = lines.iter().filter_map(|l| l["t"].as_f64()).collect();
    assert!(
        times.windows(2).all(|w| w[0] <= w[1]),
        "out of time order: {times:?}\n{out}"
    );
    let expired = lines
        .iter()
        .position(|l| l["effect"] == "timer_expired")
        .unwrap_or_else(|| panic!("no timer expiry:\n{out}"));
    assert_eq!(lines[expired]["t"].as_f64(), Some(11.5));
    let next = lines
        .iter()
        .position(|l| l["input"] == "event" && l["event"] == "next")
        .expect("the input at 30 s");
    assert!(expired < next, "{out}");
    assert!(out.contains("\"late\""), "the expiry fired N.late:\n{out}");
}

#[test]
fn no_verb_panics_when_stdout_and_stderr_cannot_be_written() {
    let full = Path::new("/dev/full");
    if !full.exists() {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "/dev/full is missing"
        );
        sitl_tests::skip::skip("no /dev/full on this system");
        return;
    }
    let dir = Scratch::new("full");
    std::fs::write(dir.join("project.toml"), "[[net]]\nfile = \"n.toml\"\n").expect("write");
    std::fs::write(
        dir.join("n.toml"),
        "name = \"N\"\nplaces = [\"a\"]\ninitial = [\"b\"]\n",
    )
    .expect("write");
    let script = dir.join("s.jsonl");
    std::fs::write(&script, "{\"t\": 1, \"event\": \"go\"}\n").expect("write");
    let broken = dir.to_str().expect("utf-8");
    let missing = dir.join("nothing.tlog");
    let missing = missing.to_str().expect("utf-8");
    let cases: Vec<Vec<&str>> = vec![
        vec!["play", broken, "--events", script.to_str().expect("utf-8")],
        vec!["play", "examples/uav-survey", "--events", missing],
        vec!["check", broken],
        vec!["draw", broken],
        vec!["export", broken, "--out", broken],
        vec!["events", missing],
        vec!["replay", missing, broken],
        vec!["run", broken, "--mavlink", "udpin:127.0.0.1:1"],
        vec!["stubs", broken, "--out", broken],
        vec!["play", "--no-such-flag"],
    ];
    let mut failures = Vec::new();
    for args in &cases {
        let open = || {
            std::fs::OpenOptions::new()
                .write(true)
                .open(full)
                .expect("/dev/full")
        };
        let status = Command::new(env!("CARGO_BIN_EXE_petrel"))
            .args(args)
            .current_dir(root())
            .stdout(open())
            .stderr(open())
            .status()
            .expect("petrel runs");
        if status.code() != Some(2) {
            failures.push(format!("petrel {}: {status}", args.join(" ")));
        }
    }
    assert!(
        failures.is_empty(),
        "expected exit 2:\n{}",
        failures.join("\n")
    );
}

#[test]
fn replay_of_a_telemetry_log_follows_the_vehicle_named_by_sysid() {
    use elaboration::frame::serialize;
    use elaboration::TlogWriter;
    use mavlink::dialects::ardupilotmega::{
        MavAutopilot, MavMessage, MavModeFlag, MavType, HEARTBEAT_DATA,
    };
    use mavlink::{MavHeader, MavlinkVersion};
    let dir = Scratch::new("replay-sysid");
    std::fs::write(
        dir.join("project.toml"),
        "[[net]]\nfile = \"n.toml\"\nactive = true\n",
    )
    .expect("write");
    std::fs::write(
        dir.join("n.toml"),
        "name = \"N\"\nplaces = [\"flying\", \"returning\"]\ninitial = [\"flying\"]\n\
         [[transition]]\nname = \"rtl\"\nfrom = [\"flying\"]\nto = [\"returning\"]\non = \"mode_changed\"\nwhen = 'mode == \"RTL\"'\n",
    )
    .expect("write");
    // Two copters on one link: system 1 goes STABILIZE → LOITER, system 2
    // STABILIZE → RTL, each heartbeating at 1 Hz for 10 s.
    let mut w = TlogWriter::new(Vec::new());
    for s in 0..10u64 {
        for (sysid, later) in [(1u32, 5u32), (2, 6)] {
            let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                custom_mode: if s < 5 { 0 } else { later },
                mavtype: MavType::MAV_TYPE_QUADROTOR,
                autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                ..HEARTBEAT_DATA::DEFAULT
            });
            let header = MavHeader {
                system_id: sysid,
                component_id: 1,
                sequence: s as u8,
            };
            w.write_frame(
                1_700_000_000_000_000 + s * 1_000_000 + u64::from(sysid) * 1000,
                &serialize(header, MavlinkVersion::V2, &hb),
            )
            .expect("vec");
        }
    }
    let log = dir.join("two.tlog");
    std::fs::write(&log, w.into_inner().expect("vec")).expect("write");
    let fired = |extra: &[&str]| {
        let mut args = vec![
            "replay",
            log.to_str().expect("utf-8"),
            dir.to_str().expect("utf-8"),
            "--json",
        ];
        args.extend_from_slice(extra);
        let (code, out, err) = petrel(&args);
        assert_eq!(code, 0, "{err}");
        out.lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .any(|l| l["effect"] == "fired" && l["transition"] == "rtl")
    };
    assert!(
        !fired(&[]),
        "the first autopilot heard (system 1) never returns"
    );
    assert!(fired(&["--sysid", "2"]), "system 2 goes RTL");
    assert!(!fired(&["--sysid", "1"]));
}

#[test]
fn draw_svg_lays_out_every_net_without_graphviz() {
    let (code, out, err) = petrel(&["draw", "examples/uav-flight-test", "--svg"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.starts_with("<svg"), "{}", &out[..out.len().min(200)]);
    for net in ["INIT", "MISSION", "FLIGHT", "CATASTROPHIC"] {
        assert!(out.contains(&format!("data-net=\"{net}\"")), "{net}");
    }
    let (code, one, _) = petrel(&[
        "draw",
        "examples/uav-flight-test",
        "--svg",
        "--net",
        "MISSION",
    ]);
    assert_eq!(code, 0);
    assert_eq!(one.matches("class=\"net\"").count(), 1);
    let (code, _, err) = petrel(&["draw", "examples/uav-flight-test", "--svg", "--dot"]);
    assert_eq!(code, 2, "one format: {err}");
}

#[test]
fn absurd_times_and_speeds_are_bad_input_not_a_panic() {
    // `--duration 1e30` used to panic turning seconds into a `Duration`
    // (exit 101), as did a clock a million times too slow; now each is
    // refused, naming the flag, before anything opens.
    let cases: &[(&[&str], &str)] = &[
        (
            &[
                "run",
                "examples/uav-flight-test",
                "--mavlink",
                "udpin:127.0.0.1:0",
                "--no-record",
                "--duration",
                "1e30",
            ],
            "--duration must be a positive number of seconds",
        ),
        (
            &[
                "run",
                "examples/uav-flight-test",
                "--mavlink",
                "udpin:127.0.0.1:0",
                "--no-record",
                "--duration",
                "0.1",
                "--time-scale",
                "1e-300",
            ],
            "--time-scale must be a number from 0.001 to 10000",
        ),
        (
            &[
                "run",
                "examples/uav-flight-test",
                "--mavlink",
                "udpin:127.0.0.1:0",
                "--no-record",
                "--duration",
                "inf",
            ],
            "--duration must be",
        ),
        (
            &[
                "mirror",
                "examples/uav-flight-test",
                "--mavlink",
                "udpin:127.0.0.1:0",
                "--duration",
                "1e30",
            ],
            "--duration must be",
        ),
        (
            &["demo", "--no-http", "--timeout", "1e30"],
            "--timeout must be a positive number of seconds",
        ),
        (
            &["demo", "--no-http", "--speed", "1e-300"],
            "--speed must be a number",
        ),
        (
            &["demo", "--no-http", "--speed", "1e300"],
            "--speed must be a number",
        ),
        (
            &[
                "replay",
                "nowhere.mcap",
                "examples/uav-flight-test",
                "--speed",
                "1e-300",
            ],
            "--speed must be a number from 0.001 to 1000000",
        ),
    ];
    for (args, says) in cases {
        let (code, _, err) = petrel(args);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}
