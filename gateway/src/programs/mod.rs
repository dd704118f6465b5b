//! Software programs: the paper's planners and payload managers (DEC, PLN,
//! GUI…) that the nets call. The protocol is JSON lines over TCP or a Unix
//! socket, documented in `docs/programs.md`.
//!
//! - The sans-IO part is `petrel_core::programs` (one connection's
//!   session, fed bytes and polled for outputs; the protocol; what the
//!   project expects of each program; the stubs).
//! - [`server`]: the tokio layer: the listener, one task per connection, the
//!   started programs ([`child`]), and the [`Programs`](server::Programs) handle the gateway's
//!   loop calls without ever blocking.

pub mod child;
pub mod server;
