//! The layout of a Petrel recording: topics, encodings, schemas, and the
//! JSON of the inputs log. Written by `writer.rs`, read back by `read.rs`;
//! documented in docs/recording.md.

use nets::{Event, Micros, Outcome};
use serde::Deserialize as _;
use serde_json::{json, Value as Json};

/// Every frame as received: a tlog record (8-byte big-endian receive time
/// in µs, then the frame's bytes exactly as on the wire).
pub const RAW: &str = "/mavlink/raw";
/// Every frame the gateway sent, same encoding.
pub const SENT: &str = "/mavlink/sent";
/// Every Supervisor input, in order: what replay feeds back.
pub const INPUTS: &str = "/petrel/inputs";
/// Events elaborated from telemetry.
pub const EVENTS: &str = "/petrel/events";
/// Every effect of the player (firings, markings, commands, calls…).
pub const EFFECTS: &str = "/petrel/effects";
/// The player's digest after each step.
pub const DIGESTS: &str = "/petrel/digests";
/// Vehicle commands and their outcomes.
pub const COMMANDS: &str = "/petrel/commands";
/// Program calls, replies, events and protocol lines.
pub const PROGRAMS: &str = "/petrel/programs";
/// The recorder's own status (what it dropped).
pub const RECORDER: &str = "/petrel/recorder";
/// The vehicle's position (`foxglove.LocationFix`).
pub const LOCATION: &str = "/vehicle/location";
/// Lines for people (`foxglove.Log`).
pub const LOG: &str = "/log";
/// The JSON Schema of `foxglove.Log` (Foxglove's well-known name).
pub const LOG_SCHEMA: &str = r#"{"title":"foxglove.Log","description":"A log message","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}},"level":{"type":"integer","description":"1 debug, 2 info, 3 warning, 4 error, 5 fatal"},"message":{"type":"string"},"name":{"type":"string"},"file":{"type":"string"},"line":{"type":"integer","minimum":0}}}"#;
/// The ground mirror's replica: every report (steps played, checks
/// agreed, gaps, `mirror_resynced`, `mirror_diverged`).
pub const MIRROR_REPLICA: &str = "/mirror/replica";
/// The ground mirror's independent check: `mirror_disagreement`.
pub const MIRROR_CHECK: &str = "/mirror/check";
/// The operator dialog on the ground: questions shown, answers sent.
pub const MIRROR_DIALOG: &str = "/mirror/dialog";
/// Markings of one net: `/petrel/marking/<net>`; the global places are
/// `/petrel/marking/@globals`.
pub const MARKING_PREFIX: &str = "/petrel/marking/";

/// The message encoding of raw frames (MCAP allows custom encodings).
pub const FRAME_ENCODING: &str = "petrel.tlog-record";
/// The schema of raw frames: a name and a description, no machine schema.
pub const FRAME_SCHEMA: &str = "petrel.mavlink.Frame";
pub const FRAME_SCHEMA_ENCODING: &str = "petrel.text";
pub const FRAME_SCHEMA_TEXT: &str = "A MAVLink 1 or 2 frame exactly as received or sent, after an 8-byte big-endian receive time in microseconds (one .tlog record).";

/// The MCAP profile and library of Petrel recordings.
pub const PROFILE: &str = "petrel";
/// The layout version, in the file's metadata `petrel`.
pub const LAYOUT_VERSION: &str = "1";

