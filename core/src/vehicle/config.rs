//! How the commander is set up: who it speaks for, whom it commands, the
//! firmware family, the payload table, and its timing. Read from the
//! `[gateway]` table of project.toml (see docs/vehicle.md).

use std::collections::BTreeMap;

use elaboration::Firmware;
use nets::Micros;

use super::parameters::Expected;

/// MAV_COMP_ID_ONBOARD_COMPUTER: the component we speak as.
pub const ONBOARD_COMPUTER: u8 = 191;

/// One entry of the payload table: what `payload_start` / `payload_stop`
/// do for a payload name.
#[derive(Debug, Clone, PartialEq)]
pub enum Payload {
    /// A MAVLink camera component: MAV_CMD_IMAGE_START_CAPTURE /
    /// IMAGE_STOP_CAPTURE addressed to it.
    Camera { component: u8 },
    /// A relay: MAV_CMD_DO_SET_RELAY instance, `start`/`stop` settings
    /// (defaults 1 and 0).
    Relay { instance: u8, start: u8, stop: u8 },
    /// A servo output: MAV_CMD_DO_SET_SERVO instance, PWM for start and stop.
    Servo { instance: u8, start: u16, stop: u16 },
}

/// Retry and timeout rules (all microseconds).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// How long to wait for a COMMAND_ACK (or a mission reply) before resending.
    pub ack_timeout: Micros,
    /// Resends after a missing ack (so `retries + 1` transmissions at most).
    pub retries: u8,
    /// Resends after TEMPORARILY_REJECTED, each after `ack_timeout`.
    pub rejected_retries: u8,
    /// After IN_PROGRESS, how long to wait for the next ack before failing.
    pub in_progress_timeout: Micros,
    /// Mission upload: resends of MISSION_COUNT or of the last item.
    pub mission_retries: u8,
    /// Silence from the autopilot after which the link counts as lost.
    pub link_timeout: Micros,
    /// Period of our HEARTBEAT.
    pub heartbeat_period: Micros,
}

impl Default for Timing {
    fn default() -> Self {
        Timing {
            ack_timeout: 1_000_000,
            retries: 3,
            rejected_retries: 3,
            in_progress_timeout: 10_000_000,
            mission_retries: 5,
            link_timeout: 3_000_000,
            heartbeat_period: 1_000_000,
        }
    }
}

/// Everything the commander needs to know before it hears the vehicle.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VehicleConfig {
    /// The vehicle's system id; learned from the autopilot's HEARTBEAT when
    /// `None`. We speak under it.
    pub system: Option<u8>,
    /// The autopilot's component id; learned from its HEARTBEAT when `None`.
    pub autopilot_component: Option<u8>,
    /// Our component id (191 unless configured).
    pub component: Option<u8>,
    /// The firmware family; from the autopilot's HEARTBEAT when `None`.
    pub firmware: Option<Firmware>,
    /// An ArduPlane QuadPlane: `takeoff` is a VTOL NAV_TAKEOFF, `land` is QLAND.
    pub quadplane: bool,
    pub payloads: BTreeMap<String, Payload>,
    pub timing: Timing,
    /// Autopilot parameters the project needs, checked at start
    /// (`[gateway.parameters]`), by name.
    pub parameters: Vec<(String, Expected)>,
}

impl VehicleConfig {
    /// Our component id.
    pub fn own_component(&self) -> u8 {
        self.component.unwrap_or(ONBOARD_COMPUTER)
    }

    /// Reads the `[gateway]` table of project.toml's text (`file` names it
    /// in errors, which come with line and column).
    pub fn from_project_toml(file: &str, text: &str) -> Result<VehicleConfig, ConfigError> {
        let doc: toml::Table = toml::from_str(text).map_err(|e| {
            let at = e.span().map(|s| line_col(text, s.start)).unwrap_or((1, 1));
            ConfigError {
                key: String::new(),
                message: e.message().to_owned(),
                at: Some((file.to_owned(), at.0, at.1)),
            }
        })?;
        let gateway = match doc.get("gateway") {
            None => return Ok(VehicleConfig::default()),
            Some(toml::Value::Table(t)) => t,
            Some(_) => {
                return Err(ConfigError {
                    at: locate(text, "gateway").map(|(l, c)| (file.to_owned(), l, c)),
                    ..ConfigError::new("gateway", "expected a table")
                })
            }
        };
        VehicleConfig::from_gateway_table(gateway).map_err(|e| ConfigError {
            at: locate(text, &e.key).map(|(l, c)| (file.to_owned(), l, c)),
            ..e
        })
    }

