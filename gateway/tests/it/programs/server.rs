//! The program server against a real child process (the fixture).

use std::time::Duration;

use nets::{Category, Outcome, Params, Value};

use super::programs::server::{Direction, ProgramInput};
use super::scratch::Scratch;
use super::support::*;
use petrel_core::programs::roster::Config;

fn check_indices(h: &Harness) {
    let names: Vec<&str> = h.project.programs[0]
        .functions
        .iter()
        .map(|f| f.name.as_str())
        .collect();
    assert_eq!(
        names,
        ["crash", "echo", "emit", "garbage", "hangup", "quit", "slow"]
    );
}

#[tokio::test]
async fn a_started_program_answers_calls_made_before_it_connected() {
    let mut h = Harness::start(&fixture_program("never", "5s", ALL), FUNCTIONS).await;
    check_indices(&h);
    // Called at once: the call waits for the started program's hello.
    let reply = Value::Map(params(&[("value", Value::Int(42))]));
    h.programs.call(1, 0, ECHO, params(&[("reply", reply)]));
    assert_eq!(
        h.outcome(1).await,
        Outcome::Done(params(&[("value", Value::Int(42))]))
    );
    let out = h.lines(Direction::Out);
    assert!(out[0].starts_with("{\"welcome\":\"P\""), "{out:?}");
    assert_eq!(
        out[1],
        "{\"call\":1,\"function\":\"echo\",\"args\":{\"reply\":{\"value\":42}}}"
    );
    assert!(h.lines(Direction::In)[0].contains("\"hello\""));
    assert!(h
        .traffic
        .iter()
        .skip(1)
        .all(|t| t.program.as_deref() == Some("P")));
    h.programs.shutdown().await;
}

#[tokio::test]
async fn hello_mismatch_is_refused_naming_the_missing_function() {
    let served = ["echo", "slow", "emit", "crash", "quit"];
    let mut h = Harness::start(&fixture_program("never", "5s", &served), FUNCTIONS).await;
    // Refused: the error reply, then the connection closes, the fixture
    // exits, and since it never connected it is lost.
    match h.next().await {
        ProgramInput::Lost { program, event } => {
            assert_eq!(program, "P");
            assert_eq!(event.name, "program_lost");
            assert_eq!(event.category, Category::Communication);
            assert_eq!(event.params.get("name"), Some(&Value::Str("P".into())));
        }
        other => panic!("expected the loss of P, got {other:?}"),
    }
    let out = h.lines(Direction::Out);
    assert_eq!(out.len(), 1, "{out:?}");
    let error: serde_json::Value = serde_json::from_str(out[0]).expect("json");
    assert_eq!(error["line"], 1);
    let message = error["error"].as_str().expect("an error");
    assert!(
        message.contains("garbage") && message.contains("does not serve"),
        "{message}"
    );
    // Never restarted: calls fail at once.
    h.programs.call(9, 0, ECHO, Params::new());
    assert_eq!(h.outcome(9).await, failed("not connected"));
    assert_eq!(h.starts().len(), 1);
    h.programs.shutdown().await;
}

#[tokio::test]
async fn malformed_json_gets_an_error_reply_and_the_connection_stays() {
    let mut h = Harness::start(&fixture_program("never", "5s", ALL), FUNCTIONS).await;
    h.programs.call(1, 0, GARBAGE, Params::new());
    let Outcome::Done(p) = h.outcome(1).await else {
        panic!("the garbage call fails")
    };
    assert!(
        matches!(p.get("error"), Some(Value::Str(e)) if e.starts_with("not JSON")),
        "{p:?}"
    );
    assert_eq!(p.get("line"), Some(&Value::Int(2)), "the hello was line 1");
    // Still connected: the next call is answered on the same connection.
    let reply = Value::Map(params(&[("value", Value::Bool(true))]));
    h.programs.call(2, 0, ECHO, params(&[("reply", reply)]));
    assert_eq!(
        h.outcome(2).await,
        Outcome::Done(params(&[("value", Value::Bool(true))]))
    );
    assert!(h.traffic.iter().all(|t| t.connection == 1));
    assert!(h.lines(Direction::In).contains(&"this is not json"));
    h.programs.shutdown().await;
}

