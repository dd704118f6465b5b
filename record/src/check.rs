//! `--check-against`: a replayed step compared with the recorded one.

use nets::player::{effect_json, Digest};
use nets::{Micros, Project};
use serde_json::Value as Json;

use super::read::Recorded;
use petrel_core::supervisor::Step;

/// The first thing that differs between a replayed and a recorded step.
#[derive(Debug, Clone, PartialEq)]
pub struct Difference {
    pub seq: u64,
    pub time: Micros,
    pub what: String,
}

/// A step's effects as recorded: its own effects, then each event's, in
/// order (the order the recorder writes them).
pub fn step_effects(project: &Project, step: &Step) -> Vec<Json> {
    step.effects
        .iter()
        .chain(step.events.iter().flat_map(|(_, e)| e.iter()))
        .map(|e| effect_json(project, e))
        .collect()
}

/// Compares a replayed step (its effects and the digest after it) with
/// what was recorded for it.
pub fn compare(
    project: &Project,
    step: &Step,
    digest: &Digest,
    recorded: Option<&Recorded>,
) -> Option<Difference> {
    let diff = |what: String| {
        Some(Difference {
            seq: step.seq,
            time: step.time,
            what,
        })
    };
    let Some(recorded) = recorded else {
        return diff("nothing recorded for this step".into());
    };
    let replayed = step_effects(project, step);
    for (i, (r, p)) in recorded.effects.iter().zip(&replayed).enumerate() {
        if r != p {
            return diff(format!("effect {}: recorded {r}, replayed {p}", i + 1));
        }
    }
    if recorded.effects.len() != replayed.len() {
        let n = recorded.effects.len().min(replayed.len());
        return diff(match (recorded.effects.get(n), replayed.get(n)) {
            (Some(r), _) => format!(
                "{} effects recorded, {} replayed; missing from the replay: {r}",
                recorded.effects.len(),
                replayed.len()
            ),
            (_, Some(p)) => format!(
                "{} effects recorded, {} replayed; not in the recording: {p}",
                recorded.effects.len(),
                replayed.len()
            ),
            _ => "effect counts differ".into(),
        });
    }
    let digest = digest.to_string();
    match &recorded.digest {
        Some(r) if *r == digest => None,
        Some(r) => diff(format!("digest: recorded {r}, replayed {digest}")),
        None => diff("no digest recorded for this step".into()),
    }
}
