//! examples/uav-flight-test through the `petrel` binary: `petrel check`
//! proves it, `petrel play` flies each of its scripts — the nominal flight,
//! refused arming, payload failure, engine failures, link loss, low
//! battery, a catastrophic event followed by others, cumulative failures —
//! and the commands, program calls, drops and final markings are the ones
//! the nets must produce.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

const PROJECT: &str = "examples/uav-flight-test";

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

/// What `petrel play --json` showed of one script.
struct Played {
    lines: Vec<Value>,
    end: Value,
}

impl Played {
    fn of(script: &str) -> Played {
        let path = format!("{PROJECT}/scripts/{script}.jsonl");
        let (code, out, err) = petrel(&["play", PROJECT, "--events", &path, "--json"]);
        assert_eq!(code, 0, "{script}: {err}");
        let mut lines: Vec<Value> = out
            .lines()
            .map(|l| serde_json::from_str(l).expect("every line is JSON"))
            .collect();
        let end = lines.pop().expect("an end line");
        assert_eq!(end["end"], true, "{script}: the last line is the end");
        Played { lines, end }
    }

    fn effects<'a>(&'a self, kind: &'a str) -> impl Iterator<Item = &'a Value> + 'a {
        self.lines.iter().filter(move |l| l["effect"] == kind)
    }

    /// The commands, each as `verb` or `verb(argument)` for the argument
    /// that tells them apart (payload, mode, seq, force).
    fn commands(&self) -> Vec<String> {
        self.effects("command")
            .map(|c| {
                let verb = c["verb"].as_str().unwrap_or("?");
                let a = &c["args"];
                let arg = [&a["payload"], &a["mode"], &a["seq"], &a["force"]]
                    .into_iter()
                    .find(|v| !v.is_null())
                    .map(|v| v.as_str().map_or_else(|| v.to_string(), str::to_owned));
                match arg {
                    Some(arg) => format!("{verb}({arg})"),
                    None => verb.to_owned(),
                }
            })
            .collect()
    }

    /// When each command was sent, in seconds.
    fn command_times(&self, verb: &str) -> Vec<f64> {
        self.effects("command")
            .filter(|c| c["verb"] == verb)
            .filter_map(|c| c["t"].as_f64())
            .collect()
    }

    fn calls(&self) -> Vec<String> {
        self.effects("call")
            .map(|c| c["function"].as_str().unwrap_or("?").to_owned())
            .collect()
    }

    fn fired(&self) -> Vec<String> {
        self.effects("fired")
            .map(|f| {
                format!(
                    "{}.{}",
                    f["net"].as_str().unwrap_or("?"),
                    f["transition"].as_str().unwrap_or("?")
                )
            })
            .collect()
    }

    /// Events dropped by the catastrophic lockout.
    fn dropped(&self) -> Vec<String> {
        self.effects("dropped")
            .inspect(|d| assert_eq!(d["reason"], "lockout", "{d}"))
            .map(|d| d["event"].as_str().unwrap_or("?").to_owned())
            .collect()
    }

    fn faults(&self) -> Vec<String> {
        self.effects("fault")
            .map(|f| format!("{} {}", f["fault"].as_str().unwrap_or("?"), f["transition"]))
            .collect()
    }

    /// Each net's last marking (`@` for the global places).
    fn final_markings(&self) -> BTreeMap<String, Vec<String>> {
        let mut out = BTreeMap::new();
        for m in self.effects("marking") {
            let net = m["net"].as_str().unwrap_or("@").to_owned();
            let marked = m["marked"]
                .as_array()
                .map(|a| {
                    a.iter()
                        .filter_map(|p| p.as_str().map(str::to_owned))
                        .collect()
                })
                .unwrap_or_default();
            out.insert(net, marked);
        }
        out
    }

    fn marking(&self, net: &str) -> Vec<String> {
        self.final_markings().get(net).cloned().unwrap_or_default()
    }

    fn lockout(&self) -> bool {
        self.end["lockout"] == true
    }
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| (*s).to_owned()).collect()
}

/// The first flight's commands up to the take-off.
const PREFLIGHT: [&str; 3] = ["upload_mission", "mode(AUTO)", "arm"];

fn with_preflight(rest: &[&str]) -> Vec<String> {
    strings(&PREFLIGHT)
        .into_iter()
        .chain(strings(rest))
        .collect()
}

