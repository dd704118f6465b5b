//! Names of the dialect's enum values and flags (`MAV_STATE_CRITICAL`,
//! `MAV_MODE_FLAG_SAFETY_ARMED`, ...), taken from rust-mavlink's generated
//! types, and flight-mode names per autopilot and vehicle type.

use std::collections::HashMap;
use std::sync::OnceLock;

use bitflags::Flags;
use mavlink::dialects::ardupilotmega::*;
use num_traits::FromPrimitive;

/// Enum values are looked for in `0..ENUM_SCAN` (MAV_CMD in `0..=u16::MAX`).
const ENUM_SCAN: u32 = 2048;

/// Every name of the dialect with its value, and each enum's values with
/// their names (without the enum's prefix) under the enum's MAVLink name.
struct Tables {
    values: HashMap<String, i64>,
    enums: HashMap<String, HashMap<i64, String>>,
}

/// `MavBatteryChargeState` -> `MAV_BATTERY_CHARGE_STATE`.
fn mavlink_enum_name(rust: &str) -> String {
    let mut out = String::with_capacity(rust.len() + 4);
    for (i, c) in rust.chars().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            out.push('_');
        }
        out.push(c.to_ascii_uppercase());
    }
    out
}

fn table() -> &'static HashMap<String, i64> {
    &tables().values
}

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(|| {
        let mut t = HashMap::new();
        let mut enums_by_name: HashMap<String, HashMap<i64, String>> = HashMap::new();
        macro_rules! enums {
            ($($ty:ident),* $(,)?) => {$(
                let enum_name = mavlink_enum_name(stringify!($ty));
                let prefix = format!("{enum_name}_");
                let names = enums_by_name.entry(enum_name).or_default();
                for v in 0..ENUM_SCAN {
                    if let Some(e) = <$ty as FromPrimitive>::from_u32(v) {
                        let name = format!("{e:?}");
                        names.insert(v as i64, name.strip_prefix(&prefix).unwrap_or(&name).to_owned());
                        t.insert(name, v as i64);
                    }
                }
            )*};
        }
        macro_rules! flags {
            ($($ty:ident),* $(,)?) => {$(
                for f in <$ty as Flags>::FLAGS {
                    t.insert(f.name().to_owned(), f.value().bits() as i64);
                }
            )*};
        }
        enums!(
            AccelcalVehiclePos,
            ActuatorConfiguration,
            ActuatorOutputFunction,
            AdsbAltitudeType,
            AdsbEmitterType,
            AirlinkAuthResponseType,
            AisNavStatus,
            AisType,
            CameraFeedbackFlags,
            CameraMode,
            CameraSource,
            CameraStatusTypes,
            CameraTrackingMode,
            CameraZoomType,
            CanFilterOp,
            CellularConfigResponse,
            CellularNetworkFailedReason,
            CellularNetworkRadioType,
            CellularStatusFlag,
            CopterMode,
            DeepstallStage,
            DeviceOpBustype,
            EscConnectionType,
            FailureType,
            FailureUnit,
            FenceBreach,
            FenceMitigate,
            FirmwareVersionType,
            GimbalAxis,
            GimbalAxisCalibrationRequired,
            GimbalAxisCalibrationStatus,
            GlobalPositionSrc,
            GoproBurstRate,
            GoproCaptureMode,
            GoproCharging,
            GoproCommand,
            GoproFieldOfView,
            GoproFrameRate,
            GoproHeartbeatStatus,
            GoproModel,
            GoproPhotoResolution,
            GoproProtuneColour,
            GoproProtuneExposure,
            GoproProtuneGain,
            GoproProtuneSharpness,
            GoproProtuneWhiteBalance,
            GoproRequestStatus,
            GoproResolution,
            GpsFixType,
            GripperActions,
            HeadingType,
            IcarousFmsState,
            IcarousTrackBandTypes,
            IlluminatorMode,
            LandingTargetType,
            LedControlPattern,
            LimitsState,
            MagCalStatus,
            MavArmAuthDeniedReason,
            MavAutopilot,
            MavBatteryChargeState,
            MavBatteryFunction,
            MavBatteryMode,
            MavBatteryType,
            MavCmd,
            MavCmdDoAuxFunctionSwitchLevel,
            MavCollisionAction,
            MavCollisionSrc,
            MavCollisionThreatLevel,
            MavComponent,
            MavDistanceSensor,
            MavEstimatorType,
            MavEventErrorReason,
            MavFtpErr,
            MavFtpOpcode,
            MavFuelType,
            MavGoto,
            MavLandedState,
            MavMissionResult,
            MavMissionType,
            MavModeGimbal,
            MavOdidArmStatus,
            MavOdidAuthType,
            MavOdidCategoryEu,
            MavOdidClassEu,
            MavOdidClassificationType,
            MavOdidDescType,
            MavOdidHeightRef,
            MavOdidHorAcc,
            MavOdidIdType,
            MavOdidOperatorIdType,
            MavOdidOperatorLocationType,
            MavOdidSpeedAcc,
            MavOdidStatus,
            MavOdidTimeAcc,
            MavOdidUaType,
            MavOdidVerAcc,
            MavParamError,
            MavParamExtType,
            MavParamType,
            MavRemoteLogDataBlockCommands,
            MavRemoteLogDataBlockStatuses,
            MavResult,
            MavSensorOrientation,
            MavSeverity,
            MavState,
            MavTunnelPayloadType,
            MavType,
            MavVtolState,
            MavlinkDataStreamType,
            MissionState,
            MotorTestOrder,
            MotorTestThrottleType,
            NavVtolLandOptions,
            OrbitYawBehaviour,
            OsdParamConfigError,
            OsdParamConfigType,
            ParachuteAction,
            ParamAck,
            PidTuningAxis,
            PlaneMode,
            PrecisionLandMode,
            PreflightCalibrationAccelerometer,
            PreflightCalibrationMagnetometer,
            PreflightStorageParameterAction,
            RallyFlags,
            RcSubType,
            RcType,
            RebootShutdownAction,
            RebootShutdownConditions,
            RoverMode,
            RtkBaselineCoordinateSystem,
            SafetySwitchState,
            ScriptingCmd,
            SecureCommandOp,
            SerialControlDev,
            SetFocusType,
            SpeedType,
            StorageStatus,
            StorageType,
            SubMode,
            TrackerMode,
            TuneFormat,
            UavcanNodeHealth,
            UavcanNodeMode,
            UavionixAdsbEmergencyStatus,
            UavionixAdsbOutCfgAircraftSize,
            UavionixAdsbOutCfgGpsOffsetLat,
            UavionixAdsbOutCfgGpsOffsetLon,
            UavionixAdsbOutDynamicGpsFix,
            UavionixAdsbOutStatusNicNacp,
            UtmFlightState,
            VideoStreamEncoding,
            VideoStreamType,
            VtolTransitionHeading,
            WifiConfigApMode,
            WifiConfigApResponse,
            WinchActions,
        );
        flags!(
            AdsbFlags,
            AirspeedSensorFlags,
            AisFlags,
            AttitudeTargetTypemask,
            AutotuneAxis,
            CameraCapFlags,
            CameraTrackingStatusFlags,
            CameraTrackingTargetData,
            ComputerStatusFlags,
            EkfStatusFlags,
            EngineControlOptions,
            EscFailureFlags,
            EstimatorStatusFlags,
            FenceType,
            GimbalDeviceCapFlags,
            GimbalDeviceCapFlagsU16,
            GimbalDeviceErrorFlags,
            GimbalDeviceFlags,
            GimbalManagerCapFlags,
            GimbalManagerFlags,
            GlobalPositionFlags,
            GoproHeartbeatFlags,
            GoproVideoSettingsFlags,
            GpsInputIgnoreFlags,
            HighresImuUpdatedFlags,
            HilActuatorControlsFlags,
            HilSensorUpdatedFlags,
            HlFailureFlag,
            IlluminatorErrorFlags,
            LimitModule,
            MavBatteryFault,
            MavBool,
            MavDoRepositionFlags,
            MavEventCurrentSequenceFlags,
            MavGeneratorStatusFlag,
            MavModeFlag,
            MavModeFlagDecodePosition,
            MavModeProperty,
            MavPowerStatus,
            MavProtocolCapability,
            MavSysStatusSensor,
            MavSysStatusSensorExtended,
            MavWinchStatusFlag,
            NavTakeoffFlags,
            PositionTargetTypemask,
            SerialControlFlag,
            StorageUsageFlag,
            UavionixAdsbOutControlState,
            UavionixAdsbOutDynamicState,
            UavionixAdsbOutRfSelect,
            UavionixAdsbOutStatusFault,
            UavionixAdsbOutStatusState,
            UavionixAdsbRfHealth,
            UavionixAdsbXbit,
            UtmDataAvailFlags,
            VideoStreamStatusFlags,
        );
        let commands = enums_by_name.entry("MAV_CMD".to_owned()).or_default();
        for v in ENUM_SCAN..=u16::MAX as u32 {
            if let Some(e) = MavCmd::from_u32(v) {
                let name = format!("{e:?}");
                commands.insert(
                    v as i64,
                    name.strip_prefix("MAV_CMD_").unwrap_or(&name).to_owned(),
                );
                t.insert(name, v as i64);
            }
        }
        enums_by_name.insert(PX4_EVENT.to_owned(), px4_events(|_| true));
        enums_by_name.insert(
            PX4_ARMING_CHECK.to_owned(),
            px4_events(|group| group == "arming_check" || group == "health"),
        );
        Tables {
            values: t,
            enums: enums_by_name,
        }
    })
}

