//! DEC against a fake gateway on 127.0.0.1: the hello, calls and replies
//! (a malformed call and bad arguments included), a refused hello, a
//! gateway that comes up late, the stop flag. Every wait is bounded.

use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serde_json::{json, Value};

const WAIT: Duration = Duration::from_secs(10);

fn mission() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../mission.toml")
}

fn accept(listener: &TcpListener) -> TcpStream {
    listener.set_nonblocking(true).expect("nonblocking");
    let start = Instant::now();
    loop {
        match listener.accept() {
            Ok((s, _)) => {
                s.set_nonblocking(false).expect("blocking");
                s.set_read_timeout(Some(WAIT)).expect("timeout");
                return s;
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                assert!(start.elapsed() < WAIT, "DEC never connected");
                std::thread::sleep(Duration::from_millis(10));
            }
            Err(e) => panic!("accept: {e}"),
        }
    }
}

fn read_json(reader: &mut impl BufRead) -> Value {
    let mut line = String::new();
    let n = reader
        .read_line(&mut line)
        .expect("a line from DEC in time");
    assert!(n > 0, "DEC closed the connection");
    serde_json::from_str(&line).unwrap_or_else(|e| panic!("DEC sent {line:?}: {e}"))
}

fn join<T>(handle: JoinHandle<T>) -> T {
    let start = Instant::now();
    while !handle.is_finished() {
        assert!(start.elapsed() < WAIT, "DEC did not return");
        std::thread::sleep(Duration::from_millis(10));
    }
    handle.join().expect("DEC's thread panicked")
}

fn spawn_dec(address: String, stop: Arc<AtomicBool>) -> JoinHandle<Result<(), petrel_dec::Error>> {
    std::thread::spawn(move || petrel_dec::serve_until(&address, &mission(), stop))
}

#[test]
fn hello_calls_replies_and_a_malformed_call() {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let address = format!("tcp:{}", listener.local_addr().expect("addr"));
    let dec = spawn_dec(address, Arc::new(AtomicBool::new(false)));
    let mut stream = accept(&listener);
    let mut reader = BufReader::new(stream.try_clone().expect("clone"));

    let hello = read_json(&mut reader);
    assert_eq!(hello["hello"], "DEC");
    let mut functions: Vec<&str> = hello["functions"]
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_str).collect())
        .unwrap_or_default();
    functions.sort_unstable();
    assert_eq!(
        functions,
        [
            "adopt",
            "emergency_plan",
            "emergency_site",
            "item",
            "payload_failed",
            "plan",
            "replan"
        ]
    );

    let lines = [
        json!({"welcome": "DEC", "functions": ["item", "plan"]}).to_string(),
        "this is not JSON".to_owned(),
        "[1, 2, 3]".to_owned(),
        json!({"call": 1, "function": "plan", "args": {}}).to_string(),
        json!({"call": 2, "function": "item", "args": {"seq": 3}}).to_string(),
        json!({"call": 3, "function": "item", "args": {"seq": "three"}}).to_string(),
        json!({"call": 4, "args": {}}).to_string(),
        json!({"call": 5, "function": "warp", "args": {}}).to_string(),
        json!({"call": 6, "function": "item", "args": [3]}).to_string(),
        // Near T1, 80 m up: the North field.
        json!({"call": 7, "function": "emergency_site", "args": {"lat": -35.3600, "lon": 149.16523, "alt": 100}}).to_string(),
        "".to_owned(),
        json!({"call": 8, "function": "payload_failed", "args": {"failed": 100}}).to_string() + "\r",
    ];
    for l in &lines {
        stream
            .write_all(format!("{l}\n").as_bytes())
            .expect("write");
    }
    stream.flush().expect("flush");

    let mut replies = Vec::new();
    for _ in 0..8 {
        replies.push(read_json(&mut reader));
    }
    let ids: Vec<u64> = replies.iter().filter_map(|r| r["reply"].as_u64()).collect();
    assert_eq!(ids, [1, 2, 3, 4, 5, 6, 7, 8], "{replies:#?}");
    let events: Vec<&str> = replies.iter().filter_map(|r| r["event"].as_str()).collect();
    assert_eq!(
        events,
        ["done", "done", "failed", "failed", "failed", "failed", "done", "done"]
    );
    assert_eq!(replies[0]["params"]["count"], 11);
    assert_eq!(replies[0]["params"]["items"][0]["command"], "TAKEOFF");
    assert_eq!(
        replies[1]["params"],
        json!({"seq": 3, "phase": "operations", "payload": "camera", "waypoint": "O1"})
    );
    let reason = |i: usize| {
        replies[i]["params"]["reason"]
            .as_str()
            .unwrap_or("")
            .to_owned()
    };
    assert!(
        reason(2).contains("`seq` must be a number"),
        "{}",
        reason(2)
    );
    assert!(reason(3).starts_with("malformed call"), "{}", reason(3));
    assert!(reason(4).contains("no function `warp`"), "{}", reason(4));
    assert!(
        reason(5).contains("`args` is not an object"),
        "{}",
        reason(5)
    );
    assert_eq!(replies[6]["params"]["name"], "North field");
    assert_eq!(replies[6]["params"]["reachable"], true);
    assert_eq!(
        replies[7]["params"],
        json!({"payload": "camera", "known": true})
    );

    // The gateway closes the session: DEC returns.
    drop(reader);
    drop(stream);
    drop(listener);
    assert!(join(dec).is_ok());
}

