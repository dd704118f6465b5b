//! Guidance as ArduPlane does it, simplified: L1 tracking of the leg between
//! two waypoints (ArduPilot's AP_L1_Control), loiter circles, heading hold,
//! and a TECS-like energy law turning a height and an airspeed into a
//! throttle and a climb rate. Pure functions of the aircraft state.

use std::f64::consts::{FRAC_1_SQRT_2, PI};

use crate::geo::{wrap_pi, V2};
use crate::model::{speed_response, Aircraft, Airframe, G};

/// The L1 controller's tuning (NAVL1_PERIOD, NAVL1_DAMPING).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct L1 {
    pub period: f64,
    pub damping: f64,
}

impl Default for L1 {
    fn default() -> Self {
        L1 {
            period: 17.0,
            damping: 0.75,
        }
    }
}

impl L1 {
    /// The L1 distance at ground speed `gs`.
    pub fn distance(&self, gs: f64) -> f64 {
        self.damping * self.period * gs / PI
    }

    fn gain(&self) -> f64 {
        4.0 * self.damping * self.damping
    }

    /// Lateral acceleration to turn the ground track by `nu` radians.
    fn lat_acc(&self, gs: f64, nu: f64) -> f64 {
        let nu = nu.clamp(-PI / 2.0, PI / 2.0);
        self.gain() * gs * gs / self.distance(gs).max(0.1) * nu.sin()
    }
}

/// What the navigation wants, and what NAV_CONTROLLER_OUTPUT reports.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Nav {
    /// Lateral acceleration demand (m/s², positive right).
    pub lat_acc: f64,
    /// The course the controller steers to (radians).
    pub nav_bearing: f64,
    /// Bearing to the target point (radians).
    pub target_bearing: f64,
    /// Cross-track error (m).
    pub xtrack: f64,
    /// Distance to the target point (m).
    pub wp_dist: f64,
}

impl Nav {
    /// The bank that gives this lateral acceleration in a level turn.
    pub fn bank(&self, limit: f64) -> f64 {
        (self.lat_acc / G).atan().clamp(-limit, limit)
    }
}

/// The ground velocity to steer with: the nose direction when (nearly) still.
fn track_vel(ac: &Aircraft) -> V2 {
    if ac.ground_vel.len() < 1.0 {
        V2::from_heading(ac.heading)
    } else {
        ac.ground_vel
    }
}

/// The signed angle from `from` to `to` (positive clockwise).
fn angle(from: V2, to: V2) -> f64 {
    from.cross(to).atan2(from.dot(to))
}

/// Tracks the leg from `a` to `b`.
pub fn leg(ac: &Aircraft, a: V2, b: V2, l1: &L1) -> Nav {
    let vel = track_vel(ac);
    let gs = vel.len();
    let dist_l1 = l1.distance(gs);
    let p = ac.pos;
    let to_b = b - p;
    let mut ab = b - a;
    if ab.len() < 1e-3 {
        ab = to_b;
    }
    let ab = ab.unit();
    let ap = p - a;
    let a_dist = ap.len();
    let along = ap.dot(ab);
    let (nu, xtrack) = if a_dist > dist_l1 && along / a_dist.max(1.0) < -FRAC_1_SQRT_2 {
        // Far behind A: fly to A first.
        (angle(vel, a - p), ap.cross(ab))
    } else if along > (b - a).len() + gs * 3.0 {
        // Well past B: come back to it.
        (angle(vel, to_b), ap.cross(ab))
    } else {
        let xtrack = ap.cross(ab);
        let nu2 = vel.cross(ab).atan2(vel.dot(ab));
        let nu1 = (xtrack / dist_l1.max(0.1))
            .clamp(-FRAC_1_SQRT_2, FRAC_1_SQRT_2)
            .asin();
        (nu1 + nu2, xtrack)
    };
    Nav {
        lat_acc: l1.lat_acc(gs, nu),
        nav_bearing: vel.heading() + wrap_pi(nu),
        target_bearing: to_b.heading(),
        xtrack,
        wp_dist: to_b.len(),
    }
}

/// Flies straight to `b`.
pub fn to_point(ac: &Aircraft, b: V2, l1: &L1) -> Nav {
    let vel = track_vel(ac);
    let to_b = b - ac.pos;
    let nu = angle(vel, to_b);
    Nav {
        lat_acc: l1.lat_acc(vel.len(), nu),
        nav_bearing: to_b.heading(),
        target_bearing: to_b.heading(),
        xtrack: 0.0,
        wp_dist: to_b.len(),
    }
}

