//! The vehicles' strips and the map's contents, read from the frames the
//! supervisor is fed (the same in `run` and over a recording) and from the
//! nets' commands and results: mode, armed, altitude, ground speed,
//! battery, GPS, link quality, the last autopilot HEARTBEAT; the track, home,
//! the mission's waypoints, and positions the programs answered (emergency
//! sites). A team project (`[[vehicle]]`) follows each vehicle of the team
//! by its declared system and component, and ignores every other system; a
//! project without a team follows the first autopilot heard.

use mavlink::dialects::ardupilotmega::{MavAutopilot, MavMessage, MavModeFlag, MavType};
use nets::model::VehicleId;
use nets::{Effect, Micros, Project};
use serde_json::{json, Value as Json};

/// The message ids read (others are not decoded).
const READ: [u32; 8] = [0, 1, 24, 33, 74, 109, 147, 242];
/// A track point at least this often, and whenever the vehicle moved more
/// than `TRACK_METRES`.
const TRACK_EVERY: Micros = 2_000_000;
const TRACK_METRES: f64 = 15.0;

/// A point of the map, with what it is.
#[derive(Debug, Clone, PartialEq)]
pub struct Mark {
    pub lat: f64,
    pub lon: f64,
    pub label: String,
}

/// What the strip and the map show.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Strip {
    pub firmware: Option<elaboration::Firmware>,
    pub mode: Option<String>,
    pub armed: Option<bool>,
    pub alt: Option<f64>,
    pub ground_speed: Option<f64>,
    pub heading: Option<f64>,
    pub battery_pct: Option<i64>,
    pub battery_v: Option<f64>,
    pub gps_fix: Option<String>,
    pub satellites: Option<u8>,
    /// Percent of packets the autopilot received from its ground link
    /// (SYS_STATUS drop rate), or the radio's RSSI when a radio reports it.
    pub link: Option<String>,
    pub heartbeat: Option<Micros>,
    pub position: Option<(f64, f64)>,
    pub home: Option<(f64, f64)>,
    pub waypoints: Vec<Mark>,
    pub sites: Vec<Mark>,
    pub targets: Vec<Mark>,
}

impl Strip {
    pub fn json(&self, now: Micros) -> Json {
        let pos = |p: &Option<(f64, f64)>| p.map(|(a, b)| json!([a, b]));
        let marks = |m: &[Mark]| -> Json {
            m.iter()
                .map(|m| json!([m.lat, m.lon, m.label]))
                .collect::<Vec<_>>()
                .into()
        };
        json!({
            "firmware": self.firmware.map(|f| f.as_str()),
            "mode": self.mode, "armed": self.armed, "alt": self.alt,
            "ground_speed": self.ground_speed, "heading": self.heading,
            "battery_pct": self.battery_pct, "battery_v": self.battery_v,
            "gps_fix": self.gps_fix, "satellites": self.satellites, "link": self.link,
            "heartbeat_age": self.heartbeat.map(|h| nets::time::seconds(now.saturating_sub(h))),
            "position": pos(&self.position), "home": pos(&self.home),
            "waypoints": marks(&self.waypoints), "sites": marks(&self.sites),
            "targets": marks(&self.targets),
        })
    }
}

/// One vehicle as the monitor follows it.
#[derive(Debug, Clone, Default)]
pub struct Vehicle {
    /// Its name in the team (`None`: a project without a team).
    pub name: Option<String>,
    /// Its MAVLink system id, declared or heard.
    pub system: Option<u8>,
    pub strip: Strip,
    /// Whether the last step changed its strip.
    pub changed: bool,
    /// The autopilot followed: (system, component).
    followed: Option<(u8, u8)>,
    /// Track points kept: (time, lat, lon), oldest first.
    pub track: Vec<(Micros, f64, f64)>,
    /// The number of track points ever added (the page asks from there).
    pub track_added: u64,
    /// At most this many points (then every other one is dropped).
    pub track_cap: usize,
}

/// The vehicles the monitor follows: a team's, in team order, or the one
/// vehicle of a project without a team.
#[derive(Debug, Clone)]
pub struct Vehicles {
    pub all: Vec<Vehicle>,
    /// Whether they are a declared team (else one vehicle, the first
    /// autopilot heard).
    team: bool,
    /// The latest time seen.
    pub now: Micros,
    /// Whether the last step changed a strip.
    pub changed: bool,
}

