//! Another site's page against Petrel's servers (issue 39,
//! docs/reliability.md "The web pages"): the real `petrel edit`, `view`
//! and `demo` over 127.0.0.1, sent what a hostile page in the crew's
//! browser can make it send — a DNS-rebound Host with a matching Origin,
//! a foreign Origin on the WebSocket, a cross-site script's GET, stubs
//! written outside the project, an unfinished 60 MB WebSocket message,
//! one WebSocket too many — and the same requests from the page itself,
//! which must still work. No browser needed: raw HTTP over TCP, as a page
//! or a rebinding attacker would put it on the wire.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

use super::browser::copy_example;
use super::{demo_live, example, spawn, url, Scratch};

/// The address part of a page's URL (`127.0.0.1:PORT`).
fn address(url: &str) -> String {
    url.trim_start_matches("http://")
        .trim_end_matches('/')
        .to_owned()
}

fn connect(at: &str) -> TcpStream {
    let s = TcpStream::connect(at).unwrap_or_else(|e| panic!("{at}: {e}"));
    let _ = s.set_read_timeout(Some(Duration::from_secs(20)));
    let _ = s.set_write_timeout(Some(Duration::from_secs(20)));
    s
}

/// One request with the given headers (Host among them); the status, the
/// response's head and body.
fn request(at: &str, method: &str, path: &str, headers: &[(&str, &str)], body: &str) -> Answer {
    let mut s = connect(at);
    let mut head = format!("{method} {path} HTTP/1.1\r\n");
    for (name, value) in headers {
        head.push_str(&format!("{name}: {value}\r\n"));
    }
    head.push_str(&format!(
        "Content-Length: {}\r\nConnection: close\r\n\r\n",
        body.len()
    ));
    s.write_all(head.as_bytes())
        .and_then(|_| s.write_all(body.as_bytes()))
        .unwrap_or_else(|e| panic!("{at}{path}: {e}"));
    let mut answer = Vec::new();
    let _ = s.read_to_end(&mut answer);
    let answer = String::from_utf8_lossy(&answer).into_owned();
    let (head, body) = answer.split_once("\r\n\r\n").unwrap_or((&answer, ""));
    Answer {
        status: head
            .split_whitespace()
            .nth(1)
            .and_then(|c| c.parse().ok())
            .unwrap_or(0),
        head: head.to_ascii_lowercase(),
        body: body.to_owned(),
    }
}

#[derive(Debug)]
struct Answer {
    status: u16,
    head: String,
    body: String,
}

/// A WebSocket handshake on `/ws` with `origin` (none: a tool, not a
/// browser) and `host`: the status and the open stream.
fn upgrade(at: &str, host: &str, origin: Option<&str>) -> (u16, TcpStream) {
    let mut s = connect(at);
    let origin = origin
        .map(|o| format!("Origin: {o}\r\n"))
        .unwrap_or_default();
    let head = format!(
        "GET /ws HTTP/1.1\r\nHost: {host}\r\n{origin}Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
    );
    s.write_all(head.as_bytes())
        .unwrap_or_else(|e| panic!("{at}: {e}"));
    // The response head, byte by byte (the frames follow it).
    let mut got = Vec::new();
    let mut byte = [0u8; 1];
    while !got.ends_with(b"\r\n\r\n") && got.len() < 8192 {
        match s.read(&mut byte) {
            Ok(1) => got.push(byte[0]),
            _ => break,
        }
    }
    let status = String::from_utf8_lossy(&got)
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    (status, s)
}

