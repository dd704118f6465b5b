//! Telemetry streams as ArduPlane schedules them: HEARTBEAT at 1 Hz and
//! every REQUEST_DATA_STREAM group at its MAVn_* rate (1 Hz in SITL with
//! plane.parm; `SimConfig::stream_hz`), then per message at the interval
//! set by MAV_CMD_SET_MESSAGE_INTERVAL (HEARTBEAT included), or at the rate
//! of its group as REQUEST_DATA_STREAM sets it (ArduPlane 4.7's groups,
//! GCS_Mavlink.cpp). Which requests are DENIED and which event messages are
//! re-sent on every period were checked on ArduPlane 4.7 SITL ([`DENIED`],
//! [`REPEATED_EVENTS`]). Times are sim microseconds.

use std::collections::BTreeMap;

/// A REQUEST_DATA_STREAM group (its MAV_DATA_STREAM number).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Group {
    RawSensors = 1,
    ExtendedStatus = 2,
    RcChannels = 3,
    RawController = 4,
    Position = 6,
    Extra1 = 10,
    Extra2 = 11,
    Extra3 = 12,
    Adsb = 13,
}

impl Group {
    /// Every group MAV_DATA_STREAM_ALL sets (ArduPilot leaves PARAMS out).
    pub const ALL: [Group; 9] = [
        Group::RawSensors,
        Group::ExtendedStatus,
        Group::RcChannels,
        Group::RawController,
        Group::Position,
        Group::Extra1,
        Group::Extra2,
        Group::Extra3,
        Group::Adsb,
    ];

    pub fn from_stream_id(id: u8) -> Option<Group> {
        Group::ALL.into_iter().find(|g| *g as u8 == id)
    }

    /// The parameter ArduPilot 4.7 stores the group's rate in (it sends the
    /// PARAM_VALUE when a REQUEST_DATA_STREAM changes it).
    pub fn param(self) -> &'static str {
        match self {
            Group::RawSensors => "MAV1_RAW_SENS",
            Group::ExtendedStatus => "MAV1_EXT_STAT",
            Group::RcChannels => "MAV1_RC_CHAN",
            Group::RawController => "MAV1_RAW_CTRL",
            Group::Position => "MAV1_POSITION",
            Group::Extra1 => "MAV1_EXTRA1",
            Group::Extra2 => "MAV1_EXTRA2",
            Group::Extra3 => "MAV1_EXTRA3",
            Group::Adsb => "MAV1_ADSB",
        }
    }
}

/// Message ids.
pub mod id {
    pub const HEARTBEAT: u32 = 0;
    pub const SYS_STATUS: u32 = 1;
    pub const SYSTEM_TIME: u32 = 2;
    pub const GPS_RAW_INT: u32 = 24;
    pub const RAW_IMU: u32 = 27;
    pub const SCALED_PRESSURE: u32 = 29;
    pub const ATTITUDE: u32 = 30;
    pub const LOCAL_POSITION_NED: u32 = 32;
    pub const GLOBAL_POSITION_INT: u32 = 33;
    pub const SERVO_OUTPUT_RAW: u32 = 36;
    pub const MISSION_CURRENT: u32 = 42;
    pub const MISSION_ITEM_REACHED: u32 = 46;
    pub const GPS_GLOBAL_ORIGIN: u32 = 49;
    pub const NAV_CONTROLLER_OUTPUT: u32 = 62;
    pub const RC_CHANNELS: u32 = 65;
    pub const VFR_HUD: u32 = 74;
    pub const POSITION_TARGET_GLOBAL_INT: u32 = 87;
    pub const SCALED_IMU2: u32 = 116;
    pub const POWER_STATUS: u32 = 125;
    pub const SCALED_IMU3: u32 = 129;
    pub const TERRAIN_REQUEST: u32 = 133;
    pub const TERRAIN_REPORT: u32 = 136;
    pub const SCALED_PRESSURE2: u32 = 137;
    pub const BATTERY_STATUS: u32 = 147;
    pub const AUTOPILOT_VERSION: u32 = 148;
    pub const MEMINFO: u32 = 152;
    pub const AHRS: u32 = 163;
    pub const SIMSTATE: u32 = 164;
    pub const WIND: u32 = 168;
    pub const AHRS2: u32 = 178;
    pub const EKF_STATUS_REPORT: u32 = 193;
    pub const EFI_STATUS: u32 = 225;
    pub const VIBRATION: u32 = 241;
    pub const HOME_POSITION: u32 = 242;
    pub const EXTENDED_SYS_STATE: u32 = 245;
    pub const AIRSPEED: u32 = 295;
    pub const AOA_SSA: u32 = 11020;
    pub const ESC_TELEMETRY_1_TO_4: u32 = 11030;
}

