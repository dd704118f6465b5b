//! A new version of a project taking over from a running one, its state
//! kept: the first half of changing the supervision in flight (issue 38).
//!
//! [`map`] carries a running player's [`State`] onto the new version by
//! name: marked places by `NET.place` (a global by its name), active nets
//! by name, running timers by `NET.timer`, pending calls, commands and
//! questions by net, program, function and question name, the vehicles
//! locked out by vehicle name; the new version's `[reload]` renames places
//! and timers. What has no counterpart is a [`Refusal`] that names it:
//! nothing is dropped silently. A net new in this version starts as its
//! `active` says, with its initial marking.
//!
//! [`swap`] maps, then explores the new version from the mapped state with
//! the project check's own explorer ([`crate::verify::project::check_from`]):
//! no double token, no dead marking, no livelock reachable from where the
//! vehicle is, or the swap is refused with the check's counterexample. It
//! returns the player the new version runs with; the old one is untouched
//! either way, so a refusal leaves supervision as it was.
//!
//! During the catastrophic lockout (the team's or one vehicle's) a
//! version takes over only if it says it keeps the lockout's nets
//! unchanged (`[reload] lockout = "kept"`) and does: each net with a
//! transition on a catastrophic event the same, place for place and
//! transition for transition, and no other such net.
//!
//! Pure, like the rest of the crate: the caller loads the new version,
//! runs this beside the player (the exploration may take seconds), and
//! swaps at a step boundary.

use std::collections::BTreeMap;
use std::sync::Arc;

use crate::model::{NetId, PlaceRef, Project};
use crate::player::{PendingKind, Player, State};
use crate::verify::project::{check_from, Options};

/// Why a new version cannot take over from the running one.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    #[error(
        "place {place} is marked and the new version has no such place (map it in [reload] places)"
    )]
    PlaceGone { place: String },
    #[error("net {net} is active and the new version has no such net")]
    NetGone { net: String },
    #[error("timer {timer} is running and the new version has no such timer (map it in [reload] timers)")]
    TimerGone { timer: String },
    #[error("{what} of net {net} is pending and the new version has no {missing}")]
    PendingGone {
        net: String,
        what: String,
        missing: String,
    },
    #[error("vehicle {vehicle} is locked out and the new version has no such vehicle")]
    VehicleGone { vehicle: String },
    #[error("the catastrophic lockout is on ({who}): a new version takes over during it only if it keeps the lockout's nets unchanged and says so ([reload] lockout = \"kept\")")]
    Lockout { who: String },
    #[error("the new version says it keeps the catastrophic lockout's nets ([reload] lockout = \"kept\") but net {net} differs: {how}")]
    LockoutNetChanged { net: String, how: String },
    #[error("[reload] {kind} `{name}`: the running version has no such {kind}")]
    RenameUnknown { kind: &'static str, name: String },
    #[error("{queued} events are queued: a version swaps only between two inputs")]
    Busy { queued: usize },
    #[error("the mapped state does not fit the new version: {0}")]
    Restore(String),
    #[error("from the state the vehicle is in, the new version {0}")]
    Unsafe(String),
}

/// The flat index of the place `name` of `project`: a global place by its
/// name, a net's as `NET.place`.
pub fn place_named(project: &Project, name: &str) -> Option<usize> {
    if let Some(g) = project.globals.iter().position(|g| g.name == name) {
        return Some(g);
    }
    let (net, place) = name.split_once('.')?;
    let n = project.net(net)?;
    let p = project.nets[n]
        .places
        .iter()
        .position(|p| p.name == place)?;
    Some(project.place_offsets[n] + p)
}

/// The timer `name` (`NET.timer`) of `project`: its net and index.
pub fn timer_named(project: &Project, name: &str) -> Option<(NetId, usize)> {
    let (net, timer) = name.split_once('.')?;
    let n = project.net(net)?;
    let t = project.nets[n].timers.iter().position(|t| t == timer)?;
    Some((n, t))
}

/// The name of flat place `flat`, as [`place_named`] reads it.
pub fn place_name(project: &Project, flat: usize) -> String {
    if let Some(g) = project.globals.get(flat) {
        return g.name.clone();
    }
    let n = project
        .place_offsets
        .iter()
        .rposition(|&offset| offset <= flat)
        .unwrap_or(0);
    let place = project.nets[n]
        .places
        .get(flat - project.place_offsets[n])
        .map_or("?", |p| p.name.as_str());
    format!("{}.{place}", project.nets[n].name)
}

/// The nets the catastrophic lockout runs: those with a transition on an
/// event the project declares catastrophic.
fn lockout_nets(project: &Project) -> Vec<NetId> {
    (0..project.nets.len())
        .filter(|&n| {
            project.nets[n].transitions.iter().any(|t| {
                t.event.as_deref().is_some_and(|e| {
                    project.declared_category(crate::model::split_vehicle(e).0)
                        == Some(crate::Category::Catastrophic)
                })
            })
        })
        .collect()
}

