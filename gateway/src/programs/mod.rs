//! Software programs: the paper's planners and payload managers (DEC, PLN,
//! GUI…) that the nets call. The protocol is JSON lines over TCP or a Unix
//! socket, documented in `docs/programs.md`.
//!
//! - [`session`], [`protocol`], [`roster`], [`address`]: the sans-IO part,
//!   in `petrel_core::programs` (one connection's core, fed bytes and
//!   polled for outputs; what the project expects of each program).
//! - [`server`]: the tokio layer: the listener, one task per connection, the
//!   started programs ([`child`]), and the [`Programs`](server::Programs) handle the gateway's
//!   loop calls without ever blocking.
//! - [`stubs`]: program skeletons for `petrel stubs`.

pub mod child;
pub mod server;
pub mod stubs;

pub use petrel_core::programs::{address, protocol, roster, session};
