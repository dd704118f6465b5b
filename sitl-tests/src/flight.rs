//! How the autopilot flies: the flight stages (take-off, cruise, landing),
//! each mode's navigation, the controls it gives the model, and what
//! happens when the aircraft meets the ground (landing or crash, then the
//! automatic disarm).

use mavlink::dialects::ardupilotmega::{MavSeverity, MavState};

use crate::geo::{wrap_pi, V2};
use crate::guidance::{self, Nav, L1};
use crate::model::{Contact, Controls, Priority};
use crate::modes;
use crate::nav_state::{Demand, Landing, Orbit, Stage, Takeoff};
use crate::state::Touchdown;
use crate::vehicle::Vehicle;

impl Vehicle {
    pub(crate) fn roll_limit(&self) -> f64 {
        self.params
            .get("ROLL_LIMIT_DEG")
            .clamp(5.0, 89.0)
            .to_radians()
    }

    pub(crate) fn l1(&self) -> L1 {
        L1 {
            period: self.params.get("NAVL1_PERIOD").max(1.0),
            damping: self.params.get("NAVL1_DAMPING").clamp(0.1, 1.0),
        }
    }

    pub(crate) fn cruise_airspeed(&self) -> f64 {
        let min = self.params.get("AIRSPEED_MIN");
        let max = self.params.get("AIRSPEED_MAX");
        let base = self
            .fl
            .airspeed_override
            .unwrap_or_else(|| self.params.get("AIRSPEED_CRUISE"));
        let gs = self.ac.groundspeed();
        let extra = (self.fl.min_groundspeed - gs).max(0.0);
        (base + extra).clamp(min, max.max(min))
    }

    pub(crate) fn land_airspeed(&self) -> f64 {
        let p = self.params.get("TECS_LAND_ARSPD");
        if p > 0.0 {
            p
        } else {
            (self.params.get("AIRSPEED_MIN") + self.params.get("AIRSPEED_CRUISE")) / 2.0
        }
    }

    pub(crate) fn wp_loiter_radius(&self) -> f64 {
        self.params.get("WP_LOITER_RAD").abs().max(10.0)
    }

    /// ArduPlane's is_flying: from the take-off run to the end of the
    /// landing roll, or whenever off the ground.
    pub(crate) fn is_flying(&self) -> bool {
        if self.fl.crashed {
            return false;
        }
        if !self.ac.on_ground {
            return true;
        }
        self.fl.armed
            && matches!(
                self.fl.stage,
                Stage::TakeoffRoll | Stage::Rollout { landing: true }
            )
    }

    /// HEARTBEAT.system_status as ArduPlane reports it.
    pub(crate) fn system_status(&self) -> MavState {
        if self.is_rover() {
            return self.rover_status();
        }
        if self.fl.mode == modes::INITIALISING {
            MavState::MAV_STATE_CALIBRATING
        } else if self.has_fault(crate::faults::FaultKind::Emergency) || self.fl.crashed {
            MavState::MAV_STATE_EMERGENCY
        } else if self.fl.battery_failsafe > 0 {
            MavState::MAV_STATE_CRITICAL
        } else if self.is_flying() {
            MavState::MAV_STATE_ACTIVE
        } else {
            MavState::MAV_STATE_STANDBY
        }
    }

