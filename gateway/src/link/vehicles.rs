//! The vehicles heard on a link, and the one the gateway supervises.
//!
//! A link may carry several vehicles (a router, a radio network). One
//! `petrel run` supervises exactly one: the configured system id
//! (`[gateway] system_id`), or else the first autopilot heard. Every frame
//! of another vehicle's system — its autopilot, its camera, and a gateway
//! speaking under its id — is dropped here, before elaboration, the
//! commander and the recording see it, so that they all follow the same
//! vehicle. Systems that are no vehicle (a ground station, a SiK radio's
//! system 51) pass: elaboration watches them too.
//!
//! A team (`[[vehicle]]`, docs/multi-vehicle.md) keeps every system of
//! its vehicles on this link ([`Vehicles::team`]) and drops every other
//! vehicle's, a team vehicle declared on another link included (it would be
//! heard twice).
//!
//! Sans-IO: fed each frame's sender and, for a HEARTBEAT, its content;
//! says whether to keep the frame. What it decides is told once, as
//! [`Notice`]s for the gateway's log.

use std::collections::btree_map::Entry;
use std::collections::{BTreeMap, VecDeque};
use std::fmt;

use mavlink::dialects::ardupilotmega::{MavAutopilot, MavType, HEARTBEAT_DATA};

/// An autopilot heard on the link.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vehicle {
    pub system: u8,
    /// The autopilot's component.
    pub component: u8,
    pub mav_type: MavType,
    pub autopilot: MavAutopilot,
}

impl fmt::Display for Vehicle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ty = format!("{:?}", self.mav_type);
        let ap = format!("{:?}", self.autopilot);
        write!(
            f,
            "vehicle {} ({} {}, autopilot component {})",
            self.system,
            ap.strip_prefix("MAV_AUTOPILOT_").unwrap_or(&ap),
            ty.strip_prefix("MAV_TYPE_").unwrap_or(&ty),
            self.component
        )
    }
}

/// What the link decided about a vehicle; each is told once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Notice {
    /// No system id configured: the first autopilot heard is supervised.
    Locked(Vehicle),
    /// The configured vehicle's autopilot is heard.
    Found(Vehicle),
    /// Another vehicle: its frames are dropped. `supervised` is the system
    /// id followed instead.
    Ignored { vehicle: Vehicle, supervised: u8 },
    /// A vehicle of the team is heard on this link.
    Member(Vehicle),
    /// A vehicle that is no vehicle of the team on this link: its frames
    /// are dropped.
    Outside(Vehicle),
}

impl fmt::Display for Notice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Notice::Locked(v) => write!(
                f,
                "supervising {v}: the first autopilot heard (set [gateway] system_id to choose)"
            ),
            Notice::Found(v) => write!(f, "supervising {v}: [gateway] system_id"),
            Notice::Ignored {
                vehicle,
                supervised,
            } => write!(
                f,
                "ignoring {vehicle}: this gateway supervises vehicle {supervised} only"
            ),
            Notice::Member(v) => write!(f, "supervising {v}: a vehicle of the team ([[vehicle]])"),
            Notice::Outside(v) => write!(
                f,
                "ignoring {v}: no vehicle of the team on this link ([[vehicle]] system and link)"
            ),
        }
    }
}

/// The supervised vehicle and the others heard.
#[derive(Debug, Clone, Default)]
pub struct Vehicles {
    /// The configured system id, if any.
    configured: Option<u8>,
    /// A team's systems on this link (empty: one vehicle, `configured`).
    team: Vec<u8>,
    /// The team's vehicles heard, by system id.
    members: BTreeMap<u8, Vehicle>,
    /// The supervised vehicle's autopilot, once heard.
    supervised: Option<Vehicle>,
    /// Other vehicles, by system id.
    ignored: BTreeMap<u8, Vehicle>,
    notices: VecDeque<Notice>,
    dropped: u64,
}

/// Whether a HEARTBEAT is an autopilot's: a real autopilot field, and
/// neither a ground station nor a companion computer (as the commander
/// judges it: docs/vehicle.md).
pub fn is_autopilot(hb: &HEARTBEAT_DATA) -> bool {
    hb.autopilot != MavAutopilot::MAV_AUTOPILOT_INVALID
        && !matches!(
            hb.mavtype,
            MavType::MAV_TYPE_GCS | MavType::MAV_TYPE_ONBOARD_CONTROLLER
        )
}