#[tokio::test]
async fn a_crash_fails_the_pending_call_emits_program_lost_and_restarts_on_failure() {
    let mut h = Harness::start(&fixture_program("on-failure", "5s", ALL), FUNCTIONS).await;
    h.connected().await;
    h.programs
        .call(1, 0, SLOW, params(&[("delay", Value::Float(0.3))]));
    h.programs.call(2, 0, CRASH, Params::new());
    // The slow call is answered, then the crash fails the pending one:
    // the gateway starts P again, so the nets may ask again.
    assert_eq!(h.outcome(1).await, Outcome::Done(Params::new()));
    assert_eq!(h.outcome(2).await, failed("restarted"));
    assert!(matches!(h.next().await, ProgramInput::Lost { program, .. } if program == "P"));
    // Restarted: a call made now waits for the new hello and is answered.
    let reply = Value::Map(params(&[("value", Value::Int(2))]));
    h.programs.call(3, 0, ECHO, params(&[("reply", reply)]));
    assert_eq!(
        h.outcome(3).await,
        Outcome::Done(params(&[("value", Value::Int(2))]))
    );
    // The new process was welcomed with what the first one answered and
    // the call its crash failed (docs/programs.md "Restarts").
    let welcomes: Vec<serde_json::Value> = h
        .lines(Direction::Out)
        .into_iter()
        .filter(|l| l.contains("\"welcome\""))
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    assert_eq!(welcomes.len(), 2, "{welcomes:?}");
    assert!(welcomes[0].get("resume").is_none(), "{}", welcomes[0]);
    assert_eq!(
        welcomes[1]["resume"],
        serde_json::json!({
            "connection": 2,
            "answered": [{"call": 1, "function": "slow", "args": {"delay": 0.3},
                          "event": "done", "params": {}}],
            "dropped": 0,
            "restarted": [2],
        })
    );
    let starts = h.starts();
    assert_eq!(starts.len(), 2, "{starts:?}");
    assert!(!exists(starts[0]), "the crashed process was reaped");
    // A clean exit is not a failure: no restart, calls fail at once.
    h.programs.call(4, 0, QUIT, Params::new());
    assert_eq!(h.outcome(4).await, failed("program lost"));
    assert!(matches!(h.next().await, ProgramInput::Lost { .. }));
    tokio::time::sleep(Duration::from_millis(300)).await;
    h.programs.call(5, 0, ECHO, Params::new());
    assert_eq!(h.outcome(5).await, failed("not connected"));
    assert_eq!(h.starts().len(), 2);
    h.programs.shutdown().await;
}

/// A started program that closes its connection but goes on running is
/// lost, not restarted: its calls fail as `program lost` once its process
/// has not exited within a second.
#[tokio::test]
async fn a_program_that_hangs_up_but_runs_on_is_lost_not_restarted() {
    let mut h = Harness::start(&fixture_program("on-failure", "5s", ALL), FUNCTIONS).await;
    h.connected().await;
    let reply = Value::Map(params(&[("value", Value::Int(1))]));
    h.programs.call(1, 0, ECHO, params(&[("reply", reply)]));
    assert_eq!(
        h.outcome(1).await,
        Outcome::Done(params(&[("value", Value::Int(1))]))
    );
    h.programs.call(2, 0, HANGUP, Params::new());
    h.programs
        .call(3, 0, SLOW, params(&[("delay", Value::Float(0.1))]));
    assert_eq!(h.outcome(2).await, failed("program lost"));
    assert_eq!(h.outcome(3).await, failed("program lost"));
    assert!(matches!(h.next().await, ProgramInput::Lost { .. }));
    assert_eq!(h.starts().len(), 1, "not restarted");
    h.programs.shutdown().await;
}