/// One frame from the server (unmasked): its opcode and payload.
fn read_frame(s: &mut TcpStream) -> (u8, Vec<u8>) {
    let mut two = [0u8; 2];
    s.read_exact(&mut two)
        .unwrap_or_else(|e| panic!("no frame: {e}"));
    let len = match two[1] & 0x7f {
        126 => {
            let mut b = [0u8; 2];
            s.read_exact(&mut b).unwrap_or_else(|e| panic!("{e}"));
            u64::from(u16::from_be_bytes(b))
        }
        127 => {
            let mut b = [0u8; 8];
            s.read_exact(&mut b).unwrap_or_else(|e| panic!("{e}"));
            u64::from_be_bytes(b)
        }
        n => u64::from(n),
    };
    assert!(len < 64 << 20, "a frame of {len} bytes");
    let mut payload = vec![0u8; len as usize];
    s.read_exact(&mut payload).unwrap_or_else(|e| panic!("{e}"));
    (two[0] & 0x0f, payload)
}

/// Whether the server ends the connection within `limit` while it is fed
/// up to `bytes` more of a message's payload: a read gets the end of the
/// stream, a reset or a close frame, or a write fails.
fn closed_while_fed(s: &mut TcpStream, bytes: usize, limit: Duration) -> bool {
    use std::io::ErrorKind;
    let _ = s.set_read_timeout(Some(Duration::from_millis(50)));
    let until = Instant::now() + limit;
    let piece = vec![0x41u8; 16 * 1024];
    let mut sent = 0;
    let mut buf = [0u8; 4096];
    while Instant::now() < until {
        if sent < bytes {
            if s.write_all(&piece).is_err() {
                return true;
            }
            sent += piece.len();
        }
        match s.read(&mut buf) {
            Ok(0) => return true,
            Ok(_) if buf[0] & 0x0f == 0x8 => return true,
            Ok(_) => {}
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(_) => return true,
        }
    }
    false
}

/// The head of a masked, unfinished text message of `len` bytes (FIN
/// clear: more fragments would follow).
fn unfinished_message(len: u64) -> Vec<u8> {
    let mut head = vec![0x01, 0x80 | 127];
    head.extend_from_slice(&len.to_be_bytes());
    head.extend_from_slice(&[1, 2, 3, 4]);
    head
}

fn nets_text(dir: &Path) -> String {
    let mut all = String::new();
    for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{e}")) {
        let path = entry.unwrap_or_else(|e| panic!("{e}")).path();
        if path.extension().is_some_and(|e| e == "toml") {
            all.push_str(&std::fs::read_to_string(&path).unwrap_or_default());
        }
    }
    all
}

