//! Symmetry of a team: vehicles that can be swapped without changing what
//! the player does, and one representative per orbit of states.
//!
//! The group is computed from the compiled project, never assumed: two
//! vehicles are interchangeable when swapping them maps the project onto
//! itself — every template has an instance for both or neither, each
//! instance's transitions (events, guards, places, actions) read the same
//! with the two names exchanged, every team net and every `[[exclusive]]`
//! resource is unchanged by the exchange, and every event's waiting list
//! maps onto the exchanged event's, in order. A team net naming `@R2` (an
//! event, a command, an `activate`) or a guard comparing with `"R2"` breaks
//! R2's symmetry with the others. The swaps that pass generate the group:
//! every permutation of each class of interchangeable vehicles.
//!
//! The player is not symmetric everywhere the model is: it fires immediate
//! transitions first declared first, so when instances of two vehicles are
//! enabled at once in one step (two robots waiting for the bottleneck when
//! a third leaves it) the vehicle declared first wins. [`Symmetry::order_decides`]
//! finds such a step; the explorer then gives up the reduction and explores
//! the whole space (the report says why).
//!
//! A state is canonicalised by the permutation of the group that gives the
//! smallest key ([`Symmetry::canonical`]); the explorer records it on each
//! edge, so that a path of representatives maps back to a real path whose
//! every step names the right vehicle ([`Symmetry::rename`]).

use crate::model::{Action, NetId, Project, VehicleId};
use crate::player::{Effect, State};

/// The largest group explored by enumeration; a bigger one is cut into
/// smaller classes (a subgroup is still sound, only less reducing).
const MAX_GROUP: usize = 120;

/// One element of the group: a permutation of the vehicles and what it
/// does to nets and flat places.
#[derive(Debug, Clone)]
pub(super) struct Perm {
    /// `vehicles[v]`: where vehicle `v` goes.
    pub vehicles: Vec<VehicleId>,
    /// `nets[n]`: the net `n` becomes (an instance of the same template for
    /// the image vehicle; a team net stays).
    pub nets: Vec<NetId>,
    /// `places[p]`: the flat place `p` becomes.
    pub places: Vec<usize>,
}

/// The symmetry group of a project (the identity alone when nothing is
/// interchangeable).
#[derive(Debug, Clone)]
pub(super) struct Symmetry {
    /// Element 0 is the identity.
    pub perms: Vec<Perm>,
    /// `inverse[g]`: the index of `perms[g]`'s inverse.
    pub inverse: Vec<u8>,
    /// `compose[a][b]`: the index of `perms[a] ∘ perms[b]` (b first).
    compose: Vec<Vec<u8>>,
    /// The classes of interchangeable vehicles (two or more each).
    pub classes: Vec<Vec<VehicleId>>,
    /// Vehicle names, for renaming step texts.
    names: Vec<String>,
    /// Whether a vehicle is moved by some element.
    moved: Vec<bool>,
    words: usize,
    nets: usize,
    /// The keys list pending calls in the order of their bytes (see
    /// [`super::project_states`]).
    order_free: bool,
}