/// Every message the vehicle streams, in the order ArduPlane sends them in
/// a burst, with its group (`None`: only by SET_MESSAGE_INTERVAL).
/// TERRAIN_REPORT stands for ArduPilot's MSG_TERRAIN (TERRAIN_REQUEST goes
/// with it).
pub const CATALOG: &[(u32, Option<Group>)] = &[
    (id::HEARTBEAT, None),
    (id::RAW_IMU, Some(Group::RawSensors)),
    (id::SCALED_IMU2, Some(Group::RawSensors)),
    (id::SCALED_IMU3, Some(Group::RawSensors)),
    (id::SCALED_PRESSURE, Some(Group::RawSensors)),
    (id::SCALED_PRESSURE2, Some(Group::RawSensors)),
    (id::AIRSPEED, Some(Group::RawSensors)),
    (id::SYS_STATUS, Some(Group::ExtendedStatus)),
    (id::POWER_STATUS, Some(Group::ExtendedStatus)),
    (id::MEMINFO, Some(Group::ExtendedStatus)),
    (id::MISSION_CURRENT, Some(Group::ExtendedStatus)),
    (id::GPS_RAW_INT, Some(Group::ExtendedStatus)),
    (id::NAV_CONTROLLER_OUTPUT, Some(Group::ExtendedStatus)),
    (id::POSITION_TARGET_GLOBAL_INT, Some(Group::ExtendedStatus)),
    (id::GLOBAL_POSITION_INT, Some(Group::Position)),
    (id::LOCAL_POSITION_NED, Some(Group::Position)),
    (id::SERVO_OUTPUT_RAW, Some(Group::RcChannels)),
    (id::RC_CHANNELS, Some(Group::RcChannels)),
    (id::ATTITUDE, Some(Group::Extra1)),
    (id::SIMSTATE, Some(Group::Extra1)),
    (id::AHRS2, Some(Group::Extra1)),
    (id::AOA_SSA, Some(Group::Extra1)),
    (id::ESC_TELEMETRY_1_TO_4, Some(Group::Extra1)),
    (id::EFI_STATUS, Some(Group::Extra1)),
    (id::VFR_HUD, Some(Group::Extra2)),
    (id::AHRS, Some(Group::Extra3)),
    (id::WIND, Some(Group::Extra3)),
    (id::SYSTEM_TIME, Some(Group::Extra3)),
    (id::TERRAIN_REPORT, Some(Group::Extra3)),
    (id::BATTERY_STATUS, Some(Group::Extra3)),
    (id::EKF_STATUS_REPORT, Some(Group::Extra3)),
    (id::VIBRATION, Some(Group::Extra3)),
    (id::HOME_POSITION, None),
    (id::GPS_GLOBAL_ORIGIN, None),
    (id::EXTENDED_SYS_STATE, None),
    // Sent on an event, but ArduPilot streams them when asked: each period
    // re-sends the last one (MISSION_ITEM_REACHED 65535 before any item
    // was reached), a repeat, not a new occurrence.
    (id::MISSION_ITEM_REACHED, None),
    (id::AUTOPILOT_VERSION, None),
];

