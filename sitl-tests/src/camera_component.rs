//! The payload camera on its own: a MAVLink component of the vehicle's
//! system (component 100, MAV_TYPE_CAMERA) on a link of its own, as a real
//! camera on one of the autopilot's serial ports. Sans-IO, as [`Vehicle`]:
//! fed `handle(now, header, message)` and `advance(now)` in its own
//! microseconds since power-on, polled with `poll_transmit()`. It answers
//! exactly as the camera inside the simulated vehicle (the same
//! [`Camera`]: acks, images, CAMERA_INFORMATION, CAMERA_CAPTURE_STATUS, the
//! payload failures), and knows where it is from the autopilot's
//! GLOBAL_POSITION_INT, which it asks for on its own link with
//! SET_MESSAGE_INTERVAL once it hears the autopilot.
//!
//! [`Vehicle`]: crate::Vehicle

use std::collections::VecDeque;

use mavlink::dialects::ardupilotmega::*;
use mavlink::MavHeader;

use crate::camera::{self, Camera, Context, Output};
use crate::faults::PayloadFailure;
use crate::mission::cmd;
use crate::state::{CameraAction, CameraEvent, Fix};

/// GLOBAL_POSITION_INT's message id.
const GLOBAL_POSITION_INT: u32 = 33;
/// How often the position request is sent again until acknowledged (µs).
const ASK_AGAIN_US: u64 = 1_000_000;
/// Position requests at most.
const ASK_AT_MOST: u32 = 10;

/// How the camera is set up.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraConfig {
    /// The vehicle's system id (the camera is one of its components).
    pub system: u8,
    /// Its component id (MAV_COMP_ID_CAMERA, 100).
    pub component: u8,
    /// The autopilot's component id (1).
    pub autopilot: u8,
    /// GLOBAL_POSITION_INT asked of the autopilot at this rate (Hz) once it
    /// is heard; 0: never asked (images then carry no position).
    pub position_hz: f32,
    /// The camera's clock runs this many times faster than the wall clock
    /// (the SITL's `--speedup`), for [`crate::CameraSim`].
    pub speedup: f64,
    /// µs since the Unix epoch at power-on (CAMERA_IMAGE_CAPTURED.time_utc).
    pub unix_boot_us: u64,
}

impl Default for CameraConfig {
    fn default() -> Self {
        CameraConfig {
            system: 1,
            component: camera::COMPONENT,
            autopilot: 1,
            position_hz: 2.0,
            speedup: 1.0,
            unix_boot_us: 1_700_000_000_000_000,
        }
    }
}

/// A command the camera heard, with its answer.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraCommand {
    /// Camera seconds since power-on.
    pub time_s: f64,
    pub command: u32,
    pub params: [f32; 7],
    /// (system, component) of the sender.
    pub from: (u8, u8),
    /// The target component it was sent to (the camera's, or 0).
    pub target_component: u8,
    /// The COMMAND_ACK result, `None` when the camera did not answer.
    pub result: Option<u8>,
}

/// What the camera did and heard (a snapshot).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CameraState {
    /// Camera seconds since power-on.
    pub time_s: f64,
    /// The link is up (set by [`crate::CameraSim`]).
    pub connected: bool,
    /// The autopilot's HEARTBEAT was heard.
    pub autopilot_heard: bool,
    /// The autopilot acknowledged the position request.
    pub position_streamed: bool,
    /// The last position heard (GLOBAL_POSITION_INT), time in camera seconds.
    pub position: Option<Fix>,
    /// The autopilot's time since its boot minus the camera's, from the last
    /// GLOBAL_POSITION_INT's `time_boot_ms` (s): a camera time plus this is
    /// the autopilot's (SITL's) time.
    pub autopilot_offset_s: Option<f64>,
    /// Every command addressed to the camera.
    pub commands: Vec<CameraCommand>,
    /// Captures started and stopped, images taken, with where and when.
    pub camera: Vec<CameraEvent>,
    /// Images taken.
    pub images: i32,
    /// The payload failure injected now.
    pub failure: Option<PayloadFailure>,
    /// Frames sent.
    pub sent: u64,
}

impl CameraState {
    /// The results of the commands with this number (`None`: unanswered).
    pub fn results_of(&self, command: u32) -> Vec<Option<u8>> {
        self.commands
            .iter()
            .filter(|c| c.command == command)
            .map(|c| c.result)
            .collect()
    }
}

