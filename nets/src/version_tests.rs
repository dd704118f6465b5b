//! Mapping a running state onto a new version, and refusing it.

use std::sync::Arc;

use super::*;
use crate::player::Player;
use crate::verify::project::Options;
use crate::Event;

const PROJECT: &str = "[[net]]\nfile = \"n.toml\"\nactive = true\n";

/// The running version: a vehicle that takes off, holds, and lands when a
/// watchdog expires or when told to.
const V1: &str = r#"
name = "N"
places = ["ground", "air", "down"]
initial = ["ground"]
final = ["down"]

[[transition]]
name = "go"
from = ["ground"]
to = ["air"]
on = "takeoff"
do = ["timer watchdog after 60s"]

[[transition]]
name = "timeout"
from = ["air"]
to = ["down"]
on = "watchdog"

[[transition]]
name = "land"
from = ["air"]
to = ["down"]
on = "landed"
do = ["cancel watchdog"]
"#;

fn project(files: &[(&str, &str)]) -> Arc<Project> {
    let files: std::collections::BTreeMap<String, String> = files
        .iter()
        .map(|(n, t)| ((*n).to_owned(), (*t).to_owned()))
        .collect();
    match crate::load(&files) {
        Ok(p) => Arc::new(p),
        Err(e) => panic!("{e:?}"),
    }
}

fn v1() -> Arc<Project> {
    project(&[("project.toml", PROJECT), ("n.toml", V1)])
}

/// The running version in the air, its watchdog running.
fn flying(p: &Arc<Project>) -> Player {
    let mut player = Player::start(p.clone(), 0);
    player.handle(&Event::new("takeoff"), 5_000_000);
    let _ = player.effects().count();
    assert!(player.state().marked(place_named(p, "N.air").expect("air")));
    player
}

fn options() -> Options<'static> {
    Options {
        each_net: false,
        alone: false,
        ..Options::default()
    }
}

#[test]
fn the_same_version_maps_onto_itself_and_swaps_with_the_same_digest() {
    let p = v1();
    let player = flying(&p);
    assert_eq!(map(&p, player.state(), &p), Ok(player.state().clone()));
    let swapped = swap(&p, player.state(), &p, &options()).expect("swaps");
    assert_eq!(swapped.digest(), player.digest());
}

#[test]
fn a_marked_place_renamed_in_reload_keeps_its_token_and_timer() {
    let p = v1();
    let player = flying(&p);
    let v2 = V1
        .replace("\"air\"", "\"aloft\"")
        .replace("watchdog", "guard");
    let project2 = format!(
        "{PROJECT}\n[reload]\nplaces = {{ \"N.air\" = \"N.aloft\" }}\ntimers = {{ \"N.watchdog\" = \"N.guard\" }}\n"
    );
    let new = project(&[("project.toml", &project2), ("n.toml", &v2)]);
    let mapped = map(&p, player.state(), &new).expect("maps");
    assert!(mapped.marked(place_named(&new, "N.aloft").expect("aloft")));
    assert_eq!(mapped.timers.len(), 1);
    assert_eq!(
        timer_named(&new, "N.guard"),
        Some((mapped.timers[0].net, mapped.timers[0].timer))
    );
    assert_eq!(mapped.timers[0].deadline, player.state().timers[0].deadline);
    // And the new version lands on its renamed timer.
    let mut swapped = swap(&p, player.state(), &new, &options()).expect("swaps");
    swapped.advance(70_000_000);
    assert!(swapped
        .state()
        .marked(place_named(&new, "N.down").expect("down")));
}

