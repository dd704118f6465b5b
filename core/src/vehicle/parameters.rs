//! The autopilot parameters a project needs (`[gateway.parameters]` in
//! project.toml), read from the vehicle at start with PARAM_REQUEST_READ
//! and judged: a mission that uses DO_LAND_START on ArduPlane needs
//! `RTL_AUTOLAND` set, or the autopilot refuses to arm. Sans-IO: fed the
//! vehicle's PARAM_VALUEs and the time, polled for the requests to send and
//! for the verdict once every parameter is answered or given up on.

use std::collections::BTreeMap;

use elaboration::Firmware;
use mavlink::dialects::ardupilotmega::{MavMessage, PARAM_REQUEST_READ_DATA, PARAM_VALUE_DATA};
use nets::Micros;

/// What a parameter must be.
#[derive(Debug, Clone, PartialEq)]
pub enum Expected {
    /// Exactly this value.
    Equal(f64),
    /// One of these values.
    OneOf(Vec<f64>),
    /// Within these bounds (inclusive; either may be open).
    Range { min: Option<f64>, max: Option<f64> },
}

impl Expected {
    /// Whether `value` (as PARAM_VALUE carries it: an f32) satisfies it.
    /// Values compare at f32 precision: that is all the wire carries.
    pub fn holds(&self, value: f64) -> bool {
        let same = |a: f64, b: f64| (a as f32) == (b as f32);
        match self {
            Expected::Equal(v) => same(*v, value),
            Expected::OneOf(vs) => vs.iter().any(|v| same(*v, value)),
            Expected::Range { min, max } => {
                min.is_none_or(|m| value >= m as f32 as f64)
                    && max.is_none_or(|m| value <= m as f32 as f64)
            }
        }
    }
}

impl std::fmt::Display for Expected {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Expected::Equal(v) => write!(f, "{v}"),
            Expected::OneOf(vs) => {
                let list: Vec<String> = vs.iter().map(|v| v.to_string()).collect();
                write!(f, "one of {}", list.join(", "))
            }
            Expected::Range { min, max } => match (min, max) {
                (Some(a), Some(b)) => write!(f, "between {a} and {b}"),
                (Some(a), None) => write!(f, "at least {a}"),
                (None, Some(b)) => write!(f, "at most {b}"),
                (None, None) => write!(f, "any value"),
            },
        }
    }
}

/// One parameter that did not fit.
#[derive(Debug, Clone, PartialEq)]
pub enum Misfit {
    /// The vehicle has it, with another value.
    Wrong {
        name: String,
        value: f64,
        expected: Expected,
    },
    /// The vehicle never answered for it (it may not have it at all);
    /// `autopilot`: the vehicle's firmware, when its HEARTBEAT said.
    Unanswered {
        name: String,
        expected: Expected,
        autopilot: Option<Firmware>,
    },
}

/// A firmware for people: the names crews know.
fn autopilot_name(firmware: Firmware) -> &'static str {
    match firmware {
        Firmware::Px4 => "PX4",
        Firmware::Plane => "ArduPlane",
        Firmware::Copter => "ArduCopter",
        Firmware::Rover => "ArduRover",
        Firmware::Sub => "ArduSub",
        Firmware::Other => "an autopilot Petrel does not know",
    }
}

impl std::fmt::Display for Misfit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Misfit::Wrong {
                name,
                value,
                expected,
            } => write!(f, "{name} is {value} on the vehicle; the project needs {expected}"),
            Misfit::Unanswered {
                name,
                expected,
                autopilot: None,
            } => write!(
                f,
                "{name} could not be read from the vehicle (no PARAM_VALUE after {ATTEMPTS} requests); the project needs {expected}"
            ),
            Misfit::Unanswered {
                name,
                expected,
                autopilot: Some(firmware),
            } => {
                let other = if *firmware == Firmware::Px4 {
                    "ArduPilot"
                } else {
                    "PX4 or another ArduPilot vehicle"
                };
                write!(
                    f,
                    "the vehicle is {} and has no parameter {name} (no PARAM_VALUE after {ATTEMPTS} requests); this project's [gateway.parameters] need it ({expected}): it is made for {other}",
                    autopilot_name(*firmware)
                )
            }
        }
    }
}

/// The outcome of the check.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// Every parameter read, with its value.
    pub read: BTreeMap<String, f64>,
    /// What did not fit; empty when the vehicle is as the project needs.
    pub misfits: Vec<Misfit>,
}

impl Verdict {
    pub fn holds(&self) -> bool {
        self.misfits.is_empty()
    }
}

/// Requests per parameter before it counts as unanswered.
pub const ATTEMPTS: u8 = 3;
/// Wait for a PARAM_VALUE before asking again.
pub const PATIENCE: Micros = 1_000_000;

#[derive(Debug, Clone)]
struct Wanted {
    name: String,
    expected: Expected,
    value: Option<f64>,
    asked: u8,
}

