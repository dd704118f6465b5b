//! Which events may come from outside the nets — from elaboration, a
//! program, a play script — and which the player alone produces.
//!
//! The player names some events itself: a net's timer expiry, a call's or a
//! command's result, `net_fault`. They are delivered only where they belong
//! (the timer's net, the caller), so an outside event that merely bears such
//! a name must never stand for them: the player drops it
//! ([`crate::player::DropReason::Reserved`]), and a net waiting on one of its
//! own timers hears that timer only, never an event of the same name. An
//! event the nets emit and the project does not declare is the nets' own
//! too: a program or a script cannot send it (declare it in `[events]` if
//! they should). In a team the rule holds per base name, as `[events]`
//! does: a net emitting `detour@R2` makes the whole `detour` family the
//! nets' own, so `detour@R3` cannot come from outside either, even if no
//! net emits it (then nothing produces it, and `petrel check` says so).
//! The verifier explores exactly the rest as outside events, so that its
//! proof covers every event the gateway can deliver.

use std::collections::BTreeSet;
use std::fmt;

use crate::model::{names, Action, NetId, Project};

/// Why an event cannot come from outside the nets.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Refusal {
    /// `net_fault`: the player's own.
    NetFault,
    /// `command.ok` / `command.failed`: a command's result.
    CommandResult,
    /// `PROGRAM.FUNCTION.done` / `.failed`: a call's result.
    CallResult,
    /// `NAME.CHOICE` / `NAME.timeout` of a question a net asks.
    Answer,
    /// An event the nets emit that the project does not declare.
    Emitted,
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Refusal::NetFault => "`net_fault` is raised by the player itself, never from outside",
            Refusal::CommandResult => {
                "a command's result comes only from the vehicle, for the net that commanded"
            }
            Refusal::CallResult => "a call's result comes only from the program, for the net that called",
            Refusal::Answer => {
                "an answer comes only from the operator (signed), and a timeout from the player, for the net that asked"
            }
            Refusal::Emitted => {
                "the nets emit this event and the project does not declare it in [events] (declare it there if it may also come from outside)"
            }
        })
    }
}

/// Whether `name` is one the player produces itself (a result or
/// `net_fault`): never deliverable from outside, whatever the source.
pub fn player_own(project: &Project, name: &str) -> Option<Refusal> {
    if name == names::NET_FAULT {
        Some(Refusal::NetFault)
    } else if name == names::COMMAND_OK || name == names::COMMAND_FAILED {
        Some(Refusal::CommandResult)
    } else if is_call_result(project, name) {
        Some(Refusal::CallResult)
    } else if is_answer(project, name) {
        Some(Refusal::Answer)
    } else {
        None
    }
}

/// Why a program or a script cannot send `name`, if it cannot: the player's
/// own events, and the events only the nets emit.
pub fn refusal(project: &Project, name: &str) -> Option<Refusal> {
    player_own(project, name).or_else(|| {
        (!declared(project, name) && emitted(project, name)).then_some(Refusal::Emitted)
    })
}

/// Whether the project declares `name`, or the base of a vehicle's event
/// (`at_gate` of `at_gate@R1`).
pub fn declared(project: &Project, name: &str) -> bool {
    project.events.contains_key(name)
        || project
            .vehicle_event(name)
            .is_some_and(|(base, _)| project.events.contains_key(base))
}

/// Whether transition-trigger `name` in net `net` is one of that net's own
/// timers: such a transition hears the timer's expiry only.
pub fn own_timer(project: &Project, net: usize, name: &str) -> bool {
    project.nets[net].timers.iter().any(|t| t == name)
}

/// `PROGRAM.FUNCTION.done` or `.failed` of a function the project declares.
pub fn is_call_result(project: &Project, name: &str) -> bool {
    let Some((head, outcome)) = name.rsplit_once('.') else {
        return false;
    };
    (outcome == names::DONE || outcome == names::FAILED)
        && head.split_once('.').is_some_and(|(p, f)| {
            project
                .programs
                .iter()
                .any(|pr| pr.name == p && pr.functions.iter().any(|x| x.name == f))
        })
}

/// `NAME.CHOICE` or `NAME.timeout` of a question some net asks.
pub fn is_answer(project: &Project, name: &str) -> bool {
    let Some((ask, outcome)) = name.split_once('.') else {
        return false;
    };
    project.nets.iter().flat_map(|n| &n.asks).any(|a| {
        a.name == ask
            && (outcome == crate::model::ASK_TIMEOUT || a.choices.iter().any(|c| c == outcome))
    })
}

