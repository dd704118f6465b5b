//! Versions offered to a running supervision: proved, taken over at a
//! boundary where the state is the one proved, proved again when it moved,
//! refused with the running version untouched.

use std::collections::BTreeMap;

use nets::Event;

use super::*;

const PROJECT: &str = "[[net]]\nfile = \"link.toml\"\nactive = true\n";

/// The running version: a link hole lets the mission go on, unless it
/// lasts 10 s (then the vehicle lands).
const LINK: &str = r#"
name = "LINK"
places = ["ok", "hole", "landing"]
initial = ["ok"]
final = ["landing"]

[[transition]]
name = "lost"
from = ["ok"]
to = ["hole"]
on = "link_lost"
do = ["timer hole after 10s"]

[[transition]]
name = "back"
from = ["hole"]
to = ["ok"]
on = "link_restored"
do = ["cancel hole"]

[[transition]]
name = "too_long"
from = ["hole"]
to = ["landing"]
on = "hole"
do = ["command land"]
"#;

fn project(files: &[(&str, &str)]) -> Arc<Project> {
    let files: BTreeMap<String, String> = files
        .iter()
        .map(|(n, t)| ((*n).to_owned(), (*t).to_owned()))
        .collect();
    match nets::load(&files) {
        Ok(p) => Arc::new(p),
        Err(e) => panic!("{e:?}"),
    }
}

fn running() -> Arc<Project> {
    project(&[("project.toml", PROJECT), ("link.toml", LINK)])
}

/// The same net, a 10 s hole now returning home instead of landing.
fn returning() -> Arc<Project> {
    let net = LINK
        .replace("command land", "command rtl")
        .replace("landing", "returning");
    project(&[("project.toml", PROJECT), ("link.toml", &net)])
}

fn in_a_hole(p: &Arc<Project>) -> Player {
    let mut player = Player::start(p.clone(), 0);
    player.handle(&Event::new("link_lost"), 2_000_000);
    let _ = player.effects().count();
    player
}

fn marked(player: &Player) -> Vec<String> {
    let p = player.project();
    (0..p.place_count)
        .filter(|&f| player.state().marked(f))
        .map(|f| nets::version::place_name(p, f))
        .collect()
}