    /// Reads the keys this module owns in a project's `[gateway]` table:
    /// `system_id`, `autopilot_component`, `component_id`, `firmware`, `quadplane`,
    /// `[gateway.payloads]` and `[gateway.commands]`. Other keys are left to
    /// their owners.
    pub fn from_gateway_table(gateway: &toml::Table) -> Result<VehicleConfig, ConfigError> {
        let mut config = VehicleConfig::default();
        if let Some(v) = gateway.get("system_id") {
            config.system = Some(id_in("gateway.system_id", v, 1)?);
        }
        if let Some(v) = gateway.get("autopilot_component") {
            config.autopilot_component = Some(id_in("gateway.autopilot_component", v, 1)?);
        }
        if let Some(v) = gateway.get("component_id") {
            config.component = Some(id_in("gateway.component_id", v, 1)?);
        }
        if let Some(v) = gateway.get("firmware") {
            let name = v
                .as_str()
                .ok_or_else(|| ConfigError::new("gateway.firmware", "expected a string"))?;
            config.firmware = Some(Firmware::parse(name).ok_or_else(|| {
                ConfigError::new(
                    "gateway.firmware",
                    format!("unknown firmware {name:?} (copter, plane, rover, sub, px4)"),
                )
            })?);
        }
        if let Some(v) = gateway.get("quadplane") {
            config.quadplane = v
                .as_bool()
                .ok_or_else(|| ConfigError::new("gateway.quadplane", "expected true or false"))?;
        }
        if let Some(v) = gateway.get("payloads") {
            let table = v
                .as_table()
                .ok_or_else(|| ConfigError::new("gateway.payloads", "expected a table"))?;
            for (name, entry) in table {
                let payload = payload(&format!("gateway.payloads.{name}"), entry)?;
                config.payloads.insert(name.clone(), payload);
            }
        }
        if let Some(v) = gateway.get("parameters") {
            let table = v
                .as_table()
                .ok_or_else(|| ConfigError::new("gateway.parameters", "expected a table"))?;
            for (name, entry) in table {
                let key = format!("gateway.parameters.{name}");
                config
                    .parameters
                    .push((name.clone(), parameter(&key, name, entry)?));
            }
        }
        if let Some(v) = gateway.get("commands") {
            let table = v
                .as_table()
                .ok_or_else(|| ConfigError::new("gateway.commands", "expected a table"))?;
            config.timing = timing(table)?;
        }
        Ok(config)
    }
}

/// One `[gateway.parameters]` entry: `NAME = 2`, `NAME = [1, 2]` (one of
/// them) or `NAME = { min = 0.5, max = 3 }`.
fn parameter(key: &str, name: &str, entry: &toml::Value) -> Result<Expected, ConfigError> {
    if name.is_empty()
        || name.len() > 16
        || !name
            .bytes()
            .all(|b| b.is_ascii_uppercase() || b.is_ascii_digit() || b == b'_')
    {
        return Err(ConfigError::new(
            key,
            "a parameter name is 1 to 16 capital letters, digits and underscores",
        ));
    }
    let number = |v: &toml::Value| match v {
        toml::Value::Integer(i) => Some(*i as f64),
        toml::Value::Float(f) if f.is_finite() => Some(*f),
        _ => None,
    };
    let bad = || {
        ConfigError::new(
            key,
            "expected a number, a list of numbers (one of them), or { min = …, max = … }",
        )
    };
    match entry {
        toml::Value::Array(values) if !values.is_empty() => values
            .iter()
            .map(|v| number(v).ok_or_else(bad))
            .collect::<Result<Vec<f64>, _>>()
            .map(Expected::OneOf),
        toml::Value::Table(t) => {
            if let Some(other) = t.keys().find(|k| *k != "min" && *k != "max") {
                return Err(ConfigError::new(
                    &format!("{key}.{other}"),
                    "unknown key (min, max)",
                ));
            }
            let bound = |k: &str| match t.get(k) {
                None => Ok(None),
                Some(v) => number(v).map(Some).ok_or_else(bad),
            };
            let (min, max) = (bound("min")?, bound("max")?);
            match (min, max) {
                (None, None) => Err(bad()),
                (Some(a), Some(b)) if a > b => Err(ConfigError::new(key, "min is above max")),
                _ => Ok(Expected::Range { min, max }),
            }
        }
        v => number(v).map(Expected::Equal).ok_or_else(bad),
    }
}