/// Messages ArduPilot re-sends unchanged on every period once asked for by
/// SET_MESSAGE_INTERVAL although they tell of an event (checked on
/// ArduPlane 4.7 SITL): a client must not take a repeat for a new
/// occurrence. COMMAND_ACK, MISSION_ACK and STATUSTEXT are DENIED instead
/// ([`DENIED`]).
pub const REPEATED_EVENTS: &[u32] = &[id::MISSION_ITEM_REACHED];

/// Messages ArduPlane 4.7 SITL answers DENIED to SET_MESSAGE_INTERVAL for
/// (with "No ap_message for mavlink id (N)"): they are not in its map of
/// streamable messages, events such as COMMAND_ACK (77), MISSION_ACK (47)
/// and STATUSTEXT (253), a radio's own RADIO_STATUS (109) and RADIO (166),
/// TIMESYNC (111), and what that build has no sender for (SENSOR_OFFSETS
/// 150, BATTERY2 181, MCU_STATUS 11039, ESC_TELEMETRY_5_TO_8/9_TO_12,
/// ESTIMATOR_STATUS 230…). Every id neither streamed ([`CATALOG`]) nor in
/// [`KNOWN_NOT_SENT`] is denied; this list is what was checked.
pub const DENIED: &[u32] = &[
    47, 77, 109, 111, 150, 166, 169, 181, 230, 231, 234, 244, 253, 370, 410, 411, 412, 11031,
    11032, 11039,
];

/// Messages ArduPlane 4.7 SITL answers ACCEPTED to SET_MESSAGE_INTERVAL
/// for that this simulation does not stream. Never sent by SITL either (no
/// such sensor, or event-driven only): PARAM_VALUE, RC_CHANNELS_RAW,
/// ATTITUDE_TARGET, POSITION_TARGET_LOCAL_NED, OPTICAL_FLOW, GPS2_RAW,
/// GPS_RTK, GPS2_RTK, DISTANCE_SENSOR, TERRAIN_REQUEST, SCALED_PRESSURE3,
/// FENCE_STATUS, RANGEFINDER, CAMERA_FEEDBACK, PID_TUNING, RPM,
/// ADSB_VEHICLE, CAMERA_INFORMATION, CAMERA_SETTINGS, CAMERA_CAPTURE_STATUS
/// (no camera on the autopilot), GIMBAL_MANAGER_*,
/// GIMBAL_DEVICE_ATTITUDE_STATUS. Streamed by SITL but not by this
/// simulation (sensor detail no scenario reads): SCALED_IMU (26),
/// ATTITUDE_QUATERNION (31), HIGHRES_IMU (105), SIM_STATE (108), HWSTATUS
/// (165), HIGH_LATENCY2 (235), AUTOPILOT_STATE_FOR_GIMBAL_DEVICE (286).
pub const KNOWN_NOT_SENT: &[u32] = &[
    22, 26, 35, 31, 83, 85, 100, 105, 108, 124, 127, 128, 132, 133, 143, 162, 165, 173, 180, 194,
    226, 235, 246, 259, 260, 262, 280, 281, 285, 286,
];

/// The group of a message, when it is in one.
pub fn group_of(message: u32) -> Option<Group> {
    CATALOG
        .iter()
        .find(|(m, _)| *m == message)
        .and_then(|(_, g)| *g)
}

/// Whether the vehicle can stream this message.
pub fn streamable(message: u32) -> bool {
    CATALOG.iter().any(|(m, _)| *m == message)
}

/// The fastest ArduPilot streams (the loop rate of the SITL plane: 50 Hz).
const MIN_INTERVAL_US: u64 = 20_000;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Override {
    /// Not sent (interval −1).
    Off,
    Every(u64),
}

/// The stream scheduler.
#[derive(Debug, Clone, PartialEq)]
pub struct Streams {
    /// Group rates (Hz) by group.
    rates: BTreeMap<Group, u16>,
    /// Per-message intervals set by SET_MESSAGE_INTERVAL.
    overrides: BTreeMap<u32, Override>,
    /// Next time each active message is due.
    due: BTreeMap<u32, u64>,
}

