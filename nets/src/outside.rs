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

use std::fmt;

use crate::model::{names, Action, Project};

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
