//! `petrel-sim`: the simulated ArduPlane (or ground rovers, or several
//! vehicles at once) on a TCP or UDP port, printing a short live log (state
//! once a second, every STATUSTEXT, command, mission item reached and
//! fault; prefixed with the system id when there are several vehicles).
//!
//! ```text
//! petrel-sim --listen tcpin:127.0.0.1:5760 --speedup 1 --fault engine_failure@90s
//! petrel-sim --listen udpin:127.0.0.1:14550 --vehicle rover:1 --vehicle rover:2:0,10 \
//!            --fault 2:stuck@wp3:30s
//! ```
//!
//! `--vehicle KIND:SYSID[:NORTH,EAST][@LISTEN]` (repeatable; KIND `plane`
//! or `rover`): a vehicle with that system id, parked NORTH,EAST metres
//! from `--home`; on `--listen` with the others (one link, as behind a
//! router) or on a socket of its own with `@LISTEN`. Without `--vehicle`:
//! one plane of system 1. `--fault SYSID:SPEC` injects into that vehicle
//! only; a `--fault SPEC` without it into every vehicle.
//!
//! Exit status: 0 when stopped by `--duration`, 2 on bad arguments or when
//! the port cannot be bound.

use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use sitl_tests::{BootTimeline, Firmware, Fleet, Home, Params, Schedule, SimConfig, SimState};

#[derive(Parser, Debug)]
#[command(
    name = "petrel-sim",
    version,
    about = "A simulated ArduPlane or ground rovers (MAVLink 2 over TCP or UDP) for Petrel's tests and demos"
)]
struct Args {
    /// Where to listen: tcpin:IP:PORT (one client at a time) or udpin:IP:PORT.
    #[arg(long, default_value = "tcpin:127.0.0.1:5760")]
    listen: String,
    /// Sim time runs this many times faster than the wall clock.
    #[arg(long, default_value_t = 1.0)]
    speedup: f64,
    /// A fault to inject: `KIND[=VALUE]@WHEN[:DURATION]`, e.g. engine_failure@90s,
    /// link_loss@60s:10s, payload_failure=critical@wp3, battery=20@120s (repeatable).
    #[arg(long = "fault", value_name = "SPEC")]
    faults: Vec<String>,
    /// Home: LAT,LON,ALT_AMSL,HEADING (default: ArduPilot SITL's CMAC).
    #[arg(long, value_name = "LAT,LON,ALT,HDG")]
    home: Option<String>,
    /// Constant wind: NORTH,EAST in m/s (the direction it blows toward).
    #[arg(long, value_name = "N,E", allow_hyphen_values = true)]
    wind: Option<String>,
    /// Accept the first arming even before the gyros settle.
    #[arg(long)]
    no_arm_refusal: bool,
    /// Compress the 23 s start-up (GPS, EKF, gyros) into 3 s.
    #[arg(long)]
    quick_boot: bool,
    /// No camera component (100).
    #[arg(long)]
    no_camera: bool,
    /// No EFI_STATUS (an electric plane, as the recorded SITL one).
    #[arg(long)]
    no_efi: bool,
    /// Every stream group's rate before anyone asks (ArduPlane's MAVn_*; 0: nothing until asked).
    #[arg(long, default_value_t = 1)]
    stream_hz: u16,
    /// Set a parameter at boot: NAME=VALUE (TKOFF_ALT, AIRSPEED_CRUISE, ROLL_LIMIT_DEG, WP_RADIUS…).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    params: Vec<String>,
    /// A vehicle: KIND:SYSID[:NORTH,EAST][@LISTEN], KIND plane or rover (repeatable).
    // The text is `--help`'s, where `[@LISTEN]` is no link.
    #[allow(rustdoc::broken_intra_doc_links)]
    #[arg(long = "vehicle", value_name = "KIND:SYSID")]
    vehicles: Vec<String>,
    /// Stop after this many sim seconds (default: run until interrupted).
    #[arg(long)]
    duration: Option<f64>,
    /// No live log.
    #[arg(long, short)]
    quiet: bool,
}

fn numbers(text: &str, n: usize, what: &str) -> Result<Vec<f64>, String> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--{what} `{text}`: expected {n} comma-separated numbers"))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        return Err(format!(
            "--{what} `{text}`: expected {n} comma-separated numbers"
        ));
    }
    Ok(v)
}

/// One `--vehicle`: its firmware, system id, offset from home, own socket.
struct VehicleSpec {
    firmware: Firmware,
    system: u8,
    offset: (f64, f64),
    listen: Option<String>,
}