/// PX4's events by EVENT.id, read with `name(EVENT.id, PX4_EVENT)`: the
/// event's message (an id it does not know reads as its number).
pub const PX4_EVENT: &str = "PX4_EVENT";

/// PX4's arming-check and health events only (`name(EVENT.id,
/// PX4_ARMING_CHECK)`): each one a check that fails.
pub const PX4_ARMING_CHECK: &str = "PX4_ARMING_CHECK";

/// `profiles/px4_events.tsv` (id, group, name, message): the messages of
/// the groups `keep` keeps.
fn px4_events(keep: impl Fn(&str) -> bool) -> HashMap<i64, String> {
    include_str!("../profiles/px4_events.tsv")
        .lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| {
            let mut cols = l.split('\t');
            let id = cols.next()?.parse().ok()?;
            let group = cols.next()?;
            let message = cols.nth(1)?;
            keep(group).then(|| (id, message.to_owned()))
        })
        .collect()
}

/// The values of an enum of the dialect, by its MAVLink name (`MAV_CMD`,
/// `MAV_RESULT`), each with its name without the enum's prefix
/// (`SET_MESSAGE_INTERVAL`, `DENIED`).
pub fn enum_names(name: &str) -> Option<&'static HashMap<i64, String>> {
    tables().enums.get(name)
}