#[test]
fn petrel_check_proves_the_project() {
    let (code, out, err) = petrel(&["check", PROJECT, "--json"]);
    assert_eq!(code, 0, "{out}\n{err}");
    let report: Value = serde_json::from_str(out.trim()).expect("one JSON report");
    assert_eq!(report["holds"], true);
    assert_eq!(report["complete"], true);
    assert_eq!(report["safe"], true);
    assert_eq!(report["max_tokens"], 1);
    assert_eq!(report["dead_markings"], 0);
    assert_eq!(report["livelocks"], serde_json::json!([]));
    // The exact figures of this example: a faster explorer must find the
    // same states and steps (they change only when the example does:
    // 1,426,433 steps before CATASTROPHIC's site_out_of_reach, the step
    // from `locating` when DEC's site is out of the glide).
    assert_eq!(
        (report["states"].as_u64(), report["edges"].as_u64()),
        (Some(55_326), Some(1_426_434))
    );
    let nets: Vec<&str> = report["nets"]
        .as_object()
        .map(|m| m.keys().map(String::as_str).collect())
        .unwrap_or_default();
    let mut expected = vec![
        "CATASTROPHIC",
        "COMMUNICATION",
        "FLIGHT",
        "INIT",
        "MISSION",
        "OPERATIONS",
        "PAYLOAD",
        "SAFETY",
    ];
    expected.sort_unstable();
    let mut nets = nets;
    nets.sort_unstable();
    assert_eq!(nets, expected);
    for (name, net) in report["nets"].as_object().into_iter().flatten() {
        assert_eq!(net["safe"], true, "{name}");
        assert_eq!(net["dead_markings"], 0, "{name}");
    }
    // The nets' choices are all declared (`else`, `priority`) or proven
    // (guards that exclude each other, siblings never enabled together):
    // no conflict is reported. Every transition can fire (failure reasons
    // and events without a position are explored too); nothing is consumed
    // that nobody produces, or emitted for nobody: no warning at all. As
    // information, a net relies on another, found by exploring each net
    // alone: MISSION starts the flight on `@initialised`, a global place
    // only INIT fills, so alone it is dead from the start (in its project
    // it is not), as designed.
    let texts = |key: &str| -> Vec<String> {
        report[key]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(Value::as_str)
            .map(str::to_owned)
            .collect()
    };
    assert_eq!(texts("warnings"), Vec::<String>::new());
    const RELIES: &str =
        "MISSION alone can reach a dead marking (it relies on other nets): at the start";
    assert_eq!(texts("relies"), [RELIES]);
    // Each net alone: its own figures, safe and free of livelocks.
    for (name, net) in report["nets"].as_object().into_iter().flatten() {
        let alone = &net["alone"];
        assert_eq!(alone["safe"], true, "{name}");
        assert_eq!(alone["livelocks"], serde_json::json!([]), "{name}");
        assert_eq!(alone["complete"], true, "{name}");
        let dead = alone["dead_markings"].as_u64();
        assert_eq!(dead, Some(u64::from(name == "MISSION")), "{name}");
    }
}

