//! Faults the simulation can inject, and their schedule: from the test API
//! (`Sim::inject`) or from `--fault` flags.
//!
//! Schedule syntax, one fault per flag:
//!
//! ```text
//! KIND[=VALUE]@WHEN[:DURATION]
//!   KIND      engine_failure | payload_failure | gps_loss | battery_drain
//!             | battery | link_loss | emergency
//!             | reboot | refuse_commands | refuse_command | garbage
//!             | duplicate | reorder | stuck
//!   VALUE     payload_failure=silent|critical (default silent)
//!             battery_drain=FACTOR             (default 10: ten times faster)
//!             battery=PERCENT                  (sets the remaining charge; required)
//!             emergency=TEXT                   (the STATUSTEXT; default "Emergency")
//!             reboot=SECONDS                   (silent that long, then boots; default 1.5)
//!             refuse_commands=denied|failed|temporarily_rejected (default denied)
//!             refuse_command=…                 (the same, for the next command only)
//!             garbage=BYTES                    (a burst of random bytes; default 512)
//!   WHEN      90s | 90 | 1.5s   sim seconds since the simulation started
//!                               (its first boot; a reboot does not reset it)
//!             wp3               when MISSION_ITEM_REACHED 3 is sent
//!   DURATION  10s | 10          the fault clears after that long (sim seconds);
//!                               without it the fault stays
//! ```
//!
//! Examples: `engine_failure@90s`, `link_loss@60s:10s`,
//! `payload_failure=critical@wp3`, `battery=20@120s`, `gps_loss@wp2:15s`,
//! `reboot@300s`, `refuse_commands@wp3:5s`, `garbage=2000@40s`,
//! `duplicate@50s:10s`, `reorder@70s:10s`, `stuck@wp2:30s`.
//!
//! The link faults (`garbage`, `duplicate`, `reorder`, and `link_loss`)
//! act on the vehicle's side of the link: what it sends is corrupted,
//! doubled or swapped on the wire by [`crate::Sim`]'s socket (a radio's
//! faults, as the gateway sees them); the core [`crate::Vehicle`] only
//! says which are active ([`crate::Vehicle::take_wire_faults`]).

use std::fmt;
use std::str::FromStr;

/// How a payload fails.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PayloadFailure {
    /// The camera stops: no heartbeat, no answer.
    Silent,
    /// The camera keeps its heartbeat but reports MAV_STATE_CRITICAL.
    Critical,
}

/// How the autopilot refuses a command under [`Fault::RefuseCommands`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// MAV_RESULT_DENIED.
    Denied,
    /// MAV_RESULT_FAILED.
    Failed,
    /// MAV_RESULT_TEMPORARILY_REJECTED.
    TemporarilyRejected,
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Refusal::Denied => "denied",
            Refusal::Failed => "failed",
            Refusal::TemporarilyRejected => "temporarily_rejected",
        })
    }
}

impl FromStr for Refusal {
    type Err = ();

    fn from_str(s: &str) -> Result<Refusal, ()> {
        match s.trim() {
            "denied" => Ok(Refusal::Denied),
            "failed" => Ok(Refusal::Failed),
            "temporarily_rejected" => Ok(Refusal::TemporarilyRejected),
            _ => Err(()),
        }
    }
}

/// A fault.
#[derive(Debug, Clone, PartialEq)]
pub enum Fault {
    /// The engine stops: rpm winds down to 0, no thrust, the aircraft
    /// glides while the autopilot keeps asking for throttle.
    EngineFailure,
    /// The camera (component 100) fails.
    PayloadFailure(PayloadFailure),
    /// The GPS loses its fix: fix_type NO_FIX, 0 satellites; the EKF loses
    /// its horizontal position and velocity aiding.
    GpsLoss,
    /// The battery drains `factor` times faster.
    BatteryDrain { factor: f64 },
    /// The battery's remaining charge becomes `percent` (at once).
    BatteryRemaining { percent: f64 },
    /// The radio link is lost: nothing goes out, nothing coming in is read.
    LinkLoss,
    /// An emergency: HEARTBEAT.system_status EMERGENCY and this STATUSTEXT
    /// (severity EMERGENCY).
    Emergency { text: String },
    /// The autopilot reboots in flight, as after a watchdog reset: the
    /// link goes silent for `silence_s`, then it boots again — HEARTBEAT,
    /// SYSTEM_TIME and every `time_boot_ms` from 0, sequence numbers from 0,
    /// the start-up sequence (sensors, GPS, EKF) again. What ArduPilot keeps
    /// in EEPROM stays (parameters, the mission); what its watchdog keeps
    /// for a reset in flight is restored (armed, the mode, home, the
    /// mission's current item: ArduPlane flies on). The aircraft flies on
    /// through it (the physics is the world's, not the autopilot's).
    Reboot { silence_s: f64 },
    /// Every COMMAND_LONG / COMMAND_INT to the autopilot or its camera is
    /// answered with this result and has no effect (a vehicle that says
    /// no).
    RefuseCommands(Refusal),
    /// The next command to the autopilot or its camera is answered with
    /// this result and has no effect; then the fault clears.
    RefuseCommand(Refusal),
    /// A burst of `bytes` random bytes on the wire, among the frames.
    Garbage { bytes: usize },
    /// Every frame the vehicle sends goes out twice.
    Duplicate,
    /// The frames the vehicle sends go out swapped two by two.
    Reorder,
    /// The vehicle cannot move (a rover's wheels blocked, bogged down):
    /// it stays where it is whatever it is told, its motor running and the
    /// autopilot asking for full throttle; nothing on the wire says so
    /// but the position that no longer changes. A plane ignores it.
    Stuck,
}

