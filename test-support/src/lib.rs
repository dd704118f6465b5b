//! # petrel-test-support — what the tests of every crate share
//!
//! This crate owns the helpers the test and bench binaries of several
//! crates use, so that no crate compiles another's files by `#[path]`:
//! [`skip`] (a test whose peer is missing says so, in a closing line after
//! libtest's, and fails under `CI=true`), [`scratch`] (a test's scratch
//! folder, kept when the test fails), and for the benchmarks [`busy`] (the
//! other core kept busy) and [`proc`] (what /proc says of a process).
//!
//! It is a dev-dependency everywhere except `sitl-tests`, whose harnesses
//! (ArduPilot's and PX4's SITL) skip through it, so that `petrel demo`'s
//! build links it too; nothing in it runs unless a test calls it.

pub mod busy;
pub mod proc;
pub mod scratch;
pub mod skip;
