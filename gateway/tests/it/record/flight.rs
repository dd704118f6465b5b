//! A scripted flight: the SITL plane's telemetry through the Supervisor
//! with the uav-survey project, commands and program calls answered, a
//! program's own event injected — every step handed to a recorder.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use elaboration::{Config, Profile, TlogReader};
use mavlink::dialects::ardupilotmega::{MavMessage, COMMAND_LONG_DATA};
use mavlink::MavlinkVersion;
use nets::{Category, Effect, Event, Micros, Outcome, Params, Project, Value};

use super::record::recorder::{Level, Recorder};
use super::supervisor::{Input, Step, Supervisor};

pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `../shared` beside the workspace root; `None` (with the reason printed)
/// when it is absent, a failure when CI=true.
pub fn shared() -> Option<PathBuf> {
    let dir = sitl_tests::skip::shared_dir();
    if dir.join("telemetry").is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "../shared is missing beside the workspace root, and CI=true"
    );
    sitl_tests::skip::skip(&format!(
        "{} is missing (../shared beside the workspace root)",
        dir.join("telemetry").display()
    ));
    None
}

pub const TLOG: &str = "telemetry/SITL_arduplane-4.7.0dev_auto_mission_land.tlog";

pub fn tlog() -> Option<Vec<u8>> {
    let path = shared()?.join(TLOG);
    Some(std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
}

pub fn project() -> Arc<Project> {
    let profile = Profile::builtin("ardupilot").expect("the built-in profile");
    super::project::load_with(
        &root().join("examples/uav-survey"),
        &super::project::catalog(&profile),
    )
    .expect("the example project loads")
}

/// What the flight fed the Supervisor.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Fed {
    pub steps: u64,
    pub frames: u64,
    pub ticks: u64,
    pub results: u64,
    pub events: u64,
    /// Frames sent (a COMMAND_LONG per command).
    pub sent: u64,
    /// Seqs of steps fed a command's result.
    pub command_results: Vec<u64>,
    pub final_digest: String,
}

fn answer(project: &Project, effect: &Effect, waypoints: &mut u32) -> Option<(u64, Outcome)> {
    let params = |pairs: &[(&str, Value)]| -> Params {
        pairs
            .iter()
            .map(|(k, v)| ((*k).to_owned(), v.clone()))
            .collect()
    };
    match effect {
        Effect::Command { id, .. } => Some((*id, Outcome::Done(Params::new()))),
        Effect::Call {
            id,
            program,
            function,
            ..
        } => {
            let p = &project.programs[*program];
            let f = p.functions[*function].name.as_str();
            let outcome = match (p.name.as_str(), f) {
                ("DEC", "next_waypoint") => {
                    *waypoints += 1;
                    Outcome::Done(params(&[
                        ("finished", Value::Bool(*waypoints > 2)),
                        ("index", Value::Int(*waypoints as i64)),
                        ("lat", Value::Float(-35.36 + 0.001 * *waypoints as f64)),
                        ("lon", Value::Float(149.16)),
                        ("alt", Value::Int(120)),
                        ("payload", Value::Str("camera".into())),
                    ]))
                }
                ("DEC", "replan") => Outcome::Done(params(&[("waypoints", Value::Int(2))])),
                ("GUI", "home") => Outcome::Failed("GUI is not connected".into()),
                _ => Outcome::Done(Params::new()),
            };
            Some((*id, outcome))
        }
        _ => None,
    }
}

/// Elaboration ticks across gaps, at most this far apart (as replay does).
const TICK: u64 = 100_000;
/// Answers come this long after their command or call.
const DELAY: u64 = 300_000;

/// Flies the first `limit` frames of `tlog`, recording every step; with
/// `pace`, at that many times the recorded pace (else as fast as it goes).
pub fn fly(tlog: &[u8], recorder: &Recorder, limit: usize, pace: Option<f64>) -> Fed {
    let project = project();
    let profile = Profile::builtin("ardupilot").expect("profile");
    let records: Vec<_> = TlogReader::new(tlog).take(limit).collect();
    let origin = records.first().expect("frames").time_us;
    let (mut sup, start) = Supervisor::start(project.clone(), profile, Config::default(), origin);
    recorder.start(&start, sup.player());
    let mut fed = Fed::default();
    let mut answers: VecDeque<(Micros, u64, Outcome)> = VecDeque::new();
    let mut waypoints = 0;
    let mut injected = false;
    let mut last = origin;
    let mut feed = |sup: &mut Supervisor,
                    fed: &mut Fed,
                    answers: &mut VecDeque<(Micros, u64, Outcome)>,
                    time: Micros,
                    input: Input| {
        let step: Step = recorder.feed(sup, time, input.clone());
        fed.steps += 1;
        match &input {
            Input::Frame(_) => fed.frames += 1,
            Input::Tick => fed.ticks += 1,
            Input::Result { .. } => fed.results += 1,
            Input::Event(_) | Input::Answer { .. } | Input::Version(_) => fed.events += 1,
        }
        for effect in step
            .effects
            .iter()
            .chain(step.events.iter().flat_map(|(_, e)| e.iter()))
        {
            // What `run` would send and say: a COMMAND_LONG per command, a
            // protocol line per call.
            match effect {
                Effect::Command { id, .. } => {
                    let header = mavlink::MavHeader {
                        system_id: 1,
                        component_id: 191,
                        sequence: *id as u8,
                    };
                    let msg = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA::DEFAULT);
                    let bytes = elaboration::frame::serialize(header, MavlinkVersion::V2, &msg);
                    recorder.sent(time, &bytes);
                    fed.sent += 1;
                }
                Effect::Call { id, .. } => {
                    recorder.program(time, "DEC", "line_out", serde_json::json!({ "call": id }));
                }
                _ => {}
            }
            if let Some((id, outcome)) = answer(&project, effect, &mut waypoints) {
                answers.push_back((time + DELAY, id, outcome));
            }
        }
        step
    };
    let wall = std::time::Instant::now();
    for rec in &records {
        let time = rec.time_us.max(last);
        if let Some(speed) = pace {
            let due = std::time::Duration::from_secs_f64((time - origin) as f64 / 1e6 / speed);
            if let Some(wait) = due.checked_sub(wall.elapsed()) {
                std::thread::sleep(wait);
            }
        }
        let mut t = last + TICK;
        while t < time {
            feed(&mut sup, &mut fed, &mut answers, t, Input::Tick);
            t += TICK;
        }
        while answers.front().is_some_and(|a| a.0 <= time) {
            let (at, id, outcome) = answers.pop_front().expect("an answer");
            let is_command = sup
                .player()
                .state()
                .pending
                .get(&id)
                .is_some_and(|p| matches!(p.kind, nets::player::PendingKind::Command { .. }));
            let step = feed(
                &mut sup,
                &mut fed,
                &mut answers,
                at.max(last),
                Input::Result { id, outcome },
            );
            if is_command {
                fed.command_results.push(step.seq);
            }
        }
        if !injected && time > origin + 100_000_000 {
            injected = true;
            let e = Event::new("payload_failure")
                .category(Category::Mission)
                .param("component", "camera");
            feed(&mut sup, &mut fed, &mut answers, time, Input::Event(e));
            recorder.log(
                time,
                Level::Warning,
                "programs",
                "PAY reports a camera failure".into(),
            );
        }
        feed(
            &mut sup,
            &mut fed,
            &mut answers,
            time,
            Input::Frame(rec.frame.bytes()),
        );
        last = time;
    }
    fed.final_digest = sup.player().digest().to_string();
    fed
}
