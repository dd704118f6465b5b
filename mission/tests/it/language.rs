//! The mission language end to end: missions compiled, loaded by `nets`,
//! proved by its verifier, played; problems at the mission's lines.

use std::collections::BTreeMap;
use std::sync::Arc;

use nets::load::{Catalog, PROJECT_FILE};
use nets::model::EventDecl;
use nets::verify::project::{check, Options};
use nets::{Category, Project};

/// A project folder in memory.
pub fn folder(project: &str, mission: &str) -> BTreeMap<String, String> {
    BTreeMap::from([
        (PROJECT_FILE.to_owned(), project.to_owned()),
        ("steps.toml".to_owned(), mission.to_owned()),
    ])
}

pub const PROJECT: &str = r#"name = "survey"
mission = "steps.toml"

[events]
ready_for_takeoff = "nominal"
altitude_reached = { category = "nominal", params = ["alt"] }
mission_item_reached = { category = "nominal", params = ["seq"] }
landed = "nominal"
link_lost = "communication"
link_restored = "communication"
engine_failure = "catastrophic"
battery_low = "safety"
payload_failure = { category = "mission", params = ["component"] }
gcs_lost = "communication"

[programs.DEC.functions]
replan = { args = ["failed"], returns = ["waypoints"] }
"#;

/// The 20-line example of docs/missions.md.
pub const SURVEY: &str = r#"[steps]
preflight = { until = "ready_for_takeoff" }
arm = { do = "command arm", until = "command.ok", limit = "10s", retries = 2 }
takeoff = { do = "command takeoff {alt: 120}", until = "altitude_reached", when = "alt >= 100", limit = "2min", on_limit = "land" }
transit = { do = "command mode {mode: AUTO}", until = "mission_item_reached", when = "seq == 2", limit = "3min", on_limit = "land" }
operations = { until = "mission_item_reached", when = "seq == 6", exits = [{ on = "payload_failure", do = "call DEC.replan {failed: $component}", then = "home" }] }
home = { do = "command rtl", until = "landed" }

[rules]
link_lost = { during = ["transit", "operations"], for = "10s", do = "command rtl", resume_on = "link_restored" }

[reactions.catastrophic]
engine_failure = { do = "command mode {mode: FBWA}" }

[reactions.safety]
battery_low = { then = "land" }

[reactions.communication]
gcs_lost = {}
"#;

pub fn load(files: &BTreeMap<String, String>) -> Result<Arc<Project>, Vec<String>> {
    petrel_mission::load(files, Some(&Catalog::new()))
        .map(Arc::new)
        .map_err(|e| e.problems.iter().map(ToString::to_string).collect())
}

fn proved(project: &Arc<Project>) -> Vec<Vec<String>> {
    let report = check(project, &Options::default());
    let nets: Vec<_> = report
        .nets
        .iter()
        .filter(|(_, r)| !r.holds())
        .map(|(n, r)| (n, &r.deadlock_example))
        .collect();
    assert!(
        report.holds(),
        "not proved: {:?}\n{:?}\n{:?}\nnets: {nets:?}",
        report.project.deadlock_example,
        report.project.unsafe_example,
        report.project.livelocks
    );
    assert!(
        report.project.warnings.is_empty(),
        "{:#?}",
        report.project.warnings
    );
    report.project.loops
}

#[test]
fn the_example_compiles_loads_and_is_proved() {
    let project = load(&folder(PROJECT, SURVEY)).unwrap_or_else(|p| panic!("{p:#?}"));
    let names: Vec<&str> = project.nets.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(
        names,
        ["CATASTROPHIC", "SAFETY", "COMMUNICATION", "MISSION"]
    );
    proved(&project);
}

#[test]
fn parallel_branches_join_before_the_next_step() {
    let mission = r#"[steps]
start_up = { until = "ready_for_takeoff" }
both = { branches = [["climb"], ["camera_on", "camera_check"]] }
climb = { until = "altitude_reached" }
camera_on = { do = "command payload_start {payload: camera}", until = "command.ok", exits = [{ on = "command.failed", then = "next" }] }
camera_check = { until = "mission_item_reached", limit = "30s", on_limit = "next" }
home = { do = "command rtl", until = "landed" }
"#;
    let project = load(&folder(PROJECT, mission)).unwrap_or_else(|p| panic!("{p:#?}"));
    proved(&project);
    let script = "{\"t\": 1, \"event\": \"ready_for_takeoff\"}\n{\"t\": 2, \"event\": \"altitude_reached\", \"params\": {\"alt\": 50}}\n{\"t\": 3, \"reply\": \"command.payload_start\"}\n{\"t\": 40}\n";
    let fired = crate::play::fired(&project, script);
    assert_eq!(
        fired,
        [
            "MISSION.start",
            "MISSION.start_up_ready_for_takeoff",
            "MISSION.climb_altitude_reached",
            "MISSION.camera_on_command_ok",
            "MISSION.camera_check_limit",
            "MISSION.both_join",
        ]
    );
}

