//! Decoded MAVLink messages as flat JSON for people and plotting tools, one
//! JSON Schema per message type.
//!
//! Field values come from elaboration's field access (`elaboration::fields`:
//! rust-mavlink's serde output with enums and bitflags as numbers, arrays as
//! numbers, character arrays as text); enum and bitflag fields also get their
//! names beside them, as `<field>_name`, from rust-mavlink's human-readable
//! serde output. Field names are MAVLink's (`type`, not `mavtype`).

use std::collections::HashMap;

use elaboration::fields::{self, EnumNames, Field};
use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::Message;
use serde_json::{json, Map, Value as Json};

/// What is known of one message type.
#[derive(Debug)]
pub struct Kind {
    pub name: &'static str,
    /// MAVLink field names, in the order elaboration extracts them.
    fields: Vec<String>,
    /// The JSON Schema of the decoded message.
    pub schema: String,
}

/// Turns decoded messages into JSON, caching each type's schema.
#[derive(Debug, Default)]
pub struct Decoder {
    names: EnumNames,
    values: Vec<Field>,
    kinds: HashMap<u32, Option<Kind>>,
}

fn field_json(f: &Field) -> Json {
    match f {
        Field::Missing => Json::Null,
        Field::Int(i) => json!(i),
        Field::Float(x) => serde_json::Number::from_f64(*x)
            .map(Json::Number)
            .unwrap_or(Json::Null),
        Field::Str(s) => json!(s),
        Field::List(l) => Json::Array(
            l.iter()
                .map(|x| {
                    serde_json::Number::from_f64(*x)
                        .map(Json::Number)
                        .unwrap_or(Json::Null)
                })
                .collect(),
        ),
    }
}

/// The name beside a numbered enum or bitflag field, from rust-mavlink's
/// human-readable serde value: `{"type": "NAME"}` or `"A | B"`.
fn enum_name(human: Option<&Json>) -> Option<&str> {
    match human? {
        Json::Object(o) => o.get("type")?.as_str(),
        Json::String(s) => Some(s),
        _ => None,
    }
}

/// The rust-mavlink key of a MAVLink field name.
fn rust_key(name: &str) -> &str {
    match name {
        "type" => "mavtype",
        other => other,
    }
}

impl Decoder {
    fn kind(&mut self, id: u32) -> Option<&Kind> {
        let names = &mut self.names;
        let values = &mut self.values;
        self.kinds
            .entry(id)
            .or_insert_with(|| {
                let msg = MavMessage::default_message_from_id(id)?;
                let fields = fields::schema(id)?;
                if !fields::extract(&msg, values, names) {
                    return None;
                }
                let human = serde_json::to_value(&msg).ok()?;
                let mut props = Map::new();
                for (i, name) in fields.iter().enumerate() {
                    let ty = match values.get(i) {
                        Some(Field::Int(_)) => json!({"type": "integer"}),
                        Some(Field::Float(_)) => json!({"type": "number"}),
                        Some(Field::Str(_)) => json!({"type": "string"}),
                        Some(Field::List(_)) => {
                            json!({"type": "array", "items": {"type": "number"}})
                        }
                        Some(Field::Missing) | None => json!({}),
                    };
                    props.insert(name.clone(), ty);
                    if matches!(values.get(i), Some(Field::Int(_)))
                        && enum_name(human.get(rust_key(name))).is_some()
                    {
                        props.insert(
                            format!("{name}_name"),
                            json!({"type": "string", "description": format!("the name of {name}")}),
                        );
                    }
                }
                let schema = json!({
                    "title": format!("mavlink.{}", msg.message_name()),
                    "description": format!("MAVLink {} (ardupilotmega dialect), decoded by rust-mavlink; enums and bitflags as numbers with their names beside", msg.message_name()),
                    "type": "object",
                    "properties": props,
                });
                Some(Kind {
                    name: msg.message_name(),
                    fields,
                    schema: schema.to_string(),
                })
            })
            .as_ref()
    }

    /// The message as flat JSON, with its type (`None` if it cannot be read
    /// field by field).
    pub fn decode(&mut self, msg: &MavMessage) -> Option<(&Kind, Json)> {
        let id = msg.message_id();
        self.kind(id)?;
        if !fields::extract(msg, &mut self.values, &mut self.names) {
            return None;
        }
        let human = serde_json::to_value(msg).ok();
        let kind = self.kinds.get(&id)?.as_ref()?;
        let mut obj = Map::new();
        for (i, name) in kind.fields.iter().enumerate() {
            let value = self.values.get(i).unwrap_or(&Field::Missing);
            obj.insert(name.clone(), field_json(value));
            if matches!(value, Field::Int(_)) {
                let h = human.as_ref().and_then(|h| h.get(rust_key(name)));
                if let Some(n) = enum_name(h) {
                    obj.insert(format!("{name}_name"), json!(n));
                }
            }
        }
        Some((kind, Json::Object(obj)))
    }
}

