//! Distances, bearings and polygons on a spherical Earth: legs of a few
//! kilometres, where the sphere's error (< 0.5 %) is far below a glide
//! margin.

/// Mean Earth radius (IUGG), metres.
pub const EARTH_RADIUS: f64 = 6_371_008.8;

/// A position in degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LatLon {
    pub lat: f64,
    pub lon: f64,
}

impl LatLon {
    pub fn new(lat: f64, lon: f64) -> LatLon {
        LatLon { lat, lon }
    }

    /// Great-circle distance in metres (haversine).
    pub fn distance(self, to: LatLon) -> f64 {
        let (p1, p2) = (self.lat.to_radians(), to.lat.to_radians());
        let dp = p2 - p1;
        let dl = (to.lon - self.lon).to_radians();
        let a = (dp / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
        2.0 * EARTH_RADIUS * a.sqrt().min(1.0).asin()
    }

    /// Initial bearing towards `to`, radians clockwise from north.
    pub fn bearing(self, to: LatLon) -> f64 {
        let (p1, p2) = (self.lat.to_radians(), to.lat.to_radians());
        let dl = (to.lon - self.lon).to_radians();
        let y = dl.sin() * p2.cos();
        let x = p1.cos() * p2.sin() - p1.sin() * p2.cos() * dl.cos();
        y.atan2(x)
    }

    /// The point `distance` metres away on `bearing` (radians).
    pub fn destination(self, bearing: f64, distance: f64) -> LatLon {
        let d = distance / EARTH_RADIUS;
        let p1 = self.lat.to_radians();
        let l1 = self.lon.to_radians();
        let p2 = (p1.sin() * d.cos() + p1.cos() * d.sin() * bearing.cos()).asin();
        let l2 = l1 + (bearing.sin() * d.sin() * p1.cos()).atan2(d.cos() - p1.sin() * p2.sin());
        LatLon {
            lat: p2.to_degrees(),
            lon: (l2.to_degrees() + 540.0) % 360.0 - 180.0,
        }
    }

    /// Whether the position is inside `polygon` (its vertices in order; ray
    /// casting in degrees, fine for fences of a few kilometres away from
    /// the poles and the antimeridian).
    pub fn inside(self, polygon: &[LatLon]) -> bool {
        let mut inside = false;
        let n = polygon.len();
        for i in 0..n {
            let a = polygon[i];
            let b = polygon[(i + n - 1) % n];
            if (a.lat > self.lat) != (b.lat > self.lat) {
                let lon_at = a.lon + (self.lat - a.lat) / (b.lat - a.lat) * (b.lon - a.lon);
                if self.lon < lon_at {
                    inside = !inside;
                }
            }
        }
        inside
    }

    /// Rounded to MAVLink's integer precision (1e-7 degree, ~1 cm).
    pub fn rounded(self) -> LatLon {
        LatLon {
            lat: (self.lat * 1e7).round() / 1e7,
            lon: (self.lon * 1e7).round() / 1e7,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOME: LatLon = LatLon {
        lat: -35.363261,
        lon: 149.165230,
    };

    #[test]
    fn a_thousandth_of_a_degree_of_latitude_is_about_111_m() {
        let d = HOME.distance(LatLon::new(HOME.lat + 0.001, HOME.lon));
        assert!((d - 111.19).abs() < 0.1, "{d}");
        // Longitude shrinks with cos(latitude): 0.8155 at CMAC.
        let d = HOME.distance(LatLon::new(HOME.lat, HOME.lon + 0.001));
        assert!((d - 111.19 * 0.8155).abs() < 0.2, "{d}");
    }

    #[test]
    fn destination_and_bearing_agree() {
        for bearing in [0.0f64, 45.0, 135.0, 200.0, 300.0] {
            let b = bearing.to_radians();
            let p = HOME.destination(b, 400.0);
            assert!((HOME.distance(p) - 400.0).abs() < 1e-6);
            let back = HOME.bearing(p).rem_euclid(std::f64::consts::TAU);
            assert!((back - b).abs() < 1e-6, "{bearing}: {back}");
        }
    }

    #[test]
    fn inside_a_square_and_outside() {
        let square = [
            LatLon::new(-1.0, -1.0),
            LatLon::new(-1.0, 1.0),
            LatLon::new(1.0, 1.0),
            LatLon::new(1.0, -1.0),
        ];
        assert!(LatLon::new(0.0, 0.0).inside(&square));
        assert!(LatLon::new(0.9, -0.9).inside(&square));
        assert!(!LatLon::new(1.1, 0.0).inside(&square));
        assert!(!LatLon::new(0.0, -1.5).inside(&square));
        // A concave L: the notch is outside.
        let l = [
            LatLon::new(0.0, 0.0),
            LatLon::new(0.0, 2.0),
            LatLon::new(1.0, 2.0),
            LatLon::new(1.0, 1.0),
            LatLon::new(2.0, 1.0),
            LatLon::new(2.0, 0.0),
        ];
        assert!(LatLon::new(1.5, 0.5).inside(&l));
        assert!(!LatLon::new(1.5, 1.5).inside(&l));
    }

    #[test]
    fn rounding_keeps_seven_decimals() {
        let p = LatLon::new(-35.363_261_49, 149.165_230_51).rounded();
        assert_eq!((p.lat, p.lon), (-35.363_261_5, 149.165_230_5));
    }
}
