//! A counterexample of `petrel check` stepped through on the nets: the
//! markings after each of its steps, from the transitions each step fired
//! (`EVENT … → NET.t1, NET.t2`), the `activate`/`deactivate` actions
//! included. Pure.

use nets::model::{Action, PlaceRef};
use nets::Project;
use serde::Serialize;

/// One step of a counterexample, and the state after it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Moment {
    /// The check's words for the step (`(the start)` for the first).
    pub label: String,
    /// `NET.transition` fired by the step.
    pub fired: Vec<String>,
    /// Marked places after it: `NET.place`, global ones as `@name`.
    pub marked: Vec<String>,
    /// Active nets after it.
    pub active: Vec<String>,
}

/// The transitions a step's label says it fired (`… → A.t, B.u`), and the
/// one a fault stopped (`… ✗ A.t would put a second token in …`).
pub fn fired(label: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    if let Some((_, tail)) = label.rsplit_once(" → ") {
        out.extend(
            tail.split(", ")
                .map(|s| s.split_whitespace().next().unwrap_or("").to_owned()),
        );
    }
    for (_, tail) in label
        .match_indices("✗ ")
        .map(|(i, m)| (i, &label[i + m.len()..]))
    {
        out.push(tail.split_whitespace().next().unwrap_or("").to_owned());
    }
    out.retain(|s| s.contains('.'));
    out
}

/// The moments of a counterexample: the start, then one per step.
pub fn replay(project: &Project, steps: &[String]) -> Vec<Moment> {
    let mut marked = vec![false; project.place_count];
    let mut active: Vec<bool> = project.nets.iter().map(|n| n.active_at_start).collect();
    for (g, global) in project.globals.iter().enumerate() {
        marked[project.flat(0, PlaceRef::Global(g))] = global.initial;
    }
    let set_net = |marked: &mut Vec<bool>, m: usize, on: bool| {
        for (i, p) in project.nets[m].places.iter().enumerate() {
            marked[project.flat(m, PlaceRef::Local(i))] = on && p.initial;
        }
    };
    for (m, on) in active.iter().enumerate() {
        set_net(&mut marked, m, *on);
    }
    let moment = |label: String, fired: Vec<String>, marked: &[bool], active: &[bool]| {
        let mut names = Vec::new();
        for (g, global) in project.globals.iter().enumerate() {
            if marked[project.flat(0, PlaceRef::Global(g))] {
                names.push(format!("@{}", global.name));
            }
        }
        for (n, net) in project.nets.iter().enumerate() {
            for (i, p) in net.places.iter().enumerate() {
                if marked[project.flat(n, PlaceRef::Local(i))] {
                    names.push(format!("{}.{}", net.name, p.name));
                }
            }
        }
        Moment {
            label,
            fired,
            marked: names,
            active: project
                .nets
                .iter()
                .zip(active)
                .filter(|(_, on)| **on)
                .map(|(n, _)| n.name.clone())
                .collect(),
        }
    };
    let mut out = vec![moment("(the start)".into(), Vec::new(), &marked, &active)];
    for label in steps {
        let names = fired(label);
        for name in &names {
            let Some((net, transition)) = name.split_once('.') else {
                continue;
            };
            let Some(n) = project.nets.iter().position(|x| x.name == net) else {
                continue;
            };
            let Some(t) = project.nets[n]
                .transitions
                .iter()
                .find(|t| t.name == transition)
            else {
                continue;
            };
            for p in &t.inputs {
                marked[project.flat(n, *p)] = false;
            }
            for p in &t.outputs {
                marked[project.flat(n, *p)] = true;
            }
            for a in &t.actions {
                match a {
                    Action::Activate(m) if !active[*m] => {
                        active[*m] = true;
                        set_net(&mut marked, *m, true);
                    }
                    Action::Deactivate(m) if active[*m] => {
                        active[*m] = false;
                        set_net(&mut marked, *m, false);
                    }
                    _ => {}
                }
            }
        }
        out.push(moment(label.clone(), names, &marked, &active));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_counterexample_is_replayed_with_activations() {
        let project = nets::load(&[
            (
                "project.toml",
                "[[net]]\nfile = \"a.toml\"\nactive = true\n[[net]]\nfile = \"b.toml\"\n[globals]\ng = true\n[events]\nx = {}\ny = {}\n",
            ),
            (
                "a.toml",
                "name = \"A\"\nplaces = [\"idle\", \"on\"]\ninitial = [\"idle\"]\n[[transition]]\nname = \"go\"\nfrom = [\"idle\", \"@g\"]\nto = [\"on\"]\non = \"x\"\ndo = [\"activate B\"]\n",
            ),
            (
                "b.toml",
                "name = \"B\"\nplaces = [\"s\", \"t\"]\ninitial = [\"s\"]\n[[transition]]\nname = \"step\"\nfrom = [\"s\"]\nto = [\"t\"]\non = \"y\"\n",
            ),
        ])
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            fired("x [guards: yes] → A.go, B.step"),
            vec!["A.go", "B.step"]
        );
        assert_eq!(fired("x (nothing fired)"), Vec::<String>::new());
        assert_eq!(
            fired("y ✗ A.go would put a second token in A.on"),
            vec!["A.go"]
        );
        let m = replay(&project, &["x → A.go".into(), "y → B.step".into()]);
        assert_eq!(m.len(), 3);
        assert_eq!(m[0].marked, vec!["@g", "A.idle"]);
        assert_eq!(m[0].active, vec!["A"]);
        assert_eq!(m[1].fired, vec!["A.go"]);
        assert_eq!(m[1].marked, vec!["A.on", "B.s"]);
        assert_eq!(m[1].active, vec!["A", "B"]);
        assert_eq!(m[2].marked, vec!["A.on", "B.t"]);
        assert_eq!(m[2].label, "y → B.step");
    }
}
