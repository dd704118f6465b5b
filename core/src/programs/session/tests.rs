//! One test per protocol rule, without sockets.

use std::sync::Arc;
use std::time::{Duration, Instant};

use nets::{Category, Outcome, Params, Value};
use serde_json::json;

use super::*;

fn roster() -> Arc<Roster> {
    let files = [
        (
            "project.toml",
            "[[net]]\nfile = \"n.toml\"\nactive = true\n\
             [events]\nobstacle = { category = \"safety\", params = [\"range\"] }\n\
             program_lost = \"communication\"\n\
             [programs.DEC]\ntimeout = \"2s\"\n\
             [programs.DEC.functions]\nnext = { returns = [\"lat\", \"lon\"] }\n\
             replan = { args = [\"failed\"] }\nspare = {}\n\
             [programs.GUI.functions]\ngoto = {}\n",
        ),
        (
            "n.toml",
            "name = \"N\"\nplaces = [\"a\", \"b\", \"c\"]\ninitial = [\"a\"]\n\
             [[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"go\"\n\
             do = [\"call DEC.next\", \"call DEC.replan {failed: cam}\"]\n\
             [[transition]]\nname = \"u\"\nfrom = [\"b\"]\nto = [\"c\"]\non = \"go\"\n\
             do = [\"call GUI.goto\", \"emit replanned\"]\n",
        ),
    ];
    let project = Arc::new(nets::load(&files).expect("loads"));
    Arc::new(Roster::new(project).expect("roster"))
}

const DEC: usize = 0;
const NEXT: usize = 0;
const REPLAN: usize = 1;

fn free(_: usize) -> bool {
    false
}

fn drain(s: &mut Session) -> Vec<Output> {
    std::iter::from_fn(|| s.poll()).collect()
}

/// The outputs other than the traffic record.
fn actions(s: &mut Session) -> Vec<Output> {
    drain(s)
        .into_iter()
        .filter(|o| !matches!(o, Output::Received(_)))
        .collect()
}

fn sent_json(o: &Output) -> serde_json::Value {
    match o {
        Output::Send(line) => serde_json::from_str(line).expect("gateway sends JSON"),
        other => panic!("expected a line to send, got {other:?}"),
    }
}

fn ready() -> Session {
    let mut s = Session::new(roster(), Instant::now());
    s.feed(
        b"{\"hello\": \"DEC\", \"functions\": [\"next\", \"replan\", \"extra\"]}\n",
        free,
    );
    drain(&mut s);
    assert_eq!(s.program(), Some(DEC));
    s
}

fn error_of(o: &[Output]) -> (String, u64) {
    let [o] = o else {
        panic!("expected exactly one output, got {o:?}")
    };
    let v = sent_json(o);
    (
        v["error"].as_str().expect("an error reply").to_owned(),
        v["line"].as_u64().expect("a line number"),
    )
}

#[test]
fn hello_with_the_called_functions_is_welcomed() {
    let mut s = Session::new(roster(), Instant::now());
    s.feed(
        b"{\"hello\": \"DEC\", \"functions\": [\"replan\", \"next\"]}\n",
        free,
    );
    let out = drain(&mut s);
    assert!(matches!(&out[0], Output::Received(l) if l.starts_with("{\"hello\"")));
    assert_eq!(
        sent_json(&out[1]),
        json!({"welcome": "DEC", "functions": ["next", "replan"]})
    );
    assert_eq!(out[2], Output::Hello { program: DEC });
    assert_eq!(out.len(), 3);
    assert!(!s.is_closed());
}

#[test]
fn hello_missing_a_called_function_is_refused_and_closed() {
    let mut s = Session::new(roster(), Instant::now());
    s.feed(
        b"{\"hello\": \"DEC\", \"functions\": [\"next\"]}\n{\"event\": \"obstacle\"}\n",
        free,
    );
    let out = actions(&mut s);
    let (message, line) = error_of(&out[..1]);
    assert!(
        message.contains("replan") && !message.contains("next"),
        "{message}"
    );
    assert_eq!(line, 1);
    assert!(matches!(&out[1], Output::Close { reason } if reason.contains("replan")));
    assert_eq!(out.len(), 2, "nothing after the close: {out:?}");
    assert!(s.is_closed());
    assert_eq!(s.program(), None);
}

#[test]
fn hello_of_an_unknown_program_is_refused_naming_the_known_ones() {
    let mut s = Session::new(roster(), Instant::now());
    s.feed(b"{\"hello\": \"PLN\", \"functions\": []}\n", free);
    let out = actions(&mut s);
    let (message, _) = error_of(&out[..1]);
    assert!(
        message.contains("unknown program `PLN`") && message.contains("DEC, GUI"),
        "{message}"
    );
    assert!(matches!(out[1], Output::Close { .. }));
    assert!(s.is_closed());
}

