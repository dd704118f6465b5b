//! A request turned into MAVLink for the firmware at hand: which MAV_CMD,
//! which parameters, COMMAND_LONG or COMMAND_INT, addressed to which
//! component. The table lives in docs/vehicle.md.

use std::collections::BTreeMap;

use elaboration::Firmware;
use mavlink::dialects::ardupilotmega::{MavCmd, MavFrame};

use super::config::Payload;
use super::modes::mode_numbers;
use super::request::{Request, SpeedKind};

/// MAV_CMD_COMPONENT_ARM_DISARM's param2 magic that skips the checks.
pub const FORCE_MAGIC: f32 = 21196.0;
/// MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, DO_SET_MODE's param1.
const CUSTOM_MODE_ENABLED: f32 = 1.0;
/// MAV_DO_REPOSITION_FLAGS_CHANGE_MODE: switch to guided on reposition.
const REPOSITION_CHANGE_MODE: f32 = 1.0;

/// The position fields of a COMMAND_INT.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntPosition {
    pub frame: MavFrame,
    pub x: i32,
    pub y: i32,
}

/// What to do if the autopilot answers UNSUPPORTED.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fallback {
    None,
    /// DO_SET_MISSION_CURRENT unsupported: send MISSION_SET_CURRENT and
    /// wait for MISSION_CURRENT to show the item.
    MissionSetCurrent(u16),
}

/// One MAVLink command, ready to send.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandSpec {
    pub command: MavCmd,
    /// param1..param7 (for COMMAND_INT, param5/6 are replaced by x/y and
    /// param7 is z).
    pub params: [f32; 7],
    /// `Some`: send as COMMAND_INT.
    pub int: Option<IntPosition>,
    /// The component it is addressed to (the autopilot, or a camera).
    pub component: u8,
    pub fallback: Fallback,
}

impl CommandSpec {
    fn long(command: MavCmd, params: [f32; 7], component: u8) -> CommandSpec {
        CommandSpec {
            command,
            params,
            int: None,
            component,
            fallback: Fallback::None,
        }
    }
}

/// What the vehicle needs from us for a request.
#[derive(Debug, Clone, PartialEq)]
pub enum Plan {
    Command(CommandSpec),
    Mission,
}

/// What planning may read about the vehicle.
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    pub firmware: Firmware,
    pub autopilot: u8,
    pub payloads: &'a BTreeMap<String, Payload>,
    /// Home altitude above mean sea level (m), from GLOBAL_POSITION_INT.
    pub home_amsl: Option<f32>,
    /// Current altitude above home (m), from GLOBAL_POSITION_INT.
    pub relative_alt: Option<f32>,
    /// An ArduPlane QuadPlane.
    pub quadplane: bool,
}

/// Degrees to the 1e7 integers of COMMAND_INT and MISSION_ITEM_INT.
pub fn degrees_e7(deg: f64) -> i32 {
    (deg * 1e7).round().clamp(i32::MIN as f64, i32::MAX as f64) as i32
}

fn ardupilot(fw: Firmware) -> bool {
    !matches!(fw, Firmware::Px4)
}

