//! The flight-test example flown in this process, in simulated time: the
//! simulated ArduPlane's core (`sitl_tests::Vehicle`), the onboard core
//! (`petrel_core::onboard::Onboard`, what `petrel run` drives) and DEC's
//! decisions (`petrel_dec::Dec`), stepped together every 10 ms of
//! simulated time: no socket, no thread, no wall clock (issue 36). A
//! flight of minutes takes a second or two of CPU, and the same flight
//! gives the same decisions on any machine, however loaded.
//!
//! The recording is written by `petrel_record`'s recorder as `petrel run`
//! writes it, and replayed by the real `petrel replay --check-against`
//! ([`Flown::replay_check`]). What only the process does (the links, the
//! program server and its protocol, the pre-flight check, the timeline's
//! printing) is flown end to end by `scenarios::nominal_mission_completes_with_every_payload`
//! and the real-firmware suites.

use std::path::Path;
use std::time::Instant;

use nets::{Effect, Micros, Outcome, Project};
use petrel_core::frame::Received;
use petrel_core::onboard::{crew, Onboard, Transmit};
use petrel_core::profile::Layers;
use petrel_core::programs::protocol::{self, Incoming};
use petrel_core::supervisor::Supervisor;
use petrel_core::vehicle::config::VehicleConfig;
use petrel_record::recorder::{Options, Recorder};
use serde_json::json;
use sitl_tests::{Schedule, SimConfig, SimState, Vehicle};

use crate::flight::{project, Flown, Injection};
use crate::scratch::Scratch;

/// The step of simulated time.
const STEP_US: Micros = 10_000;

/// The example's project as `petrel run` loads it: its profile layer,
/// its `[gateway]` table.
fn load(dir: &Path) -> (std::sync::Arc<Project>, Layers, VehicleConfig) {
    let setting = petrel_core::project::gateway_setting(dir, "profile").expect("project.toml");
    let layers = Layers::pick(None, Some((dir, setting.as_deref())), "ardupilot")
        .expect("the profile's layers");
    let profile = layers.load().expect("the profile loads");
    let project = petrel_core::project::load_with(dir, &petrel_core::project::catalog(&profile))
        .expect("the project loads");
    let text = std::fs::read_to_string(dir.join("project.toml")).expect("project.toml");
    let vehicle =
        VehicleConfig::from_project_toml("project.toml", &text).expect("its [gateway] table");
    (project, layers, vehicle)
}

/// DEC's reply to a call, as the program server hands it to the core.
fn answer(dec: &mut petrel_dec::Dec, function: &str, args: &nets::Params) -> Outcome {
    let args = match protocol::json_params(args) {
        serde_json::Value::Object(map) => map,
        _ => serde_json::Map::new(),
    };
    let line = match dec.call(function, &args) {
        Ok(params) => json!({"reply": 1, "event": "done", "params": params}),
        Err(reason) => json!({"reply": 1, "event": "failed", "params": {"reason": reason}}),
    };
    match protocol::parse(&line.to_string()) {
        Ok(Incoming::Done { params, .. }) => Outcome::Done(params),
        Ok(Incoming::Failed { reason, .. }) => Outcome::Failed(reason),
        other => panic!("DEC's reply {line} reads as {other:?}"),
    }
}

/// The timeline's JSON lines of one step, as `petrel run --json` prints
/// them: each event heard, then what it caused; then the other effects.
fn timeline(
    project: &Project,
    step: &petrel_core::supervisor::Step,
    out: &mut Vec<serde_json::Value>,
) {
    for (elaborated, effects) in &step.events {
        out.push(json!({
            "time_us": elaborated.time_us,
            "input": "event",
            "event": elaborated.event.name,
        }));
        out.extend(
            effects
                .iter()
                .map(|e| nets::player::effect_json(project, e)),
        );
    }
    out.extend(
        step.effects
            .iter()
            .map(|e| nets::player::effect_json(project, e)),
    );
}

