//! `petrel run PROJECT`: the gateway on board. Frames from the MAVLink link
//! go through elaboration to the player; the player's commands go to the
//! vehicle, its calls to the software programs, and their results come back
//! to it. Prints the timeline as it happens (`--json`: JSON lines).
//!
//! A team project (`[[vehicle]]`) is supervised whole: each vehicle's link
//! opened once however many share it, one elaborator and one commander per
//! vehicle, one player (docs/multi-vehicle.md, "A team").
//!
//! It refuses a project that fails `petrel check` unless `--unchecked`.
//! SIGINT and SIGTERM stop it cleanly: programs are stopped, and a mission
//! upload under way is given a bounded time to finish.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use elaboration::Profile;
use mavlink::dialects::ardupilotmega::{MavAutopilot, MavMessage, MavType};
use nets::{Effect, Micros, Project};
use serde_json::json;
use tokio::sync::mpsc;

use super::timeline::Timeline;
use super::{Outcome, VerbResult};
use crate::clock::Clock;
use crate::link::{Link, LinkReader, LinkWriter, Received};
use crate::mirror::dialog::AnswerGate;
use crate::mirror::publisher::{Config as PublisherConfig, Publisher};
use crate::mirror::tunnel::{Tunnel, PAYLOAD_TYPE};
use crate::preflight::Preflight;
use crate::programs::server::{Direction, ProgramInput, Programs};
use crate::record::recorder::{Options as RecordOptions, Recorder};
use crate::supervisor::{Input, Step, Supervisor};
use crate::vehicle::commander::Commander;
use crate::vehicle::config::VehicleConfig;
use crate::vehicle::crew::{Crew, Member};

#[derive(clap::Args)]
pub struct Args {
    /// The project folder (holding project.toml).
    pub project: PathBuf,
    /// The MAVLink link (rust-mavlink address: udpin:, udpout:, tcpout:,
    /// tcpin:, serial:PORT:BAUD) [default: `[gateway] mavlink` in project.toml].
    #[arg(long, value_name = "ADDRESS")]
    pub mavlink: Option<String>,
    /// Elaboration profile: ardupilot, px4 or a FILE.toml extending the
    /// autopilot's built-in one [default: `[gateway] profile`, else the
    /// autopilot's, from its first HEARTBEAT].
    #[arg(long)]
    pub profile: Option<String>,
    /// Run a project that fails `petrel check`.
    #[arg(long)]
    pub unchecked: bool,
    /// Explore the project before flying even if the same nets, profile
    /// and Petrel held before (the pre-flight check is otherwise
    /// remembered in the user's cache directory).
    #[arg(long, conflicts_with = "unchecked")]
    pub recheck: bool,
    /// Run the gateway's clock this many times faster than the wall, for a
    /// simulated vehicle running faster than real time: frame times, the
    /// nets' timers, elaboration timeouts and command timeouts all follow
    /// it (program call timeouts stay in wall-clock time). Never in flight.
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0)]
    pub time_scale: f64,
    /// Stop after this many seconds of wall-clock time (tests, demonstrations).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Print the timeline as JSON lines.
    #[arg(long)]
    pub json: bool,
    /// Record the flight to this MCAP file [default: recordings/petrel-<UTC
    /// date and time>.mcap].
    #[arg(long, value_name = "FILE", conflicts_with = "no_record")]
    pub record: Option<PathBuf>,
    /// Do not record.
    #[arg(long)]
    pub no_record: bool,
    /// Where programs connect: tcp:HOST:PORT or unix:PATH [default:
    /// `[gateway] programs`, else tcp:127.0.0.1:5790].
    #[arg(long, value_name = "ADDRESS")]
    pub programs: Option<String>,
    /// The token programs must give in their hello (a file readable by its
    /// owner only) [default: `[gateway] programs_token`]; required to
    /// listen for programs anywhere but loopback.
    #[arg(long, value_name = "FILE")]
    pub programs_token: Option<PathBuf>,
    /// Sign every frame sent to the vehicle with this MAVLink 2 signing key
    /// (a file of 32 bytes or 64 hex digits, readable by its owner only);
    /// frames from the vehicle with a bad signature are dropped.
    #[arg(long, value_name = "FILE")]
    pub signing_key: Option<PathBuf>,
    /// Drop unsigned frames from the vehicle too (needs --signing-key).
    #[arg(long, requires = "signing_key")]
    pub require_signed: bool,
    /// Our link id in the signatures.
    #[arg(long, value_name = "ID", default_value_t = 0, requires = "signing_key")]
    pub signing_link_id: u8,
    /// Where the signing timestamp persists across restarts [default: the
    /// key file's path with `.timestamp` appended].
    #[arg(long, value_name = "FILE", requires = "signing_key")]
    pub signing_timestamp: Option<PathBuf>,
    /// Publish the downlink for `petrel mirror` (docs/mirror.md): the
    /// nets' inputs, step counter and digest in MAVLink TUNNEL messages to
    /// the mirror's system id [default: `[gateway] downlink`, else off].
    #[arg(long)]
    pub downlink: bool,
    /// The mirror's MAVLink system id, which the downlink is addressed to
    /// [default: `[gateway] mirror_system`, else 245].
    #[arg(long, value_name = "ID")]
    pub mirror_system: Option<u8>,
    /// The operator key (32 bytes or 64 hex digits, readable by its owner
    /// only; the same file as `petrel mirror --operator-key`): answers to
    /// the nets' `ask` are delivered only when signed with it
    /// (docs/mirror.md, "Operator dialog"). Without it every answer is
    /// rejected.
    #[arg(long, value_name = "FILE")]
    pub operator_key: Option<PathBuf>,
    /// Serve the web monitor (docs/monitor.md) on ADDRESS:PORT, or on
    /// 127.0.0.1:PORT given a port alone. Read-only.
    #[arg(long, value_name = "ADDR:PORT")]
    pub http: Option<String>,
}

