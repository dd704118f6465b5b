//! ArduPlane's flight modes: the PLANE_MODE numbers of `custom_mode`, their
//! names, and the HEARTBEAT `base_mode` flags ArduPlane derives from them.

use mavlink::dialects::ardupilotmega::{MavModeFlag, PlaneMode};
use num_traits::FromPrimitive;

pub const MANUAL: u32 = 0;
pub const CIRCLE: u32 = 1;
pub const STABILIZE: u32 = 2;
pub const TRAINING: u32 = 3;
pub const ACRO: u32 = 4;
pub const FBWA: u32 = 5;
pub const FBWB: u32 = 6;
pub const CRUISE: u32 = 7;
pub const AUTOTUNE: u32 = 8;
pub const AUTO: u32 = 10;
pub const RTL: u32 = 11;
pub const LOITER: u32 = 12;
pub const TAKEOFF: u32 = 13;
pub const AVOID_ADSB: u32 = 14;
pub const GUIDED: u32 = 15;
pub const INITIALISING: u32 = 16;

/// The mode's name as the dialect's PLANE_MODE has it, without the prefix
/// (`FLY_BY_WIRE_A`, `AUTO`), as Petrel's elaboration names it; `MODE_<n>`
/// when unknown.
pub fn name(mode: u32) -> String {
    dialect_name::<PlaneMode>(mode, "PLANE_MODE_")
}

/// A mode's name in the dialect's enum `M`, without its `prefix`;
/// `MODE_<n>` when `M` has no such mode.
fn dialect_name<M: FromPrimitive + std::fmt::Debug>(mode: u32, prefix: &str) -> String {
    match M::from_u32(mode) {
        Some(m) => format!("{m:?}").trim_start_matches(prefix).to_owned(),
        None => format!("MODE_{mode}"),
    }
}

/// Whether a fixed-wing ArduPlane (not a QuadPlane) can switch to `mode`
/// on a command. The Q modes need a QuadPlane; INITIALISING is not a mode
/// one asks for.
pub fn settable(mode: u32) -> bool {
    matches!(
        mode,
        MANUAL
            | CIRCLE
            | STABILIZE
            | TRAINING
            | ACRO
            | FBWA
            | FBWB
            | CRUISE
            | AUTOTUNE
            | AUTO
            | RTL
            | LOITER
            | TAKEOFF
            | AVOID_ADSB
            | GUIDED
    )
}

/// Whether ArduPlane counts `mode` as a guided mode (DO_CHANGE_SPEED is
/// obeyed in these and in AUTO).
pub fn is_guided_like(mode: u32) -> bool {
    matches!(mode, GUIDED | RTL | LOITER | AVOID_ADSB | CIRCLE | TAKEOFF)
}

/// The modes where the pilot's sticks fly the aircraft (nobody holds them
/// here: wings level, throttle at the stick's minimum).
pub fn is_manual_like(mode: u32) -> bool {
    matches!(mode, MANUAL | STABILIZE | TRAINING | ACRO | FBWA | AUTOTUNE)
}

/// HEARTBEAT.base_mode as ArduPlane computes it (GCS_Mavlink.cpp), with
/// stick mixing on (the SITL default), as the recording shows: 17 while
/// initialising, 81 in MANUAL, 89 in AUTO, +128 armed.
pub fn base_mode(mode: u32, armed: bool) -> MavModeFlag {
    let mut bits: u8 = match mode {
        MANUAL | TRAINING | ACRO => 64,
        STABILIZE | FBWA | AUTOTUNE | FBWB | CRUISE => 16,
        AUTO | RTL | LOITER | AVOID_ADSB | GUIDED | CIRCLE | TAKEOFF => 8 | 16,
        _ => 0,
    };
    if mode != INITIALISING {
        // training_manual_* are false: STABILIZE_ENABLED in every mode but
        // INITIALISING; stick mixing gives MANUAL_INPUT_ENABLED.
        bits |= 16 | 64;
        if armed {
            bits |= 128;
        }
    } else {
        bits |= 16;
    }
    MavModeFlag::from_bits_truncate(bits | 1)
}