#[test]
fn second_connection_of_a_program_is_refused() {
    let mut s = Session::new(roster(), Instant::now());
    s.feed(b"{\"hello\": \"GUI\", \"functions\": [\"goto\"]}\n", |p| {
        p == 1
    });
    let out = actions(&mut s);
    let (message, _) = error_of(&out[..1]);
    assert!(message.contains("already connected"), "{message}");
    assert!(s.is_closed());
}

#[test]
fn anything_before_the_hello_gets_an_error_and_the_connection_stays() {
    let mut s = Session::new(roster(), Instant::now());
    s.feed(b"{\"event\": \"obstacle\"}\n", free);
    let (message, line) = error_of(&actions(&mut s));
    assert!(message.contains("hello first"), "{message}");
    assert_eq!(line, 1);
    assert!(!s.is_closed());
    s.feed(b"{\"hello\": \"GUI\", \"functions\": [\"goto\"]}\n", free);
    assert!(actions(&mut s).contains(&Output::Hello { program: 1 }));
}

#[test]
fn a_second_hello_is_an_error() {
    let mut s = ready();
    s.feed(
        b"{\"hello\": \"DEC\", \"functions\": [\"next\", \"replan\"]}\n",
        free,
    );
    let (message, line) = error_of(&actions(&mut s));
    assert!(message.contains("hello again"), "{message}");
    assert_eq!(line, 2);
    assert_eq!(s.program(), Some(DEC));
}

#[test]
fn malformed_lines_get_an_error_with_their_number_and_the_connection_stays() {
    let mut s = ready();
    let now = Instant::now();
    assert!(s.call(1, NEXT, &Params::new(), now));
    drain(&mut s);
    for (n, bad) in [
        "this is not json",
        "{\"reply\": 1, \"event\": \"done\", \"params\": {\"lat\": 1}, \"x\": 2}",
        "{\"reply\": \"one\", \"event\": \"done\"}",
        "[]",
    ]
    .iter()
    .enumerate()
    {
        s.feed(format!("{bad}\n").as_bytes(), free);
        let (_, line) = error_of(&actions(&mut s));
        assert_eq!(line, n as u64 + 2, "{bad}");
        assert!(!s.is_closed());
    }
    assert_eq!(s.pending(), 1, "a malformed reply leaves the call pending");
    s.feed(
        b"{\"reply\": 1, \"event\": \"done\", \"params\": {\"lat\": 1, \"lon\": 2.5}}\n",
        free,
    );
    assert_eq!(
        actions(&mut s),
        vec![Output::Outcome {
            id: 1,
            outcome: Outcome::Done(Params::from([
                ("lat".into(), Value::Int(1)),
                ("lon".into(), Value::Float(2.5))
            ])),
            answered: true,
        }]
    );
}

#[test]
fn a_call_is_sent_and_its_replies_become_outcomes() {
    let mut s = ready();
    let now = Instant::now();
    let args = Params::from([("failed".into(), Value::Str("cam".into()))]);
    assert!(s.call(7, REPLAN, &args, now));
    assert!(s.call(8, REPLAN, &args, now));
    let out = drain(&mut s);
    assert_eq!(
        sent_json(&out[0]),
        json!({"call": 7, "function": "replan", "args": {"failed": "cam"}})
    );
    assert_eq!(s.pending(), 2);
    s.feed(
        b"{\"reply\": 8, \"event\": \"failed\", \"params\": {\"reason\": \"no plan\"}}\n{\"reply\": 7, \"event\": \"done\"}\n",
        free,
    );
    assert_eq!(
        actions(&mut s),
        vec![
            Output::Outcome {
                id: 8,
                outcome: Outcome::Failed("no plan".into()),
                answered: true,
            },
            Output::Outcome {
                id: 7,
                outcome: Outcome::Done(Params::new()),
                answered: true,
            }
        ]
    );
    assert_eq!(s.pending(), 0);
}

#[test]
fn a_done_reply_must_give_exactly_the_declared_returns() {
    let mut s = ready();
    assert!(s.call(1, NEXT, &Params::new(), Instant::now()));
    drain(&mut s);
    s.feed(
        b"{\"reply\": 1, \"event\": \"done\", \"params\": {\"lat\": 1, \"alt\": 3}}\n",
        free,
    );
    let (message, _) = error_of(&actions(&mut s));
    assert!(
        message.contains("missing lon") && message.contains("unknown alt"),
        "{message}"
    );
    assert_eq!(s.pending(), 1);
}

