//! The operator dialog in the player: `ask NAME "QUESTION" {choices: [..]}
//! timeout DURATION` (docs/nets.md, "Asking the operator").

use std::sync::Arc;

use crate::common::*;
use nets::player::{snapshot, AnswerRefusal, DropReason, Effect, Player};
use nets::{Event, Project};

const S: u64 = 1_000_000;

const SURVEY: &str = r#"name = "N"
places = ["idle", "asking", "surveying", "skipped", "timed_out"]
initial = ["idle"]
[[transition]]
name = "ask"
from = ["idle"]
to = ["asking"]
on = "reached_t2"
do = ['ask survey "Survey T2?" {choices: [yes, no]} timeout 60s']
[[transition]]
name = "yes"
from = ["asking"]
to = ["surveying"]
on = "survey.yes"
[[transition]]
name = "no"
from = ["asking"]
to = ["skipped"]
on = "survey.no"
[[transition]]
name = "timeout"
from = ["asking"]
to = ["timed_out"]
on = "survey.timeout"
"#;

fn asked(p: &Arc<Project>) -> (Player, u64) {
    let mut player = Player::start(p.clone(), 0);
    drain(&mut player);
    player.handle(&Event::new("reached_t2"), 10 * S);
    let effects = drain_effects(&mut player);
    let id = effects
        .iter()
        .find_map(|e| match e {
            Effect::Ask {
                id,
                question,
                choices,
                deadline,
                ..
            } => {
                assert_eq!(question, "Survey T2?");
                assert_eq!(choices, &["yes", "no"]);
                assert_eq!(*deadline, 70 * S);
                Some(*id)
            }
            _ => None,
        })
        .expect("an ask effect");
    assert_eq!(player.questions().collect::<Vec<_>>(), [(id, 0, 0)]);
    (player, id)
}

#[test]
fn an_answer_in_time_delivers_its_choice_to_the_net_and_cancels_the_timeout() {
    let p = one_net(SURVEY);
    for (choice, place) in [("yes", "surveying"), ("no", "skipped")] {
        let (mut player, id) = asked(&p);
        assert_eq!(player.answer(id, choice, 69 * S), Ok(()));
        let effects = drain_effects(&mut player);
        assert!(effects.iter().any(
            |e| matches!(e, Effect::Answered { id: i, choice: c, .. } if *i == id && c == choice)
        ));
        assert_eq!(fired(&p, &effects), [format!("N.{choice}")]);
        assert_eq!(marking(&player, "N"), [place]);
        assert_eq!(player.questions().count(), 0);
        assert_eq!(player.next_deadline(), None, "the timeout is cancelled");
        // Answered once: a second answer is refused.
        assert_eq!(
            player.answer(id, choice, 69 * S),
            Err(AnswerRefusal::NotPending)
        );
    }
}

#[test]
fn without_an_answer_the_timeout_fires_on_the_vehicle_time_and_a_late_answer_is_dropped() {
    let p = one_net(SURVEY);
    let (mut player, id) = asked(&p);
    player.advance(69 * S);
    assert!(fired(&p, &drain_effects(&mut player)).is_empty());
    player.advance(70 * S);
    let effects = drain_effects(&mut player);
    assert!(effects
        .iter()
        .any(|e| matches!(e, Effect::Unanswered { id: i, .. } if *i == id)));
    assert_eq!(fired(&p, &effects), ["N.timeout"]);
    assert_eq!(player.questions().count(), 0);
    assert_eq!(
        player.answer(id, "yes", 71 * S),
        Err(AnswerRefusal::NotPending)
    );
    let effects = drain_effects(&mut player);
    assert!(matches!(
        effects[..],
        [Effect::AnswerRefused {
            reason: AnswerRefusal::NotPending,
            ..
        }]
    ));
    assert_eq!(marking(&player, "N"), ["timed_out"]);
    // Nothing but time changed.
    let mut later = Player::restore(p.clone(), player.snapshot()).expect("restores");
    later.advance(71 * S);
    assert_eq!(later.digest(), player.digest());
}

#[test]
fn an_answer_arriving_at_the_deadline_is_late_the_timeout_wins() {
    let p = one_net(SURVEY);
    let (mut player, id) = asked(&p);
    assert_eq!(
        player.answer(id, "yes", 70 * S),
        Err(AnswerRefusal::NotPending)
    );
    assert_eq!(fired(&p, &drain_effects(&mut player)), ["N.timeout"]);
}

#[test]
fn an_unknown_choice_or_question_is_refused_and_the_question_stays_pending() {
    let p = one_net(SURVEY);
    let (mut player, id) = asked(&p);
    assert_eq!(
        player.answer(id, "maybe", 20 * S),
        Err(AnswerRefusal::NotOffered)
    );
    assert_eq!(
        player.answer(id + 7, "yes", 20 * S),
        Err(AnswerRefusal::NotPending)
    );
    let effects = drain_effects(&mut player);
    assert!(fired(&p, &effects).is_empty());
    assert_eq!(effects.len(), 2);
    assert_eq!(player.questions().count(), 1);
    assert_eq!(player.answer(id, "no", 21 * S), Ok(()));
    assert_eq!(marking(&player, "N"), ["skipped"]);
}

