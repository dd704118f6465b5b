//! The ground rover: the vehicle core with ArduPilot Rover's personality
//! ([`crate::Firmware::ArduRover`]). The protocol plumbing is the plane's,
//! shared (streams, parameters, commands, the mission protocol, arming,
//! start-up, faults, the wire); this module holds what is Rover's: its
//! modes and how it enters them, its navigation (GUIDED, RTL, LOITER,
//! AUTO), and its kinematic model ([`crate::drive`]).
//!
//! What follows ArduPilot Rover's source (ArduPilot master, `Rover/`):
//! - HEARTBEAT: type GROUND_ROVER (`GCS_Rover::frame_type`), autopilot
//!   ARDUPILOTMEGA, `custom_mode` the mode number of `Mode::Number`
//!   (mode.h: MANUAL 0, ACRO 1, STEERING 3, HOLD 4, LOITER 5, FOLLOW 6,
//!   SIMPLE 7, AUTO 10, RTL 11, SMART_RTL 12, GUIDED 15, INITIALISING 16),
//!   `base_mode` as `GCS_MAVLINK_Rover::base_mode` ([`crate::modes::rover`]),
//!   `system_status` as `vehicle_system_status`: CALIBRATING while
//!   initialising, CRITICAL in a failsafe, STANDBY in HOLD, ACTIVE
//!   otherwise (GCS_Mavlink.cpp).
//! - AUTO refused without a mission, with "No Mission. Can't set AUTO."
//!   (NOTICE; `ModeAuto::_enter`, mode_auto.cpp); a waypoint reached says
//!   "Reached waypoint #N" (INFO; "Reached waypoint #N. Loiter for S
//!   seconds" with a delay) and, once done, MISSION_ITEM_REACHED N
//!   (`verify_nav_wp`, `verify_command_callback`); the mission's end says
//!   "Mission Complete" (NOTICE) and the rover stops, still in AUTO
//!   (`exit_mission`, MIS_DONE_BEHAVE 0 HOLD).
//! - GUIDED: entered stopped; a target (DO_REPOSITION, or
//!   SET_POSITION_TARGET_GLOBAL_INT while in GUIDED) is driven to, and
//!   reaching it sends MISSION_ITEM_REACHED 0 once, then the rover stops
//!   (`ModeGuided::update`, mode_guided.cpp).
//! - RTL: refused before home is set; drives home, says "Reached
//!   destination" (INFO) and stops (`ModeRTL`, mode_rtl.cpp). SMART_RTL
//!   is driven as RTL here (no breadcrumbs).
//!
//! What is the model's, not Rover's: see the README ("The ground rover").

use mavlink::dialects::ardupilotmega::{MavSeverity, MavState};

use crate::drive::{self, Demand, Limits};
use crate::faults::FaultKind;
use crate::geo::{wrap_pi, V2};
use crate::guidance::Nav;
use crate::mission::cmd;
use crate::modes::rover as mode;
use crate::nav_state::Notify;
use crate::vehicle::Vehicle;

impl Vehicle {
    pub(crate) fn is_rover(&self) -> bool {
        self.cfg.firmware == crate::Firmware::ArduRover
    }

    /// The mode's name as Petrel's elaboration names it.
    pub(crate) fn mode_name(&self) -> String {
        if self.is_rover() {
            mode::name(self.fl.mode)
        } else {
            crate::modes::name(self.fl.mode)
        }
    }

    fn rover_limits(&self) -> Limits {
        let speed = self
            .rv
            .speed
            .unwrap_or_else(|| match self.params.get("WP_SPEED") {
                s if s > 0.0 => s,
                _ => self.params.get("CRUISE_SPEED"),
            });
        let speed = if matches!(self.fl.mode, mode::RTL | mode::SMART_RTL)
            && self.params.get("RTL_SPEED") > 0.0
        {
            self.params.get("RTL_SPEED")
        } else {
            speed
        };
        Limits {
            speed: speed.clamp(0.1, 50.0),
            accel: self.params.get("ATC_ACCEL_MAX").clamp(0.1, 20.0),
            decel: self.params.get("ATC_DECEL_MAX").clamp(0.0, 20.0),
            turn_rate: self
                .params
                .get("ATC_STR_RAT_MAX")
                .clamp(1.0, 1000.0)
                .to_radians(),
        }
    }

