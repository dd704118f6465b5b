//! The mission: its items (item 0 is home, as on ArduPilot), and the upload
//! exchange as ArduPilot leads it (MISSION_COUNT → MISSION_REQUEST →
//! MISSION_ITEM_INT … → MISSION_ACK, asking again after 1 s of silence,
//! giving up after 8 s, answering an out-of-sequence item with
//! INVALID_SEQUENCE). A sans-IO piece of the vehicle: fed messages and
//! time, it returns the replies.

// ArduPilot asks with MISSION_REQUEST and accepts MISSION_ITEM: deprecated, still spoken.
#![allow(deprecated)]

use mavlink::dialects::ardupilotmega::{
    MavCmd, MavFrame, MavMissionResult, MISSION_ITEM_DATA, MISSION_ITEM_INT_DATA,
};
use num_traits::FromPrimitive;

/// MAV_CMD numbers the vehicle knows.
pub mod cmd {
    pub const NAV_WAYPOINT: u32 = 16;
    pub const NAV_LOITER_UNLIM: u32 = 17;
    pub const NAV_LOITER_TURNS: u32 = 18;
    pub const NAV_LOITER_TIME: u32 = 19;
    pub const NAV_RETURN_TO_LAUNCH: u32 = 20;
    pub const NAV_LAND: u32 = 21;
    pub const NAV_TAKEOFF: u32 = 22;
    pub const NAV_CONTINUE_AND_CHANGE_ALT: u32 = 30;
    pub const NAV_LOITER_TO_ALT: u32 = 31;
    pub const NAV_SPLINE_WAYPOINT: u32 = 82;
    pub const NAV_DELAY: u32 = 93;
    pub const NAV_LAST: u32 = 95;
    pub const CONDITION_DELAY: u32 = 112;
    pub const CONDITION_DISTANCE: u32 = 114;
    pub const CONDITION_YAW: u32 = 115;
    pub const DO_SET_MODE: u32 = 176;
    pub const DO_JUMP: u32 = 177;
    pub const DO_CHANGE_SPEED: u32 = 178;
    pub const DO_SET_HOME: u32 = 179;
    pub const DO_SET_RELAY: u32 = 181;
    pub const DO_REPEAT_RELAY: u32 = 182;
    pub const DO_SET_SERVO: u32 = 183;
    pub const DO_REPEAT_SERVO: u32 = 184;
    pub const DO_LAND_START: u32 = 189;
    pub const DO_GO_AROUND: u32 = 191;
    pub const DO_REPOSITION: u32 = 192;
    pub const DO_SET_ROI_LOCATION: u32 = 195;
    pub const DO_SET_ROI: u32 = 201;
    pub const DO_DIGICAM_CONFIGURE: u32 = 202;
    pub const DO_DIGICAM_CONTROL: u32 = 203;
    pub const DO_MOUNT_CONTROL: u32 = 205;
    pub const DO_SET_CAM_TRIGG_DIST: u32 = 206;
    pub const DO_FENCE_ENABLE: u32 = 207;
    pub const DO_PARACHUTE: u32 = 208;
    pub const DO_AUTOTUNE_ENABLE: u32 = 212;
    pub const DO_AUX_FUNCTION: u32 = 218;
    pub const DO_ENGINE_CONTROL: u32 = 223;
    pub const DO_SET_MISSION_CURRENT: u32 = 224;
    pub const MISSION_START: u32 = 300;
    pub const COMPONENT_ARM_DISARM: u32 = 400;
    pub const GET_HOME_POSITION: u32 = 410;
    pub const GET_MESSAGE_INTERVAL: u32 = 510;
    pub const SET_MESSAGE_INTERVAL: u32 = 511;
    pub const REQUEST_MESSAGE: u32 = 512;
    pub const REQUEST_AUTOPILOT_CAPABILITIES: u32 = 520;
    pub const IMAGE_START_CAPTURE: u32 = 2000;
    pub const IMAGE_STOP_CAPTURE: u32 = 2001;
}