/// `recordings/NAME-YYYYMMDD-HHMMSS.mcap` for the current UTC time.
pub(super) fn dated_recording(name: &str) -> PathBuf {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    PathBuf::from("recordings").join(format!(
        "{name}-{year:04}{month:02}{day:02}-{:02}{:02}{:02}.mcap",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    ))
}

/// Elaboration timeouts and link loss are evaluated at least this often when
/// no frame arrives.
const TICK: Micros = 100_000;
/// Telemetry rate asked for every message the profile reads.
const TELEMETRY_HZ: f32 = 4.0;
/// On shutdown, how long a mission upload under way may take to finish.
const UPLOAD_GRACE: Duration = Duration::from_secs(3);
/// How often the signing timestamp is persisted (well within
/// `signing::PERSIST_MARGIN`).
const TIMESTAMP_PERSIST: Duration = Duration::from_secs(10);
/// How long the vehicle may stay silent before `run` says so on stderr.
const SILENCE_WARNING: Duration = Duration::from_secs(5);

pub fn run(args: Args) -> VerbResult {
    match prepare(&args)? {
        Ok(setup) => fly(setup),
        Err(outcome) => Ok(outcome),
    }
}

/// Everything `run` checks and loads before it opens the link: the setup,
/// or the outcome of a refusal (a project failing `petrel check`, a bad
/// profile: already reported).
pub(crate) fn prepare(args: &Args) -> Result<Result<Setup, Outcome>, miette::Report> {
    let gateway = crate::project::gateway_table(&args.project)?;
    let get = |key: &str| gateway.get(key).and_then(|v| v.as_str()).map(str::to_owned);
    // --profile (beside the working directory), else `[gateway] profile`
    // (beside project.toml), else ArduPilot's.
    let vehicle = VehicleConfig::from_gateway_table(&gateway)
        .map_err(|e| miette::miette!("[gateway]: {e}"))?;
    // The built-in base follows the autopilot: `[gateway] firmware` when
    // set, else the first autopilot HEARTBEAT heard (`detect`), unless the
    // profile is a built-in one by name.
    let choice = ProfileChoice {
        given: args.profile.clone(),
        setting: get("profile"),
    };
    let base = match vehicle.firmware {
        Some(elaboration::Firmware::Px4) => "px4",
        _ => "ardupilot",
    };
    let layers = choice.layers(&args.project, base)?;
    let detect = (vehicle.firmware.is_none() && !choice.named()).then_some(choice);
    let Some(profile) = layers.load() else {
        return Ok(Err(Outcome::BadInput));
    };
    let (project, files) = crate::project::load_read(&args.project, &profile.catalog())?;
    // A team's vehicles' own profiles load, or the run is refused here,
    // before any link opens (`run` builds the lanes again once the
    // autopilot is known).
    crate::team::lanes(
        &project,
        &args.project,
        &profile,
        crate::team::family(&layers.layers),
        &elaboration_config(&vehicle),
    )?;
    if !args.unchecked {
        let inputs = crate::preflight::Inputs {
            files: &files,
            layers: &layers.layers,
        };
        match crate::preflight::check_project(&project, &inputs, args.recheck) {
            Preflight::Remembered { digest } => say!(
                "pre-flight check: holds (remembered: the same nets, profile and Petrel held before, {}; --recheck explores again)",
                &digest[..12]
            ),
            Preflight::Held {
                states,
                edges,
                seconds,
            } => say!(
                "pre-flight check: holds ({states} states, {edges} steps explored in {seconds:.2} s)"
            ),
            Preflight::Failed(report) => {
                say_part!(
                    "{}",
                    super::check_project::human(&project.name, &report, 0.0)
                );
                say!(
                    "refusing to run {}: it fails `petrel check` (run it anyway with --unchecked)",
                    args.project.display()
                );
                return Ok(Err(Outcome::Failed));
            }
        }
    }
    let Some(address) = args.mavlink.clone().or_else(|| get("mavlink")) else {
        return Err(miette::miette!(
            "no MAVLink link: give --mavlink ADDRESS or `mavlink = \"udpin:0.0.0.0:14550\"` in [gateway]"
        ));
    };
    check_timing(args.duration, args.time_scale)?;
    let mut programs = crate::programs::roster::Config::from_gateway(Some(&gateway))
        .map_err(|e| miette::miette!("[gateway] programs: {e}"))?;
    if let Some(address) = &args.programs {
        programs.address = address
            .parse()
            .map_err(|e| miette::miette!("--programs {address}: {e}"))?;
    }
    // The token: --programs-token (beside the working directory), else
    // `[gateway] programs_token` (beside project.toml).
    let token_file = args
        .programs_token
        .clone()
        .or_else(|| programs.token_file.as_ref().map(|f| args.project.join(f)));
    if let Some(file) = token_file {
        let bytes =
            crate::link::signing::read_private(&file).map_err(|e| miette::miette!("{e}"))?;
        let token = String::from_utf8(bytes)
            .ok()
            .map(|t| t.trim().to_owned())
            .filter(|t| !t.is_empty())
            .ok_or_else(|| {
                miette::miette!(
                    "{}: the programs' token must be non-empty text",
                    file.display()
                )
            })?;
        programs.token = Some(token);
    }
    let downlink = (args.downlink
        || gateway
            .get("downlink")
            .and_then(|v| v.as_bool())
            .unwrap_or(false))
    .then(|| {
        args.mirror_system.or_else(|| {
            gateway
                .get("mirror_system")
                .and_then(|v| v.as_integer())
                .and_then(|v| u8::try_from(v).ok())
        })
    })
    .map(|system| system.unwrap_or(crate::mirror::MIRROR_SYSTEM));
    let record = if args.no_record {
        None
    } else {
        Some(
            args.record
                .clone()
                .unwrap_or_else(|| dated_recording("petrel")),
        )
    };
    let signing = match &args.signing_key {
        None => None,
        Some(path) => Some(crate::link::signing::Setup {
            key: crate::link::signing::Key::load(path).map_err(|e| miette::miette!("{e}"))?,
            link_id: args.signing_link_id,
            require: args.require_signed,
            timestamp_file: args.signing_timestamp.clone().unwrap_or_else(|| {
                let mut p = path.as_os_str().to_owned();
                p.push(".timestamp");
                PathBuf::from(p)
            }),
        }),
    };
    // The operator dialog (mirror::dialog): the key answers are signed with.
    let operator = match &args.operator_key {
        None => None,
        Some(path) => {
            Some(crate::link::signing::Key::load(path).map_err(|e| miette::miette!("{e}"))?)
        }
    };
    let http = match &args.http {
        Some(a) => Some(crate::monitor::parse_address(a).map_err(|e| miette::miette!("{e}"))?),
        None => None,
    };
    Ok(Ok(Setup {
        http,
        project,
        signing,
        operator,
        dir: args.project.clone(),
        profile,
        layers,
        detect,
        record,
        address,
        vehicle,
        programs,
        downlink,
        json: args.json,
        duration: args.duration.map(Duration::from_secs_f64),
        time_scale: args.time_scale,
        out: Box::new(std::io::stdout()),
        stop: None,
    }))
}