impl Vehicles {
    /// The vehicles of `project`'s team (one unnamed vehicle without a
    /// team), each keeping at most `track_cap` track points.
    pub fn new(project: &Project, track_cap: usize) -> Vehicles {
        let all: Vec<Vehicle> = if project.vehicles.is_empty() {
            vec![Vehicle::new(track_cap)]
        } else {
            project
                .vehicles
                .iter()
                .map(|v| Vehicle {
                    name: Some(v.name.clone()),
                    system: Some(v.system),
                    followed: Some((v.system, v.component)),
                    ..Vehicle::new(track_cap)
                })
                .collect()
        };
        Vehicles {
            all,
            team: !project.vehicles.is_empty(),
            now: 0,
            changed: false,
        }
    }

    /// A new step: nothing changed yet.
    pub fn begin(&mut self) {
        self.changed = false;
        for v in &mut self.all {
            v.changed = false;
        }
    }

    /// A frame as fed to the supervisor: to the vehicle it comes from, if
    /// followed.
    pub fn frame(&mut self, time: Micros, bytes: &[u8]) {
        let Ok(frame) = elaboration::Frame::parse(bytes) else {
            return;
        };
        if !READ.contains(&frame.message_id()) {
            return;
        }
        let from = (frame.system_id(), frame.component_id());
        let i = if self.team {
            match self.all.iter().position(|v| v.followed == Some(from)) {
                Some(i) => i,
                None => return,
            }
        } else {
            0
        };
        let Ok(message) = frame.decode() else {
            return;
        };
        if let Some(v) = self.all.get_mut(i) {
            let changed = v.frame(time, from, &message);
            v.changed |= changed;
            self.changed |= changed;
        }
    }

    /// A command of the nets (the mission's waypoints, guided targets), on
    /// the vehicle commanded.
    pub fn effect(&mut self, effect: &Effect) {
        let Effect::Command { vehicle, .. } = effect else {
            return;
        };
        if let Some(v) = self.of(*vehicle) {
            let changed = v.effect(effect);
            v.changed |= changed;
            self.changed |= changed;
        }
    }

    /// A program's answer naming a position (an emergency site, say), on
    /// the vehicle the call was for.
    pub fn answer(&mut self, vehicle: Option<VehicleId>, of: &str, done: &Json) {
        if let Some(v) = self.of(vehicle) {
            let changed = v.answer(of, done);
            v.changed |= changed;
            self.changed |= changed;
        }
    }

    /// The vehicle `vehicle` names: a team's, or without a team the one.
    fn of(&mut self, vehicle: Option<VehicleId>) -> Option<&mut Vehicle> {
        match (self.team, vehicle) {
            (true, Some(v)) => self.all.get_mut(v),
            (true, None) => None,
            (false, _) => self.all.first_mut(),
        }
    }
}

/// A vehicle's strip (as it was at some instant) with its name and system.
pub fn strip_json(v: &Vehicle, strip: &Strip, now: Micros) -> Json {
    let mut j = strip.json(now);
    j["name"] = json!(v.name);
    j["system"] = json!(v.system);
    j
}

impl Vehicle {
    pub fn new(track_cap: usize) -> Vehicle {
        Vehicle {
            track_cap,
            ..Vehicle::default()
        }
    }

    /// A message from `from`: whether the strip changed. Without a
    /// declared autopilot, the first autopilot's HEARTBEAT picks it.
    fn frame(&mut self, time: Micros, from: (u8, u8), message: &MavMessage) -> bool {
        if let MavMessage::HEARTBEAT(hb) = message {
            let autopilot = hb.autopilot != MavAutopilot::MAV_AUTOPILOT_INVALID
                && hb.mavtype != MavType::MAV_TYPE_GCS
                && hb.mavtype != MavType::MAV_TYPE_ONBOARD_CONTROLLER;
            if self.followed.is_none() && autopilot {
                self.followed = Some(from);
                self.system = Some(from.0);
            }
        }
        if self.followed != Some(from) {
            return false;
        }
        let before = self.strip.clone();
        self.message(time, message);
        before != self.strip
    }

