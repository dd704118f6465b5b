//! A net's `command VERB {args}` read into a typed request, before anything
//! about the vehicle is known. Missing or ill-typed arguments are reported
//! here, so that the net hears `command.failed` at once.

use nets::{Params, Value};

/// A mission item as the nets give it: `{lat, lon, alt}` and optionally
/// `command` (a MAV_CMD name without its prefix, e.g. `WAYPOINT`,
/// `TAKEOFF`, `LAND`, `LOITER_UNLIM`, `DO_CHANGE_SPEED`, or a number),
/// `frame` (`relative` (default), `amsl`, `terrain`), `p1`..`p4`, and
/// `autocontinue` (default true).
#[derive(Debug, Clone, PartialEq)]
pub struct Item {
    pub command: u16,
    pub frame: ItemFrame,
    pub params: [f32; 4],
    pub lat: f64,
    pub lon: f64,
    pub alt: f32,
    pub autocontinue: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ItemFrame {
    Relative,
    Amsl,
    Terrain,
}

/// What the nets asked for.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    Arm {
        arm: bool,
        force: bool,
    },
    Mode {
        name: String,
    },
    Takeoff {
        alt: f32,
        pitch: f32,
    },
    Land {
        at: Option<(f64, f64)>,
        alt: Option<f32>,
    },
    Rtl,
    Goto {
        lat: f64,
        lon: f64,
        alt: Option<f32>,
        speed: Option<f32>,
        radius: Option<f32>,
    },
    SetSpeed {
        speed: f32,
        kind: SpeedKind,
    },
    UploadMission {
        items: Vec<Item>,
    },
    StartMission {
        first: u16,
        last: u16,
    },
    SetCurrent {
        seq: u16,
    },
    Payload {
        name: String,
        start: bool,
        interval: Option<f32>,
    },
}

/// MAV_CMD_DO_CHANGE_SPEED's speed type. `Default` is airspeed on planes,
/// ground speed elsewhere.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpeedKind {
    Default,
    Air,
    Ground,
    Climb,
    Descent,
}

struct Args<'a> {
    verb: &'a str,
    params: &'a Params,
}

impl<'a> Args<'a> {
    fn value(&self, name: &str) -> Option<&'a Value> {
        self.params.get(name)
    }

    fn number(&self, name: &str) -> Result<Option<f64>, String> {
        match self.value(name) {
            None => Ok(None),
            Some(v) => match v.as_f64() {
                Some(x) if x.is_finite() => Ok(Some(x)),
                Some(_) => Err(format!("{}: {name} is not a finite number", self.verb)),
                None => Err(format!(
                    "{}: {name} must be a number, not a {}",
                    self.verb,
                    v.type_name()
                )),
            },
        }
    }

    fn required(&self, name: &str) -> Result<f64, String> {
        self.number(name)?
            .ok_or_else(|| format!("{}: missing argument {name}", self.verb))
    }

    fn text(&self, name: &str) -> Result<Option<&'a str>, String> {
        match self.value(name) {
            None => Ok(None),
            Some(Value::Str(s)) => Ok(Some(s)),
            Some(v) => Err(format!(
                "{}: {name} must be a string, not a {}",
                self.verb,
                v.type_name()
            )),
        }
    }

    fn flag(&self, name: &str) -> Result<bool, String> {
        match self.value(name) {
            None => Ok(false),
            Some(Value::Bool(b)) => Ok(*b),
            Some(Value::Int(i)) if *i == 0 || *i == 1 => Ok(*i == 1),
            Some(v) => Err(format!(
                "{}: {name} must be true or false, not {v}",
                self.verb
            )),
        }
    }

    fn index(&self, name: &str) -> Result<Option<u16>, String> {
        match self.value(name) {
            None => Ok(None),
            Some(Value::Int(i)) if (0..=u16::MAX as i64).contains(i) => Ok(Some(*i as u16)),
            Some(v) => Err(format!(
                "{}: {name} must be an integer in 0..=65535, not {v}",
                self.verb
            )),
        }
    }
}

fn latitude(verb: &str, lat: f64) -> Result<f64, String> {
    if (-90.0..=90.0).contains(&lat) {
        Ok(lat)
    } else {
        Err(format!("{verb}: latitude {lat} is not in -90..=90"))
    }
}

fn longitude(verb: &str, lon: f64) -> Result<f64, String> {
    if (-180.0..=180.0).contains(&lon) {
        Ok(lon)
    } else {
        Err(format!("{verb}: longitude {lon} is not in -180..=180"))
    }
}