#[test]
fn retries_are_bounded_and_then_lead_on() {
    let mission = r#"[steps]
arm = { do = "command arm", until = "command.ok", limit = "10s", retries = 2, on_limit = "abort" }
fly = { until = "landed" }
"#;
    let project = load(&folder(PROJECT, mission)).unwrap_or_else(|p| panic!("{p:#?}"));
    // Retries are unrolled into places: no loop at all.
    assert_eq!(proved(&project), Vec::<Vec<String>>::new());
    let fired = crate::play::fired(&project, "{\"t\": 100}\n");
    assert_eq!(
        fired,
        [
            "MISSION.start",
            "MISSION.arm_limit",
            "MISSION.arm_retry1_limit",
            "MISSION.arm_retry2_limit"
        ]
    );
    let commands = crate::play::commands(&project, "{\"t\": 100}\n");
    assert_eq!(
        commands,
        ["arm", "arm", "arm"],
        "entered three times, never a fourth"
    );
}

#[test]
fn a_loss_that_lasts_interrupts_and_the_recovery_resumes() {
    let project = load(&folder(PROJECT, SURVEY)).unwrap_or_else(|p| panic!("{p:#?}"));
    let start = "{\"t\": 1, \"event\": \"ready_for_takeoff\"}\n{\"t\": 2, \"reply\": \"command.arm\"}\n{\"t\": 3, \"event\": \"altitude_reached\", \"params\": {\"alt\": 120}}\n";
    // A short loss: nothing but the grace.
    let short = format!("{start}{{\"t\": 4, \"event\": \"link_lost\"}}\n{{\"t\": 8, \"event\": \"link_restored\"}}\n{{\"t\": 30}}\n");
    let fired = crate::play::fired(&project, &short);
    assert_eq!(
        &fired[4..],
        [
            "MISSION.transit__link_lost_begins",
            "MISSION.link_lost_clears"
        ],
        "{fired:#?}"
    );
    // A loss of 10 s: return, then resume transit (AUTO asked again).
    let long = format!("{start}{{\"t\": 4, \"event\": \"link_lost\"}}\n{{\"t\": 20, \"event\": \"link_restored\"}}\n");
    let fired = crate::play::fired(&project, &long);
    assert_eq!(
        &fired[4..],
        [
            "MISSION.transit__link_lost_begins",
            "MISSION.transit__link_lost",
            "MISSION.transit__link_lost_resume"
        ],
        "{fired:#?}"
    );
    let commands = crate::play::commands(&project, &long);
    assert_eq!(commands, ["arm", "takeoff", "mode", "rtl", "mode"]);
}

#[test]
fn a_catastrophic_reaction_stops_the_steps_and_locks_out() {
    let project = load(&folder(PROJECT, SURVEY)).unwrap_or_else(|p| panic!("{p:#?}"));
    let script = "{\"t\": 1, \"event\": \"ready_for_takeoff\"}\n{\"t\": 2, \"event\": \"engine_failure\"}\n{\"t\": 3, \"event\": \"battery_low\"}\n";
    let fired = crate::play::fired(&project, script);
    assert_eq!(
        fired,
        [
            "MISSION.start",
            "MISSION.preflight_ready_for_takeoff",
            "CATASTROPHIC.engine_failure"
        ]
    );
}

#[test]
fn loader_problems_are_at_the_mission_lines() {
    let mission = r#"[steps]
a = { until = "ready_for_takof" }
b = { do = "command rtl" }
c = { until = "landed", then = "nowhere" }
d = { until = "landed", limit = "soon" }
e = { until = "landed" }

[rules]
r = { during = ["a", "x"], on = "link_lost", resume_on = "link_restored" }
s = { during = [], on = "link_lost", then = "abort" }
t = { on = "link_lost" }

[reactions.safety]
engine_failure = {}
"#;
    let problems = load(&folder(PROJECT, mission)).err().unwrap_or_default();
    assert_eq!(
        problems,
        [
            "steps.toml:2:15: unknown event `ready_for_takof`: no elaboration rule, [events] declaration, net or mission action produces it; did you mean `ready_for_takeoff`? (an event a program or another outside source sends is declared in project.toml's [events])",
            "steps.toml:3:1: step `b` has no way out: give it `until` (the event that ends it), `exits` or a `limit`",
            "steps.toml:4:32: unknown step `nowhere`: a target is a step, next, retry, done, abort or land",
            "steps.toml:5:33: malformed duration `soon`: expected a number and a unit, as in `30s`, `500ms`, `1.5s`, `2min` or `1h`",
            "steps.toml:9:22: unknown step `x`; did you mean `a`?",
            "steps.toml:10:16: rule `s` is scoped to no step: name the steps it watches in `during`, or leave `during` out to watch them all",
            "steps.toml:11:1: rule `t` leaves its steps with no way out: give it `resume_on` (suspend the step, then enter it again) or `then` (where to go)",
            "steps.toml:14:1: event `engine_failure` is declared catastrophic: its reaction belongs in [reactions.catastrophic]",
        ],
        "{problems:#?}"
    );
}

