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
        let camera_cmd = camera::Camera::is_camera_command(command);
        let to_camera =
            self.cfg.camera && (target == camera::COMPONENT || (target == 0 && camera_cmd));
        // Everything the command causes waits for its COMMAND_ACK.
        self.hold();
        let refused = self
            .refusal()
            .filter(|_| to_camera || target == 0 || target == AUTOPILOT);
        let (responder, result) = if let Some(refused) = refused {
            // A vehicle that says no (Fault::RefuseCommands): the autopilot
            // or its camera answers, and nothing happens.
            let responder = if to_camera {
                camera::COMPONENT
            } else {
                AUTOPILOT
            };
            self.clear(crate::faults::FaultKind::RefuseCommand);
            (responder, Some(refused))
        } else if to_camera {
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
        if self.is_rover() {
            if let Some(result) = self.rover_command(command, p, int) {
                return result;
            }
        }
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

    /// The commands a rover answers otherwise than ArduPlane (its modes,
    /// its GUIDED, no take-off or landing); `None`: as ArduPlane.
    fn rover_command(
        &mut self,
        command: u32,
        p: [f32; 7],
        int: Option<IntArgs>,
    ) -> Option<MavResult> {
        use MavResult::*;
        let ok = |b: bool| {
            if b {
                MAV_RESULT_ACCEPTED
            } else {
                MAV_RESULT_FAILED
            }
        };
        Some(match command {
            cmd::DO_SET_MODE => {
                if (p[0] as u32) & 1 == 0 {
                    return Some(MAV_RESULT_UNSUPPORTED);
                }
                ok(self.rover_set_mode(p[1] as u32))
            }
            cmd::NAV_RETURN_TO_LAUNCH => ok(self.rover_set_mode(modes::rover::RTL)),
            cmd::MISSION_START => ok(self.rover_set_mode(modes::rover::AUTO)),
            cmd::NAV_TAKEOFF | cmd::DO_LAND_START | cmd::NAV_LOITER_UNLIM => MAV_RESULT_UNSUPPORTED,
            cmd::DO_CHANGE_SPEED => ok(self.rover_change_speed(p[1])),
            cmd::DO_SET_MISSION_CURRENT => {
                let seq = p[0];
                if !(0.0..65535.0).contains(&seq) || seq as usize >= self.mission.len() {
                    return Some(MAV_RESULT_DENIED);
                }
                if !self.rover_set_current(seq as u16) {
                    return Some(MAV_RESULT_FAILED);
                }
                let mc = self.mission_current();
                self.send(mc);
                MAV_RESULT_ACCEPTED
            }
            cmd::DO_REPOSITION => {
                let (lat, lon) = match int {
                    Some(a) => (a.x as f64 / 1e7, a.y as f64 / 1e7),
                    None => (p[4] as f64, p[5] as f64),
                };
                if !lat.is_finite()
                    || !lon.is_finite()
                    || !(-90.0..=90.0).contains(&lat)
                    || !(-180.0..=180.0).contains(&lon)
                    || (lat == 0.0 && lon == 0.0)
                {
                    return Some(MAV_RESULT_DENIED);
                }
                let change_mode = p[1].is_finite() && (p[1] as i32) & 1 != 0;
                if self.fl.mode != modes::rover::GUIDED
                    && !(change_mode && self.rover_set_mode(modes::rover::GUIDED))
                {
                    return Some(MAV_RESULT_FAILED);
                }
                if p[0].is_finite() && p[0] > 0.0 {
                    self.rv.speed = Some(p[0] as f64);
                }
                let to = crate::geo::offset(self.origin(), lat, lon);
                self.rover_goto(to);
                MAV_RESULT_ACCEPTED
            }
            _ => return None,
        })
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
        self.fl.orbit = Some(crate::nav_state::Orbit {
            center: crate::geo::offset(self.origin(), lat, lon),
            radius,
            ccw: p[3].is_finite() && p[3] != 0.0,
            alt,
        });
        MAV_RESULT_ACCEPTED
    }
}

#[cfg(test)]
mod tests {
    use crate::mission::cmd;
    use crate::modes;
    use crate::state::{CameraAction, PayloadKind};
    use crate::vehicle::testing::*;
    use mavlink::dialects::ardupilotmega::*;

    /// The acks of a command since `from`: (sender component, result).
    fn acks(b: &Bench, from: usize, command: MavCmd) -> Vec<(u8, MavResult)> {
        b.since(from, "COMMAND_ACK")
            .into_iter()
            .filter_map(|(_, h, m)| match m {
                MavMessage::COMMAND_ACK(a) if a.command == command => {
                    Some((h.component_id, a.result))
                }
                _ => None,
            })
            .collect()
    }