/// The camera as a MAVLink component (sans-IO).
#[derive(Debug, Clone)]
pub struct CameraComponent {
    cfg: CameraConfig,
    camera: Camera,
    now: u64,
    out: VecDeque<(MavHeader, MavMessage)>,
    sequence: u8,
    /// Altitude above mean sea level of the last position (mm).
    alt_mm: i32,
    asks: u32,
    next_ask: u64,
    truth: CameraState,
}

impl CameraComponent {
    /// A camera just powered on (its time 0).
    pub fn new(cfg: CameraConfig) -> CameraComponent {
        CameraComponent {
            cfg,
            camera: Camera::default(),
            now: 0,
            out: VecDeque::new(),
            sequence: 0,
            alt_mm: 0,
            asks: 0,
            next_ask: 0,
            truth: CameraState::default(),
        }
    }

    fn t_s(&self) -> f64 {
        self.now as f64 / 1e6
    }

    /// A message heard on the link at `now` (µs since power-on).
    pub fn handle(&mut self, now: u64, header: &MavHeader, msg: &MavMessage) {
        self.advance(now);
        let from = (header.system_id as u8, header.component_id);
        if from == (self.cfg.system, self.cfg.component) {
            return;
        }
        let autopilot = (self.cfg.system, self.cfg.autopilot);
        match msg {
            MavMessage::HEARTBEAT(h)
                if from == autopilot && h.autopilot != MavAutopilot::MAV_AUTOPILOT_INVALID =>
            {
                self.truth.autopilot_heard = true;
            }
            MavMessage::GLOBAL_POSITION_INT(p) if from == autopilot => {
                self.alt_mm = p.alt;
                self.truth.autopilot_offset_s = Some(p.time_boot_ms as f64 / 1e3 - self.t_s());
                self.truth.position = Some(Fix {
                    time_s: self.t_s(),
                    lat: p.lat as f64 / 1e7,
                    lon: p.lon as f64 / 1e7,
                    alt: p.relative_alt as f64 / 1000.0,
                });
            }
            MavMessage::COMMAND_ACK(a)
                if from == autopilot
                    && a.command == MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL
                    && a.target_component == self.cfg.component =>
            {
                self.truth.position_streamed = a.result == MavResult::MAV_RESULT_ACCEPTED;
            }
            MavMessage::COMMAND_LONG(c) => {
                let p = [
                    c.param1, c.param2, c.param3, c.param4, c.param5, c.param6, c.param7,
                ];
                self.command(from, c.target_system, c.target_component, c.command, p);
            }
            MavMessage::COMMAND_INT(c) => {
                let p = [
                    c.param1, c.param2, c.param3, c.param4, c.x as f32, c.y as f32, c.z,
                ];
                self.command(from, c.target_system, c.target_component, c.command, p);
            }
            _ => {}
        }
        self.ask_position();
    }

