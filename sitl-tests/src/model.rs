//! The point-mass fixed-wing model: energy (engine power against drag,
//! shared between speed and height as TECS does), coordinated turns under a
//! bank limit, the ground roll, wind, and the engine and battery. Pure: fed
//! the autopilot's controls and a time step, no clock.

use crate::geo::{wrap_2pi, V2};

/// Standard gravity, m/s².
pub const G: f64 = 9.80665;

/// Air density (kg/m³) at `alt_amsl` metres on ArduPilot SITL's warm day
/// (ISA + 15.5 K: its barometer reads 27 °C at 584 m).
pub fn density(alt_amsl: f64) -> f64 {
    let p = 101_325.0 * (1.0 - 2.255_77e-5 * alt_amsl).powf(5.255_88);
    let t = 288.15 - 0.0065 * alt_amsl + 15.5;
    p / (287.053 * t)
}

/// True airspeed over equivalent airspeed at `alt_amsl` (1.06 at the
/// recording's 650 m: 22 m/s indicated is 23.4 m/s true, as recorded).
pub fn eas2tas(alt_amsl: f64) -> f64 {
    (1.225 / density(alt_amsl)).sqrt()
}

/// The airframe's fixed properties (the autopilot's tunables are parameters,
/// see [`crate::Params`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Airframe {
    /// Lift-to-drag ratio in a wings-level glide with the engine idle.
    pub glide_ratio: f64,
    /// The glide ratio once the engine has failed (its propeller
    /// windmilling, and ArduPlane's TECS trading speed for height as it
    /// can no longer hold it): 4.3:1 as measured on ArduPlane 4.7 SITL with
    /// its throttle output cut (about 15 m/s and 3.5 m/s of sink,
    /// gateway/tests/real_plane.rs). 11:1 before, with which our engine-out
    /// landings reached sites the real firmware came down short of.
    pub failed_engine_glide_ratio: f64,
    /// The airspeed TECS settles at once the engine has failed (m/s, at
    /// most what it asks): ArduPlane 4.7 SITL's slows to about 15 m/s.
    pub failed_engine_airspeed: f64,
    /// Climb rate at full throttle at the cruise airspeed (m/s). With the
    /// glide ratio this sets the engine's power.
    pub full_throttle_climb: f64,
    /// The cruise airspeed the power figures refer to (m/s).
    pub reference_airspeed: f64,
    /// Below this airspeed the wing stalls (m/s).
    pub stall_speed: f64,
    /// Longitudinal acceleration on the runway at full throttle (m/s²).
    pub ground_accel: f64,
    /// Airspeed at which the take-off run rotates (m/s, equivalent).
    pub rotate_speed: f64,
    /// Battery capacity (mAh).
    pub battery_capacity_mah: f64,
    /// Battery current at full throttle (A).
    pub full_throttle_current: f64,
    /// Battery voltage, full and empty, at rest (V).
    pub battery_full_volts: f64,
    pub battery_empty_volts: f64,
    /// Battery internal resistance (Ω).
    pub battery_resistance: f64,
    /// Engine speed at idle and at full throttle (rpm).
    pub idle_rpm: f64,
    pub max_rpm: f64,
}

impl Default for Airframe {
    /// A small plane flying like the SITL one of the recording: 22 m/s
    /// cruise at about 45 % throttle, 13 m/s climb at full throttle (10 m/s
    /// while gaining speed after take-off, as recorded), a 3.3 Ah
    /// 3-cell battery drawing about 10 A in cruise (as recorded).
    fn default() -> Self {
        Airframe {
            glide_ratio: 11.0,
            failed_engine_glide_ratio: 4.3,
            failed_engine_airspeed: 15.0,
            full_throttle_climb: 13.0,
            reference_airspeed: 22.0,
            stall_speed: 10.0,
            ground_accel: 6.5,
            rotate_speed: 18.0,
            battery_capacity_mah: 3300.0,
            full_throttle_current: 25.0,
            battery_full_volts: 12.6,
            battery_empty_volts: 11.1,
            battery_resistance: 0.032,
            idle_rpm: 1500.0,
            max_rpm: 7000.0,
        }
    }
}

impl Airframe {
    /// A small electric rover (the ground vehicle of [`crate::Firmware::ArduRover`]):
    /// only the battery and the motor's figures are read (a 5 Ah 3-cell
    /// battery, 10 A at full throttle, 8000 rpm).
    pub fn rover() -> Airframe {
        Airframe {
            battery_capacity_mah: 5000.0,
            full_throttle_current: 10.0,
            idle_rpm: 0.0,
            max_rpm: 8000.0,
            ..Airframe::default()
        }
    }

