//! The simulated truth, as a snapshot (`Sim::state`, `Vehicle::state`):
//! where the aircraft is and what it does, and everything that happened —
//! what tests and the demo check against.

use crate::faults::Fault;
use crate::mission::MissionItem;

/// A snapshot of the simulation.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SimState {
    /// Sim seconds since boot.
    pub time_s: f64,
    pub armed: bool,
    /// The flight mode, named as Petrel's elaboration names ArduPlane's
    /// (`MANUAL`, `FLY_BY_WIRE_A`, `AUTO`, `RTL`, `GUIDED`, `INITIALIZING` …).
    pub mode: String,
    /// HEARTBEAT.custom_mode.
    pub custom_mode: u32,
    /// HEARTBEAT.system_status (MAV_STATE: 3 STANDBY, 4 ACTIVE, 5 CRITICAL, 6 EMERGENCY).
    pub system_status: u8,
    /// Degrees.
    pub lat: f64,
    pub lon: f64,
    /// Metres above home (the ground).
    pub alt: f64,
    /// Metres north and east of the boot home.
    pub north: f64,
    pub east: f64,
    /// m/s.
    pub airspeed: f64,
    pub groundspeed: f64,
    pub climb: f64,
    /// Degrees.
    pub heading: f64,
    pub bank: f64,
    pub pitch: f64,
    /// The largest |bank| so far (degrees).
    pub max_bank: f64,
    /// Throttle output, percent.
    pub throttle: f64,
    pub on_ground: bool,
    /// ArduPlane's is_flying (ACTIVE): from the take-off run to the end of
    /// the landing roll.
    pub flying: bool,
    /// A landing has been completed (and not taken off again).
    pub landed: bool,
    pub crashed: bool,
    pub engine_running: bool,
    pub engine_rpm: f64,
    /// Percent.
    pub battery_remaining: f64,
    pub battery_voltage: f64,
    pub gps_fix: u8,
    pub satellites: u8,
    /// The link is up (no link-loss fault).
    pub link_up: bool,
    /// The stored mission, item 0 being home.
    pub mission: Vec<MissionItem>,
    /// MISSION_CURRENT.seq.
    pub mission_current: u16,
    /// Every MISSION_ITEM_REACHED sent.
    pub reached: Vec<Reached>,
    /// Camera starts, stops and images.
    pub camera: Vec<CameraEvent>,
    /// DO_SET_RELAY and DO_SET_SERVO actions (commands and mission items).
    pub payload_actions: Vec<PayloadAction>,
    /// Faults injected and cleared.
    pub faults: Vec<FaultEvent>,
    /// Every COMMAND_LONG / COMMAND_INT received, with the answer.
    pub commands: Vec<CommandRecord>,
    /// Every STATUSTEXT sent (also those lost to a link loss).
    pub statustexts: Vec<Text>,
    /// Every time the aircraft met the ground in flight.
    pub touchdowns: Vec<Touchdown>,
}

/// A MISSION_ITEM_REACHED.
#[derive(Debug, Clone, PartialEq)]
pub struct Reached {
    pub seq: u16,
    pub time_s: f64,
}

/// A position at some time.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Fix {
    pub time_s: f64,
    pub lat: f64,
    pub lon: f64,
    /// Metres above home.
    pub alt: f64,
}

/// What the camera did.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraAction {
    Start { interval_s: f32, total: u32 },
    Stop,
    Image { index: i32 },
}

#[derive(Debug, Clone, PartialEq)]
pub struct CameraEvent {
    pub at: Fix,
    pub action: CameraAction,
}

/// A relay or servo output set.
#[derive(Debug, Clone, PartialEq)]
pub enum PayloadKind {
    Relay { instance: u8, on: bool },
    Servo { channel: u8, pwm: u16 },
}

#[derive(Debug, Clone, PartialEq)]
pub struct PayloadAction {
    pub at: Fix,
    pub kind: PayloadKind,
    /// The mission item that did it, or `None` for a command.
    pub mission_seq: Option<u16>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct FaultEvent {
    pub time_s: f64,
    pub fault: Fault,
    /// False when injected, true when cleared.
    pub cleared: bool,
}

/// A command received.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandRecord {
    pub time_s: f64,
    /// MAV_CMD number.
    pub command: u32,
    /// COMMAND_INT (else COMMAND_LONG).
    pub int: bool,
    pub params: [f32; 7],
    /// Sender (system, component).
    pub from: (u8, u8),
    /// The component it was addressed to.
    pub target_component: u8,
    /// MAV_RESULT sent back; `None` when nothing answered.
    pub result: Option<u8>,
}

/// A STATUSTEXT.
#[derive(Debug, Clone, PartialEq)]
pub struct Text {
    pub time_s: f64,
    /// MAV_SEVERITY (0 EMERGENCY … 6 INFO).
    pub severity: u8,
    pub text: String,
}

/// The aircraft met the ground.
#[derive(Debug, Clone, PartialEq)]
pub struct Touchdown {
    pub time_s: f64,
    /// Sink rate (m/s).
    pub sink: f64,
    pub airspeed: f64,
    /// A landing (in a landing stage) rather than a crash.
    pub landing: bool,
}

impl SimState {
    /// The STATUSTEXTs containing `needle`.
    pub fn texts_with(&self, needle: &str) -> Vec<&Text> {
        self.statustexts
            .iter()
            .filter(|t| t.text.contains(needle))
            .collect()
    }

    /// The results sent for a MAV_CMD, in order.
    pub fn results_of(&self, command: u32) -> Vec<Option<u8>> {
        self.commands
            .iter()
            .filter(|c| c.command == command)
            .map(|c| c.result)
            .collect()
    }
}