    fn message(&mut self, time: Micros, message: &MavMessage) {
        let s = &mut self.strip;
        match message {
            MavMessage::HEARTBEAT(hb) => {
                let firmware =
                    elaboration::Firmware::from_heartbeat(hb.autopilot as i64, hb.mavtype as i64);
                s.firmware = Some(firmware);
                s.mode = Some(elaboration::constants::mode_name(firmware, hb.custom_mode));
                s.armed = Some(
                    hb.base_mode
                        .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED),
                );
                s.heartbeat = Some(time);
            }
            MavMessage::SYS_STATUS(m) => {
                if m.battery_remaining >= 0 {
                    s.battery_pct = Some(i64::from(m.battery_remaining));
                }
                if m.voltage_battery != u16::MAX {
                    s.battery_v = Some(f64::from(m.voltage_battery) / 1000.0);
                }
                if s.link.as_deref().is_none_or(|l| !l.starts_with("RSSI")) {
                    s.link = Some(format!(
                        "{:.0}% received",
                        100.0 - f64::from(m.drop_rate_comm) / 100.0
                    ));
                }
            }
            MavMessage::BATTERY_STATUS(m) if m.battery_remaining >= 0 => {
                s.battery_pct = Some(i64::from(m.battery_remaining));
            }
            MavMessage::GPS_RAW_INT(m) => {
                let fix = format!("{:?}", m.fix_type);
                let fix = match fix.trim_start_matches("GPS_FIX_TYPE_") {
                    "NO_GPS" => "no GPS".to_owned(),
                    "NO_FIX" => "no fix".to_owned(),
                    "2D_FIX" => "2D".to_owned(),
                    "3D_FIX" => "3D".to_owned(),
                    "RTK_FLOAT" => "RTK float".to_owned(),
                    "RTK_FIXED" => "RTK fixed".to_owned(),
                    other => other.to_owned(),
                };
                s.gps_fix = Some(fix);
                if m.satellites_visible != u8::MAX {
                    s.satellites = Some(m.satellites_visible);
                }
            }
            MavMessage::GLOBAL_POSITION_INT(m) => {
                if m.lat == 0 && m.lon == 0 {
                    return;
                }
                let p = (f64::from(m.lat) / 1e7, f64::from(m.lon) / 1e7);
                s.position = Some(p);
                s.alt = Some(f64::from(m.relative_alt) / 1000.0);
                if m.hdg != u16::MAX {
                    s.heading = Some(f64::from(m.hdg) / 100.0);
                }
                self.track(time, p);
            }
            MavMessage::VFR_HUD(m) => s.ground_speed = Some(f64::from(m.groundspeed)),
            MavMessage::RADIO_STATUS(m) => {
                s.link = Some(format!("RSSI {}/{}", m.rssi, m.remrssi));
            }
            MavMessage::HOME_POSITION(m) => {
                s.home = Some((f64::from(m.latitude) / 1e7, f64::from(m.longitude) / 1e7));
            }
            _ => {}
        }
    }

    fn track(&mut self, time: Micros, (lat, lon): (f64, f64)) {
        if let Some(&(t, a, b)) = self.track.last() {
            if time.saturating_sub(t) < TRACK_EVERY && metres((a, b), (lat, lon)) < TRACK_METRES {
                return;
            }
        }
        if self.track.len() >= self.track_cap.max(2) {
            let mut i = 0;
            self.track.retain(|_| {
                i += 1;
                i % 2 == 0
            });
        }
        self.track.push((time, lat, lon));
        self.track_added += 1;
    }

    /// The nets' commands: the mission's waypoints and guided targets;
    /// whether the strip changed.
    fn effect(&mut self, effect: &Effect) -> bool {
        let Effect::Command { verb, args, .. } = effect else {
            return false;
        };
        let args = nets::value::params_json(args);
        let before = self.strip.clone();
        match verb.as_str() {
            "upload_mission" => {
                self.strip.waypoints = args["items"]
                    .as_array()
                    .map(|items| {
                        items
                            .iter()
                            .enumerate()
                            .filter_map(|(i, item)| {
                                let label = item["command"].as_str().unwrap_or("").to_owned();
                                at(item, format!("{} {label}", i + 1))
                            })
                            .collect()
                    })
                    .unwrap_or_default();
            }
            "goto" | "land" | "reposition" => {
                if let Some(m) = at(&args, verb.clone()) {
                    self.strip.targets = vec![m];
                }
            }
            _ => {}
        }
        before != self.strip
    }

    /// A program's answer naming a position (an emergency site, say);
    /// whether it was new.
    fn answer(&mut self, of: &str, done: &Json) -> bool {
        let Some(mut m) = at(done, of.to_owned()) else {
            return false;
        };
        if let Some(name) = done["name"].as_str() {
            m.label = format!("{name} ({of})");
        }
        if self.strip.sites.contains(&m) {
            return false;
        }
        self.strip.sites.push(m);
        true
    }
}

