//! `petrel-dec --mission FILE [--connect ADDRESS]`: DEC for the
//! uav-flight-test example. It connects to the gateway's program server
//! (ADDRESS, else $PETREL_PROGRAMS, else tcp:127.0.0.1:5790), waiting for
//! it if need be, and serves until the gateway closes the connection.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;

/// DEC: plans, replans and picks emergency sites for the uav-flight-test nets.
#[derive(Parser)]
#[command(name = "petrel-dec", version)]
struct Args {
    /// The mission file (examples/uav-flight-test/mission.toml).
    #[arg(long)]
    mission: PathBuf,
    /// The gateway's program address: tcp:HOST:PORT or unix:PATH
    /// [default: $PETREL_PROGRAMS, else tcp:127.0.0.1:5790].
    #[arg(long)]
    connect: Option<String>,
    /// The program's name in the hello [default: $PETREL_PROGRAM, else DEC].
    #[arg(long)]
    name: Option<String>,
    /// Connection attempts before giving up (0.1 s apart, doubling to 1 s).
    #[arg(long, default_value_t = 120)]
    attempts: u32,
}

fn main() -> ExitCode {
    let args = Args::parse();
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .init();
    let address = args
        .connect
        .or_else(|| std::env::var("PETREL_PROGRAMS").ok())
        .unwrap_or_else(|| "tcp:127.0.0.1:5790".into());
    let name = args
        .name
        .or_else(|| std::env::var("PETREL_PROGRAM").ok())
        .unwrap_or_else(|| "DEC".into());
    let mission = match petrel_dec::Mission::load(&args.mission) {
        Ok(m) => m,
        Err(e) => {
            eprintln!(
                "{:?}",
                miette::miette!("{e}").context("petrel-dec: the mission file has problems")
            );
            return ExitCode::from(2);
        }
    };
    tracing::info!(mission = %mission.name, address, "DEC starting");
    let options = petrel_dec::Options {
        name,
        attempts: args.attempts,
        ..petrel_dec::Options::default()
    };
    let stop = std::sync::atomic::AtomicBool::new(false);
    match petrel_dec::serve_with(&address, petrel_dec::Dec::new(mission), &options, &stop) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{:?}", miette::miette!("{e}").context("petrel-dec"));
            ExitCode::FAILURE
        }
    }
}