#[test]
fn an_unreachable_step_is_named() {
    let mission = "[steps]\na = { until = \"landed\", then = \"c\" }\nb = { until = \"landed\" }\nc = { until = \"landed\" }\n";
    let problems = load(&folder(PROJECT, mission)).err().unwrap_or_default();
    assert_eq!(
        problems,
        ["steps.toml:3:1: step `b` is unreachable: no step, exit, limit, rule or reaction leads to it from the first step"]
    );
}

#[test]
fn a_problem_only_the_nets_loader_sees_points_at_the_mission() {
    // `height` is no parameter of altitude_reached: the guard is sound
    // syntax, so only the nets loader finds it, in generated text.
    let mission = "[steps]\nclimb = { until = \"altitude_reached\", when = \"height > 100\" }\n";
    let problems = load(&folder(PROJECT, mission)).err().unwrap_or_default();
    assert_eq!(problems.len(), 1, "{problems:#?}");
    assert!(
        problems[0].starts_with("steps.toml:2:46: ")
            && problems[0].contains("height")
            && problems[0].contains("(in steps.mission.toml:"),
        "{problems:#?}"
    );
}

#[test]
fn the_project_file_must_name_a_toml_file_it_can_read() {
    let files = folder(&PROJECT.replace("steps.toml", "gone.toml"), SURVEY);
    assert_eq!(
        load(&files).err().unwrap_or_default(),
        ["project.toml:2:11: cannot read the mission gone.toml: no such file"]
    );
    let files = folder(&PROJECT.replace("\"steps.toml\"", "3"), SURVEY);
    let problems = load(&files).err().unwrap_or_default();
    assert!(
        problems[0].starts_with("project.toml:2:11: `mission` names"),
        "{problems:?}"
    );
}

#[test]
fn events_of_the_profile_and_of_other_nets_are_known() {
    let mission = "[steps]\nwait = { until = \"armed\" }\nthen_go = { until = \"go\" }\n";
    let mut project = PROJECT.replace(
        "[events]",
        "[[net]]\nfile = \"hand.toml\"\nactive = true\n\n[events]",
    );
    project.push('\n');
    let mut files = folder(&project, mission);
    files.insert(
        "hand.toml".into(),
        "name = \"HAND\"\nplaces = [\"p\"]\ninitial = [\"p\"]\nfinal = [\"p\"]\n[[transition]]\nname = \"t\"\nfrom = [\"p\"]\nto = [\"p\"]\non = \"landed\"\ndo = [\"emit go\"]\n".into(),
    );
    let catalog = Catalog::from([(
        "armed".to_owned(),
        EventDecl {
            category: Some(Category::Nominal),
            params: Some(Vec::new()),
        },
    )]);
    let loaded = petrel_mission::load(&files, Some(&catalog)).map_err(|e| e.to_string());
    assert!(loaded.is_ok(), "{loaded:?}");
}

#[test]
fn the_compiled_text_names_the_mission_lines() {
    let files = folder(PROJECT, SURVEY);
    let compiled = petrel_mission::compile_project(&files, None)
        .map_err(|e| e.to_string())
        .and_then(|c| c.ok_or_else(|| "no mission".to_owned()))
        .unwrap_or_else(|e| panic!("{e}"));
    let steps = compiled
        .nets
        .iter()
        .find(|n| n.net == "MISSION")
        .map(|n| n.text.clone())
        .unwrap_or_default();
    if std::env::var_os("PETREL_SHOW").is_some() {
        println!("{}\n{steps}", compiled.project);
    }
    assert!(steps.contains("# steps.toml:5: step transit: until mission_item_reached when seq == 2\n[[transition]]\nname = \"transit_mission_item_reached\""), "{steps}");
    assert!(
        steps.contains("# steps.toml:10: rule link_lost during operations: on link_lost (for 10s)"),
        "{steps}"
    );
    assert!(
        compiled
            .project
            .contains("# (compiled) mission = \"steps.toml\"\n"),
        "{}",
        compiled.project
    );
    assert_eq!(
        compiled
            .nets
            .iter()
            .map(|n| n.path.as_str())
            .collect::<Vec<_>>(),
        [
            "steps.catastrophic.toml",
            "steps.safety.toml",
            "steps.communication.toml",
            "steps.mission.toml"
        ]
    );
}