impl Default for Streams {
    fn default() -> Self {
        let mut due = BTreeMap::new();
        // The first HEARTBEAT goes out one second after boot.
        due.insert(id::HEARTBEAT, 1_000_000);
        Streams {
            rates: BTreeMap::new(),
            overrides: BTreeMap::new(),
            due,
        }
    }
}

impl Streams {
    /// The interval of a message now (µs), `None` when it is not streamed.
    pub fn interval(&self, message: u32) -> Option<u64> {
        match self.overrides.get(&message) {
            Some(Override::Off) => None,
            Some(Override::Every(us)) => Some(*us),
            None if message == id::HEARTBEAT => Some(1_000_000),
            None => {
                let rate = *self.rates.get(&group_of(message)?)?;
                (rate > 0).then(|| (1_000_000 / rate as u64).max(MIN_INTERVAL_US))
            }
        }
    }

    fn reschedule(&mut self, now: u64, message: u32) {
        match self.interval(message) {
            Some(_) if self.due.contains_key(&message) => {}
            // Newly streamed: in the next burst.
            Some(_) => {
                self.due.insert(message, now);
            }
            None => {
                self.due.remove(&message);
            }
        }
    }

    /// REQUEST_DATA_STREAM: `stream` 0 for all groups. Returns the groups
    /// changed (their MAV1_ parameters change). Per-message intervals of
    /// those groups are dropped, as ArduPilot does.
    pub fn request_stream(&mut self, now: u64, stream: u8, rate: u16, start: bool) -> Vec<Group> {
        let groups: Vec<Group> = if stream == 0 {
            Group::ALL.to_vec()
        } else {
            Group::from_stream_id(stream).into_iter().collect()
        };
        let rate = if start { rate.min(50) } else { 0 };
        for &g in &groups {
            self.rates.insert(g, rate);
            let members: Vec<u32> = CATALOG
                .iter()
                .filter(|(_, gg)| *gg == Some(g))
                .map(|(m, _)| *m)
                .collect();
            for m in members {
                self.overrides.remove(&m);
                // A new rate restarts the message's cadence.
                self.due.remove(&m);
                self.reschedule(now, m);
            }
        }
        groups
    }

    /// MAV_CMD_SET_MESSAGE_INTERVAL: `interval_us` −1 stops, 0 restores the
    /// default (the group rate; 1 Hz for HEARTBEAT), otherwise the
    /// interval. False when the message is not one ArduPlane knows
    /// ([`KNOWN_NOT_SENT`] are accepted and never sent). HEARTBEAT obeys
    /// like any other, as on ArduPlane 4.7 SITL: 4 Hz when asked, and −1
    /// stops it (only a mode change still sends one).
    pub fn set_interval(&mut self, now: u64, message: u32, interval_us: i64) -> bool {
        if KNOWN_NOT_SENT.contains(&message) {
            return true;
        }
        if !streamable(message) {
            return false;
        }
        match interval_us {
            i64::MIN..=-1 => {
                self.overrides.insert(message, Override::Off);
            }
            0 => {
                self.overrides.remove(&message);
            }
            us => {
                self.overrides
                    .insert(message, Override::Every((us as u64).max(MIN_INTERVAL_US)));
            }
        }
        self.due.remove(&message);
        self.reschedule(now, message);
        true
    }

    /// The earliest time a message is due.
    pub fn next_due(&self) -> Option<u64> {
        self.due.values().copied().min()
    }