    /// Switches mode (already checked as settable). Sends the extra
    /// HEARTBEAT ArduPilot sends on a mode change.
    pub(crate) fn enter_mode(&mut self, mode: u32) {
        if self.is_rover() {
            return self.rover_enter_mode(mode);
        }
        let old = self.fl.mode;
        self.fl.mode = mode;
        let here = self.ac.pos;
        let alt = self.ac.alt;
        if old == modes::AUTO && mode != modes::AUTO {
            self.auto_stop();
        }
        if old == modes::GUIDED && mode != modes::GUIDED {
            self.fl.orbit = None;
        }
        // Leaving AUTO or TAKEOFF ends their take-off and landing.
        if !matches!(
            self.fl.stage,
            Stage::Ground | Stage::Rollout { .. } | Stage::Stopped
        ) && mode != old
        {
            match self.fl.stage {
                Stage::Approach | Stage::Flare => {
                    self.fl.landing = None;
                    self.fl.stage = Stage::Cruise;
                }
                Stage::TakeoffClimb => {
                    self.fl.takeoff = None;
                    self.fl.stage = Stage::Cruise;
                }
                Stage::TakeoffWait { .. } => {
                    self.fl.takeoff = None;
                    self.fl.stage = Stage::Ground;
                }
                _ => {}
            }
        }
        let radius = self.wp_loiter_radius();
        match mode {
            modes::LOITER => {
                self.fl.orbit = Some(Orbit {
                    center: here,
                    radius,
                    ccw: false,
                    alt,
                })
            }
            modes::RTL => {
                let r = self.params.get("RTL_RADIUS");
                let rtl_alt = self.params.get("RTL_ALTITUDE");
                self.fl.orbit = Some(Orbit {
                    center: self.home_pos,
                    radius: if r == 0.0 { radius } else { r.abs() },
                    ccw: r < 0.0,
                    alt: if rtl_alt < 0.0 { alt } else { rtl_alt },
                });
            }
            modes::GUIDED | modes::AVOID_ADSB if self.fl.orbit.is_none() || old != mode => {
                self.fl.orbit = Some(Orbit {
                    center: here,
                    radius,
                    ccw: false,
                    alt,
                });
            }
            modes::TAKEOFF if !self.ac.on_ground => {
                let course = self.ac.heading;
                let dist = self.params.get("TKOFF_DIST");
                self.fl.orbit = Some(Orbit {
                    center: here + V2::from_heading(course) * dist,
                    radius,
                    ccw: false,
                    alt: alt.max(self.params.get("TKOFF_ALT")),
                });
            }
            modes::FBWB | modes::CRUISE | modes::CIRCLE => {
                self.fl.hold = (self.ac.ground_vel.heading(), alt);
            }
            _ => {}
        }
        if mode == modes::AUTO {
            self.auto_enter();
        }
        if old != mode {
            tracing::info!(t = self.t_s(), mode = %modes::name(mode), "mode");
            self.send_heartbeat();
        }
        if mode == modes::RTL && old != mode {
            self.fl.rtl_autoland_checked = false;
            // RTL_AUTOLAND 2: straight to the landing sequence (ArduPlane's
            // ModeRTL::_enter): RTL is heard, then AUTO.
            if self.fl.armed && self.params.get("RTL_AUTOLAND") as i64 == 2 {
                self.auto_jump_to_landing();
            }
        }
    }

    /// RTL_AUTOLAND 1: once on the RTL circle at its altitude (within
    /// 10 m), the landing sequence, looked for once per RTL (ArduPlane's
    /// ModeRTL::update).
    fn rtl_autoland(&mut self) {
        if self.fl.mode != modes::RTL
            || self.fl.rtl_autoland_checked
            || !self.fl.armed
            || self.params.get("RTL_AUTOLAND") as i64 != 1
        {
            return;
        }
        let Some(o) = self.fl.orbit else {
            return;
        };
        let on_circle = (self.ac.pos - o.center).len() <= o.radius * 1.25;
        if on_circle && (self.ac.alt - o.alt).abs() < 10.0 {
            self.fl.rtl_autoland_checked = true;
            self.auto_jump_to_landing();
        }
    }

    /// Begins a take-off run from the ground.
    pub(crate) fn begin_takeoff(&mut self, alt: f64, pitch: f64, mission_seq: Option<u16>) {
        let delay = self.params.get("TKOFF_THR_DELAY").max(0.0) / 10.0;
        self.fl.takeoff = Some(Takeoff {
            start: self.ac.pos,
            course: self.ac.heading,
            alt,
            pitch,
            mission_seq,
            level_off_said: false,
            course_said: false,
        });
        self.fl.stage = Stage::TakeoffWait {
            trigger: self.now + (delay * 1e6) as u64,
        };
        self.fl.landed = false;
        self.info(format!(
            "Armed AUTO, xaccel = {:.1} m/s/s, waiting {:.1} sec",
            -0.0f64, delay
        ));
    }

    /// The controls for this step.
    pub(crate) fn control(&mut self) -> Controls {
        // Nobody on the sticks: throttle at minimum, wings level.
        let idle = Controls {
            airspeed: self.params.get("AIRSPEED_CRUISE"),
            ..Controls::default()
        };
        if !self.fl.armed {
            if self.ac.on_ground {
                self.fl.target = None;
                return idle;
            }
            let d = self.manual_demand();
            return self.controls_for(d, Priority::Speed);
        }
        // Ready to take off on the ground, in AUTO (take-off item) or TAKEOFF.
        if self.ac.on_ground && self.fl.stage == Stage::Ground && !self.fl.crashed {
            if self.fl.mode == modes::TAKEOFF {
                let alt = self.params.get("TKOFF_ALT");
                self.begin_takeoff(alt, 15.0, None);
            } else if self.fl.mode == modes::AUTO {
                self.auto_ground_check();
            }
        }
        match self.fl.stage {
            Stage::Ground | Stage::Stopped | Stage::Rollout { .. } => {
                self.fl.target = None;
                Controls {
                    steer: Some(self.ac.heading),
                    ..idle
                }
            }
            Stage::TakeoffWait { trigger } => {
                if self.now >= trigger {
                    self.fl.stage = Stage::TakeoffRoll;
                    self.info(format!(
                        "Triggered AUTO. GPS speed = {:.1}",
                        self.ac.groundspeed()
                    ));
                }
                idle
            }
            Stage::TakeoffRoll => self.takeoff_roll(),
            Stage::TakeoffClimb => self.takeoff_climb(),
            Stage::Approach | Stage::Flare => self.landing_controls(),
            Stage::Cruise => {
                let d = match self.fl.mode {
                    modes::AUTO => self.auto_demand(),
                    _ => self.mode_demand(),
                };
                // The mission may have started a landing or a take-off.
                match self.fl.stage {
                    Stage::Approach | Stage::Flare => self.landing_controls(),
                    Stage::TakeoffClimb => self.takeoff_climb(),
                    _ => self.controls_for(d, Priority::Speed),
                }
            }
        }
    }