/// The JSON Schema of `foxglove.LocationFix` (Foxglove's well-known name).
pub const LOCATION_FIX_SCHEMA: &str = r#"{"title":"foxglove.LocationFix","description":"A navigation satellite fix for any Global Navigation Satellite System","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}},"frame_id":{"type":"string"},"latitude":{"type":"number","description":"Latitude in degrees"},"longitude":{"type":"number","description":"Longitude in degrees"},"altitude":{"type":"number","description":"Altitude in meters"},"position_covariance":{"type":"array","items":{"type":"number"},"minItems":9,"maxItems":9},"position_covariance_type":{"type":"integer","description":"0 unknown"}}}"#;

/// A `foxglove.LocationFix` from GLOBAL_POSITION_INT (degrees × 1e7, mm
/// above mean sea level), stamped `time_ns`.
pub fn location_fix(msg: &MavMessage, time_ns: u64) -> Option<Json> {
    let MavMessage::GLOBAL_POSITION_INT(p) = msg else {
        return None;
    };
    Some(json!({
        "timestamp": {"sec": time_ns / 1_000_000_000, "nsec": time_ns % 1_000_000_000},
        "frame_id": "",
        "latitude": p.lat as f64 / 1e7,
        "longitude": p.lon as f64 / 1e7,
        "altitude": p.alt as f64 / 1e3,
        "position_covariance": vec![0.0; 9],
        "position_covariance_type": 0,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::*;

    #[test]
    fn enums_and_bitflags_are_numbers_with_names_beside() {
        let msg = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 10,
            mavtype: MavType::MAV_TYPE_FIXED_WING,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED
                | MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            system_status: MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        });
        let mut d = Decoder::default();
        let (kind, v) = d.decode(&msg).expect("decoded");
        assert_eq!(kind.name, "HEARTBEAT");
        assert_eq!(v["custom_mode"], 10);
        assert_eq!(v["type"], 1);
        assert_eq!(v["type_name"], "MAV_TYPE_FIXED_WING");
        assert_eq!(v["autopilot"], 3);
        assert_eq!(v["base_mode"], 129);
        let flags = v["base_mode_name"].as_str().expect("names");
        assert!(flags.contains("MAV_MODE_FLAG_SAFETY_ARMED"), "{flags}");
        assert_eq!(v["system_status"], 4);
        assert_eq!(v["mavlink_version"], 3);
        assert!(v.get("mavlink_version_name").is_none());
        let schema: Json = serde_json::from_str(&kind.schema).expect("schema is JSON");
        assert_eq!(schema["type"], "object");
        assert_eq!(schema["properties"]["type"]["type"], "integer");
        assert_eq!(schema["properties"]["type_name"]["type"], "string");
        assert_eq!(schema["properties"]["custom_mode"]["type"], "integer");
    }

    #[test]
    fn text_floats_and_arrays() {
        let mut data = STATUSTEXT_DATA::DEFAULT;
        let mut text = [0u8; 50];
        text[..5].copy_from_slice(b"Hello");
        data.text = mavlink::types::CharArray::new(text);
        let mut d = Decoder::default();
        let (_, v) = d.decode(&MavMessage::STATUSTEXT(data)).expect("decoded");
        assert_eq!(v["text"], "Hello");
        let mut att = ATTITUDE_DATA::DEFAULT;
        att.roll = 0.5;
        let (kind, v) = d.decode(&MavMessage::ATTITUDE(att)).expect("decoded");
        assert_eq!(v["roll"], 0.5);
        let schema: Json = serde_json::from_str(&kind.schema).expect("schema is JSON");
        assert_eq!(schema["properties"]["roll"]["type"], "number");
        let mut esc = ESC_TELEMETRY_1_TO_4_DATA::DEFAULT;
        esc.rpm = [1, 2, 3, 4];
        let (_, v) = d
            .decode(&MavMessage::ESC_TELEMETRY_1_TO_4(esc))
            .expect("decoded");
        assert_eq!(v["rpm"], json!([1.0, 2.0, 3.0, 4.0]));
    }

    #[test]
    fn location_fix_in_degrees_and_metres() {
        let mut p = GLOBAL_POSITION_INT_DATA::DEFAULT;
        p.lat = 433_000_000;
        p.lon = 15_000_000;
        p.alt = 120_500;
        let v = location_fix(&MavMessage::GLOBAL_POSITION_INT(p), 1_500_000_000).expect("fix");
        assert_eq!(v["latitude"], 43.3);
        assert_eq!(v["longitude"], 1.5);
        assert_eq!(v["altitude"], 120.5);
        assert_eq!(v["timestamp"]["sec"], 1);
        assert_eq!(v["timestamp"]["nsec"], 500_000_000);
        let _: Json = serde_json::from_str(LOCATION_FIX_SCHEMA).expect("schema is JSON");
    }
}