    /// Specific excess power at full throttle, as a rate of energy height
    /// (m/s): the climb at full throttle plus the glide sink at the
    /// reference airspeed.
    pub fn full_power(&self) -> f64 {
        self.full_throttle_climb + self.reference_airspeed / self.glide_ratio
    }

    /// Sink rate of a glide at `airspeed` with bank `bank` (m/s, positive
    /// down): the turn's load factor raises the drag.
    pub fn glide_sink(&self, airspeed: f64, bank: f64) -> f64 {
        let load = 1.0 / bank.cos().max(0.2);
        airspeed / self.glide_ratio * load
    }

    /// Sink rate of a glide with the engine failed (as `glide_sink`, at
    /// `failed_engine_glide_ratio`).
    pub fn failed_engine_sink(&self, airspeed: f64, bank: f64) -> f64 {
        self.glide_sink(airspeed, bank) * self.glide_ratio / self.failed_engine_glide_ratio
    }

    /// Energy height rate the engine gives at `throttle` (0..1): a
    /// propeller's power rises steeply with throttle (the recording cruises
    /// at 47 % and climbs hard at 100 %).
    pub fn engine_power(&self, throttle: f64) -> f64 {
        self.full_power() * throttle.clamp(0.0, 1.0).powf(2.5)
    }

    /// The throttle that gives `power` (inverse of [`Airframe::engine_power`]).
    pub fn throttle_for(&self, power: f64) -> f64 {
        (power / self.full_power()).clamp(0.0, 1.0).powf(0.4)
    }
}

/// How the energy is split when the engine cannot give what is asked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Priority {
    /// Hold the airspeed; the height takes what is left (TECS normally).
    #[default]
    Speed,
    /// Hold the climb rate; the airspeed takes what is left (the flare).
    Height,
}

/// What the autopilot asks of the airframe for one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Controls {
    /// Throttle, 0..1 (what the autopilot outputs, whether or not the
    /// engine runs).
    pub throttle: f64,
    /// Bank angle (radians, positive right).
    pub bank: f64,
    /// Climb rate (m/s).
    pub climb: f64,
    /// Airspeed (m/s, equivalent airspeed: what the autopilot reads and
    /// targets).
    pub airspeed: f64,
    pub priority: Priority,
    /// On the ground: steer to this heading (radians), if any.
    pub steer: Option<f64>,
}

/// The engine.
#[derive(Debug, Clone, PartialEq)]
pub struct Engine {
    /// False after an engine failure: no thrust, the rpm winds down.
    pub working: bool,
    pub rpm: f64,
}

/// The battery.
#[derive(Debug, Clone, PartialEq)]
pub struct Battery {
    pub consumed_mah: f64,
    pub current: f64,
    pub voltage: f64,
    /// Consumption multiplier (a fault drains it faster).
    pub drain_factor: f64,
}

impl Battery {
    /// Remaining charge, percent of `capacity_mah`.
    pub fn remaining(&self, capacity_mah: f64) -> f64 {
        (100.0 * (1.0 - self.consumed_mah / capacity_mah)).clamp(0.0, 100.0)
    }
}

/// The simulated aircraft's true state.
#[derive(Debug, Clone, PartialEq)]
pub struct Aircraft {
    /// Metres north and east of the boot home.
    pub pos: V2,
    /// Metres above the ground (the terrain is flat at home's altitude).
    pub alt: f64,
    /// True airspeed in flight; speed along the heading on the ground (m/s).
    pub airspeed: f64,
    /// Where the nose points (radians from north).
    pub heading: f64,
    /// Bank (radians, positive right).
    pub bank: f64,
    /// Roll rate (rad/s).
    pub roll_rate: f64,
    /// Climb rate (m/s).
    pub climb: f64,
    /// Pitch (radians).
    pub pitch: f64,
    /// Along-track acceleration (m/s²).
    pub accel: f64,
    /// Ground velocity (m/s).
    pub ground_vel: V2,
    pub on_ground: bool,
    /// The throttle the autopilot outputs (0..1).
    pub throttle: f64,
    pub engine: Engine,
    pub battery: Battery,
    /// Wind (m/s toward north and east).
    pub wind: V2,
    /// The ground's altitude (m AMSL), for the air density.
    pub ground_amsl: f64,
}

