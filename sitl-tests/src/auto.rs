//! AUTO: the mission run as ArduPlane's AP_Mission runs it. The current
//! navigation command flies; the DO commands that follow it run while it
//! flies; a navigation command done sends MISSION_ITEM_REACHED and starts
//! the next; the end of the mission switches to RTL. Waypoints are reached
//! within the turn distance (WP_RADIUS scaled by the next turn) or when
//! their finish line is passed.

use mavlink::dialects::ardupilotmega::{MavMessage, MISSION_ITEM_REACHED_DATA};

use crate::geo::{self, V2};
use crate::guidance;
use crate::mission::{cmd, MissionItem};
use crate::modes;
use crate::nav_state::{Demand, Orbit, Stage, Takeoff};
use crate::state::{PayloadAction, PayloadKind, Reached};
use crate::vehicle::Vehicle;

impl Vehicle {
    fn item(&self, seq: u16) -> Option<&MissionItem> {
        self.mission.get(seq as usize)
    }

    /// An item's position (metres from the boot home) and altitude above
    /// home; "here" when it has no position.
    pub(crate) fn item_target(&self, it: &MissionItem) -> (V2, f64) {
        let pos = if it.has_position() {
            geo::offset(self.origin(), it.lat(), it.lon())
        } else {
            self.ac.pos
        };
        let alt = it.alt_above_home(self.origin().alt_amsl);
        (pos, alt)
    }

    /// The first navigation command at or after `seq`.
    fn next_nav(&self, seq: u16) -> Option<u16> {
        (seq as usize..self.mission.len())
            .find(|&i| self.mission[i].is_nav())
            .map(|i| i as u16)
    }

    /// Entering AUTO: start or resume the mission.
    pub(crate) fn auto_enter(&mut self) {
        if self.mission.len() <= 1 {
            self.auto_complete();
            return;
        }
        if self.auto.complete || self.auto.current == 0 {
            self.auto.complete = false;
            self.auto.current = 0;
            self.auto.started = false;
        }
        self.auto.running = true;
        self.auto.from = Some((self.ac.pos, self.ac.alt));
        let first = if self.auto.current == 0 {
            1
        } else {
            self.auto.current
        };
        self.auto_start_at(first);
    }

    /// Leaving AUTO: the mission stops where it is.
    pub(crate) fn auto_stop(&mut self) {
        self.auto.running = false;
        self.auto.started = false;
        if matches!(self.fl.stage, Stage::TakeoffWait { .. }) {
            self.fl.stage = Stage::Ground;
            self.fl.takeoff = None;
        }
    }

    /// Starts the mission at `seq`: the DO commands before the first
    /// navigation command run now, then that command starts.
    fn auto_start_at(&mut self, seq: u16) {
        let Some(nav) = self.next_nav(seq) else {
            self.auto_complete();
            return;
        };
        for i in seq..nav {
            self.run_do(i);
        }
        self.start_nav(nav);
    }

    fn auto_complete(&mut self) {
        self.auto.complete = true;
        self.auto.running = false;
        self.auto.started = false;
        if self.fl.mode == modes::AUTO {
            self.info("Mission complete, changing mode to RTL");
            self.enter_mode(modes::RTL);
        }
    }

    /// Starts navigation command `seq`.
    fn start_nav(&mut self, seq: u16) {
        let Some(it) = self.item(seq).cloned() else {
            self.auto_complete();
            return;
        };
        self.auto.current = seq;
        self.auto.do_cursor = seq + 1;
        self.auto.started = true;
        self.auto.loiter_since = None;
        self.info(format!("Mission: {} {}", seq, it.type_name()));
        let (target, alt) = self.item_target(&it);
        let from = self.auto.from.unwrap_or((self.ac.pos, self.ac.alt));
        self.auto.turn_angle = self.turn_angle(seq, from.0, target);
        match it.command {
            cmd::NAV_TAKEOFF => {
                if self.ac.on_ground {
                    // Waits for arming (auto_ground_check).
                } else if self.ac.alt < alt {
                    self.fl.takeoff = Some(Takeoff {
                        start: self.ac.pos,
                        course: self.ac.heading,
                        alt,
                        pitch: it.param1 as f64,
                        mission_seq: Some(seq),
                        level_off_said: false,
                        course_said: true,
                    });
                    self.fl.stage = Stage::TakeoffClimb;
                } else {
                    self.auto_item_done(seq, vec![]);
                }
            }
            cmd::NAV_LAND if !self.ac.on_ground => {
                self.begin_landing(from.0, target, alt.max(0.0));
            }
            _ => {}
        }
    }