    fn wp_radius(&self) -> f64 {
        self.params.get("WP_RADIUS").clamp(0.1, 1000.0)
    }

    /// HEARTBEAT.system_status as Rover reports it.
    pub(crate) fn rover_status(&self) -> MavState {
        if self.fl.battery_failsafe > 0 {
            MavState::MAV_STATE_CRITICAL
        } else if self.fl.mode == mode::INITIALISING {
            MavState::MAV_STATE_CALIBRATING
        } else if self.has_fault(FaultKind::Emergency) {
            MavState::MAV_STATE_EMERGENCY
        } else if self.fl.mode == mode::HOLD {
            MavState::MAV_STATE_STANDBY
        } else {
            MavState::MAV_STATE_ACTIVE
        }
    }

    /// A mode change asked for (DO_SET_MODE, SET_MODE, the mode commands):
    /// false when the mode refuses to be entered now.
    pub(crate) fn rover_set_mode(&mut self, m: u32) -> bool {
        if !self.ready() || !mode::settable(m) {
            return false;
        }
        let positioned = self.gps_ok() && self.home_set;
        let ok = match m {
            mode::AUTO if self.mission.len() <= 1 => {
                self.text(
                    MavSeverity::MAV_SEVERITY_NOTICE,
                    "No Mission. Can't set AUTO.",
                );
                false
            }
            // FOLL_ENABLE is 0: nothing to follow.
            mode::FOLLOW => false,
            mode::AUTO | mode::GUIDED | mode::RTL | mode::SMART_RTL | mode::LOITER => positioned,
            _ => true,
        };
        if ok {
            self.enter_mode(m);
        }
        ok
    }

    /// Enters a mode (already accepted): its navigation starts.
    pub(crate) fn rover_enter_mode(&mut self, m: u32) {
        let old = self.fl.mode;
        self.fl.mode = m;
        let here = self.ac.pos;
        if old == mode::AUTO && m != mode::AUTO {
            self.auto.running = false;
            self.auto.started = false;
        }
        self.rv.dest = None;
        self.rv.notify = Notify::Nothing;
        self.rv.from = here;
        self.rv.reached_at = None;
        self.rv.pass_through = false;
        if m != old {
            self.rv.speed = None;
        }
        match m {
            mode::LOITER => self.rv.dest = Some(here),
            mode::RTL | mode::SMART_RTL => {
                self.rv.dest = Some(self.home_pos);
                self.rv.notify = Notify::Rtl;
            }
            mode::AUTO => self.rover_auto_enter(),
            _ => {}
        }
        if old != m {
            tracing::info!(t = self.t_s(), mode = %mode::name(m), "mode");
            self.send_heartbeat();
        }
    }

    /// GUIDED: drive to `to` (metres from the boot home).
    pub(crate) fn rover_goto(&mut self, to: V2) {
        self.rv.from = self.ac.pos;
        self.rv.dest = Some(to);
        self.rv.notify = Notify::Guided;
        self.rv.pass_through = false;
    }

    /// DO_CHANGE_SPEED: the speed in the autopilot modes (m/s).
    pub(crate) fn rover_change_speed(&mut self, speed: f32) -> bool {
        if !mode::is_autopilot(self.fl.mode) || !speed.is_finite() || speed <= 0.0 {
            return false;
        }
        self.rv.speed = Some(speed as f64);
        true
    }

    // ----- AUTO -----

    fn rover_auto_enter(&mut self) {
        // MIS_RESTART 0: resume the mission where it was left.
        if self.auto.complete || self.auto.current == 0 {
            self.auto.complete = false;
            self.auto.current = 1;
        }
        self.auto.running = true;
        let at = self.auto.current;
        self.rover_start_at(at);
    }

    /// MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT.
    pub(crate) fn rover_set_current(&mut self, seq: u16) -> bool {
        let seq = seq.max(1);
        if seq as usize >= self.mission.len() {
            return false;
        }
        self.auto.complete = false;
        self.auto.current = seq;
        if self.fl.mode == mode::AUTO {
            self.auto.running = true;
            self.rover_start_at(seq);
        }
        true
    }

    /// The mission was replaced while running: its command `seq` again.
    pub(crate) fn rover_restart_at(&mut self, seq: u16) {
        self.rover_start_at(seq);
    }

