//! Software programs end to end: the program server with real child
//! processes (a scripted Python fixture and the skeletons `petrel stubs`
//! writes), over 127.0.0.1 and Unix sockets. Every wait is bounded.
//!
//! The gateway is a binary crate: its programs module is compiled into this
//! test binary from its source.

#[path = "../src/programs/mod.rs"]
mod programs;
// A started program begins under the normal policy (programs/child.rs).
#[allow(dead_code)]
#[path = "../src/scheduling.rs"]
mod scheduling;

#[path = "support/scratch.rs"]
mod scratch;

#[path = "programs/support.rs"]
mod support;

#[path = "programs/server.rs"]
mod server;

#[path = "programs/stubs.rs"]
mod stubs;
