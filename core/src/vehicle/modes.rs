//! Flight modes by name, for MAV_CMD_DO_SET_MODE: ArduPilot's per-vehicle
//! `custom_mode` numbers (the dialect's COPTER_MODE, PLANE_MODE, ROVER_MODE,
//! SUB_MODE names, through elaboration's table) and PX4's main/sub modes.

use elaboration::constants::mode_name;
use elaboration::Firmware;

/// The DO_SET_MODE parameters for a mode: param2 and param3 (param1 is
/// always MAV_MODE_FLAG_CUSTOM_MODE_ENABLED).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeNumbers {
    pub custom: f32,
    pub sub: f32,
}

/// Common short names, accepted beside the dialect's.
const ARDUPILOT_ALIASES: &[(&str, &str)] = &[
    ("FBWA", "FLY_BY_WIRE_A"),
    ("FBWB", "FLY_BY_WIRE_B"),
    ("ALTHOLD", "ALT_HOLD"),
    ("SMARTRTL", "SMART_RTL"),
    ("POS_HOLD", "POSHOLD"),
    ("QSTAB", "QSTABILIZE"),
];

/// PX4 main modes and AUTO sub modes, by the names elaboration reports.
const PX4_MODES: &[(&str, u8, u8)] = &[
    ("MANUAL", 1, 0),
    ("ALTCTL", 2, 0),
    ("POSCTL", 3, 0),
    ("AUTO_READY", 4, 1),
    ("AUTO_TAKEOFF", 4, 2),
    ("AUTO_LOITER", 4, 3),
    ("AUTO_MISSION", 4, 4),
    ("AUTO_RTL", 4, 5),
    ("AUTO_LAND", 4, 6),
    ("AUTO_FOLLOW_TARGET", 4, 8),
    ("AUTO_PRECLAND", 4, 9),
    ("ACRO", 5, 0),
    ("OFFBOARD", 6, 0),
    ("STABILIZED", 7, 0),
];

const PX4_ALIASES: &[(&str, &str)] = &[
    ("AUTO", "AUTO_MISSION"),
    ("MISSION", "AUTO_MISSION"),
    ("RTL", "AUTO_RTL"),
    ("LAND", "AUTO_LAND"),
    ("LOITER", "AUTO_LOITER"),
    ("HOLD", "AUTO_LOITER"),
    ("TAKEOFF", "AUTO_TAKEOFF"),
    ("POSITION", "POSCTL"),
    ("ALTITUDE", "ALTCTL"),
    ("STABILIZE", "STABILIZED"),
];

/// The numbers for a mode name (case-insensitive), or why there are none.
pub fn mode_numbers(firmware: Firmware, name: &str) -> Result<ModeNumbers, String> {
    let upper = name.trim().to_ascii_uppercase();
    match firmware {
        Firmware::Px4 => {
            let canonical = PX4_ALIASES
                .iter()
                .find(|(alias, _)| *alias == upper)
                .map_or(upper.as_str(), |(_, full)| full);
            PX4_MODES
                .iter()
                .find(|(n, _, _)| *n == canonical)
                .map(|&(_, main, sub)| ModeNumbers {
                    custom: main as f32,
                    sub: sub as f32,
                })
                .ok_or_else(|| format!("unknown PX4 mode {name:?}"))
        }
        Firmware::Other => Err(format!(
            "cannot set mode {name:?}: the firmware family is unknown"
        )),
        ardupilot => {
            let canonical = ARDUPILOT_ALIASES
                .iter()
                .find(|(alias, _)| *alias == upper)
                .map_or(upper.as_str(), |(_, full)| full);
            (0..64u32)
                .find(|&n| mode_name(ardupilot, n) == canonical)
                .map(|n| ModeNumbers {
                    custom: n as f32,
                    sub: 0.0,
                })
                .ok_or_else(|| format!("unknown {} mode {name:?}", ardupilot.as_str()))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn custom(fw: Firmware, name: &str) -> Option<(f32, f32)> {
        mode_numbers(fw, name).ok().map(|m| (m.custom, m.sub))
    }

    #[test]
    fn ardupilot_names_and_aliases() {
        assert_eq!(custom(Firmware::Plane, "AUTO"), Some((10.0, 0.0)));
        assert_eq!(custom(Firmware::Plane, "TAKEOFF"), Some((13.0, 0.0)));
        assert_eq!(custom(Firmware::Plane, "FLY_BY_WIRE_A"), Some((5.0, 0.0)));
        assert_eq!(custom(Firmware::Plane, "fbwa"), Some((5.0, 0.0)));
        assert_eq!(custom(Firmware::Plane, "GUIDED"), Some((15.0, 0.0)));
        assert_eq!(custom(Firmware::Copter, "GUIDED"), Some((4.0, 0.0)));
        assert_eq!(custom(Firmware::Copter, "LAND"), Some((9.0, 0.0)));
        assert_eq!(custom(Firmware::Copter, "RTL"), Some((6.0, 0.0)));
        assert_eq!(custom(Firmware::Copter, "SMART_RTL"), Some((21.0, 0.0)));
        assert_eq!(custom(Firmware::Rover, "HOLD"), Some((4.0, 0.0)));
        assert_eq!(custom(Firmware::Sub, "MANUAL"), Some((19.0, 0.0)));
        assert!(mode_numbers(Firmware::Copter, "FLY_BY_WIRE_A").is_err());
        assert!(mode_numbers(Firmware::Other, "AUTO").is_err());
    }

    #[test]
    fn px4_main_and_sub_modes() {
        assert_eq!(custom(Firmware::Px4, "AUTO_MISSION"), Some((4.0, 4.0)));
        assert_eq!(custom(Firmware::Px4, "MISSION"), Some((4.0, 4.0)));
        assert_eq!(custom(Firmware::Px4, "POSCTL"), Some((3.0, 0.0)));
        assert_eq!(custom(Firmware::Px4, "rtl"), Some((4.0, 5.0)));
        assert_eq!(custom(Firmware::Px4, "OFFBOARD"), Some((6.0, 0.0)));
        assert!(mode_numbers(Firmware::Px4, "FBWA").is_err());
    }
}
