//! Choices between siblings: transitions that wait for the same event and
//! share an input place. One occurrence of the event can fire only one of
//! them; a net says which with `priority = N` (higher first) or `else =
//! true` (only when no sibling takes the event). This module orders the
//! transitions an event triggers accordingly and finds the declarations
//! that decide nothing.

use crate::model::{Choice, Net, NetId, Project, TransitionId};

/// The siblings of a transition, in declaration order.
pub fn siblings(project: &Project, net: NetId, t: TransitionId) -> Vec<(NetId, TransitionId)> {
    let tr = &project.nets[net].transitions[t];
    let Some(event) = &tr.event else {
        return Vec::new();
    };
    project
        .triggers
        .get(event)
        .into_iter()
        .flatten()
        .copied()
        .filter(|&(m, u)| (m, u) != (net, t) && tr.sibling_of(&project.nets[m].transitions[u]))
        .collect()
}

/// Orders the transitions one event triggers (given in declaration order)
/// as the player tries them: each time, the first declared whose siblings
/// of higher rank, and of equal rank declared before it, have all been
/// placed. Siblings therefore come highest
/// rank first, ties in declaration order, and without declarations the
/// order is the declaration order.
pub fn order(nets: &[Net], waiting: &mut Vec<(NetId, TransitionId)>) {
    let get = |&(n, t): &(NetId, TransitionId)| &nets[n].transitions[t];
    if waiting
        .iter()
        .all(|x| get(x).choice.rank() == Choice::Ordinary.rank())
    {
        return;
    }
    // Must come after: `before[j]` lists the `i` placed before `j`.
    let len = waiting.len();
    let mut before: Vec<Vec<usize>> = vec![Vec::new(); len];
    for i in 0..len {
        for j in i + 1..len {
            let (a, b) = (get(&waiting[i]), get(&waiting[j]));
            if a.sibling_of(b) {
                if b.choice.rank() > a.choice.rank() {
                    before[i].push(j);
                } else {
                    before[j].push(i);
                }
            }
        }
    }
    let mut placed = vec![false; len];
    let mut out = Vec::with_capacity(len);
    while out.len() < len {
        // Ranks are a strict order between siblings: one is always free.
        let Some(next) = (0..len).find(|&j| !placed[j] && before[j].iter().all(|&i| placed[i]))
        else {
            break;
        };
        placed[next] = true;
        out.push(waiting[next]);
    }
    if out.len() == len {
        *waiting = out;
    }
}

/// Declarations that decide nothing, with what is wrong: an `else` or a
/// `priority` on a transition without siblings, two `else` siblings, a
/// priority all of whose siblings have the same rank.
pub fn problems(project: &Project) -> Vec<(NetId, TransitionId, String)> {
    let mut out = Vec::new();
    let name = |n: NetId, t: TransitionId| {
        format!(
            "{}.{}",
            project.nets[n].name, project.nets[n].transitions[t].name
        )
    };
    for (n, net) in project.nets.iter().enumerate() {
        for (t, tr) in net.transitions.iter().enumerate() {
            let (Some(event), Choice::Priority(_) | Choice::Else) = (&tr.event, tr.choice) else {
                continue;
            };
            let siblings = siblings(project, n, t);
            if siblings.is_empty() {
                let (what, why) = match tr.choice {
                    Choice::Else => ("`else`", "there is no choice to fall back from"),
                    _ => ("a priority", "there is no conflict to decide"),
                };
                out.push((
                    n,
                    t,
                    format!(
                        "{what} on transition `{}`, but no other transition waiting for `{event}` shares an input place with it: {why}",
                        tr.name
                    ),
                ));
                continue;
            }
            match tr.choice {
                Choice::Else => {
                    // Reported on the later of the two.
                    if let Some(&(m, u)) = siblings.iter().find(|&&(m, u)| {
                        (m, u) < (n, t) && project.nets[m].transitions[u].choice == Choice::Else
                    }) {
                        let other = &project.nets[m].transitions[u];
                        let place = tr
                            .flat_inputs
                            .iter()
                            .find(|p| other.flat_inputs.contains(p))
                            .map(|&p| crate::player::flat_place_name(project, p))
                            .unwrap_or_default();
                        out.push((
                            n,
                            t,
                            format!(
                                "`{}` and `{}` are both `else` for `{event}` on place {place}: one transition at most falls back when no other takes the event (give the other a guard or a priority)",
                                name(m, u),
                                name(n, t)
                            ),
                        ));
                    }
                }
                Choice::Priority(p) => {
                    if siblings.iter().all(|&(m, u)| {
                        project.nets[m].transitions[u].choice.rank() == tr.choice.rank()
                    }) {
                        let list: Vec<String> = siblings
                            .iter()
                            .map(|&(m, u)| format!("`{}`", name(m, u)))
                            .collect();
                        out.push((
                            n,
                            t,
                            format!(
                                "`priority = {p}` on transition `{}` decides nothing: its siblings on `{event}` ({}) have the same priority",
                                tr.name,
                                list.join(", ")
                            ),
                        ));
                    }
                }
                Choice::Ordinary => {}
            }
        }
    }
    out
}