#[test]
fn a_reply_to_an_unknown_id_is_an_error() {
    let mut s = ready();
    s.feed(b"{\"reply\": 42, \"event\": \"done\"}\n", free);
    let (message, _) = error_of(&actions(&mut s));
    assert!(
        message.contains("42") && message.contains("not pending"),
        "{message}"
    );
    assert!(!s.is_closed());
}

#[test]
fn a_call_times_out_after_the_program_timeout_and_its_late_reply_is_ignored() {
    let mut s = ready();
    let t0 = Instant::now();
    assert!(s.call(3, NEXT, &Params::new(), t0));
    assert!(s.call(4, REPLAN, &Params::new(), t0 + Duration::from_secs(1)));
    drain(&mut s);
    assert_eq!(s.poll_timeout(), Some(t0 + Duration::from_secs(2)));
    s.handle_timeout(t0 + Duration::from_millis(1999));
    assert_eq!(actions(&mut s), vec![]);
    s.handle_timeout(t0 + Duration::from_secs(2));
    assert_eq!(
        actions(&mut s),
        vec![Output::Outcome {
            id: 3,
            outcome: Outcome::Failed("timeout".into()),
            answered: false,
        }]
    );
    assert_eq!(s.poll_timeout(), Some(t0 + Duration::from_secs(3)));
    s.feed(
        b"{\"reply\": 3, \"event\": \"done\", \"params\": {\"lat\": 1, \"lon\": 2}}\n",
        free,
    );
    assert_eq!(actions(&mut s), vec![Output::Late { id: 3 }]);
    assert_eq!(s.pending(), 1);
}

#[test]
fn a_forgotten_call_has_no_outcome_and_its_late_reply_is_ignored() {
    let mut s = ready();
    assert!(s.call(5, REPLAN, &Params::new(), Instant::now()));
    drain(&mut s);
    assert!(s.forget(5));
    assert!(!s.forget(5));
    assert_eq!(s.poll_timeout(), None);
    s.feed(
        b"{\"reply\": 5, \"event\": \"failed\", \"params\": {\"reason\": \"x\"}}\n",
        free,
    );
    assert_eq!(actions(&mut s), vec![Output::Late { id: 5 }]);
}

#[test]
fn a_lost_connection_fails_every_pending_call() {
    let mut s = ready();
    let now = Instant::now();
    assert!(s.call(1, NEXT, &Params::new(), now));
    assert!(s.call(2, REPLAN, &Params::new(), now));
    drain(&mut s);
    s.lost();
    let failed = |id| Output::Outcome {
        id,
        outcome: Outcome::Failed("program lost".into()),
        answered: false,
    };
    assert_eq!(actions(&mut s), vec![failed(1), failed(2)]);
    assert!(s.is_closed());
    assert!(
        !s.call(3, NEXT, &Params::new(), now),
        "no call on a closed session"
    );
}

#[test]
fn calls_before_the_hello_are_refused_to_the_caller() {
    let mut s = Session::new(roster(), Instant::now());
    assert!(!s.call(1, NEXT, &Params::new(), Instant::now()));
    assert_eq!(drain(&mut s), vec![]);
}

#[test]
fn events_take_the_declared_category_and_parameters() {
    let mut s = ready();
    s.feed(
        b"{\"event\": \"obstacle\", \"params\": {\"range\": 12.5}}\n{\"event\": \"wind\"}\n",
        free,
    );
    assert_eq!(
        actions(&mut s),
        vec![
            Output::Event(
                nets::Event::new("obstacle")
                    .category(Category::Safety)
                    .param("range", 12.5)
            ),
            Output::Event(nets::Event::new("wind")),
        ]
    );
}

#[test]
fn bad_events_are_errors() {
    for (line, says) in [
        (
            "{\"event\": \"obstacle\", \"params\": {\"bearing\": 1}}",
            "no parameter `bearing`",
        ),
        ("{\"event\": \"DEC.next.done\"}", "letters, digits"),
        ("{\"event\": \"\"}", "letters, digits"),
        ("{\"event\": \"9lives\"}", "letters, digits"),
        ("{\"event\": \"program_lost\"}", "gateway's own"),
        ("{\"event\": \"net_fault\"}", "raised by the player itself"),
        ("{\"event\": \"replanned\"}", "the nets emit this event"),
        ("{\"event\": \"signature_rejected\"}", "gateway's own"),
    ] {
        let mut s = ready();
        s.feed(format!("{line}\n").as_bytes(), free);
        let (message, _) = error_of(&actions(&mut s));
        assert!(message.contains(says), "{line}: {message}");
    }
}