#[test]
fn nominal_flight() {
    let p = Played::of("nominal");
    assert_eq!(
        p.commands(),
        with_preflight(&[
            "payload_start(camera)",
            "payload_stop(camera)",
            "payload_start(sensor)",
            "payload_stop(sensor)",
            "payload_start(camera)",
            "payload_stop(camera)",
            "disarm",
        ])
    );
    // DEC not connected at first: asked again; then one item per item reached.
    let mut calls = strings(&["plan", "plan"]);
    calls.extend(std::iter::repeat_n("item".to_owned(), 10));
    assert_eq!(p.calls(), calls);
    // The phases of FLIGHT in order.
    let phases: Vec<String> = p
        .fired()
        .into_iter()
        .filter(|f| {
            f.starts_with("FLIGHT.")
                && (f.contains("_to_") || f == "FLIGHT.takeoff" || f == "FLIGHT.approach")
        })
        .collect();
    assert_eq!(
        phases,
        strings(&[
            "FLIGHT.takeoff",
            "FLIGHT.climb_to_transit",
            "FLIGHT.transit_to_operations",
            "FLIGHT.operations_to_return",
            "FLIGHT.return_to_approach",
            "FLIGHT.approach",
        ])
    );
    assert_eq!(p.marking("MISSION"), ["complete"]);
    assert_eq!(p.marking("FLIGHT"), ["complete"]);
    assert_eq!(p.marking("OPERATIONS"), ["idle"]);
    assert_eq!(p.marking("INIT"), ["done"]);
    assert_eq!(p.marking("@"), ["@down"]);
    assert!(p.faults().is_empty(), "{:?}", p.faults());
    assert!(p.dropped().is_empty());
    assert!(!p.lockout());
    // The upload carries DEC's eleven items, TAKEOFF first.
    let upload = p.effects("command").next().expect("the upload");
    let items = upload["args"]["items"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    assert_eq!(items.len(), 11);
    assert_eq!(items[0]["command"], "TAKEOFF");
    assert_eq!(items[10]["command"], "LAND");
}

#[test]
fn arming_refused_twice_then_accepted() {
    let p = Played::of("arming_refused");
    assert_eq!(
        p.commands(),
        strings(&["upload_mission", "mode(AUTO)", "arm", "arm", "arm"])
    );
    // 4 s after each refusal.
    let t = p.command_times("arm");
    assert_eq!(t.len(), 3);
    for w in t.windows(2) {
        assert!((w[1] - w[0] - 4.1).abs() < 0.05, "{t:?}");
    }
    assert!(p.fired().contains(&"FLIGHT.armed_3".to_owned()));
    assert_eq!(p.marking("FLIGHT"), ["transit"]);
    assert_eq!(p.marking("MISSION"), ["nominal"]);
    assert_eq!(p.marking("@"), ["@airborne"]);
}

#[test]
fn arming_refused_five_times_gives_the_take_off_up() {
    let p = Played::of("arming_given_up");
    assert_eq!(
        p.commands(),
        strings(&[
            "upload_mission",
            "mode(AUTO)",
            "arm",
            "arm",
            "arm",
            "arm",
            "arm"
        ])
    );
    assert_eq!(p.marking("FLIGHT"), ["aborted"]);
    assert_eq!(p.marking("MISSION"), ["aborted"]);
    assert_eq!(p.marking("@"), ["@on_ground"]);
}

#[test]
fn never_ready_gives_the_take_off_up_after_five_minutes() {
    let p = Played::of("not_ready");
    assert_eq!(p.commands(), strings(&["upload_mission"]));
    let refusals = p
        .fired()
        .iter()
        .filter(|f| *f == "INIT.not_ready_yet")
        .count();
    assert_eq!(refusals, 2, "{:?}", p.fired());
    assert!(p.fired().contains(&"INIT.never_ready".to_owned()));
    assert_eq!(p.marking("MISSION"), ["not_ready"]);
    // INIT stopped everything it was doing; FLIGHT never started.
    assert!(p.marking("INIT").is_empty(), "{:?}", p.marking("INIT"));
    assert!(p.marking("FLIGHT").is_empty(), "{:?}", p.marking("FLIGHT"));
}

#[test]
fn payload_failure_replans_without_the_camera() {
    let p = Played::of("payload_failure");
    assert_eq!(
        p.commands(),
        with_preflight(&[
            "payload_start(camera)",
            "upload_mission",
            "set_current(1)",
            "payload_stop(camera)",
            "payload_start(sensor)",
            "payload_stop(sensor)",
            "disarm",
        ])
    );
    assert_eq!(
        p.calls(),
        strings(&[
            "plan",
            "plan",
            "item",
            "item",
            "item",
            "payload_failed",
            "replan",
            "adopt",
            "replan",
            "item",
            "item",
            "item",
            "item",
        ])
    );
    // The failed component goes to DEC; the new mission is DEC's.
    let failed = p
        .effects("call")
        .find(|c| c["function"] == "payload_failed")
        .expect("told");
    assert_eq!(failed["args"]["failed"], 100);
    let upload = p
        .effects("command")
        .filter(|c| c["verb"] == "upload_mission")
        .nth(1)
        .expect("replan");
    let commands: Vec<&str> = upload["args"]["items"]
        .as_array()
        .map(|a| a.iter().filter_map(|i| i["command"].as_str()).collect())
        .unwrap_or_default();
    assert_eq!(
        commands,
        [
            "WAYPOINT",
            "LOITER_TIME",
            "DO_LAND_START",
            "WAYPOINT",
            "LAND"
        ]
    );
    assert_eq!(p.marking("MISSION"), ["complete_non_nominal"]);
    assert_eq!(p.marking("PAYLOAD"), ["idle"]);
    assert_eq!(p.marking("FLIGHT"), ["complete"]);
}

#[test]
fn engine_failure_in_transit_glides_to_the_site_and_locks_out() {
    let p = Played::of("engine_failure_transit");
    assert_eq!(
        p.commands(),
        with_preflight(&["upload_mission", "set_current(1)", "mode(AUTO)", "disarm"])
    );
    let site = p
        .effects("call")
        .find(|c| c["function"] == "emergency_site")
        .expect("DEC asked");
    assert_eq!(site["args"]["lat"], -35.361);
    assert_eq!(site["args"]["alt"], 72.0);
    // DEC's site mission is what is uploaded.
    let upload = p
        .effects("command")
        .filter(|c| c["verb"] == "upload_mission")
        .nth(1)
        .expect("upload");
    assert_eq!(upload["args"]["items"][1]["command"], "LAND");
    assert!(p.lockout());
    assert_eq!(
        p.dropped(),
        strings(&[
            "payload_failure",
            "battery_low",
            "mission_item_reached",
            "landed",
            "disarmed"
        ])
    );
    // Every net but MISSION and CATASTROPHIC stopped.
    let m = p.final_markings();
    for net in ["FLIGHT", "SAFETY", "PAYLOAD", "COMMUNICATION", "INIT"] {
        assert_eq!(m.get(net).map(Vec::len), Some(0), "{net}");
    }
    assert_eq!(p.marking("CATASTROPHIC"), ["down"]);
    assert_eq!(p.marking("MISSION"), ["aborted"]);
    let after: Vec<String> = p
        .fired()
        .into_iter()
        .skip_while(|f| f != "CATASTROPHIC.engine_failure")
        .filter(|f| !f.starts_with("CATASTROPHIC.") && !f.starts_with("MISSION."))
        .collect();
    assert!(after.is_empty(), "{after:?}");
}

#[test]
fn engine_failure_without_a_position_lands_at_home() {
    let p = Played::of("engine_failure_blind");
    assert_eq!(p.commands(), with_preflight(&["land", "disarm"]));
    assert_eq!(p.faults(), ["bad_argument \"engine_failure\""]);
    assert!(p
        .fired()
        .contains(&"CATASTROPHIC.engine_failure_no_position".to_owned()));
    assert!(!p.calls().contains(&"emergency_site".to_owned()));
    assert_eq!(p.marking("CATASTROPHIC"), ["down"]);
    assert!(p.lockout());
}

#[test]
fn engine_failure_on_the_ground_disarms() {
    let p = Played::of("engine_failure_on_ground");
    assert_eq!(p.commands(), with_preflight(&["disarm"]));
    assert_eq!(p.dropped(), ["takeoff"]);
    assert_eq!(p.marking("CATASTROPHIC"), ["down"]);
    assert_eq!(p.marking("MISSION"), ["aborted"]);
}

#[test]
fn link_loss_changes_nothing_and_the_mission_completes() {
    let p = Played::of("link_loss");
    assert_eq!(
        p.commands(),
        with_preflight(&[
            "payload_start(camera)",
            // Sent as the link went: timed out, sent again, timed out, given up.
            "payload_stop(camera)",
            "payload_stop(camera)",
            "payload_start(sensor)",
            "payload_stop(sensor)",
            "payload_start(camera)",
            "payload_stop(camera)",
            "disarm",
        ])
    );
    let fired = p.fired();
    for t in [
        "COMMUNICATION.link_lost",
        "COMMUNICATION.link_restored",
        "COMMUNICATION.gcs_lost",
        "COMMUNICATION.gcs_restored",
        "OPERATIONS.camera_stop_timeout",
        "OPERATIONS.camera_stop_given_up",
    ] {
        assert!(fired.contains(&t.to_owned()), "{t}");
    }
    // A link loss is no payload failure: nothing replanned.
    let mut calls = strings(&["plan", "plan"]);
    calls.extend(std::iter::repeat_n("item".to_owned(), 10));
    assert_eq!(p.calls(), calls);
    assert!(!fired.iter().any(|f| f.starts_with("PAYLOAD.")));
    assert_eq!(p.marking("MISSION"), ["complete_non_nominal"]);
    assert_eq!(p.marking("FLIGHT"), ["complete"]);
    assert_eq!(p.marking("OPERATIONS"), ["idle"]);
}

#[test]
fn battery_low_returns_and_lands() {
    let p = Played::of("battery_low");
    assert_eq!(
        p.commands(),
        with_preflight(&[
            "payload_start(camera)",
            "payload_stop(camera)",
            "payload_start(sensor)",
            // The return: the sensor stops as it is ordered.
            "land",
            "payload_stop(sensor)",
            "rtl",
            "land",
            "disarm",
        ])
    );
    // Refused twice, asked again 2 s later.
    let t = p.command_times("land");
    assert!((t[1] - t[0] - 2.2).abs() < 0.05, "{t:?}");
    // PAYLOAD stopped by the return: the later payload failure changes nothing.
    assert_eq!(p.marking("PAYLOAD"), Vec::<String>::new());
    assert!(!p.calls().contains(&"replan".to_owned()));
    assert_eq!(p.marking("SAFETY"), ["returned"]);
    assert_eq!(p.marking("MISSION"), ["complete_non_nominal"]);
    assert_eq!(p.marking("FLIGHT"), ["complete"]);
}

#[test]
fn after_a_catastrophic_event_only_its_reaction_runs() {
    let p = Played::of("catastrophic_then_others");
    let commands = p.commands();
    let from = commands
        .iter()
        .position(|c| c == "payload_start(sensor)")
        .expect("O2")
        + 1;
    assert_eq!(
        commands[from..],
        strings(&[
            "upload_mission",
            "set_current(1)",
            "mode(AUTO)",
            "disarm",
            "disarm(true)"
        ])
    );
    assert!(p.lockout());
    assert_eq!(
        p.dropped(),
        strings(&[
            "payload_failure",
            "link_lost",
            "battery_low",
            "geofence_breach",
            "gps_lost",
            "mission_item_reached",
            "landed",
        ])
    );
    // A second catastrophic event is handled, not dropped: nothing waits for it.
    let inputs: Vec<&Value> = p
        .lines
        .iter()
        .filter(|l| l["event"] == "battery_critical")
        .collect();
    assert_eq!(inputs.len(), 1);
    assert!(!p.fired().iter().any(|f| f.contains("battery_critical")));
    let after: Vec<String> = p
        .fired()
        .into_iter()
        .skip_while(|f| f != "CATASTROPHIC.engine_failure")
        .filter(|f| !f.starts_with("CATASTROPHIC.") && !f.starts_with("MISSION."))
        .collect();
    assert!(after.is_empty(), "{after:?}");
    assert_eq!(p.calls().last().map(String::as_str), Some("emergency_site"));
    assert_eq!(p.marking("CATASTROPHIC"), ["down"]);
}

#[test]
fn cumulative_payload_failure_link_loss_and_battery_low() {
    let p = Played::of("cumulative");
    assert_eq!(
        p.commands(),
        with_preflight(&[
            "payload_start(camera)",
            "upload_mission",
            "set_current(1)",
            "set_current(1)",
            "set_current(1)",
            "payload_stop(camera)",
            "payload_start(sensor)",
            "land",
            "payload_stop(sensor)",
            "disarm",
        ])
    );
    let fired = p.fired();
    for t in [
        "PAYLOAD.replan_in_flight",
        "PAYLOAD.restart_timeout",
        "COMMUNICATION.link_lost",
        "COMMUNICATION.link_restored",
        "SAFETY.return",
        "OPERATIONS.camera_not_stopped_then_sensor",
    ] {
        assert!(fired.contains(&t.to_owned()), "{t}");
    }
    assert!(!p.lockout());
    assert_eq!(p.marking("MISSION"), ["complete_non_nominal"]);
    assert_eq!(p.marking("FLIGHT"), ["complete"]);
    assert_eq!(p.marking("SAFETY"), ["returned"]);
}

#[test]
fn every_script_is_played_here() {
    let tested = [
        "arming_given_up",
        "arming_refused",
        "battery_low",
        "catastrophic_then_others",
        "cumulative",
        "engine_failure_blind",
        "engine_failure_on_ground",
        "engine_failure_transit",
        "link_loss",
        "nominal",
        "not_ready",
        "payload_failure",
    ];
    let mut found: Vec<String> = std::fs::read_dir(root().join(PROJECT).join("scripts"))
        .expect("the scripts folder")
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            e.file_name()
                .to_str()
                .and_then(|n| n.strip_suffix(".jsonl"))
                .map(str::to_owned)
        })
        .collect();
    found.sort_unstable();
    assert_eq!(found, strings(&tested));
}

