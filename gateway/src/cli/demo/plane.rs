//! `petrel demo` (the default example, uav-flight-test): the simulated
//! ArduPlane, DEC and the gateway; the flight ends when the aircraft is
//! down and disarmed, or has crashed.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use sitl_tests::{Schedule, Sim, SimConfig, SimState};

use super::log::{list_or_none, Log};
use super::{free_port, Flight, Gateway, Settle, MISSION_FILE};
use crate::cli::{Outcome, VerbResult};

pub(super) fn fly(flight: &Flight) -> VerbResult {
    let args = flight.args;
    let schedule = Schedule::parse(flight.scenario.faults())
        .map_err(|e| miette::miette!("the scenario's fault schedule: {e}"))?;
    let sim = Sim::start(SimConfig {
        listen: "tcpin:127.0.0.1:0".into(),
        // GPS and EKF ready in 3 s instead of ArduPlane's 20.
        boot: sitl_tests::BootTimeline::quick(),
        speedup: flight.speed,
        faults: schedule,
        // What the example's mission needs of ArduPlane (its DO_LAND_START:
        // docs/flight-test.md), as a crew sets it.
        params: vec![("RTL_AUTOLAND".into(), 2.0)],
        ..SimConfig::default()
    })
    .map_err(|e| miette::miette!("cannot start the simulated vehicle: {e}"))?;
    let programs = format!("tcp:127.0.0.1:{}", free_port()?);
    let mut gateway = match Gateway::start(flight, sim.client_address(), programs.clone()) {
        Ok(Ok(gateway)) => gateway,
        Ok(Err(outcome)) => {
            sim.stop();
            return Ok(outcome);
        }
        Err(e) => {
            sim.stop();
            return Err(e);
        }
    };
    // DEC connects to the gateway like any program.
    let dec_stop = Arc::new(AtomicBool::new(false));
    let dec = {
        let stop = dec_stop.clone();
        let mission = flight.dir.join(MISSION_FILE);
        let address = programs.clone();
        std::thread::Builder::new()
            .name("dec".into())
            .spawn(move || petrel_dec::serve_until(&address, &mission, stop))
    };
    let started = Instant::now();
    let give_up = started + Duration::from_secs_f64(args.timeout.max(1.0));
    let mut faults_seen = 0;
    // The nets react within milliseconds; two simulated seconds after the
    // aircraft is down and disarmed let the last heartbeat (1 Hz) arrive.
    let mut settle = Settle::new(2.0, flight.speed);
    while dec.is_ok() && Instant::now() < give_up {
        gateway.show(Duration::from_millis(100));
        let state = sim.state();
        for f in state.faults.iter().skip(faults_seen) {
            if !args.json {
                let what = if f.cleared { "cleared" } else { "injected" };
                show!("{:>8.1}s  !! {what}: {:?}", f.time_s, f.fault);
            }
        }
        faults_seen = state.faults.len();
        // The flight is over once the aircraft is down and disarmed (or has
        // crashed), and the nets have had a moment to finish.
        let over = (state.landed && !state.armed) || state.crashed;
        if settle.done(over, Instant::now()) || gateway.finished() {
            break;
        }
    }
    let timed_out = Instant::now() >= give_up;
    let log = gateway.stop();
    dec_stop.store(true, Ordering::Relaxed);
    let dec = dec.map(|thread| thread.join());
    let state = sim.state();
    sim.stop();
    let log = log?;
    if let Err(e) = dec {
        return Err(miette::miette!("cannot start DEC: {e}"));
    }
    summary(&state, &log, &args.record, started.elapsed(), timed_out);
    Ok(if timed_out {
        Outcome::Failed
    } else {
        Outcome::Success
    })
}

fn summary(state: &SimState, log: &Log, record: &Path, wall: Duration, timed_out: bool) {
    show!();
    show!("— flight summary —");
    if timed_out {
        show!(
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
    show!(
        "{:.0} s of flight time simulated in {:.0} s; the aircraft {end} at {:.6}, {:.6}, {}",
        state.time_s,
        wall.as_secs_f64(),
        state.lat,
        state.lon,
        if state.armed { "armed" } else { "disarmed" }
    );
    let reached: Vec<String> = state.reached.iter().map(|r| r.seq.to_string()).collect();
    show!("mission items reached: {}", list_or_none(&reached));
    show!(
        "camera events: {}; payload actions: {}; faults injected: {}",
        state.camera.len(),
        state.payload_actions.len(),
        state.faults.iter().filter(|f| !f.cleared).count()
    );
    show!("{}", log.counts());
    show!(
        "recorded to {} (petrel replay {} PROJECT --check-against)",
        record.display(),
        record.display()
    );
}
