//! Elaboration's integration tests, one binary: real recorded flights,
//! rules on synthetic frames, and properties on arbitrary bytes.

mod firmware_reports;
mod properties;
mod real_flights;
mod rules;
// `Skipped` and the closing `SKIPPED:` line, shared by every crate's tests.
use petrel_test_support::skip;
mod vocabulary;

use elaboration::{Config, Elaborated, Elaborator, Profile, ReadStats, Stats, TlogReader};

/// Runs a whole log through an elaborator; events with times in seconds
/// since the first frame.
pub fn elaborate(
    bytes: &[u8],
    profile: Profile,
    config: Config,
) -> (Vec<(f64, Elaborated)>, ReadStats, Stats) {
    let mut elab = Elaborator::new(profile, config);
    let mut reader = TlogReader::new(bytes);
    let mut first = None;
    let mut out = Vec::new();
    let mut events = Vec::new();
    for rec in reader.by_ref() {
        let t0 = *first.get_or_insert(rec.time_us);
        elab.frame(rec.time_us, &rec.frame);
        elab.drain_into(&mut events);
        for e in events.drain(..) {
            out.push(((e.time_us - t0) as f64 / 1e6, e));
        }
    }
    (out, reader.stats().clone(), elab.stats().clone())
}

/// An event as `name {int and string params}` (floats left out: they are
/// measurements, checked separately where they matter).
pub fn summary(e: &Elaborated) -> String {
    let mut s = e.event.name.clone();
    let kept: Vec<String> = e
        .event
        .params
        .iter()
        .filter(|(_, v)| !matches!(v, nets::Value::Float(_)))
        .map(|(k, v)| format!("{k}: {v}"))
        .collect();
    if !kept.is_empty() {
        s.push_str(&format!(" {{{}}}", kept.join(", ")));
    }
    s
}