#[test]
fn the_compiled_project_plays_as_the_mission_does() {
    let files = folder(PROJECT, SURVEY);
    let compiled = petrel_mission::compile_project(&files, None)
        .map_err(|e| e.to_string())
        .and_then(|c| c.ok_or_else(|| "no mission".to_owned()))
        .unwrap_or_else(|e| panic!("{e}"));
    // What `petrel compile` writes: hand-written nets from then on.
    let written: BTreeMap<String, String> = compiled.files().into_iter().collect();
    assert!(!written.contains_key("steps.toml"));
    let by_hand = nets::load(&written)
        .map(Arc::new)
        .unwrap_or_else(|e| panic!("{e}"));
    let mission = load(&files).unwrap_or_else(|p| panic!("{p:#?}"));
    let script = "{\"t\": 1, \"event\": \"ready_for_takeoff\"}\n{\"t\": 2, \"reply\": \"command.arm\"}\n{\"t\": 3, \"event\": \"altitude_reached\", \"params\": {\"alt\": 120}}\n{\"t\": 4, \"event\": \"link_lost\"}\n{\"t\": 20, \"event\": \"link_restored\"}\n{\"t\": 30, \"event\": \"mission_item_reached\", \"params\": {\"seq\": 2}}\n{\"t\": 40, \"event\": \"payload_failure\", \"params\": {\"component\": \"camera\"}}\n{\"t\": 41, \"reply\": \"DEC.replan\", \"params\": {\"waypoints\": 3}}\n{\"t\": 50, \"event\": \"landed\"}\n";
    let (trace, digest) = crate::play::trace(&mission, script);
    assert_eq!(
        crate::play::trace(&by_hand, script),
        (trace.clone(), digest)
    );
    assert!(
        trace.iter().any(|l| l.contains("MISSION.home_landed")),
        "{trace:#?}"
    );
    assert!(
        trace.last().is_some_and(|l| l.contains("done")),
        "{trace:#?}"
    );
}

#[test]
fn a_rule_that_leaves_and_a_reaction_that_lands_are_proved_and_played() {
    let mission = r#"name = "FLIGHT"
land = ["command land", "call DEC.replan {failed: landing}"]

[steps]
climb = { do = "command takeoff {alt: 50}", until = "altitude_reached", limit = "1min", on_limit = "abort" }
cruise = { until = "landed" }

[rules]
lost = { during = ["climb", "cruise"], on = "link_lost", do = "command rtl", then = "land" }

[reactions.safety]
battery_low = { when = "true", then = "land" }
"#;
    let project = load(&folder(PROJECT, mission)).unwrap_or_else(|p| panic!("{p:#?}"));
    assert_eq!(proved(&project), Vec::<Vec<String>>::new());
    let script = "{\"t\": 5, \"event\": \"link_lost\"}\n{\"t\": 6, \"event\": \"battery_low\"}\n";
    assert_eq!(
        crate::play::fired(&project, script),
        ["FLIGHT.start", "FLIGHT.climb__lost", "SAFETY.battery_low"]
    );
    assert_eq!(
        crate::play::commands(&project, script),
        ["takeoff", "rtl", "land", "land"]
    );
    let (trace, _) = crate::play::trace(&project, script);
    assert!(
        trace
            .iter()
            .any(|l| l.contains("deactivated") && l.contains("FLIGHT")),
        "{trace:#?}"
    );
}

#[test]
fn exits_on_one_event_are_tried_in_the_order_written() {
    let mission = r#"[steps]
wait = { until = "mission_item_reached", when = "seq > 2", then = "far", exits = [{ on = "mission_item_reached", then = "near" }] }
far = { until = "landed" }
near = { until = "landed" }
"#;
    let project = load(&folder(PROJECT, mission)).unwrap_or_else(|p| panic!("{p:#?}"));
    proved(&project);
    let reached = |seq: u32| {
        format!(
            "{{\"t\": 1, \"event\": \"mission_item_reached\", \"params\": {{\"seq\": {seq}}}}}\n"
        )
    };
    assert_eq!(
        crate::play::fired(&project, &reached(5))[1],
        "MISSION.wait_mission_item_reached"
    );
    assert_eq!(
        crate::play::fired(&project, &reached(1))[1],
        "MISSION.wait_mission_item_reached_2"
    );
}

#[test]
fn a_question_to_the_operator_ends_a_step_by_its_answers() {
    let mission = r#"name = "SURVEY"

[steps]
ask = { do = 'ask survey "Survey the area?" {choices: [yes, no]} timeout 60s', until = "survey.yes", exits = [{ on = "survey.no", then = "home" }, { on = "survey.timeout", then = "home" }] }
work = { do = "command payload_start {payload: camera}", until = "mission_item_reached", when = "seq == 6" }
home = { do = "command rtl", until = "landed" }
"#;
    let project = load(&folder(PROJECT, mission)).unwrap_or_else(|p| panic!("{p:#?}"));
    proved(&project);
    let fired = crate::play::fired(&project, "{\"t\": 61}\n");
    assert_eq!(fired, ["SURVEY.start", "SURVEY.ask_survey_timeout"]);
    let fired = crate::play::fired(
        &project,
        "{\"t\": 5, \"answer\": \"survey\", \"choice\": \"yes\"}\n",
    );
    assert_eq!(fired, ["SURVEY.start", "SURVEY.ask_survey_yes"]);
}

