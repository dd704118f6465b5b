//! The mission file: home, the flight's constants, the landing sequence,
//! the payloads, the route (transit and operations-area waypoints), the
//! emergency landing sites and the fence. Read once, checked whole: every
//! problem is reported with `file:line:col`.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;

use serde::Deserialize;

use crate::geo::LatLon;

/// The longest payload operation (s): OPERATIONS bounds each one with a
/// 40 s timer, which must outlast the loiter and the leg out of it.
pub const MAX_OPERATION_S: f64 = 30.0;

/// A checked mission.
#[derive(Debug, Clone, PartialEq)]
pub struct Mission {
    pub name: String,
    /// Home: the take-off and landing point. `alt` is above mean sea level.
    pub home: LatLon,
    pub home_alt: f64,
    pub flight: Flight,
    /// The approach waypoint of the landing sequence; `alt` above home.
    pub approach: LatLon,
    pub approach_alt: f64,
    pub payloads: BTreeMap<String, Payload>,
    /// The route, in order.
    pub waypoints: Vec<Waypoint>,
    pub sites: Vec<Site>,
    pub fence: Vec<LatLon>,
}

#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Flight {
    /// Metres above home.
    pub takeoff_alt: f64,
    /// Degrees.
    pub takeoff_pitch: f64,
    /// m/s.
    pub cruise_speed: f64,
    /// Metres forward per metre of height, engine out.
    pub glide_ratio: f64,
    /// The part of the glide range kept in reserve, in [0, 1).
    pub glide_margin: f64,
    /// Metres: the final leg to an emergency site.
    pub emergency_approach: f64,
    /// Metres: the autopilot's loiter radius (ArduPlane's WP_LOITER_RAD).
    pub loiter_radius: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Payload {
    pub kind: PayloadKind,
    /// The MAVLink component id (cameras): `payload_failure {component}`.
    pub component: Option<u8>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PayloadKind {
    Camera,
    Relay,
    Servo,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Area {
    Transit,
    Operations,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Waypoint {
    pub name: String,
    pub area: Area,
    pub at: LatLon,
    /// Metres above home.
    pub alt: f64,
    /// The payload operated over it (operations area only).
    pub payload: Option<String>,
    /// Seconds of payload operation (LOITER_TIME).
    pub operation: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Site {
    pub name: String,
    pub at: LatLon,
    /// Metres above mean sea level.
    pub elevation: f64,
}

/// A problem in a mission file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}:{line}:{col}: {message}")]
pub struct Problem {
    pub file: String,
    pub line: usize,
    pub col: usize,
    pub message: String,
}

/// Every problem found in a mission file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}", .problems.iter().map(|p| p.to_string()).collect::<Vec<_>>().join("\n"))]
pub struct MissionError {
    pub problems: Vec<Problem>,
}

// ------------------------------------------------------------ raw file

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Raw {
    name: String,
    home: RawHome,
    flight: toml::Spanned<Flight>,
    landing: RawLanding,
    #[serde(default)]
    payloads: BTreeMap<String, toml::Spanned<RawPayload>>,
    #[serde(default, rename = "waypoint")]
    waypoints: Vec<toml::Spanned<RawWaypoint>>,
    #[serde(default, rename = "site")]
    sites: Vec<toml::Spanned<RawSite>>,
    fence: toml::Spanned<RawFence>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHome {
    lat: toml::Spanned<f64>,
    lon: toml::Spanned<f64>,
    alt: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLanding {
    approach: toml::Spanned<RawPoint>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPoint {
    lat: f64,
    lon: f64,
    alt: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPayload {
    kind: PayloadKind,
    component: Option<u8>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWaypoint {
    name: String,
    area: Area,
    lat: f64,
    lon: f64,
    alt: f64,
    payload: Option<String>,
    operation: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSite {
    name: String,
    lat: f64,
    lon: f64,
    elevation: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFence {
    polygon: Vec<[f64; 2]>,
}

impl Mission {
    /// Reads and checks the mission file at `path`.
    pub fn load(path: &Path) -> Result<Mission, MissionError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| MissionError {
            problems: vec![Problem {
                file: file.clone(),
                line: 0,
                col: 0,
                message: format!("cannot read the mission file: {e}"),
            }],
        })?;
        Mission::parse(&file, &text)
    }

    /// Parses and checks a mission file's text; `file` names it in problems.
    pub fn parse(file: &str, text: &str) -> Result<Mission, MissionError> {
        let mut check = Checker {
            file,
            text,
            problems: Vec::new(),
        };
        let raw: Raw = match toml::from_str(text) {
            Ok(raw) => raw,
            Err(e) => {
                let at = e.span().map_or(0, |s| s.start);
                check.problem(at..at, e.message().to_owned());
                return Err(MissionError {
                    problems: check.problems,
                });
            }
        };
        let mission = check.mission(raw);
        if check.problems.is_empty() {
            Ok(mission)
        } else {
            Err(MissionError {
                problems: check.problems,
            })
        }
    }

    /// The payload a failure names: a MAVLink component id (elaboration's
    /// `payload_failure {component}`), or a payload's name.
    pub fn payload_named(&self, failed: &serde_json::Value) -> Option<&str> {
        match failed {
            serde_json::Value::String(name) => self
                .payloads
                .get_key_value(name.as_str())
                .map(|(k, _)| k.as_str()),
            serde_json::Value::Number(n) => {
                let id = n.as_u64()?;
                self.payloads
                    .iter()
                    .find(|(_, p)| p.component.is_some_and(|c| u64::from(c) == id))
                    .map(|(k, _)| k.as_str())
            }
            _ => None,
        }
    }
}

struct Checker<'a> {
    file: &'a str,
    text: &'a str,
    problems: Vec<Problem>,
}

impl Checker<'_> {
    fn problem(&mut self, span: Range<usize>, message: String) {
        let at = span.start.min(self.text.len());
        let before = &self.text[..at];
        let line = before.matches('\n').count() + 1;
        let col = before.rfind('\n').map_or(at, |n| at - n - 1) + 1;
        self.problems.push(Problem {
            file: self.file.to_owned(),
            line,
            col,
            message,
        });
    }

    fn position(&mut self, span: Range<usize>, what: &str, lat: f64, lon: f64) -> LatLon {
        if !(lat.is_finite() && (-90.0..=90.0).contains(&lat)) {
            self.problem(
                span.clone(),
                format!("{what}: latitude {lat} is not in [-90, 90]"),
            );
        }
        if !(lon.is_finite() && (-180.0..=180.0).contains(&lon)) {
            self.problem(
                span,
                format!("{what}: longitude {lon} is not in [-180, 180]"),
            );
        }
        LatLon::new(lat, lon)
    }

    fn mission(&mut self, raw: Raw) -> Mission {
        if raw.name.trim().is_empty() {
            self.problem(0..0, "the mission has no name".into());
        }
        let home_span = raw.home.lat.span().start..raw.home.lon.span().end;
        let home = self.position(
            home_span,
            "home",
            *raw.home.lat.get_ref(),
            *raw.home.lon.get_ref(),
        );
        let flight_span = raw.flight.span();
        let flight = raw.flight.into_inner();
        for (name, value, ok) in [
            ("takeoff_alt", flight.takeoff_alt, flight.takeoff_alt > 0.0),
            (
                "takeoff_pitch",
                flight.takeoff_pitch,
                (0.0..=45.0).contains(&flight.takeoff_pitch),
            ),
            (
                "cruise_speed",
                flight.cruise_speed,
                flight.cruise_speed > 0.0,
            ),
            ("glide_ratio", flight.glide_ratio, flight.glide_ratio > 0.0),
            (
                "glide_margin",
                flight.glide_margin,
                (0.0..1.0).contains(&flight.glide_margin),
            ),
            (
                "emergency_approach",
                flight.emergency_approach,
                flight.emergency_approach >= 0.0,
            ),
            (
                "loiter_radius",
                flight.loiter_radius,
                flight.loiter_radius > 0.0,
            ),
        ] {
            if !(value.is_finite() && ok) {
                self.problem(
                    flight_span.clone(),
                    format!("flight.{name}: {value} is out of range"),
                );
            }
        }
        let approach_span = raw.landing.approach.span();
        let a = raw.landing.approach.into_inner();
        let approach = self.position(approach_span.clone(), "landing.approach", a.lat, a.lon);
        if !(a.alt.is_finite() && a.alt > 0.0) {
            self.problem(
                approach_span.clone(),
                format!("landing.approach: alt {} must be above home", a.alt),
            );
        }

        let mut payloads = BTreeMap::new();
        for (name, p) in raw.payloads {
            let span = p.span();
            let p = p.into_inner();
            if !is_name(&name) {
                self.problem(
                    span.clone(),
                    format!("payload `{name}`: a name is letters, digits and `_`"),
                );
            }
            if p.kind == PayloadKind::Camera && p.component.is_none() {
                self.problem(
                    span,
                    format!("payload `{name}`: a camera needs its MAVLink `component`"),
                );
            }
            payloads.insert(
                name,
                Payload {
                    kind: p.kind,
                    component: p.component,
                },
            );
        }

        let fence_span = raw.fence.span();
        let fence: Vec<LatLon> = raw
            .fence
            .into_inner()
            .polygon
            .iter()
            .map(|[lat, lon]| self.position(fence_span.clone(), "fence", *lat, *lon))
            .collect();
        if fence.len() < 3 {
            self.problem(
                fence_span.clone(),
                format!(
                    "fence: a polygon needs 3 points or more, not {}",
                    fence.len()
                ),
            );
        }
        let fenced = fence.len() >= 3;
        if fenced && !home.inside(&fence) {
            self.problem(fence_span.clone(), "home is outside the fence".into());
        }
        if fenced && !approach.inside(&fence) {
            self.problem(
                approach_span,
                "landing.approach is outside the fence".into(),
            );
        }

        let mut waypoints = Vec::new();
        let mut seen_operations = false;
        for w in raw.waypoints {
            let span = w.span();
            let w = w.into_inner();
            let what = format!("waypoint `{}`", w.name);
            let at = self.position(span.clone(), &what, w.lat, w.lon);
            if waypoints.iter().any(|o: &Waypoint| o.name == w.name) {
                self.problem(span.clone(), format!("{what} is named twice"));
            }
            if !(w.alt.is_finite() && w.alt > 0.0) {
                self.problem(
                    span.clone(),
                    format!("{what}: alt {} must be above home", w.alt),
                );
            }
            if fenced && !at.inside(&fence) {
                self.problem(span.clone(), format!("{what} is outside the fence"));
            }
            match w.area {
                Area::Operations => seen_operations = true,
                Area::Transit if seen_operations => self.problem(
                    span.clone(),
                    format!("{what}: transit waypoints come before the operations area"),
                ),
                Area::Transit => {}
            }
            if let Some(p) = &w.payload {
                if w.area == Area::Transit {
                    self.problem(
                        span.clone(),
                        format!("{what}: payloads operate in the operations area only"),
                    );
                }
                if !payloads.contains_key(p) {
                    self.problem(
                        span.clone(),
                        format!("{what}: unknown payload `{p}` (declare it in [payloads])"),
                    );
                }
            }
            let operation = match (&w.payload, w.operation) {
                (Some(_), Some(t)) if t.is_finite() && t > 0.0 && t <= MAX_OPERATION_S => t,
                (Some(_), Some(t)) => {
                    self.problem(
                        span.clone(),
                        format!("{what}: operation {t} s is not in (0, {MAX_OPERATION_S}]"),
                    );
                    0.0
                }
                (Some(_), None) => {
                    self.problem(
                        span.clone(),
                        format!("{what}: a payload needs its `operation` time (s)"),
                    );
                    0.0
                }
                (None, Some(_)) => {
                    self.problem(
                        span.clone(),
                        format!("{what}: `operation` without a payload"),
                    );
                    0.0
                }
                (None, None) => 0.0,
            };
            waypoints.push(Waypoint {
                name: w.name,
                area: w.area,
                at,
                alt: w.alt,
                payload: w.payload,
                operation,
            });
        }
        if waypoints.is_empty() {
            self.problem(0..0, "the mission has no [[waypoint]]".into());
        }

        let mut sites = Vec::new();
        for s in raw.sites {
            let span = s.span();
            let s = s.into_inner();
            let what = format!("site `{}`", s.name);
            let at = self.position(span.clone(), &what, s.lat, s.lon);
            if !s.elevation.is_finite() {
                self.problem(span.clone(), format!("{what}: bad elevation"));
            }
            if fenced && !at.inside(&fence) {
                self.problem(span, format!("{what} is outside the fence"));
            }
            sites.push(Site {
                name: s.name,
                at,
                elevation: s.elevation,
            });
        }
        if sites.is_empty() {
            self.problem(0..0, "the mission has no emergency landing [[site]]".into());
        }

        Mission {
            name: raw.name,
            home,
            home_alt: raw.home.alt,
            flight,
            approach,
            approach_alt: a.alt,
            payloads,
            waypoints,
            sites,
            fence,
        }
    }
}

fn is_name(s: &str) -> bool {
    let mut chars = s.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The example's mission file.
    /// The example with a clean glider's numbers (10:1, a 300 m final
    /// leg), on which DEC's emergency geometry is tested whatever the
    /// example's airframe measures.
    pub(crate) fn glider() -> Mission {
        let mut m = example();
        m.flight.glide_ratio = 10.0;
        m.flight.emergency_approach = 300.0;
        m
    }

    pub(crate) fn example() -> Mission {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../mission.toml");
        match Mission::load(&path) {
            Ok(m) => m,
            Err(e) => panic!("the example's mission file: {e}"),
        }
    }

    #[test]
    fn the_example_mission_reads() {
        let m = example();
        assert_eq!(m.name, "CMAC flight test");
        assert_eq!(m.home, LatLon::new(-35.363261, 149.165230));
        assert_eq!(m.home_alt, 584.0);
        let names: Vec<&str> = m.waypoints.iter().map(|w| w.name.as_str()).collect();
        assert_eq!(names, ["T1", "O1", "O2", "O3"]);
        assert_eq!(m.waypoints[1].payload.as_deref(), Some("camera"));
        assert_eq!(m.waypoints[2].payload.as_deref(), Some("sensor"));
        assert_eq!(m.payloads["camera"].component, Some(100));
        assert_eq!(m.sites.len(), 3);
        assert_eq!(m.fence.len(), 4);
    }

    #[test]
    fn the_example_legs_are_short() {
        // The first operations-area waypoint within ~40 s of the take-off
        // (the demo's budget), every leg a few hundred metres.
        let m = example();
        let first_ops = m
            .waypoints
            .iter()
            .position(|w| w.area == Area::Operations)
            .unwrap_or(0);
        let mut to_first = 0.0;
        let mut from = m.home;
        for w in &m.waypoints[..=first_ops] {
            to_first += from.distance(w.at);
            from = w.at;
        }
        assert!(to_first / m.flight.cruise_speed < 40.0, "{to_first} m");
        let mut from = m.home;
        for w in &m.waypoints {
            assert!(from.distance(w.at) < 700.0, "leg to {}", w.name);
            from = w.at;
        }
    }

    #[test]
    fn a_payload_is_found_by_component_or_name() {
        let m = example();
        assert_eq!(m.payload_named(&serde_json::json!(100)), Some("camera"));
        assert_eq!(
            m.payload_named(&serde_json::json!("sensor")),
            Some("sensor")
        );
        assert_eq!(m.payload_named(&serde_json::json!(101)), None);
        assert_eq!(m.payload_named(&serde_json::json!("lidar")), None);
        assert_eq!(m.payload_named(&serde_json::json!(true)), None);
    }

    fn problems(text: &str) -> Vec<String> {
        match Mission::parse("m.toml", text) {
            Ok(_) => Vec::new(),
            Err(e) => e.problems.iter().map(|p| p.to_string()).collect(),
        }
    }

    fn example_text() -> String {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../mission.toml");
        std::fs::read_to_string(path).unwrap_or_default()
    }

    #[test]
    fn toml_errors_say_where() {
        let p = problems("name = \"x\"\n[home]\nlat = -35.0\nlon = = 1\n");
        assert_eq!(p.len(), 1, "{p:?}");
        assert!(p[0].starts_with("m.toml:4:"), "{p:?}");
        let p = problems(&example_text().replace("glide_ratio", "glide_rati"));
        assert!(p[0].contains("glide_rati"), "{p:?}");
        assert!(p[0].starts_with("m.toml:"), "{p:?}");
    }

    #[test]
    fn every_problem_is_reported_with_its_line() {
        let text = example_text()
            .replace("payload = \"sensor\"", "payload = \"lidar\"")
            .replace(
                "operation = 10.0\n\n[[waypoint]]\nname = \"O3\"",
                "operation = 45.0\n\n[[waypoint]]\nname = \"O3\"",
            )
            .replace("lat = -35.358754", "lat = -35.3");
        let p = problems(&text);
        assert_eq!(p.len(), 3, "{p:#?}");
        assert!(p.iter().any(|p| p.contains("unknown payload `lidar`")));
        assert!(p
            .iter()
            .any(|p| p.contains("operation 45 s is not in (0, 30]")));
        assert!(p
            .iter()
            .any(|p| p.contains("site `North field` is outside the fence")));
        // Each at the line of its table.
        let line_of = |needle: &str| {
            example_text()
                .lines()
                .position(|l| l.contains(needle))
                .map_or(0, |i| i + 1)
        };
        let site = p
            .iter()
            .find(|p| p.contains("North field"))
            .cloned()
            .unwrap_or_default();
        let site_line = line_of("name = \"North field\"") - 1; // the [[site]] header
        assert!(
            site.starts_with(&format!("m.toml:{site_line}:")),
            "{site} vs {site_line}"
        );
    }

    #[test]
    fn a_transit_waypoint_after_the_operations_area_is_refused() {
        let text = example_text().replace(
            "area = \"operations\"\nlat = -35.360557",
            "area = \"transit\"\nlat = -35.360557",
        );
        let p = problems(&text.replace(
            "payload = \"camera\"\noperation = 10.0\n\n# Emergency",
            "\n# Emergency",
        ));
        assert!(
            p.iter()
                .any(|p| p
                    .contains("waypoint `O3`: transit waypoints come before the operations area")),
            "{p:?}"
        );
    }
}
