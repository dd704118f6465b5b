//! An hour of faults (issue 14, docs/reliability.md "An hour of faults"):
//! the real `petrel run` process supervising the simulated ArduPlane
//! (sitl-tests, in this process) on examples/uav-flight-test with DEC (a
//! thread of this process), all over loopback at a high time scale, with
//! faults injected throughout: link drops of 1–30 s, garbage bursts,
//! duplicated and reordered frames, commands refused by the vehicle, the
//! autopilot rebooting in flight (time_boot_ms back to zero), DEC crashing
//! and being restarted, and a DEC that stops answering.
//!
//! The mission is the example's, with a longer route: its transit waypoint,
//! then `loops` rounds of the operations area (O1 camera, O2 sensor, O3
//! camera, and a fourth corner with no payload, so that the route outlasts
//! the replans a refused payload command causes), written by
//! [`soak_mission`] from examples/uav-flight-test/mission.toml.
//!
//! Asserted: `petrel run` never panics and ends cleanly when told (exit 0,
//! no panic on stderr), its resident memory stays flat (VmRSS sampled from
//! /proc), every call and command is answered or timed out (read back from
//! the recording with `petrel replay --json`), the vehicle heard refusals,
//! the gateway logged the reboot, and the recording replays with
//! `--check-against`.
//!
//! - `a_few_minutes_of_every_fault` runs in `cargo test --workspace`: about
//!   three simulated minutes at 5×, every kind of fault at least once;
//! - `an_hour_of_faults` is the soak, ignored by default: one simulated
//!   hour at `PETREL_SOAK_SPEED` (10) × real time. Run it once per change of
//!   the link or recorder code:
//!   `cargo test -p gateway --test real soak::an_hour_of_faults -- --ignored --nocapture`.

use crate::flight;
use crate::scratch;

use std::io::{BufRead, BufReader, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use flight::{free_port, petrel_run, project, Running};
use scratch::Scratch;
use sitl_tests::{Fault, Refusal, Schedule, Sim, SimConfig, SimState, Trigger};

/// A small generator (xorshift), seeded and printed so that a run can be
/// reproduced with PETREL_SOAK_SEED.
struct Rng(u64);

impl Rng {
    fn new() -> Rng {
        let seed = std::env::var("PETREL_SOAK_SEED")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| {
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(1, |d| d.as_nanos() as u64)
                    | 1
            });
        eprintln!("faults seeded with PETREL_SOAK_SEED={seed}");
        Rng(seed)
    }

    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// A number in `lo..hi`.
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (self.next() % 1_000_000) as f64 / 1e6 * (hi - lo)
    }
}

/// The example's mission with `loops` rounds of the operations area.
fn soak_mission(dir: &Path, loops: usize) -> PathBuf {
    let text =
        std::fs::read_to_string(project().join(crate::MISSION_FILE)).expect("the mission file");
    let mut mission: toml::Table = toml::from_str(&text).expect("TOML");
    let waypoints = mission["waypoint"].as_array().expect("waypoints").clone();
    let transit: Vec<toml::Value> = waypoints
        .iter()
        .filter(|w| w["area"].as_str() == Some("transit"))
        .cloned()
        .collect();
    let operations: Vec<toml::Value> = waypoints
        .iter()
        .filter(|w| w["area"].as_str() == Some("operations"))
        .cloned()
        .collect();
    assert!(operations.len() >= 2, "the example has an operations area");
    // The fourth corner: the first's longitude, the last's latitude.
    let mut corner = operations[0].clone();
    if let Some(t) = corner.as_table_mut() {
        t.remove("payload");
        t.remove("operation");
        t.insert("name".into(), "P".into());
        t.insert(
            "lat".into(),
            operations[operations.len() - 1]["lat"].clone(),
        );
    }
    let mut route = transit;
    for round in 1..=loops {
        for w in operations.iter().chain([&corner]) {
            let mut w = w.clone();
            if let Some(t) = w.as_table_mut() {
                let name = format!("{}_{round}", t["name"].as_str().unwrap_or("W"));
                t.insert("name".into(), name.into());
            }
            route.push(w);
        }
    }
    mission.insert("waypoint".into(), toml::Value::Array(route));
    let path = dir.join("soak-mission.toml");
    std::fs::write(&path, toml::to_string(&mission).expect("TOML out")).expect("write");
    path
}

