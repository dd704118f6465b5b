//! The ground mirror's CPU per frame beside `petrel run`'s, on the same
//! flight: the simulated ArduPlane behind the mirror tests' router (the
//! companion's port and the ground's, as ArduPilot routes them), the real
//! `petrel run --downlink` with DEC on the companion's port and the real
//! `petrel mirror` on the ground's, both release builds recording their
//! MCAP as deployed, over the whole flight-test mission at 10× real time.
//!
//! Each process's CPU time (user + system, from /proc) is divided by the
//! frames its link delivered to it: `run` gets the autopilot's telemetry
//! (and the mirror's requests); the mirror gets the same telemetry plus the
//! downlink's TUNNELs, and its work per frame is elaborating the ground's
//! telemetry (the independent check), playing the records on its replica
//! and recording. So the ratio is the mirror's cost against the gateway
//! it duplicates, in the same run.
//!
//! A process-level measure: the two processes, link and recording
//! included, as a ground station would run them (the per-frame path alone,
//! through the library, is `benches/mirror_ground.rs`).
//!
//! Once idle, then with the other core kept busy by a spinning thread of
//! this process. Run: `cargo bench -p gateway --bench mirror`.

use petrel_test_support::busy;
#[path = "../tests/scenarios/flight.rs"]
mod flight;
use petrel_test_support::proc;
#[path = "../tests/mirror/router.rs"]
mod router;
use petrel_test_support::scratch;

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use flight::{free_port, petrel_run, project, start_sim, stop, Dec, Killed, SPEED};
use proc::cpu;
use router::{Loss, Router};
use scratch::Scratch;

/// The scenarios' mission file (DEC reads it).
pub const MISSION_FILE: &str = "mission.toml";

const MAX_SIM_S: f64 = 420.0;

struct Figures {
    run_cpu: Duration,
    run_frames: u64,
    mirror_cpu: Duration,
    mirror_frames: u64,
    wall: Duration,
    sim_s: f64,
}

fn flight() -> Option<Figures> {
    let dir = Scratch::new("bench-mirror");
    let sim = start_sim(&[]);
    let mut router = Router::start(sim.local_addr(), Loss::default());
    let programs = format!("tcp:127.0.0.1:{}", free_port());
    let max_wall = Duration::from_secs_f64(MAX_SIM_S / SPEED + 10.0);
    let mirror = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("mirror")
        .arg(project())
        .arg("--record")
        .arg(dir.join("mirror.mcap"))
        .args([
            "--mavlink",
            &format!("tcpout:127.0.0.1:{}", router.ground_port),
        ])
        .args(["--time-scale", &SPEED.to_string()])
        .args([
            "--duration",
            &format!("{:.0}", max_wall.as_secs_f64() + 10.0),
        ])
        .arg("--json")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    let mut mirror = Killed(Some(mirror));
    let run = petrel_run(
        &format!("tcpout:127.0.0.1:{}", router.companion_port),
        &programs,
        SPEED,
        &dir.join("flight.mcap"),
        max_wall + Duration::from_secs(5),
        &["--downlink", "--unchecked"],
    );
    let mut run = Killed(Some(run));
    let dec = Dec::start(&programs);
    let started = Instant::now();
    let mut state;
    loop {
        std::thread::sleep(Duration::from_millis(100));
        state = sim.state();
        let over = (state.landed && !state.armed && !state.reached.is_empty()) || state.crashed;
        if over || state.time_s > MAX_SIM_S || started.elapsed() > max_wall {
            break;
        }
    }
    let wall = started.elapsed();
    let run_pid = run.0.as_ref()?.id();
    let mirror_pid = mirror.0.as_ref()?.id();
    let (run_cpu, mirror_cpu) = (cpu(run_pid)?, cpu(mirror_pid)?);
    let traffic = std::mem::take(&mut *router.traffic());
    let _ = stop(run.0.take()?);
    let _ = stop(mirror.0.take()?);
    dec.stop();
    sim.stop();
    router.stop();
    if !state.landed || state.armed {
        eprintln!("the flight did not end landed and disarmed: {state:?}");
        return None;
    }
    Some(Figures {
        run_cpu,
        run_frames: traffic.to_companion,
        mirror_cpu,
        mirror_frames: traffic.to_ground.0,
        wall,
        sim_s: state.time_s,
    })
}

fn report(label: &str) {
    let Some(f) = flight() else {
        println!("{label}: the flight failed");
        return;
    };
    let per = |cpu: Duration, frames: u64| cpu.as_secs_f64() * 1e6 / frames.max(1) as f64;
    let (run, mirror) = (
        per(f.run_cpu, f.run_frames),
        per(f.mirror_cpu, f.mirror_frames),
    );
    println!("## {label}");
    println!(
        "flight-test mission, {:.0} simulated s in {:.1} wall s ({SPEED}x)",
        f.sim_s,
        f.wall.as_secs_f64()
    );
    println!(
        "petrel run --downlink: {:.2} s CPU for {} frames: {run:.1} µs/frame ({:.1} % of a core)",
        f.run_cpu.as_secs_f64(),
        f.run_frames,
        100.0 * f.run_cpu.as_secs_f64() / f.wall.as_secs_f64()
    );
    println!(
        "petrel mirror:         {:.2} s CPU for {} frames: {mirror:.1} µs/frame ({:.1} % of a core)",
        f.mirror_cpu.as_secs_f64(),
        f.mirror_frames,
        100.0 * f.mirror_cpu.as_secs_f64() / f.wall.as_secs_f64()
    );
    println!("mirror / run per frame: {:.2}", mirror / run.max(1e-9));
}

fn main() {
    // `cargo bench` passes --bench; `cargo test --benches` does not run it.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    report("idle");
    busy::with_a_core_busy(|| report("the other core busy (a spinning thread)"));
}