/// Reads a command's arguments; `Err` is the reason given to the nets.
pub fn parse(verb: &str, params: &Params) -> Result<Request, String> {
    let a = Args { verb, params };
    Ok(match verb {
        "arm" | "disarm" => Request::Arm {
            arm: verb == "arm",
            force: a.flag("force")?,
        },
        "mode" => Request::Mode {
            name: a
                .text("mode")?
                .ok_or("mode: missing argument mode")?
                .to_owned(),
        },
        "takeoff" => Request::Takeoff {
            alt: a.required("alt")? as f32,
            pitch: a.number("pitch")?.unwrap_or(0.0) as f32,
        },
        "land" => {
            let at = match (a.number("lat")?, a.number("lon")?) {
                (Some(lat), Some(lon)) => Some((latitude(verb, lat)?, longitude(verb, lon)?)),
                (None, None) => None,
                _ => return Err("land: give both lat and lon, or neither".into()),
            };
            Request::Land {
                at,
                alt: a.number("alt")?.map(|x| x as f32),
            }
        }
        "rtl" => Request::Rtl,
        "goto" => Request::Goto {
            lat: latitude(verb, a.required("lat")?)?,
            lon: longitude(verb, a.required("lon")?)?,
            alt: a.number("alt")?.map(|x| x as f32),
            speed: a.number("speed")?.map(|x| x as f32),
            radius: a.number("radius")?.map(|x| x as f32),
        },
        "set_speed" => {
            let speed = a.required("speed")?;
            if speed < 0.0 {
                return Err(format!("set_speed: speed {speed} is negative"));
            }
            let kind = match a.text("kind")? {
                None => SpeedKind::Default,
                Some("air" | "airspeed") => SpeedKind::Air,
                Some("ground" | "groundspeed") => SpeedKind::Ground,
                Some("climb") => SpeedKind::Climb,
                Some("descent") => SpeedKind::Descent,
                Some(other) => {
                    return Err(format!(
                        "set_speed: kind {other:?} is not air, ground, climb or descent"
                    ))
                }
            };
            Request::SetSpeed {
                speed: speed as f32,
                kind,
            }
        }
        "upload_mission" => {
            let items = match a.value("items") {
                Some(Value::List(items)) => items,
                Some(v) => {
                    return Err(format!(
                        "upload_mission: items must be a list, not a {}",
                        v.type_name()
                    ))
                }
                None => return Err("upload_mission: missing argument items".into()),
            };
            if items.is_empty() {
                return Err("upload_mission: items is empty".into());
            }
            if items.len() > u16::MAX as usize - 1 {
                return Err("upload_mission: too many items".into());
            }
            Request::UploadMission {
                items: items
                    .iter()
                    .enumerate()
                    .map(|(i, v)| item(i, v))
                    .collect::<Result<_, _>>()?,
            }
        }
        "start_mission" => Request::StartMission {
            first: a.index("first")?.unwrap_or(0),
            last: a.index("last")?.unwrap_or(0),
        },
        "set_current" => Request::SetCurrent {
            seq: a.index("seq")?.ok_or("set_current: missing argument seq")?,
        },
        "payload_start" | "payload_stop" => Request::Payload {
            name: a
                .text("payload")?
                .ok_or_else(|| format!("{verb}: missing argument payload"))?
                .to_owned(),
            start: verb == "payload_start",
            interval: a.number("interval")?.map(|x| x as f32),
        },
        other => return Err(format!("unknown command verb {other:?}")),
    })
}

/// A MAV_CMD by the name the nets use (`WAYPOINT`, `NAV_WAYPOINT`,
/// `MAV_CMD_NAV_WAYPOINT`, `DO_CHANGE_SPEED`…) or by number.
fn mav_cmd(v: &Value, what: &str) -> Result<u16, String> {
    match v {
        Value::Int(n) if (0..=u16::MAX as i64).contains(n) => Ok(*n as u16),
        Value::Str(s) => {
            let upper = s.to_ascii_uppercase();
            [
                format!("MAV_CMD_NAV_{upper}"),
                format!("MAV_CMD_{upper}"),
                upper.clone(),
            ]
            .iter()
            .find_map(|n| elaboration::constants::value(n))
            .filter(|v| (0..=u16::MAX as i64).contains(v))
            .map(|v| v as u16)
            .or(match upper.as_str() {
                "RTL" => Some(20),
                _ => None,
            })
            .ok_or_else(|| format!("{what}: unknown command {s:?}"))
        }
        other => Err(format!(
            "{what}: command must be a name or a number, not {other}"
        )),
    }
}

