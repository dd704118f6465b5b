//! The ground rover's kinematic model: a wheeled vehicle that turns on the
//! spot or while moving at a limited turn rate, speeds up and slows down
//! at limited accelerations, and stops within `speed² / 2·decel` metres.
//! No slip, no inertia in yaw, no terrain: enough for a labyrinth at a few
//! metres a second. It moves the body state the plane's model also uses
//! ([`Aircraft`]: position, heading, speed, throttle, motor, battery), so
//! the telemetry reads it unchanged.

use crate::geo::{wrap_2pi, wrap_pi, V2};
use crate::model::{Aircraft, Airframe};

/// The rover's limits (the model's, set from Rover-named parameters).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Top speed (m/s): CRUISE_SPEED.
    pub speed: f64,
    /// Acceleration (m/s²): ATC_ACCEL_MAX.
    pub accel: f64,
    /// Braking (m/s²): ATC_DECEL_MAX (0: the acceleration, as on Rover).
    pub decel: f64,
    /// Turn rate (rad/s): ATC_STR_RAT_MAX.
    pub turn_rate: f64,
}

impl Limits {
    /// The braking deceleration (m/s²): `decel`, or `accel` when 0.
    pub fn braking(&self) -> f64 {
        if self.decel > 0.0 {
            self.decel
        } else {
            self.accel.max(0.01)
        }
    }

    /// The distance needed to stop from `speed` (m).
    pub fn stop_distance(&self, speed: f64) -> f64 {
        speed * speed / (2.0 * self.braking())
    }
}

/// What the autopilot asks of the wheels for one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Demand {
    /// Speed wanted (m/s, ≥ 0).
    pub speed: f64,
    /// Heading wanted (radians), if any.
    pub heading: Option<f64>,
}

/// Advances the rover by `dt` seconds. `motor`: the motor can drive (armed
/// and working); `stuck`: the wheels are blocked (the motor runs, the rover
/// does not move). Returns the throttle output (0..1) the autopilot gives.
pub fn step(
    body: &mut Aircraft,
    dt: f64,
    demand: Demand,
    limits: &Limits,
    armed: bool,
    stuck: bool,
    af: &Airframe,
) {
    let v = body.airspeed.max(0.0);
    let want = if armed { demand.speed.max(0.0) } else { 0.0 };
    // Throttle: proportional to the speed asked, more when it cannot move.
    let cruise = limits.speed.max(0.1);
    let mut throttle = if armed && want > 0.0 {
        (0.5 * want / cruise + 0.5 * (want - v).max(0.0) / cruise).clamp(0.0, 1.0)
    } else {
        0.0
    };
    if stuck && want > 0.0 {
        throttle = 1.0;
    }
    body.throttle = throttle;
    let drives = armed && body.engine.working && !stuck;
    let v_new = if stuck {
        0.0
    } else if drives && want > v {
        (v + limits.accel * dt).min(want)
    } else {
        // Braking (or coasting to a stop with a dead motor: the same
        // rolling resistance as brakes on a small rover).
        (v - limits.braking() * dt).max(if drives { want.min(v) } else { 0.0 })
    };
    body.accel = (v_new - v) / dt;
    body.airspeed = v_new;
    if let (Some(h), true) = (demand.heading, armed && !stuck) {
        let err = wrap_pi(h - body.heading);
        let max = limits.turn_rate * dt;
        body.heading = wrap_2pi(body.heading + err.clamp(-max, max));
    }
    body.on_ground = true;
    body.alt = 0.0;
    body.climb = 0.0;
    body.bank = 0.0;
    body.pitch = 0.0;
    body.roll_rate = 0.0;
    body.ground_vel = V2::from_heading(body.heading) * body.airspeed;
    body.pos += body.ground_vel * dt;
    // The motor: rpm follows the throttle (a brushed motor at 8000 rpm
    // full), nothing when it failed; the battery pays for it.
    let target = if armed && body.engine.working {
        af.max_rpm * throttle
    } else {
        0.0
    };
    body.engine.rpm += (target - body.engine.rpm) * (dt / 0.3).min(1.0);
    if body.engine.rpm < 1.0 {
        body.engine.rpm = 0.0;
    }
    let effective = if body.engine.working { throttle } else { 0.0 };
    let current = af.full_throttle_current * effective;
    body.battery.current = current;
    body.battery.consumed_mah += current * body.battery.drain_factor * dt / 3.6;
    let rem = body.battery.remaining(af.battery_capacity_mah) / 100.0;
    let rest = af.battery_empty_volts + (af.battery_full_volts - af.battery_empty_volts) * rem;
    body.battery.voltage = rest - af.battery_resistance * current;
}

