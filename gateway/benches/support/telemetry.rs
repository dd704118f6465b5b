//! Synthetic ArduCopter telemetry for the throughput benchmarks: 50 messages
//! a second (HEARTBEAT 1, ATTITUDE 10, GLOBAL_POSITION_INT 10, VFR_HUD 10,
//! GPS_RAW_INT 5, SYS_STATUS 5, EKF_STATUS_REPORT 4, SYSTEM_TIME 1,
//! BATTERY_STATUS 4), an armed vehicle flying a slow circle in AUTO with the
//! battery going from 100 % to 60 % over an hour, and a mode change every ten
//! minutes so that the nets have something to do.

use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};

/// Frames of second `s` (0-based), MAVLink 2, with their time offsets in µs.
#[allow(dead_code)] // each bench uses one of the two
pub fn second(s: u64, seq: &mut u8) -> Vec<(u64, Vec<u8>)> {
    second_of(1, s, seq)
}

/// Frames of second `s` of the vehicle of system `system`.
pub fn second_of(system: u8, s: u64, seq: &mut u8) -> Vec<(u64, Vec<u8>)> {
    let mut out = Vec::with_capacity(50);
    let mut push = |at_us: u64, message: MavMessage, seq: &mut u8| {
        let header = MavHeader {
            system_id: u32::from(system),
            component_id: 1,
            sequence: *seq,
        };
        *seq = seq.wrapping_add(1);
        let mut bytes = Vec::with_capacity(64);
        if mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, header, &message).is_ok() {
            out.push((s * 1_000_000 + at_us, bytes));
        }
    };
    let t = s as f32;
    let boot_ms = (s * 1000) as u32;
    let mode = if (s / 600).is_multiple_of(2) { 3 } else { 5 }; // AUTO, LOITER
    let remaining = (100.0 - 40.0 * t / 3600.0) as i8;
    let angle = t / 60.0;
    let (lat, lon) = (
        -353_632_610 + (angle.sin() * 2_000.0) as i32,
        1_491_652_300 + (angle.cos() * 2_000.0) as i32,
    );
    push(
        0,
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: mode,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED
                | MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            system_status: MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        }),
        seq,
    );
    push(
        1_000,
        MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
            time_unix_usec: 1_700_000_000_000_000 + s * 1_000_000,
            time_boot_ms: boot_ms,
        }),
        seq,
    );
    for k in 0..10u64 {
        let at = k * 100_000 + 2_000;
        let tk = t + k as f32 / 10.0;
        push(
            at,
            MavMessage::ATTITUDE(ATTITUDE_DATA {
                time_boot_ms: boot_ms + (k * 100) as u32,
                roll: (tk * 0.3).sin() * 0.1,
                pitch: (tk * 0.2).cos() * 0.05,
                yaw: angle,
                ..Default::default()
            }),
            seq,
        );
        push(
            at + 1_000,
            MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                time_boot_ms: boot_ms + (k * 100) as u32,
                lat,
                lon,
                alt: 634_000,
                relative_alt: 50_000,
                vx: 500,
                vy: 200,
                vz: 0,
                hdg: 9000,
            }),
            seq,
        );
        push(
            at + 2_000,
            MavMessage::VFR_HUD(VFR_HUD_DATA {
                airspeed: 5.0,
                groundspeed: 5.2,
                alt: 50.0,
                climb: 0.0,
                heading: 90,
                throttle: 45,
            }),
            seq,
        );
    }
    for k in 0..5u64 {
        let at = k * 200_000 + 50_000;
        push(
            at,
            MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
                time_usec: s * 1_000_000 + k * 200_000,
                lat,
                lon,
                alt: 634_000,
                eph: 80,
                epv: 120,
                vel: 520,
                cog: 9000,
                fix_type: GpsFixType::GPS_FIX_TYPE_3D_FIX,
                satellites_visible: 14,
                ..Default::default()
            }),
            seq,
        );
        let health = MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK
            | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
        push(
            at + 1_000,
            MavMessage::SYS_STATUS(SYS_STATUS_DATA {
                onboard_control_sensors_present: health,
                onboard_control_sensors_enabled: health,
                onboard_control_sensors_health: health,
                voltage_battery: 12_000,
                current_battery: 1_500,
                battery_remaining: remaining,
                ..Default::default()
            }),
            seq,
        );
    }
    for k in 0..4u64 {
        let at = k * 250_000 + 70_000;
        push(
            at,
            MavMessage::EKF_STATUS_REPORT(EKF_STATUS_REPORT_DATA {
                velocity_variance: 0.1,
                pos_horiz_variance: 0.1,
                pos_vert_variance: 0.1,
                compass_variance: 0.05,
                terrain_alt_variance: 0.0,
                flags: EkfStatusFlags::EKF_ATTITUDE
                    | EkfStatusFlags::EKF_VELOCITY_HORIZ
                    | EkfStatusFlags::EKF_VELOCITY_VERT
                    | EkfStatusFlags::EKF_POS_HORIZ_REL
                    | EkfStatusFlags::EKF_POS_HORIZ_ABS
                    | EkfStatusFlags::EKF_POS_VERT_ABS,
                ..Default::default()
            }),
            seq,
        );
        push(
            at + 1_000,
            MavMessage::BATTERY_STATUS(BATTERY_STATUS_DATA {
                battery_remaining: remaining,
                current_consumed: (s * 1500 / 3600) as i32,
                voltages: [
                    4000,
                    4000,
                    4000,
                    u16::MAX,
                    u16::MAX,
                    u16::MAX,
                    u16::MAX,
                    u16::MAX,
                    u16::MAX,
                    u16::MAX,
                ],
                ..Default::default()
            }),
            seq,
        );
    }
    out.sort_by_key(|(t, _)| *t);
    out
}

/// `seconds` seconds of telemetry as a tlog (8-byte big-endian µs time
/// before each frame), starting at `start_us`.
pub fn tlog(seconds: u64, start_us: u64) -> Vec<u8> {
    let mut out = Vec::with_capacity(seconds as usize * 50 * 60);
    let mut seq = 0u8;
    for s in 0..seconds {
        for (t, bytes) in second(s, &mut seq) {
            out.extend_from_slice(&(start_us + t).to_be_bytes());
            out.extend_from_slice(&bytes);
        }
    }
    out
}