/// The aircraft met the ground.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Sink rate at contact (m/s, positive down).
    pub sink: f64,
    pub airspeed: f64,
    pub bank: f64,
}

impl Aircraft {
    /// On the ground at home, pointing `heading` (radians).
    pub fn parked(heading: f64, wind: V2, ground_amsl: f64, airframe: &Airframe) -> Aircraft {
        Aircraft {
            pos: V2::ZERO,
            alt: 0.0,
            airspeed: 0.0,
            heading,
            bank: 0.0,
            roll_rate: 0.0,
            climb: 0.0,
            pitch: 0.0,
            accel: 0.0,
            ground_vel: V2::ZERO,
            on_ground: true,
            throttle: 0.0,
            engine: Engine {
                working: true,
                rpm: 0.0,
            },
            battery: Battery {
                consumed_mah: 0.0,
                current: 0.0,
                voltage: airframe.battery_full_volts,
                drain_factor: 1.0,
            },
            wind,
            ground_amsl,
        }
    }

    /// True over equivalent airspeed where the aircraft is.
    pub fn eas2tas(&self) -> f64 {
        eas2tas(self.ground_amsl + self.alt)
    }

    /// Air velocity (m/s).
    pub fn air_vel(&self) -> V2 {
        if self.on_ground {
            return self.ground_vel - self.wind;
        }
        let horiz = (self.airspeed.powi(2) - self.climb.powi(2)).max(0.0).sqrt();
        V2::from_heading(self.heading) * horiz
    }

    /// The (equivalent) airspeed an airspeed sensor reads (on the ground:
    /// the wind and the roll).
    pub fn indicated_airspeed(&self) -> f64 {
        let tas = if self.on_ground {
            self.air_vel().len()
        } else {
            self.airspeed
        };
        tas / self.eas2tas()
    }

    pub fn groundspeed(&self) -> f64 {
        self.ground_vel.len()
    }

    /// The throttle that reaches the engine: none when disarmed or failed.
    fn effective_throttle(&self, armed: bool) -> f64 {
        if armed && self.engine.working {
            self.throttle
        } else {
            0.0
        }
    }

