//! `petrel demo`: one of the examples flown end to end on this machine.
//!
//! - `uav-flight-test` (the default, [`plane`]): a simulated ArduPlane
//!   (`sitl-tests`), DEC (`examples/uav-flight-test/dec`) and the onboard
//!   gateway.
//! - `ugv-bottleneck` ([`rovers`]): two simulated rovers on one link, PLN
//!   (the example's Python planner, started by the gateway as the project
//!   says) and the gateway supervising the team.
//!
//! The simulation and the gateway (`petrel run`'s loop) run in one process,
//! each on its own thread and speaking to the others over loopback sockets
//! as separate processes would (MAVLink over UDP or TCP, the program
//! protocol over TCP), so that a ground mirror or a web monitor can join
//! the same streams later. It prints a readable live log (phases, events,
//! commands), injects the scenario's failures, records `demo.mcap`, and
//! ends with a summary.

mod interrupt;
mod log;
mod plane;
mod rovers;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde_json::Value as Json;

use super::{Outcome, VerbResult};
use log::Log;

use super::examples::{unpack, Example};

/// The mission file DEC reads, in the project folder.
pub const MISSION_FILE: &str = "mission.toml";

impl Example {
    /// The scenario flown when none is named.
    fn default_scenario(self) -> Scenario {
        match self {
            Example::UavFlightTest => Scenario::PayloadThenEngine,
            Example::UgvBottleneck => Scenario::Blocked,
        }
    }

