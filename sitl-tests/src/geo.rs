//! Positions around home: latitude and longitude as metres north and east of
//! home on a flat earth (ArduPilot's `Location` offsets use the same
//! scaling), headings and the small vector arithmetic the model needs.

use std::ops::{Add, AddAssign, Mul, Neg, Sub};

/// Metres per 1e-7 degree of latitude (ArduPilot's LOCATION_SCALING_FACTOR).
const METRES_PER_E7: f64 = 0.011_131_884_502_145_034;

/// Where the vehicle boots: its home and the runway heading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Home {
    /// Degrees.
    pub lat: f64,
    /// Degrees.
    pub lon: f64,
    /// Metres above mean sea level (the ground, flat around home).
    pub alt_amsl: f64,
    /// Degrees from north: the way the aircraft points on the ground.
    pub heading: f64,
}

impl Default for Home {
    /// ArduPilot SITL's default location (CMAC, Canberra), as in the recordings.
    fn default() -> Self {
        Home {
            lat: -35.363261,
            lon: 149.165230,
            alt_amsl: 584.0,
            heading: 353.0,
        }
    }
}

/// A horizontal vector: `n` metres north, `e` metres east.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct V2 {
    pub n: f64,
    pub e: f64,
}

impl V2 {
    pub const ZERO: V2 = V2 { n: 0.0, e: 0.0 };

    pub fn new(n: f64, e: f64) -> V2 {
        V2 { n, e }
    }

    /// The unit vector of a heading (radians from north, clockwise).
    pub fn from_heading(rad: f64) -> V2 {
        V2::new(rad.cos(), rad.sin())
    }

    pub fn len(self) -> f64 {
        self.n.hypot(self.e)
    }

    pub fn dot(self, o: V2) -> f64 {
        self.n * o.n + self.e * o.e
    }

    /// ArduPilot's `%` on Vector2f: `a.x*b.y - a.y*b.x` (x north, y east).
    /// Positive when `o` is clockwise of `self`.
    pub fn cross(self, o: V2) -> f64 {
        self.n * o.e - self.e * o.n
    }

    /// The unit vector, or zero for a zero vector.
    pub fn unit(self) -> V2 {
        let l = self.len();
        if l > 1e-9 {
            V2::new(self.n / l, self.e / l)
        } else {
            V2::ZERO
        }
    }

    /// Heading of the vector, radians in [0, 2π).
    pub fn heading(self) -> f64 {
        wrap_2pi(self.e.atan2(self.n))
    }

    /// Rotated clockwise by `rad`.
    pub fn rotated(self, rad: f64) -> V2 {
        let (s, c) = rad.sin_cos();
        V2::new(self.n * c - self.e * s, self.n * s + self.e * c)
    }
}

impl Add for V2 {
    type Output = V2;
    fn add(self, o: V2) -> V2 {
        V2::new(self.n + o.n, self.e + o.e)
    }
}

impl AddAssign for V2 {
    fn add_assign(&mut self, o: V2) {
        self.n += o.n;
        self.e += o.e;
    }
}

impl Sub for V2 {
    type Output = V2;
    fn sub(self, o: V2) -> V2 {
        V2::new(self.n - o.n, self.e - o.e)
    }
}

impl Mul<f64> for V2 {
    type Output = V2;
    fn mul(self, k: f64) -> V2 {
        V2::new(self.n * k, self.e * k)
    }
}

impl Neg for V2 {
    type Output = V2;
    fn neg(self) -> V2 {
        V2::new(-self.n, -self.e)
    }
}

/// Wraps an angle to [0, 2π).
pub fn wrap_2pi(rad: f64) -> f64 {
    rad.rem_euclid(std::f64::consts::TAU)
}

/// Wraps an angle to (-π, π].
pub fn wrap_pi(rad: f64) -> f64 {
    let a = wrap_2pi(rad);
    if a > std::f64::consts::PI {
        a - std::f64::consts::TAU
    } else {
        a
    }
}

/// The offset of `(lat, lon)` (degrees) from `origin`, in metres.
pub fn offset(origin: &Home, lat: f64, lon: f64) -> V2 {
    let scale = METRES_PER_E7 * 1e7;
    V2::new(
        (lat - origin.lat) * scale,
        (lon - origin.lon) * scale * origin.lat.to_radians().cos(),
    )
}

/// The latitude and longitude (degrees) of an offset from `origin`.
pub fn location(origin: &Home, at: V2) -> (f64, f64) {
    let scale = METRES_PER_E7 * 1e7;
    let lat = origin.lat + at.n / scale;
    let lon = origin.lon + at.e / (scale * origin.lat.to_radians().cos());
    (lat, lon)
}

/// Degrees as MAVLink's 1e-7 integer.
pub fn e7(deg: f64) -> i32 {
    (deg * 1e7).round() as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_and_location_are_inverse() {
        let home = Home::default();
        let p = V2::new(400.0, -250.0);
        let (lat, lon) = location(&home, p);
        let back = offset(&home, lat, lon);
        assert!((back - p).len() < 1e-6, "{back:?}");
        // 0.0036 degrees of latitude is about 400 m (the recording's legs).
        let d = offset(&home, home.lat + 0.0036, home.lon);
        assert!((d.n - 400.7).abs() < 0.5, "{d:?}");
    }

    #[test]
    fn cross_is_positive_clockwise() {
        let north = V2::new(1.0, 0.0);
        let east = V2::new(0.0, 1.0);
        assert!(north.cross(east) > 0.0);
        assert!((north.rotated(std::f64::consts::FRAC_PI_2) - east).len() < 1e-12);
        assert!((east.heading() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((wrap_pi(3.5 * std::f64::consts::PI) + 0.5 * std::f64::consts::PI).abs() < 1e-12);
    }
}