/// A problem in the `[gateway]` table, with the key it is about and, when
/// read from a file, where (`file:line:col`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}{key}: {message}", .at.as_ref().map(|(f, l, c)| format!("{f}:{l}:{c}: ")).unwrap_or_default())]
pub struct ConfigError {
    pub key: String,
    pub message: String,
    /// File, line and column (from 1), when known.
    pub at: Option<(String, usize, usize)>,
}

impl ConfigError {
    fn new(key: &str, message: impl Into<String>) -> ConfigError {
        ConfigError {
            key: key.to_owned(),
            message: message.into(),
            at: None,
        }
    }
}

/// Line and column (from 1) of a byte offset.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// Where the value of a dotted key (`gateway.payloads.cam.camera`) is in
/// the text, or its innermost table that exists.
fn locate(text: &str, key: &str) -> Option<(usize, usize)> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(text).ok()?;
    let mut table = root.get_ref();
    let mut found = None;
    for segment in key.split('.') {
        let (_, value) = table
            .iter()
            .find(|(k, _)| k.get_ref().as_ref() == segment)?;
        found = Some(value.span().start);
        match value.get_ref() {
            DeValue::Table(t) => table = t,
            _ => break,
        }
    }
    found.map(|offset| line_col(text, offset))
}

fn int(key: &str, v: &toml::Value) -> Result<i64, ConfigError> {
    v.as_integer().ok_or_else(|| {
        ConfigError::new(key, format!("expected an integer, found {}", v.type_str()))
    })
}

fn id_in(key: &str, v: &toml::Value, min: i64) -> Result<u8, ConfigError> {
    let n = int(key, v)?;
    if !(min..=255).contains(&n) {
        return Err(ConfigError::new(key, format!("{n} is not in {min}..=255")));
    }
    Ok(n as u8)
}

fn ranged<T: TryFrom<i64>>(key: &str, v: &toml::Value, max: i64) -> Result<T, ConfigError> {
    let n = int(key, v)?;
    if !(0..=max).contains(&n) {
        return Err(ConfigError::new(key, format!("{n} is not in 0..={max}")));
    }
    T::try_from(n).map_err(|_| ConfigError::new(key, format!("{n} out of range")))
}

