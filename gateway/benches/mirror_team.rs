//! How many vehicles one ground mirror follows on one core: the real
//! `petrel mirror` (release build, `--no-record`), pinned to core 1
//! (`taskset -c 1`), on a team project of N vehicles (systems 1..=N, one
//! template net per vehicle), fed over 127.0.0.1 UDP by this process
//! (pinned to core 0) with N vehicles × 50 messages a second of realistic
//! telemetry (`support/telemetry.rs`, each vehicle its own system id and
//! sequence numbers, their 10 Hz streams spread over the 100 ms period as
//! independent vehicles' are; `MIRROR_TEAM_BURST=1`: all in step, the
//! worst case), for 10 s. The mirror's `--json` closing line says how
//! many frames it got of each vehicle; a frame sent and not got was
//! dropped (the socket's buffer overflowed while the mirror was busy). It
//! keeps up with N when it got every frame. Its CPU time over the run
//! (/proc) gives its load.
//!
//! Idle, then with core 0 kept busy by a spinning thread (this process's,
//! pinned there beside the sender). Run:
//! `cargo bench -p gateway --bench mirror_team` (Linux, two cores or more).

#![allow(dead_code)]

use petrel_test_support::proc;
#[path = "support/telemetry.rs"]
mod telemetry;

use std::io::Read;
use std::net::UdpSocket;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use proc::cpu;

const TEAMS: &[usize] = &[1, 50, 100, 150, 200, 240];
const SECONDS: u64 = 10;

fn pin(cpu: usize) {
    // SAFETY: a zeroed cpu_set_t is a valid empty set; CPU_SET and
    // sched_setaffinity only read and write it.
    unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set);
    }
}

/// A team project of `n` vehicles in `dir`.
fn project(dir: &std::path::Path, n: usize) {
    let mut toml = String::from("name = \"fleet\"\n\n");
    for i in 1..=n {
        toml.push_str(&format!("[[vehicle]]\nname = \"V{i}\"\nsystem = {i}\n\n"));
    }
    toml.push_str("[[net]]\nfile = \"watch.toml\"\nactive = true\n");
    std::fs::write(dir.join("project.toml"), toml).expect("project.toml");
    std::fs::write(
        dir.join("watch.toml"),
        "name = \"WATCH\"\nvehicles = \"all\"\nplaces = [\"ground\", \"flying\"]\ninitial = [\"ground\"]\n\n\
         [[transition]]\nname = \"up\"\nfrom = [\"ground\"]\nto = [\"flying\"]\non = \"armed\"\n\n\
         [[transition]]\nname = \"down\"\nfrom = [\"flying\"]\nto = [\"ground\"]\non = \"disarmed\"\n",
    )
    .expect("watch.toml");
}

/// Vehicle `i`'s phase among `n` when `SPREAD`: independent vehicles are
/// not in step, so their 10 Hz streams are spread over the 100 ms period;
/// else 37 µs apart (every vehicle's messages of an instant in one burst:
/// the worst case).
fn phase(i: usize, n: usize) -> u64 {
    if spread() {
        (i as u64 * 100_000) / n as u64
    } else {
        i as u64 * 37
    }
}

/// `MIRROR_TEAM_BURST=1`: all vehicles in step (the worst case).
fn spread() -> bool {
    std::env::var_os("MIRROR_TEAM_BURST").is_none()
}

struct Trial {
    sent: u64,
    got: u64,
    /// The fewest frames got of one vehicle, against the most sent.
    worst: (u64, u64),
    cpu: Duration,
}