/// Circles `center` at `radius` (clockwise unless `ccw`).
pub fn loiter(ac: &Aircraft, center: V2, radius: f64, ccw: bool, l1: &L1) -> Nav {
    let vel = track_vel(ac);
    let gs = vel.len();
    let dir = if ccw { -1.0 } else { 1.0 };
    let radius = radius.max(10.0);
    let r = ac.pos - center;
    let dist = r.len();
    let r_hat = if dist > 1e-3 {
        r.unit()
    } else {
        -V2::from_heading(ac.heading)
    };
    let tangent = r_hat.rotated(dir * PI / 2.0);
    // Steer along the tangent, turned toward the circle by the radial error.
    let err = dist - radius;
    let dist_l1 = l1.distance(gs);
    let correction = err.atan2(dist_l1 * 0.5);
    let desired = tangent.rotated(dir * correction);
    let nu = angle(vel, desired);
    // Feed forward the turn of the circle itself, near the circle.
    let near = (1.0 - err.abs() / dist_l1.max(1.0)).clamp(0.0, 1.0);
    let ff = dir * gs * gs / radius * near;
    Nav {
        lat_acc: l1.lat_acc(gs, nu) + ff,
        nav_bearing: desired.heading(),
        target_bearing: (center - ac.pos).heading(),
        xtrack: err,
        wp_dist: dist,
    }
}

/// Holds a ground course (radians).
pub fn course(ac: &Aircraft, course: f64, l1: &L1) -> Nav {
    let vel = track_vel(ac);
    let nu = angle(vel, V2::from_heading(course));
    Nav {
        lat_acc: l1.lat_acc(vel.len(), nu),
        nav_bearing: course,
        target_bearing: course,
        xtrack: 0.0,
        wp_dist: 0.0,
    }
}

/// The energy law: the throttle and climb rate that take the aircraft to
/// `alt` (m above home) at `airspeed`, within the climb and sink limits.
/// `climb_ff` is the rate the target height itself moves at (a glide
/// slope, a leg between two heights), fed forward.
pub fn energy(
    ac: &Aircraft,
    af: &Airframe,
    alt: f64,
    climb_ff: f64,
    airspeed: f64,
    climb_max: f64,
    sink_max: f64,
) -> (f64, f64) {
    let climb = (climb_ff + (alt - ac.alt) * 0.3).clamp(-sink_max, climb_max);
    (throttle_for(ac, af, climb, airspeed), climb)
}

/// The throttle that gives `climb` at `airspeed` (equivalent airspeed).
pub fn throttle_for(ac: &Aircraft, af: &Airframe, climb: f64, airspeed: f64) -> f64 {
    let v = ac.airspeed.max(1.0);
    let v_dot = speed_response(airspeed * ac.eas2tas(), v);
    let need = climb + v * v_dot / G + af.glide_sink(v, ac.bank);
    af.throttle_for(need)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Controls;

    fn flying() -> (Aircraft, Airframe) {
        let af = Airframe::default();
        let mut ac = Aircraft::parked(0.0, V2::ZERO, 0.0, &af);
        ac.on_ground = false;
        ac.alt = 100.0;
        ac.airspeed = 22.0;
        ac.ground_vel = V2::new(22.0, 0.0);
        (ac, af)
    }

    fn fly(ac: &mut Aircraft, af: &Airframe, secs: f64, nav: impl Fn(&Aircraft) -> Nav) {
        let limit = 45f64.to_radians();
        for _ in 0..(secs * 50.0) as usize {
            let n = nav(ac);
            let (throttle, climb) = energy(ac, af, 100.0, 0.0, 22.0, 5.0, 5.0);
            let ctrl = Controls {
                throttle,
                climb,
                bank: n.bank(limit),
                airspeed: 22.0,
                ..Controls::default()
            };
            ac.step(0.02, &ctrl, true, af, limit);
        }
    }

    #[test]
    fn l1_captures_a_leg_to_the_east() {
        let (mut ac, af) = flying();
        let a = V2::new(0.0, 0.0);
        let b = V2::new(0.0, 3000.0);
        let l1 = L1::default();
        fly(&mut ac, &af, 60.0, |ac| leg(ac, a, b, &l1));
        let n = leg(&ac, a, b, &l1);
        assert!(n.xtrack.abs() < 5.0, "cross track {}", n.xtrack);
        assert!((ac.ground_vel.heading() - PI / 2.0).abs() < 0.1);
        assert!((ac.alt - 100.0).abs() < 3.0, "alt {}", ac.alt);
        assert!((ac.indicated_airspeed() - 22.0).abs() < 0.5);
    }

    #[test]
    fn loiter_settles_on_the_circle() {
        let (mut ac, af) = flying();
        let l1 = L1::default();
        let center = V2::new(500.0, 300.0);
        fly(&mut ac, &af, 120.0, |ac| {
            loiter(ac, center, 80.0, false, &l1)
        });
        let mut worst: f64 = 0.0;
        for _ in 0..10 {
            fly(&mut ac, &af, 2.0, |ac| loiter(ac, center, 80.0, false, &l1));
            worst = worst.max(((ac.pos - center).len() - 80.0).abs());
        }
        assert!(worst < 15.0, "off the circle by {worst} m");
        // Clockwise: the centre is on the right of the track.
        let r = ac.pos - center;
        assert!(r.cross(ac.ground_vel) > 0.0);
    }
}