/// The schema name and loose JSON Schema of each Petrel channel.
pub fn petrel_schema(topic: &str) -> (&'static str, &'static str) {
    match topic {
        INPUTS => (
            "petrel.Input",
            r#"{"type":"object","properties":{"seq":{"type":"integer"},"time_us":{"type":"integer"},"input":{"type":"string","enum":["start","frame","tick","result","event","answer","replica","version"]},"version":{"type":"object","description":"a new version of the project took over","properties":{"number":{"type":"integer"},"files":{"type":"array","items":{"type":"object","properties":{"name":{"type":"string"},"text":{"type":"string"}}}}}},"replica":{"type":"object","description":"the ground mirror's call on its player","properties":{"call":{"type":"string","enum":["restart","record","advance","restore"]},"before":{"type":"integer"},"inputs":{"type":"array"},"state":{"type":"string","description":"(restore) the player's state, hex"}}},"frame":{"type":"integer","description":"index of the frame on /mavlink/raw"},"link":{"type":"integer","description":"the link the frame came in on: a team's links in the order first named (absent: 0)"},"id":{"type":"integer"},"outcome":{"type":"object"},"event":{"type":"object"}}}"#,
        ),
        EVENTS => (
            "petrel.Event",
            r#"{"type":"object","properties":{"seq":{"type":"integer"},"time_us":{"type":"integer"},"event":{"type":"string"},"category":{"type":"string"},"params":{"type":"object"},"sysid":{"type":"integer"},"compid":{"type":"integer"}}}"#,
        ),
        EFFECTS => (
            "petrel.Effect",
            r#"{"type":"object","properties":{"seq":{"type":"integer"},"t":{"type":"number"},"time_us":{"type":"integer"},"effect":{"type":"string"},"net":{"type":["string","null"]}}}"#,
        ),
        DIGESTS => (
            "petrel.Digest",
            r#"{"type":"object","properties":{"seq":{"type":"integer"},"time_us":{"type":"integer"},"digest":{"type":"string","description":"SHA-256 of the player's state"},"boot_ms":{"type":["integer","null"],"description":"the autopilot's SYSTEM_TIME.time_boot_ms, last seen"},"effects":{"type":"integer"}}}"#,
        ),
        COMMANDS => (
            "petrel.Command",
            r#"{"type":"object","properties":{"seq":{"type":"integer"},"time_us":{"type":"integer"},"id":{"type":"integer"},"verb":{"type":"string"},"args":{"type":"object"},"outcome":{"type":"object"}}}"#,
        ),
        PROGRAMS => (
            "petrel.Program",
            r#"{"type":"object","properties":{"seq":{"type":"integer"},"time_us":{"type":"integer"},"program":{"type":"string"},"kind":{"type":"string"}}}"#,
        ),
        RECORDER => (
            "petrel.RecorderStatus",
            r#"{"type":"object","properties":{"time_us":{"type":"integer"},"written_steps":{"type":"integer"},"last_seq":{"type":["integer","null"]},"dropped":{"type":"integer","description":"entries dropped because the writer fell behind, since the start"},"dropped_steps":{"type":"integer","description":"of which Supervisor steps"}}}"#,
        ),
        MIRROR_REPLICA => (
            "petrel.MirrorReport",
            r#"{"type":"object","properties":{"time_us":{"type":"integer","description":"ground time"},"report":{"type":"string","enum":["step","timers","agreed","gap","mirror_resynced","mirror_diverged"]},"step":{"type":"integer","description":"the vehicle's step"},"vehicle_time_us":{"type":"integer"}}}"#,
        ),
        MIRROR_CHECK => (
            "petrel.MirrorDisagreement",
            r#"{"type":"object","properties":{"time_us":{"type":"integer","description":"ground time"},"event":{"type":"string"},"seen_by":{"type":"string","enum":["ground","vehicle"]}}}"#,
        ),
        MIRROR_DIALOG => (
            "petrel.MirrorDialog",
            r#"{"type":"object","properties":{"time_us":{"type":"integer","description":"ground time"},"kind":{"type":"string","enum":["question","answer_sent","answer_not_sent"]},"id":{"type":"integer"},"choice":{"type":"string"}}}"#,
        ),
        _ => (
            "petrel.Marking",
            r#"{"type":"object","properties":{"seq":{"type":"integer"},"time_us":{"type":"integer"},"marked":{"type":"array","items":{"type":"string"}},"tokens":{"type":"integer"}}}"#,
        ),
    }
}

