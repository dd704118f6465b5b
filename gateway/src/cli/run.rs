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
use std::time::Duration;

use elaboration::Profile;
use nets::Project;

use super::{Outcome, VerbResult};
use crate::preflight::Preflight;
use petrel_core::vehicle::config::VehicleConfig;

mod autopilot;
mod gateway;
mod links;
mod parameters;
mod reload;
mod signals;
pub(crate) use signals::{Hangup, Signals};

use super::timeline;

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
    // The text is `--help`'s, where `<…>` is no HTML tag.
    #[allow(rustdoc::invalid_html_tags)]
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
    /// The real-time priority (SCHED_FIFO, 1-99) the loop asks the kernel
    /// for, so that a frame gets a CPU at once when other programs hold
    /// them all. Needs root, CAP_SYS_NICE or a high enough RLIMIT_RTPRIO;
    /// refused, the loop runs at the normal priority and says so. A
    /// real-time policy given from outside (chrt, systemd) is kept.
    #[arg(
        long,
        value_name = "PRIORITY",
        default_value_t = crate::scheduling::LOOP_PRIORITY,
        value_parser = clap::value_parser!(u32).range(1..=99)
    )]
    pub realtime_priority: u32,
    /// Do not ask for a real-time priority: the loop runs at the normal
    /// priority (with a short slice).
    #[arg(long, conflicts_with = "realtime_priority")]
    pub no_realtime: bool,
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
    let gateway = petrel_core::project::gateway_table(&args.project)?;
    let get = |key: &str| gateway.get(key).and_then(|v| v.as_str()).map(str::to_owned);
    // --profile (beside the working directory), else `[gateway] profile`
    // (beside project.toml), else ArduPilot's.
    // Read again from its text, so that an error names file:line:col.
    let file = args.project.join(nets::load::PROJECT_FILE);
    let text = std::fs::read_to_string(&file)
        .map_err(|e| miette::miette!("cannot read {}: {e}", file.display()))?;
    let vehicle = VehicleConfig::from_project_toml(&file.display().to_string(), &text)
        .map_err(|e| miette::miette!("{e}"))?;
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
    let Some(profile) = crate::cli::loaded(&layers) else {
        return Ok(Err(Outcome::BadInput));
    };
    let (project, files) =
        petrel_core::project::load_read(&args.project, &petrel_core::project::catalog(&profile))?;
    if !project.vehicles.is_empty() && vehicle.system.is_some() {
        say!(
            "warning: [gateway] system_id is not used by a team project: each [[vehicle]] names its system"
        );
    }
    // A team's vehicles' own profiles load, or the run is refused here,
    // before any link opens (`run` builds the lanes again once the
    // autopilot is known).
    petrel_core::team::lanes(
        &project,
        &args.project,
        &profile,
        petrel_core::team::family(&layers.layers),
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
    let mut programs = petrel_core::programs::roster::Config::from_gateway(Some(&gateway))
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
            petrel_core::signing::read_private(&file).map_err(|e| miette::miette!("{e}"))?;
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
    .map(|system| system.unwrap_or(petrel_core::mirror::MIRROR_SYSTEM));
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
        Some(path) => Some(petrel_core::signing::Setup {
            key: petrel_core::signing::Key::load(path).map_err(|e| miette::miette!("{e}"))?,
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
            Some(petrel_core::signing::Key::load(path).map_err(|e| miette::miette!("{e}"))?)
        }
    };
    let http = match &args.http {
        Some(a) => Some(petrel_web::monitor::parse_address(a).map_err(|e| miette::miette!("{e}"))?),
        None => None,
    };
    Ok(Ok(Setup {
        http,
        unchecked: args.unchecked,
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
        realtime: (!args.no_realtime).then_some(args.realtime_priority),
    }))
}

/// How the profile was chosen: `--profile`, else `[gateway] profile`.
#[derive(Clone, Debug)]
pub(crate) struct ProfileChoice {
    pub given: Option<String>,
    pub setting: Option<String>,
}