/// The check, from the target's first HEARTBEAT to its verdict.
#[derive(Debug, Clone)]
pub struct ParameterCheck {
    wanted: Vec<Wanted>,
    target: Option<(u8, u8)>,
    next_ask: Micros,
    verdict: Option<Verdict>,
    reported: bool,
}

impl ParameterCheck {
    /// `rules`: name and expectation, in the project's order.
    pub fn new(rules: &[(String, Expected)]) -> ParameterCheck {
        ParameterCheck {
            wanted: rules
                .iter()
                .map(|(name, expected)| Wanted {
                    name: name.clone(),
                    expected: expected.clone(),
                    value: None,
                    asked: 0,
                })
                .collect(),
            target: None,
            next_ask: 0,
            verdict: None,
            reported: false,
        }
    }

    /// Judged, or nothing to judge: commands may go to the vehicle.
    pub fn settled(&self) -> bool {
        self.wanted.is_empty() || self.verdict.is_some()
    }

    /// The autopilot is known: ask from `now` on.
    pub fn start(&mut self, target: (u8, u8), now: Micros) {
        if self.target.is_none() && !self.wanted.is_empty() {
            self.target = Some(target);
            self.next_ask = now;
        }
    }

    /// A PARAM_VALUE from the autopilot.
    pub fn value(&mut self, value: &PARAM_VALUE_DATA) {
        let name = param_name(&value.param_id[..]);
        for w in &mut self.wanted {
            if w.name == name && w.value.is_none() {
                w.value = Some(f64::from(value.param_value));
            }
        }
        self.judge();
    }

    /// The requests due by `now`, to be sent to the autopilot.
    pub fn poll(&mut self, now: Micros, out: &mut impl FnMut(MavMessage)) {
        let Some((system, component)) = self.target else {
            return;
        };
        if self.verdict.is_some() || now < self.next_ask {
            return;
        }
        let mut asked = false;
        for w in self.wanted.iter_mut().filter(|w| w.value.is_none()) {
            if w.asked < ATTEMPTS {
                w.asked += 1;
                asked = true;
                out(MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
                    param_index: -1,
                    target_system: system,
                    target_component: component,
                    param_id: param_id(&w.name).into(),
                }));
            }
        }
        self.next_ask = now + PATIENCE;
        if !asked {
            // Every request spent and the last patience over.
            self.judge_final();
        }
    }

    /// When `poll` next has something to do.
    pub fn next_deadline(&self) -> Option<Micros> {
        (self.target.is_some() && self.verdict.is_none()).then_some(self.next_ask)
    }

    /// The verdict, once (then `None`); `autopilot`, the vehicle's
    /// firmware if known, names it in what it could not read.
    pub fn poll_verdict(&mut self, autopilot: Option<Firmware>) -> Option<Verdict> {
        if self.reported {
            return None;
        }
        let mut v = self.verdict.clone()?;
        self.reported = true;
        for m in &mut v.misfits {
            if let Misfit::Unanswered { autopilot: a, .. } = m {
                *a = autopilot;
            }
        }
        Some(v)
    }

    fn judge(&mut self) {
        if self.verdict.is_none() && self.wanted.iter().all(|w| w.value.is_some()) {
            self.judge_final();
        }
    }

    fn judge_final(&mut self) {
        let mut read = BTreeMap::new();
        let mut misfits = Vec::new();
        for w in &self.wanted {
            match w.value {
                Some(v) => {
                    read.insert(w.name.clone(), v);
                    if !w.expected.holds(v) {
                        misfits.push(Misfit::Wrong {
                            name: w.name.clone(),
                            value: v,
                            expected: w.expected.clone(),
                        });
                    }
                }
                None => misfits.push(Misfit::Unanswered {
                    name: w.name.clone(),
                    expected: w.expected.clone(),
                    autopilot: None,
                }),
            }
        }
        self.verdict = Some(Verdict { read, misfits });
    }
}

/// A parameter name as the wire carries it: 16 bytes, NUL-padded.
fn param_id(name: &str) -> [u8; 16] {
    let mut id = [0u8; 16];
    for (slot, b) in id.iter_mut().zip(name.bytes()) {
        *slot = b;
    }
    id
}