/// An outcome as JSON: `{"done": params}` or `{"failed": reason}` (its
/// serde form, read back by [`outcome_from`]).
pub fn outcome_json(o: &Outcome) -> Json {
    serde_json::to_value(o).unwrap_or(Json::Null)
}

pub fn outcome_from(json: &Json) -> Option<Outcome> {
    Outcome::deserialize(json).ok()
}

/// An event as JSON: `{"name", "category", "params"}` (its serde form).
pub fn event_json(e: &Event) -> Json {
    serde_json::to_value(e).unwrap_or(Json::Null)
}

pub fn event_from(json: &Json) -> Option<Event> {
    Event::deserialize(json).ok()
}

/// How a flight was elaborated, recorded with its start so that replay
/// elaborates the same way: the config, the profile's name, and the text of
/// each of its layers (so that a replay needs neither the profile file nor
/// the same built-in profile text).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Setup {
    pub config: elaboration::Config,
    /// `ardupilot`, `px4`, a file's path, or empty (unknown).
    pub profile: String,
    /// `(file name, TOML text)`, base first; empty in recordings made
    /// before layers were recorded.
    pub layers: Vec<(String, String)>,
}

pub fn setup_json(setup: &Setup) -> Json {
    let config = &setup.config;
    let layers: Vec<Json> = setup
        .layers
        .iter()
        .map(|(name, text)| json!({"name": name, "text": text}))
        .collect();
    json!({
        "sysid": config.sysid,
        "compid": config.compid,
        "firmware": config.firmware.map(|f| f.as_str()),
        "tick_us": config.tick_us,
        "profile": setup.profile,
        "layers": layers,
    })
}

/// Reads [`setup_json`] back.
pub fn setup_from(json: &Json) -> Option<Setup> {
    let id = |key: &str| match json.get(key) {
        None | Some(Json::Null) => Some(None),
        Some(v) => v.as_u64().and_then(|n| u8::try_from(n).ok()).map(Some),
    };
    let firmware = match json.get("firmware") {
        None | Some(Json::Null) => None,
        Some(v) => Some(elaboration::Firmware::parse(v.as_str()?)?),
    };
    let config = elaboration::Config {
        sysid: id("sysid")?,
        compid: id("compid")?,
        firmware,
        tick_us: json.get("tick_us")?.as_u64()?,
    };
    let profile = json.get("profile").and_then(Json::as_str).unwrap_or("");
    let mut layers = Vec::new();
    match json.get("layers") {
        None | Some(Json::Null) => {}
        Some(Json::Array(list)) => {
            for layer in list {
                let name = layer.get("name")?.as_str()?;
                let text = layer.get("text")?.as_str()?;
                layers.push((name.to_owned(), text.to_owned()));
            }
        }
        Some(_) => return None,
    }
    Some(Setup {
        config,
        profile: profile.to_owned(),
        layers,
    })
}

/// One Supervisor input as recorded (frames by their index on [`RAW`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// The player's start (step 0).
    Start,
    Frame(u64),
    Tick,
    Result {
        id: u64,
        outcome: Outcome,
    },
    Event(Event),
    /// The operator's answer to question `id` (signature checked).
    Answer {
        id: u64,
        choice: String,
    },
    /// A call of the ground mirror's replica on its player, as the JSON
    /// `mirror::call::call_json` makes (a mirror's recording:
    /// docs/mirror.md, "The mirror's recording").
    Replica(Json),
    /// A new version of the project took over (docs/run.md, "A new
    /// version in flight"): its number and files, `(path, text)`, from
    /// which replay loads it.
    Version {
        number: u32,
        files: Vec<(String, String)>,
    },
}