    /// Turns a demand into controls with the energy law.
    pub(crate) fn controls_for(&mut self, d: Demand, priority: Priority) -> Controls {
        let limit = d.bank_limit.min(self.roll_limit());
        let bank = d.nav.bank(limit);
        let climb_max = self.params.get("TECS_CLMB_MAX");
        let sink_max = self.params.get("TECS_SINK_MAX");
        let (throttle, climb) = guidance::energy(
            &self.ac, &self.af, d.alt, d.climb_ff, d.airspeed, climb_max, sink_max,
        );
        let throttle = d.throttle.unwrap_or(throttle);
        self.fl.nav = d.nav;
        self.fl.nav_roll = bank;
        self.fl.target = d.target;
        self.fl.alt_target = d.alt;
        self.fl.speed_target = d.airspeed;
        Controls {
            throttle,
            bank,
            climb,
            airspeed: d.airspeed,
            priority,
            steer: None,
        }
    }

    /// Wings level, throttle at the stick's minimum: a glide.
    fn manual_demand(&self) -> Demand {
        let course = self.ac.heading;
        Demand {
            nav: Nav {
                nav_bearing: course,
                target_bearing: course,
                ..Nav::default()
            },
            alt: self.ac.alt,
            climb_ff: 0.0,
            airspeed: self.params.get("AIRSPEED_CRUISE"),
            bank_limit: 0.0,
            throttle: Some(0.0),
            target: None,
        }
    }

    /// Navigation of the modes other than AUTO, in flight.
    fn mode_demand(&mut self) -> Demand {
        let l1 = self.l1();
        let cruise = self.cruise_airspeed();
        let limit = self.roll_limit();
        match self.fl.mode {
            modes::RTL | modes::LOITER | modes::GUIDED | modes::AVOID_ADSB | modes::TAKEOFF => {
                let o = match self.fl.orbit {
                    Some(o) => o,
                    None => {
                        let o = Orbit {
                            center: self.ac.pos,
                            radius: self.wp_loiter_radius(),
                            ccw: false,
                            alt: self.ac.alt,
                        };
                        self.fl.orbit = Some(o);
                        o
                    }
                };
                self.orbit_demand(o, cruise, &l1)
            }
            modes::CIRCLE => {
                // ArduPlane's CIRCLE: a fixed bank of a third of the limit.
                let bank = limit / 3.0;
                let nav = Nav {
                    lat_acc: crate::model::G * bank.tan(),
                    nav_bearing: self.ac.heading,
                    target_bearing: self.ac.heading,
                    ..Nav::default()
                };
                Demand {
                    nav,
                    alt: self.fl.hold.1,
                    climb_ff: 0.0,
                    airspeed: cruise,
                    bank_limit: limit,
                    throttle: None,
                    target: None,
                }
            }
            modes::FBWB | modes::CRUISE => {
                let (course, alt) = self.fl.hold;
                Demand {
                    nav: guidance::course(&self.ac, course, &l1),
                    alt,
                    climb_ff: 0.0,
                    airspeed: cruise,
                    bank_limit: limit,
                    throttle: None,
                    target: None,
                }
            }
            _ => self.manual_demand(),
        }
    }

    pub(crate) fn orbit_demand(&self, o: Orbit, airspeed: f64, l1: &L1) -> Demand {
        Demand {
            nav: guidance::loiter(&self.ac, o.center, o.radius, o.ccw, l1),
            alt: o.alt,
            climb_ff: 0.0,
            airspeed,
            bank_limit: self.roll_limit(),
            throttle: None,
            target: Some((o.center, o.alt)),
        }
    }