    #[test]
    fn the_camera_answers_from_component_100_and_takes_pictures() {
        let mut b = Bench::airborne(quick());
        let from = b.got.len();
        b.command_to(
            100,
            MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
            [0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(
            acks(&b, from, MavCmd::MAV_CMD_IMAGE_START_CAPTURE),
            vec![(100, MavResult::MAV_RESULT_ACCEPTED)]
        );
        // Addressed to the autopilot: it has no camera of its own.
        b.command(
            MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
            [0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(
            acks(&b, from, MavCmd::MAV_CMD_IMAGE_START_CAPTURE)[1],
            (1, MavResult::MAV_RESULT_UNSUPPORTED)
        );
        b.run_to(b.v.state().time_s + 9.0);
        b.command_to(100, MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE, [0.0; 7]);
        assert_eq!(
            acks(&b, from, MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE),
            vec![(100, MavResult::MAV_RESULT_ACCEPTED)]
        );
        let images = b.since(from, "CAMERA_IMAGE_CAPTURED");
        assert_eq!(images.len(), 5, "one at once, then every 2 s for 9 s");
        assert!(images.iter().all(|(_, h, _)| h.component_id == 100));
        let s = b.v.state();
        let kinds: Vec<&CameraAction> = s.camera.iter().map(|c| &c.action).collect();
        assert!(
            matches!(kinds[0], CameraAction::Start { interval_s, total: 0 } if *interval_s == 2.0)
        );
        assert!(matches!(kinds.last().unwrap(), CameraAction::Stop));
        assert_eq!(
            kinds
                .iter()
                .filter(|k| matches!(k, CameraAction::Image { .. }))
                .count(),
            5
        );
        // Each image where the aircraft was: in the air, over different places.
        let shots: Vec<_> = s
            .camera
            .iter()
            .filter(|c| matches!(c.action, CameraAction::Image { .. }))
            .collect();
        assert!(shots.iter().all(|c| c.at.alt > 30.0));
        assert!(shots[0].at.lat != shots[4].at.lat || shots[0].at.lon != shots[4].at.lon);
        // CAMERA_INFORMATION and CAMERA_CAPTURE_STATUS on request, after
        // the ack, from component 100 (the same messages as the camera on
        // its own link).
        let asked = b.got.len();
        for id in [259.0, 262.0] {
            let r = b.command_to(
                100,
                MavCmd::MAV_CMD_REQUEST_MESSAGE,
                [id, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            );
            assert_eq!(r, Some(MavResult::MAV_RESULT_ACCEPTED));
        }
        let answered: Vec<(u8, &str)> = b.got[asked..]
            .iter()
            .map(|(_, h, m)| (h.component_id, mavlink::Message::message_name(m)))
            .filter(|(c, _)| *c == 100)
            .collect();
        assert_eq!(
            answered,
            vec![
                (100, "COMMAND_ACK"),
                (100, "CAMERA_INFORMATION"),
                (100, "COMMAND_ACK"),
                (100, "CAMERA_CAPTURE_STATUS")
            ]
        );
        let s = b.v.state();
        // The camera's commands are in the record, with the answer.
        assert!(s
            .commands
            .iter()
            .any(|c| c.command == 2000 && c.target_component == 100 && c.result == Some(0)));

        // A silent camera: no heartbeat, no answer.
        b.v.inject(crate::Fault::PayloadFailure(crate::PayloadFailure::Silent));
        let from = b.got.len();
        b.command_to(
            100,
            MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
            [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        b.run_to(b.v.state().time_s + 3.0);
        assert!(acks(&b, from, MavCmd::MAV_CMD_IMAGE_START_CAPTURE).is_empty());
        assert!(!b
            .since(from, "HEARTBEAT")
            .iter()
            .any(|(_, h, _)| h.component_id == 100));
        assert_eq!(b.v.state().commands.last().unwrap().result, None);
    }

    #[test]
    fn relays_and_servos_are_set_and_recorded() {
        let mut b = Bench::new(quick());
        b.run_to(3.0);
        let relay = b.command(
            MavCmd::MAV_CMD_DO_SET_RELAY,
            [1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(relay, Some(MavResult::MAV_RESULT_ACCEPTED));
        let servo = b.command(
            MavCmd::MAV_CMD_DO_SET_SERVO,
            [9.0, 1900.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(servo, Some(MavResult::MAV_RESULT_ACCEPTED));
        // Output 3 is the throttle: refused. Relay 9 does not exist.
        let thr = b.command(
            MavCmd::MAV_CMD_DO_SET_SERVO,
            [3.0, 1900.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(thr, Some(MavResult::MAV_RESULT_FAILED));
        let bad = b.command(
            MavCmd::MAV_CMD_DO_SET_RELAY,
            [9.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(bad, Some(MavResult::MAV_RESULT_FAILED));
        let kinds: Vec<PayloadKind> =
            b.v.state()
                .payload_actions
                .into_iter()
                .map(|a| a.kind)
                .collect();
        assert_eq!(
            kinds,
            vec![
                PayloadKind::Relay {
                    instance: 1,
                    on: true
                },
                PayloadKind::Servo {
                    channel: 9,
                    pwm: 1900
                }
            ]
        );
        assert_eq!(
            b.command(
                MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                [36.0, 500_000.0, 0.0, 0.0, 0.0, 0.0, 0.0]
            ),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        b.run_to(4.0);
        assert!(matches!(b.of("SERVO_OUTPUT_RAW").last(),
            Some(MavMessage::SERVO_OUTPUT_RAW(s)) if s.servo9_raw == 1900 && s.servo3_raw == 1000));
    }

    #[test]
    fn reposition_speed_and_landing_sequence_as_arduplane_answers() {
        let mut b = Bench::airborne(quick());
        let (lat, lon) = (b.v.cfg.home.lat + 0.005, b.v.cfg.home.lon);
        let e7 = crate::geo::e7;
        let rel = MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT;
        // Outside GUIDED without the CHANGE_MODE flag: FAILED; a bad point: DENIED.
        let r = b.command_int(
            MavCmd::MAV_CMD_DO_REPOSITION,
            rel,
            [-1.0, 0.0, 0.0, 0.0],
            e7(lat),
            e7(lon),
            70.0,
        );
        assert_eq!(r, Some(MavResult::MAV_RESULT_FAILED));
        let r = b.command_int(
            MavCmd::MAV_CMD_DO_REPOSITION,
            rel,
            [-1.0, 1.0, 0.0, 0.0],
            0,
            0,
            70.0,
        );
        assert_eq!(r, Some(MavResult::MAV_RESULT_DENIED));
        let r = b.command_int(
            MavCmd::MAV_CMD_DO_REPOSITION,
            rel,
            [-1.0, 1.0, 80.0, 0.0],
            e7(lat),
            e7(lon),
            70.0,
        );
        assert_eq!(r, Some(MavResult::MAV_RESULT_ACCEPTED));
        assert_eq!(b.v.state().mode, "GUIDED");
        // DO_CHANGE_SPEED in GUIDED: the airspeed follows.
        let r = b.command(
            MavCmd::MAV_CMD_DO_CHANGE_SPEED,
            [0.0, 27.0, -1.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(r, Some(MavResult::MAV_RESULT_ACCEPTED));
        b.run_to(b.v.state().time_s + 40.0);
        let s = b.v.state();
        assert!((s.airspeed - 27.0).abs() < 1.0, "airspeed {}", s.airspeed);
        assert!((s.alt - 70.0).abs() < 5.0, "alt {}", s.alt);
        let centre = crate::geo::offset(&b.v.cfg.home, lat, lon);
        let r = (crate::geo::V2::new(s.north, s.east) - centre).len();
        assert!((r - 80.0).abs() < 25.0, "loiter radius {r}");
        // Out of range: FAILED. In a manual mode: FAILED.
        let r = b.command(
            MavCmd::MAV_CMD_DO_CHANGE_SPEED,
            [0.0, 45.0, -1.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(r, Some(MavResult::MAV_RESULT_FAILED));
        assert_eq!(
            b.set_mode(modes::FBWA),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let r = b.command(
            MavCmd::MAV_CMD_DO_CHANGE_SPEED,
            [0.0, 20.0, -1.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(r, Some(MavResult::MAV_RESULT_FAILED));
        // DO_LAND_START without a landing sequence: FAILED.
        let r = b.command(MavCmd::MAV_CMD_DO_LAND_START, [0.0; 7]);
        assert_eq!(r, Some(MavResult::MAV_RESULT_FAILED));
        assert_eq!(
            b.texts().last().unwrap(),
            "Unable to start landing sequence"
        );
        // With one: AUTO at the item after DO_LAND_START.
        let v = &b.v;
        let mut marker = item(v, cmd::DO_LAND_START, 0.0, 0.0, 0.0);
        marker.frame = MavFrame::MAV_FRAME_MISSION;
        marker.x = 0;
        marker.y = 0;
        let mission = vec![
            item(v, cmd::NAV_WAYPOINT, 1500.0, 1500.0, 60.0),
            item(v, cmd::NAV_LOITER_UNLIM, 1500.0, 1500.0, 60.0),
            marker,
            item(v, cmd::NAV_WAYPOINT, -300.0, 0.0, 25.0),
            item(v, cmd::NAV_LAND, 100.0, 0.0, 0.0),
        ];
        assert_eq!(b.upload(&mission), MavMissionResult::MAV_MISSION_ACCEPTED);
        let r = b.command(MavCmd::MAV_CMD_DO_LAND_START, [0.0; 7]);
        assert_eq!(r, Some(MavResult::MAV_RESULT_ACCEPTED));
        let s = b.v.state();
        assert_eq!(s.mode, "AUTO");
        assert_eq!(s.mission_current, 4);
        assert_eq!(
            s.reached.last().unwrap().seq,
            3,
            "the DO_LAND_START item ran"
        );
        assert!(b.texts().contains(&"Landing sequence start".to_owned()));
        assert!(b.run_until(b.v.state().time_s + 200.0, |v| v.fl.landed));
        assert!(!b.v.state().crashed);
        // MISSION_START restarts the mission from its first item.
        let r = b.command(MavCmd::MAV_CMD_MISSION_START, [0.0; 7]);
        assert_eq!(r, Some(MavResult::MAV_RESULT_ACCEPTED));
    }
}