/// The value of an enum entry or flag of the dialect, by its MAVLink name.
pub fn value(name: &str) -> Option<i64> {
    table().get(name).copied()
}

/// The flight-software family behind a HEARTBEAT, which decides how
/// `custom_mode` reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Firmware {
    Copter,
    Plane,
    Rover,
    Sub,
    Px4,
    Other,
}

impl Firmware {
    /// From a HEARTBEAT's `autopilot` and `type`. QuadPlanes report VTOL
    /// types and are planes; a config can force the family instead.
    pub fn from_heartbeat(autopilot: i64, mav_type: i64) -> Firmware {
        const ARDUPILOT: i64 = MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA as i64;
        const PX4: i64 = MavAutopilot::MAV_AUTOPILOT_PX4 as i64;
        match autopilot {
            PX4 => Firmware::Px4,
            ARDUPILOT => match mav_type {
                1 | 16 | 19..=25 => Firmware::Plane,
                2..=4 | 13..=15 | 29 | 35 => Firmware::Copter,
                10 | 11 => Firmware::Rover,
                12 => Firmware::Sub,
                _ => Firmware::Other,
            },
            _ => Firmware::Other,
        }
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Firmware::Copter => "copter",
            Firmware::Plane => "plane",
            Firmware::Rover => "rover",
            Firmware::Sub => "sub",
            Firmware::Px4 => "px4",
            Firmware::Other => "other",
        }
    }

    /// Parses a family name as written in configuration.
    pub fn parse(name: &str) -> Option<Firmware> {
        Some(match name {
            "copter" => Firmware::Copter,
            "plane" => Firmware::Plane,
            "rover" => Firmware::Rover,
            "sub" => Firmware::Sub,
            "px4" => Firmware::Px4,
            _ => return None,
        })
    }
}

