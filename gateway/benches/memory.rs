//! Resident memory of `petrel run` (recording on) fed an hour of telemetry
//! at 50 messages/s, over TCP on 127.0.0.1 (flow control: nothing is lost),
//! at 10,000 frames/s by default — 200 times real time, as fast as the
//! gateway takes it with its recorder keeping up — or at
//! `PETREL_MEMORY_RATE` frames/s (0: as fast as the socket takes it; the
//! recorder then falls behind and drops, counted). The resident set is read from /proc every ten
//! minutes of telemetry; the baseline is the same process's resident set
//! with the link up, before the first frame. Goal: under 30 MB and not
//! growing.
//!
//! Run: `cargo bench -p gateway --bench memory` (Linux).

use petrel_test_support::proc;
#[path = "support/telemetry.rs"]
#[allow(dead_code)]
mod telemetry;

use std::io::{Read, Write};
use std::net::TcpListener;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use proc::rss_kb;

fn mb(kb: u64) -> f64 {
    kb as f64 / 1024.0
}

fn main() {
    let here = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/latency");
    let scratch = std::env::temp_dir().join(format!("petrel-memory-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&scratch);
    let Ok(listener) = TcpListener::bind("127.0.0.1:0") else {
        eprintln!("cannot listen on 127.0.0.1");
        return;
    };
    let Ok(port) = listener.local_addr().map(|a| a.port()) else {
        return;
    };
    let child = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("run")
        .arg(&here)
        .args(["--mavlink", &format!("tcpout:127.0.0.1:{port}")])
        .arg("--record")
        .arg(scratch.join("hour.mcap"))
        .args(["--duration", "900"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match child {
        Ok(c) => c,
        Err(e) => {
            eprintln!("cannot start petrel: {e}");
            return;
        }
    };
    let pid = child.id();
    let Ok((mut link, _)) = listener.accept() else {
        let _ = child.kill();
        return;
    };
    // What petrel sends (heartbeats, stream requests) is read and dropped.
    if let Ok(mut back) = link.try_clone() {
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while matches!(back.read(&mut buf), Ok(n) if n > 0) {}
        });
    }
    std::thread::sleep(Duration::from_millis(500));
    let baseline = rss_kb(pid).unwrap_or((0, 0));
    println!(
        "{:>22} {:>10} {:>10} {:>10}",
        "telemetry fed", "frames", "RSS MB", "peak MB"
    );
    println!(
        "{:>22} {:>10} {:>10.1} {:>10.1}",
        "none (baseline)",
        0,
        mb(baseline.0),
        mb(baseline.1)
    );
    let rate: f64 = std::env::var("PETREL_MEMORY_RATE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000.0);
    println!("feeding at {rate} frames/s (0: unpaced)");
    let wall = Instant::now();
    let mut seq = 0u8;
    let mut frames = 0u64;
    let mut samples = Vec::new();
    let mut chunk = Vec::with_capacity(64 * 1024);
    for s in 0..3600u64 {
        for (_, bytes) in telemetry::second(s, &mut seq) {
            chunk.extend_from_slice(&bytes);
            frames += 1;
        }
        if chunk.len() > 32 * 1024 || s == 3599 {
            if link.write_all(&chunk).is_err() {
                eprintln!("petrel closed the link after {frames} frames");
                break;
            }
            chunk.clear();
            // Paced: wait until the wall clock catches up with the frames.
            if rate > 0.0 {
                let due = Duration::from_secs_f64(frames as f64 / rate);
                if let Some(wait) = due.checked_sub(wall.elapsed()) {
                    std::thread::sleep(wait);
                }
            }
        }
        if (s + 1) % 600 == 0 {
            let (rss, peak) = rss_kb(pid).unwrap_or((0, 0));
            samples.push(rss);
            println!(
                "{:>22} {:>10} {:>10.1} {:>10.1}",
                format!("{} min", (s + 1) / 60),
                frames,
                mb(rss),
                mb(peak)
            );
        }
    }
    let fed_in = wall.elapsed();
    // Let it take what the socket still holds, then stop it cleanly.
    std::thread::sleep(Duration::from_secs(3));
    let (rss, peak) = rss_kb(pid).unwrap_or((0, 0));
    println!(
        "{:>22} {:>10} {:>10.1} {:>10.1}",
        "60 min, settled",
        frames,
        mb(rss),
        mb(peak)
    );
    let _ = Command::new("kill")
        .args(["-TERM", &pid.to_string()])
        .status();
    let mut err = String::new();
    if let Some(mut e) = child.stderr.take() {
        let _ = e.read_to_string(&mut err);
    }
    let _ = child.wait();
    println!("fed in {:.1} s of wall time", fed_in.as_secs_f64());
    for line in err
        .lines()
        .filter(|l| l.starts_with("stopped") || l.starts_with("recorded"))
    {
        println!("petrel: {line}");
    }
    if let [.., half, last] = samples[..] {
        println!(
            "RSS / baseline: {:.2}; RSS at 60 min / at 50 min: {:.3}",
            rss as f64 / baseline.0.max(1) as f64,
            last as f64 / half.max(1) as f64
        );
    }
    // The hour's recording, replayed (and checked against) as a user would.
    for extra in [&[][..], &["--check-against"][..]] {
        let t = Instant::now();
        let status = Command::new(env!("CARGO_BIN_EXE_petrel"))
            .arg("replay")
            .arg(scratch.join("hour.mcap"))
            .arg(&here)
            .args(extra)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status();
        println!(
            "petrel replay of the hour's recording {}: {:.0} ms ({})",
            extra.join(" "),
            t.elapsed().as_secs_f64() * 1e3,
            status.map_or("did not run".into(), |s| s.to_string())
        );
    }
    // The hour's recording opened in `petrel view` (docs/monitor.md): the
    // whole command until its index is built, then 1,000 instants asked
    // for as the page's scrubbing asks (`--measure`: no server).
    let t = Instant::now();
    let view = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("view")
        .arg(scratch.join("hour.mcap"))
        .arg(&here)
        .args(["--measure", "1000"])
        .stderr(Stdio::null())
        .output();
    println!(
        "petrel view of the hour's recording: {:.0} ms in all; {}",
        t.elapsed().as_secs_f64() * 1e3,
        view.map_or("did not run".into(), |o| String::from_utf8_lossy(&o.stdout)
            .trim()
            .to_owned())
    );
    let _ = std::io::stdout().flush();
    let _ = std::fs::remove_dir_all(&scratch);
}
