//! Software programs, without the sockets: the paper's planners and payload
//! managers (DEC, PLN, GUI…) that the nets call, over JSON lines
//! (`docs/programs.md`).
//!
//! - [`session`]: the sans-IO core for one connection (framing, hello,
//!   calls, replies, events, timeouts), fed bytes and polled for outputs.
//! - [`protocol`]: the lines themselves, typed.
//! - [`roster`]: what the project expects of each program (the functions
//!   the nets call, its settings) and the `[gateway] programs` address
//!   ([`address`]).
//! - [`stubs`]: program skeletons for `petrel stubs` and the editor.
//!
//! The listener, the started processes and the tasks are the driver's
//! (`gateway::programs`).

pub mod address;
pub mod protocol;
pub mod roster;
pub mod session;
pub mod stubs;
