//! The web monitor (docs/monitor.md): the nets live in a web page, as
//! EdiPet showed them (ProCoSA §2.3) — every net drawn, marked places in
//! red, the transition that just fired flashing, the event log, the
//! vehicle strip and a small offline map — for `petrel run`/`demo`
//! (`--http`) and over a recording (`petrel view`).
//!
//! It owns: the board (`board.rs`: what the page shows, fed the
//! supervisor's steps; `vehicle.rs`: the strip and map from the same
//! frames), the page's fixed part (`page.rs`: the nets' SVG from
//! `nets::svg` and their definitions), the live board shared with the
//! server (`live.rs`), a recording's index (`history.rs`), the axum server
//! (`server.rs`), the mirror's panel, its board and its answer desk
//! (`mirror.rs`, `mirror_page.rs`, `answer.rs`, for `petrel mirror --http`),
//! the rule in front of every route of every page (`guard.rs`: this
//! computer's own page only, bounded bodies and WebSockets) and the page's assets (`assets/`, built into the binary:
//! no npm, no CDN, no outside fonts).
//!
//! It never calls into the player or the commander: the gateway's loop
//! hands it steps after their commands are out, and it only reads the
//! player's state. A browser never slows the loop: frames are coalesced to
//! at most 30 a second per browser, and nothing queues per browser.

pub mod answer;
pub mod board;
pub mod guard;
pub mod history;
pub mod live;
pub mod mirror;
pub mod mirror_page;
pub mod page;
pub mod server;
pub mod vehicle;

use std::net::SocketAddr;
use std::path::Path;
use std::sync::Arc;

use nets::{Player, Project};

pub use live::{Feed, Live};
pub use server::{Server, Source};

use petrel_core::supervisor::Step;

/// Starts the live monitor on `address` for a gateway whose player has just
/// started (`start`, step 0): the feed for the loop, and the server.
pub fn start_live(
    address: SocketAddr,
    project: Arc<Project>,
    dir: &Path,
    start: &Step,
    player: &Player,
) -> std::io::Result<(Feed, Server)> {
    let page = page::page(&project, Some(dir), "live");
    let board = board::Board::new(project, player, start.time, live::LOG_LIVE);
    let live = Live::new(board, page);
    let feed = Feed::new(live.clone());
    feed.start(start, player);
    let server = Server::start(address, Source::Live(live))?;
    Ok((feed, server))
}

/// `--http ADDR:PORT`, or `PORT` alone for loopback.
pub fn parse_address(text: &str) -> Result<SocketAddr, String> {
    if let Ok(port) = text.parse::<u16>() {
        return Ok(SocketAddr::from(([127, 0, 0, 1], port)));
    }
    text.parse().map_err(|_| {
        format!("--http {text}: expected ADDRESS:PORT (e.g. 127.0.0.1:8080) or a port number")
    })
}
