#![allow(dead_code)] // shared by several test binaries, each using a part
//! One end-to-end flight: the simulated ArduPlane (in this process), DEC
//! (a thread of this process, over the program protocol on TCP) and the
//! real `petrel run` process on examples/uav-flight-test, all over
//! loopback, with the gateway's clock running as fast as the simulator's.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use sitl_tests::{Fault, Schedule, Sim, SimConfig, SimState};

use crate::scratch::Scratch;

/// A fault injected from the test when a condition first holds.
pub type Injection = (Box<dyn Fn(&SimState) -> bool>, Fault);

/// Simulated seconds per wall second.
pub const SPEED: f64 = 10.0;

pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

pub fn project() -> PathBuf {
    root().join("examples/uav-flight-test")
}

/// The flight-test example's COMMUNICATION net, version 1 (issue 38's
/// flights): a link that failed once is not trusted, the vehicle returns
/// home once it is back (version 0 proceeds with the mission whatever the
/// links do).
pub fn returning_after_a_link_hole(example: &Path) -> String {
    let text = std::fs::read_to_string(example.join("communication.toml")).expect("the net");
    let text = text
        .replace(
            "places = [\"proceeding\"]",
            "places = [\"proceeding\", \"degraded\", \"returning\"]",
        )
        .replace(
            "final = [\"proceeding\"]",
            "final = [\"proceeding\", \"returning\"]",
        );
    let lost = "from = [\"proceeding\"]\nto = [\"proceeding\"]\non = \"link_lost\"";
    let restored = "from = [\"proceeding\"]\nto = [\"proceeding\"]\non = \"link_restored\"";
    assert!(text.contains(lost) && text.contains(restored), "{text}");
    text.replace(
        lost,
        "from = [\"proceeding\"]\nto = [\"degraded\"]\non = \"link_lost\"",
    )
    .replace(
        restored,
        "from = [\"degraded\"]\nto = [\"returning\"]\non = \"link_restored\"\ndo = [\"command rtl\"]",
    )
}

/// A copy of the flight-test example's files (not its folders) in `dir`.
pub fn example_copy(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).expect("a folder");
    for entry in std::fs::read_dir(project()).expect("the example") {
        let path = entry.expect("an entry").path();
        if path.is_file() {
            std::fs::copy(&path, dir.join(path.file_name().expect("a name"))).expect("copied");
        }
    }
    dir.to_path_buf()
}

/// What a flight left behind.
pub struct Flown {
    pub state: SimState,
    /// The gateway's timeline, JSON lines.
    pub timeline: Vec<serde_json::Value>,
    pub stderr: String,
    pub recording: PathBuf,
    /// The folder of the recording, removed with the flight.
    pub scratch: Scratch,
    pub wall: Duration,
}

impl Flown {
    /// The timeline's effects of one kind.
    pub fn effects(&self, kind: &str) -> Vec<&serde_json::Value> {
        self.timeline
            .iter()
            .filter(|l| l["effect"] == kind)
            .collect()
    }

    /// The verbs commanded, in order.
    pub fn verbs(&self) -> Vec<String> {
        self.effects("command")
            .iter()
            .filter_map(|l| l["verb"].as_str().map(str::to_owned))
            .collect()
    }

    /// The functions called on programs, in order.
    pub fn calls(&self) -> Vec<String> {
        self.effects("call")
            .iter()
            .filter_map(|l| l["function"].as_str().map(str::to_owned))
            .collect()
    }

    /// Events heard (elaborated or from programs), in order.
    pub fn events(&self) -> Vec<String> {
        self.timeline
            .iter()
            .filter(|l| l["input"] == "event")
            .filter_map(|l| l["event"].as_str().map(str::to_owned))
            .collect()
    }

    /// Replays the recording with --check-against: (exit code, stderr).
    pub fn replay_check(&self) -> (Option<i32>, String) {
        self.replay_check_project(&project())
    }

    /// The same, for a flight of another project.
    pub fn replay_check_project(&self, project: &Path) -> (Option<i32>, String) {
        let out = Command::new(env!("CARGO_BIN_EXE_petrel"))
            .arg("replay")
            .arg(&self.recording)
            .arg(project)
            .arg("--check-against")
            .stdout(Stdio::null())
            .output();
        match out {
            Ok(o) => (
                o.status.code(),
                String::from_utf8_lossy(&o.stderr).into_owned(),
            ),
            Err(e) => (None, e.to_string()),
        }
    }
}

pub struct Killed(pub Option<Child>);