impl Symmetry {
    /// The group of `project` (see the module doc).
    pub fn of(project: &Project, order_free: bool) -> Symmetry {
        let n = project.vehicles.len();
        // Classes: vehicles joined by swaps that are automorphisms.
        let mut class: Vec<usize> = (0..n).collect();
        for v in 0..n {
            for w in v + 1..n {
                if class[w] != w {
                    continue;
                }
                if class[v] == v && swap_is_automorphism(project, v, w) {
                    class[w] = v;
                }
            }
        }
        let mut classes: Vec<Vec<VehicleId>> = Vec::new();
        for v in 0..n {
            if class[v] == v {
                let members: Vec<VehicleId> = (0..n).filter(|&w| class[w] == v).collect();
                if members.len() > 1 {
                    classes.push(members);
                }
            }
        }
        // Keep the group small enough to enumerate.
        let order = |cs: &[Vec<VehicleId>]| -> usize {
            cs.iter()
                .map(|c| (1..=c.len()).product::<usize>())
                .product()
        };
        while order(&classes) > MAX_GROUP {
            let Some(big) = (0..classes.len()).max_by_key(|&i| classes[i].len()) else {
                break;
            };
            classes[big].pop();
            if classes[big].len() < 2 {
                classes.remove(big);
            }
        }
        let mut vehicle_perms: Vec<Vec<VehicleId>> = vec![(0..n).collect()];
        for c in &classes {
            let mut next = Vec::new();
            for base in &vehicle_perms {
                for arrangement in permutations(c) {
                    let mut p = base.clone();
                    for (from, to) in c.iter().zip(&arrangement) {
                        p[*from] = *to;
                    }
                    next.push(p);
                }
            }
            vehicle_perms = next;
        }
        // The identity first.
        let identity: Vec<VehicleId> = (0..n).collect();
        vehicle_perms.sort_by_key(|p| *p != identity);
        let perms: Vec<Perm> = vehicle_perms.iter().map(|v| perm_of(project, v)).collect();
        let index_of = |v: &[VehicleId]| {
            vehicle_perms
                .iter()
                .position(|p| p == v)
                .unwrap_or_default() as u8
        };
        let inverse = vehicle_perms
            .iter()
            .map(|p| {
                let mut inv = vec![0; n];
                for (from, &to) in p.iter().enumerate() {
                    inv[to] = from;
                }
                index_of(&inv)
            })
            .collect();
        let compose = vehicle_perms
            .iter()
            .map(|a| {
                vehicle_perms
                    .iter()
                    .map(|b| {
                        let ab: Vec<VehicleId> = b.iter().map(|&x| a[x]).collect();
                        index_of(&ab)
                    })
                    .collect()
            })
            .collect();
        let mut moved = vec![false; n];
        for c in &classes {
            for &v in c {
                moved[v] = true;
            }
        }
        Symmetry {
            perms,
            inverse,
            compose,
            classes,
            names: project.vehicles.iter().map(|v| v.name.clone()).collect(),
            moved,
            words: project.place_count.div_ceil(64).max(1),
            nets: project.nets.len(),
            order_free,
        }
    }

    /// Whether the group has more than the identity.
    pub fn reduces(&self) -> bool {
        self.perms.len() > 1
    }

    /// `a ∘ b` (apply `b` first).
    pub fn compose(&self, a: u8, b: u8) -> u8 {
        self.compose[a as usize][b as usize]
    }

    /// Writes the smallest image of `key` under the group into `out` and
    /// returns the element that gives it (the first such).
    pub fn canonical(&self, key: &[u8], out: &mut Vec<u8>, scratch: &mut Vec<u8>) -> u8 {
        out.clear();
        out.extend_from_slice(key);
        let mut best = 0u8;
        for g in 1..self.perms.len() {
            self.apply(g, key, scratch);
            if scratch[..] < out[..] {
                std::mem::swap(out, scratch);
                best = g as u8;
            }
        }
        best
    }