fn payload(key: &str, entry: &toml::Value) -> Result<Payload, ConfigError> {
    let table = entry.as_table().ok_or_else(|| {
        ConfigError::new(
            key,
            "expected a table such as { camera = 100 }, { relay = 0 } or { servo = 9, start = 1900, stop = 1100 }",
        )
    })?;
    let kinds: Vec<&str> = ["camera", "relay", "servo"]
        .into_iter()
        .filter(|k| table.contains_key(*k))
        .collect();
    let [kind] = kinds.as_slice() else {
        return Err(ConfigError::new(
            key,
            "give exactly one of camera = COMPONENT, relay = INSTANCE, servo = INSTANCE",
        ));
    };
    let allowed: &[&str] = match *kind {
        "camera" => &["camera"],
        _ => &[kind, "start", "stop"],
    };
    if let Some(other) = table.keys().find(|k| !allowed.contains(&k.as_str())) {
        return Err(ConfigError::new(
            &format!("{key}.{other}"),
            format!("unknown key for a {kind} payload"),
        ));
    }
    let field = |name: &str| table.get(name).map(|v| (format!("{key}.{name}"), v));
    Ok(match *kind {
        "camera" => Payload::Camera {
            component: id_in(&format!("{key}.camera"), &table["camera"], 1)?,
        },
        "relay" => Payload::Relay {
            instance: ranged(&format!("{key}.relay"), &table["relay"], 255)?,
            start: match field("start") {
                Some((k, v)) => ranged(&k, v, 255)?,
                None => 1,
            },
            stop: match field("stop") {
                Some((k, v)) => ranged(&k, v, 255)?,
                None => 0,
            },
        },
        _ => Payload::Servo {
            instance: ranged(&format!("{key}.servo"), &table["servo"], 255)?,
            start: match field("start") {
                Some((k, v)) => ranged(&k, v, 65535)?,
                None => return Err(ConfigError::new(key, "a servo payload needs start = PWM")),
            },
            stop: match field("stop") {
                Some((k, v)) => ranged(&k, v, 65535)?,
                None => return Err(ConfigError::new(key, "a servo payload needs stop = PWM")),
            },
        },
    })
}

fn duration(key: &str, v: &toml::Value) -> Result<Micros, ConfigError> {
    let text = v
        .as_str()
        .ok_or_else(|| ConfigError::new(key, "expected a duration such as \"1s\" or \"500ms\""))?;
    nets::time::parse_duration(text).map_err(|e| ConfigError::new(key, e.to_string()))
}

