//! The payload camera: a MAVLink camera component (MAV_COMP_ID_CAMERA,
//! 100) with its own 1 Hz HEARTBEAT (MAV_TYPE_CAMERA), answering
//! MAV_CMD_IMAGE_START_CAPTURE / IMAGE_STOP_CAPTURE with a COMMAND_ACK from
//! component 100, taking images at the asked interval, and sending
//! CAMERA_INFORMATION / CAMERA_CAPTURE_STATUS when asked (MAV_CMD_REQUEST_MESSAGE
//! or the older REQUEST_CAMERA_INFORMATION / REQUEST_CAMERA_CAPTURE_STATUS).
//! Sans-IO: its outputs become messages through [`Camera::message`], the
//! same for the camera inside the simulated vehicle and for the camera on
//! its own ([`crate::CameraComponent`]).

use mavlink::dialects::ardupilotmega::*;

use crate::faults::PayloadFailure;
use crate::mission::cmd;

/// MAV_COMP_ID_CAMERA.
pub const COMPONENT: u8 = 100;

/// MAV_CMD_REQUEST_CAMERA_INFORMATION (superseded by REQUEST_MESSAGE).
pub const REQUEST_CAMERA_INFORMATION: u32 = 521;
/// MAV_CMD_REQUEST_CAMERA_CAPTURE_STATUS (superseded by REQUEST_MESSAGE).
pub const REQUEST_CAMERA_CAPTURE_STATUS: u32 = 527;
/// CAMERA_INFORMATION's message id.
pub const CAMERA_INFORMATION_ID: u32 = 259;
/// CAMERA_CAPTURE_STATUS's message id.
pub const CAMERA_CAPTURE_STATUS_ID: u32 = 262;
/// The free space it reports (MiB).
const CAPACITY_MIB: f32 = 32_768.0;

/// What the camera does at a given time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Output {
    /// Its HEARTBEAT; `critical` when failing with MAV_STATE_CRITICAL.
    Heartbeat { critical: bool },
    /// An image was taken (CAMERA_IMAGE_CAPTURED).
    Image { index: i32 },
    /// CAMERA_INFORMATION, as asked.
    Information,
    /// CAMERA_CAPTURE_STATUS, as asked.
    CaptureStatus,
}

/// Where and when, for the messages that carry it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Context {
    pub time_boot_ms: u32,
    /// µs since the Unix epoch.
    pub time_utc_us: u64,
    /// Degrees × 1e7.
    pub lat: i32,
    pub lon: i32,
    /// mm above mean sea level.
    pub alt_mm: i32,
    /// mm above home.
    pub relative_alt_mm: i32,
}

#[derive(Debug, Clone, PartialEq)]
struct Capture {
    interval_us: u64,
    /// Images still to take; `None`: until stopped.
    remaining: Option<u32>,
    next: u64,
}

/// The camera's state.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    failure: Option<PayloadFailure>,
    next_heartbeat: u64,
    capture: Option<Capture>,
    images: i32,
    /// Messages asked for, sent at the next tick (after the ack).
    asked: Vec<Output>,
}

impl Default for Camera {
    fn default() -> Self {
        Camera {
            failure: None,
            // Cameras boot faster than autopilots.
            next_heartbeat: 500_000,
            capture: None,
            images: 0,
            asked: Vec::new(),
        }
    }
}

impl Camera {
    /// A command addressed to the camera. `None`: no answer (a silent
    /// camera answers nothing).
    pub fn command(&mut self, now: u64, command: u32, params: [f32; 7]) -> Option<MavResult> {
        if self.failure == Some(PayloadFailure::Silent) {
            return None;
        }
        Some(match command {
            cmd::IMAGE_START_CAPTURE => {
                let interval = params[1];
                let total = params[2];
                if !interval.is_finite() || !total.is_finite() || interval < 0.0 || total < 0.0 {
                    return Some(MavResult::MAV_RESULT_DENIED);
                }
                let single = total as u32 == 1 || interval <= 0.0;
                self.capture = Some(Capture {
                    interval_us: (interval.max(0.1) as f64 * 1e6) as u64,
                    remaining: if single {
                        Some(1)
                    } else if total as u32 == 0 {
                        None
                    } else {
                        Some(total as u32)
                    },
                    next: now,
                });
                MavResult::MAV_RESULT_ACCEPTED
            }
            cmd::IMAGE_STOP_CAPTURE => {
                self.capture = None;
                MavResult::MAV_RESULT_ACCEPTED
            }
            cmd::REQUEST_MESSAGE => match params[0] as u32 {
                CAMERA_INFORMATION_ID if params[0].fract() == 0.0 => {
                    self.asked.push(Output::Information);
                    MavResult::MAV_RESULT_ACCEPTED
                }
                CAMERA_CAPTURE_STATUS_ID if params[0].fract() == 0.0 => {
                    self.asked.push(Output::CaptureStatus);
                    MavResult::MAV_RESULT_ACCEPTED
                }
                _ => MavResult::MAV_RESULT_DENIED,
            },
            REQUEST_CAMERA_INFORMATION => {
                self.asked.push(Output::Information);
                MavResult::MAV_RESULT_ACCEPTED
            }
            REQUEST_CAMERA_CAPTURE_STATUS => {
                self.asked.push(Output::CaptureStatus);
                MavResult::MAV_RESULT_ACCEPTED
            }
            _ => MavResult::MAV_RESULT_UNSUPPORTED,
        })
    }

