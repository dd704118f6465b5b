//! `petrel demo`: the paper's UAV mission flown end to end on this machine.
//! A simulated ArduPlane (`sitl-tests`), DEC (`examples/uav-flight-test/dec`)
//! and the onboard gateway (`petrel run`'s loop) run in one process, each
//! on its own thread and speaking to the others over loopback sockets as
//! separate processes would (MAVLink over UDP, the program protocol over
//! TCP), so that a ground mirror or a web monitor can join the same
//! streams later. It prints a readable live log (phases, events, commands),
//! injects the scenario's failures, records `demo.mcap`, and ends with a
//! summary of the flight.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde_json::Value as Json;
use sitl_tests::{Schedule, Sim, SimConfig, SimState};

use super::{Outcome, VerbResult};

mod embedded {
    include!(concat!(env!("OUT_DIR"), "/flight_test.rs"));
}

/// The mission file DEC reads, in the project folder.
pub const MISSION_FILE: &str = "mission.toml";

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Scenario {
    /// A payload failure at the second operations-area waypoint, then an
    /// engine failure on the way on: DEC replans, then picks a site.
    PayloadThenEngine,
    /// Nothing goes wrong.
    Nominal,
    /// The camera fails: DEC replans without its waypoints.
    Payload,
    /// The engine fails in transit: glide to the nearest emergency site.
    Engine,
    /// The radio link is lost for 10 s: the mission goes on.
    Link,
    /// The battery runs low: the vehicle returns.
    Battery,
    /// A payload failure, a link loss, then a low battery.
    Cumulative,
}

impl Scenario {
    /// The simulator's fault schedule (sitl-tests `--fault` syntax).
    pub fn faults(self) -> &'static [&'static str] {
        match self {
            Scenario::PayloadThenEngine => &["payload_failure=critical@38s", "engine_failure@50s"],
            Scenario::Nominal => &[],
            Scenario::Payload => &["payload_failure@wp3"],
            Scenario::Engine => &["engine_failure@wp2"],
            Scenario::Link => &["link_loss@wp3:10s"],
            Scenario::Battery => &["battery=22@wp4"],
            Scenario::Cumulative => &["payload_failure@wp3", "link_loss@wp5:10s", "battery=22@wp6"],
        }
    }
}

#[derive(clap::Args)]
pub struct Args {
    /// A project folder [default: examples/uav-flight-test, built into the
    /// binary].
    pub project: Option<PathBuf>,
    /// What goes wrong in flight.
    #[arg(long, value_enum, default_value = "payload-then-engine")]
    pub scenario: Scenario,
    /// Run the simulation (and the gateway's clock with it) this many times
    /// faster than real time.
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Where to record the flight.
    #[arg(long, default_value = "demo.mcap")]
    pub record: PathBuf,
    /// Give up after this many seconds of wall-clock time.
    #[arg(long, default_value_t = 170.0)]
    pub timeout: f64,
    /// Print the gateway's timeline as JSON lines instead of the live log.
    #[arg(long)]
    pub json: bool,
    /// Explore the example before flying even if the same nets, profile and
    /// Petrel held before.
    #[arg(long)]
    pub recheck: bool,
    /// Serve the web monitor on ADDR:PORT (or 127.0.0.1:PORT given a port)
    /// [default: 127.0.0.1:8080, else a free port on 127.0.0.1].
    #[arg(long, value_name = "ADDR:PORT", conflicts_with = "no_http")]
    pub http: Option<String>,
    /// Do not serve the web monitor.
    #[arg(long)]
    pub no_http: bool,
}

/// Where `demo` serves the monitor unless told: 127.0.0.1:8080, or any
/// free port on loopback when 8080 is taken.
fn default_http() -> String {
    match std::net::TcpListener::bind("127.0.0.1:8080") {
        Ok(_) => "127.0.0.1:8080".into(),
        Err(_) => "127.0.0.1:0".into(),
    }
}

/// A free TCP port on 127.0.0.1 (bound, then released).
fn free_port() -> Result<u16, miette::Report> {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .map_err(|e| miette::miette!("cannot find a free port on 127.0.0.1: {e}"))
}

/// Writes the built-in example into a fresh folder.
pub(crate) fn unpack() -> Result<PathBuf, miette::Report> {
    let dir = std::env::temp_dir().join(format!("petrel-demo-{}", std::process::id()));
    std::fs::create_dir_all(&dir)
        .map_err(|e| miette::miette!("cannot create {}: {e}", dir.display()))?;
    for (name, text) in embedded::FILES {
        std::fs::write(dir.join(name), text)
            .map_err(|e| miette::miette!("cannot write {}: {e}", dir.join(name).display()))?;
    }
    Ok(dir)
}

/// Lines written by the gateway, handed over one by one.
struct Lines(std::sync::mpsc::Sender<String>, Vec<u8>);

