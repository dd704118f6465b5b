//! Frames the link dropped because their MAVLink 2 signature failed: counted
//! by reason (shared between the reader and whoever reports), and turned
//! into the `signature_rejected` event the nets may react to, at most once
//! a second.

use std::collections::BTreeMap;
use std::sync::Mutex;

use nets::{Category, Event, Micros, Project, Value};

use super::signing::Rejection;

/// The event the gateway raises when frames are rejected (the program
/// protocol refuses it from programs: `programs::session::SIGNATURE_REJECTED`).
pub const SIGNATURE_REJECTED: &str = "signature_rejected";

/// At most one `signature_rejected` event per this many microseconds.
const EVENT_PERIOD: Micros = 1_000_000;

/// Frames rejected by signature checks, by reason.
#[derive(Debug, Default)]
pub struct Rejections {
    counts: Mutex<BTreeMap<&'static str, u64>>,
    /// The latest rejection: its reason and sender (system, component).
    latest: Mutex<Option<(Rejection, u8, u8)>>,
}

impl Rejections {
    pub(super) fn add(&self, why: Rejection, system: u8, component: u8) {
        let mut counts = self.counts.lock().unwrap_or_else(|p| p.into_inner());
        *counts.entry(why.as_str()).or_default() += 1;
        *self.latest.lock().unwrap_or_else(|p| p.into_inner()) = Some((why, system, component));
    }

    /// Frames rejected so far, by reason.
    pub fn counts(&self) -> BTreeMap<&'static str, u64> {
        self.counts
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// All frames rejected so far.
    pub fn total(&self) -> u64 {
        self.counts().values().sum()
    }

    /// The latest rejection: reason, system, component.
    pub fn latest(&self) -> Option<(Rejection, u8, u8)> {
        *self.latest.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// One line for people: `12 frames rejected (bad signature 2, unsigned 10)`.
    pub fn summary(&self) -> Option<String> {
        let counts = self.counts();
        let total: u64 = counts.values().sum();
        (total > 0).then(|| {
            let by: Vec<String> = counts.iter().map(|(k, n)| format!("{k} {n}")).collect();
            format!("{total} frames rejected ({})", by.join(", "))
        })
    }
}

/// Turns new rejections into `signature_rejected {count, reason, system,
/// component}` events: `count` frames since the last event, the latest
/// one's reason and sender. Category: the project's declaration, else
/// communication.
#[derive(Debug, Default)]
pub struct Reporter {
    reported: u64,
    last: Option<Micros>,
}

impl Reporter {
    pub fn poll(
        &mut self,
        rejections: &Rejections,
        project: &Project,
        now: Micros,
    ) -> Option<Event> {
        let total = rejections.total();
        if total == self.reported || self.last.is_some_and(|t| now < t + EVENT_PERIOD) {
            return None;
        }
        let (why, system, component) = rejections.latest()?;
        let count = total - self.reported;
        self.reported = total;
        self.last = Some(now);
        let category = project
            .declared_category(SIGNATURE_REJECTED)
            .unwrap_or(Category::Communication);
        Some(
            Event::new(SIGNATURE_REJECTED)
                .category(category)
                .param("count", Value::Int(count as i64))
                .param("reason", Value::Str(why.as_str().to_owned()))
                .param("system", Value::Int(i64::from(system)))
                .param("component", Value::Int(i64::from(component))),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejections_become_one_event_a_second_counting_every_frame() {
        let project = nets::load(&[
            (
                "project.toml",
                "[[net]]\nfile = \"n.toml\"\nactive = true\n",
            ),
            (
                "n.toml",
                "name = \"N\"\nplaces = [\"a\"]\ninitial = [\"a\"]\n",
            ),
        ])
        .expect("loads");
        let r = Rejections::default();
        let mut reporter = Reporter::default();
        assert_eq!(reporter.poll(&r, &project, 0), None);
        r.add(Rejection::Unsigned, 1, 1);
        r.add(Rejection::BadSignature, 7, 1);
        let e = reporter.poll(&r, &project, 10).expect("an event");
        assert_eq!(e.name, SIGNATURE_REJECTED);
        assert_eq!(e.category, Category::Communication);
        assert_eq!(e.params["count"], Value::Int(2));
        assert_eq!(e.params["reason"], Value::Str("bad signature".into()));
        assert_eq!(e.params["system"], Value::Int(7));
        r.add(Rejection::Unsigned, 1, 1);
        assert_eq!(
            reporter.poll(&r, &project, 500_000),
            None,
            "at most 1 a second"
        );
        let e = reporter
            .poll(&r, &project, 1_000_010)
            .expect("the next second");
        assert_eq!(e.params["count"], Value::Int(1));
        assert_eq!(reporter.poll(&r, &project, 5_000_000), None, "nothing new");
        assert_eq!(
            r.summary().as_deref(),
            Some("3 frames rejected (bad signature 1, unsigned 2)")
        );
    }
}
