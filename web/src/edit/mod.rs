//! `petrel edit PROJECT`: EdiPet's other half (docs/monitor.md,
//! "Editing"). The monitor's page in editing mode: places, transitions and
//! arcs added, moved, renamed and deleted, a transition's event, guard and
//! actions set; each change written back to the net's TOML file with
//! `toml_edit` (what it does not concern kept byte for byte), the positions
//! a person gave kept in the project's `layout.toml`, then the project
//! loaded again (its errors shown on the elements) and checked in the
//! background (`petrel check`, its counterexample stepped through on the
//! nets). A net can be added (its own file, its `[[net]]` table appended
//! to project.toml), deleted (refused while another net names it) or
//! renamed (with every action naming it, and its file if named after
//! it), or made active at start or not (its `[[net]]` table's `active`),
//! and the session's edits undone one at a time, each file back to its
//! exact bytes.
//!
//! Pure: the edits (`op.rs`), the edit core over `toml_edit` documents
//! (`draft.rs`), the layout file (`positions.rs`), the drawing of a draft
//! (`sketch.rs`), load problems mapped to elements (`locate.rs`) and a
//! counterexample's markings (`replay.rs`). I/O: the files, writes and the
//! background check (`session.rs`) and the routes (`server.rs`).

pub mod draft;
pub mod locate;
pub mod op;
pub mod positions;
pub mod replay;
pub mod server;
pub mod session;
pub mod sketch;