/// The JSON of an input on [`INPUTS`].
pub fn input_json(seq: u64, time: Micros, input: &Input) -> Json {
    let mut v = json!({"seq": seq, "time_us": time});
    let o = v.as_object_mut().expect("an object");
    match input {
        Input::Start => {
            o.insert("input".into(), json!("start"));
        }
        Input::Frame(i) => {
            o.insert("input".into(), json!("frame"));
            o.insert("frame".into(), json!(i));
        }
        Input::Tick => {
            o.insert("input".into(), json!("tick"));
        }
        Input::Result { id, outcome } => {
            o.insert("input".into(), json!("result"));
            o.insert("id".into(), json!(id));
            o.insert("outcome".into(), outcome_json(outcome));
        }
        Input::Event(e) => {
            o.insert("input".into(), json!("event"));
            o.insert("event".into(), event_json(e));
        }
        Input::Answer { id, choice } => {
            o.insert("input".into(), json!("answer"));
            o.insert("id".into(), json!(id));
            o.insert("choice".into(), json!(choice));
        }
        Input::Replica(call) => {
            o.insert("input".into(), json!("replica"));
            o.insert("replica".into(), call.clone());
        }
        Input::Version { number, files } => {
            o.insert("input".into(), json!("version"));
            let files: Vec<Json> = files
                .iter()
                .map(|(name, text)| json!({"name": name, "text": text}))
                .collect();
            o.insert("version".into(), json!({"number": number, "files": files}));
        }
    }
    v
}

/// An input line as read (typed, for speed: a flight has one per step).
#[derive(serde::Deserialize)]
struct InputLine<'a> {
    seq: u64,
    time_us: u64,
    #[serde(borrow)]
    input: std::borrow::Cow<'a, str>,
    frame: Option<u64>,
    link: Option<u64>,
    id: Option<u64>,
    outcome: Option<Json>,
    event: Option<Json>,
    setup: Option<Json>,
    choice: Option<String>,
    replica: Option<Json>,
    version: Option<VersionLine>,
}

/// A version's number and files, as [`input_json`] writes them.
#[derive(serde::Deserialize)]
struct VersionLine {
    number: u32,
    files: Vec<FileLine>,
}

#[derive(serde::Deserialize)]
struct FileLine {
    name: String,
    text: String,
}

/// Reads an input back from its JSON bytes: `(seq, time, input)`.
pub fn input_from(bytes: &[u8]) -> Option<(u64, Micros, Input)> {
    input_with_setup(bytes).map(|(i, _, _)| i)
}

