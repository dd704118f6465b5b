//! The web monitor under load (issue 13, docs/monitor.md): `petrel run`
//! (release, recording on, the page served with `--http`) takes 10,000
//! telemetry frames a second — 10,000 player steps a second — for 60 s,
//! while the latency benchmark's scripted autopilot times its low-battery
//! SYS_STATUS to RTL reaction (`latency.rs`, the same project) over the same
//! UDP link. Three times, in the same run: with no browser; with two
//! WebSocket readers in this process reading the page's `/ws` as a browser
//! does (one takes every frame at once, one reads a frame every 2 s: a slow
//! browser) — the gateway's cost of serving, without a browser's rendering
//! on the same two cores; then with two real browsers on the page (two
//! Debian chromium processes driven by playwright-core,
//! `benches/monitor/browsers.js`; the second one's CPU throttled 20 times).
//! Each run prints the reaction's p50/p99/max, the gateway's resident
//! memory every 10 s, what the recorder kept, and what the readers
//! received.
//!
//! The browsers run at `nice 19` (the page is for a ground laptop, not for
//! the companion computer's cores; on this 2-core machine they would
//! otherwise measure chromium's rendering, not the gateway's serving);
//! `PETREL_BROWSERS_NICE=0` runs them at normal priority.
//!
//! Run: `cargo bench -p gateway --bench monitor_load` (Linux; needs node,
//! playwright-core in `target/browser-tools` or `PETREL_PLAYWRIGHT_CORE`,
//! and chromium: `.ci/run` installs them; without them it says so and
//! measures the run without browsers only). `PETREL_LOAD_SECONDS` (60)
//! and `PETREL_LOAD_RATE` (10,000 frames/s) change the load.

#[path = "support/autopilot.rs"]
#[allow(dead_code)]
mod autopilot;
use petrel_test_support::proc;
#[path = "support/telemetry.rs"]
#[allow(dead_code)]
mod telemetry;

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use elaboration::Frame;
use mavlink::dialects::ardupilotmega::MavMessage;

use autopilot::{Autopilot, Stats};
use proc::rss_kb;

/// A child killed and waited for when dropped, whatever happened.
struct Reaped(Child);

impl Drop for Reaped {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// node's playwright-core folder and chromium, or why not.
fn browser_tools() -> Result<(PathBuf, PathBuf), String> {
    let chromium = PathBuf::from(std::env::var("CHROMIUM").unwrap_or("/usr/bin/chromium".into()));
    if !chromium.exists() {
        return Err(format!("no chromium at {}", chromium.display()));
    }
    if !Command::new("node")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        return Err("no node on PATH".into());
    }
    let core = std::env::var("PETREL_PLAYWRIGHT_CORE")
        .map(PathBuf::from)
        .unwrap_or_else(|_| repo().join("target/browser-tools/node_modules/playwright-core"));
    if !core.join("package.json").exists() {
        return Err(format!("no playwright-core at {}", core.display()));
    }
    Ok((core, chromium))
}

/// The telemetry fed besides the trials: the synthetic hour's messages
/// without those the trials' rule and identity come from (HEARTBEAT,
/// SYS_STATUS, BATTERY_STATUS), re-sequenced as they are sent.
fn feed_messages() -> Vec<MavMessage> {
    let mut seq = 0u8;
    let mut out = Vec::new();
    for s in 0..120 {
        for (_, bytes) in telemetry::second(s, &mut seq) {
            let Ok(frame) = Frame::parse(&bytes) else {
                continue;
            };
            let Ok(message) = frame.decode() else {
                continue;
            };
            if !matches!(
                message,
                MavMessage::HEARTBEAT(_)
                    | MavMessage::SYS_STATUS(_)
                    | MavMessage::BATTERY_STATUS(_)
            ) {
                out.push(message);
            }
        }
    }
    out
}

/// Sends `rate` frames a second on the autopilot's socket (sharing its
/// sequence) until `stop`, ten every millisecond; counts what it sent.
fn feeder(
    ap: &Autopilot,
    rate: u64,
    stop: Arc<AtomicBool>,
    sent: Arc<AtomicU64>,
) -> Option<std::thread::JoinHandle<()>> {
    let socket = ap.socket.try_clone().ok()?;
    let seq = ap.seq.clone();
    let messages = feed_messages();
    Some(std::thread::spawn(move || {
        let start = Instant::now();
        let mut n = 0u64;
        while !stop.load(Ordering::Relaxed) {
            let due = (start.elapsed().as_secs_f64() * rate as f64) as u64;
            while n < due {
                let message = &messages[(n % messages.len() as u64) as usize];
                let s = seq.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
                let _ = socket.send(&autopilot::encode(s, message));
                n += 1;
            }
            sent.store(n, Ordering::Relaxed);
            std::thread::sleep(Duration::from_millis(1));
        }
    }))
}

