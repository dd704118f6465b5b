//! The project check and the pre-flight start-up, as users wait for them.
//!
//! 1. `petrel check examples/uav-flight-test --json` on one and two
//!    threads (whole process: wall and CPU time, peak memory, states/s),
//!    beside, in the same run, the P/T explorer's `petrel check --pnml` on
//!    the Model Checking Contest's ParamProductionCell-PT-3 (1,465,206
//!    states) with `--no-loops`, on one and two threads; and the team
//!    project `examples/ugv-bottleneck` (two robots, seven nets) on one
//!    and two threads, beside the single-vehicle project.
//! 2. `petrel run examples/uav-flight-test` from process start to its first
//!    frame on the link (sent once the link is open and it heard the
//!    autopilot, which this bench plays), with the pre-flight check
//!    remembered (warm cache) and, as the baseline, with `--recheck`.
//!
//! Each set runs idle, then with the other core kept busy by a spinning
//! thread of this process. `PETREL_BENCH_RUNS` sets the runs per figure
//! (median; default 3).

use petrel_test_support::busy;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Wall time, CPU time (user + system), peak RSS (KiB) and stdout of one
/// `petrel` process.
struct Measured {
    wall: Duration,
    cpu: Duration,
    rss_kib: i64,
    stdout: String,
}

fn petrel(args: &[&str], env: &[(&str, &Path)]) -> Option<Measured> {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_petrel"));
    cmd.current_dir(root())
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::null());
    for (k, v) in env {
        cmd.env(k, v);
    }
    let start = Instant::now();
    let mut child = cmd.spawn().ok()?;
    let mut stdout = String::new();
    if let Some(mut out) = child.stdout.take() {
        use std::io::Read;
        let _ = out.read_to_string(&mut stdout);
    }
    let mut status = 0;
    // SAFETY: rusage is plain data, written by wait4 for our own child.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = child.id() as libc::pid_t;
    // SAFETY: waits for our own child, whose pid we hold.
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    let wall = start.elapsed();
    if r != pid {
        return None;
    }
    let tv = |t: libc::timeval| Duration::new(t.tv_sec as u64, t.tv_usec as u32 * 1000);
    Some(Measured {
        wall,
        cpu: tv(usage.ru_utime) + tv(usage.ru_stime),
        rss_kib: usage.ru_maxrss,
        stdout,
    })
}

fn runs() -> usize {
    std::env::var("PETREL_BENCH_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3)
}

fn median_of(mut v: Vec<Measured>) -> Measured {
    v.sort_by_key(|m| m.wall);
    v.swap_remove(v.len() / 2)
}

/// The median run of a `petrel check … --json` and its states.
fn check(args: &[&str]) -> Option<(Measured, u64, u64)> {
    let mut all = Vec::new();
    for _ in 0..runs() {
        all.push(petrel(args, &[])?);
    }
    let m = median_of(all);
    let v: serde_json::Value = serde_json::from_str(m.stdout.trim()).ok()?;
    let states = v["states"].as_u64()?;
    let edges = v["edges"]
        .as_u64()
        .or(v["edges"]["count"].as_u64())
        .unwrap_or(0);
    Some((m, states, edges))
}

fn print_check(what: &str, args: &[&str]) -> Option<f64> {
    let (m, states, edges) = check(args)?;
    let rate = states as f64 / m.wall.as_secs_f64();
    println!(
        "| {what} | {states} | {edges} | {:.3} s | {:.3} s | {:.0} MB | {:.3} M |",
        m.wall.as_secs_f64(),
        m.cpu.as_secs_f64(),
        m.rss_kib as f64 / 1024.0,
        rate / 1e6
    );
    Some(rate)
}

/// A plane's HEARTBEAT from system 1, as MAVLink 2 bytes.
fn heartbeat(seq: u8) -> Vec<u8> {
    use mavlink::dialects::ardupilotmega::*;
    let message = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_FIXED_WING,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    });
    let header = mavlink::MavHeader {
        system_id: 1,
        component_id: 1,
        sequence: seq,
    };
    let mut out = Vec::new();
    let _ = mavlink::write_versioned_msg(&mut out, mavlink::MavlinkVersion::V2, header, &message);
    out
}