/// Persists the links' signing timestamp (the latest any used); a failure
/// is said, once per attempt, and supervision goes on.
fn persist_timestamps(file: &std::path::Path, writers: &[LinkWriter]) {
    if let Some(ts) = writers
        .iter()
        .filter_map(LinkWriter::signing_timestamp)
        .max()
    {
        if let Err(e) = crate::link::signing::write_timestamp(file, ts) {
            tracing::warn!(
                "cannot persist the signing timestamp to {}: {e}",
                file.display()
            );
        }
    }
}

/// How the profile was chosen: `--profile`, else `[gateway] profile`.
#[derive(Clone, Debug)]
pub(crate) struct ProfileChoice {
    pub given: Option<String>,
    pub setting: Option<String>,
}

impl ProfileChoice {
    /// The layers over the built-in `base` (a file extends it).
    fn layers(&self, project: &Path, base: &str) -> Result<crate::profile::Layers, miette::Report> {
        crate::profile::Layers::pick(
            self.given.as_deref(),
            Some((project, self.setting.as_deref())),
            base,
        )
    }

    /// A built-in profile named by the user: nothing to detect.
    fn named(&self) -> bool {
        let builtin = |c: &str| c == "ardupilot" || c == "px4";
        match (&self.given, &self.setting) {
            (Some(g), _) => builtin(g),
            (None, Some(s)) => builtin(s),
            (None, None) => false,
        }
    }
}

/// `--duration` and `--time-scale` (`run` and `mirror`): positive numbers.
pub(crate) fn check_timing(duration: Option<f64>, time_scale: f64) -> Result<(), miette::Report> {
    if let Some(d) = duration {
        if !(d.is_finite() && d > 0.0) {
            return Err(miette::miette!(
                "--duration must be a positive number of seconds, not {d}"
            ));
        }
    }
    if !(time_scale.is_finite() && time_scale > 0.0) {
        return Err(miette::miette!(
            "--time-scale must be a positive number, not {time_scale}"
        ));
    }
    Ok(())
}

/// Runs the gateway until its duration, a signal or `stop`.
pub(crate) fn fly(setup: Setup) -> VerbResult {
    // One thread for the link reader, the programs and the loop (two worker
    // threads measured no better: BENCHMARKS.md); the recorder writes on its
    // own thread.
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| miette::miette!("cannot start the runtime: {e}"))?;
    runtime.block_on(Gateway::run(setup))
}

/// What the gateway runs with.
pub(crate) struct Setup {
    pub project: Arc<Project>,
    /// MAVLink 2 signing on the vehicle link.
    pub signing: Option<crate::link::signing::Setup>,
    /// The operator key, for the answers to `ask` (`--operator-key`).
    pub operator: Option<crate::link::signing::Key>,
    pub dir: PathBuf,
    pub profile: Profile,
    pub layers: crate::profile::Layers,
    /// The profile's choice when its built-in base is to follow the
    /// autopilot heard first (`None`: fixed).
    pub detect: Option<ProfileChoice>,
    pub record: Option<PathBuf>,
    pub address: String,
    pub vehicle: VehicleConfig,
    pub programs: crate::programs::roster::Config,
    /// Publish the mirror's downlink to this system id.
    pub downlink: Option<u8>,
    pub json: bool,
    pub duration: Option<Duration>,
    pub time_scale: f64,
    /// Where the timeline goes (stdout for `run`).
    pub out: Box<dyn Write + Send>,
    /// Stops the gateway when notified (`petrel demo`).
    pub stop: Option<Arc<tokio::sync::Notify>>,
    /// Serve the web monitor here.
    pub http: Option<std::net::SocketAddr>,
}

struct Gateway {
    clock: Clock,
    project: Arc<Project>,
    supervisor: Supervisor,
    /// One commander per vehicle, each on its link.
    crew: Crew,
    programs: Option<Programs>,
    /// One writer per link (`team::links` order).
    writers: Vec<LinkWriter>,
    recorder: Option<Recorder>,
    downlink: Option<Downlink>,
    /// Judges the operator's answers (`None`: no `--operator-key`, every
    /// answer rejected).
    answers: Option<AnswerGate>,
    /// The web monitor: fed in `settle`, served on its own thread.
    monitor: Option<(crate::monitor::Feed, crate::monitor::Server)>,
    /// Steps carried out but not yet printed and recorded (see `feed`).
    done: Vec<Done>,
    frames: u64,
    events: u64,
    out: Timeline<std::io::BufWriter<Box<dyn Write + Send>>>,
}

/// The mirror's downlink on board.
struct Downlink {
    publisher: Publisher,
    /// The mirror's system id.
    mirror: u8,
}

