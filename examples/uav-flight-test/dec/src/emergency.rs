//! The emergency landing site for an engine-out glide: the nearest site the
//! aircraft can reach from where it is, keeping the mission's margin of the
//! glide range in reserve; none reachable, the nearest all the same,
//! flagged. Its mission: an approach point `emergency_approach` metres
//! before the site on the line from the aircraft (when it is farther than
//! that), then LAND at the site.

use serde_json::{json, Value};

use crate::geo::LatLon;
use crate::mission::{Mission, Site};

/// How far a glide takes the aircraft, at least this high over the
/// approach point (m): the turn onto the landing.
pub const MIN_APPROACH_HEIGHT: f64 = 20.0;

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

/// The glide range (m) from `height` metres above a site.
pub fn glide_range(mission: &Mission, height: f64) -> f64 {
    height.max(0.0) * mission.flight.glide_ratio * (1.0 - mission.flight.glide_margin)
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
    let land = site.at.rounded();
    let land = json!({"command": "LAND", "lat": land.lat, "lon": land.lon, "alt": site_alt});
    let approach = mission.flight.emergency_approach;
    // Close enough: straight in.
    if distance <= approach * 1.5 {
        return json!([land]);
    }
    let point = site.at.destination(site.at.bearing(from), approach);
    if !point.inside(&mission.fence) {
        return json!([land]);
    }
    let height_there = alt - (distance - approach) / mission.flight.glide_ratio;
    let point_alt = height_there.clamp(
        site_alt + MIN_APPROACH_HEIGHT,
        alt.max(site_alt + MIN_APPROACH_HEIGHT),
    );
    let p = point.rounded();
    json!([
        {"command": "WAYPOINT", "lat": p.lat, "lon": p.lon, "alt": (point_alt * 10.0).round() / 10.0},
        land,
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::tests::example;

    /// A position `north`, `east` metres from home.
    fn at(m: &Mission, north: f64, east: f64) -> LatLon {
        let p = m.home.destination(0.0, north);
        p.destination(std::f64::consts::FRAC_PI_2, east)
    }

    #[test]
    fn in_transit_near_t1_the_north_field() {
        let m = example();
        let c = choose(&m, at(&m, 380.0, 0.0), 80.0);
        let c = c.expect("a site");
        assert_eq!(c.name, "North field");
        assert!(c.reachable);
        assert!((c.distance - 275.0).abs() < 15.0, "{}", c.distance);
    }

    #[test]
    fn just_after_take_off_the_runway() {
        let m = example();
        let c = choose(&m, at(&m, 200.0, 0.0), 40.0).expect("a site");
        assert_eq!(c.name, "Runway");
        assert!(c.reachable);
    }

    #[test]
    fn over_the_operations_area_the_east_field() {
        let m = example();
        let c = choose(&m, at(&m, 620.0, 550.0), 80.0).expect("a site");
        assert_eq!(c.name, "East field");
        assert!(c.reachable);
    }

    #[test]
    fn the_nearest_reachable_not_the_nearest() {
        // A site within the glide range beats a nearer one that is not: the
        // North field (200 m away) on a hill 55 m high is out of reach from
        // 60 m; the runway (390 m away) is not.
        let mut m = example();
        m.sites[1].elevation = m.home_alt + 55.0; // 5 m under the aircraft
        let c = choose(&m, at(&m, 300.0, -250.0), 60.0).expect("a site");
        assert_ne!(c.name, "North field");
        assert!(c.reachable);
    }

    #[test]
    fn none_reachable_the_nearest_flagged() {
        let m = example();
        // 5 m up: 40 m of glide.
        let c = choose(&m, at(&m, 380.0, 0.0), 5.0).expect("a site");
        assert_eq!(c.name, "North field");
        assert!(!c.reachable);
    }

    #[test]
    fn glide_range_keeps_the_margin() {
        let m = example();
        assert!((glide_range(&m, 80.0) - 640.0).abs() < 1e-9);
        assert_eq!(glide_range(&m, -3.0), 0.0);
    }

    #[test]
    fn the_mission_approaches_then_lands_at_the_site() {
        let m = example();
        let from = at(&m, 620.0, 550.0);
        let c = choose(&m, from, 80.0).expect("a site");
        let items = c.items.as_array().cloned().unwrap_or_default();
        assert_eq!(items.len(), 2, "{items:?}");
        assert_eq!(items[0]["command"], "WAYPOINT");
        assert_eq!(items[1]["command"], "LAND");
        assert_eq!(items[1]["lat"], -35.359205);
        assert_eq!(items[1]["alt"], 0.0);
        let approach = LatLon::new(
            items[0]["lat"].as_f64().unwrap_or(0.0),
            items[0]["lon"].as_f64().unwrap_or(0.0),
        );
        let site = m.sites[2].at;
        assert!((approach.distance(site) - 150.0).abs() < 1.0);
        // On the line from the aircraft: closer to it than the site is.
        assert!(approach.distance(from) < site.distance(from));
        // Lower than the aircraft, by the glide over the distance flown.
        let alt = items[0]["alt"].as_f64().unwrap_or(0.0);
        assert!((MIN_APPROACH_HEIGHT..80.0).contains(&alt), "{alt}");
    }

    #[test]
    fn close_to_the_site_straight_in() {
        let m = example();
        let c = choose(&m, at(&m, 100.0, 0.0), 30.0).expect("a site");
        assert_eq!(c.name, "Runway");
        assert_eq!(c.items.as_array().map(Vec::len), Some(1));
    }
}
