//! One test (at least) for every rule of the player (docs/nets.md, "How the
//! player plays").

use std::sync::Arc;

use crate::common::*;
use nets::player::{DropReason, Effect, Fault, Outcome, Player};
use nets::{Category, Event, Params, Value};

const S: u64 = 1_000_000;

fn ev(name: &str) -> Event {
    Event::new(name)
}

#[test]
fn a_transition_fires_iff_enabled_and_its_event_occurs() {
    let p = one_net(
        r#"name = "N"
places = ["a", "b", "c"]
initial = ["a"]
[[transition]]
name = "t1"
from = ["a"]
to = ["b"]
on = "go"
[[transition]]
name = "t2"
from = ["c"]
to = ["a"]
on = "go"
"#,
    );
    let mut player = Player::start(p, 0);
    drain(&mut player);
    assert!(
        fire(&mut player, &ev("other"), 1).is_empty(),
        "unrelated event fires nothing"
    );
    assert_eq!(marking(&player, "N"), ["a"]);
    assert_eq!(
        fire(&mut player, &ev("go"), 2),
        ["N.t1"],
        "only the enabled t1 fires"
    );
    assert_eq!(marking(&player, "N"), ["b"]);
    assert!(
        fire(&mut player, &ev("go"), 3).is_empty(),
        "nothing enabled waits for go"
    );
}

#[test]
fn one_occurrence_fires_every_enabled_waiting_transition_in_every_active_net_once() {
    let p = project(&[
        ("project.toml", "[[net]]\nfile = \"a.toml\"\nactive = true\n[[net]]\nfile = \"b.toml\"\nactive = true\n[[net]]\nfile = \"c.toml\"\n"),
        ("a.toml", "name = \"A\"\nplaces = [\"x\", \"y\", \"z\"]\ninitial = [\"x\", \"y\"]\n[[transition]]\nname = \"t1\"\nfrom = [\"x\"]\nto = [\"z\"]\non = \"e\"\n[[transition]]\nname = \"t2\"\nfrom = [\"y\"]\nto = [\"x\"]\non = \"e\"\n"),
        ("b.toml", "name = \"B\"\nplaces = [\"x\", \"y\"]\ninitial = [\"x\"]\n[[transition]]\nname = \"t\"\nfrom = [\"x\"]\nto = [\"y\"]\non = \"e\"\n"),
        ("c.toml", "name = \"C\"\nplaces = [\"x\", \"y\"]\ninitial = [\"x\"]\n[[transition]]\nname = \"t\"\nfrom = [\"x\"]\nto = [\"y\"]\non = \"e\"\n"),
    ]);
    let mut player = Player::start(p, 0);
    drain(&mut player);
    // A.t2 puts a token back in x, but t1 already took this occurrence; C
    // is inactive.
    assert_eq!(fire(&mut player, &ev("e"), 1), ["A.t1", "A.t2", "B.t"]);
    assert_eq!(marking(&player, "A"), ["x", "z"]);
    assert_eq!(marking(&player, "B"), ["y"]);
    assert!(marking(&player, "C").is_empty());
}

#[test]
fn a_token_produced_by_a_firing_does_not_let_another_transition_take_the_same_occurrence() {
    let p = one_net(
        r#"name = "N"
places = ["a", "b", "c"]
initial = ["a"]
[[transition]]
name = "second"
from = ["b"]
to = ["c"]
on = "e"
[[transition]]
name = "first"
from = ["a"]
to = ["b"]
on = "e"
"#,
    );
    let mut player = Player::start(p, 0);
    drain(&mut player);
    assert_eq!(fire(&mut player, &ev("e"), 1), ["N.first"]);
    assert_eq!(marking(&player, "N"), ["b"]);
    assert_eq!(fire(&mut player, &ev("e"), 2), ["N.second"]);
}

#[test]
fn a_place_consumed_and_refilled_in_one_occurrence_does_not_enable_a_later_transition_again() {
    // t1 consumes a; t2 refills a from b; t3 waits on a: a's arrival token
    // is gone, so t3 does not take this occurrence.
    let p = one_net(
        r#"name = "N"
places = ["a", "b", "c", "d"]
initial = ["a", "b"]
[[transition]]
name = "t1"
from = ["a"]
to = ["c"]
on = "e"
[[transition]]
name = "t2"
from = ["b"]
to = ["a"]
on = "e"
[[transition]]
name = "t3"
from = ["a"]
to = ["d"]
on = "e"
"#,
    );
    let mut player = Player::start(p, 0);
    drain(&mut player);
    assert_eq!(fire(&mut player, &ev("e"), 1), ["N.t1", "N.t2"]);
    assert_eq!(marking(&player, "N"), ["a", "c"]);
}

#[test]
fn with_a_shared_input_place_the_first_declared_wins_across_nets_in_project_order() {
    let p = project(&[
        ("project.toml", "[globals]\ng = true\n[[net]]\nfile = \"b.toml\"\nactive = true\n[[net]]\nfile = \"a.toml\"\nactive = true\n"),
        ("a.toml", "name = \"A\"\nplaces = [\"p\", \"q\"]\ninitial = [\"p\"]\n[[transition]]\nname = \"take\"\nfrom = [\"p\", \"@g\"]\nto = [\"q\"]\non = \"e\"\n"),
        ("b.toml", "name = \"B\"\nplaces = [\"p\", \"q\"]\ninitial = [\"p\"]\n[[transition]]\nname = \"take\"\nfrom = [\"p\", \"@g\"]\nto = [\"q\"]\non = \"e\"\n"),
    ]);
    let mut player = Player::start(p, 0);
    drain(&mut player);
    // B is declared first in project.toml.
    assert_eq!(fire(&mut player, &ev("e"), 1), ["B.take"]);
    assert!(!global(&player, "g"));
    assert_eq!(marking(&player, "A"), ["p"]);
}

#[test]
fn with_a_shared_input_place_the_first_declared_transition_of_a_net_wins() {
    let p = one_net(
        r#"name = "N"
places = ["a", "b", "c"]
initial = ["a"]
[[transition]]
name = "left"
from = ["a"]
to = ["b"]
on = "e"
[[transition]]
name = "right"
from = ["a"]
to = ["c"]
on = "e"
"#,
    );
    let mut player = Player::start(p, 0);
    drain(&mut player);
    assert_eq!(fire(&mut player, &ev("e"), 1), ["N.left"]);
}

#[test]
fn a_double_token_firing_is_rejected_whole_reported_and_does_not_take_the_occurrence() {
    let p = one_net(
        r#"name = "N"
places = ["a", "b", "c", "faulted"]
initial = ["a", "b", "faulted"]
[[transition]]
name = "bad"
from = ["a"]
to = ["b"]
on = "e"
do = ["command rtl"]
[[transition]]
name = "good"
from = ["a"]
to = ["c"]
on = "e"
[[transition]]
name = "on_fault"
from = ["faulted"]
to = ["faulted"]
on = "net_fault"
when = 'reason == "double token" && place == "N.b" && transition == "bad"'
do = ["emit seen"]
"#,
    );
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    player.handle(&ev("e"), 5);
    let effects = drain_effects(&mut player);
    assert!(effects.iter().any(|e| matches!(e, Effect::Fault { fault: Fault::DoubleToken { transition: 0, place, .. }, .. } if *place == p.place_offsets[0] + 1)));
    assert!(
        !effects.iter().any(|e| matches!(e, Effect::Command { .. })),
        "the rejected firing's actions do not run"
    );
    assert_eq!(fired(&p, &effects), ["N.good", "N.on_fault"]);
    assert_eq!(marking(&player, "N"), ["b", "c", "faulted"]);
    assert!(effects
        .iter()
        .any(|e| matches!(e, Effect::Emitted { event, .. } if event.name == "seen")));
}

#[test]
fn a_double_token_immediate_firing_is_rejected_once_and_the_next_one_fires() {
    // `fill` would put a second token in b: rejected whole, reported once
    // (not retried up to the livelock bound); `other` fires instead.
    let p = one_net(
        r#"name = "N"
places = ["a", "b", "c", "watch"]
initial = ["a", "b", "watch"]
[[transition]]
name = "fill"
from = ["a"]
to = ["b"]
do = ["command rtl"]
[[transition]]
name = "other"
from = ["a"]
to = ["c"]
[[transition]]
name = "seen"
from = ["watch"]
to = ["watch"]
on = "net_fault"
when = 'transition == "fill" && place == "N.b"'
"#,
    );
    let mut player = Player::start(p.clone(), 0);
    let effects = drain_effects(&mut player);
    let faults: Vec<&Fault> = effects
        .iter()
        .filter_map(|e| match e {
            Effect::Fault { fault, .. } => Some(fault),
            _ => None,
        })
        .collect();
    assert!(
        matches!(&faults[..], [Fault::DoubleToken { transition: 0, .. }]),
        "{faults:?}"
    );
    assert!(!effects.iter().any(|e| matches!(e, Effect::Command { .. })));
    assert_eq!(fired(&p, &effects), ["N.other", "N.seen"]);
    assert_eq!(marking(&player, "N"), ["b", "c", "watch"]);
}