/// A step carried out, waiting to be printed and recorded.
struct Done {
    input: Owned,
    step: Step,
    /// The player's time before the step.
    before: Micros,
    /// The player's digest right after the step (when recording).
    digest: Option<nets::player::Digest>,
}

/// A Supervisor input, owned.
enum Owned {
    Frame(Vec<u8>),
    Tick,
    Result { id: u64, outcome: nets::Outcome },
    Event(nets::Event),
    Answer { id: u64, choice: String },
}

impl Owned {
    fn input(&self) -> Input<'_> {
        match self {
            Owned::Frame(bytes) => Input::Frame(bytes),
            Owned::Tick => Input::Tick,
            Owned::Result { id, outcome } => Input::Result {
                id: *id,
                outcome: outcome.clone(),
            },
            Owned::Event(e) => Input::Event(e.clone()),
            Owned::Answer { id, choice } => Input::Answer {
                id: *id,
                choice: choice.clone(),
            },
        }
    }
}

impl Gateway {
    fn now(&self) -> Micros {
        self.clock.now()
    }

    /// Steps the supervisor and carries out the step's effects: commands go
    /// to the commander (sent by the next `pump`), calls to the programs.
    /// Printing and recording wait for `settle`, off the path from a frame
    /// to the command it causes; the digest is taken now, as it must be.
    fn feed(&mut self, time: Micros, input: Owned) {
        let before = self.supervisor.player().state().now;
        let step = self.supervisor.step(time, input.input());
        for e in &step.effects {
            self.effect(e);
        }
        for (_, effects) in &step.events {
            for e in effects {
                self.effect(e);
            }
        }
        let published = self.downlink.is_some()
            && (!step.events.is_empty()
                || matches!(
                    input,
                    Owned::Result { .. } | Owned::Event(_) | Owned::Answer { .. }
                ));
        let digest =
            (self.recorder.is_some() || published).then(|| self.supervisor.player().digest());
        self.done.push(Done {
            input,
            step,
            before,
            digest,
        });
    }

    /// Prints and records the steps carried out since the last call, in
    /// order, and flushes the timeline.
    fn settle(&mut self) {
        for Done {
            input,
            step,
            before,
            digest,
        } in std::mem::take(&mut self.done)
        {
            if let (Some(d), Some(digest)) = (&mut self.downlink, &digest) {
                if let Some(inputs) = crate::mirror::step_inputs(&input.input(), &step) {
                    d.publisher
                        .step(step.seq, before, step.time, inputs, digest);
                }
            }
            if let Owned::Event(event) = &input {
                let _ = self.out.event(&self.project, step.time, event, None);
            }
            let _ = self.out.effects(&self.project, &step.effects);
            for (event, effects) in &step.events {
                self.events += 1;
                let _ = self.out.event(
                    &self.project,
                    event.time_us,
                    &event.event,
                    Some(json!({"sysid": event.sysid, "compid": event.compid})),
                );
                let _ = self.out.effects(&self.project, effects);
            }
            if let Some((feed, _)) = &self.monitor {
                feed.step(&input.input(), &step, self.supervisor.player());
            }
            if let (Some(rec), Some(digest)) = (&self.recorder, digest) {
                rec.record(&input.input(), step, digest);
            }
        }
        if let Some((feed, _)) = &self.monitor {
            feed.publish();
        }
        let _ = self.out.out.flush();
    }