impl Write for Lines {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.1.extend_from_slice(buf);
        while let Some(end) = self.1.iter().position(|&b| b == b'\n') {
            let line: Vec<u8> = self.1.drain(..=end).collect();
            let _ = self
                .0
                .send(String::from_utf8_lossy(&line).trim_end().to_owned());
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

pub fn run(args: Args) -> VerbResult {
    if !(args.speed.is_finite() && args.speed > 0.0) {
        return Err(miette::miette!(
            "--speed must be a positive number, not {}",
            args.speed
        ));
    }
    let (dir, unpacked) = match &args.project {
        Some(dir) => (dir.clone(), false),
        None => (unpack()?, true),
    };
    let outcome = fly(&args, &dir);
    if unpacked {
        let _ = std::fs::remove_dir_all(&dir);
    }
    outcome
}

fn fly(args: &Args, dir: &Path) -> VerbResult {
    let schedule = Schedule::parse(args.scenario.faults())
        .map_err(|e| miette::miette!("the scenario's fault schedule: {e}"))?;
    let sim = Sim::start(SimConfig {
        listen: "tcpin:127.0.0.1:0".into(),
        // GPS and EKF ready in 3 s instead of ArduPlane's 20.
        boot: sitl_tests::BootTimeline::quick(),
        speedup: args.speed,
        faults: schedule,
        // What the example's mission needs of ArduPlane (its DO_LAND_START:
        // docs/flight-test.md), as a crew sets it.
        params: vec![("RTL_AUTOLAND".into(), 2.0)],
        ..SimConfig::default()
    })
    .map_err(|e| miette::miette!("cannot start the simulated vehicle: {e}"))?;
    let programs = format!("tcp:127.0.0.1:{}", free_port()?);
    let run_args = super::run::Args {
        project: dir.to_path_buf(),
        mavlink: Some(sim.client_address()),
        profile: None,
        unchecked: false,
        recheck: args.recheck,
        duration: None,
        time_scale: args.speed,
        json: true,
        record: Some(args.record.clone()),
        no_record: false,
        programs: Some(programs.clone()),
        programs_token: None,
        signing_key: None,
        require_signed: false,
        signing_link_id: 0,
        signing_timestamp: None,
        downlink: false,
        mirror_system: None,
        operator_key: None,
        http: match (&args.http, args.no_http) {
            (_, true) => None,
            (Some(a), false) => Some(a.clone()),
            (None, false) => Some(default_http()),
        },
    };
    let mut setup = match super::run::prepare(&run_args)? {
        Ok(setup) => setup,
        Err(outcome) => return Ok(outcome),
    };
    let project = setup.project.clone();
    let (tx, rx) = std::sync::mpsc::channel();
    setup.out = Box::new(Lines(tx, Vec::new()));
    let stop = Arc::new(tokio::sync::Notify::new());
    setup.stop = Some(stop.clone());
    say!(
        "petrel demo: {} over a simulated ArduPlane ({}x real time), scenario {:?}",
        project.name,
        args.speed,
        args.scenario
    );
    let gateway = std::thread::Builder::new()
        .name("petrel-gateway".into())
        .spawn(move || super::run::fly(setup).map_err(|e| format!("{e:?}")))
        .map_err(|e| miette::miette!("cannot start the gateway: {e}"))?;
    // DEC connects to the gateway like any program.
    let dec_stop = Arc::new(AtomicBool::new(false));
    let dec = {
        let stop = dec_stop.clone();
        let mission = dir.join(MISSION_FILE);
        let address = programs.clone();
        std::thread::Builder::new()
            .name("dec".into())
            .spawn(move || petrel_dec::serve_until(&address, &mission, stop))
            .map_err(|e| miette::miette!("cannot start DEC: {e}"))?
    };
    let started = Instant::now();
    let give_up = started + Duration::from_secs_f64(args.timeout.max(1.0));
    let mut log = Log::default();
    let mut faults_seen = 0;
    let mut settled_since: Option<Instant> = None;
    while Instant::now() < give_up {
        while let Ok(line) = rx.recv_timeout(Duration::from_millis(100)) {
            if args.json {
                println!("{line}");
            } else if let Ok(v) = serde_json::from_str::<Json>(&line) {
                log.line(&v);
            }
        }
        let state = sim.state();
        for f in state.faults.iter().skip(faults_seen) {
            if !args.json {
                println!("{:>8.1}s  !! injected: {:?}", f.time_s, f.fault);
            }
        }
        faults_seen = state.faults.len();
        // The flight is over once the aircraft is down and disarmed (or has
        // crashed), and the nets have had a few seconds to finish.
        let over = (state.landed && !state.armed) || state.crashed;
        match (over, settled_since) {
            (true, None) => settled_since = Some(Instant::now()),
            (true, Some(t)) if t.elapsed() > Duration::from_secs_f64(3.0 / args.speed.min(3.0)) => {
                break
            }
            (false, _) => settled_since = None,
            _ => {}
        }
        if gateway.is_finished() {
            break;
        }
    }
    let timed_out = Instant::now() >= give_up;
    stop.notify_one();
    let result = gateway.join();
    dec_stop.store(true, Ordering::Relaxed);
    let _ = dec.join();
    while let Ok(line) = rx.try_recv() {
        if args.json {
            println!("{line}");
        } else if let Ok(v) = serde_json::from_str::<Json>(&line) {
            log.line(&v);
        }
    }
    let state = sim.state();
    sim.stop();
    match result {
        Ok(Ok(_)) => {}
        Ok(Err(e)) => return Err(miette::miette!("the gateway stopped: {e}")),
        Err(_) => return Err(miette::miette!("the gateway's thread panicked")),
    }
    summary(&state, &log, &args.record, started.elapsed(), timed_out);
    Ok(if timed_out {
        Outcome::Failed
    } else {
        Outcome::Success
    })
}

/// What the live log has counted.
#[derive(Default)]
struct Log {
    events: std::collections::BTreeMap<String, u64>,
    commands: u64,
    calls: u64,
    dropped: u64,
    phase: std::collections::BTreeMap<String, String>,
}

impl Log {
    /// Prints one timeline line for people, if it is worth it.
    fn line(&mut self, v: &Json) {
        let t = v["t"].as_f64().unwrap_or(0.0);
        let s = |k: &str| v[k].as_str().unwrap_or("").to_owned();
        if v["input"] == "event" {
            let category = s("category");
            *self.events.entry(category.clone()).or_default() += 1;
            let params = params_text(&v["params"]);
            println!("{t:>8.1}s  event    {}{params}  [{category}]", s("event"));
            return;
        }
        match v["effect"].as_str() {
            Some("command") => {
                self.commands += 1;
                println!(
                    "{t:>8.1}s  command  {}{}  ({})",
                    s("verb"),
                    params_text(&v["args"]),
                    s("net")
                );
            }
            Some("call") => {
                self.calls += 1;
                println!(
                    "{t:>8.1}s  call     {}.{}{}  ({})",
                    s("program"),
                    s("function"),
                    params_text(&v["args"]),
                    s("net")
                );
            }
            Some("marking") => {
                let net = s("net");
                let marked: Vec<&str> = v["marked"]
                    .as_array()
                    .map(|a| {
                        a.iter()
                            .filter_map(Json::as_str)
                            .filter(|p| !p.starts_with('@'))
                            .collect()
                    })
                    .unwrap_or_default();
                let now = marked.join(", ");
                if !net.is_empty() && self.phase.get(&net) != Some(&now) {
                    println!("{t:>8.1}s  {net:<8} {now}");
                    self.phase.insert(net, now);
                }
            }
            Some("dropped") => {
                self.dropped += 1;
                println!("{t:>8.1}s  dropped  {} ({})", s("event"), s("reason"));
            }
            Some("fault") => println!("{t:>8.1}s  FAULT    {v}"),
            _ => {}
        }
    }
}

/// ` {a: 1, b: "x"}`, or nothing for no parameters; long values cut.
fn params_text(p: &Json) -> String {
    let Some(map) = p.as_object().filter(|m| !m.is_empty()) else {
        return String::new();
    };
    let parts: Vec<String> = map
        .iter()
        .map(|(k, v)| {
            let text = v.to_string();
            if text.len() > 40 {
                format!("{k}: …")
            } else {
                format!("{k}: {text}")
            }
        })
        .collect();
    format!(" {{{}}}", parts.join(", "))
}

fn summary(state: &SimState, log: &Log, record: &Path, wall: Duration, timed_out: bool) {
    println!();
    println!("— flight summary —");
    if timed_out {
        println!(
            "the flight did not end in time: stopped after {:.0} s of wall time",
            wall.as_secs_f64()
        );
    }
    let end = if state.crashed {
        "crashed"
    } else if state.landed {
        "landed"
    } else if state.flying {
        "still flying"
    } else {
        "on the ground"
    };
    println!(
        "{:.0} s of flight time simulated in {:.0} s; the aircraft {end} at {:.6}, {:.6}, {}",
        state.time_s,
        wall.as_secs_f64(),
        state.lat,
        state.lon,
        if state.armed { "armed" } else { "disarmed" }
    );
    let reached: Vec<String> = state.reached.iter().map(|r| r.seq.to_string()).collect();
    println!("mission items reached: {}", list_or_none(&reached));
    println!(
        "camera events: {}; payload actions: {}; faults injected: {}",
        state.camera.len(),
        state.payload_actions.len(),
        state.faults.len()
    );
    let events: Vec<String> = log.events.iter().map(|(c, n)| format!("{n} {c}")).collect();
    println!(
        "events: {}; commands: {}; program calls: {}; dropped under the catastrophic lockout: {}",
        list_or_none(&events),
        log.commands,
        log.calls,
        log.dropped
    );
    println!(
        "recorded to {} (petrel replay {} PROJECT --check-against)",
        record.display(),
        record.display()
    );
}

/// `a, b, c`, or `none`.
fn list_or_none(items: &[String]) -> String {
    if items.is_empty() {
        "none".into()
    } else {
        items.join(", ")
    }
}