#[test]
fn the_project_declares_categories_and_undeclared_events_keep_their_own() {
    // A nominal-looking engine failure becomes catastrophic by declaration
    // and starts the lockout; an undeclared event keeps the category it
    // came with.
    let p = project(&[
        ("project.toml", "[events]\nengine_failure = \"catastrophic\"\n[[net]]\nfile = \"n.toml\"\nactive = true\n"),
        ("n.toml", "name = \"N\"\nplaces = [\"a\", \"b\", \"c\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"engine_failure\"\n[[transition]]\nname = \"u\"\nfrom = [\"b\"]\nto = [\"c\"]\non = \"gps_lost\"\n"),
    ]);
    let mut player = Player::start(p, 0);
    drain(&mut player);
    player.handle(&ev("engine_failure"), 1);
    assert!(player.locked_out());
    drain(&mut player);
    // Undeclared and arriving as safety: dropped under the lockout…
    player.handle(&ev("gps_lost").category(Category::Safety), 2);
    let effects = drain_effects(&mut player);
    assert!(
        matches!(&effects[..], [Effect::Dropped { event, reason: DropReason::Lockout, .. }] if event.category == Category::Safety)
    );
    // …and handled when it arrives as catastrophic.
    assert_eq!(
        fire(
            &mut player,
            &ev("gps_lost").category(Category::Catastrophic),
            3
        ),
        ["N.u"]
    );
}

#[test]
fn emitted_events_run_to_completion_by_category_priority_fifo_within_one() {
    let p = project(&[
        (
            "project.toml",
            r#"[events]
n1 = "nominal"
n2 = "nominal"
m = "mission"
s = "safety"
c = "communication"
[[net]]
file = "n.toml"
active = true
"#,
        ),
        (
            "n.toml",
            r#"name = "N"
places = ["a", "p1", "p2", "p3", "p4", "p5", "q1", "q2", "q3", "q4", "q5"]
initial = ["a", "p1", "p2", "p3", "p4", "p5"]
[[transition]]
name = "start"
from = ["a"]
to = []
on = "go"
do = ["emit n1", "emit m", "emit n2", "emit c", "emit s"]
[[transition]]
name = "on_n1"
from = ["p1"]
to = ["q1"]
on = "n1"
[[transition]]
name = "on_n2"
from = ["p2"]
to = ["q2"]
on = "n2"
[[transition]]
name = "on_m"
from = ["p3"]
to = ["q3"]
on = "m"
[[transition]]
name = "on_s"
from = ["p4"]
to = ["q4"]
on = "s"
[[transition]]
name = "on_c"
from = ["p5"]
to = ["q5"]
on = "c"
"#,
        ),
    ]);
    let mut player = Player::start(p, 0);
    drain(&mut player);
    assert_eq!(
        fire(&mut player, &ev("go"), 1),
        ["N.start", "N.on_s", "N.on_c", "N.on_m", "N.on_n1", "N.on_n2"]
    );
}

const LOCKOUT: &str = r#"
[events]
engine_failure = "catastrophic"
battery_critical = "catastrophic"
payload_failure = "mission"
[programs.DEC.functions]
site = { returns = ["lat"] }
plan = {}
[[net]]
file = "mission.toml"
active = true
[[net]]
file = "emergency.toml"
active = true
"#;

const LOCKOUT_MISSION: &str = r#"name = "MISSION"
places = ["flying", "planning", "replanning"]
initial = ["flying"]
[[transition]]
name = "plan"
from = ["flying"]
to = ["planning"]
on = "start"
do = ["call DEC.plan"]
[[transition]]
name = "payload"
from = ["planning"]
to = ["replanning"]
on = "payload_failure"
[[transition]]
name = "planned"
from = ["planning"]
to = ["flying"]
on = "DEC.plan.done"
"#;

const LOCKOUT_EMERGENCY: &str = r#"name = "EMERGENCY"
places = ["watching", "asking", "gliding", "landed", "ground"]
initial = ["watching", "ground"]
[[transition]]
name = "failure_on_ground"
from = ["ground"]
to = ["ground"]
on = "nothing_ever"
[[transition]]
name = "engine"
from = ["watching"]
to = ["asking"]
on = "engine_failure"
do = ["call DEC.site", "timer watchdog after 10s", "emit mayday {code: 7700}"]
[[transition]]
name = "site"
from = ["asking"]
to = ["gliding"]
on = "DEC.site.done"
do = ["command goto {lat: $lat, lon: 1.5}"]
[[transition]]
name = "goto_ok"
from = ["gliding"]
to = ["landed"]
on = "command.ok"
[[transition]]
name = "watchdog"
from = ["landed"]
to = ["landed"]
on = "watchdog"
[[transition]]
name = "squawk"
from = ["ground"]
to = ["ground"]
on = "mayday"
"#;

#[test]
fn an_unconsumed_catastrophic_event_changes_nothing() {
    let p = project(&[
        ("project.toml", LOCKOUT),
        ("mission.toml", LOCKOUT_MISSION),
        (
            "emergency.toml",
            &LOCKOUT_EMERGENCY.replace("from = [\"watching\"]", "from = [\"asking\"]"),
        ),
    ]);
    let mut player = Player::start(p, 0);
    drain(&mut player);
    let before = player.digest();
    player.handle(&ev("engine_failure"), 1);
    assert!(drain(&mut player).is_empty());
    assert!(!player.locked_out());
    assert_ne!(before, player.digest(), "time moved on");
    assert_eq!(fire(&mut player, &ev("start"), 2), ["MISSION.plan"]);
}

#[test]
fn the_catastrophic_lockout_drops_everything_but_the_reactions_own_consequences() {
    let p = project(&[
        ("project.toml", LOCKOUT),
        ("mission.toml", LOCKOUT_MISSION),
        ("emergency.toml", LOCKOUT_EMERGENCY),
    ]);
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    assert_eq!(fire(&mut player, &ev("start"), S), ["MISSION.plan"]);
    let plan_call = *player
        .state()
        .pending
        .keys()
        .next()
        .expect("DEC.plan pending");

    player.handle(&ev("engine_failure"), 2 * S);
    let effects = drain_effects(&mut player);
    assert!(player.locked_out());
    assert!(
        matches!(effects.iter().find(|e| matches!(e, Effect::Lockout { .. })), Some(Effect::Lockout { event, .. }) if event == "engine_failure")
    );
    // The emitted event inherits the catastrophic category.
    assert!(effects.iter().any(|e| matches!(e, Effect::Emitted { event, .. } if event.name == "mayday" && event.category == Category::Catastrophic)));
    // …and is handled under the lockout.
    assert_eq!(
        fired(&p, &effects),
        ["EMERGENCY.engine", "EMERGENCY.squawk"]
    );
    assert!(!effects.iter().any(|e| matches!(e, Effect::Dropped { .. })));
    let site_call = effects
        .iter()
        .find_map(|e| match e {
            Effect::Call { id, .. } => Some(*id),
            _ => None,
        })
        .expect("DEC.site called");

    // Other incoming events are dropped, recorded.
    player.handle(&ev("payload_failure"), 3 * S);
    let effects = drain_effects(&mut player);
    assert!(
        matches!(&effects[..], [Effect::Dropped { event, reason: DropReason::Lockout, .. }] if event.name == "payload_failure" && event.category == Category::Mission)
    );
    // The result of a call issued before the lockout is dropped too.
    player.result(plan_call, Outcome::Done(Params::new()), 4 * S);
    let effects = drain_effects(&mut player);
    assert!(
        matches!(&effects[..], [Effect::Dropped { event, reason: DropReason::Lockout, .. }] if event.name == "DEC.plan.done")
    );
    assert_eq!(marking(&player, "MISSION"), ["planning"]);

    // The reaction's own call result is catastrophic and handled; its
    // parameters flow into the command.
    player.result(
        site_call,
        Outcome::Done(Params::from([("lat".into(), Value::Float(43.6))])),
        5 * S,
    );
    let effects = drain_effects(&mut player);
    assert_eq!(fired(&p, &effects), ["EMERGENCY.site"]);
    let (cmd, args) = effects
        .iter()
        .find_map(|e| match e {
            Effect::Command { id, verb, args, .. } if verb == "goto" => Some((*id, args.clone())),
            _ => None,
        })
        .expect("goto commanded");
    assert_eq!(
        args,
        Params::from([
            ("lat".into(), Value::Float(43.6)),
            ("lon".into(), Value::Float(1.5))
        ])
    );
    // So is the command's acknowledgement…
    player.result(cmd, Outcome::Done(Params::new()), 6 * S);
    assert_eq!(
        fired(&p, &drain_effects(&mut player)),
        ["EMERGENCY.goto_ok"]
    );
    // …and its timer, started at 2 s for 10 s.
    player.advance(12 * S);
    let effects = drain_effects(&mut player);
    assert_eq!(fired(&p, &effects), ["EMERGENCY.watchdog"]);
    assert!(matches!(effects[0], Effect::TimerExpired { time, .. } if time == 12 * S));
    // A second, external catastrophic event is still handled (it is not
    // "another kind" of event).
    player.handle(&ev("battery_critical"), 13 * S);
    assert!(drain_effects(&mut player).is_empty());
}