    /// The turn at waypoint `seq` toward the next positional command (90°
    /// when unknown, as ArduPlane).
    fn turn_angle(&self, seq: u16, from: V2, at: V2) -> f64 {
        let next = self
            .next_nav(seq + 1)
            .and_then(|i| self.item(i))
            .filter(|it| it.has_position());
        match next {
            Some(n) => {
                let (to, _) = self.item_target(n);
                let a = at - from;
                let b = to - at;
                if a.len() < 1.0 || b.len() < 1.0 {
                    return 90.0;
                }
                geo::wrap_pi(b.heading() - a.heading()).abs().to_degrees()
            }
            None => 90.0,
        }
    }

    /// A mission item done: MISSION_ITEM_REACHED, then the texts, then the
    /// next navigation command.
    pub(crate) fn auto_item_done(&mut self, seq: u16, texts: Vec<String>) {
        self.reached(seq);
        for t in texts {
            self.info(t);
        }
        let target = self
            .item(seq)
            .cloned()
            .map(|it| self.item_target(&it))
            .unwrap_or((self.ac.pos, self.ac.alt));
        let from = match self.item(seq).map(|it| it.command) {
            Some(cmd::NAV_TAKEOFF) | None => (self.ac.pos, target.1),
            _ => target,
        };
        self.auto.from = Some(from);
        self.auto.started = false;
        // DO commands not yet run, then the next navigation command.
        let cursor = self.auto.do_cursor.max(seq + 1);
        match self.next_nav(cursor) {
            Some(nav) => {
                for i in cursor..nav {
                    self.run_do(i);
                }
                self.start_nav(nav);
            }
            None => {
                for i in cursor..self.mission.len() as u16 {
                    self.run_do(i);
                }
                self.auto_complete();
            }
        }
    }

    pub(crate) fn reached(&mut self, seq: u16) {
        self.last_reached = seq;
        self.send(MavMessage::MISSION_ITEM_REACHED(
            MISSION_ITEM_REACHED_DATA { seq },
        ));
        self.truth.reached.push(Reached {
            seq,
            time_s: self.t_s(),
        });
        self.faults_on_reached(seq);
    }

    /// Runs DO command `seq` (a navigation command is skipped).
    pub(crate) fn run_do(&mut self, seq: u16) {
        let Some(it) = self.item(seq).cloned() else {
            return;
        };
        if it.is_nav() {
            return;
        }
        self.info(format!("Mission: {} {}", seq, it.type_name()));
        match it.command {
            cmd::DO_CHANGE_SPEED => {
                self.do_change_speed(it.param1, it.param2, it.param3);
            }
            cmd::DO_SET_RELAY => {
                self.set_relay(it.param1, it.param2, Some(seq));
            }
            cmd::DO_SET_SERVO => {
                self.set_servo(it.param1, it.param2, Some(seq));
            }
            _ => {}
        }
        self.reached(seq);
        self.auto.do_cursor = self.auto.do_cursor.max(seq + 1);
    }

    /// In AUTO on the ground, armed: a TAKEOFF item starts the take-off.
    pub(crate) fn auto_ground_check(&mut self) {
        if !self.auto.running || !self.auto.started {
            return;
        }
        let seq = self.auto.current;
        let Some(it) = self.item(seq).cloned() else {
            return;
        };
        if it.command == cmd::NAV_TAKEOFF {
            let (_, alt) = self.item_target(&it);
            self.begin_takeoff(alt, it.param1 as f64, Some(seq));
        }
    }