    /// The key of the state `key` with its vehicles permuted by element `g`
    /// (the key layout is [`super::project_states`]'s).
    pub fn apply(&self, g: usize, key: &[u8], out: &mut Vec<u8>) {
        let perm = &self.perms[g];
        out.clear();
        let marking_bytes = self.words * 8;
        out.resize(marking_bytes, 0);
        for (p, &to) in perm.places.iter().enumerate() {
            if key[p / 8] & (1 << (p % 8)) != 0 {
                out[to / 8] |= 1 << (to % 8);
            }
        }
        let active = &key[marking_bytes..marking_bytes + self.nets];
        let start = out.len();
        out.resize(start + self.nets, 0);
        for (n, &a) in active.iter().enumerate() {
            out[start + perm.nets[n]] = a;
        }
        let mut at = marking_bytes + self.nets;
        let lockout = key[at];
        out.push(lockout); // the team's lockout, and whether vehicles follow
        at += 1;
        if lockout & 2 != 0 {
            // The vehicles locked out one by one: renamed, ascending again.
            let count = u32_at(key, at) as usize;
            out.extend_from_slice(&key[at..at + 4]);
            at += 4;
            let mut locked: smallvec::SmallVec<[u32; 8]> = (0..count)
                .map(|i| perm.vehicles[u32_at(key, at + 4 * i) as usize] as u32)
                .collect();
            locked.sort_unstable();
            for v in locked {
                out.extend_from_slice(&v.to_le_bytes());
            }
            at += 4 * count;
        }
        // Timers: the net renamed, then back in net and timer order with
        // the groups renumbered by first appearance (as the codec writes).
        let count = u32_at(key, at) as usize;
        at += 4;
        const TIMER: usize = 25;
        let mut timers: smallvec::SmallVec<[(u32, u32, usize); 16]> = (0..count)
            .map(|i| {
                let base = at + i * TIMER;
                let net = perm.nets[u32_at(key, base) as usize] as u32;
                (net, u32_at(key, base + 4), base)
            })
            .collect();
        timers.sort_unstable();
        out.extend_from_slice(&(count as u32).to_le_bytes());
        let mut groups: smallvec::SmallVec<[(u32, u32); 16]> = smallvec::SmallVec::new();
        for (net, timer, base) in &timers {
            out.extend_from_slice(&net.to_le_bytes());
            out.extend_from_slice(&timer.to_le_bytes());
            // Duration, rank and the catastrophic flag stay.
            out.extend_from_slice(&key[base + 8..base + 21]);
            let old = u32_at(key, base + 21);
            let group = match groups.iter().find(|(o, _)| *o == old) {
                Some((_, new)) => *new,
                None => {
                    let new = groups.len() as u32;
                    groups.push((old, new));
                    new
                }
            };
            out.extend_from_slice(&group.to_le_bytes());
        }
        at += count * TIMER;
        // Pending calls and commands: the net renamed, in the same order
        // (or that of their bytes, as the codec writes them).
        let count = u32_at(key, at) as usize;
        out.extend_from_slice(&key[at..at + 4]);
        at += 4;
        let mut entries: smallvec::SmallVec<[Vec<u8>; 16]> = smallvec::SmallVec::new();
        for _ in 0..count {
            let net = perm.nets[u32_at(key, at) as usize] as u32;
            let kind_len = match key[at + 5] {
                0 => 1 + 8,
                1 | 3 => 1 + 4,
                _ => 1 + 4 + u32_at(key, at + 6) as usize,
            };
            let mut e = net.to_le_bytes().to_vec();
            e.extend_from_slice(&key[at + 4..at + 5 + kind_len]);
            entries.push(e);
            at += 5 + kind_len;
        }
        if self.order_free {
            entries.sort_unstable();
        }
        for e in entries {
            out.extend_from_slice(&e);
        }
    }

    /// A step's text as it reads after element `g`: every vehicle name
    /// (`@R1`, `MOVE@R1`) replaced by its image.
    pub fn rename(&self, g: u8, text: &str) -> String {
        if g == 0 {
            return text.to_owned();
        }
        let perm = &self.perms[g as usize].vehicles;
        rename_words(text, |word| {
            self.names
                .iter()
                .position(|n| n == word)
                .map(|v| self.names[perm[v]].as_str())
        })
    }

    /// The vehicle `v` becomes under element `g`.
    pub fn vehicle(&self, g: u8, v: VehicleId) -> VehicleId {
        self.perms[g as usize].vehicles[v]
    }