#[tokio::test]
async fn restart_always_restarts_after_a_clean_exit_and_never_does_not() {
    let mut h = Harness::start(&fixture_program("always", "5s", ALL), FUNCTIONS).await;
    h.connected().await;
    h.programs.call(1, 0, QUIT, Params::new());
    assert_eq!(h.outcome(1).await, failed("restarted"));
    assert!(matches!(h.next().await, ProgramInput::Lost { .. }));
    h.programs.call(2, 0, EMIT, Params::new());
    assert!(matches!(h.next().await, ProgramInput::Event { .. }));
    assert_eq!(h.outcome(2).await, Outcome::Done(Params::new()));
    assert_eq!(h.starts().len(), 2);
    h.programs.shutdown().await;

    let mut h = Harness::start(&fixture_program("never", "5s", ALL), FUNCTIONS).await;
    h.connected().await;
    h.programs.call(1, 0, CRASH, Params::new());
    assert_eq!(h.outcome(1).await, failed("program lost"));
    assert!(matches!(h.next().await, ProgramInput::Lost { .. }));
    h.assert_quiet(Duration::from_millis(400)).await;
    h.programs.call(2, 0, ECHO, Params::new());
    assert_eq!(h.outcome(2).await, failed("not connected"));
    assert_eq!(h.starts().len(), 1);
    h.programs.shutdown().await;
}

#[tokio::test]
async fn a_slow_reply_times_out_and_its_late_reply_is_ignored() {
    let mut h = Harness::start(&fixture_program("never", "1s", ALL), FUNCTIONS).await;
    h.connected().await;
    let sent = std::time::Instant::now();
    h.programs
        .call(1, 0, SLOW, params(&[("delay", Value::Float(1.5))]));
    assert_eq!(h.outcome(1).await, failed("timeout"));
    assert!(sent.elapsed() >= Duration::from_secs(1));
    // Asked while the fixture still sleeps on call 1: it answers in order,
    // the late reply to 1 first (ignored: no outcome, no error reply), then
    // this one, within its own timeout.
    let reply = Value::Map(params(&[("value", Value::Int(1))]));
    h.programs.call(2, 0, ECHO, params(&[("reply", reply)]));
    assert_eq!(
        h.outcome(2).await,
        Outcome::Done(params(&[("value", Value::Int(1))]))
    );
    assert!(h
        .lines(Direction::In)
        .iter()
        .any(|l| l.contains("\"reply\": 1")));
    assert!(!h.lines(Direction::Out).iter().any(|l| l.contains("error")));
    h.programs.shutdown().await;
}

#[tokio::test]
async fn an_event_sent_on_its_own_reaches_the_nets_with_its_category() {
    let mut h = Harness::start(&fixture_program("never", "5s", ALL), FUNCTIONS).await;
    h.programs.call(1, 0, EMIT, Params::new());
    match h.next().await {
        ProgramInput::Event { program, event } => {
            assert_eq!(program, "P");
            assert_eq!(
                event,
                nets::Event::new("obstacle")
                    .category(Category::Safety)
                    .param("range", 7)
            );
        }
        other => panic!("expected the event, got {other:?}"),
    }
    assert_eq!(h.outcome(1).await, Outcome::Done(Params::new()));
    h.programs.shutdown().await;
}

#[tokio::test]
async fn a_forgotten_call_gets_no_outcome() {
    let mut h = Harness::start(&fixture_program("never", "5s", ALL), FUNCTIONS).await;
    h.connected().await;
    h.programs
        .call(1, 0, SLOW, params(&[("delay", Value::Float(0.2))]));
    h.programs.forget(1);
    h.programs.call(2, 0, EMIT, Params::new());
    assert!(matches!(h.next().await, ProgramInput::Event { .. }));
    assert_eq!(h.outcome(2).await, Outcome::Done(Params::new()));
    h.programs.shutdown().await;
}

