//! Readiness to fly: the start-up sequence as it unfolds, the pre-arm
//! checks (with ArduPilot's wording: "PreArm: …" every 30 s while they
//! fail, "Arm: …" when an arming is refused), arming and disarming.

use mavlink::dialects::ardupilotmega::{MavResult, MavSeverity};

use crate::boot::{texts, Phase};
use crate::faults::FaultKind;
use crate::flight::Stage;
use crate::mission::MissionItem;
use crate::modes;
use crate::vehicle::Vehicle;

/// COMPONENT_ARM_DISARM param2 that skips the checks.
pub const FORCE: f32 = 21196.0;

impl Vehicle {
    /// Reaches the start-up phases due by now.
    pub(crate) fn boot_tick(&mut self) {
        let t = self.t_s();
        let due: Vec<Phase> = self
            .cfg
            .boot
            .phases()
            .into_iter()
            .filter(|(at, p)| *at <= t && !self.boot.has(*p))
            .map(|(_, p)| p)
            .collect();
        for phase in due {
            self.boot.reached.push(phase);
            tracing::debug!(t, ?phase, "boot");
            match phase {
                Phase::Ready => {
                    self.enter_mode(modes::MANUAL);
                    self.send_param("BARO1_GND_PRESS");
                }
                Phase::Home => {
                    self.home_set = true;
                    self.home_pos = self.ac.pos;
                    if self.mission.is_empty() {
                        let h = self.home_item();
                        self.mission.push(h);
                        self.params.set("MIS_TOTAL", 1.0);
                        self.send_param("MIS_TOTAL");
                    }
                    self.send_home();
                }
                // Home refined once the EKF uses the GPS (with its origin).
                Phase::EkfGps => self.send_home(),
                _ => {}
            }
            let elevation = self.origin().alt_amsl;
            for (sev, text) in texts(phase, elevation) {
                let sev = if sev == 4 {
                    MavSeverity::MAV_SEVERITY_WARNING
                } else {
                    MavSeverity::MAV_SEVERITY_INFO
                };
                self.text(sev, text);
            }
        }
        if !self.ready() && self.cfg.boot_servo_burst {
            self.send_servo_output(true);
        }
    }

    /// Item 0 of the mission: home.
    pub(crate) fn home_item(&self) -> MissionItem {
        let (lat, lon) = crate::geo::location(self.origin(), self.home_pos);
        MissionItem::home(lat, lon, self.origin().alt_amsl)
    }

    /// The EKF uses the GPS (flags healthy), the GPS has its fix.
    pub(crate) fn gps_ok(&self) -> bool {
        self.boot.has(Phase::Gps) && !self.has_fault(FaultKind::GpsLoss)
    }

    /// The first pre-arm check that fails, in ArduPilot's words (without
    /// the "PreArm: " / "Arm: " prefix).
    pub(crate) fn prearm_failure(&self) -> Option<String> {
        if !self.ready() {
            return Some("System not initialised".to_owned());
        }
        if self.cfg.first_arm_refused && !self.boot.has(Phase::GyrosSettled) {
            return Some("Gyros inconsistent".to_owned());
        }
        if !self.boot.has(Phase::EkfGps) {
            return Some("AHRS: EKF3 still initialising".to_owned());
        }
        if !self.gps_ok() || !self.home_set {
            return Some("Bad GPS Position".to_owned());
        }
        None
    }

    /// Every 30 s while disarmed and failing: "PreArm: <reason>".
    pub(crate) fn prearm_report(&mut self) {
        if self.fl.armed || !self.ready() {
            return;
        }
        if let Some(reason) = self.prearm_failure() {
            self.text(
                MavSeverity::MAV_SEVERITY_CRITICAL,
                format!("PreArm: {reason}"),
            );
        }
    }

    /// COMPONENT_ARM_DISARM with param1 = 1.
    pub(crate) fn arm(&mut self, force: bool) -> MavResult {
        if self.fl.armed {
            return MavResult::MAV_RESULT_ACCEPTED;
        }
        if !self.ready() {
            return MavResult::MAV_RESULT_FAILED;
        }
        if !force {
            if let Some(reason) = self.prearm_failure() {
                self.text(MavSeverity::MAV_SEVERITY_CRITICAL, format!("Arm: {reason}"));
                return MavResult::MAV_RESULT_FAILED;
            }
        }
        self.fl.armed = true;
        self.fl.armed_at = Some(self.now);
        self.fl.crashed = false;
        self.fl.crash_at = None;
        if self.fl.stage == Stage::Stopped {
            self.fl.stage = Stage::Ground;
        }
        // ArduPlane sets home where it arms.
        if self.ac.on_ground {
            self.home_pos = self.ac.pos;
            self.refresh_home_item();
        }
        self.send_home();
        self.info("Throttle armed");
        tracing::info!(t = self.t_s(), "armed");
        MavResult::MAV_RESULT_ACCEPTED
    }

    /// COMPONENT_ARM_DISARM with param1 = 0: refused in flight unless forced.
    pub(crate) fn disarm_command(&mut self, force: bool) -> MavResult {
        if !self.fl.armed {
            return MavResult::MAV_RESULT_ACCEPTED;
        }
        if !force && self.is_flying() {
            return MavResult::MAV_RESULT_FAILED;
        }
        self.disarm(false);
        MavResult::MAV_RESULT_ACCEPTED
    }

    /// Disarms (`auto`: the automatic disarm after landing).
    pub(crate) fn disarm(&mut self, auto: bool) {
        self.fl.armed = false;
        self.fl.armed_at = None;
        self.info("Throttle disarmed");
        if auto {
            self.info("Auto disarmed");
        }
        match self.fl.stage {
            Stage::TakeoffWait { .. } | Stage::TakeoffRoll => {
                self.fl.stage = Stage::Ground;
                self.fl.takeoff = None;
            }
            _ => {}
        }
        // Home follows the vehicle while disarmed on the ground.
        if self.ac.on_ground {
            self.home_pos = self.ac.pos;
            self.refresh_home_item();
            self.send_param("BARO1_GND_PRESS");
            self.later_home(0.2);
        }
        tracing::info!(t = self.t_s(), auto, "disarmed");
    }

    fn refresh_home_item(&mut self) {
        if !self.mission.is_empty() {
            self.mission[0] = self.home_item();
        }
    }

    /// HOME_POSITION (and GPS_GLOBAL_ORIGIN) a little later.
    fn later_home(&mut self, delay_s: f64) {
        self.home_due = Some(self.now + (delay_s * 1e6) as u64);
    }
}
