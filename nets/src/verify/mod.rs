//! The verifier: reachability graphs that prove nets 1-safe and deadlock-free
//! and list their loops.
//!
//! - [`ptnet`]: plain place/transition nets; [`pnml`]: PNML read and write.
//! - [`graph`]: graph algorithms shared by every explorer (breadth-first
//!   search with parent links for shortest counterexamples, strongly
//!   connected components, dead states).
//! - [`explore`]: explicit-state exploration of a P/T net's token game (a
//!   bitset engine for 1-safe nets, a counting engine for the others, both
//!   parallel); [`reference`](mod@reference): a plain explorer the tests compare it with.
//! - [`project`]: the project-level verifier (the player's own semantics,
//!   its steps in `project::explorer`, its verdicts in `project::verdict`;
//!   its states kept as bytes by `project_states`, a step's outcome reused
//!   from key to key by `project_steps` for states that differ only in
//!   orders the player cannot read, searched breadth-first on several
//!   threads by `levels`; what it finds without exploring, and the token
//!   game, by `project_warnings`); [`alone`]: each net explored alone, the
//!   single-procedure level; [`export`]: Petrel nets as PNML. Teams are
//!   reduced by `symmetry` (one representative per orbit of
//!   interchangeable vehicles) and `stubborn` (partial-order reduction).
//!
//! Pure computation: no file I/O, no clock (the caller times runs).
//! [`explore`] may use several threads when asked to (scoped, joined before
//! it returns).

pub mod alone;
pub mod exclusive;
pub mod explore;
pub mod export;
pub mod graph;
mod levels;
pub mod pnml;
pub mod project;
mod project_report;
mod project_states;
mod project_steps;
mod project_warnings;
pub mod ptnet;
pub mod reference;
mod stubborn;
mod symmetry;
