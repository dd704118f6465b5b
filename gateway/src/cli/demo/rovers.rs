//! `petrel demo --example ugv-bottleneck`: the ProCoSA paper's UGV lab
//! test (§3.3.2). Two simulated rovers (sitl-tests' `Fleet`, ArduPilot
//! Rover on the wire) on one UDP link, each its own system id, parked at
//! their starts in the labyrinth; PLN, the example's planner (pln.py),
//! started by the gateway as project.toml says; the gateway supervising the
//! team. The demo watches the simulated positions: it says when a rover is
//! in the bottleneck, and fails if both ever are at once.

use std::path::Path;
use std::time::{Duration, Instant};

use sitl_tests::geo::{location, offset, Home, V2};
use sitl_tests::{BootTimeline, Fault, Fleet, Schedule, SimConfig, SimState};

use super::log::Log;
use super::{free_port, Flight, Gateway, Scenario, Settle};
use crate::cli::{Outcome, VerbResult};

/// Where the rovers start and end, metres north and east of the
/// labyrinth's origin (SITL's home, where pln.py measures from; the
/// example's README draws the labyrinth).
const ROVERS: [Rover; 2] = [
    Rover {
        system: 1,
        start: (0.0, -20.0),
        goal: (55.0, -20.0),
    },
    Rover {
        system: 2,
        start: (60.0, 20.0),
        goal: (5.0, 20.0),
    },
];

/// How long the `blocked` scenario keeps the first rover in stuck, in
/// simulated seconds: past CORRIDOR's 60 s watchdog, so that SYNC asks PLN
/// to replan, and the other rover goes round.
const STUCK_FOR_S: f64 = 80.0;

/// When R1's motor fails in the `motor-failure` scenario.
const MOTOR_FAILS: (u8, &str) = (1, "engine_failure@30s");

struct Rover {
    system: u8,
    start: (f64, f64),
    goal: (f64, f64),
}

impl Rover {
    fn config(&self, speed: f64) -> SimConfig {
        let origin = Home::default();
        let (lat, lon) = location(&origin, V2::new(self.start.0, self.start.1));
        SimConfig {
            boot: BootTimeline::quick(),
            first_arm_refused: false,
            speedup: speed,
            ..SimConfig::rover(self.system, Home { lat, lon, ..origin })
        }
    }
}

/// Where a rover is, metres north and east of the labyrinth's origin.
fn at(s: &SimState) -> (f64, f64) {
    let v = offset(&Home::default(), s.lat, s.lon);
    (v.n, v.e)
}

/// Inside the bottleneck: the corridor between the gates (north 15..45,
/// east −1.5..1.5), the gates excluded (a robot waits at its gate).
fn in_bottleneck(s: &SimState) -> bool {
    let (n, e) = at(s);
    (17.5..42.5).contains(&n) && e.abs() < 1.5
}

/// A rover's name in the project (R1 for system 1), else its system id.
fn name(vehicles: &[(String, u8)], system: u8) -> String {
    vehicles
        .iter()
        .find(|(_, s)| *s == system)
        .map_or_else(|| format!("system {system}"), |(n, _)| n.clone())
}

/// What the demo saw of the rovers while they drove.
#[derive(Default)]
struct Watch {
    /// Each rover's faults already printed.
    faults_seen: Vec<usize>,
    /// Each rover: in the bottleneck at the last look.
    inside: Vec<bool>,
    /// Each rover: has it been armed?
    armed_once: Vec<bool>,
    /// Snapshots taken, and those with both rovers in the bottleneck.
    looks: u64,
    both_inside: u64,
    /// The rover the `blocked` scenario stuck, once it has.
    stuck: Option<u8>,
}