fn take_over(player: &Player, version: &Version) -> Player {
    let state = nets::version::map(player.project(), player.state(), &version.project)
        .unwrap_or_else(|e| panic!("{e:?}"));
    Player::restore(version.project.clone(), state).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_version_proved_from_the_running_state_takes_over_with_its_timer() {
    let player = in_a_hole(&running());
    let mut versions = Versions::default();
    versions.offer(returning(), Vec::new(), &player);
    assert_eq!(versions.poll_report(), Some(Report::Proving { number: 1 }));
    let proof = versions.poll_proof().expect("a proof to run");
    assert!(versions.poll_proof().is_none(), "one proof at a time");
    let proved = proof.run();
    assert!(proved.refusals.is_empty(), "{:?}", proved.refusals);
    // Time passed meanwhile, nothing else: it takes over.
    let mut later = player;
    later.advance(3_000_000);
    let version = versions.proved(proved, &later).expect("it takes over");
    assert_eq!(version.number, 1);
    let swapped = take_over(&later, &version);
    assert_eq!(marked(&swapped), ["LINK.hole"]);
    assert_eq!(
        swapped.next_deadline(),
        Some(12_000_000),
        "the hole's timer kept"
    );
    versions.took_over(&version, 7, Vec::new());
    assert_eq!(
        versions.poll_report(),
        Some(Report::Swapped { number: 1, seq: 7 })
    );
    assert_eq!(versions.current(), 1);
    assert!(!versions.pending());
}

#[test]
fn a_state_that_moved_during_the_proof_is_proved_again_before_the_swap() {
    let mut player = in_a_hole(&running());
    let mut versions = Versions::default();
    versions.offer(returning(), Vec::new(), &player);
    let proved = versions.poll_proof().expect("a proof").run();
    // The link came back while it was proved.
    player.handle(&Event::new("link_restored"), 2_500_000);
    let _ = player.effects().count();
    assert!(versions.proved(proved, &player).is_none(), "not this state");
    let _ = versions.poll_report();
    assert_eq!(
        versions.poll_report(),
        Some(Report::ProvingAgain {
            number: 1,
            attempt: 2
        })
    );
    let again = versions.poll_proof().expect("proved again");
    assert_eq!(
        marked(&Player::restore(running(), again.state.clone()).unwrap()),
        ["LINK.ok"]
    );
    let version = versions
        .proved(again.run(), &player)
        .expect("it takes over from the state as it is");
    assert_eq!(marked(&take_over(&player, &version)), ["LINK.ok"]);
}

#[test]
fn a_state_that_never_settles_is_refused_after_the_last_proof() {
    let mut player = in_a_hole(&running());
    let mut versions = Versions::default();
    versions.offer(returning(), Vec::new(), &player);
    let mut t = 3_000_000;
    for _ in 0..PROOFS_AT_MOST {
        let proved = versions.poll_proof().expect("a proof").run();
        let event = if marked(&player) == ["LINK.hole"] {
            "link_restored"
        } else {
            "link_lost"
        };
        player.handle(&Event::new(event), t);
        let _ = player.effects().count();
        t += 100_000;
        assert!(versions.proved(proved, &player).is_none());
    }
    assert!(versions.poll_proof().is_none(), "no proof after the last");
    let last = std::iter::from_fn(|| versions.poll_report()).last();
    match last {
        Some(Report::Refused { number: 1, reasons }) => {
            assert!(
                reasons[0].contains("moved during each of 12 proofs"),
                "{reasons:?}"
            )
        }
        other => panic!("{other:?}"),
    }
    assert!(!versions.pending());
}

#[test]
fn a_version_without_the_marked_place_is_refused_and_the_running_one_goes_on() {
    let player = in_a_hole(&running());
    let gone = LINK
        .replace("\"hole\"", "\"silence\"")
        .replace("[\"hole\"", "[\"silence\"");
    let gone = project(&[("project.toml", PROJECT), ("link.toml", &gone)]);
    let mut versions = Versions::default();
    versions.offer(gone, Vec::new(), &player);
    let proved = versions.poll_proof().expect("a proof").run();
    assert!(versions.proved(proved, &player).is_none());
    let reports: Vec<Report> = std::iter::from_fn(|| versions.poll_report()).collect();
    match reports.last() {
        Some(Report::Refused { number: 1, reasons }) => assert!(
            reasons.iter().any(|r| r.contains("LINK.hole is marked")),
            "{reasons:?}"
        ),
        other => panic!("{other:?}"),
    }
    assert_eq!(versions.current(), 0, "the running version goes on");
}

#[test]
fn a_newer_version_supersedes_one_being_proved() {
    let player = in_a_hole(&running());
    let mut versions = Versions::default();
    versions.offer(returning(), Vec::new(), &player);
    let first = versions.poll_proof().expect("a proof");
    versions.offer(running(), Vec::new(), &player);
    let reports: Vec<Report> = std::iter::from_fn(|| versions.poll_report()).collect();
    assert_eq!(
        reports,
        [
            Report::Proving { number: 1 },
            Report::Superseded { number: 1, by: 2 },
            Report::Proving { number: 2 },
        ]
    );
    assert!(
        versions.proved(first.run(), &player).is_none(),
        "the first proof's answer is for a version given up"
    );
    let second = versions.poll_proof().expect("the second's proof");
    let version = versions
        .proved(second.run(), &player)
        .expect("it takes over");
    assert_eq!(version.number, 2);
}

#[test]
fn a_version_changing_the_programs_or_the_team_is_refused_without_a_proof() {
    let player = in_a_hole(&running());
    let with_program = format!("{PROJECT}\n[programs.DEC.functions]\nplan = {{}}\n");
    let changed = project(&[("project.toml", &with_program), ("link.toml", LINK)]);
    let mut versions = Versions::default();
    versions.offer(changed, Vec::new(), &player);
    assert!(versions.poll_proof().is_none());
    match versions.poll_report() {
        Some(Report::Refused { number: 1, reasons }) => {
            assert!(reasons[0].contains("[programs]"), "{reasons:?}")
        }
        other => panic!("{other:?}"),
    }
    let team = format!("{PROJECT}\n[[vehicle]]\nname = \"A\"\nsystem = 1\n");
    let net = LINK.replace("command land", "command land @A");
    let team = project(&[("project.toml", &team), ("link.toml", &net)]);
    assert!(fixed_changes(&running(), &team)[0].contains("[[vehicle]]"));
    assert!(fixed_changes(&running(), &returning()).is_empty());
}

#[test]
fn the_reports_read_for_people() {
    let refused = Report::Refused {
        number: 3,
        reasons: vec!["place LINK.hole is marked".into()],
    };
    assert_eq!(
        refused.to_string(),
        "version 3 refused, the running version goes on:\n  - place LINK.hole is marked"
    );
    assert_eq!(
        Report::Swapped { number: 3, seq: 40 }.to_string(),
        "version 3 took over at step 40, the marking, timers and pending calls kept"
    );
}

#[test]
fn a_mission_projects_version_loads_from_its_files_as_recorded() {
    // What the run records of a mission project: the crew's files, the
    // mission among them; replay and the replica compile it again.
    let dir =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-survey-mission");
    let profile = crate::profile::Layers::builtin("ardupilot")
        .load()
        .expect("the built-in profile");
    let (project, files) = crate::project::load_read(&dir, &crate::project::catalog(&profile))
        .expect("the example loads");
    assert!(
        files.iter().any(|(p, _)| p == "project.toml") && files.len() >= 2,
        "{:?}",
        files.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    let version = Version::from_files(1, files).expect("its files load");
    let names = |p: &Project| p.nets.iter().map(|n| n.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(&version.project), names(&project));
    assert_eq!(version.project.place_count, project.place_count);
}