/// Flies the example with `faults` (sitl-tests `--fault` syntax) until
/// `done` holds of the simulated vehicle (then 3 simulated seconds more
/// for the nets to finish), at most `max_sim_s` simulated seconds.
pub fn fly(
    name: &str,
    faults: &[&str],
    mut injections: Vec<Injection>,
    max_sim_s: f64,
    done: impl Fn(&SimState) -> bool,
) -> Flown {
    let started = Instant::now();
    let scratch = Scratch::new(&format!("simulated-{name}"));
    let recording = scratch.join("flight.mcap");
    let dir = project();
    let (project, layers, vehicle) = load(&dir);
    let lanes = petrel_core::team::lanes(
        &project,
        &dir,
        &layers.load().expect("the profile loads"),
        petrel_core::team::family(&layers.layers),
        &elaboration::Config::default(),
    )
    .expect("the lanes");
    let recorder = Recorder::create(
        &recording,
        project.clone(),
        Options {
            profile: layers.name.clone(),
            profile_layers: layers.layers.clone(),
            config: lanes[0].config.clone(),
            ..Options::default()
        },
    )
    .expect("the recording");
    let crew = crew(&project, &vehicle, &lanes, &[]);
    let (supervisor, start) = Supervisor::start_lanes(project.clone(), lanes, 0);
    let mut core = Onboard::new(supervisor, crew, None, None, true);
    core.start(0, &start);
    recorder.start(&start, core.player());
    let mission = petrel_dec::Mission::load(&dir.join(crate::MISSION_FILE)).expect("the mission");
    let mut dec = petrel_dec::Dec::new(mission);
    let mut sim = Vehicle::new(SimConfig {
        boot: sitl_tests::BootTimeline::quick(),
        faults: Schedule::parse(faults).expect("a valid schedule"),
        params: vec![("RTL_AUTOLAND".into(), 2.0)],
        ..SimConfig::default()
    });
    let mut lines = Vec::new();
    let mut t: Micros = 0;
    let mut finished_at: Option<f64> = None;
    loop {
        t += STEP_US;
        sim.advance(t);
        while let Some((header, message)) = sim.poll_transmit() {
            let bytes =
                elaboration::frame::serialize(header, mavlink::MavlinkVersion::V2, &message);
            let rx = Received {
                time_us: t,
                bytes,
                version: mavlink::MavlinkVersion::V2,
                header,
                message: Some(message),
            };
            core.handle_frame(t, 0, rx, 0);
        }
        if t >= core.poll_timeout() {
            core.handle_timeout(t);
        }
        // Commands to the vehicle, and calls to DEC, answered at once (DEC
        // answers within a millisecond on loopback), until both are quiet.
        loop {
            let mut quiet = true;
            while let Some(tx) = core.poll_transmit(t) {
                quiet = false;
                if let Transmit::Command(c) = tx {
                    let header = mavlink::MavHeader {
                        system_id: u32::from(c.from.0),
                        component_id: c.from.1,
                        sequence: 0,
                    };
                    sim.handle(t, &header, &c.message);
                }
            }
            while let Some(call) = core.poll_call() {
                quiet = false;
                if let Effect::Call {
                    id,
                    program,
                    function,
                    args,
                    ..
                } = call
                {
                    let function = &project.programs[program].functions[function].name;
                    let outcome = answer(&mut dec, function, &args);
                    core.handle_result(t, id, outcome);
                }
            }
            if quiet {
                break;
            }
        }
        core.settle();
        while let Some(s) = core.poll_settled() {
            timeline(&project, &s.step, &mut lines);
            let digest = s.digest.unwrap_or_else(|| core.player().digest());
            recorder.record_on(&s.input.as_supervisor(), None, s.step, digest);
        }
        let state = sim.state();
        injections.retain(|(when, fault)| {
            let now = when(&state);
            if now {
                sim.inject(fault.clone());
            }
            !now
        });
        if finished_at.is_none() && done(&state) {
            finished_at = Some(state.time_s);
        }
        if finished_at.is_some_and(|f| state.time_s > f + 3.0) || state.time_s > max_sim_s {
            break;
        }
    }
    recorder.finish().expect("the recording ends");
    Flown {
        state: sim.state(),
        timeline: lines,
        stderr: String::new(),
        recording,
        scratch,
        wall: started.elapsed(),
    }
}