/// Time from `petrel run` starting to its first frame on the link: an
/// autopilot sends it a HEARTBEAT every 2 ms until it answers (it speaks
/// once the link is open and it has heard the vehicle).
fn startup(cache: &Path, recheck: bool) -> Option<Duration> {
    let port = std::net::UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .ok()?
        .port();
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").ok()?;
    socket
        .set_read_timeout(Some(Duration::from_millis(2)))
        .ok()?;
    let address = format!("udpin:127.0.0.1:{port}");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_petrel"));
    cmd.current_dir(root())
        .args([
            "run",
            "examples/uav-flight-test",
            "--mavlink",
            &address,
            "--no-record",
            "--programs",
            "tcp:127.0.0.1:0",
            "--duration",
            "60",
        ])
        .env("XDG_CACHE_HOME", cache)
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    if recheck {
        cmd.arg("--recheck");
    }
    let start = Instant::now();
    let mut child = cmd.spawn().ok()?;
    let mut buf = [0u8; 512];
    let mut got = None;
    let mut seq = 0u8;
    while start.elapsed() < Duration::from_secs(60) {
        let _ = socket.send_to(&heartbeat(seq), ("127.0.0.1", port));
        seq = seq.wrapping_add(1);
        if socket.recv(&mut buf).is_ok() {
            got = Some(start.elapsed());
            break;
        }
    }
    let _ = child.kill();
    let _ = child.wait();
    got
}

fn print_startup(cache: &Path) {
    for (what, recheck) in [("remembered (warm cache)", false), ("--recheck", true)] {
        let mut v: Vec<Duration> = (0..runs())
            .filter_map(|_| startup(cache, recheck))
            .collect();
        v.sort();
        match v.get(v.len() / 2) {
            Some(d) => println!(
                "| start-up to the link, check {what} | {:.3} s |",
                d.as_secs_f64()
            ),
            None => println!("| start-up to the link, check {what} | no frame came |"),
        }
    }
}

fn set(label: &str) {
    println!("\n## {label}\n");
    println!("| command | states | steps/edges | wall | CPU | peak RSS | states/s (wall) |");
    println!("|---|---|---|---|---|---|---|");
    let project = |t: &'static str| {
        vec![
            "check",
            "examples/uav-flight-test",
            "--json",
            "--threads",
            t,
        ]
    };
    let pnml = "../shared/pnml/ParamProductionCell-PT-3.pnml";
    let pt = |t: &'static str| {
        vec![
            "check",
            "--pnml",
            pnml,
            "--json",
            "--no-loops",
            "--threads",
            t,
        ]
    };
    let p1 = print_check("project check, 1 thread", &project("1"));
    let p2 = print_check("project check, 2 threads", &project("2"));
    let team = |t: &'static str| vec!["check", "examples/ugv-bottleneck", "--json", "--threads", t];
    let t1 = print_check("team project ugv-bottleneck, 1 thread", &team("1"));
    let _ = print_check("team project ugv-bottleneck, 2 threads", &team("2"));
    if let (Some(t1), Some(p1)) = (t1, p1) {
        println!(
            "\nteam states/s over project states/s, 1 thread: {:.3}",
            t1 / p1
        );
    }
    let (q1, q2) = if root().join(pnml).is_file() {
        (
            print_check(
                "P/T `--pnml` ParamProductionCell-PT-3 `--no-loops`, 1 thread",
                &pt("1"),
            ),
            print_check(
                "P/T `--pnml` ParamProductionCell-PT-3 `--no-loops`, 2 threads",
                &pt("2"),
            ),
        )
    } else {
        println!("(../shared/pnml absent: no P/T baseline)");
        (None, None)
    };
    if let (Some(p1), Some(q1)) = (p1, q1) {
        println!(
            "\nproject states/s over P/T states/s, 1 thread: {:.4}",
            p1 / q1
        );
    }
    if let (Some(p2), Some(q2)) = (p2, q2) {
        println!(
            "project states/s over P/T states/s, 2 threads: {:.4}",
            p2 / q2
        );
    }
    println!();
    let cache = std::env::temp_dir().join(format!("petrel-bench-cache-{}", std::process::id()));
    // Warm the cache.
    let _ = startup(&cache, false);
    println!("| start-up | median |\n|---|---|");
    print_startup(&cache);
    let _ = std::fs::remove_dir_all(&cache);
}

fn main() {
    // `cargo bench` passes --bench; `cargo test --benches` does not run it.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    set("idle");
    busy::with_a_core_busy(|| set("the other core busy (a spinning thread)"));
}
