//! DEC, the decision program of the `uav-flight-test` example: the
//! software program the nets call (ProCoSA's DEC) for everything that
//! needs the mission's data, which lives in a mission file, not in the
//! nets.
//!
//! It owns the mission file's model ([`mission`]), planning it as
//! ArduPlane mission items ([`plan`]), the replanning around failed
//! payloads and the progress along the active plan ([`decision`]), the
//! choice of an emergency landing site within glide range
//! ([`emergency`]) — all pure —, and a blocking client of the gateway's
//! program protocol ([`serve`], [`serve_until`]).
//!
//! It never talks to the vehicle (the nets command it through the gateway)
//! and never decides when: the nets call, DEC answers.

pub mod client;
pub mod decision;
pub mod emergency;
pub mod geo;
pub mod mission;
pub mod plan;
pub mod protocol;

pub use client::{serve, serve_until, serve_with, Ended, Error, Options};
pub use decision::{Dec, FUNCTIONS};
pub use mission::Mission;