#[test]
fn lines_split_across_reads_crlf_and_blank_lines() {
    let mut s = Session::new(roster(), Instant::now());
    s.feed(b"\n  \r\n{\"hello\": \"GUI\", ", free);
    assert_eq!(actions(&mut s), vec![]);
    s.feed(b"\"functions\": [\"goto\"]}\r", free);
    assert_eq!(actions(&mut s), vec![]);
    s.feed(b"\n[", free);
    assert!(actions(&mut s).contains(&Output::Hello { program: 1 }));
    s.feed(b"]\n", free);
    let (_, line) = error_of(&actions(&mut s));
    assert_eq!(line, 4, "blank lines count");
}

#[test]
fn a_line_longer_than_the_bound_is_discarded_with_an_error_and_memory_stays_bounded() {
    let mut s = ready();
    let chunk = vec![b'x'; 64 * 1024];
    for _ in 0..40 {
        s.feed(&chunk, free);
        assert!(s.buffer.len() <= MAX_LINE);
    }
    let out = actions(&mut s);
    let (message, line) = error_of(&out);
    assert!(message.contains("longer than"), "{message}");
    assert_eq!(line, 2);
    s.feed(b"xxx\n{\"event\": \"wind\"}\n", free);
    assert_eq!(
        actions(&mut s),
        vec![Output::Event(nets::Event::new("wind"))]
    );
}

#[test]
fn non_utf8_is_an_error() {
    let mut s = ready();
    s.feed(b"{\"event\": \"\xff\"}\n", free);
    let (message, _) = error_of(&actions(&mut s));
    assert!(message.contains("UTF-8"), "{message}");
}

#[test]
fn every_line_in_is_recorded_as_traffic() {
    let mut s = ready();
    s.feed(b"garbage\n{\"event\": \"wind\"}\n", free);
    let received: Vec<String> = drain(&mut s)
        .into_iter()
        .filter_map(|o| match o {
            Output::Received(l) => Some(l),
            _ => None,
        })
        .collect();
    assert_eq!(received, vec!["garbage", "{\"event\": \"wind\"}"]);
}

#[test]
fn the_lost_event_names_the_program_in_its_declared_category() {
    let r = roster();
    let e = lost_event(&r.project, "DEC");
    assert_eq!(
        e,
        nets::Event::new("program_lost")
            .category(Category::Communication)
            .param("name", "DEC")
    );
}

#[test]
fn a_connection_without_hello_is_closed_after_the_hello_timeout() {
    let t0 = Instant::now();
    let mut s = Session::new(roster(), t0);
    assert_eq!(s.poll_timeout(), Some(t0 + HELLO_TIMEOUT));
    s.handle_timeout(t0 + HELLO_TIMEOUT - Duration::from_millis(1));
    assert!(!s.is_closed());
    s.handle_timeout(t0 + HELLO_TIMEOUT);
    let out = actions(&mut s);
    let (message, line) = error_of(&out[..1]);
    assert!(message.contains("no hello"), "{message}");
    assert_eq!(line, 0, "no line was received");
    assert!(matches!(out[1], Output::Close { .. }));
    assert!(s.is_closed());
    assert_eq!(s.poll_timeout(), None);
    // Once said, the hello deadline no longer counts.
    let mut s = ready();
    assert_eq!(s.poll_timeout(), None);
    s.handle_timeout(t0 + HELLO_TIMEOUT * 2);
    assert!(!s.is_closed());
}

#[test]
fn a_program_that_connected_before_is_welcomed_with_its_resume() {
    let mut s = Session::new(roster(), Instant::now());
    let resume = json!({"connection": 2, "answered": [], "dropped": 0, "restarted": [4]});
    let given = resume.clone();
    s.feed_resuming(
        b"{\"hello\": \"DEC\", \"functions\": [\"replan\", \"next\"]}\n",
        free,
        move |p| (p == DEC).then(|| given.clone()),
    );
    let out = drain(&mut s);
    assert_eq!(
        sent_json(&out[1]),
        json!({"welcome": "DEC", "functions": ["next", "replan"], "resume": resume})
    );
}

#[test]
fn calls_pending_when_a_restarted_program_goes_fail_as_restarted() {
    let now = Instant::now();
    let mut s = Session::new(roster(), now);
    s.feed(
        b"{\"hello\": \"DEC\", \"functions\": [\"replan\", \"next\"]}\n",
        free,
    );
    drain(&mut s);
    assert!(s.call(5, 0, &Params::new(), now));
    drain(&mut s);
    s.lost_because(REASON_RESTARTED);
    assert_eq!(
        actions(&mut s),
        vec![Output::Outcome {
            id: 5,
            outcome: Outcome::Failed("restarted".into()),
            answered: false,
        }]
    );
    assert!(s.is_closed());
    assert_eq!(s.pending(), 0);
}