fn strip(name: String, prefix: &str) -> String {
    name.strip_prefix(prefix).map(str::to_owned).unwrap_or(name)
}

/// The name of a flight mode: ArduPilot's per-vehicle `custom_mode` tables
/// (from the dialect's COPTER_MODE, PLANE_MODE, ROVER_MODE, SUB_MODE), PX4's
/// main and sub modes (`AUTO_MISSION`, `POSCTL`, ...). Unknown numbers give
/// `MODE_<n>`.
pub fn mode_name(firmware: Firmware, custom_mode: u32) -> String {
    let named = match firmware {
        Firmware::Copter => {
            CopterMode::from_u32(custom_mode).map(|m| strip(format!("{m:?}"), "COPTER_MODE_"))
        }
        Firmware::Plane => {
            PlaneMode::from_u32(custom_mode).map(|m| strip(format!("{m:?}"), "PLANE_MODE_"))
        }
        Firmware::Rover => {
            RoverMode::from_u32(custom_mode).map(|m| strip(format!("{m:?}"), "ROVER_MODE_"))
        }
        Firmware::Sub => {
            SubMode::from_u32(custom_mode).map(|m| strip(format!("{m:?}"), "SUB_MODE_"))
        }
        Firmware::Px4 => px4_mode(custom_mode),
        Firmware::Other => None,
    };
    named.unwrap_or_else(|| format!("MODE_{custom_mode}"))
}