impl Vehicles {
    /// Supervises `system` when given, else the first autopilot heard.
    pub fn new(system: Option<u8>) -> Vehicles {
        Vehicles {
            configured: system,
            ..Vehicles::default()
        }
    }

    /// Supervises the team's `systems` (those of its vehicles on this link):
    /// every other vehicle's frames are dropped.
    pub fn team(systems: Vec<u8>) -> Vehicles {
        Vehicles {
            team: systems,
            ..Vehicles::default()
        }
    }

    /// The team's vehicles heard so far, by system id.
    pub fn members(&self) -> impl Iterator<Item = &Vehicle> {
        self.members.values()
    }

    /// The supervised system id: configured, or locked on.
    pub fn supervised(&self) -> Option<u8> {
        self.configured.or(self.supervised.map(|v| v.system))
    }

    /// The supervised vehicle's autopilot, once heard.
    pub fn vehicle(&self) -> Option<Vehicle> {
        self.supervised
    }

    /// The other vehicles heard, by system id.
    pub fn ignored(&self) -> impl Iterator<Item = &Vehicle> {
        self.ignored.values()
    }

    /// Frames dropped so far (other vehicles').
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// The next thing to tell.
    pub fn poll_notice(&mut self) -> Option<Notice> {
        self.notices.pop_front()
    }

    /// Whether to keep a frame from (`system`, `component`); `heartbeat` is
    /// its content when it is a HEARTBEAT that decodes.
    pub fn admit(&mut self, system: u8, component: u8, heartbeat: Option<&HEARTBEAT_DATA>) -> bool {
        if let Some(hb) = heartbeat.filter(|hb| is_autopilot(hb)) {
            self.autopilot_heard(Vehicle {
                system,
                component,
                mav_type: hb.mavtype,
                autopilot: hb.autopilot,
            });
        }
        let keep = !self.ignored.contains_key(&system);
        if !keep {
            self.dropped += 1;
        }
        keep
    }

    fn autopilot_heard(&mut self, vehicle: Vehicle) {
        if !self.team.is_empty() {
            return self.team_autopilot_heard(vehicle);
        }
        let supervised = match self.supervised() {
            Some(s) => s,
            None => {
                self.supervised = Some(vehicle);
                self.notices.push_back(Notice::Locked(vehicle));
                return;
            }
        };
        if vehicle.system == supervised {
            if self.supervised.is_none() {
                self.supervised = Some(vehicle);
                self.notices.push_back(Notice::Found(vehicle));
            }
        } else if let Entry::Vacant(entry) = self.ignored.entry(vehicle.system) {
            entry.insert(vehicle);
            self.notices.push_back(Notice::Ignored {
                vehicle,
                supervised,
            });
        }
    }
}

