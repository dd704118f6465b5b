//! # petrel-mission — the plans crews already have, read
//!
//! This crate owns reading a crew's mission plan into one typed form
//! ([`Plan`]): QGroundControl's `.plan` JSON ([`qgc`]) and the `QGC WPL`
//! text format of Mission Planner, MAVProxy and ArduPilot's tools
//! ([`wpl`]), the formats as `../shared/plans/FORMATS.md` sets them out
//! from QGroundControl's, MAVSDK's, pymavlink's and mavros's own readers.
//! It also owns the mission language of issue 35 ("Missions as plans, not
//! 2,000 lines", [`language`]): steps, rules and reactions in a TOML file
//! beside project.toml, checked ([`check()`]), compiled into ordinary net
//! text ([`compile()`]) and served to `nets::load` as a project of nets
//! ([`load()`], [`compile_project`]), with the nets loader's problems in
//! generated text moved back onto the mission line. It lives beside `nets`
//! rather than in it: nothing in the player or the verifier knows a
//! mission.
//!
//! A plan is read whole or refused: a file that is not the format, a wrong
//! version, a bad line or item is a [`PlanError`] that says where
//! (`file:line:col`, or the plan's item index) and what is wrong. What the
//! file holds but no mission item says — a survey pattern whose waypoints
//! QGroundControl did not store, a landing pattern — is kept in
//! [`Plan::unsupported`], named by item index with what to do, for the
//! caller to refuse or report. [`review()`] lists what in a plan that reads
//! Petrel cannot supervise as it stands (a jump repeated for ever, an
//! unknown command, a waypoint without altitude), each with what to do.
//!
//! It never does I/O (the caller reads the file and passes its name and
//! text, or a `nets::source::Sources`), never panics on any input, and
//! knows nothing of links.

pub mod error;
pub mod language;
pub mod plan;
pub mod qgc;
pub mod review;
pub mod wpl;

pub use error::{At, PlanError};
pub use language::check::{check, Known};
pub use language::compile::{compile, NetFile};
pub use language::sources::{compile_project, load, Compiled, CompiledSources, MISSION_KEY};
pub use plan::{
    command_name, Autopilot, Circle, Fence, Format, Item, Origin, Plan, Polygon, Position,
    Unsupported, VehicleType,
};
pub use review::{review, Finding};

/// Reads the plan `text` of the file `name`: a `QGC WPL` file when its
/// first line that is not a comment says so, else a QGroundControl `.plan`.
/// A file that starts otherwise (a MAVProxy fence point list, a CSV) is
/// refused as neither.
pub fn read(name: &str, text: &str) -> Result<Plan, PlanError> {
    let first = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .find(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    match first {
        Some((_, l)) if l.starts_with("QGC WPL") => wpl::read(name, text),
        Some((line, l)) if !l.starts_with('{') => Err(PlanError::new(
            name,
            At::LineCol(line, 1),
            format!(
                "`{}`: neither a QGroundControl plan (JSON) nor a waypoint file (`QGC WPL 110`)",
                l.chars().take(40).collect::<String>()
            ),
        )),
        _ => qgc::read(name, text),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_file_of_neither_format_says_so_at_its_first_line() {
        let e = super::read("f.txt", "# points\n-35.361359\t149.162872\n").expect_err("refused");
        assert_eq!(
            e.to_string(),
            "f.txt:2:1: `-35.361359\t149.162872`: neither a QGroundControl plan (JSON) nor a waypoint file (`QGC WPL 110`)"
        );
    }
}