/// The speed to ask on the way to a point `dist` metres away so as to stop
/// on it: the cruise speed until the stop distance, then slower.
pub fn approach_speed(dist: f64, limits: &Limits) -> f64 {
    (2.0 * limits.braking() * dist.max(0.0))
        .sqrt()
        .min(limits.speed)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> Limits {
        Limits {
            speed: 2.0,
            accel: 1.0,
            decel: 0.0,
            turn_rate: 90f64.to_radians(),
        }
    }

    fn parked() -> (Aircraft, Airframe) {
        let af = Airframe::rover();
        (Aircraft::parked(0.0, V2::ZERO, 0.0, &af), af)
    }

    fn run(body: &mut Aircraft, af: &Airframe, secs: f64, d: Demand, stuck: bool) {
        let dt = 0.02;
        for _ in 0..(secs / dt).round() as usize {
            step(body, dt, d, &limits(), true, stuck, af);
        }
    }

    #[test]
    fn accelerates_to_the_speed_asked_then_brakes_within_the_stop_distance() {
        let (mut b, af) = parked();
        let go = Demand {
            speed: 2.0,
            heading: Some(0.0),
        };
        run(&mut b, &af, 1.0, go, false);
        assert!((b.airspeed - 1.0).abs() < 0.05, "{}", b.airspeed);
        run(&mut b, &af, 5.0, go, false);
        assert!((b.airspeed - 2.0).abs() < 1e-9);
        let at = b.pos.n;
        run(&mut b, &af, 5.0, Demand::default(), false);
        assert_eq!(b.airspeed, 0.0);
        let stop = b.pos.n - at;
        assert!(
            (stop - limits().stop_distance(2.0)).abs() < 0.1,
            "stopped in {stop} m"
        );
    }

    #[test]
    fn turns_at_the_turn_rate() {
        let (mut b, af) = parked();
        let east = Demand {
            speed: 0.0,
            heading: Some(90f64.to_radians()),
        };
        run(&mut b, &af, 0.5, east, false);
        assert!((b.heading.to_degrees() - 45.0).abs() < 1.0);
        run(&mut b, &af, 1.0, east, false);
        assert!((b.heading.to_degrees() - 90.0).abs() < 1e-6);
        assert_eq!(b.pos, V2::ZERO, "turning on the spot");
    }

    #[test]
    fn stuck_stays_put_with_the_motor_running_and_a_failed_motor_coasts_to_a_stop() {
        let (mut b, af) = parked();
        let go = Demand {
            speed: 2.0,
            heading: Some(0.0),
        };
        run(&mut b, &af, 3.0, go, false);
        let here = b.pos;
        run(&mut b, &af, 3.0, go, true);
        assert_eq!((b.pos, b.airspeed), (here, 0.0));
        assert_eq!(b.throttle, 1.0);
        assert!(b.engine.rpm > 1000.0, "{}", b.engine.rpm);
        // Unstuck, then the motor fails: rpm to 0, the rover stops.
        run(&mut b, &af, 3.0, go, false);
        b.engine.working = false;
        run(&mut b, &af, 3.0, go, false);
        assert_eq!((b.airspeed, b.engine.rpm), (0.0, 0.0));
        assert!(b.throttle > 0.5, "the autopilot still asks: {}", b.throttle);
    }

    #[test]
    fn approach_speed_stops_on_the_point() {
        let l = limits();
        assert_eq!(approach_speed(100.0, &l), 2.0);
        assert!((approach_speed(0.5, &l) - 1.0).abs() < 1e-9);
        assert_eq!(approach_speed(0.0, &l), 0.0);
    }
}
