//! Software programs: the paper's planners and payload managers (DEC, PLN,
//! GUI…) that the nets call. The protocol is JSON lines over TCP or a Unix
//! socket, documented in `docs/programs.md`.
//!
//! - [`session`]: the sans-IO core for one connection (framing, hello,
//!   calls, replies, events, timeouts), fed bytes and polled for outputs.
//! - [`roster`]: what the project expects of each program (the functions
//!   the nets call, its settings) and the `[gateway] programs` address.
//! - [`server`]: the tokio layer: the listener, one task per connection, the
//!   started programs ([`child`]), and the [`Programs`](server::Programs) handle the gateway's
//!   loop calls without ever blocking.
//! - [`stubs`]: program skeletons for `petrel stubs`.

pub mod address;
pub mod child;
pub mod protocol;
pub mod roster;
pub mod server;
pub mod session;
pub mod stubs;