#[test]
fn the_steps_net_cannot_take_a_reaction_net_name() {
    let mission = "name = \"SAFETY\"\n[steps]\na = { until = \"landed\" }\n";
    assert_eq!(
        load(&folder(PROJECT, mission)).err().unwrap_or_default(),
        ["steps.toml:1:8: `SAFETY` names the net of the safety reactions: give the steps net another name"]
    );
}

/// A project with the flight phases of the paper's §3.2.3 as global places.
const PHASED: &str = r#"name = "phased"
mission = "steps.toml"

[globals]
on_ground = true
airborne = false
down = false

[events]
altitude_reached = { category = "nominal", params = ["alt"] }
landed = "nominal"
battery_low = "safety"
engine_failure = "catastrophic"
"#;

#[test]
fn phases_move_with_the_steps_and_reactions_read_them() {
    let mission = r#"[steps]
climb = { do = "command takeoff {alt: 50}", until = "altitude_reached", phase = "on_ground" }
cruise = { until = "landed", phase = "airborne" }
rest = { do = "command disarm", until = "command.ok", phase = "down", exits = [{ on = "command.failed", then = "done" }] }

[reactions.safety]
battery_low = { do = "command rtl", phases = ["airborne"] }

[reactions.catastrophic]
engine_failure = { do = "command land", then = "land", phases = ["airborne"] }
"#;
    let project = load(&folder(PHASED, mission)).unwrap_or_else(|p| panic!("{p:#?}"));
    proved(&project);
    // On the ground a low battery changes nothing; airborne it returns.
    let script = "{\"t\": 1, \"event\": \"battery_low\"}\n{\"t\": 2, \"event\": \"altitude_reached\", \"params\": {\"alt\": 50}}\n{\"t\": 3, \"event\": \"battery_low\"}\n{\"t\": 4, \"event\": \"landed\"}\n{\"t\": 5, \"event\": \"battery_low\"}\n";
    assert_eq!(
        crate::play::fired(&project, script),
        [
            "MISSION.start",
            "MISSION.climb_altitude_reached",
            "SAFETY.battery_low_airborne",
            "MISSION.cruise_landed"
        ]
    );
    let (trace, _) = crate::play::trace(&project, script);
    assert!(
        trace
            .iter()
            .any(|l| l.contains("globals") && l.contains("down")),
        "{trace:#?}"
    );
}

#[test]
fn phases_are_the_project_globals_every_step_says_and_the_first_marked() {
    let mission = r#"[steps]
climb = { until = "altitude_reached", phase = "airborne" }
cruise = { until = "landed" }
rest = { until = "landed", phase = "dwn" }
"#;
    assert_eq!(
        load(&folder(PHASED, mission)).err().unwrap_or_default(),
        [
            "steps.toml:4:36: phase `dwn` is no global place of project.toml: declare it in [globals]; did you mean `down`?",
            "steps.toml:3:1: step `cruise` has no phase: once a step has one, every step says its phase",
            "steps.toml:2:47: the mission starts in phase `airborne`: project.toml's [globals] must start it true and every other phase false (airborne is not)",
        ]
    );
}

#[test]
fn a_hand_written_net_beside_the_mission_keeps_its_own_name() {
    let project = PROJECT.replace(
        "[events]",
        "[[net]]\nfile = \"hand.toml\"\nactive = true\n\n[events]",
    );
    let mut files = folder(&project, "[steps]\na = { until = \"landed\" }\n");
    files.insert(
        "hand.toml".into(),
        "name = \"MISSION\"\nplaces = [\"p\"]\ninitial = [\"p\"]\nfinal = [\"p\"]\n".into(),
    );
    assert_eq!(
        load(&files).err().unwrap_or_default(),
        ["project.toml:2:11: the mission compiles into a net `MISSION`, the name of the hand-written net of hand.toml: give the mission (or that net) another `name`"]
    );
}