/// Reads an input back, with the setup a start carries and the link a
/// frame came in on (`link`: a team's links, in the order first named;
/// absent in recordings made before it, and in a mirror's).
#[allow(clippy::type_complexity)]
pub fn input_with_setup(bytes: &[u8]) -> Option<((u64, Micros, Input), Option<Json>, Option<u64>)> {
    let line: InputLine = serde_json::from_slice(bytes).ok()?;
    let input = match &*line.input {
        "start" => Input::Start,
        "frame" => Input::Frame(line.frame?),
        "tick" => Input::Tick,
        "result" => Input::Result {
            id: line.id?,
            outcome: outcome_from(line.outcome.as_ref()?)?,
        },
        "event" => Input::Event(event_from(line.event.as_ref()?)?),
        "answer" => Input::Answer {
            id: line.id?,
            choice: line.choice?,
        },
        "replica" => match line.replica? {
            call @ Json::Object(_) => Input::Replica(call),
            _ => return None,
        },
        "version" => {
            let version = line.version?;
            Input::Version {
                number: version.number,
                files: version
                    .files
                    .into_iter()
                    .map(|f| (f.name, f.text))
                    .collect(),
            }
        }
        _ => return None,
    };
    Some(((line.seq, line.time_us, input), line.setup, line.link))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nets::{Category, Value};

    #[test]
    fn inputs_round_trip_through_json() {
        let inputs = [
            Input::Start,
            Input::Frame(42),
            Input::Tick,
            Input::Result {
                id: 7,
                outcome: Outcome::Done(
                    [
                        ("lat".to_owned(), Value::Float(43.5)),
                        ("n".to_owned(), Value::Int(3)),
                        ("ok".to_owned(), Value::Bool(true)),
                    ]
                    .into_iter()
                    .collect(),
                ),
            },
            Input::Result {
                id: 8,
                outcome: Outcome::Failed("timeout".into()),
            },
            Input::Answer {
                id: 9,
                choice: "yes".into(),
            },
            Input::Event(
                Event::new("payload_failure")
                    .category(Category::Mission)
                    .param("component", "camera"),
            ),
            Input::Replica(
                json!({"call": "record", "before": 900, "inputs": [{"kind": "answered", "time_us": 990, "id": 5, "choice": "no"}]}),
            ),
            Input::Replica(json!({"call": "advance"})),
            Input::Version {
                number: 2,
                files: vec![
                    ("project.toml".into(), "name = \"p\"\n".into()),
                    ("a.toml".into(), "# \"quoted\" é\n".into()),
                ],
            },
        ];
        for (i, input) in inputs.iter().enumerate() {
            let text = input_json(i as u64, 1_000 + i as u64, input).to_string();
            assert_eq!(
                input_from(text.as_bytes()),
                Some((i as u64, 1_000 + i as u64, input.clone())),
                "{text}"
            );
        }
        assert_eq!(input_from(br#"{"seq": 1, "time_us": 2}"#), None);
        assert_eq!(
            input_from(br#"{"seq": 1, "time_us": 2, "input": "warp"}"#),
            None
        );
        assert_eq!(
            input_from(br#"{"seq": 1, "time_us": 2, "input": "frame"}"#),
            None
        );
        assert_eq!(input_from(b"{\"seq\": 1, "), None);
        assert_eq!(
            input_from(br#"{"seq": 1, "time_us": 2, "input": "replica"}"#),
            None
        );
        assert_eq!(
            input_from(br#"{"seq": 1, "time_us": 2, "input": "replica", "replica": "advance"}"#),
            None
        );
    }

    #[test]
    fn a_frames_link_is_read_back_and_absent_in_older_recordings() {
        let mut line = input_json(7, 1_000, &Input::Frame(3));
        line["link"] = json!(1);
        let read = input_with_setup(line.to_string().as_bytes()).map(|(i, _, l)| (i, l));
        assert_eq!(read, Some(((7, 1_000, Input::Frame(3)), Some(1))));
        // Written before links were: link 0 implied, the input unchanged.
        let old = br#"{"seq": 7, "time_us": 1000, "input": "frame", "frame": 3}"#;
        let read = input_with_setup(old).map(|(i, _, l)| (i, l));
        assert_eq!(read, Some(((7, 1_000, Input::Frame(3)), None)));
    }

    #[test]
    fn the_setup_round_trips_through_json() {
        let config = elaboration::Config {
            sysid: Some(3),
            compid: None,
            firmware: Some(elaboration::Firmware::Plane),
            tick_us: 50_000,
        };
        let setup = Setup {
            config,
            profile: "extra.toml".into(),
            layers: vec![
                ("ardupilot.toml".into(), "[rules]\n".into()),
                ("extra.toml".into(), "# mine\n".into()),
            ],
        };
        assert_eq!(setup_from(&setup_json(&setup)), Some(setup));
        let d = Setup::default();
        assert_eq!(setup_from(&setup_json(&d)), Some(d));
        // Recordings from before layers were recorded.
        assert_eq!(
            setup_from(&json!({"tick_us": 1, "profile": "px4"})).map(|s| s.layers.len()),
            Some(0)
        );
        assert_eq!(
            setup_from(&json!({"tick_us": 1, "layers": [{"name": 1}]})),
            None
        );
        assert_eq!(setup_from(&json!({"sysid": 300, "tick_us": 1})), None);
        assert_eq!(
            setup_from(&json!({"firmware": "glider", "tick_us": 1})),
            None
        );
    }
}
