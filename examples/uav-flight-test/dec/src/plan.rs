//! Plans: the mission as ArduPlane mission items, and what each item means
//! to the nets. Seq numbers are ArduPilot's: item 0 is home (the gateway
//! sends it), the plan's items start at 1.
//!
//! A plan is TAKEOFF (on the ground only), the route's waypoints — an
//! operations-area waypoint with a payload is a WAYPOINT (arrival: its
//! payload starts) and a LOITER_TIME over it (its end: the payload stops) —
//! then the landing sequence at home: DO_LAND_START, the approach waypoint,
//! LAND. ArduPlane's `land` (DO_LAND_START) joins that sequence.

use serde_json::{json, Value};

use crate::geo::LatLon;
use crate::mission::{Area, Mission};

/// The phase the aircraft is in while flying to an item.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    Takeoff,
    Transit,
    Operations,
    Return,
    Landing,
}

impl Phase {
    /// The name the nets' guards compare (`phase == "operations"`).
    pub fn name(self) -> &'static str {
        match self {
            Phase::Takeoff => "takeoff",
            Phase::Transit => "transit",
            Phase::Operations => "operations",
            Phase::Return => "return",
            Phase::Landing => "landing",
        }
    }
}

/// What an item is for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Role {
    Takeoff,
    /// A waypoint of the route without a payload operation.
    Pass,
    /// Arrival over a waypoint whose payload then operates.
    Arrival,
    /// The loiter of a payload operation, `seconds` long.
    Loiter {
        seconds: f64,
    },
    LandStart,
    Approach,
    Land,
}

/// One mission item of a plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Item {
    /// ArduPilot's sequence number (from 1).
    pub seq: u16,
    pub role: Role,
    pub at: LatLon,
    /// Metres above home.
    pub alt: f64,
    pub phase: Phase,
    /// Index of the route waypoint it belongs to.
    pub waypoint: Option<usize>,
}

/// A plan: mission items from seq 1.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub items: Vec<Item>,
}

impl Plan {
    /// The plan flying `route` (indices of the mission's waypoints, in
    /// order), with a TAKEOFF first when `takeoff`, and the landing
    /// sequence at home last.
    pub fn build(mission: &Mission, route: &[usize], takeoff: bool) -> Plan {
        let mut items: Vec<Item> = Vec::new();
        let mut push = |role, at: LatLon, alt, phase, waypoint| {
            let seq = items.len() as u16 + 1;
            items.push(Item {
                seq,
                role,
                at: at.rounded(),
                alt,
                phase,
                waypoint,
            });
        };
        if takeoff {
            push(
                Role::Takeoff,
                mission.home,
                mission.flight.takeoff_alt,
                Phase::Takeoff,
                None,
            );
        }
        for &i in route {
            let Some(w) = mission.waypoints.get(i) else {
                continue;
            };
            let phase = match w.area {
                Area::Transit => Phase::Transit,
                Area::Operations => Phase::Operations,
            };
            if w.payload.is_some() {
                push(Role::Arrival, w.at, w.alt, phase, Some(i));
                push(
                    Role::Loiter {
                        seconds: w.operation,
                    },
                    w.at,
                    w.alt,
                    phase,
                    Some(i),
                );
            } else {
                push(Role::Pass, w.at, w.alt, phase, Some(i));
            }
        }
        push(Role::LandStart, mission.approach, 0.0, Phase::Return, None);
        push(
            Role::Approach,
            mission.approach,
            mission.approach_alt,
            Phase::Return,
            None,
        );
        push(Role::Land, mission.home, 0.0, Phase::Landing, None);
        Plan { items }
    }

    /// The whole route of the mission, from the ground.
    pub fn full(mission: &Mission, without: &dyn Fn(usize) -> bool) -> Plan {
        let route: Vec<usize> = (0..mission.waypoints.len())
            .filter(|&i| !without(i))
            .collect();
        Plan::build(mission, &route, true)
    }

    pub fn item(&self, seq: u16) -> Option<&Item> {
        self.items.get(usize::from(seq).checked_sub(1)?)
    }

    /// The phase the aircraft is in once item `seq` is reached: that of the
    /// next item (the last item's own after the last).
    pub fn phase_after(&self, seq: u16) -> Option<Phase> {
        let here = self.item(seq)?;
        Some(self.item(seq + 1).map_or(here.phase, |next| next.phase))
    }

    /// The route waypoints still to fly once item `last_reached` has been
    /// reached (0: none yet), in order: those with an item after it.
    pub fn remaining(&self, last_reached: u16) -> Vec<usize> {
        let mut out: Vec<usize> = Vec::new();
        for item in self.items.iter().filter(|i| i.seq > last_reached) {
            if let Some(w) = item.waypoint {
                if out.last() != Some(&w) {
                    out.push(w);
                }
            }
        }
        out
    }