/// ArduPilot Rover's modes: the numbers of `Mode::Number` (Rover/mode.h),
/// their names as the dialect's ROVER_MODE has them, and the HEARTBEAT
/// `base_mode` Rover derives from them (`GCS_MAVLINK_Rover::base_mode`,
/// Rover/GCS_Mavlink.cpp).
pub mod rover {
    use mavlink::dialects::ardupilotmega::{MavModeFlag, RoverMode};

    pub const MANUAL: u32 = 0;
    pub const ACRO: u32 = 1;
    pub const STEERING: u32 = 3;
    pub const HOLD: u32 = 4;
    pub const LOITER: u32 = 5;
    pub const FOLLOW: u32 = 6;
    pub const SIMPLE: u32 = 7;
    pub const AUTO: u32 = 10;
    pub const RTL: u32 = 11;
    pub const SMART_RTL: u32 = 12;
    pub const GUIDED: u32 = 15;
    pub const INITIALISING: u32 = 16;

    /// The mode's name without the dialect's `ROVER_MODE_` prefix (`HOLD`,
    /// `SMART_RTL`, `INITIALIZING`), as Petrel's elaboration names it;
    /// `MODE_<n>` when unknown.
    pub fn name(mode: u32) -> String {
        super::dialect_name::<RoverMode>(mode, "ROVER_MODE_")
    }

    /// A mode one may ask for (whether it can be entered now is the
    /// mode's own check: a mission for AUTO, home for RTL…).
    pub fn settable(mode: u32) -> bool {
        matches!(
            mode,
            MANUAL
                | ACRO
                | STEERING
                | HOLD
                | LOITER
                | FOLLOW
                | SIMPLE
                | AUTO
                | RTL
                | SMART_RTL
                | GUIDED
        )
    }

    /// Rover's `is_autopilot_mode()`: the modes that navigate by
    /// themselves (NAV_CONTROLLER_OUTPUT is sent in these only).
    pub fn is_autopilot(mode: u32) -> bool {
        matches!(mode, AUTO | GUIDED | RTL | SMART_RTL | LOITER | FOLLOW)
    }

    /// Rover's `has_manual_input()`: the pilot's sticks drive.
    pub fn has_manual_input(mode: u32) -> bool {
        matches!(mode, MANUAL | ACRO | STEERING | SIMPLE)
    }

    /// HEARTBEAT.base_mode as Rover computes it: CUSTOM_MODE_ENABLED,
    /// MANUAL_INPUT_ENABLED in the manual modes, GUIDED_ENABLED in the
    /// autopilot modes (stick mixing off, STICK_MIXING's default),
    /// SAFETY_ARMED when armed and not initialising.
    pub fn base_mode(mode: u32, armed: bool) -> MavModeFlag {
        let mut bits: u8 = 1;
        if has_manual_input(mode) {
            bits |= 64;
        }
        if is_autopilot(mode) {
            bits |= 8;
        }
        if mode != INITIALISING && armed {
            bits |= 128;
        }
        MavModeFlag::from_bits_truncate(bits)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rover_modes_as_rover_numbers_and_flags_them() {
        assert_eq!(rover::name(rover::HOLD), "HOLD");
        assert_eq!(rover::name(rover::SMART_RTL), "SMART_RTL");
        assert_eq!(rover::name(rover::GUIDED), "GUIDED");
        assert_eq!(rover::name(2), "MODE_2");
        assert!(rover::settable(rover::STEERING) && !rover::settable(rover::INITIALISING));
        assert_eq!(rover::base_mode(rover::MANUAL, false).bits(), 65);
        assert_eq!(rover::base_mode(rover::HOLD, true).bits(), 129);
        assert_eq!(rover::base_mode(rover::AUTO, true).bits(), 137);
        assert_eq!(rover::base_mode(rover::INITIALISING, true).bits(), 1);
    }

    #[test]
    fn base_mode_matches_the_recording() {
        assert_eq!(base_mode(INITIALISING, false).bits(), 17);
        assert_eq!(base_mode(MANUAL, false).bits(), 81);
        assert_eq!(base_mode(AUTO, false).bits(), 89);
        assert_eq!(base_mode(AUTO, true).bits(), 217);
    }

    #[test]
    fn names_are_the_dialects() {
        assert_eq!(name(FBWA), "FLY_BY_WIRE_A");
        assert_eq!(name(AUTO), "AUTO");
        assert_eq!(name(99), "MODE_99");
        assert!(!settable(20)); // QLAND
        assert!(settable(GUIDED));
    }
}