    /// Whether the player's order of vehicles decided something in the step
    /// from `before` whose effects are `effects`: an immediate transition of
    /// one vehicle's instance fired while one of another vehicle's was
    /// enabled too, or an event found transitions of two vehicles' instances
    /// enabled (the one declared first goes first, which no swap of the
    /// vehicles preserves). The text names both.
    pub fn order_decides(
        &self,
        project: &Project,
        before: &State,
        effects: &[Effect],
    ) -> Option<String> {
        let mut marking = before.marking.clone();
        let mut active = before.active.clone();
        let marked = |m: &[u64], p: usize| m[p / 64] & (1 << (p % 64)) != 0;
        let set = |m: &mut [u64], p: usize, on: bool| {
            if on {
                m[p / 64] |= 1 << (p % 64);
            } else {
                m[p / 64] &= !(1 << (p % 64));
            }
        };
        for e in effects {
            let Effect::Fired {
                net, transition, ..
            } = e
            else {
                continue;
            };
            let (net, transition) = (*net, *transition);
            let t = &project.nets[net].transitions[transition];
            if let Some(v) = project.nets[net].vehicle {
                let enabled = |n: NetId, u: usize| {
                    active[n]
                        && project.nets[n].transitions[u]
                            .flat_inputs
                            .iter()
                            .all(|&p| marked(&marking, p))
                };
                let rivals: Vec<(NetId, usize)> = match &t.event {
                    None => project
                        .nets
                        .iter()
                        .enumerate()
                        .flat_map(|(n, x)| x.immediate.iter().map(move |&u| (n, u)))
                        .collect(),
                    // An event delivered to its own net only (a timer, a
                    // result, an answer) meets no other vehicle's net.
                    Some(event) if targeted(project, net, event) => Vec::new(),
                    Some(event) => project.triggers.get(event).cloned().unwrap_or_default(),
                };
                // Two transitions fired in either order end alike unless
                // they share a place (one disables the other, or the second
                // would put a double token) or one of them starts a timer
                // (timers of one step expire in start order), emits an event
                // (handled in order) or (de)activates a net; the order of
                // their calls and commands is not kept (`order_free`).
                let ordered = |x: &crate::model::Transition| {
                    !self.order_free
                        || x.actions.iter().any(|a| {
                            matches!(
                                a,
                                Action::Timer { .. }
                                    | Action::Ask { .. }
                                    | Action::Emit { .. }
                                    | Action::Activate(_)
                                    | Action::Deactivate(_)
                            )
                        })
                };
                let places = |x: &crate::model::Transition| -> Vec<usize> {
                    x.flat_inputs
                        .iter()
                        .chain(&x.flat_outputs)
                        .copied()
                        .collect()
                };
                let mine = places(t);
                for (n, u) in rivals {
                    let Some(w) = project.nets[n].vehicle else {
                        continue;
                    };
                    let rival = &project.nets[n].transitions[u];
                    let interacts = ordered(t)
                        || ordered(rival)
                        || places(rival).iter().any(|p| mine.contains(p));
                    if w != v && (self.moved[v] || self.moved[w]) && interacts && enabled(n, u) {
                        return Some(format!(
                            "{}.{} and {}.{} were enabled together and the vehicle declared first went first",
                            project.nets[net].name,
                            t.name,
                            project.nets[n].name,
                            project.nets[n].transitions[u].name
                        ));
                    }
                }
            }
            for &p in &t.flat_inputs {
                set(&mut marking, p, false);
            }
            for &p in &t.flat_outputs {
                set(&mut marking, p, true);
            }
            for a in &t.actions {
                match a {
                    Action::Activate(m) | Action::Deactivate(m) => {
                        let on = matches!(a, Action::Activate(_));
                        active[*m] = on;
                        let offset = project.place_offsets[*m];
                        for (i, place) in project.nets[*m].places.iter().enumerate() {
                            set(&mut marking, offset + i, on && place.initial);
                        }
                    }
                    _ => {}
                }
            }
        }
        None
    }
}

fn u32_at(key: &[u8], at: usize) -> u32 {
    let mut b = [0; 4];
    b.copy_from_slice(&key[at..at + 4]);
    u32::from_le_bytes(b)
}

/// Every ordering of `items`.
fn permutations(items: &[usize]) -> Vec<Vec<usize>> {
    if items.len() <= 1 {
        return vec![items.to_vec()];
    }
    let mut out = Vec::new();
    for i in 0..items.len() {
        let mut rest = items.to_vec();
        let first = rest.remove(i);
        for mut tail in permutations(&rest) {
            tail.insert(0, first);
            out.push(tail);
        }
    }
    out
}