#[test]
fn an_outside_event_named_like_an_answer_or_a_timeout_is_dropped_as_reserved() {
    let p = one_net(SURVEY);
    let (mut player, _) = asked(&p);
    for name in ["survey.yes", "survey.timeout"] {
        player.handle(&Event::new(name), 20 * S);
        assert!(matches!(
            drain_effects(&mut player)[..],
            [Effect::Dropped {
                reason: DropReason::Reserved,
                ..
            }]
        ));
    }
    assert_eq!(marking(&player, "N"), ["asking"]);
}

#[test]
fn a_result_never_answers_a_question() {
    let p = one_net(SURVEY);
    let (mut player, id) = asked(&p);
    player.result(id, nets::player::Outcome::Done(Default::default()), 20 * S);
    assert!(matches!(
        drain_effects(&mut player)[..],
        [Effect::LateResult { .. }]
    ));
    assert_eq!(player.questions().count(), 1);
}

#[test]
fn a_pending_question_is_in_the_snapshot_and_the_digest() {
    let p = one_net(SURVEY);
    let (player, id) = asked(&p);
    let bytes = snapshot::encode(&player.snapshot());
    let state = snapshot::decode(&bytes).expect("decodes");
    assert_eq!(state, player.snapshot());
    assert_eq!(snapshot::encode(&state), bytes);
    let mut restored = Player::restore(p.clone(), state).expect("restores");
    assert_eq!(restored.digest(), player.digest());
    // The digest tells a pending question apart from none.
    let mut answered = Player::restore(p.clone(), player.snapshot()).expect("restores");
    let mut timed = Player::restore(p.clone(), player.snapshot()).expect("restores");
    answered.answer(id, "yes", 20 * S).expect("answered");
    timed.advance(20 * S);
    assert_ne!(answered.digest(), timed.digest());
    let mut player = player;
    for x in [&mut player, &mut restored] {
        x.answer(id, "no", 30 * S).expect("answered");
    }
    assert_eq!(drain_effects(&mut player), drain_effects(&mut restored));
    assert_eq!(player.digest(), restored.digest());
}

#[test]
fn asking_again_replaces_the_pending_question_and_restarts_its_timeout() {
    let p = one_net(
        r#"name = "N"
places = ["a"]
initial = ["a"]
[[transition]]
name = "ask"
from = ["a"]
to = ["a"]
on = "go"
do = ['ask q "Go?" {choices: [go]} timeout 10s']
"#,
    );
    let mut player = Player::start(p.clone(), 0);
    player.handle(&Event::new("go"), 0);
    let first: Vec<u64> = player.questions().map(|q| q.0).collect();
    player.handle(&Event::new("go"), 5 * S);
    let second: Vec<u64> = player.questions().map(|q| q.0).collect();
    assert_eq!((first.len(), second.len()), (1, 1));
    assert_ne!(first, second);
    assert!(drain_effects(&mut player)
        .iter()
        .any(|e| matches!(e, Effect::Forgotten { id, .. } if *id == first[0])));
    assert_eq!(player.next_deadline(), Some(15 * S));
    assert_eq!(
        player.answer(first[0], "go", 6 * S),
        Err(AnswerRefusal::NotPending)
    );
}

#[test]
fn load_errors_name_the_bad_ask() {
    for (action, message) in [
        (
            r#"ask q "Go?" {choices: [yes, yes]} timeout 1s"#,
            "choice `yes` is offered twice",
        ),
        (
            r#"ask q "Go?" {choices: [yes, timeout]} timeout 1s"#,
            "reserved for the ask's timeout event",
        ),
        (r#"ask q "Go?" {choices: [yes]} timeout soon"#, "duration"),
    ] {
        let net = format!(
            "name = \"N\"\nplaces = [\"a\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"a\"]\non = \"go\"\ndo = ['{action}']\n"
        );
        let sources: std::collections::BTreeMap<String, String> = [
            (
                "project.toml".to_owned(),
                "[[net]]\nfile = \"n.toml\"\nactive = true\n".to_owned(),
            ),
            ("n.toml".to_owned(), net),
        ]
        .into();
        let err = nets::load(&sources).expect_err(action).to_string();
        assert!(err.contains(message), "{action}: {err}");
    }
}

#[test]
fn a_script_answers_by_name_or_id_and_a_late_answer_is_refused_not_an_error() {
    let p = one_net(SURVEY);
    let script = nets::script::parse(
        "{\"t\": 10, \"event\": \"reached_t2\"}\n{\"t\": 20, \"answer\": \"survey\", \"choice\": \"no\"}\n",
    )
    .expect("parses");
    let mut player = Player::start(p.clone(), 0);
    for line in &script {
        nets::script::play_line(&mut player, line).expect("plays");
    }
    assert_eq!(marking(&player, "N"), ["skipped"]);
    // By id, after the deadline: refused by the player, the script goes on.
    let script = nets::script::parse(
        "{\"t\": 10, \"event\": \"reached_t2\"}\n{\"t\": 80, \"answer\": 1, \"choice\": \"yes\"}\n",
    )
    .expect("parses");
    let mut player = Player::start(p.clone(), 0);
    for line in &script {
        nets::script::play_line(&mut player, line).expect("plays");
    }
    assert_eq!(marking(&player, "N"), ["timed_out"]);
    // By name with none pending: an error naming the line.
    let script = nets::script::parse("{\"t\": 5, \"answer\": \"survey\", \"choice\": \"yes\"}\n")
        .expect("parses");
    let mut player = Player::start(p, 0);
    let e = nets::script::play_line(&mut player, &script[0]).expect_err("none pending");
    assert!(
        e.to_string().contains("no pending question `survey`"),
        "{e}"
    );
}
