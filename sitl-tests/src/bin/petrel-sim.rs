//! `petrel-sim`: the simulated ArduPlane on a TCP or UDP port, printing a
//! short live log (state once a second, every STATUSTEXT, command, mission
//! item reached and fault).
//!
//! ```text
//! petrel-sim --listen tcpin:127.0.0.1:5760 --speedup 1 --fault engine_failure@90s
//! ```
//!
//! Exit status: 0 when stopped by `--duration`, 2 on bad arguments or when
//! the port cannot be bound.

use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use sitl_tests::{BootTimeline, Home, Schedule, Sim, SimConfig, SimState};

#[derive(Parser, Debug)]
#[command(
    name = "petrel-sim",
    version,
    about = "A simulated ArduPlane (MAVLink 2 over TCP or UDP) for Petrel's tests and demos"
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

fn config(args: &Args) -> Result<SimConfig, String> {
    let faults = Schedule::parse(&args.faults).map_err(|e| e.to_string())?;
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
        if !sitl_tests::Params::default().knows(&name) {
            return Err(format!("--param `{p}`: unknown parameter {name}"));
        }
        cfg.params.push((name, value));
    }
    Ok(cfg)
}

fn line(s: &SimState) -> String {
    format!(
        "t={:7.1}s {:<13} {:<8} {:<9} alt {:6.1} m  aspd {:4.1}  gs {:4.1}  bank {:5.1}  thr {:3.0}%  bat {:3.0}%  gps {}  wp {}",
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
    let cfg = match config(&args) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("{:?}", miette::miette!("{e}"));
            return ExitCode::from(2);
        }
    };
    let sim = match Sim::start(cfg) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{:?}", miette::miette!("{e}"));
            return ExitCode::from(2);
        }
    };
    println!(
        "petrel-sim: simulated ArduPlane on {} (connect with --mavlink {}), speedup {}",
        sim.local_addr(),
        sim.client_address(),
        args.speedup
    );
    println!("petrel-sim: the vehicle boots when the first client connects");
    let (mut texts, mut commands, mut reached, mut faults) = (0, 0, 0, 0);
    let mut ticks: u64 = 0;
    loop {
        ticks += 1;
        std::thread::sleep(Duration::from_millis(250));
        let s = sim.state();
        if !args.quiet {
            for t in &s.statustexts[texts..] {
                println!("t={:7.1}s STATUSTEXT [{}] {}", t.time_s, t.severity, t.text);
            }
            for c in &s.commands[commands..] {
                println!(
                    "t={:7.1}s COMMAND {} from {}/{} -> {}",
                    c.time_s,
                    c.command,
                    c.from.0,
                    c.from.1,
                    c.result
                        .map_or("no answer".to_owned(), |r| format!("result {r}"))
                );
            }
            for r in &s.reached[reached..] {
                println!("t={:7.1}s MISSION_ITEM_REACHED {}", r.time_s, r.seq);
            }
            for f in &s.faults[faults..] {
                let what = if f.cleared { "cleared" } else { "injected" };
                println!("t={:7.1}s FAULT {} {}", f.time_s, f.fault, what);
            }
            // The state once a second of wall time.
            if ticks.is_multiple_of(4) {
                println!("{}", line(&s));
            }
        }
        texts = s.statustexts.len();
        commands = s.commands.len();
        reached = s.reached.len();
        faults = s.faults.len();
        if args.duration.is_some_and(|d| s.time_s >= d) {
            println!("{}", line(&s));
            break;
        }
    }
    sim.stop();
    ExitCode::SUCCESS
}