#[tokio::test]
async fn a_program_that_is_not_started_nor_connected_fails_calls_at_once() {
    let mut h = Harness::start("", FUNCTIONS).await;
    let asked = std::time::Instant::now();
    h.programs.call(1, 0, ECHO, Params::new());
    assert_eq!(h.outcome(1).await, failed("not connected"));
    assert!(asked.elapsed() < Duration::from_secs(2));
    h.programs.call(2, 7, 0, Params::new());
    assert_eq!(h.outcome(2).await, failed("unknown program or function"));
    h.programs.shutdown().await;
}

#[tokio::test]
async fn shutdown_kills_a_program_that_ignores_sigterm_and_leaves_no_zombie() {
    let mut served = vec!["--stubborn"];
    served.extend_from_slice(ALL);
    let mut h = Harness::start(&fixture_program("always", "5s", &served), FUNCTIONS).await;
    h.connected().await;
    let starts = h.starts();
    assert_eq!(starts.len(), 1);
    assert!(exists(starts[0]));
    let asked = std::time::Instant::now();
    h.programs.shutdown().await;
    let took = asked.elapsed();
    assert!(
        took >= Duration::from_millis(500),
        "the grace period was given: {took:?}"
    );
    assert!(took < Duration::from_secs(5), "{took:?}");
    assert!(!exists(starts[0]), "killed and reaped");
    let log = std::fs::read_to_string(h.dir.path().join("starts.log")).expect("log");
    assert_eq!(log.lines().count(), 1, "not restarted on shutdown");
}

#[tokio::test]
async fn programs_connect_over_a_unix_socket() {
    let dir = Scratch::new("programs");
    let socket = dir.path().join("programs.sock");
    let mut config = config();
    config.address = format!("unix:{}", socket.display())
        .parse()
        .expect("address");
    let mut h = Harness::start_with(&fixture_program("never", "5s", ALL), FUNCTIONS, config).await;
    assert_eq!(
        h.programs.address().to_string(),
        format!("unix:{}", socket.display())
    );
    let reply = Value::Map(params(&[("value", Value::Str("unix".into()))]));
    h.programs.call(1, 0, ECHO, params(&[("reply", reply)]));
    assert_eq!(
        h.outcome(1).await,
        Outcome::Done(params(&[("value", Value::Str("unix".into()))]))
    );
    h.programs.shutdown().await;
    assert!(!socket.exists(), "the socket file is removed");
}

#[tokio::test]
async fn a_runaway_line_is_discarded_with_an_error_and_the_connection_stays() {
    use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};

    let mut h = Harness::start("", FUNCTIONS).await;
    let petrel_core::programs::address::Address::Tcp(address) = h.programs.address().clone() else {
        panic!("a TCP address")
    };
    let stream = tokio::net::TcpStream::connect(address)
        .await
        .expect("connects");
    let (read, mut write) = stream.into_split();
    let mut lines = BufReader::new(read).lines();
    let hello = format!("{{\"hello\": \"P\", \"functions\": {ALL:?}}}\n");
    write.write_all(hello.as_bytes()).await.expect("hello");
    let line = |l: Option<String>| -> serde_json::Value {
        serde_json::from_str(&l.expect("a line")).expect("JSON from the gateway")
    };
    let next = async |lines: &mut tokio::io::Lines<BufReader<tokio::net::tcp::OwnedReadHalf>>| {
        tokio::time::timeout(WAIT, lines.next_line())
            .await
            .expect("a line within the wait")
            .expect("readable")
    };
    assert_eq!(line(next(&mut lines).await)["welcome"], "P");
    // 3 MiB without a newline, in pieces, then its end and a good line.
    let chunk = vec![b'x'; 256 * 1024];
    for _ in 0..12 {
        write.write_all(&chunk).await.expect("write");
    }
    write
        .write_all(b"xxx\n{\"event\": \"obstacle\", \"params\": {\"range\": 1}}\n")
        .await
        .expect("write");
    let error = line(next(&mut lines).await);
    assert_eq!(error["line"], 2);
    assert!(error["error"]
        .as_str()
        .expect("error")
        .contains("longer than"));
    match h.next().await {
        ProgramInput::Event { event, .. } => assert_eq!(event.name, "obstacle"),
        other => panic!("expected the event, got {other:?}"),
    }
    let longest = h.traffic.iter().map(|t| t.line.len()).max().unwrap_or(0);
    assert!(longest < 1024, "the runaway line is not recorded whole");
    drop(write);
    assert!(matches!(h.next().await, ProgramInput::Lost { .. }));
    h.programs.shutdown().await;
}

