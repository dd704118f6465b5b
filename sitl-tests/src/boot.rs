//! The start-up sequence: when the sensors, the GPS, home and the EKF become
//! ready, and the STATUSTEXTs ArduPlane SITL says on the way (times from
//! the recording, in seconds since boot).

/// When each part of the autopilot becomes ready (sim seconds since boot).
#[derive(Debug, Clone, PartialEq)]
pub struct BootTimeline {
    /// INITIALISING ends: MANUAL, "ArduPilot Ready", streams start.
    pub ready: f64,
    /// EKF_STATUS_REPORT starts (flags UNINITIALIZED).
    pub ekf_start: f64,
    /// "Airspeed 1 calibrated".
    pub airspeed_calibrated: f64,
    /// ESC telemetry starts.
    pub esc: f64,
    /// The GPS is detected and has a fix.
    pub gps: f64,
    /// Home is set (HOME_POSITION).
    pub home: f64,
    /// The EKF is initialised (LOCAL_POSITION_NED, AHRS2 start).
    pub ekf_init: f64,
    /// Tilt and yaw aligned: EKF flags 0xa7 (CONST_POS_MODE).
    pub ekf_aligned: f64,
    /// EKF origin set.
    pub origin: f64,
    /// The EKF uses the GPS: flags 0x33f, "AHRS: EKF3 active".
    pub ekf_gps: f64,
    /// The gyros are consistent: until then an arming attempt is refused
    /// with "Arm: Gyros inconsistent" (when `SimConfig::first_arm_refused`).
    pub gyros_settled: f64,
}

impl Default for BootTimeline {
    /// ArduPlane SITL 4.7 as recorded (tlog time + 0.2 s: the recording
    /// starts 0.2 s after boot).
    fn default() -> Self {
        BootTimeline {
            ready: 1.74,
            ekf_start: 2.8,
            airspeed_calibrated: 3.42,
            esc: 6.05,
            gps: 9.3,
            home: 10.12,
            ekf_init: 10.28,
            ekf_aligned: 12.3,
            origin: 19.48,
            ekf_gps: 20.5,
            gyros_settled: 22.8,
        }
    }
}

impl BootTimeline {
    /// The same sequence compressed into 3 s, for tests that do not study
    /// the start-up.
    pub fn quick() -> BootTimeline {
        BootTimeline {
            ready: 0.3,
            ekf_start: 0.4,
            airspeed_calibrated: 0.5,
            esc: 0.6,
            gps: 1.0,
            home: 1.2,
            ekf_init: 1.3,
            ekf_aligned: 1.5,
            origin: 2.0,
            ekf_gps: 2.2,
            gyros_settled: 3.0,
        }
    }
}

/// A step of the start-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Phase {
    Ready,
    EkfStart,
    AirspeedCalibrated,
    Esc,
    Gps,
    Home,
    EkfInit,
    EkfAligned,
    Origin,
    EkfGps,
    GyrosSettled,
}

impl BootTimeline {
    /// Every phase with its time, in time order.
    pub fn phases(&self) -> Vec<(f64, Phase)> {
        let mut v = vec![
            (self.ready, Phase::Ready),
            (self.ekf_start, Phase::EkfStart),
            (self.airspeed_calibrated, Phase::AirspeedCalibrated),
            (self.esc, Phase::Esc),
            (self.gps, Phase::Gps),
            (self.home, Phase::Home),
            (self.ekf_init, Phase::EkfInit),
            (self.ekf_aligned, Phase::EkfAligned),
            (self.origin, Phase::Origin),
            (self.ekf_gps, Phase::EkfGps),
            (self.gyros_settled, Phase::GyrosSettled),
        ];
        v.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        v
    }
}

/// The texts of a phase: (severity, text). Severity 6 INFO, 4 WARNING.
pub fn texts(phase: Phase, field_elevation: f64) -> Vec<(u8, String)> {
    let info = |s: &str| (6u8, s.to_owned());
    match phase {
        Phase::Ready => vec![
            info("Barometer 1 calibration complete"),
            info("Barometer 2 calibration complete"),
            info("Airspeed 1 calibration started"),
            info("ArduPilot Ready"),
            info("AHRS: DCM active"),
            (4, "Throttle failsafe off".to_owned()),
        ],
        Phase::AirspeedCalibrated => vec![info("Airspeed 1 calibrated")],
        Phase::Gps => vec![
            info("GPS 1: probing for u-blox at 230400 baud"),
            info("GPS 1: detected u-blox"),
            info("EKF2 IMU0 MAG0 initial yaw alignment complete"),
            info("EKF2 IMU1 MAG0 initial yaw alignment complete"),
        ],
        Phase::EkfInit => vec![info("EKF3 IMU0 initialised"), info("EKF3 IMU1 initialised")],
        Phase::EkfAligned => vec![
            info("EKF3 IMU0 tilt alignment complete"),
            info("EKF3 IMU1 tilt alignment complete"),
            info("EKF3 IMU0 MAG0 initial yaw alignment complete"),
            info("EKF3 IMU1 MAG0 initial yaw alignment complete"),
            info("EKF2 IMU0 tilt alignment complete"),
            info("EKF2 IMU1 tilt alignment complete"),
        ],
        Phase::Origin => vec![
            info("EKF2 IMU0 origin set"),
            info("EKF2 IMU1 origin set"),
            info("EKF3 IMU0 origin set"),
            info("EKF3 IMU1 origin set"),
            (6, format!("Field Elevation Set: {:.0}m", field_elevation)),
        ],
        Phase::EkfGps => vec![
            info("EKF3 IMU0 is using GPS"),
            info("EKF3 IMU1 is using GPS"),
            info("AHRS: EKF3 active"),
        ],
        Phase::EkfStart | Phase::Esc | Phase::Home | Phase::GyrosSettled => vec![],
    }
}

/// How far the start-up has gone.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BootState {
    /// Phases reached so far (in order).
    pub reached: Vec<Phase>,
}

impl BootState {
    pub fn has(&self, phase: Phase) -> bool {
        self.reached.contains(&phase)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phases_are_in_time_order() {
        for tl in [BootTimeline::default(), BootTimeline::quick()] {
            let p = tl.phases();
            assert_eq!(p.len(), 11);
            assert!(p.windows(2).all(|w| w[0].0 <= w[1].0));
            assert_eq!(p[0].1, Phase::Ready);
        }
        let t = texts(Phase::Origin, 584.0);
        assert_eq!(t[4].1, "Field Elevation Set: 584m");
    }
}
