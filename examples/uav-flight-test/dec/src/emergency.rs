//! The emergency landing site for an engine-out glide: the nearest site the
//! aircraft can reach from where it is, keeping the mission's margin of the
//! glide range in reserve; none reachable, the nearest all the same,
//! flagged.
//!
//! Its mission brings the aircraft to the site on its glide path, since an
//! autopilot holding its airspeed cannot descend more steeply than it
//! glides: the final leg, `emergency_approach` metres long, starts from a
//! key point on the line from the site toward the aircraft, at the height
//! the glide needs for it (`emergency_approach / glide_ratio`). Energy to
//! spare at the key point is burnt in a loiter over it (LOITER_TIME, as long
//! as the glide's sink rate takes) when it is worth at least one whole
//! circle: ArduPlane leaves a loiter only once headed for the next item,
//! and on real ArduPlane SITL an engine-out plane that entered a loiter
//! with less to spare came down in it, 150 m short. Less than that, and it
//! goes to the key point and straight in.

use serde_json::{json, Value};

use crate::geo::LatLon;
use crate::mission::{Mission, Site};

/// Below this height at the key point, the aircraft goes straight to the
/// site (m).
pub const MIN_KEY_HEIGHT: f64 = 10.0;

/// A chosen site and its mission.
#[derive(Debug, Clone, PartialEq)]
pub struct Choice {
    pub name: String,
    pub at: LatLon,
    /// Metres from the aircraft.
    pub distance: f64,
    /// Within the glide range less the margin.
    pub reachable: bool,
    /// The emergency mission, as `upload_mission` takes it.
    pub items: Value,
}

/// The height (m) an engine-out loiter circle costs: its time at cruise
/// speed, at the loiter's sink rate.
pub fn circle_sink(mission: &Mission) -> f64 {
    let f = &mission.flight;
    std::f64::consts::TAU * f.loiter_radius / f.cruise_speed * loiter_sink(mission)
}

/// The glide range (m) from `height` metres above a site.
pub fn glide_range(mission: &Mission, height: f64) -> f64 {
    height.max(0.0) * mission.flight.glide_ratio * (1.0 - mission.flight.glide_margin)
}

/// The sink rate (m/s) of an engine-out loiter at cruise speed: the glide's
/// (speed / glide ratio), raised by the turn's load factor 1 / cos(bank),
/// the bank that holds the loiter radius.
pub fn loiter_sink(mission: &Mission) -> f64 {
    let f = &mission.flight;
    let bank = (f.cruise_speed.powi(2) / (9.80665 * f.loiter_radius)).atan();
    f.cruise_speed / f.glide_ratio / bank.cos().max(0.2)
}

/// Picks the site for an aircraft at `from`, `alt` metres above home.
pub fn choose(mission: &Mission, from: LatLon, alt: f64) -> Option<Choice> {
    let candidates: Vec<(&Site, f64, bool)> = mission
        .sites
        .iter()
        .map(|s| {
            let height = alt + mission.home_alt - s.elevation;
            let d = from.distance(s.at);
            (s, d, d <= glide_range(mission, height))
        })
        .collect();
    let nearest = |reachable_only: bool| {
        candidates
            .iter()
            .filter(|c| c.2 || !reachable_only)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .copied()
    };
    let (site, distance, reachable) = nearest(true).or_else(|| nearest(false))?;
    Some(Choice {
        name: site.name.clone(),
        at: site.at,
        distance,
        reachable,
        items: items(mission, from, alt, site, distance),
    })
}