pub(super) fn fly(flight: &Flight) -> VerbResult {
    let args = flight.args;
    let mut configs: Vec<SimConfig> = ROVERS.iter().map(|r| r.config(flight.speed)).collect();
    if flight.scenario == Scenario::MotorFailure {
        let (system, spec) = MOTOR_FAILS;
        let schedule = Schedule::parse(&[spec])
            .map_err(|e| miette::miette!("the scenario's fault schedule: {e}"))?;
        if let Some(c) = configs.iter_mut().find(|c| c.system_id == system) {
            c.faults.entries.extend(schedule.entries);
        }
    }
    let port = std::net::UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .map(|a| a.port())
        .map_err(|e| miette::miette!("cannot find a free port on 127.0.0.1: {e}"))?;
    let fleet = Fleet::start(&format!("udpin:127.0.0.1:{port}"), flight.speed, configs)
        .map_err(|e| miette::miette!("cannot start the simulated rovers: {e}"))?;
    let programs = format!("tcp:127.0.0.1:{}", free_port()?);
    let mut gateway = match Gateway::start(flight, fleet.client_address(), programs) {
        Ok(Ok(gateway)) => gateway,
        Ok(Err(outcome)) => {
            fleet.stop();
            return Ok(outcome);
        }
        Err(e) => {
            fleet.stop();
            return Err(e);
        }
    };
    let vehicles = gateway.vehicles.clone();
    let started = Instant::now();
    let give_up = started + Duration::from_secs_f64(args.timeout.max(1.0));
    let mut watch = Watch {
        faults_seen: vec![0; ROVERS.len()],
        inside: vec![false; ROVERS.len()],
        armed_once: vec![false; ROVERS.len()],
        ..Watch::default()
    };
    let mut settle = Settle::new(3.0, flight.speed);
    while Instant::now() < give_up {
        gateway.show(Duration::from_millis(50));
        let all = fleet.states();
        look(&mut watch, &all, flight, &fleet, &vehicles);
        // Over once every rover has driven and is holding still (its route
        // ended, or the team stopped), and the nets have had a few seconds.
        let over = watch.armed_once.iter().all(|a| *a)
            && all
                .iter()
                .all(|(_, s)| s.mode == "HOLD" && s.groundspeed < 0.2);
        if settle.done(over, Instant::now()) || gateway.finished() {
            break;
        }
    }
    let timed_out = Instant::now() >= give_up;
    let log = gateway.stop();
    let all = fleet.states();
    fleet.stop();
    let log = log?;
    summary(
        &all,
        &watch,
        &log,
        &vehicles,
        &args.record,
        started.elapsed(),
        timed_out,
    );
    Ok(if timed_out || watch.both_inside > 0 {
        Outcome::Failed
    } else {
        Outcome::Success
    })
}

/// One look at the rovers: faults injected, the bottleneck entered and
/// left, the `blocked` scenario's fault.
fn look(
    watch: &mut Watch,
    all: &[(u8, SimState)],
    flight: &Flight,
    fleet: &Fleet,
    vehicles: &[(String, u8)],
) {
    let live = !flight.args.json;
    watch.looks += 1;
    let mut inside_now = 0;
    for (i, rover) in ROVERS.iter().enumerate() {
        let Some((_, s)) = all.iter().find(|(sys, _)| *sys == rover.system) else {
            continue;
        };
        let who = name(vehicles, rover.system);
        watch.armed_once[i] |= s.armed;
        for f in s.faults.iter().skip(watch.faults_seen[i]) {
            if live {
                let what = if f.cleared {
                    "cleared from"
                } else {
                    "injected into"
                };
                show!("{:>8.1}s  !! {what} {who}: {:?}", f.time_s, f.fault);
            }
        }
        watch.faults_seen[i] = s.faults.len();
        let inside = in_bottleneck(s);
        if inside != watch.inside[i] && live {
            let verb = if inside { "enters" } else { "leaves" };
            show!("{:>8.1}s  ** {who} {verb} the bottleneck", s.time_s);
        }
        watch.inside[i] = inside;
        if inside {
            inside_now += 1;
            if flight.scenario == Scenario::Blocked && watch.stuck.is_none() {
                watch.stuck = Some(rover.system);
                fleet.inject_for(rover.system, Fault::Stuck, STUCK_FOR_S);
            }
        }
    }
    if inside_now > 1 {
        watch.both_inside += 1;
        if live {
            show!("          !! both rovers in the bottleneck");
        }
    }
}

fn summary(
    all: &[(u8, SimState)],
    watch: &Watch,
    log: &Log,
    vehicles: &[(String, u8)],
    record: &Path,
    wall: Duration,
    timed_out: bool,
) {
    show!();
    show!("— drive summary —");
    if timed_out {
        show!(
            "the rovers did not end in time: stopped after {:.0} s of wall time",
            wall.as_secs_f64()
        );
    }
    let time = all.iter().map(|(_, s)| s.time_s).fold(0.0, f64::max);
    show!(
        "{time:.0} s of driving simulated in {:.0} s",
        wall.as_secs_f64()
    );
    for rover in &ROVERS {
        let Some((_, s)) = all.iter().find(|(sys, _)| *sys == rover.system) else {
            continue;
        };
        let (n, e) = at(s);
        let goal = (n - rover.goal.0).hypot(e - rover.goal.1) < 3.0;
        show!(
            "{}: {} at {n:.1} m north, {e:.1} m east{}, {}, {}; faults injected: {}",
            name(vehicles, rover.system),
            if goal { "at its goal" } else { "stopped" },
            if watch.stuck == Some(rover.system) {
                " (was stuck in the bottleneck)"
            } else {
                ""
            },
            s.mode,
            if s.armed { "armed" } else { "disarmed" },
            s.faults.iter().filter(|f| !f.cleared).count()
        );
    }
    show!(
        "the bottleneck: {} looks at both rovers, {} with both inside",
        watch.looks,
        watch.both_inside
    );
    show!("{}", log.counts());
    show!(
        "recorded to {} (petrel replay {} PROJECT --check-against)",
        record.display(),
        record.display()
    );
}