/// The wiring `petrel run` does: the player's effects to the programs,
/// their outcomes and events back to the player.
#[tokio::test]
async fn the_player_and_a_started_program_play_together() {
    let dir = Scratch::new("programs");
    let project = format!(
        "name = \"duo\"\n[[net]]\nfile = \"n.toml\"\nactive = true\n\
         [events]\nobstacle = {{ category = \"safety\", params = [\"range\"] }}\n\
         {}\n{FUNCTIONS}",
        fixture_program("never", "5s", ALL)
    );
    let net = "name = \"N\"\nplaces = [\"a\", \"b\", \"c\", \"d\"]\ninitial = [\"a\"]\n\
        [[transition]]\nname = \"ask\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"go\"\ndo = [\"call P.emit\"]\n\
        [[transition]]\nname = \"seen\"\nfrom = [\"b\"]\nto = [\"c\"]\non = \"obstacle\"\nwhen = \"range == 7\"\n\
        [[transition]]\nname = \"done\"\nfrom = [\"c\"]\nto = [\"d\"]\non = \"P.emit.done\"\n\
        do = [\"call P.crash\"]\n\
        [[transition]]\nname = \"lost\"\nfrom = [\"d\"]\nto = [\"a\"]\non = \"P.crash.failed\"\n\
        when = \"reason == \\\"program lost\\\"\"\n";
    std::fs::write(dir.path().join("project.toml"), &project).expect("write");
    std::fs::write(dir.path().join("n.toml"), net).expect("write");
    let files = [("project.toml", project.as_str()), ("n.toml", net)];
    let project = std::sync::Arc::new(nets::load(&files).expect("loads"));
    let (programs, mut inputs) =
        super::programs::server::Programs::start(project.clone(), dir.path(), config())
            .await
            .expect("starts");
    let mut player = nets::Player::start(project.clone(), 0);
    let mut now: nets::Micros = 0;
    let mut fired = Vec::new();
    let carry_out = |player: &mut nets::Player, fired: &mut Vec<String>| {
        for effect in player.effects() {
            programs.effect(&effect);
            if let nets::Effect::Fired { transition, .. } = effect {
                fired.push(project.nets[0].transitions[transition].name.clone());
            }
        }
    };
    player.handle(&nets::Event::new("go"), now);
    carry_out(&mut player, &mut fired);
    while fired.len() < 4 {
        let input = tokio::time::timeout(WAIT, inputs.recv())
            .await
            .expect("an input within the wait")
            .expect("running");
        now += 1000;
        match input {
            ProgramInput::Outcome { id, outcome } => player.result(id, outcome, now),
            ProgramInput::Event { event, .. } | ProgramInput::Lost { event, .. } => {
                player.handle(&event, now)
            }
            ProgramInput::Traffic(_) => continue,
        }
        carry_out(&mut player, &mut fired);
    }
    assert_eq!(fired, ["ask", "seen", "done", "lost"]);
    programs.shutdown().await;
}