#[test]
fn a_reaction_runs_its_procedure_in_its_category_net() {
    let mission = r#"[steps]
climb = { do = "command takeoff {alt: 50}", until = "altitude_reached", phase = "on_ground" }
cruise = { until = "landed", phase = "airborne" }
rest = { until = "landed", phase = "down" }

[reactions.safety]
battery_low = { phases = ["airborne"], then = "land_home" }

[procedures.safety]
land_home = { do = "command land", until = "command.ok", then = "abort", exits = [{ on = "command.failed", then = "rtl_home" }] }
rtl_home = { do = "command rtl", until = "command.ok", then = "abort", exits = [{ on = "command.failed", then = "done" }] }

[reactions.catastrophic]
engine_failure = { then = "glide" }

[procedures.catastrophic]
# After the lockout only catastrophic events and the reaction's own
# results come: a glide waits for the autopilot's answer, not `landed`.
glide = { do = "command mode {mode: FBWA}", until = "command.ok", exits = [{ on = "command.failed", then = "glide_again" }] }
glide_again = { do = "command mode {mode: FBWA}", until = "command.ok", limit = "5s", on_limit = "done" }
"#;
    let project = load(&folder(PHASED, mission)).unwrap_or_else(|p| panic!("{p:#?}"));
    proved(&project);
    let airborne = "{\"t\": 1, \"event\": \"altitude_reached\", \"params\": {\"alt\": 50}}\n{\"t\": 2, \"event\": \"battery_low\"}\n";
    // Land refused, RTL refused: back to watching, the mission goes on.
    let refused = format!("{airborne}{{\"t\": 3, \"reply\": \"command.land\", \"failed\": \"denied\"}}\n{{\"t\": 4, \"reply\": \"command.rtl\", \"failed\": \"denied\"}}\n{{\"t\": 5, \"event\": \"battery_low\"}}\n");
    assert_eq!(
        crate::play::fired(&project, &refused),
        [
            "MISSION.start",
            "MISSION.climb_altitude_reached",
            "SAFETY.battery_low_airborne",
            "SAFETY.land_home_command_failed",
            "SAFETY.rtl_home_command_failed",
            "SAFETY.battery_low_airborne",
        ]
    );
    // Land accepted: the mission's steps stop.
    let accepted = format!("{airborne}{{\"t\": 3, \"reply\": \"command.land\"}}\n{{\"t\": 4, \"event\": \"landed\"}}\n");
    let fired = crate::play::fired(&project, &accepted);
    assert_eq!(
        fired.last().map(String::as_str),
        Some("SAFETY.land_home_command_ok"),
        "{fired:#?}"
    );
    // An engine failure: the steps stop at once, the glide runs.
    let failure = "{\"t\": 1, \"event\": \"engine_failure\"}\n{\"t\": 2, \"reply\": \"command.mode\", \"failed\": \"denied\"}\n{\"t\": 3, \"reply\": \"command.mode\"}\n";
    assert_eq!(
        crate::play::fired(&project, failure),
        [
            "MISSION.start",
            "CATASTROPHIC.engine_failure",
            "CATASTROPHIC.glide_command_failed",
            "CATASTROPHIC.glide_again_command_ok"
        ]
    );
    let (trace, _) = crate::play::trace(&project, failure);
    assert!(
        trace
            .iter()
            .any(|l| l.contains("deactivated") && l.contains("SAFETY")),
        "{trace:#?}"
    );
}

#[test]
fn a_reaction_leads_only_into_its_own_procedure() {
    let mission = r#"[steps]
a = { until = "landed" }

[reactions.safety]
battery_low = { then = "glid" }

[procedures.catastrophic]
glide = { until = "landed", phase = "airborne" }
"#;
    assert_eq!(
        load(&folder(PROJECT, mission)).err().unwrap_or_default(),
        [
            "steps.toml:7:13: procedure of catastrophic with no reaction to start it: add [reactions.catastrophic]",
            "steps.toml:8:37: a step of a procedure or a level has no phase: phases are the mission's steps', a reaction reads them (`phases`)",
            "steps.toml:5:24: a safety reaction ends with `abort`, `stay` (the default), `land` or a step of [procedures.safety]",
        ]
    );
}

#[test]
fn a_step_runs_a_level_of_its_own_while_it_lasts() {
    let mission = r#"[steps]
transit = { until = "mission_item_reached", when = "seq == 2" }
operations = { run = "PAYLOADS", until = "mission_item_reached", when = "seq == 6" }
home = { do = "command rtl", until = "landed" }

# Level 3: the camera on for 20 s, off for 10 s, again, while operations lasts.
[levels.PAYLOADS]
camera_on = { do = "command payload_start {payload: camera}", limit = "20s", on_limit = "camera_off" }
camera_off = { do = "command payload_stop {payload: camera}", limit = "10s", on_limit = "camera_on" }
"#;
    let project = load(&folder(PROJECT, mission)).unwrap_or_else(|p| panic!("{p:#?}"));
    let names: Vec<&str> = project.nets.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, ["MISSION", "PAYLOADS"]);
    proved(&project);
    let reached = |t: u32, seq: u32| {
        format!(
            "{{\"t\": {t}, \"event\": \"mission_item_reached\", \"params\": {{\"seq\": {seq}}}}}\n"
        )
    };
    let script = format!("{}{}{}", reached(1, 2), reached(50, 6), "{\"t\": 100}\n");
    assert_eq!(
        crate::play::fired(&project, &script),
        [
            "MISSION.start",
            "MISSION.transit_mission_item_reached",
            "PAYLOADS.start",
            "PAYLOADS.camera_on_limit",
            "PAYLOADS.camera_off_limit",
            "MISSION.operations_mission_item_reached",
        ]
    );
    assert_eq!(
        crate::play::commands(&project, &script),
        ["payload_start", "payload_stop", "payload_start", "rtl"],
        "the level stops with its step: no command after it"
    );
}