/// Whether some net emits `name`, or an event of its family: the same
/// base for another vehicle (`detour@R2` for `detour@R3`), or the base
/// itself (`detour`), as [`declared`] reads `[events]`.
pub fn emitted(project: &Project, name: &str) -> bool {
    let family = base(project, name);
    project
        .nets
        .iter()
        .flat_map(|n| &n.transitions)
        .flat_map(|t| &t.actions)
        .any(|a| matches!(a, Action::Emit { event, .. } if base(project, event) == family))
}

/// The base of a vehicle's event (`detour` of `detour@R3`), else the name.
pub fn base<'a>(project: &Project, name: &'a str) -> &'a str {
    project.vehicle_event(name).map_or(name, |(base, _)| base)
}

/// Whether something can deliver `name` to the transitions of net `net`
/// that wait for it: elaboration or the project's `[events]` (per base,
/// as [`declared`] reads them), an `emit` of some net, one of the net's
/// own timers, an answer to one of its questions, the result of one of
/// its calls or commands, or `net_fault`. Only as true as the project's
/// events are complete: loaded knowing its elaboration profile
/// (`nets::load_with`), an event awaited that nothing produces is a load
/// error ([`produced_by_nothing`] says why).
pub fn produced(project: &Project, net: NetId, name: &str) -> bool {
    declared(project, name)
        || emits(project, name)
        || own_timer(project, net, name)
        || name == names::NET_FAULT
        || ((name == names::COMMAND_OK || name == names::COMMAND_FAILED) && commands(project, net))
        || results_of(project, net).any(|r| r == name)
        || answers_of(project, net).any(|a| a == name)
}

/// Why nothing produces `name` for transition `transition` of net `net`
/// (see [`produced`]), with the nearest event that is produced when one
/// is close (a typo); `None` when something produces it.
pub fn produced_by_nothing(
    project: &Project,
    net: NetId,
    transition: &str,
    name: &str,
) -> Option<String> {
    if produced(project, net, name) {
        return None;
    }
    let n = &project.nets[net];
    let awaited = format!(
        "event `{name}` (awaited by {}.{transition}) is produced by nothing",
        n.name
    );
    if emitted(project, name) {
        // The family is the nets' own, emitted for other vehicles only:
        // no program or script may send it.
        let family = base(project, name);
        let emitted: BTreeSet<String> = emits_all(project)
            .filter(|x| base(project, x) == family)
            .map(|x| format!("`{x}`"))
            .collect();
        let emitted: Vec<String> = emitted.into_iter().collect();
        return Some(format!(
            "{awaited}: of its family `{family}` the nets emit {} only, and no program or script may send it ([events] does not declare `{family}`)",
            emitted.join(", ")
        ));
    }
    let mut text = format!(
        "{awaited}: no elaboration rule or [events] declaration, no net emits it, and it is no timer, answer or result of {}",
        n.name
    );
    if let Some(meant) = nearest_produced(project, net, name) {
        text.push_str(&format!("; did you mean `{meant}`?"));
    }
    text.push_str(" (an event a program or another outside source sends is declared in project.toml's [events])");
    Some(text)
}

/// The produced event nearest `name` as net `net`'s file writes it, if
/// close: a template's instance writes its vehicle's events unqualified,
/// a team net qualified (`engine_failure@R2`).
fn nearest_produced(project: &Project, net: NetId, name: &str) -> Option<String> {
    let written = if project.nets[net].vehicle.is_some() {
        base(project, name)
    } else {
        name
    };
    let (word, vehicle) = match project.vehicle_event(written) {
        Some((b, v)) => (b, Some(project.vehicles[v].name.as_str())),
        None => (written, None),
    };
    // A vehicle's event: its base among the events that have vehicles'.
    let mut known: BTreeSet<String> = project
        .events
        .keys()
        .cloned()
        .chain(emits_all(project).map(|e| base(project, e).to_owned()))
        .collect();
    if vehicle.is_none() {
        let n = &project.nets[net];
        known.extend(n.timers.iter().cloned());
        known.extend(results_of(project, net));
        known.extend(answers_of(project, net));
        known.insert(names::NET_FAULT.to_owned());
        if commands(project, net) {
            known.insert(names::COMMAND_OK.to_owned());
            known.insert(names::COMMAND_FAILED.to_owned());
        }
    }
    let meant = crate::suggest::nearest(word, known.iter().map(String::as_str))?;
    Some(match vehicle {
        Some(v) => crate::model::qualify(meant, v),
        None => meant.to_owned(),
    })
}

/// Every event some net emits, as written (qualified when it names a
/// vehicle).
pub(crate) fn emits_all(project: &Project) -> impl Iterator<Item = &str> {
    project
        .nets
        .iter()
        .flat_map(|n| &n.transitions)
        .flat_map(|t| &t.actions)
        .filter_map(|a| match a {
            Action::Emit { event, .. } => Some(event.as_str()),
            _ => None,
        })
}