/// `{lat, lon}` in `v`, when both are numbers on the Earth (0, 0 is no
/// position).
fn at(v: &Json, label: String) -> Option<Mark> {
    let (lat, lon) = (v["lat"].as_f64()?, v["lon"].as_f64()?);
    ((-90.0..=90.0).contains(&lat) && (-180.0..=180.0).contains(&lon) && (lat, lon) != (0.0, 0.0))
        .then_some(Mark { lat, lon, label })
}

/// Metres between two nearby positions (equirectangular).
fn metres(a: (f64, f64), b: (f64, f64)) -> f64 {
    let k = 111_320.0;
    let dy = (b.0 - a.0) * k;
    let dx = (b.1 - a.1) * k * a.0.to_radians().cos();
    (dx * dx + dy * dy).sqrt()
}

#[cfg(test)]
pub(crate) mod tests {
    use mavlink::dialects::ardupilotmega::{MavState, GLOBAL_POSITION_INT_DATA, HEARTBEAT_DATA};
    use mavlink::{MavHeader, MavlinkVersion};

    use super::*;

    /// A team of two rovers, R1 (system 1) and R2 (system 2).
    fn team() -> Project {
        let files = [
            (
                "project.toml",
                "[[vehicle]]\nname = \"R1\"\nsystem = 1\n[[vehicle]]\nname = \"R2\"\nsystem = 2\n\
                 [[net]]\nfile = \"a.toml\"\nactive = true\n[events]\nx = {}\n",
            ),
            (
                "a.toml",
                "name = \"A\"\nvehicles = \"all\"\nplaces = [\"idle\", \"on\"]\ninitial = [\"idle\"]\n\
                 [[transition]]\nname = \"go\"\nfrom = [\"idle\"]\nto = [\"on\"]\non = \"x\"\n\
                 do = [\"command goto {lat: 51.5, lon: -2.5, alt: 0}\"]\n",
            ),
        ];
        nets::load(&files).unwrap_or_else(|e| panic!("{e}"))
    }

    fn bytes(system: u8, component: u8, message: &MavMessage) -> Vec<u8> {
        let header = MavHeader {
            system_id: u32::from(system),
            component_id: component,
            sequence: 0,
        };
        elaboration::frame::serialize(header, MavlinkVersion::V2, message)
    }

