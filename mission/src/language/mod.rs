//! The mission language: steps in sequence and in parallel, interrupt
//! rules scoped to steps, reactions per category of disruptive event with
//! their procedures, the mission's phases and its levels, written in a
//! TOML file beside project.toml (`mission = "steps.toml"`) and compiled
//! into ordinary nets (docs/missions.md).
//!
//! - [`syntax`] reads the file's shape with its spans;
//! - [`check`] resolves and checks it into a [`model::Mission`], every
//!   problem at `file:line:col` (one sequence of steps at a time:
//!   `steps.rs`);
//! - [`compile`] writes the nets as TOML text, each line mapped back to
//!   the mission line it comes from;
//! - [`sources`] serves a mission project to `nets::load` as ordinary nets
//!   and moves the loader's problems back onto the mission.

pub mod check;
pub mod compile;
pub mod model;
pub mod sources;
mod steps;
pub mod syntax;