    /// Runs the DO items from `seq` to the next navigation item, and starts
    /// that one; the mission completes when there is none.
    fn rover_start_at(&mut self, seq: u16) {
        let Some(nav) = (seq as usize..self.mission.len()).find(|&i| self.mission[i].is_nav())
        else {
            for i in seq..self.mission.len() as u16 {
                self.run_do(i);
            }
            self.rover_mission_complete();
            return;
        };
        for i in seq..nav as u16 {
            self.run_do(i);
        }
        let nav = nav as u16;
        self.auto.current = nav;
        self.rv.from = self.ac.pos;
        self.rv.reached_at = None;
        let Some(it) = self.mission.get(nav as usize).cloned() else {
            return;
        };
        let next_nav = (nav as usize + 1..self.mission.len()).any(|i| self.mission[i].is_nav());
        if it.command == cmd::NAV_RETURN_TO_LAUNCH {
            self.rv.dest = Some(self.home_pos);
            self.rv.notify = Notify::Rtl;
            self.rv.pass_through = false;
        } else {
            let (to, _) = self.item_target(&it);
            self.rv.dest = Some(to);
            self.rv.notify = Notify::Nothing;
            // Rover stops on a waypoint with a delay or the last one.
            self.rv.pass_through = next_nav && it.param1 <= 0.0;
        }
        let mc = self.mission_current();
        self.send(mc);
    }

    fn rover_mission_complete(&mut self) {
        self.auto.complete = true;
        self.auto.running = false;
        self.rv.dest = None;
        self.text(MavSeverity::MAV_SEVERITY_NOTICE, "Mission Complete");
    }

    /// AUTO: the current item's progress, once the rover is on it.
    fn rover_auto_tick(&mut self) {
        if !self.auto.running {
            return;
        }
        let seq = self.auto.current;
        let Some(it) = self.mission.get(seq as usize).cloned() else {
            self.rover_mission_complete();
            return;
        };
        let Some(dest) = self.rv.dest else {
            return;
        };
        let arrived = (dest - self.ac.pos).len() <= self.wp_radius();
        if !arrived && self.rv.reached_at.is_none() {
            return;
        }
        let delay = if it.command == cmd::NAV_RETURN_TO_LAUNCH {
            0.0
        } else {
            it.param1.max(0.0) as f64
        };
        if self.rv.reached_at.is_none() {
            self.rv.reached_at = Some(self.now);
            if it.command == cmd::NAV_RETURN_TO_LAUNCH {
                self.info("Reached destination");
            } else if delay > 0.0 {
                self.info(format!(
                    "Reached waypoint #{seq}. Loiter for {} seconds",
                    delay as u32
                ));
            } else {
                self.info(format!("Reached waypoint #{seq}"));
            }
        }
        let since = self.rv.reached_at.unwrap_or(self.now);
        if self.now >= since + (delay * 1e6) as u64 {
            self.reached(seq);
            self.rover_start_at(seq + 1);
        }
    }

    // ----- the step -----

    /// One physics step of the rover: the mode's navigation, the model.
    pub(crate) fn rover_step(&mut self) {
        let dt = self.cfg.step_us as f64 / 1e6;
        if self.fl.armed && self.fl.mode == mode::AUTO {
            self.rover_auto_tick();
        }
        let limits = self.rover_limits();
        let demand = self.rover_demand(&limits);
        let stuck = self.has_fault(FaultKind::Stuck);
        let armed = self.fl.armed;
        drive::step(&mut self.ac, dt, demand, &limits, armed, stuck, &self.af);
        if armed {
            self.fl.flight_time_us += self.cfg.step_us;
        }
    }