    /// The current navigation command's demand, in flight; checks whether
    /// it is done.
    pub(crate) fn auto_demand(&mut self) -> Demand {
        let l1 = self.l1();
        let cruise = self.cruise_airspeed();
        // One pending DO command per step, as AP_Mission.
        let cursor = self.auto.do_cursor;
        if self.auto.running
            && (cursor as usize) < self.mission.len()
            && !self.mission[cursor as usize].is_nav()
        {
            self.run_do(cursor);
        }
        let seq = self.auto.current;
        let it = match self.item(seq).cloned() {
            Some(it) if self.auto.running => it,
            _ => {
                let o = Orbit {
                    center: self.ac.pos,
                    radius: self.wp_loiter_radius(),
                    ccw: false,
                    alt: self.ac.alt,
                };
                return self.orbit_demand(o, cruise, &l1);
            }
        };
        if !self.auto.started {
            self.start_nav(seq);
        }
        let (target, alt) = self.item_target(&it);
        let from = self.auto.from.unwrap_or((self.ac.pos, self.ac.alt));
        match it.command {
            cmd::NAV_LOITER_UNLIM | cmd::NAV_LOITER_TIME | cmd::NAV_LOITER_TURNS => {
                let r = it.param3 as f64;
                let radius = if r.abs() < 1.0 {
                    self.wp_loiter_radius()
                } else {
                    r.abs()
                };
                let o = Orbit {
                    center: target,
                    radius,
                    ccw: r < 0.0,
                    alt,
                };
                let dist = (self.ac.pos - target).len();
                if self.auto.loiter_since.is_none() && dist <= radius + 20.0 {
                    self.auto.loiter_since = Some(self.now);
                }
                let hold = match it.command {
                    cmd::NAV_LOITER_TIME => Some(it.param1.max(0.0) as f64),
                    cmd::NAV_LOITER_TURNS => {
                        let v = self.ac.airspeed.max(1.0);
                        Some(it.param1.max(0.0) as f64 * std::f64::consts::TAU * radius / v)
                    }
                    _ => None,
                };
                if let (Some(hold), Some(since)) = (hold, self.auto.loiter_since) {
                    if self.now >= since + (hold * 1e6) as u64 {
                        self.auto_item_done(seq, vec![]);
                    }
                }
                self.orbit_demand(o, cruise, &l1)
            }
            cmd::NAV_RETURN_TO_LAUNCH => {
                let rtl_alt = self.params.get("RTL_ALTITUDE");
                let o = Orbit {
                    center: self.home_pos,
                    radius: self.wp_loiter_radius(),
                    ccw: false,
                    alt: if rtl_alt < 0.0 { self.ac.alt } else { rtl_alt },
                };
                let dist = (self.ac.pos - self.home_pos).len();
                if dist <= self.params.get("WP_RADIUS").max(o.radius) {
                    self.auto_item_done(seq, vec!["Reached RTL location".to_owned()]);
                }
                self.orbit_demand(o, cruise, &l1)
            }
            cmd::NAV_LAND | cmd::NAV_TAKEOFF => {
                // Handled by the landing and take-off stages; meanwhile go there.
                self.waypoint_demand(from, (target, alt), cruise, &l1)
            }
            _ => {
                // WAYPOINT and the other positional commands.
                let p = self.ac.pos;
                let dist = (target - p).len();
                let acceptance = if it.param1 > 0.0 {
                    it.param1 as f64
                } else {
                    self.params.get("WP_RADIUS") * self.auto.turn_angle.min(90.0) / 90.0
                };
                let leg = target - from.0;
                let passed = leg.len() > 1.0 && (p - from.0).dot(leg.unit()) >= leg.len();
                if dist <= acceptance {
                    self.auto_item_done(
                        seq,
                        vec![format!(
                            "Reached waypoint #{} dist {}m",
                            seq,
                            dist.round() as i64
                        )],
                    );
                } else if passed {
                    self.auto_item_done(
                        seq,
                        vec![format!(
                            "Passed waypoint #{} dist {}m",
                            seq,
                            dist.round() as i64
                        )],
                    );
                }
                self.waypoint_demand(from, (target, alt), cruise, &l1)
            }
        }
    }

    /// Flies the leg `from` → `to`, the altitude moving along the leg.
    fn waypoint_demand(
        &self,
        from: (V2, f64),
        to: (V2, f64),
        airspeed: f64,
        l1: &guidance::L1,
    ) -> Demand {
        let nav = guidance::leg(&self.ac, from.0, to.0, l1);
        let leg = to.0 - from.0;
        let frac = if leg.len() > 1.0 {
            ((self.ac.pos - from.0).dot(leg.unit()) / leg.len()).clamp(0.0, 1.0)
        } else {
            1.0
        };
        // The height moves from one waypoint's to the next along the leg.
        let climb_ff = if leg.len() > 1.0 && frac < 1.0 {
            (to.1 - from.1) / leg.len() * self.ac.ground_vel.dot(leg.unit()).max(0.0)
        } else {
            0.0
        };
        Demand {
            nav,
            alt: from.1 + (to.1 - from.1) * frac,
            climb_ff,
            airspeed,
            bank_limit: self.roll_limit(),
            throttle: None,
            target: Some(to),
        }
    }

