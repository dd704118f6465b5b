//! The single-procedure level of a project check (ProCoSA §2.4: properties
//! are checked "both at the single procedure level and at the whole project
//! level"): each net explored *alone*, by the same player-driven explorer as
//! the whole project ([`super::project`]), on a copy of the project in which
//! the other nets are absent.
//!
//! In the copy, the net is active from the start with its initial marking;
//! the global places keep their declared initial marking and only the net
//! moves them; the other nets keep their places (indices stay stable) but
//! have no transitions, no initial marking and are never active, and the
//! net's own `activate`/`deactivate` of another net are left out (they could
//! change nothing the net sees). The explorer's external events are then
//! every event the net waits for and does not produce itself: the events
//! other nets emit become external and may occur in any state. Its own
//! emitted events, timers, calls and commands and their results are
//! explored as in the project.
//!
//! [`relies`] compares the two levels: a violation found alone that the net
//! in its project does not show means the net relies on the other nets;
//! it is reported as information (a design usually intends it: a net
//! waiting for a global place another fills is dead alone), the project
//! level staying authoritative. An alone exploration cut short by the
//! state limit is a warning ([`incomplete`]).

use crate::model::{Action, NetId, Project};

use super::project_report::Report;

/// The project as net `x` sees it alone (see the module doc).
pub(super) fn project_alone(project: &Project, x: NetId) -> Project {
    let mut alone = project.clone();
    for (n, net) in alone.nets.iter_mut().enumerate() {
        if n == x {
            net.active_at_start = true;
            for t in &mut net.transitions {
                let (actions, source): (Vec<Action>, Vec<String>) = std::mem::take(&mut t.actions)
                    .into_iter()
                    .zip(std::mem::take(&mut t.action_source))
                    .filter(|(a, _)| {
                        !matches!(a, Action::Activate(m) | Action::Deactivate(m) if *m != x)
                    })
                    .unzip();
                t.actions = actions;
                t.action_source = source;
            }
        } else {
            net.active_at_start = false;
            net.transitions.clear();
            net.immediate.clear();
            for p in &mut net.places {
                p.initial = false;
            }
        }
    }
    for waiting in alone.triggers.values_mut() {
        waiting.retain(|(n, _)| *n == x);
    }
    alone.triggers.retain(|_, waiting| !waiting.is_empty());
    alone
}

/// What net `name` alone shows that it does not show in its project: it
/// relies on the other nets (information, see the module doc).
pub(super) fn relies(name: &str, alone: &Report, in_project: &Report) -> Vec<String> {
    let mut out = Vec::new();
    let because = |what: &str, steps: &[String]| {
        format!(
            "{name} alone can {what} (it relies on other nets): {}",
            sequence(steps)
        )
    };
    if alone.dead_markings > 0 && in_project.dead_markings == 0 {
        let steps = alone.deadlock_example.as_deref().unwrap_or_default();
        out.push(because("reach a dead marking", steps));
    }
    if !alone.safe && in_project.safe {
        let steps = alone.unsafe_example.as_deref().unwrap_or_default();
        out.push(because("put a second token in a place", steps));
    }
    if let Some(first) = alone.livelocks.first() {
        if in_project.livelocks.is_empty() {
            out.push(because("livelock", first));
        }
    }
    out
}

/// The warning for net `name` when its alone exploration was cut short.
pub(super) fn incomplete(name: &str, alone: &Report) -> Option<String> {
    (!alone.complete).then(|| {
        format!("{name} alone: state limit reached: its single-procedure verdict is incomplete")
    })
}

/// A sequence of steps on one line.
pub fn sequence(steps: &[String]) -> String {
    if steps.is_empty() {
        "at the start".to_owned()
    } else {
        steps.join(" ⟶ ")
    }
}