/// DEC's lives: the real DEC (a thread) until it crashes, a DEC that
/// connects and then never answers, the real DEC again. Ended (its
/// connection closed) when dropped.
struct Program {
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Program {
    fn dec(address: &str, mission: &Path) -> Program {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let (address, mission) = (address.to_owned(), mission.to_owned());
        let thread = std::thread::spawn(move || {
            if let Err(e) = petrel_dec::serve_until(&address, &mission, flag) {
                eprintln!("DEC ended: {e:?}");
            }
        });
        Program {
            stop,
            thread: Some(thread),
        }
    }

    /// A program that says hello as DEC, reads every call and answers none.
    fn mute(address: &str) -> Program {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let address = address.trim_start_matches("tcp:").to_owned();
        let thread = std::thread::spawn(move || {
            let give_up = Instant::now() + Duration::from_secs(10);
            let stream = loop {
                match TcpStream::connect(&address) {
                    Ok(s) => break s,
                    Err(_) if Instant::now() < give_up && !flag.load(Ordering::Relaxed) => {
                        std::thread::sleep(Duration::from_millis(50))
                    }
                    Err(e) => {
                        eprintln!("the mute program could not connect: {e}");
                        return;
                    }
                }
            };
            let _ = stream.set_read_timeout(Some(Duration::from_millis(100)));
            let Ok(mut w) = stream.try_clone() else {
                return;
            };
            let hello = r#"{"hello": "DEC", "functions": ["plan", "item", "payload_failed", "replan", "adopt", "emergency_site", "emergency_plan"]}"#;
            if writeln!(w, "{hello}").is_err() {
                return;
            }
            let mut reader = BufReader::new(stream);
            let mut line = String::new();
            while !flag.load(Ordering::Relaxed) {
                line.clear();
                if let Ok(0) = reader.read_line(&mut line) {
                    return;
                }
            }
        });
        Program {
            stop,
            thread: Some(thread),
        }
    }

    fn end(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Program {
    fn drop(&mut self) {
        self.end();
    }
}

/// What happens to DEC, at simulated seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
enum ProgramFault {
    /// DEC's process dies: its connection closes, its calls unanswered.
    Crash,
    /// A DEC that answers nothing connects, for this many seconds.
    Mute(f64),
    /// The real DEC starts again.
    Restart,
}

/// A soak's plan.
struct Plan {
    name: &'static str,
    /// Simulated seconds flown.
    sim_s: f64,
    speed: f64,
    loops: usize,
    vehicle: Schedule,
    programs: Vec<(f64, ProgramFault)>,
}

/// The vehicle's and the link's faults from `start` to `end` (sim s), one
/// every `every` seconds on average, each kind in turn.
fn vehicle_faults(rng: &mut Rng, start: f64, end: f64, every: f64) -> Schedule {
    let mut s = Schedule::default();
    let mut t = start;
    let mut kind = 0;
    while t < end {
        let (fault, duration) = match kind % 7 {
            0 => (Fault::LinkLoss, Some(rng.range(1.0, 30.0))),
            1 => (
                Fault::Garbage {
                    bytes: rng.range(100.0, 4_000.0) as usize,
                },
                None,
            ),
            2 => (Fault::Duplicate, Some(rng.range(5.0, 30.0))),
            3 => (Fault::Reorder, Some(rng.range(5.0, 30.0))),
            // The next command, whenever it comes (a refusal window over a
            // payload command and the replan's DO_SET_MISSION_CURRENT after
            // it sends the vehicle to the landing: see the report).
            4 => (
                Fault::RefuseCommand(if rng.next().is_multiple_of(2) {
                    Refusal::Denied
                } else {
                    Refusal::TemporarilyRejected
                }),
                None,
            ),
            5 => (Fault::LinkLoss, Some(rng.range(1.0, 30.0))),
            _ => (
                Fault::Reboot {
                    silence_s: rng.range(1.0, 4.0),
                },
                None,
            ),
        };
        s = s.with(fault, Trigger::At(t), duration);
        kind += 1;
        t += rng.range(0.5 * every, 1.5 * every);
    }
    s
}

/// DEC's faults from `start` to `end`: a crash, a few seconds without it,
/// a mute DEC for 80–150 s, the real one again; then the next round. A
/// program's call timeout is in wall time (DEC's 5 s are 50 simulated s
/// at 10×): the mute DEC stays long enough for its calls to time out.
fn program_faults(rng: &mut Rng, start: f64, end: f64, every: f64) -> Vec<(f64, ProgramFault)> {
    let mut out = Vec::new();
    let mut t = start;
    while t < end {
        let mute = rng.range(80.0, 150.0);
        out.push((t, ProgramFault::Crash));
        out.push((t + 5.0, ProgramFault::Mute(mute)));
        out.push((t + 5.0 + mute + 1.0, ProgramFault::Restart));
        t += rng.range(0.5 * every, 1.5 * every) + mute;
    }
    out
}

fn vm_rss_kb(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

/// What a soak left behind.
struct Soaked {
    state: SimState,
    stdout: String,
    stderr: String,
    code: Option<i32>,
    recording: PathBuf,
    /// The recording's folder, with the soak's mission.
    _scratch: Scratch,
    rss: Vec<(f64, u64)>,
    wall: Duration,
}

fn fly(plan: Plan) -> Soaked {
    // A turn to fly (real/main.rs: at most two flights at once, each on
    // instances of its own).
    let _turn = crate::sitl_turn();
    let dir = Scratch::new(&format!("soak-{}", plan.name));
    let recording = dir.join("soak.mcap");
    let mission = soak_mission(&dir, plan.loops);
    let faults = plan.vehicle.entries.len();
    eprintln!(
        "{}: {} vehicle and link faults, {} program faults over {:.0} simulated s at {}×",
        plan.name,
        faults,
        plan.programs.len(),
        plan.sim_s,
        plan.speed
    );
    let mut airframe = sitl_tests::Airframe::default();
    // An hour and more of flight on one battery: the soak is about faults,
    // not endurance (a low battery would end the mission early).
    airframe.battery_capacity_mah *= 20.0;
    let sim = Sim::start(SimConfig {
        listen: "tcpin:127.0.0.1:0".into(),
        boot: sitl_tests::BootTimeline::quick(),
        speedup: plan.speed,
        faults: plan.vehicle,
        params: vec![("RTL_AUTOLAND".into(), 2.0)],
        airframe,
        ..SimConfig::default()
    })
    .expect("the simulator starts");
    let programs = format!("tcp:127.0.0.1:{}", free_port());
    let max_wall = Duration::from_secs_f64(plan.sim_s / plan.speed * 3.0 + 60.0);
    let child = petrel_run(
        &sim.client_address(),
        &programs,
        plan.speed,
        &recording,
        max_wall + Duration::from_secs(30),
        &[],
    );
    let pid = child.id();
    let mut petrel = Running::new(child);
    // Resident memory: (simulated seconds, kB), every 5 simulated s.
    let mut rss: Vec<(f64, u64)> = Vec::new();
    let mut dec = Program::dec(&programs, &mission);
    let started = Instant::now();
    let mut program_faults = plan.programs.clone();
    loop {
        std::thread::sleep(Duration::from_millis(50));
        let state = sim.state();
        if rss.last().is_none_or(|(t, _)| state.time_s - t >= 5.0) {
            if let Some(kb) = vm_rss_kb(pid) {
                rss.push((state.time_s, kb));
            }
        }
        while program_faults
            .first()
            .is_some_and(|(t, _)| *t <= state.time_s)
        {
            let (t, f) = program_faults.remove(0);
            eprintln!("{t:.0} s: DEC {f:?}");
            match f {
                ProgramFault::Crash => dec.end(),
                ProgramFault::Mute(_) => dec = Program::mute(&programs),
                ProgramFault::Restart => {
                    dec.end();
                    dec = Program::dec(&programs, &mission);
                }
            }
        }
        if state.time_s >= plan.sim_s || started.elapsed() > max_wall || petrel.exited() {
            break;
        }
    }
    let wall = started.elapsed();
    let (stdout, stderr, code) = petrel.stop();
    dec.end();
    // Kept beside the recording, to study a failure.
    let _ = std::fs::write(dir.join("timeline.jsonl"), &stdout);
    let _ = std::fs::write(dir.join("stderr.txt"), &stderr);
    eprintln!(
        "{}: the timeline and stderr are in {}",
        plan.name,
        dir.display()
    );
    let state = sim.state();
    sim.stop();
    Soaked {
        state,
        stdout,
        stderr,
        code,
        recording,
        _scratch: dir,
        rss,
        wall,
    }
}

/// The recording's timeline (`petrel replay --json`).
fn replayed(recording: &Path) -> Vec<serde_json::Value> {
    let out = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("replay")
        .arg(recording)
        .arg(project())
        .arg("--json")
        .stderr(Stdio::piped())
        .output()
        .expect("petrel replay runs");
    assert_eq!(
        out.status.code(),
        Some(0),
        "petrel replay: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    flight::timeline(&String::from_utf8_lossy(&out.stdout))
}

/// Every call and command issued before `until_us` (the player's time)
/// has an answer in the recording: done, failed, or timed out. Returns
/// (calls, commands, answers that were timeouts).
fn every_request_answered(timeline: &[serde_json::Value], until_us: u64) -> (usize, usize, usize) {
    use std::collections::BTreeMap;
    let mut asked: BTreeMap<u64, (String, u64)> = BTreeMap::new();
    let mut answered: BTreeMap<u64, String> = BTreeMap::new();
    for l in timeline {
        match (l["effect"].as_str(), l["input"].as_str()) {
            (Some(kind @ ("call" | "command")), _) => {
                if let (Some(id), Some(t)) = (l["id"].as_u64(), l["time_us"].as_u64()) {
                    asked.insert(id, (kind.to_owned(), t));
                }
            }
            (_, Some("reply")) => {
                if let Some(id) = l["reply"].as_u64() {
                    let how = l["failed"].as_str().unwrap_or("done").to_owned();
                    answered.insert(id, how);
                }
            }
            _ => {}
        }
    }
    let unanswered: Vec<String> = asked
        .iter()
        .filter(|(id, (_, t))| *t < until_us && !answered.contains_key(id))
        .map(|(id, (kind, t))| format!("{kind} {id} at {:.1} s", *t as f64 / 1e6))
        .collect();
    assert!(
        unanswered.is_empty(),
        "never answered nor timed out: {unanswered:?}"
    );
    let calls = asked.values().filter(|(k, _)| k == "call").count();
    let commands = asked.len() - calls;
    let timeouts = answered.values().filter(|h| h.contains("timeout")).count();
    (calls, commands, timeouts)
}

/// The memory curve: start, max, end (kB) and the slope (kB per simulated
/// hour) of a least-squares line over the second half (after warm-up).
fn curve(rss: &[(f64, u64)]) -> (u64, u64, u64, f64) {
    let start = rss.first().map_or(0, |s| s.1);
    let max = rss.iter().map(|s| s.1).max().unwrap_or(0);
    let end = rss.last().map_or(0, |s| s.1);
    let half = &rss[rss.len() / 2..];
    let n = half.len() as f64;
    let (mt, mk) = (
        half.iter().map(|s| s.0).sum::<f64>() / n,
        half.iter().map(|s| s.1 as f64).sum::<f64>() / n,
    );
    let cov: f64 = half.iter().map(|s| (s.0 - mt) * (s.1 as f64 - mk)).sum();
    let var: f64 = half.iter().map(|s| (s.0 - mt).powi(2)).sum();
    let slope = if var > 0.0 { cov / var * 3600.0 } else { 0.0 };
    (start, max, end, slope)
}

/// The common checks.
fn survived(name: &str, s: &Soaked, sim_s: f64) {
    let state = &s.state;
    eprintln!(
        "{name}: {:.0} simulated s in {:.1} s of wall time; vehicle: armed {}, flying {}, mode {}, {} items reached, {} commands heard",
        state.time_s,
        s.wall.as_secs_f64(),
        state.armed,
        state.flying,
        state.mode,
        state.reached.len(),
        state.commands.len()
    );
    // Zero panics: a clean exit when told, nothing panicked.
    assert!(
        !s.stderr.contains("panicked"),
        "{name}: a panic:\n{}",
        s.stderr
    );
    assert_eq!(s.code, Some(0), "{name}: petrel run's exit:\n{}", s.stderr);
    // Everything recorded: the recorder never dropped an entry.
    assert!(
        !s.stderr.contains("not recorded") && !s.stderr.contains("recorder fell behind"),
        "{name}: the recorder dropped entries:\n{}",
        s.stderr
    );
    assert!(
        state.time_s >= sim_s,
        "{name}: the soak stopped at {:.0} simulated s of {sim_s:.0} (petrel run exited early?)\n{}",
        state.time_s,
        s.stderr
    );
    assert!(!state.crashed, "{name}: the aircraft crashed: {state:?}");
    // Every kind of vehicle fault happened.
    let kinds: std::collections::BTreeSet<String> = state
        .faults
        .iter()
        .filter(|f| !f.cleared)
        .map(|f| format!("{:?}", f.fault.kind()))
        .collect();
    for k in [
        "LinkLoss",
        "Garbage",
        "Duplicate",
        "Reorder",
        "RefuseCommand",
        "Reboot",
    ] {
        assert!(kinds.contains(k), "{name}: no {k} fault: {kinds:?}");
    }
    // The vehicle refused commands, and the gateway heard the refusals.
    let refused = state
        .commands
        .iter()
        .filter(|c| c.result.is_some_and(|r| r == 2 || r == 1))
        .count();
    assert!(
        refused > 0,
        "{name}: no command was refused: {:?}",
        state
            .commands
            .iter()
            .map(|c| (c.time_s, c.command, c.target_component, c.result))
            .collect::<Vec<_>>()
    );
    // The reboot was seen.
    let live = flight::timeline(&s.stdout);
    let reboots = live
        .iter()
        .filter(|l| l["input"] == "event" && l["event"] == "autopilot_rebooted")
        .count();
    assert!(reboots > 0, "{name}: autopilot_rebooted never heard");
    // Every call and command answered or timed out (from the recording),
    // except those asked in the last program timeout before the end.
    let timeline = replayed(&s.recording);
    let last = timeline
        .iter()
        .filter_map(|l| l["time_us"].as_u64())
        .max()
        .unwrap_or(0);
    let (calls, commands, timeouts) =
        every_request_answered(&timeline, last.saturating_sub(10_000_000));
    assert!(
        calls > 0 && commands > 0,
        "{name}: {calls} calls, {commands} commands"
    );
    assert!(timeouts > 0, "{name}: the mute DEC caused no timeout");
    // The recording replays exactly.
    let check = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("replay")
        .arg(&s.recording)
        .arg(project())
        .arg("--check-against")
        .stdout(Stdio::null())
        .output()
        .expect("petrel replay runs");
    assert_eq!(
        check.status.code(),
        Some(0),
        "{name}: the recording does not replay: {}",
        String::from_utf8_lossy(&check.stderr)
    );
    // Resident memory flat: no growth through the flight beyond what
    // warm-up and the recorder's buffers explain.
    let (start, max, end, slope) = curve(&s.rss);
    eprintln!(
        "{name}: VmRSS start {start} kB, max {max} kB, end {end} kB, slope {slope:.0} kB/h over the second half ({} samples); {calls} calls, {commands} commands, {timeouts} timeouts, {refused} commands refused, {reboots} reboots heard",
        s.rss.len()
    );
    if std::env::var("PETREL_SOAK_CURVE").is_ok() {
        for (t, kb) in &s.rss {
            eprintln!("rss {t:.0} {kb}");
        }
    }
    assert!(s.rss.len() >= 10, "{name}: too few memory samples");
    let (first, second) = s.rss.split_at(s.rss.len() / 2);
    let first_max = first.iter().map(|x| x.1).max().unwrap_or(0);
    let second_max = second.iter().map(|x| x.1).max().unwrap_or(0);
    assert!(
        second_max <= first_max + first_max / 4 + 4_096,
        "{name}: memory kept growing: at most {first_max} kB in the first half, {second_max} kB in the second"
    );
}

#[test]
fn a_few_minutes_of_every_fault() {
    let mut rng = Rng::new();
    // About three simulated minutes at 5× (the recorder of a debug build
    // on a loaded 2-core machine keeps up with that): take-off by ~20 s,
    // then each vehicle fault once and one round of DEC's faults.
    let vehicle = Schedule::default()
        .with(Fault::Garbage { bytes: 2_000 }, Trigger::At(25.0), None)
        .with(
            Fault::LinkLoss,
            Trigger::At(35.0),
            Some(rng.range(1.0, 8.0)),
        )
        .with(Fault::Duplicate, Trigger::At(50.0), Some(8.0))
        .with(Fault::Reorder, Trigger::At(60.0), Some(8.0))
        .with(
            Fault::RefuseCommand(Refusal::Denied),
            Trigger::At(70.0),
            None,
        )
        .with(Fault::Reboot { silence_s: 2.0 }, Trigger::At(150.0), None)
        .with(Fault::Garbage { bytes: 500 }, Trigger::At(170.0), None);
    let s = fly(Plan {
        name: "short",
        sim_s: 200.0,
        speed: 5.0,
        loops: 5,
        vehicle,
        programs: vec![
            (90.0, ProgramFault::Crash),
            (95.0, ProgramFault::Mute(45.0)),
            (141.0, ProgramFault::Restart),
        ],
    });
    survived("short", &s, 200.0);
}

#[test]
#[ignore = "the soak: one simulated hour (a few minutes of wall time); run once per change of the link or recorder code"]
fn an_hour_of_faults() {
    let speed: f64 = std::env::var("PETREL_SOAK_SPEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10.0);
    let mut rng = Rng::new();
    let sim_s = 3_600.0;
    let vehicle = vehicle_faults(&mut rng, 60.0, sim_s - 60.0, 60.0);
    let programs = program_faults(&mut rng, 150.0, sim_s - 200.0, 400.0);
    let s = fly(Plan {
        name: "hour",
        sim_s,
        speed,
        loops: 60,
        vehicle,
        programs,
    });
    survived("hour", &s, sim_s);
    // How long the aircraft flew the mission through the faults (the nets
    // decide when it lands: a replan after a refused or failed payload can
    // end the route early). Reported, not asserted.
    let touchdown = s.state.touchdowns.first().map(|t| t.time_s);
    eprintln!(
        "hour: {} mission items reached; first touchdown at {}; flying at the end: {}",
        s.state.reached.len(),
        touchdown.map_or("none".into(), |t| format!("{t:.0} s")),
        s.state.flying
    );
}