    /// The items as `upload_mission` takes them (docs/vehicle.md).
    pub fn to_json(&self, mission: &Mission) -> Value {
        Value::Array(self.items.iter().map(|i| i.to_json(mission)).collect())
    }
}

impl Item {
    fn to_json(&self, mission: &Mission) -> Value {
        let (lat, lon) = (self.at.lat, self.at.lon);
        match self.role {
            Role::Takeoff => json!({
                "command": "TAKEOFF", "lat": lat, "lon": lon, "alt": self.alt,
                "p1": mission.flight.takeoff_pitch,
            }),
            Role::Pass | Role::Arrival | Role::Approach => json!({
                "command": "WAYPOINT", "lat": lat, "lon": lon, "alt": self.alt,
            }),
            Role::Loiter { seconds } => json!({
                "command": "LOITER_TIME", "lat": lat, "lon": lon, "alt": self.alt,
                "p1": seconds,
            }),
            Role::LandStart => json!({
                "command": "DO_LAND_START", "lat": lat, "lon": lon, "alt": 0.0,
            }),
            Role::Land => json!({
                "command": "LAND", "lat": lat, "lon": lon, "alt": self.alt,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::tests::example;

    fn commands(plan: &Plan, mission: &Mission) -> Vec<String> {
        plan.to_json(mission)
            .as_array()
            .map(|a| {
                a.iter()
                    .map(|i| i["command"].as_str().unwrap_or("?").to_owned())
                    .collect()
            })
            .unwrap_or_default()
    }

    #[test]
    fn the_full_plan_of_the_example() {
        let m = example();
        let plan = Plan::full(&m, &|_| false);
        assert_eq!(
            commands(&plan, &m),
            [
                "TAKEOFF",
                "WAYPOINT",
                "WAYPOINT",
                "LOITER_TIME",
                "WAYPOINT",
                "LOITER_TIME",
                "WAYPOINT",
                "LOITER_TIME",
                "DO_LAND_START",
                "WAYPOINT",
                "LAND"
            ]
        );
        let json = plan.to_json(&m);
        assert_eq!(json[0]["alt"], 50.0);
        assert_eq!(json[0]["p1"], 15.0);
        assert_eq!(json[1]["lat"], -35.359656);
        assert_eq!(json[3]["p1"], 10.0);
        assert_eq!(json[9]["alt"], 40.0);
        assert_eq!(json[10]["lat"], -35.363261);
        assert_eq!(json[10]["alt"], 0.0);
        let seqs: Vec<u16> = plan.items.iter().map(|i| i.seq).collect();
        assert_eq!(seqs, (1..=11).collect::<Vec<u16>>());
    }

    #[test]
    fn phases_after_each_item() {
        let m = example();
        let plan = Plan::full(&m, &|_| false);
        let after: Vec<&str> = (1..=11)
            .map(|s| plan.phase_after(s).map_or("-", Phase::name))
            .collect();
        assert_eq!(
            after,
            [
                "transit",    // TAKEOFF reached: flying to T1
                "operations", // T1 reached: flying to O1
                "operations", // O1 arrival: loitering
                "operations", // O1 loiter over: flying to O2
                "operations",
                "operations",
                "operations",
                "return",  // O3 loiter over: to the landing sequence
                "return",  // DO_LAND_START: flying to the approach
                "landing", // approach reached: final
                "landing"
            ]
        );
        assert_eq!(plan.phase_after(0), None);
        assert_eq!(plan.phase_after(12), None);
    }

    #[test]
    fn remaining_waypoints_follow_progress() {
        let m = example();
        let plan = Plan::full(&m, &|_| false);
        assert_eq!(plan.remaining(0), [0, 1, 2, 3]);
        assert_eq!(plan.remaining(2), [1, 2, 3]); // T1 reached
        assert_eq!(plan.remaining(3), [1, 2, 3]); // O1 arrival: its loiter is left
        assert_eq!(plan.remaining(4), [2, 3]);
        assert_eq!(plan.remaining(8), Vec::<usize>::new());
        assert_eq!(plan.remaining(11), Vec::<usize>::new());
    }

    #[test]
    fn without_the_camera_only_the_sensor_waypoint_is_left() {
        let m = example();
        let camera = |i: usize| m.waypoints[i].payload.as_deref() == Some("camera");
        let plan = Plan::full(&m, &camera);
        assert_eq!(
            commands(&plan, &m),
            [
                "TAKEOFF",
                "WAYPOINT",
                "WAYPOINT",
                "LOITER_TIME",
                "DO_LAND_START",
                "WAYPOINT",
                "LAND"
            ]
        );
        assert_eq!(plan.items[2].waypoint, Some(2)); // O2
    }
}