fn item(index: usize, v: &Value) -> Result<Item, String> {
    let what = format!("upload_mission: item {index}");
    let Value::Map(map) = v else {
        return Err(format!("{what} must be a map {{lat, lon, alt, …}}"));
    };
    let num = |name: &str| -> Result<Option<f64>, String> {
        match map.get(name) {
            None => Ok(None),
            Some(v) => match v.as_f64() {
                Some(x) if x.is_finite() => Ok(Some(x)),
                _ => Err(format!("{what}: {name} must be a finite number, not {v}")),
            },
        }
    };
    for key in map.keys() {
        if !matches!(
            key.as_str(),
            "lat"
                | "lon"
                | "alt"
                | "command"
                | "frame"
                | "p1"
                | "p2"
                | "p3"
                | "p4"
                | "autocontinue"
        ) {
            return Err(format!("{what}: unknown key {key:?}"));
        }
    }
    let command = match map.get("command") {
        None => 16,
        Some(c) => mav_cmd(c, &what)?,
    };
    let frame = match map.get("frame") {
        None => ItemFrame::Relative,
        Some(Value::Str(s)) => match s.as_str() {
            "relative" => ItemFrame::Relative,
            "amsl" => ItemFrame::Amsl,
            "terrain" => ItemFrame::Terrain,
            other => {
                return Err(format!(
                    "{what}: frame {other:?} is not relative, amsl or terrain"
                ))
            }
        },
        Some(other) => return Err(format!("{what}: frame must be a string, not {other}")),
    };
    let positional = matches!(command, 16..=19 | 31);
    let (lat, lon) = match (num("lat")?, num("lon")?) {
        (Some(lat), Some(lon)) => (latitude(&what, lat)?, longitude(&what, lon)?),
        (None, None) if !positional => (0.0, 0.0),
        _ => return Err(format!("{what}: needs lat and lon")),
    };
    let alt = match num("alt")? {
        Some(alt) => alt as f32,
        None if positional || command == 22 => return Err(format!("{what}: needs alt")),
        None => 0.0,
    };
    let mut params = [0.0f32; 4];
    for (i, p) in params.iter_mut().enumerate() {
        *p = num(&format!("p{}", i + 1))?.unwrap_or(0.0) as f32;
    }
    let autocontinue = match map.get("autocontinue") {
        None => true,
        Some(Value::Bool(b)) => *b,
        Some(other) => {
            return Err(format!(
                "{what}: autocontinue must be true or false, not {other}"
            ))
        }
    };
    Ok(Item {
        command,
        frame,
        params,
        lat,
        lon,
        alt,
        autocontinue,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(pairs: &[(&str, Value)]) -> Params {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect()
    }

    #[test]
    fn reads_typed_arguments() {
        assert_eq!(
            parse("arm", &args(&[("force", Value::Bool(true))])),
            Ok(Request::Arm {
                arm: true,
                force: true
            })
        );
        assert_eq!(
            parse("takeoff", &args(&[("alt", Value::Int(30))])),
            Ok(Request::Takeoff {
                alt: 30.0,
                pitch: 0.0
            })
        );
        let wp = Value::Map(
            [
                ("lat".to_string(), Value::Float(43.5)),
                ("lon".to_string(), Value::Float(1.4)),
                ("alt".to_string(), Value::Int(100)),
            ]
            .into(),
        );
        let land = Value::Map([("command".to_string(), Value::Str("LAND".into()))].into());
        let Ok(Request::UploadMission { items }) = parse(
            "upload_mission",
            &args(&[("items", Value::List(vec![wp, land]))]),
        ) else {
            panic!("mission parses");
        };
        assert_eq!(items[0].command, 16);
        assert_eq!(items[1].command, 21);
        assert_eq!((items[0].lat, items[0].alt), (43.5, 100.0));
    }

    #[test]
    fn missing_or_wrong_arguments_are_reasons_not_panics() {
        let cases: Vec<(&str, Params)> = vec![
            ("takeoff", args(&[])),
            ("takeoff", args(&[("alt", Value::Str("high".into()))])),
            ("takeoff", args(&[("alt", Value::Float(f64::NAN))])),
            ("mode", args(&[("mode", Value::Int(3))])),
            (
                "goto",
                args(&[("lat", Value::Float(95.0)), ("lon", Value::Int(0))]),
            ),
            ("goto", args(&[("lat", Value::Float(45.0))])),
            ("land", args(&[("lat", Value::Float(45.0))])),
            ("set_speed", args(&[("speed", Value::Int(-2))])),
            (
                "set_speed",
                args(&[
                    ("speed", Value::Int(2)),
                    ("kind", Value::Str("warp".into())),
                ]),
            ),
            ("set_current", args(&[("seq", Value::Int(-1))])),
            ("set_current", args(&[("seq", Value::Float(1.5))])),
            ("upload_mission", args(&[("items", Value::Int(1))])),
            ("upload_mission", args(&[("items", Value::List(vec![]))])),
            (
                "upload_mission",
                args(&[("items", Value::List(vec![Value::Int(1)]))]),
            ),
            (
                "upload_mission",
                args(&[(
                    "items",
                    Value::List(vec![Value::Map(
                        [("command".to_string(), Value::Str("WARP".into()))].into(),
                    )]),
                )]),
            ),
            ("payload_start", args(&[])),
            ("arm", args(&[("force", Value::Str("yes".into()))])),
            ("fly", args(&[])),
        ];
        for (verb, params) in cases {
            let r = parse(verb, &params);
            assert!(r.is_err(), "{verb} {params:?} gave {r:?}");
        }
    }
}