/// The net an instance of `net`'s template becomes for vehicle `to` (`net`
/// itself for a team net), if the template has one.
fn instance_for(project: &Project, net: NetId, to: VehicleId) -> Option<NetId> {
    let n = &project.nets[net];
    match n.vehicle {
        None => Some(net),
        Some(_) => project
            .nets
            .iter()
            .position(|m| m.file == n.file && m.vehicle == Some(to)),
    }
}

/// What a permutation of the vehicles does to nets and places (every
/// permutation built here maps each instance to one that exists).
fn perm_of(project: &Project, vehicles: &[VehicleId]) -> Perm {
    let nets: Vec<NetId> = (0..project.nets.len())
        .map(|n| match project.nets[n].vehicle {
            Some(v) => instance_for(project, n, vehicles[v]).unwrap_or(n),
            None => n,
        })
        .collect();
    let mut places: Vec<usize> = (0..project.place_count).collect();
    for (n, &m) in nets.iter().enumerate() {
        let (from, to) = (project.place_offsets[n], project.place_offsets[m]);
        for i in 0..project.nets[n].places.len() {
            places[from + i] = to + i;
        }
    }
    Perm {
        vehicles: vehicles.to_vec(),
        nets,
        places,
    }
}

/// `text` with each identifier word `renamed` where it says so (a word is
/// a run of letters, digits and `_`).
fn rename_words<'a>(text: &str, renamed: impl Fn(&str) -> Option<&'a str>) -> String {
    let mut out = String::with_capacity(text.len());
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| {
        match renamed(word) {
            Some(r) => out.push_str(r),
            None => out.push_str(word),
        }
        word.clear();
    };
    for c in text.chars() {
        if c.is_alphanumeric() || c == '_' {
            word.push(c);
        } else {
            flush(&mut word, &mut out);
            out.push(c);
        }
    }
    flush(&mut word, &mut out);
    out
}