fn items(mission: &Mission, from: LatLon, alt: f64, site: &Site, distance: f64) -> Value {
    let site_alt = site.elevation - mission.home_alt; // relative to home
    let at = site.at.rounded();
    let land = json!({"command": "LAND", "lat": at.lat, "lon": at.lon, "alt": site_alt});
    let glide = mission.flight.glide_ratio;
    let leg = mission.flight.emergency_approach;
    // The key point: `leg` metres from the site, toward the aircraft.
    let bearing = if distance < 1.0 {
        0.0
    } else {
        site.at.bearing(from)
    };
    let key = site.at.destination(bearing, leg);
    let height = alt + mission.home_alt - site.elevation;
    let at_key = height - from.distance(key) / glide;
    if leg < 1.0 || !key.inside(&mission.fence) || at_key < MIN_KEY_HEIGHT {
        return json!([land]);
    }
    let final_height = leg / glide;
    let k = key.rounded();
    let round = |x: f64| (x * 10.0).round() / 10.0;
    let first = if at_key > final_height + circle_sink(mission) {
        // The loiter's time counts from its circle, reached this high.
        let radius = mission.flight.loiter_radius;
        let at_circle = height - (from.distance(key) - radius).max(0.0) / glide;
        let sink = loiter_sink(mission);
        json!({"command": "LOITER_TIME", "lat": k.lat, "lon": k.lon,
               "alt": round(site_alt + final_height),
               "p1": ((at_circle - final_height) / sink).ceil()})
    } else {
        json!({"command": "WAYPOINT", "lat": k.lat, "lon": k.lon,
               "alt": round(site_alt + at_key.min(final_height))})
    };
    json!([first, land])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::tests::{example, glider};

    /// A position `north`, `east` metres from home.
    fn at(m: &Mission, north: f64, east: f64) -> LatLon {
        let p = m.home.destination(0.0, north);
        p.destination(std::f64::consts::FRAC_PI_2, east)
    }

    #[test]
    fn on_the_example_airframe_transit_and_operations_pick_two_sites() {
        // The example's numbers: ArduPlane 4.7 SITL's engine-out glide.
        let m = example();
        assert_eq!(m.flight.glide_ratio, 4.0);
        // Near T1 at 66 m (where the real-SITL scenario fails the engine):
        // the North field, straight in.
        let near_t1 = choose(&m, at(&m, 400.0, 20.0), 66.0).expect("a site");
        assert_eq!(near_t1.name, "North field");
        // Over O2 at 80 m: the East field.
        let o2 = choose(&m, at(&m, 620.0, 550.0), 80.0).expect("a site");
        assert_eq!(o2.name, "East field");
        assert_eq!(
            o2.items
                .as_array()
                .and_then(|a| a.last())
                .map(|l| l["command"].clone()),
            Some(json!("LAND"))
        );
    }

    #[test]
    fn in_transit_near_t1_the_north_field() {
        let m = glider();
        let c = choose(&m, at(&m, 380.0, 0.0), 80.0);
        let c = c.expect("a site");
        assert_eq!(c.name, "North field");
        assert!(c.reachable);
        assert!((c.distance - 275.0).abs() < 15.0, "{}", c.distance);
    }

    #[test]
    fn just_after_take_off_the_runway() {
        let m = glider();
        let c = choose(&m, at(&m, 200.0, 0.0), 40.0).expect("a site");
        assert_eq!(c.name, "Runway");
        assert!(c.reachable);
    }

    #[test]
    fn over_the_operations_area_the_east_field() {
        let m = glider();
        let c = choose(&m, at(&m, 620.0, 550.0), 80.0).expect("a site");
        assert_eq!(c.name, "East field");
        assert!(c.reachable);
    }

    #[test]
    fn the_nearest_reachable_not_the_nearest() {
        // A site within the glide range beats a nearer one that is not: the
        // North field (200 m away) on a hill 55 m high is out of reach from
        // 60 m; the runway (390 m away) is not.
        let mut m = glider();
        m.sites[1].elevation = m.home_alt + 55.0; // 5 m under the aircraft
        let c = choose(&m, at(&m, 300.0, -250.0), 60.0).expect("a site");
        assert_ne!(c.name, "North field");
        assert!(c.reachable);
    }

    #[test]
    fn none_reachable_the_nearest_flagged() {
        let m = glider();
        // 5 m up: 40 m of glide.
        let c = choose(&m, at(&m, 380.0, 0.0), 5.0).expect("a site");
        assert_eq!(c.name, "North field");
        assert!(!c.reachable);
    }

    #[test]
    fn glide_range_keeps_the_margin() {
        let m = glider();
        assert!((glide_range(&m, 80.0) - 640.0).abs() < 1e-9);
        assert_eq!(glide_range(&m, -3.0), 0.0);
    }

    fn key_point(items: &Value) -> (LatLon, Value) {
        let first = items[0].clone();
        let p = LatLon::new(
            first["lat"].as_f64().unwrap_or(0.0),
            first["lon"].as_f64().unwrap_or(0.0),
        );
        (p, first)
    }

    #[test]
    fn spare_height_is_burnt_over_the_key_point() {
        let m = glider();
        // Over O2, 80 m up, 300 m from the East field: 800 m of glide.
        let from = at(&m, 620.0, 550.0);
        let c = choose(&m, from, 80.0).expect("a site");
        let items = c.items.as_array().cloned().unwrap_or_default();
        assert_eq!(items.len(), 2, "{items:?}");
        assert_eq!(items[1]["command"], "LAND");
        assert_eq!(items[1]["lat"], -35.359205);
        assert_eq!(items[1]["alt"], 0.0);
        let (key, first) = key_point(&c.items);
        assert_eq!(first["command"], "LOITER_TIME");
        let site = m.sites[2].at;
        // The final leg: 300 m, from 30 m (glide ratio 10).
        assert!((key.distance(site) - 300.0).abs() < 1.0);
        assert_eq!(first["alt"], 30.0);
        // On the aircraft's side of the site.
        assert!(key.distance(from) < site.distance(from));
        // 80 m less the glide to the loiter circle, less 30 m, at the
        // loiter's sink rate: 2.2 m/s in a 39° bank (60 m at 22 m/s), 2.84 m/s.
        let sink = loiter_sink(&m);
        assert!((sink - 2.84).abs() < 0.01, "{sink}");
        // From the loiter's circle, 60 m before the key point: here the
        // aircraft is already on it (the key point 2 m away).
        assert!(from.distance(key) < 60.0);
        let at_circle = 80.0;
        let expect = ((at_circle - 30.0) / sink).ceil();
        assert_eq!(first["p1"].as_f64(), Some(expect));
        assert!(expect > 10.0, "{expect}");
    }

    #[test]
    fn no_height_to_spare_a_waypoint_then_land() {
        let m = glider();
        // 600 m south of the North field, 62 m up: at the key point (300 m
        // out) 32 m are left, 2 above the final leg's 30.
        let site = m.sites[1].at;
        let from = site.destination(std::f64::consts::PI, 600.0);
        let c = items(&m, from, 62.0, &m.sites[1], 600.0);
        let (_, first) = key_point(&c);
        assert_eq!(first["command"], "WAYPOINT");
        assert_eq!(first["alt"], 30.0);
        // Lower still: the key point's own height.
        let c = items(&m, from, 55.0, &m.sites[1], 600.0);
        let (_, first) = key_point(&c);
        assert_eq!(first["alt"], 25.0);
    }

    #[test]
    fn too_low_for_the_key_point_straight_in() {
        let m = glider();
        // 100 m north of the runway, 25 m up: the key point is 300 m
        // north, 200 m behind, and would be reached at 5 m.
        let c = choose(&m, at(&m, 100.0, 0.0), 25.0).expect("a site");
        assert_eq!(c.name, "Runway");
        assert_eq!(c.items.as_array().map(Vec::len), Some(1));
        assert_eq!(c.items[0]["command"], "LAND");
    }

    #[test]
    fn a_key_point_outside_the_fence_straight_in() {
        let mut m = glider();
        // A fence hugging the runway: the key point 300 m north is out.
        m.fence = vec![
            LatLon::new(-35.3650, 149.1630),
            LatLon::new(-35.3650, 149.1675),
            LatLon::new(-35.3620, 149.1675),
            LatLon::new(-35.3620, 149.1630),
        ];
        let from = at(&m, 100.0, 0.0);
        let c = items(&m, from, 80.0, &m.sites[0], 100.0);
        assert_eq!(c.as_array().map(Vec::len), Some(1));
    }
}