impl Vehicles {
    fn team_autopilot_heard(&mut self, vehicle: Vehicle) {
        let (known, notice) = if self.team.contains(&vehicle.system) {
            (&mut self.members, Notice::Member(vehicle))
        } else {
            (&mut self.ignored, Notice::Outside(vehicle))
        };
        if let Entry::Vacant(entry) = known.entry(vehicle.system) {
            entry.insert(vehicle);
            self.notices.push_back(notice);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::{MavModeFlag, MavState};

    fn heartbeat(mavtype: MavType, autopilot: MavAutopilot) -> HEARTBEAT_DATA {
        HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype,
            autopilot,
            base_mode: MavModeFlag::empty(),
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        }
    }

    fn copter() -> HEARTBEAT_DATA {
        heartbeat(
            MavType::MAV_TYPE_QUADROTOR,
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        )
    }

    fn companion() -> HEARTBEAT_DATA {
        heartbeat(
            MavType::MAV_TYPE_ONBOARD_CONTROLLER,
            MavAutopilot::MAV_AUTOPILOT_INVALID,
        )
    }

    fn gcs() -> HEARTBEAT_DATA {
        heartbeat(MavType::MAV_TYPE_GCS, MavAutopilot::MAV_AUTOPILOT_INVALID)
    }

    fn notices(v: &mut Vehicles) -> Vec<Notice> {
        std::iter::from_fn(|| v.poll_notice()).collect()
    }

    #[test]
    fn configured_vehicle_kept_others_dropped_and_told_once() {
        let mut v = Vehicles::new(Some(2));
        assert_eq!(v.supervised(), Some(2));
        // Before vehicle 1's autopilot is heard, its frames pass.
        assert!(v.admit(1, 1, None));
        assert!(!v.admit(1, 1, Some(&copter())));
        assert!(v.admit(2, 1, Some(&copter())));
        // Everything of system 1 is dropped from now on: its autopilot,
        // its gateway speaking under its id, its camera.
        assert!(!v.admit(1, 1, None));
        assert!(!v.admit(1, 191, Some(&companion())));
        assert!(!v.admit(1, 100, None));
        assert!(!v.admit(1, 1, Some(&copter())));
        // Our own system's other components, a ground station, a radio pass.
        assert!(v.admit(2, 100, None));
        assert!(v.admit(255, 190, Some(&gcs())));
        assert!(v.admit(51, 68, None));
        assert_eq!(v.dropped(), 5);
        let told = notices(&mut v);
        assert_eq!(told.len(), 2, "{told:?}");
        assert!(matches!(
            told[0],
            Notice::Ignored { vehicle, supervised: 2 } if vehicle.system == 1
        ));
        assert!(matches!(told[1], Notice::Found(vehicle) if vehicle.system == 2));
        assert_eq!(
            told[0].to_string(),
            "ignoring vehicle 1 (ARDUPILOTMEGA QUADROTOR, autopilot component 1): this gateway supervises vehicle 2 only"
        );
        assert_eq!(v.ignored().map(|v| v.system).collect::<Vec<_>>(), [1]);
    }

    #[test]
    fn without_configuration_the_first_autopilot_is_locked() {
        let mut v = Vehicles::new(None);
        assert_eq!(v.supervised(), None);
        // A ground station and a companion computer are no vehicle.
        assert!(v.admit(255, 190, Some(&gcs())));
        assert!(v.admit(7, 191, Some(&companion())));
        assert!(v.admit(3, 1, None));
        assert_eq!(v.supervised(), None);
        assert!(v.admit(3, 1, Some(&copter())));
        assert_eq!(v.supervised(), Some(3));
        assert!(!v.admit(4, 1, Some(&copter())));
        assert!(!v.admit(4, 1, Some(&copter())));
        assert!(v.admit(3, 1, Some(&copter())));
        assert!(v.admit(7, 191, Some(&companion())));
        let told = notices(&mut v);
        assert_eq!(told.len(), 2, "{told:?}");
        assert!(matches!(told[0], Notice::Locked(vehicle) if vehicle.system == 3));
        assert!(told[0].to_string().starts_with("supervising vehicle 3 ("));
        assert!(matches!(
            told[1],
            Notice::Ignored { vehicle, supervised: 3 } if vehicle.system == 4
        ));
    }

    #[test]
    fn forged_ids_keep_memory_bounded() {
        let mut v = Vehicles::new(Some(1));
        for _ in 0..3 {
            for system in 0..=255u8 {
                v.admit(system, 1, Some(&copter()));
            }
        }
        assert_eq!(v.ignored().count(), 255);
        assert_eq!(notices(&mut v).len(), 256);
    }

    #[test]
    fn a_team_keeps_its_vehicles_and_drops_the_others_told_once() {
        let mut v = Vehicles::team(vec![1, 3]);
        assert!(v.admit(1, 1, Some(&copter())));
        assert!(v.admit(3, 1, Some(&copter())));
        // Vehicle 2 (outside the team, or a team vehicle on another link).
        assert!(!v.admit(2, 1, Some(&copter())));
        assert!(!v.admit(2, 1, None));
        assert!(!v.admit(2, 191, Some(&companion())));
        // The team's other components, a ground station, a radio pass.
        assert!(v.admit(1, 100, None));
        assert!(v.admit(3, 1, Some(&copter())));
        assert!(v.admit(255, 190, Some(&gcs())));
        assert!(v.admit(51, 68, None));
        assert_eq!(v.dropped(), 3);
        let told = notices(&mut v);
        assert_eq!(told.len(), 3, "{told:?}");
        assert!(matches!(told[0], Notice::Member(vehicle) if vehicle.system == 1));
        assert!(matches!(told[1], Notice::Member(vehicle) if vehicle.system == 3));
        assert!(matches!(told[2], Notice::Outside(vehicle) if vehicle.system == 2));
        assert_eq!(
            told[2].to_string(),
            "ignoring vehicle 2 (ARDUPILOTMEGA QUADROTOR, autopilot component 1): no vehicle of the team on this link ([[vehicle]] system and link)"
        );
        assert_eq!(v.members().map(|v| v.system).collect::<Vec<_>>(), [1, 3]);
    }
}
