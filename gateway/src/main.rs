//! `petrel`: the Petrel command line. Each verb lives in `cli/<verb>.rs`;
//! this file only parses arguments and turns outcomes into exit codes.
//!
//! Exit status, for every verb: 0 success, 1 a property or check failed,
//! 2 bad input (unreadable or invalid files, bad arguments).

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[macro_use]
extern crate gateway;

mod cli;

use gateway::{clock, link, preflight, programs, scheduling, upload};

#[derive(Parser)]
#[command(
    name = "petrel",
    version,
    about = "Petrel: mission supervision with interpreted Petri nets over MAVLink"
)]
struct Petrel {
    #[command(subcommand)]
    verb: Verb,
}

#[derive(Subcommand)]
enum Verb {
    /// Run the gateway beside the autopilot: telemetry to events to the nets, and their commands back.
    Run(cli::run::Args),
    /// Tell a running gateway to take the new version of its project, proved from the state the vehicle is in.
    Reload(cli::reload::Args),
    /// The ground mirror: the vehicle's player replayed on the ground from `run --downlink`, checked step by step.
    Mirror(cli::mirror::Args),
    /// Play a project on a file of timed events, printing every firing and effect.
    Play(cli::play::Args),
    /// Elaborate a telemetry log (.tlog) into supervision events.
    Events(cli::events::Args),
    /// Check a net: reachability graph, 1-safety, dead markings, loops.
    Check(cli::check::Args),
    /// Draw a project's nets as Graphviz DOT.
    Draw(cli::draw::Args),
    /// Write ready-to-fill skeletons of the software programs the nets call.
    Stubs(cli::stubs::Args),
    /// Write a mission project out as hand-written nets, into a new folder.
    Compile(cli::compile::Args),
    /// Write each net of a project as PNML.
    Export(cli::export::Args),
    /// Replay recorded telemetry through elaboration and the player.
    Replay(cli::replay::Args),
    /// Show a recorded flight in the monitor's page: scrub, step, play.
    View(cli::view::Args),
    /// Edit a project's nets in the monitor's page: each change written back, loaded and checked.
    Edit(cli::edit::Args),
    /// Copy a recording cut short (no summary, a torn last chunk) into a clean, indexed MCAP.
    Recover(cli::recover::Args),
    /// Fly the paper's UAV mission on a simulated ArduPlane with DEC, live.
    #[cfg(feature = "demo")]
    Demo(cli::demo::Args),
}

fn main() -> ExitCode {
    // Errors are wrapped to the width of a terminal, and never wrapped when
    // stderr goes to a file or a pipe (logs stay greppable, one line a message).
    let wrap = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let _ = miette::set_hook(Box::new(move |_| {
        Box::new(miette::MietteHandlerOpts::new().wrap_lines(wrap).build())
    }));
    // The web pages' threads take the normal policy, never a real-time
    // priority a crew gave the gateway (docs/run.md "On a busy computer").
    petrel_web::set_thread_policy(|| {
        let _ = scheduling::normal();
    });
    // Logs (tracing) go to stderr: warnings and errors unless PETREL_LOG
    // says otherwise (`PETREL_LOG=info`, `PETREL_LOG=gateway=debug`).
    let filter = tracing_subscriber::EnvFilter::try_from_env("PETREL_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(wrap)
        .without_time()
        .with_target(false)
        .try_init();
    let petrel = match Petrel::try_parse() {
        Ok(p) => p,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    let outcome = match petrel.verb {
        Verb::Run(args) => cli::run::run(args),
        Verb::Reload(args) => cli::reload::run(args),
        Verb::Mirror(args) => cli::mirror::run(args),
        Verb::Play(args) => cli::play::run(args),
        Verb::Events(args) => cli::events::run(args),
        Verb::Check(args) => cli::check::run(args),
        Verb::Draw(args) => cli::draw::run(args),
        Verb::Stubs(args) => cli::stubs::run(args),
        Verb::Compile(args) => cli::compile::run(args),
        Verb::Export(args) => cli::export::run(args),
        Verb::Replay(args) => cli::replay::run(args),
        Verb::View(args) => cli::view::run(args),
        Verb::Edit(args) => cli::edit::run(args),
        Verb::Recover(args) => cli::recover::run(args),
        #[cfg(feature = "demo")]
        Verb::Demo(args) => cli::demo::run(args),
    };
    match outcome {
        Ok(code) => code.into(),
        Err(failure) => {
            say!("{}", petrel_core::project::for_people(&failure));
            cli::Outcome::BadInput.into()
        }
    }
}
