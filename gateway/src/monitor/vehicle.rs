//! The vehicle strip and the map's contents, read from the frames the
//! supervisor is fed (the same in `run` and over a recording) and from the
//! nets' commands and results: mode, armed, altitude, ground speed,
//! battery, GPS, link quality, the last autopilot HEARTBEAT; the track, home,
//! the mission's waypoints, and positions the programs answered (emergency
//! sites). Only the first autopilot heard is followed.

use mavlink::dialects::ardupilotmega::{MavAutopilot, MavMessage, MavModeFlag, MavType};
use nets::{Effect, Micros};
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

/// The vehicle as the monitor follows it.
#[derive(Debug, Clone, Default)]
pub struct Vehicle {
    pub strip: Strip,
    /// The latest time seen.
    pub now: Micros,
    /// Whether the last step changed the strip.
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

impl Vehicle {
    pub fn new(track_cap: usize) -> Vehicle {
        Vehicle {
            track_cap,
            ..Vehicle::default()
        }
    }

    /// A frame as fed to the supervisor.
    pub fn frame(&mut self, time: Micros, bytes: &[u8]) {
        let Ok(frame) = elaboration::Frame::parse(bytes) else {
            return;
        };
        if !READ.contains(&frame.message_id()) {
            return;
        }
        let from = (frame.system_id(), frame.component_id());
        let Ok(message) = frame.decode() else {
            return;
        };
        if let MavMessage::HEARTBEAT(hb) = &message {
            let autopilot = hb.autopilot != MavAutopilot::MAV_AUTOPILOT_INVALID
                && hb.mavtype != MavType::MAV_TYPE_GCS
                && hb.mavtype != MavType::MAV_TYPE_ONBOARD_CONTROLLER;
            if self.followed.is_none() && autopilot {
                self.followed = Some(from);
            }
        }
        if self.followed != Some(from) {
            return;
        }
        let before = self.strip.clone();
        self.message(time, &message);
        self.changed |= before != self.strip;
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

    /// The nets' commands: the mission's waypoints and guided targets.
    pub fn effect(&mut self, effect: &Effect) {
        let Effect::Command { verb, args, .. } = effect else {
            return;
        };
        let args: Json = args.iter().map(|(k, v)| (k.clone(), v.to_json())).collect();
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
        self.changed |= before != self.strip;
    }

    /// A program's answer naming a position (an emergency site, say).
    pub fn answer(&mut self, of: &str, done: &Json) {
        if let Some(mut m) = at(done, of.to_owned()) {
            if let Some(name) = done["name"].as_str() {
                m.label = format!("{name} ({of})");
            }
            if !self.strip.sites.contains(&m) {
                self.strip.sites.push(m);
                self.changed = true;
            }
        }
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