/// The name in a PARAM_VALUE (up to the first NUL; 16 bytes without one).
fn param_name(id: &[u8]) -> String {
    let end = id.iter().position(|&b| b == 0).unwrap_or(id.len());
    String::from_utf8_lossy(&id[..end]).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::MavParamType;

    fn value(name: &str, v: f32) -> PARAM_VALUE_DATA {
        PARAM_VALUE_DATA {
            param_value: v,
            param_count: 1406,
            param_index: 65535,
            param_id: param_id(name).into(),
            param_type: MavParamType::MAV_PARAM_TYPE_INT8,
        }
    }

    fn sent(check: &mut ParameterCheck, now: Micros) -> Vec<String> {
        let mut out = Vec::new();
        check.poll(now, &mut |m| {
            if let MavMessage::PARAM_REQUEST_READ(r) = m {
                assert_eq!(
                    (r.target_system, r.target_component, r.param_index),
                    (1, 1, -1)
                );
                out.push(param_name(&r.param_id[..]));
            }
        });
        out
    }

    #[test]
    fn asks_each_once_then_judges_the_answers() {
        let mut c = ParameterCheck::new(&[
            ("RTL_AUTOLAND".into(), Expected::OneOf(vec![1.0, 2.0])),
            ("FS_LONG_ACTN".into(), Expected::Equal(1.0)),
        ]);
        assert!(
            sent(&mut c, 0).is_empty(),
            "nothing before the autopilot is known"
        );
        c.start((1, 1), 5);
        assert_eq!(sent(&mut c, 5), ["RTL_AUTOLAND", "FS_LONG_ACTN"]);
        assert!(sent(&mut c, 6).is_empty(), "patience");
        c.value(&value("RTL_AUTOLAND", 0.0));
        assert_eq!(c.poll_verdict(None), None, "one still unanswered");
        c.value(&value("FS_LONG_ACTN", 1.0));
        let v = c.poll_verdict(None).expect("a verdict");
        assert!(!v.holds());
        assert_eq!(
            v.misfits[0].to_string(),
            "RTL_AUTOLAND is 0 on the vehicle; the project needs one of 1, 2"
        );
        assert_eq!(v.misfits.len(), 1);
        assert_eq!(v.read["FS_LONG_ACTN"], 1.0);
        assert_eq!(c.poll_verdict(None), None, "reported once");
        assert_eq!(c.next_deadline(), None);
    }

    #[test]
    fn an_unanswered_parameter_is_asked_again_then_named() {
        let mut c = ParameterCheck::new(&[("NO_SUCH".into(), Expected::Equal(1.0))]);
        c.start((1, 1), 0);
        let mut t = 0;
        let mut asked = 0;
        while c.poll_verdict(None).is_none() {
            asked += sent(&mut c, t).len();
            t = c.next_deadline().unwrap_or(t);
            assert!(t < 10 * PATIENCE, "never gives up");
        }
        assert_eq!(asked, usize::from(ATTEMPTS));
        let mut c2 = c.clone();
        c2.reported = false;
        let v = c2.poll_verdict(None).expect("kept");
        assert!(matches!(v.misfits[0], Misfit::Unanswered { .. }));
        assert!(v.misfits[0].to_string().contains("could not be read"));
        // The vehicle's firmware known, the words say which it is.
        let mut px4 = c.clone();
        px4.reported = false;
        let v = px4.poll_verdict(Some(Firmware::Px4)).expect("kept");
        assert_eq!(
            v.misfits[0].to_string(),
            "the vehicle is PX4 and has no parameter NO_SUCH (no PARAM_VALUE after 3 requests); this project's [gateway.parameters] need it (1): it is made for ArduPilot"
        );
        let mut copter = c.clone();
        copter.reported = false;
        let v = copter.poll_verdict(Some(Firmware::Copter)).expect("kept");
        assert!(
            v.misfits[0]
                .to_string()
                .starts_with("the vehicle is ArduCopter and has no parameter NO_SUCH"),
            "{}",
            v.misfits[0]
        );
    }

    #[test]
    fn nothing_to_check_asks_nothing_and_judges_nothing() {
        let mut c = ParameterCheck::new(&[]);
        c.start((1, 1), 0);
        assert!(sent(&mut c, 0).is_empty());
        assert_eq!(c.next_deadline(), None);
        assert_eq!(c.poll_verdict(None), None);
    }

    #[test]
    fn a_full_sixteen_byte_name_and_f32_precision() {
        let mut c = ParameterCheck::new(&[
            ("ABCDEFGHIJKLMNOP".into(), Expected::Equal(0.1)),
            (
                "R".into(),
                Expected::Range {
                    min: Some(0.3),
                    max: None,
                },
            ),
        ]);
        c.start((1, 1), 0);
        assert_eq!(sent(&mut c, 0), ["ABCDEFGHIJKLMNOP", "R"]);
        c.value(&value("ABCDEFGHIJKLMNOP", 0.1));
        c.value(&value("R", 0.3));
        assert!(c.poll_verdict(None).expect("verdict").holds());
    }

    #[test]
    fn expectations_read_for_people() {
        assert_eq!(Expected::Equal(2.0).to_string(), "2");
        assert_eq!(
            Expected::Range {
                min: Some(1.0),
                max: Some(3.0)
            }
            .to_string(),
            "between 1 and 3"
        );
        assert!(!Expected::Range {
            min: None,
            max: Some(3.0)
        }
        .holds(3.5));
    }
}
