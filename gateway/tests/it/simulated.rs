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
use petrel_core::mirror::station::{Config as StationConfig, Output, Station};
use petrel_core::mirror::tunnel::Tunnel;
use petrel_core::mirror::{Unread, MIRROR_SYSTEM};
use petrel_core::onboard::{crew, DownlinkConfig, Onboard, Transmit};
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

/// The example's project as `petrel run` loads it: its profile layer (or
/// the one `--profile` gives), its `[gateway]` table.
fn load(
    dir: &Path,
    given_profile: Option<&str>,
) -> (
    std::sync::Arc<Project>,
    Layers,
    elaboration::Profile,
    VehicleConfig,
) {
    let setting = petrel_core::project::gateway_setting(dir, "profile").expect("project.toml");
    let layers = Layers::pick(given_profile, Some((dir, setting.as_deref())), "ardupilot")
        .expect("the profile's layers");
    let profile = layers.load().expect("the profile loads");
    let project = petrel_core::project::load_with(dir, &petrel_core::project::catalog(&profile))
        .expect("the project loads");
    let text = std::fs::read_to_string(dir.join("project.toml")).expect("project.toml");
    let vehicle =
        VehicleConfig::from_project_toml("project.toml", &text).expect("its [gateway] table");
    (project, layers, profile, vehicle)
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

/// The radio between the vehicle and the ground mirror: every frame, both
/// ways, lost `per_mille` times in a thousand (seeded), and all of them
/// during the `bursts` (simulated seconds).
///
/// The vehicle's side routes as ArduPilot does (`MAVLink_routing.cpp`,
/// `tests/mirror/router.rs`): the vehicle's own telemetry goes to every
/// port, a record addressed to the mirror only where the mirror has been
/// heard. At `forget_routes_at` (simulated seconds) the routes are
/// forgotten, as by an autopilot's reboot: the records go nowhere until a
/// frame from the ground comes through again.
#[derive(Debug, Clone, Default)]
pub struct Radio {
    pub per_mille: u64,
    pub seed: u64,
    pub bursts: Vec<(f64, f64)>,
    pub forget_routes_at: Option<f64>,
    /// Frames it lost, both ways.
    pub lost: u64,
}

impl Radio {
    fn loses(&mut self, t: Micros) -> bool {
        self.seed ^= self.seed << 13;
        self.seed ^= self.seed >> 7;
        self.seed ^= self.seed << 17;
        let s = t as f64 / 1e6;
        let lost = self.seed % 1000 < self.per_mille
            || self.bursts.iter().any(|(a, b)| (*a..*b).contains(&s));
        self.lost += u64::from(lost);
        lost
    }
}

/// A flight with the ground mirror's core beside it.
pub struct Mirrored {
    pub flown: Flown,
    /// Everything the station put out, with its (simulated) time.
    pub outputs: Vec<(Micros, Output)>,
    /// Every request the station sent up (before the radio), with its time.
    pub uplink: Vec<(Micros, Vec<u8>)>,
    /// When the vehicle's routes were forgotten.
    pub forgot_at: Option<Micros>,
    pub radio: Radio,
    /// What became of the version offered, with its time.
    pub versions: Vec<(Micros, petrel_core::version::Report)>,
}

/// The ground: the station and the radio to it.
struct Ground {
    station: Station,
    radio: Radio,
    outputs: Vec<(Micros, Output)>,
    uplink: Vec<(Micros, Vec<u8>)>,
    /// The vehicle's side knows where the mirror is.
    routed: bool,
    forgot_at: Option<Micros>,
}

/// The UNIX time of the simulated flight's start (for signatures' clocks).
const UNIX: u64 = 1_780_000_000_000_000;

/// How a simulated flight of the example is flown, beyond its name,
/// length and end.
#[derive(Default)]
pub struct Setup<'a> {
    /// Faults, in sitl-tests' `--fault` syntax.
    pub faults: &'a [&'a str],
    pub injections: Vec<Injection>,
    /// The ground mirror's core beside the vehicle, through this radio.
    pub radio: Option<Radio>,
    /// The vehicle elaborates with this profile (as `petrel run --profile`
    /// gives it) while the ground keeps the project's.
    pub vehicle_profile: Option<&'a str>,
    /// A new version of the project offered in flight.
    pub version: Option<Offer>,
    /// New versions sent up from the ground mirror, in order (needs
    /// `radio`).
    pub push: Vec<Push>,
}