    fn takeoff_roll(&mut self) -> Controls {
        let Some(mut to) = self.fl.takeoff else {
            self.fl.stage = Stage::Cruise;
            return Controls::default();
        };
        let gs = self.ac.groundspeed();
        if !to.course_said && gs >= 7.0 {
            to.course_said = true;
            let deg = to.course.to_degrees().round() as i64;
            self.info(format!("Autoland direction= {}", deg.rem_euclid(360)));
            self.info(format!(
                "Holding course {} at {:.1}m/s (0.0)",
                deg.rem_euclid(360) * 100,
                gs
            ));
        }
        self.fl.takeoff = Some(to);
        self.fl.target = Some((to.start + V2::from_heading(to.course) * 1000.0, to.alt));
        self.fl.alt_target = to.alt;
        Controls {
            throttle: 1.0,
            bank: 0.0,
            climb: self.params.get("TECS_CLMB_MAX").max(1.0),
            airspeed: self.cruise_airspeed(),
            priority: Priority::Speed,
            steer: Some(to.course),
        }
    }

    fn takeoff_climb(&mut self) -> Controls {
        let Some(mut to) = self.fl.takeoff else {
            self.fl.stage = Stage::Cruise;
            return Controls::default();
        };
        let remaining = to.alt - self.ac.alt;
        if remaining <= 0.0 {
            self.takeoff_complete(to);
            return self.control();
        }
        let l1 = self.l1();
        let ahead = to.start + V2::from_heading(to.course) * 10_000.0;
        let nav = guidance::leg(&self.ac, to.start, ahead, &l1);
        // Wings nearly level until clear of the ground.
        let bank_limit = if self.ac.alt < 15.0 { 5f64 } else { 15f64 }.to_radians();
        let band = (2.0 * self.ac.climb).max(5.0);
        let cruise = self.cruise_airspeed();
        let d = Demand {
            nav,
            alt: to.alt,
            climb_ff: 0.0,
            airspeed: cruise,
            bank_limit,
            throttle: Some(1.0),
            target: Some((ahead, to.alt)),
        };
        let mut c = self.controls_for(d, Priority::Speed);
        if self.ac.indicated_airspeed() > self.af.rotate_speed + 1.0 {
            // Full throttle at the take-off pitch: a climb path of about 24°
            // (10 m/s at 25 m/s), the rest of the power into speed (the
            // recording: 25 then 27 m/s while climbing at 10 m/s).
            c.priority = Priority::Height;
            c.climb = 0.4 * self.ac.airspeed;
        }
        if remaining <= band {
            if !to.level_off_said {
                to.level_off_said = true;
                self.info(format!(
                    "Takeoff level-off starting at {}m",
                    remaining.max(0.0) as i64
                ));
            }
            // Level off: the climb rate tapers with the height still to go.
            let climb = (remaining * 0.6).max(6.0).min(0.4 * self.ac.airspeed);
            c.throttle = guidance::throttle_for(&self.ac, &self.af, climb, cruise);
            c.climb = climb;
        }
        self.fl.takeoff = Some(to);
        c
    }

    fn takeoff_complete(&mut self, to: Takeoff) {
        let text = format!("Takeoff complete at {:.2}m", self.ac.alt);
        self.fl.takeoff = None;
        self.fl.stage = Stage::Cruise;
        match to.mission_seq {
            Some(seq) if self.fl.mode == modes::AUTO => self.auto_item_done(seq, vec![text]),
            _ => {
                self.info(text);
                // TAKEOFF mode: loiter TKOFF_DIST ahead at TKOFF_ALT.
                let dist = self.params.get("TKOFF_DIST");
                self.fl.orbit = Some(Orbit {
                    center: to.start + V2::from_heading(to.course) * dist,
                    radius: self.wp_loiter_radius(),
                    ccw: false,
                    alt: to.alt,
                });
            }
        }
    }

    /// Begins the approach of a LAND item from `from` to `to`.
    pub(crate) fn begin_landing(&mut self, from: V2, to: V2, land_alt: f64) {
        let start_alt = self.ac.alt;
        self.fl.landing = Some(Landing {
            from,
            to,
            start_alt,
            land_alt,
        });
        self.fl.stage = Stage::Approach;
        self.info(format!("Landing approach start at {:.1}m", start_alt));
        let dist = (to - self.ac.pos).len().max(1.0);
        let slope = ((start_alt - land_alt) / dist).atan().to_degrees();
        self.info_later(0.2, format!("Landing glide slope {:.1} degrees", slope));
    }