/// Mission commands ArduPilot's AP_Mission accepts (others are answered
/// MAV_MISSION_UNSUPPORTED).
const SUPPORTED: &[u32] = &[
    cmd::NAV_WAYPOINT,
    cmd::NAV_LOITER_UNLIM,
    cmd::NAV_LOITER_TURNS,
    cmd::NAV_LOITER_TIME,
    cmd::NAV_RETURN_TO_LAUNCH,
    cmd::NAV_LAND,
    cmd::NAV_TAKEOFF,
    cmd::NAV_CONTINUE_AND_CHANGE_ALT,
    cmd::NAV_LOITER_TO_ALT,
    cmd::NAV_SPLINE_WAYPOINT,
    cmd::NAV_DELAY,
    cmd::CONDITION_DELAY,
    cmd::CONDITION_DISTANCE,
    cmd::CONDITION_YAW,
    cmd::DO_JUMP,
    cmd::DO_CHANGE_SPEED,
    cmd::DO_SET_HOME,
    cmd::DO_SET_RELAY,
    cmd::DO_REPEAT_RELAY,
    cmd::DO_SET_SERVO,
    cmd::DO_REPEAT_SERVO,
    cmd::DO_LAND_START,
    cmd::DO_GO_AROUND,
    cmd::DO_SET_ROI_LOCATION,
    cmd::DO_SET_ROI,
    cmd::DO_DIGICAM_CONFIGURE,
    cmd::DO_DIGICAM_CONTROL,
    cmd::DO_MOUNT_CONTROL,
    cmd::DO_SET_CAM_TRIGG_DIST,
    cmd::DO_FENCE_ENABLE,
    cmd::DO_PARACHUTE,
    cmd::DO_AUTOTUNE_ENABLE,
    cmd::DO_AUX_FUNCTION,
    cmd::DO_ENGINE_CONTROL,
    cmd::IMAGE_START_CAPTURE,
    cmd::IMAGE_STOP_CAPTURE,
];

/// One mission item, as MISSION_ITEM_INT carries it.
#[derive(Debug, Clone, PartialEq)]
pub struct MissionItem {
    pub seq: u16,
    /// MAV_CMD number.
    pub command: u32,
    pub frame: MavFrame,
    pub param1: f32,
    pub param2: f32,
    pub param3: f32,
    pub param4: f32,
    /// Latitude (degrees × 1e7) for positional commands.
    pub x: i32,
    /// Longitude (degrees × 1e7) for positional commands.
    pub y: i32,
    /// Altitude (m) in the frame.
    pub z: f32,
    pub autocontinue: bool,
}

impl MissionItem {
    /// Item 0: home (frame GLOBAL, altitude AMSL).
    pub fn home(lat: f64, lon: f64, alt_amsl: f64) -> MissionItem {
        MissionItem {
            seq: 0,
            command: cmd::NAV_WAYPOINT,
            frame: MavFrame::MAV_FRAME_GLOBAL,
            param1: 0.0,
            param2: 0.0,
            param3: 0.0,
            param4: 0.0,
            x: crate::geo::e7(lat),
            y: crate::geo::e7(lon),
            z: alt_amsl as f32,
            autocontinue: true,
        }
    }

    pub fn from_int(m: &MISSION_ITEM_INT_DATA) -> MissionItem {
        MissionItem {
            seq: m.seq,
            command: m.command as u32,
            frame: m.frame,
            param1: m.param1,
            param2: m.param2,
            param3: m.param3,
            param4: m.param4,
            x: m.x,
            y: m.y,
            z: m.z,
            autocontinue: m.autocontinue != 0,
        }
    }

    /// From the float MISSION_ITEM (ArduPilot still accepts it).
    pub fn from_float(m: &MISSION_ITEM_DATA) -> MissionItem {
        let global = is_global(m.frame);
        let conv = |v: f32| {
            if global {
                (v as f64 * 1e7).round() as i32
            } else {
                v as i32
            }
        };
        MissionItem {
            seq: m.seq,
            command: m.command as u32,
            frame: m.frame,
            param1: m.param1,
            param2: m.param2,
            param3: m.param3,
            param4: m.param4,
            x: conv(m.x),
            y: conv(m.y),
            z: m.z,
            autocontinue: m.autocontinue != 0,
        }
    }

    pub fn to_int(&self, target: (u8, u8), current: bool) -> MISSION_ITEM_INT_DATA {
        MISSION_ITEM_INT_DATA {
            param1: self.param1,
            param2: self.param2,
            param3: self.param3,
            param4: self.param4,
            x: self.x,
            y: self.y,
            z: self.z,
            seq: self.seq,
            command: MavCmd::from_u32(self.command).unwrap_or_default(),
            target_system: target.0,
            target_component: target.1,
            frame: self.frame,
            current: current as u8,
            autocontinue: self.autocontinue as u8,
            mission_type: Default::default(),
        }
    }