/// Whether some net emits exactly `name`.
fn emits(project: &Project, name: &str) -> bool {
    emits_all(project).any(|e| e == name)
}

/// Whether net `net` commands the vehicle (and so hears `command.ok` and
/// `command.failed`).
fn commands(project: &Project, net: NetId) -> bool {
    project.nets[net]
        .transitions
        .iter()
        .flat_map(|t| &t.actions)
        .any(|a| matches!(a, Action::Command { .. }))
}

/// `PROGRAM.FUNCTION.done` and `.failed` of each call net `net` makes.
fn results_of(project: &Project, net: NetId) -> impl Iterator<Item = String> + '_ {
    project.nets[net]
        .transitions
        .iter()
        .flat_map(|t| &t.actions)
        .filter_map(|a| match a {
            Action::Call {
                program, function, ..
            } => {
                let p = &project.programs[*program];
                Some(format!("{}.{}", p.name, p.functions[*function].name))
            }
            _ => None,
        })
        .flat_map(|f| {
            [
                format!("{f}.{}", names::DONE),
                format!("{f}.{}", names::FAILED),
            ]
        })
}

/// `NAME.CHOICE` of each question net `net` asks (the timeouts are its
/// timers).
fn answers_of(project: &Project, net: NetId) -> impl Iterator<Item = String> + '_ {
    project.nets[net]
        .asks
        .iter()
        .flat_map(|a| a.choices.iter().map(|c| a.answer_event(c)))
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;

    /// Three robots; TEAM tells R1 and R2 only to `detour` and relays a
    /// declared `alert@R1`; MOVE (one per robot) hears `detour` and
    /// `alert`.
    fn team() -> Project {
        let files: BTreeMap<String, String> = [
            (
                "project.toml",
                "[events]\nalert = \"nominal\"\n\n[[vehicle]]\nname = \"R1\"\nsystem = 1\n\n[[vehicle]]\nname = \"R2\"\nsystem = 2\n\n[[vehicle]]\nname = \"R3\"\nsystem = 3\n\n[[net]]\nfile = \"move.toml\"\nactive = true\n\n[[net]]\nfile = \"team.toml\"\nactive = true\n",
            ),
            (
                "move.toml",
                "name = \"MOVE\"\nvehicles = \"all\"\nplaces = [\"a\", \"b\", \"c\"]\ninitial = [\"a\"]\nfinal = [\"b\", \"c\"]\n\n[[transition]]\nname = \"detour\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"detour\"\n\n[[transition]]\nname = \"alert\"\nfrom = [\"a\"]\nto = [\"c\"]\non = \"alert\"\n",
            ),
            (
                "team.toml",
                "name = \"TEAM\"\nplaces = [\"on\", \"off\"]\ninitial = [\"on\"]\nfinal = [\"on\", \"off\"]\n\n[[transition]]\nname = \"tell\"\nfrom = [\"on\"]\nto = [\"off\"]\non = \"alert@R2\"\ndo = [\"emit detour@R1\", \"emit detour@R2\", \"emit alert@R1\"]\n",
            ),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_owned(), v.to_owned()))
        .collect();
        crate::load::load(&files).unwrap_or_else(|e| panic!("{e:?}"))
    }

    #[test]
    fn an_emitted_undeclared_family_is_the_nets_own_for_every_vehicle() {
        let project = team();
        // Emitted for R1 and R2: neither can come from outside...
        assert_eq!(refusal(&project, "detour@R1"), Some(Refusal::Emitted));
        assert_eq!(refusal(&project, "detour@R2"), Some(Refusal::Emitted));
        // ...nor R3's, which no net emits: a program sending it is
        // refused as the others are.
        assert_eq!(refusal(&project, "detour@R3"), Some(Refusal::Emitted));
        assert_eq!(refusal(&project, "detour"), Some(Refusal::Emitted));
        assert!(emitted(&project, "detour@R3"));
        // An unknown vehicle's event is no vehicle's event: its own name.
        assert!(!emitted(&project, "detour@R9"));
        assert_eq!(refusal(&project, "detour@R9"), None);
    }

    #[test]
    fn a_declared_family_may_come_from_outside_even_if_emitted() {
        let project = team();
        for name in ["alert", "alert@R1", "alert@R2", "alert@R3"] {
            assert!(declared(&project, name), "{name}");
            assert_eq!(refusal(&project, name), None, "{name}");
        }
    }

    #[test]
    fn the_base_of_a_vehicle_s_event_drops_the_vehicle_only() {
        let project = team();
        assert_eq!(base(&project, "detour@R3"), "detour");
        assert_eq!(base(&project, "detour"), "detour");
        assert_eq!(base(&project, "detour@R9"), "detour@R9");
    }
}