    async fn run(mut setup: Setup) -> VerbResult {
        let origin = Instant::now();
        let clock = Clock::new(origin, setup.time_scale);
        if clock.scale() != 1.0 {
            say!(
                "the gateway's clock runs {}× faster than the wall (--time-scale)",
                clock.scale()
            );
        }
        // The recording's times count from the gateway's origin.
        let unix_ns = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64);
        // Said once if the vehicle stays silent this long after the link
        // opens (below).
        let silent_until = Instant::now() + SILENCE_WARNING;
        // Each link once, however many vehicles share it.
        let links = crate::team::links(&setup.project, &setup.address);
        let team = !setup.project.vehicles.is_empty();
        let mut readers = Vec::new();
        let mut writers = Vec::new();
        for (address, on) in &links {
            let (mut reader, writer) = Link::open(address, clock.clone())
                .await
                .map_err(|e| miette::miette!("{e}"))?;
            if team {
                // The team's vehicles on this link; every other vehicle dropped.
                let systems = on.iter().map(|&v| setup.project.vehicles[v].system);
                reader.supervise_team(systems.collect());
            } else {
                // One vehicle: the configured one, else the first autopilot heard.
                reader.supervise(setup.vehicle.system);
            }
            if let Some(signing) = &setup.signing {
                use crate::link::signing::{read_timestamp, Signer, Verifier};
                let persisted = read_timestamp(&signing.timestamp_file);
                writer.sign(Signer::new(signing.key.clone(), signing.link_id, persisted));
                reader.verify(Verifier::new(signing.key.clone(), signing.require));
            }
            readers.push(reader);
            writers.push(writer);
        }
        let rejections: Vec<_> = readers.iter().map(LinkReader::rejections).collect();
        // Which autopilot, when the profile follows it: the frames read
        // meanwhile are fed once the supervisor runs, none lost.
        // Signals are watched from here on: a stop (systemd's SIGTERM)
        // during the wait for the autopilot still ends cleanly.
        let mut signals = Signals::new()?;
        let mut told_early = false;
        let early = match setup.detect.take() {
            None => Vec::new(),
            Some(choice) => {
                let limit = clock
                    .wall(setup.vehicle.timing.link_timeout)
                    .max(Duration::from_secs(1));
                let announce = (
                    setup
                        .project
                        .vehicles
                        .first()
                        .map(|v| v.system)
                        .or(setup.vehicle.system)
                        .unwrap_or(crate::vehicle::commander::ANNOUNCE_SYSTEM),
                    setup.vehicle.own_component(),
                );
                // The first link: the first vehicle's (all of them, but one
                // vehicle's own profile set, follow the autopilot heard).
                let (early, heard, stopped) =
                    identify(&mut readers[0], &writers[0], announce, limit, &mut signals).await;
                told_early |= stopped;
                adopt(&mut setup, &choice, heard)?;
                early
            }
        };
        // The program server listens only for a project that has programs.
        let (programs, mut inputs) = if setup.project.programs.is_empty() {
            (None, mpsc::channel(1).1)
        } else {
            let (p, i) = Programs::start(setup.project.clone(), &setup.dir, setup.programs)
                .await
                .map_err(|e| miette::miette!("{e}"))?;
            (Some(p), i)
        };
        // Each vehicle's elaboration: its profile and ids (one lane without
        // a team).
        let lanes = crate::team::lanes(
            &setup.project,
            &setup.dir,
            &setup.profile,
            crate::team::family(&setup.layers.layers),
            &elaboration_config(&setup.vehicle),
        )?;
        // The recording is created once the link and the program server
        // are open: a start that fails leaves no empty recording behind.
        let recorder = match &setup.record {
            None => None,
            Some(path) => {
                let options = RecordOptions {
                    clock_offset_ns: unix_ns,
                    profile: setup.layers.name.clone(),
                    profile_layers: setup.layers.layers.clone(),
                    config: lanes[0].config.clone(),
                    ..RecordOptions::default()
                };
                let rec = Recorder::create(path, setup.project.clone(), options)
                    .map_err(|e| miette::miette!("cannot record to {}: {e}", path.display()))?;
                say!("recording to {}", path.display());
                Some(rec)
            }
        };
        // One commander per vehicle, on its link, asking its autopilot for
        // what its profile reads.
        let configs = crate::team::commanders(&setup.project, &setup.vehicle);
        let members = configs
            .into_iter()
            .zip(&lanes)
            .enumerate()
            .map(|(v, (config, lane))| {
                let messages: Vec<(u32, f32)> = lane
                    .profile
                    .telemetry()
                    .into_iter()
                    .filter(|&id| id != 0) // HEARTBEAT always comes
                    .map(|id| (id, TELEMETRY_HZ))
                    .collect();
                let mut commander = Commander::new(config);
                commander.request_streams(&messages, 0);
                let link = links
                    .iter()
                    .position(|(_, on)| on.contains(&v))
                    .unwrap_or(0);
                Member {
                    name: lane.vehicle.clone(),
                    link,
                    commander,
                }
            })
            .collect();
        let (supervisor, start) = Supervisor::start_lanes(setup.project.clone(), lanes, 0);
        let mut gw = Gateway {
            clock,
            project: setup.project,
            supervisor,
            crew: Crew::new(members),
            programs,
            writers,
            recorder,
            downlink: setup.downlink.map(|mirror| Downlink {
                publisher: Publisher::new(session(), PublisherConfig::default(), 0),
                mirror,
            }),
            answers: setup.operator.take().map(AnswerGate::new),
            monitor: None,
            done: Vec::new(),
            frames: 0,
            events: 0,
            out: Timeline {
                out: std::io::BufWriter::new(setup.out),
                json: setup.json,
                origin: 0,
            },
        };
        if let Some(rec) = &gw.recorder {
            rec.start(&start, gw.supervisor.player());
        }
        if let Some(address) = setup.http {
            let (project, player) = (gw.project.clone(), gw.supervisor.player());
            let monitor = crate::monitor::start_live(address, project, &setup.dir, &start, player)
                .map_err(|e| miette::miette!("cannot serve the monitor on {address}: {e}"))?;
            say!("monitor: http://{}/", monitor.1.address);
            gw.monitor = Some(monitor);
        }
        for e in &start.effects {
            gw.effect(e);
        }
        let _ = gw.out.effects(&gw.project, &start.effects);
        gw.pump().await;
        gw.settle();
        for rx in early {
            gw.frame(0, rx);
            gw.pump().await;
            gw.settle();
        }
        let stop_at = setup.duration.map(|d| origin + d);
        let stop = setup.stop.clone();
        let (frames_tx, mut frames) = mpsc::channel(1024);
        // Each reader runs on its own task so that a frame is never lost to
        // a select! that picked another branch; frames come with their link.
        let several = readers.len() > 1;
        let reader_tasks: Vec<_> = readers
            .into_iter()
            .zip(links.iter().map(|(a, _)| a.clone()))
            .enumerate()
            .map(|(link, (mut reader, address))| {
                let frames_tx = frames_tx.clone();
                tokio::spawn(async move {
                    loop {
                        match reader.recv().await {
                            Ok(rx) => {
                                while let Some(notice) = reader.poll_notice() {
                                    if several {
                                        say!("{address}: {notice}");
                                    } else {
                                        say!("{notice}");
                                    }
                                }
                                if frames_tx.send((link, rx)).await.is_err() {
                                    break;
                                }
                            }
                            Err(e) => {
                                // Never spin on a link that keeps failing.
                                tracing::warn!("{e}");
                                tokio::time::sleep(Duration::from_millis(200)).await;
                            }
                        }
                    }
                })
            })
            .collect();
        drop(frames_tx);
        let mut next_tick = TICK;
        let mut refused = false;
        // Said once when the vehicle stays silent: nothing else tells a
        // user that the address, the router or the autopilot is wrong.
        let mut said_silent = vec![false; gw.crew.members().len()];
        let mut reporters: Vec<_> = rejections
            .iter()
            .map(|_| crate::link::rejections::Reporter::default())
            .collect();
        let timestamp_file = setup.signing.as_ref().map(|s| s.timestamp_file.clone());
        let mut persisted_at = Instant::now();
        loop {
            if told_early {
                break;
            }
            // Frames the signature checks dropped reach the nets as an event.
            for (reporter, rejections) in reporters.iter_mut().zip(&rejections) {
                if let Some(event) = reporter.poll(rejections, &gw.project, gw.now()) {
                    let now = gw.now();
                    gw.feed(now, Owned::Event(event));
                }
            }
            if let Some(file) = &timestamp_file {
                if persisted_at.elapsed() >= TIMESTAMP_PERSIST {
                    persisted_at = Instant::now();
                    persist_timestamps(file, &gw.writers);
                }
            }
            if Instant::now() >= silent_until {
                for (said, m) in said_silent.iter_mut().zip(gw.crew.members()) {
                    if *said || m.commander.heard() {
                        continue;
                    }
                    *said = true;
                    let (system, component) = m.commander.sender();
                    let vehicle = match &m.name {
                        Some(name) => format!("vehicle {name} not"),
                        None => "no vehicle".to_owned(),
                    };
                    say!(
                        "petrel: {vehicle} heard on {} after {} s; petrel sends its HEARTBEAT there as system {system}, component {component}. Check the address, that the router or autopilot sends telemetry to it, and the vehicle's system id.",
                        links[m.link].0,
                        SILENCE_WARNING.as_secs()
                    );
                }
            }
            let now = gw.now();
            let deadline = [
                Some(next_tick),
                gw.supervisor.next_deadline(),
                gw.crew.next_deadline(),
            ]
            .into_iter()
            .flatten()
            .min()
            .unwrap_or(next_tick);
            let sleep = tokio::time::sleep(gw.clock.wall(deadline.saturating_sub(now)));
            let until_stop = async {
                match stop_at {
                    Some(t) => tokio::time::sleep_until(t.into()).await,
                    None => std::future::pending().await,
                }
            };
            let told_to_stop = async {
                match &stop {
                    Some(n) => n.notified().await,
                    None => std::future::pending().await,
                }
            };
            tokio::select! {
                Some((link, rx)) = frames.recv() => gw.frame(link, rx),
                Some(input) = inputs.recv() => gw.program_input(input),
                _ = sleep => {
                    let now = gw.now();
                    gw.crew.tick(now);
                    if now >= next_tick {
                        next_tick = now - now % TICK + TICK;
                    }
                    gw.feed(now, Owned::Tick);
                }
                _ = signals.recv() => break,
                _ = until_stop => break,
                _ = told_to_stop => break,
            }
            gw.pump().await;
            gw.settle();
            gw.publish().await;
            if let Some((v, verdict)) = gw.crew.poll_parameters() {
                let member = &gw.crew.members()[v];
                let prefix = member
                    .name
                    .as_ref()
                    .map(|n| format!("vehicle {n}: "))
                    .unwrap_or_default();
                if !parameters_fit(&prefix, &verdict, member.commander.armed()) {
                    refused = true;
                    break;
                }
            }
        }
        // A mission upload under way gets a bounded time to finish.
        let grace = Instant::now() + UPLOAD_GRACE;
        // An interval, not a sleep made anew per turn: frames every few ms
        // would starve the commander's retries and timeouts.
        let mut ticks = tokio::time::interval(Duration::from_millis(20));
        ticks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        while gw.crew.busy() && Instant::now() < grace {
            tokio::select! {
                Some((link, rx)) = frames.recv() => {
                    if let Some(message) = &rx.message {
                        gw.crew.message(link, rx.time_us, &rx.header, message);
                    }
                }
                _ = ticks.tick() => gw.crew.tick(gw.now()),
            }
            gw.pump().await;
            gw.settle();
        }
        for task in reader_tasks {
            task.abort();
        }
        if let Some(file) = &timestamp_file {
            persist_timestamps(file, &gw.writers);
        }
        for (rejections, (address, _)) in rejections.iter().zip(&links) {
            if let Some(summary) = rejections.summary() {
                if several {
                    say!("signatures on {address}: {summary}");
                } else {
                    say!("signatures: {summary}");
                }
            }
        }
        if let Some(gate) = &gw.answers {
            let rejected: Vec<String> = gate
                .rejected()
                .iter()
                .map(|(why, n)| format!("{n} {}", why.as_str()))
                .collect();
            say!(
                "operator answers: {} delivered, rejected: {}",
                gate.delivered_count(),
                if rejected.is_empty() {
                    "none".to_owned()
                } else {
                    rejected.join(", ")
                }
            );
        }
        let Gateway {
            programs,
            supervisor,
            mut out,
            frames,
            events,
            recorder,
            ..
        } = gw;
        if let Some(programs) = programs {
            programs.shutdown().await;
        }
        if let Some(rec) = recorder {
            let dropped = rec.dropped();
            match rec.finish() {
                Ok(report) if report.dropped > 0 => say!(
                    "recorded {} steps; the recorder fell behind and dropped {} entries ({} steps): replay stops at the first",
                    report.steps, report.dropped, report.dropped_steps
                ),
                Ok(report) => say!(
                    "recorded {} steps, {} messages",
                    report.steps, report.messages
                ),
                Err(e) => say!(
                    "the recording stopped in flight ({e}); {dropped} entries were not recorded"
                ),
            }
        }
        let player = supervisor.player();
        say!(
            "stopped after {:.1} s: {frames} frames, {events} events, {} bad frames, {} calls and commands unanswered",
            origin.elapsed().as_secs_f64(),
            supervisor.bad_frames,
            player.state().pending.len()
        );
        let _ = out.end(player.state().now, &player.digest(), player.locked_out());
        let _ = out.out.flush();
        Ok(if refused {
            Outcome::Failed
        } else {
            Outcome::Success
        })
    }

    /// A frame from link `link`: to the commanders on that link, then to
    /// the supervisor.
    fn frame(&mut self, link: usize, rx: Received) {
        self.frames += 1;
        if self.crew.members().first().map(|m| m.link) == Some(link) {
            self.uplink(&rx.bytes);
        }
        if let Some(message) = &rx.message {
            self.follow_vehicle_time(&rx.header, message);
            self.crew.message(link, rx.time_us, &rx.header, message);
        }
        self.feed(rx.time_us, Owned::Frame(rx.bytes));
    }

    /// A scaled clock follows the simulated autopilot's own time
    /// (`clock::Clock::sync`); at scale 1 this does nothing.
    fn follow_vehicle_time(&self, header: &mavlink::MavHeader, message: &MavMessage) {
        if self.clock.scale() == 1.0
            || self.crew.first().and_then(Commander::target)
                != Some((header.system_id as u8, header.component_id))
        {
            return;
        }
        let boot_ms = match message {
            MavMessage::SYSTEM_TIME(m) => m.time_boot_ms,
            MavMessage::GLOBAL_POSITION_INT(m) => m.time_boot_ms,
            MavMessage::ATTITUDE(m) => m.time_boot_ms,
            _ => return,
        };
        self.clock.sync(Micros::from(boot_ms) * 1000);
    }

    fn effect(&mut self, effect: &Effect) {
        let now = self.now();
        match effect {
            Effect::Command {
                id,
                verb,
                args,
                vehicle,
                ..
            } => self.crew.command(*id, *vehicle, verb, args, now),
            Effect::Forgotten { id, .. } => {
                self.crew.forget(*id);
                if let Some(p) = &self.programs {
                    p.effect(effect);
                }
            }
            Effect::Call { .. } => {
                if let Some(p) = &self.programs {
                    p.effect(effect);
                }
            }
            _ => {}
        }
    }

    /// Sends what the commanders have to send, each on its vehicle's link
    /// (each frame recorded as sent), and hands their outcomes to the
    /// player, until they have nothing more.
    async fn pump(&mut self) {
        loop {
            let mut busy = false;
            while let Some(t) = self.crew.poll_transmit() {
                busy = true;
                let Some(writer) = self.writers.get(t.link) else {
                    continue;
                };
                match writer.send(t.from, &t.message).await {
                    Ok(bytes) => {
                        if let (Some(rec), false) = (&self.recorder, bytes.is_empty()) {
                            rec.sent(self.clock.now(), &bytes);
                        }
                    }
                    Err(e) => {
                        // Never spin on a link that keeps failing.
                        tracing::warn!("{e}");
                        tokio::time::sleep(Duration::from_millis(200)).await;
                    }
                }
            }
            if let Some((id, outcome)) = self.crew.poll_outcome() {
                busy = true;
                let now = self.now();
                self.feed(now, Owned::Result { id, outcome });
            }
            if !busy {
                break;
            }
        }
    }

    /// A frame from the mirror (a resync request) goes to the publisher.
    fn uplink(&mut self, bytes: &[u8]) {
        let me = self.crew.first().and_then(Commander::identity);
        let (Some(d), Some(me)) = (&mut self.downlink, me) else {
            return;
        };
        let Ok(frame) = elaboration::Frame::parse(bytes) else {
            return;
        };
        if let Some(t) = Tunnel::from_frame(&frame) {
            if (t.target_system, t.target_component) == me {
                if crate::mirror::dialog::is_answer(&t.payload) {
                    self.answer(bytes);
                } else {
                    d.publisher.receive(&t.payload);
                }
            }
        }
    }

    /// An operator's answer (mirror::dialog): judged by the gate, then, if
    /// let through, an input of the player like any other (published down).
    fn answer(&mut self, bytes: &[u8]) {
        let Some(gate) = &mut self.answers else {
            tracing::warn!("an operator's answer rejected: no --operator-key");
            return;
        };
        let (id, choice) = match gate.judge_bytes(bytes, crate::link::unix_us()) {
            Ok(answer) => answer,
            Err(why) => {
                tracing::warn!("an operator's answer rejected: {}", why.as_str());
                return;
            }
        };
        let now = self.now();
        self.feed(now, Owned::Answer { id, choice });
        let verdict = self
            .done
            .last()
            .and_then(|d| crate::mirror::dialog::verdict(&d.step.effects, id));
        if let (Some(gate), Some(v)) = (&mut self.answers, verdict) {
            gate.delivered(v);
            if let Err(why) = v {
                tracing::warn!("the operator's answer to #{id} refused: {}", why.as_str());
            }
        }
    }

    /// The downlink's heartbeat and snapshots when due, and every packet
    /// the publisher has, sent (and recorded as sent).
    async fn publish(&mut self) {
        let now = self.now();
        let me = self.crew.first().and_then(Commander::identity);
        let link = self.crew.members().first().map_or(0, |m| m.link);
        let (Some(d), Some(me), Some(writer)) = (&mut self.downlink, me, self.writers.get(link))
        else {
            return;
        };
        d.publisher
            .tick(now, self.supervisor.seq(), self.supervisor.player());
        while let Some(payload) = d.publisher.poll_transmit() {
            let tunnel = Tunnel {
                payload_type: PAYLOAD_TYPE,
                target_system: d.mirror,
                target_component: 0,
                payload,
            };
            match writer.send_data(me, &tunnel).await {
                Ok(bytes) => {
                    if let (Some(rec), false) = (&self.recorder, bytes.is_empty()) {
                        rec.sent(self.clock.now(), &bytes);
                    }
                }
                Err(e) => {
                    tracing::warn!("downlink: {e}");
                    break;
                }
            }
        }
    }

    fn program_input(&mut self, input: ProgramInput) {
        let now = self.now();
        match input {
            ProgramInput::Outcome { id, outcome } => self.feed(now, Owned::Result { id, outcome }),
            ProgramInput::Event { event, .. } | ProgramInput::Lost { event, .. } => {
                self.feed(now, Owned::Event(event))
            }
            ProgramInput::Traffic(t) => {
                if let Some(rec) = &self.recorder {
                    let kind = match t.direction {
                        Direction::In => "in",
                        Direction::Out => "out",
                    };
                    let body = serde_json::from_str(&t.line)
                        .unwrap_or_else(|_| serde_json::Value::String(t.line.clone()));
                    rec.program(now, t.program.as_deref().unwrap_or("?"), kind, body);
                }
            }
        }
    }
}