    /// MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT: false when `seq` is
    /// not an item.
    pub(crate) fn auto_set_current(&mut self, seq: u16) -> bool {
        let seq = seq.max(1);
        if seq as usize >= self.mission.len() {
            return false;
        }
        self.auto.complete = false;
        self.auto.from = Some((self.ac.pos, self.ac.alt));
        if self.fl.mode == modes::AUTO {
            self.auto.running = true;
            // A take-off or landing under way is abandoned.
            if matches!(
                self.fl.stage,
                Stage::Approach | Stage::Flare | Stage::TakeoffClimb
            ) {
                self.fl.stage = Stage::Cruise;
                self.fl.landing = None;
                self.fl.takeoff = None;
            }
            self.auto_start_at(seq);
        } else {
            self.auto.current = self.next_nav(seq).unwrap_or(seq);
            self.auto.started = false;
            self.auto.do_cursor = seq;
        }
        true
    }

    /// DO_LAND_START: the nearest DO_LAND_START item becomes current and
    /// the mode AUTO. False when the mission has none.
    pub(crate) fn auto_jump_to_landing(&mut self) -> bool {
        let here = self.ac.pos;
        let best = self
            .mission
            .iter()
            .enumerate()
            .skip(1)
            .filter(|(_, it)| it.command == cmd::DO_LAND_START)
            .map(|(i, it)| {
                let d = if it.has_position() {
                    (geo::offset(self.origin(), it.lat(), it.lon()) - here).len()
                } else {
                    0.0
                };
                (i as u16, d)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let Some((seq, _)) = best else {
            self.text(
                mavlink::dialects::ardupilotmega::MavSeverity::MAV_SEVERITY_WARNING,
                "Unable to start landing sequence",
            );
            return false;
        };
        self.info("Landing sequence start");
        self.auto.complete = false;
        self.auto.current = seq;
        self.auto.started = false;
        if self.fl.mode != modes::AUTO {
            self.fl.mode = modes::AUTO;
            self.send_heartbeat();
        }
        self.auto.running = true;
        self.auto.from = Some((self.ac.pos, self.ac.alt));
        if matches!(
            self.fl.stage,
            Stage::TakeoffClimb | Stage::Approach | Stage::Flare
        ) {
            self.fl.stage = Stage::Cruise;
        }
        self.auto_start_at(seq);
        true
    }

    /// DO_SET_RELAY (command or mission item).
    pub(crate) fn set_relay(
        &mut self,
        instance: f32,
        setting: f32,
        mission_seq: Option<u16>,
    ) -> bool {
        let i = instance as i64;
        if !(0..self.relays.len() as i64).contains(&i) {
            return false;
        }
        let on = setting >= 0.5;
        self.relays[i as usize] = on;
        let at = self.fix();
        self.truth.payload_actions.push(PayloadAction {
            at,
            kind: PayloadKind::Relay {
                instance: i as u8,
                on,
            },
            mission_seq,
        });
        true
    }

    /// DO_SET_SERVO (command or mission item): outputs 5..16 are free; 1..4
    /// fly the aircraft and are refused.
    pub(crate) fn set_servo(&mut self, channel: f32, pwm: f32, mission_seq: Option<u16>) -> bool {
        let ch = channel as i64;
        if !(5..=16).contains(&ch) || !(0.0..=3000.0).contains(&pwm) {
            return false;
        }
        self.servos[(ch - 1) as usize] = pwm as u16;
        let at = self.fix();
        self.truth.payload_actions.push(PayloadAction {
            at,
            kind: PayloadKind::Servo {
                channel: ch as u8,
                pwm: pwm as u16,
            },
            mission_seq,
        });
        true
    }

    /// DO_CHANGE_SPEED: speed type 0 airspeed, 1 ground speed; −2 restores
    /// the cruise airspeed. False when the airspeed is out of range.
    pub(crate) fn do_change_speed(&mut self, kind: f32, speed: f32, throttle: f32) -> bool {
        let mut ok = false;
        match kind as i64 {
            0 => {
                if speed == -2.0 {
                    self.fl.airspeed_override = None;
                    ok = true;
                } else if (self.params.get("AIRSPEED_MIN")..=self.params.get("AIRSPEED_MAX"))
                    .contains(&(speed as f64))
                {
                    self.fl.airspeed_override = Some(speed as f64);
                    self.info(format!("Set airspeed {} m/s", speed as u32));
                    ok = true;
                }
            }
            1 if speed >= 0.0 => {
                self.fl.min_groundspeed = speed as f64;
                self.info(format!("Set groundspeed {}", speed as u32));
                ok = true;
            }
            _ => {}
        }
        if throttle > 0.0 && throttle <= 100.0 {
            ok = true;
        }
        ok
    }
}

#[cfg(test)]
mod tests {
    use crate::mission::cmd;
    use crate::modes;
    use crate::state::PayloadKind;
    use crate::vehicle::testing::*;
    use mavlink::dialects::ardupilotmega::*;

    #[test]
    fn loiter_time_do_commands_and_return_to_launch_items() {
        let mut b = Bench::airborne(quick());
        let v = &b.v;
        let mut loiter = item(v, cmd::NAV_LOITER_TIME, 600.0, 0.0, 60.0);
        loiter.param1 = 30.0; // seconds
        let mut speed = item(v, cmd::DO_CHANGE_SPEED, 0.0, 0.0, 0.0);
        speed.frame = MavFrame::MAV_FRAME_MISSION;
        (speed.x, speed.y, speed.param1, speed.param2) = (0, 0, 0.0, 26.0);
        let mut relay = item(v, cmd::DO_SET_RELAY, 0.0, 0.0, 0.0);
        relay.frame = MavFrame::MAV_FRAME_MISSION;
        (relay.x, relay.y, relay.param1, relay.param2) = (0, 0, 2.0, 1.0);
        let mut rtl = item(v, cmd::NAV_RETURN_TO_LAUNCH, 0.0, 0.0, 0.0);
        (rtl.x, rtl.y) = (0, 0);
        let mission = vec![
            item(v, cmd::NAV_WAYPOINT, 400.0, 400.0, 60.0),
            speed,
            relay,
            loiter,
            rtl,
        ];
        assert_eq!(b.upload(&mission), MavMissionResult::MAV_MISSION_ACCEPTED);
        assert_eq!(
            b.command(MavCmd::MAV_CMD_MISSION_START, [0.0; 7]),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let start = b.v.state().time_s;
        assert!(
            b.run_until(start + 400.0, |v| v.fl.mode == modes::RTL),
            "{:?}",
            b.texts()
        );
        let s = b.v.state();
        let reached: Vec<(u16, f64)> = s.reached.iter().map(|r| (r.seq, r.time_s)).collect();
        assert_eq!(
            reached.iter().map(|r| r.0).collect::<Vec<_>>(),
            vec![2, 3, 1, 4, 5]
        );
        // The DO commands ran while flying to waypoint 1.
        assert!(reached[0].1 < reached[2].1 && reached[1].1 < reached[2].1);
        assert_eq!(
            s.payload_actions[0].kind,
            PayloadKind::Relay {
                instance: 2,
                on: true
            }
        );
        assert_eq!(s.payload_actions[0].mission_seq, Some(3));
        // The speed change is ArduPlane's, announced.
        assert!(b.texts().contains(&"Set airspeed 26 m/s".to_owned()));
        // At least 30 s on the loiter circle.
        let loiter_done = reached[3].1;
        assert!(loiter_done - reached[2].1 >= 30.0);
        let texts = b.texts();
        let at = |t: &str| texts.iter().position(|x| x == t);
        let (reached_rtl, complete) = (
            at("Reached RTL location"),
            at("Mission complete, changing mode to RTL"),
        );
        assert!(reached_rtl.is_some() && reached_rtl < complete, "{texts:?}");
        let mc = b.v.mission_current();
        assert!(
            matches!(mc, MavMessage::MISSION_CURRENT(c) if c.mission_state == MissionState::MISSION_STATE_COMPLETE)
        );
    }

    /// Asked for by SET_MESSAGE_INTERVAL, MISSION_ITEM_REACHED is re-sent
    /// every period with the last item reached (65535 before any), as
    /// ArduPlane 4.7 SITL does: repeats, not new occurrences.
    #[test]
    fn mission_item_reached_streamed_repeats_the_last_one() {
        let mut b = Bench::new(quick());
        b.run_to(1.0);
        assert_eq!(
            b.command(
                MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                [46.0, 1_000_000.0, 0.0, 0.0, 0.0, 0.0, 0.0]
            ),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let seqs = |b: &Bench, from: usize| -> Vec<u16> {
            b.since(from, "MISSION_ITEM_REACHED")
                .into_iter()
                .map(|(_, _, m)| match m {
                    MavMessage::MISSION_ITEM_REACHED(r) => r.seq,
                    _ => unreachable!(),
                })
                .collect()
        };
        b.run_to(4.5);
        assert_eq!(seqs(&b, 0), vec![65535; 4]); // at 1, 2, 3, 4 s
        let from = b.got.len();
        b.v.reached(2);
        b.drain_for_tests();
        b.run_to(7.5);
        assert_eq!(seqs(&b, from), vec![2, 2, 2, 2]); // reached, then 5, 6, 7 s
        assert_eq!(b.v.state().reached.len(), 1, "one item reached");
    }
}