/// Two browsers on `url`, ready; their stdin closes to end them.
fn browsers(
    tools: &(PathBuf, PathBuf),
    url: &str,
) -> Option<(Reaped, ChildStdin, mpsc::Receiver<String>)> {
    let nice = env_or("PETREL_BROWSERS_NICE", 19).to_string();
    let mut child = Command::new("nice")
        .args(["-n", &nice, "node"])
        .arg(repo().join("gateway/benches/monitor/browsers.js"))
        .arg(url)
        .env("PLAYWRIGHT_CORE", &tools.0)
        .env("CHROMIUM", &tools.1)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| eprintln!("cannot start node: {e}"))
        .ok()?;
    let stdin = child.stdin.take()?;
    let out = child.stdout.take()?;
    let child = Reaped(child);
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    match rx.recv_timeout(Duration::from_secs(180)) {
        Ok(line) if line == "ready" => Some((child, stdin, rx)),
        other => {
            eprintln!("the browsers did not get ready: {other:?}");
            None
        }
    }
}

/// How the page is read during a run.
#[derive(Clone, Copy)]
enum Readers<'a> {
    None,
    /// Two WebSocket readers in this process: one fast, one slow.
    Sockets,
    /// Two chromium processes (node, playwright-core, chromium).
    Browsers(&'a (PathBuf, PathBuf)),
}

/// One reader of `/ws` until `stop`, sleeping `pause` after each frame:
/// (frames, bytes) received.
fn socket_reader(
    url: &str,
    pause: Duration,
    stop: Arc<AtomicBool>,
) -> Option<std::thread::JoinHandle<(u64, u64)>> {
    let ws_url = format!("{}ws", url.replacen("http://", "ws://", 1));
    let (mut ws, _) = tungstenite::connect(ws_url.as_str())
        .map_err(|e| eprintln!("cannot open {ws_url}: {e}"))
        .ok()?;
    if let tungstenite::stream::MaybeTlsStream::Plain(s) = ws.get_ref() {
        let _ = s.set_read_timeout(Some(Duration::from_millis(500)));
    }
    Some(std::thread::spawn(move || {
        let (mut frames, mut bytes) = (0u64, 0u64);
        while !stop.load(Ordering::Relaxed) {
            match ws.read() {
                Ok(tungstenite::Message::Text(t)) => {
                    frames += 1;
                    bytes += t.len() as u64;
                    std::thread::sleep(pause);
                }
                Ok(_) => {}
                Err(tungstenite::Error::Io(e))
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) => {}
                Err(_) => break,
            }
        }
        let _ = ws.close(None);
        (frames, bytes)
    }))
}

struct Phase {
    stats: Stats,
    /// (seconds into the load, RSS kB)
    rss: Vec<(u64, u64)>,
    frames: u64,
    said: Vec<String>,
    pages: Option<String>,
}

/// One run of `petrel run` under the load, with browsers or without.
fn phase(
    name: &'static str,
    readers: Readers,
    seconds: u64,
    rate: u64,
    scratch: &Path,
) -> Option<Phase> {
    let here = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/latency");
    let port = std::net::UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .map(|a| a.port())
        .ok()?;
    let mut child = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("run")
        .arg(&here)
        .args(["--mavlink", &format!("udpin:127.0.0.1:{port}"), "--profile"])
        .arg(here.join("profile.toml"))
        .arg("--record")
        .arg(scratch.join(format!("{}.mcap", name.replace(' ', "-"))))
        .args(["--http", "127.0.0.1:0", "--duration", "3600"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| eprintln!("cannot start petrel: {e}"))
        .ok()?;
    let err = child.stderr.take()?;
    let pid = child.id();
    let petrel = Reaped(child);
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let mut said = Vec::new();
    let url = loop {
        match rx.recv_timeout(Duration::from_secs(60)) {
            Ok(line) => match line.strip_prefix("monitor: ") {
                Some(u) => break u.trim().to_owned(),
                None => said.push(line),
            },
            Err(_) => {
                eprintln!("petrel never served the page: {}", said.join("\n"));
                return None;
            }
        }
    };
    let ap = autopilot::connect(port)?;
    let stop = Arc::new(AtomicBool::new(false));
    let sent = Arc::new(AtomicU64::new(0));
    let feed = feeder(&ap, rate, stop.clone(), sent.clone())?;
    let pages = match readers {
        Readers::Browsers(t) => Some(browsers(t, &url)?),
        _ => None,
    };
    let reading = Arc::new(AtomicBool::new(false));
    let sockets = match readers {
        Readers::Sockets => vec![
            socket_reader(&url, Duration::ZERO, reading.clone())?,
            socket_reader(&url, Duration::from_secs(2), reading.clone())?,
        ],
        _ => Vec::new(),
    };
    // Memory every 10 s of the load, on its own thread.
    let sampling = Arc::new(AtomicBool::new(false));
    let sampler = {
        let sampling = sampling.clone();
        std::thread::spawn(move || {
            let start = Instant::now();
            let mut out = Vec::new();
            let mut next = 10;
            while !sampling.load(Ordering::Relaxed) {
                if start.elapsed() >= Duration::from_secs(next) {
                    out.push((next, rss_kb(pid).map_or(0, |r| r.0)));
                    next += 10;
                }
                std::thread::sleep(Duration::from_millis(100));
            }
            out
        })
    };
    let stats = autopilot::trials_on(name, ap, usize::MAX, Duration::from_secs(seconds));
    sampling.store(true, Ordering::Relaxed);
    stop.store(true, Ordering::Relaxed);
    let _ = feed.join();
    let rss = sampler.join().unwrap_or_default();
    let pages = pages.and_then(|(child, stdin, rx)| {
        drop(stdin);
        let line = rx.recv_timeout(Duration::from_secs(60)).ok();
        drop(child);
        line
    });
    reading.store(true, Ordering::Relaxed);
    let read: Vec<(u64, u64)> = sockets.into_iter().filter_map(|h| h.join().ok()).collect();
    let pages = if read.is_empty() {
        pages
    } else {
        Some(format!("frames and bytes, fast reader then slow: {read:?}"))
    };
    let _ = Command::new("kill")
        .args(["-TERM", &pid.to_string()])
        .status();
    let until = Instant::now() + Duration::from_secs(30);
    while let Some(left) = until.checked_duration_since(Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(line) => said.push(line),
            Err(_) => break,
        }
    }
    drop(petrel);
    Some(Phase {
        stats: stats?,
        rss,
        frames: sent.load(Ordering::Relaxed),
        said,
        pages,
    })
}

