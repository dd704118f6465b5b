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
// `Skipped` and the closing `SKIPPED:` line, shared by every crate's tests.
use petrel_test_support::skip;
mod team;
mod team_reduction;
mod verify;