    fn landing_controls(&mut self) -> Controls {
        let Some(l) = self.fl.landing else {
            self.fl.stage = Stage::Cruise;
            return Controls::default();
        };
        let l1 = self.l1();
        let dir = (l.to - l.from).unit();
        let dir = if dir.len() < 0.5 {
            V2::from_heading(self.ac.heading)
        } else {
            dir
        };
        let beyond = l.to + dir * 2000.0;
        let mut nav = guidance::leg(&self.ac, l.from, beyond, &l1);
        nav.wp_dist = (l.to - self.ac.pos).len();
        let total = (l.to - l.from).dot(dir).max(1.0);
        let remaining = (l.to - self.ac.pos).dot(dir);
        let frac = (remaining / total).clamp(0.0, 1.0);
        let alt = l.land_alt + (l.start_alt - l.land_alt) * frac;
        let speed = self.land_airspeed();
        let height = self.ac.alt - l.land_alt;
        if self.fl.stage == Stage::Approach {
            let flare_alt = self.params.get("LAND_FLARE_ALT");
            let flare_sec = self.params.get("LAND_FLARE_SEC");
            let sink = -self.ac.climb;
            if height <= flare_alt || (sink > 0.0 && height <= sink * flare_sec) {
                self.fl.stage = Stage::Flare;
                self.info(format!(
                    "Flare {:.1}m sink={:.2} speed={:.1} dist={:.1}",
                    height, sink, self.ac.airspeed, nav.wp_dist
                ));
            }
        }
        // The glide slope descends as the aircraft moves along it.
        let along_speed = self.ac.ground_vel.dot(dir).max(0.0);
        let climb_ff = if remaining > 0.0 {
            -(l.start_alt - l.land_alt) / total * along_speed
        } else {
            0.0
        };
        let d = Demand {
            nav,
            alt,
            climb_ff,
            airspeed: speed,
            bank_limit: if self.fl.stage == Stage::Flare {
                5f64.to_radians()
            } else {
                self.roll_limit()
            },
            throttle: None,
            target: Some((l.to, l.land_alt)),
        };
        let mut c = self.controls_for(d, Priority::Speed);
        if self.fl.stage == Stage::Flare {
            // The flare: throttle off, the sink rate eased as the ground comes.
            let land_sink = self.params.get("TECS_LAND_SINK").max(0.1);
            c.throttle = 0.0;
            c.climb = -(0.4 * height + land_sink.max(0.7));
            c.priority = Priority::Height;
        }
        c
    }

    /// After a physics step: stage changes, touchdowns, crash detection,
    /// the automatic disarm.
    pub(crate) fn after_step(&mut self, contact: Option<Contact>) {
        let bank = self.ac.bank.abs();
        if bank > self.fl.max_bank {
            self.fl.max_bank = bank;
        }
        if self.is_flying() {
            self.fl.flight_time_us += self.cfg.step_us;
        }
        if self.fl.stage == Stage::TakeoffRoll && !self.ac.on_ground {
            self.fl.stage = Stage::TakeoffClimb;
        }
        if let Some(c) = contact {
            self.touchdown(c);
        }
        if let Stage::Rollout { landing } = self.fl.stage {
            if self.ac.groundspeed() < 0.5 {
                self.fl.stage = Stage::Stopped;
                self.fl.stopped_at = Some(self.now);
                if landing {
                    self.fl.landed = true;
                    self.send_stats();
                }
            }
        }
        if let Some(at) = self.fl.crash_at {
            if !self.fl.crashed && self.now >= at + 2_500_000 {
                self.fl.crashed = true;
                self.text(
                    MavSeverity::MAV_SEVERITY_EMERGENCY,
                    "Crash detected. No action taken",
                );
            }
        }
        // LAND_DISARMDELAY after the landing roll stops.
        let delay = self.params.get("LAND_DISARMDELAY");
        if self.fl.armed && self.fl.landed && delay > 0.0 && self.fl.stage == Stage::Stopped {
            if let Some(at) = self.fl.stopped_at {
                if self.now >= at + (delay * 1e6) as u64 {
                    self.disarm(true);
                    if let Some(l) = self.fl.landing.take() {
                        let d = (l.to - self.ac.pos).len();
                        self.info_later(0.1, format!("Distance from LAND point={:.2}m", d));
                    }
                }
            }
        }
        self.battery_check();
        self.rtl_autoland();
    }

    fn touchdown(&mut self, c: Contact) {
        let landing = matches!(self.fl.stage, Stage::Approach | Stage::Flare);
        self.info(format!("SIM Hit ground at {:.6} m/s", c.sink));
        self.truth.touchdowns.push(Touchdown {
            time_s: self.t_s(),
            sink: c.sink,
            airspeed: c.airspeed,
            landing,
        });
        self.fl.stage = Stage::Rollout { landing };
        if !landing {
            self.fl.crash_at = Some(self.now);
            self.fl.takeoff = None;
        }
    }

