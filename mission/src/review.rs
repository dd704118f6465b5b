//! What in a plan Petrel cannot supervise as it stands, each named where
//! it is with what to do: the list `petrel new --from-plan` will print
//! (issue 35). Reading a plan ([`crate::read`]) refuses what is not the
//! format; this reviews what is the format but not a mission Petrel can
//! follow and bound.

use crate::plan::{command_name, Origin, Plan};

/// One thing to fix or to know.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Finding {
    pub origin: Option<Origin>,
    /// The item's sequence, when it is one.
    pub seq: Option<u16>,
    pub what: String,
    pub remedy: String,
}

const DO_JUMP: u16 = 177;

/// NAV commands that fly to the item's position: a missing coordinate
/// leaves the vehicle's target undefined.
const NAV_TO_POSITION: &[u16] = &[
    16, // NAV_WAYPOINT
    17, // NAV_LOITER_UNLIM
    18, // NAV_LOITER_TURNS
    19, // NAV_LOITER_TIME
    31, // NAV_LOITER_TO_ALT
    82, // NAV_SPLINE_WAYPOINT
];

/// Everything in `plan` Petrel cannot supervise as it stands, in file
/// order.
pub fn review(plan: &Plan) -> Vec<Finding> {
    let mut out: Vec<Finding> = plan
        .unsupported
        .iter()
        .map(|u| Finding {
            origin: Some(u.origin),
            seq: None,
            what: u.what.clone(),
            remedy: u.remedy.clone(),
        })
        .collect();
    if plan.items.is_empty() {
        out.push(Finding {
            origin: None,
            seq: None,
            what: "no mission items (a fence or rally plan)".to_owned(),
            remedy: "add the mission, or give this file as the project's fence".to_owned(),
        });
    }
    let last = plan.items.len();
    for item in &plan.items {
        let at = |what: String, remedy: &str| Finding {
            origin: Some(item.origin),
            seq: Some(item.seq),
            what,
            remedy: remedy.to_owned(),
        };
        let name = command_name(item.command);
        if name.starts_with("command ") {
            out.push(at(
                format!("{name} is not in MAVLink's ardupilotmega dialect"),
                "Petrel cannot tell what the vehicle does there: replace it with a standard command",
            ));
        }
        if item.command == DO_JUMP {
            let target = item.params[0];
            let repeat = item.params[1];
            if !(target >= 1.0 && target <= last as f64 && target.fract() == 0.0) {
                out.push(at(
                    format!("DO_JUMP to item {target}, which the mission does not have"),
                    "point it at an item of the mission",
                ));
            } else if repeat < 0.0 {
                out.push(at(
                    format!("DO_JUMP to item {target} repeats for ever"),
                    "Petrel cannot bound the mission's time and battery: give the jump a repeat count",
                ));
            }
        }
        if NAV_TO_POSITION.contains(&item.command) && item.has_position() && !item.z.is_finite() {
            out.push(at(
                format!("{name} without an altitude"),
                "QGroundControl computes it from terrain data (altitude mode \"calc above terrain\"): open the plan with terrain data and save it, or give the altitude",
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_endless_jump_an_unknown_command_and_a_missing_altitude_are_found() {
        let text = "QGC WPL 110\n\
            0\t1\t0\t16\t0\t0\t0\t0\t1\t2\t3\t1\n\
            1\t0\t3\t16\t0\t0\t0\t0\t1.1\t2.1\tnan\t1\n\
            2\t0\t3\t31337\t0\t0\t0\t0\t0\t0\t0\t1\n\
            3\t0\t0\t177\t1\t-1\t0\t0\t0\t0\t0\t1\n\
            4\t0\t0\t177\t9\t2\t0\t0\t0\t0\t0\t1\n";
        let plan = crate::read("m.txt", text).expect("reads");
        let found: Vec<(Option<u16>, String)> =
            review(&plan).into_iter().map(|f| (f.seq, f.what)).collect();
        assert_eq!(
            found,
            [
                (Some(1), "NAV_WAYPOINT without an altitude".to_owned()),
                (
                    Some(2),
                    "command 31337 is not in MAVLink's ardupilotmega dialect".to_owned()
                ),
                (Some(3), "DO_JUMP to item 1 repeats for ever".to_owned()),
                (
                    Some(4),
                    "DO_JUMP to item 9, which the mission does not have".to_owned()
                ),
            ]
        );
    }

    #[test]
    fn a_plain_mission_has_nothing_to_say() {
        let text = "QGC WPL 110\n\
            0\t1\t0\t16\t0\t0\t0\t0\t1\t2\t3\t1\n\
            1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t20\t1\n\
            2\t0\t3\t16\t0\t0\t0\t0\t1.1\t2.1\t50\t1\n\
            3\t0\t0\t177\t2\t3\t0\t0\t0\t0\t0\t1\n\
            4\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1\n";
        let plan = crate::read("m.txt", text).expect("reads");
        assert_eq!(review(&plan), []);
    }
}
