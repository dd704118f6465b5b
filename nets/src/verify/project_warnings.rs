//! What the project verifier finds without exploring: conflicts between
//! transitions that wait for the same event in a place (unless the net
//! says the choice is intended), events nothing produces, events nothing
//! consumes; and a project's plain token game (the P/T net other tools
//! see, and what `petrel export` writes).
//!
//! Pure: reads the [`Project`] only.

use std::collections::BTreeSet;

use super::ptnet::PtNet;
use crate::model::{Action, NetId, Project, TransitionId};

pub(super) fn emitted_events(project: &Project) -> BTreeSet<String> {
    crate::outside::emits_all(project)
        .map(str::to_owned)
        .collect()
}

/// A warning found without exploring, and the nets it concerns.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Warning {
    pub text: String,
    pub nets: Vec<NetId>,
    /// For a conflict: the event and the two transitions.
    pub conflict: Option<(String, [(NetId, TransitionId); 2])>,
}

/// Warnings found without exploring: conflicts, events nothing produces,
/// events nothing consumes.
pub fn static_warnings(project: &Project) -> Vec<Warning> {
    let mut out = Vec::new();
    // Conflicts: two transitions waiting for one event share an input place,
    // unless their guards exclude each other or they declare their ranks.
    let mut events: Vec<&String> = project.triggers.keys().collect();
    events.sort();
    for e in events {
        let list = &project.triggers[e];
        for (i, &(n1, t1)) in list.iter().enumerate() {
            for &(n2, t2) in &list[i + 1..] {
                let a = &project.nets[n1].transitions[t1];
                let b = &project.nets[n2].transitions[t2];
                let shared = a.flat_inputs.iter().find(|p| b.flat_inputs.contains(p));
                if let Some(&p) = shared.filter(|_| !super::exclusive::intended(a, b)) {
                    let text = format!(
                        "conflict on `{e}`: {}.{} and {}.{} share input place {}; {}.{} is declared first and wins",
                        project.nets[n1].name,
                        a.name,
                        project.nets[n2].name,
                        b.name,
                        crate::player::flat_place_name(project, p),
                        project.nets[n1].name,
                        a.name
                    );
                    out.push(Warning {
                        text,
                        nets: vec![n1, n2],
                        conflict: Some((e.clone(), [(n1, t1), (n2, t2)])),
                    });
                }
            }
        }
    }
    // Events consumed that nothing produces: a load error when the project
    // was loaded knowing its elaboration profile (`load_with`), so found
    // here only in a project loaded without (`load`).
    for (ni, net) in project.nets.iter().enumerate() {
        for t in &net.transitions {
            let Some(e) = &t.event else { continue };
            if let Some(text) = crate::outside::produced_by_nothing(project, ni, &t.name, e) {
                out.push(Warning {
                    text,
                    nets: vec![ni],
                    conflict: None,
                });
            }
        }
    }
    // Events emitted that nothing consumes, unless declared in `[events]`:
    // an event meant for the crew (the timeline, the page, the mirror) or
    // for a program, not a misspelt one.
    for e in &emitted_events(project) {
        if !project.triggers.contains_key(e) && !project.events.contains_key(e) {
            let nets = (0..project.nets.len())
                .filter(|&n| {
                    issues(
                        project,
                        n,
                        |a| matches!(a, Action::Emit { event, .. } if event == e),
                    )
                })
                .collect();
            out.push(Warning {
                text: format!("event `{e}` is emitted but no transition waits for it (declare it in [events] if it is meant for the crew or a program)"),
                nets,
                conflict: None,
            });
        }
    }
    out
}

fn issues(project: &Project, net: NetId, pred: impl Fn(&Action) -> bool) -> bool {
    project.nets[net]
        .transitions
        .iter()
        .flat_map(|t| &t.actions)
        .any(pred)
}

/// The plain token game of a project: every net's places and transitions in
/// one P/T net (global places once), events, guards, actions, activation and
/// priorities forgotten, every net marked initially. The player's semantics
/// can reach less than this (see the module doc): it is what other Petri net
/// tools see of a project, and what `petrel export` writes.
pub fn token_game(project: &Project) -> PtNet {
    let mut net = PtNet::new(project.name.clone());
    for g in &project.globals {
        net.add_place(format!("@{}", g.name), u32::from(g.initial));
    }
    for n in &project.nets {
        for p in &n.places {
            net.add_place(format!("{}.{}", n.name, p.name), u32::from(p.initial));
        }
    }
    for n in &project.nets {
        for t in &n.transitions {
            let arcs = |places: &[usize]| places.iter().map(|&p| (p, 1)).collect::<Vec<_>>();
            net.add_transition(
                format!("{}.{}", n.name, t.name),
                &arcs(&t.flat_inputs),
                &arcs(&t.flat_outputs),
            );
        }
    }
    net
}
