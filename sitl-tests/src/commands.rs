//! COMMAND_LONG and COMMAND_INT, answered as ArduPlane 4.7 answers them
//! (GCS_Mavlink.cpp, GCS_Common.cpp), with the COMMAND_ACK first and the
//! texts and heartbeats the command causes after it. Camera commands go to
//! the camera component.

// MAV_FRAME_GLOBAL_INT is deprecated but still sent by ground stations.
#![allow(deprecated)]

use mavlink::dialects::ardupilotmega::*;

use crate::arming::FORCE;
use crate::camera;
use crate::mission::cmd;
use crate::modes;
use crate::state::{CameraAction, CameraEvent, CommandRecord};
use crate::streams::{self, id};
use crate::vehicle::{Vehicle, AUTOPILOT};

/// The position fields of a COMMAND_INT.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntArgs {
    pub frame: MavFrame,
    pub x: i32,
    pub y: i32,
    pub z: f32,
}

impl Vehicle {
    /// A command; `target` is the component it is addressed to.
    pub(crate) fn on_command(
        &mut self,
        from: (u8, u8),
        target: u8,
        command: u32,
        p: [f32; 7],
        int: Option<IntArgs>,
    ) {
        let camera_cmd = matches!(command, cmd::IMAGE_START_CAPTURE | cmd::IMAGE_STOP_CAPTURE);
        let to_camera =
            self.cfg.camera && (target == camera::COMPONENT || (target == 0 && camera_cmd));
        // Everything the command causes waits for its COMMAND_ACK.
        self.hold();
        let (responder, result) = if to_camera {
            (camera::COMPONENT, self.camera_command(command, p))
        } else if target == 0 || target == AUTOPILOT {
            (AUTOPILOT, Some(self.autopilot_command(command, p, int)))
        } else {
            (AUTOPILOT, None)
        };
        let held = self.release();
        self.truth.commands.push(CommandRecord {
            time_s: self.t_s(),
            command,
            int: int.is_some(),
            params: p,
            from,
            target_component: target,
            result: result.map(|r| r as u8),
        });
        if let Some(result) = result {
            tracing::debug!(t = self.t_s(), command, ?result, "command");
            let ack = MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                command: num_traits::FromPrimitive::from_u32(command).unwrap_or_default(),
                result,
                progress: 0,
                result_param2: 0,
                target_system: from.0,
                target_component: from.1,
            });
            self.send_from(responder, ack);
        }
        for (component, msg) in held {
            self.send_from(component, msg);
        }
    }

    fn camera_command(&mut self, command: u32, p: [f32; 7]) -> Option<MavResult> {
        let result = self.camera.command(self.now, command, p)?;
        if result == MavResult::MAV_RESULT_ACCEPTED {
            let action = match command {
                cmd::IMAGE_START_CAPTURE => Some(CameraAction::Start {
                    interval_s: p[1],
                    total: p[2].max(0.0) as u32,
                }),
                cmd::IMAGE_STOP_CAPTURE => Some(CameraAction::Stop),
                _ => None,
            };
            if let Some(action) = action {
                let at = self.fix();
                self.truth.camera.push(CameraEvent { at, action });
            }
        }
        // An image due at once goes out after the ack.
        if self.camera.next_deadline() <= self.now {
            for o in self.camera.tick(self.now) {
                self.camera_output(o);
            }
        }
        Some(result)
    }

    fn autopilot_command(&mut self, command: u32, p: [f32; 7], int: Option<IntArgs>) -> MavResult {
        use MavResult::*;
        match command {
            cmd::COMPONENT_ARM_DISARM => {
                if p[0] == 1.0 {
                    self.arm(p[1] == FORCE)
                } else if p[0] == 0.0 {
                    self.disarm_command(p[1] == FORCE)
                } else {
                    MAV_RESULT_UNSUPPORTED
                }
            }
            cmd::DO_SET_MODE => {
                if (p[0] as u32) & 1 == 0 {
                    return MAV_RESULT_UNSUPPORTED;
                }
                let mode = p[1] as u32;
                if !self.ready() || !modes::settable(mode) {
                    return MAV_RESULT_FAILED;
                }
                self.enter_mode(mode);
                MAV_RESULT_ACCEPTED
            }
            cmd::NAV_TAKEOFF => {
                // Only a QuadPlane takes off on command; from COMMAND_LONG
                // ArduPlane converts to the LOCAL_OFFSET_NED frame.
                match int {
                    Some(a) if a.frame != MavFrame::MAV_FRAME_LOCAL_OFFSET_NED => MAV_RESULT_DENIED,
                    _ => MAV_RESULT_FAILED,
                }
            }
            cmd::NAV_RETURN_TO_LAUNCH => self.mode_command(modes::RTL),
            cmd::NAV_LOITER_UNLIM => self.mode_command(modes::LOITER),
            cmd::MISSION_START => self.mode_command(modes::AUTO),
            cmd::DO_LAND_START => {
                if self.ready() && self.auto_jump_to_landing() {
                    MAV_RESULT_ACCEPTED
                } else {
                    MAV_RESULT_FAILED
                }
            }
            cmd::DO_SET_MISSION_CURRENT => {
                let seq = p[0];
                if !(0.0..65535.0).contains(&seq) || seq as usize >= self.mission.len() {
                    return MAV_RESULT_DENIED;
                }
                if !self.auto_set_current(seq as u16) {
                    return MAV_RESULT_FAILED;
                }
                let mc = self.mission_current();
                self.send(mc);
                MAV_RESULT_ACCEPTED
            }
            cmd::DO_REPOSITION => self.reposition(p, int),
            cmd::DO_CHANGE_SPEED => {
                if !modes::is_guided_like(self.fl.mode) && self.fl.mode != modes::AUTO {
                    return MAV_RESULT_FAILED;
                }
                if self.do_change_speed(p[0], p[1], p[2]) {
                    MAV_RESULT_ACCEPTED
                } else {
                    MAV_RESULT_FAILED
                }
            }
            cmd::DO_SET_RELAY => {
                if self.set_relay(p[0], p[1], None) {
                    MAV_RESULT_ACCEPTED
                } else {
                    MAV_RESULT_FAILED
                }
            }
            cmd::DO_SET_SERVO => {
                if self.set_servo(p[0], p[1], None) {
                    MAV_RESULT_ACCEPTED
                } else {
                    MAV_RESULT_FAILED
                }
            }
            cmd::SET_MESSAGE_INTERVAL => {
                let message = p[0];
                let interval = p[1];
                if !(0.0..16_777_216.0).contains(&message) || !interval.is_finite() {
                    return MAV_RESULT_DENIED;
                }
                if self
                    .streams
                    .set_interval(self.now, message as u32, interval as i64)
                {
                    MAV_RESULT_ACCEPTED
                } else {
                    self.info(format!("No ap_message for mavlink id ({})", message as u32));
                    MAV_RESULT_DENIED
                }
            }
            cmd::GET_MESSAGE_INTERVAL => {
                let message = p[0].max(0.0) as u32;
                let interval_us = if streams::streamable(message) {
                    self.streams
                        .interval(message)
                        .map(|i| i as i32)
                        .unwrap_or(-1)
                } else {
                    0
                };
                self.send(MavMessage::MESSAGE_INTERVAL(MESSAGE_INTERVAL_DATA {
                    interval_us,
                    message_id: message as u16,
                }));
                MAV_RESULT_ACCEPTED
            }
            cmd::REQUEST_MESSAGE => {
                let message = p[0].max(0.0) as u32;
                let ok = match message {
                    id::AUTOPILOT_VERSION => {
                        let v = self.autopilot_version();
                        self.send(v);
                        true
                    }
                    id::HEARTBEAT => {
                        self.send_heartbeat();
                        true
                    }
                    m if streams::streamable(m) => self.send_stream(m),
                    _ => return MAV_RESULT_DENIED,
                };
                if ok {
                    MAV_RESULT_ACCEPTED
                } else {
                    MAV_RESULT_FAILED
                }
            }
            cmd::REQUEST_AUTOPILOT_CAPABILITIES => {
                let v = self.autopilot_version();
                self.send(v);
                MAV_RESULT_ACCEPTED
            }
            cmd::GET_HOME_POSITION => {
                if self.home_set {
                    self.send_home();
                    MAV_RESULT_ACCEPTED
                } else {
                    MAV_RESULT_FAILED
                }
            }
            cmd::DO_SET_HOME => {
                if !self.home_set {
                    return MAV_RESULT_FAILED;
                }
                if p[0] == 1.0 {
                    self.home_pos = self.ac.pos;
                } else {
                    let (lat, lon) = match int {
                        Some(a) => (a.x as f64 / 1e7, a.y as f64 / 1e7),
                        None => (p[4] as f64, p[5] as f64),
                    };
                    if !(-90.0..=90.0).contains(&lat) || !(-180.0..=180.0).contains(&lon) {
                        return MAV_RESULT_DENIED;
                    }
                    self.home_pos = crate::geo::offset(self.origin(), lat, lon);
                }
                if !self.mission.is_empty() {
                    self.mission[0] = self.home_item();
                }
                self.send_home();
                MAV_RESULT_ACCEPTED
            }
            _ => MAV_RESULT_UNSUPPORTED,
        }
    }

    fn mode_command(&mut self, mode: u32) -> MavResult {
        if !self.ready() {
            return MavResult::MAV_RESULT_FAILED;
        }
        self.enter_mode(mode);
        MavResult::MAV_RESULT_ACCEPTED
    }

    /// DO_REPOSITION: GUIDED to loiter at a point (with the CHANGE_MODE
    /// flag, or when already in GUIDED); FAILED otherwise, DENIED for a bad
    /// position.
    fn reposition(&mut self, p: [f32; 7], int: Option<IntArgs>) -> MavResult {
        use MavResult::*;
        let (lat, lon, z, frame) = match int {
            Some(a) => (a.x as f64 / 1e7, a.y as f64 / 1e7, a.z, a.frame),
            None => (
                p[4] as f64,
                p[5] as f64,
                p[6],
                MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            ),
        };
        if !lat.is_finite()
            || !lon.is_finite()
            || !(-90.0..=90.0).contains(&lat)
            || !(-180.0..=180.0).contains(&lon)
            || (lat == 0.0 && lon == 0.0)
        {
            return MAV_RESULT_DENIED;
        }
        let change_mode = p[1].is_finite() && (p[1] as i32) & 1 != 0;
        if !change_mode && self.fl.mode != modes::GUIDED {
            return MAV_RESULT_FAILED;
        }
        if !self.ready() {
            return MAV_RESULT_FAILED;
        }
        let alt = if !z.is_finite() {
            self.ac.alt
        } else {
            match frame {
                MavFrame::MAV_FRAME_GLOBAL | MavFrame::MAV_FRAME_GLOBAL_INT => {
                    z as f64 - self.origin().alt_amsl
                }
                _ => z as f64,
            }
        };
        self.enter_mode(modes::GUIDED);
        let radius = if p[2].is_finite() && p[2] > 0.0 {
            p[2] as f64
        } else {
            self.wp_loiter_radius()
        };
        self.fl.orbit = Some(crate::flight::Orbit {
            center: crate::geo::offset(self.origin(), lat, lon),
            radius,
            ccw: p[3].is_finite() && p[3] != 0.0,
            alt,
        });
        MAV_RESULT_ACCEPTED
    }
}