/// A new version sent up from the ground, as `petrel mirror --push DIR
/// --operator-key KEY --push-rate BYTES` sends it: at `at_s` simulated
/// seconds, `bytes_per_s` of the radio's uplink, signed with the operator
/// key both ends hold.
pub struct Push {
    pub at_s: f64,
    pub dir: std::path::PathBuf,
    pub bytes_per_s: u64,
    /// Each proof answered this long after it was asked for.
    pub proof_s: f64,
}

/// The operator key of the flights that push a version.
fn operator_key() -> petrel_core::signing::Key {
    petrel_core::signing::Key::new([42; 32])
}

/// A new version of the project offered in flight, as `petrel reload`
/// offers it: loaded from `dir` at `at_s` simulated seconds, each of its
/// proofs answered `proof_s` simulated seconds after it was asked for
/// (the state may move meanwhile).
pub struct Offer {
    pub at_s: f64,
    pub dir: std::path::PathBuf,
    pub proof_s: f64,
    /// When the ground mirror is given the version (its folder read again
    /// on SIGHUP), in simulated seconds; `None`: never.
    pub ground_at_s: Option<f64>,
}

/// Flies the example with `faults` (sitl-tests `--fault` syntax) until
/// `done` holds of the simulated vehicle (then 3 simulated seconds more
/// for the nets to finish), at most `max_sim_s` simulated seconds.
pub fn fly(
    name: &str,
    faults: &[&str],
    injections: Vec<Injection>,
    max_sim_s: f64,
    done: impl Fn(&SimState) -> bool,
) -> Flown {
    let setup = Setup {
        faults,
        injections,
        ..Setup::default()
    };
    fly_with(name, setup, max_sim_s, done).flown
}

/// [`fly`] with the downlink on and the ground mirror's core (what
/// `petrel mirror` drives) hearing the vehicle's telemetry and the
/// downlink through `radio`, its requests going up through it too.
pub fn fly_mirrored(
    name: &str,
    faults: &[&str],
    radio: Radio,
    max_sim_s: f64,
    done: impl Fn(&SimState) -> bool,
) -> Mirrored {
    let setup = Setup {
        faults,
        radio: Some(radio),
        ..Setup::default()
    };
    fly_with(name, setup, max_sim_s, done)
}

/// [`fly_mirrored`] with the vehicle elaborating with the profile
/// `vehicle_profile` (as `petrel run --profile` gives it) while the ground
/// keeps the project's.
pub fn fly_mirrored_profiled(
    name: &str,
    faults: &[&str],
    radio: Radio,
    max_sim_s: f64,
    done: impl Fn(&SimState) -> bool,
    vehicle_profile: &str,
) -> Mirrored {
    let setup = Setup {
        faults,
        radio: Some(radio),
        vehicle_profile: Some(vehicle_profile),
        ..Setup::default()
    };
    fly_with(name, setup, max_sim_s, done)
}

/// A project's lanes as `petrel run` makes them.
fn lanes_of(
    project: &std::sync::Arc<Project>,
    dir: &Path,
    layers: &Layers,
    profile: &elaboration::Profile,
) -> Vec<petrel_core::supervisor::Lane> {
    petrel_core::team::lanes(
        project,
        dir,
        profile,
        petrel_core::team::family(&layers.layers),
        &elaboration::Config::default(),
    )
    .expect("the lanes")
}