    /// The speed and heading the mode asks for now; the navigation outputs
    /// for NAV_CONTROLLER_OUTPUT and POSITION_TARGET_GLOBAL_INT.
    fn rover_demand(&mut self, limits: &Limits) -> Demand {
        let navigating = mode::is_autopilot(self.fl.mode) && self.fl.armed;
        let Some(dest) = self.rv.dest.filter(|_| navigating) else {
            self.fl.nav = Nav::default();
            self.fl.target = None;
            return Demand::default();
        };
        self.fl.target = Some((dest, 0.0));
        let to = dest - self.ac.pos;
        let dist = to.len();
        let bearing = to.heading();
        let leg = dest - self.rv.from;
        let xtrack = if leg.len() > 0.1 {
            leg.unit().cross(self.ac.pos - self.rv.from)
        } else {
            0.0
        };
        self.fl.nav = Nav {
            nav_bearing: bearing,
            target_bearing: bearing,
            wp_dist: dist,
            xtrack,
            ..Nav::default()
        };
        if dist <= self.wp_radius() {
            match std::mem::take(&mut self.rv.notify) {
                Notify::Guided => self.reached(0),
                Notify::Rtl if self.fl.mode != mode::AUTO => self.info("Reached destination"),
                _ => {}
            }
            if self.rv.pass_through {
                return Demand {
                    speed: limits.speed,
                    heading: Some(bearing),
                };
            }
            return Demand::default();
        }
        let err = wrap_pi(bearing - self.ac.heading).abs();
        let cruise = if self.rv.pass_through {
            limits.speed
        } else {
            drive::approach_speed(dist, limits)
        };
        // Turn on the spot first when the target is well off the nose.
        let speed = cruise * err.cos().max(0.0).powi(2);
        Demand {
            speed,
            heading: Some(bearing),
        }
    }
}

#[cfg(test)]
#[allow(deprecated)]
mod tests {
    use mavlink::dialects::ardupilotmega::*;

    use super::mode;
    use crate::faults::Fault;
    use crate::geo::{location, Home, V2};
    use crate::mission::{cmd, MissionItem};
    use crate::vehicle::testing::*;

    fn rover() -> crate::SimConfig {
        crate::SimConfig {
            boot: crate::boot::BootTimeline::quick(),
            first_arm_refused: false,
            ..crate::SimConfig::rover(1, Home::default())
        }
    }

