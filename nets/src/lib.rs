//! # nets — Petrel's net language, player and verifier
//!
//! This crate owns the interpreted safe Petri nets of a Petrel project: the
//! TOML language and its loader (every problem reported at once, with
//! file:line:col), the **player** that fires event-triggered transitions and
//! produces effects, and (later) the verifier.
//!
//! It never does I/O beyond reading the project's own files in [`load`], never
//! reads a clock, never spawns threads and knows nothing of MAVLink: time and
//! events are inputs, effects are outputs, and the same inputs give the same
//! outputs bit for bit. The ground mirror depends on it.

pub mod action;
pub mod event;
pub mod expr;
pub mod load;
pub mod model;
pub mod player;
pub mod script;
pub mod source;
pub mod time;
pub mod value;
pub mod verbs;
pub mod verify;

pub use event::{Category, Event};
pub use load::{load, load_with};
pub use model::Project;
pub use player::{Effect, Outcome, Player};
pub use time::Micros;
pub use value::{Params, Value};