#[test]
fn immediate_transitions_fire_at_start_after_activation_and_after_events_in_declaration_order() {
    let p = project(&[
        (
            "project.toml",
            "[[net]]\nfile = \"a.toml\"\nactive = true\n[[net]]\nfile = \"b.toml\"\n",
        ),
        (
            "a.toml",
            r#"name = "A"
places = ["s", "x", "y", "z"]
initial = ["s"]
[[transition]]
name = "later"
from = ["x"]
to = ["z"]
[[transition]]
name = "boot"
from = ["s"]
to = ["x"]
[[transition]]
name = "wake_b"
from = ["z"]
to = ["y"]
on = "e"
do = ["activate B"]
"#,
        ),
        (
            "b.toml",
            r#"name = "B"
places = ["s", "t"]
initial = ["s"]
[[transition]]
name = "go"
from = ["s"]
to = ["t"]
"#,
        ),
    ]);
    let mut player = Player::start(p.clone(), 0);
    let effects = drain_effects(&mut player);
    // `later` is declared first but only enabled by `boot`.
    assert_eq!(fired(&p, &effects), ["A.boot", "A.later"]);
    assert_eq!(fire(&mut player, &ev("e"), 1), ["A.wake_b", "B.go"]);
    assert_eq!(marking(&player, "B"), ["t"]);
}

#[test]
fn a_livelock_of_immediate_transitions_is_a_reported_fault_not_a_hang() {
    let p = project(&[
        ("project.toml", "[limits]\nfirings_per_step = 50\n[[net]]\nfile = \"n.toml\"\nactive = true\n"),
        ("n.toml", "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"there\"\nfrom = [\"a\"]\nto = [\"b\"]\n[[transition]]\nname = \"back\"\nfrom = [\"b\"]\nto = [\"a\"]\n"),
    ]);
    let mut player = Player::start(p.clone(), 0);
    let effects = drain_effects(&mut player);
    assert_eq!(fired(&p, &effects).len(), 50);
    assert!(matches!(
        effects.last(),
        Some(Effect::Fault {
            fault: Fault::Livelock { firings: 50, .. },
            ..
        })
    ));
}

#[test]
fn an_endless_chain_of_emitted_events_overflows_into_a_fault() {
    let p = project(&[
        ("project.toml", "[limits]\nsteps_per_input = 20\n[[net]]\nfile = \"n.toml\"\nactive = true\n"),
        ("n.toml", "name = \"N\"\nplaces = [\"a\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"echo\"\nfrom = [\"a\"]\nto = [\"a\"]\non = \"ping\"\ndo = [\"emit ping\"]\n"),
    ]);
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    player.handle(&ev("ping"), 1);
    let effects = drain_effects(&mut player);
    assert_eq!(fired(&p, &effects).len(), 20);
    assert!(effects.iter().any(|e| matches!(
        e,
        Effect::Fault {
            fault: Fault::Overflow { steps: 20 },
            ..
        }
    )));
    assert!(matches!(
        effects.last(),
        Some(Effect::Dropped {
            reason: DropReason::Overflow,
            ..
        })
    ));
    assert_eq!(player.state().queued(), 0);
}

#[test]
fn a_timer_restarted_at_its_own_instant_is_an_overflow_fault_not_a_hang() {
    // `tick` restarts itself with a zero duration each time it expires: at
    // one instant, forever. Both inputs that fire timers must stop it.
    let p = project(&[
        (
            "project.toml",
            "[limits]\nsteps_per_input = 10\n[[net]]\nfile = \"n.toml\"\nactive = true\n",
        ),
        (
            "n.toml",
            r#"name = "N"
places = ["a", "b"]
initial = ["a"]
[[transition]]
name = "go"
from = ["a"]
to = ["a"]
on = "go"
do = ["timer tick after 0s", "timer later after 1s"]
[[transition]]
name = "spin"
from = ["a"]
to = ["a"]
on = "tick"
do = ["timer tick after 0s"]
[[transition]]
name = "later"
from = ["a"]
to = ["b"]
on = "later"
"#,
        ),
    ]);
    for by_advance in [true, false] {
        let mut player = Player::start(p.clone(), 0);
        player.handle(&ev("go"), 0);
        drain(&mut player);
        if by_advance {
            player.advance(2 * S);
        } else {
            player.handle(&ev("nothing"), 2 * S);
        }
        let effects = drain_effects(&mut player);
        let spins = fired(&p, &effects);
        assert_eq!(spins.len(), 11, "{by_advance}: {spins:?}");
        assert!(spins[..10].iter().all(|f| f == "N.spin"));
        assert_eq!(spins[10], "N.later");
        let fault = effects
            .iter()
            .position(|e| {
                matches!(
                    e,
                    Effect::Fault {
                        time: 0,
                        fault: Fault::Overflow { steps: 10 }
                    }
                )
            })
            .expect("an overflow fault at 0 s");
        assert!(
            matches!(&effects[fault + 1], Effect::Dropped { time: 0, event, reason: DropReason::Overflow } if event.name == "tick"),
            "the looping timer's expiry is dropped, recorded"
        );
        // The timer due later is not dropped: it fires at its own deadline.
        assert!(effects
            .iter()
            .any(|e| matches!(e, Effect::Fired { time, transition: 2, .. } if *time == S)));
        assert_eq!(player.next_deadline(), None);
        assert_eq!(marking(&player, "N"), ["b"]);
    }
}

const LIFECYCLE: &str = r#"
[events.job]
params = ["size"]
[globals]
g = true
[programs.DEC.functions]
f = { args = ["x"], returns = ["y"] }
[[net]]
file = "boss.toml"
active = true
[[net]]
file = "worker.toml"
"#;

const BOSS: &str = r#"name = "BOSS"
places = ["idle"]
initial = ["idle"]
[[transition]]
name = "hire"
from = ["idle"]
to = ["idle"]
on = "hire"
do = ["activate WORKER"]
[[transition]]
name = "fire"
from = ["idle"]
to = ["idle"]
on = "fire"
do = ["deactivate WORKER"]
"#;

const WORKER: &str = r#"name = "WORKER"
places = ["start", "busy", "done"]
initial = ["start"]
[[transition]]
name = "work"
from = ["start", "@g"]
to = ["busy"]
on = "job"
do = ["call DEC.f {x: $size}", "timer t after 5s", "command rtl"]
[[transition]]
name = "finish"
from = ["busy"]
to = ["done"]
on = "DEC.f.done"
"#;

#[test]
fn activation_gives_the_initial_marking_and_activating_an_active_net_is_ignored() {
    let p = project(&[
        ("project.toml", LIFECYCLE),
        ("boss.toml", BOSS),
        ("worker.toml", WORKER),
    ]);
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    assert!(marking(&player, "WORKER").is_empty());
    fire(&mut player, &ev("hire"), 1);
    assert_eq!(marking(&player, "WORKER"), ["start"]);
    assert_eq!(
        fire(&mut player, &ev("job").param("size", 3), 2),
        ["WORKER.work"]
    );
    let digest = player.digest();
    player.handle(&ev("hire"), 2);
    let effects = drain_effects(&mut player);
    assert!(effects.iter().any(|e| matches!(
        e,
        Effect::Ignored {
            action: "activate",
            ..
        }
    )));
    assert_eq!(
        marking(&player, "WORKER"),
        ["busy"],
        "the active net keeps its marking"
    );
    assert_eq!(player.digest(), digest, "nothing else changed either");
}