    /// The battery failsafe (BATT_LOW_MAH / BATT_CRT_MAH remaining, 0 = off).
    fn battery_check(&mut self) {
        let cap = self.af.battery_capacity_mah;
        let left = cap - self.ac.battery.consumed_mah;
        let low = self.params.get("BATT_LOW_MAH");
        let crit = self.params.get("BATT_CRT_MAH");
        let level = if crit > 0.0 && left <= crit {
            2
        } else if low > 0.0 && left <= low {
            1
        } else {
            0
        };
        if level > self.fl.battery_failsafe {
            self.fl.battery_failsafe = level;
            let kind = if level == 2 { "critical" } else { "low" };
            self.text(
                MavSeverity::MAV_SEVERITY_WARNING,
                format!(
                    "Battery 1 is {} {:.2}V used {:.0} mAh",
                    kind, self.ac.battery.voltage, self.ac.battery.consumed_mah
                ),
            );
            let action = if level == 2 {
                self.params.get("BATT_FS_CRT_ACT")
            } else {
                self.params.get("BATT_FS_LOW_ACT")
            };
            if self.is_flying() {
                match action as i64 {
                    1 => self.enter_mode(modes::RTL),
                    2 if !self.auto_jump_to_landing() => self.enter_mode(modes::RTL),
                    _ => {}
                }
            }
        }
    }

    /// Whether a nav target lies behind the aircraft (for tests).
    #[allow(dead_code)]
    pub(crate) fn bearing_error(&self, to: V2) -> f64 {
        wrap_pi((to - self.ac.pos).heading() - self.ac.heading)
    }
}

#[cfg(test)]
#[allow(deprecated)] // REQUEST_DATA_STREAM, as ArduPilot's clients still send it
mod tests {
    use super::*;
    use crate::mission::cmd;
    use crate::vehicle::testing::*;
    use mavlink::dialects::ardupilotmega::*;

    /// The recording's mission, relative to home: take-off to 50 m, a
    /// 400 m × 400 m box, down to 25 m, land 100 m north of home.
    fn box_mission(b: &Bench) -> Vec<crate::mission::MissionItem> {
        let v = &b.v;
        let mut to = item(v, cmd::NAV_TAKEOFF, 0.0, 0.0, 50.0);
        to.param1 = 15.0;
        vec![
            to,
            item(v, cmd::NAV_WAYPOINT, 400.0, 0.0, 80.0),
            item(v, cmd::NAV_WAYPOINT, 400.0, 400.0, 80.0),
            item(v, cmd::NAV_WAYPOINT, -600.0, 400.0, 60.0),
            item(v, cmd::NAV_WAYPOINT, -600.0, 0.0, 40.0),
            item(v, cmd::NAV_WAYPOINT, -300.0, 0.0, 25.0),
            item(v, cmd::NAV_LAND, 100.0, 0.0, 0.0),
        ]
    }

