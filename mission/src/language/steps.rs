//! One sequence of steps checked: the mission's, or a category's
//! procedure. Names resolved within the sequence, branches, `next`,
//! targets, limits and retries.

use std::collections::BTreeMap;

use toml::Spanned;

use super::check::{Checker, Known, Scope, RESERVED};
use super::model::{Exit, Said, Step, Target};
use super::syntax::{in_order, RawStep, Text};

/// A sequence checked, with what rules and phases read of it.
pub(super) struct Sequence<'r> {
    pub steps: Vec<Step>,
    /// Each step's index, by name.
    pub index: BTreeMap<&'r str, usize>,
    pub branch_of: Vec<Option<(usize, usize)>>,
    /// The first step not in a branch.
    pub first: Option<usize>,
    /// The steps as written, in order.
    pub raw: Vec<(&'r Text, &'r Spanned<RawStep>)>,
}

/// Checks the steps of `table`, in the order written; `phased`: the
/// mission's steps, which may say their phase (a procedure's may not);
/// `section`: the level's or procedure's key, where an empty one is said.
pub(super) fn sequence<'r>(
    c: &mut Checker,
    table: &'r BTreeMap<Text, Spanned<RawStep>>,
    known: &Known,
    phased: bool,
    section: Option<&Text>,
) -> Sequence<'r> {
    // Steps, in the order written.
    let raw_steps: Vec<(&Text, &Spanned<RawStep>)> = in_order(table);
    let index: BTreeMap<&str, usize> = raw_steps
        .iter()
        .enumerate()
        .map(|(i, (k, _))| (k.get_ref().as_str(), i))
        .collect();
    if raw_steps.is_empty() {
        let (at, what) = match section {
            Some(key) => (key.span(), format!("`{}` has no step", key.get_ref())),
            None => (
                0..0,
                "the mission has no step: `[steps]` is empty or missing".to_owned(),
            ),
        };
        c.at(at, format!("{what}: a sequence has at least one step"));
    }
    for (key, _) in &raw_steps {
        c.name(key, "step");
        if RESERVED.contains(&key.get_ref().as_str()) {
            c.at(
                key.span(),
                format!(
                    "`{}` cannot name a step: it is a word of the mission language ({})",
                    key.get_ref(),
                    RESERVED.join(", ")
                ),
            );
        }
    }

    // Branches first: which step belongs to which parallel step.
    let mut branch_of: Vec<Option<(usize, usize)>> = vec![None; raw_steps.len()];
    let mut branches: Vec<Vec<Vec<usize>>> = vec![Vec::new(); raw_steps.len()];
    for (p, (key, step)) in raw_steps.iter().enumerate() {
        let Some(list) = &step.get_ref().branches else {
            continue;
        };
        let s = step.get_ref();
        if s.actions.is_some()
            || s.until.is_some()
            || !s.exits.is_empty()
            || s.limit.is_some()
            || s.retries.is_some()
            || s.on_limit.is_some()
            || s.when.is_some()
        {
            c.at(key.span(), format!("parallel step `{}` has only `branches` and `then`: actions, exits and limits belong to the steps of its branches", key.get_ref()));
        }
        if list.get_ref().len() < 2 {
            c.at(list.span(), "a parallel step has at least two branches");
        }
        for (b, branch) in list.get_ref().iter().enumerate() {
            if branch.is_empty() {
                c.at(
                    list.span(),
                    format!("branch {} of `{}` has no step", b + 1, key.get_ref()),
                );
            }
            let mut steps = Vec::new();
            for name in branch {
                match c.step(&index, name) {
                    Some(i) if i == p => c.at(name.span(), format!("`{}` cannot be a branch of itself", name.get_ref())),
                    Some(i) if branch_of[i].is_some() || raw_steps[i].1.get_ref().branches.is_some() => c.at(
                        name.span(),
                        format!("step `{}` is already in a branch, or is parallel itself: a step is in one branch, branches do not nest", name.get_ref()),
                    ),
                    Some(i) => {
                        branch_of[i] = Some((p, b));
                        steps.push(i);
                    }
                    None => {}
                }
            }
            branches[p].push(steps);
        }
    }
    // `next` of each step: the following step of its sequence.
    let main: Vec<usize> = (0..raw_steps.len())
        .filter(|&i| branch_of[i].is_none())
        .collect();
    let mut next = vec![Target::Done; raw_steps.len()];
    for w in main.windows(2) {
        next[w[0]] = Target::Step(w[1]);
    }
    for (p, list) in branches.iter().enumerate() {
        for (b, branch) in list.iter().enumerate() {
            for (k, &i) in branch.iter().enumerate() {
                next[i] = branch
                    .get(k + 1)
                    .map_or(Target::Join(p, b), |&j| Target::Step(j));
            }
        }
    }

    let mut steps = Vec::new();
    for (i, (key, step)) in raw_steps.iter().enumerate() {
        let s = step.get_ref();
        let retries = match &s.retries {
            None => 0,
            Some(r) => match u32::try_from(*r.get_ref()) {
                Ok(n) if n <= 20 => n,
                _ => {
                    c.at(r.span(), "retries: a count from 0 to 20");
                    0
                }
            },
        };
        let scope = Scope {
            step: i,
            retries,
            branch_of: branch_of[i],
            next: next[i],
            index: &index,
            branch_of_all: &branch_of,
        };
        let mut exits = Vec::new();
        if let Some(on) = &s.until {
            let then = s.then.as_ref().map_or(next[i], |t| c.target(t, &scope));
            exits.push(Exit {
                on: Some(c.event(on, known)),
                phase: None,
                when: c.guard(&s.when),
                then,
                actions: Vec::new(),
            });
        } else if let Some(w) = &s.when {
            c.at(
                w.span(),
                "`when` guards the event of `until`: this step has no `until`",
            );
        }
        if s.until.is_none() && s.branches.is_none() {
            if let Some(t) = &s.then {
                c.at(
                    t.span(),
                    "`then` says where `until` leads: this step has no `until`",
                );
            }
        }
        for exit in &s.exits {
            let e = exit.get_ref();
            let then = e.then.as_ref().map_or(next[i], |t| c.target(t, &scope));
            let phase = e.phase.as_ref().map(|p| {
                if phased {
                    c.at(p.span(), "a step of the mission knows its phase: an exit's `phase` is for a procedure's or a level's steps");
                } else {
                    c.global(p, known);
                }
                Said { text: p.get_ref().clone(), span: p.span() }
            });
            match (&e.on, &phase, &e.when) {
                (None, None, _) => c.at(
                    exit.span(),
                    "an exit says its event (`on`), or the phase it is taken in (`phase`)",
                ),
                (None, Some(_), Some(w)) => c.at(
                    w.span(),
                    "an exit without an event is taken at once: it has no `when`",
                ),
                _ => {}
            }
            exits.push(Exit {
                phase,
                on: e.on.as_ref().map(|on| c.event(on, known)),
                when: c.guard(&e.when),
                then,
                actions: c.actions(&e.actions),
            });
        }
        let limit = s.limit.as_ref().and_then(|l| c.duration(l));
        let on_limit = match &s.on_limit {
            Some(t) if s.limit.is_none() && s.retries.is_none() => {
                c.at(
                    t.span(),
                    "`on_limit` says where the limit, or the last retry, leads: this step has neither `limit` nor `retries`",
                );
                Target::Abort
            }
            Some(t) => match c.target(t, &scope) {
                Target::Retry => {
                    c.at(
                        t.span(),
                        "`on_limit` is where the step goes once no retry is left: not `retry`",
                    );
                    Target::Abort
                }
                t => t,
            },
            None if branch_of[i].is_some() && s.limit.is_some() => {
                c.at(key.span(), format!("step `{}` of a branch has a limit: say where it leads within the branch (`on_limit`)", key.get_ref()));
                Target::Abort
            }
            None => Target::Abort,
        };
        if let Some(r) = &s.retries {
            if s.limit.is_none() && !exits.iter().any(|e| e.then == Target::Retry) {
                c.at(r.span(), "`retries` with nothing to retry: give the step a `limit` or an exit with `then = \"retry\"`");
            }
        }
        let parallel_then = match (&s.branches, &s.then) {
            (Some(_), Some(t)) => c.target(t, &scope),
            _ => next[i],
        };
        if s.branches.is_none() && exits.is_empty() && limit.is_none() {
            c.at(key.span(), format!("step `{}` has no way out: give it `until` (the event that ends it), `exits` or a `limit`", key.get_ref()));
        }
        let phase = s.phase.as_ref().map(|p| {
            if !phased {
                c.at(p.span(), "a step of a procedure or a level has no phase: phases are the mission's steps', a reaction reads them (`phases`)");
            } else if branch_of[i].is_some() {
                c.at(p.span(), "a step of a branch is in its parallel step's phase: give the phase to the parallel step");
            } else {
                c.global(p, known);
            }
            p.get_ref().clone()
        });
        if let (false, Some(r)) = (phased, &s.run) {
            c.at(
                r.span(),
                "levels do not nest: only a step of the mission runs a level",
            );
        } else if let (Some(_), Some(r)) = (&s.branches, &s.run) {
            c.at(
                r.span(),
                "a parallel step runs no level: give `run` to the steps of its branches",
            );
        }
        let retry_after = s.retry_after.as_ref().and_then(|d| {
            if s.retries.is_none() {
                c.at(
                    d.span(),
                    "`retry_after` without `retries`: say how many times the step is entered again",
                );
            }
            c.duration(d)
        });
        steps.push(Step {
            retry_after,
            run: None,
            phase,
            name: key.get_ref().clone(),
            span: key.span(),
            actions: c.actions(&s.actions),
            exits,
            limit,
            retries,
            on_limit,
            branches: branches[i].clone(),
            branch_of: branch_of[i],
            next: if s.branches.is_some() {
                parallel_then
            } else {
                next[i]
            },
        });
    }

    Sequence {
        steps,
        index,
        branch_of,
        first: main.first().copied(),
        raw: raw_steps,
    }
}