    /// The messages due at `now`, in burst order; each is rescheduled one
    /// interval later (or at `now` + interval when it fell far behind).
    pub fn take_due(&mut self, now: u64) -> Vec<u32> {
        let mut out = Vec::new();
        for &(m, _) in CATALOG {
            let Some(&due) = self.due.get(&m) else {
                continue;
            };
            if due > now {
                continue;
            }
            out.push(m);
            if let Some(interval) = self.interval(m) {
                let mut next = due + interval;
                if next <= now {
                    next = now + interval;
                }
                self.due.insert(m, next);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nothing_but_heartbeat_until_asked() {
        let mut s = Streams::default();
        let mut seen = Vec::new();
        let mut t = 0;
        while t <= 5_000_000 {
            seen.extend(s.take_due(t));
            t += 10_000;
        }
        assert_eq!(seen, vec![id::HEARTBEAT; 5]);
    }

    #[test]
    fn data_stream_all_at_4_hz_and_interval_override() {
        let mut s = Streams::default();
        let groups = s.request_stream(0, 0, 4, true);
        assert_eq!(groups.len(), 9);
        assert_eq!(s.interval(id::ATTITUDE), Some(250_000));
        assert_eq!(s.interval(id::EFI_STATUS), Some(250_000));
        assert_eq!(s.interval(id::HOME_POSITION), None);
        assert!(s.set_interval(0, id::ATTITUDE, 100_000));
        assert!(s.set_interval(0, id::VFR_HUD, -1));
        assert!(!s.set_interval(0, 12345, 100_000));
        assert!(!s.set_interval(0, 109, 100_000)); // RADIO_STATUS: a radio's, not ArduPilot's
        assert!(s.set_interval(0, 173, 100_000)); // RANGEFINDER: known, no sensor
        assert_eq!(s.interval(173), None);
        // HEARTBEAT obeys, as on ArduPlane SITL (−1 stops it).
        assert!(s.set_interval(0, id::HEARTBEAT, 250_000));
        assert_eq!(s.interval(id::HEARTBEAT), Some(250_000));
        assert!(s.set_interval(0, id::HEARTBEAT, 0));
        assert_eq!(s.interval(id::HEARTBEAT), Some(1_000_000));
        let mut count = BTreeMap::new();
        let mut t = 0;
        while t < 10_000_000 {
            for m in s.take_due(t) {
                *count.entry(m).or_insert(0) += 1;
            }
            t += 10_000;
        }
        assert_eq!(count[&id::ATTITUDE], 100);
        assert_eq!(count[&id::SYS_STATUS], 40);
        assert!(!count.contains_key(&id::VFR_HUD));
        // Restoring the default goes back to the group's 4 Hz.
        assert!(s.set_interval(t, id::ATTITUDE, 0));
        assert_eq!(s.interval(id::ATTITUDE), Some(250_000));
        // Stopping a group.
        s.request_stream(t, 10, 0, false);
        assert_eq!(s.interval(id::ATTITUDE), None);
        assert_eq!(s.interval(id::SYS_STATUS), Some(250_000));
        assert_eq!(s.interval(id::VFR_HUD), None);
    }

    /// What ArduPlane 4.7 SITL answered to SET_MESSAGE_INTERVAL (see the
    /// README): events and a radio's messages DENIED, MISSION_ITEM_REACHED
    /// and AUTOPILOT_VERSION ACCEPTED and streamed.
    #[test]
    fn denied_and_repeated_as_arduplane_answers() {
        let mut s = Streams::default();
        for &m in DENIED {
            assert!(!s.set_interval(0, m, 250_000), "{m} should be denied");
        }
        // COMMAND_ACK, MISSION_ACK, STATUSTEXT, RADIO_STATUS, RADIO: the
        // four a gateway reading them is refused (and MISSION_ACK).
        for m in [77, 47, 253, 109, 166] {
            assert!(DENIED.contains(&m));
        }
        for &m in REPEATED_EVENTS.iter().chain(&[id::AUTOPILOT_VERSION]) {
            assert!(s.set_interval(0, m, 1_000_000));
            assert_eq!(s.interval(m), Some(1_000_000));
        }
        for &m in KNOWN_NOT_SENT {
            assert!(!DENIED.contains(&m) && !streamable(m), "{m}");
            assert!(s.set_interval(0, m, 1_000_000));
            assert_eq!(s.interval(m), None);
        }
        let mut count = 0;
        let mut t = 0;
        while t <= 10_000_000 {
            count += s
                .take_due(t)
                .iter()
                .filter(|m| **m == id::MISSION_ITEM_REACHED)
                .count();
            t += 10_000;
        }
        assert_eq!(count, 11); // at once, then every second
    }
}
