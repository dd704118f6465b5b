//! # nets — Petrel's net language, player and verifier
//!
//! This crate owns the interpreted safe Petri nets of a Petrel project: the
//! TOML language and its [`load`](mod@load)er (every problem reported at once, with
//! file:line:col), the [`Player`] that fires event-triggered transitions and
//! produces effects, scripts of timed inputs ([`script`]), and the
//! [`verify`]er (reachability graphs, PNML).
//!
//! It never does I/O — the loader asks a [`source::Sources`] for the text of
//! each file, the caller reads the disk —, never reads a clock, never spawns
//! threads (except the verifier's explorer, which may use both cores) and
//! knows nothing of MAVLink: time and events are inputs, effects are
//! outputs, and the same inputs give the same outputs bit for bit. The ground
//! mirror depends on it.
//!
//! ```
//! use std::sync::Arc;
//! use nets::{Event, Player};
//!
//! let files = [
//!     ("project.toml", "[[net]]\nfile = \"n.toml\"\nactive = true\n"),
//!     ("n.toml", "name = \"N\"\nplaces = [\"ground\", \"air\"]\ninitial = [\"ground\"]\n\
//!                 [[transition]]\nname = \"go\"\nfrom = [\"ground\"]\nto = [\"air\"]\n\
//!                 on = \"ready_for_takeoff\"\ndo = [\"command takeoff {alt: 30}\"]\n"),
//! ];
//! let project = Arc::new(nets::load(&files).expect("loads"));
//! let mut player = Player::start(project, 0);
//! player.handle(&Event::new("ready_for_takeoff"), 1_000_000);
//! let commands = player
//!     .effects()
//!     .filter(|e| matches!(e, nets::Effect::Command { .. }))
//!     .count();
//! assert_eq!(commands, 1);
//! ```

pub mod action;
pub mod binary;
pub mod choice;
pub mod dot;
pub mod event;
pub mod expr;
pub mod layout;
pub mod load;
pub mod model;
pub mod outside;
pub mod player;
pub mod script;
pub mod source;
pub mod suggest;
pub mod svg;
pub mod time;
pub mod value;
pub mod verbs;
pub mod verify;
pub mod version;

pub use event::{Category, Event};
pub use load::{load, load_with};
pub use model::Project;
pub use player::{Effect, Outcome, Player};
pub use time::Micros;
pub use value::{Params, Value};