    /// The scenarios it has.
    fn scenarios(self) -> &'static [Scenario] {
        match self {
            Example::UavFlightTest => &[
                Scenario::PayloadThenEngine,
                Scenario::Nominal,
                Scenario::Payload,
                Scenario::Engine,
                Scenario::Link,
                Scenario::Battery,
                Scenario::Cumulative,
            ],
            Example::UgvBottleneck => {
                &[Scenario::Blocked, Scenario::Nominal, Scenario::MotorFailure]
            }
        }
    }

    /// The speed-up when none is given: the plane's flight is watched in
    /// real time (two minutes); the rovers' crossing takes over five
    /// minutes of driving at 2 m/s, watched five times faster.
    fn default_speed(self) -> f64 {
        match self {
            Example::UavFlightTest => 1.0,
            Example::UgvBottleneck => 5.0,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Scenario {
    /// (uav) A payload failure over the first operations-area waypoint,
    /// then an engine failure on the way to the new route: DEC replans,
    /// then picks a site.
    PayloadThenEngine,
    /// Nothing goes wrong.
    Nominal,
    /// (uav) The camera fails: DEC replans without its waypoints.
    Payload,
    /// (uav) The engine fails in transit: glide to the nearest emergency
    /// site.
    Engine,
    /// (uav) The radio link is lost for 10 s: the mission goes on.
    Link,
    /// (uav) The battery runs low: the vehicle returns.
    Battery,
    /// (uav) A payload failure, a link loss, then a low battery.
    Cumulative,
    /// (ugv) The first rover into the bottleneck is stuck there for 80 s:
    /// the other waits at its gate, PLN sends it round.
    Blocked,
    /// (ugv) R1's motor fails on its way: R1 is locked out, the team stops.
    MotorFailure,
}

impl Scenario {
    /// The plane's fault schedule (sitl-tests `--fault` syntax).
    pub fn faults(self) -> &'static [&'static str] {
        match self {
            Scenario::PayloadThenEngine => &["payload_failure=critical@35s", "engine_failure@42s"],
            Scenario::Payload => &["payload_failure@wp3"],
            Scenario::Engine => &["engine_failure@wp2"],
            Scenario::Link => &["link_loss@wp3:10s"],
            Scenario::Battery => &["battery=22@wp4"],
            Scenario::Cumulative => &["payload_failure@wp3", "link_loss@wp5:10s", "battery=22@wp6"],
            Scenario::Nominal | Scenario::Blocked | Scenario::MotorFailure => &[],
        }
    }

    fn name(self) -> String {
        use clap::ValueEnum as _;
        self.to_possible_value()
            .map_or_else(|| format!("{self:?}"), |v| v.get_name().to_owned())
    }
}

#[derive(clap::Args)]
pub struct Args {
    /// A project folder [default: the example's, built into the binary].
    pub project: Option<PathBuf>,
    /// Which example to fly: its simulated vehicles, its programs and its
    /// scenarios.
    #[arg(long, value_enum, default_value = "uav-flight-test")]
    pub example: Example,
    /// What goes wrong [default: payload-then-engine for uav-flight-test,
    /// blocked for ugv-bottleneck].
    #[arg(long, value_enum)]
    pub scenario: Option<Scenario>,
    /// Run the simulation (and the gateway's clock with it) this many times
    /// faster than real time [default: 1 for uav-flight-test, 5 for
    /// ugv-bottleneck].
    #[arg(long)]
    pub speed: Option<f64>,
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

/// What `run` settled from the arguments.
struct Flight<'a> {
    args: &'a Args,
    dir: &'a Path,
    scenario: Scenario,
    speed: f64,
    /// Ctrl-C before the gateway starts (`None` if it cannot be watched).
    interrupt: Option<&'a interrupt::Watch>,
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
    let speed = args.speed.unwrap_or(args.example.default_speed());
    super::run::check_factor("--speed", speed, super::run::FASTEST_CLOCK)?;
    super::run::check_seconds("--timeout", args.timeout)?;
    let scenario = args.scenario.unwrap_or(args.example.default_scenario());
    if !args.example.scenarios().contains(&scenario) {
        let names: Vec<String> = args.example.scenarios().iter().map(|s| s.name()).collect();
        say!(
            "petrel demo: {} has no scenario {}; its scenarios: {}",
            args.example.folder(),
            scenario.name(),
            names.join(", ")
        );
        return Ok(Outcome::BadInput);
    }
    let interrupt = interrupt::Watch::arm();
    let (dir, unpacked) = match &args.project {
        Some(dir) => (dir.clone(), false),
        None => (unpack(args.example)?, true),
    };
    if let (Some(watch), true) = (&interrupt, unpacked) {
        watch.remove_on_interrupt(dir.clone());
    }
    let flight = Flight {
        args: &args,
        dir: &dir,
        scenario,
        speed,
        interrupt: interrupt.as_ref(),
    };
    let outcome = match args.example {
        Example::UavFlightTest => plane::fly(&flight),
        Example::UgvBottleneck => rovers::fly(&flight),
    };
    if unpacked {
        let _ = std::fs::remove_dir_all(&dir);
    }
    outcome
}

/// The onboard gateway (`petrel run`'s own loop) on its thread, its
/// timeline read line by line.
struct Gateway {
    thread: std::thread::JoinHandle<Result<Outcome, String>>,
    stop: Arc<tokio::sync::Notify>,
    lines: std::sync::mpsc::Receiver<String>,
    /// Print the timeline as JSON lines rather than the live log.
    json: bool,
    log: Log,
    /// The team's vehicles (name, system id); empty for one vehicle.
    vehicles: Vec<(String, u8)>,
}

impl Gateway {
    /// Checks the project as `petrel run` does, then starts the gateway on
    /// `mavlink`, serving programs on `programs`. `Err(outcome)` when the
    /// check or the project refused to fly.
    fn start(
        flight: &Flight,
        mavlink: String,
        programs: String,
    ) -> Result<Result<Gateway, Outcome>, miette::Report> {
        let args = flight.args;
        let run_args = super::run::Args {
            project: flight.dir.to_path_buf(),
            mavlink: Some(mavlink),
            profile: None,
            unchecked: false,
            recheck: args.recheck,
            duration: None,
            time_scale: flight.speed,
            json: true,
            record: Some(args.record.clone()),
            no_record: false,
            programs: Some(programs),
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
            // A demonstration on a desktop: the normal priority.
            realtime_priority: crate::scheduling::LOOP_PRIORITY,
            no_realtime: true,
        };
        let mut setup = match super::run::prepare(&run_args)? {
            Ok(setup) => setup,
            Err(outcome) => return Ok(Err(outcome)),
        };
        say!(
            "petrel demo: {} ({}x real time), scenario {}",
            setup.project.name,
            flight.speed,
            flight.scenario.name()
        );
        let vehicles = setup
            .project
            .vehicles
            .iter()
            .map(|v| (v.name.clone(), v.system))
            .collect();
        let (tx, lines) = std::sync::mpsc::channel();
        setup.out = Box::new(Lines(tx, Vec::new()));
        let stop = Arc::new(tokio::sync::Notify::new());
        setup.stop = Some(stop.clone());
        // The gateway watches the signals from here on, stops cleanly and
        // the folder is removed after it.
        if let Some(watch) = flight.interrupt {
            watch.disarm();
        }
        let thread = std::thread::Builder::new()
            .name("petrel-gateway".into())
            .spawn(move || super::run::fly(setup).map_err(|e| format!("{e:?}")))
            .map_err(|e| miette::miette!("cannot start the gateway: {e}"))?;
        Ok(Ok(Gateway {
            thread,
            stop,
            lines,
            json: args.json,
            log: Log::default(),
            vehicles,
        }))
    }

    /// Shows the lines written so far, waiting up to `wait` for the first.
    fn show(&mut self, wait: Duration) {
        while let Ok(line) = self.lines.recv_timeout(wait) {
            print(self.json, &mut self.log, &line);
        }
    }

    /// Whether the gateway stopped by itself (it failed, or its
    /// `--duration` ran out).
    fn finished(&self) -> bool {
        self.thread.is_finished()
    }

    /// Stops the gateway, shows its last lines; its error if it failed.
    fn stop(self) -> Result<Log, miette::Report> {
        let Gateway {
            thread,
            stop,
            lines,
            json,
            mut log,
            ..
        } = self;
        stop.notify_one();
        let result = thread.join();
        while let Ok(line) = lines.try_recv() {
            print(json, &mut log, &line);
        }
        match result {
            Ok(Ok(_)) => Ok(log),
            Ok(Err(e)) => Err(miette::miette!("the gateway stopped: {e}")),
            Err(_) => Err(miette::miette!("the gateway's thread panicked")),
        }
    }
}

/// One timeline line: as it is (`--json`), or in the live log.
fn print(json: bool, log: &mut Log, line: &str) {
    if json {
        show!("{line}");
    } else if let Ok(v) = serde_json::from_str::<Json>(line) {
        log.line(&v);
    }
}

/// The end of a flight: once it is over (the vehicles at rest), the nets
/// get `simulated` seconds of the simulation's time to finish before the
/// demo stops; a flight that goes on again starts the wait afresh.
struct Settle {
    wait: Duration,
    since: Option<Instant>,
}

impl Settle {
    /// `simulated` seconds at `speed` times real time, at least a quarter
    /// of a second of wall time (the gateway's thread prints its last
    /// lines).
    fn new(simulated: f64, speed: f64) -> Settle {
        Settle {
            wait: Duration::from_secs_f64((simulated / speed).max(0.25)),
            since: None,
        }
    }

    /// Whether the demo may stop at `now`, given whether the flight is
    /// over then.
    fn done(&mut self, over: bool, now: Instant) -> bool {
        if !over {
            self.since = None;
            return false;
        }
        now.duration_since(*self.since.get_or_insert(now)) >= self.wait
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settle_waits_for_the_flight_to_stay_over() {
        let t0 = Instant::now();
        let at = |ms: u64| t0 + Duration::from_millis(ms);
        let mut settle = Settle::new(1.0, 1.0);
        assert!(!settle.done(false, at(0)));
        assert!(!settle.done(true, at(100)));
        assert!(!settle.done(true, at(1000)));
        // Moving again starts the wait afresh.
        assert!(!settle.done(false, at(1050)));
        assert!(!settle.done(true, at(1100)));
        assert!(!settle.done(true, at(2000)));
        assert!(settle.done(true, at(2100)));
        // Simulated seconds at the speed, at least a quarter of a second.
        assert_eq!(Settle::new(10.0, 5.0).wait, Duration::from_secs(2));
        assert_eq!(Settle::new(1.0, 100.0).wait, Duration::from_millis(250));
    }
}
