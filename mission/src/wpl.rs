//! The `QGC WPL` text format (Mission Planner `.waypoints`, MAVProxy and
//! ArduPilot `.txt`): `QGC WPL 110` or `120`, then one item a line, twelve
//! fields — INDEX, CURRENT, FRAME, COMMAND, PARAM1-4, latitude, longitude,
//! altitude, AUTOCONTINUE.
//!
//! Read as QGroundControl reads it, and as leniently as pymavlink where the
//! files in the wild need it: fields split on tabs, or on any whitespace
//! in a line without a tab; `#` comment lines and blank lines skipped
//! (before the header too); CRLF or LF. In `110`, row 0 is home
//! (a row 0 other than a waypoint is noted in `Plan::unsupported`; a fence
//! or rally row is none) and the items follow from sequence 1; in `120`
//! there is no home row, the rows take sequences 1 on and each DO_JUMP's
//! target moves up by one. Fence commands (NAV_FENCE_*: 5000-5005) go to
//! the fence and rally points (NAV_RALLY_POINT, 5100) to the rally list:
//! ArduPilot's tools save them in this format, and only the commands say
//! so.

use crate::error::{At, PlanError};
use crate::plan::{
    command_name, Circle, Fence, Format, Item, Origin, Plan, Polygon, Position, Unsupported,
};

const NAV_WAYPOINT: u16 = 16;
const DO_JUMP: u16 = 177;
const FENCE_RETURN_POINT: u16 = 5000;
const FENCE_POLYGON_INCLUSION: u16 = 5001;
const FENCE_POLYGON_EXCLUSION: u16 = 5002;
const FENCE_CIRCLE_INCLUSION: u16 = 5003;
const FENCE_CIRCLE_EXCLUSION: u16 = 5004;
const FENCE_HOME_CIRCLE_INCLUSION: u16 = 5005;
const RALLY_POINT: u16 = 5100;

/// One row: its fields, and where each starts (column, from 1).
struct Row<'a> {
    line: usize,
    fields: Vec<(&'a str, usize)>,
}

fn split(line: &str) -> Vec<(&str, usize)> {
    let mut out = Vec::new();
    if line.contains('\t') {
        let mut col = 1;
        for f in line.split('\t') {
            let lead = f.len() - f.trim_start().len();
            out.push((f.trim(), col + f[..lead].chars().count()));
            col += f.chars().count() + 1;
        }
    } else {
        let mut start = None;
        for (i, c) in line.char_indices() {
            match (c.is_whitespace(), start) {
                (false, None) => start = Some(i),
                (true, Some(s)) => {
                    out.push((&line[s..i], line[..s].chars().count() + 1));
                    start = None;
                }
                _ => {}
            }
        }
        if let Some(s) = start {
            out.push((&line[s..], line[..s].chars().count() + 1));
        }
    }
    out
}