/// Whether exchanging vehicles `v` and `w` maps the project onto itself
/// (see the module doc).
fn swap_is_automorphism(project: &Project, v: VehicleId, w: VehicleId) -> bool {
    let names: Vec<&str> = project.vehicles.iter().map(|x| x.name.as_str()).collect();
    let swap = |text: &str| {
        rename_words(text, |word| {
            if word == names[v] {
                Some(names[w])
            } else if word == names[w] {
                Some(names[v])
            } else {
                None
            }
        })
    };
    let mut vehicles: Vec<VehicleId> = (0..names.len()).collect();
    vehicles.swap(v, w);
    // Every instance of v's or w's has its counterpart.
    for (n, net) in project.nets.iter().enumerate() {
        if let Some(u) = net.vehicle {
            if instance_for(project, n, vehicles[u]).is_none() {
                return false;
            }
        }
    }
    let perm = perm_of(project, &vehicles);
    let flat = |places: &[usize]| -> Vec<usize> {
        let mut out: Vec<usize> = places.iter().map(|&p| perm.places[p]).collect();
        out.sort_unstable();
        out
    };
    let sorted = |places: &[usize]| -> Vec<usize> {
        let mut out = places.to_vec();
        out.sort_unstable();
        out
    };
    let action = |a: &Action, mapped: bool| -> String {
        let net = |m: NetId| if mapped { perm.nets[m] } else { m };
        let text = match a {
            Action::Activate(m) => format!("activate {}", net(*m)),
            Action::Deactivate(m) => format!("deactivate {}", net(*m)),
            Action::Command {
                verb,
                args,
                vehicle,
            } => format!(
                "command {verb} {:?} {args:?}",
                vehicle.map(|x| if mapped { vehicles[x] } else { x })
            ),
            other => format!("{other:?}"),
        };
        if mapped {
            swap(&text)
        } else {
            text
        }
    };
    for (n, net) in project.nets.iter().enumerate() {
        let m = perm.nets[n];
        let image = &project.nets[m];
        if net.places.len() != image.places.len()
            || net.transitions.len() != image.transitions.len()
            || net.active_at_start != image.active_at_start
            || net.timers != image.timers
            || net.asks != image.asks
            || net.immediate != image.immediate
            || format!("{:?}", net.places) != format!("{:?}", image.places)
        {
            return false;
        }
        for (t, u) in net.transitions.iter().zip(&image.transitions) {
            let same = t.name == u.name
                && t.event.as_deref().map(swap) == u.event
                && t.guard.as_ref().map(|g| swap(&g.text))
                    == u.guard.as_ref().map(|g| g.text.clone())
                && flat(&t.flat_inputs) == sorted(&u.flat_inputs)
                && flat(&t.flat_outputs) == sorted(&u.flat_outputs)
                && t.choice == u.choice
                && t.actions.len() == u.actions.len()
                && t.actions
                    .iter()
                    .zip(&u.actions)
                    .all(|(a, b)| action(a, true) == action(b, false));
            if !same {
                return false;
            }
        }
    }
    // Each event's waiting transitions map onto the exchanged event's, in
    // the order the player tries them.
    for (event, waiting) in &project.triggers {
        let mapped: Vec<(NetId, usize)> = waiting.iter().map(|&(n, t)| (perm.nets[n], t)).collect();
        let swapped = swap(event);
        let Some(image) = project.triggers.get(&swapped) else {
            return false;
        };
        // An event delivered to one net only (its own timer, a result, an
        // answer) meets one transition list entry's net at a time: the order
        // of the list does not matter.
        let targeted = waiting.iter().all(|&(n, _)| targeted(project, n, event));
        let same = if targeted {
            let (mut a, mut b) = (mapped.clone(), image.clone());
            a.sort_unstable();
            b.sort_unstable();
            a == b
        } else {
            *image == mapped
        };
        if !same || project.declared_category(event) != project.declared_category(&swapped) {
            return false;
        }
    }
    // Each shared resource is the same set of holders.
    for r in &project.exclusive {
        let mut held: Vec<(VehicleId, Vec<usize>)> = r
            .held
            .iter()
            .map(|(x, places)| (vehicles[*x], flat(places)))
            .collect();
        held.sort();
        let mut original: Vec<(VehicleId, Vec<usize>)> = r
            .held
            .iter()
            .map(|(x, places)| (*x, sorted(places)))
            .collect();
        original.sort();
        if held != original {
            return false;
        }
    }
    true
}

/// Whether `event`, awaited by net `net`, is delivered to that net only:
/// its own timer, or a result or an answer the player hands to the net
/// that called, commanded or asked — and no net emits it.
fn targeted(project: &Project, net: NetId, event: &str) -> bool {
    !emitted(project, event)
        && (crate::outside::own_timer(project, net, event)
            || matches!(
                crate::outside::player_own(project, event),
                Some(
                    crate::outside::Refusal::CommandResult
                        | crate::outside::Refusal::CallResult
                        | crate::outside::Refusal::Answer
                )
            ))
}

/// Whether a net emits `event`.
fn emitted(project: &Project, event: &str) -> bool {
    project
        .nets
        .iter()
        .flat_map(|n| &n.transitions)
        .flat_map(|t| &t.actions)
        .any(|a| matches!(a, Action::Emit { event: e, .. } if e == event))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_are_renamed_whole() {
        let text = "at_gate@R1 → MOVE@R1.arrive, R10.x [reason: \"R1\"]";
        let out = rename_words(text, |w| (w == "R1").then_some("R2"));
        assert_eq!(out, "at_gate@R2 → MOVE@R2.arrive, R10.x [reason: \"R2\"]");
    }

    #[test]
    fn permutations_are_all_orderings() {
        let mut all = permutations(&[1, 2, 3]);
        all.sort();
        assert_eq!(all.len(), 6);
        all.dedup();
        assert_eq!(all.len(), 6);
    }
}