impl Drop for Killed {
    fn drop(&mut self) {
        if let Some(mut c) = self.0.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// `petrel run` whose timeline (stdout) is read on a thread as it comes,
/// so that its pipe never fills; killed and reaped on drop.
pub struct Running {
    child: Killed,
    lines: Arc<std::sync::Mutex<String>>,
    reader: Option<std::thread::JoinHandle<()>>,
}

impl Running {
    pub fn new(mut child: Child) -> Running {
        let lines = Arc::new(std::sync::Mutex::new(String::new()));
        let reader = child.stdout.take().map(|out| {
            let lines = lines.clone();
            std::thread::spawn(move || {
                use std::io::BufRead;
                for line in std::io::BufReader::new(out).lines().map_while(Result::ok) {
                    if let Ok(mut l) = lines.lock() {
                        l.push_str(&line);
                        l.push('\n');
                    }
                }
            })
        });
        Running {
            child: Killed(Some(child)),
            lines,
            reader,
        }
    }

    /// SIGHUP: `petrel run` reads its project again (a new version).
    pub fn hangup(&self) {
        if let Some(c) = &self.child.0 {
            let _ = Command::new("kill")
                .args(["-HUP", &c.id().to_string()])
                .stderr(std::process::Stdio::null())
                .status();
        }
    }

    /// Whether its timeline so far holds `needle`.
    pub fn printed(&self, needle: &str) -> bool {
        self.lines.lock().is_ok_and(|l| l.contains(needle))
    }

    /// It has exited by itself.
    pub fn exited(&mut self) -> bool {
        self.child
            .0
            .as_mut()
            .is_some_and(|c| matches!(c.try_wait(), Ok(Some(_))))
    }

    /// SIGTERM (the recording is finished), then what it printed and its
    /// exit code: (stdout, stderr, code).
    pub fn stop(mut self) -> (String, String, Option<i32>) {
        let Some(mut petrel) = self.child.0.take() else {
            return (String::new(), String::new(), None);
        };
        let _ = Command::new("kill")
            .args(["-TERM", &petrel.id().to_string()])
            .stderr(std::process::Stdio::null())
            .status();
        let mut stderr = String::new();
        if let Some(mut e) = petrel.stderr.take() {
            let _ = e.read_to_string(&mut stderr);
        }
        let code = petrel.wait().ok().and_then(|s| s.code());
        if let Some(r) = self.reader.take() {
            let _ = r.join();
        }
        let stdout = self.lines.lock().map(|l| l.clone()).unwrap_or_default();
        (stdout, stderr, code)
    }
}

/// One mirrored flight or team drive at a time in a test binary (held
/// until dropped): the machine has two cores, and each runs simulated
/// vehicles, gateways and a program faster than real time; one slowed by
/// another misses its deadlines. Poison is ignored (a failed test does not
/// stop the others).
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

pub fn turn() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// A UDP port free on 127.0.0.1 a moment ago.
pub fn free_udp_port() -> u16 {
    std::net::UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .map(|a| a.port())
        .expect("a free UDP port")
}

/// `petrel run` on the example, its clock `time_scale` times the wall,
/// its timeline (JSON lines) and stderr piped.
pub fn petrel_run(
    mavlink: &str,
    programs: &str,
    time_scale: f64,
    recording: &Path,
    duration: Duration,
    extra: &[&str],
) -> Child {
    petrel_run_project(
        &project(),
        mavlink,
        programs,
        time_scale,
        recording,
        duration,
        extra,
    )
}

/// The same on another project.
pub fn petrel_run_project(
    project: &Path,
    mavlink: &str,
    programs: &str,
    time_scale: f64,
    recording: &Path,
    duration: Duration,
    extra: &[&str],
) -> Child {
    Command::new(env!("CARGO_BIN_EXE_petrel"))
        .current_dir(root())
        .arg("run")
        .arg(project)
        .args(["--mavlink", mavlink])
        .args(["--programs", programs])
        .args(["--time-scale", &time_scale.to_string()])
        .arg("--record")
        .arg(recording)
        .args(["--duration", &format!("{:.0}", duration.as_secs_f64())])
        .arg("--json")
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("petrel runs")
}

/// Stops `petrel run` cleanly (SIGTERM: the recording is finished) and
/// returns what it printed: (stdout, stderr).
pub fn stop(mut child: Child) -> (String, String) {
    let _ = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status();
    let mut stdout = String::new();
    let mut stderr = String::new();
    if let Some(mut o) = child.stdout.take() {
        let _ = o.read_to_string(&mut stdout);
    }
    if let Some(mut e) = child.stderr.take() {
        let _ = e.read_to_string(&mut stderr);
    }
    let _ = child.wait();
    (stdout, stderr)
}

/// DEC on a thread, connecting to the gateway's programs address.
pub struct Dec {
    stop: Arc<AtomicBool>,
    thread: std::thread::JoinHandle<Result<(), petrel_dec::Error>>,
}

impl Dec {
    pub fn start(programs: &str) -> Dec {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let mission = project().join(super::MISSION_FILE);
        let address = programs.to_owned();
        let thread = std::thread::spawn(move || petrel_dec::serve_until(&address, &mission, flag));
        Dec { stop, thread }
    }

    pub fn stop(self) {
        self.stop.store(true, Ordering::Relaxed);
        let _ = self.thread.join();
    }
}

pub fn timeline(stdout: &str) -> Vec<serde_json::Value> {
    stdout
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

/// The simulated ArduPlane for the example's flights, on a free TCP port,
/// with `faults` (sitl-tests `--fault` syntax).
pub fn start_sim(faults: &[&str]) -> Sim {
    Sim::start(SimConfig {
        listen: "tcpin:127.0.0.1:0".into(),
        // GPS and EKF ready in 3 s instead of ArduPlane's 20.
        boot: sitl_tests::BootTimeline::quick(),
        speedup: SPEED,
        faults: Schedule::parse(faults).expect("a valid schedule"),
        // What the example's mission needs of ArduPlane (its DO_LAND_START:
        // docs/flight-test.md), as a crew sets it.
        params: vec![("RTL_AUTOLAND".into(), 2.0)],
        ..SimConfig::default()
    })
    .expect("the simulator starts")
}

/// Flies `faults` (sitl-tests `--fault` syntax) until `done` holds of the
/// simulated vehicle (then 3 more simulated seconds for the nets to
/// finish), at most `max_sim_s` simulated seconds.
pub fn fly(
    name: &str,
    faults: &[&str],
    mut injections: Vec<Injection>,
    max_sim_s: f64,
    done: impl Fn(&SimState) -> bool,
) -> Flown {
    let scratch = Scratch::new(&format!("scenario-{name}"));
    let recording = scratch.join("flight.mcap");
    let sim = start_sim(faults);
    let programs = format!("tcp:127.0.0.1:{}", free_port());
    let max_wall = Duration::from_secs_f64(max_sim_s / SPEED + 10.0);
    let petrel = petrel_run(
        &sim.client_address(),
        &programs,
        SPEED,
        &recording,
        max_wall + Duration::from_secs(5),
        &[],
    );
    let mut petrel = Killed(Some(petrel));
    let dec = Dec::start(&programs);
    let started = Instant::now();
    let mut finished_at: Option<f64> = None;
    loop {
        std::thread::sleep(Duration::from_millis(100));
        let state = sim.state();
        if over(
            &state,
            &mut injections,
            |f| sim.inject(f),
            &done,
            &mut finished_at,
        ) {
            break;
        }
        if state.time_s > max_sim_s || started.elapsed() > max_wall {
            break;
        }
        if petrel
            .0
            .as_mut()
            .is_some_and(|c| matches!(c.try_wait(), Ok(Some(_))))
        {
            break;
        }
    }
    let wall = started.elapsed();
    let (stdout, stderr) = stop(petrel.0.take().expect("petrel"));
    dec.stop();
    let state = sim.state();
    sim.stop();
    Flown {
        state,
        timeline: timeline(&stdout),
        stderr,
        recording,
        scratch,
        wall,
    }
}

/// One look at the flight: injects the faults whose condition first holds
/// of `state`, and says whether it is over (`done` held 3 simulated seconds
/// ago, `finished_at` remembering when).
pub fn over(
    state: &SimState,
    injections: &mut Vec<Injection>,
    mut inject: impl FnMut(Fault),
    done: &impl Fn(&SimState) -> bool,
    finished_at: &mut Option<f64>,
) -> bool {
    injections.retain(|(when, fault)| {
        let now = when(state);
        if now {
            inject(fault.clone());
        }
        !now
    });
    if finished_at.is_none() && done(state) {
        *finished_at = Some(state.time_s);
    }
    finished_at.is_some_and(|t| state.time_s > t + 3.0)
}

/// Metres between two positions (equirectangular, fine at these ranges).
pub fn metres(a: (f64, f64), b: (f64, f64)) -> f64 {
    let north = (a.0 - b.0).to_radians() * 6_371_000.0;
    let east = (a.1 - b.1).to_radians() * 6_371_000.0 * a.0.to_radians().cos();
    (north * north + east * east).sqrt()
}

/// An emergency site of the mission file, by name.
pub fn site(name: &str) -> (f64, f64) {
    let text = std::fs::read_to_string(project().join(super::MISSION_FILE)).expect("mission file");
    let mission: toml::Table = toml::from_str(&text).expect("TOML");
    let sites = mission["site"].as_array().expect("sites");
    let site = sites
        .iter()
        .find(|s| s["name"].as_str() == Some(name))
        .unwrap_or_else(|| panic!("no site {name}"));
    (
        site["lat"].as_float().expect("lat"),
        site["lon"].as_float().expect("lon"),
    )
}