#[test]
fn a_level_is_declared_run_and_does_not_nest() {
    let mission = r#"[steps]
a = { run = "PAYLOAD", until = "landed" }

[levels.PAYLOADS]
x = { run = "PAYLOADS", until = "landed" }
"#;
    assert_eq!(
        load(&folder(PROJECT, mission)).err().unwrap_or_default(),
        [
            "steps.toml:5:13: levels do not nest: only a step of the mission runs a level",
            "steps.toml:2:13: unknown level `PAYLOAD`: declare it as [levels.PAYLOAD]; did you mean `PAYLOADS`?",
            "steps.toml:4:9: level `PAYLOADS` is run by no step: give a step `run = \"PAYLOADS\"`",
        ]
    );
}

#[test]
fn a_category_is_one_of_the_four() {
    let mission = "[steps]\na = { until = \"landed\" }\n[reactions.safty]\nbattery_low = {}\n[procedures.comms]\nx = { until = \"landed\" }\n";
    assert_eq!(
        load(&folder(PROJECT, mission)).err().unwrap_or_default(),
        [
            "steps.toml:5:13: unknown category `comms`: procedures are catastrophic, safety, mission or communication",
            "steps.toml:3:12: unknown category `safty`: reactions are catastrophic, safety, mission or communication",
        ]
    );
}

#[test]
fn a_refused_command_is_asked_again_after_a_wait() {
    let mission = r#"[steps]
arm = { do = "command arm", until = "command.ok", retries = 2, retry_after = "4s", on_limit = "abort", exits = [{ on = "command.failed", then = "retry" }] }
fly = { until = "landed" }
"#;
    let project = load(&folder(PROJECT, mission)).unwrap_or_else(|p| panic!("{p:#?}"));
    assert_eq!(proved(&project), Vec::<Vec<String>>::new());
    let refused =
        |t: u32| format!("{{\"t\": {t}, \"reply\": \"command.arm\", \"failed\": \"denied\"}}\n");
    let script = format!("{}{}{}{{\"t\": 20}}\n", refused(1), refused(6), refused(11));
    assert_eq!(
        crate::play::fired(&project, &script),
        [
            "MISSION.start",
            "MISSION.arm_command_failed",
            "MISSION.arm_retry1_again",
            "MISSION.arm_retry1_command_failed",
            "MISSION.arm_retry2_again",
            "MISSION.arm_retry2_command_failed",
        ]
    );
    let (trace, _) = crate::play::trace(&project, &script);
    let sent: Vec<&String> = trace
        .iter()
        .filter(|l| l.contains("cmd") && l.contains("arm"))
        .collect();
    assert_eq!(sent.len(), 3, "{trace:#?}");
    assert!(trace.iter().any(|l| l.contains("aborted")), "{trace:#?}");
}