#[test]
fn a_refused_hello_is_an_error() {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let address = format!("tcp:{}", listener.local_addr().expect("addr"));
    let dec = spawn_dec(address, Arc::new(AtomicBool::new(false)));
    let mut stream = accept(&listener);
    let mut reader = BufReader::new(stream.try_clone().expect("clone"));
    assert_eq!(read_json(&mut reader)["hello"], "DEC");
    stream
        .write_all(b"{\"error\": \"program `DEC` is already connected\", \"line\": 1}\n")
        .expect("write");
    drop(stream);
    drop(reader);
    match join(dec) {
        Err(petrel_dec::Error::Refused(why)) => assert!(why.contains("already connected"), "{why}"),
        other => panic!("expected a refusal, got {other:?}"),
    }
}

#[test]
fn a_gateway_that_comes_up_late() {
    // A free port, closed again: DEC finds nobody at first.
    let port = TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port();
    let stop = Arc::new(AtomicBool::new(false));
    let dec = spawn_dec(format!("tcp:127.0.0.1:{port}"), stop);
    std::thread::sleep(Duration::from_millis(400));
    let listener = TcpListener::bind(("127.0.0.1", port)).expect("the port again");
    let mut stream = accept(&listener);
    let mut reader = BufReader::new(stream.try_clone().expect("clone"));
    assert_eq!(read_json(&mut reader)["hello"], "DEC");
    stream
        .write_all(b"{\"welcome\": \"DEC\", \"functions\": []}\n")
        .expect("write");
    stream
        .write_all(b"{\"call\": 1, \"function\": \"replan\", \"args\": {}}\n")
        .expect("write");
    let reply = read_json(&mut reader);
    assert_eq!(reply["params"]["changed"], false);
    drop(stream);
    drop(reader);
    assert!(join(dec).is_ok());
}

#[test]
fn the_stop_flag_ends_a_session() {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let address = format!("tcp:{}", listener.local_addr().expect("addr"));
    let stop = Arc::new(AtomicBool::new(false));
    let dec = spawn_dec(address, stop.clone());
    let mut stream = accept(&listener);
    let mut reader = BufReader::new(stream.try_clone().expect("clone"));
    assert_eq!(read_json(&mut reader)["hello"], "DEC");
    stream
        .write_all(b"{\"welcome\": \"DEC\", \"functions\": []}\n")
        .expect("write");
    // Half a line, then the stop: DEC returns without waiting for the rest.
    stream.write_all(b"{\"call\": 1, \"func").expect("write");
    std::thread::sleep(Duration::from_millis(200));
    stop.store(true, Ordering::Relaxed);
    assert!(join(dec).is_ok());
}

#[test]
fn nobody_there_is_an_error_after_the_attempts() {
    let port = TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port();
    let options = petrel_dec::Options {
        attempts: 3,
        first_delay: Duration::from_millis(10),
        ..petrel_dec::Options::default()
    };
    let dec = petrel_dec::Dec::new(petrel_dec::Mission::load(&mission()).expect("mission"));
    let stop = AtomicBool::new(false);
    match petrel_dec::serve_with(&format!("tcp:127.0.0.1:{port}"), dec, &options, &stop) {
        Err(petrel_dec::Error::Unreachable { attempts, .. }) => assert_eq!(attempts, 3),
        other => panic!("expected unreachable, got {other:?}"),
    }
}

#[cfg(unix)]
#[test]
fn over_a_unix_socket() {
    use std::os::unix::net::UnixListener;
    let path = std::env::temp_dir().join(format!("petrel-dec-test-{}.sock", std::process::id()));
    let _ = std::fs::remove_file(&path);
    let listener = UnixListener::bind(&path).expect("bind");
    let dec = spawn_dec(
        format!("unix:{}", path.display()),
        Arc::new(AtomicBool::new(false)),
    );
    let (mut stream, _) = listener.accept().expect("accept");
    stream.set_read_timeout(Some(WAIT)).expect("timeout");
    let mut reader = BufReader::new(stream.try_clone().expect("clone"));
    assert_eq!(read_json(&mut reader)["hello"], "DEC");
    stream
        .write_all(b"{\"welcome\": \"DEC\", \"functions\": []}\n{\"call\": 9, \"function\": \"adopt\", \"args\": {}}\n")
        .expect("write");
    let reply = read_json(&mut reader);
    assert_eq!(
        reply,
        json!({"reply": 9, "event": "failed", "params": {"reason": "no plan proposed"}})
    );
    drop(stream);
    drop(reader);
    assert!(join(dec).is_ok());
    let _ = std::fs::remove_file(&path);
}

#[test]
fn a_bad_mission_file_is_an_error_before_connecting() {
    let stop = Arc::new(AtomicBool::new(false));
    let bad = Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
    match petrel_dec::serve_until("tcp:127.0.0.1:9", &bad, stop) {
        Err(petrel_dec::Error::Mission(e)) => assert!(e.to_string().contains("Cargo.toml:"), "{e}"),
        other => panic!("expected a mission error, got {other:?}"),
    }
}