#[test]
fn deactivation_removes_tokens_cancels_timers_forgets_calls_and_drops_late_results_while_globals_keep_theirs(
) {
    let p = project(&[
        ("project.toml", LIFECYCLE),
        ("boss.toml", BOSS),
        ("worker.toml", WORKER),
    ]);
    let mut player = Player::start(p.clone(), 0);
    fire(&mut player, &ev("hire"), 1);
    player.handle(&ev("job").param("size", 3), 2 * S);
    let effects = drain_effects(&mut player);
    // Parameters flow from the event into the call.
    let call = effects
        .iter()
        .find_map(|e| match e {
            Effect::Call { id, args, .. } => Some((*id, args.clone())),
            _ => None,
        })
        .expect("called");
    assert_eq!(call.1, Params::from([("x".into(), Value::Int(3))]));
    assert!(!global(&player, "g"));
    assert_eq!(player.next_deadline(), Some(7 * S));
    assert_eq!(player.state().pending.len(), 2);

    player.handle(&ev("fire"), 3 * S);
    let effects = drain_effects(&mut player);
    assert!(effects
        .iter()
        .any(|e| matches!(e, Effect::TimerCancelled { .. })));
    assert_eq!(
        effects
            .iter()
            .filter(|e| matches!(e, Effect::Forgotten { .. }))
            .count(),
        2
    );
    assert!(effects
        .iter()
        .any(|e| matches!(e, Effect::Deactivated { .. })));
    assert!(marking(&player, "WORKER").is_empty());
    assert_eq!(player.next_deadline(), None);
    assert!(player.state().pending.is_empty());

    // The timer never fires; the late result is recorded and dropped.
    player.advance(10 * S);
    assert!(drain_effects(&mut player).is_empty());
    player.result(
        call.0,
        Outcome::Done(Params::from([("y".into(), Value::Int(1))])),
        11 * S,
    );
    assert_eq!(
        drain_effects(&mut player),
        [Effect::LateResult {
            time: 11 * S,
            id: call.0
        }]
    );

    // The global place keeps its state (empty: `work` took it) across
    // deactivation and a new activation.
    fire(&mut player, &ev("hire"), 12 * S);
    assert!(!global(&player, "g"));
    assert_eq!(marking(&player, "WORKER"), ["start"]);
    assert!(
        fire(&mut player, &ev("job").param("size", 1), 13 * S).is_empty(),
        "@g is empty"
    );
}

#[test]
fn a_deactivated_net_reads_deactivated_not_as_an_empty_marking() {
    // An active net may hold no token: its marking line is `(empty)`. A
    // deactivation's marking says `deactivated`, as text and as JSON.
    let p = project(&[
        ("project.toml", LIFECYCLE),
        ("boss.toml", BOSS),
        ("worker.toml", WORKER),
    ]);
    let mut player = Player::start(p.clone(), 0);
    fire(&mut player, &ev("hire"), S);
    player.handle(&ev("fire"), 2 * S);
    let effects = drain_effects(&mut player);
    let text: Vec<String> = effects
        .iter()
        .map(|e| nets::player::effect_text(&p, e))
        .collect();
    assert!(
        text.contains(&"mark   WORKER: deactivated".to_owned()),
        "{text:?}"
    );
    let json: Vec<serde_json::Value> = effects
        .iter()
        .map(|e| nets::player::effect_json(&p, e))
        .collect();
    let mark = json
        .iter()
        .find(|j| j["effect"] == "marking" && j["net"] == "WORKER")
        .expect("a marking for WORKER");
    assert_eq!(mark["active"], false, "{mark}");
    assert_eq!(mark["marked"], serde_json::json!([]));

    // Back: an ordinary marking, without the field.
    player.handle(&ev("hire"), 3 * S);
    let effects = drain_effects(&mut player);
    let mark = effects
        .iter()
        .map(|e| nets::player::effect_json(&p, e))
        .find(|j| j["effect"] == "marking" && j["net"] == "WORKER")
        .expect("a marking for WORKER");
    assert_eq!(mark.get("active"), None, "{mark}");
    assert!(effects
        .iter()
        .map(|e| nets::player::effect_text(&p, e))
        .any(|l| l == "mark   WORKER: start"));
    assert_eq!(
        nets::player::marking_words::<&str>(true, &[], " "),
        "(empty)",
        "an active net without a token"
    );
}

#[test]
fn a_net_that_deactivates_itself_still_acts_but_a_new_activation_inherits_none_of_it() {
    // WORKER's `quit` deactivates WORKER, then starts a timer and calls DEC:
    // the call goes out (the world must hear it), but the net is inactive,
    // so the expiry and the result are dropped, recorded; and a new
    // activation starts clean, without the old timer or call.
    let worker = r#"name = "WORKER"
places = ["start", "busy", "done"]
initial = ["start"]
[[transition]]
name = "quit"
from = ["start"]
to = ["busy"]
on = "quit"
do = ["deactivate WORKER", "timer t after 5s", "call DEC.f {x: 1}"]
[[transition]]
name = "expired"
from = ["start"]
to = ["done"]
on = "t"
[[transition]]
name = "answered"
from = ["start"]
to = ["done"]
on = "DEC.f.done"
"#;
    let p = project(&[
        ("project.toml", LIFECYCLE),
        ("boss.toml", BOSS),
        ("worker.toml", worker),
    ]);
    let worker_net = p.net("WORKER").expect("WORKER");

    // Left inactive: the expiry and the result are dropped, recorded.
    let mut player = Player::start(p.clone(), 0);
    fire(&mut player, &ev("hire"), 0);
    player.handle(&ev("quit"), S);
    let effects = drain_effects(&mut player);
    let id = effects
        .iter()
        .find_map(|e| match e {
            Effect::Call { id, .. } => Some(*id),
            _ => None,
        })
        .expect("the call goes out");
    assert!(!player.is_active(worker_net));
    assert!(marking(&player, "WORKER").is_empty());
    player.result(
        id,
        Outcome::Done(Params::from([("y".into(), Value::Int(1))])),
        2 * S,
    );
    let effects = drain_effects(&mut player);
    assert!(
        matches!(&effects[..], [Effect::Dropped { event, reason: DropReason::NetInactive, .. }] if event.name == "DEC.f.done"),
        "{effects:?}"
    );
    player.advance(10 * S);
    let effects = drain_effects(&mut player);
    assert!(effects.iter().any(|e| matches!(e, Effect::Dropped { event, reason: DropReason::NetInactive, .. } if event.name == "t")));
    assert!(fired(&p, &effects).is_empty());

    // Activated again before they come: the new activation cancels the old
    // timer and forgets the old call, and receives neither.
    let mut player = Player::start(p.clone(), 0);
    fire(&mut player, &ev("hire"), 0);
    player.handle(&ev("quit"), S);
    let id = drain_effects(&mut player)
        .iter()
        .find_map(|e| match e {
            Effect::Call { id, .. } => Some(*id),
            _ => None,
        })
        .expect("the call goes out");
    player.handle(&ev("hire"), 2 * S);
    let effects = drain_effects(&mut player);
    assert!(effects
        .iter()
        .any(|e| matches!(e, Effect::TimerCancelled { net, .. } if *net == worker_net)));
    assert!(effects
        .iter()
        .any(|e| matches!(e, Effect::Forgotten { id: f, .. } if *f == id)));
    assert_eq!(marking(&player, "WORKER"), ["start"]);
    assert_eq!(player.next_deadline(), None);
    assert!(player.state().pending.is_empty());
    player.result(
        id,
        Outcome::Done(Params::from([("y".into(), Value::Int(1))])),
        3 * S,
    );
    assert_eq!(
        drain_effects(&mut player),
        [Effect::LateResult { time: 3 * S, id }]
    );
    player.advance(10 * S);
    assert!(drain_effects(&mut player).is_empty());
    assert_eq!(marking(&player, "WORKER"), ["start"]);
}