    fn command(&mut self, from: (u8, u8), system: u8, component: u8, command: MavCmd, p: [f32; 7]) {
        let number = command as u32;
        let ours = component == self.cfg.component
            || (component == 0 && Camera::is_camera_command(number));
        if !(system == self.cfg.system || system == 0) || !ours {
            return;
        }
        let result = self.camera.command(self.now, number, p);
        self.truth.commands.push(CameraCommand {
            time_s: self.t_s(),
            command: number,
            params: p,
            from,
            target_component: component,
            result: result.map(|r| r as u8),
        });
        let Some(result) = result else {
            return;
        };
        tracing::debug!(t = self.t_s(), number, ?result, "camera command");
        self.send(MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
            command,
            result,
            progress: 0,
            result_param2: 0,
            target_system: from.0,
            target_component: from.1,
        }));
        if result == MavResult::MAV_RESULT_ACCEPTED {
            let action = match number {
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
        // What is due at once (an image, the message asked for) follows the ack.
        self.tick();
    }

    /// Runs the camera to `now` (µs since power-on; never backwards).
    pub fn advance(&mut self, now: u64) {
        self.now = self.now.max(now);
        self.truth.time_s = self.t_s();
        self.tick();
        self.ask_position();
    }

    fn tick(&mut self) {
        if self.camera.next_deadline() > self.now {
            return;
        }
        for o in self.camera.tick(self.now) {
            let at = self.fix();
            if let Output::Image { index } = o {
                self.truth.images = self.camera.images();
                self.truth.camera.push(CameraEvent {
                    at,
                    action: CameraAction::Image { index },
                });
            }
            let context = Context {
                time_boot_ms: (self.now / 1000) as u32,
                time_utc_us: self.cfg.unix_boot_us.saturating_add(self.now),
                lat: (at.lat * 1e7) as i32,
                lon: (at.lon * 1e7) as i32,
                alt_mm: self.alt_mm,
                relative_alt_mm: (at.alt * 1000.0) as i32,
            };
            let msg = self.camera.message(o, &context);
            self.send(msg);
        }
    }

    /// SET_MESSAGE_INTERVAL for GLOBAL_POSITION_INT to the autopilot, again
    /// every second until acknowledged (at most 10 times).
    fn ask_position(&mut self) {
        let hz = self.cfg.position_hz;
        let wanted = hz.is_finite() && hz > 0.0 && self.truth.autopilot_heard;
        if !wanted
            || self.truth.position_streamed
            || self.truth.failure == Some(PayloadFailure::Silent)
            || self.asks >= ASK_AT_MOST
            || self.now < self.next_ask
        {
            return;
        }
        self.asks += 1;
        self.next_ask = self.now + ASK_AGAIN_US;
        self.send(MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: GLOBAL_POSITION_INT as f32,
            param2: (1e6 / hz).round(),
            param3: 0.0,
            param4: 0.0,
            param5: 0.0,
            param6: 0.0,
            param7: 0.0,
            command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            target_system: self.cfg.system,
            target_component: self.cfg.autopilot,
            confirmation: 0,
        }));
    }

    /// Where the camera is now (the last position heard; zeros before any).
    fn fix(&self) -> Fix {
        let mut at = self.truth.position.unwrap_or_default();
        at.time_s = self.t_s();
        at
    }

    fn send(&mut self, msg: MavMessage) {
        let header = MavHeader {
            system_id: self.cfg.system as u32,
            component_id: self.cfg.component,
            sequence: self.sequence,
        };
        self.sequence = self.sequence.wrapping_add(1);
        self.truth.sent += 1;
        self.out.push_back((header, msg));
    }

    /// The next frame to send.
    pub fn poll_transmit(&mut self) -> Option<(MavHeader, MavMessage)> {
        self.out.pop_front()
    }

    /// The next time `advance` has something to do (µs).
    pub fn next_deadline(&self) -> u64 {
        let mut t = self.camera.next_deadline();
        if self.truth.autopilot_heard && !self.truth.position_streamed && self.asks < ASK_AT_MOST {
            t = t.min(self.next_ask);
        }
        t.max(self.now)
    }

    /// A payload failure starts (`None`: it ends).
    pub fn inject(&mut self, failure: Option<PayloadFailure>) {
        self.camera.set_failure(failure);
        self.truth.failure = failure;
    }

    /// A snapshot of what it did and heard.
    pub fn state(&self) -> CameraState {
        self.truth.clone()
    }

    /// µs since power-on.
    pub fn now_us(&self) -> u64 {
        self.now
    }

    /// Its configuration.
    pub fn config(&self) -> &CameraConfig {
        &self.cfg
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GATEWAY: (u8, u8) = (1, 191);

    fn header(from: (u8, u8)) -> MavHeader {
        MavHeader {
            system_id: from.0 as u32,
            component_id: from.1,
            sequence: 0,
        }
    }

    fn command(c: &mut CameraComponent, now: u64, command: MavCmd, p: [f32; 7]) {
        let msg = crate::wire::command_long((1, 100), command, p);
        c.handle(now, &header(GATEWAY), &msg);
    }

    fn drain(c: &mut CameraComponent) -> Vec<(MavHeader, MavMessage)> {
        std::iter::from_fn(|| c.poll_transmit()).collect()
    }

    fn autopilot_heartbeat() -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: MavType::MAV_TYPE_FIXED_WING,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: MavModeFlag::empty(),
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        })
    }

    /// The same answers as the camera inside the simulated vehicle, from
    /// its own component; images where the autopilot said it is.
    #[test]
    fn answers_from_its_component_and_takes_images_where_the_vehicle_is() {
        let mut c = CameraComponent::new(CameraConfig::default());
        c.advance(2_600_000);
        let beats = drain(&mut c);
        assert_eq!(beats.len(), 3); // 0.5, 1.5, 2.5 s
        assert!(beats.iter().all(|(h, m)| h.system_id == 1
            && h.component_id == 100
            && matches!(m, MavMessage::HEARTBEAT(x) if x.mavtype == MavType::MAV_TYPE_CAMERA
                && x.system_status == MavState::MAV_STATE_ACTIVE)));
        // The autopilot heard: GLOBAL_POSITION_INT asked of it, again until acked.
        c.handle(2_700_000, &header((1, 1)), &autopilot_heartbeat());
        let asked = drain(&mut c);
        assert!(matches!(&asked[..], [(_, MavMessage::COMMAND_LONG(l))]
            if l.command == MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL && l.param1 == 33.0
                && l.param2 == 500_000.0 && l.target_component == 1));
        c.advance(3_800_000);
        assert_eq!(
            drain(&mut c)
                .iter()
                .filter(|(_, m)| matches!(m, MavMessage::COMMAND_LONG(_)))
                .count(),
            1
        );
        c.handle(
            3_900_000,
            &header((1, 1)),
            &MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                result: MavResult::MAV_RESULT_ACCEPTED,
                progress: 0,
                result_param2: 0,
                target_system: 1,
                target_component: 100,
            }),
        );
        assert!(c.state().position_streamed);
        assert_eq!(c.state().autopilot_offset_s, None);
        c.handle(
            4_000_000,
            &header((1, 1)),
            &MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                time_boot_ms: 30_000,
                lat: -353_632_610,
                lon: 1_491_652_300,
                alt: 664_000,
                relative_alt: 80_000,
                ..Default::default()
            }),
        );
        drain(&mut c);
        command(
            &mut c,
            4_000_000,
            MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
            [0.0, 2.0, 3.0, 0.0, 0.0, 0.0, 0.0],
        );
        let out = drain(&mut c);
        // The ack first, to the sender, from component 100; then the first image.
        assert!(
            matches!(&out[0], (h, MavMessage::COMMAND_ACK(a)) if h.component_id == 100
            && a.command == MavCmd::MAV_CMD_IMAGE_START_CAPTURE
            && a.result == MavResult::MAV_RESULT_ACCEPTED
            && (a.target_system, a.target_component) == GATEWAY)
        );
        assert!(matches!(&out[1], (_, MavMessage::CAMERA_IMAGE_CAPTURED(i))
            if i.image_index == 0 && i.lat == -353_632_610 && i.alt == 664_000 && i.relative_alt == 80_000));
        c.advance(9_000_000);
        let s = c.state();
        assert_eq!(s.images, 3, "three images asked, at 4, 6, 8 s");
        // The autopilot's clock: 30 s when the camera's said 4 s.
        assert_eq!(s.autopilot_offset_s, Some(26.0));
        assert_eq!(s.results_of(2000), vec![Some(0)]);
        assert!(matches!(
            s.camera[0].action,
            CameraAction::Start { total: 3, .. }
        ));
        assert!((s.camera[0].at.alt - 80.0).abs() < 1e-9);
        // CAMERA_INFORMATION and CAMERA_CAPTURE_STATUS on request.
        drain(&mut c);
        command(
            &mut c,
            9_000_000,
            MavCmd::MAV_CMD_REQUEST_MESSAGE,
            [259.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        command(
            &mut c,
            9_000_000,
            MavCmd::MAV_CMD_REQUEST_MESSAGE,
            [262.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        let names: Vec<&str> = drain(&mut c)
            .iter()
            .map(|(_, m)| mavlink::Message::message_name(m))
            .collect();
        assert_eq!(
            names,
            vec![
                "COMMAND_ACK",
                "CAMERA_INFORMATION",
                "COMMAND_ACK",
                "CAMERA_CAPTURE_STATUS"
            ]
        );
        // Commands for the autopilot are not the camera's.
        let msg = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            target_system: 1,
            target_component: 1,
            ..Default::default()
        });
        c.handle(9_100_000, &header(GATEWAY), &msg);
        assert!(drain(&mut c).is_empty());
    }

    #[test]
    fn a_silent_camera_says_nothing_a_critical_one_says_so() {
        let mut c = CameraComponent::new(CameraConfig::default());
        c.inject(Some(PayloadFailure::Silent));
        c.advance(3_000_000);
        command(
            &mut c,
            3_000_000,
            MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
            [0.0; 7],
        );
        assert!(drain(&mut c).is_empty());
        assert_eq!(c.state().results_of(2000), vec![None]);
        c.inject(Some(PayloadFailure::Critical));
        c.advance(4_000_000);
        assert!(matches!(&drain(&mut c)[..], [(_, MavMessage::HEARTBEAT(h))]
            if h.system_status == MavState::MAV_STATE_CRITICAL));
        c.inject(None);
        command(&mut c, 4_000_000, MavCmd::MAV_CMD_DO_SET_MODE, [0.0; 7]);
        assert!(
            matches!(&drain(&mut c)[..], [(_, MavMessage::COMMAND_ACK(a))]
            if a.result == MavResult::MAV_RESULT_UNSUPPORTED)
        );
    }
}