fn vehicle_spec(text: &str) -> Result<VehicleSpec, String> {
    let bad = |why: &str| {
        format!("--vehicle `{text}`: {why} (expected KIND:SYSID[:NORTH,EAST][@LISTEN], e.g. rover:2:0,10)")
    };
    let (spec, listen) = match text.split_once('@') {
        Some((s, l)) => (s, Some(l.trim().to_owned())),
        None => (text, None),
    };
    let mut parts = spec.splitn(3, ':');
    let firmware = match parts.next().map(str::trim) {
        Some("plane") => Firmware::ArduPlane,
        Some("rover") => Firmware::ArduRover,
        _ => return Err(bad("the kind is plane or rover")),
    };
    let system: u8 = parts
        .next()
        .and_then(|s| s.trim().parse().ok())
        .filter(|s| *s > 0)
        .ok_or_else(|| bad("the system id is a number in 1..=255"))?;
    let offset = match parts.next() {
        Some(o) => {
            let v =
                numbers(o, 2, "vehicle").map_err(|_| bad("the offset is NORTH,EAST in metres"))?;
            (v[0], v[1])
        }
        None => (0.0, 0.0),
    };
    Ok(VehicleSpec {
        firmware,
        system,
        offset,
        listen,
    })
}

/// The `--fault` flags for system `system`: those without a prefix and
/// those with its `SYSID:`.
fn faults_for(args: &Args, system: u8) -> Result<Schedule, String> {
    let mut mine = Vec::new();
    for f in &args.faults {
        match f.split_once(':') {
            Some((sys, spec)) if !sys.is_empty() && sys.chars().all(|c| c.is_ascii_digit()) => {
                if sys.parse::<u8>().ok() == Some(system) {
                    mine.push(spec.to_owned());
                }
            }
            _ => mine.push(f.clone()),
        }
    }
    Schedule::parse(&mine).map_err(|e| e.to_string())
}

/// Every vehicle's configuration, with the socket it listens on.
fn configs(args: &Args) -> Result<Vec<(String, SimConfig)>, String> {
    let base = config(args)?;
    if args.vehicles.is_empty() {
        return Ok(vec![(base.listen.clone(), base)]);
    }
    let mut out = Vec::new();
    for text in &args.vehicles {
        let v = vehicle_spec(text)?;
        if out
            .iter()
            .any(|(_, c): &(String, SimConfig)| c.system_id == v.system)
        {
            return Err(format!(
                "--vehicle `{text}`: system id {} is given twice",
                v.system
            ));
        }
        let (lat, lon) =
            sitl_tests::geo::location(&base.home, sitl_tests::geo::V2::new(v.offset.0, v.offset.1));
        let home = Home {
            lat,
            lon,
            ..base.home
        };
        let mut cfg = match v.firmware {
            Firmware::ArduPlane => SimConfig {
                system_id: v.system,
                home,
                ..base.clone()
            },
            Firmware::ArduRover => SimConfig {
                first_arm_refused: base.first_arm_refused,
                stream_hz: base.stream_hz,
                boot: base.boot.clone(),
                wind: base.wind,
                ..SimConfig::rover(v.system, home)
            },
        };
        cfg.faults = faults_for(args, v.system)?;
        let params = Params::of(v.firmware);
        for (name, value) in &base.params {
            if params.knows(name) {
                cfg.params.push((name.clone(), *value));
            }
        }
        let listen = v.listen.unwrap_or_else(|| base.listen.clone());
        out.push((listen, cfg));
    }
    Ok(out)
}

fn config(args: &Args) -> Result<SimConfig, String> {
    // Faults without a system prefix (a prefixed one is checked by
    // `faults_for`, per vehicle).
    let faults = faults_for(args, 0)?;
    let mut cfg = SimConfig {
        listen: args.listen.clone(),
        speedup: args.speedup,
        first_arm_refused: !args.no_arm_refusal,
        faults,
        camera: !args.no_camera,
        efi: !args.no_efi,
        stream_hz: args.stream_hz,
        ..SimConfig::default()
    };
    if let Some(h) = &args.home {
        let v = numbers(h, 4, "home")?;
        cfg.home = Home {
            lat: v[0],
            lon: v[1],
            alt_amsl: v[2],
            heading: v[3],
        };
    }
    if let Some(w) = &args.wind {
        let v = numbers(w, 2, "wind")?;
        cfg.wind = (v[0], v[1]);
    }
    if args.quick_boot {
        cfg.boot = BootTimeline::quick();
    }
    for p in &args.params {
        let (name, value) = p
            .split_once('=')
            .ok_or_else(|| format!("--param `{p}`: expected NAME=VALUE"))?;
        let value: f32 = value
            .trim()
            .parse()
            .map_err(|_| format!("--param `{p}`: the value is not a number"))?;
        let name = name.trim().to_owned();
        let known = [Firmware::ArduPlane, Firmware::ArduRover]
            .iter()
            .any(|f| Params::of(*f).knows(&name));
        if !known {
            return Err(format!("--param `{p}`: unknown parameter {name}"));
        }
        cfg.params.push((name, value));
    }
    Ok(cfg)
}