fn timing(table: &toml::Table) -> Result<Timing, ConfigError> {
    let mut t = Timing::default();
    for (name, v) in table {
        let key = format!("gateway.commands.{name}");
        match name.as_str() {
            "ack_timeout" => t.ack_timeout = duration(&key, v)?,
            "in_progress_timeout" => t.in_progress_timeout = duration(&key, v)?,
            "link_timeout" => t.link_timeout = duration(&key, v)?,
            "retries" => t.retries = ranged(&key, v, 20)?,
            "rejected_retries" => t.rejected_retries = ranged(&key, v, 20)?,
            "mission_retries" => t.mission_retries = ranged(&key, v, 20)?,
            _ => return Err(ConfigError::new(&key, "unknown key")),
        }
    }
    if t.ack_timeout == 0 {
        return Err(ConfigError::new(
            "gateway.commands.ack_timeout",
            "must be more than zero",
        ));
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<VehicleConfig, ConfigError> {
        let doc: toml::Table = text.parse().expect("test TOML parses");
        let gateway = doc
            .get("gateway")
            .and_then(|g| g.as_table())
            .cloned()
            .unwrap_or_default();
        VehicleConfig::from_gateway_table(&gateway)
    }

    #[test]
    fn reads_payloads_identity_and_timing() {
        let c = parse(
            r#"
            [gateway]
            mavlink = "udpin:0.0.0.0:14550"   # someone else's key: ignored here
            system_id = 3
            firmware = "plane"
            [gateway.payloads]
            camera = { camera = 100 }
            sprayer = { relay = 2 }
            dropper = { servo = 9, start = 1900, stop = 1100 }
            [gateway.commands]
            ack_timeout = "500ms"
            retries = 5
            "#,
        )
        .expect("valid");
        assert_eq!(c.system, Some(3));
        assert_eq!(c.firmware, Some(Firmware::Plane));
        assert_eq!(c.own_component(), 191);
        assert_eq!(c.payloads["camera"], Payload::Camera { component: 100 });
        assert_eq!(
            c.payloads["sprayer"],
            Payload::Relay {
                instance: 2,
                start: 1,
                stop: 0
            }
        );
        assert_eq!(
            c.payloads["dropper"],
            Payload::Servo {
                instance: 9,
                start: 1900,
                stop: 1100
            }
        );
        assert_eq!(c.timing.ack_timeout, 500_000);
        assert_eq!(c.timing.retries, 5);
    }

    #[test]
    fn errors_in_a_file_say_where() {
        let text = "name = \"p\"\n\n[gateway]\nmavlink = \"udpin:0.0.0.0:14550\"\n[gateway.payloads]\ncam = { camera = 300 }\n";
        let e = VehicleConfig::from_project_toml("project.toml", text).expect_err("bad id");
        assert_eq!(e.at, Some(("project.toml".to_owned(), 6, 18)));
        assert_eq!(
            e.to_string(),
            "project.toml:6:18: gateway.payloads.cam.camera: 300 is not in 1..=255"
        );
        let e = VehicleConfig::from_project_toml("project.toml", "[gateway]\nsystem_id = = 1\n")
            .expect_err("bad TOML");
        assert_eq!(e.at.as_ref().map(|a| a.1), Some(2));
        let ok = VehicleConfig::from_project_toml("project.toml", "name = \"p\"\n")
            .expect("no gateway table");
        assert_eq!(ok, VehicleConfig::default());
    }

    #[test]
    fn parameters_in_three_forms_by_name() {
        let c = parse(
            "[gateway.parameters]\nRTL_AUTOLAND = [1, 2]\nFS_LONG_ACTN = 1\nTHR_MIN = { max = 0.5 }\n",
        )
        .expect("valid");
        assert_eq!(
            c.parameters,
            vec![
                ("FS_LONG_ACTN".to_owned(), Expected::Equal(1.0)),
                ("RTL_AUTOLAND".to_owned(), Expected::OneOf(vec![1.0, 2.0])),
                (
                    "THR_MIN".to_owned(),
                    Expected::Range {
                        min: None,
                        max: Some(0.5)
                    }
                ),
            ]
        );
    }

    #[test]
    fn bad_tables_name_the_key() {
        let cases = [
            ("[gateway]\nsystem_id = 0", "gateway.system_id"),
            ("[gateway]\nsystem_id = \"one\"", "gateway.system_id"),
            ("[gateway]\nfirmware = \"heli\"", "gateway.firmware"),
            ("[gateway]\nquadplane = 1", "gateway.quadplane"),
            ("[gateway.payloads]\ncam = 100", "gateway.payloads.cam"),
            (
                "[gateway.payloads]\ncam = { camera = 300 }",
                "gateway.payloads.cam.camera",
            ),
            (
                "[gateway.payloads]\ncam = { camera = 1, relay = 2 }",
                "gateway.payloads.cam",
            ),
            (
                "[gateway.payloads]\ncam = { camera = 1, start = 2 }",
                "gateway.payloads.cam.start",
            ),
            (
                "[gateway.payloads]\ns = { servo = 1 }",
                "gateway.payloads.s",
            ),
            (
                "[gateway.commands]\nack_timeout = \"soon\"",
                "gateway.commands.ack_timeout",
            ),
            ("[gateway.commands]\nspeed = 1", "gateway.commands.speed"),
            ("[gateway]\nparameters = 1", "gateway.parameters"),
            (
                "[gateway.parameters]\nrtl_autoland = 2",
                "gateway.parameters.rtl_autoland",
            ),
            (
                "[gateway.parameters]\nA_NAME_LONGER_THAN_16 = 2",
                "gateway.parameters.A_NAME_LONGER_THAN_16",
            ),
            (
                "[gateway.parameters]\nRTL_AUTOLAND = \"two\"",
                "gateway.parameters.RTL_AUTOLAND",
            ),
            (
                "[gateway.parameters]\nRTL_AUTOLAND = []",
                "gateway.parameters.RTL_AUTOLAND",
            ),
            (
                "[gateway.parameters]\nRTL_AUTOLAND = { min = 3, max = 1 }",
                "gateway.parameters.RTL_AUTOLAND",
            ),
            (
                "[gateway.parameters]\nRTL_AUTOLAND = { least = 3 }",
                "gateway.parameters.RTL_AUTOLAND.least",
            ),
            (
                "[gateway.parameters]\nRTL_AUTOLAND = nan",
                "gateway.parameters.RTL_AUTOLAND",
            ),
        ];
        for (text, key) in cases {
            let e = parse(text).expect_err(text);
            assert_eq!(e.key, key, "{text}: {e}");
        }
    }
}