    pub fn to_float(&self, target: (u8, u8), current: bool) -> MISSION_ITEM_DATA {
        let global = is_global(self.frame);
        let conv = |v: i32| {
            if global {
                (v as f64 / 1e7) as f32
            } else {
                v as f32
            }
        };
        MISSION_ITEM_DATA {
            param1: self.param1,
            param2: self.param2,
            param3: self.param3,
            param4: self.param4,
            x: conv(self.x),
            y: conv(self.y),
            z: self.z,
            seq: self.seq,
            command: MavCmd::from_u32(self.command).unwrap_or_default(),
            target_system: target.0,
            target_component: target.1,
            frame: self.frame,
            current: current as u8,
            autocontinue: self.autocontinue as u8,
            mission_type: Default::default(),
        }
    }

    /// A navigation command (ArduPilot: id ≤ MAV_CMD_NAV_LAST).
    pub fn is_nav(&self) -> bool {
        self.command <= cmd::NAV_LAST
    }

    pub fn lat(&self) -> f64 {
        self.x as f64 / 1e7
    }

    pub fn lon(&self) -> f64 {
        self.y as f64 / 1e7
    }

    /// Whether the item carries a position (zero means "here" on ArduPilot).
    pub fn has_position(&self) -> bool {
        is_global(self.frame) && (self.x != 0 || self.y != 0)
    }

    /// The altitude above home (m), given home's altitude AMSL.
    pub fn alt_above_home(&self, home_amsl: f64) -> f64 {
        if is_amsl(self.frame) {
            self.z as f64 - home_amsl
        } else {
            self.z as f64
        }
    }

    /// ArduPilot's short name for the command ("Mission: 2 WP").
    pub fn type_name(&self) -> &'static str {
        type_name(self.command)
    }
}

/// AP_Mission's `Mission_Command::type()` names.
pub fn type_name(command: u32) -> &'static str {
    match command {
        cmd::NAV_WAYPOINT => "WP",
        cmd::NAV_SPLINE_WAYPOINT => "SplineWP",
        cmd::NAV_RETURN_TO_LAUNCH => "RTL",
        cmd::NAV_LOITER_UNLIM => "LoitUnlim",
        cmd::NAV_LOITER_TIME => "LoitTime",
        cmd::NAV_LOITER_TURNS => "LoitTurns",
        cmd::NAV_LOITER_TO_ALT => "LoitAltitude",
        cmd::NAV_LAND => "Land",
        cmd::NAV_TAKEOFF => "Takeoff",
        cmd::NAV_CONTINUE_AND_CHANGE_ALT => "ContinueAndChangeAlt",
        cmd::NAV_DELAY => "Delay",
        cmd::CONDITION_DELAY => "CondDelay",
        cmd::CONDITION_DISTANCE => "CondDist",
        cmd::CONDITION_YAW => "CondYaw",
        cmd::DO_JUMP => "Jump",
        cmd::DO_CHANGE_SPEED => "ChangeSpeed",
        cmd::DO_SET_HOME => "SetHome",
        cmd::DO_SET_RELAY => "SetRelay",
        cmd::DO_REPEAT_RELAY => "RepeatRelay",
        cmd::DO_SET_SERVO => "SetServo",
        cmd::DO_REPEAT_SERVO => "RepeatServo",
        cmd::DO_LAND_START => "LandStart",
        cmd::DO_GO_AROUND => "Go Around",
        cmd::DO_SET_ROI | cmd::DO_SET_ROI_LOCATION => "SetROI",
        cmd::DO_DIGICAM_CONFIGURE => "DigiCamCfg",
        cmd::DO_DIGICAM_CONTROL => "DigiCamCtrl",
        cmd::DO_MOUNT_CONTROL => "MountControl",
        cmd::DO_SET_CAM_TRIGG_DIST => "SetCamTrigDst",
        cmd::DO_FENCE_ENABLE => "FenceEnable",
        cmd::DO_PARACHUTE => "Parachute",
        cmd::DO_AUTOTUNE_ENABLE => "AutoTuneEnable",
        cmd::DO_AUX_FUNCTION => "AuxFunction",
        cmd::DO_ENGINE_CONTROL => "EngineControl",
        cmd::IMAGE_START_CAPTURE => "ImageStartCapture",
        cmd::IMAGE_STOP_CAPTURE => "ImageStopCapture",
        _ => "?",
    }
}

fn is_global(frame: MavFrame) -> bool {
    use MavFrame::*;
    matches!(
        frame,
        MAV_FRAME_GLOBAL
            | MAV_FRAME_GLOBAL_RELATIVE_ALT
            | MAV_FRAME_GLOBAL_INT
            | MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
            | MAV_FRAME_GLOBAL_TERRAIN_ALT
            | MAV_FRAME_GLOBAL_TERRAIN_ALT_INT
    )
}

fn is_amsl(frame: MavFrame) -> bool {
    matches!(
        frame,
        MavFrame::MAV_FRAME_GLOBAL | MavFrame::MAV_FRAME_GLOBAL_INT
    )
}

