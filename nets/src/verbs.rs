//! The vehicle command verbs the net language knows, and their arguments.
//! The gateway maps each verb to MAVLink for ArduPilot and PX4; the loader
//! checks every `command` action against this table.

/// A command verb and the arguments it takes.
#[derive(Debug, Clone, Copy)]
pub struct Verb {
    pub name: &'static str,
    pub required: &'static [&'static str],
    pub optional: &'static [&'static str],
    pub doc: &'static str,
}

/// Every verb, in the order the documentation lists them.
pub const VERBS: &[Verb] = &[
    Verb {
        name: "arm",
        required: &[],
        optional: &["force"],
        doc: "arm the vehicle (force: skip pre-arm checks)",
    },
    Verb {
        name: "disarm",
        required: &[],
        optional: &["force"],
        doc: "disarm the vehicle",
    },
    Verb {
        name: "mode",
        required: &["mode"],
        optional: &[],
        doc: "change flight mode, by name (AUTO, GUIDED, RTL…)",
    },
    Verb {
        name: "takeoff",
        required: &["alt"],
        optional: &["pitch"],
        doc: "take off to alt metres above home",
    },
    Verb {
        name: "land",
        required: &[],
        optional: &["lat", "lon", "alt"],
        doc: "land here, or at lat/lon",
    },
    Verb {
        name: "rtl",
        required: &[],
        optional: &[],
        doc: "return to launch",
    },
    Verb {
        name: "goto",
        required: &["lat", "lon"],
        optional: &["alt", "speed", "radius"],
        doc: "fly to a position (guided)",
    },
    Verb {
        name: "set_speed",
        required: &["speed"],
        optional: &["kind"],
        doc: "change target speed (m/s)",
    },
    Verb {
        name: "upload_mission",
        required: &["items"],
        optional: &[],
        doc: "upload a mission: a list of items {lat, lon, alt, …}",
    },
    Verb {
        name: "start_mission",
        required: &[],
        optional: &["first", "last"],
        doc: "start the uploaded mission (AUTO)",
    },
    Verb {
        name: "set_current",
        required: &["seq"],
        optional: &[],
        doc: "make mission item seq the current one",
    },
    Verb {
        name: "payload_start",
        required: &["payload"],
        optional: &["interval"],
        doc: "start a payload from the project's payload table",
    },
    Verb {
        name: "payload_stop",
        required: &["payload"],
        optional: &[],
        doc: "stop a payload",
    },
];

/// The verb of that name.
pub fn verb(name: &str) -> Option<&'static Verb> {
    VERBS.iter().find(|v| v.name == name)
}
