//! The integration tests of `nets`, one test binary (issue 36: linking the
//! library and its dependencies once rather than once per file). Each module
//! was a test binary of its own; `common` holds the helpers they share.
//! Run one module with a filter: `cargo test -p nets --test it verify::`.

mod ask;
mod check;
mod check_ask;
mod choice;
mod common;
mod example;
mod load;
mod player;
mod properties;
// `Skipped` and the closing `SKIPPED:` line, shared with the gateway's and
// elaboration's tests (nets does not depend on sitl-tests).
#[path = "../../../sitl-tests/src/skip.rs"]
mod skip;
mod team;
mod team_reduction;
mod verify;