fn line(s: &SimState) -> String {
    format!(
        "t={:7.1}s {:<13} {:<8} {:<9} N {:7.1} E {:7.1}  alt {:6.1} m  aspd {:4.1}  gs {:4.1}  bank {:5.1}  thr {:3.0}%  bat {:3.0}%  gps {}  wp {}",
        s.time_s,
        s.mode,
        if s.armed { "ARMED" } else { "disarmed" },
        match s.system_status {
            2 => "CALIBRAT",
            3 => "STANDBY",
            4 => "ACTIVE",
            5 => "CRITICAL",
            6 => "EMERGENCY",
            _ => "?",
        },
        s.north,
        s.east,
        s.alt,
        s.airspeed,
        s.groundspeed,
        s.bank,
        s.throttle,
        s.battery_remaining,
        s.gps_fix,
        s.mission_current,
    )
}

fn main() -> ExitCode {
    let args = Args::parse();
    let wrap = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let _ = miette::set_hook(Box::new(move |_| {
        Box::new(miette::MietteHandlerOpts::new().wrap_lines(wrap).build())
    }));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .try_init();
    let configs = match configs(&args) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("{:?}", miette::miette!("{e}"));
            return ExitCode::from(2);
        }
    };
    // One fleet per socket.
    let mut sockets: Vec<(String, Vec<SimConfig>)> = Vec::new();
    for (listen, cfg) in configs {
        match sockets.iter_mut().find(|(l, _)| *l == listen) {
            Some((_, v)) => v.push(cfg),
            None => sockets.push((listen, vec![cfg])),
        }
    }
    let several = sockets.iter().map(|(_, v)| v.len()).sum::<usize>() > 1;
    let mut fleets = Vec::new();
    for (listen, cfgs) in sockets {
        let what: Vec<String> = cfgs
            .iter()
            .map(|c| match c.firmware {
                Firmware::ArduPlane => format!("ArduPlane {}", c.system_id),
                Firmware::ArduRover => format!("Rover {}", c.system_id),
            })
            .collect();
        match Fleet::start(&listen, args.speedup, cfgs) {
            Ok(f) => {
                println!(
                    "petrel-sim: simulated {} on {} (connect with --mavlink {}), speedup {}",
                    what.join(", "),
                    f.local_addr(),
                    f.client_address(),
                    args.speedup
                );
                fleets.push(f);
            }
            Err(e) => {
                eprintln!("{:?}", miette::miette!("{e}"));
                return ExitCode::from(2);
            }
        }
    }
    println!("petrel-sim: the vehicles boot when the first client connects");
    let mut seen: std::collections::BTreeMap<u8, [usize; 4]> = Default::default();
    let mut ticks: u64 = 0;
    loop {
        ticks += 1;
        std::thread::sleep(Duration::from_millis(250));
        let all: Vec<(u8, SimState)> = fleets.iter().flat_map(|f| f.states()).collect();
        for (sys, s) in &all {
            let tag = if several {
                format!("[{sys}] ")
            } else {
                String::new()
            };
            let [texts, commands, reached, faults] = seen.entry(*sys).or_default();
            if !args.quiet {
                for t in &s.statustexts[*texts..] {
                    println!(
                        "{tag}t={:7.1}s STATUSTEXT [{}] {}",
                        t.time_s, t.severity, t.text
                    );
                }
                for c in &s.commands[*commands..] {
                    println!(
                        "{tag}t={:7.1}s COMMAND {} from {}/{} -> {}",
                        c.time_s,
                        c.command,
                        c.from.0,
                        c.from.1,
                        c.result
                            .map_or("no answer".to_owned(), |r| format!("result {r}"))
                    );
                }
                for r in &s.reached[*reached..] {
                    println!("{tag}t={:7.1}s MISSION_ITEM_REACHED {}", r.time_s, r.seq);
                }
                for f in &s.faults[*faults..] {
                    let what = if f.cleared { "cleared" } else { "injected" };
                    println!("{tag}t={:7.1}s FAULT {} {}", f.time_s, f.fault, what);
                }
                // The state once a second of wall time.
                if ticks.is_multiple_of(4) {
                    println!("{tag}{}", line(s));
                }
            }
            *texts = s.statustexts.len();
            *commands = s.commands.len();
            *reached = s.reached.len();
            *faults = s.faults.len();
        }
        let time = all.iter().map(|(_, s)| s.time_s).fold(0.0, f64::max);
        if args.duration.is_some_and(|d| time >= d) {
            for (sys, s) in &all {
                let tag = if several {
                    format!("[{sys}] ")
                } else {
                    String::new()
                };
                println!("{tag}{}", line(s));
            }
            break;
        }
    }
    for f in fleets {
        f.stop();
    }
    ExitCode::SUCCESS
}