/// Reads a `QGC WPL` file `name` whose text is `text`.
pub fn read(name: &str, text: &str) -> Result<Plan, PlanError> {
    let err = |line: usize, col: usize, m: String| PlanError::new(name, At::LineCol(line, col), m);
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let Some((header_line, header)) = lines.next() else {
        return Err(PlanError::new(
            name,
            At::File,
            "empty: no `QGC WPL 110` header",
        ));
    };
    let tokens: Vec<&str> = header.split_whitespace().collect();
    let format = match tokens.as_slice() {
        ["QGC", "WPL", "110"] => Format::Wpl110,
        ["QGC", "WPL", "120"] => Format::Wpl120,
        ["QGC", "WPL", v] => {
            return Err(err(
                header_line,
                header.find(v).map_or(1, |i| i + 1),
                format!("QGC WPL version {v}: only 110 and 120 exist"),
            ))
        }
        _ => {
            return Err(err(
                header_line,
                1,
                format!(
                    "`{}` is no QGC WPL header (expected `QGC WPL 110`)",
                    header.chars().take(40).collect::<String>()
                ),
            ))
        }
    };
    let rows: Vec<Row> = lines
        .map(|(line, l)| Row {
            line,
            fields: split(l),
        })
        .collect();
    let mut plan = Plan {
        format,
        autopilot: None,
        vehicle: None,
        home: None,
        items: Vec::new(),
        fence: Fence::default(),
        rally: Vec::new(),
        unsupported: Vec::new(),
    };
    let mut polygon: Option<(Polygon, usize)> = None;
    for (r, row) in rows.iter().enumerate() {
        if row.fields.len() != 12 {
            return Err(err(
                row.line,
                1,
                format!(
                    "{} fields, a QGC WPL row has 12 (INDEX CURRENT FRAME COMMAND P1 P2 P3 P4 LAT LON ALT AUTOCONTINUE)",
                    row.fields.len()
                ),
            ));
        }
        let number = |i: usize, what: &str| -> Result<f64, PlanError> {
            let (text, col) = row.fields[i];
            text.parse::<f64>()
                .map_err(|_| err(row.line, col, format!("{what} `{text}` is not a number")))
        };
        let integer = |i: usize, what: &str, max: f64| -> Result<f64, PlanError> {
            let v = number(i, what)?;
            if v.fract() != 0.0 || !(0.0..=max).contains(&v) {
                let (text, col) = row.fields[i];
                return Err(err(
                    row.line,
                    col,
                    format!("{what} `{text}` is not a whole number from 0 to {max}"),
                ));
            }
            Ok(v)
        };
        integer(0, "INDEX", f64::from(u16::MAX))?;
        let frame = integer(2, "FRAME", f64::from(u8::MAX))? as u8;
        let command = integer(3, "COMMAND", f64::from(u16::MAX))? as u16;
        let mut params = [0.0; 4];
        for (k, p) in params.iter_mut().enumerate() {
            *p = number(4 + k, &format!("PARAM{}", k + 1))?;
        }
        let (x, y, z) = (
            number(8, "latitude")?,
            number(9, "longitude")?,
            number(10, "altitude")?,
        );
        let autocontinue = integer(11, "AUTOCONTINUE", 1.0)? != 0.0;
        // Row 0 of a 110 file is home, unless it is a fence or rally row
        // (a fence file's first row is its return point).
        if r == 0 && format == Format::Wpl110 && command < FENCE_RETURN_POINT {
            plan.home = Some(Position {
                lat: x,
                lon: y,
                alt: z,
            });
            if command != NAV_WAYPOINT {
                plan.unsupported.push(Unsupported {
                    origin: Origin::Line(row.line),
                    what: format!("row 0 is {}, read as home", command_name(command)),
                    remedy: "QGroundControl and ArduPilot read row 0 of a QGC WPL 110 file as home: if it is meant as the first item (as some PX4 files do), put a home NAV_WAYPOINT row before it and number the rows again".to_owned(),
                });
            }
            continue;
        }
        // Fence vertices come in runs of `p1` for one polygon.
        if let Some((p, left)) = polygon.take() {
            let same = matches!(
                (command, p.inclusion),
                (FENCE_POLYGON_INCLUSION, true) | (FENCE_POLYGON_EXCLUSION, false)
            );
            if same && left > 0 {
                let mut p = p;
                p.vertices.push((x, y));
                if left == 1 {
                    plan.fence.polygons.push(p);
                } else {
                    polygon = Some((p, left - 1));
                }
                continue;
            }
            return Err(err(
                row.line,
                1,
                format!(
                    "a fence polygon of {} vertices ends after {}",
                    p.vertices.len() + left,
                    p.vertices.len()
                ),
            ));
        }
        match command {
            FENCE_RETURN_POINT => {
                plan.fence.breach_return = Some(Position {
                    lat: x,
                    lon: y,
                    alt: z,
                });
            }
            FENCE_POLYGON_INCLUSION | FENCE_POLYGON_EXCLUSION => {
                let count = params[0];
                if count.fract() != 0.0 || !(3.0..=1000.0).contains(&count) {
                    return Err(err(
                        row.line,
                        row.fields[4].1,
                        format!("a fence polygon of {count} vertices (3 at least)"),
                    ));
                }
                let p = Polygon {
                    inclusion: command == FENCE_POLYGON_INCLUSION,
                    vertices: vec![(x, y)],
                };
                polygon = Some((p, count as usize - 1));
            }
            FENCE_CIRCLE_INCLUSION | FENCE_CIRCLE_EXCLUSION | FENCE_HOME_CIRCLE_INCLUSION => {
                plan.fence.circles.push(Circle {
                    inclusion: command != FENCE_CIRCLE_EXCLUSION,
                    center: (x, y),
                    radius: params[0],
                });
            }
            RALLY_POINT => plan.rally.push(Position {
                lat: x,
                lon: y,
                alt: z,
            }),
            _ => {
                let seq = plan.items.len() + 1;
                let seq = u16::try_from(seq)
                    .map_err(|_| err(row.line, 1, "more than 65,535 items".to_owned()))?;
                if command == DO_JUMP && format == Format::Wpl120 {
                    params[0] += 1.0;
                }
                plan.items.push(Item {
                    seq,
                    command,
                    frame,
                    params,
                    x,
                    y,
                    z,
                    autocontinue,
                    origin: Origin::Line(row.line),
                });
            }
        }
    }
    if let Some((p, left)) = polygon {
        let last = rows.last().map_or(header_line, |r| r.line);
        return Err(err(
            last,
            1,
            format!(
                "the file ends inside a fence polygon of {} vertices ({} missing)",
                p.vertices.len() + left,
                left
            ),
        ));
    }
    Ok(plan)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MISSION: &str = "QGC WPL 110\r\n\
        0\t1\t0\t16\t0\t0\t0\t0\t-35.363262\t149.165237\t584.090000\t1\r\n\
        1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t20\t1\r\n\
        2\t0\t3\t16\t0\t0\t0\t0\t-35.36\t149.16\t100\t1\r\n\
        3\t0\t0\t177\t2\t3\t0\t0\t0\t0\t0\t1\r\n";

    #[test]
    fn a_mission_reads_with_home_and_items_from_one() {
        let plan = read("m.waypoints", MISSION).expect("reads");
        assert_eq!(plan.format, Format::Wpl110);
        let home = plan.home.expect("home");
        assert_eq!(
            (home.lat, home.lon, home.alt),
            (-35.363262, 149.165237, 584.09)
        );
        let seqs: Vec<(u16, String)> = plan
            .items
            .iter()
            .map(|i| (i.seq, i.command_name()))
            .collect();
        assert_eq!(
            seqs,
            [
                (1, "NAV_TAKEOFF".to_owned()),
                (2, "NAV_WAYPOINT".to_owned()),
                (3, "DO_JUMP".to_owned())
            ]
        );
        assert!(!plan.items[0].has_position());
        assert_eq!(plan.items[2].params[0], 2.0);
        assert_eq!(plan.items[1].origin, Origin::Line(4));
    }

    #[test]
    fn version_120_has_no_home_and_moves_jump_targets() {
        let text = "QGC WPL 120\n0\t1\t3\t16\t0\t0\t0\t0\t1\t2\t30\t1\n1\t0\t0\t177\t0\t1\t0\t0\t0\t0\t0\t1\n";
        let plan = read("m.txt", text).expect("reads");
        assert!(plan.home.is_none());
        assert_eq!(plan.items[0].seq, 1);
        assert_eq!(plan.items[1].params[0], 1.0);
    }

    #[test]
    fn spaces_comments_and_a_missing_final_newline_are_read() {
        let text =
            "# exported\nQGC WPL 110\n0 1 0 16 0 0 0 0 1 2 3 1\n\n1 0 3 16 0 0 0 0 1.5 2.5 40 1";
        let plan = read("m.txt", text).expect("reads");
        assert_eq!(plan.items.len(), 1);
        assert_eq!(plan.items[0].z, 40.0);
    }

    #[test]
    fn fence_and_rally_commands_go_to_the_fence_and_the_rally_points() {
        let text = "QGC WPL 110\n\
            0\t1\t0\t16\t0\t0\t0\t0\t1\t2\t3\t1\n\
            1\t0\t0\t5000\t0\t0\t0\t0\t1.1\t2.1\t0\t1\n\
            2\t0\t0\t5001\t3\t0\t0\t0\t1.0\t2.0\t0\t1\n\
            3\t0\t0\t5001\t3\t0\t0\t0\t1.0\t2.2\t0\t1\n\
            4\t0\t0\t5001\t3\t0\t0\t0\t1.2\t2.2\t0\t1\n\
            5\t0\t0\t5004\t50\t0\t0\t0\t1.1\t2.1\t0\t1\n\
            6\t0\t3\t5100\t0\t0\t0\t0\t1.05\t2.05\t30\t1\n";
        let plan = read("f.txt", text).expect("reads");
        assert!(plan.items.is_empty());
        assert_eq!(plan.fence.polygons.len(), 1);
        assert_eq!(plan.fence.polygons[0].vertices.len(), 3);
        assert!(plan.fence.polygons[0].inclusion);
        assert_eq!(plan.fence.circles[0].radius, 50.0);
        assert!(!plan.fence.circles[0].inclusion);
        assert!(plan.fence.breach_return.is_some());
        assert_eq!(plan.rally.len(), 1);
    }

    #[test]
    fn bad_files_say_where_and_why() {
        let cases: &[(&str, &str)] = &[
            ("", "m.txt: empty: no `QGC WPL 110` header"),
            ("QGC WPL 100\n", "m.txt:1:9: QGC WPL version 100: only 110 and 120 exist"),
            ("{\"fileType\": \"Plan\"}\n", "m.txt:1:1: `{\"fileType\": \"Plan\"}` is no QGC WPL header (expected `QGC WPL 110`)"),
            ("QGC WPL 110\n0\t1\t0\t16\t0\n", "m.txt:2:1: 5 fields, a QGC WPL row has 12 (INDEX CURRENT FRAME COMMAND P1 P2 P3 P4 LAT LON ALT AUTOCONTINUE)"),
            ("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\tnorth\t2\t3\t1\n", "m.txt:2:18: latitude `north` is not a number"),
            ("QGC WPL 110\n0\t1\t0\t16.5\t0\t0\t0\t0\t1\t2\t3\t1\n", "m.txt:2:7: COMMAND `16.5` is not a whole number from 0 to 65535"),
            ("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t1\t2\t3\t1\n1\t0\t0\t5001\t4\t0\t0\t0\t1\t2\t0\t1\n", "m.txt:3:1: the file ends inside a fence polygon of 4 vertices (3 missing)"),
        ];
        for (text, want) in cases {
            let e = read("m.txt", text).expect_err(text);
            assert_eq!(e.to_string(), *want, "{text:?}");
        }
    }
}