/// Checks an item as ArduPilot does before storing it.
pub fn check(item: &MissionItem) -> Result<(), MavMissionResult> {
    if !SUPPORTED.contains(&item.command) {
        return Err(MavMissionResult::MAV_MISSION_UNSUPPORTED);
    }
    if !is_global(item.frame) && item.frame != MavFrame::MAV_FRAME_MISSION {
        return Err(MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME);
    }
    if is_global(item.frame) {
        if !(-900_000_000..=900_000_000).contains(&item.x) {
            return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X);
        }
        if !(-1_800_000_000..=1_800_000_000).contains(&item.y) {
            return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y);
        }
    }
    Ok(())
}

/// The most items the vehicle stores (a 16 kB storage of 15-byte items).
pub const MAX_ITEMS: u16 = 1000;
/// ArduPilot asks again for an item after this silence (µs).
pub const REQUEST_RETRY_US: u64 = 1_000_000;
/// ... and abandons the upload after this silence (µs).
pub const UPLOAD_TIMEOUT_US: u64 = 8_000_000;

/// What the upload wants sent or done.
#[derive(Debug, Clone, PartialEq)]
pub enum Reply {
    /// MISSION_REQUEST for this item, to the uploader.
    Request { to: (u8, u8), seq: u16 },
    /// MISSION_ACK to the uploader.
    Ack {
        to: (u8, u8),
        result: MavMissionResult,
    },
    /// The upload is complete: the new mission (item 0 as received; the
    /// vehicle puts home there).
    Stored(Vec<MissionItem>),
    /// MISSION_COUNT 0: the mission is cleared.
    Cleared,
}

#[derive(Debug, Clone, PartialEq)]
struct Pending {
    partner: (u8, u8),
    count: u16,
    items: Vec<MissionItem>,
    last_request: u64,
    last_receive: u64,
}

/// The upload side of the mission protocol.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Uploads {
    upload: Option<Pending>,
}

impl Uploads {
    /// Whether an upload is under way.
    pub fn active(&self) -> bool {
        self.upload.is_some()
    }

    /// MISSION_COUNT from `from`.
    pub fn count(&mut self, now: u64, from: (u8, u8), count: u16) -> Vec<Reply> {
        if count == 0 {
            self.upload = None;
            return vec![
                Reply::Cleared,
                Reply::Ack {
                    to: from,
                    result: MavMissionResult::MAV_MISSION_ACCEPTED,
                },
            ];
        }
        if count > MAX_ITEMS {
            return vec![Reply::Ack {
                to: from,
                result: MavMissionResult::MAV_MISSION_NO_SPACE,
            }];
        }
        self.upload = Some(Pending {
            partner: from,
            count,
            items: Vec::new(),
            last_request: now,
            last_receive: now,
        });
        vec![Reply::Request { to: from, seq: 0 }]
    }

    /// MISSION_ITEM_INT (or MISSION_ITEM) from `from`.
    pub fn item(&mut self, now: u64, from: (u8, u8), item: MissionItem) -> Vec<Reply> {
        let Some(up) = self.upload.as_mut() else {
            return vec![Reply::Ack {
                to: from,
                result: MavMissionResult::MAV_MISSION_ERROR,
            }];
        };
        let expected = up.items.len() as u16;
        if item.seq != expected {
            // A duplicate or an item out of order: refused, the upload goes on.
            return vec![Reply::Ack {
                to: from,
                result: MavMissionResult::MAV_MISSION_INVALID_SEQUENCE,
            }];
        }
        if from != up.partner {
            return vec![Reply::Ack {
                to: from,
                result: MavMissionResult::MAV_MISSION_DENIED,
            }];
        }
        if let Err(result) = check(&item) {
            self.upload = None;
            return vec![Reply::Ack { to: from, result }];
        }
        up.items.push(item);
        up.last_receive = now;
        if (up.items.len() as u16) < up.count {
            up.last_request = now;
            return vec![Reply::Request {
                to: from,
                seq: up.items.len() as u16,
            }];
        }
        let items = std::mem::take(&mut up.items);
        self.upload = None;
        vec![
            Reply::Ack {
                to: from,
                result: MavMissionResult::MAV_MISSION_ACCEPTED,
            },
            Reply::Stored(items),
        ]
    }

    /// MISSION_ACK from the uploader (a cancel).
    pub fn cancel(&mut self, from: (u8, u8)) {
        if self.upload.as_ref().is_some_and(|u| u.partner == from) {
            self.upload = None;
        }
    }