/// A net as its author wrote it, whatever the project around it: its
/// places, timers, and each transition's arcs (by place name), event,
/// guard, actions as written and rank.
fn net_text(project: &Project, n: NetId) -> String {
    let net = &project.nets[n];
    let place = |r: &PlaceRef| match *r {
        PlaceRef::Local(i) => net.places.get(i).map_or("?".into(), |p| p.name.clone()),
        PlaceRef::Global(g) => project
            .globals
            .get(g)
            .map_or("@?".into(), |p| format!("@{}", p.name)),
    };
    let mut text = format!(
        "places {:?} initial {:?} timers {:?}\n",
        net.places.iter().map(|p| &p.name).collect::<Vec<_>>(),
        net.places
            .iter()
            .filter(|p| p.initial)
            .map(|p| &p.name)
            .collect::<Vec<_>>(),
        net.timers
    );
    for t in &net.transitions {
        text.push_str(&format!(
            "{} {:?} -> {:?} on {:?} when {:?} do {:?} {:?}\n",
            t.name,
            t.inputs.iter().map(place).collect::<Vec<_>>(),
            t.outputs.iter().map(place).collect::<Vec<_>>(),
            t.event,
            t.guard.as_ref().map(|g| &g.text),
            t.action_source,
            t.choice,
        ));
    }
    text
}

/// Why `new`, which says it keeps the lockout's nets, does not: each
/// lockout net of `old` the same in `new`, and no other.
fn lockout_changes(old: &Project, new: &Project) -> Vec<Refusal> {
    let mut why = Vec::new();
    let names = |p: &Project| -> Vec<String> {
        lockout_nets(p)
            .into_iter()
            .map(|n| p.nets[n].name.clone())
            .collect()
    };
    let (before, after) = (names(old), names(new));
    for name in &after {
        if !before.contains(name) {
            why.push(Refusal::LockoutNetChanged {
                net: name.clone(),
                how: "it reacts to a catastrophic event in this version only".into(),
            });
        }
    }
    for name in &before {
        let (Some(o), Some(n)) = (old.net(name), new.net(name)) else {
            why.push(Refusal::LockoutNetChanged {
                net: name.clone(),
                how: "the new version has no such net".into(),
            });
            continue;
        };
        if net_text(old, o) != net_text(new, n) {
            why.push(Refusal::LockoutNetChanged {
                net: name.clone(),
                how: "its places, timers or transitions are not the running version's".into(),
            });
        }
    }
    why
}