/// The MAVLink for a request on this vehicle, or why it cannot be done.
pub fn plan(request: &Request, ctx: &Context) -> Result<Plan, String> {
    let fw = ctx.firmware;
    let ap = ctx.autopilot;
    let nan = f32::NAN;
    let spec = match request {
        Request::Arm { arm, force } => CommandSpec::long(
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [
                if *arm { 1.0 } else { 0.0 },
                if *force { FORCE_MAGIC } else { 0.0 },
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
            ],
            ap,
        ),
        Request::Mode { name } => set_mode(fw, name, ap)?,
        Request::Takeoff { alt, pitch } => match fw {
            Firmware::Copter | Firmware::Other => CommandSpec::long(
                MavCmd::MAV_CMD_NAV_TAKEOFF,
                [*pitch, 0.0, 0.0, 0.0, 0.0, 0.0, *alt],
                ap,
            ),
            // A QuadPlane takes off vertically to `alt` on NAV_TAKEOFF.
            Firmware::Plane if ctx.quadplane => CommandSpec::long(
                MavCmd::MAV_CMD_NAV_TAKEOFF,
                [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, *alt],
                ap,
            ),
            // ArduPlane answers NAV_TAKEOFF on QuadPlanes only: a fixed wing
            // takes off in TAKEOFF mode, climbing to its TKOFF_ALT.
            Firmware::Plane => set_mode(fw, "TAKEOFF", ap)?,
            Firmware::Px4 => {
                let home = ctx
                    .home_amsl
                    .ok_or("takeoff: home altitude unknown (no GLOBAL_POSITION_INT yet)")?;
                CommandSpec::long(
                    MavCmd::MAV_CMD_NAV_TAKEOFF,
                    [*pitch, 0.0, 0.0, nan, nan, nan, home + alt],
                    ap,
                )
            }
            Firmware::Rover | Firmware::Sub => {
                return Err(format!("takeoff: not supported on {}", fw.as_str()))
            }
        },
        Request::Land { at, alt } => match fw {
            Firmware::Copter | Firmware::Other => {
                if at.is_some() {
                    return Err(
                        "land: ArduCopter lands where it is; use goto first, then land".into(),
                    );
                }
                CommandSpec::long(MavCmd::MAV_CMD_NAV_LAND, [0.0; 7], ap)
            }
            Firmware::Plane if ctx.quadplane && at.is_none() => set_mode(fw, "QLAND", ap)?,
            Firmware::Plane => {
                let (lat, lon) = at.unwrap_or((0.0, 0.0));
                CommandSpec::long(
                    MavCmd::MAV_CMD_DO_LAND_START,
                    [0.0, 0.0, 0.0, 0.0, lat as f32, lon as f32, 0.0],
                    ap,
                )
            }
            Firmware::Px4 => {
                let (lat, lon) = at.map_or((nan, nan), |(a, o)| (a as f32, o as f32));
                let z = match (alt, ctx.home_amsl) {
                    (Some(a), Some(h)) => h + a,
                    (Some(_), None) => {
                        return Err(
                            "land: home altitude unknown (no GLOBAL_POSITION_INT yet)".into()
                        )
                    }
                    (None, _) => nan,
                };
                CommandSpec::long(
                    MavCmd::MAV_CMD_NAV_LAND,
                    [0.0, 0.0, 0.0, nan, lat, lon, z],
                    ap,
                )
            }
            Firmware::Rover | Firmware::Sub => {
                return Err(format!("land: not supported on {}", fw.as_str()))
            }
        },
        Request::Rtl => CommandSpec::long(MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH, [0.0; 7], ap),
        Request::Goto {
            lat,
            lon,
            alt,
            speed,
            radius,
        } => {
            let (frame, z) = if ardupilot(fw) {
                let z = alt.or(ctx.relative_alt).ok_or(
                    "goto: no alt given and the current altitude is unknown (no GLOBAL_POSITION_INT yet)",
                )?;
                (MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT, z)
            } else {
                let z = match (alt, ctx.home_amsl) {
                    (Some(a), Some(h)) => h + a,
                    (Some(_), None) => {
                        return Err(
                            "goto: home altitude unknown (no GLOBAL_POSITION_INT yet)".into()
                        )
                    }
                    (None, _) => nan,
                };
                (MavFrame::MAV_FRAME_GLOBAL, z)
            };
            CommandSpec {
                command: MavCmd::MAV_CMD_DO_REPOSITION,
                params: [
                    speed.unwrap_or(-1.0),
                    REPOSITION_CHANGE_MODE,
                    radius.unwrap_or(0.0),
                    nan,
                    0.0,
                    0.0,
                    z,
                ],
                int: Some(IntPosition {
                    frame,
                    x: degrees_e7(*lat),
                    y: degrees_e7(*lon),
                }),
                component: ap,
                fallback: Fallback::None,
            }
        }
        Request::SetSpeed { speed, kind } => {
            let kind = match kind {
                SpeedKind::Default if fw == Firmware::Plane => 0.0,
                SpeedKind::Default => 1.0,
                SpeedKind::Air => 0.0,
                SpeedKind::Ground => 1.0,
                SpeedKind::Climb => 2.0,
                SpeedKind::Descent => 3.0,
            };
            CommandSpec::long(
                MavCmd::MAV_CMD_DO_CHANGE_SPEED,
                [kind, *speed, -1.0, 0.0, 0.0, 0.0, 0.0],
                ap,
            )
        }
        Request::UploadMission { .. } => return Ok(Plan::Mission),
        Request::StartMission { first, last } => CommandSpec::long(
            MavCmd::MAV_CMD_MISSION_START,
            [*first as f32, *last as f32, 0.0, 0.0, 0.0, 0.0, 0.0],
            ap,
        ),
        Request::SetCurrent { seq } => CommandSpec {
            fallback: Fallback::MissionSetCurrent(*seq),
            ..CommandSpec::long(
                MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT,
                [*seq as f32, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                ap,
            )
        },
        Request::Payload {
            name,
            start,
            interval,
        } => {
            let payload = ctx.payloads.get(name).ok_or_else(|| {
                format!("payload {name:?} is not in the project's [gateway.payloads]")
            })?;
            match (payload, start) {
                (Payload::Camera { component }, true) => CommandSpec::long(
                    MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
                    [0.0, interval.unwrap_or(1.0), 0.0, 0.0, 0.0, 0.0, 0.0],
                    *component,
                ),
                (Payload::Camera { component }, false) => {
                    CommandSpec::long(MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE, [0.0; 7], *component)
                }
                (
                    Payload::Relay {
                        instance,
                        start: on,
                        stop: off,
                    },
                    s,
                ) => CommandSpec::long(
                    MavCmd::MAV_CMD_DO_SET_RELAY,
                    [
                        *instance as f32,
                        if *s { *on as f32 } else { *off as f32 },
                        0.0,
                        0.0,
                        0.0,
                        0.0,
                        0.0,
                    ],
                    ap,
                ),
                (
                    Payload::Servo {
                        instance,
                        start: on,
                        stop: off,
                    },
                    s,
                ) => CommandSpec::long(
                    MavCmd::MAV_CMD_DO_SET_SERVO,
                    [
                        *instance as f32,
                        if *s { *on as f32 } else { *off as f32 },
                        0.0,
                        0.0,
                        0.0,
                        0.0,
                        0.0,
                    ],
                    ap,
                ),
            }
        }
    };
    Ok(Plan::Command(spec))
}

fn set_mode(fw: Firmware, name: &str, ap: u8) -> Result<CommandSpec, String> {
    let m = mode_numbers(fw, name)?;
    Ok(CommandSpec::long(
        MavCmd::MAV_CMD_DO_SET_MODE,
        [CUSTOM_MODE_ENABLED, m.custom, m.sub, 0.0, 0.0, 0.0, 0.0],
        ap,
    ))
}