/// Reads the link until the first autopilot HEARTBEAT (not a ground
/// station's, not a companion's), at most `limit` of wall time: the frames
/// read, and the autopilot's family when one was heard.
async fn identify(
    reader: &mut LinkReader,
    writer: &LinkWriter,
    announce: (u8, u8),
    limit: Duration,
    signals: &mut Signals,
) -> (Vec<Received>, Option<elaboration::Firmware>, bool) {
    let until = tokio::time::Instant::now() + limit;
    let mut early = Vec::new();
    // Speak first while waiting, as the commander will (docs/run.md):
    // behind an endpoint that waits for its client, nothing comes otherwise.
    let mut beat = tokio::time::interval(Duration::from_secs(1));
    loop {
        let received = tokio::select! {
            r = tokio::time::timeout_at(until, reader.recv()) => r,
            _ = beat.tick() => {
                let _ = writer.send(announce, &crate::vehicle::commander::companion_heartbeat()).await;
                continue;
            }
            _ = signals.recv() => return (early, None, true),
        };
        match received {
            Err(_) => return (early, None, false),
            Ok(Ok(rx)) => {
                let heard = match &rx.message {
                    Some(MavMessage::HEARTBEAT(hb))
                        if hb.autopilot != MavAutopilot::MAV_AUTOPILOT_INVALID
                            && hb.mavtype != MavType::MAV_TYPE_GCS
                            && hb.mavtype != MavType::MAV_TYPE_ONBOARD_CONTROLLER =>
                    {
                        Some(elaboration::Firmware::from_heartbeat(
                            hb.autopilot as i64,
                            hb.mavtype as i64,
                        ))
                    }
                    _ => None,
                };
                early.push(rx);
                if heard.is_some() {
                    return (early, heard, false);
                }
            }
            Ok(Err(e)) => {
                tracing::warn!("{e}");
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
        }
    }
}

/// The profile and the project for the autopilot heard (`None`: none within
/// the wait; ArduPilot's profile stays, and the user is told).
fn adopt(
    setup: &mut Setup,
    choice: &ProfileChoice,
    heard: Option<elaboration::Firmware>,
) -> Result<(), miette::Report> {
    let base = match heard {
        Some(elaboration::Firmware::Px4) => "px4",
        Some(_) => "ardupilot",
        None => {
            say!(
                "no autopilot HEARTBEAT yet: elaboration uses the ArduPilot profile (give --profile px4 or [gateway] firmware = \"px4\" for PX4)"
            );
            return Ok(());
        }
    };
    say!(
        "autopilot: {}, elaboration profile {base}",
        if base == "px4" { "PX4" } else { "ArduPilot" }
    );
    if setup.layers.layers.first().map(|(n, _)| n.as_str()) == Some(&format!("{base}.toml")) {
        return Ok(());
    }
    let layers = choice.layers(&setup.dir, base)?;
    let Some(profile) = layers.load() else {
        return Err(miette::miette!("the {base} profile does not load"));
    };
    setup.project = crate::project::load_with(&setup.dir, &profile.catalog())?;
    setup.profile = profile;
    setup.layers = layers;
    Ok(())
}

/// Reports the check of `[gateway.parameters]`; false when the gateway must
/// refuse to go on: a parameter is wrong or unreadable and the vehicle is
/// not armed. An armed vehicle is never abandoned (`vehicle`: `vehicle R2: `
/// in a team, else empty): the misfit is reported
/// and supervision goes on.
fn parameters_fit(
    vehicle: &str,
    verdict: &crate::vehicle::parameters::Verdict,
    armed: Option<bool>,
) -> bool {
    if verdict.holds() {
        let read: Vec<String> = verdict
            .read
            .iter()
            .map(|(name, value)| format!("{name} = {value}"))
            .collect();
        say!("{vehicle}autopilot parameters checked: {}", read.join(", "));
        return true;
    }
    let misfits: Vec<String> = verdict.misfits.iter().map(|m| format!("  {m}")).collect();
    if armed == Some(true) {
        say!(
            "warning: {vehicle}the vehicle's parameters do not fit the project ([gateway.parameters] in project.toml), but it is armed: supervision goes on\n{}",
            misfits.join("\n")
        );
        return true;
    }
    say!(
        "refused: {vehicle}the vehicle's parameters do not fit the project ([gateway.parameters] in project.toml); set them on the autopilot and start again:\n{}",
        misfits.join("\n")
    );
    false
}

/// A number for this run of the gateway, so that a mirror tells a restart
/// from a gap: the low bits of the UNIX time in milliseconds.
fn session() -> u32 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(1, |d| d.as_millis() as u32)
        .max(1)
}

/// Elaboration follows the vehicle the commander commands (docs/multi-vehicle.md).
fn elaboration_config(vehicle: &VehicleConfig) -> elaboration::Config {
    elaboration::Config {
        sysid: vehicle.system,
        compid: vehicle.autopilot_component,
        ..elaboration::Config::default()
    }
}

/// SIGINT and SIGTERM.
struct Signals {
    term: tokio::signal::unix::Signal,
    int: tokio::signal::unix::Signal,
}

impl Signals {
    fn new() -> Result<Signals, miette::Report> {
        use tokio::signal::unix::{signal, SignalKind};
        let err = |e: std::io::Error| miette::miette!("cannot watch for signals: {e}");
        Ok(Signals {
            term: signal(SignalKind::terminate()).map_err(err)?,
            int: signal(SignalKind::interrupt()).map_err(err)?,
        })
    }

    async fn recv(&mut self) {
        tokio::select! {
            _ = self.term.recv() => {}
            _ = self.int.recv() => {}
        }
    }
}