impl ProfileChoice {
    /// The layers over the built-in `base` (a file extends it).
    fn layers(
        &self,
        project: &Path,
        base: &str,
    ) -> Result<petrel_core::profile::Layers, miette::Report> {
        petrel_core::profile::Layers::pick(
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

/// The longest wall time a verb waits (`--duration`, `--timeout`): about
/// 31 years, far from where a `Duration` or an `Instant` overflows.
const LONGEST_S: f64 = 1e9;
/// Time factors (`--time-scale`, `--speed`) from this slowest one.
const SLOWEST: f64 = 1e-3;
/// The fastest simulated clock (`run --time-scale`, `demo --speed`); a
/// replay may go faster ([`check_factor`]'s `fastest`).
pub(crate) const FASTEST_CLOCK: f64 = 1e4;

/// A wall time in seconds: positive, at most [`LONGEST_S`] (bad input, not a
/// panic, for `1e30` or `inf`).
pub(crate) fn check_seconds(flag: &str, seconds: f64) -> Result<(), miette::Report> {
    if !(seconds.is_finite() && seconds > 0.0 && seconds <= LONGEST_S) {
        return Err(miette::miette!(
            "{flag} must be a positive number of seconds up to {LONGEST_S:e}, not {seconds}"
        ));
    }
    Ok(())
}

/// A time factor: from [`SLOWEST`] to `fastest`.
pub(crate) fn check_factor(flag: &str, factor: f64, fastest: f64) -> Result<(), miette::Report> {
    if !(factor.is_finite() && (SLOWEST..=fastest).contains(&factor)) {
        return Err(miette::miette!(
            "{flag} must be a number from {SLOWEST} to {fastest}, not {factor}"
        ));
    }
    Ok(())
}

/// `--duration` and `--time-scale` (`run` and `mirror`).
pub(crate) fn check_timing(duration: Option<f64>, time_scale: f64) -> Result<(), miette::Report> {
    if let Some(d) = duration {
        check_seconds("--duration", d)?;
    }
    check_factor("--time-scale", time_scale, FASTEST_CLOCK)
}

/// Runs the gateway until its duration, a signal or `stop`.
pub(crate) fn fly(setup: Setup) -> VerbResult {
    // One thread for the link reader, the programs and the loop (two worker
    // threads measured no better: BENCHMARKS.md); the recorder writes on its
    // own thread.
    // The loop asks the kernel for a real-time priority, else a short
    // slice, so that a frame arriving while other programs hold both cores
    // gets a CPU at once (scheduling.rs).
    crate::scheduling::for_the_loop(setup.realtime);
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| miette::miette!("cannot start the runtime: {e}"))?;
    runtime.block_on(gateway::Gateway::run(setup))
}

/// What the gateway runs with.
pub(crate) struct Setup {
    pub project: Arc<Project>,
    /// MAVLink 2 signing on the vehicle link.
    pub signing: Option<petrel_core::signing::Setup>,
    /// The operator key, for the answers to `ask` (`--operator-key`).
    pub operator: Option<petrel_core::signing::Key>,
    pub dir: PathBuf,
    pub profile: Profile,
    pub layers: petrel_core::profile::Layers,
    /// The profile's choice when its built-in base is to follow the
    /// autopilot heard first (`None`: fixed).
    pub detect: Option<ProfileChoice>,
    pub record: Option<PathBuf>,
    pub address: String,
    pub vehicle: VehicleConfig,
    pub programs: petrel_core::programs::roster::Config,
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
    /// `--unchecked`: a new version (SIGHUP) is not checked from its own
    /// start either (it is still proved from the running state).
    pub unchecked: bool,
    /// The real-time priority the loop asks for (`None`: the normal policy).
    pub realtime: Option<u32>,
}

/// Elaboration follows the vehicle the commander commands (docs/multi-vehicle.md).
fn elaboration_config(vehicle: &VehicleConfig) -> elaboration::Config {
    elaboration::Config {
        sysid: vehicle.system,
        compid: vehicle.autopilot_component,
        ..elaboration::Config::default()
    }
}