/// The kind of a fault, to clear it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FaultKind {
    EngineFailure,
    PayloadFailure,
    GpsLoss,
    BatteryDrain,
    BatteryRemaining,
    LinkLoss,
    Emergency,
    Reboot,
    RefuseCommands,
    RefuseCommand,
    Garbage,
    Duplicate,
    Reorder,
    Stuck,
}

impl Fault {
    pub fn kind(&self) -> FaultKind {
        match self {
            Fault::EngineFailure => FaultKind::EngineFailure,
            Fault::PayloadFailure(_) => FaultKind::PayloadFailure,
            Fault::GpsLoss => FaultKind::GpsLoss,
            Fault::BatteryDrain { .. } => FaultKind::BatteryDrain,
            Fault::BatteryRemaining { .. } => FaultKind::BatteryRemaining,
            Fault::LinkLoss => FaultKind::LinkLoss,
            Fault::Emergency { .. } => FaultKind::Emergency,
            Fault::Reboot { .. } => FaultKind::Reboot,
            Fault::RefuseCommands(_) => FaultKind::RefuseCommands,
            Fault::RefuseCommand(_) => FaultKind::RefuseCommand,
            Fault::Garbage { .. } => FaultKind::Garbage,
            Fault::Duplicate => FaultKind::Duplicate,
            Fault::Reorder => FaultKind::Reorder,
            Fault::Stuck => FaultKind::Stuck,
        }
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Fault::EngineFailure => write!(f, "engine_failure"),
            Fault::PayloadFailure(PayloadFailure::Silent) => write!(f, "payload_failure=silent"),
            Fault::PayloadFailure(PayloadFailure::Critical) => {
                write!(f, "payload_failure=critical")
            }
            Fault::GpsLoss => write!(f, "gps_loss"),
            Fault::BatteryDrain { factor } => write!(f, "battery_drain={factor}"),
            Fault::BatteryRemaining { percent } => write!(f, "battery={percent}"),
            Fault::LinkLoss => write!(f, "link_loss"),
            Fault::Emergency { text } => write!(f, "emergency={text}"),
            Fault::Reboot { silence_s } => write!(f, "reboot={silence_s}"),
            Fault::RefuseCommands(r) => write!(f, "refuse_commands={r}"),
            Fault::RefuseCommand(r) => write!(f, "refuse_command={r}"),
            Fault::Garbage { bytes } => write!(f, "garbage={bytes}"),
            Fault::Duplicate => write!(f, "duplicate"),
            Fault::Reorder => write!(f, "reorder"),
            Fault::Stuck => write!(f, "stuck"),
        }
    }
}

/// When a scheduled fault happens.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Trigger {
    /// Sim seconds since the simulation started (a reboot does not reset
    /// them).
    At(f64),
    /// When the vehicle sends MISSION_ITEM_REACHED for this sequence number.
    Reached(u16),
}

/// One entry of a schedule.
#[derive(Debug, Clone, PartialEq)]
pub struct ScheduledFault {
    pub fault: Fault,
    pub when: Trigger,
    /// Sim seconds after which the fault clears; `None`: it stays.
    pub duration: Option<f64>,
}

/// Faults to inject during a run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Schedule {
    pub entries: Vec<ScheduledFault>,
}