    /// Whether a command is one a camera answers when addressed to every
    /// component (target component 0).
    pub fn is_camera_command(command: u32) -> bool {
        matches!(
            command,
            cmd::IMAGE_START_CAPTURE
                | cmd::IMAGE_STOP_CAPTURE
                | REQUEST_CAMERA_INFORMATION
                | REQUEST_CAMERA_CAPTURE_STATUS
        )
    }

    /// The message of an output.
    pub fn message(&self, o: Output, at: &Context) -> MavMessage {
        match o {
            Output::Heartbeat { critical } => MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                custom_mode: 0,
                mavtype: MavType::MAV_TYPE_CAMERA,
                autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
                base_mode: MavModeFlag::empty(),
                system_status: if critical {
                    MavState::MAV_STATE_CRITICAL
                } else {
                    MavState::MAV_STATE_ACTIVE
                },
                mavlink_version: 3,
            }),
            Output::Image { index } => {
                MavMessage::CAMERA_IMAGE_CAPTURED(CAMERA_IMAGE_CAPTURED_DATA {
                    time_utc: at.time_utc_us,
                    time_boot_ms: at.time_boot_ms,
                    lat: at.lat,
                    lon: at.lon,
                    alt: at.alt_mm,
                    relative_alt: at.relative_alt_mm,
                    q: [1.0, 0.0, 0.0, 0.0],
                    image_index: index,
                    camera_id: 1,
                    capture_result: MavBool::MAV_BOOL_TRUE,
                    file_url: format!("img{index:05}.jpg").as_str().into(),
                })
            }
            Output::Information => {
                let mut vendor = [0u8; 32];
                vendor[..6].copy_from_slice(b"Petrel");
                let mut model = [0u8; 32];
                model[..9].copy_from_slice(b"SimCamera");
                MavMessage::CAMERA_INFORMATION(CAMERA_INFORMATION_DATA {
                    time_boot_ms: at.time_boot_ms,
                    firmware_version: 1,
                    focal_length: 16.0,
                    sensor_size_h: 23.5,
                    sensor_size_v: 15.6,
                    flags: CameraCapFlags::CAMERA_CAP_FLAGS_CAPTURE_IMAGE,
                    resolution_h: 6000,
                    resolution_v: 4000,
                    cam_definition_version: 0,
                    vendor_name: vendor,
                    model_name: model,
                    lens_id: 0,
                    cam_definition_uri: "".into(),
                    gimbal_device_id: 0,
                    camera_device_id: 0,
                })
            }
            Output::CaptureStatus => {
                let (image_status, image_interval) = match &self.capture {
                    Some(c) if c.remaining != Some(1) => (3, c.interval_us as f32 / 1e6),
                    Some(_) => (1, 0.0),
                    None => (0, 0.0),
                };
                MavMessage::CAMERA_CAPTURE_STATUS(CAMERA_CAPTURE_STATUS_DATA {
                    time_boot_ms: at.time_boot_ms,
                    image_interval,
                    recording_time_ms: 0,
                    available_capacity: CAPACITY_MIB,
                    image_status,
                    video_status: 0,
                    image_count: self.images,
                    camera_device_id: 0,
                })
            }
        }
    }

    /// Whether it is capturing images.
    pub fn capturing(&self) -> bool {
        self.capture.is_some()
    }

    /// Images taken so far.
    pub fn images(&self) -> i32 {
        self.images
    }

    /// A failure starts (or, with `None`, ends).
    pub fn set_failure(&mut self, failure: Option<PayloadFailure>) {
        self.failure = failure;
        if failure == Some(PayloadFailure::Silent) {
            self.capture = None;
            self.asked.clear();
        }
    }

    /// What is due by `now`.
    pub fn tick(&mut self, now: u64) -> Vec<Output> {
        let mut out = Vec::new();
        while self.next_heartbeat <= now {
            self.next_heartbeat += 1_000_000;
            match self.failure {
                Some(PayloadFailure::Silent) => {}
                Some(PayloadFailure::Critical) => out.push(Output::Heartbeat { critical: true }),
                None => out.push(Output::Heartbeat { critical: false }),
            }
        }
        out.append(&mut self.asked);
        while let Some(c) = self.capture.as_mut() {
            if c.next > now {
                break;
            }
            self.images = self.images.saturating_add(1);
            out.push(Output::Image {
                index: self.images - 1,
            });
            // An interval of 1e36 s saturates: the next image never comes.
            c.next = c.next.saturating_add(c.interval_us);
            if let Some(r) = c.remaining.as_mut() {
                *r -= 1;
                if *r == 0 {
                    self.capture = None;
                }
            }
        }
        out
    }

    /// The next time `tick` has something to do.
    pub fn next_deadline(&self) -> u64 {
        if !self.asked.is_empty() {
            return 0;
        }
        match &self.capture {
            Some(c) => c.next.min(self.next_heartbeat),
            None => self.next_heartbeat,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Found by `hostile_input_never_stops_the_vehicle`: an interval of
    /// 5.26e36 s overflowed the next image's time.
    #[test]
    fn a_huge_interval_takes_one_image_then_waits_for_ever() {
        let mut c = Camera::default();
        let huge = [
            f32::NAN,
            5.260_086_4e36,
            0.0,
            f32::NAN,
            f32::NAN,
            f32::NAN,
            f32::NAN,
        ];
        assert_eq!(
            c.command(1_000_000, cmd::IMAGE_START_CAPTURE, huge),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let images = |o: Vec<Output>| {
            o.iter()
                .filter(|x| matches!(x, Output::Image { .. }))
                .count()
        };
        assert_eq!(images(c.tick(1_000_000)), 1);
        assert_eq!(images(c.tick(3_600_000_000)), 0); // an hour later
        assert!(c.capturing());
    }

    #[test]
    fn heartbeat_every_second_and_images_at_the_interval() {
        let mut c = Camera::default();
        let hb = |o: &[Output]| {
            o.iter()
                .filter(|x| matches!(x, Output::Heartbeat { .. }))
                .count()
        };
        assert_eq!(hb(&c.tick(2_600_000)), 3);
        assert_eq!(
            c.command(
                3_000_000,
                cmd::IMAGE_START_CAPTURE,
                [0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0]
            ),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let out = c.tick(9_000_000);
        let images: Vec<_> = out
            .iter()
            .filter_map(|o| match o {
                Output::Image { index } => Some(*index),
                _ => None,
            })
            .collect();
        assert_eq!(images, vec![0, 1, 2, 3]); // at 3, 5, 7, 9 s
        assert_eq!(
            c.command(9_500_000, cmd::IMAGE_STOP_CAPTURE, [0.0; 7]),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        assert!(!c.capturing());
        assert_eq!(
            c.command(0, 12345, [0.0; 7]),
            Some(MavResult::MAV_RESULT_UNSUPPORTED)
        );
    }

    #[test]
    fn a_silent_camera_says_nothing_a_critical_one_says_so() {
        let mut c = Camera::default();
        c.set_failure(Some(PayloadFailure::Silent));
        assert!(c.tick(5_000_000).is_empty());
        assert_eq!(c.command(0, cmd::IMAGE_START_CAPTURE, [0.0; 7]), None);
        c.set_failure(Some(PayloadFailure::Critical));
        assert_eq!(
            c.tick(6_000_000),
            vec![Output::Heartbeat { critical: true }]
        );
        c.set_failure(None);
        assert_eq!(
            c.tick(7_000_000),
            vec![Output::Heartbeat { critical: false }]
        );
    }

    #[test]
    fn a_single_image_then_stops() {
        let mut c = Camera::default();
        c.command(
            0,
            cmd::IMAGE_START_CAPTURE,
            [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
        );
        let out = c.tick(100);
        assert!(out.contains(&Output::Image { index: 0 }));
        assert!(!c.capturing());
        assert_eq!(c.images(), 1);
    }
}