#[test]
fn timers_are_scoped_to_their_net_restart_and_expire_in_deadline_then_start_order_each_at_its_deadline(
) {
    let net = |name: &str| {
        format!(
            r#"name = "{name}"
places = ["a", "b", "c", "d"]
initial = ["a"]
[[transition]]
name = "arm"
from = ["a"]
to = ["b"]
on = "go"
do = ["timer t after 10s", "timer u after 4s"]
[[transition]]
name = "rearm"
from = ["b"]
to = ["c"]
on = "again"
do = ["timer t after 2s"]
[[transition]]
name = "t_fired"
from = ["c"]
to = ["d"]
on = "t"
[[transition]]
name = "u_fired"
from = ["b"]
to = ["b"]
on = "u"
"#
        )
    };
    let p = project(&[
        ("project.toml", "[[net]]\nfile = \"x.toml\"\nactive = true\n[[net]]\nfile = \"y.toml\"\nactive = true\n"),
        ("x.toml", &net("X")),
        ("y.toml", &net("Y").replace("on = \"go\"", "on = \"go_y\"").replace("on = \"again\"", "on = \"again_y\"")),
    ]);
    // The same whether the due timers are fired by `handle` or `advance`.
    for by_advance in [false, true] {
        let mut player = Player::start(p.clone(), 0);
        drain(&mut player);
        fire(&mut player, &ev("go"), 0);
        fire(&mut player, &ev("go_y"), S);
        // X's u expires at 4 s, Y's at 5 s; X's `t` is restarted at 3 s (now
        // due at 5 s, started after Y's u). Y's t (11 s) is not X's t.
        fire(&mut player, &ev("again"), 3 * S);
        if by_advance {
            player.advance(20 * S);
        } else {
            player.handle(&ev("nothing"), 20 * S);
        }
        let effects = drain_effects(&mut player);
        let expiries: Vec<(String, u64)> = effects
            .iter()
            .filter_map(|e| match e {
                Effect::TimerExpired { time, net, timer } => Some((
                    format!("{}.{}", p.nets[*net].name, p.nets[*net].timers[*timer]),
                    *time,
                )),
                _ => None,
            })
            .collect();
        assert_eq!(
            expiries,
            [
                ("X.u".into(), 4 * S),
                ("Y.u".into(), 5 * S),
                ("X.t".into(), 5 * S),
                ("Y.t".into(), 11 * S)
            ]
        );
        // X left b at 3 s, so its u finds nothing to fire; Y is still in b when
        // its t expires, so it fires u_fired but not t_fired.
        assert_eq!(fired(&p, &effects), ["Y.u_fired", "X.t_fired"]);
        let t_fired_time = effects.iter().find_map(|e| match e {
            Effect::Fired {
                time,
                transition: 2,
                ..
            } => Some(*time),
            _ => None,
        });
        assert_eq!(t_fired_time, Some(5 * S), "handled at its own deadline");
    }
}

#[test]
fn starting_a_running_timer_restarts_it() {
    let p = one_net(
        r#"name = "N"
places = ["a", "b"]
initial = ["a"]
[[transition]]
name = "kick"
from = ["a"]
to = ["a"]
on = "kick"
do = ["timer t after 5s"]
[[transition]]
name = "expired"
from = ["a"]
to = ["b"]
on = "t"
"#,
    );
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    player.handle(&ev("kick"), 0);
    assert!(
        matches!(drain_effects(&mut player)[..], [_, _, Effect::TimerStarted { restarted: false, deadline, .. }] if deadline == 5 * S)
    );
    player.handle(&ev("kick"), 4 * S);
    assert!(
        matches!(drain_effects(&mut player)[..], [_, _, Effect::TimerStarted { restarted: true, deadline, .. }] if deadline == 9 * S)
    );
    player.advance(8 * S);
    assert!(drain_effects(&mut player).is_empty());
    player.advance(9 * S);
    assert_eq!(fired(&p, &drain_effects(&mut player)), ["N.expired"]);
}

#[test]
fn results_are_delivered_only_to_the_net_that_issued_them() {
    let caller = |name: &str, event: &str| {
        format!(
            r#"name = "{name}"
places = ["a", "b", "c"]
initial = ["a"]
[[transition]]
name = "ask"
from = ["a"]
to = ["b"]
on = "{event}"
do = ["call DEC.f", "command arm"]
[[transition]]
name = "got"
from = ["b"]
to = ["c"]
on = "DEC.f.done"
do = ["emit echo {{v: $v}}"]
[[transition]]
name = "armed"
from = ["c"]
to = ["c"]
on = "command.ok"
"#
        )
    };
    let p = project(&[
        ("project.toml", "[programs.DEC.functions]\nf = { returns = [\"v\"] }\n[[net]]\nfile = \"x.toml\"\nactive = true\n[[net]]\nfile = \"y.toml\"\nactive = true\n"),
        ("x.toml", &caller("X", "go")),
        ("y.toml", &caller("Y", "go")),
    ]);
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    assert_eq!(fire(&mut player, &ev("go"), 0), ["X.ask", "Y.ask"]);
    let ids: Vec<u64> = player.state().pending.keys().copied().collect();
    assert_eq!(ids, [1, 2, 3, 4]);
    player.result(
        3,
        Outcome::Done(Params::from([("v".into(), Value::Str("for Y".into()))])),
        1,
    );
    let effects = drain_effects(&mut player);
    assert_eq!(fired(&p, &effects), ["Y.got"]);
    assert!(effects.iter().any(|e| matches!(e, Effect::Emitted { event, .. } if event.params["v"] == Value::Str("for Y".into()))));
    player.result(4, Outcome::Done(Params::new()), 2);
    assert_eq!(fired(&p, &drain_effects(&mut player)), ["Y.armed"]);
    player.result(2, Outcome::Failed("denied".into()), 3);
    let effects = drain_effects(&mut player);
    assert!(
        fired(&p, &effects).is_empty(),
        "command.failed is not command.ok"
    );
}

#[test]
fn guards_read_the_event_parameters_and_a_guard_error_counts_as_false_and_is_reported() {
    let p = project(&[
        ("project.toml", "[events.wp]\nparams = [\"seq\"]\n[[net]]\nfile = \"n.toml\"\nactive = true\n"),
        ("n.toml", "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"third\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"wp\"\nwhen = \"seq >= 3\"\n"),
    ]);
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    assert!(fire(&mut player, &ev("wp").param("seq", 2), 1).is_empty());
    player.handle(&ev("wp").param("seq", "three"), 2);
    assert!(matches!(
        &drain_effects(&mut player)[..],
        [Effect::Fault {
            fault: Fault::Guard { .. },
            ..
        }]
    ));
    player.handle(&ev("wp"), 3);
    assert!(
        matches!(&drain_effects(&mut player)[..], [Effect::Fault { fault: Fault::Guard { message, .. }, .. }] if message.contains("no parameter `seq`"))
    );
    assert_eq!(fire(&mut player, &ev("wp").param("seq", 3), 4), ["N.third"]);
}

#[test]
fn time_never_goes_backwards() {
    let p = one_net("name = \"N\"\nplaces = [\"a\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"a\"]\non = \"e\"\ndo = [\"timer x after 1s\"]\n");
    let mut player = Player::start(p, 10 * S);
    player.handle(&ev("e"), 5 * S);
    let effects = drain_effects(&mut player);
    assert!(effects.iter().all(|e| e.time() == 10 * S));
    assert_eq!(player.next_deadline(), Some(11 * S));
}

#[test]
fn snapshot_and_restore_continue_identically() {
    let p = project(&[
        ("project.toml", LIFECYCLE),
        ("boss.toml", BOSS),
        ("worker.toml", WORKER),
    ]);
    let mut a = Player::start(p.clone(), 0);
    fire(&mut a, &ev("hire"), 1);
    fire(&mut a, &ev("job").param("size", 9), 2);
    let mut b = Player::restore(p.clone(), a.snapshot()).expect("restores");
    assert_eq!(a.digest(), b.digest());
    for player in [&mut a, &mut b] {
        player.result(
            1,
            Outcome::Done(Params::from([("y".into(), Value::Int(2))])),
            3 * S,
        );
        player.advance(10 * S);
    }
    assert_eq!(drain_effects(&mut a), drain_effects(&mut b));
    assert_eq!(a.snapshot(), b.snapshot());
    assert_eq!(a.digest(), b.digest());
}

#[test]
fn restore_refuses_a_snapshot_of_another_project() {
    let p = project(&[
        ("project.toml", LIFECYCLE),
        ("boss.toml", BOSS),
        ("worker.toml", WORKER),
    ]);
    let other = one_net("name = \"N\"\nplaces = [\"a\"]\ninitial = [\"a\"]\n");
    let snapshot = Player::start(p, 0).snapshot();
    assert!(Player::restore(other, snapshot).is_err());
}

