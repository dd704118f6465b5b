//! examples/ugv-bottleneck's two simulated rovers (sitl-tests' `Fleet`, in
//! this process) and the real `petrel run` supervising them (PLN started by
//! the gateway from project.toml's `run`); the labyrinth's geometry to
//! assert on the simulated positions. A module of the `it` binary
//! (`ugv_bottleneck`, `mirror_team`) and of `browser` (`monitor_team`),
//! each using a part; uses the binary's `flight` (tests/scenarios/flight.rs).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::flight::{free_port, free_udp_port, petrel_run_project, Running};
use crate::scratch::Scratch;
use sitl_tests::geo::{offset, Home};
use sitl_tests::{BootTimeline, Fleet, SimConfig, SimState};

/// Simulated seconds per wall second (the simulator's and the gateway's).
pub const SPEED: f64 = 10.0;

pub fn project() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/ugv-bottleneck")
}

/// The labyrinth's origin: SITL's home, where pln.py measures from.
pub fn origin() -> Home {
    Home::default()
}

/// A rover of system `system` parked `north`, `east` metres from the origin.
pub fn rover(system: u8, north: f64, east: f64) -> SimConfig {
    let (lat, lon) = sitl_tests::geo::location(&origin(), sitl_tests::geo::V2::new(north, east));
    SimConfig {
        boot: BootTimeline::quick(),
        first_arm_refused: false,
        ..SimConfig::rover(
            system,
            Home {
                lat,
                lon,
                ..origin()
            },
        )
    }
}

/// Where a rover is, metres north and east of the labyrinth's origin.
pub fn at(s: &SimState) -> (f64, f64) {
    let v = offset(&origin(), s.lat, s.lon);
    (v.n, v.e)
}

/// Inside the bottleneck: the corridor between the gates (north 15..45,
/// east -1.5..1.5), gates excluded (a robot waits at its gate).
pub fn in_bottleneck(s: &SimState) -> bool {
    let (n, e) = at(s);
    (17.5..42.5).contains(&n) && e.abs() < 1.5
}

/// This test's turn to drive a team (held until it is dropped): two
/// simulated rovers, a gateway and PLN each take a good share of CI's two
/// cores, and a team slowed by another drive or a mirrored flight of the
/// binary misses its deadlines (`flight::turn`, shared with them).
pub fn turn() -> std::sync::MutexGuard<'static, ()> {
    crate::flight::turn()
}

/// Two rovers on one link, the gateway on the example, PLN started by it.
pub struct Team {
    pub fleet: Fleet,
    petrel: Option<Running>,
    /// Every snapshot of both rovers taken while it ran.
    pub seen: Vec<Vec<(u8, SimState)>>,
    _turn: std::sync::MutexGuard<'static, ()>,
    /// The gateway's recording's folder: after `petrel` (fields drop in
    /// order), removed once the gateway is reaped.
    scratch: Scratch,
}

/// The two rovers (R1 south-west, R2 north-east of the bottleneck) on one
/// link `listen` (`udpin` or `tcpin`, a free port), with their faults.
pub fn fleet(transport: &str, faults: &[(u8, &str)]) -> Fleet {
    fleet_at(transport, faults, SPEED)
}

/// The same, simulated `speed` times faster than real time.
pub fn fleet_at(transport: &str, faults: &[(u8, &str)], speed: f64) -> Fleet {
    let mut r1 = rover(1, 0.0, -20.0);
    let mut r2 = rover(2, 60.0, 20.0);
    for (sys, spec) in faults {
        let parsed = sitl_tests::Schedule::parse(&[*spec]).expect("a fault");
        let cfg = if *sys == 1 { &mut r1 } else { &mut r2 };
        cfg.faults.entries.extend(parsed.entries);
    }
    let port = if transport == "tcpin" {
        free_port()
    } else {
        free_udp_port()
    };
    Fleet::start(
        &format!("{transport}:127.0.0.1:{port}"),
        speed,
        vec![r1, r2],
    )
    .expect("the fleet starts")
}

impl Team {
    /// Two rovers on one UDP link, the gateway on the example, PLN started
    /// by it.
    pub fn start(name: &str, faults: &[(u8, &str)]) -> Team {
        Team::start_at(name, faults, &[], SPEED)
    }

    /// The same, `petrel run` given `extra` arguments, `speed` simulated
    /// seconds per wall second.
    pub fn start_at(name: &str, faults: &[(u8, &str)], extra: &[&str], speed: f64) -> Team {
        let turn = turn();
        let fleet = fleet_at("udpin", faults, speed);
        let link = fleet.client_address();
        Team::started(name, fleet, &link, extra, speed, turn)
    }

    /// `petrel run` on the example over `mavlink` (the fleet's address, or
    /// a router's in front of it), with `extra` arguments.
    pub fn run(name: &str, fleet: Fleet, mavlink: &str, extra: &[&str]) -> Team {
        Team::run_at(name, fleet, mavlink, extra, SPEED)
    }

    /// The same, the gateway's clock `speed` times the wall (the fleet's).
    pub fn run_at(name: &str, fleet: Fleet, mavlink: &str, extra: &[&str], speed: f64) -> Team {
        Team::started(name, fleet, mavlink, extra, speed, turn())
    }

    fn started(
        name: &str,
        fleet: Fleet,
        mavlink: &str,
        extra: &[&str],
        speed: f64,
        turn: std::sync::MutexGuard<'static, ()>,
    ) -> Team {
        let scratch = Scratch::new(name);
        let programs = format!("tcp:127.0.0.1:{}", free_port());
        let child = petrel_run_project(
            &project(),
            mavlink,
            &programs,
            speed,
            &scratch.join("flight.rec"),
            Duration::from_secs(600),
            extra,
        );
        Team {
            fleet,
            petrel: Some(Running::new(child)),
            seen: Vec::new(),
            _turn: turn,
            scratch,
        }
    }

    /// Runs until `done` holds on both rovers (or `wall` passes), checking
    /// at every snapshot that they are never both in the bottleneck.
    pub fn run_until(&mut self, wall: Duration, done: impl Fn(&[(u8, SimState)]) -> bool) -> bool {
        let end = Instant::now() + wall;
        while Instant::now() < end {
            let all = self.fleet.states();
            let inside: Vec<u8> = all
                .iter()
                .filter(|(_, s)| in_bottleneck(s))
                .map(|(sys, _)| *sys)
                .collect();
            assert!(inside.len() < 2, "both rovers in the bottleneck: {all:?}");
            let ok = done(&all);
            self.seen.push(all);
            if ok {
                return true;
            }
            if self.petrel.as_mut().is_none_or(Running::exited) {
                return false; // it refused the project, or died
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        false
    }

    /// Whether `petrel run` has exited by itself.
    pub fn exited(&mut self) -> bool {
        self.petrel.as_mut().is_none_or(Running::exited)
    }

    /// Stops the gateway and the rovers: what the gateway printed (stdout,
    /// stderr) and the folder of its recording, to hold until the
    /// assertions are done (a failed test leaves it to read).
    pub fn stop(mut self) -> (String, String, Scratch) {
        let (out, err, _) = self.petrel.take().map(Running::stop).unwrap_or_default();
        self.fleet.stop();
        (out, err, self.scratch)
    }
}

pub fn near(s: &SimState, n: f64, e: f64) -> bool {
    let (sn, se) = at(s);
    (sn - n).hypot(se - e) < 3.0
}

pub fn state(all: &[(u8, SimState)], sys: u8) -> &SimState {
    &all.iter().find(|(s, _)| *s == sys).expect("that rover").1
}