/// The payload names agree: the gateway's table, DEC's mission file, and
/// the payloads OPERATIONS commands.
#[test]
fn payload_names_agree() {
    let read = |f: &str| -> toml::Table {
        let text = std::fs::read_to_string(root().join(PROJECT).join(f)).expect("readable");
        text.parse().expect("TOML")
    };
    let project = read("project.toml");
    let gateway: Vec<&String> = project["gateway"]["payloads"]
        .as_table()
        .map(|t| t.keys().collect())
        .unwrap_or_default();
    let mission = read("mission.toml");
    let dec: Vec<&String> = mission["payloads"]
        .as_table()
        .map(|t| t.keys().collect())
        .unwrap_or_default();
    assert_eq!(gateway, dec);
    assert_eq!(
        project["gateway"]["payloads"]["camera"]["camera"].as_integer(),
        Some(100)
    );
    assert_eq!(
        mission["payloads"]["camera"]["component"].as_integer(),
        Some(100)
    );
    let operations =
        std::fs::read_to_string(root().join(PROJECT).join("operations.toml")).expect("net");
    for name in gateway {
        assert!(
            operations.contains(&format!("payload_start {{payload: {name}}}")),
            "{name}"
        );
    }
}

/// The profile layer on the recorded ArduPlane SITL flight: it loads over
/// the built-in profile, and `emergency_landed` comes with `landed`.
#[test]
fn the_profile_layer_on_the_sitl_plane_flight() {
    let tlog = sitl_tests::skip::shared_dir()
        .join("telemetry/SITL_arduplane-4.7.0dev_auto_mission_land.tlog");
    if !tlog.is_file() {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "{} is missing (CI=true)",
            tlog.display()
        );
        sitl_tests::skip::skip(&format!("{} is not there", tlog.display()));
        return;
    }
    let profile = format!("{PROJECT}/profile.toml");
    let tlog = tlog.display().to_string();
    let (code, out, err) = petrel(&["events", &tlog, "--profile", &profile, "--json"]);
    assert_eq!(code, 0, "{err}");
    let events: Vec<Value> = out
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    let at = |name: &str| -> Vec<f64> {
        events
            .iter()
            .filter(|e| e["event"] == name)
            .filter_map(|e| e["t"].as_f64())
            .collect()
    };
    let landed = at("landed");
    assert_eq!(landed.len(), 1);
    assert_eq!(at("emergency_landed"), landed);
    let e = events
        .iter()
        .find(|e| e["event"] == "emergency_landed")
        .expect("one");
    assert_eq!(e["category"], "catastrophic");
    // The items the mission flew, for DEC's numbering: 1 to 6.
    let seqs: Vec<i64> = events
        .iter()
        .filter(|e| e["event"] == "mission_item_reached")
        .filter_map(|e| e["params"]["seq"].as_i64())
        .collect();
    assert_eq!(seqs, [1, 2, 3, 4, 5, 6]);
}

/// Every catastrophic rule of the built-in ArduPilot profile, under the
/// project's layer, carries the position DEC needs to pick an emergency
/// site (a rule added to the built-in profile without it would make the
/// nets fall back to landing at home).
#[test]
fn every_catastrophic_rule_carries_the_position() {
    let layer = std::fs::read_to_string(root().join(PROJECT).join("profile.toml"))
        .expect("the project's profile layer");
    let builtin = elaboration::profile::builtin("ardupilot").expect("built in");
    let profile =
        elaboration::Profile::load(&[("ardupilot.toml", builtin), ("profile.toml", &layer)])
            .expect("the layered profile loads");
    let mut checked = 0;
    for rule in profile.rules() {
        if rule.category != nets::Category::Catastrophic || rule.event == "emergency_landed" {
            continue;
        }
        let params: Vec<&str> = rule.param_names().collect();
        for p in ["lat", "lon", "alt"] {
            assert!(
                params.contains(&p),
                "rule {} lacks {p}: {params:?}",
                rule.name
            );
        }
        checked += 1;
    }
    assert!(checked >= 6, "only {checked} catastrophic rules");
}
