//! Replay rate: `petrel replay FILE.tlog examples/uav-survey` on the largest
//! shared telemetry log and on a synthetic hour of telemetry at 50
//! messages/s, as a user runs it (the whole command: start, project load,
//! elaboration and the player on every frame, the timeline written to
//! /dev/null). Baselines in the same run: reading and decoding the same
//! frames in memory with rust-mavlink (the floor of any replay), and
//! pymavlink reading the file (the usual tool for the job).
//!
//! Then the cost of a team: the synthetic hour (vehicle 1's telemetry)
//! replayed with a two-vehicle team project (`tests/fixtures/team-scripted`:
//! one elaborator per vehicle, events qualified) beside its single-vehicle
//! twin (`benches/team/one`: the same net, one elaborator), same run.
//!
//! Run: `cargo bench -p gateway --bench replay`.

#[path = "support/telemetry.rs"]
mod telemetry;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use elaboration::TlogReader;

const RUNS: usize = 5;

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

/// The median wall time of `petrel replay FILE PROJECT` over RUNS runs.
fn petrel_replay(file: &Path, project: &Path) -> Option<Duration> {
    let mut times = Vec::new();
    for _ in 0..RUNS {
        let t = Instant::now();
        let status = Command::new(env!("CARGO_BIN_EXE_petrel"))
            .arg("replay")
            .arg(file)
            .arg(project)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .ok()?;
        let elapsed = t.elapsed();
        if !status.success() {
            eprintln!("petrel replay {} failed: {status}", file.display());
            return None;
        }
        times.push(elapsed);
    }
    Some(median(times))
}

/// Reading and decoding every frame in memory (median of RUNS).
fn decode_only(bytes: &[u8]) -> Duration {
    let mut times = Vec::new();
    for _ in 0..RUNS {
        let t = Instant::now();
        let mut decoded = 0usize;
        for rec in TlogReader::new(bytes) {
            decoded += usize::from(rec.frame.decode().is_ok());
        }
        std::hint::black_box(decoded);
        times.push(t.elapsed());
    }
    median(times)
}

/// pymavlink reading the file once (it is slow enough for one run).
fn pymavlink(file: &Path) -> Option<(Duration, u64)> {
    let script = "import sys, time\n\
from pymavlink import mavutil\n\
m = mavutil.mavlink_connection(sys.argv[1], robust_parsing=True)\n\
t = time.perf_counter(); n = 0\n\
while m.recv_match() is not None: n += 1\n\
print(n, time.perf_counter() - t)\n";
    let out = Command::new("python3")
        .env("MAVLINK20", "1")
        .args(["-c", script])
        .arg(file)
        .output()
        .ok()?;
    if !out.status.success() {
        eprintln!(
            "skipped the pymavlink baseline: {}",
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or("")
        );
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let mut words = text.split_whitespace();
    let n = words.next()?.parse().ok()?;
    let secs: f64 = words.next()?.parse().ok()?;
    Some((Duration::from_secs_f64(secs), n))
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let project = root.join("examples/uav-survey");
    let scratch = std::env::temp_dir().join(format!("petrel-replay-bench-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&scratch);
    let mut files: Vec<(String, PathBuf)> = Vec::new();
    let largest = root.join("../shared/telemetry/ardusub_2023-04-18_sub_qgc_baddata.tlog");
    if largest.is_file() {
        files.push(("ardusub_2023-04-18 (largest shared)".into(), largest));
    } else {
        eprintln!("skipped the shared log: {} is absent", largest.display());
    }
    let hour = scratch.join("hour.tlog");
    if std::fs::write(&hour, telemetry::tlog(3600, 1_700_000_000_000_000)).is_ok() {
        files.push(("synthetic hour, 50 msg/s".into(), hour));
    }
    println!(
        "{:<36} {:>8} {:>12} {:>14} {:>14} {:>14}",
        "file", "frames", "petrel ms", "petrel fr/s", "decode fr/s", "pymavlink fr/s"
    );
    for (name, file) in &files {
        let Ok(bytes) = std::fs::read(file) else {
            continue;
        };
        let frames = TlogReader::new(&bytes).count() as f64;
        let Some(replay) = petrel_replay(file, &project) else {
            continue;
        };
        let decode = decode_only(&bytes);
        let py = pymavlink(file);
        println!(
            "{:<36} {:>8} {:>12.1} {:>14.0} {:>14.0} {:>14}",
            name,
            frames,
            replay.as_secs_f64() * 1e3,
            frames / replay.as_secs_f64(),
            frames / decode.as_secs_f64(),
            py.map_or("-".into(), |(d, n)| format!(
                "{:.0}",
                n as f64 / d.as_secs_f64()
            )),
        );
        if let Some((d, _)) = py {
            println!(
                "{:<36} petrel replay / pymavlink read: {:.3} of its time",
                "",
                replay.as_secs_f64() / d.as_secs_f64()
            );
        }
    }
    let hour = scratch.join("hour.tlog");
    let one = root.join("gateway/benches/team/one");
    let two = root.join("gateway/tests/fixtures/team-scripted");
    if let (Some(single), Some(team)) = (petrel_replay(&hour, &one), petrel_replay(&hour, &two)) {
        println!(
            "team of two (2 elaborators) {:.1} ms, one vehicle {:.1} ms on the synthetic hour: {:.2}x",
            team.as_secs_f64() * 1e3,
            single.as_secs_f64() * 1e3,
            team.as_secs_f64() / single.as_secs_f64()
        );
    }
    let _ = std::fs::remove_dir_all(&scratch);
}