    /// A rover's HEARTBEAT in `custom_mode` (Rover: 4 HOLD, 15 GUIDED).
    pub(crate) fn heartbeat(system: u8, custom_mode: u32, armed: bool) -> Vec<u8> {
        let mut base_mode = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
        if armed {
            base_mode |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
        }
        bytes(
            system,
            1,
            &MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                custom_mode,
                mavtype: MavType::MAV_TYPE_GROUND_ROVER,
                autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                base_mode,
                system_status: MavState::MAV_STATE_ACTIVE,
                mavlink_version: 3,
            }),
        )
    }

    /// The strips as the page reads them.
    fn json(v: &Vehicles) -> Json {
        v.all
            .iter()
            .map(|x| strip_json(x, &x.strip, v.now))
            .collect::<Vec<_>>()
            .into()
    }

    pub(crate) fn position(system: u8, lat: f64, lon: f64) -> Vec<u8> {
        bytes(
            system,
            1,
            &MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                lat: (lat * 1e7) as i32,
                lon: (lon * 1e7) as i32,
                hdg: u16::MAX,
                ..GLOBAL_POSITION_INT_DATA::default()
            }),
        )
    }

    #[test]
    fn each_team_vehicle_is_followed_by_its_system_and_others_are_ignored() {
        let project = team();
        let mut v = Vehicles::new(&project, 100);
        v.frame(1, &heartbeat(2, 15, true));
        v.frame(2, &heartbeat(1, 4, false));
        // A third system (a ground station, a stranger) and R1's camera.
        v.frame(3, &heartbeat(3, 15, true));
        v.frame(
            3,
            &bytes(
                1,
                100,
                &MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                    custom_mode: 15,
                    mavtype: MavType::MAV_TYPE_CAMERA,
                    autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
                    base_mode: MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED,
                    system_status: MavState::MAV_STATE_ACTIVE,
                    mavlink_version: 3,
                }),
            ),
        );
        v.frame(4, &position(1, 51.0, -2.0));
        v.frame(5, &position(2, 51.1, -2.1));
        v.frame(6, &position(3, 10.0, 10.0));
        v.now = 6;
        let j = json(&v);
        let all = j.as_array().cloned().unwrap_or_default();
        assert_eq!(all.len(), 2);
        assert_eq!(
            (&all[0]["name"], &all[0]["system"]),
            (&json!("R1"), &json!(1))
        );
        assert_eq!(
            (&all[1]["name"], &all[1]["system"]),
            (&json!("R2"), &json!(2))
        );
        assert_eq!(all[0]["mode"], "HOLD");
        assert_eq!(all[0]["armed"], false);
        assert_eq!(all[1]["mode"], "GUIDED");
        assert_eq!(all[1]["armed"], true);
        assert_eq!(all[0]["position"], json!([51.0, -2.0]));
        assert_eq!(all[1]["position"], json!([51.1, -2.1]));
        assert_eq!(v.all[0].track.len(), 1);
        assert_eq!(v.all[1].track, vec![(5, 51.1, -2.1)]);
    }

    #[test]
    fn a_command_and_an_answer_go_to_the_vehicle_they_are_for() {
        let project = team();
        let mut v = Vehicles::new(&project, 100);
        let goto = |vehicle| Effect::Command {
            time: 0,
            id: 1,
            net: 0,
            verb: "goto".into(),
            args: [("lat", 51.5), ("lon", -2.5)]
                .into_iter()
                .map(|(k, x)| (k.to_owned(), nets::Value::Float(x)))
                .collect(),
            vehicle,
        };
        v.begin();
        v.effect(&goto(Some(1)));
        assert!(v.changed && !v.all[0].changed && v.all[1].changed);
        assert!(v.all[0].strip.targets.is_empty());
        assert_eq!(v.all[1].strip.targets.len(), 1);
        // A team net's command naming no vehicle marks none.
        v.begin();
        v.effect(&goto(None));
        assert!(!v.changed);
        v.answer(
            Some(0),
            "DEC.site",
            &json!({"lat": 51.2, "lon": -2.2, "name": "field"}),
        );
        assert_eq!(v.all[0].strip.sites[0].label, "field (DEC.site)");
        assert!(v.all[1].strip.sites.is_empty());
    }

    #[test]
    fn without_a_team_the_first_autopilot_heard_is_followed() {
        let project = super::super::board::tests::project();
        let mut v = Vehicles::new(&project, 100);
        assert_eq!(v.all.len(), 1);
        v.frame(1, &heartbeat(7, 15, true));
        v.frame(2, &heartbeat(8, 4, false));
        v.frame(3, &position(7, 51.0, -2.0));
        v.frame(4, &position(8, 52.0, -2.0));
        let j = json(&v);
        assert_eq!(j[0]["name"], Json::Null);
        assert_eq!(j[0]["system"], 7);
        assert_eq!(j[0]["mode"], "GUIDED");
        assert_eq!(j[0]["position"], json!([51.0, -2.0]));
        // Its command, naming no vehicle, is its own.
        v.effect(&Effect::Command {
            time: 0,
            id: 1,
            net: 0,
            verb: "land".into(),
            args: [("lat", 51.5), ("lon", -2.5)]
                .into_iter()
                .map(|(k, x)| (k.to_owned(), nets::Value::Float(x)))
                .collect(),
            vehicle: None,
        });
        assert_eq!(v.all[0].strip.targets.len(), 1);
    }
}