#[test]
fn the_digest_hashes_the_documented_byte_layout() {
    use sha2::{Digest as _, Sha256};
    let p = one_net("name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"b\"]\n[[transition]]\nname = \"t\"\nfrom = [\"b\"]\nto = [\"a\"]\non = \"e\"\ndo = [\"timer w after 2s\", \"command mode {mode: AUTO}\"]\n");
    let mut player = Player::start(p, 7);
    player.handle(&ev("e"), 9);
    // Written out by hand from docs/nets.md, "The state digest".
    let mut expected: Vec<u8> = b"petrel.player.state".to_vec();
    expected.push(1);
    expected.extend(9u64.to_le_bytes()); // now
    expected.push(0); // lockout
    expected.extend(1u32.to_le_bytes()); // one marking word
    expected.extend(1u64.to_le_bytes()); // place a (flat 0) marked
    expected.extend(1u32.to_le_bytes());
    expected.push(1); // N active
    expected.extend(1u32.to_le_bytes()); // one timer
    expected.extend(0u32.to_le_bytes()); // net 0
    expected.extend(0u32.to_le_bytes()); // timer 0 (w)
    expected.extend(2_000_009u64.to_le_bytes()); // deadline
    expected.extend(0u64.to_le_bytes()); // seq
    expected.push(0); // not catastrophic
    for _ in 0..5 {
        expected.extend(0u32.to_le_bytes()); // empty queues
    }
    expected.extend(1u32.to_le_bytes()); // one pending
    expected.extend(1u64.to_le_bytes()); // id 1
    expected.extend(0u32.to_le_bytes()); // net 0
    expected.push(0); // not catastrophic
    expected.push(1); // command
    expected.extend(4u32.to_le_bytes());
    expected.extend(b"mode");
    expected.extend(2u64.to_le_bytes()); // next id
    expected.extend(1u64.to_le_bytes()); // next timer seq
    assert_eq!(nets::player::canonical_bytes(player.state()), expected);
    let hash: [u8; 32] = Sha256::digest(&expected).into();
    assert_eq!(player.digest().0, hash);
    assert_eq!(nets::player::DIGEST_ALGORITHM, "SHA-256");
    assert_eq!(player.digest().to_string().len(), 64);
}

#[test]
fn the_digest_layout_covers_the_lockout_calls_queues_and_every_value_kind() {
    use nets::player::{Pending, PendingKind, Queued, State};
    // A state written by hand (queues are empty between inputs, so this one
    // is built rather than played), then its bytes by hand from docs/nets.md.
    let mut queue: [std::collections::VecDeque<Queued>; 5] = Default::default();
    queue[1].push_back(Queued {
        event: Event {
            name: "e".into(),
            category: Category::Safety,
            params: Params::from([
                ("b".into(), Value::Bool(true)),
                ("f".into(), Value::Float(1.5)),
                ("i".into(), Value::Int(-2)),
                ("l".into(), Value::List(vec![Value::Str("x".into())])),
                (
                    "m".into(),
                    Value::Map(Params::from([("k".into(), Value::Int(1))])),
                ),
            ]),
        },
        target: Some(2),
    });
    queue[4].push_back(Queued {
        event: Event::new("n"),
        target: None,
    });
    let state = State {
        now: 3,
        marking: vec![5],
        active: vec![true, false],
        timers: Vec::new(),
        queue,
        lockout: true,
        locked: Vec::new(),
        pending: [(
            7,
            Pending {
                net: 1,
                kind: PendingKind::Call {
                    program: 2,
                    function: 3,
                },
                catastrophic: true,
            },
        )]
        .into(),
        next_id: 8,
        next_timer_seq: 0,
    };
    let str_ = |out: &mut Vec<u8>, s: &str| {
        out.extend((s.len() as u32).to_le_bytes());
        out.extend(s.as_bytes());
    };
    let mut x: Vec<u8> = b"petrel.player.state".to_vec();
    x.push(1);
    x.extend(3u64.to_le_bytes()); // now
    x.push(1); // lockout
    x.extend(1u32.to_le_bytes());
    x.extend(5u64.to_le_bytes()); // marking
    x.extend(2u32.to_le_bytes());
    x.extend([1, 0]); // active
    x.extend(0u32.to_le_bytes()); // no timers
    x.extend(0u32.to_le_bytes()); // catastrophic queue
    x.extend(1u32.to_le_bytes()); // safety queue: one event
    str_(&mut x, "e");
    x.push(1); // safety
    x.extend(5u32.to_le_bytes()); // five params, keys in order
    str_(&mut x, "b");
    x.extend([0, 1]);
    str_(&mut x, "f");
    x.push(2);
    x.extend(1.5f64.to_bits().to_le_bytes());
    str_(&mut x, "i");
    x.push(1);
    x.extend((-2i64).to_le_bytes());
    str_(&mut x, "l");
    x.push(4);
    x.extend(1u32.to_le_bytes());
    x.push(3);
    str_(&mut x, "x");
    str_(&mut x, "m");
    x.push(5);
    x.extend(1u32.to_le_bytes());
    str_(&mut x, "k");
    x.push(1);
    x.extend(1i64.to_le_bytes());
    x.push(1); // has target
    x.extend(2u32.to_le_bytes());
    x.extend(0u32.to_le_bytes()); // communication
    x.extend(0u32.to_le_bytes()); // mission
    x.extend(1u32.to_le_bytes()); // nominal: one event
    str_(&mut x, "n");
    x.push(4);
    x.extend(0u32.to_le_bytes()); // no params
    x.push(0); // no target
    x.extend(0u32.to_le_bytes());
    x.extend(1u32.to_le_bytes()); // one pending
    x.extend(7u64.to_le_bytes());
    x.extend(1u32.to_le_bytes()); // net
    x.push(1); // catastrophic
    x.push(0); // a call
    x.extend(2u32.to_le_bytes());
    x.extend(3u32.to_le_bytes());
    x.extend(8u64.to_le_bytes()); // next id
    x.extend(0u64.to_le_bytes()); // next timer seq
    assert_eq!(nets::player::canonical_bytes(&state), x);
    // Vehicles locked out one by one (a team's): the lockout byte says so
    // (2 | team) and their ids follow; the rest is unchanged.
    let mut team = state.clone();
    team.locked = vec![0, 2];
    let at = b"petrel.player.state".len() + 1 + 8;
    let mut y = x[..at].to_vec();
    y.push(3);
    y.extend(2u32.to_le_bytes());
    y.extend(0u32.to_le_bytes());
    y.extend(2u32.to_le_bytes());
    y.extend(&x[at + 1..]);
    assert_eq!(nets::player::canonical_bytes(&team), y);
}

#[test]
fn the_same_inputs_give_the_same_effects_and_digests() {
    let p = project(&[
        ("project.toml", LIFECYCLE),
        ("boss.toml", BOSS),
        ("worker.toml", WORKER),
    ]);
    let run = |p: Arc<nets::Project>| {
        let mut player = Player::start(p, 0);
        let mut log = Vec::new();
        for (i, name) in ["hire", "job", "fire", "hire", "job"].iter().enumerate() {
            player.handle(&ev(name).param("size", i as i64), i as u64 * S);
            log.extend(drain_effects(&mut player));
            log.push(Effect::LateResult {
                time: 0,
                id: u64::from_le_bytes(player.digest().0[..8].try_into().unwrap()),
            });
        }
        log
    };
    assert_eq!(run(p.clone()), run(p));
}

#[test]
fn timers_and_results_take_the_declared_category_or_nominal() {
    let p = project(&[
        (
            "project.toml",
            r#"[events]
boom = "catastrophic"
tick = "catastrophic"
"DEC.f.done" = "safety"
[programs.DEC.functions]
f = {}
[[net]]
file = "n.toml"
active = true
"#,
        ),
        (
            "n.toml",
            r#"name = "N"
places = ["a", "b", "c", "x", "y"]
initial = ["a", "x"]
[[transition]]
name = "start"
from = ["a"]
to = ["b"]
on = "go"
do = ["timer tick after 5s", "timer tock after 5s", "call DEC.f"]
[[transition]]
name = "explode"
from = ["b"]
to = ["c"]
on = "boom"
[[transition]]
name = "ticked"
from = ["x"]
to = ["y"]
on = "tick"
[[transition]]
name = "tocked"
from = ["y"]
to = ["x"]
on = "tock"
"#,
        ),
    ]);
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    fire(&mut player, &ev("go"), 0);
    assert_eq!(fire(&mut player, &ev("boom"), S), ["N.explode"]);
    assert!(player.locked_out());
    player.result(1, Outcome::Done(Params::new()), 2 * S);
    let effects = drain_effects(&mut player);
    assert!(
        matches!(&effects[..], [Effect::Dropped { event, reason: DropReason::Lockout, .. }] if event.name == "DEC.f.done" && event.category == Category::Safety)
    );
    player.advance(5 * S);
    let effects = drain_effects(&mut player);
    // `tick` is declared catastrophic: handled under the lockout; `tock` is
    // nominal: dropped.
    assert_eq!(fired(&p, &effects), ["N.ticked"]);
    assert!(effects.iter().any(|e| matches!(e, Effect::Dropped { event, .. } if event.name == "tock" && event.category == Category::Nominal)));
}

