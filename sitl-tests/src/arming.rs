//! Readiness to fly: the start-up sequence as it unfolds, the pre-arm
//! checks (with ArduPilot's wording: "PreArm: …" every 30 s while they
//! fail, "Arm: …" when an arming is refused), arming and disarming.

use mavlink::dialects::ardupilotmega::{MavResult, MavSeverity};

use crate::boot::{texts, Phase};
use crate::faults::FaultKind;
use crate::mission::{cmd, MissionItem};
use crate::modes;
use crate::nav_state::Stage;
use crate::vehicle::Vehicle;

/// COMPONENT_ARM_DISARM param2 that skips the checks.
pub const FORCE: f32 = 21196.0;

impl Vehicle {
    /// Reaches the start-up phases due by now.
    pub(crate) fn boot_tick(&mut self) {
        let t = self.boot_s();
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
                // After a watchdog reset in flight ArduPlane restores its
                // mode and arming (Fault::Reboot): the flight goes on.
                Phase::Ready if self.watchdog => {
                    self.send_param("BARO1_GND_PRESS");
                }
                Phase::Ready => {
                    self.enter_mode(modes::MANUAL);
                    self.send_param("BARO1_GND_PRESS");
                }
                // Home restored from the watchdog's persistent data.
                Phase::Home if self.watchdog => self.send_home(),
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
                // A rover has no airspeed sensor.
                if self.is_rover() && text.starts_with("Airspeed") {
                    continue;
                }
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

    /// The pre-arm checks that fail, in ArduPilot's words (without the
    /// "PreArm: " / "Arm: " prefix): the first of the start-up chain
    /// (initialised, gyros, EKF, GPS), then each independent check that
    /// fails, as ArduPilot reports every failing check.
    pub(crate) fn prearm_failures(&self) -> Vec<String> {
        let mut out = Vec::new();
        if !self.ready() {
            out.push("System not initialised".to_owned());
        } else if self.cfg.first_arm_refused && !self.boot.has(Phase::GyrosSettled) {
            out.push("Gyros inconsistent".to_owned());
        } else if !self.boot.has(Phase::EkfGps) {
            out.push("AHRS: EKF3 still initialising".to_owned());
        } else if !self.gps_ok() || !self.home_set {
            out.push("Bad GPS Position".to_owned());
        }
        // AP_Arming_Plane: a landing sequence RTL would never use.
        if self.params.get("RTL_AUTOLAND") as i64 == 0
            && self
                .mission
                .iter()
                .any(|it| it.command == cmd::DO_LAND_START)
        {
            out.push("DO_LAND_START set and RTL_AUTOLAND disabled".to_owned());
        }
        out
    }

    /// A failing check said as ArduPilot's check_failed says it: CRITICAL,
    /// cut to the 50 characters of one STATUSTEXT ("PreArm: DO_LAND_START
    /// set and RTL_AUTOLAND disable").
    fn check_failed(&mut self, prefix: &str, reason: &str) {
        let text: String = format!("{prefix}: {reason}").chars().take(50).collect();
        self.text(MavSeverity::MAV_SEVERITY_CRITICAL, text);
    }

    /// Every 30 s while disarmed and failing: `"PreArm: <reason>"` for each
    /// failing check.
    pub(crate) fn prearm_report(&mut self) {
        if self.fl.armed || !self.ready() {
            return;
        }
        for reason in self.prearm_failures() {
            self.check_failed("PreArm", &reason);
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
            let failures = self.prearm_failures();
            if !failures.is_empty() {
                for reason in failures {
                    self.check_failed("Arm", &reason);
                }
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

#[cfg(test)]
#[allow(deprecated)] // REQUEST_DATA_STREAM, as ArduPilot's clients still send it
mod tests {
    use super::*;
    use crate::vehicle::testing::*;
    use mavlink::dialects::ardupilotmega::*;

    #[test]
    fn the_first_arming_is_refused_until_the_gyros_settle() {
        let mut b = Bench::new(crate::SimConfig {
            first_arm_refused: true,
            ..quick()
        });
        b.run_to(2.5); // EKF uses the GPS at 2.2 s, gyros settle at 3.0 s
        let before = b.got.len();
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_FAILED));
        // The COMMAND_ACK first, then the reason (as the recording).
        let order: Vec<&'static str> = b.got[before..]
            .iter()
            .map(|(_, _, m)| mavlink::Message::message_name(m))
            .collect();
        assert_eq!(order, vec!["COMMAND_ACK", "STATUSTEXT"]);
        let text = b.v.truth.statustexts.last().cloned().unwrap();
        assert_eq!(text.text, "Arm: Gyros inconsistent");
        assert_eq!(text.severity, MavSeverity::MAV_SEVERITY_CRITICAL as u8);
        assert!(!b.v.state().armed);
        b.run_to(3.2);
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_ACCEPTED));
        assert!(b.v.state().armed);
        assert!(b.texts().contains(&"Throttle armed".to_owned()));
        // Arming again is accepted and changes nothing.
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_ACCEPTED));
        assert_eq!(b.v.state().results_of(400), vec![Some(4), Some(0), Some(0)]);
    }

    #[test]
    fn arming_waits_for_the_ekf_and_the_gps_with_prearm_reports() {
        let mut b = Bench::new(crate::SimConfig {
            first_arm_refused: false,
            ..crate::SimConfig::default()
        });
        b.run_to(5.0);
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_FAILED));
        assert_eq!(
            b.texts().last().unwrap(),
            "Arm: AHRS: EKF3 still initialising"
        );
        // The pre-arm bit of SYS_STATUS is present, enabled and unhealthy.
        b.send(MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
            req_message_rate: 2,
            target_system: 1,
            target_component: 1,
            req_stream_id: MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS,
            start_stop: 1,
        }));
        b.run_to(6.0);
        let prearm = |b: &Bench| {
            b.of("SYS_STATUS")
                .last()
                .map(|m| match m {
                    MavMessage::SYS_STATUS(s) => (
                        s.onboard_control_sensors_enabled.bits() & 0x1000_0000 != 0,
                        s.onboard_control_sensors_health.bits() & 0x1000_0000 != 0,
                    ),
                    _ => unreachable!(),
                })
                .unwrap()
        };
        assert_eq!(prearm(&b), (true, false));
        b.run_to(21.0);
        assert_eq!(prearm(&b), (true, true));
        // The GPS lost: "Bad GPS Position", and every 30 s while disarmed.
        b.v.inject(crate::Fault::GpsLoss);
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_FAILED));
        assert_eq!(b.texts().last().unwrap(), "Arm: Bad GPS Position");
        b.run_to(61.0);
        let reports: Vec<f64> =
            b.v.truth
                .statustexts
                .iter()
                .filter(|t| t.text == "PreArm: Bad GPS Position")
                .map(|t| t.time_s)
                .collect();
        assert_eq!(reports.len(), 2, "{reports:?}"); // at 30 s and 60 s
        b.v.clear(crate::FaultKind::GpsLoss);
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_ACCEPTED));
    }

    #[test]
    fn disarming_in_flight_is_refused_unless_forced() {
        let mut b = Bench::airborne(quick());
        let disarm = |b: &mut Bench, force: f32| {
            b.command(
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                [0.0, force, 0.0, 0.0, 0.0, 0.0, 0.0],
            )
        };
        assert_eq!(disarm(&mut b, 0.0), Some(MavResult::MAV_RESULT_FAILED));
        assert!(b.v.state().armed);
        assert_eq!(disarm(&mut b, FORCE), Some(MavResult::MAV_RESULT_ACCEPTED));
        assert!(!b.v.state().armed);
        assert_eq!(b.texts().last().unwrap(), "Throttle disarmed");
    }

    /// The texts on the wire (STATUSTEXT as sent), with their severity.
    fn wire_texts(b: &Bench, from: usize) -> Vec<(u64, MavSeverity, String)> {
        b.since(from, "STATUSTEXT")
            .into_iter()
            .map(|(t, _, m)| match m {
                MavMessage::STATUSTEXT(s) => (t, s.severity, s.text.to_str().unwrap().to_owned()),
                _ => unreachable!(),
            })
            .collect()
    }

    fn param_values(b: &Bench, from: usize) -> Vec<PARAM_VALUE_DATA> {
        b.since(from, "PARAM_VALUE")
            .into_iter()
            .map(|(_, _, m)| match m {
                MavMessage::PARAM_VALUE(p) => p,
                _ => unreachable!(),
            })
            .collect()
    }

    fn prearm_healthy(b: &Bench) -> bool {
        match b.of("SYS_STATUS").last() {
            Some(MavMessage::SYS_STATUS(s)) => {
                s.onboard_control_sensors_health.bits() & 0x1000_0000 != 0
            }
            _ => panic!("no SYS_STATUS"),
        }
    }

    /// As ArduPlane 4.7 SITL (checked on the real firmware, see the
    /// README): a mission with DO_LAND_START while RTL_AUTOLAND is 0 keeps
    /// it from arming; the reason is said every 30 s and after each refused
    /// arming, cut to 50 characters in the PreArm report; the pre-arm bit
    /// stays unhealthy; RTL_AUTOLAND set over PARAM_SET lets it arm.
    #[test]
    fn a_landing_sequence_needs_rtl_autoland_to_arm() {
        let mut b = Bench::new(quick());
        b.send(MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
            req_message_rate: 2,
            target_system: 1,
            target_component: 1,
            req_stream_id: MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS,
            start_stop: 1,
        }));
        b.run_to(4.0);
        let v = &b.v;
        let mut land_start = item(v, cmd::DO_LAND_START, 0.0, 0.0, 0.0);
        (land_start.x, land_start.y) = (0, 0);
        let mission = vec![
            item(v, cmd::NAV_TAKEOFF, 0.0, 0.0, 50.0),
            item(v, cmd::NAV_WAYPOINT, 600.0, 0.0, 80.0),
            land_start,
            item(v, cmd::NAV_WAYPOINT, 400.0, 0.0, 50.0),
            item(v, cmd::NAV_LAND, 0.0, 0.0, 0.0),
        ];
        assert_eq!(b.upload(&mission), MavMissionResult::MAV_MISSION_ACCEPTED);
        b.run_to(5.0);
        assert!(!prearm_healthy(&b));
        let from = b.got.len();
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_FAILED));
        let order: Vec<&'static str> = b.got[from..]
            .iter()
            .map(|(_, _, m)| mavlink::Message::message_name(m))
            .collect();
        assert_eq!(order, vec!["COMMAND_ACK", "STATUSTEXT"]);
        let said = wire_texts(&b, from);
        assert_eq!(said[0].1, MavSeverity::MAV_SEVERITY_CRITICAL);
        assert_eq!(
            said[0].2,
            "Arm: DO_LAND_START set and RTL_AUTOLAND disabled"
        );
        // The report every 30 s, cut to one STATUSTEXT's 50 characters.
        let from = b.got.len();
        b.run_to(61.0);
        let reports: Vec<(u64, String)> = wire_texts(&b, from)
            .into_iter()
            .filter(|(_, _, t)| t.starts_with("PreArm"))
            .map(|(t, _, text)| (t, text))
            .collect();
        assert_eq!(
            reports,
            vec![
                (
                    30_000_000,
                    "PreArm: DO_LAND_START set and RTL_AUTOLAND disable".to_owned()
                ),
                (
                    60_000_000,
                    "PreArm: DO_LAND_START set and RTL_AUTOLAND disable".to_owned()
                ),
            ]
        );
        assert!(!prearm_healthy(&b));
        // RTL_AUTOLAND read by name, then set: PARAM_VALUE as ArduPilot
        // answers a request by name (INT8, param_index 65535).
        let from = b.got.len();
        b.send(MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
            param_index: -1,
            target_system: 1,
            target_component: 1,
            param_id: "RTL_AUTOLAND".into(),
        }));
        b.send(MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
            param_index: -1,
            target_system: 1,
            target_component: 1,
            param_id: "NO_SUCH_PARAM".into(),
        }));
        b.send(MavMessage::PARAM_SET(PARAM_SET_DATA {
            param_value: 2.0,
            target_system: 1,
            target_component: 1,
            param_id: "RTL_AUTOLAND".into(),
            param_type: MavParamType::MAV_PARAM_TYPE_INT8,
        }));
        let answers: Vec<(String, f32, MavParamType, u16)> = param_values(&b, from)
            .into_iter()
            .map(|p| {
                let name = p.param_id.to_str().unwrap().to_owned();
                (name, p.param_value, p.param_type, p.param_index)
            })
            .collect();
        let int8 = MavParamType::MAV_PARAM_TYPE_INT8;
        assert_eq!(
            answers,
            vec![
                ("RTL_AUTOLAND".to_owned(), 0.0, int8, u16::MAX),
                ("RTL_AUTOLAND".to_owned(), 2.0, int8, u16::MAX),
            ]
        );
        b.run_to(62.0);
        assert!(prearm_healthy(&b));
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_ACCEPTED));
    }

    /// ArduPilot reports every failing check: the start-up chain's first and
    /// the landing sequence's, each on its own line.
    #[test]
    fn each_failing_check_is_reported() {
        let mut b = Bench::new(crate::SimConfig {
            first_arm_refused: false,
            ..crate::SimConfig::default()
        });
        b.run_to(12.0); // home set at 10.1 s, the EKF not using the GPS yet
        let mut land_start = item(&b.v, cmd::DO_LAND_START, 0.0, 0.0, 0.0);
        (land_start.x, land_start.y) = (0, 0);
        assert_eq!(
            b.upload(&[land_start]),
            MavMissionResult::MAV_MISSION_ACCEPTED
        );
        let from = b.got.len();
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_FAILED));
        let said: Vec<String> = wire_texts(&b, from).into_iter().map(|x| x.2).collect();
        assert_eq!(
            said,
            vec![
                "Arm: AHRS: EKF3 still initialising",
                "Arm: DO_LAND_START set and RTL_AUTOLAND disabled"
            ]
        );
    }
}