#[test]
fn a_procedure_decides_by_the_phase_at_once() {
    let mission = r#"[steps]
climb = { do = "command takeoff {alt: 50}", until = "altitude_reached", phase = "on_ground" }
cruise = { until = "landed", phase = "airborne" }
rest = { until = "landed", phase = "down" }

[reactions.safety]
battery_low = { then = "deciding" }

[procedures.safety]
deciding = { exits = [{ phase = "airborne", then = "return_home" }, { phase = "on_ground", then = "done" }, { phase = "down", then = "done" }] }
return_home = { do = "command rtl", until = "command.ok", then = "done", exits = [{ on = "command.failed", then = "done" }] }
"#;
    let project = load(&folder(PHASED, mission)).unwrap_or_else(|p| panic!("{p:#?}"));
    proved(&project);
    let script = "{\"t\": 1, \"event\": \"battery_low\"}\n{\"t\": 2, \"event\": \"altitude_reached\", \"params\": {\"alt\": 50}}\n{\"t\": 3, \"event\": \"battery_low\"}\n";
    assert_eq!(
        crate::play::fired(&project, script),
        [
            "MISSION.start",
            "SAFETY.battery_low",
            "SAFETY.deciding_on_ground",
            "MISSION.climb_altitude_reached",
            "SAFETY.battery_low",
            "SAFETY.deciding_airborne",
        ]
    );
    assert_eq!(crate::play::commands(&project, script), ["takeoff", "rtl"]);
    // Without the phase `down`, a low battery after landing would leave the
    // procedure stuck in `deciding`: the verifier says so.
    let stuck = mission.replace(r#", { phase = "down", then = "done" }"#, "");
    let project = load(&folder(PHASED, &stuck)).unwrap_or_else(|p| panic!("{p:#?}"));
    let report = check(&project, &Options::default());
    assert!(!report.holds());
    let (_, safety) = report
        .nets
        .iter()
        .find(|(n, _)| n == "SAFETY")
        .expect("SAFETY's report");
    assert!(
        safety
            .deadlock_example
            .as_ref()
            .is_some_and(|steps| steps.last().is_some_and(|s| s.contains("battery_low"))),
        "{:?}",
        safety.deadlock_example
    );
}

#[test]
fn an_exit_says_its_event_or_its_phase() {
    let mission = r#"[steps]
a = { until = "landed", phase = "on_ground", exits = [{ phase = "airborne", then = "b" }, { then = "b" }] }
b = { until = "landed", phase = "airborne" }

[reactions.safety]
battery_low = { then = "p" }

[procedures.safety]
p = { exits = [{ phase = "airborne", when = "x > 1" }] }
"#;
    assert_eq!(
        load(&folder(PHASED, mission)).err().unwrap_or_default(),
        [
            "steps.toml:2:65: a step of the mission knows its phase: an exit's `phase` is for a procedure's or a level's steps",
            "steps.toml:2:91: an exit says its event (`on`), or the phase it is taken in (`phase`)",
            "steps.toml:9:45: an exit without an event is taken at once: it has no `when`",
        ]
    );
}

#[test]
fn an_empty_mission_level_or_procedure_is_said_where_it_is() {
    let mission = "[steps]\n[levels.L]\n";
    assert_eq!(
        load(&folder(PROJECT, mission)).err().unwrap_or_default(),
        [
            "steps.toml:1:1: the mission has no step: `[steps]` is empty or missing: a sequence has at least one step",
            "steps.toml:2:9: `L` has no step: a sequence has at least one step",
            "steps.toml:2:9: level `L` is run by no step: give a step `run = \"L\"`",
        ]
    );
}

#[test]
fn a_level_goes_on_between_steps_that_run_it() {
    let mission = r#"[steps]
operations = { run = "PAYLOADS", until = "mission_item_reached", then = "asking" }
asking = { run = "PAYLOADS", do = "call DEC.replan {failed: none}", until = "DEC.replan.done", when = "waypoints > 0", then = "operations", exits = [{ on = "DEC.replan.done", then = "home" }, { on = "DEC.replan.failed", then = "home" }] }
home = { do = "command rtl", until = "landed" }

[levels.PAYLOADS]
camera_on = { do = "command payload_start {payload: camera}", limit = "20s", on_limit = "camera_off" }
camera_off = { do = "command payload_stop {payload: camera}", until = "landed" }
"#;
    let project = load(&folder(PROJECT, mission)).unwrap_or_else(|p| panic!("{p:#?}"));
    proved(&project);
    let script = "{\"t\": 5, \"event\": \"mission_item_reached\", \"params\": {\"seq\": 1}}\n{\"t\": 6, \"reply\": \"DEC.replan\", \"params\": {\"waypoints\": 2}}\n{\"t\": 30}\n{\"t\": 31, \"event\": \"mission_item_reached\", \"params\": {\"seq\": 2}}\n{\"t\": 32, \"reply\": \"DEC.replan\", \"params\": {\"waypoints\": 0}}\n";
    // The camera starts once and stops at 20 s, though the mission went
    // from operations to asking and back; home stops the level.
    assert_eq!(
        crate::play::commands(&project, script),
        ["payload_start", "payload_stop", "rtl"]
    );
    let (trace, _) = crate::play::trace(&project, script);
    let activations = trace
        .iter()
        .filter(|l| l.contains("activated") && l.contains("PAYLOADS") && !l.contains("deactivated"))
        .count();
    assert_eq!(activations, 1, "{trace:#?}");
}

#[test]
fn a_level_stopped_by_a_suspension_or_a_wait_starts_again() {
    let mission = r#"[steps]
work = { run = "PAYLOADS", until = "landed", limit = "60s", retries = 1, retry_after = "5s", on_limit = "done" }

[rules]
lost = { on = "link_lost", resume_on = "link_restored" }

[levels.PAYLOADS]
camera_on = { do = "command payload_start {payload: camera}", until = "mission_item_reached" }
"#;
    let project = load(&folder(PROJECT, mission)).unwrap_or_else(|p| panic!("{p:#?}"));
    proved(&project);
    // Suspended and resumed: started again. Its limit, then 5 s: again.
    let script = "{\"t\": 1, \"event\": \"link_lost\"}\n{\"t\": 2, \"event\": \"link_restored\"}\n{\"t\": 70}\n";
    assert_eq!(
        crate::play::commands(&project, script),
        ["payload_start", "payload_start", "payload_start"]
    );
}
