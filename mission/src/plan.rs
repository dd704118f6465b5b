//! The typed form every plan file is read into.

use mavlink::dialects::ardupilotmega::MavCmd;
use num_traits::FromPrimitive;

/// Which format a plan came in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// QGroundControl's `.plan` JSON.
    QgcPlan,
    /// `QGC WPL 110`: row 0 is home.
    Wpl110,
    /// `QGC WPL 120`: no home row.
    Wpl120,
}

/// The autopilot a plan was made for (`firmwareType`, MAV_AUTOPILOT).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Autopilot {
    ArduPilot,
    Px4,
    /// Another MAV_AUTOPILOT number (0: generic).
    Other(u8),
}

impl Autopilot {
    pub fn from_mav_autopilot(n: u8) -> Autopilot {
        match n {
            3 => Autopilot::ArduPilot,
            12 => Autopilot::Px4,
            n => Autopilot::Other(n),
        }
    }
}

/// The kind of vehicle a plan was made for (`vehicleType`, MAV_TYPE).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VehicleType {
    Plane,
    Copter,
    Rover,
    Boat,
    Vtol,
    /// Another MAV_TYPE number.
    Other(u8),
}

impl VehicleType {
    pub fn from_mav_type(n: u8) -> VehicleType {
        match n {
            1 => VehicleType::Plane,
            2..=4 | 13..=15 | 29 => VehicleType::Copter,
            10 => VehicleType::Rover,
            11 => VehicleType::Boat,
            19..=25 => VehicleType::Vtol,
            n => VehicleType::Other(n),
        }
    }
}

/// A position: degrees, and metres (its reference is the item's frame; a
/// `.plan`'s home and a WPL's home row are above mean sea level).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Position {
    pub lat: f64,
    pub lon: f64,
    /// NaN when the file gives none.
    pub alt: f64,
}

/// Where an item is in its file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// A line of a WPL file (from 1).
    Line(usize),
    /// `mission.items[index]` of a `.plan`; `within`: its index among the
    /// items a survey or corridor pattern stored.
    PlanItem { index: usize, within: Option<usize> },
}

/// One mission item, as it goes to the vehicle (MISSION_ITEM_INT's
/// fields).
#[derive(Debug, Clone, PartialEq)]
pub struct Item {
    /// Its sequence number in the mission: home is 0, the items follow
    /// from 1 in file order. A DO_JUMP's `params[0]` is its target's.
    pub seq: u16,
    /// MAV_CMD.
    pub command: u16,
    /// MAV_FRAME.
    pub frame: u8,
    /// param1 to param4; NaN where the file says `null`.
    pub params: [f64; 4],
    /// x (latitude), y (longitude), z (altitude); NaN where `null`.
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub autocontinue: bool,
    pub origin: Origin,
}

impl Item {
    /// Whether the item gives a position (0, 0 on a NAV item means none:
    /// FORMATS.md §2).
    pub fn has_position(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && !(self.x == 0.0 && self.y == 0.0)
    }

    /// Its command's name (`NAV_WAYPOINT`), or its number.
    pub fn command_name(&self) -> String {
        command_name(self.command)
    }
}

/// A MAV_CMD's name without its prefix (`NAV_WAYPOINT`), or `command N`
/// when the dialect does not have it.
pub fn command_name(command: u16) -> String {
    match MavCmd::from_u16(command) {
        Some(c) => {
            let name = format!("{c:?}");
            name.strip_prefix("MAV_CMD_")
                .map_or(name.clone(), str::to_owned)
        }
        None => format!("command {command}"),
    }
}

/// A fence polygon: the vehicle must stay inside (`inclusion`) or out.
#[derive(Debug, Clone, PartialEq)]
pub struct Polygon {
    pub inclusion: bool,
    /// (latitude, longitude) in degrees.
    pub vertices: Vec<(f64, f64)>,
}

/// A fence circle.
#[derive(Debug, Clone, PartialEq)]
pub struct Circle {
    pub inclusion: bool,
    pub center: (f64, f64),
    /// Metres.
    pub radius: f64,
}

/// The geofence a plan carries.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Fence {
    pub polygons: Vec<Polygon>,
    pub circles: Vec<Circle>,
    /// Where the vehicle goes on a breach, if the plan says.
    pub breach_return: Option<Position>,
}

impl Fence {
    pub fn is_empty(&self) -> bool {
        self.polygons.is_empty() && self.circles.is_empty() && self.breach_return.is_none()
    }
}

/// What a plan holds that no mission item says, or says otherwise than a
/// crew may mean it: named, with what to do.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Unsupported {
    /// Where it is in the file.
    pub origin: Origin,
    /// What it is (`StructureScan`, `survey version 3`…).
    pub what: String,
    /// What the crew can do about it.
    pub remedy: String,
}

/// A mission plan, whatever file it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub format: Format,
    pub autopilot: Option<Autopilot>,
    pub vehicle: Option<VehicleType>,
    /// Home (sequence 0): the `.plan`'s planned home, a WPL 110's row 0.
    pub home: Option<Position>,
    /// The mission items from sequence 1.
    pub items: Vec<Item>,
    pub fence: Fence,
    /// Rally points (altitude above home).
    pub rally: Vec<Position>,
    /// Items the file holds that are not mission items.
    pub unsupported: Vec<Unsupported>,
}