    /// Advances the model by `dt` seconds. Returns the contact when the
    /// aircraft meets the ground in this step.
    pub fn step(
        &mut self,
        dt: f64,
        ctrl: &Controls,
        armed: bool,
        af: &Airframe,
        roll_limit: f64,
    ) -> Option<Contact> {
        self.throttle = if armed {
            ctrl.throttle.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let thr = self.effective_throttle(armed);
        self.update_engine(dt, armed, af);
        self.update_battery(dt, thr, af);
        if self.on_ground {
            self.step_ground(dt, ctrl, thr, af);
            None
        } else {
            self.step_air(dt, ctrl, thr, af, roll_limit)
        }
    }

    fn update_engine(&mut self, dt: f64, armed: bool, af: &Airframe) {
        let target = if armed && self.engine.working {
            af.idle_rpm + (af.max_rpm - af.idle_rpm) * self.throttle
        } else {
            0.0
        };
        // A propeller spins up in about half a second and winds down in one;
        // a seized engine stops in under a second.
        let tau = if target > self.engine.rpm {
            0.5
        } else if self.engine.working {
            1.0
        } else {
            0.4
        };
        self.engine.rpm += (target - self.engine.rpm) * (dt / tau).min(1.0);
        if self.engine.rpm < 1.0 {
            self.engine.rpm = 0.0;
        }
    }

    fn update_battery(&mut self, dt: f64, thr: f64, af: &Airframe) {
        let current = af.full_throttle_current * thr.powf(1.1);
        self.battery.current = current;
        self.battery.consumed_mah += current * self.battery.drain_factor * dt / 3.6;
        let rem = self.battery.remaining(af.battery_capacity_mah) / 100.0;
        let rest = af.battery_empty_volts + (af.battery_full_volts - af.battery_empty_volts) * rem;
        self.battery.voltage = rest - af.battery_resistance * current;
    }

    fn step_ground(&mut self, dt: f64, ctrl: &Controls, thr: f64, af: &Airframe) {
        let v = self.airspeed.max(0.0);
        let accel = if thr > 0.0 {
            af.ground_accel * thr * thr - 0.3 - 0.004 * v * v
        } else {
            // Rolling friction and brakes, fitted on the recording's landing
            // roll (3.5 m/s² at 12 m/s, 0.8 at 3 m/s, 0.2 at 0.7 m/s: 9 s
            // from touchdown to a stop).
            -(0.2 + 0.32 * v)
        };
        let v_new = (v + accel * dt).max(0.0);
        self.accel = (v_new - v) / dt;
        self.airspeed = v_new;
        if let Some(h) = ctrl.steer {
            let err = crate::geo::wrap_pi(h - self.heading);
            let max_rate = (v / 10.0).min(0.5); // rad/s, nose-wheel steering
            self.heading = wrap_2pi(self.heading + err.clamp(-max_rate * dt, max_rate * dt));
        }
        self.bank = 0.0;
        self.roll_rate = 0.0;
        self.climb = 0.0;
        self.pitch = 0.0;
        self.alt = 0.0;
        self.ground_vel = V2::from_heading(self.heading) * self.airspeed;
        self.pos += self.ground_vel * dt;
        // Rotate: leave the runway at the rotation airspeed when asked to climb.
        let air = (self.ground_vel - self.wind).len();
        if ctrl.climb > 0.0 && thr > 0.0 && air / self.eas2tas() >= af.rotate_speed {
            self.on_ground = false;
            self.airspeed = air;
            self.heading = (self.ground_vel - self.wind).heading();
        }
    }

    fn step_air(
        &mut self,
        dt: f64,
        ctrl: &Controls,
        thr: f64,
        af: &Airframe,
        roll_limit: f64,
    ) -> Option<Contact> {
        // Bank: a first-order roll response, rate limited, never past the limit.
        let target = ctrl.bank.clamp(-roll_limit, roll_limit);
        let max_rate = 75f64.to_radians();
        let rate = ((target - self.bank) / 0.35).clamp(-max_rate, max_rate);
        self.roll_rate = rate;
        self.bank = (self.bank + rate * dt).clamp(-roll_limit, roll_limit);

        let v = self.airspeed.max(1.0);
        // Energy height rate: engine power against drag.
        let drag = if self.engine.working {
            af.glide_sink(v, self.bank)
        } else {
            af.failed_engine_sink(v, self.bank)
        };
        let edot = af.engine_power(thr) - drag;
        let (v_dot, h_dot) = if v < af.stall_speed {
            // Stalled: the nose drops, the speed comes back, the height goes.
            let v_dot = 2.0;
            (v_dot, edot - v * v_dot / G)
        } else {
            match ctrl.priority {
                Priority::Speed => {
                    let target = if self.engine.working {
                        ctrl.airspeed
                    } else {
                        ctrl.airspeed.min(af.failed_engine_airspeed)
                    };
                    let v_dot = speed_response(target * self.eas2tas(), v);
                    let h_dot = edot - v * v_dot / G;
                    // No balloon: energy beyond the climb asked stays in speed.
                    let ceiling = ctrl.climb.max(0.0);
                    if h_dot > ceiling {
                        ((edot - ceiling) * G / v, ceiling)
                    } else {
                        (v_dot, h_dot)
                    }
                }
                Priority::Height => {
                    let h_dot = ctrl.climb;
                    ((edot - h_dot) * G / v, h_dot)
                }
            }
        };
        // The path cannot be steeper than the speed allows.
        let h_dot = h_dot.clamp(-0.9 * v, 0.9 * v);
        self.accel = v_dot;
        self.airspeed = (v + v_dot * dt).max(0.5 * af.stall_speed);
        self.climb = h_dot;
        self.heading = wrap_2pi(self.heading + G * self.bank.tan() / v * dt);
        let gamma = (h_dot / v).clamp(-1.0, 1.0).asin();
        let load = 1.0 / self.bank.cos().max(0.2);
        let alpha = (0.06 * load * (af.reference_airspeed / v).powi(2)).min(0.25);
        self.pitch = gamma + alpha - 0.04;
        self.ground_vel = self.air_vel() + self.wind;
        self.pos += self.ground_vel * dt;
        self.alt += h_dot * dt;
        if self.alt <= 0.0 {
            let contact = Contact {
                sink: -h_dot,
                airspeed: self.airspeed,
                bank: self.bank,
            };
            self.alt = 0.0;
            self.on_ground = true;
            self.climb = 0.0;
            self.bank = 0.0;
            self.pitch = 0.0;
            self.airspeed = self.ground_vel.len();
            if self.airspeed > 0.1 {
                self.heading = self.ground_vel.heading();
            }
            return Some(contact);
        }
        None
    }
}

/// The acceleration the airspeed loop asks for (m/s²); the autopilot uses
/// the same law to compute its throttle.
pub fn speed_response(target: f64, airspeed: f64) -> f64 {
    ((target - airspeed) * 0.5).clamp(-2.0, 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flying(af: &Airframe) -> Aircraft {
        let mut ac = Aircraft::parked(0.0, V2::ZERO, 0.0, af);
        ac.on_ground = false;
        ac.alt = 500.0;
        ac.airspeed = 22.0;
        ac
    }

    #[test]
    fn a_failed_engine_glides_at_its_glide_ratio() {
        let af = Airframe::default();
        let mut ac = flying(&af);
        ac.airspeed = 20.0;
        ac.engine.working = false;
        let ctrl = Controls {
            throttle: 1.0,
            airspeed: 20.0 / ac.eas2tas(),
            ..Controls::default()
        };
        let start = (ac.pos, ac.alt);
        for _ in 0..(60 * 50) {
            ac.step(0.02, &ctrl, true, &af, 45f64.to_radians());
        }
        let dist = (ac.pos - start.0).len();
        let lost = start.1 - ac.alt;
        let ratio = dist / lost;
        assert!(
            (ratio - af.failed_engine_glide_ratio).abs() < 0.5,
            "glide ratio {ratio}"
        );
        assert_eq!(ac.engine.rpm, 0.0);
    }

    #[test]
    fn full_throttle_climbs_and_cruise_throttle_holds_level() {
        let af = Airframe::default();
        let mut ac = flying(&af);
        let ctrl = Controls {
            throttle: 1.0,
            airspeed: ac.indicated_airspeed(),
            climb: 20.0,
            ..Controls::default()
        };
        ac.step(0.02, &ctrl, true, &af, 1.0);
        assert!((ac.climb - 13.0).abs() < 0.2, "climb {}", ac.climb);
        let cruise = af.throttle_for(af.glide_sink(22.0, 0.0));
        assert!((0.4..0.55).contains(&cruise), "cruise throttle {cruise}");
    }

    #[test]
    fn bank_never_exceeds_the_limit_and_turns_coordinated() {
        let af = Airframe::default();
        let mut ac = flying(&af);
        let limit = 45f64.to_radians();
        let ctrl = Controls {
            throttle: 0.6,
            bank: 1.2,
            airspeed: 22.0,
            ..Controls::default()
        };
        let h0 = ac.heading;
        for _ in 0..100 {
            ac.step(0.02, &ctrl, true, &af, limit);
            assert!(ac.bank <= limit + 1e-12);
        }
        // g tan(45°) / 22 m/s = 0.446 rad/s once rolled in.
        let h1 = ac.heading;
        ac.step(0.02, &ctrl, true, &af, limit);
        let rate = crate::geo::wrap_pi(ac.heading - h1) / 0.02;
        assert!((rate - G / ac.airspeed).abs() < 0.02, "turn rate {rate}");
        assert!(crate::geo::wrap_pi(h1 - h0) != 0.0);
    }

    #[test]
    fn takeoff_run_rotates_at_the_rotation_speed() {
        let af = Airframe::default();
        let mut ac = Aircraft::parked(0.0, V2::ZERO, 0.0, &af);
        let ctrl = Controls {
            throttle: 1.0,
            climb: 5.0,
            airspeed: 22.0,
            steer: Some(0.0),
            ..Controls::default()
        };
        let mut t = 0.0;
        while ac.on_ground && t < 20.0 {
            ac.step(0.02, &ctrl, true, &af, 1.0);
            t += 0.02;
        }
        assert!(!ac.on_ground);
        assert!((3.0..6.0).contains(&t), "rotation after {t} s");
        assert!(ac.indicated_airspeed() >= af.rotate_speed);
    }

    #[test]
    fn battery_drains_with_throttle() {
        let af = Airframe::default();
        let mut ac = flying(&af);
        let ctrl = Controls {
            throttle: 1.0,
            airspeed: 22.0,
            ..Controls::default()
        };
        for _ in 0..(60 * 50) {
            ac.step(0.02, &ctrl, true, &af, 1.0);
        }
        // 25 A for a minute is 417 mAh, 12.6 % of 3300 mAh.
        let rem = ac.battery.remaining(af.battery_capacity_mah);
        assert!((rem - 87.4).abs() < 0.5, "{rem}");
        assert!(ac.battery.voltage < 12.0);
    }
}