/// A net that goes to a position when `alert` carries one, and falls back
/// when it does not; a net that listens for `net_fault`; and, if `guarded`,
/// a net with a guard on the position.
fn fallback_project(guarded: bool) -> Arc<nets::Project> {
    project(&[
        (
            "project.toml",
            &format!(
                "[events.alert]\ncategory = \"safety\"\nparams = [\"lat\"]\n[[net]]\nfile = \"a.toml\"\nactive = {guarded}\n[[net]]\nfile = \"b.toml\"\nactive = true\n[[net]]\nfile = \"f.toml\"\nactive = true\n"
            ),
        ),
        (
            "a.toml",
            "name = \"A\"\nplaces = [\"a0\", \"a1\"]\ninitial = [\"a0\"]\n[[transition]]\nname = \"near\"\nfrom = [\"a0\"]\nto = [\"a1\"]\non = \"alert\"\nwhen = \"lat > 45\"\n",
        ),
        (
            "b.toml",
            "name = \"B\"\nplaces = [\"idle\", \"going\", \"blind\"]\ninitial = [\"idle\"]\n[[transition]]\nname = \"go\"\nfrom = [\"idle\"]\nto = [\"going\"]\non = \"alert\"\ndo = [\"command goto {lat: $lat, lon: 2}\"]\n[[transition]]\nname = \"go_blind\"\nfrom = [\"idle\"]\nto = [\"blind\"]\non = \"alert\"\n",
        ),
        (
            "f.toml",
            "name = \"F\"\nplaces = [\"watching\", \"seen\"]\ninitial = [\"watching\"]\n[[transition]]\nname = \"fault\"\nfrom = [\"watching\"]\nto = [\"seen\"]\non = \"net_fault\"\nwhen = 'reason == \"argument `lat`: the event has no parameter `lat`\"'\n",
        ),
    ])
}

#[test]
fn under_the_oracle_an_event_said_to_lack_a_parameter_plays_exactly_as_in_flight() {
    use nets::player::{Oracle, Question};
    let p = fallback_project(false);
    let mut flight = Player::start(p.clone(), 0);
    drain(&mut flight);
    flight.handle(&ev("alert"), 1);
    let in_flight = drain(&mut flight);
    let mut verified = Player::start(p.clone(), 0);
    drain(&mut verified);
    verified.set_oracle(Some(Oracle::new(vec![false])));
    verified.handle(&ev("alert"), 1);
    assert_eq!(drain(&mut verified), in_flight);
    assert_eq!(verified.digest(), flight.digest());
    assert_eq!(
        verified.oracle().map(|o| o.questions.clone()),
        Some(vec![Question::Carries("lat".into())])
    );
    // The fault, the net_fault event with flight's reason, the fallback.
    let joined = in_flight.join("\n");
    for line in ["no parameter `lat`", "B.go_blind", "F.fault"] {
        assert!(joined.contains(line), "{line}: {joined}");
    }

    // Said to carry it: `go` fires, its unknown argument left out.
    let mut present = Player::start(p.clone(), 0);
    drain(&mut present);
    present.set_oracle(Some(Oracle::new(vec![true])));
    present.handle(&ev("alert"), 1);
    let effects = drain_effects(&mut present);
    assert_eq!(fired(&p, &effects), ["B.go"]);
    assert!(effects.iter().any(|e| matches!(
        e,
        Effect::Command { verb, args, .. }
            if verb == "goto" && args == &Params::from([("lon".to_owned(), Value::Int(2))])
    )));
}

#[test]
fn under_the_oracle_a_guard_that_holds_makes_the_event_carry_what_it_read() {
    use nets::player::{Oracle, Question};
    let p = fallback_project(true);
    // The guard holds: `lat` is carried, B.go's argument is not asked.
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    player.set_oracle(Some(Oracle::new(vec![true])));
    player.handle(&ev("alert"), 1);
    assert_eq!(fired(&p, &drain_effects(&mut player)), ["A.near", "B.go"]);
    assert_eq!(
        player.oracle().map(|o| o.questions.clone()),
        Some(vec![Question::Guard])
    );
    // The guard does not hold: whether `lat` is carried is still asked.
    for (carried, taken) in [(true, "B.go"), (false, "B.go_blind")] {
        let mut player = Player::start(p.clone(), 0);
        drain(&mut player);
        player.set_oracle(Some(Oracle::new(vec![false, carried])));
        player.handle(&ev("alert"), 1);
        let fired = fired(&p, &drain_effects(&mut player));
        assert_eq!(fired.first().map(String::as_str), Some(taken), "{fired:?}");
        assert!(!fired.contains(&"A.near".to_owned()), "{fired:?}");
        assert_eq!(
            player.oracle().map(|o| o.questions.clone()),
            Some(vec![Question::Guard, Question::Carries("lat".into())])
        );
    }
}

/// A project whose only reaction to `engine_failure` calls DEC.site with the
/// event's position, and a net that logs every `net_fault`.
const FAULT_UNDER_CATASTROPHE: &str = r#"
[events]
engine_failure = { category = "catastrophic", params = ["lat", "lon"] }
[programs.DEC.functions]
site = { args = ["lat", "lon"], returns = ["lat"] }
[[net]]
file = "emergency.toml"
active = true
[[net]]
file = "faults.toml"
active = true
[[net]]
file = "mission.toml"
active = true
"#;

const FAULT_EMERGENCY: &str = r#"name = "EMERGENCY"
places = ["watching", "asking", "busy"]
initial = ["watching"]
[[transition]]
name = "engine"
from = ["watching"]
to = ["asking"]
on = "engine_failure"
do = ["call DEC.site {lat: $lat, lon: $lon}"]
"#;

const FAULT_LOG: &str = r#"name = "FAULTS"
places = ["logging"]
initial = ["logging"]
[[transition]]
name = "log"
from = ["logging"]
to = ["logging"]
on = "net_fault"
"#;

const FAULT_MISSION: &str = r#"name = "MISSION"
places = ["a", "b"]
initial = ["a"]
[[transition]]
name = "go"
from = ["a"]
to = ["b"]
on = "waypoint"
"#;

#[test]
fn a_rejected_catastrophic_firing_raises_a_net_fault_that_does_not_start_the_lockout() {
    let p = project(&[
        ("project.toml", FAULT_UNDER_CATASTROPHE),
        ("emergency.toml", FAULT_EMERGENCY),
        ("faults.toml", FAULT_LOG),
        ("mission.toml", FAULT_MISSION),
    ]);
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    // The event lacks `lon`: the only catastrophic transition is rejected.
    let mut failure = Event::new("engine_failure").category(Category::Catastrophic);
    failure.params.insert("lat".into(), Value::Float(43.6));
    player.handle(&failure, S);
    let effects = drain_effects(&mut player);
    assert!(effects.iter().any(|e| matches!(
        e,
        Effect::Fault {
            fault: Fault::BadArgument { .. },
            ..
        }
    )));
    // The fault is heard, as a safety event, by the logging net…
    assert_eq!(fired(&p, &effects), ["FAULTS.log"]);
    // …and no catastrophic transition fired, so there is no lockout.
    assert!(!effects.iter().any(|e| matches!(e, Effect::Lockout { .. })));
    assert!(!player.locked_out());
    // Later events are still handled, and the emergency net still waits.
    assert_eq!(fire(&mut player, &ev("waypoint"), 2 * S), ["MISSION.go"]);
    assert_eq!(marking(&player, "EMERGENCY"), ["watching"]);
    // A complete engine_failure then starts the reaction and the lockout.
    failure.params.insert("lon".into(), Value::Float(1.4));
    assert_eq!(fire(&mut player, &failure, 3 * S), ["EMERGENCY.engine"]);
    assert!(player.locked_out());
}