fn main() {
    let seconds: u64 = env_or("PETREL_LOAD_SECONDS", 60);
    let rate: u64 = env_or("PETREL_LOAD_RATE", 10_000);
    let scratch = std::env::temp_dir().join(format!("petrel-monitor-load-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&scratch);
    let tools = match browser_tools() {
        Ok(t) => Some(t),
        Err(why) => {
            eprintln!("no browsers: {why}; measuring the run without them only");
            None
        }
    };
    println!("{rate} frames/s for {seconds} s, recording on, the page served");
    let mut phases = Vec::new();
    phases.extend(
        phase("no browser", Readers::None, seconds, rate, &scratch).map(|p| ("no browser", p)),
    );
    phases.extend(
        phase("two sockets", Readers::Sockets, seconds, rate, &scratch).map(|p| ("two sockets", p)),
    );
    if let Some(t) = &tools {
        phases.extend(
            phase(
                "two browsers",
                Readers::Browsers(t),
                seconds,
                rate,
                &scratch,
            )
            .map(|p| ("two browsers", p)),
        );
    }
    let _ = std::fs::remove_dir_all(&scratch);
    let mut out = std::io::stdout().lock();
    let _ = writeln!(
        out,
        "{:<14} {:>8} {:>9} {:>9} {:>10} {:>6} {:>10}",
        "run", "trials", "p50 µs", "p99 µs", "max µs", "lost", "frames fed"
    );
    for (name, p) in &phases {
        let _ = writeln!(
            out,
            "{:<14} {:>8} {:>9.1} {:>9.1} {:>10.1} {:>6} {:>10}",
            name,
            p.stats.micros.len(),
            p.stats.pct(0.5),
            p.stats.pct(0.99),
            p.stats.pct(1.0),
            p.stats.lost,
            p.frames
        );
    }
    for (name, p) in &phases {
        let mb: Vec<String> = p
            .rss
            .iter()
            .map(|(s, kb)| format!("{s} s: {:.1} MB", *kb as f64 / 1024.0))
            .collect();
        let _ = writeln!(out, "{name}: RSS {}", mb.join(", "));
        if let [(_, first), .., (_, last)] = p.rss[..] {
            let _ = writeln!(
                out,
                "{name}: RSS at the end / at 10 s: {:.3}",
                last as f64 / first.max(1) as f64
            );
        }
        for line in p
            .said
            .iter()
            .filter(|l| l.starts_with("stopped") || l.starts_with("recorded"))
        {
            let _ = writeln!(out, "{name}: petrel: {line}");
        }
        if let Some(pages) = &p.pages {
            let _ = writeln!(out, "{name}: the readers received {pages}");
        }
    }
    if let [(_, a), rest @ ..] = &phases[..] {
        for (name, b) in rest {
            let _ = writeln!(
                out,
                "{name} / no browser: p50 {:.2}, p99 {:.2}",
                b.stats.pct(0.5) / a.stats.pct(0.5),
                b.stats.pct(0.99) / a.stats.pct(0.99)
            );
        }
    }
}
