//! Petrel's web pages: the monitor (`petrel run --http`, `demo`, `mirror
//! --http`), the viewer of a recording (`petrel view`) and the editor
//! (`petrel edit`), their routes (axum), their assets (built in: no npm,
//! no CDN), and the guard in front of every route (this computer's own
//! page only, bounded bodies and WebSockets).
//!
//! It never calls into the player, the commander or the programs: the
//! drivers hand it the steps after their commands are out, and it reads
//! the player's state. The routers ([`monitor::server::router`],
//! [`edit::server::router`]) are served on their own thread and runtime
//! ([`monitor::Server`]); the thread's scheduling is the driver's, given
//! once with [`set_thread_policy`].

use std::sync::OnceLock;

pub mod edit;
pub mod monitor;

static THREAD_POLICY: OnceLock<fn()> = OnceLock::new();

/// The scheduling policy a page's thread puts itself in first (`petrel`:
/// the normal policy, never a real-time priority a crew gave the gateway;
/// docs/run.md "On a busy computer"). Set once, by the binary; later calls
/// are ignored.
pub fn set_thread_policy(policy: fn()) {
    let _ = THREAD_POLICY.set(policy);
}

fn thread_started() {
    if let Some(policy) = THREAD_POLICY.get() {
        policy();
    }
}
