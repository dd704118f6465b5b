//! What the vehicle's navigation remembers between steps: the plane's
//! flight (its stage, orbit, take-off and landing, the demand a mode flies),
//! AUTO's progress through the mission, the rover's navigation. Data only:
//! [`crate::vehicle::Vehicle`] holds it, and the steps that change it are
//! `impl Vehicle` blocks in `flight.rs`, `auto.rs` and `rover.rs`, which
//! import this module and `vehicle.rs` (never the other way round).

use crate::geo::V2;
use crate::guidance::Nav;
use crate::modes;

// ---- the plane's flight (flight.rs)

/// A circle to loiter on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orbit {
    pub center: V2,
    pub radius: f64,
    pub ccw: bool,
    /// Metres above home.
    pub alt: f64,
}

/// Where the flight is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stage {
    /// On the ground, not going anywhere.
    Ground,
    /// Armed for take-off, throttle held until `trigger` (TKOFF_THR_DELAY).
    TakeoffWait { trigger: u64 },
    /// Full throttle down the runway.
    TakeoffRoll,
    /// Climbing to the take-off altitude.
    TakeoffClimb,
    /// In flight under the mode's navigation.
    Cruise,
    /// Landing: on the glide slope.
    Approach,
    /// Landing: the flare.
    Flare,
    /// Rolling on the ground after touching down (`landing`: a landing,
    /// else a crash).
    Rollout { landing: bool },
    /// Stopped after a landing or a crash.
    Stopped,
}

/// The take-off under way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Takeoff {
    pub start: V2,
    /// Ground course (radians).
    pub course: f64,
    /// Metres above home.
    pub alt: f64,
    /// Climb angle asked (mission item param1, degrees).
    pub pitch: f64,
    /// The mission item, when the mission started it.
    pub mission_seq: Option<u16>,
    pub level_off_said: bool,
    pub course_said: bool,
}

/// The landing under way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landing {
    pub from: V2,
    pub to: V2,
    pub start_alt: f64,
    pub land_alt: f64,
}

/// The autopilot's flight state.
#[derive(Debug, Clone, PartialEq)]
pub struct Flight {
    pub mode: u32,
    pub armed: bool,
    pub stage: Stage,
    pub crashed: bool,
    /// When a crash touchdown happened (crash detection confirms it 2.5 s later).
    pub crash_at: Option<u64>,
    /// When the landing roll stopped.
    pub stopped_at: Option<u64>,
    pub landed: bool,
    /// DO_CHANGE_SPEED airspeed (m/s).
    pub airspeed_override: Option<f64>,
    /// DO_CHANGE_SPEED ground speed minimum (m/s).
    pub min_groundspeed: f64,
    /// The mode's loiter circle (LOITER, RTL, GUIDED, TAKEOFF once done).
    pub orbit: Option<Orbit>,
    /// FBWB/CRUISE: course and altitude held.
    pub hold: (f64, f64),
    pub takeoff: Option<Takeoff>,
    pub landing: Option<Landing>,
    /// Navigation outputs for NAV_CONTROLLER_OUTPUT / POSITION_TARGET_GLOBAL_INT.
    pub nav: Nav,
    pub nav_roll: f64,
    pub target: Option<(V2, f64)>,
    pub alt_target: f64,
    pub speed_target: f64,
    pub max_bank: f64,
    /// Battery failsafe level: 0 none, 1 low, 2 critical.
    pub battery_failsafe: u8,
    pub armed_at: Option<u64>,
    pub flight_time_us: u64,
    /// RTL_AUTOLAND 1: the landing sequence was looked for in this RTL.
    pub rtl_autoland_checked: bool,
}

impl Flight {
    pub fn new() -> Flight {
        Flight {
            mode: modes::INITIALISING,
            armed: false,
            stage: Stage::Ground,
            crashed: false,
            crash_at: None,
            stopped_at: None,
            landed: false,
            airspeed_override: None,
            min_groundspeed: 0.0,
            orbit: None,
            hold: (0.0, 0.0),
            takeoff: None,
            landing: None,
            nav: Nav::default(),
            nav_roll: 0.0,
            target: None,
            alt_target: 0.0,
            speed_target: 0.0,
            max_bank: 0.0,
            battery_failsafe: 0,
            armed_at: None,
            flight_time_us: 0,
            rtl_autoland_checked: false,
        }
    }
}

impl Default for Flight {
    fn default() -> Self {
        Flight::new()
    }
}

/// What a mode's navigation asks for.
pub(crate) struct Demand {
    pub nav: Nav,
    pub alt: f64,
    /// The rate the target height moves at (m/s), fed forward.
    pub climb_ff: f64,
    pub airspeed: f64,
    /// Bank limit for this demand (radians).
    pub bank_limit: f64,
    /// A fixed throttle (manual modes), else the energy law's.
    pub throttle: Option<f64>,
    pub target: Option<(V2, f64)>,
}

// ---- AUTO (auto.rs)

/// The mission's progress.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AutoState {
    /// The current navigation command (0: none yet).
    pub current: u16,
    /// The mission runs (in AUTO).
    pub running: bool,
    /// The mission ran to its end.
    pub complete: bool,
    /// The next item to look at for DO commands.
    pub do_cursor: u16,
    /// Where the current leg starts (position, metres above home).
    pub from: Option<(V2, f64)>,
    /// The current command's start has been done (text, take-off, landing).
    pub started: bool,
    /// When the loiter of a LOITER_TIME/TURNS item reached its circle.
    pub loiter_since: Option<u64>,
    /// The turn at the current waypoint (degrees).
    pub turn_angle: f64,
}

// ---- the rover (rover.rs)

/// What the rover is told to do on reaching its destination.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) enum Notify {
    #[default]
    Nothing,
    /// GUIDED: MISSION_ITEM_REACHED 0.
    Guided,
    /// RTL: "Reached destination".
    Rtl,
}

/// The rover's navigation state.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct RoverNav {
    /// Where it drives to; `None`: it stops where it is.
    pub dest: Option<V2>,
    /// Where the leg began (for the cross-track error).
    pub from: V2,
    pub notify: Notify,
    /// AUTO: when the current waypoint was reached (its text said).
    pub reached_at: Option<u64>,
    /// DO_CHANGE_SPEED (m/s).
    pub speed: Option<f64>,
    /// AUTO: the current leg goes on to another waypoint (no stop on it).
    pub pass_through: bool,
}