#[test]
fn an_unmarked_place_may_go_a_marked_one_may_not() {
    let p = v1();
    let player = flying(&p);
    // `ground` is empty in the air: dropping it (`go` now takes off again
    // from `down`) is fine.
    let without_ground = V1
        .replace(
            "places = [\"ground\", \"air\", \"down\"]",
            "places = [\"air\", \"down\"]",
        )
        .replace("initial = [\"ground\"]", "initial = [\"down\"]")
        .replace("from = [\"ground\"]", "from = [\"down\"]");
    let new = project(&[("project.toml", PROJECT), ("n.toml", &without_ground)]);
    assert!(map(&p, player.state(), &new).is_ok());
    // `air` holds the token: dropping it is refused, by name.
    let without_air = V1.replace("\"air\"", "\"aloft\"");
    let new = project(&[("project.toml", PROJECT), ("n.toml", &without_air)]);
    let refused = map(&p, player.state(), &new).expect_err("refused");
    assert!(
        refused.contains(&Refusal::PlaceGone {
            place: "N.air".into()
        }),
        "{refused:?}"
    );
    assert_eq!(
        refused[0].to_string(),
        "place N.air is marked and the new version has no such place (map it in [reload] places)"
    );
}

#[test]
fn a_running_timer_whose_name_is_gone_is_refused() {
    let p = v1();
    let player = flying(&p);
    let new = project(&[
        ("project.toml", PROJECT),
        ("n.toml", &V1.replace("watchdog", "guard")),
    ]);
    let refused = map(&p, player.state(), &new).expect_err("refused");
    assert_eq!(
        refused,
        vec![Refusal::TimerGone {
            timer: "N.watchdog".into()
        }]
    );
}

#[test]
fn an_active_net_missing_from_the_new_version_is_refused() {
    let p = v1();
    let player = flying(&p);
    let new = project(&[
        ("project.toml", PROJECT),
        ("n.toml", &V1.replace("name = \"N\"", "name = \"M\"")),
    ]);
    let refused = map(&p, player.state(), &new).expect_err("refused");
    assert!(
        refused.contains(&Refusal::NetGone { net: "N".into() }),
        "{refused:?}"
    );
}

#[test]
fn a_rename_of_something_the_running_version_lacks_is_a_typo() {
    let p = v1();
    let player = flying(&p);
    let project2 = format!("{PROJECT}\n[reload]\nplaces = {{ \"N.aier\" = \"N.air\" }}\n");
    let new = project(&[("project.toml", &project2), ("n.toml", V1)]);
    assert_eq!(
        map(&p, player.state(), &new),
        Err(vec![Refusal::RenameUnknown {
            kind: "place",
            name: "N.aier".into()
        }])
    );
}

#[test]
fn a_rename_to_a_place_the_new_version_lacks_is_a_load_error_with_its_position() {
    let project2 = format!("{PROJECT}\n[reload]\nplaces = {{ \"N.air\" = \"N.aloft\" }}\n");
    let e =
        crate::load(&[("project.toml", project2.as_str()), ("n.toml", V1)]).expect_err("refused");
    let p = &e.problems[0];
    assert!(
        p.message.contains("[reload] place `N.aloft`"),
        "{}",
        p.message
    );
    assert_eq!(p.file.name, "project.toml");
    assert_eq!(p.line_col().0, 6);
}

/// A version sound from its own start (it takes off straight to `down`)
/// that has no way out of `air`, where the vehicle is.
const STUCK: &str = r#"
name = "N"
places = ["ground", "air", "down"]
initial = ["ground"]
final = ["down"]

[[transition]]
name = "go"
from = ["ground"]
to = ["down"]
on = "takeoff"
do = ["timer watchdog after 60s"]

[[transition]]
name = "timeout"
from = ["down"]
to = ["down"]
on = "watchdog"
"#;

#[test]
fn a_version_sound_from_its_start_but_stuck_from_the_vehicles_state_is_refused() {
    let p = v1();
    let player = flying(&p);
    let new = project(&[("project.toml", PROJECT), ("n.toml", STUCK)]);
    // Its own check holds: from its start, `air` is never marked.
    assert!(crate::verify::project::check(&new, &options()).holds());
    // The mapping itself is fine: every name is there.
    assert!(map(&p, player.state(), &new).is_ok());
    // From the air, nothing ever fires again.
    let refused = swap(&p, player.state(), &new, &options()).expect_err("refused");
    assert!(
        refused
            .iter()
            .any(|r| matches!(r, Refusal::Unsafe(why) if why.contains("dead marking"))),
        "{refused:?}"
    );
}