/// A `--fault` flag that does not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("bad fault `{spec}`: {reason} (expected KIND[=VALUE]@WHEN[:DURATION], e.g. engine_failure@90s, link_loss@60s:10s, payload_failure@wp3)")]
pub struct ScheduleError {
    pub spec: String,
    pub reason: String,
}

impl Schedule {
    /// Parses `--fault` flags.
    pub fn parse<S: AsRef<str>>(specs: &[S]) -> Result<Schedule, ScheduleError> {
        let entries = specs
            .iter()
            .map(|s| s.as_ref().parse())
            .collect::<Result<Vec<ScheduledFault>, _>>()?;
        Ok(Schedule { entries })
    }

    /// Adds one entry.
    pub fn with(mut self, fault: Fault, when: Trigger, duration: Option<f64>) -> Schedule {
        self.entries.push(ScheduledFault {
            fault,
            when,
            duration,
        });
        self
    }
}

fn seconds(text: &str) -> Option<f64> {
    let t = text.trim();
    let t = t.strip_suffix('s').unwrap_or(t);
    let v: f64 = t.parse().ok()?;
    (v.is_finite() && v >= 0.0).then_some(v)
}

impl FromStr for ScheduledFault {
    type Err = ScheduleError;

    fn from_str(spec: &str) -> Result<Self, Self::Err> {
        let err = |reason: &str| ScheduleError {
            spec: spec.to_owned(),
            reason: reason.to_owned(),
        };
        let (what, when) = spec.rsplit_once('@').ok_or_else(|| err("no `@WHEN`"))?;
        let (kind, value) = match what.split_once('=') {
            Some((k, v)) => (k.trim(), Some(v)),
            None => (what.trim(), None),
        };
        let fault = match (kind, value) {
            ("engine_failure", None) => Fault::EngineFailure,
            ("payload_failure", None | Some("silent")) => {
                Fault::PayloadFailure(PayloadFailure::Silent)
            }
            ("payload_failure", Some("critical")) => {
                Fault::PayloadFailure(PayloadFailure::Critical)
            }
            ("payload_failure", Some(_)) => {
                return Err(err("payload_failure takes `silent` or `critical`"))
            }
            ("gps_loss", None) => Fault::GpsLoss,
            ("battery_drain", None) => Fault::BatteryDrain { factor: 10.0 },
            ("battery_drain", Some(v)) => match v.trim().parse::<f64>() {
                Ok(f) if f.is_finite() && f > 0.0 => Fault::BatteryDrain { factor: f },
                _ => return Err(err("battery_drain takes a positive factor")),
            },
            ("battery", Some(v)) => match v.trim().trim_end_matches('%').parse::<f64>() {
                Ok(p) if (0.0..=100.0).contains(&p) => Fault::BatteryRemaining { percent: p },
                _ => return Err(err("battery takes a percentage in 0..=100")),
            },
            ("battery", None) => return Err(err("battery needs `=PERCENT`")),
            ("link_loss", None) => Fault::LinkLoss,
            ("emergency", None) => Fault::Emergency {
                text: "Emergency".to_owned(),
            },
            ("emergency", Some(text)) => Fault::Emergency {
                text: text.to_owned(),
            },
            ("reboot", None) => Fault::Reboot { silence_s: 1.5 },
            ("reboot", Some(v)) => match seconds(v) {
                Some(silence_s) => Fault::Reboot { silence_s },
                None => return Err(err("reboot takes the seconds of silence")),
            },
            ("refuse_commands" | "refuse_command", v) => {
                let r = match v {
                    None => Refusal::Denied,
                    Some(v) => v.parse().map_err(|()| {
                        err("refuse_commands takes `denied`, `failed` or `temporarily_rejected`")
                    })?,
                };
                if kind == "refuse_command" {
                    Fault::RefuseCommand(r)
                } else {
                    Fault::RefuseCommands(r)
                }
            }
            ("garbage", None) => Fault::Garbage { bytes: 512 },
            ("garbage", Some(v)) => match v.trim().parse::<usize>() {
                Ok(n) if n > 0 => Fault::Garbage { bytes: n },
                _ => return Err(err("garbage takes a number of bytes")),
            },
            ("duplicate", None) => Fault::Duplicate,
            ("reorder", None) => Fault::Reorder,
            ("stuck", None) => Fault::Stuck,
            (
                "engine_failure" | "gps_loss" | "link_loss" | "duplicate" | "reorder" | "stuck",
                Some(_),
            ) => return Err(err("this fault takes no value")),
            _ => return Err(err("unknown fault kind")),
        };
        let (at, duration) = match when.split_once(':') {
            Some((at, d)) => (at, Some(seconds(d).ok_or_else(|| err("bad duration"))?)),
            None => (when, None),
        };
        let at = at.trim();
        let when = if let Some(n) = at.strip_prefix("wp") {
            Trigger::Reached(n.parse().map_err(|_| err("bad waypoint number"))?)
        } else {
            Trigger::At(seconds(at).ok_or_else(|| err("bad time"))?)
        };
        Ok(ScheduledFault {
            fault,
            when,
            duration,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_documented_forms() {
        let s = Schedule::parse(&[
            "engine_failure@90s",
            "link_loss@60s:10s",
            "payload_failure@wp3",
            "payload_failure=critical@12",
            "battery=20@120s",
            "battery_drain=5@1.5s:30",
            "emergency=Fire on board@100s",
            "gps_loss@wp2:15s",
            "reboot@300s",
            "reboot=4@wp5",
            "refuse_commands@wp3:5s",
            "refuse_commands=temporarily_rejected@10",
            "garbage=2000@40s",
            "duplicate@50s:10s",
            "reorder@70:10",
            "refuse_command=failed@wp4",
            "stuck@wp2:30s",
        ])
        .unwrap();
        let e = &s.entries;
        assert_eq!(e[0].fault, Fault::EngineFailure);
        assert_eq!(e[0].when, Trigger::At(90.0));
        assert_eq!(e[0].duration, None);
        assert_eq!(e[1].fault, Fault::LinkLoss);
        assert_eq!(e[1].duration, Some(10.0));
        assert_eq!(e[2].fault, Fault::PayloadFailure(PayloadFailure::Silent));
        assert_eq!(e[2].when, Trigger::Reached(3));
        assert_eq!(e[3].fault, Fault::PayloadFailure(PayloadFailure::Critical));
        assert_eq!(e[4].fault, Fault::BatteryRemaining { percent: 20.0 });
        assert_eq!(e[5].fault, Fault::BatteryDrain { factor: 5.0 });
        assert_eq!(e[5].when, Trigger::At(1.5));
        assert_eq!(e[5].duration, Some(30.0));
        assert_eq!(
            e[6].fault,
            Fault::Emergency {
                text: "Fire on board".into()
            }
        );
        assert_eq!(e[7].when, Trigger::Reached(2));
        assert_eq!(e[8].fault, Fault::Reboot { silence_s: 1.5 });
        assert_eq!(e[9].fault, Fault::Reboot { silence_s: 4.0 });
        assert_eq!(e[10].fault, Fault::RefuseCommands(Refusal::Denied));
        assert_eq!(e[10].duration, Some(5.0));
        assert_eq!(
            e[11].fault,
            Fault::RefuseCommands(Refusal::TemporarilyRejected)
        );
        assert_eq!(e[12].fault, Fault::Garbage { bytes: 2000 });
        assert_eq!(e[13].fault, Fault::Duplicate);
        assert_eq!(e[14].fault, Fault::Reorder);
        assert_eq!(e[15].fault, Fault::RefuseCommand(Refusal::Failed));
        assert_eq!(
            (&e[16].fault, e[16].when, e[16].duration),
            (&Fault::Stuck, Trigger::Reached(2), Some(30.0))
        );
        // Each prints as it parses.
        for entry in e {
            let text = entry.fault.to_string();
            assert_eq!(
                format!("{text}@1")
                    .parse::<ScheduledFault>()
                    .map(|f| f.fault),
                Ok(entry.fault.clone()),
                "{text}"
            );
        }
    }

    #[test]
    fn rejects_bad_specs_with_the_reason() {
        for (spec, why) in [
            ("engine_failure", "no `@WHEN`"),
            ("engine_fail@3s", "unknown fault kind"),
            ("engine_failure=3@3s", "takes no value"),
            ("link_loss@soon", "bad time"),
            ("link_loss@3s:-1", "bad duration"),
            ("battery@3s", "needs `=PERCENT`"),
            ("battery=150@3s", "percentage"),
            ("payload_failure=smoke@wp1", "silent"),
            ("gps_loss@wpX", "bad waypoint"),
            ("reboot=soon@3s", "seconds of silence"),
            ("refuse_commands=maybe@3s", "denied"),
            ("garbage=0@3s", "number of bytes"),
            ("duplicate=2@3s", "takes no value"),
        ] {
            let e = spec.parse::<ScheduledFault>().unwrap_err();
            assert!(e.reason.contains(why), "{spec}: {}", e.reason);
            assert!(e.to_string().contains(spec));
        }
    }
}