#[test]
fn a_double_token_under_a_catastrophic_event_does_not_start_the_lockout() {
    let emergency = r#"name = "EMERGENCY"
places = ["watching", "asking"]
initial = ["watching", "asking"]
[[transition]]
name = "engine"
from = ["watching"]
to = ["asking"]
on = "engine_failure"
"#;
    let p = project(&[
        ("project.toml", FAULT_UNDER_CATASTROPHE),
        ("emergency.toml", emergency),
        ("faults.toml", FAULT_LOG),
        ("mission.toml", FAULT_MISSION),
    ]);
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    player.handle(&ev("engine_failure"), S);
    let effects = drain_effects(&mut player);
    assert!(effects.iter().any(|e| matches!(
        e,
        Effect::Fault {
            fault: Fault::DoubleToken { .. },
            ..
        }
    )));
    assert_eq!(fired(&p, &effects), ["FAULTS.log"]);
    assert!(!player.locked_out());
    assert_eq!(fire(&mut player, &ev("waypoint"), 2 * S), ["MISSION.go"]);
}

#[test]
fn a_net_fault_raised_by_the_running_catastrophic_reaction_stays_catastrophic() {
    // The first catastrophic candidate is rejected, the second fires: the
    // reaction is running, so its net_fault is catastrophic and still heard.
    let emergency = r#"name = "EMERGENCY"
places = ["watching", "asking", "gliding"]
initial = ["watching"]
[[transition]]
name = "engine"
from = ["watching"]
to = ["asking"]
on = "engine_failure"
do = ["call DEC.site {lat: $lat, lon: $lon}"]
[[transition]]
name = "glide"
from = ["watching"]
to = ["gliding"]
on = "engine_failure"
"#;
    let p = project(&[
        ("project.toml", FAULT_UNDER_CATASTROPHE),
        ("emergency.toml", emergency),
        ("faults.toml", FAULT_LOG),
        ("mission.toml", FAULT_MISSION),
    ]);
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    player.handle(&ev("engine_failure"), S);
    let effects = drain_effects(&mut player);
    assert_eq!(fired(&p, &effects), ["EMERGENCY.glide", "FAULTS.log"]);
    assert!(player.locked_out());
    assert!(!effects.iter().any(|e| matches!(e, Effect::Dropped { .. })));
}

const SPOOF: &str = r#"
[programs.DEC.functions]
site = {}
[[net]]
file = "a.toml"
active = true
[[net]]
file = "b.toml"
active = true
[[net]]
file = "c.toml"
active = true
"#;

/// A starts its timer `watchdog` and waits for it.
const SPOOF_A: &str = r#"name = "A"
places = ["idle", "waiting", "expired"]
initial = ["idle"]
[[transition]]
name = "start"
from = ["idle"]
to = ["waiting"]
on = "go"
do = ["timer watchdog after 10s", "call DEC.site"]
[[transition]]
name = "expired"
from = ["waiting"]
to = ["expired"]
on = "watchdog"
"#;

/// B has a timer of the same name it never starts.
const SPOOF_B: &str = r#"name = "B"
places = ["idle", "expired"]
initial = ["idle"]
[[transition]]
name = "expired"
from = ["idle"]
to = ["expired"]
on = "watchdog"
[[transition]]
name = "never"
from = ["expired"]
to = ["expired"]
on = "never"
do = ["timer watchdog after 1s"]
"#;

/// C waits for an ordinary event called `watchdog`, and for DEC's answer
/// although it never calls DEC.
const SPOOF_C: &str = r#"name = "C"
places = ["idle", "heard", "answered"]
initial = ["idle"]
[[transition]]
name = "heard"
from = ["idle"]
to = ["heard"]
on = "watchdog"
[[transition]]
name = "answered"
from = ["heard"]
to = ["answered"]
on = "DEC.site.done"
"#;

#[test]
fn an_outside_event_named_like_a_timer_never_stands_for_its_expiry() {
    let p = project(&[
        ("project.toml", SPOOF),
        ("a.toml", SPOOF_A),
        ("b.toml", SPOOF_B),
        ("c.toml", SPOOF_C),
    ]);
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    assert_eq!(fire(&mut player, &ev("go"), S), ["A.start"]);
    // An outside `watchdog`: only C, which waits for an event of that name,
    // hears it; A's running timer and B's idle one are not spoofed.
    assert_eq!(fire(&mut player, &ev("watchdog"), 2 * S), ["C.heard"]);
    assert_eq!(marking(&player, "A"), ["waiting"]);
    assert_eq!(marking(&player, "B"), ["idle"]);
    // The real expiry reaches A, and only A.
    player.advance(11 * S);
    let effects = drain_effects(&mut player);
    assert_eq!(fired(&p, &effects), ["A.expired"]);
    assert_eq!(marking(&player, "B"), ["idle"]);
}

#[test]
fn outside_results_and_net_faults_are_dropped_as_reserved() {
    let p = project(&[
        ("project.toml", SPOOF),
        ("a.toml", SPOOF_A),
        ("b.toml", SPOOF_B),
        ("c.toml", SPOOF_C),
    ]);
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    assert_eq!(fire(&mut player, &ev("watchdog"), S), ["C.heard"]);
    for name in [
        "DEC.site.done",
        "DEC.site.failed",
        "command.ok",
        "command.failed",
        "net_fault",
    ] {
        player.handle(&ev(name), 2 * S);
        let effects = drain_effects(&mut player);
        assert!(
            matches!(&effects[..], [Effect::Dropped { event, reason: DropReason::Reserved, .. }] if event.name == name),
            "{name}: {effects:?}"
        );
    }
    assert_eq!(marking(&player, "C"), ["heard"]);
    // A real result goes to the caller only: C never called DEC.site.
    assert_eq!(fire(&mut player, &ev("go"), 3 * S), ["A.start"]);
    let id = *player
        .state()
        .pending
        .keys()
        .next()
        .expect("DEC.site pending");
    player.result(id, Outcome::Done(Params::new()), 4 * S);
    assert!(fired(&p, &drain_effects(&mut player)).is_empty());
    assert_eq!(marking(&player, "C"), ["heard"]);
}

#[test]
fn a_non_finite_float_never_reaches_a_command_or_a_call() {
    let p = project(&[
        (
            "project.toml",
            "[events]\nfix = { params = [\"lat\"] }\n[programs.P.functions]\nf = { args = [\"x\"] }\n[[net]]\nfile = \"n.toml\"\nactive = true\n",
        ),
        (
            "n.toml",
            r#"name = "N"
places = ["a", "b"]
initial = ["a"]
[[transition]]
name = "overflow"
from = ["a"]
to = ["b"]
on = "go"
do = ["call P.f {x: 1e100 * 1e300}"]
[[transition]]
name = "goto"
from = ["a"]
to = ["b"]
on = "fix"
do = ["command goto {lat: $lat, lon: 1.5}"]
"#,
        ),
    ]);
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    for (event, at) in [
        (ev("go"), S),
        (ev("fix").param("lat", f64::NAN), 2 * S),
        (ev("fix").param("lat", f64::INFINITY), 3 * S),
    ] {
        player.handle(&event, at);
        let effects = drain_effects(&mut player);
        assert!(
            effects.iter().any(|e| matches!(e, Effect::Fault { fault: Fault::BadArgument { message, .. }, .. } if message.contains("not a finite number"))),
            "{event}: {effects:?}"
        );
        assert!(
            !effects
                .iter()
                .any(|e| matches!(e, Effect::Command { .. } | Effect::Call { .. })),
            "{event}: {effects:?}"
        );
        assert_eq!(marking(&player, "N"), ["a"]);
    }
    // A finite one goes through.
    assert_eq!(
        fire(&mut player, &ev("fix").param("lat", 43.5), 4 * S),
        ["N.goto"]
    );
}

#[test]
fn a_float_literal_too_large_is_a_load_error() {
    let files = [
        ("project.toml", "[[net]]\nfile = \"n.toml\"\nactive = true\n"),
        (
            "n.toml",
            "name = \"N\"\nplaces = [\"a\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"a\"]\non = \"go\"\ndo = [\"emit x {v: 1e999}\"]\n",
        ),
    ];
    let e = nets::load(&files).expect_err("refused").to_string();
    let report = format!("{e:?}");
    assert!(
        e.contains("too large for a float") || report.contains("too large for a float"),
        "{e}\n{report}"
    );
}