    #[test]
    fn auto_mission_takes_off_flies_lands_and_disarms() {
        let mut b = Bench::new(quick());
        b.run_to(4.0);
        let mission = box_mission(&b);
        assert_eq!(b.upload(&mission), MavMissionResult::MAV_MISSION_ACCEPTED);
        assert_eq!(
            b.set_mode(modes::AUTO),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_ACCEPTED));
        assert!(b.run_until(400.0, |v| !v.fl.armed), "never disarmed");
        let s = b.v.state();
        let texts = b.texts();
        let seqs: Vec<u16> = s.reached.iter().map(|r| r.seq).collect();
        for t in &s.statustexts {
            println!("{:7.2} {}", t.time_s, t.text);
        }
        println!(
            "{:?}\nland at n={:.1} e={:.1} t={:.1}",
            s.touchdowns, s.north, s.east, s.time_s
        );
        assert_eq!(seqs, vec![1, 2, 3, 4, 5, 6], "{texts:?}");
        assert!(
            texts.iter().any(|t| t.starts_with("Takeoff complete at 5")),
            "{texts:?}"
        );
        assert!(texts.iter().any(|t| t == "Mission: 7 Land"));
        assert!(texts.iter().any(|t| t.starts_with("Flare ")));
        assert!(texts.iter().any(|t| t == "Auto disarmed"));
        assert_eq!(s.touchdowns.len(), 1);
        assert!(
            s.touchdowns[0].landing && s.touchdowns[0].sink < 1.5,
            "{:?}",
            s.touchdowns
        );
        assert!(s.landed && !s.crashed && s.on_ground);
        assert!(s.max_bank <= 45.0 + 1e-9);
        // Stopped near the land point (100 m north of home), on its line
        // (ArduPlane SITL stopped 15 m short of it; this model ~50 m past).
        assert!(s.east.abs() < 15.0, "east {}", s.east);
        assert!((40.0..180.0).contains(&s.north), "north {}", s.north);
    }

    #[test]
    fn rtl_returns_and_loiters_over_home() {
        let mut b = Bench::airborne(quick());
        // Away to a point 1.5 km east, in GUIDED.
        let (lat, lon) = crate::geo::location(&b.v.cfg.home, crate::geo::V2::new(0.0, 1500.0));
        let r = b.command_int(
            MavCmd::MAV_CMD_DO_REPOSITION,
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            [-1.0, 1.0, 0.0, 0.0],
            crate::geo::e7(lat),
            crate::geo::e7(lon),
            60.0,
        );
        assert_eq!(r, Some(MavResult::MAV_RESULT_ACCEPTED));
        assert_eq!(b.v.state().mode, "GUIDED");
        assert!(b.run_until(200.0, |v| v.ac.pos.e > 1300.0));
        let r = b.command(MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH, [0.0; 7]);
        assert_eq!(r, Some(MavResult::MAV_RESULT_ACCEPTED));
        assert_eq!(b.v.state().mode, "RTL");
        let t = b.v.state().time_s;
        b.run_to(t + 150.0);
        // Circling home at WP_LOITER_RAD (60 m) and RTL_ALTITUDE (100 m).
        let mut worst: f64 = 0.0;
        for _ in 0..20 {
            b.run_to(b.v.state().time_s + 1.0);
            let s = b.v.state();
            worst = worst.max((s.north.hypot(s.east) - 60.0).abs());
            assert!((s.alt - 100.0).abs() < 5.0, "alt {}", s.alt);
            assert!(s.bank.abs() <= 45.0 + 1e-9);
        }
        assert!(worst < 20.0, "off the RTL circle by {worst} m");
        assert!(b.v.state().flying && b.v.state().armed);
    }

    #[test]
    fn engine_failure_glides_then_crashes_outside_a_landing() {
        let mut b = Bench::airborne(quick());
        b.send(MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
            req_message_rate: 4,
            target_system: 1,
            target_component: 1,
            req_stream_id: MavDataStream::MAV_DATA_STREAM_ALL,
            start_stop: 1,
        }));
        // Loiter, wings nearly level on a large circle.
        let r = b.command_int(
            MavCmd::MAV_CMD_DO_REPOSITION,
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            [-1.0, 1.0, 600.0, 0.0],
            crate::geo::e7(b.v.cfg.home.lat + 0.01),
            crate::geo::e7(b.v.cfg.home.lon),
            50.0,
        );
        assert_eq!(r, Some(MavResult::MAV_RESULT_ACCEPTED));
        b.run_to(b.v.state().time_s + 20.0);
        let s0 = b.v.state();
        b.v.inject(crate::Fault::EngineFailure);
        let from = b.got.len();
        assert!(b.run_until(400.0, |v| v.fl.crashed), "never crashed");
        let s = b.v.state();
        // EFI_STATUS: the rpm falls to 0 while the autopilot asks for throttle.
        let efi: Vec<(f32, f32)> = b
            .since(from, "EFI_STATUS")
            .into_iter()
            .map(|(_, _, m)| match m {
                MavMessage::EFI_STATUS(e) => (e.rpm, e.throttle_out),
                _ => unreachable!(),
            })
            .collect();
        // (from 2 s after the failure until the touchdown, as the elaboration's
        // engine_failure rule reads it)
        let gliding: Vec<&(f32, f32)> = efi
            .iter()
            .skip(8)
            .take_while(|(_, thr)| *thr > 0.0)
            .collect();
        assert!(gliding.len() > 20, "{efi:?}");
        assert!(
            gliding.iter().all(|(rpm, thr)| *rpm < 500.0 && *thr > 20.0),
            "{efi:?}"
        );
        // The glide: distance over height lost near the glide ratio (11).
        let td = s.touchdowns.last().unwrap();
        assert!(!td.landing);
        let dist: f64 = {
            // Integrated along the track: the ground speed in sim time.
            let hud: Vec<f64> = b
                .since(from, "VFR_HUD")
                .into_iter()
                .filter_map(|(_, _, m)| match m {
                    MavMessage::VFR_HUD(h) if h.alt > b.v.cfg.home.alt_amsl as f32 + 0.5 => {
                        Some(h.groundspeed as f64)
                    }
                    _ => None,
                })
                .collect();
            hud.iter().sum::<f64>() * 0.25
        };
        let ratio = dist / s0.alt;
        // ArduPlane SITL's engine-out glide, 4.3:1 (Airframe), stretched
        // a little by the speed traded from 22 to 15 m/s.
        assert!((3.5..6.0).contains(&ratio), "glide ratio {ratio}");
        let texts = b.texts();
        assert!(texts.iter().any(|t| t.starts_with("SIM Hit ground")));
        assert_eq!(texts.last().unwrap(), "Crash detected. No action taken");
        assert_eq!(s.system_status, MavState::MAV_STATE_EMERGENCY as u8);
        assert!(s.crashed && !s.flying && s.on_ground);
    }

    #[test]
    fn an_engine_out_touchdown_in_auto_land_is_a_landing() {
        let mut b = Bench::new(crate::SimConfig {
            faults: crate::Schedule::parse(&["engine_failure@wp3"]).unwrap(),
            ..quick()
        });
        b.run_to(4.0);
        let v = &b.v;
        let mut to = item(v, cmd::NAV_TAKEOFF, 0.0, 0.0, 40.0);
        to.param1 = 15.0;
        let mission = vec![
            to,
            item(v, cmd::NAV_WAYPOINT, 500.0, 0.0, 40.0),
            item(v, cmd::NAV_WAYPOINT, 500.0, 300.0, 30.0),
            item(v, cmd::NAV_LAND, 200.0, 300.0, 0.0),
        ];
        assert_eq!(b.upload(&mission), MavMissionResult::MAV_MISSION_ACCEPTED);
        assert_eq!(
            b.set_mode(modes::AUTO),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_ACCEPTED));
        assert!(b.run_until(300.0, |v| !v.fl.armed), "{:?}", b.texts());
        let s = b.v.state();
        assert_eq!(s.faults.len(), 1);
        assert!(!s.engine_running);
        assert!(
            s.touchdowns.len() == 1 && s.touchdowns[0].landing,
            "{:?}",
            s.touchdowns
        );
        assert!(s.landed && !s.crashed);
        assert!(b.texts().contains(&"Auto disarmed".to_owned()));
    }

    #[test]
    fn nav_takeoff_is_refused_as_arduplane_without_quadplane() {
        let mut b = Bench::new(quick());
        b.run_to(4.0);
        let r = b.command(
            MavCmd::MAV_CMD_NAV_TAKEOFF,
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 30.0],
        );
        assert_eq!(r, Some(MavResult::MAV_RESULT_FAILED));
        let r = b.command_int(
            MavCmd::MAV_CMD_NAV_TAKEOFF,
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            0,
            0,
            30.0,
        );
        assert_eq!(r, Some(MavResult::MAV_RESULT_DENIED));
        // Q modes need a QuadPlane; unknown modes fail.
        assert_eq!(b.set_mode(20), Some(MavResult::MAV_RESULT_FAILED));
        assert_eq!(b.set_mode(99), Some(MavResult::MAV_RESULT_FAILED));
        assert_eq!(
            b.set_mode(modes::FBWA),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        assert_eq!(b.v.state().mode, "FLY_BY_WIRE_A");
    }

    /// RTL with RTL_AUTOLAND as on ArduPlane 4.7 SITL (checked on the real
    /// firmware with 2: RTL heard, then AUTO at once and "Landing sequence
    /// start"); with 1 the landing sequence once on the RTL circle.
    #[test]
    fn rtl_autoland_flies_the_landing_sequence() {
        for autoland in [2.0, 1.0] {
            let mut b = Bench::airborne(crate::SimConfig {
                params: vec![("RTL_AUTOLAND".into(), autoland)],
                ..quick()
            });
            let v = &b.v;
            let mut land_start = item(v, cmd::DO_LAND_START, 0.0, 0.0, 0.0);
            (land_start.x, land_start.y) = (0, 0);
            let mission = vec![
                item(v, cmd::NAV_WAYPOINT, 800.0, 0.0, 60.0),
                land_start,
                item(v, cmd::NAV_WAYPOINT, 500.0, 0.0, 40.0),
                item(v, cmd::NAV_LAND, 0.0, 0.0, 0.0),
            ];
            assert_eq!(b.upload(&mission), MavMissionResult::MAV_MISSION_ACCEPTED);
            let from = b.got.len();
            assert_eq!(b.set_mode(modes::RTL), Some(MavResult::MAV_RESULT_ACCEPTED));
            if autoland == 2.0 {
                let heard: Vec<u32> = b
                    .since(from, "HEARTBEAT")
                    .into_iter()
                    .filter(|(_, h, _)| h.component_id == 1)
                    .map(|(_, _, m)| match m {
                        MavMessage::HEARTBEAT(h) => h.custom_mode,
                        _ => unreachable!(),
                    })
                    .collect();
                assert_eq!(heard, vec![modes::RTL, modes::AUTO]);
            } else {
                assert_eq!(b.v.fl.mode, modes::RTL);
                let start = b.v.t_s();
                assert!(b.run_until(start + 120.0, |v| v.fl.mode == modes::AUTO));
                let o = b.v.fl.orbit.expect("the RTL circle");
                let d = (b.v.ac.pos - b.v.home_pos).len();
                assert!(d <= o.radius * 1.25 + 1.0, "{d} m from home");
                assert!((b.v.ac.alt - 100.0).abs() < 10.0, "at {} m", b.v.ac.alt);
            }
            assert!(b.texts().contains(&"Landing sequence start".to_owned()));
            assert_eq!(
                b.v.auto.current, 3,
                "RTL_AUTOLAND {autoland}: the waypoint after DO_LAND_START"
            );
            let start = b.v.t_s();
            assert!(
                b.run_until(start + 300.0, |v| v.fl.landed),
                "RTL_AUTOLAND {autoland}: not landed: {:?}",
                b.texts()
            );
        }
    }
}
