//! `petrel edit PROJECT`: the monitor's page in editing mode (EdiPet's
//! other half; docs/monitor.md, "Editing"). Serves until stopped.
//!
//! Exit status: 0 when stopped, 2 for bad input (no project, a
//! project.toml that is not TOML, a mission project: its nets are
//! compiled, an address that cannot be served).

use std::net::SocketAddr;
use std::path::PathBuf;

use super::{Outcome, VerbResult};
use petrel_web::edit::server::router;
use petrel_web::edit::session::Session;
use petrel_web::monitor::Server;

#[derive(clap::Args)]
pub struct Args {
    /// The project folder (holding project.toml).
    pub project: PathBuf,
    /// Serve the page on ADDR:PORT, or 127.0.0.1:PORT given a port
    /// [default: 127.0.0.1:8091, else a free port on 127.0.0.1].
    #[arg(long, value_name = "ADDR:PORT")]
    pub http: Option<String>,
}

pub fn run(args: Args) -> VerbResult {
    let address: SocketAddr = match &args.http {
        Some(a) => petrel_web::monitor::parse_address(a).map_err(|e| miette::miette!("{e}"))?,
        None => {
            let port = if std::net::TcpListener::bind("127.0.0.1:8091").is_ok() {
                8091
            } else {
                0
            };
            SocketAddr::from(([127, 0, 0, 1], port))
        }
    };
    // The editor writes net files back: a mission's nets are generated at
    // every load, so an edit to them would be lost. The crew edits the
    // mission, or compiles it out into nets of their own first.
    if let Some(compiled) = petrel_core::project::compiled(&args.project)? {
        return Err(miette::miette!(
            "{}'s nets are compiled from its mission {} at every load, and an edit to them would be lost: edit {} itself, or write the nets out with `petrel compile {} --out DIR` and edit DIR",
            args.project.display(),
            compiled.mission.name,
            compiled.mission.name,
            args.project.display()
        ));
    }
    let session = Session::open(&args.project).map_err(|e| miette::miette!("{e}"))?;
    let server = Server::serve(address, router(session))
        .map_err(|e| miette::miette!("cannot serve the page on {address}: {e}"))?;
    say!(
        "edit: http://{}/ (editing {}; every change is written at once; Ctrl-C stops)",
        server.address,
        args.project.display()
    );
    server.wait();
    Ok(Outcome::Success)
}