pub fn fly_with(
    name: &str,
    setup: Setup,
    max_sim_s: f64,
    done: impl Fn(&SimState) -> bool,
) -> Mirrored {
    let Setup {
        faults,
        mut injections,
        radio,
        vehicle_profile,
        version,
        push,
    } = setup;
    let mut pushed = 0;
    let mut signer = petrel_core::signing::Signer::new(operator_key(), 0, None);
    let started = Instant::now();
    let scratch = Scratch::new(&format!("simulated-{name}"));
    let recording = scratch.join("flight.mcap");
    let dir = project();
    let (project, layers, profile, vehicle) = load(&dir, vehicle_profile);
    let lanes = lanes_of(&project, &dir, &layers, &profile);
    // The ground elaborates with the project's own profile.
    let ground_lanes = match vehicle_profile {
        None => lanes.clone(),
        Some(_) => {
            let (_, layers, profile, _) = load(&dir, None);
            lanes_of(&project, &dir, &layers, &profile)
        }
    };
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
    let downlink = radio.as_ref().map(|_| DownlinkConfig {
        session: 1,
        mirror: MIRROR_SYSTEM,
        unread: Unread::of(&lanes),
    });
    let mut ground = radio.map(|radio| Ground {
        station: Station::new(StationConfig {
            project: project.clone(),
            system: MIRROR_SYSTEM,
            identity: (MIRROR_SYSTEM, 190),
            lanes: ground_lanes,
            signing: None,
            dialog: false,
            record: false,
        }),
        radio,
        outputs: Vec::new(),
        uplink: Vec::new(),
        routed: true,
        forgot_at: None,
    });
    let (supervisor, start) = Supervisor::start_lanes(project.clone(), lanes, 0);
    let operator = (!push.is_empty()).then(operator_key);
    let mut core = Onboard::new(supervisor, crew, downlink, operator, true);
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
    let (mut offered, mut proofs, mut versions) = (false, Vec::new(), Vec::new());
    let mut ground_knows = false;
    // The version each step is printed with.
    let mut shown = project.clone();
    let mut t: Micros = 0;
    let mut finished_at: Option<f64> = None;
    loop {
        t += STEP_US;
        sim.advance(t);
        while let Some((header, message)) = sim.poll_transmit() {
            let bytes =
                elaboration::frame::serialize(header, mavlink::MavlinkVersion::V2, &message);
            if let Some(g) = &mut ground {
                if !g.radio.loses(t) {
                    g.station.handle_frame(t, &bytes, UNIX + t);
                }
            }
            let rx = Received {
                time_us: t,
                bytes,
                version: mavlink::MavlinkVersion::V2,
                header,
                message: Some(message),
            };
            core.handle_frame(t, 0, rx, UNIX + t);
        }
        if t >= core.poll_timeout() {
            core.handle_timeout(t);
        }
        // A version sent up from the ground: packed and pushed once; each
        // of its records goes up signed, through the radio; whole on
        // board, it is unpacked and loaded as `run` does (no pre-flight
        // check here: the proof follows).
        if let Some(g) = &mut ground {
            if let Some(p) = push.get(pushed).filter(|p| t as f64 >= p.at_s * 1e6) {
                pushed += 1;
                let (project, files) = petrel_core::project::load_read(
                    &p.dir,
                    &petrel_core::project::catalog(&profile),
                )
                .expect("the version loads");
                let bytes = gateway::upload::pack(&files).expect("it packs");
                let version = std::sync::Arc::new(petrel_core::version::Version {
                    number: 0,
                    project,
                    files,
                });
                let config = petrel_core::mirror::upload::Config {
                    bytes_per_s: p.bytes_per_s,
                    ..Default::default()
                };
                g.station
                    .push(t, pushed as u64, bytes, version, config)
                    .expect("one push at a time");
            }
            while let Some((to, signed)) = g.station.poll_signed(t) {
                let tunnel = Tunnel::petrel(to, signed.bytes().to_vec());
                let header = mavlink::MavHeader {
                    system_id: u32::from(MIRROR_SYSTEM),
                    component_id: 190,
                    sequence: 0,
                };
                let raw = signer.sign_data(header, &tunnel, UNIX + t);
                let bytes = raw.raw_bytes().to_vec();
                g.uplink.push((t, bytes.clone()));
                if g.radio.loses(t) {
                    continue;
                }
                g.routed = true;
                let rx = Received {
                    time_us: t,
                    bytes,
                    version: mavlink::MavlinkVersion::V2,
                    header,
                    message: None,
                };
                core.handle_frame(t, 0, rx, UNIX + t);
            }
        }
        while let Some((upload, bytes)) = core.poll_upload() {
            match gateway::upload::unpack(&bytes).and_then(|files| {
                let sources: std::collections::BTreeMap<String, String> =
                    files.iter().cloned().collect();
                petrel_mission::load(&sources, Some(&petrel_core::project::catalog(&profile)))
                    .map(|p| (std::sync::Arc::new(p), files))
                    .map_err(|e| format!("{e:?}"))
            }) {
                Ok((project, files)) => core.offer_uploaded(upload, project, files),
                Err(why) => core.upload_refused(upload, &why),
            }
        }
        // A new version, as `petrel reload` offers it: loaded, then each
        // proof answered after a while (the state may move meanwhile).
        if let Some(offer) = version
            .as_ref()
            .filter(|o| !offered && t as f64 >= o.at_s * 1e6)
        {
            offered = true;
            let (new, files) = petrel_core::project::load_read(
                &offer.dir,
                &petrel_core::project::catalog(&profile),
            )
            .expect("the new version loads");
            core.offer_version(new, files);
        }
        while let Some(proof) = core.poll_proof() {
            // A version's proof answered after its offer's delay (a pushed
            // version's: a second).
            let delay = version
                .as_ref()
                .map(|o| o.proof_s)
                .or(push.first().map(|p| p.proof_s))
                .unwrap_or(1.0);
            let due = t + (delay * 1e6) as Micros;
            proofs.push((due, proof));
        }
        while let Some(i) = proofs.iter().position(|(due, _)| *due <= t) {
            let (_, proof) = proofs.remove(i);
            core.handle_proved(t, proof.run());
        }
        while let Some(report) = core.poll_version() {
            versions.push((t, report));
        }
        if let (Some(g), Some(offer)) = (&mut ground, &version) {
            if !ground_knows && offer.ground_at_s.is_some_and(|at| t as f64 >= at * 1e6) {
                ground_knows = true;
                let (project, files) = petrel_core::project::load_read(
                    &offer.dir,
                    &petrel_core::project::catalog(&profile),
                )
                .expect("the new version loads");
                g.station
                    .know(std::sync::Arc::new(petrel_core::version::Version {
                        number: 0,
                        project,
                        files,
                    }));
            }
        }
        if let Some(g) = &mut ground {
            let forget = g.radio.forget_routes_at.map(|s| (s * 1e6) as Micros);
            if g.forgot_at.is_none() && forget.is_some_and(|at| t >= at) {
                g.routed = false;
                g.forgot_at = Some(t);
            }
            if t.is_multiple_of(100_000) {
                g.station.handle_tick(t);
            }
            // What goes up from the ground, through the radio.
            while let Some((to, request)) = g.station.poll_transmit() {
                g.uplink.push((t, request.bytes().to_vec()));
                if g.radio.loses(t) {
                    continue;
                }
                // Heard: the vehicle's side knows the mirror's route again.
                g.routed = true;
                let rx = Received {
                    time_us: t,
                    bytes: Tunnel::petrel(to, request.bytes().to_vec())
                        .unsigned_frame((MIRROR_SYSTEM, 190), 0),
                    version: mavlink::MavlinkVersion::V2,
                    header: mavlink::MavHeader {
                        system_id: u32::from(MIRROR_SYSTEM),
                        component_id: 190,
                        sequence: 0,
                    },
                    message: None,
                };
                core.handle_frame(t, 0, rx, UNIX + t);
            }
        }
        // Commands to the vehicle, and calls to DEC, answered at once (DEC
        // answers within a millisecond on loopback), until both are quiet.
        loop {
            let mut quiet = true;
            while let Some(tx) = core.poll_transmit(t) {
                quiet = false;
                send(&mut sim, &mut ground, t, tx);
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
            if let petrel_core::onboard::Input::Version(v) = &s.input {
                shown = v.project.clone();
                lines.push(json!({"input": "version", "version": v.number}));
            }
            timeline(&shown, &s.step, &mut lines);
            let digest = s.digest.unwrap_or_else(|| core.player().digest());
            recorder.record_on(&s.input.as_supervisor(), None, s.step, digest);
        }
        core.publish(t);
        while let Some(tx) = core.poll_transmit(t) {
            send(&mut sim, &mut ground, t, tx);
        }
        if let Some(g) = &mut ground {
            while let Some(o) = g.station.poll_output() {
                g.outputs.push((t, o));
            }
        }
        let state = sim.state();
        let ended = crate::flight::over(
            &state,
            &mut injections,
            |f| sim.inject(f),
            &done,
            &mut finished_at,
        );
        if ended || state.time_s > max_sim_s {
            break;
        }
    }
    recorder.finish().expect("the recording ends");
    let flown = Flown {
        state: sim.state(),
        timeline: lines,
        stderr: String::new(),
        recording,
        scratch,
        wall: started.elapsed(),
    };
    match ground {
        None => Mirrored {
            flown,
            outputs: Vec::new(),
            uplink: Vec::new(),
            forgot_at: None,
            radio: Radio::default(),
            versions,
        },
        Some(g) => Mirrored {
            flown,
            outputs: g.outputs,
            uplink: g.uplink,
            forgot_at: g.forgot_at,
            radio: g.radio,
            versions,
        },
    }
}

/// A frame the onboard core sends: a command to the vehicle, or a
/// downlink record to the ground through the radio.
fn send(sim: &mut Vehicle, ground: &mut Option<Ground>, t: Micros, tx: Transmit) {
    match tx {
        Transmit::Command(c) => {
            let header = mavlink::MavHeader {
                system_id: u32::from(c.from.0),
                component_id: c.from.1,
                sequence: 0,
            };
            sim.handle(t, &header, &c.message);
        }
        Transmit::Downlink { from, tunnel, .. } => {
            if let Some(g) = ground {
                // Addressed to the mirror: nowhere while its route is
                // forgotten.
                if g.routed && !g.radio.loses(t) {
                    let frame = tunnel.unsigned_frame(from, 0);
                    g.station.handle_frame(t, &frame, UNIX + t);
                }
            }
        }
    }
}
