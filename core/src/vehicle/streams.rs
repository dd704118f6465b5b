//! Telemetry requests: MAV_CMD_SET_MESSAGE_INTERVAL per message, and the
//! older REQUEST_DATA_STREAM groups (ArduPilot's SRx_ parameters) as the
//! fallback.

// MAV_DATA_STREAM is superseded by SET_MESSAGE_INTERVAL; this module is the
// fallback for autopilots that only know it.
#![allow(deprecated)]

use mavlink::dialects::ardupilotmega::{self as dialect, MavDataStream};
use mavlink::{Message, MessageData};

/// Messages never asked for at an interval. Some are events, sent when
/// something happens (an answer, a text, a reached item): a stream would
/// make the autopilot send its last one again on every period — ArduPilot
/// does, MISSION_ITEM_REACHED with its last seq (65535 before any), and it
/// answers DENIED for STATUSTEXT and COMMAND_ACK. Others come from another
/// component that the autopilot only relays (RADIO_STATUS and RADIO from
/// the telemetry radio: ArduPilot answers DENIED). They arrive by
/// themselves; the rules that read them still see every one.
pub const NEVER_STREAMED: &[u32] = &[
    dialect::HEARTBEAT_DATA::ID,
    dialect::PARAM_VALUE_DATA::ID,
    dialect::MISSION_ITEM_DATA::ID,
    dialect::MISSION_REQUEST_DATA::ID,
    dialect::MISSION_COUNT_DATA::ID,
    dialect::MISSION_ITEM_REACHED_DATA::ID,
    dialect::MISSION_ACK_DATA::ID,
    dialect::MISSION_REQUEST_INT_DATA::ID,
    dialect::MISSION_ITEM_INT_DATA::ID,
    dialect::COMMAND_INT_DATA::ID,
    dialect::COMMAND_LONG_DATA::ID,
    dialect::COMMAND_ACK_DATA::ID,
    dialect::RADIO_STATUS_DATA::ID,
    dialect::RADIO_DATA::ID,
    dialect::STATUSTEXT_DATA::ID,
    dialect::CAMERA_IMAGE_CAPTURED_DATA::ID,
];

/// Whether a message may be asked for at an interval.
pub fn streamable(message: u32) -> bool {
    !NEVER_STREAMED.contains(&message)
}

/// A message's MAVLink name (`STATUSTEXT`), or its number when this
/// dialect does not know it.
pub fn message_name(message: u32) -> String {
    dialect::MavMessage::default_message_from_id(message)
        .map(|m| m.message_name().to_owned())
        .unwrap_or_else(|| format!("message {message}"))
}

/// The REQUEST_DATA_STREAM group that carries a message on ArduPilot
/// (GCS_Common's stream lists); `None` for messages outside every group.
pub fn stream_of(message: u32) -> Option<MavDataStream> {
    use MavDataStream::*;
    Some(match message {
        // RAW_IMU, SCALED_IMU2/3, SCALED_PRESSURE/2/3, SENSOR_OFFSETS
        27 | 116 | 129 | 29 | 137 | 143 | 150 => MAV_DATA_STREAM_RAW_SENSORS,
        // SYS_STATUS, POWER_STATUS, MEMINFO, MISSION_CURRENT, GPS_RAW_INT,
        // GPS_RTK, GPS2_RAW, GPS2_RTK, NAV_CONTROLLER_OUTPUT, FENCE_STATUS,
        // POSITION_TARGET_GLOBAL_INT, MCU_STATUS
        1 | 125 | 152 | 42 | 24 | 127 | 124 | 128 | 62 | 162 | 87 | 11039 => {
            MAV_DATA_STREAM_EXTENDED_STATUS
        }
        // SERVO_OUTPUT_RAW, RC_CHANNELS, RC_CHANNELS_RAW
        36 | 65 | 35 => MAV_DATA_STREAM_RC_CHANNELS,
        // GLOBAL_POSITION_INT, LOCAL_POSITION_NED
        33 | 32 => MAV_DATA_STREAM_POSITION,
        // ATTITUDE, SIMSTATE, AHRS2, PID_TUNING
        30 | 164 | 178 | 194 => MAV_DATA_STREAM_EXTRA1,
        // VFR_HUD
        74 => MAV_DATA_STREAM_EXTRA2,
        // AHRS, HWSTATUS, SYSTEM_TIME, RANGEFINDER, DISTANCE_SENSOR, WIND,
        // BATTERY_STATUS, VIBRATION, EKF_STATUS_REPORT, TERRAIN_REPORT,
        // ESC_TELEMETRY_1_TO_4, EXTENDED_SYS_STATE, GIMBAL_DEVICE_ATTITUDE_STATUS
        163 | 165 | 2 | 173 | 132 | 168 | 147 | 241 | 193 | 136 | 11030 | 245 | 285 => {
            MAV_DATA_STREAM_EXTRA3
        }
        _ => return None,
    })
}

/// The REQUEST_DATA_STREAM requests that cover `messages` (id, Hz): one per
/// group at the fastest rate asked of it, and MAV_DATA_STREAM_ALL first
/// when some message belongs to no group. Rates are whole Hz, at least 1.
pub fn data_streams(messages: &[(u32, f32)]) -> Vec<(MavDataStream, u16)> {
    let mut out: Vec<(MavDataStream, u16)> = Vec::new();
    let hz = |rate: f32| rate.ceil().clamp(1.0, u16::MAX as f32) as u16;
    let mut all: Option<u16> = None;
    for &(id, rate) in messages {
        if rate <= 0.0 || !rate.is_finite() {
            continue;
        }
        match stream_of(id) {
            Some(stream) => match out.iter_mut().find(|(s, _)| *s == stream) {
                Some((_, r)) => *r = (*r).max(hz(rate)),
                None => out.push((stream, hz(rate))),
            },
            None => all = Some(all.unwrap_or(0).max(hz(rate))),
        }
    }
    if let Some(rate) = all {
        out.insert(0, (MavDataStream::MAV_DATA_STREAM_ALL, rate));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_and_relayed_messages_are_never_streamed_and_names_read() {
        // What real ArduPlane 4.7 SITL answers DENIED, and what it repeats.
        for id in [77, 253, 109, 166, 46] {
            assert!(!streamable(id), "{}", message_name(id));
        }
        for id in [1, 24, 33, 42, 74, 147, 193, 225, 245, 11030, 36] {
            assert!(streamable(id), "{}", message_name(id));
        }
        assert_eq!(message_name(253), "STATUSTEXT");
        assert_eq!(message_name(46), "MISSION_ITEM_REACHED");
        assert_eq!(message_name(65000), "message 65000");
    }

    #[test]
    fn groups_take_the_fastest_rate_and_unknowns_ask_for_all() {
        let req = data_streams(&[
            (33, 4.0),
            (32, 10.0),
            (1, 2.0),
            (245, 0.5),
            (9999, 1.0),
            (0, 0.0),
        ]);
        assert_eq!(
            req,
            vec![
                (MavDataStream::MAV_DATA_STREAM_ALL, 1),
                (MavDataStream::MAV_DATA_STREAM_POSITION, 10),
                (MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS, 2),
                (MavDataStream::MAV_DATA_STREAM_EXTRA3, 1),
            ]
        );
    }
}