#[tokio::test]
async fn with_a_token_only_programs_that_give_it_connect_and_the_token_is_never_logged() {
    let config = Config {
        token: Some("s3cret-token".into()),
        ..config()
    };
    // A started program is given the token and connects.
    let mut h = Harness::start_with(&fixture_program("never", "5s", ALL), FUNCTIONS, config).await;
    h.connected().await;
    let reply = params(&[("value", Value::Int(7))]);
    h.programs
        .call(1, 0, ECHO, params(&[("reply", Value::Map(reply.clone()))]));
    assert_eq!(h.outcome(1).await, Outcome::Done(reply));
    // A client without the token, and one with a wrong one, are refused.
    let petrel_core::programs::address::Address::Tcp(at) = h.programs.address().clone() else {
        panic!("a TCP address")
    };
    for hello in [
        r#"{"hello": "Q", "functions": []}"#,
        r#"{"hello": "Q", "functions": [], "token": "guess"}"#,
    ] {
        let stream = tokio::net::TcpStream::connect(at).await.expect("connects");
        let (read, mut write) = stream.into_split();
        use tokio::io::{AsyncBufReadExt, AsyncWriteExt};
        write
            .write_all(format!("{hello}\n").as_bytes())
            .await
            .expect("hello");
        let mut lines = tokio::io::BufReader::new(read).lines();
        let reply = tokio::time::timeout(WAIT, lines.next_line())
            .await
            .expect("an answer")
            .expect("reads")
            .expect("a line");
        assert!(reply.contains("unauthorised"), "{hello}: {reply}");
        let closed = tokio::time::timeout(WAIT, lines.next_line())
            .await
            .expect("closes");
        assert!(
            matches!(closed, Ok(None)),
            "{hello}: closed after the refusal"
        );
    }
    // The token never appears in the traffic (which is logged and recorded).
    while let Ok(Some(input)) =
        tokio::time::timeout(Duration::from_millis(300), h.inputs.recv()).await
    {
        if let ProgramInput::Traffic(t) = input {
            h.traffic.push(t);
        }
    }
    let hello = h
        .traffic
        .iter()
        .find(|t| t.line.contains("\"hello\""))
        .expect("the hello was recorded");
    assert!(hello.line.contains("(redacted)"), "{}", hello.line);
    assert!(h.traffic.iter().all(|t| !t.line.contains("s3cret-token")));
    h.programs.shutdown().await;
}

#[tokio::test]
async fn listening_beyond_loopback_without_a_token_is_refused() {
    let dir = Scratch::new("programs");
    let project = write_project(dir.path(), &fixture_program("never", "5s", ALL), FUNCTIONS);
    let config = Config {
        address: "tcp:0.0.0.0:0".parse().expect("address"),
        ..config()
    };
    let Err(e) = super::programs::server::Programs::start(project, dir.path(), config).await else {
        panic!("must refuse");
    };
    assert!(e.to_string().contains("no token"), "{e}");
}

/// In a team, a call carries the vehicle it is for (an instance's); the
/// reply is matched by id alone.
#[tokio::test]
async fn a_teams_calls_name_their_vehicle() {
    let team = "[[vehicle]]\nname = \"R1\"\nsystem = 1\n\n[[vehicle]]\nname = \"R2\"\nsystem = 2\n";
    let settings = format!("{}{team}", fixture_program("never", "5s", ALL));
    let mut h = Harness::start(&settings, FUNCTIONS).await;
    let reply = Value::Map(params(&[("value", Value::Int(7))]));
    let call = |id, vehicle| nets::Effect::Call {
        time: 0,
        id,
        net: 0,
        program: 0,
        function: ECHO,
        args: params(&[("reply", reply.clone())]),
        vehicle,
    };
    assert!(h.programs.effect(&call(1, Some(1))));
    assert_eq!(
        h.outcome(1).await,
        Outcome::Done(params(&[("value", Value::Int(7))]))
    );
    assert!(h.programs.effect(&call(2, None)));
    assert_eq!(
        h.outcome(2).await,
        Outcome::Done(params(&[("value", Value::Int(7))]))
    );
    let out = h.lines(Direction::Out);
    assert_eq!(
        out[1],
        "{\"call\":1,\"function\":\"echo\",\"args\":{\"reply\":{\"value\":7}},\"vehicle\":\"R2\"}"
    );
    // A team net's call is no vehicle's: no key.
    assert_eq!(
        out[2],
        "{\"call\":2,\"function\":\"echo\",\"args\":{\"reply\":{\"value\":7}}}"
    );
    h.programs.shutdown().await;
}