    /// Quick boot, armed in GUIDED.
    fn ready() -> Bench {
        let mut b = Bench::new(rover());
        b.run_to(4.0);
        assert_eq!(
            b.set_mode(mode::GUIDED),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_ACCEPTED));
        b
    }

    fn heartbeat(b: &Bench) -> HEARTBEAT_DATA {
        b.got
            .iter()
            .rev()
            .find_map(|(_, _, m)| match m {
                MavMessage::HEARTBEAT(h) => Some(h.clone()),
                _ => None,
            })
            .expect("a heartbeat")
    }

    fn goto(b: &mut Bench, n: f64, e: f64) -> Option<MavResult> {
        let (lat, lon) = location(&Home::default(), V2::new(n, e));
        b.command_int(
            MavCmd::MAV_CMD_DO_REPOSITION,
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            [-1.0, 1.0, 0.0, 0.0],
            (lat * 1e7) as i32,
            (lon * 1e7) as i32,
            0.0,
        )
    }

    #[test]
    fn heartbeat_and_modes_as_rover() {
        let mut b = Bench::new(rover());
        b.run_to(1.5);
        let h = heartbeat(&b);
        assert_eq!(h.mavtype, MavType::MAV_TYPE_GROUND_ROVER);
        assert_eq!(h.autopilot, MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA);
        b.run_to(4.0);
        assert_eq!(b.v.state().mode, "MANUAL");
        assert_eq!(heartbeat(&b).system_status, MavState::MAV_STATE_ACTIVE);
        assert_eq!(b.set_mode(mode::HOLD), Some(MavResult::MAV_RESULT_ACCEPTED));
        b.run_to(5.5);
        let h = heartbeat(&b);
        assert_eq!((h.custom_mode, h.base_mode.bits()), (4, 1));
        assert_eq!(h.system_status, MavState::MAV_STATE_STANDBY);
        // No mission: AUTO refused with Rover's words; FOLLOW has nothing
        // to follow; a plane's mode number is not a rover's.
        assert_eq!(b.set_mode(mode::AUTO), Some(MavResult::MAV_RESULT_FAILED));
        assert!(b
            .texts()
            .contains(&"No Mission. Can't set AUTO.".to_owned()));
        assert_eq!(b.set_mode(mode::FOLLOW), Some(MavResult::MAV_RESULT_FAILED));
        assert_eq!(b.set_mode(13), Some(MavResult::MAV_RESULT_FAILED));
        assert_eq!(b.v.state().mode, "HOLD");
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_ACCEPTED));
        assert_eq!(
            b.set_mode(mode::GUIDED),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let h = heartbeat(&b);
        assert_eq!((h.custom_mode, h.base_mode.bits()), (15, 1 | 8 | 128));
    }

    #[test]
    fn guided_drives_to_the_target_stops_and_says_reached_once() {
        let mut b = ready();
        assert_eq!(
            goto(&mut b, 30.0, 40.0),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let t0 = b.v.state().time_s;
        assert!(b.run_until(120.0, |v| !v.state().reached.is_empty()));
        let s = b.v.state();
        // 50 m at 2 m/s, a turn first: about 25 s.
        let took = s.time_s - t0;
        assert!((24.0..32.0).contains(&took), "took {took} s");
        assert_eq!(s.reached[0].seq, 0);
        let t = s.time_s + 10.0;
        b.run_to(t);
        let s = b.v.state();
        assert_eq!(s.groundspeed, 0.0);
        assert!(
            ((s.north - 30.0).powi(2) + (s.east - 40.0).powi(2)).sqrt() < 2.5,
            "{} {}",
            s.north,
            s.east
        );
        assert_eq!(b.of("MISSION_ITEM_REACHED").len(), 1);
        // SET_POSITION_TARGET_GLOBAL_INT in GUIDED: off again.
        let (lat, lon) = location(&Home::default(), V2::new(0.0, 40.0));
        b.send(MavMessage::SET_POSITION_TARGET_GLOBAL_INT(
            SET_POSITION_TARGET_GLOBAL_INT_DATA {
                lat_int: (lat * 1e7) as i32,
                lon_int: (lon * 1e7) as i32,
                target_system: 1,
                target_component: 1,
                coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_INT,
                type_mask: PositionTargetTypemask::from_bits_retain(0x0ff8),
                ..Default::default()
            },
        ));
        assert!(b.run_until(t + 60.0, |v| v.state().reached.len() == 2));
        assert!(b.v.state().north.abs() < 2.5);
    }

    #[test]
    fn auto_runs_the_mission_reports_each_waypoint_and_stops_at_its_end() {
        let mut b = ready();
        let wp = |n: f64, e: f64, delay: f32| {
            let (lat, lon) = location(&Home::default(), V2::new(n, e));
            MissionItem {
                command: cmd::NAV_WAYPOINT,
                x: (lat * 1e7) as i32,
                y: (lon * 1e7) as i32,
                param1: delay,
                ..MissionItem::home(lat, lon, 584.0)
            }
        };
        assert_eq!(
            b.upload(&[wp(20.0, 0.0, 0.0), wp(20.0, 20.0, 3.0), wp(0.0, 20.0, 0.0)]),
            MavMissionResult::MAV_MISSION_ACCEPTED
        );
        assert_eq!(b.set_mode(mode::AUTO), Some(MavResult::MAV_RESULT_ACCEPTED));
        assert!(b.run_until(200.0, |v| v.state().reached.len() == 3));
        let s = b.v.state();
        let seqs: Vec<u16> = s.reached.iter().map(|r| r.seq).collect();
        assert_eq!(seqs, vec![1, 2, 3]);
        let texts = b.texts();
        for t in [
            "Reached waypoint #1",
            "Reached waypoint #2. Loiter for 3 seconds",
            "Reached waypoint #3",
            "Mission Complete",
        ] {
            assert!(texts.contains(&t.to_owned()), "{t} not in {texts:?}");
        }
        let t = s.time_s + 5.0;
        b.run_to(t);
        let s = b.v.state();
        assert_eq!((s.mode.as_str(), s.groundspeed), ("AUTO", 0.0));
        assert!(s.north.abs() < 2.5 && (s.east - 20.0).abs() < 2.5);
    }

    #[test]
    fn rtl_drives_home_and_stuck_or_a_motor_failure_stops_it_where_it_is() {
        let mut b = ready();
        goto(&mut b, 0.0, 60.0);
        assert!(b.run_until(100.0, |v| !v.state().reached.is_empty()));
        assert_eq!(b.set_mode(mode::RTL), Some(MavResult::MAV_RESULT_ACCEPTED));
        let t = b.v.state().time_s;
        b.run_to(t + 10.0);
        b.v.inject(Fault::Stuck);
        let at = b.v.state();
        b.run_to(t + 20.0);
        let s = b.v.state();
        assert_eq!((s.north, s.east), (at.north, at.east), "moved while stuck");
        assert!(s.throttle > 90.0 && s.engine_running);
        b.v.clear(crate::FaultKind::Stuck);
        assert!(b.run_until(t + 80.0, |v| v
            .truth
            .statustexts
            .iter()
            .any(|x| x.text == "Reached destination")));
        assert!(b.v.state().east.abs() < 2.5);
        // The motor fails on the way out: it stops, the ESC says 0 rpm.
        goto(&mut b, 0.0, 30.0);
        let t = b.v.state().time_s;
        b.run_to(t + 8.0);
        b.v.inject(Fault::EngineFailure);
        b.run_to(t + 14.0);
        let s = b.v.state();
        assert_eq!(s.groundspeed, 0.0);
        assert!(!s.engine_running);
        assert!(s.east > 3.0 && s.east < 28.0, "{}", s.east);
    }

    /// What Petrel's elaboration (ArduPilot's built-in profile under the
    /// ugv-bottleneck example's layer) makes of the frames sent so far:
    /// (sim seconds, event name).
    fn elaborated(b: &Bench) -> Vec<(f64, String)> {
        let layer = include_str!("../../examples/ugv-bottleneck/profile.toml");
        let base = elaboration::profile::builtin("ardupilot").expect("the built-in profile");
        let profile =
            elaboration::Profile::load(&[("ardupilot.toml", base), ("profile.toml", layer)])
                .expect("the example's profile loads");
        let mut e = elaboration::Elaborator::new(profile, Default::default());
        let mut out = Vec::new();
        for (t, h, m) in &b.got {
            e.tick(*t);
            e.message(*t, h, m);
            while let Some(ev) = e.poll_event() {
                out.push((ev.time_us as f64 / 1e6, ev.event.name));
            }
        }
        out
    }

    #[test]
    fn elaboration_hears_a_rover_each_goto_reached_and_its_motor_failure() {
        let mut b = ready();
        // Streams as a ground station asks them (ESC telemetry, VFR_HUD…).
        b.send(MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
            req_message_rate: 4,
            target_system: 1,
            target_component: 1,
            req_stream_id: MavDataStream::MAV_DATA_STREAM_ALL,
            start_stop: 1,
        }));
        goto(&mut b, 20.0, 0.0);
        assert!(b.run_until(60.0, |v| v.state().reached.len() == 1));
        goto(&mut b, 20.0, 10.0);
        assert!(b.run_until(90.0, |v| v.state().reached.len() == 2));
        // Stuck with the motor turning at full throttle: no motor failure.
        goto(&mut b, 40.0, 0.0);
        let t = b.v.state().time_s;
        b.run_to(t + 3.0);
        b.v.inject(Fault::Stuck);
        b.run_to(t + 10.0);
        b.v.clear(crate::FaultKind::Stuck);
        let before = elaborated(&b);
        let names: Vec<&str> = before.iter().map(|(_, n)| n.as_str()).collect();
        for name in ["mode_changed", "armed"] {
            assert!(names.contains(&name), "no {name} in {before:?}");
        }
        // Each goto reached is heard (the built-in `goto_reached`, which
        // the example uses), and none is a mission item.
        let count = |n: &str| names.iter().filter(|x| **x == n).count();
        assert_eq!(
            (count("goto_reached"), count("mission_item_reached")),
            (2, 0)
        );
        assert!(!names.contains(&"engine_failure"), "{before:?}");
        // The motor fails while driving: engine_failure within 2 s and a
        // stream period.
        let failed_at = b.v.state().time_s + 1.0;
        b.run_to(failed_at);
        b.v.inject(Fault::EngineFailure);
        b.run_to(failed_at + 5.0);
        let after = elaborated(&b);
        let failure: Vec<f64> = after
            .iter()
            .filter(|(_, n)| n == "engine_failure")
            .map(|(t, _)| *t)
            .collect();
        assert_eq!(failure.len(), 1, "{after:?}");
        assert!(
            (failed_at + 2.0..failed_at + 3.5).contains(&failure[0]),
            "failed at {failed_at}, heard at {}",
            failure[0]
        );
    }
}