    /// Time passes: ask again after 1 s of silence, give up after 8 s.
    pub fn tick(&mut self, now: u64) -> Vec<Reply> {
        let Some(up) = self.upload.as_mut() else {
            return vec![];
        };
        if now.saturating_sub(up.last_receive) >= UPLOAD_TIMEOUT_US {
            let to = up.partner;
            self.upload = None;
            return vec![Reply::Ack {
                to,
                result: MavMissionResult::MAV_MISSION_OPERATION_CANCELLED,
            }];
        }
        if now.saturating_sub(up.last_request) >= REQUEST_RETRY_US {
            up.last_request = now;
            return vec![Reply::Request {
                to: up.partner,
                seq: up.items.len() as u16,
            }];
        }
        vec![]
    }

    /// The next time `tick` may have something to do.
    pub fn next_deadline(&self) -> Option<u64> {
        self.upload
            .as_ref()
            .map(|u| (u.last_request + REQUEST_RETRY_US).min(u.last_receive + UPLOAD_TIMEOUT_US))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wp(seq: u16) -> MissionItem {
        let mut it = MissionItem::home(-35.36, 149.16, 10.0);
        it.seq = seq;
        it.frame = MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT;
        it
    }

    const GCS: (u8, u8) = (255, 190);

    #[test]
    fn upload_requests_every_item_then_acks() {
        let mut u = Uploads::default();
        assert_eq!(u.count(0, GCS, 3), vec![Reply::Request { to: GCS, seq: 0 }]);
        assert_eq!(
            u.item(10, GCS, wp(0)),
            vec![Reply::Request { to: GCS, seq: 1 }]
        );
        assert_eq!(
            u.item(20, GCS, wp(1)),
            vec![Reply::Request { to: GCS, seq: 2 }]
        );
        let r = u.item(30, GCS, wp(2));
        assert_eq!(
            r[0],
            Reply::Ack {
                to: GCS,
                result: MavMissionResult::MAV_MISSION_ACCEPTED
            }
        );
        assert!(matches!(&r[1], Reply::Stored(items) if items.len() == 3));
        assert!(!u.active());
    }

    #[test]
    fn duplicate_item_is_refused_and_a_lost_one_asked_again() {
        let mut u = Uploads::default();
        u.count(0, GCS, 3);
        u.item(100, GCS, wp(0));
        // The same item again: INVALID_SEQUENCE, and the upload goes on.
        assert_eq!(
            u.item(200, GCS, wp(0)),
            vec![Reply::Ack {
                to: GCS,
                result: MavMissionResult::MAV_MISSION_INVALID_SEQUENCE
            }]
        );
        assert!(u.active());
        // Item 1 never comes: asked again after a second, twice.
        assert_eq!(u.tick(900_000), vec![]);
        assert_eq!(u.tick(1_000_100), vec![Reply::Request { to: GCS, seq: 1 }]);
        assert_eq!(u.tick(2_000_100), vec![Reply::Request { to: GCS, seq: 1 }]);
        assert_eq!(
            u.item(2_100_000, GCS, wp(1)),
            vec![Reply::Request { to: GCS, seq: 2 }]
        );
        // Then silence: cancelled after 8 s.
        let r = u.tick(10_200_000);
        assert_eq!(
            r,
            vec![Reply::Ack {
                to: GCS,
                result: MavMissionResult::MAV_MISSION_OPERATION_CANCELLED
            }]
        );
        assert!(!u.active());
    }

    #[test]
    fn bad_items_end_the_upload() {
        let mut u = Uploads::default();
        u.count(0, GCS, 2);
        let mut bad = wp(0);
        bad.command = 12345;
        assert_eq!(
            u.item(1, GCS, bad),
            vec![Reply::Ack {
                to: GCS,
                result: MavMissionResult::MAV_MISSION_UNSUPPORTED
            }]
        );
        assert!(!u.active());
        assert_eq!(
            u.count(0, GCS, 5000),
            vec![Reply::Ack {
                to: GCS,
                result: MavMissionResult::MAV_MISSION_NO_SPACE
            }]
        );
        let mut far = wp(0);
        far.x = 950_000_000;
        assert_eq!(
            check(&far),
            Err(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X)
        );
    }

    #[test]
    fn float_items_convert() {
        let it = wp(4);
        let f = it.to_float((1, 1), false);
        assert!((f.x as f64 - -35.36).abs() < 1e-5);
        let back = MissionItem::from_float(&f);
        assert!((back.x - it.x).abs() <= 10);
        assert_eq!(back.seq, 4);
        assert_eq!(type_name(cmd::NAV_TAKEOFF), "Takeoff");
    }
}