fn trial(n: usize) -> Option<Trial> {
    let dir = std::env::temp_dir().join(format!("petrel-mirror-team-{n}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).ok()?;
    project(&dir, n);
    let port = UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .ok()?
        .port();
    let wait = SECONDS + 6;
    let mut child = Command::new("taskset")
        .args(["-c", "1"])
        .arg(env!("CARGO_BIN_EXE_petrel"))
        .arg("mirror")
        .arg(&dir)
        .args(["--mavlink", &format!("udpin:127.0.0.1:{port}")])
        .args(["--no-record", "--json", "--duration", &wait.to_string()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .ok()?;
    // The mirror loads the project and binds its port.
    std::thread::sleep(Duration::from_secs(2));
    let socket = UdpSocket::bind("127.0.0.1:0").ok()?;
    socket.connect(("127.0.0.1", port)).ok()?;
    let cpu_before = cpu(child.id()).unwrap_or_default();
    let mut seqs = vec![0u8; n];
    let mut sent = vec![0u64; n];
    let start = Instant::now();
    for s in 0..SECONDS {
        let mut frames: Vec<(u64, usize, Vec<u8>)> = (0..n)
            .flat_map(|i| {
                telemetry::second_of(i as u8 + 1, s, &mut seqs[i])
                    .into_iter()
                    .map(move |(t, b)| (t + phase(i, n), i, b))
            })
            .collect();
        frames.sort_by_key(|(t, _, _)| *t);
        for (t, i, bytes) in frames {
            let due = Duration::from_micros(t);
            let now = start.elapsed();
            if due > now + Duration::from_millis(2) {
                std::thread::sleep(due - now);
            }
            if socket.send(&bytes).is_ok() {
                sent[i] += 1;
            }
        }
    }
    let sending = start.elapsed();
    std::thread::sleep(Duration::from_millis(500));
    let used = cpu(child.id())
        .unwrap_or_default()
        .saturating_sub(cpu_before);
    let mut out = String::new();
    child.stdout.take()?.read_to_string(&mut out).ok()?;
    let _ = child.wait();
    let _ = std::fs::remove_dir_all(&dir);
    let summary: serde_json::Value = out
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .find(|l| l["summary"] == "mirror")?;
    let got: Vec<u64> = summary["vehicles"]
        .as_array()?
        .iter()
        .map(|v| v["frames"].as_u64().unwrap_or(0))
        .collect();
    if sending > Duration::from_secs(SECONDS) + Duration::from_millis(500) {
        eprintln!("  (the sender fell behind: {sending:.1?} for {SECONDS} s of telemetry)");
    }
    Some(Trial {
        sent: sent.iter().sum(),
        got: got.iter().sum(),
        worst: (
            got.iter().copied().min().unwrap_or(0),
            sent.iter().copied().max().unwrap_or(0),
        ),
        cpu: used,
    })
}

fn pass(label: &str) {
    println!("{label}:");
    println!(
        "  vehicles  frames/s  sent     got      dropped  worst vehicle  mirror CPU (of one core)"
    );
    for &n in TEAMS {
        match trial(n) {
            Some(t) => println!(
                "  {n:>8}  {:>8}  {:>7}  {:>7}  {:>7}  {:>5}/{:<7}  {:.1} %",
                n * 50,
                t.sent,
                t.got,
                t.sent.saturating_sub(t.got),
                t.worst.0,
                t.worst.1,
                t.cpu.as_secs_f64() / (SECONDS as f64 + 0.5) * 100.0
            ),
            None => println!("  {n:>8}  (the trial failed)"),
        }
    }
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    pin(0);
    println!(
        "vehicles' streams {}",
        if spread() {
            "spread over the 100 ms period (independent vehicles)"
        } else {
            "in step, 37 µs apart (MIRROR_TEAM_BURST: the worst case)"
        }
    );
    pass("idle");
    let stop = Arc::new(AtomicBool::new(false));
    let spinner = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            pin(0);
            let mut x = 0u64;
            while !stop.load(Ordering::Relaxed) {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
                std::hint::black_box(x);
            }
        })
    };
    pass("core 0 busy (the sender's)");
    stop.store(true, Ordering::Relaxed);
    let _ = spinner.join();
}