#[test]
fn no_swap_during_the_catastrophic_lockout() {
    let glide = format!(
        "{V1}\n[[transition]]\nname = \"glide\"\nfrom = [\"air\"]\nto = [\"down\"]\non = \"engine_failure\"\n"
    );
    let project_toml = format!("{PROJECT}\n[events]\nengine_failure = \"catastrophic\"\n");
    let p = project(&[("project.toml", &project_toml), ("n.toml", &glide)]);
    let mut player = flying(&p);
    player.handle(&Event::new("engine_failure"), 6_000_000);
    let _ = player.effects().count();
    assert!(player.state().lockout, "the lockout is on");
    let refused = map(&p, player.state(), &p).expect_err("refused");
    assert_eq!(
        refused,
        vec![Refusal::Lockout {
            who: "the whole team".into()
        }]
    );
}

#[test]
fn a_version_keeping_the_lockouts_nets_takes_over_during_the_lockout() {
    let glide = format!(
        "{V1}\n[[transition]]\nname = \"glide\"\nfrom = [\"air\"]\nto = [\"down\"]\non = \"engine_failure\"\n"
    );
    let events = "\n[events]\nengine_failure = \"catastrophic\"\n";
    let p = project(&[
        ("project.toml", &format!("{PROJECT}{events}")),
        ("n.toml", &glide),
    ]);
    let mut player = flying(&p);
    player.handle(&Event::new("engine_failure"), 6_000_000);
    let _ = player.effects().count();
    assert!(player.state().lockout);
    // The same nets, and a net of its own beside them: it may take over.
    let kept = format!("{PROJECT}[[net]]\nfile = \"w.toml\"\nactive = true\n{events}[reload]\nlockout = \"kept\"\n");
    let watch = "name = \"W\"\nplaces = [\"w\"]\ninitial = [\"w\"]\nfinal = [\"w\"]\n";
    let new = project(&[
        ("project.toml", &kept),
        ("n.toml", &glide),
        ("w.toml", watch),
    ]);
    let mapped = map(&p, player.state(), &new).expect("it maps during the lockout");
    assert!(mapped.lockout, "the lockout goes on in the new version");
    // Said kept, but the catastrophic net changed: refused by name.
    let changed = glide.replace(
        "to = [\"down\"]\non = \"engine_failure\"",
        "to = [\"air\"]\non = \"engine_failure\"",
    );
    let new = project(&[
        ("project.toml", &kept),
        ("n.toml", &changed),
        ("w.toml", watch),
    ]);
    let refused = map(&p, player.state(), &new).expect_err("refused");
    assert!(
        refused
            .iter()
            .any(|r| matches!(r, Refusal::LockoutNetChanged { net, .. } if net == "N")),
        "{refused:?}"
    );
    // Any other value of `lockout` is a load error at its place.
    let bad = format!("{PROJECT}{events}[reload]\nlockout = \"yes\"\n");
    let files: std::collections::BTreeMap<String, String> = [
        ("project.toml".to_owned(), bad),
        ("n.toml".to_owned(), glide.clone()),
    ]
    .into_iter()
    .collect();
    let err = crate::load(&files).expect_err("a load error");
    let text: String = err.problems.iter().map(|p| p.to_string()).collect();
    assert!(text.contains("\"kept\" is its one value"), "{text}");
}

#[test]
fn a_net_new_in_this_version_starts_as_it_says() {
    let p = v1();
    let player = flying(&p);
    let project2 = format!("{PROJECT}[[net]]\nfile = \"w.toml\"\nactive = true\n");
    let watch = "name = \"W\"\nplaces = [\"watching\", \"seen\"]\ninitial = [\"watching\"]\nfinal = [\"watching\", \"seen\"]\n\n[[transition]]\nname = \"see\"\nfrom = [\"watching\"]\nto = [\"seen\"]\non = \"landed\"\n";
    let new = project(&[
        ("project.toml", &project2),
        ("n.toml", V1),
        ("w.toml", watch),
    ]);
    let mapped = map(&p, player.state(), &new).expect("maps");
    let w = new.net("W").expect("W");
    assert!(mapped.active[w]);
    assert!(mapped.marked(place_named(&new, "W.watching").expect("watching")));
    assert!(swap(&p, player.state(), &new, &options()).is_ok());
}