/// PX4: main mode in bits 16..24, sub mode (for AUTO) in bits 24..32.
fn px4_mode(custom_mode: u32) -> Option<String> {
    let main = (custom_mode >> 16) & 0xff;
    let sub = (custom_mode >> 24) & 0xff;
    let main_name = match main {
        1 => "MANUAL",
        2 => "ALTCTL",
        3 => "POSCTL",
        4 => "AUTO",
        5 => "ACRO",
        6 => "OFFBOARD",
        7 => "STABILIZED",
        8 => "RATTITUDE",
        9 => "SIMPLE",
        10 => "TERMINATION",
        _ => return None,
    };
    if main != 4 {
        return Some(main_name.to_owned());
    }
    let sub_name = match sub {
        1 => "READY",
        2 => "TAKEOFF",
        3 => "LOITER",
        4 => "MISSION",
        5 => "RTL",
        6 => "LAND",
        8 => "FOLLOW_TARGET",
        9 => "PRECLAND",
        10 => "VTOL_TAKEOFF",
        _ => return Some("AUTO".to_owned()),
    };
    Some(format!("AUTO_{sub_name}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_resolve_to_dialect_values() {
        assert_eq!(value("MAV_MODE_FLAG_SAFETY_ARMED"), Some(128));
        assert_eq!(value("MAV_STATE_CRITICAL"), Some(5));
        assert_eq!(value("MAV_SYS_STATUS_PREARM_CHECK"), Some(0x1000_0000));
        assert_eq!(value("MAV_LANDED_STATE_IN_AIR"), Some(2));
        assert_eq!(value("MAV_CMD_COMPONENT_ARM_DISARM"), Some(400));
        assert_eq!(value("MAV_CMD_DO_SET_MODE"), Some(176));
        assert_eq!(value("GPS_FIX_TYPE_3D_FIX"), Some(3));
        assert_eq!(value("EKF_UNINITIALIZED"), Some(1024));
        assert_eq!(value("NOT_A_NAME"), None);
    }

    #[test]
    fn px4_events_are_named_by_their_wire_id() {
        let events = enum_names(PX4_ARMING_CHECK).expect("PX4_ARMING_CHECK");
        // Heard from PX4 v1.18 SITL at boot: EVENT.id 0x1ccdef5.
        assert_eq!(
            events.get(&0x1cc_def5).map(String::as_str),
            Some("No heading reference")
        );
        assert_eq!(
            events.get(&0x198_c273).map(String::as_str),
            Some("Navigation error: No valid global position estimate")
        );
        // Summary events carry no reason: left out.
        assert_eq!(events.get(&0x1a8_93e0), None);
        assert!(events.len() > 100, "{}", events.len());
        // Not an arming check: in PX4_EVENT only.
        assert_eq!(events.get(&0x102_089d), None);
        assert_eq!(
            enum_names(PX4_EVENT)
                .and_then(|e| e.get(&0x102_089d))
                .map(String::as_str),
            Some("Arming denied: Resolve system health failures first")
        );
    }

    #[test]
    fn enum_values_have_names_without_their_prefix() {
        let cmd = enum_names("MAV_CMD").expect("MAV_CMD");
        assert_eq!(
            cmd.get(&511).map(String::as_str),
            Some("SET_MESSAGE_INTERVAL")
        );
        assert_eq!(
            cmd.get(&400).map(String::as_str),
            Some("COMPONENT_ARM_DISARM")
        );
        // Beyond the scan of the other enums.
        assert_eq!(cmd.get(&42600).map(String::as_str), Some("DO_WINCH"));
        let result = enum_names("MAV_RESULT").expect("MAV_RESULT");
        assert_eq!(result.get(&2).map(String::as_str), Some("DENIED"));
        let charge = enum_names("MAV_BATTERY_CHARGE_STATE").expect("charge state");
        assert_eq!(charge.get(&2).map(String::as_str), Some("LOW"));
        assert_eq!(
            enum_names("GPS_FIX_TYPE")
                .and_then(|t| t.get(&3))
                .map(String::as_str),
            Some("3D_FIX")
        );
        assert!(enum_names("NOT_AN_ENUM").is_none());
        assert_eq!(mavlink_enum_name("MavOdidUaType"), "MAV_ODID_UA_TYPE");
    }

    #[test]
    fn modes_by_firmware() {
        assert_eq!(mode_name(Firmware::Copter, 5), "LOITER");
        assert_eq!(mode_name(Firmware::Copter, 3), "AUTO");
        assert_eq!(mode_name(Firmware::Plane, 10), "AUTO");
        assert_eq!(mode_name(Firmware::Plane, 5), "FLY_BY_WIRE_A");
        assert_eq!(mode_name(Firmware::Sub, 19), "MANUAL");
        assert_eq!(mode_name(Firmware::Px4, 65536), "MANUAL");
        assert_eq!(
            mode_name(Firmware::Px4, (4 << 16) | (4 << 24)),
            "AUTO_MISSION"
        );
        assert_eq!(mode_name(Firmware::Rover, 4), "HOLD");
        assert_eq!(mode_name(Firmware::Rover, 10), "AUTO");
        assert_eq!(mode_name(Firmware::Sub, 2), "ALT_HOLD");
        assert_eq!(mode_name(Firmware::Px4, 3 << 16), "POSCTL");
        assert_eq!(mode_name(Firmware::Px4, 4 << 16), "AUTO");
        assert_eq!(mode_name(Firmware::Px4, (4 << 16) | (6 << 24)), "AUTO_LAND");
        assert_eq!(mode_name(Firmware::Px4, 99 << 16), "MODE_6488064");
        assert_eq!(mode_name(Firmware::Other, 3), "MODE_3");
        assert_eq!(mode_name(Firmware::Copter, 999), "MODE_999");
        assert_eq!(Firmware::from_heartbeat(3, 2), Firmware::Copter);
        assert_eq!(Firmware::from_heartbeat(3, 1), Firmware::Plane);
        assert_eq!(Firmware::from_heartbeat(12, 2), Firmware::Px4);
        assert_eq!(Firmware::from_heartbeat(3, 10), Firmware::Rover);
        assert_eq!(Firmware::from_heartbeat(3, 11), Firmware::Rover);
        assert_eq!(Firmware::from_heartbeat(3, 12), Firmware::Sub);
        assert_eq!(Firmware::from_heartbeat(3, 20), Firmware::Plane);
        assert_eq!(Firmware::from_heartbeat(3, 6), Firmware::Other);
        assert_eq!(Firmware::from_heartbeat(0, 2), Firmware::Other);
    }
}
