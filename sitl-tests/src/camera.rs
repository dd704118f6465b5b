//! The payload camera: a MAVLink camera component (MAV_COMP_ID_CAMERA,
//! 100) with its own 1 Hz HEARTBEAT (MAV_TYPE_CAMERA), answering
//! MAV_CMD_IMAGE_START_CAPTURE / IMAGE_STOP_CAPTURE with a COMMAND_ACK from
//! component 100, taking images at the asked interval. Sans-IO: the vehicle
//! turns its outputs into messages and records the captures.

use mavlink::dialects::ardupilotmega::MavResult;

use crate::faults::PayloadFailure;
use crate::mission::cmd;

/// MAV_COMP_ID_CAMERA.
pub const COMPONENT: u8 = 100;

/// What the camera does at a given time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Output {
    /// Its HEARTBEAT; `critical` when failing with MAV_STATE_CRITICAL.
    Heartbeat { critical: bool },
    /// An image was taken (CAMERA_IMAGE_CAPTURED).
    Image { index: i32 },
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
}

impl Default for Camera {
    fn default() -> Self {
        Camera {
            failure: None,
            // Cameras boot faster than autopilots.
            next_heartbeat: 500_000,
            capture: None,
            images: 0,
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
            _ => MavResult::MAV_RESULT_UNSUPPORTED,
        })
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