#[test]
fn the_editor_answers_only_its_own_page() {
    let tmp = Scratch::new("hostile-edit");
    let dir = tmp.path().join("project");
    std::fs::create_dir(&dir).unwrap_or_else(|e| panic!("{e}"));
    copy_example(&dir);
    let (_edit, rx) = spawn(
        &["edit", "--http", "127.0.0.1:0", &dir.to_string_lossy()],
        tmp.path(),
    );
    let at = address(&url(&rx, "edit: ", Duration::from_secs(60)));
    let port = at.rsplit(':').next().unwrap_or("0").to_owned();
    let evil_host = format!("evil.example:{port}");
    let evil_origin = format!("http://evil.example:{port}");
    let own_origin = format!("http://{at}");
    let json = ("Content-Type", "application/json");
    let add = r#"{"op":"add_place","net":"COMMUNICATION","name":"rebound"}"#;
    let before = nets_text(&dir);

    // 1. DNS rebinding: Host and Origin agree on a name of the attacker's.
    let rebound = [("Host", evil_host.as_str()), ("Origin", &evil_origin), json];
    for (method, path, body) in [
        ("POST", "/edit", add),
        ("POST", "/stubs", r#"{"lang":"python"}"#),
        ("POST", "/undo", ""),
        ("POST", "/redo", ""),
        ("POST", "/reload", ""),
        ("GET", "/page.json", ""),
        ("GET", "/version", ""),
        ("GET", "/", ""),
    ] {
        let a = request(&at, method, path, &rebound, body);
        assert_eq!(a.status, 421, "{method} {path}: {a:?}");
        assert!(a.body.contains("not an address of this computer"), "{a:?}");
    }
    assert_eq!(
        nets_text(&dir),
        before,
        "a rebound request changed the project"
    );
    assert!(!dir.join("stubs").exists());

    // Another site's script reading the draft (no Origin on a no-cors GET).
    let a = request(
        &at,
        "GET",
        "/page.json",
        &[
            ("Host", &at),
            ("Sec-Fetch-Site", "cross-site"),
            ("Sec-Fetch-Mode", "no-cors"),
            ("Sec-Fetch-Dest", "script"),
        ],
        "",
    );
    assert_eq!(a.status, 403, "{a:?}");
    // Another site posting with its own Origin.
    let a = request(
        &at,
        "POST",
        "/edit",
        &[("Host", &at), ("Origin", "http://evil.example"), json],
        add,
    );
    assert_eq!(a.status, 403, "{a:?}");
    assert_eq!(nets_text(&dir), before);

    // The page itself still edits, and no other page may frame it.
    let page = [("Host", at.as_str()), ("Origin", own_origin.as_str()), json];
    let a = request(&at, "POST", "/edit", &page, add);
    assert_eq!(a.status, 200, "{a:?}");
    assert!(nets_text(&dir).contains("rebound"), "the page's edit");
    let a = request(&at, "GET", "/", &[("Host", &at)], "");
    assert_eq!(a.status, 200);
    assert!(a.head.contains("x-frame-options: deny"), "{}", a.head);
    assert!(a.head.contains("frame-ancestors 'none'"), "{}", a.head);

    // 2. Stubs only into a folder of the project.
    let elsewhere = tmp.path().join("elsewhere");
    let out = elsewhere.to_string_lossy().to_string();
    for out in [
        out.as_str(),
        "../../x",
        "../elsewhere",
        "stubs/../../elsewhere",
    ] {
        let body = serde_json::json!({"lang": "python", "out": out, "force": true}).to_string();
        let a = request(&at, "POST", "/stubs", &page, &body);
        assert_eq!(a.status, 400, "{out}: {a:?}");
        assert!(a.body.contains("a folder of the project"), "{out}: {a:?}");
    }
    assert!(!elsewhere.exists(), "stubs written outside the project");
    assert!(!tmp.path().join("x").exists());
    let a = request(
        &at,
        "POST",
        "/stubs",
        &page,
        r#"{"lang":"python","out":"programs"}"#,
    );
    assert_eq!(a.status, 200, "{a:?}");
    assert!(dir.join("programs/DEC.py").is_file(), "{a:?}");

    // A body far beyond any edit.
    let big = format!(
        r#"{{"op":"add_place","net":"COMMUNICATION","name":"{}"}}"#,
        "a".repeat(100_000)
    );
    let a = request(&at, "POST", "/edit", &page, &big);
    assert_eq!(a.status, 413, "{}", a.status);
}

#[test]
fn the_live_and_recorded_pages_websockets_answer_only_their_own_page() {
    let tmp = Scratch::new("hostile-ws");
    let mcap = tmp.path().join("flight.mcap");
    let mcap_s = mcap.to_string_lossy().to_string();
    // Live: the demo's flight with its page.
    let (demo, rx) = demo_live(tmp.path(), &mcap_s);
    let live = address(&url(&rx, "monitor: ", Duration::from_secs(600)));
    let (status, _) = upgrade(&live, &live, Some("http://evil.example"));
    assert_eq!(status, 403, "another site's page reading the live flight");
    let (status, _) = upgrade(&live, "evil.example:80", Some("http://evil.example:80"));
    assert_eq!(status, 421, "a rebound name");
    let (status, mut own) = upgrade(&live, &live, Some(&format!("http://{live}")));
    assert_eq!(status, 101, "the page itself");
    let (op, first) = read_frame(&mut own);
    assert_eq!(op, 0x1, "a text frame");
    assert!(serde_json::from_slice::<serde_json::Value>(&first).is_ok());
    drop(own);
    // Let the flight go on a little so the recording holds it, then stop.
    std::thread::sleep(Duration::from_secs(5));
    drop(demo);

    // Recorded: the same flight in `petrel view`.
    let (_view, rx) = spawn(
        &[
            "view",
            &mcap_s,
            &example().to_string_lossy(),
            "--http",
            "127.0.0.1:0",
        ],
        tmp.path(),
    );
    let at = address(&url(&rx, "view: ", Duration::from_secs(120)));
    let own_origin = format!("http://{at}");
    assert_eq!(upgrade(&at, &at, Some("http://evil.example")).0, 403);
    assert_eq!(upgrade(&at, &at, Some("null")).0, 403);
    assert_eq!(
        request(&at, "GET", "/page.json", &[("Host", "evil.example")], "").status,
        421
    );
    assert_eq!(upgrade(&at, &at, None).0, 101, "a tool without Origin");

    // An unfinished 60 MB message, and one too long in 4 KiB fragments:
    // the server ends the connection instead of holding them.
    let (status, mut s) = upgrade(&at, &at, Some(&own_origin));
    assert_eq!(status, 101);
    assert_eq!(read_frame(&mut s).0, 0x1, "the flight's first instant");
    s.write_all(&unfinished_message(8 << 20))
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        closed_while_fed(&mut s, 1 << 20, Duration::from_secs(20)),
        "an unfinished 8 MiB message (under tungstenite's own 16 MiB frame limit) was held"
    );
    let (status, mut s) = upgrade(&at, &at, Some(&own_origin));
    assert_eq!(status, 101);
    assert_eq!(read_frame(&mut s).0, 0x1);
    let mut fragments = Vec::new();
    for i in 0..16u8 {
        let op = if i == 0 { 0x01 } else { 0x00 };
        fragments.extend_from_slice(&[op, 0x80 | 126, 0x10, 0x00, 9, 9, 9, 9]);
        fragments.extend(std::iter::repeat_n(0x20u8, 0x1000));
    }
    let _ = s.write_all(&fragments);
    assert!(
        closed_while_fed(&mut s, 0, Duration::from_secs(20)),
        "a 64 KiB message in fragments was held"
    );

    // The page's own message is still answered (a step through the
    // flight), on a socket of its own.
    let (status, mut s) = upgrade(&at, &at, Some(&own_origin));
    assert_eq!(status, 101);
    let ask = br#"{"at":0,"step":1}"#;
    let mut message = vec![0x81, 0x80 | ask.len() as u8, 0, 0, 0, 0];
    message.extend_from_slice(ask);
    assert_eq!(read_frame(&mut s).0, 0x1);
    s.write_all(&message).unwrap_or_else(|e| panic!("{e}"));
    let (op, answer) = read_frame(&mut s);
    assert_eq!(op, 0x1);
    assert!(serde_json::from_slice::<serde_json::Value>(&answer).is_ok());
    drop(s);

    // At most 16 WebSockets at once; one given back makes room.
    std::thread::sleep(Duration::from_millis(300));
    let mut open: Vec<TcpStream> = Vec::new();
    let until = Instant::now() + Duration::from_secs(30);
    loop {
        let (status, s) = upgrade(&at, &at, None);
        if status != 101 {
            assert_eq!(status, 503, "the socket past the cap");
            break;
        }
        open.push(s);
        assert!(open.len() <= 16, "more than 16 WebSockets taken");
        assert!(Instant::now() < until);
    }
    assert_eq!(open.len(), 16, "earlier sockets still counted");
    open.pop();
    let until = Instant::now() + Duration::from_secs(10);
    loop {
        let (status, _s) = upgrade(&at, &at, None);
        if status == 101 {
            break;
        }
        assert!(
            Instant::now() < until,
            "a closed socket never gave its place back"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}