/// The running version's `state` carried onto `new`, or every reason it
/// cannot be.
pub fn map(old: &Project, state: &State, new: &Project) -> Result<State, Vec<Refusal>> {
    let mut refused = Vec::new();
    let queued = state.queued();
    if queued > 0 {
        refused.push(Refusal::Busy { queued });
    }
    if state.lockout || !state.locked.is_empty() {
        let who = if state.lockout {
            "the whole team".to_owned()
        } else {
            state
                .locked
                .iter()
                .filter_map(|&v| old.vehicles.get(v).map(|v| v.name.clone()))
                .collect::<Vec<_>>()
                .join(", ")
        };
        if new.reload.lockout_kept {
            refused.extend(lockout_changes(old, new));
        } else {
            refused.push(Refusal::Lockout { who });
        }
    }
    let places = new
        .reload
        .places
        .keys()
        .map(|n| ("place", n, place_named(old, n).is_some()));
    let timers = new
        .reload
        .timers
        .keys()
        .map(|n| ("timer", n, timer_named(old, n).is_some()));
    for (kind, name, _) in places.chain(timers).filter(|(_, _, known)| !known) {
        refused.push(Refusal::RenameUnknown {
            kind,
            name: name.clone(),
        });
    }
    let words = new.place_count.div_ceil(64).max(1);
    let mut out = State {
        now: state.now,
        marking: vec![0; words],
        active: vec![false; new.nets.len()],
        timers: Vec::new(),
        queue: Default::default(),
        lockout: state.lockout,
        locked: Vec::new(),
        pending: BTreeMap::new(),
        next_id: state.next_id,
        next_timer_seq: state.next_timer_seq,
    };
    // Nets by name: the running ones must all be there.
    let net_of: Vec<Option<NetId>> = old.nets.iter().map(|n| new.net(&n.name)).collect();
    for (n, net) in old.nets.iter().enumerate() {
        match net_of[n] {
            Some(m) => out.active[m] = state.active[n],
            None if state.active[n] => refused.push(Refusal::NetGone {
                net: net.name.clone(),
            }),
            None => {}
        }
    }
    // A net new in this version starts as it says, with its initial
    // marking.
    for (m, net) in new.nets.iter().enumerate() {
        if old.net(&net.name).is_none() && net.active_at_start {
            out.active[m] = true;
            for (i, p) in net.places.iter().enumerate() {
                if p.initial {
                    out.set(new.place_offsets[m] + i, true);
                }
            }
        }
    }
    for flat in (0..old.place_count).filter(|&p| state.marked(p)) {
        let name = place_name(old, flat);
        let renamed = new.reload.places.get(&name).unwrap_or(&name);
        match place_named(new, renamed) {
            Some(p) => out.set(p, true),
            None => refused.push(Refusal::PlaceGone { place: name }),
        }
    }
    for timer in &state.timers {
        let net = &old.nets[timer.net];
        let name = format!("{}.{}", net.name, net.timers[timer.timer]);
        let renamed = new.reload.timers.get(&name).unwrap_or(&name);
        match timer_named(new, renamed) {
            Some((n, t)) => {
                let mut carried = timer.clone();
                carried.net = n;
                carried.timer = t;
                out.timers.push(carried);
            }
            None => refused.push(Refusal::TimerGone { timer: name }),
        }
    }
    // Ordered by deadline then start order, as the player keeps them.
    out.timers.sort_by_key(|t| (t.deadline, t.seq));
    for (&id, pending) in &state.pending {
        let net = &old.nets[pending.net];
        let gone = |what: String, missing: String| Refusal::PendingGone {
            net: net.name.clone(),
            what,
            missing,
        };
        let Some(m) = net_of[pending.net] else {
            refused.push(gone(
                describe(old, &pending.kind),
                format!("net {}", net.name),
            ));
            continue;
        };
        let kind = match &pending.kind {
            PendingKind::Call { program, function } => {
                let program = &old.programs[*program];
                let function = &program.functions[*function].name;
                let found = new
                    .programs
                    .iter()
                    .position(|p| p.name == program.name)
                    .and_then(|p| {
                        let f = new.programs[p]
                            .functions
                            .iter()
                            .position(|f| f.name == *function)?;
                        Some((p, f))
                    });
                match found {
                    Some((program, function)) => PendingKind::Call { program, function },
                    None => {
                        refused.push(gone(
                            describe(old, &pending.kind),
                            format!("function {}.{function}", program.name),
                        ));
                        continue;
                    }
                }
            }
            PendingKind::Command { verb } => PendingKind::Command { verb: verb.clone() },
            PendingKind::Question { ask } => {
                let name = &net.asks[*ask].name;
                match new.nets[m].asks.iter().position(|a| a.name == *name) {
                    Some(ask) => PendingKind::Question { ask },
                    None => {
                        refused.push(gone(
                            describe(old, &pending.kind),
                            format!("question {name} in net {}", new.nets[m].name),
                        ));
                        continue;
                    }
                }
            }
        };
        let mut carried = pending.clone();
        carried.net = m;
        carried.kind = kind;
        out.pending.insert(id, carried);
    }
    for &v in &state.locked {
        let name = old.vehicles.get(v).map_or("?", |v| v.name.as_str());
        match new.vehicles.iter().position(|w| w.name == name) {
            Some(w) => out.locked.push(w),
            None => refused.push(Refusal::VehicleGone {
                vehicle: name.to_owned(),
            }),
        }
    }
    out.locked.sort_unstable();
    if refused.is_empty() {
        Ok(out)
    } else {
        Err(refused)
    }
}

/// A pending call, command or question, for people.
fn describe(project: &Project, kind: &PendingKind) -> String {
    match kind {
        PendingKind::Call { program, function } => {
            let program = &project.programs[*program];
            format!(
                "call {}.{}",
                program.name, program.functions[*function].name
            )
        }
        PendingKind::Command { verb } => format!("command {verb}"),
        PendingKind::Question { .. } => "a question".to_owned(),
    }
}

/// The player `new` runs with, taking over from the running version
/// `old` in `state`: mapped ([`map`]), then proved from there
/// ([`check_from`] with `options`; its state limit applies, and an
/// exploration it stops is a refusal).
pub fn swap(
    old: &Project,
    state: &State,
    new: &Arc<Project>,
    options: &Options,
) -> Result<Player, Vec<Refusal>> {
    let mapped = map(old, state, new)?;
    let report =
        check_from(new, &mapped, options).map_err(|e| vec![Refusal::Restore(e.to_string())])?;
    let mut why = Vec::new();
    if !report.safe {
        let example = report.unsafe_example.clone().unwrap_or_default();
        why.push(format!(
            "can put a second token in a place: {}",
            example.join(" → ")
        ));
    }
    if report.dead_markings > 0 {
        let example = report.deadlock_example.clone().unwrap_or_default();
        why.push(format!(
            "can reach a dead marking ({} of them): {}",
            report.dead_markings,
            if example.is_empty() {
                "the mapped state itself".to_owned()
            } else {
                example.join(" → ")
            }
        ));
    }
    for livelock in &report.livelocks {
        why.push(format!("can loop for ever: {}", livelock.join(" → ")));
    }
    for e in &report.exclusion {
        why.push(format!("breaks a declared exclusion: {e:?}"));
    }
    if !report.complete {
        why.push(format!(
            "could not be explored whole ({} states, the limit)",
            report.states
        ));
    }
    if !why.is_empty() {
        return Err(why.into_iter().map(Refusal::Unsafe).collect());
    }
    Player::restore(new.clone(), mapped).map_err(|e| vec![Refusal::Restore(e.to_string())])
}

#[cfg(test)]
#[path = "version_tests.rs"]
mod tests;
